"""Trained policies as callables ``obs -> actions``: which controller runs a checkpoint (rsl-rl's or a skrl
baseline's), loading a checkpoint's actor into an rsl-rl runner, the deterministic / sampled / expected action, the
Gaussian's std, the fixed CPG baselines as constant actions, and the ONNX export of the deterministic policy.
"""

from __future__ import annotations

import contextlib
import copy
import io
import logging
import math
import warnings

import numpy as np

from hexnewton.learning.checkpoint import (
    check_compatible,
    check_rsl_rl_checkpoint,
    checkpoint_agent,
    checkpoint_meta,
    is_baseline_checkpoint,
    load_checkpoint,
    load_into_runner,
    read_checkpoint,
)


def action_std(policy) -> list[float] | None:
    """The Gaussian's std of each action (rsl-rl's scalar or log parameterisation, clamped to its range); None for a
    Beta policy, whose spread depends on the observation."""
    dist = policy.distribution
    if not hasattr(dist, "std_range"):
        return None
    std = dist.std_param if hasattr(dist, "std_param") else dist.log_std_param.exp()
    return std.detach().clamp(*dist.std_range).cpu().tolist()


def fix_action_std(policy, std: float) -> None:
    """Set the Gaussian's std of every action to ``std`` (rsl-rl's scalar or log parameterisation)."""
    import torch

    dist = policy.distribution
    with torch.no_grad():
        if hasattr(dist, "std_param"):
            dist.std_param.fill_(std)
        else:
            dist.log_std_param.fill_(math.log(std))


def fixed_cpg_actions(env, gait: str = "default", params: np.ndarray | None = None) -> "torch.Tensor":  # noqa: F821
    """A fixed baseline's parameters (``CPGConfig.fixed_params(gait)``, or ``params``: (15,) or one row per env)
    expressed as (constant) policy actions."""
    import torch

    from hexnewton.kernels.reference import params_to_actions

    lo, hi = env.cfg.cpg.param_ranges()
    p = env.cfg.cpg.fixed_params(gait) if params is None else env.cfg.cpg.with_posture(params)
    a = np.broadcast_to(np.clip(params_to_actions(p, lo, hi), -1.0, 1.0), (env.num_envs, len(lo)))
    return torch.tensor(np.ascontiguousarray(a), dtype=torch.float32, device=env.device_torch)


def policy_checkpoint(path: str) -> tuple[dict, str]:
    """Any trained policy's checkpoint (an rsl-rl one from ``train.py`` or a skrl baseline's from ``python -m
    hexnewton.apps.baselines``) read once, as data only, with the controller that runs it by default (``cpg_rl``,
    ``joint``, ``sac_cpg``, ``td3_cpg``, ``a2c_cpg``)."""
    ckpt = read_checkpoint(path)
    if is_baseline_checkpoint(ckpt):
        from hexnewton.learning.baselines import check_baseline_checkpoint

        ckpt = check_baseline_checkpoint(ckpt, path)
        return ckpt, f"{ckpt['algo']}_cpg"
    ckpt = check_rsl_rl_checkpoint(ckpt, path)
    return ckpt, "joint" if checkpoint_meta(ckpt).get("action_mode", "cpg") == "joint" else "cpg_rl"


def load_runner(env, path: str, action_mode: str, ckpt: dict | None = None):
    """An rsl-rl runner holding the checkpoint's actor, after checking the checkpoint fits this environment; ``ckpt``:
    the checkpoint at ``path`` already read (:func:`~hexnewton.learning.checkpoint.load_checkpoint`), else it is read here.
    The critic reads the groups ``env`` emits (an evaluation's env has no ``critic`` group: the critic of a checkpoint
    trained with one is neither built for it nor loaded)."""
    from rsl_rl.runners import OnPolicyRunner

    class PolicyRunner(OnPolicyRunner):
        """A runner that only holds a policy: one process, also inside a torchrun job (rsl-rl's own set-up reads
        torchrun's variables and would join, or start, a process group)."""

        def _configure_multi_gpu(self) -> None:
            self.gpu_world_size, self.gpu_local_rank, self.gpu_global_rank = 1, 0, 0
            self.is_distributed, self.cfg["multi_gpu"] = False, None

    ckpt = load_checkpoint(path) if ckpt is None else ckpt
    check_compatible(ckpt, path, env.num_obs, env.num_actions, action_mode)
    tcfg = checkpoint_agent(ckpt).to_rsl_rl(env.num_envs, env.obs_groups)
    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints both networks in full
        runner = PolicyRunner(env, copy.deepcopy(tcfg), log_dir=None, device=str(env.device_torch))
    # the actor alone: full training checkpoints and actor-only policy files (results/policies) both load
    load_into_runner(runner, ckpt, {"actor": True})
    return runner


def expected_clipped_action(mean, std):
    """Torch twin of :func:`hexnewton.deploy.runtime.expected_clipped_action` (its float64 NumPy reference):
    E[clip(a, -1, 1)] for a ~ N(mean, std^2)."""
    import torch

    std = std.clamp_min(1e-12)
    a, b = (-1.0 - mean) / std, (1.0 - mean) / std
    cdf_a, cdf_b = torch.special.ndtr(a), torch.special.ndtr(b)
    pdf_a, pdf_b = torch.exp(-0.5 * a * a) / math.sqrt(2 * math.pi), torch.exp(-0.5 * b * b) / math.sqrt(2 * math.pi)
    return -cdf_a + (1.0 - cdf_b) + mean * (cdf_b - cdf_a) - std * (pdf_b - pdf_a)


def load_policy(env, path: str, action_mode: str, stochastic: bool = False, expected: bool = False,
                ckpt: dict | None = None):
    """Policy from an rsl-rl checkpoint, after checking it fits this environment: its deterministic action (the
    distribution's mean: for a Beta policy the action the robot runs), with ``stochastic`` an action sampled from
    its distribution as in training, with ``expected`` (Gaussian policies) the expected clipped action
    E[clip(a, -1, 1)], what the sampled policy asks of the CPG on average. A Beta policy's mean already is its
    expected action: ``expected`` gives the same. ``ckpt``: the checkpoint at ``path``
    already read."""
    import torch

    if stochastic and expected:
        raise ValueError("choose sampled (--stochastic) or expected (--expected) actions, not both")
    runner = load_runner(env, path, action_mode, ckpt)
    device = str(env.device_torch)
    policy = runner.get_inference_policy(device=device)
    if stochastic:
        return lambda obs: policy(obs, stochastic_output=True)
    std = action_std(runner.alg.get_policy())
    if expected and std is not None:
        std = torch.tensor(std, device=device)
        return lambda obs: expected_clipped_action(policy(obs), std)
    return policy


def export_onnx(policy, num_obs: int, path: str) -> float:
    """Export the deterministic policy as one ONNX file with a dynamic batch dimension; returns the largest
    |onnxruntime - torch| difference on a random batch of 64 observations."""
    import onnxruntime as ort
    import torch

    module = copy.deepcopy(policy.as_onnx(verbose=False)).to("cpu").eval()
    example = torch.zeros(1, num_obs)
    batch = torch.export.Dim("batch", min=1)
    onnx_log = logging.getLogger("torch.onnx")
    level = onnx_log.level
    onnx_log.setLevel(logging.ERROR)  # the exporter's progress lines and optional-dependency notices
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            torch.onnx.export(module, (example,), path, input_names=["obs"], output_names=["actions"],
                              dynamic_shapes=({0: batch},), external_data=False, dynamo=True, verbose=False)  # fmt: skip
    finally:
        onnx_log.setLevel(level)
    obs = torch.randn(64, num_obs)
    with torch.no_grad():
        ref = module(obs).numpy()
    sess = ort.InferenceSession(path, providers=["CPUExecutionProvider"])
    out = sess.run(None, {sess.get_inputs()[0].name: obs.numpy()})[0]
    return float(np.abs(out - ref).max())
