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

**Stability shaping** (ours, :func:`shaping_kernel`, after the Table 1 kernel; each weight 0 switches its term off,
``RewardConfig.paper_reward()`` all of them). Table 1 fines a tilt only beyond π/6, so inside ±30° a policy is free
to rock the body, and with a -100 cliff at 30° it learns nothing about how far it is from it. Three smooth costs
per 20 ms step (scaled like the others):
- r_tilt = -w_tilt (roll² + pitch²) [rad²]: 10° of pitch costs 0.06 w_tilt, 30° 0.55 w_tilt;
- r_ang_vel = -w_ang_vel (ω_x² + ω_y²), the body's roll and pitch rates [rad/s] in its own frame: the rocking
  that a tilt average hides;
- r_action_rate = -w_action_rate Σ_k (a_k - a_k,prev)² over the 15 actions in [-1, 1] (0 on an episode's first
  step): the CPG parameters should change with the ground, not every control step.
"""

import numpy as np
import warp as wp

from ..terrain.query import HeightField, terrain_height
from .terminations import FELL, OFF_COURSE, SUCCESS

REF_DT = 0.02
FORWARD_MIN_SPEED = 0.1
#: Table 1's terms and ours (rewards_kernel), then the stability shaping (shaping_kernel)
TABLE1_TERMS = ("height", "direction", "distance", "stability", "forward", "goal", "off_course")
SHAPING_TERMS = ("tilt", "ang_vel", "action_rate")
TERMS = TABLE1_TERMS + SHAPING_TERMS


@wp.kernel
def rewards_kernel(
    joint_q: wp.array2d[wp.float32],
    rpy: wp.array2d[wp.float32],
    status: wp.array[wp.int32],
    hf: HeightField,
    start: wp.array[wp.vec2],
    goal_distance: float,
    goal_radius: float,
    w_height: float,
    w_direction: float,
    w_distance: float,
    direction_deadband: float,
    direction_to_goal: int,
    stability_penalty: float,
    stability_tilt: float,
    forward_penalty: float,
    goal_bonus: float,
    off_course_penalty: float,
    control_dt: float,
    prev_x: wp.array[wp.float32],
    reward: wp.array[wp.float32],
    terms: wp.array2d[wp.float32],
):
    e = wp.tid()
    scale = control_dt / REF_DT
    px = joint_q[e, 0]
    py = joint_q[e, 1]
    z = joint_q[e, 2] - terrain_height(hf, px, py)
    st = status[e]
    if not (wp.isfinite(px) and wp.isfinite(py) and wp.isfinite(z)):
        # a blown-up env (reset and counted by the caller): no reward signal from garbage
        for k in range(terms.shape[1]):
            terms[e, k] = 0.0
        reward[e] = 0.0
        prev_x[e] = 0.0
        return
    r_h = float(0.0)
    if z > 0.12:
        r_h = z - 0.11
    to_goal = start[e] + wp.vec2(goal_distance, 0.0) - wp.vec2(px, py)
    # the start-to-goal direction D is +x, so (cos θ, sin θ) . D / |D| = cos(yaw); ours: D from the robot
    bearing = float(0.0)
    if direction_to_goal != 0:
        bearing = wp.atan2(to_goal[1], to_goal[0])
    r_dir = wp.min(0.0, wp.cos(rpy[e, 2] - bearing) - wp.cos(direction_deadband))
    d_n = wp.length(to_goal)
    r_d = wp.exp(-(d_n - goal_radius))
    tilted = wp.abs(rpy[e, 0]) > stability_tilt or wp.abs(rpy[e, 1]) > stability_tilt
    r_s = float(0.0)
    if z < 0.05 or tilted or st == FELL:
        r_s = -stability_penalty
    r_f = float(0.0)
    if px - prev_x[e] < FORWARD_MIN_SPEED * control_dt:
        r_f = -forward_penalty
    r_g = float(0.0)
    if st == SUCCESS:
        r_g = goal_bonus
    r_off = float(0.0)
    if st == OFF_COURSE:
        r_off = -off_course_penalty
    t0 = w_height * r_h * scale
    t1 = w_direction * r_dir * scale
    t2 = w_distance * r_d * scale
    t3 = r_s * scale
    t4 = r_f * scale
    terms[e, 0] = t0
    terms[e, 1] = t1
    terms[e, 2] = t2
    terms[e, 3] = t3
    terms[e, 4] = t4
    terms[e, 5] = r_g
    terms[e, 6] = r_off
    reward[e] = t0 + t1 + t2 + t3 + t4 + r_g + r_off
    prev_x[e] = px


def rewards_reference(joint_q, rpy, status, ground, start, prev_x, goal_distance, goal_radius, w_height, w_direction,
                      w_distance, direction_deadband, direction_to_goal, stability_penalty, stability_tilt,
                      forward_penalty, goal_bonus, off_course_penalty, control_dt):  # fmt: skip
    """Float64 reference of :func:`rewards_kernel` (finite states); ``ground`` (N,) is the terrain under the base.

    Returns (reward (N,), terms (N, 7))."""
    jq, rpy = np.asarray(joint_q, np.float64), np.asarray(rpy, np.float64)
    start = np.asarray(start, np.float64)
    scale = control_dt / REF_DT
    z = jq[:, 2] - ground
    r_h = np.where(z > 0.12, z - 0.11, 0.0)
    gx, gy = start[:, 0] + goal_distance - jq[:, 0], start[:, 1] - jq[:, 1]
    bearing = np.arctan2(gy, gx) if direction_to_goal else 0.0
    r_dir = np.minimum(0.0, np.cos(rpy[:, 2] - bearing) - np.cos(direction_deadband))
    d_n = np.hypot(gx, gy)
    r_d = np.exp(-(d_n - goal_radius))
    tilted = (np.abs(rpy[:, 0]) > stability_tilt) | (np.abs(rpy[:, 1]) > stability_tilt)
    r_s = np.where((z < 0.05) | tilted | (np.asarray(status) == FELL), -stability_penalty, 0.0)
    r_f = np.where(jq[:, 0] - np.asarray(prev_x, np.float64) < FORWARD_MIN_SPEED * control_dt, -forward_penalty, 0.0)
    r_g = np.where(np.asarray(status) == SUCCESS, goal_bonus, 0.0)
    r_off = np.where(np.asarray(status) == OFF_COURSE, -off_course_penalty, 0.0)
    terms = np.stack([w_height * r_h * scale, w_direction * r_dir * scale, w_distance * r_d * scale, r_s * scale,
                      r_f * scale, r_g, r_off], axis=1)  # fmt: skip
    return terms.sum(axis=1), terms


@wp.func
def body_roll_pitch_rate(qx: float, qy: float, qz: float, qw: float, wx: float, wy: float, wz: float) -> wp.vec2:
    """The base's world-frame angular velocity (a free joint's qd[3:6]) in its own frame: (roll rate, pitch rate)."""
    w_body = wp.quat_rotate_inv(wp.quat(qx, qy, qz, qw), wp.vec3(wx, wy, wz))
    return wp.vec2(w_body[0], w_body[1])


@wp.kernel
def shaping_kernel(
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    rpy: wp.array2d[wp.float32],
    actions: wp.array2d[wp.float32],
    episode_steps: wp.array[wp.int32],
    w_tilt: float,
    w_ang_vel: float,
    w_action_rate: float,
    control_dt: float,
    prev_actions: wp.array2d[wp.float32],
    reward: wp.array[wp.float32],
    terms: wp.array2d[wp.float32],
):
    """The stability shaping terms (module docstring), added to ``reward`` and written to ``terms[:, 7:10]``; then the
    actions become ``prev_actions``. Runs after :func:`rewards_kernel`, before the episode counters advance."""
    e = wp.tid()
    scale = control_dt / REF_DT
    rate = body_roll_pitch_rate(joint_q[e, 3], joint_q[e, 4], joint_q[e, 5], joint_q[e, 6], joint_qd[e, 3],
                                joint_qd[e, 4], joint_qd[e, 5])  # fmt: skip
    da = float(0.0)
    for k in range(actions.shape[1]):
        a = actions[e, k]
        if not wp.isfinite(a):
            a = 0.0
        a = wp.clamp(a, -1.0, 1.0)
        if episode_steps[e] > 0:
            d = a - prev_actions[e, k]
            da += d * d
        prev_actions[e, k] = a
    t_tilt = -w_tilt * (rpy[e, 0] * rpy[e, 0] + rpy[e, 1] * rpy[e, 1]) * scale
    t_rate = -w_ang_vel * (rate[0] * rate[0] + rate[1] * rate[1]) * scale
    t_act = -w_action_rate * da * scale
    if not (wp.isfinite(t_tilt) and wp.isfinite(t_rate) and wp.isfinite(reward[e])):
        t_tilt = 0.0  # a blown-up env (reset and counted by the caller)
        t_rate = 0.0
    terms[e, 7] = t_tilt
    terms[e, 8] = t_rate
    terms[e, 9] = t_act
    reward[e] = reward[e] + t_tilt + t_rate + t_act


def shaping_reference(joint_q, joint_qd, rpy, actions, prev_actions, episode_steps, w_tilt, w_ang_vel, w_action_rate,
                      control_dt):  # fmt: skip
    """Float64 reference of :func:`shaping_kernel` (finite states). Returns (terms (N, 3), new prev_actions (N, A))."""
    from .reference import quat_rotate_inv_np

    jq, jqd, rpy = (np.asarray(x, np.float64) for x in (joint_q, joint_qd, rpy))
    scale = control_dt / REF_DT
    w_body = quat_rotate_inv_np(jq[:, 3:7], jqd[:, 3:6])
    a = np.clip(np.nan_to_num(np.asarray(actions, np.float64), nan=0.0), -1.0, 1.0)
    da = np.where(np.asarray(episode_steps) > 0, ((a - np.asarray(prev_actions, np.float64)) ** 2).sum(axis=1), 0.0)
    terms = np.stack([-w_tilt * (rpy[:, 0] ** 2 + rpy[:, 1] ** 2), -w_ang_vel * (w_body[:, 0] ** 2 + w_body[:, 1] ** 2),
                      -w_action_rate * da], axis=1) * scale  # fmt: skip
    return terms, a
