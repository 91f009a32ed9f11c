"""rsl-rl's per-step episode bookkeeping without host syncs (``AgentConfig.deferred_episode_log``).

rsl-rl 5.5.1's ``Logger.process_env_step`` runs after every env step of the rollout. For the mean reward and episode
length it logs, it finds the finished envs with ``nonzero`` and copies their sums to the host (``.cpu()``) at once:
three host syncs per step, each of which makes the CPU wait for the step it has just launched, so the GPU idles
while the next step's policy inference and env launch are queued. :class:`DeferredEpisodes` keeps the same sums on
the device and notes each step's finished episodes there; :meth:`DeferredEpisodes.flush` (once per iteration, before
rsl-rl's ``Logger.log`` reads them) copies them to the host in one read and extends the logger's buffers with the
same values, in the same order (step by step, env by env), as rsl-rl's own bookkeeping would have. Nothing the
learner computes changes; what the logger writes is the same. The Logger's methods and buffers it uses are those of
``rsl_rl_private.py`` (checked against the pinned rsl-rl).
"""

from __future__ import annotations

import torch

from hexnewton.learning.rsl_rl_private import replace_logger_method


class DeferredEpisodes:
    """Installed on an rsl-rl ``Logger``: its ``process_env_step`` replaced, its ``log`` (once per iteration) preceded by
    :meth:`flush`."""

    def __init__(self, logger):
        self.logger = logger
        self._rsl_process = replace_logger_method(logger, "process_env_step", self.process_env_step)
        self._rsl_log = replace_logger_method(logger, "log", self.log)
        self._done: list[torch.Tensor] = []
        self._returns: list[torch.Tensor] = []
        self._lengths: list[torch.Tensor] = []

    def process_env_step(self, rewards: torch.Tensor, dones: torch.Tensor, extras: dict,
                         intrinsic_rewards: torch.Tensor | None = None) -> None:  # fmt: skip
        """As rsl-rl's, with the finished episodes' sums kept on the device (RND's intrinsic rewards: rsl-rl's own)."""
        lg = self.logger
        if lg.writer is None:
            return
        if intrinsic_rewards is not None:
            self._rsl_process(rewards, dones, extras, intrinsic_rewards)
            return
        if "episode" in extras:
            lg.ep_extras.append(extras["episode"])
        elif "log" in extras:
            lg.ep_extras.append(extras["log"])
        lg.cur_reward_sum += rewards
        lg.cur_episode_length += 1
        done = dones > 0
        self._done.append(done)
        self._returns.append(lg.cur_reward_sum.clone())
        self._lengths.append(lg.cur_episode_length.clone())
        lg.cur_reward_sum.masked_fill_(done, 0.0)
        lg.cur_episode_length.masked_fill_(done, 0.0)

    def log(self, *args, **kwargs):
        """rsl-rl's ``Logger.log`` after :meth:`flush`."""
        self.flush()
        return self._rsl_log(*args, **kwargs)

    def flush(self) -> None:
        """The episodes finished since the last flush into the logger's reward and length buffers (one host read)."""
        if not self._done:
            return
        done = torch.stack(self._done)
        values = torch.stack([torch.stack(self._returns), torch.stack(self._lengths)])[:, done].cpu()
        self.logger.rewbuffer.extend(values[0].tolist())
        self.logger.lenbuffer.extend(values[1].tolist())
        self._done.clear()
        self._returns.clear()
        self._lengths.clear()
