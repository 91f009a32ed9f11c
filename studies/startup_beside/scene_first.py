"""The terrain and the scene first, only Newton's finalize beside the imports (``train.py``'s default,
``ModelBuild(beside=True, scene_first=True)``), against all three beside them (``--no-build_scene_first``): when the
model is ready, measured as ``train.py`` orders its start-up (warp, newton and the world imported, the build begun,
torch, rsl-rl, the env and the runner imported, then the model taken), in fresh processes one after another,
alternating, on this machine's CPU or GPU (the complex task, 4096 envs).

    python studies/startup_beside/scene_first.py --runs 2 --device cpu --out studies/startup_beside/scene_first
    python studies/startup_beside/scene_first.py --rebuild studies/startup_beside/scene_first   # report.md again
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

MODES = {"scene_first": True, "all_beside": False}
#: one run: the start-up as train.py orders it, then its phases and notes as JSON on the last line
RUN = """
import json, sys
from hexnewton import startup
startup.timed_imports("warp", "newton", "hexnewton.physics.world")
from dataclasses import replace
from hexnewton.physics.model_build import ModelBuild
from hexnewton.tasks import task
cfg = task("complex").env
cfg = replace(cfg, sim=replace(cfg.sim, num_envs=int(sys.argv[1]), device=sys.argv[2]))
build = ModelBuild(cfg, beside=True, scene_first=sys.argv[3] == "1")
startup.timed_imports("torch", "rsl_rl", "hexnewton.mdp.env", "hexnewton.learning.runner")
startup.mark("python and imports")
build.result()
print(json.dumps({"ready_s": startup.since_start(), "phases_s": startup.phases(), "notes": startup.notes()}))
"""


def measure(mode: str, num_envs: int, device: str) -> dict:
    done = subprocess.run([sys.executable, "-c", RUN, str(num_envs), device, "1" if MODES[mode] else "0"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    got = json.loads(done.stdout.strip().splitlines()[-1])
    return {"mode": mode, "ready_s": round(got["ready_s"], 2),
            "phases_s": {k: round(v, 2) for k, v in got["phases_s"].items()},
            "beside_s": got["notes"].get("model_build_beside_s", {}), "imports_s": got["notes"].get("imports_s", {})}


def _machine(device: str) -> str:
    """The CPU cores and, on a GPU, its name (nvidia-smi)."""
    if device.startswith("cuda"):
        done = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                              text=True)  # fmt: skip
        if done.returncode == 0:
            return f"{os.cpu_count()} CPU cores, {done.stdout.strip().splitlines()[0]}"
    return f"{os.cpu_count()} CPU cores"


def report(res: dict) -> str:
    lines = ["# The terrain and the scene first, the finalize beside the imports", "",
             f"`{res['command']}` ({res['machine']}; the complex task, {res['num_envs']} envs, device "
             f"{res['device']}). "
             "Each run a fresh process, in the order shown; the start-up as train.py orders it up to the model's "
             "being ready. Numbers: results.json.", "",
             "| run | mode | model ready [s] | imports after the build began [s] | terrain + scene [s] | the finalize "
             "[s] | the wait for it [s] |", "|---|---|---:|---:|---:|---:|---:|"]  # fmt: skip
    for k, r in enumerate(res["runs"], 1):
        ph, bs = r["phases_s"], r["beside_s"]
        main = ph.get("terrain", 0) + ph.get("scene", 0)
        side = bs.get("terrain", 0) + bs.get("scene", 0)
        before = ("warp", "newton", "hexnewton.physics.world")  # imported before the build began
        imports = sum(v for name, v in r["imports_s"].items() if name not in before)
        lines.append(f"| {k} | {r['mode']} | {r['ready_s']:.1f} | {imports:.1f} | {main + side:.1f} "
                     f"({'before the imports' if main else 'beside them'}) | {bs.get('finalize', 0):.1f} | "
                     f"{ph.get('model build', 0):.1f} |")  # fmt: skip
    means = {m: [r["ready_s"] for r in res["runs"] if r["mode"] == m] for m in MODES}
    if all(means.values()):
        a, b = (sum(v) / len(v) for v in means.values())
        lines += ["", f"Mean time to the model: scene_first {a:.1f} s, all_beside {b:.1f} s ({a - b:+.1f} s)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=int, default=2, help="runs per mode, alternating")
    p.add_argument("--num_envs", type=int, default=4096)
    p.add_argument("--device", default="cpu")
    p.add_argument("--out", help="folder for results.json and report.md")
    p.add_argument("--rebuild", metavar="DIR", help="report.md again from DIR/results.json")
    a = p.parse_args()
    if a.rebuild:
        with open(os.path.join(a.rebuild, "results.json")) as f:
            res = json.load(f)
    else:
        if not a.out or a.runs < 1:
            p.error("--out DIR and --runs >= 1 are needed")
        res = {"command": "python studies/startup_beside/scene_first.py " + " ".join(sys.argv[1:]),
               "machine": _machine(a.device), "num_envs": a.num_envs, "device": a.device, "runs": []}
        for _ in range(a.runs):
            for mode in MODES:
                res["runs"].append(measure(mode, a.num_envs, a.device))
                print(json.dumps(res["runs"][-1]), flush=True)
        os.makedirs(a.out, exist_ok=True)
        with open(os.path.join(a.out, "results.json"), "w") as f:
            json.dump(res, f, indent=1)
    with open(os.path.join(a.rebuild or a.out, "report.md"), "w") as f:
        f.write(report(res))


if __name__ == "__main__":
    main()
