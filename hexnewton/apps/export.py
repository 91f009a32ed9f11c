"""Export a trained CPG_RL checkpoint as a controller bundle for the robot (``hexnewton.deploy.runtime``).

    python -m hexnewton.apps.export --checkpoint logs/.../model_299.pt --out bundle/

writes ``bundle/policy.onnx`` (one file, dynamic batch), ``bundle/controller.json`` (observation layout,
parameter ranges, CPG and mapping constants, periods, standing pose, joint limits, the robot: its name, joint names,
senses and limits, scales and whole description) and ``bundle/check.npz``
(a short rollout in the simulator: the observations and the simulator's joint targets). It then replays the
rollout through the NumPy/onnxruntime runtime and fails unless the joint targets agree within the tolerance.
The configuration comes from the checkpoint (the config the policy was trained with).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import sys

import numpy as np

from hexnewton.apps.cli import (
    ArgumentParser,
    add_robot_args,
    check_checkpoint_file,
    positive_int,
    robot_from_args,
    run,
)
from hexnewton.config import RandomizationConfig, TaskConfig, TerrainConfig, config_from_dict
from hexnewton.deploy.runtime import FORMAT, replay


def _sha256(path: str) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def controller_spec(env, checkpoint: str, action_std: list[float] | None) -> dict:
    """controller.json for ``env``'s configuration; ``action_std`` is the policy's Gaussian standard deviation (None
    for a Beta policy)."""
    from hexnewton.analysis.report import git_rev
    from hexnewton.mdp.terms import H_HALF_EXTENT, OBS_LAYOUT
    from hexnewton.robot import joint_limits, joint_names, joint_signs, leg_bounds, stand_height

    cfg = env.cfg
    lo, hi = cfg.cpg.param_ranges()
    lower, upper = leg_bounds(cfg.robot)
    window = H_HALF_EXTENT * cfg.task.length_scale
    sub_dt = cfg.sim.frame_dt / cfg.sim.substeps
    return {
        "format": FORMAT,
        "action_mode": "cpg",
        "num_obs": env.num_obs,
        "num_actions": env.num_actions,
        "obs_layout": [list(row) for row in OBS_LAYOUT[env.obs_layout]],
        "obs_notes": {
            "joint order": list(joint_names(cfg.robot)),
            "target": "goal relative to the base in its heading frame (x forward, y left) [m]; z = goal ground - base z"
                      + (" (/ height_scale)" if cfg.task.height_scale != 1.0 else ""),
            "quat": "base orientation (x, y, z, w), w >= 0",
            "max_height": f"highest terrain within +-{window:.6g} m of the base minus the ground under it [m]"
                          + (" (/ height_scale)" if cfg.task.height_scale != 1.0 else ""),
            **({"gyro": "base angular velocity in the body frame (x forward, y left, z up) [rad/s], the IMU's gyro"}
               if cfg.obs.gyro else {}),
            **({"last_action": "the actions the policy gave last, clamped to [-1, 1]; 0 after a reset"}
               if cfg.obs.last_action else {}),
        },
        "param_names": list(cfg.cpg.param_names),
        # ours: the levelling reflex (CPGConfig.posture_reflex; 0 = none), its knee offsets clamped to +-tilt_max
        "posture_reflex": cfg.cpg.posture_reflex if cfg.cpg.posture else 0.0,
        "posture_tilt_max": cfg.cpg.tilt_max,
        # ours: the stuck response (CPGConfig.stuck_*; stuck_lift 0 = none), its lift scaled for the robot
        **{f"stuck_{k}": getattr(cfg.cpg, f"stuck_{k}") for k in ("window", "progress", "hold")},
        "stuck_lift": cfg.cpg.lift,
        "param_lower": list(lo),
        "param_upper": list(hi),
        "initial_params": list(cfg.cpg.fixed_params()),
        # the deterministic action (policy.onnx) is the controller. A Gaussian policy's std per action lets
        # Controller(stochastic=True / expected=True) sample as in training; a Beta policy's spread depends on the
        # observation and is not exported
        "distribution": "gaussian" if action_std is not None else "beta",
        **({"action_std": [float(v) for v in action_std]} if action_std is not None else {}),
        "cpg": {k: getattr(cfg.cpg, k) for k in ("alpha", "mu", "delta", "theta", "duty", "steepness", "param_tau")},
        "control_dt": cfg.task.control_dt,
        "substep_dt": sub_dt,
        "substeps_per_control": int(round(cfg.task.control_dt / sub_dt)),
        "stand_pose": list(cfg.robot.stand_pose),
        "joint_lower": list(lower),
        "joint_upper": list(upper),
        # the robot (docs/robots.md): its name, each joint's limits in hexnewton's sense and its sense on the robot
        # (a robot file's joint that turns the other way: -1), its standing height and the scales of the observed
        # heights and the terrain window, and its whole description (the model sim2sim builds)
        "robot": cfg.robot.name,
        "joint_limits": [list(limit) for limit in joint_limits(cfg.robot)],
        "joint_signs": list(joint_signs(cfg.robot)),
        "stand_height": stand_height(cfg.robot),
        "height_scale": cfg.task.height_scale,
        "length_scale": cfg.task.length_scale,
        "robot_description": dataclasses.asdict(cfg.robot),
        "joint_gains": {"kp": cfg.robot.joint_ke, "kd": cfg.robot.joint_kd, "effort_limit": cfg.robot.effort_limit},
        "goal_distance": cfg.task.goal_distance,
        # the goals it was trained to: "ahead" (goal_distance along +x, the paper's) or "any" (every direction: steer it
        # with Controller.set_goal); within goal_radius a goal is reached
        "goals": "any" if cfg.task.random_goals else "ahead",
        "goal_radius": cfg.task.goal_radius,
        "source": {"checkpoint": os.path.abspath(checkpoint), "sha256": _sha256(checkpoint), "git": git_rev()},
    }


class AttitudeLog:
    """The world's substep controller, wrapped: logs the body quaternion (x, y, z, w) each substep's mapping reads,
    the levelling reflex's input (an env built without graph capture calls it from Python)."""

    def __init__(self, controller):
        self.controller, self.quats = controller, []

    def __call__(self, world) -> None:
        self.quats.append(world.state_0.joint_q.numpy().reshape(world.num_envs, -1)[:, 3:7].copy())
        self.controller(world)


def record(env, policy, steps: int) -> dict[str, np.ndarray]:
    """``steps`` control steps of ``policy``: the observation before each step, the joint targets the simulator's
    CPG and mapping wrote at the step's last substep and, with the levelling reflex, the body quaternion at every
    substep (``substep_quat``, (K, substeps, N, 4)). Stops early if an episode ends."""
    import torch

    log = None
    if env.cfg.cpg.posture and env.cfg.cpg.posture_reflex:
        log = AttitudeLog(env.cpg)
        env.world.set_controller(log)
    rec = {"obs": [], "targets": [], "substep_quat": []}
    obs = env.get_observations()
    with torch.inference_mode():
        for _ in range(steps):
            o = obs["policy"].cpu().numpy().copy()
            obs, _, done, _ = env.step(policy(obs))
            if bool(done.any()):  # the reset moved the CPG state: not part of one continuous rollout
                break
            rec["obs"].append(o)
            rec["targets"].append(env.world.joint_target_wp.numpy()[:, 7:25].copy())
            if log is not None:
                rec["substep_quat"].append(np.asarray(log.quats))
                log.quats.clear()
    return {k: np.asarray(v, np.float64 if k == "substep_quat" else np.float32) for k, v in rec.items() if len(v)}


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.apps.export", description=__doc__.split("\n")[0])
    p.add_argument("--checkpoint", required=True, metavar="PATH", help="rsl-rl checkpoint of a cpg_rl policy")
    p.add_argument("--out", required=True, metavar="DIR", help="bundle folder (must not exist)")
    p.add_argument("--steps", type=positive_int, default=100, help="control steps of the recorded check rollout")
    p.add_argument("--robots", type=positive_int, default=4, help="robots in the recorded check rollout")
    p.add_argument("--tolerance", type=float, default=1e-3, help="largest joint-target difference allowed [rad]")
    add_robot_args(p, "the checkpoint's (the bundle is its robot's; another is one error line)")
    args = p.parse_args(argv)
    check_checkpoint_file(args.checkpoint)  # a run's folder: one line naming its result
    if os.path.exists(args.out):
        raise ValueError(f"{args.out} exists: nothing is overwritten")
    from hexnewton.learning.checkpoint import checkpoint_meta, load_checkpoint
    from hexnewton.learning.policy import action_std, export_onnx, load_runner
    from hexnewton.mdp.env import make_env

    meta = checkpoint_meta(load_checkpoint(args.checkpoint))
    if meta.get("action_mode", "cpg") != "cpg":
        raise ValueError(f"{args.checkpoint} is a '{meta['action_mode']}' policy: a bundle carries the CPG hierarchy "
                         "(a joint-mode policy's policy.onnx from train.py is its whole controller)")  # fmt: skip
    cfg = config_from_dict(meta.get("config", {}))
    from hexnewton.robot.registry import check_robot

    check_robot(cfg.robot, robot_from_args(args), args.checkpoint)
    cfg = dataclasses.replace(
        cfg,
        # no graph capture: the reflex's attitude log (AttitudeLog) runs from Python at every substep
        sim=dataclasses.replace(cfg.sim, num_envs=args.robots, device="cpu", use_graph=False),
        terrain=TerrainConfig(name="flat"),
        task=dataclasses.replace(cfg.task, seed=12345, reset_yaw=TaskConfig.reset_yaw),
        randomization=RandomizationConfig(),  # the check rollout is the nominal robot (no latency, no noise)
        obs=dataclasses.replace(cfg.obs, critic=False),  # the policy's inputs only: the critic is not exported
    )
    env = make_env(cfg, "cpg")
    runner = load_runner(env, args.checkpoint, "cpg")
    rec = record(env, runner.get_inference_policy(device="cpu"), args.steps)
    os.makedirs(args.out)
    err = export_onnx(runner.alg.get_policy(), env.num_obs, os.path.join(args.out, "policy.onnx"))
    with open(os.path.join(args.out, "controller.json"), "w") as f:
        json.dump(controller_spec(env, args.checkpoint, action_std(runner.alg.get_policy())), f, indent=1)
    np.savez_compressed(os.path.join(args.out, "check.npz"), **rec)
    r = replay(args.out)
    print(f"wrote {args.out}: policy.onnx (onnxruntime vs torch {err:.1e}), controller.json, check.npz "
          f"({r['steps']} steps x {r['robots']} robots); the runtime reproduces the simulator's joint targets "
          f"within {r['max_target_diff_rad']:.2e} rad")  # fmt: skip
    if r["max_target_diff_rad"] > args.tolerance:
        raise ValueError(f"the runtime differs from the simulator by {r['max_target_diff_rad']:.2e} rad "
                         f"(> {args.tolerance:g}): the bundle in {args.out} is not trustworthy")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.export"))
