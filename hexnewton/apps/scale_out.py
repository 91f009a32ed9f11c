"""Scale-out report: throughput and time to the result at 1, 2, 4 ... GPUs of one host, from a lease's outputs.

    python -m hexnewton.apps.scale_out LEASE [LEASE ...] --out results/scale_out

LEASE (one or more, joined: e.g. the benches of one lease and the runs of another) is what
``bash scripts/device/scale_out.sh pack`` brings back, unpacked: ``bench_<K>gpu.json`` (``hexnewton-bench --json``
under torchrun at K GPUs), ``runs/<name>/`` (a ``train.py`` run's ``timing.json`` and ``config.json``, its
console log and ``wall.txt``), ``evals/<name>_<terrain>/`` (``python -m hexnewton.apps.evaluate --out`` of the run's
result) and ``commands.txt`` (the calls, quoted in the report). Writes ``report.md`` and ``results.json``
(:mod:`hexnewton.analysis.scale_out`): per GPU count the device, envs per GPU, env-steps/s, the scaling efficiency,
the seconds from process start to the result and, per terrain, the result's success at 3 m and fall rate.
"""

from __future__ import annotations

import os
import sys

from hexnewton.apps.cli import ArgumentParser, check_new_dir, run


def parser() -> ArgumentParser:
    """The command line of ``python -m hexnewton.apps.scale_out``."""
    p = ArgumentParser(prog="python -m hexnewton.apps.scale_out", description=__doc__.split("\n")[0])
    p.add_argument("lease", nargs="+", help="the unpacked outputs of scripts/device/scale_out.sh pack (one or more "
                   "folders, joined)")
    p.add_argument("--out", required=True, help="the folder for report.md and results.json: a new one, or one that "
                   "holds neither (e.g. the folder of the leases' outputs); nothing is overwritten")
    return p


def main(argv: list[str] | None = None) -> int:
    from hexnewton.analysis.scale_out import build_report

    args = parser().parse_args(argv)
    for folder in args.lease:
        if not os.path.isdir(folder):
            raise ValueError(f"{folder} is not a folder")
    check_new_dir(args.out, files=("report.md", "results.json"))
    commands = []
    for folder in args.lease:
        path = os.path.join(folder, "commands.txt")
        commands += open(path).read().splitlines() if os.path.isfile(path) else []
    results = build_report(args.lease, args.out, commands)
    print(f"{len(results['bench'])} throughput rows, {len(results['runs'])} runs -> {args.out}/ (report.md, "
          "results.json)")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.scale_out"))
