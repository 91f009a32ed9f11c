"""studies/startup_beside/preload.py: its reports are the renderings of its measured runs, both modes alternating."""

import glob
import json
import os

import pytest

import preload as study  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))
FOLDERS = sorted(os.path.dirname(p) for p in glob.glob(os.path.join(HERE, "preload*", "results.json")))


def test_a_measured_folder_is_kept():
    assert [os.path.basename(f) for f in FOLDERS][:1] == ["preload"]


@pytest.mark.parametrize("folder", FOLDERS, ids=os.path.basename)
def test_the_committed_report_renders_the_runs(folder):
    with open(os.path.join(folder, "results.json")) as f:
        res = json.load(f)
    with open(os.path.join(folder, "report.md")) as f:
        assert f.read() == study.report(res)
    modes = [r["mode"] for r in res["runs"]]
    assert modes == list(study.MODES) * (len(modes) // 2)  # alternating, each mode as often
    for r in res["runs"]:  # the phase and the module count together, only where preloading (and the finalize ran on)
        preloaded = "kernels beside the build" in r["phases_s"]
        assert preloaded == bool(r["modules_preloaded"]) and (not preloaded or r["mode"] == "preload")


def test_the_gpu_queue_runs_each_ab_on_cuda(tmp_path):
    """queue.sh with a stand-in python: each step's script, 2 runs per mode on cuda, into $TP/<step>."""
    import subprocess

    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    (bin_dir / "python").write_text('#!/bin/bash\necho "$*" >> "$TP/calls"\n')
    (bin_dir / "python").chmod(0o755)
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", TP=str(tmp_path))
    root = os.path.dirname(os.path.dirname(HERE))
    done = subprocess.run(["bash", "studies/startup_beside/queue.sh"], cwd=root, env=env, capture_output=True,
                          text=True)  # fmt: skip
    assert done.returncode == 0 and done.stdout.rstrip().endswith("done"), done.stdout + done.stderr
    assert (tmp_path / "calls").read_text().splitlines() == [
        f"studies/startup_beside/{s}.py --runs 2 --warmup 1 --device cuda --out {tmp_path}/{s}"
        for s in ("scene_first", "preload")]


def test_warm_up_runs_are_kept_apart_from_the_means(tmp_path):
    """--warmup N: N runs of the first mode before the alternating ones, in results.json's ``warmup`` and the report's
    note, not in the runs or the means (a fresh machine's first process pays for its caches)."""
    import alternate

    calls = []

    def fake(mode, num_envs, device):
        calls.append(mode)
        return {"mode": mode, "first_iteration_s": 30.0 if len(calls) == 1 else 20.0, "phases_s": {},
                "finalize_s": 1.0, "modules_preloaded": 27 if mode == "preload" else None}

    alternate.main("preload.py", study.__doc__, study.MODES, fake, study.report,
                   ["--runs", "1", "--warmup", "1", "--out", str(tmp_path)])
    res = json.loads((tmp_path / "results.json").read_text())
    assert calls == ["preload", "preload", "after"] and len(res["warmup"]) == 1 and len(res["runs"]) == 2
    text = (tmp_path / "report.md").read_text()
    assert "1 warm-up run(s) of `preload`" in text and "30.0 s" in text and "preload 20.0 s" in text
