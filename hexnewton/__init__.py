"""hexnewton: GPU-vectorized hierarchical CPG + RL hexapod locomotion on Newton and Warp."""

import warp as _wp

# no init banner or per-module compile chatter; warnings and errors still print
_wp.config.log_level = _wp.LOG_WARNING

__version__ = "0.1.0"
