"""Headless rollouts of a controller on any terrain, with statistics, an optional recording and a gait plot.

    python play.py --controller cpg --terrain flat --num_envs 64 --steps 500
    python play.py --controller cpg --terrain stepped --record rollout.npz --plot gait.png

``--controller cpg`` is the paper's fixed-parameter "CPG" baseline (§3.3): the two-Hopf CPG and the
mapping function with the constant parameters of ``CPGConfig`` (``fixed_*``). Episodes end and restart
as §2.4.4 says (fall, off course, success, timeout); the statistics cover each robot's first episode.

``--record PATH.npz`` stores, per control step, the arrays listed under ``Recorder``.
"""

from __future__ import annotations

import math
import os
import sys
import time
from dataclasses import replace

import numpy as np

from .cli import ArgumentParser, positive_int, run, terrain_name
from .config import TERRAINS, HexConfig, SimConfig, TaskConfig, TerrainConfig
from .kernels.terminations import STATUS_NAMES
from .rollout import Recorder, Rollout


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


def rollout_cpg(cfg: HexConfig, steps: int, recorder: Recorder | None = None, progress: bool = True):
    """Run the fixed CPG for ``steps`` control steps; returns (stats, rollout)."""
    roll = Rollout(cfg)
    n = roll.num_envs
    pos = np.zeros((steps, n, 3), np.float32)
    rpy = np.zeros((steps, n, 3), np.float32)
    done = np.zeros((steps, n), bool)
    status_log = np.zeros((steps, n), np.int32)
    from rich.progress import track

    it = track(range(steps), description=f"{cfg.terrain.name}", transient=True) if progress else range(steps)
    for k in it:
        roll.step()
        status = roll.status.numpy()
        q = roll.world.numpy_q()
        pos[k], rpy[k], done[k], status_log[k] = q[:, :3], roll.rpy.numpy(), status != 0, status
        pos[k, :, :2] -= roll.world.spawn_xy  # relative to each env's start
        if recorder is not None:
            recorder.add(roll, (k + 1) * cfg.task.control_dt, status, q)
        roll.reset_done(status)
    roll.world.check_contacts()
    return first_episode_stats(pos, rpy, done, status_log), roll


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python play.py", description="Headless rollouts with statistics.")
    p.add_argument("--controller", choices=["cpg"], default="cpg", help="cpg: the fixed-parameter CPG baseline")
    p.add_argument("--terrain", type=terrain_name, nargs="+", default=["flat"], help=f"one or more of {TERRAINS}")
    p.add_argument("--num_envs", type=positive_int, default=64)
    p.add_argument("--steps", type=positive_int, default=500, help="control steps (20 ms each by default)")
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--seed", type=int, default=0, help="terrain seed")
    p.add_argument("--record", metavar="PATH.npz", help="save the rollout (first terrain)")
    p.add_argument("--plot", metavar="PATH.png", help="plot the six legs' joint targets over two gait cycles")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    for path, ext in ((args.record, ".npz"), (args.plot, ".png")):
        if path:
            check_writable(path, ext)

    for i, terrain in enumerate(args.terrain):
        cfg = HexConfig(
            sim=replace(SimConfig(), num_envs=args.num_envs, device=args.device),
            terrain=TerrainConfig(name=terrain, seed=args.seed),
            task=TaskConfig(),
        )
        recorder = Recorder() if (args.record and i == 0) else None
        t0 = time.perf_counter()
        stats, roll = rollout_cpg(cfg, args.steps, recorder, progress=not args.no_progress and sys.stderr.isatty())
        wall = time.perf_counter() - t0
        print(format_stats(terrain, stats, args.steps * cfg.task.control_dt) + f"  [{wall:.1f} s wall, {roll.world.device}]")
        if recorder is not None:
            recorder.save(args.record)
            print(f"recorded {args.steps} steps x {args.num_envs} envs to {args.record}")
    if args.plot:
        from .plotting import plot_gait

        plot_gait(HexConfig(), args.plot)
        print(f"gait plot written to {args.plot}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python play.py"))
