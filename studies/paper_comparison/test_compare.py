"""The paper's comparison kept across leases, end to end on the CPU: two methods trained for a few real iterations (two
seeds each), evaluated with their deterministic and their sampled action beside the fixed CPG, stored in a study as
``studies/device/gpu.sh`` lays a lease out, and reported (Fig. 5a against env-steps and wall time, Table 3)."""

import json

import pytest
import torch

from hexnewton.apps.cli import run

from compare import cut_short, main, without  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)


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
    # the figures, against env-steps and against wall time (one per GPU kind), and their numbers
    for name in ("fig5a_env_steps.png", "fig5a_wall_time_cpu.png"):
        assert (study / name).stat().st_size > 10000
    for key in ("success", "reward", "curriculum"):
        for method in ("cpg_rl", "a2c_cpg"):
            got = res["fig5a"][key][method]
            assert got["seeds"] == [1, 2] and len(got["per_seed"]) == 2
            # flat ground has no curriculum: no curve to read
            assert (got["mean"] is None) == (key == "curriculum"), (key, method, got)
            assert got["mean"] is None or {"peak", "end", "at_common"} <= set(got["mean"])
    assert {"first", "sustained", "dip_after_first"} <= set(res["fig5a"]["success"]["cpg_rl"]["mean"])
    assert res["budgets"]["cpg_rl"]["1"]["env_steps"] == 2 * 8 * 24 and res["budgets"]["a2c_cpg"]["2"]["gpu"] == "cpu"
    # Table 3: the fixed CPG and both methods, deterministic with the sampled action beside, and the sampled table
    for actions in ("deterministic", "sampled"):
        assert set(res["table3"][actions]["flat"]) >= {"cpg_rl", "a2c_cpg"}
    row = res["table3"]["deterministic"]["flat"]["a2c_cpg"]
    assert row["seeds"] == [1, 2] and row["rounds"] == [2]
    assert {"fall_rate", "pitch_var_deg2", "roll_var_deg2", "pitch_p999_deg", "roll_p999_deg"} <= set(row)
    assert "| falls | falls before the goal | pitch var [deg²] |" in report
    assert "| \\|pitch\\| p99.9 [deg] | \\|roll\\| p99.9 [deg] | 3 m sampled | falls sampled |" in report
    assert "| flat | fixed CPG (10 ms frame) | 1 | 2 |" in report and "| flat | A2C-CPG | 2 | 2 |" in report
    # the verdict: each claim worded by its numbers, every number read from results.json
    assert {v["verdict"] for v in res["verdict"]} <= {"holds", "holds in part", "does not hold"}
    assert {v["claim"].split(" (")[0] for v in res["verdict"]} >= {
        "CPG_RL converges faster than SAC-CPG on skrl's untuned `scale` preset and A2C-CPG on CPG_RL's PPO settings, "
        "untuned for A2C", "CPG_RL completes every task: 100 % at every distance on every terrain"}  # fmt: skip
    assert "## Tuned and preset" in report.split("## Verdict")[0]
    section = report.split("## Verdict")[1].split("\n## ")[0]
    assert section.count("\n- **") == len(res["verdict"])
    assert_numbers_from(section, res)
    # the methods never run are what is missing; a second --add of the same lease adds nothing
    assert "(partial)" in report and "runs sac_cpg_s1, sac_cpg_s2" in report and "runs paper_s1" in report
    assert run(main, "compare", argv) == 0
    assert "0 runs (none), 0 evaluations" in capsys.readouterr().out
    # a stored policy is still what evaluate loads
    ck = next(p for p in stored if "a2c_cpg" in str(p))
    assert torch.load(ck, weights_only=True)["algo"] == "a2c"


def leaves(obj) -> list[float]:
    """Every number in a JSON document."""
    if isinstance(obj, dict):
        return [x for v in obj.values() for x in leaves(v)]
    if isinstance(obj, list):
        return [x for v in obj for x in leaves(v)]
    return [float(obj)] if isinstance(obj, (int, float)) and not isinstance(obj, bool) else []


def assert_numbers_from(text: str, res: dict) -> None:
    """Every number of ``text`` (but the references Fig. 5a, Table 3, §3.3) is a number of ``res`` as the verdict
    writes it: a rate in percent, env-steps in millions, or the value itself, at the text's decimals."""
    import math
    import re

    values = [v for v in leaves(res) if math.isfinite(v)]
    text = re.sub(r"Fig\. 5a|Table 3|§3\.3", "", text)
    tokens = re.findall(r"(?<![\w.])\d+(?:\.\d+)?", text)
    assert tokens
    for tok in tokens:
        d = len(tok.split(".")[1]) if "." in tok else 0
        forms = {f"{k * v:.{d}f}" for v in values for k in (100.0, 1e-6, 1.0)}
        assert tok in forms, f"{tok} in the verdict is no number of results.json"


def test_the_verdict_check_finds_a_number_not_in_results():
    with pytest.raises(AssertionError, match="12.5 in the verdict"):
        assert_numbers_from("- **claim: holds.** 96.0 % and 12.5 deg²", {"a": 0.96, "b": [12.4]})
    assert_numbers_from("- **claim (Fig. 5a): holds.** 96.0 % at 3.6 M env-steps, 12.4 deg²", {"a": [0.96, 3.6e6, 12.4]})


def test_crossings_first_sustained_and_the_dip():
    from hexnewton.analysis.curves import crossings

    xs = [0, 1, 2, 3, 4, 5, 6, 7, 8]
    ys = [0.0, 0.95, 0.2, 0.5, 0.92, 0.93, 0.94, 0.96, 0.97]
    got = crossings(xs, ys, 0.9, 2.0)
    assert got == {"first": 1.0, "sustained": 4.0, "dip_after_first": {"value": 0.2, "at": 2.0}}
    assert crossings(xs, ys, 0.99, 2.0) == {"first": None, "sustained": None, "dip_after_first": None}
    # above the level to the end, but for less than the window: a first crossing, no sustained one
    assert crossings(xs, ys, 0.965, 2.0)["sustained"] is None and crossings(xs, ys, 0.965, 2.0)["first"] == 8.0


def test_a_cut_short_run_is_left_out_of_the_means():

    budgets = {"sac_cpg": {1: {"env_steps": 60_000_000, "wall_min": 11.9}, 2: {"env_steps": 35_400_000, "wall_min": 20.0}},
               "paper": {1: {"env_steps": 9_100_000, "wall_min": 20.2}}}  # fmt: skip
    out = cut_short(budgets)
    assert list(out) == ["sac_cpg_s2"] and "35.4 M env-steps after 20.0 min" in out["sac_cpg_s2"]
    evals = {"deterministic": {"rugged": {"sac_cpg": {1: {"x": 1}, 2: {"x": 2}}}}}
    kept, left = without(evals, out)
    assert kept["deterministic"]["rugged"]["sac_cpg"] == {1: {"x": 1}}
    assert left["deterministic"]["rugged"]["sac_cpg"] == {2: {"x": 2}}


def test_compare_arguments_give_one_line(tmp_path, capsys):

    for argv, msg in ((["--study", str(tmp_path), "--out", str(tmp_path / "x")], "--study replaces"),
                      (["--runs", str(tmp_path)], "give --study DIR, or --runs and --out"),
                      (["--study", str(tmp_path), "--add", str(tmp_path / "nope")], "not a folder"),
                      (["--runs", str(tmp_path), "--add", str(tmp_path), "--out", str(tmp_path / "o")], "--add needs")):
        assert run(main, "compare", argv) == 2
        err = capsys.readouterr().err
        assert msg in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def _events(run, points, config):
    from torch.utils.tensorboard import SummaryWriter

    run.mkdir(parents=True)
    (run / "config.json").write_text(json.dumps(config))
    w = SummaryWriter(str(run))
    for step, reward, success in points:
        w.add_scalar("Train/mean_reward", reward, step)
        w.add_scalar("Episode/success_rate", success, step)
    w.close()


def test_fig5a_and_table3_over_seeds(tmp_path, capsys):
    """The comparison on synthetic runs: a PPO run (iterations) and two skrl runs (env-steps) become one band per
    method; two seeds' evaluations one Table 3 row with their mean and range."""
    ppo = {"hexnewton": {"config": {"sim": {"num_envs": 8}}}, "train": {"num_steps_per_env": 24}}
    _events(tmp_path / "runs" / "cpg_rl_s1" / "r", [(0, 1.0, 0.0), (1, 2.0, 0.5), (2, 3.0, 1.0)], ppo)
    for seed, top in ((1, 0.4), (2, 0.6)):
        _events(tmp_path / "runs" / f"sac_cpg_s{seed}" / "r", [(192, 0.0, 0.0), (576, 1.0, top)],
                {"hexnewton": {"algo": "sac"}})
        ev = tmp_path / "evals" / f"sac_cpg_s{seed}_complex"
        ev.mkdir(parents=True)
        summary = {"rounds": 4, "success_0.5m": top, "success_3m": top / 2, "fall_rate": 0.25}
        (ev / "results.json").write_text(json.dumps({"meta": {"distances": [0.5, 3]},
                                                     "results": {"complex": {"sac_cpg": summary}}}))
    out = tmp_path / "report"
    assert main(["--runs", str(tmp_path / "runs"), "--evals", str(tmp_path / "evals"), "--out", str(out)]) == 0
    report = (out / "report.md").read_text()
    assert "| complex | SAC-CPG | 2 | 4 | 50.0% (40-60) | 25.0% (20-30) | 25.0% (25-25) | — | — | — | — | — |" in report
    res = json.loads((out / "results.json").read_text())
    assert res["budgets"]["cpg_rl"]["1"]["env_steps"] == 3 * 8 * 24 and res["budgets"]["sac_cpg"]["2"]["env_steps"] == 576
    ends = [seed["end"]["value"] for seed in res["fig5a"]["success"]["sac_cpg"]["per_seed"]]
    assert ends == pytest.approx([0.4, 0.6])
    # runs with no recorded GPU (no .done beside them) share one wall-time figure
    assert (out / "fig5a_env_steps.png").stat().st_size > 10000
    assert (out / "fig5a_wall_time_unrecorded.png").stat().st_size > 10000


def test_the_kept_report_is_what_its_results_write(tmp_path):
    """The study's report.md and verdict are what ``--from_results`` writes from its results.json, every number of the
    verdict is one of results.json, and a claim about a baseline on settings not chosen for it names them."""
    import os
    import shutil

    from verdict import ON

    here = os.path.dirname(os.path.abspath(__file__))
    study = tmp_path / "study"
    study.mkdir()
    for name in os.listdir(here):
        if name in ("results.json", "discussion.md") or name.startswith("fig5a_") and name.endswith(".png"):
            shutil.copy(os.path.join(here, name), study / name)
    assert main(["--study", str(study), "--from_results"]) == 0
    with open(os.path.join(here, "report.md")) as f:
        assert (study / "report.md").read_text() == f.read()
    with open(os.path.join(here, "results.json")) as f:
        assert json.loads((study / "results.json").read_text()) == json.load(f)
    res = json.loads((study / "results.json").read_text())
    report = (study / "report.md").read_text()
    assert_numbers_from(report.split("## Verdict")[1].split("\n## ")[0], res)
    named = 0
    for v in res["verdict"]:
        for method, name in (("sac_cpg", "SAC-CPG"), ("td3_cpg", "TD3-CPG"), ("a2c_cpg", "A2C-CPG")):
            if name in v["claim"]:
                assert ON[method] in v["claim"], (method, v["claim"])
                named += 1
    assert named >= 5


def test_a_study_without_its_runs_events_refuses_a_full_report(tmp_path):
    run_dir = tmp_path / "runs" / "cpg_rl_s1" / "r"
    run_dir.mkdir(parents=True)
    (run_dir / "config.json").write_text("{}")
    with pytest.raises(ValueError, match="without TensorBoard events .* --from_results"):
        main(["--runs", str(tmp_path / "runs"), "--out", str(tmp_path / "out")])
    with pytest.raises(ValueError, match="--from_results takes --study DIR alone"):
        main(["--from_results", "--runs", str(tmp_path / "runs")])
