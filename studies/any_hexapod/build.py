"""The any-hexapod study's results.json and report.md from what it holds (studies/any_hexapod/README.md).

    python studies/any_hexapod/build.py --add LEASE    # a lease's files (queue.sh collect, unpacked) into the study
    python studies/any_hexapod/build.py                # results.json and report.md again from leases/
    python studies/any_hexapod/build.py --better scratch_s1=A.timing.json init_s1=B.timing.json   # queue.sh's choice

A lease's folder holds ``lease.json`` (the queue's knobs and GPU), ``runs/NAME/<stamp>/{timing,config}.json`` and
``runs/NAME.log`` (NAME: ``scratch_sN``, ``init_sN``), ``policies/NAME.pt``, ``evals/JOB_COURSE/results.json`` (JOB:
a result or ``fixed_cpg``) and ``evals/s2s_NAME/{results,details}.json`` (the bundle in C MuJoCo). ``--add`` copies
the small JSON files into ``leases/LEASE_DATE/`` (the runs' under ``trainings/``, their consoles as ``console.json``:
the last iteration and the time) and the policies into ``policies/LEASE_DATE/`` (not tracked).
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import re
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROBOT = "mx_phoenix"
COURSES = ("rugged", "stepped", "complex")
METRICS = ("rounds", "success_3m", "fall_rate_before_goal", "fall_rate", "pitch_var_deg2", "roll_var_deg2")
S2S_METRICS = ("rounds", "success_3m", "fall_rate", "pitch_var_deg2", "roll_var_deg2")
RUN = re.compile(r"^(?P<arm>scratch|init)_s(?P<seed>\d+)$")
ARMS = {"scratch": "from scratch", "init": "--init results/policies/cpg_rl_complex.pt"}
#: how far apart two shares must be to count as a difference: this many standard errors of their difference
SE_LINE = 2.0
#: the lease's commands (README.md, "On the GPU")
COMMANDS = (
    "bash studies/device/gpu.sh queue studies/any_hexapod/queue.sh   # ROBOT SEEDS ROUNDS S2S_ROUNDS LIMIT TRAIN TEST",
    "cd /root/code && bash studies/device/gpu.sh poll 560              # as often as needed, then",
    "cd /root/code && bash studies/any_hexapod/queue.sh collect       # $OUT/any_hexapod.tgz.NN",
    "mkdir -p LEASE && cat any_hexapod.tgz.* | tar xzf - -C LEASE && python studies/any_hexapod/build.py --add LEASE",
)
TRAIN_COMMANDS = (
    "python train.py --task complex --robot mx_phoenix --seed 1",
    "python train.py --task complex --robot mx_phoenix --seed 1 --init results/policies/cpg_rl_complex.pt",
)
#: what each lease was beside its lease.json: its code, what it left out
LEASE_NOTES: dict[str, str] = {}


def validation_score(timing: dict) -> tuple[float, float] | None:
    """The chosen result's validation goal share and falls before the goal, averaged over the courses (train.py's
    own ranking: the most goals, then the fewest falls); None without validation."""
    v = timing.get("validation")
    if not v:
        return None
    chosen = next(c for c in v["candidates"] if c["path"] == v["chosen"])
    return chosen["goal"], chosen["fell_before_goal"]


def better(pairs: dict[str, str]) -> str:
    """The name of the result better on its validation rounds among ``pairs`` {name: timing.json}; the first with a
    timing when none was validated; '' when none has a timing."""
    scores = {}
    for name, path in pairs.items():
        if os.path.exists(path):
            s = validation_score(json.load(open(path)))
            scores[name] = (-1.0, 0.0) if s is None else (s[0], -s[1])
    return max(scores, key=lambda n: scores[n]) if scores else ""


def parse_console(text: str) -> dict:
    """A train.py console: its last iteration line's ``i/N`` and the seconds from process start to the result."""
    its = re.findall(r"^iteration (\d+)/(\d+) ", text, re.M)
    secs = re.findall(r"^(\d+) s from process start to the exported result", text, re.M)
    return {"last_iteration": int(its[-1][0]) if its else None, "of": int(its[-1][1]) if its else None,
            "wall_s_to_result": float(secs[-1]) if secs else None}  # fmt: skip


def lease_name(lease: str) -> str:
    path = os.path.join(lease, "lease.json")
    date = json.load(open(path)).get("date", "") if os.path.exists(path) else ""
    if not re.match(r"\d{4}-\d\d-\d\d$", date):
        timings = glob.glob(os.path.join(lease, "runs", "*", "*", "timing.json"))
        stamps = sorted(os.path.basename(os.path.dirname(p)) for p in timings)
        date = stamps[0][:10] if stamps else ""
    return date if re.match(r"\d{4}-\d\d-\d\d$", date) else os.path.basename(os.path.normpath(lease))


def _copy(src: str, dest: str) -> None:
    os.makedirs(os.path.dirname(dest), exist_ok=True)
    shutil.copyfile(src, dest)


def add(lease: str, name: str | None = None, study: str = HERE) -> str:
    """Copy a lease's small files into ``study`` under the lease's date (or ``name``); returns that name."""
    found = [p for pat in ("runs/*.log", "runs/*/*/timing.json", "evals/*/results.json", "policies/*.pt")
             for p in glob.glob(os.path.join(lease, pat))]  # fmt: skip
    if not found:
        raise SystemExit(f"build.py: no runs, evaluations or policies under {lease} (queue.sh collect, unpacked)")
    name = name or lease_name(lease)
    dest = os.path.join(study, "leases", name)
    if os.path.exists(os.path.join(lease, "lease.json")):
        _copy(os.path.join(lease, "lease.json"), os.path.join(dest, "lease.json"))
    for path in glob.glob(os.path.join(lease, "runs", "*.log")):
        run = os.path.basename(path)[:-4]
        if RUN.match(run):
            os.makedirs(os.path.join(dest, "trainings", run), exist_ok=True)
            with open(os.path.join(dest, "trainings", run, "console.json"), "w") as f:
                json.dump(parse_console(open(path).read()), f, indent=1)
    for path in glob.glob(os.path.join(lease, "runs", "*", "*", "timing.json")):
        run = os.path.basename(os.path.dirname(os.path.dirname(path)))
        for f in ("timing.json", "config.json"):
            if os.path.exists(src := os.path.join(os.path.dirname(path), f)):
                _copy(src, os.path.join(dest, "trainings", run, f))
    for path in glob.glob(os.path.join(lease, "evals", "*", "results.json")):
        job = os.path.basename(os.path.dirname(path))
        if job.startswith("s2s_"):
            _copy(path, os.path.join(dest, "sim2sim", job[4:], "results.json"))
            details = os.path.join(os.path.dirname(path), "details.json")
            if os.path.exists(details):  # the fixed CPG's headline and the meta; the rounds stay out
                d = json.load(open(details))
                fixed = {t: {k: s.get(k) for k in S2S_METRICS} for t, s in d.get("fixed_cpg", {}).items()}
                with open(os.path.join(dest, "sim2sim", job[4:], "fixed_cpg.json"), "w") as f:
                    json.dump({"fixed_cpg": fixed, "meta": d.get("meta", {})}, f, indent=1)
        elif not job.startswith("bundle_"):
            _copy(path, os.path.join(dest, "evals", job, "results.json"))
    for path in glob.glob(os.path.join(lease, "policies", "*")):  # untracked: a split lease's second half carries them
        _copy(path, os.path.join(study, "policies", name, os.path.basename(path)))
    return name


def _test(lease_dir: str, job: str, course: str, who: str) -> dict | None:
    path = os.path.join(lease_dir, "evals", f"{job}_{course}", "results.json")
    if not os.path.exists(path):
        return None
    r = json.load(open(path))["results"].get(course, {}).get(who)
    return None if r is None else {m: r.get(m) for m in METRICS}


def _run(run_dir: str) -> dict:
    m = RUN.match(os.path.basename(run_dir))
    tpath, cpath = os.path.join(run_dir, "timing.json"), os.path.join(run_dir, "console.json")
    timing = json.load(open(tpath)) if os.path.exists(tpath) else {}
    console = json.load(open(cpath)) if os.path.exists(cpath) else {}
    score = validation_score(timing)
    cpath = os.path.join(run_dir, "config.json")  # train.py's: the run's meta under "hexnewton"
    init = (json.load(open(cpath))["hexnewton"].get("init") or {}).get("checkpoint") if os.path.exists(cpath) else None
    return {"arm": m["arm"], "seed": int(m["seed"]), "init": init,
            "trained_to_the_end": bool(timing), "iterations": timing.get("iterations"),
            "last_iteration": console.get("last_iteration"),
            "wall_s_to_result": timing.get("wall_s_to_result", console.get("wall_s_to_result")),
            "train_s": timing.get("train_s"), "device": timing.get("device_name"),
            "validation": None if score is None else {"goal": score[0], "fell_before_goal": score[1],
                                                      "rounds": timing["validation"]["rounds"]}}  # fmt: skip


def _order(name: str) -> tuple:
    """Seed by seed, scratch before init; other names after."""
    m = RUN.match(name)
    return (0, int(m["seed"]), m["arm"] != "scratch") if m else (1, 0, name)


def collect(study: str = HERE) -> dict:
    """Every lease of ``study``: its runs, test rounds per course and sim2sim beside the simulator's numbers."""
    leases = {}
    for lease_dir in sorted(glob.glob(os.path.join(study, "leases", "*"))):
        lease = os.path.basename(lease_dir)
        lpath = os.path.join(lease_dir, "lease.json")
        names = sorted((os.path.basename(d) for d in glob.glob(os.path.join(lease_dir, "trainings", "*"))), key=_order)
        runs = {n: _run(os.path.join(lease_dir, "trainings", n)) for n in names if RUN.match(n)}
        jobs = sorted({os.path.basename(p).rsplit("_", 1)[0]
                       for p in glob.glob(os.path.join(lease_dir, "evals", "*"))} - {"fixed_cpg"}, key=_order)
        test = {t: {job: _test(lease_dir, job, t, "cpg_rl") for job in jobs} for t in COURSES}
        for t in COURSES:
            test[t]["fixed_cpg"] = _test(lease_dir, "fixed_cpg", t, "cpg")
            test[t] = {k: v for k, v in test[t].items() if v is not None}
        s2s = {}
        for d in sorted(glob.glob(os.path.join(lease_dir, "sim2sim", "*"))):
            policy = os.path.basename(d)
            mujoco = json.load(open(os.path.join(d, "results.json")))
            fpath = os.path.join(d, "fixed_cpg.json")
            fixed = json.load(open(fpath)) if os.path.exists(fpath) else {"fixed_cpg": {}, "meta": {}}
            s2s[policy] = {"bundle": {t: {k: s.get(k) for k in S2S_METRICS} for t, s in mujoco.items()},
                           "fixed_cpg": fixed["fixed_cpg"], "meta": fixed["meta"],
                           "newton": {t: test.get(t, {}).get(policy) for t in mujoco},
                           "newton_fixed_cpg": {t: test.get(t, {}).get("fixed_cpg") for t in fixed["fixed_cpg"]}}
        leases[lease] = {"lease": json.load(open(lpath)) if os.path.exists(lpath) else {}, "runs": runs,
                         "test": {t: v for t, v in test.items() if v}, "sim2sim": s2s}  # fmt: skip
    return leases


def compare(a: dict, b: dict, key: str, higher_better: bool) -> dict:
    """``a`` against ``b`` on the share ``key``: the difference, its standard error (two independent binomials) and
    'better' / 'worse' / 'within noise' (``SE_LINE`` standard errors) for ``a``."""
    pa, pb, na, nb = a[key], b[key], a["rounds"], b["rounds"]
    se = math.sqrt(max(pa * (1 - pa) / na + pb * (1 - pb) / nb, 0.25 / max(na, nb) ** 2))
    d = pa - pb
    word = "within noise" if abs(d) <= SE_LINE * se else ("better" if (d > 0) == higher_better else "worse")
    return {"init": pa, "scratch": pb, "difference": d, "se": se, "verdict": word}


def verdict(leases: dict) -> dict | None:
    """``--init`` against scratch at equal iterations, per seed and course (success at 3 m, falls before the goal),
    from the latest lease with both on the test rounds; None without one."""
    for lease in sorted(leases, reverse=True):
        test = leases[lease]["test"]
        seeds = sorted({int(RUN.match(j)["seed"]) for t in test.values() for j in t if RUN.match(j)})
        pairs = {}
        for s in seeds:
            per = {}
            for t in COURSES:
                a, b = test.get(t, {}).get(f"init_s{s}"), test.get(t, {}).get(f"scratch_s{s}")
                if a and b:
                    per[t] = {"success_3m": compare(a, b, "success_3m", True),
                              "fall_rate_before_goal": compare(a, b, "fall_rate_before_goal", False)}
            if per:
                pairs[s] = per
        if not pairs:
            continue
        words = [c["verdict"] for per in pairs.values() for m in per.values() for c in m.values()]
        full = all(len(per) == len(COURSES) for per in pairs.values())
        if "worse" in words:
            overall = "not better: worse than scratch on some course"
        elif "better" in words and full:
            overall = "better: better than scratch on some course and worse on none"
        elif full:
            overall = "not better: within noise of scratch on every course"
        else:
            overall = "not settled: a course missing"
        return {"lease": lease, "seeds": {str(k): v for k, v in pairs.items()}, "overall": overall,
                "init_better": overall.startswith("better"), "se_line": SE_LINE}  # fmt: skip
    return None


def fmt(v, pct: bool = True) -> str:
    if v is None:
        return "-"
    return f"{100 * v:.1f}" if pct else f"{v:.1f}"


def _who(job: str) -> str:
    m = RUN.match(job)
    return f"{'init' if m['arm'] == 'init' else 'scratch'} (seed {m['seed']})" if m else "fixed CPG"


def lease_section(name: str, data: dict) -> list[str]:
    info = data["lease"]
    lines = [f"## Lease {name}", "", f"{info.get('gpu', '?')}; robot {info.get('robot', ROBOT)}, seeds "
             f"{info.get('seeds', '?')}, {info.get('rounds', '?')} test rounds per course, sim2sim "
             f"{info.get('s2s_rounds', '?')} rounds per course. " + LEASE_NOTES.get(name, ""), ""]
    if data["runs"]:
        lines += ["| training | iterations | s from process start | device | validation goal / falls before goal |",
                  "|---|---|---|---|---|"]
        for run, r in data["runs"].items():
            its = r["iterations"] if r["trained_to_the_end"] else f"cut at {r['last_iteration']}"
            v = r["validation"] or {}
            cmd = TRAIN_COMMANDS[r["arm"] == "init"].replace("--seed 1", f"--seed {r['seed']}")
            lines.append(f"| {run}: `{cmd}` "
                         f"| {its} | {fmt(r['wall_s_to_result'], False)} | {r['device'] or '-'} | "
                         f"{fmt(v.get('goal'))} / {fmt(v.get('fell_before_goal'))} % |")
        lines.append("")
    for t, per in data["test"].items():
        lines += [f"### {t}", "", "| controller | rounds | 3 m | falls before the goal | falls | pitch var [deg²] | "
                  "roll var [deg²] |", "|---|---|---|---|---|---|---|"]
        for job, m in per.items():
            lines.append(f"| {_who(job)} | {m['rounds']} | {fmt(m['success_3m'])} | "
                         f"{fmt(m['fall_rate_before_goal'])} | {fmt(m['fall_rate'])} | "
                         f"{fmt(m['pitch_var_deg2'], False)} | {fmt(m['roll_var_deg2'], False)} |")
        lines.append("")
    for policy, s in data["sim2sim"].items():
        lines += [f"### {policy}'s bundle in C MuJoCo", "", f"{policy}: the result better on its validation "
                  "rounds (queue.sh). Each cell: MuJoCo (sim2sim, the same terrain and start seeds, its rounds spread "
                  "over the same lanes) / Newton (this lease's test rounds).", "",
                  "| course | controller | rounds | 3 m | falls | pitch var [deg²] | roll var [deg²] |",
                  "|---|---|---|---|---|---|---|"]
        for label, mine, newton in (("bundle", s["bundle"], s["newton"]), ("fixed CPG", s["fixed_cpg"],
                                                                          s["newton_fixed_cpg"])):
            for t, m in mine.items():
                n = newton.get(t) or {}
                lines.append(f"| {t} | {label} | {m['rounds']} / {n.get('rounds', '-')} | "
                             + " | ".join(f"{fmt(m.get(k), p)} / {fmt(n.get(k), p)}" for k, p in (
                                 ("success_3m", True), ("fall_rate", True), ("pitch_var_deg2", False),
                                 ("roll_var_deg2", False))) + " |")  # fmt: skip
        wall = s["meta"].get("wall time")
        lines += ["", f"sim2sim: {s['meta'].get('machine', '?')}, wall time {wall or '?'}.", ""]
    return lines


def verdict_lines(v: dict | None) -> list[str]:
    lines = ["## Verdict: `--init` against scratch at equal iterations", ""]
    if v is None:
        return lines + ["Not measured yet: no lease holds both results on the test rounds."]
    lines.append(f"Lease {v['lease']}; a difference counts beyond {v['se_line']:g} standard errors of the two shares "
                 "(independent binomials).")
    lines.append("")
    for seed, per in v["seeds"].items():
        for t, m in per.items():
            s, f = m["success_3m"], m["fall_rate_before_goal"]
            lines.append(f"- seed {seed}, {t}: 3 m {fmt(s['init'])} % with --init against {fmt(s['scratch'])} % from "
                         f"scratch ({100 * s['difference']:+.1f} ± {100 * s['se']:.1f} points): {s['verdict']}; falls "
                         f"before the goal {fmt(f['init'])} against {fmt(f['scratch'])} % "
                         f"({100 * f['difference']:+.1f} ± {100 * f['se']:.1f}): {f['verdict']}.")
    lines += ["", f"`--init` is **{v['overall']}**" + (" (one seed: a first reading, not a seeds-wide verdict)."
                                                     if len(v["seeds"]) == 1 else ".")]
    return lines


def report(results: dict) -> str:
    lines = ["# Any hexapod: the second robot trained from scratch and from the shipped policy", "",
             f"`{TRAIN_COMMANDS[0]}` against `{TRAIN_COMMANDS[1]}` at equal iterations (the task's 300), each alone "
             "on one GPU, with the fixed CPG on the same robot: success at 3 m, falls before the goal and pitch / "
             "roll variance on the test rounds of each course (evaluate's default seed, deterministic action), the "
             "time from process start to each result, and the better result's bundle in C MuJoCo beside the "
             "simulator's numbers. Generated by `python studies/any_hexapod/build.py` from results.json.", ""]
    if not results["leases"]:
        lines += ["**Not measured yet**: no lease has run the queue. The commands (studies/any_hexapod/README.md, "
                  "\"On the GPU\"):", "", "```bash"] + list(results["commands"]) + ["```", "",
                  "The queue runs, in order:", ""] + [f"- {what}: `{c}`" for c, what in results["queue"]] + [""]
    for name, data in results["leases"].items():
        lines += lease_section(name, data)
    lines += verdict_lines(results["verdict"])
    return "\n".join(lines) + "\n"


#: what the queue runs, in order: (command, what it is)
QUEUE_STEPS = (
    ("python train.py --task complex --robot mx_phoenix --num_envs 256 --max_iterations 2 --agent.validation_rounds 0",
     "the warm-up"),
    (TRAIN_COMMANDS[0], "scratch_s1, alone on the GPU"),
    (TRAIN_COMMANDS[1], "init_s1, alone on the GPU after it"),
    ("python -m hexnewton.apps.evaluate --robot mx_phoenix --controllers cpg_rl --checkpoint cpg_rl=NAME.pt "
     "--terrains rugged --rounds 1000 --out DIR --no-progress", "each result on each course (rugged, stepped, "
     "complex), all at once"),
    ("python -m hexnewton.apps.evaluate --robot mx_phoenix --controllers cpg --env.sim.frame_dt 0.02 "
     "--env.sim.substeps 4 --terrains rugged --rounds 1000 --out DIR --no-progress",
     "the fixed CPG in the complex task's physics, on each course beside them"),
    ("python -m hexnewton.apps.export --checkpoint BETTER.pt --robot mx_phoenix --out BUNDLE",
     "beside them, the result better on its validation rounds (`build.py --better`)"),
    ("python -m hexnewton.apps.sim2sim BUNDLE --robot mx_phoenix --terrains rugged stepped complex --rounds 100 "
     "--newton none --workers 12 --out DIR", "its bundle in C MuJoCo on 12 of the host's cores"),
)


def build(study: str = HERE) -> dict:
    leases = collect(study)
    results = {"command": "python studies/any_hexapod/build.py", "robot": ROBOT, "measured": bool(leases),
               "status": "measured" if leases else "not measured yet", "commands": list(COMMANDS),
               "queue": list(QUEUE_STEPS), "leases": leases, "verdict": verdict(leases)}  # fmt: skip
    with open(os.path.join(study, "results.json"), "w") as f:
        json.dump(results, f, indent=1)
    with open(os.path.join(study, "report.md"), "w") as f:
        f.write(report(results))
    return results


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter,
                                allow_abbrev=False)  # fmt: skip
    p.add_argument("--add", metavar="LEASE", help="a lease's unpacked folder (queue.sh collect)")
    p.add_argument("--name", help="the lease's name in the study (default: its date)")
    p.add_argument("--better", nargs="*", metavar="NAME=TIMING", help="print the name of the result better on its "
                   "validation rounds (queue.sh's sim2sim choice) and exit")
    a = p.parse_args(argv)
    if a.better is not None:
        print(better(dict(pair.split("=", 1) for pair in a.better)))
        return 0
    if a.add:
        if not os.path.isdir(a.add):
            print(f"build.py: {a.add} is not a folder", file=sys.stderr)
            return 2
        print(f"added lease {add(a.add, a.name)}")
    results = build()
    said = (results["verdict"] or {}).get("overall", "not measured yet")
    print(f"{len(results['leases'])} lease(s); verdict: {said}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
