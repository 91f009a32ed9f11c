"""Fig. 1 of Huang et al. 2025: the two-oscillator CPG against a six-oscillator network, convergence and phase error.

    python studies/fig1/figure.py --out DIR      # this study's report.md, results.json and fig1.png in DIR

§2.2 claims that two coupled Hopf oscillators (phase difference theta = pi, one per tripod) replace the usual
fully coupled network of six: the six-oscillator CPG converges to its rhythm in about 200 steps, the two-oscillator
one in about 70, with 67 % fewer network parameters. The paper publishes neither its constants nor its step size.
This command integrates both networks with ours (``CPGConfig``), in float64 NumPy, from random initial states.

Networks (every oscillator is the kernel's Eq. 3 oscillator, ``kernels/reference.hopf_unit_rhs_np``: the same
alpha, mu, delta, the swing/stance blend of omega keyed on x and the frequency compensation; only the topology
differs):

- ``two``: the kernel's pair (``kernels/cpg.py``), integrated by its reference ``hopf_cpg_reference``:
  theta_10 = -theta, theta_01 = theta, oscillator 0 for the tripod {R1, L2, R3}, 1 for {L1, R2, L3}.
- ``six_sum``: one oscillator per leg (R1, R2, R3, L1, L2, L3), fully coupled, Eq. 3's coupling summed over the
  five others: dy_i/dt gets delta * sum_{j != i} Delta_ji, Delta_ji = y_j cos(theta_ji) - x_j sin(theta_ji), with
  theta_ji = 0 within a tripod and pi across (``kernels/reference.tripod_theta``: theta_ji = theta (g_i - g_j) for
  the tripods g = ``LEG_OSCILLATOR``). Each link has Eq. 3's strength delta.
- ``six_mean``: the same network with delta / 5 on each link (the mean over the neighbours), so each oscillator
  feels the coupling strength of the pair.

Frequency compensation. Locked in the tripod, every neighbour's Delta_ji equals r sin(phi_i) = y_i (all radii are
equal), so oscillator i receives K y_i with K = delta * sum_j c_ji (c_ji: the weight of the link j -> i): K = delta
for ``two`` and ``six_mean``, 5 delta for ``six_sum``. That term adds K sin(phi) cos(phi) to dphi/dt, so a cycle
lasts 2 pi / sqrt(w^2 - K^2 / 4): the kernel's derivation with delta replaced by K. Every network therefore
integrates with omega_c = sqrt(omega^2 + K^2 / 4) (``kernels/reference.network_omega``; K = delta is the kernel's
own), and all three run at the commanded omega (the report lists the measured frequency of each converged cycle).
Uncompensated, ``six_sum`` would not oscillate at all below omega = K / 2 = 12.5 rad/s (2 Hz) with delta = 5:
dphi/dt would vanish on the cycle. The same term adds K r sin^2(phi) to dr/dt, so the converged radius ripples
within a cycle, between sqrt(mu) and about sqrt(mu + K / alpha): 1.00-1.05 for K = 5, 1.00-1.22 for K = 25 (mu = 1).
The phase speed varies within a cycle by +-K / 2 about omega_c, so ``six_sum``'s output is far from a sine
(Fig. 1a).

What sets the speed. Averaged over a cycle, the phases obey dphi_i/dt = omega + (delta c / 2) sum_j sin(phi_j -
theta_ji - phi_i), c the weight of every link: near the tripod, errors decay at delta c / 2 times the coupling
graph's Laplacian eigenvalue, n for a complete graph of n. That is delta for the pair, 3 delta for ``six_sum`` and
0.6 delta for ``six_mean``: six fully coupled oscillators lock more slowly than the pair only when c < 1/3, i.e. when
each link is weaker than a third of the pair's. From random starts, far from the lock, the six lag further behind
these rates (the report's ratios of the medians).

Convergence. A state has converged when (1) every oscillator's radius lies within ``--amp_tol`` (1 %) of the
network's own converged cycle at the same phase (the cycle from the locked start, after ``SETTLE_S`` seconds, radius
against phase per oscillator, interpolated) and (2) every pair's phase error, phi_i - phi_j minus the tripod
relation (0 within a tripod, theta across), lies within ``--phase_tol_deg`` (1 degree). The steps to converge are
the first step from which it stays converged up to the horizon; a start still unconverged at the horizon counts as
never. The table also gives the steps for (1) and (2) alone.

Starts: each oscillator's (x, y) drawn independently, uniform over the disc of radius ``--radius`` sqrt(mu) (1.5:
inside and outside the limit cycle), seeded; the pair takes the first two of the six legs' draws (R1, R2: one per
tripod), so both networks start from the same distribution.

Step: one RK4 step of the CPG, what ``hexnewton.kernels.cpg`` integrates before every physics substep, dt =
``SimConfig.frame_dt / substeps``: 2.5 ms for the default physics (tasks ``flat``, ``paper``), 5 ms under the 20 ms
frame of the terrain tasks (the shipped policies). The high level acts every ``TaskConfig.control_dt`` (20 ms), i.e.
every 8 or 4 steps. ``--dt`` defaults to every step size the CPG tasks use.

Writes ``report.md`` (the command, the table, the parameter counts, the figure, the comparison with the paper),
``results.json`` and ``fig1.png``: (a) the six-oscillator outputs y_i and (b) the pair's, against steps, from the
first start, as in the paper's Fig. 1; (c) ``six_mean``; (d) the share of starts converged against steps.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))  # this study's own module, oscillators.py

from oscillators import (  # noqa: E402
    NETWORKS,
    PAPER_STEPS,
    convergence,
    coupling_weights,
    param_counts,
    plot_figure,
    random_starts,
    step_stats,
)
from hexnewton.apps.cli import ArgumentParser, check_new_dir, positive_int, run
from hexnewton.config import CPGConfig, TaskConfig
from hexnewton.kernels.reference import network_omega

FIGURE = "fig1.png"


def _fmt(v, spec: str = ".0f") -> str:
    return "never" if v is None else format(v, spec)


def report_markdown(result: dict) -> str:
    """report.md: the command, the setup, the table, the parameter counts, the figure and the comparison."""
    meta, runs, counts = result["meta"], result["runs"], result["param_counts"]
    lines = ["# Fig. 1: two oscillators against six (Huang et al. 2025, §2.2)", "",
             "```bash", meta["command"], "```", "",
             *(f"- {k}: {v}" for k, v in meta.items() if k != "command"), "",
             "## Steps to converge", "",
             "Amplitude within {:g} % of the network's own cycle for every oscillator and phase error within {:g}° "
             "of the tripod relation for every pair, from that step on; {} random starts per row. A step is one RK4 "
             "step of the CPG (one physics substep); a control step is {:g} ms.".format(
                 100 * meta["amp_tol"], meta["phase_tol_deg"], meta["samples"], 1000 * meta["control_dt"]), "",
             "| network | step [ms] | omega [rad/s] | median steps | p95 steps | max | never | median / p95 [s] "
             "| median / p95 control steps | amplitude alone, median / p95 | phase alone, median / p95 "
             "| measured omega | cycle radius |",
             "|---|---:|---:|---:|---:|---:|---:|---|---|---|---|---:|---|"]  # fmt: skip
    for r in runs:
        b, a, p = r["both"], r["amplitude"], r["phase"]
        lines.append(f"| {r['network']} | {1000 * r['dt']:g} | {r['omega']:.2f} | {_fmt(b['median_steps'])} | "
                     f"{_fmt(b['p95_steps'])} | {_fmt(b['max_steps'])} | {b['never']} | {_fmt(b['median_s'], '.2f')} / "
                     f"{_fmt(b['p95_s'], '.2f')} | {_fmt(b['median_control_steps'], '.1f')} / "
                     f"{_fmt(b['p95_control_steps'], '.1f')} | {_fmt(a['median_steps'])} / {_fmt(a['p95_steps'])} | "
                     f"{_fmt(p['median_steps'])} / {_fmt(p['p95_steps'])} | {r['omega_measured']:.3f} | "
                     f"{r['radius_min']:.3f}-{r['radius_max']:.3f} |")  # fmt: skip
    lines += ["", "## Network size", "", "| | oscillators | directed couplings (theta_ji) | independent coupling "
              "phases | state variables |", "|---|---:|---:|---:|---:|"]  # fmt: skip
    for key in ("two", "six", "reduction_pct"):
        c = counts[key]
        unit = " %" if key == "reduction_pct" else ""
        lines.append(f"| {key.replace('_pct', ' (two vs six)')} | " + " | ".join(f"{c[k]:g}{unit}" for k in
                     ("oscillators", "directed_couplings", "coupling_phases", "state_variables")) + " |")  # fmt: skip
    lines += ["", f"![Fig. 1]({FIGURE})", "", "## Against the paper", "", *result["verdict"]]
    return "\n".join(lines) + "\n"


def verdict(runs: list[dict], omega: float) -> list[str]:
    """The paper's claim (six ~200 steps, two ~70: 2.9 times as many) against the medians at ``omega``."""
    paper = PAPER_STEPS["six"] / PAPER_STEPS["two"]
    out = [f"The paper: six oscillators converge in ~{PAPER_STEPS['six']} steps, two in ~{PAPER_STEPS['two']} "
           f"({paper:.1f} times as many; its step size and constants are not published)."]  # fmt: skip
    for dt in sorted({r["dt"] for r in runs}):
        row = {r["network"]: r["both"]["median_steps"] for r in runs if r["dt"] == dt and r["omega"] == omega}
        if None in row.values():
            out.append(f"- step {1000 * dt:g} ms: some medians lie beyond the horizon; no ratio.")
            continue
        parts = [f"{k} {row[k] / row['two']:.2f} times the pair's ({row[k]:.0f} against {row['two']:.0f} steps)"
                 for k in ("six_sum", "six_mean")]
        out.append(f"- step {1000 * dt:g} ms, median steps to converge: " + "; ".join(parts) + ".")
    red = param_counts()["reduction_pct"]
    out.append(f"- Network size: the pair has {red['oscillators']:g} % fewer oscillators and "
               f"{red['state_variables']:g} % fewer state variables (the paper's 67 %) and "
               f"{red['directed_couplings']:g} % fewer coupling terms.")
    return out


def _task_steps() -> list[float]:
    """The CPG step of every CPG task (frame_dt / substeps), each once."""
    from hexnewton.tasks import TASKS

    return sorted({round(t.env.sim.frame_dt / t.env.sim.substeps, 9) for t in TASKS.values() if t.action_mode == "cpg"})


def _check(args) -> None:
    check_new_dir(args.out)
    if not all(0.0 < d <= 0.01 for d in args.dt):
        raise ValueError(f"--dt {args.dt}: each step must lie in (0, 0.01] s (RK4 stays stable there)")
    if not all(0.0 < w <= 50.0 for w in args.omega):
        raise ValueError(f"--omega {args.omega}: each frequency must lie in (0, 50] rad/s")
    if not 0.0 < args.radius <= 2.0:
        raise ValueError(f"--radius {args.radius}: must lie in (0, 2] (in units of sqrt(mu))")
    if not (0.0 < args.amp_tol < 1.0 and 0.0 < args.phase_tol_deg < 180.0 and args.horizon_s > 0.0):
        raise ValueError("--amp_tol must lie in (0, 1), --phase_tol_deg in (0, 180), --horizon_s above 0")


def main(argv: list[str] | None = None) -> int:
    cfg = CPGConfig()
    p = ArgumentParser(prog="python studies/fig1/figure.py", description=__doc__.split("\n")[0])
    p.add_argument("--out", required=True, help="output directory (must not exist)")
    p.add_argument("--samples", type=positive_int, default=1000, help="random starts per network (default 1000)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random starts (default 0)")
    p.add_argument("--dt", type=float, nargs="+", default=None,
                   help="CPG steps [s] (default: every step the CPG tasks integrate with, 0.0025 and 0.005)")
    p.add_argument("--omega", type=float, nargs="+", default=[cfg.fixed_omega, *cfg.omega_range],
                   help="commanded omega [rad/s]; the first is the figure's (default: the fixed gait's, then the "
                        "range's ends)")  # fmt: skip
    p.add_argument("--radius", type=float, default=1.5, help="starts uniform over the disc of this radius x sqrt(mu)")
    p.add_argument("--horizon_s", type=float, default=8.0, help="seconds integrated per start (default 8)")
    p.add_argument("--amp_tol", type=float, default=0.01, help="relative amplitude tolerance (default 0.01)")
    p.add_argument("--phase_tol_deg", type=float, default=1.0, help="phase tolerance [deg] (default 1)")
    args = p.parse_args(argv)
    args.dt = args.dt or _task_steps()
    _check(args)
    from hexnewton.analysis.report import git_rev

    t0, control_dt = time.perf_counter(), TaskConfig().control_dt
    starts = random_starts(args.seed, args.samples, args.radius, cfg.mu)
    runs, traces, fig_steps = [], {}, {}
    for dt in args.dt:
        horizon = int(round(args.horizon_s / dt))
        for omega in args.omega:
            for name in NETWORKS:
                shown = dt == args.dt[0] and omega == args.omega[0]
                c = convergence(name, cfg, omega, dt, starts, horizon, args.amp_tol, math.radians(args.phase_tol_deg),
                                keep=horizon if shown else 0)  # fmt: skip
                st = c["steps"]
                first = st["both"][0]
                runs.append({"network": name, "dt": dt, "omega": omega, "horizon_steps": horizon,
                             **{k: step_stats(v, dt, control_dt) for k, v in st.items()},
                             "first_start_steps": float(first) if np.isfinite(first) else None,
                             **{k: c["cycle"][k] for k in ("omega_measured", "radius_min", "radius_max")}})  # fmt: skip
                if shown:
                    traces[name], fig_steps[name] = c["trace"], st["both"]
                b = runs[-1]["both"]
                print(f"{name:8s} step {1000 * dt:g} ms, omega {omega:.2f}: median {_fmt(b['median_steps'])} steps, "
                      f"p95 {_fmt(b['p95_steps'])}, never {b['never']}", flush=True)  # fmt: skip
    meta = {"command": "python studies/fig1/figure.py " + " ".join(argv if argv is not None else sys.argv[1:]),
            "git_rev": git_rev(), "samples": args.samples, "seed": args.seed,
            "starts": f"each oscillator's (x, y) uniform over the disc of radius {args.radius:g} sqrt(mu)",
            "dt": args.dt, "omega": args.omega, "horizon_s": args.horizon_s, "amp_tol": args.amp_tol,
            "phase_tol_deg": args.phase_tol_deg, "control_dt": control_dt,
            "cpg": {k: getattr(cfg, k) for k in ("alpha", "mu", "delta", "theta", "duty", "steepness")},
            "compensation_omega_c": {k: round(float(network_omega(np.array([args.omega[0]]), cfg.delta,
                                                            coupling_weights(k))[0, 0]), 3) for k in NETWORKS},
            "wall_s": round(time.perf_counter() - t0, 1)}  # fmt: skip
    result = {"meta": meta, "networks": {k: v[0] for k, v in NETWORKS.items()}, "paper_steps": PAPER_STEPS,
              "runs": runs, "param_counts": param_counts(), "verdict": verdict(runs, args.omega[0]),
              "figure": FIGURE, "figure_steps": {k: [None if np.isinf(x) else float(x) for x in v]
                                                 for k, v in fig_steps.items()}}  # fmt: skip
    os.makedirs(args.out)
    plot_figure(os.path.join(args.out, FIGURE), runs, traces, fig_steps, args.dt[0], args.omega[0])
    with open(os.path.join(args.out, "results.json"), "w") as f:
        json.dump(result, f, indent=1)
    with open(os.path.join(args.out, "report.md"), "w") as f:
        f.write(report_markdown(result))
    print(f"report in {args.out}/ (report.md, results.json, {FIGURE}) after {meta['wall_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(run(main, "python studies/fig1/figure.py"))
