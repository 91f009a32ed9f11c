"""hexnewton: GPU-vectorized hierarchical CPG + RL hexapod locomotion on Newton and Warp."""

try:
    import warp as _wp
except ImportError:  # the deployment runtime (hexnewton.deploy) runs on NumPy and onnxruntime alone
    _wp = None
else:
    # no init banner or per-module compile chatter; warnings and errors still print
    _wp.config.log_level = _wp.LOG_WARNING

__version__ = "0.1.0"
