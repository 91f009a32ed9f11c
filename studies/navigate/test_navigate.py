"""The navigate study's measurement (``studies/navigate/mesh_cost.py``): its report is the rendering of its numbers, and
those numbers are of the patch the navigate tasks build today."""

import json
import os

import pytest

from mesh_cost import _report  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))


def _saved() -> dict:
    with open(os.path.join(HERE, "results.json")) as f:
        return json.load(f)


def test_report_renders_the_results():
    saved = _saved()
    with open(os.path.join(HERE, "report.md")) as f:
        assert f.read() == _report(saved["rows"], saved["command"], saved["machine"])


def test_the_measured_patch_is_the_tasks():
    """navigate-rugged's terrain as the task builds it now: the same patch and the same collision triangles."""
    import newton

    from hexnewton.physics.terrain import make_terrain
    from hexnewton.tasks import task

    row = next(r for r in _saved()["rows"] if r["case"] == "navigate-rugged")
    terrain = make_terrain(task("navigate-rugged").env.terrain)
    builder = newton.ModelBuilder()
    first = terrain.add_to_builder(builder, newton.ModelBuilder.ShapeConfig())
    meshes = [builder.shape_source[s] for s in range(first, builder.shape_count)
              if builder.shape_type[s] == newton.GeoType.MESH]  # fmt: skip
    g = terrain.grid
    assert [round(g.x1 - g.x0, 3), round(g.y1 - g.y0, 3)] == row["patch_m"]
    assert sum(len(m.indices) // 3 for m in meshes) == row["triangles"]
