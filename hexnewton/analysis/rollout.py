"""Rollouts of a controller in the batched env: step by step (:func:`stepped`), with first-episode statistics
(:func:`rollout`, ``play.py``), recorded (:class:`Recorder`), and the evaluation's rounds (:func:`run_rounds`:
one robot per round on unseen seeds, the arrays behind every metric and figure).
"""

from __future__ import annotations

import typing
from dataclasses import dataclass

import numpy as np

from hexnewton.analysis.metrics import first_episode_stats
from hexnewton.config import JOINT_NAMES, PARAM_NAMES, HexConfig, RandomizationConfig
from hexnewton.mdp.status import SUCCESS
from hexnewton.kernels.reference import quat_rotate_inv_np

EVAL_TERRAIN_SEED = 1000
EVAL_RESET_SEED = 2000
START_SEED_OFFSET = EVAL_RESET_SEED - EVAL_TERRAIN_SEED  # --seed S: terrain seed S, start seed S + 1000
# controller -> env action mode; *_cpg are the skrl baselines (hexnewton.learning.baselines)
CONTROLLERS = {"cpg": "cpg", "cpg_swept": "cpg", "cpg_rl": "cpg", "joint": "joint", "sac_cpg": "cpg", "td3_cpg": "cpg",
               "a2c_cpg": "cpg"}  # fmt: skip
FIXED = {"cpg": "default", "cpg_swept": "swept"}  # fixed-parameter controllers -> config.FIXED_GAITS
LABELS = {"cpg": "CPG", "cpg_swept": "CPG (swept)", "cpg_rl": "CPG_RL", "joint": "pure DRL", "sac_cpg": "SAC-CPG",
          "td3_cpg": "TD3-CPG", "a2c_cpg": "A2C-CPG", "paper": "CPG_RL (task paper)"}  # fmt: skip
#: Named perturbations beyond the training ranges (RandomizationConfig: friction 0.4-1.2, payload -0.2..0.6 kg,
#: gains and effort x0.8-1.2, half the envs 20 ms late, pushes of 0.3 m/s every 6 s; 6 cm steps and blocks). Each
#: changes one thing; everything else is the nominal robot. Values: (RandomizationConfig fields, TerrainConfig fields).
_NOMINAL = dict(friction=(0.9, 0.9), payload=(0.0, 0.0), link_mass_scale=(1.0, 1.0), kp_scale=(1.0, 1.0),
                kd_scale=(1.0, 1.0), effort_scale=(1.0, 1.0), latency_share=0.0, noise_joint_pos=0.0,
                noise_joint_vel=0.0, noise_target=0.0, noise_quat=0.0, noise_height=0.0, noise_gyro=0.0,
                push_velocity=0.0, foot_radius=None, contact_timeconst=None, motor_strength=None)
#: the RandomizationConfig fields that are per-env ranges (a sweep point sets such a field to (value, value))
_RANGES = {name for name, hint in typing.get_type_hints(RandomizationConfig).items()
           if tuple in (typing.get_origin(hint), *map(typing.get_origin, typing.get_args(hint)))}
PERTURBATIONS = {
    "nominal": ({}, {}),
    "friction_0.3": ({"friction": (0.3, 0.3)}, {}),
    "payload_0.8kg": ({"payload": (0.8, 0.8)}, {}),
    "motors_0.6": ({"kp_scale": (0.6, 0.6), "effort_scale": (0.6, 0.6)}, {}),
    "push_0.6m/s": ({"push_velocity": 0.6, "push_interval": 3.0}, {}),
    "latency_40ms": ({"latency_share": 1.0}, {}),  # every env one control step late, plus the 20 ms step itself
    "sensor_noise_x2": ({"noise_joint_pos": 0.02, "noise_joint_vel": 1.0, "noise_target": 0.1, "noise_quat": 0.04,
                         "noise_height": 0.02, "noise_gyro": 0.4}, {}),
    "steps_7cm": ({}, {"step_rise": 0.07}),
    "blocks_8cm": ({}, {"block_height_max": 0.08}),
}  # fmt: skip


#: Capability curves (``evaluate --sweep default``): (name, swept field, the course it is walked on, values). Each point
#: changes one thing from the nominal robot on that course; ``motor_strength`` scales the PD gains and the effort
#: limits together, ``push`` pushes every 3 s, ``action_delay`` makes every env's actions one control step late.
DEFAULT_SWEEPS = (
    ("step_rise", "terrain.step_rise", "stepped", (0.04, 0.06, 0.07, 0.08, 0.09, 0.10)),
    ("tread_depth", "terrain.step_depth", "stepped", (0.15, 0.18, 0.20, 0.22, 0.25)),
    ("block_height", "terrain.block_height_max", "rugged", (0.04, 0.06, 0.08, 0.10)),
    ("friction", "randomization.friction", "complex", (0.2, 0.3, 0.5, 0.9)),
    ("payload", "randomization.payload", "complex", (0.0, 0.5, 1.0, 1.5)),
    ("motor_strength", "motor_strength", "complex", (0.4, 0.5, 0.6, 0.8, 1.0)),
    ("push", "randomization.push_velocity", "complex", (0.0, 0.3, 0.6, 0.9)),
    ("action_delay", "randomization.latency_share", "complex", (0.0, 1.0)),
)  # fmt: skip


def sweep_overrides(field: str, value: float) -> dict:
    """The config overrides of one sweep point (``evaluate --sweep FIELD V ...``): ``field`` at ``value`` with
    everything else as in the course. A ``randomization.*`` field applies to every robot (a range becomes
    ``(value, value)``) with the nominal robot otherwise, as :func:`perturbation` does; ``motor_strength`` scales
    ``kp_scale`` and ``effort_scale`` together; any other HexConfig field is set as given."""
    if field == "motor_strength":
        rz = {"kp_scale": (value, value), "effort_scale": (value, value)}
    elif field.startswith("randomization."):
        key = field.split(".", 1)[1]
        rz = {key: (value, value) if key in _RANGES else value}
        if key == "push_velocity":
            rz["push_interval"] = 3.0
    else:
        return {field: value}
    return on_every_robot(rz)


def on_every_robot(rz: dict) -> dict:
    """``RandomizationConfig`` fields ``rz`` applied to every robot, the nominal robot otherwise, as overrides."""
    return {"randomization.enabled": True, **{f"randomization.{k}": v for k, v in {**_NOMINAL, **rz}.items()}}


def perturbation(name: str) -> dict:
    """A named perturbation (``PERTURBATIONS``) as config overrides for :func:`run_rounds`."""
    if name not in PERTURBATIONS:
        raise ValueError(f"unknown perturbation '{name}': choose from {', '.join(PERTURBATIONS)}")
    rz, terrain = PERTURBATIONS[name]
    out = {f"terrain.{k}": v for k, v in terrain.items()}
    if rz:
        out.update(on_every_robot(rz))
    return out
BASELINES = ("sac_cpg", "td3_cpg", "a2c_cpg")  # controllers trained by hexnewton.learning.baselines (skrl)


class Recorder:
    """Collects per-control-step arrays on the host; ``save(path)`` writes one ``.npz``.

    Keys: ``t`` (T,), ``joint_target``/``joint_pos`` (T, N, 18), ``base_pos``/``base_rpy`` (T, N, 3) (world frame;
    roll, pitch, yaw), ``cpg_xy`` (T, N, 2, 2) (oscillator, [x, y]), ``params`` (T, N, 15) (physical units),
    ``done`` (T, N) (that env's episode ended at this step; the next row starts a new one), ``joint_names``.
    A row holds the state at the end of the step, before a finished env is reset.
    """

    KEYS = ("t", "joint_target", "joint_pos", "base_pos", "base_rpy", "cpg_xy", "params", "done")

    def __init__(self):
        self.rows: dict[str, list[np.ndarray]] = {k: [] for k in self.KEYS}

    def add(self, env, t: float, q: np.ndarray, rpy: np.ndarray, done: np.ndarray) -> None:
        r = self.rows
        r["t"].append(np.float64(t))
        r["joint_target"].append(env.world.joint_target_wp.numpy()[:, 7:].copy())
        r["joint_pos"].append(q[:, 7:].copy())
        r["base_pos"].append(q[:, 0:3].copy())
        r["base_rpy"].append(rpy.copy())
        r["cpg_xy"].append(env.last_cpg_state.numpy().reshape(-1, 2, 2).copy())
        r["params"].append(env.last_params.numpy().copy())
        r["done"].append(done.copy())

    def save(self, path: str) -> None:
        arrays = {k: np.stack(v) for k, v in self.rows.items()}
        arrays["joint_names"] = np.array(JOINT_NAMES)
        np.savez_compressed(path, **arrays)


def progress_mode() -> bool | str:
    """How long work shows its progress: a bar on a terminal, else plain lines with the time left (a log file)."""
    import sys

    return True if sys.stderr.isatty() else "lines"


def duration(seconds: float) -> str:
    """``45 s``, ``6 min``, ``1.5 h`` for the console."""
    if seconds < 90:
        return f"{seconds:.0f} s"
    return f"{seconds / 60:.0f} min" if seconds < 5400 else f"{seconds / 3600:.1f} h"


def progress_lines(it: range, description: str, every: int = 10):
    """``it``, printing a line at each ``1 / every`` of it: the steps done, the seconds so far and at most how many
    are left (the rounds may all end sooner)."""
    import time

    from hexnewton.learning.progress import time_left

    t0, n = time.perf_counter(), len(it)
    marks = {max(1, round(n * j / every)) for j in range(1, every)}
    for k in it:
        yield k
        if k + 1 in marks:
            done = time.perf_counter() - t0
            print(f"{description}: {k + 1} of {n} control steps, {duration(done)}, at most "
                  f"{duration(time_left(k + 1, n, done))} left", flush=True)  # fmt: skip


def stepped(env, policy, steps: int, description: str, progress: bool | str = True):
    """Run ``policy(obs) -> actions`` for up to ``steps`` control steps (deterministic, no gradients); yield
    per step the host copies ``(k, status, q, pos, rpy)``: status codes (N,), the state before resets
    (N, 25), base position relative to each env's start (N, 3) and roll/pitch/yaw (N, 3). ``progress``: a bar
    (True), plain lines with the time left (``"lines"``, :func:`progress_lines`) or nothing (False)."""
    import torch

    it = range(steps)
    if progress == "lines":
        it = progress_lines(it, description)
    elif progress:
        from rich.progress import track

        it = track(it, description=description, transient=True)
    obs = env.get_observations()
    with torch.inference_mode():
        for k in it:
            obs, _, _, _ = env.step(policy(obs))
            q = env.last_q.numpy()
            pos = q[:, :3].copy()
            pos[:, :2] -= env.last_start.numpy()
            yield k, env.status.numpy(), q, pos, env.rpy.numpy().copy()


def goals_reached(env, status: np.ndarray) -> np.ndarray:
    """Each env's goals reached in the episode that this step's ``status`` ends or continues: the env's count, or where
    the last waypoint ended the episode (success; the env has been reset since), all of the course's goals."""
    return np.where(status == SUCCESS, env.goals.count, env.goals.reached.numpy())


def rollout(env, policy, steps: int, recorders: tuple = (), progress: bool = True) -> dict:
    """Run ``policy(obs) -> actions`` for up to ``steps`` control steps; returns first-episode statistics.
    Each of ``recorders`` gets every step. Without recorders, the rollout ends as soon as every env's first
    episode has (the statistics cover nothing else)."""
    n = env.num_envs
    pos = np.zeros((steps, n, 3), np.float32)
    rpy = np.zeros((steps, n, 3), np.float32)
    done = np.zeros((steps, n), bool)
    status_log = np.zeros((steps, n), np.int32)
    ended = np.zeros(n, bool)
    last = steps
    # goals to walk to (waypoints or random goals): each first episode's goals reached (the last waypoint's success)
    task, count = env.cfg.task, env.goals.count
    goals = np.zeros(n, np.int64) if (task.random_goals or count) else None
    for k, status, q, p, r in stepped(env, policy, steps, env.cfg.terrain.name, progress):
        pos[k], rpy[k], done[k], status_log[k] = p, r, status != 0, status
        for rec in recorders:
            rec.add(env, (k + 1) * env.cfg.task.control_dt, q, r, status != 0)
        if goals is not None:
            goals = np.where(ended, goals, goals_reached(env, status))
        ended |= status != 0
        if not recorders and ended.all():
            last = k + 1
            break
    env.world.check_contacts()
    stats = first_episode_stats(pos[:last], rpy[:last], done[:last], status_log[:last])
    stats["control_s"] = last * env.cfg.task.control_dt
    if goals is not None:
        stats.update(goals_mean=float(goals.mean()), goals_min=int(goals.min()), goals_of=count or None)
    return stats


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
    goal_line: float | None = None  # [m] ahead of the start: beyond it a round has passed its goal (distance + radius)


def controller_policy(env, controller: str, checkpoint: str | None = None, ckpt: dict | None = None,
                      stochastic: bool = False, expected: bool = False, fixed_params: np.ndarray | None = None):
    """``policy(obs) -> actions`` of ``controller`` in ``env``: a fixed gait's constant actions (``fixed_params``: one
    gait per env), a skrl baseline's or a trained rsl-rl policy's (``checkpoint``, already read as ``ckpt`` if given;
    deterministic unless ``stochastic``/``expected``)."""
    from hexnewton.learning.policy import fixed_cpg_actions, load_policy

    if controller in FIXED:
        actions = fixed_cpg_actions(env, FIXED[controller], fixed_params)
        return lambda obs: actions
    if controller in BASELINES:
        from hexnewton.learning.baselines import load_baseline_policy

        return load_baseline_policy(env, checkpoint, controller, stochastic, ckpt)
    return load_policy(env, checkpoint, CONTROLLERS[controller], stochastic, expected, ckpt)


def read_controller_checkpoint(controller: str, checkpoint: str | None) -> dict | None:
    """The checkpoint of a learnt ``controller`` (a skrl baseline's or an rsl-rl one) read as data only, with one-line
    errors for a missing or wrong file; None for a fixed gait."""
    if controller in BASELINES:
        from hexnewton.learning.baselines import load_baseline_checkpoint

        return load_baseline_checkpoint(checkpoint)
    if controller in ("cpg_rl", "joint"):
        from hexnewton.learning.checkpoint import load_checkpoint

        return load_checkpoint(checkpoint)
    return None


class RoundLog:
    """The host arrays of an :class:`Episode`, one control step at a time: positions, attitudes, ends and body rates of
    every round; in CPG mode round 0's parameters, every round's parameter change and, on the complex course (the
    blocks end at ``split_x``), the mean parameters on the blocks and on the stairs."""

    def __init__(self, cfg: HexConfig, rounds: int, action_mode: str, split_x: float | None = None):
        self.rounds, self.action_mode, self.split_x = rounds, action_mode, split_x
        self.lo, self.hi = (np.asarray(b, np.float64) for b in cfg.cpg.param_ranges())
        self.goal_line = cfg.task.goal_distance + cfg.task.goal_radius
        npar = cfg.cpg.num_params
        self.seg_sum, self.seg_n = {"blocks": np.zeros(npar), "stairs": np.zeros(npar)}, {"blocks": 0, "stairs": 0}
        self.pos, self.rpy, self.done, self.status, self.params = [], [], [], [], []
        self.ang_rate, self.dparam, self.daction = [], [], []
        self.finished = np.zeros(rounds, bool)
        self.prev_p = self.prev_t = None

    def change(self, now: np.ndarray, before: np.ndarray | None) -> np.ndarray:
        """Mean |change| of the CPG parameters (15, or 18 with the posture) since the last step, in fractions of
        their ranges (NaN at the start)."""
        if before is None:
            return np.full(self.rounds, np.nan, np.float32)
        return (np.abs(now - before) / (self.hi - self.lo)).mean(axis=1).astype(np.float32)

    def add(self, env, st: np.ndarray, q: np.ndarray, p: np.ndarray, r: np.ndarray) -> None:
        """One control step of :func:`stepped` (status, state, position, roll/pitch/yaw)."""
        self.pos.append(p[:, :2])
        self.rpy.append(r)
        self.done.append(st != 0)
        self.status.append(st.copy())
        qd = env.last_qd.numpy()
        self.ang_rate.append(quat_rotate_inv_np(q[:, 3:7], qd[:, 3:6])[:, :2].astype(np.float32))
        if self.action_mode == "cpg":
            pr, tg = env.last_params.numpy(), env.cpg.params_target.numpy()
            self.params.append(pr[0].copy())
            self.dparam.append(self.change(pr, self.prev_p))
            self.daction.append(self.change(tg, self.prev_t))
            self.prev_p, self.prev_t = pr.copy(), tg.copy()
            if self.split_x is not None:
                alive = ~self.finished
                for seg, sel in (("blocks", alive & (p[:, 0] < self.split_x)),
                                 ("stairs", alive & (p[:, 0] >= self.split_x))):  # fmt: skip
                    self.seg_sum[seg] += pr[sel].sum(axis=0)
                    self.seg_n[seg] += int(sel.sum())
        else:
            self.params.append(np.full(len(PARAM_NAMES), np.nan))
            self.dparam.append(np.full(self.rounds, np.nan, np.float32))
            self.daction.append(np.full(self.rounds, np.nan, np.float32))
        self.finished |= st != 0

    def episode(self, dt: float) -> Episode:
        """The steps so far as an :class:`Episode` (control period ``dt``)."""
        segments = {seg: (self.seg_sum[seg] / self.seg_n[seg]).tolist() for seg in self.seg_sum if self.seg_n[seg]}
        return Episode(np.stack(self.pos), np.stack(self.rpy), np.stack(self.done), np.stack(self.status),
                       np.stack(self.params), dt, np.stack(self.ang_rate), np.stack(self.dparam),
                       np.stack(self.daction), segments, self.goal_line)  # fmt: skip


def run_rounds(controller: str, checkpoint: str | None, terrain: str, rounds: int, device: str | None,
               max_steps: int, progress: bool = True, seed: int = EVAL_TERRAIN_SEED, overrides: dict | None = None,
               stochastic: bool = False, expected: bool = False, fixed_params: np.ndarray | None = None,
               robot=None) -> Episode:
    """``rounds`` robots, one first episode each, with a controller on unseen seeds: the course of ``terrain``
    (:func:`hexnewton.tasks.course`) with the policy's own robot, physics and CPG (from its checkpoint; a fixed
    controller on ``robot``, default the paper's; a policy of another robot than ``robot`` is one line), then
    ``overrides`` ({"terrain.step_rise": 0.07, "randomization.enabled": True, ...}: fields of the HexConfig tree; a
    named perturbation is such a dict). ``seed`` is the terrain seed; the start poses (and sampled actions) use ``seed +
    START_SEED_OFFSET``. ``stochastic``: a learnt policy samples its actions as in training; ``expected``: the
    expected clipped action of its Gaussian. ``fixed_params`` (N, 15) gives a fixed controller one gait per round
    (``studies/cpg_sweep/sweep.py``). ``cpg.posture_reflex`` in ``overrides`` gives a fixed gait the body posture at its
    neutral values with that reflex; a policy needs its own posture for it."""
    from hexnewton.learning.checkpoint import is_baseline_checkpoint, trained_config
    from hexnewton.mdp.env import make_env
    from hexnewton.robot.registry import check_robot, with_robot
    from hexnewton.tasks import course

    action_mode = CONTROLLERS[controller]
    ckpt = read_controller_checkpoint(controller, checkpoint)
    trained = trained_config(ckpt) if ckpt is not None else with_robot(HexConfig(), robot or HexConfig().robot)
    if ckpt is not None:
        check_robot(trained.robot, robot, checkpoint, init=not is_baseline_checkpoint(ckpt))
    overrides = dict(overrides or {})
    if "cpg.posture_reflex" in overrides and action_mode == "cpg":
        if controller not in FIXED and not trained.cpg.posture:
            raise ValueError(f"{checkpoint} has no body posture: a posture_reflex needs a policy trained with it")
        overrides["cpg.posture"] = True
    cfg = course(terrain, trained, overrides, rounds, device, seed, seed=seed + START_SEED_OFFSET)
    env = make_env(cfg, action_mode)
    policy = controller_policy(env, controller, checkpoint, ckpt, stochastic, expected, fixed_params)
    if stochastic:
        import torch

        torch.manual_seed(seed + START_SEED_OFFSET)
    log = RoundLog(cfg, rounds, action_mode, cfg.terrain.complex_rugged_length if terrain == "complex" else None)
    for _, st, q, p, r in stepped(env, policy, max_steps, f"{LABELS[controller]} on {terrain}", progress):
        log.add(env, st, q, p, r)
        if log.finished.all():
            break
    env.world.check_contacts()
    return log.episode(cfg.task.control_dt)
