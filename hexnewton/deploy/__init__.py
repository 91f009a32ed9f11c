"""Deployment: the exported controller's runtime (``runtime``: NumPy and onnxruntime only, no Warp, Newton or torch)
and the robot and terrain as MJCF for C MuJoCo (``mjcf``)."""
