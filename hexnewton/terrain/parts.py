"""The terrain's collision surface as static boxes plus meshes (``TerrainConfig.collision = "mesh_boxes"``).

The height grid is cut along x into strips, band by band along y (the whole width, or one curriculum lane each):

* a run of columns whose cells all share one height across the band (a flat run-up, a stair tread, a landing,
  the flat ground beyond the blocks) becomes one box whose top is that height;
* a run of columns that is not constant across the band (the rugged blocks) becomes one closed triangle mesh of
  its sub-grid (:func:`~hexnewton.terrain.mesh.grid_to_mesh`).

Equal parts of neighbouring bands (same columns, same box height) are merged. Every part reaches down to the same
bottom, ``min(height) - base_depth``, so the parts tile the patch without gaps and their union has the surface of
the single mesh. Pure NumPy apart from :func:`add_mesh_boxes` (which loads Newton and Warp when called).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from hexnewton.terrain.heightmap import HeightGrid
from hexnewton.terrain.mesh import grid_to_mesh

if TYPE_CHECKING:
    import newton


@dataclass(frozen=True)
class Part:
    """Cells ``i0 .. i1 - 1`` along x by ``j0 .. j1 - 1`` along y; ``box``: one height over all of them."""

    i0: int
    i1: int
    j0: int
    j1: int
    box: bool


def _column_runs(h: np.ndarray) -> list[tuple[int, int, bool]]:
    """Maximal runs ``(i0, i1, constant)`` of the columns of ``h`` (nx, band): constant runs share one height."""
    const = (h == h[:, :1]).all(axis=1)
    runs, i, nx = [], 0, h.shape[0]
    while i < nx:
        j = i + 1
        if const[i]:
            while j < nx and const[j] and h[j, 0] == h[i, 0]:
                j += 1
        else:
            while j < nx and not const[j]:
                j += 1
        runs.append((i, j, bool(const[i])))
        i = j
    return runs


def split_strips(grid: HeightGrid, band: int | None = None) -> list[Part]:
    """Cut ``grid`` into boxes (full-band strips of one height) and rugged parts (everything else).

    ``band``: cells per band along y (must divide ``grid.ny``; None: the whole width). Parts of neighbouring bands
    with the same columns (and, for boxes, the same height) are merged. Sorted by (box, i0, j0).
    """
    h = np.asarray(grid.heights)
    band = grid.ny if band is None else int(band)
    if band <= 0 or grid.ny % band:
        raise ValueError(f"band ({band} cells) must be positive and divide the grid's {grid.ny} cells along y")
    parts = [Part(i0, i1, j0, j0 + band, box)
             for j0 in range(0, grid.ny, band) for i0, i1, box in _column_runs(h[:, j0:j0 + band])]  # fmt: skip
    parts.sort(key=lambda p: (p.box, p.i0, p.i1, float(h[p.i0, p.j0]) if p.box else 0.0, p.j0))
    merged: list[Part] = []
    for p in parts:
        q = merged[-1] if merged else None
        if (q is not None and (q.box, q.i0, q.i1, q.j1) == (p.box, p.i0, p.i1, p.j0)
                and (not p.box or h[q.i0, q.j0] == h[p.i0, p.j0])):  # fmt: skip
            merged[-1] = Part(q.i0, q.i1, q.j0, p.j1, q.box)
        else:
            merged.append(p)
    return sorted(merged, key=lambda p: (p.box, p.i0, p.j0))


def add_mesh_boxes(grid: HeightGrid, builder: newton.ModelBuilder, cfg: newton.ModelBuilder.ShapeConfig,
                   name: str, band: int | None = None, base_depth: float = 0.1, watertight: bool = False) -> list[int]:
    """Add the parts of :func:`split_strips` as static shapes (body -1): boxes from the common bottom
    ``min(height) - base_depth`` up to their height, closed meshes down to the same bottom (``watertight``: without
    T-junctions, :func:`~hexnewton.terrain.mesh.grid_to_mesh`). Returns the shape indices (consecutive),
    meshes first."""
    import newton
    import warp as wp

    if not base_depth > 0:
        raise ValueError(f"base_depth must be positive, got {base_depth!r}")
    h = np.asarray(grid.heights, dtype=np.float32)
    zb = float(np.float32(h.min() - base_depth))
    ids = []
    for n, p in enumerate(split_strips(grid, band)):
        xa, xb = grid.x0 + p.i0 * grid.res, grid.x0 + p.i1 * grid.res
        ya, yb = grid.y0 + p.j0 * grid.res, grid.y0 + p.j1 * grid.res
        if p.box:
            hz = 0.5 * (float(h[p.i0, p.j0]) - zb)
            xf = wp.transform(wp.vec3(0.5 * (xa + xb), 0.5 * (ya + yb), zb + hz), wp.quat_identity())
            ids.append(builder.add_shape_box(-1, xform=xf, hx=0.5 * (xb - xa), hy=0.5 * (yb - ya), hz=hz, cfg=cfg,
                                             label=f"terrain_{name}_box{n}"))  # fmt: skip
        else:
            sub = HeightGrid(h[p.i0:p.i1, p.j0:p.j1].copy(), xa, ya, grid.res)
            vertices, indices = grid_to_mesh(sub, base_depth=float(sub.heights.min()) - zb, watertight=watertight)
            mesh = newton.Mesh(vertices, indices, compute_inertia=False)  # static: no mass properties
            ids.append(builder.add_shape_mesh(-1, mesh=mesh, cfg=cfg, label=f"terrain_{name}_mesh{n}"))
    return ids
