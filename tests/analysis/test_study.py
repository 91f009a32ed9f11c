"""The paper's comparison kept across leases, end to end on the CPU: two methods trained for a few real iterations (two
seeds each), evaluated with their deterministic and their sampled action beside the fixed CPG, stored in a study as
``scripts/device/gpu.sh`` lays a lease out, and reported (Fig. 5a against env-steps and wall time, Table 3)."""

import json

import pytest
import torch

from hexnewton.apps.cli import run


def _lease(tmp_path):
    """A lease's $RUNS/methods and $RUNS/method_evals: cpg_rl (train.py) and a2c_cpg (skrl), seeds 1 and 2, on the flat
    task (20-step episodes); each run's .done as gpu.sh writes it; its last checkpoint on 2 rounds of 60 steps, deterministic and
    sampled; the fixed CPG."""
    from hexnewton.apps import baselines, evaluate, train

    methods, evals = tmp_path / "methods", tmp_path / "method_evals"
    evals.mkdir(parents=True)
    common = ["--task", "flat", "--num_envs", "8", "--device", "cpu", "--log_dir", str(methods),
              "--env.task.max_episode_steps", "20"]  # episodes end within an iteration
    for seed in (1, 2):
        for name, main, prog, extra in (
            ("cpg_rl", train.main, "train.py", ["--max_iterations", "2", "--headless", "--agent.validation_rounds", "0"]),
            ("a2c_cpg", baselines.main, "python -m hexnewton.apps.baselines",
             ["--algo", "a2c", "--total_steps", "384", "--agent.rollouts", "24"]),
        ):  # fmt: skip
            argv = [*common, *extra, "--seed", str(seed), "--experiment", f"{name}_s{seed}"]
            assert run(main, prog, argv) == 0
            (methods / f"{name}_s{seed}.done").write_text(json.dumps({"exit": 0, "process_s": 1, "gpu": "cpu",
                                                                      "command": " ".join(argv)}))  # fmt: skip
    eval_args = ["--terrains", "flat", "--rounds", "2", "--max_steps", "60", "--device", "cpu", "--no-progress"]
    assert run(evaluate.main, "evaluate", ["--controllers", "cpg", *eval_args, "--out", str(evals / "cpg_s0_flat")]) == 0
    for ck in sorted(methods.glob("*_s*/*/model_*.pt")):
        name = ck.parent.parent.name
        ctrl = name.rsplit("_s", 1)[0]
        for suffix, flags in (("", []), ("_sampled", ["--stochastic"])):
            argv = ["--controllers", ctrl, "--checkpoint", f"{ctrl}={ck}", *eval_args, *flags,
                    "--out", str(evals / f"{name}_flat{suffix}")]  # fmt: skip
            if not (evals / f"{name}_flat{suffix}").exists():
                assert run(evaluate.main, "evaluate", argv) == 0
    return methods, evals


def test_study_of_two_methods_is_stored_and_reported(tmp_path, capsys):
    from hexnewton.apps.compare import main
    from hexnewton.learning.checkpoint import read_checkpoint

    methods, evals = _lease(tmp_path)
    study = tmp_path / "study"
    argv = ["--study", str(study), "--add", str(methods), str(evals), "--terrains", "flat", "--seeds", "2"]
    assert run(main, "compare", argv) == 0
    assert "added to" in capsys.readouterr().out
    # the study keeps each run's policy alone, the scalars Fig. 5a reads and the evaluations' results
    stored = sorted(study.glob("runs/*_s*/*/model_*.pt"))
    assert len(stored) == 4
    for path in stored:
        ckpt = read_checkpoint(str(path))
        assert "optimizer_state_dict" not in ckpt and "critic_state_dict" not in ckpt
        assert set(ckpt.get("modules", {})) <= {"policy", "observation_preprocessor"}
    assert not list(study.glob("evals/*/*.png"))
    report = (study / "report.md").read_text()
    res = json.loads((study / "results.json").read_text())
    # both figures, against env-steps and against wall time
    for x in ("env_steps", "wall_time"):
        assert (study / f"fig5a_{x}.png").stat().st_size > 10000
        for method in ("cpg_rl", "a2c_cpg"):
            assert set(res["fig5a_final"][method][x]) >= {"Train/mean_reward", "Episode/success_rate"}
    assert res["budgets"]["cpg_rl"]["1"]["env_steps"] == 2 * 8 * 24 and res["budgets"]["a2c_cpg"]["2"]["gpu"] == "cpu"
    # Table 3: the fixed CPG and both methods, deterministic with the sampled action beside, and the sampled table
    for actions in ("deterministic", "sampled"):
        assert set(res["table3"][actions]["flat"]) >= {"cpg_rl", "a2c_cpg"}
    row = res["table3"]["deterministic"]["flat"]["a2c_cpg"]
    assert row["seeds"] == [1, 2] and row["rounds"] == [2]
    assert {"fall_rate", "pitch_var_deg2", "roll_var_deg2", "pitch_p999_deg", "roll_p999_deg"} <= set(row)
    assert "| \\|pitch\\| p99.9 [deg] | \\|roll\\| p99.9 [deg] | 3 m sampled | falls sampled |" in report
    assert "| flat | CPG | 1 | 2 |" in report and "| flat | A2C-CPG | 2 | 2 |" in report
    # the methods never run are what is missing; a second --add of the same lease adds nothing
    assert "(partial)" in report and "runs sac_cpg_s1, sac_cpg_s2" in report and "runs paper_s1" in report
    assert run(main, "compare", argv) == 0
    assert "0 runs (none), 0 evaluations" in capsys.readouterr().out
    # a stored policy is still what evaluate loads
    ck = next(p for p in stored if "a2c_cpg" in str(p))
    assert torch.load(ck, weights_only=True)["algo"] == "a2c"


def test_compare_arguments_give_one_line(tmp_path, capsys):
    from hexnewton.apps.compare import main

    for argv, msg in ((["--study", str(tmp_path), "--out", str(tmp_path / "x")], "--study replaces"),
                      (["--runs", str(tmp_path)], "give --study DIR, or --runs and --out"),
                      (["--study", str(tmp_path), "--add", str(tmp_path / "nope")], "not a folder"),
                      (["--runs", str(tmp_path), "--add", str(tmp_path), "--out", str(tmp_path / "o")], "--add needs")):
        assert run(main, "compare", argv) == 2
        err = capsys.readouterr().err
        assert msg in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
