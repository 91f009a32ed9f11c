"""The baselines' settings: the algorithms, their controllers and labels, one config dataclass per algorithm and two
presets per algorithm (:func:`agent_config`):

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
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

ALGOS = ("sac", "td3", "a2c")
PRESETS = ("scale", "paper")
#: evaluation controller -> algorithm
CONTROLLERS = {"sac_cpg": "sac", "td3_cpg": "td3", "a2c_cpg": "a2c"}
LABELS = {"sac": "SAC-CPG", "td3": "TD3-CPG", "a2c": "A2C-CPG"}
ACTIVATIONS = ("relu", "elu", "tanh")


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
