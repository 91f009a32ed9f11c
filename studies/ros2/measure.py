"""The controller bundle as a ROS 2 node against C MuJoCo over real topics: lockstep agreement with the in-process
sim2sim, real-time rounds, latency (sensor stamp to the targets' publish) and misses. Writes report.md and
results.json beside this file (or in --out).

    python studies/ros2/measure.py                        # 40 lockstep rounds on flat and rugged, 25 real-time
    python studies/ros2/measure.py --rounds 2 --realtime_rounds 1 --out /tmp/ros2   # a quick look

Each part runs the node (``python -m hexnewton.apps.ros node``) and the robot (``... robot``) as two processes on
loopback, on one ROS_DOMAIN_ID, discovery on this machine only:
1. in-process baseline: sim2sim's rounds (``run_part``, one robot per model: round k of ``--rounds``, terrain seed
   1000, starts from seed 2000), flat and rugged;
2. lockstep: the same rounds, the robot waiting for each target; per round, how it ended beside the baseline;
3. real time: flat rounds paced by the wall clock, the node's default QoS (best-effort sensors);
4. a bag: a short real-time run recorded as rosbag2 (MCAP), then replayed to a fresh node (no MuJoCo on the cores);
3 and 4 once under the normal scheduler and once with the node, the robot and the replay at real-time FIFO
priority (``--priority``), as a robot runs its driver and controller; the lockstep runs stay on the normal one.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)
BUNDLE = "results/controllers/cpg_rl_complex"
PY = [sys.executable, "-m", "hexnewton.apps.ros"]
LOCKSTEP = None  # the node's parameters for the lockstep robot (hexnewton.analysis.ros_robot), set in main
ENV = dict(os.environ, ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID", "77"), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
BINS = [0, 0.5, 1, 1.5, 2, 3, 4, 5, 7.5, 10, 15, 20, 50, 1e9]


def node(stats: str, params: list[str], priority: int = 0):
    cmd = PY + ["node", BUNDLE, "--stats", stats] + (["--priority", str(priority)] if priority else [])
    return subprocess.Popen(cmd + ["--ros-args", *params], cwd=ROOT, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)  # fmt: skip


def stop(proc, stats: str) -> dict:
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    if proc.returncode != 0 or not os.path.isfile(stats):
        raise RuntimeError(f"the node ended with {proc.returncode}:\n{out[-3000:]}")
    with open(stats) as f:
        s = json.load(f)
    lat = np.asarray(s.pop("latency_samples_ms"))
    s["latency_histogram_ms"] = {"bins": BINS[:-1], "counts": np.histogram(lat, BINS)[0].tolist()}
    s["log_lines"] = out.count("\n")
    return s


def robot(args: list[str], out: str) -> dict:
    proc = subprocess.run(PY + ["robot", BUNDLE, "--out", out, *args], cwd=ROOT, env=ENV, capture_output=True,
                          text=True, timeout=7200)  # fmt: skip
    if proc.returncode != 0:
        raise RuntimeError(f"robot {args}: {proc.stderr[-3000:]}")
    with open(out) as f:
        return json.load(f)


def baseline(terrain: str, rounds: int) -> list[dict]:
    from hexnewton.analysis.ros_robot import round_summary
    from hexnewton.analysis.sim2sim import run_part

    return [dict(round=k, **round_summary(run_part(BUNDLE, terrain, rounds, 1000, None, robots=[k])))
            for k in range(rounds)]  # fmt: skip


def agreement(ros: list[dict], ref: list[dict]) -> dict:
    same = [a["status"] == b["status"] for a, b in zip(ros, ref)]
    exact = [a["status"] == b["status"] and a["steps"] == b["steps"] and a["x"] == b["x"] and a["y"] == b["y"]
             for a, b in zip(ros, ref)]  # fmt: skip
    dx = max(abs(a["x"] - b["x"]) for a, b in zip(ros, ref))
    return {"rounds": len(ros), "same_end": int(sum(same)), "same_end_rate": float(np.mean(same)),
            "identical": int(sum(exact)), "max_abs_dx_m": dx,
            "ros_success": sum(a["status"] == "success" for a in ros),
            "in_process_success": sum(b["status"] == "success" for b in ref)}  # fmt: skip


def dropped(sent: dict, received: dict) -> dict:
    return {k: int(sent[k] - received.get(k, 0)) for k in sent}


def latency_parts(args, tmp: str, priority: int) -> tuple[dict, dict]:
    """Real-time flat rounds, then a recorded bag replayed, the node at ``priority`` (0: the normal scheduler)."""
    tag = f"_fifo{priority}" if priority else ""
    stats = os.path.join(tmp, f"node_rt{tag}.json")
    n = node(stats, [], priority)
    load = os.getloadavg()[0]
    fifo = ["--priority", str(priority)] if priority else []
    r = robot(["--terrain", "flat", "--rounds", str(args.realtime_rounds), "--realtime", *fifo],
              os.path.join(tmp, f"rt{tag}.json"))  # fmt: skip
    s = stop(n, stats)
    rt = {"node": s, "robot": r, "dropped": dropped(r["sent"], s["received"]), "priority": priority,
          "load_1min": [load, os.getloadavg()[0]],
          "reached_3m": sum(row["status"] == "success" and row["x_far"] >= 3.0 for row in r["rounds"])}  # fmt: skip
    print(f"real time{tag}: {rt['reached_3m']} of {args.realtime_rounds} reached 3 m, node latency "
          f"{s['latency_ms']}", flush=True)  # fmt: skip
    bag = os.path.join(tmp, f"bag{tag}")
    stats = os.path.join(tmp, f"node_bag{tag}.json")
    n = node(stats, [], priority)
    rec = robot(["--terrain", "flat", "--rounds", str(args.bag_rounds), "--realtime", "--bag", bag, *fifo],
                os.path.join(tmp, f"bag_robot{tag}.json"))  # fmt: skip
    stop(n, stats)
    stats = os.path.join(tmp, f"node_replay{tag}.json")
    n = node(stats, [], priority)
    load = os.getloadavg()[0]
    rep = subprocess.run(PY + ["replay", bag, *fifo], cwd=ROOT, env=ENV, capture_output=True, text=True,
                         timeout=3600)  # fmt: skip
    if rep.returncode != 0:
        raise RuntimeError(rep.stderr[-3000:])
    s = stop(n, stats)
    print(f"replay{tag}: node latency {s['latency_ms']}", flush=True)
    rp = {"node": s, "bag_messages": rec["bag_messages"], "replay": rep.stdout.strip(), "priority": priority,
          "load_1min": [load, os.getloadavg()[0]],
          "bag_bytes": sum(os.path.getsize(os.path.join(bag, f)) for f in os.listdir(bag))}  # fmt: skip
    return rt, rp


def run(args, tmp: str) -> dict:
    res = {"bundle": BUNDLE, "rounds": args.rounds, "realtime_rounds": args.realtime_rounds,
           "bag_rounds": args.bag_rounds, "lockstep": {}}
    res["realtime"], res["replay"] = latency_parts(args, tmp, 0)
    if args.priority:
        res["realtime_fifo"], res["replay_fifo"] = latency_parts(args, tmp, args.priority)
    for terrain in ("flat", "rugged"):
        t = time.perf_counter()
        ref = baseline(terrain, args.rounds)
        print(f"in-process {terrain}: {time.perf_counter() - t:.0f} s", flush=True)
        stats = os.path.join(tmp, f"node_{terrain}.json")
        n = node(stats, LOCKSTEP)
        t = time.perf_counter()
        r = robot(["--terrain", terrain, "--rounds", str(args.rounds)], os.path.join(tmp, f"robot_{terrain}.json"))
        wall = time.perf_counter() - t
        s = stop(n, stats)
        res["lockstep"][terrain] = {"agreement": agreement(r["rounds"], ref), "node": s, "robot": r,
                                    "in_process": ref, "wall_s": round(wall, 1),
                                    "dropped": dropped(r["sent"], s["received"])}  # fmt: skip
        print(f"lockstep {terrain}: {res['lockstep'][terrain]['agreement']}, {wall:.0f} s", flush=True)
    return res


def _lat(s: dict) -> str:
    lat = s["latency_ms"]
    return f"{lat['p50']:.2f} / {lat['p90']:.2f} / {lat['p99']:.2f} / {lat['p999']:.2f} / {lat['max']:.1f}"


def _runs(res: dict) -> list[tuple[str, dict, dict | None]]:
    """(name, node stats, robot results or None) of every run."""
    out = [(f"lockstep {t}", p["node"], p["robot"]) for t, p in res["lockstep"].items()]
    for tag, label in (("", "normal scheduler"), ("_fifo", "FIFO priority")):
        if f"realtime{tag}" in res:
            out.append((f"real time, flat, {label}", res[f"realtime{tag}"]["node"], res[f"realtime{tag}"]["robot"]))
            out.append((f"bag replayed, {label}", res[f"replay{tag}"]["node"], None))
    return out


def _met(ok: bool) -> str:
    return f"**{'met' if ok else 'not met'}**"


def target_lines(res: dict) -> list[str]:
    lines = []
    for terrain, part in res["lockstep"].items():
        a = part["agreement"]
        lines.append(f"- lockstep on {terrain}: {a['same_end']} of {a['rounds']} rounds end as in-process "
                     f"({100 * a['same_end_rate']:.0f} %, >= 95 %; {a['identical']} identical to the last bit): "
                     f"{_met(a['same_end_rate'] >= 0.95)}")  # fmt: skip
    for tag, label in (("", "normal scheduler"), ("_fifo", "node, robot and replay at FIFO priority")):
        if f"realtime{tag}" not in res:
            continue
        rt, rp = res[f"realtime{tag}"], res[f"replay{tag}"]
        p99r, p99m = rp["node"]["latency_ms"]["p99"], rt["node"]["latency_ms"]["p99"]
        lines.append(f"- real time ({label}): {rt['reached_3m']} of {res['realtime_rounds']} flat rounds reach 3 m "
                     f"(>= 20): {_met(rt['reached_3m'] >= 20)}")  # fmt: skip
        lines.append(f"- latency p99, robot replayed from a bag ({label}): {p99r:.2f} ms (<= 5 ms): {_met(p99r <= 5)}")
        lines.append(f"- latency p99, the MuJoCo robot in real time on the same cores ({label}): {p99m:.2f} ms "
                     f"(<= 10 ms): {_met(p99m <= 10)}")  # fmt: skip
    return lines


def report(res: dict, meta: dict) -> str:
    lines = ["# The controller bundle as a ROS 2 node, closed loop against C MuJoCo over real topics", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()]
    lines += ["", "## Targets", ""] + target_lines(res)
    lines += ["", "## Latency: the sensor message's stamp to the targets' publish, measured by the node", "",
              "| run | substeps | p50 / p90 / p99 / p99.9 / max [ms] | load average (1 min) at start / end |",
              "|---|---|---|---|"]  # fmt: skip
    loads = {"real time, flat, normal scheduler": res["realtime"], "bag replayed, normal scheduler": res["replay"]}
    loads.update({"real time, flat, FIFO priority": res.get("realtime_fifo"),
                  "bag replayed, FIFO priority": res.get("replay_fifo")})
    for name, s, _ in _runs(res):
        load = (loads.get(name) or {}).get("load_1min")
        lines.append(f"| {name} | {s['counts']['substeps']} | {_lat(s)} | "
                     f"{' / '.join(f'{v:.1f}' for v in load) if load else ''} |")
    lines += ["", "Distribution (substeps per bin; bins from the lower edge in ms):", ""]
    head = ["run"] + [f"{b:g}" for b in BINS[:-1]]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name, s, _ in _runs(res):
        lines.append(f"| {name} | " + " | ".join(map(str, s["latency_histogram_ms"]["counts"])) + " |")
    lines += ["", "## Misses", "",
              "| run | messages sent by the robot | sensor messages dropped (sent - received by the node) | control "
              "periods missed (no new target within 85 % of the period) | policy steps on unmatched readings | "
              "refused |", "|---|---|---|---|---|---|"]  # fmt: skip
    for name, s, r in _runs(res):
        if r is None:
            continue
        d = dropped(r["sent"], s["received"])
        missed = sum(row["missed_periods"] for row in r["rounds"])
        lines.append(f"| {name} | {sum(r['sent'].values())} | {sum(d.values())} | {missed} of "
                     f"{sum(row['substeps'] for row in r['rounds'])} | {s['counts']['unmatched_control_steps']} | "
                     f"{sum(s['refused'].values())} |")
    lines += ["", "## Lockstep: per round, ROS 2 / in-process", "",
              "| terrain | round | ROS 2 end | steps | x [m] | in-process end | steps | x [m] | same end |",
              "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
    for terrain, part in res["lockstep"].items():
        for a, b in zip(part["robot"]["rounds"], part["in_process"]):
            lines.append(f"| {terrain} | {a['round']} | {a['status']} | {a['steps']} | {a['x']:.4f} | {b['status']} | "
                         f"{b['steps']} | {b['x']:.4f} | {'yes' if a['status'] == b['status'] else '**no**'} |")
    rp = res["replay"]
    lines += ["", f"The bag of {res.get('bag_rounds', 2)} real-time rounds: {rp['bag_messages']} messages, "
              f"{rp['bag_bytes'] / 1e6:.1f} MB (rosbag2, MCAP storage, metadata version 9); replay: {rp['replay']}.",
              ""]  # fmt: skip
    return "\n".join(lines)


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rounds", type=int, default=40)
    p.add_argument("--realtime_rounds", type=int, default=25)
    p.add_argument("--bag_rounds", type=int, default=2)
    p.add_argument("--priority", type=int, default=50, help="also the latency runs with the node at this real-time "
                   "FIFO priority (0: not)")
    p.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    args = p.parse_args()
    from hexnewton.analysis.ros_robot import LOCKSTEP_NODE_PARAMETERS

    global LOCKSTEP
    LOCKSTEP = [w for k, v in LOCKSTEP_NODE_PARAMETERS.items() for w in ("-p", f"{k}:={v}")]
    t0, load0 = time.perf_counter(), os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        res = run(args, tmp)
    import mujoco
    import rclpy  # noqa: F401

    from hexnewton.analysis.report import git_rev

    meta = {"command": "`python " + " ".join([os.path.relpath(__file__, ROOT)] + sys.argv[1:]) + "`",
            "git": git_rev(), "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
            "no GPU", "ROS 2": "rclpy 9.1.2 (Kilted wheels), Fast DDS, SingleThreadedExecutor, loopback",
            "MuJoCo": mujoco.__version__, "wall time": f"{time.perf_counter() - t0:.0f} s",
            "load average at the start / end (1 min)": f"{load0:.2f} / {os.getloadavg()[0]:.2f}"}  # fmt: skip
    res["meta"] = meta
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report(res, meta))
    print(f"wrote {args.out}/report.md, results.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
