"""The MuJoCo model options of the two sides of the sim2sim gap, side by side (studies/sim2sim/wedge/report.md, "Which
MuJoCo setting wedges"): the shipped bundle's C MuJoCo model (``hexnewton.analysis.sim2sim.Rounds`` on the rugged
course) and the mujoco_warp model that Newton's SolverMuJoCo builds for the shipped policy's own physics (its
checkpoint's config, ``hexnewton.physics.world.World``), both with 2 robots on seed 1000's course, CPU.

    PYTHONPATH=. python studies/sim2sim/sim2sim_physics_diff.py --out studies/sim2sim/wedge/physics_diff.json

Per side: the solver options, the first robot's foot geom (friction, condim, solref, solimp, margin, gap), the first
leg's hinge joints (limit solref / solimp, armature, damping), the first actuator (gain, bias, force clamp) and the
joint's actuator-force clamp. Newton hands MuJoCo its own contacts (``use_mujoco_contacts=False``): each contact
takes the pair's geom parameters (``contact_params``) with ``includemargin`` = the summed geom margins (0).
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np

POLICY = "results/policies/cpg_rl_complex.pt"
BUNDLE = "results/controllers/cpg_rl_complex"
OPT = ("timestep", "integrator", "solver", "cone", "iterations", "ls_iterations", "tolerance", "ls_tolerance",
       "noslip_iterations", "disableflags")


def _pick(a, i=0):
    return np.asarray(a, np.float64)[i].round(6).tolist()


def _world0(mw, m, name: str) -> np.ndarray:
    """A mujoco_warp model array of world 0 (batched arrays carry a leading world axis that MuJoCo's lacks)."""
    a = getattr(mw, name).numpy()
    return a[0] if a.ndim == np.ndim(getattr(m, name)) + 1 else a


def summary(opt: dict, get, foot: int, hinges: list[int], dofs: list[int]) -> dict:
    """The compared fields: ``opt`` the solver options, ``get(name)`` a model array (world 0), ``foot`` a foot geom,
    ``hinges`` / ``dofs`` the first leg's joints and their dofs."""
    return {"opt": opt,
            "foot_geom": {k: _pick(get(f"geom_{k}"), foot) for k in ("friction", "condim", "solref", "solimp",
                                                                     "margin", "gap")},
            "first_leg_joints": {k: [_pick(get(f"jnt_{k}"), j) for j in hinges] for k in ("solref", "solimp",
                                                                                          "actfrclimited",
                                                                                          "actfrcrange")},
            "first_leg_dofs": {k: [_pick(get(f"dof_{k}"), d) for d in dofs] for k in ("armature", "damping")},
            "first_actuator": {k: _pick(get(f"actuator_{k}"), 0) for k in ("gainprm", "biasprm", "forcelimited",
                                                                          "forcerange")}}


def bundle_side() -> dict:
    from hexnewton.analysis.sim2sim import Rounds

    m = Rounds(BUNDLE, "rugged", 2, 1000).m
    foot = [i for i in range(m.ngeom) if (m.geom(i).name or "").endswith("_foot")][0]
    return summary({k: float(getattr(m.opt, k)) for k in OPT}, lambda n: getattr(m, n), foot, [1, 2, 3], [6, 7, 8])


def newton_side() -> dict:
    from hexnewton.analysis.rollout import START_SEED_OFFSET, read_controller_checkpoint
    from hexnewton.learning.checkpoint import trained_config
    from hexnewton.physics.world import World
    from hexnewton.tasks import course

    cfg = course("rugged", trained_config(read_controller_checkpoint("cpg_rl", POLICY)), {}, 2, "cpu", 1000,
                 seed=1000 + START_SEED_OFFSET)
    w = World(cfg)
    mw, m = w.solver.mjw_model, w.solver.mj_model
    opt = {k: float(np.asarray(getattr(mw.opt, k).numpy() if hasattr(getattr(mw.opt, k), "numpy")
                               else getattr(mw.opt, k)).ravel()[0]) for k in OPT if hasattr(mw.opt, k)}
    opt.update(timestep=w.sim_dt, frame_dt=w.frame_dt, collision_per_frame=True, use_mujoco_contacts=False,
               terrain_collision=cfg.terrain.collision)
    foot = [i for i in range(m.ngeom) if "foot" in (m.geom(i).name or "")][0]
    return summary(opt, lambda n: _world0(mw, m, n), foot, [1, 2, 3], [6, 7, 8])


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True)
    a = p.parse_args()
    res = {"command": "PYTHONPATH=. python studies/sim2sim/sim2sim_physics_diff.py " + " ".join(sys.argv[1:]),
           "bundle_c_mujoco": bundle_side(), "newton_training": newton_side()}
    print(json.dumps(res, indent=1))
    with open(a.out, "w") as f:
        json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
