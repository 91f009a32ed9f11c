"""The bundle as a ROS 2 node (hexnewton.deploy.ros, hexnewton-ros): its logic without ROS (parameters, refusals, the
standing pose on stale data, the runtime's targets, a robot file's joint senses), then over real topics: the node and
the MuJoCo robot as two processes in lockstep, the faults and Ctrl-C. The ROS tests need rclpy (the ros extra); each
has its own ROS_DOMAIN_ID, discovery on this machine only."""

from __future__ import annotations

import itertools
import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from hexnewton.config import JOINT_NAMES
from hexnewton.deploy.control_loop import PARAMETERS, ControlLoop, check_parameters
from hexnewton.deploy.ros import parameter_names
from hexnewton.deploy.runtime import Controller, target_in_heading_frame

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BUNDLE = os.path.join(ROOT, "results", "controllers", "cpg_rl_complex")
MS = 1_000_000
_domains = itertools.count()


def _loop(**params):
    return _loop_for(BUNDLE, **params)


def _loop_for(bundle: str, **params):
    lines = []
    loop = ControlLoop(check_parameters({"bundle": bundle, **params}), log=lines.append)
    return loop, lines


def _readings(loop, t: int, pos=(0.0, 0.0, 0.15), q=(0.0, 0.0, 0.0, 1.0), joints=None, stamp=None):
    """The policy substep's readings of one instant (stamp ``stamp`` or ``t``), delivered at ``t``; then the IMU's
    substep: its targets."""
    stamp = t if stamp is None else stamp
    joints = np.tile([0.0, 0.15, -0.15], 6) if joints is None else joints
    assert loop.joint_state(JOINT_NAMES, joints, np.zeros(18), stamp, t) is None
    assert loop.odometry("odom", pos, q, stamp, t) is None
    assert loop.terrain(0.0, stamp, t) is None
    return loop.on_imu(q, (0.0, 0.0, 0.0), stamp, t)


def test_parameters_are_checked():
    p = check_parameters({"bundle": BUNDLE})
    assert p["sensor_timeout"] == PARAMETERS["sensor_timeout"][0] and p["trigger"] == "imu"
    assert check_parameters({"bundle": BUNDLE, "sensor_timeout": 1})["sensor_timeout"] == 1.0  # an int for a float
    for bad, words in [({"sensor_timeout": "fast"}, "expected float"), ({"trigger": "clock"}, "not one of"),
                       ({"executor": "multi_threaded"}, "not one of"),
                       ({"sensor_timeout": 0.0}, "positive"), ({"substep_period": 0.0025}, "bundle's policy"),
                       ({"no_such": 1}, "unknown parameter"), ({"sensor_depth": 2.5}, "expected int")]:  # fmt: skip
        with pytest.raises(ValueError, match=words):
            check_parameters({"bundle": BUNDLE, **bad})
    with pytest.raises(ValueError, match="no bundle"):
        check_parameters({})
    assert parameter_names(["-p", "a:=1", "--param", "node:b:=x", "-r", "c:=d"]) == ["a", "b"]


def test_malformed_messages_are_refused_with_one_log_line_each_and_counted():
    loop, lines = _loop()
    names = list(JOINT_NAMES)
    assert "17 joints" in loop.joint_state(names[:17], np.zeros(17), np.zeros(17), 0, 0)
    assert "unknown" in loop.joint_state(names[:17] + ["tail"], np.zeros(18), np.zeros(18), 1, 1)
    assert "not finite" in loop.joint_state(names, np.full(18, np.nan), np.zeros(18), 2, 2)
    assert "norm" in loop.imu((0, 0, 0, 2.0), (0, 0, 0), 3, 3)
    assert "not finite" in loop.imu((0, 0, 0, np.nan), (0, 0, 0), 3, 3)
    assert loop.odometry("odom", (0, 0, 0.15), (0, 0, 0, 1), 4, 4) is None
    assert "not the odometry's" in loop.set_goal("map", (1.0, 0.0, 0.0), 5)
    assert loop.set_goal("odom", (1.0, 0.0, 0.0), 6) is None and loop.goal_frame == "odom"
    assert loop.refused == {"joint_states": 3, "imu": 2, "odom": 0, "terrain": 0, "goal": 1}
    refusals = [line for line in lines if line.startswith("refused")]
    assert len(refusals) == 3 and all("\n" not in line for line in refusals)  # the first of each topic
    # a joint state in another order is taken, by name
    order = names[::-1]
    pos = np.arange(18.0)
    assert loop.joint_state(order, pos, -pos, 7, 7) is None
    np.testing.assert_array_equal(loop.latest["joint_states"].value[0], pos[::-1])


def test_the_loop_runs_the_runtime_and_waits_for_the_policys_readings():
    """Its targets are the runtime's on the same readings; a policy substep waits for readings of its IMU stamp."""
    loop, _ = _loop(sync_tolerance=0.0)
    ctrl = Controller(BUNDLE, num_robots=1)
    loop.set_goal("odom", (3.0, 0.5, 0.0), 0)
    rng = np.random.default_rng(0)
    for step in range(3):
        t = (step + 1) * 20 * MS
        joints = np.tile([0.0, 0.15, -0.15], 6) + rng.normal(0, 0.05, 18)
        pos = (0.1 * step, 0.0, 0.15)
        # the IMU message of the instant comes first: its policy substep waits for the joints and odometry
        q = (0.0, 0.0, np.sin(0.05), np.cos(0.05))
        assert loop.on_imu(q, (0, 0, 0), t, t) == []
        assert loop.joint_state(JOINT_NAMES, joints, np.zeros(18), t, t) is None and loop.on_reading(t) == []
        assert loop.terrain(0.01, t, t) is None and loop.on_reading(t) == []
        assert loop.odometry("odom", pos, q, t, t) is None
        (stamp, got), = loop.on_reading(t)
        assert stamp == t
        target = target_in_heading_frame(pos, q, (3.0, 0.5, 0.0), 0.0)
        ctrl.set_actions(ctrl.act(ctrl.observe(joints, np.zeros(18), q, target, 0.01)), target)
        np.testing.assert_array_equal(got, ctrl.substep(q)[0])
        for k in range(1, 4):  # the other substeps: one per IMU message, no wait
            (_, got), = loop.on_imu(q, (0, 0, 0), t + k * 5 * MS, t + k * 5 * MS)
            np.testing.assert_array_equal(got, ctrl.substep(q)[0])
    assert loop.walking and loop.counts["control_steps"] == 3 and loop.counts["substeps"] == 12


def _walk(loop, instants, lost=(), readings_first=True, every=4):
    """The robot's messages at ``instants`` substeps of 5 ms: the IMU at each (but those in ``lost``), the joints,
    odometry and terrain every ``every``-th (before or after the IMU message); the IMU stamps of the substeps that
    ran the policy, and of those whose readings were of their own instant."""
    policy, matched = [], []
    for k in range(instants):
        t = (k + 1) * 5 * MS
        feed = k % every == 0
        q = (0.0, 0.0, 0.0, 1.0)

        def send():
            assert loop.joint_state(JOINT_NAMES, np.tile([0.0, 0.15, -0.15], 6), np.zeros(18), t, t) is None
            assert loop.odometry("odom", (0.001 * k, 0.0, 0.15), q, t, t) is None
            assert loop.terrain(0.0, t, t) is None
            return loop.on_reading(t)

        before = loop.counts["control_steps"]
        out = send() if feed and readings_first else []
        if k not in lost:
            out += loop.on_imu(q, (0.0, 0.0, 0.0), t, t)
        if feed and not readings_first:
            out += send()
        if loop.counts["control_steps"] > before:
            policy.append(out[-1][0])
            matched.append(loop.latest["joint_states"].stamp == out[-1][0])
    return policy, matched


@pytest.mark.parametrize("readings_first", [True, False])
def test_lost_imu_messages_realign_the_policy_on_the_readings_instant(readings_first):
    """Readings once per control period mark its instant: after an IMU message lost while walking, the policy runs on
    the readings' instant again (one step re-aligned), not one substep late for the rest of the walk."""
    loop, _ = _loop()
    loop.set_goal("odom", (3.0, 0.0, 0.0), 0)
    policy, matched = _walk(loop, 200, lost=(41, 122), readings_first=readings_first)
    assert loop.walking and loop.counts["unmatched_control_steps"] == 0
    assert loop.counts["realigned_control_steps"] == 2
    # every policy step reads the readings of its own instant, but those re-aligned on readings that came after the
    # IMU message of their instant: they run one substep later, on them
    assert len(policy) == 50 and matched.count(False) == (0 if readings_first else 2)
    if readings_first:  # the policy runs at each instant the readings come
        assert policy == [(k + 1) * 5 * MS for k in range(0, 200, 4)]


def test_readings_every_substep_or_the_latest_never_realign():
    """Readings at every substep (any IMU message is a policy instant) and ``sync_tolerance`` negative (the latest,
    whatever its instant) keep the count from the start: a lost IMU message shifts it, as nothing marks the period."""
    for params, every in (({}, 1), ({"sync_tolerance": -1.0}, 4)):
        loop, _ = _loop(**params)
        loop.set_goal("odom", (3.0, 0.0, 0.0), 0)
        policy, _ = _walk(loop, 120, lost=(41,), every=every)
        assert loop.counts["realigned_control_steps"] == 0 and len(policy) == 30


def test_stale_data_holds_the_standing_pose_says_so_once_and_resumes():
    loop, lines = _loop()
    assert loop.on_watchdog(0) == [] or loop.on_watchdog(0)[0][1] is None  # nothing before the first joint state
    loop.set_goal("odom", (3.0, 0.0, 0.0), 0)
    (_, q0), = _readings(loop, 1 * MS)
    assert loop.walking and "walking" in lines[-1]
    walked_at = len(lines)
    # the joints stop: the IMU's substeps and the watchdog hold the standing pose, moving at stand_speed
    t, last = 1 * MS, q0
    for k in range(1, 80):
        t = 1 * MS + k * 5 * MS
        walked = loop.walking
        # (a policy substep waits for its readings until the next IMU message, which then serves it)
        for _, q in loop.on_imu((0, 0, 0, 1.0), (0, 0, 0), t, t):
            if not walked:  # the CPG's substeps until the joints are stale, then the standing pose's ramp
                assert np.abs(q - last).max() <= PARAMETERS["stand_speed"][0] * 0.005 + 1e-12
            last = q
    assert not loop.walking and "joint_states stale" in loop.reason
    assert sum("holding" in line for line in lines[walked_at:]) == 1 and loop.counts["holds"] == 1
    state, values = loop.status()
    assert state.startswith("holding: joint_states stale") and values["holds"] == "1"
    # everything stops: the watchdog keeps publishing the pose, which reaches the standing one
    held = [q for k in range(1, 200) for _, q in loop.on_watchdog(t + k * 20 * MS)]
    assert len(held) >= 190  # (not while the IMU is fresh: its own substeps hold the pose)
    np.testing.assert_allclose(held[-1], loop.stand)
    # data again: it walks with a fresh CPG, the runtime's first targets
    t += 200 * 20 * MS
    q1 = _readings(loop, t)[-1][1]  # (after the earlier pending substep, served now)
    assert loop.walking and "walking" in lines[-1]
    np.testing.assert_array_equal(q1, q0)  # the same readings as at the start: the same first targets
    assert loop.ctrl.session.get_session_options().intra_op_num_threads == 1  # still the one-thread session


def test_goal_reached_and_no_goal_hold_the_pose():
    loop, _ = _loop()
    _readings(loop, 1 * MS)
    assert loop.reason == "waiting for a goal" and not loop.walking
    loop.set_goal("odom", (0.2, 0.0, 0.0), 2 * MS)  # within goal_tolerance of the base
    _readings(loop, 3 * MS)
    assert loop.reason == "goal reached" and not loop.walking
    loop.set_goal("odom", (3.0, 0.0, 0.0), 4 * MS)
    _readings(loop, 5 * MS)
    assert loop.walking


#: the senses of the flipped MX-Phoenix file's joints (tests/deploy/conftest.py): R1 hip, R2 knee, R3 ankle and L3 hip
#: turned round, L1 knee back to hexnewton's sense, the file's other left knees and ankles as written (-1)
FLIPPED_SIGNS = [-1.0, 1, 1, 1, -1, 1, 1, 1, -1, 1, 1, -1, 1, -1, -1, -1, -1, -1]


def _file_robot(bundle: str, path: str):
    """A robot file's bundle as the node reads it: (controller.json, the file's joint names in hexnewton's order, their
    senses), the senses checked against the file's (the loader's ``JointConfig.sign``)."""
    from hexnewton.robot.loader import load_robot

    with open(os.path.join(bundle, "controller.json")) as f:
        spec = json.load(f)
    robot = load_robot(path)
    names = [j.name for leg in robot.legs for j in leg.joints]
    assert spec["obs_notes"]["joint order"] == names and spec["robot"] == robot.name
    assert spec["joint_signs"] == [j.sign for leg in robot.legs for j in leg.joints] == FLIPPED_SIGNS
    return spec, names, np.asarray(spec["joint_signs"])


def test_a_file_robots_joint_states_and_targets_turn_with_its_joint_senses(flipped_bundle, flipped_mjcf):
    """A robot file some of whose joints turn the other way (the MX-Phoenix's MJCF with 5 axes reversed): its bundle's
    controller.json has those joints' senses, and the node's loop turns the robot's joint states (the file's angles,
    by the file's names, in any order) into hexnewton's sense and its targets back into the file's: the targets are
    the runtime's on hexnewton's angles with the file's senses applied, while walking and while holding the pose."""
    spec, names, signs = _file_robot(flipped_bundle, flipped_mjcf)
    loop, _ = _loop_for(flipped_bundle, sync_tolerance=0.0)
    ctrl = Controller(flipped_bundle, num_robots=1)
    loop.set_goal("odom", (3.0, 0.0, 0.0), 0)
    rng = np.random.default_rng(3)
    hex_q = np.tile(spec["stand_pose"], 6) + rng.uniform(-0.1, 0.1, 18)  # hexnewton's angles
    hex_v = rng.uniform(-0.5, 0.5, 18)
    order = rng.permutation(18)
    robot_q, robot_v = signs * hex_q, signs * hex_v  # what the robot's encoders say
    assert robot_q[0] == -hex_q[0] and robot_q[1] == hex_q[1]  # R1's hip turns the other way, its knee not
    q, t = (0.0, 0.0, np.sin(0.05), np.cos(0.05)), 20 * MS
    assert loop.joint_state([names[i] for i in order], robot_q[order], robot_v[order], t, t) is None
    got_q, got_v = loop.latest["joint_states"].value
    np.testing.assert_array_equal(got_q, hex_q)
    np.testing.assert_array_equal(got_v, hex_v)
    assert loop.odometry("odom", (0.0, 0.0, 0.2), q, t, t) is None and loop.terrain(0.0, t, t) is None
    (_, out), = loop.on_imu(q, (0.0, 0.0, 0.0), t, t)
    target = target_in_heading_frame((0.0, 0.0, 0.2), q, (3.0, 0.0, 0.0), 0.0)
    ctrl.set_actions(ctrl.act(ctrl.observe(hex_q, hex_v, q, target, 0.0)), target)
    want = ctrl.substep(q)[0]  # hexnewton's targets
    np.testing.assert_array_equal(out, signs * want)
    turned = signs < 0
    assert np.abs(want[turned]).min() > 1e-3 and np.all(np.sign(out[turned]) == -np.sign(want[turned]))
    for k in range(1, 4):
        (_, out), = loop.on_imu(q, (0.0, 0.0, 0.0), t + k * 5 * MS, t + k * 5 * MS)
        np.testing.assert_array_equal(out, signs * ctrl.substep(q)[0])
    # the readings stop: the targets go to the standing pose, in the file's sense
    held = [q_out for k in range(1, 200) for _, q_out in loop.on_watchdog(t + 200 * MS + k * 20 * MS)]
    np.testing.assert_allclose(held[-1], signs * np.tile(spec["stand_pose"], 6))


def test_the_node_turns_a_file_robots_messages(flipped_bundle, flipped_mjcf, ros_env):
    """The same through the rclpy node: a ``sensor_msgs/JointState`` of the file's angles in, the
    ``Float64MultiArray`` of its targets out, in the file's senses."""
    import rclpy
    from geometry_msgs.msg import PointStamped, PoseStamped
    from nav_msgs.msg import Odometry
    from sensor_msgs.msg import Imu, JointState

    from hexnewton.deploy.ros import ControllerNode, ros_time

    spec, names, signs = _file_robot(flipped_bundle, flipped_mjcf)
    hex_q = np.tile(spec["stand_pose"], 6) + np.linspace(-0.1, 0.1, 18)
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(ros_env["ROS_DOMAIN_ID"]))
    try:
        node = ControllerNode(flipped_bundle, context=ctx, cli_args=["--ros-args", "-p", "sync_tolerance:=0.0"])
        goal = PoseStamped()
        goal.header.frame_id, goal.pose.position.x = "odom", 3.0
        node._goal(goal)
        stamp = ros_time(time.time_ns())
        js = JointState(name=names[::-1], position=(signs * hex_q)[::-1].tolist(), velocity=[0.0] * 18)
        od, tr, imu = Odometry(), PointStamped(), Imu()
        od.header.frame_id = tr.header.frame_id = "odom"
        od.pose.pose.position.z, od.pose.pose.orientation.w, imu.orientation.w = 0.2, 1.0, 1.0
        for m in (js, od, tr, imu):
            m.header.stamp = stamp
        node._joint_states(js)
        node._odom(od)
        node._terrain(tr)
        node._imu(imu)
        assert node.loop.walking and node.loop.counts["substeps"] == 1
        ctrl = Controller(flipped_bundle, num_robots=1)
        target = target_in_heading_frame((0.0, 0.0, 0.2), (0, 0, 0, 1.0), (3.0, 0.0, 0.0), 0.0)
        ctrl.set_actions(ctrl.act(ctrl.observe(hex_q, np.zeros(18), (0, 0, 0, 1.0), target, 0.0)), target)
        np.testing.assert_array_equal(node.cmd_msg.data, signs * ctrl.substep((0, 0, 0, 1.0))[0])
        node.node.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)


def test_the_node_module_loads_neither_warp_newton_nor_torch_and_asks_for_rclpy():
    """``hexnewton.deploy.ros`` and its loop (``control_loop``) run on NumPy and onnxruntime; without rclpy the
    command says in one line how to install it."""
    code = ("import json, sys\n"
            "import hexnewton.deploy.ros\nfrom hexnewton.deploy.control_loop import ControlLoop, check_parameters\n"
            f"ControlLoop(check_parameters({{'bundle': {BUNDLE!r}}}))\n"
            "print(json.dumps([m for m in ('warp', 'newton', 'torch', 'rclpy') if m in sys.modules]))\n")  # fmt: skip
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert proc.returncode == 0 and json.loads(proc.stdout.strip().splitlines()[-1]) == [], proc.stderr
    code = ("import sys\nsys.modules['rclpy'] = None\n"
            "from hexnewton.apps.cli import run\nfrom hexnewton.apps.ros import main\n"
            f"sys.exit(run(main, 'hexnewton-ros', ['node', {BUNDLE!r}]))\n")  # fmt: skip
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2 and len(lines) == 1 and "pip install -e '.[ros]'" in lines[0], proc.stderr


def test_bad_command_lines_are_one_error_line(capsys):
    from hexnewton.apps.cli import run
    from hexnewton.apps.ros import main

    for argv, words in [(["node", BUNDLE, "--ros-args", "-p", "no_such:=1"], "unknown parameter 'no_such'"),
                        (["robot", "no_bundle"], "not a controller bundle"),
                        (["robot", BUNDLE, "--rounds", "2", "--only", "5"], "--only"),
                        (["robot", BUNDLE, "--mjcf", "own"], "--mjcf own"),
                        (["robot", BUNDLE, "--robot", "mx_phoenix"], "trained on robot paper, not mx_phoenix"),
                        (["replay", "no_bag"], "not a rosbag2 folder")]:  # fmt: skip
        assert run(main, "hexnewton-ros", argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], (argv, err)


# --- over ROS 2 ------------------------------------------------------------------------------------------------------


@pytest.fixture
def ros_env():
    """An environment of its own: a ROS_DOMAIN_ID per test (per pytest worker and test), this machine only."""
    pytest.importorskip("rclpy")
    worker = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0")[2:] or 0)
    domain = 20 + (worker * 10 + next(_domains)) % 80
    return dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")


def _node(env, *params, stats=None, bundle=BUNDLE):
    cmd = [sys.executable, "-m", "hexnewton.apps.ros", "node", bundle] + (["--stats", stats] if stats else [])
    return subprocess.Popen(cmd + (["--ros-args", *params] if params else []), cwd=ROOT, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)  # fmt: skip


def _value(status, key: str) -> str:
    return next((kv.value for kv in status.values if kv.key == key), "")


def _stop(proc) -> tuple[str, str]:
    proc.send_signal(signal.SIGINT)  # Ctrl-C
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "Traceback" not in err, err[-3000:]
    assert "stopped after" in out
    return out, err


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_node_and_mujoco_robot_walk_in_lockstep_as_in_process(ros_env, tmp_path):
    """Two processes on loopback: the node and C MuJoCo as its robot, lockstep on flat ground, the run recorded as
    a rosbag2 file; the robot walks past 1 m, exactly as the in-process sim2sim's round does."""
    pytest.importorskip("rosbags")
    from hexnewton.analysis.ros_robot import LOCKSTEP_NODE_PARAMETERS, round_summary
    from hexnewton.analysis.sim2sim import run_part

    params = [w for k, v in LOCKSTEP_NODE_PARAMETERS.items() for w in ("-p", f"{k}:={v}")]
    node = _node(ros_env, *params, stats=str(tmp_path / "node.json"))
    try:
        out, bag = tmp_path / "robot.json", tmp_path / "bag"
        proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.ros", "robot", BUNDLE, "--terrain", "flat",
                               "--rounds", "3", "--only", "1", "--max_steps", "300", "--out", str(out), "--bag",
                               str(bag)], cwd=ROOT, env=ros_env, capture_output=True, text=True,
                              timeout=180)  # fmt: skip
        assert proc.returncode == 0, proc.stderr[-3000:]
    finally:
        _stop(node)
    res = json.loads(out.read_text())
    (row,) = res["rounds"]
    assert row["x"] >= 1.0 and row["status"] == "running" and row["steps"] == 300, row
    ref = round_summary(run_part(BUNDLE, "flat", 3, 1000, 300, robots=[1]))
    assert (row["x"], row["y"]) == (ref["x"], ref["y"])
    stats = json.loads((tmp_path / "node.json").read_text())
    assert stats["counts"]["substeps"] == 1200 and stats["received"]["imu"] == res["sent"]["imu"] == 1200
    from rosbags.rosbag2 import Reader

    with Reader(bag) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert reader.connections[0].digest is not None
    assert counts["imu"] == 1200 and counts["joint_states"] == 300 and counts["joint_trajectory"] >= 1200
    assert os.path.isfile(bag / "metadata.yaml") and list(bag.glob("*.mcap"))


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
@pytest.mark.parametrize("model", ["generated", "own"])
def test_a_file_robot_walks_over_ros_as_in_process(ros_env, flipped_bundle, flipped_mjcf, tmp_path, model):
    """The flipped robot file's bundle over ROS 2 in lockstep: C MuJoCo as the robot publishes the file's joint angles
    and applies the node's targets in the file's senses (``RosRounds``), the node turns them into hexnewton's and
    back; the round is the in-process sim2sim's, number for number, on the model written from the bundle and on the
    file itself (``--mjcf own``)."""
    from hexnewton.analysis.ros_robot import LOCKSTEP_NODE_PARAMETERS, round_summary
    from hexnewton.analysis.sim2sim import run_part

    params = [w for k, v in LOCKSTEP_NODE_PARAMETERS.items() for w in ("-p", f"{k}:={v}")]
    node = _node(ros_env, *params, bundle=flipped_bundle)
    try:
        out = tmp_path / "robot.json"
        proc = subprocess.run([sys.executable, "-m", "hexnewton.apps.ros", "robot", flipped_bundle, "--terrain", "flat",
                               "--rounds", "1", "--max_steps", "150", "--out", str(out), "--mjcf", model],
                              cwd=ROOT, env=ros_env, capture_output=True, text=True, timeout=180)  # fmt: skip
        assert proc.returncode == 0, proc.stderr[-3000:]
    finally:
        _stop(node)
    res = json.loads(out.read_text())
    (row,) = res["rounds"]
    assert res["model"] == (flipped_mjcf if model == "own" else "generated")
    ref = round_summary(run_part(flipped_bundle, "flat", 1, 1000, 150, mjcf=flipped_mjcf if model == "own" else None))
    assert row["steps"] == 150 and row["x"] > 0.2 and (row["x"], row["y"]) == (ref["x"], ref["y"]), (row, ref)


def test_node_on_the_events_executor_stops_on_ctrl_c(ros_env):
    """rclpy's EventsExecutor waits in C++: the node's spin returns to look for Ctrl-C, and the node stops cleanly."""
    node = _node(ros_env, "-p", "executor:=events")
    for line in node.stderr:  # spinning: its watchdog says why it holds
        if "holding the standing pose" in line:
            break
    out, _ = _stop(node)
    assert "stopped after 0 substeps" in out


def test_node_faults_over_ros(ros_env):
    """Stale data holds the standing pose (WARN in the diagnostics) and walking resumes; a malformed message is refused
    with one log line; a bad parameter is one error line; Ctrl-C stops the node cleanly."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from geometry_msgs.msg import PointStamped, PoseStamped
    from nav_msgs.msg import Odometry
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import Imu, JointState
    from std_msgs.msg import Float64MultiArray

    from hexnewton.deploy.ros import qos, ros_time

    bad = subprocess.run([sys.executable, "-m", "hexnewton.apps.ros", "node", BUNDLE, "--ros-args", "-p",
                          "trigger:=clock"], cwd=ROOT, env=ros_env, capture_output=True, text=True, timeout=60)
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1 and "trigger" in bad.stderr, bad.stderr
    node = _node(ros_env, "-p", "sensor_timeout:=0.1")
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=int(ros_env["ROS_DOMAIN_ID"]))
    try:
        me = rclpy.create_node("fault_test", context=ctx)
        ex = SingleThreadedExecutor(context=ctx)
        ex.add_node(me)
        pubs = {k: me.create_publisher(t, k, qos("reliable", 10)) for k, t in (
            ("joint_states", JointState), ("imu", Imu), ("odom", Odometry), ("terrain_height", PointStamped),
            ("goal_pose", PoseStamped))}  # fmt: skip
        seen, commands = [], []
        me.create_subscription(DiagnosticArray, "/diagnostics", lambda m: seen.append(m.status[0]), 10)
        me.create_subscription(Float64MultiArray, "forward_position_controller/commands",
                               lambda m: commands.append(np.asarray(m.data)), 10)  # fmt: skip

        def spin(seconds: float, publish: bool = True, names=JOINT_NAMES):
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                stamp = ros_time(time.time_ns())
                if publish:
                    js = JointState(name=list(names), position=[0.0, 0.15, -0.15] * 6, velocity=[0.0] * 18)
                    od, imu, tr = Odometry(), Imu(), PointStamped()
                    od.header.frame_id = tr.header.frame_id = "odom"
                    od.pose.pose.orientation.w = imu.orientation.w = 1.0
                    for m in (js, od, tr, imu):
                        m.header.stamp = stamp
                    for k, m in (("joint_states", js), ("odom", od), ("terrain_height", tr), ("imu", imu)):
                        pubs[k].publish(m)
                ex.spin_once(timeout_sec=0.005)

        def state() -> str:
            return seen[-1].message if seen else ""

        def until(cond, publish: bool = True, names=JOINT_NAMES, timeout: float = 20.0) -> None:
            end = time.monotonic() + timeout
            while not cond() and time.monotonic() < end:
                spin(0.02, publish, names)
            assert cond(), [s.message for s in seen[-5:]]

        until(lambda: pubs["goal_pose"].get_subscription_count() > 0, publish=False)
        goal = PoseStamped()
        goal.header.frame_id, goal.pose.position.x = "odom", 3.0
        pubs["goal_pose"].publish(goal)
        until(lambda: state() == "walking" and len(commands) > 10)
        until(lambda: "stale" in state(), publish=False)  # the readings stop
        assert state().startswith("holding: ") and seen[-1].level == b"\x01", state()
        goal.header.frame_id = "map"
        pubs["goal_pose"].publish(goal)  # a goal in another frame
        wrong = list(JOINT_NAMES[:17]) + ["tail"]
        until(lambda: "stale" in state() and _value(seen[-1], "refused_goal") == "1"
              and _value(seen[-1], "refused_joint_states") not in ("", "0"), names=wrong)  # refused, still stale
        until(lambda: state() == "walking")
        values = {kv.key: kv.value for kv in seen[-1].values}
        assert int(values["refused_joint_states"]) > 0 and values["refused_goal"] == "1" and values["holds"] == "1"
        me.destroy_node()
    finally:
        rclpy.try_shutdown(context=ctx)
        out, err = _stop(node)
    log = err + out
    # one line for the first refusal of a topic, then at most one per 5 s
    assert 1 <= log.count("refused a joint_states message") <= 2 and log.count("refused a goal message") == 1, log
    assert log.count("holding the standing pose: ") >= 2  # no data yet, then the stale readings: once each


def test_a_bag_replays_as_instants_in_their_recorded_order(tmp_path):
    """A recording's messages grouped by stamp: each instant once, at its first message's recorded time, its messages
    in their recorded order, whatever the recording's gaps between them."""
    pytest.importorskip("rclpy")
    pytest.importorskip("rosbags")
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import Imu, JointState

    from hexnewton.analysis.ros_robot import TOPICS, TYPES, Bag, bag_instants
    from hexnewton.deploy.ros import ros_time, stamp_ns

    bag = Bag(str(tmp_path / "bag"))
    t = 1_000 * MS
    for k in range(3):
        stamp = ros_time(t + k * 5 * MS)
        js, imu = JointState(name=list(JOINT_NAMES), position=[0.0] * 18, velocity=[0.0] * 18), Imu()
        js.header.stamp = imu.header.stamp = stamp
        if k == 1:  # the IMU alone
            bag.write(TOPICS["imu"], TYPES["imu"], serialize_message(imu), t + k * 5 * MS + 10_000)
            continue
        bag.write(TOPICS["joint_states"], TYPES["joint_states"], serialize_message(js), t + k * 5 * MS + 10_000)
        bag.write(TOPICS["imu"], TYPES["imu"], serialize_message(imu), t + k * 5 * MS + 3 * MS)  # 3 ms later
    bag.write(TOPICS["commands"], TYPES["commands"], b"\x00\x01\x00\x00", t + 20 * MS)  # not replayed
    bag.close()
    instants = bag_instants(str(tmp_path / "bag"))
    assert [when for when, _ in instants] == [t + k * 5 * MS + 10_000 for k in range(3)]
    assert [[key for key, _ in msgs] for _, msgs in instants] == [["joint_states", "imu"], ["imu"],
                                                                  ["joint_states", "imu"]]  # fmt: skip
    assert all(stamp_ns(m.header.stamp) == t + k * 5 * MS for k, (_, msgs) in enumerate(instants) for _, m in msgs)


def test_timer_trigger_runs_a_substep_per_tick_on_the_latest_readings():
    loop, _ = _loop(trigger="timer")
    loop.set_goal("odom", (3.0, 0.0, 0.0), 0)
    ctrl = Controller(BUNDLE, num_robots=1)
    q = (0.0, 0.0, 0.0, 1.0)
    joints = np.tile([0.0, 0.15, -0.15], 6)
    for t in (1 * MS, 2 * MS):  # the readings come at their own pace; only the timer runs substeps
        assert loop.joint_state(JOINT_NAMES, joints, np.zeros(18), t, t) is None
        assert loop.odometry("odom", (0.0, 0.0, 0.15), q, t, t) is None and loop.terrain(0.0, t, t) is None
        assert loop.imu(q, (0.0, 0.0, 0.0), t, t) is None
    assert loop.counts["substeps"] == 0
    target = target_in_heading_frame((0.0, 0.0, 0.15), q, (3.0, 0.0, 0.0), 0.0)
    ctrl.set_actions(ctrl.act(ctrl.observe(joints, np.zeros(18), q, target, 0.0)), target)
    for k in range(5):
        (stamp, got), = loop.on_timer(3 * MS + k * 5 * MS)
        assert stamp == 2 * MS
        np.testing.assert_array_equal(got, ctrl.substep(q)[0])
        if k == 3:
            ctrl.set_actions(ctrl.act(ctrl.observe(joints, np.zeros(18), q, target, 0.0)), target)
    assert loop.counts["control_steps"] == 2
