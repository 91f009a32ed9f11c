"""Where a policy's lateral drift on the rugged course comes from: its rounds (``analysis.rollout.run_rounds``, the
evaluation's courses and start draws, deterministic action), each round's start yaw against its lateral offset from
its start line and its yaw when it has walked 1, 2 and 3 m.

    python studies/time_to_skill/drift_sources.py --checkpoint results/policies/cpg_rl_complex.pt --rounds 64 --device cpu \\
        --out drift_sources.json

A drift that follows the start yaw (correlation near 1, the offset growing as the yaw times the distance) is a heading
the policy corrects slowly; a drift that does not is made on the way (the terrain, the gait)."""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

MARKS = (1.0, 2.0, 3.0)


def at_distances(pos: np.ndarray, yaw: np.ndarray, marks=MARKS) -> dict:
    """Per round (N,) the lateral offset y and the yaw [rad] at the first step each round has walked ``marks`` metres in
    x (NaN where it never did). ``pos`` (T, N, 2) relative to the start, ``yaw`` (T, N)."""
    out = {}
    x = np.nan_to_num(pos[..., 0], nan=-np.inf)
    for m in marks:
        reached = x >= m
        first = np.argmax(reached, axis=0)
        ok = reached.any(axis=0)
        cols = np.arange(pos.shape[1])
        out[m] = {"y": np.where(ok, pos[first, cols, 1], np.nan), "yaw": np.where(ok, yaw[first, cols], np.nan)}
    return out


def corr(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson's correlation over the rounds where both are finite (NaN for fewer than 3 or a constant side)."""
    ok = np.isfinite(a) & np.isfinite(b)
    if ok.sum() < 3 or np.ptp(a[ok]) == 0 or np.ptp(b[ok]) == 0:
        return float("nan")
    return float(np.corrcoef(a[ok], b[ok])[0, 1])


def summarize(pos: np.ndarray, rpy: np.ndarray) -> dict:
    """The start yaw's share in the drift: per mark the mean |y| (``pos`` is relative to each round's start), its
    correlation with the start yaw, the mean |yaw| there, and the offset a round would have if it kept its start
    yaw."""
    yaw = np.unwrap(rpy[..., 2], axis=0)
    yaw0 = yaw[0]
    rows = {}
    for m, v in at_distances(pos, yaw).items():
        rows[f"{m:g} m"] = {
            "rounds_reached": int(np.isfinite(v["y"]).sum()),
            "mean_abs_y_m": float(np.nanmean(np.abs(v["y"]))),
            "corr_y_start_yaw": corr(v["y"], yaw0),
            "mean_abs_yaw_rad": float(np.nanmean(np.abs(v["yaw"]))),
            "mean_abs_y_if_start_yaw_kept_m": float(np.nanmean(np.abs(m * np.tan(yaw0)))),
        }
    return {"rounds": int(pos.shape[1]), "mean_abs_start_yaw_rad": float(np.mean(np.abs(yaw0))), "at": rows}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python studies/time_to_skill/drift_sources.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--checkpoint", required=True)
    p.add_argument("--terrain", default="rugged")
    p.add_argument("--rounds", type=int, default=64)
    p.add_argument("--seed", type=int, default=3000, help="terrain seed (3000: the validation rounds)")
    p.add_argument("--device", default=None)
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    if not os.path.isfile(args.checkpoint):
        print(f"{p.prog}: --checkpoint {args.checkpoint}: no such file", file=sys.stderr)
        return 2
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.config import TaskConfig

    ep = run_rounds("cpg_rl", args.checkpoint, args.terrain, args.rounds, args.device, TaskConfig.max_episode_steps,
                    progress=False, seed=args.seed)  # fmt: skip
    res = {"command": "python studies/time_to_skill/drift_sources.py " + " ".join(sys.argv[1:] if argv is None else argv),
           "checkpoint": args.checkpoint, "terrain": args.terrain, "seed": args.seed, **summarize(ep.pos, ep.rpy)}
    with open(args.out, "w") as f:
        json.dump(res, f, indent=1)
    for mark, r in res["at"].items():
        print(f"{mark}: |y| {r['mean_abs_y_m']:.3f} m (kept start yaw: {r['mean_abs_y_if_start_yaw_kept_m']:.3f}), "
              f"corr with start yaw {r['corr_y_start_yaw']:+.2f}, |yaw| {r['mean_abs_yaw_rad']:.3f} rad "
              f"({r['rounds_reached']} rounds)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
