"""What the navigate tasks' terrain patch costs at start-up: the square that holds every goal (``tasks.navigation_terrain``)
as its collision mesh (triangles, vertices), ``make_terrain`` and Newton's ``ModelBuilder.finalize`` on this machine's
CPU, beside the rugged task's own curriculum terrain (10 lanes of 3 m) measured the same way.

    python3 studies/navigate/mesh_cost.py [--out studies/navigate/mesh]

Each case runs in a fresh process (``--one NAME``): ``navigate-rugged`` as the task builds it (collision "mesh_boxes",
watertight off), the same patch watertight (``TerrainConfig.watertight``, which skips finalize's mesh-boundary pass),
``navigate-flat`` (an infinite plane) and ``rugged``, the paper task's curriculum terrain. Writes ``results.json`` and
``report.md`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import time
from dataclasses import replace

CASES = {"navigate-rugged": ("navigate-rugged", False), "navigate-rugged watertight": ("navigate-rugged", True),
         "navigate-flat": ("navigate-flat", False), "rugged (curriculum, 10 lanes)": ("rugged", False)}  # fmt: skip


def _one(case: str) -> dict:
    import newton
    import warp as wp

    from hexnewton.physics.private_api import time_mesh_boundary_flags
    from hexnewton.terrain import make_terrain
    from hexnewton.tasks import task

    wp.init()
    boundary = []
    time_mesh_boundary_flags(boundary)  # Newton's ModelBuilder.finalize computes them per mesh shape
    name, watertight = CASES[case]
    cfg = replace(task(name).env.terrain, watertight=watertight)
    t0, c0 = time.perf_counter(), time.process_time()
    terrain = make_terrain(cfg)
    make_s, make_cpu = time.perf_counter() - t0, time.process_time() - c0
    builder = newton.ModelBuilder()
    first = terrain.add_to_builder(builder, newton.ModelBuilder.ShapeConfig())
    meshes = [builder.shape_source[s] for s in range(first, builder.shape_count)
              if builder.shape_type[s] == newton.GeoType.MESH]  # fmt: skip
    t0, c0 = time.perf_counter(), time.process_time()
    builder.finalize(device="cpu")
    fin, fin_cpu = time.perf_counter() - t0, time.process_time() - c0
    g = terrain.grid
    return {"case": case, "task": name, "watertight": watertight, "collision": cfg.collision,
            "patch_m": [round(g.x1 - g.x0, 3), round(g.y1 - g.y0, 3)], "grid_cells": int(g.nx * g.ny),
            "mesh_shapes": len(meshes), "triangles": int(sum(len(m.indices) // 3 for m in meshes)),
            "vertices": int(sum(len(m.vertices) for m in meshes)), "static_shapes": int(builder.shape_count),
            "make_terrain_s": round(make_s, 2), "make_terrain_cpu_s": round(make_cpu, 2),
            "finalize_s": round(fin, 2), "finalize_cpu_s": round(fin_cpu, 2),
            "boundary_pass_cpu_s": round(sum(boundary), 2), "height_grid_mb": round(g.heights.nbytes / 2**20, 1),
            "peak_rss_mb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 0),
            "load_average_1min": round(os.getloadavg()[0], 1)}  # fmt: skip


def _report(rows: list[dict], command: str, machine: str) -> str:
    by = {r["case"]: r for r in rows}
    nav, cur = by.get("navigate-rugged"), by.get("rugged (curriculum, 10 lanes)")
    lines = ["# The navigate tasks' terrain patch: its mesh cost at start-up (CPU)", "",
             f"Command: `{command}` ({machine}). Numbers: `results.json`.", "",
             "The navigate tasks' goals lie anywhere within +-4 m of each robot's start (`TaskConfig.goal_area`), so "
             "their terrain is one square patch around the starts (`hexnewton.tasks.navigation_terrain`: +-5 m along x, "
             "+-5.6 m along y for the starts' 0.6 m spread, a metre beyond the goals), not the curriculum's 3 m lanes; "
             "on `navigate-rugged` the 2 cm blocks (0-6 cm) cover all of it. One run each in a fresh process; CPU "
             "seconds of the process (all threads) and, in brackets, wall seconds (the 2 cores were shared: load is the "
             "1-minute load average).", "",
             "| case | patch [m] | mesh shapes | triangles | vertices | make_terrain CPU s (wall) | finalize CPU s (wall) "
             "| boundary pass CPU s | height grid [MB] | peak RSS [MB] | load |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in rows:
        lines.append(f"| {r['case']} | {r['patch_m'][0]:g} x {r['patch_m'][1]:g} | {r['mesh_shapes']} | "
                     f"{r['triangles']:,} | {r['vertices']:,} | {r['make_terrain_cpu_s']} ({r['make_terrain_s']}) | "
                     f"{r['finalize_cpu_s']} ({r['finalize_s']}) | {r['boundary_pass_cpu_s']} | {r['height_grid_mb']} | "
                     f"{r['peak_rss_mb']:.0f} | {r['load_average_1min']} |")  # fmt: skip
    if nav and cur:
        lines += ["", f"The navigate-rugged patch ({nav['patch_m'][0]:g} x {nav['patch_m'][1]:g} m) has "
                  f"{nav['triangles'] / max(cur['triangles'], 1):.2f}x the triangles of the rugged task's curriculum "
                  f"terrain ({cur['patch_m'][0]:g} x {cur['patch_m'][1]:g} m of lanes) and its finalize takes "
                  f"{nav['finalize_cpu_s'] / max(cur['finalize_cpu_s'], 1e-9):.2f}x the CPU time: a start-up cost the "
                  "rugged task already pays. The watertight mesh (`--env.terrain.watertight true`, off until its A/B "
                  f"on evaluation rounds) would cut the finalize to {by['navigate-rugged watertight']['finalize_cpu_s']} "
                  "CPU s for 1.56x the triangles. On the GPU host the finalize runs on its CPU beside the imports "
                  "(studies/startup_mesh/report.md: 9.7-11 s of a 34-42 s start-up on the H200 for the complex "
                  "curriculum's 1.1 M faces)." if "navigate-rugged watertight" in by else "rugged task already pays."]
    lines += ["", "## On the GPU (not run here)", "",
              "The start-up phases of `python train.py --task navigate-rugged` (terrain, scene, finalize, first step) "
              "come with the run's `timing.json`: studies/navigate/README.md has the commands."]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "mesh"))
    ap.add_argument("--cases", nargs="+", default=list(CASES), choices=list(CASES))
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--render", action="store_true", help="rewrite report.md from --out's results.json, no runs")
    args = ap.parse_args()
    if args.one:
        print("ROW " + json.dumps(_one(args.one)))
        return
    if args.render:
        with open(os.path.join(args.out, "results.json")) as f:
            saved = json.load(f)
        with open(os.path.join(args.out, "report.md"), "w") as f:
            f.write(_report(saved["rows"], saved["command"], saved["machine"]))
        return
    rows = []
    for case in args.cases:
        out = subprocess.run([sys.executable, __file__, "--one", case], check=True, capture_output=True, text=True)
        rows.append(json.loads(next(line for line in out.stdout.splitlines() if line.startswith("ROW "))[4:]))
        print(json.dumps(rows[-1]), flush=True)
    command = ("python3 studies/navigate/mesh_cost.py " + " ".join(sys.argv[1:])).strip()
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPU cores, no GPU (device cpu)"
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"command": command, "machine": machine, "rows": rows}, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(_report(rows, command, machine))


if __name__ == "__main__":
    main()
