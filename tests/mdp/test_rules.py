"""One definition per rule: the episode ends and the goal switch of ``hexnewton/deploy/rules.py`` (NumPy, the robot
runtime's) against the env's Warp kernels, their float64 twins (``mdp/terms``: the rules themselves), C MuJoCo's closed
loop (``analysis/sim2sim.py``) and the runtime's course (``Controller.set_course / next_goal``) on random states."""

import dataclasses
import json
import math
import os
from types import SimpleNamespace

import numpy as np
import pytest
import warp as wp

from hexnewton.analysis.navigation import NAVIGATION_ENDS
from hexnewton.analysis.sim2sim import episode_status
from hexnewton.config import TaskConfig, TerrainConfig
from hexnewton.deploy import rules
from hexnewton.deploy.runtime import Controller
from hexnewton.mdp.status import FELL, NONFINITE, RUNNING, SUCCESS
from hexnewton.mdp.terms import (
    TERMINATIONS,
    EndInputs,
    TaskParams,
    config_params,
    episode_status_np,
    goal_switch_kernel,
    goal_switch_reference,
    goals_from_host,
    height_field_from_grid,
    make_struct,
)
from hexnewton.mdp.terms.terminations import make_status_kernel
from hexnewton.terrain import make_terrain, terrain_height_np

DEV = "cpu"
ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
SPEC = os.path.join(ROOT, "results", "controllers", "cpg_rl_flat", "controller.json")


def test_the_twins_are_the_rules():
    """The termination table's references and the goal twins are the shared rule's functions, not copies."""
    from hexnewton.mdp.terms import goals, terminations

    assert [(t.name, t.code, t.reference) for t in TERMINATIONS] == list(rules.ENDS)
    assert terminations.end_frame_np is rules.end_frame
    assert goals.set_goal_np is rules.set_goal and goals.goal_from_draws_np is rules.goal_from_draws
    assert goals.off_line_np is rules.off_line and goals.course_to_np is rules.course_to


def _random_ends(rng, n, grid):
    """Random robots over ``grid``: some blown up (NaN, runaway base or joint), low or tilted, near or far from a goal
    in any direction (some the last), some at their time limit."""
    q = np.zeros((n, 25))
    q[:, :2] = rng.uniform(-1.5, 1.5, (n, 2))
    q[:, 2] = terrain_height_np(grid, q[:, 0], q[:, 1]) + rng.uniform(0.0, 0.25, n)
    quat = rng.normal(size=(n, 4)) * [0.3, 0.3, 1.0, 1.0]
    q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    q[:, 7:] = rng.uniform(-1, 1, (n, 18))
    qd = rng.normal(0, 1, (n, 24))
    qd[rng.random(n) < 0.05, :3] *= 20  # runaway bases
    qd[rng.random(n) < 0.05, 10] = 60.0  # a runaway joint
    q[rng.random(n) < 0.03, 9] = np.nan
    b, r = rng.uniform(-math.pi, math.pi, n), rng.uniform(0, 1.5, n)
    goal = q[:, :2] + np.stack([r * np.cos(b), r * np.sin(b)], axis=1)
    course = np.stack([np.cos(b + rng.normal(0, 0.5, n)), np.sin(b + rng.normal(0, 0.5, n))], axis=1)
    left = rng.choice([0, 0, 1, -1], n)
    steps = rng.choice([0, 10, TaskConfig().max_episode_steps - 1], n)
    return q.astype(np.float32).astype(np.float64), qd.astype(np.float32).astype(np.float64), goal, course, left, steps


@pytest.mark.parametrize("robot", ["paper", "mx_phoenix"])
@pytest.mark.parametrize("names", [TaskConfig().terminations, NAVIGATION_ENDS])
def test_ends_kernel_twin_rule_and_mujoco_agree_on_random_states(names, robot):
    """Random states on a rugged terrain: the Warp status kernel, its twin (``episode_status_np``), the shared rule
    (``rules.episode_status``) and C MuJoCo's (``sim2sim.episode_status``, its (w, x, y, z) quaternions) give the
    same status codes and angles, with and without the off-course end, for the paper's robot and the MX-Phoenix (its
    fall height scaled); every code turns up."""
    from hexnewton.config import HexConfig
    from hexnewton.robot.registry import ROBOTS, with_robot

    rng = np.random.default_rng(11)
    n = 4096
    task = dataclasses.replace(with_robot(HexConfig(), ROBOTS[robot]).task, terminations=names)
    grid = make_terrain(TerrainConfig(name="rugged", seed=3)).grid
    q, qd, goal, course, left, steps = _random_ends(rng, n, grid)
    inputs = make_struct(EndInputs, joint_q=wp.array(q.astype(np.float32), device=DEV),
                         joint_qd=wp.array(qd.astype(np.float32), device=DEV),
                         episode_steps=wp.array(steps.astype(np.int32), device=DEV),
                         goals=goals_from_host(DEV, goal, course, left), hf=height_field_from_grid(grid, DEV),
                         task=task)  # fmt: skip
    status, rpy = wp.zeros(n, dtype=wp.int32, device=DEV), wp.zeros((n, 3), device=DEV)
    wp.launch(make_status_kernel(names), dim=n, inputs=[inputs], outputs=[status, rpy], device=DEV)
    ground = terrain_height_np(grid, np.nan_to_num(q[:, 0]), np.nan_to_num(q[:, 1]))
    ns = SimpleNamespace(joint_q=q, joint_qd=qd, episode_steps=steps, ground=ground, task=task,
                         goals=SimpleNamespace(goal=goal, course=course, left=left))  # fmt: skip
    twin, twin_rpy = episode_status_np(ns, names)
    rule, rule_rpy = rules.episode_status(rules.EndInputs(q, qd, steps, ns.goals, ground, task), names)
    np.testing.assert_array_equal(twin, rule)
    np.testing.assert_array_equal(twin_rpy, rule_rpy)
    np.testing.assert_array_equal(status.numpy(), rule)
    np.testing.assert_allclose(rpy.numpy(), rule_rpy, atol=2e-5)
    assert set(rule) >= {RUNNING, FELL, SUCCESS, NONFINITE} and len(set(rule)) == len(names) + 1
    for k in np.unique(steps):  # C MuJoCo's layout, ``steps`` counted after the step
        m = steps == k
        qpos = np.c_[q[m, :3], q[m][:, [6, 3, 4, 5]], q[m, 7:]]
        got, got_rpy = episode_status(qpos, qd[m], ground[m], np.zeros((m.sum(), 2)), int(k) + 1, task, goal[m],
                                      course[m], left[m] == 0)  # fmt: skip
        np.testing.assert_array_equal(got, rule[m])
        np.testing.assert_allclose(got_rpy, rule_rpy[m], atol=1e-12)


@pytest.mark.parametrize("mode", ["ahead", "waypoints"])
def test_goal_switch_kernel_twin_rule_and_runtime_agree_on_random_states(mode):
    """Random goals, waypoint courses and robots about their goals: the Warp switch, its twin, the shared rule and the
    runtime's course (``Controller.next_goal``, the one sim2sim's rounds walk) switch the same robots to the same
    goals."""
    rng = np.random.default_rng(7)
    n, k_max = 1024, 4
    task = TaskConfig()
    waypoints = rng.uniform(-2.5, 2.5, (n, k_max if mode == "waypoints" else 0, 2))
    start, start_yaw = rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-math.pi, math.pi, n)
    reached = rng.integers(0, k_max, n) if mode == "waypoints" else np.zeros(n, np.int64)
    goals = rules.start_goals(start, start_yaw, waypoints)
    goals.reached = reached
    goals.goal, goals.course, goals.left = rules.set_goal(goals, task, reached, *start.T, start_yaw, 0.0, 0.0)
    if mode == "ahead":  # goals after the one ahead (2) or none (-1) too, so that some switch
        goals.left = rng.choice([-1, 0, 2], n)
    pos = goals.goal + rng.uniform(-0.7, 0.7, (n, 2))
    yaw = rng.uniform(-math.pi, math.pi, n)
    q = np.zeros((n, 25))
    q[:, :2], q[:, 5], q[:, 6] = pos, np.sin(yaw / 2), np.cos(yaw / 2)
    q = q.astype(np.float32).astype(np.float64)
    status = rng.choice([RUNNING, RUNNING, FELL, SUCCESS], n)
    rule = rules.goal_switch(status, q[:, 0], q[:, 1], yaw, goals, task, np.zeros(n), np.zeros(n))
    twin = goal_switch_reference(status, q, goals, task, np.zeros(n), np.zeros(n))
    for k in ("goal", "course", "left", "reached", "switched"):
        np.testing.assert_allclose(twin[k], rule[k], atol=1e-12, err_msg=k)
    sw = rule["switched"]
    assert sw.sum() > 50 and (~sw).sum() > 50
    wgoals = goals_from_host(DEV, goals.goal, goals.course, goals.left, reached, start, start_yaw, waypoints)
    wp.launch(goal_switch_kernel, dim=n, inputs=[wp.array(status.astype(np.int32), device=DEV),
                                                 wp.array(q.astype(np.float32), device=DEV), wgoals,
                                                 config_params(TaskParams, task), 17,
                                                 wp.array(np.array([3], np.int32), device=DEV)], device=DEV)  # fmt: skip
    np.testing.assert_array_equal(wgoals.reached.numpy(), rule["reached"])
    np.testing.assert_array_equal(wgoals.left.numpy(), rule["left"])
    np.testing.assert_allclose(wgoals.goal.numpy(), rule["goal"], atol=3e-5)
    np.testing.assert_allclose(wgoals.course.numpy(), rule["course"], atol=3e-5)
    ctrl = Controller(json.load(open(SPEC)), num_robots=n)
    ctrl.set_course(np.c_[start, start_yaw], waypoints if mode == "waypoints" else None, goal_radius=task.goal_radius,
                    goal_distance=task.goal_distance)  # fmt: skip
    ctrl.goals = dataclasses.replace(goals, reached=reached.copy())
    got = ctrl.next_goal(np.c_[q[:, :2], yaw], status == RUNNING)
    np.testing.assert_array_equal(got, sw)
    np.testing.assert_allclose(ctrl.goal[:, :2], rule["goal"], atol=1e-12)
    np.testing.assert_array_equal(ctrl.goals.reached, rule["reached"])
    np.testing.assert_array_equal(ctrl.goals.left, rule["left"])
