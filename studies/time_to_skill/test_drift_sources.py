"""studies/time_to_skill/drift_sources.py's arithmetic on made-up rounds: the lateral offset and yaw where each round has walked
1, 2 and 3 m, and the start yaw's share in the drift; a missing checkpoint gets one line and a non-zero exit."""

import importlib.util
import os
import subprocess
import sys

import numpy as np
import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCRIPT = os.path.join(ROOT, "studies", "time_to_skill", "drift_sources.py")
spec = importlib.util.spec_from_file_location("drift_sources", SCRIPT)
ds = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ds)


def _straight(yaw0: np.ndarray, y0: np.ndarray, steps: int = 400, dx: float = 0.01):
    """Robots that keep their start yaw, each step dx forward in x."""
    x = dx * np.arange(steps)[:, None] * np.ones_like(yaw0)
    pos = np.stack([x, y0 + x * np.tan(yaw0)], axis=-1)
    rpy = np.zeros(pos.shape[:2] + (3,))
    rpy[..., 2] = yaw0
    return pos, rpy


def test_a_kept_start_yaw_is_the_whole_drift():
    yaw0 = np.linspace(-0.2, 0.2, 9)
    pos, rpy = _straight(yaw0, np.zeros(9))  # positions relative to each round's start
    s = ds.summarize(pos, rpy)
    at3 = s["at"]["3 m"]
    assert at3["rounds_reached"] == 9 and at3["corr_y_start_yaw"] == pytest.approx(1.0, abs=1e-3)
    assert at3["mean_abs_y_m"] == pytest.approx(at3["mean_abs_y_if_start_yaw_kept_m"], rel=1e-2)
    assert at3["mean_abs_yaw_rad"] == pytest.approx(np.mean(np.abs(yaw0)))


def test_rounds_that_never_walk_the_distance_are_left_out():
    pos, rpy = _straight(np.array([0.1, -0.1]), np.array([0.05, -0.05]))
    pos[:, 1, 0] = np.minimum(pos[:, 1, 0], 1.5)  # the second round stops at 1.5 m
    pos[301:, 0] = np.nan  # the first round ended at 3 m (NaN after its end, as the logs hold it)
    v = ds.at_distances(pos, rpy[..., 2])
    assert np.isfinite(v[1.0]["y"]).all() and np.isnan(v[2.0]["y"][1]) and np.isfinite(v[2.0]["y"][0])
    assert v[3.0]["y"][0] == pytest.approx(0.05 + 3.0 * np.tan(0.1), abs=1e-6) and np.isnan(v[3.0]["y"][1])


def test_missing_checkpoint_is_one_line():
    r = subprocess.run([sys.executable, SCRIPT, "--checkpoint", "nope.pt", "--out", "x.json"], capture_output=True,
                       text=True, cwd=ROOT)  # fmt: skip
    assert r.returncode == 2 and r.stderr.strip().count("\n") == 0 and "nope.pt" in r.stderr
