"""The capability ceiling on known values: the forward kinematics against Newton's and the standing height, the lift
growing with A2, the stairs' pitch against its closed form, footholds on flat and unclimbable stairs, the verdicts
and the command line's report and one-line errors."""

import json
import math

import numpy as np
import pytest

import ceiling_model as cap
from hexnewton.apps.cli import run
from hexnewton.config import CPGConfig, HexConfig, RobotConfig, gait_params
from hexnewton.robot import BASE_Q, stand_height

pytestmark = pytest.mark.slow  # a study's test: the CI line of its own (python -m pytest -q -m slow)


def _ceiling():
    """This study's ceiling.py, loaded by its path under a name of its own (studies/curriculum has a ceiling.py too,
    and pytest puts every test folder on sys.path)."""
    import importlib.util
    import os
    import sys

    name = "capability_ceiling"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, os.path.join(os.path.dirname(__file__), "ceiling.py"))
        sys.modules[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(sys.modules[name])
    return sys.modules[name]


def test_fk_at_the_standing_pose_matches_the_standing_height():
    robot = RobotConfig()
    feet = cap.feet_np(robot, cap.stand_q(robot))
    assert np.allclose(feet[:, 2], robot.foot_radius - stand_height(robot), atol=1e-12)
    assert np.allclose(feet[:3, 0], feet[3:, 0]) and np.allclose(feet[:3, 1], -feet[3:, 1])  # left mirrors right
    g = cap.robot_geometry(robot)
    assert g["stand_height_fk_m"] == pytest.approx(stand_height(robot), abs=1e-12)
    assert g["span_x_m"] == pytest.approx(feet[0, 0] - feet[2, 0])


def test_fk_matches_newton():
    """The NumPy forward kinematics against Newton's eval_fk of the built articulation, at random poses."""
    import newton
    import warp as wp

    from hexnewton.robot import build_hexapod, joint_limits

    wp.init()
    robot = RobotConfig()
    model = build_hexapod(robot, gap=0.01).finalize(device="cpu")
    lo, hi = np.array(joint_limits(robot)).T
    rng = np.random.default_rng(0)
    for q_joints in rng.uniform(lo, hi, size=(3, 18)):
        q = np.zeros(model.joint_coord_count, dtype=np.float32)
        q[6], q[BASE_Q:] = 1.0, q_joints
        state = model.state()
        newton.eval_fk(model, wp.array(q, dtype=wp.float32), model.joint_qd, state)
        body_q = state.body_q.numpy()
        for leg, name in enumerate(("R1", "R2", "R3", "L1", "L2", "L3")):
            t = body_q[[i for i, b in enumerate(model.body_label) if b.endswith(f"{name}_tibia")][0]]
            tf = wp.transform(wp.vec3(*t[:3]), wp.quat(*t[3:]))
            foot = np.array(wp.transform_point(tf, wp.vec3(0.0, 0.0, -robot.tibia_length)))
            assert np.allclose(cap.feet_np(robot, q_joints)[leg], foot, atol=1e-5), name


def _cycle(a2_values, a3=0.0, a1=0.3):
    cpg = CPGConfig()
    params = np.array([gait_params(cpg.omega_range[1], a1, a2, a3) for a2 in a2_values])
    return params, cap.cpg_cycle(RobotConfig(), cpg, params, dt=0.002)


def test_lift_grows_with_a2_and_stance_is_the_standing_pose():
    robot = RobotConfig()
    _, cycle = _cycle([0.3, 0.6, 0.9, 1.2])
    st = cap.lift_stats(robot, cycle)
    worst = st["lift"].min(axis=1)
    assert np.all(np.diff(worst) > 0.01)
    # without the posture a stance leg holds the standing pose: its foot at the standing height
    assert np.allclose(st["stance_z"], robot.foot_radius - stand_height(robot), atol=1e-9)
    # A2 at the knee alone: the peak is the FK of knee + A2 (ankle at its standing angle)
    k, a = robot.stand_pose[1] + 1.2, robot.stand_pose[2]
    peak = robot.femur_length * math.sin(k) - robot.tibia_length * math.cos(k + a)
    assert worst[-1] == pytest.approx(peak - (robot.foot_radius - stand_height(robot)), abs=1e-4)


def test_swing_path_lifts_off_and_touches_down():
    _, cycle = _cycle([1.0])
    x, z = cap.swing_paths(cycle, 0, 1)
    assert x[0] == 0.0 and z[0] == 0.0 and abs(z[-1]) < 1e-3 and np.all(np.diff(x) > -1e-6)
    stride = cap.lift_stats(RobotConfig(), cycle)["stride"][0, 1]
    assert x[-1] == pytest.approx(2 * stride, rel=0.05)  # duty 0.5: the body moves a stride while the foot swings


def test_footholds_flat_and_unclimbable():
    _, cycle = _cycle([1.0])
    x, z = cap.swing_paths(cycle, 0, 1)
    flat = cap.stair_footholds(x, z, 0.0, 0.25, 0.012, 0.01)
    assert flat["fail"] == 0.0 and flat["climb"] == 0.0
    tall = cap.stair_footholds(x, z, float(z.max()) + 0.005, 0.25, 0.012, 0.01)
    assert tall["climb"] == 0.0 and tall["per_riser"] < 0.01  # within the sampling of the path
    low = cap.stair_footholds(x, z, 0.02, 0.25, 0.012, 0.01)
    assert 0.0 < low["per_riser"] <= 1.0 and low["climb"] > 0.0


@pytest.mark.parametrize("rise,depth", [(0.06, 0.25), (0.08, 0.18), (0.06, 0.15)])
def test_stair_pitch_on_the_generated_flight_matches_its_closed_form(rise, depth):
    t = cap.stair_tilt(RobotConfig(), rise, depth)
    assert t["worst_deg"] == pytest.approx(t["closed_form_worst_deg"], abs=0.05)
    assert t["mean_deg"] == pytest.approx(t["closed_form_mean_deg"], abs=0.5)


def test_posture_levels_the_body_and_nothing_without_it():
    robot = RobotConfig()
    assert cap.posture_levelling(robot, CPGConfig())["pitch_deg"] == 0.0
    lev = cap.posture_levelling(robot, CPGConfig(posture=True))
    assert 0.0 < lev["pitch_deg"] < 20.0
    lo, hi = lev["height_m"]
    assert lo < stand_height(robot) < hi


@pytest.fixture(scope="module")
def small():
    """The shipped complex recipe's config (posture on, A2 0.9-1.3) on a coarse grid."""
    from hexnewton.tasks import task

    return cap.ceilings(task("complex").env, margin=0.01, n=2, dt=0.005)


def test_ceilings_and_verdicts(small):
    assert small["cpg"]["lift_max_m"] <= small["robot_lift_m"]
    assert small["cpg"]["lift_at_a2_min_m"] <= small["cpg"]["lift_max_m"]
    a3_0 = [r["a3_0_m"] for r in small["cpg"]["lift_by_a2"]]
    assert np.all(np.diff(a3_0) > 0)
    lines = {v["target"]: v for v in small["verdicts"]}
    assert set(lines) == {t[0] for t in cap.TARGETS}
    assert all(v["robot"] and v["cpg"] and v["fine"] and v["fall"] for v in lines.values())
    assert [v["gap"].split(",")[0] for v in lines.values()] == ["the controller's"] * 3
    assert "stability fine the nearest limit" in lines["8 cm rise"]["gap"]  # 24.6 deg standing, 5.4 below the fine
    assert "nearest" not in lines["20 cm treads"]["gap"] + lines["8 cm blocks"]["gap"]
    # the worst standing pitch of 8 cm x 25 cm stairs: two risers under the 0.35 m span
    assert lines["8 cm rise"]["fine_margin_deg"] == pytest.approx(30.0 - math.degrees(math.atan(0.16 / 0.3491)),
                                                                  abs=0.1)
    # a stricter tilt limit turns the stairs' verdicts, and a taller target the CPG's
    strict = {**small, "task": {**small["task"], "stability_tilt_rad": math.radians(20.0)}}
    assert [v["gap"].split(",")[0] for v in cap.verdicts(strict)] == ["the task's", "the controller's",
                                                                       "the controller's"]  # fmt: skip
    low = {**small, "cpg": {**small["cpg"], "lift_at_a2_min_m": 0.085}}
    assert [v["gap"].split(",")[0] for v in cap.verdicts(low)] == ["the controller's", "the controller's",
                                                                    "the CPG's"]  # fmt: skip
    short = {**small, "robot_lift_m": 0.05}
    assert [v["gap"] for v in cap.verdicts(short)] == ["the robot's"] * 3


def test_tread_limits_follow_the_span():
    robot = RobotConfig()
    span = cap.robot_geometry(robot)["span_x_m"]
    rows = {r["rise_m"]: r for r in cap.tread_limits(robot, 0.0, math.pi / 6)}
    assert rows[0.08]["tread_m"] == pytest.approx(span / 2)  # three risers under the span: atan(0.24 / span) > 30 deg
    assert rows[0.06]["tread_m"] == pytest.approx(span / 3)


def test_command_line_writes_the_report(tmp_path, monkeypatch, small):
    capability = _ceiling()

    monkeypatch.setattr("ceiling_model.ceilings", lambda cfg, **kw: dict(small))
    out = tmp_path / "ceiling"
    assert run(capability.main, "python studies/capability/ceiling.py", ["--out", str(out), "--task", "complex"]) == 0
    res = json.loads((out / "results.json").read_text())
    report = (out / "report.md").read_text()
    assert res["meta"]["command"].startswith("python studies/capability/ceiling.py --out")
    assert res["meta"]["command"] in report
    assert all(v["line"] in report for v in res["verdicts"]) and all(n in report for n in res["notes"])


def test_bad_input_is_one_clear_error(tmp_path, capsys):
    capability = _ceiling()

    assert run(capability.main, "python studies/capability/ceiling.py",
               ["--out", str(tmp_path / "a"), "--task", "complex", "--grid", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "n in [2, 9]" in err[0]
    assert run(capability.main, "python studies/capability/ceiling.py", ["--out", str(tmp_path / "b"), "--task",
                                                                        "nope"]) == 2  # fmt: skip
    assert "unknown task 'nope'" in capsys.readouterr().err
    with pytest.raises(ValueError, match="margin"):
        cap.ceilings(HexConfig(), margin=-0.01)
