"""The MDP's terms (Huang et al. 2025, §2.4), by kind: episode ends (``terminations``), rewards (``rewards``) and
observations (``observations``), one table of rows and one fused Warp kernel each, on the ground as the terms see it
(``ground``), each env's goal, which they all read (``goals``), and the configuration structs the tables share
(``structs``).

After the physics frames of a control step the env (``hexnewton/mdp/env.py``) launches, in this order, the episode
status kernel (:func:`make_status_kernel`: which envs' episodes end, and why), the rewards kernel of the task's reward
terms (:func:`make_rewards_kernel`), then, after the resets of the finished envs (``hexnewton/mdp/events.py``),
:func:`observations_kernel`. Each kind declares its terms once, in a table of rows (name, parameters, a ``@wp.func`` for
one env, a float64 NumPy function for all envs): ``TERMINATIONS``, ``REWARD_TERMS``, ``OBS_TERMS``. The fused kernel
(the rows unrolled with ``wp.static``, one launch), the log names and the float64 reference follow from the table. A
task chooses its rows: ``TaskConfig.terminations``, ``RewardConfig.terms`` and the observation layout of its action
mode (``LAYOUTS``, with the rows ``ObsConfig`` switches on). With ``ObsConfig.critic`` the critic's own group
(``critic``: ``CRITIC_TERMS``, :func:`critic_kernel`) follows the observations. ``docs/internals.md`` ("The MDP")
gives every term's reasons and how to add one."""

from hexnewton.mdp.terms.critic import (
    CRITIC_DIM,
    CRITIC_LAYOUT,
    CRITIC_TERMS,
    PHYSICS,
    CriticInputs,
    CriticTerm,
    critic_kernel,
    critic_reference,
    physics_columns,
)
from hexnewton.mdp.terms.goals import (
    SWITCH_SEED,
    GoalBuffers,
    Goals,
    check_goals,
    goal_from_draws,
    goal_from_draws_np,
    goal_switch_kernel,
    goal_switch_reference,
    goals_from_host,
    set_goal,
    set_goal_np,
)
from hexnewton.mdp.terms.ground import (
    HeightField,
    height_field_from_grid,
    max_terrain_height,
    sample_heights,
    terrain_height,
)
from hexnewton.mdp.terms.observations import (
    BASE_LAYOUTS,
    H_HALF_EXTENT,
    LAYOUTS,
    OBS_DIM,
    OBS_LAYOUT,
    OBS_TERMS,
    SWITCHES,
    ObsInputs,
    ObsTerm,
    layout_name,
    layout_parts,
    obs_span,
    observation_noise,
    observations_kernel,
    observations_reference,
)
from hexnewton.mdp.terms.rewards import (
    REWARD_NAMES,
    REWARD_TERMS,
    RewardFrame,
    RewardInputs,
    RewardTerm,
    make_rewards_kernel,
    reward_table,
    reward_weights,
    rewards_kernel,
    rewards_reference,
)
from hexnewton.mdp.terms.structs import RewardParams, TaskParams, config_params, make_struct
from hexnewton.mdp.terms.terminations import (
    TERMINATIONS,
    EndInputs,
    Termination,
    episode_status_kernel,
    episode_status_np,
    make_status_kernel,
)

__all__ = ["BASE_LAYOUTS", "CRITIC_DIM", "CRITIC_LAYOUT", "CRITIC_TERMS", "H_HALF_EXTENT", "LAYOUTS", "OBS_DIM",
           "OBS_LAYOUT", "OBS_TERMS", "PHYSICS", "REWARD_NAMES", "REWARD_TERMS", "SWITCHES", "SWITCH_SEED",
           "TERMINATIONS", "CriticInputs", "CriticTerm", "EndInputs", "GoalBuffers", "Goals", "HeightField", "ObsInputs", "ObsTerm", "RewardFrame",
           "RewardInputs", "RewardParams", "RewardTerm", "TaskParams", "Termination", "check_goals", "config_params",
           "critic_kernel",
           "critic_reference", "episode_status_kernel", "episode_status_np", "goal_from_draws", "goal_from_draws_np",
           "goal_switch_kernel", "goal_switch_reference", "goals_from_host", "height_field_from_grid", "layout_name",
           "layout_parts", "make_rewards_kernel", "make_status_kernel", "make_struct", "max_terrain_height",
           "obs_span", "observation_noise", "observations_kernel", "observations_reference", "physics_columns",
           "reward_table", "reward_weights", "rewards_kernel", "rewards_reference", "sample_heights", "set_goal",
           "set_goal_np", "terrain_height"]
