"""The learner study (studies/learner): the complex recipe's learner changes one at a time, each arm on two seeds in
the same lease, judged on validation rounds (seed 3000) by the deterministic action.

    python studies/learner/build.py --add LEASE       # a lease's runs and evaluations into the study, then the report
    python studies/learner/build.py                   # results.json and report.md from what the study holds

LEASE holds what ``studies/device/learner.sh collect`` brings back (``cat learner.tgz.* | tar xzf - -C LEASE``):
``runs/NAME.log`` with its run folder (``runs/NAME/<date_time>/{config.json,timing.json,model_result.pt}``, or
``runs/<date_time>/`` as ``gpu.sh pack`` writes it) and ``evals/JOB/results.json`` (``JOB``: ``NAME_TERRAIN`` for a
run's result, ``shipped_TERRAIN`` / ``STEM_shipped_TERRAIN`` for the shipped policy beside the fixed CPG on the
validation / test rounds). The gate's runs are ``gate_s1`` ... ``gate_s3``. The study keeps
per run its console log, config, timing and the result's actor (``runs/NAME/``), and per evaluation its report; the
tracked tree holds results.json, report.md, the runs' configs and timings and the gates' actors (README, Raw runs).
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
#: each arm's train.py flags beside ``--task complex`` (studies/device/learner.sh reads them: ``--flags ARM``)
ARM_FLAGS = {"recipe": "", "critic": "--env.obs.critic true",
             "actor": "--env.obs.gyro true --env.obs.last_action true",
             "both": "--env.obs.critic true --env.obs.gyro true --env.obs.last_action true",
             # the shipped policy's schedule (hexnewton/tasks LONG_STABLE_STAGES): 1062 iterations, stages at 382, 744
             "long": "--max_iterations 1062 --agent.stages ((382,{'posture_reflex':2.0,'w_tilt':15.0,'w_ang_vel':0.1}),"
                     "(744,{'w_tilt':40.0,'w_ang_vel':0.3}))",
             "envs8192": "--num_envs 8192",
             # the last stage's PPO steps smaller (KL target 0.004, the recipe's 0.01) and without the entropy bonus
             "settle": "--agent.stages ((100,{'posture_reflex':2.0,'w_tilt':15.0,'w_ang_vel':0.1}),"
                       "(200,{'w_tilt':40.0,'w_ang_vel':0.3,'desired_kl':0.004,'entropy_coef':0.0}))",
             # the last stage saved every 10 iterations, 8 candidates validated (the recipe: every 50, at most 4)
             "candidates": "--agent.save_interval 10 --agent.validation_candidates 8",
             # each candidate on 1024 rounds per course, not 256: the falls line (0.5 %) within the estimate's noise
             "rounds1024": "--agent.validation_rounds 1024",
             # the rugged and stepped courses' lanes beside the complex course's: a third of the envs on each
             "courses": "--env.terrain.lane_courses rugged stepped",
             # the networks' float32 matrix products on TF32 tensor cores (studies/throughput/tf32: +10 % at 16384 envs)
             "tf32": "--agent.tf32 true",
             # the three validation courses side by side in one env, not one env per course one after another
             "together": "--agent.validation_together true"}
#: each arm in words, with its flags
ARMS = {arm: f"{what} (`{ARM_FLAGS[arm] or '--task complex'}`)" for arm, what in (
    ("recipe", "the complex recipe"), ("critic", "+ the asymmetric critic"),
    ("actor", "+ the gyro and the last actions in the actor's observation"),
    ("both", "+ the asymmetric critic and the actor's gyro and last actions together"),
    ("long", "the shipped policy's schedule: 1062 iterations, the stages at 382 and 744 (3.5x the env-steps)"),
    ("envs8192", "8192 envs at the same 300 iterations (2x the env-steps)"),
    ("settle", "the last stage (iterations 200-299) with smaller PPO steps: KL target 0.004 and no entropy bonus"),
    ("candidates", "the last stage saved every 10 iterations and 8 of its checkpoints validated (validation time x2)"),
    ("rounds1024", "each candidate validated on 1024 rounds per course, not 256 (the choice's noise: at 256 rounds a "
                   "1 % fall share has a standard error of 0.6 points)"),
    ("courses", "the rugged and stepped courses trained beside the complex one (a lane group each, a third of the envs "
                "on each; what it trains on, not what it sees): validation and the gate walk all three"),
    ("tf32", "the networks' float32 matrix products on TF32 tensor cores, not in full float32 (a speed switch: the "
             "gate asks whether it may become the default)"),
    ("together", "the validation's three courses side by side in one env (a lane group each, its own block seed): "
                 "38 s against 69 s one by one on an H100, studies/throughput/validation (a speed switch: the gate "
                 "asks whether it may become the default)"))}
TERRAINS = ("rugged", "stepped", "complex")
METRICS = ("success_3m", "fall_rate", "fall_rate_before_goal", "pitch_var_deg2", "roll_var_deg2")
#: the gate's lines (1000 test rounds per terrain, deterministic action)
GATE = {"success_3m_min": 0.975, "fall_rate_before_goal_max": 0.005, "rugged_var_vs_fixed_cpg": 0.8, "wall_s_max": 240}
CANDIDATE = re.compile(r"^\s*(->)?\s*(model_\w+\.pt) \((.+?), iteration (\d+)\): goal ([\d.]+) %, fell before the goal "
                       r"([\d.]+) % \(in all ([\d.]+) %\), 3 m ([\d.]+) %, off course ([\d.]+) %, pitch / roll var "
                       r"([\d.]+) / ([\d.]+) deg")


def parse_log(text: str) -> dict:
    """A train.py console log: its validation candidates (shares averaged over the courses), the choice, the times."""
    out: dict = {"candidates": []}
    for line in text.splitlines():
        m = CANDIDATE.match(line)
        if m:
            out["candidates"].append({"file": m[2], "kind": m[3], "iteration": int(m[4]), "chosen": bool(m[1]),
                                      "goal": float(m[5]) / 100, "fell_before_goal": float(m[6]) / 100,
                                      "fell": float(m[7]) / 100, "walk_3m": float(m[8]) / 100,
                                      "off_course": float(m[9]) / 100, "pitch_var": float(m[10]),
                                      "roll_var": float(m[11])})  # fmt: skip
        elif m := re.match(r"finished at iteration \d+ after (\d+) s \((\d+) iterations\)", line):
            out["train_s"], out["iterations"] = float(m[1]), int(m[2])
        elif m := re.match(r"(\d+) s from process start to the exported result", line):
            out["wall_s"] = float(m[1])
        elif m := re.match(r"start-up ([\d.]+) s from process start", line):
            out["startup_s"] = float(m[1])
        elif m := re.match(r"deterministic validation, (\d+) rounds of the (.+) courses .* per candidate, (\d+) s", line):
            out["validation_rounds"], out["validation_s"] = int(m[1]), float(m[3])
        elif m := re.match(r"training task (\S+): (\d+) envs on (\S+), .* logs in (\S+)", line):
            out["task"], out["num_envs"], out["run_dir"] = m[1], int(m[2]), m[4]
    return out


def add(lease: str) -> list[str]:
    """Copy a lease's runs and evaluations into the study; returns the run names added."""
    from hexnewton.learning.checkpoint import save_policy_only

    added = []
    for log in sorted(glob.glob(os.path.join(lease, "runs", "*.log"))):
        name = os.path.basename(log)[:-4]
        text = open(log).read()
        info = parse_log(text)
        if not info.get("candidates"):
            print(f"{name}: no validation in its log, skipped", file=sys.stderr)
            continue
        date = os.path.basename(info["run_dir"])  # gpu.sh pack: runs/DATE; learner.sh collect: runs/NAME/DATE
        run = next((d for d in (os.path.join(lease, "runs", name, date), os.path.join(lease, "runs", date))
                    if os.path.isdir(d)), os.path.join(lease, "runs", date))
        dst = os.path.join(HERE, "runs", name)
        os.makedirs(dst, exist_ok=True)
        shutil.copy(log, os.path.join(dst, "train.log"))
        for f in ("config.json", "timing.json"):
            if os.path.exists(os.path.join(run, f)):
                shutil.copy(os.path.join(run, f), os.path.join(dst, f))
        if os.path.exists(os.path.join(run, "model_result.pt")):
            save_policy_only(os.path.join(run, "model_result.pt"), os.path.join(dst, "policy.pt"))
        added.append(name)
    for res in sorted(glob.glob(os.path.join(lease, "evals", "*", "results.json"))):
        job = os.path.dirname(res)
        dst = os.path.join(HERE, "evals", os.path.basename(job))
        os.makedirs(dst, exist_ok=True)
        for f in ("results.json", "report.md"):
            shutil.copy(os.path.join(job, f), os.path.join(dst, f))
    return added


WORD = {True: "yes", False: "**no**", None: "not measured"}
#: the references of test rounds not measured yet
NO_REF = {"shipped": {}, "fixed_cpg": {}}


def _metrics(s: dict) -> dict:
    return {k: s.get(k) for k in METRICS}


def run_entry(name: str, log: str, timing: str, lease: dict) -> dict:
    """One run's numbers from its console log (and its timing.json where kept)."""
    arm, seed = name.rsplit("_s", 1)
    info = parse_log(open(log).read())
    per_course = json.load(open(timing)).get("validation", {}).get("courses") if os.path.exists(timing) else None
    goals = [c["goal"] for c in info["candidates"] if c["file"] != "model_average.pt"] or [0.0]
    chosen = next((c["file"] for c in info["candidates"] if c["chosen"]), None)
    return {"arm": arm, "seed": int(seed), "device": lease.get("device"), "wall_s": info.get("wall_s"),
           "train_s": info.get("train_s"), "startup_s": info.get("startup_s"),
           "s_per_iteration": round(info["train_s"] / info["iterations"], 3) if "train_s" in info else None,
           "gpu_shared_with": lease.get("runs_beside", {}).get(name),
           "validation": {"rounds_per_course": info.get("validation_rounds"),
                          "seconds": info.get("validation_s"), "candidates": info["candidates"],
                          "per_course": per_course,
                          "goal_spread": round(max(goals) - min(goals), 4), "chosen": chosen,
                 "average": next(({"goal": c["goal"], "fell_before_goal": c["fell_before_goal"],
                                   "chosen": c["chosen"]} for c in info["candidates"]
                                  if c["file"] == "model_average.pt"), None)},
           "result_on_validation": {}, "result_on_test": {}}  # fmt: skip


def study_runs(leases: list[dict]) -> dict:
    """The study's kept runs (``runs/NAME/train.log``), each with the lease that ran it."""
    runs = {}
    for log in sorted(glob.glob(os.path.join(HERE, "runs", "*", "train.log"))):
        name = os.path.basename(os.path.dirname(log))
        lease = next((le for le in leases if name in le["runs"]), {})
        runs[name] = run_entry(name, log, os.path.join(os.path.dirname(log), "timing.json"), lease)
    return runs


def kept_runs() -> dict:
    """The study's runs as the arms' choice reads them: parsed from the kept console logs (``study_runs``) where the
    tree holds every one; else, the raw runs having left the tree, the committed results.json's ``runs``
    (the numbers build.py parsed from those logs)."""
    if not raw_missing() and glob.glob(os.path.join(HERE, "runs", "*", "train.log")):
        return study_runs([])
    with open(os.path.join(HERE, "results.json")) as f:
        return json.load(f)["runs"]


def raw_missing() -> str:
    """'' when every kept run (``runs/NAME/``) has its console log; else the first run folder without one."""
    for d in sorted(glob.glob(os.path.join(HERE, "runs", "*", ""))):
        if not os.path.isfile(os.path.join(d, "train.log")):
            return os.path.relpath(os.path.join(d, "train.log"), HERE)
    return ""


def collect() -> dict:
    leases = json.load(open(os.path.join(HERE, "leases.json")))
    runs = study_runs(leases)
    # the validation rounds' references are shared; each gate's test rounds have their own, measured in its lease
    # (``STEM_shipped``: the same policy's rounds differ between machines and code revisions)
    fixed: dict = {"validation": {k: {} for k in NO_REF}, "test": {}}
    for res in sorted(glob.glob(os.path.join(HERE, "evals", "*", "results.json"))):
        job = os.path.basename(os.path.dirname(res))
        d = json.load(open(res))
        name, terrain = job.rsplit("_", 1)
        rows, rounds = d["results"][terrain], d["meta"]["rounds"]
        test = d["meta"]["terrain_seed"] != 3000  # validation rounds: seed 3000; the rest are test rounds
        if name == "shipped" or name.endswith("_shipped"):
            ref = fixed["validation"] if not test else fixed["test"].setdefault(
                name[:-len("_shipped")], {k: {} for k in NO_REF})
            ref["shipped"][terrain] = {**_metrics(rows["cpg_rl"]), "rounds": rounds}
            ref["fixed_cpg"][terrain] = {**_metrics(rows["cpg"]), "rounds": rounds,
                                         "physics": d["meta"]["fixed_cpg_physics"]}
        elif name in runs:
            runs[name]["result_on_test" if test else "result_on_validation"][terrain] = {**_metrics(rows["cpg_rl"]),
                                                                                     "rounds": rounds}
    arms = summarise(runs)
    return {"meta": {"task": "complex", "validation_seed": 3000, "actions": "deterministic (mean)",
                     "arms": ARMS, "leases": leases, "gate_lines": GATE}, "runs": runs, "arms": arms,
            "same_rounds": fixed, "gates": gates(runs, fixed["test"]), "choice_noise": choice_noise(runs),
            "falls_line": falls_line(runs, fixed), "seed_lines": seed_lines(runs)}


def choice_noise(runs: dict, terrain: str = "rugged") -> dict:
    """Per run: its chosen candidate's falls before the goal on ``terrain`` in train.py's validation (the rounds it was
    chosen on) against the same checkpoint's evaluation on that course afterwards (``result_on_validation``, the same
    seed); and the means. A choice among noisy estimates is optimistic on the one it picks."""
    rows = {}
    for name, r in runs.items():
        per, cands, after = r["validation"]["per_course"], r["validation"]["candidates"], r["result_on_validation"]
        if not per or terrain not in per or terrain not in after or len(per[terrain]) != len(cands):
            continue
        chosen = next(i for i, c in enumerate(cands) if c["chosen"])
        rows[name] = {"chosen_on": {"rounds": per[terrain][chosen]["rounds"],
                                    "fell_before_goal": per[terrain][chosen]["fell_before_goal"]},
                      "evaluated": {"rounds": after[terrain]["rounds"],
                                    "fall_rate_before_goal": after[terrain]["fall_rate_before_goal"]}}
    mean = (lambda xs: round(sum(xs) / len(xs), 4)) if rows else (lambda xs: None)
    return {"terrain": terrain, "runs": rows,
            "mean_chosen_on": mean([x["chosen_on"]["fell_before_goal"] for x in rows.values()]),
            "mean_evaluated": mean([x["evaluated"]["fall_rate_before_goal"] for x in rows.values()]),
            "higher_when_evaluated": sum(x["evaluated"]["fall_rate_before_goal"] > x["chosen_on"]["fell_before_goal"]
                                         for x in rows.values())}


def falls_line(runs: dict, fixed: dict) -> dict:
    """Per course: how many of the study's results (every arm's and gate's run, on the validation rounds) fall before
    the goal in no more than the gate's share of the rounds, which, and the shipped policy's share on the same rounds
    and on the recipe's gate's test rounds. The gate asks it of all three seeds at once."""
    line, out = GATE["fall_rate_before_goal_max"], {}
    for t in TERRAINS:
        got = {n: r["result_on_validation"][t]["fall_rate_before_goal"] for n, r in runs.items()
               if t in r["result_on_validation"]}
        met = sorted(n for n, v in got.items() if v <= line)
        shipped = {k: ref["shipped"].get(t, {}).get("fall_rate_before_goal")
                   for k, ref in (("validation", fixed["validation"]), ("test", fixed["test"].get("gate", NO_REF)))}
        out[t] = {"results": len(got), "met": met, "share_met": round(len(met) / len(got), 4) if got else None,
                  "shipped_validation": shipped["validation"], "shipped_test": shipped["test"]}
    return {"line": line, "courses": out}


def seed_lines(runs: dict) -> dict:
    """The gate's lines for one seed, on the validation rounds: which results (those evaluated on every course) reach
    3 m in at least the gate's share on every course, which fall before the goal in at most its share on every course,
    and which do both."""
    done = {n: r["result_on_validation"] for n, r in runs.items() if len(r["result_on_validation"]) == len(TERRAINS)}
    success = sorted(n for n, v in done.items() if all(x["success_3m"] >= GATE["success_3m_min"] for x in v.values()))
    falls = sorted(n for n, v in done.items()
                   if all(x["fall_rate_before_goal"] <= GATE["fall_rate_before_goal_max"] for x in v.values()))
    return {"results": len(done), "success": success, "falls": falls, "both": sorted(set(success) & set(falls))}


def gates(runs: dict, test: dict) -> dict:
    """Every gate the study ran (``gate``: the recipe's; ``gate_ARM-ARM``: with those arms' flags), as ``gate``,
    each against the references of its own test rounds (``test[stem]``)."""
    stems = sorted({r["arm"] for r in runs.values() if is_gate(r["arm"])})
    return {stem: g for stem in stems if (g := gate(runs, test.get(stem, NO_REF), stem)) is not None}


def summarise(runs: dict) -> dict:
    """Per arm: its seeds, the chosen candidates' goal share and falls before the goal line, the candidates' spread."""
    arms = {}
    for arm in ARMS:
        mine = [r for r in runs.values() if r["arm"] == arm]
        if not mine:
            continue
        # the arms compare on the checkpoints train.py saves: a weight-averaged candidate (--agent.validation_average)
        # is left out here and reported apart (``average``)
        chosen = [plain_choice(r["validation"]["candidates"]) for r in mine]
        arms[arm] = {"label": ARMS[arm], "seeds": sorted(r["seed"] for r in mine),
                     "chosen_goal": [c["goal"] for c in chosen],
                     "chosen_fell_before_goal": [c["fell_before_goal"] for c in chosen],
                     "goal_spread": [r["validation"]["goal_spread"] for r in mine],
                     "mean_chosen_goal": round(sum(c["goal"] for c in chosen) / len(chosen), 4),
                     "mean_chosen_fell_before_goal": round(sum(c["fell_before_goal"] for c in chosen) / len(chosen),
                                                           4)}  # fmt: skip
    return arms


def plain_choice(cands: list[dict]) -> dict:
    """train.py's choice among the saved checkpoints alone: the most goals, then the fewest falls before the goal."""
    plain = [c for c in cands if c["file"] != "model_average.pt"]
    return max(plain, key=lambda c: (c["goal"], -c["fell_before_goal"]))


def pays(arm: dict, base: dict) -> bool:
    """A change pays when its chosen candidates reach the goal more often and fall before the goal line no more."""
    return arm["mean_chosen_goal"] > base["mean_chosen_goal"] and (
        arm["mean_chosen_fell_before_goal"] <= base["mean_chosen_fell_before_goal"])


def complete(arm: dict, base: dict) -> bool:
    """An arm is judged once it ran on every seed the recipe ran on: a lead on fewer seeds is reported, not chosen."""
    return set(base["seeds"]) <= set(arm["seeds"])


def _line(values: list, ok) -> bool | None:
    """One gate line over the three seeds' values: None (not measured) while a seed's value is missing."""
    return None if len(values) < 3 or None in values else bool(ok(values))


def gate(runs: dict, test: dict, stem: str = "gate") -> dict | None:
    """The gate's lines over its runs (``STEM_sN``, ``gate_name``) on the test rounds, against the shipped policy and
    the fixed CPG on the same rounds: each line True, False, or None where a seed's result (or the reference) is not
    measured yet; ``holds`` is None while no line fails and some are not measured. None before any of its runs was
    evaluated."""
    seeds = {r["seed"]: r for r in runs.values() if r["arm"] == stem and r["result_on_test"]}
    if not seeds:
        return None
    lines = {}
    for t in TERRAINS:
        got = [r["result_on_test"].get(t, {}).get("success_3m") for r in seeds.values()]
        falls = [r["result_on_test"].get(t, {}).get("fall_rate_before_goal") for r in seeds.values()]
        shipped = test["shipped"].get(t, {}).get("success_3m")
        lines[f"every seed >= 97.5 % at 3 m, {t}"] = _line(got, lambda v: min(v) >= GATE["success_3m_min"])
        lines[f"median >= the shipped policy's, {t}"] = None if shipped is None else _line(
            got, lambda v: sorted(v)[1] >= shipped)
        lines[f"falls before the goal <= 0.5 %, {t}"] = _line(
            falls, lambda v: max(v) <= GATE["fall_rate_before_goal_max"])
    cpg = test["fixed_cpg"].get("rugged", {})
    for v in ("pitch_var_deg2", "roll_var_deg2"):
        vals = [r["result_on_test"].get("rugged", {}).get(v) for r in seeds.values()]
        lines[f"rugged {v.split('_')[0]} variance < 0.8x the fixed CPG's"] = None if cpg.get(v) is None else _line(
            vals, lambda x, v=v: all(y < GATE["rugged_var_vs_fixed_cpg"] * cpg[v] for y in x))
    lines["<= 240 s from process start, validation included"] = _line(
        [r["wall_s"] for r in seeds.values()], lambda v: max(v) <= GATE["wall_s_max"])
    states = set(lines.values())
    arms = gate_arms(stem)
    return {"seeds": sorted(seeds), "arms": arms, "flags": arms_flags(arms), "lines": lines,
            "holds": False if False in states else None if None in states else True}


def paid_arms(run_dirs: list[str]) -> list[str]:
    """The changes that paid: the study's runs (``kept_runs``) and those of ``run_dirs`` (NAME.log each), against the
    recipe."""
    runs = kept_runs()
    for d in run_dirs:
        for log in sorted(glob.glob(os.path.join(d, "*_s[0-9].log"))):
            name = os.path.basename(log)[:-4]
            if name.rsplit("_s", 1)[0] in ARMS and parse_log(open(log).read())["candidates"]:
                runs[name] = run_entry(name, log, "", {})
    arms = summarise(runs)
    if "recipe" not in arms:
        raise ValueError("the study holds no recipe runs to compare with")
    return paying(arms)


def paying(arms: dict) -> list[str]:
    """The arms of ``summarise`` that ran on the recipe's seeds and paid against it (none without recipe runs)."""
    base = arms.get("recipe")
    return [a for a in ARM_FLAGS if a != "recipe" and a in arms and base is not None and complete(arms[a], base)
            and pays(arms[a], base)]


def arms_flags(arms: list[str]) -> str:
    """The train.py flags of these arms together, each flag with its values once (arms may share flags)."""
    flags: list[list[str]] = []
    for word in " ".join(ARM_FLAGS[a] for a in arms).split():
        if word.startswith("--"):
            flags.append([word])
        else:
            flags[-1].append(word)
    return " ".join(dict.fromkeys(" ".join(f) for f in flags))


def choose(run_dirs: list[str]) -> str:
    """The train.py flags of the changes that paid (``paid_arms``)."""
    return arms_flags(paid_arms(run_dirs))


def gate_name(arms: list[str]) -> str:
    """The gate's run names' stem for these arms: ``gate`` for the recipe itself, else ``gate_ARM-ARM``."""
    return "gate_" + "-".join(arms) if arms else "gate"


def is_gate(name: str) -> bool:
    """Whether a run name's stem is a gate's (``gate_name``)."""
    return name == "gate" or name.startswith("gate_")


def gate_arms(name: str) -> list[str]:
    """The arms a gate's stem names (``gate_name``'s inverse): unknown arms raise ValueError."""
    arms = name.split("_", 1)[1].split("-") if "_" in name else []
    unknown = [a for a in arms if a not in ARM_FLAGS]
    if not is_gate(name) or unknown:
        raise ValueError(f"{name} is not a gate of known arms")
    return arms


def pct(x) -> str:
    return "—" if x is None else f"{100 * x:.1f} %"


def terrain_rows(rows: list[tuple[str, dict]], rounds: bool) -> list[str]:
    """A table's rows per policy and terrain: 3 m, falls before the goal, falls, pitch / roll variance; with
    ``rounds`` the rounds' column, and a row saying "not run" where a terrain has no result (else none)."""
    out = []
    for name, per in rows:
        for t in TERRAINS:
            s = per.get(t)
            if s is None:
                if rounds:
                    out.append(f"| {name} | {t} | — | not run | | | |")
                continue
            out.append(f"| {name} | {t} | " + (f"{s['rounds']} | " if rounds else "") + f"{pct(s['success_3m'])} | "
                       f"{pct(s['fall_rate_before_goal'])} | {pct(s['fall_rate'])} | {s['pitch_var_deg2']:.1f} / "
                       f"{s['roll_var_deg2']:.1f} |")
    return out


def report(res: dict) -> str:
    runs, arms, fixed = res["runs"], res["arms"], res["same_rounds"]
    lines = ["# The learner, one change at a time", "",
             "Generated by `python studies/learner/build.py` from `results.json`. Task `complex` (300 iterations at "
             "4096 envs, its stable-gait stages), each arm on seeds 1 and 2 in the same lease; train.py's own "
             "validation (deterministic action, seed 3000, the rugged, stepped and complex courses, candidates ranked "
             "by goal reached, then falls before the goal line) chooses each run's result. "
             "The arms:", ""]
    lines += [f"- `{a}`: {label}" for a, label in ARMS.items()]
    lines += ["", "## Validation candidates (train.py, shares averaged over the three courses)", "",
              "| run | candidate | goal | fell before the goal (in all) | 3 m | off course | pitch / roll var [deg²] |",
              "|---|---|---:|---:|---:|---:|---:|"]
    for name, r in runs.items():
        for c in r["validation"]["candidates"]:
            lines.append(f"| {name} | {'**' if c['chosen'] else ''}{c['file']}{'**' if c['chosen'] else ''} | "
                         f"{pct(c['goal'])} | {pct(c['fell_before_goal'])} ({pct(c['fell'])}) | {pct(c['walk_3m'])} | "
                         f"{pct(c['off_course'])} | {c['pitch_var']:.1f} / {c['roll_var']:.1f} |")
    lines += ["", "Per arm: the chosen candidates' goal share and the spread of goal over each run's candidates:", "",
              "| arm | seeds | chosen: goal | chosen: fell before the goal | spread of goal over candidates |",
              "|---|---|---|---|---|"]
    for a, s in arms.items():
        lines.append(f"| {a} | {', '.join(map(str, s['seeds']))} | {' / '.join(pct(g) for g in s['chosen_goal'])} "
                     f"(mean {pct(s['mean_chosen_goal'])}) | {' / '.join(pct(g) for g in s['chosen_fell_before_goal'])}"
                     f" | {' / '.join(pct(g) for g in s['goal_spread'])} |")
    lines += ["", "## The results on validation rounds, per course", "",
              "Deterministic action, seed 3000, `python -m hexnewton.apps.evaluate --controllers cpg_rl --checkpoint "
              "cpg_rl=RESULT --terrains T --rounds 500 --seed 3000`; the shipped policy and the fixed CPG (on the "
              "shipped policy's physics: 20 ms frame, 4 substeps) on the same rounds.", "",
              "| policy | terrain | rounds | 3 m | falls before the goal | falls | pitch / roll var [deg²] |",
              "|---|---|---:|---:|---:|---:|---:|"]
    val = fixed["validation"]
    rows = [(n, r["result_on_validation"]) for n, r in runs.items() if r["arm"] in ARMS] + [
        ("shipped `cpg_rl_complex`", val["shipped"]), ("fixed CPG", val["fixed_cpg"])]
    lines += terrain_rows(rows, rounds=True)
    for stem, g in res["gates"].items():
        test = fixed["test"].get(stem, NO_REF)
        command = " ".join(["python train.py --task complex --seed N"] + ([g["flags"]] if g["flags"] else []))
        lines += ["", f"## {gate_title(g)}", "", f"`{command}`"
                  f" (runs `{stem}_sN`), one after another and alone on the GPU; 1000 test rounds per terrain "
                  "(the evaluate default seed), deterministic action, the shipped policy and the fixed CPG on the "
                  "same rounds in the same lease.", "",
                  "| policy | terrain | 3 m | falls before the goal | falls | pitch / roll var [deg²] |",
                  "|---|---|---:|---:|---:|---:|"]
        rows = [(n, r["result_on_test"]) for n, r in runs.items() if r["arm"] == stem] + [
            ("shipped `cpg_rl_complex`", test["shipped"]), ("fixed CPG", test["fixed_cpg"])]
        lines += terrain_rows(rows, rounds=False)
        lines += ["", "| line | holds |", "|---|---|"] + [f"| {k} | {WORD[v]} |" for k, v in g["lines"].items()]
    noise = res["choice_noise"]
    if noise["runs"]:
        lines += ["", "## The choice's noise", "",
                  f"Each run's chosen candidate, falls before the goal on the {noise['terrain']} course: on the "
                  "validation rounds train.py chose it on, and on the rounds of the same course and seed it was then "
                  "evaluated on (the table above; evaluate's rounds and train.py's are drawn alike from seed 3000, so "
                  "the two sets may share rounds).", "",
                  "| run | chosen on: rounds | falls before the goal | evaluated: rounds | falls before the goal |",
                  "|---|---:|---:|---:|---:|"]
        lines += [f"| {n} | {x['chosen_on']['rounds']} | {pct(x['chosen_on']['fell_before_goal'])} | "
                  f"{x['evaluated']['rounds']} | {pct(x['evaluated']['fall_rate_before_goal'])} |"
                  for n, x in noise["runs"].items()]
    lines += ["", "## Time", "",
              "| run | device | GPU shared with | start-up [s] | train [s] | s / iteration | validation [s] | "
              "process start to result [s] |", "|---|---|---|---:|---:|---:|---:|---:|"]
    for name, r in runs.items():
        lines.append(f"| {name} | {r['device']} | {r['gpu_shared_with'] or 'nothing'} | {r['startup_s']} | "
                     f"{r['train_s']} | {r['s_per_iteration']} | {r['validation']['seconds']} | {r['wall_s']} |")
    lines += ["", "## Leases", ""]
    for le in res["meta"]["leases"]:
        lines += [f"- {le['date']}, {le['device']}: {le['ran']}", f"  - commands: " + "; ".join(
            f"`{c}`" for c in le["commands"]), f"  - {le['notes']}"]
    return "\n".join(lines[:2] + verdict(res) + lines[2:]) + "\n"


def gate_title(g: dict) -> str:
    """A gate in words: the recipe's, or the one with the arms that paid."""
    return "The gate" + (f" with {' + '.join(f'`{a}`' for a in g['arms'])}" if g["arms"] else " for the recipe")


def against_recipe(runs: dict, stem: str, g: dict, recipe: dict, terrain: str = "rugged") -> str:
    """A gate's failing lines against the recipe's gate's, and its seeds' falls on ``terrain`` beside the recipe's
    (each seed's share of the test rounds that ended in a fall anywhere, and before the goal)."""
    fails = {k for k, v in g["lines"].items() if v is False}
    theirs = {k for k, v in recipe["lines"].items() if v is False}

    def falls(arm: str, key: str) -> str:
        seeds = sorted((r["seed"], r["result_on_test"].get(terrain, {}).get(key)) for r in runs.values()
                       if r["arm"] == arm)
        return " / ".join("—" if v is None else f"{100 * v:.1f}" for _, v in seeds) + " %"

    other = sorted(fails - theirs)
    return (f"- **{gate_title(g)} against the recipe's**: {len(fails & theirs)} of the recipe's {len(theirs)} failing "
            "lines fail, " + (f"{len(other)} other ({'; '.join(other)})" if other else "no other")
            + f"; on the {terrain} course its seeds fall in {falls(stem, 'fall_rate')} of the test rounds against "
            f"{falls('gate', 'fall_rate')} (before the goal {falls(stem, 'fall_rate_before_goal')} against "
            f"{falls('gate', 'fall_rate_before_goal')}).")


def verdict(res: dict) -> list[str]:
    """Each change against the recipe, from results.json: the chosen candidates' goal share (the validation's first
    key), their falls before the goal line (its second) and the candidates' spread; what the study still lacks."""
    runs, arms = res["runs"], res["arms"]
    out = ["## Verdict", "", "Written by `build.py` from `results.json` (`arms`, `runs`):", ""]
    base = arms.get("recipe")
    for arm, s in arms.items():
        if arm == "recipe" or base is None:
            continue
        goal = s["mean_chosen_goal"] - base["mean_chosen_goal"]
        falls = s["mean_chosen_fell_before_goal"] - base["mean_chosen_fell_before_goal"]
        spread = sum(s["goal_spread"]) / len(s["seeds"]) - sum(base["goal_spread"]) / len(base["seeds"])
        word = "pays" if pays(s, base) else "does not pay" if goal < 0 else "is even"
        seeds = ", ".join(map(str, s["seeds"]))
        if not complete(s, base):
            word = {"pays": "leads", "does not pay": "trails", "is even": "is even so far"}[word]
            seeds += f"; partial, the recipe ran on {len(base['seeds'])}"
        out.append(f"- **`{arm}` {word} on validation** (seeds {seeds}): the chosen "
                   f"candidates reach the goal in {pct(s['mean_chosen_goal'])} of the validation rounds against the "
                   f"recipe's {pct(base['mean_chosen_goal'])} ({100 * goal:+.1f} points), fall before the goal line "
                   f"{100 * falls:+.1f} points against it, and its candidates spread {100 * spread:+.1f} points more "
                   f"in goal share within a run.")
    averaged = [(n, r) for n, r in runs.items() if r["validation"]["average"] is not None]
    if averaged:
        won = [n for n, r in averaged if r["validation"]["average"]["chosen"]]
        gain = [r["validation"]["average"]["goal"] - plain_choice(r["validation"]["candidates"])["goal"]
                for _, r in averaged]
        out.append(f"- **The weight average of the last stage's candidates** (`--agent.validation_average true`) is "
                   f"chosen in {len(won)} of {len(averaged)} runs ({', '.join(won) or 'none'}); its goal share against "
                   f"the best saved checkpoint's: {', '.join(f'{100 * g:+.1f}' for g in gain)} points.")
    for g in res["gates"].values():
        lines = g["lines"]
        failed = [k for k, v in lines.items() if v is False]
        unmeasured = [k for k, v in lines.items() if v is None]
        head = {True: "holds**", False: "does not hold**", None: "is partial**"}[g["holds"]]
        out.append(f"- **{gate_title(g)} {head} (seeds {', '.join(map(str, g['seeds']))}): "
                   f"{len(lines) - len(unmeasured)} of {len(lines)} lines measured"
                   + (f"; fails: {'; '.join(failed)}" if failed else "")
                   + (f"; not measured yet: {'; '.join(unmeasured)}" if unmeasured else "") + ".")
    recipe = res["gates"].get("gate")
    for stem, g in res["gates"].items():
        if stem != "gate" and recipe is not None:
            out.append(against_recipe(runs, stem, g, recipe))
    paid = paying(arms)
    if paid and gate_name(paid) not in res["gates"]:
        worst = []   # each paid arm's results on the validation rounds, against the gate's falls line
        for a in paid:
            for t in TERRAINS:
                got = [r["result_on_validation"][t] for r in runs.values()
                       if r["arm"] == a and t in r["result_on_validation"]]
                if got and max(g["fall_rate_before_goal"] for g in got) > GATE["fall_rate_before_goal_max"]:
                    worst.append(f"`{a}` falls before the goal in "
                                 f"{' / '.join(pct(g['fall_rate_before_goal']) for g in got)} of the "
                                 f"{' / '.join(str(g['rounds']) for g in got)} {t} validation rounds")
        named = " + ".join(f"`{a}`" for a in paid)
        out.append(f"- **Not run yet: the gate with {named}** (runs `{gate_name(paid)}_sN`: "
                   "`python train.py --task complex --seed N` with their flags)"
                   + (f"; {'; '.join(worst)}, above the gate's "
                      f"{pct(GATE['fall_rate_before_goal_max'])}." if worst else "."))
    fl = res.get("falls_line") or {"courses": {}}
    for t, c in fl["courses"].items():
        if not c["results"] or c["share_met"] > 0.5:
            continue
        out.append(f"- **The falls line on the {t} course is rarely met**: {len(c['met'])} of {c['results']} results "
                   f"fall before the goal in at most {pct(fl['line'])} of their validation rounds "
                   f"({', '.join(c['met']) or 'none'}); the gate asks it of three seeds at once (seeds meeting it "
                   f"independently at that share: {100 * c['share_met'] ** 3:.2f} % of gates). The shipped policy: "
                   f"{pct(c['shipped_validation'])} on the same rounds, {pct(c['shipped_test'])} on the test rounds.")
    sl = res.get("seed_lines")
    if sl and sl["results"]:
        out.append(f"- **One seed's lines, on the validation rounds**: of {sl['results']} results, "
                   f"{len(sl['success'])} reach 3 m in at least {pct(GATE['success_3m_min'])} of the rounds on every "
                   f"course ({', '.join(sl['success']) or 'none'}), {len(sl['falls'])} fall before the goal in at most "
                   f"{pct(GATE['fall_rate_before_goal_max'])} on every course ({', '.join(sl['falls']) or 'none'}), "
                   f"{len(sl['both'])} do both ({', '.join(sl['both']) or 'none'}); the gate asks both of every seed.")
    noise = res["choice_noise"]
    if noise["runs"]:
        first = next(iter(noise["runs"].values()))
        out.append(f"- **The choice is optimistic**: on the {noise['terrain']} course the chosen candidates fall "
                   f"before the goal in {pct(noise['mean_chosen_on'])} of the rounds they were chosen on (mean over "
                   f"{len(noise['runs'])} runs) and in {pct(noise['mean_evaluated'])} of the "
                   f"{first['evaluated']['rounds']} evaluated after, higher in {noise['higher_when_evaluated']} of "
                   f"{len(noise['runs'])}: at {first['chosen_on']['rounds']} rounds a 1 % fall share has a standard "
                   "error of 0.6 points, as large as the gate's line (the `rounds1024` arm).")
    gated = {a for r in runs.values() if is_gate(r["arm"]) for a in gate_arms(r["arm"])}   # gate-only arms: tf32
    not_run = [a for a in ARMS if a not in arms and a not in gated]
    missing = [a for a in ARMS if a in arms and len(arms[a]["seeds"]) < 2]
    unevaluated = [n for n, r in runs.items() if r["arm"] in ARMS and len(r["result_on_validation"]) < len(TERRAINS)]
    untested = sorted({r["arm"] for r in runs.values() if is_gate(r["arm"]) and r["arm"] not in res["gates"]})
    if not_run or missing or unevaluated or untested:
        out.append("- **Partial**: " + "; ".join(
            ([f"arms not run yet: {', '.join(not_run)}"] if not_run else [])
            + [f"the gate `{g}`: seeds {', '.join(str(r['seed']) for r in runs.values() if r['arm'] == g)} of 1, 2, 3 "
               "trained, its test rounds not run yet" for g in untested]
            + ([f"arms on one seed: {', '.join(missing)}"] if missing else [])
            + ([f"results not yet on 500 validation rounds per course: {', '.join(unevaluated)}"] if unevaluated
               else [])) + "." + ("" if res["gates"] else " The 3-seed gate waits for the chosen recipe."))
    return out + [""]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--add", metavar="LEASE", help="a lease's folder (runs/, evals/) to copy into the study first")
    p.add_argument("--choose", action="store_true", help="print the train.py flags of the changes that paid, and stop")
    p.add_argument("--gate-name", action="store_true",
                   help="print the stem of the gate's run names for the changes that paid (gate_ARM-ARM), and stop")
    p.add_argument("--runs", nargs="*", default=[], metavar="DIR",
                   help="with --choose or --gate-name: more runs (NAME.log each)")
    p.add_argument("--flags", metavar="ARM", help="print an arm's train.py flags, and stop")
    args = p.parse_args(argv)
    if args.flags is not None:
        if args.flags not in ARM_FLAGS:
            print(f"build.py: no arm {args.flags!r} (the arms: {', '.join(ARM_FLAGS)})", file=sys.stderr)
            return 2
        print(ARM_FLAGS[args.flags])
        return 0
    if args.choose or args.gate_name:
        try:
            paid = paid_arms(args.runs)
            print(gate_name(paid) if args.gate_name else arms_flags(paid))
        except ValueError as e:
            print(f"build.py: {e}", file=sys.stderr)
            return 2
        return 0
    if args.add:
        if not os.path.isdir(os.path.join(args.add, "runs")):
            print(f"build.py: {args.add} has no runs/ folder", file=sys.stderr)
            return 2
        print("added:", ", ".join(add(args.add)) or "nothing")
    missing = raw_missing()
    if missing:
        print(f"build.py: the raw runs are not in the tree ({missing}, not tracked): restore them with `git -C "
              "studies/learner restore --source df27913 --worktree -- runs evals` or rerun the lease (README, Raw "
              "runs)",
              file=sys.stderr)
        return 2
    res = collect()
    with open(os.path.join(HERE, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
        f.write("\n")
    with open(os.path.join(HERE, "report.md"), "w") as f:
        f.write(report(res))
    print(f"{HERE}/report.md, results.json: {len(res['runs'])} runs, arms {', '.join(res['arms'])}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
