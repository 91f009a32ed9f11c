"""Compact closed triangle mesh of a piecewise-constant height grid (pure NumPy).

The surface of a :class:`~hexnewton.physics.terrain.heightmap.HeightGrid` is made of

* top faces: equal-height cells merged greedily into rectangles (a 25 cm step strip is one quad,
  a 2 cm rugged block one quad), normal +z;
* vertical walls where neighbouring cells differ, merged along collinear runs with the same
  low/high heights, normal pointing from the higher cell to the lower one;
* skirt walls around the patch down to ``min(height) - base_depth`` and one bottom face (normal -z).

Every quad is wound counter-clockwise seen from outside (the convention ``newton.Mesh`` requires).
Merged faces meet smaller ones at T-junctions, so the mesh is geometrically closed but not
edge-manifold; Newton resolves such split seams itself (``compute_mesh_boundary_flags``).
Vertices live on grid nodes and are shared between quads.
"""

from __future__ import annotations

import numpy as np

from hexnewton.physics.terrain.heightmap import HeightGrid

# Corner order that reverses a quad's winding (flips its normal).
_FLIP = np.array([0, 3, 2, 1])


def _row_runs(valid: np.ndarray, *keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Maximal runs along axis 1 of ``valid`` cells with equal ``keys``.

    Returns ``(row, c0, c1)``: run ``n`` covers columns ``c0[n] .. c1[n] - 1`` of row ``row[n]``.
    """
    rows, cols = valid.shape
    differs = np.ones((rows, cols + 1), dtype=bool)  # differs[:, c]: a run may not join c-1 and c
    differs[:, 1:-1] = ~valid[:, :-1] | ~valid[:, 1:]
    for key in keys:
        differs[:, 1:-1] |= key[:, 1:] != key[:, :-1]
    start_r, start_c = np.nonzero(valid & differs[:, :-1])
    _, last_c = np.nonzero(valid & differs[:, 1:])
    return start_r, start_c, last_c + 1


def merge_rows(h: np.ndarray) -> tuple[np.ndarray, ...]:
    """Greedy rectangles of equal-height cells: row runs, then identical runs of consecutive rows.

    Returns ``(r0, r1, c0, c1, height)`` with rectangle ``n`` = rows r0..r1-1 x columns c0..c1-1.
    """
    r, c0, c1 = _row_runs(np.ones(h.shape, dtype=bool), h)
    hv = h[r, c0]
    order = np.lexsort((r, hv, c1, c0))
    r, c0, c1, hv = r[order], c0[order], c1[order], hv[order]
    new = np.ones(len(r), dtype=bool)
    new[1:] = (c0[1:] != c0[:-1]) | (c1[1:] != c1[:-1]) | (hv[1:] != hv[:-1]) | (r[1:] != r[:-1] + 1)
    first = np.flatnonzero(new)
    last = np.append(first[1:], len(r)) - 1
    return r[first], r[last] + 1, c0[first], c1[first], hv[first]


def _top_quads(h: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Top faces (normal +z) as quad corner arrays ``(ix, iy, z)`` each of shape (Q, 4)."""
    by_rows = merge_rows(h)
    by_cols = merge_rows(h.T)
    if len(by_cols[0]) < len(by_rows[0]):
        j0, j1, i0, i1, z = by_cols
    else:
        i0, i1, j0, j1, z = by_rows
    ix = np.stack([i0, i1, i1, i0], axis=1)
    iy = np.stack([j0, j0, j1, j1], axis=1)
    return ix, iy, np.repeat(z[:, None], 4, axis=1)


def _wall_runs(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, ...]:
    """Walls between cell rows ``a`` and ``b`` (same shape) where they differ, merged along axis 1.

    Returns ``(row, c0, c1, low, high, a_higher)``.
    """
    row, c0, c1 = _row_runs(a != b, a, b)
    ha, hb = a[row, c0], b[row, c0]
    return row, c0, c1, np.minimum(ha, hb), np.maximum(ha, hb), ha > hb


def _x_walls(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Walls in the planes x = const of the padded grid ``p``; normal +x where the -x cell is higher."""
    i, j0, j1, lo, hi, a_higher = _wall_runs(p[:-1, 1:-1], p[1:, 1:-1])
    # corners (i, j0, lo), (i, j1, lo), (i, j1, hi), (i, j0, hi): normal +x
    ix = np.repeat(i[:, None], 4, axis=1)
    iy = np.stack([j0, j1, j1, j0], axis=1)
    z = np.stack([lo, lo, hi, hi], axis=1)
    return _orient(ix, iy, z, ~a_higher)


def _y_walls(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Walls in the planes y = const of the padded grid ``p``; normal +y where the -y cell is higher."""
    j, i0, i1, lo, hi, a_higher = _wall_runs(p[1:-1, :-1].T, p[1:-1, 1:].T)
    # corners (i0, j, lo), (i1, j, lo), (i1, j, hi), (i0, j, hi): normal -y
    ix = np.stack([i0, i1, i1, i0], axis=1)
    iy = np.repeat(j[:, None], 4, axis=1)
    z = np.stack([lo, lo, hi, hi], axis=1)
    return _orient(ix, iy, z, a_higher)


def _orient(ix: np.ndarray, iy: np.ndarray, z: np.ndarray, flip: np.ndarray) -> tuple[np.ndarray, ...]:
    """Reverse the winding of the quads selected by ``flip``."""
    for arr in (ix, iy, z):
        arr[flip] = arr[flip][:, _FLIP]
    return ix, iy, z


def _bottom_quad(nx: int, ny: int, zb: np.float32) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One face under the whole patch, normal -z."""
    ix = np.array([[0, 0, nx, nx]])
    iy = np.array([[0, ny, ny, 0]])
    return ix, iy, np.full((1, 4), zb, dtype=np.float32)


def _weld(grid: HeightGrid, ix: np.ndarray, iy: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Share vertices between quads (keyed on grid node and height) and split quads into triangles."""
    z_values, z_id = np.unique(z, return_inverse=True)
    key = (ix.astype(np.int64) * (grid.ny + 1) + iy) * len(z_values) + z_id.reshape(z.shape)
    unique_keys, corner = np.unique(key, return_inverse=True)
    node, zi = np.divmod(unique_keys, len(z_values))
    vi, vj = np.divmod(node, grid.ny + 1)
    vertices = np.empty((len(unique_keys), 3), dtype=np.float32)
    vertices[:, 0] = grid.x0 + vi * grid.res
    vertices[:, 1] = grid.y0 + vj * grid.res
    vertices[:, 2] = z_values[zi]
    corner = corner.reshape(-1, 4)
    triangles = corner[:, [0, 1, 2, 0, 2, 3]]  # (c0, c1, c2), (c0, c2, c3): same winding as the quad
    return vertices, triangles.astype(np.int32).reshape(-1)


def grid_to_mesh(grid: HeightGrid, base_depth: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Closed, outward-wound triangle mesh of ``grid``'s piecewise-constant surface.

    Returns ``(vertices, indices)``: float32 (V, 3) and flat int32 (3T,). The solid extends down to
    ``min(heights) - base_depth``.
    """
    if not base_depth > 0:
        raise ValueError(f"base_depth must be positive, got {base_depth!r}")
    h = np.ascontiguousarray(grid.heights, dtype=np.float32)
    if h.ndim != 2 or h.size == 0:
        raise ValueError(f"grid.heights must be a non-empty 2-D array, got shape {h.shape}")
    zb = np.float32(h.min() - base_depth)
    padded = np.full((h.shape[0] + 2, h.shape[1] + 2), zb, dtype=np.float32)
    padded[1:-1, 1:-1] = h
    parts = [_top_quads(h), _x_walls(padded), _y_walls(padded), _bottom_quad(*h.shape, zb)]
    ix, iy, z = (np.concatenate([part[k] for part in parts]) for k in range(3))
    return _weld(grid, ix, iy, z)
