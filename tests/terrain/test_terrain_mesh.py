"""Tests for the watertight terrain mesh (``grid_to_mesh(..., watertight=True)``, ``TerrainConfig.watertight``): every
edge in exactly two triangles (``newton.Mesh.is_watertight``), the same surface as today's mesh, and off by default.
CPU only, small grids."""

from __future__ import annotations

from dataclasses import replace

import newton
import numpy as np
import pytest
import warp as wp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hexnewton.config import TerrainConfig
from hexnewton.terrain import HeightGrid, build_height_grid, grid_to_mesh, make_terrain, terrain_height_np
from hexnewton.terrain.mesh import HEIGHT_TOLERANCE

wp.init()
DEVICE = "cpu"

# small versions of the paper's terrains and of the complex course's curriculum (3 lanes)
SMALL = {
    "rugged": TerrainConfig(name="rugged", seed=3, x_max=0.4, width=0.6),
    "stepped": TerrainConfig(name="stepped", x_max=1.5, width=0.4, step_count=3),
    "complex_levels": TerrainConfig(name="complex", x_min=-0.2, x_max=1.8, complex_rugged_length=0.4,
                                    complex_stepped_length=0.5, rugged_x_max=1.8, levels=3, lane_width=0.3,
                                    complex_landing_blocks=0.2),
}  # fmt: skip


def _mesh(vertices: np.ndarray, indices: np.ndarray) -> newton.Mesh:
    return newton.Mesh(vertices, indices, compute_inertia=False)


def _signed_volume(vertices: np.ndarray, indices: np.ndarray) -> float:
    tri = vertices.astype(np.float64)[indices.reshape(-1, 3)]
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)


def _check_watertight(grid: HeightGrid, base_depth: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """The watertight mesh of ``grid``: watertight, no degenerate triangle, axis-aligned faces, closed, the same
    volume, outward normals and face areas per direction as today's mesh, every vertex on today's surface."""
    old_v, old_i = grid_to_mesh(grid, base_depth)
    v, i = grid_to_mesh(grid, base_depth, watertight=True)
    assert v.dtype == np.float32 and i.dtype == np.int32
    assert _mesh(v, i).is_watertight
    tri = v.astype(np.float64)[i.reshape(-1, 3)]
    area_n = 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area = np.linalg.norm(area_n, axis=1)
    assert (area > 0).all(), "degenerate triangles"
    unit = area_n / area[:, None]
    assert np.isclose(np.abs(unit).max(axis=1), 1.0).all(), "faces must be axis aligned"
    np.testing.assert_allclose(area_n.sum(axis=0), 0.0, atol=1e-7)  # closed
    # same solid, same outward winding
    np.testing.assert_allclose(_signed_volume(v, i), _signed_volume(old_v, old_i), rtol=1e-6, atol=1e-9)
    assert _signed_volume(v, i) > 0
    old_tri = old_v.astype(np.float64)[old_i.reshape(-1, 3)]
    old_n = 0.5 * np.cross(old_tri[:, 1] - old_tri[:, 0], old_tri[:, 2] - old_tri[:, 0])
    for axis in range(3):
        for sign in (-1, 1):
            got = area[np.sign(np.round(unit[:, axis])) == sign].sum()
            old_area = np.linalg.norm(old_n, axis=1)
            old_unit = old_n / old_area[:, None]
            want = old_area[np.sign(np.round(old_unit[:, axis])) == sign].sum()
            np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-9)
    # tops at the height of the cells beneath (to HEIGHT_TOLERANCE where near-equal heights merged)
    top = unit[:, 2] > 0.5
    centroid = tri[top].mean(axis=1)
    assert (tri[top][:, :, 2] == tri[top][:, :1, 2]).all()
    np.testing.assert_allclose(tri[top][:, 0, 2], terrain_height_np(grid, centroid[:, 0], centroid[:, 1]),
                               atol=HEIGHT_TOLERANCE, rtol=0)  # fmt: skip
    return v, i


@settings(max_examples=80, deadline=None)
@given(
    heights=arrays(np.float32, st.tuples(st.integers(1, 8), st.integers(1, 8)),
                   elements=st.sampled_from([-0.05, 0.0, 0.03, 0.05, 0.1])),
    base_depth=st.sampled_from([0.01, 0.1]),
)  # fmt: skip
def test_watertight_random_grids(heights: np.ndarray, base_depth: float) -> None:
    _check_watertight(HeightGrid(heights, x0=-0.3, y0=0.2, res=0.05), base_depth)


def test_todays_mesh_is_not_watertight_and_the_new_one_is() -> None:
    # a 2-cell strip beside two 1-cell blocks: the strip's top edge meets the blocks' walls at a T-junction
    grid = HeightGrid(np.array([[0.0, 0.0], [0.1, 0.2]], dtype=np.float32), x0=0.0, y0=0.0, res=0.1)
    assert not _mesh(*grid_to_mesh(grid)).is_watertight
    _, i = _check_watertight(grid)
    # the bottom's and the strip's edges split at the 2 + 1 vertices on them: one triangle more per split point
    assert len(i) // 3 > len(grid_to_mesh(grid)[1]) // 3


def test_plain_box_keeps_two_triangles_per_face() -> None:
    grid = HeightGrid(np.full((3, 2), 0.05, dtype=np.float32), x0=0.0, y0=0.0, res=0.1)
    v, i = _check_watertight(grid)
    assert len(v) == 8 and len(i) // 3 == 12


def test_saddle_corner() -> None:
    # diagonal cells 0.1 and 0.08 above the other two: four walls share the vertical edge 0.03 .. 0.08 at the centre
    h = np.array([[0.1, 0.0], [0.03, 0.08]], dtype=np.float32)
    grid = HeightGrid(h, x0=0.0, y0=0.0, res=0.1)
    v, _ = _check_watertight(grid)
    centre = np.isclose(v[:, 0], 0.1) & np.isclose(v[:, 1], 0.1)
    # the four cells' corners and the added vertex halfway up the shared edge
    np.testing.assert_allclose(np.sort(v[centre, 2]), [0.0, 0.03, 0.055, 0.08, 0.1], atol=1e-7)


def test_near_equal_heights_merge() -> None:
    # neighbours 50 nm apart: Newton folds such vertices into one; the watertight mesh puts both at the lower height
    h = np.array([[0.02, np.float32(0.02) + np.float32(5e-8)], [0.04, 0.0]], dtype=np.float32)
    assert h[0, 0] != h[0, 1]
    grid = HeightGrid(h, x0=0.0, y0=0.0, res=0.1)
    v, i = _check_watertight(grid)
    assert _mesh(v, i).is_watertight
    assert not np.isin(h[0, 1], v[:, 2])


@wp.kernel
def _ray_down_kernel(mesh: wp.uint64, xy: wp.array(dtype=wp.vec2), z0: float, hit_z: wp.array(dtype=wp.float32),
                     normal_z: wp.array(dtype=wp.float32)):  # fmt: skip
    tid = wp.tid()
    p = xy[tid]
    q = wp.mesh_query_ray(mesh, wp.vec3(p[0], p[1], z0), wp.vec3(0.0, 0.0, -1.0), 100.0)
    hit_z[tid] = -100.0
    if q.result:
        hit_z[tid] = wp.mesh_eval_position(mesh, q.face, q.u, q.v)[2]
        normal_z[tid] = q.normal[2]


def _ray_cast_heights(vertices: np.ndarray, indices: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    wmesh = wp.Mesh(points=wp.array(vertices, dtype=wp.vec3, device=DEVICE),
                    indices=wp.array(indices, dtype=wp.int32, device=DEVICE))  # fmt: skip
    out = [wp.zeros(len(xy), dtype=wp.float32, device=DEVICE) for _ in range(2)]
    z0 = float(vertices[:, 2].max()) + 0.5
    wp.launch(_ray_down_kernel, dim=len(xy), inputs=[wmesh.id, wp.array(xy, dtype=wp.vec2, device=DEVICE), z0],
              outputs=out, device=DEVICE)  # fmt: skip
    return out[0].numpy(), out[1].numpy()


@pytest.mark.parametrize("name", list(SMALL))
def test_same_surface_by_ray_casts(name: str) -> None:
    cfg = SMALL[name]
    grid = build_height_grid(cfg)
    v, i = _check_watertight(grid)
    # every cell centre, and random points off the cell edges
    xc, yc = grid.cell_centers()
    xc, yc = np.meshgrid(xc, yc, indexing="ij")
    rng = np.random.default_rng(11)
    frac = rng.uniform(0.05, 0.95, size=(4000, 2))
    cell = np.stack([rng.integers(0, grid.nx, 4000), rng.integers(0, grid.ny, 4000)], axis=1)
    rand = np.array([grid.x0, grid.y0]) + (cell + frac) * grid.res
    xy = np.concatenate([np.stack([xc.ravel(), yc.ravel()], axis=1), rand]).astype(np.float32)
    expected = terrain_height_np(grid, xy[:, 0], xy[:, 1])
    hit_z, normal_z = _ray_cast_heights(v, i, xy)
    np.testing.assert_allclose(hit_z, expected, atol=1e-6, rtol=0)
    np.testing.assert_allclose(normal_z, 1.0, atol=1e-6)
    old_z, _ = _ray_cast_heights(*grid_to_mesh(grid), xy)
    np.testing.assert_allclose(hit_z, old_z, atol=1e-6, rtol=0)


def test_switch_off_by_default_is_todays_mesh() -> None:
    assert TerrainConfig().watertight is False
    for cfg in SMALL.values():
        grid = build_height_grid(cfg)
        today = grid_to_mesh(grid)
        terrain = make_terrain(cfg)
        np.testing.assert_array_equal(terrain.mesh.vertices, today[0])
        np.testing.assert_array_equal(terrain.mesh.indices, today[1])
        np.testing.assert_array_equal(grid_to_mesh(grid, watertight=False)[1], today[1])
        on = make_terrain(replace(cfg, watertight=True)).mesh
        assert on.is_watertight and not terrain.mesh.is_watertight
        np.testing.assert_array_equal(on.indices, grid_to_mesh(grid, watertight=True)[1])


def _finalized_terrain(cfg: TerrainConfig) -> tuple[newton.Model, list[int]]:
    builder = newton.ModelBuilder()
    terrain = make_terrain(cfg)
    first = terrain.add_to_builder(builder, newton.ModelBuilder.ShapeConfig())
    model = builder.finalize(device=DEVICE)
    meshes = [s for s in range(first, builder.shape_count) if builder.shape_type[s] == newton.GeoType.MESH]
    assert meshes
    return model, meshes


@pytest.mark.parametrize("collision", ["mesh", "mesh_boxes"])
def test_finalize_skips_boundary_pass(collision: str) -> None:
    cfg = replace(SMALL["complex_levels"], collision=collision)
    model, meshes = _finalized_terrain(cfg)
    assert (model._shape_mesh_boundary_start.numpy()[meshes] >= 0).all()  # today: boundary flags computed
    model, meshes = _finalized_terrain(replace(cfg, watertight=True))
    assert (model._shape_mesh_boundary_start.numpy()[meshes] == -1).all()  # watertight: pass skipped
    from hexnewton.physics.private_api import mesh_watertight_flag

    assert (model._shape_mesh_properties.numpy()[meshes] & mesh_watertight_flag()).all()
