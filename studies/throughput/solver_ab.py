"""The solver's settings against the defaults: the physics alone under each variant and the A/B on evaluation rounds,
from what ``solver_ab.sh`` left in each lease's folder ``solver_ab/raw/DATE/`` (``sim_VARIANT.json``,
``eval_VARIANT_TERRAIN/results.json``, ``gpu.txt``: the queue's ``$TP/ab/``, brought back as one tarball).

    python studies/throughput/solver_ab.py              # solver_ab/raw/ -> solver_ab/report.md, results.json
    python studies/throughput/solver_ab.py --flags cg   # a variant's bench/evaluate flags (solver_ab.sh reads them)

A variant is kept only if it is faster and, on every terrain, the shipped policy's success at 3 m is within 1 point of
the defaults' and its falls before the goal line within 0.5 points (the issue's A/B). A terrain whose evaluations did
not finish under both settings leaves the A/B partial. The fixed CPG's rounds under both settings are reported beside
the verdict, not judged: where they move beyond the same tolerances, the variant's physics is not the defaults'.
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import sys

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "solver_ab")
BASE = "base"
TERRAINS = ("complex", "rugged", "stepped")
#: the variants' bench/evaluate flags (solver_ab.sh reads them: ``--flags VARIANT``)
FLAGS = {"base": "", "iter5": "--env.sim.iterations 5 --env.sim.ls_iterations 5",
         "ls4": "--env.sim.ls_iterations 4", "cg": "--env.sim.solver cg",
         # fewer MuJoCo steps per 20 ms frame (the recipes' 4 of 5 ms): 3 of 6.7 ms, 2 of 10 ms; the collision stays
         # once per frame, so the solver's share (68.5 %) shrinks with the steps
         "sub3": "--env.sim.substeps 3", "sub2": "--env.sim.substeps 2",
         # constraint rows per world 192, not 480: MuJoCo-Warp launches its per-row solver kernels over every row of
         # the capacity (_update_constraint_efc, 7.4 % of the step, over 16384 x 480 threads) and most stay empty
         # (rows per world: mean 39, max 129 on the rugged course, contacts/); the same physics unless a world overflows
         "rows192": "--env.sim.constraints_per_env 192"}
#: the A/B's tolerances [points]
SUCCESS_TOL, FALLS_TOL = 1.0, 0.5


def load_lease(folder: str) -> dict:
    """One lease's folder: the physics alone per variant (``sim_VARIANT.json``, the base's among them) and the A/B's
    evaluations that finished (``eval_VARIANT_TERRAIN/results.json``), each variant against that lease's base."""
    sims = {}
    for path in sorted(glob.glob(os.path.join(folder, "sim_*.json"))):
        with open(path) as f:
            d = json.load(f)
        sims[os.path.basename(path)[4:-5]] = {
            r["terrain"]: {"robot_s_per_s": round(r["robot_s_per_s"]), "overflow": r["overflow"],
                           "not_converged_worlds": r.get("not_converged_worlds")} for r in d["sim"]}
    if BASE not in sims:
        raise FileNotFoundError(f"no sim_{BASE}.json in {folder}")
    unknown = [v for v in sims if v not in FLAGS]
    if unknown:
        raise ValueError(f"{folder}: variants not in FLAGS: {', '.join(unknown)}")
    evals = {}
    for v in sims:
        for t in TERRAINS:
            path = os.path.join(folder, f"eval_{v}_{t}", "results.json")
            if not os.path.exists(path):
                continue
            with open(path) as f:
                d = json.load(f)
            evals.setdefault(v, {})[t] = {
                c: {"success_3m": r["success_3m"], "fall_rate": r["fall_rate"],
                    "fall_rate_before_goal": r["fall_rate_before_goal"], "pitch_var": r["pitch_var_deg2"],
                    "roll_var": r["roll_var_deg2"]} for c, r in d["results"][t].items()}
    with open(os.path.join(folder, "gpu.txt")) as f:
        gpu = f.read().strip()
    return {"lease": os.path.basename(folder), "gpu": gpu, "flags": {v: FLAGS[v] for v in sims}, "sim": sims,
            "eval": evals, "verdicts": verdicts(sims, evals)}


def load(raw: str) -> dict:
    """Every lease under ``raw`` (one folder each, named by its date): a variant is judged against the base measured
    on the same machine in the same lease."""
    folders = sorted(d for d in glob.glob(os.path.join(raw, "*")) if os.path.isdir(d))
    if not folders:
        raise FileNotFoundError(f"no lease folders in {raw}")
    return {"leases": [load_lease(d) for d in folders]}


def verdicts(sims: dict, evals: dict) -> dict:
    out = {}
    for v in sims:
        if v == BASE:
            continue
        speed = {t: sims[v][t]["robot_s_per_s"] / sims[BASE][t]["robot_s_per_s"] - 1 for t in sims[v]}
        overflow = [t for t in sims[v] if sims[v][t]["overflow"] != "none"]
        lines, fixed, missing = {}, {}, []
        for t in TERRAINS:
            a, b = evals.get(BASE, {}).get(t, {}), evals.get(v, {}).get(t, {})
            if "cpg_rl" not in a or "cpg_rl" not in b:
                missing.append(t)
                continue
            lines[t] = deltas(a["cpg_rl"], b["cpg_rl"])
            lines[t]["holds"] = (abs(lines[t]["success_points"]) <= SUCCESS_TOL
                                 and lines[t]["falls_before_goal_points"] <= FALLS_TOL)
            if "cpg" in a and "cpg" in b:   # the fixed CPG on the same rounds: not judged, the physics' own witness
                fixed[t] = deltas(a["cpg"], b["cpg"])
        failed = [t for t, x in lines.items() if not x["holds"]]
        if failed:
            verdict = "not kept: the A/B fails on " + ", ".join(failed)
        elif overflow or min(speed.values()) <= 0:
            verdict = "not kept: " + (f"contacts overflow on {', '.join(overflow)}" if overflow else "not faster")
        elif missing:
            verdict = "partial: the A/B lacks " + ", ".join(missing)
        else:
            verdict = "kept"
        out[v] = {"speedup": {t: round(s, 4) for t, s in speed.items()}, "overflow": overflow, "ab": lines,
                  "fixed_cpg": fixed, "ab_missing": missing, "verdict": verdict}
    return out


def deltas(a: dict, b: dict) -> dict:
    """Success at 3 m and falls before the goal under a variant (``b``) against the defaults (``a``) [points]."""
    return {"success_points": round(100 * (b["success_3m"] - a["success_3m"]), 2),
            "falls_before_goal_points": round(100 * (b["fall_rate_before_goal"] - a["fall_rate_before_goal"]), 2)}


def pct(x: float) -> str:
    return f"{100 * x:.1f} %"


def report(res: dict) -> str:
    lines = ["# The solver's settings against the defaults, one GPU", "",
             "`bash studies/device/gpu.sh queue studies/throughput/solver_ab.sh` (`VARIANTS=\"base ...\"`: the "
             "defaults and the variants, on one machine in one lease); `python studies/throughput/solver_ab.py` writes "
             "this file and results.json from raw/ (a folder per lease). A variant is judged against the defaults "
             "measured in its own lease.", "",
             "## The physics alone", "",
             "`python -m hexnewton.apps.bench --device cuda --num_envs 16384 --mode sim --frames 200 "
             "--env.sim.frame_dt 0.02 --env.sim.substeps 4 --terrain complex rugged stepped` with each variant's "
             "flags, each alone on the GPU, one after another (robot-s/s; worlds at the solver's iteration cap in the "
             "timed window):", "",
             "| lease | variant | flags | " + " | ".join(TERRAINS) + " | overflow |",
             "|---|---|---|" + "---:|" * len(TERRAINS) + "---|"]
    for le in res["leases"]:
        sims = le["sim"]
        for v in sims:
            cells = [f"{sims[v][t]['robot_s_per_s']:,} ({sims[v][t]['not_converged_worlds']})" for t in TERRAINS]
            over = ", ".join(f"{t}: {sims[v][t]['overflow']}" for t in TERRAINS if sims[v][t]["overflow"] != "none")
            lines.append(f"| {le['lease']} ({le['gpu']}) | {v} | `{le['flags'][v] or 'the defaults'}` | "
                         + " | ".join(cells) + f" | {over or 'none'} |")
    base_over = [f"{t} ({le['lease']})" for le in res["leases"] for t in TERRAINS
                 if le["sim"][BASE][t]["overflow"] != "none"]
    if base_over:
        lines += ["", f"The defaults too overflow in a world now and then: {', '.join(base_over)}."]
    lines += ["", "## The A/B on 1000 test rounds per terrain", "",
              "`python -m hexnewton.apps.evaluate --controllers cpg cpg_rl --checkpoint "
              "cpg_rl=results/policies/cpg_rl_complex.pt --terrains complex --rounds 1000`, per terrain and with each "
              "variant's flags, the evaluate default seeds, deterministic action, every evaluation at once:", "",
              "| lease | variant | terrain | controller | 3 m | falls (before the goal) | pitch / roll var [deg²] |",
              "|---|---|---|---|---:|---:|---:|"]
    for le in res["leases"]:
        evals = le["eval"]
        for v in le["sim"]:
            for t in TERRAINS:
                for c, r in evals.get(v, {}).get(t, {}).items():
                    lines.append(f"| {le['lease']} | {v} | {t} | {c} | {pct(r['success_3m'])} | {pct(r['fall_rate'])} "
                                 f"({pct(r['fall_rate_before_goal'])}) | {r['pitch_var']:.1f} / {r['roll_var']:.1f} |")
                if t not in evals.get(v, {}):
                    lines.append(f"| {le['lease']} | {v} | {t} | | not finished | | |")
    lines += ["", "## Verdict", "",
              "Written from results.json (`verdicts`): kept only if faster, with no overflow, and the shipped policy's "
              f"success within {SUCCESS_TOL:g} point and falls before the goal within {FALLS_TOL:g} points of the "
              "defaults' on every terrain.", ""]
    for le in res["leases"]:
        for v, x in le["verdicts"].items():
            speed = ", ".join(f"{t} {100 * s:+.1f} %" for t, s in x["speedup"].items())
            ab = "; ".join(f"{t}: success {d['success_points']:+.1f}, falls before the goal "
                           f"{d['falls_before_goal_points']:+.1f} points" for t, d in x["ab"].items())
            lines.append(f"- **`{v}` ({le['lease']}): {x['verdict']}.** The physics alone: {speed}"
                         + (f". The A/B: {ab}" if ab else "")
                         + (f"; not finished on {', '.join(x['ab_missing'])}" if x["ab_missing"] else "")
                         + (" (not needed for this verdict)." if x["ab_missing"] and x["verdict"].startswith("not kept")
                            else "."))
            moved = {t: d for t, d in x.get("fixed_cpg", {}).items() if abs(d["success_points"]) > SUCCESS_TOL
                     or abs(d["falls_before_goal_points"]) > FALLS_TOL}
            if moved:
                lines.append("  The fixed CPG on the same rounds, which no training adapted to either physics: "
                             + "; ".join(f"{t}: success {d['success_points']:+.1f}, falls before the goal "
                                         f"{d['falls_before_goal_points']:+.1f} points" for t, d in moved.items())
                             + f". {PHYSICS_MOVES}.")
            lines += capped_note(le["sim"], v)
    return "\n".join(lines) + "\n"


#: what a fixed CPG that moves beyond the tolerances under a variant says
PHYSICS_MOVES = ("The variant's physics is not the defaults' made faster: every committed evaluation, the paper "
                 "comparison's baselines among them, would shift with it")

#: what the worlds at the iteration cap say under a variant, beside its counts
CAPPED_MEANS = {
    "iter5": "most worlds need 6-10 iterations, yet capping them at 5 makes the physics faster by only the shares "
             "above. The solver's time is not in its iterations past the fifth",
    "cg": "the conjugate-gradient solver converges in none of the worlds within the same 10 iterations where the "
          "Newton solver converges in all but a few: it runs more iterations to a looser result, and the step is "
          "slower"}


def capped_note(sims: dict, v: str) -> list[str]:
    """What the worlds at the iteration cap say, when every terrain has some under ``v``."""
    capped = [sims[v][t]["not_converged_worlds"] for t in TERRAINS]
    if not all(capped):
        return []
    base = ", ".join(str(sims[BASE][t]["not_converged_worlds"]) for t in TERRAINS)
    means = CAPPED_MEANS.get(v)
    return [f"  Under `{v}` {', '.join(f'{n:,}' for n in capped)} of the worlds end the timed window at the solver's "
            f"iteration cap against {base} under the defaults" + (f": {means}." if means else ".")]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--flags", metavar="VARIANT", help="print a variant's bench/evaluate flags, and stop")
    args = p.parse_args(argv)
    if args.flags is not None:
        if args.flags not in FLAGS:
            print(f"solver_ab.py: no variant {args.flags!r} (the variants: {', '.join(FLAGS)})", file=sys.stderr)
            return 2
        print(FLAGS[args.flags])
        return 0
    try:
        res = load(os.path.join(HERE, "raw"))
    except (OSError, KeyError, ValueError) as e:
        print(f"solver_ab.py: {e}", file=sys.stderr)
        return 1
    with open(os.path.join(HERE, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
        f.write("\n")
    with open(os.path.join(HERE, "report.md"), "w") as f:
        f.write(report(res))
    print(f"wrote {HERE}/report.md and results.json")
    return 0


if __name__ == "__main__":
    sys.exit(main())
