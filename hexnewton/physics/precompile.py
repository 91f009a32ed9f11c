"""Parallel compilation of the Warp modules a physics step launches, before the first step."""

from __future__ import annotations

import os

import warp as wp


# Warp modules (defined at import time) that a World's step launches, as listed by a CPU run. They are compiled
# in parallel before the first step (``precompile``), on CUDA (NVRTC) and on the CPU (LLVM) alike: on the 2-core
# machine a cold start to the first iteration took 74 s against 82 s compiling them one by one. Kernels that
# mujoco_warp builds on the fly still compile lazily (161 s of a 265 s cold start on an H100,
# results/time_to_skill); a module missing from this list only costs time, never correctness.
STEP_MODULES = (
    "newton._src.geometry.broad_phase_nxn", "newton._src.geometry.bvh", "newton._src.geometry.narrow_phase",
    "newton._src.sim.articulation", "newton._src.sim.collide", "newton._src.solvers.mujoco.kernels",
    "mujoco_warp._src.constraint", "mujoco_warp._src.derivative", "mujoco_warp._src.forward",
    "mujoco_warp._src.passive", "mujoco_warp._src.set_const", "mujoco_warp._src.smooth",
    "mujoco_warp._src.solver", "mujoco_warp._src.support",
)  # fmt: skip


def precompile(device: str, max_workers: int | None = None) -> list[str]:
    """Compile ``STEP_MODULES`` and every ``hexnewton`` Warp module for ``device`` on parallel threads
    (default: one per CPU core); returns the module names loaded."""
    from warp._src.context import user_modules

    modules = [m for m in list(user_modules.values())
               if m.kernels and (m.name in STEP_MODULES or m.name.startswith("hexnewton."))]  # fmt: skip
    wp.force_load(device=device, modules=modules, max_workers=max_workers or os.cpu_count() or 1)
    return [m.name for m in modules]
