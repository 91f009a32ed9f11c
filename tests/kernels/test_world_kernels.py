"""The world's kernels (``hexnewton/kernels/world.py``) against their NumPy twins on random states."""

import numpy as np
import warp as wp

from hexnewton.kernels.world import (
    OVERFLOW_CONTACT_REDUCTION,
    OVERFLOW_TRIANGLE_PAIRS,
    accumulate_overflow_kernel,
    accumulate_overflow_reference,
    as_mask,
    nonfinite_envs_kernel,
    nonfinite_envs_reference,
    spawn_pose_kernel,
    spawn_pose_reference,
    zero_world_rows_kernel,
    zero_world_rows_reference,
)

DEV = "cpu"


def _f32(a):
    return wp.array(np.asarray(a, np.float32), device=DEV)


def test_nonfinite_envs_kernel_matches_reference():
    rng = np.random.default_rng(0)
    q, qd = rng.normal(size=(64, 25)), rng.normal(size=(64, 24))
    q[rng.random(q.shape) < 0.01] = np.nan
    qd[rng.random(qd.shape) < 0.01] = np.inf
    out = wp.zeros(64, dtype=wp.bool, device=DEV)
    wp.launch(nonfinite_envs_kernel, dim=64, inputs=[_f32(q), _f32(qd), out], device=DEV)
    want = nonfinite_envs_reference(q, qd)
    assert want.any() and not want.all()
    np.testing.assert_array_equal(out.numpy(), want)


def test_spawn_pose_and_zero_rows_kernels_match_references():
    rng = np.random.default_rng(1)
    n = 32
    mask = rng.random(n) < 0.5
    spawn, q, qd, target = rng.normal(size=(n, 25)), rng.normal(size=(n, 25)), rng.normal(size=(n, 24)), rng.normal(
        size=(n, 25))
    arrays = [_f32(a) for a in (spawn, q, qd, target)]
    m = as_mask(mask, wp.zeros(n, dtype=wp.bool, device=DEV))
    wp.launch(spawn_pose_kernel, dim=n, inputs=[m, *arrays], device=DEV)
    want = spawn_pose_reference(mask, spawn.astype(np.float32), q.astype(np.float32), qd.astype(np.float32),
                                target.astype(np.float32))  # fmt: skip
    for got, expected in zip(arrays[1:], want):
        np.testing.assert_array_equal(got.numpy(), expected.astype(np.float32))
    rows = _f32(q)
    wp.launch(zero_world_rows_kernel, dim=n, inputs=[m, rows], device=DEV)
    np.testing.assert_array_equal(rows.numpy(), zero_world_rows_reference(mask, q.astype(np.float32)))


def test_accumulate_overflow_kernel_matches_reference():
    rng = np.random.default_rng(2)
    n = 16
    for pairs, reduction in ((0, 0), (11, 0), (0, 1), (11, 1)):
        solver = rng.integers(0, 4, n).astype(np.int32) * (rng.random(n) < 0.3)
        sticky0 = rng.integers(0, 2, n).astype(np.int32)
        sticky = wp.array(sticky0, dtype=wp.int32, device=DEV)
        global_sticky = wp.zeros(1, dtype=wp.int32, device=DEV)
        ints = [wp.array(np.asarray(a, np.int32), dtype=wp.int32, device=DEV) for a in (solver, [pairs], [reduction])]
        wp.launch(accumulate_overflow_kernel, dim=n, inputs=[ints[0], ints[1], 10, ints[2], sticky, global_sticky],
                  device=DEV)  # fmt: skip
        want_sticky, want_global = accumulate_overflow_reference(solver, [pairs], 10, [reduction], sticky0, [0])
        np.testing.assert_array_equal(sticky.numpy(), want_sticky)
        np.testing.assert_array_equal(global_sticky.numpy(), want_global)
        assert bool(want_global[0] & OVERFLOW_TRIANGLE_PAIRS) == (pairs > 10)
        assert bool(want_global[0] & OVERFLOW_CONTACT_REDUCTION) == (reduction != 0)
