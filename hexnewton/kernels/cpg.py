"""The CPG: the policy's action to the CPG parameters, the mid level (Huang et al. 2025, Eq. 3) and the low level
(Eq. 4), as Warp kernels and :class:`CPGController`, which drives a ``World``'s joints every substep.

``CPGController(world, cfg)`` owns, per env:
- ``params_target`` (N, P): the parameters the high level asks for, in physical units (P = 15, or 18 with the
  body posture, ``CPGConfig.posture``);
- ``params`` (N, P): their filtered values, which the oscillators and the mapping actually use;
- ``state`` (N, 4): the oscillators' (x0, y0, x1, y1);
- ``dy`` (N, 2): the oscillators' dy/dt.

The high level writes actions with ``set_actions`` (policy actions in [-1, 1]: one launch of
:func:`scale_actions_kernel` per control step) or ``set_params`` (physical values). Call
``world.set_controller(controller)``: before every physics substep (inside the captured graph) the controller
launches :func:`hopf_cpg_kernel` and then :func:`mapping_kernel`, which writes the 18 joint targets into Newton's
control array. Float64 references of every kernel: ``kernels/reference.py`` (the deployment runtime runs them too).

Actions -> parameters
---------------------
A policy action in [-1, 1]^15 (18 with the body posture) to the physical CPG parameters:

    p_k = lo_k + (clip(a_k, -1, 1) + 1) / 2 * (hi_k - lo_k)

with the ranges of ``CPGConfig`` (omega in rad/s, amplitudes in rad). A non-finite action component maps
to the middle of its range, so a diverged policy cannot poison the oscillators.

Pure DRL (the comparison without the CPG, action mode ``joint``): 18 actions in [-1, 1] are joint targets about
the standing pose, ``q = stand + TaskConfig.joint_action_scale * a`` clipped to the joint limits, as legged-robot
RL usually scales joint-position actions (a scale of 0.5 rad reaches most of each joint's range). A scale of 0
maps the actions onto each joint's whole limit range instead, ``q = lo + (a + 1) / 2 (hi - lo)``.

Mid level: two coupled Hopf oscillators (Eq. 3), batched per env, one RK4 step per call
----------------------------------------------------------------------------------------
For oscillator i with partner j (state x, y; r^2 = x^2 + y^2):

    dx_i/dt = alpha (mu - r_i^2) x_i - w_i y_i
    dy_i/dt = w_i x_i + alpha (mu - r_i^2) y_i + delta * Delta_ji
    Delta_ji = y_j cos(theta_ji) - x_j sin(theta_ji)

The oscillators run counter-clockwise (phase phi with x = r cos phi, y = r sin phi). The coupling pulls
phi_i toward phi_j - theta_ji (averaged phase dynamics: d(phi_0 - phi_1)/dt = -delta sin(phi_0 - phi_1 -
theta)). We take theta_10 = -theta and theta_01 = theta, so the pair locks at phi_0 - phi_1 = theta for
any theta. At the paper's theta = pi the two are the same, and the oscillators lock in anti-phase: the
tripod gait.

Swing/stance frequencies (Eq. 3 names omega_sw and omega_st but gives no formula). The paper calls the
rising edge of y the swing phase (§2.3). Near the limit cycle, y rises exactly while x > 0. We use the
usual logistic blend (Righetti & Ijspeert 2008), keyed on x so that it follows the paper's edges:

    w_i = omega_sw / (1 + exp(-b x_i / sqrt(mu))) + omega_st / (1 + exp(b x_i / sqrt(mu)))
    omega_sw = omega / (2 (1 - duty)),   omega_st = omega / (2 duty)

Half a cycle at omega_sw plus half at omega_st lasts 2 pi / omega, so the high-level omega is the
commanded stride frequency for any duty factor. At duty = 0.5 (the default), w = omega.

Frequency compensation: when locked (phi_j - theta = phi_i), the y-only coupling adds delta sin(phi)
cos(phi) to dphi/dt. That slows one cycle to 2 pi / sqrt(w^2 - delta^2 / 4): 28 % slow at omega = 4 rad/s
with delta = 5. The kernel therefore integrates with omega_c = sqrt(omega^2 + delta^2 / 4) in place of
omega, so the oscillators really run at the commanded omega (tested to 2 %).

Before integrating, the call moves the 15 high-level parameters a first-order step toward their targets:
p += gain * (target - p), with gain = 1 - exp(-dt / tau). The new action changes the oscillators' speed
and the amplitudes smoothly, so the joint targets never jump.

State layout per env: ``state[e] = (x0, y0, x1, y1)``. ``dy[e] = (dy0/dt, dy1/dt)`` is evaluated at the
new state; the mapping function (Eq. 4) reads its sign.

Low level: the mapping function (Eq. 4), from oscillator output to the 18 joint targets
----------------------------------------------------------------------------------------
For every leg, with its oscillator's normalised output y = y_osc / sqrt(mu) (in [-1, 1] on the limit cycle):

    hip   = A1[side] * y
    knee  = A2[leg] * (1 - y^2)    while y is rising (dy/dt >= 0, the swing phase, §2.3), else 0
    ankle = -A3[leg] * (1 - y^2)   while y is rising, else 0

Eq. 4 writes the ankle as -A3 * phi_2, but the paper's text calls A3 "the amplitude of the ankle joint",
and the policy's ranges treat A1, A2 and A3 alike as angles. We therefore read A3 as the ankle's own
amplitude, so ankle = -(A3 / A2) * knee. The knee and ankle both vanish at y = +-1, where the edge
changes, so the targets stay continuous. A1 has one value per side: A1[1] for the right legs, A1[2] for
the left. A2 and A3 have one value per leg.

The outputs are offsets from the standing pose. They are clipped to the joint limits and written straight
into Newton's ``control.joint_target_q``. The robot's joint convention (``hexnewton.config``) already
mirrors the left side: hip > 0 swings the foot forward on every leg. So the same formula makes every
stance leg push backward, and no sign flip is needed here.

Tripods: R1, L2, R3 follow oscillator 0; L1, R2, L3 follow oscillator 1. With leg order R1, R2, R3, L1,
L2, L3 that is ``oscillator = leg % 2``.
Parameter layout per env (15): omega, A1_R, A1_L, A2[R1..L3], A3[R1..L3].

Body posture (ours, ``CPGConfig.posture``; off for the paper's 15 parameters): three more parameters
P_h, P_p, P_r (columns 15..17) add a knee offset to every leg in both phases,

    knee += P_h + P_p * fx[leg] + P_r * sy[leg],   fx = +1 front, 0 middle, -1 rear;  sy = +1 right, -1 left

A positive knee angle raises the foot, so in stance P_h lowers the body, P_p > 0 lowers its front (nose down)
and P_r > 0 lowers its right side. With Eq. 4 alone a stance leg holds the standing pose whatever the ground
under it; the posture terms let the high level level the body over uneven footholds (the stance-knee /
pitch feedback of the paper's ref. [19]). A params array of 15 columns leaves them out.

Levelling reflex (ours, ``CPGConfig.posture_reflex``, with the posture only): at every substep the body's
measured pitch and roll (an IMU's reading) feed back into the tilt terms,

    P_p' = clamp(P_p - k * pitch, -tilt_max, tilt_max),   P_r' = clamp(P_r - k * roll, -tilt_max, tilt_max)

so the legs under a raised corner bend within milliseconds while the policy (50 Hz, through the parameter
filter) sets the posture it wants. k = 0 turns the reflex off.

Stuck response (ours, ``CPGConfig.stuck_lift``; 0 = off): a way out for a foot caught between blocks. Once per
control step, after the actions are scaled, :func:`stuck_response_kernel` reads each robot's goal distance from the
target the policy observes (the goal relative to the robot, odometry on a real robot) into a ring of its last
``stuck_window`` distances. A robot whose distance fell by less than ``stuck_progress`` over that window walks the next
``stuck_hold`` control steps with ``stuck_lift`` more knee amplitude A2 on every leg (the knee target stays clipped
to its limit), then, while it still gains no ground, again. ``reset`` empties the ring of the envs it resets.
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from hexnewton.config import CPGConfig, RobotConfig
from hexnewton.kernels.reference import initial_cpg_state
from hexnewton.kernels.world import as_mask
from hexnewton.robot import BASE_Q, leg_bounds

# ----------------------------------------------------------------------------------------------------
# actions -> parameters
# ----------------------------------------------------------------------------------------------------


@wp.func
def action_to_range(a: float, lo: float, hi: float) -> float:
    """lo + (clip(a, -1, 1) + 1) / 2 * (hi - lo); a non-finite action maps to the middle of the range."""
    if not wp.isfinite(a):
        a = 0.0
    return lo + 0.5 * (wp.clamp(a, -1.0, 1.0) + 1.0) * (hi - lo)


@wp.kernel
def scale_actions_kernel(
    actions: wp.array2d[wp.float32],
    lower: wp.array[wp.float32],
    upper: wp.array[wp.float32],
    params_target: wp.array2d[wp.float32],
):
    e, k = wp.tid()
    params_target[e, k] = action_to_range(actions[e, k], lower[k], upper[k])


@wp.kernel
def joint_actions_kernel(
    actions: wp.array2d[wp.float32],
    stand: wp.vec3,
    lower: wp.vec3,
    upper: wp.vec3,
    scale: float,
    target_offset: int,
    targets: wp.array2d[wp.float32],
):
    """The pure-DRL action mode: 18 actions in [-1, 1] to joint targets, ``stand + scale * a`` clipped to the limits
    (``scale`` 0: each action spans its joint's whole limit range)."""
    e, j = wp.tid()
    k = j % 3
    q = action_to_range(actions[e, j], lower[k], upper[k])
    if scale > 0.0:
        a = actions[e, j]
        if not wp.isfinite(a):
            a = 0.0
        q = wp.clamp(stand[k] + scale * wp.clamp(a, -1.0, 1.0), lower[k], upper[k])
    targets[e, target_offset + j] = q


# ----------------------------------------------------------------------------------------------------
# mid level (Eq. 3)
# ----------------------------------------------------------------------------------------------------


@wp.func
def _blend_omega(omega: float, x: float, inv_sqrt_mu: float, duty: float, steepness: float) -> float:
    w_sw = omega / (2.0 * (1.0 - duty))
    w_st = omega / (2.0 * duty)
    z = steepness * x * inv_sqrt_mu
    z = wp.clamp(z, -60.0, 60.0)
    return w_sw / (1.0 + wp.exp(-z)) + w_st / (1.0 + wp.exp(z))


@wp.func
def hopf_rhs(
    s: wp.vec4, omega: float, alpha: float, mu: float, delta: float, theta: float, duty: float, steepness: float
) -> wp.vec4:
    """Time derivative of (x0, y0, x1, y1) under Eq. 3."""
    inv_sqrt_mu = 1.0 / wp.sqrt(mu)
    c = wp.cos(theta)
    sn = wp.sin(theta)
    x0 = s[0]
    y0 = s[1]
    x1 = s[2]
    y1 = s[3]
    g0 = alpha * (mu - (x0 * x0 + y0 * y0))
    g1 = alpha * (mu - (x1 * x1 + y1 * y1))
    w0 = _blend_omega(omega, x0, inv_sqrt_mu, duty, steepness)
    w1 = _blend_omega(omega, x1, inv_sqrt_mu, duty, steepness)
    return wp.vec4(
        g0 * x0 - w0 * y0,
        w0 * x0 + g0 * y0 + delta * (y1 * c + x1 * sn),
        g1 * x1 - w1 * y1,
        w1 * x1 + g1 * y1 + delta * (y0 * c - x0 * sn),
    )


@wp.kernel
def hopf_cpg_kernel(
    params_target: wp.array2d[wp.float32],
    gain: float,
    alpha: float,
    mu: float,
    delta: float,
    theta: float,
    duty: float,
    steepness: float,
    dt: float,
    params: wp.array2d[wp.float32],
    state: wp.array2d[wp.float32],
    dy: wp.array2d[wp.float32],
):
    """Filter the 15 parameters toward their targets, then advance both oscillators by one RK4 step."""
    e = wp.tid()
    for k in range(params.shape[1]):
        params[e, k] = params[e, k] + gain * (params_target[e, k] - params[e, k])
    omega = wp.sqrt(params[e, 0] * params[e, 0] + 0.25 * delta * delta)  # see "Frequency compensation"
    s = wp.vec4(state[e, 0], state[e, 1], state[e, 2], state[e, 3])
    k1 = hopf_rhs(s, omega, alpha, mu, delta, theta, duty, steepness)
    k2 = hopf_rhs(s + 0.5 * dt * k1, omega, alpha, mu, delta, theta, duty, steepness)
    k3 = hopf_rhs(s + 0.5 * dt * k2, omega, alpha, mu, delta, theta, duty, steepness)
    k4 = hopf_rhs(s + dt * k3, omega, alpha, mu, delta, theta, duty, steepness)
    s = s + (dt / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    for k in range(4):
        state[e, k] = s[k]
    d = hopf_rhs(s, omega, alpha, mu, delta, theta, duty, steepness)
    dy[e, 0] = d[1]
    dy[e, 1] = d[3]


# ----------------------------------------------------------------------------------------------------
# low level (Eq. 4)
# ----------------------------------------------------------------------------------------------------


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
def mapping_kernel(
    state: wp.array2d[wp.float32],
    dy: wp.array2d[wp.float32],
    params: wp.array2d[wp.float32],
    inv_sqrt_mu: float,
    stand: wp.vec3,
    lower: wp.vec3,
    upper: wp.vec3,
    target_offset: int,
    joint_q: wp.array2d[wp.float32],
    reflex: float,
    tilt_max: float,
    targets: wp.array2d[wp.float32],
):
    e = wp.tid()
    posture = params.shape[1] > 15
    tilt_p = float(0.0)
    tilt_r = float(0.0)
    if posture:
        tilt_p = params[e, 16]
        tilt_r = params[e, 17]
        if reflex != 0.0:
            rpy = quat_to_rpy(wp.normalize(wp.quat(joint_q[e, 3], joint_q[e, 4], joint_q[e, 5], joint_q[e, 6])))
            tilt_p = wp.clamp(tilt_p - reflex * rpy[1], -tilt_max, tilt_max)
            tilt_r = wp.clamp(tilt_r - reflex * rpy[0], -tilt_max, tilt_max)
    for leg in range(6):
        osc = leg % 2
        y = state[e, 2 * osc + 1] * inv_sqrt_mu
        lift = float(0.0)
        if dy[e, osc] >= 0.0:
            lift = wp.max(1.0 - y * y, 0.0)
        a1 = params[e, 1]
        if leg >= 3:
            a1 = params[e, 2]
        knee = stand[1] + params[e, 3 + leg] * lift
        if posture:
            side = float(1.0)
            if leg >= 3:
                side = -1.0
            knee += params[e, 15] + tilt_p * float(1 - leg % 3) + tilt_r * side
        col = target_offset + 3 * leg
        targets[e, col + 0] = wp.clamp(stand[0] + a1 * y, lower[0], upper[0])
        targets[e, col + 1] = wp.clamp(knee, lower[1], upper[1])
        targets[e, col + 2] = wp.clamp(stand[2] - params[e, 9 + leg] * lift, lower[2], upper[2])


@wp.kernel
def stuck_response_kernel(
    target: wp.array2d[wp.float32],
    col: int,
    lift: float,
    progress: float,
    hold: int,
    history: wp.array2d[wp.float32],
    count: wp.array[wp.int32],
    left: wp.array[wp.int32],
    params_target: wp.array2d[wp.float32],
):
    """One control step of the stuck response (module docstring); ``target[e, col:col + 2]``: the goal relative to
    robot e, x and y."""
    e = wp.tid()
    x = target[e, col]
    y = target[e, col + 1]
    d = wp.sqrt(x * x + y * y)
    w = history.shape[1]
    k = count[e]
    slot = k % w
    if k >= w and left[e] == 0 and history[e, slot] - d < progress:
        left[e] = hold
    history[e, slot] = d
    count[e] = k + 1
    if left[e] > 0:
        for j in range(6):
            params_target[e, 3 + j] = params_target[e, 3 + j] + lift
        left[e] = left[e] - 1


# ----------------------------------------------------------------------------------------------------
# the controller
# ----------------------------------------------------------------------------------------------------

@wp.kernel
def _reset_cpg(
    mask: wp.array[wp.bool],
    init_state: wp.vec4,
    params_target: wp.array2d[wp.float32],
    params: wp.array2d[wp.float32],
    state: wp.array2d[wp.float32],
    dy: wp.array2d[wp.float32],
    stuck_count: wp.array[wp.int32],
    stuck_left: wp.array[wp.int32],
):
    e = wp.tid()
    if not mask[e]:
        return
    for k in range(params.shape[1]):
        params[e, k] = params_target[e, k]
    for k in range(4):
        state[e, k] = init_state[k]
    dy[e, 0] = 0.0
    dy[e, 1] = 0.0
    stuck_count[e] = 0
    stuck_left[e] = 0


class CPGController:
    """Batched two-oscillator CPG + mapping function for one ``World``."""

    def __init__(self, world, cfg: CPGConfig | None = None, robot: RobotConfig | None = None):
        self.cfg = cfg = cfg or world.cfg.cpg
        robot = robot or world.cfg.robot
        if not (0.0 < cfg.duty < 1.0):
            raise ValueError(f"cpg.duty must lie in (0, 1), got {cfg.duty}")
        if not (cfg.mu > 0 and cfg.alpha >= 0 and cfg.param_tau >= 0):
            raise ValueError("cpg.mu must be > 0, cpg.alpha and cpg.param_tau >= 0")
        if not (cfg.stuck_lift >= 0 and cfg.stuck_progress >= 0 and cfg.stuck_window >= 1 and cfg.stuck_hold >= 1):
            raise ValueError("cpg.stuck_lift and cpg.stuck_progress must be >= 0, cpg.stuck_window and "
                             "cpg.stuck_hold >= 1 control step")
        n, dev = world.num_envs, world.device
        self.num_envs, self.device, self.num_params = n, dev, cfg.num_params
        self.dt = world.sim_dt
        self.gain = 1.0 if cfg.param_tau == 0 else 1.0 - math.exp(-self.dt / cfg.param_tau)
        lo, hi = cfg.param_ranges()
        self.lower = wp.array(np.asarray(lo, np.float32), device=dev)
        self.upper = wp.array(np.asarray(hi, np.float32), device=dev)
        fixed = np.tile(np.asarray(cfg.fixed_params(), np.float32), (n, 1))
        self.params_target = wp.array(fixed, dtype=wp.float32, device=dev)
        self.params = wp.array(fixed, dtype=wp.float32, device=dev)
        start = initial_cpg_state(cfg.mu, cfg.theta)  # the oscillators' locked start (x0, y0, x1, y1)
        self._start_state = wp.vec4(*start)
        self.state = wp.array(np.tile(np.asarray(start, np.float32), (n, 1)), device=dev)
        self.dy = wp.zeros((n, 2), dtype=wp.float32, device=dev)
        self._actions = wp.zeros((n, self.num_params), dtype=wp.float32, device=dev)
        self._mask = wp.zeros(n, dtype=wp.bool, device=dev)
        # the stuck response's ring of goal distances, steps seen and steps of the response to go (one ring entry
        # when it is off)
        self.stuck_history = wp.zeros((n, cfg.stuck_window if cfg.stuck_lift > 0 else 1), dtype=wp.float32, device=dev)
        self.stuck_count = wp.zeros(n, dtype=wp.int32, device=dev)
        self.stuck_left = wp.zeros(n, dtype=wp.int32, device=dev)
        lower, upper = leg_bounds(robot)
        self.stand, self.joint_lower, self.joint_upper = wp.vec3(*robot.stand_pose), wp.vec3(*lower), wp.vec3(*upper)
        self.tilt_max, self.lift = cfg.tilt_max, cfg.lift  # scaled for the robot (CPGConfig.amplitude_scale)

    # ------------------------------------------------------------------ high-level inputs
    def set_actions(self, actions) -> None:
        """Policy actions (N, P) in [-1, 1] (torch tensor, Warp array or NumPy) -> ``params_target``."""
        if isinstance(actions, wp.array):
            a = actions
        else:
            if isinstance(actions, np.ndarray):
                self._actions.assign(actions.astype(np.float32))
            else:  # torch: one device-side copy into the controller's own buffer (no host round trip)
                wp.to_torch(self._actions).copy_(actions.detach())
            a = self._actions
        wp.launch(scale_actions_kernel, dim=(self.num_envs, self.num_params),
                  inputs=[a, self.lower, self.upper, self.params_target], device=self.device)  # fmt: skip

    def respond_to_stuck(self, target: wp.array, col: int) -> None:
        """The stuck response's control step (module docstring), after ``set_actions``: ``target[:, col:col + 2]``
        the goal relative to each robot (the policy's target observation). Nothing with ``stuck_lift`` 0."""
        c = self.cfg
        if c.stuck_lift <= 0:
            return
        wp.launch(stuck_response_kernel, dim=self.num_envs,
                  inputs=[target, col, self.lift, c.stuck_progress, c.stuck_hold],
                  outputs=[self.stuck_history, self.stuck_count, self.stuck_left, self.params_target],
                  device=self.device)  # fmt: skip

    def set_params(self, params) -> None:
        """Physical parameters, (P,) for every env or (N, P)."""
        p = np.broadcast_to(np.asarray(params, np.float32), (self.num_envs, self.num_params))
        self.params_target.assign(np.ascontiguousarray(p))

    # ------------------------------------------------------------------ stepping
    def __call__(self, world) -> None:
        c = self.cfg
        wp.launch(
            hopf_cpg_kernel,
            dim=self.num_envs,
            inputs=[self.params_target, self.gain, c.alpha, c.mu, c.delta, c.theta, c.duty, c.steepness, self.dt],
            outputs=[self.params, self.state, self.dy],
            device=self.device,
        )
        wp.launch(
            mapping_kernel,
            dim=self.num_envs,
            inputs=[self.state, self.dy, self.params, 1.0 / math.sqrt(c.mu), self.stand, self.joint_lower,
                    self.joint_upper, BASE_Q, world.state_0.joint_q.reshape(world.joint_q_wp.shape), c.posture_reflex,
                    self.tilt_max],  # fmt: skip
            outputs=[world.joint_target_wp],
            device=self.device,
        )

    def reset(self, mask=None) -> None:
        """Selected envs (all if None): oscillators back to the locked start, parameters at their targets, the stuck
        response's ring emptied."""
        m = as_mask(mask, self._mask)
        wp.launch(_reset_cpg, dim=self.num_envs,
                  inputs=[m, self._start_state, self.params_target],
                  outputs=[self.params, self.state, self.dy, self.stuck_count, self.stuck_left],
                  device=self.device)  # fmt: skip
