"""The paper's hierarchical baselines SAC-CPG, TD3-CPG and A2C-CPG, trained with skrl 2.1 (torch) on the same batched
env, task config and budget as CPG_RL. The command line is ``python -m hexnewton.apps.baselines``
(``hexnewton/apps/baselines.py``).

    python -m hexnewton.apps.baselines --task complex --algo sac                       # the scale preset, 4096 envs on CUDA
    python -m hexnewton.apps.baselines --task complex --algo td3 --preset paper --total_steps 50000000 --max_minutes 8
    python -m hexnewton.apps.evaluate --controllers cpg_rl sac_cpg --checkpoint cpg_rl=A.pt sac_cpg=logs/.../model_N.pt

What is skrl's and what is ours. skrl runs the algorithms (``skrl.agents.torch.{sac,td3,a2c}``), the replay and
rollout memory (``RandomMemory`` on the env's device), the observation normaliser (``RunningStandardScaler``) and the
exploration noise. Ours, one module each: the settings and their two presets (``config``); ``SkrlVecEnv``, the adapter
from ``HexapodEnv`` to skrl's torch ``Wrapper`` (``env``); the networks (``models``: skrl models, a tanh-squashed
Gaussian actor for SAC, because skrl's ``GaussianMixin`` only clips; a tanh actor for TD3; a Gaussian with a learnt
state-independent std for A2C); skrl's agents built from the settings and the actions a trained one runs
(``agents``); the checkpoint format, tensors and plain data only, and the policy loaded from it (``checkpoint``); the
training loop (``trainer``: :class:`BaselineTrainer`, skrl's ``Trainer.train`` loop plus the budget, the task's
curriculum stages, TensorBoard against env-steps and checkpoints).

The task. A baseline trains on ``hexnewton.tasks.task(name).env`` exactly as ``train.py`` builds it (terrain and its
curriculum lanes, randomisation, physics, body posture, reward; with ``--robot NAME|FILE`` on that robot, the config
scaled for it by ``hexnewton.robot.registry.with_robot``) with the task's own stage schedule of reward weights
and reflex gain (``AgentConfig.stages``): a stage that begins at PPO iteration ``i`` begins here after ``i x
num_steps_per_env`` steps of every env, the same env-steps when the number of envs is the same.

Actions are bounded to [-1, 1], the env's range: SAC's sample is tanh(u) with the log-probability corrected for the
squashing (Haarnoja et al. 2018, App. C), TD3's actor ends in tanh and skrl clips its exploration noise to the action
space, A2C's Gaussian sample is clipped by the env's action kernel (as CPG_RL's Gaussian is) and its deterministic
action is its clipped mean.

Two presets per algorithm, ``scale`` (default, for thousands of envs) and ``paper`` (the paper's Table 2 and, where
it is silent, Stable-Baselines3's defaults): :func:`~hexnewton.learning.baselines.config.agent_config` and the
``config`` module's notes, with every setting's source.

Time-outs (7000 steps, 140 s) bootstrap; falls and the goal do not. The env resets a finished robot inside its step,
so a time-out's next observation is the fresh start's: a small bias on those rare transitions (skrl's SAC and TD3
bootstrap every non-terminated transition from its next observation; A2C with ``time_limit_bootstrap``).

Each run writes ``logs/hexnewton_<task>_<algo>/<date_time>/`` (on another robot, ``--robot``,
``hexnewton_<task>_<algo>_<robot>``): ``config.json``; TensorBoard events whose step is the env-step count
(``Train/mean_reward``, ``Episode/success_rate`` and the env's other logs; wall time is each event's time;
``hexnewton.analysis.curves`` plots against both); ``model_<vector step>.pt`` checkpoints: tensors and plain data only
(``torch.load(weights_only=True)``), the task, robot, algorithm, configs, action mode, observation and action sizes
under ``infos["hexnewton"]`` as for CPG_RL, so ``play.py`` and ``hexnewton.apps.evaluate`` (controllers ``sac_cpg``,
``td3_cpg``, ``a2c_cpg``) load them by path, on the robot they were trained on. With ``skrl_stats`` skrl's own losses
and Q values go to ``skrl/``.

skrl is optional (the ``baselines`` extra: ``pip install -e ".[baselines]"``): nothing imports it before a baseline is
built (``requirement``: :func:`require_skrl`, a one-line error naming the install where it is missing).
"""

from hexnewton.learning.baselines.agents import deterministic_action, make_agent
from hexnewton.learning.baselines.checkpoint import (
    FORMAT,
    check_baseline_checkpoint,
    load_baseline_checkpoint,
    load_baseline_policy,
    save_checkpoint,
)
from hexnewton.learning.baselines.config import (
    ALGOS,
    CONTROLLERS,
    LABELS,
    PRESETS,
    A2CConfig,
    BaselineConfig,
    NetworkConfig,
    SACConfig,
    TD3Config,
    agent_config,
    config_from_dict,
)
from hexnewton.learning.baselines.env import wrap_env
from hexnewton.learning.baselines.models import make_models
from hexnewton.learning.baselines.requirement import INSTALL, require_skrl
from hexnewton.learning.baselines.trainer import BaselineTrainer, Budget, stage_changes

__all__ = ["A2CConfig", "ALGOS", "BaselineConfig", "BaselineTrainer", "Budget", "CONTROLLERS", "FORMAT", "INSTALL",
           "LABELS", "NetworkConfig", "PRESETS", "SACConfig", "TD3Config", "agent_config", "check_baseline_checkpoint",
           "config_from_dict", "deterministic_action", "load_baseline_checkpoint", "load_baseline_policy",
           "make_agent", "make_models", "require_skrl", "save_checkpoint", "stage_changes", "wrap_env"]
