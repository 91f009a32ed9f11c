"""The policy's observation (Huang et al. 2025, §2.4.1), one kernel for every env. The layout lives here only.

The paper says the state has 59 dimensions but lists only 54:
- 18 joint positions;
- 18 joint velocities;
- the target position (x, y, z);
- the 14 amplitudes A1[2], A2[6], A3[6];
- the maximum terrain height h.

We add omega (the fifteenth CPG parameter) and the base orientation as a unit quaternion, which makes 59.

``cpg`` layout (59):
    [0:18]   joint positions [rad], order R1..L3 x (hip, knee, ankle)
    [18:36]  joint velocities [rad/s]
    [36:39]  target relative to the robot in its heading frame (x forward, y left; z = goal ground - base z) [m]
    [39]     omega [rad/s] (the filtered parameter the CPG runs with)
    [40:54]  A1_R, A1_L, A2[R1..L3], A3[R1..L3] [rad] (filtered)
    [54:58]  base orientation quaternion (x, y, z, w), sign chosen so that w >= 0
    [58]     h: highest terrain within +-H_HALF_EXTENT of the base, minus the terrain under the base [m]

``cpg_posture`` layout (62): as ``cpg`` with the body posture P_h, P_p, P_r [rad] (filtered) at [54:57], the
quaternion at [57:61] and h at [61].

``joint`` layout (44, the pure-DRL comparison): the same without omega and the amplitudes:
    [0:18] positions, [18:36] velocities, [36:39] target, [39:43] quaternion, [43] h.
"""

import numpy as np
import warp as wp

from ..terrain.query import HeightField, max_terrain_height, terrain_height
from .reference import quat_to_rpy_np
from .terminations import quat_to_rpy

H_HALF_EXTENT = 0.3  # ours: the square that "max height h" looks at: +-30 cm, about the legs' reach [m]
OBS_DIM = {"cpg": 59, "cpg_posture": 62, "joint": 44}
OBS_LAYOUT = {
    "cpg": (("joint_pos", 0, 18), ("joint_vel", 18, 36), ("target", 36, 39), ("omega", 39, 40),
            ("amplitudes", 40, 54), ("quat", 54, 58), ("max_height", 58, 59)),
    "cpg_posture": (("joint_pos", 0, 18), ("joint_vel", 18, 36), ("target", 36, 39), ("omega", 39, 40),
                    ("amplitudes", 40, 54), ("posture", 54, 57), ("quat", 57, 61), ("max_height", 61, 62)),
    "joint": (("joint_pos", 0, 18), ("joint_vel", 18, 36), ("target", 36, 39), ("quat", 39, 43),
              ("max_height", 43, 44)),
}  # fmt: skip


@wp.kernel
def observations_kernel(
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    params: wp.array2d[wp.float32],
    hf: HeightField,
    start: wp.array[wp.vec2],
    goal_distance: float,
    with_params: int,
    obs: wp.array2d[wp.float32],
):
    e = wp.tid()
    for j in range(18):
        obs[e, j] = joint_q[e, 7 + j]
        obs[e, 18 + j] = joint_qd[e, 6 + j]
    px = joint_q[e, 0]
    py = joint_q[e, 1]
    pz = joint_q[e, 2]
    gx = start[e][0] + goal_distance
    gy = start[e][1]
    dx = gx - px
    dy = gy - py
    yaw = quat_to_rpy(wp.normalize(wp.quat(joint_q[e, 3], joint_q[e, 4], joint_q[e, 5], joint_q[e, 6])))[2]
    c = wp.cos(yaw)
    s = wp.sin(yaw)
    obs[e, 36] = c * dx + s * dy
    obs[e, 37] = -s * dx + c * dy
    obs[e, 38] = terrain_height(hf, gx, gy) - pz
    k = int(39)
    if with_params != 0:
        for p in range(params.shape[1]):
            obs[e, 39 + p] = params[e, p]
        k = 39 + params.shape[1]
    sign = float(1.0)
    if joint_q[e, 6] < 0.0:
        sign = -1.0
    for i in range(4):
        obs[e, k + i] = sign * joint_q[e, 3 + i]
    obs[e, k + 4] = max_terrain_height(hf, px, py, H_HALF_EXTENT) - terrain_height(hf, px, py)


def observations_reference(joint_q, joint_qd, params, ground_at, start, goal_distance, with_params):
    """Float64 reference of :func:`observations_kernel`.

    ``ground_at(x, y)`` returns terrain heights and ``ground_at.max(x, y, half_extent)`` the max over a square
    (both vectorised), e.g. ``terrain_height_np`` / ``max_terrain_height_np`` bound to a grid.
    """
    jq, jqd = np.asarray(joint_q, np.float64), np.asarray(joint_qd, np.float64)
    n = len(jq)
    start = np.asarray(start, np.float64)
    gx, gy = start[:, 0] + goal_distance, start[:, 1]
    dx, dy = gx - jq[:, 0], gy - jq[:, 1]
    yaw = quat_to_rpy_np(jq[:, 3:7])[:, 2]
    c, s = np.cos(yaw), np.sin(yaw)
    target = np.stack([c * dx + s * dy, -s * dx + c * dy, ground_at(gx, gy) - jq[:, 2]], axis=1)
    quat = jq[:, 3:7] * np.where(jq[:, 6:7] < 0, -1.0, 1.0)
    h = ground_at.max(jq[:, 0], jq[:, 1], H_HALF_EXTENT) - ground_at(jq[:, 0], jq[:, 1])
    parts = [jq[:, 7:25], jqd[:, 6:24], target]
    if with_params:
        parts.append(np.asarray(params, np.float64).reshape(n, -1))
    parts += [quat, h[:, None]]
    return np.concatenate(parts, axis=1)
