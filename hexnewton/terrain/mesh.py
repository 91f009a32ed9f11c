"""Compact closed triangle mesh of a piecewise-constant height grid (pure NumPy).

The surface of a :class:`~hexnewton.terrain.heightmap.HeightGrid` is made of

* top faces: equal-height cells merged greedily into rectangles (a 25 cm step strip is one quad,
  a 2 cm rugged block one quad), normal +z;
* vertical walls where neighbouring cells differ, merged along collinear runs with the same
  low/high heights, normal pointing from the higher cell to the lower one;
* skirt walls around the patch down to ``min(height) - base_depth`` and one bottom face (normal -z).

Every quad is wound counter-clockwise seen from outside (the convention ``newton.Mesh`` requires).
Merged faces meet smaller ones at T-junctions, so the mesh is geometrically closed but not
edge-manifold; Newton resolves such split seams itself (``compute_mesh_boundary_flags``).
Vertices live on grid nodes and are shared between quads.

``grid_to_mesh(..., watertight=True)`` (``TerrainConfig.watertight``) removes the T-junctions: every
quad edge is split at the mesh vertices lying on it and each quad, now a convex polygon of N
vertices (its 4 corners and the split points), is cut into the fewest triangles it can have without
added vertices, N - 2, none degenerate (:func:`_triangulate_polygons`). Every edge is then shared by
exactly two triangles, so ``newton.Mesh.is_watertight`` holds and ``ModelBuilder.finalize`` skips its
mesh-boundary pass, except at saddle corners: where two diagonal cells are both higher than the other
two at some height, four walls share the vertical edge between those heights (the solid touches
itself along a line), and no mesh of this surface has every edge in exactly two triangles. There the
two walls in the plane y = const take one added vertex halfway up that edge, so that the two walls in
x = const share its whole length and the two in y = const its two halves (:func:`_saddle_points`): a
T-junction along a line where the surface already folds onto itself, and the only vertices off the
grid's heights. First, cells that meet at a grid node and differ by less than 1 um are put at the lower
of the two heights (:func:`_merge_close_heights`: Newton folds vertices closer than 100 nm into one);
the random block heights have a few hundred such cells in the complex and rugged curricula.
"""

from __future__ import annotations

import numpy as np

from hexnewton.terrain.heightmap import HeightGrid

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


def grid_to_mesh(grid: HeightGrid, base_depth: float = 0.1, watertight: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Closed, outward-wound triangle mesh of ``grid``'s piecewise-constant surface.

    Returns ``(vertices, indices)``: float32 (V, 3) and flat int32 (3T,). The solid extends down to
    ``min(heights) - base_depth``. ``watertight``: without T-junctions (every edge in exactly two
    triangles, ``newton.Mesh.is_watertight``; module docstring), the same surface in more triangles.
    """
    if not base_depth > 0:
        raise ValueError(f"base_depth must be positive, got {base_depth!r}")
    h = np.ascontiguousarray(grid.heights, dtype=np.float32)
    if h.ndim != 2 or h.size == 0:
        raise ValueError(f"grid.heights must be a non-empty 2-D array, got shape {h.shape}")
    zb = np.float32(h.min() - base_depth)
    padded = np.full((h.shape[0] + 2, h.shape[1] + 2), zb, dtype=np.float32)
    padded[1:-1, 1:-1] = h
    if watertight:
        padded = _merge_close_heights(padded)
        h = np.ascontiguousarray(padded[1:-1, 1:-1])
    parts = [_top_quads(h), _x_walls(padded), _y_walls(padded), _bottom_quad(*h.shape, zb)]
    ix, iy, z = (np.concatenate([part[k] for part in parts]) for k in range(3))
    if not watertight:
        return _weld(grid, ix, iy, z)
    sizes = [len(part[0]) for part in parts]
    y_wall = np.repeat(np.arange(4) == 2, sizes)
    return _weld_watertight(grid, ix, iy, z, y_wall, _saddle_points(padded))


# ----------------------------------------------------------------------------------------------------
# watertight variant: quads split at the vertices on their edges
# ----------------------------------------------------------------------------------------------------

_NEXT = np.array([1, 2, 3, 0])

# ours: least height difference [m] between the watertight mesh's vertices on one vertical line. Newton's
# ``Mesh.is_watertight`` folds vertices closer than 1e-7 m into one (its 100 nm bucket, on float32 products), which
# would merge the ends of a wall lower than that and split its edges' counts; a saddle's added vertex needs room too.
HEIGHT_TOLERANCE = 1.0e-6

# the pairs of cells that share a grid node: offsets (di, dj) of the first and the second cell
_NODE_PAIRS = (((0, 0), (1, 0)), ((0, 0), (0, 1)), ((0, 0), (1, 1)), ((1, 0), (0, 1)))


def _merge_close_heights(p: np.ndarray, tol: float = HEIGHT_TOLERANCE) -> np.ndarray:
    """``p`` with any two cells that share a grid node and differ by less than ``tol`` both at the lower height.

    Repeated until no such pair is left; a height moves down by less than ``tol`` unless such pairs chain. The
    surface loses the walls lower than ``tol``: 292 cells of the complex task's curriculum, 592 of the rugged
    task's (random block heights), none on the stepped one (studies/startup_mesh).
    """
    p = p.copy()
    rows, cols = p.shape[0] - 1, p.shape[1] - 1
    while True:
        merged = False
        for (ai, aj), (bi, bj) in _NODE_PAIRS:
            a, b = p[ai : ai + rows, aj : aj + cols], p[bi : bi + rows, bj : bj + cols]
            i, j = np.nonzero((a != b) & (np.abs(a - b) < tol))
            if len(i):
                low = np.minimum(a[i, j], b[i, j])
                np.minimum.at(p, (i + ai, j + aj), low)
                np.minimum.at(p, (i + bi, j + bj), low)
                merged = True
        if not merged:
            return p


def _saddle_points(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid nodes of the padded grid ``p`` where four walls share a vertical edge, and a height halfway up it.

    Around node (i, j) lie the cells a = p[i, j], b = p[i + 1, j] (a's neighbour in x), c = p[i, j + 1] (in y) and
    d = p[i + 1, j + 1]. All four walls at the node cover the heights between max(b, c) and min(a, d) (a and d
    higher) or between max(a, d) and min(b, c); no vertex lies strictly between. Returns ``(i, j, z_mid)``.
    """
    a, b, c, d = p[:-1, :-1], p[1:, :-1], p[:-1, 1:], p[1:, 1:]
    ad_high = np.maximum(b, c) < np.minimum(a, d)
    lo = np.where(ad_high, np.maximum(b, c), np.maximum(a, d))
    hi = np.where(ad_high, np.minimum(a, d), np.minimum(b, c))
    i, j = np.nonzero(lo < hi)
    z1, z2 = lo[i, j], hi[i, j]
    z_mid = (0.5 * (z1.astype(np.float64) + z2)).astype(np.float32)
    if not ((z1 < z_mid) & (z_mid < z2)).all():  # heights one float32 apart: no room for a vertex
        raise ValueError("saddle heights too close to split in float32")
    return i, j, z_mid


def _triangulate_polygons(start: np.ndarray, size: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Triangles (T, 3) of positions into a flat array of convex polygons, N - 2 per polygon of N vertices.

    Polygon q holds positions ``start[q] .. start[q] + size[q] - 1``, counter-clockwise: corner c0 at 0, then the
    points of edge c0-c1, c1, those of c1-c2 and c2 at ``m[q]``; c3 and the points of c2-c3 and c3-c0 follow. Seen
    as two chains from c0 to c2, P = p_0 .. p_m (through c1) and Q = q_0 .. q_n (through c3, q_j at N - j), the
    triangles are (c0, p_1, q_1), a fan from p_1 over Q's edges q_1 .. q_{n-1}, and a fan from q_{n-1} over P's
    edges p_1 .. p_m. None is degenerate: p_1 lies on neither line of Q's edges and q_{n-1} on neither of P's
    (split points lie strictly inside their edge), and (c0, p_1, q_1) has one vertex on each of c0's two edges.
    A plain quad (N = 4) gives (c0, c1, c3), (c1, c2, c3).
    """
    n = size - m

    def ranks(count: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        owner = np.repeat(np.arange(len(count)), count)
        first = np.cumsum(count) - count
        return owner, np.arange(owner.size) - first[owner] + 1

    s, N = start, size
    first = np.stack([s, s + 1, s + N - 1], axis=1)
    q, j = ranks(n - 2)  # j = 1 .. n - 2: (p_1, q_{j+1}, q_j)
    fan_p = np.stack([s[q] + 1, s[q] + N[q] - j - 1, s[q] + N[q] - j], axis=1)
    q, i = ranks(m - 1)  # i = 1 .. m - 1: (p_i, p_{i+1}, q_{n-1})
    fan_q = np.stack([s[q] + i, s[q] + i + 1, s[q] + m[q] + 1], axis=1)
    return np.concatenate([first, fan_p, fan_q])


def _weld_watertight(grid: HeightGrid, ix: np.ndarray, iy: np.ndarray, z: np.ndarray, y_wall: np.ndarray,
                     saddles: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Like :func:`_weld`, with every quad edge split at the vertices on it (the saddle points only for ``y_wall``
    quads' edges) and each quad triangulated by :func:`_triangulate_polygons`."""
    si, sj, sz = saddles
    z_values, z_inv = np.unique(np.concatenate([z.reshape(-1), sz]), return_inverse=True)
    nx1, ny1, nz = grid.nx + 1, grid.ny + 1, len(z_values)
    cz = z_inv[: z.size].reshape(z.shape).astype(np.int64)
    cx, cy = ix.astype(np.int64), iy.astype(np.int64)
    unique_keys, corner = np.unique((cx * ny1 + cy) * nz + cz, return_inverse=True)
    corner = corner.reshape(-1, 4)
    n_base = len(unique_keys)
    keys = np.concatenate([unique_keys, (si.astype(np.int64) * ny1 + sj) * nz + z_inv[z.size :]])
    node, vz = np.divmod(keys, nz)
    vx, vy = np.divmod(node, ny1)
    vertices = np.empty((len(keys), 3), dtype=np.float32)
    vertices[:, 0] = grid.x0 + vx * grid.res
    vertices[:, 1] = grid.y0 + vy * grid.res
    vertices[:, 2] = z_values[vz]

    # Vertices sorted along each axis's lines: key = line * extent + coordinate along the axis.
    coords, extents = (vx, vy, vz), (nx1, ny1, nz)

    def line_key(axis: int, c: tuple[np.ndarray, ...]) -> np.ndarray:
        u, w = [k for k in range(3) if k != axis]
        return (c[u] * extents[w] + c[w]) * extents[axis]

    vline = [line_key(axis, coords) + coords[axis] for axis in range(3)]
    ids = np.arange(len(keys))
    # tables: x lines, y lines, z lines without the saddle points, z lines with them
    tables = [(0, ids[:n_base]), (1, ids[:n_base]), (2, ids[:n_base]), (2, ids)]
    sorted_keys, sorted_ids, offsets = [], [], [0]
    for axis, sel in tables:
        order = np.argsort(vline[axis][sel], kind="stable")
        sorted_keys.append(vline[axis][sel][order])
        sorted_ids.append(sel[order])
        offsets.append(offsets[-1] + len(sel))
    flat_ids = np.concatenate(sorted_ids)

    a = (cx, cy, cz)
    b = tuple(c[:, _NEXT] for c in a)
    moves = np.stack([a[k] != b[k] for k in range(3)])  # (3, Q, 4)
    if not (moves.sum(axis=0) == 1).all():
        raise AssertionError("quad edges must be axis aligned")
    axis_of = np.argmax(moves, axis=0)
    table_of = np.where((axis_of == 2) & y_wall[:, None], 3, axis_of)
    start = np.empty(corner.shape, dtype=np.int64)
    end = np.empty(corner.shape, dtype=np.int64)
    ascending = np.empty(corner.shape, dtype=bool)
    for t, (axis, _) in enumerate(tables):
        sel = table_of == t
        base = line_key(axis, tuple(c[sel] for c in a))
        lo, hi = np.minimum(a[axis][sel], b[axis][sel]), np.maximum(a[axis][sel], b[axis][sel])
        start[sel] = np.searchsorted(sorted_keys[t], base + lo, side="right") + offsets[t]
        end[sel] = np.searchsorted(sorted_keys[t], base + hi, side="left") + offsets[t]
        ascending[sel] = b[axis][sel] > a[axis][sel]

    # Polygons, flat: per quad edge its first corner, then the points strictly inside it in walking order.
    count = (end - start).reshape(-1)
    edge = np.repeat(np.arange(count.size), count)
    rank = np.arange(edge.size) - (np.cumsum(count) - count)[edge]
    s, e = start.reshape(-1)[edge], end.reshape(-1)[edge]
    inside = flat_ids[np.where(ascending.reshape(-1)[edge], s + rank, e - 1 - rank)]
    seg = np.cumsum(count + 1) - (count + 1)
    polygon = np.empty(int(count.sum()) + count.size, dtype=np.int64)
    is_corner = np.zeros(polygon.size, dtype=bool)
    is_corner[seg] = True
    polygon[seg] = corner.reshape(-1)
    polygon[~is_corner] = inside
    count = count.reshape(-1, 4)
    tri = _triangulate_polygons(seg[::4], 4 + count.sum(axis=1), count[:, 0] + count[:, 1] + 2)
    return vertices, polygon[tri].astype(np.int32).reshape(-1)
