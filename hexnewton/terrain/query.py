"""Terrain height queries on a :class:`~hexnewton.terrain.heightmap.HeightGrid`, in float64 NumPy: the height
under a point (:func:`terrain_height_np`, one cell lookup, indices clamped to the grid edge, so points off the patch
see the nearest edge cell) and the highest cell overlapping an axis-aligned square (:func:`max_terrain_height_np`).
They are the references of the MDP's in-kernel queries (``terrain_height`` and ``max_terrain_height`` in
``hexnewton/mdp/terms/ground.py``), and the host's own queries (spawn heights, C MuJoCo's terrain scanner).

Note on precision: the kernels compute cell indices in float32. Within about 1e-4 cells of a cell
edge the float32 index can differ by one from the float64 reference, so comparisons against the
references should keep sample points (and square edges) slightly away from cell edges.
"""

from __future__ import annotations

import numpy as np

from hexnewton.terrain.heightmap import HeightGrid

# ----------------------------------------------------------------------------------------------------
# float64 NumPy references
# ----------------------------------------------------------------------------------------------------


def _cell_index_np(coord: np.ndarray, origin: float, res: float, n: int) -> np.ndarray:
    return np.clip(np.floor((coord - origin) / res), 0, n - 1).astype(np.int64)


def terrain_height_np(grid: HeightGrid, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Float64 reference of ``mdp.terms.ground.terrain_height`` (vectorised over broadcastable x, y)."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    i = _cell_index_np(x, grid.x0, grid.res, grid.nx)
    j = _cell_index_np(y, grid.y0, grid.res, grid.ny)
    return grid.heights[i, j].astype(np.float64)


def max_terrain_height_np(grid: HeightGrid, x: np.ndarray, y: np.ndarray, half_extent: float) -> np.ndarray:
    """Float64 reference of ``mdp.terms.ground.max_terrain_height`` (vectorised over broadcastable x, y)."""
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
