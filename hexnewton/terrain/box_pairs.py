"""The robot-shape / terrain-box pairs of ``TerrainConfig.collision = "boxes"``, found before every collision detection.

Newton's explicit broad phase tests a fixed-length list of shape pairs. With ~50,000 terrain boxes the list of every
robot shape against every box would hold ~10^6 pairs per robot; :func:`find_box_pairs` instead writes, per robot
shape, the boxes under the shape's bounding cube (its centre from the body pose, half width its bounding radius plus
both contact gaps), read off the cell each box covers (:class:`~hexnewton.terrain.boxes.BoxIndex`). Every
shape owns a fixed run of slots sized for the most boxes its cube can overlap
(:func:`~hexnewton.terrain.boxes.box_capacity`); unused slots pair the shape with one box far below the
terrain that nothing reaches. Newton's broad phase then tests these pairs' exact bounding boxes as usual.
Float64 reference: :func:`~hexnewton.terrain.boxes.box_pairs_np`.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from hexnewton.terrain.boxes import BoxIndex, box_capacity
from hexnewton.terrain.heightmap import HeightGrid


@wp.kernel
def find_box_pairs(
    body_q: wp.array[wp.transform],
    shape_transform: wp.array[wp.transform],
    shape_body: wp.array[wp.int32],
    shapes: wp.array[wp.int32],
    half_width: wp.array[wp.float32],
    first_slot: wp.array[wp.int32],
    slots: wp.array[wp.int32],
    cell_box: wp.array2d[wp.int32],
    box_i0: wp.array[wp.int32],
    box_j0: wp.array[wp.int32],
    box_top: wp.array[wp.float32],
    bottom: float,
    x0: float,
    y0: float,
    res: float,
    first_box: int,
    far_box: int,
    pairs: wp.array[wp.vec2i],
    overflow: wp.array[wp.int32],
):
    """One thread per robot shape ``shapes[n]``: its pairs with the boxes overlapping its bounding cube in
    ``pairs[first_slot[n] : first_slot[n] + slots[n]]`` (box ``k`` is shape ``first_box + k``), the rest with
    ``far_box``; ``overflow[0]`` counts boxes that found no slot."""
    n = wp.tid()
    s = shapes[n]
    b = shape_body[s]
    c = wp.transform_get_translation(shape_transform[s])
    if b >= 0:
        c = wp.transform_point(body_q[b], c)
    w = half_width[n]
    nx = cell_box.shape[0]
    ny = cell_box.shape[1]
    ilo = int(wp.floor((c[0] - w - x0) / res))
    ihi = int(wp.floor((c[0] + w - x0) / res))
    jlo = int(wp.floor((c[1] - w - y0) / res))
    jhi = int(wp.floor((c[1] + w - y0) / res))
    inside = c[2] + w >= bottom and ihi >= 0 and ilo < nx and jhi >= 0 and jlo < ny
    ilo, ihi = wp.max(ilo, 0), wp.min(ihi, nx - 1)
    jlo, jhi = wp.max(jlo, 0), wp.min(jhi, ny - 1)
    start = first_slot[n]
    cap = slots[n]
    count = int(0)
    if inside:
        for i in range(ilo, ihi + 1):
            for j in range(jlo, jhi + 1):
                k = cell_box[i, j]
                # each box once: at its first cell inside the window
                if i == wp.max(box_i0[k], ilo) and j == wp.max(box_j0[k], jlo) and box_top[k] >= c[2] - w:
                    if count < cap:
                        pairs[start + count] = wp.vec2i(s, first_box + k)
                    else:
                        wp.atomic_add(overflow, 0, 1)
                    count += 1
    for m in range(wp.min(count, cap), cap):
        pairs[start + m] = wp.vec2i(s, far_box)


class TerrainBoxPairs:
    """The pair list of ``shapes`` (robot shapes of ``model``) against the terrain boxes (shapes ``first_box`` ..,
    one per box of ``index``, then ``far_box``), refreshed by :meth:`update` from the bodies' poses."""

    def __init__(self, model, index: BoxIndex, grid: HeightGrid, shapes: np.ndarray, first_box: int, far_box: int,
                 terrain_gap: float):  # fmt: skip
        dev = model.device
        radius = model.shape_collision_radius.numpy()[shapes].astype(np.float64)
        gap = model.shape_gap.numpy()[shapes] + model.shape_margin.numpy()[shapes]
        half = radius + gap + terrain_gap
        slots = box_capacity(half, index.min_side(grid.res))
        first = np.concatenate([[0], np.cumsum(slots)[:-1]])
        self.count = int(slots.sum())
        self.shapes = wp.array(np.asarray(shapes, np.int32), dtype=wp.int32, device=dev)
        self.half_width = wp.array(half.astype(np.float32), dtype=wp.float32, device=dev)
        self.first_slot = wp.array(first.astype(np.int32), dtype=wp.int32, device=dev)
        self.slots = wp.array(slots.astype(np.int32), dtype=wp.int32, device=dev)
        self.cell_box = wp.array(index.cell_box, dtype=wp.int32, device=dev)
        self.box_i0 = wp.array(index.i0, dtype=wp.int32, device=dev)
        self.box_j0 = wp.array(index.j0, dtype=wp.int32, device=dev)
        self.box_top = wp.array(index.top, dtype=wp.float32, device=dev)
        self.grid = (float(index.bottom), float(grid.x0), float(grid.y0), float(grid.res))
        self.first_box, self.far_box = int(first_box), int(far_box)
        self.pairs = wp.zeros(self.count, dtype=wp.vec2i, device=dev)
        self.overflow = wp.zeros(1, dtype=wp.int32, device=dev)
        self.model = model

    def update(self, body_q: wp.array) -> None:
        """Rewrite :attr:`pairs` for the poses ``body_q`` (inside a captured graph too)."""
        m = self.model
        wp.launch(find_box_pairs, dim=len(self.shapes), device=m.device,
                  inputs=[body_q, m.shape_transform, m.shape_body, self.shapes, self.half_width, self.first_slot,
                          self.slots, self.cell_box, self.box_i0, self.box_j0, self.box_top, *self.grid,
                          self.first_box, self.far_box],
                  outputs=[self.pairs, self.overflow])  # fmt: skip
