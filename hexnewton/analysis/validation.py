"""Deterministic validation, the end of a training run (``train.py``, ``AgentConfig.validation_rounds``): candidate
checkpoints of the last curriculum stage walk the task's course on validation rounds (terrain seed 3000, start seed
4000, as ``evaluate --seed 3000``: never the test seeds), each with its deterministic action, all of them side by side
in one batched env (candidate k drives robots k, k + K, k + 2K, ...); the run's result is the candidate that reaches
the goal most often, then falls least before the goal line (``fell_before_goal``: the goal's distance plus its radius,
``analysis.metrics.summarize``'s ``fall_rate_before_goal``; a robot that walks past the goal and off the course patch's
end missed its steering, not its footing), then the later one. All falls (``fell``) are reported beside.

Training success counts sampled actions on the training levels; a policy's deterministic action can walk past the
goal where its samples reach it (studies/cpu_main_job), so the result is chosen on what is shipped and evaluated.
"""

from __future__ import annotations

import glob
import os
import re
from dataclasses import dataclass, replace

import numpy as np

from hexnewton.analysis.metrics import round_metrics
from hexnewton.mdp.status import FELL, OFF_COURSE, SUCCESS

#: the validation rounds' terrain seed (start seed + 1000): ``evaluate --seed 3000`` (docs/evaluation.md, "Conventions")
VALIDATION_SEED = 3000
_SAVED = re.compile(r"model_(\d+)\.pt$")


@dataclass
class Candidate:
    """A checkpoint to validate: its iteration, path and why it is a candidate."""

    iteration: int
    path: str
    why: str


def candidates(run_dir: str, first_iteration: int, last: Candidate, best: Candidate | None,
               limit: int) -> list[Candidate]:  # fmt: skip
    """At most ``limit`` candidates, oldest first: the ``last`` checkpoint, the ``best`` by training success and the
    newest ``model_<it>.pt`` of ``run_dir`` saved from ``first_iteration`` on (the last stage's)."""
    chosen = [last] + ([best] if best is not None and best.iteration != last.iteration else [])
    saved = sorted(((int(m.group(1)), p) for p in glob.glob(os.path.join(run_dir, "model_*.pt"))
                    if (m := _SAVED.search(os.path.basename(p)))), reverse=True)  # fmt: skip
    for it, path in saved:
        if len(chosen) >= limit:
            break
        if it >= first_iteration and all(c.iteration != it for c in chosen):
            chosen.append(Candidate(it, path, "saved"))
    return sorted(chosen[:limit], key=lambda c: c.iteration)


def candidate_rows(n: int, k: int) -> list[np.ndarray]:
    """Each of ``k`` candidates' robots among ``n`` interleaved ones: candidate i drives robots i, i + k, ..."""
    return [np.arange(i, n, k) for i in range(k)]


def _batched_policy(env, controller: str, cands: list[Candidate], rows: list[np.ndarray]):
    """``policy(obs) -> actions``: candidate k's deterministic action for its robots ``rows[k]``."""
    import torch

    from hexnewton.analysis.rollout import controller_policy, read_controller_checkpoint

    device = env.get_observations().device
    rows = [torch.as_tensor(r, device=device) for r in rows]
    policies = [controller_policy(env, controller, c.path, read_controller_checkpoint(controller, c.path))
                for c in cands]  # fmt: skip

    def policy(obs):
        out = None
        for idx, act in zip(rows, policies):
            a = act(obs[idx])
            if out is None:
                out = torch.empty((env.num_envs, a.shape[-1]), dtype=a.dtype, device=a.device)
            out[idx] = a
        return out

    return policy


def validate(cands: list[Candidate], controller: str, terrain, rounds: int, device: str | None, max_steps: int,
             goal_distance: float | None = None) -> list[dict]:  # fmt: skip
    """Each candidate's validation: ``rounds`` robots each on the course of ``terrain`` (a name, or the task's
    ``TerrainConfig``: its rises and blocks without the curriculum lanes) with the goal ``goal_distance`` ahead (None:
    the default), with the physics and CPG of the newest candidate's checkpoint (one stage: one configuration).
    Returns per candidate the shares of rounds that reached the goal, walked 3 m, fell, fell before the goal line
    (``fell_before_goal``) and left the course, and its body's pitch and roll variance over its rounds [deg²] (the
    stability the last curriculum stage trains: the choice does not weigh it, the console and ``timing.json`` show
    it). A navigate run (random goals) walks the navigation's validation instead: one goal at 2 m per round, every
    bearing (:func:`hexnewton.analysis.navigation.validate_navigation`)."""
    from hexnewton.analysis.rollout import CONTROLLERS, START_SEED_OFFSET, read_controller_checkpoint
    from hexnewton.learning.checkpoint import trained_config
    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import course

    k = len(cands)
    trained = trained_config(read_controller_checkpoint(controller, cands[-1].path))
    if trained.task.random_goals:  # a navigate run: one goal at 2 m per round, every bearing (analysis/navigation.py)
        from hexnewton.analysis.navigation import navigation_config, validate_navigation

        env = make_env(navigation_config(terrain, trained, rounds * k, device, VALIDATION_SEED, max_steps),
                       CONTROLLERS[controller])  # fmt: skip
        rows = candidate_rows(env.num_envs, k)
        shares, run = validate_navigation(env, _batched_policy(env, controller, cands, rows), k)
        pitch, roll = candidate_variances(run["rpy"], np.isfinite(run["pos"][..., 0]), rows)
        return [dict(r, pitch_var=pitch[i], roll_var=roll[i]) for i, r in enumerate(shares)]
    cfg = course(terrain, trained, None, rounds * k, device, VALIDATION_SEED, seed=VALIDATION_SEED + START_SEED_OFFSET,
                 **({} if goal_distance is None else {"goal_distance": goal_distance}))  # fmt: skip
    rows = candidate_rows(cfg.sim.num_envs, k)
    return _walk(cfg, controller, cands, rows, max_steps, f"validation of {k} candidates on {cfg.terrain.name}, "
                 f"{rounds} rounds each")  # fmt: skip


def _walk(cfg, controller: str, cands: list[Candidate], rows: list[np.ndarray], max_steps: int, where: str,
          results: list[np.ndarray] | None = None) -> list[dict]:  # fmt: skip
    """The candidates walk the env of ``cfg``, candidate i driving robots ``rows[i]``, until every round ended or
    ``max_steps``; the shares and variances (:func:`validate`'s) of each robot set of ``results`` (None: ``rows``)."""
    from hexnewton.analysis.rollout import CONTROLLERS, progress_mode, stepped
    from hexnewton.mdp.env import make_env

    env = make_env(cfg, CONTROLLERS[controller])
    policy = _batched_policy(env, controller, cands, rows)
    pos, rpy, status = [], [], []
    finished = np.zeros(env.num_envs, bool)
    for _, st, _, p, r in stepped(env, policy, max_steps, where, progress_mode()):
        pos.append(p[:, :2])
        rpy.append(r)
        status.append(st.copy())
        finished |= st != 0
        if finished.all():
            break
    env.world.check_contacts()
    status, rpy = np.stack(status), np.stack(rpy)
    m = round_metrics(np.stack(pos), rpy, status != 0, status, cfg.task.control_dt, (3.0,))
    end, walked = m["end"], m["reached"][0]
    early = (end == FELL) & (m["x_far"] < cfg.task.goal_distance + cfg.task.goal_radius)  # fell before the goal line
    rows = rows if results is None else results
    pitch, roll = candidate_variances(rpy, m["in_episode"], rows)
    return [{"goal": float((end[r] == SUCCESS).mean()), "walk_3m": float(walked[r].mean()),
             "fell": float((end[r] == FELL).mean()), "fell_before_goal": float(early[r].mean()),
             "off_course": float((end[r] == OFF_COURSE).mean()), "pitch_var": pitch[i], "roll_var": roll[i],
             "rounds": int(r.size)} for i, r in enumerate(rows)]  # fmt: skip


def together_config(terrains: list[str], trained, rounds: int, device: str | None,
                    goal_distance: float | None = None):  # fmt: skip
    """The env of :func:`validate_together`: the courses ``terrains`` (names) side by side along y, each one lane
    group of a single lane as wide as a course's patch (``TerrainConfig.lane_courses``, ``levels`` 1: each course at
    its full height, without a curriculum), ``rounds`` robots per course and candidate; returns the config and the
    index in ``terrains`` of each lane group's course (a flat course, a ground plane, cannot lead the groups)."""
    from hexnewton.analysis.rollout import START_SEED_OFFSET
    from hexnewton.tasks import course

    order = sorted(range(len(terrains)), key=lambda c: terrains[c] == "flat")
    if terrains[order[0]] == "flat":
        raise ValueError("validation side by side needs a course other than flat among the validation terrains")
    cfg = course(terrains[order[0]], trained, None, rounds * len(terrains), device, VALIDATION_SEED,
                 seed=VALIDATION_SEED + START_SEED_OFFSET,
                 **({} if goal_distance is None else {"goal_distance": goal_distance}))  # fmt: skip
    lanes = replace(cfg.terrain, levels=1, start_levels=1, lane_width=cfg.terrain.width,
                    lane_courses=tuple(terrains[c] for c in order[1:]))  # fmt: skip
    return replace(cfg, terrain=lanes), order


def validate_together(cands: list[Candidate], controller: str, terrains: list[str], rounds: int,
                      device: str | None, max_steps: int,
                      goal_distance: float | None = None) -> dict[tuple[int, int], dict]:  # fmt: skip
    """:func:`validate` of every candidate on every course of ``terrains`` (names) in one env
    (:func:`together_config`): G courses and K candidates, robot i plays lane group i mod G and candidate
    (i // G) mod K, ``rounds`` robots per pair. One env of 3072 robots steps the three courses in little more than
    the time the rugged course's 1024 take alone (on an H100: 37.7 against 68.9 s one by one,
    studies/throughput/validation). The rounds are not those of the courses one by one: each course is its own lane
    group with its own block seed and its robots' starts spread over the robots of all courses. Returns
    {(course index, candidate index): result}, as :func:`validate_share`. A navigate run (random goals) walks each
    course's navigation validation one after another (:func:`validate`)."""
    from hexnewton.analysis.rollout import read_controller_checkpoint
    from hexnewton.learning.checkpoint import trained_config

    k, g = len(cands), len(terrains)
    trained = trained_config(read_controller_checkpoint(controller, cands[-1].path))
    if trained.task.random_goals:
        return validate_share(cands, controller, terrains, rounds, device, max_steps, goal_distance)
    cfg, order = together_config(terrains, trained, rounds * k, device, goal_distance)
    i = np.arange(cfg.sim.num_envs)
    pairs = [(grp, c) for grp in range(g) for c in range(k)]
    rows = [np.flatnonzero((i % g == grp) & ((i // g) % k == c)) for grp, c in pairs]
    policy_rows = [np.flatnonzero((i // g) % k == c) for c in range(k)]
    where = f"validation of {k} candidates on {course_names([terrains[c] for c in order])} side by side, {rounds} " \
            "rounds each"  # fmt: skip
    results = _walk(cfg, controller, cands, policy_rows, max_steps, where, rows)
    return {(order[grp], c): r for (grp, c), r in zip(pairs, results)}


def candidate_variances(rpy: np.ndarray, in_episode: np.ndarray,
                        rows: list[np.ndarray]) -> tuple[list[float], list[float]]:  # fmt: skip
    """Each robot set's (``rows``: one index array per candidate) body pitch and roll variance [deg²] over the steps
    of its rounds' first episodes (``rpy`` (T, N, 3) roll, pitch, yaw [rad]; ``in_episode`` (T, N)); non-finite
    angles are left out, nan for none."""
    out = []
    for axis in (1, 0):
        per = []
        for r in rows:
            a = np.degrees(np.asarray(rpy[:, r, axis], np.float64))[in_episode[:, r]]
            a = a[np.isfinite(a)]
            per.append(float(a.var()) if a.size else float("nan"))
        out.append(per)
    return out[0], out[1]


def validation_share(candidates: int, courses: int, rank: int = 0, world_size: int = 1) -> dict[int, list[int]]:
    """Rank ``rank``'s share of a validation of ``candidates`` candidates on ``courses`` courses among ``world_size``
    torchrun ranks, as {course index: [candidate indices]}: whole courses dealt over the ranks while there are no more
    ranks than courses, else each course's candidates dealt over its ranks (ranks c, c + courses, ...), so that no
    rank steps more envs than it must (an env's step costs about the same for 256 robots as for 1024)."""
    if world_size <= courses:
        return {c: list(range(candidates)) for c in range(courses) if c % world_size == rank}
    course = rank % courses
    ranks = list(range(course, world_size, courses))
    mine = list(range(candidates))[ranks.index(rank)::len(ranks)]
    return {course: mine} if mine else {}


def side_by_side(terrains: list, world_size: int, together: bool) -> bool:
    """Whether :func:`validate_share` walks ``terrains`` side by side in one env: ``together`` asked, one process,
    more than one course, each named."""
    return together and world_size == 1 and len(terrains) > 1 and all(isinstance(t, str) for t in terrains)


def validate_share(cands: list[Candidate], controller: str, terrains: list, rounds: int, device: str | None,
                   max_steps: int, goal_distance: float | None = None, rank: int = 0,
                   world_size: int = 1, together: bool = False) -> dict[tuple[int, int], dict]:  # fmt: skip
    """:func:`validate` of this rank's :func:`validation_share`, course by course: {(course index, candidate index):
    result}. Each candidate walks ``rounds`` rounds of the validation seeds; a share of the candidates takes its own
    env of the same seeds (the rounds dealt differently among the candidates, as among those of one env).
    ``together`` (``AgentConfig.validation_together``): one process's courses (names) in one env instead
    (:func:`validate_together`)."""
    if side_by_side(terrains, world_size, together):
        return validate_together(cands, controller, terrains, rounds, device, max_steps, goal_distance)
    out = {}
    for course, idx in validation_share(len(cands), len(terrains), rank, world_size).items():
        results = validate([cands[i] for i in idx], controller, terrains[course], rounds, device, max_steps,
                           goal_distance)  # fmt: skip
        out.update({(course, i): r for i, r in zip(idx, results)})
    return out


def combine_courses(cands: list[Candidate], terrains: list,
                    results: dict[tuple[int, int], dict]) -> tuple[list[dict], dict[str, list[dict]]]:  # fmt: skip
    """Each candidate's shares averaged over the courses, and each course's own results by its name, from the
    results of every (course, candidate) pair (:func:`validate_share` of every rank)."""
    per = {(t if isinstance(t, str) else t.name): [results[(c, i)] for i in range(len(cands))]
           for c, t in enumerate(terrains)}  # fmt: skip
    keys = ("goal", "walk_3m", "fell", "fell_before_goal", "off_course", "pitch_var", "roll_var")
    mean = [dict({k: float(np.mean([r[i][k] for r in per.values()])) for k in keys},
                 rounds=sum(r[i]["rounds"] for r in per.values())) for i in range(len(cands))]  # fmt: skip
    return mean, per


def course_names(names: list[str]) -> str:
    """``the complex course`` / ``the rugged and complex courses`` for the console."""
    return f"the {names[0]} course" if len(names) == 1 else f"the {', '.join(names[:-1])} and {names[-1]} courses"


def choose(cands: list[Candidate], results: list[dict], per_course: dict[str, list[dict]] | None = None,
           rank: str = "mean", fall_weight: float = 2.0) -> int:
    """The index of the result. ``rank`` "mean" (``results``: the shares averaged over the courses): the most goals,
    then the fewest falls before the goal line, then the later. "worst" (``per_course``: each course's results): the
    highest score goal - ``fall_weight`` x fell_before_goal on the worst course among those where some candidate
    misses a goal, then the highest such score averaged over them, then the later."""
    if rank == "mean":
        return max(range(len(cands)), key=lambda i: (results[i]["goal"], -results[i]["fell_before_goal"],
                                                      cands[i].iteration))  # fmt: skip
    if rank != "worst" or per_course is None:
        raise ValueError(f"validation rank must be 'mean' or 'worst' (with each course's results), got {rank!r}")
    scores = np.array([[r["goal"] - fall_weight * r["fell_before_goal"] for r in rows] for rows in per_course.values()])
    informative = ~np.all(np.array([[r["goal"] for r in rows] for rows in per_course.values()]) >= 1.0, axis=1)
    s = scores[informative] if informative.any() else scores
    return max(range(len(cands)), key=lambda i: (s[:, i].min(), s[:, i].mean(), cands[i].iteration))


def report_lines(cands: list[Candidate], results: list[dict], chosen: int) -> list[str]:
    """One console line per candidate, the chosen one marked."""
    return [f"  {'->' if i == chosen else '  '} {os.path.basename(c.path)} ({c.why}, iteration {c.iteration}): goal "
            f"{100 * r['goal']:.1f} %, fell before the goal {100 * r['fell_before_goal']:.1f} % (in all "
            f"{100 * r['fell']:.1f} %), " + (f"3 m {100 * r['walk_3m']:.1f} %, " if np.isfinite(r["walk_3m"]) else "")
            + f"off course {100 * r['off_course']:.1f} %, "
            f"pitch / roll var {r['pitch_var']:.1f} / {r['roll_var']:.1f} deg²"
            for i, (c, r) in enumerate(zip(cands, results))]  # fmt: skip
