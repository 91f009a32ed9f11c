"""Rewards (Table 1 and Eq. 5, with our additions): ``REWARD_TERMS``, one :class:`RewardTerm` row per term, its fused
kernel (:func:`make_rewards_kernel`) and its float64 reference (:func:`rewards_reference`).

R_t = w_h r_h + w_d r_d + w_theta r_theta + r_f + r_s (Eq. 5) + r_goal + r_off + the stability shaping (ours). Per-step
terms are quoted for a 20 ms control step (``REF_DT``) and scaled by ``control_dt / REF_DT``. The rows, in column
order (each function's docstring gives its value):

- ``height``: r_h, z - 0.11 above z = 0.12 m (z: torso height above the terrain under it; the heights are the paper
  robot's, another robot's x ``TaskConfig.height_scale``);
- ``direction``: r_theta, the heading error beyond a dead band, toward the goal (or, the paper's, along +x);
- ``distance``: r_d, exp(-(d_n - d_t)), 1 on the goal circle;
- ``stability``: r_s, -100 per step while low, tilted beyond ``stability_tilt`` or fallen;
- ``forward``: r_f, -0.3 per step below ``FORWARD_MIN_SPEED`` along the goal's course (+x on the straight tasks);
- ``goal``: r_goal, +300 once on reaching a goal (ours);
- ``off_course``: r_off, -100 once on leaving the course (ours);
- ``fall``: r_fall, -``fall_penalty`` once on falling (ours; 0: off);
- ``tilt``, ``ang_vel``, ``action_rate``: the stability shaping's costs (ours; weight 0: off);
- ``lateral``: the squared offset from the start-to-goal line, a cost (ours; weight 0: off).

The goal, its course (the start-to-goal direction D) and whether it is the episode's last come from ``goals.py``.

``docs/internals.md`` ("The MDP") gives the paper's wording, our reading of it, the weights and how to add a term."""

import functools
from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp

from hexnewton.mdp.status import FELL, OFF_COURSE, RUNNING, SUCCESS
from hexnewton.mdp.terms.goals import Goals, along_course, off_line, off_line_np
from hexnewton.mdp.terms.ground import HeightField, terrain_height
from hexnewton.mdp.terms.structs import RewardParams, TaskParams, choose
from hexnewton.kernels.reference import quat_rotate_inv_np


REF_DT = 0.02
FORWARD_MIN_SPEED = 0.1


@wp.struct
class RewardInputs:
    """What the reward terms read, one row per env. The kernel also writes ``prev_xy`` and ``prev_actions`` for the
    next step."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity (world frame), 18 joint velocities
    rpy: wp.array2d[wp.float32]  # roll, pitch, yaw (the terminations kernel's; 0 for a blown-up env)
    status: wp.array[wp.int32]  # this step's episode status (a status code)
    episode_steps: wp.array[wp.int32]  # the episode's steps before this one
    actions: wp.array2d[wp.float32]  # the policy's actions
    goals: Goals  # each env's goal and its course (goals.py)
    hf: HeightField
    prev_xy: wp.array[wp.vec2]  # base x, y at the last step
    prev_actions: wp.array2d[wp.float32]  # the last step's actions, clamped to [-1, 1]
    task: TaskParams
    reward: RewardParams


@wp.struct
class RewardFrame:
    """Per-env values the terms share, computed once per step by :func:`reward_frame`."""

    env: int
    px: float  # base position [m]
    py: float
    z: float  # torso height above the terrain under it [m]
    to_goal: wp.vec2  # goal minus base position [m]
    scale: float  # control_dt / REF_DT: per-step terms mean the same per second at any control rate
    ok: bool  # base position and the terrain height under it are finite


@wp.func
def reward_frame(inputs: RewardInputs, env: int) -> RewardFrame:
    """Env ``env``'s :class:`RewardFrame`."""
    frame = RewardFrame()
    frame.env = env
    frame.px = inputs.joint_q[env, 0]
    frame.py = inputs.joint_q[env, 1]
    frame.z = inputs.joint_q[env, 2] - terrain_height(inputs.hf, frame.px, frame.py)
    frame.to_goal = inputs.goals.goal[env] - wp.vec2(frame.px, frame.py)
    frame.scale = inputs.task.control_dt / REF_DT
    frame.ok = wp.isfinite(frame.px) and wp.isfinite(frame.py) and wp.isfinite(frame.z)
    return frame


@dataclass(frozen=True)
class FrameNp:
    """:class:`RewardFrame` for all envs, in float64."""

    px: np.ndarray
    py: np.ndarray
    z: np.ndarray
    to_goal: np.ndarray  # (N, 2)
    scale: float
    ok: np.ndarray


def reward_frame_np(inputs) -> FrameNp:
    """Float64 :func:`reward_frame` for all envs; ``inputs.ground`` (N,) is the terrain under each base."""
    jq = np.asarray(inputs.joint_q, np.float64)
    px, py = jq[:, 0], jq[:, 1]
    z = jq[:, 2] - np.asarray(inputs.ground, np.float64)
    to_goal = np.asarray(inputs.goals.goal, np.float64) - np.stack([px, py], axis=1)
    ok = np.isfinite(px) & np.isfinite(py) & np.isfinite(z)
    return FrameNp(px=px, py=py, z=z, to_goal=to_goal, scale=inputs.task.control_dt / REF_DT, ok=ok)


# ----------------------------------------------------------------------------------------------------
# the terms: unweighted values, one Warp function per env and one NumPy function for all envs
# ----------------------------------------------------------------------------------------------------


@wp.func
def height(inputs: RewardInputs, frame: RewardFrame) -> float:
    """r_h: z - 0.11 above 0.12 m, else 0 (the heights x the robot's ``height_scale``)."""
    s = inputs.task.height_scale
    r = float(0.0)
    if frame.z > 0.12 * s:
        r = frame.z - 0.11 * s
    return r


def height_np(inputs, frame):
    s = inputs.task.height_scale
    return np.where(frame.z > 0.12 * s, frame.z - 0.11 * s, 0.0)


@wp.func
def direction(inputs: RewardInputs, frame: RewardFrame) -> float:
    """r_theta: min(0, cos(heading error) - cos(dead band)), toward the goal (ours) or along the goal's course."""
    # the start-to-goal direction D is the goal's course (+x on the straight tasks: (cos θ, sin θ) . D / |D| =
    # cos(yaw)); ours: D from the robot
    c = inputs.goals.course[frame.env]
    bearing = wp.atan2(c[1], c[0])
    if inputs.reward.direction_to_goal:
        bearing = wp.atan2(frame.to_goal[1], frame.to_goal[0])
    return wp.min(0.0, wp.cos(inputs.rpy[frame.env, 2] - bearing) - wp.cos(inputs.reward.direction_deadband))


def direction_np(inputs, frame):
    course = np.asarray(inputs.goals.course, np.float64)
    bearing = np.arctan2(course[:, 1], course[:, 0])
    if inputs.reward.direction_to_goal:
        bearing = np.arctan2(frame.to_goal[:, 1], frame.to_goal[:, 0])
    yaw = np.asarray(inputs.rpy, np.float64)[:, 2]
    return np.minimum(0.0, np.cos(yaw - bearing) - np.cos(inputs.reward.direction_deadband))


@wp.func
def distance(inputs: RewardInputs, frame: RewardFrame) -> float:
    """r_d: exp(-(d_n - d_t)), 1 on the goal circle."""
    return wp.exp(-(wp.length(frame.to_goal) - inputs.task.goal_radius))


def distance_np(inputs, frame):
    return np.exp(-(np.hypot(frame.to_goal[:, 0], frame.to_goal[:, 1]) - inputs.task.goal_radius))


@wp.func
def stability(inputs: RewardInputs, frame: RewardFrame) -> float:
    """-1 while z < 0.05 m (x the robot's ``height_scale``), |roll| or |pitch| > stability_tilt, or fallen (r_s =
    stability_penalty x this)."""
    lim = inputs.reward.stability_tilt
    tilted = wp.abs(inputs.rpy[frame.env, 0]) > lim or wp.abs(inputs.rpy[frame.env, 1]) > lim
    r = float(0.0)
    if frame.z < 0.05 * inputs.task.height_scale or tilted or inputs.status[frame.env] == FELL:
        r = -1.0
    return r


def stability_np(inputs, frame):
    rpy = np.asarray(inputs.rpy, np.float64)
    tilted = (np.abs(rpy[:, 0]) > inputs.reward.stability_tilt) | (np.abs(rpy[:, 1]) > inputs.reward.stability_tilt)
    low = frame.z < 0.05 * inputs.task.height_scale
    return np.where(low | tilted | (np.asarray(inputs.status) == FELL), -1.0, 0.0)


@wp.func
def forward(inputs: RewardInputs, frame: RewardFrame) -> float:
    """-1 below FORWARD_MIN_SPEED along the goal's course, +x on the straight tasks (r_f = forward_penalty x this)."""
    prev = inputs.prev_xy[frame.env]
    r = float(0.0)
    if along_course(inputs.goals, frame.env, frame.px - prev[0], frame.py - prev[1]) < \
            FORWARD_MIN_SPEED * inputs.task.control_dt:
        r = -1.0
    return r


def forward_np(inputs, frame):
    prev, course = np.asarray(inputs.prev_xy, np.float64), np.asarray(inputs.goals.course, np.float64)
    step = (frame.px - prev[:, 0]) * course[:, 0] + (frame.py - prev[:, 1]) * course[:, 1]
    return np.where(step < FORWARD_MIN_SPEED * inputs.task.control_dt, -1.0, 0.0)


@wp.func
def ended_as(inputs: RewardInputs, frame: RewardFrame, code: int) -> float:
    """1 on the step that ends the episode with status ``code``, else 0."""
    r = float(0.0)
    if inputs.status[frame.env] == code:
        r = 1.0
    return r


def ended_as_np(inputs, code):
    return np.where(np.asarray(inputs.status) == code, 1.0, 0.0)


@wp.func
def goal(inputs: RewardInputs, frame: RewardFrame) -> float:
    """1 on reaching a goal: the episode's last (status success) or, still running, one that sets the next (ours:
    r_goal = goal_bonus x this)."""
    r = ended_as(inputs, frame, SUCCESS)
    running = inputs.status[frame.env] == RUNNING and inputs.goals.left[frame.env] != 0
    if running and wp.length(frame.to_goal) < inputs.task.goal_radius:
        r = 1.0
    return r


def goal_np(inputs, frame):
    near = np.hypot(frame.to_goal[:, 0], frame.to_goal[:, 1]) < inputs.task.goal_radius
    running = (np.asarray(inputs.status) == RUNNING) & (np.asarray(inputs.goals.left) != 0)
    return np.where(running & near, 1.0, ended_as_np(inputs, SUCCESS))


@wp.func
def off_course(inputs: RewardInputs, frame: RewardFrame) -> float:
    """-1 on leaving the course (ours: r_off = off_course_penalty x this)."""
    return -ended_as(inputs, frame, OFF_COURSE)


def off_course_np(inputs, frame):
    return -ended_as_np(inputs, OFF_COURSE)


@wp.func
def fall(inputs: RewardInputs, frame: RewardFrame) -> float:
    """-1 on falling (ours: r_fall = fall_penalty x this)."""
    return -ended_as(inputs, frame, FELL)


def fall_np(inputs, frame):
    return -ended_as_np(inputs, FELL)


@wp.func
def tilt(inputs: RewardInputs, frame: RewardFrame) -> float:
    """roll² + pitch² [rad²], a cost: r_tilt = -w_tilt x this."""
    return inputs.rpy[frame.env, 0] * inputs.rpy[frame.env, 0] + inputs.rpy[frame.env, 1] * inputs.rpy[frame.env, 1]


def tilt_np(inputs, frame):
    rpy = np.asarray(inputs.rpy, np.float64)
    return rpy[:, 0] ** 2 + rpy[:, 1] ** 2


@wp.func
def lateral(inputs: RewardInputs, frame: RewardFrame) -> float:
    """The squared offset from the start-to-goal line [m²] ((y - y_start)² on the straight tasks), a cost:
    r_lateral = -w_lateral x this."""
    d = off_line(inputs.goals, frame.env, frame.px, frame.py)
    return d * d


def lateral_np(inputs, frame):
    return off_line_np(inputs.goals, frame.px, frame.py) ** 2


@wp.func
def body_roll_pitch_rate(qx: float, qy: float, qz: float, qw: float, wx: float, wy: float, wz: float) -> wp.vec2:
    """The base's world-frame angular velocity (a free joint's qd[3:6]) in its own frame: (roll rate, pitch rate)."""
    w_body = wp.quat_rotate_inv(wp.quat(qx, qy, qz, qw), wp.vec3(wx, wy, wz))
    return wp.vec2(w_body[0], w_body[1])


@wp.func
def ang_vel(inputs: RewardInputs, frame: RewardFrame) -> float:
    """ω_x² + ω_y², the body's roll and pitch rates in its own frame [(rad/s)²]; a cost: r_ang_vel = -w_ang_vel x
    this."""
    env = frame.env
    rate = body_roll_pitch_rate(inputs.joint_q[env, 3], inputs.joint_q[env, 4], inputs.joint_q[env, 5],
                                inputs.joint_q[env, 6], inputs.joint_qd[env, 3], inputs.joint_qd[env, 4],
                                inputs.joint_qd[env, 5])  # fmt: skip
    return rate[0] * rate[0] + rate[1] * rate[1]


def ang_vel_np(inputs, frame):
    quat, w_world = np.asarray(inputs.joint_q, np.float64)[:, 3:7], np.asarray(inputs.joint_qd, np.float64)[:, 3:6]
    w_body = quat_rotate_inv_np(quat, w_world)
    return w_body[:, 0] ** 2 + w_body[:, 1] ** 2


@wp.func
def clamped_action(inputs: RewardInputs, env: int, k: int) -> float:
    """Action k of env ``env`` in [-1, 1] (0 if not finite), as the action scaling reads it."""
    a = inputs.actions[env, k]
    if not wp.isfinite(a):
        a = 0.0
    return wp.clamp(a, -1.0, 1.0)


def clamped_actions_np(actions):
    return np.clip(np.nan_to_num(np.asarray(actions, np.float64), nan=0.0), -1.0, 1.0)


@wp.func
def action_rate(inputs: RewardInputs, frame: RewardFrame) -> float:
    """Σ_k (a_k - a_k,prev)² (0 on an episode's first step), a cost: r_action_rate = -w_action_rate x this."""
    da = float(0.0)
    if inputs.episode_steps[frame.env] > 0:
        for k in range(inputs.actions.shape[1]):
            d = clamped_action(inputs, frame.env, k) - inputs.prev_actions[frame.env, k]
            da += d * d
    return da


def action_rate_np(inputs, frame):
    da = ((clamped_actions_np(inputs.actions) - np.asarray(inputs.prev_actions, np.float64)) ** 2).sum(axis=1)
    return np.where(np.asarray(inputs.episode_steps) > 0, da, 0.0)


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RewardTerm:
    """One reward term: ``terms[:, k] = (-)reward.<weight> * func(inputs, frame)``, times ``control_dt / REF_DT`` if
    ``per_step``."""

    name: str  # logged as Reward/<name>
    weight: str  # the RewardConfig field that weighs it
    func: wp.Function  # (RewardInputs, RewardFrame) -> unweighted value of one env
    reference: Callable  # float64 NumPy (inputs namespace, reward_frame_np) -> (N,) unweighted values
    per_step: bool = True  # paid per 20 ms step, scaled by control_dt / REF_DT (False: paid once)
    state: bool = True  # computed from the simulator state: 0 for an env whose base position is not finite
    cost: bool = False  # paid as -weight * value (a cost >= 0 that the weight scales)


REWARD_TERMS = (
    # Table 1 and Eq. 5
    RewardTerm("height", "w_height", height, height_np),
    RewardTerm("direction", "w_direction", direction, direction_np),
    RewardTerm("distance", "w_distance", distance, distance_np),
    RewardTerm("stability", "stability_penalty", stability, stability_np),  # -1 while fallen or tilted: -100
    RewardTerm("forward", "forward_penalty", forward, forward_np),  # -1 below FORWARD_MIN_SPEED: -0.3
    # ours: the success bonus, the off-course and fall fines, paid once
    RewardTerm("goal", "goal_bonus", goal, goal_np, per_step=False),
    RewardTerm("off_course", "off_course_penalty", off_course, off_course_np, per_step=False),
    RewardTerm("fall", "fall_penalty", fall, fall_np, per_step=False),
    # ours: the stability shaping
    RewardTerm("tilt", "w_tilt", tilt, tilt_np, cost=True),
    RewardTerm("ang_vel", "w_ang_vel", ang_vel, ang_vel_np, cost=True),
    RewardTerm("action_rate", "w_action_rate", action_rate, action_rate_np, state=False, cost=True),
    # ours: the drift from the start-to-goal line
    RewardTerm("lateral", "w_lateral", lateral, lateral_np, cost=True),
)
REWARD_NAMES = tuple(t.name for t in REWARD_TERMS)  # the columns of ``terms``


def reward_weights(reward, table=REWARD_TERMS):
    """The table's weights from a ``RewardConfig``, in column order: the kernel's ``weights`` argument."""
    return wp.types.vector(len(table), wp.float32)(*(float(getattr(reward, t.weight)) for t in table))


def reward_table(reward) -> tuple:
    """The rows of ``REWARD_TERMS`` a ``RewardConfig`` chooses (``RewardConfig.terms``), in table order."""
    return choose(REWARD_TERMS, reward.terms, "reward.terms")


@functools.cache
def make_rewards_kernel(table: tuple = REWARD_TERMS) -> wp.Kernel:
    """The fused reward kernel of a term table, one per table in a process (:data:`rewards_kernel` is
    ``REWARD_TERMS``'; the env's is :func:`reward_table`'s choice)."""

    @wp.kernel(module="unique")
    def rewards_kernel(
        inputs: RewardInputs,
        weights: wp.types.vector(len(table), wp.float32),
        reward: wp.array[wp.float32],
        terms: wp.array2d[wp.float32],
    ):
        """Every term of the table (weighted) into ``terms[env, k]`` and their sum, in table order, into
        ``reward[env]``; then this step's base x, y and clamped actions become ``prev_xy`` and ``prev_actions``. Runs after
        the episode status, before the episode counters advance."""
        env = wp.tid()
        frame = reward_frame(inputs, env)
        total = float(0.0)
        for k in range(wp.static(len(table))):
            w = weights[wp.static(k)]
            if wp.static(table[k].cost):
                w = -w
            t = w * wp.static(table[k].func)(inputs, frame)
            if wp.static(table[k].per_step):
                t = t * frame.scale
            if wp.static(table[k].state):
                if not frame.ok:
                    t = 0.0
            if not wp.isfinite(t):
                t = 0.0
            terms[env, wp.static(k)] = t
            if wp.static(k == 0):
                total = t
            else:
                total = total + t
        reward[env] = total
        here = wp.vec2(0.0, 0.0)
        if frame.ok:
            here = wp.vec2(frame.px, frame.py)
        inputs.prev_xy[env] = here
        for k in range(inputs.actions.shape[1]):
            inputs.prev_actions[env, k] = clamped_action(inputs, env, k)

    return rewards_kernel


rewards_kernel = make_rewards_kernel(REWARD_TERMS)


def rewards_reference(inputs, table=REWARD_TERMS):
    """Float64 reference of :func:`make_rewards_kernel`'s kernel. ``inputs`` has :class:`RewardInputs`' fields as NumPy
    arrays, with ``ground`` (N,), the terrain under each base, in place of ``hf``, and ``task`` / ``reward`` a
    ``TaskConfig`` / ``RewardConfig``, ``goals`` :class:`Goals`' fields as NumPy arrays. Returns (reward (N,), terms
    (N, len(table)), prev_xy (N, 2), prev_actions (N, A)).
    """
    with np.errstate(invalid="ignore", over="ignore"):
        frame = reward_frame_np(inputs)
        cols = []
        for row in table:
            t = (-1.0 if row.cost else 1.0) * getattr(inputs.reward, row.weight) * row.reference(inputs, frame)
            if row.per_step:
                t = t * frame.scale
            if row.state:
                t = np.where(frame.ok, t, 0.0)
            cols.append(np.where(np.isfinite(t), t, 0.0))
    terms = np.stack(cols, axis=1)
    prev_xy = np.where(frame.ok[:, None], np.stack([frame.px, frame.py], axis=1), 0.0)
    return terms.sum(axis=1), terms, prev_xy, clamped_actions_np(inputs.actions)
