"""studies/sim2sim/sim2sim_wedge.py's wedge criterion on made-up logs (no simulator): a stuck robot with a foot held between two
taller blocks is wedged; one whose foot rests on top, or that still progresses, is not; bad arguments get one line."""

import importlib.util
import os
import subprocess
import sys

import numpy as np

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "studies", "sim2sim", "sim2sim_wedge.py")


def _script():
    spec = importlib.util.spec_from_file_location("sim2sim_wedge", SCRIPT)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _heights(x, y):
    """2 cm blocks: 4 cm tall except a 0 cm gap at x in [0.10, 0.12)."""
    x = np.asarray(x, float) + 0 * np.asarray(y, float)
    return np.where((x >= 0.10) & (x < 0.12), 0.0, 0.04)


def test_wedge_rounds():
    w = _script()
    t, n = 600, 3
    base_x = np.zeros((t, n))
    base_x[:, 2] = np.linspace(0.0, 1.0, t)  # robot 2 walks on
    feet = np.zeros((t, n, 6, 3))
    feet[..., 0], feet[..., 1], feet[..., 2] = 0.3, 0.0, 0.05  # every foot on top of the blocks
    feet[:, 0, 4] = (0.11, 0.0, 0.012)  # robot 0: foot 4 in the gap, below both neighbours
    feet[:, 2, 1] = (0.11, 0.0, 0.012)  # robot 2: the same foot, but the robot progresses
    out = w.wedge_rounds(base_x, feet, np.ones(n, bool), _heights, 0.02)
    assert out["stuck"] == [0, 1]
    assert out["wedged"] == [0] and out["wedged_feet"] == {0: [4]}
    moving = feet.copy()
    moving[:, 0, 4, 0] = np.linspace(0.0, 0.11, t)  # the foot travels: not held
    assert w.wedge_rounds(base_x, moving, np.ones(n, bool), _heights, 0.02)["wedged"] == []
    assert w.wedge_rounds(base_x, feet, np.array([False, True, True]), _heights, 0.02)["stuck"] == [1]


def test_first_episode_holds_the_last_row():
    w = _script()
    status = np.zeros((5, 2), np.int32)
    status[2, 0], status[3:, 0] = 3, 0  # robot 0 succeeds at step 2 and restarts
    base_x = np.arange(10, dtype=float).reshape(5, 2)
    feet = np.zeros((5, 2, 6, 3))
    ends, x_end, running = w.first_episode(base_x, feet, status)
    assert ends.tolist() == [3, 0] and running.tolist() == [False, True]
    assert x_end.tolist() == [4.0, 9.0] and base_x[4, 0] == 4.0


def test_bad_steps_is_one_line():
    p = subprocess.run([sys.executable, SCRIPT, "--steps", "100", "--out", "x.json"], capture_output=True, text=True,
                       cwd=ROOT)
    assert p.returncode == 2 and p.stderr.strip().splitlines()[-1].endswith("(the 10 s window)")


def test_combine_sums_the_runs(tmp_path):
    w = _script()
    paths = []
    for seed, wedged in ((1000, 1), (1001, 2)):
        run = {"command": "c", "terrain_seed": seed, "mujoco": {"rounds": 20, "success": 10, "fell": 0, "off_course": 1,
                                                                "still_walking": 9, "stuck": 3, "wedged": wedged}}
        paths.append(str(tmp_path / f"m{seed}.json"))
        with open(paths[-1], "w") as f:
            f.write(__import__("json").dumps(run))
    run = {"command": "c", "terrain_seed": 1000, "mujoco_stuck_lift:w200": {"rounds": 20, "success": 12, "wedged": 0}}
    paths.append(str(tmp_path / "labelled.json"))
    with open(paths[-1], "w") as f:
        f.write(__import__("json").dumps(run))
    out = w.combine(paths)
    assert out["mujoco"]["rounds"] == 40 and out["mujoco"]["wedged"] == 3 and out["mujoco"]["terrain_seeds"] == [1000, 1001]
    assert out["mujoco_stuck_lift:w200"] == {"rounds": 20, "success": 12, "wedged": 0, "terrain_seeds": [1000]}


#: Newton's hinge-limit solref of the first leg (R1 hip, knee, ankle) for RobotConfig's limit_ke / limit_kd, read from
#: ``World(course("rugged", trained_config(ckpt), {}, 2, "cpu", 1000, seed=2000)).solver.mjw_model.jnt_solref[0, 1:4]``
#: with the shipped policy's checkpoint
NEWTON_LIMIT_SOLREF = ((0.02431918, 0.45343027), (0.02222878, 0.47427168), (0.02105086, 0.48736027))


def test_mujoco_settings_move_the_bundle_model():
    import mujoco

    from hexnewton.analysis.sim2sim import Rounds

    w = _script()
    r = Rounds(w.BUNDLE, w.TERRAIN, 2, 1000)
    assert r.m.opt.iterations == 100 and r.m.actuator_forcelimited.all() and not r.m.jnt_actfrclimited.any()
    assert np.allclose(r.m.jnt_solref, (0.02, 1.0))
    w.mujoco_variant(r.m, "mujoco")  # the shipped model: unchanged
    assert r.m.opt.iterations == 100 and np.allclose(r.m.jnt_solref, (0.02, 1.0))
    w.mujoco_variant(r.m, "mujoco_newton")
    assert (r.m.opt.iterations, r.m.opt.ls_iterations, r.m.opt.tolerance) == (10, 10, 1e-6)
    assert np.allclose(r.m.jnt_solref[1:4], NEWTON_LIMIT_SOLREF, rtol=1e-5)
    hinge = r.m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE
    assert not r.m.actuator_forcelimited.any() and r.m.jnt_actfrclimited[hinge].all()
    assert np.allclose(r.m.jnt_actfrcrange[hinge], (-3.5, 3.5))
    for _ in range(3):
        r.control_step()
    assert np.isfinite(r.d.qpos).all() and (r.status()[0] == 0).all()


def test_unknown_setting_is_one_line():
    p = subprocess.run([sys.executable, SCRIPT, "--settings", "mujoco_bogus", "--out", "x.json"], capture_output=True,
                       text=True, cwd=ROOT)
    assert p.returncode == 2 and "invalid choice: 'mujoco_bogus'" in p.stderr.strip().splitlines()[-1]


def test_servo_clamp_step():
    """studies/sim2sim/servo_clamp_step.py: the joint's clamp (Newton's) keeps the implicit kv term, so a saturated servo
    accelerates less than under the actuator's clamp (the bundle's), at the same applied torque."""
    script = os.path.join(ROOT, "studies", "sim2sim", "servo_clamp_step.py")
    spec = importlib.util.spec_from_file_location("servo_clamp_step", script)
    s = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(s)
    bundle, newton = s.step_response(False, 1.0), s.step_response(True, 1.0)
    assert bundle["applied_torque_step_1"] == newton["applied_torque_step_1"] == 3.5
    assert newton["qvel_after_1_step"] < 0.7 * bundle["qvel_after_1_step"]
    p = subprocess.run([sys.executable, script, "--step", "9", "--out", "x.json"], capture_output=True, text=True,
                       cwd=ROOT)
    assert p.returncode == 2 and p.stderr.strip().splitlines()[-1].endswith("--step must be in (0, 3] rad")


def test_effort_clamp_on_the_actuators():
    """SimConfig.effort_clamp "actuator" (newton_actuator_clamp): the mujoco_warp model's joint clamp off, every
    actuator clamped to its joint's effort limit, world by world, also after randomize_physics hands MuJoCo new
    limits; the robots step finitely."""
    from hexnewton.config import HexConfig, SimConfig, TerrainConfig
    from hexnewton.mdp.events import randomize_physics
    from hexnewton.physics.world import World

    assert _script().SETTINGS["newton_actuator_clamp"] == {"sim.effort_clamp": "actuator"}
    world = World(HexConfig(sim=SimConfig(num_envs=3, device="cpu", effort_clamp="actuator"),
                            terrain=TerrainConfig(name="flat")))  # fmt: skip
    mw = world.solver.mjw_model
    for draw in range(2):
        if draw:
            randomize_physics(world, seed=0)
        effort = world.model.joint_effort_limit.numpy().reshape(3, -1)[:, 6:]  # the 18 servos after the base dofs
        assert not mw.jnt_actfrclimited.numpy().any() and mw.actuator_forcelimited.numpy().all()
        rng = mw.actuator_forcerange.numpy()
        assert np.allclose(rng[..., 1], effort, rtol=1e-6) and np.allclose(rng[..., 0], -effort, rtol=1e-6)
    assert np.ptp(mw.actuator_forcerange.numpy()[:, 0, 1]) > 0  # the limits differ between worlds
    world.step(5)
    assert np.isfinite(world.state_0.body_q.numpy()).all()


class _Mj:
    """MuJoCo's two half steps, doing nothing (the responses only read sensors and write targets)."""

    def mj_step1(self, m, d):
        pass

    mj_step2 = mj_step1


class _Ctrl:
    """The runtime's controller as the responses use it: fixed targets; oscillator 0 in swing, 1 in stance."""

    def __init__(self, n):
        self.joint_upper = np.array([0.5, 1.5, 0.0])
        self.dy = np.tile([1.0, -1.0], (n, 1))
        self.target = np.zeros((n, 18))
        self.set = 0

    def observe(self, *a):
        return None

    def act(self, obs):
        return None

    def set_actions(self, actions, target=None):
        self.set += 1
        self.target[:] = 0.5  # what the policy asks: every parameter 0.5

    def substep(self, quat):
        t = np.zeros((len(self.dy), 6, 3))
        t[..., 1] = 1.3  # every knee target 1.3 rad
        return t.reshape(len(t), 18)


class _Rounds:
    def __init__(self, n, substeps=1, policy=True):
        from hexnewton.deploy.mjcf import Layout

        self.n, self.substeps, self.policy, self.steps = n, substeps, policy, 0
        self.alive = np.ones(n, bool)
        self.mj, self.m = _Mj(), None
        self.d = type("D", (), {"ctrl": np.zeros(18 * n)})()
        self.layout = Layout.identity(n)  # the servos' controls in order, as the generated model's
        self.ctrl = _Ctrl(n)
        self.knee = np.full((n, 6), 1.2)
        self.goal = np.full(n, 3.0)

    def sensors(self):
        q = np.zeros((self.n, 6, 3))
        q[..., 0], q[..., 1] = 0.2, self.knee
        return {"quat": np.tile([0.0, 0.0, 0.0, 1.0], (self.n, 1)), "joint_pos": q.reshape(self.n, 18),
                "joint_vel": np.zeros((self.n, 18)), "gyro": np.zeros((self.n, 3))}

    def observation_inputs(self, r):
        return {"target": np.c_[self.goal, np.zeros((self.n, 2))], "max_height": np.zeros(self.n)}

    def targets(self, k, r):  # the closed loop's own: policy on the first substep, then the CPG substep
        from hexnewton.analysis.sim2sim import Rounds

        return Rounds.targets(self, k, r)


def test_stall_reflex_lifts_a_lagging_swing_knee():
    w = _script()
    r = _Rounds(2)
    r.knee[0, 0] = 0.8  # robot 0, leg R1 (oscillator 0, swing): knee 0.5 rad behind its 1.3 rad target
    r.knee[0, 1] = 0.8  # leg R2 lags as much, but oscillator 1 is in stance
    from hexnewton.analysis.sim2sim import Rounds

    counts = w.stall_reflex(r, lag=0.3, lift=0.4)
    Rounds.control_step(r)  # the closed loop's own control step on the stand-in
    t = r.d.ctrl.reshape(2, 6, 3)
    assert t[0, 0, 0] == 0.2 and t[0, 0, 1] == 1.5  # hip held at its measured angle, knee 1.3 + 0.4 clipped to 1.5
    assert t[0, 1, 0] == 0.0 and t[0, 1, 1] == 1.3 and np.all(t[1, :, 1] == 1.3)  # stance leg and robot 1 unchanged
    assert counts == {"stalled_leg_substeps": 1, "swing_leg_substeps": 6} and r.steps == 1


def test_stuck_response_turns_on_the_runtimes_and_counts_it():
    """The script's ``mujoco_stuck_lift`` turns on the runtime controller's own stuck response (as a bundle exported
    with ``CPGConfig.stuck_*`` has it) and counts its control steps: the robot that gains no ground gets the lift once
    the window is full, for ``hold`` steps and at once again; the walking robot never."""
    from hexnewton.analysis.sim2sim import fixed_cpg_spec
    from hexnewton.deploy.runtime import Controller

    w = _script()
    r = _Rounds(2)
    r.ctrl = Controller(fixed_cpg_spec(), num_robots=2)
    counts = w.stuck_response(r, window=3, progress=0.02, hold=2, lift=0.3)
    actions = np.zeros((2, r.ctrl.lower.size))
    lifted = []
    for step in range(6):
        r.goal[1] -= 0.1  # robot 1 walks 10 cm a step toward the goal; robot 0 stays
        r.ctrl.set_actions(actions, np.c_[r.goal, np.zeros((2, 2))])
        lifted.append(r.ctrl.target[:, 3:9].mean(axis=1) - (r.ctrl.lower[3] + r.ctrl.upper[3]) / 2)
    lifted = np.round(np.array(lifted), 6)
    assert lifted[:, 1].tolist() == [0.0] * 6
    assert lifted[:, 0].tolist() == [0.0, 0.0, 0.0, 0.3, 0.3, 0.3]  # from step 4, 2 steps, then again
    assert counts == {"responding_robot_steps": 3, "responses": 2}
