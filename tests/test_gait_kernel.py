"""The open-loop tripod test pattern: Warp kernel vs its float64 NumPy reference on random inputs."""

import numpy as np
import warp as wp
from hypothesis import given, settings
from hypothesis import strategies as st

from hexnewton.kernels.gait import tripod_sine_kernel, tripod_sine_reference

STAND = np.array([0.0, 0.15, -0.15])
LOWER = np.array([-np.pi / 6, 0.0, -np.pi / 3])
UPPER = np.array([np.pi / 6, np.pi / 2, 0.0])


def _run_kernel(phase, freq, ah, ak, dt, offset=7):
    n = len(phase)
    dev = "cpu"
    arr = lambda a: wp.array(np.asarray(a, np.float32), device=dev)  # noqa: E731
    ph = arr(phase)
    targets = wp.zeros((n, offset + 18), dtype=wp.float32, device=dev)
    wp.launch(
        tripod_sine_kernel, dim=n,
        inputs=[arr(freq), arr(ah), arr(ak), wp.vec3(*STAND), wp.vec3(*LOWER), wp.vec3(*UPPER), dt, offset, ph,
                targets],
        device=dev,
    )  # fmt: skip
    return ph.numpy(), targets.numpy()


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), dt=st.floats(1e-4, 0.02))
def test_kernel_matches_reference(seed, dt):
    rng = np.random.default_rng(seed)
    n = 64
    phase = rng.uniform(0, 2 * np.pi, n)
    freq, ah, ak = rng.uniform(0, 3, n), rng.uniform(0, 0.8, n), rng.uniform(0, 1.5, n)
    ph, targets = _run_kernel(phase, freq, ah, ak, dt)
    ref_phase, ref = tripod_sine_reference(phase, freq, ah, ak, STAND, LOWER, UPPER, dt)
    dphase = np.angle(np.exp(1j * (ph - ref_phase)))
    np.testing.assert_allclose(dphase, 0.0, atol=1e-5)
    np.testing.assert_allclose(targets[:, 7:], ref, atol=1e-5)
    assert np.all(targets[:, :7] == 0.0)  # the free joint's columns are never written


def test_tripods_alternate_and_respect_limits():
    _, t = tripod_sine_reference(np.array([0.0]), np.array([0.0]), np.array([0.4]), np.array([0.5]), STAND, LOWER,
                                 UPPER, 0.0)  # fmt: skip
    legs = t.reshape(6, 3)
    # phase 0: tripod {R1, R3, L2} lifted (knee above stand), {R2, L1, L3} on the ground
    assert np.all(legs[[0, 2, 4], 1] > STAND[1]) and np.allclose(legs[[1, 3, 5], 1], STAND[1])
    assert np.all(legs >= LOWER - 1e-12) and np.all(legs <= UPPER + 1e-12)
