"""studies/throughput/episode_log_ab.sh with a stand-in python: the bench alternates rsl-rl's per-step episode
bookkeeping and the deferred one (off, on, off, on), each call with its own json, markdown and log."""

import os
import subprocess

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))


def test_the_queue_alternates_the_bookkeeping(tmp_path):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "python").write_text('#!/bin/bash\necho "$*" >> "$TP/calls"\n')
    (bin_dir / "python").chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", TP=str(tmp_path))
    root = os.path.dirname(os.path.dirname(HERE))
    done = subprocess.run(["bash", "studies/throughput/episode_log_ab.sh"], cwd=root, env=env, capture_output=True,
                          text=True)  # fmt: skip
    assert done.returncode == 0 and done.stdout.rstrip().endswith("done"), done.stdout + done.stderr
    calls = (tmp_path / "calls").read_text().splitlines()
    assert [c.split("--agent.deferred_episode_log ")[1].split()[0] for c in calls] == ["false", "true"] * 2
    assert all("--task complex --num_envs 4096 16384 --mode sim env train" in c for c in calls)
    assert [c.split("--json ")[1].split()[0].rsplit("/", 1)[1] for c in calls] == [
        "off_1.json", "on_1.json", "off_2.json", "on_2.json"]
    assert sorted(p.name for p in (tmp_path / "episode_log").glob("*.log")) == [
        "off_1.log", "off_2.log", "on_1.log", "on_2.log"]


def _study():
    import importlib.util

    spec = importlib.util.spec_from_file_location("episode_log", os.path.join(HERE, "episode_log.py"))
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


def test_the_committed_report_renders_the_raw_calls():
    """report.md and results.json are what episode_log.py makes of episode_log/raw/ (a call that left only its log
    makes the lease partial)."""
    import json

    study = _study()
    res = study.load()
    with open(os.path.join(study.HERE, "results.json")) as f:
        assert json.load(f) == json.loads(json.dumps(res))
    with open(os.path.join(study.HERE, "report.md")) as f:
        assert f.read() == study.render(res)
    lease = res["leases"][0]
    assert lease["unfinished"] == ["on_2"] and "**Partial**" in study.render(res)
