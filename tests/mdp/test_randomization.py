"""Domain randomisation: per-env physical draws reach MuJoCo; latency, observation noise and pushes against
their NumPy references; a randomised env trains-ready (finite, captured) on CPU."""

from dataclasses import replace

import numpy as np
import pytest
import torch
import warp as wp

from hexnewton.config import HexConfig, RandomizationConfig, SimConfig, TaskConfig
from hexnewton.mdp.env import make_env
from hexnewton.kernels.events import (
    delay_actions_kernel,
    delay_actions_reference,
    observation_noise_kernel,
    push_kernel,
    pushed_envs_reference,
)
from hexnewton.mdp.terms import OBS_LAYOUT
from hexnewton.kernels.reference import scale_actions_reference

DEV = "cpu"
RZ = RandomizationConfig(enabled=True)


def test_delay_actions_matches_reference():
    rng = np.random.default_rng(0)
    n, a = 64, 15
    actions, prev = rng.uniform(-1, 1, (n, a)).astype(np.float32), rng.uniform(-1, 1, (n, a)).astype(np.float32)
    late = rng.random(n) < 0.5
    prev_wp, eff = wp.array(prev, device=DEV), wp.zeros((n, a), dtype=wp.float32, device=DEV)
    wp.launch(delay_actions_kernel, dim=(n, a), inputs=[wp.array(actions, device=DEV), wp.array(late, dtype=wp.bool,
              device=DEV)], outputs=[prev_wp, eff], device=DEV)  # fmt: skip
    want_eff, want_prev = delay_actions_reference(actions, late, prev)
    np.testing.assert_array_equal(eff.numpy(), want_eff.astype(np.float32))
    np.testing.assert_array_equal(prev_wp.numpy(), want_prev.astype(np.float32))


def test_observation_noise_bounds():
    n = 256
    layout = OBS_LAYOUT["cpg"]
    amp = np.zeros(59, np.float32)
    amp[0:18], amp[18:36] = RZ.noise_joint_pos, RZ.noise_joint_vel
    obs = np.random.default_rng(1).normal(size=(n, 59)).astype(np.float32)
    o = wp.array(obs, device=DEV)
    wp.launch(observation_noise_kernel, dim=n, inputs=[wp.array(amp, device=DEV), 7, wp.array([3], dtype=wp.int32,
              device=DEV)], outputs=[o], device=DEV)  # fmt: skip
    d = o.numpy() - obs
    assert np.all(np.abs(d) <= amp + 1e-6) and np.all(d[:, 36:] == 0.0)
    assert np.abs(d[:, 18:36]).max() > 0.9 * RZ.noise_joint_vel and abs(d[:, 18:36].mean()) < 0.05
    assert len(layout) == 7


def test_push_kernel_matches_reference():
    n, interval, v = 40, 5, 0.3
    steps = np.arange(n, dtype=np.int32)
    qd = np.zeros((n, 24), np.float32)
    q = wp.array(qd, device=DEV)
    wp.launch(push_kernel, dim=n, inputs=[wp.array(steps, device=DEV), interval, v, 3, wp.array([0], dtype=wp.int32,
              device=DEV)], outputs=[q], device=DEV)  # fmt: skip
    pushed = np.any(q.numpy()[:, :2] != 0, axis=1)
    np.testing.assert_array_equal(pushed, pushed_envs_reference(steps, interval))
    assert np.all(np.abs(q.numpy()[:, :2]) <= v) and np.all(q.numpy()[:, 2:] == 0)


@pytest.fixture(scope="module")
def pair():
    cfg = HexConfig(sim=replace(SimConfig(), num_envs=8, device=DEV), task=replace(TaskConfig(), seed=3),
                    randomization=replace(RZ, push_interval=0.1))  # fmt: skip
    return make_env(cfg), make_env(replace(cfg, randomization=RandomizationConfig()))


def test_physical_draws_reach_mujoco(pair):
    env, _ = pair
    d, m, n = env.physical_draws, env.world.solver.mjw_model, 8
    for key, rng in (("friction", RZ.friction), ("payload", RZ.payload), ("kp_scale", RZ.kp_scale),
                     ("effort_scale", RZ.effort_scale), ("link_mass_scale", RZ.link_mass_scale)):  # fmt: skip
        assert d[key].shape == (n,) and np.all((d[key] >= rng[0]) & (d[key] <= rng[1])) and d[key].std() > 0
    friction = m.geom_friction.numpy()[:, :, 0]  # (worlds, geoms): the ground (min of the range), then the robot
    np.testing.assert_allclose(friction[:, 0], min(RZ.friction), rtol=1e-6)
    np.testing.assert_allclose(friction[:, 1:].max(axis=1), d["friction"], rtol=1e-6)
    torso = m.body_mass.numpy()[:, 1]
    np.testing.assert_allclose(torso, 1.6 + d["payload"], rtol=1e-5)
    kp = m.actuator_gainprm.numpy()[:, :, 0]
    np.testing.assert_allclose(kp, 40.0 * d["kp_scale"][:, None] * np.ones((1, 18)), rtol=1e-5)
    effort = m.jnt_actfrcrange.numpy()[:, 1:, 1]
    np.testing.assert_allclose(effort, 3.5 * d["effort_scale"][:, None] * np.ones((1, 18)), rtol=1e-5)


def test_randomised_env_steps(pair):
    env, plain = pair
    late = env._late.numpy()
    a0, a1 = torch.full((8, 15), -0.5), torch.full((8, 15), 0.5)
    env.step(a0)
    plain.step(a0)
    obs, rew, done, _ = env.step(a1)
    plain.step(a1)
    lo, hi = env.cpg.lower.numpy(), env.cpg.upper.numpy()
    target = env.cpg.params_target.numpy()
    np.testing.assert_allclose(target[late], scale_actions_reference(a0.numpy()[late], lo, hi), rtol=1e-6)  # 20 ms late
    np.testing.assert_allclose(target[~late], scale_actions_reference(a1.numpy()[~late], lo, hi), rtol=1e-6)
    for _ in range(10):  # a push every 5 steps (push_interval 0.1 s)
        obs, rew, done, _ = env.step(a1)
        obs_plain, *_ = plain.step(a1)
    assert torch.isfinite(obs["policy"]).all() and torch.isfinite(rew).all()
    noise = (obs["policy"] - obs_plain["policy"]).abs()
    assert float(noise[:, 18:36].max()) > 0  # noisy (and physically different) observations
    assert float(noise[~late][:, 39:54].max()) < 1e-5  # the CPG parameters are the controller's own: exact


def test_evaluation_under_perturbed_conditions():
    from hexnewton.analysis.rollout import run_rounds

    ep = run_rounds("cpg", None, "flat", 3, DEV, 20, progress=False,
                    overrides={"task.reset_yaw": 0.0, "randomization.enabled": True, "task.goal_distance": 5.5})
    assert ep.pos.shape == (20, 3, 2) and np.isfinite(ep.pos).all() and ep.pos[-1, :, 0].min() > 0


def test_foot_radius_and_contact_timeconst_reach_both_simulators():
    """The drawn foot radius sizes each env's foot spheres for Newton's collision and MuJoCo, and the drawn time
    constant is the solref of that env's robot-ground contacts after MuJoCo's averaging with the ground's."""
    from hexnewton.mdp.events import randomize_physics
    from hexnewton.physics.world import World

    rz = RandomizationConfig(enabled=True, foot_radius=(0.010, 0.014), contact_timeconst=(0.015, 0.03))
    cfg = HexConfig(sim=replace(SimConfig(), num_envs=4, device=DEV), randomization=rz)
    w = World(cfg)
    d, m, solver = randomize_physics(w, seed=3), w.model, w.solver
    for key, (lo, hi) in (("foot_radius", rz.foot_radius), ("contact_timeconst", rz.contact_timeconst)):
        assert d[key].shape == (4,) and np.all((d[key] >= lo) & (d[key] <= hi)) and d[key].std() > 0
    feet = np.array([str(s).endswith("_foot") for s in m.shape_label])
    world = m.shape_world.numpy()
    np.testing.assert_allclose(m.shape_scale.numpy()[feet, 0], d["foot_radius"][world[feet]], rtol=1e-6)
    geom_shape = solver.mjc_geom_to_newton_shape.numpy()  # (worlds, geoms) -> Newton shape or -1
    size = solver.mjw_model.geom_size.numpy()[:, :, 0]
    for e in range(4):
        foot_geoms = [g for g, s in enumerate(geom_shape[e]) if s >= 0 and feet[s]]
        assert len(foot_geoms) == 6
        np.testing.assert_allclose(size[e, foot_geoms], d["foot_radius"][e], rtol=1e-6)
    w.step(10)  # standing on flat ground: every contact is robot-ground
    data = solver.mjw_data
    nc = int(data.nacon.numpy()[0])
    assert nc > 0
    solref, contact_world = data.contact.solref.numpy()[:nc], data.contact.worldid.numpy()[:nc]
    np.testing.assert_allclose(solref[:, 0], d["contact_timeconst"][contact_world], rtol=1e-4)
    np.testing.assert_allclose(solref[:, 1], 1.0, rtol=1e-4)


def test_larger_feet_stand_higher():
    """Newton's collision uses the drawn radius: 4 mm more foot radius lifts the standing torso by about 4 mm."""
    from hexnewton.mdp.events import randomize_physics
    from hexnewton.physics.world import World

    heights = []
    for r in (0.010, 0.014):
        rz = RandomizationConfig(enabled=True, foot_radius=(r, r), friction=(0.9, 0.9), payload=(0.0, 0.0),
                                 link_mass_scale=(1.0, 1.0), kp_scale=(1.0, 1.0), kd_scale=(1.0, 1.0),
                                 effort_scale=(1.0, 1.0))  # fmt: skip
        w = World(HexConfig(sim=replace(SimConfig(), num_envs=2, device=DEV), randomization=rz))
        randomize_physics(w)
        w.step(50)
        heights.append(w.base_pos()[:, 2])
    np.testing.assert_allclose(heights[1] - heights[0], 0.004, atol=0.001)


def test_margin_ranges_are_applied():
    """``complex-margin``'s randomisation on 256 robots (CPU): each env's friction, payload, motor strength and own
    gain and effort factors uniform over their ranges (sample mean and quartiles), one motor strength on both the
    gains and the effort limits, and the draws in MuJoCo's model (the ground at the range's lowest friction)."""
    from hexnewton.mdp.events import randomize_physics
    from hexnewton.physics.world import World
    from hexnewton.tasks import task

    rz, n = task("complex-margin").env.randomization, 256
    w = World(HexConfig(sim=replace(SimConfig(), num_envs=n, device=DEV), randomization=rz))
    d = randomize_physics(w, seed=5)
    strength = d["motor_strength"]
    own = {"friction": d["friction"], "payload": d["payload"], "motor_strength": strength,
           "kp_scale": d["kp_scale"] / strength, "effort_scale": d["effort_scale"] / strength}  # fmt: skip
    for key, x in own.items():
        lo, hi = getattr(rz, key)
        u = (x - lo) / (hi - lo)  # uniform in [0, 1]
        assert np.all((u >= 0) & (u <= 1)) and u.min() < 0.05 and u.max() > 0.95, key
        assert abs(u.mean() - 0.5) < 4 * np.sqrt(1 / 12 / n), key
        np.testing.assert_allclose(np.quantile(u, [0.25, 0.5, 0.75]), [0.25, 0.5, 0.75], atol=0.1, err_msg=key)
    # the shared factor: weak gains come with weak effort limits
    assert np.corrcoef(d["kp_scale"], d["effort_scale"])[0, 1] > 0.8
    assert d["kp_scale"].min() >= rz.motor_strength[0] * rz.kp_scale[0] - 1e-12
    m = w.solver.mjw_model
    friction = m.geom_friction.numpy()[:, :, 0]
    np.testing.assert_allclose(friction[:, 0], 0.25, rtol=1e-6)
    np.testing.assert_allclose(friction[:, 1:].max(axis=1), d["friction"], rtol=1e-6)
    np.testing.assert_allclose(m.body_mass.numpy()[:, 1], 1.6 + d["payload"], rtol=1e-5)
    np.testing.assert_allclose(m.actuator_gainprm.numpy()[:, :, 0], 40.0 * d["kp_scale"][:, None] * np.ones((1, 18)),
                               rtol=1e-5)  # fmt: skip
    np.testing.assert_allclose(m.jnt_actfrcrange.numpy()[:, 1:, 1], 3.5 * d["effort_scale"][:, None] * np.ones((1, 18)),
                               rtol=1e-5)  # fmt: skip


def test_motor_strength_off_keeps_the_draws():
    """Without ``motor_strength`` (the default) the draws are those of the recipe's ranges, the same numbers; a bad
    range is one ValueError."""
    from hexnewton.mdp.events import randomize_physics
    from hexnewton.physics.world import World

    cfg = HexConfig(sim=replace(SimConfig(), num_envs=4, device=DEV), randomization=RZ)
    plain = randomize_physics(World(cfg), seed=2)
    strong = randomize_physics(World(replace(cfg, randomization=replace(RZ, motor_strength=(2.0, 2.0)))), seed=2)
    assert "motor_strength" not in plain and np.all(strong["motor_strength"] == 2.0)
    for key in ("friction", "payload", "link_mass_scale", "kd_scale"):
        np.testing.assert_array_equal(plain[key], strong[key])
    np.testing.assert_allclose(strong["kp_scale"], 2.0 * plain["kp_scale"])
    with pytest.raises(ValueError, match="motor_strength must be LO HI with 0 < LO <= HI"):
        randomize_physics(World(replace(cfg, randomization=replace(RZ, motor_strength=(0.0, 1.0)))))
