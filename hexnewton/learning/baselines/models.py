"""The baselines' networks as skrl models: SAC's tanh-squashed Gaussian actor (skrl's ``GaussianMixin`` only clips),
TD3's tanh actor, A2C's Gaussian with a learnt state-independent std, the Q(s, a) and V(s) critics."""

from __future__ import annotations

import math

from hexnewton.learning.baselines.config import BaselineConfig
from hexnewton.learning.baselines.requirement import require_skrl

LOG_STD_RANGE = (-20.0, 2.0)  # SAC's log std, as skrl's GaussianMixin clips it


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
    require_skrl()
    spaces = dict(observation_space=observation_space, action_space=action_space, device=device)
    SquashedGaussianActor, TanhActor, GaussianActor = _actor_classes(cfg, spaces)
    QCritic, ValueCritic = _critic_classes(cfg, spaces)
    if algo == "a2c":
        return {"policy": GaussianActor(), "value": ValueCritic()}
    critics = {"critic_1": QCritic(), "critic_2": QCritic(), "target_critic_1": QCritic(), "target_critic_2": QCritic()}
    if algo == "sac":
        return {"policy": SquashedGaussianActor(), **critics}
    return {"policy": TanhActor(), "target_policy": TanhActor(), **critics}
