"""One servo in C MuJoCo under the two ways of clamping its effort: the bundle's (``forcerange`` on the position
actuator) and Newton's SolverMuJoCo's (``actuatorfrcrange`` on the joint), at the bundle's 5 ms step with the
``implicitfast`` integrator (studies/sim2sim/wedge/report.md, "Which MuJoCo setting wedges").

    PYTHONPATH=. python studies/sim2sim/servo_clamp_step.py --out studies/sim2sim/wedge/servo_clamp.json

The joint: a hinge about z (no gravity) carrying the tibia (RobotConfig's mass and length, a rod about its end) with
the robot's armature, kp = joint_ke, kv = joint_kd, |force| <= effort_limit; its target jumps by ``--step`` rad at
rest. Per clamp: joint velocity after 1 and 2 steps, the actuator force applied, and the time to reach half the
target.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from hexnewton.config import RobotConfig


def servo_xml(cfg: RobotConfig, joint_clamp: bool, dt: float) -> str:
    e = cfg.effort_limit
    jnt = f' actuatorfrcrange="{-e} {e}"' if joint_clamp else ""
    act = "" if joint_clamp else f' forcerange="{-e} {e}"'
    return (f'<mujoco><option timestep="{dt}" integrator="implicitfast" gravity="0 0 0"/><worldbody><body>'
            f'<joint name="j" type="hinge" axis="0 0 1" armature="{cfg.armature}"{jnt}/>'
            f'<geom type="capsule" size="{cfg.leg_radius}" fromto="0 0 0 {cfg.tibia_length} 0 0" '
            f'mass="{cfg.tibia_mass}"/></body></worldbody>'
            f'<actuator><position joint="j" kp="{cfg.joint_ke}" kv="{cfg.joint_kd}"{act}/></actuator></mujoco>')


def step_response(joint_clamp: bool, target: float, dt: float = 0.005, steps: int = 100) -> dict:
    import mujoco

    m = mujoco.MjModel.from_xml_string(servo_xml(RobotConfig(), joint_clamp, dt))
    d = mujoco.MjData(m)
    d.ctrl[0] = target
    q, v, f = [], [], []
    for _ in range(steps):
        mujoco.mj_step(m, d)
        q.append(float(d.qpos[0]))
        v.append(float(d.qvel[0]))
        f.append(float(d.qfrc_actuator[0]))
    half = int(np.argmax(np.asarray(q) >= 0.5 * target)) + 1
    return {"qvel_after_1_step": round(v[0], 4), "qvel_after_2_steps": round(v[1], 4),
            "applied_torque_step_1": round(f[0], 4), "time_to_half_target_s": round(half * dt, 4)}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--step", type=float, default=1.0, help="target jump [rad]")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    if not 0.0 < a.step <= 3.0:
        p.error("--step must be in (0, 3] rad")
    res = {"command": "PYTHONPATH=. python studies/sim2sim/servo_clamp_step.py " + " ".join(sys.argv[1:]), "target_rad": a.step,
           "actuator_forcerange (bundle)": step_response(False, a.step),
           "joint_actuatorfrcrange (Newton)": step_response(True, a.step)}
    print(json.dumps(res, indent=1))
    with open(a.out, "w") as f:
        json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
