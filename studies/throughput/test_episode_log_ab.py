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
