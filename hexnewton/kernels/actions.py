"""High level -> mid/low level: a policy action in [-1, 1]^15 to the 15 physical CPG parameters.

    p_k = lo_k + (clip(a_k, -1, 1) + 1) / 2 * (hi_k - lo_k)

with the ranges of ``CPGConfig`` (omega in rad/s, amplitudes in rad). A non-finite action component maps
to the middle of its range, so a diverged policy cannot poison the oscillators.
"""

import warp as wp


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
    lower: wp.vec3,
    upper: wp.vec3,
    target_offset: int,
    targets: wp.array2d[wp.float32],
):
    """The pure-DRL action mode: 18 actions in [-1, 1] map straight onto each joint's limit range."""
    e, j = wp.tid()
    k = j % 3
    targets[e, target_offset + j] = action_to_range(actions[e, j], lower[k], upper[k])
