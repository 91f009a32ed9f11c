"""The simulation device: Warp started quietly (:func:`init_warp`) and a device name resolved and checked
(:func:`resolve_device`)."""

from __future__ import annotations

import os

import warp as wp

from hexnewton.errors import HexnewtonError
from hexnewton.physics.private_api import warp_started


def init_warp() -> None:
    """``wp.init()`` without the notice Warp's native library prints on every start of a machine without a CUDA driver
    ("Warp CUDA warning: Could not find or load the NVIDIA CUDA driver ...": the CPU machines this runs on by design);
    anything else it writes to stderr passes through. Warp logs warnings and errors only: no init banner, no
    per-module compile lines. Called where a command first needs Warp (:func:`resolve_device`, which every
    :class:`~hexnewton.physics.world.World` calls), not on import."""
    import sys
    import tempfile

    wp.config.log_level = wp.LOG_WARNING
    if warp_started():
        return
    sys.stderr.flush()
    saved = os.dup(2)
    with tempfile.TemporaryFile() as captured:
        os.dup2(captured.fileno(), 2)
        try:
            wp.init()
        finally:
            os.dup2(saved, 2)
            os.close(saved)
        captured.seek(0)
        text = captured.read().decode(errors="replace")
    rest = [line for line in text.splitlines(keepends=True) if "Could not find or load the NVIDIA CUDA driver" not in line]
    sys.stderr.write("".join(rest))


def resolve_device(name: str | None) -> str:
    """``None``/``"auto"`` -> ``cuda:0`` if CUDA is available else ``cpu``; explicit CUDA must exist."""
    init_warp()
    if name in (None, "", "auto"):
        return "cuda:0" if wp.is_cuda_available() else "cpu"
    if name.startswith("cuda"):
        if not wp.is_cuda_available():
            raise HexnewtonError(f"device '{name}' was requested but this machine has no CUDA device")
        if name == "cuda":
            return "cuda:0"
        try:
            wp.get_device(name)
        except Exception:
            raise HexnewtonError(f"device '{name}' does not exist (CUDA devices: {wp.get_cuda_device_count()})")
        return name
    if name != "cpu":
        raise HexnewtonError(f"unknown device '{name}': use cpu, cuda or cuda:N")
    return name
