"""Terrain curriculum (legged_gym style): every finished episode moves its robot between lanes.

The curriculum terrain (``TerrainConfig.levels`` = L > 0) is L lanes side by side along y; lane k is the
chosen terrain with its block heights and step rise scaled by (k + 1) / L (``terrain.heightmap.lane_config``).
When an env's episode ends (status != 0), before it is reset:
- success (the goal reached, i.e. ``goal_distance - goal_radius`` walked): one level up; an env that solves
  the last level goes to a random level, so every level keeps being visited (as legged_gym does);
- fell, off course or timed out having walked less than half of ``goal_distance`` along x: one level down
  (never below 0); otherwise the level stays;
- nonfinite (blown-up physics): the level stays.
The env's lane start moves to the new level's lane centre (plus the env's own fixed lateral offset), at
``spawn_height`` above the highest terrain under the robot's footprint there; ``World.reset`` then places the
robot there. ``placement_kernel`` does the placement alone (at construction).
"""

import numpy as np
import warp as wp

from ..terrain.query import HeightField, max_terrain_height
from .reference import NONFINITE, SUCCESS


@wp.func
def _place(hf: HeightField, level: int, levels: int, lane_width: float, offset_y: float, footprint: float,
           spawn_height: float) -> wp.vec3:  # fmt: skip
    y = (float(level) + 0.5 - 0.5 * float(levels)) * lane_width + offset_y
    return wp.vec3(0.0, y, max_terrain_height(hf, 0.0, y, footprint) + spawn_height)


@wp.kernel
def curriculum_kernel(
    status: wp.array[wp.int32],
    joint_q: wp.array2d[wp.float32],
    start: wp.array[wp.vec2],
    goal_distance: float,
    levels: int,
    lane_width: float,
    offset_y: wp.array[wp.float32],
    hf: HeightField,
    footprint: float,
    spawn_height: float,
    seed: int,
    counter: wp.array[wp.int32],
    level: wp.array[wp.int32],
    lane: wp.array[wp.vec2],
    spawn_z: wp.array[wp.float32],
):
    e = wp.tid()
    st = status[e]
    if st == 0 or st == NONFINITE:
        return
    lv = level[e]
    if st == SUCCESS:
        lv = lv + 1
        if lv >= levels:
            rng = wp.rand_init(seed, e + joint_q.shape[0] * counter[0])
            lv = wp.min(int(wp.randf(rng) * float(levels)), levels - 1)
    elif joint_q[e, 0] - start[e][0] < 0.5 * goal_distance:
        lv = wp.max(lv - 1, 0)
    level[e] = lv
    p = _place(hf, lv, levels, lane_width, offset_y[e], footprint, spawn_height)
    lane[e] = wp.vec2(p[0], p[1])
    spawn_z[e] = p[2]


@wp.kernel
def placement_kernel(
    level: wp.array[wp.int32],
    levels: int,
    lane_width: float,
    offset_y: wp.array[wp.float32],
    hf: HeightField,
    footprint: float,
    spawn_height: float,
    lane: wp.array[wp.vec2],
    spawn_z: wp.array[wp.float32],
):
    e = wp.tid()
    p = _place(hf, level[e], levels, lane_width, offset_y[e], footprint, spawn_height)
    lane[e] = wp.vec2(p[0], p[1])
    spawn_z[e] = p[2]


def start_levels(num_envs: int, start_levels: int) -> np.ndarray:
    """Initial levels: envs spread evenly over 0 .. start_levels - 1."""
    return (np.arange(num_envs) * start_levels // max(num_envs, 1)).astype(np.int32)


def curriculum_reference(status, walked, level, goal_distance, levels, random_level):
    """Float64 reference of :func:`curriculum_kernel`'s level update (``walked`` = x - start x; ``random_level``
    (N,) stands in for the kernel's draw where an env solves the last level). Returns the new levels."""
    status, walked, level = np.asarray(status), np.asarray(walked, np.float64), np.asarray(level, np.int64)
    up = level + 1
    up = np.where(up >= levels, random_level, up)
    down = np.where(walked < 0.5 * goal_distance, np.maximum(level - 1, 0), level)
    new = np.where(status == SUCCESS, up, down)
    return np.where((status == 0) | (status == NONFINITE), level, new)
