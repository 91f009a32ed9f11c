"""Simulation throughput: robot-seconds simulated per wall-clock second, per terrain and env count.

    python -m hexnewton.bench                         # default device, all terrains, N = 1024 (64 on CPU)
    python -m hexnewton.bench --num_envs 1024 4096 16384 --terrain flat complex --device cuda
    python -m hexnewton.bench --append BENCHMARKS.md  # also append the table (date, device, git rev)

Every robot walks under the CPG controller (Eq. 3 + Eq. 4 kernels at every substep) with its own
parameters, the fixed baseline's scaled by a random factor in [0.7, 1.3], so contacts are those of walking.
The whole frame (CPG, mapping, collision, substeps) replays from one captured graph. Contact overflow is
checked after the timed frames and reported in the table.
"""

from __future__ import annotations

import datetime
import json
import os
import platform
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, replace

import numpy as np
import warp as wp

from .cli import ArgumentParser, positive_int, run, terrain_name
from .config import TERRAINS, HexConfig, SimConfig, TerrainConfig
from .controller import CPGController
from .sim import World, resolve_device


@dataclass
class BenchResult:
    terrain: str
    num_envs: int
    device: str
    frames: int
    wall_s: float
    robot_s_per_s: float
    robot_frames_per_s: float
    build_s: float
    capture_s: float
    overflow: str
    not_converged_worlds: int
    mean_forward_m: float
    upright_frac: float


def bench_one(terrain: str, num_envs: int, device: str, frames: int, sim: SimConfig, seed: int = 0) -> BenchResult:
    cfg = HexConfig(sim=replace(sim, num_envs=num_envs, device=device), terrain=TerrainConfig(name=terrain, seed=seed))
    t0 = time.perf_counter()
    world = World(cfg)
    rng = np.random.default_rng(seed)
    controller = CPGController(world)
    fixed = np.asarray(cfg.cpg.fixed_params())
    controller.set_params(fixed * rng.uniform(0.7, 1.3, (num_envs, fixed.size)))
    controller.reset()
    world.set_controller(controller)
    build_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    world.step(1)  # captures the graph
    wp.synchronize_device(world.device)
    capture_s = time.perf_counter() - t0
    world.step(max(frames // 10, 1))  # warm-up
    wp.synchronize_device(world.device)
    x0 = world.base_pos()[:, 0].copy()
    t0 = time.perf_counter()
    world.step(frames)
    wp.synchronize_device(world.device)
    wall = time.perf_counter() - t0
    report = world.check_contacts()
    q = world.numpy_q()
    up_z = 1.0 - 2.0 * (q[:, 3] ** 2 + q[:, 4] ** 2)  # body z-axis . world z
    return BenchResult(
        terrain=terrain,
        num_envs=num_envs,
        device=world.device,
        frames=frames,
        wall_s=wall,
        robot_s_per_s=num_envs * frames * world.frame_dt / wall,
        robot_frames_per_s=num_envs * frames / wall,
        build_s=build_s,
        capture_s=capture_s,
        overflow="none" if report.ok else report.describe(),
        not_converged_worlds=report.not_converged_worlds,
        mean_forward_m=float(np.nanmean(q[:, 0] - x0)),
        upright_frac=float(np.mean(up_z > 0.5)),
    )


def device_name(device: str) -> str:
    if device.startswith("cuda"):
        return wp.get_device(device).name
    return f"CPU ({platform.processor() or platform.machine()}, Warp CPU kernels single-threaded)"


def git_rev() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True).stdout.strip()  # fmt: skip
    except Exception:  # e.g. a copy of the tree without .git (the GPU machine)
        return os.environ.get("HEXNEWTON_GIT_REV", "unknown")


def table(results: list[BenchResult], sim: SimConfig, command: str) -> str:
    dev = device_name(results[0].device) if results else "?"
    head = (
        f"### Sim throughput, {datetime.date.today().isoformat()}, {dev}, git {git_rev()}\n\n"
        f"`{command}`  \nframe {sim.frame_dt * 1e3:g} ms = {sim.substeps} x {sim.frame_dt / sim.substeps * 1e3:g} ms "
        f"substeps, MuJoCo {sim.solver} solver {sim.iterations} it / {sim.ls_iterations} ls, gap {sim.rigid_gap} m\n\n"
        "| terrain | envs | robot-s/s | robot-frames/s | frames | forward in timed window [m] | upright | overflow |\n"
        "|---|---:|---:|---:|---:|---:|---:|---|\n"
    )
    rows = [
        f"| {r.terrain} | {r.num_envs} | {r.robot_s_per_s:,.0f} | {r.robot_frames_per_s:,.0f} | {r.frames} | "
        f"{r.mean_forward_m:.3f} | {r.upright_frac:.0%} | {r.overflow} |"
        for r in results
    ]
    return head + "\n".join(rows) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.bench", description=__doc__.split("\n")[0])
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--num_envs", type=positive_int, nargs="+", default=None)
    p.add_argument("--terrain", type=terrain_name, nargs="+", default=list(TERRAINS))
    p.add_argument("--frames", type=positive_int, default=None, help="timed physics frames (default 400 GPU, 100 CPU)")
    p.add_argument("--substeps", type=positive_int, default=SimConfig.substeps)
    p.add_argument("--iterations", type=positive_int, default=SimConfig.iterations)
    p.add_argument("--ls_iterations", type=positive_int, default=SimConfig.ls_iterations)
    p.add_argument("--frame_dt", type=float, default=SimConfig.frame_dt)
    p.add_argument("--append", metavar="PATH", help="append the markdown table to this file")
    p.add_argument("--json", metavar="PATH", help="write the raw results as JSON")
    args = p.parse_args(argv)

    device = resolve_device(args.device)
    gpu = device.startswith("cuda")
    envs = args.num_envs or ([1024] if gpu else [64])
    frames = args.frames or (400 if gpu else 100)
    sim = replace(SimConfig(), substeps=args.substeps, iterations=args.iterations, ls_iterations=args.ls_iterations,
                  frame_dt=args.frame_dt)  # fmt: skip
    command = "python -m hexnewton.bench " + " ".join(sys.argv[1:] if argv is None else argv)
    results = []
    for terrain in args.terrain:
        for n in envs:
            r = bench_one(terrain, n, device, frames, sim)
            print(f"{terrain:8s} N={n:6d} {r.robot_s_per_s:12,.0f} robot-s/s  ({r.robot_frames_per_s:,.0f} "
                  f"robot-frames/s, build {r.build_s:.1f} s, capture {r.capture_s:.1f} s, overflow: {r.overflow})",
                  flush=True)  # fmt: skip
            results.append(r)
    md = table(results, sim, command)
    print()
    print(md)
    if args.append:
        with open(args.append, "a") as f:
            f.write("\n" + md)
    if args.json:
        with open(args.json, "w") as f:
            json.dump([asdict(r) for r in results], f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.bench"))
