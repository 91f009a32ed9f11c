"""The curriculum's ceiling: how much of the complex recipe's top lane its training curriculum lets a robot reach that
walks as the shipped policy does from the first iteration on, per arm (arms.py). No learning: the shipped policy
(``results/policies/cpg_rl_complex.pt``) plays the training env of ``python train.py --task complex`` with the arm's
flags for the run's iterations x steps per iteration, as training meets it: the episode counters spread at the start
(rsl-rl's ``init_at_random_ep_len``), the curriculum stages' reflex gains and physics from their iterations on
(``apply_stage``), the lanes counted by the run's own ``LaneLog``. Its actions are sampled from the policy's
distribution as training's are (``--action sample``) or its mean (``mean``, the deterministic action). A robot climbs
a lane per goal reached: a run whose policy walks worse than the shipped one, as every run's does early on, climbs no
faster, so an arm whose last stage sees less than the target here leaves it out of reach of its runs too.

    python studies/curriculum/ceiling.py --out DIR                      # every arm, 128 robots, sampled actions, seed 1
    python studies/curriculum/ceiling.py --out DIR --num_envs 64 --seeds 1 2 --device cpu   # the kept one (ceiling/)
    python studies/curriculum/ceiling.py --out DIR --arms recipe spread --num_envs 64 --iterations 100

``--out`` (which must not exist) receives report.md and results.json; the study keeps them in ``ceiling/``.
"""

from __future__ import annotations

import json
import os
import sys
import time

from hexnewton.apps.cli import ArgumentParser, check_new_dir, positive_int, run

HERE = os.path.dirname(os.path.abspath(__file__))


def _arms() -> dict:
    """arms.py's ARMS (loaded under a name of its own: other studies' scripts share file names)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("curriculum_arms", os.path.join(HERE, "arms.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.ARMS


ARMS = _arms()

SHIPPED = "results/policies/cpg_rl_complex.pt"
#: the issue's target: the last stage's finished episodes on the top lane
TARGET = 0.20


def arm_overrides(flags: str, env) -> dict:
    """An arm's ``--env.A.B V`` flags as ``apply_overrides`` paths, each value of its field's type in ``env``."""
    words = flags.split()
    out = {}
    for name, value in zip(words[::2], words[1::2]):
        if not name.startswith("--env."):
            raise ValueError(f"arm flag {name}: only --env.* flags are read here")
        path = name[len("--env."):]
        section, field = path.split(".")
        out[path] = type(getattr(getattr(env, section), field))(value)
    return out


def play_arm(arm: str, num_envs: int, iterations: int, action: str, seed: int, device: str) -> dict:
    """The shipped policy through ``iterations`` training iterations of arm ``arm`` (module docstring): the run's
    ``LaneLog.summary`` and the top lane's share of the episodes finished in each iteration."""
    import dataclasses

    import torch

    from hexnewton.analysis.rollout import controller_policy, read_controller_checkpoint
    from hexnewton.config import apply_overrides
    from hexnewton.learning.agent import apply_stage, stage_at
    from hexnewton.learning.lanes import LaneLog, shares
    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import task

    t = task("complex")
    cfg = apply_overrides(t.env, arm_overrides(ARMS[arm][0], t.env))
    cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, num_envs=num_envs, device=device),
                              task=dataclasses.replace(cfg.task, seed=seed))  # fmt: skip
    env = make_env(cfg, t.action_mode)
    ckpt = read_controller_checkpoint("cpg_rl", SHIPPED)
    policy = controller_policy(env, "cpg_rl", SHIPPED, ckpt, stochastic=action == "sample")
    torch.manual_seed(seed)
    env.episode_length_buf = torch.randint_like(env.episode_length_buf, high=int(env.max_episode_length))
    lanes, stage, steps = LaneLog(env), None, t.agent.num_steps_per_env
    per_iteration = []
    obs = env.get_observations()
    t0 = time.perf_counter()
    for it in range(iterations):
        index, changes = stage_at(t.agent.stages, it)
        if index >= 0 and index != stage:
            apply_stage(env, changes)
            lanes.new_stage(index + 1, it)
            stage = index
        with torch.inference_mode():
            for _ in range(steps):
                obs, _, _, _ = env.step(policy(obs))
        lanes.update()
        step = lanes.now - lanes.previous
        per_iteration.append(float(shares(step)[-1]) if step[..., 0].sum() else None)
    summary = lanes.summary()
    return {"arm": arm, "flags": ARMS[arm][0], "num_envs": num_envs, "iterations": iterations,
            "steps_per_iteration": steps, "action": action, "seed": seed, "wall_s": round(time.perf_counter() - t0, 1),
            "summary": summary, "iteration_top_lane_share": per_iteration}  # fmt: skip


def pct(v) -> str:
    return "-" if v is None else f"{100 * v:.1f}"


def pooled(runs: list[dict]) -> dict:
    """Per arm, its seeds' last stages together: episodes, those on the top lane, the share, and each seed's share."""
    out: dict = {}
    for r in runs:
        last = r["summary"]["last_stage"]
        top = last["lanes_top_first"][0]["episodes"]
        o = out.setdefault(r["arm"], {"flags": r["flags"], "episodes": 0, "top_lane_episodes": 0, "seed_shares": {}})
        o["episodes"] += last["episodes"]
        o["top_lane_episodes"] += top
        o["seed_shares"][str(r["seed"])] = last["top_lane_share"]
    for o in out.values():
        o["top_lane_share"] = o["top_lane_episodes"] / o["episodes"] if o["episodes"] else None
        shares_ = [v for v in o["seed_shares"].values() if v is not None]
        o["every_seed_meets_target"] = len(shares_) == len(o["seed_shares"]) and min(shares_) >= TARGET
    return out


def render(res: dict) -> str:
    """report.md from results.json."""
    seeds = ", ".join(str(s) for s in res["seeds"])
    lines = ["# The curriculum's ceiling", "",
             "How much of its own top lane the complex recipe's training curriculum lets a robot reach that walks as "
             "the shipped policy does from the first iteration on (`studies/curriculum/ceiling.py`: the shipped policy "
             "plays the training env of `--task complex` with each arm's flags, as training meets it, no learning). "
             f"The issue's target for a run: >= {100 * TARGET:.0f} % of the last stage's finished episodes on the top "
             "lane, on every seed.", "",
             f"Command: `{res['command']}` ({res['device']}, {res['num_envs']} robots, {res['iterations']} iterations "
             f"of {res['steps_per_iteration']} steps per robot, actions: {res['action']}, seeds {seeds}, code "
             f"{res['commit']}).", "",
             "| arm | seeds' last stages: episodes | on the top lane | per seed | target on every seed |",
             "|---|---:|---:|---|---|"]  # fmt: skip
    for arm, o in res["arms"].items():
        per = ", ".join(f"{pct(v)} %" for v in o["seed_shares"].values())
        lines.append(f"| {arm} | {o['episodes']} | {o['top_lane_episodes']} ({pct(o['top_lane_share'])} %) | {per} | "
                     f"{'reachable' if o['every_seed_meets_target'] else 'out of reach'} |")
    lines += ["", "Each run (the last stage from its iteration on; lanes counted 1, the easiest, to 10, the course's "
              "own heights):", "",
              "| arm | seed | last stage from iteration | its episodes | on the top lane | "
              "run's episodes on the top lane | episodes per robot | mean lane at the end | wall time |",
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
    for r in res["runs"]:
        s, last = r["summary"], r["summary"]["last_stage"]
        lines.append(f"| {r['arm']} | {r['seed']} | {last['first_iteration']} | {last['episodes']} | "
                     f"{pct(last['top_lane_share'])} % | {pct(s['run']['top_lane_share'])} % | "
                     f"{s['episodes_per_robot']:.1f} | {s['mean_level_end'] + 1:.1f} of {s['levels']} | "
                     f"{r['wall_s']:.0f} s |")
    lines += ["", "The last stage's finished episodes per lane, top lane first:", ""]
    for r in res["runs"]:
        lanes = r["summary"]["last_stage"]["lanes_top_first"]
        lines.append(f"- {r['arm']} ({r['flags'] or 'no flags'}), seed {r['seed']}: "
                     + ", ".join(f"lane {x['lane'] + 1} {x['episodes']}" for x in lanes))
    lines += ["", "An arm out of reach here leaves its last stage below the target even for a walker as good as the "
              "shipped one from the first iteration on; a run's policy, which walks worse early on, climbs no faster. "
              "One reachable here still has to be reached by what its runs learn (the arms' runs: report.md). A "
              "share counts episodes, and a robot's episodes follow one another up its lanes: the seeds' spread, not "
              "a binomial error, says how far a share moves."]  # fmt: skip
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python studies/curriculum/ceiling.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", required=True, help="a new folder for report.md and results.json")
    p.add_argument("--arms", nargs="+", choices=list(ARMS), default=list(ARMS))
    p.add_argument("--num_envs", type=positive_int, default=128)
    p.add_argument("--iterations", type=positive_int, default=None, help="default: the task's max_iterations")
    p.add_argument("--action", choices=("sample", "mean"), default="sample")
    p.add_argument("--seeds", type=int, nargs="+", default=[1],
                   help="one run per arm and seed (its terrain, starts and sampled actions)")
    p.add_argument("--device", default=None, help="default: cuda:0 where there is one, else cpu")
    a = p.parse_args(argv)
    check_new_dir(a.out)
    from hexnewton.analysis.report import git_rev
    from hexnewton.physics.device import resolve_device
    from hexnewton.tasks import task

    t = task("complex")
    device = resolve_device(a.device)
    iterations = a.iterations or t.agent.max_iterations
    res = {"command": "python studies/curriculum/ceiling.py " + " ".join(sys.argv[1:] if argv is None else argv),
           "commit": git_rev(), "device": device, "num_envs": a.num_envs, "iterations": iterations,
           "steps_per_iteration": t.agent.num_steps_per_env, "action": a.action, "seeds": a.seeds, "runs": []}
    for seed in a.seeds:
        for arm in a.arms:
            r = play_arm(arm, a.num_envs, iterations, a.action, seed, device)
            last = r["summary"]["last_stage"]
            print(f"{arm}, seed {seed}: last stage {pct(last['top_lane_share'])} % of {last['episodes']} episodes on "
                  f"the top lane, {r['summary']['episodes_per_robot']:.1f} per robot, {r['wall_s']:.0f} s", flush=True)
            res["runs"].append(r)
    res["arms"] = pooled(res["runs"])
    os.makedirs(a.out)
    with open(os.path.join(a.out, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(a.out, "report.md"), "w") as f:
        f.write(render(res))
    print(f"report in {a.out}/ (report.md, results.json)")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "ceiling.py"))
