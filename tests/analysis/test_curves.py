"""Learning curves from a run's TensorBoard events (hexnewton/analysis/curves.py)."""

import glob
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)


def test_learning_curves_from_a_run(trained, tmp_path):
    logs, _ = trained
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    out = tmp_path / "curve.png"
    proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.curves", run_dir, "--out", str(out)], capture_output=True,
                          text=True, timeout=300)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert out.stat().st_size > 5000 and "Episode/success_rate" in (tmp_path / "curve.csv").read_text()
    bad = subprocess.run([sys.executable, "-m", "hexnewton.apps.curves", str(tmp_path / "nope")], capture_output=True,
                         text=True, timeout=300)  # fmt: skip
    assert bad.returncode == 2 and "not a run directory" in bad.stderr


def test_curve_axes_and_resumed_pieces(trained):
    """env-steps come from config.json (iterations x envs x steps per env); a piece that repeats iterations
    already plotted adds nothing; wall time starts at 0."""
    from hexnewton.analysis.curves import read_curve, steps_per_iteration

    logs, _ = trained
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    per_it = steps_per_iteration(run_dir)
    tag = next(iter(read_curve(run_dir)))
    its = [x for x, _ in read_curve(run_dir, "iteration")[tag]]
    steps = [x for x, _ in read_curve(run_dir, "env_steps")[tag]]
    assert steps == [(i - its[0] + 1) * per_it for i in its]
    joined = read_curve(f"{run_dir},{run_dir}", "env_steps")
    assert {t: [x for x, _ in rows] for t, rows in joined.items()} == {t: [x for x, _ in rows] for t, rows in
                                                                       read_curve(run_dir, "env_steps").items()}
    wall = [x for x, _ in read_curve(run_dir, "wall_time")[tag]]
    assert wall[0] >= 0.0 and wall == sorted(wall)
