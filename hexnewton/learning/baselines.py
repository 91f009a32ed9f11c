"""The paper's hierarchical baselines SAC-CPG, TD3-CPG and A2C-CPG, trained with skrl 2.1 (torch) on the same batched
env, task config and budget as CPG_RL. The command line is ``python -m hexnewton.apps.baselines`` (``__main__.py``).

    python -m hexnewton.apps.baselines --task complex --algo sac                       # the scale preset, 4096 envs on CUDA
    python -m hexnewton.apps.baselines --task complex --algo td3 --preset paper --total_steps 50000000 --max_minutes 8
    python -m hexnewton.apps.evaluate --controllers cpg_rl sac_cpg --checkpoint cpg_rl=A.pt sac_cpg=logs/.../model_N.pt

What is skrl's and what is ours. skrl runs the algorithms (``skrl.agents.torch.{sac,td3,a2c}``), the replay and
rollout memory (``RandomMemory`` on the env's device), the observation normaliser (``RunningStandardScaler``) and the
exploration noise. Ours: :class:`SkrlVecEnv`, the adapter from ``HexapodEnv`` to skrl's torch ``Wrapper``; the
networks (skrl models: a tanh-squashed Gaussian actor for SAC, because skrl's ``GaussianMixin`` only clips; a tanh
actor for TD3; a Gaussian with a learnt state-independent std for A2C); the training loop
(:class:`BaselineTrainer`, skrl's ``Trainer.train`` loop plus the budget, the task's curriculum stages, TensorBoard
against env-steps and checkpoints); the checkpoint format (tensors and plain data only).

The task. A baseline trains on ``hexnewton.tasks.task(name).env`` exactly as ``train.py`` builds it (terrain and its
curriculum lanes, randomisation, physics, body posture, reward) with the task's own stage schedule of reward weights
and reflex gain (``AgentConfig.stages``): a stage that begins at PPO iteration ``i`` begins here after ``i x
num_steps_per_env`` steps of every env, the same env-steps when the number of envs is the same.

Actions are bounded to [-1, 1], the env's range: SAC's sample is tanh(u) with the log-probability corrected for the
squashing (Haarnoja et al. 2018, App. C), TD3's actor ends in tanh and skrl clips its exploration noise to the action
space, A2C's Gaussian sample is clipped by the env's action kernel (as CPG_RL's Gaussian is) and its deterministic
action is its clipped mean.

Two presets per algorithm (:func:`agent_config`):
- ``scale`` (default), for thousands of envs, after FastTD3 (Seo et al. 2025, ``fast_td3/hyperparams.py``, its
  Isaac Lab settings: 4096 envs, batch 32768, 2 updates per vector step, tau 0.1, learning rate 3e-4, observation
  normalisation, learning from the 10th vector step) and the SAC-at-scale reports (araffin's "Getting SAC to work on
  a massive parallel simulator", Parts I-II; Sabatini et al. 2026, RSL-RL-SAC): bounded actions, a small initial
  entropy coefficient (0.01; skrl's default is 0.2) for a low initial exploration, the replay buffer on the GPU
  (4M transitions: 1024 per env at 4096 envs; FastTD3 keeps 10240 per env, which for our 62-D observations would
  take 25 GB beside the simulator) sampled with replacement (skrl's default draws a permutation of the whole buffer
  on the host for every batch). The replay ratio is 2 x 32768 / 4096 = 16 samples per transition at 4096 envs.
  Not available in skrl 2.1: n-step returns (FastTD3 uses 3 on some tasks; RSL-RL-SAC uses them) and a distributional
  critic. A2C: 24-step rollouts (one PPO iteration of CPG_RL's recipe), 4 mini-batches, learning rate 1e-3 with
  skrl's KL-adaptive schedule at a KL of 0.01, entropy 0.005, gradient norm 1.0, initial std 0.5, observation and
  value normalisation: CPG_RL's PPO settings where A2C has them.
- ``paper``: Table 2 for every algorithm (learning rate 1e-4, batch 512, gamma 0.99, [256, 256, 256, 256] ReLU, GAE
  lambda 0.95 for A2C) and, where Table 2 is silent, the defaults of the library the paper used (Stable-Baselines3):
  a 1M-transition buffer, learning from step 100, tau 0.005, one gradient step per vector step, SAC's entropy
  coefficient learnt from 1.0, TD3's policy delay 2 and target smoothing 0.2 / 0.5 with exploration noise 0.1
  (SB3 has none by default; 0.1 is the TD3 paper's), A2C's 5-step rollouts, no entropy bonus, gradient norm 0.5, no
  normalisation. skrl's A2C uses Adam where SB3's uses RMSprop. At N envs one gradient step per vector step replays
  512 / N samples per transition; the paper's single env replayed 512.

Time-outs (7000 steps, 140 s) bootstrap; falls and the goal do not. The env resets a finished robot inside its step,
so a time-out's next observation is the fresh start's: a small bias on those rare transitions (skrl's SAC and TD3
bootstrap every non-terminated transition from its next observation; A2C with ``time_limit_bootstrap``).

Each run writes ``logs/hexnewton_<task>_<algo>/<date_time>/``: ``config.json``; TensorBoard events whose step is the
env-step count (``Train/mean_reward``, ``Episode/success_rate`` and the env's other logs; wall time is each event's
time; ``hexnewton.analysis.curves`` plots against both); ``model_<vector step>.pt`` checkpoints: tensors and plain data only
(``torch.load(weights_only=True)``), the task, algorithm, configs, action mode, observation and action sizes under
``infos["hexnewton"]`` as for CPG_RL, so ``play.py`` and ``hexnewton.apps.evaluate`` (controllers ``sac_cpg``,
``td3_cpg``, ``a2c_cpg``) load them by path. With ``skrl_stats`` skrl's own losses and Q values go to ``skrl/``.
"""

from __future__ import annotations

import dataclasses
import math
import os
import signal
import time
from dataclasses import dataclass, field

ALGOS = ("sac", "td3", "a2c")
PRESETS = ("scale", "paper")
#: evaluation controller -> algorithm
CONTROLLERS = {"sac_cpg": "sac", "td3_cpg": "td3", "a2c_cpg": "a2c"}
LABELS = {"sac": "SAC-CPG", "td3": "TD3-CPG", "a2c": "A2C-CPG"}
FORMAT = "hexnewton-skrl-2.1"
LOG_STD_RANGE = (-20.0, 2.0)  # SAC's log std, as skrl's GaussianMixin clips it
ACTIVATIONS = ("relu", "elu", "tanh")


# ----------------------------------------------------------------------------------------------------- configs
@dataclass
class NetworkConfig:
    """Hidden layers of every network (actor and critics)."""

    hidden_dims: tuple[int, ...] = (256, 256, 256, 256)
    activation: str = field(default="relu", metadata={"choices": ACTIVATIONS})


@dataclass
class BaselineConfig:
    """Settings every algorithm has."""

    learning_rate: float = 3.0e-4
    gamma: float = 0.99
    #: skrl's ``RunningStandardScaler`` on the observations (saved with the policy)
    obs_normalization: bool = True
    #: global gradient norm clip; 0: none
    grad_norm_clip: float = 0.0
    #: vector steps between TensorBoard points and console lines (24: one PPO iteration of CPG_RL's recipe)
    log_interval: int = 24
    #: vector steps between checkpoints
    save_interval: int = 2400
    #: skrl's own tracking (losses, Q values, rewards) to ``skrl/``; it reads tensors to the host every step
    skrl_stats: bool = False
    model: NetworkConfig = field(default_factory=NetworkConfig)

    def check(self) -> None:
        """ValueError (one line) for a setting skrl would misread or reject late."""
        if not self.learning_rate > 0:
            raise ValueError("agent.learning_rate must be positive")
        if not 0 < self.gamma <= 1:
            raise ValueError("agent.gamma must lie in (0, 1]")
        if self.grad_norm_clip < 0:
            raise ValueError("agent.grad_norm_clip must be >= 0")
        if self.log_interval <= 0 or self.save_interval <= 0:
            raise ValueError("agent.log_interval and agent.save_interval must be positive")
        if not self.model.hidden_dims or min(self.model.hidden_dims) <= 0:
            raise ValueError("agent.model.hidden_dims must be positive layer widths")
        for name in ("batch_size", "gradient_steps", "buffer_size", "policy_delay", "rollouts", "mini_batch_size"):
            value = getattr(self, name, 1)
            if value is not None and value <= 0:
                raise ValueError(f"agent.{name} must be positive")
        if getattr(self, "learning_starts", 0) < 0:
            raise ValueError("agent.learning_starts must be >= 0")


@dataclass
class OffPolicyConfig(BaselineConfig):
    """Replay settings shared by SAC and TD3."""

    batch_size: int = 32768
    #: gradient steps per vector step (each vector step adds num_envs transitions)
    gradient_steps: int = 2
    #: target networks' Polyak factor per gradient step
    polyak: float = 0.1
    #: replay transitions over all envs (skrl keeps buffer_size // num_envs per env)
    buffer_size: int = 4_194_304
    #: vector steps before the first update
    learning_starts: int = 10


@dataclass
class SACConfig(OffPolicyConfig):
    """skrl's SAC with a tanh-squashed Gaussian actor and twin critics."""

    learn_entropy: bool = True
    initial_entropy: float = 0.01
    #: none: -(number of actions)
    target_entropy: float | None = None


@dataclass
class TD3Config(OffPolicyConfig):
    """skrl's TD3 with a tanh actor."""

    policy_delay: int = 2
    #: std of the Gaussian exploration noise added to the actor's action (then clipped to [-1, 1])
    exploration_std: float = 0.2
    #: target policy smoothing: std and clip of its noise
    smoothing_std: float = 0.2
    smoothing_clip: float = 0.5


@dataclass
class A2CConfig(BaselineConfig):
    """skrl's A2C with a Gaussian actor (learnt, state-independent std) and a value network."""

    learning_rate: float = 1.0e-3
    grad_norm_clip: float = 1.0
    #: steps per env between updates
    rollouts: int = 24
    mini_batches: int = 4
    #: samples per mini-batch; set, it replaces ``mini_batches`` (rollouts x num_envs / mini_batch_size)
    mini_batch_size: int | None = None
    gae_lambda: float = 0.95
    entropy_coef: float = 0.005
    init_std: float = 0.5
    #: skrl's KL-adaptive learning rate at this KL; none: a fixed learning rate
    desired_kl: float | None = 0.01
    #: skrl's ``RunningStandardScaler`` on the value targets
    value_normalization: bool = True
    #: bootstrap time-outs (skrl's ``time_limit_bootstrap``)
    time_limit_bootstrap: bool = True


CONFIGS = {"sac": SACConfig, "td3": TD3Config, "a2c": A2CConfig}


def agent_config(algo: str, preset: str = "scale") -> BaselineConfig:
    """The ``scale`` or ``paper`` settings of ``algo`` (module docstring)."""
    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm '{algo}': choose one of {', '.join(ALGOS)}")
    if preset not in PRESETS:
        raise ValueError(f"unknown preset '{preset}': choose one of {', '.join(PRESETS)}")
    cfg = CONFIGS[algo]()
    if preset == "scale":
        return cfg
    table2 = dict(learning_rate=1.0e-4, gamma=0.99, obs_normalization=False,
                  model=NetworkConfig((256, 256, 256, 256), "relu"))  # fmt: skip
    if algo == "a2c":
        return dataclasses.replace(cfg, **table2, rollouts=5, mini_batch_size=512, gae_lambda=0.95, entropy_coef=0.0,
                                   grad_norm_clip=0.5, init_std=1.0, desired_kl=None, value_normalization=False)  # fmt: skip
    off = dict(table2, batch_size=512, gradient_steps=1, polyak=0.005, buffer_size=1_000_000, learning_starts=100)
    if algo == "sac":
        return dataclasses.replace(cfg, **off, initial_entropy=1.0)
    return dataclasses.replace(cfg, **off, exploration_std=0.1)


def config_from_dict(algo: str, d: dict | None) -> BaselineConfig:
    """Rebuild an algorithm's config from ``dataclasses.asdict`` output (a checkpoint's)."""
    from hexnewton.config import dataclass_from_dict

    return dataclass_from_dict(CONFIGS[algo], d or {})


# ----------------------------------------------------------------------------------------------------- env adapter
def wrap_env(env):
    """``HexapodEnv`` (an rsl-rl VecEnv of device tensors) as skrl's torch ``Wrapper`` (:class:`SkrlVecEnv`)."""
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


# ----------------------------------------------------------------------------------------------------- models
def _mlp(sizes: list[int], activation: str):
    import torch.nn as nn

    act = {"relu": nn.ReLU, "elu": nn.ELU, "tanh": nn.Tanh}[activation]
    layers = []
    for k in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[k], sizes[k + 1]))
        if k < len(sizes) - 2:
            layers.append(act())
    return nn.Sequential(*layers)


def _actor_classes(cfg: BaselineConfig, spaces: dict) -> tuple[type, type, type]:
    """The skrl actor models (SAC's squashed Gaussian, TD3's tanh actor, A2C's Gaussian) with ``cfg.model``'s hidden
    layers on ``spaces`` (observation and action spaces, device)."""
    import torch
    import torch.nn.functional as F
    from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
    from torch.distributions import Normal

    hidden, activation = list(cfg.model.hidden_dims), cfg.model.activation

    class SquashedGaussianActor(Model):
        """SAC's actor: a = tanh(u), u ~ N(mean(s), std(s)); ``log_prob`` with the tanh correction; ``mean_actions``
        tanh(mean), the deterministic action."""

        def __init__(self):
            Model.__init__(self, **spaces)
            self.net = _mlp([self.num_observations] + hidden, activation)
            self.trunk_act = {"relu": torch.nn.ReLU, "elu": torch.nn.ELU, "tanh": torch.nn.Tanh}[activation]()
            self.mean = torch.nn.Linear(hidden[-1], self.num_actions)
            self.log_std = torch.nn.Linear(hidden[-1], self.num_actions)

        def compute(self, inputs, role=""):
            h = self.trunk_act(self.net(inputs["observations"]))
            return self.mean(h), {"log_std": self.log_std(h).clamp(*LOG_STD_RANGE)}

        def act(self, inputs, *, role=""):
            mean, outputs = self.compute(inputs, role)
            dist = Normal(mean, outputs["log_std"].exp())
            taken = inputs.get("taken_actions")
            if taken is None:
                u = dist.rsample()
                actions = torch.tanh(u)
            else:
                actions = taken.clamp(-1.0 + 1e-6, 1.0 - 1e-6)
                u = torch.atanh(actions)
            # log(1 - tanh(u)^2) = 2 (log 2 - u - softplus(-2u)), stable for large |u|
            log_prob = dist.log_prob(u) - 2.0 * (math.log(2.0) - u - F.softplus(-2.0 * u))
            outputs.update(log_prob=log_prob.sum(dim=-1, keepdim=True), mean_actions=torch.tanh(mean))
            return actions, outputs

    class TanhActor(DeterministicMixin, Model):
        """TD3's actor: tanh(net(s))."""

        def __init__(self):
            Model.__init__(self, **spaces)
            DeterministicMixin.__init__(self, clip_actions=True)
            self.net = _mlp([self.num_observations] + hidden + [self.num_actions], activation)

        def compute(self, inputs, role=""):
            return torch.tanh(self.net(inputs["observations"])), {}

    class GaussianActor(GaussianMixin, Model):
        """A2C's actor: N(net(s), std) with a learnt state-independent std; the env clips the sample."""

        def __init__(self):
            Model.__init__(self, **spaces)
            GaussianMixin.__init__(self, clip_actions=False, clip_log_std=True, min_log_std=LOG_STD_RANGE[0],
                                   max_log_std=LOG_STD_RANGE[1], reduction="sum")  # fmt: skip
            self.net = _mlp([self.num_observations] + hidden + [self.num_actions], activation)
            self.log_std_param = torch.nn.Parameter(torch.full((self.num_actions,), math.log(cfg.init_std)))

        def compute(self, inputs, role=""):
            mean = self.net(inputs["observations"])
            return mean, {"log_std": self.log_std_param.expand_as(mean)}

    return SquashedGaussianActor, TanhActor, GaussianActor


def _critic_classes(cfg: BaselineConfig, spaces: dict) -> tuple[type, type]:
    """The skrl critic models Q(s, a) (SAC, TD3) and V(s) (A2C) with ``cfg.model``'s hidden layers on ``spaces``."""
    import torch
    from skrl.models.torch import DeterministicMixin, Model

    hidden, activation = list(cfg.model.hidden_dims), cfg.model.activation

    class QCritic(DeterministicMixin, Model):
        """Q(s, a)."""

        def __init__(self):
            Model.__init__(self, **spaces)
            DeterministicMixin.__init__(self, clip_actions=False)
            self.net = _mlp([self.num_observations + self.num_actions] + hidden + [1], activation)

        def compute(self, inputs, role=""):
            return self.net(torch.cat([inputs["observations"], inputs["taken_actions"]], dim=-1)), {}

    class ValueCritic(DeterministicMixin, Model):
        """V(s)."""

        def __init__(self):
            Model.__init__(self, **spaces)
            DeterministicMixin.__init__(self, clip_actions=False)
            self.net = _mlp([self.num_observations] + hidden + [1], activation)

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {}

    return QCritic, ValueCritic


def make_models(algo: str, cfg: BaselineConfig, observation_space, action_space, device) -> dict:
    """skrl models of ``algo``: ``policy`` and the critics (with targets) or the value network."""
    spaces = dict(observation_space=observation_space, action_space=action_space, device=device)
    SquashedGaussianActor, TanhActor, GaussianActor = _actor_classes(cfg, spaces)
    QCritic, ValueCritic = _critic_classes(cfg, spaces)
    if algo == "a2c":
        return {"policy": GaussianActor(), "value": ValueCritic()}
    critics = {"critic_1": QCritic(), "critic_2": QCritic(), "target_critic_1": QCritic(), "target_critic_2": QCritic()}
    if algo == "sac":
        return {"policy": SquashedGaussianActor(), **critics}
    return {"policy": TanhActor(), "target_policy": TanhActor(), **critics}


# ----------------------------------------------------------------------------------------------------- agents
def make_agent(algo: str, cfg: BaselineConfig, observation_space, action_space, device, num_envs: int,
               training: bool = True, run_dir: str | None = None):
    """skrl's agent of ``algo`` with ``cfg`` on ``device``; with ``training`` its memory (replay buffer or rollout
    storage for ``num_envs`` envs) and, with ``cfg.skrl_stats``, its TensorBoard writer in ``run_dir/skrl``."""
    from skrl.agents.torch import ExperimentCfg
    from skrl.memories.torch import RandomMemory
    from skrl.resources.preprocessors.torch import RunningStandardScaler

    cfg.check()
    models = make_models(algo, cfg, observation_space, action_space, device)
    stats = cfg.skrl_stats and training and run_dir is not None
    common = dict(
        discount_factor=cfg.gamma, learning_rate=cfg.learning_rate, grad_norm_clip=cfg.grad_norm_clip,
        experiment=ExperimentCfg(directory=run_dir or "", experiment_name="skrl", checkpoint_interval=0,
                                 write_interval=cfg.log_interval if stats else 0),
    )  # fmt: skip
    if cfg.obs_normalization:
        common.update(observation_preprocessor=RunningStandardScaler,
                      observation_preprocessor_kwargs={"size": observation_space, "device": device})  # fmt: skip
    kw = dict(models=models, observation_space=observation_space, action_space=action_space, device=device)
    if algo == "a2c":
        from skrl.agents.torch.a2c import A2C, A2C_CFG
        from skrl.resources.schedulers.torch import KLAdaptiveLR

        mini = cfg.mini_batches if not cfg.mini_batch_size else max(1, cfg.rollouts * num_envs // cfg.mini_batch_size)
        a2c = A2C_CFG(**common, rollouts=cfg.rollouts, mini_batches=mini, gae_lambda=cfg.gae_lambda,
                      entropy_loss_scale=cfg.entropy_coef, time_limit_bootstrap=cfg.time_limit_bootstrap)  # fmt: skip
        if cfg.desired_kl:
            a2c.learning_rate_scheduler = KLAdaptiveLR
            a2c.learning_rate_scheduler_kwargs = {"kl_threshold": cfg.desired_kl}
        if cfg.value_normalization:
            a2c.value_preprocessor = RunningStandardScaler
            a2c.value_preprocessor_kwargs = {"size": 1, "device": device}
        memory = RandomMemory(memory_size=cfg.rollouts, num_envs=num_envs, device=device) if training else None
        return A2C(memory=memory, cfg=a2c, **kw)
    off = dict(common, batch_size=cfg.batch_size, gradient_steps=cfg.gradient_steps, polyak=cfg.polyak,
               learning_starts=cfg.learning_starts)  # fmt: skip
    rows = max(1, cfg.buffer_size // num_envs)
    memory = RandomMemory(memory_size=rows, num_envs=num_envs, device=device, replacement=True) if training else None
    if algo == "sac":
        from skrl.agents.torch.sac import SAC, SAC_CFG

        return SAC(memory=memory, cfg=SAC_CFG(**off, learn_entropy=cfg.learn_entropy,
                                              initial_entropy_value=cfg.initial_entropy,
                                              target_entropy=cfg.target_entropy), **kw)  # fmt: skip
    from skrl.agents.torch.td3 import TD3, TD3_CFG
    from skrl.resources.noises.torch import GaussianNoise

    return TD3(memory=memory, cfg=TD3_CFG(**off, policy_delay=cfg.policy_delay, exploration_noise=GaussianNoise,
                                          exploration_noise_kwargs={"mean": 0.0, "std": cfg.exploration_std,
                                                                    "device": device},
                                          smooth_regularization_noise=GaussianNoise,
                                          smooth_regularization_noise_kwargs={"mean": 0.0, "std": cfg.smoothing_std,
                                                                              "device": device},
                                          smooth_regularization_clip=cfg.smoothing_clip), **kw)  # fmt: skip


def deterministic_action(algo: str, agent, observations):
    """The action a trained agent runs: SAC's tanh(mean), TD3's actor, A2C's mean clipped to [-1, 1]; observations
    through the agent's normaliser."""
    inputs = {"observations": agent._observation_preprocessor(observations), "states": None}
    actions, outputs = agent.policy.act(inputs, role="policy")
    if algo == "td3":
        return actions
    return outputs["mean_actions"].clamp(-1.0, 1.0)


def sampled_action(algo: str, agent, observations):
    """An action sampled as in training, without TD3's exploration noise (TD3's actor is deterministic)."""
    inputs = {"observations": agent._observation_preprocessor(observations), "states": None}
    actions, _ = agent.policy.act(inputs, role="policy")
    return actions.clamp(-1.0, 1.0)


# ----------------------------------------------------------------------------------------------------- checkpoints
def save_checkpoint(path: str, agent, meta: dict, env_steps: int, timestep: int) -> None:
    """The agent's modules (models, optimisers, normalisers: state dicts) with hexnewton's metadata, written to a
    temporary file and renamed (atomic)."""
    import torch

    modules = {name: agent._get_internal_value(m) for name, m in agent.checkpoint_modules.items() if m is not None}
    torch.save({"format": FORMAT, "algo": meta["algo"], "modules": modules, "env_steps": int(env_steps),
                "timestep": int(timestep), "infos": {"hexnewton": meta}}, path + ".tmp")  # fmt: skip
    os.replace(path + ".tmp", path)


def load_baseline_checkpoint(path: str, map_location: str = "cpu") -> dict:
    """A baseline checkpoint read as tensors and plain data (nothing in the file is executed); one-line errors for a
    missing, damaged or other file."""
    from hexnewton.learning.checkpoint import read_checkpoint

    return check_baseline_checkpoint(read_checkpoint(path, map_location), path)


def check_baseline_checkpoint(ckpt, path: str) -> dict:
    """``ckpt`` (read from ``path``) if it is a baseline checkpoint; a one-line error otherwise."""
    if not isinstance(ckpt, dict) or ckpt.get("format") != FORMAT or "policy" not in ckpt.get("modules", {}):
        what = "an rsl-rl checkpoint (train.py)" if isinstance(ckpt, dict) and "actor_state_dict" in ckpt else "not one"
        raise ValueError(f"{path} is not a skrl baseline checkpoint from python -m hexnewton.apps.baselines ({what})")
    if ckpt["algo"] not in ALGOS:
        raise ValueError(f"{path}: unknown algorithm '{ckpt['algo']}'")
    return ckpt


def load_baseline_policy(env, path: str, controller: str, stochastic: bool = False, ckpt: dict | None = None):
    """``policy(obs TensorDict) -> actions`` of a baseline checkpoint after checking it fits ``env`` and
    ``controller`` (``sac_cpg``, ...): its deterministic action, with ``stochastic`` one sampled as in training."""
    import torch

    from hexnewton.learning.checkpoint import checkpoint_meta

    ckpt = load_baseline_checkpoint(path) if ckpt is None else ckpt
    algo, meta = ckpt["algo"], checkpoint_meta(ckpt)
    if CONTROLLERS.get(controller) != algo:
        raise ValueError(f"{path} holds a {LABELS[algo]} policy, not {controller}")
    if meta.get("action_mode", "cpg") != env.action_mode:
        raise ValueError(f"{path} was trained with action mode '{meta.get('action_mode')}', not '{env.action_mode}'")
    if (meta.get("num_obs"), meta.get("num_actions")) != (env.num_obs, env.num_actions):
        raise ValueError(f"{path} expects {meta.get('num_obs')} observations and {meta.get('num_actions')} actions; "
                         f"this environment has {env.num_obs} and {env.num_actions}")  # fmt: skip
    skrl_env = wrap_env(env)
    device = env._obs_t.device
    agent = make_agent(algo, config_from_dict(algo, meta.get("baseline")), skrl_env.observation_space,
                       skrl_env.action_space, device, env.num_envs, training=False)  # fmt: skip
    for name in ("policy", "observation_preprocessor"):
        module = agent.checkpoint_modules.get(name)
        if module is not None:
            module.load_state_dict(ckpt["modules"][name])
            module.eval()
    act = sampled_action if stochastic else deterministic_action

    def policy(obs):
        with torch.no_grad():
            return act(algo, agent, obs["policy"])

    return policy


# ----------------------------------------------------------------------------------------------------- training
@dataclass
class Budget:
    """When a run ends: ``env_steps`` over all envs or ``max_minutes`` of wall time, whichever comes first."""

    env_steps: int
    max_minutes: float | None = None


class EpisodeReturns:
    """Returns of finished episodes summed on the device (no host read per step); :meth:`take` reads and clears."""

    def __init__(self, num_envs: int, device):
        import torch

        self.ret = torch.zeros(num_envs, device=device)
        self.length = torch.zeros(num_envs, device=device)
        self.sums = torch.zeros(3, device=device)  # returns, lengths, episodes

    def add(self, rewards, ended) -> None:
        import torch

        self.ret += rewards.view(-1)
        self.length += 1.0
        e = ended.view(-1).float()
        self.sums += torch.stack([(self.ret * e).sum(), (self.length * e).sum(), e.sum()])
        self.ret *= 1.0 - e
        self.length *= 1.0 - e

    def take(self) -> tuple[float, float, int]:
        """(mean return, mean length, episodes) since the last call (NaN means when none ended)."""
        ret, length, n = self.sums.tolist()
        self.sums.zero_()
        return (ret / n, length / n, int(n)) if n else (float("nan"), float("nan"), 0)


def stage_changes(stages: tuple, env_step: int, steps_per_iteration: int) -> tuple[int, dict]:
    """(index, merged changes) of the task's curriculum stage that has begun by ``env_step`` steps of every env
    (a stage beginning at PPO iteration ``i`` begins at ``i x steps_per_iteration``); (-1, {}) before the first."""
    begun = [k for k, (start, _) in enumerate(stages) if env_step >= start * steps_per_iteration]
    if not begun:
        return -1, {}
    changes: dict = {}
    for _, c in stages[: begun[-1] + 1]:
        changes.update(c)
    return begun[-1], changes


class BaselineTrainer:
    """skrl's ``Trainer.train`` loop (pre-interaction, act, env step, record transition, post-interaction) for one
    agent on :func:`wrap_env`'s env, with the budget, the task's curriculum stages, TensorBoard against env-steps,
    one console line per log and checkpoints; Ctrl-C, SIGTERM and the time limit end it and save."""

    def __init__(self, env, agent, algo: str, cfg: BaselineConfig, meta: dict, run_dir: str, stages: tuple = (),
                 steps_per_iteration: int = 24):  # fmt: skip
        from skrl.trainers.torch import SequentialTrainerCfg

        self.hex_env, self.env, self.agent, self.algo, self.cfg = env, wrap_env(env), agent, algo, cfg
        self.meta, self.run_dir = meta, run_dir
        self.stages, self.steps_per_iteration, self._stage = stages, steps_per_iteration, -1
        self.trainer_cfg = SequentialTrainerCfg(timesteps=1, headless=True, disable_progressbar=True,
                                                close_environment_at_exit=False)  # fmt: skip
        self.timestep = 0
        self.last_checkpoint: str | None = None

    @property
    def env_steps(self) -> int:
        return self.timestep * self.hex_env.num_envs

    def checkpoint(self) -> str:
        path = os.path.join(self.run_dir, f"model_{self.timestep}.pt")
        save_checkpoint(path, self.agent, self.meta, self.env_steps, self.timestep)
        self.last_checkpoint = path
        return path

    def enter_stage(self) -> None:
        index, changes = stage_changes(self.stages, self.timestep, self.steps_per_iteration)
        if index == self._stage:
            return
        self._stage = index
        env = self.hex_env
        reflex = changes.pop("posture_reflex", env.cfg.cpg.posture_reflex)
        env.set_shaping(dataclasses.replace(env.cfg.reward, **changes), reflex)
        self.meta["config"] = dataclasses.asdict(env.cfg)
        print(f"step {self.timestep}: curriculum stage {index + 2} of {len(self.stages) + 1}: posture_reflex "
              f"{reflex:g}, " + ", ".join(f"{k} {v:g}" for k, v in changes.items()), flush=True)  # fmt: skip

    def train(self, budget: Budget) -> str:
        """Train until the budget is spent; save and return why it ended."""
        import torch
        from torch.utils.tensorboard import SummaryWriter

        from hexnewton.learning.stopping import (  # the signal handling train.py's runner uses
            TrainingStopped,
            catch_stop_signals,
        )

        timesteps = max(1, math.ceil(budget.env_steps / self.hex_env.num_envs))
        self.trainer_cfg.timesteps = timesteps
        agent, env = self.agent, self.env
        agent.init(trainer_cfg=self.trainer_cfg)
        agent.enable_training_mode(True)
        writer = SummaryWriter(log_dir=self.run_dir)
        returns = EpisodeReturns(self.hex_env.num_envs, self.hex_env._obs_t.device)
        handlers = catch_stop_signals()
        t0 = time.monotonic()
        deadline = t0 + 60.0 * budget.max_minutes if budget.max_minutes else math.inf
        reason = f"{budget.env_steps} env-steps"
        obs, _ = env.reset()
        states = env.state()
        try:
            for t in range(timesteps):
                self.timestep = t
                if self.stages:
                    self.enter_stage()
                agent.pre_interaction(timestep=t, timesteps=timesteps)
                with torch.no_grad():
                    actions, _ = agent.act(obs, states, timestep=t, timesteps=timesteps)
                    next_obs, rewards, terminated, truncated, infos = env.step(actions)
                    next_states = env.state()
                    returns.add(rewards, terminated | truncated)  # before A2C adds its time-out bootstrap in place
                    agent.record_transition(observations=obs, states=states, actions=actions, rewards=rewards,
                                            next_observations=next_obs, next_states=next_states,
                                            terminated=terminated, truncated=truncated, infos=infos, timestep=t,
                                            timesteps=timesteps)  # fmt: skip
                agent.post_interaction(timestep=t, timesteps=timesteps)
                obs, states = next_obs, next_states
                self.timestep = t + 1
                if self.timestep % self.cfg.log_interval == 0:
                    self._log(writer, returns, infos["log"], time.monotonic() - t0)
                if self.timestep % self.cfg.save_interval == 0:
                    self.checkpoint()
                if time.monotonic() >= deadline:
                    reason = f"the --max_minutes limit ({budget.max_minutes:g} min)"
                    break
        except TrainingStopped as stop:
            reason = str(stop)
        finally:
            for sig, handler in handlers.items():
                signal.signal(sig, handler)
            if self.timestep % self.cfg.log_interval:
                self._log(writer, returns, self.hex_env._log(), time.monotonic() - t0)
            writer.close()
            self.wall_s = time.monotonic() - t0
            self.checkpoint()
        return reason

    def _log(self, writer, returns: EpisodeReturns, log: dict, elapsed: float) -> None:
        step = self.env_steps
        ret, length, episodes = returns.take()
        if episodes:
            writer.add_scalar("Train/mean_reward", ret, step)
            writer.add_scalar("Train/mean_episode_length", length, step)
        for key, value in log.items():
            writer.add_scalar(key, float(value), step)
        writer.add_scalar("Perf/wall_time_s", elapsed, step)
        writer.add_scalar("Perf/env_steps_per_s", step / max(elapsed, 1e-9), step)
        writer.flush()
        success = float(log["Episode/success_rate"]) if "Episode/success_rate" in log else float("nan")
        print(f"step {self.timestep}  env-steps {step}  return {ret:.2f}  success {success:.3f}  "
              f"{step / max(elapsed, 1e-9):.0f} env-steps/s  {elapsed:.0f} s", flush=True)  # fmt: skip


__all__ = ["A2CConfig", "ALGOS", "BaselineConfig", "BaselineTrainer", "Budget", "CONTROLLERS", "FORMAT", "LABELS",
           "NetworkConfig", "PRESETS", "SACConfig", "TD3Config", "agent_config", "check_baseline_checkpoint",
           "config_from_dict", "deterministic_action", "load_baseline_checkpoint", "load_baseline_policy",
           "make_agent", "make_models", "save_checkpoint", "stage_changes", "wrap_env"]
