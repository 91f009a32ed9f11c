"""The MDP on top of the physics: the rsl-rl ``VecEnv`` and its control step (``env``), the term tables (``terms``:
episode ends, rewards, observations) and the events (``events``: resets, randomisation, terrain curriculum). Knows no
runner."""
