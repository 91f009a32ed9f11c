"""The capability ceiling: what the robot, its CPG, the task and the terrain generator allow on stairs and blocks.

    python studies/capability/ceiling.py --out studies/capability/ceiling
    python studies/capability/ceiling.py --task stairs-8cm --out ceiling_stairs8 --margin 0.005

Reads the configuration a controller trained with (``--checkpoint``, default the shipped all-terrain policy, or a
registered ``--task``) and computes in float64 NumPy, without Warp or a simulation (``ceiling_model``
defines every quantity): the robot's geometry and reach, the CPG's foot lift and stride over the parameter ranges the
policy may choose, the pitch stairs and blocks impose on the standing robot against the task's tilt limits, and what
the terrain generator builds. ``--out`` (which must not exist) receives ``report.md`` and ``results.json``; both
carry the command that made them.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

from hexnewton.apps.cli import ArgumentParser, check_new_dir, run


def _deg(rad: float) -> str:
    return f"{math.degrees(rad):.0f} deg"


def summary_rows(res: dict) -> list[tuple[str, str, str, str]]:
    """(quantity, value, how computed, what it bounds) of the report's first table."""
    g, c, p, t, m = res["robot"], res["cpg"], res["posture"], res["task"], res["margin_m"]
    st = {(r["rise_m"], r["tread_m"]): r for r in res["stairs"]}
    s8 = st[(0.08, 0.25)]
    return [
        ("standing torso height", f"{g['stand_height_m']:.3f} m", "`geometry.stand_height`, equal to the FK of the "
         "standing pose", "the body's height over its feet"),
        ("torso underside above the feet's ground", f"{g['torso_clearance_m']:.3f} m", "standing height - half the "
         "torso's height", "the tallest block that fits under the torso with every foot on the ground"),
        ("torso height range of the posture (P_h, P_p)", f"{p['height_m'][0]:.3f}-{p['height_m'][1]:.3f} m",
         "Eq. 4's reference at stance over the posture ranges, FK", "how far the body can crouch or rise"),
        ("front-to-rear foot span (a tripod)", f"{g['span_x_m']:.3f} m", "FK of the standing pose",
         "ceil(span / tread) risers lie between the front and the rear feet at worst"),
        ("foot spacing along one side", f"{g['side_spacing_x_m'][0]:.3f} m", "FK of the standing pose",
         "treads near a multiple of it put a side's three feet at the same place relative to the risers"),
        ("a foot's highest reach (any knee and ankle within their limits)", f"{res['robot_lift_m']:.3f} m",
         "FK over the joint limits, above the standing foot", f"the robot's rise and block ceiling: "
         f"{res['robot_lift_m'] - m:.3f} m with the {m:g} m margin"),
        ("CPG's peak foot lift, worst leg, over the policy's ranges", f"{c['lift_max_m']:.3f} m",
         "Eq. 3 and Eq. 4 references (one cycle), FK; above the leg's own stance height",
         f"the CPG's rise and block ceiling: {c['lift_max_m'] - m:.3f} m with the margin"),
        (f"CPG's peak foot lift at the lowest A2 ({c['a2_min']:g})", f"{c['lift_at_a2_min_m']:.3f} m", "the same",
         "what every gait the policy may choose clears"),
        ("swing foot's peak above the standing foot (body frame)", f"{c['lift_over_stand_max_m']:.3f} m", "the same",
         "the issue's 'highest foot lift above the standing foot height'"),
        ("longest stride (body frame) / longest swing (world) / top speed",
         f"{c['stride_max_m']:.3f} m / {c['swing_step_max_m']:.3f} m / {c['speed_max_m_s']:.2f} m/s",
         "the same; the body moves at the stance speed", "how far one swing can carry a foot over treads"),
        ("stair slope the posture levels", f"{p['pitch_deg']:.1f} deg", "Eq. 4's reference at stance over P_h and "
         "P_p, FK", "the pitch left on stairs: imposed - this"),
        ("pitch 8 cm x 25 cm stairs impose: mean / worst", f"{s8['pitch_mean_deg']:.1f} / {s8['pitch_worst_deg']:.1f} "
         f"deg ({100 * s8['share_at_worst']:.0f} % of positions at the worst)", "plane through a tripod's standing "
         "feet on the generated grid", "the tilt a climb costs before any dynamics"),
        ("stability fine / fall termination", f"{_deg(t['stability_tilt_rad'])} (-{t['stability_penalty']:g} per "
         f"step) / {_deg(t['max_tilt_rad'])}", "`RewardConfig.stability_tilt`, `TaskConfig.max_tilt` (the controller's "
         "config)", "the tilt the task tolerates"),
        ("tilt shaping on 6 / 8 cm stairs (25 cm treads) at the mean imposed pitch",
         f"{st[(0.06, 0.25)]['tilt_cost_per_step']:.1f} / {s8['tilt_cost_per_step']:.1f} per step",
         f"w_tilt ({t['w_tilt']:g}) x pitch^2", "the price the reward puts on climbing (r_d pays at most 1 per step)"),
    ]  # fmt: skip


def _m(v) -> str:
    return "none" if v is None else f"{v:.3f}"


def _table(header: list[str], rows: list[list]) -> list[str]:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    return out + ["| " + " | ".join(str(x) for x in r) + " |" for r in rows]


def detail_tables(res: dict) -> list[str]:
    """The lift against A2, the stairs, the rises at the tilt limits, the blocks and the terrain generator."""
    c, m = res["cpg"], res["margin_m"]
    lines = ["## Foot lift against A2 (worst leg, above its stance height)", ""]
    lines += _table(["A2 [rad]", "best A1, A3, posture [m]", "A3 = 0 [m]"],
                    [[f"{r['a2']:g}", f"{r['best_m']:.3f}", f"{r['a3_0_m']:.3f}"] for r in c["lift_by_a2"]])
    lines += ["", "## Stairs", "", f"Blind gait: the best fixed gait of the policy's ranges ({res['grid']} values per "
              "range), its worst leg, first riser uniform within a tread ahead of lift-off; a clean foothold clears "
              f"risers by {m:g} m and lands a foot radius or more from them. Pitch: standing feet on the generated "
              f"flight. Risers: those before the {res['goal_m']:g} m mark.", ""]  # fmt: skip
    lines += _table(["rise [m]", "tread [m]", "risers cleared (blind gait)", "pitch mean / worst [deg]",
                     "at worst", "worst, levelled [deg]", "tilt cost per step", "risers to the mark"],
                    [[f"{r['rise_m']:g}", f"{r['tread_m']:g}", f"{100 * r['cleared_per_riser']:.0f} %",
                      f"{r['pitch_mean_deg']:.1f} / {r['pitch_worst_deg']:.1f}", f"{100 * r['share_at_worst']:.0f} %",
                      f"{r['pitch_worst_levelled_deg']:.1f}", f"{r['tilt_cost_per_step']:.1f}", r["risers_to_goal"]]
                     for r in res["stairs"]])  # fmt: skip
    lines += ["", "## The rise at which the worst standing pitch reaches the task's tilt limits", ""]
    lines += _table(["tread [m]", "risers under the span", "fine [m]", "fine, levelled [m]", "fall [m]",
                     "fall, levelled [m]"],
                    [[f"{r['tread_m']:g}", r["risers_under_span"], f"{r['rise_at_fine_m']:.3f}",
                      f"{r['rise_at_fine_levelled_m']:.3f}", f"{r['rise_at_fall_m']:.3f}",
                      f"{r['rise_at_fall_levelled_m']:.3f}"] for r in res["pitch_limits"]])  # fmt: skip
    lines += ["", "The tread below which the worst standing pitch passes the stability fine:", ""]
    lines += _table(["rise [m]", "tread [m]", "tread, levelled [m]"],
                    [[f"{r['rise_m']:g}", _m(r["tread_m"]), _m(r["tread_levelled_m"])] for r in res["tread_limits"]])
    lines += ["", "## Blocks (2 cm blocks, heights uniform in 0-h)", ""]
    lines += _table(["h [m]", f"lift - h - margin at A2 {c['a2_min']:g} [m]", "lift - h - margin, best [m]",
                     "torso over a full block [m]", "p99.9 pitch / roll [deg]", "tilt beyond 30 deg"],
                    [[f"{r['height_m']:g}", f"{r['lift_margin_at_a2_min_m']:+.3f}", f"{r['lift_margin_max_m']:+.3f}",
                      f"{r['torso_clearance_m']:+.3f}", f"{r['pitch_p999_deg']:.1f} / {r['roll_p999_deg']:.1f}",
                      f"{100 * r['share_beyond_pi6']:.1f} %"] for r in res["blocks"]])  # fmt: skip
    tr = res["terrain"]
    lines += ["", "## The terrain generator", "",
              f"- Treads lie on the {tr['query_resolution_m']:g} m grid: a 0.175 m tread is refused with "
              f"`{tr['tread_off_grid_error']}`.",
              f"- Rises have no upper bound: a 0.5 m rise is "
              f"{'built' if tr['rise_0_5m_error'] is None else 'refused'}.",
              f"- Blocks are {tr['block_size_m']:g} m squares, narrower than the {2 * res['robot']['foot_radius_m']:g} "
              "m foot: a foot always rests on the highest of the blocks under it.", ""]  # fmt: skip
    lines += _table(["tread [m]", "flight ends at [m]", "risers before the mark", "stairs on the complex course"],
                    [[f"{r['tread_m']:g}", f"{r['flight_end_m']:.2f}", r["risers_to_goal"], r["complex_steps"]]
                     for r in tr["stairs"]])  # fmt: skip
    return lines


def report_markdown(res: dict) -> str:
    meta = res["meta"]
    lines = ["# Capability ceiling: stairs and blocks", "", "```bash", meta["command"], "```", "",
             f"Controller config: {meta['source']}; git {meta['git_rev']}; {meta['wall_s']:.0f} s on the CPU. "
             "Kinematic and quasi-static: joint angles are the CPG's targets, the body a rigid frame over its "
             "standing feet (`studies/capability/ceiling_model.py` defines every quantity).", "", "## Ceilings", ""]
    lines += _table(["quantity", "value", "how computed", "what it bounds"], [list(r) for r in summary_rows(res)])
    lines += ["", "## Verdicts (the issue's targets: >= 95 % at 8 cm rise, 20 cm treads, 8 cm blocks)", ""]
    lines += [f"- {v['line']}" for v in res["verdicts"]]
    lines += ["", "Against the trained course:", "", *(f"- {n}" for n in res["notes"])]
    lines += ["", *detail_tables(res)]
    return "\n".join(lines) + "\n"


def _config(args):
    """The controller's config: the checkpoint's, or the registered task's."""
    if args.task:
        from hexnewton.tasks import task

        return task(args.task).env, f"task {args.task}"
    from hexnewton.learning.checkpoint import read_checkpoint, trained_config

    return trained_config(read_checkpoint(args.checkpoint)), f"checkpoint {args.checkpoint}"


def main(argv: list[str] | None = None) -> int:
    p = ArgumentParser(prog="python studies/capability/ceiling.py", description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="output directory (must not exist)")
    p.add_argument("--checkpoint", default="results/policies/cpg_rl_complex.pt",
                   help="the controller whose config is read (default: the shipped all-terrain policy)")
    p.add_argument("--task", default=None, help="a registered task's config instead of --checkpoint's")
    p.add_argument("--margin", type=float, default=0.01, help="clearance a swing foot keeps over a riser or block [m]")
    p.add_argument("--grid", type=int, default=5, help="values per CPG parameter range (2-9, default 5)")
    p.add_argument("--dt", type=float, default=0.002, help="CPG step of the gait cycles [s] (default 0.002)")
    args = p.parse_args(argv)
    check_new_dir(args.out)
    from ceiling_model import ceilings
    from hexnewton.analysis.report import git_rev

    t0 = time.perf_counter()
    cfg, source = _config(args)
    res = ceilings(cfg, margin=args.margin, n=args.grid, dt=args.dt)
    res["meta"] = {"command": "python studies/capability/ceiling.py " + " ".join(argv if argv is not None
                                                                                  else sys.argv[1:]),
                   "source": source, "git_rev": git_rev(), "wall_s": round(time.perf_counter() - t0, 1)}
    os.makedirs(args.out)
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(res, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(res))
    for v in res["verdicts"]:
        print(v["line"])
    print(f"report in {args.out}/ (report.md, results.json) after {res['meta']['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python studies/capability/ceiling.py"))
