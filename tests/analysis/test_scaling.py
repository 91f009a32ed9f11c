"""The ranks' rates of ``hexnewton-bench`` under torchrun (hexnewton/analysis/scaling.py): each rank's rows, the
gathered total and the scaling efficiency."""

import pytest

from hexnewton.analysis.bench import BenchResult, PipelineResult
from hexnewton.analysis.scaling import rate_rows, scaling_rows, with_ranks


def test_rate_rows_line_up_with_the_ranks():
    """Each rank's rows in one order (sim, then env and train per pipeline result, unmeasured modes left out); the
    gathered rates give the total; one run of one GPU is its own baseline."""
    sim = [BenchResult("complex", 64, "cpu", 10, 1.0, 50.0, 2500.0, 0.0, 0.0, "none", 0, 0.1, 1.0)]
    pipe = [PipelineResult("complex", 64, env_steps_per_s=300.0, train_steps_per_s=200.0),
            PipelineResult("flat", 64, env_steps_per_s=400.0)]
    rows = rate_rows(sim, pipe)
    assert [(r["measure"], r["terrain"], r["rate"]) for r in rows] == [
        ("sim", "complex", 50.0), ("env", "complex", 300.0), ("train", "complex", 200.0), ("env", "flat", 400.0)]
    gathered = with_ranks(rows, [[r["rate"] for r in rows], [49.0, 310.0, 190.0, 390.0]])
    assert gathered[2]["per_rank"] == [200.0, 190.0] and gathered[2]["total"] == 390.0
    one = scaling_rows([{"world_size": 1, "ranks": with_ranks(rows, [[r["rate"] for r in rows]])}])
    assert all(r["efficiency"] == pytest.approx(1.0) for r in one)
