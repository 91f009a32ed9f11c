"""Start-up to the first iteration on one GPU: the phases train.py records in timing.json (``startup_phases_s``,
``startup_notes``), for the runs in ``startup/raw/`` (their device calls: ``studies/throughput/queue.sh``, step 1).

    python studies/throughput/startup.py      # startup/raw/*.timing.json -> startup/report.md, results.json
"""

from __future__ import annotations

import glob
import json
import os
import sys

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "startup")
COMMAND = "python train.py --task complex --max_iterations 2 --agent.validation_rounds 0"
#: the issue's targets [s]: to the first iteration, warm
TARGET_WARM_S = 15.0


def load(raw: str) -> dict:
    runs = {}
    for path in sorted(glob.glob(os.path.join(raw, "*.timing.json"))):
        with open(path) as f:
            t = json.load(f)
        notes = t.get("startup_notes", {})
        runs[os.path.basename(path).removesuffix(".timing.json")] = {
            "first_iteration_s": round(t["first_iteration_s"], 1),
            "phases_s": {k: round(v, 2) for k, v in t["startup_phases_s"].items()},
            "imports_s": notes.get("imports_s", {}), "model_build_beside_s": notes.get("model_build_beside_s", {}),
            "shipped_modules_installed": notes.get("shipped_modules_installed"), "device": t.get("device_name")}
    if not runs:
        raise FileNotFoundError(f"no *.timing.json in {raw}")
    with open(os.path.join(raw, "gpu.txt")) as f:
        gpu = f.read().strip()
    return {"command": COMMAND, "gpu": gpu, "target_warm_s": TARGET_WARM_S, "runs": runs}


def report(res: dict) -> str:
    runs = res["runs"]
    names = list(runs)
    phases = list(next(iter(runs.values()))["phases_s"])
    lines = ["# Start-up to the first iteration, warm, one GPU", "",
             f"`{res['command']}`, one run after another, each alone on the GPU ({res['gpu']}); the machine warm (its "
             "Warp kernel cache filled by the runs before). `python studies/throughput/startup.py` writes this file "
             "and results.json from raw/.", "",
             "| | " + " | ".join(names) + " |", "|---|" + "---:|" * len(names),
             "| **first iteration [s]** | "
             + " | ".join(f"**{runs[n]['first_iteration_s']:.1f}**" for n in names) + " |"]
    lines += [f"| {p} | " + " | ".join(f"{runs[n]['phases_s'][p]:.1f}" for n in names) + " |" for p in phases]
    lines += ["", "Beside the imports, in a thread (`startup_notes.model_build_beside_s`), and the imports' own times:",
              "",
              "| | " + " | ".join(names) + " |", "|---|" + "---:|" * len(names)]
    for key in ("model_build_beside_s", "imports_s"):
        for k in next(iter(runs.values()))[key]:
            lines.append(f"| {key.removesuffix('_s').replace('_', ' ')}: {k} | " +
                         " | ".join(f"{runs[n][key].get(k, float('nan')):.1f}" for n in names) + " |")
    best = min(r["first_iteration_s"] for r in runs.values())
    verdict = "met" if best <= res["target_warm_s"] else "not met"
    lines += ["", f"Target: <= {res['target_warm_s']:.0f} s to the first iteration, warm: **{verdict}** "
              f"(fastest {best:.1f} s)."]
    return "\n".join(lines) + "\n"


def main() -> int:
    try:
        res = load(os.path.join(HERE, "raw"))
    except (OSError, ValueError, KeyError) as exc:
        print(f"startup.py: {exc}", file=sys.stderr)
        return 2
    with open(os.path.join(HERE, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(HERE, "report.md"), "w") as f:
        f.write(report(res))
    return 0


if __name__ == "__main__":
    sys.exit(main())
