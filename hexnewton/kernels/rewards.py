"""The paper's reward, Table 1 and Eq. 5, one kernel for every env.

    R_t = w_h r_h + w_d r_d + w_theta r_theta + r_f + r_s   (Eq. 5)   + r_goal + r_off (ours)

The paper leaves the weights, the direction condition and its step length unstated. Our choices follow.

**Units.** Per-step terms are quoted for a 20 ms control step (``REF_DT``) and scaled by
``control_dt / REF_DT``, so they mean the same per second at any control rate. The one-off success bonus is
not scaled.

**The terms** (z is the torso height above the terrain under it, because the terrain height varies):
- r_h (height), "(z_r - 0.11), condition z_r > 0.12": exactly that, and 0 otherwise.
- r_theta (direction), "(cos θ, sin θ) · D / ||D||, condition θ > π/6". Taken literally, a term paid only
  outside the ±30° cone would be largest just outside it. We therefore read the condition as "heading error
  beyond π/6" and pay min(0, (cos θ, sin θ) · D̂ - cos(π/6)) (π/6 is ``RewardConfig.direction_deadband``).
  That is 0 inside the cone and falls continuously to -1 - cos(π/6) = -1.87 when walking backward. The paper's
  D is the start-to-goal vector; ours (``RewardConfig.direction_to_goal``) is the robot-to-goal vector. With
  the start-to-goal D, a robot that has drifted sideways is paid for walking parallel to the goal line and
  past the goal circle (without it, 94 % of a complex run's episodes walked past the goal and off the course).
  The default dead band is 0 (ours, ``RewardConfig``): inside Table 1's ±30° cone nothing asks the policy to
  correct a heading error, and the goal circle (0.5 m at 3.5 m) allows only ~8°.
- r_d (distance), "exp(-(d_n - d_t))": d_n is the distance to the goal and d_t the goal radius, so
  r_d = 1 on reaching the goal.
- r_s (stability), "-100 if z_r < 0.05 or |θ_y| > π/6 or |θ_x| > π/6", weight 1. Paid per (20 ms) step while
  the condition holds. A fall (z < 0.05, or tilt > π/3) ends the episode at that step. The π/6 is
  ``RewardConfig.stability_tilt`` (``train.py --stability_tilt``): climbing 8 cm stairs pitches this robot's
  torso by 19-25° on average (its stance pose is fixed, so the body follows the feet: front feet one or two steps
  above the rear ones), and a -100 fine on every step beyond 30° makes falling cheaper than climbing.
- r_f (forward), "-0.3 if x_r - x_pr < 0.01", weight 1. The paper's step is unstated. 1 cm per 20 ms would
  be 0.5 m/s, twice what the fixed CPG walks. We read the threshold as a speed, ``FORWARD_MIN_SPEED`` =
  0.1 m/s along +x (the start-to-goal direction), i.e. 2 mm per 20 ms step.
- r_goal (ours), +300 when the goal is reached. The episode ends there, so without a bonus the paper's
  rewards would pay more for lingering just outside the goal radius than for entering it. The bonus must
  beat what lingering is worth: r_d is ~1 at the circle's edge, so with gamma = 0.99 walking past it is worth
  up to w_d / (1 - gamma) = 100. A bonus of 100 made missing and entering the circle equal,
  and runs without it stopped aiming (RESULTS.md); 300 makes entering worth three times as much.
- r_off (ours), -100 once when the robot leaves the course (|y - y_start| > 1.5 m, §2.4.4 (2)), as much as
  a fall. Table 1 fines falls but not leaving the course, and a robot stuck at a step earns about -0.07 per
  step (r_f = -0.3 against r_d ~ 0.2 two metres from the goal). Without r_off, PPO learnt to end such
  episodes by walking sideways off the course: on complex terrain 98 % of the training episodes ended off
  course (RESULTS.md). With gamma = 0.99 the discounted cost of lingering is ~ -7, far above -100.

Weights (ours, marked in ``RewardConfig``): w_h = 1, w_d = 1, w_theta = 1.

**Stability shaping** (ours, the table's last three rows; each weight 0 switches its term off,
``RewardConfig.paper_reward()`` all of them). Table 1 fines a tilt only beyond π/6, so inside ±30° a policy is free
to rock the body, and with a -100 cliff at 30° it learns nothing about how far it is from it. Three smooth costs
per 20 ms step (scaled like the others):
- r_tilt = -w_tilt (roll² + pitch²) [rad²]: 10° of pitch costs 0.06 w_tilt, 30° 0.55 w_tilt;
- r_ang_vel = -w_ang_vel (ω_x² + ω_y²), the body's roll and pitch rates [rad/s] in its own frame: the rocking
  that a tilt average hides;
- r_action_rate = -w_action_rate Σ_k (a_k - a_k,prev)² over the 15 actions in [-1, 1] (0 on an episode's first
  step): the CPG parameters should change with the ground, not every control step.

**The table.** ``REWARD_TERMS`` declares every term once, one :class:`RewardTerm` row per term in column order:
its name (logged as ``Reward/<name>``), the ``RewardConfig`` field that weighs it, whether it is paid per 20 ms step
(scaled by ``control_dt / REF_DT``) or once, whether it is a cost (paid as -weight x value), a ``@wp.func`` that
computes its unweighted value for one env from :class:`RewardInputs` and the env's :class:`RewardFrame`, and a
float64 NumPy function of the same value for all envs (from a namespace with the same fields as NumPy arrays and the
frame of :func:`reward_frame_np`). From the table follow the kernel (:func:`make_rewards_kernel`; one launch: the
frame, then each row's function unrolled with ``wp.static``, times its weight and scale, written to ``terms[:, k]``
and summed into ``reward`` in table order), the log names (``TERMS``), the weight vector (:func:`reward_weights`)
and the float64 reference (:func:`rewards_reference`, weighted and summed the same way). A term computed from the
simulator state (``state=True``) is 0 for an env whose base position is not finite (a blown-up env, reset and counted
by the caller), and any term whose value is not finite is 0: training never sees a NaN.

Adding a term touches two places: its row in ``REWARD_TERMS`` with its ``@wp.func`` and NumPy function (both read
``i.task.<field>`` / ``i.reward.<field>`` for any ``TaskConfig`` / ``RewardConfig`` field: ``kernels/tables.py``
makes the structs from the dataclasses), and, for a new weight or parameter, its field in ``RewardConfig``. The env
sizes ``terms``, launches the kernel and logs ``Reward/<name>`` from the table; ``tests/test_terms.py`` checks every
row's Warp function against its NumPy function.
"""

from dataclasses import dataclass
from typing import Callable

import numpy as np
import warp as wp

from ..terrain.query import HeightField, terrain_height
from .reference import quat_rotate_inv_np
from .status import FELL, OFF_COURSE, SUCCESS
from .tables import RewardParams, TaskParams

REF_DT = 0.02
FORWARD_MIN_SPEED = 0.1


@wp.struct
class RewardInputs:
    """What the reward terms read, one row per env. The kernel also writes ``prev_x`` and ``prev_actions`` for the
    next step."""

    joint_q: wp.array2d[wp.float32]  # base position (3), quaternion (x, y, z, w), 18 joint angles
    joint_qd: wp.array2d[wp.float32]  # base linear and angular velocity (world frame), 18 joint velocities
    rpy: wp.array2d[wp.float32]  # roll, pitch, yaw (the terminations kernel's; 0 for a blown-up env)
    status: wp.array[wp.int32]  # this step's episode status (kernels/status.py)
    episode_steps: wp.array[wp.int32]  # the episode's steps before this one
    actions: wp.array2d[wp.float32]  # the policy's actions
    start: wp.array[wp.vec2]  # the episode's start; the goal lies task.goal_distance ahead of it along +x
    hf: HeightField
    prev_x: wp.array[wp.float32]  # base x at the last step
    prev_actions: wp.array2d[wp.float32]  # the last step's actions, clamped to [-1, 1]
    task: TaskParams
    reward: RewardParams


@wp.struct
class RewardFrame:
    """Per-env values the terms share, computed once per step by :func:`reward_frame`."""

    e: int  # the env
    px: float  # base position [m]
    py: float
    z: float  # torso height above the terrain under it [m]
    to_goal: wp.vec2  # goal minus base position [m]
    scale: float  # control_dt / REF_DT: per-step terms mean the same per second at any control rate
    ok: bool  # base position and the terrain height under it are finite


@wp.func
def reward_frame(i: RewardInputs, e: int) -> RewardFrame:
    f = RewardFrame()
    f.e = e
    f.px = i.joint_q[e, 0]
    f.py = i.joint_q[e, 1]
    f.z = i.joint_q[e, 2] - terrain_height(i.hf, f.px, f.py)
    f.to_goal = i.start[e] + wp.vec2(i.task.goal_distance, 0.0) - wp.vec2(f.px, f.py)
    f.scale = i.task.control_dt / REF_DT
    f.ok = wp.isfinite(f.px) and wp.isfinite(f.py) and wp.isfinite(f.z)
    return f


@dataclass(frozen=True)
class FrameNp:
    """:class:`RewardFrame` for all envs, in float64."""

    px: np.ndarray
    py: np.ndarray
    z: np.ndarray
    to_goal: np.ndarray  # (N, 2)
    scale: float
    ok: np.ndarray


def reward_frame_np(i) -> FrameNp:
    """Float64 :func:`reward_frame` for all envs; ``i.ground`` (N,) is the terrain under each base."""
    jq = np.asarray(i.joint_q, np.float64)
    px, py = jq[:, 0], jq[:, 1]
    z = jq[:, 2] - np.asarray(i.ground, np.float64)
    start = np.asarray(i.start, np.float64)
    to_goal = np.stack([start[:, 0] + i.task.goal_distance - px, start[:, 1] - py], axis=1)
    ok = np.isfinite(px) & np.isfinite(py) & np.isfinite(z)
    return FrameNp(px=px, py=py, z=z, to_goal=to_goal, scale=i.task.control_dt / REF_DT, ok=ok)


# ----------------------------------------------------------------------------------------------------
# the terms: unweighted values, one Warp function per env and one NumPy function for all envs
# ----------------------------------------------------------------------------------------------------


@wp.func
def height(i: RewardInputs, f: RewardFrame) -> float:
    """r_h: z - 0.11 above 0.12 m, else 0."""
    r = float(0.0)
    if f.z > 0.12:
        r = f.z - 0.11
    return r


def height_np(i, f):
    return np.where(f.z > 0.12, f.z - 0.11, 0.0)


@wp.func
def direction(i: RewardInputs, f: RewardFrame) -> float:
    """r_theta: min(0, cos(heading error) - cos(dead band)), toward the goal (ours) or along +x."""
    # the start-to-goal direction D is +x, so (cos θ, sin θ) . D / |D| = cos(yaw); ours: D from the robot
    bearing = float(0.0)
    if i.reward.direction_to_goal:
        bearing = wp.atan2(f.to_goal[1], f.to_goal[0])
    return wp.min(0.0, wp.cos(i.rpy[f.e, 2] - bearing) - wp.cos(i.reward.direction_deadband))


def direction_np(i, f):
    bearing = np.arctan2(f.to_goal[:, 1], f.to_goal[:, 0]) if i.reward.direction_to_goal else 0.0
    return np.minimum(0.0, np.cos(np.asarray(i.rpy, np.float64)[:, 2] - bearing) - np.cos(i.reward.direction_deadband))


@wp.func
def distance(i: RewardInputs, f: RewardFrame) -> float:
    """r_d: exp(-(d_n - d_t)), 1 on the goal circle."""
    return wp.exp(-(wp.length(f.to_goal) - i.task.goal_radius))


def distance_np(i, f):
    return np.exp(-(np.hypot(f.to_goal[:, 0], f.to_goal[:, 1]) - i.task.goal_radius))


@wp.func
def stability(i: RewardInputs, f: RewardFrame) -> float:
    """-1 while z < 0.05 m, |roll| or |pitch| > stability_tilt, or fallen (r_s = stability_penalty x this)."""
    lim = i.reward.stability_tilt
    tilted = wp.abs(i.rpy[f.e, 0]) > lim or wp.abs(i.rpy[f.e, 1]) > lim
    r = float(0.0)
    if f.z < 0.05 or tilted or i.status[f.e] == FELL:
        r = -1.0
    return r


def stability_np(i, f):
    rpy = np.asarray(i.rpy, np.float64)
    tilted = (np.abs(rpy[:, 0]) > i.reward.stability_tilt) | (np.abs(rpy[:, 1]) > i.reward.stability_tilt)
    return np.where((f.z < 0.05) | tilted | (np.asarray(i.status) == FELL), -1.0, 0.0)


@wp.func
def forward(i: RewardInputs, f: RewardFrame) -> float:
    """-1 below FORWARD_MIN_SPEED along +x (r_f = forward_penalty x this)."""
    r = float(0.0)
    if f.px - i.prev_x[f.e] < FORWARD_MIN_SPEED * i.task.control_dt:
        r = -1.0
    return r


def forward_np(i, f):
    return np.where(f.px - np.asarray(i.prev_x, np.float64) < FORWARD_MIN_SPEED * i.task.control_dt, -1.0, 0.0)


@wp.func
def goal(i: RewardInputs, f: RewardFrame) -> float:
    """1 on reaching the goal (ours: r_goal = goal_bonus x this)."""
    r = float(0.0)
    if i.status[f.e] == SUCCESS:
        r = 1.0
    return r


def goal_np(i, f):
    return np.where(np.asarray(i.status) == SUCCESS, 1.0, 0.0)


@wp.func
def off_course(i: RewardInputs, f: RewardFrame) -> float:
    """-1 on leaving the course (ours: r_off = off_course_penalty x this)."""
    r = float(0.0)
    if i.status[f.e] == OFF_COURSE:
        r = -1.0
    return r


def off_course_np(i, f):
    return np.where(np.asarray(i.status) == OFF_COURSE, -1.0, 0.0)


@wp.func
def tilt(i: RewardInputs, f: RewardFrame) -> float:
    """roll² + pitch² [rad²], a cost: r_tilt = -w_tilt x this."""
    return i.rpy[f.e, 0] * i.rpy[f.e, 0] + i.rpy[f.e, 1] * i.rpy[f.e, 1]


def tilt_np(i, f):
    rpy = np.asarray(i.rpy, np.float64)
    return rpy[:, 0] ** 2 + rpy[:, 1] ** 2


@wp.func
def body_roll_pitch_rate(qx: float, qy: float, qz: float, qw: float, wx: float, wy: float, wz: float) -> wp.vec2:
    """The base's world-frame angular velocity (a free joint's qd[3:6]) in its own frame: (roll rate, pitch rate)."""
    w_body = wp.quat_rotate_inv(wp.quat(qx, qy, qz, qw), wp.vec3(wx, wy, wz))
    return wp.vec2(w_body[0], w_body[1])


@wp.func
def ang_vel(i: RewardInputs, f: RewardFrame) -> float:
    """ω_x² + ω_y², the body's roll and pitch rates in its own frame [(rad/s)²]; a cost: r_ang_vel = -w_ang_vel x
    this."""
    e = f.e
    rate = body_roll_pitch_rate(i.joint_q[e, 3], i.joint_q[e, 4], i.joint_q[e, 5], i.joint_q[e, 6], i.joint_qd[e, 3],
                                i.joint_qd[e, 4], i.joint_qd[e, 5])  # fmt: skip
    return rate[0] * rate[0] + rate[1] * rate[1]


def ang_vel_np(i, f):
    w_body = quat_rotate_inv_np(np.asarray(i.joint_q, np.float64)[:, 3:7], np.asarray(i.joint_qd, np.float64)[:, 3:6])
    return w_body[:, 0] ** 2 + w_body[:, 1] ** 2


@wp.func
def clamped_action(i: RewardInputs, e: int, k: int) -> float:
    """Action k of env e in [-1, 1] (0 if not finite), as the action scaling reads it."""
    a = i.actions[e, k]
    if not wp.isfinite(a):
        a = 0.0
    return wp.clamp(a, -1.0, 1.0)


def clamped_actions_np(actions):
    return np.clip(np.nan_to_num(np.asarray(actions, np.float64), nan=0.0), -1.0, 1.0)


@wp.func
def action_rate(i: RewardInputs, f: RewardFrame) -> float:
    """Σ_k (a_k - a_k,prev)² (0 on an episode's first step), a cost: r_action_rate = -w_action_rate x this."""
    da = float(0.0)
    if i.episode_steps[f.e] > 0:
        for k in range(i.actions.shape[1]):
            d = clamped_action(i, f.e, k) - i.prev_actions[f.e, k]
            da += d * d
    return da


def action_rate_np(i, f):
    da = ((clamped_actions_np(i.actions) - np.asarray(i.prev_actions, np.float64)) ** 2).sum(axis=1)
    return np.where(np.asarray(i.episode_steps) > 0, da, 0.0)


# ----------------------------------------------------------------------------------------------------
# the table
# ----------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RewardTerm:
    """One reward term: ``terms[:, k] = (-)reward.<weight> * func(i, f) [* control_dt / REF_DT if per_step]``."""

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
    # ours: the success bonus and the off-course fine, paid once
    RewardTerm("goal", "goal_bonus", goal, goal_np, per_step=False),
    RewardTerm("off_course", "off_course_penalty", off_course, off_course_np, per_step=False),
    # ours: the stability shaping
    RewardTerm("tilt", "w_tilt", tilt, tilt_np, cost=True),
    RewardTerm("ang_vel", "w_ang_vel", ang_vel, ang_vel_np, cost=True),
    RewardTerm("action_rate", "w_action_rate", action_rate, action_rate_np, state=False, cost=True),
)
TERMS = tuple(t.name for t in REWARD_TERMS)  # the columns of ``terms``


def reward_weights(reward, table=REWARD_TERMS):
    """The table's weights from a ``RewardConfig``, in column order: the kernel's ``weights`` argument."""
    return wp.types.vector(len(table), wp.float32)(*(float(getattr(reward, t.weight)) for t in table))


def make_rewards_kernel(table=REWARD_TERMS) -> wp.Kernel:
    """The fused reward kernel of a term table (:data:`rewards_kernel` is ``REWARD_TERMS``')."""

    @wp.kernel(module="unique")
    def rewards_kernel(
        i: RewardInputs,
        weights: wp.types.vector(len(table), wp.float32),
        reward: wp.array[wp.float32],
        terms: wp.array2d[wp.float32],
    ):
        """Every term of the table (weighted) into ``terms[e, k]`` and their sum, in table order, into ``reward[e]``;
        then this step's base x and clamped actions become ``prev_x`` and ``prev_actions``. Runs after the episode
        status, before the episode counters advance."""
        e = wp.tid()
        f = reward_frame(i, e)
        total = float(0.0)
        for k in range(wp.static(len(table))):
            w = weights[wp.static(k)]
            if wp.static(table[k].cost):
                w = -w
            t = w * wp.static(table[k].func)(i, f)
            if wp.static(table[k].per_step):
                t = t * f.scale
            if wp.static(table[k].state):
                if not f.ok:
                    t = 0.0
            if not wp.isfinite(t):
                t = 0.0
            terms[e, wp.static(k)] = t
            if wp.static(k == 0):
                total = t
            else:
                total = total + t
        reward[e] = total
        px = float(0.0)
        if f.ok:
            px = f.px
        i.prev_x[e] = px
        for k in range(i.actions.shape[1]):
            i.prev_actions[e, k] = clamped_action(i, e, k)

    return rewards_kernel


rewards_kernel = make_rewards_kernel()


def rewards_reference(i, table=REWARD_TERMS):
    """Float64 reference of :func:`make_rewards_kernel`'s kernel. ``i`` has :class:`RewardInputs`' fields as NumPy
    arrays, with ``ground`` (N,), the terrain under each base, in place of ``hf``, and ``task`` / ``reward`` a
    ``TaskConfig`` / ``RewardConfig``. Returns (reward (N,), terms (N, len(table)), prev_x (N,), prev_actions (N, A)).
    """
    with np.errstate(invalid="ignore", over="ignore"):
        f = reward_frame_np(i)
        cols = []
        for row in table:
            t = (-1.0 if row.cost else 1.0) * getattr(i.reward, row.weight) * row.reference(i, f)
            if row.per_step:
                t = t * f.scale
            if row.state:
                t = np.where(f.ok, t, 0.0)
            cols.append(np.where(np.isfinite(t), t, 0.0))
    terms = np.stack(cols, axis=1)
    return terms.sum(axis=1), terms, np.where(f.ok, f.px, 0.0), clamped_actions_np(i.actions)
