"""play.py and reading checkpoints (hexnewton/apps/play.py, checkpoint.py, policy.py): the trained checkpoint plays, the
newest run's result is the default, bad checkpoints and arguments are one-line errors, the shipped policies fit."""

import glob
import os
import subprocess
import sys

import numpy as np
import pytest
import torch

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_play_loads_the_trained_checkpoint(trained):
    logs, _ = trained
    proc = subprocess.run([sys.executable, "play.py", "--controller", "cpg_rl", "--log_dir", str(logs), "--num_envs",
                           "2", "--steps", "10", "--device", "cpu", "--terrain", "flat", "stepped",
                           "--env.terrain.step_rise", "0.08", "--env.task.goal_distance", "5.5"],
                          capture_output=True, text=True, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "[cpg_rl (" in proc.stdout and "model_result.pt" in proc.stdout


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_play_without_arguments_plays_the_newest_policy(trained, tmp_path):
    """``python play.py``: the newest run's checkpoint on the terrain it was trained on; with nothing trained, the
    shipped complex policy; a checkpoint given to the fixed CPG is an error, never ignored."""
    logs, _ = trained
    base = [sys.executable, "play.py", "--num_envs", "1", "--steps", "3", "--device", "cpu", "--no-progress"]
    proc = subprocess.run([*base, "--log_dir", str(logs)], capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "playing " in proc.stdout and "model_result.pt" in proc.stdout and "[cpg_rl (" in proc.stdout
    assert "flat" in proc.stdout.split("[cpg_rl (")[1]
    proc = subprocess.run([*base, "--log_dir", str(tmp_path / "none")], capture_output=True, text=True, timeout=600,
                          cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "cpg_rl_complex.pt" in proc.stdout and "complex" in proc.stdout.split("[cpg_rl (")[1]
    proc = subprocess.run([*base, "--controller", "cpg", "--checkpoint", "x.pt"], capture_output=True, text=True,
                          timeout=600, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 2 and "the fixed CPG (--controller cpg) has none" in proc.stderr


def test_bad_checkpoints_are_one_line_errors(trained, tmp_path, capsys):
    logs, _ = trained
    good = sorted(glob.glob(str(logs / "hexnewton_flat" / "*" / "model_1.pt")))[0]
    corrupt = tmp_path / "corrupt.pt"
    corrupt.write_bytes(b"not a checkpoint")
    ckpt = torch.load(good, weights_only=False)
    ckpt["actor_state_dict"]["mlp.0.weight"] = torch.zeros(256, 44)
    ckpt["infos"] = None
    mismatched = tmp_path / "mismatched.pt"
    torch.save(ckpt, mismatched)
    truncated = tmp_path / "truncated.pt"
    truncated.write_bytes(open(good, "rb").read()[:5000])
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    cases = [
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(tmp_path / "missing.pt")], "checkpoint not found"),
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(corrupt)], "cannot read checkpoint"),
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(mismatched), "--num_envs", "1", "--steps", "1"],
         "expects 44 observations"),
        (["play.py", "--controller", "joint", "--checkpoint", good, "--num_envs", "1", "--steps", "1"],
         "action mode 'cpg'"),
        (["train.py", "--task", "fancy"], "unknown task 'fancy'"),
        (["train.py", "--agent.distribution.name", "cauchy"], "'cauchy' is not one of beta, gaussian"),
        (["train.py", "--env.reward.w_tilt", "much"], "expected a number"),
        (["train.py", "--env.randomization.enabled", "maybe"], "expected true or false"),
        (["train.py", "--resume", str(corrupt), "--task", "flat"], "continues the checkpoint's own task"),
        (["train.py", "--resume", str(corrupt)], "cannot read checkpoint"),
        (["train.py", "--resume", str(truncated)], "cannot read checkpoint"),
        (["train.py", "--resume", "results/policies/cpg_rl_complex.pt"], "holds the policy only"),
        (["play.py", "--controller", "cpg_rl", "--checkpoint", str(truncated)], "cannot read checkpoint"),
        (["play.py", "--controller", "pid"], "invalid choice: 'pid'"),
        (["train.py", "--num_envs", "abc"], "positive integer"),
        (["train.py", "--num_envs", "0"], "positive integer"),
        (["train.py", "--num_envs", "100000000"], "exceeds"),
        (["train.py", "--max_iterations", "1.5"], "positive integer"),
        (["train.py", "--env.task.goal_distance", "far"], "expected a number"),
        (["train.py", "--env.terrain.name", "moon"], "'moon' is not one of flat, rugged, stepped, complex"),
        (["train.py", "--log_dir", str(a_file / "sub")], "not a writable directory"),
        (["train.py", "--agent.max_minutes", "-1"], "agent.max_minutes must be positive"),
        (["train.py", "--agent.distribution.name", "gaussian", "--agent.distribution.init_std", "0"],
         "init_std must be positive"),
        (["train.py", "--env.sim.frame_dt", "0.015"], "must be a positive multiple of sim.frame_dt"),
        (["train.py", "--env.cpg.a2_range", "1.0", "0.5"], "cpg.a2_range must satisfy"),
        (["train.py", "--env.reward.stability_tilt", "2"], "stability_tilt must lie in (0, pi/2)"),
        (["play.py", "--controller", "cpg", "--env.task.goal_distance", "0.2", "--steps", "1"],
         "goal_distance must exceed"),
        (["play.py", "--controller", "cpg", "--terrain", "stepped", "--env.terrain.step_rise", "-0.1", "--steps", "1"],
         "step_rise must be >= 0"),
    ]
    before = sorted(glob.glob(str(logs / "**"), recursive=True))
    # the first case of each entry point as its own process (the file users run), the others through the same
    # cli.run wrapper in this process: one line on stderr, exit status 2, no traceback
    from hexnewton.apps import play, train
    from hexnewton.apps.cli import run

    entry = {"train.py": (train.main, "python train.py"), "play.py": (play.main, "python play.py")}
    seen = set()
    for args, message in cases:
        if args[0] not in seen:
            seen.add(args[0])
            proc = subprocess.run([sys.executable, *args, "--device", "cpu"], capture_output=True, text=True,
                                  timeout=600)  # fmt: skip
            code, stderr = proc.returncode, proc.stderr
        else:
            capsys.readouterr()
            try:
                code = run(entry[args[0]][0], entry[args[0]][1], [*args[1:], "--device", "cpu"])
            except SystemExit as exc:  # argparse's usage errors exit from the parser
                code = exc.code
            stderr = capsys.readouterr().err
        err = [line for line in stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
        assert code == 2 and len(err) == 1 and message in err[0], (args, stderr[-2000:])
    assert sorted(glob.glob(str(logs / "**"), recursive=True)) == before  # nothing written or overwritten


@pytest.mark.parametrize("name", ["cpg_rl_flat", "cpg_rl_rugged"])
def test_shipped_policies_fit_the_environment(name):
    """results/policies holds the GPU-trained actors and results/controllers their bundles (RESULTS.md); they must
    keep matching the observation layout and action count, in torch and in ONNX."""
    import os

    import onnxruntime as ort

    from hexnewton.learning.checkpoint import check_compatible, load_checkpoint
    from hexnewton.mdp.terms import OBS_DIM

    results = os.path.join(os.path.dirname(__file__), "..", "..", "results")
    pt = os.path.join(results, "policies", name + ".pt")
    check_compatible(load_checkpoint(pt), pt, OBS_DIM["cpg"], 15, "cpg")
    sess = ort.InferenceSession(os.path.join(results, "controllers", name, "policy.onnx"),
                                providers=["CPUExecutionProvider"])
    out = sess.run(None, {sess.get_inputs()[0].name: np.zeros((3, OBS_DIM["cpg"]), np.float32)})[0]
    assert out.shape == (3, 15) and np.isfinite(out).all()


def test_newest_checkpoint_is_the_runs_result(tmp_path):
    """play.py's default: the newest run's model_best.pt where it kept one (train.py's result then), else its last
    numbered checkpoint."""
    from hexnewton.learning.checkpoint import newest_checkpoint

    old, new = tmp_path / "hexnewton_flat" / "2026-01-01_00-00-00", tmp_path / "hexnewton_rugged" / "2026-01-02_00-00-00"
    for run, names in ((old, ("model_0.pt", "model_best.pt")), (new, ("model_2.pt", "model_10.pt"))):
        run.mkdir(parents=True)
        for name in names:
            (run / name).write_bytes(b"")
    assert newest_checkpoint(str(tmp_path), "hexnewton_*") == str(new / "model_10.pt")
    (new / "model_best.pt").write_bytes(b"")
    assert newest_checkpoint(str(tmp_path), "hexnewton_*") == str(new / "model_best.pt")
    assert newest_checkpoint(str(tmp_path), "hexnewton_flat") == str(old / "model_best.pt")


@pytest.mark.parametrize(("waypoints", "message"), [
    (["2"], "expected a waypoint X,Y in metres (e.g. 2,0), got '2'"),
    (["2,0", "2,x"], "got '2,x'"),
    (["1,2,3"], "got '1,2,3'"),
    (["nan,0"], "got 'nan,0'"),
    ([], "expected at least one argument"),
])  # fmt: skip
def test_bad_waypoints_are_one_line_errors(waypoints, message, capsys):
    """``play.py --waypoints X,Y ...``: a malformed waypoint is one stderr line and exit status 2, before any world."""
    from hexnewton.apps import play
    from hexnewton.apps.cli import run

    try:
        code = run(play.main, "python play.py", ["--controller", "cpg", "--waypoints", *waypoints, "--device", "cpu"])
    except SystemExit as exc:
        code = exc.code
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert code == 2 and len(err) == 1 and message in err[0], err


def test_waypoints_parse_negative_coordinates():
    """A waypoint with a negative X (``-1,2``) is a value, not a flag; the course reaches the task as (x, y) pairs."""
    from hexnewton.analysis.navigation import NAVIGATION_ENDS, played_goals
    from hexnewton.apps.play import parser
    from hexnewton.config import TaskConfig

    args = parser().parse_args(["--waypoints", "2,0", "-1,-2.5", "0,2e0", "--num_envs", "2"])
    assert args.waypoints == [(2.0, 0.0), (-1.0, -2.5), (0.0, 2.0)] and args.num_envs == 2
    fields = played_goals(TaskConfig(), args.waypoints)
    assert fields["waypoints"] == ((2.0, 0.0), (-1.0, -2.5), (0.0, 2.0)) and fields["terminations"] == NAVIGATION_ENDS


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_play_walks_a_waypoint_course():
    """The fixed CPG walks straight: waypoints 0.3 m and 0.6 m ahead are reached in turn and the last ends the
    episode as a success; the summary counts the goals reached, not the distance along a straight course."""
    proc = subprocess.run([sys.executable, "play.py", "--controller", "cpg", "--terrain", "flat", "--num_envs", "2",
                           "--steps", "150", "--device", "cpu", "--no-progress", "--viewer", "null", "--waypoints",
                           "0.3,0", "0.6,0"], capture_output=True, text=True, timeout=600, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "first episodes ended: success 2" in proc.stdout, proc.stdout
    assert "first episodes reached 2.0 of 2 goals (min 2)" in proc.stdout and "heading error" not in proc.stdout


def test_the_summary_counts_goals_where_robots_walk_to_goals():
    from hexnewton.analysis.metrics import format_stats

    base = {"envs": 3, "distance_m": 0.5, "distance_min_m": 0.4, "lateral_drift_m": 0.01, "lateral_drift_max_m": 0.02,
            "heading_error_deg": 2.0, "roll_mean_deg": 1.0, "roll_std_deg": 0.5, "roll_max_deg": 3.0,
            "pitch_mean_deg": 1.0, "pitch_std_deg": 0.5, "pitch_max_deg": 3.0, "ended": {"success": 3}}  # fmt: skip
    assert "walked 0.50 m" in format_stats("flat", base, 10.0)
    line = format_stats("flat", {**base, "goals_mean": 3.5, "goals_min": 2, "goals_of": None}, 20.0)
    assert "first episodes reached 3.5 goals (min 2)" in line and "walked" not in line
    line = format_stats("flat", {**base, "goals_mean": 4.0, "goals_min": 4, "goals_of": 4}, 20.0)
    assert "reached 4.0 of 4 goals" in line
