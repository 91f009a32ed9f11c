"""The controller bundle as a ROS 2 node, and C MuJoCo as its robot over ROS 2 topics (``hexnewton-ros``).

    python -m hexnewton.apps.ros node BUNDLE                     # the node, until Ctrl-C (the robot's own topics)
    python -m hexnewton.apps.ros node BUNDLE --ros-args -p sensor_timeout:=0.2 -p imu_topic:=/imu/data
    python -m hexnewton.apps.ros params                          # the node's ROS parameters, one line each
    python -m hexnewton.apps.ros node BUNDLE --stats node.json --ros-args -p trajectory_topic:=joint_trajectory \\
        -p sensor_reliability:=reliable -p sync_tolerance:=0.0 -p sensor_timeout:=1.0   # for the lockstep robot
    python -m hexnewton.apps.ros robot BUNDLE --terrain flat --rounds 1 --max_steps 400 --out robot.json
    python -m hexnewton.apps.ros robot BUNDLE --terrain flat --rounds 20 --realtime --bag run_bag --out robot.json
    python -m hexnewton.apps.ros replay run_bag                  # the recorded readings to a node, instant by instant

``node`` (:mod:`hexnewton.deploy.ros`) runs the bundle's policy and CPG on ``sensor_msgs/JointState``, ``Imu``,
``nav_msgs/Odometry``, the terrain reading and a ``geometry_msgs/PoseStamped`` goal, and publishes the joint targets
(``std_msgs/Float64MultiArray`` for ros2_control's forward position controller) and ``diagnostic_msgs`` diagnostics;
its topics, QoS, rates, timeouts and the bundle are ROS parameters (``--ros-args -p NAME:=VALUE``). It needs rclpy:
``pip install -e '.[ros]'``, or a sourced ROS 2 installation (not both). ``--stats`` writes its counters and every
latency (sensor stamp to the targets' publish) to a JSON file when it stops.

``robot`` (:mod:`hexnewton.analysis.ros_robot`) is C MuJoCo as the robot: sim2sim's rounds (terrain seed
``--seed``, the evaluation's starts and episode ends), one after another, each its own model, the targets from
the node, in lockstep (the default: each step waits for its targets) or ``--realtime`` (paced by the wall clock);
its model sim2sim's (``--mjcf own|generated``, ``--robot FILE.xml``: a robot's own MJCF file, or the one written from
the bundle's description);
``--bag`` records the run as a rosbag2 folder (MCAP); ``--out`` writes the rounds and the robot's counts as JSON.
``replay`` plays a recorded run's readings back to a node (open loop), each instant's messages together at the
instant's recorded time.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from hexnewton.analysis.rollout import EVAL_TERRAIN_SEED
from hexnewton.apps.cli import ArgumentParser, add_mjcf_arg, add_robot_args, check_new_dir, check_writable
from hexnewton.apps.cli import positive_int, robot_from_args, run, terrain_name
from hexnewton.config import TaskConfig

PROG = "python -m hexnewton.apps.ros"


def _parser() -> ArgumentParser:
    p = ArgumentParser(prog=PROG, description="The controller bundle as a ROS 2 node; C MuJoCo as its robot.")
    sub = p.add_subparsers(dest="command", required=True, metavar="{node,params,robot,replay}")
    n = sub.add_parser("node", help="the bundle as a ROS 2 node, until Ctrl-C")
    n.add_argument("bundle", nargs="?", default="", help="the bundle's folder (or the parameter bundle)")
    n.add_argument("--stats", metavar="PATH.json", help="write the counters and every latency here when it stops")
    priority = dict(type=int, default=0, metavar="1..99",
                    help="run under the real-time FIFO scheduler at this priority (0: the normal scheduler)")
    n.add_argument("--priority", **priority)
    n.add_argument("--ros-args", dest="ros_args", nargs=argparse.REMAINDER, default=[],
                   help="ROS arguments to the end: -p NAME:=VALUE sets a parameter (the params command lists them)")
    sub.add_parser("params", help="the node's ROS parameters, their defaults and what they are")
    r = sub.add_parser("robot", help="C MuJoCo as the node's robot: sim2sim's rounds over ROS 2")
    r.add_argument("bundle", help="the bundle the node runs (its substep, goal distance and joint names)")
    r.add_argument("--terrain", type=terrain_name, default="flat")
    r.add_argument("--rounds", type=positive_int, default=1, help="rounds of the protocol (lanes, starts)")
    r.add_argument("--only", type=int, nargs="+", metavar="K", help="run only these rounds (indices)")
    r.add_argument("--seed", type=int, default=EVAL_TERRAIN_SEED, help="terrain seed; starts use seed + 1000")
    r.add_argument("--max_steps", type=positive_int, default=TaskConfig.max_episode_steps,
                   help="control steps per round at most")  # fmt: skip
    r.add_argument("--realtime", action="store_true", help="paced by the wall clock (default: lockstep)")
    r.add_argument("--bag", metavar="DIR", help="record the run as a rosbag2 folder (MCAP storage)")
    r.add_argument("--out", metavar="PATH.json", help="write the rounds and the robot's counts here")
    r.add_argument("--priority", **priority)
    add_mjcf_arg(r)
    add_robot_args(r, "the bundle's (its controller.json's description)")
    b = sub.add_parser("replay", help="play a recorded run's readings back to a node")
    b.add_argument("bag", help="a rosbag2 folder written by robot --bag")
    b.add_argument("--speed", type=float, default=1.0, help="times faster than recorded")
    b.add_argument("--priority", **priority)
    return p


def main(argv: list[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.command == "params":
        from hexnewton.deploy.control_loop import PARAMETERS

        for name, (default, text) in PARAMETERS.items():
            print(f"{name} = {default!r}: {text}")
        return 0
    if args.command == "node":
        from hexnewton.deploy.ros import run_node

        if args.stats:
            check_writable(args.stats, ".json")
        return run_node(args.bundle, list(args.ros_args), args.stats, args.priority)
    if args.command == "replay":
        return _replay(args)
    return _robot(args)


def _robot(args) -> int:
    from hexnewton.analysis.sim2sim import bundle_model

    _, mjcf = bundle_model(args.bundle, robot_from_args(args), args.mjcf, prog="ros robot")
    if args.out:
        check_writable(args.out, ".json")
    if args.bag:
        check_new_dir(args.bag)
    only = args.only
    if only is not None and not all(0 <= k < args.rounds for k in only):
        raise ValueError(f"--only: round indices must be in 0..{args.rounds - 1}, got {only}")
    from hexnewton.analysis.ros_robot import run_rounds
    from hexnewton.deploy.ros import realtime_priority

    realtime_priority(args.priority)

    def show(row: dict) -> None:
        print(f"round {row['round']}: {row['status']} after {row['steps']} control steps, x {row['x']:.3f} m, "
              f"{row['missed_periods']} missed periods, {row['wall_s']:.1f} s", flush=True)  # fmt: skip

    res = run_rounds(args.bundle, args.terrain, args.rounds, args.seed, args.max_steps, args.realtime, args.bag, only,
                     show, mjcf=mjcf)  # fmt: skip
    res.update(mode="realtime" if args.realtime else "lockstep", terrain=args.terrain, seed=args.seed,
               bundle=args.bundle, model=mjcf or "generated")  # fmt: skip
    if args.out:
        with open(args.out, "w") as f:
            json.dump(res, f, indent=1)
    print(f"{len(res['rounds'])} rounds; sent {sum(res['sent'].values())} messages, round trip p50 "
          f"{res['round_trip_ms']['p50']} ms, p99 {res['round_trip_ms']['p99']} ms"
          + (f"; bag {args.bag} ({res['bag_messages']} messages)" if args.bag else ""))  # fmt: skip
    return 0


def _replay(args) -> int:
    if not os.path.isfile(os.path.join(args.bag, "metadata.yaml")):
        raise ValueError(f"{args.bag} is not a rosbag2 folder (no metadata.yaml)")
    if not args.speed > 0:
        raise ValueError(f"--speed must be positive, got {args.speed}")
    from hexnewton.analysis.ros_robot import replay
    from hexnewton.deploy.ros import realtime_priority

    realtime_priority(args.priority)
    counts = replay(args.bag, args.speed)
    print(f"replayed {sum(counts.values())} messages: " + ", ".join(f"{k} {v}" for k, v in counts.items()))
    return 0


if __name__ == "__main__":
    sys.exit(run(main, PROG))
