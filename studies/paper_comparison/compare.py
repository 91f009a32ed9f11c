"""The methods compared at equal budgets: Fig. 5a over seeds and Table 3 over seeds, one report.

    python studies/paper_comparison/compare.py --study studies/paper_comparison                   # report from a kept study
    python studies/paper_comparison/compare.py --study studies/paper_comparison --add LEASE/methods LEASE/method_evals
    python studies/paper_comparison/compare.py --runs RUNS --evals EVALS --out report_dir          # report from loose folders
    python studies/paper_comparison/compare.py --study studies/paper_comparison --from_results     # verdict, report.md

``--runs`` holds one experiment folder per training run, named ``<method>_s<seed>`` (``cpg_rl``, ``paper``, ``joint``
from ``train.py --task complex / paper / complex-joint``; ``sac_cpg``, ``td3_cpg``, ``a2c_cpg`` from
``python -m hexnewton.apps.baselines``), each with its run folder, and beside it ``<method>_s<seed>.done`` (the command,
GPU and process time ``studies/device/gpu.sh`` records when the run ends). ``--evals`` holds one
``hexnewton.apps.evaluate`` folder per run and terrain: ``<method>_s<seed>_<terrain>`` (the deterministic action),
``<method>_s<seed>_<terrain>_sampled`` (``--stochastic``) and ``cpg_s0_<terrain>`` (the fixed CPG). ``gpu.sh methods``
and ``gpu.sh evals`` lay them out so.

``--study DIR`` is a study kept across GPU leases (``store.py``): ``--add`` first copies a lease's
finished runs (policy-only checkpoints, Fig. 5a's scalars) and evaluations into it, skipping those it holds; the
report is then written into DIR itself. Writes: ``report.md`` (what is still missing, when anything is; the GPU
leases; the budget each run used; Table 3 for the deterministic and the sampled action; Fig. 5a), ``results.json``
(every number), ``fig5a_env_steps.png`` and ``fig5a_wall_time.png`` with their ``.csv``
(:func:`hexnewton.analysis.curves.plot_fig5a`).

``--from_results`` (with ``--study``) writes the verdict (``results.json`` ``verdict``) and ``report.md`` again from
the study's ``results.json`` alone: every number and figure stays as it is, and the runs' TensorBoard events, which
the tracked study does not hold (its README, "Raw runs"), are not read. A full report refuses a run without them.
"""

from __future__ import annotations

import glob
import json
import os
import re
import sys

from verdict import VERDICT_LEVELS, claims, paper_table3
from hexnewton.apps.cli import ArgumentParser, positive_int, run

METHODS = ("cpg_rl", "paper", "sac_cpg", "td3_cpg", "a2c_cpg", "joint", "joint_staged")
#: the fixed CPG's rows (seed 0, no training run): at its default 10 ms frame (the paper's setting) and on the
#: policies' physics (20 ms frame, 4 substeps: ``evaluate --env.sim.frame_dt 0.02 --env.sim.substeps 4``)
FIXED_ROWS = ("cpg", "cpg_frame20")
#: the controller ``evaluate`` runs for a method's checkpoint (``paper`` is CPG_RL trained with task ``paper``,
#: ``joint_staged`` pure DRL trained with task ``complex-joint-staged``)
CONTROLLER = {"paper": "cpg_rl", "joint_staged": "joint", "cpg_frame20": "cpg"}
#: the report's names where a method's controller label (``rollout.LABELS``) does not tell its rows apart
ROW_LABELS = {"cpg": "fixed CPG (10 ms frame)", "cpg_frame20": "fixed CPG (20 ms frame)",
              "joint": "pure DRL (no stages)", "joint_staged": "pure DRL (stages)"}
#: seeds each method should have (``paper``: one more row, one seed)
SEEDS = {"paper": 1}
ACTIONS = ("deterministic", "sampled")
#: methods with no sampled action to evaluate: TD3's actor is deterministic (its exploration noise is no policy of its
#: own; ``baselines.sampled_action`` gives its deterministic action)
DETERMINISTIC_ONLY = ("td3_cpg",)
METRICS = ("fall_rate", "fall_rate_before_goal", "pitch_var_deg2", "roll_var_deg2", "pitch_p999_deg", "roll_p999_deg")
_RUN = re.compile(r"^(?P<method>[a-z0-9_]+)_s(?P<seed>\d+)$")
_EVAL = re.compile(r"^(?P<method>[a-z0-9_]+)_s(?P<seed>\d+)_(?P<terrain>[a-z]+)(?P<sampled>_sampled)?$")


def find_runs(runs_dir: str) -> dict[str, dict[int, str]]:
    """{method: {seed: run folder}}: the newest run folder of each ``<method>_s<seed>`` experiment."""
    out: dict[str, dict[int, str]] = {}
    for exp in sorted(glob.glob(os.path.join(runs_dir, "*"))):
        m = _RUN.match(os.path.basename(exp))
        runs = sorted(d for d in glob.glob(os.path.join(exp, "*")) if os.path.isdir(d) and not d.endswith(".part"))
        if m and m["method"] in METHODS and runs:
            out.setdefault(m["method"], {})[int(m["seed"])] = runs[-1]
    if not out:
        raise ValueError(f"no <method>_s<seed> runs under {runs_dir} (methods: {', '.join(METHODS)})")
    return {k: dict(sorted(out[k].items())) for k in METHODS if k in out}


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


def find_evals(evals_dir: str) -> dict[str, dict[str, dict[str, dict[int, dict]]]]:
    """{actions: {terrain: {method: {seed: that evaluation's summary}}}} from the ``results.json`` of
    ``<method>_s<seed>_<terrain>[_sampled]`` folders; ``cpg`` (seed 0) is the fixed CPG."""
    out: dict = {}
    for path in sorted(glob.glob(os.path.join(evals_dir, "*", "results.json"))):
        m = _EVAL.match(os.path.basename(os.path.dirname(path)))
        if not m or m["method"] not in (*METHODS, *FIXED_ROWS):
            continue
        with open(path) as f:
            res = json.load(f)
        summary = res["results"].get(m["terrain"], {}).get(CONTROLLER.get(m["method"], m["method"]))
        if summary is not None:
            actions = "sampled" if m["sampled"] else "deterministic"
            out.setdefault(actions, {}).setdefault(m["terrain"], {}).setdefault(m["method"], {})[int(m["seed"])] = \
                dict(summary, meta=res["meta"])  # fmt: skip
    return out


def _stat(values: list[float]) -> dict:
    import numpy as np

    v = np.asarray([x for x in values if x is not None], float)
    if not len(v):
        return {"mean": None, "min": None, "max": None, "n": 0}
    return {"mean": float(v.mean()), "min": float(v.min()), "max": float(v.max()), "n": int(len(v))}


def label(method: str) -> str:
    """A method's name in the report: ``pure DRL (stages)``, ``SAC-CPG``, ..."""
    from hexnewton.analysis.rollout import LABELS

    return ROW_LABELS.get(method) or LABELS.get(method, method)


def cut_short(budgets: dict) -> dict[str, str]:
    """{``<method>_s<seed>``: why}: runs that ended short of the env-steps the method's other seeds reached (at the
    wall-time limit, by less than 99 % of them). They stay in the budget table and are left out of every mean."""
    out = {}
    for method, seeds in budgets.items():
        top = max(b["env_steps"] for b in seeds.values())
        for seed, b in seeds.items():
            if len(seeds) > 1 and b["env_steps"] < 0.99 * top:
                out[f"{method}_s{seed}"] = (f"ended at {b['env_steps'] / 1e6:.1f} M env-steps after {b['wall_min']:.1f} "
                                            f"min, where the method's other seeds reached {top / 1e6:.1f} M")  # fmt: skip
    return out


def without(evals: dict, excluded: dict) -> tuple[dict, dict]:
    """``evals`` split into (the runs the means take, the ``excluded`` runs'), both in ``find_evals``' layout."""
    kept, left = {}, {}
    for actions, by_t in evals.items():
        for terrain, by_m in by_t.items():
            for method, seeds in by_m.items():
                for seed, summary in seeds.items():
                    side = left if f"{method}_s{seed}" in excluded else kept
                    side.setdefault(actions, {}).setdefault(terrain, {}).setdefault(method, {})[seed] = summary
    return kept, left


def table3(evals: dict, distances: tuple[float, ...]) -> dict:
    """{terrain: {method: {"success_<d>m": stat, "fall_rate": stat, ..., "rounds": R, "seeds": [...]}}}: over seeds;
    the fixed CPG's rows first."""
    out = {}
    for terrain, by_method in evals.items():
        for method in [m for m in (*FIXED_ROWS, *METHODS) if m in by_method]:
            seeds = by_method[method]
            row = {f"success_{d:g}m": _stat([s.get(f"success_{d:g}m") for s in seeds.values()]) for d in distances}
            row.update({k: _stat([s.get(k) for s in seeds.values()]) for k in METRICS})
            row.update(rounds=sorted({s["rounds"] for s in seeds.values()}), seeds=sorted(seeds))
            out.setdefault(terrain, {})[method] = row
    return out


def missing(runs: dict, evals: dict, terrains: tuple[str, ...], seeds: int) -> list[str]:
    """What a complete study still lacks: runs (every method, ``seeds`` seeds; ``paper`` one) and their deterministic
    and sampled evaluations on ``terrains`` (:data:`DETERMINISTIC_ONLY` has none sampled), and the fixed CPG's."""
    out = []
    for method in METHODS:
        want = range(1, SEEDS.get(method, seeds) + 1)
        lacking = [s for s in want if s not in runs.get(method, {})]
        if lacking:
            out.append(f"runs {', '.join(f'{method}_s{s}' for s in lacking)}")
    for actions in ACTIONS:
        for terrain in terrains:
            got = evals.get(actions, {}).get(terrain, {})
            need = [f"{m}_s{s}" for m, ss in runs.items() for s in ss if s not in got.get(m, {})
                    and not (actions == "sampled" and m in DETERMINISTIC_ONLY)]  # fmt: skip
            if actions == "deterministic":
                need[:0] = [f"{m}_s0" for m in FIXED_ROWS if 0 not in got.get(m, {})]
            if need:
                out.append(f"{actions} evaluations on {terrain}: {', '.join(need)}")
    return out


def _cell(stat: dict, scale: float = 100.0, unit: str = "%", digits: int = 1) -> str:
    if stat["mean"] is None:
        return "—"
    if stat["n"] == 1:
        return f"{scale * stat['mean']:.{digits}f}{unit}"
    return f"{scale * stat['mean']:.{digits}f}{unit} ({scale * stat['min']:.0f}-{scale * stat['max']:.0f})"


def _table_lines(table: dict, distances: tuple[float, ...], beside: dict | None) -> list[str]:
    head = ("| terrain | method | seeds | rounds | " + " | ".join(f"{d:g} m" for d in distances) + " | falls | falls "
            "before the goal | pitch var [deg²] | roll var [deg²] | \\|pitch\\| p99.9 [deg] | \\|roll\\| p99.9 [deg] |")  # fmt: skip
    cols = len(distances) + len(METRICS)
    if beside is not None:
        head += " 3 m sampled | falls sampled |"
        cols += 2
    lines = [head, "|---|---|---:|---:|" + "---:|" * cols]

    for terrain, by_method in table.items():
        for method, row in by_method.items():
            cells = [_cell(row[f"success_{d:g}m"]) for d in distances]
            cells += [_cell(row[k]) if k.startswith("fall_rate") else _cell(row[k], 1.0, "", 1) for k in METRICS]
            if beside is not None:
                other = beside.get(terrain, {}).get(method)
                last = f"success_{distances[-1]:g}m" if distances else None
                cells += [_cell(other[last]) if other and last else "—", _cell(other["fall_rate"]) if other else "—"]
            lines.append(f"| {terrain} | {label(method)} | {len(row['seeds'])} | "
                         f"{'/'.join(map(str, row['rounds']))} | " + " | ".join(cells) + " |")  # fmt: skip
    return lines


def _run_notes(leases: list[dict]) -> dict[str, str]:
    """{``<method>_s<seed>``: note} from the leases' ``cold_cache`` and ``shared_gpu`` lists: the runs whose wall
    time holds the kernels' compilation or was shared with other work on their GPU."""
    notes: dict[str, list[str]] = {}
    for lease in leases:
        for name in lease.get("cold_cache", []):
            notes.setdefault(name, []).append("cold kernel cache")
        for name in lease.get("shared_gpu", []):
            notes.setdefault(name, []).append("GPU shared")
    return {k: ", ".join(v) for k, v in notes.items()}


def report_markdown(res: dict, figs: dict[str, list[str]], discussion: str | None) -> str:
    """The study's report.md, from its ``results.json`` (``res``); ``figs``: {"env_steps": [png], "wall_time": [png
    per GPU kind]}; ``discussion``: the study's ``discussion.md`` (prose on the baselines against the paper's rows)."""
    from verdict import verdict_markdown

    meta, gaps, leases, budgets = res["meta"], res["missing"], res["leases"], res["budgets"]
    distances, tables = tuple(meta.get("distances", ())), res["table3"]
    title = "# Methods at equal budgets" + (" (partial)" if gaps else "")
    lines = [title, ""] + [f"- {k}: {v}" for k, v in meta.items()]
    if gaps:
        lines += ["", "## Partial: still missing", ""] + [f"- {g}" for g in gaps]
    lines += ["", *verdict_markdown(res["verdict"])]
    if res.get("excluded"):
        lines += ["", "Left out of every mean (Table 3 and Fig. 5a), kept in the budget table: " + "; ".join(
            f"{k} {v}" for k, v in res["excluded"].items()) + "."]
    if discussion:
        lines += ["", discussion.strip()]
    if leases:
        total = sum(float(x.get("device_s", 0)) for x in leases)
        lines += ["", f"## GPU leases ({total / 60:.1f} device-minutes in all)", "",
                  "| date | GPU kind | device [s] | what ran |", "|---|---|---:|---|"]  # fmt: skip
        lines += [f"| {x.get('date', '')} | {x.get('kind', '')} | {x.get('device_s', '')} | {x.get('ran', '')} |"
                  for x in leases]  # fmt: skip
        for i, x in enumerate(leases, 1):
            if x.get("notes"):
                lines += ["", f"Lease {i}: {x['notes']}"]
            if x.get("commands"):
                lines += ["", f"Lease {i} ({x.get('date', '')}), its device calls after the install:", "", "```bash",
                          *x["commands"], "```"]  # fmt: skip
    notes = _run_notes(leases)
    lines += ["", "## Budget used by each run", "", "Each run ended at its env-step budget or its wall-time budget, "
              "whichever came first. Wall time: the training loop's, without building the env; process: the whole "
              "command, start-up and kernel compilation included; conditions: a run that started on an empty kernel "
              "cache, shared its GPU, or was cut short (and so left out of the means).", "",
              "| method | seed | env-steps | wall time [min] | process [s] | GPU | conditions | run |",
              "|---|---:|---:|---:|---:|---|---|---|"]  # fmt: skip
    for method, seeds in budgets.items():
        for seed, b in sorted(seeds.items(), key=lambda kv: int(kv[0])):
            name = f"{method}_s{seed}"
            cond = ", ".join(x for x in (notes.get(name), "cut short" if name in res.get("excluded", {}) else None) if x)
            lines.append(f"| {label(method)} | {seed} | {b['env_steps']:,} | {b['wall_min']:.2f} | "
                         f"{b.get('process_s', '—')} | {b.get('gpu', '—')} | {cond or '—'} | {b['run']} |")  # fmt: skip
    for actions in ACTIONS:
        if not tables.get(actions):
            continue
        lines += ["", f"## Table 3, {actions} action: success at each distance, mean over seeds (min-max)", ""]
        beside = tables.get("sampled") if actions == "deterministic" else None
        lines += _table_lines(tables[actions], distances, beside)
        if res.get("table3_excluded", {}).get(actions):
            lines += ["", f"Left out of the means ({actions} action):", ""]
            lines += _table_lines(res["table3_excluded"][actions], distances, None)
        if actions == "sampled":
            lines += ["", ", ".join(label(m) for m in DETERMINISTIC_ONLY) + ": no sampled action (a "
                      "deterministic actor; its exploration noise is no policy of its own)."]  # fmt: skip
    lines += ["", "The fixed CPG's rows: at its default 10 ms frame (the paper's setting) and on the policies' physics "
              "(20 ms frame, 4 substeps, as every policy here trains and is evaluated). Falls before the goal line: "
              "falls of robots that had not passed the goal (the course patch ends beyond it); evaluations written "
              "before the metric existed show a dash."]  # fmt: skip
    if figs:
        f5 = res.get("fig5a", {})
        lines += ["", "## Fig. 5a", ""] + [f"![Fig. 5a]({f})" for f in figs["env_steps"] + figs["wall_time"]]
        lines += ["", "Mean episode return and training success (the last 1024 finished episodes, sampled actions) "
                  "and the mean terrain curriculum level against env-steps, and against wall time in one figure per "
                  "GPU kind (runs of that kind only); the line is the mean over seeds, the band their range, up to "
                  "where a method's shortest run ends (the budget table). In the wall-time figures the runs that "
                  "started on an empty kernel cache or shared their GPU are dashed lines of their own, outside the "
                  "bands. `results.json` `fig5a` holds per method and seed the first and the sustained crossing of "
                  f"{100 * f5.get('level', 0):.0f} % training success (above it for "
                  f"{f5.get('window_env_steps', 0) / 1e6:g} M env-steps), the lowest value after the first crossing, "
                  "the peak, the value at the common budget (the shortest run's end) and at the run's own end."]  # fmt: skip
    return "\n".join(lines) + "\n"


def _resolve_folders(args) -> list[dict]:
    """``--study`` (after ``--add`` copied a lease into it) or ``--runs`` / ``--evals`` / ``--out`` into ``args.runs``,
    ``args.evals``, ``args.out``; returns the study's leases."""
    leases: list[dict] = []
    if args.study is not None:
        if args.runs or args.evals or args.out:
            raise ValueError("--study replaces --runs, --evals and --out")
        if args.add is not None and len(args.add) > 2:
            raise ValueError("--add takes a runs folder and, optionally, an evaluations folder")
        from store import read_leases, store

        if args.add:
            for d in args.add:
                if not os.path.isdir(d):
                    raise ValueError(f"not a folder: {d}")
            added = store(args.add[0], args.add[1] if len(args.add) > 1 else None, args.study)
            print(f"added to {args.study}: {len(added['runs'])} runs ({', '.join(added['runs']) or 'none'}), "
                  f"{len(added['evals'])} evaluations")  # fmt: skip
        args.runs, args.out = os.path.join(args.study, "runs"), args.study
        args.evals = os.path.join(args.study, "evals") if os.path.isdir(os.path.join(args.study, "evals")) else None
        leases = read_leases(args.study)
    else:
        if args.add:
            raise ValueError("--add needs --study")
        if not args.runs or not args.out:
            raise ValueError("give --study DIR, or --runs and --out")
        if os.path.exists(args.out):
            raise ValueError(f"{args.out} exists: choose a new --out (nothing is overwritten)")
    return leases


def from_results(study: str) -> int:
    """The verdict and ``report.md`` of ``study`` again from its ``results.json`` alone (``--from_results``): the
    numbers, the figures and the other keys stay as they are."""
    path = os.path.join(study, "results.json")
    if not os.path.isfile(path):
        raise ValueError(f"no results.json in {study}")
    with open(path) as f:
        res = json.load(f)
    res["verdict"] = claims(res, label)
    figs = {"env_steps": [n for n in ("fig5a_env_steps.png",) if os.path.isfile(os.path.join(study, n))],
            "wall_time": sorted(os.path.basename(p) for p in glob.glob(os.path.join(study, "fig5a_wall_time_*.png")))}
    with open(path, "w") as f:
        json.dump(res, f, indent=1)
    discussion = os.path.join(study, "discussion.md")
    text = open(discussion).read() if os.path.isfile(discussion) else None
    with open(os.path.join(study, "report.md"), "w") as f:
        f.write(report_markdown(res, figs if figs["env_steps"] or figs["wall_time"] else {}, text))
    print(f"verdict and report.md in {study}/ from its results.json ({len(res['verdict'])} claims)")
    return 0


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python studies/paper_comparison/compare.py", description=__doc__.split("\n")[0])
    p.add_argument("--study", default=None, help="a study folder kept across leases (runs/, evals/, leases.json); the "
                                                 "report is written into it")  # fmt: skip
    p.add_argument("--add", nargs="+", metavar="DIR", default=None,
                   help="with --study: a lease's runs folder (gpu.sh's $RUNS/methods) and, optionally, its evaluations "
                        "folder ($RUNS/method_evals) to copy into the study first")  # fmt: skip
    p.add_argument("--runs", default=None, help="folder of <method>_s<seed> experiments (without --study)")
    p.add_argument("--evals", default=None, help="folder of <method>_s<seed>_<terrain> evaluations (Table 3)")
    p.add_argument("--out", default=None, help="report folder (without --study; must not exist)")
    p.add_argument("--seeds", type=positive_int, default=3, help="seeds a complete study has per method (default 3)")
    p.add_argument("--terrains", nargs="+", default=["rugged", "stepped", "complex"],
                   help="terrains a complete study evaluates (default rugged stepped complex)")
    p.add_argument("--from_results", action="store_true",
                   help="with --study: the verdict and report.md again from the study's results.json alone (no runs "
                        "or evaluations read; every number and figure stays)")  # fmt: skip
    args = p.parse_args(argv)
    if args.from_results:
        if args.study is None or args.add or args.runs or args.evals or args.out:
            raise ValueError("--from_results takes --study DIR alone")
        return from_results(args.study)
    leases = _resolve_folders(args)
    if args.evals is not None and not os.path.isdir(args.evals):
        raise ValueError(f"not a folder: {args.evals}")
    from store import read_done

    runs = find_runs(args.runs)
    bare = [os.path.relpath(d, args.runs) for seeds in runs.values() for d in seeds.values()
            if not glob.glob(os.path.join(d, "events.out.tfevents.*"))]  # fmt: skip
    if bare:
        raise ValueError(f"{len(bare)} runs without TensorBoard events under {args.runs} (first: {bare[0]}): Fig. 5a "
                         "and the budgets need them; --study DIR --from_results writes the verdict and report.md from "
                         "results.json alone")  # fmt: skip
    budgets = {}
    for m, seeds in runs.items():
        for s, d in seeds.items():
            done = read_done(args.runs, f"{m}_s{s}")
            budgets.setdefault(m, {})[s] = dict(run_budget(d), run=os.path.relpath(d, args.runs),
                                                process_s=done.get("process_s"), gpu=done.get("gpu"))  # fmt: skip
    evals = find_evals(args.evals) if args.evals else {}
    distances: tuple = ()
    for by_terrain in evals.values():
        for by_method in by_terrain.values():
            for seeds in by_method.values():
                for s in seeds.values():
                    distances = tuple(s["meta"].get("distances", distances))
    excluded = cut_short(budgets)
    kept, left = without(evals, excluded)
    tables = {a: table3(kept[a], distances) for a in ACTIONS if a in kept}
    os.makedirs(args.out, exist_ok=args.study is not None)
    gaps = missing(runs, evals, tuple(args.terrains), args.seeds)
    gpus = sorted({b["gpu"] for seeds in budgets.values() for b in seeds.values() if b.get("gpu")})
    meta = {"runs": os.path.relpath(args.runs), "evals": os.path.relpath(args.evals) if args.evals else None,
            "methods": list(runs), "seeds": sorted({s for seeds in runs.values() for s in seeds}),
            "checkpoints": "each run's last (the same rule for every method)", "GPUs": ", ".join(gpus) or None,
            "distances": list(distances), "complete": not gaps}  # fmt: skip
    figs, fig5a = fig5a_figures(args.out, runs, budgets, excluded, leases)
    res = {"meta": meta, "missing": gaps, "leases": leases, "budgets": budgets, "excluded": excluded,
           "table3": tables, "table3_excluded": {a: table3(left[a], distances) for a in ACTIONS if a in left},
           "fig5a": fig5a, "paper_table3": paper_table3(), "verdict_levels": VERDICT_LEVELS,
           "evaluations": {a: {t: {m: {str(s): {k: v for k, v in r.items() if k != "meta"}
                                       for s, r in seeds.items()} for m, seeds in bm.items()}
                               for t, bm in by_t.items()} for a, by_t in evals.items()}}  # fmt: skip
    # the verdict reads the numbers as results.json holds them
    res = json.loads(json.dumps(res))
    res["verdict"] = claims(res, label)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    discussion = os.path.join(args.out, "discussion.md")
    text = open(discussion).read() if os.path.isfile(discussion) else None
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(res, figs, text))
    print(f"report in {args.out}/ (report.md, results.json, {', '.join(figs['env_steps'] + figs['wall_time'])})"
          + (" — partial" if gaps else ""))  # fmt: skip
    return 0


def fig5a_figures(out: str, runs: dict, budgets: dict, excluded: dict, leases: list[dict]) -> tuple[dict, dict]:
    """Fig. 5a against env-steps (every run the means take) and against wall time, one figure per GPU kind (its runs
    alone; those with a cold kernel cache or a shared GPU dashed, outside the bands), and the curves' numbers
    (:func:`hexnewton.analysis.curves.curve_numbers`): ({"env_steps": [png], "wall_time": [png, ...]}, numbers)."""
    from hexnewton.analysis.curves import curve_numbers, plot_fig5a

    labels = {m: label(m) for m in runs}
    kept = {m: [d for s, d in seeds.items() if f"{m}_s{s}" not in excluded] for m, seeds in runs.items()}
    figs = {"env_steps": ["fig5a_env_steps.png"], "wall_time": []}
    plot_fig5a(os.path.join(out, "fig5a_env_steps.png"), kept, ("env_steps",), labels=labels,
               title="Fig. 5a against env-steps\nmean over seeds, min to max shaded")  # fmt: skip
    notes = _run_notes(leases)
    for kind in sorted({b.get("gpu") or "unrecorded" for seeds in budgets.values() for b in seeds.values()}):
        clean, marked = {}, {}
        for m, seeds in runs.items():
            for s, d in seeds.items():
                name = f"{m}_s{s}"
                if (budgets[m][s].get("gpu") or "unrecorded") != kind or name in excluded:
                    continue
                if name in notes:
                    marked.setdefault(m, []).append((d, f"seed {s} ({notes[name]})"))
                else:
                    clean.setdefault(m, []).append(d)
        name = "fig5a_wall_time_" + re.sub(r"[^a-z0-9]+", "_", kind.lower()).strip("_") + ".png"
        plot_fig5a(os.path.join(out, name), clean, ("wall_time",), labels=labels, marked=marked,
                   title=f"Fig. 5a against wall time, runs on {kind} GPUs\nmean over seeds, min to max shaded")  # fmt: skip
        figs["wall_time"].append(name)
    # the common budget: the shortest run's end among the methods of a full set of seeds (the paper task's one run
    # ends at its own wall-time budget)
    ends = [budgets[m][s]["env_steps"] for m, seeds in runs.items() if m not in SEEDS for s in seeds
            if f"{m}_s{s}" not in excluded]  # fmt: skip
    common = float(min(ends)) if ends else 0.0
    level, window = VERDICT_LEVELS["success"], VERDICT_LEVELS["window_env_steps"]
    numbers = {"level": level, "window_env_steps": window, "common_env_steps": common}
    for key, tag, lv in (("success", "Episode/success_rate", level), ("reward", "Train/mean_reward", None),
                         ("curriculum", "Curriculum/mean_level", None)):
        numbers[key] = {}
        for m, specs in kept.items():
            if specs:
                got = curve_numbers(specs, "env_steps", tag, lv, window, common)
                numbers[key][m] = {"seeds": [int(s) for s, d in runs[m].items() if d in specs],
                                   "per_seed": got["seeds"], "mean": got.get("mean")}  # fmt: skip
    return figs, numbers


if __name__ == "__main__":
    sys.exit(run(main, "python studies/paper_comparison/compare.py"))
