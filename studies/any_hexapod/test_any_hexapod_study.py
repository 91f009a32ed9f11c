"""The any-hexapod study on the CPU: its report renders from its results.json, a lease's files go in with ``--add``
and give the tables and the verdict, and the queue's train / evaluate / export / sim2sim command lines parse with the
real command lines (the queue run with a stand-in ``python`` that records them)."""

import importlib.util
import json
import os
import shutil
import stat
import subprocess
import sys
import tarfile

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def _load(name: str):
    """A script of this study as a module of its own name (other studies' tests import their own ``build``)."""
    spec = importlib.util.spec_from_file_location(f"any_hexapod_{name}", os.path.join(HERE, f"{name}.py"))
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


build = _load("build")

pytestmark = pytest.mark.slow


def _metrics(success: float, falls: float, rounds: int = 1000) -> dict:
    return {"rounds": rounds, "success_3m": success, "fall_rate_before_goal": falls, "fall_rate": falls + 0.01,
            "pitch_var_deg2": 20.0, "roll_var_deg2": 8.0}  # fmt: skip


def _timing(goal: float, falls: float, wall: float) -> dict:
    cand = {"path": "/r/model_result.pt", "goal": goal, "fell_before_goal": falls, "iteration": 299, "why": "last"}
    return {"wall_s_to_result": wall, "train_s": wall - 40, "iterations": 300, "device_name": "H100",
            "validation": {"chosen": "/r/model_result.pt", "rounds": 256, "candidates": [cand]}}


def _write(path, data) -> None:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(data if isinstance(data, str) else json.dumps(data))


def _lease(folder, init_success: dict) -> None:
    """A lease as ``queue.sh collect`` unpacks it: two runs, their test rounds and the fixed CPG's, one sim2sim."""
    _write(folder / "lease.json", {"date": "2027-01-05", "gpu": "NVIDIA H100 80GB HBM3", "robot": "mx_phoenix",
                                   "seeds": "1", "rounds": 1000, "s2s_rounds": 100})  # fmt: skip
    for name, goal, wall, init in (("scratch_s1", 0.9, 230.0, None), ("init_s1", 0.95, 210.0, "cpg_rl_complex.pt")):
        stamp = folder / "runs" / name / "2027-01-05_10-00-00"
        _write(stamp / "timing.json", _timing(goal, 0.01, wall))
        _write(stamp / "config.json", {"hexnewton": {"init": {"checkpoint": init} if init else None}, "train": {}})
        _write(folder / "runs" / f"{name}.log", f"iteration 299/299  success 0.9\n{wall:.0f} s from process start to "
                                                "the exported result\n")  # fmt: skip
        _write(folder / "policies" / f"{name}.pt", "not a checkpoint")
    for t in build.COURSES:
        _write(folder / "evals" / f"scratch_s1_{t}" / "results.json", {"results": {t: {"cpg_rl": _metrics(0.9, 0.02)}}})
        _write(folder / "evals" / f"init_s1_{t}" / "results.json",
               {"results": {t: {"cpg_rl": _metrics(init_success[t], 0.02)}}})
        _write(folder / "evals" / f"fixed_cpg_{t}" / "results.json", {"results": {t: {"cpg": _metrics(0.3, 0.05)}}})
    s2s = folder / "evals" / "s2s_init_s1"
    _write(s2s / "results.json", {t: _metrics(0.85, 0.03, 100) for t in build.COURSES})
    _write(s2s / "details.json", {"meta": {"machine": "CPU (16 cores, 12 worker processes)", "wall time": "300 s"},
                                  "fixed_cpg": {"rugged": _metrics(0.35, 0.04, 100)}, "bundle": {}})  # fmt: skip
    _write(folder / "evals" / "bundle_init_s1" / "results.json", "{}")  # not an evaluation


def test_the_report_renders_from_results_json():
    results = json.load(open(os.path.join(HERE, "results.json")))
    assert build.report(results) == open(os.path.join(HERE, "report.md")).read()
    assert results["leases"] == json.loads(json.dumps(build.collect()))
    if not results["measured"]:
        text = open(os.path.join(HERE, "report.md")).read()
        assert "Not measured yet" in text and build.TRAIN_COMMANDS[1] in text and results["verdict"] is None


def test_a_lease_goes_in_and_gives_the_tables_and_the_verdict(tmp_path):
    lease, study = tmp_path / "lease", tmp_path / "study"
    _lease(lease, {"rugged": 0.95, "stepped": 0.9, "complex": 0.93})
    study.mkdir()
    assert build.add(str(lease), study=str(study)) == "2027-01-05"
    assert (study / "policies" / "2027-01-05" / "init_s1.pt").exists()
    assert not (study / "leases" / "2027-01-05" / "evals" / "bundle_init_s1_rugged").exists()
    results = build.build(str(study))
    data = results["leases"]["2027-01-05"]
    assert data["runs"]["init_s1"]["init"] == "cpg_rl_complex.pt" and data["runs"]["scratch_s1"]["init"] is None
    assert data["runs"]["scratch_s1"]["wall_s_to_result"] == 230.0
    assert set(data["test"]["rugged"]) == {"scratch_s1", "init_s1", "fixed_cpg"}
    assert data["sim2sim"]["init_s1"]["newton"]["rugged"]["success_3m"] == 0.95
    assert data["sim2sim"]["init_s1"]["newton_fixed_cpg"]["rugged"]["success_3m"] == 0.3
    v = results["verdict"]["seeds"]["1"]
    assert v["rugged"]["success_3m"]["verdict"] == "better"  # +5 points, se ~1.2
    assert v["stepped"]["success_3m"]["verdict"] == "within noise"
    assert v["complex"]["fall_rate_before_goal"]["verdict"] == "within noise"
    assert results["verdict"]["init_better"]
    text = (study / "report.md").read_text()
    assert "| init (seed 1) | 1000 | 95.0 | 2.0 | 3.0 | 20.0 | 8.0 |" in text
    assert "| rugged | fixed CPG | 100 / 1000 | 35.0 / 30.0 |" in text
    assert "`--init` is **better: better than scratch on some course and worse on none** (one seed" in text
    assert "| 230.0 |" in text and build.report(json.loads(json.dumps(results))) == text
    # worse on one course: not better, said so
    _lease(lease, {"rugged": 0.95, "stepped": 0.8, "complex": 0.93})
    build.add(str(lease), "2027-01-06", study=str(study))
    results = build.build(str(study))
    assert results["verdict"]["lease"] == "2027-01-06" and not results["verdict"]["init_better"]
    assert "**not better: worse than scratch on some course**" in (study / "report.md").read_text()


def test_no_lease_says_not_measured_yet(tmp_path):
    results = build.build(str(tmp_path))
    assert results["status"] == "not measured yet" and results["verdict"] is None
    text = (tmp_path / "report.md").read_text()
    assert "**Not measured yet**" in text and "bash studies/device/gpu.sh queue studies/any_hexapod/queue.sh" in text


def test_the_better_result_on_validation(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    _write(a, _timing(0.9, 0.01, 200))
    _write(b, _timing(0.9, 0.005, 200))
    assert build.better({"scratch_s1": str(a), "init_s1": str(b)}) == "init_s1"  # the same goals, fewer falls
    _write(b, {"wall_s_to_result": 10})  # not validated
    assert build.better({"scratch_s1": str(a), "init_s1": str(b)}) == "scratch_s1"
    assert build.better({"init_s1": str(tmp_path / "none.json")}) == ""


FAKE_PYTHON = """#!/bin/bash
# train.py / apps: one line per call in $CALLS (the arguments, tab-separated) and their outputs; anything else: python
if [ "$1" = train.py ] || { [ "$1" = -m ] && [[ "$2" == hexnewton.apps.* ]]; }; then
  (IFS=$'\\t'; echo "$*") >> "$CALLS"
  out= ld= ex=
  while [ $# -gt 0 ]; do case $1 in --out) out=$2; shift;; --log_dir) ld=$2; shift;; --experiment) ex=$2; shift;; esac
    shift; done
  if [ -n "$out" ]; then mkdir -p "$out"; echo '{"results": {}}' > "$out/results.json"; exit 0; fi
  [ -z "$ex" ] && exit 0
  run="$ld/$ex/2027-01-05_10-00-00"; mkdir -p "$run"; touch "$run/model_1.pt" "$run/model_result.pt"
  echo '{"wall_s_to_result": 1.0}' > "$run/timing.json"; echo '{}' > "$run/config.json"
  echo "  python play.py --checkpoint $run/model_result.pt"; exit 0
fi
exec "$REAL_PYTHON" "$@"
"""


def _queue(tmp_path, *args, **env) -> subprocess.CompletedProcess:
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir(exist_ok=True)
    (bin_dir / "python").write_text(FAKE_PYTHON)
    (bin_dir / "python").chmod((bin_dir / "python").stat().st_mode | stat.S_IEXEC)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", REAL_PYTHON=sys.executable,
               CALLS=str(tmp_path / "calls"), ROOT=str(tmp_path / "root"), OUT=str(tmp_path / "out"), **env)
    return subprocess.run(["bash", "studies/any_hexapod/queue.sh", *args], cwd=ROOT, env=env, check=True,
                          capture_output=True, text=True)  # fmt: skip


class Parsed(Exception):
    pass


@pytest.mark.skipif(shutil.which("timeout") is None, reason="needs timeout")
def test_the_queue_command_lines_parse_with_the_real_command_lines(tmp_path, monkeypatch):
    from hexnewton.apps import cli, evaluate, export, sim2sim, train

    _queue(tmp_path)
    calls = [line.split("\t") for line in (tmp_path / "calls").read_text().splitlines()]
    trains = [c[1:] for c in calls if c[0] == "train.py"]
    assert len(trains) == 3  # the warm-up, scratch_s1, init_s1, one after another
    assert trains[1][:7] == ["--task", "complex", "--robot", "mx_phoenix", "--seed", "1", "--log_dir"]
    assert "--init" in trains[2] and "--max_iterations" not in trains[1] + trains[2]  # the task's iterations
    apps = {"train": train, "evaluate": evaluate, "export": export, "sim2sim": sim2sim}
    seen = {c[1].rsplit(".", 1)[1] for c in calls if c[0] == "-m"}
    assert seen == {"evaluate", "export", "sim2sim"}
    original = cli.ArgumentParser.parse_args

    def parse_only(self, args=None, namespace=None):
        if self.add_help:  # train.py's first look at --task / --resume / --init has no help
            raise Parsed(original(self, args, namespace))
        return original(self, args, namespace)

    monkeypatch.setattr(cli.ArgumentParser, "parse_args", parse_only)
    parsed = []
    for c in calls:
        app, argv = ("train", c[1:]) if c[0] == "train.py" else (c[1].rsplit(".", 1)[1], c[2:])
        with pytest.raises(Parsed) as got:
            apps[app].main(argv)
        parsed.append((app, got.value.args[0]))
    evals = [ns for app, ns in parsed if app == "evaluate"]
    assert len(evals) == 9 and all(ns.rounds == 1000 and ns.robot == "mx_phoenix" for ns in evals)
    assert all(ns.seed == 1000 and not ns.stochastic for ns in evals)  # the test seed, the deterministic action
    fixed = [ns for ns in evals if ns.controllers == ["cpg"]]
    physics = {"sim.frame_dt": 0.02, "sim.substeps": 4}  # the complex task's, as a policy's evaluation takes it
    assert len(fixed) == 3 and all(cli.config_overrides(ns, "env") == physics for ns in fixed)
    s2s = next(ns for app, ns in parsed if app == "sim2sim")
    assert s2s.rounds == 100 and s2s.workers == 12 and s2s.terrains == list(build.COURSES)
    # collect: the small files in parts, as build.py --add reads them
    _queue(tmp_path, "collect")
    parts = sorted((tmp_path / "out").glob("any_hexapod.tgz.*"))
    (tmp_path / "all.tgz").write_bytes(b"".join(p.read_bytes() for p in parts))
    with tarfile.open(tmp_path / "all.tgz") as tar:
        names = set(tar.getnames())
    assert {"lease.json", "runs/init_s1.log", "policies/init_s1.pt", "policies/scratch_s1.timing.json",
            "runs/scratch_s1/2027-01-05_10-00-00/timing.json", "evals/fixed_cpg_stepped/results.json"} <= names
