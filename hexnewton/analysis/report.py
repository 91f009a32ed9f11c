"""The evaluation's report and figures: ``report.md`` (Table 3's shape with the paper's numbers beside ours, stability
and gait quality, robustness), ``results.json``, Figs. 5b-8 as PNG (matplotlib; Fig. 5a, the learning
curves, is :mod:`hexnewton.analysis.curves`'s), and the merge of evaluations run apart.
"""

from __future__ import annotations

import json
import math
import os
import subprocess

import numpy as np

from hexnewton.analysis.figures import save_png
from hexnewton.analysis.metrics import DISTANCES
from hexnewton.analysis.rollout import LABELS, Episode
from hexnewton.config import PARAM_NAMES, POSTURE_NAMES

# Table 3 of Huang et al. 2025 (25 rounds): success [%] at 0.5, 1, 2, 3 m
PAPER_TABLE3 = {
    "rugged": {"CPG": (96, 96, 88, 60), "TD3-CPG": (100, 100, 100, 70), "SAC-CPG": (100, 100, 100, 96),
               "CPG_RL": (100, 100, 100, 100)},
    "stepped": {"CPG": (60, 28, 0, 0), "TD3-CPG": (100, 84, 0, 0), "SAC-CPG": (96, 96, 96, 52),
                "CPG_RL": (100, 100, 100, 100)},
    "complex": {"CPG": (92, 56, 8, 0), "TD3-CPG": (100, 100, 12, 0), "SAC-CPG": (100, 80, 40, 4),
                "CPG_RL": (100, 100, 100, 100)},
}  # fmt: skip


def percent(v: float | None) -> str:
    """A rate as a whole percentage (``0.96`` -> ``96%``); a dash for none."""
    return "—" if v is None else f"{100 * v:.0f}%"


def ended_cell(s: dict, last: float) -> str:
    """How the rounds ended, "fell 69 (60 past 3 m), success 909": the bad endings of rounds that had walked the
    last distance (``ended_past_3m``) in brackets; reports written without it show the counts alone."""
    past = s.get(f"ended_past_{last:g}m", {})
    return ", ".join(f"{k} {v}" + (f" ({past[k]} past {last:g} m)" if k != "success" and past.get(k) else "")
                     for k, v in s["ended"].items() if v)  # fmt: skip


def falls_cell(s: dict) -> str:
    """The rounds that fell, "30 / 1000 (22 past the goal)": in brackets those that had passed the goal line
    (``ended_past_goal``); reports written without it show the count alone."""
    fell, past = s["ended"].get("fell", 0), s.get("ended_past_goal", {}).get("fell", 0)
    return f"{fell} / {s['rounds']}" + (f" ({past} past the goal)" if past else "")


def report_markdown(results: dict, meta: dict, robustness: dict | None = None, sweeps: dict | None = None) -> str:
    """Table 3's shape (ours beside the paper's), stability and gait quality per terrain and controller, the
    parameters on blocks and stairs, one robustness table per controller (``robustness[name][ctrl][terrain]``), then
    one table per capability sweep (``sweeps[name]``, :func:`hexnewton.apps.evaluate.run_sweeps`)."""
    lines = ["# hexnewton evaluation", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()]
    distances = tuple(meta.get("distances", DISTANCES))
    lines += ["", "## Success rate at each distance (Table 3)", "",
              "| terrain | method | " + " | ".join(f"{d:g} m" for d in distances) + " | paper (" +
              " / ".join(f"{d:g}" for d in distances) + " m) |",
              "|---|---|" + "---:|" * len(distances) + "---|"]  # fmt: skip
    for terrain, by_ctrl in results.items():
        for ctrl, s in by_ctrl.items():
            paper = PAPER_TABLE3.get(terrain, {}).get(LABELS[ctrl])
            ref = " / ".join(f"{p}%" for p in paper) if paper else "—"
            cells = " | ".join(percent(s[f"success_{d:g}m"]) for d in distances)
            lines.append(f"| {terrain} | {LABELS[ctrl]} | {cells} | {ref} |")
    lines += ["", "## Stability (§3.3; angles in degrees over every step of every round)", "",
              "| terrain | method | rounds | pitch mean / var / peak | roll mean / var / peak | Y dev. mean / max [m] "
              f"| time to {distances[-1]:g} m [s] | ended |", "|---|---|---:|---|---|---|---:|---|"]  # fmt: skip
    for terrain, by_ctrl in results.items():
        for ctrl, s in by_ctrl.items():
            ang = {n: " / ".join("—" if s[f"{n}_{k}"] is None else f"{s[f'{n}_{k}']:.2f}"
                                 for k in ("mean_deg", "var_deg2", "peak_deg")) for n in ("pitch", "roll")}  # fmt: skip
            t3 = s[f"time_to_{distances[-1]:g}m_s"]
            ended = ended_cell(s, distances[-1])
            lines.append(f"| {terrain} | {LABELS[ctrl]} | {s['rounds']} | {ang['pitch']} | {ang['roll']} | "
                         f"{s['y_dev_mean_m']:.3f} / {s['y_dev_max_m']:.3f} | "
                         f"{'—' if t3 is None else f'{t3:.1f}'} | {ended} |")  # fmt: skip
    lines += ["", "## Gait quality (deterministic actions unless stated in the header)", "",
              "Falls: rounds that ended in a fall anywhere (also after the last distance; in brackets those that had "
              "walked past the goal without reaching it: beyond it the course's patch ends). p99.9: the 99.9th "
              "percentile of |angle| over every step. Rates: RMS of the body's roll / pitch rate. Δparam: mean change per "
              "control step of the CPG parameters the oscillators and the mapping use (15; 18 with the body "
              "posture), requested by the policy in brackets, in % of each parameter's range. Ratios: variance "
              "against the fixed CPG's in the same run.", "",
              "| terrain | method | falls | pitch var [deg²] | roll var [deg²] | \\|pitch\\| / \\|roll\\| p99.9 [deg] "
              "| roll / pitch rate RMS [deg/s] | Δparam [%/step] | pitch / roll var ÷ CPG | ÷ CPG (swept) |",
              "|---|---|---:|---:|---:|---|---|---|---|---|"]  # fmt: skip
    f = lambda v, fmt=".1f": "—" if v is None else format(v, fmt)  # noqa: E731
    for terrain, by_ctrl in results.items():
        for ctrl, s in by_ctrl.items():
            ratios = []
            for base in ("cpg", "cpg_swept"):
                b = by_ctrl.get(base)
                ok = b and ctrl != base and b["pitch_var_deg2"] and b["roll_var_deg2"]
                ratios.append(f"{s['pitch_var_deg2'] / b['pitch_var_deg2']:.2f} / "
                              f"{s['roll_var_deg2'] / b['roll_var_deg2']:.2f}" if ok else "—")  # fmt: skip
            lines.append(f"| {terrain} | {LABELS[ctrl]} | {falls_cell(s)} | "
                         f"{f(s['pitch_var_deg2'])} | {f(s['roll_var_deg2'])} | {f(s['pitch_p999_deg'])} / "
                         f"{f(s['roll_p999_deg'])} | {f(s.get('roll_rate_rms_deg_s'))} / "
                         f"{f(s.get('pitch_rate_rms_deg_s'))} | {f(s.get('param_change_pct'), '.2f')} "
                         f"({f(s.get('action_change_pct'), '.2f')}) | {ratios[0]} | {ratios[1]} |")  # fmt: skip
    segs = [(t, c, s["segments"]) for t, by in results.items() for c, s in by.items()
            if len(s.get("segments", {})) == 2]
    if segs:
        names = PARAM_NAMES + (POSTURE_NAMES if any(len(seg["blocks"]) > len(PARAM_NAMES) for *_, seg in segs) else ())
        lines += ["", "## Parameters on the blocks and on the stairs (Fig. 5b; complex course, mean over all rounds)",
                  "", "| method | where | " + " | ".join(names) + " |", "|---|---|" + "---:|" * len(names)]
        for _, ctrl, seg in segs:
            for where in ("blocks", "stairs"):
                v = [f"{v:.2f}" for v in seg[where]] + ["—"] * (len(names) - len(seg[where]))
                lines.append(f"| {LABELS[ctrl]} | {where} | " + " | ".join(v) + " |")
    robustness = robustness or {}
    for ctrl in dict.fromkeys(c for by in robustness.values() for c in by):
        lines += ["", f"## Robustness: {LABELS[ctrl]} under named perturbations (beyond the training ranges)", "",
                  "| perturbation | terrain | " + " | ".join(f"{d:g} m" for d in distances) + " | falls | "
                  "pitch var [deg²] | \\|pitch\\| p99.9 [deg] |",
                  "|---|---|" + "---:|" * (len(distances) + 3)]  # fmt: skip
        for name, by_ctrl in robustness.items():
            for terrain, s in by_ctrl.get(ctrl, {}).items():
                cells = " | ".join(percent(s[f"success_{d:g}m"]) for d in distances)
                lines.append(f"| {name} | {terrain} | {cells} | {s['ended'].get('fell', 0)} / {s['rounds']} | "
                             f"{f(s['pitch_var_deg2'])} | {f(s['pitch_p999_deg'])} |")  # fmt: skip
    return "\n".join(lines + sweep_markdown(sweeps or {}, distances[-1])) + "\n"


def sweep_markdown(sweeps: dict, last: float) -> list[str]:
    """One table per capability sweep: each value, each controller's success, falls, pitch / roll variance, time."""
    lines = []
    for name, sw in sweeps.items():
        lines += ["", f"## Capability curve: {name} (`{sw['field']}` on {sw['terrain']} ground, fig_sweep_"
                  f"{name.replace('@', '_')}.png)", "", f"| value | method | rounds | {last:g} m | falls | pitch / roll var "
                  f"[deg²] | time to {last:g} m [s] |", "|---:|---|---:|---:|---:|---|---:|"]  # fmt: skip
        for k, value in enumerate(sw["values"]):
            for ctrl, points in sw["curves"].items():
                p = points[k]
                t = p[f"time_to_{last:g}m_s"]
                var = " / ".join("—" if p[m] is None else f"{p[m]:.1f}" for m in ("pitch_var_deg2", "roll_var_deg2"))
                lines.append(f"| {value:g} | {LABELS.get(ctrl, ctrl)} | {p['rounds']} | "
                             f"{percent(p[f'success_{last:g}m'])} | {percent(p['fall_rate'])} | {var} | "
                             f"{'—' if t is None else f'{t:.1f}'} |")  # fmt: skip
    return lines


def plot_sweep(path: str, name: str, sweep: dict, last: float) -> None:
    """A capability curve: success at ``last`` metres and falls against the swept value, one line per controller."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.6))
    for ctrl, points in sweep["curves"].items():
        xs = [p["value"] for p in points]
        axes[0].plot(xs, [100 * p[f"success_{last:g}m"] for p in points], "o-", label=LABELS.get(ctrl, ctrl))
        axes[1].plot(xs, [100 * p["fall_rate"] for p in points], "o-", label=LABELS.get(ctrl, ctrl))
    axes[0].set(ylabel=f"reached {last:g} m [%]", ylim=(-3, 103))
    axes[1].set(ylabel="fell [%]")
    for ax in axes:
        ax.set(xlabel=f"{sweep['field']} ({sweep['terrain']})", title=name)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path, dpi=90)
    plt.close(fig)


def plot_terrain(path: str, terrain: str, episodes: dict[str, Episode], metrics: dict[str, dict]) -> None:
    """Figs. 6-8: pitch / roll of round 0 over time, box plots over all rounds, XY trajectories."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    deg = 180.0 / math.pi
    fig, axes = plt.subplots(1, 5, figsize=(24, 4.2))
    for idx, (axis, name) in enumerate(((1, "pitch"), (0, "roll"))):
        line_ax, box_ax = axes[2 * idx], axes[2 * idx + 1]
        boxes = []
        for ctrl, ep in episodes.items():
            m = metrics[ctrl]["in_episode"]
            n0 = int(m[:, 0].sum())
            line_ax.plot(np.arange(n0) * ep.dt, ep.rpy[:n0, 0, axis] * deg, label=LABELS[ctrl], lw=0.8)
            boxes.append(ep.rpy[..., axis][m] * deg)
        line_ax.set(title=f"{name}, round 0", xlabel="time [s]", ylabel=f"{name} [deg]")
        box_ax.boxplot(boxes, showfliers=False)
        box_ax.set_xticks(range(1, len(boxes) + 1), [LABELS[c] for c in episodes])
        box_ax.set(title=f"{name}, all rounds", ylabel=f"{name} [deg]")
    ax = axes[4]
    for i, (ctrl, ep) in enumerate(episodes.items()):
        m = metrics[ctrl]["in_episode"]
        for r in range(min(ep.pos.shape[1], 25)):
            k = m[:, r]
            ax.plot(ep.pos[k, r, 0], ep.pos[k, r, 1], color=f"C{i}", lw=0.6, alpha=0.6,
                    label=LABELS[ctrl] if r == 0 else None)  # fmt: skip
    ax.axhline(1.5, color="k", ls=":", lw=0.8)
    ax.axhline(-1.5, color="k", ls=":", lw=0.8)
    ax.add_patch(matplotlib.patches.Circle((3.5, 0.0), 0.5, fill=False, color="g"))
    ax.set(title=f"trajectories (x, y from start), {terrain}", xlabel="x [m]", ylabel="y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[4].legend(fontsize=8)
    fig.tight_layout()
    save_png(fig, path, dpi=90)
    plt.close(fig)


def plot_params(path: str, terrain: str, episodes: dict[str, Episode]) -> None:
    """Fig. 5b: omega and the mean A1 / A2 / A3 along round 0, learned against fixed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = {"omega [rad/s]": [0], "A1 (hip)": [1, 2], "A2 (knee), mean of 6": list(range(3, 9)),
              "A3 (ankle), mean of 6": list(range(9, 15))}  # fmt: skip
    fig, axes = plt.subplots(1, 4, figsize=(18, 3.6))
    for ctrl, ep in episodes.items():
        if np.isnan(ep.params).all():
            continue
        t = np.arange(len(ep.params)) * ep.dt
        for ax, (title, cols) in zip(axes, groups.items()):
            ax.plot(t, ep.params[:, cols].mean(axis=1), label=LABELS[ctrl])
            ax.set(title=title, xlabel="time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"CPG parameters along round 0 on {terrain}")
    fig.tight_layout()
    save_png(fig, path, dpi=90)
    plt.close(fig)


def merge_reports(dirs: list[str], out: str) -> int:
    """One report from several evaluation folders (``--merge``): their results and robustness tables side by side.
    The folders must share the seeds, rounds and distances (otherwise the rows would not be comparable)."""
    runs = []
    for d in dirs:
        path = os.path.join(d, "results.json")
        if not os.path.isfile(path):
            raise ValueError(f"{d} holds no results.json (not an evaluation folder, or an unfinished one)")
        with open(path) as f:
            runs.append(json.load(f))
    keys = ("terrain_seed", "reset_seed", "rounds", "distances", "max_steps", "goal_distance", "actions")
    for d, r in zip(dirs[1:], runs[1:]):
        differ = [k for k in keys if r["meta"].get(k) != runs[0]["meta"].get(k)]
        if differ:
            raise ValueError(f"{d} differs from {dirs[0]} in {', '.join(differ)}: its rounds are not comparable")
    if os.path.exists(out):
        raise ValueError(f"{out} exists: choose a new --out (nothing is overwritten)")
    results: dict = {}
    robustness: dict = {}
    sweeps: dict = {}
    for r in runs:
        sweeps.update(r.get("sweeps", {}))
        for terrain, by_ctrl in r["results"].items():
            results.setdefault(terrain, {}).update(by_ctrl)
        for name, by_ctrl in r.get("robustness", {}).items():
            for ctrl, by_terrain in by_ctrl.items():
                robustness.setdefault(name, {}).setdefault(ctrl, {}).update(by_terrain)
    meta = {**runs[0]["meta"], "merged_from": [os.path.abspath(d) for d in dirs],
            "wall_s": round(sum(r["meta"].get("wall_s", 0.0) for r in runs), 1)}  # fmt: skip
    os.makedirs(out)
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"meta": meta, "results": results, "robustness": robustness, "sweeps": sweeps}, f, indent=1)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write(report_markdown(results, meta, robustness, sweeps))
    print(f"merged {len(dirs)} evaluations into {out}/ (report.md, results.json)")
    return 0


def git_rev() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()  # fmt: skip
    except Exception:  # e.g. a copy of the tree without .git (the GPU machine)
        return os.environ.get("HEXNEWTON_GIT_REV", "unknown")
