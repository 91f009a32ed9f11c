"""A hexapod from a robot file, URDF or MJCF: :func:`load_robot` reads it with MuJoCo (``mujoco.MjModel.from_xml_path``
compiles both) into a :class:`~hexnewton.config.RobotConfig` given frame by frame, or says in one line what it could
not find (:class:`~hexnewton.errors.HexnewtonError`).

How the legs are found (docs/robots.md): the torso is the file's root body (its free joint, or none: a URDF's base
link), with every body fixed to it. A leg is a chain of revolute joints that starts on the torso: each body of the
chain turns on one hinge, the next body of the leg is its only child with a joint; bodies without a joint are welded
to the link they hang from (their mass, inertia and shapes join it). Six legs of three joints each are needed, three
on each side of the torso's x axis (the torso's frame: x forward, z up), ordered front to back; ``joints``, 18 names in
hexnewton's order (R1 hip, knee, ankle, R2 ..., L3), names them instead. Along a leg the joints are hip, knee, ankle:
the hip turns about a roughly vertical axis, knee and ankle about roughly parallel horizontal ones. Each joint needs
limits; its sense is turned round where the file's positive angle is not hexnewton's (hip forward, knee up, ankle
with the knee). The foot is the last link's sphere farthest from the ankle, else the far end of its capsule or
cylinder.

The standing pose is an MJCF keyframe's named ``stand`` or ``home`` where the file has one, else: hip 0, the femur
:data:`STAND_FEMUR_RAISE` above level and the tibia vertical, clipped into the limits. Servo gains, effort limits and
armature are the file's (MJCF position actuators, ``armature``; URDF ``<limit effort>``) where it gives them, else the
paper robot's scaled by the robot's weight on the femur (mass x femur length).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import replace

import numpy as np

from hexnewton.errors import HexnewtonError
from hexnewton.robot import frames
from hexnewton.robot_config import JOINT_NAMES, LEG_NAMES, JointConfig, LegConfig, LinkConfig, RobotConfig, ShapeConfig

#: the robot files ``--robot`` reads
EXTENSIONS = (".urdf", ".xml")
#: the femur's rise above level in a computed standing pose [rad], the paper robot's
STAND_FEMUR_RAISE = 0.15
#: |z| of a unit axis that counts as vertical (hip) or horizontal (knee, ankle): within ~45 degrees
VERTICAL = math.sqrt(0.5)


def _fail(path: str, what: str):
    raise HexnewtonError(f"robot file {path}: {what}")


def load_robot(path: str, joints: tuple[str, ...] | None = None) -> RobotConfig:
    """The hexapod of a URDF (``.urdf``) or MJCF (``.xml``) file (module docstring); ``joints``: the 18 leg joints'
    names in hexnewton's order, where the file's tree does not show them."""
    import mujoco

    if not os.path.isfile(path):
        raise HexnewtonError(f"robot file not found: {path} (--robot takes a robot's name or a .urdf / .xml file)")
    if not path.lower().endswith(EXTENSIONS):
        _fail(path, "expected a URDF (.urdf) or MJCF (.xml) file")
    is_urdf = path.lower().endswith(".urdf")
    urdf = _urdf_joints(path) if is_urdf else {}
    try:
        m = mujoco.MjModel.from_xml_string(_urdf_for_mujoco(path)) if is_urdf else mujoco.MjModel.from_xml_path(path)
    except Exception as exc:  # MuJoCo's compiler: a ValueError with its message
        _fail(path, "MuJoCo cannot read it: " + " ".join(str(exc).split())[:300])
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    tree = _Tree(m, d, path)
    chains = tree.named_legs(joints) if joints else tree.legs()
    legs, signs = [], []
    for leg_name, chain in zip(LEG_NAMES, chains):
        leg, leg_signs = tree.leg(leg_name, chain, urdf)
        legs.append(leg)
        signs.append(leg_signs)
    stand = _stand_pose(tree, legs, chains, signs)
    return _summary(path, tree, legs, stand, urdf, chains)


def _urdf_joints(path: str) -> dict[str, dict]:
    """{joint name: {"type", "effort"}} of a URDF file, read as XML (MuJoCo keeps neither a joint's URDF type nor its
    effort limit)."""
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        _fail(path, f"not valid XML ({exc})")
    out = {}
    for j in root.iter("joint"):
        limit = j.find("limit")
        effort = limit.get("effort") if limit is not None else None
        out[j.get("name")] = {"type": j.get("type"), "effort": float(effort) if effort else None}
    return out


def _urdf_for_mujoco(path: str) -> str:
    """A URDF's text as MuJoCo should compile it here: links on fixed joints kept as bodies (``fusestatic`` off: the
    base link stays the torso, not the world), a link's mass its ``<inertial>``'s alone (none: massless, not its shapes'
    volume), visual elements dropped, meshes looked up beside the file (MuJoCo keeps a URDF mesh's file name only) or in
    a ``meshes`` folder beside it or above it."""
    root = ET.parse(path).getroot()
    for link in root.iter("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
    folder = os.path.dirname(os.path.abspath(path))
    meshes = [m.get("filename", "") for m in root.iter("mesh")]
    where = [f for f in (folder, os.path.join(folder, "meshes"), os.path.join(os.path.dirname(folder), "meshes"))
             if all(os.path.isfile(os.path.join(f, os.path.basename(n))) for n in meshes)]  # fmt: skip
    for old in root.findall("mujoco"):
        root.remove(old)
    ext = ET.SubElement(root, "mujoco")
    ET.SubElement(ext, "compiler", fusestatic="false", discardvisual="true", inertiafromgeom="false",
                  meshdir=where[0] if where else folder)
    return ET.tostring(root, encoding="unicode")


class _Tree:
    """The file's kinematic tree at its zero pose (MuJoCo's ``qpos0``): bodies, links (a jointed body and the bodies
    welded to it), the torso, the legs' chains."""

    def __init__(self, m, d, path: str):
        import mujoco

        self.m, self.d, self.path, self.mj = m, d, path, mujoco
        parent = m.body_parentid
        self.owner = [0] * m.nbody  # each body's link: the nearest of itself and its ancestors with a joint
        for b in range(1, m.nbody):
            self.owner[b] = b if m.body_jntnum[b] > 0 or parent[b] == 0 else self.owner[parent[b]]
        roots = {self.owner[m.jnt_bodyid[j]] for j in range(m.njnt)}
        roots = {self._root(b) for b in roots}
        if not roots:
            _fail(path, "no joints: a hexapod's legs turn on 18 revolute joints")
        if len(roots) > 1:
            _fail(path, f"{len(roots)} separate bodies with joints ({self._names(sorted(roots))}): one robot expected")
        self.torso = roots.pop()
        self._check_joints()

    def _root(self, b: int) -> int:
        while self.m.body_parentid[b] != 0:
            b = self.m.body_parentid[b]
        return b

    def name(self, kind, i: int) -> str:
        return self.mj.mj_id2name(self.m, kind, i) or f"#{i}"

    def body(self, b: int) -> str:
        return self.name(self.mj.mjtObj.mjOBJ_BODY, b)

    def joint(self, j: int) -> str:
        return self.name(self.mj.mjtObj.mjOBJ_JOINT, j)

    def _names(self, bodies) -> str:
        return ", ".join(f"'{self.body(b)}'" for b in bodies)

    def _check_joints(self) -> None:
        m, hinge = self.m, self.mj.mjtJoint.mjJNT_HINGE
        for j in range(m.njnt):
            b = m.jnt_bodyid[j]
            if b == self.torso and m.jnt_type[j] == self.mj.mjtJoint.mjJNT_FREE:
                continue
            if m.jnt_type[j] != hinge:
                kind = {0: "free", 1: "ball", 2: "slide"}.get(int(m.jnt_type[j]), "non-revolute")
                _fail(self.path, f"joint '{self.joint(j)}' is a {kind} joint: a leg turns on revolute joints only")
            if m.body_jntnum[b] > 1:
                _fail(self.path, f"body '{self.body(b)}' has {m.body_jntnum[b]} joints: one revolute joint per link")

    def parent_link(self, b: int) -> int:
        """The link a jointed body hangs from."""
        return self.owner[self.m.body_parentid[b]]

    def children(self, link: int) -> list[int]:
        """The jointed bodies hanging from ``link``, in file order."""
        return [b for b in range(1, self.m.nbody) if self.m.body_jntnum[b] > 0 and b != self.torso
                and self.parent_link(b) == link]  # fmt: skip

    def legs(self) -> list[list[int]]:
        """The six legs' joint chains (joint ids hip, knee, ankle) in hexnewton's order, from the tree."""
        chains = []
        for first in self.children(self.torso):
            chain, b = [], first
            while True:
                chain.append(int(self.m.body_jntadr[b]))
                below = self.children(b)
                if len(below) > 1:
                    _fail(self.path, f"the leg from '{self.body(first)}' branches at '{self.body(b)}' "
                                     f"({self._names(below)}): a leg is one chain of joints")
                if not below:
                    break
                b = below[0]
            if len(chain) != 3:
                names = ", ".join(f"'{self.joint(j)}'" for j in chain)
                _fail(self.path, f"the leg from '{self.body(first)}' has {len(chain)} revolute joint"
                                 f"{'s' if len(chain) != 1 else ''} ({names}): each leg needs 3 (hip, knee, ankle)")
            chains.append(chain)
        if len(chains) != 6:
            _fail(self.path, f"found {len(chains)} legs (chains of revolute joints from the torso "
                             f"'{self.body(self.torso)}'): a hexapod has 6 (or name them: --robot_joints)")
        return self._ordered(chains)

    def _ordered(self, chains: list[list[int]]) -> list[list[int]]:
        """The chains as R1, R2, R3 (right, y < 0, front to back), L1, L2, L3, by where their hips sit."""
        at = [self.in_torso(self.d.xanchor[c[0]]) for c in chains]
        right = sorted((k for k in range(6) if at[k][1] < 0), key=lambda k: -at[k][0])
        left = sorted((k for k in range(6) if at[k][1] > 0), key=lambda k: -at[k][0])
        if len(right) != 3 or len(left) != 3:
            _fail(self.path, f"{len(right)} legs on the right (y < 0) and {len(left)} on the left of the torso's x "
                             "axis: three on each side expected (or name them: --robot_joints)")
        return [chains[k] for k in right + left]

    def named_legs(self, names: tuple[str, ...]) -> list[list[int]]:
        """The legs' chains from 18 joint names in hexnewton's order, checked to be chains from the torso."""
        if len(names) != 18:
            _fail(self.path, f"--robot_joints takes the 18 leg joints in hexnewton's order ({', '.join(JOINT_NAMES)}),"
                             f" got {len(names)}")
        ids = []
        for n in names:
            j = self.mj.mj_name2id(self.m, self.mj.mjtObj.mjOBJ_JOINT, n)
            if j < 0:
                _fail(self.path, f"no joint named '{n}' (--robot_joints)")
            ids.append(j)
        chains = [ids[3 * k:3 * k + 3] for k in range(6)]
        for leg, chain in zip(LEG_NAMES, chains):
            before = self.torso
            for j in chain:
                b = self.m.jnt_bodyid[j]
                if self.parent_link(b) != before:
                    _fail(self.path, f"--robot_joints: leg {leg}'s joint '{self.joint(j)}' does not hang from "
                                     f"'{self.body(before)}': a leg's joints are one chain from the torso")
                before = b
        return chains

    # ------------------------------------------------------------------ frames, masses, shapes
    def in_torso(self, p) -> np.ndarray:
        """A world point in the torso's frame."""
        t = self.torso
        return self.d.xmat[t].reshape(3, 3).T @ (np.asarray(p, np.float64) - self.d.xpos[t])

    def frame(self, link: int) -> tuple[np.ndarray, np.ndarray]:
        """A link's frame in the world (position, rotation matrix): a jointed body's at its joint, the torso's its
        body's."""
        rot = self.d.xmat[link].reshape(3, 3).copy()
        pos = self.d.xanchor[self.m.body_jntadr[link]].copy() if link != self.torso else self.d.xpos[link].copy()
        return pos, rot

    def link(self, link: int, welded_into=None) -> LinkConfig:
        """A link's mass, centre of mass, inertia and collision shapes in its frame (its welded bodies' included)."""
        m, d = self.m, self.d
        pos, rot = self.frame(link)
        bodies = [b for b in range(1, m.nbody) if self.owner[b] == link]
        mass = float(sum(m.body_mass[b] for b in bodies))
        if not mass > 0:
            _fail(self.path, f"link '{self.body(link)}' has no mass: every moving link needs its mass and inertia")
        com_w = sum(m.body_mass[b] * d.xipos[b] for b in bodies) / mass
        inertia = np.zeros((3, 3))
        for b in bodies:
            r_i = d.ximat[b].reshape(3, 3)
            off = d.xipos[b] - com_w
            inertia += r_i @ np.diag(m.body_inertia[b]) @ r_i.T + m.body_mass[b] * (off @ off * np.eye(3)
                                                                                    - np.outer(off, off))
        inertia = rot.T @ inertia @ rot
        shapes = tuple(s for b in bodies for g in range(m.ngeom) if m.geom_bodyid[g] == b
                       for s in self._shape(g, pos, rot))  # fmt: skip
        com = rot.T @ (com_w - pos)
        return LinkConfig(mass, _t(com), _t(inertia[[0, 1, 2, 0, 0, 1], [0, 1, 2, 1, 2, 2]]), shapes)

    def _shape(self, g: int, pos: np.ndarray, rot: np.ndarray) -> tuple[ShapeConfig, ...]:
        """Geom ``g`` as a collision shape in the frame (``pos``, ``rot``); none for a geom that collides with
        nothing (a visual one). Ellipsoids and meshes become their bounding boxes."""
        m, d, t = self.m, self.d, self.mj.mjtGeom
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            return ()
        g_rot, g_pos, kind = d.geom_xmat[g].reshape(3, 3), d.geom_xpos[g], int(m.geom_type[g])
        size = m.geom_size[g]
        if kind in (int(t.mjGEOM_MESH), int(t.mjGEOM_ELLIPSOID)):
            centre, size = m.geom_aabb[g][:3], m.geom_aabb[g][3:]
            g_pos, kind = g_pos + g_rot @ centre, int(t.mjGEOM_BOX)
        names = {int(t.mjGEOM_SPHERE): ("sphere", 1), int(t.mjGEOM_CAPSULE): ("capsule", 2),
                 int(t.mjGEOM_CYLINDER): ("cylinder", 2), int(t.mjGEOM_BOX): ("box", 3)}  # fmt: skip
        if kind not in names:
            return ()
        name, n = names[kind]
        local = rot.T @ g_rot
        return (ShapeConfig(name, _t(size[:n]), _t(rot.T @ (g_pos - pos)), _quat(local)),)

    def leg(self, leg_name: str, chain: list[int], urdf: dict) -> tuple[LegConfig, list[float]]:
        """One leg (its chain's joints, links and foot in hexnewton's sense) and its joints' signs."""
        links = [int(self.m.jnt_bodyid[j]) for j in chain]
        prev_pos, prev_rot = self.frame(self.torso)
        foot_link = self.link(links[2])
        foot, radius, extra = self._foot(leg_name, links[2], foot_link)
        foot_w = self.frame(links[2])[0] + self.frame(links[2])[1] @ np.asarray(foot)
        signs = self._signs(leg_name, chain, foot_w)
        joints = []
        for k, (j, b) in enumerate(zip(chain, links)):
            self._check_limit(j, urdf)
            pos, rot = self.frame(b)
            axis = signs[k] * self.m.jnt_axis[j] / np.linalg.norm(self.m.jnt_axis[j])
            ref = float(self.m.qpos0[self.m.jnt_qposadr[j]])  # the joint's ref: the file's frames stand at it
            lo, hi = (float(v) - ref for v in self.m.jnt_range[j])
            limit = (lo, hi) if signs[k] > 0 else (-hi, -lo)
            link = foot_link if k == 2 else self.link(b)
            if k == 2 and extra is not None:
                link = replace(link, shapes=link.shapes + (extra,))
            joints.append(JointConfig(self.joint(j), _t(prev_rot.T @ (pos - prev_pos)), _quat(prev_rot.T @ rot),
                                      _t(axis), limit, float(signs[k]), link))  # fmt: skip
            prev_pos, prev_rot = pos, rot
        self.foot_radius = radius
        return LegConfig(tuple(joints), foot), signs

    def _check_limit(self, j: int, urdf: dict) -> None:
        if not self.m.jnt_limited[j]:
            kind = (urdf.get(self.joint(j)) or {}).get("type")
            what = "is continuous (no limits)" if kind == "continuous" else "has no limits (a range)"
            _fail(self.path, f"joint '{self.joint(j)}' {what}: every leg joint needs its lower and upper limit")

    def _foot(self, leg: str, link: int, cfg: LinkConfig):
        """(the foot's centre in the last link's frame, its radius, a sphere to add there or None)."""
        pos, _ = self.frame(link)
        spheres = [s for s in cfg.shapes if s.kind == "sphere"]
        if spheres:
            s = max(spheres, key=lambda s: frames.norm(s.pos))
            return s.pos, s.size[0], None
        rods = [s for s in cfg.shapes if s.kind in ("capsule", "cylinder")]
        if not rods:
            _fail(self.path, f"leg {leg}'s last link '{self.body(link)}' has no sphere, capsule or cylinder: "
                             "hexnewton needs its foot")
        ends = [frames.add(s.pos, sign * np.asarray(frames.qrot(s.quat, (0.0, 0.0, s.size[1])))) for s in rods
                for sign in (1.0, -1.0)]  # fmt: skip
        k = max(range(len(ends)), key=lambda i: frames.norm(ends[i]))
        end, radius = _t(ends[k]), rods[k // 2].size[0]
        return end, radius, ShapeConfig("sphere", (radius,), end)

    def _signs(self, leg: str, chain: list[int], foot_w: np.ndarray) -> list[float]:
        """Each joint's sense: +1 where the file's positive angle is hexnewton's (hip: foot forward; knee: foot up;
        ankle: about the knee's axis), else -1; a one-line error for a leg whose axes are not hip, knee, ankle."""
        rot_t = self.d.xmat[self.torso].reshape(3, 3).T
        axes = [rot_t @ self.d.xaxis[j] for j in chain]
        at = [rot_t @ (self.d.xanchor[j] - self.d.xpos[self.torso]) for j in chain]
        foot = rot_t @ (foot_w - self.d.xpos[self.torso])
        names = [self.joint(j) for j in chain]
        if abs(axes[0][2]) < VERTICAL:
            _fail(self.path, f"leg {leg}'s first joint '{names[0]}' turns about {_t(axes[0])}: a hip turns about a "
                             "vertical axis (hip, knee, ankle from the torso)")
        if abs(axes[1][2]) > VERTICAL or abs(axes[1] @ axes[2]) < VERTICAL:
            _fail(self.path, f"leg {leg}'s knee '{names[1]}' and ankle '{names[2]}' need parallel horizontal axes, got "
                             f"{_t(axes[1])} and {_t(axes[2])}")
        hip = 1.0 if np.cross(axes[0], foot - at[0])[0] > 0 else -1.0
        knee = 1.0 if np.cross(axes[1], foot - at[1])[2] > 0 else -1.0
        ankle = 1.0 if knee * (axes[1] @ axes[2]) > 0 else -1.0
        return [hip, knee, ankle]


def _t(v) -> tuple[float, ...]:
    return tuple(float(x) for x in np.asarray(v, np.float64).ravel())


def _quat(rot: np.ndarray) -> tuple[float, float, float, float]:
    """A rotation matrix's unit quaternion (x, y, z, w), w >= 0."""
    import mujoco

    q = np.zeros(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(rot, np.float64).ravel())
    q = q if q[0] >= 0 else -q
    return (float(q[1]), float(q[2]), float(q[3]), float(q[0]))


def _stand_pose(tree: _Tree, legs: list[LegConfig], chains: list[list[int]], signs) -> tuple[float, float, float]:
    """The standing pose (module docstring): an MJCF keyframe ``stand`` / ``home``, else computed; the same on every
    leg (one line where the legs disagree by more than 0.05 rad)."""
    m = tree.m
    poses = None
    for key in ("stand", "home"):
        k = tree.mj.mj_name2id(m, tree.mj.mjtObj.mjOBJ_KEY, key)
        if k >= 0:
            qpos = m.key_qpos[k]
            poses = [[s * float(qpos[m.jnt_qposadr[j]] - m.qpos0[m.jnt_qposadr[j]]) for j, s in zip(chain, sg)]
                     for chain, sg in zip(chains, signs)]  # angles from the joints' ref, as the limits
            break
    if poses is None:
        poses = [_computed_stand(leg) for leg in legs]
    poses = np.asarray(poses)
    spread = float(np.max(np.ptp(poses, axis=0)))
    if spread > 0.05:
        _fail(tree.path, f"the legs' standing poses differ by up to {spread:.2f} rad (their zero poses differ): give "
                         "the file a keyframe 'stand', the legs' hip, knee and ankle angles alike")
    lower = np.max([[j.limit[0] for j in leg.joints] for leg in legs], axis=0)
    upper = np.min([[j.limit[1] for j in leg.joints] for leg in legs], axis=0)
    return _t(np.clip(np.median(poses, axis=0), lower, upper))


def _computed_stand(leg: LegConfig) -> list[float]:
    """Hip 0; the knee that raises the femur :data:`STAND_FEMUR_RAISE` above level; the ankle that then hangs the
    tibia straight down (angles in the plane the knee turns in)."""
    poses, foot = frames.leg_poses(leg)
    (knee_at, knee_rot), (ankle_at, _) = poses[1], poses[2]
    axis = np.asarray(frames.qrot(knee_rot, leg.joints[1].axis))
    femur, tibia = np.subtract(ankle_at, knee_at), np.subtract(foot, ankle_at)
    e1 = femur - (femur @ axis) * axis
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)

    def angle(v) -> float:
        return math.atan2(float(np.asarray(v) @ e2), float(np.asarray(v) @ e1))

    level = e1 - (e1 @ np.array([0.0, 0.0, 1.0])) * np.array([0.0, 0.0, 1.0])
    level /= np.linalg.norm(level)
    raised = math.cos(STAND_FEMUR_RAISE) * level + math.sin(STAND_FEMUR_RAISE) * np.array([0.0, 0.0, 1.0])
    knee = _wrap(angle(raised) - angle(femur))
    ankle = _wrap(angle([0.0, 0.0, -1.0]) - angle(tibia) - knee)
    return [0.0, knee, ankle]


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _servo(tree: _Tree, chains, urdf: dict, mass: float, femur: float) -> dict:
    """The servo's gains, effort limit and armature: the file's where it gives them (the median over the 18 joints),
    else the paper robot's scaled by mass x femur length against the paper robot's."""
    m, paper = tree.m, RobotConfig()
    ratio = mass * femur / (paper.total_mass * paper.femur_length)
    joints = [j for chain in chains for j in chain]
    kp, kv, effort = [], [], []
    for a in range(m.nu):
        if m.actuator_trntype[a] == 0 and m.actuator_trnid[a][0] in joints and m.actuator_biasprm[a][1] < 0:
            gear = abs(float(m.actuator_gear[a][0]))  # the servo turns the joint through its gear: the joint's
            kp.append(float(m.actuator_gainprm[a][0]) * gear**2)  # stiffness kp g², damping kv g², torque g x force
            kv.append(float(-m.actuator_biasprm[a][2]) * gear**2)
            if m.actuator_forcelimited[a]:
                effort.append(float(max(abs(v) for v in m.actuator_forcerange[a])) * gear)
    effort += [e for j in joints if (e := (urdf.get(tree.joint(j)) or {}).get("effort"))]
    armature = [float(m.dof_armature[m.jnt_dofadr[j]]) for j in joints if m.dof_armature[m.jnt_dofadr[j]] > 0]
    pick = lambda values, default: float(np.median(values)) if values else default  # noqa: E731
    return dict(joint_ke=pick(kp, paper.joint_ke * ratio), joint_kd=pick(kv, paper.joint_kd * ratio),
                effort_limit=pick(effort, paper.effort_limit * ratio), armature=pick(armature, paper.armature))


def _summary(path: str, tree: _Tree, legs: list[LegConfig], stand, urdf: dict, chains) -> RobotConfig:
    """The robot: its frames, and the dimension fields summarising them (the first leg's link lengths and masses,
    the limits all legs reach, the torso's box, the hip mounts)."""
    torso = tree.link(tree.torso)
    first = legs[0]
    lengths = [frames.norm(first.joints[1].pos), frames.norm(first.joints[2].pos), frames.norm(first.foot)]
    mass = torso.mass + sum(j.link.mass for leg in legs for j in leg.joints)
    lower = [max(leg.joints[k].limit[0] for leg in legs) for k in range(3)]
    upper = [min(leg.joints[k].limit[1] for leg in legs) for k in range(3)]
    boxes = [s for s in torso.shapes if s.kind == "box"]
    mounts = tuple((round(leg.joints[0].pos[0], 6), round(abs(leg.joints[0].pos[1]), 6)) for leg in legs[:3])
    cfg = RobotConfig(
        name=os.path.splitext(os.path.basename(path))[0], source=os.path.abspath(path), hip_length=lengths[0],
        femur_length=lengths[1], tibia_length=lengths[2], total_mass=mass,
        coxa_mass=first.joints[0].link.mass, femur_mass=first.joints[1].link.mass,
        tibia_mass=first.joints[2].link.mass, hip_limit=(lower[0], upper[0]), knee_limit=(lower[1], upper[1]),
        ankle_limit=(lower[2], upper[2]), torso_size=_t(2.0 * np.asarray(boxes[0].size)) if boxes else (0.0,) * 3,
        hip_mounts=mounts, foot_radius=tree.foot_radius, stand_pose=stand, legs=tuple(legs), torso=torso,
        **_servo(tree, chains, urdf, mass, lengths[1]))  # fmt: skip
    from hexnewton.robot.geometry import stand_height

    return replace(cfg, spawn_height=round(stand_height(cfg) + 0.02, 6))
