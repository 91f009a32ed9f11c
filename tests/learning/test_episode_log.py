"""The deferred episode bookkeeping (``AgentConfig.deferred_episode_log``) against rsl-rl's own ``Logger``: the same
reward and length buffers, the same running sums and extras, and no host read per step."""

from collections import deque

import pytest
import torch
from rsl_rl.utils.logger import Logger

from hexnewton.learning.episode_log import DeferredEpisodes


def _logger(num_envs: int) -> Logger:
    lg = Logger(None, {"algorithm": {}}, {}, num_envs, False, 1, 0, "cpu")
    lg.writer = object()  # process_env_step books episodes only with a writer
    return lg


def test_the_same_buffers_as_rsl_rl():
    """Random rewards and ends over 3 iterations of 24 steps (several envs ending in one step, envs ending twice in
    one iteration): after each iteration's flush the buffers hold what rsl-rl's per-step bookkeeping holds, in its
    order, and the running sums agree at every step."""
    n, g = 37, torch.Generator().manual_seed(0)
    ours, theirs = _logger(n), _logger(n)
    ours.rewbuffer, theirs.rewbuffer = deque(maxlen=1000), deque(maxlen=1000)  # every episode, not only the last 100
    ours.lenbuffer, theirs.lenbuffer = deque(maxlen=1000), deque(maxlen=1000)
    book = DeferredEpisodes(ours)
    for _ in range(3):
        for _ in range(24):
            rewards = torch.randn(n, generator=g)
            dones = (torch.rand(n, generator=g) < 0.15).long()
            extras = {"log": {"x": torch.tensor(1.0)}}
            ours.process_env_step(rewards, dones, extras)
            theirs.process_env_step(rewards, dones, extras)
            torch.testing.assert_close(ours.cur_reward_sum, theirs.cur_reward_sum)
            torch.testing.assert_close(ours.cur_episode_length, theirs.cur_episode_length)
        book.flush()
        assert list(ours.lenbuffer) == list(theirs.lenbuffer) and len(theirs.lenbuffer) > 24
        assert list(ours.rewbuffer) == pytest.approx(list(theirs.rewbuffer), abs=0, rel=0)
    assert len(ours.ep_extras) == len(theirs.ep_extras) == 72
    book.flush()  # nothing since the last: nothing added
    assert len(ours.rewbuffer) == len(theirs.rewbuffer)


def test_no_host_read_per_step(monkeypatch):
    """The step's bookkeeping reads nothing back (no nonzero, no .cpu()); the flush reads once."""
    lg = _logger(8)
    book = DeferredEpisodes(lg)
    reads = []
    real_cpu = torch.Tensor.cpu
    monkeypatch.setattr(torch.Tensor, "cpu", lambda self, *a, **k: reads.append(1) or real_cpu(self, *a, **k))
    monkeypatch.setattr(torch.Tensor, "nonzero", lambda *a, **k: pytest.fail("nonzero in the step's bookkeeping"))
    for step in range(5):
        lg.process_env_step(torch.ones(8), torch.tensor([1, 0, 0, 0, 0, 0, 0, step % 2]), {})
    assert reads == []
    monkeypatch.undo()
    book.flush()
    assert list(lg.lenbuffer) == [1.0, 1.0, 2.0, 1.0, 1.0, 2.0, 1.0]  # env 0 every step, env 7 every other
    assert list(lg.rewbuffer) == list(lg.lenbuffer)


def test_without_a_writer_nothing_is_booked():
    lg = _logger(4)
    lg.writer = None
    book = DeferredEpisodes(lg)
    lg.process_env_step(torch.ones(4), torch.ones(4), {"log": {}})
    book.flush()
    assert not lg.rewbuffer and not lg.ep_extras and lg.cur_reward_sum.sum() == 0


def test_the_log_reads_the_iteration_s_episodes():
    """The logger's ``log`` (rsl-rl calls it once per iteration) sees the episodes of the steps before it."""
    lg, seen = _logger(3), []
    lg.log = lambda **kwargs: seen.append((kwargs, list(lg.lenbuffer)))  # stands in for rsl-rl's Logger.log
    DeferredEpisodes(lg)
    lg.process_env_step(torch.ones(3), torch.tensor([0, 1, 0]), {})
    lg.process_env_step(torch.ones(3), torch.tensor([1, 0, 1]), {})
    lg.log(it=0)
    assert seen == [({"it": 0}, [1.0, 2.0, 2.0])]
