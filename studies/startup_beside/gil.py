"""How much of Newton's finalize of a task's model (the complex task's by default) needs the interpreter lock, on this
machine: the finalize alone, then in a thread beside a pure-Python loop in the main thread (as it runs beside
``train.py``'s imports); the loop's speed beside it against alone gives the seconds the finalize kept the lock from the
main thread, the finalize's seconds beside it against alone what the lock cost the finalize. Also train.py's heavy
imports alone in a fresh process (``startup.timed_imports``, its order), the finalize's costliest calls (cProfile, a
run alone) and NumPy's version: NumPy 2.3 and later find ``np.unique``'s values (without ``return_*``) through a hash
table, and Newton's ``compute_mesh_boundary_flags`` calls it once per finalize.

    python studies/startup_beside/gil.py --device cpu --num_envs 4096 --out studies/startup_beside/gil
    python studies/startup_beside/gil.py --rebuild studies/startup_beside/gil      # report.md from raw.json

Writes DIR/raw.json, DIR/report.md and DIR/results.json.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import os
import platform
import pstats
import subprocess
import sys
import threading
import time

#: seconds the loop runs alone to measure its speed
ALONE_S = 2.0
#: train.py's heavy imports, in its order (``startup.timed_imports``)
IMPORTS = ("warp", "newton", "hexnewton.physics.world", "torch", "rsl_rl", "hexnewton.mdp.env",
           "hexnewton.learning.runner")


def imports_alone() -> dict:
    """train.py's heavy imports in a fresh process with nothing beside them: each module's seconds and the process's."""
    code = ("import json; from hexnewton import startup; "
            f"print(json.dumps(startup.timed_imports(*{list(IMPORTS)!r})))")  # fmt: skip
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        sys.exit(f"gil.py: the imports exited {done.returncode}: {(done.stderr.strip().splitlines() or ['?'])[-1]}")
    return {"modules_s": json.loads(done.stdout.strip().splitlines()[-1]), "process_s": wall}


def spin_until(stop: threading.Event | None, seconds: float | None = None) -> tuple[int, float]:
    """A pure-Python loop until ``stop`` is set (or for ``seconds``): its iterations and its wall seconds."""
    n, t0 = 0, time.perf_counter()
    end = t0 + seconds if seconds is not None else None
    while (stop is None or not stop.is_set()) and (end is None or time.perf_counter() < end):
        for _ in range(1000):
            n += 1
    return n, time.perf_counter() - t0


def scene_of(name: str, num_envs: int, device: str):
    from dataclasses import replace

    from hexnewton.physics.model_build import build_scene
    from hexnewton.terrain import make_terrain
    from hexnewton.tasks import task

    cfg = task(name).env
    cfg = replace(cfg, sim=replace(cfg.sim, num_envs=num_envs, device=device))
    return build_scene(cfg, make_terrain(cfg.terrain))[0]


def finalize(scene, device: str) -> float:
    import warp as wp

    t0 = time.perf_counter()
    with wp.ScopedDevice(device):
        scene.finalize(device=device)
    return time.perf_counter() - t0


def measure(args) -> dict:
    imports = imports_alone()
    import numpy as np
    import warp as wp

    wp.init()
    finalize(scene_of(args.task, 16, args.device), args.device)  # the finalize's Warp modules loaded, not timed
    n, s = spin_until(None, ALONE_S)
    rate_alone = n / s
    alone = finalize(scene_of(args.task, args.num_envs, args.device), args.device)
    scene = scene_of(args.task, args.num_envs, args.device)
    stop, out = threading.Event(), {}

    def build():
        out["s"] = finalize(scene, args.device)
        stop.set()

    th = threading.Thread(target=build)
    th.start()
    n, s = spin_until(stop)
    th.join()
    prof = cProfile.Profile()
    scene = scene_of(args.task, args.num_envs, args.device)
    prof.enable()
    profiled = finalize(scene, args.device)
    prof.disable()
    stats = pstats.Stats(prof).stats
    top = sorted(((v[2], k[2] if k[0] == "~" else f"{os.path.basename(k[0])}:{k[2]}") for k, v in stats.items()),
                 reverse=True)[:10]  # fmt: skip
    gpu = "cpu"
    if args.device.startswith("cuda"):
        gpu = wp.get_device(args.device).name
    from hexnewton.analysis.report import git_rev

    return {"command": " ".join(["python", *sys.argv]), "revision": git_rev(), "device": gpu,
            "cpus": os.cpu_count(), "machine": platform.processor() or platform.machine(), "numpy": np.__version__,
            "task": args.task, "num_envs": args.num_envs, "finalize_alone_s": alone, "finalize_beside_s": out["s"],
            "loop_alone_per_s": rate_alone, "loop_beside_per_s": n / s, "loop_beside_s": s,
            "profiled_s": profiled, "top_self_s": [[name, secs] for secs, name in top],
            "imports_alone": imports}  # fmt: skip


def summarize(raw: dict) -> dict:
    """The loop's share of its speed beside the finalize and the seconds the finalize kept the lock from it."""
    share = raw["loop_beside_per_s"] / raw["loop_alone_per_s"]
    return {k: raw[k] for k in ("command", "revision", "device", "cpus", "numpy", "task", "num_envs",
                                "finalize_alone_s", "finalize_beside_s")} | {
        "loop_speed_beside": share, "lock_held_s": raw["loop_beside_s"] * (1 - share),
        "hash_unique_s": sum(s for name, s in raw["top_self_s"] if "_unique_hash" in name),
        "imports_alone_s": sum(raw["imports_alone"]["modules_s"].values())}  # fmt: skip


def report(raw: dict, res: dict) -> str:
    lines = ["# Newton's finalize and the interpreter lock", "",
             f"`{res['command']}` (device {res['device']}, {res['cpus']} CPUs, NumPy {res['numpy']}, code "
             f"{res['revision']}): the {res['task']} task's model, {res['num_envs']} envs, each finalize of a scene "
             "built anew. Numbers: results.json.", "",
             "| measure | value |", "|---|---:|",
             f"| the finalize alone [s] | {res['finalize_alone_s']:.2f} |",
             f"| the finalize beside a pure-Python loop [s] | {res['finalize_beside_s']:.2f} |",
             f"| the loop's speed beside it, of its speed alone | {100 * res['loop_speed_beside']:.0f} % |",
             f"| seconds the finalize kept the lock from the loop (its lost share of the time) | "
             f"{res['lock_held_s']:.2f} |",
             f"| NumPy's hash-table unique in the profiled finalize [s] | {res['hash_unique_s']:.2f} |",
             f"| train.py's heavy imports alone, a fresh process [s] | {res['imports_alone_s']:.2f} |", "",
             f"The profiled finalize ({raw['profiled_s']:.2f} s) by its calls' own time:", "",
             "| call | s |", "|---|---:|"]  # fmt: skip
    lines += [f"| `{name}` | {secs:.2f} |" for name, secs in raw["top_self_s"]]
    lines += ["", f"The imports alone (a fresh process, {raw['imports_alone']['process_s']:.2f} s in all), each with "
              "what it needs that is not loaded yet:", "", "| module | s |", "|---|---:|"]
    lines += [f"| `{m}` | {s:.2f} |" for m, s in raw["imports_alone"]["modules_s"].items()]
    return "\n".join(lines) + "\n"


def write(folder: str, raw: dict) -> None:
    res = summarize(raw)
    with open(os.path.join(folder, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(folder, "report.md"), "w") as f:
        f.write(report(raw, res))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--out", help="folder for raw.json, report.md, results.json")
    p.add_argument("--rebuild", help="a folder whose raw.json to report again")
    p.add_argument("--device", default="cpu")
    p.add_argument("--num_envs", type=int, default=4096)
    p.add_argument("--task", default="complex", help="the task whose model is finalized")
    args = p.parse_args(argv)
    if args.rebuild:
        path = os.path.join(args.rebuild, "raw.json")
        if not os.path.exists(path):
            print(f"gil.py: no {path}", file=sys.stderr)
            return 2
        with open(path) as f:
            write(args.rebuild, json.load(f))
        return 0
    if not args.out:
        print("gil.py: --out DIR or --rebuild DIR", file=sys.stderr)
        return 2
    os.makedirs(args.out, exist_ok=True)
    raw = measure(args)
    with open(os.path.join(args.out, "raw.json"), "w") as f:
        json.dump(raw, f, indent=1)
    write(args.out, raw)
    return 0


if __name__ == "__main__":
    sys.exit(main())
