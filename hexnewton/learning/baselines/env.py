"""The adapter from ``HexapodEnv`` (an rsl-rl VecEnv of device tensors) to skrl's torch ``Wrapper``."""


def wrap_env(env):
    """``HexapodEnv`` (an rsl-rl VecEnv of device tensors) as skrl's torch ``Wrapper`` (:class:`SkrlVecEnv`)."""
    from hexnewton.learning.baselines.requirement import require_skrl

    require_skrl()

    import gymnasium
    import numpy as np
    from skrl.envs.wrappers.torch import Wrapper

    class SkrlVecEnv(Wrapper):
        """skrl's single-agent torch env API over ``HexapodEnv``: device tensors pass through (the env returns device
        copies of its buffers, so a stored observation is never overwritten by the next step); rewards, terminated
        (a fall, leaving the course, a non-finite state, the goal) and truncated (time-outs,
        ``extras["time_outs"]``) as (N, 1). Finished robots reset inside ``step``; ``reset`` only hands out the
        first observation. The info dict is the env's extras (``log``: device scalars)."""

        def __init__(self):
            super().__init__(env)
            self._observation_space = gymnasium.spaces.Box(-np.inf, np.inf, (env.num_obs,), np.float32)
            self._action_space = gymnasium.spaces.Box(-1.0, 1.0, (env.num_actions,), np.float32)

        @property
        def observation_space(self):
            return self._observation_space

        @property
        def action_space(self):
            return self._action_space

        @property
        def state_space(self):
            return None

        @property
        def num_envs(self) -> int:
            return env.num_envs

        @property
        def num_agents(self) -> int:
            return 1

        def reset(self):
            return env.get_observations()["policy"], {}

        def step(self, actions):
            obs, rew, done, extras = env.step(actions)
            timeout = extras["time_outs"].bool()
            ended = done.bool()
            return (obs["policy"], rew.view(-1, 1), (ended & ~timeout).view(-1, 1), (ended & timeout).view(-1, 1),
                    extras)  # fmt: skip

        def state(self):
            return None

        def render(self, *args, **kwargs):
            return None

        def close(self) -> None:
            env.close()

    return SkrlVecEnv()
