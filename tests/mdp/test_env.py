"""The rsl-rl VecEnv (hexnewton/mdp/env.py): API conformance, the PPO storage contract, blow-ups, time-outs, the
joint action mode, posture and shaping in the step, the heading-frame target; the Gymnasium wrapper (the reward, end
and observation tables: tests/mdp/test_terms.py)."""

import dataclasses
import math

import numpy as np
import pytest
import torch
import warp as wp
from tensordict import TensorDict

from hexnewton.config import HexConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.mdp.env import make_env
from hexnewton.mdp.events import reset_bounds_reference
from hexnewton.mdp.status import NONFINITE, TIMEOUT
from hexnewton.mdp.terms import OBS_LAYOUT, REWARD_NAMES
from hexnewton.kernels.cpg import joint_actions_kernel
from hexnewton.kernels.reference import joint_actions_reference

DEV = "cpu"
TASK = TaskConfig()


def _cfg(terrain="flat", n=4, **task):
    return HexConfig(sim=SimConfig(num_envs=n, device=DEV), terrain=TerrainConfig(name=terrain), task=TaskConfig(**task))


@pytest.fixture(scope="module")
def env():
    return make_env(_cfg("rugged", 6))


def test_vecenv_api(env):
    obs = env.get_observations()
    assert isinstance(obs, TensorDict) and obs["policy"].shape == (6, 59) and obs["policy"].dtype == torch.float32
    assert env.num_actions == 15 and env.max_episode_length == 7000
    obs, rew, done, extras = env.step(torch.zeros(6, 15))
    assert obs["policy"].shape == (6, 59) and torch.isfinite(obs["policy"]).all()
    assert rew.shape == (6,) and rew.dtype == torch.float32
    assert done.shape == (6,) and extras["time_outs"].shape == (6,)
    # the torch device, public: the env's tensors are on it, and rsl-rl's VecEnv.device names it
    assert isinstance(env.device_torch, torch.device) and obs["policy"].device == rew.device == env.device_torch
    assert torch.device(str(env.device)) == env.device_torch
    assert all(k.count("/") == 1 and v.dim() == 0 for k, v in extras["log"].items())
    assert {f"Reward/{t}" for t in REWARD_NAMES} <= set(extras["log"])
    # rsl-rl's learn(init_at_random_ep_len=True) assigns a new tensor: it must reach the Warp buffer
    env.episode_length_buf = torch.randint_like(env.episode_length_buf, high=100)
    assert np.array_equal(env.episode_steps.numpy(), env.episode_length_buf.numpy())


def test_returned_tensors_outlive_the_next_step(env):
    """``step`` returns copies: the observation an action was computed from is still intact after the next step,
    as rsl-rl needs (it stores that observation only in ``process_env_step``, after ``env.step``)."""
    obs = env.get_observations()["policy"]
    kept = obs.clone()
    out = env.step(torch.zeros(6, 15))
    kept2 = [t.clone() for t in (out[0]["policy"], out[1], out[2], out[3]["time_outs"])]
    env.step(torch.ones(6, 15))
    assert torch.equal(obs, kept) and not torch.equal(obs, env.get_observations()["policy"])
    for t, k in zip((out[0]["policy"], out[1], out[2], out[3]["time_outs"]), kept2):
        assert torch.equal(t, k)


def test_ppo_stores_the_observation_each_action_was_taken_from():
    """Before its first optimizer step, PPO recomputes the stored actions' Gaussians from the stored observations:
    they must equal the ones the actions were sampled from (KL 0). With observations one step late the KL was
    ~0.04-0.2, and rsl-rl's adaptive schedule held the learning rate at its 1e-5 floor."""
    import copy
    import tempfile

    from rsl_rl.runners import OnPolicyRunner

    from hexnewton.learning.agent import AgentConfig

    env = make_env(_cfg("flat", 8))
    tcfg = AgentConfig(num_steps_per_env=8).to_rsl_rl(8)
    runner = OnPolicyRunner(env, copy.deepcopy(tcfg), log_dir=tempfile.mkdtemp(prefix="hexnewton-kl-"), device=DEV)
    kls, kl = [], runner.alg.actor.get_kl_divergence
    runner.alg.actor.get_kl_divergence = lambda old, new: kls.append(float(kl(old, new).mean())) or kl(old, new)
    runner.learn(1)
    # float32 rounding of the batched recomputation leaves ~1e-9 (BLAS paths vary with the batch and the threads)
    assert len(kls) == 8 and kls[0] < 1e-6, kls[:3]


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_ppo_update_options_reach_rsl_rl():
    """AgentConfig's update options: fewer mini-batches and epochs, torch.compile and bfloat16 autocast are rsl-rl's
    own; the runner must train with them (here on the CPU, inductor's C++ backend)."""
    import copy
    import tempfile

    from rsl_rl.runners import OnPolicyRunner

    from hexnewton.learning.agent import AgentConfig, AlgorithmConfig, DistributionConfig

    env = make_env(_cfg("flat", 8))
    agent = AgentConfig(num_steps_per_env=8, torch_compile="default", distribution=DistributionConfig(name="gaussian"),
                        algorithm=AlgorithmConfig(num_mini_batches=3, num_learning_epochs=3, use_mixed_precision=True))
    agent.check()
    with pytest.raises(ValueError, match="Beta"):
        AgentConfig(algorithm=AlgorithmConfig(use_mixed_precision=True)).check()
    tcfg = agent.to_rsl_rl(8)
    runner = OnPolicyRunner(env, copy.deepcopy(tcfg), log_dir=tempfile.mkdtemp(prefix="hexnewton-up-"), device=DEV)
    alg = runner.alg
    assert alg.use_mixed_precision and alg.actor is not alg.get_policy()  # compiled wrapper; raw module exported
    batches = []
    gen = alg.storage.mini_batch_generator
    alg.storage.mini_batch_generator = lambda n, e: batches.append((n, e)) or gen(n, e)
    runner.learn(1)
    assert batches == [(3, 3)]  # not the preset's 2 x 4
    assert all(torch.isfinite(p).all() for p in alg.get_policy().parameters())


def test_std_max_caps_the_sampling_std():
    """agent.distribution.std_max: rsl-rl's std_range clamps the Gaussian in training, and action_std (export, deploy bundle) reports
    the clamped value, not the raw parameter."""
    import copy

    from rsl_rl.runners import OnPolicyRunner

    from hexnewton.learning.agent import AgentConfig, DistributionConfig
    from hexnewton.learning.policy import action_std

    env = make_env(_cfg("flat", 8))
    agent = AgentConfig(distribution=DistributionConfig(name="gaussian", std_max=0.3))
    runner = OnPolicyRunner(env, copy.deepcopy(agent.to_rsl_rl(8)), log_dir=None, device=DEV)
    policy = runner.alg.get_policy()
    with torch.no_grad():
        policy.distribution.std_param.fill_(5.0)
    policy(env.get_observations(), stochastic_output=True)
    assert torch.allclose(policy.distribution.std, torch.full((8, 15), 0.3))
    assert action_std(policy) == pytest.approx([0.3] * 15)


@pytest.mark.parametrize("where", ["velocity", "runaway", "joint angle"])
def test_blown_up_env_is_reset_counted_and_isolated(where):
    """Corrupt one env's state: it ends as nonfinite, is reset and counted; observations and rewards stay
    finite; the other envs go on exactly as in an untouched twin."""
    a, b = make_env(_cfg("flat", 4)), make_env(_cfg("flat", 4))
    act = torch.zeros(4, 15)
    for env in (a, b):
        for _ in range(5):
            env.step(act)
    qd, q = b.world.joint_qd, b.world.joint_q
    if where == "velocity":
        qd[1, 8] = float("nan")
    elif where == "runaway":
        qd[1, 0] = 2.0 * TASK.max_base_speed
    else:
        q[1, 12] = float("inf")
    _, ra, _, _ = a.step(act)
    ob, rb, db, extras = b.step(act)
    assert b.status.numpy()[1] == NONFINITE and int(db[1]) == 1
    assert torch.isfinite(ob["policy"]).all() and torch.isfinite(rb).all()
    assert float(extras["log"]["Episode/nonfinite_resets_total"]) == 1.0
    assert torch.isfinite(b.world.joint_q).all() and torch.isfinite(b.world.joint_qd).all()
    others = [0, 2, 3]
    np.testing.assert_array_equal(b.last_q.numpy()[others], a.last_q.numpy()[others])
    np.testing.assert_array_equal(rb.numpy()[others], ra.numpy()[others])
    for _ in range(10):  # the reset env walks on (no NaN left in the solver's warm start)
        ob, rb, _, _ = b.step(act)
        a.step(act)
    assert torch.isfinite(b.world.joint_q).all() and b.episode_stats()["nonfinite_resets_total"] == 1
    np.testing.assert_array_equal(b.last_q.numpy()[others], a.last_q.numpy()[others])


def test_time_outs_and_auto_reset():
    env = make_env(_cfg("flat", 3, max_episode_steps=5))
    for k in range(5):
        _, _, done, extras = env.step(torch.zeros(3, 15))
        assert done.sum() == (3 if k == 4 else 0)
    assert torch.all(extras["time_outs"] == 1) and np.all(env.status.numpy() == TIMEOUT)
    assert np.all(env.episode_steps.numpy() == 0)
    assert env.episode_stats()["timeout_rate"] == 1.0 and env.episode_stats()["length_steps"] == 5.0
    q = env.world.numpy_q()
    assert reset_bounds_reference(env.world.spawn_xy, env.world.spawn_z, HexConfig().robot.stand_pose,
                                  (-math.pi / 6, 0, -math.pi / 3), (math.pi / 6, math.pi / 2, 0), TASK.reset_lateral,
                                  TASK.reset_yaw, TASK.reset_joint_noise, q)  # fmt: skip
    np.testing.assert_allclose(env.start.numpy(), q[:, :2], atol=1e-6)


def test_joint_action_mode():
    env = make_env(_cfg("flat", 2), action_mode="joint")
    assert env.num_actions == 18 and env.get_observations()["policy"].shape == (2, 44)
    env.step(torch.ones(2, 18))  # standing pose + 0.5 rad, clipped to the limits
    t = env.world.joint_target.numpy()
    np.testing.assert_allclose(t.reshape(2, 6, 3), np.broadcast_to([0.5, 0.65, 0.0], (2, 6, 3)), atol=1e-6)
    env = make_env(_cfg("flat", 2, joint_action_scale=0.0), action_mode="joint")  # the whole limit range
    env.step(torch.ones(2, 18))
    t = env.world.joint_target.numpy()
    np.testing.assert_allclose(t.reshape(2, 6, 3), np.broadcast_to([math.pi / 6, math.pi / 2, 0.0], (2, 6, 3)), atol=1e-6)


def test_joint_actions_kernel_matches_reference():
    """Pure DRL's joint targets: offsets about the standing pose (scale > 0) or the whole limit range (scale 0)."""
    rng = np.random.default_rng(0)
    a = rng.uniform(-1.5, 1.5, (16, 18)).astype(np.float32)
    a[0, :3] = (np.nan, np.inf, -np.inf)
    stand, lo, hi = (0.0, 0.15, -0.15), (-0.5, 0.0, -1.0), (0.5, 1.5, 0.0)
    for scale in (0.5, 0.2, 0.0):
        out = wp.zeros((16, 25), dtype=wp.float32, device=DEV)
        wp.launch(joint_actions_kernel, dim=(16, 18),
                  inputs=[wp.array(a, device=DEV), wp.vec3(*stand), wp.vec3(*lo), wp.vec3(*hi), scale, 7],
                  outputs=[out], device=DEV)  # fmt: skip
        ref = joint_actions_reference(a, stand, lo, hi, scale)
        np.testing.assert_allclose(out.numpy()[:, 7:], ref, atol=1e-6)
        assert np.isfinite(ref).all() and (ref >= np.tile(lo, 6)).all() and (ref <= np.tile(hi, 6)).all()
    assert np.allclose(joint_actions_reference(np.zeros((1, 18)), stand, lo, hi, 0.5), np.tile(stand, 6))


def test_posture_env_acts_with_18_and_levels_with_the_reflex():
    """The body posture adds 3 actions and 3 observations; the reflex bends the knees against the measured tilt."""
    cfg = _cfg("flat", 2, reset_yaw=0.0, reset_lateral=0.0, reset_joint_noise=0.0)
    cfg.cpg = dataclasses.replace(cfg.cpg, posture=True, posture_reflex=2.0)
    env = make_env(cfg)
    assert env.num_actions == 18 and env.num_obs == 62 and env.obs_layout == "cpg_posture"
    obs, rew, done, _ = env.step(torch.zeros(2, 18))
    assert obs["policy"].shape == (2, 62) and torch.isfinite(obs["policy"]).all() and torch.isfinite(rew).all()
    sl = {name: slice(a, b) for name, a, b in OBS_LAYOUT["cpg_posture"]}
    np.testing.assert_allclose(obs["policy"][:, sl["posture"]].numpy(), 0.0, atol=1e-6)  # action 0: neutral
    q = env.world.joint_q
    q[:, 3:7] = q.new_tensor([0.0, math.sin(0.05), 0.0, math.cos(0.05)])  # pitched by 0.1 rad
    env.cpg(env.world)  # one CPG + mapping substep on this attitude
    knee = env.world.joint_target_wp.numpy()[:, 7:].reshape(2, 6, 3)[:, :, 1]
    stand = cfg.robot.stand_pose[1]
    # P_p' = -2 * 0.1 lowers the front knees' targets and raises the rear ones (swing lift only adds to the knee)
    assert np.all(knee[:, [0, 3]] <= knee[:, [2, 5]] - 0.3) and np.all(knee[:, [2, 5]] >= stand + 0.19)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_set_shaping_recaptures_the_step_with_new_weights_and_reflex():
    """A curriculum stage (``set_shaping``) between steps: the same weights again leave the rollout as it was (the
    step is captured again from the same state), a heavier tilt penalty lowers the reward, the reflex moves the
    joint targets."""
    cfg = _cfg("rugged", 2, reset_yaw=0.0, reset_lateral=0.0, reset_joint_noise=0.0)
    cfg.cpg = dataclasses.replace(cfg.cpg, posture=True)
    cfg.reward = dataclasses.replace(cfg.reward, w_tilt=5.0)
    envs = [make_env(cfg) for _ in range(3)]
    act = torch.full((2, 18), 0.3)
    for _ in range(5):
        outs = [env.step(act) for env in envs]
    envs[1].set_shaping(cfg.reward, 0.0)  # unchanged
    envs[2].set_shaping(dataclasses.replace(cfg.reward, w_tilt=5000.0), 2.0)
    assert envs[2].cpg.cfg.posture_reflex == 2.0 and envs[2].cfg.reward.w_tilt == 5000.0
    outs = [env.step(act) for env in envs]
    torch.testing.assert_close(outs[1][0]["policy"], outs[0][0]["policy"])
    torch.testing.assert_close(outs[1][1], outs[0][1])
    assert torch.all(outs[2][1] < outs[0][1])
    targets = [env.world.joint_target_wp.numpy() for env in envs]
    assert np.abs(targets[2] - targets[0]).max() > 1e-3


def test_target_is_in_the_heading_frame():
    env = make_env(_cfg("flat", 1, reset_yaw=0.0, reset_lateral=0.0))
    q = env.world.joint_q
    q[0, 3:7] = q.new_tensor([0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)])  # facing +y (yaw 90 deg)
    env._observe()
    obs = env.get_observations()["policy"][0]
    sl = {name: slice(a, b) for name, a, b in OBS_LAYOUT["cpg"]}
    start_y = env.start.numpy()[0, 1]
    np.testing.assert_allclose(obs[sl["target"]][:2].numpy(), [start_y - q[0, 1].item(), -3.5], atol=1e-4)
    np.testing.assert_allclose(obs[sl["amplitudes"]].numpy(), HexConfig().cpg.fixed_params()[1:], rtol=1e-6)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_gymnasium_makes_a_task_by_its_id():
    """``gym.make("Hexnewton-<Task>-v0")`` after ``import hexnewton.tasks``: a batched env with torch tensors."""
    import gymnasium as gym

    import hexnewton.tasks  # noqa: F401

    env = gym.make("Hexnewton-Rugged-v0", num_envs=3, device=DEV, overrides={"sim.frame_dt": 0.01})
    obs, info = env.reset(seed=0)
    assert obs.shape == (3, 59) and env.unwrapped.single_action_space.shape == (15,)
    assert env.unwrapped.vec_env.cfg.terrain.name == "rugged" and env.unwrapped.vec_env.cfg.sim.frame_dt == 0.01
    for _ in range(3):
        obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert obs.shape == (3, 59) and reward.shape == (3,) and terminated.dtype == torch.bool
    assert torch.isfinite(obs).all() and "log" in info
    assert (env.unwrapped.vec_env.episode_length_buf == 3).all()
    obs, _ = env.reset()
    assert obs.shape == (3, 59) and (env.unwrapped.vec_env.episode_length_buf == 0).all()
    env.close()


def test_env_compiles_its_generated_kernels_before_the_first_step():
    """The episode-status and reward kernels an env generates for its task are loaded when the env is built (compiled
    in parallel there, not one by one by the first step: hexnewton.physics.precompile)."""
    e = make_env(_cfg("flat", 2, terminations=("nonfinite", "timeout")))
    context = wp.get_device(DEV).context
    for kernel in (e.status_kernel, e.rewards_kernel):
        assert any(ctx == context for ctx, _ in kernel.module.execs)


def test_a_curriculum_stage_moves_the_effort_clamp_to_the_actuators():
    """``HexapodEnv.set_effort_clamp("actuator")`` on a built env (a training stage's ``effort_clamp``): the
    mujoco_warp model's joint clamp off and every actuator clamped to its joint's limit, as a world built with it has
    them; the env's and the world's configs say so (checkpoints record it); the robots step on; the joint clamp does
    not come back (one-line ValueError)."""
    env = make_env(_cfg("flat", 3))
    built = make_env(dataclasses.replace(_cfg("flat", 3), sim=SimConfig(num_envs=3, device=DEV,
                                                                        effort_clamp="actuator")))  # fmt: skip
    mw = env.world.solver.mjw_model
    assert mw.jnt_actfrclimited.numpy().any() and not mw.actuator_forcelimited.numpy().any()
    actions = torch.zeros((3, env.num_actions))
    env.step(actions)
    env.set_effort_clamp("actuator")
    assert env.cfg.sim.effort_clamp == env.world.cfg.sim.effort_clamp == "actuator"
    ref = built.world.solver.mjw_model
    for name in ("jnt_actfrclimited", "actuator_forcelimited", "actuator_forcerange"):
        assert np.array_equal(getattr(mw, name).numpy(), getattr(ref, name).numpy()), name
    for _ in range(3):
        obs, *_ = env.step(actions)
    assert torch.isfinite(obs["policy"]).all()
    env.set_effort_clamp("actuator")  # already there: nothing to do
    with pytest.raises(ValueError, match="moves its clamp to the actuators, not back to 'joint'"):
        env.set_effort_clamp("joint")
