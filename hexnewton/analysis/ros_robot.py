"""C MuJoCo as the robot of the ROS 2 controller node (:mod:`hexnewton.deploy.ros`), over the node's topics.

:class:`RosRounds` is sim2sim's :class:`hexnewton.analysis.sim2sim.Rounds` (one round: one robot, one model) whose
joint targets come from the node: at every MuJoCo step it publishes the readings the in-process loop hands the
runtime (``sensor_msgs/Imu``: attitude and gyro, every substep; on the policy's substeps also
``sensor_msgs/JointState``, ``nav_msgs/Odometry`` and the terrain reading as ``geometry_msgs/PointStamped``; all of
one instant with one stamp) and applies the targets it gets back:

- **lockstep**: each step waits for the node's ``trajectory_msgs/JointTrajectory`` stamped with its readings' stamp,
  so the run is the in-process sim2sim's, number for number;
- **real time**: paced by the wall clock at the bundle's substep; each step applies the newest
  ``std_msgs/Float64MultiArray`` command that arrived within ``deadline`` (a fraction) of the period (a period
  without one keeps the previous command and counts as missed), as a robot's servo loop does.

Before each round it sends the goal (``geometry_msgs/PoseStamped`` in ``odom``, z the ground at the goal) and waits
for the node's diagnostics to show it holding with that goal. :class:`Bag` records a run as a rosbag2 file (MCAP
storage, metadata version 9); :func:`replay` plays one back to a node at its recorded pace, each instant's messages
together, restamped."""

from __future__ import annotations

import time

import numpy as np

from hexnewton.analysis.sim2sim import Rounds
from hexnewton.config import JOINT_NAMES
from hexnewton.deploy.control_loop import percentiles_ms
from hexnewton.deploy.ros import import_rclpy, qos, ros_time, stamp_ns
from hexnewton.errors import HexnewtonError
from hexnewton.mdp.status import STATUS_NAMES

#: the node's default topics, and the trajectory topic the lockstep robot reads (the node's trajectory_topic)
TOPICS = {"joint_states": "joint_states", "imu": "imu", "odom": "odom", "terrain": "terrain_height",
          "goal": "goal_pose", "commands": "forward_position_controller/commands",
          "trajectory": "joint_trajectory", "diagnostics": "/diagnostics"}  # fmt: skip
#: the node's parameters a lockstep robot needs (``--ros-args -p NAME:=VALUE``): the targets stamped, no sensor
#: message lost, the readings of the IMU message's own stamp, and a wall-clock pause of the simulation no fault
LOCKSTEP_NODE_PARAMETERS = {"trajectory_topic": TOPICS["trajectory"], "sensor_reliability": "reliable",
                            "sync_tolerance": 0.0, "sensor_timeout": 1.0}  # fmt: skip
TYPES = {"joint_states": "sensor_msgs/msg/JointState", "imu": "sensor_msgs/msg/Imu", "odom": "nav_msgs/msg/Odometry",
         "terrain": "geometry_msgs/msg/PointStamped", "goal": "geometry_msgs/msg/PoseStamped",
         "commands": "std_msgs/msg/Float64MultiArray", "trajectory": "trajectory_msgs/msg/JointTrajectory",
         "diagnostics": "diagnostic_msgs/msg/DiagnosticArray"}  # fmt: skip
#: what the robot sends (and a replay plays back)
SENT = ("joint_states", "imu", "odom", "terrain", "goal")


def _message_class(type_name: str):
    import importlib

    package, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{package}.msg"), name)


class Bag:
    """A rosbag2 recording (MCAP storage, metadata version 9, CDR messages) written with ``rosbags``: the folder
    ``path`` with ``metadata.yaml`` and one ``.mcap`` file."""

    def __init__(self, path: str):
        try:
            from rosbags.rosbag2 import StoragePlugin, Writer
            from rosbags.typesys import Stores, get_typestore
        except ImportError:
            raise ValueError("recording a bag needs rosbags: pip install -e '.[ros]'") from None
        self.writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
        self.writer.open()
        self.store, self.connections, self.messages = get_typestore(Stores.ROS2_KILTED), {}, 0

    def write(self, topic: str, type_name: str, data: bytes, t_ns: int) -> None:
        if topic not in self.connections:
            self.connections[topic] = self.writer.add_connection(topic, type_name, typestore=self.store)
        self.writer.write(self.connections[topic], t_ns, bytes(data))
        self.messages += 1

    def close(self) -> None:
        self.writer.close()


class RobotLink:
    """The robot's rclpy node: publishers of the readings and the goal, subscriptions to the node's targets and
    diagnostics, and the waits of the two modes. ``bag``: a :class:`Bag` that records everything sent and received."""

    def __init__(self, bundle_joints, bag: Bag | None = None, name: str = "hexnewton_mujoco_robot",
                 answer_timeout: float = 10.0):
        self.rclpy = rclpy = import_rclpy()
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.serialization import serialize_message

        self.serialize, self.bag, self.timeout = serialize_message, bag, answer_timeout
        self.node = rclpy.create_node(name)
        self.executor = SingleThreadedExecutor()
        self.executor.add_node(self.node)
        reliable = qos("reliable", 10)
        self.pub = {k: self.node.create_publisher(_message_class(TYPES[k]), TOPICS[k], reliable) for k in SENT}
        for k, cb in (("commands", self._command), ("trajectory", self._trajectory), ("diagnostics", self._diag)):
            self.node.create_subscription(_message_class(TYPES[k]), TOPICS[k], cb, qos("reliable", 50))
        self.joints = list(bundle_joints)
        self.msg = {k: _message_class(TYPES[k])() for k in SENT}
        self.msg["joint_states"].name = self.joints
        self.msg["odom"].header.frame_id, self.msg["odom"].child_frame_id = "odom", "base_link"
        self.msg["terrain"].header.frame_id = "odom"
        self.msg["imu"].header.frame_id = "base_link"
        self.msg["imu"].linear_acceleration_covariance[0] = -1.0  # no accelerometer
        self.command, self.commands, self.answer, self.waiting = None, 0, None, None
        self.status: dict[str, str] = {}
        self.sent = dict.fromkeys(SENT, 0)
        self.round_trips: list[float] = []  # readings' stamp to the answer's arrival [ms]

    def send(self, key: str, msg, stamp: int | None = None) -> None:
        if stamp is not None:
            msg.header.stamp = ros_time(stamp)
        data = self.serialize(msg)
        self.pub[key].publish(data)
        self.sent[key] += 1
        if self.bag is not None:
            self.bag.write(TOPICS[key], TYPES[key], data, time.time_ns())

    def _record(self, key: str, msg) -> None:
        if self.bag is not None:
            self.bag.write(TOPICS[key], TYPES[key], self.serialize(msg), time.time_ns())

    def _command(self, msg) -> None:
        self.command, self.commands = np.asarray(msg.data, np.float64), self.commands + 1
        self._record("commands", msg)

    def _trajectory(self, msg) -> None:
        self._record("trajectory", msg)
        if self.waiting is not None and stamp_ns(msg.header.stamp) == self.waiting and msg.points:
            self.answer = np.asarray(msg.points[0].positions, np.float64)

    def _diag(self, msg) -> None:
        self._record("diagnostics", msg)
        for st in msg.status:
            if st.name.endswith(": controller"):
                self.status = {kv.key: kv.value for kv in st.values}

    def readings(self, stamp: int, joint_pos, joint_vel, qpos, quat, height: float) -> None:
        """The policy substep's readings: joints, odometry (the free joint's position, the IMU's attitude), terrain."""
        js, od, tr = self.msg["joint_states"], self.msg["odom"], self.msg["terrain"]
        js.position, js.velocity = [float(v) for v in joint_pos], [float(v) for v in joint_vel]
        p, o = od.pose.pose.position, od.pose.pose.orientation
        p.x, p.y, p.z = (float(v) for v in qpos[:3])
        o.x, o.y, o.z, o.w = (float(v) for v in quat)
        tr.point.x, tr.point.y, tr.point.z = float(qpos[0]), float(qpos[1]), float(height)
        for key in ("joint_states", "odom", "terrain"):
            self.send(key, self.msg[key], stamp)

    def imu(self, stamp: int, quat, gyro) -> None:
        m = self.msg["imu"]
        o, w = m.orientation, m.angular_velocity
        o.x, o.y, o.z, o.w = (float(v) for v in quat)
        w.x, w.y, w.z = (float(v) for v in gyro)
        self.send("imu", m, stamp)

    def lockstep_answer(self, stamp: int) -> np.ndarray:
        """The node's targets for the readings stamped ``stamp`` (its trajectory message of that stamp)."""
        self.waiting, self.answer = stamp, None
        end = time.monotonic() + self.timeout
        while self.answer is None:
            if time.monotonic() > end:
                raise HexnewtonError(f"no joint targets from the node for {self.timeout:g} s (is it running with "
                                   + ", ".join(f"{k}:={v}" for k, v in LOCKSTEP_NODE_PARAMETERS.items()) + "?)")
            self.executor.spin_once(timeout_sec=0.05)
        self.round_trips.append((time.time_ns() - stamp) * 1e-6)
        self.waiting = None
        return self.answer

    def realtime_answer(self, stamp: int, deadline: float) -> bool:
        """Wait until a new command arrives or the wall clock reaches ``deadline`` (perf_counter seconds); whether
        one came."""
        before = self.commands
        while self.commands == before:
            left = deadline - time.perf_counter()
            if left <= 0:
                return False
            self.executor.spin_once(timeout_sec=left)
        self.round_trips.append((time.time_ns() - stamp) * 1e-6)
        return True

    def spin_until(self, t: float) -> None:
        """Process messages until the wall clock reaches ``t`` (perf_counter seconds)."""
        while (left := t - time.perf_counter()) > 0:
            self.executor.spin_once(timeout_sec=left)

    def handshake(self, goal, timeout: float = 60.0) -> None:
        """Send the goal (x, y, ground z in ``odom``) until the node's diagnostics show it holding with it."""
        g = self.msg["goal"]
        g.header.frame_id = "odom"
        g.pose.position.x, g.pose.position.y, g.pose.position.z = (float(v) for v in goal)
        g.pose.orientation.w = 1.0
        end, last = time.monotonic() + timeout, -1.0
        while True:
            s = self.status
            if s.get("state") == "holding" and all(s.get(f"goal_{k}") == repr(float(v)) for k, v in zip("xyz", goal)):
                return
            if time.monotonic() > end:
                raise HexnewtonError(f"the controller node did not take the goal within {timeout:g} s (is it running, "
                                   "with the same ROS_DOMAIN_ID?)")  # fmt: skip
            if time.monotonic() - last > 0.25 and self.pub["goal"].get_subscription_count() > 0:
                self.send("goal", g, time.time_ns())
                last = time.monotonic()
            self.executor.spin_once(timeout_sec=0.02)

    def close(self) -> None:
        self.node.destroy_node()


class RosRounds(Rounds):
    """One round of sim2sim's protocol (round ``k`` of ``rounds``, its own model) with the joint targets from the
    ROS 2 node through ``link`` (:class:`RobotLink`), in lockstep or in real time (``deadline``: the fraction of the
    substep a command may take)."""

    def __init__(self, link: RobotLink, controller: str, terrain: str, rounds: int, k: int, seed: int,
                 realtime: bool = False, deadline: float = 0.85, mjcf: str | None = None):
        super().__init__(controller, terrain, rounds, seed, robots=[k], mjcf=mjcf)
        self.link, self.realtime, self.deadline = link, realtime, deadline
        self.dt = float(self.spec["substep_dt"])
        self.ticks, self.t0, self.missed, self.late_starts = 0, None, 0, 0
        self.last = np.asarray(self.spec["stand_pose"] * 6, np.float64)
        # the robot's joint senses: the model's joints turn as hexnewton's, the node speaks the robot's
        self.signs = np.asarray(self.spec.get("joint_signs", [1.0] * 18), np.float64)

    def targets(self, k: int, r: dict) -> np.ndarray:
        link, d = self.link, self.d
        if self.realtime:
            if self.t0 is None:
                self.t0 = time.perf_counter()
            start = self.t0 + self.ticks * self.dt
            self.late_starts += time.perf_counter() > start + self.dt
            link.spin_until(start)
        stamp = time.time_ns()
        if k == 0:
            link.readings(stamp, self.signs * r["joint_pos"][0], self.signs * r["joint_vel"][0], d.qpos[:3],
                          r["quat"][0], self.scan.reading(d.qpos[0], d.qpos[1]))  # fmt: skip
        link.imu(stamp, r["quat"][0], r["gyro"][0])
        self.ticks += 1
        if not self.realtime:
            self.last = self.signs * link.lockstep_answer(stamp)
        elif link.realtime_answer(stamp, start + self.deadline * self.dt):
            self.last = self.signs * link.command
        else:
            self.missed += 1
        return self.last[None]

    def goal3(self) -> tuple[float, float, float]:
        return float(self.goal[0, 0]), float(self.goal[0, 1]), float(self.goal_z[0])


def round_summary(ep: dict) -> dict:
    """How a round ended: :meth:`Rounds.run`'s arrays of one robot as status name, control steps, final x, y (from
    the start) and the farthest x."""
    st = ep["status"][:, 0]
    end = int(np.flatnonzero(st)[0]) if st.any() else len(st) - 1
    x, y = ep["pos"][end, 0]
    return {"status": STATUS_NAMES[int(st[end])], "steps": end + 1, "x": float(x), "y": float(y),
            "x_far": float(np.nanmax(ep["pos"][:, 0, 0]))}  # fmt: skip


def run_rounds(bundle: str, terrain: str, rounds: int, seed: int, max_steps: int | None, realtime: bool,
               bag_path: str | None = None, only=None, on_round=None, mjcf: str | None = None) -> dict:
    """Rounds ``only`` (default all) of ``rounds``, one after another, each with the node's targets (on ``mjcf``,
    a robot's own MJCF file, as sim2sim's ``Rounds``; None: the model written from the bundle); per round
    :func:`round_summary` and the robot's counts (messages sent, commands, missed periods, round trips)."""
    from hexnewton.deploy.runtime import load_spec

    spec = load_spec(bundle)
    bag = Bag(bag_path) if bag_path else None
    rclpy = import_rclpy()
    rclpy.init()
    link = None
    try:
        link = RobotLink(spec.get("obs_notes", {}).get("joint order") or JOINT_NAMES, bag)
        out = []
        for k in range(rounds) if only is None else only:
            r = RosRounds(link, bundle, terrain, rounds, k, seed, realtime, mjcf=mjcf)
            link.handshake(r.goal3())
            t = time.perf_counter()
            row = dict(round=k, **round_summary(r.run(max_steps)), wall_s=round(time.perf_counter() - t, 2),
                       substeps=r.ticks, missed_periods=r.missed, late_starts=r.late_starts)  # fmt: skip
            out.append(row)
            if on_round is not None:
                on_round(row)
        return {"rounds": out, "sent": dict(link.sent), "commands_received": link.commands,
                "round_trip_ms": percentiles_ms(link.round_trips), "bag_messages": bag.messages if bag else 0}
    finally:
        if link is not None:
            link.close()
        if bag is not None:
            bag.close()
        rclpy.try_shutdown()


def bag_instants(bag_path: str) -> list[tuple[int, list]]:
    """A recorded run's readings and goals (:data:`SENT`) as instants: ``[(recorded time [ns], [(key, message),
    ...])]``, an instant the messages of one recorded stamp in their recorded order, at its first message's recorded
    time, deserialized."""
    from rosbags.rosbag2 import Reader

    import_rclpy()
    from rclpy.serialization import deserialize_message

    keys, classes = {TOPICS[k]: k for k in SENT}, {k: _message_class(TYPES[k]) for k in SENT}
    instants, index = [], {}
    with Reader(bag_path) as reader:
        conns = [c for c in reader.connections if c.topic in keys]
        for conn, t, data in reader.messages(connections=conns):
            key = keys[conn.topic]
            msg = deserialize_message(data, classes[key])
            stamp = stamp_ns(msg.header.stamp)
            if stamp not in index:
                index[stamp] = len(instants)
                instants.append((t, []))
            instants[index[stamp]][1].append((key, msg))
    return instants


def replay(bag_path: str, speed: float = 1.0, wait: float = 30.0) -> dict:
    """Publish a recorded run's readings and goals (:data:`SENT`) to a node as a robot's driver publishes them: each
    instant's messages (:func:`bag_instants`: those of one recorded stamp) together, in their recorded order, at the
    instant's recorded time (``speed`` times faster), restamped with one stamp, the time its first message is
    published. The recording robot's own waits between an instant's messages are not replayed: the node would count
    them as its latency. The messages are deserialized before the first is published, and the garbage collector
    waits while they are published. Returns the counts per topic."""
    import gc

    instants = bag_instants(bag_path)
    rclpy = import_rclpy()
    rclpy.init()
    node = rclpy.create_node("hexnewton_bag_replay")
    collecting = gc.isenabled()
    try:
        pubs = {k: node.create_publisher(_message_class(TYPES[k]), TOPICS[k], qos("reliable", 10)) for k in SENT}
        end = time.monotonic() + wait
        while pubs["imu"].get_subscription_count() == 0:  # the node is there
            if time.monotonic() > end:
                raise HexnewtonError(f"no node subscribed to {TOPICS['imu']} within {wait:g} s")
            time.sleep(0.05)
        time.sleep(0.5)
        counts = dict.fromkeys(SENT, 0)
        gc.collect()
        gc.freeze()  # the messages, out of the collector's way
        gc.disable()
        t0, w0 = instants[0][0] if instants else 0, time.perf_counter()
        for t, messages in instants:
            left = w0 + (t - t0) * 1e-9 / speed - time.perf_counter()
            if left > 0:
                time.sleep(left)
            stamp = ros_time(time.time_ns())
            for _, msg in messages:
                msg.header.stamp = stamp
            for key, msg in messages:
                pubs[key].publish(msg)
                counts[key] += 1
        return counts
    finally:
        if collecting:
            gc.enable()
        gc.unfreeze()
        node.destroy_node()
        rclpy.try_shutdown()
