"""Check a controller bundle against its recorded simulator rollout, on the robot's computer (NumPy and onnxruntime
only): ``python -m hexnewton.apps.deploy BUNDLE``."""

from __future__ import annotations

import sys

from hexnewton.apps.cli import ArgumentParser
from hexnewton.deploy.runtime import replay


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.apps.deploy",
                       description="Check a controller bundle against its recorded simulator rollout.")  # fmt: skip
    p.add_argument("bundle")
    p.add_argument("--tolerance", type=float, default=1e-3, help="largest joint-target difference allowed [rad]")
    args = p.parse_args(argv)
    try:
        r = replay(args.bundle)
    except (ValueError, OSError, KeyError) as exc:
        print(f"python -m hexnewton.apps.deploy: error: {exc}", file=sys.stderr)
        return 2
    ok = r["max_target_diff_rad"] <= args.tolerance
    print(f"{args.bundle}: {r['steps']} control steps x {r['robots']} robots replayed; joint targets differ from the "
          f"simulator's by at most {r['max_target_diff_rad']:.2e} rad, observations by {r['max_obs_diff']:.2e} "
          f"({'ok' if ok else 'FAILED'}, tolerance {args.tolerance:g} rad)")  # fmt: skip
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
