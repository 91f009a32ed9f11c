"""The curriculum stages (``AgentConfig.stages``): which stage an iteration is in, what a stage may change (the reflex
gain, reward weights, PPO settings) and the one-line errors for what it may not."""

from dataclasses import replace

import pytest

from hexnewton.learning.agent import AgentConfig, AlgorithmConfig, split_stage_changes, stage_at, stage_line
from hexnewton.learning.baselines.trainer import BaselineTrainer, stage_changes
from hexnewton.tasks import task

STAGES = ((100, {"posture_reflex": 2.0, "w_tilt": 15.0}), (200, {"w_tilt": 40.0, "desired_kl": 0.005}))


def test_a_stage_holds_its_changes_and_those_before_it():
    assert stage_at(STAGES, 99) == (-1, {})
    assert stage_at(STAGES, 100) == (0, {"posture_reflex": 2.0, "w_tilt": 15.0})
    assert stage_at(STAGES, 250) == (1, {"posture_reflex": 2.0, "w_tilt": 40.0, "desired_kl": 0.005})
    # the baselines count env-steps per env: a stage beginning at iteration i begins at i x steps per iteration
    assert stage_changes(STAGES, 200 * 24 - 1, 24)[0] == 0 and stage_changes(STAGES, 200 * 24, 24)[0] == 1
    assert split_stage_changes(stage_at(STAGES, 250)[1]) == (2.0, {"w_tilt": 40.0}, {"desired_kl": 0.005}, {})
    assert split_stage_changes({"w_tilt": 1.0, "effort_clamp": "actuator"}) == (None, {"w_tilt": 1.0}, {},
                                                                                 {"effort_clamp": "actuator"})
    assert stage_line({"w_tilt": 40.0, "desired_kl": 0.005, "effort_clamp": "actuator"}) == \
        "w_tilt 40, desired_kl 0.005, effort_clamp actuator"


def test_stage_fields_are_checked_before_training():
    AgentConfig(stages=STAGES).check()
    AgentConfig(stages=((300, {"effort_clamp": "actuator"}),)).check()
    task("complex").agent.check()
    bad = [({"w_tilts": 1.0}, "w_tilts is none of posture_reflex"), ({"entropy_coef": -0.1}, "must be numbers >= 0"),
           ({"learning_rate": "fast"}, "must be numbers >= 0"),
           ({"effort_clamp": "joint"}, "effort_clamp 'joint': a stage may set it to actuator")]
    for changes, message in bad:
        with pytest.raises(ValueError, match=message):
            AgentConfig(stages=((10, changes),)).check()
    fixed = AgentConfig(stages=STAGES, algorithm=AlgorithmConfig(schedule="fixed"))
    with pytest.raises(ValueError, match="desired_kl needs the adaptive schedule"):
        fixed.check()


def test_a_stage_learning_rate_scales_with_the_ranks_as_the_rate_does():
    agent = AgentConfig(stages=((2, {"learning_rate": 5e-4, "w_tilt": 3.0}),), scale_with_ranks=("learning_rate",),
                        algorithm=AlgorithmConfig(schedule="fixed"))  # fmt: skip
    two = agent.for_ranks(2)
    assert two.stages == ((2, {"learning_rate": 1e-3, "w_tilt": 3.0}),)
    assert replace(agent, scale_with_ranks=()).for_ranks(2).stages == agent.stages


def test_the_baselines_take_no_ppo_settings_from_stages():
    with pytest.raises(ValueError, match="desired_kl is one of train.py's PPO settings"):
        BaselineTrainer(None, None, "sac", None, {}, "", stages=STAGES)


def test_pure_drl_takes_the_reward_part_of_the_stages_and_refuses_the_reflex(capsys):
    """complex-joint-staged: the complex recipe's stages at the same iterations, without the CPG's levelling reflex;
    train.py refuses a reflex stage in joint mode (one line, before anything is built)."""
    from hexnewton.apps.cli import run
    from hexnewton.apps.train import main
    from hexnewton.tasks import STABLE_STAGES

    staged = task("complex-joint-staged")
    assert staged.action_mode == "joint" and staged.env == task("complex-joint").env
    assert [start for start, _ in staged.agent.stages] == [start for start, _ in STABLE_STAGES]
    for (_, mine), (_, theirs) in zip(staged.agent.stages, STABLE_STAGES):
        assert "posture_reflex" not in mine and mine == {k: v for k, v in theirs.items() if k != "posture_reflex"}
    argv = ["--task", "complex-joint", "--agent.stages", "((1, {'posture_reflex': 2.0}),)", "--device", "cpu"]
    assert run(main, "train.py", argv) == 2
    err = capsys.readouterr().err
    assert "posture_reflex is the CPG's levelling reflex" in err and len(err.strip().splitlines()) == 1
