"""The rsl-rl VecEnv: API conformance, action / reset kernels vs NumPy, train.py -> play.py (the reward, end and
observation tables: tests/test_terms.py)."""

import dataclasses
import glob
import json
import math
import os
import re
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
import torch
import warp as wp
from tensordict import TensorDict

from hexnewton.config import HexConfig, RewardConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.env import make_env
from hexnewton.kernels.cpg import joint_actions_kernel
from hexnewton.kernels.mdp import NONFINITE, OBS_LAYOUT, REWARD_NAMES, TIMEOUT, reset_bounds_reference
from hexnewton.kernels.reference import joint_actions_reference

DEV = "cpu"
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TASK = TaskConfig()


def _cfg(terrain="flat", n=4, **task):
    return HexConfig(sim=SimConfig(num_envs=n, device=DEV), terrain=TerrainConfig(name=terrain), task=TaskConfig(**task))


@pytest.fixture(scope="module")
def env():
    return make_env(_cfg("rugged", 6))


# ------------------------------------------------------------------ API conformance


def test_vecenv_api(env):
    obs = env.get_observations()
    assert isinstance(obs, TensorDict) and obs["policy"].shape == (6, 59) and obs["policy"].dtype == torch.float32
    assert env.num_actions == 15 and env.max_episode_length == 7000
    obs, rew, done, extras = env.step(torch.zeros(6, 15))
    assert obs["policy"].shape == (6, 59) and torch.isfinite(obs["policy"]).all()
    assert rew.shape == (6,) and rew.dtype == torch.float32
    assert done.shape == (6,) and extras["time_outs"].shape == (6,)
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

    from hexnewton.agent import AgentConfig

    env = make_env(_cfg("flat", 8))
    tcfg = AgentConfig(num_steps_per_env=8).to_rsl_rl(8)
    runner = OnPolicyRunner(env, copy.deepcopy(tcfg), log_dir=tempfile.mkdtemp(prefix="hexnewton-kl-"), device=DEV)
    kls, kl = [], runner.alg.actor.get_kl_divergence
    runner.alg.actor.get_kl_divergence = lambda old, new: kls.append(float(kl(old, new).mean())) or kl(old, new)
    runner.learn(1)
    assert len(kls) == 8 and kls[0] < 1e-10, kls[:3]


def test_ppo_update_options_reach_rsl_rl():
    """AgentConfig's update options: fewer mini-batches and epochs, torch.compile and bfloat16 autocast are rsl-rl's
    own; the runner must train with them (here on the CPU, inductor's C++ backend)."""
    import copy
    import tempfile

    from rsl_rl.runners import OnPolicyRunner

    from hexnewton.agent import AgentConfig, AlgorithmConfig, DistributionConfig

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

    from hexnewton.agent import AgentConfig, DistributionConfig
    from hexnewton.policy import action_std

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
    np.testing.assert_allclose(env.world.start_wp.numpy(), q[:, :2], atol=1e-6)


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


# ------------------------------------------------------------------ rewards and observations in the env
# (the kernels against their float64 references: tests/test_terms.py)


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
    env.controller(env.world)  # one CPG + mapping substep on this attitude
    knee = env.world.joint_target_wp.numpy()[:, 7:].reshape(2, 6, 3)[:, :, 1]
    stand = cfg.robot.stand_pose[1]
    # P_p' = -2 * 0.1 lowers the front knees' targets and raises the rear ones (swing lift only adds to the knee)
    assert np.all(knee[:, [0, 3]] <= knee[:, [2, 5]] - 0.3) and np.all(knee[:, [2, 5]] >= stand + 0.19)


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
    assert envs[2].controller.cfg.posture_reflex == 2.0 and envs[2].cfg.reward.w_tilt == 5000.0
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
    start_y = env.world.start_wp.numpy()[0, 1]
    np.testing.assert_allclose(obs[sl["target"]][:2].numpy(), [start_y - q[0, 1].item(), -3.5], atol=1e-4)
    np.testing.assert_allclose(obs[sl["amplitudes"]].numpy(), HexConfig().cpg.fixed_params()[1:], rtol=1e-6)


# ------------------------------------------------------------------ train.py -> play.py


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    logs = tmp_path_factory.mktemp("logs")
    proc = subprocess.run(
        [sys.executable, "train.py", "--num_envs", "16", "--max_iterations", "2", "--device", "cpu", "--log_dir",
         str(logs), "--task", "flat", "--headless"],
        capture_output=True, text=True, timeout=900,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return logs, proc.stdout


def test_training_writes_checkpoint_onnx_and_tensorboard(trained):
    logs, out = trained
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    files = {p.rsplit("/", 1)[1] for p in glob.glob(run_dir + "/*")}
    assert {"model_0.pt", "model_1.pt", "policy.onnx", "config.json"} <= files
    assert any(f.startswith("events.out.tfevents") for f in files)
    assert "onnxruntime vs torch" in out
    import onnx

    model = onnx.load(run_dir + "/policy.onnx")  # one self-contained file, dynamic batch
    assert not glob.glob(run_dir + "/*.onnx.data")
    assert model.graph.input[0].type.tensor_type.shape.dim[0].dim_param
    assert model.graph.input[0].type.tensor_type.shape.dim[1].dim_value == 59


def test_play_loads_the_trained_checkpoint(trained):
    logs, _ = trained
    proc = subprocess.run([sys.executable, "play.py", "--controller", "cpg_rl", "--log_dir", str(logs), "--num_envs",
                           "2", "--steps", "10", "--device", "cpu", "--terrain", "flat", "stepped",
                           "--env.terrain.step_rise", "0.08", "--env.task.goal_distance", "5.5"],
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "[cpg_rl (" in proc.stdout and "model_1.pt" in proc.stdout


def test_play_without_arguments_plays_the_newest_policy(trained, tmp_path):
    """``python play.py``: the newest run's checkpoint on the terrain it was trained on; with nothing trained, the
    shipped complex policy; a checkpoint given to the fixed CPG is an error, never ignored."""
    logs, _ = trained
    base = [sys.executable, "play.py", "--num_envs", "1", "--steps", "3", "--device", "cpu", "--no-progress"]
    proc = subprocess.run([*base, "--log_dir", str(logs)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "playing " in proc.stdout and "model_1.pt" in proc.stdout and "[cpg_rl (" in proc.stdout
    assert "flat" in proc.stdout.split("[cpg_rl (")[1]
    proc = subprocess.run([*base, "--log_dir", str(tmp_path / "none")], capture_output=True, text=True, timeout=600,
                          cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "cpg_rl_complex.pt" in proc.stdout and "complex" in proc.stdout.split("[cpg_rl (")[1]
    proc = subprocess.run([*base, "--controller", "cpg", "--checkpoint", "x.pt"], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 2 and "the fixed CPG (--controller cpg) has none" in proc.stderr


def test_bad_checkpoints_are_one_line_errors(trained, tmp_path, capsys):
    logs, _ = trained
    good = sorted(glob.glob(str(logs / "hexnewton_flat" / "*" / "model_1.pt")))[0]
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(b"not a checkpoint")
    ckpt = torch.load(good, weights_only=False)
    ckpt["actor_state_dict"]["mlp.0.weight"] = torch.zeros(256, 44)
    ckpt["infos"] = None
    mismatched = tmp_path / "mismatched.pt"
    torch.save(ckpt, mismatched)
    truncated = tmp_path / "truncated.pt"
    truncated.write_bytes(open(good, "rb").read()[:5000])
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    cases = [
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(tmp_path / "missing.pt")], "checkpoint not found"),
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(corrupt)], "cannot read checkpoint"),
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(mismatched), "--num_envs", "1", "--steps", "1"],
         "expects 44 observations"),
        (["play.py", "--controller", "joint", "--checkpoint", good, "--num_envs", "1", "--steps", "1"],
         "action mode 'cpg'"),
        (["train.py", "--task", "fancy"], "unknown task 'fancy'"),
        (["train.py", "--agent.distribution.name", "cauchy"], "'cauchy' is not one of beta, gaussian"),
        (["train.py", "--env.reward.w_tilt", "much"], "expected a number"),
        (["train.py", "--env.randomization.enabled", "maybe"], "expected true or false"),
        (["train.py", "--resume", str(corrupt), "--task", "flat"], "continues the checkpoint's own task"),
        (["train.py", "--resume", str(corrupt)], "cannot read checkpoint"),
        (["train.py", "--resume", str(truncated)], "cannot read checkpoint"),
        (["train.py", "--resume", "results/policies/cpg_rl_complex.pt"], "holds the policy only"),
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(truncated)], "cannot read checkpoint"),
        (["play.py", "--controller", "pid"], "invalid choice: 'pid'"),
        (["train.py", "--num_envs", "abc"], "positive integer"),
        (["train.py", "--num_envs", "0"], "positive integer"),
        (["train.py", "--num_envs", "100000000"], "exceeds"),
        (["train.py", "--max_iterations", "1.5"], "positive integer"),
        (["train.py", "--env.task.goal_distance", "far"], "expected a number"),
        (["train.py", "--env.terrain.name", "moon"], "'moon' is not one of flat, rugged, stepped, complex"),
        (["train.py", "--log_dir", str(a_file / "sub")], "not a writable directory"),
        (["train.py", "--agent.max_minutes", "-1"], "agent.max_minutes must be positive"),
        (["train.py", "--agent.distribution.name", "gaussian", "--agent.distribution.init_std", "0"],
         "init_std must be positive"),
        (["train.py", "--env.sim.frame_dt", "0.015"], "must be a positive multiple of sim.frame_dt"),
        (["train.py", "--env.cpg.a2_range", "1.0", "0.5"], "cpg.a2_range must satisfy"),
        (["train.py", "--env.reward.stability_tilt", "2"], "stability_tilt must lie in (0, pi/2)"),
        (["play.py", "--controller", "cpg", "--env.task.goal_distance", "0.2", "--steps", "1"],
         "goal_distance must exceed"),
        (["play.py", "--controller", "cpg", "--terrain", "stepped", "--env.terrain.step_rise", "-0.1", "--steps", "1"],
         "step_rise must be >= 0"),
    ]
    before = sorted(glob.glob(str(logs / "**"), recursive=True))
    # the first case of each entry point as its own process (the file users run), the others through the same
    # cli.run wrapper in this process: one line on stderr, exit status 2, no traceback
    from hexnewton import play, train
    from hexnewton.cli import run

    entry = {"train.py": (train.main, "python train.py"), "play.py": (play.main, "python play.py")}
    seen = set()
    for args, message in cases:
        if args[0] not in seen:
            seen.add(args[0])
            proc = subprocess.run([sys.executable, *args, "--device", "cpu"], capture_output=True, text=True,
                                  timeout=600)  # fmt: skip
            code, stderr = proc.returncode, proc.stderr
        else:
            capsys.readouterr()
            try:
                code = run(entry[args[0]][0], entry[args[0]][1], [*args[1:], "--device", "cpu"])
            except SystemExit as exc:  # argparse's usage errors exit from the parser
                code = exc.code
            stderr = capsys.readouterr().err
        err = [line for line in stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
        assert code == 2 and len(err) == 1 and message in err[0], (args, stderr[-2000:])
    assert sorted(glob.glob(str(logs / "**"), recursive=True)) == before  # nothing written or overwritten


def test_learning_curves_from_a_run(trained, tmp_path):
    logs, _ = trained
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    out = tmp_path / "curve.png"
    proc = subprocess.run([sys.executable, "-m", "hexnewton.curves", run_dir, "--out", str(out)], capture_output=True,
                          text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert out.stat().st_size > 5000 and "Episode/success_rate" in (tmp_path / "curve.csv").read_text()
    bad = subprocess.run([sys.executable, "-m", "hexnewton.curves", str(tmp_path / "nope")], capture_output=True,
                         text=True, timeout=300)  # fmt: skip
    assert bad.returncode == 2 and "not a run directory" in bad.stderr


def test_curve_axes_and_resumed_pieces(trained):
    """env-steps come from config.json (iterations x envs x steps per env); a piece that repeats iterations
    already plotted adds nothing; wall time starts at 0."""
    from hexnewton.curves import read_curve, steps_per_iteration

    logs, _ = trained
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    per_it = steps_per_iteration(run_dir)
    tag = next(iter(read_curve(run_dir)))
    its = [x for x, _ in read_curve(run_dir, "iteration")[tag]]
    steps = [x for x, _ in read_curve(run_dir, "env_steps")[tag]]
    assert steps == [(i - its[0] + 1) * per_it for i in its]
    joined = read_curve(f"{run_dir},{run_dir}", "env_steps")
    assert {t: [x for x, _ in rows] for t, rows in joined.items()} == {t: [x for x, _ in rows] for t, rows in
                                                                       read_curve(run_dir, "env_steps").items()}
    wall = [x for x, _ in read_curve(run_dir, "wall_time")[tag]]
    assert wall[0] >= 0.0 and wall == sorted(wall)


@pytest.mark.parametrize("name", ["cpg_rl_flat", "cpg_rl_rugged"])
def test_shipped_policies_fit_the_environment(name):
    """results/policies holds the GPU-trained actors and results/controllers their bundles (RESULTS.md); they must
    keep matching the observation layout and action count, in torch and in ONNX."""
    import os

    import onnxruntime as ort

    from hexnewton.checkpoint import check_compatible, load_checkpoint
    from hexnewton.kernels.mdp import OBS_DIM

    results = os.path.join(os.path.dirname(__file__), "..", "results")
    pt = os.path.join(results, "policies", name + ".pt")
    check_compatible(load_checkpoint(pt), pt, OBS_DIM["cpg"], 15, "cpg")
    sess = ort.InferenceSession(os.path.join(results, "controllers", name, "policy.onnx"),
                                providers=["CPUExecutionProvider"])
    out = sess.run(None, {sess.get_inputs()[0].name: np.zeros((3, OBS_DIM["cpg"]), np.float32)})[0]
    assert out.shape == (3, 15) and np.isfinite(out).all()


# ------------------------------------------------------------------ reliability: seeding, resume, interruption


def _train(logs, *args, timeout=900):
    task = [] if "--resume" in args else ["--task", "flat"]  # a resumed run continues its own task
    cmd = [sys.executable, "train.py", "--num_envs", "8", "--device", "cpu", *task, "--log_dir", str(logs),
           "--agent.num_steps_per_env", "8", *args]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc.stdout


def _run_dirs(logs, experiment):
    return sorted(glob.glob(str(logs / experiment / "*")))


def _actor(path):
    return torch.load(path, weights_only=False)["actor_state_dict"]


def test_same_seed_same_first_iteration_on_cpu(tmp_path):
    """Seeds reach torch, numpy and the env's resets: the same seed gives the same first update."""
    for name, seed in (("a", "3"), ("b", "3"), ("c", "4")):
        _train(tmp_path, "--max_iterations", "1", "--seed", seed, "--experiment", name)
    a, b, c = (_actor(glob.glob(str(tmp_path / n / "*" / "model_0.pt"))[0]) for n in "abc")
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_resume_continues_iterations_and_learning_rate(tmp_path):
    """2 iterations + resume 2 numbers its iterations like 4 straight ones and keeps the adapted learning rate and
    the physics it was trained under."""
    _train(tmp_path, "--max_iterations", "2", "--experiment", "part", "--env.sim.frame_dt", "0.02",
           "--env.sim.substeps", "2", "--agent.distribution.name", "gaussian")  # fmt: skip
    (first,) = _run_dirs(tmp_path, "part")
    ck = torch.load(first + "/model_1.pt", weights_only=False)
    lr_saved = ck["optimizer_state_dict"]["param_groups"][0]["lr"]
    time.sleep(1.1)  # run directories are named by the second
    out = _train(tmp_path, "--max_iterations", "2", "--experiment", "part", "--resume",
                 first + "/model_1.pt", "--agent.distribution.init_std", "0.2",
                 "--agent.distribution.learn_std", "false")  # fmt: skip
    assert "continuing at iteration 2" in out
    second = _run_dirs(tmp_path, "part")[1]
    assert os.path.isfile(second + "/model_3.pt") and torch.load(second + "/model_3.pt", weights_only=False)["iter"] == 3
    meta = json.loads(open(second + "/config.json").read())["hexnewton"]
    sim = meta["config"]["sim"]
    assert meta["agent"]["distribution"]["name"] == "gaussian"  # a resumed run keeps its action distribution
    assert (sim["frame_dt"], sim["substeps"]) == (0.02, 2)  # from the checkpoint: no --env.sim.* on the resume
    # agent.distribution.init_std on a resume replaced the checkpoint's learnt std
    std = torch.load(second + "/model_3.pt", weights_only=False)["actor_state_dict"]["distribution.std_param"]
    assert ck["actor_state_dict"]["distribution.std_param"].sub(0.2).abs().max() > 1e-3
    torch.testing.assert_close(std, torch.full_like(std, 0.2))
    lr = read_scalars_lr(second)
    assert f"learning rate {lr_saved:.2e}" in out  # the resumed optimizer starts at the saved rate, not the preset's
    steps = 2 * 4  # the default update's mini-batches x epochs: one adaptive x1.5 (or /1.5) step each at most
    assert sorted(lr) == [2, 3] and lr_saved / 1.5**steps * 0.999 <= lr[2] <= lr_saved * 1.5**steps * 1.001
    _train(tmp_path, "--max_iterations", "4", "--experiment", "straight")
    assert sorted(read_scalars_lr(_run_dirs(tmp_path, "straight")[0])) == [0, 1, 2, 3]


def read_scalars_lr(run_dir):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(run_dir)
    acc.Reload()
    return {e.step: e.value for e in acc.Scalars("Loss/learning_rate")}


def test_interrupt_saves_and_exports(tmp_path):
    """SIGINT in the middle of training: a final checkpoint and the ONNX policy are written, exit status 0."""
    cmd = [sys.executable, "train.py", "--num_envs", "8", "--device", "cpu", "--task", "flat", "--log_dir",
           str(tmp_path), "--agent.num_steps_per_env", "8", "--max_iterations", "100000", "--agent.save_interval", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 600  # interrupt once training is under way (iteration 1 saved), whatever the load
    while not glob.glob(str(tmp_path / "*" / "*" / "model_1.pt")) and time.time() < deadline:
        time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, out[-2000:] + err[-3000:]
    assert "stopped by SIGINT" in out
    (run,) = glob.glob(str(tmp_path / "*" / "*"))
    final = re.search(r"saving (model_\d+\.pt)", out).group(1)  # the checkpoint written on the interrupt
    assert int(final[6:-3]) >= 1 and os.path.isfile(os.path.join(run, final))
    assert os.path.isfile(run + "/policy.onnx")
    assert not glob.glob(run + "/*.tmp")  # atomic saves leave no temporary file


def test_torchrun_ranks_devices_and_seeds():
    """torchrun's variables pick cuda:LOCAL_RANK (or the CPU when asked) and rank-offset seeds; a plain run is
    unchanged (no GPU needed)."""
    from hexnewton.runner import distributed_rank

    assert distributed_rank({}, None).device is None and distributed_rank({}, "cpu").world_size == 1
    r = distributed_rank({"WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}, None)
    assert (r.device, r.rank, r.world_size, r.is_main) == ("cuda:1", 1, 2, False)
    assert r.seeds(7, 0) == (8, 1) and distributed_rank({}, None).seeds(7, 0) == (7, 0)
    r0 = distributed_rank({"WORLD_SIZE": "2", "RANK": "0", "LOCAL_RANK": "0"}, "cuda")
    assert r0.device == "cuda:0" and r0.is_main
    r3 = distributed_rank({"WORLD_SIZE": "4", "RANK": "3", "LOCAL_RANK": "1"}, None)  # 2 nodes x 2 GPUs
    assert r3.device == "cuda:1" and r3.rank == 3
    for environ, device, message in (({"WORLD_SIZE": "2", "RANK": "2", "LOCAL_RANK": "0"}, None, "must lie in"),
                                     ({"WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}, "mps", "runs on cuda"),
                                     ({"WORLD_SIZE": "two"}, None, "integers")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            distributed_rank(environ, device)
    r1 = distributed_rank({"WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}, "cpu")
    assert (r1.device, r1.rank, r1.world_size) == ("cpu", 1, 2)
    # the CLI: a device no rank can run on is one line, exit 2
    env = dict(os.environ, WORLD_SIZE="2", RANK="1", LOCAL_RANK="1")
    proc = subprocess.run([sys.executable, "train.py", "--device", "mps"], capture_output=True, text=True, env=env,
                          timeout=300)  # fmt: skip
    err = [line for line in proc.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
    assert proc.returncode == 2 and len(err) == 1 and "runs on cuda" in err[0], proc.stderr[-1500:]


def test_torchrun_two_cpu_processes_train_as_one(tmp_path):
    """``torchrun --nproc_per_node=2 train.py --device cpu``: two processes (Gloo) train two iterations with their
    gradients averaged; their parameters agree at the end, and only rank 0 writes a run directory."""
    cmd = ["torchrun", "--standalone", "--nproc_per_node=2", "train.py", "--task", "flat", "--num_envs", "4",
           "--max_iterations", "2", "--device", "cpu", "--log_dir", str(tmp_path)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert "rank 0 of 2" in proc.stdout and "rank 1 of 2" in proc.stdout
    agree = re.search(r"parameters of the 2 ranks agree to (\S+)", proc.stdout)
    assert agree and float(agree.group(1)) <= 1e-6, proc.stdout[-2000:]
    runs = glob.glob(str(tmp_path / "hexnewton_flat" / "*"))
    assert len(runs) == 1 and os.path.isfile(os.path.join(runs[0], "model_1.pt"))
    from hexnewton.checkpoint import checkpoint_meta, load_checkpoint

    assert checkpoint_meta(load_checkpoint(os.path.join(runs[0], "model_1.pt")))["world_size"] == 2


def test_stop_reason_is_one_decision_for_all_ranks():
    """--max_minutes / --target_success under torchrun: every rank reaches the same decision from the sums over
    the ranks (here a fake two-rank sum), so no rank leaves the others waiting in a collective."""
    from hexnewton.env import RING
    from hexnewton.runner import stop_reason

    full = {"episodes": RING, "success_rate": 0.96, "top_level_episodes": RING // 4, "top_level_success_rate": 0.5}
    assert stop_reason(False, full, 0.95, 0) == "target success 0.960 >= 0.95"
    assert stop_reason(False, full, 0.95, 10) is None  # a curriculum counts the last level only
    assert stop_reason(False, dict(full, episodes=RING - 1), 0.95, 0) is None  # ring not full yet
    assert stop_reason(True, full, None, 0) == "the --max_minutes limit"
    assert stop_reason(False, full, None, 0) is None
    other = {"episodes": RING, "success_rate": 0.90, "top_level_episodes": RING // 4, "top_level_success_rate": 1.0}
    sent = []
    stop_reason(False, other, 0.9, 0, reduce=lambda v: sent.append(v) or v)  # what the other rank contributes
    plus_other = lambda v: [a + b for a, b in zip(v, sent[0], strict=True)]  # noqa: E731
    assert stop_reason(False, full, 0.95, 0, plus_other) is None  # (0.96 + 0.90) / 2 < 0.95
    assert stop_reason(False, full, 0.92, 0, plus_other) == "target success 0.930 >= 0.92"
    assert stop_reason(False, other, 0.95, 10) == "target success on the last level 1.000 >= 0.95"
    time_up_elsewhere = lambda v: [a + b for a, b in zip(v, [1.0, 0.0, 0.0, 1.0], strict=True)]  # noqa: E731
    assert stop_reason(False, full, 0.95, 0, time_up_elsewhere) == "the --max_minutes limit"


@pytest.mark.parametrize("curriculum", [(), ("--env.terrain.levels", "2", "--env.terrain.start_levels", "2")])
def test_target_success_stops_training(tmp_path, curriculum):
    """--target_success (time-to-skill): with the goal 5 cm beyond reach every episode succeeds at once, so
    training stops as soon as 1024 episodes have finished (with a curriculum: 256 on its last level), then saves
    and exports."""
    out = _train(tmp_path, "--env.task.goal_distance", "0.55", "--agent.target_success", "0.9", "--max_iterations", "100000",
                 "--num_envs", "32", *curriculum)  # fmt: skip
    assert ("stopped by target success on the last level" if curriculum else "stopped by target success") in out
    (run,) = glob.glob(str(tmp_path / "*" / "*"))
    assert os.path.isfile(run + "/policy.onnx") and len(glob.glob(run + "/model_*.pt")) >= 2


def test_max_minutes_stops_at_an_iteration_boundary(tmp_path):
    """--max_minutes: the alarm is acted on at the end of an iteration (as under torchrun), then save and export."""
    out = _train(tmp_path, "--agent.max_minutes", "0.001", "--max_iterations", "100000", "--num_envs", "8")
    it = re.search(r"stopped by the --max_minutes limit after iteration (\d+): saving", out)
    assert it, out[-2000:]
    (run,) = glob.glob(str(tmp_path / "*" / "*"))
    assert os.path.isfile(run + "/policy.onnx") and os.path.isfile(f"{run}/model_{it.group(1)}.pt")


def test_tasks_hold_the_recipes():
    """The registry's tasks: the terrain recipe (curriculum, knee-lift floor, randomisation, 20 ms frame, 0.1 s filter,
    stability shaping), the complex course's posture and curriculum, Table 1 and Table 2 in ``paper``; every task has
    a Gymnasium id, and ``task`` hands out copies."""
    from hexnewton.agent import AgentConfig
    from hexnewton.tasks import LONG_STABLE_STAGES, STABLE_STAGES, TASKS, task

    c = task("complex")
    assert (c.env.terrain.levels, c.env.terrain.start_levels, c.env.cpg.a2_range, c.env.randomization.enabled,
            c.env.sim.frame_dt, c.env.cpg.param_tau) == (10, 3, (0.9, 1.3), True, 0.02, 0.1)  # fmt: skip
    assert c.env.cpg.posture and c.agent.stages == STABLE_STAGES and c.agent.max_iterations == 300
    assert c.env.terrain.collision == "mesh_boxes"
    assert task("complex-5m").agent.stages == LONG_STABLE_STAGES and task("stairs-8cm").agent.max_iterations == 1062
    assert (c.env.reward.w_tilt, c.env.reward.w_action_rate) == (5.0, 0.1)
    r = task("rugged")
    assert not r.env.cpg.posture and r.agent.stages == () and r.agent.max_iterations == 300
    f = task("flat")
    assert (f.env.terrain.levels, f.env.randomization.enabled, f.env.sim.frame_dt) == (0, False, 0.01)
    assert f.env.reward == RewardConfig() and f.agent == AgentConfig()
    p = task("paper")
    assert p.env.reward == RewardConfig().paper_reward() and p.env.reward.goal_bonus == 0 and p.env.reward.w_tilt == 0
    a = p.agent.to_rsl_rl(1024)["algorithm"]
    assert (a["learning_rate"], a["schedule"], a["gamma"], a["lam"], a["clip_param"]) == (1e-4, "fixed", 0.99, 0.95, 0.2)
    assert a["num_mini_batches"] == 1024 * 24 // 512  # Table 2's batch of 512
    assert p.agent.model.activation == "relu" and p.agent.model.hidden_dims == (256, 256, 256, 256)
    assert not p.env.cpg.posture and p.env.terrain.levels == 0 and not p.env.randomization.enabled
    s8 = task("stairs-8cm")
    assert (s8.env.terrain.step_rise, s8.env.task.goal_distance, s8.env.terrain.x_max) == (0.08, 5.5, 6.5)
    assert task("complex-5m").env.task.goal_distance == 5.5 and task("complex-joint").action_mode == "joint"
    c.env.reward.w_tilt = 99.0
    assert task("complex").env.reward.w_tilt == 5.0  # a copy
    assert len({t.gym_id for t in TASKS.values()}) == len(TASKS) and TASKS["complex-5m"].gym_id == "Hexnewton-Complex-5m-v0"
    with pytest.raises(ValueError, match="unknown task 'moon'"):
        task("moon")


def test_config_overrides_are_generated_from_the_dataclasses():
    """Every field of the env and agent trees is a flag; values are typed (tuples, optionals, choices, literals);
    only the given ones are overrides."""
    from hexnewton.agent import AgentConfig
    from hexnewton.cli import ArgumentParser, add_config_args, config_overrides
    from hexnewton.config import apply_overrides

    p = ArgumentParser(prog="t")
    add_config_args(p, "env", HexConfig(), skip=("sim.num_envs",))
    add_config_args(p, "agent", AgentConfig())
    flags = {o for a in p._actions for o in a.option_strings}
    assert "--env.reward.w_tilt" in flags and "--agent.algorithm.learning_rate" in flags
    assert "--env.sim.num_envs" not in flags  # a conventional flag of its own
    args = p.parse_args(["--env.cpg.a2_range", "0.5", "1.0", "--env.randomization.enabled", "true",
                         "--agent.distribution.std_max", "none", "--agent.model.hidden_dims", "64", "64",
                         "--agent.stages", "((3, {'w_tilt': 2.0}),)", "--env.terrain.name", "rugged"])  # fmt: skip
    env, agent = config_overrides(args, "env"), config_overrides(args, "agent")
    assert env == {"cpg.a2_range": (0.5, 1.0), "randomization.enabled": True, "terrain.name": "rugged"}
    assert agent == {"distribution.std_max": None, "model.hidden_dims": (64, 64), "stages": ((3, {"w_tilt": 2.0}),)}
    cfg = apply_overrides(HexConfig(), env)
    assert cfg.cpg.a2_range == (0.5, 1.0) and cfg.randomization.enabled and cfg.terrain.name == "rugged"
    assert apply_overrides(AgentConfig(), agent).to_rsl_rl(8)["actor"]["hidden_dims"] == [64, 64]
    with pytest.raises(ValueError, match="no field 'sim.warp'"):
        apply_overrides(HexConfig(), {"sim.warp": 1})
    # an optional pair takes two numbers or none
    for given, want in ((["0.01", "0.014"], (0.01, 0.014)), (["none"], None)):
        args = p.parse_args(["--env.randomization.foot_radius", *given])
        assert config_overrides(args, "env") == {"randomization.foot_radius": want}
    with pytest.raises(ValueError, match="foot_radius: give 2 numbers or none"):
        config_overrides(p.parse_args(["--env.randomization.foot_radius", "0.01"]), "env")


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


def test_curriculum_stages_change_reflex_and_weights_in_one_run(tmp_path, capsys):
    """The complex recipe's curriculum, on shortened stages (--agent.stages): each stage begins at its iteration, the
    checkpoints carry the task, the gain and weights they were trained under; a resumed run continues in its
    stage, on its own task."""
    import torch

    from hexnewton import train

    stages = "((1, {'posture_reflex': 2.0, 'w_tilt': 15.0}), (2, {'w_tilt': 40.0, 'w_ang_vel': 0.3}))"
    assert train.main(["--task", "complex", "--num_envs", "8", "--agent.num_steps_per_env", "4", "--max_iterations",
                       "3", "--device", "cpu", "--log_dir", str(tmp_path), "--agent.stages", stages]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "iteration 1: curriculum stage 2 of 3: posture_reflex 2, w_tilt 15" in out
    assert "iteration 2: curriculum stage 3 of 3: posture_reflex 2, w_tilt 40, w_ang_vel 0.3" in out
    last = sorted(tmp_path.glob("*/*/model_2.pt"))[-1]
    meta = torch.load(last, weights_only=True)["infos"]["hexnewton"]
    cfg = meta["config"]
    assert meta["task"] == "complex" and meta["agent"]["max_iterations"] == 3
    assert cfg["cpg"]["posture"] and cfg["cpg"]["posture_reflex"] == 2.0 and cfg["reward"]["w_tilt"] == 40.0
    # resumed: the run goes on with its own task and configs, in the stage its iteration is in
    assert train.main(["--resume", str(last), "--num_envs", "8", "--max_iterations", "1", "--device", "cpu",
                       "--log_dir", str(tmp_path)]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "training task complex" in out and "iteration 3: curriculum stage 3 of 3" in out


def test_training_reports_its_start_up_and_writes_timing(trained):
    """After the first iteration train.py prints where the start-up went (phases from the process's start), and the
    run's timing.json records them with the training time and the result it exported."""
    logs, out = trained
    line = next(x for x in out.splitlines() if x.startswith("start-up "))
    for phase in ("python and imports", "terrain", "finalize", "solver", "first step and graph capture",
                  "first iteration"):  # fmt: skip
        assert f"{phase} " in line
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    timing = json.load(open(os.path.join(run_dir, "timing.json")))
    assert timing["iterations"] == 2 and timing["env_steps"] == 2 * 16 * 24
    assert 0 < timing["first_iteration_s"] < timing["wall_s_to_result"]
    assert sum(timing["startup_phases_s"].values()) == pytest.approx(timing["first_iteration_s"], abs=0.5)
    assert os.path.isfile(timing["result"])


def test_progress_line_says_when_no_episode_has_ended():
    from hexnewton.runner import progress_line

    stats = {"success_rate": float("nan"), "fell_rate": float("nan"), "off_course_rate": float("nan"),
             "distance_m": float("nan"), "episodes": 0}  # fmt: skip
    line = progress_line({"it": 0, "total_it": 300}, stats, 1.0)
    assert "no episode ended yet" in line and "nan" not in line
    line = progress_line({"it": 9, "total_it": 300}, {**stats, "success_rate": 0.5, "episodes": 3}, 1.0)
    assert "success 0.500" in line


def test_newest_checkpoint_is_the_runs_result(tmp_path):
    """play.py's default: the newest run's model_best.pt where it kept one (train.py's result then), else its last
    numbered checkpoint."""
    from hexnewton.checkpoint import newest_checkpoint

    old, new = tmp_path / "hexnewton_flat" / "2026-01-01_00-00-00", tmp_path / "hexnewton_rugged" / "2026-01-02_00-00-00"
    for run, names in ((old, ("model_0.pt", "model_best.pt")), (new, ("model_2.pt", "model_10.pt"))):
        run.mkdir(parents=True)
        for name in names:
            (run / name).write_bytes(b"")
    assert newest_checkpoint(str(tmp_path), "hexnewton_*") == str(new / "model_10.pt")
    (new / "model_best.pt").write_bytes(b"")
    assert newest_checkpoint(str(tmp_path), "hexnewton_*") == str(new / "model_best.pt")
    assert newest_checkpoint(str(tmp_path), "hexnewton_flat") == str(old / "model_best.pt")


def test_best_checkpoint_keeps_the_best_iteration(tmp_path):
    """model_best.pt follows the training success once enough episodes are in (a quarter of the ring; with a
    curriculum, played on the last level), and only a real improvement saves again."""
    from hexnewton.env import RING
    from hexnewton.runner import BestCheckpoint, training_success

    saved = []
    best = BestCheckpoint(str(tmp_path), levels=0)
    save = lambda path, infos: saved.append((path, infos["best_success"]))  # noqa: E731
    for it, (rate, n) in enumerate([(0.9, RING // 8), (0.5, RING // 4), (0.8, RING), (0.802, RING), (0.7, RING)]):
        best.update({"success_rate": rate, "episodes": n}, it, save)
    assert [r for _, r in saved] == [0.5, 0.8] and best.iteration == 2 and best.rate == 0.8
    assert saved[0][0] == str(tmp_path / "model_best.pt")
    stats = {"top_level_success_rate": 0.9, "top_level_episodes": RING // 4, "success_rate": 0.1, "episodes": RING}
    assert training_success(stats, levels=10) == 0.9 and training_success(stats, levels=0) == 0.1
    assert training_success({**stats, "top_level_episodes": 3}, levels=10) is None
