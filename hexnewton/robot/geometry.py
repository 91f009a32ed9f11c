"""The hexapod's geometry and mass properties from :class:`~hexnewton.config.RobotConfig`, in plain Python: what the
Newton articulation (:mod:`hexnewton.robot.hexapod`) and the MuJoCo model (:mod:`hexnewton.deploy.mjcf`) are both built
from. Each question (limits, standing height, footprint, masses, the foot) is answered for a robot given by its
dimensions (``RobotConfig.legs`` empty: the formulas below) and for one given frame by frame (a robot file's:
:mod:`hexnewton.robot.frames`); :func:`describe` writes a robot of the first kind as the second.

Each leg has its own "leg frame" at its hip mount: x' points outward along the leg's neutral direction, z' = world up,
y' = z' x x'. In that frame the hip axis is +z' (right legs) or -z' (left legs), so that a positive hip angle moves the
foot toward +x on both sides; the knee and ankle axes are -y', so a positive angle rotates x' toward +z' (lifting) and
-z' toward +x' (foot outward).
"""

from __future__ import annotations

import math

from hexnewton.robot import frames
from hexnewton.robot_config import JOINT_NAMES, JointConfig, LegConfig, LinkConfig, RobotConfig, ShapeConfig

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


def hip_axis(leg: int) -> tuple[float, float, float]:
    """The hip joint's axis in the leg frame: +z' on the right legs, -z' on the left (positive = foot forward)."""
    return (0.0, 0.0, 1.0) if leg < 3 else (0.0, 0.0, -1.0)


#: The knee and ankle axes in the leg frame (positive knee lifts the femur, negative ankle tucks the foot).
PITCH_AXIS = (0.0, -1.0, 0.0)


def explicit(cfg: RobotConfig) -> bool:
    """Whether ``cfg`` is given frame by frame (a robot file's legs) rather than by its dimensions."""
    return bool(cfg.legs)


def torso_mass(cfg: RobotConfig) -> float:
    if explicit(cfg):
        return cfg.torso.mass
    return cfg.total_mass - 6.0 * (cfg.coxa_mass + cfg.femur_mass + cfg.tibia_mass)


def robot_mass(cfg: RobotConfig) -> float:
    """The whole robot's mass [kg]."""
    return frames.total_mass(cfg) if explicit(cfg) else cfg.total_mass


def box_inertia(m: float, sx: float, sy: float, sz: float) -> tuple[float, float, float]:
    """Principal moments of a solid box of mass ``m`` and side lengths ``sx, sy, sz`` about its centre."""
    return (m * (sy * sy + sz * sz) / 12.0, m * (sx * sx + sz * sz) / 12.0, m * (sx * sx + sy * sy) / 12.0)


def rod_inertia(m: float, length: float, radius: float, axis: int) -> tuple[float, float, float]:
    """Principal moments of a solid cylinder about its centre, long axis along ``axis`` (0 = x, 2 = z)."""
    i_long = 0.5 * m * radius * radius
    i_trans = m * (3.0 * radius * radius + length * length) / 12.0
    d = [i_trans, i_trans, i_trans]
    d[axis] = i_long
    return (d[0], d[1], d[2])


def leg_links(cfg: RobotConfig) -> tuple[tuple, ...]:
    """The three links of a leg: (name, mass, length, centre of mass in the link frame, long axis 0 = x / 2 = z).
    Coxa and femur run along the leg frame's +x; the tibia hangs along its local -z."""
    return (
        ("coxa", cfg.coxa_mass, cfg.hip_length, (cfg.hip_length / 2, 0.0, 0.0), 0),
        ("femur", cfg.femur_mass, cfg.femur_length, (cfg.femur_length / 2, 0.0, 0.0), 0),
        ("tibia", cfg.tibia_mass, cfg.tibia_length, (0.0, 0.0, -cfg.tibia_length / 2), 2),
    )


def stand_height(cfg: RobotConfig) -> float:
    """Torso-origin height above flat ground in the neutral standing pose [m] (feet touching)."""
    if explicit(cfg):
        return frames.stand_height(cfg)
    _, knee, ankle = cfg.stand_pose
    # femur raised by `knee`, tibia at angle (knee + ankle) from vertical in the leg plane
    return -cfg.femur_length * math.sin(knee) + cfg.tibia_length * math.cos(knee + ankle) + cfg.foot_radius


def footprint(cfg: RobotConfig) -> float:
    """Half side [m] of the square the robot spawns above: half the torso's diagonal plus coxa and femur."""
    if explicit(cfg):
        return frames.footprint(cfg)
    return 0.5 * math.hypot(*cfg.torso_size[:2]) + cfg.hip_length + cfg.femur_length


def spawn_clearance(cfg: RobotConfig) -> float:
    """Torso height [m] above the highest terrain under the footprint at a (re)spawn."""
    return max(cfg.spawn_height, stand_height(cfg))


def leg_length(cfg: RobotConfig) -> float:
    """A leg's length [m]: coxa, femur and tibia (hip to knee to ankle to the foot's centre)."""
    return frames.leg_length(cfg) if explicit(cfg) else cfg.hip_length + cfg.femur_length + cfg.tibia_length


def foot_offset(cfg: RobotConfig) -> tuple[float, float, float]:
    """The foot's centre in the lower leg's (tibia's) frame [m] (the first leg's, for a robot file)."""
    return tuple(cfg.legs[0].foot) if explicit(cfg) else (0.0, 0.0, -cfg.tibia_length)


def joint_names(cfg: RobotConfig) -> tuple[str, ...]:
    """The 18 joints' names in hexnewton's order: a robot file's own (the ROS node's), else ``JOINT_NAMES``."""
    return tuple(j.name for leg in cfg.legs for j in leg.joints) if explicit(cfg) else JOINT_NAMES


def joint_signs(cfg: RobotConfig) -> tuple[float, ...]:
    """Per joint, hexnewton's angle over the robot file's (1 where they agree; 1 everywhere for a named robot)."""
    return tuple(float(j.sign) for leg in cfg.legs for j in leg.joints) if explicit(cfg) else (1.0,) * NUM_JOINTS


def validate(cfg: RobotConfig) -> None:
    """Raise ValueError with one clear line for a physically meaningless robot config."""
    if explicit(cfg):
        frames.validate(cfg)
    else:
        for name in ("hip_length", "femur_length", "tibia_length", "total_mass", "leg_radius", "foot_radius"):
            if not getattr(cfg, name) > 0:
                raise ValueError(f"robot.{name} must be > 0, got {getattr(cfg, name)}")
        if torso_mass(cfg) <= 0:
            raise ValueError("robot.total_mass must exceed the six legs' mass")
    lower, upper = leg_bounds(cfg)
    for kind, lo, hi, q in zip(("hip", "knee", "ankle"), lower, upper, cfg.stand_pose):
        if not lo <= q <= hi:
            raise ValueError(f"robot.stand_pose {kind}={q} lies outside its limits [{lo}, {hi}]")


def joint_limits(cfg: RobotConfig) -> list[tuple[float, float]]:
    """(lower, upper) per joint in JOINT_NAMES order."""
    if explicit(cfg):
        return [tuple(j.limit) for leg in cfg.legs for j in leg.joints]
    return [cfg.hip_limit, cfg.knee_limit, cfg.ankle_limit] * 6


def leg_bounds(cfg: RobotConfig) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """(lower, upper) limits of one leg's (hip, knee, ankle), the same on every leg: where a robot file's legs differ,
    the range all of them reach (the controller's)."""
    if explicit(cfg):
        limits = joint_limits(cfg)
        return (tuple(max(lo for lo, _ in limits[k::3]) for k in range(3)),
                tuple(min(hi for _, hi in limits[k::3]) for k in range(3)))  # fmt: skip
    return (cfg.hip_limit[0], cfg.knee_limit[0], cfg.ankle_limit[0]), (cfg.hip_limit[1], cfg.knee_limit[1],
                                                                         cfg.ankle_limit[1])


#: a shape quaternion that turns a capsule's own z onto its link's x (x, y, z, w)
Z_TO_X = (0.0, math.sin(math.pi / 4), 0.0, math.cos(math.pi / 4))


def describe(cfg: RobotConfig) -> RobotConfig:
    """``cfg`` frame by frame: a robot given by its dimensions with the legs and torso they make (the frames, masses,
    inertias and shapes :mod:`hexnewton.robot.hexapod` builds from them); a robot given frame by frame as it is."""
    if explicit(cfg):
        return cfg
    from dataclasses import replace

    r, fr = cfg.leg_radius, cfg.foot_radius
    legs = []
    for leg in range(6):
        links = leg_links(cfg)
        inertia = [rod_inertia(mass, length, r, axis) + (0.0, 0.0, 0.0) for _, mass, length, _, axis in links]
        tibia_half = max((cfg.tibia_length - fr) / 2 - r, 1e-3)
        femur = ShapeConfig("capsule", (r, cfg.femur_length / 2 - r), (cfg.femur_length / 2, 0.0, 0.0), Z_TO_X)
        shapes = ((), (femur,),
                  (ShapeConfig("capsule", (r, tibia_half), (0.0, 0.0, -(cfg.tibia_length - fr) / 2)),
                   ShapeConfig("sphere", (fr,), (0.0, 0.0, -cfg.tibia_length))))  # fmt: skip
        at = (hip_mount(cfg, leg), (cfg.hip_length, 0.0, 0.0), (cfg.femur_length, 0.0, 0.0))
        yaw = leg_yaw(cfg, leg)
        quats = ((0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)), frames.IDENTITY, frames.IDENTITY)
        axes = (hip_axis(leg), PITCH_AXIS, PITCH_AXIS)
        limits = (cfg.hip_limit, cfg.knee_limit, cfg.ankle_limit)
        joints = tuple(JointConfig(JOINT_NAMES[3 * leg + k], at[k], quats[k], axes[k], limits[k], 1.0,
                                   LinkConfig(links[k][1], links[k][3], inertia[k], shapes[k]))
                       for k in range(3))  # fmt: skip
        legs.append(LegConfig(joints, (0.0, 0.0, -cfg.tibia_length)))
    m, (sx, sy, sz) = torso_mass(cfg), cfg.torso_size
    torso = LinkConfig(m, (0.0, 0.0, 0.0), box_inertia(m, sx, sy, sz) + (0.0, 0.0, 0.0),
                       (ShapeConfig("box", (sx / 2, sy / 2, sz / 2)),))
    return replace(cfg, legs=tuple(legs), torso=torso)


#: the paper's robot (``RobotConfig()``), the measure of another robot's scales
_PAPER = RobotConfig()


def headroom(cfg: RobotConfig) -> tuple[float, float, float]:
    """How far the CPG's amplitudes may take each joint from the standing pose [rad]: the hip to its nearer limit
    (A1 swings both ways), the knee up to its upper limit (A2 lifts), the ankle down to its lower (A3 tucks)."""
    (lo_h, lo_k, lo_a), (hi_h, hi_k, hi_a) = leg_bounds(cfg)
    hip, knee, ankle = cfg.stand_pose
    return min(hip - lo_h, hi_h - hip), hi_k - knee, ankle - lo_a


def amplitude_scale(cfg: RobotConfig) -> tuple[float, float, float]:
    """The CPG amplitudes' scale per joint kind (A1 hip, A2 knee and the body posture, A3 ankle): the robot's
    :func:`headroom` over the paper robot's, at most 1 (a robot whose joints reach further keeps the paper's
    amplitudes; its mechanical limits are no gait). 1 for the paper's robot."""
    return tuple(min(1.0, mine / paper) for mine, paper in zip(headroom(cfg), headroom(_PAPER)))


def height_scale(cfg: RobotConfig) -> float:
    """The robot's standing height over the paper robot's (1 for the paper's): the fall threshold, the height
    rewards and the observed heights scale with it (``TaskConfig.height_scale``)."""
    return stand_height(cfg) / stand_height(_PAPER)


def length_scale(cfg: RobotConfig) -> float:
    """The robot's footprint over the paper robot's (1 for the paper's): the observation's terrain window scales with
    it (``TaskConfig.length_scale``)."""
    return footprint(cfg) / footprint(_PAPER)
