"""Learning curves from training runs' TensorBoard events: one PNG and a CSV; Fig. 5a over seeds.

    python -m hexnewton.apps.curves logs/hexnewton_flat/<run> [more runs] --out curve.png
    python -m hexnewton.apps.curves RUN_A,RUN_A_RESUMED --x env_steps --out curve.png   # one curve from a resumed run
    python -m hexnewton.apps.curves --method cpg_rl RUN1 RUN2 RUN3 --method sac_cpg RUN4 RUN5 RUN6 --out fig5a.png

A run given as ``DIR1,DIR2,...`` is one curve: the pieces of a run continued with ``train.py --resume``. ``--method
NAME RUN...`` draws Fig. 5a (``hexnewton.analysis.curves.plot_fig5a``); ``--out``'s CSV holds the bands and a JSON
the final values.
"""

from __future__ import annotations

import json
import os
import sys

from hexnewton.analysis.curves import X_AXES, plot_curves, plot_fig5a, read_curve
from hexnewton.apps.cli import ArgumentParser, run


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.apps.curves", description=__doc__.split("\n")[0])
    p.add_argument("runs", nargs="*", help="run directories; DIR1,DIR2 joins a resumed run's pieces")
    p.add_argument("--out", default="curve.png")
    p.add_argument("--labels", nargs="+", help="one legend label per run (default: experiment/run)")
    p.add_argument("--x", default="iteration", choices=list(X_AXES))
    p.add_argument("--method", nargs="+", action="append", metavar=("NAME", "RUN"),
                   help="Fig. 5a: a method (cpg_rl, sac_cpg, ..., joint) and its runs, one per seed; repeat per method")
    args = p.parse_args(argv)
    if not args.out.endswith(".png"):
        raise ValueError(f"--out {args.out}: expected a .png file name")
    if args.method:
        if args.runs:
            raise ValueError("give runs either positionally (one curve each) or with --method (Fig. 5a), not both")
        methods = {}
        for name, *runs in args.method:
            if not runs:
                raise ValueError(f"--method {name}: name its runs (one per seed)")
            methods[name] = runs
        for runs in methods.values():
            for r in runs:
                read_curve(r)  # one-line errors before any plotting
        summary = plot_fig5a(args.out, methods)
        with open(os.path.splitext(args.out)[0] + ".json", "w") as f:
            json.dump({"methods": methods, "final": summary}, f, indent=1)
        print(f"wrote {args.out}, its .csv and .json")
        return 0
    if not args.runs:
        raise ValueError("name at least one run directory (or --method NAME RUN...)")
    csv_path = plot_curves(args.out, args.runs, args.labels, args.x)
    print(f"wrote {args.out} and {csv_path}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.curves"))
