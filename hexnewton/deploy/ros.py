"""The controller bundle as a ROS 2 node (``hexnewton-ros node BUNDLE``; the command line: ``hexnewton.apps.ros``).

The node runs :class:`hexnewton.deploy.runtime.Controller` on a robot's own messages:

- in: ``sensor_msgs/JointState`` (the bundle's 18 joints by name, any order; position and velocity),
  ``sensor_msgs/Imu`` (orientation x y z w; one CPG substep per message: the levelling reflex reads it every
  substep), ``nav_msgs/Odometry`` (the base's pose in the odometry frame, for the goal in the heading frame),
  ``geometry_msgs/PointStamped`` (the terrain reading the bundle observes as ``point.z``: the highest terrain within
  +-30 cm of the base minus the ground under it [m]; x and y: where it was taken) and ``geometry_msgs/PoseStamped``
  (the goal in the odometry frame; its z: the ground height at the goal). A new goal replaces the current one.
- out: the 18 joint position targets as ``std_msgs/Float64MultiArray`` (ros2_control's forward position controller,
  reliable), optionally as a one-point ``trajectory_msgs/JointTrajectory`` stamped with the IMU message it answers,
  and its state as ``diagnostic_msgs/DiagnosticArray`` (on every change and periodically).

The substeps, policy steps, faults and counts are :class:`hexnewton.deploy.control_loop.ControlLoop`'s (the logic
without ROS, its rules in that module); rclpy is imported only by :class:`ControllerNode`.
"""

from __future__ import annotations

import gc
import json
import os
import signal
import time

from hexnewton.deploy.control_loop import PARAMETERS, ControlLoop, check_parameters, percentiles_ms

INSTALL = "pip install -e '.[ros]' (or source a ROS 2 installation)"


def stamp_ns(stamp) -> int:
    """A ``builtin_interfaces/Time`` in nanoseconds."""
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


# --- the ROS 2 side ----------------------------------------------------------------------------------------------


def import_rclpy():
    """rclpy, or ValueError in one line saying how to install it."""
    try:
        import rclpy
    except Exception as exc:  # noqa: BLE001 - no rclpy, or one without a middleware (RMW)
        raise ValueError(f"ROS 2's rclpy cannot be imported ({type(exc).__name__}: {exc}); {INSTALL}") from None
    return rclpy


def qos(reliability: str, depth: int, durability: str = "volatile"):
    """A keep-last QoS profile."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=int(depth),
                      reliability=getattr(ReliabilityPolicy, reliability.upper()),
                      durability=getattr(DurabilityPolicy, durability.upper()))  # fmt: skip


def ros_time(ns: int):
    """Nanoseconds as a ``builtin_interfaces/Time``."""
    from builtin_interfaces.msg import Time

    return Time(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def parameter_names(ros_args: list[str]) -> list[str]:
    """The parameter names that ``-p NAME:=VALUE`` of ROS arguments sets (its long spelling and ``node:NAME`` too)."""
    names = []
    for flag, value in zip(ros_args, ros_args[1:]):
        if flag in ("-p", "--param") and ":=" in value:
            names.append(value.split(":=", 1)[0].rsplit(":", 1)[-1])
    return names


class ControllerNode:
    """:class:`ControlLoop` as the rclpy node ``name``: its parameters declared (``PARAMETERS``, the ``bundle``
    parameter defaulting to ``bundle``), subscriptions, publishers and timers. ``self.node`` is the rclpy node."""

    def __init__(self, bundle: str = "", name: str = "hexnewton_controller", context=None, cli_args=None):
        import_rclpy()
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import PointStamped, PoseStamped
        from nav_msgs.msg import Odometry
        from rcl_interfaces.msg import ParameterDescriptor
        from rclpy.node import Node
        from sensor_msgs.msg import Imu, JointState
        from std_msgs.msg import Float64MultiArray
        from trajectory_msgs.msg import JointTrajectory

        self.node = node = Node(name, context=context, cli_args=cli_args)
        try:
            for key, (default, text) in PARAMETERS.items():
                node.declare_parameter(key, bundle if key == "bundle" else default,
                                       ParameterDescriptor(description=text, dynamic_typing=True))  # fmt: skip
            self.p = p = check_parameters({k: node.get_parameter(k).value for k in PARAMETERS})
            self.log = node.get_logger()
            self.loop = ControlLoop(p, log=self.log.info)
        except BaseException:
            node.destroy_node()
            raise
        sensors = qos(p["sensor_reliability"], p["sensor_depth"])
        sub = node.create_subscription
        sub(JointState, p["joint_states_topic"], self._joint_states, sensors)
        sub(Imu, p["imu_topic"], self._imu, sensors)
        sub(Odometry, p["odom_topic"], self._odom, sensors)
        if p["terrain_topic"]:
            sub(PointStamped, p["terrain_topic"], self._terrain, sensors)
        sub(PoseStamped, p["goal_topic"], self._goal, qos("reliable", 10, p["goal_durability"]))
        self.cmd = node.create_publisher(Float64MultiArray, p["commands_topic"], qos(p["command_reliability"], 10))
        self.cmd_msg = Float64MultiArray()
        self.traj = None
        if p["trajectory_topic"]:
            self.traj = node.create_publisher(JointTrajectory, p["trajectory_topic"], qos(p["command_reliability"], 10))
            self.traj_msg = self._trajectory_message()
        self.diag = node.create_publisher(DiagnosticArray, p["diagnostics_topic"], qos("reliable", 10))
        self.loop.log(f"{p['bundle']}: {len(self.loop.joints)} joints, substep {self.loop.dt * 1e3:g} ms, policy "
                      f"every {self.loop.substeps} substeps, trigger {p['trigger']}")  # fmt: skip
        node.create_timer(p["watchdog_period"], lambda: self._publish(self.loop.on_watchdog(time.time_ns())))
        node.create_timer(p["diagnostics_period"], self.publish_diagnostics)
        if p["trigger"] == "timer":
            node.create_timer(self.loop.dt, lambda: self._publish(self.loop.on_timer(time.time_ns())))
        self.publish_diagnostics()

    def _trajectory_message(self):
        from builtin_interfaces.msg import Duration
        from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

        msg = JointTrajectory(joint_names=list(self.loop.joints))
        msg.points = [JointTrajectoryPoint(time_from_start=Duration(nanosec=int(round(self.loop.dt * 1e9))))]
        return msg

    # --- callbacks ---------------------------------------------------------------------------------------------
    def _joint_states(self, msg) -> None:
        now = time.time_ns()
        if self.loop.joint_state(msg.name, msg.position, msg.velocity, stamp_ns(msg.header.stamp), now) is None:
            self._publish(self.loop.on_reading(now))

    def _imu(self, msg) -> None:
        o, w = msg.orientation, msg.angular_velocity
        args = ((o.x, o.y, o.z, o.w), (w.x, w.y, w.z), stamp_ns(msg.header.stamp), time.time_ns())
        if self.p["trigger"] == "imu":
            self._publish(self.loop.on_imu(*args))
        else:  # the timer runs the substeps
            self.loop.imu(*args)

    def _odom(self, msg) -> None:
        now, pose = time.time_ns(), msg.pose.pose
        p, o = pose.position, pose.orientation
        if self.loop.odometry(msg.header.frame_id, (p.x, p.y, p.z), (o.x, o.y, o.z, o.w), stamp_ns(msg.header.stamp),
                              now) is None:  # fmt: skip
            self._publish(self.loop.on_reading(now))

    def _terrain(self, msg) -> None:
        now = time.time_ns()
        if self.loop.terrain(msg.point.z, stamp_ns(msg.header.stamp), now) is None:
            self._publish(self.loop.on_reading(now))

    def _goal(self, msg) -> None:
        p = msg.pose.position
        self.loop.set_goal(msg.header.frame_id, (p.x, p.y, p.z), time.time_ns())
        self.publish_diagnostics()

    # --- out -----------------------------------------------------------------------------------------------------
    def _publish(self, items: list) -> None:
        for stamp, q in items:
            if q is None:
                continue
            self.cmd_msg.data = q.tolist()
            self.cmd.publish(self.cmd_msg)
            if self.traj is not None:
                self.traj_msg.header.stamp = ros_time(stamp if stamp is not None else time.time_ns())
                self.traj_msg.points[0].positions = self.cmd_msg.data
                self.traj.publish(self.traj_msg)
            self.loop.published(stamp, time.time_ns())
        if self.loop.changed:
            self.publish_diagnostics()

    def publish_diagnostics(self) -> None:
        """The node's state as one ``DiagnosticStatus``: OK walking or holding for a goal, WARN holding for data."""
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

        state, values = self.loop.status()
        data_fault = not self.loop.walking and self.loop.reason not in ("waiting for a goal", "goal reached")
        st = DiagnosticStatus(level=DiagnosticStatus.WARN if data_fault else DiagnosticStatus.OK,
                              name=f"{self.node.get_name()}: controller", message=state,
                              hardware_id=self.p["bundle"],
                              values=[KeyValue(key=k, value=v) for k, v in values.items()])  # fmt: skip
        self.diag.publish(DiagnosticArray(header=self._header(), status=[st]))
        self.loop.changed = False

    def _header(self):
        from std_msgs.msg import Header

        return Header(stamp=ros_time(time.time_ns()))


def realtime_priority(priority: int) -> None:
    """This process, and the threads it starts from now on, under the real-time FIFO scheduler at ``priority``
    (1..99; 0: leave it), as a robot runs its control loop; ValueError where the system does not allow it."""
    if not 0 <= priority <= 99:
        raise ValueError(f"--priority must be 0 (the normal scheduler) or 1..99, got {priority}")
    if priority:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
        except (OSError, AttributeError) as exc:
            raise ValueError(f"real-time priority {priority}: {exc} (needs CAP_SYS_NICE or an rtprio limit)") from None


#: how often the EventsExecutor's spin returns to look for a stop request [s]
STOP_POLL_S = 0.05


def run_node(bundle: str, ros_args: list[str], stats: str | None = None, priority: int = 0) -> int:
    """``hexnewton-ros node``: the node spun until Ctrl-C (SIGINT or SIGTERM), then its counters (and every latency,
    in ``stats``, a JSON file) and a clean exit. ``priority`` > 0: the process (and the middleware's threads it
    starts) under the real-time FIFO scheduler at that priority, as a robot runs its control loop."""
    unknown = sorted(set(parameter_names(ros_args)) - set(PARAMETERS) - {"use_sim_time"})
    if unknown:
        raise ValueError(f"unknown parameter {unknown[0]!r} (the node's: {', '.join(PARAMETERS)})")
    realtime_priority(priority)
    rclpy = import_rclpy()
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
    from rclpy.signals import SignalHandlerOptions

    try:  # the node's own SIGINT / SIGTERM handling (below), not rclpy's
        rclpy.init(args=["hexnewton_ros", "--ros-args", *ros_args] if ros_args else None,
                   signal_handler_options=SignalHandlerOptions.NO)
    except Exception as exc:  # noqa: BLE001 - rcl's parse error
        raise ValueError(f"bad ROS arguments {' '.join(ros_args)!r}: {str(exc).splitlines()[0]}") from None
    node = None
    try:
        node = ControllerNode(bundle, cli_args=None)
        if node.loop.p["executor"] == "events":
            from rclpy.experimental import EventsExecutor

            spinner = EventsExecutor()
        else:
            spinner = SingleThreadedExecutor()
        spinner.add_node(node.node)
        gc.collect()  # what is built so far, then out of the collector's scans: a full collection of the modules,
        gc.freeze()  # onnxruntime's session and the node stops the node for 15-30 ms on a 2-core CPU
        # Ctrl-C (SIGINT) or SIGTERM asks the loop to stop between callbacks: a KeyboardInterrupt raised inside one
        # (rclpy's handling) can leave the executor's objects half built, and their finalizers print tracebacks
        stop: list[int] = []
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, lambda signum, frame: stop.append(signum))
        try:
            # SingleThreadedExecutor: no timeout (it would build a timer for every wait), the watchdog's timer wakes
            # its wait while no message comes; EventsExecutor waits in C++ past Python's signal handler, so a timeout
            timeout = STOP_POLL_S if node.loop.p["executor"] == "events" else None
            while not stop and rclpy.ok():
                spinner.spin_once(timeout_sec=timeout)
        except ExternalShutdownException:
            pass
        s = node.loop.stats()
        lat = s["latency_ms"]
        print(f"stopped after {s['counts']['substeps']} substeps ({s['counts']['control_steps']} policy steps)"
              + (f"; latency p50 {lat['p50']} ms, p99 {lat['p99']} ms" if lat["p50"] is not None else ""),
              flush=True)  # fmt: skip
        if stats:
            with open(stats, "w") as f:
                json.dump(s, f)
        return 0
    finally:
        if node is not None:
            node.node.destroy_node()
        rclpy.try_shutdown()
