"""The baselines' checkpoint format (tensors and plain data only, hexnewton's metadata under ``infos["hexnewton"]``)
and the policy loaded from a checkpoint."""

from __future__ import annotations

import os

from hexnewton.learning.baselines.agents import deterministic_action, make_agent, sampled_action
from hexnewton.learning.baselines.config import ALGOS, CONTROLLERS, LABELS, config_from_dict
from hexnewton.learning.baselines.env import wrap_env
from hexnewton.learning.baselines.skrl_private import module_state

FORMAT = "hexnewton-skrl-2.1"


def save_checkpoint(path: str, agent, meta: dict, env_steps: int, timestep: int) -> None:
    """The agent's modules (models, optimisers, normalisers: state dicts) with hexnewton's metadata, written to a
    temporary file and renamed (atomic)."""
    import torch

    modules = {name: module_state(agent, m) for name, m in agent.checkpoint_modules.items() if m is not None}
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
    device = env.device_torch
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
