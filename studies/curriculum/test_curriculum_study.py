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
