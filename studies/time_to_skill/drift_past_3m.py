"""Rugged rounds that end badly after walking 3 m against the mean lateral drift, over every evaluation in a tree.

Every ``ROOT/**/results.json`` (``--root``, default ``studies``; the evaluations themselves are in git history,
studies/time_to_skill/README.md) of ``python -m hexnewton.apps.evaluate`` with a learnt CPG policy (``cpg_rl``) on the
rugged course, at least 300 rounds, deterministic action. A round that never walked 3 m ended badly (fell, left the
course, timed out), so the bad endings of the rounds that did are (fell + off course + time-outs) / rounds - (1 - 3 m
success) (a report that carries ``ended_past_3m`` gives the same directly). Prints one line per evaluation and the
correlation with ``y_dev_mean_m``; ``--out`` writes them as JSON.

    python studies/time_to_skill/drift_past_3m.py --out studies/time_to_skill/recipes/kl_choice/drift.json
"""

import argparse
import glob
import json
import sys

import numpy as np


def rows(root: str = "studies") -> list[dict]:
    out = []
    for path in sorted(glob.glob(f"{root}/**/results.json", recursive=True)):
        if "sampled" in path:
            continue
        try:
            with open(path) as f:
                data = json.load(f)
        except (OSError, ValueError):
            continue
        meta = data.get("meta", {}) if isinstance(data, dict) else {}
        m = (data.get("results") or {}).get("rugged", {}).get("cpg_rl") if isinstance(data, dict) else None
        if not isinstance(m, dict) or "ended" not in m or m.get("rounds", 0) < 300:
            continue
        if not str(meta.get("actions", "deterministic")).startswith("deterministic"):
            continue
        e, n = m["ended"], m["rounds"]
        bad = (e.get("fell", 0) + e.get("off_course", 0) + e.get("timeout", 0)) / n
        out.append({"file": path, "rounds": n, "success_3m": m["success_3m"], "bad_endings": round(bad, 4),
                    "bad_past_3m": round(bad - (1.0 - m["success_3m"]), 4),
                    "y_dev_mean_m": round(m["y_dev_mean_m"], 3)})
    return out


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--root", default="studies")
    p.add_argument("--out", default=None, help="write the rows and the correlation as JSON")
    a = p.parse_args()
    r = rows(a.root)
    if len(r) < 3:
        print(f"drift_past_3m.py: {len(r)} rugged evaluations under {a.root}, too few", file=sys.stderr)
        return 1
    x = np.array([v["y_dev_mean_m"] for v in r])
    y = np.array([v["bad_past_3m"] for v in r])
    corr = float(np.corrcoef(x, y)[0, 1])
    bins = []
    for lo, hi in ((0.0, 0.3), (0.3, 0.4), (0.4, 0.5), (0.5, 10.0)):
        k = (x >= lo) & (x < hi)
        bins.append({"y_dev_mean_m": [lo, hi], "evaluations": int(k.sum()),
                     "median_bad_past_3m": float(np.median(y[k])) if k.any() else None})
    for v in r:
        print(f"{v['y_dev_mean_m']:5.2f} m  past 3 m {100 * v['bad_past_3m']:5.1f} %  {v['file']}")
    for b in bins:
        med = "—" if b["median_bad_past_3m"] is None else f"{100 * b['median_bad_past_3m']:.1f} %"
        lo, hi = b["y_dev_mean_m"]
        print(f"drift {lo:.1f}-{hi:.1f} m: {b['evaluations']} evaluations, median {med}")
    print(f"{len(r)} evaluations, correlation {corr:.2f}")
    if a.out:
        try:
            with open(a.out, "w") as f:
                json.dump({"command": f"python studies/time_to_skill/drift_past_3m.py --out {a.out}", "evaluations": len(r),
                           "correlation": round(corr, 3), "bins": bins, "rows": r}, f, indent=1)
        except OSError as err:
            print(f"drift_past_3m.py: cannot write {a.out}: {err.strerror}", file=sys.stderr)
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
