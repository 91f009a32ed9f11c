"""The 18-DoF hexapod as a Newton articulation: the paper's (Huang et al. 2025, §3.5) and any robot given by its
dimensions built procedurally, a robot given frame by frame (a robot file's, ``RobotConfig.legs``) from its frames.

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

import newton
import numpy as np
import warp as wp

from hexnewton.config import JOINT_KINDS, LEG_NAMES, RobotConfig
from hexnewton.robot import frames
from hexnewton.robot.geometry import (  # noqa: F401  (re-exported: hexnewton.robot's names)
    BASE_Q,
    BASE_QD,
    NUM_JOINTS,
    PITCH_AXIS,
    box_inertia,
    explicit,
    hip_axis,
    hip_mount,
    joint_limits,
    leg_bounds,
    leg_links,
    leg_yaw,
    rod_inertia,
    stand_height,
    torso_mass,
    validate,
)


def _mat33(diag: tuple[float, float, float]) -> wp.mat33:
    return wp.mat33(diag[0], 0.0, 0.0, 0.0, diag[1], 0.0, 0.0, 0.0, diag[2])


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
    if explicit(cfg):
        joints = _add_frames(b, cfg, torso_shape, leg_shape)
    else:
        torso = _add_torso(b, cfg, torso_shape)
        joints = [b.add_joint_free(child=torso, label="base")]
        for leg in range(len(LEG_NAMES)):
            joints += _add_leg(b, cfg, leg, torso, leg_shape)
    b.add_articulation(joints, label="hexapod")

    # self-collision off: filter every pair of the robot's own shapes
    shapes = list(range(b.shape_count))
    for i, a in enumerate(shapes):
        for c in shapes[i + 1 :]:
            b.add_shape_collision_filter_pair(a, c)

    # neutral standing pose: free joint at spawn height, legs in stand_pose
    q = np.asarray(b.joint_q, dtype=np.float64)
    q[0:3] = (0.0, 0.0, cfg.spawn_height)
    q[3:7] = (0.0, 0.0, 0.0, 1.0)
    q[BASE_Q:] = np.tile(cfg.stand_pose, 6)
    b.joint_q[:] = q.tolist()
    return b


def _add_torso(b: newton.ModelBuilder, cfg: RobotConfig, shape: newton.ModelBuilder.ShapeConfig) -> int:
    """The torso link (a box, ``cfg.spawn_height`` above z = 0) and its collision box; returns the link."""
    torso_m = torso_mass(cfg)
    sx, sy, sz = cfg.torso_size
    torso = b.add_link(
        xform=wp.transform(wp.vec3(0.0, 0.0, cfg.spawn_height), wp.quat_identity()),
        mass=torso_m,
        inertia=_mat33(box_inertia(torso_m, sx, sy, sz)),
        label="torso",
        lock_inertia=True,
    )
    b.add_shape_box(torso, hx=sx / 2, hy=sy / 2, hz=sz / 2, cfg=shape, label="torso")
    return torso


def _add_leg(b: newton.ModelBuilder, cfg: RobotConfig, leg: int, torso: int,
             shape: newton.ModelBuilder.ShapeConfig) -> list[int]:
    """Leg ``leg`` (``LEG_NAMES`` order) on ``torso``: coxa, femur and tibia links on the hip, knee and ankle joints
    (PD-driven, at the standing pose), and the femur's, shin's and foot's collision shapes; returns its joints."""
    name = LEG_NAMES[leg]
    hip_q, knee_q, ankle_q = cfg.stand_pose
    drive = dict(
        target_ke=cfg.joint_ke,
        target_kd=cfg.joint_kd,
        effort_limit=cfg.effort_limit,
        armature=cfg.armature,
        limit_ke=cfg.limit_ke,
        limit_kd=cfg.limit_kd,
    )
    yaw = leg_yaw(cfg, leg)
    q_leg = wp.quat_from_axis_angle(wp.vec3(0.0, 0.0, 1.0), yaw)
    mount = wp.vec3(*hip_mount(cfg, leg))
    # initial world poses only seed the builder; eval_fk from joint_q is authoritative
    p_world = wp.vec3(mount[0], mount[1], cfg.spawn_height)

    # joints: (name, parent offset, axis, limits, standing angle); links: geometry.leg_links
    joint_specs = (
        ("hip", wp.transform(mount, q_leg), hip_axis(leg), cfg.hip_limit, hip_q),
        ("knee", wp.transform(wp.vec3(cfg.hip_length, 0.0, 0.0), wp.quat_identity()), PITCH_AXIS,
         cfg.knee_limit, knee_q),
        ("ankle", wp.transform(wp.vec3(cfg.femur_length, 0.0, 0.0), wp.quat_identity()), PITCH_AXIS,
         cfg.ankle_limit, ankle_q),
    )  # fmt: skip
    parent = torso
    bodies, joints = [], []
    for (link, mass, length, com, long_axis), (kind, parent_xform, axis, limit, q0) in zip(leg_links(cfg),
                                                                                          joint_specs):
        body = b.add_link(
            xform=wp.transform(p_world, q_leg),
            com=wp.vec3(*com),
            mass=mass,
            inertia=_mat33(rod_inertia(mass, length, cfg.leg_radius, long_axis)),
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
    _add_leg_shapes(b, cfg, name, femur, tibia, shape)
    return joints


def _add_leg_shapes(b: newton.ModelBuilder, cfg: RobotConfig, name: str, femur: int, tibia: int,
                    shape: newton.ModelBuilder.ShapeConfig) -> None:
    """A leg's collision shapes: the femur capsule and the tibia capsule ending in the foot sphere (the coxa hides in
    the torso)."""
    r = cfg.leg_radius
    # capsules run along their local z; rotate local z onto the leg frame's +x
    z_to_x = wp.quat_from_axis_angle(wp.vec3(0.0, 1.0, 0.0), math.pi / 2)
    b.add_shape_capsule(
        femur,
        xform=wp.transform(wp.vec3(cfg.femur_length / 2, 0.0, 0.0), z_to_x),
        radius=r, half_height=cfg.femur_length / 2 - r, cfg=shape, label=f"{name}_femur",
    )  # fmt: skip
    b.add_shape_capsule(
        tibia,
        xform=wp.transform(wp.vec3(0.0, 0.0, -(cfg.tibia_length - cfg.foot_radius) / 2), wp.quat_identity()),
        radius=r, half_height=max((cfg.tibia_length - cfg.foot_radius) / 2 - r, 1e-3),
        cfg=shape, label=f"{name}_shin",
    )  # fmt: skip
    b.add_shape_sphere(
        tibia,
        xform=wp.transform(wp.vec3(0.0, 0.0, -cfg.tibia_length), wp.quat_identity()),
        radius=cfg.foot_radius, cfg=shape, label=f"{name}_foot",
    )  # fmt: skip


# ----------------------------------------------------------------------------------------------------
# a robot given frame by frame (RobotConfig.legs, a robot file's)
# ----------------------------------------------------------------------------------------------------

#: the links of a leg by joint kind, as the bodies are named (``R1_tibia``: the lower leg, whose contacts are tracked)
LINK_NAMES = ("coxa", "femur", "tibia")


def _inertia(values) -> wp.mat33:
    ixx, iyy, izz, ixy, ixz, iyz = values
    return wp.mat33(ixx, ixy, ixz, ixy, iyy, iyz, ixz, iyz, izz)


def _add_shapes(b: newton.ModelBuilder, body: int, link, label: str, shape, foot=None) -> None:
    """A link's collision shapes; the sphere centred on ``foot`` is labelled ``<label-leg>_foot``."""
    for k, s in enumerate(link.shapes):
        xform = wp.transform(wp.vec3(*s.pos), wp.quat(*s.quat))
        is_foot = foot is not None and s.kind == "sphere" and frames.norm(frames.sub(s.pos, foot)) < 1e-9
        name = label.rsplit("_", 1)[0] + "_foot" if is_foot else f"{label}_{s.kind}{k}"
        if s.kind == "box":
            b.add_shape_box(body, xform=xform, hx=s.size[0], hy=s.size[1], hz=s.size[2], cfg=shape, label=name)
        elif s.kind == "sphere":
            b.add_shape_sphere(body, xform=xform, radius=s.size[0], cfg=shape, label=name)
        else:
            add = b.add_shape_capsule if s.kind == "capsule" else b.add_shape_cylinder
            add(body, xform=xform, radius=s.size[0], half_height=s.size[1], cfg=shape, label=name)


def _add_frames(b: newton.ModelBuilder, cfg: RobotConfig, torso_shape, leg_shape) -> list[int]:
    """A robot given frame by frame: the torso on a free joint, then per leg its three links on PD-driven revolute
    joints at the standing pose, each with its collision shapes; returns the joints."""
    t = cfg.torso
    torso = b.add_link(xform=wp.transform(wp.vec3(0.0, 0.0, cfg.spawn_height), wp.quat_identity()),
                       com=wp.vec3(*t.com), mass=t.mass, inertia=_inertia(t.inertia), label="torso", lock_inertia=True)
    _add_shapes(b, torso, t, "torso", torso_shape)
    joints = [b.add_joint_free(child=torso, label="base")]
    drive = dict(target_ke=cfg.joint_ke, target_kd=cfg.joint_kd, effort_limit=cfg.effort_limit, armature=cfg.armature,
                 limit_ke=cfg.limit_ke, limit_kd=cfg.limit_kd)
    for name, leg in zip(LEG_NAMES, cfg.legs):
        poses, _ = frames.leg_poses(leg)
        parent = torso
        for k, (joint, (pos, rot)) in enumerate(zip(leg.joints, poses)):
            link = joint.link
            body = b.add_link(xform=wp.transform(wp.vec3(pos[0], pos[1], pos[2] + cfg.spawn_height), wp.quat(*rot)),
                              com=wp.vec3(*link.com), mass=link.mass, inertia=_inertia(link.inertia),
                              label=f"{name}_{LINK_NAMES[k]}", lock_inertia=True)
            joints.append(b.add_joint_revolute(
                parent, body, parent_xform=wp.transform(wp.vec3(*joint.pos), wp.quat(*joint.quat)),
                child_xform=wp.transform_identity(), axis=tuple(joint.axis), limit_lower=joint.limit[0],
                limit_upper=joint.limit[1], target_q=cfg.stand_pose[k], label=f"{name}_{JOINT_KINDS[k]}", **drive))
            _add_shapes(b, body, link, f"{name}_{LINK_NAMES[k]}", leg_shape, leg.foot if k == 2 else None)
            parent = body
    return joints
