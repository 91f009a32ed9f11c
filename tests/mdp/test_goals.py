"""Goals (mdp/terms/goals.py): the goal sampler, the first goal of an episode and the switch to the next against their
float64 twins on random inputs; progress, the lateral offset and the ends toward a goal that is not straight ahead on
hand-made states; the waypoint switch and random goals in a CPU env."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch
import warp as wp

from hexnewton.config import HexConfig, RewardConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.mdp.env import make_env
from hexnewton.mdp.status import FELL, OFF_COURSE, RUNNING, SUCCESS
from hexnewton.mdp.terms import (
    REWARD_NAMES,
    EndInputs,
    Goals,
    RewardInputs,
    TaskParams,
    config_params,
    episode_status_kernel,
    episode_status_np,
    goal_from_draws,
    goal_from_draws_np,
    goal_switch_kernel,
    goal_switch_reference,
    goals_from_host,
    height_field_from_grid,
    make_struct,
    rewards_kernel,
    rewards_reference,
    reward_weights,
    set_goal,
    set_goal_np,
)
from hexnewton.terrain import make_terrain, terrain_height_np

DEV = "cpu"
RANDOM = dataclasses.replace(TaskConfig(), random_goals=True, goal_bearing=math.pi, goal_distance_min=1.0,
                             goal_distance_max=4.0, goal_area=4.0)  # fmt: skip


@wp.kernel
def _sample(x: wp.array[wp.float32], y: wp.array[wp.float32], yaw: wp.array[wp.float32], u1: wp.array[wp.float32],
            u2: wp.array[wp.float32], start: wp.array[wp.vec2], task: TaskParams, out: wp.array[wp.vec2]):  # fmt: skip
    e = wp.tid()
    out[e] = goal_from_draws(x[e], y[e], yaw[e], u1[e], u2[e], start[e], task)


@wp.kernel
def _set(goals: Goals, task: TaskParams, k: wp.array[wp.int32], x: wp.array[wp.float32], y: wp.array[wp.float32],
         yaw: wp.array[wp.float32], u1: wp.array[wp.float32], u2: wp.array[wp.float32]):  # fmt: skip
    e = wp.tid()
    set_goal(goals, task, e, k[e], x[e], y[e], yaw[e], u1[e], u2[e])


def _f32(a):
    return wp.array(np.asarray(a, np.float32), device=DEV)


def _vec2(a):
    return wp.array(np.asarray(a, np.float32), dtype=wp.vec2, device=DEV)


def _draws(rng, n):
    """Robots anywhere in and around the +-4 m square of their start, any heading, and the two uniform draws."""
    start = rng.uniform(-0.6, 0.6, (n, 2)).astype(np.float32)
    x, y = (start + rng.uniform(-4.8, 4.8, (n, 2))).T.astype(np.float32)
    return start, x, y, rng.uniform(-math.pi, math.pi, n).astype(np.float32), *rng.random((2, n)).astype(np.float32)


@pytest.mark.parametrize("bearing", [math.pi, math.pi / 4])
def test_goal_sampler_matches_its_twin(bearing):
    """goal_from_draws against goal_from_draws_np on random robots and draws; every goal lies in the square around
    the start; a goal left as drawn (not mirrored, not clamped) is 1-4 m away at a bearing within +-goal_bearing of
    the heading."""
    rng = np.random.default_rng(7)
    n = 4096
    task = dataclasses.replace(RANDOM, goal_bearing=bearing)
    start, x, y, yaw, u1, u2 = _draws(rng, n)
    out = wp.zeros(n, dtype=wp.vec2, device=DEV)
    wp.launch(_sample, dim=n, inputs=[_f32(x), _f32(y), _f32(yaw), _f32(u1), _f32(u2), _vec2(start),
                                      config_params(TaskParams, task)], outputs=[out], device=DEV)  # fmt: skip
    got, ref = out.numpy(), goal_from_draws_np(x, y, yaw, u1, u2, start, task)
    np.testing.assert_allclose(got, ref, atol=2e-5)
    assert np.all(np.abs(got - start) <= task.goal_area + 1e-5)
    b = yaw + bearing * (2.0 * u1.astype(np.float64) - 1.0)
    r = 1.0 + 3.0 * u2.astype(np.float64)
    drawn = np.stack([x + r * np.cos(b), y + r * np.sin(b)], axis=1)
    as_drawn = np.all(np.abs(drawn - start) <= task.goal_area, axis=1)
    assert 0.3 < as_drawn.mean() < 1.0  # both kinds occur
    d = got[as_drawn] - np.stack([x, y], axis=1)[as_drawn]
    dist = np.hypot(d[:, 0], d[:, 1])
    assert np.all((dist >= 1.0 - 1e-4) & (dist <= 4.0 + 1e-4))
    rel = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - yaw[as_drawn])))
    assert np.all(np.abs(rel) <= bearing + 1e-3)
    if bearing == math.pi:  # the whole circle: goals behind the robot too
        assert (np.abs(rel) > 3 * math.pi / 4).mean() > 0.15
    # a robot inside the square keeps its goal's distance when mirrored (the square holds 4 m either way)
    inside = np.all(np.abs(np.stack([x, y], axis=1) - start) <= task.goal_area, axis=1)
    d = got[inside] - np.stack([x, y], axis=1)[inside]
    np.testing.assert_allclose(np.hypot(d[:, 0], d[:, 1]), r[inside], atol=1e-4)


def _goal_arrays(rng, n, k_max=4):
    """Random per-env goals and waypoint courses (host arrays and the kernel's struct)."""
    arrays = dict(goal=rng.uniform(-3, 3, (n, 2)), course=np.tile([1.0, 0.0], (n, 1)), left=rng.choice([-1, 0, 2], n),
                  reached=rng.integers(0, k_max, n), start=rng.uniform(-0.5, 0.5, (n, 2)),
                  start_yaw=rng.uniform(-math.pi, math.pi, n), waypoints=rng.uniform(-2.5, 2.5, (n, k_max, 2)))
    arrays = {k: np.asarray(v, np.int32 if k in ("left", "reached") else np.float32) for k, v in arrays.items()}
    return arrays


@pytest.mark.parametrize("mode", ["ahead", "random", "waypoints"])
def test_set_goal_matches_its_twin(mode):
    """Goal k of an episode for robots anywhere: the paper's goal ahead (course +x, the last), a random goal (no end)
    and waypoint k of each env's course in its start frame (the last one ends it), each against set_goal_np."""
    rng = np.random.default_rng(11)
    n = 512
    task = RANDOM if mode == "random" else TaskConfig()
    a = _goal_arrays(rng, n)
    if mode != "waypoints":
        a["waypoints"] = np.zeros((n, 0, 2), np.float32)
    goals = goals_from_host(DEV, a["goal"], a["course"], a["left"], a["reached"], a["start"], a["start_yaw"],
                            a["waypoints"])  # fmt: skip
    start, x, y, yaw, u1, u2 = _draws(rng, n)
    k = rng.integers(0, 5, n).astype(np.int32)  # past the course's last waypoint too: it stays there
    wp.launch(_set, dim=n, inputs=[goals, config_params(TaskParams, task), wp.array(k, device=DEV), _f32(x), _f32(y),
                                   _f32(yaw), _f32(u1), _f32(u2)], device=DEV)  # fmt: skip
    ns = SimpleNamespace(**a, waypoint_count=a["waypoints"].shape[1])
    goal, course, left = set_goal_np(ns, task, k, x, y, yaw, u1, u2)
    np.testing.assert_allclose(goals.goal.numpy(), goal, atol=3e-5)
    np.testing.assert_allclose(goals.course.numpy(), course, atol=3e-5)
    np.testing.assert_array_equal(goals.left.numpy(), left)
    np.testing.assert_allclose(np.linalg.norm(course, axis=1), 1.0, atol=1e-9)
    if mode == "ahead":
        np.testing.assert_array_equal(goals.goal.numpy(), np.stack([x + np.float32(task.goal_distance), y], axis=1))
        assert (left == 0).all() and (goals.course.numpy() == [1.0, 0.0]).all()
    if mode == "waypoints":  # waypoint (2, 0) of a robot started at (1, 1) facing +y lies at (1, 3)
        assert set(left) == {0, 1, 2, 3}
        ns1 = SimpleNamespace(start=[[1.0, 1.0]], start_yaw=[math.pi / 2], waypoints=[[[2.0, 0.0]]], waypoint_count=1)
        np.testing.assert_allclose(set_goal_np(ns1, task, np.array([0]), [0.0], [0.0], [0.0], [0.0], [0.0])[0],
                                   [[1.0, 3.0]], atol=1e-12)  # fmt: skip


@pytest.mark.parametrize("mode", ["ahead", "random", "waypoints"])
def test_goal_switch_matches_its_twin(mode):
    """The switch on random states: only a running robot within the goal radius of a goal that is not its last gets
    the next one (goals reached + 1); waypoint courses and the goal ahead against the twin exactly, random goals in
    their square and 1-4 m away from a robot inside it."""
    rng = np.random.default_rng(5)
    n = 1024
    task = RANDOM if mode == "random" else TaskConfig()
    a = _goal_arrays(rng, n)
    if mode != "waypoints":
        a["waypoints"] = np.zeros((n, 0, 2), np.float32)
    q = np.zeros((n, 25), np.float32)
    q[:, :2] = a["goal"] + rng.uniform(-0.7, 0.7, (n, 2))  # about half within the 0.5 m radius
    yaw = rng.uniform(-math.pi, math.pi, n)
    q[:, 5], q[:, 6] = np.sin(yaw / 2), np.cos(yaw / 2)
    status = rng.choice([RUNNING, RUNNING, FELL, SUCCESS], n).astype(np.int32)
    goals = goals_from_host(DEV, a["goal"], a["course"], a["left"], a["reached"], a["start"], a["start_yaw"],
                            a["waypoints"])  # fmt: skip
    counter = wp.array(np.array([3], np.int32), device=DEV)
    wp.launch(goal_switch_kernel, dim=n, inputs=[wp.array(status, device=DEV), wp.array(q, device=DEV), goals,
                                                 config_params(TaskParams, task), 17, counter], device=DEV)  # fmt: skip
    ns = SimpleNamespace(**a, waypoint_count=a["waypoints"].shape[1])
    ref = goal_switch_reference(status, q, ns, task, np.zeros(n), np.zeros(n))
    sw = ref["switched"]
    assert sw.sum() > 50 and (~sw).sum() > 50
    np.testing.assert_array_equal(goals.reached.numpy(), ref["reached"])
    np.testing.assert_array_equal(goals.left.numpy(), ref["left"])
    got = goals.goal.numpy()
    np.testing.assert_array_equal(got[~sw], a["goal"][~sw])  # nothing else moves
    if mode != "random":
        np.testing.assert_allclose(got, ref["goal"], atol=3e-5)
        np.testing.assert_allclose(goals.course.numpy(), ref["course"], atol=3e-5)
        return
    assert np.all(np.abs(got[sw] - a["start"][sw]) <= task.goal_area + 1e-5)
    inside = sw & np.all(np.abs(q[:, :2] - a["start"]) <= task.goal_area, axis=1)
    dist = np.hypot(*(got[inside] - q[inside, :2]).T)
    assert inside.sum() > 20 and np.all((dist >= 1.0 - 1e-4) & (dist <= 4.0 + 1e-4))
    c = goals.course.numpy()[sw]
    np.testing.assert_allclose(c, (got[sw] - q[sw, :2]) / np.linalg.norm(got[sw] - q[sw, :2], axis=1)[:, None],
                               atol=1e-4)  # fmt: skip


# ------------------------------------------------------------------ the terms toward a goal not straight ahead


def _rewards(q, prev_xy, goal, course, left, status, rpy, reward, task=TaskConfig()):
    """The reward kernel's terms and the float64 reference's on flat ground."""
    n = len(q)
    grid = make_terrain(TerrainConfig(name="flat")).grid
    arrays = dict(joint_q=np.asarray(q, np.float32), joint_qd=np.zeros((n, 24), np.float32),
                  rpy=np.asarray(rpy, np.float32), status=np.asarray(status, np.int32),
                  episode_steps=np.full(n, 5, np.int32), actions=np.zeros((n, 15), np.float32),
                  prev_actions=np.zeros((n, 15), np.float32))  # fmt: skip
    g = dict(goal=np.asarray(goal, np.float32), course=np.asarray(course, np.float32), left=np.asarray(left, np.int32))
    inputs = make_struct(RewardInputs, **{k: wp.array(v, device=DEV) for k, v in arrays.items()},
                         prev_xy=_vec2(prev_xy), goals=goals_from_host(DEV, g["goal"], g["course"], g["left"]),
                         hf=height_field_from_grid(grid, DEV), task=task, reward=reward)  # fmt: skip
    rew, terms = wp.zeros(n, device=DEV), wp.zeros((n, len(REWARD_NAMES)), device=DEV)
    wp.launch(rewards_kernel, dim=n, inputs=[inputs, reward_weights(reward)], outputs=[rew, terms], device=DEV)
    ns = SimpleNamespace(**arrays, prev_xy=np.asarray(prev_xy, np.float32), goals=SimpleNamespace(**g),
                         ground=np.zeros(n), task=task, reward=reward)  # fmt: skip
    _, ref, _, _ = rewards_reference(ns)
    return dict(zip(REWARD_NAMES, terms.numpy().T)), dict(zip(REWARD_NAMES, ref.T))


def test_progress_toward_a_goal_not_straight_ahead():
    """A goal 2 m to the left of the robot's start (its course +y): a 1 cm step along +y is progress, one along +x is
    not (the forward fine); the lateral cost is the squared offset from the start-to-goal line (x = 0 here), not
    from y_start; the direction term wants the robot facing +y (ours: toward the goal; the paper's: along the course);
    the goal bonus is paid once within 0.5 m of a goal that sets the next and still running, as at the last goal's
    success, not at a last goal still running (its success ends the episode)."""
    reward = dataclasses.replace(RewardConfig(), w_lateral=2.0)
    n = 6
    q = np.zeros((n, 25))
    q[:, 2], q[:, 6] = 0.13, 1.0
    q[:, :2] = [[0.0, 1.0], [0.0, 1.0], [0.3, 1.0], [0.1, 1.7], [0.1, 1.7], [0.1, 1.7]]
    prev = q[:, :2] - [[0.0, 0.01], [0.01, 0.0], [0.0, 0.01], [0.0, 0.01], [0.0, 0.01], [0.0, 0.01]]
    goal, course = np.tile([0.0, 2.0], (n, 1)), np.tile([0.0, 1.0], (n, 1))
    left, status = [-1, -1, -1, -1, 0, 0], [RUNNING, RUNNING, RUNNING, RUNNING, RUNNING, SUCCESS]
    rpy = np.zeros((n, 3))
    rpy[:, 2] = math.pi / 2  # facing +y, the goal
    rpy[1, 2] = 0.0  # facing +x: 90 deg off
    got, ref = _rewards(q, prev, goal, course, left, status, rpy, reward)
    for name in REWARD_NAMES:
        np.testing.assert_allclose(got[name], ref[name], atol=1e-5, err_msg=name)
    np.testing.assert_allclose(got["forward"], [0, -0.3, 0, 0, 0, 0])
    np.testing.assert_allclose(got["lateral"], [0, 0, -2.0 * 0.09, -2.0 * 0.01, -2.0 * 0.01, -2.0 * 0.01], atol=1e-6)
    assert got["direction"][0] == pytest.approx(0.0, abs=1e-6)
    assert got["direction"][1] == pytest.approx(-1.0, abs=1e-5)  # cos(90 deg) - 1
    assert got["direction"][2] == pytest.approx(math.cos(math.pi / 2 - math.atan2(1.0, -0.3)) - 1, abs=1e-5)
    np.testing.assert_allclose(got["goal"], [0, 0, 0, 300, 0, 300])
    np.testing.assert_allclose(got["distance"][0], math.exp(-(1.0 - 0.5)), rtol=1e-5)
    paper = dataclasses.replace(reward, direction_to_goal=False)  # D: the course, +y
    got, _ = _rewards(q, prev, goal, course, left, status, rpy, paper)
    assert got["direction"][0] == pytest.approx(0.0, abs=1e-6) and got["direction"][1] == pytest.approx(-1.0, abs=1e-5)


def test_rewards_toward_goals_in_every_direction_match_the_reference():
    """Every reward column against its float64 twin on random robots with goals in every direction, their courses,
    some of them the last, some within reach."""
    rng = np.random.default_rng(4)
    n = 512
    q = np.zeros((n, 25))
    q[:, :2] = rng.uniform(-3.0, 3.0, (n, 2))
    q[:, 2] = rng.uniform(0.03, 0.2, n)
    quat = rng.normal(size=(n, 4))
    q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    bearing, r = rng.uniform(-math.pi, math.pi, n), rng.uniform(0.0, 4.0, n)
    goal = q[:, :2] + np.stack([r * np.cos(bearing), r * np.sin(bearing)], axis=1)
    tilt = bearing + rng.uniform(-0.6, 0.6, n)
    course = np.stack([np.cos(tilt), np.sin(tilt)], axis=1)
    prev = q[:, :2] - rng.uniform(-0.01, 0.01, (n, 2))
    reward = dataclasses.replace(RewardConfig(), w_lateral=1.5, fall_penalty=50.0)
    for to_goal in (True, False):
        got, ref = _rewards(q, prev, goal, course, rng.choice([-1, 0, 3], n), rng.integers(0, 5, n),
                            rng.uniform(-1.0, 1.0, (n, 3)), dataclasses.replace(reward, direction_to_goal=to_goal))
        for name in REWARD_NAMES:
            np.testing.assert_allclose(got[name], ref[name], rtol=1e-4, atol=1e-4, err_msg=name)
        assert (got["goal"] > 0).sum() > 10 and (got["forward"] < 0).sum() > 50


def test_ends_toward_a_goal_not_straight_ahead():
    """Success within 0.5 m of the episode's last goal only; off course more than max_abs_y from the line through the
    goal along its course (here x = 1), whatever y_start; the kernel as its twin."""
    n = 5
    q = np.zeros((n, 25))
    q[:, 2], q[:, 6] = 0.13, 1.0
    q[:, :2] = [[1.1, 2.8], [1.1, 2.8], [2.7, 0.0], [-0.6, 0.5], [1.4, 0.0]]
    goal, course = np.tile([1.0, 3.0], (n, 1)), np.tile([0.0, 1.0], (n, 1))
    left = np.array([0, -1, -1, 2, 0])
    grid = make_terrain(TerrainConfig(name="flat")).grid
    inputs = make_struct(EndInputs, joint_q=wp.array(q.astype(np.float32), device=DEV),
                         joint_qd=wp.zeros((n, 24), device=DEV), episode_steps=wp.zeros(n, dtype=wp.int32, device=DEV),
                         goals=goals_from_host(DEV, goal, course, left), hf=height_field_from_grid(grid, DEV),
                         task=TaskConfig())  # fmt: skip
    status = wp.zeros(n, dtype=wp.int32, device=DEV)
    wp.launch(episode_status_kernel, dim=n, inputs=[inputs], outputs=[status, wp.zeros((n, 3), device=DEV)],
              device=DEV)  # fmt: skip
    ns = SimpleNamespace(joint_q=q, joint_qd=np.zeros((n, 24)), episode_steps=np.zeros(n, np.int32),
                         goals=SimpleNamespace(goal=goal, course=course, left=left), ground=np.zeros(n),
                         task=TaskConfig())  # fmt: skip
    np.testing.assert_array_equal(status.numpy(), [SUCCESS, RUNNING, OFF_COURSE, OFF_COURSE, RUNNING])
    np.testing.assert_array_equal(episode_status_np(ns)[0], status.numpy())


# ------------------------------------------------------------------ in the env


def _env(n=2, **task):
    task = {"reset_yaw": 0.0, "reset_lateral": 0.0, **task}
    cfg = HexConfig(sim=SimConfig(num_envs=n, device=DEV), terrain=TerrainConfig(name="flat"),
                    task=dataclasses.replace(TaskConfig(), **task))  # fmt: skip
    return make_env(cfg)


def test_straight_tasks_set_the_goal_ahead():
    """The paper's goal: goal_distance ahead of each start along +x, course +x, the last; nothing switches."""
    env = _env(3)
    env.step(torch.zeros(3, 15))
    np.testing.assert_array_equal(env.goals.goal.numpy(), env.start.numpy() + np.float32([3.5, 0.0]))
    assert (env.goals.course.numpy() == [1.0, 0.0]).all() and (env.goals.left.numpy() == 0).all()
    assert (env.goals.reached.numpy() == 0).all()


def test_waypoint_switch_in_the_env():
    """A waypoint course (0.3, 0) then (0.7, 0) in the start frame, the fixed CPG walking: the first waypoint lies
    within the goal radius of the start, so the first step pays the goal bonus and sets the second (the observation's
    target moves to it); reaching the second, the last, ends the episode as a success with two goals reached; the
    per-env course (set_waypoints) then takes over from the next reset."""
    from hexnewton.learning.policy import fixed_cpg_actions

    env = _env(2, waypoints=((0.3, 0.0), (0.7, 0.0)), max_episode_steps=400)
    actions = fixed_cpg_actions(env)
    assert (env.goals.left.numpy() == 1).all()
    _, _, done, extras = env.step(actions)
    goal_col = list(env.reward_terms).index(next(t for t in env.reward_terms if t.name == "goal"))
    np.testing.assert_allclose(env.terms.numpy()[:, goal_col], 300.0)
    assert (env.goals.reached.numpy() == 1).all() and (env.goals.left.numpy() == 0).all()
    np.testing.assert_allclose(env.goals.goal.numpy(), env.start.numpy() + [0.7, 0.0], atol=1e-6)
    np.testing.assert_allclose(env.obs.numpy()[:, 36], 0.7 - env.last_q.numpy()[:, 0], atol=0.02)  # target x
    ended, how = np.zeros(2, bool), np.zeros(2, np.int32)
    for _ in range(300):
        _, _, done, extras = env.step(actions)
        now = done.numpy().astype(bool) & ~ended
        how[now], ended = env.status.numpy()[now], ended | now
        if ended.all():
            break
    assert ended.all() and (how == SUCCESS).all()
    assert extras["log"]["Episode/goals_reached"].item() == pytest.approx(2.0)
    env.set_waypoints(np.array([[[1.0, 0.0]], [[0.0, 1.0]]]))  # one course per env
    env.reset()
    np.testing.assert_allclose(env.goals.goal.numpy(), env.start.numpy() + [[1.0, 0.0], [0.0, 1.0]], atol=1e-6)
    with pytest.raises(ValueError, match="waypoints"):
        env.set_waypoints(np.zeros((3, 1, 2)))


def test_random_goals_in_the_env():
    """Random goals (the navigate tasks): after a reset each robot's goal lies 1-4 m away at a bearing within
    +-goal_bearing of its heading, inside the square around its start, and has no end; bad settings are one line."""
    env = _env(16, random_goals=True, goal_bearing=math.pi / 2, reset_yaw=math.pi)
    env.step(torch.zeros(16, 15))
    env.reset()
    goal, start, q = env.goals.goal.numpy(), env.start.numpy(), env.world.joint_q_wp.numpy()
    d = goal - q[:, :2]
    dist = np.hypot(d[:, 0], d[:, 1])
    yaw = 2 * np.arctan2(q[:, 5], q[:, 6])
    rel = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - yaw)))
    assert np.all((dist >= 1.0 - 1e-4) & (dist <= 4.0 + 1e-4)) and np.all(np.abs(rel) <= math.pi / 2 + 1e-3)
    assert np.all(np.abs(goal - start) <= 4.0 + 1e-5) and (env.goals.left.numpy() == -1).all()
    assert np.ptp(yaw) > 2.0  # random start headings
    with pytest.raises(ValueError, match="goal_distance_min/max"):
        _env(1, random_goals=True, goal_distance_min=0.4)
    with pytest.raises(ValueError, match="task.waypoints"):
        _env(1, waypoints=((1.0, float("nan")),))


def test_random_goals_with_the_observation_switches():
    """The learner's switches (gyro, last actions, the critic's group) with random goals: the policy group's target is
    the goal in the heading frame, both groups finite, the goals switching as without them."""
    from hexnewton.config import ObsConfig

    cfg = HexConfig(sim=SimConfig(num_envs=4, device=DEV), terrain=TerrainConfig(name="flat"),
                    task=dataclasses.replace(TaskConfig(), random_goals=True, reset_yaw=math.pi),
                    obs=ObsConfig(gyro=True, last_action=True, critic=True))  # fmt: skip
    env = make_env(cfg)
    for _ in range(3):
        obs, _, _, _ = env.step(torch.zeros(4, env.num_actions))
    assert set(obs.keys()) == {"policy", "critic"} and all(np.isfinite(v.numpy()).all() for v in obs.values())
    q, goal = env.world.joint_q_wp.numpy(), env.goals.goal.numpy()
    yaw = 2 * np.arctan2(q[:, 5], q[:, 6])
    d = goal - q[:, :2]
    want = np.stack([np.cos(yaw) * d[:, 0] + np.sin(yaw) * d[:, 1], -np.sin(yaw) * d[:, 0] + np.cos(yaw) * d[:, 1]], 1)
    np.testing.assert_allclose(obs["policy"].numpy()[:, 36:38], want, atol=0.05)  # (small roll/pitch: yaw as here)
