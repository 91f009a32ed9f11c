"""Sim2sim in C MuJoCo (hexnewton.deploy.mjcf, hexnewton.apps.sim2sim): the MJCF is the Newton robot, the terrain and the height
scanner are the training's grid, a shipped bundle walks closed loop, a robot's own MJCF file runs as written
(hexnewton.deploy.robot_mjcf: as the generated model, joints turned round or not), and the command line's outputs and
errors."""

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


def _robot(name: str) -> RobotConfig:
    """The paper's robot, or the MX-Phoenix by name or as its URDF or MJCF file."""
    from hexnewton.robot.mx_phoenix import MJCF, URDF
    from hexnewton.robot.registry import resolve_robot

    return resolve_robot({"paper": "paper", "mx_phoenix": "mx_phoenix", "urdf": URDF, "xml": MJCF}[name])


def _inertia(m) -> np.ndarray:
    """The bodies' inertia tensors (nbody - 1, 3, 3) about their centres of mass, in their frames."""
    out = []
    for quat, diag in zip(m.body_iquat[1:], m.body_inertia[1:]):
        rot = np.zeros(9)
        mujoco.mju_quat2Mat(rot, quat)
        rot = rot.reshape(3, 3)
        out.append(rot @ np.diag(diag) @ rot.T)
    return np.asarray(out)


@pytest.mark.parametrize("name", ["paper", "mx_phoenix", "urdf", "xml"])
def test_mjcf_is_the_newton_robot(name):
    """The MJCF written from a description is Newton's robot (``build_hexapod``): the paper's robot, the MX-Phoenix by
    its dimensions and as its URDF and MJCF files (written from their frames, ``mjcf.frames_robot_xml``). Every body
    frame (joint positions, link lengths, mounts, splay, axes and their signs) at a random pose, masses, centres of
    mass, inertias, limits in hexnewton's sense, armature, and the joint names in the observation's order."""
    from hexnewton.robot import leg_bounds

    cfg = _robot(name)
    rng = np.random.default_rng(0)
    lo, hi = (np.tile(b, 6) for b in leg_bounds(cfg))
    yaw = 0.4
    q = np.r_[0.1, -0.2, 0.3, 0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2), rng.uniform(lo, hi)]
    nm, body_q = _newton_robot(cfg, q)
    m, d = _mujoco_robot(cfg, q)
    assert m.nbody - 1 == nm.body_count == 19 and m.njnt - 1 == 18
    np.testing.assert_allclose(d.xpos[1:], body_q[:, :3], atol=1e-5)
    np.testing.assert_allclose(np.abs(np.sum(d.xquat[1:][:, [1, 2, 3, 0]] * body_q[:, 3:], axis=1)), 1.0, atol=1e-5)
    np.testing.assert_allclose(m.body_mass[1:], nm.body_mass.numpy(), rtol=1e-6)
    np.testing.assert_allclose(m.body_mass[1:].sum(), cfg.total_mass, rtol=1e-9)
    np.testing.assert_allclose(m.body_ipos[1:], nm.body_com.numpy(), atol=1e-7)
    np.testing.assert_allclose(_inertia(m), nm.body_inertia.numpy(), rtol=1e-5, atol=1e-10)
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


def _leg_bodies(r: Rounds, names) -> list[list[int]]:
    """Per robot of ``r``, the bodies of the leg joints ``names`` (the model's names after the ``r<k>_`` prefix)."""
    return [[int(r.m.jnt_bodyid[mujoco.mj_name2id(r.m, mujoco.mjtObj.mjOBJ_JOINT, f"r{k}_{n}")]) for n in names]
            for k in range(r.n)]  # fmt: skip


def test_a_robots_own_mjcf_walks_as_the_model_generated_from_it():
    """The MX-Phoenix's own MJCF file run as written (``mjcf``: ``deploy.robot_mjcf``) with the fixed CPG, 3 rounds of
    5 s on flat ground: each round's distance is within 10 % of the generated model's. Two things of the file differ:
    its feet are bodies of their own (MuJoCo softens a contact by its body's weight, ``body_invweight0``) and its geoms
    have MuJoCo's friction 1 (the generated model's 0.9). Set as the generated model has them, the rounds are the
    generated model's to rounding: the targets reach the file's joints by name, in its senses, through its own
    servos, and the sensors read back in hexnewton's."""
    from hexnewton.robot.mx_phoenix import MJCF

    robot = _robot("xml")
    spec = fixed_cpg_spec(robot=robot)
    gen, own, aligned = Rounds(spec, "flat", 3), Rounds(spec, "flat", 3, mjcf=MJCF), Rounds(spec, "flat", 3, mjcf=MJCF)
    signs = [j.sign for leg in robot.legs for j in leg.joints]
    assert own.layout.signs.tolist() == signs and signs.count(-1.0) == 6  # the file's left knees and ankles
    assert own.m.nbody == gen.m.nbody + 3 * 6 and own.m.nu == gen.m.nu == 54  # its feet; its 18 servos each
    np.testing.assert_array_equal(own.m.actuator_gainprm[:, 0], 100.0)  # the file's kp
    ankles = [j.name for leg in robot.legs for j in leg.joints][2::3]
    for g_row, o_row in zip(_leg_bodies(gen, [f"{leg}_ankle" for leg in ("R1", "R2", "R3", "L1", "L2", "L3")]),
                            _leg_bodies(aligned, ankles)):  # fmt: skip
        for g, o in zip(g_row, o_row):
            foot = int(np.flatnonzero(aligned.m.body_parentid == o)[0])
            aligned.m.body_invweight0[[o, foot]] = gen.m.body_invweight0[g]
    robot_geoms = aligned.m.geom_contype == 1
    aligned.m.geom_friction[robot_geoms] = gen.m.geom_friction[gen.m.geom_contype == 1][0]
    a, b, c = (r.run(max_steps=250) for r in (gen, own, aligned))
    assert (a["status"][-1] == RUNNING).all() and (b["status"][-1] == RUNNING).all()
    assert np.all(a["pos"][-1][:, 0] > 1.2), a["pos"][-1]
    np.testing.assert_allclose(b["pos"][-1][:, 0], a["pos"][-1][:, 0], rtol=0.10)
    np.testing.assert_allclose(c["pos"], a["pos"], rtol=0, atol=1e-8)  # (a foot body: sums in another order)
    np.testing.assert_allclose(aligned.layout.qpos(aligned.d), gen.layout.qpos(gen.d), rtol=0, atol=1e-8)


def test_a_file_with_joints_turned_round_walks_as_it_did(flipped_mjcf, flipped_names):
    """The MX-Phoenix's MJCF with 5 joints turned round (axes reversed, ranges and keyframe negated: the same robot,
    those joints counting the other way) loads with those joints' senses reversed and nothing else changed, and walks
    in sim2sim as the file as written does, number for number; its own angles and servo controls at those joints are
    the other file's negated."""
    import dataclasses

    from hexnewton.robot.loader import load_robot
    from hexnewton.robot.mx_phoenix import MJCF

    robot, flipped = _robot("xml"), load_robot(flipped_mjcf)
    names = [j.name for leg in robot.legs for j in leg.joints]
    sa, sb = (np.array([j.sign for leg in r.legs for j in leg.joints]) for r in (robot, flipped))
    turned = np.isin(names, flipped_names)
    np.testing.assert_array_equal(sb, np.where(turned, -sa, sa))
    legs = [dataclasses.replace(leg, joints=tuple(dataclasses.replace(j, sign=float(s))
                                                  for j, s in zip(leg.joints, sa[3 * k:3 * k + 3])))
            for k, leg in enumerate(flipped.legs)]  # fmt: skip
    assert dataclasses.replace(flipped, name=robot.name, source=robot.source, legs=tuple(legs)) == robot
    ra = Rounds(fixed_cpg_spec(robot=robot), "flat", 2, mjcf=MJCF)
    rb = Rounds(fixed_cpg_spec(robot=flipped), "flat", 2, mjcf=flipped_mjcf)
    ea, eb = ra.run(max_steps=200), rb.run(max_steps=200)
    assert np.all(ea["pos"][-1][:, 0] > 0.9), ea["pos"][-1]
    np.testing.assert_allclose(eb["pos"], ea["pos"], rtol=0, atol=1e-9)
    qa, qb = (r.d.qpos.reshape(2, -1)[:, r.layout.joint_q] for r in (ra, rb))
    ca, cb = (r.d.ctrl[r.layout.actuators] for r in (ra, rb))
    assert np.abs(qa[:, turned]).min() > 1e-3
    np.testing.assert_allclose(qb, np.where(turned, -qa, qa), atol=1e-9)
    np.testing.assert_allclose(cb, np.where(turned, -ca, ca), atol=1e-9)


def test_a_robot_file_without_servos_or_free_joint_gets_them_and_other_drives_are_refused(tmp_path):
    """A file without actuators gets the generated model's servos (its description's gains), a root body without a
    free joint gets one, each said in one note; a geared servo gets its gear x the file's angle; a leg joint on a
    motor, or servos on some leg joints only, is one error line; so are a file that is not the robot's and a robot
    that has no MJCF file."""
    import dataclasses
    import re

    from hexnewton.deploy.robot_mjcf import RobotFile, check_file
    from hexnewton.errors import HexnewtonError
    from hexnewton.robot.loader import load_robot
    from hexnewton.robot.mx_phoenix import MJCF, MX_PHOENIX

    text = open(MJCF).read()

    def write(name: str, body: str) -> str:
        (tmp_path / name).write_text(body)
        return str(tmp_path / name)

    bare = write("bare.xml", re.sub(r"<actuator>.*</actuator>", "", text).replace('<freejoint name="root"/>', "")
                 .replace('qpos="0 0 0.25 1 0 0 0 ', 'qpos="'))  # fmt: skip
    robot = load_robot(bare)
    assert robot.joint_ke != 100.0  # no servos in the file: the paper robot's gains, scaled
    rf = RobotFile(bare, robot)
    assert len(rf.notes) == 2 and "no free joint" in rf.notes[0] and "adds the generated model's" in rf.notes[1]
    m, layout = rf.model(None, [(0.0, 0.0, 0.3, 0.0), (0.0, 0.5, 0.3, 0.0)], 0.005)
    assert m.nu == 36 and layout.nq == 25 and (m.jnt_type[m.body_jntadr[layout.torsos]] == 0).all()  # free joints
    np.testing.assert_allclose(m.actuator_gainprm[:, 0], robot.joint_ke)
    np.testing.assert_allclose(m.actuator_forcerange, np.tile([-robot.effort_limit, robot.effort_limit], (36, 1)))
    r = Rounds(fixed_cpg_spec(robot=robot), "flat", 1, mjcf=bare)
    for _ in range(25):
        r.control_step()
    assert (r.status()[0] == RUNNING).all() and r.layout.qpos(r.d)[0, 2] > 0.15
    geared = write("geared.xml", text.replace('kp="100" kv="2" forcerange="-6 6"', 'kp="25" kv="0.5" gear="2"'))
    r = Rounds(fixed_cpg_spec(robot=load_robot(geared)), "flat", 1, mjcf=geared)
    target = np.tile([0.1, 0.2, -0.3], 6)
    r.layout.set_targets(r.d, target[None])
    np.testing.assert_allclose(r.d.ctrl, 2.0 * r.layout.signs * target)  # a servo's control: gear x the file's angle
    motor = write("motor.xml", text.replace('<position joint="rm_femur" kp="100" kv="2" forcerange="-6 6"/>',
                                            '<motor joint="rm_femur" gear="1"/>'))  # fmt: skip
    some = write("some.xml", text.replace('<position joint="lr_tibia" kp="100" kv="2" forcerange="-6 6"/>', ""))
    cases = {motor: "leg joint 'rm_femur' (no position servo) is not driven by one position servo",
             some: "no actuator on leg joint 'lr_tibia', position servos on the others"}  # fmt: skip
    for path, says in cases.items():
        with pytest.raises(HexnewtonError) as err:
            RobotFile(path, load_robot(path))
        assert says in str(err.value) and "\n" not in str(err.value), str(err.value)
    for path, cfg, says in [(MJCF, dataclasses.replace(robot, source=MJCF), "is no longer robot"),
                            (str(tmp_path / "gone.xml"), robot, "is not here"),
                            ("", MX_PHOENIX, "a named robot: --mjcf own runs a robot's own MJCF file")]:  # fmt: skip
        with pytest.raises(HexnewtonError, match=re.escape(says)):
            check_file(path, cfg)


def test_cli_runs_a_robots_own_mjcf_where_it_can(flipped_bundle, flipped_mjcf, tmp_path, capsys):
    """``--mjcf``: a bundle of a robot read from an MJCF file runs that file by default (one line says so, the report
    names it), ``--mjcf generated`` the model written from the description. A bundle whose file is not here runs the
    generated model with one line, ``--mjcf own`` then is one error line, and ``--robot FILE`` gives the file; a
    named robot's bundle has no file to run."""
    import shutil

    from hexnewton.apps.cli import run

    moved = tmp_path / "moved"
    shutil.copytree(flipped_bundle, moved)
    spec = json.loads((moved / "controller.json").read_text())
    spec["robot_description"]["source"] = str(tmp_path / "elsewhere" / "flipped.xml")  # exported on another machine
    (moved / "controller.json").write_text(json.dumps(spec))

    def sim2sim(bundle, *flags) -> tuple[int, str, str, dict]:
        out = tmp_path / f"s2s{len(list(tmp_path.iterdir()))}"
        code = run(main, PROG, [str(bundle), "--terrains", "flat", "--rounds", "1", "--max_steps", "20",
                                "--fixed_terrains", "flat", "--out", str(out), *flags])  # fmt: skip
        got = capsys.readouterr()
        meta = json.loads((out / "details.json").read_text())["meta"] if code == 0 else {}
        return code, got.out, got.err, meta

    code, out, _, meta = sim2sim(flipped_bundle)
    assert code == 0 and f"its own MJCF file {flipped_mjcf}, as written" in out and flipped_mjcf in meta["model"]
    code, out, _, meta = sim2sim(flipped_bundle, "--mjcf", "generated")
    assert code == 0 and "MJCF" not in out and meta["model"] == "written from the bundle's description"
    code, out, _, meta = sim2sim(moved)
    lines = [line for line in out.splitlines() if line.startswith("sim2sim:")]
    assert code == 0 and len(lines) == 1 and "is not here: running the model written from" in lines[0], out
    assert meta["model"] == "written from the bundle's description"
    code, _, err, _ = sim2sim(moved, "--mjcf", "own")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--mjcf own: robot flipped's file" in err, err
    code, out, _, meta = sim2sim(moved, "--mjcf", "own", "--robot", flipped_mjcf)
    assert code == 0 and flipped_mjcf in meta["model"]
    code, _, err, _ = sim2sim(BUNDLE, "--mjcf", "own")
    assert code == 2 and "robot paper is a named robot" in err, err
