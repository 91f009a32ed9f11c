"""Learning curves from a training run's TensorBoard events: one PNG and a CSV.

    python -m hexnewton.curves logs/hexnewton_cpg_flat/<run> [more runs] --out curve.png
"""

from __future__ import annotations

import csv
import os
import sys

from .cli import ArgumentParser, run

TAGS = ("Episode/success_rate", "Episode/distance_m", "Train/mean_reward", "Episode/fell_rate",
        "Episode/off_course_rate")  # fmt: skip


def read_scalars(run_dir: str) -> dict[str, list[tuple[int, float]]]:
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    if not os.path.isdir(run_dir):
        raise ValueError(f"not a run directory: {run_dir}")
    acc = EventAccumulator(run_dir, size_guidance={"scalars": 0})
    acc.Reload()
    tags = set(acc.Tags().get("scalars", []))
    if not tags:
        raise ValueError(f"no TensorBoard scalars under {run_dir}")
    return {t: [(e.step, e.value) for e in acc.Scalars(t)] for t in TAGS if t in tags}


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.curves", description=__doc__.split("\n")[0])
    p.add_argument("runs", nargs="+")
    p.add_argument("--out", default="curve.png")
    p.add_argument("--labels", nargs="+", help="one legend label per run (default: experiment/run)")
    args = p.parse_args(argv)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if args.labels and len(args.labels) != len(args.runs):
        raise ValueError(f"--labels needs one label per run ({len(args.runs)}), got {len(args.labels)}")
    data = {r: read_scalars(r) for r in args.runs}
    default = ["/".join(os.path.normpath(r).split(os.sep)[-2:]) for r in args.runs]
    labels = dict(zip(args.runs, args.labels or default))
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    for r, scalars in data.items():
        label = labels[r]
        for ax, tag in zip(axes, TAGS[:3]):
            if tag in scalars:
                it, v = zip(*scalars[tag])
                ax.plot(it, v, label=label)
                ax.set_title(tag)
                ax.set_xlabel("iteration")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=100)
    csv_path = os.path.splitext(args.out)[0] + ".csv"
    with open(csv_path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", "tag", "iteration", "value"])
        for r, scalars in data.items():
            for tag, rows in scalars.items():
                w.writerows([r, tag, i, v] for i, v in rows)
    print(f"wrote {args.out} and {csv_path}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.curves"))
