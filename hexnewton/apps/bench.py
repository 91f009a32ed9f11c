"""Throughput: simulation, env-step and end-to-end training, per terrain and env count.

    python -m hexnewton.apps.bench                         # default device, all terrains, N = 1024 (64 on CPU)
    python -m hexnewton.apps.bench --num_envs 1024 4096 16384 --terrain flat complex --device cuda
    python -m hexnewton.apps.bench --mode sim              # simulation only
    python -m hexnewton.apps.bench --mode sim --robot mx_phoenix --terrain rugged   # another robot (docs/robots.md)
    python -m hexnewton.apps.bench --mode sim --terrain stepped --env.terrain.collision mesh_boxes  # terrain settings
    python -m hexnewton.apps.bench --append studies/throughput/report.md  # the table appended (date, device, git)
    python -m hexnewton.apps.bench --task complex --mode train --num_envs 4096    # the complex task's physics, learner
    torchrun --standalone --nproc_per_node=4 -m hexnewton.apps.bench --task complex --mode train --num_envs 4096 \
        --baseline bench_1gpu.json --json bench_4gpu.json  # 4096 envs on each of 4 GPUs; efficiency vs 1 GPU

Under torchrun each rank measures on its own GPU (``cuda:LOCAL_RANK``; ``--device cpu``: Gloo on the CPU), every timed
window starting together (a barrier), train mode averaging the ranks' gradients as ``train.py`` does; rank 0 gathers
the ranks' rates and writes the tables: the total (their sum) and, with ``--baseline`` (a 1-GPU run's ``--json``), the
scaling efficiency, total / (GPUs x the 1-GPU rate) (:mod:`hexnewton.analysis.scaling`).

Three measurements, each in robot-seconds simulated per wall second (robot-s/s) so they compare directly:
- ``sim``: the physics world alone. Every robot walks under the CPG controller (Eq. 3 + Eq. 4 kernels at
  every substep) with its own parameters: the fixed baseline's, scaled by a random factor in [0.7, 1.3],
  so the contacts are those of walking. The whole frame (CPG, mapping, collision, substeps) replays from one
  captured graph. Contact overflow is checked after the timed frames and reported.
- ``env``: ``HexapodEnv.step`` with random actions: the parameter, CPG, physics, termination, reward, reset
  and observation kernels, plus the torch hand-off. Also reported as env-steps/s (one env-step is one
  20 ms control step).
- ``train``: ``OnPolicyRunner.learn`` with the ``default`` preset: rollout collection plus the PPO update.
  Also reported as env-steps/s, with the device memory per env on CUDA (torch's peak plus Warp's
  allocations, read from the driver).
"""

from __future__ import annotations

import contextlib
import datetime
import io
import json
import os
import sys
from dataclasses import asdict, replace

from hexnewton.analysis.bench import (
    PHASES,
    BenchResult,
    PipelineResult,
    bench_one,
    bench_pipeline,
    device_name,
    largest_that_fits,
)
from hexnewton.analysis.report import git_rev
from hexnewton.analysis.scaling import rate_rows, scaling_markdown, scaling_rows, with_ranks
from hexnewton.apps.cli import (
    ArgumentParser,
    add_config_args,
    add_robot_args,
    config_overrides,
    positive_int,
    robot_from_args,
    run,
    terrain_name,
)
from hexnewton.config import TERRAINS, SimConfig, TerrainConfig, apply_overrides
from hexnewton.learning.agent import AgentConfig
from hexnewton.terrain import validate_config


def pipeline_table(sim_results: list[BenchResult], results: list[PipelineResult]) -> str:
    """Sim, env-step and training throughput side by side (robot-s/s) with their ratios to sim-only."""
    sim = {(r.terrain, r.num_envs): r.robot_s_per_s for r in sim_results}
    head = ("| terrain | envs | sim robot-s/s | env-step robot-s/s (env-steps/s) | env / sim | training robot-s/s "
            "(env-steps/s) | training / sim | s per iteration | memory per env |\n"
            "|---|---:|---:|---:|---:|---:|---:|---:|---:|\n")  # fmt: skip

    def num(v, fmt="{:,.0f}"):
        return "—" if v != v else fmt.format(v)

    def ratio(a, b):
        return "—" if a != a or b != b or not b else f"{a / b:.0%}"

    rows = []
    for r in results:
        s = sim.get((r.terrain, r.num_envs), float("nan"))
        rows.append(f"| {r.terrain} | {r.num_envs} | {num(s)} | {num(r.env_robot_s_per_s)} ({num(r.env_steps_per_s)}) | "
                    f"{ratio(r.env_robot_s_per_s, s)} | {num(r.train_robot_s_per_s)} ({num(r.train_steps_per_s)}) | "
                    f"{ratio(r.train_robot_s_per_s, s)} | {num(r.train_iteration_s, '{:.2f}')} | "
                    f"{num(r.memory_per_env_kb, '{:,.0f} KB')} |")  # fmt: skip
    return head + "\n".join(rows) + "\n"


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


def parser() -> ArgumentParser:
    """The command line of ``python -m hexnewton.apps.bench``."""
    p = ArgumentParser(prog="python -m hexnewton.apps.bench", description=__doc__.split("\n")[0])
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu; under "
                   "torchrun cuda:LOCAL_RANK)")
    from hexnewton.tasks import TASKS

    p.add_argument("--task", choices=list(TASKS), default=None,
                   help="take this task's physics, terrain settings and learner (default: the configs' defaults); "
                        "--terrain defaults to its terrain")  # fmt: skip
    p.add_argument("--num_envs", type=positive_int, nargs="+", default=None)
    p.add_argument("--terrain", type=terrain_name, nargs="+", default=None, help="default: every terrain (with "
                   "--task: its own)")
    p.add_argument("--frames", type=positive_int, default=None, help="timed physics frames (default 400 GPU, 100 CPU)")
    p.add_argument("--mode", nargs="+", choices=["sim", "env", "train"], default=["sim", "env", "train"])
    p.add_argument("--env_steps", type=positive_int, default=None, help="timed env steps (default 200 GPU, 25 CPU)")
    p.add_argument("--train_iterations", type=positive_int, default=None, help="timed PPO iterations (default 10 GPU, 2 CPU)")
    p.add_argument("--profile", action="store_true",
                   help="with train mode: time each phase of an iteration (env step, policy, storage, logger, "
                        "returns, PPO update)")  # fmt: skip
    p.add_argument("--largest", action="store_true",
                   help="sim-only: double the largest --num_envs until the device runs out of memory")
    p.add_argument("--append", metavar="PATH", help="append the markdown table to this file")
    p.add_argument("--json", metavar="PATH", help="write the raw results as JSON (with every rank's rates)")
    p.add_argument("--baseline", metavar="PATH",
                   help="a 1-GPU run's --json: the scaling efficiency of this run's rates against it")
    add_robot_args(p, "the paper's")
    add_config_args(p, "env.sim", SimConfig(), skip=("num_envs", "device"),
                    title="--env.sim.*: the physics (SimConfig), as train.py's")
    add_config_args(p, "env.terrain", TerrainConfig(), skip=("name", "seed"),
                    title="--env.terrain.*: the terrain's other settings (TerrainConfig; --terrain names it)")
    add_config_args(p, "agent", AgentConfig(), title="--agent.*: train mode's learner (AgentConfig), as train.py's")
    return p


def profile_table(profiles: list[dict]) -> str:
    """The training phases' time per iteration (``--profile``), one row per terrain and env count."""
    md = "| terrain | envs | " + " | ".join(name for name, _, _ in PHASES) + " | other |\n"
    md += "|---|---:|" + "---:|" * (len(PHASES) + 1) + "\n"
    for pr in profiles:
        md += f"| {pr['terrain']} | {pr['num_envs']} | " + " | ".join(
            f"{pr[name] * 1e3:.1f} ms" for name in [p[0] for p in PHASES] + ["other"]) + " |\n"  # fmt: skip
    return md


def markdown(results: list[BenchResult], pipeline: list[PipelineResult], profiles: list[dict], sim: SimConfig,
             command: str, device: str) -> str:
    """Every table of a run: sim-only (or a heading without one), env-step and training, phases."""
    md = table(results, sim, command) if results else (f"### Throughput, {datetime.date.today().isoformat()}, "
                                                        f"{device_name(device)}, git {git_rev()}\n\n`{command}`\n\n")
    if pipeline:
        md += "\n" + pipeline_table(results, pipeline)
    if profiles:
        md += "\n" + profile_table(profiles)
    return md


def settings(args):
    """The run's physics, terrain settings, learner and env base: ``--task``'s (or the defaults) with the command
    line's ``--env.sim.*``, ``--env.terrain.*`` and ``--agent.*`` on top, and the terrains to measure."""
    from hexnewton.config import HexConfig
    from hexnewton.tasks import task

    base = task(args.task) if args.task else None
    env, agent = (base.env, base.agent) if base else (HexConfig(), AgentConfig())
    robot = robot_from_args(args)
    if robot is not None:  # the robot and its scales in the env base the measurements build from
        from hexnewton.robot.registry import with_robot

        env = with_robot(env, robot)
    agent = apply_overrides(agent, config_overrides(args, "agent"))
    sim = apply_overrides(env.sim, config_overrides(args, "env.sim"))
    ground = apply_overrides(env.terrain, config_overrides(args, "env.terrain"))
    terrains = args.terrain or ([env.terrain.name] if base else list(TERRAINS))
    for name in terrains:
        validate_config(replace(ground, name=name))
    return sim, ground, agent, (env if base or robot else None), terrains


def measure(args, device: str, rank, sim, ground, agent, base, terrains):
    """Every asked measurement on this rank, printed as it is made: sim-only, env-step and training results, phases."""
    gpu = device.startswith("cuda")
    envs = args.num_envs or ([1024] if gpu else [64])
    frames = args.frames or (400 if gpu else 100)
    env_steps = args.env_steps or (200 if gpu else 25)
    iterations = args.train_iterations or (10 if gpu else 2)
    results, pipeline, profiles = [], [], []
    for terrain in terrains:
        for n in envs:
            if "sim" in args.mode:
                r = bench_one(terrain, n, device, frames, sim, ground=ground, base=base)
                print(f"{terrain:8s} N={n:6d} sim   {r.robot_s_per_s:12,.0f} robot-s/s  ({r.robot_frames_per_s:,.0f} "
                      f"robot-frames/s, build {r.build_s:.1f} s, capture {r.capture_s:.1f} s, overflow: {r.overflow})",
                      flush=True)  # fmt: skip
                results.append(r)
            if "env" in args.mode or "train" in args.mode:
                pr, prof = bench_pipeline(terrain, n, device, args.mode, env_steps, iterations, args.profile, sim,
                                          agent, ground, rank, base)  # fmt: skip
                if prof is not None:
                    profiles.append({"terrain": terrain, "num_envs": n, **prof})
                pipeline.append(pr)
        if args.largest:
            results += largest_that_fits(terrain, max(envs), device, frames, sim, ground=ground, base=base)
    return results, pipeline, profiles


def check_outputs(args) -> dict | None:
    """Fail before any simulation on outputs that could not be written or a baseline that is not a 1-GPU bench
    JSON; returns the baseline (None without one)."""
    from hexnewton.apps.cli import check_writable

    if args.json:
        check_writable(args.json, ".json")
    if not args.baseline:
        return None
    try:
        with open(args.baseline) as f:
            baseline = json.load(f)
    except (OSError, ValueError) as exc:
        raise ValueError(f"--baseline {args.baseline}: {exc}")
    if baseline.get("world_size") != 1 or "ranks" not in baseline:
        raise ValueError(f"--baseline {args.baseline}: not a 1-GPU hexnewton-bench --json (world_size 1, ranks)")
    return baseline


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    baseline = check_outputs(args)
    sim, ground, agent, base, terrains = settings(args)
    from hexnewton.learning.ranks import distributed_rank
    from hexnewton.learning.runner import close_group, gather_floats, init_group
    from hexnewton.physics.device import resolve_device

    rank = distributed_rank(dict(os.environ), args.device)
    if rank.world_size > 1 and args.largest:
        raise ValueError("--largest runs in one process (each rank would stop at its own env count): leave out torchrun")
    device = resolve_device(rank.device or args.device)
    init_group(rank, device)
    launcher = f"torchrun --standalone --nproc_per_node={rank.world_size}" if rank.world_size > 1 else "python"
    command = f"{launcher} -m hexnewton.apps.bench " + " ".join(sys.argv[1:] if argv is None else argv)
    quiet = contextlib.redirect_stdout(io.StringIO()) if not rank.is_main else contextlib.nullcontext()
    with quiet:  # rank 0 alone prints
        results, pipeline, profiles = measure(args, device, rank, sim, ground, agent, base, terrains)
    rows = rate_rows(results, pipeline)
    ranks = with_ranks(rows, gather_floats([r["rate"] for r in rows], device))
    close_group()
    if rank.is_main:
        report(args, results, pipeline, profiles, sim, command, device, rank.world_size, ranks, baseline)
    return 0


def report(args, results, pipeline, profiles, sim, command: str, device: str, world: int, ranks: list[dict],
           baseline: dict | None) -> None:  # fmt: skip
    """Rank 0: the tables (with the ranks' total and efficiency under torchrun or with ``--baseline``), printed,
    appended and written as JSON."""
    md = markdown(results, pipeline, profiles, sim, command, device)
    run = {"world_size": world, "device_name": device_name(device), "command": command, "ranks": ranks}
    if ranks and (world > 1 or baseline):
        md += "\n" + scaling_markdown(scaling_rows([baseline, run] if baseline else [run]))
    print()
    print(md)
    if args.append:
        with open(args.append, "a") as f:
            f.write("\n" + md)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"sim": [asdict(r) for r in results], "pipeline": [asdict(r) for r in pipeline],
                       "profile": profiles, **run}, f, indent=1)  # fmt: skip


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.bench"))
