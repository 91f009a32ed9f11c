"""Episode end conditions (Huang et al. 2025, §2.4.4), evaluated per env in one kernel.

``TERMINATIONS`` declares each end once, one :class:`Termination` row per status code, in the order the kernel
checks them (the first that holds is the env's status; 0, running, if none does):
  5 nonfinite  the physics blew up: NaN/Inf in any coordinate or velocity, or a runaway (base speed above
               ``max_base_speed``, a joint speed above ``max_joint_speed``); the env is reset and counted;
  1 fell       the torso is less than ``min_height`` above the terrain under it, or |roll| or |pitch| exceeds
               ``max_tilt`` (§2.4.4 (1));
  2 off course |y - y_start| > ``max_abs_y`` (§2.4.4 (2));
  3 success    within ``goal_radius`` of the goal, ``goal_distance`` ahead of the env's start (§2.4.4 (3));
  4 timeout    this step is the episode's ``max_episode_steps``-th (``episode_steps`` counts the steps before it)
               (§2.4.4 (2)).
The codes and names live in ``kernels/status.py`` (plain Python, for tools that do not load Warp); each row adds the
condition as a ``@wp.func`` of (:class:`EndInputs`, :class:`EndFrame`) and as a float64 NumPy function of the same
inputs (:func:`end_frame_np`). The kernel (:func:`episode_status_kernel`, the rows unrolled with ``wp.static``), the
float64 reference (:func:`episode_status_np`) and the episode statistics' names (``Episode/<name>_rate``, env.py)
follow from the table. Adding an end: its code and name in ``status.py``, its row here (and a ``TaskConfig`` field
for a new threshold, read as ``i.task.<field>``).

The kernel also writes roll, pitch and yaw (ZYX Euler angles of the base quaternion; 0 for a blown-up env) for
observations, rewards, logging and recording.
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp

from ..terrain.query import HeightField, terrain_height
from .reference import quat_to_rpy_np
from .tables import TaskParams

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


@wp.struct
class EndInputs:
    """What the end conditions read, one row per env."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity, 18 joint velocities
    episode_steps: wp.array[wp.int32]  # the episode's steps before this one
    start: wp.array[wp.vec2]  # the episode's start
    hf: HeightField
    task: TaskParams


@wp.struct
class EndFrame:
    """Per-env values the conditions share (:func:`end_frame`)."""

    e: int
    px: float  # base position [m]
    py: float
    pz: float
    rpy: wp.vec3  # roll, pitch, yaw of the (normalised) base quaternion


@wp.func
def end_frame(i: EndInputs, e: int) -> EndFrame:
    f = EndFrame()
    f.e = e
    f.px = i.joint_q[e, 0]
    f.py = i.joint_q[e, 1]
    f.pz = i.joint_q[e, 2]
    f.rpy = quat_to_rpy(wp.normalize(wp.quat(i.joint_q[e, 3], i.joint_q[e, 4], i.joint_q[e, 5], i.joint_q[e, 6])))
    return f


@dataclass(frozen=True)
class EndFrameNp:
    """:class:`EndFrame` for all envs, in float64; ``finite`` marks the envs whose state is all finite."""

    px: np.ndarray
    py: np.ndarray
    pz: np.ndarray
    rpy: np.ndarray  # (N, 3)
    finite: np.ndarray


def end_frame_np(i) -> EndFrameNp:
    """Float64 :func:`end_frame`; ``i`` has :class:`EndInputs`' fields as NumPy arrays, with ``ground`` (N,), the
    terrain under each base, in place of ``hf``, and ``task`` a ``TaskConfig``."""
    jq, jqd = np.asarray(i.joint_q, np.float64), np.asarray(i.joint_qd, np.float64)
    finite = np.isfinite(jq).all(axis=1) & np.isfinite(jqd).all(axis=1)
    rpy = quat_to_rpy_np(np.where(finite[:, None], jq[:, 3:7], [0.0, 0.0, 0.0, 1.0]))
    return EndFrameNp(px=jq[:, 0], py=jq[:, 1], pz=jq[:, 2], rpy=rpy, finite=finite)


# ----------------------------------------------------------------------------------------------------
# the conditions: one Warp function per env and one NumPy function for all envs
# ----------------------------------------------------------------------------------------------------


@wp.func
def nonfinite(i: EndInputs, f: EndFrame) -> bool:
    finite = bool(True)
    for k in range(i.joint_q.shape[1]):
        finite = finite and wp.isfinite(i.joint_q[f.e, k])
    for k in range(i.joint_qd.shape[1]):
        v = i.joint_qd[f.e, k]
        finite = finite and wp.isfinite(v)
        if k >= 6 and wp.abs(v) > i.task.max_joint_speed:
            finite = False
    base_v = wp.vec3(i.joint_qd[f.e, 0], i.joint_qd[f.e, 1], i.joint_qd[f.e, 2])
    if wp.length(base_v) > i.task.max_base_speed:
        finite = False
    return not finite


def nonfinite_np(i, f):
    jqd = np.asarray(i.joint_qd, np.float64)
    with np.errstate(invalid="ignore"):
        runaway = (np.linalg.norm(jqd[:, :3], axis=1) > i.task.max_base_speed) | (
            np.abs(jqd[:, 6:]) > i.task.max_joint_speed
        ).any(axis=1)
    return ~f.finite | runaway


@wp.func
def fell(i: EndInputs, f: EndFrame) -> bool:
    lim = i.task.max_tilt
    low = f.pz - terrain_height(i.hf, f.px, f.py) < i.task.min_height
    return low or wp.abs(f.rpy[0]) > lim or wp.abs(f.rpy[1]) > lim


def fell_np(i, f):
    lim = i.task.max_tilt
    return (f.pz - i.ground < i.task.min_height) | (np.abs(f.rpy[:, 0]) > lim) | (np.abs(f.rpy[:, 1]) > lim)


@wp.func
def off_course(i: EndInputs, f: EndFrame) -> bool:
    return wp.abs(f.py - i.start[f.e][1]) > i.task.max_abs_y


def off_course_np(i, f):
    return np.abs(f.py - np.asarray(i.start, np.float64)[:, 1]) > i.task.max_abs_y


@wp.func
def success(i: EndInputs, f: EndFrame) -> bool:
    return wp.length(wp.vec2(f.px, f.py) - i.start[f.e] - wp.vec2(i.task.goal_distance, 0.0)) < i.task.goal_radius


def success_np(i, f):
    start = np.asarray(i.start, np.float64)
    return np.hypot(f.px - start[:, 0] - i.task.goal_distance, f.py - start[:, 1]) < i.task.goal_radius


@wp.func
def timeout(i: EndInputs, f: EndFrame) -> bool:
    return i.episode_steps[f.e] + 1 >= i.task.max_episode_steps


def timeout_np(i, f):
    return np.asarray(i.episode_steps) + 1 >= i.task.max_episode_steps


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Termination:
    """One episode end: status ``code`` (``kernels/status.py``) when ``func`` holds and no earlier row does."""

    code: int
    func: wp.Function  # (EndInputs, EndFrame) -> bool for one env
    reference: Callable  # float64 NumPy (inputs namespace, end_frame_np) -> (N,) bool

    @property
    def name(self) -> str:
        return STATUS_NAMES[self.code]


TERMINATIONS = (
    Termination(NONFINITE, nonfinite, nonfinite_np),
    Termination(FELL, fell, fell_np),
    Termination(OFF_COURSE, off_course, off_course_np),
    Termination(SUCCESS, success, success_np),
    Termination(TIMEOUT, timeout, timeout_np),
)
assert sorted(t.code for t in TERMINATIONS) == list(range(1, len(STATUS_NAMES))), "one row per status code"


@wp.kernel
def episode_status_kernel(i: EndInputs, status: wp.array[wp.int32], rpy: wp.array2d[wp.float32]):
    """Each env's status: the code of the first row of ``TERMINATIONS`` whose condition holds, else ``RUNNING``;
    and its roll, pitch, yaw (0 for a blown-up env)."""
    e = wp.tid()
    f = end_frame(i, e)
    s = int(RUNNING)
    for k in range(wp.static(len(TERMINATIONS))):
        if s == RUNNING:
            if wp.static(TERMINATIONS[k].func)(i, f):
                s = wp.static(TERMINATIONS[k].code)
    status[e] = s
    a = f.rpy
    if s == NONFINITE:
        a = wp.vec3(0.0)
    for k in range(3):
        rpy[e, k] = a[k]


def episode_status_np(i):
    """Float64 reference of :func:`episode_status_kernel` (inputs as in :func:`end_frame_np`): (status, rpy)."""
    f = end_frame_np(i)
    with np.errstate(invalid="ignore"):
        hits = [t.reference(i, f) for t in TERMINATIONS]
    status = np.select(hits, [t.code for t in TERMINATIONS], RUNNING)
    return status, np.where((status == NONFINITE)[:, None], 0.0, f.rpy)
