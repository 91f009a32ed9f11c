"""The paper's terrains (Huang et al. 2025, §3.1): flat, rugged, stepped and complex.

``make_terrain(cfg)`` builds a :class:`Terrain`: the exact piecewise-constant height grid
(:mod:`.heightmap`), its compact closed collision mesh (:mod:`.mesh`, built on first use; ``None`` for flat, which is
an infinite ground plane at z = 0; or boxes plus meshes of the same surface, :mod:`.parts`) and helpers to add
it to a ``newton.ModelBuilder`` and to query heights on the host. The grids and their box decomposition load without
Warp or Newton (the MuJoCo model, :mod:`hexnewton.deploy.mjcf`, is built from them). :mod:`.query` holds the float64 height
queries (the MDP's in-kernel ones are their Warp twins, ``hexnewton/mdp/terms/ground.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

from hexnewton.config import TerrainConfig
from hexnewton.terrain.boxes import BoxIndex, add_boxes, grid_boxes
from hexnewton.terrain.heightmap import HeightGrid, build_height_grid, complex_step_count, validate_config
from hexnewton.terrain.mesh import grid_to_mesh
from hexnewton.terrain.parts import Part, add_mesh_boxes, split_strips
from hexnewton.terrain.query import max_terrain_height_np, terrain_height_np

if TYPE_CHECKING:
    import newton

__all__ = [
    "BoxIndex",
    "HeightGrid",
    "Part",
    "Terrain",
    "add_boxes",
    "add_mesh_boxes",
    "build_height_grid",
    "complex_step_count",
    "generate",
    "grid_boxes",
    "grid_to_mesh",
    "make_terrain",
    "max_terrain_height_np",
    "split_strips",
    "terrain_height_np",
    "validate_config",
]


@dataclass
class Terrain:
    """One built terrain: config, exact height grid and collision mesh (None for flat)."""

    name: str
    cfg: TerrainConfig
    grid: HeightGrid
    boxes: BoxIndex | None = None  # with collision "boxes": the boxes added by add_to_builder

    @cached_property
    def mesh(self) -> newton.Mesh | None:
        """The whole grid as one closed triangle mesh (None for flat), built on first use: collision "mesh" adds it,
        "mesh_boxes" and "boxes" build their own shapes from the grid and never need it (a 1-5 s build on the
        curricula's grids)."""
        return None if self.name == "flat" else _mesh_from_grid(self.grid, self.cfg.watertight)

    def add_to_builder(self, builder: newton.ModelBuilder, cfg: newton.ModelBuilder.ShapeConfig) -> int:
        """Add the terrain as static shapes (body -1); returns the index of the first one.

        flat: an infinite ground plane at z = 0. Otherwise, by ``TerrainConfig.collision``: "mesh", one triangle
        mesh; "mesh_boxes", the same surface as boxes for the constant-height strips plus meshes for the rugged
        blocks (:func:`~hexnewton.terrain.parts.add_mesh_boxes`, consecutive shapes; with curriculum levels the
        strips are one lane wide); "boxes", every rectangle of equal-height cells one box, each rugged block one
        (:mod:`~hexnewton.terrain.boxes`, consecutive shapes, then one box far below: :attr:`boxes` holds
        them, their pairs with the robot shapes come from :mod:`~hexnewton.terrain.box_pairs`).
        """
        if self.name == "flat":
            return builder.add_ground_plane(cfg=cfg)
        if self.cfg.collision == "mesh_boxes":
            band = round(self.cfg.lane_width / self.grid.res) if self.cfg.levels else None
            return add_mesh_boxes(self.grid, builder, cfg, self.name, band, watertight=self.cfg.watertight)[0]
        if self.cfg.collision == "boxes":
            self.boxes = grid_boxes(self.grid)
            return add_boxes(self.boxes, self.grid, builder, cfg, self.name)
        return builder.add_shape_mesh(-1, mesh=self.mesh, cfg=cfg, label=f"terrain_{self.name}")

    def height_at(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Terrain height at (x, y) (float64, broadcast shape); off-patch points see the edge cell."""
        return terrain_height_np(self.grid, x, y)


def _mesh_from_grid(grid: HeightGrid, watertight: bool = False) -> newton.Mesh:
    import newton

    vertices, indices = grid_to_mesh(grid, watertight=watertight)
    # a static terrain needs no mass properties
    return newton.Mesh(vertices, indices, compute_inertia=False)


def make_terrain(cfg: TerrainConfig) -> Terrain:
    """Build terrain ``cfg.name``; raises ``ValueError`` for unknown names or invalid parameters."""
    return Terrain(name=cfg.name, cfg=cfg, grid=build_height_grid(cfg))


def generate(name: str, seed: int = 0, **overrides) -> newton.Mesh | None:
    """Collision mesh of terrain ``name`` (None for flat: an infinite plane at z = 0).

    ``overrides`` replace other :class:`TerrainConfig` fields.
    """
    cfg = replace(TerrainConfig(), name=name, seed=seed, **overrides)
    return make_terrain(cfg).mesh
