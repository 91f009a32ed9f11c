"""The paper's terrains (Huang et al. 2025, §3.1): flat, rugged, stepped and complex.

``make_terrain(cfg)`` builds a :class:`Terrain`: the exact piecewise-constant height grid
(:mod:`.heightmap`), its compact closed collision mesh (:mod:`.mesh`, ``None`` for flat, which is an
infinite ground plane at z = 0; or boxes plus meshes of the same surface, :mod:`.parts`) and helpers to add
it to a ``newton.ModelBuilder`` and to query heights on the host. The grids and their box decomposition load without
Warp or Newton (the MuJoCo model, :mod:`hexnewton.mjcf`, is built from them). :mod:`.query` provides the in-kernel
height lookup (``HeightField``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from hexnewton.config import TerrainConfig
from hexnewton.terrain.heightmap import HeightGrid, build_height_grid, complex_step_count, validate_config
from hexnewton.terrain.mesh import grid_to_mesh
from hexnewton.terrain.parts import Part, add_mesh_boxes, split_strips

if TYPE_CHECKING:
    import newton
    import warp as wp

    from hexnewton.terrain.query import HeightField

#: names of :mod:`.query` (Warp structs and kernels with their NumPy references), imported on first use so that the
#: height grids and their box decomposition load without Warp or Newton
_QUERY = ("HeightField", "height_field_from_grid", "max_terrain_height", "max_terrain_height_np", "sample_heights",
          "sample_heights_kernel", "terrain_height", "terrain_height_np")


def __getattr__(name: str):
    if name in _QUERY:
        from hexnewton.terrain import query

        return getattr(query, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "HeightField",
    "HeightGrid",
    "Part",
    "Terrain",
    "add_mesh_boxes",
    "build_height_grid",
    "complex_step_count",
    "generate",
    "grid_to_mesh",
    "height_field_from_grid",
    "make_terrain",
    "max_terrain_height",
    "max_terrain_height_np",
    "sample_heights",
    "sample_heights_kernel",
    "split_strips",
    "terrain_height",
    "terrain_height_np",
    "validate_config",
]


@dataclass
class Terrain:
    """One built terrain: config, exact height grid and collision mesh (None for flat)."""

    name: str
    cfg: TerrainConfig
    grid: HeightGrid
    mesh: newton.Mesh | None

    def add_to_builder(self, builder: newton.ModelBuilder, cfg: newton.ModelBuilder.ShapeConfig) -> int:
        """Add the terrain as static shapes (body -1); returns the index of the first one.

        flat: an infinite ground plane at z = 0. Otherwise, by ``TerrainConfig.collision``: "mesh", one triangle
        mesh; "mesh_boxes", the same surface as boxes for the constant-height strips plus meshes for the rugged
        blocks (:func:`~hexnewton.terrain.parts.add_mesh_boxes`, consecutive shapes; with curriculum levels the
        strips are one lane wide).
        """
        if self.mesh is None:
            return builder.add_ground_plane(cfg=cfg)
        if self.cfg.collision == "mesh_boxes":
            band = round(self.cfg.lane_width / self.grid.res) if self.cfg.levels else None
            return add_mesh_boxes(self.grid, builder, cfg, self.name, band)[0]
        return builder.add_shape_mesh(-1, mesh=self.mesh, cfg=cfg, label=f"terrain_{self.name}")

    def height_at(self, x: np.ndarray | float, y: np.ndarray | float) -> np.ndarray:
        """Terrain height at (x, y) (float64, broadcast shape); off-patch points see the edge cell."""
        from hexnewton.terrain.query import terrain_height_np

        return terrain_height_np(self.grid, x, y)

    def height_field(self, device: wp.DeviceLike = None) -> HeightField:
        """The grid as a device :class:`HeightField` for in-kernel queries."""
        from hexnewton.terrain.query import height_field_from_grid

        return height_field_from_grid(self.grid, device)


def _mesh_from_grid(grid: HeightGrid) -> newton.Mesh:
    import newton

    vertices, indices = grid_to_mesh(grid)
    # a static terrain needs no mass properties
    return newton.Mesh(vertices, indices, compute_inertia=False)


def make_terrain(cfg: TerrainConfig) -> Terrain:
    """Build terrain ``cfg.name``; raises ``ValueError`` for unknown names or invalid parameters."""
    grid = build_height_grid(cfg)
    mesh = None if cfg.name == "flat" else _mesh_from_grid(grid)
    return Terrain(name=cfg.name, cfg=cfg, grid=grid, mesh=mesh)


def generate(name: str, seed: int = 0, **overrides) -> newton.Mesh | None:
    """Collision mesh of terrain ``name`` (None for flat: an infinite plane at z = 0).

    ``overrides`` replace other :class:`TerrainConfig` fields.
    """
    cfg = replace(TerrainConfig(), name=name, seed=seed, **overrides)
    return make_terrain(cfg).mesh
