"""Sim2sim: a controller bundle walks in C MuJoCo, closed loop through the robot runtime, on the paper's terrains.

    python -m hexnewton.apps.sim2sim results/controllers/cpg_rl_complex --terrains rugged stepped complex --rounds 100 \\
        --out DIR
    python -m hexnewton.apps.sim2sim BUNDLE --terrains rugged --rounds 300 --workers 0 --out /tmp/s2s  # every core
    python -m hexnewton.apps.sim2sim BUNDLE --terrains rugged --rounds 1 --video walk.mp4 --out /tmp/s2s  # one round filmed
    python -m hexnewton.apps.sim2sim BUNDLE --terrains complex --rounds 1 --viewer --out /tmp/s2s         # MuJoCo's viewer
    python -m hexnewton.apps.sim2sim NAV_BUNDLE --terrains flat --rounds 100 --waypoints 2,0 2,2 0,2 0,0 \
        --newton eval/navigate/results.json --out /tmp/s2s_square                     # a waypoint course, as Newton's

The robot and the terrain are a MuJoCo model written from the project's descriptions (:mod:`hexnewton.deploy.mjcf`), or
a robot's own MJCF file on that terrain (``--mjcf``, below): MuJoCo's own collision detection and solver, every step.
Per control step (``control_dt`` of the bundle) the loop does what the robot's computer does with
:class:`hexnewton.deploy.runtime.Controller`:
- reads the 18 joint encoders and velocities and the IMU's quaternion and gyro (MuJoCo sensors), the base position
  (the free joint's coordinates, as odometry gives it) for the goal in the heading frame
  (:func:`deploy.target_in_heading_frame`, the goal's ground from the height scanner), and the terrain reading: the
  highest terrain within +-30 cm of the base minus the ground under it, from vertical ray casts at the 1 cm cells of
  that window (:class:`HeightScanner`);
- ``observe`` -> ``act`` (policy.onnx) -> ``set_actions``; then every ``substep_dt`` ``Controller.substep`` with the
  IMU's latest quaternion, whose 18 joint targets the position servos track during the next MuJoCo step.

A round is one robot's first episode with the evaluation's protocol (:mod:`hexnewton.apps.evaluate`, :func:`rollout.
run_rounds`): terrain seed S (default 1000), robot k in lane y_k of ``linspace(-0.5, 0.5, rounds)`` with a start
drawn from seed S + 1000 (+-0.1 m across, +-0.2 rad yaw, +-0.05 rad per joint), the goal 3.5 m ahead, the episode's
ends of ``TaskConfig`` (fall: torso below 5 cm over the ground or tilted past 60 deg; off course: 1.5 m sideways;
goal within 0.5 m; 7000 steps). All rounds run at once as robots of one model that touch the terrain but not each
other; a finished robot is parked out of the way. ``--workers N`` splits a terrain's rounds into N consecutive ranges,
each a model of its own in a process of its own (0: one per core), the same rounds on more cores (a film or the
viewer runs its terrain in one process). Metrics: :mod:`hexnewton.analysis.metrics`, as for Newton.

``--mjcf own|generated``: the model of the robot. ``own`` runs the robot's own MJCF file as written (its bodies,
geoms, actuators and joint senses; :mod:`hexnewton.deploy.robot_mjcf`) on the course; ``generated`` the model written
from the bundle's description. The default is ``own`` for a robot read from an MJCF file: the file is the user's
MuJoCo model of the robot, the one the rest of their MuJoCo work runs, and the policy meeting it is the stronger
check; ``generated`` (every other robot's model) isolates what the simulators differ in, on the very description
Newton trained. The file is ``--robot FILE.xml``'s, else the one the description was read from; where that is not
here (or no longer that robot, or not driven by position servos), the default runs the generated model and says so in
one line; ``--mjcf own`` then is an error. The fixed CPG walks the same model.

``--waypoints X,Y ...``: each round walks that waypoint course in its start frame instead (the goals in turn, the last
one's reaching ending the round), on the navigate tasks' square patch with every start heading and no off-course end,
as Newton's navigation evaluation (``evaluate --navigate``) walks its 2 m square: the runtime keeps each robot's goal
(``Controller.set_goal``) and forms the target from its pose. Scored as the completion rate, the time, the goals
reached and the falls; ``--newton`` then takes a navigation evaluation's ``results.json`` (its ``square`` of
``cpg_rl``); the fixed CPG runs only on ``--fixed_terrains`` given.

Outputs in ``--out`` (which must not exist): ``results.json`` (``{terrain: metrics}`` of the bundle), ``details.json``
(the fixed CPG's rounds, the Newton reference numbers, the command, versions) and ``report.md``. The fixed CPG
(``CPGConfig().fixed_params()`` through the same runtime maths, :func:`fixed_cpg_spec`) runs on ``--fixed_terrains``.
"""

from __future__ import annotations

import json
import os
import sys
import time

from hexnewton.analysis.report import ended_cell
from hexnewton.analysis.rollout import EVAL_TERRAIN_SEED, START_SEED_OFFSET
from hexnewton.analysis.sim2sim import Film, Viewer, bundle_model, fixed_cpg_spec, measure
from hexnewton.apps.cli import (
    ArgumentParser,
    add_mjcf_arg,
    add_robot_args,
    check_writable,
    positive_int,
    robot_from_args,
    run,
    terrain_name,
    waypoint,
)
from hexnewton.config import TaskConfig

PROG = "python -m hexnewton.apps.sim2sim"
#: the keys results.json carries per terrain (hexnewton.analysis.metrics' names)
HEADLINE = ("rounds", "success_3m", "fall_rate", "pitch_var_deg2", "roll_var_deg2", "pitch_p999_deg", "roll_p999_deg")
NEWTON_REFERENCE = "studies/stable_gait/results.json"


def newton_reference(path: str | None) -> dict:
    """The committed Newton numbers ``{"cpg_rl" | "cpg": {terrain: summary}}`` of an evaluation: ``evaluate``'s own
    results.json (its ``results``) or a study's (its ``test`` section, as studies/stable_gait's), with the file and
    the policy they were measured for."""
    if not path:
        return {}
    with open(path) as f:
        data = json.load(f)
    meta = data.get("meta", {})
    test = data.get("test") or data.get("results") or data
    out = {"file": path, "policy": data.get("policy", meta.get("checkpoint")), "commands": data.get("commands"),
           "device": data.get("device", meta.get("device"))}  # fmt: skip
    for terrain, per in test.items():
        for ctrl in ("cpg_rl", "cpg"):
            if isinstance(per, dict) and ctrl in per:
                out.setdefault(ctrl, {})[terrain] = per[ctrl]
    return out


#: What differs between the two simulators besides the engine itself (docs/deployment.md explains each).
MODEL_DIFFERENCES = (
    "collision: MuJoCo's own detection at every 5 ms step, every 2 cm block and every tread a box (sphere-box, "
    "capsule-box contacts); training: Newton's collision pipeline once per 20 ms frame (contacts re-evaluated at its 4 "
    "substeps, 5 mm detection gap) on boxes for the treads and one triangle mesh of the blocks",
    "contact: the same soft contact on both sides (solref 0.02 s / damping ratio 1, solimp 0.9-0.95, friction 0.9, "
    "pyramidal cone, condim 3, no margin; read from the training world's mujoco_warp model)",
    "joint limits: MuJoCo's default limit constraint (solref 0.02 s, ratio 1); training: Newton's 1000 N m/rad, "
    "10 N m s/rad limit spring as solref ~(0.021 s, 0.49); the CPG's targets stay inside the limits",
    "solver: Newton solver and implicitfast at 5 ms on both sides; MuJoCo's 100-iteration cap against training's 10 "
    "does not bind (MuJoCo converges in ~2 iterations per step, studies/sim2sim/sim2sim_side_by_side.py)",
    "sensing: encoders, IMU quaternion and odometry are MuJoCo's exact values (as training's noise-free evaluation); "
    "the terrain reading comes from ray casts, equal to training's grid query at the same cells",
    "starts: the same lanes, offsets, yaw and joint noise ranges, drawn by NumPy from the start seed where Newton "
    "draws with Warp's generator (same distribution, not the same draws)",
)


def _fmt(v, kind: str) -> str:
    if v is None:
        return "—"
    return f"{100 * v:.1f} %" if kind == "pct" else f"{v:.1f}"


def comparison_rows(label: str, mine: dict, newton: dict) -> list[str]:
    """Markdown table rows, one per terrain: MuJoCo's number / Newton's for each headline metric."""
    rows = []
    for terrain, m in mine.items():
        n = newton.get(terrain, {})
        cells = [f"{_fmt(m.get(k), kind)} / {_fmt(n.get(k), kind)}" for k, kind in (
            ("success_3m", "pct"), ("fall_rate", "pct"), ("pitch_var_deg2", "x"), ("roll_var_deg2", "x"),
            ("pitch_p999_deg", "x"), ("roll_p999_deg", "x"), ("time_to_3m_s", "x"))]  # fmt: skip
        ended = ended_cell(m, 3.0)
        rows.append(f"| {terrain} | {label} | {m['rounds']} / {n.get('rounds', '—')} | " + " | ".join(cells)
                    + f" | {ended} |")
    return rows


def target_lines(bundle_res: dict, fixed_res: dict, newton: dict) -> list[str]:
    """The issue's targets, each with its measured value and whether it holds."""
    out = []
    for terrain, m in bundle_res.items():
        ok = m["success_3m"] >= 0.9 and m["fall_rate"] <= 0.02
        out.append(f"- bundle on {terrain}: {100 * m['success_3m']:.0f} % at 3 m (>= 90 %), falls "
                   f"{100 * m['fall_rate']:.0f} % (<= 2 %): **{'met' if ok else 'not met'}**")
    for terrain, m in fixed_res.items():
        n = newton.get("cpg", {}).get(terrain)
        if not n:
            continue
        d_s = 100 * (m["success_3m"] - n["success_3m"])
        r_p = m["pitch_var_deg2"] / n["pitch_var_deg2"] - 1
        r_r = m["roll_var_deg2"] / n["roll_var_deg2"] - 1
        ok = abs(d_s) <= 10 and abs(r_p) <= 0.25 and abs(r_r) <= 0.25
        out.append(f"- fixed CPG on {terrain}: success {d_s:+.1f} points (within 10), pitch variance "
                   f"{100 * r_p:+.0f} %, roll variance {100 * r_r:+.0f} % (within 25 %) of Newton's: "
                   f"**{'met' if ok else 'not met'}**")
    return out


def report_markdown(bundle: str, bundle_res: dict, fixed_res: dict, newton: dict, meta: dict) -> str:
    head = "| terrain | controller | rounds | 3 m | falls | pitch var [deg²] | roll var [deg²] | \\|pitch\\| p99.9 " \
           "[deg] | \\|roll\\| p99.9 [deg] | time to 3 m [s] | ended (MuJoCo) |"
    lines = [f"# Sim2sim: `{bundle}` in C MuJoCo, closed loop through the robot runtime", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()]
    lines += ["", "## Targets", ""] + target_lines(bundle_res, fixed_res, newton)
    src = newton.get("file")
    lines += ["", "## MuJoCo / Newton", "",
              f"Each cell: MuJoCo (this run) / Newton (`{src}`: {newton.get('device')}, policy "
              f"{newton.get('policy')}, the same terrain and start seeds with 1000 rounds per terrain)." if src else
              "Each cell: MuJoCo (this run) / — (no Newton reference given).", "", head,
              "|---|---|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    lines += comparison_rows("bundle (CPG_RL)", bundle_res, newton.get("cpg_rl", {}))
    lines += comparison_rows("fixed CPG", fixed_res, newton.get("cpg", {}))
    if newton.get("commands"):
        lines += ["", "Newton's commands:", ""] + [f"- {k}: `{v}`" for k, v in newton["commands"].items()
                                                    if k.startswith("test")]  # fmt: skip
    lines += ["", "## What differs between the two simulators", ""] + [f"- {d}" for d in MODEL_DIFFERENCES]
    lines += ["", "How the loop is built and what the differences do: docs/deployment.md (\"Sim2sim\")."]
    return "\n".join(lines) + "\n"


def headline(summary: dict) -> dict:
    """results.json's entry for one terrain (hexnewton.analysis.metrics' names)."""
    return {k: summary[k] for k in HEADLINE}


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog=PROG, description="Closed-loop rounds of a controller bundle in C MuJoCo, beside Newton's.")
    p.add_argument("bundle", help="a controller bundle folder (python -m hexnewton.apps.export)")
    p.add_argument("--terrains", nargs="+", type=terrain_name, default=["rugged", "stepped", "complex"])
    p.add_argument("--rounds", type=positive_int, default=100, help="rounds per terrain (robots, one episode each)")
    p.add_argument("--out", required=True, help="output folder (must not exist)")
    p.add_argument("--seed", type=int, default=EVAL_TERRAIN_SEED, help="terrain seed; starts use seed + 1000")
    p.add_argument("--max_steps", type=positive_int, default=TaskConfig.max_episode_steps)
    p.add_argument("--fixed_terrains", nargs="*", type=terrain_name, default=None,
                   help="terrains for the fixed CPG (default rugged; with --waypoints none; empty: skip it)")  # fmt: skip
    p.add_argument("--waypoints", nargs="+", type=waypoint, metavar="X,Y",
                   help="each round walks this waypoint course in its start frame [m] (e.g. 2,0 2,2 0,2 0,0), as "
                        "evaluate --navigate's square")  # fmt: skip
    p.add_argument("--newton", default=NEWTON_REFERENCE, help="a Newton evaluation's results.json ('none': skip)")
    p.add_argument("--video", metavar="PATH.mp4", help="film robot 0 of the first terrain's bundle rounds")
    p.add_argument("--viewer", action="store_true", help="show robot 0 in MuJoCo's interactive viewer")
    p.add_argument("--workers", type=int, default=1,
                   help="processes per terrain, each a consecutive range of the rounds (0: one per core)")
    add_mjcf_arg(p)
    add_robot_args(p, "the bundle's (its controller.json's description; the fixed CPG walks it too)")
    args = p.parse_args(argv)
    if args.workers < 0:
        raise ValueError(f"--workers must be 0 (one per core) or more, got {args.workers}")
    args.workers = args.workers or os.cpu_count() or 1
    args.argv = list(sys.argv[1:] if argv is None else argv)
    if args.fixed_terrains is None:
        args.fixed_terrains = [] if args.waypoints else ["rugged"]
    if os.path.exists(args.out):
        raise ValueError(f"--out {args.out} exists already (nothing is overwritten)")
    # the fixed CPG walks the bundle's robot, on the same model
    args.robot_cfg, args.mjcf_file = bundle_model(args.bundle, robot_from_args(args), args.mjcf)
    if args.video:
        check_writable(args.video, ".mp4")
        os.environ.setdefault("MUJOCO_GL", "egl")
    newton_path = None if args.newton.lower() == "none" else args.newton
    if newton_path and not os.path.isfile(newton_path):
        if args.newton != NEWTON_REFERENCE:
            raise ValueError(f"--newton {args.newton}: no such file")
        newton_path = None
    if args.waypoints:
        return run_waypoints(args, None if args.newton == NEWTON_REFERENCE else newton_path)
    return run_all(args, newton_reference(newton_path))


def model_words(path: str | None) -> str:
    """The report's words for the model that ran."""
    return f"the robot's own MJCF file `{path}`" if path else "written from the bundle's description"


def run_all(args, newton: dict) -> int:
    """The rounds of the bundle and the fixed CPG, then results.json, details.json and report.md in ``args.out``."""
    import mujoco

    t0 = time.perf_counter()
    bundle_res, fixed_res = {}, {}
    for i, terrain in enumerate(args.terrains):
        hook = (Film(args.video) if args.video else Viewer() if args.viewer else None) if i == 0 else None
        try:
            bundle_res[terrain] = measure(args.bundle, terrain, args.rounds, args.seed, args.max_steps, hook,
                                          1 if hook is not None else args.workers, mjcf=args.mjcf_file)
        finally:
            if hook is not None:
                hook.close()
        print(_line("bundle", terrain, bundle_res[terrain]), flush=True)
    for terrain in args.fixed_terrains:
        fixed_res[terrain] = measure(fixed_cpg_spec(robot=args.robot_cfg), terrain, args.rounds, args.seed,
                                     args.max_steps, workers=args.workers, mjcf=args.mjcf_file)
        print(_line("fixed CPG", terrain, fixed_res[terrain]), flush=True)
    from hexnewton.analysis.report import git_rev

    cmd = f"{PROG} " + " ".join(args.argv)
    meta = {"command": f"`{cmd}`", "MuJoCo": mujoco.__version__, "git": git_rev(),
            "rounds per terrain": args.rounds, "model": model_words(args.mjcf_file),
            "terrain seed / start seed": f"{args.seed} / {args.seed + START_SEED_OFFSET}",
            "machine": f"CPU ({os.cpu_count()} cores, {args.workers} worker processes)",
            "wall time": f"{time.perf_counter() - t0:.0f} s"}  # fmt: skip
    os.makedirs(args.out)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({t: headline(s) for t, s in bundle_res.items()}, f, indent=1)
    with open(os.path.join(args.out, "details.json"), "w") as f:
        json.dump({"meta": meta, "bundle": bundle_res, "fixed_cpg": fixed_res,
                   "fixed_cpg_spec": fixed_cpg_spec(robot=args.robot_cfg), "newton": newton}, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(args.bundle, bundle_res, fixed_res, newton, meta))
    print(f"wrote {args.out}/report.md, results.json, details.json")
    return 0


def newton_square(path: str | None) -> dict:
    """``{terrain: summary}`` of the square in a navigation evaluation's results.json (``evaluate --navigate``: its
    ``cpg_rl``'s), with the file; empty without one."""
    if not path:
        return {}
    with open(path) as f:
        data = json.load(f)
    out = {t: per["cpg_rl"]["square"] for t, per in data.get("results", {}).items()
           if isinstance(per, dict) and "square" in per.get("cpg_rl", {})}  # fmt: skip
    if not out:
        raise ValueError(f"--newton {path}: no navigation evaluation of cpg_rl (evaluate --navigate) in it")
    return dict(out, file=path, meta=data.get("meta", {}))


def run_waypoints(args, newton_path: str | None) -> int:
    """The waypoint rounds of the bundle (and the fixed CPG on ``--fixed_terrains``): results.json, details.json and
    report.md in ``args.out``, MuJoCo's completion beside Newton's where ``--newton`` gives it."""
    import mujoco

    from hexnewton.analysis.report import git_rev

    newton = newton_square(newton_path)
    t0, bundle_res, fixed_res = time.perf_counter(), {}, {}
    for terrain in args.terrains:
        bundle_res[terrain] = measure(args.bundle, terrain, args.rounds, args.seed, args.max_steps,
                                      workers=args.workers, waypoints=args.waypoints, mjcf=args.mjcf_file)  # fmt: skip
        print(_waypoint_line("bundle", terrain, bundle_res[terrain]), flush=True)
    for terrain in args.fixed_terrains:
        fixed_res[terrain] = measure(fixed_cpg_spec(robot=args.robot_cfg), terrain, args.rounds, args.seed,
                                     args.max_steps, workers=args.workers, waypoints=args.waypoints,
                                     mjcf=args.mjcf_file)  # fmt: skip
        print(_waypoint_line("fixed CPG", terrain, fixed_res[terrain]), flush=True)
    course = " ".join(f"({x:g}, {y:g})" for x, y in args.waypoints)
    meta = {"command": f"`{PROG} " + " ".join(args.argv) + "`", "MuJoCo": mujoco.__version__, "git": git_rev(),
            "waypoints (start frame)": course, "rounds per terrain": args.rounds,
            "model": model_words(args.mjcf_file),
            "terrain seed / start seed": f"{args.seed} / {args.seed + START_SEED_OFFSET}",
            "wall time": f"{time.perf_counter() - t0:.0f} s"}  # fmt: skip
    os.makedirs(args.out)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({t: s["waypoints"] for t, s in bundle_res.items()}, f, indent=1)
    with open(os.path.join(args.out, "details.json"), "w") as f:
        json.dump({"meta": meta, "bundle": bundle_res, "fixed_cpg": fixed_res, "newton": newton}, f, indent=1)
    lines = [f"# Sim2sim: `{args.bundle}` through the waypoints {course} in C MuJoCo", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()] + ["", "MuJoCo (this run) / Newton (" + (
        f"`{newton['file']}`" if newton else "none given") + "):", "",
        "| terrain | controller | rounds | completed | time [s] | goals reached | falls | within 5 points |",
        "|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for label, res in (("bundle (CPG_RL)", bundle_res), ("fixed CPG", fixed_res)):
        for terrain, s in res.items():
            m, n = s["waypoints"], newton.get(terrain, {}) if label.startswith("bundle") else {}
            gap = "—" if not n else ("yes" if abs(m["completed"] - n["completed"]) <= 0.05 else "no")
            lines.append(f"| {terrain} | {label} | {m['rounds']} / {n.get('rounds', '—')} | "
                         f"{_fmt(m['completed'], 'pct')} / {_fmt(n.get('completed'), 'pct')} | {_fmt(m['time_s'], 'x')} / "
                         f"{_fmt(n.get('time_s'), 'x')} | {_fmt(m['corners'], 'x')} / {_fmt(n.get('corners'), 'x')} | "
                         f"{_fmt(m['fall_rate'], 'pct')} / {_fmt(n.get('fall_rate'), 'pct')} | {gap} |")  # fmt: skip
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {args.out}/report.md, results.json, details.json")
    return 0


def _waypoint_line(label: str, terrain: str, s: dict) -> str:
    w = s["waypoints"]
    return (f"{label} on {terrain}: {w['rounds']} rounds through the waypoints, completed {100 * w['completed']:.0f} %, "
            f"falls {100 * w['fall_rate']:.0f} %, {s['control_steps']} control steps in {s['wall_s']:.0f} s")


def _line(label: str, terrain: str, s: dict) -> str:
    return (f"{label} on {terrain}: {s['rounds']} rounds, {100 * s['success_3m']:.0f} % at 3 m, falls "
            f"{100 * s['fall_rate']:.0f} %, pitch / roll var {s['pitch_var_deg2']:.1f} / {s['roll_var_deg2']:.1f} "
            "deg², "
            f"{s['control_steps']} control steps in {s['wall_s']:.0f} s")


if __name__ == "__main__":
    sys.exit(run(main, PROG))
