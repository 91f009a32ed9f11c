"""The hexapod matches the paper's §3.5: mass, link lengths, joint limits, joint order and sign conventions."""

import math

import newton
import numpy as np
import pytest
import warp as wp

from hexnewton.config import JOINT_NAMES, RobotConfig
from hexnewton.robot import BASE_Q, build_hexapod, stand_height


@pytest.fixture(scope="module")
def robot():
    wp.init()
    builder = build_hexapod(RobotConfig(), gap=0.01)
    model = builder.finalize(device="cpu")
    return builder, model


def _fk(model, q_joints, base=(0.0, 0.0, 0.5)):
    """Body poses for the given 18 joint angles (free base at ``base``, identity orientation)."""
    q = np.zeros(model.joint_coord_count, dtype=np.float32)
    q[0:3] = base
    q[6] = 1.0
    q[BASE_Q:] = q_joints
    state = model.state()
    newton.eval_fk(model, wp.array(q, dtype=wp.float32), model.joint_qd, state)
    return state.body_q.numpy()


def _body(model, label):
    return [i for i, name in enumerate(model.body_label) if name.endswith(label)][0]


def test_mass_within_one_percent(robot):
    _, model = robot
    total = float(model.body_mass.numpy().sum())
    assert abs(total - 2.5) / 2.5 < 0.01


def test_topology_and_joint_order(robot):
    builder, model = robot
    assert model.articulation_count == 1
    assert model.joint_count == 19
    assert model.joint_type.numpy()[0] == int(newton.JointType.FREE)
    assert all(t == int(newton.JointType.REVOLUTE) for t in model.joint_type.numpy()[1:])
    labels = [name.split("/")[-1] for name in model.joint_label[1:]]
    assert tuple(labels) == JOINT_NAMES
    assert model.joint_coord_count == 25 and model.joint_dof_count == 24


def test_joint_limits_as_paper(robot):
    _, model = robot
    lo, hi = model.joint_limit_lower.numpy()[6:], model.joint_limit_upper.numpy()[6:]
    expect = [(-math.pi / 6, math.pi / 6), (0.0, math.pi / 2), (-math.pi / 3, 0.0)] * 6
    np.testing.assert_allclose(lo, [e[0] for e in expect], atol=1e-6)
    np.testing.assert_allclose(hi, [e[1] for e in expect], atol=1e-6)


def test_link_lengths(robot):
    _, model = robot
    body_q = _fk(model, np.zeros(18))
    for leg in ("R1", "R2", "R3", "L1", "L2", "L3"):
        coxa, femur, tibia = (body_q[_body(model, f"{leg}_{n}")][:3] for n in ("coxa", "femur", "tibia"))
        assert np.linalg.norm(femur - coxa) == pytest.approx(0.050, abs=1e-5)
        assert np.linalg.norm(tibia - femur) == pytest.approx(0.080, abs=1e-5)
    # tibia length: the foot sphere sits 130 mm from the ankle joint along the tibia
    shape_body = model.shape_body.numpy()
    foot = [i for i, n in enumerate(model.shape_label) if n.endswith("R1_foot")][0]
    offset = model.shape_transform.numpy()[foot][:3]
    assert shape_body[foot] == _body(model, "R1_tibia")
    assert np.linalg.norm(offset) == pytest.approx(0.130, abs=1e-6)


def _foot(model, body_q, leg):
    """World position of a leg's foot centre (130 mm down the tibia's local -z)."""
    t = body_q[_body(model, f"{leg}_tibia")]
    tf = wp.transform(wp.vec3(*t[:3]), wp.quat(*t[3:]))
    return np.array(wp.transform_point(tf, wp.vec3(0.0, 0.0, -0.130)))


@pytest.mark.parametrize("leg", ["R1", "R2", "R3", "L1", "L2", "L3"])
def test_sign_conventions(robot, leg):
    """hip > 0 moves the foot forward (+x), knee > 0 lifts it, ankle < 0 pulls it toward the body."""
    _, model = robot
    i = ("R1", "R2", "R3", "L1", "L2", "L3").index(leg)
    base = np.zeros(18)
    ref = _foot(model, _fk(model, base), leg)

    def moved(j, v):
        q = base.copy()
        q[3 * i + j] = v
        return _foot(model, _fk(model, q), leg)

    assert moved(0, 0.3)[0] > ref[0] + 0.01
    assert moved(1, 0.3)[2] > ref[2] + 0.01
    lateral = lambda p: abs(p[1])  # noqa: E731
    assert lateral(moved(2, -0.3)) < lateral(ref) - 0.01
    # neutral: femur horizontal (knee level with the hip), tibia vertical
    body_q = _fk(model, base)
    assert body_q[_body(model, f"{leg}_tibia")][2] == pytest.approx(0.5, abs=1e-6)
    assert ref[2] == pytest.approx(0.5 - 0.130, abs=1e-6)


def test_stand_height_formula(robot):
    _, model = robot
    cfg = RobotConfig()
    body_q = _fk(model, np.tile(cfg.stand_pose, 6))
    lowest = min(_foot(model, body_q, leg)[2] for leg in ("R1", "R2", "R3", "L1", "L2", "L3"))
    assert 0.5 - (lowest - cfg.foot_radius) == pytest.approx(stand_height(cfg), abs=1e-5)


def test_drives_and_self_collision_filtered(robot):
    builder, model = robot
    ke = model.joint_target_ke.numpy()[6:]
    assert np.all(ke > 0)
    n = model.shape_count
    assert len(builder.shape_collision_filter_pairs) >= n * (n - 1) // 2


def test_bad_config_is_one_clear_error():
    with pytest.raises(ValueError, match="stand_pose"):
        build_hexapod(RobotConfig(stand_pose=(0.0, -0.2, 0.0)))
    with pytest.raises(ValueError, match="total_mass"):
        build_hexapod(RobotConfig(total_mass=0.5))


def _model_arrays(cfg):
    model = build_hexapod(cfg, gap=0.01).finalize(device="cpu")
    state = model.state()
    newton.eval_fk(model, model.joint_q, model.joint_qd, state)
    names = ("body_mass", "body_inertia", "body_com", "joint_limit_lower", "joint_limit_upper", "joint_axis",
             "joint_X_p", "joint_q", "shape_scale", "shape_type", "joint_target_ke", "joint_armature")
    return {n: getattr(model, n).numpy() for n in names} | {"body_q": state.body_q.numpy(),
                                                            "labels": [str(x) for x in model.body_label]}


@pytest.mark.parametrize("name", ["paper", "mx_phoenix"])
def test_frames_build_the_robot_its_dimensions_build(name):
    """A robot given by its dimensions and the same robot frame by frame (``describe``) make the same Newton model:
    masses, inertias, frames, limits, shapes, gains, the standing pose's body poses (float32 rounding apart)."""
    from hexnewton.robot.geometry import describe
    from hexnewton.robot.registry import ROBOTS

    wp.init()
    a, b = _model_arrays(ROBOTS[name]), _model_arrays(describe(ROBOTS[name]))
    assert a.pop("labels") == b.pop("labels")
    for key in a:
        np.testing.assert_allclose(a[key], b[key], atol=2e-7, err_msg=key)


def test_robot_file_builds_the_named_robot():
    """The MX-Phoenix's MJCF file, loaded, builds the named robot's model: link masses, joint limits in hexnewton's
    sense, the standing pose's body poses (at the same spawn height)."""
    import dataclasses

    from hexnewton.robot.loader import load_robot
    from hexnewton.robot.mx_phoenix import MJCF, MX_PHOENIX

    wp.init()
    loaded = dataclasses.replace(load_robot(MJCF), spawn_height=MX_PHOENIX.spawn_height)
    a, b = _model_arrays(MX_PHOENIX), _model_arrays(loaded)
    for key in ("body_mass", "joint_limit_lower", "joint_limit_upper", "body_q", "joint_q"):
        np.testing.assert_allclose(a[key], b[key], atol=1e-5, err_msg=key)
