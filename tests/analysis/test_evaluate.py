"""The evaluation protocol (hexnewton.apps.evaluate): metrics on synthetic trajectories, the report on a tiny run."""

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from hexnewton.analysis.metrics import DISTANCES, round_metrics, summarize
from hexnewton.analysis.report import ended_cell, falls_cell
from hexnewton.mdp.status import FELL, OFF_COURSE, SUCCESS

DT = 0.02
ROOT = os.path.join(os.path.dirname(__file__), "..", "..")


def _synthetic():
    """Four rounds of 300 steps at 0.6 m/s along x (1.2 cm per step):
    0 reaches the goal at step 270 (x = 3.24 m); 1 falls at step 150 (x = 1.8 m); 2 drifts in y and leaves
    the course at step 200 (x = 2.4 m); 3 walks at a quarter speed and never ends (x = 0.9 m)."""
    t_len, n = 300, 4
    k = np.arange(1, t_len + 1)[:, None]
    x = np.repeat(0.012 * k, n, axis=1)
    x[:, 3] *= 0.25
    y = np.zeros((t_len, n))
    y[:, 2] = 0.0076 * k[:, 0]  # |y| passes 1.5 m at step 198
    done = np.zeros((t_len, n), bool)
    status = np.zeros((t_len, n), np.int32)
    for env, step, code in ((0, 269, SUCCESS), (1, 149, FELL), (2, 199, OFF_COURSE)):
        done[step, env], status[step, env] = True, code
        x[step + 1:, env] = 0.0  # the env was reset: a new episode starts at its origin
        y[step + 1:, env] = 0.0
    rpy = np.zeros((t_len, n, 3))
    rpy[:, :, 1] = np.deg2rad(2.0) * np.sin(k * 0.3)
    rpy[100, 0, 0] = np.deg2rad(-10.0)  # one roll peak inside round 0's episode
    rpy[280, 0, 0] = np.deg2rad(50.0)  # after round 0 ended: must be ignored
    return np.stack([x, y], axis=-1), rpy, done, status


def test_reached_distances_and_times():
    pos, rpy, done, status = _synthetic()
    m = round_metrics(pos, rpy, done, status, DT)
    assert DISTANCES == (0.5, 1.0, 2.0, 3.0)
    # reached flags: success walks 3 m; the fall counts up to its last valid step (1.788 m); off course
    # counts to 2.388 m; the slow robot covers 0.9 m
    np.testing.assert_array_equal(m["reached"], [[1, 1, 1, 1], [1, 1, 1, 0], [1, 0, 1, 0], [1, 0, 0, 0]])  # (D, N)
    # x >= d first at step ceil(d / 0.012) (1-based), times in seconds
    np.testing.assert_allclose(m["time_to"][0, :3], np.ceil(0.5 / 0.012 - 1e-9) * DT)
    np.testing.assert_allclose(m["time_to"][3, 0], np.ceil(3.0 / 0.012 - 1e-9) * DT)
    assert np.isnan(m["time_to"][3, 1:]).all()
    np.testing.assert_array_equal(m["end"], [SUCCESS, FELL, OFF_COURSE, 0])
    np.testing.assert_array_equal(m["steps"], [270, 150, 200, 300])
    assert m["y_dev"][2] == pytest.approx(0.0076 * 200) and m["y_dev"][0] == 0.0


def test_summary_rates_and_angles():
    pos, rpy, done, status = _synthetic()
    s = summarize(round_metrics(pos, rpy, done, status, DT), rpy)
    assert [s[f"success_{d:g}m"] for d in DISTANCES] == [1.0, 0.75, 0.5, 0.25]
    assert s["roll_peak_deg"] == pytest.approx(10.0)  # the 50 deg sample lies after round 0's episode
    assert s["pitch_peak_deg"] <= 2.0 + 1e-9 and s["pitch_var_deg2"] == pytest.approx(2.0, rel=0.1)
    assert s["ended"]["success"] == 1 and s["ended"]["running"] == 1
    assert s["time_to_3m_s"] == pytest.approx(250 * DT)
    # only round 0 walked 3 m (then reached the goal); a fall of a round past 3 m counts there as well
    assert s["ended_past_3m"] == {**{k: 0 for k in s["ended"]}, "success": 1}
    status[149, 1], x = 0, pos[..., 0]
    x[:, 1] = 0.012 * np.arange(1, 301)  # round 1 walks on and falls at step 279, x = 3.36 m
    done[149, 1], done[279, 1], status[279, 1] = False, True, FELL
    s = summarize(round_metrics(pos, rpy, done, status, DT), rpy)
    assert s["ended_past_3m"]["fell"] == 1 and s["ended"]["fell"] == 1 and s["success_3m"] == 0.5
    assert ended_cell(s, 3.0) == "running 1, fell 1 (1 past 3 m), off_course 1, success 1"


def test_falls_past_the_goal_line():
    """A round that walked beyond the goal line (goal distance + radius) without reaching the goal and then fell
    counts in ``ended_past_goal``, not in ``fall_rate_before_goal``; a fall short of the line counts there."""
    pos, rpy, done, status = _synthetic()
    m = round_metrics(pos, rpy, done, status, DT)
    np.testing.assert_allclose(m["x_far"], [3.24, 0.012 * 149, 0.012 * 199, 0.9])  # the falling row does not count
    x = pos[..., 0]
    x[:, 0] = 0.012 * np.arange(1, 301)  # round 0 walks on past the line (3.0 m) and falls at x = 3.48 m
    status[269, 0], done[269, 0], done[289, 0], status[289, 0] = 0, False, True, FELL
    s = summarize(round_metrics(pos, rpy, done, status, DT), rpy, DISTANCES, goal_line=3.0)
    assert s["goal_line_m"] == 3.0 and s["fall_rate"] == 0.5
    assert s["ended_past_goal"] == {**{k: 0 for k in s["ended"]}, "fell": 1}
    assert s["fall_rate_before_goal"] == 0.25  # round 1, at 1.8 m
    assert falls_cell(s) == "2 / 4 (1 past the goal)"
    assert "ended_past_goal" not in summarize(m, rpy)


def _fake_run(path, rewards):
    from torch.utils.tensorboard import SummaryWriter

    os.makedirs(path)
    w = SummaryWriter(path)
    for it, r in enumerate(rewards):
        w.add_scalar("Train/mean_reward", r, it)
    w.close()
    with open(os.path.join(path, "config.json"), "w") as f:
        json.dump({"hexnewton": {"config": {"sim": {"num_envs": 8}}}, "train": {"num_steps_per_env": 24}}, f)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_report_on_a_tiny_run(tmp_path):
    """Fixed CPG and the shipped CPG_RL policy, 2 rounds of 25 steps on stepped ground, plus Fig. 5a from
    two fake runs: every output exists and the Markdown carries the paper's row."""
    _fake_run(str(tmp_path / "a"), [0.0, 1.0, 3.0])
    _fake_run(str(tmp_path / "b"), [0.0, 0.5])
    out = tmp_path / "report"
    policy = os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt")
    cmd = [sys.executable, "-m", "hexnewton.apps.evaluate", "--controllers", "cpg", "cpg_rl", "--checkpoint",
           f"cpg_rl={policy}", "--terrains", "stepped", "--rounds", "2", "--max_steps", "25", "--device", "cpu",
           "--runs", f"cpg_rl={tmp_path / 'a'}", f"joint={tmp_path / 'b'}", "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    for name in ("report.md", "results.json", "fig_stepped.png", "fig_params.png", "fig_learning.png"):
        assert (out / name).stat().st_size > 200, name
    res = json.loads((out / "results.json").read_text())
    assert res["meta"]["terrain_seed"] == 1000 and set(res["results"]["stepped"]) == {"cpg", "cpg_rl"}
    assert res["results"]["stepped"]["cpg"]["rounds"] == 2
    report = (out / "report.md").read_text()
    assert "| stepped | CPG | " in report and "60% / 28% / 0% / 0%" in report  # Table 3's fixed-CPG row

    # bad input: one line, exit 2, nothing overwritten
    before = sorted(os.listdir(out))
    cases = [
        (["--out", str(out), "--controllers", "cpg", "--terrains", "flat"], "exists"),
        (["--controllers", "cpg_rl", "--terrains", "flat", "--out", str(tmp_path / "x")], "needs --checkpoint"),
        (["--controllers", "cpg_rl", "--checkpoint", "cpg_rl=/nope.pt", "--out", str(tmp_path / "x")], "not found"),
        (["--checkpoint", "cpg_rl", "--out", str(tmp_path / "x")], "NAME=PATH"),
        (["--rounds", "0"], "positive"),
        (["--controllers", "cpg", "--env.sim.frame_dt", "0.015", "--out", str(tmp_path / "x")], "positive multiple of"),
        (["--stochastic", "--expected", "--out", str(tmp_path / "x")], "not allowed with argument --stochastic"),
    ]
    for args, message in cases:
        p = subprocess.run([sys.executable, "-m", "hexnewton.apps.evaluate", *args, "--device", "cpu"], capture_output=True,
                           text=True, timeout=300, cwd=ROOT)  # fmt: skip
        err = [line for line in p.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
        assert p.returncode == 2 and len(err) == 1 and message in err[0], (args, p.stderr[-1500:])
    assert sorted(os.listdir(out)) == before and not (tmp_path / "x").exists()


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_stochastic_rounds_are_seeded_and_sample_around_the_mean():
    """``--stochastic``: the policy samples its actions (trajectories differ from the mean action's), and the
    same evaluation seed gives the same rounds; another seed (``--seed``, a validation set) other rounds."""
    from hexnewton.analysis.rollout import run_rounds

    policy = os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt")
    mean, a, b = (run_rounds("cpg_rl", policy, "flat", 2, "cpu", 30, False, stochastic=stochastic)
                  for stochastic in (False, True, True))
    np.testing.assert_array_equal(a.pos, b.pos)
    np.testing.assert_array_equal(a.params, b.params)
    assert np.abs(a.params - mean.params).max() > 1e-3
    other = run_rounds("cpg_rl", policy, "flat", 2, "cpu", 30, False, stochastic=True, seed=3000)
    assert np.abs(other.rpy[0, :, 2] - a.rpy[0, :, 2]).max() > 1e-2  # other start headings


def test_rounds_run_under_the_policys_own_physics(tmp_path, monkeypatch):
    """A policy trained under other physics (--env.sim.frame_dt / substeps) is evaluated under it, unless the overrides
    set it; the fixed CPG runs under the defaults."""
    import torch

    import hexnewton.mdp.env
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.config import SimConfig
    from hexnewton.learning.checkpoint import load_checkpoint, trained_config

    ckpt = load_checkpoint(os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt"))
    ckpt["infos"]["hexnewton"]["config"]["sim"].update(frame_dt=0.02, substeps=3)
    path = str(tmp_path / "fast.pt")
    torch.save(ckpt, path)
    assert (trained_config(ckpt).sim.frame_dt, trained_config(ckpt).sim.substeps) == (0.02, 3)
    seen, make_env = [], hexnewton.mdp.env.make_env
    monkeypatch.setattr(hexnewton.mdp.env, "make_env", lambda cfg, mode="cpg": seen.append(cfg.sim) or make_env(cfg, mode))
    run_rounds("cpg_rl", path, "flat", 2, "cpu", 3, False)
    run_rounds("cpg_rl", path, "flat", 2, "cpu", 3, False, overrides={"sim.frame_dt": 0.01, "sim.substeps": 4})
    run_rounds("cpg", None, "flat", 2, "cpu", 3, False)
    assert [(s.frame_dt, s.substeps, s.num_envs) for s in seen] == [(0.02, 3, 2), (0.01, 4, 2),
                                                                      (SimConfig.frame_dt, SimConfig.substeps, 2)]


def test_posture_reflex_for_posture_policies_and_fixed_gaits():
    """``--env.cpg.posture_reflex``: a posture policy runs with the given gain, a fixed gait (15 parameters) gets the neutral
    posture and the reflex, a policy without the posture is refused with one error."""
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.config import gait_params

    posture = os.path.join(ROOT, "results", "policies", "cpg_rl_complex_posture.pt")
    ep = run_rounds("cpg_rl", posture, "rugged", 2, "cpu", 5, False, overrides={"cpg.posture_reflex": 2.0})
    assert ep.params.shape[1] == 18 and np.isfinite(ep.rpy).all()
    fixed = run_rounds("cpg_swept", None, "flat", 2, "cpu", 5, False, overrides={"cpg.posture_reflex": 2.0},
                       fixed_params=np.tile(gait_params(6.28, 0.2, 0.9, 0.3), (2, 1)))
    np.testing.assert_allclose(fixed.params[-1, 15:], 0.0, atol=1e-6)
    with pytest.raises(ValueError, match="no body posture"):
        run_rounds("cpg_rl", os.path.join(ROOT, "results", "policies", "cpg_rl_flat.pt"), "flat", 2, "cpu", 5,
                   False, overrides={"cpg.posture_reflex": 2.0})


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_shipped_complex_policy_climbs_steps_under_its_20ms_physics():
    """The shipped complex policy (trained under a 20 ms frame = 4 x 5 ms) climbs the 6 cm risers on the CPU as
    on the GPU: 8 unseen rounds, sampled actions, 20 s. Steps climbable is one of the stability checks
    for that physics; the fixed CPG stands at the first riser (x = 0.5 m)."""
    from hexnewton.analysis.rollout import run_rounds
    from hexnewton.learning.checkpoint import load_checkpoint, trained_config
    from hexnewton.mdp.status import FELL

    policy = os.path.join(ROOT, "results", "policies", "cpg_rl_complex_gaussian.pt")
    sim = trained_config(load_checkpoint(policy)).sim
    assert (sim.frame_dt, sim.substeps) == (0.02, 4)
    ep = run_rounds("cpg_rl", policy, "stepped", 8, "cpu", 1000, False, stochastic=True)
    assert not (ep.status == FELL).any()
    assert (ep.pos[:, :, 0].max(axis=0) > 0.8).sum() >= 6  # the torso is past the second riser (0.75 m)


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_shipped_policy_is_more_level_than_the_fixed_cpg_on_rugged_ground():
    """The shipped complex policy (body posture, levelling reflex, deterministic action) against the fixed CPG with
    its default gait under the same physics: 4 unseen rugged rounds of 8 s, the same seeds, no falls, lower pitch
    and roll variance (on the GPU's 1000 test rounds: 0.60x / 0.77x, RESULTS.md)."""
    from hexnewton.analysis.rollout import run_rounds

    policy = os.path.join(ROOT, "results", "policies", "cpg_rl_complex.pt")
    stats = {}
    for ctrl, ck, physics in (("cpg_rl", policy, None), ("cpg", None, {"sim.frame_dt": 0.02, "sim.substeps": 4})):
        ep = run_rounds(ctrl, ck, "rugged", 4, "cpu", 400, False, overrides=physics)
        stats[ctrl] = summarize(round_metrics(ep.pos, ep.rpy, ep.done, ep.status, ep.dt), ep.rpy)
    assert stats["cpg_rl"]["fall_rate"] == 0.0
    for angle in ("pitch", "roll"):
        assert stats["cpg_rl"][f"{angle}_var_deg2"] < stats["cpg"][f"{angle}_var_deg2"], stats


def test_gait_quality_and_fall_metrics():
    """Falls anywhere in a round, the 99.9th percentile of |angle|, body rate RMS and the parameters' change per step
    (from each first episode's second step on)."""
    from hexnewton.analysis.metrics import gait_quality

    pos, rpy, done, status = _synthetic()
    m = round_metrics(pos, rpy, done, status, DT)
    s = summarize(m, rpy)
    assert s["fall_rate"] == pytest.approx(0.25)  # round 1 fell
    assert s["roll_p999_deg"] <= s["roll_peak_deg"] and s["pitch_p999_deg"] <= 2.0 + 1e-9
    rate = np.zeros(rpy.shape[:2] + (2,))
    rate[..., 1] = 0.5  # pitch rate 0.5 rad/s everywhere
    dparam = np.full(done.shape, 0.02)
    dparam[0] = np.nan  # no previous step
    dparam[280:, 0] = 1.0  # after round 0 ended: ignored
    q = gait_quality(m, rate, dparam, dparam * 2)
    assert q["roll_rate_rms_deg_s"] == 0.0 and q["pitch_rate_rms_deg_s"] == pytest.approx(np.degrees(0.5))
    assert q["param_change_pct"] == pytest.approx(2.0) and q["action_change_pct"] == pytest.approx(4.0)


def test_named_perturbations_change_one_thing():
    from hexnewton.analysis.rollout import PERTURBATIONS, perturbation
    from hexnewton.config import RandomizationConfig

    assert perturbation("nominal") == {}
    friction = perturbation("friction_0.3")
    assert friction["randomization.enabled"] and friction["randomization.friction"] == (0.3, 0.3)
    assert friction["randomization.payload"] == (0.0, 0.0) and friction["randomization.latency_share"] == 0.0
    assert friction["randomization.push_velocity"] == 0.0 and friction["randomization.noise_quat"] == 0.0
    train = RandomizationConfig()
    assert perturbation("payload_0.8kg")["randomization.payload"][0] > train.payload[1]  # beyond the training range
    assert perturbation("latency_40ms")["randomization.latency_share"] == 1.0 > train.latency_share
    assert perturbation("steps_7cm") == {"terrain.step_rise": 0.07}
    assert len(PERTURBATIONS) >= 9
    with pytest.raises(ValueError, match="unknown perturbation"):
        perturbation("gravity")


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_robustness_and_merge_on_a_tiny_run(tmp_path):
    """``evaluate --perturbations`` adds a robustness table per controller, with the swept fixed gait beside;
    ``--merge`` joins evaluations run apart."""
    ev = tmp_path / "ev"
    cmd = [sys.executable, "-m", "hexnewton.apps.evaluate", "--controllers", "cpg", "cpg_swept", "--terrains", "flat",
           "--rounds", "2", "--max_steps", "20", "--device", "cpu", "--perturbations", "payload_0.8kg", "--out",
           str(ev)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((ev / "results.json").read_text())
    assert set(res["robustness"]["payload_0.8kg"]) == {"cpg", "cpg_swept"}
    s = res["results"]["flat"]["cpg_swept"]
    assert {"fall_rate", "pitch_p999_deg", "roll_rate_rms_deg_s", "param_change_pct"} <= set(s)
    report = (ev / "report.md").read_text()
    assert "## Gait quality" in report and "## Robustness: CPG (swept)" in report
    # --merge joins evaluations run apart (same seeds); rounds that are not comparable are refused
    other = tmp_path / "other"
    other.mkdir()
    res["meta"]["rounds"] = 3
    (other / "results.json").write_text(json.dumps(res))
    for dirs, code in (([ev, ev], 0), ([ev, other], 2)):
        p = subprocess.run([sys.executable, "-m", "hexnewton.apps.evaluate", "--merge", *map(str, dirs), "--out",
                            str(tmp_path / f"merged{code}")], capture_output=True, text=True, timeout=300, cwd=ROOT)
        assert p.returncode == code, p.stderr[-2000:]
    assert "## Robustness: CPG (swept)" in (tmp_path / "merged0" / "report.md").read_text()
    assert not (tmp_path / "merged2").exists()


def test_sweep_points_change_one_thing():
    """A sweep point is the course with one field at one value: terrain fields as given, randomisation fields on every
    robot with the nominal robot otherwise, motor strength on gains and effort together; ``default`` is the set."""
    from hexnewton.analysis.rollout import DEFAULT_SWEEPS, perturbation, sweep_overrides
    from hexnewton.apps.evaluate import sweep_specs

    assert sweep_overrides("terrain.step_rise", 0.08) == {"terrain.step_rise": 0.08}
    friction = sweep_overrides("randomization.friction", 0.3)
    assert friction == perturbation("friction_0.3")
    motors = sweep_overrides("motor_strength", 0.5)
    assert motors["randomization.kp_scale"] == motors["randomization.effort_scale"] == (0.5, 0.5)
    assert motors["randomization.payload"] == (0.0, 0.0) and motors["randomization.enabled"]
    assert motors["randomization.motor_strength"] is None  # a course's robot draws no motor strength of its own
    assert sweep_overrides("randomization.push_velocity", 0.6)["randomization.push_interval"] == 3.0
    feet = sweep_overrides("randomization.foot_radius", 0.01)
    assert feet["randomization.foot_radius"] == (0.01, 0.01) and feet["randomization.contact_timeconst"] is None
    specs = sweep_specs([["default"], ["terrain.step_depth", "0.2", "0.3"]], ["stepped", "complex"])
    assert [s[0] for s in specs[:len(DEFAULT_SWEEPS)]] == [s[0] for s in DEFAULT_SWEEPS]
    assert specs[-2:] == [("terrain.step_depth@stepped", "terrain.step_depth", "stepped", (0.2, 0.3)),
                          ("terrain.step_depth@complex", "terrain.step_depth", "complex", (0.2, 0.3))]
    assert {s[0] for s in DEFAULT_SWEEPS} >= {"step_rise", "tread_depth", "block_height", "friction", "payload",
                                               "motor_strength", "push", "action_delay"}  # fmt: skip
    assert sweep_specs([["step_rise"], ["friction"]], ["rugged"]) == [DEFAULT_SWEEPS[0], DEFAULT_SWEEPS[3]]
    for args, message in (([["terrain.nope", "1"]], "terrain.nope"), ([["terrain.step_rise"]], "give the values"),
                          ([["terrain.step_rise", "high"]], "must be numbers"),
                          ([["default"], ["terrain.step_rise", "0.1"]], None)):  # fmt: skip
        if message is None:
            sweep_specs(args, ["rugged"])  # a field of the default set on another course is its own curve
            continue
        with pytest.raises(ValueError, match=message):
            sweep_specs(args, ["stepped"])


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_capability_sweep_on_a_tiny_run(tmp_path):
    """``evaluate --sweep FIELD V1 V2``: every controller at each value, one entry per value with its rounds counted,
    in results.json, the report and one figure per sweep; bad sweeps end with one line and exit 2."""
    out = tmp_path / "sweep"
    policy = os.path.join(ROOT, "results", "policies", "cpg_rl_complex.pt")
    cmd = [sys.executable, "-m", "hexnewton.apps.evaluate", "--controllers", "cpg", "cpg_rl", "--checkpoint",
           f"cpg_rl={policy}", "--terrains", "stepped", "--rounds", "2", "--max_steps", "20", "--device", "cpu",
           "--sweep", "terrain.step_rise", "0.06", "0.1", "--sweep", "motor_strength", "0.5", "--out", str(out)]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((out / "results.json").read_text())
    rise = res["sweeps"]["terrain.step_rise"]
    assert rise["terrain"] == "stepped" and rise["values"] == [0.06, 0.1] and set(rise["curves"]) == {"cpg", "cpg_rl"}
    for points in rise["curves"].values():
        assert [p["value"] for p in points] == [0.06, 0.1] and all(p["rounds"] == 2 for p in points)
        assert {"success_3m", "fall_rate", "pitch_var_deg2", "roll_var_deg2", "time_to_3m_s"} <= set(points[0])
    assert len(res["sweeps"]["motor_strength"]["curves"]["cpg"]) == 1
    assert (out / "fig_sweep_terrain.step_rise.png").stat().st_size > 2000
    assert "## Capability curve: terrain.step_rise" in (out / "report.md").read_text()
    assert set(res["results"]) == {"stepped"}  # the course as given, then the sweep points
    assert "(point 1 of 6, " in proc.stdout and "(point 6 of 6, " in proc.stdout and " left)" in proc.stdout
    # a default curve by name, its points alone (--no-nominal): nothing of the course as given
    alone = tmp_path / "alone"
    proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.evaluate", "--controllers", "cpg_rl", "--checkpoint",
                           f"cpg_rl={policy}", "--rounds", "1", "--max_steps", "5", "--device", "cpu", "--sweep",
                           "tread_depth", "--no-nominal", "--out", str(alone)], capture_output=True, text=True,
                          timeout=900, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    res = json.loads((alone / "results.json").read_text())
    tread = res["sweeps"]["tread_depth"]
    assert res["results"] == {} and list(res["sweeps"]) == ["tread_depth"] and tread["terrain"] == "stepped"
    assert [p["value"] for p in tread["curves"]["cpg_rl"]] == [0.15, 0.18, 0.20, 0.22, 0.25]
    p = subprocess.run([sys.executable, "-m", "hexnewton.apps.evaluate", "--controllers", "cpg", "--sweep", "terrain.nope",
                        "1", "--device", "cpu", "--out", str(tmp_path / "x")], capture_output=True, text=True,
                       timeout=300, cwd=ROOT)  # fmt: skip
    err = [line for line in p.stderr.splitlines() if line.strip() and "Warp CUDA" not in line]
    assert p.returncode == 2 and len(err) == 1 and "terrain.nope" in err[0] and not (tmp_path / "x").exists()
    p = subprocess.run([sys.executable, "-m", "hexnewton.apps.evaluate", "--controllers", "cpg", "--no-nominal",
                        "--device", "cpu", "--out", str(tmp_path / "y")], capture_output=True, text=True,
                       timeout=300, cwd=ROOT)  # fmt: skip
    assert p.returncode == 2 and "leaves nothing to run" in p.stderr and not (tmp_path / "y").exists()
