"""The complex recipe's 5-seed gate (issue "learner-curriculum", studies/curriculum/README.md) checked by Monte Carlo
before it is used: how often a recipe exactly as good as the shipped policy passes it, and how often one with twice
its falls before the goal line does.

    python studies/curriculum/gate_mc.py            # -> studies/curriculum/gate_mc.json (and prints the table)

The model, from the shipped policy's own test results (studies/learner/results.json, ``same_rounds``/``test``: 1000
test rounds per course in each of three leases, deterministic action, beside the fixed CPG of the same lease):
- per course, a seed's share at 3 m and its share of falls before the goal line are binomial on the gate's rounds
  (4000 on rugged and complex, 1000 on stepped) at the shipped policy's rates pooled over the three leases; the
  shipped policy in the gate's lease is one more such draw (the gate judges every seed against it);
- the rugged pitch and roll variance, the policy's and the fixed CPG's, are log-normal about their means over the
  three leases, with the leases' spread of the log scaled by sqrt(1000 / 4000) (the leases walked the same rounds:
  what moves between them is the contacts' chaos per round, which averages over rounds); the fixed CPG is one draw per
  lease, shared by the five seeds;
- "twice its falls": every course's falls before the goal doubled, the share at 3 m lower by the same amount;
- "with the seeds' spread": each seed's fall rate before the goal a log-normal factor (sd 0.9 in log, the spread of
  rugged falls between the recipe's seeds, studies/learner) about the model's, mean kept, its 3 m share moved alike.
"""

from __future__ import annotations

import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
LEARNER = os.path.join(ROOT, "studies", "learner", "results.json")
LEASES = ("gate", "gate_tf32", "gate_together")  # the three leases whose shipped policy ran the gate's test rounds
COURSES = ("rugged", "stepped", "complex")
ROUNDS = {"rugged": 4000, "stepped": 1000, "complex": 4000}
SEEDS = 5
#: the gate's lines (studies/curriculum/README.md, "The gate")
LINES = dict(median_3m_below_shipped=0.005, pooled_falls_above_shipped=0.003, worst_3m=0.95, worst_falls=0.02,
             rugged_var_vs_fixed_cpg=0.8)  # fmt: skip
SEED_SPREAD_LOG = 0.9
DRAWS = 20000


def shipped_results() -> dict:
    """Per lease and course: the shipped policy's and the fixed CPG's test results (1000 rounds each), as the learner
    study's results.json keeps them from each gate's evaluations."""
    with open(LEARNER) as f:
        test = json.load(f)["same_rounds"]["test"]
    out = {}
    for lease in LEASES:
        for t in COURSES:
            refs = test.get(lease, {})
            if t not in refs.get("shipped", {}) or t not in refs.get("fixed_cpg", {}):
                raise SystemExit(f"gate_mc.py: studies/learner/results.json has no {lease} test rounds on {t} (the "
                                 "shipped policy's and the fixed CPG's, same_rounds/test)")  # fmt: skip
            out.setdefault(lease, {})[t] = {"cpg_rl": refs["shipped"][t], "cpg": refs["fixed_cpg"][t]}
    return out


def model(res: dict) -> dict:
    """Pooled rates per course and the rugged variance's log-normal parameters (module docstring)."""
    rates = {}
    for t in COURSES:
        n = sum(res[lease][t]["cpg_rl"]["rounds"] for lease in LEASES)
        p3 = sum(res[lease][t]["cpg_rl"]["success_3m"] * res[lease][t]["cpg_rl"]["rounds"] for lease in LEASES) / n
        pf = sum(res[lease][t]["cpg_rl"]["fall_rate_before_goal"] * res[lease][t]["cpg_rl"]["rounds"]
                 for lease in LEASES) / n  # fmt: skip
        rates[t] = {"success_3m": p3, "fall_before_goal": pf, "rounds_pooled": n}
    var = {}
    scale = np.sqrt(1000 / ROUNDS["rugged"])
    for who in ("cpg_rl", "cpg"):
        for axis in ("pitch", "roll"):
            logs = np.log([res[lease]["rugged"][who][f"{axis}_var_deg2"] for lease in LEASES])
            var[f"{who}_{axis}"] = {"log_mean": float(logs.mean()), "log_sd_1000": float(logs.std(ddof=1)),
                                    "log_sd_gate": float(logs.std(ddof=1) * scale)}  # fmt: skip
    return {"rates": rates, "rugged_variance": var}


def simulate(m: dict, fall_factor: float = 1.0, seed_spread: float = 0.0, draws: int = DRAWS, seed: int = 0) -> dict:
    """The share of draws that pass each line and the whole gate (the stability line included; the time line is not
    drawn)."""
    rng = np.random.default_rng(seed)
    passes = {name: np.ones(draws, bool) for name in ("median_3m", "pooled_falls", "worst_seed", "rugged_variance")}
    for t in COURSES:
        r, n = m["rates"][t], ROUNDS[t]
        pf0, p30 = r["fall_before_goal"], r["success_3m"]
        pf = np.full((draws, SEEDS), pf0 * fall_factor)
        if seed_spread:  # a log-normal factor per seed, its mean 1
            pf = pf * np.exp(seed_spread * rng.standard_normal((draws, SEEDS)) - 0.5 * seed_spread**2)
        pf = np.clip(pf, 0.0, 1.0)
        p3 = np.clip(p30 - (pf - pf0), 0.0, 1.0)
        seeds_3m = rng.binomial(n, p3) / n
        seeds_f = rng.binomial(n, pf) / n
        ship_3m, ship_f = rng.binomial(n, p30, draws) / n, rng.binomial(n, pf0, draws) / n
        passes["median_3m"] &= np.median(seeds_3m, axis=1) >= ship_3m - LINES["median_3m_below_shipped"]
        passes["pooled_falls"] &= seeds_f.mean(axis=1) <= ship_f + LINES["pooled_falls_above_shipped"]
        worst = (seeds_3m.min(axis=1) >= LINES["worst_3m"]) & (seeds_f.max(axis=1) <= LINES["worst_falls"])
        passes["worst_seed"] &= worst
    v = m["rugged_variance"]
    for axis in ("pitch", "roll"):
        pol, ref = v[f"cpg_rl_{axis}"], v[f"cpg_{axis}"]
        policy = np.exp(pol["log_mean"] + pol["log_sd_gate"] * rng.standard_normal((draws, SEEDS)))
        fixed = np.exp(ref["log_mean"] + ref["log_sd_gate"] * rng.standard_normal(draws))
        passes["rugged_variance"] &= (policy < LINES["rugged_var_vs_fixed_cpg"] * fixed[:, None]).all(axis=1)
    every = np.logical_and.reduce(list(passes.values()))
    out = {name: float(p.mean()) for name, p in passes.items()}
    out["gate"] = float(every.mean())
    return out


def main() -> int:
    m = model(shipped_results())
    scenarios = {"as good as the shipped policy": simulate(m),
                 "twice its falls before the goal": simulate(m, fall_factor=2.0),
                 "as good, with the seeds' spread": simulate(m, seed_spread=SEED_SPREAD_LOG),
                 "twice its falls, with the seeds' spread": simulate(m, fall_factor=2.0, seed_spread=SEED_SPREAD_LOG)}
    result = {"command": "python studies/curriculum/gate_mc.py", "draws": DRAWS, "seeds": SEEDS, "rounds": ROUNDS,
              "lines": LINES, "model": m, "scenarios": scenarios,
              "sound": scenarios["as good as the shipped policy"]["gate"] >= 0.8
              and scenarios["twice its falls before the goal"]["gate"] <= 0.2}  # fmt: skip
    with open(os.path.join(HERE, "gate_mc.json"), "w") as f:
        json.dump(result, f, indent=1)
    cols = ("median_3m", "pooled_falls", "worst_seed", "rugged_variance", "gate")
    print("| recipe | " + " | ".join(cols) + " |")
    for name, s in scenarios.items():
        print(f"| {name} | " + " | ".join(f"{s[c]:.1%}" for c in cols) + " |")
    print(f"sound (as good >= 80 %, twice the falls <= 20 %): {result['sound']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
