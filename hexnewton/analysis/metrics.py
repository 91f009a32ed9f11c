"""Metrics of rollouts, on the host in float64: the paper's (§3.3-3.4: success at 0.5 / 1 / 2 / 3 m, roll and pitch
mean, variance and peak, Y deviation, time to each distance) and ours (99.9th percentile tilt, falls, body rates,
parameter changes), per round and over all rounds.
"""

from __future__ import annotations

import math

import numpy as np

from hexnewton.mdp.status import FELL, NONFINITE, OFF_COURSE, STATUS_NAMES

DISTANCES = (0.5, 1.0, 2.0, 3.0)  # Table 3's columns [m]
_BAD_END = (FELL, OFF_COURSE, NONFINITE)


def round_metrics(pos: np.ndarray, rpy: np.ndarray, done: np.ndarray, status: np.ndarray, dt: float,
                  distances: tuple[float, ...] = DISTANCES) -> dict:  # fmt: skip
    """Per-round metrics of each env's first episode.

    ``pos`` (T, N, 2+) x, y relative to the round's start; ``rpy`` (T, N, 3) [rad]; ``done`` (T, N) the
    episode ended at that step; ``status`` (T, N) why (``kernels.reference`` status codes); ``dt`` the control
    period. Returns arrays over the N rounds: ``reached`` (D, N) bool, ``time_to`` (D, N) [s] (nan if not
    reached), ``y_dev`` (N,) [m], ``end`` (N,) status code (0 = still running at the last step),
    ``steps`` (N,), ``x_far`` (N,) [m] the farthest x of each first episode (-inf if none), and ``in_episode`` (T, N),
    the rows that belong to each first episode.
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
            "x_far": x.max(axis=0), "in_episode": in_episode}  # fmt: skip


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


def summarize(metrics: dict, rpy: np.ndarray, distances: tuple[float, ...] = DISTANCES,
              goal_line: float | None = None) -> dict:
    """Rates and stability over all rounds (JSON-ready; angles in degrees): success and time at each distance, the
    paper's roll / pitch mean, variance and peak, the 99.9th percentile of |roll| and |pitch|, the share of rounds
    that ended in a fall (anywhere, also after the last distance), Y deviation, how the rounds ended (``ended``) and
    how those that walked the last distance ended (``ended_past_3m``: a fall there happened after the success column
    counted the round). With ``goal_line`` (the goal's distance plus its radius [m]): how the rounds that walked
    beyond it ended (``ended_past_goal``: but for a success at the goal's far edge, they passed the goal without
    reaching it, and walking on, the course's patch ends under them) and the share of rounds that fell before it
    (``fall_rate_before_goal``)."""
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
    past = metrics["reached"][-1]  # how the rounds that walked the last distance ended: the way to the goal beyond it
    out[f"ended_past_{distances[-1]:g}m"] = {STATUS_NAMES[c]: int(((metrics["end"] == c) & past).sum())
                                             for c in range(len(STATUS_NAMES))}  # fmt: skip
    if goal_line is not None:
        passed = metrics["x_far"] >= goal_line
        out["goal_line_m"] = float(goal_line)
        out["ended_past_goal"] = {STATUS_NAMES[c]: int(((metrics["end"] == c) & passed).sum())
                                  for c in range(len(STATUS_NAMES))}  # fmt: skip
        out["fall_rate_before_goal"] = float(((metrics["end"] == FELL) & ~passed).mean())
    return out


def first_episode_stats(pos: np.ndarray, rpy: np.ndarray, done: np.ndarray, status: np.ndarray) -> dict:
    """Statistics over every env's first episode. Arrays are (T, N, ...) per control step, positions relative
    to each env's start; a row with ``done`` is the last row of that episode, ``status`` gives the reason."""
    ended_before = np.cumsum(done, axis=0) - done  # episodes finished before this row
    first = ended_before == 0  # (T, N)
    last_row = np.where(done.any(axis=0), np.argmax(done, axis=0), len(done) - 1)
    envs = np.arange(pos.shape[1])
    end_pos, end_rpy = pos[last_row, envs], rpy[last_row, envs]
    end_status = np.where(done.any(axis=0), status[last_row, envs], 0)
    deg = 180.0 / math.pi
    tilt = np.abs(rpy[..., :2])[first]  # (samples, 2): roll, pitch
    return {
        "envs": pos.shape[1],
        "distance_m": float(end_pos[:, 0].mean()),
        "distance_min_m": float(end_pos[:, 0].min()),
        "lateral_drift_m": float(np.abs(end_pos[:, 1]).mean()),
        "lateral_drift_max_m": float(np.abs(end_pos[:, 1]).max()),
        "heading_error_deg": float(np.abs(end_rpy[:, 2]).mean() * deg),
        "roll_mean_deg": float(tilt[:, 0].mean() * deg),
        "roll_std_deg": float(tilt[:, 0].std() * deg),
        "roll_max_deg": float(tilt[:, 0].max() * deg),
        "pitch_mean_deg": float(tilt[:, 1].mean() * deg),
        "pitch_std_deg": float(tilt[:, 1].std() * deg),
        "pitch_max_deg": float(tilt[:, 1].max() * deg),
        "ended": {STATUS_NAMES[k]: int((end_status == k).sum()) for k in range(1, len(STATUS_NAMES))},
    }


def format_stats(terrain: str, s: dict, seconds: float) -> str:
    """play.py's summary of :func:`first_episode_stats`: how far the first episodes walked along the course, or, where
    the robots walk to goals (``goals_mean`` from :func:`~hexnewton.analysis.rollout.rollout`), how many they reached;
    their roll and pitch, how they ended."""
    ended = ", ".join(f"{k} {v}" for k, v in s["ended"].items() if v) or "none"
    if "goals_mean" in s:
        of = f" of {s['goals_of']}" if s.get("goals_of") else ""
        where = f"first episodes reached {s['goals_mean']:.1f}{of} goals (min {s['goals_min']})"
    else:
        where = (f"first episodes walked {s['distance_m']:.2f} m (min {s['distance_min_m']:.2f}), |y| drift "
                 f"{s['lateral_drift_m']:.3f} m (max {s['lateral_drift_max_m']:.3f}), heading error "
                 f"{s['heading_error_deg']:.1f} deg")  # fmt: skip
    return (
        f"{terrain}: {s['envs']} robots, {seconds:.1f} s of control: {where}\n"
        f"  |roll| {s['roll_mean_deg']:.1f} +- {s['roll_std_deg']:.1f} deg (max {s['roll_max_deg']:.1f}), "
        f"|pitch| {s['pitch_mean_deg']:.1f} +- {s['pitch_std_deg']:.1f} deg (max {s['pitch_max_deg']:.1f}); "
        f"first episodes ended: {ended}"
    )
