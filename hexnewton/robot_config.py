"""The robot as data: :class:`RobotConfig`, one hexapod's description, a part of the config tree
(``HexConfig.robot``, ``hexnewton.config`` names it too), so that every checkpoint and bundle records the robot whole.

A robot is six legs of three revolute joints each, on one torso. Two ways to give one:

- **By its dimensions** (``legs`` empty): the paper's kind of hexapod, link lengths, link masses, joint limits per
  kind, torso box, hip mounts and splay, from which ``hexnewton.robot`` builds every frame. The defaults are the
  paper's robot (Huang et al. 2025, §3.5); ``hexnewton.robot.registry`` names others (``paper``, ``mx_phoenix``).
- **Frame by frame** (``legs`` and ``torso`` given, as ``hexnewton.robot.loader`` reads them from a URDF or MJCF
  file): per leg in ``LEG_NAMES`` order its hip, knee and ankle (:class:`JointConfig`: where the joint sits in its
  parent link, its axis, limits, and the link it moves, :class:`LinkConfig`), and its foot. The dimension fields then
  summarise the file (link lengths, masses), and the servo, contact and spawn fields still apply.

Conventions (everywhere in hexnewton, whatever the file's): joint order R1, R2, R3, L1, L2, L3 (front to back), each
hip, knee, ankle; hip > 0 swings the foot forward (+x), knee > 0 lifts the femur, ankle < 0 tucks the foot toward the
body. A loaded joint whose positive turn goes the other way is stored with its axis and limits turned round and
``sign`` -1 (hexnewton's angle = sign x the file's).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

LEG_NAMES = ("R1", "R2", "R3", "L1", "L2", "L3")
JOINT_KINDS = ("hip", "knee", "ankle")
JOINT_NAMES = tuple(f"{leg}_{kind}" for leg in LEG_NAMES for kind in JOINT_KINDS)
#: the collision shapes a link may have (``ShapeConfig.kind``)
SHAPE_KINDS = ("box", "capsule", "cylinder", "sphere")
#: fields of the description that are no command-line flag (``--robot NAME|FILE`` gives them)
NO_FLAG = {"flag": False}


@dataclass
class ShapeConfig:
    """One collision shape in its link's frame: ``box`` (``size``: half extents x, y, z), ``capsule`` and ``cylinder``
    (radius, half length along the shape's z), ``sphere`` (radius); ``quat`` (x, y, z, w)."""

    kind: str = "sphere"
    size: tuple[float, ...] = (0.01,)
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)


@dataclass
class LinkConfig:
    """A rigid link: its mass [kg], centre of mass [m] and inertia about the centre of mass (ixx, iyy, izz, ixy, ixz,
    iyz) [kg m^2], both in the link's frame, and its collision shapes."""

    mass: float = 0.0
    com: tuple[float, float, float] = (0.0, 0.0, 0.0)
    inertia: tuple[float, float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    shapes: tuple[ShapeConfig, ...] = ()


@dataclass
class JointConfig:
    """One revolute joint and the link it moves. The link's frame is the joint's: at ``pos`` in the parent link's
    frame, turned by ``quat`` (x, y, z, w); ``axis`` in that frame with hexnewton's sign (module docstring); ``limit``
    (lower, upper) [rad] in hexnewton's sign; ``sign`` the file's sense (hexnewton's angle = sign x the file's);
    ``name`` the file's name of the joint (the ROS node's)."""

    name: str = ""
    pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    quat: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    limit: tuple[float, float] = (-1.0, 1.0)
    sign: float = 1.0
    link: LinkConfig = field(default_factory=LinkConfig)


@dataclass
class LegConfig:
    """One leg: its ``joints`` hip, knee, ankle (each on the link before it, the hip on the torso) and the centre of
    its foot sphere in the last link's frame [m]."""

    joints: tuple[JointConfig, ...] = ()
    foot: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class RobotConfig:
    """One hexapod: by default the paper's (§3.5) plus the physical details the paper leaves open (module docstring
    for the two ways to describe one)."""

    # the robot's name: a named robot's (hexnewton.robot.registry), or a file's stem
    name: str = field(default="paper", metadata=NO_FLAG)
    # where it was read from ("" for a named robot): the URDF or MJCF file (a checkpoint replays without it)
    source: str = field(default="", metadata=NO_FLAG)
    # §3.5: link lengths [m]
    hip_length: float = 0.050
    femur_length: float = 0.080
    tibia_length: float = 0.130
    # §3.5: total mass [kg]
    total_mass: float = 2.5
    # ours: mass split. Servo-driven legs: 0.15 kg per leg (coxa servo 0.05, femur 0.05, tibia 0.05),
    # the remaining 1.6 kg in the torso (battery, controller, six servos' share).
    coxa_mass: float = 0.05
    femur_mass: float = 0.05
    tibia_mass: float = 0.05
    # §3.5: joint limits [rad]
    hip_limit: tuple[float, float] = (-math.pi / 6, math.pi / 6)
    knee_limit: tuple[float, float] = (0.0, math.pi / 2)
    ankle_limit: tuple[float, float] = (-math.pi / 3, 0.0)
    # ours: torso box (x length, y width, z height) [m], sized like common 2.5 kg servo hexapods
    torso_size: tuple[float, float, float] = (0.26, 0.14, 0.05)
    # ours: hip mounts in the body frame, (x, |y|) per leg row front/middle/rear [m]
    hip_mounts: tuple[tuple[float, float], ...] = ((0.11, 0.07), (0.0, 0.08), (-0.11, 0.07))
    # ours: outward leg direction, degrees from lateral toward +x for the front row (front legs splay
    # forward, rear legs backward)
    mount_splay_deg: tuple[float, float, float] = (30.0, 0.0, -30.0)
    # ours: collision radii [m]
    leg_radius: float = 0.010
    foot_radius: float = 0.012
    # ours: neutral standing pose (hip, knee, ankle) [rad]: femur slightly raised, tibia vertical, so
    # stance never rests on the knee's lower limit and the torso stands ~0.13 m high (the paper's
    # height reward pays above 0.12 m, Table 1).
    stand_pose: tuple[float, float, float] = (0.0, 0.15, -0.15)
    # ours: PD position drive. A tripod stance carries ~8 N per foot at ~0.09 m lever: ~0.75 N m at the
    # knee; kp = 40 N m/rad keeps the sag under 0.02 rad. Effort limit like a 35 kg cm hobby servo.
    joint_ke: float = 40.0
    joint_kd: float = 0.8
    effort_limit: float = 3.5
    # ours: reflected rotor inertia of a geared servo [kg m^2]; it also keeps the light tibia stable
    armature: float = 0.005
    # ours: joint-limit penalty stiffness/damping
    limit_ke: float = 1.0e3
    limit_kd: float = 10.0
    # ours: contact material
    friction: float = 0.9
    # initial torso height above the terrain under the origin [m]; the robot drops onto its feet
    spawn_height: float = 0.15
    # frame by frame (a robot file's, hexnewton.robot.loader): the six legs in LEG_NAMES order and the torso; empty /
    # None: the legs and torso built from the dimensions above
    legs: tuple[LegConfig, ...] = field(default=(), metadata=NO_FLAG)
    torso: LinkConfig | None = field(default=None, metadata=NO_FLAG)
