"""Episode end conditions (Huang et al. 2025, §2.4.4), evaluated per env in one kernel.

Status codes (``STATUS_NAMES``), checked in this order:
  1 fell       the torso is less than ``min_height`` above the terrain under it, or |roll| or |pitch| exceeds
               ``max_tilt`` (§2.4.4 (1));
  2 off course |y - y_start| > ``max_abs_y`` (§2.4.4 (2));
  3 success    within ``goal_radius`` of the goal, ``goal_distance`` ahead of the env's start (§2.4.4 (3));
  4 timeout    this step is the episode's ``max_episode_steps``-th (``episode_steps`` counts the steps before it)
               (§2.4.4 (2));
  5 nonfinite  the physics blew up: NaN/Inf in any coordinate or velocity, or a runaway (base speed above
               ``max_base_speed``, a joint speed above ``max_joint_speed``); the env is reset and counted.
0 means the episode goes on. The kernel also writes roll, pitch and yaw (ZYX Euler angles of the base
quaternion) for observations, logging and recording.
"""

import numpy as np
import warp as wp

from ..terrain.query import HeightField, terrain_height
from .reference import quat_to_rpy_np

from .status import FELL, NONFINITE, OFF_COURSE, RUNNING, STATUS_NAMES, SUCCESS, TIMEOUT  # noqa: F401


@wp.func
def quat_to_rpy(q: wp.quat) -> wp.vec3:
    """ZYX Euler angles (roll about x, pitch about y, yaw about z) of a unit quaternion (x, y, z, w)."""
    x = q[0]
    y = q[1]
    z = q[2]
    w = q[3]
    roll = wp.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = wp.asin(wp.clamp(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = wp.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return wp.vec3(roll, pitch, yaw)


@wp.kernel
def episode_status_kernel(
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    episode_steps: wp.array[wp.int32],
    hf: HeightField,
    start: wp.array[wp.vec2],
    goal_distance: float,
    goal_radius: float,
    min_height: float,
    max_tilt: float,
    max_abs_y: float,
    max_episode_steps: int,
    max_base_speed: float,
    max_joint_speed: float,
    status: wp.array[wp.int32],
    rpy: wp.array2d[wp.float32],
):
    e = wp.tid()
    px = joint_q[e, 0]
    py = joint_q[e, 1]
    pz = joint_q[e, 2]
    q = wp.quat(joint_q[e, 3], joint_q[e, 4], joint_q[e, 5], joint_q[e, 6])
    finite = bool(True)
    for i in range(joint_q.shape[1]):
        finite = finite and wp.isfinite(joint_q[e, i])
    for i in range(joint_qd.shape[1]):
        v = joint_qd[e, i]
        finite = finite and wp.isfinite(v)
        if i >= 6 and wp.abs(v) > max_joint_speed:
            finite = False
    base_v = wp.vec3(joint_qd[e, 0], joint_qd[e, 1], joint_qd[e, 2])
    if wp.length(base_v) > max_base_speed:
        finite = False
    if not finite:
        status[e] = NONFINITE
        for k in range(3):
            rpy[e, k] = 0.0
        return
    a = quat_to_rpy(wp.normalize(q))
    for k in range(3):
        rpy[e, k] = a[k]
    s = int(RUNNING)
    if pz - terrain_height(hf, px, py) < min_height or wp.abs(a[0]) > max_tilt or wp.abs(a[1]) > max_tilt:
        s = FELL
    elif wp.abs(py - start[e][1]) > max_abs_y:
        s = OFF_COURSE
    elif wp.length(wp.vec2(px, py) - start[e] - wp.vec2(goal_distance, 0.0)) < goal_radius:
        s = SUCCESS
    elif episode_steps[e] + 1 >= max_episode_steps:
        s = TIMEOUT
    status[e] = s


# ----------------------------------------------------------------------------------------------------
# float64 NumPy references
# ----------------------------------------------------------------------------------------------------


def episode_status_np(joint_q, joint_qd, episode_steps, ground_height, start, goal_distance, goal_radius, min_height,
                      max_tilt, max_abs_y, max_episode_steps, max_base_speed, max_joint_speed):  # fmt: skip
    """Float64 reference of :func:`episode_status_kernel`; ``ground_height`` (N,) is the terrain under the base,
    ``start`` (N, 2) each env's start."""
    jq, jqd = np.asarray(joint_q, np.float64), np.asarray(joint_qd, np.float64)
    with np.errstate(invalid="ignore"):
        runaway = (np.linalg.norm(jqd[:, :3], axis=1) > max_base_speed) | (np.abs(jqd[:, 6:]) > max_joint_speed).any(axis=1)
    finite = np.isfinite(jq).all(axis=1) & np.isfinite(jqd).all(axis=1) & ~runaway
    safe_q = np.where(finite[:, None], jq[:, 3:7], [0.0, 0.0, 0.0, 1.0])
    rpy = np.where(finite[:, None], quat_to_rpy_np(safe_q), 0.0)
    fell = (jq[:, 2] - ground_height < min_height) | (np.abs(rpy[:, 0]) > max_tilt) | (np.abs(rpy[:, 1]) > max_tilt)
    start = np.asarray(start, np.float64)
    off = np.abs(jq[:, 1] - start[:, 1]) > max_abs_y
    success = np.hypot(jq[:, 0] - start[:, 0] - goal_distance, jq[:, 1] - start[:, 1]) < goal_radius
    timeout = np.asarray(episode_steps) + 1 >= max_episode_steps
    status = np.select([fell, off, success, timeout], [FELL, OFF_COURSE, SUCCESS, TIMEOUT], RUNNING)
    status = np.where(finite, status, NONFINITE)
    return status, rpy
