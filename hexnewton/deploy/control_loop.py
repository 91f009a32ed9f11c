"""The ROS 2 controller node's logic without ROS (:class:`ControlLoop`): its parameters, the readings it checks, the
substeps and policy steps it runs on them, the standing pose it holds on faults, and what it counts.
:mod:`hexnewton.deploy.ros` puts it on topics; it needs NumPy and onnxruntime only.

Per IMU message (``trigger`` imu) or per timer tick at the bundle's substep (``trigger`` timer) it runs one CPG
substep; every ``substeps_per_control`` substeps first the policy, on readings stamped within ``sync_tolerance`` of
that IMU message (it waits for them until the next IMU message). Where the readings come once per control period,
their instant is the policy's: IMU messages lost while walking re-align the count to it (``realigned_control_steps``).
Faults: a reading missing or older than ``sensor_timeout``, no goal, or the goal reached: it moves to the standing
pose at ``stand_speed`` and holds it, says so once in the log and in diagnostics, and walks again, with a fresh CPG,
when all is back. A malformed message (wrong joint names or count, NaN, a goal in another frame than the odometry's)
is refused with one log line (then one per 5 s per topic, with the count) and counted.
"""

from __future__ import annotations

import math
import os
from collections import deque

import numpy as np

from hexnewton.config import JOINT_NAMES
from hexnewton.deploy.runtime import Controller, load_spec, target_in_heading_frame

#: the node's ROS parameters: name -> (default, what it is); a period of 0 means the bundle's own
PARAMETERS = {
    "bundle": ("", "the controller bundle's folder (python -m hexnewton.apps.export)"),
    "joint_states_topic": ("joint_states", "sensor_msgs/JointState in"),
    "imu_topic": ("imu", "sensor_msgs/Imu in"),
    "odom_topic": ("odom", "nav_msgs/Odometry in"),
    "terrain_topic": ("terrain_height", "geometry_msgs/PointStamped in, the terrain reading as z [m] ('': none, 0)"),
    "goal_topic": ("goal_pose", "geometry_msgs/PoseStamped in, in the odometry frame"),
    "commands_topic": ("forward_position_controller/commands", "std_msgs/Float64MultiArray out"),
    "trajectory_topic": ("", "trajectory_msgs/JointTrajectory out ('': off)"),
    "diagnostics_topic": ("/diagnostics", "diagnostic_msgs/DiagnosticArray out"),
    "sensor_reliability": ("best_effort", "the sensors' subscriptions: best_effort or reliable"),
    "sensor_depth": (10, "the sensors' queue depth"),
    "command_reliability": ("reliable", "the targets' publishers: reliable or best_effort"),
    "goal_durability": ("volatile", "the goal's subscription: volatile or transient_local"),
    "trigger": ("imu", "a CPG substep per IMU message (imu) or per timer tick at substep_period (timer)"),
    "executor": ("single_threaded", "rclpy's SingleThreadedExecutor (single_threaded) or its EventsExecutor (events: "
                 "rclpy.experimental, the waits in C++)"),
    "substep_period": (0.0, "the CPG substep [s] (0: the bundle's; another value is refused)"),
    "control_period": (0.0, "the policy's period [s] (0: the bundle's; another value is refused)"),
    "sensor_timeout": (0.1, "a reading older than this [s] holds the standing pose"),
    "sync_tolerance": (0.0025, "the policy's readings within this of the IMU stamp [s] (negative: the latest)"),
    "goal_tolerance": (0.5, "the goal is reached within this distance [m] (0: never)"),
    "stand_speed": (1.0, "how fast a joint moves to the standing pose when holding [rad/s]"),
    "watchdog_period": (0.02, "how often the readings' age is checked while no IMU message comes [s]"),
    "diagnostics_period": (1.0, "the diagnostics' period [s]"),
}
CHOICES = {"sensor_reliability": ("best_effort", "reliable"), "command_reliability": ("reliable", "best_effort"),
           "goal_durability": ("volatile", "transient_local"), "trigger": ("imu", "timer"),
           "executor": ("single_threaded", "events")}  # fmt: skip
#: refusals of one topic are logged the first time, then at most once per this many seconds
REFUSAL_LOG_PERIOD = 5.0


def _typed(default, value):
    """``value`` as the type of ``default`` (an int for an int, a number for a float, a string for a string), or
    None where it is not one."""
    if isinstance(default, str):
        return value if isinstance(value, str) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    if isinstance(default, int):
        return int(value) if float(value).is_integer() else None
    return float(value) if math.isfinite(value) else None


def check_parameters(values: dict) -> dict:
    """The node's parameters (defaults filled in), each of its type and range; ValueError names the first bad one."""
    unknown = sorted(set(values) - set(PARAMETERS))
    if unknown:
        raise ValueError(f"unknown parameter {unknown[0]!r} (the node's: {', '.join(PARAMETERS)})")
    out = {}
    for name, (default, _) in PARAMETERS.items():
        v = _typed(default, values.get(name, default))
        if v is None:
            raise ValueError(f"parameter {name}: expected {type(default).__name__}, got {values.get(name)!r}")
        if name in CHOICES and v not in CHOICES[name]:
            raise ValueError(f"parameter {name}: {v!r} is not one of {', '.join(CHOICES[name])}")
        positive = name in ("sensor_depth", "sensor_timeout", "stand_speed", "watchdog_period", "diagnostics_period")
        if (positive and v <= 0) or (name.endswith("_period") and v < 0) or (name == "goal_tolerance" and v < 0):
            raise ValueError(f"parameter {name}: must be {'positive' if positive else '>= 0'}, got {v}")
        out[name] = v
    if not out["bundle"]:
        raise ValueError("no bundle: give its folder (the parameter bundle)")
    spec = load_spec(out["bundle"])
    for name, key in (("substep_period", "substep_dt"), ("control_period", "control_dt")):
        if out[name] and abs(out[name] - spec[key]) > 1e-9:
            raise ValueError(f"parameter {name}: {out[name]} s, but the bundle's policy runs at {key} = "
                             f"{spec[key]} s")  # fmt: skip
    return out




def percentiles_ms(samples) -> dict:
    """p50 / p90 / p99 / p99.9 / max of latencies in milliseconds (None without samples)."""
    a = np.asarray(samples, np.float64)
    keys = ("p50", "p90", "p99", "p999", "max")
    if a.size == 0:
        return dict.fromkeys(keys)
    return dict(zip(keys, [round(float(v), 4) for v in np.percentile(a, [50, 90, 99, 99.9, 100])]))


def single_threaded(bundle: str) -> Controller:
    """The bundle's :class:`Controller` for one robot, its policy in an onnxruntime session of one thread that does
    not spin: onnxruntime's default pool spins its threads after each run, which on a robot's few cores takes the CPU
    from every other callback. The same model, the same input."""
    import onnxruntime as ort

    ctrl = Controller(bundle, num_robots=1)
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = opts.inter_op_num_threads = 1
    opts.add_session_config_entry("session.intra_op.allow_spinning", "0")
    ctrl.session = ort.InferenceSession(os.path.join(bundle, "policy.onnx"), sess_options=opts,
                                        providers=ctrl.session.get_providers())  # fmt: skip
    return ctrl


class Reading:
    """The latest message of one input: its values, its stamp [ns] and when it arrived [ns, wall clock]."""

    __slots__ = ("value", "stamp", "received")

    def __init__(self, value, stamp: int, received: int):
        self.value, self.stamp, self.received = value, stamp, received


class ControlLoop:
    """The node's logic without ROS: readings in (each checked; a refusal is a reason string), joint targets out.

    ``p``: :func:`check_parameters`'s dict; ``log(text)``: one line for the log. Times are nanoseconds, stamps those of
    the messages, ``now`` the wall clock. :meth:`on_imu` / :meth:`on_reading` / :meth:`on_timer` / :meth:`on_watchdog`
    return the targets to publish, ``[(stamp of the IMU message they answer or None, targets (18,))]``, in the robot's
    joint senses (``joint_signs``)."""

    def __init__(self, p: dict, log=print):
        self.p, self.log = p, log
        self.ctrl = single_threaded(p["bundle"])
        spec = self.spec = self.ctrl.spec
        self.joints = tuple(spec.get("obs_notes", {}).get("joint order", JOINT_NAMES))
        self.order = {name: i for i, name in enumerate(self.joints)}
        # the robot's joint senses (controller.json's joint_signs, a robot file's): its joint states are turned into
        # hexnewton's sense as they come, the targets back into the robot's as they go
        self.signs = np.asarray(spec.get("joint_signs", [1.0] * 18), np.float64)
        self.substeps, self.dt = int(spec["substeps_per_control"]), float(spec["substep_dt"])
        self.stand = np.tile(np.asarray(spec["stand_pose"], np.float64), 6)
        terrain = bool(p["terrain_topic"]) and "max_height" in self.ctrl.layout
        self.required = ("joint_states", "imu", "odom") + (("terrain",) if terrain else ())
        self.latest: dict[str, Reading] = {}
        self.goal = self.goal_frame = None
        self.pending = None  # the stamp of an IMU message whose substep waits for the policy's readings
        self.pending_since = 0
        self.sub, self.walking, self.reached, self.reason = 0, False, False, "no readings yet"
        self.last, self.last_time = None, 0
        self.counts = {k: 0 for k in ("substeps", "control_steps", "holds", "unmatched_control_steps",
                                      "realigned_control_steps")}
        # the readings' instants: the count of IMU messages accepted at the latest new joint state, the last gaps
        # between new joint states in IMU messages, the joint state stamp the last policy step read, and whether the
        # next substep is a policy step on readings of the substep before it (they came after its IMU message)
        self._imu_at_reading, self.reading_gaps = None, deque(maxlen=8)
        self.policy_reading, self.late = None, False
        self.last_stamp, self.last_sub = None, None  # the last substep's IMU stamp and its index
        self.received = dict.fromkeys(("joint_states", "imu", "odom", "terrain", "goal"), 0)
        self.refused = dict.fromkeys(self.received, 0)
        self._refusal_logged: dict[str, float] = {}
        self.latencies: list[float] = []  # stamp to publish [ms], every substep's
        self.recent = deque(maxlen=2000)
        self.changed = True  # the state changed since the diagnostics last said it

    # --- readings ------------------------------------------------------------------------------------------------
    def refuse(self, topic: str, why: str, now: int) -> str:
        """Count a malformed message and log it (the first, then once per REFUSAL_LOG_PERIOD per topic)."""
        self.refused[topic] += 1
        t = now * 1e-9
        if t - self._refusal_logged.get(topic, -math.inf) >= REFUSAL_LOG_PERIOD:
            self._refusal_logged[topic] = t
            self.log(f"refused a {topic} message: {why} ({self.refused[topic]} refused so far)")
        return why

    def _store(self, topic: str, value, stamp: int, now: int) -> None:
        self.received[topic] += 1
        self.latest[topic] = Reading(value, stamp, now)

    def joint_state(self, names, position, velocity, stamp: int, now: int) -> str | None:
        """The 18 joints' positions and velocities, by name; None, or why the message was refused."""
        names = list(names)
        if len(names) != 18 or set(names) != set(self.joints):
            extra = sorted(set(names) - set(self.joints))[:3]
            return self.refuse("joint_states", f"{len(names)} joints{f' ({extra} unknown)' if extra else ''}, "
                               f"expected the bundle's 18: {', '.join(self.joints[:3])}, ...", now)  # fmt: skip
        pos, vel = np.asarray(position, np.float64), np.asarray(velocity, np.float64)
        if pos.shape != (18,) or vel.shape != (18,):
            return self.refuse("joint_states", f"{pos.size} positions and {vel.size} velocities for 18 joints", now)
        if not (np.isfinite(pos).all() and np.isfinite(vel).all()):
            return self.refuse("joint_states", "a position or velocity is not finite", now)
        idx = [names.index(j) for j in self.joints] if names != list(self.joints) else slice(None)
        last = self.latest.get("joint_states")
        if last is None or stamp != last.stamp:  # a new instant: IMU messages since the previous one
            if self._imu_at_reading is not None:
                self.reading_gaps.append(self.received["imu"] - self._imu_at_reading)
            self._imu_at_reading = self.received["imu"]
        self._store("joint_states", (self.signs * pos[idx], self.signs * vel[idx]), stamp, now)
        return None

    def imu(self, quat, gyro, stamp: int, now: int) -> str | None:
        """The body's attitude (x, y, z, w) and angular velocity [rad/s]."""
        q, w = np.asarray(quat, np.float64), np.asarray(gyro, np.float64)
        if not (np.isfinite(q).all() and np.isfinite(w).all()):
            return self.refuse("imu", "the orientation or angular velocity is not finite", now)
        if abs(np.linalg.norm(q) - 1.0) > 0.01:
            return self.refuse("imu", f"the orientation's norm is {np.linalg.norm(q):.3f}, not 1", now)
        self._store("imu", (q, w), stamp, now)
        return None

    def odometry(self, frame: str, position, quat, stamp: int, now: int) -> str | None:
        """The base's pose in the odometry frame ``frame``."""
        p, q = np.asarray(position, np.float64), np.asarray(quat, np.float64)
        if not (np.isfinite(p).all() and np.isfinite(q).all()) or np.linalg.norm(q) < 0.5:
            return self.refuse("odom", "the pose is not finite or its orientation not a unit quaternion", now)
        if self.goal_frame is not None and frame != self.goal_frame:
            return self.refuse("odom", f"frame {frame!r}, but the goal is in {self.goal_frame!r}", now)
        self._store("odom", (frame, p, q), stamp, now)
        return None

    def terrain(self, value: float, stamp: int, now: int) -> str | None:
        """The terrain reading [m]."""
        if not math.isfinite(value):
            return self.refuse("terrain", f"reading {value}", now)
        self._store("terrain", float(value), stamp, now)
        return None

    def set_goal(self, frame: str, position, now: int) -> str | None:
        """A goal (x, y, ground z) in the odometry frame; it replaces the current one."""
        g = np.asarray(position, np.float64)
        if not np.isfinite(g).all():
            return self.refuse("goal", "the position is not finite", now)
        odom = self.latest.get("odom")
        known = odom.value[0] if odom is not None else self.goal_frame
        if not frame or (known is not None and frame != known):
            return self.refuse("goal", f"frame {frame!r} is not the odometry's ({known!r})", now)
        self.received["goal"] += 1
        self.goal, self.goal_frame, self.reached, self.changed = g, frame, False, True
        self.log(f"goal ({g[0]:.3f}, {g[1]:.3f}) in {frame!r}")
        return None

    # --- substeps ------------------------------------------------------------------------------------------------
    def hold_reason(self, now: int) -> str | None:
        """Why the robot must stand now (None: it may walk)."""
        for topic in self.required:
            r = self.latest.get(topic)
            if r is None:
                return f"no {topic} message yet"
            if (now - r.received) * 1e-9 > self.p["sensor_timeout"]:
                return f"{topic} stale (none for {self.p['sensor_timeout']:g} s)"
        if self.goal is None:
            return "waiting for a goal"
        return "goal reached" if self.reached else None

    def _synced(self, stamp: int) -> bool:
        tol = self.p["sync_tolerance"]
        if tol < 0:
            return True
        return all(t in self.latest and abs(self.latest[t].stamp - stamp) <= tol * 1e9
                   for t in self.required if t != "imu")  # fmt: skip

    def on_imu(self, quat, gyro, stamp: int, now: int) -> list:
        """An IMU message (``trigger`` imu): its substep, now or once the policy's readings of its stamp are here."""
        if self.imu(quat, gyro, stamp, now) is not None:
            return []
        out = []
        if self.pending is not None:  # superseded while waiting: the latest readings serve it
            self.counts["unmatched_control_steps"] += 1
            out.append(self._substep(now))
        self.pending, self.pending_since = stamp, now
        if self.sub != 0 and self._fresh_readings_at(stamp):  # readings of this instant: the policy's substep
            self.sub = 0
            self.counts["realigned_control_steps"] += 1
        return out + self._try(now)

    def on_reading(self, now: int) -> list:
        """After a joint state or odometry: the substep waiting for it, if it was the last one missing; readings of
        the instant of a substep that ran without the policy make the next substep the policy's, on them."""
        if self.pending is not None:
            return self._try(now)
        if self.last_sub not in (None, 0) and not self.late and self._fresh_readings_at(self.last_stamp):
            self.sub, self.late = 0, True
            self.counts["realigned_control_steps"] += 1
        return []

    def once_per_period(self) -> bool:
        """Whether the joint states come once per control period (so their instants are the policy's)."""
        gaps = sorted(self.reading_gaps)
        return self.substeps > 1 and len(gaps) >= 3 and gaps[len(gaps) // 2] == self.substeps

    def _fresh_readings_at(self, stamp: int | None) -> bool:
        """While walking on the IMU: readings of ``stamp``'s instant that no policy step has read, arriving once per
        control period (IMU messages lost since the last policy step moved its count off their instant); never with
        ``sync_tolerance`` negative (the policy reads the latest, whatever its instant)."""
        js = self.latest.get("joint_states")
        return (self.walking and self.p["trigger"] == "imu" and self.p["sync_tolerance"] >= 0 and stamp is not None
                and js is not None and js.stamp != self.policy_reading and self.once_per_period()
                and self._synced(stamp))

    def on_timer(self, now: int) -> list:
        """A timer tick (``trigger`` timer): one substep on the latest readings."""
        self.pending = self.latest["imu"].stamp if "imu" in self.latest else None
        return [self._substep(now)]

    def on_watchdog(self, now: int) -> list:
        """While no IMU message comes: hold the standing pose (saying why once); a substep that waited longer than
        ``sensor_timeout`` for its readings runs on the latest."""
        if self.pending is not None and now - self.pending_since > self.p["sensor_timeout"] * 1e9:
            self.counts["unmatched_control_steps"] += 1
            return [self._substep(now)]
        reason = self.hold_reason(now)
        imu = self.latest.get("imu")
        if reason is None or (imu is not None and now - imu.received < self.p["sensor_timeout"] * 1e9):
            return []  # walking, or the IMU's own substeps hold the pose
        return [(None, self._hold(reason, now))]

    def _try(self, now: int) -> list:
        if self.sub == 0 and not self.late and not self._synced(self.pending):
            return []
        return [self._substep(now)]

    def _substep(self, now: int):
        stamp, self.pending = self.pending, None
        reason = self.hold_reason(now)
        if reason is None and self.sub == 0 and self._reached():
            reason = "goal reached"
        if reason is None and not self.walking and self.p["trigger"] == "imu" and not self._synced(stamp):
            reason = self.reason  # walking starts on a policy substep: readings of the IMU message's instant
        if reason is not None:
            return stamp, self._hold(reason, now)
        if not self.walking:
            self.walking, self.changed, self.reason = True, True, None
            self.log(f"walking to ({self.goal[0]:.3f}, {self.goal[1]:.3f})")
        imu = self.latest["imu"].value
        if self.sub == 0:
            self._policy(imu[0], imu[1])
        q = self.ctrl.substep(imu[0])[0]
        self.last_stamp, self.last_sub = stamp, self.sub
        # after a policy step on the readings of the substep before: the count goes on from their instant
        self.sub = (self.sub + (2 if self.late else 1)) % self.substeps
        self.late = False
        self.counts["substeps"] += 1
        self.last, self.last_time = q, now
        return stamp, self.signs * q

    def _reached(self) -> bool:
        tol = self.p["goal_tolerance"]
        pos = self.latest["odom"].value[1]
        self.reached = tol > 0 and math.hypot(self.goal[0] - pos[0], self.goal[1] - pos[1]) < tol
        return self.reached

    def _policy(self, quat, gyro) -> None:
        """The policy's step on the latest readings (the runtime's observe, act, set_actions; the IMU's angular
        velocity is the gyro a policy may observe)."""
        joint_pos, joint_vel = self.latest["joint_states"].value
        _, pos, base_quat = self.latest["odom"].value
        goal = np.r_[self.goal[:2], 0.0]
        target = target_in_heading_frame(pos, base_quat, goal, self.goal[2])
        height = self.latest["terrain"].value if "terrain" in self.required else 0.0
        obs = self.ctrl.observe(joint_pos, joint_vel, quat, target, height, gyro)
        self.ctrl.set_actions(self.ctrl.act(obs), target)
        self.counts["control_steps"] += 1
        self.policy_reading = self.latest["joint_states"].stamp

    def _hold(self, reason: str, now: int) -> np.ndarray | None:
        """Move to the standing pose at ``stand_speed`` from the last targets (or the measured joints; None before
        the first joint state)."""
        if self.walking or reason != self.reason:
            if self.walking:
                self.counts["holds"] += 1
                self.ctrl.reset()  # a fresh CPG when it walks again (building a Controller anew: 40-60 ms)
            self.walking, self.sub, self.reason, self.changed, self.late = False, 0, reason, True, False
            self.log(f"holding the standing pose: {reason}")
        if self.last is None:  # from the measured joints; nothing before the first joint state
            js = self.latest.get("joint_states")
            if js is None:
                return None
            self.last, self.last_time = js.value[0].copy(), now
        step = self.p["stand_speed"] * min((now - self.last_time) * 1e-9, 0.1)
        self.last = self.last + np.clip(self.stand - self.last, -step, step)
        self.last_time = now
        return self.signs * self.last

    def published(self, stamp: int | None, now: int) -> None:
        """Record the latency of targets published at ``now`` for the IMU message stamped ``stamp``."""
        if stamp is not None:
            ms = (now - stamp) * 1e-6
            self.latencies.append(ms)
            self.recent.append(ms)

    def status(self) -> tuple[str, dict]:
        """(state, values) for the diagnostics: the state in words and the counters, as strings."""
        state = "walking" if self.walking else f"holding: {self.reason}"
        lat = percentiles_ms(self.recent)
        values = {"state": "walking" if self.walking else "holding", "reason": self.reason or "",
                  "goal_frame": self.goal_frame or ""}  # fmt: skip
        for k, v in zip("xyz", self.goal if self.goal is not None else ("", "", "")):
            values[f"goal_{k}"] = repr(float(v)) if v != "" else ""
        values.update({k: str(v) for k, v in self.counts.items()})
        values.update({f"received_{k}": str(v) for k, v in self.received.items()})
        values.update({f"refused_{k}": str(v) for k, v in self.refused.items()})
        values.update({f"latency_{k}_ms": "" if v is None else f"{v:.3f}" for k, v in lat.items()})
        return state, values

    def stats(self) -> dict:
        """Everything counted, and every latency, for a stats file."""
        return {"counts": dict(self.counts), "received": dict(self.received), "refused": dict(self.refused),
                "latency_ms": percentiles_ms(self.latencies), "latency_samples_ms": self.latencies}  # fmt: skip
