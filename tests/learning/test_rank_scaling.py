"""``--agent.scale_with_ranks`` (AgentConfig.for_ranks): what each of K torchrun ranks trains with."""

from dataclasses import replace

import pytest

from hexnewton.learning.agent import AgentConfig, AlgorithmConfig, paper_agent
from hexnewton.tasks import task


def test_scaling_with_ranks():
    agent = task("complex").agent
    assert agent.for_ranks(4) is agent  # rsl-rl's way: every rank runs the config as it is
    both = replace(agent, scale_with_ranks=("mini_batches", "iterations"))
    assert both.for_ranks(1) is both
    four = both.for_ranks(4)
    assert four.max_iterations == 75 and [s for s, _ in four.stages] == [25, 50] and four.save_interval == 13
    assert [c for _, c in four.stages] == [c for _, c in agent.stages]
    assert four.algorithm.num_mini_batches == 4 * agent.algorithm.num_mini_batches
    assert four.algorithm.learning_rate == agent.algorithm.learning_rate
    three = replace(agent, max_iterations=301, scale_with_ranks=("iterations",)).for_ranks(3)
    assert three.max_iterations == 101  # rounded up: at least the env-steps of one process
    # a mini-batch size (the paper's 512 samples) is per rank: K ranks take 512 / K each
    paper = replace(paper_agent(), scale_with_ranks=("mini_batches", "learning_rate"))
    paper.check()
    two = paper.for_ranks(2)
    assert two.algorithm.mini_batch_size == 256 and two.algorithm.learning_rate == pytest.approx(2e-4)
    assert two.to_rsl_rl(4096)["algorithm"]["num_mini_batches"] == 2 * paper.to_rsl_rl(4096)["algorithm"]["num_mini_batches"]


def test_learning_rate_scaling_needs_the_fixed_schedule():
    bad = AgentConfig(scale_with_ranks=("learning_rate",), algorithm=AlgorithmConfig(schedule="adaptive"))
    with pytest.raises(ValueError, match="schedule fixed"):
        bad.check()
    with pytest.raises(ValueError, match="not one of"):
        AgentConfig(scale_with_ranks=("epochs",)).check()
