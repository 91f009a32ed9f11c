"""The curriculum study's results.json and report.md from what it holds (studies/curriculum/README.md).

    python studies/curriculum/build.py --add LEASE    # a lease's files (queue.sh collect, unpacked) into the study
    python studies/curriculum/build.py                # results.json and report.md again from runs/ and evals/

A lease's folder holds ``runs/NAME/<stamp>/timing.json`` (with its ``curriculum`` block: what training saw), the
consoles ``runs/NAME.log``, and ``evals/JOB/results.json`` (each result, the shipped policy with the fixed CPG, and the
recipe's kept results on the same validation rounds). ``--add`` keeps the timings, the consoles' summaries and the
evaluations' numbers in one file, ``leases/LEASE_DATE.json`` (the checkpoints and consoles stay out), and the gate's
results (``gate/gate_sN.pt``, gate.sh) in ``policies/LEASE_DATE/`` (not tracked).
"""

from __future__ import annotations

import argparse
import glob
import importlib.util
import json
import os
import re
import shutil
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("curriculum_arms", os.path.join(HERE, "arms.py"))
_arms = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_arms)
ARMS = _arms.ARMS  # the study's arms (arms.py), loaded by path: other studies have scripts of the same names
_spec = importlib.util.spec_from_file_location("curriculum_gate_mc", os.path.join(HERE, "gate_mc.py"))
_gate_mc = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_gate_mc)
GATE_LINES, GATE_SEEDS = _gate_mc.LINES, _gate_mc.SEEDS  # the gate's lines, the ones its Monte Carlo checks
GATE_SECONDS = 240  # the gate's time line: from process start to the exported result, validation included

COURSES = ("rugged", "stepped", "complex")
METRICS = ("success_3m", "fall_rate_before_goal", "fall_rate", "pitch_var_deg2", "roll_var_deg2")
#: the target of "experience that reaches the hardest ground": every seed >= this share of its last stage's finished
#: episodes on the top lane
TOP_TARGET = 0.20
#: what each lease was: its device, what shared the GPU, what it left out
LEASE_NOTES = {
    "2026-12-07": "one H100 (`nvidia-h100-x1`), code 4e8e34b; the four runs (`ARMS=\"anchor spread both\" SEEDS=1 "
                  "RECIPE_SEEDS=1 VAL_ROUNDS=500 KEPT=gate_s1`) trained side by side on the one GPU, beside the "
                  "references' evaluations (times shared: not timed). The lease's device time ended as the runs "
                  "reached their validation: their results were not validated, so their rows hold what training saw "
                  "(each console's last line, iteration 299) and the training episodes' sampled success and falls "
                  "on their own lanes, not validation rounds. Partial.",
    "2026-12-08": "one H100 (`nvidia-h100-x1`), code c0c44ef; the three seed-1 runs (`ARMS=\"anchor spread both\" "
                  "SEEDS=1 RECIPE_SEEDS= VAL_ROUNDS=1000 KEPT=\"gate_s1 gate_s2 gate_s3\" LIMIT=680`) trained side by "
                  "side beside the references' twelve evaluations, which held them at 3.7 s/it; the queue's limit "
                  "stopped them at iterations 214-220 of 299, early in their last stage (iterations 200-299), before "
                  "their validation. Their rows hold what training saw up to there (not the last stage's whole share). "
                  "The references' 1000 validation rounds per course all came back. Partial.",
}
RUN = re.compile(r"^(?P<arm>[a-z0-9]+)_s(?P<seed>\d+)$")


LINE = re.compile(r"^iteration (?P<it>\d+)/(?P<of>\d+)  success (?P<success>[\d.]+)  fell (?P<fell>[\d.]+)  off course "
                  r"[\d.]+  distance [\d.]+ m  level (?P<level>[\d.]+)  top lane (?P<top>\d+|-)%? of (?P<ep>\d+) ep  "
                  r"(?P<per_robot>[\d.]+) ep/robot")
STAGE = re.compile(r"^iteration (\d+): curriculum stage (\d+) of (\d+)")


def parse_console(text: str) -> dict:
    """A train.py console: per iteration the training episodes' success and falls (sampled actions, the last 1024),
    the mean lane, the top lane's share of the current stage's finished episodes, their count and the episodes per
    robot; the stages' first iterations."""
    rows, stages, last = [], [], None
    for line in text.splitlines():
        if m := LINE.match(line):
            last = int(m["of"])
            rows.append({"iteration": int(m["it"]), "success": float(m["success"]), "fell": float(m["fell"]),
                         "mean_level": float(m["level"]), "stage_episodes": int(m["ep"]),
                         "stage_top_lane_share": None if m["top"] == "-" else int(m["top"]) / 100,
                         "episodes_per_robot": float(m["per_robot"])})  # fmt: skip
        elif m := STAGE.match(line):
            stages.append(int(m[1]))
    return {"iterations": rows, "stage_starts": stages, "last_iteration": last}


LEASES_DIR = os.path.join(HERE, "leases")  # one JSON file a lease: its runs' small files and its evaluations' numbers
_LEASES: dict[str, dict] = {}


def _lease(name: str) -> dict:
    if name not in _LEASES:
        _LEASES[name] = json.load(open(os.path.join(LEASES_DIR, f"{name}.json")))
    return _LEASES[name]


def _slim(results: dict) -> dict:
    """An evaluation's results.json as the study keeps it: per controller its metrics and rounds."""
    return {who: {m: r[m] for m in METRICS} | {"rounds": r["rounds"]}
            for course in results["results"].values() for who, r in course.items()}  # fmt: skip


def add(lease: str, name: str | None = None) -> str:
    """A lease's small files into the study as ``leases/NAME.json`` (NAME: the lease's date, or ``name``; a second
    ``--add`` of the same name adds to it): each run's timing.json (its ``curriculum`` block: what training saw), or,
    for a run cut off before its timing.json, what its console said; each evaluation's numbers. The gate's results
    (``gate/gate_sN.pt``, gate.sh) go to ``policies/NAME/`` (not tracked). Returns NAME."""
    timings = glob.glob(os.path.join(lease, "runs", "*", "*", "timing.json"))
    consoles = glob.glob(os.path.join(lease, "runs", "*.log"))
    if not timings and not consoles:
        raise SystemExit(f"build.py: no runs/*/*/timing.json or runs/*.log under {lease}")
    if name is None:
        stamp = os.path.basename(os.path.dirname(sorted(timings)[0]))[:10] if timings else ""
        name = stamp if re.match(r"\d{4}-\d\d-\d\d$", stamp) else os.path.basename(os.path.normpath(lease))
    path = os.path.join(LEASES_DIR, f"{name}.json")
    data = json.load(open(path)) if os.path.exists(path) else {"runs": {}, "evals": {}}
    for log in consoles:
        run = os.path.basename(log)[:-4]
        parsed = parse_console(open(log).read())
        if RUN.match(run) and parsed["iterations"]:
            data["runs"].setdefault(run, {})["console"] = parsed
    for t in timings:
        run = os.path.basename(os.path.dirname(os.path.dirname(t)))
        data["runs"].setdefault(run, {})["timing"] = json.load(open(t))
    for pt in glob.glob(os.path.join(lease, "gate", "gate_s*.pt")):  # untracked: a split gate's second lease carries them
        dest = os.path.join(HERE, "policies", name)
        os.makedirs(dest, exist_ok=True)
        shutil.copyfile(pt, os.path.join(dest, os.path.basename(pt)))
    for r in glob.glob(os.path.join(lease, "evals", "*", "results.json")):
        data["evals"][os.path.basename(os.path.dirname(r))] = _slim(json.load(open(r)))
    os.makedirs(LEASES_DIR, exist_ok=True)
    with open(path, "w") as f:
        json.dump(data, f, indent=0, sort_keys=True)
    _LEASES.pop(name, None)
    return name


def _eval(lease: str, job: str, course: str, who: str = "cpg_rl") -> dict | None:
    return _lease(lease)["evals"].get(f"{job}_{course}", {}).get(who)


def collect() -> dict:
    leases = {}
    for path in sorted(glob.glob(os.path.join(LEASES_DIR, "*.json"))):
        lease = os.path.basename(path)[:-5]
        runs = {}
        for name, files in sorted(_lease(lease)["runs"].items()):
            m = RUN.match(name)
            timing = files.get("timing", {})
            cur = timing.get("curriculum", {})
            complete = bool(cur)  # timing.json is written after the last iteration
            if not cur and "console" in files:  # cut off before its validation: what its console said
                console = files["console"]
                last = console["iterations"][-1]
                complete = last["iteration"] >= console["last_iteration"]
                cur = {"training_success": last["success"], "training_fell": last["fell"],
                       "last_stage": {"top_lane_share": last["stage_top_lane_share"],
                                      "episodes": last["stage_episodes"]},
                       "episodes_per_robot": last["episodes_per_robot"], "mean_level_end": last["mean_level"],
                       "from": f"console, iteration {last['iteration']}"}  # fmt: skip
            runs[name] = {"arm": m["arm"] if m else name, "seed": int(m["seed"]) if m else None,
                          "flags": ARMS.get(m["arm"], ("?",))[0] if m else "?",
                          "trained_to_the_end": complete,
                          "top_lane_share_last_stage": cur.get("last_stage", {}).get("top_lane_share"),
                          "last_stage_episodes": cur.get("last_stage", {}).get("episodes"),
                          "top_lane_share_run": cur.get("run", {}).get("top_lane_share"),
                          "episodes_per_robot": cur.get("episodes_per_robot"),
                          "mean_level_end": cur.get("mean_level_end"),
                          "lanes_last_stage": cur.get("last_stage", {}).get("lanes_top_first"),
                          "curriculum_from": cur.get("from", "timing.json"),
                          "training_success": cur.get("training_success"), "training_fell": cur.get("training_fell"),
                          "wall_s_to_result": timing.get("wall_s_to_result"), "device": timing.get("device_name"),
                          "validation": {t: _eval(lease, name, t) for t in COURSES}}  # fmt: skip
        refs = {"shipped": {t: _eval(lease, "shipped", t) for t in COURSES},
                "fixed_cpg": {t: _eval(lease, "shipped", t, "cpg") for t in COURSES}}
        for job in sorted({k.rsplit("_", 1)[0] for k in _lease(lease)["evals"] if k.startswith("recipe_")}):
            refs[job] = {t: _eval(lease, job, t) for t in COURSES}
        leases[lease] = {"runs": runs, "references": refs}
    return leases


def gate_lines(seeds: dict, shipped: dict, fixed: dict, times: dict) -> dict:
    """The gate's lines (README, "The gate") on its test results: ``seeds`` {seed: {course: metrics}}, ``shipped`` and
    ``fixed`` {course: metrics} (the shipped policy and the fixed CPG on the same rounds), ``times`` {seed: seconds
    from process start to the result, or None}. Returns each line's pass and values, and the whole gate's pass."""
    lines = {}
    per = {t: [seeds[k][t] for k in sorted(seeds)] for t in COURSES}
    lines["median_3m"] = {t: {"median": float(np.median([r["success_3m"] for r in per[t]])),
                              "shipped": shipped[t]["success_3m"]} for t in COURSES}  # fmt: skip
    for t, v in lines["median_3m"].items():
        v["pass"] = v["median"] >= v["shipped"] - GATE_LINES["median_3m_below_shipped"] - 1e-12
    pooled = {}
    for t in COURSES:
        n = sum(r["rounds"] for r in per[t])
        pooled[t] = {"pooled": sum(r["fall_rate_before_goal"] * r["rounds"] for r in per[t]) / n,
                     "shipped": shipped[t]["fall_rate_before_goal"]}  # fmt: skip
        pooled[t]["pass"] = (pooled[t]["pooled"]
                             <= pooled[t]["shipped"] + GATE_LINES["pooled_falls_above_shipped"] + 1e-12)
    lines["pooled_falls"] = pooled
    lines["worst_seed"] = {t: {"worst_3m": min(r["success_3m"] for r in per[t]),
                               "worst_falls": max(r["fall_rate_before_goal"] for r in per[t])} for t in COURSES}
    for v in lines["worst_seed"].values():
        v["pass"] = v["worst_3m"] >= GATE_LINES["worst_3m"] and v["worst_falls"] <= GATE_LINES["worst_falls"]
    cap = GATE_LINES["rugged_var_vs_fixed_cpg"]
    lines["rugged_variance"] = {axis: {"worst": max(seeds[k]["rugged"][f"{axis}_var_deg2"] for k in seeds),
                                       "fixed_cpg": fixed["rugged"][f"{axis}_var_deg2"]} for axis in ("pitch", "roll")}
    for v in lines["rugged_variance"].values():
        v["pass"] = v["worst"] < cap * v["fixed_cpg"]
    measured = [times.get(k) for k in sorted(seeds)]
    lines["time"] = {"seconds": measured, "pass": None not in measured and max(measured) <= GATE_SECONDS}
    passes = [v["pass"] for line in lines.values() for v in (line.values() if "pass" not in line else [line])]
    return {"seeds": sorted(seeds), "lines": lines, "pass": len(seeds) >= GATE_SEEDS and all(passes)}


def gate_table(leases: dict) -> dict | None:
    """The gate of the lease whose evaluations hold its test rounds (``gate_shipped_COURSE`` beside ``gate_sN_COURSE``),
    with the seeds' times from their runs (that lease's, else the latest lease with them); None without one."""
    tested = [lease for lease in leases if _eval(lease, "gate_shipped", "rugged")]
    if not tested:
        return None
    lease = tested[-1]
    seeds = {}
    for job in sorted(_lease(lease)["evals"]):
        if not (m := re.match(r"gate_s(\d+)_rugged$", job)):
            continue
        k = int(m[1])
        res = {t: _eval(lease, f"gate_s{k}", t) for t in COURSES}
        if all(res.values()):
            seeds[k] = res
    times, shares = {}, {}
    for name in sorted(leases, key=lambda n: n != lease):  # the tested lease first
        for run in leases[name]["runs"].values():
            if run["arm"] == "gate" and run["seed"] in seeds and run["seed"] not in times:
                times[run["seed"]] = run["wall_s_to_result"]
                shares[run["seed"]] = run["top_lane_share_last_stage"]
    if not seeds:
        return None
    shipped = {t: _eval(lease, "gate_shipped", t) for t in COURSES}
    fixed = {t: _eval(lease, "gate_shipped", t, "cpg") for t in COURSES}
    out = gate_lines(seeds, shipped, fixed, times)
    out.update(lease=lease, per_seed={str(k): v for k, v in seeds.items()}, shipped=shipped, fixed_cpg=fixed,
               top_lane_shares={str(k): v for k, v in shares.items()})  # fmt: skip
    return out


def arms_table(leases: dict) -> dict:
    """Per arm: its seeds' top-lane shares, whether every seed meets the target, the seeds' validation medians and the
    log-falls mean (log(falls before the goal + 0.1 %), the verdict's scale)."""
    best = {}  # (arm, seed) -> the run of most evidence: trained to the end, then validated, then the later lease
    for lease in leases.values():
        for run in lease["runs"].values():
            if not run["trained_to_the_end"] or run["arm"] == "gate":
                continue  # its last stage's share is not the whole stage's; the gate's seeds are the gate's
            key, rank = (run["arm"], run["seed"]), any(run["validation"].values())
            if key not in best or rank >= best[key][0]:
                best[key] = (rank, run)
    out = {}
    for (arm, _), (_, run) in sorted(best.items(), key=lambda kv: (kv[0][0], kv[0][1] or 0)):
        out.setdefault(arm, []).append(run)
    table = {}
    for arm, runs in out.items():
        shares = [r["top_lane_share_last_stage"] for r in runs if r["top_lane_share_last_stage"] is not None]
        row = {"seeds": len(runs), "seed_list": [r["seed"] for r in runs], "top_lane_shares": shares,
               "every_seed_meets_top_target": bool(shares) and min(shares) >= TOP_TARGET,
               "episodes_per_robot": [r["episodes_per_robot"] for r in runs]}  # fmt: skip
        for t in COURSES:
            vals = [r["validation"][t] for r in runs if r["validation"][t]]
            if vals:
                row[t] = {"success_3m_median": float(np.median([v["success_3m"] for v in vals])),
                          "fall_before_goal_median": float(np.median([v["fall_rate_before_goal"] for v in vals])),
                          "log_falls_mean": float(np.mean([np.log(v["fall_rate_before_goal"] + 0.001) for v in vals]))}
        row["verdict"] = "partial: fewer than 6 seeds, no quality verdict" if len(runs) < 6 else "seeds enough"
        table[arm] = row
    return table


def fmt(v, pct=True):
    if v is None:
        return "-"
    return f"{100 * v:.1f}" if pct else f"{v:.1f}"


def report(results: dict) -> str:
    lines = ["# The curriculum study: experience that reaches the top lane", "",
             "How the robots meet the complex recipe's terrain curriculum, arm by arm (`python train.py --task "
             "complex --seed N` with the arm's flags), with what each run's training saw (`timing.json`'s "
             "`curriculum`: the share of the last "
             "stage's finished episodes on the top lane, lane 10 of 10, the course itself) beside its result on the "
             "validation rounds (seed 3000, deterministic action), against the shipped policy, the fixed CPG and the "
             "recipe's kept results on the same rounds in the same lease. Generated by `python "
             "studies/curriculum/build.py` from results.json.", ""]
    for arm, (flags, what) in ARMS.items():
        lines.append(f"- `{arm}`: {what} (`{flags or '--task complex'}`)")
    lines.append("")
    for lease, data in results["leases"].items():
        lines += [f"## Lease {lease}", "", LEASE_NOTES.get(lease, ""), "",
                  "| run | top lane, last stage | episodes/robot | mean lane at end | " + " | ".join(
                      f"{t} 3 m | {t} falls before goal" for t in COURSES) + " | rugged pitch / roll var |",
                  "|---|---|---|---|" + "---|---|" * len(COURSES) + "---|"]
        rows = list(data["runs"].items()) + [(k, {"validation": v}) for k, v in data["references"].items()]
        for name, r in rows:
            v = r["validation"]
            if r.get("trained_to_the_end") is False:
                name = f"{name} (cut: {r['curriculum_from']})"
            rug = v.get("rugged") or {}
            lines.append(f"| {name} | {fmt(r.get('top_lane_share_last_stage'))} % | "
                         f"{fmt(r.get('episodes_per_robot'), False)} | {fmt(r.get('mean_level_end'), False)} | "
                         + " | ".join(f"{fmt((v.get(t) or {}).get('success_3m'))} | "
                                      f"{fmt((v.get(t) or {}).get('fall_rate_before_goal'))}" for t in COURSES)
                         + f" | {fmt(rug.get('pitch_var_deg2'), False)} / {fmt(rug.get('roll_var_deg2'), False)} |")
        trained = [(k, r) for k, r in data["runs"].items() if r.get("training_success") is not None]
        if trained:
            lines += ["", "Training episodes at the last iteration (sampled actions, the last 1024 finished, each "
                      "on its own lane): " + "; ".join(f"{k} success {fmt(r['training_success'])} %, fell "
                                               f"{fmt(r['training_fell'])} %" for k, r in trained) + "."]
        lines.append("")
    lines += ["## Arms", "", f"Target: every seed >= {TOP_TARGET:.0%} of its last stage's finished episodes on the top "
              "lane. A quality verdict needs >= 6 seeds an arm (log(falls before the goal + 0.1 %)). Each seed "
              "once (its run trained to the end, validated where one was); runs cut before their last iteration "
              "are left out.", "",
              "| arm | seeds | top lane, last stage (each seed) | every seed >= target | " + " | ".join(
                  f"{t} 3 m median | {t} falls median" for t in COURSES) + " | verdict |",
              "|---|---|---|---|" + "---|---|" * len(COURSES) + "---|"]
    for arm, row in results["arms"].items():
        lines.append(f"| {arm} | {', '.join(map(str, row['seed_list']))} | "
                     + ", ".join(f"{100 * s:.0f} %" for s in row["top_lane_shares"])
                     + f" | {'yes' if row['every_seed_meets_top_target'] else 'no'} | "
                     + " | ".join(f"{fmt(row.get(t, {}).get('success_3m_median'))} | "
                                  f"{fmt(row.get(t, {}).get('fall_before_goal_median'))}" for t in COURSES)
                     + f" | {row['verdict']} |")
    met = [a for a, r in results["arms"].items() if r["every_seed_meets_top_target"]]
    missed = [a for a, r in results["arms"].items() if not r["every_seed_meets_top_target"]]
    if results["arms"]:
        lines += ["", f"Top lane: {', '.join(met) or 'no arm'} reach{'es' if len(met) == 1 else ''} the target on "
                  f"every seed run; {', '.join(missed) or 'none'} {'does' if len(missed) == 1 else 'do'} not. "
                  "Arms with fewer than 6 seeds have no quality verdict."]
    g = results.get("gate")
    if g:
        lines += ["", "## The gate", "", f"Lease {g['lease']}: `python train.py --task complex --seed N` (the gate's "
                  "flags: gate.sh), each alone on the GPU; test rounds (the evaluate default seed, deterministic "
                  f"action) beside the shipped policy and the fixed CPG. Seeds {', '.join(map(str, g['seeds']))}.", "",
                  "| seed | " + " | ".join(f"{t} 3 m | {t} falls before goal" for t in COURSES)
                  + " | rugged pitch / roll var | top lane, last stage | s from process start |",
                  "|---|" + "---|---|" * len(COURSES) + "---|---|---|"]
        who = [(f"gate_s{k}", g["per_seed"][str(k)], k) for k in g["seeds"]] + [
            ("shipped", g["shipped"], None), ("fixed CPG", g["fixed_cpg"], None)]
        shares = {int(k): v for k, v in g["top_lane_shares"].items()}
        secs = dict(zip(g["seeds"], g["lines"]["time"]["seconds"]))
        for name, res, k in who:
            rug = res["rugged"]
            lines.append(f"| {name} | " + " | ".join(f"{fmt(res[t]['success_3m'])} | "
                                                     f"{fmt(res[t]['fall_rate_before_goal'])}" for t in COURSES)
                         + f" | {fmt(rug['pitch_var_deg2'], False)} / {fmt(rug['roll_var_deg2'], False)} | "
                         + (f"{fmt(shares.get(k))} % | {fmt(secs.get(k), False)} |" if k else "- | - |"))
        ln = g["lines"]
        lines += ["", "| line | " + " | ".join(COURSES) + " |", "|---|" + "---|" * len(COURSES),
                  "| median seed >= shipped - 0.5 points at 3 m | " + " | ".join(
                      f"{fmt(ln['median_3m'][t]['median'])} vs {fmt(ln['median_3m'][t]['shipped'])}: "
                      f"{'pass' if ln['median_3m'][t]['pass'] else 'FAIL'}" for t in COURSES) + " |",
                  "| pooled falls before the goal <= shipped + 0.3 points | " + " | ".join(
                      f"{fmt(ln['pooled_falls'][t]['pooled'])} vs {fmt(ln['pooled_falls'][t]['shipped'])}: "
                      f"{'pass' if ln['pooled_falls'][t]['pass'] else 'FAIL'}" for t in COURSES) + " |",
                  "| worst seed >= 95 % at 3 m, <= 2 % falls | " + " | ".join(
                      f"{fmt(ln['worst_seed'][t]['worst_3m'])} / {fmt(ln['worst_seed'][t]['worst_falls'])}: "
                      f"{'pass' if ln['worst_seed'][t]['pass'] else 'FAIL'}" for t in COURSES) + " |", "",
                  "Rugged variance, the worst seed against 0.8x the fixed CPG's: " + "; ".join(
                      f"{axis} {fmt(v['worst'], False)} vs {fmt(0.8 * v['fixed_cpg'], False)}: "
                      f"{'pass' if v['pass'] else 'FAIL'}" for axis, v in ln["rugged_variance"].items())
                  + f". Time <= {GATE_SECONDS} s from process start on every seed: "
                  f"{'pass' if ln['time']['pass'] else 'FAIL'}.", "",
                  f"The gate: **{'holds' if g['pass'] else 'fails'}**."]
    mc = results.get("gate_mc")
    if mc:
        cols = ("median_3m", "pooled_falls", "worst_seed", "rugged_variance", "gate")
        lines += ["", "## The gate, checked by Monte Carlo", "", f"`{mc['command']}` ({mc['draws']} draws of "
                  f"{mc['seeds']} seeds; model in gate_mc.py's docstring): the share of draws passing each line.", "",
                  "| recipe | " + " | ".join(cols) + " |", "|---|" + "---|" * len(cols)]
        for name, s in mc["scenarios"].items():
            lines.append(f"| {name} | " + " | ".join(f"{100 * s[c]:.1f} %" for c in cols) + " |")
        lines += ["", f"Sound (as good >= 80 %, twice the falls <= 20 %): {'yes' if mc['sound'] else 'no'}."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, allow_abbrev=False)
    p.add_argument("--add", metavar="LEASE", help="a lease's unpacked folder (queue.sh collect)")
    p.add_argument("--name", help="the lease's name in the study (default: its runs' date)")
    a = p.parse_args(argv)
    if a.add:
        if not os.path.isdir(a.add):
            print(f"build.py: {a.add} is not a folder", file=sys.stderr)
            return 2
        print(f"added lease {add(a.add, a.name)}")
    leases = collect()
    mc_path = os.path.join(HERE, "gate_mc.json")
    results = {"command": "python studies/curriculum/build.py", "top_target": TOP_TARGET, "leases": leases,
               "arms": arms_table(leases), "gate": gate_table(leases),
               "gate_mc": json.load(open(mc_path)) if os.path.exists(mc_path) else None}
    with open(os.path.join(HERE, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(HERE, "report.md"), "w") as f:
        f.write(report(results))
    print(f"{len(leases)} lease(s), arms: {', '.join(results['arms']) or 'none'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
