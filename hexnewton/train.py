"""Train the hierarchical CPG_RL controller (or the pure-DRL joint baseline) with rsl-rl's PPO.

    python train.py --num_envs 4096 --terrain rugged --max_iterations 300
    python train.py --preset paper --terrain complex --num_envs 1024
    python train.py --resume logs/hexnewton_cpg_rugged/2026-11-21_15-00-00/model_299.pt --max_iterations 100
    torchrun --nproc_per_node=2 train.py --terrain complex --num_envs 4096     # 4096 envs on each of 2 GPUs

Each run writes ``logs/<experiment>/<date_time>/``:
- TensorBoard event files;
- ``model_<it>.pt`` checkpoints, including ``hexnewton`` metadata (observation size, action mode and
  config) for ``play.py``;
- ``config.json``;
- at the end, ``policy.onnx``: one file with a dynamic batch dimension, checked against torch with
  onnxruntime.

Presets (plain dicts, rsl-rl style):
- ``paper``: Table 2. Learning rate 1e-4 (fixed schedule), gamma 0.99, lambda 0.95, clip 0.2, an actor and
  critic of [256, 256, 256, 256] ReLU. The paper's batch size of 512 maps to rsl-rl mini-batches of 512
  samples: num_mini_batches = num_envs x num_steps_per_env / 512. The paper trained with Stable-Baselines3,
  whose PPO runs 10 epochs per update; we keep those 10.
- ``default``: ours, tuned for thousands of envs. Learning rate 1e-3 with rsl-rl's adaptive KL schedule
  (desired KL 0.01), 4 epochs x 2 mini-batches, [256, 256, 256, 256] ELU, initial action std 0.5. The update
  is bound by per-mini-batch overhead, not arithmetic: 2 x 4 costs 53 ms per iteration at 4096 envs against 119 ms
  for rsl-rl's usual 4 x 5, and reached the same skill sooner (BENCHMARKS.md).
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import dataclasses
import datetime
import io
import json
import logging
import math
import os
import random
import signal
import sys
import time
import warnings

import numpy as np

from .cli import ArgumentParser, positive_int, run, terrain_name
from .config import (
    CPGConfig,
    HexConfig,
    RandomizationConfig,
    RewardConfig,
    SimConfig,
    TaskConfig,
    TerrainConfig,
    config_from_dict,
    terrain_for_goal,
)

PRESETS = ("default", "paper")


DISTRIBUTIONS = ("beta", "gaussian")


def train_cfg(preset: str, num_envs: int, num_steps_per_env: int = 24, action_std: float | None = None,
              num_mini_batches: int | None = None, num_learning_epochs: int | None = None,
              torch_compile: str | None = None, mixed_precision: bool = False, std_max: float | None = None,
              distribution: str = "gaussian") -> dict:
    """rsl-rl-lib 5.5.1 runner configuration for ``preset``; ``action_std`` fixes the policy's Gaussian std (not
    learnt) instead of starting from the preset's and learning it. ``num_mini_batches`` / ``num_learning_epochs``
    override the preset's; ``torch_compile`` (a ``torch.compile`` mode rsl-rl accepts: ``default`` or
    ``max-autotune-no-cudagraphs``) compiles the actor and critic; ``mixed_precision`` runs the PPO update's
    forward pass and losses under bfloat16 autocast (rsl-rl's ``use_mixed_precision``). ``std_max`` caps the learnt
    std (rsl-rl's ``std_range``): actions are clipped to [-1, 1] and low-pass filtered into the CPG parameters, so a
    wider Gaussian only changes the filtered parameter's mean, and the entropy bonus grew the std to 1.7-5.8 in
    the complex runs (RESULTS.md).

    ``distribution``: ``beta`` (rsl-rl's ``BetaDistribution``: actions bounded to [-1, 1] by construction, its mean is
    the deterministic controller, the ONNX export computes that mean) or ``gaussian`` (a Gaussian clipped to [-1, 1]
    by the action kernel; checkpoints without a recorded distribution are Gaussian). ``action_std`` and ``std_max``
    are the Gaussian's."""
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"unknown distribution '{distribution}': choose one of {', '.join(DISTRIBUTIONS)}")
    if distribution == "beta" and (action_std is not None or std_max is not None):
        raise ValueError("--action_std and --std_max set the Gaussian's std: the Beta distribution has none to fix")
    if preset not in PRESETS:
        raise ValueError(f"unknown preset '{preset}': choose one of {', '.join(PRESETS)}")
    samples = num_envs * num_steps_per_env
    if preset == "paper":
        hidden, act, std = [256, 256, 256, 256], "relu", 1.0  # Table 2
        algorithm = dict(learning_rate=1.0e-4, schedule="fixed", gamma=0.99, lam=0.95, clip_param=0.2,  # Table 2
                         num_learning_epochs=10, num_mini_batches=max(1, samples // 512))  # batch 512, SB3 epochs
    else:
        hidden, act, std = [256, 256, 256, 256], "elu", 0.5
        algorithm = dict(learning_rate=1.0e-3, schedule="adaptive", desired_kl=0.01, gamma=0.99, lam=0.95,
                         clip_param=0.2, num_learning_epochs=4, num_mini_batches=2)  # fmt: skip
    algorithm.update(class_name="PPO", value_loss_coef=1.0, use_clipped_value_loss=True, entropy_coef=0.005,
                     max_grad_norm=1.0, use_mixed_precision=mixed_precision)  # fmt: skip
    if num_mini_batches is not None:
        algorithm["num_mini_batches"] = num_mini_batches
    if num_learning_epochs is not None:
        algorithm["num_learning_epochs"] = num_learning_epochs
    model = dict(class_name="MLPModel", hidden_dims=hidden, activation=act, obs_normalization=True)
    return {
        "num_steps_per_env": num_steps_per_env,
        "save_interval": 50,
        "obs_groups": {"actor": ["policy"], "critic": ["policy"]},
        "logger": "tensorboard",
        # rsl-rl's NaN check costs three device-to-host syncs per env step; the env already guarantees finite
        # observations and rewards in-kernel (a blown-up env is reset and counted: kernels/terminations.py,
        # tested by injecting NaN/Inf), so the check only stalls the GPU
        "check_for_nan": False,
        "actor": dict(model, distribution_cfg={"class_name": "BetaDistribution"} if distribution == "beta" else
                      {"class_name": "GaussianDistribution", "init_std": action_std or std,
                       "learn_std": action_std is None, "std_range": (1e-6, std_max or 1e6)}),  # rsl-rl's default
        "critic": dict(model),
        "algorithm": algorithm,
        "torch_compile_mode": torch_compile,
    }


COMPILE_MODES = ("default", "max-autotune-no-cudagraphs")  # rsl-rl rejects the CUDA-graph modes


def add_update_args(p) -> None:
    """The PPO-update options shared by ``train.py`` and ``hexnewton.bench`` (see :func:`train_cfg`)."""
    p.add_argument("--num_mini_batches", type=positive_int, default=None, help="default: the preset's (2)")
    p.add_argument("--num_learning_epochs", type=positive_int, default=None, help="default: the preset's (4)")
    p.add_argument("--torch_compile", choices=COMPILE_MODES, default=None,
                   help="torch.compile the actor and critic (rsl-rl's torch_compile_mode; default off)")
    p.add_argument("--mixed_precision", action="store_true",
                   help="bfloat16 autocast in the PPO update (rsl-rl's use_mixed_precision)")


def update_kwargs(args) -> dict:
    """:func:`train_cfg`'s keyword arguments from :func:`add_update_args`' options."""
    return dict(num_mini_batches=args.num_mini_batches, num_learning_epochs=args.num_learning_epochs,
                torch_compile=args.torch_compile, mixed_precision=args.mixed_precision)


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


def progress_line(log_kwargs: dict, stats: dict, elapsed: float) -> str:
    """One console line per iteration: the iteration, the last training episodes' outcome (``env.episode_stats()``),
    the iteration's time and the run's."""
    it, total = log_kwargs.get("it", 0), log_kwargs.get("total_it", 0)
    step_s = log_kwargs.get("collect_time", 0.0) + log_kwargs.get("learn_time", 0.0)
    level = f"  level {stats['mean_level']:.1f}" if "mean_level" in stats else ""
    return (f"iteration {it}/{total - 1}  success {stats['success_rate']:.3f}  fell {stats['fell_rate']:.3f}  "
            f"off course {stats['off_course_rate']:.3f}  distance {stats['distance_m']:.2f} m{level}  "
            f"{step_s:.2f} s/it  {datetime.timedelta(seconds=int(elapsed))}")  # fmt: skip


class TrainingStopped(Exception):
    """Raised by the signal handler (Ctrl-C, SIGTERM) or at the end of an iteration (--max_minutes,
    --target_success) to end training cleanly."""


def _stop(signum, frame):
    raise TrainingStopped(signal.Signals(signum).name)


def training_success(stats: dict, levels: int) -> float | None:
    """The success rate of the last training episodes (``env.episode_stats()``) once at least RING // 4 are in (with a
    curriculum: played on the last level, the terrain itself); else None."""
    from .env import RING

    key = "top_level_" if levels else ""
    return float(stats[f"{key}success_rate"]) if stats.get(f"{key}episodes", 0) >= RING // 4 else None


class BestCheckpoint:
    """Keeps ``model_best.pt``: the policy of the iteration whose last training episodes succeeded most often
    (:func:`training_success`), so that a run ends with a policy as good as its best even when its skill drifts
    down later (the flat CPU main job peaked at 0.945 near iteration 110 and ended at 0.869)."""

    margin = 0.005  # a new best must beat the old one by this much (no save every iteration on a plateau)

    def __init__(self, run_dir: str, levels: int):
        self.path, self.levels = os.path.join(run_dir, "model_best.pt"), levels
        self.rate, self.iteration = None, None

    def reset(self) -> None:
        """Forget the best so far (a new curriculum stage trains under another objective)."""
        self.rate = self.iteration = None
        if os.path.exists(self.path):
            os.remove(self.path)

    def update(self, stats: dict, iteration: int, save) -> None:
        rate = training_success(stats, self.levels)
        if rate is not None and (self.rate is None or rate >= self.rate + self.margin):
            save(self.path, infos={"best_success": rate})
            self.rate, self.iteration = rate, iteration


def stop_reason(time_up: bool, stats: dict, target: float | None, levels: int, reduce=None) -> str | None:
    """Why training should stop after this iteration (None: go on), decided at the iteration boundary so that
    every rank of a torchrun job stops at the same iteration. ``reduce`` sums a list over the ranks.
    ``stats`` (``env.episode_stats()``) is read only when there is a ``target``.

    With ``target``: the success rate over the last episodes of all ranks (a full ring of RING per rank; with a
    curriculum, at least RING // 4 per rank on the last level, which is the terrain itself)."""
    from .env import RING

    key, need = ("top_level_", RING // 4) if levels else ("", RING)
    n = float(stats[f"{key}episodes"]) if target is not None else 0.0
    values = [float(time_up), stats[f"{key}success_rate"] * n if n else 0.0, n, 1.0]
    time_up, successes, n, ranks = reduce(values) if reduce else values
    if time_up:
        return "the --max_minutes limit"
    if target is not None and n >= need * ranks and successes / n >= target:
        where = " on the last level" if levels else ""
        return f"target success{where} {successes / n:.3f} >= {target}"
    return None


def _sum_over_ranks(device: str):
    import torch
    import torch.distributed as td

    def reduce(values: list[float]) -> list[float]:
        t = torch.tensor(values, dtype=torch.float64, device=device)
        td.all_reduce(t)  # NCCL: one small collective per iteration
        return t.tolist()

    return reduce


@dataclasses.dataclass(frozen=True)
class Rank:
    """This process's place in a ``torchrun`` job (rank 0 of 1 without one)."""

    rank: int = 0
    local_rank: int = 0
    world_size: int = 1
    device: str | None = None  # None: resolve --device as usual

    @property
    def is_main(self) -> bool:
        return self.rank == 0

    def seeds(self, seed: int, terrain_seed: int) -> tuple[int, int]:
        """Each rank its own seed (actions, resets) and terrain layout; rank 0 keeps the given ones."""
        return seed + self.rank, terrain_seed + self.rank


def distributed_rank(environ: dict, device: str | None) -> Rank:
    """Read torchrun's WORLD_SIZE / RANK / LOCAL_RANK. Each rank trains its own env batch on
    ``cuda:LOCAL_RANK`` (rsl-rl's distributed mode: NCCL, gradients averaged, rank 0 logs and saves)."""
    try:
        world = int(environ.get("WORLD_SIZE", "1"))
        rank, local = int(environ.get("RANK", "0")), int(environ.get("LOCAL_RANK", "0"))
    except ValueError:
        raise ValueError("WORLD_SIZE, RANK and LOCAL_RANK must be integers (set by torchrun)")
    if world <= 1:
        return Rank(device=device)
    if not 0 <= rank < world or not 0 <= local < world:
        raise ValueError(f"RANK {rank} / LOCAL_RANK {local} must lie in [0, WORLD_SIZE={world})")
    if device is not None and not device.startswith("cuda"):
        raise ValueError(f"distributed training runs on CUDA (rsl-rl uses NCCL), not on '{device}'")
    return Rank(rank, local, world, f"cuda:{local}")


def seed_everything(seed: int) -> None:
    import torch

    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    if torch.cuda.is_available():
        torch.cuda.manual_seed_all(seed)


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


def check_log_dir(log_dir: str) -> None:
    """Fail before any simulation if runs could not be written under ``log_dir``."""
    path = os.path.abspath(log_dir)
    while not os.path.exists(path):
        path = os.path.dirname(path)
    if not os.path.isdir(path) or not os.access(path, os.W_OK | os.X_OK):
        raise ValueError(f"cannot write runs under {log_dir}: {path} is not a writable directory")


def load_checkpoint(path: str, map_location: str = "cpu") -> dict:
    """A checkpoint's tensors and plain data (``torch.load(weights_only=True)``: nothing in the file is executed), with
    one-line errors for missing, corrupt, unsafe or wrong-type files."""
    import pickle

    import torch

    if not os.path.isfile(path):
        raise ValueError(f"checkpoint not found: {path}")
    if path.endswith(".onnx"):
        raise ValueError(f"{path} is an ONNX policy: pass its .pt checkpoint here (an ONNX policy runs in a controller "
                         "bundle, python -m hexnewton.deploy)")  # fmt: skip
    try:
        ckpt = torch.load(path, weights_only=True, map_location=map_location)
    except pickle.UnpicklingError as exc:
        if "GLOBAL" not in str(exc).replace("Unsupported global", "GLOBAL"):  # no code reference: a damaged file
            raise ValueError(f"cannot read checkpoint {path}: not a torch checkpoint (unpickling failed)") from None
        raise ValueError(f"{path} holds more than tensors and plain data; it is not loaded, because loading it could "
                         "run code from the file") from None  # fmt: skip
    except Exception as exc:  # torch raises many types for a damaged file
        raise ValueError(f"cannot read checkpoint {path}: {type(exc).__name__}: {str(exc).splitlines()[0][:120]}")
    if not isinstance(ckpt, dict) or "actor_state_dict" not in ckpt:
        raise ValueError(f"{path} is not an rsl-rl checkpoint (no actor_state_dict)")
    return ckpt


def load_into_runner(runner, ckpt: dict, load_cfg: dict | None = None) -> None:
    """``OnPolicyRunner.load`` for a checkpoint read by :func:`load_checkpoint` (rsl-rl's own reads the file again,
    with ``weights_only=False``): the models and, with ``load_cfg`` None, the optimiser and iteration. State dicts
    load onto the runner's device whatever device the checkpoint was read to."""
    if runner.alg.load(ckpt, load_cfg, True):
        runner.current_learning_iteration = ckpt["iter"]


def checkpoint_meta(ckpt: dict | None) -> dict:
    """The hexnewton metadata train.py saves with a checkpoint ({} for none, or for a checkpoint without it)."""
    infos = (ckpt or {}).get("infos")
    meta = infos.get("hexnewton") if isinstance(infos, dict) else None
    return meta if isinstance(meta, dict) else {}


def trained_config(ckpt: dict | None) -> HexConfig:
    """The configuration a checkpoint was trained with; the defaults for no checkpoint or one without hexnewton
    metadata. Its ``cpg`` parameter ranges give the actions their meaning, its ``sim`` is the physics (frame and
    substeps) the policy learnt under."""
    cfg = checkpoint_meta(ckpt).get("config")
    return config_from_dict(cfg) if cfg else HexConfig()


def check_compatible(ckpt: dict, path: str, num_obs: int, num_actions: int, action_mode: str) -> None:
    mode = checkpoint_meta(ckpt).get("action_mode")
    if mode is not None and mode != action_mode:
        raise ValueError(f"{path} was trained with action mode '{mode}', not '{action_mode}'")
    for key, value in ckpt["actor_state_dict"].items():
        if key.endswith("mlp.0.weight") and value.shape[1] != num_obs:
            raise ValueError(f"{path} expects {value.shape[1]} observations; this environment has {num_obs}")
    out = [v for k, v in ckpt["actor_state_dict"].items() if k.startswith("mlp.") and k.endswith(".weight")]
    per_action = 2 if checkpoint_distribution(ckpt) == "beta" else 1  # a Beta head outputs (alpha, beta) per action
    if out and out[-1].shape[0] != per_action * num_actions:
        raise ValueError(f"{path} outputs {out[-1].shape[0] // per_action} actions; this environment takes "
                         f"{num_actions}")  # fmt: skip


def checkpoint_distribution(ckpt: dict | None) -> str:
    """The action distribution a checkpoint was trained with (those saved before the choice existed: Gaussian)."""
    return checkpoint_meta(ckpt).get("distribution", "gaussian")


#: The stability shaping of the variant chosen on validation rounds among six (RESULTS.md, "Stable gaits"): fewest
#: falls, lowest rugged pitch and roll variance; 2 / 0.02 / 0.05 (with a 0.03 s filter) fell 18x as often on rugged
#: ground, 20 / 0.2 / 0.1 20x. On flat ground (the CPU main job, 64 envs) it slowed learning: 59 % success after 300
#: iterations against 84 % without it (results/cpu_main_job).
STABLE_SHAPING = dict(w_tilt=5.0, w_ang_vel=0.05, w_action_rate=0.1)

#: ours: the stable-gait curriculum of the complex recipe (RESULTS.md, "Stable gaits"): (first iteration, changes)
#: of the reflex gain (``posture_reflex``) and the reward weights, applied from that iteration on. With the body
#: posture from the start, it is in one run what three runs trained for results/policies/cpg_rl_complex.pt: the
#: posture policy (its best checkpoint, iteration 381), resumed under the levelling reflex with tilt shaping 15 / 0.1
#: to iteration 743, then with 40 / 0.3 to 1061 (scripts/device/posture_gait.sh train, finetune, level).
STABLE_STAGES = ((382, dict(posture_reflex=2.0, w_tilt=15.0, w_ang_vel=0.1)), (744, dict(w_tilt=40.0, w_ang_vel=0.3)))

#: What ``python train.py --terrain T`` trains when a flag is not given (``apply_recipe``). Flat ground: the plain
#: MDP. The paper's terrains: the terrain curriculum (10 lanes, robots start on the first 3), the knee-lift floor
#: (a high-stepping gait from the start), domain randomisation, the 20 ms physics frame and a 0.1 s filter on the
#: CPG parameters and the stability shaping (``STABLE_SHAPING``). The complex course adds the body posture and the
#: stable-gait curriculum (``STABLE_STAGES``, 1062 iterations): ``python train.py --terrain complex`` trains the
#: shipped results/policies/cpg_rl_complex; ``--no-posture --seed 1 --max_iterations 332`` the Beta policy without
#: posture (results/policies/cpg_rl_complex_beta).
RECIPES = {
    "flat": {},
    **{t: dict(levels=10, start_levels=3, a2_range=(0.9, 1.3), randomize=True, frame_dt=0.02, substeps=4,
               param_tau=0.1, **STABLE_SHAPING) for t in ("rugged", "stepped", "complex")},
}
RECIPES["complex"].update(posture=True, stages=STABLE_STAGES, max_iterations=1062)


def apply_recipe(args, resumed: bool) -> None:
    """Fill the flags left unset (None) from ``RECIPES[args.terrain]``, then the config defaults; a resumed run keeps
    its own parameter ranges and physics (they come from the checkpoint)."""
    recipe = RECIPES[args.terrain]
    keep = ("a2_range", "frame_dt", "substeps", "param_tau", "posture") if resumed else ()
    if args.paper_reward:  # Table 1 as written: no shaping unless a flag asks for it
        keep += tuple(STABLE_SHAPING) + ("stages",)
    for key, value in recipe.items():
        if getattr(args, key) is None and key not in keep:
            setattr(args, key, value)
    for key, default in (("levels", TerrainConfig.levels), ("start_levels", TerrainConfig.start_levels),
                         ("randomize", False), ("max_iterations", 300), ("stages", ())):  # fmt: skip
        if getattr(args, key) is None:
            setattr(args, key, default)


def reward_config(args) -> RewardConfig:
    """``RewardConfig`` (or Table 1's, ``--paper_reward``) with the reward flags that were given."""
    base = RewardConfig().paper_reward() if args.paper_reward else RewardConfig()
    given = {k: getattr(args, k) for k in ("direction_deadband", "goal_bonus", "off_course_penalty", "stability_tilt",
                                           "w_tilt", "w_ang_vel", "w_action_rate") if getattr(args, k) is not None}
    if args.direction_from_start:
        given["direction_to_goal"] = False
    return dataclasses.replace(base, **given)


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python train.py", description="Train CPG_RL with rsl-rl PPO.")
    p.add_argument("--num_envs", type=positive_int, default=None, help="default 4096 on CUDA, 64 on CPU")
    p.add_argument("--terrain", type=terrain_name, default=None,
                   help="default: a resumed run's own terrain, else flat")
    p.add_argument("--terrain_seed", type=int, default=0)
    p.add_argument("--device", default=None, help="cpu, cuda or cuda:N (default: cuda if present, else cpu)")
    p.add_argument("--max_iterations", type=positive_int, default=None,
                   help="default: the recipe's (complex: 1062, the stable-gait curriculum), else 300")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--preset", default="default", help=f"one of {', '.join(PRESETS)}")
    p.add_argument("--action_mode", default="cpg", choices=["cpg", "joint"])
    p.add_argument("--resume", metavar="PATH", help="checkpoint to continue from (a new run directory is made)")
    p.add_argument("--log_dir", default="logs")
    p.add_argument("--experiment", default=None, help="default: hexnewton_<action_mode>_<terrain>")
    p.add_argument("--num_steps_per_env", type=positive_int, default=24)
    p.add_argument("--save_interval", type=positive_int, default=50)
    p.add_argument("--max_minutes", type=float, default=None,
                   help="stop after this wall time (then save, export and evaluate as at the end)")
    p.add_argument("--target_success", type=float, default=None,
                   help="stop once this share of the last 1024 training episodes succeeded (time-to-skill; with "
                        "--levels: of those, at least 256, played on the last level)")
    p.add_argument("--goal_distance", type=float, default=TaskConfig.goal_distance)
    p.add_argument("--levels", type=int, default=None,
                   help="terrain curriculum: this many lanes of increasing difficulty, the last one the terrain "
                        "itself (0: off; default: the terrain's recipe, RECIPES)")  # fmt: skip
    p.add_argument("--start_levels", type=int, default=None,
                   help="with --levels: robots start spread over the first this many lanes (default: the recipe's)")
    p.add_argument("--step_rise", type=float, default=TerrainConfig.step_rise, help="step height [m] (§3.1: 0.06)")
    p.add_argument("--block_height_max", type=float, default=TerrainConfig.block_height_max,
                   help="tallest rugged block [m] (§3.1: 0.06)")
    p.add_argument("--randomize", action=argparse.BooleanOptionalAction, default=None,
                   help="domain randomisation (RandomizationConfig): friction, payload, masses, gains, latency, "
                        "observation noise, pushes (default: the recipe's)")  # fmt: skip
    p.add_argument("--a2_range", type=float, nargs=2, metavar=("LO", "HI"), default=None,
                   help="knee-lift range [rad] of new runs (default: the recipe's, else CPGConfig.a2_range; a floor "
                        "such as 0.9 starts PPO from a high-stepping gait, action 0 = the middle of the range)")
    p.add_argument("--param_tau", type=float, default=None,
                   help="time constant [s] of the CPG parameters' filter, new runs (default: the recipe's, else "
                        f"{CPGConfig.param_tau})")
    p.add_argument("--posture", action=argparse.BooleanOptionalAction, default=None,
                   help="ours: 3 more actions, the body posture (height, pitch, roll knee offsets; kernels/mapping.py), "
                        "new runs (default off: the paper's 15 parameters)")
    p.add_argument("--stages", action=argparse.BooleanOptionalAction, default=None,
                   help="ours: the recipe's curriculum of reflex gain and reward weights (STABLE_STAGES, complex "
                        "recipe with the posture; --no-stages: the first stage's settings throughout)")
    p.add_argument("--posture_reflex", type=float, default=None,
                   help="ours: levelling reflex gain [rad of knee per rad of tilt] on the posture, at every substep "
                        "(kernels/mapping.py; default: the resumed checkpoint's, else 0 = off)")
    p.add_argument("--frame_dt", type=float, default=None,
                   help="physics frame [s], collision once per frame (must divide the 20 ms control step; default "
                        f"the recipe's, else {SimConfig.frame_dt}, or the resumed checkpoint's)")
    p.add_argument("--substeps", type=positive_int, default=None,
                   help=f"MuJoCo steps per frame (default as --frame_dt; {SimConfig.substeps})")
    p.add_argument("--distribution", choices=DISTRIBUTIONS, default=None,
                   help="action distribution of new runs: beta (bounded, default) or gaussian (clipped; the paper's "
                        "SB3 PPO); a resumed run keeps its own")  # fmt: skip
    p.add_argument("--action_std", type=float, default=None,
                   help="gaussian: fix the policy's action std (not learnt; also on --resume) so that its mean action "
                        "learns to do what its noise did (default: learnt, from the preset's initial std)")
    p.add_argument("--std_max", type=float, default=None,
                   help="gaussian: cap the learnt action std (default: uncapped; see train_cfg)")
    r = p.add_argument_group("reward (RewardConfig; kernels/rewards.py)")
    r.add_argument("--paper_reward", action="store_true",
                   help="Table 1 as written (RewardConfig.paper_reward): no goal bonus, no off-course penalty, no "
                        "gait-quality terms, pi/6 dead band on the start-to-goal direction; flags below still apply")
    r.add_argument("--direction_deadband", type=float, default=None,
                   help="heading error [rad] below which the direction term is 0 (Table 1: pi/6; default 0)")
    r.add_argument("--direction_from_start", action="store_true",
                   help="direction term along the start-to-goal vector (Table 1's D) instead of robot-to-goal (ours)")
    r.add_argument("--goal_bonus", type=float, default=None,
                   help=f"paid once on reaching the goal (ours, default {RewardConfig.goal_bonus:g})")
    r.add_argument("--off_course_penalty", type=float, default=None,
                   help=f"paid once on leaving the course (ours, default {RewardConfig.off_course_penalty:g}; 0: the "
                        "paper's reward)")
    r.add_argument("--stability_tilt", type=float, default=None,
                   help="roll / pitch [rad] beyond which r_s fines every step (Table 1: pi/6; 8 cm stairs pitch the "
                        "torso 19-25 deg, see kernels/rewards.py)")
    r.add_argument("--w_tilt", type=float, default=None,
                   help="ours: weight of -(roll^2 + pitch^2) per step (default: the recipe's, "
                        f"{STABLE_SHAPING['w_tilt']:g} on the paper's terrains, else {RewardConfig.w_tilt:g} = off)")
    r.add_argument("--w_ang_vel", type=float, default=None,
                   help="ours: weight of -(roll rate^2 + pitch rate^2) (default: the recipe's, "
                        f"{STABLE_SHAPING['w_ang_vel']:g} on the paper's terrains, else {RewardConfig.w_ang_vel:g} = off)")
    r.add_argument("--w_action_rate", type=float, default=None,
                   help="ours: weight of -sum (a - a_prev)^2 (default: the recipe's, "
                        f"{STABLE_SHAPING['w_action_rate']:g} on the paper's terrains, else {RewardConfig.w_action_rate:g}"
                        " = off)")
    add_update_args(p)
    args = p.parse_args(argv)
    if args.preset not in PRESETS:
        raise ValueError(f"unknown preset '{args.preset}': choose one of {', '.join(PRESETS)}")
    if args.max_minutes is not None and not args.max_minutes > 0:
        raise ValueError("--max_minutes must be positive")
    if args.action_std is not None and not args.action_std > 0:
        raise ValueError("--action_std must be positive")
    if args.stability_tilt is not None and not 0 < args.stability_tilt < math.pi / 2:
        raise ValueError("--stability_tilt must lie in (0, pi/2) rad")
    if args.param_tau is not None and not args.param_tau >= 0:
        raise ValueError("--param_tau must be >= 0")
    if args.std_max is not None and not args.std_max > 0:
        raise ValueError("--std_max must be positive")
    if args.target_success is not None and not 0 < args.target_success <= 1:
        raise ValueError("--target_success must lie in (0, 1]")
    for flag in ("a2_range", "param_tau", "distribution", "posture"):
        if args.resume and getattr(args, flag) is not None:
            raise ValueError(f"--{flag} is for new runs: a resumed run keeps what it was trained with")
    ckpt = load_checkpoint(args.resume) if args.resume else None  # fail before building anything
    if args.terrain is None:  # a resumed run goes on where it trained (and with that terrain's recipe)
        args.terrain = checkpoint_meta(ckpt).get("config", {}).get("terrain", {}).get("name", "flat")
    apply_recipe(args, resumed=ckpt is not None)
    reward = reward_config(args)
    if args.a2_range is not None:
        lo, hi = args.a2_range
        if not 0 <= lo < hi <= CPGConfig.a2_range[1]:
            raise ValueError(f"--a2_range must satisfy 0 <= LO < HI <= {CPGConfig.a2_range[1]} (the knee limit)")
    distribution = checkpoint_distribution(ckpt) if ckpt is not None else args.distribution or "beta"
    check_log_dir(args.log_dir)

    from rsl_rl.runners import OnPolicyRunner

    from .env import make_env
    from .sim import resolve_device

    dist = distributed_rank(dict(os.environ), args.device)
    device = resolve_device(dist.device or args.device)
    if args.num_envs is None:
        args.num_envs = 4096 if device.startswith("cuda") else 64
    seed, terrain_seed = dist.seeds(args.seed, args.terrain_seed)
    seed_everything(seed)
    trained = trained_config(ckpt)  # a resumed run keeps its physics and parameter ranges unless told otherwise
    physics = {k: v for k, v in (("frame_dt", args.frame_dt), ("substeps", args.substeps)) if v is not None}
    cfg = HexConfig(
        sim=dataclasses.replace(trained.sim, num_envs=args.num_envs, device=device, **physics),
        terrain=terrain_for_goal(TerrainConfig(name=args.terrain, seed=terrain_seed, levels=args.levels,
                                               start_levels=args.start_levels, step_rise=args.step_rise,
                                               block_height_max=args.block_height_max), args.goal_distance),
        task=dataclasses.replace(TaskConfig(), seed=seed, goal_distance=args.goal_distance),
        reward=reward,
        randomization=RandomizationConfig(enabled=args.randomize),
        cpg=trained.cpg if ckpt is not None else dataclasses.replace(
            CPGConfig(), **({"a2_range": tuple(args.a2_range)} if args.a2_range else {}),
            **({"param_tau": args.param_tau} if args.param_tau is not None else {}),
            **({"posture": args.posture} if args.posture is not None else {})),
    )
    if args.posture_reflex is not None:  # a gain of the low level: a resumed posture policy may learn under a new one
        if not cfg.cpg.posture:
            raise ValueError("--posture_reflex acts on the body posture: train with --posture (or resume a posture policy)")
        cfg = dataclasses.replace(cfg, cpg=dataclasses.replace(cfg.cpg, posture_reflex=args.posture_reflex))
    stages = args.stages if isinstance(args.stages, tuple) else STABLE_STAGES if args.stages else ()
    if stages and not (cfg.cpg.posture and args.action_mode == "cpg"):
        if args.stages is True:
            raise ValueError("--stages changes the levelling reflex: train with --posture (or resume a posture policy)")
        stages = ()  # the recipe's curriculum needs the posture (--no-posture runs without it)
    env = make_env(cfg, args.action_mode)
    if ckpt is not None:
        check_compatible(ckpt, args.resume, env.num_obs, env.num_actions, args.action_mode)
    if ckpt is not None and args.std_max is None:  # a resumed run keeps its cap
        args.std_max = checkpoint_meta(ckpt).get("std_max")
    tcfg = train_cfg(args.preset, args.num_envs, args.num_steps_per_env, args.action_std,
                     std_max=args.std_max, distribution=distribution, **update_kwargs(args))
    tcfg["save_interval"] = args.save_interval
    experiment = args.experiment or f"hexnewton_{args.action_mode}_{args.terrain}"
    run_dir = os.path.join(args.log_dir, experiment, datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S"))
    meta = {"action_mode": args.action_mode, "num_obs": env.num_obs, "num_actions": env.num_actions,
            "preset": args.preset, "config": dataclasses.asdict(cfg), "world_size": dist.world_size,
            "std_max": args.std_max, "distribution": distribution}  # fmt: skip
    if dist.is_main:  # only rank 0 writes logs, checkpoints and the export
        if os.path.exists(run_dir):
            raise ValueError(f"{run_dir} exists: nothing is overwritten (start again in a second, or change --experiment)")
        os.makedirs(run_dir)
        with open(os.path.join(run_dir, "config.json"), "w") as f:
            json.dump({"hexnewton": meta, "train": tcfg}, f, indent=1, default=str)

    with contextlib.redirect_stdout(io.StringIO()):  # rsl-rl prints both networks in full
        runner = OnPolicyRunner(env, copy.deepcopy(tcfg), log_dir=run_dir if dist.is_main else None, device=device)
    # the run's git/ folder records hexnewton's commit and diff (rsl-rl's default looks for its own, installed, repo)
    runner.logger.git_status_repos = [os.path.dirname(os.path.abspath(__file__))]
    _save = runner.save

    def save(path: str, infos: dict | None = None) -> None:
        """Checkpoint with hexnewton metadata, written to a temporary file and renamed (atomic)."""
        _save(path + ".tmp", infos={"hexnewton": meta, **(infos or {})})
        os.replace(path + ".tmp", path)

    runner.save = save
    time_up = [False]  # set by the --max_minutes alarm, acted on at the end of the iteration
    best = BestCheckpoint(run_dir, args.levels)
    _log = runner.logger.log
    reduce = _sum_over_ranks(device) if dist.world_size > 1 else None

    def log_and_stop(*a, **k):
        """Keep the best policy (rank 0), then stop (every rank at once) on the time limit or the target success. The
        ring's statistics are a few small host reads per iteration. rsl-rl's 30-line block per iteration goes to
        TensorBoard only; the console gets :func:`progress_line`."""
        with contextlib.redirect_stdout(io.StringIO()):
            _log(*a, **k)
        stats = env.episode_stats()
        if dist.is_main:
            print(progress_line(k, stats, time.time() - t0), flush=True)
            best.update(stats, runner.current_learning_iteration, runner.save)
        reason = stop_reason(time_up[0], stats, args.target_success, args.levels, reduce)
        if reason:
            raise TrainingStopped(reason)

    stage = [None]

    def enter_stage(iteration: int) -> None:
        """The curriculum (``stages``): from its first iteration on, a stage's reflex gain and reward weights (with
        those of the stages before it). The best checkpoint is chosen within the last stage begun."""
        begun = [k for k, (start, _) in enumerate(stages) if iteration >= start]
        if not begun or begun[-1] == stage[0]:
            return
        stage[0] = begun[-1]
        changes = {}
        for _, c in stages[: stage[0] + 1]:
            changes.update(c)
        reflex = changes.pop("posture_reflex", env.cfg.cpg.posture_reflex)
        env.set_shaping(dataclasses.replace(env.cfg.reward, **changes), reflex)
        meta["config"] = dataclasses.asdict(env.cfg)  # checkpoints carry the gain they run with
        best.reset()
        print(f"iteration {iteration}: curriculum stage {stage[0] + 2} of {len(stages) + 1}: posture_reflex "
              f"{reflex:g}, " + ", ".join(f"{k} {v:g}" for k, v in changes.items()), flush=True)

    def log(*a, **k):
        """After each iteration's log: the curriculum's next stage if it begins, the best policy (rank 0), then stop
        (every rank at once) on the time limit or the target success."""
        log_and_stop(*a, **k)
        enter_stage(runner.current_learning_iteration + 1)

    runner.logger.log = log
    if ckpt is not None:
        load_into_runner(runner, ckpt)
        # rsl-rl stores the last finished iteration and would start again from it: continue after it instead
        runner.current_learning_iteration += 1
        if args.action_std is not None:  # the checkpoint brought its own std: fix ours
            fix_action_std(runner.alg.get_policy(), args.action_std)
        print(f"resumed from {args.resume}: continuing at iteration {runner.current_learning_iteration}, "
              f"learning rate {runner.alg.learning_rate:.2e}")
    enter_stage(runner.current_learning_iteration)
    where = f"rank {dist.rank} of {dist.world_size}, " if dist.world_size > 1 else ""
    print(f"training {experiment}: {where}{args.num_envs} envs on {device}, preset {args.preset}, logs in {run_dir}")
    t0 = time.time()
    handlers = {sig: signal.signal(sig, _stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    handlers[signal.SIGALRM] = signal.signal(signal.SIGALRM, lambda signum, frame: time_up.__setitem__(0, True))
    if args.max_minutes:
        signal.setitimer(signal.ITIMER_REAL, 60.0 * args.max_minutes)
    try:
        runner.learn(args.max_iterations, init_at_random_ep_len=True)
    except TrainingStopped as stop:  # save what was learnt; rsl-rl only saves at intervals and at the end
        signal.setitimer(signal.ITIMER_REAL, 0)
        it = runner.current_learning_iteration
        if dist.is_main:
            print(f"stopped by {stop} after iteration {it}: saving model_{it}.pt")
            runner.save(os.path.join(run_dir, f"model_{it}.pt"))
            runner.logger.stop_logging_writer()
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        for sig, handler in handlers.items():
            signal.signal(sig, handler)
        if hasattr(runner.logger.writer, "flush"):
            runner.logger.writer.flush()  # TensorBoard otherwise writes every 120 s
    print(f"finished at iteration {runner.current_learning_iteration} after {time.time() - t0:.0f} s")
    if not dist.is_main:
        return 0
    stats = env.episode_stats()
    print("last episodes: " + ", ".join(f"{k} {v:.3f}" for k, v in stats.items()))
    if best.iteration is not None and best.iteration != runner.current_learning_iteration:
        print(f"best training success {best.rate:.3f} at iteration {best.iteration} ({best.path}); the last iteration "
              f"ended at {training_success(stats, args.levels) or float('nan'):.3f}: exporting the best")
        load_into_runner(runner, load_checkpoint(best.path, device), {"actor": True})
    onnx_path = os.path.join(run_dir, "policy.onnx")
    err = export_onnx(runner.alg.get_policy(), env.num_obs, onnx_path)
    print(f"exported {onnx_path} (dynamic batch; onnxruntime vs torch max |diff| {err:.2e})")
    if err > 1e-4:
        raise RuntimeError(f"ONNX export differs from torch by {err}")
    final = best.path if best.iteration is not None else os.path.join(run_dir, f"model_{runner.current_learning_iteration}.pt")
    print(f"\nresults in {run_dir} (checkpoints, TensorBoard events, policy.onnx). Next:\n"
          f"  python play.py --checkpoint {final}\n"
          f"  python -m hexnewton.evaluate --controllers cpg cpg_rl --checkpoint cpg_rl={final} --terrains {args.terrain}\n"
          f"  python -m hexnewton.export --checkpoint {final} --out bundle/\n"
          f"  tensorboard --logdir {args.log_dir}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python train.py"))
