"""Write a named robot given by its dimensions as a URDF and an MJCF file, in the conventions such files use rather than
hexnewton's: ``python scripts/robot_files.py mx_phoenix`` writes ``hexnewton/robot/mx_phoenix/mx_phoenix.urdf`` and
``.xml`` from ``hexnewton.robot.mx_phoenix.MX_PHOENIX``.

The URDF names its links and joints as ROS packages do (``rf_coxa``, ``rf_coxa_joint``; rf, rm, rr, lf, lm, lr for
R1 .. L3), turns every hip about +z and every knee and ankle about +y (so hexnewton reverses the left hips and all
knees and ankles), models the femur and tibia as cylinders and hangs each foot sphere on a link of its own on a fixed
joint. The MJCF keeps hexnewton's axes except the left knees' and ankles', hangs each foot on a body of its own without
a joint (10 g of the tibia's mass in it), carries the servos as position actuators and the standing pose as the
keyframe ``stand``. ``tests/robot/test_loader.py`` checks that both load to the named robot.
"""

from __future__ import annotations

import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from hexnewton.robot.geometry import (  # noqa: E402
    box_inertia,
    describe,
    hip_mount,
    leg_links,
    leg_yaw,
    rod_inertia,
    torso_mass,
)
from hexnewton.robot.registry import ROBOTS  # noqa: E402

SIDES = ("rf", "rm", "rr", "lf", "lm", "lr")
FOOT_MASS = 0.01  # [kg] of the tibia's, in the MJCF's foot body


def _v(values) -> str:
    return " ".join(f"{float(x):.9g}" for x in values)


def urdf(cfg) -> str:
    """The robot as URDF text."""
    m, (sx, sy, sz) = torso_mass(cfg), cfg.torso_size
    ixx, iyy, izz = box_inertia(m, sx, sy, sz)
    out = [f'<?xml version="1.0"?>\n<robot name="{cfg.name}">',
           f'  <link name="base_link">\n    <inertial><origin xyz="0 0 0"/><mass value="{m:.9g}"/>'
           f'<inertia ixx="{ixx:.9g}" iyy="{iyy:.9g}" izz="{izz:.9g}" ixy="0" ixz="0" iyz="0"/></inertial>\n'
           f'    <collision><geometry><box size="{_v(cfg.torso_size)}"/></geometry></collision>\n  </link>']
    r, fr = cfg.leg_radius, cfg.foot_radius
    limits = (cfg.hip_limit, (-cfg.knee_limit[1], -cfg.knee_limit[0]), (-cfg.ankle_limit[1], -cfg.ankle_limit[0]))
    for leg, side in enumerate(SIDES):
        at = (hip_mount(cfg, leg), (cfg.hip_length, 0.0, 0.0), (cfg.femur_length, 0.0, 0.0))
        rpy = ((0.0, 0.0, leg_yaw(cfg, leg)), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        axes = ((0, 0, 1), (0, 1, 0), (0, 1, 0))
        collision = ("", f'    <collision><origin xyz="{cfg.femur_length / 2:.9g} 0 0" rpy="0 {math.pi / 2:.9g} 0"/>'
                         f'<geometry><cylinder radius="{r:.9g}" length="{cfg.femur_length:.9g}"/></geometry>'
                         '</collision>\n',
                     f'    <collision><origin xyz="0 0 {-(cfg.tibia_length - fr) / 2:.9g}"/><geometry><cylinder '
                     f'radius="{r:.9g}" length="{cfg.tibia_length - fr:.9g}"/></geometry></collision>\n')  # fmt: skip
        parent = "base_link"
        for k, (link, mass, length, com, axis) in enumerate(leg_links(cfg)):
            name = f"{side}_{link}"
            i = rod_inertia(mass, length, r, axis)
            out.append(f'  <joint name="{name}_joint" type="revolute"><parent link="{parent}"/><child link="{name}"/>'
                       f'<origin xyz="{_v(at[k])}" rpy="{_v(rpy[k])}"/><axis xyz="{_v(axes[k])}"/>'
                       f'<limit lower="{limits[k][0]:.12g}" upper="{limits[k][1]:.12g}" '
                       f'effort="{cfg.effort_limit:.9g}" velocity="6"/></joint>')  # fmt: skip
            out.append(f'  <link name="{name}">\n    <inertial><origin xyz="{_v(com)}"/><mass value="{mass:.9g}"/>'
                       f'<inertia ixx="{i[0]:.9g}" iyy="{i[1]:.9g}" izz="{i[2]:.9g}" ixy="0" ixz="0" iyz="0"/>'
                       f'</inertial>\n{collision[k]}  </link>')  # fmt: skip
            parent = name
        out.append(f'  <joint name="{side}_foot_joint" type="fixed"><parent link="{parent}"/><child '
                   f'link="{side}_foot"/><origin xyz="0 0 {-cfg.tibia_length:.9g}"/></joint>')
        out.append(f'  <link name="{side}_foot">\n    <collision><geometry><sphere radius="{fr:.9g}"/></geometry>'
                   '</collision>\n  </link>')
    return "\n".join(out + ["</robot>", ""])


def _quat_wxyz(yaw: float) -> tuple[float, float, float, float]:
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def mjcf(cfg) -> str:
    """The robot as MJCF text."""
    d = describe(cfg)
    m, (sx, sy, sz) = torso_mass(cfg), cfg.torso_size
    r, fr = cfg.leg_radius, cfg.foot_radius
    body = [f'    <body name="torso" pos="0 0 {cfg.spawn_height:.9g}"><freejoint name="root"/>'
            f'<inertial pos="0 0 0" mass="{m:.9g}" diaginertia="{_v(box_inertia(m, sx, sy, sz))}"/>'
            f'<geom name="torso" type="box" size="{_v((sx / 2, sy / 2, sz / 2))}"/>']
    joints, key = [], []
    for leg, side in enumerate(SIDES):
        left = leg >= 3
        tibia_len = cfg.tibia_length
        parts = []
        for k, ((link, mass, length, com, axis), joint) in enumerate(zip(leg_links(cfg), d.legs[leg].joints)):
            flip = -1.0 if left and k > 0 else 1.0
            lo, hi = joint.limit if flip > 0 else (-joint.limit[1], -joint.limit[0])
            quat = f' quat="{_v(_quat_wxyz(leg_yaw(cfg, leg)))}"' if k == 0 else ""
            if k == 2:  # the foot's 10 g hang below, on a body of its own
                mass = mass - FOOT_MASS
                com = (0.0, 0.0, (cfg.tibia_mass * -tibia_len / 2 + FOOT_MASS * tibia_len) / mass)
            i = rod_inertia(mass, length, r, axis)
            geom = ("", f'<geom type="capsule" size="{r:.9g}" fromto="{r:.9g} 0 0 {cfg.femur_length - r:.9g} 0 0"/>',
                    f'<geom type="capsule" size="{r:.9g}" fromto="0 0 {-r:.9g} 0 0 {-(tibia_len - fr):.9g}"/>'
                    f'<body name="{side}_foot" pos="0 0 {-tibia_len:.9g}"><inertial pos="0 0 0" '
                    f'mass="{FOOT_MASS:.9g}" diaginertia="1e-6 1e-6 1e-6"/><geom type="sphere" size="{fr:.9g}"/>'
                    '</body>')  # fmt: skip
            parts.append(f'<body name="{side}_{link}" pos="{_v(joint.pos)}"{quat}>'
                         f'<joint name="{side}_{link}" axis="{_v(flip * v for v in joint.axis)}" range="{lo:.12g} '
                         f'{hi:.12g}" armature="{cfg.armature:.9g}"/><inertial pos="{_v(com)}" mass="{mass:.9g}" '
                         f'diaginertia="{_v(i)}"/>{geom[k]}')  # fmt: skip
            joints.append(f"{side}_{link}")
            key.append(flip * cfg.stand_pose[k])
        body.append("      " + "".join(parts) + "</body>" * 3)
    act = "".join(f'<position joint="{j}" kp="{cfg.joint_ke:.9g}" kv="{cfg.joint_kd:.9g}" '
                  f'forcerange="{-cfg.effort_limit:.9g} {cfg.effort_limit:.9g}"/>' for j in joints)  # fmt: skip
    qpos = _v((0.0, 0.0, cfg.spawn_height, 1.0, 0.0, 0.0, 0.0, *key))
    return (f'<mujoco model="{cfg.name}">\n  <compiler angle="radian" autolimits="true"/>\n  <worldbody>\n'
            + "\n".join(body) + '\n    </body>\n  </worldbody>\n  <actuator>' + act + '</actuator>\n'
            f'  <keyframe><key name="stand" qpos="{qpos}"/></keyframe>\n</mujoco>\n')  # fmt: skip


def main(argv: list[str]) -> int:
    name = argv[0] if argv else "mx_phoenix"
    cfg = ROBOTS[name]
    folder = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "hexnewton", "robot", name)
    for ext, text in ((".urdf", urdf(cfg)), (".xml", mjcf(cfg))):
        path = os.path.join(folder, name + ext)
        with open(path, "w") as f:
            f.write(text)
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
