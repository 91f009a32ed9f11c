"""The critic's own observation group (hexnewton/mdp/terms/critic.py, ObsConfig.critic): the fused kernel against its
float64 twin on random states, the env emitting it with the world's leg contact forces and the randomised physics, and
rsl-rl's observation groups following the env's."""

import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import torch
import warp as wp

from hexnewton.config import HexConfig, ObsConfig, RandomizationConfig, SimConfig, TerrainConfig
from hexnewton.mdp.env import make_env
from hexnewton.mdp.terms import (
    BASE_LAYOUTS,
    CRITIC_DIM,
    CRITIC_LAYOUT,
    CRITIC_TERMS,
    PHYSICS,
    CriticInputs,
    critic_kernel,
    critic_reference,
    height_field_from_grid,
    make_struct,
)
from hexnewton.kernels.reference import quat_rotate_inv_np
from hexnewton.terrain import make_terrain, terrain_height_np

DEV = "cpu"
BODIES = 19  # per robot: torso, then coxa, femur, tibia per leg
FOOT = np.array([0.0, 0.0, -0.13])


def _quat(roll, pitch, yaw):
    """(x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr, cp, sp, cy, sy = (f(a / 2) for a in (roll, pitch, yaw) for f in (np.cos, np.sin))
    return np.stack([sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy,
                     cr * cp * cy + sr * sp * sy], axis=-1)  # fmt: skip


def _rotate(q, v):
    return quat_rotate_inv_np(q * np.array([-1.0, -1.0, -1.0, 1.0]), v)


def _cell_centres(rng, lo, hi, shape):
    """Points at the centres of 1 cm cells (float32 and float64 cell indices agree there)."""
    return (np.floor(rng.uniform(lo, hi, shape) / 0.01) + 0.5) * 0.01


def _random_inputs(rng, n, grid):
    """Random critic inputs on ``grid`` whose height samples all fall on cell centres: the bases and feet at cell
    centres, the bases' yaw a multiple of 90 degrees (the points ahead are then 1 cm multiples away), random roll,
    pitch and tibia attitudes; a few blown-up velocities, some episodes at their first step, some oscillators at 0."""
    q = np.zeros((n, 25))
    q[:, 0], q[:, 1] = _cell_centres(rng, -0.5, 3.5, n), _cell_centres(rng, -1.0, 1.0, n)
    q[:, 2] = rng.uniform(0.05, 0.5, n)
    q[:, 3:7] = _quat(rng.uniform(-0.3, 0.3, n), rng.uniform(-0.3, 0.3, n), rng.integers(0, 4, n) * math.pi / 2)
    qd = rng.normal(0.0, 1.0, (n, 24))
    qd[:3, rng.integers(0, 6)] = np.nan
    feet = np.stack([_cell_centres(rng, -0.5, 3.5, (n, 6)), _cell_centres(rng, -1.0, 1.0, (n, 6)),
                     rng.uniform(0.0, 0.3, (n, 6))], axis=-1)  # fmt: skip
    tibia_q = rng.normal(size=(n, 6, 4))
    tibia_q /= np.linalg.norm(tibia_q, axis=-1, keepdims=True)
    body_q = rng.normal(size=(n * BODIES, 7))
    body_q[:, 3:] /= np.linalg.norm(body_q[:, 3:], axis=1, keepdims=True)
    legs = np.arange(n)[:, None] * BODIES + 3 + 3 * np.arange(6)[None, :]
    body_q[legs, :3] = feet - _rotate(tibia_q, np.broadcast_to(FOOT, feet.shape))
    body_q[legs, 3:] = tibia_q
    cpg = rng.normal(size=(n, 4))
    cpg[:4, :2] = 0.0
    return {"joint_q": q.astype(np.float32), "joint_qd": qd.astype(np.float32), "body_q": body_q.astype(np.float32),
            "lower_legs": legs.astype(np.int32), "forces": rng.normal(0.0, 5.0, (n, 6, 3)).astype(np.float32),
            "physics": rng.uniform(0.0, 2.0, (n, len(PHYSICS))).astype(np.float32), "cpg_state": cpg.astype(np.float32),
            "episode_steps": rng.integers(0, 3, n).astype(np.int32)}  # fmt: skip


def _run(arrays, grid):
    """The kernel's critic group and the float64 reference's, for every layout."""
    n = len(arrays["joint_q"])
    types = {"body_q": wp.transform, "forces": wp.vec3}
    dev = {k: wp.array(v, dtype=types[k], device=DEV) if k in types else wp.array(v, device=DEV)
           for k, v in arrays.items()}  # fmt: skip
    inputs = make_struct(CriticInputs, foot=wp.vec3(*FOOT), hf=height_field_from_grid(grid, DEV), **dev)
    ns = SimpleNamespace(**arrays, foot=FOOT, ground_at=lambda x, y: terrain_height_np(grid, x, y))
    out = {}
    for layout in BASE_LAYOUTS:
        got = wp.zeros((n, CRITIC_DIM[layout]), dtype=wp.float32, device=DEV)
        wp.launch(critic_kernel, dim=n, inputs=[inputs, BASE_LAYOUTS.index(layout)], outputs=[got], device=DEV)
        out[layout] = (got.numpy(), critic_reference(ns, layout), ns)
    return out


def test_critic_kernel_matches_reference_on_random_states():
    """Every part of the fused kernel against its row's float64 NumPy function, on the complex course (blocks and
    stairs), in every layout; non-finite values are 0, the forces 0 on an episode's first step."""
    grid = make_terrain(TerrainConfig(name="complex")).grid
    arrays = _random_inputs(np.random.default_rng(4), 96, grid)
    for layout, (got, ref, ns) in _run(arrays, grid).items():
        assert got.shape == ref.shape == (96, CRITIC_DIM[layout]) and np.isfinite(got).all()
        np.testing.assert_allclose(got, ref, atol=2e-4, rtol=1e-4)
        for name, a, b in CRITIC_LAYOUT[layout]:
            row = next(t for t in CRITIC_TERMS if t.name == name)
            want = np.nan_to_num(row.reference(ns), nan=0.0)
            np.testing.assert_allclose(got[:, a:b], want, atol=2e-4, rtol=1e-4, err_msg=name)
    assert [name for name, _, _ in CRITIC_LAYOUT["cpg"]][-1] == "cpg_phase" and CRITIC_DIM == {
        "cpg": 106, "cpg_posture": 106, "joint": 102}  # fmt: skip
    got, _, _ = _run(arrays, grid)["cpg"]
    cols = {name: slice(a, b) for name, a, b in CRITIC_LAYOUT["cpg"]}
    assert (got[:3, cols["base_lin_vel"]] == 0).all() or (got[:3, cols["base_ang_vel"]] == 0).all()  # NaN -> 0
    first = arrays["episode_steps"] == 0
    assert (got[first, cols["leg_forces"]] == 0).all() and np.abs(got[~first, cols["leg_forces"]]).max() > 1
    np.testing.assert_allclose(got[:4, cols["cpg_phase"]][:, :2], np.tile([1.0, 0.0], (4, 1)))  # phase of (0, 0)
    # the ground under a foot where it is known: the foot grid's centre is the cell under the foot
    foot = 9 * np.arange(6) + 4
    feet = arrays["body_q"][arrays["lower_legs"], :3] + _rotate(arrays["body_q"][arrays["lower_legs"], 3:], FOOT)
    np.testing.assert_allclose(got[:, cols["foot_heights"]][:, foot],
                               terrain_height_np(grid, feet[..., 0], feet[..., 1]) - feet[..., 2], atol=2e-5)


def test_env_emits_the_critic_group_with_contacts_and_physics():
    """An env with ObsConfig.critic: observation groups policy and critic (rsl-rl's critic reads both, the actor the
    policy group); the critic group is its kernel's reference on the env's own state, the lower legs carry the robot's
    weight standing, the physics columns are the env's draws and latency flags, and the actor's observation is the
    paper's (the switch adds no policy column)."""
    from hexnewton.learning.agent import AgentConfig

    cfg = HexConfig(sim=SimConfig(num_envs=3, device=DEV), terrain=TerrainConfig(name="flat"),
                    randomization=RandomizationConfig(enabled=True, push_interval=100.0, latency_share=0.5),
                    obs=ObsConfig(critic=True))  # fmt: skip
    env = make_env(cfg)
    assert env.obs_groups == ("policy", "critic") and env.num_obs == 59
    groups = AgentConfig().to_rsl_rl(3, env.obs_groups)["obs_groups"]
    assert groups == {"actor": ["policy"], "critic": ["policy", "critic"]}
    assert AgentConfig().to_rsl_rl(3)["obs_groups"] == {"actor": ["policy"], "critic": ["policy"]}
    cols = {name: slice(a, b) for name, a, b in CRITIC_LAYOUT["cpg"]}
    load = []
    for k in range(60):  # mid-range actions: the CPG walks
        obs, *_ = env.step(torch.zeros(3, env.num_actions))
        if k >= 20:
            load.append(obs["critic"].numpy()[:, cols["leg_forces"]].reshape(3, 6, 3))
    assert set(obs.keys()) == {"policy", "critic"} and obs["critic"].shape == (3, CRITIC_DIM["cpg"])
    w = env.world
    ns = SimpleNamespace(joint_q=w.joint_q_wp.numpy(), joint_qd=w.joint_qd_wp.numpy(),
                         body_q=w.state_0.body_q.numpy(), lower_legs=w.lower_legs, foot=FOOT,
                         forces=env._leg_forces.numpy(), physics=env.physics.numpy(),
                         cpg_state=env.cpg.state.numpy(), episode_steps=env.episode_steps.numpy(),
                         ground_at=lambda x, y: terrain_height_np(w.terrain.grid, x, y))  # fmt: skip
    np.testing.assert_allclose(obs["critic"].numpy(), critic_reference(ns, "cpg"), atol=1e-4, rtol=1e-4)
    load = np.stack(load)  # (steps, envs, legs, xyz): on flat ground the legs push up, on average the weight
    weight = w.model.body_mass.numpy().reshape(3, BODIES).sum(axis=1) * 9.81  # with each env's payload
    assert (load[..., 2] >= -1e-3).all() and (load[..., 2].max(axis=2) > 0).all()
    np.testing.assert_allclose(load[..., 2].sum(axis=2).mean(axis=0), weight, rtol=0.1)
    physics = obs["critic"].numpy()[:, cols["physics"]]
    for k, name in enumerate(PHYSICS[:-1]):
        want = env.physical_draws.get(name)
        if want is not None:
            np.testing.assert_allclose(physics[:, k], want, rtol=1e-6, err_msg=name)
    np.testing.assert_array_equal(physics[:, -1], env._late.numpy().astype(np.float32))
    nominal = dict(zip(PHYSICS, physics[0]))
    assert nominal["foot_radius"] == np.float32(cfg.robot.foot_radius)
    assert nominal["contact_timeconst"] == np.float32(0.02)
    # without the switch: one group, no contact tracking
    plain = make_env(dataclasses.replace(cfg, obs=ObsConfig()))
    assert plain.obs_groups == ("policy",) and set(plain.get_observations().keys()) == {"policy"}
    assert plain.world.leg_sensor is None
