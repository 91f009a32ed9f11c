"""Fast terrain height queries inside Warp kernels, with float64 NumPy references.

A :class:`HeightField` struct carries the :class:`~hexnewton.terrain.heightmap.HeightGrid` to the
device. ``terrain_height`` is one cell lookup (indices clamped to the grid edge, so points off the
patch see the nearest edge cell); ``max_terrain_height`` is the highest cell overlapping an
axis-aligned square, e.g. a foot's footprint.

Note on precision: the kernels compute cell indices in float32. Within about 1e-4 cells of a cell
edge the float32 index can differ by one from the float64 reference, so comparisons against the
references should keep sample points (and square edges) slightly away from cell edges.

This module deliberately does not use ``from __future__ import annotations`` (Warp reads the
annotations of structs, functions and kernels at definition time).
"""

import numpy as np
import warp as wp

from hexnewton.terrain.heightmap import HeightGrid


@wp.struct
class HeightField:
    """Device copy of a :class:`HeightGrid`; cell (i, j) spans x0 + [i, i+1) / inv_res in x."""

    heights: wp.array2d(dtype=wp.float32)
    x0: float
    y0: float
    inv_res: float
    nx: int
    ny: int


def height_field_from_grid(grid: HeightGrid, device: wp.DeviceLike = None) -> HeightField:
    """Upload ``grid`` to ``device`` as a :class:`HeightField` (the struct keeps the array alive)."""
    hf = HeightField()
    hf.heights = wp.array(np.ascontiguousarray(grid.heights, dtype=np.float32), dtype=wp.float32,
                          device=device)
    hf.x0 = float(grid.x0)
    hf.y0 = float(grid.y0)
    hf.inv_res = float(1.0 / grid.res)
    hf.nx = int(grid.nx)
    hf.ny = int(grid.ny)
    return hf


@wp.func
def _cell_index(coord: float, origin: float, inv_res: float, n: int) -> int:
    """Index of the cell containing ``coord``, clamped to [0, n - 1]."""
    return wp.clamp(int(wp.floor((coord - origin) * inv_res)), 0, n - 1)


@wp.func
def terrain_height(hf: HeightField, x: float, y: float) -> float:
    """Terrain height at (x, y): the height of the (clamped) cell containing the point."""
    i = _cell_index(x, hf.x0, hf.inv_res, hf.nx)
    j = _cell_index(y, hf.y0, hf.inv_res, hf.ny)
    return hf.heights[i, j]


@wp.func
def max_terrain_height(hf: HeightField, x: float, y: float, half_extent: float) -> float:
    """Highest cell overlapping the square [x - half_extent, x + half_extent] x [y - ..., y + ...]."""
    i0 = _cell_index(x - half_extent, hf.x0, hf.inv_res, hf.nx)
    i1 = _cell_index(x + half_extent, hf.x0, hf.inv_res, hf.nx)
    j0 = _cell_index(y - half_extent, hf.y0, hf.inv_res, hf.ny)
    j1 = _cell_index(y + half_extent, hf.y0, hf.inv_res, hf.ny)
    h = hf.heights[i0, j0]
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            h = wp.max(h, hf.heights[i, j])
    return h


@wp.kernel
def sample_heights_kernel(
    hf: HeightField,
    points: wp.array(dtype=wp.vec3),
    half_extent: float,
    height_out: wp.array(dtype=wp.float32),
    max_out: wp.array(dtype=wp.float32),
):
    """Per point: terrain height under it and the max height over its square footprint."""
    tid = wp.tid()
    p = points[tid]
    height_out[tid] = terrain_height(hf, p[0], p[1])
    max_out[tid] = max_terrain_height(hf, p[0], p[1], half_extent)


def sample_heights(
    hf: HeightField, points_np: np.ndarray, half_extent: float, device: wp.DeviceLike = None
) -> tuple[np.ndarray, np.ndarray]:
    """Host helper: run :func:`sample_heights_kernel` on (N, 2) or (N, 3) points; returns (h, hmax)."""
    pts = np.asarray(points_np, dtype=np.float32)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"points must have shape (N, 2) or (N, 3), got {pts.shape}")
    if pts.shape[1] == 2:
        pts = np.concatenate([pts, np.zeros((len(pts), 1), dtype=np.float32)], axis=1)
    n = len(pts)
    points = wp.array(pts, dtype=wp.vec3, device=device)
    h = wp.zeros(n, dtype=wp.float32, device=device)
    hmax = wp.zeros(n, dtype=wp.float32, device=device)
    if n > 0:
        wp.launch(sample_heights_kernel, dim=n, inputs=[hf, points, float(half_extent)], outputs=[h, hmax],
                  device=device)
    return h.numpy(), hmax.numpy()


# ----------------------------------------------------------------------------------------------------
# float64 NumPy references
# ----------------------------------------------------------------------------------------------------


def _cell_index_np(coord: np.ndarray, origin: float, res: float, n: int) -> np.ndarray:
    return np.clip(np.floor((coord - origin) / res), 0, n - 1).astype(np.int64)


def terrain_height_np(grid: HeightGrid, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Float64 reference of :func:`terrain_height` (vectorised over broadcastable x, y)."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    i = _cell_index_np(x, grid.x0, grid.res, grid.nx)
    j = _cell_index_np(y, grid.y0, grid.res, grid.ny)
    return grid.heights[i, j].astype(np.float64)


def max_terrain_height_np(grid: HeightGrid, x: np.ndarray, y: np.ndarray, half_extent: float) -> np.ndarray:
    """Float64 reference of :func:`max_terrain_height` (vectorised over broadcastable x, y)."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    i0 = _cell_index_np(x - half_extent, grid.x0, grid.res, grid.nx)
    i1 = _cell_index_np(x + half_extent, grid.x0, grid.res, grid.nx)
    j0 = _cell_index_np(y - half_extent, grid.y0, grid.res, grid.ny)
    j1 = _cell_index_np(y + half_extent, grid.y0, grid.res, grid.ny)
    h = grid.heights.astype(np.float64)
    out = h[i0, j0]
    for di in range(int((i1 - i0).max(initial=0)) + 1):
        for dj in range(int((j1 - j0).max(initial=0)) + 1):
            inside = (i0 + di <= i1) & (j0 + dj <= j1)
            cand = h[np.minimum(i0 + di, i1), np.minimum(j0 + dj, j1)]
            out = np.where(inside, np.maximum(out, cand), out)
    return out
