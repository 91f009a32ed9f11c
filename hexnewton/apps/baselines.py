"""Train SAC-CPG, TD3-CPG or A2C-CPG with skrl on a task: ``python -m hexnewton.apps.baselines --task T --algo A``.

    python -m hexnewton.apps.baselines --task complex --algo sac                         # scale preset, the task's budget
    python -m hexnewton.apps.baselines --task complex --algo a2c --preset paper --total_steps 100000000 --max_minutes 8
    python -m hexnewton.apps.baselines --task rugged --algo td3 --agent.batch_size 8192 --env.reward.w_tilt 10
    python -m hexnewton.apps.baselines --task complex --algo sac --robot mx_phoenix     # another robot (name or file)

The task's environment config (``--env.<section>.<field>`` overrides it as in ``train.py``) and curriculum stages;
the algorithm's preset (``--agent.<field>`` overrides it; ``--task T --algo A --help`` lists the fields with their
values). The budget: ``--total_steps`` env-steps over all envs (default: what the task's PPO recipe collects with
the same number of envs, max_iterations x num_steps_per_env x num_envs) and ``--max_minutes`` of wall time, whichever
ends first. ``--robot NAME|FILE`` trains on another robot than the paper's as ``train.py`` does (docs/robots.md: the
task's config scaled for it, ``with_robot``); its checkpoints record the robot, and its runs go to
``hexnewton_<task>_<algo>_<robot>``. Details: ``hexnewton/learning/baselines/`` (``__init__.py``; the presets in
``config.py``). It needs skrl, the ``baselines`` extra (``pip install -e ".[baselines]"``); without it the command says
so in one line, exit status 2.
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import os
import sys

from hexnewton.apps.cli import (
    ArgumentParser,
    add_config_args,
    add_robot_args,
    config_overrides,
    positive_int,
    robot_from_args,
    run,
)
from hexnewton.config import apply_overrides
from hexnewton.learning.stopping import exit_status


def _chosen(argv: list[str] | None) -> tuple[str, str | None, str]:
    """The task, algorithm and preset the command line names (before the full parser is built from them)."""
    pre = ArgumentParser(add_help=False)
    pre.add_argument("--task", default="complex")
    pre.add_argument("--algo", default=None)
    pre.add_argument("--preset", default="scale")
    known, _ = pre.parse_known_args(argv)
    return known.task, known.algo, known.preset


def parser(base, algo: str | None, preset: str) -> ArgumentParser:
    from hexnewton.learning.baselines import ALGOS, PRESETS, agent_config
    from hexnewton.tasks import TASKS

    p = ArgumentParser(prog="python -m hexnewton.apps.baselines", description="SAC-/TD3-/A2C-CPG with skrl on a task.",
                       usage="python -m hexnewton.apps.baselines --algo {sac,td3,a2c} [--task NAME] [--preset "
                             "{scale,paper}] [options] [--env.SECTION.FIELD VALUE ...] [--agent.FIELD VALUE ...]")  # fmt: skip
    p.add_argument("--algo", required=True, choices=ALGOS, help="the algorithm")
    p.add_argument("--task", choices=list(TASKS), default=base.name, help="the task (default complex)")
    p.add_argument("--preset", choices=PRESETS, default="scale",
                   help="scale: settings for thousands of envs; paper: Table 2 (default scale)")
    p.add_argument("--num_envs", type=positive_int, default=None, help="envs (default 4096 on CUDA, 16 on CPU)")
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--seed", type=int, default=base.env.task.seed,
                   help=f"seed of the networks, actions and resets (default {base.env.task.seed})")
    p.add_argument("--total_steps", type=positive_int, default=None,
                   help="env-steps over all envs (default: the task's PPO budget at this number of envs, "
                        f"{base.agent.max_iterations} x {base.agent.num_steps_per_env} x num_envs)")
    p.add_argument("--max_minutes", type=float, default=None, help="end (and save) after this wall time")
    add_robot_args(p, "the paper's")
    p.add_argument("--log_dir", default="logs")
    p.add_argument("--experiment", default=None, help="default: hexnewton_<task>_<algo> (on another robot than the "
                   "paper's hexnewton_<task>_<algo>_<robot>)")
    add_config_args(p, "env", base.env, skip=("sim.num_envs", "sim.device", "task.seed"),
                    title="--env.*: the environment (HexConfig, hexnewton/config.py)")
    if algo in ALGOS and preset in PRESETS:
        add_config_args(p, "agent", agent_config(algo, preset),
                        title=f"--agent.*: {algo.upper()} ({preset} preset; hexnewton/learning/baselines/config.py)")
    return p


def main(argv: list[str] | None = None) -> int:
    from hexnewton.learning.baselines import LABELS, agent_config, require_skrl
    from hexnewton.tasks import task

    name, algo, preset = _chosen(argv)
    base = task(name)
    args = parser(base, algo, preset).parse_args(argv)
    skrl = require_skrl()  # the baselines extra: one line naming the install where it is missing (--help needs none)
    if base.action_mode != "cpg":
        raise ValueError(f"task {base.name} sets joint targets: SAC-/TD3-/A2C-CPG act through the CPG (pure DRL trains "
                         f"with python train.py --task {base.name})")  # fmt: skip
    if args.max_minutes is not None and not args.max_minutes > 0:
        raise ValueError("--max_minutes must be positive")
    robot, base_env = robot_from_args(args), base.env
    if robot is not None:  # the robot and its scales first, the --env.* overrides on top (as train.py)
        from hexnewton.robot.registry import with_robot

        base_env = with_robot(base.env, robot)
    env_cfg = apply_overrides(base_env, config_overrides(args, "env"))
    cfg = apply_overrides(agent_config(args.algo, args.preset), config_overrides(args, "agent"))
    cfg.check()
    stages = base.agent.stages
    if stages and not env_cfg.cpg.posture:
        raise ValueError(f"task {base.name}'s curriculum stages change the body posture's levelling reflex: keep "
                         "--env.cpg.posture true")  # fmt: skip
    from hexnewton.learning.runner import check_log_dir

    check_log_dir(args.log_dir)

    from skrl.utils import set_seed

    from hexnewton.learning.baselines import BaselineTrainer, Budget, make_agent, wrap_env
    from hexnewton.learning.runner import seed_everything
    from hexnewton.mdp.env import make_env
    from hexnewton.physics.device import resolve_device

    device = resolve_device(args.device)
    num_envs = args.num_envs or (4096 if device.startswith("cuda") else 16)
    total = args.total_steps or base.agent.max_iterations * base.agent.num_steps_per_env * num_envs
    seed_everything(args.seed)
    set_seed(args.seed)
    # skrl's critic reads the policy's observation: the critic group (ObsConfig.critic) would go unread
    cfg_env = dataclasses.replace(env_cfg, sim=dataclasses.replace(env_cfg.sim, num_envs=num_envs, device=device),
                                  task=dataclasses.replace(env_cfg.task, seed=args.seed),
                                  obs=dataclasses.replace(env_cfg.obs, critic=False))  # fmt: skip
    env = make_env(cfg_env, "cpg")
    robot_name = cfg_env.robot.name  # another robot's runs are named after it, as train.py's
    on_robot = f"_{robot_name}" if robot_name != "paper" else ""
    experiment = args.experiment or f"hexnewton_{base.name}_{args.algo}{on_robot}"
    run_dir = os.path.join(args.log_dir, experiment, datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S"))
    if os.path.exists(run_dir):
        raise ValueError(f"{run_dir} exists: nothing is overwritten (start again in a second, or change --experiment)")
    os.makedirs(run_dir)
    meta = {"task": base.name, "robot": robot_name, "algo": args.algo, "controller": f"{args.algo}_cpg",
            "preset": args.preset, "action_mode": "cpg", "num_obs": env.num_obs, "num_actions": env.num_actions,
            "num_envs": num_envs, "seed": args.seed, "device": device, "skrl": skrl.__version__,
            "budget": {"env_steps": total, "max_minutes": args.max_minutes},
            "stages": [list(s) for s in stages], "steps_per_iteration": base.agent.num_steps_per_env,
            "config": dataclasses.asdict(cfg_env), "baseline": dataclasses.asdict(cfg)}  # fmt: skip
    with open(os.path.join(run_dir, "config.json"), "w") as f:
        json.dump({"hexnewton": meta}, f, indent=1, default=str)
    skrl_env = wrap_env(env)
    agent = make_agent(args.algo, cfg, skrl_env.observation_space, skrl_env.action_space, device, num_envs,
                       training=True, run_dir=run_dir)  # fmt: skip
    trainer = BaselineTrainer(env, agent, args.algo, cfg, meta, run_dir, stages, base.agent.num_steps_per_env)
    limit = f" or {args.max_minutes:g} min" if args.max_minutes else ""
    on = f" on robot {robot_name}" if robot_name != "paper" else ""
    print(f"training {LABELS[args.algo]} ({args.preset} preset) on task {base.name}{on}: {num_envs} envs on {device}, "
          f"{total} env-steps{limit}, logs in {run_dir}", flush=True)  # fmt: skip
    reason = trainer.train(Budget(total, args.max_minutes))
    print(f"finished after {trainer.env_steps} env-steps in {trainer.wall_s:.0f} s ({reason})")
    stats = env.episode_stats()
    print("last episodes: " + ", ".join(f"{k} {v:.3f}" for k, v in stats.items()))
    final = trainer.last_checkpoint
    print(f"\nresults in {run_dir} (checkpoints, TensorBoard events). Next:\n"
          f"  python play.py --checkpoint {final}\n"
          f"  python -m hexnewton.apps.evaluate --controllers cpg cpg_rl {args.algo}_cpg --checkpoint cpg_rl=POLICY.pt "
          f"{args.algo}_cpg={final} --terrains {cfg_env.terrain.name}\n"
          f"  tensorboard --logdir {args.log_dir}")  # fmt: skip
    return exit_status(reason)


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.baselines"))
