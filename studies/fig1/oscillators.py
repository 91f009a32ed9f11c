"""Fig. 1: the two-oscillator CPG against a six-oscillator network, in NumPy: the networks, their limit cycles, the
convergence from random starts and the figure. The command line and its report: ``python studies/fig1/figure.py``."""

from __future__ import annotations

import math

import numpy as np

from hexnewton.analysis.figures import save_png
from hexnewton.config import LEG_NAMES, LEG_OSCILLATOR, CPGConfig
from hexnewton.kernels.reference import hopf_cpg_reference, hopf_network_reference, tripod_theta

#: name: (label, oscillator groups (tripod of each oscillator), coupling weight of each link)
NETWORKS = {
    "two": ("two oscillators (the kernel's pair)", (0, 1), 1.0),
    "six_sum": ("six oscillators, delta on each link", LEG_OSCILLATOR, 1.0),
    "six_mean": ("six oscillators, delta / 5 on each link", LEG_OSCILLATOR, 0.2),
}


#: §2.2, Fig. 1: steps to converge read from the paper's text (step size not published)
PAPER_STEPS = {"six": 200, "two": 70}


#: seconds from the locked start before the reference cycle is recorded
SETTLE_S = 4.0


def coupling_weights(name: str) -> np.ndarray:
    """weights[j, i]: how strongly oscillator j drives oscillator i (0 on the diagonal)."""
    _, groups, w = NETWORKS[name]
    n = len(groups)
    return w * (1.0 - np.eye(n))


def tripod_phases(name: str, theta: float) -> np.ndarray:
    """The locked phase of each oscillator relative to the first: -theta g_i."""
    return -theta * np.asarray(NETWORKS[name][1], np.float64)


def random_starts(seed: int, samples: int, radius: float, mu: float) -> np.ndarray:
    """(samples, 6, 2): each leg's (x, y) uniform over the disc of radius ``radius`` sqrt(mu)."""
    rng = np.random.default_rng(seed)
    r = radius * math.sqrt(mu) * np.sqrt(rng.uniform(0.0, 1.0, (samples, 6)))
    phi = rng.uniform(-math.pi, math.pi, (samples, 6))
    return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)


def stepper(name: str, cfg: CPGConfig, omega: float, dt: float, samples: int):
    """One CPG step of network ``name`` for ``samples`` states (samples, n, 2) at the commanded ``omega``."""
    if name == "two":
        params = np.zeros((samples, 15))
        params[:, 0] = omega

        def step_two(s: np.ndarray) -> np.ndarray:
            _, out, _ = hopf_cpg_reference(params, params, s.reshape(samples, 4), 1.0, cfg.alpha, cfg.mu, cfg.delta,
                                           cfg.theta, cfg.duty, cfg.steepness, dt)  # fmt: skip
            return out.reshape(samples, 2, 2)

        return step_two
    theta_ji, weights = tripod_theta(NETWORKS[name][1], cfg.theta), coupling_weights(name)
    om = np.full(samples, omega)

    def step_network(s: np.ndarray) -> np.ndarray:
        return hopf_network_reference(s, om, cfg.alpha, cfg.mu, cfg.delta, theta_ji, weights, cfg.duty,
                                      cfg.steepness, dt)[0]  # fmt: skip

    return step_network


def limit_cycle(name: str, cfg: CPGConfig, omega: float, dt: float) -> dict:
    """The network's own converged cycle, from the locked start: after ``SETTLE_S`` s, one cycle of each oscillator's
    (phase, radius), its frequency measured over the second half of the settling and that cycle."""
    phases = tripod_phases(name, cfg.theta)
    s = math.sqrt(cfg.mu) * np.stack([np.cos(phases), np.sin(phases)], axis=-1)[None]
    step = stepper(name, cfg, omega, dt, 1)
    settle, cycle = int(round(SETTLE_S / dt)), int(math.ceil(2 * math.pi / omega / dt)) + 2
    z_prev, turned, phi, rad = s[0, :, 0] + 1j * s[0, :, 1], 0.0, [], []
    for k in range(settle + cycle):
        s = step(s)
        z = s[0, :, 0] + 1j * s[0, :, 1]
        if k >= settle // 2:
            turned = turned + np.angle(z / z_prev)
        z_prev = z
        if k >= settle:
            phi.append(np.angle(z))
            rad.append(np.abs(z))
    rad = np.array(rad)
    freq = turned / ((settle + cycle - settle // 2) * dt)
    return {"phase": np.array(phi), "radius": rad, "omega_measured": float(freq.mean()),
            "radius_min": float(rad.min()), "radius_max": float(rad.max())}  # fmt: skip


def errors(s: np.ndarray, cycle: dict, phases: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per state (N, n, 2): the largest relative radius error against the cycle at the same phase, and the largest
    pair phase error against the tripod relation [rad]; inf where the state is not finite."""
    z = s[..., 0] + 1j * s[..., 1]
    phi = np.angle(z)
    ref = np.stack([np.interp(phi[:, i], cycle["phase"][:, i], cycle["radius"][:, i], period=2 * math.pi)
                    for i in range(z.shape[1])], axis=1)  # fmt: skip
    amp = np.abs(np.abs(z) / ref - 1.0).max(axis=1)
    u = z * np.exp(-1j * phases)
    i, j = np.triu_indices(z.shape[1], 1)
    ph = np.abs(np.angle(u[:, i] * np.conj(u[:, j]))).max(axis=1)
    bad = ~np.isfinite(s).all(axis=(1, 2))
    amp[bad], ph[bad] = np.inf, np.inf
    return amp, ph


def convergence(name: str, cfg: CPGConfig, omega: float, dt: float, starts: np.ndarray, horizon: int,
                amp_tol: float, phase_tol: float, keep: int = 0) -> dict:
    """Steps to converge (first step from which the criterion holds up to ``horizon``; inf: never) for each start,
    for both criteria and for each alone; ``trace`` holds the first start's states over ``keep`` + 1 steps."""
    n = len(NETWORKS[name][1])
    s = np.array(starts[:, :n], np.float64)
    cycle = limit_cycle(name, cfg, omega, dt)
    phases = tripod_phases(name, cfg.theta)
    step = stepper(name, cfg, omega, dt, len(s))
    last_bad = {k: np.full(len(s), -1) for k in ("both", "amplitude", "phase")}
    trace = []
    for k in range(horizon + 1):
        if k:
            s = step(s)
        if k <= keep:
            trace.append(s[0].copy())
        amp, ph = errors(s, cycle, phases)
        amp_bad, ph_bad = ~(amp <= amp_tol), ~(ph <= phase_tol)
        for key, bad in (("both", amp_bad | ph_bad), ("amplitude", amp_bad), ("phase", ph_bad)):
            last_bad[key][bad] = k
    steps = {}
    for key, lb in last_bad.items():
        st = (lb + 1).astype(np.float64)
        st[lb == horizon] = np.inf
        steps[key] = st
    return {"steps": steps, "cycle": cycle, "trace": np.array(trace)}


def step_stats(steps: np.ndarray, dt: float, control_dt: float) -> dict:
    """Median, 95th percentile and max of the steps to converge (None where it lies beyond the horizon), in steps,
    seconds and control steps; how many never converged."""
    out = {"never": int(np.isinf(steps).sum())}
    for key, v in (("median", np.median(steps)), ("p95", np.percentile(steps, 95)), ("max", steps.max())):
        ok = bool(np.isfinite(v))
        out[f"{key}_steps"] = float(v) if ok else None
        out[f"{key}_s"] = float(v * dt) if ok else None
        out[f"{key}_control_steps"] = float(v * dt / control_dt) if ok else None
    return out


def param_counts() -> dict:
    """Oscillators, directed coupling terms (one theta_ji each), independent coupling phases (theta_ij = -theta_ji)
    and state variables of each topology, and the pair's reduction against the six."""
    rows = {}
    for key, n in (("two", 2), ("six", 6)):
        rows[key] = {"oscillators": n, "directed_couplings": n * (n - 1), "coupling_phases": n * (n - 1) // 2,
                     "state_variables": 2 * n}  # fmt: skip
    rows["reduction_pct"] = {k: round(100.0 * (1.0 - rows["two"][k] / rows["six"][k]), 1) for k in rows["two"]}
    return rows


def plot_figure(path: str, runs: list[dict], traces: dict, steps: dict, dt: float, omega: float) -> None:
    """(a) six_sum, (b) two, (c) six_mean: y of each oscillator from the first start; (d) share converged."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    first = {r["network"]: r for r in runs if r["dt"] == dt and r["omega"] == omega}

    def span(names) -> int:  # 1.3 x the largest p95 of ``names``, in hundreds, within the trace
        p95 = [first[k]["both"]["p95_steps"] or first[k]["horizon_steps"] for k in names]
        return min(int(math.ceil(1.3 * max(p95) / 100.0)) * 100, min(len(traces[k]) - 1 for k in names))

    upto = {"six_sum": span(("six_sum", "two")), "two": span(("six_sum", "two")), "six_mean": span(("six_mean",))}
    fig, axes = plt.subplots(2, 2, figsize=(12, 7))
    shades = {0: plt.get_cmap("Blues"), 1: plt.get_cmap("Reds")}
    panels = (("six_sum", "(a)"), ("two", "(b)"), ("six_mean", "(c)"))
    for ax, (name, tag) in zip(axes.flat, panels):
        tr = traces[name][: upto[name] + 1]
        groups = NETWORKS[name][1]
        names = LEG_NAMES if len(groups) == 6 else ("oscillator 0 (R1 L2 R3)", "oscillator 1 (L1 R2 L3)")
        for i, leg in enumerate(names):
            shade = 0.85 - 0.25 * sum(g == groups[i] for g in groups[:i])
            ax.plot(np.arange(len(tr)), tr[:, i, 1], lw=1.0, color=shades[groups[i]](shade), label=leg)
        conv = first[name]["first_start_steps"]
        if conv is not None and conv <= upto[name]:
            ax.axvline(conv, color="k", lw=0.8, ls=":", label=f"converged: step {conv:.0f}")
        ax.set(title=f"{tag} {NETWORKS[name][0]}", xlabel="step", ylabel="output y")
        ax.legend(fontsize=7, ncol=2, loc="lower right")
    ax = axes[1, 1]
    for name in NETWORKS:
        st = np.sort(steps[name])
        ax.plot(st, np.arange(1, len(st) + 1) / len(st), label=NETWORKS[name][0])
    for key, v in PAPER_STEPS.items():
        ax.axvline(v, color="grey", ls=":", lw=0.8)
        ax.text(v, 0.02, f" paper, {key}: {v}", rotation=90, fontsize=7, color="grey", va="bottom")
    ax.set(title=f"(d) share of {len(st)} random starts converged", xlabel="step", ylabel="share",
           xlim=(0, upto["six_mean"]))
    ax.legend(fontsize=7, loc="center right")
    for a in axes.flat:
        a.grid(alpha=0.3)
    fig.suptitle(f"Eq. 3 networks from random starts: omega = {omega:.2f} rad/s, step = {1000 * dt:g} ms (one RK4 "
                 "step per physics substep); blue: tripod R1 L2 R3, red: tripod L1 R2 L3", fontsize=10)  # fmt: skip
    fig.tight_layout()
    save_png(fig, path, dpi=80)
    plt.close(fig)
