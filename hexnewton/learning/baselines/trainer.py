"""The baselines' training loop: skrl's ``Trainer.train`` loop with the budget, the task's curriculum stages,
TensorBoard against env-steps, console lines and checkpoints."""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import time
from dataclasses import dataclass

from hexnewton.learning.agent import apply_stage, split_stage_changes, stage_at
from hexnewton.learning.baselines.checkpoint import save_checkpoint
from hexnewton.learning.baselines.config import BaselineConfig
from hexnewton.learning.baselines.env import wrap_env
from hexnewton.learning.progress import TimeLeft


@dataclass
class Budget:
    """When a run ends: ``env_steps`` over all envs or ``max_minutes`` of wall time, whichever comes first."""

    env_steps: int
    max_minutes: float | None = None


class EpisodeReturns:
    """Returns of finished episodes summed on the device (no host read per step); :meth:`take` reads and clears."""

    def __init__(self, num_envs: int, device):
        import torch

        self.ret = torch.zeros(num_envs, device=device)
        self.length = torch.zeros(num_envs, device=device)
        self.sums = torch.zeros(3, device=device)  # returns, lengths, episodes

    def add(self, rewards, ended) -> None:
        import torch

        self.ret += rewards.view(-1)
        self.length += 1.0
        e = ended.view(-1).float()
        self.sums += torch.stack([(self.ret * e).sum(), (self.length * e).sum(), e.sum()])
        self.ret *= 1.0 - e
        self.length *= 1.0 - e

    def take(self) -> tuple[float, float, int]:
        """(mean return, mean length, episodes) since the last call (NaN means when none ended)."""
        ret, length, n = self.sums.tolist()
        self.sums.zero_()
        return (ret / n, length / n, int(n)) if n else (float("nan"), float("nan"), 0)


def stage_changes(stages: tuple, env_step: int, steps_per_iteration: int) -> tuple[int, dict]:
    """(index, merged changes) of the task's curriculum stage that has begun by ``env_step`` steps of every env
    (a stage beginning at PPO iteration ``i`` begins at ``i x steps_per_iteration``); (-1, {}) before the first."""
    return stage_at(stages, env_step // steps_per_iteration)


class BaselineTrainer:
    """skrl's ``Trainer.train`` loop (pre-interaction, act, env step, record transition, post-interaction) for one
    agent on :func:`wrap_env`'s env, with the budget, the task's curriculum stages, TensorBoard against env-steps,
    one console line per log and checkpoints; Ctrl-C, SIGTERM and the time limit end it and save."""

    def __init__(self, env, agent, algo: str, cfg: BaselineConfig, meta: dict, run_dir: str, stages: tuple = (),
                 steps_per_iteration: int = 24):  # fmt: skip
        from skrl.trainers.torch import SequentialTrainerCfg

        ppo = [k for _, c in stages for k in split_stage_changes(c)[2]]
        if ppo:
            raise ValueError(f"stages: {ppo[0]} is one of train.py's PPO settings; the baselines' stages change the "
                             "reflex gain, reward weights and physics only")  # fmt: skip
        self.hex_env, self.env, self.agent, self.algo, self.cfg = env, wrap_env(env), agent, algo, cfg
        self.meta, self.run_dir = meta, run_dir
        self.stages, self.steps_per_iteration, self._stage = stages, steps_per_iteration, -1
        self._left: TimeLeft | None = None  # the run's time left (train() sets its vector steps and time cap)
        self.trainer_cfg = SequentialTrainerCfg(timesteps=1, headless=True, disable_progressbar=True,
                                                close_environment_at_exit=False)  # fmt: skip
        self.timestep = 0
        self.last_checkpoint: str | None = None

    @property
    def env_steps(self) -> int:
        return self.timestep * self.hex_env.num_envs

    def checkpoint(self) -> str:
        path = os.path.join(self.run_dir, f"model_{self.timestep}.pt")
        save_checkpoint(path, self.agent, self.meta, self.env_steps, self.timestep)
        self.last_checkpoint = path
        return path

    def enter_stage(self) -> None:
        index, changes = stage_changes(self.stages, self.timestep, self.steps_per_iteration)
        if index == self._stage:
            return
        self._stage = index
        _, line = apply_stage(self.hex_env, changes)  # no PPO fields: refused when the trainer was made
        self.meta["config"] = dataclasses.asdict(self.hex_env.cfg)
        print(f"step {self.timestep}: curriculum stage {index + 2} of {len(self.stages) + 1}: {line}", flush=True)

    def train(self, budget: Budget) -> str:
        """Train until the budget is spent; save and return why it ended."""
        import torch
        from torch.utils.tensorboard import SummaryWriter

        from hexnewton.learning.stopping import (  # the signal handling train.py's runner uses
            TrainingStopped,
            catch_stop_signals,
        )

        timesteps = max(1, math.ceil(budget.env_steps / self.hex_env.num_envs))
        self.trainer_cfg.timesteps = timesteps
        agent, env = self.agent, self.env
        agent.init(trainer_cfg=self.trainer_cfg)
        agent.enable_training_mode(True)
        writer = SummaryWriter(log_dir=self.run_dir)
        returns = EpisodeReturns(self.hex_env.num_envs, self.hex_env.device_torch)
        handlers = catch_stop_signals()
        t0 = time.monotonic()
        deadline = t0 + 60.0 * budget.max_minutes if budget.max_minutes else math.inf
        self._left = TimeLeft(timesteps, 60.0 * budget.max_minutes if budget.max_minutes else None)
        reason = f"{budget.env_steps} env-steps"
        obs, _ = env.reset()
        states = env.state()
        try:
            for t in range(timesteps):
                self.timestep = t
                if self.stages:
                    self.enter_stage()
                agent.pre_interaction(timestep=t, timesteps=timesteps)
                with torch.no_grad():
                    actions, _ = agent.act(obs, states, timestep=t, timesteps=timesteps)
                    next_obs, rewards, terminated, truncated, infos = env.step(actions)
                    next_states = env.state()
                    returns.add(rewards, terminated | truncated)  # before A2C adds its time-out bootstrap in place
                    agent.record_transition(observations=obs, states=states, actions=actions, rewards=rewards,
                                            next_observations=next_obs, next_states=next_states,
                                            terminated=terminated, truncated=truncated, infos=infos, timestep=t,
                                            timesteps=timesteps)  # fmt: skip
                agent.post_interaction(timestep=t, timesteps=timesteps)
                obs, states = next_obs, next_states
                self.timestep = t + 1
                if self.timestep % self.cfg.log_interval == 0:
                    self._log(writer, returns, infos["log"], time.monotonic() - t0)
                if self.timestep % self.cfg.save_interval == 0:
                    self.checkpoint()
                if time.monotonic() >= deadline:
                    reason = f"the --max_minutes limit ({budget.max_minutes:g} min)"
                    break
        except TrainingStopped as stop:
            reason = str(stop)
        finally:
            for sig, handler in handlers.items():
                signal.signal(sig, handler)
            if self.timestep % self.cfg.log_interval:
                self._log(writer, returns, self.hex_env._log(), time.monotonic() - t0)
            writer.close()
            self.wall_s = time.monotonic() - t0
            self.checkpoint()
        return reason

    def _log(self, writer, returns: EpisodeReturns, log: dict, elapsed: float) -> None:
        step = self.env_steps
        ret, length, episodes = returns.take()
        if episodes:
            writer.add_scalar("Train/mean_reward", ret, step)
            writer.add_scalar("Train/mean_episode_length", length, step)
        for key, value in log.items():
            writer.add_scalar(key, float(value), step)
        writer.add_scalar("Perf/wall_time_s", elapsed, step)
        writer.add_scalar("Perf/env_steps_per_s", step / max(elapsed, 1e-9), step)
        writer.flush()
        success = float(log["Episode/success_rate"]) if "Episode/success_rate" in log else float("nan")
        left = ""
        if self._left is not None:
            self._left.update(self.timestep)
            left = f"  {self._left.text()}" if self.timestep else ""
        print(f"step {self.timestep}  env-steps {step}  return {ret:.2f}  success {success:.3f}  "
              f"{step / max(elapsed, 1e-9):.0f} env-steps/s  {elapsed:.0f} s{left}", flush=True)  # fmt: skip
