"""The controller bundle as a ROS 2 node against C MuJoCo over real topics: lockstep agreement with the in-process
sim2sim, real-time rounds, latency (sensor stamp to the targets' publish) and misses. Writes report.md and
results.json beside this file (or in --out).

    python studies/ros2/measure.py                        # 40 lockstep rounds on flat and rugged, 25 real-time
    python studies/ros2/measure.py --rounds 2 --realtime_rounds 1 --out /tmp/ros2   # a quick look
    python studies/ros2/measure.py --parts realtime replay   # these parts again; results.json keeps the others

Each part runs the node (``python -m hexnewton.apps.ros node``) and the robot (``... robot``) as two processes on
loopback, on one ROS_DOMAIN_ID, discovery on this machine only:
1. ``lockstep``: sim2sim's in-process rounds (``run_part``, one robot per model: round k of ``--rounds``, terrain
   seed 1000, starts from seed 2000), flat and rugged, then the same rounds over ROS 2, the robot waiting for each
   target; per round, how it ended beside the in-process one;
2. ``realtime``: flat rounds paced by the wall clock, the node's default QoS (best-effort sensors);
3. ``replay``: a short real-time run recorded as rosbag2 (MCAP), then replayed ``--replays`` times, each to a fresh
   node (no MuJoCo on the cores; their latencies pooled), each instant's messages together at its recorded time;
2 and 3 once under the normal scheduler and once with the node, the robot and the replay at real-time FIFO
priority (``--priority``, results.json's ``realtime_fifo`` and ``replay_fifo``), as a robot runs its driver and
controller; the lockstep runs stay on the normal one. ``--parts`` runs only the parts named: results.json in --out
keeps the results this run does not write. Each result keeps the command, git revision, time and load average it ran
under (the report's table of runs), and report.md is written anew from the merged results.
"""

from __future__ import annotations

import json
import os
import platform
import re
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
EXECUTOR = "single_threaded"  # the node's executor parameter (--executor), set in main
#: one ROS domain for the study's processes (101: outside the tests' 20-99), discovery on this machine only
ENV = dict(os.environ, ROS_DOMAIN_ID=os.environ.get("ROS_DOMAIN_ID", "101"), ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
BINS = [0, 0.5, 1, 1.5, 2, 3, 4, 5, 7.5, 10, 15, 20, 50, 1e9]
#: the parts of the study (``--parts``), in the order they run
PARTS = ("realtime", "replay", "lockstep")
#: results.json's keys each part writes (the latency parts: the normal scheduler's and the FIFO priority's)
KEYS = {"realtime": ("realtime", "realtime_fifo"), "replay": ("replay", "replay_fifo"), "lockstep": ("lockstep",)}


def node(stats: str, params: list[str], priority: int = 0):
    cmd = PY + ["node", BUNDLE, "--stats", stats] + (["--priority", str(priority)] if priority else [])
    return subprocess.Popen(cmd + ["--ros-args", *params, "-p", f"executor:={EXECUTOR}"], cwd=ROOT, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)  # fmt: skip


def stop(proc, stats: str, samples: list | None = None) -> dict:
    """Ctrl-C to the node, then its stats (the latencies as a histogram; appended to ``samples`` if given)."""
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=60)
    if proc.returncode != 0 or not os.path.isfile(stats):
        raise RuntimeError(f"the node ended with {proc.returncode}:\n{out[-3000:]}")
    with open(stats) as f:
        s = json.load(f)
    lat = np.asarray(s.pop("latency_samples_ms"))
    if samples is not None:
        samples.extend(lat.tolist())
    s["latency_histogram_ms"] = {"bins": BINS[:-1], "counts": np.histogram(lat, BINS)[0].tolist()}
    s["log_lines"] = out.count("\n")
    return s


def pooled(runs: list[dict], samples: list) -> dict:
    """The node stats of several runs as one: counts added, latencies over all their samples."""
    from hexnewton.deploy.control_loop import percentiles_ms

    out = {k: {c: sum(r[k][c] for r in runs) for c in runs[0][k]} for k in ("counts", "received", "refused")}
    out["latency_ms"] = percentiles_ms(samples)
    out["latency_histogram_ms"] = {"bins": BINS[:-1], "counts": np.histogram(samples, BINS)[0].tolist()}
    return out


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
    """Messages sent and not received by the node, per topic; HexnewtonError where the node received more than were
    sent: another process publishes on the study's ROS domain, and the run measures it too."""
    from hexnewton.errors import HexnewtonError

    out = {k: int(sent[k] - received.get(k, 0)) for k in sent}
    extra = {k: -v for k, v in out.items() if v < 0}
    if extra:
        raise HexnewtonError(f"the node received {extra} more messages than were sent: another process publishes on "
                             f"ROS_DOMAIN_ID {ENV['ROS_DOMAIN_ID']}; set ROS_DOMAIN_ID to a free one")  # fmt: skip
    return out


def replayed_counts(line: str) -> dict:
    """The counts per topic of ``hexnewton-ros replay``'s last line (``replayed N messages: imu 5448, ...``)."""
    return {k: int(v) for k, v in re.findall(r"(\w+) (\d+)", line.split(":", 1)[-1])}


def realtime_part(args, tmp: str, priority: int) -> dict:
    """Real-time flat rounds, the node (and the robot) at ``priority`` (0: the normal scheduler)."""
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
    return rt


def replay_part(args, tmp: str, priority: int) -> dict:
    """A real-time run recorded as a bag, then replayed ``args.replays`` times, each to a fresh node (their
    latencies pooled); the node, the robot and the replay at ``priority``."""
    tag = f"_fifo{priority}" if priority else ""
    fifo = ["--priority", str(priority)] if priority else []
    bag = os.path.join(tmp, f"bag{tag}")
    stats = os.path.join(tmp, f"node_bag{tag}.json")
    n = node(stats, [], priority)
    rec = robot(["--terrain", "flat", "--rounds", str(args.bag_rounds), "--realtime", "--bag", bag, *fifo],
                os.path.join(tmp, f"bag_robot{tag}.json"))  # fmt: skip
    dropped(rec["sent"], stop(n, stats)["received"])  # (what the bag holds is the robot's alone)
    replays, samples, load = [], [], os.getloadavg()[0]
    for k in range(args.replays):
        stats = os.path.join(tmp, f"node_replay{tag}_{k}.json")
        n = node(stats, [], priority)
        load_k = os.getloadavg()[0]
        rep = subprocess.run(PY + ["replay", bag, *fifo], cwd=ROOT, env=ENV, capture_output=True, text=True,
                             timeout=3600)  # fmt: skip
        if rep.returncode != 0:
            raise RuntimeError(rep.stderr[-3000:])
        s = stop(n, stats, samples)
        line = rep.stdout.strip().splitlines()[-1]
        replays.append({"node": s, "replay": line, "dropped": dropped(replayed_counts(line), s["received"]),
                        "load_1min": [load_k, os.getloadavg()[0]]})  # fmt: skip
        print(f"replay{tag} {k + 1} of {args.replays}: node latency {s['latency_ms']}", flush=True)
    s = pooled([r["node"] for r in replays], samples)
    return {"node": s, "replays": replays, "bag_rounds": args.bag_rounds, "bag_messages": rec["bag_messages"],
            "replay": replays[0]["replay"], "priority": priority,
            "dropped": {k: sum(r["dropped"][k] for r in replays) for k in replays[0]["dropped"]},
            "load_1min": [load, os.getloadavg()[0]],
            "bag_bytes": sum(os.path.getsize(os.path.join(bag, f)) for f in os.listdir(bag))}  # fmt: skip


def lockstep_part(args, tmp: str) -> dict:
    """The in-process rounds, then the same rounds over ROS 2 in lockstep, flat and rugged."""
    out = {}
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
        out[terrain] = {"agreement": agreement(r["rounds"], ref), "node": s, "robot": r, "in_process": ref,
                        "wall_s": round(wall, 1), "dropped": dropped(r["sent"], s["received"])}  # fmt: skip
        print(f"lockstep {terrain}: {out[terrain]['agreement']}, {wall:.0f} s", flush=True)
    return out


def provenance(command: str, git: str, load0: tuple, t0: float, wall: float) -> dict:
    """What a part ran under: the command, the git revision, when (UTC), the load average (1, 5, 15 min) at its start
    and end, and its wall time."""
    return {"command": command, "git": git, "started": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t0)),
            "load_start": [round(v, 2) for v in load0], "load_end": [round(v, 2) for v in os.getloadavg()],
            "wall_s": round(wall)}  # fmt: skip


#: the files whose code a part measures: a revision with these changed is marked ``+`` (uncommitted changes)
MEASURED = ("hexnewton/deploy/ros.py", "hexnewton/deploy/control_loop.py", "hexnewton/deploy/runtime.py",
            "hexnewton/analysis/ros_robot.py", "hexnewton/apps/ros.py", "studies/ros2/measure.py")


def revision() -> str:
    """The git revision the parts run at, ``+`` where the working tree changes a file of :data:`MEASURED`."""
    from hexnewton.analysis.report import git_rev

    try:
        changed = subprocess.run(["git", "status", "--porcelain", "--", *MEASURED], cwd=ROOT, capture_output=True,
                                 text=True, check=True).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        changed = ""
    return git_rev() + ("+" if changed else "")


def run(args, tmp: str, command: str, git: str) -> tuple[dict, dict]:
    """The parts ``args.parts``: results.json's keys they write, and each key's provenance."""
    res, prov = {}, {}
    for part in PARTS:
        if part not in args.parts:
            continue
        runs = [(part, lambda: lockstep_part(args, tmp))] if part == "lockstep" else []
        if part != "lockstep":
            fn = realtime_part if part == "realtime" else replay_part
            runs = [(part, lambda fn=fn: fn(args, tmp, 0))]
            if args.priority:
                runs.append((f"{part}_fifo", lambda fn=fn: fn(args, tmp, args.priority)))
        for key, fn in runs:
            t0, w0, load0 = time.time(), time.perf_counter(), os.getloadavg()
            res[key] = fn()
            prov[key] = provenance(command, git, load0, t0, time.perf_counter() - w0)
    return res, prov


def merge(old: dict | None, new: dict, prov: dict) -> dict:
    """``new`` results over ``old`` ones (None: none): ``old``'s other results (:data:`KEYS`) stay, with their
    provenance (results written before parts kept one: the whole run's meta as theirs)."""
    out, order = {}, [k for part in PARTS for k in KEYS[part]]
    if old is not None:
        meta = old.get("meta", {})
        kept = old.get("provenance") or {}
        for key in order:
            if key in old and key not in new:
                out[key] = old[key]
                out.setdefault("provenance", {})[key] = kept.get(key) or {
                    "command": meta.get("command", "").strip("`"), "git": meta.get("git", "unknown"),
                    "load": f"{meta.get('load average at the start / end (1 min)', '?')} (1 min, the whole "
                    "run's)"}  # fmt: skip
    out.update(new)
    out.setdefault("provenance", {}).update(prov)
    out["provenance"] = {k: out["provenance"][k] for k in order if k in out["provenance"]}
    return out


def _lat(s: dict) -> str:
    lat = s["latency_ms"]
    return f"{lat['p50']:.2f} / {lat['p90']:.2f} / {lat['p99']:.2f} / {lat['p999']:.2f} / {lat['max']:.1f}"


LABELS = {"realtime": "real time, flat, normal scheduler", "replay": "bag replayed, normal scheduler",
          "realtime_fifo": "real time, flat, FIFO priority", "replay_fifo": "bag replayed, FIFO priority"}


def _runs(res: dict) -> list[tuple[str, str, dict, dict | None]]:
    """(results.json's key, name, node stats, robot results or None) of every run."""
    out = [("lockstep", f"lockstep {t}", p["node"], p["robot"]) for t, p in res.get("lockstep", {}).items()]
    for key in ("realtime", "replay", "realtime_fifo", "replay_fifo"):
        if key in res:
            out.append((key, LABELS[key], res[key]["node"], res[key].get("robot")))
    return out


def _met(ok: bool) -> str:
    return f"**{'met' if ok else 'not met'}**"


def target_lines(res: dict) -> list[str]:
    lines = []
    for terrain, part in res.get("lockstep", {}).items():
        a = part["agreement"]
        lines.append(f"- lockstep on {terrain}: {a['same_end']} of {a['rounds']} rounds end as in-process "
                     f"({100 * a['same_end_rate']:.0f} %, >= 95 %; {a['identical']} identical to the last bit): "
                     f"{_met(a['same_end_rate'] >= 0.95)}")  # fmt: skip
    for tag, label in (("", "normal scheduler"), ("_fifo", "node, robot and replay at FIFO priority")):
        if f"realtime{tag}" in res:
            rt = res[f"realtime{tag}"]
            p99m, n = rt["node"]["latency_ms"]["p99"], len(rt["robot"]["rounds"])
            lines.append(f"- real time ({label}): {rt['reached_3m']} of {n} flat rounds reach 3 m (>= 20): "
                         f"{_met(rt['reached_3m'] >= 20)}")  # fmt: skip
        if f"replay{tag}" in res:
            p99r = res[f"replay{tag}"]["node"]["latency_ms"]["p99"]
            lines.append(f"- latency p99, robot replayed from a bag ({label}): {p99r:.2f} ms (<= 5 ms): "
                         f"{_met(p99r <= 5)}")  # fmt: skip
        if f"realtime{tag}" in res:
            lines.append(f"- latency p99, the MuJoCo robot in real time on the same cores ({label}): {p99m:.2f} ms "
                         f"(<= 10 ms): {_met(p99m <= 10)}")  # fmt: skip
    return lines


def _load(p: dict) -> str:
    if "load_start" in p:
        return " / ".join(", ".join(f"{v:.1f}" for v in p[k]) for k in ("load_start", "load_end"))
    return p.get("load", "")


def report(res: dict, meta: dict) -> str:
    lines = ["# The controller bundle as a ROS 2 node, closed loop against C MuJoCo over real topics", ""]
    lines += [f"- {k}: {v}" for k, v in meta.items()]
    lines += ["", "## Runs", "", "Each part of results.json, the command that produced it (`python "
              "studies/ros2/measure.py --parts ...` reruns some and keeps the others) and the git revision it ran at "
              "(`+`: with uncommitted changes to the files it measures):", "",
              "| part | command | git | started | load average (1, 5, 15 min) at start / end | wall time [s] |",
              "|---|---|---|---|---|---|"]  # fmt: skip
    for key, p in res.get("provenance", {}).items():
        lines.append(f"| {key} | `{p['command']}` | {p['git']} | {p.get('started', '')} | {_load(p)} | "
                     f"{p.get('wall_s', '')} |")  # fmt: skip
    lines += ["", "The load averages count this study's own processes too (the node with the robot or the replay: "
              "about 1-2 of them); the rest is other work on the machine, which shares its 2 cores.", ""]  # fmt: skip
    lines += ["## Targets", ""] + target_lines(res)
    lines += ["", "## Latency: the sensor message's stamp to the targets' publish, measured by the node", "",
              "| run | substeps | p50 / p90 / p99 / p99.9 / max [ms] | policy steps on unmatched readings | "
              "re-aligned | load average (1 min) at start / end |", "|---|---|---|---|---|---|"]  # fmt: skip
    for key, name, s, _ in _runs(res):
        load = res[key].get("load_1min") if key != "lockstep" else None
        realigned = s["counts"].get("realigned_control_steps", "—")  # (a node that did not count them: —)
        lines.append(f"| {name} | {s['counts']['substeps']} | {_lat(s)} | {s['counts']['unmatched_control_steps']} "
                     f"of {s['counts']['control_steps']} | {realigned} | "
                     f"{' / '.join(f'{v:.1f}' for v in load) if load else ''} |")
    for key in ("replay", "replay_fifo"):
        if "replays" in res.get(key, {}):
            each = res[key]["replays"]
            p99 = ", ".join(f"{r['node']['latency_ms']['p99']:.2f}" for r in each)
            unmatched = ", ".join(str(r["node"]["counts"]["unmatched_control_steps"]) for r in each)
            lost = ", ".join(str(r["dropped"]["imu"]) for r in each)
            lines += ["", f"{LABELS[key][0].upper() + LABELS[key][1:]}: the row above pools {len(each)} replays of one "
                      f"bag, each to a fresh node; each replay's p99 {p99} ms, policy steps on unmatched readings "
                      f"{unmatched}, IMU messages dropped {lost}."]  # fmt: skip
    lines += ["", "A policy step on unmatched readings waited for its readings until the next IMU message (5 ms). "
              "Re-aligned: policy steps moved back onto the readings' instant after IMU messages were lost "
              "(docs/deployment.md, Rates).", "",
              "Distribution (substeps per bin; bins from the lower edge in ms):", ""]  # fmt: skip
    head = ["run"] + [f"{b:g}" for b in BINS[:-1]]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for _, name, s, _ in _runs(res):
        lines.append(f"| {name} | " + " | ".join(map(str, s["latency_histogram_ms"]["counts"])) + " |")
    lines += ["", "## Misses", "",
              "| run | messages sent | sensor messages dropped (sent - received by the node) | control periods missed "
              "(no new target within 85 % of the period) | policy steps on unmatched readings | refused |",
              "|---|---|---|---|---|---|"]  # fmt: skip
    for key, name, s, r in _runs(res):
        if r is None:
            d = res[key].get("dropped")
            if d is not None:
                lines.append(f"| {name} (the replay's) | {sum(s['received'].values()) + sum(d.values())} | "
                             f"{sum(d.values())} | | {s['counts']['unmatched_control_steps']} | "
                             f"{sum(s['refused'].values())} |")  # fmt: skip
            continue
        d = dropped(r["sent"], s["received"])
        missed = sum(row["missed_periods"] for row in r["rounds"])
        lines.append(f"| {name} | {sum(r['sent'].values())} | {sum(d.values())} | {missed} of "
                     f"{sum(row['substeps'] for row in r['rounds'])} | {s['counts']['unmatched_control_steps']} | "
                     f"{sum(s['refused'].values())} |")
    if "lockstep" in res:
        lines += ["", "## Lockstep: per round, ROS 2 / in-process", "",
                  "| terrain | round | ROS 2 end | steps | x [m] | in-process end | steps | x [m] | same end |",
                  "|---|---|---|---|---|---|---|---|---|"]  # fmt: skip
        for terrain, part in res["lockstep"].items():
            for a, b in zip(part["robot"]["rounds"], part["in_process"]):
                lines.append(f"| {terrain} | {a['round']} | {a['status']} | {a['steps']} | {a['x']:.4f} | "
                             f"{b['status']} | {b['steps']} | {b['x']:.4f} | "
                             f"{'yes' if a['status'] == b['status'] else '**no**'} |")  # fmt: skip
    for key in ("replay", "replay_fifo"):
        if key in res:
            rp = res[key]
            name, n = LABELS[key][0].upper() + LABELS[key][1:], rp.get("bag_rounds", res.get("bag_rounds", 2))
            lines += ["", f"{name}: the bag of {n} real-time rounds, {rp['bag_messages']} messages, "
                      f"{rp['bag_bytes'] / 1e6:.1f} MB (rosbag2, MCAP storage, metadata version 9); {rp['replay']}."]
    return "\n".join(lines) + "\n"


def check_priority(priority: int) -> None:
    """ValueError in one line unless this machine lets a process run at FIFO ``priority`` (0: nothing to check)."""
    if not 0 <= priority <= 99:
        raise ValueError(f"--priority must be 0 (no FIFO runs) or 1..99, got {priority}")
    if priority:
        code = f"import os; os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param({priority}))"
        if subprocess.run([sys.executable, "-c", code], capture_output=True).returncode != 0:
            raise ValueError(f"--priority {priority}: this user may not use the real-time FIFO scheduler (it needs "
                             "CAP_SYS_NICE or an rtprio limit; --priority 0: no FIFO runs)")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    from hexnewton.apps.cli import ArgumentParser, positive_int

    p = ArgumentParser(prog="studies/ros2/measure.py", description=__doc__.splitlines()[0])
    p.add_argument("--parts", nargs="+", choices=PARTS, default=list(PARTS),
                   help="run these parts (default: all); results.json in --out keeps the other results")  # fmt: skip
    p.add_argument("--rounds", type=positive_int, default=40)
    p.add_argument("--realtime_rounds", type=positive_int, default=25)
    p.add_argument("--bag_rounds", type=positive_int, default=2)
    p.add_argument("--replays", type=positive_int, default=5, help="replays of the bag, each to a fresh node")
    p.add_argument("--priority", type=int, default=50, help="also the latency runs with the node at this real-time "
                   "FIFO priority (0: not)")
    p.add_argument("--executor", choices=("single_threaded", "events"), default="single_threaded",
                   help="the node's executor parameter (default: the node's default)")
    p.add_argument("--out", default=os.path.dirname(os.path.abspath(__file__)))
    args = p.parse_args(argv)
    check_priority(args.priority)
    path = os.path.join(args.out, "results.json")
    old = None
    if os.path.isfile(path):
        try:
            with open(path) as f:
                old = json.load(f)
        except (OSError, ValueError) as exc:
            raise ValueError(f"{path}: cannot keep its other parts ({exc})") from None
    os.makedirs(args.out, exist_ok=True)
    if not os.access(args.out, os.W_OK):
        raise ValueError(f"cannot write {args.out}")
    from hexnewton.analysis.ros_robot import LOCKSTEP_NODE_PARAMETERS

    global LOCKSTEP, EXECUTOR
    EXECUTOR = args.executor
    LOCKSTEP = [w for k, v in LOCKSTEP_NODE_PARAMETERS.items() for w in ("-p", f"{k}:={v}")]
    command = "python " + " ".join([os.path.relpath(os.path.abspath(__file__), ROOT)] + list(sys.argv[1:]
                                                                                          if argv is None else argv))
    with tempfile.TemporaryDirectory() as tmp:
        new, prov = run(args, tmp, command, revision())
    import mujoco
    import rclpy  # noqa: F401

    res = merge(old, new, prov)
    res.update(bundle=BUNDLE)
    meta = {"machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, no GPU",
            "ROS 2": f"rclpy 9.1.2 (Kilted wheels), Fast DDS, the node's executor {args.executor}, loopback",
            "MuJoCo": mujoco.__version__, "parts run by the last command": ", ".join(args.parts)}  # fmt: skip
    res["meta"] = meta
    with open(path, "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report(res, meta))
    print(f"wrote {args.out}/report.md, results.json")
    return 0


if __name__ == "__main__":
    from hexnewton.apps.cli import run as run_cli

    sys.exit(run_cli(main, "studies/ros2/measure.py"))
