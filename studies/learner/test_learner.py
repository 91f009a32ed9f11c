"""The learner study's build: the report and results.json regenerate from the kept runs, the log parser reads
train.py's validation block, the choice names only changes that paid, and the gate's lines read the test rounds."""

import json
import os
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)
sys.path.insert(0, os.path.dirname(__file__))
import build  # noqa: E402

LOG = """training task complex: 4096 envs on cuda:0, 300 iterations, logs in /root/runs/x_s1/2026-01-01_00-00-00
start-up 40.0 s from process start: python and imports 17.4
finished at iteration 299 after 150 s (300 iterations)
deterministic validation, 256 rounds of the rugged, stepped and complex courses (seed 3000) per candidate, 40 s (x):
     model_200.pt (saved, iteration 200): goal 83.9 %, fell before the goal 0.9 % (in all 8.7 %), 3 m 95.1 %, off course 3.3 %, pitch / roll var 35.4 / 12.4 deg²
  -> model_250.pt (saved, iteration 250): goal 92.3 %, fell before the goal 0.4 % (in all 0.9 %), 3 m 94.9 %, off course 0.8 %, pitch / roll var 26.2 / 9.3 deg²
230 s from process start to the exported result
"""


def test_parse_log_reads_the_validation_block():
    info = build.parse_log(LOG)
    assert [c["file"] for c in info["candidates"]] == ["model_200.pt", "model_250.pt"]
    assert [c["chosen"] for c in info["candidates"]] == [False, True]
    assert info["candidates"][1]["goal"] == pytest.approx(0.923) and info["candidates"][1]["pitch_var"] == 26.2
    assert (info["train_s"], info["iterations"], info["wall_s"], info["startup_s"]) == (150.0, 300, 230.0, 40.0)
    assert info["validation_rounds"] == 256 and info["run_dir"].endswith("2026-01-01_00-00-00")


def test_the_report_regenerates_from_the_kept_runs(tmp_path):
    kept = json.load(open(os.path.join(build.HERE, "results.json")))
    if build.raw_missing():  # the raw runs left the tree: the committed results.json renders report.md
        res = kept
        assert build.main([]) == 2  # build.py says what is missing, writes nothing
        assert json.load(open(os.path.join(build.HERE, "results.json"))) == kept
    else:
        res = build.collect()
        assert res == kept, "results.json is stale: python studies/learner/build.py"
    assert open(os.path.join(build.HERE, "report.md")).read() == build.report(res)
    for name, r in res["runs"].items():
        chosen = [c for c in r["validation"]["candidates"] if c["chosen"]]
        assert len(chosen) == 1 and chosen[0]["file"] == r["validation"]["chosen"], name


def test_a_change_pays_only_with_more_goals_and_no_more_falls():
    base = {"mean_chosen_goal": 0.94, "mean_chosen_fell_before_goal": 0.008}
    assert build.pays({"mean_chosen_goal": 0.95, "mean_chosen_fell_before_goal": 0.008}, base)
    assert not build.pays({"mean_chosen_goal": 0.95, "mean_chosen_fell_before_goal": 0.01}, base)
    assert not build.pays({"mean_chosen_goal": 0.92, "mean_chosen_fell_before_goal": 0.0}, base)
    # the study's own arms: from the kept logs where the tree holds them, else from the committed results.json
    arms, paid = build.summarise(build.kept_runs()), build.paid_arms([])
    with open(os.path.join(build.HERE, "results.json")) as f:
        assert arms == json.load(f)["arms"]
    assert all(build.pays(arms[a], arms["recipe"]) and build.complete(arms[a], arms["recipe"]) for a in paid)
    assert build.choose([]) == build.arms_flags(paid)


def test_the_choice_reads_the_committed_runs_without_the_raw_ones(tmp_path, monkeypatch):
    """kept_runs: the runs parsed from runs/NAME/train.log while every kept run has its log; with none in the tree
    the committed results.json's runs, so --choose and --gate-name still judge the study; a lease's runs
    (--runs DIR) join them, and a study without recipe runs has nothing to compare with."""
    (tmp_path / "runs" / "recipe_s1").mkdir(parents=True)
    (tmp_path / "runs" / "recipe_s1" / "config.json").write_text("{}")   # the raw log gone, its config kept
    kept = {"runs": {"recipe_s1": {"arm": "recipe", "seed": 1, "validation": {"candidates": [
        {"file": "model_250.pt", "goal": 0.9, "fell_before_goal": 0.004, "chosen": True}], "goal_spread": 0.0}}}}
    (tmp_path / "results.json").write_text(json.dumps(kept))
    monkeypatch.setattr(build, "HERE", str(tmp_path))
    assert build.raw_missing() and build.kept_runs() == kept["runs"]
    lease = tmp_path / "lease"
    lease.mkdir()
    (lease / "settle_s1.log").write_text(LOG)   # goal 92.3 %, falls 0.4 %: more goals, no more falls
    (lease / "critic_s1.log").write_text(LOG.replace("goal 92.3 %, fell before the goal 0.4 %",
                                                     "goal 92.3 %, fell before the goal 0.5 %"))
    assert build.paid_arms([str(lease)]) == ["settle"]
    assert build.main(["--gate-name", "--runs", str(lease)]) == 0
    (tmp_path / "runs" / "recipe_s1" / "train.log").write_text(LOG.replace("goal 92.3 %", "goal 99.0 %"))
    assert not build.raw_missing() and build.kept_runs()["recipe_s1"]["validation"]["chosen"] == "model_250.pt"
    assert build.paid_arms([str(lease)]) == []   # the log's recipe (99 %) now, not results.json's
    (tmp_path / "results.json").write_text(json.dumps({"runs": {}}))
    (tmp_path / "runs" / "recipe_s1" / "train.log").unlink()
    with pytest.raises(ValueError, match="no recipe runs"):
        build.paid_arms([str(lease)])
    assert build.main(["--choose"]) == 2


def test_arms_that_paid_give_each_flag_once(monkeypatch):
    monkeypatch.setattr(build, "pays", lambda arm, recipe: True)   # critic, actor and both: their flags overlap
    monkeypatch.setattr(build, "ARM_FLAGS", {a: build.ARM_FLAGS[a] for a in ("recipe", "critic", "actor", "both")})
    assert build.choose([]) == "--env.obs.critic true --env.obs.gyro true --env.obs.last_action true"


def test_an_arm_on_fewer_seeds_than_the_recipe_leads_but_is_not_chosen(monkeypatch):
    recipe = {"seeds": [1, 2], "mean_chosen_goal": 0.94, "mean_chosen_fell_before_goal": 0.008, "goal_spread": [0, 0]}
    long = {"seeds": [1], "mean_chosen_goal": 0.95, "mean_chosen_fell_before_goal": 0.003, "goal_spread": [0]}
    assert build.pays(long, recipe) and not build.complete(long, recipe)
    monkeypatch.setattr(build, "summarise", lambda runs: {"recipe": recipe, "long": long})
    assert build.choose([]) == ""
    res = {"runs": {}, "arms": {"recipe": recipe, "long": long}, "gates": {}, "choice_noise": build.choice_noise({})}
    line = next(v for v in build.verdict(res) if "`long`" in v)
    assert "**`long` leads on validation** (seeds 1; partial, the recipe ran on 2)" in line


def test_the_gate_lines_read_the_test_rounds():
    def per(s, f, pv=10.0):
        return {t: {"success_3m": s, "fall_rate_before_goal": f, "pitch_var_deg2": pv, "roll_var_deg2": pv}
                for t in build.TERRAINS}

    runs = {f"gate_s{k}": {"arm": "gate", "seed": k, "wall_s": 230.0, "result_on_test": per(0.98, 0.0)}
            for k in (1, 2, 3)}
    test = {"shipped": per(0.979, 0.0), "fixed_cpg": per(0.4, 0.03, pv=30.0)}
    assert build.gate(runs, test)["holds"]
    runs["gate_s2"]["result_on_test"]["rugged"]["fall_rate_before_goal"] = 0.006
    g = build.gate(runs, test)
    assert g["holds"] is False and [k for k, v in g["lines"].items() if v is False] == [
        "falls before the goal <= 0.5 %, rugged"]
    # a terrain not yet evaluated leaves its lines unmeasured, not failed
    for r in runs.values():
        r["result_on_test"] = {"stepped": per(0.98, 0.0)["stepped"]}
    g = build.gate(runs, test)
    assert g["holds"] is None and g["lines"]["every seed >= 97.5 % at 3 m, stepped"] is True
    assert g["lines"]["every seed >= 97.5 % at 3 m, rugged"] is None
    assert build.gate({}, test) is None


def test_each_gate_is_named_by_its_arms_and_judged_on_its_own_runs(capsys):
    assert build.gate_name([]) == "gate" and build.gate_name(["settle", "critic"]) == "gate_settle-critic"
    assert build.gate_arms("gate_settle-critic") == ["settle", "critic"] and build.gate_arms("gate") == []
    with pytest.raises(ValueError):
        build.gate_arms("gate_nope")
    assert build.main(["--gate-name"]) == 0
    assert capsys.readouterr().out.strip() == build.gate_name(build.paid_arms([]))

    def per(s):
        return {t: {"success_3m": s, "fall_rate_before_goal": 0.0, "pitch_var_deg2": 10.0, "roll_var_deg2": 10.0}
                for t in build.TERRAINS}

    runs = {f"{stem}_s{k}": {"arm": stem, "seed": k, "wall_s": 230.0, "result_on_test": per(s)}
            for stem, s in (("gate", 0.9), ("gate_settle", 0.99)) for k in (1, 2, 3)}
    runs["settle_s1"] = {"arm": "settle", "seed": 1, "wall_s": 230.0, "result_on_test": per(0.5)}
    ref = {"shipped": per(0.98), "fixed_cpg": {t: {**per(0.4)[t], "pitch_var_deg2": 30.0, "roll_var_deg2": 30.0}
                                               for t in build.TERRAINS}}
    g = build.gates(runs, {"gate": ref, "gate_settle": ref})
    assert list(g) == ["gate", "gate_settle"] and g["gate"]["holds"] is False and g["gate_settle"]["holds"]
    # each gate against the references of its own lease: the shipped policy better there, the median line fails;
    # none measured, the lines against them are not measured
    median = "median >= the shipped policy's, rugged"
    other = build.gates(runs, {"gate": ref, "gate_settle": {**ref, "shipped": per(0.995)}})["gate_settle"]
    assert other["holds"] is False and other["lines"][median] is False
    other = build.gates(runs, {"gate": ref})["gate_settle"]
    assert other["holds"] is None and other["lines"][median] is None
    assert g["gate_settle"]["flags"] == build.ARM_FLAGS["settle"] and g["gate"]["flags"] == ""
    res = {"runs": {}, "arms": {}, "gates": g, "choice_noise": build.choice_noise({})}
    line = next(v for v in build.verdict(res) if "`settle`" in v)
    assert line.startswith("- **The gate with `settle` holds** (seeds 1, 2, 3)")


def test_the_choice_noise_compares_the_chosen_candidate_before_and_after():
    def run(before, after, chosen=1):
        cands = [{"chosen": i == chosen} for i in range(2)]
        per = {"rugged": [{"rounds": 256, "fell_before_goal": before if i == chosen else 0.5} for i in range(2)]}
        return {"validation": {"per_course": per, "candidates": cands},
                "result_on_validation": {"rugged": {"rounds": 500, "fall_rate_before_goal": after}}}

    runs = {"a_s1": run(0.0, 0.02), "a_s2": run(0.01, 0.004), "b_s1": run(0.0, 0.0, chosen=0)}
    runs["c_s1"] = {"validation": {"per_course": None, "candidates": []}, "result_on_validation": {}}   # no per course
    n = build.choice_noise(runs)
    assert set(n["runs"]) == {"a_s1", "a_s2", "b_s1"} and n["higher_when_evaluated"] == 1
    assert n["runs"]["b_s1"]["chosen_on"]["fell_before_goal"] == 0.0   # the chosen one's share, not the other's
    assert n["mean_chosen_on"] == pytest.approx(0.0033, abs=1e-4) and n["mean_evaluated"] == pytest.approx(0.008)
    assert build.choice_noise({})["mean_evaluated"] is None


def test_an_empty_arms_list_trains_nothing():
    """``ARMS= ... learner.sh`` (a gate or test rounds alone) must not fall back to the default arm."""
    with open(os.path.join(build.HERE, "..", "device", "learner.sh")) as f:
        queue = f.read()
    assert "ARMS=${ARMS-actor}" in queue and "ARMS=${ARMS:-" not in queue


FAKE_PYTHON = """#!/bin/bash
case "$1" in
  train.py) echo "train ${*:2}" >> "$CALLS"; mkdir -p "$RUNS";;
  -m) echo "$2 ${*:3}" >> "$CALLS";;
  *) exec python3 "$@";;
esac
"""


def test_the_queue_runs_the_gate_alone_then_the_arms_beside_its_test_rounds(tmp_path):
    """learner.sh with ARMS_AFTER_GATE=1: the gate's seeds one after another, then its test rounds and the arms' lanes
    (train.py and evaluate stand-ins log their calls); without GATE=1 it refuses at once."""
    import subprocess

    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "python").write_text(FAKE_PYTHON)
    (bin_dir / "python").chmod(0o755)
    calls = tmp_path / "calls"
    env = {**os.environ, "PATH": f"{bin_dir}:{os.environ['PATH']}", "CALLS": str(calls), "LANE_GAP": "0",
           **{k: str(tmp_path / k.lower()) for k in ("EVALS", "QUEUE", "RUNS", "KEEP", "RUNS_OUT")}}
    queue = os.path.join(build.HERE, "..", "device", "learner.sh")
    root = os.path.join(build.HERE, "..", "..")
    gate = {"ARMS": "rounds1024", "SEEDS": "1", "KEPT": "", "GATE": "1", "ARMS_AFTER_GATE": "1",
            "GATE_SEEDS": "1 2", "GATE_NAME": "gate_settle", "GATE_FLAGS": build.ARM_FLAGS["settle"]}
    done = subprocess.run(["bash", queue], env={**env, **gate}, cwd=root, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = calls.read_text().splitlines()
    trains = [ln for ln in lines if ln.startswith("train ")]
    assert [t.split("--experiment ")[1] for t in trains] == ["gate_settle_s1", "gate_settle_s2", "rounds1024_s1"]
    assert "--agent.validation_rounds 1024" in trains[2] and "'desired_kl':0.004" in trains[0]
    first_eval = next(i for i, ln in enumerate(lines) if ln.startswith("hexnewton.apps.evaluate"))
    assert lines.index(trains[1]) < first_eval   # the seeds ran before any evaluation
    outs = {ln.split("--out ")[1].split()[0].rsplit("/", 1)[1] for ln in lines if "cpg_rl_complex.pt" in ln}
    assert outs == {f"gate_settle_shipped_{t}" for t in build.TERRAINS}   # the references named by their gate
    refused = subprocess.run(["bash", queue], env={**env, "ARMS_AFTER_GATE": "1"}, cwd=root, capture_output=True,
                             text=True, timeout=60)
    assert refused.returncode == 2 and "needs GATE=1" in refused.stderr


def test_the_average_candidate_is_parsed_and_left_out_of_the_arms_choice():
    log = LOG.replace("230 s from", "  model_average.pt (average of iterations 200, 250, iteration 250): goal 99.0 %, "
                      "fell before the goal 0.0 % (in all 0.0 %), 3 m 99.0 %, off course 0.0 %, pitch / roll var "
                      "20.0 / 8.0 deg²\n230 s from")
    cands = build.parse_log(log)["candidates"]
    assert [c["file"] for c in cands][-1] == "model_average.pt" and cands[-1]["kind"].startswith("average of")
    assert build.plain_choice(cands)["file"] == "model_250.pt"


def test_the_long_arm_is_the_shipped_schedule():
    """The long arm's flags, as train.py's parser reads them, are the tasks' 1062-iteration schedule."""
    from hexnewton.apps.cli import ArgumentParser, add_config_args
    from hexnewton.tasks import LONG_STABLE_ITERATIONS, LONG_STABLE_STAGES, TASKS

    p = ArgumentParser(prog="train.py")
    add_config_args(p, "agent", TASKS["complex"].agent)
    p.add_argument("--max_iterations", type=int)
    args = vars(p.parse_args(build.ARM_FLAGS["long"].split()))
    assert args["override:agent:stages"] == LONG_STABLE_STAGES and args["max_iterations"] == LONG_STABLE_ITERATIONS


def test_the_settle_and_candidates_arms_parse_as_train_py_reads_them():
    """settle: the recipe's stages with the last one's PPO steps smaller; candidates: denser saves, more candidates."""
    from hexnewton.apps.cli import ArgumentParser, add_config_args, config_overrides
    from hexnewton.config import apply_overrides
    from hexnewton.tasks import STABLE_STAGES, TASKS

    base = TASKS["complex"].agent
    p = ArgumentParser(prog="train.py")
    add_config_args(p, "agent", base)
    settle = apply_overrides(base, config_overrides(p.parse_args(build.ARM_FLAGS["settle"].split()), "agent"))
    settle.check()
    (s1, c1), (s2, c2) = settle.stages
    assert (s1, c1) == STABLE_STAGES[0] and s2 == STABLE_STAGES[1][0]
    assert c2 == {**STABLE_STAGES[1][1], "desired_kl": 0.004, "entropy_coef": 0.0}
    more = apply_overrides(base, config_overrides(p.parse_args(build.ARM_FLAGS["candidates"].split()), "agent"))
    more.check()
    assert (more.save_interval, more.validation_candidates, more.stages) == (10, 8, base.stages)
    sharp = apply_overrides(base, config_overrides(p.parse_args(build.ARM_FLAGS["rounds1024"].split()), "agent"))
    sharp.check()
    assert (sharp.validation_rounds, base.validation_rounds, sharp.stages) == (1024, 256, base.stages)


def test_the_falls_line_counts_the_results_at_or_below_it():
    """falls_line: per course, the results on the validation rounds that fall before the goal in at most the gate's
    share, and the shipped policy's shares beside them; the verdict says it where at most half meet it."""
    v = lambda rate: {"fall_rate_before_goal": rate, "rounds": 500}  # noqa: E731
    runs = {"a_s1": {"result_on_validation": {"rugged": v(0.0), "complex": v(0.0)}},
            "a_s2": {"result_on_validation": {"rugged": v(0.012), "complex": v(0.005)}},
            "b_s1": {"result_on_validation": {"rugged": v(0.006)}}}
    fixed = {"validation": {"shipped": {"rugged": v(0.002)}}, "test": {"gate": {"shipped": {"rugged": v(0.005)}}}}
    fl = build.falls_line(runs, fixed)
    assert fl["line"] == 0.005
    assert fl["courses"]["rugged"] == {"results": 3, "met": ["a_s1"], "share_met": 0.3333,
                                       "shipped_validation": 0.002, "shipped_test": 0.005}
    assert fl["courses"]["complex"]["met"] == ["a_s1", "a_s2"] and fl["courses"]["stepped"]["results"] == 0
    res = {"runs": {}, "arms": {}, "gates": {}, "falls_line": fl, "choice_noise": {"runs": {}}}
    lines = [x for x in build.verdict(res) if "falls line" in x]
    assert len(lines) == 1 and "on the rugged course is rarely met**: 1 of 3 results" in lines[0]
    assert "3.70 % of gates" in lines[0]


def test_one_seed_s_lines_on_the_validation_rounds():
    """seed_lines: the results evaluated on every course that meet the gate's success line on all of them, its falls
    line on all of them, and both; a result missing a course is left out."""
    v = lambda ok3, falls: {"success_3m": 0.98 if ok3 else 0.97, "fall_rate_before_goal": falls}  # noqa: E731
    runs = {"a_s1": {"result_on_validation": {t: v(True, 0.0) for t in build.TERRAINS}},
            "b_s1": {"result_on_validation": {t: v(t != "rugged", 0.004) for t in build.TERRAINS}},
            "c_s1": {"result_on_validation": {t: v(True, 0.006 if t == "rugged" else 0.0) for t in build.TERRAINS}},
            "d_s1": {"result_on_validation": {"rugged": v(True, 0.0)}}}
    sl = build.seed_lines(runs)
    assert sl == {"results": 3, "success": ["a_s1", "c_s1"], "falls": ["a_s1", "b_s1"], "both": ["a_s1"]}
    res = {"runs": {}, "arms": {}, "gates": {}, "seed_lines": sl, "choice_noise": {"runs": {}}}
    (line,) = [x for x in build.verdict(res) if "One seed's lines" in x]
    assert "of 3 results, 2 reach 3 m" in line and "1 do both (a_s1)" in line


def test_the_tf32_gate_queue_trains_its_seeds_then_tests_the_kept_one(tmp_path):
    """gate_tf32.sh: learner.sh (a stand-in logging its environment) once for the gate's seeds 2 and 3 with the tf32
    arm's flags, then once for the kept seed's test rounds; TEST_KEPT= leaves the second out."""
    import subprocess

    fake = tmp_path / "learner.sh"
    fake.write_text('echo "ARMS=[$ARMS] GATE=${GATE:-} SEEDS=${GATE_SEEDS:-} NAME=${GATE_NAME:-} '
                    'FLAGS=${GATE_FLAGS:-} TEST_KEPT=${TEST_KEPT:-}" >> "$CALLS"\n')
    calls = tmp_path / "calls"
    env = {**os.environ, "LEARNER": str(fake), "CALLS": str(calls)}
    queue = os.path.join(build.HERE, "gate_tf32.sh")
    done = subprocess.run(["bash", queue], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stdout + done.stderr
    assert calls.read_text().splitlines() == [
        "ARMS=[] GATE=1 SEEDS=2 3 NAME=gate_tf32 FLAGS=--agent.tf32 true TEST_KEPT=",
        "ARMS=[] GATE=0 SEEDS= NAME= FLAGS= TEST_KEPT=gate_tf32_s1"]
    calls.unlink()
    done = subprocess.run(["bash", queue], env={**env, "TEST_KEPT": ""}, capture_output=True, text=True, timeout=60)
    assert done.returncode == 0 and len(calls.read_text().splitlines()) == 1


def test_a_gate_is_set_beside_the_recipes_lines_and_falls():
    """against_recipe: which of the recipe's failing lines a gate fails too and which others, and both gates' seeds'
    falls on the rugged course."""
    def run(arm, seed, falls, before):
        return {"arm": arm, "seed": seed, "result_on_test": {"rugged": {"fall_rate": falls,
                                                                        "fall_rate_before_goal": before}}}

    runs = {"gate_s2": run("gate", 2, 0.02, 0.01), "gate_s1": run("gate", 1, 0.01, 0.0),
            "gate_tf32_s1": run("gate_tf32", 1, 0.05, 0.03)}
    recipe = {"arms": [], "lines": {"a": False, "b": False, "c": True}}
    g = {"arms": ["tf32"], "lines": {"a": False, "b": True, "c": False}}
    line = build.against_recipe(runs, "gate_tf32", g, recipe)
    assert line.startswith("- **The gate with `tf32` against the recipe's**: 1 of the recipe's 2 failing lines fail, "
                           "1 other (c); on the rugged course its seeds fall in 5.0 % of the test rounds against "
                           "1.0 / 2.0 % (before the goal 3.0 % against 0.0 / 1.0 %)")
    assert "no other" in build.against_recipe(runs, "gate_tf32", {**g, "lines": {"a": False}}, recipe)
