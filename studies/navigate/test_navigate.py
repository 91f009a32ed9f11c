"""The navigate study's measurement (``studies/navigate/mesh_cost.py``): its report is the rendering of its numbers, and
those numbers are of the patch the navigate tasks build today."""

import json
import os

import pytest

from mesh_cost import _report  # this study's module (pytest puts the study's folder on sys.path)

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

HERE = os.path.dirname(os.path.abspath(__file__))


def _saved() -> dict:
    with open(os.path.join(HERE, "mesh", "results.json")) as f:
        return json.load(f)


def test_report_renders_the_results():
    saved = _saved()
    with open(os.path.join(HERE, "mesh", "report.md")) as f:
        assert f.read() == _report(saved["rows"], saved["command"], saved["machine"])


def test_the_measured_patch_is_the_tasks():
    """navigate-rugged's terrain as the task builds it now: the same patch and the same collision triangles."""
    import newton

    from hexnewton.terrain import make_terrain
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


FAKE_PYTHON = """#!/bin/bash
# train.py: a run folder with a result and timing.json; the apps: their --out folder; every call noted in order
echo "$*" >> "$NAV/calls"
args=("$@"); out= ld= task=
for ((i = 0; i < $#; i++)); do case ${args[i]} in --out) out=${args[i+1]};; --log_dir) ld=${args[i+1]};;
  --task) task=${args[i+1]};; --video) touch "${args[i+1]}";; esac; done
if [ -n "$ld" ]; then mkdir -p "$ld/hexnewton_$task/run"; touch "$ld/hexnewton_$task/run/model_result.pt"
  echo '{}' > "$ld/hexnewton_$task/run/timing.json"; fi
if [ -n "$out" ]; then mkdir -p "$out"; echo '{}' > "$out/results.json"; fi
exit 0
"""


def test_the_queue_finishes_the_flat_task_whole_before_the_rugged_one(tmp_path):
    """queue.sh with a stand-in python: navigate-flat is trained, evaluated, exported and run in C MuJoCo
    before navigate-rugged starts, and every step's outputs are packed as they come."""
    import subprocess

    bin_dir, out, call_out = tmp_path / "bin", tmp_path / "navigate", tmp_path / "call_out"
    bin_dir.mkdir()
    call_out.mkdir()
    (bin_dir / "python").write_text(FAKE_PYTHON)
    (bin_dir / "python").chmod(0o755)
    # the device sets $OUT for every call and empties it at the next: the queue keeps its outputs in $NAV
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", NAV=str(out), OUT=str(call_out), ROUNDS="4",
               S2S_ROUNDS="2")  # fmt: skip
    root = os.path.dirname(os.path.dirname(HERE))
    done = subprocess.run(["bash", "studies/navigate/queue.sh"], cwd=root, env=env, capture_output=True, text=True)
    assert done.returncode == 0 and done.stdout.rstrip().endswith("queue ended"), done.stdout + done.stderr
    calls = (out / "calls").read_text().splitlines()
    steps = [w[1] if w[0] == "-m" else w[0] for w in map(str.split, calls)]  # the script or the module run
    assert steps == ["train.py", "hexnewton.apps.evaluate", "hexnewton.apps.export", "hexnewton.apps.sim2sim",
                     "train.py", "hexnewton.apps.evaluate", "hexnewton.apps.export"]  # fmt: skip
    assert "--task navigate-flat" in calls[0] and "--task navigate-rugged" in calls[4]
    assert sorted(p.name for p in out.glob("*.tgz")) == ["eval_flat.tgz", "eval_rugged.tgz", "s2s_flat.tgz",
                                                          "train_flat.tgz", "train_rugged.tgz"]  # fmt: skip
    assert not list(call_out.iterdir())


def test_the_queue_evaluates_a_kept_policy_without_training_it(tmp_path):
    """TASKS=rugged TRAINED=rugged: the study's kept policy is evaluated and exported, nothing is trained."""
    import subprocess

    bin_dir, out = tmp_path / "bin", tmp_path / "navigate"
    bin_dir.mkdir()
    (bin_dir / "python").write_text(FAKE_PYTHON)
    (bin_dir / "python").chmod(0o755)
    root = os.path.dirname(os.path.dirname(HERE))
    kept = tmp_path / "runs"
    (kept / "rugged").mkdir(parents=True)
    (kept / "rugged" / "policy.pt").write_bytes(b"a kept policy")
    env = dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", NAV=str(out), TASKS="rugged", TRAINED="rugged",
               KEPT_RUNS=str(kept))
    done = subprocess.run(["bash", "studies/navigate/queue.sh"], cwd=root, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr
    calls = (out / "calls").read_text().splitlines()
    assert [w[1] if w[0] == "-m" else w[0] for w in map(str.split, calls)] == [
        "hexnewton.apps.evaluate", "hexnewton.apps.export"]
    assert all(f"{kept}/rugged/policy.pt" in c for c in calls)
    assert sorted(p.name for p in out.glob("*.tgz")) == ["eval_rugged.tgz"]


def _build():
    import importlib.util

    spec = importlib.util.spec_from_file_location("navigate_build", os.path.join(HERE, "build.py"))
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


TRAIN_LOG = """training task navigate-rugged: 4096 envs on cuda:0, 1500 iterations, logs in /root/navigate/logs/x
start-up 38.7 s from process start: python and imports 15.3
iteration 1009/1499  goals 0.31  fell 0.004  off course 0.000  distance 0.85 m  0.37 s/it  0:06:29
finished at iteration 1010 after 390 s (the --max_minutes limit)
last episodes: fell_rate 0.004, off_course_rate 0.000, success_rate 0.000, timeout_rate 0.996, nonfinite_rate 0.000, distance_m 0.851, length_steps 996.632, goals_reached 0.305, episodes 1024, window 1024
deterministic validation, 256 rounds of the rugged course (seed 3000) per candidate, 31 s:
     model_best.pt (best training goals per episode 0.331, iteration 870): goal 93.0 %, fell before the goal 0.4 % (in all 0.4 %), off course 0.0 %, pitch / roll var 46.0 / 18.0 deg²
  -> model_1010.pt (last, iteration 1010): goal 95.3 %, fell before the goal 0.0 % (in all 0.0 %), off course 0.0 %, pitch / roll var 46.8 / 19.4 deg²
462 s from process start to the exported result
"""


def test_the_train_log_gives_the_runs_time_and_its_choice():
    info = _build().parse_train_log(TRAIN_LOG)
    assert (info["task"], info["num_envs"], info["device"], info["max_iterations"]) == ("navigate-rugged", 4096,
                                                                                        "cuda:0", 1500)
    assert (info["startup_s"], info["train_s"], info["last_iteration"], info["wall_s_to_result"]) == (38.7, 390, 1010,
                                                                                                       462)
    assert info["stopped_by"] == "the --max_minutes limit" and info["validation_rounds"] == 256
    assert (info["goals_per_episode"], info["last_episodes"]) == (0.305, 1024)
    best, last = info["candidates"]
    assert (best["why"], best["iteration"], best["goal"], best["chosen"]) == (
        "best training goals per episode 0.331", 870, 0.93, False)
    assert (last["checkpoint"], last["goal"], last["fell_before_goal"], last["chosen"]) == ("model_1010.pt", 0.953,
                                                                                            0.0, True)


def test_the_committed_report_renders_what_the_study_keeps():
    """report.md and results.json are build.py's rendering of runs/, eval/, sim2sim/ and media/; a task whose
    evaluation is missing is listed as partial; every target line comes from the kept evaluations."""
    build = _build()
    with open(os.path.join(HERE, "results.json")) as f:
        kept = json.load(f)
    if build.raw_missing():  # the console logs left the tree: the committed results.json renders report.md
        res = kept
        with pytest.raises(RuntimeError, match="not tracked"):
            build.build()
    else:
        res = build.load()
        assert kept == json.loads(json.dumps(res))
    with open(os.path.join(HERE, "report.md")) as f:
        assert f.read() == build.render(res)
    with open(os.path.join(HERE, "..", "house", "kept.json")) as f:
        held = json.load(f)["files"]  # the kept checkpoints in git history (studies/house/kept.py fetch)
    for t in build.TASKS:  # the kept policies the queue evaluates again (TRAINED=T): a link to a shipped one or held
        path = f"studies/navigate/runs/{t}/policy.pt"
        assert os.path.islink(os.path.join(HERE, "runs", t, "policy.pt")) or held[path]["bytes"] < 2_000_000
    missing = [f"navigate-{t}: evaluation" for t in build.TASKS if t not in res["evaluation"]]
    assert [p for p in res["partial"] if p.endswith("evaluation")] == missing
    assert {c["terrain"] for c in res["targets"]} == set(res["evaluation"]) - set(build.VARIANTS)
    for name, v in res["variants"].items():  # a task trained with other flags: its lines beside, never the task's
        assert name in build.VARIANTS and name in res["evaluation"] and name in res["training"]
        assert {c["terrain"] for c in v["targets"]} == {build.VARIANTS[name][0]} and v["flags"] in build.render(res)


def test_bad_input_is_one_line(tmp_path):
    import subprocess
    import sys

    for args, says in ((["--add", str(tmp_path)], "no navigate outputs"), (["video", "moon"], "expected 'video TASK'")):
        done = subprocess.run([sys.executable, os.path.join(HERE, "build.py"), *args], capture_output=True, text=True)
        assert done.returncode == 1 and done.stderr.startswith("build.py: ") and says in done.stderr
        assert len(done.stderr.strip().splitlines()) == 1


def test_add_keeps_an_evaluation_alone_with_its_code(tmp_path):
    """A lease that only evaluated a kept policy (TASKS=rugged TRAINED=rugged): its evaluation is kept with the commit
    it ran, the runs are left as they are."""
    build = _build()
    lease = tmp_path / "lease"
    (lease / "eval_rugged").mkdir(parents=True)
    (lease / "eval_rugged" / "results.json").write_text("{}")
    (lease / "eval_rugged" / "report.md").write_text("# r")
    (lease / "eval_rugged" / "stray.txt").write_text("x")
    build.HERE = str(tmp_path / "study")
    assert build.add(str(lease), "abc1234") == ["rugged"]
    kept = tmp_path / "study" / "eval" / "rugged"
    assert sorted(p.name for p in kept.iterdir()) == ["lease.json", "report.md", "results.json"]
    assert json.loads((kept / "lease.json").read_text())["revision"] == "abc1234"
    assert not (tmp_path / "study" / "runs").exists()


def test_add_writes_a_new_policy_beside_the_shipped_one_a_run_links_to(tmp_path):
    """runs/flat/policy.pt links to the shipped results/policies/cpg_rl_navigate_flat.pt (the same file); a lease's
    new flat result replaces the link, never the shipped file."""
    assert os.readlink(os.path.join(HERE, "runs", "flat", "policy.pt")) == os.path.join(
        "..", "..", "..", "..", "results", "policies", "cpg_rl_navigate_flat.pt")
    build = _build()
    shipped = os.path.join(HERE, "..", "..", "results", "policies", "cpg_rl_navigate_flat.pt")
    (tmp_path / "shipped.pt").write_bytes(open(shipped, "rb").read())
    runs = tmp_path / "study" / "runs" / "flat"
    runs.mkdir(parents=True)
    (runs / "policy.pt").symlink_to(tmp_path / "shipped.pt")
    lease = tmp_path / "lease"
    (lease / "keep").mkdir(parents=True)
    (lease / "train_flat.log").write_text(TRAIN_LOG.replace("navigate-rugged", "navigate-flat"))
    (lease / "keep" / "navigate_flat.pt").write_bytes(open(shipped, "rb").read())
    build.HERE = str(tmp_path / "study")
    assert build.add(str(lease), "abc1234") == ["flat"]
    assert not (runs / "policy.pt").is_symlink() and (runs / "policy.pt").stat().st_size < 2_000_000
    assert (tmp_path / "shipped.pt").read_bytes() == open(shipped, "rb").read()
