"""The paper's hierarchical baselines SAC-CPG, TD3-CPG and A2C-CPG: Stable-Baselines3 on the same batched env.

    python -m hexnewton.baselines --algo sac --terrain rugged --num_envs 256 --total_steps 2000000
    python -m hexnewton.baselines --algo a2c --terrain complex --num_envs 4096 --total_steps 10**9 --max_minutes 8
    python -m hexnewton.evaluate --controllers cpg_rl sac_cpg --checkpoint cpg_rl=A.pt sac_cpg=logs/.../model.zip

The paper trained every algorithm with Stable-Baselines3 (§3.1) and "the same hyper-parameters" (Table 2):
learning rate 1e-4, batch size 512, gamma 0.99, [256, 256, 256, 256] ReLU networks (lambda 0.95 for A2C's
GAE). What Table 2 cannot cover is SB3's default for each algorithm (replay buffer, learning starts, target
smoothing, A2C's n_steps). Two choices are ours because the env is batched:
- SAC / TD3: ``gradient_steps`` per vector step (default 16; SB3's 1 would do one update per
  ``num_envs`` transitions);
- A2C: ``n_steps`` 8 per env, so an update sees ``8 x num_envs`` samples.

``Sb3VecEnv`` adapts ``HexapodEnv`` (an rsl-rl VecEnv of torch tensors) to SB3's numpy ``VecEnv`` API and is
wrapped in SB3's ``VecMonitor`` for episode returns. Finished envs reset inside the env's step, so the
observation after a reset is the only one left. SB3 reads ``infos[i]["terminal_observation"]`` only to
bootstrap time-outs (``TimeLimit.truncated``), which come after 7000 steps (140 s). It gets that
post-reset observation: a small bias on those rare transitions, stated here rather than hidden.

Each run writes ``logs/hexnewton_<algo>_cpg_<terrain>/<date_time>/``: ``model.zip``, ``config.json`` and
TensorBoard events (SB3's ``rollout/ep_rew_mean`` against env-steps; ``hexnewton.curves`` reads them).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import os
import sys
import time
import zipfile

import numpy as np

from .cli import ArgumentParser, positive_int, run, terrain_name
from .config import HexConfig, SimConfig, TaskConfig, TerrainConfig

ALGOS = ("sac", "td3", "a2c")
LABELS = {"sac": "SAC-CPG", "td3": "TD3-CPG", "a2c": "A2C-CPG"}
TABLE2 = dict(learning_rate=1.0e-4, gamma=0.99)  # Table 2, shared by every algorithm
NET_ARCH = [256, 256, 256, 256]  # Table 2 (ReLU)


def _algo_class(algo: str):
    import stable_baselines3 as sb3

    if algo not in ALGOS:
        raise ValueError(f"unknown algorithm '{algo}': choose one of {', '.join(ALGOS)}")
    return {"sac": sb3.SAC, "td3": sb3.TD3, "a2c": sb3.A2C}[algo]


def make_sb3_env(env):
    """``HexapodEnv`` as an SB3 ``VecEnv`` (numpy in, numpy out), with SB3's ``VecMonitor`` on top."""
    import torch
    from gymnasium import spaces
    from stable_baselines3.common.vec_env import VecEnv, VecMonitor

    class Sb3VecEnv(VecEnv):
        def __init__(self):
            obs_space = spaces.Box(-np.inf, np.inf, (env.num_obs,), np.float32)
            act_space = spaces.Box(-1.0, 1.0, (env.num_actions,), np.float32)
            super().__init__(env.num_envs, obs_space, act_space)
            self.hex_env = env
            self._actions = None

        def reset(self):
            # the env reset every robot when it was built and resets finished ones inside step()
            return env.get_observations()["policy"].cpu().numpy()

        def step_async(self, actions):
            self._actions = torch.as_tensor(np.asarray(actions), dtype=torch.float32).clamp(-1.0, 1.0)

        def step_wait(self):
            obs, rew, done, extras = env.step(self._actions.to(env._obs_t.device))
            o = obs["policy"].cpu().numpy()
            d = done.cpu().numpy().astype(bool)
            timeout = extras["time_outs"].cpu().numpy().astype(bool)
            infos = [{} for _ in range(self.num_envs)]
            for i in np.flatnonzero(d):
                infos[i]["terminal_observation"] = o[i]  # post-reset (see the module docstring)
                infos[i]["TimeLimit.truncated"] = bool(timeout[i])
            return o, rew.cpu().numpy().astype(np.float32), d, infos

        def close(self):
            env.close()

        def get_attr(self, attr_name, indices=None):
            value = None if attr_name == "render_mode" else getattr(env, attr_name)  # headless: no render mode
            return [value] * len(list(self._get_indices(indices)))

        def set_attr(self, attr_name, value, indices=None):
            raise AttributeError("the hexnewton env has no per-robot attributes to set")

        def env_method(self, method_name, *args, indices=None, **kwargs):
            raise AttributeError("the hexnewton env has no per-robot methods")

        def env_is_wrapped(self, wrapper_class, indices=None):
            return [False] * len(list(self._get_indices(indices)))

    return VecMonitor(Sb3VecEnv())


def time_limit_callback(minutes: float):
    """An SB3 callback that ends ``learn`` (which then returns normally, so the model is saved) after ``minutes``
    of wall time."""
    from stable_baselines3.common.callbacks import BaseCallback

    class TimeLimit(BaseCallback):
        def _on_training_start(self) -> None:
            self.deadline = time.monotonic() + 60.0 * minutes

        def _on_step(self) -> bool:
            return time.monotonic() < self.deadline

    return TimeLimit()


def sb3_kwargs(algo: str, num_envs: int, gradient_steps: int, learning_starts: int, buffer_size: int) -> dict:
    """Constructor arguments: Table 2 plus SB3's defaults and the two batching choices above."""
    import torch

    kw = dict(TABLE2, policy_kwargs=dict(net_arch=NET_ARCH, activation_fn=torch.nn.ReLU))
    if algo in ("sac", "td3"):
        kw.update(batch_size=512, gradient_steps=gradient_steps, learning_starts=learning_starts,
                  buffer_size=buffer_size, train_freq=1)  # fmt: skip
    else:
        kw.update(n_steps=8, gae_lambda=0.95)
    return kw


def load_sb3_policy(env, path: str, algo: str, deterministic: bool = True):
    """``policy(obs TensorDict) -> actions`` from an SB3 ``model.zip`` (its mean action when ``deterministic``)."""
    import torch

    model = _algo_class(algo).load(path, device="cpu")
    if model.observation_space.shape != (env.num_obs,) or model.action_space.shape != (env.num_actions,):
        raise ValueError(f"{path} expects {model.observation_space.shape[0]} observations and "
                         f"{model.action_space.shape[0]} actions; this env has {env.num_obs} and {env.num_actions}")  # fmt: skip
    device = env._obs_t.device

    def policy(obs):
        actions, _ = model.predict(obs["policy"].cpu().numpy(), deterministic=deterministic)
        return torch.as_tensor(actions, dtype=torch.float32, device=device)

    return policy


def check_model_file(path: str) -> None:
    """One-line errors for a missing or damaged ``model.zip``."""
    if not os.path.isfile(path):
        raise ValueError(f"model not found: {path}")
    if not zipfile.is_zipfile(path):
        raise ValueError(f"{path} is not a Stable-Baselines3 model (not a zip file)")


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.baselines", description="SAC-/TD3-/A2C-CPG with Stable-Baselines3.")
    p.add_argument("--algo", required=True, help=f"one of {', '.join(ALGOS)}")
    p.add_argument("--terrain", type=terrain_name, default="flat")
    p.add_argument("--terrain_seed", type=int, default=0)
    p.add_argument("--num_envs", type=positive_int, default=None, help="default 256 on CUDA, 16 on CPU")
    p.add_argument("--total_steps", type=positive_int, default=1_000_000, help="env-steps over all envs")
    p.add_argument("--device", default=None)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--gradient_steps", type=positive_int, default=16, help="SAC/TD3 updates per vector step")
    p.add_argument("--learning_starts", type=int, default=10_000, help="SAC/TD3: env-steps before learning")
    p.add_argument("--buffer_size", type=positive_int, default=1_000_000, help="SAC/TD3 replay buffer")
    p.add_argument("--log_dir", default="logs")
    p.add_argument("--max_minutes", type=float, default=None, help="end training (and save) after this wall time")
    args = p.parse_args(argv)
    if args.max_minutes is not None and args.max_minutes <= 0:
        raise ValueError("--max_minutes must be positive")
    algo_cls = _algo_class(args.algo)
    from stable_baselines3.common.logger import configure

    from .env import make_env
    from .sim import resolve_device
    from .runner import seed_everything

    device = resolve_device(args.device)
    if args.num_envs is None:
        args.num_envs = 256 if device.startswith("cuda") else 16
    seed_everything(args.seed)
    cfg = HexConfig(sim=dataclasses.replace(SimConfig(), num_envs=args.num_envs, device=device),
                    terrain=TerrainConfig(name=args.terrain, seed=args.terrain_seed),
                    task=dataclasses.replace(TaskConfig(), seed=args.seed))  # fmt: skip
    env = make_env(cfg, "cpg")
    venv = make_sb3_env(env)
    kw = sb3_kwargs(args.algo, args.num_envs, args.gradient_steps, args.learning_starts, args.buffer_size)
    run_dir = os.path.join(args.log_dir, f"hexnewton_{args.algo}_cpg_{args.terrain}",
                           datetime.datetime.now().strftime("%Y-%m-%d_%H-%M-%S"))  # fmt: skip
    os.makedirs(run_dir, exist_ok=False)
    meta = {"algo": args.algo, "action_mode": "cpg", "num_obs": env.num_obs, "num_actions": env.num_actions,
            "sb3": {k: v for k, v in kw.items() if k != "policy_kwargs"}, "net_arch": NET_ARCH,
            "config": dataclasses.asdict(cfg)}  # fmt: skip
    with open(os.path.join(run_dir, "config.json"), "w") as f:
        json.dump({"hexnewton": meta}, f, indent=1, default=str)
    model = algo_cls("MlpPolicy", venv, seed=args.seed, device=device, verbose=0, **kw)
    model.set_logger(configure(run_dir, ["tensorboard"]))
    print(f"training {LABELS[args.algo]}: {args.num_envs} envs on {device}, {args.total_steps} env-steps, logs in {run_dir}")
    callback = time_limit_callback(args.max_minutes) if args.max_minutes else None
    t0 = time.perf_counter()
    model.learn(total_timesteps=args.total_steps, callback=callback, progress_bar=sys.stderr.isatty())
    print(f"trained {model.num_timesteps} env-steps in {time.perf_counter() - t0:.0f} s")
    path = os.path.join(run_dir, "model.zip")
    model.save(path + ".tmp.zip")
    os.replace(path + ".tmp.zip", path)
    stats = env.episode_stats()
    print("last episodes: " + ", ".join(f"{k} {v:.3f}" for k, v in stats.items()))
    print(f"saved {path}")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.baselines"))
