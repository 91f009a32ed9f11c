"""The hexapod's geometry and mass properties from :class:`~hexnewton.config.RobotConfig`, in plain Python: what the
Newton articulation (:mod:`hexnewton.robot.hexapod`) and the MuJoCo model (:mod:`hexnewton.deploy.mjcf`) are both built from.

Each leg has its own "leg frame" at its hip mount: x' points outward along the leg's neutral direction, z' = world up,
y' = z' x x'. In that frame the hip axis is +z' (right legs) or -z' (left legs), so that a positive hip angle moves the
foot toward +x on both sides; the knee and ankle axes are -y', so a positive angle rotates x' toward +z' (lifting) and
-z' toward +x' (foot outward).
"""

from __future__ import annotations

import math

from hexnewton.config import RobotConfig

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


def torso_mass(cfg: RobotConfig) -> float:
    return cfg.total_mass - 6.0 * (cfg.coxa_mass + cfg.femur_mass + cfg.tibia_mass)


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
    _, knee, ankle = cfg.stand_pose
    # femur raised by `knee`, tibia at angle (knee + ankle) from vertical in the leg plane
    return -cfg.femur_length * math.sin(knee) + cfg.tibia_length * math.cos(knee + ankle) + cfg.foot_radius


def footprint(cfg: RobotConfig) -> float:
    """Half side [m] of the square the robot spawns above: half the torso's diagonal plus coxa and femur."""
    return 0.5 * math.hypot(*cfg.torso_size[:2]) + cfg.hip_length + cfg.femur_length


def spawn_clearance(cfg: RobotConfig) -> float:
    """Torso height [m] above the highest terrain under the footprint at a (re)spawn."""
    return max(cfg.spawn_height, stand_height(cfg))


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
