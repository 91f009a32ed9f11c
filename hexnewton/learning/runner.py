"""Training on top of rsl-rl: :class:`HexRunner`, an ``OnPolicyRunner`` that saves hexnewton's metadata with every
checkpoint (atomically), keeps the best policy, runs the curriculum of reward weights and reflex gain, stops on a time
limit or a target success (every torchrun rank at the same iteration), prints one line per iteration and exports
the deterministic policy to ONNX at the end.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import io
import os
import random
import signal
import time

import numpy as np
from rsl_rl.runners import OnPolicyRunner

from hexnewton import startup
from hexnewton.learning.agent import apply_stage, stage_at
from hexnewton.learning.checkpoint import load_checkpoint, load_into_runner
from hexnewton.learning.episode_log import DeferredEpisodes
from hexnewton.learning.lanes import LaneLog
from hexnewton.learning.policy import export_onnx
from hexnewton.learning.progress import TimeLeft
from hexnewton.learning.ranks import Rank
from hexnewton.learning.rsl_rl_private import replace_logger_method, set_git_status_repos
from hexnewton.learning.stopping import TrainingStopped, catch_stop_signals


def progress_line(log_kwargs: dict, stats: dict, elapsed: float, goals: bool = False, lanes: str = "",
                  left: str = "") -> str:
    """One console line per iteration: the iteration, the last training episodes' outcome (``env.episode_stats()``;
    with ``goals``, random goals, the goals reached per episode in place of the success rate, which stays 0: reaching
    a goal sets the next one), the curriculum's mean level and ``lanes`` (``LaneLog.line``: the top lane's share of
    the stage's episodes, the episodes per robot), the iteration's time, the run's and ``left``
    (``TimeLeft.text``: the run's time left)."""
    it, total = log_kwargs.get("it", 0), log_kwargs.get("total_it", 0)
    step_s = log_kwargs.get("collect_time", 0.0) + log_kwargs.get("learn_time", 0.0)
    level = f"  level {stats['mean_level']:.1f}" if "mean_level" in stats else ""
    if not stats.get("episodes"):  # no episode has ended yet: nothing to rate
        outcome = "no episode ended yet"
    else:
        reached = f"goals {stats['goals_reached']:.2f}" if goals else f"success {stats['success_rate']:.3f}"
        outcome = (f"{reached}  fell {stats['fell_rate']:.3f}  off course "
                   f"{stats['off_course_rate']:.3f}  distance {stats['distance_m']:.2f} m")  # fmt: skip
    return (f"iteration {it}/{total - 1}  {outcome}{level}{lanes}  {step_s:.2f} s/it  "
            f"{datetime.timedelta(seconds=int(elapsed))}" + (f"  {left}" if left else ""))


def training_success(stats: dict, levels: int, goals: bool = False) -> float | None:
    """The success rate of the last training episodes (``env.episode_stats()``) once at least a quarter of the env's
    window (``stats["window"]`` episodes) are in (with a curriculum: played on the last level, the terrain itself);
    else None. With ``goals`` (random goals, ``TaskConfig.random_goals``: an episode ends on a fall or its time limit,
    never on a goal) the goals reached per episode."""
    key = "top_level_" if levels else ""
    if stats.get(f"{key}episodes", 0) < stats["window"] // 4:
        return None
    return float(stats["goals_reached" if goals else f"{key}success_rate"])


class BestCheckpoint:
    """Keeps ``model_best.pt``: the policy of the iteration whose last training episodes succeeded most often
    (:func:`training_success`), so that a run ends with a policy as good as its best even when its skill drifts
    down later (the flat CPU main job peaked at 0.945 near iteration 110 and ended at 0.869)."""

    def __init__(self, run_dir: str, levels: int, goals: bool = False):
        self.path, self.levels, self.goals = os.path.join(run_dir, "model_best.pt"), levels, goals
        # a new best must beat the old one by this much (no save every iteration on a plateau): 0.5 points of success,
        # or 0.02 goals per episode (an episode of the navigate tasks reaches ~3)
        self.margin = 0.02 if goals else 0.005
        self.measure = "goals per episode" if goals else "success"
        self.rate, self.iteration = None, None

    def reset(self) -> None:
        """Forget the best so far (a new curriculum stage trains under another objective)."""
        self.rate = self.iteration = None
        if os.path.exists(self.path):
            os.remove(self.path)

    def update(self, stats: dict, iteration: int, save) -> None:
        rate = training_success(stats, self.levels, self.goals)
        if rate is not None and (self.rate is None or rate >= self.rate + self.margin):
            save(self.path, infos={"best_goals" if self.goals else "best_success": rate})
            self.rate, self.iteration = rate, iteration


def stop_reason(time_up: bool, stats: dict, target: float | None, levels: int, reduce=None) -> str | None:
    """Why training should stop after this iteration (None: go on), decided at the iteration boundary so that
    every rank of a torchrun job stops at the same iteration. ``reduce`` sums a list over the ranks.
    ``stats`` (``env.episode_stats()``) is read only when there is a ``target``.

    With ``target``: the success rate over the last episodes of all ranks (a full window, ``stats["window"]`` episodes,
    per rank; with a curriculum, at least a quarter of it per rank on the last level, which is the terrain itself)."""
    window = stats["window"]
    key, need = ("top_level_", window // 4) if levels else ("", window)
    n = float(stats[f"{key}episodes"]) if target is not None else 0.0
    values = [float(time_up), stats[f"{key}success_rate"] * n if n else 0.0, n, 1.0]
    time_up, successes, n, ranks = reduce(values) if reduce else values
    if time_up:
        return "the --max_minutes limit"
    if target is not None and n >= need * ranks and successes / n >= target:
        where = " on the last level" if levels else ""
        return f"target success{where} {successes / n:.3f} >= {target}"
    return None


def _sum_over_ranks(device: str):
    import torch
    import torch.distributed as td

    def reduce(values: list[float]) -> list[float]:
        t = torch.tensor(values, dtype=torch.float64, device=device)
        td.all_reduce(t)  # NCCL: one small collective per iteration
        return t.tolist()

    return reduce


def init_group(rank: Rank, device: str) -> None:
    """Open this torchrun job's process group once (NCCL on ``cuda:LOCAL_RANK``, Gloo on the CPU) and make
    ``cuda:LOCAL_RANK`` the current device; nothing for a run of one process."""
    import torch
    import torch.distributed as td

    if rank.world_size <= 1:
        return
    cuda = str(device).startswith("cuda")
    if not td.is_initialized():
        td.init_process_group(backend="nccl" if cuda else "gloo", rank=rank.rank, world_size=rank.world_size)
    if cuda:
        torch.cuda.set_device(rank.local_rank)


def barrier() -> None:
    """Wait for every rank of the open process group (nothing without one)."""
    import torch.distributed as td

    if td.is_initialized():
        td.barrier()


def gather_floats(values: list[float], device: str) -> list[list[float]]:
    """Every rank's ``values`` (the same length on each), in rank order, on every rank; ``[values]`` without a
    process group. Every rank must call it."""
    import torch
    import torch.distributed as td

    if not td.is_initialized():
        return [list(values)]
    mine = torch.tensor(values, dtype=torch.float64, device=device)
    out = [torch.empty_like(mine) for _ in range(td.get_world_size())]
    td.all_gather(out, mine)
    return [t.tolist() for t in out]


def share_objects(value, device: str) -> list:
    """Every rank's picklable ``value``, in rank order, on every rank (NCCL on the GPU, Gloo on the CPU); ``[value]``
    without a process group. Every rank must call it."""
    import torch.distributed as td

    if not td.is_initialized():
        return [value]
    out = [None] * td.get_world_size()
    td.all_gather_object(out, value)
    return out


def close_group() -> None:
    """Every rank at the end of a torchrun job: wait for the others, then close the process group (a process that
    exits with its Gloo group open can abort in the group's teardown)."""
    import torch.distributed as td

    if td.is_initialized():
        td.barrier()
        td.destroy_process_group()


def matmul_precision(tf32: bool) -> None:
    """``AgentConfig.tf32``: the networks' float32 matrix products on TF32 tensor cores ("high"), else in full float32
    ("highest", torch's default). Process-wide, as torch's setting is."""
    import torch

    torch.set_float32_matmul_precision("high" if tf32 else "highest")


def learner_settings(runner: OnPolicyRunner, agent) -> None:
    """What ``AgentConfig`` sets on an rsl-rl runner beyond its config dict: the finished episodes booked on the device
    (``deferred_episode_log``) and the networks' float32 matmul precision (``tf32``). :class:`HexRunner` and the
    bench's runner alike."""
    if agent.deferred_episode_log:
        DeferredEpisodes(runner.logger)  # its log flushes the iteration's episodes, then calls rsl-rl's
    matmul_precision(agent.tf32)


def seed_everything(seed: int) -> None:
    import torch

    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    if torch.cuda.is_available():
        torch.cuda.manual_seed_all(seed)


def check_log_dir(log_dir: str) -> None:
    """Fail before any simulation if runs could not be written under ``log_dir``."""
    path = os.path.abspath(log_dir)
    while not os.path.exists(path):
        path = os.path.dirname(path)
    if not os.path.isdir(path) or not os.access(path, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write runs under {log_dir}: {path} is not a writable directory")


class RankedRunner(OnPolicyRunner):
    """rsl-rl's ``OnPolicyRunner`` placed in a torchrun job by a :class:`Rank` (rank 0 of 1 without one) rather than by
    rsl-rl's own reading of the environment: NCCL on ``cuda:LOCAL_RANK``, Gloo on the CPU. ``train.py`` trains with
    :class:`HexRunner`, a subclass; ``hexnewton-bench``'s train mode times this one."""

    def __init__(self, env, train_cfg: dict, log_dir: str | None, device: str, rank: Rank = Rank()):
        self.rank = rank  # before rsl-rl's set-up, which calls _configure_multi_gpu
        with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints both networks in full
            super().__init__(env, train_cfg, log_dir=log_dir, device=device)

    def _configure_multi_gpu(self) -> None:
        """rsl-rl's multi-process set-up (``cfg["multi_gpu"]``, ranks, the process group) from this run's
        :class:`Rank`, with the backend its device needs: NCCL on ``cuda:LOCAL_RANK``, Gloo on the CPU (rsl-rl 5.5.1
        itself always takes NCCL and CUDA)."""
        r = self.rank
        self.gpu_world_size, self.is_distributed = r.world_size, r.world_size > 1
        self.gpu_local_rank, self.gpu_global_rank = r.local_rank, r.rank
        if not self.is_distributed:
            self.cfg["multi_gpu"] = None
            return
        self.cfg["multi_gpu"] = {"global_rank": r.rank, "local_rank": r.local_rank, "world_size": r.world_size}
        cuda = str(self.device).startswith("cuda")
        if self.device != (f"cuda:{r.local_rank}" if cuda else "cpu"):
            raise ValueError(f"rank {r.rank} runs on cuda:{r.local_rank} or cpu, not on {self.device}")
        init_group(r, self.device)

    def leave_group(self) -> None:
        """Every rank at the end of a torchrun run: :func:`close_group`."""
        if self.is_distributed:
            close_group()

    def rank_spread(self) -> float:
        """The largest difference between any rank's actor and critic parameters and rank 0's (0 in a run of one
        process). Every rank must call it: it broadcasts and reduces."""
        if not self.is_distributed:
            return 0.0
        import torch
        import torch.distributed as td

        mine = torch.cat([p.detach().flatten() for m in (self.alg.actor, self.alg.critic) for p in m.parameters()])
        ref = mine.clone()
        td.broadcast(ref, src=0)
        spread = (mine - ref).abs().max().reshape(1)
        td.all_reduce(spread, op=td.ReduceOp.MAX)
        return float(spread)


class HexRunner(RankedRunner):
    """rsl-rl's ``OnPolicyRunner`` for a hexnewton task.

    ``meta`` (task, action mode, observation size, env and agent configs) goes into every checkpoint's
    ``infos["hexnewton"]``; saves go to a temporary file and are renamed. After every iteration (rsl-rl calls
    ``logger.log`` once per iteration, its only per-iteration hook) the runner prints :func:`progress_line`,
    keeps ``model_best.pt`` (:class:`BestCheckpoint`), enters the curriculum's next stage
    (``AgentConfig.stages``) and stops on ``max_minutes`` / ``target_success`` (:func:`stop_reason`)."""

    def __init__(self, env, agent, meta: dict, log_dir: str | None, device: str, rank: Rank = Rank()):
        train_cfg = agent.to_rsl_rl(env.num_envs, env.obs_groups)  # the critic reads every group the env emits
        super().__init__(env, train_cfg, log_dir=log_dir, device=device, rank=rank)
        # the run's git/ folder records hexnewton's commit and diff (rsl-rl's default looks for its own repo)
        set_git_status_repos(self.logger, [os.path.dirname(os.path.abspath(__file__))])
        self.agent, self.meta = agent, meta
        self.run_dir = log_dir
        self.levels = env.cfg.terrain.levels
        self.goals = env.cfg.task.random_goals
        self.best = BestCheckpoint(log_dir or "", self.levels, self.goals)
        self.lanes = LaneLog(env) if self.levels else None  # what training saw of its curriculum (learning/lanes.py)
        self._reduce = _sum_over_ranks(device) if rank.world_size > 1 else None
        learner_settings(self, agent)
        self._rsl_log = replace_logger_method(self.logger, "log", self._after_iteration)  # rsl_rl_private.py
        self._rsl_init_writer = replace_logger_method(self.logger, "init_logging_writer", self._init_writer)
        self._stage, self._time_up, self._t0 = None, False, time.time()
        self._actor_frozen_until = None  # --init: the iteration from which the loaded actor learns too
        self._left = TimeLeft(0)  # the run's time left (train() sets its iterations and time cap)
        self.first_iteration_s = None  # seconds from the process's start to the end of the first iteration
        startup.mark("runner")

    # -------------------------------------------------------------- checkpoints
    def save(self, path: str, infos: dict | None = None) -> None:
        """Checkpoint with hexnewton metadata, written to a temporary file and renamed (atomic)."""
        super().save(path + ".tmp", infos={"hexnewton": self.meta, **(infos or {})})
        os.replace(path + ".tmp", path)

    def load(self, path: str, load_cfg: dict | None = None, strict: bool = True, map_location=None) -> dict:
        """Read ``path`` as data only (:func:`~hexnewton.learning.checkpoint.load_checkpoint`) and load it: the models and,
        with ``load_cfg`` None, the optimiser and iteration (rsl-rl's own ``load`` unpickles with
        ``weights_only=False``)."""
        ckpt = load_checkpoint(path, map_location or "cpu")
        load_into_runner(self, ckpt, load_cfg)
        return ckpt.get("infos")

    def start_from(self, ckpt: dict, path: str) -> None:
        """``train.py --init``: the actor and its observation normaliser from ``ckpt`` (read from ``path``: another
        run's policy of the same observation and action shapes, networks and distribution), the critic anew; for
        ``agent.init_critic_iterations`` iterations the actor stays as loaded while the critic learns (one line for a
        checkpoint whose actor does not fit)."""
        try:
            self.alg.load(ckpt, {"actor": True}, True)
        except RuntimeError as exc:  # torch lists every key and shape that differs
            raise ValueError(f"--init {path}: its actor does not fit this run's ({str(exc).splitlines()[0][:160]}): "
                             "the same --agent.model and --agent.distribution as it was trained with") from None
        n = self.agent.init_critic_iterations
        self._actor_frozen_until = self.current_learning_iteration + n
        self.freeze_actor(n > 0)
        if self.rank.is_main:
            first = f"the critic learns alone for {n} iterations, then both" if n else "actor and critic learn at once"
            print(f"started from {path}: its actor and observation normaliser, a new critic; {first}", flush=True)

    def freeze_actor(self, frozen: bool) -> None:
        """The actor's parameters and observation normaliser kept as they are (``frozen``), or learning again."""
        actor = self.alg.get_policy()
        for p in actor.parameters():
            p.requires_grad_(not frozen)
        normalizer = getattr(actor, "obs_normalizer", None)
        if hasattr(normalizer, "until"):  # rsl-rl's EmpiricalNormalization learns until ``count`` reaches ``until``
            normalizer.until = int(normalizer.count) if frozen else None

    def export(self, path: str) -> float:
        """The deterministic policy as ONNX (:func:`~hexnewton.learning.policy.export_onnx`); returns the largest
        |onnxruntime - torch| difference, RuntimeError above 1e-4."""
        err = export_onnx(self.alg.get_policy(), self.env.num_obs, path)
        if err > 1e-4:
            raise RuntimeError(f"ONNX export differs from torch by {err}")
        return err

    def _init_writer(self) -> None:
        """rsl-rl's writer, without its "Storing git diff ..." console line (the diff is in the run's git/ folder)."""
        with contextlib.redirect_stdout(io.StringIO()):
            self._rsl_init_writer()

    # -------------------------------------------------------------- per iteration
    def _after_iteration(self, *args, **kwargs) -> None:
        """rsl-rl's 30-line block goes to TensorBoard only; the console gets :func:`progress_line`."""
        with contextlib.redirect_stdout(io.StringIO()):
            self._rsl_log(*args, **kwargs)
        stats = self.env.episode_stats()
        if self.first_iteration_s is None:
            startup.mark("first iteration")
            self.first_iteration_s = startup.since_start()
            if self.rank.is_main:
                print(startup.summary(), flush=True)
        lanes = ""
        if self.lanes is not None:
            self.lanes.update()
            lanes = self.lanes.line()
            if self.rank.is_main and self.logger.writer is not None:
                for tag, value in self.lanes.scalars().items():
                    self.logger.writer.add_scalar(tag, value, self.current_learning_iteration)
        if self.rank.is_main:
            self._left.update(kwargs.get("it", 0) - kwargs.get("start_it", 0) + 1)
            print(progress_line(kwargs, stats, time.time() - self._t0, self.goals, lanes, self._left.text()),
                  flush=True)
            self.best.update(stats, self.current_learning_iteration, self.save)
        reason = stop_reason(self._time_up, stats, self.agent.target_success, self.levels, self._reduce)
        if reason:
            raise TrainingStopped(reason)
        self.enter_stage(self.current_learning_iteration + 1)
        if self._actor_frozen_until is not None and self.current_learning_iteration + 1 >= self._actor_frozen_until:
            self.freeze_actor(False)
            self._actor_frozen_until = None
            if self.rank.is_main:
                print(f"iteration {self.current_learning_iteration + 1}: the actor learns from here on", flush=True)

    def enter_stage(self, iteration: int) -> None:
        """The curriculum: from its first iteration on, a stage's reflex gain, reward weights, PPO settings and
        physics (with those of the stages before it). The best checkpoint is chosen within the last stage begun."""
        stages = self.agent.stages
        index, changes = stage_at(stages, iteration)
        if index < 0 or index == self._stage:
            return
        self._stage = index
        algorithm, line = apply_stage(self.env, changes)
        for name, value in algorithm.items():
            setattr(self.alg, name, value)
            if name == "learning_rate":
                for group in self.alg.optimizer.param_groups:
                    group["lr"] = value
        self.meta["config"] = dataclasses.asdict(self.env.cfg)  # checkpoints carry the gain they run with
        self.best.reset()
        if self.lanes is not None:
            self.lanes.new_stage(index + 1, iteration)
        if self.rank.is_main:
            print(f"iteration {iteration}: curriculum stage {index + 2} of {len(stages) + 1}: {line}", flush=True)

    # -------------------------------------------------------------- the run
    def train(self, iterations: int) -> str:
        """Learn for ``iterations`` iterations from the current one, or until a stop rule, Ctrl-C or SIGTERM;
        save what was learnt in every case. Returns why it ended."""
        self.enter_stage(self.current_learning_iteration)
        self._t0 = time.time()
        self._left = TimeLeft(iterations, 60.0 * self.agent.max_minutes if self.agent.max_minutes else None)
        handlers = catch_stop_signals()
        handlers[signal.SIGALRM] = signal.signal(signal.SIGALRM, lambda *_: setattr(self, "_time_up", True))
        if self.agent.max_minutes:
            signal.setitimer(signal.ITIMER_REAL, 60.0 * self.agent.max_minutes)
        reason = f"{iterations} iterations"
        try:
            self.learn(iterations, init_at_random_ep_len=True)
        except TrainingStopped as stop:  # rsl-rl only saves at intervals and at the end
            signal.setitimer(signal.ITIMER_REAL, 0)
            reason, it = str(stop), self.current_learning_iteration
            if self.rank.is_main:
                print(f"stopped by {stop} after iteration {it}: saving model_{it}.pt")
                self.save(os.path.join(self.run_dir, f"model_{it}.pt"))
                self.logger.stop_logging_writer()
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            for sig, handler in handlers.items():
                signal.signal(sig, handler)
            if hasattr(self.logger.writer, "flush"):
                self.logger.writer.flush()  # TensorBoard otherwise writes every 120 s
        return reason

    def final_policy(self) -> str:
        """Load the policy to ship into the actor and return its checkpoint: the best iteration's when it is not
        the last one (the skill may drift down late in a run), else the last."""
        last = os.path.join(self.run_dir, f"model_{self.current_learning_iteration}.pt")
        if self.best.iteration is None or self.best.iteration == self.current_learning_iteration:
            return last
        self.load(self.best.path, {"actor": True}, map_location=self.device)
        return self.best.path
