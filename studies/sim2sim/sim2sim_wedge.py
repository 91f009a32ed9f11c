"""Wedged feet on the rugged course, counted the same way in C MuJoCo and in Newton under several collision settings
(studies/sim2sim/wedge/report.md): the shipped complex policy, deterministic action, CPU, the same lanes and rounds.

    PYTHONPATH=. python studies/sim2sim/sim2sim_wedge.py --robots 20 --steps 3000 --seed 1000 \
        --settings newton_frame newton_substep --out studies/sim2sim/wedge/newton_1000.json
    PYTHONPATH=. python studies/sim2sim/sim2sim_wedge.py --robots 20 --steps 3000 --seed 1000 --settings mujoco \
        --out studies/sim2sim/wedge/mujoco_1000.json
    PYTHONPATH=. python studies/sim2sim/sim2sim_wedge.py --combine studies/sim2sim/wedge/*_100?.json \
        --out studies/sim2sim/wedge/results.json

Settings: ``newton_frame`` (the policy's own physics: collision detection once per 20 ms frame, 4 substeps),
``newton_substep`` (detection at every 5 ms step: ``sim.frame_dt 0.005, sim.substeps 1``), ``newton_mesh`` (the whole
terrain as one triangle mesh, ``terrain.collision mesh``), ``newton_boxes`` (every block a box, ``terrain.collision
boxes``, otherwise ``newton_frame``), ``newton_actuator_clamp`` (``newton_frame`` with the bundle's effort clamp: on
the actuators' force instead of the joints', ``SimConfig.effort_clamp`` "actuator"), ``newton_boxes_actuator_clamp`` (``newton_boxes``
with that clamp), ``mujoco`` (the bundle closed loop, every block a
box), ``mujoco_*``: the bundle closed loop with one option of its compiled model moved to Newton's training
physics (``MUJOCO``), and ``mujoco_stall_reflex`` / ``mujoco_stuck_lift``: the bundle as shipped with a way out for a
caught foot in its runtime (``STALL``; ``STUCK``, the runtime's stuck response).

Per round (each robot's first episode, up to ``--steps`` control steps): its end (success at 3 m, fell, off course,
still walking), x progress, stuck (still walking, less than 5 cm in the last 10 s) and wedged: stuck with a foot that
stayed within a 2 cm square over those 10 s while its centre is lower than the terrain on both sides of it along x, y
or a diagonal (the highest cell 1.3-3 cm away each side: the foot sits in a gap between two taller blocks). Foot centres: MuJoCo's
foot geoms, Newton's foot spheres (body pose x shape offset); heights from the course's height grid. MuJoCo also
reports the contact check of studies/sim2sim/sim2sim_side_by_side.py (two contacts of one foot with opposing horizontal
normals).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from hexnewton.config import RobotConfig
from hexnewton.kernels.reference import scale_actions_reference

POLICY = "results/policies/cpg_rl_complex.pt"
BUNDLE = "results/controllers/cpg_rl_complex"
TERRAIN = "rugged"
WINDOW = 500  # control steps (10 s at 20 ms)
STUCK_M = 0.05  # base progress over the window below which a walking robot is stuck [m]
HOLD_M = 0.02  # a foot's horizontal range over the window below which it is held [m]
FOOT_RADIUS = RobotConfig().foot_radius  # [m]
SUNK_M = 0.003  # how far a foot's bottom sits below both walls beside it for it to count as between them [m]
SETTINGS = {
    "newton_frame": {},
    "newton_substep": {"sim.frame_dt": 0.005, "sim.substeps": 1},
    "newton_mesh": {"terrain.collision": "mesh"},
    "newton_boxes": {"terrain.collision": "boxes"},
    # newton_frame and newton_boxes with the bundle's effort clamp (on the actuators: SimConfig.effort_clamp)
    "newton_actuator_clamp": {"sim.effort_clamp": "actuator"},
    "newton_boxes_actuator_clamp": {"terrain.collision": "boxes", "sim.effort_clamp": "actuator"},
    # newton_frame with the controller's stuck response at mujoco_stuck_lift's settings (STUCK; main sets them from
    # the --stuck_* options)
    "newton_stuck_lift": {},
}
#: C MuJoCo settings: the bundle's closed loop on its MJCF, with one model option moved to Newton's training physics
#: (``mujoco_variant``); the bundle's files stay as shipped
MUJOCO = {
    "mujoco": "the bundle's MJCF as shipped",
    "mujoco_solver": "solver iterations 10, line-search iterations 10, tolerance 1e-6 (mujoco_warp's, SimConfig's)",
    "mujoco_limits": "joint-limit solref from RobotConfig limit_ke / limit_kd as Newton's SolverMuJoCo converts them",
    "mujoco_actfrc": "effort limit as the joint's actuator-force range (Newton's) instead of the actuator's forcerange",
    "mujoco_newton": "mujoco_solver, mujoco_limits and mujoco_actfrc together",
    "mujoco_stall_reflex": "the bundle's MJCF as shipped; the runtime's targets with a stalled-swing reflex (STALL)",
    "mujoco_stuck_lift": "the bundle's MJCF as shipped; a robot that stops gaining ground lifts its knees (STUCK)",
}
#: ``mujoco_stuck_lift``: the runtime's stuck response (``CPGConfig.stuck_*``): a robot whose goal distance (odometry,
#: as the policy observes it) fell by less than ``progress`` m over the last ``window`` control steps walks the next
#: ``hold`` control steps with ``lift`` rad more knee amplitude A2 on every leg
STUCK = {"window": 100, "progress": 0.02, "hold": 50, "lift": 0.3}
#: ``mujoco_stall_reflex``: a leg in swing (its oscillator's dy >= 0) whose knee lags its target by more than ``lag``
#: rad at a substep is stalled: its hip target holds the hip's measured angle (no forward swing) and its knee target
#: rises by ``lift`` rad (clipped to the joint limit), so a caught foot is lifted before it swings on
STALL = {"lag": 0.3, "lift": 0.4}
#: mujoco_warp's solver settings in Newton (SimConfig iterations / ls_iterations; mujoco_warp's tolerance)
NEWTON_SOLVER = {"iterations": 10, "ls_iterations": 10, "tolerance": 1e-6}


LOGS: dict = {}  # per setting, the last 10 s of its log (saved beside --out as .npz)


#: the conjugate of a quaternion (x y z w) as a factor: R(q) v = R(q*)^T v (``quat_rotate_inv_np``)
CONJUGATE = np.array([-1.0, -1.0, -1.0, 1.0])


def wedge_rounds(base_x: np.ndarray, feet: np.ndarray, running: np.ndarray, heights, block: float) -> dict:
    """The stuck and wedged rounds at the end of the log. ``base_x`` (T, N) x progress, ``feet`` (T, N, F, 3) foot
    centres in the terrain frame, ``running`` (N,) still in the first episode at the end, ``heights(x, y)`` the
    terrain height (vectorised), ``block`` the block size [m]. A wall on one side of a foot along a direction: the
    highest terrain at 0.65, 1 and 1.5 blocks from its centre that way; a foot is between walls where its bottom
    (centre - FOOT_RADIUS) is more than SUNK_M below both sides' walls along x, y or a diagonal (a 24 mm foot resting
    on the edges of a 20 mm gap has its bottom 5.4 mm below them)."""
    t = base_x.shape[0]
    w = min(WINDOW, t - 1)
    stuck = running & (base_x[-1] - base_x[-1 - w] < STUCK_M)
    held = np.all(np.ptp(feet[-1 - w:, ..., :2], axis=0) < HOLD_M, axis=-1)  # (N, F)
    x, y, z = feet[-1, ..., 0], feet[-1, ..., 1], feet[-1, ..., 2]
    between = np.zeros_like(held)
    for ux, uy in ((1.0, 0.0), (0.0, 1.0), (0.7071, 0.7071), (0.7071, -0.7071)):
        side = [np.max([heights(x + s * d * block * ux, y + s * d * block * uy) for d in (0.65, 1.0, 1.5)], axis=0)
                for s in (1.0, -1.0)]
        between |= np.minimum(*side) - (z - FOOT_RADIUS) > SUNK_M
    foot = held & between
    wedged = stuck & foot.any(axis=1)
    return {"stuck": np.flatnonzero(stuck).tolist(), "wedged": np.flatnonzero(wedged).tolist(),
            "wedged_feet": {int(k): np.flatnonzero(foot[k]).tolist() for k in np.flatnonzero(wedged)}}


def summarize_rounds(ends: np.ndarray, x_end: np.ndarray, wedge: dict, steps: int, wall_s: float) -> dict:
    from hexnewton.mdp.status import STATUS_NAMES

    n = len(ends)
    return {"rounds": n, "control_steps": steps, "ended": {STATUS_NAMES[c]: int((ends == c).sum()) for c in
                                                         range(len(STATUS_NAMES)) if (ends == c).any()},
            "success": int((ends == 3).sum()), "fell": int((ends == 1).sum()), "off_course": int((ends == 2).sum()),
            "still_walking": int((ends == 0).sum()), "mean_x_m": round(float(np.mean(x_end)), 3),
            "stuck": len(wedge["stuck"]), "wedged": len(wedge["wedged"]), "stuck_rounds": wedge["stuck"],
            "wedged_rounds": wedge["wedged"], "wedged_feet": wedge["wedged_feet"], "wall_s": round(wall_s, 1)}


def first_episode(base_x: np.ndarray, feet: np.ndarray, status: np.ndarray):
    """Each round's end code, final x, and its arrays held at their last first-episode row after it ended."""
    t, n = status.shape
    ended = status != 0
    last = np.where(ended.any(axis=0), np.argmax(ended, axis=0), t - 1)
    ends = status[last, np.arange(n)]
    for k in range(n):
        base_x[last[k] + 1:, k] = base_x[last[k], k]
        feet[last[k] + 1:, k] = feet[last[k], k]
    return ends, base_x[last, np.arange(n)], ~ended.any(axis=0)


def newton_setting(name: str, robots: int, steps: int, seed: int) -> dict:
    import torch

    from hexnewton.analysis.rollout import CONTROLLERS, START_SEED_OFFSET, controller_policy, read_controller_checkpoint
    from hexnewton.learning.checkpoint import trained_config
    from hexnewton.mdp.env import make_env
    from hexnewton.kernels.reference import quat_rotate_inv_np
    from hexnewton.terrain.query import terrain_height_np
    from hexnewton.tasks import course

    t0 = time.perf_counter()
    ckpt = read_controller_checkpoint("cpg_rl", POLICY)
    cfg = course(TERRAIN, trained_config(ckpt), dict(SETTINGS[name]), robots, "cpu", seed,
                 seed=seed + START_SEED_OFFSET)
    env = make_env(cfg, CONTROLLERS["cpg_rl"])
    policy = controller_policy(env, "cpg_rl", POLICY, ckpt, False, False, None)
    m = env.world.model
    feet_idx = np.flatnonzero([str(s).endswith("_foot") for s in m.shape_label])
    body = m.shape_body.numpy()[feet_idx]
    offset = m.shape_transform.numpy()[feet_idx, :3]
    per = len(feet_idx) // robots
    xs, fs, sts = [], [], []
    obs = env.get_observations()
    with torch.inference_mode():
        for _ in range(steps):
            obs, _, _, _ = env.step(policy(obs))
            bq = env.world.state_0.body_q.numpy()[body]
            q = bq[:, 3:7]  # x y z w
            fs.append((bq[:, :3] + quat_rotate_inv_np(q * CONJUGATE, offset)).reshape(robots, per, 3))
            xs.append(env.last_q.numpy()[:, 0] - env.last_start.numpy()[:, 0])
            sts.append(env.status.numpy().copy())
    env.world.check_contacts()
    base_x, feet = np.stack(xs), np.stack(fs)
    ends, x_end, running = first_episode(base_x, feet, np.stack(sts))
    grid = env.world.terrain.grid
    wedge = wedge_rounds(base_x, feet, running, lambda x, y: terrain_height_np(grid, x, y), cfg.terrain.block_size)
    LOGS[name] = {"base_x": base_x[-WINDOW - 1:], "feet": feet[-WINDOW - 1:], "running": running}
    out = summarize_rounds(ends, x_end, wedge, steps, time.perf_counter() - t0)
    out["physics"] = {"frame_dt": cfg.sim.frame_dt, "substeps": cfg.sim.substeps, "collision": cfg.terrain.collision,
                      "effort_clamp": cfg.sim.effort_clamp}
    return out


def newton_limit_solref(m, ke: float, kd: float) -> np.ndarray:
    """The hinge joints' limit solref (timeconst, dampratio) that Newton's SolverMuJoCo writes for force-space limit
    gains ``ke`` / ``kd`` (``update_jnt_solref_from_invweight0_kernel``): both scaled by ``dof_invweight0 (1 - dmax)``,
    then timeconst = 2 / kd', dampratio = kd' / 2 / sqrt(ke')."""
    import mujoco

    hinge = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
    factor = m.dof_invweight0[m.jnt_dofadr[hinge]] * (1.0 - m.jnt_solimp[hinge, 1])
    ks, kds = ke * factor, kd * factor
    return np.stack([2.0 / kds, kds / 2.0 / np.sqrt(ks)], axis=1)


def mujoco_variant(m, name: str, robot: RobotConfig | None = None) -> None:
    """Move the compiled bundle model ``m`` to Newton's training physics in the way ``name`` says (``MUJOCO``)."""
    import mujoco

    robot = robot or RobotConfig()
    parts = ("mujoco_solver", "mujoco_limits", "mujoco_actfrc") if name == "mujoco_newton" else (name,)
    if "mujoco_solver" in parts:
        for k, v in NEWTON_SOLVER.items():
            setattr(m.opt, k, v)
    hinge = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
    if "mujoco_limits" in parts:
        m.jnt_solref[hinge] = newton_limit_solref(m, robot.limit_ke, robot.limit_kd)
    if "mujoco_actfrc" in parts:
        m.actuator_forcelimited[:] = 0
        m.jnt_actfrclimited[hinge] = 1
        m.jnt_actfrcrange[hinge] = (-robot.effort_limit, robot.effort_limit)


def stall_reflex(r, lag: float, lift: float) -> dict:
    """Wrap the runtime controller's ``substep`` in ``r`` so that its joint targets carry the stalled-swing reflex
    (``STALL``), on the joint readings of the same substep; returns its counters (substeps x legs stalled, substeps x
    legs in swing)."""
    counts = {"stalled_leg_substeps": 0, "swing_leg_substeps": 0}
    osc = np.arange(6) % 2
    knee_upper = float(np.asarray(r.ctrl.joint_upper, np.float64).reshape(-1, 3)[0, 1])
    substep = r.ctrl.substep

    def with_reflex(base_quat=None) -> np.ndarray:
        t = substep(base_quat).reshape(r.n, 6, 3)
        q = r.sensors()["joint_pos"].reshape(r.n, 6, 3)  # the readings mj_step1 just took
        swing = r.ctrl.dy[:, osc] >= 0.0
        stalled = swing & (t[..., 1] - q[..., 1] > lag)
        t[..., 0] = np.where(stalled, q[..., 0], t[..., 0])
        t[..., 1] = np.where(stalled, np.minimum(t[..., 1] + lift, knee_upper), t[..., 1])
        counts["stalled_leg_substeps"] += int(stalled[r.alive].sum())
        counts["swing_leg_substeps"] += int(swing[r.alive].sum())
        return t.reshape(r.n, 18)

    r.ctrl.substep = with_reflex
    return counts


def stuck_response(r, window: int, progress: float, hold: int, lift: float) -> dict:
    """Turn on the runtime's stuck response (``CPGConfig.stuck_*``, ``hexnewton.deploy.runtime``) in the controller of
    ``r`` with ``STUCK``'s settings, as a bundle exported with them would have it; returns its counters (control steps
    x robots in the response, responses started), counted as ``Rounds.control_step`` calls ``set_actions``."""
    counts = {"responding_robot_steps": 0, "responses": 0}
    c = r.ctrl
    c.stuck = {"lift": lift, "window": window, "progress": progress, "hold": hold}
    c.stuck_history = np.zeros((r.n, window))
    set_actions = c.set_actions

    def counted(actions, target=None) -> None:
        before = c.stuck_left.copy()
        set_actions(actions, target)
        on = r.alive & np.any(c.target != scale_actions_reference(actions, c.lower, c.upper), axis=1)
        counts["responding_robot_steps"] += int(on.sum())
        counts["responses"] += int((on & (before == 0)).sum())

    c.set_actions = counted
    return counts


#: the C MuJoCo settings with a way out for a caught foot: the function that turns it on and its settings
RESPONSES = {"mujoco_stall_reflex": (stall_reflex, STALL), "mujoco_stuck_lift": (stuck_response, STUCK)}


def mujoco_setting(name: str, robots: int, steps: int, seed: int) -> dict:
    import mujoco

    from hexnewton.analysis.sim2sim import Rounds
    from hexnewton.terrain.query import terrain_height_np

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from sim2sim_side_by_side import wedged_feet

    t0 = time.perf_counter()
    r = Rounds(BUNDLE, TERRAIN, robots, seed)
    way_out = RESPONSES.get(name)  # a way out for a caught foot in the runtime, and its settings
    counts = way_out[0](r, **way_out[1]) if way_out else None
    mujoco_variant(r.m, name)
    names = [mujoco.mj_id2name(r.m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(r.m.ngeom)]
    feet_idx = [[g for g, s in enumerate(names) if s.startswith(f"r{k}_") and s.endswith("_foot")]
                for k in range(robots)]
    fs = []
    r_run = r.run(steps, lambda rr: fs.append(rr.d.geom_xpos[np.array(feet_idx)].copy()))
    base_x = np.nan_to_num(r_run["pos"][..., 0], nan=0.0)
    feet = np.stack(fs)
    ends, x_end, running = first_episode(base_x, feet, r_run["status"])
    wedge = wedge_rounds(base_x, feet, running, lambda x, y: terrain_height_np(r.grid, x, y), 0.02)
    LOGS[name] = {"base_x": base_x[-WINDOW - 1:], "feet": feet[-WINDOW - 1:], "running": running}
    out = summarize_rounds(ends, x_end, wedge, len(fs), time.perf_counter() - t0)
    out["contact_wedged_of_stuck"] = wedged_feet(r, wedge["stuck"])
    if way_out:
        out["response"] = {**way_out[1], **counts}
    out["physics"] = {"change": MUJOCO[name], "iterations": int(r.m.opt.iterations),
                      "ls_iterations": int(r.m.opt.ls_iterations), "tolerance": float(r.m.opt.tolerance),
                      "hinge_limit_solref_first_leg": r.m.jnt_solref[1:4].round(5).tolist(),
                      "actuator_forcelimited": bool(r.m.actuator_forcelimited.any()),
                      "joint_actfrclimited": bool(r.m.jnt_actfrclimited.any())}
    return out


COUNTS = ("rounds", "success", "fell", "off_course", "still_walking", "stuck", "wedged", "contact_wedged_of_stuck")


def combine(paths: list[str]) -> dict:
    """Per setting, the counts of the runs in ``paths`` (their JSON) summed, with each run's terrain seed."""
    out: dict = {"runs": []}
    for path in paths:
        with open(path) as f:
            run = json.load(f)
        out["runs"].append({"file": path, "command": run["command"], "terrain_seed": run["terrain_seed"]})
        for s in [k for k, v in run.items() if isinstance(v, dict) and "rounds" in v]:  # settings, labelled or not
            tot = out.setdefault(s, {k: 0 for k in COUNTS if k in run[s]})
            for k in COUNTS:
                if k in tot:
                    tot[k] += run[s][k]
            tot.setdefault("terrain_seeds", []).append(run["terrain_seed"])
    return out


def main() -> None:
    global POLICY, BUNDLE
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robots", type=int, default=20)
    p.add_argument("--steps", type=int, default=2000, help="control steps per round (20 ms each)")
    p.add_argument("--seed", type=int, default=1000, help="terrain seed (starts: seed + 1000), as the evaluation's")
    p.add_argument("--settings", nargs="+", default=[*SETTINGS, "mujoco"], choices=[*SETTINGS, *MUJOCO])
    p.add_argument("--combine", nargs="+", metavar="JSON", help="sum the counts of these runs' files into --out")
    p.add_argument("--policy", default=POLICY, help="the policy checkpoint for the Newton settings")
    p.add_argument("--bundle", default=BUNDLE, help="its controller bundle for the C MuJoCo settings")
    p.add_argument("--stall_lag", type=float, default=STALL["lag"], help="mujoco_stall_reflex: knee lag [rad]")
    p.add_argument("--stall_lift", type=float, default=STALL["lift"], help="mujoco_stall_reflex: extra knee lift [rad]")
    p.add_argument("--stuck_lift", type=float, default=STUCK["lift"],
                   help="*_stuck_lift: extra knee amplitude [rad]")
    p.add_argument("--stuck_hold", type=int, default=STUCK["hold"],
                   help="*_stuck_lift: control steps of the response")
    p.add_argument("--stuck_window", type=int, default=STUCK["window"], help="*_stuck_lift: control steps watched")
    p.add_argument("--stuck_progress", type=float, default=STUCK["progress"],
                   help="*_stuck_lift: goal distance gained over the window below which a robot is stuck [m]")
    p.add_argument("--label", help="keep each setting's counts as SETTING:LABEL (one setting under different "
                   "parameters side by side in --combine)")
    p.add_argument("--out", required=True)
    a = p.parse_args()
    STALL.update(lag=a.stall_lag, lift=a.stall_lift)
    STUCK.update(lift=a.stuck_lift, hold=a.stuck_hold, window=a.stuck_window, progress=a.stuck_progress)
    SETTINGS["newton_stuck_lift"] = {f"cpg.stuck_{k}": v for k, v in STUCK.items()}
    POLICY, BUNDLE = a.policy, a.bundle  # read by newton_setting and mujoco_setting
    if a.combine:
        missing = [f for f in a.combine if not os.path.isfile(f)]
        if missing:
            p.error(f"no such file: {missing[0]}")
        res = {"command": "PYTHONPATH=. python studies/sim2sim/sim2sim_wedge.py " + " ".join(sys.argv[1:]), **combine(a.combine)}
        with open(a.out, "w") as f:
            json.dump(res, f, indent=1)
        return
    if a.robots < 1 or a.steps <= WINDOW:
        p.error(f"--robots must be >= 1 and --steps > {WINDOW} (the 10 s window)")
    if not os.path.isfile(a.policy) or not os.path.isdir(a.bundle):
        p.error(f"no policy file {a.policy} or no bundle folder {a.bundle}")
    res = {"command": "PYTHONPATH=. python studies/sim2sim/sim2sim_wedge.py " + " ".join(sys.argv[1:]), "terrain": TERRAIN,
           "terrain_seed": a.seed, "start_seed": a.seed + 1000,
           "policy": POLICY, "bundle": BUNDLE}
    for s in a.settings:
        key = f"{s}:{a.label}" if a.label else s
        res[key] = (mujoco_setting(s, a.robots, a.steps, a.seed) if s in MUJOCO
                    else newton_setting(s, a.robots, a.steps, a.seed))
        print(key, json.dumps(res[key]), flush=True)
        os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
        with open(a.out, "w") as f:
            json.dump(res, f, indent=1)
        np.savez_compressed(os.path.splitext(a.out)[0] + ".npz",
                            **{f"{k}_{n}": v for k, log in LOGS.items() for n, v in log.items()})


if __name__ == "__main__":
    main()
