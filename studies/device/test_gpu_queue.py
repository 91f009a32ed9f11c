"""studies/device/gpu.sh's queues on the CPU, with stand-ins for ``python`` and ``nvidia-smi``: a methods queue with
``EVALS_AFTER`` evaluates every run it finished (deterministic and sampled, TD3 deterministic only) and the fixed
CPG, also the runs that end after an evaluation queue has started; no job runs twice."""

import os
import shutil
import stat
import subprocess
import time

import pytest

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

FAKE_PYTHON = """#!/bin/bash
# train.py / baselines: a run folder with a checkpoint after a pause that grows with the name (1-4 s; tenths of a
# second with PAUSE_PREFIX=0.); evaluate: results.json
out= ld= ex=
while [ $# -gt 0 ]; do case $1 in --out) out=$2; shift;; --log_dir) ld=$2; shift;; --experiment) ex=$2; shift;; esac; shift; done
if [ -n "$out" ]; then echo "$out" >> "$(dirname "$out")/../evaluated"; mkdir -p "$out"; echo '{}' > "$out/results.json"; exit 0; fi
echo "training $ex"; sleep "${PAUSE_PREFIX:-}$(( ${#ex} % 4 + 1 ))"; mkdir -p "$ld/$ex/run"; touch "$ld/$ex/run/model_10.pt"
"""


def _tool(folder, name, text):
    path = folder / name
    path.write_text(text)
    path.chmod(path.stat().st_mode | stat.S_IEXEC)


def _env(tmp_path, python: str, **extra) -> dict:
    """The environment of a queue under test: ``python`` (a stand-in's script) first on PATH, then ``extra``."""
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    _tool(bin_dir, "python", python)
    return dict(os.environ, PATH=f"{bin_dir}:{os.environ['PATH']}", **extra)


def _gate_names(cmd: list[str], env: dict, out) -> set[str]:
    """Start a gate queue with ``cmd``, wait for it with ``gate_wait`` and return the names in its ``gate.tgz``."""
    import tarfile

    subprocess.run(cmd, cwd=ROOT, env=env, check=True, capture_output=True)
    waited = subprocess.run(["bash", "studies/device/time_to_skill.sh", "gate_wait", "60"], cwd=ROOT, env=env,
                            check=True, capture_output=True, text=True)
    assert "gate ended" in waited.stdout, waited.stdout
    with tarfile.open(out / "gate.tgz") as tar:
        return set(tar.getnames())


def test_methods_queue_then_evaluations(tmp_path):
    runs = tmp_path / "runs"
    env = _env(tmp_path, FAKE_PYTHON, RUNS=str(runs), OUT=str(tmp_path / "out"),
               JOBS="paper:1 td3_cpg:1 joint:2 sac_cpg:1", PER_GPU="2", EVALS_AFTER="10 rugged stepped", POLL_S="0.1",
               PAUSE_PREFIX="0.")
    _tool(tmp_path / "bin", "nvidia-smi", "#!/bin/bash\necho FakeGPU\n")
    subprocess.run(["bash", "studies/device/gpu.sh", "methods", "complex", "20", "600", "16", "", "0 1"], cwd=ROOT,
                   env=env, check=True, capture_output=True)
    deadline = time.time() + 60
    while time.time() < deadline:
        busy = subprocess.run(["bash", "studies/device/gpu.sh", "busy"], cwd=ROOT, env=env).returncode == 0
        if not busy and (runs / "method_evals.log").exists():
            break
        time.sleep(0.2)
    done = sorted(p.name for p in (runs / "method_evals").iterdir() if (p / "results.json").exists())
    runs_done = ["joint_s2", "paper_s1", "sac_cpg_s1", "td3_cpg_s1"]
    expected = [f"{cpg}_s0_{t}" for cpg in ("cpg", "cpg_frame20") for t in ("rugged", "stepped")]
    expected += [f"{r}_{t}" for r in runs_done for t in ("rugged", "stepped")]
    expected += [f"{r}_{t}_sampled" for r in runs_done if r != "td3_cpg_s1" for t in ("rugged", "stepped")]
    assert done == sorted(expected)
    evaluated = (runs / "evaluated").read_text().split()
    assert len(evaluated) == len(set(evaluated)) == len(expected)
    assert sorted(p.name for p in (runs / "methods").glob("*.done")) == [f"{r}.done" for r in runs_done]


@pytest.mark.skipif(not all(shutil.which(t) for t in ("setsid", "pgrep", "ps")), reason="needs setsid, pgrep and ps")
def test_train_runs_detached_from_the_call(tmp_path):
    """``gpu.sh train`` starts the run detached (setsid): the device tool ends the processes of a
    call when it returns, and the run must outlive it; it returns once the run is past its imports (the next call
    replaces the working tree) and refuses a second run of the same name."""
    runs = tmp_path / "runs"
    env = _env(tmp_path, FAKE_PYTHON, RUNS=str(runs), OUT=str(tmp_path / "out"))
    script = "bash studies/device/gpu.sh train r1 0 -- --task complex; ps -o sid= -p $$"
    call = subprocess.run(["setsid", "bash", "-c", script], cwd=ROOT, env=env, check=True, capture_output=True, text=True)
    call_session = int(call.stdout.split()[-1])
    run = subprocess.run(["pgrep", "-f", "--", "--experiment r1"], capture_output=True, text=True).stdout.split()
    assert run, call.stdout
    assert all(int(subprocess.run(["ps", "-o", "sid=", "-p", pid], capture_output=True, text=True).stdout or -1)
               != call_session for pid in run)
    assert (runs / "r1.log").read_text().startswith("training r1")  # started past its imports
    again = subprocess.run(["bash", "studies/device/gpu.sh", "train", "r1", "0", "--", "--task", "complex"], cwd=ROOT,
                           env=env, capture_output=True, text=True)
    assert again.returncode == 1 and "running already" in again.stderr  # a second r1 would overwrite the first's log
    deadline = time.time() + 30
    while time.time() < deadline and not (runs / "r1" / "run" / "model_10.pt").exists():
        time.sleep(0.5)
    assert (runs / "r1" / "run" / "model_10.pt").exists()


FAKE_TRAIN_EVAL = """#!/bin/bash
# train.py: a run folder with its result and the line gate reads it from; evaluate: results.json; anything else: ok
out= ld= ex=
while [ $# -gt 0 ]; do case $1 in --out) out=$2; shift;; --log_dir) ld=$2; shift;; --experiment) ex=$2; shift;; esac; shift; done
if [ -n "$out" ]; then mkdir -p "$out"; echo '{}' > "$out/results.json"; echo "report in $out"; exit 0; fi
[ -z "$ex" ] && exit 0
mkdir -p "$ld/$ex/run"; touch "$ld/$ex/run/model_result.pt"; echo '{}' > "$ld/$ex/run/timing.json"
echo "training $ex"; echo "  python play.py --checkpoint $ld/$ex/run/model_result.pt"
"""


def test_gate_queue_trains_evaluates_and_packs(tmp_path):
    """``time_to_skill.sh gate`` (the one-command gate on a 4-GPU machine): each seed's run of ``$TASK``, then its
    result on every terrain beside ``SEED_AFTER`` (here studies/device/capability.sh's curves and named points, one
    evaluate each); the shipped policy and the fixed CPG; GPU 3's further work; ``gate_wait`` packs what finished."""
    runs, out = tmp_path / "runs", tmp_path / "out"
    env = _env(tmp_path, FAKE_TRAIN_EVAL, RUNS=str(runs), OUT=str(out),
               KEEP=str(tmp_path / "keep"), SEEDS="1 2", TASK="complex-margin", CURVES="step_rise payload",
               GPU3_AFTER='python -m hexnewton.apps.evaluate --out "$RUNS"/extra/curve',
               SEED_AFTER='C=studies/device/capability.sh; FOREGROUND=1 bash $C curves $NAME $CKPT &'
                          ' FOREGROUND=1 bash $C points $NAME $CKPT; wait')  # fmt: skip
    names = _gate_names(["bash", "studies/device/time_to_skill.sh", "gate", "--max_iterations", "5"], env, out)
    assert "--task complex-margin --seed 1 --max_iterations 5" in (runs / "seed1.sh").read_text()
    for job in ("seed1_rugged", "seed2_complex", "shipped_stepped", "cpg_rugged"):
        assert f"eval_{job}/results.json" in names
    assert "extra/curve/results.json" in names and "seed2.log" in names
    points = ("rise8", "tread20", "blocks8", "friction03", "motors50", "payload1")
    for seed in ("seed1", "seed2"):
        for job in ("step_rise", "payload", *(f"at_{p}" for p in points)):
            assert f"extra/{seed}_{job}/results.json" in names and f"extra/{seed}_{job}.log" in names
    commands = (runs / "commands.txt").read_text()
    assert "--sweep payload --no-nominal" in commands and "--sweep randomization.payload 1.0" in commands
    assert sorted(os.listdir(tmp_path / "keep")) == ["seed1.pt", "seed2.pt"]
    assert list(out.glob("gate_ckpt.tgz.*"))


def test_capability_margin_lease(tmp_path):
    """``capability.sh margin``: the gate of ``complex-margin`` with each seed's curves and named points, the shipped
    policy's curves with the fixed CPG, the README command's run and its result's curves; all packed by gate_wait."""
    runs, out = tmp_path / "runs", tmp_path / "out"
    env = _env(tmp_path, FAKE_TRAIN_EVAL, RUNS=str(runs), OUT=str(out), KEEP=str(tmp_path / "keep"), SEEDS="1",
               CURVES="friction")
    names = _gate_names(["bash", "studies/device/capability.sh", "margin"], env, out)
    assert "--task complex-margin --seed 1" in (runs / "seed1.sh").read_text()
    for job in ("seed1_friction", "seed1_at_blocks8", "shipped_friction", "readme_friction"):
        assert f"extra/{job}/results.json" in names, sorted(names)
    assert "extra/readme_train.log" in names
    commands = (runs / "commands.txt").read_text()
    shipped = [c for c in commands.splitlines() if "extra/shipped_friction" in c]
    assert len(shipped) == 1 and "--controllers cpg cpg_rl" in shipped[0] and "CUDA_VISIBLE_DEVICES=3" in shipped[0]
    assert sorted(os.listdir(tmp_path / "keep")) == ["readme.pt", "seed1.pt"]


FAKE_SLOW_EVAL = """#!/bin/bash
# evaluate: counts the evaluations running beside it (marker files), then results.json
out=
while [ $# -gt 0 ]; do case $1 in --out) out=$2; shift;; esac; shift; done
d=$(dirname "$out"); touch "$out.running"; ls "$d"/*.running | wc -l >> "$d/../concurrency"; sleep 1
mkdir -p "$out"; echo '{}' > "$out/results.json"; rm "$out.running"
"""


def test_capability_jobs_at_most_max_jobs_at_once(tmp_path):
    """``capability.sh curves`` runs one evaluation per curve, at most ``MAX_JOBS`` at once, and skips finished ones."""
    runs = tmp_path / "runs"
    env = _env(tmp_path, FAKE_SLOW_EVAL, RUNS=str(runs), MAX_JOBS="2", FOREGROUND="1")
    subprocess.run(["bash", "studies/device/capability.sh", "curves", "p", "ck.pt"], cwd=ROOT, env=env, check=True,
                   capture_output=True, timeout=120)  # fmt: skip
    done = sorted(d.name for d in (runs / "extra").iterdir() if (d / "results.json").exists())
    assert len(done) == 8 and done[0] == "p_action_delay"
    assert max(int(n) for n in (runs / "concurrency").read_text().split()) <= 2
    (runs / "concurrency").unlink()
    subprocess.run(["bash", "studies/device/capability.sh", "curves", "p", "ck.pt"], cwd=ROOT, env=env, check=True,
                   capture_output=True, timeout=120)  # fmt: skip
    assert not (runs / "concurrency").exists()  # every curve finished: nothing runs again


FAKE_TRAIN_EVAL = """#!/bin/bash
# train.py: a run folder whose result is an earlier checkpoint, named on the console as train.py names it;
# evaluate (-m hexnewton.apps.evaluate ... --out DIR): a report
out= ld= ex=
while [ $# -gt 0 ]; do case $1 in --out) out=$2; shift;; --log_dir) ld=$2; shift;; --experiment) ex=$2; shift;; esac; shift; done
if [ -n "$out" ]; then mkdir -p "$out"; echo '{}' > "$out/results.json"; printf '| rugged | CPG_RL |\\n' > "$out/report.md"; exit 0; fi
run="$ld/$ex/2026-01-01"; mkdir -p "$run"; touch "$run/config.json" "$run/model_250.pt" "$run/model_299.pt"
cp "$run/model_250.pt" "$run/model_result.pt"
echo "training $ex"; echo "  python play.py --checkpoint $run/model_result.pt"
"""


def test_candidates_train_pack_and_evaluate_in_one_call(tmp_path):
    """candidates.sh: each pipeline trains, packs (the chosen result travels in the archive) and evaluates its result
    on validation rounds, or on the named capability points; with ``S2S_ROUNDS`` a validation candidate's bundle
    runs in C MuJoCo beside its evaluations; the evaluations come back in one archive."""
    import tarfile

    out, keep = tmp_path / "out", tmp_path / "keep"
    env = _env(tmp_path, FAKE_TRAIN_EVAL, RUNS=str(tmp_path / "runs"), OUT=str(out), KEEP=str(keep),
               EVALS=str(tmp_path / "evals"), LIMIT="60", VAL_TERRAINS="rugged stepped", S2S_ROUNDS="2")
    done = subprocess.run(["bash", "studies/device/candidates.sh", "a1@0:--task complex --seed 1",
                           "m1@1:points:--task complex-margin --seed 1"], cwd=ROOT, env=env, check=True,
                          capture_output=True, text=True)  # fmt: skip
    assert "a1: evaluations ended" in done.stdout and "m1: evaluations ended" in done.stdout, done.stdout
    with tarfile.open(out / "run_a1.tgz") as tar:  # the result, not the last checkpoint beside it (PACK_LAST=1)
        assert "2026-01-01/model_result.pt" in tar.getnames() and "a1.log" in tar.getnames()
        assert "2026-01-01/model_299.pt" not in tar.getnames()
    assert (keep / "a1.pt").is_file() and (keep / "m1.pt").is_file()
    with tarfile.open(out / "evals.tgz") as tar:
        names = set(tar.getnames())
    assert {"./a1_rugged/results.json", "./a1_stepped/results.json"} <= names
    assert "./extra/m1_at_rise8/results.json" in names and "./extra/m1_at_payload1/results.json" in names
    assert not any(n.startswith("./m1_") for n in names)  # points only for the points pipeline
    assert "./s2s_a1/results.json" in names and "./bundle_a1" in names  # the bundle in MuJoCo, beside
    assert not any(n.startswith(("./s2s_m1", "./bundle_m1")) for n in names)
    assert "sim2sim exit 0" in (tmp_path / "evals" / "s2s_a1.log").read_text()


def test_queue_and_poll(tmp_path):
    """gpu.sh queue runs a file detached from the call; poll waits for it, shows its log and copies what it made into
    $OUT; on a machine where no queue was started (a fresh one) poll answers at once with exit 3."""
    out, q = tmp_path / "out", tmp_path / "queue"
    env = dict(os.environ, OUT=str(out), RUNS=str(tmp_path / "runs"), KEEP=str(tmp_path / "keep"), QUEUE=str(q))
    t0 = time.time()
    lost = subprocess.run(["bash", "studies/device/gpu.sh", "poll", "60"], cwd=ROOT, env=env, capture_output=True,
                          text=True)  # fmt: skip
    assert lost.returncode == 3 and "the queue and its outputs are lost" in lost.stderr
    assert time.time() - t0 < 10
    made = tmp_path / "made.txt"
    work = tmp_path / "work.sh"
    work.write_text(f"sleep 2; echo step one; echo done > {made}; exit 4\n")
    started = subprocess.run(["bash", "studies/device/gpu.sh", "queue", str(work)], cwd=ROOT, env=env, check=True,
                             capture_output=True, text=True)  # fmt: skip
    assert "started the queue" in started.stdout
    again = subprocess.run(["bash", "studies/device/gpu.sh", "queue", str(work)], cwd=ROOT, env=env,
                           capture_output=True, text=True)  # fmt: skip
    assert again.returncode == 1 and "running already" in again.stderr
    polled = subprocess.run(["bash", "studies/device/gpu.sh", "poll", "60", str(tmp_path / "made*")], cwd=ROOT,
                            env=env, check=True, capture_output=True, text=True)  # fmt: skip
    assert "the queue ended (exit 4)" in polled.stdout and "step one" in polled.stdout
    assert (out / "made.txt").read_text() == "done\n"  # the glob, given before the file existed, expanded after
    missing = subprocess.run(["bash", "studies/device/gpu.sh", "queue", str(tmp_path / "none.sh")], cwd=ROOT, env=env,
                             capture_output=True, text=True)  # fmt: skip
    assert missing.returncode == 2 and "no file" in missing.stderr


def test_a_queue_of_several_files_runs_them_in_turn(tmp_path):
    """gpu.sh queue A B: B starts when A has ended, whatever A's exit status; the queue's status is the last nonzero."""
    env = dict(os.environ, OUT=str(tmp_path / "out"), QUEUE=str(tmp_path / "queue"))
    order = tmp_path / "order.txt"
    a, b = tmp_path / "a.sh", tmp_path / "b.sh"
    a.write_text(f"sleep 1; echo a >> {order}; exit 4\n")
    b.write_text(f"echo b >> {order}\n")
    missing = subprocess.run(["bash", "studies/device/gpu.sh", "queue", str(a), str(tmp_path / "none.sh")], cwd=ROOT,
                             env=env, capture_output=True, text=True)  # fmt: skip
    assert missing.returncode == 2 and "no file" in missing.stderr and not order.exists()
    for cmd in (["queue", str(a), str(b)], ["poll", "60"]):
        done = subprocess.run(["bash", "studies/device/gpu.sh", *cmd], cwd=ROOT, env=env, check=True,
                              capture_output=True, text=True)  # fmt: skip
    assert "the queue ended (exit 4)" in done.stdout and f"queue: {b}" in done.stdout
    assert order.read_text() == "a\nb\n"


def test_sample_scaled_queue_on_two_gpus(tmp_path):
    """studies/device/sample_scaled.sh on a 2-GPU machine: the three seeds of the sample-scaled recipe and the recipe's
    seed 1, two runs at a time, each packed with its validation rounds; no scale-out on fewer than 4 GPUs."""
    cand, args = tmp_path / "cand", tmp_path / "args.txt"
    env = _env(tmp_path, FAKE_TRAIN_EVAL.replace("#!/bin/bash\n", '#!/bin/bash\necho "$@" >> "$ARGS_LOG"\n', 1),
               ARGS_LOG=str(args), CAND=str(cand), SO_OUT=str(tmp_path / "so"), RUNS=str(tmp_path / "runs"),
               KEEP=str(tmp_path / "keep"), EVALS=str(tmp_path / "evals"), LIMIT="60", S2S_ROUNDS="",
               VAL_TERRAINS="rugged")  # fmt: skip
    _tool(tmp_path / "bin", "nvidia-smi", "#!/bin/bash\necho 'GPU 0: H100'; echo 'GPU 1: H100'\n")
    env["QUEUE"] = str(tmp_path / "queue")  # as a lease starts it: one detached queue, polled
    for cmd in (["queue", "studies/device/sample_scaled.sh"], ["poll", "120"]):
        done = subprocess.run(["bash", "studies/device/gpu.sh", *cmd], cwd=ROOT, env=env, check=True,
                              capture_output=True, text=True)  # fmt: skip
    assert "the queue ended (exit 0)" in done.stdout, done.stdout
    assert "item 1 ended" in done.stdout and "item 2" not in done.stdout
    assert {p.name for p in cand.iterdir()} == {"run_rep1.tgz", "run_rep2.tgz", "run_rep3.tgz", "run_recipe1.tgz",
                                                 "evals_a.tgz", "evals_b.tgz"}  # fmt: skip
    trained = [line for line in args.read_text().splitlines() if line.startswith("train.py")]
    rep3 = next(line for line in trained if "--experiment rep3" in line)
    assert "--num_envs 16384 --max_iterations 150 --agent.save_interval 13 --env.terrain.climb 2" in rep3
    assert "--agent.algorithm.num_mini_batches 8 --agent.stages ((25," in rep3 and "--seed 3" in rep3
    assert any("--num_envs 4096 --seed 1" in line and "--experiment recipe1" in line for line in trained)
    assert not (tmp_path / "so").exists()
    # the one-GPU flags compute what g4cmi600's 4 ranks do: the same iterations, checkpoints, stages, and mini-batches
    # of the same size (16384 envs in 8 against 4096 per rank in 8, the ranks' gradients averaged)
    from hexnewton.apps.train import _base_task, configs, parser

    def agent_of(argv):
        base, ckpt = _base_task(argv)
        return configs(parser(base, False).parse_args(argv), base, ckpt)

    env1, one = agent_of(rep3.split()[1:rep3.split().index("--log_dir")])
    env4, four = agent_of("--task complex --num_envs 4096 --max_iterations 600 --env.terrain.climb 2 "
                          "--agent.scale_with_ranks mini_batches iterations".split())  # fmt: skip
    four = four.for_ranks(4)
    assert (one.max_iterations, one.save_interval, one.stages) == (four.max_iterations, four.save_interval, four.stages)
    assert one.algorithm.num_mini_batches == four.algorithm.num_mini_batches == 8
    assert one.to_rsl_rl(16384)["num_steps_per_env"] == four.to_rsl_rl(4096)["num_steps_per_env"]
    assert env1.terrain.climb == env4.terrain.climb == 2


def test_aside_moves_the_studies_data_out_and_back(tmp_path):
    """aside.sh: the named folders leave the tree (a device call's size drops) and come back unchanged; KEEP leaves a
    folder in; a second ``out`` over folders already set aside refuses; bad words get one usage line."""
    repo, aside = tmp_path / "repo", tmp_path / "aside"
    (repo / "studies/device").mkdir(parents=True)
    shutil.copy(os.path.join(ROOT, "studies/device/aside.sh"), repo / "studies/device/aside.sh")
    for folder in ("studies/big/data", "studies/runs", "studies/kept"):
        (repo / folder).mkdir(parents=True)
        (repo / folder / "blob.bin").write_bytes(os.urandom(3 * 1048576))
    git = dict(cwd=repo, check=True, capture_output=True)
    subprocess.run(["git", "init", "-q"], **git)
    subprocess.run(["git", "add", "-A"], **git)
    env = dict(os.environ, ASIDE=str(aside), FOLDERS="studies/big studies/runs studies/kept studies/none",
               KEEP="studies/kept")  # fmt: skip
    run = dict(cwd=repo, env=env, capture_output=True, text=True)
    assert subprocess.run(["bash", "studies/device/aside.sh", "size"], **run).stdout.strip() == "tree 9 MiB"
    out = subprocess.run(["bash", "studies/device/aside.sh", "out"], **run)
    assert out.returncode == 0 and out.stdout.startswith("tree 3 MiB, set aside in"), out.stdout + out.stderr
    assert out.stdout.rstrip().endswith("set aside in " + str(aside) + ": studies/big studies/runs")
    assert (aside / "studies/big/data/blob.bin").is_file() and not (repo / "studies/big").exists()
    size = subprocess.run(["bash", "studies/device/aside.sh", "bytes"], **run)  # tracked files set aside: skipped
    assert size.returncode == 0 and 3 * 1048576 <= int(size.stdout) < 4 * 1048576, size.stdout + size.stderr
    assert (repo / "studies/kept/blob.bin").is_file() and not (aside / "studies/kept").exists()
    (repo / "studies/runs").mkdir()
    again = subprocess.run(["bash", "studies/device/aside.sh", "out"], **run)
    assert again.returncode == 1 and "exists already" in again.stderr
    (repo / "studies/runs").rmdir()
    back = subprocess.run(["bash", "studies/device/aside.sh", "back"], **run)
    assert back.returncode == 0 and back.stdout.strip() == "tree 9 MiB", back.stdout + back.stderr
    assert (repo / "studies/runs/blob.bin").is_file() and not (aside / "studies/runs").exists()
    bad = subprocess.run(["bash", "studies/device/aside.sh", "over"], **run)
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1 and bad.stderr.startswith("usage:")
