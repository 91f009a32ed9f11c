"""Sim2sim through waypoints (hexnewton/analysis/sim2sim.py, hexnewton/apps/sim2sim.py): C MuJoCo's episode ends toward a
goal in any direction are the MDP's float64 ones, a bundle walks a waypoint course through the runtime's goal, and the
command line's outputs and one-line errors."""

import json
import math
import os
import subprocess
import sys
from types import SimpleNamespace

import numpy as np
import pytest

from hexnewton.analysis.navigation import NAVIGATION_ENDS
from hexnewton.analysis.sim2sim import Rounds, episode_status, measure
from hexnewton.config import TaskConfig
from hexnewton.mdp.terms import episode_status_np

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
BUNDLE = os.path.join(ROOT, "results", "controllers", "cpg_rl_flat")


@pytest.mark.parametrize("ends", [TaskConfig().terminations, NAVIGATION_ENDS])
def test_mujoco_ends_are_the_mdps_toward_any_goal(ends):
    """Random robots, goals in every direction with their courses, some the last: C MuJoCo's ``episode_status``
    (its (w, x, y, z) quaternions) against ``mdp/terms``' float64 reference, with and without the off-course end."""
    rng = np.random.default_rng(3)
    n = 512
    task = TaskConfig(terminations=ends)
    qpos = np.zeros((n, 25))
    qpos[:, :2] = rng.uniform(-3, 3, (n, 2))
    qpos[:, 2] = rng.uniform(0.02, 0.2, n)
    quat = rng.normal(size=(n, 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)  # x, y, z, w
    qpos[:, 3:7] = quat[:, [3, 0, 1, 2]]
    qvel = rng.normal(0, 1, (n, 24))
    b, r = rng.uniform(-math.pi, math.pi, n), rng.uniform(0, 3, n)
    goal = qpos[:, :2] + np.stack([r * np.cos(b), r * np.sin(b)], axis=1)
    course = np.stack([np.cos(b + 0.3), np.sin(b + 0.3)], axis=1)
    last = rng.random(n) < 0.5
    steps = 7000 if ends is NAVIGATION_ENDS else 10
    got, rpy = episode_status(qpos, qvel, np.zeros(n), np.zeros((n, 2)), steps, task, goal, course, last)
    jq = np.c_[qpos[:, :3], quat, qpos[:, 7:]]
    ns = SimpleNamespace(joint_q=jq, joint_qd=qvel, episode_steps=np.full(n, steps - 1), ground=np.zeros(n), task=task,
                         goals=SimpleNamespace(goal=goal, course=course, left=np.where(last, 0, -1)))  # fmt: skip
    want, want_rpy = episode_status_np(ns, ends)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_allclose(rpy, want_rpy, atol=1e-12)
    assert len(set(got)) >= 3


def test_a_bundle_walks_a_waypoint_course_in_mujoco():
    """The shipped flat bundle: a course of two waypoints, 0.3 m and 0.6 m ahead in each start frame, completed by
    every round (the first lies within the goal radius at the start: the runtime's goal moves on at once); the goals
    sit in each start frame (every start heading)."""
    r = Rounds(BUNDLE, "flat", 3, waypoints=[(0.3, 0.0), (0.6, 0.0)])
    yaw = r.start_yaw
    np.testing.assert_allclose(r.course[:, 1] - r.start, 0.6 * np.stack([np.cos(yaw), np.sin(yaw)], 1), atol=1e-12)
    np.testing.assert_allclose(r.ctrl.goal[:, :2], r.goal)
    assert r.task.reset_yaw == pytest.approx(math.pi) and "off_course" not in r.task.terminations
    s = measure(BUNDLE, "flat", 3, max_steps=200, waypoints=[(0.3, 0.0), (0.6, 0.0)])
    w = s["waypoints"]
    assert w["rounds"] == 3 and w["completed"] == 1.0 and w["corners"] == 2.0 and w["fall_rate"] == 0.0


def test_sim2sim_waypoints_command(tmp_path):
    """``--waypoints``: results.json per terrain (completion, time, goals, falls), report.md beside Newton's square
    when given; a bad waypoint or a --newton file without a navigation evaluation is one line."""
    nav = tmp_path / "nav.json"
    nav.write_text(json.dumps({"results": {"flat": {"cpg_rl": {"square": {"rounds": 10, "completed": 1.0,
                                                                          "time_s": 1.0, "corners": 2.0,
                                                                          "fall_rate": 0.0}}}}}))  # fmt: skip
    out = tmp_path / "s2s"
    base = [sys.executable, "-m", "hexnewton.apps.sim2sim", BUNDLE, "--terrains", "flat", "--rounds", "2"]
    proc = subprocess.run([*base, "--max_steps", "100", "--waypoints", "0.3,0", "0.6,0", "--newton", str(nav),
                           "--out", str(out)], capture_output=True, text=True, timeout=600, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((out / "results.json").read_text())["flat"]["completed"] == 1.0
    report = (out / "report.md").read_text()
    assert "| flat | bundle (CPG_RL) | 2 / 10 | 100.0 % / 100.0 % |" in report and "| yes |" in report
    for extra, message in ((["--waypoints", "2"], "expected a waypoint X,Y"),
                           (["--waypoints", "2,0", "--newton", BUNDLE + "/controller.json"], "no navigation evaluation")):
        proc = subprocess.run([*base, *extra, "--out", str(tmp_path / "x")], capture_output=True, text=True,
                              timeout=300, cwd=ROOT)  # fmt: skip
        lines = [line for line in proc.stderr.splitlines() if line.strip()]
        assert proc.returncode == 2 and len(lines) == 1 and message in lines[0], proc.stderr
