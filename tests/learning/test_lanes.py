"""What training saw of its curriculum (hexnewton/learning/lanes.py): shares per lane, per stage and per lane group
from the env's counts, the console part, TensorBoard scalars, the summary and the end line; bad values of the
curriculum's and validation's new fields give one error line."""

from types import SimpleNamespace

import numpy as np
import pytest

from hexnewton.config import RobotConfig, TerrainConfig
from hexnewton.learning.agent import AgentConfig
from hexnewton.learning.lanes import TOO_FEW, LaneLog, shares


class FakeEnv:
    """The two host reads LaneLog makes, over counts the test sets."""

    def __init__(self, groups=("complex",), levels=4, num_envs=8, robot=None):
        self.cfg = SimpleNamespace(terrain=TerrainConfig(name=groups[0], levels=levels, lane_courses=tuple(groups[1:])),
                                   robot=robot or RobotConfig())
        self.lane_groups, self.num_envs = groups, num_envs
        self.counts = np.zeros((len(groups), levels, 2), np.int64)
        self.levels = np.zeros((num_envs, 2), np.int64)
        self.levels[:, 1] = np.arange(num_envs) % len(groups)

    def lane_counts(self):
        return self.counts.copy()

    def lane_levels(self):
        return self.levels.copy()


def test_shares_and_stages():
    env = FakeEnv()
    log = LaneLog(env)
    env.counts[0, :, 0] = [10, 6, 3, 1]  # the first stage: 20 episodes, 1 on the top lane
    log.update()
    assert log.line() == "  top lane 5% of 20 ep  2.5 ep/robot"
    log.new_stage(1, 200)
    env.counts[0, :, 0] += [0, 2, 3, 5]  # the last stage: 10 episodes, half on the top lane
    env.counts[0, 3, 1] = 4
    env.levels[:, 0] = [3, 3, 2, 2, 1, 1, 0, 3]
    log.update()
    np.testing.assert_allclose(shares(log.stage_counts()), [0.0, 0.2, 0.3, 0.5])
    s = log.scalars()
    assert s["Curriculum/stage_top_lane_share"] == 0.5 and s["Curriculum/iteration_top_lane_share"] == 0.5
    assert s["Curriculum/episodes_per_robot"] == 30 / 8
    summary = log.summary()
    assert summary["last_stage"]["first_iteration"] == 200 and summary["last_stage"]["episodes"] == 10
    assert summary["last_stage"]["lanes_top_first"][0] == {"lane": 3, "episodes": 5, "successes": 4, "share": 0.5}
    assert summary["run"]["top_lane_share"] == 6 / 30 and summary["mean_level_end"] == 15 / 8
    assert "50.0% on the top lane" in log.verdict() and "below" not in log.verdict()


def test_a_last_stage_below_the_target_says_so_and_groups_apart():
    env = FakeEnv(groups=("complex", "rugged"))
    log = LaneLog(env)
    env.counts[0, :, 0] = [5, 5, 5, 0]
    env.counts[1, :, 0] = [0, 0, 9, 1]
    log.update()
    s = log.scalars()
    assert s["Curriculum/complex/stage_top_lane_share"] == 0.0 and s["Curriculum/rugged/stage_top_lane_share"] == 0.1
    assert log.summary()["per_group"]["rugged"]["last_stage"]["episodes"] == 10
    assert shares(log.stage_counts())[-1] < TOO_FEW and "below 10%" in log.verdict()
    assert np.isnan(shares(np.zeros((1, 4, 2)))).all()


@pytest.mark.parametrize("weight", [-1.0, float("inf"), float("nan")])
def test_bad_fall_weight(weight):
    with pytest.raises(ValueError, match="validation_fall_weight must be a finite number >= 0"):
        AgentConfig(validation_fall_weight=weight).check()


def test_a_run_cut_by_its_time_cap_or_reaching_nothing_says_so_last():
    from hexnewton.apps.train import closing_line

    agent = AgentConfig(max_minutes=7.0, max_iterations=1500)
    line = closing_line("the --max_minutes limit", 378, agent, None)
    assert line.startswith("stopped by its time cap, --agent.max_minutes 7, at iteration 378 of 1499")
    validation = {"rounds": 8, "chosen": "b.pt",
                  "candidates": [{"path": "a.pt", "goal": 0.5}, {"path": "b.pt", "goal": 0.0}]}
    assert "reaches the goal in 0 of its 8 validation rounds" in closing_line("300 iterations", 299, agent, validation)
    validation["chosen"] = "a.pt"
    assert closing_line("300 iterations", 299, agent, validation) is None


def test_hardest_lane_in_leg_lengths():
    """The top lane's heights in metres and in the robot's leg lengths: the complex course's 6 cm blocks and rises are
    0.23 of the paper robot's 0.26 m leg and 0.14 of the MX-Phoenix's 0.41 m one; past the course, the hardest_*."""
    from hexnewton.robot.registry import ROBOTS

    h = LaneLog(FakeEnv()).hardest()
    assert h["leg_length_m"] == pytest.approx(0.26)
    assert h["complex"]["step_rise_m"] == pytest.approx(0.06) and h["complex"]["block_height_legs"] == pytest.approx(
        0.06 / 0.26)
    mx = LaneLog(FakeEnv(("rugged", "stepped"), robot=ROBOTS["mx_phoenix"]))
    h = mx.hardest()
    assert set(h["rugged"]) == {"block_height_m", "block_height_legs"} and "step_rise_legs" in h["stepped"]
    assert h["stepped"]["step_rise_legs"] == pytest.approx(0.06 / 0.414)
    assert "stepped 6 cm rises (0.14 leg)" in mx.verdict() and "(leg length 0.414 m)" in mx.verdict()
    assert mx.summary()["hardest_lane"] == h
