"""Scale-out report: throughput and time to the result at 1, 2, 4 ... GPUs of one host, from a lease's outputs.

    python studies/scale_out/scale_out.py LEASE [LEASE ...] --out DIR

LEASE (one or more, joined: e.g. the benches of one lease and the runs of another) is what
``bash studies/device/scale_out.sh pack`` brings back, unpacked: ``bench_<K>gpu.json`` (``hexnewton-bench --json``
under torchrun at K GPUs), ``runs/<name>/`` (a ``train.py`` run's ``timing.json`` and ``config.json``, its
console log and ``wall.txt``), ``evals/<name>_<terrain>/`` (``python -m hexnewton.apps.evaluate --out`` of the run's
result) and ``commands.txt`` (the calls, quoted in the report). Writes ``report.md`` and ``results.json``:
per GPU count the device, envs per GPU, env-steps/s, the scaling efficiency (``hexnewton.analysis.scaling``), the seconds from process start to the result and, per terrain, the result's success at 3 m and fall rate.
"""

from __future__ import annotations

import glob
import json
import os
import sys

from hexnewton.analysis.scaling import TARGET_EFFICIENCY, percent, scaling_markdown, scaling_rows
from hexnewton.apps.cli import ArgumentParser, check_new_dir, run


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


def runs_markdown(runs: dict[str, dict]) -> str:
    """One row per training run: GPUs, envs, training rate and efficiency, seconds to the result, per terrain."""
    terrains = list(dict.fromkeys(t for r in runs.values() for t in r["terrains"]))
    md = ("| run | device | GPUs | envs per GPU | total envs | scaled with ranks | iterations | env-steps/s "
          "(training) | efficiency | first iteration [s] | training [s] | process start to result [s] | speed-up | ran beside | "
          + " | ".join(f"{t} 3 m / falls" for t in terrains) + " |\n|---|---|" + "---:|" * 3 + "---|" + "---:|" * 7
          + "---|" + "---:|" * len(terrains) + "\n")
    for name, r in sorted(runs.items(), key=lambda kv: (kv[1]["total_envs"], kv[1]["gpus"])):
        cells = [f"{percent(r['terrains'][t]['success_3m'])} / {percent(r['terrains'][t]['fall_rate'])}"
                 if t in r["terrains"] else "—" for t in terrains]  # fmt: skip
        speedup = "—" if r["speedup"] is None else f"{r['speedup']:.2f}x"
        md += (f"| {name} | {r['device_name']} | {r['gpus']} | {r['envs_per_gpu']} | {r['total_envs']} | "
               f"{' '.join(r['scale_with_ranks']) or 'no'} | {r['iterations']} | "
               f"{r['env_steps_per_s']:,.0f} | {percent(r['efficiency'])} | "
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
    """Scale-out leases' outputs (``studies/device/scale_out.sh pack``), joined: ``bench_*.json`` (bench runs),
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
    md = [f"# Scale-out on one host: {', '.join(devices)}", "", "Made by `python studies/scale_out/scale_out.py "
          f"{' '.join(folders)} --out {out}` from the outputs of these calls (`studies/device/scale_out.sh`):", "",
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



def parser() -> ArgumentParser:
    """The command line of ``python studies/scale_out/scale_out.py``."""
    p = ArgumentParser(prog="python studies/scale_out/scale_out.py", description=__doc__.split("\n")[0])
    p.add_argument("lease", nargs="+", help="the unpacked outputs of studies/device/scale_out.sh pack (one or more "
                   "folders, joined)")
    p.add_argument("--out", required=True, help="the folder for report.md and results.json: a new one, or one that "
                   "holds neither (e.g. the folder of the leases' outputs); nothing is overwritten")
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    for folder in args.lease:
        if not os.path.isdir(folder):
            raise ValueError(f"{folder} is not a folder")
    check_new_dir(args.out, files=("report.md", "results.json"))
    commands = []
    for folder in args.lease:
        path = os.path.join(folder, "commands.txt")
        commands += open(path).read().splitlines() if os.path.isfile(path) else []
    results = build_report(args.lease, args.out, commands)
    print(f"{len(results['bench'])} throughput rows, {len(results['runs'])} runs -> {args.out}/ (report.md, "
          "results.json)")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python studies/scale_out/scale_out.py"))
