"""studies/startup_beside/scene_first.py: its reports (CPU, GPU) are the renderings of its measured runs, both modes
alternating."""

import json
import os

import pytest

import scene_first as study  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))


@pytest.mark.parametrize("folder", ["scene_first", "scene_first_gpu"])
def test_the_committed_report_renders_the_runs(folder):
    with open(os.path.join(HERE, folder, "results.json")) as f:
        res = json.load(f)
    with open(os.path.join(HERE, folder, "report.md")) as f:
        assert f.read() == study.report(res)
    modes = [r["mode"] for r in res["runs"]]
    assert modes == list(study.MODES) * (len(modes) // 2)  # alternating, each mode as often
    for r in res["runs"]:  # scene_first: terrain and scene are the command's phases; else the thread's
        assert ("scene" in r["phases_s"]) == (r["mode"] == "scene_first") and "finalize" in r["beside_s"]
