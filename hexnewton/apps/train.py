"""Train a task's controller with rsl-rl's PPO: ``python train.py --task NAME``.

    python train.py --list_tasks                                           # the tasks, one line each
    python train.py                                                        # task flat
    python train.py --task complex                                         # the shipped complex policy's recipe
    python train.py --task rugged --env.reward.w_tilt 10 --agent.algorithm.learning_rate 5e-4
    python train.py --resume logs/hexnewton_rugged/2026-11-21_15-00-00/model_299.pt --max_iterations 100
    torchrun --nproc_per_node=2 train.py --task complex --num_envs 4096    # 4096 envs on each of 2 GPUs
    python train.py --task rugged --video --video_interval 100             # a 4 s clip every 100 iterations
    python train.py --task complex --viewer viser                          # watch training at http://127.0.0.1:8080
    python train.py --task complex --robot mx_phoenix                      # another robot (a name or a robot file)
    python train.py --task complex --robot mx_phoenix --init results/policies/cpg_rl_complex.pt   # from a policy

Every field of the task's configs can be set from the command line: ``--env.<section>.<field>`` (HexConfig: robot,
terrain, sim, cpg, task, reward, randomization) and ``--agent.<field>`` (AgentConfig: PPO, networks, distribution,
curriculum, stop rules); ``python train.py --task T --help`` lists them with the task's values. ``--robot NAME|FILE``
trains on another robot than the paper's (docs/robots.md: its CPG amplitudes, heights and terrain window scaled for it,
before the ``--env.*`` overrides), its whole description recorded in the checkpoints. A resumed run goes on with the
configs its checkpoint recorded, overrides on top. ``--init POLICY.pt`` starts a new run's actor and its observation
normaliser from another policy of the same observation and action shapes (its critic new, learning alone for the
first ``--agent.init_critic_iterations`` iterations): how a policy is adapted to another robot or task.

Each run writes ``logs/hexnewton_<task>/<date_time>/``: TensorBoard event files; ``model_<it>.pt`` checkpoints with
the task, the configs and the action mode (``play.py``, ``evaluate`` and ``export`` need nothing else);
``model_best.pt``; ``config.json``; ``git/`` (hexnewton's commit and diff); at the end ``model_result.pt``, the
result chosen on deterministic validation rounds (``--agent.validation_rounds``: docs/training.md), and
``policy.onnx``, its deterministic policy with a dynamic batch dimension, checked against torch with onnxruntime. With ``--video``,
``videos/iteration_<k>.mp4``: ``--video_length`` control steps of the first robots as training plays them, from
iteration 0 and every ``--video_interval`` iterations (Newton's ViewerGL, headless; ``hexnewton.physics.viewer.VideoEnv``).
With ``--viewer viser`` the first ``--robots_shown`` training robots are drawn in a web page every ``--viewer_stride``
control steps while training runs (``hexnewton.physics.viewer.LiveEnv``; ``--host`` / ``--port``, 127.0.0.1:8080 by
default: this machine only).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import os
import shutil
import sys
import time

from hexnewton.apps.cli import (
    ArgumentParser,
    add_browser_args,
    add_config_args,
    add_robot_args,
    announce_browser,
    check_checkpoint_file,
    config_overrides,
    positive_int,
    robot_from_args,
    run,
)
from hexnewton.config import apply_overrides
from hexnewton.learning.stopping import exit_status

#: on the CPU, a validation sized for a GPU (more rounds per candidate than ``CPU_VALIDATION_MAX``, the flat main
#: job's) runs ``CPU_VALIDATION_ROUNDS`` instead unless the command line sets them: the terrain tasks' 256 per candidate
#: (a GPU steps 1024 robots as fast as 256) would take hours on a 2-core CPU, 8 take minutes
CPU_VALIDATION_ROUNDS, CPU_VALIDATION_MAX = 8, 16


def _base_task(argv: list[str] | None):
    """The task the command line starts from: ``--task``'s (default flat), or a resumed checkpoint's own configs,
    with the checkpoint itself (None when not resuming)."""
    from hexnewton.tasks import task

    pre = ArgumentParser(add_help=False)
    pre.add_argument("--task", default=None)
    pre.add_argument("--resume", default=None)
    pre.add_argument("--init", default=None)
    known, _ = pre.parse_known_args(argv)
    if known.resume is not None and known.init is not None:
        raise ValueError("--init starts a new run from a policy, --resume continues a run: give one of them")
    if known.resume is None:
        return task(known.task or "flat"), None
    if known.task is not None:
        raise ValueError("--resume continues the checkpoint's own task: leave --task out (override fields with "
                         "--env.* / --agent.*)")  # fmt: skip
    from hexnewton.learning.checkpoint import (
        checkpoint_agent,
        checkpoint_meta,
        checkpoint_task,
        load_checkpoint,
        trained_config,
    )
    from hexnewton.tasks import TASKS, Task

    check_checkpoint_file(known.resume, "--resume")  # a run's folder: one line naming its result
    ckpt = load_checkpoint(known.resume)  # fails before building anything
    if "critic_state_dict" not in ckpt or "optimizer_state_dict" not in ckpt:
        raise ValueError(f"{known.resume} holds the policy only (no critic or optimiser): resume from a run's "
                         "model_<iteration>.pt")  # fmt: skip
    meta = checkpoint_meta(ckpt)
    cfg = trained_config(ckpt)
    name = checkpoint_task(ckpt) or cfg.terrain.name
    base = Task(name, TASKS[name].description if name in TASKS else "", cfg, checkpoint_agent(ckpt),
                meta.get("action_mode", "cpg"))  # fmt: skip
    return base, ckpt


def parser(base, resumed: bool) -> ArgumentParser:
    """The command line of ``python train.py``, its defaults those of ``base`` (the task, or a ``resumed``
    checkpoint's configs)."""
    from hexnewton.tasks import TASKS

    p = ArgumentParser(prog="python train.py", description="Train a task's controller with rsl-rl PPO.",
                       usage="python train.py [--task NAME] [options] [--env.SECTION.FIELD VALUE ...] "
                             "[--agent.FIELD VALUE ...]")  # fmt: skip
    p.add_argument("--task", choices=list(TASKS), default=base.name if not resumed else None,
                   help="what to train (python train.py --list_tasks; default flat)")
    p.add_argument("--list_tasks", action="store_true", help="list the tasks, one line each, and exit")
    p.add_argument("--num_envs", type=positive_int, default=None, help="envs per GPU (default 4096 on CUDA, 64 on CPU)")
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--seed", type=int, default=base.env.task.seed,
                   help=f"seed of actions, resets and initialisation (default {base.env.task.seed}; the terrain's is "
                        "--env.terrain.seed)")  # fmt: skip
    p.add_argument("--max_iterations", type=positive_int, default=None,
                   help=f"PPO iterations of this run (default: the task's, {base.agent.max_iterations})")
    p.add_argument("--resume", metavar="PATH", help="checkpoint to continue from (a new run directory is made)")
    add_robot_args(p, "the checkpoint's" if resumed else "the paper's")
    p.add_argument("--init", metavar="POLICY.pt",
                   help="start the actor and its observation normaliser from this policy (the same observation and "
                        "action shapes; another robot's too), the critic new and learning alone for the first "
                        "--agent.init_critic_iterations iterations")  # fmt: skip
    p.add_argument("--log_dir", default="logs")
    p.add_argument("--experiment", default=None, help="default: hexnewton_<task> (on another robot than the paper's "
                   "hexnewton_<task>_<robot>)")
    p.add_argument("--build_beside_imports", action=argparse.BooleanOptionalAction, default=True,
                   help="build the terrain and the physics model in a thread while torch and rsl-rl import (default; "
                        "--no-build_beside_imports: after them)")  # fmt: skip
    p.add_argument("--build_scene_first", action=argparse.BooleanOptionalAction, default=True,
                   help="with the build beside the imports: the terrain and the scene before them, only Newton's "
                        "finalize beside them (default; --no-build_scene_first: all of it beside them)")  # fmt: skip
    p.add_argument("--preload_kernels", action=argparse.BooleanOptionalAction, default=True,
                   help="with the build beside the imports: load the Warp modules the world loads whatever its model "
                        "while the finalize ends (default; --no-preload_kernels: after it)")  # fmt: skip
    p.add_argument("--headless", action="store_true",
                   help="Isaac Lab's flag, accepted: training never opens a window (--video renders off-screen)")
    p.add_argument("--video", action="store_true",
                   help="record clips of the training robots into the run's videos/ (headless ViewerGL, .mp4)")
    p.add_argument("--video_length", type=positive_int, default=200, help="control steps per clip (default 200: 4 s)")
    p.add_argument("--video_interval", type=positive_int, default=100, help="iterations between clips (default 100)")
    p.add_argument("--viewer", choices=("viser",), default=None,
                   help="viser: watch the first training robots live in a browser while training runs")
    p.add_argument("--viewer_stride", type=positive_int, default=10,
                   help="--viewer viser: control steps between drawn frames (default 10)")
    p.add_argument("--robots_shown", type=positive_int, default=3, help="--viewer viser: robots drawn (default 3)")
    add_browser_args(p)
    add_config_args(p, "env", base.env, skip=("sim.num_envs", "sim.device", "task.seed"),
                    title="--env.*: the environment (HexConfig, hexnewton/config.py)")
    add_config_args(p, "agent", base.agent, skip=("max_iterations",),
                    title="--agent.*: the learner (AgentConfig, hexnewton/learning/agent.py)")
    return p


def configs(args, base, ckpt: dict | None):
    """The run's environment and learner configs: the task's (or the resumed checkpoint's) with the command line's
    overrides, checked before anything is built."""
    robot, base_env = robot_from_args(args), base.env
    if robot is not None:  # the robot and its scales first, the --env.* overrides on top
        from hexnewton.robot.registry import check_robot, with_robot

        if ckpt is not None:
            check_robot(base.env.robot, robot, args.resume)
        base_env = with_robot(base.env, robot)
    env_cfg = apply_overrides(base_env, config_overrides(args, "env"))
    agent = apply_overrides(base.agent, config_overrides(args, "agent"))
    if args.max_iterations is not None:
        agent = dataclasses.replace(agent, max_iterations=args.max_iterations)
    agent.check()
    if ckpt is not None:
        from hexnewton.learning.checkpoint import checkpoint_agent

        if agent.distribution.name != checkpoint_agent(ckpt).distribution.name:
            raise ValueError("--agent.distribution.name: a resumed run keeps the distribution it was trained with")
    reflex = any("posture_reflex" in changes for _, changes in agent.stages)
    if reflex and base.action_mode != "cpg":
        raise ValueError("agent.stages: posture_reflex is the CPG's levelling reflex, which the joint targets do not "
                         "have: a joint-mode stage changes reward weights, PPO settings and physics only")  # fmt: skip
    if reflex and not env_cfg.cpg.posture:
        raise ValueError("agent.stages change the levelling reflex of the body posture: set --env.cpg.posture true "
                         "or drop posture_reflex from the stages")  # fmt: skip
    return env_cfg, agent


def init_policy(args, agent) -> dict | None:
    """``--init``'s checkpoint, read and checked before anything is built (None without it): a policy of ``agent``'s
    action distribution (never beside ``--resume``: :func:`_base_task` says so)."""
    if args.init is None:
        return None
    from hexnewton.apps.cli import check_checkpoint_file
    from hexnewton.learning.checkpoint import checkpoint_distribution, load_checkpoint

    check_checkpoint_file(args.init, "--init")
    init = load_checkpoint(args.init)
    if checkpoint_distribution(init) != agent.distribution.name:
        raise ValueError(f"--init {args.init} acts through a {checkpoint_distribution(init)} distribution, this run "
                         f"through a {agent.distribution.name} one: --agent.distribution.name "
                         f"{checkpoint_distribution(init)}")  # fmt: skip
    return init


def checked_env(args, base, cfg, build, ckpt: dict | None, init: dict | None):
    """The run's env, checked against the checkpoint it resumes (observations, actions, critic) or starts from
    (``--init``: observations and actions)."""
    from hexnewton.learning.checkpoint import check_compatible, check_critic
    from hexnewton.mdp.env import make_env

    env = make_env(cfg, base.action_mode, build)
    if ckpt is not None:
        check_compatible(ckpt, args.resume, env.num_obs, env.num_actions, base.action_mode)
        check_critic(ckpt, args.resume, sum(g.shape[1] for g in env.get_observations().values()))
    if init is not None:
        check_compatible(init, args.init, env.num_obs, env.num_actions, base.action_mode)
    return env


def init_meta(args, init: dict | None) -> dict:
    """What a run started from a policy records of it (``--init``): the checkpoint, its task and robot."""
    if init is None:
        return {}
    from hexnewton.learning.checkpoint import checkpoint_task, trained_config

    return {"init": {"checkpoint": os.path.abspath(args.init), "task": checkpoint_task(init),
                     "robot": trained_config(init).robot.name}}


def check_outputs(args) -> None:
    """Fail before any simulation if the run's logs or its videos could not be written."""
    from hexnewton.learning.runner import check_log_dir

    check_log_dir(args.log_dir)
    from hexnewton.physics.viewer import check_viewer_args

    if args.video:
        check_viewer_args("gl", True, "clip.mp4", None)
    if args.viewer:
        check_viewer_args(args.viewer, True, None, None, args.host, args.port)


def device_validation(agent, device: str, argv: list[str] | None):
    """``agent`` with :data:`CPU_VALIDATION_ROUNDS` validation rounds per candidate on the CPU where it has more than
    :data:`CPU_VALIDATION_MAX`, unless the command line sets ``--agent.validation_rounds``; on CUDA, as it is."""
    argv = sys.argv[1:] if argv is None else argv
    named = any(a == "--agent.validation_rounds" or a.startswith("--agent.validation_rounds=") for a in argv)
    if device.startswith("cuda") or named or agent.validation_rounds <= CPU_VALIDATION_MAX:
        return agent
    print(f"validation on the CPU: {CPU_VALIDATION_ROUNDS} rounds per candidate (the task's {agent.validation_rounds} "
          "are sized for a GPU; --agent.validation_rounds sets them)")  # fmt: skip
    return dataclasses.replace(agent, validation_rounds=CPU_VALIDATION_ROUNDS)


def rank_config(args, env_cfg):
    """This process's torchrun rank and its config: the device resolved, ``--num_envs`` (default 4096 on CUDA, 64 on
    the CPU), the rank's own seeds (``seed_everything(cfg.task.seed)`` seeds them; no torch here)."""
    from hexnewton.learning.ranks import distributed_rank
    from hexnewton.physics.device import resolve_device

    rank = distributed_rank(dict(os.environ), args.device)
    device = resolve_device(rank.device or args.device)
    num_envs = args.num_envs or (4096 if device.startswith("cuda") else 64)
    seed, terrain_seed = rank.seeds(args.seed, env_cfg.terrain.seed)
    cfg = dataclasses.replace(env_cfg, sim=dataclasses.replace(env_cfg.sim, num_envs=num_envs, device=device),
                              terrain=dataclasses.replace(env_cfg.terrain, seed=terrain_seed),
                              task=dataclasses.replace(env_cfg.task, seed=seed))  # fmt: skip
    return rank, cfg


def make_run_dir(args, meta: dict, train_cfg: dict, rank) -> str:
    """``log_dir/experiment/<date_time>``; rank 0 makes it (nothing is overwritten) and writes its config.json: the
    run's metadata and rsl-rl's ``train_cfg``."""
    robot = meta.get("robot", "paper")
    experiment = args.experiment or f"hexnewton_{meta['task']}" + (f"_{robot}" if robot != "paper" else "")
    run_dir = os.path.join(args.log_dir, experiment, datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S"))
    if rank.is_main:  # only rank 0 writes logs, checkpoints and the export
        if os.path.exists(run_dir):
            raise ValueError(f"{run_dir} exists: nothing is overwritten (start again in a second, or change "
                             "--experiment)")  # fmt: skip
        os.makedirs(run_dir)
        with open(os.path.join(run_dir, "config.json"), "w") as f:
            json.dump({"hexnewton": meta, "train": train_cfg}, f, indent=1, default=str)
    return run_dir


def make_runner(args, env, agent, meta: dict, run_dir: str, rank, ckpt: dict | None, init: dict | None = None):
    """The run's :class:`~hexnewton.learning.runner.HexRunner` (resumed from ``ckpt``, or its actor started from
    ``init``, ``--init``'s policy, if given) and, on rank 0, the
    viewers it trains through: ``--video``'s :class:`~hexnewton.physics.viewer.VideoEnv` and ``--viewer viser``'s
    :class:`~hexnewton.physics.viewer.LiveEnv` (a list, empty without them)."""
    from hexnewton.learning.runner import HexRunner

    cfg = env.cfg
    views = []
    steps_per_iteration = agent.to_rsl_rl(cfg.sim.num_envs)["num_steps_per_env"]
    if args.video and rank.is_main:
        from hexnewton.physics.viewer import VideoEnv

        env = VideoEnv(env, os.path.join(run_dir, "videos"), args.video_interval, args.video_length,
                       steps_per_iteration, title=f"task {meta['task']}: ")  # fmt: skip
        views.append(env)
    if args.viewer == "viser" and rank.is_main:
        from hexnewton.physics.viewer import LiveEnv

        env = LiveEnv(env, args.viewer_stride, steps_per_iteration, args.robots_shown, f"task {meta['task']}: ",
                      args.host, args.port)  # fmt: skip
        views.append(env)
        announce_browser(env.url, args.host, "while training runs")
    runner = HexRunner(env, agent, meta, run_dir if rank.is_main else None, cfg.sim.device, rank)
    if ckpt is not None:
        resume(runner, ckpt, args, agent)
    if init is not None:
        runner.start_from(init, args.init)
    return runner, views


def resume(runner, ckpt: dict, args, agent) -> None:
    """Load the checkpoint's models, optimiser and iteration into ``runner`` and continue after its iteration; a
    Gaussian's ``--agent.distribution.init_std`` replaces the std the checkpoint brought."""
    from hexnewton.learning.checkpoint import load_into_runner
    from hexnewton.learning.policy import fix_action_std

    load_into_runner(runner, ckpt)
    # rsl-rl stores the last finished iteration and would start again from it: continue after it instead
    runner.current_learning_iteration += 1
    if "distribution.init_std" in config_overrides(args, "agent") and agent.distribution.name == "gaussian":
        fix_action_std(runner.alg.get_policy(), agent.distribution.init_std)  # the checkpoint brought its own
    print(f"resumed from {args.resume}: continuing at iteration {runner.current_learning_iteration}, "
          f"learning rate {runner.alg.learning_rate:.2e}")


def ranks_agent(agent, rank):
    """The learner each torchrun rank trains with (``--agent.scale_with_ranks``), announced by rank 0 when scaled."""
    scaled = agent.for_ranks(rank.world_size)
    if scaled is not agent and rank.is_main:
        a = scaled.algorithm
        batches = f"mini-batch size {a.mini_batch_size}" if a.mini_batch_size else f"{a.num_mini_batches} mini-batches"
        print(f"scaled for {rank.world_size} ranks ({' '.join(agent.scale_with_ranks)}): {scaled.max_iterations} "
              f"iterations, stages from {[start for start, _ in scaled.stages]}, {batches} per rank, learning rate "
              f"{a.learning_rate:g}")  # fmt: skip
    return scaled


def check_ranks_agree(runner, rank) -> None:
    """RuntimeError unless every torchrun rank ended with the same parameters (the gradients were shared)."""
    spread = runner.rank_spread()
    if rank.is_main:
        print(f"parameters of the {rank.world_size} ranks agree to {spread:.1e}")
    if spread > 1e-5:
        raise RuntimeError(f"the ranks' parameters differ by {spread:.2e}: the gradients were not shared")


def validate_result(runner, cfg, agent, run_dir: str | None, first_it: int, rank) -> dict | None:
    """Deterministic validation (:mod:`hexnewton.analysis.validation`) of rank 0's candidates: the last stage's
    checkpoints. Every rank of a torchrun job calls it and validates its share (:func:`validation_share`) on its own
    GPU, where every rank reads rank 0's checkpoints (one host); else rank 0 validates them all. Returns on rank 0
    the candidates, each one's results and the seconds (None on the other ranks)."""
    from hexnewton.analysis.validation import (Candidate, candidates, combine_courses, course_names, side_by_side,
                                               validate_share)
    from hexnewton.learning.runner import share_objects

    cands = None
    if rank.is_main:
        it, best = runner.current_learning_iteration, runner.best
        stage_start = max([start for start, _ in agent.stages if start <= it] + [first_it])
        last = Candidate(it, os.path.join(run_dir, f"model_{it}.pt"), "last")
        kept = Candidate(best.iteration, best.path, f"best training {best.measure} {best.rate:.3f}") \
            if best.iteration is not None else None  # fmt: skip
        cands = candidates(run_dir, stage_start, last, kept, agent.validation_candidates)
        if agent.validation_average and len(cands) > 1:
            from hexnewton.learning.checkpoint import average_checkpoints

            path = average_checkpoints([c.path for c in cands], os.path.join(run_dir, "model_average.pt"))
            cands.append(Candidate(it, path, "average of iterations " + ", ".join(str(c.iteration) for c in cands)))
    t0 = time.time()
    cands = share_objects(cands, cfg.sim.device)[0]
    ranks = rank.world_size if all(share_objects(all(os.path.isfile(c.path) for c in cands), cfg.sim.device)) else 1
    controller = "joint" if runner.meta["action_mode"] == "joint" else "cpg_rl"
    terrains = list(agent.validation_terrains) or [cfg.terrain]
    together = side_by_side(terrains, ranks, agent.validation_together)
    if rank.is_main:
        names = [t if isinstance(t, str) else t.name for t in terrains]
        print(f"deterministic validation: {len(cands)} candidates, {agent.validation_rounds} rounds each on "
              f"{course_names(names)}" + (" side by side in one env" if together else "") + ", at most "
              f"{agent.validation_steps} control steps a round" + (f", shared by {ranks} ranks" if ranks > 1 else ""),
              flush=True)  # fmt: skip
    mine = validate_share(cands, controller, terrains, agent.validation_rounds, cfg.sim.device,
                          agent.validation_steps, cfg.task.goal_distance, rank.rank, ranks, agent.validation_together) \
        if rank.rank < ranks else {}  # fmt: skip
    shares = share_objects(mine, cfg.sim.device) if ranks > 1 else [mine]
    if not rank.is_main:
        return None
    results, per_course = combine_courses(cands, terrains, {k: v for share in shares for k, v in share.items()})
    return {"candidates": cands, "results": results, "courses": per_course, "ranks": ranks, "side_by_side": together,
            "seconds": time.time() - t0}


def choose_on_validation(runner, agent, run_dir: str, validated: dict) -> tuple[str, dict]:
    """The run's result chosen on :func:`validate_result`'s numbers, loaded into the actor and kept as
    ``model_result.pt``; returns it and what was measured."""
    from hexnewton.analysis.validation import VALIDATION_SEED, choose, course_names, report_lines

    cands, results, per_course = validated["candidates"], validated["results"], validated["courses"]
    k = choose(cands, results, per_course, agent.validation_rank, agent.validation_fall_weight)
    seconds = validated["seconds"]
    how = " (shares averaged over the courses)" if len(per_course) > 1 else ""
    if agent.validation_rank == "worst":
        how += (f"; ranked by the worst course's goal share less {agent.validation_fall_weight:g} x its falls before "
                "the goal line")
    shared = f" on {validated['ranks']} ranks" if validated["ranks"] > 1 else ""
    lines = report_lines(cands, results, k)
    print(f"deterministic validation, {agent.validation_rounds} rounds of {course_names(list(per_course))} (seed "
          f"{VALIDATION_SEED}) per candidate, {seconds:.0f} s{shared}{how}:\n" + "\n".join(lines))
    runner.load(cands[k].path, {"actor": True}, map_location=runner.device)
    result = os.path.join(run_dir, "model_result.pt")
    shutil.copyfile(cands[k].path, result)
    print(f"the result: {os.path.basename(cands[k].path)} ({cands[k].why}), kept as {result}")
    return result, {"seconds": seconds, "chosen": cands[k].path, "rounds": agent.validation_rounds,
                    "courses": per_course, "ranks": validated["ranks"], "side_by_side": validated["side_by_side"],
                    "candidates": [dict(r, path=c.path, iteration=c.iteration, why=c.why)
                                   for c, r in zip(cands, results)]}  # fmt: skip


def device_label(device: str) -> str:
    """The GPU's name for ``timing.json``, as the benchmarks name it (``cpu`` on the CPU)."""
    from hexnewton.analysis.bench import device_name

    return device_name(device) if device.startswith("cuda") else "cpu"


def finish(args, runner, cfg, agent, rank, run_dir: str, views, train_s: float, first_it: int,
           validated: dict | None, started: tuple[dict, dict], reason: str = "") -> None:  # fmt: skip
    """Rank 0 after training: the last episodes, the policy to ship (chosen on ``validated``, the result of
    :func:`validate_result`; without validation the best iteration's or the last) exported as ONNX, ``timing.json``
    (``started``: the start-up's phases and notes, taken before validation builds its env), and the commands that use
    the result."""
    from hexnewton import startup
    from hexnewton.learning.runner import training_success

    num_envs = cfg.sim.num_envs
    iterations = runner.current_learning_iteration + 1 - first_it  # this run's (a resumed one starts later)
    timing = {"startup_phases_s": started[0], "startup_notes": started[1],
              "first_iteration_s": runner.first_iteration_s,
              "train_s": train_s, "iterations": iterations,
              "env_steps": iterations * num_envs * agent.num_steps_per_env * rank.world_size,
              "world_size": rank.world_size, "num_envs_per_rank": num_envs, "device_name": device_label(cfg.sim.device),
              "process_start": startup.process_start(),
              "wall_s_to_result": None}  # fmt: skip
    stats = runner.env.episode_stats()
    print("last episodes: " + ", ".join(f"{k} {v}" if isinstance(v, int) else f"{k} {v:.3f}" for k, v in stats.items()))
    if runner.lanes is not None:  # what training saw of its curriculum
        timing["curriculum"] = runner.lanes.summary()
        print(runner.lanes.verdict())
    if validated is not None:
        final, timing["validation"] = choose_on_validation(runner, agent, run_dir, validated)
    else:
        final = runner.final_policy()
        if final == runner.best.path:
            last = training_success(stats, cfg.terrain.levels, runner.goals)
            print(f"best training {runner.best.measure} {runner.best.rate:.3f} at iteration {runner.best.iteration} "
                  f"({final}); the last iteration ended at {last or float('nan'):.3f}: "
                  "exporting the best")  # fmt: skip
    onnx_path = os.path.join(run_dir, "policy.onnx")
    err = runner.export(onnx_path)
    print(f"exported {onnx_path} (dynamic batch; onnxruntime vs torch max |diff| {err:.2e})")
    timing["wall_s_to_result"] = startup.since_start()
    timing["result"] = final
    with open(os.path.join(run_dir, "timing.json"), "w") as f:
        json.dump(timing, f, indent=1)
    print(f"{timing['wall_s_to_result']:.0f} s from process start to the exported result")
    for view in views:
        if hasattr(view, "clips"):
            print(f"{len(view.clips)} training video(s) in {os.path.join(run_dir, 'videos')}")
        else:
            print(f"viewer viser: {view.viewer.frames} frames of the training robots drawn")
    print(f"\nresults in {run_dir} (checkpoints, TensorBoard events, policy.onnx). Next:\n"
          f"  python play.py --checkpoint {final}\n"
          f"  python -m hexnewton.apps.evaluate --controllers cpg cpg_rl --checkpoint cpg_rl={final} --terrains "
          f"{cfg.terrain.name}\n"
          f"  python -m hexnewton.apps.export --checkpoint {final} --out bundle/\n"
          f"  tensorboard --logdir {args.log_dir}")  # fmt: skip
    last = closing_line(reason, runner.current_learning_iteration, agent, timing.get("validation"))
    if last:
        print(last)


def closing_line(reason: str, iteration: int, agent, validation: dict | None) -> str | None:
    """The run's last line where its result is not what the command's header promised: training cut short by the
    task's time cap (``agent.max_minutes``), or a result that reaches no goal on its validation rounds."""
    out = []
    if reason == "the --max_minutes limit":
        out.append(f"stopped by its time cap, --agent.max_minutes {agent.max_minutes:g}, at iteration {iteration} of "
                   f"{agent.max_iterations - 1}: the schedule did not finish (raise the cap for the whole run)")
    if validation is not None:
        chosen = next(c for c in validation["candidates"] if c["path"] == validation["chosen"])
        if chosen["goal"] == 0.0:
            out.append(f"the result reaches the goal in 0 of its {validation['rounds']} validation rounds per course: "
                       "it has not learnt the task")
    return "; ".join(out) if out else None


def main(argv: list[str] | None = None) -> int:
    base, ckpt = _base_task(argv)
    args = parser(base, ckpt is not None).parse_args(argv)
    if args.list_tasks:
        from hexnewton.tasks import task_table

        print(task_table())
        return 0
    env_cfg, agent = configs(args, base, ckpt)
    init = init_policy(args, agent)
    from hexnewton import startup

    # the heavy imports one by one, so that the start-up line says where "python and imports" goes; the terrain and
    # the scene (Python) are built before torch and rsl-rl import, Newton's finalize of the model (mostly NumPy, no
    # torch) in a thread meanwhile (--no-build_scene_first: all three beside; --no-build_beside_imports: after); the
    # world's Warp modules load while the finalize ends (--no-preload_kernels: after it)
    startup.timed_imports("warp", "newton", "hexnewton.physics.world")
    rank, cfg = rank_config(args, env_cfg)
    agent = device_validation(agent, cfg.sim.device, argv)
    from hexnewton.physics.model_build import ModelBuild

    build = ModelBuild(cfg, beside=True, scene_first=args.build_scene_first,
                       preload_kernels=args.preload_kernels) if args.build_beside_imports else None
    startup.timed_imports("torch", "rsl_rl", "hexnewton.mdp.env", "hexnewton.learning.runner")
    check_outputs(args)
    from hexnewton.learning.runner import seed_everything

    seed_everything(cfg.task.seed)
    env = checked_env(args, base, cfg, build, ckpt, init)
    meta = {"task": base.name, "robot": cfg.robot.name, "action_mode": base.action_mode, "num_obs": env.num_obs,
            "num_actions": env.num_actions, "config": dataclasses.asdict(cfg), "agent": dataclasses.asdict(agent),
            "world_size": rank.world_size, **init_meta(args, init)}  # fmt: skip
    agent = ranks_agent(agent, rank)  # checkpoints keep the unscaled one: a resumed run scales for its own ranks
    run_dir = make_run_dir(args, meta, agent.to_rsl_rl(cfg.sim.num_envs, env.obs_groups), rank)
    runner, views = make_runner(args, env, agent, meta, run_dir, rank, ckpt, init)
    where = f"rank {rank.rank} of {rank.world_size}, " if rank.world_size > 1 else ""
    on = f" on robot {cfg.robot.name}" if cfg.robot.name != "paper" else ""
    print(f"training task {base.name}{on}: {where}{cfg.sim.num_envs} envs on {cfg.sim.device}, {agent.max_iterations} "
          f"iterations, logs in {run_dir}")  # fmt: skip
    for view in views:
        view.first_iteration = runner.current_learning_iteration
    t0, first_it = time.time(), runner.current_learning_iteration
    try:
        reason = runner.train(agent.max_iterations)
    finally:
        for view in views:
            view.close()
    train_s = time.time() - t0
    print(f"finished at iteration {runner.current_learning_iteration} after {train_s:.0f} s ({reason})")
    if rank.world_size > 1:
        check_ranks_agree(runner, rank)
    started = startup.phases(), startup.notes()  # validation's env marks its own build
    validated = validate_result(runner, cfg, agent, run_dir, first_it, rank) if agent.validation_rounds else None
    if rank.world_size > 1:
        runner.leave_group()
    if rank.is_main:
        finish(args, runner, cfg, agent, rank, run_dir, views, train_s, first_it, validated, started, reason)
    return exit_status(reason)


if __name__ == "__main__":
    sys.exit(run(main, "python train.py"))
