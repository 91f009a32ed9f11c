"""``python studies/capability/capability_runs.py``: a lease's capability jobs gathered per policy, finished ones from their
results.json, cut-off curves from their console lines (marked partial), the named points' medians against the target."""

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _job(folder, name, sweep, field, terrain, curves):
    d = folder / name
    d.mkdir()
    points = {ctrl: [{"value": v, "success_3m": s, "fall_rate": f, "rounds": 200} for v, s, f in pts]
              for ctrl, pts in curves.items()}  # fmt: skip
    values = [p[0] for p in next(iter(curves.values()))]
    sweeps = {sweep: {"field": field, "terrain": terrain, "values": values, "curves": points}}
    (d / "results.json").write_text(json.dumps({"sweeps": sweeps}))
    (folder / f"{name}.log").write_text("report in ...\nexit 0\n")


def test_gathers_complete_partial_and_points(tmp_path):
    from capability_runs import main

    ev = tmp_path / "extra"
    ev.mkdir()
    _job(ev, "s1_tread_depth", "tread_depth", "terrain.step_depth", "stepped",
         {"cpg_rl": [(0.15, 0.5, 0.1), (0.2, 1.0, 0.0)]})
    (ev / "shipped_payload.log").write_text(
        "complex  CPG_RL   3 m 98%\n[sweep payload = 0] complex  CPG      3 m 0%  falls 1%\n"
        "[sweep payload = 0] complex  CPG_RL   3 m 99%  falls 0%\n"
        "[sweep payload = 0.5] complex  CPG      3 m 0%  falls 2%\n")
    for seed, ok in (("s1", 0.9), ("s2", 0.97), ("s3", 0.96)):
        _job(ev, f"{seed}_at_friction03", "randomization.friction", "randomization.friction", "complex",
             {"cpg_rl": [(0.3, ok, 0.01)]})
    _job(ev, "s1_at_rise8", "terrain.step_rise", "terrain.step_rise", "stepped", {"cpg_rl": [(0.08, 0.0, 0.02)]})
    out = tmp_path / "out"
    assert main([str(ev), "--policy", "shipped=shipped", "--policy", "margin=s1,s2,s3", "--out", str(out)]) == 0
    res = json.loads((out / "results.json").read_text())
    tread = res["curves"]["tread_depth"]["policies"]["margin"]
    assert tread["s1"]["status"] == "complete" and [p["value"] for p in tread["s1"]["points"]] == [0.15, 0.2]
    assert tread["s2"]["status"] == "missing"
    payload = res["curves"]["payload"]
    assert payload["policies"]["shipped"]["shipped"]["status"] == "partial"
    assert payload["policies"]["shipped"]["shipped"]["points"] == [
        {"value": 0.0, "success_3m": 0.99, "fall_rate": 0.0, "rounds": None, "source": "console"}]
    assert [p["fall_rate"] for p in payload["cpg"]["points"]] == [0.01, 0.02]  # the fixed CPG beside
    friction = res["points"]["friction03"]["margin"]
    assert friction["median_success_3m"] == 0.96 and friction["target_met"]
    assert not res["points"]["rise8"]["margin"]["target_met"]  # one seed of three: no median to meet the target
    report = (out / "report.md").read_text()
    assert "python studies/capability/capability_runs.py" in report and "| friction 0.3 (complex) | margin |" in report
    assert "shipped (shipped, partial)" in report
    assert "Named points: 200 rounds each." in report  # the rounds the points' results name
    assert (out / "fig_sweep_tread_depth.png").stat().st_size > 2000 and not (out / "fig_sweep_push.png").exists()


def test_bad_input_is_one_line(tmp_path):
    for args, message in (([str(tmp_path / "none"), "--policy", "a=b"], "no such folder"),
                          ([str(tmp_path), "--policy", "a"], "LABEL=PREFIX"),
                          ([str(tmp_path), "--policy", "a=b"], "holds no evaluation")):  # fmt: skip
        cmd = [sys.executable, "studies/capability/capability_runs.py", *args, "--out", str(tmp_path / "o")]
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=120, cwd=ROOT)
        err = [line for line in p.stderr.splitlines() if line.strip()]
        assert p.returncode == 2 and len(err) == 1 and message in err[0], p.stderr
        assert not (tmp_path / "o").exists()
