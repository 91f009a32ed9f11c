"""The paper's evaluation (§3.3-3.4): success at 0.5 / 1 / 2 / 3 m, stability, trajectories, and a report.

    python -m hexnewton.apps.evaluate --controllers cpg cpg_rl --checkpoint cpg_rl=results/policies/cpg_rl_rugged.pt \\
        --terrains rugged stepped complex --rounds 25 --out eval/paper
    python -m hexnewton.apps.evaluate ... --checkpoint cpg_rl:rugged=A.pt cpg_rl:stepped=B.pt   # one policy per terrain
    python -m hexnewton.apps.evaluate ... --runs cpg_rl=logs/.../run joint=logs/.../run       # adds Fig. 5a
    python -m hexnewton.apps.evaluate ... --sweep terrain.step_rise 0.06 0.08 0.10          # a capability curve
    python -m hexnewton.apps.evaluate ... --sweep default                                   # the default set of curves
    python -m hexnewton.apps.evaluate --controllers cpg --robot mx_phoenix --terrains rugged  # another robot
    python -m hexnewton.apps.evaluate ... --sweep step_rise --no-nominal                    # one of them, alone
    python -m hexnewton.apps.evaluate --navigate --controllers cpg_rl --checkpoint cpg_rl=NAV.pt --terrains flat \
        --rounds 1000 --out eval/navigate     # goals at 8 bearings and the 2 m square (hexnewton.analysis.navigation)

Protocol. A round is one robot walking toward the target 3.5 m ahead, from its own start pose, until its
first episode ends (goal, fall, off course) or the episode limit (``TaskConfig.max_episode_steps``,
7000 steps = 140 s). R rounds run as R robots in parallel; a deterministic policy acts in every round
(``--stochastic``: it samples its actions from its Gaussian as in training; see RESULTS.md).
The robots use terrain seed ``EVAL_TERRAIN_SEED`` and reset seed ``EVAL_RESET_SEED`` (``--seed S``: S and S + 1000,
a validation set for choosing among checkpoints before the one test-set report). Training uses
``train.py`` with terrain seed 0 and seed 1 by default, so both the ground and the start poses (lane,
±0.1 m, ±0.2 rad yaw, ±0.05 rad joints) are unseen.

A round *reaches* d metres when the robot's x progress from its start is >= d at some control step before
its episode ended by a fall, by leaving |y - y_start| <= 1.5 m, or by a non-finite state (§3.4, Table 3).
The goal circle (0.5 m around x = 3.5 m) lies beyond x = 3 m, so success implies 3 m.

Stability (§3.3, Figs. 6-8): roll and pitch in degrees over every control step of every round's episode,
as a mean, a variance and a peak |angle|; the Y deviation as each round's largest |y - y_start|; the time to
each distance. Outputs in ``--out``:
- ``report.md`` (Table 3's shape, the paper's numbers beside ours, then stability);
- ``results.json`` (every number);
- ``fig_<terrain>.png`` (Figs. 6-8: pitch and roll over time for round 0, box plots over all rounds, XY
  trajectories);
- ``fig_params.png`` (Fig. 5b: CPG_RL's parameters against the fixed CPG's along round 0);
- ``fig_learning.png`` (Fig. 5a: reward against env-steps and against wall time) with ``--runs``;
- ``fig_sweep_<name>.png`` and a table per ``--sweep``: success at the last distance and falls against the swept
  value for every controller, also under ``sweeps`` in ``results.json`` (one entry per value: rounds, success, time,
  falls, pitch / roll variance and p99.9). A sweep point is the course with one field at one value
  (:func:`hexnewton.analysis.rollout.sweep_overrides`, the mechanism of ``--perturbations`` and ``--env.*``).

``--navigate``: the navigation evaluation instead (:mod:`hexnewton.analysis.navigation`): ``--rounds`` rounds at each
of 8 bearings (a goal at 2 m) and ``--rounds`` rounds of the 2 m waypoint square per controller and terrain, on the
navigate tasks' square patch; ``report.md``, ``results.json`` and ``fig_paths_<terrain>_<controller>.png``, the top view
of the paths. ``--max_steps`` defaults to 1500 (a goal) and 4000 (the square) steps on flat ground, 3000 and 12000
elsewhere (``analysis.navigation.NAVIGATION_STEPS``: the robot's pace on the blocks) there.

Controllers: ``cpg`` (fixed parameters), ``cpg_rl`` and ``joint`` (rsl-rl checkpoints from ``train.py``),
``sac_cpg`` / ``td3_cpg`` / ``a2c_cpg`` (skrl checkpoints from ``python -m hexnewton.apps.baselines``, deterministic action
unless ``--stochastic``; ``--expected`` gives them their deterministic action).
"""

from __future__ import annotations

import datetime
import json
import os
import sys
import time

import numpy as np

from hexnewton.analysis.metrics import DISTANCES, gait_quality, round_metrics, summarize
from hexnewton.analysis.report import merge_reports, percent, plot_params, plot_sweep, plot_terrain, report_markdown
from hexnewton.analysis.rollout import (
    CONTROLLERS,
    DEFAULT_SWEEPS,
    EVAL_TERRAIN_SEED,
    FIXED,
    LABELS,
    PERTURBATIONS,
    START_SEED_OFFSET,
    perturbation,
    progress_mode,
    read_controller_checkpoint,
    run_rounds,
    sweep_overrides,
)
from hexnewton.apps.cli import (
    ArgumentParser,
    add_config_args,
    add_robot_args,
    check_checkpoint_file,
    check_new_dir,
    config_overrides,
    positive_int,
    robot_from_args,
    run,
    terrain_name,
)
from hexnewton.config import FIXED_GAITS, HexConfig, TaskConfig, apply_overrides, control_decimation, gait_params

#: what a sweep point keeps of an evaluation's summary
SWEEP_METRICS = ("rounds", "fall_rate", "pitch_var_deg2", "roll_var_deg2", "pitch_p999_deg", "roll_p999_deg")


def _pairs(items: list[str] | None, what: str) -> dict[str, str]:
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key or not value:
            raise ValueError(f"{what} takes NAME=PATH, got '{item}'")
        out[key] = value
    return out


def checkpoint_for(checkpoints: dict[str, str], controller: str, terrain: str) -> str:
    """``controller:terrain=PATH`` wins over ``controller=PATH``."""
    path = checkpoints.get(f"{controller}:{terrain}") or checkpoints.get(controller)
    if path is None:
        raise ValueError(f"controller {controller} needs --checkpoint {controller}=PATH (or {controller}:{terrain}=PATH)")
    return path


def sweep_specs(sweeps: list[list[str]] | None, terrains: list[str]) -> list[tuple[str, str, str, tuple[float, ...]]]:
    """``--sweep`` flags as (name, field, terrain, values): ``default`` is :data:`DEFAULT_SWEEPS`, a name of that set
    alone (``step_rise``) its curve; ``FIELD V1 V2 ...`` runs on each of ``terrains`` (named ``FIELD`` with one
    terrain, ``FIELD@TERRAIN`` with several). Every point is checked against the config tree before anything runs;
    ValueError (one line) otherwise."""
    out = []
    by_name = {s[0]: s for s in DEFAULT_SWEEPS}
    for spec in sweeps or []:
        if spec == ["default"]:
            out += list(DEFAULT_SWEEPS)
            continue
        if len(spec) == 1 and spec[0] in by_name:
            out.append(by_name[spec[0]])
            continue
        field, raw = spec[0], spec[1:]
        if not raw:
            raise ValueError(f"--sweep {field}: give the values to sweep (--sweep FIELD V1 V2 ...), --sweep default or "
                             f"one of its curves ({', '.join(by_name)})")
        try:
            values = tuple(float(v) for v in raw)
        except ValueError:
            raise ValueError(f"--sweep {field}: values must be numbers, got {' '.join(raw)}")
        for v in values:
            apply_overrides(HexConfig(), sweep_overrides(field, v))  # an unknown field fails here
        out += [(field if len(terrains) == 1 else f"{field}@{t}", field, t, values) for t in terrains]
    names = [name for name, *_ in out]
    if len(set(names)) != len(names):
        raise ValueError("--sweep: each field once (--sweep default holds " + ", ".join(n for n, *_ in DEFAULT_SWEEPS) + ")")
    return out


def run_sweeps(specs, controllers, evaluate_one, last: float, out: str) -> dict:
    """Every controller at every point of every sweep (``evaluate_one(ctrl, terrain, overrides)``): success at
    ``last`` metres, falls, pitch / roll variance and p99.9, time to ``last``; one figure per sweep in ``out``."""
    from hexnewton.analysis.rollout import duration
    from hexnewton.learning.progress import TimeLeft

    sweeps, done = {}, 0
    total = sum(len(values) for *_, values in specs) * len(controllers)
    left = TimeLeft(total)  # from the finished points; the first's one-time costs (a course built) left out
    for name, field, terrain, values in specs:
        curves = {ctrl: [] for ctrl in controllers}
        for value in values:
            for ctrl in controllers:
                s, _, _ = evaluate_one(ctrl, terrain, sweep_overrides(field, value))
                point = {"value": value, f"success_{last:g}m": s[f"success_{last:g}m"],
                         f"time_to_{last:g}m_s": s[f"time_to_{last:g}m_s"], **{k: s[k] for k in SWEEP_METRICS}}
                curves[ctrl].append(point)
                done += 1
                left.update(done)
                print(f"[sweep {name} = {value:g}] {terrain:8s} {LABELS[ctrl]:8s} {last:g} m "
                      f"{percent(point[f'success_{last:g}m'])}  falls {percent(point['fall_rate'])}  (point {done} of "
                      f"{total}, {duration(left.elapsed())}, about {left.text(duration)})", flush=True)  # fmt: skip
        sweeps[name] = {"field": field, "terrain": terrain, "values": list(values), "curves": curves}
        plot_sweep(os.path.join(out, f"fig_sweep_{name.replace('@', '_')}.png"), name, sweeps[name], last)
    return sweeps


def parser() -> ArgumentParser:
    """The command line of ``python -m hexnewton.apps.evaluate``."""
    p = ArgumentParser(prog="python -m hexnewton.apps.evaluate", description="The paper's evaluation and report.")
    p.add_argument("--controllers", nargs="+", default=["cpg", "cpg_rl"], choices=list(CONTROLLERS))
    p.add_argument("--checkpoint", nargs="+", metavar="CTRL[:TERRAIN]=PATH", help="policy of cpg_rl / joint / sac_cpg / td3_cpg / a2c_cpg")
    p.add_argument("--terrains", nargs="+", type=terrain_name, default=["rugged", "stepped", "complex"])
    p.add_argument("--rounds", type=positive_int, default=25, help="rounds per controller and terrain (paper: 25)")
    p.add_argument("--max_steps", type=positive_int, default=None,
                   help=f"control steps per round (default: the episode limit, {TaskConfig.max_episode_steps}; with "
                        "--navigate per goal and per square: 1500 and 4000 on flat ground, 3000 and 12000 elsewhere)")
    p.add_argument("--navigate", action="store_true",
                   help="the navigation evaluation: goals at 2 m at bearings 0, +-45, +-90, +-135, 180 deg and the 2 m "
                        "waypoint square, --rounds of each, on the navigate tasks' patch of each terrain")  # fmt: skip
    p.add_argument("--runs", nargs="+", metavar="CTRL=RUN[,RUN]", help="training runs for Fig. 5a")
    p.add_argument("--distances", nargs="+", type=float, default=list(DISTANCES),
                   help="success distances [m] (Table 3: 0.5 1 2 3)")
    p.add_argument("--swept_gait", type=float, nargs=4, metavar=("OMEGA", "A1", "A2", "A3"), default=None,
                   help="the cpg_swept controller's gait (default config.FIXED_GAITS['swept'], from studies/cpg_sweep/sweep.py)")
    p.add_argument("--sweep", nargs="+", action="append", metavar="FIELD V",
                   help="capability curve: every controller on --terrains at each value of FIELD (a config field, "
                        "e.g. terrain.step_rise 0.06 0.08 0.10; randomization.* fields apply to every robot; "
                        "motor_strength scales gains and effort); 'default': the set in rollout.DEFAULT_SWEEPS, each "
                        "on its own course; a name of that set (step_rise, tread_depth, block_height, friction, "
                        "payload, motor_strength, push, action_delay): that curve. Repeat for several curves")
    p.add_argument("--no-nominal", action="store_true",
                   help="with --sweep or --perturbations: only the swept points and perturbed cases, not the courses "
                        "as given (Table 3)")  # fmt: skip
    p.add_argument("--perturbations", nargs="+", default=[], metavar="NAME",
                   help="also run every controller under these named perturbations beyond the training ranges, one "
                        f"robustness table per controller: {', '.join(PERTURBATIONS)}")
    actions = p.add_mutually_exclusive_group()
    actions.add_argument("--stochastic", action="store_true",
                         help="learnt policies sample their actions as in training (default: the deterministic "
                              "action, the distribution's mean)")
    actions.add_argument("--expected", action="store_true",
                         help="learnt policies take the expected clipped action E[clip(a, -1, 1)] of their Gaussian "
                              "(deterministic; the skrl baselines: their deterministic action)")
    p.add_argument("--seed", type=int, default=EVAL_TERRAIN_SEED,
                   help=f"terrain seed S, start poses from seed S + {START_SEED_OFFSET} (default {EVAL_TERRAIN_SEED}: "
                        "the test set). Choose checkpoints on another S (a validation set), report on the default")
    p.add_argument("--device", default=None)
    add_robot_args(p, "the learnt policies' own (the fixed gaits walk it too; without a policy the paper's)")
    p.add_argument("--out", default=None, help="output directory (default eval/<date_time>); must not exist")
    p.add_argument("--merge", nargs="+", metavar="DIR",
                   help="simulate nothing: join the results.json of evaluations run apart (one controller or terrain "
                        "per GPU or process, the same seeds) into one report in --out")
    p.add_argument("--no-progress", action="store_true", help="no progress bar or lines")
    add_config_args(p, "env", HexConfig(), skip=("sim.num_envs", "sim.device", "task.seed", "terrain.seed", "terrain.name"),
                    title="--env.*: a field of every course (HexConfig; e.g. --env.terrain.step_rise 0.08, "
                          "--env.randomization.enabled true, --env.cpg.posture_reflex 2: a fixed gait gets the body "
                          "posture with that reflex). sim.* and cpg.* default to each policy's own (its checkpoint's); "
                          "task.reset_yaw is the start yaw noise")  # fmt: skip
    return p


def default_out() -> str:
    """``eval/<date_time>``."""
    return os.path.join("eval", datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S"))


def success_distances(given: list[float], goal_distance: float) -> tuple[float, ...]:
    """The success distances, sorted and each once; ValueError for one that a round cannot reach before its goal."""
    distances = tuple(sorted(set(given)))
    if not all(0 < d <= goal_distance - TaskConfig.goal_radius + 1e-9 for d in distances):
        raise ValueError(f"--distances must lie in (0, goal_distance - {TaskConfig.goal_radius:g}] = "
                         f"(0, {goal_distance - TaskConfig.goal_radius:g}] m (set --env.task.goal_distance)")  # fmt: skip
    return distances


def read_checkpoints(checkpoints: dict[str, str], controllers: list[str], terrains: list[str]) -> dict[str, dict]:
    """{path: checkpoint} of every learnt policy on every terrain, each file read and checked before any simulation
    (a directory given as a checkpoint: one line saying what it is and what is expected)."""
    for key, path in checkpoints.items():
        check_checkpoint_file(path, "--checkpoint", f"{key}=")
    read = {}
    for ctrl in controllers:
        for terrain in terrains:
            if ctrl not in FIXED:
                path = checkpoint_for(checkpoints, ctrl, terrain)
                read[path] = read_controller_checkpoint(ctrl, path)
    return read


def evaluation_robot(args, read: dict[str, dict]):
    """The robot every controller walks: ``--robot``'s, else the learnt policies' own (one line where they differ),
    else None (the paper's)."""
    from hexnewton.learning.checkpoint import is_baseline_checkpoint, trained_config
    from hexnewton.robot.registry import check_robot

    robot = robot_from_args(args)
    for path, ckpt in read.items():
        trained = trained_config(ckpt).robot
        check_robot(trained, robot, path, init=not is_baseline_checkpoint(ckpt))
        robot = robot or trained
    return robot


def check_runs(runs: dict[str, str]) -> None:
    """ValueError unless every ``--runs`` training run logged its mean episode reward (Fig. 5a)."""
    from hexnewton.analysis.curves import read_curve

    for spec in runs.values():
        if "Train/mean_reward" not in read_curve(spec, "env_steps"):
            raise ValueError(f"no mean episode reward logged under {spec}")


def fixed_gait_physics(physics: dict, checkpoints: dict[str, str], controllers: list[str], terrain: str,
                       read: dict[str, dict]) -> dict:
    """The physics overrides of the fixed gaits: ``physics`` (``--env.sim.*``) if given, else the first learnt
    policy's frame and substeps (the same run, the same simulator), else none."""
    from hexnewton.learning.checkpoint import trained_config

    learnt = [checkpoint_for(checkpoints, c, terrain) for c in controllers if c not in FIXED]
    if physics or not learnt:
        return physics
    sim = trained_config(read[learnt[0]]).sim
    return {"sim.frame_dt": sim.frame_dt, "sim.substeps": sim.substeps}


def evaluator(args, checkpoints: dict[str, str], env_overrides: dict, fixed_physics: dict, device: str,
              distances: tuple[float, ...]):
    """``evaluate_one(ctrl, terrain, perturbed=None) -> (summary, episode, metrics)``: ``args.rounds`` rounds of one
    controller on one course, ``perturbed`` (a perturbation's or a sweep point's overrides) on top of ``--env.*``;
    its progress a bar on a terminal, else plain lines with at most how long is left (``--no-progress``: none)."""
    progress = False if args.no_progress else progress_mode()

    def evaluate_one(ctrl: str, terrain: str, perturbed: dict | None = None):
        ck = None if ctrl in FIXED else checkpoint_for(checkpoints, ctrl, terrain)
        fixed_params = gait_params(*args.swept_gait) if ctrl == "cpg_swept" and args.swept_gait else None
        overrides = {**env_overrides, **(fixed_physics if ctrl in FIXED else {}), **(perturbed or {})}
        ep = run_rounds(ctrl, ck, terrain, args.rounds, device, args.max_steps, progress, args.seed, overrides,
                        args.stochastic, args.expected, fixed_params, args.robot_cfg)  # fmt: skip
        m = round_metrics(ep.pos, ep.rpy, ep.done, ep.status, ep.dt, distances)
        s = summarize(m, ep.rpy, distances, ep.goal_line)
        s.update(gait_quality(m, ep.ang_rate, ep.dparam, ep.daction), segments=ep.segments, checkpoint=ck)
        return s, ep, m

    return evaluate_one


def failures(summary: dict) -> str:
    """The rounds that ended in a fall and those that ended off the course, as percentages of the rounds."""
    off = summary["ended"].get("off_course", 0) / summary["rounds"] if summary["rounds"] else None
    return f"falls {percent(summary['fall_rate'])}  off course {percent(off)}"


def evaluate_terrains(args, evaluate_one, distances: tuple[float, ...], out: str) -> dict[str, dict[str, dict]]:
    """Every controller on every terrain: one line each, the terrain's figures in ``out`` (Figs. 6-8; Fig. 5b for the
    first terrain). Returns {terrain: {controller: summary}}."""
    results: dict[str, dict[str, dict]] = {}
    for terrain in args.terrains:
        episodes, metrics = {}, {}
        for ctrl in args.controllers:
            s, ep, m = evaluate_one(ctrl, terrain)
            results.setdefault(terrain, {})[ctrl] = s
            episodes[ctrl], metrics[ctrl] = ep, m
            print(f"{terrain:8s} {LABELS[ctrl]:8s} " + "  ".join(f"{d:g} m {percent(s[f'success_{d:g}m'])}"
                                                                 for d in distances)
                  + f"  {failures(s)}  ({s['rounds']} rounds, {len(ep.done)} steps)", flush=True)  # fmt: skip
        # figures now, so that only one terrain's trajectories are held at a time (1000 rounds x 7000 steps)
        plot_terrain(os.path.join(out, f"fig_{terrain}.png"), terrain, episodes, metrics)
        if terrain == args.terrains[0] and any(not np.isnan(ep.params).all() for ep in episodes.values()):
            plot_params(os.path.join(out, "fig_params.png"), terrain, episodes)
    return results


def evaluate_perturbations(args, evaluate_one, distances: tuple[float, ...]) -> dict[str, dict[str, dict[str, dict]]]:
    """Every controller on every terrain under each ``--perturbations`` name, one line each. Returns {perturbation:
    {controller: {terrain: summary}}}."""
    robustness: dict[str, dict[str, dict[str, dict]]] = {}
    for name in args.perturbations:
        perturbed = perturbation(name)
        for terrain in args.terrains:
            for ctrl in args.controllers:
                s, _, _ = evaluate_one(ctrl, terrain, perturbed)
                robustness.setdefault(name, {}).setdefault(ctrl, {})[terrain] = s
                print(f"[{name}] {terrain:8s} {LABELS[ctrl]:8s} " + "  ".join(
                    f"{d:g} m {percent(s[f'success_{d:g}m'])}" for d in distances)
                    + f"  {failures(s)}", flush=True)  # fmt: skip
    return robustness


def evaluate_navigation(args, env_overrides: dict, argv: list[str]) -> int:
    """``--navigate``: both protocols of :mod:`hexnewton.analysis.navigation` for every controller on every terrain,
    one line each; ``report.md``, ``results.json`` and one path figure per controller and terrain in ``--out``."""
    from hexnewton.analysis import navigation as nav

    checkpoints = _pairs(args.checkpoint, "--checkpoint")
    read_checkpoints(checkpoints, args.controllers, args.terrains)
    out = args.out or default_out()
    check_new_dir(out)
    from hexnewton.physics.device import resolve_device

    device = resolve_device(args.device)
    os.makedirs(out)
    t0, progress = time.perf_counter(), False if args.no_progress else progress_mode()
    results: dict[str, dict[str, dict]] = {}
    limits = {t: (args.max_steps, args.max_steps) if args.max_steps else nav.navigation_steps(t) for t in args.terrains}
    for terrain in args.terrains:
        steps = limits[terrain]
        for ctrl in args.controllers:
            ck = None if ctrl in FIXED else checkpoint_for(checkpoints, ctrl, terrain)
            s, runs = nav.evaluate_controller(ctrl, ck, terrain, args.rounds, device, args.seed, progress,
                                              env_overrides, steps)  # fmt: skip
            results.setdefault(terrain, {})[ctrl] = dict(s, checkpoint=ck)
            nav.plot_paths(os.path.join(out, f"fig_paths_{terrain}_{ctrl}.png"), f"{LABELS[ctrl]} on {terrain}", runs)
            b, sq = s["bearings"], s["square"]
            print(f"{terrain:8s} {LABELS[ctrl]:8s} goals at 2 m: |b| <= 90 {percent(b['near']['reached'])}, 135-180 "
                  f"{percent(b['behind']['reached'])}, falls {percent(b['all']['fall_rate'])}; square completed "
                  f"{percent(sq['completed'])}, falls {percent(sq['fall_rate'])}", flush=True)  # fmt: skip
    wall = time.perf_counter() - t0
    meta = {"device": device, "rounds per bearing and of the square": args.rounds,
            "bearings [deg]": list(nav.BEARINGS_DEG), "goal distance [m]": nav.GOAL_DISTANCE,
            "square [m]": [list(c) for c in nav.SQUARE], "max_steps (goal, square)": {t: list(v) for t, v in limits.items()},
            "goal radius [m]": TaskConfig.goal_radius, "actions": "deterministic (mean)", "overrides": env_overrides,
            "terrain_seed": args.seed, "reset_seed": args.seed + START_SEED_OFFSET,
            "command": "python -m hexnewton.apps.evaluate " + " ".join(argv), "wall_s": round(wall, 1)}
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"meta": meta, "results": results}, f, indent=1)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write(nav.report_markdown(results, meta))
    print(f"report in {out}/ (report.md, results.json, path figures) after {wall:.0f} s")
    return 0


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    env_overrides = config_overrides(args, "env")
    if args.navigate:
        if args.merge or args.sweep or args.perturbations or args.runs or args.stochastic or args.expected:
            raise ValueError("--navigate runs the navigation evaluation alone: no --merge, --sweep, --perturbations, "
                             "--runs, --stochastic or --expected")  # fmt: skip
        return evaluate_navigation(args, env_overrides, list(sys.argv[1:] if argv is None else argv))
    args.max_steps = args.max_steps or TaskConfig.max_episode_steps
    goal_distance = env_overrides.get("task.goal_distance", TaskConfig.goal_distance)
    course = apply_overrides(HexConfig(), env_overrides)  # fail before any output folder is made
    control_decimation(course.task.control_dt, course.sim.frame_dt)
    if args.merge:
        return merge_reports(args.merge, args.out or default_out())
    distances = success_distances(args.distances, goal_distance)
    checkpoints = _pairs(args.checkpoint, "--checkpoint")
    runs = _pairs(args.runs, "--runs")
    read = read_checkpoints(checkpoints, args.controllers, args.terrains)  # every learnt policy's file, checked
    args.robot_cfg = evaluation_robot(args, read)
    check_runs(runs)
    for name in args.perturbations:
        perturbation(name)
    sweeps = sweep_specs(args.sweep, args.terrains)
    if args.no_nominal and not (sweeps or args.perturbations):
        raise ValueError("--no-nominal leaves nothing to run: give --sweep or --perturbations")
    physics = {k: v for k, v in env_overrides.items() if k.startswith("sim.")}
    # the fixed gaits walk under the first learnt policy's physics (the same run, the same simulator) unless told
    fixed_physics = fixed_gait_physics(physics, checkpoints, args.controllers, args.terrains[0], read)
    out = args.out or default_out()
    check_new_dir(out)

    from hexnewton.physics.device import resolve_device

    device = resolve_device(args.device)
    os.makedirs(out)
    t0 = time.perf_counter()
    evaluate_one = evaluator(args, checkpoints, env_overrides, fixed_physics, device, distances)
    results = {} if args.no_nominal else evaluate_terrains(args, evaluate_one, distances, out)
    robustness = evaluate_perturbations(args, evaluate_one, distances)
    swept = run_sweeps(sweeps, args.controllers, evaluate_one, distances[-1], out) if sweeps else {}
    wall = time.perf_counter() - t0
    meta = {"device": device, "rounds": args.rounds, "max_steps": args.max_steps,
            "distances": list(distances), "goal_distance": goal_distance, "overrides": env_overrides,
            "actions": "sampled" if args.stochastic else "expected" if args.expected else "deterministic (mean)",
            "physics": physics or "each policy's own (checkpoint)", "fixed_cpg_physics": fixed_physics or "default",
            "perturbations": args.perturbations, "robot": (args.robot_cfg or HexConfig().robot).name,
            "swept_gait": args.swept_gait or list(FIXED_GAITS["swept"]),
            "terrain_seed": args.seed, "reset_seed": args.seed + START_SEED_OFFSET,
            "unseen": "terrain seed and start poses differ from training (train.py: terrain seed 0, seed 1)",
            "wall_s": round(wall, 1)}  # fmt: skip
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"meta": meta, "results": results, "robustness": robustness, "sweeps": swept}, f, indent=1)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write(report_markdown(results, meta, robustness, swept))
    if runs:
        from hexnewton.analysis.curves import plot_learning

        plot_learning(os.path.join(out, "fig_learning.png"), runs)
    print(f"report in {out}/ (report.md, results.json, figures) after {wall:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.evaluate"))
