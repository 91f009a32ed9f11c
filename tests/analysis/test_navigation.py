"""The navigation evaluation (hexnewton/analysis/navigation.py): the bearings' goals, the path metrics and summaries on
hand-made rounds, the fixed CPG's rounds in a CPU env (it walks straight: the goal ahead is reached, the one behind
not), the validation's shares, and ``evaluate --navigate``'s outputs."""

import dataclasses
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from hexnewton.analysis.navigation import (
    BEARINGS_DEG,
    SQUARE,
    bearing_goals,
    navigation_config,
    path_metrics,
    run_goals,
    summarize_bearings,
    summarize_square,
    validate_navigation,
)
from hexnewton.config import HexConfig
from hexnewton.mdp.status import FELL, SUCCESS, TIMEOUT

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def test_bearing_goals_and_path_metrics():
    """Round i's goal at 2 m and bearing BEARINGS_DEG[i % 8] in its start frame (grouped for interleaved
    candidates); a path's length over its steps and the straight line from the start to its end."""
    g = bearing_goals(16)[:, 0]
    np.testing.assert_allclose(np.hypot(g[:, 0], g[:, 1]), 2.0)
    np.testing.assert_allclose(np.degrees(np.arctan2(g[:8, 1], g[:8, 0])), [0, 45, -45, 90, -90, 135, -135, 180],
                               atol=1e-9)  # fmt: skip
    np.testing.assert_allclose(bearing_goals(16, group=2)[::2], bearing_goals(8))
    pos = np.full((4, 2, 2), np.nan)
    pos[:, 0] = [[1, 0], [1, 1], [2, 1], [2, 2]]  # 1 + 1 + 1 + 1 = 4 m walked, 2.83 m from the start
    pos[:2, 1] = [[0, -1], [0, -2]]  # ended after two steps
    length, straight = path_metrics(pos)
    np.testing.assert_allclose(length, [4.0, 2.0])
    np.testing.assert_allclose(straight, [math.sqrt(8), 2.0])


def test_summaries_of_hand_made_rounds():
    """Per bearing and over the targets' groups: the shares reached and fallen, the time and path ratio of the reached
    rounds; the square's completion, time and corners."""
    n = 16
    pos = np.zeros((3, n, 2))
    pos[:, :, 0] = [[0.5], [1.0], [1.5]]  # 1.5 m straight ahead: path / straight = 1
    end = np.full(n, TIMEOUT)
    end[[0, 8, 3]] = SUCCESS  # bearing 0 twice, bearing 90 once
    end[5] = FELL  # bearing 135
    run = {"pos": pos, "end": end, "steps": np.full(n, 3), "goals": np.zeros(n, np.int64), "dt": 0.02}
    s = summarize_bearings(run, n)
    assert s["per_bearing"]["0"]["reached"] == 1.0 and s["per_bearing"]["90"]["reached"] == 0.5
    assert s["per_bearing"]["135"]["fall_rate"] == 0.5 and s["per_bearing"]["0"]["time_s"] == pytest.approx(0.06)
    assert s["near"]["rounds"] == 10 and s["near"]["reached"] == pytest.approx(0.3)
    assert s["behind"]["rounds"] == 6 and s["behind"]["reached"] == 0.0 and s["behind"]["path_ratio"] is None
    assert s["all"]["path_ratio"] == pytest.approx(1.0) and s["all"]["timeouts"] == 12
    run["goals"] = np.array([4, 4, 2, 1] * 4)
    run["end"] = np.array([SUCCESS, SUCCESS, TIMEOUT, FELL] * 4)
    sq = summarize_square(run)
    assert sq["completed"] == 0.5 and sq["corners"] == pytest.approx(2.75) and sq["fall_rate"] == 0.25


@pytest.fixture(scope="module")
def fixed_cpg_env():
    from hexnewton.analysis.rollout import controller_policy
    from hexnewton.mdp.env import make_env

    cfg = navigation_config("flat", HexConfig(), 8, "cpu", 1000, 200)
    env = make_env(cfg, "cpg")
    return env, controller_policy(env, "cpg")


def test_fixed_cpg_reaches_the_goal_ahead_only(fixed_cpg_env):
    """The fixed CPG walks straight along its start heading: of goals 0.8 m away at the eight bearings it reaches the
    one ahead (0.3 m of walking) and none behind or beside; every start heading differs (reset_yaw pi); the paths are
    in the start frame (x along the start heading)."""
    env, policy = fixed_cpg_env
    assert env.cfg.task.reset_yaw == pytest.approx(math.pi) and "off_course" not in env.cfg.task.terminations
    run = run_goals(env, policy, bearing_goals(8, distance=0.8), 200)
    assert run["end"][0] == SUCCESS and (run["end"][[3, 4, 5, 6, 7]] == TIMEOUT).all()
    assert run["goals"][0] == 1 and run["steps"][0] < 200
    assert np.ptp(env.goals.start_yaw.numpy()) > 1.0
    ahead = run["pos"][run["steps"][0] - 1, 0]
    assert ahead[0] > 0.25 and abs(ahead[1]) < 0.1
    s = summarize_bearings(run, 8)
    assert s["per_bearing"]["0"]["reached"] == 1.0 and s["behind"]["reached"] == 0.0
    assert 1.0 <= s["per_bearing"]["0"]["path_ratio"] < 1.2


def test_square_and_validation_shares(fixed_cpg_env):
    """The square's waypoints reach the env in each start frame (its first corner 2 m ahead); the validation's shares
    per interleaved candidate."""
    env, policy = fixed_cpg_env
    run = run_goals(env, policy, np.asarray(SQUARE), 5)
    w = env.goals.waypoints_world()
    yaw = env.goals.start_yaw.numpy()
    np.testing.assert_allclose(w[:, 0] - env.start.numpy(), 2.0 * np.stack([np.cos(yaw), np.sin(yaw)], 1), atol=1e-5)
    assert (run["goals"] == 0).all() and (run["end"] == 0).all()
    env.cfg = dataclasses.replace(env.cfg, task=dataclasses.replace(env.cfg.task, max_episode_steps=5))
    shares, run = validate_navigation(env, policy, candidates=2)
    assert len(shares) == 2 and all(r["rounds"] == 4 and r["goal"] == 0.0 and r["fell"] == 0.0 for r in shares)
    assert all(np.isnan(r["walk_3m"]) for r in shares) and run["rpy"].shape == (5, 8, 3)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_evaluate_navigate_writes_its_report(tmp_path):
    """``evaluate --navigate``: one line per controller and terrain, report.md with the targets and both protocols'
    tables, results.json, the paths' figure; incompatible flags are one line."""
    out = tmp_path / "nav"
    cmd = [sys.executable, "-m", "hexnewton.apps.evaluate", "--navigate", "--controllers", "cpg", "--terrains", "flat",
           "--rounds", "1", "--max_steps", "20", "--device", "cpu", "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "flat     CPG      goals at 2 m: |b| <= 90 0%" in proc.stdout
    report = (out / "report.md").read_text()
    assert "## Targets" in report and "## flat: goals at 2 m" in report and "## flat: the 2 m square" in report
    data = json.loads((out / "results.json").read_text())
    r = data["results"]["flat"]["cpg"]
    assert set(r["bearings"]["per_bearing"]) == {str(b) for b in BEARINGS_DEG} and r["square"]["rounds"] == 1
    assert data["meta"]["max_steps (goal, square)"] == {"flat": [20, 20]} and (out / "fig_paths_flat_cpg.png").stat().st_size
    proc = subprocess.run(cmd[:4] + ["--sweep", "default", "--out", str(tmp_path / "x")], capture_output=True,
                          text=True, timeout=300, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 2 and "--navigate runs the navigation evaluation alone" in proc.stderr
