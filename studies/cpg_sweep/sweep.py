"""The fair fixed baseline: a sweep of fixed CPG gaits, so that CPG_RL is compared with the best fixed gait.

    python studies/cpg_sweep/sweep.py --terrains rugged stepped complex --rounds 32 --out DIR \\
        --env.sim.frame_dt 0.02 --env.sim.substeps 4

Every gait of the grid (omega x A1 x A2 x A3, the same amplitude on every leg) walks ``--rounds`` rounds on each
terrain, all gaits of a terrain at once (one robot per gait and round, one env batch), with the evaluation's
protocol (``hexnewton.apps.evaluate``: the first episode of each robot, success at 3 m) on validation seeds. The best gait
has the highest mean success at 3 m over the terrains; among gaits within ``--tie`` of it, the lowest mean pitch +
roll variance. ``config.FIXED_GAITS["swept"]`` holds it, and ``evaluate --controllers cpg_swept`` runs it beside
the paper-like default (``CPGConfig.fixed_*``).

Writes ``report.md`` (the ten best gaits, the default's row) and ``results.json`` (every gait).
"""

from __future__ import annotations

import itertools
import json
import math
import os
import sys
import time

import numpy as np

from hexnewton.apps.cli import (
    ArgumentParser,
    add_config_args,
    check_new_dir,
    config_overrides,
    positive_int,
    run,
    terrain_name,
)
from hexnewton.config import CPGConfig, HexConfig, gait_params

GRID = {
    "omega": [math.pi, 2.0 * math.pi, 3.0 * math.pi, 4.0 * math.pi],  # 0.5 - 2 Hz
    "a1": [0.2, 0.3, 0.4],
    "a2": [0.5, 0.7, 0.9, 1.1, 1.3],
    "a3": [0.3, 0.5, 0.7],
}


def choose(rows: list[dict], tie: float) -> dict:
    """The best gait: highest mean success at 3 m; within ``tie`` of it, the lowest mean pitch + roll variance."""
    top = max(r["success_3m"] for r in rows)
    near = [r for r in rows if r["success_3m"] >= top - tie]
    return min(near, key=lambda r: r["tilt_var_deg2"])


def parser() -> ArgumentParser:
    """The command line of ``python studies/cpg_sweep/sweep.py``."""
    p = ArgumentParser(prog="python studies/cpg_sweep/sweep.py", description=__doc__.split("\n")[0])
    p.add_argument("--terrains", nargs="+", type=terrain_name, default=["rugged", "stepped", "complex"])
    p.add_argument("--rounds", type=positive_int, default=16, help="rounds per gait and terrain")
    for key, values in GRID.items():
        p.add_argument(f"--{key}", type=float, nargs="+", default=values, help=f"grid values (default {values})")
    p.add_argument("--max_steps", type=positive_int, default=3000,
                   help="control steps per round (default 3000 = 60 s: 3 m at 5 cm/s)")
    p.add_argument("--tie", type=float, default=0.02, help="success margin within which stability decides")
    p.add_argument("--seed", type=int, default=3000,
                   help="terrain seed S, start poses S + 1000 (default 3000: a validation set, not the test set)")
    p.add_argument("--device", default=None)
    p.add_argument("--out", required=True, help="output directory (must not exist)")
    add_config_args(p, "env", HexConfig(), skip=("sim.num_envs", "sim.device", "task.seed", "terrain.seed", "terrain.name"),
                    title="--env.*: a field of every course (HexConfig), e.g. --env.sim.frame_dt 0.02")  # fmt: skip
    return p


def gait_grid(args) -> list[tuple[float, float, float, float]]:
    """Every (omega, A1, A2, A3) of the grid; ValueError for one outside the CPG's parameter ranges."""
    lo, hi = CPGConfig().param_ranges()
    gaits = list(itertools.product(args.omega, args.a1, args.a2, args.a3))
    for g in gaits:
        for v, a, b in zip(gait_params(*g)[:4], lo[:4], hi[:4]):
            if not a <= v <= b:
                raise ValueError(f"gait {g} leaves the parameter ranges (CPGConfig: {lo[:4]} .. {hi[:4]})")
    return gaits


def sweep_terrain(terrain: str, params: np.ndarray, rounds: int, device: str, max_steps: int, seed: int,
                  overrides: dict) -> list[dict]:
    """Every gait's ``rounds`` rounds on ``terrain`` in one env batch (``params``: one row per robot, gait-major);
    one row per gait: success at 3 m, pitch and roll variance, fall rate."""
    from hexnewton.analysis.metrics import round_metrics, summarize
    from hexnewton.analysis.rollout import run_rounds

    n = len(params) // rounds
    ep = run_rounds("cpg", None, terrain, n * rounds, device, max_steps, False, seed, overrides,
                    fixed_params=params)  # fmt: skip
    m = round_metrics(ep.pos, ep.rpy, ep.done, ep.status, ep.dt, (1.0, 3.0))
    rows = []
    for k in range(n):
        cols = slice(k * rounds, (k + 1) * rounds)
        sub = {key: (v[..., cols] if key in ("reached", "time_to", "in_episode") else v[cols])
               for key, v in m.items()}  # fmt: skip
        s = summarize(sub, ep.rpy[:, cols], (1.0, 3.0))
        rows.append({"success_3m": s["success_3m"], "pitch_var_deg2": s["pitch_var_deg2"],
                     "roll_var_deg2": s["roll_var_deg2"], "fall_rate": s["fall_rate"]})  # fmt: skip
    return rows


def gait_table(gaits: list[tuple], per_terrain: dict[str, list[dict]], terrains: list[str]) -> list[dict]:
    """One row per gait: its means over ``terrains`` (success at 3 m, pitch + roll variance, fall rate) and each
    terrain's row (``per_terrain[terrain][gait]``)."""
    table = []
    for k, g in enumerate(gaits):
        rows = [per_terrain[t][k] for t in terrains]
        table.append({"omega": g[0], "a1": g[1], "a2": g[2], "a3": g[3],
                      "success_3m": float(np.mean([x["success_3m"] for x in rows])),
                      "tilt_var_deg2": float(np.mean([(x["pitch_var_deg2"] or 0) + (x["roll_var_deg2"] or 0)
                                                      for x in rows])),
                      "fall_rate": float(np.mean([x["fall_rate"] for x in rows])),
                      "by_terrain": dict(zip(terrains, rows))})  # fmt: skip
    return table


def report_markdown(meta: dict, table: list[dict], best: dict, default: dict | None, terrains: list[str],
                    tie: float) -> str:
    """report.md: the run's settings, the best gait, the ten best gaits and the default's row."""
    ranked = sorted(table, key=lambda x: (-x["success_3m"], x["tilt_var_deg2"]))

    def row(x: dict, tag: str = "") -> str:
        cells = " | ".join(f"{100 * x['by_terrain'][t]['success_3m']:.0f}%" for t in terrains)
        return (f"| {tag}{x['omega'] / (2 * math.pi):.2f} Hz | {x['a1']:.2f} | {x['a2']:.2f} | {x['a3']:.2f} | "
                f"{cells} | {100 * x['success_3m']:.1f}% | {x['tilt_var_deg2']:.1f} | {100 * x['fall_rate']:.1f}% |")

    lines = ["# Fixed CPG sweep", "", *(f"- {k}: {v}" for k, v in meta.items()), "",
             f"Best (highest mean success at 3 m; within {tie:g} of it, the lowest pitch + roll variance): "
             f"omega {best['omega']:.4f} rad/s, A1 {best['a1']:g}, A2 {best['a2']:g}, A3 {best['a3']:g}.", "",
             "| omega | A1 | A2 | A3 | " + " | ".join(f"{t} 3 m" for t in terrains) +
             " | mean 3 m | pitch + roll var [deg²] | falls |",
             "|---|---:|---:|---:|" + "---:|" * (len(terrains) + 3)]
    lines += [row(x, "**best** " if x is best else "") for x in ranked[:10]]
    if default is not None:
        lines.append(row(default, "default "))
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    check_new_dir(args.out)
    overrides = config_overrides(args, "env")
    gaits = gait_grid(args)
    from hexnewton.physics.device import resolve_device

    device = resolve_device(args.device)
    seed = args.seed
    n, r = len(gaits), args.rounds
    params = np.repeat(np.asarray([gait_params(*g) for g in gaits]), r, axis=0)  # gait-major: rows g*r .. g*r+r-1
    os.makedirs(args.out)
    t0 = time.perf_counter()
    per_terrain: dict[str, list[dict]] = {}
    for terrain in args.terrains:
        rows = per_terrain[terrain] = sweep_terrain(terrain, params, r, device, args.max_steps, seed, overrides)
        best = max(rows, key=lambda x: x["success_3m"])
        print(f"{terrain}: {n} gaits x {r} rounds, best success at 3 m {100 * best['success_3m']:.0f} %", flush=True)
    table = gait_table(gaits, per_terrain, args.terrains)
    best = choose(table, args.tie)
    d = CPGConfig()
    default = next((row for row in table if np.allclose([row["omega"], row["a1"], row["a2"], row["a3"]],
                                                          [d.fixed_omega, d.fixed_a1, d.fixed_a2, d.fixed_a3])), None)
    wall = time.perf_counter() - t0
    meta = {"device": device, "gaits": n, "rounds": r, "terrains": args.terrains, "grid": {k: getattr(args, k) for k in
            GRID}, "max_steps": args.max_steps, "tie": args.tie, "overrides": overrides, "terrain_seed": seed,
            "wall_s": round(wall, 1), "command": "python studies/cpg_sweep/sweep.py " + " ".join(argv or sys.argv[1:])}
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump({"meta": meta, "best": best, "default": default, "gaits": table}, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(meta, table, best, default, args.terrains, args.tie))
    print(f"best gait: omega {best['omega']:.4f}, A1 {best['a1']:g}, A2 {best['a2']:g}, A3 {best['a3']:g} "
          f"(mean success at 3 m {100 * best['success_3m']:.1f} %); report in {args.out}/ after {wall:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python studies/cpg_sweep/sweep.py"))
