"""studies/throughput/flag_ab.sh with a stand-in python: the bench alternates a learner switch off and on (off, on, off,
on), each call with its own json, markdown and log; flag_ab.py renders each A/B's report from its raw calls."""

import os
import subprocess

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))


def _queue(tmp_path, ab: str) -> subprocess.CompletedProcess:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    (bin_dir / "python").write_text('#!/bin/bash\necho "$*" >> "$TP/calls"\n')
    (bin_dir / "python").chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", TP=str(tmp_path), AB=ab)
    root = os.path.dirname(os.path.dirname(HERE))
    return subprocess.run(["bash", "studies/throughput/flag_ab.sh"], cwd=root, env=env, capture_output=True, text=True)


@pytest.mark.parametrize("ab, flag, modes", [("episode_log", "--agent.deferred_episode_log", "sim env train"),
                                             ("tf32", "--agent.tf32", "sim train --profile")])
def test_the_queue_alternates_the_switch(tmp_path, ab, flag, modes):
    done = _queue(tmp_path, ab)
    assert done.returncode == 0 and done.stdout.rstrip().endswith("done"), done.stdout + done.stderr
    calls = (tmp_path / "calls").read_text().splitlines()
    assert [c.split(flag + " ")[1].split()[0] for c in calls] == ["false", "true"] * 2
    assert all(f"--task complex --num_envs 4096 16384 --mode {modes} " in c for c in calls)
    assert [c.split("--json ")[1].split()[0].rsplit("/", 1)[1] for c in calls] == [
        "off_1.json", "on_1.json", "off_2.json", "on_2.json"]
    assert sorted(p.name for p in (tmp_path / ab).glob("*.log")) == ["off_1.log", "off_2.log", "on_1.log", "on_2.log"]


def test_an_unknown_ab_is_one_line(tmp_path):
    done = _queue(tmp_path, "moon")
    assert done.returncode == 2 and done.stderr.strip() == "flag_ab.py: no A/B named 'moon': episode_log, tf32"
    assert not (tmp_path / "calls").exists()


def _study():
    import importlib.util

    spec = importlib.util.spec_from_file_location("flag_ab", os.path.join(HERE, "flag_ab.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_effect_is_the_deferred_mean_over_the_per_step_one():
    study = _study()
    row = lambda steps, ratio: {"4096": {"train_steps_per_s": steps, "train_over_sim": ratio}}  # noqa: E731
    calls = {"off": [{"rows": row(100, 0.6)}, {"rows": row(104, 0.62)}], "on": [{"rows": row(113, 0.66)}]}
    e = study.effect(calls)["4096"]
    assert e["off"]["train_steps_per_s"] == 102 and e["off"]["spread"] == 0.04 and e["on"]["calls"] == 1
    assert e["change"] == round(113 / 102 - 1, 4) and e["off"]["train_over_sim"] == 0.61
    assert study.effect({"off": calls["off"], "on": []})["4096"]["change"] is None


def _committed(study, name: str) -> dict:
    """The committed results.json of A/B ``name``, checked against what flag_ab.py makes of NAME/raw/ now: all of it
    where the calls' console logs are in the tree; without them (``git restore --source df27913 --worktree
    -- studies/throughput/NAME/raw`` brings them back) every number from the kept call jsons, and the calls that
    left only a log (``unfinished``, which only the logs tell) as committed. report.md renders it."""
    import json

    with open(os.path.join(HERE, name, "results.json")) as f:
        kept = json.load(f)
    got = json.loads(json.dumps(study.load(name)))
    if study.logs_missing(name):
        assert [le["unfinished"] for le in got["leases"]] == [[] for _ in kept["leases"]]
        for le, k in zip(got["leases"], kept["leases"]):
            le["unfinished"] = k["unfinished"]
    assert got == kept, f"{name}/results.json is stale: python studies/throughput/flag_ab.py {name}"
    with open(os.path.join(HERE, name, "report.md")) as f:
        assert f.read() == study.render(kept)
    return kept


def test_the_committed_report_renders_the_raw_calls():
    """report.md renders the committed results.json, whose numbers are what flag_ab.py makes of episode_log/raw/'s
    calls (a call that left only its log makes the lease partial)."""
    study = _study()
    res = _committed(study, "episode_log")
    lease = res["leases"][0]
    assert lease["unfinished"] == ["on_2"] and "**Partial**" in study.render(res)


def test_without_the_logs_flag_ab_writes_nothing(tmp_path, monkeypatch):
    """A lease whose call jsons lack their console logs: the finished calls still load, but flag_ab.py refuses to
    rewrite the report (an unfinished call, a log alone, cannot be told) and says how to get the logs back."""
    import json
    import sys

    study = _study()
    lease = tmp_path / "episode_log" / "raw" / "2026-01-01"
    lease.mkdir(parents=True)
    (lease / "gpu.txt").write_text("NVIDIA H100, 580\n")
    bench = {"device_name": "NVIDIA H100", "sim": [{"num_envs": 4096, "robot_s_per_s": 1000.0}],
             "pipeline": [{"num_envs": 4096, "env_steps_per_s": 9.0, "train_steps_per_s": 90.0,
                           "train_robot_s_per_s": 600.0, "train_iteration_s": 1.0}]}
    for call in ("off_1", "on_1"):
        (lease / f"{call}.json").write_text(json.dumps(bench))
    (lease / "on_1.log").write_text("exit 0\n")
    monkeypatch.setattr(study, "STUDY", str(tmp_path))
    assert study.logs_missing("episode_log") == os.path.join("episode_log", "raw", "2026-01-01", "off_1.log")
    got = study.load("episode_log")["leases"][0]
    assert [c["call"] for m in study.MODES for c in got["calls"][m]] == ["off_1", "on_1"] and not got["unfinished"]
    monkeypatch.setattr(sys, "argv", ["flag_ab.py", "episode_log"])
    with pytest.raises(SystemExit) as exc:
        study.main()
    assert "git restore --source df27913 --worktree -- studies/throughput/episode_log/raw" in str(exc.value.code)
    assert not (tmp_path / "episode_log" / "results.json").exists()
    (lease / "off_1.log").write_text("exit 0\n")
    assert study.logs_missing("episode_log") == ""


def test_profiled_calls_give_the_phases_per_mode(tmp_path):
    """A profiled A/B (tf32): each call's phases kept per env count, their mean per mode, and the phases' table."""
    import json

    study = _study()
    lease = tmp_path / "2026-01-01"
    lease.mkdir()
    (lease / "gpu.txt").write_text("NVIDIA H200, 580\n")
    for call, update in (("off_1", 0.2), ("on_1", 0.1), ("off_2", 0.22)):
        (lease / f"{call}.log").write_text("exit 0\n")
        (lease / f"{call}.json").write_text(json.dumps({
            "device_name": "NVIDIA H200", "sim": [{"num_envs": 16384, "robot_s_per_s": 14000.0}],
            "pipeline": [{"num_envs": 16384, "env_steps_per_s": float("nan"), "train_steps_per_s": 500000.0,
                          "train_robot_s_per_s": 10000.0, "train_iteration_s": 0.79}],
            "profile": [{"terrain": "complex", "num_envs": 16384, "env.step": 0.57, "PPO update": update}]}))
    got = study.load_lease(str(lease))
    assert got["calls"]["off"][0]["rows"]["16384"]["env_steps_per_s"] is None
    e = got["effect"]["16384"]
    assert e["off"]["phases_s"] == {"env.step": 0.57, "PPO update": 0.21} and e["on"]["phases_s"]["PPO update"] == 0.1
    text = study.render({"ab": "tf32", **study.ABS["tf32"], "leases": [got]})
    assert "| 16384 | off | 570.0 | 210.0 |" in text and "--agent.tf32 true" in text


def test_the_command_pair_gives_times_and_the_chosen_candidate(tmp_path):
    """command/DATE/{off,on}/: the command as run and timing.json with the candidate its validation chose, one row
    each (a validation that names no kept candidate gives none)."""
    import json

    study = _study()
    pair = tmp_path / "2026-01-01"
    cand = {"path": "/r/model_299.pt", "goal": 0.948, "fell_before_goal": 0.001}
    for mode, chosen in (("off", "/r/model_299.pt"), ("on", "/r/model_250.pt")):
        (pair / mode).mkdir(parents=True)
        (pair / mode / "command.txt").write_text(f"python train.py --task complex --seed 1 # {mode}\n")
        (pair / mode / "timing.json").write_text(json.dumps({
            "device_name": "NVIDIA H200", "iterations": 300, "wall_s_to_result": 201.06, "first_iteration_s": 30.14,
            "train_s": 108.88, "validation": {"seconds": 60.71, "chosen": chosen, "candidates": [cand]}}))
    got = study.load_command(str(pair))["modes"]
    assert got["off"]["chosen"] == {"file": "model_299.pt", "goal": 0.948, "fell_before_goal": 0.001}
    assert got["on"]["chosen"] is None and got["on"]["wall_s_to_result"] == 201.1
    text = "\n".join(study._commands({"ab": "tf32", "commands": [{"date": "2026-01-01", "modes": got}]}))
    assert "| 2026-01-01 | `python train.py --task complex --seed 1` | NVIDIA H200 | 201.1 | 30.1 | 108.9 (300) | " \
           "60.7 | model_299.pt: 94.8 %, 0.1 % |" in text


def test_the_committed_tf32_report_renders_its_calls_and_commands():
    study = _study()
    res = _committed(study, "tf32")
    assert [sorted(c["modes"]) for c in res["commands"]] == [["off", "on"]]
