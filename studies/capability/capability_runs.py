"""Measured capability: the curves and named points that ``studies/device/capability.sh`` evaluated, gathered per
policy into one report.

    python studies/capability/capability_runs.py LEASE/extra --policy shipped=shipped \\
        --policy complex-margin=seed1,seed2,seed3 --out studies/capability/margin

``FOLDER`` holds one evaluation per job, named ``<prefix>_<curve>`` (``evaluate --sweep CURVE --no-nominal``, the
curves of ``hexnewton.analysis.rollout.DEFAULT_SWEEPS``) and ``<prefix>_at_<point>`` (the named points,
``$POINT_ROUNDS`` rounds), each a folder with ``results.json`` once finished and a console log ``<job>.log`` beside
it. A curve whose job was cut off is read from the points its log printed (whole percentages) and marked partial; a
point or curve with neither is missing. ``--policy LABEL=PREFIX[,PREFIX...]`` groups the seeds of one recipe (median
over them); the fixed CPG's curve comes from any job that evaluated it. ``--out`` (which must not exist) receives
``report.md``, ``results.json`` and one ``fig_sweep_<curve>.png`` per curve; the report names the command.
"""

from __future__ import annotations

import json
import os
import re
import statistics
import sys

from hexnewton.apps.cli import ArgumentParser, check_new_dir, run

#: the named points (``capability.sh points``) and the targets they are held to (success at 3 m)
POINTS = (("rise8", "8 cm rise (stepped)"), ("tread20", "20 cm treads (stepped)"), ("blocks8", "8 cm blocks (rugged)"),
          ("friction03", "friction 0.3 (complex)"), ("motors50", "50 % motor strength (complex)"),
          ("payload1", "1.0 kg payload (complex)"))  # fmt: skip
TARGET = 0.95
_LINE = re.compile(r"^\[sweep (\S+) = (\S+)\] +(\S+) +(.+?) +3 m (\d+)%  falls (\d+)%")


def _from_results(path: str) -> dict[str, dict]:
    """{curve: {"field", "terrain", "curves": {ctrl: [point, ...]}}} of a finished evaluation, each point with its
    success at 3 m, falls, variances and rounds (source ``results.json``)."""
    with open(path) as f:
        sweeps = json.load(f)["sweeps"]
    for sweep in sweeps.values():
        for points in sweep["curves"].values():
            for p in points:
                p["source"] = "results.json"
    return sweeps


def _from_log(path: str) -> dict[str, dict]:
    """The points an unfinished evaluation printed: {curve: {"curves": {label: [point, ...]}}}, success and falls as the
    console's whole percentages (source ``console``)."""
    from hexnewton.analysis.rollout import LABELS

    ctrl_of = {label: ctrl for ctrl, label in LABELS.items()}
    sweeps: dict[str, dict] = {}
    with open(path, errors="replace") as f:
        for line in f:
            m = _LINE.match(line.strip())
            if not m:
                continue
            name, value, terrain, label, success, falls = m.groups()
            sweep = sweeps.setdefault(name, {"terrain": terrain, "curves": {}})
            sweep["curves"].setdefault(ctrl_of.get(label, label), []).append(
                {"value": float(value), "success_3m": int(success) / 100, "fall_rate": int(falls) / 100,
                 "rounds": None, "source": "console"})  # fmt: skip
    return sweeps


def read_job(folder: str, job: str) -> tuple[dict[str, dict], str]:
    """(sweeps, status) of one job: ``complete`` (its results.json), ``partial`` (points from its log), ``missing``."""
    res = os.path.join(folder, job, "results.json")
    if os.path.isfile(res):
        return _from_results(res), "complete"
    log = os.path.join(folder, f"{job}.log")
    sweeps = _from_log(log) if os.path.isfile(log) else {}
    return sweeps, "partial" if sweeps else "missing"


def gather(folder: str, policies: dict[str, list[str]]) -> dict:
    """Every policy's curves and named points in ``folder``, and the fixed CPG's curves from whichever job ran it."""
    from hexnewton.analysis.rollout import DEFAULT_SWEEPS

    curves: dict[str, dict] = {}
    for name, field, terrain, values in DEFAULT_SWEEPS:
        entry = {"field": field, "terrain": terrain, "values": list(values), "policies": {}, "cpg": None}
        for label, prefixes in policies.items():
            for prefix in prefixes:
                sweeps, status = read_job(folder, f"{prefix}_{name}")
                by_ctrl = sweeps.get(name, {}).get("curves", {})
                job = {"status": status, "points": by_ctrl.get("cpg_rl", [])}
                entry["policies"].setdefault(label, {})[prefix] = job
                if by_ctrl.get("cpg") and (entry["cpg"] is None or status == "complete"):
                    entry["cpg"] = {"status": status, "from": prefix, "points": by_ctrl["cpg"]}
        curves[name] = entry
    points: dict[str, dict] = {}
    for key, _ in POINTS:
        for label, prefixes in policies.items():
            seeds = {}
            for prefix in prefixes:
                sweeps, status = read_job(folder, f"{prefix}_at_{key}")
                pts = [p for s in sweeps.values() for p in s["curves"].get("cpg_rl", [])]
                if pts and status == "complete":
                    seeds[prefix] = pts[0]
            if seeds:
                ok = [p["success_3m"] for p in seeds.values()]
                points.setdefault(key, {})[label] = {
                    "seeds": seeds, "median_success_3m": statistics.median(ok),
                    "median_fall_rate": statistics.median(p["fall_rate"] for p in seeds.values()),
                    "target_met": statistics.median(ok) >= TARGET and len(seeds) == len(prefixes)}  # fmt: skip
    return {"curves": curves, "points": points}


def _pct(v) -> str:
    return "—" if v is None else f"{100 * v:.1f}"


def _point_rounds(res: dict) -> str:
    """How many rounds each named point ran, from its results ("1000 rounds each"; several counts listed)."""
    rounds = sorted({v.get("rounds") for by_label in res["points"].values() for p in by_label.values()
                     for v in p["seeds"].values() if v.get("rounds")})  # fmt: skip
    return " or ".join(str(r) for r in rounds) + " rounds each" if rounds else "none measured"


def report(res: dict) -> str:
    """The markdown report: the named points against the target, then one table per curve."""
    meta = res["meta"]
    lines = ["# Capability: curves and named points", "", "```bash", meta["command"], "```", "",
             f"Evaluations in `{meta['folder']}`; deterministic action, success at 3 m and rounds that fell (%).",
             "Curves: `evaluate --sweep CURVE --no-nominal` at 200 rounds a point; a curve marked *partial* was cut "
             "off and shows the points its console printed (whole percentages). "
             f"Named points: {_point_rounds(res)}.", "",
             f"## Named points (target: median of the seeds >= {100 * TARGET:.0f} % at 3 m)", "",
             "| point | policy | per seed: success / falls | median success | median falls | target |",
             "|---|---|---|---:|---:|---|"]  # fmt: skip
    for key, title in POINTS:
        for label, p in res["points"].get(key, {}).items():
            seeds = "; ".join(f"{s} {_pct(v['success_3m'])} / {_pct(v['fall_rate'])}" for s, v in p["seeds"].items())
            lines.append(f"| {title} | {label} | {seeds} | {_pct(p['median_success_3m'])} | "
                         f"{_pct(p['median_fall_rate'])} | {'met' if p['target_met'] else 'not met'} |")
    for name, c in res["curves"].items():
        cols = [(label, prefix, job) for label, by_prefix in c["policies"].items() for prefix, job in by_prefix.items()]
        if c["cpg"]:
            cols.append(("fixed CPG", c["cpg"]["from"], c["cpg"]))
        if not any(job["points"] for *_, job in cols):
            continue
        lines += ["", f"## {name}: `{c['field']}` on the {c['terrain']} course", "",
                  "| value | " + " | ".join(f"{label} ({prefix}{', partial' if job['status'] == 'partial' else ''})"
                                          for label, prefix, job in cols) + " |",
                  "|---:|" + "---|" * len(cols)]  # fmt: skip
        for v in c["values"]:
            cells = []
            for *_, job in cols:
                p = next((p for p in job["points"] if abs(p["value"] - v) < 1e-9), None)
                cells.append("—" if p is None else f"{_pct(p['success_3m'])} / {_pct(p['fall_rate'])}")
            lines.append(f"| {v:g} | " + " | ".join(cells) + " |")
        lines.append(f"\n![{name}](fig_sweep_{name}.png)")
    return "\n".join(lines) + "\n"


def plot(path: str, name: str, c: dict) -> None:
    """Success at 3 m and falls against the swept value (``report.plot_sweep``): one line per policy seed and the fixed
    CPG, a curve cut off marked partial."""
    from hexnewton.analysis.report import plot_sweep

    jobs = [(f"{label} ({prefix})", job) for label, by in c["policies"].items() for prefix, job in by.items()]
    jobs += [("fixed CPG", c["cpg"])] if c["cpg"] else []
    curves = {text + (", partial" if job["status"] == "partial" else ""):
              sorted(job["points"], key=lambda p: p["value"]) for text, job in jobs if job["points"]}  # fmt: skip
    plot_sweep(path, name, {"field": c["field"], "terrain": c["terrain"], "curves": curves}, 3.0)


def _policies(specs: list[str] | None) -> dict[str, list[str]]:
    out = {}
    for spec in specs or []:
        label, sep, prefixes = spec.partition("=")
        if not sep or not label or not prefixes:
            raise ValueError(f"--policy {spec}: give LABEL=PREFIX[,PREFIX...]")
        out[label] = [p for p in prefixes.split(",") if p]
    return out


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python studies/capability/capability_runs.py", description=__doc__.splitlines()[0])
    p.add_argument("folder", help="the evaluations of studies/device/capability.sh (RUNS/extra)")
    p.add_argument("--policy", action="append", required=True, metavar="LABEL=PREFIX[,PREFIX...]",
                   help="a policy's jobs by name prefix; several prefixes: its seeds (median over them)")
    p.add_argument("--out", required=True)
    args = p.parse_args(argv)
    policies = _policies(args.policy)
    if not os.path.isdir(args.folder):
        raise ValueError(f"{args.folder}: no such folder")
    check_new_dir(args.out)
    res = gather(args.folder, policies)
    if not res["points"] and not any(job["points"] for c in res["curves"].values()
                                     for by in c["policies"].values() for job in by.values()):
        raise ValueError(f"{args.folder} holds no evaluation of these policies")
    res["meta"] = {"command": "python studies/capability/capability_runs.py " + " ".join(argv if argv is not None
                                                                                       else sys.argv[1:]),
                   "folder": args.folder, "policies": policies, "target_success_3m": TARGET}  # fmt: skip
    os.makedirs(args.out)
    for name, c in res["curves"].items():
        if any(job["points"] for by in c["policies"].values() for job in by.values()):
            plot(os.path.join(args.out, f"fig_sweep_{name}.png"), name, c)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report(res))
    print(f"report in {args.out}/ (report.md, results.json, figures)")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python studies/capability/capability_runs.py"))
