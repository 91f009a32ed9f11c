"""CPU time per call of the collision pipeline vs one MuJoCo substep (16 walking envs), per terrain and gap."""
import time
import warnings
from dataclasses import replace

import numpy as np

from hexnewton.config import HexConfig, SimConfig, TerrainConfig
from hexnewton.kernels.cpg import CPGController
from hexnewton.physics.world import World

for terrain in ("flat", "complex"):
    for gap in (0.005, 0.01):
        cfg = HexConfig(sim=replace(SimConfig(), num_envs=16, device="cpu", rigid_gap=gap), terrain=TerrainConfig(name=terrain))
        w = World(cfg)
        c = CPGController(w)
        fixed = np.asarray(cfg.cpg.fixed_params())
        c.set_params(fixed * np.random.default_rng(0).uniform(0.7, 1.3, (16, fixed.size))); c.reset()
        w.set_controller(c)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            w.step(50)
        K = 40
        t0 = time.perf_counter()
        for _ in range(K):
            w.pipeline.collide(w.state_0, w.contacts)
        tc = (time.perf_counter() - t0) / K
        t0 = time.perf_counter()
        for _ in range(K):
            c(w); w.state_0.clear_forces()
            w.solver.step(w.state_0, w.state_1, w.control, w.contacts, w.sim_dt)
            w.state_0, w.state_1 = w.state_1, w.state_0
        ts = (time.perf_counter() - t0) / K
        ncon = int(w.solver.mjw_data.nacon.numpy()[0])
        print(f"{terrain:8s} gap {gap}: collide {tc*1e3:.2f} ms, substep (CPG+MuJoCo) {ts*1e3:.2f} ms, contacts {ncon} ({ncon/16:.1f}/env)", flush=True)
