"""TerrainConfig.collision = "boxes": every rectangle of equal-height cells one static box (each rugged block one),
paired with the robot shapes under them by ``find_box_pairs`` before every detection. CPU only, a small patch."""

from __future__ import annotations

from dataclasses import replace

import newton
import numpy as np
import warp as wp

from hexnewton.config import HexConfig, SimConfig, TerrainConfig
from hexnewton.kernels.reference import quat_rotate_inv_np
from hexnewton.terrain import HeightGrid, grid_boxes, make_terrain, max_terrain_height_np
from hexnewton.terrain.box_pairs import find_box_pairs
from hexnewton.terrain.boxes import box_capacity, box_pairs_np
from hexnewton.physics.world import World

wp.init()
SMALL = TerrainConfig(name="rugged", seed=7, collision="boxes", x_min=-0.5, x_max=1.0, width=2.0, rugged_x_max=1.0,
                      rugged_half_width=0.8)  # fmt: skip


def test_boxes_match_the_grid():
    """Float64: every cell lies in exactly one box, whose top is the cell's height; each rugged block is one box; the
    shapes added to a builder have those extents, down to one common bottom."""
    terrain = make_terrain(SMALL)
    grid = terrain.grid
    index = grid_boxes(grid)
    h = grid.heights.astype(np.float64)
    covered = np.zeros(h.shape, int)
    for k in range(index.count):
        covered[index.i0[k]:index.i1[k], index.j0[k]:index.j1[k]] += 1
        np.testing.assert_array_equal(h[index.i0[k]:index.i1[k], index.j0[k]:index.j1[k]], float(index.top[k]))
    assert (covered == 1).all() and (index.cell_box >= 0).all()
    blocks = (np.abs(grid.cell_centers()[1]) < SMALL.rugged_half_width).sum() // 2 * grid.nx // 2
    assert blocks <= index.count <= blocks + 4 and index.min_side(grid.res) == SMALL.block_size
    builder = newton.ModelBuilder()
    first = terrain.add_to_builder(builder, newton.ModelBuilder.ShapeConfig())
    assert builder.shape_count == first + index.count + 1  # the boxes, then the far box
    xc, yc = grid.cell_centers()
    top = np.full(h.shape, -np.inf)
    for s in range(first, first + index.count):
        t, (hx, hy, hz) = np.asarray(builder.shape_transform[s], np.float64), builder.shape_scale[s]
        assert builder.shape_type[s] == newton.GeoType.BOX and builder.shape_body[s] == -1
        np.testing.assert_allclose(t[2] - hz, h.min() - 0.1, atol=1e-6)
        i, j = np.abs(xc - t[0]) < hx, np.abs(yc - t[1]) < hy
        top[np.ix_(i, j)] = np.maximum(top[np.ix_(i, j)], t[2] + hz)
    np.testing.assert_allclose(top, h, atol=1e-6)


def _random_case(rng: np.random.Generator, n: int):
    """A random block grid (2-cell blocks, a flat margin) and ``n`` shapes on random bodies, their centres (float64)
    kept away from cell edges and box tops so float32 and float64 agree."""
    heights = np.repeat(np.repeat(rng.uniform(0, 0.06, (12, 9)), 2, 0), 2, 1)
    heights[:, 14:] = 0.0
    grid = HeightGrid(heights.astype(np.float32), -0.1, -0.07, 0.01)
    tops = np.unique(grid.heights).astype(np.float64)
    body_q = np.zeros((n, 7))
    offset = rng.uniform(-0.02, 0.02, (n, 3))
    half = rng.uniform(0.005, 0.06, n)
    for s in range(n):
        while True:
            q = rng.normal(size=4)
            body_q[s] = [*rng.uniform([-0.15, -0.12, -0.05], [0.2, 0.2, 0.15]), *(q / np.linalg.norm(q))]
            c = body_q[s, :3] + quat_rotate_inv_np(body_q[s, 3:] * [-1, -1, -1, 1], offset[s])
            edges = np.concatenate([(c[:2] - half[s] - [grid.x0, grid.y0]) / grid.res,
                                    (c[:2] + half[s] - [grid.x0, grid.y0]) / grid.res])  # fmt: skip
            if np.abs(edges - np.round(edges)).min() > 1e-3 and np.abs(tops - (c[2] - half[s])).min() > 1e-5:
                break
    return grid, body_q, offset, half


def test_find_box_pairs_matches_the_reference():
    """Random grids, body poses and cubes: the kernel's pairs of each shape are the float64 brute-force reference's,
    within the slots box_capacity gives it, the rest the far box; nothing overflows."""
    rng = np.random.default_rng(3)
    for _ in range(5):
        n = 40
        grid, body_q, offset, half = _random_case(rng, n)
        index = grid_boxes(grid)
        slots = box_capacity(half, index.min_side(grid.res))
        first = np.concatenate([[0], np.cumsum(slots)[:-1]])
        xf = np.zeros((n, 7), np.float32)
        xf[:, :3], xf[:, 6] = offset, 1.0
        pairs = wp.zeros(int(slots.sum()), dtype=wp.vec2i)
        overflow = wp.zeros(1, dtype=wp.int32)
        arr = lambda a, t=wp.int32: wp.array(np.asarray(a), dtype=t)  # noqa: E731
        wp.launch(find_box_pairs, dim=n, inputs=[
            arr(body_q.astype(np.float32), wp.transform), arr(xf, wp.transform), arr(np.arange(n, dtype=np.int32)),
            arr(np.arange(n, dtype=np.int32)), arr(half.astype(np.float32), wp.float32), arr(first.astype(np.int32)),
            arr(slots.astype(np.int32)), arr(index.cell_box), arr(index.i0), arr(index.j0), arr(index.top, wp.float32),
            index.bottom, grid.x0, grid.y0, grid.res, 1000, 99999], outputs=[pairs, overflow])  # fmt: skip
        got = pairs.numpy()
        centers = body_q[:, :3] + quat_rotate_inv_np(body_q[:, 3:] * [-1, -1, -1, 1], offset)
        ref = box_pairs_np(index, grid, centers, half)
        assert overflow.numpy()[0] == 0
        for s in range(n):
            run = got[first[s]:first[s] + slots[s]]
            assert (run[:, 0] == s).all()
            hit = run[run[:, 1] != 99999, 1] - 1000
            assert len(ref[s]) <= slots[s] and sorted(hit.tolist()) == ref[s], s
        assert sum(map(len, ref)) > 50  # the cases reach the blocks


def test_robot_stands_on_boxes():
    """Two robots stand 1 s on the small block patch's boxes (upright, torso clear of the blocks under it, within
    1 cm of its height on the mesh_boxes surface); every terrain contact is with a box, no foot sinks into the block
    under it (bottom at most 3 mm below its top), nothing overflows."""
    z = {}
    for collision in ("mesh_boxes", "boxes"):
        world = World(HexConfig(sim=SimConfig(num_envs=2, device="cpu"), terrain=replace(SMALL, collision=collision)))
        world.step(100)
        q = world.numpy_q()
        z[collision] = q[:, 2]
        assert (1.0 - 2.0 * (q[:, 3] ** 2 + q[:, 4] ** 2) > 0.95).all()
        assert world.check_contacts(on_overflow="raise").ok
    ground = max_terrain_height_np(world.terrain.grid, q[:, 0], q[:, 1], 0.5 * world.cfg.robot.torso_size[0])
    assert (q[:, 2] - ground > 0.06).all()
    np.testing.assert_allclose(z["boxes"], z["mesh_boxes"], atol=0.01)
    m, c = world.model, world.contacts
    shapes = np.stack([c.rigid_contact_shape0.numpy(), c.rigid_contact_shape1.numpy()], 1)[
        :c.rigid_contact_count.numpy()[0]]
    static = m.shape_body.numpy()[shapes] < 0
    boxes = m.shape_type.numpy()[shapes] == newton.GeoType.BOX
    assert static.any(axis=1).all() and (boxes | ~static).all() and len(shapes) >= 8
    feet = np.flatnonzero([str(s).endswith("_foot") for s in m.shape_label])
    bq = world.state_0.body_q.numpy()[m.shape_body.numpy()[feet]].astype(np.float64)
    centre = bq[:, :3] + quat_rotate_inv_np(bq[:, 3:] * [-1, -1, -1, 1], m.shape_transform.numpy()[feet, :3])
    bottom = centre[:, 2] - m.shape_scale.numpy()[feet, 0]
    assert (bottom > world.terrain.height_at(centre[:, 0], centre[:, 1]) - 0.003).all()
