"""Training against the physics with rsl-rl's per-step episode bookkeeping (``off``: three host reads a step) and with
the deferred one (``on``: ``--agent.deferred_episode_log``, the default), from what ``episode_log_ab.sh`` left in each
lease's folder ``episode_log/raw/DATE/`` (``off_N.json``, ``on_N.json``: ``bench --json``; ``gpu.txt``,
``revision.txt``; a call that did not finish leaves only its ``.log``).

    python studies/throughput/episode_log.py     # episode_log/raw/ -> episode_log/report.md, results.json

Each call runs the complex task's physics alone, its env step and its training loop (``bench --task complex --mode sim
env train``) at 4096 and 16384 envs, alone on the GPU. The deferred bookkeeping is compared with the per-step one of
the same lease: training env-steps per second, and training as a share of the physics alone measured in the same call.
"""

from __future__ import annotations

import glob
import json
import os
import statistics
import sys

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "episode_log")
MODES = ("off", "on")
COMMAND = ("python -m hexnewton.apps.bench --task complex --num_envs 4096 16384 --mode sim env train "
           "--agent.deferred_episode_log {flag} --json DIR/{mode}_N.json")  # fmt: skip


def load_lease(folder: str) -> dict:
    """One lease: per mode, the calls that finished (in their order), each with per env count the physics alone
    (robot-s/s), the env step and training (env-steps/s), training / physics and the iteration's seconds; the calls
    that left only a log (``unfinished``)."""
    calls: dict = {m: [] for m in MODES}
    unfinished = []
    for log in sorted(glob.glob(os.path.join(folder, "*.log"))):
        name = os.path.basename(log)[:-4]
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
        for p in d["pipeline"]:
            n = p["num_envs"]
            rows[str(n)] = {"sim_robot_s_per_s": round(sim[n]), "env_steps_per_s": round(p["env_steps_per_s"]),
                            "train_steps_per_s": round(p["train_steps_per_s"]),
                            "train_over_sim": round(p["train_robot_s_per_s"] / sim[n], 4),
                            "iteration_s": round(p["train_iteration_s"], 3)}  # fmt: skip
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
    """Per env count: each mode's mean training env-steps/s and training / physics over its calls, and the deferred
    bookkeeping's change against the per-step one (None where a mode has no call)."""
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
        both = all(per[m]["calls"] for m in MODES)
        per["change"] = round(per["on"]["train_steps_per_s"] / per["off"]["train_steps_per_s"] - 1, 4) if both else None
        out[n] = per
    return out


def load(raw: str = os.path.join(HERE, "raw")) -> dict:
    folders = sorted(d for d in glob.glob(os.path.join(raw, "*")) if os.path.isdir(d))
    if not folders:
        raise FileNotFoundError(f"no lease folders in {raw}")
    return {"leases": [load_lease(d) for d in folders]}


def _k(v: float | None) -> str:
    return "-" if v is None else f"{v:,.0f}"


def _pct(v: float | None, sign: bool = False) -> str:
    return "-" if v is None else (f"{100 * v:+.1f} %" if sign else f"{100 * v:.0f} %")


def render(res: dict) -> str:
    lines = ["# Training against the physics: rsl-rl's per-step episode bookkeeping against the deferred one", "",
             "`python studies/throughput/episode_log.py` writes this report and results.json from episode_log/raw/ "
             "(a folder per lease). Each call, alone on the GPU, in the order off, on, off, on:", "",
             "```bash", COMMAND.format(flag="false", mode="off") + "   # off: three host reads per env step",
             COMMAND.format(flag="true", mode="on") + "    # on: the default, one read per iteration", "```", ""]
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
                         f"**{_pct(e['change'], True)}** | {_pct(off['train_over_sim'])} / {_pct(on['train_over_sim'])} |")
        lines.append("")
    return "\n".join(lines)


def main() -> None:
    try:
        res = load()
    except (FileNotFoundError, ValueError, KeyError) as exc:
        sys.exit(f"episode_log.py: {exc}")
    with open(os.path.join(HERE, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(HERE, "report.md"), "w") as f:
        f.write(render(res))
    for lease in res["leases"]:
        for n, e in lease["effect"].items():
            print(f"{lease['lease']} {n} envs: training {_pct(e['change'], True)} with the deferred bookkeeping")


if __name__ == "__main__":
    main()
