"""The methods compared at equal budgets: Fig. 5a over seeds and Table 3 over seeds, one report.

    python -m hexnewton.apps.compare --runs RUNS --evals EVALS --out results/methods_complex

``--runs`` holds one experiment folder per training run, named ``<method>_s<seed>`` (``cpg_rl``, ``joint`` from
``train.py``; ``sac_cpg``, ``td3_cpg``, ``a2c_cpg`` from ``python -m hexnewton.apps.baselines``), each with its run folder
(``train.py --experiment`` / ``--log_dir``). ``--evals`` holds one ``hexnewton.apps.evaluate`` output folder per run and
terrain, named ``<method>_s<seed>_<terrain>``. ``scripts/device/gpu.sh methods`` and ``gpu.sh evals`` lay them out
so. Writes to ``--out``: ``report.md`` (the budget each run used: env-steps and wall time; Table 3 as the mean and
range over seeds of the success at each distance and the falls; Fig. 5a), ``results.json`` (every number),
``fig5a.png`` with its ``.csv`` (:func:`hexnewton.analysis.curves.plot_fig5a`).
"""

from __future__ import annotations

import glob
import json
import os
import re
import sys

from hexnewton.apps.cli import ArgumentParser, run

METHODS = ("cpg_rl", "sac_cpg", "td3_cpg", "a2c_cpg", "joint")
_RUN = re.compile(r"^(?P<method>[a-z0-9_]+)_s(?P<seed>\d+)$")
_EVAL = re.compile(r"^(?P<method>[a-z0-9_]+)_s(?P<seed>\d+)_(?P<terrain>[a-z]+)$")


def find_runs(runs_dir: str) -> dict[str, dict[int, str]]:
    """{method: {seed: run folder}}: the newest run folder of each ``<method>_s<seed>`` experiment."""
    out: dict[str, dict[int, str]] = {}
    for exp in sorted(glob.glob(os.path.join(runs_dir, "*"))):
        m = _RUN.match(os.path.basename(exp))
        runs = sorted(d for d in glob.glob(os.path.join(exp, "*")) if os.path.isdir(d))
        if m and m["method"] in METHODS and runs:
            out.setdefault(m["method"], {})[int(m["seed"])] = runs[-1]
    if not out:
        raise ValueError(f"no <method>_s<seed> runs under {runs_dir} (methods: {', '.join(METHODS)})")
    return {k: out[k] for k in METHODS if k in out}


def run_budget(run_dir: str) -> dict:
    """The env-steps and wall time [min] a run trained for: a skrl run's last ``Perf/wall_time_s`` (its loop's time);
    an rsl-rl run's time from its first to its last iteration's event plus the first iteration's collection and
    learning time."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from hexnewton.analysis.curves import read_curve

    steps = read_curve(run_dir, "env_steps").get("Episode/success_rate") or []
    acc = EventAccumulator(run_dir, size_guidance={"scalars": 0})
    acc.Reload()
    tags = set(acc.Tags().get("scalars", []))
    wall = 0.0
    if "Perf/wall_time_s" in tags:
        wall = acc.Scalars("Perf/wall_time_s")[-1].value
    elif {"Perf/collection_time", "Perf/learning_time"} <= tags:
        collect, learn = acc.Scalars("Perf/collection_time"), acc.Scalars("Perf/learning_time")
        wall = collect[-1].wall_time - collect[0].wall_time + collect[0].value + learn[0].value
    return {"env_steps": int(steps[-1][0]) if steps else 0, "wall_min": round(wall / 60.0, 3)}


def find_evals(evals_dir: str) -> dict[str, dict[str, dict[int, dict]]]:
    """{terrain: {method: {seed: that evaluation's summary}}} from ``<method>_s<seed>_<terrain>/results.json``."""
    out: dict[str, dict[str, dict[int, dict]]] = {}
    for path in sorted(glob.glob(os.path.join(evals_dir, "*", "results.json"))):
        m = _EVAL.match(os.path.basename(os.path.dirname(path)))
        if not m or m["method"] not in METHODS:
            continue
        with open(path) as f:
            res = json.load(f)
        summary = res["results"].get(m["terrain"], {}).get(m["method"])
        if summary is not None:
            out.setdefault(m["terrain"], {}).setdefault(m["method"], {})[int(m["seed"])] = dict(summary,
                                                                                               meta=res["meta"])
    return out


def _stat(values: list[float]) -> dict:
    import numpy as np

    v = np.asarray([x for x in values if x is not None], float)
    if not len(v):
        return {"mean": None, "min": None, "max": None, "n": 0}
    return {"mean": float(v.mean()), "min": float(v.min()), "max": float(v.max()), "n": int(len(v))}


def table3(evals: dict, distances: tuple[float, ...]) -> dict:
    """{terrain: {method: {"success_<d>m": stat, "fall_rate": stat, "rounds": R, "seeds": [...]}}}: over seeds."""
    out = {}
    for terrain, by_method in evals.items():
        for method in [m for m in METHODS if m in by_method]:
            seeds = by_method[method]
            row = {f"success_{d:g}m": _stat([s.get(f"success_{d:g}m") for s in seeds.values()]) for d in distances}
            row["fall_rate"] = _stat([s.get("fall_rate") for s in seeds.values()])
            row.update(rounds=sorted({s["rounds"] for s in seeds.values()}), seeds=sorted(seeds))
            out.setdefault(terrain, {})[method] = row
    return out


def _cell(stat: dict) -> str:
    if stat["mean"] is None:
        return "—"
    if stat["n"] == 1:
        return f"{100 * stat['mean']:.1f}%"
    return f"{100 * stat['mean']:.1f}% ({100 * stat['min']:.0f}-{100 * stat['max']:.0f})"


def report_markdown(budgets: dict, table: dict, distances: tuple[float, ...], fig: str | None, meta: dict) -> str:
    from hexnewton.analysis.rollout import LABELS

    lines = ["# Methods at equal budgets", ""] + [f"- {k}: {v}" for k, v in meta.items()]
    lines += ["", "## Budget used by each run", "", "Each run ended at its env-step budget or its wall-time budget, "
              "whichever came first. Wall time: the training loop's, without building the env.", "",
              "| method | seed | env-steps | wall time [min] | run |", "|---|---:|---:|---:|---|"]  # fmt: skip
    for method, seeds in budgets.items():
        for seed, b in sorted(seeds.items()):
            lines.append(f"| {LABELS.get(method, method)} | {seed} | {b['env_steps']:,} | {b['wall_min']:.2f} | "
                         f"{b['run']} |")  # fmt: skip
    lines += ["", "## Table 3: success at each distance, mean over seeds (min-max)", "",
              "| terrain | method | seeds | rounds | " + " | ".join(f"{d:g} m" for d in distances) + " | falls |",
              "|---|---|---:|---:|" + "---:|" * (len(distances) + 1)]  # fmt: skip
    for terrain, by_method in table.items():
        for method, row in by_method.items():
            cells = " | ".join(_cell(row[f"success_{d:g}m"]) for d in distances)
            lines.append(f"| {terrain} | {LABELS.get(method, method)} | {len(row['seeds'])} | "
                         f"{'/'.join(map(str, row['rounds']))} | {cells} | {_cell(row['fall_rate'])} |")  # fmt: skip
    if fig:
        lines += ["", "## Fig. 5a", "", f"![Fig. 5a]({fig}): mean return and training success against env-steps and "
                  "against wall time; the line is the mean over seeds, the band their range."]  # fmt: skip
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python -m hexnewton.apps.compare", description=__doc__.split("\n")[0])
    p.add_argument("--runs", required=True, help="folder of <method>_s<seed> experiments")
    p.add_argument("--evals", default=None, help="folder of <method>_s<seed>_<terrain> evaluations (Table 3)")
    p.add_argument("--out", required=True, help="report folder (must not exist)")
    args = p.parse_args(argv)
    if os.path.exists(args.out):
        raise ValueError(f"{args.out} exists: choose a new --out (nothing is overwritten)")
    if args.evals is not None and not os.path.isdir(args.evals):
        raise ValueError(f"not a folder: {args.evals}")
    runs = find_runs(args.runs)
    budgets = {m: {s: dict(run_budget(d), run=os.path.relpath(d, args.runs)) for s, d in seeds.items()}
               for m, seeds in runs.items()}  # fmt: skip
    evals = find_evals(args.evals) if args.evals else {}
    distances = ()
    for by_method in evals.values():
        for seeds in by_method.values():
            for s in seeds.values():
                distances = tuple(s["meta"].get("distances", distances))
    table = table3(evals, distances)
    os.makedirs(args.out)
    from hexnewton.analysis.curves import plot_fig5a

    final = plot_fig5a(os.path.join(args.out, "fig5a.png"), {m: list(seeds.values()) for m, seeds in runs.items()})
    meta = {"runs": os.path.abspath(args.runs), "evals": os.path.abspath(args.evals) if args.evals else None,
            "methods": list(runs), "seeds": sorted({s for seeds in runs.values() for s in seeds}),
            "checkpoints": "each run's last (the same rule for every method)"}  # fmt: skip
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"meta": meta, "budgets": budgets, "table3": table, "fig5a_final": final,
                   "evaluations": {t: {m: {str(s): {k: v for k, v in r.items() if k != "meta"} for s, r in seeds.items()}
                                       for m, seeds in bm.items()} for t, bm in evals.items()}}, f, indent=1)  # fmt: skip
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(budgets, table, distances, "fig5a.png", meta))
    print(f"report in {args.out}/ (report.md, results.json, fig5a.png)")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python -m hexnewton.apps.compare"))
