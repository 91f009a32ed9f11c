"""Graph capture: a step recorded once and replayed (a CUDA graph on GPU, Warp's own capture on CPU)."""

from __future__ import annotations

from collections.abc import Callable

import warp as wp


def capture_graph(device: str, step: Callable[[], None], restore: list[wp.array]) -> wp.Graph:
    """Run ``step`` once uncaptured (kernel compilation, lazy solver allocations), put the ``restore`` arrays
    back as they were, then record ``step`` into a graph (a CUDA graph on GPU, Warp's capture on CPU)."""
    saved = [wp.clone(a) for a in restore]
    step()
    for dst, src in zip(restore, saved):
        wp.copy(dst, src)
    wp.synchronize_device(device)
    with wp.ScopedDevice(device), wp.ScopedCapture() as cap:
        step()
    return cap.graph
