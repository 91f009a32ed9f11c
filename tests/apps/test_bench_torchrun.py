"""``hexnewton-bench`` under torchrun (hexnewton/apps/bench.py): two CPU processes (Gloo) each measure their own envs,
training with their gradients averaged; rank 0 gathers both ranks' rates and writes the total and the efficiency against a 1-GPU baseline."""

import json
import os
import subprocess

import pytest

from hexnewton.apps.bench import main
from hexnewton.apps.cli import run

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def _baseline(path, world_size: int = 1) -> None:
    rows = [{"measure": m, "terrain": "flat", "num_envs": 4, "per_rank": [100.0] * world_size,
             "total": 100.0 * world_size} for m in ("env", "train")]  # fmt: skip
    path.write_text(json.dumps({"world_size": world_size, "device_name": "cpu", "command": "x", "ranks": rows}))


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_two_cpu_ranks_gather_their_rates(tmp_path):
    _baseline(tmp_path / "one.json")
    cmd = ["torchrun", "--standalone", "--nproc_per_node=2", "-m", "hexnewton.apps.bench", "--device", "cpu",
           "--terrain", "flat", "--num_envs", "4", "--mode", "train", "--train_iterations", "1", "--baseline", str(tmp_path / "one.json"), "--json", str(tmp_path / "two.json")]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=ROOT,
                          env=dict(os.environ, PYTHONPATH=ROOT))  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    out = json.load(open(tmp_path / "two.json"))
    assert out["world_size"] == 2 and [r["measure"] for r in out["ranks"]] == ["train"]
    for r in out["ranks"]:
        assert len(r["per_rank"]) == 2 and min(r["per_rank"]) > 0 and r["total"] == sum(r["per_rank"])
    assert out["pipeline"][0]["train_steps_per_s"] == out["ranks"][0]["per_rank"][0]  # rank 0's own results
    assert out["command"].startswith("torchrun --standalone --nproc_per_node=2 -m hexnewton.apps.bench")
    lines = [line for line in proc.stdout.splitlines() if line.startswith("| train | flat | 4 | 2 |")]
    eff = out["ranks"][0]["total"] / 200.0
    assert len(lines) == 1 and f"{100 * eff:.1f} %" in lines[0], proc.stdout[-2000:]
    assert proc.stdout.count("### Throughput") == 1  # rank 0 alone prints


def test_a_baseline_of_several_gpus_or_largest_under_torchrun_is_one_error_line(tmp_path, capsys, monkeypatch):
    _baseline(tmp_path / "two.json", world_size=2)
    argv = ["--device", "cpu", "--baseline", str(tmp_path / "two.json")]
    assert run(main, "python -m hexnewton.apps.bench", argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a 1-GPU hexnewton-bench --json" in err[0], err
    # --largest stops at each rank's own env count: one process only
    for key, value in (("WORLD_SIZE", "2"), ("RANK", "0"), ("LOCAL_RANK", "0")):
        monkeypatch.setenv(key, value)
    assert run(main, "python -m hexnewton.apps.bench", ["--device", "cpu", "--largest"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--largest runs in one process" in err[0], err
