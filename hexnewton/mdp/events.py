"""The MDP's events: what happens to an env besides the policy's actions (mjlab's "events"), in the order of a control
step, and the physical draws made once when the env is built.

Physical draws (``RandomizationConfig``, at construction: :func:`randomize_physics`)
-------------------------------------------------------------------------------------
Each env's friction, payload, link masses, PD gains, effort limits and, where set, foot radius, contact time
constant and motor strength (a factor on both the gains and the effort limits), drawn once and written into the
:class:`~hexnewton.physics.world.World`'s Newton model, then handed to MuJoCo.

Per-step randomisation (``RandomizationConfig.enabled``; the kernels in ``hexnewton.kernels.events``)
--------------------------------------------------------------------------------------------------
- :func:`delay_actions_kernel`: actuation latency. Envs flagged ``late`` act on the previous control step's
  actions (20 ms late); the others on this step's.
- :func:`push_kernel`: every ``interval`` control steps of an episode, a random horizontal change of the base
  velocity (components uniform in +-``velocity``).
- :func:`observation_noise_kernel`: uniform noise of a per-column amplitude added to the observation.

Terrain curriculum (legged_gym style, ``TerrainConfig.levels`` = L > 0): every finished episode moves its robot
between lanes
------------------------------------------------------------------------------------------------------------------
The curriculum terrain is L lanes side by side along y; lane k is the chosen terrain with its block heights and step
rise scaled by (k + 1) / L, or with ``TerrainConfig.levels_past`` = P lanes past the course by (k + 1) / (L - P) up to
the course and toward the ``hardest_*`` rise, tread and block height beyond it (``terrain.heightmap.lane_config``).
When an env's episode ends (status != 0), before it is reset (:func:`curriculum_kernel`):
- success (the goal reached, i.e. ``goal_distance - goal_radius`` walked): ``TerrainConfig.climb`` levels up (1 by
  default); an env that solves the last level goes to a random level, so every level keeps being visited (as
  legged_gym does);
- fell, off course or timed out having walked less than half of ``goal_distance`` (with
  ``TerrainConfig.start_progress``, of the episode's own way from its start to its goal) along the goal's course (x on
  the straight tasks): one level down
  (never below 0); otherwise the level stays; on the lanes past the course with ``TerrainConfig.past_down`` "miss"
  (levels from ``strict_from`` on), any of these: one level down;
- nonfinite (blown-up physics): the level stays;
- an episode played on a drawn lane past the course (below): the level stays.
With ``TerrainConfig.past_share`` = s > 0, each new episode is played with probability s on a lane past the course
drawn evenly among the P, whatever the level (which it does not change); the others on the level's lane.
With ``TerrainConfig.lane_courses``, the lanes form one group of L per course, side by side along y, and env i plays
group i mod the groups' count throughout: its fixed lateral offset holds its group's offset.
Every finished episode is also counted on the lane it was played on (:func:`lane_count_kernel`: episodes and
successes per lane group and lane, since the env was built), which the training log reads once per iteration
(``hexnewton.learning.lanes``).
The env's lane start moves to the new (or drawn) level's lane centre (plus the env's own fixed lateral offset), at
``spawn_height`` above the highest terrain under the robot's footprint there; the reset then places the
robot there. :func:`placement_kernel` does the placement alone (at construction).

Resets (:func:`reset_envs_kernel`)
----------------------------------
For every env selected by ``mask``, back to the env's start lane with the randomisation the task asks for
(``TaskConfig.reset_lateral``, ``reset_yaw``, ``reset_joint_noise``):
- the base goes to (lane_x, lane_y + U(-lateral, lateral)) at height ``spawn_z``, with yaw U(-yaw, yaw); with
  ``TerrainConfig.start_progress`` = p > 0 (one draw more, after the others) to lane_x + U(0, p), at the spawn
  clearance above the highest ground under the robot's footprint there, its goal still ``goal_distance`` ahead of
  lane_x;
- the joints go to the standing pose + U(-joint, joint), clipped to the limits, at rest;
- the joint targets are set to that pose;
- ``start`` receives the new base (x, y) and the goals' ``start_yaw`` its heading: the episode's start, the frame of a
  waypoint course;
- the episode's first goal (``mdp/terms/goals.py``, ``set_goal``; two more draws, which only random goals read);
- ``prev_xy`` receives the new base (x, y), for the forward reward.
The world then makes its physics consistent with the new joint state (``World.restart``).

Episode bookkeeping (:func:`bookkeeping_kernel`)
------------------------------------------------
After the rewards and the goal switch: the done flags and step counters, and for each finished episode a row of the
env's ring of the last episodes (status one-hot, distance walked along the goal's course, length, curriculum lane,
goals reached), which the env's log averages.

Random numbers come from Warp's counter-based generator, ``wp.rand_init(seed, env + N * counter)``, with ``counter``
the env's control-step counter, advanced once per step by :func:`advance_counter_kernel` (a launch of its own, so
that every kernel runs inside the captured graph).
"""

from __future__ import annotations

import newton
import numpy as np
import warp as wp

from hexnewton.mdp.status import NONFINITE, SUCCESS, TIMEOUT
from hexnewton.mdp.terms import TERMINATIONS, Goals, HeightField, TaskParams, max_terrain_height, set_goal
from hexnewton.mdp.terms.goals import course_to
from hexnewton.physics.world import World
from hexnewton.robot import BASE_QD


def randomize_physics(world: World, seed: int = 0) -> dict[str, np.ndarray]:
    """Draw each env's physical properties from ``world.cfg.randomization`` (``RandomizationConfig``), write them into
    the world's Newton model and hand them to MuJoCo: contact friction, torso payload, leg link masses, PD gains and
    effort limits, foot radius, contact time constant and motor strength (where set). Returns the per-env draws
    (``kp_scale`` and ``effort_scale`` as applied: with ``motor_strength``, their own draws times it)."""
    r, m, n = world.cfg.randomization, world.model, world.num_envs
    rng = np.random.default_rng([seed, 0x5EED])
    u = lambda lo_hi: rng.uniform(lo_hi[0], lo_hi[1], n)  # noqa: E731
    draws = {"friction": u(r.friction), "payload": u(r.payload), "link_mass_scale": u(r.link_mass_scale),
             "kp_scale": u(r.kp_scale), "kd_scale": u(r.kd_scale), "effort_scale": u(r.effort_scale)}  # fmt: skip
    # friction: MuJoCo combines two geoms' friction by max, so the shared ground takes the range's minimum
    # and every robot shape its env's draw
    shape_world = m.shape_world.numpy()
    mu = m.shape_material_mu.numpy()
    robot = shape_world >= 0
    mu[robot] = draws["friction"][shape_world[robot]]
    mu[~robot] = min(r.friction)
    m.shape_material_mu.assign(mu)
    draws.update(_contact_draws(world, rng, robot, shape_world))
    if r.motor_strength is not None:  # one factor on the gains and the effort limits together
        if not 0 < r.motor_strength[0] <= r.motor_strength[1]:
            raise ValueError(f"randomization.motor_strength must be LO HI with 0 < LO <= HI, got {r.motor_strength}")
        draws["motor_strength"] = strength = u(r.motor_strength)
        draws["kp_scale"], draws["effort_scale"] = draws["kp_scale"] * strength, draws["effort_scale"] * strength
    # masses: bodies are laid out env by env, torso first; inertia scales with the mass
    per_env = m.body_count // n
    mass = m.body_mass.numpy().reshape(n, per_env)
    inertia = m.body_inertia.numpy().reshape(n, per_env, 3, 3)
    scale = np.ones((n, per_env))
    scale[:, 0] = (mass[:, 0] + draws["payload"]) / mass[:, 0]
    scale[:, 1:] = draws["link_mass_scale"][:, None]
    mass = mass * scale
    inertia = inertia * scale[:, :, None, None]
    m.body_mass.assign(mass.reshape(-1).astype(np.float32))
    m.body_inv_mass.assign(np.where(mass > 0, 1.0 / mass, 0.0).reshape(-1).astype(np.float32))
    m.body_inertia.assign(inertia.reshape(-1, 3, 3).astype(np.float32))
    m.body_inv_inertia.assign(np.linalg.inv(inertia.reshape(-1, 3, 3)).astype(np.float32))
    # the 18 actuated joints of each env (after the 6 base dofs)
    nd = m.joint_dof_count // n
    for name, key in (("joint_target_ke", "kp_scale"), ("joint_target_kd", "kd_scale"),
                      ("joint_effort_limit", "effort_scale")):  # fmt: skip
        a = getattr(m, name).numpy().reshape(n, nd)
        a[:, BASE_QD:] *= draws[key][:, None]
        getattr(m, name).assign(a.reshape(-1))
    world.solver.notify_model_changed(newton.ModelFlags.SHAPE_PROPERTIES | newton.ModelFlags.BODY_INERTIAL_PROPERTIES
                                      | newton.ModelFlags.JOINT_DOF_PROPERTIES | newton.ModelFlags.ACTUATOR_PROPERTIES)
    world.apply_effort_clamp()  # the effort limits just handed to MuJoCo, moved to the actuators where configured
    return draws


def _contact_draws(world: World, rng: np.random.Generator, robot: np.ndarray, shape_world: np.ndarray) -> dict:
    """Each env's foot radius (``shape_scale`` of its ``*_foot`` spheres, their bounding radius with it) and its
    robot-ground contact time constant, where ``cfg.randomization`` sets them. MuJoCo averages the two geoms'
    solref, so the robot's shapes get ``2 t - t_ground`` (stiffness 1/t², damping 2/t: damping ratio 1)."""
    r, m, n = world.cfg.randomization, world.model, world.num_envs
    draws = {}
    if r.foot_radius is not None:
        draws["foot_radius"] = radius = rng.uniform(r.foot_radius[0], r.foot_radius[1], n)
        feet = robot & np.array([str(label).endswith("_foot") for label in m.shape_label])
        scale, bound = m.shape_scale.numpy(), m.shape_collision_radius.numpy()
        scale[feet, 0] = bound[feet] = radius[shape_world[feet]]
        m.shape_scale.assign(scale)
        m.shape_collision_radius.assign(bound)
    if r.contact_timeconst is not None:
        draws["contact_timeconst"] = t = rng.uniform(r.contact_timeconst[0], r.contact_timeconst[1], n)
        ke, kd = m.shape_material_ke.numpy(), m.shape_material_kd.numpy()
        ground = ~robot
        t_ground = 2.0 / float(kd[ground][0]) if ground.any() and kd[ground][0] > 0 else 0.02
        t_robot = np.maximum(2.0 * t[shape_world[robot]] - t_ground, 1e-3)
        ke[robot], kd[robot] = 1.0 / t_robot**2, 2.0 / t_robot
        m.shape_material_ke.assign(ke)
        m.shape_material_kd.assign(kd)
    return draws


__all__ = ["randomize_physics"]


# ====================================================================================================
# terrain curriculum
# ====================================================================================================

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
    course: wp.array[wp.vec2],
    goal: wp.array[wp.vec2],
    goal_distance: float,
    own_way: bool,
    levels: int,
    climb: int,
    strict_from: int,
    lane_width: float,
    offset_y: wp.array[wp.float32],
    hf: HeightField,
    footprint: float,
    spawn_height: float,
    levels_past: int,
    past_share: float,
    seed: int,
    counter: wp.array[wp.int32],
    level: wp.array[wp.int32],
    played: wp.array[wp.int32],
    lane: wp.array[wp.vec2],
    spawn_z: wp.array[wp.float32],
):
    e = wp.tid()
    st = status[e]
    if st == 0 or st == NONFINITE:
        return
    lv = level[e]
    rng = wp.rand_init(seed, e + joint_q.shape[0] * counter[0])
    if played[e] != lv:  # an episode on a drawn lane past the course leaves the level as it is
        pass
    elif st == SUCCESS:
        if lv + 1 >= levels:  # the last level solved
            lv = wp.min(int(wp.randf(rng) * float(levels)), levels - 1)
        else:
            lv = wp.min(lv + climb, levels - 1)
    else:
        way = goal_distance
        if own_way:  # episodes that start part of the way along (TerrainConfig.start_progress): their own way
            way = wp.length(goal[e] - start[e])
        if lv >= strict_from or walked(joint_q, start, course, e) < 0.5 * way:
            lv = wp.max(lv - 1, 0)
    level[e] = lv
    play = lv
    if past_share > 0.0 and wp.randf(rng) < past_share:  # this episode on a lane past the course, drawn evenly
        play = levels - levels_past + wp.min(int(wp.randf(rng) * float(levels_past)), levels_past - 1)
    played[e] = play
    p = _place(hf, play, levels, lane_width, offset_y[e], footprint, spawn_height)
    lane[e] = wp.vec2(p[0], p[1])
    spawn_z[e] = p[2]


@wp.func
def walked(joint_q: wp.array2d[wp.float32], start: wp.array[wp.vec2], course: wp.array[wp.vec2], e: int) -> float:
    """How far env ``e`` walked from its episode's start along its goal's course (x - x_start on the straight tasks)."""
    c = course[e]
    return (joint_q[e, 0] - start[e][0]) * c[0] + (joint_q[e, 1] - start[e][1]) * c[1]


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


@wp.kernel
def lane_count_kernel(
    status: wp.array[wp.int32],
    played: wp.array[wp.int32],
    group: wp.array[wp.int32],
    levels: int,
    counts: wp.array2d[wp.int32],
):
    """Every finished episode (status != 0) counted on the lane it was played on, in its env's lane group: row
    ``group * levels + lane``, column 0 the episodes, 1 those that reached the goal (what training saw, per lane)."""
    e = wp.tid()
    st = status[e]
    if st == 0:
        return
    row = group[e] * levels + played[e]
    wp.atomic_add(counts, row, 0, 1)
    if st == SUCCESS:
        wp.atomic_add(counts, row, 1, 1)


def lane_count_reference(status, played, group, levels: int, groups: int) -> np.ndarray:
    """Float64-free twin of :func:`lane_count_kernel` (integer counts): (groups * levels, 2) episodes and successes of
    this step's finished episodes per (group, lane) row."""
    status, played, group = np.asarray(status), np.asarray(played), np.asarray(group)
    out = np.zeros((groups * levels, 2), np.int64)
    done = status != 0
    rows = group[done] * levels + played[done]
    np.add.at(out[:, 0], rows, 1)
    np.add.at(out[:, 1], rows[status[done] == SUCCESS], 1)
    return out


def start_levels(num_envs: int, start_levels: int) -> np.ndarray:
    """Initial levels: envs spread evenly over 0 .. start_levels - 1."""
    return (np.arange(num_envs) * start_levels // max(num_envs, 1)).astype(np.int32)


def strict_from(cfg) -> int:
    """The first level on which any missed goal moves a robot down (:func:`curriculum_kernel`): the first lane past
    the course with ``TerrainConfig.past_down`` "miss", else ``levels`` (none)."""
    return cfg.levels - cfg.levels_past if cfg.past_down == "miss" and cfg.levels_past else cfg.levels


def curriculum_reference(status, walked, level, goal_distance, levels, random_level, strict_from=None, climb=1,
                         played=None, way=None):
    """Float64 reference of :func:`curriculum_kernel`'s level update (``walked`` along the goal's course from the
    start: x - start x on the straight tasks; ``random_level``
    (N,) stands in for the kernel's draw where an env solves the last level; ``strict_from`` and ``climb`` as the
    kernel's, None: ``levels``; ``played`` (N,): the lane each episode was played on, None: its level; one drawn
    past the course leaves the level as it is; ``way`` (N,): each episode's own way from its start to its goal
    (``own_way``), None: ``goal_distance``). Returns the new levels."""
    status, walked, level = np.asarray(status), np.asarray(walked, np.float64), np.asarray(level, np.int64)
    strict = level >= (levels if strict_from is None else strict_from)
    up = np.where(level + 1 >= levels, random_level, np.minimum(level + climb, levels - 1))
    half = 0.5 * (goal_distance if way is None else np.asarray(way, np.float64))
    down = np.where(strict | (walked < half), np.maximum(level - 1, 0), level)
    new = np.where(status == SUCCESS, up, down)
    keep = (status == 0) | (status == NONFINITE)
    if played is not None:
        keep |= np.asarray(played) != level
    return np.where(keep, level, new)


# ====================================================================================================
# resets
# ====================================================================================================

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
    progress: float,
    hf: HeightField,
    footprint: float,
    spawn_height: float,
    seed: int,
    counter: wp.array[wp.int32],
    task: TaskParams,
    goals: Goals,
    joint_q: wp.array2d[wp.float32],
    joint_qd: wp.array2d[wp.float32],
    joint_target: wp.array2d[wp.float32],
    prev_xy: wp.array[wp.vec2],
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
    u_bearing = wp.randf(rng)
    u_distance = wp.randf(rng)
    x0 = x
    if progress > 0.0:  # part of the way along the lane (TerrainConfig.start_progress), above the ground there
        x = x0 + progress * wp.randf(rng)
        joint_q[e, 0] = x
        joint_q[e, 2] = max_terrain_height(hf, x, y, footprint) + spawn_height
    goals.start[e] = wp.vec2(x, y)
    goals.start_yaw[e] = a
    goals.reached[e] = 0
    set_goal(goals, task, e, 0, x, y, a, u_bearing, u_distance)
    if progress > 0.0 and goals.waypoint_count == 0 and not task.random_goals:  # the lane's goal, ahead of its start
        g = wp.vec2(x0 + task.goal_distance, y)
        goals.goal[e] = g
        goals.course[e] = course_to(x, y, g)
    prev_xy[e] = wp.vec2(x, y)


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


# ====================================================================================================
# episode bookkeeping
# ====================================================================================================

# the ring's columns: one per episode end (its status code - 1), then distance, length, the curriculum lane played and
# the goals reached
ENDS = sorted(TERMINATIONS, key=lambda end: end.code)
DISTANCE, LENGTH, LEVEL, GOALS = len(ENDS), len(ENDS) + 1, len(ENDS) + 2, len(ENDS) + 3


@wp.kernel
def bookkeeping_kernel(
    status: wp.array[wp.int32],
    joint_q: wp.array2d[wp.float32],
    start: wp.array[wp.vec2],
    course: wp.array[wp.vec2],
    reached: wp.array[wp.int32],
    level: wp.array[wp.int32],
    steps: wp.array[wp.int32],
    done: wp.array[wp.bool],
    done_u8: wp.array[wp.uint8],
    time_out: wp.array[wp.uint8],
    cursor: wp.array[wp.int32],
    ring: wp.array2d[wp.float32],
    nonfinite_total: wp.array[wp.int32],
):
    """Done flags and step counters; each finished episode writes (status one-hot, distance along the goal's course,
    length, curriculum level, goals reached) to the ring; blown-up envs are counted in ``nonfinite_total``."""
    e = wp.tid()
    st = status[e]
    d = st != 0
    done[e] = d
    done_u8[e] = wp.uint8(0)
    time_out[e] = wp.uint8(0)
    if st == TIMEOUT:
        time_out[e] = wp.uint8(1)
    if st == NONFINITE:
        wp.atomic_add(nonfinite_total, 0, 1)
    if d:
        done_u8[e] = wp.uint8(1)
        slot = wp.atomic_add(cursor, 0, 1) % ring.shape[0]
        for k in range(wp.static(len(ENDS))):
            ring[slot, k] = 0.0
        ring[slot, st - 1] = 1.0  # status 1..5 -> columns fell, off_course, success, timeout, nonfinite
        dist = float(0.0)
        if wp.isfinite(joint_q[e, 0]) and wp.isfinite(joint_q[e, 1]):
            dist = walked(joint_q, start, course, e)
        ring[slot, DISTANCE] = dist
        ring[slot, LENGTH] = float(steps[e] + 1)
        ring[slot, LEVEL] = float(level[e])
        goals = reached[e]
        if st == SUCCESS:  # the last goal, whose reaching ended the episode
            goals = goals + 1
        ring[slot, GOALS] = float(goals)
        steps[e] = 0
    else:
        steps[e] = steps[e] + 1
