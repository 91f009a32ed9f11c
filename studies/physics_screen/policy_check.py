"""Trained CPG_RL policies (trained at the default physics) rolled out under each candidate SimConfig (CPU).

    python studies/physics_screen/policy_check.py A C ...
flat policy on flat (16 robots x 2 seeds, 15 s), rugged policy on rugged (16 robots x 2 seeds, 30 s);
reset_yaw 0.2 as in training, first episodes only.
"""
import sys
import warnings
from dataclasses import replace

import numpy as np

from hexnewton.analysis.rollout import rollout
from hexnewton.config import HexConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.learning.checkpoint import load_checkpoint, trained_config
from hexnewton.learning.policy import load_policy
from hexnewton.mdp.env import make_env

sys.path.insert(0, "studies/physics_screen")
from candidates import CANDIDATES  # noqa: E402

POL = {"flat": ("results/policies/cpg_rl_flat.pt", 15.0), "rugged": ("results/policies/cpg_rl_rugged.pt", 30.0)}

for name in sys.argv[1:]:
    for terrain, (path, seconds) in POL.items():
        cpg = trained_config(load_checkpoint(path)).cpg
        rows = []
        for seed in (11, 12):
            cfg = HexConfig(sim=replace(SimConfig(), num_envs=16, device="cpu", **CANDIDATES[name]),
                            terrain=TerrainConfig(name=terrain, seed=seed), task=replace(TaskConfig(), seed=seed), cpg=cpg)
            env = make_env(cfg, "cpg")
            policy = load_policy(env, path, "cpg")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                st = rollout(env, policy, int(seconds / cfg.task.control_dt), progress=False)
            rows.append(st)
        dist = np.mean([r["distance_m"] for r in rows])
        ended = {}
        for r in rows:
            for k, v in r["ended"].items():
                ended[k] = ended.get(k, 0) + v
        ovf = env.world.overflow_frames
        print(f"{name:4s} {terrain:6s} {seconds:.0f}s: dist {dist:.2f} m (min {min(r['distance_min_m'] for r in rows):.2f}), "
              f"|roll| {np.mean([r['roll_mean_deg'] for r in rows]):.1f} |pitch| {np.mean([r['pitch_mean_deg'] for r in rows]):.1f} deg, "
              f"ended {ended}, overflow frames {ovf}", flush=True)
