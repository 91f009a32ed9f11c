"""Domain randomisation's per-env physical draws (``RandomizationConfig``, the MDP's): each env's friction, payload,
link masses, PD gains, effort limits and, where set, foot radius and contact time constant, drawn once when an env is
built and written into its :class:`~hexnewton.sim.World`'s Newton model, then handed to MuJoCo. The per-step
randomisation (actuation latency, observation noise, pushes) is in :mod:`hexnewton.kernels.randomization`."""

from __future__ import annotations

import numpy as np

import newton

from .robot import BASE_QD
from .sim import World


def randomize_physics(world: World, seed: int = 0) -> dict[str, np.ndarray]:
    """Draw each env's physical properties from ``world.cfg.randomization`` (``RandomizationConfig``), write them into
    the world's Newton model and hand them to MuJoCo: contact friction, torso payload, leg link masses, PD gains and
    effort limits, foot radius and contact time constant (where set). Returns the per-env draws."""
    r, m, n = world.cfg.randomization, world.model, world.num_envs
    rng = np.random.default_rng([seed, 0x5EED])
    u = lambda lo_hi: rng.uniform(lo_hi[0], lo_hi[1], n)  # noqa: E731
    draws = {"friction": u(r.friction), "payload": u(r.payload), "link_mass_scale": u(r.link_mass_scale),
             "kp_scale": u(r.kp_scale), "kd_scale": u(r.kd_scale), "effort_scale": u(r.effort_scale)}  # fmt: skip
    # friction: MuJoCo combines two geoms' friction by max, so the shared ground takes the range's minimum
    # and every robot shape its env's draw
    shape_world = m.shape_world.numpy()
    mu = m.shape_material_mu.numpy()
    robot = shape_world >= 0
    mu[robot] = draws["friction"][shape_world[robot]]
    mu[~robot] = min(r.friction)
    m.shape_material_mu.assign(mu)
    draws.update(_contact_draws(world, rng, robot, shape_world))
    # masses: bodies are laid out env by env, torso first; inertia scales with the mass
    per_env = m.body_count // n
    mass = m.body_mass.numpy().reshape(n, per_env)
    inertia = m.body_inertia.numpy().reshape(n, per_env, 3, 3)
    scale = np.ones((n, per_env))
    scale[:, 0] = (mass[:, 0] + draws["payload"]) / mass[:, 0]
    scale[:, 1:] = draws["link_mass_scale"][:, None]
    mass = mass * scale
    inertia = inertia * scale[:, :, None, None]
    m.body_mass.assign(mass.reshape(-1).astype(np.float32))
    m.body_inv_mass.assign(np.where(mass > 0, 1.0 / mass, 0.0).reshape(-1).astype(np.float32))
    m.body_inertia.assign(inertia.reshape(-1, 3, 3).astype(np.float32))
    m.body_inv_inertia.assign(np.linalg.inv(inertia.reshape(-1, 3, 3)).astype(np.float32))
    # the 18 actuated joints of each env (after the 6 base dofs)
    nd = m.joint_dof_count // n
    for name, key in (("joint_target_ke", "kp_scale"), ("joint_target_kd", "kd_scale"),
                      ("joint_effort_limit", "effort_scale")):  # fmt: skip
        a = getattr(m, name).numpy().reshape(n, nd)
        a[:, BASE_QD:] *= draws[key][:, None]
        getattr(m, name).assign(a.reshape(-1))
    world.solver.notify_model_changed(newton.ModelFlags.SHAPE_PROPERTIES | newton.ModelFlags.BODY_INERTIAL_PROPERTIES
                                      | newton.ModelFlags.JOINT_DOF_PROPERTIES | newton.ModelFlags.ACTUATOR_PROPERTIES)
    return draws


def _contact_draws(world: World, rng: np.random.Generator, robot: np.ndarray, shape_world: np.ndarray) -> dict:
    """Each env's foot radius (``shape_scale`` of its ``*_foot`` spheres, their bounding radius with it) and its
    robot-ground contact time constant, where ``cfg.randomization`` sets them. MuJoCo averages the two geoms'
    solref, so the robot's shapes get ``2 t - t_ground`` (stiffness 1/t², damping 2/t: damping ratio 1)."""
    r, m, n = world.cfg.randomization, world.model, world.num_envs
    draws = {}
    if r.foot_radius is not None:
        draws["foot_radius"] = radius = rng.uniform(r.foot_radius[0], r.foot_radius[1], n)
        feet = robot & np.array([str(label).endswith("_foot") for label in m.shape_label])
        scale, bound = m.shape_scale.numpy(), m.shape_collision_radius.numpy()
        scale[feet, 0] = bound[feet] = radius[shape_world[feet]]
        m.shape_scale.assign(scale)
        m.shape_collision_radius.assign(bound)
    if r.contact_timeconst is not None:
        draws["contact_timeconst"] = t = rng.uniform(r.contact_timeconst[0], r.contact_timeconst[1], n)
        ke, kd = m.shape_material_ke.numpy(), m.shape_material_kd.numpy()
        ground = ~robot
        t_ground = 2.0 / float(kd[ground][0]) if ground.any() and kd[ground][0] > 0 else 0.02
        t_robot = np.maximum(2.0 * t[shape_world[robot]] - t_ground, 1e-3)
        ke[robot], kd[robot] = 1.0 / t_robot**2, 2.0 / t_robot
        m.shape_material_ke.assign(ke)
        m.shape_material_kd.assign(kd)
    return draws


__all__ = ["randomize_physics"]
