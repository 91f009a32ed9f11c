"""Learning curves from training runs' TensorBoard events: one PNG and a CSV.

    python -m hexnewton.curves logs/hexnewton_cpg_flat/<run> [more runs] --out curve.png
    python -m hexnewton.curves RUN_A,RUN_A_RESUMED --x env_steps --out curve.png   # one curve from a resumed run

A run given as ``DIR1,DIR2,...`` is one curve: the pieces of a run continued with ``train.py --resume``,
joined in order. The x axis is the iteration, the env-steps (iterations x envs x steps per env, from each
piece's ``config.json``; a Stable-Baselines3 run from ``hexnewton.baselines`` logs env-steps directly) or
the wall time (each piece's own time from its first to its last logged
iteration, so the pause between pieces does not count).
"""

from __future__ import annotations

import csv
import json
import os
import sys

from .cli import ArgumentParser, run

TAGS = ("Episode/success_rate", "Episode/distance_m", "Train/mean_reward", "Episode/fell_rate",
        "Episode/off_course_rate", "Curriculum/mean_level", "Curriculum/top_level_success_rate")  # fmt: skip
# Stable-Baselines3 runs (hexnewton.baselines) log the mean episode return against env-steps
SB3_ALIASES = {"rollout/ep_rew_mean": "Train/mean_reward"}
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
    out = {t: [(e.step, e.value, e.wall_time) for e in acc.Scalars(t)] for t in TAGS if t in tags}
    for sb3_tag, tag in SB3_ALIASES.items():
        if sb3_tag in tags and tag not in out:
            out[tag] = [(e.step, e.value, e.wall_time) for e in acc.Scalars(sb3_tag)]
    return out


def steps_per_iteration(run_dir: str) -> int | None:
    """Env-steps collected per PPO iteration (num_envs x num_steps_per_env) from the run's config.json;
    None for a Stable-Baselines3 run, whose TensorBoard step already counts env-steps."""
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


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.curves", description=__doc__.split("\n")[0])
    p.add_argument("runs", nargs="+", help="run directories; DIR1,DIR2 joins a resumed run's pieces")
    p.add_argument("--out", default="curve.png")
    p.add_argument("--labels", nargs="+", help="one legend label per run (default: experiment/run)")
    p.add_argument("--x", default="iteration", choices=list(X_AXES))
    args = p.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if args.labels and len(args.labels) != len(args.runs):
        raise ValueError(f"--labels needs one label per run ({len(args.runs)}), got {len(args.labels)}")
    data = {r: read_curve(r, args.x) for r in args.runs}
    default = ["/".join(os.path.normpath(r.split(",")[-1]).split(os.sep)[-2:]) for r in args.runs]
    labels = dict(zip(args.runs, args.labels or default))
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for r, curves in data.items():
        for ax, tag in zip(axes, TAGS[:3]):
            if tag in curves:
                xs, v = zip(*curves[tag])
                ax.plot(xs, v, label=labels[r])
                ax.set_title(tag)
                ax.set_xlabel(X_AXES[args.x])
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    csv_path = os.path.splitext(args.out)[0] + ".csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "tag", args.x, "value"])
        for r, curves in data.items():
            for tag, rows in curves.items():
                w.writerows([labels[r], tag, xv, v] for xv, v in rows)
    print(f"wrote {args.out} and {csv_path}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.curves"))
