"""The hexapod and the paper's terrains as a C MuJoCo model (MJCF), written from the project's own descriptions.

The robot comes from :class:`~hexnewton.config.RobotConfig` through :mod:`hexnewton.robot.geometry`, the same functions
the Newton articulation is built from (:func:`hexnewton.robot.hexapod.build_hexapod`), not converted from Newton's
model: a free torso box and per leg (R1, R2, R3, L1, L2, L3) the bodies coxa -> femur -> tibia on hinge joints hip ->
knee -> ankle with the Newton robot's frames, axes, masses, inertias, limits and armature; collision capsules on femur
and tibia, a foot sphere, the torso box (no self-collision). A robot given frame by frame (a robot file's,
``RobotConfig.legs``) is written from its frames the same way (:func:`frames_robot_xml`): its links' masses, full
inertias and collision shapes, its joints in hexnewton's sense and names, so that the sensors read as in Newton.
Each joint has a MuJoCo position actuator with Newton's PD drive: kp = ``joint_ke``, kv = ``joint_kd``, force clamped
to ``effort_limit``. Sensors per robot (``SENSORS_PER_ROBOT`` values): the torso's orientation (``framequat`` at an IMU
site on the torso origin), 18 ``jointpos`` / 18 ``jointvel`` encoders and the IMU's ``gyro`` (the torso's angular
velocity in its own frame).

The terrain comes from the height grid (:func:`hexnewton.terrain.heightmap.build_height_grid`): every strip of constant
height across the patch (run-ups, stair treads, landings) is one box (:func:`hexnewton.terrain.parts.split_strips`),
every rugged block is one box, all down to a common bottom; flat ground is a plane. Boxes keep the risers vertical,
where a MuJoCo heightfield would interpolate them into ramps. A heightfield copy of the grid (its vertices at the cell
centres, so a vertical ray through a cell centre hits that cell's height) takes the height scanner's ray casts
(``hexnewton.apps.sim2sim``); it does not collide.

Several robots can share one model (one terrain, as the evaluation's robots share one): robots touch the terrain
only (``contype`` 1 / ``conaffinity`` 0 on the robot, 0 / 1 on the terrain), never each other. Plain Python and NumPy
until :func:`build_model` compiles the text with ``mujoco``. :class:`Layout` says where each robot's coordinates,
servos and sensors are, in this model and in a robot's own MJCF file put on the terrain
(:mod:`hexnewton.deploy.robot_mjcf`).
"""

from __future__ import annotations

import math

import numpy as np

from hexnewton.config import LEG_NAMES, RobotConfig
from hexnewton.robot.geometry import (
    PITCH_AXIS,
    box_inertia,
    explicit,
    hip_axis,
    hip_mount,
    leg_bounds,
    leg_links,
    leg_yaw,
    rod_inertia,
    torso_mass,
    validate,
)
from hexnewton.terrain.heightmap import HeightGrid
from hexnewton.terrain.parts import split_strips

#: geom group of the scanner's heightfield (hidden in the viewer's default groups 0-2)
SCANNER_GROUP = 5
_BASE_DEPTH = 0.1  # the terrain boxes reach this far below the lowest cell [m]
_ROBOT = 'contype="1" conaffinity="0"'
#: sensor values per robot, in :func:`robot_io_xml`'s order: quaternion (4), joint positions (18), joint velocities
#: (18), gyro (3)
SENSORS_PER_ROBOT = 4 + 18 + 18 + 3
_TERRAIN = 'contype="0" conaffinity="1"'


def _v(values) -> str:
    return " ".join(f"{float(x):.9g}" for x in values)


def _yaw_quat(yaw: float) -> tuple[float, float, float, float]:
    """MuJoCo's (w, x, y, z) of a rotation by ``yaw`` about z."""
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def leg_xml(cfg: RobotConfig, leg: int, prefix: str) -> str:
    """One leg's three bodies, hinge joints and collision geoms (MJCF text, body frames at the joints as in Newton)."""
    name = f"{prefix}{LEG_NAMES[leg]}"
    lower, upper = leg_bounds(cfg)
    r, fr = cfg.leg_radius, cfg.foot_radius
    joint_at = (hip_mount(cfg, leg), (cfg.hip_length, 0.0, 0.0), (cfg.femur_length, 0.0, 0.0))
    axes = (hip_axis(leg), PITCH_AXIS, PITCH_AXIS)
    tibia_mid, tibia_half = -(cfg.tibia_length - fr) / 2, max((cfg.tibia_length - fr) / 2 - r, 1e-3)
    geoms = (
        "",
        f'<geom name="{name}_femur" type="capsule" size="{r:.9g}" fromto="{r:.9g} 0 0 {cfg.femur_length - r:.9g} 0 0" '
        f'{_ROBOT}/>',
        f'<geom name="{name}_shin" type="capsule" size="{r:.9g}" fromto="0 0 {tibia_mid + tibia_half:.9g} 0 0 '
        f'{tibia_mid - tibia_half:.9g}" {_ROBOT}/><geom name="{name}_foot" type="sphere" size="{fr:.9g}" '
        f'pos="0 0 {-cfg.tibia_length:.9g}" {_ROBOT}/>',
    )
    kinds = ("hip", "knee", "ankle")
    out, close = [], []
    for k, (link, mass, length, com, axis_i) in enumerate(leg_links(cfg)):
        quat = f' quat="{_v(_yaw_quat(leg_yaw(cfg, leg)))}"' if k == 0 else ""
        out.append(
            f'<body name="{name}_{link}" pos="{_v(joint_at[k])}"{quat}>'
            f'<joint name="{name}_{kinds[k]}" type="hinge" axis="{_v(axes[k])}" '
            f'range="{lower[k]:.12g} {upper[k]:.12g}" armature="{cfg.armature:.9g}"/>'
            f'<inertial pos="{_v(com)}" mass="{mass:.9g}" diaginertia="{_v(rod_inertia(mass, length, r, axis_i))}"/>'
            + geoms[k])  # fmt: skip
        close.append("</body>")
    return "".join(out) + "".join(close)


def _quat_wxyz(q) -> tuple[float, float, float, float]:
    """MuJoCo's (w, x, y, z) of a quaternion (x, y, z, w)."""
    return (q[3], q[0], q[1], q[2])


def _link_xml(link, name: str, foot=None) -> str:
    """A link's inertial (full inertia) and collision geoms; the sphere centred on ``foot`` named ``<name>_foot``."""
    out = [f'<inertial pos="{_v(link.com)}" mass="{link.mass:.9g}" fullinertia="{_v(link.inertia)}"/>']
    for k, s in enumerate(link.shapes):
        is_foot = foot is not None and s.kind == "sphere" and max(abs(a - b) for a, b in zip(s.pos, foot)) < 1e-9
        out.append(f'<geom name="{name}_{"foot" if is_foot else f"{s.kind}{k}"}" type="{s.kind}" '
                   f'size="{_v(s.size)}" pos="{_v(s.pos)}" quat="{_v(_quat_wxyz(s.quat))}" {_ROBOT}/>')
    return "".join(out)


def frames_robot_xml(cfg: RobotConfig, prefix: str = "", pos=(0.0, 0.0, 0.15), yaw: float = 0.0) -> str:
    """A robot given frame by frame as :func:`robot_xml` writes one: the torso on a free joint, per leg its three links
    on hinge joints named ``<prefix><leg>_<hip|knee|ankle>`` with hexnewton's axes and limits."""
    kinds, links = ("hip", "knee", "ankle"), ("coxa", "femur", "tibia")
    legs = []
    for leg, name in zip(cfg.legs, LEG_NAMES):
        out = []
        for k, j in enumerate(leg.joints):
            out.append(f'<body name="{prefix}{name}_{links[k]}" pos="{_v(j.pos)}" quat="{_v(_quat_wxyz(j.quat))}">'
                       f'<joint name="{prefix}{name}_{kinds[k]}" type="hinge" axis="{_v(j.axis)}" '
                       f'range="{j.limit[0]:.12g} {j.limit[1]:.12g}" armature="{cfg.armature:.9g}"/>'
                       + _link_xml(j.link, f"{prefix}{name}_{links[k]}", leg.foot if k == 2 else None))  # fmt: skip
        legs.append("".join(out) + "</body>" * 3)
    return (f'<body name="{prefix}torso" pos="{_v(pos)}" quat="{_v(_yaw_quat(yaw))}">'
            f'<freejoint name="{prefix}base"/>{_link_xml(cfg.torso, f"{prefix}torso")}'
            f'<site name="{prefix}imu"/>{"".join(legs)}</body>')  # fmt: skip


def robot_xml(cfg: RobotConfig, prefix: str = "", pos=(0.0, 0.0, 0.15), yaw: float = 0.0) -> str:
    """One hexapod (MJCF ``<body>`` text): torso with a free joint at ``pos`` turned by ``yaw``, then the six legs.
    Names start with ``prefix`` (``r0_torso``, ``r0_R1_hip``, ...)."""
    validate(cfg)
    if explicit(cfg):
        return frames_robot_xml(cfg, prefix, pos, yaw)
    m = torso_mass(cfg)
    sx, sy, sz = cfg.torso_size
    legs = "".join(leg_xml(cfg, leg, prefix) for leg in range(len(LEG_NAMES)))
    return (f'<body name="{prefix}torso" pos="{_v(pos)}" quat="{_v(_yaw_quat(yaw))}">'
            f'<freejoint name="{prefix}base"/>'
            f'<inertial pos="0 0 0" mass="{m:.9g}" diaginertia="{_v(box_inertia(m, sx, sy, sz))}"/>'
            f'<geom name="{prefix}torso" type="box" size="{_v((sx / 2, sy / 2, sz / 2))}" {_ROBOT} '
            f'rgba=".35 .45 .6 1"/>'
            f'<site name="{prefix}imu"/>{legs}</body>')  # fmt: skip


def robot_io_xml(cfg: RobotConfig, prefix: str = "") -> tuple[str, str]:
    """(actuators, sensors) of one robot: 18 position servos (kp = joint_ke, kv = joint_kd, |force| <= effort_limit),
    then the IMU quaternion, 18 joint encoders, 18 joint velocities and the IMU's gyro, in that order."""
    joints = [f"{prefix}{leg}_{kind}" for leg in LEG_NAMES for kind in ("hip", "knee", "ankle")]
    e = cfg.effort_limit
    act = "".join(f'<position name="{j}" joint="{j}" kp="{cfg.joint_ke:.9g}" kv="{cfg.joint_kd:.9g}" '
                  f'forcerange="{-e:.9g} {e:.9g}"/>' for j in joints)  # fmt: skip
    sens = (f'<framequat name="{prefix}imu" objtype="site" objname="{prefix}imu"/>'
            + "".join(f'<jointpos name="{j}_pos" joint="{j}"/>' for j in joints)
            + "".join(f'<jointvel name="{j}_vel" joint="{j}"/>' for j in joints)
            + f'<gyro name="{prefix}gyro" site="{prefix}imu"/>')  # fmt: skip
    return act, sens


def _column_boxes(h: np.ndarray) -> list[tuple[int, int, int, int]]:
    """Boxes (i0, i1, j0, j1) of constant height covering ``h`` (ni, nj): runs of equal cells along y, merged over
    consecutive identical columns (a 2 cm block of 1 cm cells is one box)."""
    boxes, i, ni = [], 0, h.shape[0]
    while i < ni:
        k = i + 1
        while k < ni and np.array_equal(h[k], h[i]):
            k += 1
        cuts = np.flatnonzero(np.diff(h[i]) != 0) + 1
        edges = [0, *cuts.tolist(), h.shape[1]]
        boxes += [(i, k, a, b) for a, b in zip(edges[:-1], edges[1:])]
        i = k
    return boxes


def terrain_boxes(grid: HeightGrid, base_depth: float = _BASE_DEPTH) -> np.ndarray:
    """The terrain as boxes (M, 6): centre x, y, z and half sizes, each of one height, all down to the common
    bottom ``min(height) - base_depth``; their union has the grid's surface."""
    h = np.asarray(grid.heights, np.float64)
    zb = float(h.min()) - base_depth
    out = []
    for p in split_strips(grid):
        cells = [(p.i0, p.i1, p.j0, p.j1)] if p.box else \
            [(p.i0 + a, p.i0 + b, p.j0 + c, p.j0 + d) for a, b, c, d in _column_boxes(h[p.i0:p.i1, p.j0:p.j1])]
        for i0, i1, j0, j1 in cells:
            top = h[i0, j0]
            xa, xb = grid.x0 + i0 * grid.res, grid.x0 + i1 * grid.res
            ya, yb = grid.y0 + j0 * grid.res, grid.y0 + j1 * grid.res
            out.append((0.5 * (xa + xb), 0.5 * (ya + yb), 0.5 * (top + zb), 0.5 * (xb - xa), 0.5 * (yb - ya),
                        0.5 * (top - zb)))  # fmt: skip
    return np.asarray(out, np.float64).reshape(-1, 6)


def terrain_xml(grid: HeightGrid | None) -> tuple[str, str]:
    """(asset, worldbody) MJCF text of the terrain: a plane for flat ground (``grid`` None or all zero), else the
    boxes of :func:`terrain_boxes`, plus the scanner's heightfield (geom ``scanner``, group ``SCANNER_GROUP``)."""
    h = None if grid is None else np.asarray(grid.heights, np.float64)
    if h is None or not h.any():
        asset, scanner = ("", "") if grid is None else _scanner_xml(grid, h)
        return asset, f'<geom name="ground" type="plane" size="0 0 1" {_TERRAIN} rgba=".55 .55 .5 1"/>' + scanner
    boxes = terrain_boxes(grid)
    top = boxes[:, 2] + boxes[:, 5]
    shade = 0.45 + 0.35 * (top - top.min()) / max(float(np.ptp(top)), 1e-9)
    geoms = [f'<geom type="box" pos="{_v(b[:3])}" size="{_v(b[3:])}" {_TERRAIN} rgba="{s:.3f} {s:.3f} .45 1"/>'
             for b, s in zip(boxes, shade)]  # fmt: skip
    body = "".join(geoms)
    asset, scanner = _scanner_xml(grid, h)
    return asset, body + scanner


def _scanner_xml(grid: HeightGrid, h: np.ndarray) -> tuple[str, str]:
    """The non-colliding heightfield of the grid, one vertex at each cell centre (elevations set after compiling:
    :func:`set_scanner_heights`)."""
    rx, ry = 0.5 * (grid.nx - 1) * grid.res, 0.5 * (grid.ny - 1) * grid.res
    lo, span = float(h.min()), float(np.ptp(h)) or 1.0
    cx, cy = grid.x0 + 0.5 * grid.nx * grid.res, grid.y0 + 0.5 * grid.ny * grid.res
    asset = f'<hfield name="scanner" nrow="{grid.ny}" ncol="{grid.nx}" size="{_v((rx, ry, span, _BASE_DEPTH))}"/>'
    geom = (f'<geom name="scanner" type="hfield" hfield="scanner" pos="{_v((cx, cy, lo))}" contype="0" '
            f'conaffinity="0" group="{SCANNER_GROUP}" rgba="0 0 0 0"/>')  # fmt: skip
    return asset, geom


def set_scanner_heights(model, grid: HeightGrid) -> None:
    """Write the grid's heights into the compiled model's scanner heightfield (rows along y, columns along x)."""
    h = np.asarray(grid.heights, np.float64)
    span = float(np.ptp(h)) or 1.0
    model.hfield_data[:] = ((h - h.min()) / span).T.ravel()


def scene_xml(cfg: RobotConfig, grid: HeightGrid | None, starts, timestep: float) -> str:
    """The whole scene: MuJoCo's default solver and contact settings (Newton solver, pyramidal cones) at ``timestep``
    with the implicit-in-velocity integrator (``implicitfast``: the servos' kv term is integrated implicitly, as in
    training), the terrain, and one robot per start ``(x, y, z, yaw)`` named ``r0_``, ``r1_``, ..."""
    asset, ground = terrain_xml(grid)
    robots, acts, sens = [], [], []
    for k, (x, y, z, yaw) in enumerate(starts):
        robots.append(robot_xml(cfg, f"r{k}_", (x, y, z), yaw))
        a, s = robot_io_xml(cfg, f"r{k}_")
        acts.append(a)
        sens.append(s)
    return (f'<mujoco model="hexnewton"><compiler angle="radian" autolimits="true"/>'
            f'<option timestep="{timestep:.9g}" integrator="implicitfast"/>'
            f'<size memory="{64 + 8 * len(robots)}M"/>'
            f'<visual><global offwidth="1280" offheight="720"/><quality shadowsize="4096"/></visual>'
            f'<default><geom friction="{cfg.friction:.9g} 0.005 0.0001"/></default>'
            f'<asset>{asset}</asset><worldbody><light pos="0 0 4" dir="0 0 -1" directional="true"/>{ground}'
            f'{"".join(robots)}</worldbody><actuator>{"".join(acts)}</actuator>'
            f'<sensor>{"".join(sens)}</sensor></mujoco>')  # fmt: skip


def build_model(cfg: RobotConfig, grid: HeightGrid | None, starts, timestep: float):
    """Compile :func:`scene_xml` (``mujoco.MjModel``), the scanner's heightfield filled in."""
    import mujoco

    model = mujoco.MjModel.from_xml_string(scene_xml(cfg, grid, starts, timestep))
    if grid is not None:
        set_scanner_heights(model, grid)
    return model


class Layout:
    """Where a model of N robots keeps each robot, in hexnewton's terms: a block of ``nq`` position and ``nv``
    velocity coordinates per robot, its free joint first; the 18 leg joints at ``joint_q`` / ``joint_v`` within the
    block, in hexnewton's order, their senses ``signs`` and the coordinates of their zero angles ``zero`` (hexnewton's
    angle = sign x (the model's - zero)); the servos ``actuators`` (N, 18), a servo's control = its ``gear`` (N, 18) x
    the model's angle; the 43 sensor values per robot ``sensors`` (N, 43) in :func:`robot_io_xml`'s order (the
    joints' in the model's sense); the torso bodies ``torsos`` (N,). The generated model's (:meth:`generated`) is
    the identity: 25 / 24 coordinates per robot, hexnewton's senses, servos and sensors in order."""

    def __init__(self, nq: int, nv: int, joint_q, joint_v, signs, zero, actuators, gear, sensors, torsos):
        self.nq, self.nv = int(nq), int(nv)
        self.joint_q, self.joint_v = np.asarray(joint_q, np.int64), np.asarray(joint_v, np.int64)
        self.signs, self.zero = np.asarray(signs, np.float64), np.asarray(zero, np.float64)
        self.actuators, self.gear = np.asarray(actuators, np.int64), np.asarray(gear, np.float64)
        self.sensors, self.torsos = np.asarray(sensors, np.int64), np.asarray(torsos, np.int64)
        self.n = len(self.torsos)

    @classmethod
    def identity(cls, n: int, torsos=None) -> "Layout":
        """``n`` robots as :func:`build_model` lays them out (``torsos``: their bodies, default the first of each
        robot's 19)."""
        torsos = 1 + 19 * np.arange(n) if torsos is None else torsos
        return cls(25, 24, np.arange(7, 25), np.arange(6, 24), np.ones(18), np.zeros(18),
                   np.arange(18 * n).reshape(n, 18), np.ones((n, 18)),
                   np.arange(SENSORS_PER_ROBOT * n).reshape(n, SENSORS_PER_ROBOT), torsos)  # fmt: skip

    @classmethod
    def generated(cls, model, n: int) -> "Layout":
        """The layout of :func:`build_model`'s ``n`` robots (checked against the model)."""
        import mujoco

        if model.nq != 25 * n or model.nu != 18 * n or model.nsensordata != SENSORS_PER_ROBOT * n:
            raise RuntimeError("unexpected MuJoCo model layout")
        return cls.identity(n, [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"r{k}_torso") for k in range(n)])

    def blocks(self, d) -> tuple[np.ndarray, np.ndarray]:
        """The robots' position and velocity coordinates (N, nq) and (N, nv), views of ``d``'s."""
        return d.qpos.reshape(self.n, self.nq), d.qvel.reshape(self.n, self.nv)

    def qpos(self, d) -> np.ndarray:
        """The robots' coordinates in hexnewton's terms (N, 25): the free joint's (x, y, z, MuJoCo's w, x, y, z
        quaternion), then the 18 joint angles."""
        q, _ = self.blocks(d)
        return np.concatenate([q[:, :7], self.signs * (q[:, self.joint_q] - self.zero)], axis=1)

    def qvel(self, d) -> np.ndarray:
        """The robots' velocities in hexnewton's terms (N, 24): the free joint's 6, then the 18 joints'."""
        _, v = self.blocks(d)
        return np.concatenate([v[:, :6], self.signs * v[:, self.joint_v]], axis=1)

    def place(self, d, base: np.ndarray, joints: np.ndarray) -> None:
        """Set the free joints' coordinates (N, 7) and the joint angles (N, 18, hexnewton's)."""
        q, _ = self.blocks(d)
        q[:, :7] = base
        q[:, self.joint_q] = self.zero + self.signs * np.asarray(joints)

    def set_targets(self, d, targets: np.ndarray) -> None:
        """The servos' controls for joint targets (N, 18) in hexnewton's sense."""
        d.ctrl[self.actuators] = self.gear * (self.zero + self.signs * np.asarray(targets).reshape(self.n, 18))

    def readings(self, d) -> dict:
        """The sensors' values: joint encoders and velocities (N, 18) in hexnewton's sense, the IMU quaternion (N, 4)
        x y z w and gyro (N, 3)."""
        s = d.sensordata[self.sensors]
        return {"quat": s[:, [1, 2, 3, 0]], "joint_pos": self.signs * (s[:, 4:22] - self.zero),
                "joint_vel": self.signs * s[:, 22:40], "gyro": s[:, 40:43]}  # fmt: skip
