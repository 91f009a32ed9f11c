"""studies/throughput/contacts.py: its report is the rendering of its measured numbers, and its settings are flags the
physics config takes."""

import json
import os

import pytest

import contacts as study  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))


def test_the_committed_report_renders_the_results():
    with open(os.path.join(HERE, "contacts", "results.json")) as f:
        res = json.load(f)
    with open(os.path.join(HERE, "contacts", "report.md")) as f:
        assert f.read() == study.report(res)
    measured = {(r["setting"], r["terrain"]) for r in res["runs"]}
    assert measured == {(s, t) for s in study.SETTINGS for t in study.TERRAINS}


def test_the_settings_are_physics_flags():
    from hexnewton.config import HexConfig, apply_overrides

    for flags in study.SETTINGS.values():
        cfg = apply_overrides(HexConfig(), dict(flags))
        assert all(getattr(cfg.sim, k.split(".")[1]) == v for k, v in flags.items())
