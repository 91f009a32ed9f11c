"""What the robot can do at all on stairs and blocks: the limits set by its geometry, by the CPG's reach, by the task's
tilt limits and by the terrain generator, in float64 NumPy (``python studies/capability/ceiling.py``).

Everything here is kinematic: joint angles are the CPG's joint targets (the PD drives are taken to track them), the
body is a rigid frame over its feet, and the ground is the terrain generator's own height grid.

- Forward kinematics (:func:`feet_np`): the foot spheres' centres in the body frame from the 18 joint angles, the
  geometry of ``robot/geometry.py`` (the leg frame at the hip mount, yawed by ``leg_yaw``; hip about the
  vertical, knee and ankle about the leg frame's -y', the tibia hanging along -z at knee + ankle from vertical).
- The CPG's gait (:func:`cpg_cycle`): Eq. 3 integrated by its float64 reference (``hopf_cpg_reference``) from the
  locked start, one settling cycle, then one recorded cycle mapped by Eq. 4's reference (``mapping_reference``) to
  joint targets. A leg swings while its oscillator's dy/dt >= 0; its lift is the foot's height above its own stance
  height (the same posture, Eq. 4's lift term 0). omega only sets the timing: the world-frame path of a swinging foot
  (body-frame path plus the body's travel at the stance speed, duty 0.5) is the same at every omega.
- Footholds on stairs (:func:`stair_footholds`): the swinging foot's world path over a staircase whose first riser
  lies at a uniform offset within one tread ahead of the lift-off point. The foot's lowest point touches the ground
  where it first meets the highest ground under its sphere (plus ``margin`` over a riser); a touch-down within one
  foot radius of a riser's line (a stubbed riser or a foot on the nose) fails, anything else is a clean foothold.
- Body tilt on the terrain (:func:`tripod_tilt`): the plane through a tripod's three standing feet on the generated
  grid (each foot on the highest cell under its sphere), at body positions along the course.
- Verdicts (:func:`verdicts`): per target of :data:`TARGETS`, whether it lies within the robot's reach (its joint
  limits), the CPG's (the policy's parameter ranges) and the task's tilt limits (the stability fine, the fall), and so
  whose limit a shortfall there is.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from hexnewton.config import LEG_NAMES, LEG_OSCILLATOR, CPGConfig, RobotConfig, TerrainConfig, without_lanes
from hexnewton.kernels.reference import hopf_cpg_reference, initial_cpg_state, mapping_reference
from hexnewton.robot.geometry import hip_mount, joint_limits, leg_bounds, leg_yaw, stand_height
from hexnewton.terrain.heightmap import build_height_grid, complex_step_count, validate_config
from hexnewton.terrain.query import max_terrain_height_np

#: the issue's targets: (name, what is swept, value [m], the course it is walked on, the rest of that course)
TARGETS = (("8 cm rise", "step_rise", 0.08, "stepped", dict(step_depth=0.25)),
           ("20 cm treads", "step_depth", 0.20, "stepped", dict(step_rise=0.06)),
           ("8 cm blocks", "block_height_max", 0.08, "rugged", {}))  # fmt: skip
#: tripods: the legs on oscillator 0 and on oscillator 1
TRIPODS = tuple(tuple(i for i, o in enumerate(LEG_OSCILLATOR) if o == k) for k in (0, 1))


# ------------------------------------------------------------------------------------------------------------------
# robot geometry
# ------------------------------------------------------------------------------------------------------------------


def feet_np(robot: RobotConfig, q) -> np.ndarray:
    """Foot-sphere centres (..., 6, 3) in the body frame for joint angles ``q`` (..., 18) in JOINT_NAMES order."""
    q = np.asarray(q, np.float64)
    out = np.empty(q.shape[:-1] + (6, 3))
    l1, l2, l3 = robot.hip_length, robot.femur_length, robot.tibia_length
    for leg in range(len(LEG_NAMES)):
        hip, knee, ankle = (q[..., 3 * leg + k] for k in range(3))
        rho = l1 + l2 * np.cos(knee) + l3 * np.sin(knee + ankle)
        ang = leg_yaw(robot, leg) + (hip if leg < 3 else -hip)  # the hip axis is +z' on the right, -z' on the left
        mx, my, mz = hip_mount(robot, leg)
        out[..., leg, 0] = mx + rho * np.cos(ang)
        out[..., leg, 1] = my + rho * np.sin(ang)
        out[..., leg, 2] = mz + l2 * np.sin(knee) - l3 * np.cos(knee + ankle)
    return out


def stand_q(robot: RobotConfig) -> np.ndarray:
    return np.tile(np.asarray(robot.stand_pose, np.float64), 6)


def robot_geometry(robot: RobotConfig) -> dict:
    """The standing robot: height, feet, the front-to-rear span of a tripod, the spacing of a side's feet along x, the
    torso's underside clearance."""
    feet = feet_np(robot, stand_q(robot))
    x = feet[:3, 0]  # right legs front to rear
    h = stand_height(robot)
    return {"link_lengths_m": [robot.hip_length, robot.femur_length, robot.tibia_length],
            "foot_radius_m": robot.foot_radius, "torso_size_m": list(robot.torso_size),
            "stand_height_m": h, "stand_height_fk_m": robot.foot_radius - float(feet[:, 2].min()),
            "feet_stand_body_m": feet.tolist(), "span_x_m": float(x[0] - x[2]),
            "side_spacing_x_m": [float(x[0] - x[1]), float(x[1] - x[2])],
            "span_y_m": float(feet[3:, 1].max() - feet[:3, 1].min()),
            "torso_clearance_m": h - robot.torso_size[2] / 2}  # fmt: skip


# ------------------------------------------------------------------------------------------------------------------
# the CPG's reach
# ------------------------------------------------------------------------------------------------------------------


def param_grid(cpg: CPGConfig, n: int = 5, a2=None) -> np.ndarray:
    """Gaits (M, num_params) over the ranges the policy may choose: omega at the top of its range (it only sets the
    timing), every A1 > 0, A2 (``a2``: these values; default ``n`` over its range) and A3 the same on every leg, and
    with the posture P_h and P_p at their ends and 0 (P_r 0: roll does not help on stairs)."""
    lo, hi = cpg.param_ranges()
    a1 = np.linspace(max(lo[1], 0.2 * hi[1]), hi[1], n)
    a2 = np.linspace(lo[3], hi[3], n) if a2 is None else np.asarray(a2, np.float64)
    a3 = np.linspace(lo[9], hi[9], n)
    axes = [a1, a2, a3]
    if cpg.posture:
        axes += [np.array([lo[15], 0.0, hi[15]]), np.array([lo[16], 0.0, hi[16]])]
    mesh = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(axes))
    p = np.zeros((len(mesh), cpg.num_params))
    p[:, 0] = hi[0]
    p[:, 1:3], p[:, 3:9], p[:, 9:15] = mesh[:, :1], mesh[:, 1:2], mesh[:, 2:3]
    if cpg.posture:
        p[:, 15:17] = mesh[:, 3:5]
    return p


def cpg_cycle(robot: RobotConfig, cpg: CPGConfig, params, dt: float = 0.001) -> dict:
    """One gait cycle of every gait in ``params`` (M, num_params), all at one omega, through the float64 references:
    joint targets, feet (body frame) and each leg's swing flag, (T, M, ...)."""
    params = np.asarray(params, np.float64)
    if not np.allclose(params[:, 0], params[0, 0]):
        raise ValueError("cpg_cycle: every gait of one call must share omega")
    steps = int(round(2 * math.pi / params[0, 0] / dt))
    state = np.tile(np.asarray(initial_cpg_state(cpg.mu, cpg.theta)), (len(params), 1))
    lower, upper = (np.asarray(b) for b in leg_bounds(robot))
    stand = np.asarray(robot.stand_pose, np.float64)
    args = (cpg.alpha, cpg.mu, cpg.delta, cpg.theta, cpg.duty, cpg.steepness, dt)
    q, swing = [], []
    for k in range(2 * steps):
        _, state, dy = hopf_cpg_reference(params, params, state, 1.0, *args)
        if k >= steps:
            q.append(mapping_reference(state, dy, params, cpg.mu, stand, lower, upper))
            swing.append(dy[:, list(LEG_OSCILLATOR)] >= 0.0)
    q = np.stack(q)
    return {"q": q, "feet": feet_np(robot, q), "swing": np.stack(swing), "dt": dt}


def _stance_z(cycle: dict) -> np.ndarray:
    """Each gait's and leg's stance foot height (M, 6): the median over the cycle's stance samples."""
    z = np.where(cycle["swing"], np.nan, cycle["feet"][..., 2])
    return np.nanmedian(z, axis=0)


def lift_stats(robot: RobotConfig, cycle: dict) -> dict:
    """Per gait and leg (M, 6): the swing foot's peak height above its own stance height, above the standing pose's
    foot height, and the stride (the stance foot's travel along x in the body frame)."""
    z, x = cycle["feet"][..., 2], cycle["feet"][..., 0]
    stance = _stance_z(cycle)
    z0 = feet_np(robot, stand_q(robot))[:, 2]
    x_st = np.where(cycle["swing"], np.nan, x)
    return {"lift": z.max(axis=0) - stance, "lift_over_stand": z.max(axis=0) - z0,
            "stride": np.nanmax(x_st, axis=0) - np.nanmin(x_st, axis=0), "stance_z": stance}


def swing_paths(cycle: dict, gait: int, leg: int) -> tuple[np.ndarray, np.ndarray]:
    """The swinging foot's world-frame path of gait ``gait``, leg ``leg``, lift-off to touch-down: (x from the lift-off
    point, height of the foot above its stance height), the body advancing at the stance speed meanwhile."""
    sw = cycle["swing"][:, gait, leg]
    x, z = cycle["feet"][:, gait, leg, 0], cycle["feet"][:, gait, leg, 2]
    start = int(np.argmax(sw & ~np.roll(sw, 1)))  # the first swing sample: the cycle rolled to begin there
    sw, x, z = np.roll(sw, -start), np.roll(x, -start), np.roll(z, -start)
    n, dt = int(sw.sum()), cycle["dt"]
    v = (x[n] - x[-1]) / ((len(x) - 1 - n) * dt)  # the body's speed: the stance foot's backward travel
    k = np.arange(n + 1)
    path_x = np.concatenate([[0.0], x[: n + 1] + v * (k + 1) * dt - x[-1]])
    path_z = np.concatenate([[0.0], z[: n + 1] - np.median(z[n:])])
    return path_x, path_z


# ------------------------------------------------------------------------------------------------------------------
# footholds on stairs
# ------------------------------------------------------------------------------------------------------------------


def stair_footholds(path_x, path_z, rise: float, depth: float, foot_radius: float, margin: float,
                    offsets: int = 200) -> dict:
    """Where a swing over stairs ends, for the first riser at ``offsets`` offsets uniform within one tread ahead of
    the lift-off point: shares of clean footholds, of clean footholds a tread or more up, and of failures (a stubbed
    riser or a foot on a nose)."""
    e = (np.arange(offsets) + 0.5) / offsets * depth  # (K,)
    x = np.asarray(path_x)[None, :]
    zb = np.asarray(path_z)[None, :]

    def ground(xq):
        return rise * np.clip(np.floor((xq - e[:, None]) / depth) + 1, 0, None)

    front, back = ground(x + foot_radius), ground(x - foot_radius)
    edge = front > back  # a riser's line within the sphere's reach
    off = int(np.argmax(zb[0] > 1e-6))  # the first sample off the ground: before it only a riser stops the foot
    touch = (edge & (zb <= front + margin)) | ((np.arange(zb.shape[1]) >= off) & (zb <= front))
    touch[:, 0], touch[:, -1] = False, True  # the foot leaves the ground at lift-off and is down at the end
    i = np.argmax(touch, axis=1)
    k = np.arange(offsets)
    fail = edge[k, i]
    level = np.round(ground(x)[k, i] / rise) if rise > 0 else np.zeros(offsets)
    land = np.asarray(path_x)[max(off, int(np.argmax((np.arange(zb.shape[1]) >= off) & (zb[0] <= 0.0))))]
    crossing = min(1.0, (float(land) + foot_radius) / depth)  # offsets with a riser within reach before flat landing
    return {"clean": float(np.mean(~fail)), "climb": float(np.mean(~fail & (level >= 1))),
            "fail": float(np.mean(fail)), "per_riser": max(0.0, 1.0 - float(np.mean(fail)) / crossing)}


def best_footholds(robot: RobotConfig, cycle: dict, rise: float, depth: float, margin: float) -> dict:
    """The gait whose worst leg (all six must climb) clears the largest share of the risers it meets
    (:func:`stair_footholds`' ``per_riser``); gaits whose swing reaches less than 1 cm forward are left out."""
    n = cycle["feet"].shape[1]
    score = np.empty((n, 6))
    for g in range(n):
        for leg in range(6):
            px, pz = swing_paths(cycle, g, leg)
            ok = px[-1] >= 0.01
            score[g, leg] = stair_footholds(px, pz, rise, depth, robot.foot_radius, margin)["per_riser"] if ok else 0.0
    worst = score.min(axis=1)
    g = int(np.argmax(worst))
    return {"gait": g, "per_riser_worst_leg": float(worst[g]), "per_riser_per_leg": score[g].tolist()}


# ------------------------------------------------------------------------------------------------------------------
# tilt the terrain imposes
# ------------------------------------------------------------------------------------------------------------------


def tripod_tilt(robot: RobotConfig, terrain: TerrainConfig, xs, ys, feet=None) -> np.ndarray:
    """(pitch, roll) [rad], (2, P, 2 tripods), of the plane through each tripod's standing feet on the generated grid
    with the body (yaw 0) at (xs, ys); ``feet`` (6, 3): body-frame feet (default: the standing pose's). Positive
    pitch: nose up."""
    grid = build_height_grid(terrain)
    feet = feet_np(robot, stand_q(robot)) if feet is None else np.asarray(feet)
    px = np.asarray(xs, np.float64)[:, None] + feet[None, :, 0]
    py = np.asarray(ys, np.float64)[:, None] + feet[None, :, 1]
    h = max_terrain_height_np(grid, px, py, robot.foot_radius)  # (P, 6)
    out = np.empty((2, len(px), 2))
    for t, legs in enumerate(TRIPODS):
        a = np.stack([feet[list(legs), 0], feet[list(legs), 1], np.ones(3)], axis=1)  # z = c0 x + c1 y + c2
        c = np.linalg.solve(a, h[:, list(legs)].T)  # (3, P)
        out[0, :, t] = np.arctan(c[0])
        out[1, :, t] = -np.arctan(c[1])  # ground rising to the left (+y) rolls the body right side down
    return out


def stair_tilt(robot: RobotConfig, rise: float, depth: float, samples: int = 400) -> dict:
    """The pitch the stairs impose on the standing robot, at ``samples`` body positions over the flight (both tripods):
    mean, worst, the share of positions within 0.5 deg of the worst, and the closed forms: atan(rise / tread) for the
    mean, atan(n rise / span) for the worst, n the most risers between the front and the rear feet."""
    terrain = replace(TerrainConfig(name="stepped"), step_rise=rise, step_depth=depth)
    span = robot_geometry(robot)["span_x_m"]
    x0 = terrain.stepped_start_x + span
    x1 = terrain.stepped_start_x + terrain.step_count * depth - span
    xs = np.linspace(x0, x1, samples)
    pitch = tripod_tilt(robot, terrain, xs, np.zeros_like(xs))[0]
    worst = float(pitch.max())
    return {"mean_deg": math.degrees(float(pitch.mean())), "worst_deg": math.degrees(worst),
            "share_at_worst": float(np.mean(pitch > worst - math.radians(0.5))),
            "closed_form_worst_deg": math.degrees(math.atan(rise * math.ceil(span / depth - 1e-9) / span)),
            "closed_form_mean_deg": math.degrees(math.atan(rise / depth))}  # fmt: skip


def block_tilt(robot: RobotConfig, height: float, samples: int = 4000, seed: int = 0) -> dict:
    """The tilt 2 cm blocks of 0-``height`` impose on the standing robot at ``samples`` random positions (both
    tripods): the 99.9th percentile of |pitch| and |roll| and the share beyond pi/6."""
    terrain = replace(TerrainConfig(name="rugged", seed=seed), block_height_max=height)
    rng = np.random.default_rng(seed)
    xs, ys = rng.uniform(0.0, 3.0, samples), rng.uniform(-1.5, 1.5, samples)
    pitch, roll = np.abs(tripod_tilt(robot, terrain, xs, ys))
    tilt = np.maximum(pitch, roll)
    return {"pitch_p999_deg": math.degrees(float(np.quantile(pitch, 0.999))),
            "roll_p999_deg": math.degrees(float(np.quantile(roll, 0.999))),
            "share_beyond_pi6": float(np.mean(tilt > math.pi / 6))}  # fmt: skip


def posture_levelling(robot: RobotConfig, cpg: CPGConfig, n: int = 31) -> dict:
    """The stair slope the body posture can level: the most nose-down pitch it gives on level ground (P_p > 0 raises
    the front feet in the body frame, as the treads ahead do), and the torso height range it gives (standing feet on
    level ground); 0 and the standing height without the posture."""
    if not cpg.posture:
        h = stand_height(robot)
        return {"pitch_deg": 0.0, "height_m": [h, h]}
    lo, hi = cpg.param_ranges()
    ph, pp = np.meshgrid(np.linspace(lo[15], hi[15], n), np.linspace(lo[16], hi[16], n), indexing="ij")
    p = np.zeros((ph.size, cpg.num_params))
    p[:, 15], p[:, 16] = ph.ravel(), pp.ravel()
    state = np.tile([0.0, 1.0, 0.0, -1.0], (len(p), 1)) * math.sqrt(cpg.mu)  # y = +-1: no lift
    lower, upper = (np.asarray(b) for b in leg_bounds(robot))
    q = mapping_reference(state, -np.ones((len(p), 2)), p, cpg.mu, np.asarray(robot.stand_pose), lower, upper)
    feet = feet_np(robot, q)
    span = feet[:, 0, 0] - feet[:, 2, 0]
    pitch = np.arctan((feet[:, 0, 2] - feet[:, 2, 2]) / span)  # front feet higher in the body: the nose drops
    height = robot.foot_radius - feet[:, :, 2].min(axis=1)
    return {"pitch_deg": math.degrees(float(pitch.max())), "height_m": [float(height.min()), float(height.max())]}


def joint_limits_list(robot: RobotConfig) -> list:
    return [list(b) for b in joint_limits(robot)[:3]]


# ------------------------------------------------------------------------------------------------------------------
# the ceilings and the verdicts
# ------------------------------------------------------------------------------------------------------------------

#: the points of the capability curves (``evaluate --sweep default``'s stairs and blocks, ``rollout.DEFAULT_SWEEPS``)
RISES = (0.04, 0.06, 0.07, 0.08, 0.09, 0.10, 0.12, 0.14)
TREADS = (0.10, 0.12, 0.15, 0.18, 0.20, 0.22, 0.25)
BLOCKS = (0.04, 0.06, 0.08, 0.09, 0.10)
#: a target whose worst standing tilt lies within this many degrees of the stability fine names the fine as its nearest
#: limit (the body's dynamic pitch comes on top of the standing one)
TIGHT_DEG = 10.0
#: the A2 values of the lift-against-A2 table (the default range's, 0-1.3)
A2_VALUES = (0.0, 0.3, 0.6, 0.9, 1.1, 1.3)


def cpg_reach(robot: RobotConfig, cpg: CPGConfig, n: int, dt: float) -> tuple[dict, dict]:
    """The CPG's reach over the policy's ranges: peak lift (worst leg: every leg must clear), over the whole range
    and at its lowest A2; stride; the world-frame step of a swing; the lift against A2 over 0-1.3 (the best A1, A3 and
    posture, and A3 = 0). Returns (numbers, the cycle of the policy's gaits)."""
    params = param_grid(cpg, n)
    cycle = cpg_cycle(robot, cpg, params, dt)
    st = lift_stats(robot, cycle)
    worst = st["lift"].min(axis=1)
    a2_lo = params[:, 3] == params[:, 3].min()
    steps = [swing_paths(cycle, g, 1)[0][-1] for g in range(len(params)) if params[g, 1] == params[:, 1].max()]
    full = replace(cpg, a2_range=(min(A2_VALUES), max(A2_VALUES)))
    grid = param_grid(full, 3, a2=A2_VALUES)
    by_a2 = lift_stats(robot, cpg_cycle(robot, full, grid, dt))["lift"].min(axis=1)
    knee_only = grid[:, 9] == 0.0  # A3 = 0: the knee alone lifts
    g = int(np.argmax(worst))
    return {"lift_max_m": float(worst.max()), "lift_max_gait": params[g].tolist(),
            "lift_max_any_leg_m": float(st["lift"].max()), "lift_over_stand_max_m": float(st["lift_over_stand"].max()),
            "lift_at_a2_min_m": float(worst[a2_lo].max()), "a2_min": float(params[:, 3].min()),
            "stride_max_m": float(st["stride"].max()), "swing_step_max_m": float(max(steps)),
            "speed_max_m_s": float(max(steps)) * cpg.omega_range[1] / (2 * math.pi),
            "lift_by_a2": [{"a2": a, "best_m": float(by_a2[grid[:, 3] == a].max()),
                            "a3_0_m": float(by_a2[(grid[:, 3] == a) & knee_only].max())} for a in A2_VALUES]}, cycle


def stairs_table(robot: RobotConfig, cycle: dict, levelling_deg: float, margin: float, goal: float) -> list[dict]:
    """One row per stairs point (the rises at 25 cm treads, the treads at 6 cm rises): the best blind gait's share of
    risers cleared (worst leg), the pitch the flight imposes (mean, worst, worst after the posture's levelling, the
    share of positions within 0.5 deg of the worst), and the risers a walk to ``goal`` metres climbs."""
    start, count = TerrainConfig.stepped_start_x, TerrainConfig.step_count
    points = [(r, 0.25) for r in RISES] + [(0.06, d) for d in TREADS if d != 0.25] + [(0.08, 0.20), (0.08, 0.18)]
    rows = []
    for rise, depth in points:
        tilt = stair_tilt(robot, rise, depth)
        feet = best_footholds(robot, cycle, rise, depth, margin)
        rows.append({"rise_m": rise, "tread_m": depth, "cleared_per_riser": feet["per_riser_worst_leg"],
                     "pitch_mean_deg": tilt["mean_deg"], "pitch_worst_deg": tilt["worst_deg"],
                     "pitch_worst_levelled_deg": max(0.0, tilt["worst_deg"] - levelling_deg),
                     "share_at_worst": tilt["share_at_worst"],
                     "risers_to_goal": min(count, math.ceil((goal - start) / depth - 1e-9))})  # fmt: skip
    return rows


def pitch_limits(robot: RobotConfig, levelling_deg: float, limits: dict) -> list[dict]:
    """Per tread: the rise at which the worst pitch the flight imposes reaches each tilt limit, without and with the
    posture's levelling (the body levels ``levelling_deg`` of it)."""
    span = robot_geometry(robot)["span_x_m"]
    out = []
    for depth in TREADS:
        n = math.ceil(span / depth - 1e-9)  # risers between the front and the rear feet at worst
        row = {"tread_m": depth, "risers_under_span": n}
        for name, angle in limits.items():
            row[f"rise_at_{name}_m"] = span * math.tan(angle) / n
            row[f"rise_at_{name}_levelled_m"] = span * (math.tan(angle) + math.tan(math.radians(levelling_deg))) / n
        out.append(row)
    return out


def tread_limits(robot: RobotConfig, levelling_deg: float, angle: float, rises=(0.06, 0.08)) -> list[dict]:
    """Per rise: the tread below which the worst standing pitch passes ``angle`` [rad], without and with the posture's
    levelling (ceil(span / tread) risers under the span; None: no tread on the flight passes it)."""
    span = robot_geometry(robot)["span_x_m"]
    out = []
    for rise in rises:
        row = {"rise_m": rise}
        for key, extra in (("tread_m", 0.0), ("tread_levelled_m", math.tan(math.radians(levelling_deg)))):
            risers = math.floor(span * (math.tan(angle) + extra) / rise)  # the most risers the span may hold
            row[key] = span / risers if risers >= 1 else None
        out.append(row)
    return out


def blocks_table(robot: RobotConfig, reach: dict, margin: float) -> list[dict]:
    """Per block height: the lift left over the tallest block at the lowest A2, the torso's clearance over a block of
    full height under it (feet on the ground), and the tilt the blocks impose."""
    clearance = robot_geometry(robot)["torso_clearance_m"]
    rows = []
    for h in BLOCKS:
        tilt = block_tilt(robot, h)
        rows.append({"height_m": h, "lift_margin_at_a2_min_m": reach["lift_at_a2_min_m"] - h - margin,
                     "lift_margin_max_m": reach["lift_max_m"] - h - margin, "torso_clearance_m": clearance - h,
                     **tilt})  # fmt: skip
    return rows


def robot_lift(robot: RobotConfig, n: int = 181) -> float:
    """The highest a foot can rise above its standing height with the knee and ankle anywhere within their limits (the
    robot's own reach, whatever drives the joints)."""
    (_, k0, a0), (_, k1, a1) = leg_bounds(robot)
    k, a = np.meshgrid(np.linspace(k0, k1, n), np.linspace(a0, a1, n), indexing="ij")
    q = np.zeros(k.shape + (18,))
    q[..., 1], q[..., 2] = k, a
    return float(feet_np(robot, q)[..., 0, 2].max() - feet_np(robot, stand_q(robot))[0, 2])


def terrain_limits(terrain: TerrainConfig, goal: float) -> dict:
    """What the generator builds: treads on its grid (a tread off it is one error line), any rise >= 0, the stairs
    a walk to ``goal`` metres meets and the complex course's stair count per tread, the block lattice."""
    def message(**fields):
        try:
            validate_config(without_lanes(terrain, name="stepped", **fields))
        except ValueError as exc:
            return str(exc)
        return None

    start, count = terrain.stepped_start_x, terrain.step_count
    return {"query_resolution_m": terrain.query_resolution, "tread_off_grid_error": message(step_depth=0.175),
            "rise_0_5m_error": message(step_rise=0.5), "block_size_m": terrain.block_size,
            "stairs": [{"tread_m": d, "flight_end_m": start + count * d,
                        "risers_to_goal": min(count, math.ceil((goal - start) / d - 1e-9)),
                        "complex_steps": complex_step_count(replace(terrain, step_depth=d))} for d in TREADS]}


def task_limits(cfg) -> dict:
    """The task's tilt limits: Table 1's stability fine and the fall termination, and the tilt shaping weight."""
    return {"stability_tilt_rad": cfg.reward.stability_tilt, "stability_penalty": cfg.reward.stability_penalty,
            "max_tilt_rad": cfg.task.max_tilt, "w_tilt": cfg.reward.w_tilt, "control_dt_s": cfg.task.control_dt}


def _row(rows: list[dict], **key) -> dict:
    return next(r for r in rows if all(abs(r[k] - v) < 1e-9 for k, v in key.items()))


def _yes(ok: bool) -> str:
    return "yes" if ok else "no"


def verdicts(res: dict) -> list[dict]:
    """Per target of :data:`TARGETS`: within the robot's reach, the CPG's reach, the stability fine's and the fall
    termination's tilt; each with its one-line reason."""
    g, reach, task, margin = res["robot"], res["cpg"], res["task"], res["margin_m"]
    fine, fall = task["stability_tilt_rad"], task["max_tilt_rad"]
    out = []
    for name, field, value, _, rest in TARGETS:
        if field == "block_height_max":
            row = _row(res["blocks"], height_m=value)
            robot = res["robot_lift_m"] - margin >= value and row["torso_clearance_m"] > 0
            cpg = reach["lift_at_a2_min_m"] - value - margin >= 0
            tilt = math.radians(max(row["pitch_p999_deg"], row["roll_p999_deg"]))
            why = (f"foot lift {res['robot_lift_m']:.3f} m, torso {row['torso_clearance_m']:.3f} m above a full block",
                   f"lift at the lowest A2 ({reach['a2_min']:g}) {reach['lift_at_a2_min_m']:.3f} m: "
                   f"{reach['lift_at_a2_min_m'] - value - margin:+.3f} m over the block and the margin",
                   f"p99.9 tripod tilt {math.degrees(tilt):.1f} deg")  # fmt: skip
        else:
            rise, depth = (value, rest["step_depth"]) if field == "step_rise" else (rest["step_rise"], value)
            row = _row(res["stairs"], rise_m=rise, tread_m=depth)
            robot = res["robot_lift_m"] - margin >= rise and depth > 2 * g["foot_radius_m"]
            cpg = reach["lift_max_m"] - margin >= rise and row["cleared_per_riser"] > 0
            tilt = math.radians(row["pitch_worst_deg"])
            foot = 2 * g["foot_radius_m"]
            why = (f"foot lift {res['robot_lift_m']:.3f} m, tread {depth:g} m against a {foot:g} m foot",
                   f"peak lift {reach['lift_max_m']:.3f} m; a blind gait clears {100 * row['cleared_per_riser']:.0f} "
                   f"% of the risers it meets",
                   f"worst standing pitch {row['pitch_worst_deg']:.1f} deg ({row['pitch_worst_levelled_deg']:.1f} "
                   f"levelled), mean {row['pitch_mean_deg']:.1f}")  # fmt: skip
        v = {"target": name, "robot": robot, "cpg": cpg, "fine": tilt < fine, "fall": tilt < fall,
             "fine_margin_deg": math.degrees(fine - tilt), "reasons": list(why)}
        v["gap"] = ("the robot's" if not robot else "the CPG's" if not cpg else "the task's" if not (v["fine"] and
                    v["fall"]) else "the controller's")  # fmt: skip
        if v["gap"] == "the controller's" and v["fine_margin_deg"] < TIGHT_DEG:
            v["gap"] += f", with the task's stability fine the nearest limit (within {TIGHT_DEG:g} deg of the pitch)"
        v["line"] = (f"{name}: robot's reach {_yes(robot)} ({why[0]}); CPG's reach {_yes(cpg)} ({why[1]}); below the "
                     f"stability fine ({math.degrees(fine):.0f} deg) {_yes(v['fine'])}, below the fall "
                     f"({math.degrees(fall):.0f} deg) {_yes(v['fall'])} ({why[2]}, {v['fine_margin_deg']:+.1f} deg "
                     f"to the fine): a shortfall here is {v['gap']}")  # fmt: skip
        out.append(v)
    return out


def notes(res: dict) -> list[str]:
    """Each target against the trained course (6 cm rises, 25 cm treads, blocks of 0-6 cm): what changes."""
    st = {(r["rise_m"], r["tread_m"]): r for r in res["stairs"]}
    bl = {r["height_m"]: r for r in res["blocks"]}
    base, r8, t20, t18 = st[(0.06, 0.25)], st[(0.08, 0.25)], st[(0.06, 0.20)], st[(0.06, 0.18)]
    g, c, m = res["robot"], res["cpg"], res["margin_m"]
    crouch = res["posture"]["height_m"][0] - g["torso_size_m"][2] / 2
    return [
        f"8 cm rise against 6 cm (25 cm treads): the blind gait clears {100 * r8['cleared_per_riser']:.0f} % of the "
        f"risers against {100 * base['cleared_per_riser']:.0f} %; the worst standing pitch rises from "
        f"{base['pitch_worst_deg']:.1f} to {r8['pitch_worst_deg']:.1f} deg (the fine at "
        f"{math.degrees(res['task']['stability_tilt_rad']):.0f}), the tilt shaping from "
        f"{base['tilt_cost_per_step']:.1f} to {r8['tilt_cost_per_step']:.1f} per step. The CPG lifts a foot "
        f"{c['lift_max_m']:.3f} m: the rise ceiling with the {m:g} m margin is {c['lift_max_m'] - m:.3f} m.",
        f"20 cm treads against 25 cm (6 cm rises): the same worst pitch ({t20['pitch_worst_deg']:.1f} deg, two "
        f"risers under the {g['span_x_m']:.3f} m span) at {100 * t20['share_at_worst']:.0f} % of the positions "
        f"against {100 * base['share_at_worst']:.0f} %, {t20['risers_to_goal']} risers before the "
        f"{res['goal_m']:g} m mark against {base['risers_to_goal']}; at 18 cm {100 * t18['share_at_worst']:.0f} % and "
        f"{t18['risers_to_goal']} risers, and a side's three feet ({g['side_spacing_x_m'][0]:.3f} m apart) meet the "
        "risers at nearly the same place.",
        f"8 cm blocks against 6 cm: the lowest A2 still lifts a foot {c['lift_at_a2_min_m'] - 0.08 - m:+.3f} m over "
        f"the tallest block and the margin; the torso clears a full block by {bl[0.08]['torso_clearance_m']:.3f} m "
        f"standing, {crouch - 0.08:.3f} m crouched (P_h at its top); p99.9 tilt {bl[0.08]['pitch_p999_deg']:.1f} deg.",
    ]  # fmt: skip


def ceilings(cfg, margin: float = 0.01, n: int = 5, dt: float = 0.002) -> dict:
    """Every ceiling of the module docstring for the config ``cfg`` (a :class:`~hexnewton.config.HexConfig`, e.g. a
    checkpoint's): the swing foot clears a riser or a block with ``margin`` to spare; ``n`` values per CPG range."""
    if not (0.0 <= margin < 0.1 and 2 <= n <= 9 and 0.0 < dt <= 0.005):
        raise ValueError(f"margin must lie in [0, 0.1) m, n in [2, 9], dt in (0, 0.005] s; got {margin}, {n}, {dt}")
    robot, cpg = cfg.robot, cfg.cpg
    goal = cfg.task.goal_distance - cfg.task.goal_radius
    reach, cycle = cpg_reach(robot, cpg, n, dt)
    level = posture_levelling(robot, cpg)
    task = task_limits(cfg)
    stairs = stairs_table(robot, cycle, level["pitch_deg"], margin, goal)
    for row in stairs:
        row["tilt_cost_per_step"] = task["w_tilt"] * math.radians(row["pitch_mean_deg"]) ** 2
    res = {"margin_m": margin, "grid": n, "dt_s": dt, "goal_m": goal, "robot": robot_geometry(robot),
           "joint_limits_rad": joint_limits_list(robot), "robot_lift_m": robot_lift(robot), "cpg": reach,
           "param_ranges": [list(r) for r in zip(*cpg.param_ranges())], "param_names": list(cpg.param_names),
           "posture": level, "task": task, "stairs": stairs,
           "pitch_limits": pitch_limits(robot, level["pitch_deg"], {"fine": task["stability_tilt_rad"],
                                                                      "fall": task["max_tilt_rad"]}),
           "tread_limits": tread_limits(robot, level["pitch_deg"], task["stability_tilt_rad"]),
           "blocks": blocks_table(robot, reach, margin), "terrain": terrain_limits(cfg.terrain, goal)}  # fmt: skip
    res["verdicts"] = verdicts(res)
    res["notes"] = notes(res)
    return res
