"""The skrl baselines (hexnewton.learning.baselines): each algorithm trains a few steps on CPU, saves a checkpoint that loads as
data only, and runs the evaluation's rounds; the adapter, the squashed actor, the presets and one-line errors."""

import json
import math
import os

import pytest
import torch

from hexnewton.learning.baselines import agent_config

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
SMALL = {  # a few updates on 8 envs
    "sac": ["--agent.batch_size", "64", "--agent.learning_starts", "2", "--agent.buffer_size", "512"],
    "td3": ["--agent.batch_size", "64", "--agent.learning_starts", "2", "--agent.buffer_size", "512"],
    "a2c": ["--agent.rollouts", "3"],
}


def _main(argv):
    from hexnewton.apps.baselines import main
    from hexnewton.apps.cli import run

    return run(main, "python -m hexnewton.apps.baselines", argv)


@pytest.mark.parametrize("algo", ["sac", "td3", "a2c"])
def test_baseline_trains_saves_and_runs_the_rounds(algo, tmp_path, capsys):
    """12 vector steps of 8 envs (updates from the 3rd), a checkpoint of tensors and plain data with the task's
    config, TensorBoard points against env-steps, then two evaluation rounds with the deterministic action."""
    from hexnewton.analysis.curves import read_curve
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.learning.baselines import load_baseline_checkpoint
    from hexnewton.learning.checkpoint import checkpoint_meta, trained_config
    from hexnewton.learning.policy import policy_checkpoint
    from hexnewton.tasks import task

    logs = tmp_path / "logs"
    argv = ["--task", "flat", "--algo", algo, "--num_envs", "8", "--device", "cpu", "--total_steps", "96",
            "--log_dir", str(logs), "--agent.log_interval", "4", *SMALL[algo]]  # fmt: skip
    assert _main(argv) == 0
    out = capsys.readouterr().out
    assert "finished after 96 env-steps" in out
    steps = [line for line in out.splitlines() if line.startswith("step ")]
    assert len(steps) == 3 and all(" left" in line for line in steps), steps  # the time left on each line
    assert steps[-1].endswith("0:00:00 left"), steps[-1]
    (path,) = logs.glob(f"hexnewton_flat_{algo}/*/model_12.pt")
    raw = torch.load(path, weights_only=True)  # nothing in the file is code
    assert raw["env_steps"] == 96 and "policy" in raw["modules"]
    ckpt = load_baseline_checkpoint(str(path))
    meta = checkpoint_meta(ckpt)
    assert (meta["algo"], meta["action_mode"], meta["num_obs"], meta["num_actions"]) == (algo, "cpg", 59, 15)
    expected = task("flat").env
    assert trained_config(ckpt).reward == expected.reward and trained_config(ckpt).cpg == expected.cpg
    assert policy_checkpoint(str(path))[1] == f"{algo}_cpg"
    curve = read_curve(str(path.parent), "env_steps")
    assert [x for x, _ in curve["Episode/success_rate"]] == [32.0, 64.0, 96.0]
    ep = run_rounds(f"{algo}_cpg", str(path), "flat", 2, "cpu", 5, False)
    assert ep.pos.shape == (5, 2, 2) and not torch.isnan(torch.as_tensor(ep.pos)).any()
    cfg = json.loads((path.parent / "config.json").read_text())["hexnewton"]
    assert cfg["baseline"]["learning_rate"] == agent_config(algo).learning_rate


def test_a_baseline_trains_on_another_robot_and_keeps_to_it(tmp_path, capsys):
    """``--robot mx_phoenix``: the task's config on that robot (``with_robot``, as ``train.py --robot``), its runs in
    ``hexnewton_<task>_<algo>_mx_phoenix``; the checkpoint records the robot as an rsl-rl one does (the whole
    description in its config, its name in the metadata), its evaluation rounds walk that robot, and played or
    evaluated on another robot it is the rsl-rl path's one line, exit status 2."""
    pytest.importorskip("skrl")
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.apps import evaluate, play
    from hexnewton.apps.cli import run
    from hexnewton.errors import HexnewtonError
    from hexnewton.learning.baselines import load_baseline_checkpoint
    from hexnewton.learning.checkpoint import checkpoint_meta, trained_config
    from hexnewton.robot.registry import ROBOTS, same_robot, with_robot
    from hexnewton.tasks import task

    logs = tmp_path / "logs"
    argv = ["--task", "flat", "--algo", "a2c", "--num_envs", "4", "--device", "cpu", "--total_steps", "16",
            "--log_dir", str(logs), "--agent.rollouts", "2", "--robot", "mx_phoenix"]  # fmt: skip
    assert _main(argv) == 0
    assert "on task flat on robot mx_phoenix: 4 envs" in capsys.readouterr().out
    (path,) = logs.glob("hexnewton_flat_a2c_mx_phoenix/*/model_4.pt")
    ckpt = load_baseline_checkpoint(str(path))
    trained, want = trained_config(ckpt), with_robot(task("flat").env, ROBOTS["mx_phoenix"])
    assert checkpoint_meta(ckpt)["robot"] == "mx_phoenix" and same_robot(trained.robot, ROBOTS["mx_phoenix"])
    assert (trained.cpg, trained.task.height_scale) == (want.cpg, want.task.height_scale) != (task("flat").env.cpg, 1.0)
    assert json.loads((path.parent / "config.json").read_text())["hexnewton"]["robot"] == "mx_phoenix"
    ep = run_rounds("a2c_cpg", str(path), "flat", 2, "cpu", 3, False, robot=ROBOTS["mx_phoenix"])
    assert ep.pos.shape == (3, 2, 2)
    with pytest.raises(HexnewtonError, match="trained on robot mx_phoenix, not paper"):
        run_rounds("a2c_cpg", str(path), "flat", 2, "cpu", 3, False, robot=ROBOTS["paper"])
    for module, args in ((play, ["--checkpoint", str(path), "--steps", "1", "--viewer", "null"]),
                         (evaluate, ["--controllers", "a2c_cpg", "--checkpoint", f"a2c_cpg={path}", "--rounds", "1",
                                     "--terrains", "flat", "--out", str(tmp_path / "e")])):  # fmt: skip
        rc = run(module.main, "prog", args + ["--robot", "paper"])
        err = capsys.readouterr().err.strip().splitlines()
        assert rc == 2 and len(err) == 1 and f"{path} was trained on robot mx_phoenix, not paper" in err[0], err
        assert "--init" not in err[0]  # train.py --init takes an rsl-rl checkpoint, not a baseline's
    assert not (tmp_path / "e").exists()


def test_a_stop_signal_saves_and_exits_143(tmp_path, monkeypatch, capsys):
    """SIGTERM during training (raised where the handler raises it, inside the loop): the checkpoint is written and
    the command exits 143, so a queue never takes the stopped run for a finished one."""
    from hexnewton.learning import baselines
    from hexnewton.learning.stopping import TrainingStopped, exit_status

    log = baselines.BaselineTrainer._log
    calls = []

    def stop_once(self, *a):
        log(self, *a)
        if not calls:
            calls.append(1)
            raise TrainingStopped("SIGTERM")

    monkeypatch.setattr(baselines.BaselineTrainer, "_log", stop_once)
    argv = ["--task", "flat", "--algo", "a2c", "--num_envs", "8", "--device", "cpu", "--total_steps", "96",
            "--log_dir", str(tmp_path), "--agent.log_interval", "4", *SMALL["a2c"]]  # fmt: skip
    assert _main(argv) == 143 == exit_status("SIGTERM")
    assert "finished after 32 env-steps" in capsys.readouterr().out
    assert list(tmp_path.glob("hexnewton_flat_a2c/*/model_4.pt"))
    assert (exit_status("SIGINT"), exit_status("96 env-steps")) == (130, 0)


def test_adapter_passes_device_tensors_in_skrls_layout():
    from hexnewton.config import HexConfig, SimConfig
    from hexnewton.learning.baselines import wrap_env
    from hexnewton.mdp.env import make_env

    env = make_env(HexConfig(sim=SimConfig(num_envs=3, device="cpu")))
    skrl_env = wrap_env(env)
    obs, _ = skrl_env.reset()
    assert obs.shape == (3, 59) and skrl_env.action_space.shape == (15,) and skrl_env.num_envs == 3
    nxt, rew, term, trunc, infos = skrl_env.step(torch.zeros(3, 15))
    assert nxt.shape == (3, 59) and rew.shape == (3, 1) and term.dtype == torch.bool and trunc.shape == (3, 1)
    assert nxt.data_ptr() != env._obs_t.data_ptr() and obs.data_ptr() != nxt.data_ptr()  # copies, never views
    assert "Episode/success_rate" in infos["log"] and skrl_env.state() is None


def test_squashed_actor_is_bounded_with_the_tanh_corrected_log_prob():
    """SAC's actor: samples and the deterministic action in [-1, 1]; log_prob equals torch's TanhTransform density."""
    import gymnasium
    import numpy as np
    from torch.distributions import Normal, TransformedDistribution
    from torch.distributions.transforms import TanhTransform

    from hexnewton.learning.baselines import make_models

    obs_space = gymnasium.spaces.Box(-np.inf, np.inf, (5,), np.float32)
    act_space = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
    actor = make_models("sac", agent_config("sac"), obs_space, act_space, "cpu")["policy"]
    obs = 10.0 * torch.randn(64, 5)
    actions, out = actor.act({"observations": obs})
    assert actions.abs().max() <= 1.0 and out["mean_actions"].abs().max() <= 1.0
    mean, o = actor.compute({"observations": obs})
    ref = TransformedDistribution(Normal(mean, o["log_std"].exp()), [TanhTransform()])
    a = torch.tanh(mean + 0.3)
    _, out = actor.act({"observations": obs, "taken_actions": a})
    assert torch.allclose(out["log_prob"].squeeze(-1), ref.log_prob(a).sum(-1), atol=1e-3)


def test_paper_preset_is_table_2():
    for algo in ("sac", "td3", "a2c"):
        cfg = agent_config(algo, "paper")
        assert (cfg.learning_rate, cfg.gamma, cfg.model.hidden_dims, cfg.model.activation) == (
            1e-4, 0.99, (256, 256, 256, 256), "relu")
        assert (cfg.mini_batch_size if algo == "a2c" else cfg.batch_size) == 512
    assert agent_config("a2c", "paper").gae_lambda == 0.95


def test_stages_follow_the_ppo_schedule_in_steps_per_env():
    from hexnewton.learning.baselines import stage_changes
    from hexnewton.tasks import task

    stages = task("complex").agent.stages
    assert stage_changes(stages, 100 * 24 - 1, 24) == (-1, {})
    assert stage_changes(stages, 100 * 24, 24)[0] == 0
    index, changes = stage_changes(stages, 200 * 24, 24)
    assert index == 1 and changes["posture_reflex"] == 2.0 and changes["w_tilt"] == 40.0


@pytest.mark.parametrize("argv, message", [
    (["--algo", "ppo"], "argument --algo: invalid choice: 'ppo'"),
    (["--algo", "sac", "--agent.batch_size", "0"], "agent.batch_size must be positive"),
    (["--algo", "td3", "--task", "complex-joint"], "SAC-/TD3-/A2C-CPG act through the CPG"),
    (["--algo", "sac", "--max_minutes", "0"], "--max_minutes must be positive"),
    (["--algo", "a2c", "--agent.gamma", "x"], "expected a number"),
    (["--algo", "sac", "--robot", "phantom"], "unknown robot 'phantom': choose one of paper, mx_phoenix"),
    (["--algo", "sac", "--robot_joints", *["j"] * 18], "--robot_joints names the joints of a --robot FILE"),
])  # fmt: skip
def test_bad_values_give_one_line_and_exit_2(argv, message, capsys):
    try:
        rc = _main(argv + ["--device", "cpu"])
    except SystemExit as exc:  # argparse's own errors (hexnewton.apps.cli.ArgumentParser: one line, status 2)
        rc = exc.code
    err = capsys.readouterr().err
    assert rc == 2 and message in err and len(err.strip().splitlines()) == 1, err


def test_evaluate_rejects_a_checkpoint_of_the_other_kind(tmp_path, capsys):
    from hexnewton.apps.cli import run
    from hexnewton.apps.evaluate import main

    policy = os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt")
    rc = run(main, "python -m hexnewton.apps.evaluate", ["--controllers", "sac_cpg", "--checkpoint", f"sac_cpg={policy}",
                                                   "--terrains", "flat", "--out", str(tmp_path / "e")])  # fmt: skip
    err = capsys.readouterr().err
    assert rc == 2 and "not a skrl baseline checkpoint" in err and len(err.strip().splitlines()) == 1


def test_deterministic_action_of_a2c_is_the_clipped_mean():
    import gymnasium
    import numpy as np

    from hexnewton.learning.baselines import deterministic_action, make_agent

    obs_space = gymnasium.spaces.Box(-np.inf, np.inf, (4,), np.float32)
    act_space = gymnasium.spaces.Box(-1.0, 1.0, (2,), np.float32)
    agent = make_agent("a2c", agent_config("a2c", "paper"), obs_space, act_space, "cpu", 2, training=False)
    with torch.no_grad():
        for p in agent.policy.net[-1].parameters():
            p.fill_(0.0)
        agent.policy.net[-1].bias.copy_(torch.tensor([3.0, -0.25]))
        a = deterministic_action("a2c", agent, torch.randn(5, 4))
    assert torch.allclose(a, torch.tensor([[1.0, -0.25]] * 5)) and math.isclose(float(a.max()), 1.0)
