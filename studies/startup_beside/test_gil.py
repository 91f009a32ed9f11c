"""studies/startup_beside/gil.py: its report is the rendering of its raw measurement; one clear line for a missing
folder; the queue's call; a short measurement (the flat task's model: no terrain mesh)."""

import json
import os
import subprocess
import sys

import pytest

import gil as study  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def test_the_committed_report_renders_the_raw_measurement(tmp_path):
    kept = os.path.join(HERE, "gil")
    (tmp_path / "raw.json").write_text(open(os.path.join(kept, "raw.json")).read())
    assert study.main(["--rebuild", str(tmp_path)]) == 0
    for name in ("report.md", "results.json"):
        assert (tmp_path / name).read_text() == open(os.path.join(kept, name)).read(), name
    res = json.loads((tmp_path / "results.json").read_text())
    assert res["finalize_beside_s"] > res["finalize_alone_s"] > 0 and res["imports_alone_s"] > 0


def test_a_missing_folder_is_one_line_and_exit_2(tmp_path):
    done = subprocess.run([sys.executable, os.path.join(HERE, "gil.py"), "--rebuild", str(tmp_path)],
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 2 and done.stderr.strip().count("\n") == 0 and "raw.json" in done.stderr


def test_the_queue_runs_it_once_on_cuda_with_the_revision(tmp_path):
    """The queue passes HEXNEWTON_GIT_REV on: where a device call's tree has no git history,
    ``hexnewton.analysis.report.git_rev`` reads the commit from it."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "python").write_text('#!/bin/bash\necho "$* $HEXNEWTON_GIT_REV" >> "$TP/calls"\n')
    (bin_dir / "python").chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", TP=str(tmp_path), STEPS="preload gil",
               HEXNEWTON_GIT_REV="abc1234")  # fmt: skip
    done = subprocess.run(["bash", "studies/startup_beside/queue.sh"], cwd=ROOT, env=env, capture_output=True,
                          text=True)  # fmt: skip
    assert done.returncode == 0 and done.stdout.rstrip().endswith("done"), done.stdout + done.stderr
    assert (tmp_path / "calls").read_text().splitlines() == [
        f"studies/startup_beside/preload.py --runs 2 --warmup 1 --device cuda --out {tmp_path}/preload abc1234",
        f"studies/startup_beside/gil.py --device cuda --out {tmp_path}/gil abc1234"]


def test_a_short_measurement_on_the_cpu(tmp_path):
    from hexnewton.analysis.report import git_rev

    assert study.main(["--out", str(tmp_path), "--task", "flat", "--num_envs", "8"]) == 0
    raw = json.loads((tmp_path / "raw.json").read_text())
    assert raw["task"] == "flat" and raw["revision"] == git_rev() and list(raw["imports_alone"]["modules_s"]) == \
        list(study.IMPORTS)  # fmt: skip
    assert "| the finalize alone [s] |" in (tmp_path / "report.md").read_text()
