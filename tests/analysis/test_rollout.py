"""Episode ends (§2.4.4) in-kernel vs reference, fixed-CPG rollouts on CPU, and play.py's outputs."""

import math
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest
import warp as wp
from hypothesis import given, settings
from hypothesis import strategies as st

from hexnewton.analysis.rollout import rollout
from hexnewton.config import JOINT_NAMES, HexConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.learning.policy import fixed_cpg_actions
from hexnewton.mdp.env import make_env
from hexnewton.mdp.status import FELL, NONFINITE, SUCCESS
from hexnewton.mdp.terms import (
    EndInputs,
    episode_status_kernel,
    episode_status_np,
    goals_from_host,
    height_field_from_grid,
    make_struct,
)
from hexnewton.kernels.reference import quat_to_rpy_np
from hexnewton.terrain import make_terrain, terrain_height_np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
TASK = TaskConfig()


def _random_quats(rng, n, max_angle):
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    ang = rng.uniform(0, max_angle, n)
    return np.concatenate([axis * np.sin(ang / 2)[:, None], np.cos(ang / 2)[:, None]], axis=1)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_episode_status_kernel_matches_reference(seed):
    rng = np.random.default_rng(seed)
    n = 256
    terrain = make_terrain(TerrainConfig(name="complex", seed=3))
    hf = height_field_from_grid(terrain.grid, "cpu")
    q = np.zeros((n, 25))
    q[:, 0] = rng.uniform(-0.5, 3.5, n)
    q[:, 1] = rng.uniform(-2.0, 2.0, n)
    # keep sample points off 1 cm cell edges (float32 vs float64 cell index)
    q[:, :2] = (np.floor(q[:, :2] / 0.01) + rng.uniform(0.1, 0.9, (n, 2))) * 0.01
    ground = terrain_height_np(terrain.grid, q[:, 0], q[:, 1])
    q[:, 2] = ground + rng.uniform(0.0, 0.2, n)
    q[:, 3:7] = _random_quats(rng, n, 1.6)
    start = np.stack([rng.uniform(-0.2, 0.2, n), rng.uniform(-0.5, 0.5, n)], axis=1).astype(np.float32)
    # half the goals the paper's, 3.5 m ahead of the start (the last); half in every direction, 0-4 m from the
    # robot, each with the course from a point behind it, the last or not (mdp/terms/goals.py)
    bearing, r = rng.uniform(-math.pi, math.pi, n), rng.uniform(0.0, 4.0, n)
    goal = np.stack([q[:, 0] + r * np.cos(bearing), q[:, 1] + r * np.sin(bearing)], axis=1)
    course = np.stack([np.cos(bearing + rng.uniform(-0.5, 0.5, n)), np.sin(bearing + rng.uniform(-0.5, 0.5, n))], 1)
    course /= np.linalg.norm(course, axis=1, keepdims=True)
    left = rng.choice([0, -1, 2], n)
    ahead = np.arange(n) % 2 == 0
    goal[ahead], course[ahead], left[ahead] = start[ahead] + [TASK.goal_distance, 0.0], (1.0, 0.0), 0
    goal, course = goal.astype(np.float32), course.astype(np.float32)
    q[: n // 16, rng.integers(0, 25)] = np.nan
    qd = rng.normal(0.0, 1.0, (n, 24))
    qd[n // 16: n // 8, rng.integers(0, 24)] = np.inf  # non-finite velocities
    qd[n // 8: n // 8 + 4, 0] = 1.5 * TASK.max_base_speed  # runaway base
    qd[n // 8 + 4: n // 8 + 8, 6 + rng.integers(0, 18)] = -1.5 * TASK.max_joint_speed  # runaway joint
    steps = rng.integers(6990, 7010, n).astype(np.int32)
    status = wp.zeros(n, dtype=wp.int32, device="cpu")
    rpy = wp.zeros((n, 3), dtype=wp.float32, device="cpu")
    f32 = lambda a: wp.array(a.astype(np.float32), device="cpu")  # noqa: E731
    inputs = make_struct(EndInputs, joint_q=f32(q), joint_qd=f32(qd), episode_steps=wp.array(steps, device="cpu"),
                         goals=goals_from_host("cpu", goal, course, left), hf=hf, task=TASK)  # fmt: skip
    wp.launch(episode_status_kernel, dim=n, inputs=[inputs], outputs=[status, rpy], device="cpu")
    ns = SimpleNamespace(joint_q=q.astype(np.float32), joint_qd=qd.astype(np.float32), episode_steps=steps,
                         goals=SimpleNamespace(goal=goal, course=course, left=left), ground=ground,
                         task=TASK)  # fmt: skip
    ref_status, ref_rpy = episode_status_np(ns)
    assert (ref_status[: n // 8 + 8] == NONFINITE).all()
    # thresholds compared in float32 vs float64 can differ right at the boundary: allow a handful
    assert (status.numpy() != ref_status).sum() <= 2
    finite = ref_status != NONFINITE
    np.testing.assert_allclose(rpy.numpy()[finite], ref_rpy[finite], atol=2e-4)
    assert np.all(status.numpy()[~finite] == NONFINITE)


def test_quat_to_rpy_round_trip():
    rng = np.random.default_rng(0)
    rpy = np.stack([rng.uniform(-1.5, 1.5, 100), rng.uniform(-1.4, 1.4, 100), rng.uniform(-3, 3, 100)], axis=1)
    r, p, y = rpy.T
    cr, sr, cp, sp, cy, sy = np.cos(r / 2), np.sin(r / 2), np.cos(p / 2), np.sin(p / 2), np.cos(y / 2), np.sin(y / 2)
    q = np.stack([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
                  cr * cp * cy + sr * sp * sy], axis=1)  # fmt: skip  (ZYX, x y z w)
    np.testing.assert_allclose(quat_to_rpy_np(q), rpy, atol=1e-9)


def _cfg(terrain, n, **task):
    return HexConfig(sim=SimConfig(num_envs=n, device="cpu"), terrain=TerrainConfig(name=terrain),
                     task=TaskConfig(**task))  # fmt: skip


def _fixed(env):
    actions = fixed_cpg_actions(env)
    return lambda obs: actions


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_fixed_cpg_walks_straight_on_flat():
    """64 robots walk >= 1 m forward in 10 s with |y| drift < 0.2 m, none falls."""
    env = make_env(_cfg("flat", 64, reset_yaw=0.0))  # as play.py: every robot starts facing its goal
    stats = rollout(env, _fixed(env), steps=int(10.0 / TASK.control_dt), progress=False)
    assert stats["distance_min_m"] >= 1.0, stats
    assert stats["lateral_drift_max_m"] < 0.2, stats
    assert stats["ended"]["fell"] == 0 and stats["ended"]["nonfinite"] == 0, stats
    assert env.world.check_contacts(on_overflow="raise").ok


def test_episodes_end_and_restart():
    """A goal 0.4 m ahead: success ends the episode, the env restarts near its lane start, the CPG restarts."""
    env = make_env(_cfg("flat", 4, goal_distance=0.5, goal_radius=0.1, reset_yaw=0.0))
    policy = _fixed(env)
    lanes = env.world.spawn_xy
    ended_at = None
    for k in range(200):
        env.step(policy(None))
        status = env.status.numpy()
        if status.any():
            ended = status != 0
            assert np.all(status[ended] == SUCCESS) and np.all(env.done_u8.numpy()[ended] == 1)
            ended_at = k
            break
    assert ended_at is not None and 50 < ended_at < 150  # ~0.24 m/s
    assert np.all(env.last_q.numpy()[ended, 0] - env.last_start.numpy()[ended, 0] > 0.39)  # the terminal state
    q = env.world.numpy_q()
    np.testing.assert_allclose(q[ended, 0], lanes[ended, 0], atol=1e-6)
    assert np.all(np.abs(q[ended, 1] - lanes[ended, 1]) <= TASK.reset_lateral + 1e-6)
    assert np.all(env.episode_steps.numpy()[ended] == 0) and np.all(env.episode_steps.numpy()[~ended] == ended_at + 1)
    assert env.episode_stats()["success_rate"] == 1.0
    env.step(policy(None))
    assert np.all(env.episode_steps.numpy()[ended] == 1)


def test_nan_state_ends_episode_as_nonfinite_and_resets():
    env = make_env(_cfg("flat", 4))
    policy = _fixed(env)
    env.step(policy(None))
    env.world.joint_q[2, 0] = float("nan")
    _, rew, done, _ = env.step(policy(None))
    assert env.status.numpy()[2] == NONFINITE and done[2] == 1 and np.isfinite(rew.numpy()).all()
    assert np.isfinite(env.world.numpy_q()).all() and np.isfinite(env.get_observations()["policy"].numpy()).all()
    assert env.episode_stats()["nonfinite_rate"] == 1.0


def test_tilted_robot_counts_as_fallen():
    env = make_env(_cfg("flat", 2))
    env.world.joint_q[0, 3:7] = env.world.joint_q.new_tensor([math.sin(0.6), 0.0, 0.0, math.cos(0.6)])  # 1.2 rad roll
    env.step(_fixed(env)(None))
    assert env.status.numpy()[0] == FELL


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_play_records_and_plots(tmp_path):
    rec, png = tmp_path / "r.npz", tmp_path / "g.png"
    proc = subprocess.run(
        [sys.executable, "play.py", "--controller", "cpg", "--terrain", "flat", "--num_envs", "3", "--steps", "30",
         "--device", "cpu", "--record", str(rec), "--plot", str(png)],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    assert "flat: 3 robots" in proc.stdout and "heading error" in proc.stdout
    d = np.load(rec)
    T, N = 30, 3
    shapes = {"t": (T,), "joint_target": (T, N, 18), "joint_pos": (T, N, 18), "base_pos": (T, N, 3),
              "base_rpy": (T, N, 3), "cpg_xy": (T, N, 2, 2), "params": (T, N, 15), "done": (T, N),
              "joint_names": (18,)}  # fmt: skip
    assert {k: d[k].shape for k in d.files} == shapes
    assert tuple(d["joint_names"]) == JOINT_NAMES
    np.testing.assert_allclose(d["t"], np.arange(1, T + 1) * TASK.control_dt)
    np.testing.assert_allclose(d["params"][0, 0], HexConfig().cpg.fixed_params(), rtol=1e-6)
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    "args, message",
    [
        (["--steps", "0"], "positive integer"),
        (["--terrain", "lava"], "unknown terrain 'lava'"),
        (["--record", "out.txt"], "expected a .npz file name"),
        (["--record", "/nonexistent-dir/r.npz"], "cannot write"),
        (["--controller", "policy"], "invalid choice"),
    ],
)
def test_play_bad_input_is_one_line(args, message):
    proc = subprocess.run([sys.executable, "play.py", *args], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2
    err = [line for line in proc.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
    assert len(err) == 1 and message in err[0], proc.stderr
