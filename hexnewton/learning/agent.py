"""The learner's configuration: rsl-rl's PPO runner as one dataclass tree (``AgentConfig``), from which the plain dict
rsl-rl-lib 5.5.1 takes is generated (:meth:`AgentConfig.to_rsl_rl`).

Two presets:
- :func:`paper_agent`: Table 2. Learning rate 1e-4 (fixed schedule), gamma 0.99, lambda 0.95, clip 0.2, an actor and
  critic of [256, 256, 256, 256] ReLU. The paper's batch size of 512 is rsl-rl's mini-batch: ``mini_batch_size =
  512`` gives num_envs x num_steps_per_env / 512 mini-batches. Where Table 2 is silent, the paper's library
  (Stable-Baselines3 PPO) decides: 10 epochs, no entropy bonus, value loss weight 0.5 (not clipped), gradient norm
  0.5, a Gaussian of initial std 1 (log std 0), no observation normalisation.
- :class:`AgentConfig` as it stands (ours, tuned for thousands of envs): learning rate 1e-3 with rsl-rl's adaptive KL
  schedule (desired KL 0.01), 4 epochs x 2 mini-batches, [256, 256, 256, 256] ELU, a Beta distribution (actions
  bounded to [-1, 1] by construction; its mean is the deterministic controller). The update is bound by
  per-mini-batch overhead, not arithmetic: 2 x 4 costs 53 ms per iteration at 4096 envs against 119 ms for rsl-rl's
  usual 4 x 5, and reached the same skill sooner (BENCHMARKS.md).

Only this module and :mod:`hexnewton.tasks` hold learner settings; ``train.py --agent.<field> VALUE`` overrides any.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields, replace

from hexnewton.config import TERRAINS, RewardConfig

DISTRIBUTIONS = ("beta", "gaussian")
#: torch.compile modes rsl-rl accepts (it rejects the CUDA-graph ones)
COMPILE_MODES = ("default", "max-autotune-no-cudagraphs")
#: what ``AgentConfig.scale_with_ranks`` may scale with the number of torchrun ranks
RANK_SCALINGS = ("mini_batches", "iterations", "learning_rate")
#: PPO settings a curriculum stage may change besides the reflex gain and the reward weights (``AgentConfig.stages``):
#: train.py's runner sets them on rsl-rl's PPO as the stage begins (the adaptive schedule goes on from a stage's
#: learning rate); the skrl baselines take none
STAGE_ALGORITHM_FIELDS = ("learning_rate", "desired_kl", "entropy_coef")
#: physics a curriculum stage may change, with the values it may take: the servos' effort clamp moved to the
#: actuators, as the deployment bundle's MJCF has it (``SimConfig.effort_clamp``; ``HexapodEnv.set_effort_clamp``)
STAGE_PHYSICS_FIELDS = {"effort_clamp": ("actuator",)}


def stage_at(stages: tuple, iteration: int) -> tuple[int, dict]:
    """(index, merged changes) of the curriculum stage begun by PPO iteration ``iteration`` (the changes of it and
    of every stage before it); (-1, {}) before the first."""
    begun = [k for k, (start, _) in enumerate(stages) if iteration >= start]
    if not begun:
        return -1, {}
    changes: dict = {}
    for _, c in stages[: begun[-1] + 1]:
        changes.update(c)
    return begun[-1], changes


def stage_line(changes: dict) -> str:
    """A stage's changes for the console: ``w_tilt 40, desired_kl 0.005, effort_clamp actuator``."""
    return ", ".join(f"{k} {v:g}" if isinstance(v, (int, float)) else f"{k} {v}" for k, v in changes.items())


def apply_stage(env, changes: dict) -> tuple[dict, str]:
    """A stage's merged ``changes`` (:func:`stage_at`) set on ``env`` (a ``HexapodEnv``): its reflex gain and reward
    weights (``set_shaping``) and its physics (``set_effort_clamp``). Returns its PPO fields, for the learner to set,
    and the console text of the whole stage (``posture_reflex 2, w_tilt 40, ...``)."""
    reflex, reward, algorithm, physics = split_stage_changes(changes)
    reflex = env.cfg.cpg.posture_reflex if reflex is None else reflex
    env.set_shaping(replace(env.cfg.reward, **reward), reflex)
    if "effort_clamp" in physics:
        env.set_effort_clamp(physics["effort_clamp"])
    head = f"posture_reflex {reflex:g}, " if getattr(env, "cpg", None) is not None else ""  # joint mode: no CPG
    return algorithm, head + stage_line({**reward, **algorithm, **physics})


def split_stage_changes(changes: dict) -> tuple[float | None, dict, dict, dict]:
    """A stage's changes as (its ``posture_reflex`` or None, its RewardConfig fields, its PPO fields, its physics
    fields)."""
    rest = dict(changes)
    reflex = rest.pop("posture_reflex", None)
    algorithm = {k: rest.pop(k) for k in STAGE_ALGORITHM_FIELDS if k in rest}
    physics = {k: rest.pop(k) for k in STAGE_PHYSICS_FIELDS if k in rest}
    return reflex, rest, algorithm, physics


@dataclass
class DistributionConfig:
    """The policy's action distribution."""

    #: ``beta`` (rsl-rl's ``BetaDistribution``, bounded) or ``gaussian`` (clipped to [-1, 1] by the action kernel)
    name: str = field(default="beta", metadata={"choices": DISTRIBUTIONS})
    #: gaussian: initial std, learnt unless ``learn_std`` is false (then fixed)
    init_std: float = 0.5
    learn_std: bool = True
    #: gaussian: cap on the learnt std (rsl-rl's ``std_range``; none: uncapped). Actions are clipped to [-1, 1] and
    #: filtered into the CPG parameters, so a wider Gaussian only moves the filtered parameter's mean; the entropy
    #: bonus grew the std to 1.7-5.8 in uncapped complex runs (RESULTS.md).
    std_max: float | None = None


@dataclass
class ModelConfig:
    """Actor and critic MLPs (rsl-rl's ``MLPModel``)."""

    hidden_dims: tuple[int, ...] = (256, 256, 256, 256)
    activation: str = field(default="elu", metadata={"choices": ("elu", "relu", "tanh", "selu", "lrelu")})
    obs_normalization: bool = True


@dataclass
class AlgorithmConfig:
    """rsl-rl's PPO."""

    learning_rate: float = 1.0e-3
    schedule: str = field(default="adaptive", metadata={"choices": ("adaptive", "fixed")})
    desired_kl: float = 0.01
    gamma: float = 0.99
    lam: float = 0.95
    clip_param: float = 0.2
    num_learning_epochs: int = 4
    num_mini_batches: int = 2
    #: samples per mini-batch; set, it replaces ``num_mini_batches`` (num_envs x num_steps_per_env / mini_batch_size)
    mini_batch_size: int | None = None
    value_loss_coef: float = 1.0
    use_clipped_value_loss: bool = True
    entropy_coef: float = 0.005
    max_grad_norm: float = 1.0
    #: bfloat16 autocast in the update's forward pass and losses (rsl-rl's ``use_mixed_precision``)
    use_mixed_precision: bool = False


@dataclass
class AgentConfig:
    """Everything the learner does: PPO, the networks, the rollout length, how long and how it stops, the curriculum."""

    num_steps_per_env: int = 24
    max_iterations: int = 300
    save_interval: int = 50
    #: stop after this wall time [min] (then save and export as at the end); none: no limit
    max_minutes: float | None = None
    #: stop once this share of the last 1024 training episodes succeeded (with a terrain curriculum: of those, at
    #: least 256, played on the last level); none: no target
    target_success: float | None = None
    #: torch.compile the actor and critic (rsl-rl's ``torch_compile_mode``); none: off
    torch_compile: str | None = field(default=None, metadata={"choices": COMPILE_MODES})
    #: curriculum of the reflex gain, the reward weights, PPO settings and physics: ((first iteration, {field:
    #: value}), ...), applied from that iteration on; fields are ``posture_reflex`` (CPGConfig), RewardConfig's,
    #: :data:`STAGE_ALGORITHM_FIELDS` (e.g. ``{'desired_kl': 0.005}``: smaller steps from that stage on) and
    #: :data:`STAGE_PHYSICS_FIELDS` (``{'effort_clamp': 'actuator'}``: the deployment bundle's clamp from then on)
    stages: tuple = ()
    #: deterministic validation at the end (``hexnewton.analysis.validation``): the run's result is the candidate
    #: checkpoint of the last stage (the last, the best by training success and the newest saved ones, at most
    #: ``validation_candidates``) whose deterministic action reaches the goal most often in this many validation
    #: rounds of the task's course; 0: the result is the best by training success (sampled actions)
    validation_rounds: int = 0
    validation_candidates: int = 4
    #: control steps per validation round: a robot still on its way then has not reached the goal
    validation_steps: int = 3000
    #: the courses validated on (§3.1's, by name), each candidate judged on its shares averaged over them; empty: the
    #: task's own course
    validation_terrains: tuple[str, ...] = field(default=(), metadata={"choices": TERRAINS})
    #: ours: the validation's courses side by side in one env (a lane group each, its own block seed;
    #: ``analysis.validation.validate_together``), which steps them in about one course's time, not one env per course
    #: one after another; a torchrun job deals its courses over its ranks either way. Off until the learner's gate
    #: holds with it (studies/learner, arm ``together``)
    validation_together: bool = False
    #: ours: how the candidates are ranked. "mean": the goal share averaged over the courses, then the fewest falls
    #: before the goal line; "worst": the worst course's goal share less ``validation_fall_weight`` x its falls before
    #: the goal line (a course on which every candidate reaches every goal does not count), then the same averaged over
    #: the courses (``analysis.validation.choose``): what the gate judges, each course on its own
    validation_rank: str = field(default="mean", metadata={"choices": ("mean", "worst")})
    validation_fall_weight: float = 2.0
    #: ours: one more candidate, the weight average of the last stage's candidates (actor, critic and their
    #: observation normalisers; :func:`hexnewton.learning.checkpoint.average_checkpoints`), kept as
    #: ``model_average.pt``
    validation_average: bool = False
    #: ours: rsl-rl's per-step bookkeeping of the finished episodes (the mean reward and episode length it logs) kept
    #: on the device and read once per iteration (:mod:`hexnewton.learning.episode_log`), not with three host syncs
    #: every step; the same values logged. False: rsl-rl's own
    deferred_episode_log: bool = True
    #: ours: the networks' float32 matrix products on TF32 tensor cores (``torch.set_float32_matmul_precision("high")``,
    #: in the rollout's inference and the update; CUDA only, a 10-bit mantissa in the products' inputs). False: torch's
    #: default, full float32 ("highest")
    tf32: bool = False
    #: under torchrun with K ranks (:meth:`for_ranks`): ``mini_batches``: K times the mini-batches per rank (the
    #: mini-batch summed over the ranks stays one process's, K times the optimizer steps per iteration);
    #: ``iterations``: max_iterations, save_interval and the stages' first iterations divided by K (one process's
    #: env-steps and reward stages per env-step; the terrain lanes still climb per goal reached, so each robot climbs
    #: K times fewer: studies/scale_out); ``learning_rate``: K times the learning rate (fixed schedule only: the
    #: adaptive one sets it from the ranks' mean KL). Empty: every rank runs this config as it is (rsl-rl's way)
    scale_with_ranks: tuple[str, ...] = field(default=(), metadata={"choices": RANK_SCALINGS})
    #: ours: ``train.py --init POLICY.pt`` starts the actor (and its observation normaliser) from that policy and the
    #: critic anew; for this many first iterations the actor stays as loaded (its parameters and normaliser frozen)
    #: while the critic learns the values of its actions on this task and robot, then both learn. 0: both at once
    init_critic_iterations: int = 10
    distribution: DistributionConfig = field(default_factory=DistributionConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    algorithm: AlgorithmConfig = field(default_factory=AlgorithmConfig)

    def check(self) -> None:
        """ValueError (one line) for settings rsl-rl would reject late or misread."""
        if self.max_minutes is not None and not self.max_minutes > 0:
            raise ValueError("agent.max_minutes must be positive")
        if self.target_success is not None and not 0 < self.target_success <= 1:
            raise ValueError("agent.target_success must lie in (0, 1]")
        if self.validation_rounds < 0:
            raise ValueError("agent.validation_rounds must be 0 (off) or positive")
        if self.init_critic_iterations < 0:
            raise ValueError("agent.init_critic_iterations must be 0 (the actor learns at once) or positive")
        if not (self.validation_fall_weight >= 0 and self.validation_fall_weight < float("inf")):
            raise ValueError("agent.validation_fall_weight must be a finite number >= 0")
        for name in ("num_steps_per_env", "max_iterations", "save_interval", "validation_candidates",
                     "validation_steps"):  # fmt: skip
            if getattr(self, name) <= 0:
                raise ValueError(f"agent.{name} must be positive")
        if self.distribution.name == "gaussian" and not self.distribution.init_std > 0:
            raise ValueError("agent.distribution.init_std must be positive")
        if self.distribution.std_max is not None and not self.distribution.std_max > 0:
            raise ValueError("agent.distribution.std_max must be positive")
        a = self.algorithm
        if a.use_mixed_precision and self.distribution.name == "beta":
            raise ValueError("agent.algorithm.use_mixed_precision: bfloat16 autocast cannot sample the Beta distribution "
                             "(torch has no bfloat16 Dirichlet); use it with --agent.distribution.name gaussian")
        if a.num_learning_epochs <= 0 or a.num_mini_batches <= 0 or (a.mini_batch_size or 1) <= 0:
            raise ValueError("agent.algorithm epochs, mini-batches and mini-batch size must be positive")
        reward_fields = {f.name for f in fields(RewardConfig)}
        for start, changes in self.stages:
            if not isinstance(start, int) or not isinstance(changes, dict):
                raise ValueError("agent.stages: expected ((first_iteration, {field: value}), ...)")
            unknown = [k for k in changes if k != "posture_reflex" and k not in reward_fields
                       and k not in STAGE_ALGORITHM_FIELDS and k not in STAGE_PHYSICS_FIELDS]  # fmt: skip
            if unknown:
                raise ValueError(f"agent.stages: {unknown[0]} is none of posture_reflex, a reward weight "
                                 f"(RewardConfig), {', '.join(STAGE_ALGORITHM_FIELDS)} or "
                                 f"{', '.join(STAGE_PHYSICS_FIELDS)}")  # fmt: skip
            _, _, algorithm, physics = split_stage_changes(changes)
            for name, value in physics.items():
                if value not in STAGE_PHYSICS_FIELDS[name]:
                    raise ValueError(f"agent.stages: {name} {value!r}: a stage may set it to "
                                     f"{', '.join(STAGE_PHYSICS_FIELDS[name])}")  # fmt: skip
            if any(not isinstance(v, (int, float)) or not v >= 0 for v in algorithm.values()):
                raise ValueError(f"agent.stages: {', '.join(algorithm)} must be numbers >= 0")
            if "desired_kl" in algorithm and a.schedule != "adaptive":
                raise ValueError("agent.stages: desired_kl needs the adaptive schedule (--agent.algorithm.schedule "
                                 "adaptive)")  # fmt: skip
        unknown = [t for t in self.validation_terrains if t not in TERRAINS]
        if unknown:
            raise ValueError(f"agent.validation_terrains: {unknown[0]} is not one of {', '.join(TERRAINS)}")
        if len(set(self.validation_terrains)) < len(self.validation_terrains):
            raise ValueError("agent.validation_terrains: name each course once")
        unknown = [s for s in self.scale_with_ranks if s not in RANK_SCALINGS]
        if unknown:
            raise ValueError(f"agent.scale_with_ranks: {unknown[0]} is not one of {', '.join(RANK_SCALINGS)}")
        if "learning_rate" in self.scale_with_ranks and a.schedule == "adaptive":
            raise ValueError("agent.scale_with_ranks learning_rate needs --agent.algorithm.schedule fixed: the adaptive "
                             "schedule sets the rate from the ranks' mean KL after every mini-batch")

    def for_ranks(self, world_size: int) -> AgentConfig:
        """The config each of ``world_size`` torchrun ranks trains with: this one scaled as ``scale_with_ranks``
        says (itself for one rank or no scaling). rsl-rl 5.5.1 averages the ranks' gradients in every mini-batch
        (so the mini-batch summed over the ranks is K per-rank ones, at the same optimizer steps per iteration) and,
        with the adaptive schedule, averages the KL over the ranks; rank 0 sets the rate and broadcasts it."""
        k, todo = world_size, set(self.scale_with_ranks)
        if k <= 1 or not todo:
            return self
        out, a = self, self.algorithm
        if "mini_batches" in todo:
            a = replace(a, mini_batch_size=max(1, a.mini_batch_size // k)) if a.mini_batch_size else \
                replace(a, num_mini_batches=a.num_mini_batches * k)  # fmt: skip
        if "learning_rate" in todo:
            a = replace(a, learning_rate=a.learning_rate * k)
            out = replace(out, stages=tuple((start, {n: v * k if n == "learning_rate" else v for n, v in c.items()})
                                            for start, c in out.stages))  # fmt: skip
        if "iterations" in todo:
            def div(n: int) -> int:
                return max(1, -(-n // k))

            out = replace(out, max_iterations=div(out.max_iterations), save_interval=div(out.save_interval),
                          stages=tuple((start // k, changes) for start, changes in out.stages))  # fmt: skip
        return replace(out, algorithm=a)

    def to_rsl_rl(self, num_envs: int, groups: tuple[str, ...] = ("policy",)) -> dict:
        """rsl-rl-lib 5.5.1's ``OnPolicyRunner`` configuration for ``num_envs`` envs per process whose observations hold
        the groups ``groups`` (``HexapodEnv.obs_groups``): the actor reads ``policy``, the critic every group (with
        ``ObsConfig.critic``: ``["policy", "critic"]``, an asymmetric critic)."""
        a = asdict(self.algorithm)
        size = a.pop("mini_batch_size")
        if size:
            a["num_mini_batches"] = max(1, num_envs * self.num_steps_per_env // size)
        if self.algorithm.schedule != "adaptive":
            a.pop("desired_kl")
        d = self.distribution
        dist = {"class_name": "BetaDistribution"} if d.name == "beta" else {
            "class_name": "GaussianDistribution", "init_std": d.init_std, "learn_std": d.learn_std,
            "std_range": (1e-6, d.std_max or 1e6)}  # fmt: skip
        model = dict(class_name="MLPModel", hidden_dims=list(self.model.hidden_dims), activation=self.model.activation,
                     obs_normalization=self.model.obs_normalization)  # fmt: skip
        return {
            "num_steps_per_env": self.num_steps_per_env,
            "save_interval": self.save_interval,
            "obs_groups": {"actor": ["policy"], "critic": list(groups)},
            "logger": "tensorboard",
            # rsl-rl's NaN check costs three device-to-host syncs per env step; the env already guarantees finite
            # observations and rewards in-kernel (a blown-up env is reset and counted: mdp/terms/,
            # tested by injecting NaN/Inf), so the check only stalls the GPU
            "check_for_nan": False,
            "actor": dict(model, distribution_cfg=dist),
            "critic": dict(model),
            "algorithm": dict(a, class_name="PPO"),
            "torch_compile_mode": self.torch_compile,
        }


def paper_agent() -> AgentConfig:
    """Table 2's PPO (module docstring)."""
    return AgentConfig(
        distribution=DistributionConfig(name="gaussian", init_std=1.0),
        model=ModelConfig(activation="relu", obs_normalization=False),
        algorithm=AlgorithmConfig(learning_rate=1.0e-4, schedule="fixed", num_learning_epochs=10, mini_batch_size=512,
                                  entropy_coef=0.0, value_loss_coef=0.5, use_clipped_value_loss=False,
                                  max_grad_norm=0.5),  # fmt: skip
    )


def agent_from_dict(d: dict | None) -> AgentConfig:
    """Rebuild an :class:`AgentConfig` from ``dataclasses.asdict`` output (a checkpoint's ``agent``); unknown keys are
    ignored, missing ones keep their defaults."""
    from hexnewton.config import dataclass_from_dict

    return dataclass_from_dict(AgentConfig, d or {})


def legacy_agent(meta: dict) -> AgentConfig:
    """The learner of a checkpoint that records only ``preset``, ``distribution`` and ``std_max``."""
    base = AgentConfig()
    if meta.get("preset") == "paper":  # those normalised their observations
        base = replace(paper_agent(), model=ModelConfig(activation="relu"))
    dist = replace(base.distribution, name=meta.get("distribution", "gaussian"), std_max=meta.get("std_max"))
    return replace(base, distribution=dist)
