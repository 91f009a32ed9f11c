"""The world's kernels (``hexnewton.physics.world.World`` launches them): the contact-overflow flags folded every
frame, the envs whose state went NaN/Inf, the spawn pose of a reset, rows of per-world values zeroed; each beside its
NumPy twin (float64 where it computes; the overflow flags are integer bits), and ``as_mask``, a per-env mask as the
kernels take it."""

from __future__ import annotations

import numpy as np
import warp as wp

# overflow bits beyond MuJoCo's own (bits 0-15) and Newton's (16 pipeline contacts, 17 nconmax)
OVERFLOW_TRIANGLE_PAIRS = 1 << 20
OVERFLOW_CONTACT_REDUCTION = 1 << 21
OVERFLOW_BOX_PAIRS = 1 << 22  # terrain collision "boxes": a robot shape met more boxes than its pair slots


@wp.kernel
def accumulate_overflow_kernel(
    solver_overflow: wp.array[wp.int32],
    triangle_pairs: wp.array[wp.int32],
    max_triangle_pairs: int,
    reduction_overflow: wp.array[wp.int32],
    sticky: wp.array[wp.int32],
    global_sticky: wp.array[wp.int32],
):
    w = wp.tid()
    bits = solver_overflow[w]
    if bits != 0:
        wp.atomic_or(sticky, w, bits)
    if w == 0:
        g = wp.int32(0)
        if triangle_pairs[0] > max_triangle_pairs:
            g = g | OVERFLOW_TRIANGLE_PAIRS
        if reduction_overflow[0] != 0:
            g = g | OVERFLOW_CONTACT_REDUCTION
        if g != 0:
            wp.atomic_or(global_sticky, 0, g)


def accumulate_overflow_reference(solver_overflow, triangle_pairs, max_triangle_pairs, reduction_overflow, sticky,
                                  global_sticky):
    """NumPy twin of :func:`accumulate_overflow_kernel`: (sticky, global_sticky) after one fold."""
    sticky = np.asarray(sticky, np.int32) | np.asarray(solver_overflow, np.int32)
    g = (OVERFLOW_TRIANGLE_PAIRS if triangle_pairs[0] > max_triangle_pairs else 0) | (
        OVERFLOW_CONTACT_REDUCTION if reduction_overflow[0] != 0 else 0)
    return sticky, np.asarray(global_sticky, np.int32) | g


@wp.kernel
def nonfinite_envs_kernel(
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    out: wp.array[wp.bool],
):
    e = wp.tid()
    bad = int(0)
    for i in range(joint_q.shape[1]):
        if not wp.isfinite(joint_q[e, i]):
            bad = 1
    for i in range(joint_qd.shape[1]):
        if not wp.isfinite(joint_qd[e, i]):
            bad = 1
    out[e] = bad != 0


def nonfinite_envs_reference(joint_q, joint_qd) -> np.ndarray:
    """NumPy twin of :func:`nonfinite_envs_kernel`: True where any coordinate or velocity of an env is NaN/Inf."""
    return ~(np.isfinite(joint_q).all(axis=1) & np.isfinite(joint_qd).all(axis=1))


@wp.kernel
def spawn_pose_kernel(
    mask: wp.array[wp.bool],
    spawn_q: wp.array2d[wp.float32],
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    joint_target: wp.array2d[wp.float32],
):
    e = wp.tid()
    if not mask[e]:
        return
    for k in range(joint_q.shape[1]):
        joint_q[e, k] = spawn_q[e, k]
        joint_target[e, k] = spawn_q[e, k]
    for k in range(joint_qd.shape[1]):
        joint_qd[e, k] = 0.0


def spawn_pose_reference(mask, spawn_q, joint_q, joint_qd, joint_target):
    """Float64 twin of :func:`spawn_pose_kernel`: (joint_q, joint_qd, joint_target) with the masked envs at spawn."""
    q, qd, target = (np.array(a, dtype=np.float64) for a in (joint_q, joint_qd, joint_target))
    q[mask], target[mask], qd[mask] = spawn_q[mask], spawn_q[mask], 0.0
    return q, qd, target


@wp.kernel
def zero_world_rows_kernel(mask: wp.array[wp.bool], values: wp.array2d[wp.float32]):
    """values[w, :] = 0 for the worlds w selected by mask (one thread per world: most steps reset few)."""
    w = wp.tid()
    if mask[w]:
        for i in range(values.shape[1]):
            values[w, i] = 0.0


def zero_world_rows_reference(mask, values) -> np.ndarray:
    """Float64 twin of :func:`zero_world_rows_kernel`."""
    out = np.array(values, dtype=np.float64)
    out[mask] = 0.0
    return out


def as_mask(mask: np.ndarray | wp.array | None, buffer: wp.array) -> wp.array:
    """A per-env bool mask as a Warp array: ``None`` selects all (filled into ``buffer``), a Warp array is used as
    is (capturable), anything else is copied into ``buffer``."""
    if mask is None:
        buffer.fill_(True)
        return buffer
    if isinstance(mask, wp.array):
        return mask
    buffer.assign(np.asarray(mask, dtype=bool))
    return buffer
