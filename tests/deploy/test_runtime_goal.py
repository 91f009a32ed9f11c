"""The runtime's goal (hexnewton/deploy/runtime.py): ``set_goal`` in the odometry frame, the target formed from the
robot's planar pose as the simulator forms it, the old ``step`` signature for straight bundles, one-line errors; all
on NumPy and onnxruntime alone."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from hexnewton.deploy.runtime import STAND_HEIGHT, Controller, target_in_heading_frame

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUNDLE = os.path.join(ROOT, "results", "controllers", "cpg_rl_flat")


def _quat(yaw):
    yaw = np.asarray(yaw, np.float64)
    return np.stack([0 * yaw, 0 * yaw, np.sin(yaw / 2), np.cos(yaw / 2)], axis=-1)


def test_target_from_the_pose_is_the_simulators():
    """Random poses and goals: the target from (x, y, yaw) and the goal of set_goal equals target_in_heading_frame of
    the 3D base position and its quaternion (the simulator's and sim2sim's); the default base height is the
    standing height; a goal behind the robot comes out at negative x."""
    rng = np.random.default_rng(0)
    n = 64
    ctrl = Controller(json.load(open(os.path.join(BUNDLE, "controller.json"))), num_robots=n)
    pose = np.c_[rng.uniform(-3, 3, (n, 2)), rng.uniform(-np.pi, np.pi, n)]
    goal, ground, base_z = rng.uniform(-4, 4, (n, 2)), rng.uniform(0, 0.1, n), rng.uniform(0.1, 0.2, n)
    ctrl.set_goal(goal[:, 0], goal[:, 1], ground)
    got = ctrl.target_from_pose(pose, base_z)
    want = target_in_heading_frame(np.c_[pose[:, :2], base_z], _quat(pose[:, 2]), np.c_[goal, ground], ground)
    np.testing.assert_allclose(got, want, atol=1e-12)
    ctrl.set_goal(-2.0, 0.0)  # one goal for every robot, level with the frame's origin
    t = ctrl.target_from_pose(np.zeros((n, 3)))
    np.testing.assert_allclose(t, np.tile([-2.0, 0.0, -STAND_HEIGHT], (n, 1)), atol=1e-12)
    np.testing.assert_allclose(ctrl.goal_distance(np.zeros((n, 3))), 2.0)


def test_step_toward_the_goal_and_the_old_signature():
    """A bundle's step from the pose toward its goal gives the joint targets of the same step given the target
    (straight bundles' call, unchanged); moving the goal changes the observation's target and nothing else."""
    q = np.tile(np.tile([0.0, 0.15, -0.15], 6), (2, 1))
    quat, pose = _quat([0.3, -1.0]), np.array([[0.5, -0.2, 0.3], [1.0, 1.0, -1.0]])
    a, b = Controller(BUNDLE, num_robots=2), Controller(BUNDLE, num_robots=2)
    a.set_goal([2.0, 0.0], [1.0, -3.0])
    target = target_in_heading_frame(np.c_[pose[:, :2], [STAND_HEIGHT] * 2], quat, [[2.0, 1.0, 0.0], [0.0, -3.0, 0.0]],
                                     0.0)  # fmt: skip
    for _ in range(3):
        np.testing.assert_allclose(a.step(q, np.zeros((2, 18)), quat, pose=pose), b.step(q, np.zeros((2, 18)), quat,
                                                                                         target), atol=1e-12)
    lay = a.layout["target"]
    obs = a.observe(q, np.zeros((2, 18)), quat, a.target_from_pose(pose))
    np.testing.assert_allclose(obs[:, lay[0]:lay[1]], target, atol=1e-12)


def test_goal_errors_are_one_line():
    ctrl = Controller(BUNDLE, num_robots=2)
    q = np.zeros((2, 18))
    with pytest.raises(ValueError, match=r"step\(\) needs the target, or the robot's pose"):
        ctrl.step(q, q, _quat([0.0, 0.0]))
    with pytest.raises(ValueError, match="no goal: call set_goal"):
        ctrl.step(q, q, _quat([0.0, 0.0]), pose=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="set_goal: finite x, y, ground_z"):
        ctrl.set_goal([1.0, 2.0, 3.0], 0.0)
    with pytest.raises(ValueError, match="set_goal: finite"):
        ctrl.set_goal(float("nan"), 0.0)


def test_the_goal_runs_without_warp_newton_or_torch():
    """set_goal and the step from the pose import nothing beyond NumPy and onnxruntime."""
    blocked = ("warp", "torch", "newton", "mujoco", "mujoco_warp", "rsl_rl", "tensordict")
    code = (
        "import sys\n"
        f"for m in {blocked!r}: sys.modules[m] = None\n"
        "import numpy as np\n"
        "from hexnewton.deploy.runtime import Controller\n"
        f"c = Controller({BUNDLE!r}, num_robots=1)\n"
        "c.set_goal(2.0, 2.0)\n"
        "out = c.step(np.zeros((1, 18)), np.zeros((1, 18)), [[0, 0, 0, 1.0]], pose=[[0.0, 0.0, 0.0]])\n"
        "print(out.shape)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0 and "(1, 18)" in proc.stdout, proc.stderr[-2000:]
