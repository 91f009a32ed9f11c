"""The shipped complex policy in MuJoCo (hexnewton.apps.sim2sim) and in Newton (hexnewton.analysis.rollout.run_rounds, CPU) on the
same terrain and lanes, step by step: where the two simulators part (studies/sim2sim/report.md, "Why they differ").

    PYTHONPATH=. python studies/sim2sim/sim2sim_side_by_side.py --out studies/sim2sim/side_by_side.json

Per case: R robots for T control steps (terrain seed 1000, lanes as in the evaluation; Newton draws its start offsets
with Warp, MuJoCo with NumPy), each robot's first episode: mean x progress, the robots still walking at the end whose
last 10 s took them less than 5 cm ("stuck"), and in MuJoCo how many stuck robots hold a foot between opposing walls
(two contacts of one foot whose horizontal normals point against each other: wedged in a gap narrower than the foot).
Newton also runs with collision detection at every 5 ms step (``sim.frame_dt 0.005, sim.substeps 1``) instead of once
per 20 ms frame, and MuJoCo reports its solver's iterations per step.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

POLICY = "results/policies/cpg_rl_complex.pt"
BUNDLE = "results/controllers/cpg_rl_complex"
CASES = (("flat", 10, 250), ("rugged", 20, 1500))
STUCK_WINDOW = 500  # control steps (10 s)


def first_episode_summary(pos: np.ndarray, done: np.ndarray) -> dict:
    """Mean x progress over each robot's first episode, robots ended, robots stuck at the end."""
    t_len, n = done.shape
    ended = done.any(axis=0)
    last = np.where(ended, np.argmax(done, axis=0), t_len - 1)
    x_end = pos[last, np.arange(n), 0]
    back = np.maximum(t_len - 1 - STUCK_WINDOW, 0)
    stuck = ~ended & (pos[-1, :, 0] - pos[back, :, 0] < 0.05)
    return {"robots": n, "steps": t_len, "mean_x_m": round(float(np.mean(x_end)), 3), "ended": int(ended.sum()),
            "stuck": int(stuck.sum()), "stuck_robots": np.flatnonzero(stuck).tolist()}


def wedged_feet(r, robots) -> int:
    """Robots among ``robots`` with a foot between opposing walls (MuJoCo contacts)."""
    import mujoco

    names = [mujoco.mj_id2name(r.m, mujoco.mjtObj.mjOBJ_GEOM, g) or "" for g in range(r.m.ngeom)]
    count = 0
    for k in robots:
        normals: dict[str, list[np.ndarray]] = {}
        for c in r.d.contact[: r.d.ncon]:
            for g in (c.geom1, c.geom2):
                if names[g].startswith(f"r{k}_") and names[g].endswith("_foot"):
                    normals.setdefault(names[g], []).append(np.asarray(c.frame[:2]))
        if any(float(a @ b) < -0.5 for ns in normals.values() for i, a in enumerate(ns) for b in ns[i + 1:]):
            count += 1
    return count


def mujoco_case(terrain: str, robots: int, steps: int) -> dict:
    from hexnewton.analysis.sim2sim import Rounds

    t0 = time.perf_counter()
    r = Rounds(BUNDLE, terrain, robots)
    iters = []

    def log(rr):
        iters.append(float(np.mean(rr.d.solver_niter[: max(rr.d.nisland, 1)])))

    ep = r.run(steps, log)
    pos = np.nan_to_num(ep["pos"], nan=0.0)
    for k in range(robots):  # a finished robot's rows are NaN: hold its last position
        if ep["done"][:, k].any():
            pos[np.argmax(ep["done"][:, k]) + 1:, k] = pos[np.argmax(ep["done"][:, k]), k]
    out = first_episode_summary(pos, ep["done"])
    out["wedged"] = wedged_feet(r, out["stuck_robots"])
    out["solver_iterations_mean"] = round(float(np.mean(iters)), 2)
    out["wall_s"] = round(time.perf_counter() - t0, 1)
    return out


def newton_case(terrain: str, robots: int, steps: int, overrides: dict | None = None) -> dict:
    from hexnewton.analysis.rollout import run_rounds

    t0 = time.perf_counter()
    ep = run_rounds("cpg_rl", POLICY, terrain, robots, "cpu", steps, progress=False, overrides=overrides)
    pad = steps - len(ep.pos)
    pos, done = ep.pos, ep.done
    if pad > 0:  # every episode ended early: hold the last row
        pos = np.concatenate([pos, np.repeat(pos[-1:], pad, axis=0)])
        done = np.concatenate([done, np.zeros((pad, robots), bool)])
    out = first_episode_summary(pos, done)
    out["wall_s"] = round(time.perf_counter() - t0, 1)
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", required=True)
    args = p.parse_args()
    res = {}
    for terrain, robots, steps in CASES:
        res[terrain] = {"mujoco": mujoco_case(terrain, robots, steps), "newton": newton_case(terrain, robots, steps)}
        if terrain != "flat":
            res[terrain]["newton_collide_every_5ms"] = newton_case(terrain, robots, steps,
                                                                   {"sim.frame_dt": 0.005, "sim.substeps": 1})
        print(terrain, json.dumps(res[terrain]), flush=True)
    with open(args.out, "w") as f:
        json.dump({"command": "PYTHONPATH=. python studies/sim2sim/sim2sim_side_by_side.py --out " + args.out, **res}, f,
                  indent=1)


if __name__ == "__main__":
    main()
