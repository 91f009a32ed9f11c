"""Controller bundle export and the NumPy/onnxruntime runtime: it reproduces the simulator's joint targets for
a recorded rollout, without Warp, Newton or torch."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
POLICY = os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt")
BLOCKED = ("warp", "torch", "newton", "mujoco", "mujoco_warp", "rsl_rl", "tensordict")


def _run(args, **kw):
    return subprocess.run([sys.executable, *args], capture_output=True, text=True, timeout=900, cwd=ROOT, **kw)


@pytest.fixture(scope="module")
def bundle(tmp_path_factory):
    out = tmp_path_factory.mktemp("deploy") / "bundle"
    proc = _run(["-m", "hexnewton.apps.export", "--checkpoint", POLICY, "--out", str(out), "--steps", "60", "--robots", "3"])
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "reproduces the simulator's joint targets" in proc.stdout
    return out


def test_bundle_contents(bundle):
    spec = json.loads((bundle / "controller.json").read_text())
    assert spec["format"] == "hexnewton-controller/1" and spec["num_obs"] == 59 and spec["num_actions"] == 15
    assert spec["substeps_per_control"] == 8 and spec["control_dt"] == pytest.approx(0.02)
    assert [row[0] for row in spec["obs_layout"]] == ["joint_pos", "joint_vel", "target", "omega", "amplitudes", "quat",
                                                      "max_height"]  # fmt: skip
    rec = np.load(bundle / "check.npz")
    assert rec["obs"].shape == (60, 3, 59) and rec["targets"].shape == (60, 3, 18)
    import onnxruntime as ort

    sess = ort.InferenceSession(str(bundle / "policy.onnx"), providers=["CPUExecutionProvider"])
    assert sess.run(None, {sess.get_inputs()[0].name: rec["obs"][0]})[0].shape == (3, 15)  # dynamic batch


def test_runtime_reproduces_the_simulator_without_warp_newton_or_torch(bundle):
    code = (
        "import sys, json\n"
        f"for m in {BLOCKED!r}: sys.modules[m] = None  # importing any of them now fails\n"
        "from hexnewton.deploy.runtime import replay\n"
        f"print(json.dumps(replay({str(bundle)!r})))\n"
    )
    proc = _run(["-c", code])
    assert proc.returncode == 0, proc.stderr[-3000:]
    r = json.loads(proc.stdout.strip().splitlines()[-1])
    assert r["steps"] == 60 and r["robots"] == 3
    assert r["max_target_diff_rad"] < 1e-4 and r["max_obs_diff"] < 1e-4
    proc = _run(["-m", "hexnewton.apps.deploy", str(bundle)])
    assert proc.returncode == 0 and "(ok," in proc.stdout


def test_runtime_step_by_step(bundle):
    """The public per-step API: readings in, joint targets out, within the joint limits; the heading-frame helper."""
    from hexnewton.deploy.runtime import Controller, target_in_heading_frame

    ctrl = Controller(str(bundle), num_robots=2)
    yaw = 0.3
    quat = np.array([[0, 0, np.sin(yaw / 2), np.cos(yaw / 2)]] * 2)
    target = target_in_heading_frame([[0.0, 0.0, 0.13]] * 2, quat, [[3.5, 0.0, 0.0]] * 2, goal_ground_z=0.0)
    np.testing.assert_allclose(target[0], [3.5 * np.cos(yaw), -3.5 * np.sin(yaw), -0.13], atol=1e-12)
    q = np.tile([0.0, 0.15, -0.15], 6)
    for _ in range(5):
        out = ctrl.step(np.tile(q, (2, 1)), np.zeros((2, 18)), quat, target)
    lo, hi = np.tile(ctrl.joint_lower, 6), np.tile(ctrl.joint_upper, 6)
    assert out.shape == (2, 18) and np.all(out >= lo - 1e-9) and np.all(out <= hi + 1e-9)
    assert ctrl.last_substep_targets.shape == (8, 2, 18)
    ctrl.reset(mask=[True, False])
    np.testing.assert_allclose(ctrl.params[0], ctrl.spec["initial_params"])


def test_sampled_actions_follow_the_trained_gaussian(bundle):
    """``stochastic=True``: actions scatter around the mean with the exported std, reproducibly for one seed."""
    from hexnewton.deploy.runtime import Controller

    obs = np.load(bundle / "check.npz")["obs"][0]
    std = np.asarray(json.loads((bundle / "controller.json").read_text())["action_std"])
    assert std.shape == (15,) and np.all(std > 0)
    mean = Controller(str(bundle), num_robots=3).act(obs)
    a, b = (Controller(str(bundle), num_robots=3, stochastic=True, seed=7) for _ in range(2))
    draws = np.stack([a.act(obs) for _ in range(2000)])
    np.testing.assert_array_equal(draws[0], b.act(obs))
    np.testing.assert_allclose(draws.mean(axis=0), mean, atol=0.1)
    np.testing.assert_allclose(draws.std(axis=0), np.broadcast_to(std, mean.shape), rtol=0.1)


def test_expected_clipped_action_matches_its_reference_and_monte_carlo():
    """E[clip(a, -1, 1)], a ~ N(mean, std^2): the torch twin (play.py, used in evaluation) against the float64 NumPy
    reference (deploy/runtime.py, the robot runtime) on random inputs, the reference against sampling, and its limits."""
    import torch

    from hexnewton.deploy.runtime import expected_clipped_action
    from hexnewton.learning.policy import expected_clipped_action as expected_torch

    rng = np.random.default_rng(0)
    mean, std = rng.uniform(-4, 4, (64, 15)), rng.uniform(0.01, 6.0, 15)
    ref = expected_clipped_action(mean, std)
    got = expected_torch(torch.tensor(mean, dtype=torch.float32), torch.tensor(std, dtype=torch.float32)).numpy()
    np.testing.assert_allclose(got, ref, atol=2e-6)
    assert np.all(np.abs(ref) <= 1)
    m, s = mean[0], std
    draws = np.clip(m + s * rng.standard_normal((200_000, 15)), -1, 1)
    np.testing.assert_allclose(draws.mean(axis=0), expected_clipped_action(m, s), atol=0.01)
    np.testing.assert_allclose(expected_clipped_action(mean, np.full(15, 1e-9)), np.clip(mean, -1, 1), atol=1e-9)
    np.testing.assert_allclose(expected_clipped_action(0.0, 3.0), 0.0, atol=1e-12)  # symmetric


def test_expected_actions_in_the_runtime_and_the_simulator(bundle):
    """``expected=True`` in the runtime and ``--expected`` in play/evaluate apply the same formula to the same mean,
    with the exported std; it cannot be combined with sampling."""
    import dataclasses

    import torch

    from hexnewton.deploy.runtime import Controller, expected_clipped_action
    from hexnewton.learning.checkpoint import load_checkpoint, trained_config
    from hexnewton.learning.policy import load_policy
    from hexnewton.mdp.env import make_env

    obs = np.load(bundle / "check.npz")["obs"][0]
    std = np.asarray(json.loads((bundle / "controller.json").read_text())["action_std"])
    mean = Controller(str(bundle), num_robots=3).act(obs)
    np.testing.assert_allclose(Controller(str(bundle), num_robots=3, expected=True).act(obs),
                               expected_clipped_action(mean, std), atol=1e-12)  # fmt: skip
    with pytest.raises(ValueError, match="not both"):
        Controller(str(bundle), stochastic=True, expected=True)
    cfg = trained_config(load_checkpoint(POLICY))
    cfg = dataclasses.replace(cfg, sim=dataclasses.replace(cfg.sim, num_envs=3, device="cpu"))
    env = make_env(cfg)
    policy = load_policy(env, POLICY, "cpg", expected=True)
    with torch.no_grad():
        got = policy(env.get_observations()).numpy()
        mu = load_policy(env, POLICY, "cpg")(env.get_observations()).numpy()
    np.testing.assert_allclose(got, expected_clipped_action(mu, std), atol=1e-5)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_bad_bundles_and_exports(bundle, tmp_path):
    not_bundle = _run(["-m", "hexnewton.apps.deploy", str(tmp_path)])
    assert not_bundle.returncode == 2 and "not a controller bundle" in not_bundle.stderr
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "controller.json").write_text(json.dumps({"format": "something-else"}))
    wrong = _run(["-m", "hexnewton.apps.deploy", str(bad)])
    assert wrong.returncode == 2 and "expected 'hexnewton-controller/1'" in wrong.stderr
    exists = _run(["-m", "hexnewton.apps.export", "--checkpoint", POLICY, "--out", str(bundle)])
    err = [line for line in exists.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
    assert exists.returncode == 2 and len(err) == 1 and "exists: nothing is overwritten" in err[0]
    missing = _run(["-m", "hexnewton.apps.export", "--checkpoint", str(tmp_path / "nope.pt"), "--out", str(tmp_path / "b")])
    assert missing.returncode == 2 and "checkpoint not found" in missing.stderr
    assert not (tmp_path / "b").exists()


def test_policies_keep_their_trained_parameter_ranges():
    """A checkpoint's actions mean what they meant in training: play, evaluate, export and --resume take the CPG
    ranges from the checkpoint, not from today's defaults."""
    from hexnewton.config import CPGConfig
    from hexnewton.learning.checkpoint import load_checkpoint, trained_config

    assert trained_config(load_checkpoint(POLICY)).cpg.a2_range == (0.0, 0.8)  # trained before the range was widened
    assert CPGConfig().a2_range == (0.0, 1.3)
    assert trained_config(None).cpg == CPGConfig() and trained_config({"infos": None}).cpg == CPGConfig()
    spec = json.loads(open(os.path.join(ROOT, "results", "controllers", "cpg_rl_flat", "controller.json")).read())
    assert spec["param_upper"][3] == 0.8  # the shipped bundle carries the policy's own ranges


BETA_POLICY = os.path.join(ROOT, "results", "policies", "cpg_rl_complex_beta.pt")


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_beta_policy_bundle_runs_its_deterministic_action(tmp_path):
    """A Beta policy: the ONNX file computes the distribution's mean (the controller), the runtime reproduces the
    simulator with it, and sampling in the runtime is refused with one clear error (no Gaussian std to sample)."""
    from hexnewton.deploy.runtime import Controller, replay

    out = tmp_path / "beta"
    proc = _run(["-m", "hexnewton.apps.export", "--checkpoint", BETA_POLICY, "--out", str(out), "--steps", "30",
                 "--robots", "2"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    spec = json.loads((out / "controller.json").read_text())
    assert spec["distribution"] == "beta" and "action_std" not in spec
    assert replay(str(out))["max_target_diff_rad"] < 1e-4
    obs = np.load(out / "check.npz")["obs"][0]
    act = Controller(str(out), num_robots=2).act(obs)
    assert act.shape == (2, 15) and np.all(np.abs(act) < 1.0)  # bounded by construction
    with pytest.raises(ValueError, match="deterministic action"):
        Controller(str(out), stochastic=True)


REFLEX_POLICY = os.path.join(ROOT, "results", "policies", "cpg_rl_complex.pt")


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_reflex_bundle_reads_the_attitude_at_every_substep(tmp_path):
    """The shipped complex policy has the body posture and the levelling reflex: its bundle records the body's
    quaternion at every substep, the runtime reproduces the simulator with them (and not with the control step's
    quaternion held over the step), and a substep without the attitude is refused with one clear error."""
    from hexnewton.deploy.runtime import Controller, replay

    out = tmp_path / "reflex"
    proc = _run(["-m", "hexnewton.apps.export", "--checkpoint", REFLEX_POLICY, "--out", str(out), "--steps", "25",
                 "--robots", "2"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    spec = json.loads((out / "controller.json").read_text())
    assert spec["posture_reflex"] > 0 and spec["num_actions"] == 18
    rec = np.load(out / "check.npz")
    assert rec["substep_quat"].shape == (len(rec["obs"]), spec["substeps_per_control"], 2, 4)
    assert replay(str(out))["max_target_diff_rad"] < 1e-4
    ctrl = Controller(str(out), num_robots=2)
    lay = ctrl.layout
    held = 0.0
    for obs, target in zip(rec["obs"], rec["targets"]):
        quat = obs[:, lay["quat"][0]:lay["quat"][1]]
        held = max(held, float(np.abs(ctrl.advance(ctrl.act(obs), quat) - target).max()))
    assert held > 1e-3  # the attitude moves within a control step and the reflex follows it
    with pytest.raises(ValueError, match="levelling reflex"):
        ctrl.substep()


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_stuck_response_in_the_simulator_and_the_runtime(tmp_path):
    """A policy whose config turns the stuck response on (here so that every robot counts as stuck after 3 control
    steps): its bundle carries the response's settings, the runtime reproduces the simulator's joint targets with it
    (the lifted knees included), and setting actions without the observed target is refused with one clear error."""
    import torch

    from hexnewton.deploy.runtime import Controller, replay
    from hexnewton.kernels.reference import scale_actions_reference

    ck = torch.load(POLICY, map_location="cpu", weights_only=False)
    ck["infos"]["hexnewton"]["config"]["cpg"].update(stuck_lift=0.3, stuck_window=3, stuck_progress=100.0, stuck_hold=2)
    torch.save(ck, tmp_path / "stuck.pt")
    out = tmp_path / "stuck"
    proc = _run(["-m", "hexnewton.apps.export", "--checkpoint", str(tmp_path / "stuck.pt"), "--out", str(out),
                 "--steps", "12", "--robots", "2"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    spec = json.loads((out / "controller.json").read_text())
    assert (spec["stuck_lift"], spec["stuck_window"], spec["stuck_progress"], spec["stuck_hold"]) == (0.3, 3, 100.0, 2)
    assert replay(str(out))["max_target_diff_rad"] < 1e-4
    rec = np.load(out / "check.npz")
    ctrl = Controller(str(out), num_robots=2)
    lay = ctrl.layout
    lift = []
    for obs in rec["obs"]:
        actions = ctrl.act(obs)
        ctrl.set_actions(actions, obs[:, lay["target"][0]:lay["target"][1]])
        lift.append(ctrl.target - scale_actions_reference(actions, ctrl.lower, ctrl.upper))
    lift = np.array(lift)  # (steps, robots, params): what the response added
    assert np.all(lift[:, :, :3] == 0) and np.all(lift[:, :, 9:] == 0)
    # every robot stuck from the 4th control step: 2 steps of lift, then at once again (still no ground gained)
    np.testing.assert_allclose(lift[3:, :, 3:9], 0.3)
    assert np.all(lift[:3] == 0)
    with pytest.raises(ValueError, match="stuck response"):
        ctrl.set_actions(ctrl.act(rec["obs"][0]))


class _Payload:
    """Unpickling this runs ``os.system``: what a crafted checkpoint could do to whoever loads it."""

    def __init__(self, marker):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_checkpoints_load_as_data_only(tmp_path):
    """A checkpoint whose pickle would run code is refused with one line and nothing runs; an ONNX file passed as a
    checkpoint is named for what it is."""
    import torch

    marker = tmp_path / "ran"
    evil = tmp_path / "evil.pt"
    torch.save({"actor_state_dict": {}, "iter": 0, "infos": {"x": _Payload(str(marker))}}, evil)
    proc = _run(["-m", "hexnewton.apps.export", "--checkpoint", str(evil), "--out", str(tmp_path / "b")])
    assert proc.returncode == 2 and "could run code" in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not marker.exists()
    onnx_file = os.path.join(ROOT, "results", "controllers", "cpg_rl_flat", "policy.onnx")
    onnx = _run(["-m", "hexnewton.apps.export", "--checkpoint", onnx_file, "--out", str(tmp_path / "c")])
    assert onnx.returncode == 2 and "is an ONNX policy" in onnx.stderr


@pytest.mark.parametrize("name", sorted(os.listdir(os.path.join(ROOT, "results", "controllers"))))
def test_every_shipped_bundle_deploys(name):
    """``python -m hexnewton.apps.deploy results/controllers/<name>`` replays the bundle's recorded rollout (check.npz is
    committed with it) within the default tolerance."""
    proc = _run(["-m", "hexnewton.apps.deploy", os.path.join(ROOT, "results", "controllers", name)])
    assert proc.returncode == 0 and "(ok," in proc.stdout, proc.stdout + proc.stderr


def test_runtime_observes_the_gyro_and_last_actions_as_the_env_does():
    """A policy observing the gyro and its last actions (``ObsConfig.gyro``, ``last_action``): the env's gyro is the
    body's rate in its own frame (the quaternion's change in free flight), and the runtime, given the robots' readings
    (an ideal IMU's gyro) and the same actions step by step, assembles the env's observation column for column; the
    last actions are clamped on both sides and 0 after a reset (episodes of 10 steps), and an observation without the
    gyro is refused with one clear error."""
    import torch

    from hexnewton.analysis.sim2sim import fixed_cpg_spec
    from hexnewton.config import HexConfig, ObsConfig, SimConfig, TaskConfig, TerrainConfig
    from hexnewton.deploy.runtime import Controller
    from hexnewton.mdp.env import make_env
    from hexnewton.mdp.terms import OBS_LAYOUT
    from hexnewton.kernels.reference import quat_rotate_inv_np

    cfg = HexConfig(sim=SimConfig(num_envs=2, device="cpu", use_graph=False), terrain=TerrainConfig(name="stepped"),
                    task=TaskConfig(max_episode_steps=10), obs=ObsConfig(gyro=True, last_action=True))  # fmt: skip
    env = make_env(cfg)
    assert env.obs_layout == "cpg+gyro+last_action" and env.num_obs == 59 + 3 + 15 and env.obs_groups == ("policy",)
    w, lay = env.world, {name: (a, b) for name, a, b in OBS_LAYOUT[env.obs_layout]}
    # free flight, turned and spinning: the gyro is the body-frame rate the quaternion turns at
    q, qd, spin = w.joint_q_wp.numpy().copy(), w.joint_qd_wp.numpy().copy(), np.array([0.5, 2.0, -0.3])
    q[:, 2], q[:, 3:7], qd[:, 3:6] = 1.0, [0.0, 0.0, np.sin(0.45), np.cos(0.45)], spin
    w.joint_q_wp.assign(q)
    w.joint_qd_wp.assign(qd)
    env._observe()
    gyro = env.obs.numpy()[:, lay["gyro"][0]:lay["gyro"][1]]
    q0 = w.joint_q_wp.numpy()[:, 3:7].copy()
    w.set_controller(None)  # the legs held still: a rigid body's rate
    w.step(1)
    w.set_controller(env.cpg)
    q1 = w.joint_q_wp.numpy()[:, 3:7]
    x, y, z, s = np.moveaxis(0.5 * (q0 + q1), -1, 0)  # body rate = 2 conj(q) dq/dt
    dx, dy, dz, ds = np.moveaxis((q1 - q0) / w.frame_dt, -1, 0)
    rate = 2 * np.stack([s * dx - x * ds - y * dz + z * dy, s * dy - y * ds - z * dx + x * dz,
                         s * dz - z * ds - x * dy + y * dx], axis=1)  # fmt: skip
    np.testing.assert_allclose(gyro, rate, rtol=0.02, atol=0.01)
    np.testing.assert_allclose(gyro, quat_rotate_inv_np(q0, np.tile(spin, (2, 1))), atol=1e-5)
    # the runtime beside the env, step by step
    obs = env.reset()["policy"].numpy()
    spec = dict(fixed_cpg_spec(cfg.cpg, cfg.robot, cfg.task.control_dt, cfg.sim.frame_dt / cfg.sim.substeps),
                num_obs=env.num_obs, obs_layout=[list(row) for row in OBS_LAYOUT[env.obs_layout]])  # fmt: skip
    ctrl = Controller(spec, num_robots=2)
    rng = np.random.default_rng(0)
    last = slice(*lay["last_action"])
    for k in range(25):
        q, qd = w.joint_q_wp.numpy().copy(), w.joint_qd_wp.numpy().copy()
        parts = [obs[:, slice(*lay[name])] for name in ("target", "max_height")]
        mine = ctrl.observe(q[:, 7:], qd[:, 6:], q[:, 3:7], *parts, gyro=quat_rotate_inv_np(q[:, 3:7], qd[:, 3:6]))
        np.testing.assert_allclose(mine, obs, atol=2e-5, err_msg=f"step {k}")
        actions = rng.uniform(-1.3, 1.3, (2, 15))
        out, _, done, _ = env.step(torch.tensor(actions, dtype=torch.float32))
        ctrl.advance(actions)
        obs = out["policy"].numpy()
        ended, asked = done.numpy().astype(bool), ctrl.target.copy()
        ctrl.reset(ended)
        ctrl.params[ended] = asked[ended]  # the simulator restarts a CPG at the parameters it was asked for last
        np.testing.assert_allclose(obs[~ended, last], np.clip(actions[~ended], -1, 1), atol=1e-6)
        assert (obs[ended, last] == 0).all() and (ctrl.last_actions[ended] == 0).all()
    assert k == 24 and env.episode_stats()["episodes"] >= 4  # the episodes ended and restarted on both sides
    with pytest.raises(ValueError, match="pass the IMU's gyro"):
        ctrl.observe(q[:, 7:], qd[:, 6:], q[:, 3:7], *parts)


def test_a_checkpoint_from_before_the_switches_loads_evaluates_and_exports(tmp_path):
    """The shipped complex policy, trained before ``ObsConfig`` existed: it rebuilds the paper's observation with the
    posture (62 inputs, no critic group), evaluation's rounds run it, and its bundle's layout is the one it always had
    (the export itself: test_reflex_bundle_reads_the_attitude_at_every_substep)."""
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.config import ObsConfig
    from hexnewton.learning.checkpoint import checkpoint_agent, load_checkpoint, trained_config
    from hexnewton.learning.policy import load_runner
    from hexnewton.mdp.env import make_env
    from hexnewton.tasks import course

    ckpt = load_checkpoint(REFLEX_POLICY)
    trained = trained_config(ckpt)
    assert trained.obs == ObsConfig() and "obs" not in ckpt["infos"]["hexnewton"]["config"]
    env = make_env(course("stepped", trained, None, 2, "cpu"), "cpg")
    assert env.obs_layout == "cpg_posture" and env.num_obs == 62 and env.obs_groups == ("policy",)
    runner = load_runner(env, REFLEX_POLICY, "cpg", ckpt)
    assert runner.alg.actor.obs_groups == ["policy"] and runner.alg.critic.obs_groups == ["policy"]
    assert checkpoint_agent(ckpt).to_rsl_rl(2, env.obs_groups)["obs_groups"]["critic"] == ["policy"]
    ep = run_rounds("cpg_rl", REFLEX_POLICY, "stepped", 2, "cpu", 60, False)
    assert ep.pos.shape[1] == 2 and np.isfinite(ep.pos[-1]).all() and (ep.pos[-1, :, 0] > 0.05).all()


def test_second_robot_bundle_names_its_robot_and_replays(tmp_path):
    """The shipped policy's checkpoint given the MX-Phoenix's config (its robot and scales, ``with_robot``): its bundle
    names the robot and carries its joint names, senses, limits, standing height, scales and whole description; the
    runtime reproduces the simulator's joint targets (the observed heights scaled); C MuJoCo builds the robot from the
    bundle alone."""
    import dataclasses

    import torch

    from hexnewton.analysis.sim2sim import Rounds
    from hexnewton.config import config_from_dict
    from hexnewton.deploy.runtime import replay, spec_robot
    from hexnewton.robot import stand_height
    from hexnewton.robot.registry import ROBOTS, same_robot, with_robot

    ck = torch.load(POLICY, map_location="cpu", weights_only=False)
    cfg = with_robot(config_from_dict(ck["infos"]["hexnewton"]["config"]), ROBOTS["mx_phoenix"])
    ck["infos"]["hexnewton"]["config"] = dataclasses.asdict(cfg)
    torch.save(ck, tmp_path / "mx.pt")
    out = tmp_path / "mx"
    proc = _run(["-m", "hexnewton.apps.export", "--checkpoint", str(tmp_path / "mx.pt"), "--out", str(out),
                 "--steps", "20", "--robots", "2", "--robot", "mx_phoenix"])  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    spec = json.loads((out / "controller.json").read_text())
    assert spec["robot"] == "mx_phoenix" and spec["height_scale"] == pytest.approx(cfg.task.height_scale)
    assert spec["stand_height"] == pytest.approx(stand_height(ROBOTS["mx_phoenix"]))
    assert spec["joint_signs"] == [1.0] * 18 and len(spec["joint_limits"]) == 18
    assert same_robot(spec_robot(spec), ROBOTS["mx_phoenix"])
    assert replay(str(out))["max_target_diff_rad"] < 1e-4
    r = Rounds(str(out), "flat", 1)
    assert r.m.body_mass[1:].sum() == pytest.approx(4.2) and r.scan.half == pytest.approx(0.3 * cfg.task.length_scale)
