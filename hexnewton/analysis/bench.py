"""Speed measurements: robot-seconds simulated per wall second (:func:`bench_one`), env-steps per second of the MDP
(:func:`bench_env`) and of training (:func:`bench_train`, with a per-phase profile), the largest env count that
fits (:func:`largest_that_fits`). The command line and its tables: ``python -m hexnewton.apps.bench``."""

from __future__ import annotations

import platform
import tempfile
import time
from dataclasses import dataclass, replace

import numpy as np

from hexnewton.config import HexConfig, SimConfig, TerrainConfig
from hexnewton.learning.agent import AgentConfig
from hexnewton.learning.ranks import Rank
from hexnewton.learning.runner import barrier


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
            ground: TerrainConfig | None = None, base: HexConfig | None = None) -> HexConfig:  # fmt: skip
    """``base`` (default ``HexConfig()``: a task's env) with ``sim`` and ``ground`` (the other terrain settings,
    ``--env.terrain.*``) in place of its own, ``terrain`` and ``seed`` replacing the terrain's name and seed."""
    base = base or HexConfig()
    return replace(base, sim=replace(sim or base.sim, num_envs=num_envs, device=device),
                   terrain=replace(ground or base.terrain, name=terrain, seed=seed))  # fmt: skip


def bench_one(terrain: str, num_envs: int, device: str, frames: int, sim: SimConfig, seed: int = 0,
              ground: TerrainConfig | None = None, base: HexConfig | None = None) -> BenchResult:  # fmt: skip
    """The physics world alone: ``frames`` timed frames of ``num_envs`` robots walking under the CPG controller, each
    with the fixed gait scaled by a random factor in [0.7, 1.3]; contact overflow checked after the timed frames."""
    import warp as wp

    from hexnewton.kernels.cpg import CPGController
    from hexnewton.physics.world import World

    cfg = _config(terrain, num_envs, device, seed, sim, ground, base)
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
    barrier()  # under torchrun every rank's timed window starts together
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


def bench_env(terrain: str, num_envs: int, device: str, steps: int, seed: int = 0, sim: SimConfig | None = None,
              ground: TerrainConfig | None = None, base: HexConfig | None = None) -> PipelineResult:
    """``steps`` timed ``HexapodEnv.step`` calls with uniform random actions (drawn before the timing)."""
    import torch
    import warp as wp

    from hexnewton.mdp.env import make_env

    cfg = _config(terrain, num_envs, device, seed, sim, ground, base)
    env = make_env(cfg)
    gen = torch.Generator(device=env.device_torch).manual_seed(seed)
    actions = torch.rand((8, num_envs, env.num_actions), generator=gen, device=env.device_torch) * 2 - 1
    for k in range(max(steps // 10, 2)):  # capture + warm-up
        env.step(actions[k % 8])
    wp.synchronize_device(env.device)
    barrier()
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
                sim: SimConfig | None = None, agent=None, ground: TerrainConfig | None = None, rank: Rank = Rank(),
                base: HexConfig | None = None) -> tuple[PipelineResult, dict[str, float] | None]:  # fmt: skip
    """``iterations`` timed PPO iterations of ``agent`` (default: ``AgentConfig()``) after one untimed warm-up iteration
    (two with ``torch.compile``, whose first update compiles). Under torchrun (``rank``) every rank trains its own
    envs and the ranks average their gradients in every mini-batch, as ``train.py`` does.

    With ``profile``, the same runner then trains ``iterations`` more with a device sync around each rsl-rl
    phase (so their total exceeds an unprofiled iteration's): seconds per iteration per phase, plus "other"."""
    import copy

    import torch
    import warp as wp

    from hexnewton.learning.runner import RankedRunner, learner_settings, seed_everything
    from hexnewton.mdp.env import make_env

    seed_everything(seed)
    cuda = device.startswith("cuda")
    used0 = _device_memory(device) if cuda else 0
    cfg = _config(terrain, num_envs, device, seed, sim, ground, base)
    env = make_env(cfg)
    agent = agent or AgentConfig()
    tcfg = agent.to_rsl_rl(num_envs, env.obs_groups)
    # a TensorBoard writer as in train.py: rsl-rl's logger only does its per-step bookkeeping with one
    logs = tempfile.TemporaryDirectory(prefix="hexnewton-bench-")
    runner = RankedRunner(env, copy.deepcopy(tcfg), log_dir=logs.name, device=device, rank=rank)
    learner_settings(runner, agent)  # as train.py's runner: the episode bookkeeping, the matmul precision
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
    barrier()
    t0 = time.perf_counter()
    runner.learn(iterations)
    wp.synchronize_device(env.device)
    return time.perf_counter() - t0


def is_out_of_memory(exc: BaseException) -> bool:
    """Warp, torch and MuJoCo Warp report a failed device allocation in different words."""
    text = f"{type(exc).__name__} {exc}".lower()
    return isinstance(exc, MemoryError) or "out of memory" in text or "failed to allocate" in text


def largest_that_fits(terrain: str, start: int, device: str, frames: int, sim: SimConfig,
                      limit: int = 1 << 20, ground: TerrainConfig | None = None,
                      base: HexConfig | None = None) -> list[BenchResult]:  # fmt: skip
    """Sim-only results at 2x, 4x, ... ``start`` envs until an allocation fails (or ``limit``); the last one
    is the largest env count that fits on ``device`` (``base``: the env config, a task's or another robot's)."""
    import gc

    out, n = [], start
    while n * 2 <= limit:
        n *= 2
        try:
            out.append(bench_one(terrain, n, device, frames, sim, ground=ground, base=base))
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


def device_name(device: str) -> str:
    """The device's name for the tables: the GPU's, or the CPU's with a note on Warp's single-threaded kernels."""
    if device.startswith("cuda"):
        import warp as wp

        return wp.get_device(device).name
    return f"CPU ({platform.processor() or platform.machine()}, Warp CPU kernels single-threaded)"


def bench_pipeline(terrain: str, n: int, device: str, modes: list[str], env_steps: int, iterations: int,
                   profile: bool, sim: SimConfig, agent: AgentConfig, ground: TerrainConfig, rank: Rank = Rank(),
                   base: HexConfig | None = None) -> tuple[PipelineResult, dict[str, float] | None]:  # fmt: skip
    """The env-step (``env`` in ``modes``) and training (``train``) throughput of ``n`` envs on ``terrain``, each
    printed as it is measured; with ``profile`` also the training phases' seconds per iteration (else None)."""
    pr, prof = PipelineResult(terrain, n), None
    if "env" in modes:
        e = bench_env(terrain, n, device, env_steps, sim=sim, ground=ground, base=base)
        pr.env_steps_per_s, pr.env_robot_s_per_s = e.env_steps_per_s, e.env_robot_s_per_s
        print(f"{terrain:8s} N={n:6d} env   {e.env_robot_s_per_s:12,.0f} robot-s/s  "
              f"({e.env_steps_per_s:,.0f} env-steps/s)", flush=True)  # fmt: skip
    if "train" in modes:
        t, prof = bench_train(terrain, n, device, iterations, profile=profile, sim=sim, agent=agent, ground=ground,
                              rank=rank, base=base)  # fmt: skip
        for k in ("train_steps_per_s", "train_robot_s_per_s", "train_iteration_s", "memory_per_env_kb"):
            setattr(pr, k, getattr(t, k))
        print(f"{terrain:8s} N={n:6d} train {t.train_robot_s_per_s:12,.0f} robot-s/s  ({t.train_steps_per_s:,.0f} "
              f"env-steps/s, {t.train_iteration_s:.2f} s/iteration)", flush=True)  # fmt: skip
        if prof is not None:
            total = sum(prof.values())
            print(f"{terrain:8s} N={n:6d} profile (synced, {total:.3f} s/iteration): " + ", ".join(
                f"{k} {v * 1e3:.1f} ms ({v / total:.0%})" for k, v in prof.items()), flush=True)  # fmt: skip
    return pr, prof
