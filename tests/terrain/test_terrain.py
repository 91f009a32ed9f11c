"""Tests for hexnewton.terrain: the paper's terrains (Huang et al. 2025, §3.1), their collision mesh
and the in-kernel height query. CPU only."""

from __future__ import annotations

import re
from dataclasses import replace

import newton
import numpy as np
import pytest
import warp as wp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hexnewton.config import TERRAINS, TerrainConfig
from hexnewton.mdp.terms import HeightField, height_field_from_grid, sample_heights, terrain_height
from hexnewton.terrain import (
    HeightGrid,
    Part,
    Terrain,
    build_height_grid,
    generate,
    grid_to_mesh,
    make_terrain,
    max_terrain_height_np,
    split_strips,
    terrain_height_np,
)

wp.init()
DEVICE = "cpu"
MESH_TERRAINS = tuple(name for name in TERRAINS if name != "flat")  # flat is a plane


@pytest.fixture(scope="module")
def terrains() -> dict[str, Terrain]:
    """All four terrains at the default (simulation) size."""
    return {name: make_terrain(TerrainConfig(name=name)) for name in TERRAINS}


def _walk_y0(terrain: Terrain) -> tuple[np.ndarray, np.ndarray]:
    """Cell-centre x positions and heights along y = 0."""
    g = terrain.grid
    x = g.x0 + (np.arange(g.nx) + 0.5) * g.res
    return x, terrain.height_at(x, 0.0)


def _step_edges(x: np.ndarray, h: np.ndarray, res: float) -> tuple[np.ndarray, np.ndarray]:
    """x of each height change along a walk (the cell edge) and the change."""
    k = np.flatnonzero(np.diff(h) != 0)
    return x[k] + res / 2, np.diff(h)[k]


def _away_from_edges(rng: np.random.Generator, grid: HeightGrid, n: int, margin: float, pad: float = 0.0,
                     offsets: tuple[float, ...] = (0.0,)) -> np.ndarray:
    """n random float32 (x, y) points whose coordinates (+- each offset) keep ``margin`` [m] from any
    cell edge (the float32 kernel and float64 reference may pick different cells right at an edge)."""
    lo, hi = np.array([grid.x0 - pad, grid.y0 - pad]), np.array([grid.x1 + pad, grid.y1 + pad])
    pts = rng.uniform(lo, hi, size=(20 * n, 2)).astype(np.float32)
    keep = np.ones(len(pts), dtype=bool)
    origin = np.array([grid.x0, grid.y0])
    for off in offsets:
        for sign in (-1.0, 1.0):
            frac = np.mod((pts.astype(np.float64) + sign * off - origin) / grid.res, 1.0)
            keep &= ((frac > margin / grid.res) & (frac < 1.0 - margin / grid.res)).all(axis=1)
    pts = pts[keep]
    assert len(pts) >= n
    return pts[:n]


def _triangles(vertices: np.ndarray, indices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corner positions (T, 3, 3) float64 and area-weighted normals (T, 3)."""
    tri = vertices.astype(np.float64)[indices.reshape(-1, 3)]
    return tri, 0.5 * np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])


def _check_closed_mesh(grid: HeightGrid, vertices: np.ndarray, indices: np.ndarray, base_depth: float) -> None:
    """Closure, winding and top faces of a grid mesh, checked geometrically."""
    tri, area_n = _triangles(vertices, indices)
    area = np.linalg.norm(area_n, axis=1)
    assert (area > 0).all(), "degenerate triangles"
    unit = area_n / area[:, None]
    assert np.isclose(np.abs(unit).max(axis=1), 1.0).all(), "faces must be axis aligned"
    # closed surface: the area-weighted normals cancel
    np.testing.assert_allclose(area_n.sum(axis=0), 0.0, atol=1e-7)
    # outward winding: signed volume (divergence theorem) = volume of the solid down to the base
    zb = float(grid.heights.min()) - base_depth
    c = tri.reshape(-1, 3).mean(axis=0)
    volume = np.einsum("ij,ij->i", tri[:, 0] - c, np.cross(tri[:, 1] - c, tri[:, 2] - c)).sum() / 6.0
    expected = (grid.heights.astype(np.float64) - zb).sum() * grid.res**2
    np.testing.assert_allclose(volume, expected, rtol=1e-6)
    # tops (+z) cover the patch once, each at the height of the cells beneath; bottom (-z) covers it once
    patch = (grid.x1 - grid.x0) * (grid.y1 - grid.y0)
    top, bottom = unit[:, 2] > 0.5, unit[:, 2] < -0.5
    np.testing.assert_allclose(area[top].sum(), patch, rtol=1e-6)
    np.testing.assert_allclose(area[bottom].sum(), patch, rtol=1e-6)
    assert np.allclose(tri[bottom][:, :, 2], zb)
    centroid = tri[top].mean(axis=1)
    assert (tri[top][:, :, 2] == tri[top][:, :1, 2]).all()
    np.testing.assert_array_equal(tri[top][:, 0, 2], terrain_height_np(grid, centroid[:, 0], centroid[:, 1]))


# ----------------------------------------------------------------------------------------------------
# height grids
# ----------------------------------------------------------------------------------------------------


def test_grid_layout(terrains: dict[str, Terrain]) -> None:
    cfg = TerrainConfig()
    g = terrains["flat"].grid
    assert g.heights.dtype == np.float32
    assert g.heights.shape == (600, 500)
    assert (g.x0, g.y0, g.res) == (cfg.x_min, -cfg.width / 2, cfg.query_resolution)
    assert np.isclose(g.x1, cfg.x_max) and np.isclose(g.y1, cfg.width / 2)
    assert not g.heights.any()
    # heights[i, j] is the cell x in [x0 + i res, x0 + (i + 1) res)
    rg = terrains["rugged"].grid
    i, j = 123, 77
    x, y = rg.x0 + i * rg.res, rg.y0 + j * rg.res
    assert terrain_height_np(rg, x + 1e-4, y + 1e-4) == rg.heights[i, j]
    assert terrain_height_np(rg, x + rg.res - 1e-4, y + rg.res - 1e-4) == rg.heights[i, j]


def test_rugged_blocks(terrains: dict[str, Terrain]) -> None:
    cfg = TerrainConfig()
    g = terrains["rugged"].grid
    assert cfg.block_size == pytest.approx(0.02) and g.res == pytest.approx(0.01)  # §3.1: 2 cm blocks
    xc, yc = g.cell_centers()
    ix = np.flatnonzero(xc < cfg.rugged_x_max)
    iy = np.flatnonzero(np.abs(yc) < cfg.rugged_half_width)
    assert ix[0] == 0 and iy[0] % 2 == 0  # lattice anchored at (x_min, -width/2)
    region = g.heights[ix[0] : ix[-1] + 1, iy[0] : iy[-1] + 1]
    assert region.shape == (500, 400)
    blocks4 = region.reshape(250, 2, 200, 2)
    assert (blocks4 == blocks4[:, :1, :, :1]).all(), "each 2 x 2 cell block is constant"
    blocks = blocks4[:, 0, :, 0]
    assert (blocks[1:] != blocks[:-1]).all() and (blocks[:, 1:] != blocks[:, :-1]).all()
    assert blocks.min() >= 0.0 and blocks.max() <= cfg.block_height_max  # §3.1: 0-6 cm
    assert blocks.min() < 0.005 and blocks.max() > 0.055
    outside = g.heights.copy()
    outside[ix[0] : ix[-1] + 1, iy[0] : iy[-1] + 1] = 0.0
    assert not outside.any()


def test_rugged_seeded(terrains: dict[str, Terrain]) -> None:
    g0 = terrains["rugged"].grid.heights
    np.testing.assert_array_equal(build_height_grid(TerrainConfig(name="rugged", seed=0)).heights, g0)
    other = build_height_grid(TerrainConfig(name="rugged", seed=1)).heights
    assert (other != g0).mean() > 0.5


def test_stepped(terrains: dict[str, Terrain]) -> None:
    cfg = TerrainConfig()
    g = terrains["stepped"].grid
    assert (g.heights == g.heights[:, :1]).all(), "steps span the full width"
    x, h = _walk_y0(terrains["stepped"])
    edges, rises = _step_edges(x, h, g.res)
    assert len(edges) == 15  # §3.1: 15 steps of 6 cm rise, 25 cm deep, 90 cm in total
    np.testing.assert_allclose(rises, 0.06, atol=1e-6)
    np.testing.assert_allclose(np.diff(edges), 0.25, atol=1e-9)
    assert edges[0] == pytest.approx(cfg.stepped_start_x)
    assert h.max() - h.min() == pytest.approx(0.90, abs=1e-6)
    assert (h[x < cfg.stepped_start_x] == 0).all()
    assert (h[x > edges[-1]] == h.max()).all()  # landing up to x_max


def test_complex(terrains: dict[str, Terrain]) -> None:
    cfg = TerrainConfig()
    g = terrains["complex"].grid
    xc, yc = g.cell_centers()
    rugged_x = xc < 1.5  # §3.1: 1.5 m rugged, then 1.5 m of steps
    # rugged part: the rugged terrain's blocks (same seed), flat beyond |y| = rugged_half_width
    np.testing.assert_array_equal(g.heights[rugged_x], terrains["rugged"].grid.heights[rugged_x])
    assert (g.heights[rugged_x][:, np.abs(yc) < cfg.rugged_half_width] != 0).mean() > 0.99
    steps = g.heights[~rugged_x]
    assert (steps == steps[:, :1]).all(), "steps span the full width"
    x, h = _walk_y0(terrains["complex"])
    edges, rises = _step_edges(x[x > 1.5], h[x > 1.5], g.res)
    assert (h[(x > 1.5) & (x < 1.75)] == np.float32(0.06)).all()  # first step starts exactly at 1.5 m
    assert len(edges) == 5 and np.allclose(edges, 1.5 + 0.25 * np.arange(1, 6))
    np.testing.assert_allclose(rises, 0.06, atol=1e-6)
    assert (h[x > 3.0] == np.float32(0.36)).all()  # landing after 6 steps


def test_complex_landing_blocks(terrains: dict[str, Terrain]) -> None:
    """``complex_landing_blocks``: the rugged terrain's blocks on the landing's height over that length, the course
    before it unchanged, flat landing beyond it and beyond |y| = rugged_half_width."""
    plain = terrains["complex"].grid
    g = build_height_grid(TerrainConfig(name="complex", complex_landing_blocks=1.0))
    xc, yc = g.cell_centers()
    before, on, after = xc < 3.0, (xc >= 3.0) & (xc < 4.0), xc >= 4.0
    np.testing.assert_array_equal(g.heights[before], plain.heights[before])
    np.testing.assert_array_equal(g.heights[after], plain.heights[after])
    band = np.abs(yc) < TerrainConfig().rugged_half_width
    blocks = terrains["rugged"].grid.heights[on][:, band]  # the same seed: the same blocks, 0.36 m higher
    np.testing.assert_allclose(g.heights[on][:, band], 0.36 + blocks.astype(np.float64), atol=1e-6)
    assert (g.heights[on][:, ~band] == np.float32(0.36)).all() and blocks.std() > 0.01
    lanes = build_height_grid(replace(TerrainConfig(name="complex", levels=2, complex_landing_blocks=0.5), seed=1))
    assert lanes.heights.max() <= 0.36 + 0.06 + 1e-6  # the lanes scale the blocks with the heights
    # lanes past the course with treads off the block lattice (23 cm: the last step ends at 3.11 m): the blocks begin
    # on the lattice's next edge, 3.12 m
    past = TerrainConfig(name="complex", complex_landing_blocks=1.0, step_depth=0.23)
    g, steps = build_height_grid(past), round(1.5 / 0.23)
    xc, yc = g.cell_centers()
    band = np.abs(yc) < past.rugged_half_width
    top = steps * past.step_rise
    assert np.allclose(g.heights[(xc > 3.11) & (xc < 3.12)][:, band], top)
    assert g.heights[(xc > 3.12) & (xc < 4.12)][:, band].std() > 0.01 and np.allclose(g.heights[xc > 4.12], top)


def test_unknown_terrain() -> None:
    msg = "unknown terrain 'hills': choose one of flat, rugged, stepped, complex"
    with pytest.raises(ValueError, match=re.escape(msg)):
        build_height_grid(TerrainConfig(name="hills"))
    with pytest.raises(ValueError, match=re.escape(msg)):
        make_terrain(TerrainConfig(name="hills"))
    with pytest.raises(ValueError, match=re.escape(msg)):
        generate("hills")


@pytest.mark.parametrize(
    ("name", "overrides", "message"),
    [
        ("rugged", {"block_size": 0.015}, "block_size (0.015 m) must be a multiple of query_resolution"),
        ("stepped", {"step_depth": 0.255}, "step_depth (0.255 m) must be a multiple of query_resolution"),
        ("flat", {"width": -1.0}, "width must be positive"),
        ("flat", {"query_resolution": 0.0}, "query_resolution must be positive"),
        ("flat", {"x_max": -2.0}, "x_max (-2.0) must be greater than x_min"),
        ("stepped", {"step_count": 0}, "step_count must be a positive integer"),
        ("stepped", {"x_max": 2.0}, "beyond x_max"),
        ("rugged", {"rugged_x_max": 3.99}, "rugged_x_max - x_min (4.99 m) must be a multiple of block_size"),
        ("complex", {"complex_landing_blocks": 0.51},
         "complex_landing_blocks (0.51 m) must be a multiple of block_size"),
        ("complex", {"complex_landing_blocks": -1.0}, "complex_landing_blocks (-1.0) must be >= 0"),
    ],
)
def test_invalid_parameters(name: str, overrides: dict, message: str) -> None:
    with pytest.raises(ValueError, match=re.escape(message)):
        build_height_grid(replace(TerrainConfig(name=name), **overrides))


def test_shrunk_patch_clips_rugged_region() -> None:
    g = build_height_grid(TerrainConfig(name="rugged", x_max=1.0, width=1.0))
    assert g.heights.shape == (200, 100) and (g.heights > 0).mean() > 0.99


# ----------------------------------------------------------------------------------------------------
# collision mesh
# ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", MESH_TERRAINS)
def test_mesh_closed_and_outward(terrains: dict[str, Terrain], name: str) -> None:
    mesh = terrains[name].mesh
    assert mesh.vertices.dtype == np.float32 and mesh.indices.dtype == np.int32
    _check_closed_mesh(terrains[name].grid, mesh.vertices, mesh.indices, base_depth=0.1)


def test_mesh_is_compact(terrains: dict[str, Terrain]) -> None:
    n_tri = {name: len(terrains[name].mesh.indices) // 3 for name in MESH_TERRAINS}
    assert n_tri["rugged"] < 320_000  # ~50k blocks: 1 top quad + ~2 walls each, ~301k triangles
    # stepped: 16 top quads, 15 risers + 2 end skirts, 2 x 16 side skirts, 1 bottom
    assert n_tri["stepped"] == 2 * (16 + 17 + 32 + 1)


@settings(max_examples=60, deadline=None)
@given(
    heights=arrays(np.float32, st.tuples(st.integers(1, 7), st.integers(1, 7)),
                   elements=st.sampled_from([-0.05, 0.0, 0.05, 0.1])),
    base_depth=st.sampled_from([0.01, 0.1]),
)
def test_mesh_random_grids(heights: np.ndarray, base_depth: float) -> None:
    grid = HeightGrid(heights, x0=-0.3, y0=0.2, res=0.05)
    vertices, indices = grid_to_mesh(grid, base_depth=base_depth)
    _check_closed_mesh(grid, vertices, indices, base_depth)


@wp.kernel
def _ray_down_kernel(
    mesh: wp.uint64,
    hf: HeightField,
    xy: wp.array(dtype=wp.vec2),
    hit_z: wp.array(dtype=wp.float32),
    normal_z: wp.array(dtype=wp.float32),
    expected: wp.array(dtype=wp.float32),
):
    tid = wp.tid()
    p = xy[tid]
    z0 = 2.0
    q = wp.mesh_query_ray(mesh, wp.vec3(p[0], p[1], z0), wp.vec3(0.0, 0.0, -1.0), 10.0)
    hit_z[tid] = -100.0
    if q.result:
        hit_z[tid] = z0 - q.t
        normal_z[tid] = q.normal[2]
    expected[tid] = terrain_height(hf, p[0], p[1])


@pytest.mark.parametrize("name", MESH_TERRAINS)
def test_mesh_ray_cast_hits_terrain_height(terrains: dict[str, Terrain], name: str) -> None:
    terrain = terrains[name]
    rng = np.random.default_rng(7)
    xy = _away_from_edges(rng, terrain.grid, 2000, margin=1e-3)
    wmesh = wp.Mesh(points=wp.array(terrain.mesh.vertices, dtype=wp.vec3, device=DEVICE),
                    indices=wp.array(terrain.mesh.indices, dtype=wp.int32, device=DEVICE))
    out = [wp.zeros(len(xy), dtype=wp.float32, device=DEVICE) for _ in range(3)]
    wp.launch(_ray_down_kernel, dim=len(xy),
              inputs=[wmesh.id, height_field_from_grid(terrain.grid, DEVICE), wp.array(xy, dtype=wp.vec2, device=DEVICE)],
              outputs=out, device=DEVICE)
    hit_z, normal_z, expected = (a.numpy() for a in out)
    np.testing.assert_allclose(hit_z, expected, atol=1e-5)
    np.testing.assert_allclose(hit_z, terrain.height_at(xy[:, 0], xy[:, 1]), atol=1e-5)
    np.testing.assert_allclose(normal_z, 1.0, atol=1e-6)  # tops wound counter-clockwise: +z normals


# ----------------------------------------------------------------------------------------------------
# in-kernel height query
# ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", ["rugged", "complex"])
@pytest.mark.parametrize("half_extent", [0.0, 0.012, 0.047])
def test_kernel_matches_reference(terrains: dict[str, Terrain], name: str, half_extent: float) -> None:
    grid = terrains[name].grid
    rng = np.random.default_rng(3)
    xy = _away_from_edges(rng, grid, 1000, margin=1e-5, pad=0.3, offsets=(0.0, half_extent))
    pts = np.concatenate([xy, rng.uniform(-1, 1, size=(len(xy), 1)).astype(np.float32)], axis=1)
    h, hmax = sample_heights(height_field_from_grid(grid, DEVICE), pts, half_extent, DEVICE)
    x, y = xy[:, 0].astype(np.float64), xy[:, 1].astype(np.float64)
    np.testing.assert_allclose(h, terrain_height_np(grid, x, y), atol=1e-6, rtol=0)
    np.testing.assert_allclose(hmax, max_terrain_height_np(grid, x, y, half_extent), atol=1e-6, rtol=0)
    assert (hmax >= h).all()
    if half_extent == 0.0:
        np.testing.assert_array_equal(hmax, h)


def test_max_height_reference_brute_force() -> None:
    grid = HeightGrid(np.arange(20, dtype=np.float32).reshape(4, 5) % 7, x0=0.0, y0=0.0, res=1.0)
    x, y, he = np.array([1.5, -3.0, 2.2]), np.array([2.5, 9.0, 0.3]), 0.6
    got = max_terrain_height_np(grid, x, y, he)
    for k in range(3):
        i0, i1 = (int(np.clip(np.floor(v), 0, 3)) for v in (x[k] - he, x[k] + he))
        j0, j1 = (int(np.clip(np.floor(v), 0, 4)) for v in (y[k] - he, y[k] + he))
        assert got[k] == grid.heights[i0 : i1 + 1, j0 : j1 + 1].max()


# ----------------------------------------------------------------------------------------------------
# Newton integration
# ----------------------------------------------------------------------------------------------------


def test_generate() -> None:
    assert generate("flat") is None
    mesh = generate("stepped")
    assert isinstance(mesh, newton.Mesh) and len(mesh.indices) // 3 == 132
    small = generate("rugged", seed=3, x_max=0.0, width=0.4)
    grid = build_height_grid(TerrainConfig(name="rugged", seed=3, x_max=0.0, width=0.4))
    np.testing.assert_array_equal(small.vertices, grid_to_mesh(grid)[0])


def test_the_whole_grid_mesh_is_built_only_when_used() -> None:
    """mesh_boxes (the tasks' collision) adds its own parts: the whole-grid mesh stays unbuilt; asked for, it is the
    grid's mesh, built once."""
    cfg = TerrainConfig(name="rugged", seed=3, x_max=0.0, width=0.4)
    terrain = make_terrain(cfg)
    terrain.add_to_builder(newton.ModelBuilder(), newton.ModelBuilder.ShapeConfig())
    assert "mesh" not in vars(terrain)
    np.testing.assert_array_equal(terrain.mesh.vertices, grid_to_mesh(build_height_grid(cfg))[0])
    assert terrain.mesh is terrain.mesh


def test_add_to_builder_and_finalize() -> None:
    shape_cfg = newton.ModelBuilder.ShapeConfig()
    builder = newton.ModelBuilder()
    flat = make_terrain(TerrainConfig(name="flat"))
    assert flat.mesh is None
    plane = flat.add_to_builder(builder, shape_cfg)
    terrain = make_terrain(TerrainConfig(name="complex", x_max=3.0, width=0.5, collision="mesh"))
    shape = terrain.add_to_builder(builder, shape_cfg)
    assert builder.shape_type[plane] == newton.GeoType.PLANE
    assert builder.shape_type[shape] == newton.GeoType.MESH and builder.shape_body[shape] == -1
    model = builder.finalize(device=DEVICE)
    assert model.shape_count == 2
    # Newton's own seam analysis finds no open edge (T-junctions are covered on both sides)
    from hexnewton.physics.private_api import mesh_boundary_flags

    wmesh = wp.Mesh(points=wp.array(terrain.mesh.vertices, dtype=wp.vec3, device=DEVICE),
                    indices=wp.array(terrain.mesh.indices, dtype=wp.int32, device=DEVICE))
    assert not mesh_boundary_flags(wmesh).any()


def test_patch_reaches_beyond_the_goal():
    """A goal farther than the paper's 3.5 m (5 m walked) gets ground 1 m beyond it."""
    from hexnewton.config import terrain_for_goal

    base = TerrainConfig(name="complex")
    assert terrain_for_goal(base, 3.5) is base
    far = terrain_for_goal(base, 5.5)
    assert far.x_max == 6.5 and build_height_grid(far).x1 == pytest.approx(6.5)
    assert terrain_for_goal(base, 6.2).x_max == 7.5


# ----------------------------------------------------------------------------------------------------
# mesh_boxes: the same surface as boxes (constant-height strips) plus meshes (rugged blocks)
# ----------------------------------------------------------------------------------------------------


def _top_of_shapes(builder: newton.ModelBuilder, ids: range, grid: HeightGrid) -> tuple[np.ndarray, list[float]]:
    """Highest upward face of the static shapes ``ids`` over every cell centre of ``grid`` (-inf where none),
    and each shape's bottom z. Boxes from their transform and half extents; meshes from their horizontal
    upward-facing triangles (cell centres lie inside, or on a diagonal of, a top quad, never on a grid line)."""
    top = np.full((grid.nx, grid.ny), -np.inf)
    xc, yc = grid.cell_centers()
    bottoms = []
    for s in ids:
        t, kind = builder.shape_transform[s], builder.shape_type[s]
        assert builder.shape_body[s] == -1 and tuple(t[3:]) == (0.0, 0.0, 0.0, 1.0)
        if kind == newton.GeoType.PLANE:
            return np.full_like(top, float(t[2])), []
        if kind == newton.GeoType.BOX:
            hx, hy, hz = builder.shape_scale[s]
            i = (xc > t[0] - hx) & (xc < t[0] + hx)
            j = (yc > t[1] - hy) & (yc < t[1] + hy)
            top[np.ix_(i, j)] = np.maximum(top[np.ix_(i, j)], t[2] + hz)
            bottoms.append(t[2] - hz)
            continue
        assert kind == newton.GeoType.MESH
        v = np.asarray(builder.shape_source[s].vertices, np.float64) + np.asarray(t[:3])
        tri = v[np.asarray(builder.shape_source[s].indices).reshape(-1, 3)]
        bottoms.append(v[:, 2].min())
        e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        up = tri[(np.ptp(tri[:, :, 2], axis=1) == 0) & (e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0] > 0)]
        # candidate cells: every cell centre in each triangle's bounding box
        lo = np.ceil((up[:, :, :2].min(axis=1) - [grid.x0, grid.y0]) / grid.res - 0.5).astype(int)
        hi = np.floor((up[:, :, :2].max(axis=1) - [grid.x0, grid.y0]) / grid.res - 0.5).astype(int) + 1
        w = hi - lo
        count = w[:, 0] * w[:, 1]
        k = np.repeat(np.arange(len(up)), count)
        local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        ci, cj = lo[k, 0] + local // w[k, 1], lo[k, 1] + local % w[k, 1]
        p = np.stack([xc[ci], yc[cj]], axis=1)
        inside = np.ones(len(k), dtype=bool)
        for a, b in ((0, 1), (1, 2), (2, 0)):  # counter-clockwise seen from above: left of every edge
            pa, pb = up[k, a, :2], up[k, b, :2]
            cross = (pb[:, 0] - pa[:, 0]) * (p[:, 1] - pa[:, 1]) - (pb[:, 1] - pa[:, 1]) * (p[:, 0] - pa[:, 0])
            inside &= cross >= -1e-9
        np.maximum.at(top, (ci[inside], cj[inside]), up[k[inside], 0, 2])
    return top, bottoms


MESH_BOXES = [pytest.param(TerrainConfig(name=n, collision="mesh_boxes"), id=n) for n in TERRAINS] + [
    pytest.param(TerrainConfig(name=n, collision="mesh_boxes", levels=3), id=f"{n}-levels3")
    for n in ("stepped", "complex")]  # fmt: skip


@pytest.mark.parametrize("cfg", MESH_BOXES)
def test_mesh_boxes_reproduce_the_grid(cfg: TerrainConfig) -> None:
    terrain = make_terrain(cfg)
    builder = newton.ModelBuilder()
    first = terrain.add_to_builder(builder, newton.ModelBuilder.ShapeConfig())
    ids = range(first, builder.shape_count)
    top, bottoms = _top_of_shapes(builder, ids, terrain.grid)
    np.testing.assert_allclose(top, terrain.grid.heights, atol=1e-6)  # every cell covered, at its height
    # one common bottom: the parts tile the patch without gaps underneath
    if bottoms:
        np.testing.assert_allclose(bottoms, terrain.grid.heights.min() - 0.1, atol=1e-6)
    kinds = [builder.shape_type[s] for s in ids]
    meshes = kinds.count(newton.GeoType.MESH)
    if cfg.name == "flat":
        assert kinds == [newton.GeoType.PLANE]
    elif cfg.name == "stepped":
        assert meshes == 0 and len(kinds) <= (20 if not cfg.levels else 20 * cfg.levels)
    else:  # the rugged blocks as one mesh (lanes side by side merged), a few boxes
        assert meshes == 1 and len(kinds) <= 20 * max(1, cfg.levels)
    # the single mesh's surface by the same measure
    if cfg.name != "flat":
        ref = newton.ModelBuilder()
        s = make_terrain(replace(cfg, collision="mesh")).add_to_builder(ref, newton.ModelBuilder.ShapeConfig())
        np.testing.assert_allclose(_top_of_shapes(ref, range(s, s + 1), terrain.grid)[0], top, atol=1e-6)


def test_split_strips_bands_and_bad_input() -> None:
    h = np.zeros((6, 4), np.float32)
    h[2:4, :2], h[2:4, 2:] = 0.1, 0.2  # a step of different rise in each of two bands
    h[5, 1] = 0.05  # a rugged column at the end of band 0 (band 1's flat strip runs on to the end)
    parts = split_strips(HeightGrid(h, 0.0, 0.0, 0.01), band=2)
    assert parts == [Part(5, 6, 0, 2, False), Part(0, 2, 0, 4, True), Part(2, 4, 0, 2, True),
                     Part(2, 4, 2, 4, True), Part(4, 5, 0, 2, True), Part(4, 6, 2, 4, True)]  # fmt: skip
    with pytest.raises(ValueError, match="divide"):
        split_strips(HeightGrid(h, 0.0, 0.0, 0.01), band=3)
    with pytest.raises(ValueError, match="unknown terrain collision 'voxels'"):
        make_terrain(TerrainConfig(name="rugged", collision="voxels"))
