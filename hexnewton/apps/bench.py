"""Throughput: simulation, env-step and end-to-end training, per terrain and env count.

    python -m hexnewton.apps.bench                         # default device, all terrains, N = 1024 (64 on CPU)
    python -m hexnewton.apps.bench --num_envs 1024 4096 16384 --terrain flat complex --device cuda
    python -m hexnewton.apps.bench --mode sim              # simulation only
    python -m hexnewton.apps.bench --mode sim --terrain stepped --env.terrain.collision mesh_boxes  # terrain settings
    python -m hexnewton.apps.bench --append BENCHMARKS.md  # also append the table (date, device, git rev)

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

import datetime
import json
import platform
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from hexnewton.analysis.report import git_rev
from hexnewton.apps.cli import ArgumentParser, add_config_args, config_overrides, positive_int, run, terrain_name
from hexnewton.config import TERRAINS, HexConfig, SimConfig, TerrainConfig, apply_overrides
from hexnewton.learning.agent import AgentConfig
from hexnewton.physics.terrain import validate_config


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


def _config(terrain: str, num_envs: int, device: str, seed: int, sim: SimConfig | None = None,
            ground: TerrainConfig | None = None) -> HexConfig:  # fmt: skip
    """``ground``: the other terrain settings (``--env.terrain.*``); ``terrain`` and ``seed`` replace its name, seed."""
    return HexConfig(sim=replace(sim or SimConfig(), num_envs=num_envs, device=device),
                     terrain=replace(ground or TerrainConfig(), name=terrain, seed=seed))  # fmt: skip


def bench_one(terrain: str, num_envs: int, device: str, frames: int, sim: SimConfig, seed: int = 0,
              ground: TerrainConfig | None = None) -> BenchResult:  # fmt: skip
    """The physics world alone: ``frames`` timed frames of ``num_envs`` robots walking under the CPG controller, each
    with the fixed gait scaled by a random factor in [0.7, 1.3]; contact overflow checked after the timed frames."""
    import warp as wp

    from hexnewton.physics.cpg import CPGController
    from hexnewton.physics.world import World

    cfg = _config(terrain, num_envs, device, seed, sim, ground)
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


@dataclass
class PipelineResult:
    terrain: str
    num_envs: int
    env_steps_per_s: float = float("nan")  # env-step mode
    env_robot_s_per_s: float = float("nan")
    train_steps_per_s: float = float("nan")  # train mode (collection + PPO update)
    train_robot_s_per_s: float = float("nan")
    train_iteration_s: float = float("nan")
    memory_per_env_kb: float = float("nan")  # CUDA only


def _device_memory(device: str) -> int:
    """Bytes this process holds on ``device``: Warp's memory pool plus torch's allocations. The previous
    benchmark's env is collected first, so the next delta is not hidden in memory it left in a pool."""
    import gc

    import torch
    import warp as wp

    gc.collect()
    torch.cuda.empty_cache()
    return wp.get_mempool_used_mem_current(device) + torch.cuda.memory_allocated(torch.device(device))


def bench_env(terrain: str, num_envs: int, device: str, steps: int, seed: int = 0,
              sim: SimConfig | None = None, ground: TerrainConfig | None = None) -> PipelineResult:
    """``steps`` timed ``HexapodEnv.step`` calls with uniform random actions (drawn before the timing)."""
    import torch
    import warp as wp

    from hexnewton.mdp.env import make_env

    cfg = _config(terrain, num_envs, device, seed, sim, ground)
    env = make_env(cfg)
    gen = torch.Generator(device=env._obs_t.device).manual_seed(seed)
    actions = torch.rand((8, num_envs, env.num_actions), generator=gen, device=env._obs_t.device) * 2 - 1
    for k in range(max(steps // 10, 2)):  # capture + warm-up
        env.step(actions[k % 8])
    wp.synchronize_device(env.device)
    t0 = time.perf_counter()
    for k in range(steps):
        obs, rew, done, extras = env.step(actions[k % 8])
    float(rew.sum())  # the last step's results reach torch
    wp.synchronize_device(env.device)
    wall = time.perf_counter() - t0
    rate = num_envs * steps / wall
    return PipelineResult(terrain, num_envs, env_steps_per_s=rate, env_robot_s_per_s=rate * cfg.task.control_dt)


PHASES = (("env.step", "env", "step"), ("policy act", "alg", "act"), ("storage", "alg", "process_env_step"),
          ("logger", "logger", "process_env_step"), ("returns", "alg", "compute_returns"), ("PPO update", "alg", "update"))


def bench_train(terrain: str, num_envs: int, device: str, iterations: int, seed: int = 0, profile: bool = False,
                sim: SimConfig | None = None, agent=None, ground: TerrainConfig | None = None,
                ) -> tuple[PipelineResult, dict[str, float] | None]:  # fmt: skip
    """``iterations`` timed PPO iterations of ``agent`` (default: ``AgentConfig()``) after one untimed warm-up iteration
    (two with ``torch.compile``, whose first update compiles).

    With ``profile``, the same runner then trains ``iterations`` more with a device sync around each rsl-rl
    phase (so their total exceeds an unprofiled iteration's): seconds per iteration per phase, plus "other"."""
    import copy

    import torch
    import warp as wp
    from rsl_rl.runners import OnPolicyRunner

    from hexnewton.learning.runner import seed_everything
    from hexnewton.mdp.env import make_env

    seed_everything(seed)
    cuda = device.startswith("cuda")
    used0 = _device_memory(device) if cuda else 0
    cfg = _config(terrain, num_envs, device, seed, sim, ground)
    env = make_env(cfg)
    tcfg = (agent or AgentConfig()).to_rsl_rl(num_envs)
    # a TensorBoard writer as in train.py: rsl-rl's logger only does its per-step bookkeeping with one
    logs = tempfile.TemporaryDirectory(prefix="hexnewton-bench-")
    runner = OnPolicyRunner(env, copy.deepcopy(tcfg), log_dir=logs.name, device=device)
    runner.learn(2 if tcfg["torch_compile_mode"] else 1)  # capture, kernel loading, optimizer state, compile
    wall = _timed_learn(runner, env, iterations)
    rate = num_envs * tcfg["num_steps_per_env"] * iterations / wall
    mem = float("nan")
    if cuda:  # env, rollout storage, networks and optimizer (Warp pool + torch), after the timed iterations
        mem = (wp.get_mempool_used_mem_current(device) + torch.cuda.memory_allocated(torch.device(device)) - used0)
        mem /= num_envs * 1024
    result = PipelineResult(terrain, num_envs, train_steps_per_s=rate, train_robot_s_per_s=rate * cfg.task.control_dt,
                            train_iteration_s=wall / iterations, memory_per_env_kb=mem)  # fmt: skip
    if not profile:
        return result, None
    spent = {name: 0.0 for name, _, _ in PHASES}

    def timed(name, fn):
        def wrapper(*a, **k):
            wp.synchronize_device(env.device)
            t0 = time.perf_counter()
            out = fn(*a, **k)
            wp.synchronize_device(env.device)
            spent[name] += time.perf_counter() - t0
            return out

        return wrapper

    owners = {"env": env, "alg": runner.alg, "logger": runner.logger}
    for name, owner, method in PHASES:
        setattr(owners[owner], method, timed(name, getattr(owners[owner], method)))
    total = _timed_learn(runner, env, iterations)
    phases = {name: v / iterations for name, v in spent.items()}
    phases["other"] = total / iterations - sum(phases.values())
    return result, phases


def _timed_learn(runner, env, iterations: int) -> float:
    """Wall time of ``iterations`` more PPO iterations, the device idle before and after."""
    import warp as wp

    wp.synchronize_device(env.device)
    t0 = time.perf_counter()
    runner.learn(iterations)
    wp.synchronize_device(env.device)
    return time.perf_counter() - t0


def is_out_of_memory(exc: BaseException) -> bool:
    """Warp, torch and MuJoCo Warp report a failed device allocation in different words."""
    text = f"{type(exc).__name__} {exc}".lower()
    return isinstance(exc, MemoryError) or "out of memory" in text or "failed to allocate" in text


def largest_that_fits(terrain: str, start: int, device: str, frames: int, sim: SimConfig,
                      limit: int = 1 << 20, ground: TerrainConfig | None = None) -> list[BenchResult]:  # fmt: skip
    """Sim-only results at 2x, 4x, ... ``start`` envs until an allocation fails (or ``limit``); the last one
    is the largest env count that fits on ``device``."""
    import gc

    out, n = [], start
    while n * 2 <= limit:
        n *= 2
        try:
            out.append(bench_one(terrain, n, device, frames, sim, ground=ground))
        except Exception as exc:
            if not is_out_of_memory(exc):
                raise
            print(f"{terrain:8s} N={n:6d} does not fit: {str(exc).splitlines()[0][:100]}", flush=True)
            break
        finally:
            gc.collect()
        r = out[-1]
        print(f"{terrain:8s} N={n:6d} sim   {r.robot_s_per_s:12,.0f} robot-s/s (fits)", flush=True)
    return out


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


def device_name(device: str) -> str:
    """The device's name for the tables: the GPU's, or the CPU's with a note on Warp's single-threaded kernels."""
    if device.startswith("cuda"):
        import warp as wp

        return wp.get_device(device).name
    return f"CPU ({platform.processor() or platform.machine()}, Warp CPU kernels single-threaded)"


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
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--num_envs", type=positive_int, nargs="+", default=None)
    p.add_argument("--terrain", type=terrain_name, nargs="+", default=list(TERRAINS))
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
    p.add_argument("--json", metavar="PATH", help="write the raw results as JSON")
    add_config_args(p, "env.sim", SimConfig(), skip=("num_envs", "device"),
                    title="--env.sim.*: the physics (SimConfig), as train.py's")
    add_config_args(p, "env.terrain", TerrainConfig(), skip=("name", "seed"),
                    title="--env.terrain.*: the terrain's other settings (TerrainConfig; --terrain names it)")
    add_config_args(p, "agent", AgentConfig(), title="--agent.*: train mode's learner (AgentConfig), as train.py's")
    return p


def bench_pipeline(terrain: str, n: int, device: str, modes: list[str], env_steps: int, iterations: int,
                   profile: bool, sim: SimConfig, agent: AgentConfig, ground: TerrainConfig,
                   ) -> tuple[PipelineResult, dict[str, float] | None]:  # fmt: skip
    """The env-step (``env`` in ``modes``) and training (``train``) throughput of ``n`` envs on ``terrain``, each
    printed as it is measured; with ``profile`` also the training phases' seconds per iteration (else None)."""
    pr, prof = PipelineResult(terrain, n), None
    if "env" in modes:
        e = bench_env(terrain, n, device, env_steps, sim=sim, ground=ground)
        pr.env_steps_per_s, pr.env_robot_s_per_s = e.env_steps_per_s, e.env_robot_s_per_s
        print(f"{terrain:8s} N={n:6d} env   {e.env_robot_s_per_s:12,.0f} robot-s/s  "
              f"({e.env_steps_per_s:,.0f} env-steps/s)", flush=True)  # fmt: skip
    if "train" in modes:
        t, prof = bench_train(terrain, n, device, iterations, profile=profile, sim=sim, agent=agent, ground=ground)
        for k in ("train_steps_per_s", "train_robot_s_per_s", "train_iteration_s", "memory_per_env_kb"):
            setattr(pr, k, getattr(t, k))
        print(f"{terrain:8s} N={n:6d} train {t.train_robot_s_per_s:12,.0f} robot-s/s  ({t.train_steps_per_s:,.0f} "
              f"env-steps/s, {t.train_iteration_s:.2f} s/iteration)", flush=True)  # fmt: skip
        if prof is not None:
            total = sum(prof.values())
            print(f"{terrain:8s} N={n:6d} profile (synced, {total:.3f} s/iteration): " + ", ".join(
                f"{k} {v * 1e3:.1f} ms ({v / total:.0%})" for k, v in prof.items()), flush=True)  # fmt: skip
    return pr, prof


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


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    agent = apply_overrides(AgentConfig(), config_overrides(args, "agent"))
    from hexnewton.physics.world import resolve_device

    device = resolve_device(args.device)
    gpu = device.startswith("cuda")
    envs = args.num_envs or ([1024] if gpu else [64])
    frames = args.frames or (400 if gpu else 100)
    sim = apply_overrides(SimConfig(), config_overrides(args, "env.sim"))
    ground = apply_overrides(TerrainConfig(), config_overrides(args, "env.terrain"))
    for name in args.terrain:
        validate_config(replace(ground, name=name))
    command = "python -m hexnewton.apps.bench " + " ".join(sys.argv[1:] if argv is None else argv)
    results, pipeline, profiles = [], [], []
    env_steps = args.env_steps or (200 if gpu else 25)
    iterations = args.train_iterations or (10 if gpu else 2)
    for terrain in args.terrain:
        for n in envs:
            if "sim" in args.mode:
                r = bench_one(terrain, n, device, frames, sim, ground=ground)
                print(f"{terrain:8s} N={n:6d} sim   {r.robot_s_per_s:12,.0f} robot-s/s  ({r.robot_frames_per_s:,.0f} "
                      f"robot-frames/s, build {r.build_s:.1f} s, capture {r.capture_s:.1f} s, overflow: {r.overflow})",
                      flush=True)  # fmt: skip
                results.append(r)
            if "env" in args.mode or "train" in args.mode:
                pr, prof = bench_pipeline(terrain, n, device, args.mode, env_steps, iterations, args.profile, sim,
                                          agent, ground)  # fmt: skip
                if prof is not None:
                    profiles.append({"terrain": terrain, "num_envs": n, **prof})
                pipeline.append(pr)
        if args.largest:
            results += largest_that_fits(terrain, max(envs), device, frames, sim, ground=ground)
    md = markdown(results, pipeline, profiles, sim, command, device)
    print()
    print(md)
    if args.append:
        with open(args.append, "a") as f:
            f.write("\n" + md)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"sim": [asdict(r) for r in results], "pipeline": [asdict(r) for r in pipeline],
                       "profile": profiles}, f, indent=1)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.bench"))
