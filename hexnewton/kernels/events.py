"""The events' kernels that read no term table: actuation latency (:func:`delay_actions_kernel`), pushes
(:func:`push_kernel`), observation noise (:func:`observation_noise_kernel`), each beside its float64 NumPy twin, and
the control-step counter their random numbers key on (:func:`advance_counter_kernel`). ``hexnewton.mdp.events`` says
when a control step launches them; its curriculum, placement, reset and bookkeeping kernels stay there, beside the
goals, ground and status codes they read."""

from __future__ import annotations

import numpy as np
import warp as wp


@wp.kernel
def delay_actions_kernel(
    actions: wp.array2d[wp.float32],
    late: wp.array[wp.bool],
    previous: wp.array2d[wp.float32],
    effective: wp.array2d[wp.float32],
):
    e, k = wp.tid()
    a = actions[e, k]
    if late[e]:
        effective[e, k] = previous[e, k]
    else:
        effective[e, k] = a
    previous[e, k] = a


@wp.kernel
def observation_noise_kernel(
    amplitude: wp.array[wp.float32],
    seed: int,
    counter: wp.array[wp.int32],
    obs: wp.array2d[wp.float32],
):
    e = wp.tid()
    rng = wp.rand_init(seed, e + obs.shape[0] * counter[0])
    for j in range(obs.shape[1]):
        obs[e, j] = obs[e, j] + amplitude[j] * (2.0 * wp.randf(rng) - 1.0)


@wp.kernel
def push_kernel(
    episode_steps: wp.array[wp.int32],
    interval: int,
    velocity: float,
    seed: int,
    counter: wp.array[wp.int32],
    joint_qd: wp.array2d[wp.float32],
):
    e = wp.tid()
    k = episode_steps[e]
    if k == 0 or k % interval != 0:
        return
    rng = wp.rand_init(seed, e + joint_qd.shape[0] * counter[0])
    joint_qd[e, 0] = joint_qd[e, 0] + velocity * (2.0 * wp.randf(rng) - 1.0)
    joint_qd[e, 1] = joint_qd[e, 1] + velocity * (2.0 * wp.randf(rng) - 1.0)


def delay_actions_reference(actions, late, previous):
    """Float64 reference of :func:`delay_actions_kernel`: returns (effective, new previous)."""
    a = np.asarray(actions, np.float64)
    return np.where(np.asarray(late, bool)[:, None], np.asarray(previous, np.float64), a), a


def pushed_envs_reference(episode_steps, interval):
    """Which envs :func:`push_kernel` pushes this step (the draws themselves are Warp's)."""
    k = np.asarray(episode_steps)
    return (k != 0) & (k % interval == 0)



@wp.kernel
def advance_counter_kernel(counter: wp.array[wp.int32]):
    counter[0] = counter[0] + 1
