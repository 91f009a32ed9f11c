"""The ROS 2 study (``python studies/ros2/measure.py``): ``--parts`` reruns some parts and keeps the others of
results.json, each part with the command that produced it; a bad part is one error line."""

import json
import os
import shutil
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
MEASURE = os.path.join("studies", "ros2", "measure.py")
STUDY = os.path.join(ROOT, "studies", "ros2")


def test_a_bad_part_is_one_error_line(tmp_path):
    proc = subprocess.run([sys.executable, MEASURE, "--parts", "everything", "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)  # fmt: skip
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "--parts" in lines[0], proc.stderr
    assert not (tmp_path / "o").exists()


def test_parts_rerun_merges_into_the_results_and_the_report_names_each_command(tmp_path):
    """The replay part alone (one recorded round replayed twice, the normal scheduler) into a copy of the study's
    results: the other parts stay as they were, with their own command; the report says which command produced which
    part."""
    pytest.importorskip("rclpy")
    pytest.importorskip("rosbags")
    shutil.copy(os.path.join(STUDY, "results.json"), tmp_path / "results.json")
    old = json.loads((tmp_path / "results.json").read_text())
    env = dict(os.environ, ROS_DOMAIN_ID=str(60 + os.getpid() % 20))
    args = ["--parts", "replay", "--bag_rounds", "1", "--replays", "2", "--priority", "0", "--out", str(tmp_path)]
    proc = subprocess.run([sys.executable, MEASURE, *args], capture_output=True, text=True, timeout=900, cwd=ROOT,
                          env=env)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((tmp_path / "results.json").read_text())
    for key in ("lockstep", "realtime", "realtime_fifo", "replay_fifo"):
        assert res[key] == old[key], key
    rp = res["replay"]
    assert rp != old["replay"] and rp["bag_rounds"] == 1 and len(rp["replays"]) == 2
    assert rp["node"]["counts"]["substeps"] == sum(r["node"]["counts"]["substeps"] for r in rp["replays"]) > 0
    prov = res["provenance"]
    assert prov["replay"]["command"] == "python " + MEASURE + " " + " ".join(args)
    assert len(prov["replay"]["load_start"]) == 3 and prov["replay"]["git"]
    assert prov["lockstep"] == old.get("provenance", {}).get("lockstep", prov["lockstep"])
    report = (tmp_path / "report.md").read_text()
    assert f"| replay | `{prov['replay']['command']}` |" in report
    assert f"| lockstep | `{prov['lockstep']['command']}` |" in report
    assert "bag replayed, normal scheduler" in report
