"""The solver A/B's verdicts and its committed report, on the CPU."""

import importlib.util
import os

import pytest

pytestmark = pytest.mark.slow

spec = importlib.util.spec_from_file_location("solver_ab", os.path.join(os.path.dirname(__file__), "solver_ab.py"))
ab = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ab)


def sim(speed, overflow="none"):
    return {t: {"robot_s_per_s": speed, "overflow": overflow, "not_converged_worlds": 0} for t in ab.TERRAINS}


def ev(success, falls):
    return {t: {"cpg_rl": {"success_3m": success, "fall_rate_before_goal": falls}} for t in ab.TERRAINS}


def test_a_faster_variant_within_the_tolerances_is_kept():
    v = ab.verdicts({"base": sim(100), "fast": sim(120)}, {"base": ev(0.98, 0.001), "fast": ev(0.975, 0.004)})
    assert v["fast"]["verdict"] == "kept" and v["fast"]["speedup"]["complex"] == pytest.approx(0.2)


def test_quality_overflow_speed_and_missing_rounds_each_decide():
    base = {"base": ev(0.98, 0.001)}
    assert ab.verdicts({"base": sim(100), "v": sim(120)}, base | {"v": ev(0.96, 0.001)})["v"]["verdict"].startswith(
        "not kept: the A/B fails")
    assert ab.verdicts({"base": sim(100), "v": sim(120)}, base | {"v": ev(0.98, 0.007)})["v"]["verdict"].startswith(
        "not kept: the A/B fails")
    assert ab.verdicts({"base": sim(100), "v": sim(120, "overflowed")}, base | {"v": ev(0.98, 0.001)})["v"][
        "verdict"].startswith("not kept: contacts overflow")
    assert ab.verdicts({"base": sim(100), "v": sim(99)}, base | {"v": ev(0.98, 0.001)})["v"]["verdict"] == \
        "not kept: not faster"
    part = ab.verdicts({"base": sim(100), "v": sim(120)}, {"base": ev(0.98, 0.001)})["v"]
    assert part["verdict"] == "partial: the A/B lacks complex, rugged, stepped"


def test_the_fixed_cpg_is_a_witness_not_a_judge():
    def both(policy, fixed):
        return {t: {"cpg_rl": ev(policy, 0.001)[t]["cpg_rl"], "cpg": ev(fixed, 0.02)[t]["cpg_rl"]} for t in ab.TERRAINS}

    v = ab.verdicts({"base": sim(100), "v": sim(120)}, {"base": both(0.98, 0.40), "v": both(0.98, 0.34)})["v"]
    assert v["verdict"] == "kept" and v["fixed_cpg"]["rugged"]["success_points"] == pytest.approx(-6.0)
    res = {"leases": [{"lease": "L", "gpu": "G", "flags": {"base": "", "v": "--x"},
                       "sim": {"base": sim(100), "v": sim(120)}, "eval": {}, "verdicts": {"v": v}}]}
    assert "The fixed CPG on the same rounds" in ab.report(res) and ab.PHYSICS_MOVES in ab.report(res)


def test_the_committed_report_is_what_raw_gives():
    res = ab.load(os.path.join(ab.HERE, "raw"))
    with open(os.path.join(ab.HERE, "report.md")) as f:
        assert f.read() == ab.report(res)


def test_the_queue_reads_each_variants_flags_from_the_study(capsys):
    assert ab.main(["--flags", "cg"]) == 0 and capsys.readouterr().out.strip() == ab.FLAGS["cg"]
    assert ab.main(["--flags", "nope"]) == 2 and "no variant 'nope'" in capsys.readouterr().err
    with open(os.path.join(os.path.dirname(__file__), "solver_ab.sh")) as f:
        queue = f.read()
    assert "solver_ab.py --flags" in queue and "--env.sim" not in queue.split("flags()")[0]
    assert f"VARIANTS=${{VARIANTS:-{' '.join(ab.FLAGS)}}}" in queue   # the default: every variant
    assert "for v in ${EVAL_VARIANTS:-$VARIANTS}; do" in queue   # the A/B rounds: every variant unless named
