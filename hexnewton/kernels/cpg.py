"""Mid level: two coupled Hopf oscillators (Huang et al. 2025, Eq. 3), batched per env, one RK4 step per call.

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
"""

import warp as wp


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
