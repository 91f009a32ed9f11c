"""The ground as the terms see it: a terrain's height grid on the device (:class:`HeightField`) and the Warp height
queries the kernels run on it; their float64 twins are ``hexnewton/terrain/query.py``'s."""

import numpy as np
import warp as wp

from hexnewton.terrain.heightmap import HeightGrid


@wp.struct
class HeightField:
    """Device copy of a :class:`HeightGrid` (a terrain's exact heights); cell (i, j) spans x0 + [i, i+1) / inv_res in x."""

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
