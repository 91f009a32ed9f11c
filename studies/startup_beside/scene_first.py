"""The terrain and the scene first, only Newton's finalize beside the imports (``train.py``'s default,
``ModelBuild(beside=True, scene_first=True)``), against all three beside them (``--no-build_scene_first``): when the
model is ready, measured as ``train.py`` orders its start-up (warp, newton and the world imported, the build begun,
torch, rsl-rl, the env and the runner imported, then the model taken), in fresh processes one after another,
alternating, on this machine's CPU or GPU (the complex task, 4096 envs).

    python studies/startup_beside/scene_first.py --runs 2 --device cpu --out studies/startup_beside/scene_first
    python studies/startup_beside/scene_first.py --rebuild studies/startup_beside/scene_first   # report.md again
"""

from __future__ import annotations

import json
import subprocess
import sys

import alternate  # this study's shared runner (the script's folder is on sys.path)

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


def report(res: dict) -> str:
    lines = ["# The terrain and the scene first, the finalize beside the imports", "",
             f"`{res['command']}` ({res['machine']}; the complex task, {res['num_envs']} envs, device "
             f"{res['device']}). "
             "Each run a fresh process, in the order shown; the start-up as train.py orders it up to the model's "
             "being ready. Numbers: results.json.", "",
             *alternate.warmup_note(res, "ready_s", "the model ready at"),
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
    means = alternate.per_mode(res, "ready_s", MODES)
    if means:
        (a, _, _), (b, _, _) = means.values()
        lines += ["", f"Mean time to the model: scene_first {a:.1f} s, all_beside {b:.1f} s ({a - b:+.1f} s)."]
    return "\n".join(lines) + "\n"


def main() -> None:
    alternate.main("scene_first.py", __doc__, MODES, measure, report)


if __name__ == "__main__":
    main()
