"""Headless rollouts of a controller on any terrain, with statistics, an optional recording and a gait plot.

    python play.py                                                       # the newest trained policy on its terrain
    python play.py --controller cpg --terrain flat --num_envs 64 --steps 500
    python play.py --controller cpg --terrain stepped --record rollout.npz --plot gait.png
    python play.py --controller cpg_rl --terrain rugged                  # newest CPG_RL run's newest checkpoint
    python play.py --checkpoint logs/.../model_299.pt                    # its controller and terrain from the file

Without ``--controller`` and ``--checkpoint`` it plays the newest checkpoint under ``--log_dir`` (any task), or the
shipped ``results/policies/cpg_rl_complex.pt`` when nothing was trained; without ``--terrain``, on the terrain the
policy was trained on.

Controllers:
- ``cpg``: the paper's fixed-parameter "CPG" baseline (§3.3). The two-Hopf CPG and the mapping run with the
  constant parameters of ``CPGConfig`` (``fixed_*``).
- ``cpg_rl``: a trained CPG_RL policy, acting deterministically (its distribution's mean).
- ``joint``: a trained pure-DRL policy that sets the 18 joint targets directly.

All three run in the same ``HexapodEnv``, so episodes end and restart as §2.4.4 says (fall, off course,
success, timeout). The statistics cover each robot's first episode. ``--record PATH.npz`` stores, per
control step, the arrays listed under ``Recorder``.
"""

from __future__ import annotations

import contextlib
import glob
import io
import math
import os
import sys
import time
from dataclasses import replace

import numpy as np

from .cli import ArgumentParser, positive_int, run, terrain_name
from .config import JOINT_NAMES, TERRAINS, HexConfig, TaskConfig, TerrainConfig, terrain_for_goal
from .kernels.status import STATUS_NAMES

CONTROLLERS = {"cpg": "cpg", "cpg_rl": "cpg", "joint": "joint"}  # controller -> env action mode


def check_writable(path: str, ext: str) -> None:
    """Fail before any simulation if an output file could not be written (never lose a finished rollout)."""
    if not path.endswith(ext):
        raise ValueError(f"{path}: expected a {ext} file name")
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK):
        raise ValueError(f"cannot write {path}: {parent} is not a writable directory")


def first_episode_stats(pos: np.ndarray, rpy: np.ndarray, done: np.ndarray, status: np.ndarray) -> dict:
    """Statistics over every env's first episode. Arrays are (T, N, ...) per control step, positions relative
    to each env's start; a row with ``done`` is the last row of that episode, ``status`` gives the reason."""
    ended_before = np.cumsum(done, axis=0) - done  # episodes finished before this row
    first = ended_before == 0  # (T, N)
    last_row = np.where(done.any(axis=0), np.argmax(done, axis=0), len(done) - 1)
    envs = np.arange(pos.shape[1])
    end_pos, end_rpy = pos[last_row, envs], rpy[last_row, envs]
    end_status = np.where(done.any(axis=0), status[last_row, envs], 0)
    deg = 180.0 / math.pi
    tilt = np.abs(rpy[..., :2])[first]  # (samples, 2): roll, pitch
    return {
        "envs": pos.shape[1],
        "distance_m": float(end_pos[:, 0].mean()),
        "distance_min_m": float(end_pos[:, 0].min()),
        "lateral_drift_m": float(np.abs(end_pos[:, 1]).mean()),
        "lateral_drift_max_m": float(np.abs(end_pos[:, 1]).max()),
        "heading_error_deg": float(np.abs(end_rpy[:, 2]).mean() * deg),
        "roll_mean_deg": float(tilt[:, 0].mean() * deg),
        "roll_std_deg": float(tilt[:, 0].std() * deg),
        "roll_max_deg": float(tilt[:, 0].max() * deg),
        "pitch_mean_deg": float(tilt[:, 1].mean() * deg),
        "pitch_std_deg": float(tilt[:, 1].std() * deg),
        "pitch_max_deg": float(tilt[:, 1].max() * deg),
        "ended": {STATUS_NAMES[k]: int((end_status == k).sum()) for k in range(1, len(STATUS_NAMES))},
    }


def format_stats(terrain: str, s: dict, seconds: float) -> str:
    ended = ", ".join(f"{k} {v}" for k, v in s["ended"].items() if v) or "none"
    return (
        f"{terrain}: {s['envs']} robots, {seconds:.1f} s of control: first episodes walked {s['distance_m']:.2f} m "
        f"(min {s['distance_min_m']:.2f}), |y| drift {s['lateral_drift_m']:.3f} m (max {s['lateral_drift_max_m']:.3f}), "
        f"heading error {s['heading_error_deg']:.1f} deg\n"
        f"  |roll| {s['roll_mean_deg']:.1f} +- {s['roll_std_deg']:.1f} deg (max {s['roll_max_deg']:.1f}), "
        f"|pitch| {s['pitch_mean_deg']:.1f} +- {s['pitch_std_deg']:.1f} deg (max {s['pitch_max_deg']:.1f}); "
        f"first episodes ended: {ended}"
    )


class Recorder:
    """Collects per-control-step arrays on the host; ``save(path)`` writes one ``.npz``.

    Keys: ``t`` (T,), ``joint_target``/``joint_pos`` (T, N, 18), ``base_pos``/``base_rpy`` (T, N, 3) (world frame;
    roll, pitch, yaw), ``cpg_xy`` (T, N, 2, 2) (oscillator, [x, y]), ``params`` (T, N, 15) (physical units),
    ``done`` (T, N) (that env's episode ended at this step; the next row starts a new one), ``joint_names``.
    A row holds the state at the end of the step, before a finished env is reset.
    """

    KEYS = ("t", "joint_target", "joint_pos", "base_pos", "base_rpy", "cpg_xy", "params", "done")

    def __init__(self):
        self.rows: dict[str, list[np.ndarray]] = {k: [] for k in self.KEYS}

    def add(self, env, t: float, q: np.ndarray, rpy: np.ndarray, done: np.ndarray) -> None:
        r = self.rows
        r["t"].append(np.float64(t))
        r["joint_target"].append(env.world.joint_target_wp.numpy()[:, 7:].copy())
        r["joint_pos"].append(q[:, 7:].copy())
        r["base_pos"].append(q[:, 0:3].copy())
        r["base_rpy"].append(rpy.copy())
        r["cpg_xy"].append(env.last_cpg_state.numpy().reshape(-1, 2, 2).copy())
        r["params"].append(env.last_params.numpy().copy())
        r["done"].append(done.copy())

    def save(self, path: str) -> None:
        arrays = {k: np.stack(v) for k, v in self.rows.items()}
        arrays["joint_names"] = np.array(JOINT_NAMES)
        np.savez_compressed(path, **arrays)


def fixed_cpg_actions(env, gait: str = "default", params: np.ndarray | None = None) -> "torch.Tensor":  # noqa: F821
    """A fixed baseline's parameters (``CPGConfig.fixed_params(gait)``, or ``params``: (15,) or one row per env)
    expressed as (constant) policy actions."""
    import torch

    from .kernels.reference import params_to_actions

    lo, hi = env.cfg.cpg.param_ranges()
    p = env.cfg.cpg.fixed_params(gait) if params is None else env.cfg.cpg.with_posture(params)
    a = np.broadcast_to(np.clip(params_to_actions(p, lo, hi), -1.0, 1.0), (env.num_envs, len(lo)))
    return torch.tensor(np.ascontiguousarray(a), dtype=torch.float32, device=env._obs_t.device)


def stepped(env, policy, steps: int, description: str, progress: bool = True):
    """Run ``policy(obs) -> actions`` for up to ``steps`` control steps (deterministic, no gradients); yield
    per step the host copies ``(k, status, q, pos, rpy)``: status codes (N,), the state before resets
    (N, 25), base position relative to each env's start (N, 3) and roll/pitch/yaw (N, 3)."""
    import torch

    it = range(steps)
    if progress:
        from rich.progress import track

        it = track(it, description=description, transient=True)
    obs = env.get_observations()
    with torch.inference_mode():
        for k in it:
            obs, _, _, _ = env.step(policy(obs))
            q = env.last_q.numpy()
            pos = q[:, :3].copy()
            pos[:, :2] -= env.last_start.numpy()
            yield k, env.status.numpy(), q, pos, env.rpy.numpy().copy()


def rollout(env, policy, steps: int, recorders: tuple = (), progress: bool = True) -> dict:
    """Run ``policy(obs) -> actions`` for up to ``steps`` control steps; returns first-episode statistics.
    Each of ``recorders`` gets every step. Without recorders, the rollout ends as soon as every env's first
    episode has (the statistics cover nothing else)."""
    n = env.num_envs
    pos = np.zeros((steps, n, 3), np.float32)
    rpy = np.zeros((steps, n, 3), np.float32)
    done = np.zeros((steps, n), bool)
    status_log = np.zeros((steps, n), np.int32)
    ended = np.zeros(n, bool)
    last = steps
    for k, status, q, p, r in stepped(env, policy, steps, env.cfg.terrain.name, progress):
        pos[k], rpy[k], done[k], status_log[k] = p, r, status != 0, status
        for rec in recorders:
            rec.add(env, (k + 1) * env.cfg.task.control_dt, q, r, status != 0)
        ended |= status != 0
        if not recorders and ended.all():
            last = k + 1
            break
    env.world.check_contacts()
    stats = first_episode_stats(pos[:last], rpy[:last], done[:last], status_log[:last])
    stats["control_s"] = last * env.cfg.task.control_dt
    return stats


#: What ``python play.py`` plays when nothing was trained yet.
SHIPPED_POLICY = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "results", "policies",
                              "cpg_rl_complex.pt")  # fmt: skip


def newest_checkpoint(log_dir: str, experiment: str) -> str:
    """The newest run's last numbered checkpoint under ``log_dir/experiment`` (a glob pattern: ``*`` for any); runs
    are named by their start time, so the newest is the last name across experiments."""
    runs = sorted(glob.glob(os.path.join(log_dir, experiment, "*")), key=os.path.basename)
    for run_dir in reversed(runs):
        models = glob.glob(os.path.join(run_dir, "model_[0-9]*.pt"))
        if models:
            return max(models, key=lambda m: int(m.rsplit("_", 1)[1].split(".")[0]))
    raise ValueError(f"no checkpoint under {os.path.join(log_dir, experiment)}: pass --checkpoint PATH")


def load_runner(env, path: str, action_mode: str):
    """An rsl-rl runner holding the checkpoint's actor, after checking the checkpoint fits this environment."""
    import copy

    from rsl_rl.runners import OnPolicyRunner

    from .train import check_compatible, checkpoint_distribution, checkpoint_meta, load_checkpoint, load_into_runner, \
        train_cfg

    ckpt = load_checkpoint(path)
    check_compatible(ckpt, path, env.num_obs, env.num_actions, action_mode)
    meta = checkpoint_meta(ckpt)
    tcfg = train_cfg(meta.get("preset", "default"), env.num_envs, std_max=meta.get("std_max"),
                     distribution=checkpoint_distribution(ckpt))  # fmt: skip
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints both networks in full
        runner = OnPolicyRunner(env, copy.deepcopy(tcfg), log_dir=None, device=str(env._obs_t.device))
    # the actor alone: full training checkpoints and actor-only policy files (results/policies) both load
    load_into_runner(runner, ckpt, {"actor": True})
    return runner


def expected_clipped_action(mean, std):
    """Torch twin of :func:`hexnewton.deploy.expected_clipped_action` (its float64 NumPy reference):
    E[clip(a, -1, 1)] for a ~ N(mean, std^2)."""
    import torch

    std = std.clamp_min(1e-12)
    a, b = (-1.0 - mean) / std, (1.0 - mean) / std
    cdf_a, cdf_b = torch.special.ndtr(a), torch.special.ndtr(b)
    pdf_a, pdf_b = torch.exp(-0.5 * a * a) / math.sqrt(2 * math.pi), torch.exp(-0.5 * b * b) / math.sqrt(2 * math.pi)
    return -cdf_a + (1.0 - cdf_b) + mean * (cdf_b - cdf_a) - std * (pdf_b - pdf_a)


def load_policy(env, path: str, action_mode: str, stochastic: bool = False, expected: bool = False):
    """Policy from an rsl-rl checkpoint, after checking it fits this environment: its deterministic action (the
    distribution's mean: for a Beta policy the action the robot runs), with ``stochastic`` an action sampled from
    its distribution as in training, with ``expected`` (Gaussian policies) the expected clipped action
    E[clip(a, -1, 1)], what the sampled policy asks of the CPG on average. A Beta policy's mean already is its
    expected action: ``expected`` gives the same."""
    import torch

    from .train import action_std

    if stochastic and expected:
        raise ValueError("choose sampled (--stochastic) or expected (--expected) actions, not both")
    runner = load_runner(env, path, action_mode)
    device = str(env._obs_t.device)
    policy = runner.get_inference_policy(device=device)
    if stochastic:
        return lambda obs: policy(obs, stochastic_output=True)
    std = action_std(runner.alg.get_policy())
    if expected and std is not None:
        std = torch.tensor(std, device=device)
        return lambda obs: expected_clipped_action(policy(obs), std)
    return policy


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python play.py", description="Headless rollouts with statistics.")
    p.add_argument("--controller", choices=list(CONTROLLERS), default=None,
                   help="default: the checkpoint's (cpg_rl or joint); cpg is the fixed gait and takes no checkpoint")
    p.add_argument("--checkpoint", metavar="PATH", help="a trained policy (.pt); default: the newest under --log_dir, "
                   "else results/policies/cpg_rl_complex.pt")  # fmt: skip
    p.add_argument("--log_dir", default="logs")
    p.add_argument("--terrain", type=terrain_name, nargs="+", default=None,
                   help=f"one or more of {TERRAINS} (default: the policy's training terrain, else flat)")
    p.add_argument("--num_envs", type=positive_int, default=64)
    p.add_argument("--steps", type=positive_int, default=500, help="control steps (20 ms each by default)")
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--seed", type=int, default=0, help="terrain and reset seed")
    p.add_argument("--step_rise", type=float, default=TerrainConfig.step_rise, help="step height [m] (§3.1: 0.06)")
    p.add_argument("--goal_distance", type=float, default=TaskConfig.goal_distance, help="goal ahead of the start [m]")
    p.add_argument("--reset_yaw", type=float, default=0.0,
                   help="start yaw noise [rad] (training uses 0.2; 0 starts every robot facing its goal)")
    p.add_argument("--record", metavar="PATH.npz", help="save the rollout (first terrain)")
    p.add_argument("--video", metavar="PATH.mp4|.gif", help="render the first terrain's rollout headless (matplotlib)")
    p.add_argument("--video_robots", type=positive_int, default=3, help="robots drawn in the video")
    p.add_argument("--video_speed", type=positive_int, default=1, help="video playback speed (x real time)")
    actions = p.add_mutually_exclusive_group()
    actions.add_argument("--stochastic", action="store_true",
                         help="cpg_rl / joint: sample actions from the policy's Gaussian as in training "
                              "(default: the mean)")
    actions.add_argument("--expected", action="store_true",
                         help="cpg_rl / joint: the expected clipped action E[clip(a, -1, 1)] of the Gaussian "
                              "(deterministic)")
    p.add_argument("--plot", metavar="PATH.png", help="plot the six legs' joint targets over two gait cycles")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    for path, ext in ((args.record, ".npz"), (args.plot, ".png")):
        if path:
            check_writable(path, ext)
    if args.video:
        from .video import check_video_path

        check_video_path(args.video)
        check_writable(args.video, os.path.splitext(args.video)[1])
    if args.controller == "cpg" and args.checkpoint:
        raise ValueError("--checkpoint is a trained policy's: the fixed CPG (--controller cpg) has none; use "
                         "--controller cpg_rl or joint, or leave --controller out")  # fmt: skip
    if args.controller != "cpg" and args.checkpoint is None:
        pattern = "hexnewton_*" if args.controller is None else f"hexnewton_{CONTROLLERS[args.controller]}_*"
        try:
            args.checkpoint = newest_checkpoint(args.log_dir, pattern)
        except ValueError:
            if args.controller == "joint" or not os.path.isfile(SHIPPED_POLICY):
                raise
            args.checkpoint = SHIPPED_POLICY
        print(f"playing {args.checkpoint}")
    trained = HexConfig()
    if args.checkpoint:
        from .train import checkpoint_meta, load_checkpoint, trained_config

        ckpt = load_checkpoint(args.checkpoint)  # fails before building a world
        trained = trained_config(ckpt)
        ckpt_mode = checkpoint_meta(ckpt).get("action_mode", "cpg")
        if args.controller is None:
            args.controller = "joint" if ckpt_mode == "joint" else "cpg_rl"
        if args.terrain is None:
            args.terrain = [trained.terrain.name]
    args.terrain = args.terrain or ["flat"]
    mode = CONTROLLERS[args.controller]

    from .env import make_env

    for i, terrain in enumerate(args.terrain):
        cfg = HexConfig(
            sim=replace(trained.sim, num_envs=args.num_envs, device=args.device),  # the policy's own physics
            terrain=terrain_for_goal(TerrainConfig(name=terrain, seed=args.seed, step_rise=args.step_rise),
                                     args.goal_distance),
            task=replace(TaskConfig(), seed=args.seed, reset_yaw=args.reset_yaw, goal_distance=args.goal_distance),
            cpg=trained.cpg,  # the policy's own parameter ranges
        )
        env = make_env(cfg, mode)
        if args.controller == "cpg":
            actions = fixed_cpg_actions(env)
            policy = lambda obs: actions  # noqa: E731
        else:
            policy = load_policy(env, args.checkpoint, mode, args.stochastic, args.expected)
            if args.stochastic:
                import torch

                torch.manual_seed(args.seed)
        recorder = Recorder() if (args.record and i == 0) else None
        video = None
        if args.video and i == 0:
            from .video import VideoRecorder

            video = VideoRecorder(robots=args.video_robots, speed=args.video_speed)
        t0 = time.perf_counter()
        stats = rollout(env, policy, args.steps, tuple(r for r in (recorder, video) if r is not None),
                        progress=not args.no_progress and sys.stderr.isatty())  # fmt: skip
        wall = time.perf_counter() - t0
        label = args.controller if args.controller == "cpg" else f"{args.controller} ({args.checkpoint})"
        print(f"[{label}] " + format_stats(terrain, stats, stats["control_s"])
              + f"  [{wall:.1f} s wall, {env.device}]")  # fmt: skip
        if recorder is not None:
            recorder.save(args.record)
            print(f"recorded {args.steps} steps x {args.num_envs} envs to {args.record}")
        if video is not None:
            video.save(args.video, title=f"{args.controller} on {terrain}")
            print(f"video of {len(video.frames)} frames written to {args.video}")
    if args.plot:
        from .plotting import plot_gait

        plot_gait(HexConfig(), args.plot)
        print(f"gait plot written to {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python play.py"))
