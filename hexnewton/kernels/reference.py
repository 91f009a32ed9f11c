"""The kernels' Warp-free side: float64 NumPy references of the control kernels.

The kernel tests compare each Warp kernel with its reference here, and the deployment runtime
(``hexnewton.deploy.runtime``) runs the same functions on the robot's computer: the Hopf oscillators (Eq. 3, RK4),
the mapping function (Eq. 4) and the action scaling (all in ``kernels/cpg.py``) and the base quaternion's
roll/pitch/yaw. The kernel modules' docstrings explain the maths; this module only holds the NumPy versions. The
n-oscillator network (``hopf_network_*``, the six-oscillator comparison of ``studies/fig1/figure.py``, explained there)
shares the kernel's single-oscillator right-hand side, :func:`hopf_unit_rhs_np`.
"""

import math

import numpy as np


def initial_cpg_state(mu: float, theta: float) -> tuple[float, float, float, float]:
    """Both oscillators on the limit cycle (radius sqrt(mu)), already locked: phase 0 and phase -theta."""
    r = math.sqrt(mu)
    return (r, 0.0, r * math.cos(-theta), r * math.sin(-theta))


def hopf_unit_rhs_np(x, y, drive, omega, alpha, mu, duty, steepness):
    """One Eq. 3 oscillator: (dx/dt, dy/dt) of the state (x, y) given its coupling input ``drive`` (delta times the sum
    of its Delta_ji); the swing/stance blend of ``omega`` keyed on x. Arrays broadcast."""
    z = np.clip(steepness * x / np.sqrt(mu), -60.0, 60.0)
    w = omega / (2 * (1 - duty)) / (1 + np.exp(-z)) + omega / (2 * duty) / (1 + np.exp(z))
    g = alpha * (mu - x**2 - y**2)
    return g * x - w * y, w * x + g * y + drive


def hopf_rhs_np(s, omega, alpha, mu, delta, theta, duty, steepness):
    """Float64 reference of :func:`hopf_rhs`; ``s`` is (N, 4), ``omega`` (N,)."""
    s = np.asarray(s, np.float64)
    omega = np.asarray(omega, np.float64)
    x0, y0, x1, y1 = s.T
    c, sn = np.cos(theta), np.sin(theta)
    args = (omega, alpha, mu, duty, steepness)
    dx0, dy0 = hopf_unit_rhs_np(x0, y0, delta * (y1 * c + x1 * sn), *args)
    dx1, dy1 = hopf_unit_rhs_np(x1, y1, delta * (y0 * c - x0 * sn), *args)
    return np.stack([dx0, dy0, dx1, dy1], axis=1)


def hopf_cpg_reference(params_target, params, state, gain, alpha, mu, delta, theta, duty, steepness, dt):
    """Float64 reference of :func:`hopf_cpg_kernel`: returns (params, state, dy)."""
    params = np.asarray(params, np.float64)
    params = params + gain * (np.asarray(params_target, np.float64) - params)
    omega = np.sqrt(params[:, 0] ** 2 + 0.25 * delta**2)
    s = np.asarray(state, np.float64)
    args = (omega, alpha, mu, delta, theta, duty, steepness)
    k1 = hopf_rhs_np(s, *args)
    k2 = hopf_rhs_np(s + 0.5 * dt * k1, *args)
    k3 = hopf_rhs_np(s + 0.5 * dt * k2, *args)
    k4 = hopf_rhs_np(s + dt * k3, *args)
    s = s + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    d = hopf_rhs_np(s, *args)
    return params, s, d[:, [1, 3]]


def tripod_theta(groups, theta):
    """Coupling phases theta_ji, (n, n) indexed [j, i], of oscillators that run in ``groups`` (group g at phase
    -g theta): theta_ji = theta (g_i - g_j), so Delta_ji pulls phi_i toward phi_j - theta_ji. Groups (0, 1) give the
    kernel's pair, theta_10 = -theta and theta_01 = theta; ``LEG_OSCILLATOR`` gives the six legs' tripods."""
    g = np.asarray(groups, np.float64)
    return theta * (g[None, :] - g[:, None])


def network_omega(omega, delta, weights):
    """The frequency each oscillator of a network integrates with, (N, n): sqrt(omega^2 + (delta k_i)^2 / 4), where
    k_i = sum_j weights[j, i] (``studies/fig1/figure.py`` derives it; k = 1 is the kernel's compensation)."""
    k = np.asarray(weights, np.float64).sum(axis=0)
    return np.sqrt(np.asarray(omega, np.float64)[:, None] ** 2 + 0.25 * (delta * k[None, :]) ** 2)


def hopf_network_rhs_np(s, omega, alpha, mu, delta, theta_ji, weights, duty, steepness):
    """Eq. 3 for n coupled oscillators: the time derivative of ``s`` (N, n, 2), each oscillator (x_i, y_i) driven by
    delta * sum_j weights[j, i] Delta_ji with Delta_ji = y_j cos(theta_ji) - x_j sin(theta_ji); ``omega`` (N, n)."""
    s = np.asarray(s, np.float64)
    x, y = s[..., 0], s[..., 1]
    w = np.asarray(weights, np.float64)
    drive = delta * (y @ (w * np.cos(theta_ji)) - x @ (w * np.sin(theta_ji)))
    dx, dy = hopf_unit_rhs_np(x, y, drive, omega, alpha, mu, duty, steepness)
    return np.stack([dx, dy], axis=-1)


def hopf_network_reference(state, omega, alpha, mu, delta, theta_ji, weights, duty, steepness, dt):
    """One RK4 step of the network of :func:`hopf_network_rhs_np` at the commanded ``omega`` (N,), compensated per
    oscillator by :func:`network_omega`: returns (state (N, n, 2), dy/dt (N, n) at the new state)."""
    args = (network_omega(omega, delta, weights), alpha, mu, delta, theta_ji, weights, duty, steepness)
    s = np.asarray(state, np.float64)
    k1 = hopf_network_rhs_np(s, *args)
    k2 = hopf_network_rhs_np(s + 0.5 * dt * k1, *args)
    k3 = hopf_network_rhs_np(s + 0.5 * dt * k2, *args)
    k4 = hopf_network_rhs_np(s + dt * k3, *args)
    s = s + dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return s, hopf_network_rhs_np(s, *args)[..., 1]


def mapping_offsets_np(state, dy, params, mu, rpy=None, reflex=0.0, tilt_max=0.0):
    """Float64 Eq. 4 offsets (N, 6, 3) before the standing pose and clipping are applied; with the body posture
    (18 parameters) and a ``reflex`` gain, ``rpy`` (N, 3) is the body's measured attitude."""
    state = np.asarray(state, np.float64)
    dy = np.asarray(dy, np.float64)
    params = np.asarray(params, np.float64)
    osc = np.arange(6) % 2
    y = state[:, 2 * osc + 1] / np.sqrt(mu)  # (N, 6)
    lift = np.where(dy[:, osc] >= 0.0, np.maximum(1.0 - y**2, 0.0), 0.0)
    a1 = np.where(np.arange(6) < 3, params[:, 1:2], params[:, 2:3])
    knee = params[:, 3:9] * lift
    if params.shape[1] > 15:  # body posture: P_h + P_p * fx + P_r * sy on every knee
        fx, sy = np.array([1.0, 0.0, -1.0] * 2), np.array([1.0] * 3 + [-1.0] * 3)
        tilt_p, tilt_r = params[:, 16:17], params[:, 17:18]
        if reflex != 0.0:
            rpy = np.asarray(rpy, np.float64)
            tilt_p = np.clip(tilt_p - reflex * rpy[:, 1:2], -tilt_max, tilt_max)
            tilt_r = np.clip(tilt_r - reflex * rpy[:, 0:1], -tilt_max, tilt_max)
        knee = knee + params[:, 15:16] + tilt_p * fx + tilt_r * sy
    return np.stack([a1 * y, knee, -params[:, 9:15] * lift], axis=-1)


def mapping_reference(state, dy, params, mu, stand, lower, upper, rpy=None, reflex=0.0, tilt_max=0.0):
    """Float64 reference of :func:`mapping_kernel`: joint targets (N, 18)."""
    out = mapping_offsets_np(state, dy, params, mu, rpy, reflex, tilt_max) + np.asarray(stand, np.float64)
    out = np.clip(out, np.asarray(lower, np.float64), np.asarray(upper, np.float64))
    return out.reshape(len(out), 18)


def stuck_response_reference(target, history, count, left, params_target, lift, progress, hold):
    """Float64 reference of :func:`hexnewton.kernels.cpg.stuck_response_kernel`, one control step: ``target`` (N, 2+)
    the goal relative to each robot (x, y first), ``history`` (N, W) its last W goal distances (a ring indexed by
    ``count`` (N,) mod W), ``left`` (N,) control steps of the response still to go, ``params_target`` (N, P). Returns
    updated copies of ``history``, ``count``, ``left`` and ``params_target``."""
    h, p = np.array(history, np.float64), np.array(params_target, np.float64)
    c, n_left = np.array(count, np.int64), np.array(left, np.int64)
    t = np.asarray(target, np.float64)
    d = np.hypot(t[:, 0], t[:, 1])
    rows, slot = np.arange(len(d)), c % h.shape[1]
    start = (c >= h.shape[1]) & (n_left == 0) & (h[rows, slot] - d < progress)
    n_left[start] = hold
    h[rows, slot] = d
    on = n_left > 0
    p[on, 3:9] += lift
    n_left[on] -= 1
    return h, c + 1, n_left, p


def scale_actions_reference(actions, lower, upper):
    """Float64 reference of :func:`scale_actions_kernel`."""
    a = np.asarray(actions, np.float64)
    a = np.clip(np.where(np.isfinite(a), a, 0.0), -1.0, 1.0)
    lo, hi = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    return lo + 0.5 * (a + 1.0) * (hi - lo)


def params_to_actions(params, lower, upper):
    """Inverse of the scaling (for fixed physical parameters expressed as actions)."""
    lo, hi = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    return 2.0 * (np.asarray(params, np.float64) - lo) / (hi - lo) - 1.0


def joint_actions_reference(actions, stand, lower, upper, scale):
    """Float64 reference of :func:`joint_actions_kernel`: (N, 18) joint targets."""
    lo = np.tile(np.asarray(lower, np.float64), 6)
    hi = np.tile(np.asarray(upper, np.float64), 6)
    if scale <= 0.0:
        return scale_actions_reference(actions, lo, hi)
    a = np.asarray(actions, np.float64)
    a = np.clip(np.where(np.isfinite(a), a, 0.0), -1.0, 1.0)
    return np.clip(np.tile(np.asarray(stand, np.float64), 6) + scale * a, lo, hi)


def quat_to_rpy_np(q: np.ndarray) -> np.ndarray:
    """Float64 reference of :func:`quat_to_rpy` for quaternions (..., 4) in (x, y, z, w) order."""
    q = np.asarray(q, np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = np.moveaxis(q, -1, 0)
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1, 1))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.stack([roll, pitch, yaw], axis=-1)


def quat_rotate_inv_np(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """R(q)^T v for unit quaternions (..., 4) in (x, y, z, w) order and vectors (..., 3): a world vector in the body
    frame (float64; the reference of ``wp.quat_rotate_inv``)."""
    q = np.asarray(q, np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    u, w = q[..., :3], q[..., 3:4]
    v = np.asarray(v, np.float64)
    t = 2.0 * np.cross(u, v)
    return v - w * t + np.cross(u, t)
