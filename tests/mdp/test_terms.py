"""The term tables (mdp/terms/): each fused kernel against the rows' float64
NumPy functions on random states, the paper's terms on hand-made states, and what the tables drive (kernel columns,
log names, layouts, noise)."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
import torch
import warp as wp

from hexnewton.config import (
    HexConfig,
    ObsConfig,
    RandomizationConfig,
    RewardConfig,
    SimConfig,
    TaskConfig,
    TerrainConfig,
)
from hexnewton.mdp.env import make_env
from hexnewton.mdp.status import FELL, OFF_COURSE, STATUS_NAMES, SUCCESS
from hexnewton.mdp.terms import (
    BASE_LAYOUTS,
    LAYOUTS,
    OBS_DIM,
    OBS_LAYOUT,
    OBS_TERMS,
    REWARD_NAMES,
    REWARD_TERMS,
    TERMINATIONS,
    ObsInputs,
    RewardFrame,
    RewardInputs,
    RewardParams,
    RewardTerm,
    TaskParams,
    config_params,
    goals_from_host,
    height_field_from_grid,
    layout_name,
    layout_parts,
    make_rewards_kernel,
    make_struct,
    observation_noise,
    observations_kernel,
    observations_reference,
    reward_weights,
    rewards_kernel,
    rewards_reference,
)
from hexnewton.mdp.terms.observations import LAYOUT_ACTIONS
from hexnewton.robot.registry import ROBOTS, with_robot
from hexnewton.terrain import make_terrain, max_terrain_height_np, terrain_height_np

DEV = "cpu"
TASK, REW = TaskConfig(), RewardConfig()
#: the MX-Phoenix's task: its heights and terrain window scaled (hexnewton.robot.registry.with_robot)
MX_TASK = with_robot(HexConfig(), ROBOTS["mx_phoenix"]).task


# ------------------------------------------------------------------ rewards (Table 1, Eq. 5, shaping)


def _reward_arrays(n, q=None, start=None, **given):
    """Reward inputs as float32 / int32 NumPy arrays: upright, at rest, no actions, unless given; the goal
    ``TASK.goal_distance`` ahead of ``start`` (zeros) along +x, the last, unless ``goal``, ``course``, ``left`` are
    given (``mdp/terms/goals.py``)."""
    q = np.zeros((n, 25)) if q is None else q
    if not np.any(q[:, 3:7]):
        q[:, 6] = 1.0
    start = np.zeros((n, 2)) if start is None else np.asarray(start, np.float32)
    arrays = dict(joint_q=q, joint_qd=np.zeros((n, 24)), rpy=np.zeros((n, 3)), status=np.zeros(n),
                  episode_steps=np.full(n, 5), actions=np.zeros((n, 15)),
                  goal=(start + np.float32([TASK.goal_distance, 0.0])).astype(np.float32),
                  course=np.tile([1.0, 0.0], (n, 1)), left=np.zeros(n), prev_xy=q[:, :2].copy(),
                  prev_actions=np.zeros((n, 15)))  # fmt: skip
    arrays.update(given)
    ints = ("status", "episode_steps", "left")
    return {k: np.asarray(v, np.int32 if k in ints else np.float32) for k, v in arrays.items()}


GOAL_KEYS = ("goal", "course", "left")


def _run_rewards(grid, arrays, task=TASK, reward=REW, table=None):
    """The kernel's (reward, terms, prev_xy, prev_actions) and the float64 reference's, on ``grid``."""
    n = len(arrays["joint_q"])
    dev = {k: wp.array(v, dtype=wp.vec2, device=DEV) if k == "prev_xy" else wp.array(v, device=DEV)
           for k, v in arrays.items() if k not in GOAL_KEYS}  # fmt: skip
    goals = goals_from_host(DEV, *(arrays[k] for k in GOAL_KEYS))
    inputs = make_struct(RewardInputs, hf=height_field_from_grid(grid, DEV), task=task, reward=reward, goals=goals,
                         **dev)  # fmt: skip
    cols = len(table or REWARD_TERMS)
    rew, terms = wp.zeros(n, device=DEV), wp.zeros((n, cols), device=DEV)
    kernel = rewards_kernel if table is None else make_rewards_kernel(table)
    wp.launch(kernel, dim=n, inputs=[inputs, reward_weights(reward, table or REWARD_TERMS)], outputs=[rew, terms],
              device=DEV)  # fmt: skip
    q = arrays["joint_q"]
    with np.errstate(invalid="ignore"):
        ground = terrain_height_np(grid, np.nan_to_num(q[:, 0]), np.nan_to_num(q[:, 1]))
    ns = SimpleNamespace(**{k: v for k, v in arrays.items() if k not in GOAL_KEYS}, ground=ground, task=task,
                         reward=reward, goals=SimpleNamespace(**{k: arrays[k] for k in GOAL_KEYS}))  # fmt: skip
    ref = rewards_reference(ns) if table is None else rewards_reference(ns, table)
    return (rew.numpy(), terms.numpy(), dev["prev_xy"].numpy(), dev["prev_actions"].numpy()), ref


def _random_reward_arrays(rng, n, grid):
    q = np.zeros((n, 25))
    # keep sample points off 1 cm cell edges (float32 vs float64 cell index)
    q[:, 0] = (np.floor(rng.uniform(-0.5, 3.5, n) / 0.01) + 0.5) * 0.01
    q[:, 1] = (np.floor(rng.uniform(-1.0, 1.0, n) / 0.01) + 0.5) * 0.01
    q[:, 2] = terrain_height_np(grid, q[:, 0], q[:, 1]) + rng.uniform(0.02, 0.2, n)
    quat = rng.normal(size=(n, 4))
    q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    q[: n // 32, rng.integers(0, 3)] = np.nan  # blown-up envs: their state terms are 0
    return _reward_arrays(n, q, joint_qd=rng.normal(0.0, 2.0, (n, 24)), rpy=rng.uniform(-1.2, 1.2, (n, 3)),
                          status=rng.integers(0, 5, n), episode_steps=rng.integers(0, 3, n),
                          actions=rng.uniform(-1.3, 1.3, (n, 15)), start=rng.uniform(-0.2, 0.2, (n, 2)),
                          prev_xy=q[:, :2] - rng.uniform(-0.01, 0.01, (n, 2)),
                          prev_actions=rng.uniform(-1.0, 1.0, (n, 15)))  # fmt: skip


def test_reward_kernel_matches_reference_on_random_states():
    """Every column of the fused kernel against its row's float64 NumPy function, the reward against their sum,
    and the state kept for the next step (prev_xy, clamped actions)."""
    rng = np.random.default_rng(1)
    n = 256
    grid = make_terrain(TerrainConfig(name="complex")).grid
    arrays = _random_reward_arrays(rng, n, grid)
    arrays["actions"][3, 2] = np.nan  # a non-finite action counts as 0
    shaping = dict(w_tilt=2.0, w_ang_vel=0.05, w_action_rate=0.3)
    # ours; 40 ms control; Table 1 as written; a wider stability tilt (--env.reward.stability_tilt) with the shaping on;
    # the MX-Phoenix's heights (height_scale 1.7) with Table 1's reward and ours
    for task, reward in ((TASK, REW), (dataclasses.replace(TASK, control_dt=0.04), REW), (TASK, REW.paper_reward()),
                         (TASK, dataclasses.replace(REW, stability_tilt=0.8, **shaping)), (MX_TASK, REW.paper_reward()),
                         (MX_TASK, REW)):  # fmt: skip
        (rew, terms, px, prev), (ref_rew, ref_terms, ref_px, ref_prev) = _run_rewards(grid, arrays, task, reward)
        assert terms.shape == (n, len(REWARD_TERMS)) and np.isfinite(rew).all()
        for k, name in enumerate(REWARD_NAMES):
            np.testing.assert_allclose(terms[:, k], ref_terms[:, k], rtol=1e-4, atol=1e-4, err_msg=name)
        np.testing.assert_allclose(rew, ref_rew, rtol=1e-4, atol=1e-3)
        np.testing.assert_allclose(px, ref_px, atol=1e-6)
        np.testing.assert_allclose(prev, ref_prev, atol=1e-6)
    blown = np.arange(n // 32)
    assert np.all(terms[blown][:, [k for k, t in enumerate(REWARD_TERMS) if t.state]] == 0.0) and np.all(px[blown] == 0)


def test_reward_terms_on_hand_made_states():
    grid = make_terrain(TerrainConfig(name="flat")).grid
    # 0: upright at 0.13 m, facing the goal, 1 cm progress in a 20 ms step, 3 m from the goal
    # 1: fallen (status), tilted 40 deg, no progress; 2: reached the goal; 3: facing backward;
    # 4: left the course (status), stuck (no progress)
    q = np.zeros((5, 25))
    q[:, 2] = [0.13, 0.04, 0.13, 0.13, 0.13]
    q[:, 0] = [0.5, 0.5, 3.2, 0.5, 0.5]
    rpy = np.array([[0, 0, 0], [0.7, 0, 0], [0, 0, 0], [0, 0, math.pi], [0, 0, 0]])
    status = np.array([0, FELL, SUCCESS, 0, OFF_COURSE])
    prev_xy = q[:, :2] - np.array([[0.01, 0.0], [0.0, 0.0], [0.01, 0.0], [0.01, 0.0], [0.0, 0.0]])

    def terms(reward=REW):
        (_, t, _, _), _ = _run_rewards(grid, _reward_arrays(5, q.copy(), rpy=rpy, status=status, prev_xy=prev_xy),
                                       reward=reward)  # fmt: skip
        return dict(zip(REWARD_NAMES, t.T))

    t = terms()
    np.testing.assert_allclose(t["height"], [0.02, 0.0, 0.02, 0.02, 0.02], atol=1e-6)  # z - 0.11 when z > 0.12
    np.testing.assert_allclose(t["distance"][0], math.exp(-(3.0 - 0.5)), rtol=1e-5)  # exp(-(d_n - d_t))
    np.testing.assert_allclose(t["stability"], [0, -100, 0, 0, 0])
    np.testing.assert_allclose(t["forward"], [0, -0.3, 0, 0, -0.3])
    np.testing.assert_allclose(t["goal"], [0, 0, 300, 0, 0])  # ours: more than lingering by the goal is worth
    np.testing.assert_allclose(t["off_course"], [0, 0, 0, 0, -100])  # ours: leaving the course costs a fall
    np.testing.assert_allclose(t["fall"], [0, 0, 0, 0, 0])  # ours, off by default
    np.testing.assert_allclose(terms(dataclasses.replace(REW, fall_penalty=200.0))["fall"], [0, -200, 0, 0, 0])
    np.testing.assert_allclose(t["direction"], [0, 0, 0, -2.0, 0], atol=1e-6)  # default dead band 0
    # pitched 35 deg nose-up (an 8 cm staircase): fined under Table 1's pi/6, free under --env.reward.stability_tilt 0.8
    rpy[0, 1] = -math.radians(35)
    for tilt, expect in ((math.pi / 6, -100.0), (0.8, 0.0)):
        assert terms(dataclasses.replace(REW, stability_tilt=tilt))["stability"][0] == pytest.approx(expect)
    rpy[0, 1] = 0.0
    # Table 1's dead band: a 20 deg heading error is free inside +-30 deg, and costs cos(20 deg) - 1 without it
    rpy[0, 2] = math.radians(20)
    for deadband, expect in ((math.pi / 6, 0.0), (0.0, math.cos(math.radians(20)) - 1)):
        got = terms(dataclasses.replace(REW, direction_deadband=deadband))["direction"][0]
        assert got == pytest.approx(expect, abs=1e-6)
    # 1 m to the side of the start, 2 m short of the goal: facing +x is the paper's ideal heading; ours asks
    # for the bearing to the goal, atan2(-1, 2)
    q[0, :2], bearing = (1.5, 1.0), math.atan2(-1.0, 2.0)
    prev_xy[0] = (1.49, 1.0)
    for yaw, to_goal, expect in ((0.0, False, 0.0), (0.0, True, math.cos(bearing) - 1), (bearing, True, 0.0)):
        rpy[0, 2] = yaw
        got = terms(dataclasses.replace(REW, direction_to_goal=to_goal))["direction"][0]
        assert got == pytest.approx(expect, abs=1e-6)


def test_shaping_terms_on_hand_made_states():
    grid = make_terrain(TerrainConfig(name="flat")).grid
    q = np.zeros((3, 25))
    q[:, 2], q[:, 6] = 0.13, 1.0  # upright, yaw 0: the body frame is the world frame
    qd = np.zeros((3, 24))
    qd[1, 3:6] = (1.0, 2.0, 5.0)  # roll rate 1, pitch rate 2 rad/s; the yaw rate is free
    rpy = np.array([[math.radians(10), 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    a = np.zeros((3, 15))
    a[2, 0] = 1.0
    prev = np.zeros((3, 15))
    prev[2, 0] = -1.0
    from hexnewton.tasks import STABLE_SHAPING

    w = STABLE_SHAPING
    reward = dataclasses.replace(REW, **w)

    def run(steps):
        arrays = _reward_arrays(3, q.copy(), joint_qd=qd, rpy=rpy, actions=a, prev_actions=prev, episode_steps=steps)
        (rew, t, _, new_prev), _ = _run_rewards(grid, arrays, reward=reward)
        (base, _, _, _), _ = _run_rewards(grid, arrays)  # the same state without the shaping
        return dict(zip(REWARD_NAMES, t.T)), rew - base, new_prev

    t, extra, new_prev = run([5, 5, 5])
    np.testing.assert_allclose(t["tilt"], [-w["w_tilt"] * math.radians(10) ** 2, 0, 0], rtol=1e-5)
    np.testing.assert_allclose(t["ang_vel"], [0, -w["w_ang_vel"] * 5.0, 0], rtol=1e-5)
    np.testing.assert_allclose(t["action_rate"], [0, 0, -w["w_action_rate"] * 4.0], rtol=1e-5)  # (1 - (-1))^2
    np.testing.assert_allclose(extra, t["tilt"] + t["ang_vel"] + t["action_rate"], rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(new_prev, a)
    # an episode's first step has no previous action; Table 1's reward has none of these terms
    t, _, _ = run([0, 0, 0])
    assert t["action_rate"][2] == 0.0
    paper = REW.paper_reward()
    assert (paper.w_tilt, paper.w_ang_vel, paper.w_action_rate, paper.goal_bonus, paper.off_course_penalty,
            paper.fall_penalty) == (0,) * 6
    assert paper.direction_deadband == pytest.approx(math.pi / 6) and not paper.direction_to_goal


def test_reward_table_drives_kernel_reference_and_log():
    """The kernel's columns, the reference and the log names follow the table: a table with its rows reversed and
    one row added (a cost on the lateral offset, weighed by an existing config field) gives a kernel whose columns
    are those rows, each equal to its NumPy function, and whose reward is their sum."""
    assert len(set(REWARD_NAMES)) == len(REWARD_NAMES) and all(hasattr(REW, t.weight) for t in REWARD_TERMS)

    @wp.func
    def lateral(inputs: RewardInputs, frame: RewardFrame) -> float:
        return wp.abs(frame.py - inputs.goals.goal[frame.env][1])

    table = tuple(reversed(REWARD_TERMS)) + (
        RewardTerm("lateral", "w_height", lateral, lambda inputs, frame: np.abs(frame.py - inputs.goals.goal[:, 1]),
                   cost=True),
    )
    grid = make_terrain(TerrainConfig(name="rugged")).grid
    arrays = _random_reward_arrays(np.random.default_rng(3), 128, grid)
    reward = dataclasses.replace(REW, w_tilt=1.0, w_ang_vel=0.1, w_action_rate=0.2, w_height=2.0)
    (rew, terms, _, _), (ref_rew, ref_terms, _, _) = _run_rewards(grid, arrays, reward=reward, table=table)
    (_, base_terms, _, _), _ = _run_rewards(grid, arrays, reward=reward)
    assert terms.shape == (128, len(REWARD_TERMS) + 1)
    np.testing.assert_array_equal(terms[:, : len(REWARD_TERMS)], base_terms[:, ::-1])  # same values, table order
    np.testing.assert_allclose(terms, ref_terms, rtol=1e-4, atol=1e-4)
    np.testing.assert_allclose(terms[:, -1], -2.0 * np.abs(arrays["joint_q"][:, 1] - arrays["goal"][:, 1])
                               * np.isfinite(arrays["joint_q"][:, :3]).all(axis=1), rtol=1e-5, atol=1e-6)  # fmt: skip
    np.testing.assert_allclose(rew, ref_rew, rtol=1e-4, atol=1e-3)
    np.testing.assert_allclose(rew, terms.sum(axis=1), rtol=1e-5, atol=1e-4)
    # the env logs Reward/<name> for exactly the table's rows, and Episode/<name>_rate for each end
    env = make_env(HexConfig(sim=SimConfig(num_envs=2, device=DEV), terrain=TerrainConfig(name="flat")))
    log = env.step(torch.zeros(2, 15))[3]["log"]
    assert [k for k in log if k.startswith("Reward/")] == [f"Reward/{t.name}" for t in REWARD_TERMS]
    assert {k for k in log if k.endswith("_rate") and k.startswith("Episode/")} == {
        f"Episode/{t.name}_rate" for t in TERMINATIONS}  # fmt: skip
    assert env.terms.shape == (2, len(REWARD_TERMS))


def test_a_task_chooses_its_terms():
    """``RewardConfig.terms`` and ``TaskConfig.terminations`` choose table rows: the env pays and logs only the
    chosen reward terms (their sum is the reward), checks only the chosen ends (without ``timeout`` an episode runs past
    its step limit), and a name that is no row, or ends without ``nonfinite``, are one-line errors; the default is every
    row."""
    assert REW.terms == REWARD_NAMES and TaskConfig().terminations == tuple(t.name for t in TERMINATIONS)
    chosen = ("distance", "forward", "height")
    cfg = HexConfig(sim=SimConfig(num_envs=2, device=DEV), terrain=TerrainConfig(name="flat"),
                    task=dataclasses.replace(TaskConfig(), max_episode_steps=3, terminations=("nonfinite", "fell")),
                    reward=dataclasses.replace(REW, terms=chosen))  # fmt: skip
    env = make_env(cfg)
    for _ in range(4):
        _, rew, done, extras = env.step(torch.zeros(2, 15))
    assert [k for k in extras["log"] if k.startswith("Reward/")] == ["Reward/height", "Reward/distance", "Reward/forward"]
    assert env.terms.shape == (2, 3)
    np.testing.assert_allclose(rew.numpy(), env.terms.numpy().sum(axis=1), rtol=1e-6)
    assert not done.any() and (env.episode_steps.numpy() == 4).all()  # no timeout row: past max_episode_steps
    with pytest.raises(ValueError, match="reward.terms: no term speed; choose from height, direction"):
        make_env(dataclasses.replace(cfg, reward=dataclasses.replace(REW, terms=("height", "speed"))))
    with pytest.raises(ValueError, match="task.terminations must include nonfinite"):
        make_env(dataclasses.replace(cfg, task=dataclasses.replace(TaskConfig(), terminations=("fell",))))
    paper = RewardConfig().paper_reward()
    assert paper.terms == ("height", "direction", "distance", "stability", "forward")


def test_config_structs_follow_the_config():
    """The terms read the configuration through structs generated from TaskConfig and RewardConfig: every scalar
    field, same name and value."""
    for struct, cfg in ((TaskParams, TASK), (RewardParams, REW.paper_reward())):
        scalars = [f.name for f in dataclasses.fields(cfg) if isinstance(getattr(cfg, f.name), (bool, int, float))]
        assert list(struct.vars) == scalars
        s = config_params(struct, cfg)
        for name in scalars:
            assert getattr(s, name) == pytest.approx(getattr(cfg, name))
    with pytest.raises(TypeError, match="missing"):
        make_struct(RewardInputs, task=TASK)


# ------------------------------------------------------------------ terminations (§2.4.4)


def test_termination_table_covers_every_status_once():
    """One row per status code 1..5, named as in kernels/reference.py; the blow-up check comes first (its rpy is 0)."""
    assert sorted(t.code for t in TERMINATIONS) == list(range(1, len(STATUS_NAMES)))
    assert [t.name for t in sorted(TERMINATIONS, key=lambda t: t.code)] == list(STATUS_NAMES[1:])
    assert TERMINATIONS[0].name == "nonfinite" and [t.name for t in TERMINATIONS[1:]] == ["fell", "off_course",
                                                                                           "success", "timeout"]


# ------------------------------------------------------------------ observations (§2.4.1)


def test_observation_layout_covers_59_62_and_44():
    """The base layouts (the paper's 59, with the posture 62, pure DRL 44) and each with ObsConfig's switches: the gyro
    (3) and the last actions (one per action) appended, the other columns where they were."""
    assert {base: OBS_DIM[base] for base in BASE_LAYOUTS} == {"cpg": 59, "cpg_posture": 62, "joint": 44}
    assert set(OBS_DIM) == set(LAYOUTS) and LAYOUTS[:3] == BASE_LAYOUTS and len(LAYOUTS) == 3 * 4
    for base, actions in (("cpg", 15), ("cpg_posture", 18), ("joint", 18)):
        assert OBS_DIM[base + "+gyro"] == OBS_DIM[base] + 3
        assert OBS_DIM[base + "+last_action"] == OBS_DIM[base] + actions
        both = layout_name(base, ObsConfig(gyro=True, last_action=True, critic=True))
        assert both == base + "+gyro+last_action" and OBS_DIM[both] == OBS_DIM[base] + 3 + actions
        assert OBS_LAYOUT[both][: len(OBS_LAYOUT[base])] == OBS_LAYOUT[base]
        assert [name for name, _, _ in OBS_LAYOUT[both][-2:]] == ["gyro", "last_action"]
        assert layout_name(base, ObsConfig()) == base and layout_parts(both) == (base, ("gyro", "last_action"))
    for mode, dim in OBS_DIM.items():
        spans = OBS_LAYOUT[mode]
        assert spans[0][1] == 0 and spans[-1][2] == dim
        assert all(a[2] == b[1] for a, b in zip(spans, spans[1:]))
        assert [name for name, _, _ in spans] == [t.name for t in OBS_TERMS if t.carried_by(mode)]
    # the layout documented in the module docstring is the table's
    import hexnewton.mdp.terms.observations as obs_module

    assert "    [54:57]   body posture P_h, P_p, P_r [rad] (filtered)" in obs_module.__doc__


def test_observation_noise_follows_the_table():
    rz = RandomizationConfig(enabled=True)
    amp = {"joint_pos": rz.noise_joint_pos, "joint_vel": rz.noise_joint_vel, "target": rz.noise_target,
           "quat": rz.noise_quat, "max_height": rz.noise_height, "gyro": rz.noise_gyro}  # fmt: skip
    for layout in LAYOUTS:
        want = np.zeros(OBS_DIM[layout], np.float32)
        for name, a, b in OBS_LAYOUT[layout]:
            want[a:b] = amp.get(name, 0.0)  # the CPG parameters are the controller's own: exact
        np.testing.assert_array_equal(observation_noise(layout, rz), want)


def test_observation_kernel_matches_reference():
    rng = np.random.default_rng(2)
    n = 64
    grid = make_terrain(TerrainConfig(name="stepped")).grid
    q = np.zeros((n, 25), np.float32)
    q[:, 0] = (np.floor(rng.uniform(-0.5, 4.0, n) / 0.01) + 0.5) * 0.01
    q[:, 1] = (np.floor(rng.uniform(-1.0, 1.0, n) / 0.01) + 0.5) * 0.01
    q[:, 2] = rng.uniform(0.1, 1.0, n)
    quat = rng.normal(size=(n, 4))
    q[:, 3:7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    q[:, 7:] = rng.uniform(-1, 1, (n, 18))
    qd = rng.normal(size=(n, 24)).astype(np.float32)
    params = rng.uniform(0, 10, (n, 18)).astype(np.float32)
    # goals in every direction, on the stepped course's patch
    goal = np.stack([rng.uniform(-0.8, 4.8, n), rng.uniform(-2.4, 2.4, n)], axis=1).astype(np.float32)
    goal = ((np.floor(goal / 0.01) + 0.5) * 0.01).astype(np.float32)  # off 1 cm cell edges
    course = np.tile([1.0, 0.0], (n, 1))  # (the observation reads the goal alone)
    steps = rng.integers(0, 3, n).astype(np.int32)  # some envs at their episode's first step: no last actions yet
    hf = height_field_from_grid(grid, DEV)

    def ground_at(x, y):
        return terrain_height_np(grid, x, y)

    ground_at.max = lambda x, y, h: max_terrain_height_np(grid, x, y, h)
    # every layout: the paper's, with the posture, joint, each with the gyro and the last actions; the paper robot's and
    # the MX-Phoenix's heights and terrain window
    for layout, task in [(layout, task) for task in (TASK, MX_TASK) for layout in LAYOUTS]:
        npar = {"cpg": 15, "cpg_posture": 18, "joint": 10}[layout_parts(layout)[0]]  # joint: unread
        p = np.ascontiguousarray(params[:, :npar])
        actions = rng.uniform(-1, 1, (n, LAYOUT_ACTIONS[layout_parts(layout)[0]])).astype(np.float32)
        out = wp.zeros((n, OBS_DIM[layout]), dtype=wp.float32, device=DEV)
        inputs = make_struct(ObsInputs, joint_q=wp.array(q, device=DEV), joint_qd=wp.array(qd, device=DEV),
                             params=wp.array(p, device=DEV), goals=goals_from_host(DEV, goal, course, np.zeros(n)),
                             actions=wp.array(actions, device=DEV), episode_steps=wp.array(steps, device=DEV), hf=hf,
                             task=task)  # fmt: skip
        wp.launch(observations_kernel, dim=n, inputs=[inputs, LAYOUTS.index(layout)], outputs=[out], device=DEV)
        ns = SimpleNamespace(joint_q=q, joint_qd=qd, params=p, goals=SimpleNamespace(goal=goal), actions=actions,
                             episode_steps=steps, ground_at=ground_at, task=task)  # fmt: skip
        ref = observations_reference(ns, layout)
        assert ref.shape == (n, OBS_DIM[layout])
        np.testing.assert_allclose(out.numpy(), ref, atol=2e-4, rtol=1e-4)
        for name, a, b in OBS_LAYOUT[layout]:  # each part where the layout puts it
            row = next(t for t in OBS_TERMS if t.name == name)
            np.testing.assert_allclose(out.numpy()[:, a:b], row.reference(ns), atol=2e-4, rtol=1e-4, err_msg=name)
