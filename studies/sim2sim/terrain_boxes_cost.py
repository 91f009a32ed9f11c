"""The CPU cost of the rugged course's terrain collision settings under the shipped complex policy (the wedge
measurement's setup, studies/sim2sim/wedge/report.md): shapes, explicit shape pairs, build time, wall time per
20 ms control step (one physics frame), contacts per frame and any overflow.

    PYTHONPATH=. python studies/sim2sim/terrain_boxes_cost.py --robots 4 20 --steps 200 --out studies/sim2sim/wedge/cost.json
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

POLICY = "results/policies/cpg_rl_complex.pt"
SETTINGS = ("mesh_boxes", "boxes")


def measure(collision: str, robots: int, steps: int, seed: int) -> dict:
    import torch

    from hexnewton.analysis.rollout import CONTROLLERS, START_SEED_OFFSET, controller_policy, read_controller_checkpoint
    from hexnewton.learning.checkpoint import trained_config
    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import course

    t0 = time.perf_counter()
    ckpt = read_controller_checkpoint("cpg_rl", POLICY)
    cfg = course("rugged", trained_config(ckpt), {"terrain.collision": collision}, robots, "cpu", seed,
                 seed=seed + START_SEED_OFFSET)  # fmt: skip
    env = make_env(cfg, CONTROLLERS["cpg_rl"])
    policy = controller_policy(env, "cpg_rl", POLICY, ckpt, False, False, None)
    world = env.world
    build_s = time.perf_counter() - t0
    obs = env.get_observations()
    contacts, wall = [], []
    with torch.inference_mode():
        for k in range(steps):
            t = time.perf_counter()
            obs, _, _, _ = env.step(policy(obs))
            contacts.append(int(world.contacts.rigid_contact_count.numpy()[0]))
            if k >= 10:  # after the first steps' kernel compilation and graph capture
                wall.append(time.perf_counter() - t)
    report = world.check_contacts()
    return {"collision": collision, "robots": robots, "steps": steps, "shapes": int(world.model.shape_count),
            "explicit_pairs": len(world.pipeline.shape_pairs_filtered), "build_s": round(build_s, 1),
            "ms_per_step": round(1000 * float(np.mean(wall)), 1), "contacts_per_frame": round(float(np.mean(contacts)), 1),
            "contacts_per_robot": round(float(np.mean(contacts)) / robots, 1), "overflow": report.describe()
            if not report.ok else None, "rigid_contact_max": int(world.pipeline.rigid_contact_max)}  # fmt: skip


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--robots", type=int, nargs="+", default=[4, 20])
    p.add_argument("--steps", type=int, default=200, help="control steps (20 ms frames) per measurement")
    p.add_argument("--seed", type=int, default=1000, help="terrain seed (starts: seed + 1000)")
    p.add_argument("--settings", nargs="+", default=list(SETTINGS), choices=SETTINGS)
    p.add_argument("--out", required=True)
    a = p.parse_args()
    if min(a.robots) < 1 or a.steps <= 10:
        p.error("--robots must be >= 1 and --steps > 10 (the first 10 steps are not timed)")
    res = {"command": "PYTHONPATH=. python studies/sim2sim/terrain_boxes_cost.py " + " ".join(sys.argv[1:]), "runs": []}
    for n in a.robots:
        for s in a.settings:
            res["runs"].append(measure(s, n, a.steps, a.seed))
            print(json.dumps(res["runs"][-1]), flush=True)
            with open(a.out, "w") as f:
                json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
