"""The paper's evaluation (§3.3-3.4): success at 0.5 / 1 / 2 / 3 m, stability, trajectories, and a report.

    python -m hexnewton.evaluate --controllers cpg cpg_rl --checkpoint cpg_rl=results/policies/cpg_rl_rugged.pt \\
        --terrains rugged stepped complex --rounds 25 --out eval/paper
    python -m hexnewton.evaluate ... --checkpoint cpg_rl:rugged=A.pt cpg_rl:stepped=B.pt   # one policy per terrain
    python -m hexnewton.evaluate ... --runs cpg_rl=logs/.../run joint=logs/.../run       # adds Fig. 5a

Protocol. A round is one robot walking toward the target 3.5 m ahead, from its own start pose, until its
first episode ends (goal, fall, off course) or the episode limit (``TaskConfig.max_episode_steps``,
7000 steps = 140 s). R rounds run as R robots in parallel; a deterministic policy acts in every round
(``--stochastic``: it samples its actions from its Gaussian as in training; see RESULTS.md).
The robots use terrain seed ``EVAL_TERRAIN_SEED`` and reset seed ``EVAL_RESET_SEED`` (``--seed S``: S and S + 1000,
a validation set for choosing among checkpoints before the one test-set report). Training uses
``train.py --terrain_seed 0 --seed 1`` by default, so both the ground and the start poses (lane,
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
- ``fig_learning.png`` (Fig. 5a: reward against env-steps and against wall time) with ``--runs``.

Controllers: ``cpg`` (fixed parameters), ``cpg_rl`` and ``joint`` (rsl-rl checkpoints from ``train.py``),
``sac_cpg`` / ``td3_cpg`` / ``a2c_cpg`` (Stable-Baselines3 ``model.zip`` from ``hexnewton.baselines``).
"""

from __future__ import annotations

import datetime
import json
import math
import os
import sys
import time
from dataclasses import dataclass, replace

import numpy as np

from .cli import ArgumentParser, positive_int, run, terrain_name
from .config import (
    FIXED_GAITS,
    PARAM_NAMES,
    POSTURE_NAMES,
    HexConfig,
    RandomizationConfig,
    TaskConfig,
    TerrainConfig,
    control_decimation,
    gait_params,
    terrain_for_goal,
)
from .kernels.status import FELL, NONFINITE, OFF_COURSE, STATUS_NAMES

DISTANCES = (0.5, 1.0, 2.0, 3.0)  # Table 3's columns [m]
EVAL_TERRAIN_SEED = 1000
EVAL_RESET_SEED = 2000
START_SEED_OFFSET = EVAL_RESET_SEED - EVAL_TERRAIN_SEED  # --seed S: terrain seed S, start seed S + 1000
# controller -> env action mode; *_cpg are the Stable-Baselines3 baselines (hexnewton.baselines)
CONTROLLERS = {"cpg": "cpg", "cpg_swept": "cpg", "cpg_rl": "cpg", "joint": "joint", "sac_cpg": "cpg", "td3_cpg": "cpg",
               "a2c_cpg": "cpg"}  # fmt: skip
FIXED = {"cpg": "default", "cpg_swept": "swept"}  # fixed-parameter controllers -> config.FIXED_GAITS
LABELS = {"cpg": "CPG", "cpg_swept": "CPG (swept)", "cpg_rl": "CPG_RL", "joint": "pure DRL", "sac_cpg": "SAC-CPG",
          "td3_cpg": "TD3-CPG", "a2c_cpg": "A2C-CPG"}  # fmt: skip
#: Named perturbations beyond the training ranges (RandomizationConfig: friction 0.4-1.2, payload -0.2..0.6 kg,
#: gains and effort x0.8-1.2, half the envs 20 ms late, pushes of 0.3 m/s every 6 s; 6 cm steps and blocks). Each
#: changes one thing; everything else is the nominal robot. Values: (RandomizationConfig fields, TerrainConfig fields).
_NOMINAL = dict(friction=(0.9, 0.9), payload=(0.0, 0.0), link_mass_scale=(1.0, 1.0), kp_scale=(1.0, 1.0),
                kd_scale=(1.0, 1.0), effort_scale=(1.0, 1.0), latency_share=0.0, noise_joint_pos=0.0,
                noise_joint_vel=0.0, noise_target=0.0, noise_quat=0.0, noise_height=0.0, push_velocity=0.0)
PERTURBATIONS = {
    "nominal": ({}, {}),
    "friction_0.3": ({"friction": (0.3, 0.3)}, {}),
    "payload_0.8kg": ({"payload": (0.8, 0.8)}, {}),
    "motors_0.6": ({"kp_scale": (0.6, 0.6), "effort_scale": (0.6, 0.6)}, {}),
    "push_0.6m/s": ({"push_velocity": 0.6, "push_interval": 3.0}, {}),
    "latency_40ms": ({"latency_share": 1.0}, {}),  # every env one control step late, plus the 20 ms step itself
    "sensor_noise_x2": ({"noise_joint_pos": 0.02, "noise_joint_vel": 1.0, "noise_target": 0.1, "noise_quat": 0.04,
                         "noise_height": 0.02}, {}),
    "steps_7cm": ({}, {"step_rise": 0.07}),
    "blocks_8cm": ({}, {"block_height_max": 0.08}),
}  # fmt: skip


def perturbation(name: str) -> tuple[RandomizationConfig | None, dict]:
    """The randomisation (None: off) and terrain overrides of a named perturbation (``PERTURBATIONS``)."""
    if name not in PERTURBATIONS:
        raise ValueError(f"unknown perturbation '{name}': choose from {', '.join(PERTURBATIONS)}")
    rz, terrain = PERTURBATIONS[name]
    return (RandomizationConfig(enabled=True, **{**_NOMINAL, **rz}) if rz else None), terrain
SB3 = {"sac_cpg": "sac", "td3_cpg": "td3", "a2c_cpg": "a2c"}
# Table 3 of Huang et al. 2025 (25 rounds): success [%] at 0.5, 1, 2, 3 m
PAPER_TABLE3 = {
    "rugged": {"CPG": (96, 96, 88, 60), "TD3-CPG": (100, 100, 100, 70), "SAC-CPG": (100, 100, 100, 96),
               "CPG_RL": (100, 100, 100, 100)},
    "stepped": {"CPG": (60, 28, 0, 0), "TD3-CPG": (100, 84, 0, 0), "SAC-CPG": (96, 96, 96, 52),
                "CPG_RL": (100, 100, 100, 100)},
    "complex": {"CPG": (92, 56, 8, 0), "TD3-CPG": (100, 100, 12, 0), "SAC-CPG": (100, 80, 40, 4),
                "CPG_RL": (100, 100, 100, 100)},
}  # fmt: skip
_BAD_END = (FELL, OFF_COURSE, NONFINITE)


# ----------------------------------------------------------------------------------------------------
# metrics (host, float64)
# ----------------------------------------------------------------------------------------------------


def round_metrics(pos: np.ndarray, rpy: np.ndarray, done: np.ndarray, status: np.ndarray, dt: float,
                  distances: tuple[float, ...] = DISTANCES) -> dict:  # fmt: skip
    """Per-round metrics of each env's first episode.

    ``pos`` (T, N, 2+) x, y relative to the round's start; ``rpy`` (T, N, 3) [rad]; ``done`` (T, N) the
    episode ended at that step; ``status`` (T, N) why (``kernels.terminations`` codes); ``dt`` the control
    period. Returns arrays over the N rounds: ``reached`` (D, N) bool, ``time_to`` (D, N) [s] (nan if not
    reached), ``y_dev`` (N,) [m], ``end`` (N,) status code (0 = still running at the last step),
    ``steps`` (N,), and ``in_episode`` (T, N), the rows that belong to each first episode.
    """
    pos, rpy = np.asarray(pos, np.float64), np.asarray(rpy, np.float64)
    done, status = np.asarray(done, bool), np.asarray(status)
    t_len, n = done.shape
    ended_before = np.cumsum(done, axis=0) - done
    in_episode = ended_before == 0  # (T, N): rows up to and including the first done
    has_end = done.any(axis=0)
    last = np.where(has_end, np.argmax(done, axis=0), t_len - 1)
    envs = np.arange(n)
    end = np.where(has_end, status[last, envs], 0)
    # the row on which a fall / off-course / blow-up ended the episode does not count as progress
    bad_row = done & np.isin(status, _BAD_END)
    valid = in_episode & ~bad_row & np.isfinite(pos[..., 0])
    x = np.where(valid, pos[..., 0], -np.inf)
    reached = np.zeros((len(distances), n), bool)
    time_to = np.full((len(distances), n), np.nan)
    for k, d in enumerate(distances):
        hit = x >= d
        reached[k] = hit.any(axis=0)
        first = np.argmax(hit, axis=0)
        time_to[k] = np.where(reached[k], (first + 1) * dt, np.nan)
    y_abs = np.where(in_episode & np.isfinite(pos[..., 1]), np.abs(pos[..., 1]), 0.0)
    return {"reached": reached, "time_to": time_to, "y_dev": y_abs.max(axis=0), "end": end, "steps": last + 1,
            "in_episode": in_episode}  # fmt: skip


def gait_quality(metrics: dict, ang_rate: np.ndarray, dparam: np.ndarray, daction: np.ndarray) -> dict:
    """Body roll / pitch rate RMS [deg/s] and the mean change per control step of the CPG parameters (filtered, as
    the oscillators see them) and of the policy's requested parameters, in % of each parameter's range, over every
    step of every round's first episode (from its second step)."""
    mask = metrics["in_episode"]
    later = mask.copy()
    later[0] = False
    deg = 180.0 / math.pi
    out = {}
    for i, name in ((0, "roll"), (1, "pitch")):
        r = np.asarray(ang_rate[..., i], np.float64)[mask]
        r = r[np.isfinite(r)]
        out[f"{name}_rate_rms_deg_s"] = float(np.sqrt(np.mean(r * r)) * deg) if r.size else None
    for key, arr in (("param_change_pct", dparam), ("action_change_pct", daction)):
        v = np.asarray(arr, np.float64)[later]
        v = v[np.isfinite(v)]
        out[key] = float(100.0 * v.mean()) if v.size else None
    return out


def summarize(metrics: dict, rpy: np.ndarray, distances: tuple[float, ...] = DISTANCES) -> dict:
    """Rates and stability over all rounds (JSON-ready; angles in degrees): success and time at each distance, the
    paper's roll / pitch mean, variance and peak, the 99.9th percentile of |roll| and |pitch|, the share of rounds
    that ended in a fall (anywhere, also after the last distance), Y deviation and how the rounds ended."""
    deg = 180.0 / math.pi
    mask = metrics["in_episode"]
    rpy = np.asarray(rpy, np.float64)
    out = {"rounds": int(mask.shape[1])}
    for k, d in enumerate(distances):
        out[f"success_{d:g}m"] = float(metrics["reached"][k].mean())
        t = metrics["time_to"][k]
        out[f"time_to_{d:g}m_s"] = float(np.nanmean(t)) if np.isfinite(t).any() else None
    for i, name in ((0, "roll"), (1, "pitch")):
        a = rpy[..., i][mask & np.isfinite(rpy[..., i])] * deg
        out[f"{name}_mean_deg"] = float(a.mean()) if a.size else None
        out[f"{name}_var_deg2"] = float(a.var()) if a.size else None
        out[f"{name}_peak_deg"] = float(np.abs(a).max()) if a.size else None
    for i, name in ((0, "roll"), (1, "pitch")):  # gait quality beyond the paper's mean / variance / peak
        a = np.abs(rpy[..., i][mask & np.isfinite(rpy[..., i])]) * deg
        out[f"{name}_p999_deg"] = float(np.percentile(a, 99.9)) if a.size else None
    out["fall_rate"] = float((metrics["end"] == FELL).mean())
    out["y_dev_mean_m"] = float(metrics["y_dev"].mean())
    out["y_dev_max_m"] = float(metrics["y_dev"].max())
    out["ended"] = {STATUS_NAMES[c]: int((metrics["end"] == c).sum()) for c in range(len(STATUS_NAMES))}
    return out


# ----------------------------------------------------------------------------------------------------
# rollouts
# ----------------------------------------------------------------------------------------------------


@dataclass
class Episode:
    """Host arrays of one controller's rounds on one terrain (T steps, N rounds)."""

    pos: np.ndarray  # (T, N, 2) relative to each round's start
    rpy: np.ndarray  # (T, N, 3)
    done: np.ndarray  # (T, N)
    status: np.ndarray  # (T, N)
    params: np.ndarray  # (T, 15) round 0's CPG parameters (physical units); NaN in joint mode
    dt: float
    ang_rate: np.ndarray  # (T, N, 2) body roll and pitch rate [rad/s]
    dparam: np.ndarray  # (T, N) mean |change| of the 15 filtered parameters since the last step / their ranges
    daction: np.ndarray  # (T, N) the same for the parameters the policy asks for (params_target)
    segments: dict  # complex course: mean parameters (physical units) on the blocks and on the stairs, all rounds


def run_rounds(controller: str, checkpoint: str | None, terrain: str, rounds: int, device: str | None,
               max_steps: int, reset_yaw: float, progress: bool = True, randomize: bool = False,
               step_rise: float = TerrainConfig.step_rise, goal_distance: float = TaskConfig.goal_distance,
               stochastic: bool = False, physics: dict | None = None, expected: bool = False,
               seed: int = EVAL_TERRAIN_SEED, randomization: RandomizationConfig | None = None,
               terrain_overrides: dict | None = None, fixed_params: np.ndarray | None = None,
               posture_reflex: float | None = None) -> Episode:
    """``rounds`` robots, one first episode each, with a deterministic controller on unseen seeds; with
    ``randomize``, under perturbed conditions (``RandomizationConfig`` drawn with the evaluation seed); with
    ``stochastic``, a learnt policy samples its actions from its Gaussian as in training (torch seeded with the
    evaluation seed); with ``expected``, the expected clipped action of that Gaussian. The physics (frame and
    substeps) is the policy's own, from its checkpoint, unless ``physics`` overrides fields of ``SimConfig``. ``seed``
    is the terrain seed; the start poses (and sampled actions) use ``seed + START_SEED_OFFSET``. ``randomization``
    (a named perturbation) replaces ``randomize``'s training ranges; ``terrain_overrides`` changes ``TerrainConfig``
    fields; ``fixed_params`` (N, 15) gives a fixed controller one gait per round (``hexnewton.cpg_sweep``);
    ``posture_reflex`` sets the levelling reflex gain (``CPGConfig.posture_reflex``) of a posture policy, or gives a
    fixed gait the body posture at its neutral values with that reflex."""
    from .env import make_env
    from .play import fixed_cpg_actions, load_policy, stepped

    from .train import load_checkpoint, trained_config

    mode = CONTROLLERS[controller]
    trained = trained_config(load_checkpoint(checkpoint)) if controller in ("cpg_rl", "joint") else HexConfig()
    ground = replace(TerrainConfig(name=terrain, seed=seed, step_rise=step_rise), **(terrain_overrides or {}))
    cpg = trained.cpg  # a policy's own parameter ranges
    if posture_reflex is not None and mode == "cpg":
        if controller not in FIXED and not cpg.posture:
            raise ValueError(f"{checkpoint} has no body posture: --posture_reflex needs a policy trained with --posture")
        cpg = replace(cpg, posture=True, posture_reflex=posture_reflex)
    cfg = HexConfig(
        sim=replace(trained.sim, num_envs=rounds, device=device, **(physics or {})),
        terrain=terrain_for_goal(ground, goal_distance),
        task=replace(TaskConfig(), seed=seed + START_SEED_OFFSET, reset_yaw=reset_yaw, goal_distance=goal_distance),
        randomization=randomization or RandomizationConfig(enabled=randomize),
        cpg=cpg,
    )
    env = make_env(cfg, mode)
    if controller in FIXED:
        actions = fixed_cpg_actions(env, FIXED[controller], fixed_params)
        policy = lambda obs: actions  # noqa: E731
    elif controller in SB3:
        from .baselines import load_sb3_policy

        policy = load_sb3_policy(env, checkpoint, SB3[controller], deterministic=not stochastic)
    else:
        policy = load_policy(env, checkpoint, mode, stochastic, expected)
    if stochastic:
        import torch

        torch.manual_seed(seed + START_SEED_OFFSET)
    from .kernels.reference import quat_rotate_inv_np

    lo, hi = (np.asarray(b, np.float64) for b in cfg.cpg.param_ranges())
    split_x = ground.complex_rugged_length if terrain == "complex" else None
    npar = cfg.cpg.num_params
    seg_sum, seg_n = {"blocks": np.zeros(npar), "stairs": np.zeros(npar)}, {"blocks": 0, "stairs": 0}
    pos, rpy, done, status, params, ang_rate, dparam, daction = [], [], [], [], [], [], [], []
    finished = np.zeros(rounds, bool)
    prev_p = prev_t = None

    def change(now: np.ndarray, before: np.ndarray | None) -> np.ndarray:
        """Mean |change| of the CPG parameters (15, or 18 with the posture) since the last step, in fractions of
        their ranges (NaN at the start)."""
        if before is None:
            return np.full(rounds, np.nan, np.float32)
        return (np.abs(now - before) / (hi - lo)).mean(axis=1).astype(np.float32)

    for _, st, q, p, r in stepped(env, policy, max_steps, f"{LABELS[controller]} on {terrain}", progress):
        pos.append(p[:, :2])
        rpy.append(r)
        done.append(st != 0)
        status.append(st.copy())
        qd = env.last_qd.numpy()
        ang_rate.append(quat_rotate_inv_np(q[:, 3:7], qd[:, 3:6])[:, :2].astype(np.float32))
        if mode == "cpg":
            pr, tg = env.last_params.numpy(), env.controller.params_target.numpy()
            params.append(pr[0].copy())
            dparam.append(change(pr, prev_p))
            daction.append(change(tg, prev_t))
            prev_p, prev_t = pr.copy(), tg.copy()
            if split_x is not None:
                alive = ~finished
                for seg, sel in (("blocks", alive & (p[:, 0] < split_x)), ("stairs", alive & (p[:, 0] >= split_x))):
                    seg_sum[seg] += pr[sel].sum(axis=0)
                    seg_n[seg] += int(sel.sum())
        else:
            params.append(np.full(len(PARAM_NAMES), np.nan))
            dparam.append(np.full(rounds, np.nan, np.float32))
            daction.append(np.full(rounds, np.nan, np.float32))
        finished |= st != 0
        if finished.all():
            break
    env.world.check_contacts()
    segments = {seg: (seg_sum[seg] / seg_n[seg]).tolist() for seg in seg_sum if seg_n[seg]}
    return Episode(np.stack(pos), np.stack(rpy), np.stack(done), np.stack(status), np.stack(params),
                   cfg.task.control_dt, np.stack(ang_rate), np.stack(dparam), np.stack(daction), segments)  # fmt: skip


# ----------------------------------------------------------------------------------------------------
# report and figures
# ----------------------------------------------------------------------------------------------------


def _pct(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.0f}%"


def report_markdown(results: dict, meta: dict, robustness: dict | None = None) -> str:
    """Table 3's shape (ours beside the paper's), stability and gait quality per terrain and controller, the
    parameters on blocks and stairs, then one robustness table per controller (``robustness[name][ctrl][terrain]``)."""
    lines = ["# hexnewton evaluation", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()]
    distances = tuple(meta.get("distances", DISTANCES))
    lines += ["", "## Success rate at each distance (Table 3)", "",
              "| terrain | method | " + " | ".join(f"{d:g} m" for d in distances) + " | paper (" +
              " / ".join(f"{d:g}" for d in distances) + " m) |",
              "|---|---|" + "---:|" * len(distances) + "---|"]  # fmt: skip
    for terrain, by_ctrl in results.items():
        for ctrl, s in by_ctrl.items():
            paper = PAPER_TABLE3.get(terrain, {}).get(LABELS[ctrl])
            ref = " / ".join(f"{p}%" for p in paper) if paper else "—"
            cells = " | ".join(_pct(s[f"success_{d:g}m"]) for d in distances)
            lines.append(f"| {terrain} | {LABELS[ctrl]} | {cells} | {ref} |")
    lines += ["", "## Stability (§3.3; angles in degrees over every step of every round)", "",
              "| terrain | method | rounds | pitch mean / var / peak | roll mean / var / peak | Y dev. mean / max [m] "
              f"| time to {distances[-1]:g} m [s] | ended |", "|---|---|---:|---|---|---|---:|---|"]  # fmt: skip
    for terrain, by_ctrl in results.items():
        for ctrl, s in by_ctrl.items():
            ang = {n: " / ".join("—" if s[f"{n}_{k}"] is None else f"{s[f'{n}_{k}']:.2f}"
                                 for k in ("mean_deg", "var_deg2", "peak_deg")) for n in ("pitch", "roll")}  # fmt: skip
            t3 = s[f"time_to_{distances[-1]:g}m_s"]
            ended = ", ".join(f"{k} {v}" for k, v in s["ended"].items() if v)
            lines.append(f"| {terrain} | {LABELS[ctrl]} | {s['rounds']} | {ang['pitch']} | {ang['roll']} | "
                         f"{s['y_dev_mean_m']:.3f} / {s['y_dev_max_m']:.3f} | "
                         f"{'—' if t3 is None else f'{t3:.1f}'} | {ended} |")  # fmt: skip
    lines += ["", "## Gait quality (deterministic actions unless stated in the header)", "",
              "Falls: rounds that ended in a fall anywhere (also after the last distance). p99.9: the 99.9th "
              "percentile of |angle| over every step. Rates: RMS of the body's roll / pitch rate. Δparam: mean change per "
              "control step of the CPG parameters the oscillators and the mapping use (15; 18 with the body "
              "posture), requested by the policy in brackets, in % of each parameter's range. Ratios: variance "
              "against the fixed CPG's in the same run.", "",
              "| terrain | method | falls | pitch var [deg²] | roll var [deg²] | \\|pitch\\| / \\|roll\\| p99.9 [deg] "
              "| roll / pitch rate RMS [deg/s] | Δparam [%/step] | pitch / roll var ÷ CPG | ÷ CPG (swept) |",
              "|---|---|---:|---:|---:|---|---|---|---|---|"]  # fmt: skip
    f = lambda v, fmt=".1f": "—" if v is None else format(v, fmt)  # noqa: E731
    for terrain, by_ctrl in results.items():
        for ctrl, s in by_ctrl.items():
            ratios = []
            for base in ("cpg", "cpg_swept"):
                b = by_ctrl.get(base)
                ok = b and ctrl != base and b["pitch_var_deg2"] and b["roll_var_deg2"]
                ratios.append(f"{s['pitch_var_deg2'] / b['pitch_var_deg2']:.2f} / "
                              f"{s['roll_var_deg2'] / b['roll_var_deg2']:.2f}" if ok else "—")  # fmt: skip
            lines.append(f"| {terrain} | {LABELS[ctrl]} | {s['ended'].get('fell', 0)} / {s['rounds']} | "
                         f"{f(s['pitch_var_deg2'])} | {f(s['roll_var_deg2'])} | {f(s['pitch_p999_deg'])} / "
                         f"{f(s['roll_p999_deg'])} | {f(s.get('roll_rate_rms_deg_s'))} / "
                         f"{f(s.get('pitch_rate_rms_deg_s'))} | {f(s.get('param_change_pct'), '.2f')} "
                         f"({f(s.get('action_change_pct'), '.2f')}) | {ratios[0]} | {ratios[1]} |")  # fmt: skip
    segs = [(t, c, s["segments"]) for t, by in results.items() for c, s in by.items()
            if len(s.get("segments", {})) == 2]
    if segs:
        names = PARAM_NAMES + (POSTURE_NAMES if any(len(seg["blocks"]) > len(PARAM_NAMES) for *_, seg in segs) else ())
        lines += ["", "## Parameters on the blocks and on the stairs (Fig. 5b; complex course, mean over all rounds)",
                  "", "| method | where | " + " | ".join(names) + " |", "|---|---|" + "---:|" * len(names)]
        for _, ctrl, seg in segs:
            for where in ("blocks", "stairs"):
                v = [f"{v:.2f}" for v in seg[where]] + ["—"] * (len(names) - len(seg[where]))
                lines.append(f"| {LABELS[ctrl]} | {where} | " + " | ".join(v) + " |")
    robustness = robustness or {}
    for ctrl in dict.fromkeys(c for by in robustness.values() for c in by):
        lines += ["", f"## Robustness: {LABELS[ctrl]} under named perturbations (beyond the training ranges)", "",
                  "| perturbation | terrain | " + " | ".join(f"{d:g} m" for d in distances) + " | falls | "
                  "pitch var [deg²] | \\|pitch\\| p99.9 [deg] |",
                  "|---|---|" + "---:|" * (len(distances) + 3)]  # fmt: skip
        for name, by_ctrl in robustness.items():
            for terrain, s in by_ctrl.get(ctrl, {}).items():
                cells = " | ".join(_pct(s[f"success_{d:g}m"]) for d in distances)
                lines.append(f"| {name} | {terrain} | {cells} | {s['ended'].get('fell', 0)} / {s['rounds']} | "
                             f"{f(s['pitch_var_deg2'])} | {f(s['pitch_p999_deg'])} |")  # fmt: skip
    return "\n".join(lines) + "\n"


def plot_terrain(path: str, terrain: str, episodes: dict[str, Episode], metrics: dict[str, dict]) -> None:
    """Figs. 6-8: pitch / roll of round 0 over time, box plots over all rounds, XY trajectories."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    deg = 180.0 / math.pi
    fig, axes = plt.subplots(1, 5, figsize=(24, 4.2))
    for idx, (axis, name) in enumerate(((1, "pitch"), (0, "roll"))):
        line_ax, box_ax = axes[2 * idx], axes[2 * idx + 1]
        boxes = []
        for ctrl, ep in episodes.items():
            m = metrics[ctrl]["in_episode"]
            n0 = int(m[:, 0].sum())
            line_ax.plot(np.arange(n0) * ep.dt, ep.rpy[:n0, 0, axis] * deg, label=LABELS[ctrl], lw=0.8)
            boxes.append(ep.rpy[..., axis][m] * deg)
        line_ax.set(title=f"{name}, round 0", xlabel="time [s]", ylabel=f"{name} [deg]")
        box_ax.boxplot(boxes, showfliers=False)
        box_ax.set_xticks(range(1, len(boxes) + 1), [LABELS[c] for c in episodes])
        box_ax.set(title=f"{name}, all rounds", ylabel=f"{name} [deg]")
    ax = axes[4]
    for i, (ctrl, ep) in enumerate(episodes.items()):
        m = metrics[ctrl]["in_episode"]
        for r in range(min(ep.pos.shape[1], 25)):
            k = m[:, r]
            ax.plot(ep.pos[k, r, 0], ep.pos[k, r, 1], color=f"C{i}", lw=0.6, alpha=0.6,
                    label=LABELS[ctrl] if r == 0 else None)  # fmt: skip
    ax.axhline(1.5, color="k", ls=":", lw=0.8)
    ax.axhline(-1.5, color="k", ls=":", lw=0.8)
    ax.add_patch(matplotlib.patches.Circle((3.5, 0.0), 0.5, fill=False, color="g"))
    ax.set(title=f"trajectories (x, y from start), {terrain}", xlabel="x [m]", ylabel="y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    for a in axes:
        a.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[4].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_params(path: str, terrain: str, episodes: dict[str, Episode]) -> None:
    """Fig. 5b: omega and the mean A1 / A2 / A3 along round 0, learned against fixed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = {"omega [rad/s]": [0], "A1 (hip)": [1, 2], "A2 (knee), mean of 6": list(range(3, 9)),
              "A3 (ankle), mean of 6": list(range(9, 15))}  # fmt: skip
    fig, axes = plt.subplots(1, 4, figsize=(18, 3.6))
    for ctrl, ep in episodes.items():
        if np.isnan(ep.params).all():
            continue
        t = np.arange(len(ep.params)) * ep.dt
        for ax, (title, cols) in zip(axes, groups.items()):
            ax.plot(t, ep.params[:, cols].mean(axis=1), label=LABELS[ctrl])
            ax.set(title=title, xlabel="time [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(f"CPG parameters along round 0 on {terrain}")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def plot_learning(path: str, runs: dict[str, str]) -> None:
    """Fig. 5a: mean episode reward against env-steps and against wall time, one curve per controller."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .curves import read_curve

    fig, axes = plt.subplots(1, 2, figsize=(11, 3.8))
    for ax, x in zip(axes, ("env_steps", "wall_time")):
        for ctrl, spec in runs.items():
            curve = read_curve(spec, x).get("Train/mean_reward")
            if curve:
                xs, v = zip(*curve)
                ax.plot(xs, v, label=LABELS.get(ctrl, ctrl))
        ax.set(xlabel="env-steps" if x == "env_steps" else "wall time [min]", ylabel="mean episode reward")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


# ----------------------------------------------------------------------------------------------------
# command line
# ----------------------------------------------------------------------------------------------------


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


def merge_reports(dirs: list[str], out: str) -> int:
    """One report from several evaluation folders (``--merge``): their results and robustness tables side by side.
    The folders must share the seeds, rounds and distances (otherwise the rows would not be comparable)."""
    runs = []
    for d in dirs:
        path = os.path.join(d, "results.json")
        if not os.path.isfile(path):
            raise ValueError(f"{d} holds no results.json (not an evaluation folder, or an unfinished one)")
        with open(path) as f:
            runs.append(json.load(f))
    keys = ("terrain_seed", "reset_seed", "rounds", "distances", "max_steps", "goal_distance", "actions")
    for d, r in zip(dirs[1:], runs[1:]):
        differ = [k for k in keys if r["meta"].get(k) != runs[0]["meta"].get(k)]
        if differ:
            raise ValueError(f"{d} differs from {dirs[0]} in {', '.join(differ)}: its rounds are not comparable")
    if os.path.exists(out):
        raise ValueError(f"{out} exists: choose a new --out (nothing is overwritten)")
    results: dict = {}
    robustness: dict = {}
    for r in runs:
        for terrain, by_ctrl in r["results"].items():
            results.setdefault(terrain, {}).update(by_ctrl)
        for name, by_ctrl in r.get("robustness", {}).items():
            for ctrl, by_terrain in by_ctrl.items():
                robustness.setdefault(name, {}).setdefault(ctrl, {}).update(by_terrain)
    meta = {**runs[0]["meta"], "merged_from": [os.path.abspath(d) for d in dirs],
            "wall_s": round(sum(r["meta"].get("wall_s", 0.0) for r in runs), 1)}  # fmt: skip
    os.makedirs(out)
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"meta": meta, "results": results, "robustness": robustness}, f, indent=1)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write(report_markdown(results, meta, robustness))
    print(f"merged {len(dirs)} evaluations into {out}/ (report.md, results.json)")
    return 0


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.evaluate", description="The paper's evaluation and report.")
    p.add_argument("--controllers", nargs="+", default=["cpg", "cpg_rl"], choices=list(CONTROLLERS))
    p.add_argument("--checkpoint", nargs="+", metavar="CTRL[:TERRAIN]=PATH", help="policy of cpg_rl / joint")
    p.add_argument("--terrains", nargs="+", type=terrain_name, default=["rugged", "stepped", "complex"])
    p.add_argument("--rounds", type=positive_int, default=25, help="rounds per controller and terrain (paper: 25)")
    p.add_argument("--max_steps", type=positive_int, default=TaskConfig.max_episode_steps,
                   help="control steps per round (default: the episode limit)")  # fmt: skip
    p.add_argument("--reset_yaw", type=float, default=TaskConfig.reset_yaw, help="start yaw noise [rad]")
    p.add_argument("--runs", nargs="+", metavar="CTRL=RUN[,RUN]", help="training runs for Fig. 5a")
    p.add_argument("--distances", nargs="+", type=float, default=list(DISTANCES),
                   help="success distances [m] (Table 3: 0.5 1 2 3)")
    p.add_argument("--goal_distance", type=float, default=TaskConfig.goal_distance,
                   help="goal ahead of the start [m]; the largest distance needs goal_distance - 0.5 or more")
    p.add_argument("--step_rise", type=float, default=TerrainConfig.step_rise, help="step height [m] (§3.1: 0.06)")
    p.add_argument("--posture_reflex", type=float, default=None, metavar="K",
                   help="levelling reflex gain of every CPG controller (kernels/mapping.py): a posture policy's "
                        "instead of its own; fixed gaits get the body posture at its neutral values (default: each "
                        "policy's own, fixed gaits without posture)")
    p.add_argument("--block_height_max", type=float, default=TerrainConfig.block_height_max,
                   help="tallest rugged block [m] (§3.1: 0.06)")
    p.add_argument("--randomize", action="store_true",
                   help="perturbed conditions: friction, payload, masses, gains, latency, noise, pushes")
    p.add_argument("--swept_gait", type=float, nargs=4, metavar=("OMEGA", "A1", "A2", "A3"), default=None,
                   help="the cpg_swept controller's gait (default config.FIXED_GAITS['swept'], from hexnewton.cpg_sweep)")
    p.add_argument("--perturbations", nargs="+", default=[], metavar="NAME",
                   help="also run every controller under these named perturbations beyond the training ranges, one "
                        f"robustness table per controller: {', '.join(PERTURBATIONS)}")
    actions = p.add_mutually_exclusive_group()
    actions.add_argument("--stochastic", action="store_true",
                         help="learnt policies sample their actions as in training (default: the deterministic "
                              "action, the distribution's mean)")
    actions.add_argument("--expected", action="store_true",
                         help="learnt policies take the expected clipped action E[clip(a, -1, 1)] of their Gaussian "
                              "(deterministic; SB3 models: their deterministic action)")
    p.add_argument("--frame_dt", type=float, default=None,
                   help="physics frame [s] (default: the policy's own, from its checkpoint; 0.01 for cpg)")
    p.add_argument("--substeps", type=positive_int, default=None,
                   help="MuJoCo steps per frame (default: as --frame_dt)")
    p.add_argument("--seed", type=int, default=EVAL_TERRAIN_SEED,
                   help=f"terrain seed S, start poses from seed S + {START_SEED_OFFSET} (default {EVAL_TERRAIN_SEED}: "
                        "the test set). Choose checkpoints on another S (a validation set), report on the default")
    p.add_argument("--device", default=None)
    p.add_argument("--out", default=None, help="output directory (default eval/<date_time>); must not exist")
    p.add_argument("--merge", nargs="+", metavar="DIR",
                   help="simulate nothing: join the results.json of evaluations run apart (one controller or terrain "
                        "per GPU or process, the same seeds) into one report in --out")
    p.add_argument("--no-progress", action="store_true")
    args = p.parse_args(argv)
    if args.merge:
        return merge_reports(args.merge, args.out or os.path.join("eval", datetime.datetime.now().strftime(
            "%Y-%m-%d_%H-%M-%S")))
    distances = tuple(sorted(set(args.distances)))
    if not all(0 < d <= args.goal_distance - TaskConfig.goal_radius + 1e-9 for d in distances):
        raise ValueError(f"--distances must lie in (0, goal_distance - {TaskConfig.goal_radius:g}] = "
                         f"(0, {args.goal_distance - TaskConfig.goal_radius:g}] m")  # fmt: skip
    checkpoints = _pairs(args.checkpoint, "--checkpoint")
    runs = _pairs(args.runs, "--runs")
    from .baselines import check_model_file
    from .train import load_checkpoint

    for ctrl in args.controllers:  # fail before any simulation
        for terrain in args.terrains:
            if ctrl in SB3:
                check_model_file(checkpoint_for(checkpoints, ctrl, terrain))
            elif ctrl not in FIXED:
                load_checkpoint(checkpoint_for(checkpoints, ctrl, terrain))
    from .curves import read_curve

    for spec in runs.values():
        if "Train/mean_reward" not in read_curve(spec, "env_steps"):
            raise ValueError(f"no mean episode reward logged under {spec}")
    for name in args.perturbations:
        perturbation(name)
    physics = {k: v for k, v in (("frame_dt", args.frame_dt), ("substeps", args.substeps)) if v is not None}
    if args.frame_dt is not None:
        control_decimation(TaskConfig.control_dt, args.frame_dt)
    # the fixed gaits walk under the first learnt policy's physics (the same run, the same simulator) unless told
    learnt = [checkpoint_for(checkpoints, c, args.terrains[0]) for c in args.controllers if c in ("cpg_rl", "joint")]
    fixed_physics = physics
    if not physics and learnt:
        from .train import trained_config

        sim = trained_config(load_checkpoint(learnt[0])).sim
        fixed_physics = {"frame_dt": sim.frame_dt, "substeps": sim.substeps}
    out = args.out or os.path.join("eval", datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S"))
    if os.path.exists(out):
        raise ValueError(f"{out} exists: choose a new --out (nothing is overwritten)")
    parent = os.path.dirname(os.path.abspath(out))
    if not os.path.isdir(parent) or not os.access(parent, os.W_OK):
        raise ValueError(f"cannot create {out}: {parent} is not a writable directory")

    from .sim import resolve_device

    device = resolve_device(args.device)
    progress = not args.no_progress and sys.stderr.isatty()
    results: dict[str, dict[str, dict]] = {}
    os.makedirs(out)
    t0 = time.perf_counter()
    def evaluate_one(ctrl: str, terrain: str, randomization=None, terrain_overrides=None) -> tuple[dict, Episode, dict]:
        ck = None if ctrl in FIXED else checkpoint_for(checkpoints, ctrl, terrain)
        gait = gait_params(*args.swept_gait) if ctrl == "cpg_swept" and args.swept_gait else None
        ep = run_rounds(ctrl, ck, terrain, args.rounds, device, args.max_steps, args.reset_yaw, progress,
                        args.randomize, args.step_rise, args.goal_distance, args.stochastic,
                        fixed_physics if ctrl in FIXED else physics, args.expected, args.seed, randomization,
                        {"block_height_max": args.block_height_max, **(terrain_overrides or {})}, gait,
                        args.posture_reflex)  # fmt: skip
        m = round_metrics(ep.pos, ep.rpy, ep.done, ep.status, ep.dt, distances)
        s = summarize(m, ep.rpy, distances)
        s.update(gait_quality(m, ep.ang_rate, ep.dparam, ep.daction), segments=ep.segments, checkpoint=ck)
        return s, ep, m

    for terrain in args.terrains:
        episodes, metrics = {}, {}
        for ctrl in args.controllers:
            s, ep, m = evaluate_one(ctrl, terrain)
            results.setdefault(terrain, {})[ctrl] = s
            episodes[ctrl], metrics[ctrl] = ep, m
            print(f"{terrain:8s} {LABELS[ctrl]:8s} " + "  ".join(f"{d:g} m {_pct(s[f'success_{d:g}m'])}" for d in distances)
                  + f"  ({s['rounds']} rounds, {len(ep.done)} steps)", flush=True)  # fmt: skip
        # figures now, so that only one terrain's trajectories are held at a time (1000 rounds x 7000 steps)
        plot_terrain(os.path.join(out, f"fig_{terrain}.png"), terrain, episodes, metrics)
        if terrain == args.terrains[0] and any(not np.isnan(ep.params).all() for ep in episodes.values()):
            plot_params(os.path.join(out, "fig_params.png"), terrain, episodes)
    robustness: dict[str, dict[str, dict[str, dict]]] = {}
    for name in args.perturbations:
        rz, overrides = perturbation(name)
        for terrain in args.terrains:
            for ctrl in args.controllers:
                s, _, _ = evaluate_one(ctrl, terrain, rz, overrides)
                robustness.setdefault(name, {}).setdefault(ctrl, {})[terrain] = s
                print(f"[{name}] {terrain:8s} {LABELS[ctrl]:8s} " + "  ".join(
                    f"{d:g} m {_pct(s[f'success_{d:g}m'])}" for d in distances) + f"  falls {s['ended'].get('fell', 0)}",
                    flush=True)  # fmt: skip
    wall = time.perf_counter() - t0
    meta = {"device": device, "rounds": args.rounds, "max_steps": args.max_steps, "reset_yaw": args.reset_yaw,
            "distances": list(distances), "goal_distance": args.goal_distance, "step_rise": args.step_rise,
            "randomized": args.randomize,
            "actions": "sampled" if args.stochastic else "expected" if args.expected else "deterministic (mean)",
            "physics": physics or "each policy's own (checkpoint)", "fixed_cpg_physics": fixed_physics or "default",
            "posture_reflex": "each policy's own" if args.posture_reflex is None else args.posture_reflex,
            "block_height_max": args.block_height_max, "perturbations": args.perturbations,
            "swept_gait": args.swept_gait or list(FIXED_GAITS["swept"]),
            "terrain_seed": args.seed, "reset_seed": args.seed + START_SEED_OFFSET,
            "unseen": "terrain seed and start poses differ from training (train.py: terrain seed 0, seed 1)",
            "wall_s": round(wall, 1)}  # fmt: skip
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump({"meta": meta, "results": results, "robustness": robustness}, f, indent=1)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write(report_markdown(results, meta, robustness))
    if runs:
        plot_learning(os.path.join(out, "fig_learning.png"), runs)
    print(f"report in {out}/ (report.md, results.json, figures) after {wall:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.evaluate"))
