"""skrl's SAC, TD3 and A2C agents built from the baselines' settings, and the actions a trained agent runs."""

from __future__ import annotations

from hexnewton.learning.baselines.config import BaselineConfig
from hexnewton.learning.baselines.models import make_models
from hexnewton.learning.baselines.requirement import require_skrl
from hexnewton.learning.baselines.skrl_private import preprocess_observations


def make_agent(algo: str, cfg: BaselineConfig, observation_space, action_space, device, num_envs: int,
               training: bool = True, run_dir: str | None = None):
    """skrl's agent of ``algo`` with ``cfg`` on ``device``; with ``training`` its memory (replay buffer or rollout
    storage for ``num_envs`` envs) and, with ``cfg.skrl_stats``, its TensorBoard writer in ``run_dir/skrl``."""
    require_skrl()
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
    inputs = {"observations": preprocess_observations(agent, observations), "states": None}
    actions, outputs = agent.policy.act(inputs, role="policy")
    if algo == "td3":
        return actions
    return outputs["mean_actions"].clamp(-1.0, 1.0)


def sampled_action(algo: str, agent, observations):
    """An action sampled as in training, without TD3's exploration noise (TD3's actor is deterministic)."""
    inputs = {"observations": preprocess_observations(agent, observations), "states": None}
    actions, _ = agent.policy.act(inputs, role="policy")
    return actions.clamp(-1.0, 1.0)
