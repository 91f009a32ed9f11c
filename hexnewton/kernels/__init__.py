"""Warp kernels: gait patterns now; the CPG (Eq. 3), mapping (Eq. 4), observations, rewards, resets next."""
