"""studies/throughput/validation_ab.py: its report and results from a kept raw.json, the queue's call, one clear line
for a missing folder; the measurement itself (a short one on the CPU)."""

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)

import validation_ab  # noqa: E402


def test_the_kept_report_is_what_its_raw_data_gives(tmp_path):
    """studies/throughput/validation/: report.md and results.json rebuilt from raw.json are the committed ones."""
    kept = os.path.join(HERE, "validation")
    for name in ("raw.json",):
        (tmp_path / name).write_text(open(os.path.join(kept, name)).read())
    assert validation_ab.main(["--rebuild", str(tmp_path)]) == 0
    for name in ("report.md", "results.json"):
        assert (tmp_path / name).read_text() == open(os.path.join(kept, name)).read(), name
    res = json.loads((tmp_path / "results.json").read_text())
    one, side = res["modes"]["one_by_one"]["mean_s"], res["modes"]["side_by_side"]["mean_s"]
    assert res["saved_s"] == pytest.approx(one - side) and side < one


def test_a_missing_folder_is_one_line_and_exit_2(tmp_path):
    done = subprocess.run([sys.executable, os.path.join(HERE, "validation_ab.py"), "--rebuild", str(tmp_path)],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 2 and done.stderr.strip().count("\n") == 0 and "raw.json" in done.stderr


def test_the_queue_calls_the_study_with_its_revision(tmp_path):
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "python").write_text('#!/bin/bash\necho "$* $HEXNEWTON_GIT_REV" >> "$TP/calls"\n')
    (bin_dir / "python").chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", TP=str(tmp_path), HEXNEWTON_GIT_REV="abc1234")
    done = subprocess.run(["bash", "studies/throughput/validation_ab.sh"], cwd=ROOT, env=env, capture_output=True,
                          text=True)  # fmt: skip
    assert done.returncode == 0 and done.stdout.rstrip().endswith("done"), done.stdout + done.stderr
    assert (tmp_path / "calls").read_text().split() == [
        "studies/throughput/validation_ab.py", "--out", f"{tmp_path}/validation_ab", "--repeats", "1", "abc1234"]


def test_a_short_measurement_on_the_cpu(tmp_path):
    """Both modes, one repeat, 2 candidates of 2 rounds per course, 10 control steps: every course's shares in both."""
    assert validation_ab.main(["--out", str(tmp_path), "--device", "cpu", "--candidates", "2", "--rounds", "2",
                               "--steps", "10", "--repeats", "1"]) == 0  # fmt: skip
    raw = json.loads((tmp_path / "raw.json").read_text())
    from hexnewton.analysis.report import git_rev

    assert [r["mode"] for r in raw["runs"]] == ["one_by_one", "side_by_side"] and raw["revision"] == git_rev()
    assert all(sorted(r["courses"]) == ["complex", "rugged", "stepped"] for r in raw["runs"])
    assert "| rugged |" in (tmp_path / "report.md").read_text()
