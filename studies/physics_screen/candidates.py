"""Stability + dynamics-similarity checks of physics-setting candidates (CPU, small worlds).

    python studies/physics_screen/candidates.py A B C ... [--json out.json]

Per candidate SimConfig:
  stand    : test_world.test_stands_two_seconds on every terrain (4 envs, 2 s), plus penetration/overflow
  tripod   : test_world.test_tripod_walks_forward_on_flat (4 envs, 3 s)
  flat     : test_rollout.test_fixed_cpg_walks_straight_on_flat (16 envs instead of 64, 10 s) + dynamics numbers
  rugged   : the same fixed CPG on rugged, 10 s, dynamics numbers
  stepped  : fixed gait (3pi, 0.3, 1.1, 0.3) on stepped terrain (seed 3), 20 s: farthest x, steps climbed
  complex  : the same high-lift gait on complex terrain (seed 3), 20 s
Penetration: foot sphere bottom / torso box corners below the heightmap at their (x, y) [m] (positive = below
the surface), and the deepest MuJoCo contact distance (negative = penetrating) seen at sample times.
"""

from __future__ import annotations

import json
import math
import sys
import time
import warnings
from dataclasses import replace

import numpy as np
import torch

from hexnewton.config import TERRAINS, CPGConfig, HexConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.learning.policy import fixed_cpg_actions
from hexnewton.mdp.env import make_env
from hexnewton.mdp.status import STATUS_NAMES
from hexnewton.kernels.cpg import CPGController
from hexnewton.robot import stand_height
from hexnewton.terrain import max_terrain_height_np
from hexnewton.terrain.query import terrain_height_np
from hexnewton.physics.world import World

CANDIDATES = {
    "A": dict(),  # defaults: 10 ms frame = 4 x 2.5 ms, 10/10 it, gap 5 mm
    "B": dict(substeps=2),  # 10 ms frame = 2 x 5 ms
    "C": dict(frame_dt=0.020, substeps=4),  # 20 ms frame = 4 x 5 ms
    "C10": dict(frame_dt=0.020, substeps=4, rigid_gap=0.010),
    "D": dict(frame_dt=0.020, substeps=8),  # 20 ms frame = 8 x 2.5 ms
    "D10": dict(frame_dt=0.020, substeps=8, rigid_gap=0.010),
    "E": dict(substeps=2, iterations=5, ls_iterations=5),
    "F": dict(iterations=5, ls_iterations=5),  # defaults with 5/5 iterations
    "G": dict(frame_dt=0.020, substeps=4, iterations=5, ls_iterations=5),
    "H": dict(substeps=2, iterations=3, ls_iterations=3),
    "J": dict(substeps=1),  # 10 ms MuJoCo steps
    "K": dict(substeps=2, iterations=10, ls_iterations=3),
    "L": dict(frame_dt=0.020, substeps=2),  # 20 ms frame = 2 x 10 ms
    "M": dict(frame_dt=0.020, substeps=3),  # 20 ms frame = 3 x 6.67 ms
}

HIGH_LIFT = dict(fixed_omega=3.0 * math.pi, fixed_a1=0.3, fixed_a2=1.1, fixed_a3=0.3)


def sim_cfg(cand: dict, n: int) -> SimConfig:
    return replace(SimConfig(), num_envs=n, device="cpu", **cand)


def upright(q):
    return 1.0 - 2.0 * (q[:, 3] ** 2 + q[:, 4] ** 2)


def quat_rotate(q, v):
    """Rotate vectors v (..., 3) by quaternions q (..., 4) in (x, y, z, w)."""
    u, w = q[..., :3], q[..., 3:4]
    t = 2.0 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


class Probe:
    """Per-env penetration probes read from a World after a step."""

    def __init__(self, world: World):
        self.w = world
        r = world.cfg.robot
        self.n = world.num_envs
        self.per_env = world.model.body_count // self.n
        self.tibia = np.array([1 + 3 * leg + 2 for leg in range(6)])
        self.foot_off = np.array([0.0, 0.0, -r.tibia_length])
        self.foot_r = r.foot_radius
        sx, sy, sz = r.torso_size
        self.corners = np.array([[a * sx / 2, b * sy / 2, c * sz / 2] for a in (-1, 1) for b in (-1, 1) for c in (-1, 1)])
        self.foot_pen = np.full(self.n, -np.inf)
        self.torso_pen = np.full(self.n, -np.inf)
        self.contact_min = np.full(self.n, np.inf)
        self.foot_pen_samples: list[np.ndarray] = []

    def sample(self, active: np.ndarray | None = None):
        w = self.w
        grid = w.terrain.grid
        bq = w.state_0.body_q.numpy().reshape(self.n, self.per_env, 7)
        tib = bq[:, self.tibia]  # (n, 6, 7)
        foot = tib[..., :3] + quat_rotate(tib[..., 3:], np.broadcast_to(self.foot_off, tib[..., :3].shape))
        pen_f = terrain_height_np(grid, foot[..., 0], foot[..., 1]) - (foot[..., 2] - self.foot_r)  # (n, 6)
        tor = bq[:, 0]
        c = tor[:, None, :3] + quat_rotate(np.repeat(tor[:, None, 3:], 8, 1), np.broadcast_to(self.corners, (self.n, 8, 3)))
        pen_t = terrain_height_np(grid, c[..., 0], c[..., 1]) - c[..., 2]
        d = w.solver.mjw_data
        k = int(d.nacon.numpy()[0])
        cmin = np.full(self.n, np.inf)
        if k:
            np.minimum.at(cmin, d.contact.worldid.numpy()[:k], d.contact.dist.numpy()[:k])
        m = np.ones(self.n, bool) if active is None else active
        self.foot_pen[m] = np.maximum(self.foot_pen[m], pen_f.max(1)[m])
        self.torso_pen[m] = np.maximum(self.torso_pen[m], pen_t.max(1)[m])
        self.contact_min[m] = np.minimum(self.contact_min[m], cmin[m])
        self.foot_pen_samples.append(pen_f[m].ravel())

    def summary(self) -> dict:
        s = np.concatenate(self.foot_pen_samples) if self.foot_pen_samples else np.zeros(1)
        fin = lambda a: float(np.max(a[np.isfinite(a)])) if np.isfinite(a).any() else float("nan")  # noqa: E731
        return {
            "foot_pen_max_mm": 1e3 * fin(self.foot_pen),
            "foot_pen_p99_mm": 1e3 * float(np.percentile(s, 99)),
            "torso_pen_max_mm": 1e3 * fin(self.torso_pen),
            "contact_dist_min_mm": 1e3 * float(np.min(self.contact_min[np.isfinite(self.contact_min)]))
            if np.isfinite(self.contact_min).any() else float("nan"),
        }


def check_stand(cand: dict, terrain: str) -> dict:
    n = 4
    world = World(HexConfig(sim=sim_cfg(cand, n), terrain=TerrainConfig(name=terrain)))
    frames = int(round(2.0 / world.frame_dt))
    probe = Probe(world)
    lowest = np.full(n, np.inf)
    up_min = np.full(n, np.inf)
    finite = True
    for _ in range(frames):
        world.step(1)
        q = world.numpy_q()
        finite &= bool(np.isfinite(q).all())
        ground = max_terrain_height_np(world.terrain.grid, q[:, 0], q[:, 1], 0.5 * world.cfg.robot.torso_size[0])
        lowest = np.minimum(lowest, q[:, 2] - ground)
        up_min = np.minimum(up_min, upright(q))
        probe.sample()
    rep = world.check_contacts(on_overflow="warn")
    z_err = float(np.abs(q[:, 2] - stand_height(world.cfg.robot)).max()) if terrain in ("flat", "stepped") else 0.0
    ok = finite and (up_min > 0.95).all() and (lowest > 0.06).all() and rep.ok and z_err < 0.01
    return {"ok": bool(ok), "lowest_m": float(lowest.min()), "upright_min": float(up_min.min()), "z_err_m": z_err,
            "overflow": rep.ok is False, **probe.summary()}


def check_tripod(cand: dict) -> dict:
    n = 4
    world = World(HexConfig(sim=sim_cfg(cand, n), terrain=TerrainConfig(name="flat")))
    world.set_controller(CPGController(world))
    x0 = world.base_pos().copy()
    probe = Probe(world)
    for _ in range(int(round(3.0 / world.frame_dt))):
        world.step(1)
        probe.sample()
    q = world.numpy_q()
    dx = q[:, 0] - x0[:, 0]
    dy = np.abs(q[:, 1] - world.spawn_xy[:, 1])
    rep = world.check_contacts(on_overflow="warn")
    ok = (dx > 0.5).all() and (dy < 0.1).all() and (upright(q) > 0.9).all() and rep.ok
    return {"ok": bool(ok), "dx_min": float(dx.min()), "dx_mean": float(dx.mean()), "dy_max": float(dy.max()),
            "overflow": not rep.ok, **probe.summary()}


def gait_rollout(cand: dict, terrain: str, seconds: float, n: int = 16, cpg: CPGConfig | None = None,
                 seed: int = 0, task_seed: int = 0) -> dict:
    cfg = HexConfig(sim=sim_cfg(cand, n), terrain=TerrainConfig(name=terrain, seed=seed),
                    task=replace(TaskConfig(), reset_yaw=0.0, seed=task_seed), cpg=cpg or CPGConfig())
    env = make_env(cfg)
    actions = fixed_cpg_actions(env)
    probe = Probe(env.world)
    grid = env.world.terrain.grid
    steps = int(round(seconds / cfg.task.control_dt))
    first = np.ones(n, bool)  # still in the first episode
    end_status = np.zeros(n, np.int32)
    xmax = np.full(n, -np.inf)
    x_end = np.zeros(n)
    y_end = np.zeros(n)
    heights, rolls, pitches = [], [], []
    ovf_steps = nc_world_steps = 0
    t0 = time.perf_counter()
    with torch.inference_mode():
        for k in range(steps):
            env.step(actions)
            q = env.last_q.numpy()
            status = env.status.numpy()
            start = env.last_start.numpy()
            rpy = env.rpy.numpy()
            live = first.copy()
            x = q[:, 0] - start[:, 0]
            xmax[live] = np.maximum(xmax[live], x[live])
            x_end[live], y_end[live] = x[live], q[live, 1] - start[live, 1]
            h = q[:, 2] - terrain_height_np(grid, q[:, 0], q[:, 1])
            heights.append(h[live]); rolls.append(rpy[live, 0]); pitches.append(rpy[live, 1])  # noqa: E702
            # probes read the post-reset state: only envs that did not end this step
            probe.sample(live & (status == 0))
            ended = live & (status != 0)
            end_status[ended] = status[ended]
            first &= status == 0
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                rep = env.world.check_contacts(on_overflow="warn")
            ovf_steps += int(not rep.ok)
            nc_world_steps += rep.not_converged_worlds
    wall = time.perf_counter() - t0
    deg = 180 / math.pi
    H, R, P = (np.concatenate(a) for a in (heights, rolls, pitches))
    # steps climbed: terrain height under the farthest torso position / rise
    rise = cfg.terrain.step_rise
    climbed = terrain_height_np(grid, xmax + env.world.spawn_xy[:, 0], env.world.spawn_xy[:, 1]) / rise
    return {
        "x_mean": float(x_end.mean()), "x_min": float(x_end.min()), "xmax_mean": float(xmax.mean()),
        "xmax_max": float(xmax.max()), "y_drift_max": float(np.abs(y_end).max()),
        "height_mean": float(H.mean()), "height_std": float(H.std()),
        "roll_std_deg": float(R.std() * deg), "pitch_std_deg": float(P.std() * deg),
        "roll_absmax_deg": float(np.abs(R).max() * deg), "pitch_absmax_deg": float(np.abs(P).max() * deg),
        "steps_climbed_mean": float(climbed.mean()), "steps_climbed_max": float(climbed.max()),
        "ended": {STATUS_NAMES[s]: int((end_status == s).sum()) for s in range(1, len(STATUS_NAMES))
                  if (end_status == s).any()},
        "overflow": ovf_steps > 0, "overflow_steps": ovf_steps, "not_converged_worlds": nc_world_steps,
        "climbed_per_env": climbed.tolist(), "xmax_per_env": xmax.tolist(),
        "wall_s": wall, **probe.summary(),
    }


SEEDS = (0, 1, 2)


def merge(runs: list[dict]) -> dict:
    """Pool rollouts of several reset seeds (16 envs each)."""
    cl = np.concatenate([r["climbed_per_env"] for r in runs])
    xm = np.concatenate([r["xmax_per_env"] for r in runs])
    out = {k: float(np.mean([r[k] for r in runs])) for k in runs[0] if isinstance(runs[0][k], float)}
    for k in ("foot_pen_max_mm", "torso_pen_max_mm", "roll_absmax_deg", "pitch_absmax_deg", "y_drift_max"):
        out[k] = max(r[k] for r in runs)
    out["contact_dist_min_mm"] = min(r["contact_dist_min_mm"] for r in runs)
    out["x_min"] = min(r["x_min"] for r in runs)
    out.update(steps_climbed_mean=float(cl.mean()), steps_climbed_max=float(cl.max()),
               steps_climbed_median=float(np.median(cl)), xmax_mean=float(xm.mean()), xmax_max=float(xm.max()),
               share_ge_6_steps=float((cl >= 6 - 1e-6).mean()), robots=int(cl.size))
    out["ended"] = {}
    for r in runs:
        for k, v in r["ended"].items():
            out["ended"][k] = out["ended"].get(k, 0) + v
    out["overflow"] = any(r["overflow"] for r in runs)
    out["overflow_steps"] = sum(r["overflow_steps"] for r in runs)
    out["not_converged_worlds"] = sum(r["not_converged_worlds"] for r in runs)
    out["wall_s"] = sum(r["wall_s"] for r in runs)
    return out


def run_candidate(name: str) -> dict:
    cand = CANDIDATES[name]
    out = {"name": name, "sim": cand}
    t0 = time.perf_counter()
    out["stand"] = {t: check_stand(cand, t) for t in TERRAINS}
    out["tripod"] = check_tripod(cand)
    flat = gait_rollout(cand, "flat", 10.0)
    flat["ok"] = bool(flat["x_min"] >= 1.0 and flat["y_drift_max"] < 0.2 and "fell" not in flat["ended"]
                      and "nonfinite" not in flat["ended"] and not flat["overflow"])
    out["flat"] = flat
    out["rugged"] = gait_rollout(cand, "rugged", 10.0)
    hl = replace(CPGConfig(), **HIGH_LIFT)
    out["stepped"] = merge([gait_rollout(cand, "stepped", 20.0, cpg=hl, seed=3, task_seed=s) for s in SEEDS])
    out["complex"] = merge([gait_rollout(cand, "complex", 20.0, cpg=hl, seed=3, task_seed=s) for s in SEEDS])
    out["wall_s"] = time.perf_counter() - t0
    return out


def brief(r: dict) -> str:
    s = r["stand"]
    lines = [f"== {r['name']} {r['sim']}  ({r['wall_s']:.0f} s)"]
    for t, v in s.items():
        lines.append(f"  stand {t:8s} ok={v['ok']} lowest={v['lowest_m']:.3f} up={v['upright_min']:.3f} "
                     f"zerr={v['z_err_m'] * 1e3:.1f}mm foot_pen={v['foot_pen_max_mm']:.1f}mm torso_pen="
                     f"{v['torso_pen_max_mm']:.1f}mm cdist={v['contact_dist_min_mm']:.1f}mm ovf={v['overflow']}")
    v = r["tripod"]
    lines.append(f"  tripod ok={v['ok']} dx_min={v['dx_min']:.3f} dy_max={v['dy_max']:.3f} "
                 f"foot_pen={v['foot_pen_max_mm']:.1f}mm cdist={v['contact_dist_min_mm']:.1f}mm")
    for key in ("flat", "rugged", "stepped", "complex"):
        v = r[key]
        lines.append(f"  {key:8s} {'ok=' + str(v['ok']) + ' ' if 'ok' in v else ''}x={v['x_mean']:.2f} "
                     f"(min {v['x_min']:.2f}) xmax={v['xmax_mean']:.2f}/{v['xmax_max']:.2f} "
                     f"steps={v['steps_climbed_mean']:.1f}/{v['steps_climbed_max']:.0f}"
                     f"{' ge6=' + format(v['share_ge_6_steps'], '.2f') if 'share_ge_6_steps' in v else ''} h={v['height_mean']:.3f} "
                     f"roll_sd={v['roll_std_deg']:.2f} pitch_sd={v['pitch_std_deg']:.2f} ydrift={v['y_drift_max']:.3f} "
                     f"ended={v['ended']} foot_pen={v['foot_pen_max_mm']:.1f}/p99 {v['foot_pen_p99_mm']:.1f}mm "
                     f"torso_pen={v['torso_pen_max_mm']:.1f}mm cdist={v['contact_dist_min_mm']:.1f}mm "
                     f"ovf={v['overflow']}({v['overflow_steps']}) nc={v['not_converged_worlds']} wall={v['wall_s']:.0f}s")
    return "\n".join(lines)


if __name__ == "__main__":
    args = sys.argv[1:]
    out_path = None
    if "--json" in args:
        i = args.index("--json")
        out_path = args[i + 1]
        del args[i : i + 2]
    results = []
    for name in args:
        r = run_candidate(name)
        print(brief(r), flush=True)
        results.append(r)
        if out_path:
            with open(out_path, "w") as f:
                json.dump(results, f, indent=1)
