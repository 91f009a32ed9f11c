"""hexnewton: GPU-vectorized hierarchical CPG + RL hexapod locomotion on Newton and Warp."""

__version__ = "0.1.0"
