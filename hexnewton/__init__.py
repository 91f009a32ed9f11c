"""hexnewton: GPU-vectorized hierarchical CPG + RL hexapod locomotion on Newton and Warp."""

import warp as _wp

_wp.config.quiet = True  # no init banner or per-module compile chatter; errors and warnings still print

__version__ = "0.1.0"
