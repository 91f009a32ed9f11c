"""train.py and the runner (hexnewton/apps/train.py, runner.py, stopping.py): checkpoints, ONNX and TensorBoard, seeding,
resume, interruption, torchrun ranks, stop rules, the stable-gait stages, start-up timing, the progress line, the
best checkpoint."""

import glob
import json
import os
import re
import signal
import subprocess
import sys
import time

import pytest
import torch

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


def test_training_writes_checkpoint_onnx_and_tensorboard(trained):
    logs, out = trained
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    files = {p.rsplit("/", 1)[1] for p in glob.glob(run_dir + "/*")}
    assert {"model_0.pt", "model_1.pt", "policy.onnx", "config.json"} <= files
    assert any(f.startswith("events.out.tfevents") for f in files)
    assert "onnxruntime vs torch" in out
    import onnx

    model = onnx.load(run_dir + "/policy.onnx")  # one self-contained file, dynamic batch
    assert not glob.glob(run_dir + "/*.onnx.data")
    assert model.graph.input[0].type.tensor_type.shape.dim[0].dim_param
    assert model.graph.input[0].type.tensor_type.shape.dim[1].dim_value == 59


def _train(logs, *args, timeout=900):
    task = [] if "--resume" in args else ["--task", "flat"]  # a resumed run continues its own task
    cmd = [sys.executable, "train.py", "--num_envs", "8", "--device", "cpu", *task, "--log_dir", str(logs),
           "--agent.num_steps_per_env", "8", "--agent.validation_rounds", "0", *args]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    return proc.stdout


def _run_dirs(logs, experiment):
    return sorted(glob.glob(str(logs / experiment / "*")))


def _actor(path):
    return torch.load(path, weights_only=False)["actor_state_dict"]


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_same_seed_same_first_iteration_on_cpu(tmp_path):
    """Seeds reach torch, numpy and the env's resets: the same seed gives the same first update."""
    for name, seed in (("a", "3"), ("b", "3"), ("c", "4")):
        _train(tmp_path, "--max_iterations", "1", "--seed", seed, "--experiment", name)
    a, b, c = (_actor(glob.glob(str(tmp_path / n / "*" / "model_0.pt"))[0]) for n in "abc")
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not all(torch.equal(a[k], c[k]) for k in a)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_resume_continues_iterations_and_learning_rate(tmp_path):
    """2 iterations + resume 2 numbers its iterations like 4 straight ones and keeps the adapted learning rate and
    the physics it was trained under."""
    _train(tmp_path, "--max_iterations", "2", "--experiment", "part", "--env.sim.frame_dt", "0.02",
           "--env.sim.substeps", "2", "--agent.distribution.name", "gaussian")  # fmt: skip
    (first,) = _run_dirs(tmp_path, "part")
    ck = torch.load(first + "/model_1.pt", weights_only=False)
    lr_saved = ck["optimizer_state_dict"]["param_groups"][0]["lr"]
    time.sleep(1.1)  # run directories are named by the second
    out = _train(tmp_path, "--max_iterations", "2", "--experiment", "part", "--resume",
                 first + "/model_1.pt", "--agent.distribution.init_std", "0.2",
                 "--agent.distribution.learn_std", "false")  # fmt: skip
    assert "continuing at iteration 2" in out
    second = _run_dirs(tmp_path, "part")[1]
    assert os.path.isfile(second + "/model_3.pt") and torch.load(second + "/model_3.pt", weights_only=False)["iter"] == 3
    meta = json.loads(open(second + "/config.json").read())["hexnewton"]
    sim = meta["config"]["sim"]
    assert meta["agent"]["distribution"]["name"] == "gaussian"  # a resumed run keeps its action distribution
    assert (sim["frame_dt"], sim["substeps"]) == (0.02, 2)  # from the checkpoint: no --env.sim.* on the resume
    # agent.distribution.init_std on a resume replaced the checkpoint's learnt std
    std = torch.load(second + "/model_3.pt", weights_only=False)["actor_state_dict"]["distribution.std_param"]
    assert ck["actor_state_dict"]["distribution.std_param"].sub(0.2).abs().max() > 1e-3
    torch.testing.assert_close(std, torch.full_like(std, 0.2))
    lr = read_scalars_lr(second)
    assert f"learning rate {lr_saved:.2e}" in out  # the resumed optimizer starts at the saved rate, not the preset's
    steps = 2 * 4  # the default update's mini-batches x epochs: one adaptive x1.5 (or /1.5) step each at most
    assert sorted(lr) == [2, 3] and lr_saved / 1.5**steps * 0.999 <= lr[2] <= lr_saved * 1.5**steps * 1.001
    _train(tmp_path, "--max_iterations", "4", "--experiment", "straight")
    assert sorted(read_scalars_lr(_run_dirs(tmp_path, "straight")[0])) == [0, 1, 2, 3]


def read_scalars_lr(run_dir):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(run_dir)
    acc.Reload()
    return {e.step: e.value for e in acc.Scalars("Loss/learning_rate")}


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_interrupt_saves_and_exports(tmp_path):
    """SIGINT in the middle of training: a final checkpoint and the ONNX policy are written, exit status 130 (128 +
    SIGINT: a queue never takes a stopped run for a finished one)."""
    cmd = [sys.executable, "train.py", "--num_envs", "8", "--device", "cpu", "--task", "flat", "--agent.validation_rounds", "0", "--log_dir",
           str(tmp_path), "--agent.num_steps_per_env", "8", "--max_iterations", "100000", "--agent.save_interval", "1"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 600  # interrupt once training is under way (iteration 1 saved), whatever the load
    while not glob.glob(str(tmp_path / "*" / "*" / "model_1.pt")) and time.time() < deadline:
        time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 130, out[-2000:] + err[-3000:]
    assert "stopped by SIGINT" in out
    (run,) = glob.glob(str(tmp_path / "*" / "*"))
    final = re.search(r"saving (model_\d+\.pt)", out).group(1)  # the checkpoint written on the interrupt
    assert int(final[6:-3]) >= 1 and os.path.isfile(os.path.join(run, final))
    assert os.path.isfile(run + "/policy.onnx")
    assert not glob.glob(run + "/*.tmp")  # atomic saves leave no temporary file


def test_torchrun_ranks_devices_and_seeds():
    """torchrun's variables pick cuda:LOCAL_RANK (or the CPU when asked) and rank-offset seeds; a plain run is
    unchanged (no GPU needed)."""
    from hexnewton.learning.ranks import distributed_rank

    assert distributed_rank({}, None).device is None and distributed_rank({}, "cpu").world_size == 1
    r = distributed_rank({"WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}, None)
    assert (r.device, r.rank, r.world_size, r.is_main) == ("cuda:1", 1, 2, False)
    assert r.seeds(7, 0) == (8, 1) and distributed_rank({}, None).seeds(7, 0) == (7, 0)
    r0 = distributed_rank({"WORLD_SIZE": "2", "RANK": "0", "LOCAL_RANK": "0"}, "cuda")
    assert r0.device == "cuda:0" and r0.is_main
    r3 = distributed_rank({"WORLD_SIZE": "4", "RANK": "3", "LOCAL_RANK": "1"}, None)  # 2 nodes x 2 GPUs
    assert r3.device == "cuda:1" and r3.rank == 3
    for environ, device, message in (({"WORLD_SIZE": "2", "RANK": "2", "LOCAL_RANK": "0"}, None, "must lie in"),
                                     ({"WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}, "mps", "runs on cuda"),
                                     ({"WORLD_SIZE": "two"}, None, "integers")):  # fmt: skip
        with pytest.raises(ValueError, match=message):
            distributed_rank(environ, device)
    r1 = distributed_rank({"WORLD_SIZE": "2", "RANK": "1", "LOCAL_RANK": "1"}, "cpu")
    assert (r1.device, r1.rank, r1.world_size) == ("cpu", 1, 2)
    # the CLI: a device no rank can run on is one line, exit 2
    env = dict(os.environ, WORLD_SIZE="2", RANK="1", LOCAL_RANK="1")
    proc = subprocess.run([sys.executable, "train.py", "--device", "mps"], capture_output=True, text=True, env=env,
                          timeout=300)  # fmt: skip
    err = [line for line in proc.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
    assert proc.returncode == 2 and len(err) == 1 and "runs on cuda" in err[0], proc.stderr[-1500:]


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_torchrun_two_cpu_processes_train_as_one(tmp_path):
    """``torchrun --nproc_per_node=2 train.py --device cpu``: two processes (Gloo) train two iterations with their
    gradients averaged; their parameters agree at the end, and only rank 0 writes a run directory and chooses the
    result on validation rounds, as one process does, from the candidates both ranks validated.
    ``--agent.scale_with_ranks iterations``: 4 iterations of one process are 2 per rank; the checkpoints keep the
    unscaled config, timing.json the ranks and envs per rank."""
    cmd = ["torchrun", "--standalone", "--nproc_per_node=2", "train.py", "--task", "flat", "--num_envs", "4",
           "--max_iterations", "4", "--agent.scale_with_ranks", "iterations", "--device", "cpu",
           "--agent.validation_rounds", "2", "--agent.validation_steps", "5", "--log_dir", str(tmp_path)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-3000:]
    assert "rank 0 of 2" in proc.stdout and "rank 1 of 2" in proc.stdout
    agree = re.search(r"parameters of the 2 ranks agree to (\S+)", proc.stdout)
    assert agree and float(agree.group(1)) <= 1e-6, proc.stdout[-2000:]
    runs = glob.glob(str(tmp_path / "hexnewton_flat" / "*"))
    assert len(runs) == 1 and os.path.isfile(os.path.join(runs[0], "model_1.pt"))
    assert proc.stdout.count("deterministic validation, 2 rounds") == 1
    # the candidates were validated by both ranks (each its share, on its own device), chosen on rank 0
    assert re.search(r"deterministic validation, 2 rounds of the flat course \(seed 3000\) per candidate, \d+ s on 2 "
                     r"ranks:", proc.stdout), proc.stdout[-2000:]  # fmt: skip
    assert os.path.isfile(os.path.join(runs[0], "model_result.pt"))
    from hexnewton.learning.checkpoint import checkpoint_meta, load_checkpoint

    meta = checkpoint_meta(load_checkpoint(os.path.join(runs[0], "model_1.pt")))
    assert meta["world_size"] == 2 and meta["agent"]["max_iterations"] == 4
    assert "scaled for 2 ranks (iterations): 2 iterations" in proc.stdout
    assert not os.path.exists(os.path.join(runs[0], "model_2.pt"))
    timing = json.load(open(os.path.join(runs[0], "timing.json")))
    assert (timing["world_size"], timing["num_envs_per_rank"], timing["device_name"]) == (2, 4, "cpu")
    assert timing["validation"]["ranks"] == 2 and len(timing["validation"]["candidates"]) >= 2
    assert timing["env_steps"] == 2 * 4 * 24 * 2 and timing["process_start"] <= time.time()


def test_stop_reason_is_one_decision_for_all_ranks():
    """--max_minutes / --target_success under torchrun: every rank reaches the same decision from the sums over
    the ranks (here a fake two-rank sum), so no rank leaves the others waiting in a collective."""
    from hexnewton.learning.runner import stop_reason
    from hexnewton.mdp.env import RING

    full = {"window": RING, "episodes": RING, "success_rate": 0.96, "top_level_episodes": RING // 4, "top_level_success_rate": 0.5}
    assert stop_reason(False, full, 0.95, 0) == "target success 0.960 >= 0.95"
    assert stop_reason(False, full, 0.95, 10) is None  # a curriculum counts the last level only
    assert stop_reason(False, dict(full, episodes=RING - 1), 0.95, 0) is None  # ring not full yet
    assert stop_reason(True, full, None, 0) == "the --max_minutes limit"
    assert stop_reason(False, full, None, 0) is None
    other = {"window": RING, "episodes": RING, "success_rate": 0.90, "top_level_episodes": RING // 4, "top_level_success_rate": 1.0}
    sent = []
    stop_reason(False, other, 0.9, 0, reduce=lambda v: sent.append(v) or v)  # what the other rank contributes
    plus_other = lambda v: [a + b for a, b in zip(v, sent[0], strict=True)]  # noqa: E731
    assert stop_reason(False, full, 0.95, 0, plus_other) is None  # (0.96 + 0.90) / 2 < 0.95
    assert stop_reason(False, full, 0.92, 0, plus_other) == "target success 0.930 >= 0.92"
    assert stop_reason(False, other, 0.95, 10) == "target success on the last level 1.000 >= 0.95"
    time_up_elsewhere = lambda v: [a + b for a, b in zip(v, [1.0, 0.0, 0.0, 1.0], strict=True)]  # noqa: E731
    assert stop_reason(False, full, 0.95, 0, time_up_elsewhere) == "the --max_minutes limit"


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
@pytest.mark.parametrize("curriculum", [(), ("--env.terrain.levels", "2", "--env.terrain.start_levels", "2")])
def test_target_success_stops_training(tmp_path, curriculum):
    """--target_success (time-to-skill): with the goal 1 cm beyond reach every episode succeeds at once, so
    training stops as soon as 1024 episodes have finished (with a curriculum: 256 on its last level), then saves
    and exports."""
    out = _train(tmp_path, "--env.task.goal_distance", "0.51", "--agent.target_success", "0.9", "--max_iterations", "100000",
                 "--num_envs", "32", *curriculum)  # fmt: skip
    assert ("stopped by target success on the last level" if curriculum else "stopped by target success") in out
    (run,) = glob.glob(str(tmp_path / "*" / "*"))
    assert os.path.isfile(run + "/policy.onnx") and len(glob.glob(run + "/model_*.pt")) >= 2


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_max_minutes_stops_at_an_iteration_boundary(tmp_path):
    """--max_minutes: the alarm is acted on at the end of an iteration (as under torchrun), then save and export."""
    out = _train(tmp_path, "--agent.max_minutes", "0.001", "--max_iterations", "100000", "--num_envs", "8")
    it = re.search(r"stopped by the --max_minutes limit after iteration (\d+): saving", out)
    assert it, out[-2000:]
    (run,) = glob.glob(str(tmp_path / "*" / "*"))
    assert os.path.isfile(run + "/policy.onnx") and os.path.isfile(f"{run}/model_{it.group(1)}.pt")


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_curriculum_stages_change_reflex_and_weights_in_one_run(tmp_path, capsys):
    """The complex recipe's curriculum, on shortened stages (--agent.stages): each stage begins at its iteration (its
    reflex gain, reward weights, PPO settings and effort clamp), the checkpoints carry the task, the gain, weights and
    physics they were trained under; a resumed run continues in its stage, on its own task. (Built after the
    imports, --no-build_beside_imports: the start-up phases terrain, scene and finalize.)"""
    import torch

    from hexnewton import startup
    from hexnewton.apps import train

    startup.restart()  # the phases of this run alone (other tests ran train.main in this process)
    stages = ("((1, {'posture_reflex': 2.0, 'w_tilt': 15.0}), (2, {'w_tilt': 40.0, 'w_ang_vel': 0.3, "
              "'learning_rate': 2.5e-4, 'entropy_coef': 0.001, 'effort_clamp': 'actuator'}))")
    assert train.main(["--task", "complex", "--num_envs", "8", "--agent.num_steps_per_env", "4", "--max_iterations",
                       "3", "--device", "cpu", "--log_dir", str(tmp_path), "--agent.stages", stages,
                       "--agent.save_interval", "1", "--agent.validation_rounds", "2", "--agent.validation_steps",
                       "8", "--agent.validation_terrains", "complex", "--agent.algorithm.schedule", "fixed",
                       "--no-build_beside_imports"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    # the terrain and the model built after the imports, each a phase of its own
    line = next(x for x in out.splitlines() if x.startswith("start-up "))
    assert all(f", {phase} " in line for phase in ("terrain", "scene", "finalize"))
    assert " model build " not in line and "model built beside" not in line
    assert "iteration 1: curriculum stage 2 of 3: posture_reflex 2, w_tilt 15" in out
    assert ("iteration 2: curriculum stage 3 of 3: posture_reflex 2, w_tilt 40, w_ang_vel 0.3, learning_rate "
            "0.00025, entropy_coef 0.001, effort_clamp actuator") in out
    # the stage's learning rate is PPO's from its first iteration on (rsl-rl logs the rate each iteration ran with)
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    (events,) = [str(p.parent) for p in tmp_path.glob("*/*/events.out.tfevents.*")]
    rates = {e.step: e.value for e in EventAccumulator(events).Reload().Scalars("Loss/learning_rate")}
    assert rates[0] == rates[1] == pytest.approx(1e-3) and rates[2] == pytest.approx(2.5e-4)
    # deterministic validation among the last stage's checkpoints only (iteration 2 on), on the complex course
    assert "deterministic validation, 2 rounds of the complex course (seed 3000) per candidate" in out
    assert "model_2.pt (last, iteration 2)" in out and "model_1.pt" not in out and "model_0.pt" not in out
    (kept,) = tmp_path.glob("*/*/model_result.pt")
    assert "python play.py --checkpoint " + str(kept) in out
    last = sorted(tmp_path.glob("*/*/model_2.pt"))[-1]
    meta = torch.load(last, weights_only=True)["infos"]["hexnewton"]
    cfg = meta["config"]
    assert meta["task"] == "complex" and meta["agent"]["max_iterations"] == 3
    assert cfg["cpg"]["posture"] and cfg["cpg"]["posture_reflex"] == 2.0 and cfg["reward"]["w_tilt"] == 40.0
    assert cfg["sim"]["effort_clamp"] == "actuator"  # the stage's physics travels with the checkpoint
    # resumed: the run goes on with its own task and configs, in the stage its iteration is in
    assert train.main(["--resume", str(last), "--num_envs", "8", "--max_iterations", "1", "--device", "cpu",
                       "--log_dir", str(tmp_path), "--agent.validation_rounds", "0"]) == 0  # fmt: skip
    out = capsys.readouterr().out
    assert "training task complex" in out and "iteration 3: curriculum stage 3 of 3" in out


def test_training_reports_its_start_up_and_writes_timing(trained):
    """After the first iteration train.py prints where the start-up went (phases from the process's start), and the
    run's timing.json records them with the training time and the result it exported. The terrain and the scene are
    built before the imports, the model's finalize in a thread beside them (the default): the wait is a phase, the
    thread's own phase a note."""
    logs, out = trained
    line = next(x for x in out.splitlines() if x.startswith("start-up "))
    for phase in ("python and imports", "model build", "solver", "first step and graph capture", "first iteration"):
        assert f"{phase} " in line
    assert ", terrain " in line.split(";")[0] and ", scene " in line.split(";")[0]
    assert "; model built beside the imports: finalize " in line and ", finalize " not in line.split(";")[0]
    run_dir = glob.glob(str(logs / "hexnewton_flat" / "*"))[0]
    timing = json.load(open(os.path.join(run_dir, "timing.json")))
    assert timing["iterations"] == 2 and timing["env_steps"] == 2 * 16 * 24
    assert 0 < timing["first_iteration_s"] < timing["wall_s_to_result"]
    assert sum(timing["startup_phases_s"].values()) == pytest.approx(timing["first_iteration_s"], abs=0.5)
    # the Warp modules the first step loaded (those the precompile left to it), counted on the console too
    loads = timing["startup_notes"]["first_step_loaded_modules"]
    assert isinstance(loads, list) and all(isinstance(n, str) for n in loads)
    assert f"first step loaded modules: {len(loads)}" in out
    # the heavy imports one by one (0 for a module already loaded)
    imports = timing["startup_notes"]["imports_s"]
    assert list(imports)[:4] == ["warp", "newton", "hexnewton.physics.world", "torch"]
    assert all(v >= 0 for v in imports.values()) and "; imports: warp " in line
    assert os.path.isfile(timing["result"])
    # the result chosen on deterministic validation (the fixture: 4 rounds of 30 steps per candidate), kept as
    # model_result.pt, which play.py and evaluate take for the run's result
    v = timing["validation"]
    assert timing["result"] == os.path.join(run_dir, "model_result.pt") and v["rounds"] == 4
    assert [c["iteration"] for c in v["candidates"]] == [0, 1, 1]
    assert v["chosen"] in [c["path"] for c in v["candidates"]]
    # --agent.validation_average: the weight average of the last stage's candidates, its own file, one more candidate
    assert v["candidates"][-1]["path"] == os.path.join(run_dir, "model_average.pt") and os.path.isfile(
        v["candidates"][-1]["path"]) and v["candidates"][-1]["why"] == "average of iterations 0, 1"
    assert "deterministic validation, 4 rounds of the flat course (seed 3000) per candidate" in out
    assert "the result: " in out


def test_progress_line_says_when_no_episode_has_ended():
    from hexnewton.learning.runner import progress_line

    stats = {"success_rate": float("nan"), "fell_rate": float("nan"), "off_course_rate": float("nan"),
             "distance_m": float("nan"), "episodes": 0}  # fmt: skip
    line = progress_line({"it": 0, "total_it": 300}, stats, 1.0)
    assert "no episode ended yet" in line and "nan" not in line
    line = progress_line({"it": 9, "total_it": 300}, {**stats, "success_rate": 0.5, "episodes": 3}, 1.0)
    assert "success 0.500" in line


def test_tf32_is_torchs_matmul_precision_and_off_by_default():
    """--agent.tf32 sets torch's float32 matmul precision for the process ("high": TF32 tensor cores); off, the
    full float32 torch starts with."""
    from hexnewton.apps.train import _base_task, configs, parser
    from hexnewton.learning.agent import AgentConfig
    from hexnewton.learning.runner import matmul_precision

    assert AgentConfig().tf32 is False
    for argv, want in ((["--task", "flat"], False), (["--task", "flat", "--agent.tf32", "true"], True)):
        base, _ = _base_task(argv)
        assert configs(parser(base, False).parse_args(argv), base, None)[1].tf32 is want
    before = torch.get_float32_matmul_precision()
    try:
        matmul_precision(True)
        assert torch.get_float32_matmul_precision() == "high"
        matmul_precision(False)
        assert torch.get_float32_matmul_precision() == "highest"
    finally:
        torch.set_float32_matmul_precision(before)


def test_best_checkpoint_keeps_the_best_iteration(tmp_path):
    """model_best.pt follows the training success once enough episodes are in (a quarter of the ring; with a
    curriculum, played on the last level), and only a real improvement saves again."""
    from hexnewton.learning.runner import BestCheckpoint, training_success
    from hexnewton.mdp.env import RING

    saved = []
    best = BestCheckpoint(str(tmp_path), levels=0)
    save = lambda path, infos: saved.append((path, infos["best_success"]))  # noqa: E731
    for it, (rate, n) in enumerate([(0.9, RING // 8), (0.5, RING // 4), (0.8, RING), (0.802, RING), (0.7, RING)]):
        best.update({"window": RING, "success_rate": rate, "episodes": n}, it, save)
    assert [r for _, r in saved] == [0.5, 0.8] and best.iteration == 2 and best.rate == 0.8
    assert saved[0][0] == str(tmp_path / "model_best.pt")
    stats = {"window": RING, "top_level_success_rate": 0.9, "top_level_episodes": RING // 4, "success_rate": 0.1,
             "episodes": RING}
    assert training_success(stats, levels=10) == 0.9 and training_success(stats, levels=0) == 0.1
    assert training_success({**stats, "top_level_episodes": 3}, levels=10) is None


def test_random_goals_train_toward_more_goals_per_episode(tmp_path):
    """With random goals (the navigate tasks) an episode never ends on success: reaching a goal sets the next one. The
    console line, model_best.pt and its validation candidate's reason follow the goals reached per episode."""
    from hexnewton.learning.runner import BestCheckpoint, progress_line, training_success
    from hexnewton.mdp.env import RING

    stats = {"window": RING, "episodes": RING, "success_rate": 0.0, "goals_reached": 3.2, "fell_rate": 0.0,
             "off_course_rate": 0.0, "distance_m": 0.5}  # fmt: skip
    assert training_success(stats, levels=0, goals=True) == 3.2 and training_success(stats, levels=0) == 0.0
    line = progress_line({"it": 9, "total_it": 300}, stats, 1.0, goals=True)
    assert "goals 3.20" in line and "success" not in line
    saved = []
    best = BestCheckpoint(str(tmp_path), levels=0, goals=True)
    save = lambda path, infos: saved.append(infos["best_goals"])  # noqa: E731
    for it, goals in enumerate([0.1, 2.0, 2.01, 3.1, 2.5]):
        best.update({**stats, "goals_reached": goals}, it, save)
    assert saved == [0.1, 2.0, 3.1] and best.iteration == 3 and best.measure == "goals per episode"


def test_cpu_validation_takes_minutes_unless_the_command_line_says_otherwise(capsys):
    """On the CPU a terrain task validates 8 rounds per candidate, not the 256 sized for a GPU, and says so; a
    command line that sets ``--agent.validation_rounds``, CUDA and the flat task's 16 keep theirs."""
    from hexnewton.apps.train import CPU_VALIDATION_MAX, CPU_VALIDATION_ROUNDS, device_validation
    from hexnewton.tasks import task

    rugged, flat = task("rugged").agent, task("flat").agent
    assert rugged.validation_rounds > CPU_VALIDATION_MAX == flat.validation_rounds and CPU_VALIDATION_ROUNDS == 8
    assert device_validation(rugged, "cpu", ["--task", "rugged"]).validation_rounds == CPU_VALIDATION_ROUNDS
    assert "8 rounds per candidate (the task's 256 are sized for a GPU" in capsys.readouterr().out
    argv = ["--task", "rugged", "--agent.validation_rounds", "256"]
    assert device_validation(rugged, "cpu", argv).validation_rounds == rugged.validation_rounds
    assert device_validation(rugged, "cuda:0", ["--task", "rugged"]) is rugged
    assert device_validation(flat, "cpu", []) is flat and capsys.readouterr().out == ""
