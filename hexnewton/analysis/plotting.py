"""Figures: the CPG outputs and the six legs' joint targets over two gait cycles (like the paper's Fig. 1b, 2)."""

from __future__ import annotations

import math

import numpy as np
import warp as wp

from hexnewton.analysis.figures import save_png
from hexnewton.config import LEG_NAMES, HexConfig
from hexnewton.kernels.cpg import hopf_cpg_kernel, mapping_kernel
from hexnewton.kernels.reference import initial_cpg_state
from hexnewton.robot import leg_bounds


def gait_trajectory(cfg: HexConfig, cycles: float = 2.0, device: str = "cpu"):
    """Run the Hopf and mapping kernels (no physics) from the locked start with the fixed parameters.

    Returns (t (T,), cpg state (T, 4), joint targets (T, 18)) at the physics substep rate.
    """
    from hexnewton.physics.device import init_warp

    init_warp()
    c, r = cfg.cpg, cfg.robot
    dt = cfg.sim.frame_dt / cfg.sim.substeps
    params = wp.array(np.asarray([c.fixed_params()], np.float32), device=device)
    state = wp.array(np.asarray([initial_cpg_state(c.mu, c.theta)], np.float32), device=device)
    dy = wp.zeros((1, 2), dtype=wp.float32, device=device)
    targets = wp.zeros((1, 18), dtype=wp.float32, device=device)
    no_q = wp.zeros((1, 7), dtype=wp.float32, device=device)  # the body's attitude (no reflex without the posture)
    stand = wp.vec3(*r.stand_pose)
    lower, upper = leg_bounds(r)
    lo, hi = wp.vec3(*lower), wp.vec3(*upper)
    steps = int(round(cycles * 2 * math.pi / c.fixed_omega / dt))
    ts, ss, qs = [], [], []
    for k in range(steps):
        wp.launch(hopf_cpg_kernel, dim=1, inputs=[params, 1.0, c.alpha, c.mu, c.delta, c.theta, c.duty, c.steepness,
                  dt], outputs=[params, state, dy], device=device)  # fmt: skip
        wp.launch(mapping_kernel, dim=1, inputs=[state, dy, params, 1.0 / math.sqrt(c.mu), stand, lo, hi, 0, no_q, 0.0,
                  0.0], outputs=[targets], device=device)  # fmt: skip
        ts.append((k + 1) * dt)
        ss.append(state.numpy()[0].copy())
        qs.append(targets.numpy()[0].copy())
    return np.array(ts), np.array(ss), np.array(qs)


def plot_gait(cfg: HexConfig, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, s, q = gait_trajectory(cfg)
    fig, axes = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
    axes[0].plot(t, s[:, 1], label="y, oscillator 0 (R1 L2 R3)")
    axes[0].plot(t, s[:, 3], label="y, oscillator 1 (L1 R2 L3)")
    axes[0].set_ylabel("CPG output y")
    axes[0].set_title(f"Two-Hopf CPG (Eq. 3) and mapping (Eq. 4): omega = {cfg.cpg.fixed_omega:.2f} rad/s, "
                      f"A1 = {cfg.cpg.fixed_a1}, A2 = {cfg.cpg.fixed_a2}, A3 = {cfg.cpg.fixed_a3}")  # fmt: skip
    for row, joint in enumerate(("hip", "knee", "ankle"), start=1):
        for leg, name in enumerate(LEG_NAMES):
            axes[row].plot(t, q[:, 3 * leg + row - 1], label=name, linestyle="-" if leg % 2 == 0 else "--")
        axes[row].set_ylabel(f"{joint} target [rad]")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=7, ncol=3)
    axes[-1].set_xlabel("time [s]")
    fig.tight_layout()
    save_png(fig, path, dpi=110)
    plt.close(fig)
