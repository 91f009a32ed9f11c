"""The terrain's collision surface as static boxes only (``TerrainConfig.collision = "boxes"``), pure NumPy.

The height grid is cut into greedy rectangles of equal-height cells (the top faces of :mod:`.mesh`): every 2 cm rugged
block is one box (neighbouring blocks never share a random height), every run-up, stair tread, landing and the flat
ground beyond the blocks one box each. Every box reaches down to the common bottom ``min(height) - base_depth``, so
the boxes tile the patch without gaps, as the C MuJoCo model's boxes do (:mod:`hexnewton.deploy.mjcf`): a foot meets
box edges and faces, not triangles.

A rugged patch is ~50,000 boxes, too many to pair every robot shape with every box. The boxes' pairs with the robot
shapes are therefore found anew before every collision detection from the cell each box covers
(:class:`BoxIndex`, :mod:`.box_pairs`): each robot shape is paired with the boxes under its bounding cube only.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hexnewton.terrain.heightmap import HeightGrid
from hexnewton.terrain.mesh import merge_rows


@dataclass(frozen=True)
class BoxIndex:
    """Boxes ``k``: cells ``i0[k] .. i1[k] - 1`` along x by ``j0[k] .. j1[k] - 1`` along y, top ``top[k]`` (float32
    heights of the grid), bottom ``bottom``; ``cell_box[i, j]`` the box covering cell (i, j)."""

    i0: np.ndarray
    i1: np.ndarray
    j0: np.ndarray
    j1: np.ndarray
    top: np.ndarray
    bottom: float
    cell_box: np.ndarray

    @property
    def count(self) -> int:
        return len(self.top)

    def min_side(self, res: float) -> float:
        """The shortest side of any box [m]."""
        return float(min((self.i1 - self.i0).min(), (self.j1 - self.j0).min())) * res


def grid_boxes(grid: HeightGrid, base_depth: float = 0.1) -> BoxIndex:
    """The boxes of ``grid`` (greedy rectangles of equal-height cells) down to ``min(height) - base_depth``."""
    if not base_depth > 0:
        raise ValueError(f"base_depth must be positive, got {base_depth!r}")
    h = np.ascontiguousarray(grid.heights, dtype=np.float32)
    i0, i1, j0, j1, top = merge_rows(h)
    cell_box = np.full(h.shape, -1, dtype=np.int32)
    for k in range(len(top)):
        cell_box[i0[k]:i1[k], j0[k]:j1[k]] = k
    return BoxIndex(i0.astype(np.int32), i1.astype(np.int32), j0.astype(np.int32), j1.astype(np.int32),
                    top.astype(np.float32), float(np.float32(h.min() - base_depth)), cell_box)  # fmt: skip


def box_capacity(half_width: np.ndarray | float, min_side: float) -> np.ndarray:
    """The most boxes (each side >= ``min_side``, disjoint) a square of half width ``half_width`` can overlap: every
    such box holds a min_side square of its own inside the square grown by min_side on each side."""
    return np.floor((2.0 * np.asarray(half_width, np.float64) / min_side + 2.0) ** 2).astype(np.int64)


def box_pairs_np(index: BoxIndex, grid: HeightGrid, centers: np.ndarray, half_widths: np.ndarray) -> list[list[int]]:
    """Float64 reference of :func:`~hexnewton.terrain.box_pairs.find_box_pairs`: per cube (centre
    ``centers[n]``, half width ``half_widths[n]``), the boxes whose extent (x, y from their cells, z from the bottom to
    their top) overlaps it, in ascending order. A brute-force test of every box."""
    c = np.asarray(centers, np.float64)
    r = np.asarray(half_widths, np.float64)
    xa, xb = grid.x0 + index.i0 * grid.res, grid.x0 + index.i1 * grid.res
    ya, yb = grid.y0 + index.j0 * grid.res, grid.y0 + index.j1 * grid.res
    top = index.top.astype(np.float64)
    out = []
    for (x, y, z), w in zip(c, r):
        hit = (xa <= x + w) & (xb >= x - w) & (ya <= y + w) & (yb >= y - w) & (top >= z - w) & (index.bottom <= z + w)
        out.append(np.flatnonzero(hit).tolist())
    return out


def add_boxes(index: BoxIndex, grid: HeightGrid, builder, cfg, name: str) -> int:
    """Add the boxes of ``index`` as static shapes (body -1), then one box 100 m under the terrain that no shape
    reaches (the pair list's filler, :mod:`.box_pairs`). Returns the first box's shape index (consecutive).

    The boxes carry no automatic collision flag: only the explicit pair list reaches them (a flagged box would be
    paired with every shape, and MuJoCo's model, which pairs all its geoms, would hold ~10^9 pairs). The far box is
    flagged, so MuJoCo holds it as a geom, and the boxes' contacts take its (identical) contact parameters
    (``World``)."""
    import warp as wp

    first = builder.shape_count
    far_cfg, cfg = cfg, cfg.copy()
    cfg.has_shape_collision = False
    xc = grid.x0 + 0.5 * (index.i0 + index.i1) * grid.res
    yc = grid.y0 + 0.5 * (index.j0 + index.j1) * grid.res
    hz = 0.5 * (index.top.astype(np.float64) - index.bottom)
    for k in range(index.count):
        xf = wp.transform(wp.vec3(xc[k], yc[k], index.bottom + hz[k]), wp.quat_identity())
        builder.add_shape_box(-1, xform=xf, hx=0.5 * (index.i1[k] - index.i0[k]) * grid.res,
                              hy=0.5 * (index.j1[k] - index.j0[k]) * grid.res, hz=hz[k], cfg=cfg,
                              label=f"terrain_{name}_box{k}")  # fmt: skip
    far = wp.transform(wp.vec3(grid.x0, grid.y0, index.bottom - 100.0), wp.quat_identity())
    builder.add_shape_box(-1, xform=far, hx=0.01, hy=0.01, hz=0.01, cfg=far_cfg, label=f"terrain_{name}_far")
    return first
