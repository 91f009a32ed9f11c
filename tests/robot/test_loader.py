"""Robot files: the MX-Phoenix's URDF and MJCF (written by us, ``scripts/robot_files.py``) load to its named
description (joint order, senses, limits, masses, frames), and a file with a leg missing, a leg of two joints, a
continuous joint, a joint without limits, seven legs or a bad path is one error line (exit status 2 from the command
lines: tests/apps/test_robot_flag.py)."""

import copy
import dataclasses
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from hexnewton.errors import HexnewtonError
from hexnewton.robot.geometry import describe, joint_limits, leg_bounds, robot_mass, stand_height
from hexnewton.robot.loader import load_robot
from hexnewton.robot.mx_phoenix import MJCF, MX_PHOENIX, URDF
from hexnewton.robot.registry import ROBOTS, resolve_robot

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SPEC = describe(MX_PHOENIX)


@pytest.fixture(scope="module", params=["urdf", "mjcf"])
def loaded(request):
    return load_robot(URDF if request.param == "urdf" else MJCF)


def _same_frame(a, b) -> bool:
    q = np.asarray(a.quat)
    return (np.allclose(a.pos, b.pos, atol=1e-9) and np.allclose(a.axis, b.axis, atol=1e-9)
            and (np.allclose(q, b.quat, atol=1e-9) or np.allclose(-q, b.quat, atol=1e-9)))  # fmt: skip


def test_files_load_to_the_named_robot(loaded):
    """Joint order (each file's names in hexnewton's leg order), limits and senses, masses, frames, the standing pose
    and its height as the named description's."""
    sides = ("rf", "rm", "rr", "lf", "lm", "lr")
    names = [j.name for leg in loaded.legs for j in leg.joints]
    assert [n.split("_")[0] for n in names] == [s for s in sides for _ in range(3)]
    assert [n.split("_")[1] for n in names] == ["coxa", "femur", "tibia"] * 6
    np.testing.assert_allclose(joint_limits(loaded), joint_limits(SPEC), atol=1e-9)
    np.testing.assert_allclose(leg_bounds(loaded), leg_bounds(MX_PHOENIX), atol=1e-9)
    assert robot_mass(loaded) == pytest.approx(MX_PHOENIX.total_mass, abs=1e-9)
    assert loaded.torso.mass == pytest.approx(SPEC.torso.mass, abs=1e-9)
    for leg, spec in zip(loaded.legs, SPEC.legs):
        np.testing.assert_allclose(leg.foot, spec.foot, atol=1e-9)
        for j, s in zip(leg.joints, spec.joints):
            assert _same_frame(j, s), (j.name, j.pos, s.pos, j.axis, s.axis)
            assert j.link.mass == pytest.approx(s.link.mass, abs=1e-9)
            np.testing.assert_allclose(j.link.com, s.link.com, atol=1e-9)
    assert loaded.stand_pose == pytest.approx(MX_PHOENIX.stand_pose, abs=1e-9)
    assert stand_height(loaded) == pytest.approx(stand_height(MX_PHOENIX), abs=1e-9)
    assert loaded.foot_radius == pytest.approx(MX_PHOENIX.foot_radius)


def test_senses_follow_the_files_axes():
    """The URDF turns every hip about +z and every knee and ankle about +y: the left hips and all knees and ankles are
    reversed (sign -1); the MJCF reverses the left knees and ankles only."""
    urdf, mjcf = load_robot(URDF), load_robot(MJCF)
    assert [j.sign for leg in urdf.legs for j in leg.joints] == [1, -1, -1] * 3 + [-1, -1, -1] * 3
    assert [j.sign for leg in mjcf.legs for j in leg.joints] == [1, 1, 1] * 3 + [1, -1, -1] * 3
    assert (mjcf.joint_ke, mjcf.joint_kd, mjcf.effort_limit, mjcf.armature) == (100.0, 2.0, 6.0, 0.005)
    assert urdf.effort_limit == 6.0  # the URDF's <limit effort>


def test_registry_names_and_files():
    """A name, a file (a path object too) or a description as it is (``gym.make(..., robot=)`` takes all three);
    anything else is one line."""
    import pathlib

    assert ROBOTS["paper"] == dataclasses.replace(ROBOTS["paper"]) and resolve_robot("paper").legs == ()
    assert resolve_robot("mx_phoenix") is MX_PHOENIX and resolve_robot(MX_PHOENIX) is MX_PHOENIX
    assert resolve_robot(URDF).source == URDF and resolve_robot(pathlib.Path(URDF)).source == URDF
    with pytest.raises(HexnewtonError, match="unknown robot 'phantom'"):
        resolve_robot("phantom")
    with pytest.raises(HexnewtonError, match="robot 3: expected a robot's name"):
        resolve_robot(3)
    with pytest.raises(HexnewtonError, match="robot_joints names a robot file's joints"):
        resolve_robot(MX_PHOENIX, ("j",) * 18)


def _urdf_tree():
    return ET.parse(URDF).getroot()


def _write(tmp_path, root, name="robot.urdf") -> str:
    path = str(tmp_path / name)
    ET.ElementTree(root).write(path)
    return path


def _drop_leg(root, side: str):
    for e in list(root):
        if e.get("name", "").startswith(side + "_"):
            root.remove(e)
    return root


def _joint(root, name: str):
    return next(j for j in root.iter("joint") if j.get("name") == name)


def _bad_files(tmp_path) -> dict[str, tuple[str, str]]:
    """{case: (path, what its one error line says)}."""
    out = {"missing leg": (_write(tmp_path, _drop_leg(_urdf_tree(), "lm"), "five.urdf"), "found 5 legs")}
    root = _urdf_tree()
    _joint(root, "rm_tibia_joint").set("type", "fixed")
    out["two-joint leg"] = (_write(tmp_path, root, "two.urdf"), "the leg from 'rm_coxa' has 2 revolute joints")
    root = _urdf_tree()
    j = _joint(root, "lf_femur_joint")
    j.set("type", "continuous")
    j.remove(j.find("limit"))
    out["continuous joint"] = (_write(tmp_path, root, "cont.urdf"), "joint 'lf_femur_joint' is continuous")
    root = _urdf_tree()
    extra = [copy.deepcopy(e) for e in root if e.get("name", "").startswith("rm_")]
    for e in extra:
        for tag in [e, *e.iter()]:
            for key in ("name", "link"):
                if tag.get(key, "").startswith("rm_"):
                    tag.set(key, "rx_" + tag.get(key)[3:])
        origin = e.find("origin")
        if e.tag == "joint" and e.get("name") == "rx_coxa_joint":
            origin.set("xyz", "-0.2 -0.113 0")
        root.append(e)
    out["seven legs"] = (_write(tmp_path, root, "seven.urdf"), "found 7 legs")
    text = open(MJCF).read().replace('<joint name="rr_tibia" axis="0 -1 0" range="-1.1344640138 1.308996939"',
                                     '<joint name="rr_tibia" axis="0 -1 0" limited="false"')
    (tmp_path / "nolimit.xml").write_text(text)
    out["no limit"] = (str(tmp_path / "nolimit.xml"), "joint 'rr_tibia' has no limits")
    out["bad path"] = (str(tmp_path / "nowhere.urdf"), "robot file not found")
    return out


def test_bad_files_say_what_is_missing_in_one_line(tmp_path):
    for case, (path, says) in _bad_files(tmp_path).items():
        with pytest.raises(HexnewtonError) as err:
            load_robot(path)
        assert says in str(err.value) and "\n" not in str(err.value), (case, str(err.value))


def test_named_joints_replace_the_tree(tmp_path):
    """--robot_joints: 18 names in hexnewton's order give the legs; a name the file lacks is one line."""
    names = [j.name for leg in load_robot(URDF).legs for j in leg.joints]
    assert [j.name for leg in load_robot(URDF, tuple(names)).legs for j in leg.joints] == names
    with pytest.raises(HexnewtonError, match="no joint named 'x_joint'"):
        load_robot(URDF, tuple(names[:17]) + ("x_joint",))
    swapped = names[3:6] + names[:3] + names[6:]
    assert [j.name for leg in load_robot(URDF, tuple(swapped)).legs for j in leg.joints] == swapped


def test_a_joints_ref_and_a_servos_gear_are_counted(tmp_path):
    """The same MX-Phoenix written with each femur's ``ref`` at 0.3 rad (its range and keyframe moved with it, the
    frames as they were) and servos of gear 2 at a quarter of the stiffness and damping, half the force: the same
    robot (angles from the ref; the joint's stiffness kp g², damping kv g², torque g x force)."""
    root = ET.parse(MJCF).getroot()
    femurs = [j for j in root.iter("joint") if j.get("name", "").endswith("_femur")]
    adr = {}
    for j in femurs:
        lo, hi = (float(v) for v in j.get("range").split())
        j.set("ref", "0.3")
        j.set("range", f"{lo + 0.3!r} {hi + 0.3!r}")
    names = [j.get("name") for j in root.iter("joint") if j.get("type") != "free" and j.get("name")]
    for k, name in enumerate(names):
        adr[name] = 7 + k
    key = root.find("keyframe/key")
    qpos = [float(v) for v in key.get("qpos").split()]
    for j in femurs:
        qpos[adr[j.get("name")]] += 0.3
    key.set("qpos", " ".join(repr(v) for v in qpos))
    for a in root.iter("position"):
        a.set("gear", "2")
        a.set("kp", repr(float(a.get("kp")) / 4))
        a.set("kv", repr(float(a.get("kv")) / 4))
        a.set("forcerange", " ".join(repr(float(v) / 2) for v in a.get("forcerange").split()))
    path = tmp_path / "mx_phoenix_ref_gear.xml"
    ET.ElementTree(root).write(path)
    got, want = load_robot(str(path)), load_robot(MJCF)
    assert np.allclose(got.stand_pose, want.stand_pose, atol=1e-9)
    assert np.allclose(joint_limits(got), joint_limits(want), atol=1e-9)
    for name in ("joint_ke", "joint_kd", "effort_limit"):
        assert getattr(got, name) == pytest.approx(getattr(want, name), rel=1e-9), name
    for lg, lw in zip(got.legs, want.legs):
        for jg, jw in zip(lg.joints, lw.joints):
            assert _same_frame(jg, jw) and jg.limit == pytest.approx(jw.limit, abs=1e-9)
