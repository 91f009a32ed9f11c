"""Training against the physics with one learner switch off and on, in turn on one GPU: each A/B of :data:`ABS` from
what ``flag_ab.sh`` left in each lease's folder ``NAME/raw/DATE/`` (``off_N.json``, ``on_N.json``: ``bench --json``;
``gpu.txt``, ``revision.txt``; a call that did not finish leaves only its ``.log``).

    python studies/throughput/flag_ab.py [NAME ...]    # NAME/raw/ -> NAME/report.md, results.json (default: every A/B)
    python studies/throughput/flag_ab.py --bench NAME  # the bench's arguments for off and on (flag_ab.sh reads them)

Each call runs the complex task's physics alone and its training loop (``bench --task complex --mode sim ... train``)
at 4096 and 16384 envs, alone on the GPU, in the order off, on, off, on. A switch is compared with its off state of
the same lease: training env-steps per second, training as a share of the physics alone measured in the same call and,
where the A/B profiles (``--profile``: a device sync around each phase), the iteration's phases.
"""

from __future__ import annotations

import glob
import json
import math
import os
import statistics
import sys

STUDY = os.path.dirname(os.path.abspath(__file__))
MODES = ("off", "on")
#: the A/Bs: name (its folder) -> the switch (an AgentConfig flag), what is compared, what off and on mean, the bench's
#: modes and whether the calls profile the iteration's phases
ABS = {
    "episode_log": dict(flag="agent.deferred_episode_log", title="rsl-rl's per-step episode bookkeeping against the "
                        "deferred one", off="three host reads per env step", on="the default, one read per iteration",
                        modes="sim env train", profile=False),
    "tf32": dict(flag="agent.tf32", title="the networks' float32 matrix products in full float32 against TF32 tensor "
                 "cores", off="the default, full float32", on="TF32 (`torch.set_float32_matmul_precision(\"high\")`)",
                 modes="sim train", profile=True),
}  # fmt: skip


def bench_args(name: str, mode: str) -> str:
    """The bench's arguments of A/B ``name`` in ``mode`` (off, on), without --json and --append."""
    ab = ABS[name]
    profile = " --profile" if ab["profile"] else ""
    return (f"--task complex --num_envs 4096 16384 --mode {ab['modes']}{profile} --{ab['flag']} "
            f"{'true' if mode == 'on' else 'false'}")  # fmt: skip


def load_lease(folder: str) -> dict:
    """One lease: per mode, the calls that finished (in their order), each with per env count the physics alone
    (robot-s/s), the env step (where measured) and training (env-steps/s), training / physics, the iteration's seconds
    and, where profiled, its phases [s]; the calls that left only a log (``unfinished``)."""
    calls: dict = {m: [] for m in MODES}
    unfinished = []
    # a call's json without its log is a finished call whose console left the tree: a call that left only
    # its log (unfinished) is told by the logs alone (``logs_missing``)
    names = {os.path.basename(p)[:-4] for p in glob.glob(os.path.join(folder, "*.log"))} | {
        os.path.basename(p)[:-5] for p in glob.glob(os.path.join(folder, "*.json"))}
    for name in sorted(names):
        log = os.path.join(folder, name + ".log")
        mode = name.split("_")[0]
        if mode not in MODES:
            raise ValueError(f"{log}: not off_N.log or on_N.log")
        path = os.path.join(folder, name + ".json")
        if not os.path.exists(path):
            unfinished.append(name)
            continue
        with open(path) as f:
            d = json.load(f)
        sim = {r["num_envs"]: r["robot_s_per_s"] for r in d["sim"]}
        rows = {}
        phases = {str(p["num_envs"]): {k: round(v, 5) for k, v in p.items() if k not in ("terrain", "num_envs")}
                  for p in d.get("profile") or []}  # fmt: skip
        for p in d["pipeline"]:
            n = p["num_envs"]
            env = p.get("env_steps_per_s")  # nan where the call did not time the env step
            rows[str(n)] = {"sim_robot_s_per_s": round(sim[n]),
                            "env_steps_per_s": round(env) if env is not None and math.isfinite(env) else None,
                            "train_steps_per_s": round(p["train_steps_per_s"]),
                            "train_over_sim": round(p["train_robot_s_per_s"] / sim[n], 4),
                            "iteration_s": round(p["train_iteration_s"], 3)}  # fmt: skip
            if str(n) in phases:
                rows[str(n)]["phases_s"] = phases[str(n)]
        calls[mode].append({"call": name, "device": d["device_name"], "rows": rows})
    with open(os.path.join(folder, "gpu.txt")) as f:
        gpu = f.read().strip()
    revision = None
    if os.path.exists(os.path.join(folder, "revision.txt")):
        with open(os.path.join(folder, "revision.txt")) as f:
            revision = f.read().strip()
    return {"lease": os.path.basename(folder), "gpu": gpu, "revision": revision, "calls": calls,
            "unfinished": unfinished, "effect": effect(calls)}  # fmt: skip


def effect(calls: dict) -> dict:
    """Per env count: each mode's mean training env-steps/s, training / physics and (where profiled) phases over its
    calls, and the switch's change on against off (None where a mode has no call)."""
    out = {}
    envs = sorted({n for m in MODES for c in calls[m] for n in c["rows"]}, key=int)
    for n in envs:
        per = {}
        for m in MODES:
            rows = [c["rows"][n] for c in calls[m] if n in c["rows"]]
            per[m] = {"calls": len(rows),
                      "train_steps_per_s": round(statistics.mean(r["train_steps_per_s"] for r in rows)) if rows else None,
                      "train_over_sim": round(statistics.mean(r["train_over_sim"] for r in rows), 4) if rows else None,
                      "spread": round(max(r["train_steps_per_s"] for r in rows) / min(r["train_steps_per_s"] for r in rows)
                                      - 1, 4) if rows else None}  # fmt: skip
            profiled = [r["phases_s"] for r in rows if "phases_s" in r]
            if profiled:
                per[m]["phases_s"] = {k: round(statistics.mean(p[k] for p in profiled), 5) for k in profiled[0]}
        both = all(per[m]["calls"] for m in MODES)
        per["change"] = round(per["on"]["train_steps_per_s"] / per["off"]["train_steps_per_s"] - 1, 4) if both else None
        out[n] = per
    return out


def _chosen(validation: dict) -> dict | None:
    """The candidate train.py's validation chose (timing.json's ``validation``), its file and shares; None without."""
    chosen = validation.get("chosen")
    cand = next((c for c in validation.get("candidates", []) if c.get("path") == chosen), None)
    if cand is None:
        return None
    return {"file": os.path.basename(chosen), "goal": round(cand["goal"], 4),
            "fell_before_goal": round(cand["fell_before_goal"], 4)}


def load_command(folder: str) -> dict:
    """One pair of the task's command, off and on, one after the other on one GPU (``NAME/command/DATE/MODE/``:
    ``command.txt``, the command as run; its run's ``timing.json`` and ``config.json``; train.py's console
    ``train.log``): per mode the seconds from process start to the result, to the first iteration, of training and of
    validation, and the candidate validation chose (timing.json's ``validation``)."""
    modes = {}
    for m in MODES:
        with open(os.path.join(folder, m, "timing.json")) as f:
            t = json.load(f)
        with open(os.path.join(folder, m, "command.txt")) as f:
            command = f.read().strip()
        modes[m] = {"command": command, "device": t["device_name"], "iterations": t["iterations"],
                    "wall_s_to_result": round(t["wall_s_to_result"], 1),
                    "first_iteration_s": round(t["first_iteration_s"], 1), "train_s": round(t["train_s"], 1),
                    "validation_s": round(t["validation"]["seconds"], 1), "chosen": _chosen(t["validation"])}
    return {"date": os.path.basename(folder), "modes": modes}


def logs_missing(name: str) -> str:
    """'' when every call of A/B ``name`` (``NAME/raw/DATE/MODE_N.json``) has its console log beside it; else the first
    log missing. Without the logs a call that never wrote its json (the lease's ``unfinished``) cannot be told."""
    for path in sorted(glob.glob(os.path.join(STUDY, name, "raw", "*", "*.json"))):
        if not os.path.isfile(path[:-5] + ".log"):
            return os.path.relpath(path[:-5] + ".log", STUDY)
    return ""


def load(name: str) -> dict:
    raw = os.path.join(STUDY, name, "raw")
    folders = sorted(d for d in glob.glob(os.path.join(raw, "*")) if os.path.isdir(d))
    if not folders:
        raise FileNotFoundError(f"no lease folders in {raw}")
    commands = sorted(d for d in glob.glob(os.path.join(STUDY, name, "command", "*")) if os.path.isdir(d))
    return {"ab": name, **ABS[name], "leases": [load_lease(d) for d in folders],
            "commands": [load_command(d) for d in commands]}


def _k(v: float | None) -> str:
    return "-" if v is None else f"{v:,.0f}"


def _pct(v: float | None, sign: bool = False) -> str:
    return "-" if v is None else (f"{100 * v:+.1f} %" if sign else f"{100 * v:.0f} %")


def _phases(lease: dict) -> list[str]:
    """The profiled phases per mode and env count, in ms per iteration (each timed with a sync around it)."""
    rows = [(n, m, e[m]["phases_s"]) for n, e in lease["effect"].items() for m in MODES if "phases_s" in e[m]]
    if not rows:
        return []
    names = list(rows[0][2])
    lines = ["", "Phases of an iteration (`--profile`: a device sync around each, so they add up to more than an "
             "unprofiled iteration), ms, the mean over the mode's calls:", "",
             "| envs | mode | " + " | ".join(names) + " |", "|---:|---|" + "---:|" * len(names)]  # fmt: skip
    for n, m, ph in rows:
        lines.append(f"| {n} | {m} | " + " | ".join(f"{1e3 * ph[k]:.1f}" for k in names) + " |")
    return lines


def render(res: dict) -> str:
    name = res["ab"]
    command = "python -m hexnewton.apps.bench {args} --json DIR/{mode}_N.json"
    lines = [f"# Training against the physics: {res['title']}", "",
             f"`python studies/throughput/flag_ab.py {name}` writes this report and results.json from {name}/raw/ (a "
             "folder per lease; `AB=" + name + " bash studies/device/gpu.sh queue studies/throughput/flag_ab.sh` makes "
             "one). Each call, alone on the GPU, in the order off, on, off, on:", "",
             "```bash", command.format(args=bench_args(name, "off"), mode="off") + f"   # off: {res['off']}",
             command.format(args=bench_args(name, "on"), mode="on") + f"    # on: {res['on']}", "```", ""]  # fmt: skip
    for lease in res["leases"]:
        lines += [f"## {lease['lease']}: {lease['gpu']} (code {lease['revision'] or 'unknown'})", ""]
        if lease["unfinished"]:
            lines += [f"**Partial**: {', '.join(lease['unfinished'])} did not finish (the call was stopped before it wrote its results); the "
                      "means below are over the calls that did.", ""]  # fmt: skip
        lines += ["| call | envs | physics alone [robot-s/s] | env step [env-steps/s] | training [env-steps/s] | "
                  "training / physics | s per iteration |", "|---|---:|---:|---:|---:|---:|---:|"]  # fmt: skip
        order = sorted((c for m in MODES for c in lease["calls"][m]), key=lambda c: (c["call"][-1], c["call"]))
        for c in order:
            for n, r in c["rows"].items():
                lines.append(f"| {c['call']} | {n} | {_k(r['sim_robot_s_per_s'])} | {_k(r['env_steps_per_s'])} | "
                             f"{_k(r['train_steps_per_s'])} | {_pct(r['train_over_sim'])} | {r['iteration_s']:.2f} |")
        lines += ["", "| envs | training off [env-steps/s] (calls, spread) | training on | change | training / physics "
                  "off / on |", "|---:|---:|---:|---:|---|"]  # fmt: skip
        for n, e in lease["effect"].items():
            off, on = e["off"], e["on"]
            lines.append(f"| {n} | {_k(off['train_steps_per_s'])} ({off['calls']}, {_pct(off['spread'], True)}) | "
                         f"{_k(on['train_steps_per_s'])} ({on['calls']}, {_pct(on['spread'], True)}) | "
                         f"**{_pct(e['change'], True)}** | {_pct(off['train_over_sim'])} / "
                         f"{_pct(on['train_over_sim'])} |")
        lines += _phases(lease)
        lines.append("")
    return "\n".join(lines + _commands(res))


def _commands(res: dict) -> list[str]:
    """The task's training command off and on, one after the other on one GPU (``command/DATE/``)."""
    if not res.get("commands"):
        return []
    lines = ["## The complex command, off and on", "",
             "The task's training command with the switch off and on, one after the other, each alone on the GPU "
             f"(`studies/device/learner.sh`, its gate's runs; {res['ab']}/command/DATE/MODE/: the command, the "
             "console, timing.json, config.json). One seed: how long the command takes, not what it learns (the "
             "learner study's gate judges that). The validation's share of goals is averaged over the rugged, stepped "
             "and complex courses, 256 rounds each (seed 3000):", "",
             "| date | command | device | from process start [s] | first iteration [s] | training [s] (iterations) "
             "| validation [s] | chosen: goal, fell before it |", "|---|---|---|---:|---:|---:|---:|---|"]
    for c in res["commands"]:
        for m, r in c["modes"].items():
            ch = r["chosen"]
            lines.append(f"| {c['date']} | `{r['command'].split('#')[0].strip()}` | {r['device']} | "
                         f"{r['wall_s_to_result']:.1f} | "
                         f"{r['first_iteration_s']:.1f} | {r['train_s']:.1f} ({r['iterations']}) | "
                         f"{r['validation_s']:.1f} | " + ("-" if ch is None else f"{ch['file']}: "
                         f"{100 * ch['goal']:.1f} %, {100 * ch['fell_before_goal']:.1f} %") + " |")
    return lines + [""]


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*",
                    help=f"A/Bs to render (default: every one with a raw/ folder): {', '.join(ABS)}")
    ap.add_argument("--bench", metavar="NAME", help="print the bench's arguments of NAME, off then on (two lines)")
    args = ap.parse_args()
    try:
        for name in ([args.bench] if args.bench else args.names):
            if name not in ABS:
                raise ValueError(f"no A/B named {name!r}: {', '.join(ABS)}")
        if args.bench:
            print(bench_args(args.bench, "off"), bench_args(args.bench, "on"), sep="\n")
            return
        names = args.names or [n for n in ABS if os.path.isdir(os.path.join(STUDY, n, "raw"))]
        for name in names:
            missing = logs_missing(name)
            if missing:
                raise FileNotFoundError(
                    f"the raw calls' console logs are not in the tree ({missing}, not tracked): restore them "
                    f"with `git restore --source df27913 --worktree -- studies/throughput/{name}/raw` (its "
                    "results.json and report.md stay as committed)")
            res = load(name)
            with open(os.path.join(STUDY, name, "results.json"), "w") as f:
                json.dump(res, f, indent=1)
            with open(os.path.join(STUDY, name, "report.md"), "w") as f:
                f.write(render(res))
            for lease in res["leases"]:
                for n, e in lease["effect"].items():
                    print(f"{name} {lease['lease']} {n} envs: training {_pct(e['change'], True)} on against off")
    except (FileNotFoundError, ValueError, KeyError) as exc:
        sys.exit(f"flag_ab.py: {exc}")


if __name__ == "__main__":
    main()
