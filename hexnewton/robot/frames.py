"""A robot described frame by frame (``RobotConfig.legs``): its legs' forward kinematics in the torso's frame and what
follows from it, in plain Python (quaternions x, y, z, w, as Warp and Newton write them).

:mod:`hexnewton.robot.geometry` answers the same questions for any robot, through these functions where the robot has
frames and from its dimensions where it has none."""

from __future__ import annotations

import math

from hexnewton.robot_config import SHAPE_KINDS, LegConfig, RobotConfig

Vec = tuple[float, float, float]
Quat = tuple[float, float, float, float]
IDENTITY: Quat = (0.0, 0.0, 0.0, 1.0)


def qmul(a: Quat, b: Quat) -> Quat:
    """The rotation ``a`` after ``b`` (Hamilton product, x, y, z, w)."""
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)  # fmt: skip


def qrot(q: Quat, v: Vec) -> Vec:
    """``v`` turned by the unit quaternion ``q``."""
    x, y, z, w = q
    tx, ty, tz = 2.0 * (y * v[2] - z * v[1]), 2.0 * (z * v[0] - x * v[2]), 2.0 * (x * v[1] - y * v[0])
    return (v[0] + w * tx + y * tz - z * ty, v[1] + w * ty + z * tx - x * tz, v[2] + w * tz + x * ty - y * tx)


def qaxis(axis: Vec, angle: float) -> Quat:
    """The turn by ``angle`` about the unit vector ``axis``."""
    s = math.sin(0.5 * angle)
    return (axis[0] * s, axis[1] * s, axis[2] * s, math.cos(0.5 * angle))


def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def norm(a: Vec) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def leg_poses(leg: LegConfig, q=(0.0, 0.0, 0.0)) -> tuple[list[tuple[Vec, Quat]], Vec]:
    """The leg's link frames (position, quaternion) in the torso's frame at joint angles ``q`` (hip, knee, ankle,
    hexnewton's sign), and its foot's centre."""
    pos, rot, out = (0.0, 0.0, 0.0), IDENTITY, []
    for joint, angle in zip(leg.joints, q):
        pos = add(pos, qrot(rot, joint.pos))
        rot = qmul(qmul(rot, joint.quat), qaxis(joint.axis, angle))
        out.append((pos, rot))
    return out, add(pos, qrot(rot, leg.foot))


def stand_height(cfg: RobotConfig) -> float:
    """Torso-origin height above flat ground in the standing pose [m]: down to the lowest foot sphere's bottom."""
    return max(-leg_poses(leg, cfg.stand_pose)[1][2] for leg in cfg.legs) + cfg.foot_radius


def footprint(cfg: RobotConfig) -> float:
    """Half side [m] of the square the robot spawns above: the farthest ankle joint (standing) or torso shape corner
    from the torso's centre, horizontally."""
    reach = [math.hypot(*leg_poses(leg, cfg.stand_pose)[0][2][0][:2]) for leg in cfg.legs]
    for shape in cfg.torso.shapes if cfg.torso is not None else ():
        r = max(shape.size[:2]) if shape.kind == "box" else shape.size[0]
        reach.append(math.hypot(abs(shape.pos[0]) + r, abs(shape.pos[1]) + r))
    return max(reach)


def leg_length(cfg: RobotConfig) -> float:
    """The first leg's length [m]: hip to knee to ankle to the foot's centre."""
    leg = cfg.legs[0]
    return norm(leg.joints[1].pos) + norm(leg.joints[2].pos) + norm(leg.foot)


def total_mass(cfg: RobotConfig) -> float:
    return (cfg.torso.mass if cfg.torso is not None else 0.0) + sum(j.link.mass for leg in cfg.legs
                                                                     for j in leg.joints)


def validate(cfg: RobotConfig) -> None:
    """ValueError with one clear line for a frame-by-frame robot that cannot stand."""
    if len(cfg.legs) != 6 or any(len(leg.joints) != 3 for leg in cfg.legs):
        raise ValueError(f"robot {cfg.name}: six legs of three joints needed, got "
                         f"{[len(leg.joints) for leg in cfg.legs]}")
    if cfg.torso is None or not cfg.torso.mass > 0:
        raise ValueError(f"robot {cfg.name}: the torso needs a mass > 0")
    for leg in cfg.legs:
        for j in leg.joints:
            if not (j.link.mass > 0 and j.limit[0] < j.limit[1]):
                raise ValueError(f"robot {cfg.name}: joint {j.name} needs a link mass > 0 and limits LO < HI, got "
                                 f"{j.link.mass} and {j.limit}")
            if abs(norm(j.axis) - 1.0) > 1e-6:
                raise ValueError(f"robot {cfg.name}: joint {j.name}'s axis {j.axis} is not a unit vector")
    shapes = [s for link in [cfg.torso] + [j.link for leg in cfg.legs for j in leg.joints] for s in link.shapes]
    unknown = sorted({s.kind for s in shapes} - set(SHAPE_KINDS))
    if unknown:
        raise ValueError(f"robot {cfg.name}: shape kind {unknown[0]} is none of {', '.join(SHAPE_KINDS)}")
