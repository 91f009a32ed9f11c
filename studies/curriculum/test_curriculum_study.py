"""The curriculum study: its report renders from its results.json, its consoles parse, its arms' flags are train.py's,
and its gate's Monte Carlo reproduces (CPU)."""

import importlib.util
import json
import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))


def _load(name: str):
    """A script of this study as a module of its own name (other studies' tests import their own ``build``)."""
    spec = importlib.util.spec_from_file_location(f"curriculum_{name}", os.path.join(HERE, f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


arms, build, gate_mc = _load("arms"), _load("build"), _load("gate_mc")

pytestmark = pytest.mark.slow


def test_the_report_renders_from_results_json():
    results = json.load(open(os.path.join(HERE, "results.json")))
    assert build.report(results) == open(os.path.join(HERE, "report.md")).read()
    assert results["arms"] == build.arms_table(build.collect())


def test_a_console_line_parses():
    text = ("iteration 200: curriculum stage 3 of 3: posture_reflex 2, w_tilt 40, w_ang_vel 0.3\n"
            "iteration 299/299  success 0.996  fell 0.002  off course 0.000  distance 3.02 m  level 6.7  top lane 33% "
            "of 6203 ep  5.4 ep/robot  1.20 s/it  0:10:50\n"
            "iteration 0/299  no episode ended yet  level 0.9  top lane - of 0 ep  0.0 ep/robot  3.35 s/it  0:00:03\n")
    parsed = build.parse_console(text)
    assert parsed["stage_starts"] == [200]
    assert parsed["iterations"] == [{"iteration": 299, "success": 0.996, "fell": 0.002, "mean_level": 6.7,
                                     "stage_episodes": 6203, "stage_top_lane_share": 0.33, "episodes_per_robot": 5.4}]


def test_the_arms_flags_are_train_flags():
    """Every flag of every arm names a field of the complex task's configs (train.py makes every field a flag)."""
    from dataclasses import fields, is_dataclass

    from hexnewton.tasks import task

    t = task("complex")
    for arm, (flags, _) in arms.ARMS.items():
        assert arms.main(["--flags", arm]) == 0
        for word in flags.split():
            if not word.startswith("--"):
                continue
            node = {"env": t.env, "agent": t.agent}[word[2:].split(".")[0]]
            for part in word[2:].split(".")[1:]:
                assert is_dataclass(node) and part in {f.name for f in fields(node)}, f"{arm}: {word}"
                node = getattr(node, part)
    assert arms.main(["--flags", "nope"]) == 2


def test_the_gate_monte_carlo_reproduces():
    committed = json.load(open(os.path.join(HERE, "gate_mc.json")))
    m = gate_mc.model(gate_mc.shipped_results())
    assert m == committed["model"]
    assert gate_mc.simulate(m) == committed["scenarios"]["as good as the shipped policy"]
    assert committed["sound"]


def _gate_case():
    """Five seeds a little better than the shipped policy on every line, 4000/1000/4000 test rounds."""
    rounds = {"rugged": 4000, "stepped": 1000, "complex": 4000}
    seed = {t: {"success_3m": 0.985, "fall_rate_before_goal": 0.004, "pitch_var_deg2": 20.0, "roll_var_deg2": 8.0,
                "rounds": n} for t, n in rounds.items()}  # fmt: skip
    seeds = {k: {t: dict(v) for t, v in seed.items()} for k in range(1, 6)}
    shipped = {t: dict(v, success_3m=0.98, fall_rate_before_goal=0.004) for t, v in seed.items()}
    fixed = {t: dict(v, pitch_var_deg2=30.0, roll_var_deg2=13.0) for t, v in seed.items()}
    return seeds, shipped, fixed, {k: 200.0 for k in seeds}


def test_the_gate_lines():
    seeds, shipped, fixed, times = _gate_case()
    assert build.gate_lines(seeds, shipped, fixed, times)["pass"]
    # each line fails alone
    s = {k: {t: dict(v) for t, v in r.items()} for k, r in seeds.items()}
    for k in (1, 2, 3):
        s[k]["complex"]["success_3m"] = 0.97  # the median 0.97 < shipped 0.98 - 0.005
    g = build.gate_lines(s, shipped, fixed, times)
    assert not g["pass"] and not g["lines"]["median_3m"]["complex"]["pass"]
    assert g["lines"]["worst_seed"]["complex"]["pass"]
    s = {k: {t: dict(v) for t, v in r.items()} for k, r in seeds.items()}
    s[1]["rugged"]["fall_rate_before_goal"] = 0.02  # pooled (0.02 + 4 x 0.004) / 5 = 0.0072 > 0.004 + 0.003
    g = build.gate_lines(s, shipped, fixed, times)
    assert not g["pass"] and not g["lines"]["pooled_falls"]["rugged"]["pass"]
    assert g["lines"]["worst_seed"]["rugged"]["pass"]
    s = {k: {t: dict(v) for t, v in r.items()} for k, r in seeds.items()}
    s[5]["stepped"]["success_3m"] = 0.94  # the worst seed < 95 %
    g = build.gate_lines(s, shipped, fixed, times)
    assert not g["pass"] and not g["lines"]["worst_seed"]["stepped"]["pass"]
    s = {k: {t: dict(v) for t, v in r.items()} for k, r in seeds.items()}
    s[2]["rugged"]["roll_var_deg2"] = 10.5  # >= 0.8 x 13
    g = build.gate_lines(s, shipped, fixed, times)
    assert not g["pass"] and not g["lines"]["rugged_variance"]["roll"]["pass"]
    assert not build.gate_lines(seeds, shipped, fixed, {**times, 3: 250.0})["pass"]
    assert not build.gate_lines(seeds, shipped, fixed, {**times, 3: None})["pass"]
    assert not build.gate_lines({k: seeds[k] for k in (1, 2, 3, 4)}, shipped, fixed, times)["pass"]  # < 5 seeds


def test_the_gate_renders():
    seeds, shipped, fixed, times = _gate_case()
    g = build.gate_lines(seeds, shipped, fixed, times)
    g.update(lease="L", per_seed={str(k): v for k, v in seeds.items()}, shipped=shipped, fixed_cpg=fixed,
             top_lane_shares={str(k): 0.3 for k in seeds})
    text = build.report({"leases": {}, "arms": {}, "gate": json.loads(json.dumps(g)), "gate_mc": None})
    assert "| gate_s5 | 98.5 | 0.4 |" in text and "The gate: **holds**." in text


def test_the_ceiling_plays_the_shipped_policy_through_an_arms_curriculum(tmp_path):
    """ceiling.py: an arm's flags as config paths of their fields' types, two iterations of the shipped policy on the
    training env of the complex task with the spread arm (4 robots), its lanes counted and the report rendered from
    the results; the kept ceiling/report.md is the rendering of ceiling/results.json."""
    ceiling = _load("ceiling")
    from hexnewton.tasks import task

    env = task("complex").env
    assert ceiling.arm_overrides(arms.ARMS["both"][0], env) == {"terrain.start_levels": 6, "terrain.climb": 2,
                                                               "terrain.start_progress": 2.0}  # fmt: skip
    out = tmp_path / "ceiling"
    assert ceiling.main(["--out", str(out), "--arms", "spread", "--num_envs", "4", "--iterations", "2",
                         "--device", "cpu"]) == 0  # fmt: skip
    res = json.loads((out / "results.json").read_text())
    (r,) = res["runs"]
    assert r["arm"] == "spread" and r["seed"] == 1 and set(res["arms"]) == {"spread"}
    assert r["iterations"] == 2 and len(r["iteration_top_lane_share"]) == 2 and r["summary"]["levels"] == 10
    assert (out / "report.md").read_text() == ceiling.render(res)
    with open(os.path.join(HERE, "ceiling", "results.json")) as f:
        kept = json.load(f)
    assert ceiling.render(kept) == open(os.path.join(HERE, "ceiling", "report.md")).read()
    assert kept["arms"] == ceiling.pooled(kept["runs"])
