"""The world's Warp modules loaded while the finalize ends (``train.py``'s default, ``ModelBuild(...,
preload_kernels=True)``) against after it (``--no-preload_kernels``): the time to the first iteration of
``python train.py --task complex --max_iterations 1 --agent.validation_rounds 0`` and its start-up phases (the run's
timing.json), in fresh processes one after another, alternating, on this machine's CPU or GPU.

    python studies/startup_beside/preload.py --runs 3 --device cpu --num_envs 16 --out studies/startup_beside/preload
    python studies/startup_beside/preload.py --rebuild studies/startup_beside/preload     # report.md again
"""

from __future__ import annotations

import glob
import json
import os
import subprocess
import sys
import tempfile

import alternate  # this study's shared runner (the script's folder is on sys.path)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MODES = {"preload": [], "after": ["--no-preload_kernels"]}
COMMAND = ["train.py", "--task", "complex", "--max_iterations", "1", "--agent.validation_rounds", "0"]
#: the phases the table shows, in the start-up's order (each run's others are in results.json)
SHOWN = ("python and imports", "kernels beside the build", "model build", "solver kernels", "solver",
         "collision pipeline", "kernels", "first step and graph capture")  # fmt: skip


def measure(mode: str, num_envs: int, device: str) -> dict:
    with tempfile.TemporaryDirectory() as logs:
        args = [sys.executable, *COMMAND, "--num_envs", str(num_envs), "--device", device, "--log_dir", logs,
                *MODES[mode]]  # fmt: skip
        done = subprocess.run(args, cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            tail = (done.stderr or done.stdout).strip().splitlines()[-1:] or ["no output"]
            sys.exit(f"preload.py: train.py ({mode}) exited {done.returncode}: {tail[0]}")
        with open(glob.glob(os.path.join(logs, "*", "*", "timing.json"))[0]) as f:
            t = json.load(f)
    notes = t["startup_notes"]
    return {"mode": mode, "first_iteration_s": round(t["first_iteration_s"], 2),
            "phases_s": {k: round(v, 2) for k, v in t["startup_phases_s"].items()},
            "finalize_s": notes.get("model_build_beside_s", {}).get("finalize"),
            "modules_preloaded": notes.get("kernels_beside_build")}  # fmt: skip


def report(res: dict) -> str:
    lines = ["# The world's Warp modules loaded while the finalize ends", "",
             f"`{res['command']}` ({res['machine']}; `python {' '.join(COMMAND)} --num_envs {res['num_envs']} "
             f"--device {res['device']}`, with `--no-preload_kernels` for `after`). Each run a fresh process, in the "
             "order shown; the phases are the run's timing.json (`startup_phases_s`), 0 where a run has none. "
             "Numbers: results.json.", "",
             *alternate.warmup_note(res, "first_iteration_s", "the first iteration at"),
             "| run | mode | first iteration [s] | " + " | ".join(SHOWN) + " | the finalize, beside [s] |",
             "|---|---|---:|" + "---:|" * (len(SHOWN) + 1)]  # fmt: skip
    for k, r in enumerate(res["runs"], 1):
        ph = r["phases_s"]
        lines.append(f"| {k} | {r['mode']} | {r['first_iteration_s']:.1f} | "
                     + " | ".join(f"{ph.get(p, 0.0):.1f}" for p in SHOWN) + f" | {r['finalize_s'] or 0:.1f} |")
    times = alternate.per_mode(res, "first_iteration_s", MODES)
    if times:
        (a, a_lo, a_hi), (b, b_lo, b_hi) = times.values()
        lines += ["", f"Mean time to the first iteration: preload {a:.1f} s ({a_lo:.1f}-{a_hi:.1f}), after {b:.1f} s "
                  f"({b_lo:.1f}-{b_hi:.1f}): {a - b:+.1f} s."]  # fmt: skip
    return "\n".join(lines) + "\n"


def main() -> None:
    alternate.main("preload.py", __doc__, MODES, measure, report)


if __name__ == "__main__":
    main()
