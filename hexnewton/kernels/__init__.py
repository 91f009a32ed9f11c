"""Warp kernels (each with a float64 NumPy reference): CPG (Eq. 3), mapping (Eq. 4), action scaling, episode ends."""
