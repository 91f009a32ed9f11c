"""Per-env resets: back to the env's start lane, with the randomisation the RL environment asks for.

For every env selected by ``mask``:
- the base goes to (lane_x, lane_y + U(-lateral, lateral)) at height ``spawn_z``, with yaw U(-yaw, yaw);
- the joints go to the standing pose + U(-joint, joint), clipped to the limits, at rest;
- the joint targets are set to that pose;
- ``start`` receives the new base (x, y), which the goal and the off-course check are measured from;
- ``prev_x`` receives the new base x, for the forward reward.

Random numbers come from Warp's counter-based generator: ``wp.rand_init(seed, env + N * counter)``.
``counter`` is advanced by a separate launch, so the kernel can run inside a captured graph.
"""

import numpy as np
import warp as wp


@wp.kernel
def reset_envs_kernel(
    mask: wp.array[wp.bool],
    lane: wp.array[wp.vec2],
    spawn_z: wp.array[wp.float32],
    stand: wp.vec3,
    lower: wp.vec3,
    upper: wp.vec3,
    lateral: float,
    yaw: float,
    joint_noise: float,
    seed: int,
    counter: wp.array[wp.int32],
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    joint_target: wp.array2d[wp.float32],
    start: wp.array[wp.vec2],
    prev_x: wp.array[wp.float32],
):
    e = wp.tid()
    if not mask[e]:
        return
    n = joint_q.shape[0]
    rng = wp.rand_init(seed, e + n * counter[0])
    x = lane[e][0]
    y = lane[e][1] + lateral * (2.0 * wp.randf(rng) - 1.0)
    a = yaw * (2.0 * wp.randf(rng) - 1.0)
    joint_q[e, 0] = x
    joint_q[e, 1] = y
    joint_q[e, 2] = spawn_z[e]
    joint_q[e, 3] = 0.0
    joint_q[e, 4] = 0.0
    joint_q[e, 5] = wp.sin(0.5 * a)
    joint_q[e, 6] = wp.cos(0.5 * a)
    for leg in range(6):
        for k in range(3):
            q = wp.clamp(stand[k] + joint_noise * (2.0 * wp.randf(rng) - 1.0), lower[k], upper[k])
            joint_q[e, 7 + 3 * leg + k] = q
            joint_target[e, 7 + 3 * leg + k] = q
    for i in range(joint_qd.shape[1]):
        joint_qd[e, i] = 0.0
    start[e] = wp.vec2(x, y)
    prev_x[e] = x


@wp.kernel
def advance_counter_kernel(counter: wp.array[wp.int32]):
    counter[0] = counter[0] + 1


def reset_bounds_reference(lane, spawn_z, stand, lower, upper, lateral, yaw, joint_noise, joint_q):
    """Checks a reset state against its bounds (the generator itself is Warp's); returns True if all hold."""
    q = np.asarray(joint_q, np.float64)
    ok = np.allclose(q[:, 0], np.asarray(lane)[:, 0], atol=1e-6)
    ok &= np.all(np.abs(q[:, 1] - np.asarray(lane)[:, 1]) <= lateral + 1e-6)
    ok &= np.allclose(q[:, 2], spawn_z, atol=1e-6)
    ok &= np.allclose(np.linalg.norm(q[:, 3:7], axis=1), 1.0, atol=1e-5)
    ok &= np.all(np.abs(2 * np.arctan2(q[:, 5], q[:, 6])) <= yaw + 1e-5)
    joints = q[:, 7:25].reshape(-1, 6, 3)
    ok &= np.all(joints >= np.asarray(lower) - 1e-6) & np.all(joints <= np.asarray(upper) + 1e-6)
    ok &= np.all(np.abs(joints - np.asarray(stand)) <= joint_noise + 1e-6)
    return bool(ok)
