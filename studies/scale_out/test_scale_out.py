"""The scale-out report (``python studies/scale_out/scale_out.py``) from fixture outputs
of a lease: bench JSONs at 1, 2 and 4 GPUs, train.py runs and their evaluations."""

import json
import os

import pytest

from hexnewton.apps.cli import run

from scale_out import main  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)


def _bench(k: int, train: dict[int, list[float]]) -> dict:
    """A ``hexnewton-bench --json`` of K ranks: train mode at each envs per GPU, the ranks' rates."""
    ranks = [{"measure": "train", "terrain": "complex", "num_envs": n, "per_rank": rates, "total": sum(rates)}
             for n, rates in train.items()]  # fmt: skip
    return {"sim": [], "pipeline": [], "profile": [], "world_size": k, "device_name": "NVIDIA H100 80GB HBM3",
            "command": f"torchrun --standalone --nproc_per_node={k} -m hexnewton.apps.bench --task complex", "ranks": ranks}


def _run(folder, name: str, k: int, envs: int, train_s: float, wall: float, start: float, evals: dict,
         scaled: tuple = ()) -> None:
    run_dir = folder / "runs" / name
    run_dir.mkdir(parents=True)
    steps = 300 * 24 * envs * k
    (run_dir / "timing.json").write_text(json.dumps({
        "startup_phases_s": {}, "first_iteration_s": 40.0, "train_s": train_s, "iterations": 300, "env_steps": steps,
        "world_size": k, "num_envs_per_rank": envs, "device_name": "NVIDIA H100 80GB HBM3", "process_start": start,
        "wall_s_to_result": wall, "result": f"/root/scale_out/{name}/x/model_result.pt"}))  # fmt: skip
    (run_dir / "config.json").write_text(json.dumps({"hexnewton": {"world_size": k, "config": {"sim": {
        "num_envs": envs, "device": "cuda:0"}}, "agent": {"scale_with_ranks": list(scaled)}},
        "train": {}}))  # fmt: skip
    (run_dir / "wall.txt").write_text(f"{wall + 3.0}\n")
    for terrain, (success, falls) in evals.items():
        d = folder / "evals" / f"{name}_{terrain}"
        d.mkdir(parents=True)
        (d / "results.json").write_text(json.dumps({"meta": {}, "results": {terrain: {"cpg_rl": {
            "rounds": 1000, "success_3m": success, "fall_rate": falls}}}}))  # fmt: skip


@pytest.fixture
def lease(tmp_path):
    folder = tmp_path / "lease"
    folder.mkdir()
    for k, rate in ((1, 100000.0), (2, 95000.0), (4, 80000.0)):
        bench = _bench(k, {4096: [rate] * k, 16384: [2 * rate] * k})
        (folder / f"bench_{k}gpu.json").write_text(json.dumps(bench))
    ev = {"rugged": (0.99, 0.01), "stepped": (1.0, 0.0), "complex": (0.975, 0.002)}
    _run(folder, "g1x4096", 1, 4096, 120.0, 170.0, 1000.0, ev)
    _run(folder, "g2x4096", 2, 4096, 126.0, 176.0, 2000.0, ev)
    _run(folder, "g2x2048", 2, 2048, 80.0, 125.0, 2010.0, ev)
    _run(folder, "g4x1024", 4, 1024, 60.0, 100.0, 3000.0, {"rugged": (0.95, 0.04)}, scaled=("iterations",))
    (folder / "commands.txt").write_text("CUDA_VISIBLE_DEVICES=0 python train.py --task complex --num_envs 4096\n")
    return folder


def test_report_from_a_lease(lease, tmp_path, capsys):
    out = tmp_path / "report"
    assert run(main, "python studies/scale_out/scale_out.py", [str(lease), "--out", str(out)]) == 0
    res = json.load(open(out / "results.json"))
    eff = {(r["envs_per_gpu"], r["gpus"]): r["efficiency"] for r in res["bench"]}
    assert eff[(4096, 1)] == pytest.approx(1.0) and eff[(4096, 2)] == pytest.approx(0.95)
    assert eff[(16384, 4)] == pytest.approx(0.8)
    totals = {(r["envs_per_gpu"], r["gpus"]): r["total"] for r in res["bench"]}
    assert totals[(4096, 4)] == pytest.approx(320000.0)
    runs = res["runs"]
    assert set(runs) == {"g1x4096", "g2x4096", "g2x2048", "g4x1024"}
    g2 = runs["g2x4096"]
    assert g2["gpus"] == 2 and g2["envs_per_gpu"] == 4096 and g2["total_envs"] == 8192
    assert g2["efficiency"] == pytest.approx(120.0 / 126.0)  # twice the steps in 126 s against once in 120 s, per GPU
    assert g2["speedup"] == pytest.approx(170.0 / 176.0) and g2["shell_wall_s"] == pytest.approx(179.0)
    assert runs["g4x1024"]["speedup"] == pytest.approx(1.7) and runs["g4x1024"]["efficiency"] is None
    assert g2["beside"] == ["g2x2048"] and runs["g1x4096"]["beside"] == []
    assert g2["terrains"]["complex"] == {"rounds": 1000, "success_3m": 0.975, "fall_rate": 0.002}
    assert g2["device_name"] == "NVIDIA H100 80GB HBM3" and g2["result"] == "model_result.pt"
    four = res["by_gpus"]["4"]
    assert four["bench"]["train"]["16384"]["efficiency"] == pytest.approx(0.8) and set(four["runs"]) == {"g4x1024"}
    assert four["runs"]["g4x1024"]["terrains"]["rugged"]["fall_rate"] == 0.04
    assert four["devices"] == ["NVIDIA H100 80GB HBM3"] and set(res["by_gpus"]) == {"1", "2", "4"}
    md = open(out / "report.md").read()
    assert "| train | complex | 16384 | 4 | 640,000 env-steps/s | 160,000 | 100.0 % | 80.0 % (below 90 %) |" in md
    assert "CUDA_VISIBLE_DEVICES=0 python train.py --task complex --num_envs 4096" in md
    assert four["runs"]["g4x1024"]["scale_with_ranks"] == ["iterations"] and g2["scale_with_ranks"] == []
    assert "| g4x1024 | NVIDIA H100 80GB HBM3 | 4 | 1024 | 4096 | iterations | 300 |" in md and "95.0 % / 4.0 %" in md
    # nothing is overwritten; an empty folder or a run without timing.json is one line, exit 2
    for argv, message in (([str(lease), "--out", str(out)], "exists"),
                          ([str(tmp_path / "report"), "--out", str(tmp_path / "r2")], "nothing to report"),
                          ([str(tmp_path / "none"), "--out", str(tmp_path / "r3")], "is not a folder")):  # fmt: skip
        capsys.readouterr()
        assert run(main, "python studies/scale_out/scale_out.py", argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and message in err[0], err
    os.remove(lease / "runs" / "g2x2048" / "timing.json")
    assert run(main, "python studies/scale_out/scale_out.py", [str(lease), "--out", str(tmp_path / "r4")]) == 2
    assert "holds no timing.json" in capsys.readouterr().err


def test_report_joins_leases(lease, tmp_path):
    """The benches of one lease and the runs of another make one report; two runs of one name are an error."""
    benches = tmp_path / "benches"
    benches.mkdir()
    for p in lease.glob("bench_*.json"):
        p.rename(benches / p.name)
    (benches / "commands.txt").write_text("torchrun --standalone --nproc_per_node=4 -m hexnewton.apps.bench\n")
    out = tmp_path / "joined"
    assert run(main, "python studies/scale_out/scale_out.py", [str(benches), str(lease), "--out", str(out)]) == 0
    res = json.load(open(out / "results.json"))
    assert len(res["bench"]) == 6 and len(res["runs"]) == 4
    assert res["commands"][0].startswith("torchrun") and res["commands"][1].startswith("CUDA_VISIBLE_DEVICES=0")
    assert f"scale_out.py {benches} {lease} --out {out}`" in open(out / "report.md").read()
    assert run(main, "python studies/scale_out/scale_out.py", [str(lease), str(lease), "--out", str(tmp_path / "x")]) == 2
    # the leases' own folder may hold the report, once
    argv = [str(benches), str(lease), "--out", str(tmp_path)]
    assert run(main, "python studies/scale_out/scale_out.py", argv) == 0 and (tmp_path / "report.md").is_file()
    assert run(main, "python studies/scale_out/scale_out.py", argv) == 2
