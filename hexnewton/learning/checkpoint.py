"""Checkpoints: reading them safely (tensors and plain data only: nothing in a file is executed), what they record
(task, environment and learner configs, action mode), whether they fit an environment, and where the newest is.

``train.py`` writes rsl-rl checkpoints with a ``hexnewton`` entry in ``infos`` (:func:`checkpoint_meta`):
``task``, ``action_mode``, ``num_obs``, ``num_actions``, ``config`` (the :class:`~hexnewton.config.HexConfig` as a
dict), ``agent`` (the :class:`~hexnewton.learning.agent.AgentConfig`), ``world_size``. Checkpoints written before the task
registry carry ``preset``, ``distribution`` and ``std_max`` instead of ``agent``; both load. The skrl baselines
(:mod:`hexnewton.learning.baselines`) write their own format with the same ``infos["hexnewton"]`` entry (``baseline`` holds
their learner's config); :func:`hexnewton.learning.policy.policy_checkpoint` reads either kind.
"""

from __future__ import annotations

import glob
import os
from importlib import resources

from hexnewton.config import HexConfig, config_from_dict
from hexnewton.learning.agent import AgentConfig, agent_from_dict, legacy_agent

#: What ``python play.py`` plays when nothing was trained yet: package data (``hexnewton/assets/``, which
#: ``results/policies/cpg_rl_complex.pt`` links to), so an installed wheel has it too.
SHIPPED_POLICY = str(resources.files("hexnewton").joinpath("assets", "policies", "cpg_rl_complex.pt"))


def read_checkpoint(path: str, map_location: str = "cpu"):
    """A file's tensors and plain data (``torch.load(weights_only=True)``: nothing in the file is executed), with
    one-line errors for missing, corrupt or unsafe files."""
    import pickle

    import torch

    if not os.path.isfile(path):
        raise ValueError(f"checkpoint not found: {path}")
    if path.endswith(".onnx"):
        raise ValueError(f"{path} is an ONNX policy: pass its .pt checkpoint here (an ONNX policy runs in a controller "
                         "bundle, python -m hexnewton.apps.deploy)")  # fmt: skip
    try:
        ckpt = torch.load(path, weights_only=True, map_location=map_location)
    except pickle.UnpicklingError as exc:
        if "GLOBAL" not in str(exc).replace("Unsupported global", "GLOBAL"):  # no code reference: a damaged file
            raise ValueError(f"cannot read checkpoint {path}: not a torch checkpoint (unpickling failed)") from None
        raise ValueError(f"{path} holds more than tensors and plain data; it is not loaded, because loading it could "
                         "run code from the file") from None  # fmt: skip
    except Exception as exc:  # torch raises many types for a damaged file
        raise ValueError(f"cannot read checkpoint {path}: {type(exc).__name__}: {str(exc).splitlines()[0][:120]}")
    return ckpt


def is_baseline_checkpoint(ckpt) -> bool:
    """Whether a file read by :func:`read_checkpoint` is a skrl baseline's (``python -m hexnewton.apps.baselines``)."""
    return isinstance(ckpt, dict) and str(ckpt.get("format", "")).startswith("hexnewton-skrl")


def check_rsl_rl_checkpoint(ckpt, path: str) -> dict:
    """``ckpt`` (read from ``path``) if it is an rsl-rl checkpoint (``train.py``); a one-line error otherwise."""
    if is_baseline_checkpoint(ckpt):
        raise ValueError(f"{path} is a skrl baseline checkpoint (python -m hexnewton.apps.baselines): evaluate it as "
                         f"controller {ckpt.get('algo')}_cpg")
    if not isinstance(ckpt, dict) or "actor_state_dict" not in ckpt:
        raise ValueError(f"{path} is not an rsl-rl checkpoint (no actor_state_dict)")
    return ckpt


def load_checkpoint(path: str, map_location: str = "cpu") -> dict:
    """An rsl-rl checkpoint (``train.py``) read by :func:`read_checkpoint`, with one-line errors for missing, corrupt,
    unsafe or wrong-type files."""
    return check_rsl_rl_checkpoint(read_checkpoint(path, map_location), path)


def policy_only(ckpt: dict) -> dict:
    """A checkpoint without its training state: an rsl-rl checkpoint's actor (and iteration, infos), a skrl baseline
    checkpoint's policy and observation normaliser. Both still load in ``evaluate``, ``export`` and ``play.py``."""
    if "actor_state_dict" in ckpt:
        return {k: ckpt[k] for k in ("actor_state_dict", "iter", "infos") if k in ckpt}
    if "modules" in ckpt:
        keep = {k: v for k, v in ckpt["modules"].items() if k in ("policy", "observation_preprocessor")}
        return dict({k: v for k, v in ckpt.items() if k != "modules"}, modules=keep)
    raise ValueError("not a training checkpoint of train.py or python -m hexnewton.apps.baselines")


def save_policy_only(src: str, dst: str) -> None:
    """``src``'s :func:`policy_only` saved as ``dst`` (a study keeps its results' policies, not their optimisers)."""
    import torch

    torch.save(policy_only(read_checkpoint(src)), dst)


def load_into_runner(runner, ckpt: dict, load_cfg: dict | None = None) -> None:
    """``OnPolicyRunner.load`` for a checkpoint read by :func:`load_checkpoint` (rsl-rl's own reads the file again,
    with ``weights_only=False``): the models and, with ``load_cfg`` None, the optimiser and iteration. State dicts
    load onto the runner's device whatever device the checkpoint was read to."""
    if runner.alg.load(ckpt, load_cfg, True):
        runner.current_learning_iteration = ckpt["iter"]


def average_checkpoints(paths: list[str], out: str) -> str:
    """The weight average of rsl-rl checkpoints of one run, written to ``out``: every floating-point tensor of the
    actor's and the critic's state (weights and observation normalisers' means and variances) averaged, each
    normaliser's standard deviation the square root of its averaged variance; counts, the optimiser's state, the
    iteration and the metadata are the last checkpoint's. Returns ``out``."""
    import torch

    if len(paths) < 2:
        raise ValueError(f"an average needs two checkpoints or more, not {len(paths)}")
    ckpts = [load_checkpoint(p) for p in paths]
    avg = dict(ckpts[-1])
    for key in ("actor_state_dict", "critic_state_dict"):
        if key not in avg:
            continue
        state = {}
        for name, value in ckpts[-1][key].items():
            parts = [c[key][name] for c in ckpts]
            if any(p.shape != value.shape for p in parts):
                raise ValueError(f"{key}[{name!r}] differs in shape between the checkpoints: not one run's")
            state[name] = torch.stack(parts).mean(0) if torch.is_floating_point(value) else value.clone()
        for name in state:
            if name.endswith("obs_normalizer._std"):
                state[name] = state[name[: -len("_std")] + "_var"].sqrt()
        avg[key] = state
    torch.save(avg, out)
    return out


def checkpoint_meta(ckpt: dict | None) -> dict:
    """The hexnewton metadata train.py saves with a checkpoint ({} for none, or for a checkpoint without it)."""
    infos = (ckpt or {}).get("infos")
    meta = infos.get("hexnewton") if isinstance(infos, dict) else None
    return meta if isinstance(meta, dict) else {}


def trained_config(ckpt: dict | None) -> HexConfig:
    """The configuration a checkpoint was trained with; the defaults for no checkpoint or one without hexnewton
    metadata. Its ``cpg`` parameter ranges give the actions their meaning, its ``sim`` is the physics (frame and
    substeps) the policy learnt under."""
    meta = checkpoint_meta(ckpt)
    cfg = meta.get("config")
    if cfg and meta.get("action_mode") == "joint" and "joint_action_scale" not in cfg.get("task", {}):
        cfg = {**cfg, "task": {**cfg["task"], "joint_action_scale": 0.0}}  # saved before the offsets: whole range
    return config_from_dict(cfg) if cfg else HexConfig()


def check_compatible(ckpt: dict, path: str, num_obs: int, num_actions: int, action_mode: str) -> None:
    trained_mode = checkpoint_meta(ckpt).get("action_mode")
    if trained_mode is not None and trained_mode != action_mode:
        raise ValueError(f"{path} was trained with action mode '{trained_mode}', not '{action_mode}'")
    for key, value in ckpt["actor_state_dict"].items():
        if key.endswith("mlp.0.weight") and value.shape[1] != num_obs:
            raise ValueError(f"{path} expects {value.shape[1]} observations; this environment has {num_obs}")
    out = [v for k, v in ckpt["actor_state_dict"].items() if k.startswith("mlp.") and k.endswith(".weight")]
    per_action = 2 if checkpoint_distribution(ckpt) == "beta" else 1  # a Beta head outputs (alpha, beta) per action
    if out and out[-1].shape[0] != per_action * num_actions:
        raise ValueError(f"{path} outputs {out[-1].shape[0] // per_action} actions; this environment takes "
                         f"{num_actions}")  # fmt: skip


def check_critic(ckpt: dict, path: str, num_inputs: int) -> None:
    """A one-line error unless the checkpoint's critic reads ``num_inputs`` values (the env's groups together, a resumed
    run's critic: ``ObsConfig.critic`` as it was trained)."""
    weight = (ckpt.get("critic_state_dict") or {}).get("mlp.0.weight")
    if weight is not None and weight.shape[1] != num_inputs:
        raise ValueError(f"{path}'s critic reads {weight.shape[1]} values; this environment gives it {num_inputs} "
                         "(--env.obs.critic as the checkpoint was trained)")


def checkpoint_distribution(ckpt: dict | None) -> str:
    """The action distribution a checkpoint was trained with (those saved before the choice existed: Gaussian)."""
    return checkpoint_agent(ckpt).distribution.name


def checkpoint_agent(ckpt: dict | None) -> AgentConfig:
    """The learner a checkpoint was trained with (the default one for a checkpoint without hexnewton metadata)."""
    meta = checkpoint_meta(ckpt)
    return agent_from_dict(meta["agent"]) if isinstance(meta.get("agent"), dict) else legacy_agent(meta)


def checkpoint_task(ckpt: dict | None) -> str | None:
    """The task a checkpoint was trained on (None for one written before the task registry)."""
    return checkpoint_meta(ckpt).get("task")


def newest_checkpoint(log_dir: str, experiment: str) -> str:
    """The newest run's result under ``log_dir/experiment`` (a glob pattern: ``*`` for any): its ``model_result.pt``
    (chosen on deterministic validation), else its ``model_best.pt`` where it kept one (what ``train.py`` reports and
    exports then), else its last numbered checkpoint. Runs are named by their start time, so the newest is the last
    name across experiments."""
    runs = sorted(glob.glob(os.path.join(log_dir, experiment, "*")), key=os.path.basename)
    for run_dir in reversed(runs):
        models = glob.glob(os.path.join(run_dir, "model_[0-9]*.pt"))
        for kept in ("model_result.pt", "model_best.pt"):
            if os.path.isfile(os.path.join(run_dir, kept)):
                return os.path.join(run_dir, kept)
        if models:
            return max(models, key=lambda m: int(m.rsplit("_", 1)[1].split(".")[0]))
    raise ValueError(f"no checkpoint under {os.path.join(log_dir, experiment)}: pass --checkpoint PATH")
