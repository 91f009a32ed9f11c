"""Start-up cost of the terrain's collision mesh, today's against the watertight one (``TerrainConfig.watertight``,
issue 70): mesh build, triangle and vertex counts, ``ModelBuilder.finalize`` and its mesh-boundary pass, on this
machine's CPU.

    python3 studies/startup_mesh/measure.py [--out studies/startup_mesh] [--terrains complex rugged stepped]

Each terrain runs in a fresh process (``--one NAME``), its config as the task of that name uses it (``task(name)``:
the complex course's curriculum, collision "mesh_boxes"), each with collision "mesh_boxes" (the default: the rugged
blocks as meshes) and "mesh" (one mesh of the whole grid), watertight off and on. Writes ``results.json`` and
``report.md`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import time
from dataclasses import replace


def _one(name: str) -> list[dict]:
    import newton
    import numpy as np
    import warp as wp

    from hexnewton.physics.private_api import time_mesh_boundary_flags
    from hexnewton.terrain import build_height_grid, make_terrain
    from hexnewton.terrain.mesh import _merge_close_heights, grid_to_mesh
    from hexnewton.tasks import task

    wp.init()
    boundary_s = []
    time_mesh_boundary_flags(boundary_s)  # Newton's ModelBuilder.finalize computes them per mesh shape
    base = task(name).env.terrain
    grid = build_height_grid(base)
    h = grid.heights.astype(np.float32)
    padded = np.pad(h, 1, constant_values=np.float32(h.min() - 0.1))
    moved = (_merge_close_heights(padded) - padded)[1:-1, 1:-1]
    merged, change = int((moved != 0).sum()), float(np.abs(moved).max())  # cells the watertight mesh lowers
    rows = []
    for collision in ("mesh_boxes", "mesh"):
        for watertight in (False, True):
            cfg = replace(base, collision=collision, watertight=watertight)
            t0, c0 = time.perf_counter(), time.process_time()
            grid_to_mesh(grid, watertight=watertight)
            mesh_build, mesh_build_cpu = time.perf_counter() - t0, time.process_time() - c0
            t0 = time.perf_counter()
            terrain = make_terrain(cfg)
            make_s = time.perf_counter() - t0
            builder = newton.ModelBuilder()
            t0 = time.perf_counter()
            first = terrain.add_to_builder(builder, newton.ModelBuilder.ShapeConfig())
            add_s = time.perf_counter() - t0
            meshes = [builder.shape_source[s] for s in range(first, builder.shape_count)
                      if builder.shape_type[s] == newton.GeoType.MESH]  # fmt: skip
            boundary_s.clear()
            t0, c0 = time.perf_counter(), time.process_time()
            model = builder.finalize(device="cpu")
            fin, fin_cpu = time.perf_counter() - t0, time.process_time() - c0
            starts = model._shape_mesh_boundary_start.numpy()[first:]
            rows.append({
                "terrain": name, "collision": collision, "watertight": watertight,
                "grid": list(grid.heights.shape),
                "full_mesh_build_s": round(mesh_build, 2), "full_mesh_build_cpu_s": round(mesh_build_cpu, 2), "make_terrain_s": round(make_s, 2),
                "add_to_builder_s": round(add_s, 2), "finalize_s": round(fin, 2), "finalize_cpu_s": round(fin_cpu, 2),
                "boundary_flags_cpu_s": round(sum(boundary_s), 2),
                "load_average_1min": round(os.getloadavg()[0], 1), "boundary_flag_meshes": len(boundary_s),
                "mesh_shapes": len(meshes), "all_watertight": all(m.is_watertight for m in meshes),
                "collision_vertices": int(sum(len(m.vertices) for m in meshes)),
                "collision_triangles": int(sum(len(m.indices) // 3 for m in meshes)),
                "full_mesh_vertices": len(terrain.mesh.vertices), "full_mesh_triangles": len(terrain.mesh.indices) // 3,
                "shapes_without_boundary_bits": int((starts[: len(meshes)] < 0).sum()) if len(meshes) else 0,
                "merged_cells": merged if watertight else 0, "max_height_change_m": change if watertight else 0.0,
            })  # fmt: skip
            print(json.dumps(rows[-1]), flush=True)
            del model, builder, terrain
    return rows


def _report(rows: list[dict], command: str, machine: str) -> str:
    lines = [
        "# Start-up: a watertight terrain mesh (issue 70, CPU part)",
        "",
        f"Command: `{command}` ({machine}). Numbers: `results.json`.",
        "",
        "`TerrainConfig.watertight` (off by default) builds the terrain meshes without T-junctions: every quad edge",
        "split at the vertices on it, each quad cut into N - 2 triangles (N: its corners and split points), plus one",
        "vertex halfway up the vertical edge of each saddle corner, where four walls meet (hexnewton/terrain/",
        "mesh.py). Newton's `Mesh.is_watertight` then holds and `ModelBuilder.finalize` skips",
        "`compute_mesh_boundary_flags`. One run each; CPU seconds of the process (all threads) and, in brackets, wall",
        "seconds. The machine was shared with other jobs (load: its 1-minute load average on 2 cores), so wall times",
        "run up to 3-4x the idle ones; CPU times are the steadier measure.",
        "",
        "| terrain | collision | watertight | mesh shapes | triangles | vertices | finalize CPU s (wall) |"
        + " boundary pass CPU s | full-mesh build CPU s (wall) | full mesh triangles | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['terrain']} | {r['collision']} | {'on' if r['watertight'] else 'off'} | {r['mesh_shapes']} | "
            f"{r['collision_triangles']:,} | {r['collision_vertices']:,} | {r['finalize_cpu_s']} ({r['finalize_s']}) | "
            f"{r['boundary_flags_cpu_s']} | {r['full_mesh_build_cpu_s']} ({r['full_mesh_build_s']}) | "
            f"{r['full_mesh_triangles']:,} | {r['load_average_1min']} |"
        )
    by = {(r["terrain"], r["collision"], r["watertight"]): r for r in rows}
    lines += [
        "",
        "`collision` \"mesh_boxes\" is what the tasks use (the rugged blocks as meshes, the strips as boxes; with the",
        "curricula's 10 lanes the blocks make one mesh of nearly the whole grid); \"mesh\" is one mesh of the whole",
        "grid. The whole-grid mesh (`Terrain.mesh`, the last column) is built on first use: \"mesh_boxes\" never",
        "adds it to the builder, so a task's start-up does not pay that column. The part meshes (add_to_builder wall s,",
        "off -> on: "
        + ", ".join(f"{t} {by[(t, 'mesh_boxes', False)]['add_to_builder_s']} -> {by[(t, 'mesh_boxes', True)]['add_to_builder_s']}"
                    for t in ("complex", "rugged") if (t, "mesh_boxes", False) in by)
        + ").",
        "",
        "Cells lowered by the watertight mesh (neighbours closer than 1 um put at the lower height, <= 1e-6 m): "
        + ", ".join(f"{t} {by[(t, 'mesh', True)]['merged_cells']}" for t in ("complex", "rugged", "stepped")
                    if (t, "mesh", True) in by) + ".",
        "",
        "Where the extra triangles are (complex, whole grid, triangles counted by normal direction, a separate count"
        + " not redone by this script): tops 375,118 -> 376,610 (+0.4 %),",
        "walls 753,500 -> 1,376,610 (+83 %: their vertical edges split at the neighbouring blocks' heights), bottom",
        "2 -> 1,770. The feet's surface keeps its triangulation almost everywhere; the longest top triangles (fans",
        "across long strips) reach an aspect ratio of ~1,800 against 12 today.",
        "",
        "## What Newton's watertight path changes (Newton 1.8.0)",
        "",
        "- `finalize`: `Mesh.is_watertight` -> `MeshProperties.WATERTIGHT`; no `compute_mesh_boundary_flags`",
        "  (`_shape_mesh_boundary_start` -1).",
        "- At run time `resolve_mesh_sign_method` signs mesh distances by ray parity instead of pseudo-normals (with",
        "  the boundary bits). Only the mesh-SDF kernels read it: mesh-mesh contacts and particle (soft) contacts. The",
        "  hexapod's shapes are a box, capsules and spheres, whose contacts with a mesh go through the per-triangle",
        "  narrow phase, which reads neither; so the robot's contact signs do not change. What does change is the",
        "  triangulation (the triangle pairs per foot, `SimConfig.triangle_pairs_per_env`, and the contact points per",
        "  triangle): the A/B must watch contact/pair overflows and the physics-alone rate as well as quality.",
        "- A mesh SDF built from it (`Mesh.build_sdf`, not used here) would take the parity sign.",
        "",
        "## Still to run (not run here)",
        "",
        "- The GPU host's start-up and physics rate with it (finalize 9.7-11 s of a 34-42 s start-up on the H200):",
        "  `python train.py --task complex --max_iterations 1` against the same with `--env.terrain.watertight true`",
        "  (timing.json); `python -m hexnewton.apps.bench --device cuda --num_envs 16384 --mode sim --frames 200",
        "  --env.sim.frame_dt 0.02 --env.sim.substeps 4 --terrain complex stepped rugged` with and without",
        "  `--env.terrain.watertight true`.",
        "- The A/B on evaluation rounds that issue 70 asks before it may be switched on: 1000 test rounds per terrain,",
        "  the same seeds (evaluate's default `--seed`), success within 1 point, falls within 0.5 points:",
        "  (the shipped policy; add one `--checkpoint cpg_rl:TERRAIN=PATH` per terrain for per-terrain policies)",
        "  `python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint cpg_rl=results/policies/cpg_rl_complex.pt",
        "  --terrains rugged stepped complex --rounds 1000 --device cuda --out eval/watertight_off`, and the same with",
        "  `--env.terrain.watertight true --out eval/watertight_on`.",
    ]
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    ap.add_argument("--terrains", nargs="+", default=["complex", "rugged", "stepped"])
    ap.add_argument("--one", help=argparse.SUPPRESS)
    ap.add_argument("--render", action="store_true", help="rewrite report.md from --out's results.json, no runs")
    args = ap.parse_args()
    if args.one:
        print("ROWS " + json.dumps(_one(args.one)))
        return
    if args.render:
        with open(os.path.join(args.out, "results.json")) as f:
            saved = json.load(f)
        with open(os.path.join(args.out, "report.md"), "w") as f:
            f.write(_report(saved["rows"], saved["command"], saved["machine"]))
        return
    rows = []
    for name in args.terrains:
        out = subprocess.run([sys.executable, __file__, "--one", name], check=True, capture_output=True, text=True)
        rows += json.loads(next(line for line in out.stdout.splitlines() if line.startswith("ROWS "))[5:])
        print(f"{name}: done", flush=True)
    command = "python3 studies/startup_mesh/measure.py " + " ".join(sys.argv[1:])
    machine = f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPU cores, no GPU (device cpu)"
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"command": command.strip(), "machine": machine, "rows": rows}, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(_report(rows, command.strip(), machine))


if __name__ == "__main__":
    main()
