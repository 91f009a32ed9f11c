"""The fixed-gait sweep (``python studies/cpg_sweep/sweep.py``): every gait of a grid walks its rounds in one batch,
the best is reported; a gait outside the CPG's ranges is one error line."""

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SWEEP = os.path.join("studies", "cpg_sweep", "sweep.py")


def test_fixed_gait_sweep_on_a_tiny_run(tmp_path):
    """Every gait of a 2-gait grid walks its rounds in one batch and the best is reported."""
    out = tmp_path / "sweep"
    cmd = [sys.executable, SWEEP, "--terrains", "flat", "--rounds", "2", "--omega",
           "9.42477796076938", "--a1", "0.3", "--a2", "0.5", "1.1", "--a3", "0.5", "--max_steps", "30", "--device",
           "cpu", "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((out / "results.json").read_text())
    assert res["meta"]["gaits"] == 2 and len(res["gaits"]) == 2 and res["best"]["a2"] in (0.5, 1.1)
    assert res["default"] is not None and "best gait" in proc.stdout
    assert "| default " in (out / "report.md").read_text()


def test_a_gait_outside_the_ranges_is_one_error(tmp_path):
    bad = subprocess.run([sys.executable, SWEEP, "--a2", "2.0", "--out", str(tmp_path / "b")],
                         capture_output=True, text=True, timeout=300, cwd=ROOT)  # fmt: skip
    lines = bad.stderr.strip().splitlines()
    assert bad.returncode == 2 and len(lines) == 1 and "leaves the parameter ranges" in lines[0], bad.stderr
    assert not (tmp_path / "b").exists()
