"""studies/time_to_skill/drift_past_3m.py on made-up evaluation reports: the bad endings past 3 m per evaluation, their correlation
with the drift, the evaluations it leaves out; bad arguments get one line and a non-zero exit."""

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "studies", "time_to_skill", "drift_past_3m.py")


def _report(path, drift, success_3m, fell, off, timeout, rounds=1000, controller="cpg_rl",
            actions="deterministic (mean)"):
    os.makedirs(path)
    ended = {"running": 0, "fell": fell, "off_course": off, "timeout": timeout, "nonfinite": 0,
             "success": rounds - fell - off - timeout}
    data = {"meta": {"actions": actions}, "results": {"rugged": {controller: {
        "rounds": rounds, "success_3m": success_3m, "y_dev_mean_m": drift, "ended": ended}}}}
    with open(os.path.join(path, "results.json"), "w") as f:
        json.dump(data, f)


def test_drift_and_endings_past_3m(tmp_path):
    root = tmp_path / "results"
    _report(root / "a", 0.2, 0.99, 5, 5, 5)  # 1.5 % bad, 1 % before 3 m: 0.5 % past
    _report(root / "b", 0.4, 0.98, 60, 20, 0)  # 8 % bad, 2 % before: 6 % past
    _report(root / "c", 0.6, 0.97, 150, 100, 0)  # 25 % bad, 3 % before: 22 % past
    _report(root / "d", 0.6, 0.5, 500, 0, 0, controller="cpg")  # the fixed CPG: left out
    _report(root / "e_sampled", 0.6, 0.5, 500, 0, 0)  # sampled actions: left out
    _report(root / "f", 0.6, 0.5, 500, 0, 0, rounds=100)  # too few rounds: left out
    out = tmp_path / "drift.json"
    proc = subprocess.run([sys.executable, SCRIPT, "--root", str(root), "--out", str(out)], capture_output=True,
                          text=True)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    got = json.loads(out.read_text())
    assert got["evaluations"] == 3 and [r["bad_past_3m"] for r in got["rows"]] == [0.005, 0.06, 0.22]
    assert got["correlation"] > 0.9 and "3 evaluations, correlation" in proc.stdout


def test_bad_arguments(tmp_path):
    proc = subprocess.run([sys.executable, SCRIPT, "--root", str(tmp_path / "none")], capture_output=True, text=True)
    assert proc.returncode == 1 and proc.stderr.count("\n") == 1 and "too few" in proc.stderr
    root = tmp_path / "results"
    for k, d in enumerate((0.1, 0.2, 0.3)):
        _report(root / str(k), d, 0.99, 5 * k, 0, 0)
    proc = subprocess.run([sys.executable, SCRIPT, "--root", str(root), "--out", str(tmp_path / "no" / "x.json")],
                          capture_output=True, text=True)  # fmt: skip
    assert proc.returncode == 1 and proc.stderr.count("\n") == 1 and "cannot write" in proc.stderr
