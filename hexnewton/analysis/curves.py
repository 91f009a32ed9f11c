"""Learning curves from training runs' TensorBoard events (:func:`read_curve`), one figure and CSV of several runs
(:func:`plot_curves`), Fig. 5a over seeds (:func:`plot_fig5a`); the command line is ``python -m hexnewton.apps.curves``.

A run given as ``DIR1,DIR2,...`` is one curve: the pieces of a run continued with ``train.py --resume``,
joined in order. The x axis is the iteration, the env-steps (iterations x envs x steps per env, from each
piece's ``config.json``; a skrl baseline run from ``hexnewton.learning.baselines`` logs against env-steps directly) or
the wall time (each piece's own time from its first to its last logged
iteration, so the pause between pieces does not count).

Fig. 5a (:func:`plot_fig5a`): the mean episode return, the training success rate and the terrain curriculum's mean
level (``Train/mean_reward``, ``Episode/success_rate``: the last 1024 finished episodes, ``Curriculum/mean_level``:
training success is measured on the level each robot has reached) of each method's runs (seeds) against env-steps and against
wall time, as the mean over seeds with their range (min to max) shaded, each method up to the shortest of its runs;
a CSV beside the figure holds the bands and a JSON the final values.
"""

from __future__ import annotations

import csv
import json
import math
import os

from hexnewton.analysis.figures import save_png

TAGS = ("Episode/success_rate", "Episode/distance_m", "Train/mean_reward", "Episode/fell_rate",
        "Episode/off_course_rate", "Curriculum/mean_level", "Curriculum/top_level_success_rate")  # fmt: skip
X_AXES = {"iteration": "iteration", "env_steps": "env-steps", "wall_time": "wall time [min]"}


def read_scalars(run_dir: str) -> dict[str, list[tuple[int, float, float]]]:
    """{tag: [(iteration, value, wall time [s]), ...]} from one run directory's TensorBoard events."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    if not os.path.isdir(run_dir):
        raise ValueError(f"not a run directory: {run_dir}")
    acc = EventAccumulator(run_dir, size_guidance={"scalars": 0})
    acc.Reload()
    tags = set(acc.Tags().get("scalars", []))
    if not tags:
        raise ValueError(f"no TensorBoard scalars under {run_dir}")
    return {t: [(e.step, e.value, e.wall_time) for e in acc.Scalars(t)] for t in TAGS if t in tags}


def steps_per_iteration(run_dir: str) -> int | None:
    """Env-steps collected per PPO iteration (num_envs x num_steps_per_env) from the run's config.json;
    None for a skrl baseline run (``hexnewton.learning.baselines``), whose TensorBoard step already counts env-steps."""
    path = os.path.join(run_dir, "config.json")
    try:
        with open(path) as f:
            cfg = json.load(f)
        if "algo" in cfg["hexnewton"]:
            return None
        return int(cfg["hexnewton"]["config"]["sim"]["num_envs"]) * int(cfg["train"]["num_steps_per_env"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"cannot read env-steps per iteration from {path}: {exc}")


def read_curve(spec: str, x: str = "iteration") -> dict[str, list[tuple[float, float]]]:
    """{tag: [(x, value), ...]} for ``spec``: one run directory, or resumed pieces joined by commas."""
    out: dict[str, list[tuple[float, float]]] = {}
    steps_done, time_done, last_it = 0.0, 0.0, -1
    for piece in spec.split(","):
        scalars = read_scalars(piece)
        per_it = steps_per_iteration(piece) if x == "env_steps" else 0
        t0 = min(r[2] for rows in scalars.values() for r in rows)
        t1 = max(r[2] for rows in scalars.values() for r in rows)
        first = min(r[0] for rows in scalars.values() for r in rows)
        for tag, rows in scalars.items():
            for it, v, wall in rows:
                if it <= last_it:
                    continue  # a resumed piece repeats its checkpoint's iteration
                if x == "iteration":
                    xv = float(it)
                elif x == "env_steps":
                    xv = steps_done + (it if per_it is None else (it - first + 1) * per_it)
                else:
                    xv = (time_done + wall - t0) / 60.0
                out.setdefault(tag, []).append((xv, v))
        last = max(r[0] for rows in scalars.values() for r in rows)
        if x == "env_steps":
            steps_done += last if per_it is None else (last - max(first, last_it + 1) + 1) * per_it
        time_done += t1 - t0
        last_it = last
    return out


FIG5A_TAGS = {"Train/mean_reward": "mean episode return", "Episode/success_rate": "training success rate",
              "Curriculum/mean_level": "terrain curriculum level (mean)"}


def seed_band(specs: list[str], x: str, tag: str, points: int = 200) -> dict | None:
    """Mean, min and max over ``specs`` (one run per seed) of ``tag`` against ``x`` on a common grid up to the shortest
    run's last point (linear interpolation; before a run's first point, its first value). None when a run lacks the
    tag."""
    import numpy as np

    curves = [[(a, v) for a, v in read_curve(spec, x).get(tag, []) if math.isfinite(v)] for spec in specs]
    if any(not c for c in curves):  # a run without the tag, or without a finite value of it (no episode ended)
        return None
    end = min(c[-1][0] for c in curves)
    grid = np.linspace(0.0, end, points)
    ys = np.stack([np.interp(grid, *map(np.asarray, zip(*c))) for c in curves])
    return {"x": grid, "mean": ys.mean(axis=0), "min": ys.min(axis=0), "max": ys.max(axis=0), "seeds": len(specs),
            "final": ys[:, -1].tolist()}  # finite: NaN points are dropped above


def crossings(xs, ys, level: float, window: float) -> dict:
    """Where a curve (``xs`` rising, ``ys``) reaches ``level``: ``first`` (the first x with y >= level), ``sustained``
    (the first x from which y stays >= level over the next ``window`` of x, within the curve), ``dip_after_first``
    (the lowest y after the first crossing, and its x); None where it never does."""
    import numpy as np

    xs, ys = np.asarray(xs, float), np.asarray(ys, float)
    above = ys >= level
    first = float(xs[above.argmax()]) if above.any() else None
    sustained = None
    for i in np.flatnonzero(above):
        if xs[i] + window > xs[-1]:
            break
        span = (xs >= xs[i]) & (xs <= xs[i] + window)
        if above[span].all():
            sustained = float(xs[i])
            break
    dip = None
    if first is not None:
        after = xs >= first
        k = int(ys[after].argmin())
        dip = {"value": float(ys[after][k]), "at": float(xs[after][k])}
    return {"first": first, "sustained": sustained, "dip_after_first": dip}


def curve_numbers(specs: list[str], x: str, tag: str, level: float | None, window: float, common: float) -> dict:
    """The numbers of Fig. 5a's ``tag`` against ``x`` for one method's runs (``specs``, one per seed): per seed its
    peak (value, x), its value at ``common`` (None past its end) and at its own end (value, x), and where it crosses
    ``level`` (:func:`crossings`, with ``window``); the same of the seeds' mean curve (:func:`seed_band`), whose
    ``common`` value is read where every seed has a point."""
    import numpy as np

    out: dict = {"seeds": []}
    for spec in specs:
        c = [(a, v) for a, v in read_curve(spec, x).get(tag, []) if math.isfinite(v)]
        if not c:
            out["seeds"].append(None)
            continue
        xs, ys = map(np.asarray, zip(*c))
        k = int(ys.argmax())
        row = {"peak": {"value": float(ys[k]), "at": float(xs[k])}, "end": {"value": float(ys[-1]), "at": float(xs[-1])},
               "at_common": float(np.interp(common, xs, ys)) if common <= xs[-1] else None}  # fmt: skip
        if level is not None:
            row.update(crossings(xs, ys, level, window))
        out["seeds"].append(row)
    band = seed_band(specs, x, tag, points=2000)
    if band is not None:
        k = int(band["mean"].argmax())
        out["mean"] = {"peak": {"value": float(band["mean"][k]), "at": float(band["x"][k])},
                       "end": {"value": float(band["mean"][-1]), "at": float(band["x"][-1])},
                       "at_common": float(np.interp(common, band["x"], band["mean"])) if common <= band["x"][-1]
                       else None}  # fmt: skip
        if level is not None:
            out["mean"].update(crossings(band["x"], band["mean"], level, window))
    return out


def plot_fig5a(path: str, methods: dict[str, list[str]], axes: tuple[str, ...] = ("env_steps", "wall_time"),
               title: str = "Fig. 5a: mean over seeds, min to max shaded", labels: dict[str, str] | None = None,
               marked: dict[str, list[tuple[str, str]]] | None = None) -> dict:
    """Fig. 5a: reward, success and curriculum level (rows) against each of ``axes`` (columns: env-steps, wall time), one band per
    method (its seeds' mean, min to max shaded; ``labels`` names them); ``marked`` {method: [(run, note), ...]}: runs
    drawn apart as dashed lines with their note (a cold kernel cache, a shared GPU), outside the bands; writes ``path``
    (PNG) and the bands as ``<path>.csv``; returns each method's final values {method: {axis: {tag: [per seed]}}} and
    the axis end it was read at."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hexnewton.analysis.rollout import LABELS

    fig, grid = plt.subplots(len(FIG5A_TAGS), len(axes), figsize=(6 * len(axes), 3.6 * len(FIG5A_TAGS)),
                             squeeze=False)
    rows, summary = [], {}
    for col, x in enumerate(axes):
        for row, (tag, ylabel) in enumerate(FIG5A_TAGS.items()):
            ax = grid[row, col]
            names = {**dict.fromkeys(methods), **dict.fromkeys(marked or {})}
            for k, name in enumerate(names):
                text = (labels or {}).get(name) or LABELS.get(name, name)
                for spec, note in (marked or {}).get(name, []):
                    c = [(a, v) for a, v in read_curve(spec, x).get(tag, []) if math.isfinite(v)]
                    if c:
                        ax.plot(*zip(*c), color=f"C{k}", ls="--", lw=0.8, label=f"{text}, {note}")
                band = seed_band(methods[name], x, tag) if methods.get(name) else None
                if band is None:
                    continue
                # one colour per method on every panel, whichever tags its runs lack
                ax.plot(band["x"], band["mean"], color=f"C{k}", label=f"{text} ({band['seeds']} seed{'s' * (band['seeds'] != 1)})")
                ax.fill_between(band["x"], band["min"], band["max"], color=f"C{k}", alpha=0.2, lw=0)
                summary.setdefault(name, {}).setdefault(x, {})[tag] = {"at": float(band["x"][-1]),
                                                                      "final": band["final"]}  # fmt: skip
                rows += [[name, tag, x, float(a), float(m), float(lo), float(hi)]
                         for a, m, lo, hi in zip(band["x"], band["mean"], band["min"], band["max"])]
            ax.set(xlabel=X_AXES[x], ylabel=ylabel)
            ax.grid(alpha=0.3)
    if grid[0, 0].get_legend_handles_labels()[0]:
        grid[0, 0].legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    save_png(fig, path, dpi=100)
    plt.close(fig)
    with open(os.path.splitext(path)[0] + ".csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["method", "tag", "x_axis", "x", "mean", "min", "max"])
        w.writerows(rows)
    return summary


def plot_learning(path: str, runs: dict[str, str]) -> None:
    """Fig. 5a: mean episode reward against env-steps and against wall time, one curve per controller."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hexnewton.analysis.rollout import LABELS

    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    for ax, x in zip(axes, ("env_steps", "wall_time")):
        for ctrl, spec in runs.items():
            curve = read_curve(spec, x).get("Train/mean_reward")
            if curve:
                xs, v = zip(*curve)
                ax.plot(xs, v, label=LABELS.get(ctrl, ctrl))
        ax.set(xlabel="env-steps" if x == "env_steps" else "wall time [min]", ylabel="mean episode reward")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path, dpi=90)
    plt.close(fig)


def plot_curves(path: str, runs: list[str], labels: list[str] | None = None, x: str = "iteration") -> str:
    """The first three :data:`TAGS` of each run (``DIR1,DIR2`` joins a resumed run's pieces) against ``x``, one
    subplot per tag, into the PNG ``path``; every tag's points into a CSV beside it, whose path is returned."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if labels and len(labels) != len(runs):
        raise ValueError(f"--labels needs one label per run ({len(runs)}), got {len(labels)}")
    data = {r: read_curve(r, x) for r in runs}
    default = ["/".join(os.path.normpath(r.split(",")[-1]).split(os.sep)[-2:]) for r in runs]
    names = dict(zip(runs, labels or default))
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for r, curves in data.items():
        for ax, tag in zip(axes, TAGS[:3]):
            if tag in curves:
                xs, v = zip(*curves[tag])
                ax.plot(xs, v, label=names[r])
                ax.set_title(tag)
                ax.set_xlabel(X_AXES[x])
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path, dpi=100)
    plt.close(fig)
    csv_path = os.path.splitext(path)[0] + ".csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "tag", x, "value"])
        for r, curves in data.items():
            for tag, rows in curves.items():
                w.writerows([names[r], tag, xv, v] for xv, v in rows)
    return csv_path
