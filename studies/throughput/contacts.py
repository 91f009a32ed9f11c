"""Contacts and MuJoCo constraint rows per robot under the shipped complex policy, for physics settings that could
shrink the solver's work (its share of the complex step's GPU time: 68.5 %, profile/complex_16384/report.md), on the
CPU: each setting's flags (``SETTINGS``) on the rugged and complex courses, a few robots, the deterministic action.

    python studies/throughput/contacts.py --robots 16 --steps 300 --out studies/throughput/contacts
    python studies/throughput/contacts.py --rebuild studies/throughput/contacts     # report.md from results.json

Per setting and course: Newton's rigid contacts per robot (after its contact reduction) and MuJoCo's constraint rows
per world (``nefc``: 4 per pyramidal contact plus joint limits), the mean and the largest over the steps. The
physics' speed and the A/B on 1000 rounds per course are GPU work (studies/throughput/solver_ab.sh); this tells which
settings are worth it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

POLICY = "results/policies/cpg_rl_complex.pt"
#: physics settings (SimConfig fields) against the default; rigid_gap: Newton's contact band per shape (a foot meets
#: the terrain within twice it); speculative_gap: the band widened by the closing speed x frame for shapes that approach
SETTINGS = {"base": {}, "gap2_spec": {"sim.rigid_gap": 0.002, "sim.speculative_gap": 0.01},
            "gap3_spec": {"sim.rigid_gap": 0.003, "sim.speculative_gap": 0.01}}
TERRAINS = ("rugged", "complex")


def measure(setting: str, terrain: str, robots: int, steps: int, seed: int) -> dict:
    import torch

    from hexnewton.analysis.rollout import CONTROLLERS, START_SEED_OFFSET, controller_policy, read_controller_checkpoint
    from hexnewton.learning.checkpoint import trained_config
    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import course

    ckpt = read_controller_checkpoint("cpg_rl", POLICY)
    cfg = course(terrain, trained_config(ckpt), dict(SETTINGS[setting]), robots, "cpu", seed,
                 seed=seed + START_SEED_OFFSET)  # fmt: skip
    env = make_env(cfg, CONTROLLERS["cpg_rl"])
    policy = controller_policy(env, "cpg_rl", POLICY, ckpt, False, False, None)
    world = env.world
    data = world.solver.mjw_data
    obs = env.get_observations()
    contacts, rows = [], []
    t0 = time.perf_counter()
    with torch.inference_mode():
        for _ in range(steps):
            obs = env.step(policy(obs))[0]
            contacts.append(int(world.contacts.rigid_contact_count.numpy()[0]))
            rows.append(data.nefc.numpy().copy())
    wall = time.perf_counter() - t0
    rows = np.stack(rows)
    overflow = world.check_contacts()
    return {"setting": setting, "flags": SETTINGS[setting], "terrain": terrain, "robots": robots, "steps": steps,
            "contacts_per_robot": round(float(np.mean(contacts)) / robots, 1),
            "contacts_per_robot_max": round(max(contacts) / robots, 1),
            "rows_per_world": round(float(rows.mean()), 1), "rows_per_world_max": int(rows.max()),
            "s_per_step": round(wall / steps, 3), "overflow": None if overflow.ok else overflow.describe()}


def report(res: dict) -> str:
    lines = ["# Contacts and constraint rows per robot: physics settings against the default (CPU)", "",
             f"`{res['command']}` ({res['machine']}; the shipped `cpg_rl_complex` policy, deterministic action, "
             f"{res['robots']} robots per course, {res['steps']} control steps of 20 ms, terrain seed {res['seed']}). "
             "Numbers: results.json.", "",
             "| setting | flags | course | contacts per robot (mean / max) | constraint rows per world (mean / max) | "
             "CPU s per step | overflow |", "|---|---|---|---:|---:|---:|---|"]  # fmt: skip
    for r in res["runs"]:
        flags = " ".join(f"--env.{k} {v}" for k, v in r["flags"].items()) or "(defaults)"
        lines.append(f"| {r['setting']} | `{flags}` | {r['terrain']} | {r['contacts_per_robot']} / "
                     f"{r['contacts_per_robot_max']} | {r['rows_per_world']} / {r['rows_per_world_max']} | "
                     f"{r['s_per_step']} | {r['overflow'] or 'none'} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robots", type=int, default=16)
    p.add_argument("--steps", type=int, default=300, help="control steps (20 ms) per setting and course")
    p.add_argument("--seed", type=int, default=1000, help="terrain seed (starts: seed + 1000)")
    p.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=list(SETTINGS))
    p.add_argument("--out", help="folder for results.json and report.md")
    p.add_argument("--rebuild", metavar="DIR", help="report.md again from DIR/results.json")
    a = p.parse_args()
    if a.rebuild:
        with open(os.path.join(a.rebuild, "results.json")) as f:
            res = json.load(f)
        with open(os.path.join(a.rebuild, "report.md"), "w") as f:
            f.write(report(res))
        return
    if not a.out or a.robots < 1 or a.steps < 1:
        p.error("--out DIR, --robots >= 1 and --steps >= 1 are needed")
    os.makedirs(a.out, exist_ok=True)
    res = {"command": "python studies/throughput/contacts.py " + " ".join(sys.argv[1:]), "robots": a.robots,
           "steps": a.steps, "seed": a.seed, "machine": f"{os.cpu_count()} CPU cores, device cpu", "runs": []}
    for s in a.settings:
        for t in TERRAINS:
            res["runs"].append(measure(s, t, a.robots, a.steps, a.seed))
            print(json.dumps(res["runs"][-1]), flush=True)
            with open(os.path.join(a.out, "results.json"), "w") as f:
                json.dump(res, f, indent=1)
    with open(os.path.join(a.out, "report.md"), "w") as f:
        f.write(report(res))


if __name__ == "__main__":
    main()
