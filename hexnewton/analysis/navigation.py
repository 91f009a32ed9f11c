"""Walking to any goal (ours; the navigate tasks): the evaluation's two protocols, their metrics, report and figure, and
the deterministic validation of a navigate run.

- **Bearings**: one goal per round at 2 m (:data:`GOAL_DISTANCE`) at a bearing of 0, +-45, +-90, +-135 or 180 deg
  (:data:`BEARINGS_DEG`) from the robot's start heading, the rounds dealt evenly over the bearings; a round ends when
  the robot comes within 0.5 m of its goal (reached), falls or runs out of time (:data:`NAVIGATION_STEPS`). Per bearing:
  the share reached, the time to reach, the path walked over the straight line from the start to where it reached
  (1: straight), the falls.
- **Square**: the waypoint course (2, 0), (2, 2), (0, 2), (0, 0) in the start frame (:data:`SQUARE`), each corner
  within 0.5 m in turn, the last ending the round (:data:`NAVIGATION_STEPS`). The share of rounds that completed it, the
  time to complete, the corners reached, the falls.

Each round is one robot's first episode on the course of ``terrain`` as the navigate tasks lay it out
(``tasks.navigation_terrain``: a square patch), with the policy's own physics and CPG, no randomisation, every start
heading (``reset_yaw`` pi), terrain seed ``seed`` and start seed ``seed + START_SEED_OFFSET`` (the evaluation's test
set by default). The episode ends on a fall, the last goal or the step limit (no off-course end). The goals live in
the env (``HexapodEnv.set_waypoints``, ``mdp/terms/goals.py``). ``python -m hexnewton.apps.evaluate --navigate``
writes ``report.md``, ``results.json`` and the top-view figure of the paths.
"""

from __future__ import annotations

import math

import numpy as np

from hexnewton.analysis.figures import save_png
from hexnewton.analysis.rollout import CONTROLLERS, LABELS, START_SEED_OFFSET, controller_policy
from hexnewton.analysis.rollout import goals_reached, read_controller_checkpoint, stepped
from hexnewton.mdp.status import FELL, NONFINITE, SUCCESS, TIMEOUT

#: the bearings' goals: their bearings from the start heading [deg] and distance [m]
BEARINGS_DEG = (0, 45, -45, 90, -90, 135, -135, 180)
GOAL_DISTANCE = 2.0
#: the waypoint course: a 2 m square in the start frame [m]
SQUARE = ((2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (0.0, 0.0))
#: the rounds' step limits (20 ms steps: a 2 m goal, the 8 m square) per terrain, three to eight times what the robot
#: needs at its pace there. On flat ground it walks a 2 m goal in ~4 s and the square in ~17 s: 30 s and 80 s. On the
#: 2 cm blocks it walks 3 m in 30-38 s (the shipped policy's straight rounds, studies/stable_gait/report.md), a 2 m goal
#: in ~20-25 s and the square in ~80-100 s: 60 s and 240 s. Other terrains take the blocks' limits.
NAVIGATION_STEPS = {"flat": (1500, 4000), "rugged": (3000, 12000)}


def navigation_steps(terrain: str) -> tuple[int, int]:
    """The step limits of a round toward a 2 m goal and of a round of the square on ``terrain``."""
    return NAVIGATION_STEPS.get(terrain, NAVIGATION_STEPS["rugged"])

#: the rounds' episode ends: no off-course end (a goal behind the robot is reached by turning)
NAVIGATION_ENDS = ("nonfinite", "fell", "success", "timeout")
#: the issue's targets (share of rounds): reached at |bearing| <= 90 and at 135-180 deg, the square completed, falls
TARGETS = {"flat": {"near": 0.97, "behind": 0.90, "square": 0.90}, "rugged": {"near": 0.95, "square": 0.85},
           "falls": 0.01}  # fmt: skip


def played_goals(trained_task, waypoints=None) -> dict:
    """The ``TaskConfig`` fields of a course a policy is played on (``play.py``): its own goal distance; with
    ``waypoints`` ((x, y), ...) that waypoint course and the navigation's ends; else a navigate policy's random goals
    as it trained on them."""
    fields = {"goal_distance": trained_task.goal_distance}
    if waypoints:
        return dict(fields, waypoints=tuple((float(x), float(y)) for x, y in waypoints), terminations=NAVIGATION_ENDS)
    if trained_task.random_goals:
        keys = ("random_goals", "goal_bearing", "goal_distance_min", "goal_distance_max", "goal_area", "terminations")
        fields.update({k: getattr(trained_task, k) for k in keys})
    return fields


def bearing_goals(rounds: int, group: int = 1, distance: float = GOAL_DISTANCE,
                  bearings=BEARINGS_DEG) -> np.ndarray:  # fmt: skip
    """Each round's one goal (N, 1, 2) in its start frame: round i at bearing ``bearings[(i // group) % B]``
    (``group``: consecutive robots with the same bearing, the validation's candidates interleaved)."""
    b = np.radians(np.asarray(bearings, np.float64))[(np.arange(rounds) // group) % len(bearings)]
    return np.stack([distance * np.cos(b), distance * np.sin(b)], axis=1)[:, None, :]


def navigation_config(terrain, trained, rounds: int, device: str | None, seed: int, max_steps: int,
                      overrides: dict | None = None):  # fmt: skip
    """The course of the rounds (module docstring): ``terrain`` (a name or a ``TerrainConfig``) laid out as the
    navigate tasks' patch, ``trained``'s physics and CPG, every start heading, the navigation ends, ``max_steps``."""
    from hexnewton.tasks import course, navigation_terrain

    return course(navigation_terrain(terrain), trained, overrides, rounds, device, seed, seed=seed + START_SEED_OFFSET,
                  reset_yaw=math.pi, terminations=NAVIGATION_ENDS, max_episode_steps=max_steps)  # fmt: skip


def run_goals(env, policy, waypoints: np.ndarray, max_steps: int, progress: bool | str = False,
              keep_rpy: bool = False) -> dict:  # fmt: skip
    """Every robot's first episode toward its waypoint course ``waypoints`` ((K, 2) or (N, K, 2), start frame):
    ``pos`` (T, N, 2) float32 in each start frame (NaN after the episode), ``end`` (N,) status (0: still walking at
    the end), ``steps`` (N,) the episode's steps, ``goals`` (N,) the waypoints reached, ``dt``; with ``keep_rpy`` also
    ``rpy`` (T, N, 3) [rad] (NaN after the episode). ``progress``: as :func:`~hexnewton.analysis.rollout.stepped`'s."""
    env.set_waypoints(waypoints)
    env.reset()
    n = env.num_envs
    yaw = env.goals.start_yaw.numpy().astype(np.float64)
    c, s = np.cos(yaw), np.sin(yaw)
    alive, goals = np.ones(n, bool), np.zeros(n, np.int64)
    end, steps = np.zeros(n, np.int64), np.full(n, max_steps)
    pos, rpy = [], []
    for t, st, _, p, r in stepped(env, policy, max_steps, f"navigation, {env.num_envs} rounds", progress):
        d = p[:, :2].astype(np.float64)
        here = np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)  # the start frame
        pos.append(np.where(alive[:, None], here, np.nan).astype(np.float32))
        if keep_rpy:
            rpy.append(np.where(alive[:, None], r, np.nan))
        goals = np.where(alive, goals_reached(env, st), goals)
        ended = alive & (st != 0)
        end[ended], steps[ended] = st[ended], t + 1
        alive &= ~ended
        if not alive.any():
            break
    env.world.check_contacts()
    out = {"pos": np.stack(pos), "end": end, "steps": steps, "goals": goals, "dt": env.cfg.task.control_dt}
    if keep_rpy:
        out["rpy"] = np.stack(rpy)
    return out


def path_metrics(pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each round's path length [m] (from its start, over its episode's steps) and the straight line from the start to
    where it ended [m]."""
    p = np.concatenate([np.zeros((1,) + pos.shape[1:]), np.asarray(pos, np.float64)], axis=0)
    step = np.hypot(*np.diff(p, axis=0).transpose(2, 0, 1))
    length = np.nansum(step, axis=0)
    last = np.array([p[np.flatnonzero(np.isfinite(p[:, i, 0]))[-1], i] for i in range(p.shape[1])])
    return length, np.hypot(last[:, 0], last[:, 1])


def _mean(v) -> float | None:
    v = np.asarray(v, np.float64)
    return float(v.mean()) if v.size else None


def summarize_bearings(run: dict, rounds: int) -> dict:
    """Per bearing and over the groups the targets name (|bearing| <= 90, 135-180 deg): rounds, the share reached,
    the mean time to reach [s], the mean and median path over the straight line (reached rounds), the falls."""
    reached, fell = run["end"] == SUCCESS, np.isin(run["end"], (FELL, NONFINITE))
    length, straight = path_metrics(run["pos"])
    ratio = np.where(reached, length / np.maximum(straight, 1e-9), np.nan)
    idx = np.arange(rounds) % len(BEARINGS_DEG)

    def block(sel) -> dict:
        r = reached & sel
        return {"rounds": int(sel.sum()), "reached": _mean(reached[sel]), "time_s": _mean(run["steps"][r] * run["dt"]),
                "path_ratio": _mean(ratio[r]), "path_ratio_median": float(np.median(ratio[r])) if r.any() else None,
                "fall_rate": _mean(fell[sel]), "timeouts": int((run["end"][sel] == TIMEOUT).sum())}  # fmt: skip

    per = {str(b): block(idx == i) for i, b in enumerate(BEARINGS_DEG)}
    absb = np.abs(np.asarray(BEARINGS_DEG))[idx]
    return {"per_bearing": per, "near": block(absb <= 90), "behind": block(absb >= 135), "all": block(idx >= 0)}


def summarize_square(run: dict) -> dict:
    """The share that completed the square, the mean time to complete [s], the mean corners reached, the falls."""
    done, fell = run["end"] == SUCCESS, np.isin(run["end"], (FELL, NONFINITE))
    length, _ = path_metrics(run["pos"])
    return {"rounds": int(done.size), "completed": _mean(done), "time_s": _mean(run["steps"][done] * run["dt"]),
            "corners": _mean(run["goals"]), "path_m": _mean(length[done]), "fall_rate": _mean(fell),
            "timeouts": int((run["end"] == TIMEOUT).sum())}  # fmt: skip


def evaluate_controller(controller: str, checkpoint: str | None, terrain: str, rounds: int, device: str | None,
                        seed: int, progress: bool | str = False, overrides: dict | None = None,
                        steps: tuple[int, int] | None = None) -> tuple[dict, dict]:  # fmt: skip
    """Both protocols for one controller on one terrain: ``rounds`` rounds at each bearing, ``rounds`` rounds of the
    square, with ``steps`` (a goal's, the square's; default :func:`navigation_steps`) control steps at most. Returns
    ({"bearings": summary, "square": summary}, the two runs' arrays for the figure)."""
    from hexnewton.learning.checkpoint import trained_config
    from hexnewton.mdp.env import make_env

    ckpt = read_controller_checkpoint(controller, checkpoint)
    trained = trained_config(ckpt) if ckpt is not None else None
    if trained is None:
        from hexnewton.config import HexConfig

        trained = HexConfig()
    out, runs = {}, {}
    steps = steps or navigation_steps(terrain)
    for name, n, goals, limit in (("bearings", rounds * len(BEARINGS_DEG), None, steps[0]),
                                  ("square", rounds, np.asarray(SQUARE), steps[1])):  # fmt: skip
        cfg = navigation_config(terrain, trained, n, device, seed, limit, overrides)
        env = make_env(cfg, CONTROLLERS[controller])
        policy = controller_policy(env, controller, checkpoint, ckpt)
        runs[name] = run_goals(env, policy, bearing_goals(n) if goals is None else goals, limit, progress)
        out[name] = summarize_bearings(runs[name], n) if goals is None else summarize_square(runs[name])
        del env
    return out, runs


def plot_paths(path: str, title: str, runs: dict, shown: int = 6) -> None:
    """The top view of the paths in the start frame: the bearings' (``shown`` rounds per bearing) with their goals and
    0.5 m circles, and the square's (``4 * shown`` rounds) with its corners; a fall marked x."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 5.4))
    b, sq = runs["bearings"], runs["square"]
    goals = bearing_goals(len(b["end"]))[:, 0]
    for i in range(min(len(b["end"]), shown * len(BEARINGS_DEG))):
        _path(axes[0], b, i, f"C{i % len(BEARINGS_DEG)}")
    for g in goals[: len(BEARINGS_DEG)]:
        axes[0].add_patch(matplotlib.patches.Circle(tuple(g), 0.5, fill=False, color="g", lw=0.8))
    for i in range(min(len(sq["end"]), 4 * shown)):
        _path(axes[1], sq, i, "C0")
    for k, corner in enumerate(SQUARE):
        axes[1].add_patch(matplotlib.patches.Circle(corner, 0.5, fill=False, color="g", lw=0.8))
        axes[1].annotate(str(k + 1), corner, color="g", ha="center", va="center")
    axes[0].set_title(f"goals at 2 m, {min(shown, len(b['end']) // len(BEARINGS_DEG))} rounds per bearing")
    axes[1].set_title(f"the 2 m square, {min(len(sq['end']), 4 * shown)} rounds")
    for ax in axes:
        ax.plot(0, 0, "k^", ms=8)
        ax.set(xlabel="x along the start heading [m]", ylabel="y [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    save_png(fig, path, dpi=90)
    plt.close(fig)


def _path(ax, run: dict, i: int, color: str) -> None:
    p = run["pos"][:, i]
    p = p[np.isfinite(p[:, 0])]
    ax.plot(np.r_[0.0, p[:, 0]], np.r_[0.0, p[:, 1]], color=color, lw=0.7, alpha=0.7)
    if run["end"][i] in (FELL, NONFINITE) and len(p):
        ax.plot(p[-1, 0], p[-1, 1], "rx", ms=6)


def _pct(v) -> str:
    return "—" if v is None else f"{100 * v:.1f} %"


def _num(v, digits: int = 1) -> str:
    return "—" if v is None else f"{v:.{digits}f}"


def target_checks(results: dict) -> list[dict]:
    """Each target of :data:`TARGETS` that ``results`` (``{terrain: {controller: ...}}``) measure: terrain, controller,
    what, the measured share (``got``), the line (``need``), ``at_least`` (a floor, else a ceiling) and ``met``."""
    out = []
    for terrain, per in results.items():
        want = TARGETS.get(terrain, {})
        for ctrl, r in per.items():
            rows = [("goals at |bearing| <= 90 deg reached", r["bearings"]["near"]["reached"], want.get("near"), True),
                    ("goals at 135-180 deg reached", r["bearings"]["behind"]["reached"], want.get("behind"), True),
                    ("square completed", r["square"]["completed"], want.get("square"), True),
                    ("falls (bearings)", r["bearings"]["all"]["fall_rate"], TARGETS["falls"], False),
                    ("falls (square)", r["square"]["fall_rate"], TARGETS["falls"], False)]  # fmt: skip
            for what, got, need, at_least in rows:
                if need is None or got is None:
                    continue
                out.append(dict(terrain=terrain, controller=ctrl, what=what, got=got, need=need, at_least=at_least,
                                met=bool(got >= need if at_least else got <= need)))  # fmt: skip
    return out


def target_lines(results: dict) -> list[str]:
    """Each target of :data:`TARGETS` with the measured share and whether it holds, per controller and terrain."""
    return [f"- {LABELS.get(c['controller'], c['controller'])} on {c['terrain']}: {c['what']} {_pct(c['got'])} "
            f"({'>=' if c['at_least'] else '<='} {100 * c['need']:g} %): **{'met' if c['met'] else 'not met'}**"
            for c in target_checks(results)]  # fmt: skip


def report_markdown(results: dict, meta: dict) -> str:
    """report.md: the targets, one table per terrain of the bearings (per controller, per bearing) and one of the
    square."""
    lines = ["# hexnewton navigation evaluation: goals in every direction and a waypoint course", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()]
    lines += ["", "## Targets", ""] + (target_lines(results) or ["- (none for these terrains)"])
    for terrain, per in results.items():
        lines += ["", f"## {terrain}: goals at 2 m", "",
                  "| controller | bearing [deg] | rounds | reached | time [s] | path / straight (median) | falls | "
                  "timeouts |", "|---|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        for ctrl, r in per.items():
            rows = [(b, r["bearings"]["per_bearing"][str(b)]) for b in BEARINGS_DEG]
            rows += [("\\|b\\| <= 90", r["bearings"]["near"]), ("135-180", r["bearings"]["behind"]),
                     ("all", r["bearings"]["all"])]  # fmt: skip
            for b, s in rows:
                lines.append(f"| {LABELS.get(ctrl, ctrl)} | {b} | {s['rounds']} | {_pct(s['reached'])} | "
                             f"{_num(s['time_s'])} | {_num(s['path_ratio'], 2)} ({_num(s['path_ratio_median'], 2)}) | "
                             f"{_pct(s['fall_rate'])} | {s['timeouts']} |")  # fmt: skip
        lines += ["", f"## {terrain}: the 2 m square (2, 0), (2, 2), (0, 2), (0, 0)", "",
                  "| controller | rounds | completed | time [s] | corners reached | path [m] | falls | timeouts |",
                  "|---|---:|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        for ctrl, r in per.items():
            s = r["square"]
            lines.append(f"| {LABELS.get(ctrl, ctrl)} | {s['rounds']} | {_pct(s['completed'])} | {_num(s['time_s'])} | "
                         f"{_num(s['corners'], 2)} | {_num(s['path_m'], 1)} | {_pct(s['fall_rate'])} | "
                         f"{s['timeouts']} |")  # fmt: skip
        lines += ["", f"Paths: `fig_paths_{terrain}_<controller>.png` (start frame, x along the start heading)."]
    return "\n".join(lines) + "\n"


def validate_navigation(env, policy, candidates: int) -> tuple[list[dict], dict]:
    """A navigate run's validation rounds (:func:`hexnewton.analysis.validation.validate`): every robot one goal at 2 m,
    the bearings dealt so that each of the ``candidates`` (robots k, k + K, ...) walks each bearing equally often.
    Returns per candidate the keys of the straight validation but the body's variances (``goal`` the share reached,
    ``fell`` = ``fell_before_goal``: a round ends at its goal, ``walk_3m`` none, ``off_course`` 0) and the run
    (:func:`run_goals`, with ``rpy``)."""
    run = run_goals(env, policy, bearing_goals(env.num_envs, group=candidates), env.cfg.task.max_episode_steps,
                    keep_rpy=True)  # fmt: skip
    end = run["end"]
    fell = np.isin(end, (FELL, NONFINITE))
    return [{"goal": float((end[i::candidates] == SUCCESS).mean()), "walk_3m": float("nan"),
             "fell": float(fell[i::candidates].mean()), "fell_before_goal": float(fell[i::candidates].mean()),
             "off_course": 0.0, "rounds": int(end[i::candidates].size)} for i in range(candidates)], run
