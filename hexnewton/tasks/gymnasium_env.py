"""A hexnewton task as a Gymnasium environment, batched the way Isaac Lab's and mjlab's are: one ``gym.Env`` holds
``num_envs`` robots, and ``reset`` / ``step`` take and return torch tensors with a leading batch dimension on the
task's device. Finished robots restart by themselves (§2.4.4); ``terminated`` and ``truncated`` mark the step their
episode ended on.

    import gymnasium as gym
    import hexnewton.tasks                                   # registers Hexnewton-<Task>-v0 for every task
    env = gym.make("Hexnewton-Rugged-v0", num_envs=256, device="cpu")
    obs, info = env.reset(seed=0)                            # obs: (256, 59) float32
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

``gym.make`` takes config overrides as ``overrides={"sim.frame_dt": 0.01, "reward.w_tilt": 10.0}`` (paths into the
task's :class:`~hexnewton.config.HexConfig`). rsl-rl trains on :class:`~hexnewton.mdp.env.HexapodEnv` directly
(``env.unwrapped.vec_env``, whose ``obs_groups`` give ``AgentConfig.to_rsl_rl`` the groups its critic reads: with
``ObsConfig.critic``, ``policy`` and ``critic``); ``reset`` and ``step`` return the ``policy`` group, the actor's.

Another robot than the paper's, as ``train.py --robot NAME|FILE`` trains on it (docs/robots.md):

    env = gym.make("Hexnewton-Rugged-v0", num_envs=256, device="cpu", robot="mx_phoenix")

``robot`` is a named robot (:data:`hexnewton.robot.registry.ROBOTS`), a URDF / MJCF file (``robot_joints``: its 18
leg joints in hexnewton's order, where its tree does not show them) or a
:class:`~hexnewton.robot_config.RobotConfig`; it goes into the task's config with its scales
(:func:`hexnewton.robot.registry.with_robot`: the CPG's amplitudes, the heights, the terrain window) before the
``overrides``. A robot that cannot be read, or none of those, is one :class:`~hexnewton.errors.HexnewtonError` line.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import gymnasium as gym
import numpy as np

from hexnewton.errors import HexnewtonError

if TYPE_CHECKING:
    from hexnewton.robot_config import RobotConfig


class HexnewtonGymEnv(gym.Env):
    """``num_envs`` robots of task ``task`` (on ``robot``, the paper's without one: module docstring); spaces are those
    of one robot (``single_*``) and of the batch."""

    metadata = {"render_modes": []}

    def __init__(self, task: str, num_envs: int = 64, device: str | None = None, seed: int | None = None,
                 overrides: dict | None = None, robot: str | os.PathLike | RobotConfig | None = None,
                 robot_joints: tuple[str, ...] | None = None):
        from dataclasses import replace

        from hexnewton.config import apply_overrides
        from hexnewton.mdp.env import make_env
        from hexnewton.robot.registry import resolve_robot, with_robot
        from hexnewton.tasks import task as get_task

        t = get_task(task)
        cfg = t.env
        if robot is not None:  # the robot and its scales first, the overrides on top (train.py --robot)
            cfg = with_robot(cfg, resolve_robot(robot, robot_joints))
        elif robot_joints:
            raise HexnewtonError("robot_joints names the joints of a robot file: give it as robot=")
        cfg = apply_overrides(cfg, overrides or {})
        cfg = replace(cfg, sim=replace(cfg.sim, num_envs=num_envs, device=device))
        if seed is not None:
            cfg = replace(cfg, task=replace(cfg.task, seed=seed))
        self.task = t.name
        self.vec_env = make_env(cfg, t.action_mode)
        self.num_envs = num_envs
        self.device = self.vec_env.device
        n_obs, n_act = self.vec_env.num_obs, self.vec_env.num_actions
        self.single_observation_space = gym.spaces.Box(-np.inf, np.inf, (n_obs,), np.float32)
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (n_act,), np.float32)
        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (num_envs, n_obs), np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (num_envs, n_act), np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Every robot back to a (randomised) start; ``seed`` reseeds the action space's sampler."""
        super().reset(seed=seed)
        if seed is not None:
            self.action_space.seed(seed)
        return self.vec_env.reset()["policy"], {}

    def step(self, action):
        import torch

        env = self.vec_env
        a = torch.as_tensor(np.asarray(action) if not isinstance(action, torch.Tensor) else action,
                            dtype=torch.float32, device=env.device)  # fmt: skip
        obs, reward, done, extras = env.step(a)
        truncated = extras["time_outs"].bool()
        terminated = done.bool() & ~truncated
        return obs["policy"], reward.clone(), terminated, truncated, {"log": extras["log"]}

    def close(self):
        self.vec_env.close()
