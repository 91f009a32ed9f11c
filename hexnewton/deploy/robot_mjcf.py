"""A robot's own MJCF file as sim2sim's C MuJoCo model (``sim2sim --mjcf own``, docs/robots.md): the file's robot
as written, spliced into the world :mod:`hexnewton.deploy.mjcf` generates (the terrain, the scanner's heightfield, the
options) with MuJoCo's own model editing (``mujoco.MjSpec``: each round's robot a copy of the file's root body
attached to the world with the prefix ``r<k>_``), instead of the robot written from the description.

What is the file's: its bodies, inertias, joints (axes, senses, ranges, armature, damping, friction loss), geoms
(shapes, friction, solref, solimp, margins), actuators, tendons, sensors, default classes and assets. What is
sim2sim's: the world, its options (the bundle's substep as timestep, ``implicitfast``, MuJoCo's default solver and
contacts, as for the generated model) and terrain; the file's own floor, lights and keyframes are left out. Three
changes to the robot, each as the generated model has it: a colliding geom of the robot touches the terrain only
(``contype`` 1, ``conaffinity`` 0: the rounds' robots share one model and never meet, and neither model has
self-collisions); a root body without a free joint gets one; and each robot gets an IMU site at its root body's
origin with the loop's sensors (``mjcf.robot_io_xml``'s 43 values).

The controller's targets reach the file's joints by name (the description's joint names, the bundle's ``joint
order``), in the file's senses (the description's ``JointConfig.sign``, the bundle's ``joint_signs``), through the
file's position servo on each joint (``<position>``, or a ``<general>`` actuator with the same gain and bias; its
gear and the joint's ``ref`` taken into account): :class:`~hexnewton.deploy.mjcf.Layout`. A file with no actuator on
its leg joints gets the generated model's servos (kp ``joint_ke``, kv ``joint_kd``, ``|force| <= effort_limit``),
said in :attr:`RobotFile.notes`; a leg joint driven otherwise (a motor, a velocity servo alone, two position servos)
or only some of them driven is one error line.
"""

from __future__ import annotations

import math
import os

import numpy as np

from hexnewton.config import RobotConfig
from hexnewton.deploy.mjcf import SENSORS_PER_ROBOT, Layout, scene_xml, set_scanner_heights
from hexnewton.errors import HexnewtonError
from hexnewton.terrain.heightmap import HeightGrid

#: the names of what sim2sim adds to each robot (after its ``r<k>_`` prefix)
ADDED = "hexnewton_"


def _fail(path: str, what: str):
    raise HexnewtonError(f"robot file {path}: {what}")


def joint_names(cfg: RobotConfig) -> list[str]:
    """The file's names of the 18 leg joints, in hexnewton's order."""
    return [j.name for leg in cfg.legs for j in leg.joints]


def check_file(path: str, cfg: RobotConfig) -> None:
    """One line (``HexnewtonError``) unless ``path`` is an MJCF file that reads as robot ``cfg`` (its legs named as
    the description names them)."""
    from hexnewton.robot.loader import load_robot
    from hexnewton.robot.registry import same_robot

    if not path.lower().endswith(".xml"):
        raise HexnewtonError(f"robot {cfg.name} is {'a named robot' if not path else 'read from ' + path}: "
                             "--mjcf own runs a robot's own MJCF file (.xml)")  # fmt: skip
    if not os.path.isfile(path):
        raise HexnewtonError(f"robot {cfg.name}'s file {path} is not here")
    if not same_robot(load_robot(path, tuple(joint_names(cfg))), cfg):
        raise HexnewtonError(f"{path} is no longer robot {cfg.name} as the bundle describes it (the file changed)")


def servo(m, a: int) -> bool:
    """Whether actuator ``a`` of model ``m`` is a position servo on a joint: fixed gain kp > 0, affine bias -kp x
    length (- kv x velocity), not an integrator."""
    import mujoco

    gain, bias = m.actuator_gainprm[a], m.actuator_biasprm[a]
    return (m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT and m.actuator_gaintype[a] == mujoco.mjtGain.mjGAIN_FIXED
            and m.actuator_biastype[a] == mujoco.mjtBias.mjBIAS_AFFINE and gain[0] > 0 and bias[0] == 0
            and math.isclose(bias[1], -gain[0], rel_tol=1e-9)
            and m.actuator_dyntype[a] != mujoco.mjtDyn.mjDYN_INTEGRATOR)  # fmt: skip


def servos(m, joints: list[int]) -> tuple[list[int], list[str]]:
    """The position servo on each joint id of ``joints`` (-1 where there is none) and, per joint, what is wrong with
    its actuators ("" where nothing is)."""
    import mujoco

    on: dict[int, list[int]] = {}
    for a in np.flatnonzero(m.actuator_trntype == mujoco.mjtTrn.mjTRN_JOINT):
        on.setdefault(int(m.actuator_trnid[a, 0]), []).append(int(a))
    ids, wrong = [], []
    for j in joints:
        acts = on.get(int(j), [])
        pos = [a for a in acts if servo(m, a)]
        ids.append(pos[0] if len(pos) == 1 else -1)
        wrong.append("" if len(pos) == 1 or not acts else "two position servos" if pos else "no position servo")
    return ids, wrong


class RobotFile:
    """Robot ``cfg``'s own MJCF file ``path`` (checked to be that robot, :func:`check_file`), ready to be put into a
    course: :meth:`model`. ``notes``: what sim2sim added to it, one line each."""

    def __init__(self, path: str, cfg: RobotConfig):
        import mujoco

        check_file(path, cfg)
        self.path, self.cfg, self.mj, self.notes = path, cfg, mujoco, []
        self.names = joint_names(cfg)
        spec = self.spec = mujoco.MjSpec.from_file(path)
        for key in list(spec.keys):  # the file's poses are its own; a key of the world's size would be needed
            spec.delete(key)
        m = spec.compile()
        ids = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, n) for n in self.names]
        root = int(m.body_rootid[m.jnt_bodyid[ids[0]]])
        self.torso = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, root)
        if not self.torso:
            _fail(path, "its root body needs a name (sim2sim attaches it to the course by name)")
        torso = spec.body(self.torso)
        if m.body_jntnum[root] == 0:
            torso.add_freejoint(name=ADDED + "base")
            self.notes.append(f"robot file {path}: its root body '{self.torso}' has no free joint: sim2sim gives it "
                              "one")
        for g in spec.geoms:  # the terrain only (the world's contype 0 / conaffinity 1)
            if g.contype or g.conaffinity:
                g.contype, g.conaffinity = 1, 0
        self._servos(m, ids)
        self._sensors(torso)

    def _servos(self, m, ids: list[int]) -> None:
        """The file's position servo on every leg joint; or, where it drives none of them, the generated model's."""
        found, wrong = servos(m, ids)
        bad = [f"'{n}' ({w})" for n, w in zip(self.names, wrong) if w]
        if bad:
            more = f" (and {len(bad) - 1} more)" if len(bad) > 1 else ""
            _fail(self.path, f"leg joint {bad[0]}{more} is not driven by one position servo: sim2sim sends joint "
                             "targets to position servos (--mjcf generated runs the model written from the "
                             "description)")  # fmt: skip
        if all(a >= 0 for a in found):
            return
        if any(a >= 0 for a in found):
            missing = [n for n, a in zip(self.names, found) if a < 0]
            more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
            _fail(self.path, f"no actuator on leg joint '{missing[0]}'{more}, position servos on the others: give "
                             "every leg joint its servo, or none (sim2sim then adds the generated model's)")
        cfg, mj = self.cfg, self.mj
        for n in self.names:
            a = self.spec.add_actuator(name=f"{ADDED}{n}", target=n, trntype=mj.mjtTrn.mjTRN_JOINT)
            a.set_to_position(kp=cfg.joint_ke, kv=cfg.joint_kd)
            a.forcelimited, a.forcerange = mj.mjtLimited.mjLIMITED_TRUE, [-cfg.effort_limit, cfg.effort_limit]
        self.notes.append(f"robot file {self.path}: no actuators on its leg joints: sim2sim adds the generated model's "
                          f"position servos (kp {cfg.joint_ke:g} N m/rad, kv {cfg.joint_kd:g} N m s/rad, |force| <= "
                          f"{cfg.effort_limit:g} N m)")  # fmt: skip

    def _sensors(self, torso) -> None:
        """The loop's sensors (``robot_io_xml``'s order): the IMU's quaternion at a site on the root body's origin,
        the 18 joints' positions and velocities, the IMU's gyro."""
        s, mj = self.spec, self.mj.mjtSensor
        site = ADDED + "imu"
        torso.add_site(name=site)
        s.add_sensor(name=f"{ADDED}quat", type=mj.mjSENS_FRAMEQUAT, objtype=self.mj.mjtObj.mjOBJ_SITE, objname=site)
        for kind, t in (("pos", mj.mjSENS_JOINTPOS), ("vel", mj.mjSENS_JOINTVEL)):
            for n in self.names:
                s.add_sensor(name=f"{ADDED}{n}_{kind}", type=t, objtype=self.mj.mjtObj.mjOBJ_JOINT, objname=n)
        s.add_sensor(name=f"{ADDED}gyro", type=mj.mjSENS_GYRO, objtype=self.mj.mjtObj.mjOBJ_SITE, objname=site)

    def model(self, grid: HeightGrid | None, starts, timestep: float):
        """The course with one copy of the file's robot per start ``(x, y, z, yaw)``, named ``r0_``, ``r1_``, ...:
        (``mujoco.MjModel``, its :class:`Layout`)."""
        mj = self.mj
        world = mj.MjSpec.from_string(scene_xml(self.cfg, grid, [], timestep))
        world.memory = (64 + 8 * len(starts)) << 20
        for k, (x, y, z, yaw) in enumerate(starts):
            frame = world.worldbody.add_frame(pos=[x, y, z], quat=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
            frame.attach_body(self.spec.copy().body(self.torso), f"r{k}_", "")
        try:
            m = world.compile()
        except ValueError as exc:  # MuJoCo's compiler
            _fail(self.path, "MuJoCo cannot put it into the course: " + " ".join(str(exc).split())[:300])
        if grid is not None:
            set_scanner_heights(m, grid)
        return m, self.layout(m, len(starts))

    def layout(self, m, n: int) -> Layout:
        """Where the ``n`` robots' coordinates, leg joints, servos and sensors are in the compiled course ``m``."""
        mj = self.mj
        obj = mj.mjtObj

        def ids(kind, names, k):
            return [mj.mj_name2id(m, kind, f"r{k}_{name}") for name in names]

        nq, nv = m.nq // n, m.nv // n
        joints = np.array([ids(obj.mjOBJ_JOINT, self.names, k) for k in range(n)])
        torsos = [mj.mj_name2id(m, obj.mjOBJ_BODY, f"r{k}_{self.torso}") for k in range(n)]
        base, start = m.body_jntadr[torsos], nq * np.arange(n)
        if (m.nq != nq * n or m.nv != nv * n or not np.array_equal(m.jnt_qposadr[base], start)
                or (m.jnt_type[base] != mj.mjtJoint.mjJNT_FREE).any()
                or (m.jnt_qposadr[joints] - start[:, None] != m.jnt_qposadr[joints[0]]).any()):  # fmt: skip
            raise RuntimeError(f"{self.path}: unexpected layout of the course's MuJoCo model")
        acts = np.reshape(servos(m, joints.ravel())[0], (n, 18))
        names = [f"{ADDED}quat"] + [f"{ADDED}{j}_{k}" for k in ("pos", "vel") for j in self.names] + [f"{ADDED}gyro"]
        sensors = []
        for k in range(n):
            adr = [m.sensor_adr[s] + i for s in ids(obj.mjOBJ_SENSOR, names, k) for i in range(m.sensor_dim[s])]
            sensors.append(adr)
        signs = [j.sign for leg in self.cfg.legs for j in leg.joints]
        q0 = m.jnt_qposadr[joints[0]]
        return Layout(nq, nv, q0, m.jnt_dofadr[joints[0]], signs, m.qpos0[q0], acts, m.actuator_gear[acts, 0],
                      np.asarray(sensors).reshape(n, SENSORS_PER_ROBOT), torsos)  # fmt: skip
