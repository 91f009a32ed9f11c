"""Sim2sim in C MuJoCo (hexnewton.deploy.mjcf, hexnewton.apps.sim2sim): the MJCF is the Newton robot, the terrain and the height
scanner are the training's grid, a shipped bundle walks closed loop, and the command line's outputs and errors."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")

from hexnewton.analysis.sim2sim import HeightScanner, Rounds, fixed_cpg_spec, join_parts, measure  # noqa: E402
from hexnewton.apps.sim2sim import HEADLINE, PROG, main  # noqa: E402
from hexnewton.config import JOINT_NAMES, RobotConfig, TerrainConfig  # noqa: E402
from hexnewton.deploy.mjcf import SENSORS_PER_ROBOT, build_model, robot_xml  # noqa: E402
from hexnewton.mdp.status import RUNNING, SUCCESS  # noqa: E402
from hexnewton.terrain.heightmap import build_height_grid  # noqa: E402

BUNDLE = os.path.join(os.path.dirname(__file__), "..", "..", "results", "controllers", "cpg_rl_complex")


def _newton_robot(cfg: RobotConfig, q: np.ndarray):
    """Newton's robot (build_hexapod) on the CPU at joint coordinates ``q`` (25,): model and body poses (N, 7)."""
    import newton
    import warp as wp

    from hexnewton.robot import build_hexapod

    model = build_hexapod(cfg).finalize(device="cpu")
    state = model.state()
    newton.eval_fk(model, wp.array(q, dtype=wp.float32, device="cpu"), model.joint_qd, state)
    return model, state.body_q.numpy()


def _mujoco_robot(cfg: RobotConfig, q: np.ndarray):
    m = mujoco.MjModel.from_xml_string(f"<mujoco><compiler angle='radian' autolimits='true'/><worldbody>"
                                       f"{robot_xml(cfg)}</worldbody></mujoco>")  # fmt: skip
    d = mujoco.MjData(m)
    d.qpos[:] = np.r_[q[:3], q[6], q[3:6], q[7:]]  # MuJoCo's free joint quaternion is (w, x, y, z)
    mujoco.mj_kinematics(m, d)
    return m, d


def test_mjcf_is_the_newton_robot():
    cfg = RobotConfig()
    rng = np.random.default_rng(0)
    lo, hi = np.array([cfg.hip_limit, cfg.knee_limit, cfg.ankle_limit] * 6).T
    yaw = 0.4
    q = np.r_[0.1, -0.2, 0.3, 0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2), rng.uniform(lo, hi)]
    nm, body_q = _newton_robot(cfg, q)
    m, d = _mujoco_robot(cfg, q)
    assert m.nbody - 1 == nm.body_count == 19 and m.njnt - 1 == 18
    # every body frame (joint positions, link lengths, mounts, splay, axes and their signs) at a random pose
    np.testing.assert_allclose(d.xpos[1:], body_q[:, :3], atol=1e-5)
    np.testing.assert_allclose(np.abs(np.sum(d.xquat[1:][:, [1, 2, 3, 0]] * body_q[:, 3:], axis=1)), 1.0, atol=1e-5)
    # masses, centres of mass, inertias
    np.testing.assert_allclose(m.body_mass[1:], nm.body_mass.numpy(), rtol=1e-6)
    np.testing.assert_allclose(m.body_mass[1:].sum(), cfg.total_mass, rtol=1e-9)
    np.testing.assert_allclose(m.body_ipos[1:], nm.body_com.numpy(), atol=1e-7)
    inertia = nm.body_inertia.numpy()
    np.testing.assert_allclose(m.body_inertia[1:], np.stack([np.diag(i) for i in inertia]), rtol=1e-5)
    # joint limits, armature, names in the observation's order
    limits = np.c_[nm.joint_limit_lower.numpy()[6:], nm.joint_limit_upper.numpy()[6:]]
    np.testing.assert_allclose(m.jnt_range[1:], limits, atol=1e-6)
    np.testing.assert_allclose(m.dof_armature[6:], nm.joint_armature.numpy()[6:], rtol=1e-6)
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(1, 19)] == list(JOINT_NAMES)


def test_servos_and_sensors_follow_the_robot_config():
    cfg = RobotConfig()
    m = build_model(cfg, None, [(0.0, 0.0, 0.2, 0.0)], 0.005)
    nm, _ = _newton_robot(cfg, np.r_[0, 0, 0.2, 0, 0, 0, 1, np.tile(cfg.stand_pose, 6)])
    assert m.nu == 18 and m.nsensordata == 4 + 36 + 3 == SENSORS_PER_ROBOT
    # the gyro (last) reads the torso's angular velocity in its own frame: a free joint's qvel[3:6] in MuJoCo
    d = mujoco.MjData(m)
    d.qpos[3:7] = [np.cos(0.4), np.sin(0.4), 0.0, 0.0]
    d.qvel[:6] = [0.1, -0.2, 0.3, 0.7, -1.1, 0.4]
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.sensordata[40:43], d.qvel[3:6], atol=1e-12)
    np.testing.assert_allclose(m.actuator_gainprm[:, 0], nm.joint_target_ke.numpy()[6:], rtol=1e-6)
    bias = np.c_[-nm.joint_target_ke.numpy()[6:], -nm.joint_target_kd.numpy()[6:]]
    np.testing.assert_allclose(m.actuator_biasprm[:, 1:3], bias, rtol=1e-6)
    np.testing.assert_allclose(m.actuator_forcerange, np.c_[-nm.joint_effort_limit.numpy()[6:],
                                                            nm.joint_effort_limit.numpy()[6:]], rtol=1e-6)  # fmt: skip
    assert m.opt.timestep == 0.005 and m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST


def test_terrain_boxes_and_scanner_are_the_height_grid():
    from hexnewton.terrain import max_terrain_height_np, terrain_height_np

    grid = build_height_grid(TerrainConfig(name="complex", seed=3))
    m = build_model(RobotConfig(), grid, [], 0.005)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    rng = np.random.default_rng(1)
    x, y = rng.uniform(-0.9, 3.2, 60), rng.uniform(-1.0, 1.0, 60)
    # the collision boxes: a vertical ray onto the boxes (geom group 0) lands on the cell's height
    top = np.array([2.0 - mujoco.mj_ray(m, d, np.array([a, b, 2.0]), np.array([0, 0, -1.0]),
                                        np.array([1, 0, 0, 0, 0, 0], np.uint8), 1, -1, None) for a, b in zip(x, y)])
    np.testing.assert_allclose(top, terrain_height_np(grid, x, y), atol=1e-6)
    # the scanner: ground under a point and the highest cell of the +-30 cm window, as the training's grid query
    scan = HeightScanner(m, d, grid)
    np.testing.assert_allclose([scan.height(a, b) for a, b in zip(x, y)], terrain_height_np(grid, x, y), atol=1e-6)
    np.testing.assert_allclose([scan.reading(a, b) for a, b in zip(x[:8], y[:8])],
                               max_terrain_height_np(grid, x[:8], y[:8], 0.3) - terrain_height_np(grid, x[:8], y[:8]),
                               atol=1e-6)  # fmt: skip


def test_shipped_bundle_walks_forward_in_mujoco():
    r = Rounds(BUNDLE, "flat", 2)
    x0 = r.d.qpos.reshape(2, 25)[:, 0].copy()
    for _ in range(200):  # 4 s
        r.control_step()
        status, rpy = r.status()
        assert (status == RUNNING).all(), status
    q = r.d.qpos.reshape(2, 25)
    assert (q[:, 0] - x0 > 0.3).all(), q[:, 0]
    assert (np.abs(rpy[:, :2]) < 0.3).all() and (q[:, 2] > 0.1).all()


def test_fixed_cpg_runs_through_the_runtime():
    spec = fixed_cpg_spec()
    r = Rounds(spec, "flat", 1)
    assert not r.policy and r.ctrl.params[0].tolist() == pytest.approx(spec["initial_params"])
    for _ in range(100):
        r.control_step()
    assert r.d.qpos[0] > 0.1 and (r.status()[0] == RUNNING).all()


def test_cli_writes_results_and_rejects_bad_input(tmp_path, capsys):
    from hexnewton.apps.cli import run

    out = str(tmp_path / "s2s")
    args = [BUNDLE, "--terrains", "flat", "--rounds", "2", "--max_steps", "20", "--fixed_terrains", "--out", out]
    assert run(main, PROG, args) == 0
    with open(os.path.join(out, "results.json")) as f:
        res = json.load(f)
    assert list(res) == ["flat"] and set(res["flat"]) == set(HEADLINE) and res["flat"]["rounds"] == 2
    assert os.path.isfile(os.path.join(out, "report.md")) and os.path.isfile(os.path.join(out, "details.json"))
    capsys.readouterr()
    assert run(main, PROG, args) == 2  # --out exists
    assert "exists" in capsys.readouterr().err
    assert run(main, PROG, [str(tmp_path), "--out", str(tmp_path / "x")]) == 2  # not a bundle
    with pytest.raises(SystemExit) as e:
        run(main, PROG, [BUNDLE, "--rounds", "0", "--out", str(tmp_path / "y")])
    assert e.value.code == 2
    assert run(main, PROG, [BUNDLE, "--video", str(tmp_path / "v.avi"), "--out", str(tmp_path / "z")]) == 2
    assert run(main, PROG, [BUNDLE, "--workers", "-1", "--out", str(tmp_path / "w")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 4 and all(line.startswith(PROG) for line in err) and "--workers" in err[-1]


def test_newton_reference_reads_both_results_layouts(tmp_path):
    """``--newton`` takes evaluate's own results.json (``meta`` + ``results``) and a study's (``test``)."""
    import json

    from hexnewton.apps.sim2sim import newton_reference

    summary = {"rounds": 10, "success_3m": 0.9}
    own = tmp_path / "own.json"
    own.write_text(json.dumps({"meta": {"device": "cuda:0"}, "results": {"rugged": {"cpg_rl": summary}}}))
    study = tmp_path / "study.json"
    study.write_text(json.dumps({"device": "H200", "policy": "p.pt", "test": {"rugged": {"cpg": summary}}}))
    a, b = newton_reference(str(own)), newton_reference(str(study))
    assert a["cpg_rl"] == {"rugged": summary} and a["device"] == "cuda:0" and "cpg" not in a
    assert b["cpg"] == {"rugged": summary} and b["device"] == "H200" and b["policy"] == "p.pt"


def test_rounds_subset_keeps_each_rounds_start():
    whole = Rounds(BUNDLE, "stepped", 4, 1000)
    part = Rounds(BUNDLE, "stepped", 4, 1000, robots=[1, 3])
    np.testing.assert_array_equal(part.d.qpos.reshape(2, 25), whole.d.qpos.reshape(4, 25)[[1, 3]])
    np.testing.assert_array_equal(part.goal, whole.goal[[1, 3]])
    for bad in ([], [4], [[0, 1]], [-1]):
        with pytest.raises(ValueError, match="robots must be indices"):
            Rounds(BUNDLE, "flat", 4, robots=bad)


def test_join_parts_pads_the_shorter_part_as_ended_robots_read():
    def part(t, n, ended):
        done = np.zeros((t, n), bool)
        done[-1] = ended
        status = np.where(done, SUCCESS, RUNNING)
        return {"pos": np.ones((t, n, 2)), "rpy": np.zeros((t, n, 3)), "done": done, "status": status,
                "control_dt": 0.02, "steps": t, "rays": 5}

    ep = join_parts([part(3, 2, True), part(5, 1, True)])
    assert ep["pos"].shape == (5, 3, 2) and ep["steps"] == 5 and ep["rays"] == 10
    assert np.isnan(ep["pos"][3:, :2]).all() and not ep["done"][3:, :2].any()
    assert (ep["status"][3:, :2] == RUNNING).all()
    assert ep["done"][2, :2].all() and ep["done"][4, 2] and ep["done"].sum() == 3


def test_workers_run_the_same_rounds_as_one_model():
    one = measure(BUNDLE, "stepped", 4, 1000, max_steps=40)
    two = measure(BUNDLE, "stepped", 4, 1000, max_steps=40, workers=2)
    for k in ("rounds", "success_3m", "fall_rate", "control_steps"):
        assert one[k] == two[k], k
    for k in ("pitch_var_deg2", "roll_var_deg2", "y_dev_mean_m"):
        assert two[k] == pytest.approx(one[k], rel=1e-6, abs=1e-9), k
    with pytest.raises(ValueError, match="on_step"):
        measure(BUNDLE, "flat", 2, workers=2, on_step=lambda r: None)


def _other_robot(name: str) -> RobotConfig:
    """The MX-Phoenix by name, or as its URDF or MJCF file."""
    from hexnewton.robot.mx_phoenix import MJCF, URDF
    from hexnewton.robot.registry import resolve_robot

    return resolve_robot({"mx_phoenix": "mx_phoenix", "urdf": URDF, "xml": MJCF}[name])


@pytest.mark.parametrize("name", ["mx_phoenix", "urdf", "xml"])
def test_mjcf_is_the_newton_robot_for_other_robots(name):
    """The MX-Phoenix by its dimensions and as its URDF and MJCF files (written from their frames,
    ``mjcf.frames_robot_xml``): every body frame at a random pose, masses, centres of mass, limits in hexnewton's sense
    and joint names as Newton's."""
    from hexnewton.robot import leg_bounds

    cfg = _other_robot(name)
    rng = np.random.default_rng(1)
    lo, hi = (np.tile(b, 6) for b in leg_bounds(cfg))
    q = np.r_[0.1, -0.2, 0.3, 0.0, 0.0, np.sin(0.2), np.cos(0.2), rng.uniform(lo, hi)]
    nm, body_q = _newton_robot(cfg, q)
    m, d = _mujoco_robot(cfg, q)
    assert m.nbody - 1 == nm.body_count == 19 and m.njnt - 1 == 18
    np.testing.assert_allclose(d.xpos[1:], body_q[:, :3], atol=1e-5)
    np.testing.assert_allclose(np.abs(np.sum(d.xquat[1:][:, [1, 2, 3, 0]] * body_q[:, 3:], axis=1)), 1.0, atol=1e-5)
    np.testing.assert_allclose(m.body_mass[1:], nm.body_mass.numpy(), rtol=1e-6)
    np.testing.assert_allclose(m.body_mass[1:].sum(), 4.2, rtol=1e-9)
    limits = np.c_[nm.joint_limit_lower.numpy()[6:], nm.joint_limit_upper.numpy()[6:]]
    np.testing.assert_allclose(m.jnt_range[1:], limits, atol=1e-6)
    assert [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(1, 19)] == list(JOINT_NAMES)


def test_second_robot_walks_in_mujoco_with_the_fixed_cpg():
    """The MX-Phoenix's fixed CPG (its own spec: description, scales) in C MuJoCo on flat ground for 4 s: it stands at
    its height and walks ahead; the spec names the robot."""
    from hexnewton.robot.mx_phoenix import MX_PHOENIX

    spec = fixed_cpg_spec(robot=MX_PHOENIX)
    assert spec["robot"] == "mx_phoenix" and spec["height_scale"] > 1.6 and "robot_description" in spec
    assert "robot" not in fixed_cpg_spec()  # the paper robot's spec as it was
    r = Rounds(spec, "flat", 2)
    out = r.run(max_steps=200)
    assert (out["status"][-1] == RUNNING).all()
    assert np.all(out["pos"][-1][:, 0] > 0.8)
    z = r.d.qpos.reshape(2, 25)[:, 2]
    assert np.all(np.abs(z - 0.22) < 0.04), z
