"""Mid and low level (Eq. 3, Eq. 4): Warp kernels vs float64 NumPy references, and the CPG's dynamics."""

import math

import numpy as np
import pytest
import warp as wp
from hypothesis import given, settings
from hypothesis import strategies as st

from hexnewton.config import CPGConfig
from hexnewton.kernels.cpg import hopf_cpg_kernel, mapping_kernel, scale_actions_kernel, stuck_response_kernel
from hexnewton.kernels.reference import (
    hopf_cpg_reference,
    mapping_offsets_np,
    mapping_reference,
    params_to_actions,
    quat_to_rpy_np,
    scale_actions_reference,
    stuck_response_reference,
)

DEV = "cpu"
CFG = CPGConfig()
STAND = np.array([0.0, 0.15, -0.15])
LOWER = np.array([-math.pi / 6, 0.0, -math.pi / 3])
UPPER = np.array([math.pi / 6, math.pi / 2, 0.0])
DT = 0.0025


def _arr(a):
    return wp.array(np.ascontiguousarray(a, np.float32), device=DEV)


def _cpg_kernel(params_target, params, state, gain, cfg=CFG, dt=DT):
    p, s = _arr(params), _arr(state)
    dy = wp.zeros((len(state), 2), dtype=wp.float32, device=DEV)
    wp.launch(hopf_cpg_kernel, dim=len(state),
              inputs=[_arr(params_target), gain, cfg.alpha, cfg.mu, cfg.delta, cfg.theta, cfg.duty, cfg.steepness, dt],
              outputs=[p, s, dy], device=DEV)  # fmt: skip
    return p.numpy(), s.numpy(), dy.numpy()


def _random_params(rng, n):
    lo, hi = (np.asarray(b) for b in CFG.param_ranges())
    return lo + rng.uniform(0, 1, (n, 15)) * (hi - lo)


# ------------------------------------------------------------------ kernel == reference


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), gain=st.floats(0.0, 1.0), duty=st.floats(0.3, 0.7),
       theta=st.floats(0.0, 2 * math.pi), mu=st.floats(0.25, 4.0))  # fmt: skip
def test_hopf_kernel_matches_reference(seed, gain, duty, theta, mu):
    rng = np.random.default_rng(seed)
    n = 64
    cfg = CPGConfig(duty=duty, theta=theta, mu=mu)
    target, params = _random_params(rng, n), _random_params(rng, n)
    state = rng.uniform(-1.5, 1.5, (n, 4)) * math.sqrt(mu)
    p, s, dy = _cpg_kernel(target, params, state, gain, cfg)
    rp, rs, rdy = hopf_cpg_reference(target, params, state, gain, cfg.alpha, mu, cfg.delta, theta, duty,
                                     cfg.steepness, DT)  # fmt: skip
    np.testing.assert_allclose(p, rp, rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(s, rs, rtol=1e-4, atol=1e-4 * math.sqrt(mu))
    np.testing.assert_allclose(dy, rdy, rtol=1e-3, atol=2e-3 * max(mu, 1.0) * 20)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), mu=st.floats(0.25, 4.0), posture=st.booleans(), reflex=st.sampled_from([0.0, 2.0]))
def test_mapping_kernel_matches_reference(seed, mu, posture, reflex):
    rng = np.random.default_rng(seed)
    n = 64
    state = rng.uniform(-1.2, 1.2, (n, 4)) * math.sqrt(mu)
    dy = rng.normal(size=(n, 2))
    dy[: n // 4] = 0.0  # exactly on the edge: counts as rising (dy >= 0)
    params = _random_params(rng, n)
    if posture:  # the body posture (P_h, P_p, P_r) inside and beyond its ranges
        params = np.concatenate([params, rng.uniform(-0.4, 0.4, (n, 3))], axis=1)
    q = np.zeros((n, 25))
    q[:, 3:7] = rng.normal(size=(n, 4)) * [0.2, 0.2, 0.2, 1.0]  # random body attitudes, not normalised
    targets = wp.zeros((n, 25), dtype=wp.float32, device=DEV)
    wp.launch(mapping_kernel, dim=n,
              inputs=[_arr(state), _arr(dy), _arr(params), 1.0 / math.sqrt(mu), wp.vec3(*STAND), wp.vec3(*LOWER),
                      wp.vec3(*UPPER), 7, _arr(q), reflex, 0.3],
              outputs=[targets], device=DEV)  # fmt: skip
    t = targets.numpy()
    rpy = quat_to_rpy_np(q[:, 3:7])
    ref = mapping_reference(state, dy, params, mu, STAND, LOWER, UPPER, rpy, reflex, 0.3)
    np.testing.assert_allclose(t[:, 7:], ref, atol=1e-5)
    assert np.all(t[:, :7] == 0.0)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_action_scaling_matches_reference(seed):
    rng = np.random.default_rng(seed)
    n = 32
    actions = rng.uniform(-2, 2, (n, 15))
    actions[0, 3] = np.nan
    actions[1, 4] = np.inf
    lo, hi = CFG.param_ranges()
    out = wp.zeros((n, 15), dtype=wp.float32, device=DEV)
    wp.launch(scale_actions_kernel, dim=(n, 15), inputs=[_arr(actions), _arr(lo), _arr(hi), out], device=DEV)
    ref = scale_actions_reference(actions, lo, hi)
    np.testing.assert_allclose(out.numpy(), ref, rtol=1e-6, atol=1e-6)
    assert np.all(ref >= np.asarray(lo) - 1e-12) and np.all(ref <= np.asarray(hi) + 1e-12)
    np.testing.assert_allclose(scale_actions_reference(params_to_actions(ref[2:], lo, hi), lo, hi), ref[2:])


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), window=st.integers(1, 6), hold=st.integers(1, 4), posture=st.booleans())
def test_stuck_response_matches_reference(seed, window, hold, posture):
    """Robots 0-7 stand still (the goal 3 m away, jittering by 1 mm), robots 8-15 walk 5 cm a step toward it; some
    envs are reset on the way (ring emptied, as ``CPGController.reset`` does): kernel == reference at every step, the
    standing robots get the lift and the walking ones never."""
    rng = np.random.default_rng(seed)
    n, p, lift, progress = 16, 18 if posture else 15, 0.3, 0.02
    hist, count, left = np.zeros((n, window)), np.zeros(n, np.int64), np.zeros(n, np.int64)
    h_wp, c_wp, l_wp = _arr(hist), wp.zeros(n, dtype=wp.int32, device=DEV), wp.zeros(n, dtype=wp.int32, device=DEV)
    lifted = np.zeros(n, bool)
    for step in range(3 * window + 2 * hold):
        dist = np.where(np.arange(n) < 8, 3.0 + rng.uniform(-1e-3, 1e-3, n), 3.0 - 0.05 * step)
        yaw = rng.uniform(-math.pi, math.pi, n)
        target = np.c_[dist * np.cos(yaw), dist * np.sin(yaw), rng.normal(0, 0.05, n)]
        params = rng.uniform(0.0, 1.0, (n, p)).astype(np.float32).astype(np.float64)
        if step == window + 1:  # a reset of two envs, one standing, one walking
            count[[3, 12]] = left[[3, 12]] = 0
            c_wp.assign(count.astype(np.int32))
            l_wp.assign(left.astype(np.int32))
        p_wp = _arr(params)
        wp.launch(stuck_response_kernel, dim=n, inputs=[_arr(np.c_[np.zeros(n), target]), 1, lift, progress, hold],
                  outputs=[h_wp, c_wp, l_wp, p_wp], device=DEV)  # fmt: skip
        hist, count, left, ref = stuck_response_reference(target, hist, count, left, params, lift, progress, hold)
        np.testing.assert_allclose(h_wp.numpy(), hist, rtol=1e-6, atol=1e-6)
        assert np.array_equal(c_wp.numpy(), count) and np.array_equal(l_wp.numpy(), left)
        np.testing.assert_allclose(p_wp.numpy(), ref, rtol=1e-6, atol=1e-6)
        on = np.any(ref != params, axis=1)
        assert np.allclose(ref[on, 3:9] - params[on, 3:9], lift) and np.array_equal(ref[:, :3], params[:, :3])
        lifted |= on
    assert lifted[:8].all() and not lifted[8:].any()


# ------------------------------------------------------------------ properties of Eq. 3 (float64 reference)


def _simulate(state, omega, seconds, cfg=CFG, dt=DT, keep_last=None):
    """Integrate with the Warp kernel (what runs in the simulator); returns states (T, N, 4) and dy (T, N, 2),
    of the last ``keep_last`` seconds only if given."""
    n = len(state)
    params = np.zeros((n, 15), np.float32)
    params[:, 0] = omega
    p, s = _arr(params), _arr(state)
    dy = wp.zeros((n, 2), dtype=wp.float32, device=DEV)
    traj, dys = [], []
    steps = int(round(seconds / dt))
    first_kept = steps - int(round(keep_last / dt)) if keep_last is not None else 0
    for k in range(steps):
        wp.launch(hopf_cpg_kernel, dim=n,
                  inputs=[p, 1.0, cfg.alpha, cfg.mu, cfg.delta, cfg.theta, cfg.duty, cfg.steepness, dt],
                  outputs=[p, s, dy], device=DEV)  # fmt: skip
        if k < first_kept:
            continue
        traj.append(s.numpy().astype(np.float64))
        dys.append(dy.numpy().astype(np.float64))
    return np.array(traj), np.array(dys)


def _random_starts(seed, n, mu, theta):
    """Random starts in [-1.5, 1.5]^4 sqrt(mu), each oscillator off the origin (an unstable fixed point) and
    away from the unstable phase difference theta + pi, a measure-zero set that never locks."""
    rng = np.random.default_rng(seed)
    r = math.sqrt(mu) * rng.uniform(0.05, 1.5, (n, 2))
    phase = rng.uniform(-math.pi, math.pi, (n, 2))
    bad = np.abs(np.angle(np.exp(1j * (phase[:, 0] - phase[:, 1] - theta - math.pi)))) < 0.1
    phase[bad, 1] += 0.3
    return np.stack([r[:, 0] * np.cos(phase[:, 0]), r[:, 0] * np.sin(phase[:, 0]),
                     r[:, 1] * np.cos(phase[:, 1]), r[:, 1] * np.sin(phase[:, 1])], axis=1)  # fmt: skip


def _phase_diff(s):
    return np.angle((s[..., 0] + 1j * s[..., 1]) / (s[..., 2] + 1j * s[..., 3]))  # phi_0 - phi_1


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), omega=st.floats(math.pi, 5 * math.pi), mu=st.floats(0.5, 2.0))
def test_reaches_limit_cycle_of_radius_sqrt_mu(seed, omega, mu):
    cfg = CPGConfig(mu=mu)
    cycle = 2 * math.pi / omega
    traj, _ = _simulate(_random_starts(seed, 32, mu, cfg.theta), omega, 3.0, cfg, keep_last=cycle)
    r = np.hypot(traj[..., [0, 2]], traj[..., [1, 3]]).mean(axis=0)  # mean radius over the last cycle (N, 2)
    # Eq. 3's coupling does not vanish at the lock (Delta_ji = y_i there): averaged over a cycle it adds
    # delta / (2 alpha) to the squared radius, 2.5 % of the radius with the defaults and mu = 1
    predicted = math.sqrt(mu + cfg.delta / (2 * cfg.alpha))
    np.testing.assert_allclose(r, predicted, rtol=0.01)


def test_limit_cycle_is_exactly_sqrt_mu_without_coupling():
    cfg = CPGConfig(delta=0.0)
    traj, _ = _simulate(np.array([[0.1, 0.0, 1.9, 0.3]]), 3 * math.pi, 2.0, cfg, keep_last=0.5)
    r = np.hypot(traj[:, 0, [0, 2]], traj[:, 0, [1, 3]])
    np.testing.assert_allclose(r, 1.0, atol=1e-5)


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), omega=st.floats(math.pi, 5 * math.pi))
def test_phase_locks_at_pi_tripod(seed, omega):
    """The paper's theta = pi: from random starts the pair locks in exact anti-phase."""
    traj, _ = _simulate(_random_starts(seed, 32, 1.0, math.pi), omega, 4.0, CFG, keep_last=0.5)
    err = np.angle(np.exp(1j * (_phase_diff(traj) - math.pi)))
    assert np.abs(err).max() < 0.02


@settings(max_examples=5, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), omega=st.floats(math.pi, 5 * math.pi), theta=st.floats(0.5, 2 * math.pi - 0.5))
def test_phase_locks_at_any_theta_on_average(seed, omega, theta):
    """Other theta: Eq. 3 couples through y only, so the phase difference ripples within a cycle (up to
    ~0.5 rad at 0.5 Hz); its circular mean over a cycle locks at theta."""
    cfg = CPGConfig(theta=theta)
    traj, _ = _simulate(_random_starts(seed, 32, 1.0, theta), omega, 5.0, cfg, keep_last=2 * math.pi / omega)
    mean_err = np.angle(np.exp(1j * (_phase_diff(traj) - theta)).mean(axis=0))
    assert np.abs(mean_err).max() < 0.15


def _period(y):
    up = np.flatnonzero((y[:-1] < 0) & (y[1:] >= 0))  # upward zero crossings
    return np.mean(np.diff(up)) * DT


@settings(max_examples=8, deadline=None)
@given(omega=st.floats(math.pi, 5 * math.pi))
def test_oscillates_at_commanded_frequency(omega):
    """The locked tripod pair (default duty 0.5) cycles at the commanded omega (coupling compensated)."""
    traj, _ = _simulate(np.array([[1.0, 0.0, -1.0, 0.0]]), omega, 6.0, CFG, keep_last=4.0)
    assert _period(traj[:, 0, 1]) == pytest.approx(2 * math.pi / omega, rel=0.02)
    assert _period(traj[:, 0, 3]) == pytest.approx(2 * math.pi / omega, rel=0.02)


@settings(max_examples=5, deadline=None)
@given(omega=st.floats(math.pi, 5 * math.pi), duty=st.floats(0.35, 0.65))
def test_swing_stance_split_keeps_the_period(omega, duty):
    """omega_sw / omega_st change the shape of a cycle, not its length (one free oscillator)."""
    cfg = CPGConfig(duty=duty, delta=0.0)
    traj, _ = _simulate(np.array([[1.0, 0.0, -1.0, 0.0]]), omega, 6.0, cfg, keep_last=4.0)
    assert _period(traj[:, 0, 1]) == pytest.approx(2 * math.pi / omega, rel=0.02)


def test_swing_and_stance_durations_follow_duty():
    omega, duty = 3 * math.pi, 0.6
    cfg = CPGConfig(duty=duty, delta=0.0)  # one free oscillator: the split is exact
    traj, dys = _simulate(np.array([[1.0, 0.0, -1.0, 0.0]]), omega, 5.0, cfg, keep_last=4.0)
    rising = dys[:, 0, 0] >= 0
    assert rising.mean() == pytest.approx(1 - duty, abs=0.02)  # swing = rising edge (§2.3)


def test_convergence_steps_reported():
    """From a small off-cycle start both oscillators are on the cycle (5 %) and locked (0.1 rad) within 1 s."""
    traj, _ = _simulate(np.array([[0.05, 0.0, 0.0, 0.05]]), 3 * math.pi, 2.0)
    r = np.hypot(traj[:, 0, [0, 2]], traj[:, 0, [1, 3]])
    diff = _phase_diff(traj[:, 0])
    ok = (np.abs(r - 1.0) < 0.05).all(axis=1) & (np.abs(np.abs(diff) - math.pi) < 0.1)
    first = int(np.argmax(ok))
    assert ok[first:].all()
    assert first * DT < 1.0


# ------------------------------------------------------------------ properties of Eq. 4


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**31 - 1))
def test_mapping_edges_and_ankle_ratio(seed):
    rng = np.random.default_rng(seed)
    n = 64
    state = rng.uniform(-1, 1, (n, 4))
    dy = rng.normal(size=(n, 2))
    params = _random_params(rng, n)
    off = mapping_offsets_np(state, dy, params, 1.0)
    falling = (dy < 0)[:, np.arange(6) % 2]  # (n, 6)
    assert np.all(off[..., 1][falling] == 0.0) and np.all(off[..., 2][falling] == 0.0)  # knee exactly 0
    ratio = -params[:, 9:15] / params[:, 3:9]
    np.testing.assert_allclose(off[..., 2], ratio * off[..., 1], atol=1e-12)  # ankle = -A3 / A2 * knee
    y = state[:, 2 * (np.arange(6) % 2) + 1]
    a1 = np.where(np.arange(6) < 3, params[:, 1:2], params[:, 2:3])
    np.testing.assert_allclose(off[..., 0], a1 * y)  # hip = A1[side] * y, right legs A1[1], left A1[2]


def test_tripod_groups_share_an_oscillator():
    state = np.array([[0.0, 0.5, 0.0, -0.5]])
    dy = np.array([[1.0, -1.0]])
    off = mapping_offsets_np(state, dy, np.array([CFG.fixed_params()]), 1.0)[0]
    swing = off[:, 1] > 0  # legs R1, R2, R3, L1, L2, L3
    assert swing.tolist() == [True, False, True, False, True, False]  # {R1, R3, L2} swing, {R2, L1, L3} stand


def _robots():
    """The MX-Phoenix, its URDF as loaded, and a robot whose joints reach less far than the paper's (its amplitudes
    scaled down: hip 0.3 rad, knee 0.9, ankle -0.6)."""
    import dataclasses

    from hexnewton.robot.loader import load_robot
    from hexnewton.robot.mx_phoenix import URDF, MX_PHOENIX

    narrow = dataclasses.replace(MX_PHOENIX, name="narrow", hip_limit=(-0.3, 0.3), knee_limit=(0.0, 0.9),
                                 ankle_limit=(-0.6, 0.2))
    return {"mx_phoenix": MX_PHOENIX, "mx_phoenix_urdf": load_robot(URDF), "narrow": narrow}


@pytest.mark.parametrize("name", ["mx_phoenix", "mx_phoenix_urdf", "narrow"])
def test_kernels_match_reference_for_other_robots(name):
    """Another robot's standing pose, limits and amplitude-scaled ranges (``with_robot``): the action scaling and the
    mapping (posture and reflex on) against their float64 twins, and every target inside the robot's limits."""
    from hexnewton.config import HexConfig
    from hexnewton.robot import leg_bounds
    from hexnewton.robot.registry import with_robot

    robot = _robots()[name]
    cpg = with_robot(HexConfig(cpg=CPGConfig(posture=True)), robot).cpg
    if name == "narrow":
        assert cpg.amplitude_scale[0] < 1 and cpg.amplitude_scale[1] < 1 and cpg.amplitude_scale[2] < 1
    stand, (lower, upper) = np.asarray(robot.stand_pose), (np.asarray(b) for b in leg_bounds(robot))
    rng = np.random.default_rng(7)
    n = 64
    lo, hi = cpg.param_ranges()
    actions = rng.uniform(-1.2, 1.2, (n, 18))
    params = wp.zeros((n, 18), dtype=wp.float32, device=DEV)
    wp.launch(scale_actions_kernel, dim=(n, 18), inputs=[_arr(actions), _arr(lo), _arr(hi), params], device=DEV)
    ref_params = scale_actions_reference(actions, lo, hi)
    np.testing.assert_allclose(params.numpy(), ref_params, rtol=1e-6, atol=1e-6)
    state, dy = rng.uniform(-1.2, 1.2, (n, 4)), rng.normal(size=(n, 2))
    q = np.zeros((n, 25))
    q[:, 3:7] = rng.normal(size=(n, 4)) * [0.2, 0.2, 0.2, 1.0]
    targets = wp.zeros((n, 25), dtype=wp.float32, device=DEV)
    wp.launch(mapping_kernel, dim=n,
              inputs=[_arr(state), _arr(dy), params, 1.0, wp.vec3(*stand), wp.vec3(*lower), wp.vec3(*upper), 7,
                      _arr(q), 2.0, cpg.tilt_max],
              outputs=[targets], device=DEV)  # fmt: skip
    ref = mapping_reference(state, dy, params.numpy().astype(np.float64), 1.0, stand, lower, upper,
                            quat_to_rpy_np(q[:, 3:7]), 2.0, cpg.tilt_max)  # fmt: skip
    np.testing.assert_allclose(targets.numpy()[:, 7:], ref, atol=1e-5)
    t = ref.reshape(n, 6, 3)
    assert np.all(t >= lower - 1e-9) and np.all(t <= upper + 1e-9)
