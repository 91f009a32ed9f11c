"""Scale-out over GPUs of one host: the throughput of ``hexnewton-bench`` under torchrun at 1, 2, 4 ... GPUs
(:func:`rate_rows`, :func:`scaling_rows`) and the time from process start to the result of ``train.py`` runs at
those GPU counts with their evaluations (:func:`run_summary`), joined into ``report.md`` and ``results.json``
(:func:`build_report`; the command line: ``python -m hexnewton.apps.scale_out``).

A bench run's rates are per rank (each rank one GPU, ``cuda:LOCAL_RANK``); the total is their sum, and the scaling
efficiency at K GPUs is ``total / (K x the 1-GPU rate)`` at the same envs per GPU. A training run's rate is its
env-steps (all ranks) over its training seconds.
"""

from __future__ import annotations

import glob
import json
import os

#: what each bench measure counts per second
UNITS = {"sim": "robot-s/s", "env": "env-steps/s", "train": "env-steps/s"}
#: the throughput scaling the issue asks for
TARGET_EFFICIENCY = 0.90


def rate_rows(sim: list, pipeline: list) -> list[dict]:
    """One row per measurement of this process (``BenchResult`` / ``PipelineResult`` objects): measure, terrain, envs
    on this rank and its rate (``UNITS``), in a fixed order so that every rank's rows line up."""
    rows = [{"measure": "sim", "terrain": r.terrain, "num_envs": r.num_envs, "rate": r.robot_s_per_s} for r in sim]
    for r in pipeline:
        for measure, rate in (("env", r.env_steps_per_s), ("train", r.train_steps_per_s)):
            if rate == rate:  # measured (NaN: that mode was not asked for)
                rows.append({"measure": measure, "terrain": r.terrain, "num_envs": r.num_envs, "rate": rate})
    return rows


def with_ranks(rows: list[dict], per_rank: list[list[float]]) -> list[dict]:
    """``rows`` (rank 0's) with every rank's rate (``per_rank[rank][row]``, :func:`~hexnewton.learning.runner.
    gather_floats`) and their sum."""
    out = []
    for k, row in enumerate(rows):
        rates = [float(ranks[k]) for ranks in per_rank]
        out.append({**{key: row[key] for key in ("measure", "terrain", "num_envs")}, "per_rank": rates,
                    "total": sum(rates)})  # fmt: skip
    return out


def scaling_rows(runs: list[dict]) -> list[dict]:
    """Rows over bench runs (each ``hexnewton-bench --json`` output with ``world_size`` and ``ranks``): per measure,
    terrain, envs per GPU and GPU count, the total and per-GPU rate and the efficiency against the 1-GPU run's rate
    at the same envs per GPU (None without one)."""
    single = {}
    for run in runs:
        if run["world_size"] == 1:
            for r in run["ranks"]:
                single[(r["measure"], r["terrain"], r["num_envs"])] = r["total"]
    rows = []
    for run in sorted(runs, key=lambda r: r["world_size"]):
        k = run["world_size"]
        for r in run["ranks"]:
            base = single.get((r["measure"], r["terrain"], r["num_envs"]))
            rows.append({"measure": r["measure"], "terrain": r["terrain"], "envs_per_gpu": r["num_envs"], "gpus": k,
                         "device_name": run.get("device_name", "?"), "total": r["total"], "per_gpu": r["total"] / k,
                         "per_rank": r["per_rank"], "efficiency": r["total"] / (k * base) if base else None})  # fmt: skip
    return sorted(rows, key=lambda r: (r["measure"], r["terrain"], r["envs_per_gpu"], r["gpus"]))


def scaling_markdown(rows: list[dict]) -> str:
    """The table of :func:`scaling_rows`, the efficiency marked against ``TARGET_EFFICIENCY``."""
    md = ("| measure | terrain | envs per GPU | GPUs | total | per GPU | slowest / fastest rank | efficiency |\n"
          "|---|---|---:|---:|---:|---:|---:|---:|\n")  # fmt: skip
    for r in rows:
        eff = _pct(r["efficiency"]) + ("" if r["efficiency"] is None or r["gpus"] == 1 or
                                       r["efficiency"] >= TARGET_EFFICIENCY else " (below 90 %)")  # fmt: skip
        spread = min(r["per_rank"]) / max(r["per_rank"]) if max(r["per_rank"]) else None
        md += (f"| {r['measure']} | {r['terrain']} | {r['envs_per_gpu']} | {r['gpus']} | {r['total']:,.0f} "
               f"{UNITS[r['measure']]} | {r['per_gpu']:,.0f} | {_pct(spread)} | {eff} |\n")  # fmt: skip
    return md


def _load(path: str) -> dict:
    with open(path) as f:
        return json.load(f)


def run_summary(run_dir: str, evals: list[str]) -> dict:
    """One ``train.py`` run (its folder: ``timing.json``, ``config.json``; ``wall.txt``: the shell's seconds from the
    launch to the exit, if written) and its evaluations (``evaluate --out`` folders, one or more terrains each): GPUs,
    envs, rates, seconds, and per terrain the result's success at 3 m and fall rate."""
    for name in ("timing.json", "config.json"):
        if not os.path.isfile(os.path.join(run_dir, name)):
            raise ValueError(f"{run_dir} holds no {name} (not a finished train.py run)")
    timing, meta = _load(os.path.join(run_dir, "timing.json")), _load(os.path.join(run_dir, "config.json"))["hexnewton"]
    k = int(timing.get("world_size", meta.get("world_size", 1)))
    envs = int(timing.get("num_envs_per_rank", meta["config"]["sim"]["num_envs"]))
    shell = os.path.join(run_dir, "wall.txt")
    terrains = {}
    for d in evals:
        for terrain, by_ctrl in _load(os.path.join(d, "results.json"))["results"].items():
            s = by_ctrl.get("cpg_rl") or next(iter(by_ctrl.values()))
            terrains[terrain] = {"rounds": s["rounds"], "success_3m": s["success_3m"], "fall_rate": s["fall_rate"]}
    scaled = list(meta.get("agent", {}).get("scale_with_ranks", ()))
    return {"gpus": k, "device_name": timing.get("device_name", meta["config"]["sim"]["device"]), "envs_per_gpu": envs,
            "total_envs": k * envs, "scale_with_ranks": scaled, "iterations": timing["iterations"],
            "env_steps": timing["env_steps"],
            "train_s": timing["train_s"], "env_steps_per_s": timing["env_steps"] / timing["train_s"],
            "first_iteration_s": timing["first_iteration_s"], "wall_s_to_result": timing["wall_s_to_result"],
            "shell_wall_s": float(open(shell).read().split()[0]) if os.path.isfile(shell) else None,
            "process_start": timing.get("process_start"), "result": os.path.basename(timing.get("result") or ""),
            "terrains": terrains}  # fmt: skip


def with_training_efficiency(runs: dict[str, dict]) -> dict[str, dict]:
    """Each run's training efficiency, its env-steps/s over K x the 1-GPU run's at the same envs per GPU, and its
    speed-up, the 1-GPU run's seconds from process start to the result over its own (against the 1-GPU run of the
    same total envs, else of the same envs per GPU); None without such a run."""
    single = {r["envs_per_gpu"]: r for r in runs.values() if r["gpus"] == 1}
    for r in runs.values():
        base = single.get(r["envs_per_gpu"])
        r["efficiency"] = r["env_steps_per_s"] / (r["gpus"] * base["env_steps_per_s"]) if base else None
        base = single.get(r["total_envs"]) or base
        r["speedup"] = base["wall_s_to_result"] / r["wall_s_to_result"] if base else None
    for name, r in runs.items():  # the runs whose time from process start to result overlapped this one's
        t0 = r["process_start"]
        r["beside"] = sorted(n for n, o in runs.items() if n != name and None not in (t0, o["process_start"]) and
                             o["process_start"] < t0 + r["wall_s_to_result"] and t0 < o["process_start"] +
                             o["wall_s_to_result"])  # fmt: skip
    return runs


def _pct(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.1f} %"


def runs_markdown(runs: dict[str, dict]) -> str:
    """One row per training run: GPUs, envs, training rate and efficiency, seconds to the result, per terrain."""
    terrains = list(dict.fromkeys(t for r in runs.values() for t in r["terrains"]))
    md = ("| run | device | GPUs | envs per GPU | total envs | scaled with ranks | iterations | env-steps/s "
          "(training) | efficiency | first iteration [s] | training [s] | process start to result [s] | speed-up | ran beside | "
          + " | ".join(f"{t} 3 m / falls" for t in terrains) + " |\n|---|---|" + "---:|" * 3 + "---|" + "---:|" * 7
          + "---|" + "---:|" * len(terrains) + "\n")
    for name, r in sorted(runs.items(), key=lambda kv: (kv[1]["total_envs"], kv[1]["gpus"])):
        cells = [f"{_pct(r['terrains'][t]['success_3m'])} / {_pct(r['terrains'][t]['fall_rate'])}"
                 if t in r["terrains"] else "—" for t in terrains]  # fmt: skip
        speedup = "—" if r["speedup"] is None else f"{r['speedup']:.2f}x"
        md += (f"| {name} | {r['device_name']} | {r['gpus']} | {r['envs_per_gpu']} | {r['total_envs']} | "
               f"{' '.join(r['scale_with_ranks']) or 'no'} | {r['iterations']} | "
               f"{r['env_steps_per_s']:,.0f} | {_pct(r['efficiency'])} | "
               f"{r['first_iteration_s']:.1f} | {r['train_s']:.1f} | {r['wall_s_to_result']:.1f} | {speedup} | "
               f"{', '.join(r['beside']) or 'alone'} | "
               + " | ".join(cells) + " |\n")  # fmt: skip
    return md


def by_gpu_count(rows: list[dict], runs: dict[str, dict]) -> dict[int, dict]:
    """Per GPU count: the devices, each bench measure's rate and efficiency per envs per GPU, and the runs' rate,
    efficiency, seconds to the result and per-terrain success and falls."""
    out: dict[int, dict] = {}
    for r in rows:
        k = out.setdefault(r["gpus"], {"devices": [], "bench": {}, "runs": {}})
        k["devices"] = sorted(set(k["devices"]) | {r["device_name"]})
        k["bench"].setdefault(r["measure"], {})[r["envs_per_gpu"]] = {
            "total": r["total"], "per_gpu": r["per_gpu"], "efficiency": r["efficiency"]}  # fmt: skip
    keys = ("envs_per_gpu", "total_envs", "scale_with_ranks", "env_steps_per_s", "efficiency", "wall_s_to_result",
            "speedup", "terrains")
    for name, r in runs.items():
        k = out.setdefault(r["gpus"], {"devices": [], "bench": {}, "runs": {}})
        k["devices"] = sorted(set(k["devices"]) | {r["device_name"]})
        k["runs"][name] = {key: r[key] for key in keys}
    return dict(sorted(out.items()))


def collect(folders: list[str]) -> tuple[list[dict], dict[str, dict]]:
    """Scale-out leases' outputs (``scripts/device/scale_out.sh pack``), joined: ``bench_*.json`` (bench runs),
    ``runs/<name>/`` (train.py runs) and ``evals/<name>_<terrain>/`` (their evaluations)."""
    benches, runs = [], {}
    for folder in folders:
        for p in sorted(glob.glob(os.path.join(folder, "bench_*.json"))):
            b = _load(p)
            if "ranks" not in b or "world_size" not in b:
                raise ValueError(f"{p} has no per-rank rates: not written by hexnewton-bench --json")
            benches.append(b)
        for run_dir in sorted(glob.glob(os.path.join(folder, "runs", "*", ""))):
            name = os.path.basename(os.path.dirname(run_dir))
            if name in runs:
                raise ValueError(f"two runs named {name} in {', '.join(folders)}")
            evals = glob.glob(os.path.join(folder, "evals", f"{name}_*", "results.json"))
            runs[name] = run_summary(run_dir, [os.path.dirname(p) for p in sorted(evals)])
    if not benches and not runs:
        raise ValueError(f"{', '.join(folders)} hold no bench_*.json and no runs/*/: nothing to report")
    return benches, with_training_efficiency(runs)


def build_report(folders: list[str], out: str, commands: list[str]) -> dict:
    """``out/report.md`` and ``out/results.json`` from scale-out leases' ``folders`` (:func:`collect`); ``commands``:
    the calls that made them, quoted in the report. Returns results.json's content."""
    benches, runs = collect(folders)
    rows = scaling_rows(benches)
    devices = sorted({b.get("device_name", "?") for b in benches} | {r["device_name"] for r in runs.values()})
    results = {"devices": devices, "target_efficiency": TARGET_EFFICIENCY, "by_gpus": by_gpu_count(rows, runs),
               "bench": rows, "runs": runs,
               "bench_commands": sorted({b.get("command", "?") for b in benches}), "commands": commands}  # fmt: skip
    md = [f"# Scale-out on one host: {', '.join(devices)}", "", "Made by `python -m hexnewton.apps.scale_out "
          f"{' '.join(folders)} --out {out}` from the outputs of these calls (`scripts/device/scale_out.sh`):", "",
          "```bash",
          *commands, "```", ""]  # fmt: skip
    if rows:
        md += ["## Throughput (`hexnewton-bench` under torchrun, each rank one GPU)", "",
               "Total: the sum of the ranks' rates, timed together (a barrier before each timed window). Efficiency: "
               "the total over (GPUs x the 1-GPU rate at the same envs per GPU); the target is 90 %.", "",
               *[f"`{c}`" for c in results["bench_commands"]], "", scaling_markdown(rows)]  # fmt: skip
    if runs:
        md += ["## Time to the result (`train.py` under torchrun, then the result's test rounds per terrain)", "",
               "Process start to result: rank 0's `timing.json` (`wall_s_to_result`: from its process start through "
               "training, deterministic validation (`timing.json`'s `validation.ranks`: the ranks that shared it) and "
               "the ONNX export; `shell_wall_s` in results.json: the shell's seconds from the launch, torchrun's own "
               "start included). Speed-up: the 1-GPU run's seconds "
               "over the run's (same total envs, else same envs per GPU). Success at 3 m and falls: the "
               "result's deterministic action on unseen rounds (`python -m hexnewton.apps.evaluate`). Efficiency: "
               "training env-steps/s over (GPUs x the 1-GPU run's at the same envs per GPU). Ran beside: the runs whose "
               "process start to result overlapped (on other GPUs of the host).", "",
               runs_markdown(runs)]  # fmt: skip
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(out, "report.md"), "w") as f:
        f.write("\n".join(md))
    return results
