"""Fig. 1 (``studies/fig1/figure.py``): the pair and the six-oscillator networks from random starts (NumPy only)."""

import json
import math

import numpy as np
import pytest

from hexnewton.apps.cli import run
from hexnewton.config import LEG_OSCILLATOR, CPGConfig
from hexnewton.kernels.reference import (
    hopf_cpg_reference,
    hopf_network_reference,
    initial_cpg_state,
    tripod_theta,
)

from figure import main  # this study's modules (pytest puts the study's folder on sys.path)
from oscillators import NETWORKS, convergence, limit_cycle, param_counts, random_starts

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

CFG = CPGConfig()
DT = 0.005


@pytest.mark.parametrize("theta,duty", [(math.pi, 0.5), (1.0, 0.35), (4.0, 0.6)])
def test_network_of_two_is_the_kernels_pair(theta, duty):
    """The n-oscillator reference with two oscillators and groups (0, 1) is the kernel's pair, step for step."""
    rng = np.random.default_rng(3)
    n = 64
    state, omega = rng.uniform(-1.5, 1.5, (n, 4)), rng.uniform(math.pi, 5 * math.pi, n)
    params = np.zeros((n, 15))
    params[:, 0] = omega
    _, ref, ref_dy = hopf_cpg_reference(params, params, state, 1.0, CFG.alpha, CFG.mu, CFG.delta, theta, duty,
                                        CFG.steepness, DT)  # fmt: skip
    s, dy = hopf_network_reference(state.reshape(n, 2, 2), omega, CFG.alpha, CFG.mu, CFG.delta,
                                   tripod_theta((0, 1), theta), 1.0 - np.eye(2), duty, CFG.steepness, DT)  # fmt: skip
    np.testing.assert_allclose(s.reshape(n, 4), ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(dy, ref_dy, rtol=1e-12, atol=1e-12)


def test_tripod_coupling_phases():
    th = tripod_theta(LEG_OSCILLATOR, math.pi)
    same = np.equal.outer(LEG_OSCILLATOR, LEG_OSCILLATOR)
    assert np.all(th[same] == 0.0) and np.allclose(np.abs(th[~same]), math.pi)
    assert tripod_theta((0, 1), 2.0)[1, 0] == -2.0 and tripod_theta((0, 1), 2.0)[0, 1] == 2.0  # theta_10, theta_01


@pytest.mark.parametrize("name", list(NETWORKS))
def test_network_reaches_the_tripod_from_random_starts(name):
    """Every start locks: amplitude within 1 % of the network's own cycle, every pair within 1 deg of the tripod."""
    starts = random_starts(7, 48, 1.5, CFG.mu)
    c = convergence(name, CFG, 3 * math.pi, DT, starts, int(6.0 / DT), 0.01, math.radians(1.0))
    steps = c["steps"]["both"]
    assert np.all(np.isfinite(steps)), f"{name}: {np.isinf(steps).sum()} starts never converged"
    assert np.all(steps >= c["steps"]["phase"]) and np.all(steps >= c["steps"]["amplitude"])


@pytest.mark.parametrize("name", list(NETWORKS))
@pytest.mark.parametrize("omega", [math.pi, 5 * math.pi])
def test_network_runs_at_the_commanded_omega(name, omega):
    """The frequency compensation derived for each topology keeps the locked network at the commanded omega."""
    assert limit_cycle(name, CFG, omega, DT)["omega_measured"] == pytest.approx(omega, rel=0.01)


def _phase_error(s, theta):
    return np.angle(np.exp(1j * (np.arctan2(s[:, 1], s[:, 0]) - np.arctan2(s[:, 3], s[:, 2]) - theta)))


def test_pair_phase_difference_stays_at_theta():
    """Locked at the start, the pair's phase difference stays at theta; from random starts it settles on theta and
    stays there (the last second of six)."""
    n, steps = 64, int(6.0 / DT)
    params = np.zeros((n, 15))
    params[:, 0] = 3 * math.pi
    locked = np.tile(initial_cpg_state(CFG.mu, CFG.theta), (n, 1))
    rand = random_starts(11, n, 1.5, CFG.mu)[:, :2].reshape(n, 4)
    err_locked, err_rand = [], []
    args = (1.0, CFG.alpha, CFG.mu, CFG.delta, CFG.theta, CFG.duty, CFG.steepness, DT)
    for _ in range(steps):
        locked = hopf_cpg_reference(params, params, locked, *args)[1]
        rand = hopf_cpg_reference(params, params, rand, *args)[1]
        err_locked.append(_phase_error(locked, CFG.theta))
        err_rand.append(_phase_error(rand, CFG.theta))
    assert np.abs(err_locked).max() < 1e-9
    assert np.abs(err_rand[: steps // 10]).max() > 0.5  # the starts were far from theta
    assert np.abs(err_rand[-int(1.0 / DT):]).max() < 1e-5


def test_param_counts():
    c = param_counts()
    assert c["two"] == {"oscillators": 2, "directed_couplings": 2, "coupling_phases": 1, "state_variables": 4}
    assert c["six"] == {"oscillators": 6, "directed_couplings": 30, "coupling_phases": 15, "state_variables": 12}
    assert c["reduction_pct"]["oscillators"] == 66.7


def test_command_writes_report_json_and_figure(tmp_path):
    out = tmp_path / "fig1"
    argv = ["--out", str(out), "--samples", "12", "--dt", "0.005", "--omega", "9.42", "--horizon_s", "4"]
    assert main(argv) == 0
    res = json.loads((out / "results.json").read_text())
    assert [r["network"] for r in res["runs"]] == list(NETWORKS)
    for r in res["runs"]:
        assert r["dt"] == 0.005 and r["omega"] == 9.42 and r["horizon_steps"] == 800
        for key in ("both", "amplitude", "phase"):
            assert r[key]["never"] == 0 and r[key]["median_steps"] <= r[key]["p95_steps"] <= r[key]["max_steps"]
        assert r["omega_measured"] == pytest.approx(9.42, rel=0.01)
    assert res["param_counts"]["six"]["oscillators"] == 6 and res["paper_steps"] == {"six": 200, "two": 70}
    assert {len(v) for v in res["figure_steps"].values()} == {12}
    report = (out / "report.md").read_text()
    assert "python studies/fig1/figure.py --out" in report and "| six_mean | 5 | 9.42 |" in report
    assert 0 < (out / "fig1.png").stat().st_size < 300_000


def _exit_code(argv):
    try:
        return run(main, "python studies/fig1/figure.py", argv)
    except SystemExit as exc:  # argparse's own errors
        return exc.code


@pytest.mark.parametrize("extra", [["--dt", "0.5"], ["--radius", "0"], ["--samples", "0"], ["--omega"]])
def test_bad_input_is_one_line_and_exit_2(tmp_path, capsys, extra):
    out = tmp_path / "fresh"
    assert _exit_code(["--out", str(out), *extra]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "error" in err[0] and not out.exists()


def test_existing_out_is_refused(tmp_path, capsys):
    (tmp_path / "fig1").mkdir()
    (tmp_path / "fig1" / "keep.txt").write_text("kept")
    assert _exit_code(["--out", str(tmp_path / "fig1")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "exists" in err[0]
    assert [p.name for p in (tmp_path / "fig1").iterdir()] == ["keep.txt"]
