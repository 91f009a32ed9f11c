"""The paper's 18-DoF hexapod (Huang et al. 2025, §3.5), built procedurally as a Newton articulation.

Kinematic tree: torso (free base joint first), then per leg in the order R1, R2, R3, L1, L2, L3 (front to
back) three revolute joints hip -> knee -> ankle with links coxa (50 mm), femur (80 mm), tibia (130 mm).
Sign conventions are in ``hexnewton.config`` and the README: positive hip swings the foot forward on every
leg, positive knee lifts the femur, negative ankle tucks the foot toward the body.

Each leg has its own "leg frame" at its hip mount: x' points outward along the leg's neutral direction,
z' = world up, y' = z' x x'. In that frame the hip axis is +z' (right legs) or -z' (left legs), so that a
positive hip angle moves the foot toward +x on both sides; the knee and ankle axes are -y', so a positive
angle rotates x' toward +z' (lifting) and -z' toward +x' (foot outward).
"""

from __future__ import annotations

import math

import numpy as np
import warp as wp

import newton

from ..config import LEG_NAMES, RobotConfig

#: Free-joint coordinates per robot (position xyz + quaternion xyzw) and velocities (linear + angular).
BASE_Q = 7
BASE_QD = 6
NUM_JOINTS = 18


def leg_yaw(cfg: RobotConfig, leg: int) -> float:
    """Yaw [rad] of the leg's outward neutral direction in the body frame (leg index in LEG_NAMES order)."""
    row = leg % 3
    splay = math.radians(cfg.mount_splay_deg[row])
    # right legs point to -y, left legs to +y; front legs splay toward +x on both sides
    return -math.pi / 2 + splay if leg < 3 else math.pi / 2 - splay


def hip_mount(cfg: RobotConfig, leg: int) -> tuple[float, float, float]:
    """Hip joint position in the body frame [m]."""
    x, y = cfg.hip_mounts[leg % 3]
    return (x, -y if leg < 3 else y, 0.0)


def torso_mass(cfg: RobotConfig) -> float:
    return cfg.total_mass - 6.0 * (cfg.coxa_mass + cfg.femur_mass + cfg.tibia_mass)


def _box_inertia(m: float, sx: float, sy: float, sz: float) -> wp.mat33:
    return wp.mat33(
        m * (sy * sy + sz * sz) / 12.0, 0.0, 0.0,
        0.0, m * (sx * sx + sz * sz) / 12.0, 0.0,
        0.0, 0.0, m * (sx * sx + sy * sy) / 12.0,
    )  # fmt: skip


def _rod_inertia(m: float, length: float, radius: float, axis: int) -> wp.mat33:
    """Solid-cylinder inertia about its centre, long axis along ``axis`` (0 = x, 2 = z)."""
    i_long = 0.5 * m * radius * radius
    i_trans = m * (3.0 * radius * radius + length * length) / 12.0
    d = [i_trans, i_trans, i_trans]
    d[axis] = i_long
    return wp.mat33(d[0], 0.0, 0.0, 0.0, d[1], 0.0, 0.0, 0.0, d[2])


def stand_height(cfg: RobotConfig) -> float:
    """Torso-origin height above flat ground in the neutral standing pose [m] (feet touching)."""
    _, knee, ankle = cfg.stand_pose
    # femur raised by `knee`, tibia at angle (knee + ankle) from vertical in the leg plane
    return -cfg.femur_length * math.sin(knee) + cfg.tibia_length * math.cos(knee + ankle) + cfg.foot_radius


def validate(cfg: RobotConfig) -> None:
    """Raise ValueError with one clear line for a physically meaningless robot config."""
    for name in ("hip_length", "femur_length", "tibia_length", "total_mass", "leg_radius", "foot_radius"):
        if not getattr(cfg, name) > 0:
            raise ValueError(f"robot.{name} must be > 0, got {getattr(cfg, name)}")
    if torso_mass(cfg) <= 0:
        raise ValueError("robot.total_mass must exceed the six legs' mass")
    for kind, (lo, hi), q in zip(("hip", "knee", "ankle"), joint_limits(cfg)[:3], cfg.stand_pose):
        if not lo <= q <= hi:
            raise ValueError(f"robot.stand_pose {kind}={q} lies outside its limits [{lo}, {hi}]")


def joint_limits(cfg: RobotConfig) -> list[tuple[float, float]]:
    """(lower, upper) per joint in JOINT_NAMES order."""
    return [cfg.hip_limit, cfg.knee_limit, cfg.ankle_limit] * 6


def leg_bounds(cfg: RobotConfig) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(lower, upper) limits of one leg's (hip, knee, ankle), the same on every leg."""
    return (cfg.hip_limit[0], cfg.knee_limit[0], cfg.ankle_limit[0]), (cfg.hip_limit[1], cfg.knee_limit[1],
                                                                         cfg.ankle_limit[1])


def build_hexapod(cfg: RobotConfig | None = None, gap: float | None = None) -> newton.ModelBuilder:
    """Build one hexapod as a Newton ``ModelBuilder`` (free base + 18 revolute joints, one articulation).

    The torso starts at ``cfg.spawn_height`` above z = 0 in the neutral standing pose; callers move it onto
    the terrain through the free joint's coordinates. ``gap`` is the contact detection gap of the robot's
    shapes (Newton's default, 0.1 m, overflows contact buffers on block terrain).
    """
    cfg = cfg or RobotConfig()
    validate(cfg)
    b = newton.ModelBuilder()
    newton.solvers.SolverMuJoCo.register_custom_attributes(b)
    if gap is not None:
        b.rigid_gap = gap

    leg_shape = newton.ModelBuilder.ShapeConfig(density=0.0, mu=cfg.friction)
    leg_shape.collision_filter_parent = True
    torso_shape = newton.ModelBuilder.ShapeConfig(density=0.0, mu=cfg.friction)

    base_z = cfg.spawn_height
    torso_m = torso_mass(cfg)
    sx, sy, sz = cfg.torso_size
    torso = b.add_link(
        xform=wp.transform(wp.vec3(0.0, 0.0, base_z), wp.quat_identity()),
        mass=torso_m,
        inertia=_box_inertia(torso_m, sx, sy, sz),
        label="torso",
        lock_inertia=True,
    )
    b.add_shape_box(torso, hx=sx / 2, hy=sy / 2, hz=sz / 2, cfg=torso_shape, label="torso")
    joints = [b.add_joint_free(child=torso, label="base")]

    hip_q, knee_q, ankle_q = cfg.stand_pose
    drive = dict(
        target_ke=cfg.joint_ke,
        target_kd=cfg.joint_kd,
        effort_limit=cfg.effort_limit,
        armature=cfg.armature,
        limit_ke=cfg.limit_ke,
        limit_kd=cfg.limit_kd,
    )
    r = cfg.leg_radius
    # capsules run along their local z; rotate local z onto the leg frame's +x
    z_to_x = wp.quat_from_axis_angle(wp.vec3(0.0, 1.0, 0.0), math.pi / 2)

    for leg, name in enumerate(LEG_NAMES):
        yaw = leg_yaw(cfg, leg)
        q_leg = wp.quat_from_axis_angle(wp.vec3(0.0, 0.0, 1.0), yaw)
        mount = wp.vec3(*hip_mount(cfg, leg))
        hip_axis = (0.0, 0.0, 1.0) if leg < 3 else (0.0, 0.0, -1.0)
        pitch_axis = (0.0, -1.0, 0.0)
        # initial world poses only seed the builder; eval_fk from joint_q is authoritative
        p_world = wp.vec3(mount[0], mount[1], base_z)

        # links: (name, mass, length, com, long axis 0 = x / 2 = z); joints: (name, parent offset, axis, limits,
        # standing angle). The tibia hangs along its local -z; coxa and femur run along the leg frame's +x.
        links = (
            ("coxa", cfg.coxa_mass, cfg.hip_length, wp.vec3(cfg.hip_length / 2, 0.0, 0.0), 0),
            ("femur", cfg.femur_mass, cfg.femur_length, wp.vec3(cfg.femur_length / 2, 0.0, 0.0), 0),
            ("tibia", cfg.tibia_mass, cfg.tibia_length, wp.vec3(0.0, 0.0, -cfg.tibia_length / 2), 2),
        )
        joint_specs = (
            ("hip", wp.transform(mount, q_leg), hip_axis, cfg.hip_limit, hip_q),
            ("knee", wp.transform(wp.vec3(cfg.hip_length, 0.0, 0.0), wp.quat_identity()), pitch_axis,
             cfg.knee_limit, knee_q),
            ("ankle", wp.transform(wp.vec3(cfg.femur_length, 0.0, 0.0), wp.quat_identity()), pitch_axis,
             cfg.ankle_limit, ankle_q),
        )  # fmt: skip
        parent = torso
        bodies = []
        for (link, mass, length, com, long_axis), (kind, parent_xform, axis, limit, q0) in zip(links, joint_specs):
            body = b.add_link(
                xform=wp.transform(p_world, q_leg),
                com=com,
                mass=mass,
                inertia=_rod_inertia(mass, length, r, long_axis),
                label=f"{name}_{link}",
                lock_inertia=True,
            )
            joints.append(
                b.add_joint_revolute(
                    parent, body, parent_xform=parent_xform, child_xform=wp.transform_identity(), axis=axis,
                    limit_lower=limit[0], limit_upper=limit[1], target_q=q0, label=f"{name}_{kind}", **drive,
                )
            )  # fmt: skip
            bodies.append(body)
            parent = body
        _, femur, tibia = bodies
        # collision shapes: femur capsule, tibia capsule ending in a foot sphere (coxa hides in the torso)
        b.add_shape_capsule(
            femur,
            xform=wp.transform(wp.vec3(cfg.femur_length / 2, 0.0, 0.0), z_to_x),
            radius=r, half_height=cfg.femur_length / 2 - r, cfg=leg_shape, label=f"{name}_femur",
        )  # fmt: skip
        b.add_shape_capsule(
            tibia,
            xform=wp.transform(wp.vec3(0.0, 0.0, -(cfg.tibia_length - cfg.foot_radius) / 2), wp.quat_identity()),
            radius=r, half_height=max((cfg.tibia_length - cfg.foot_radius) / 2 - r, 1e-3),
            cfg=leg_shape, label=f"{name}_shin",
        )  # fmt: skip
        b.add_shape_sphere(
            tibia,
            xform=wp.transform(wp.vec3(0.0, 0.0, -cfg.tibia_length), wp.quat_identity()),
            radius=cfg.foot_radius, cfg=leg_shape, label=f"{name}_foot",
        )  # fmt: skip

    b.add_articulation(joints, label="hexapod")

    # self-collision off: filter every pair of the robot's own shapes
    shapes = list(range(b.shape_count))
    for i, a in enumerate(shapes):
        for c in shapes[i + 1 :]:
            b.add_shape_collision_filter_pair(a, c)

    # neutral standing pose: free joint at spawn height, legs in stand_pose
    q = np.asarray(b.joint_q, dtype=np.float64)
    q[0:3] = (0.0, 0.0, base_z)
    q[3:7] = (0.0, 0.0, 0.0, 1.0)
    q[BASE_Q:] = np.tile(cfg.stand_pose, 6)
    b.joint_q[:] = q.tolist()
    return b
