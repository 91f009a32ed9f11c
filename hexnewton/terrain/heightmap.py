"""Piecewise-constant height grids for the paper's four terrains (Huang et al. 2025, §3.1).

Every terrain is described by one :class:`HeightGrid`: a regular grid of cells of side
``TerrainConfig.query_resolution`` with one constant height per cell. All terrain features (blocks,
step edges, the rugged/stepped split of the complex terrain) lie on cell edges, so the grid is an
exact description of the surface; the collision mesh (:mod:`hexnewton.terrain.mesh`) and the in-kernel
height query (:mod:`hexnewton.terrain.query`) are both built from it.

World frame: z up, the robot starts at the origin facing +x, features lie ahead along +x.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hexnewton.config import TERRAIN_COLLISIONS, TERRAINS, TerrainConfig, without_lanes

# Lengths must be integer multiples of the grid resolution to within this many metres.
ALIGN_TOL = 1e-9


@dataclass
class HeightGrid:
    """Cell-centred height grid.

    ``heights[i, j]`` is the terrain height over the cell
    ``x in [x0 + i * res, x0 + (i + 1) * res)``, ``y in [y0 + j * res, y0 + (j + 1) * res)``.
    """

    heights: np.ndarray  # float32, shape (nx, ny)
    x0: float
    y0: float
    res: float

    @property
    def nx(self) -> int:
        return int(self.heights.shape[0])

    @property
    def ny(self) -> int:
        return int(self.heights.shape[1])

    @property
    def x1(self) -> float:
        """Upper x edge of the grid."""
        return self.x0 + self.nx * self.res

    @property
    def y1(self) -> float:
        """Upper y edge of the grid."""
        return self.y0 + self.ny * self.res

    def cell_centers(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates along x (shape (nx,)) and y (shape (ny,)), float64."""
        xc = self.x0 + (np.arange(self.nx) + 0.5) * self.res
        yc = self.y0 + (np.arange(self.ny) + 0.5) * self.res
        return xc, yc


# ----------------------------------------------------------------------------------------------------
# validation
# ----------------------------------------------------------------------------------------------------


def _unknown_terrain(name: str) -> ValueError:
    return ValueError(f"unknown terrain '{name}': choose one of {', '.join(TERRAINS)}")


def _require(ok: bool, message: str) -> None:
    if not ok:
        raise ValueError(message)


def _multiple(length: float, unit: float, what: str, unit_name: str) -> int:
    """Return ``length / unit`` as an int, or raise if ``length`` is not a multiple of ``unit``."""
    k = round(length / unit)
    _require(
        abs(length - k * unit) <= ALIGN_TOL,
        f"{what} ({length!r} m) must be a multiple of {unit_name} ({unit!r} m)",
    )
    return int(k)


def validate_config(cfg: TerrainConfig) -> None:
    """Raise ``ValueError`` (one message per problem) if ``cfg`` cannot describe a grid terrain."""
    if cfg.name not in TERRAINS:
        raise _unknown_terrain(cfg.name)
    _require(cfg.collision in TERRAIN_COLLISIONS,
             f"unknown terrain collision '{cfg.collision}': choose one of {', '.join(TERRAIN_COLLISIONS)}")
    res = cfg.query_resolution
    for field_name in ("query_resolution", "block_size", "step_depth", "width", "rugged_half_width"):
        value = getattr(cfg, field_name)
        _require(math.isfinite(value) and value > 0, f"{field_name} must be positive, got {value!r}")
    for field_name in ("block_height_max", "step_rise", "complex_stepped_length"):
        value = getattr(cfg, field_name)
        _require(math.isfinite(value) and value >= 0, f"{field_name} must be >= 0, got {value!r}")
    _require(int(cfg.step_count) == cfg.step_count and cfg.step_count >= 1,
             f"step_count must be a positive integer, got {cfg.step_count!r}")
    _require(cfg.x_max > cfg.x_min, f"x_max ({cfg.x_max!r}) must be greater than x_min ({cfg.x_min!r})")
    _multiple(cfg.block_size, res, "block_size", "query_resolution")
    _multiple(cfg.step_depth, res, "step_depth", "query_resolution")
    _multiple(cfg.x_max - cfg.x_min, res, "x_max - x_min", "query_resolution")
    _multiple(cfg.width, res, "width", "query_resolution")
    _multiple(cfg.width / 2, res, "width / 2", "query_resolution")
    _require(int(cfg.levels) == cfg.levels and cfg.levels >= 0, f"levels must be an integer >= 0, got {cfg.levels!r}")
    _require(cfg.levels or cfg.past_share == 0.0, f"past_share {cfg.past_share} needs a curriculum (levels > 0)")
    _require(cfg.levels or cfg.start_progress == 0.0,
             f"start_progress {cfg.start_progress} needs a curriculum (levels > 0)")
    _require(cfg.levels or not cfg.lane_courses,
             f"lane_courses ({' '.join(cfg.lane_courses)}) needs a curriculum (levels > 0)")
    if cfg.levels:
        _require(int(cfg.start_levels) == cfg.start_levels and 1 <= cfg.start_levels <= cfg.levels,
                 f"start_levels must be an integer in [1, levels = {cfg.levels}], got {cfg.start_levels!r}")
        _require(math.isfinite(cfg.lane_width) and cfg.lane_width > 0,
                 f"lane_width must be positive, got {cfg.lane_width!r}")
        _require(int(cfg.climb) == cfg.climb and cfg.climb >= 1, f"climb must be an integer >= 1, got {cfg.climb!r}")
        _require(math.isfinite(cfg.start_progress) and 0.0 <= cfg.start_progress < cfg.x_max,
                 f"start_progress must be in [0, x_max = {cfg.x_max:g}) m, got {cfg.start_progress!r}")
        _check_levels_past(cfg)
        _require(cfg.name != "flat" or not cfg.lane_courses,
                 "lane_courses beside a flat terrain (a ground plane): name another course, flat among lane_courses")
        for name in cfg.lane_courses:
            _require(name in TERRAINS, f"lane_courses: unknown terrain '{name}': choose among {', '.join(TERRAINS)}")
        _require(len(set(course_names(cfg))) == len(course_names(cfg)),
                 f"lane_courses ({' '.join(cfg.lane_courses)}) must name each course once, '{cfg.name}' not again")
        for group in range(len(course_names(cfg))):
            for level in range(cfg.levels - cfg.levels_past - 1, cfg.levels):  # the course's lane and those past it
                validate_config(lane_config(cfg, level, group))
        return
    TERRAIN_KINDS[cfg.name].check(cfg)


def _check_levels_past(cfg: TerrainConfig) -> None:
    """``levels_past`` leaves the course a lane; the ``hardest_*`` values are finite and not negative."""
    _require(int(cfg.levels_past) == cfg.levels_past and 0 <= cfg.levels_past < cfg.levels,
             f"levels_past must be an integer in [0, levels - 1 = {cfg.levels - 1}], got {cfg.levels_past!r}")
    _require(math.isfinite(cfg.past_share) and 0.0 <= cfg.past_share <= 1.0,
             f"past_share must be in [0, 1], got {cfg.past_share!r}")
    _require(cfg.past_share == 0.0 or cfg.levels_past > 0,
             f"past_share {cfg.past_share} draws lanes past the course: it needs levels_past > 0")
    for field_name in ("hardest_step_rise", "hardest_step_depth", "hardest_block_height_max"):
        value = getattr(cfg, field_name)
        _require(value is None or (math.isfinite(value) and value >= 0),
                 f"{field_name} must be >= 0 or None, got {value!r}")


def _check_flat(cfg: TerrainConfig) -> None:
    """Nothing beyond the common checks."""


def _check_rugged_region(cfg: TerrainConfig, x_end: float, x_end_name: str) -> None:
    """The rugged region [x_min, x_end) x |y| <= rugged_half_width must be block aligned."""
    _require(x_end > cfg.x_min, f"{x_end_name} ({x_end!r}) must be greater than x_min ({cfg.x_min!r})")
    if x_end < cfg.x_max:  # beyond x_max the region is clipped to the patch
        _multiple(x_end - cfg.x_min, cfg.block_size, f"{x_end_name} - x_min", "block_size")
    if cfg.rugged_half_width < cfg.width / 2:
        _multiple(cfg.width / 2 - cfg.rugged_half_width, cfg.block_size, "width / 2 - rugged_half_width",
                  "block_size")


def _check_rugged(cfg: TerrainConfig) -> None:
    _check_rugged_region(cfg, cfg.rugged_x_max, "rugged_x_max")


def _check_stairs(cfg: TerrainConfig, start: float, count: int, start_name: str) -> None:
    """A staircase of ``count`` steps from ``start`` must start on the grid and fit in the patch."""
    _require(cfg.x_min <= start < cfg.x_max,
             f"{start_name} ({start!r}) must lie in [x_min, x_max) = [{cfg.x_min!r}, {cfg.x_max!r})")
    _multiple(start - cfg.x_min, cfg.query_resolution, f"{start_name} - x_min", "query_resolution")
    end = start + count * cfg.step_depth
    _require(end <= cfg.x_max + ALIGN_TOL,
             f"the {count} steps from {start_name} = {start!r} end at x = {end!r}, beyond x_max ({cfg.x_max!r})")


def _check_stepped(cfg: TerrainConfig) -> None:
    _check_stairs(cfg, cfg.stepped_start_x, int(cfg.step_count), "stepped_start_x")


def _check_complex(cfg: TerrainConfig) -> None:
    _check_rugged_region(cfg, cfg.complex_rugged_length, "complex_rugged_length")
    n = complex_step_count(cfg)
    _require(n >= 1, f"complex_stepped_length ({cfg.complex_stepped_length!r}) must hold at least one step "
                     f"of step_depth ({cfg.step_depth!r})")
    _check_stairs(cfg, cfg.complex_rugged_length, n, "complex_rugged_length")
    if cfg.complex_landing_blocks:
        _require(cfg.complex_landing_blocks > 0,
                 f"complex_landing_blocks ({cfg.complex_landing_blocks!r}) must be >= 0")
        if _landing_blocks_start(cfg, n) + cfg.complex_landing_blocks < cfg.x_max:
            _multiple(cfg.complex_landing_blocks, cfg.block_size, "complex_landing_blocks", "block_size")


def _landing_blocks_start(cfg: TerrainConfig, steps: int) -> float:
    """Where the complex terrain's landing blocks begin: the first edge of the block lattice on or after the last step's
    end (a lane past the course may have treads off the lattice)."""
    landing = cfg.complex_rugged_length + steps * cfg.step_depth
    return cfg.x_min + math.ceil((landing - cfg.x_min) / cfg.block_size - ALIGN_TOL) * cfg.block_size


def complex_step_count(cfg: TerrainConfig) -> int:
    """Steps on the complex terrain: round(complex_stepped_length / step_depth) (§3.1: 1.5 m of steps)."""
    return int(round(cfg.complex_stepped_length / cfg.step_depth))


# ----------------------------------------------------------------------------------------------------
# terrain builders
# ----------------------------------------------------------------------------------------------------


def _empty_grid(cfg: TerrainConfig) -> HeightGrid:
    res = cfg.query_resolution
    nx = _multiple(cfg.x_max - cfg.x_min, res, "x_max - x_min", "query_resolution")
    ny = _multiple(cfg.width, res, "width", "query_resolution")
    return HeightGrid(np.zeros((nx, ny), dtype=np.float32), float(cfg.x_min), -cfg.width / 2, float(res))


def _block_heights(cfg: TerrainConfig, grid: HeightGrid) -> np.ndarray:
    """Per-cell rugged heights over the whole patch (float64, shape (nx, ny)).

    One uniform draw in [0, block_height_max] per block of the block lattice anchored at
    (x_min, -width/2) (§3.1: 2 cm x 2 cm blocks, 0-6 cm). The lattice always covers the whole patch,
    so a block has the same height on every terrain built with the same seed and patch size.
    """
    bc = _multiple(cfg.block_size, grid.res, "block_size", "query_resolution")
    nbx, nby = -(-grid.nx // bc), -(-grid.ny // bc)
    blocks = np.random.default_rng(cfg.seed).uniform(0.0, cfg.block_height_max, size=(nbx, nby))
    return np.repeat(np.repeat(blocks, bc, axis=0), bc, axis=1)[: grid.nx, : grid.ny]


def _rugged_region(cfg: TerrainConfig, grid: HeightGrid, heights: np.ndarray, x_end: float,
                   x_start: float | None = None) -> None:
    """Add block heights to cells of x in [x_start (default x_min), x_end), |y| <= rugged_half_width."""
    xc, yc = grid.cell_centers()
    mask = ((xc < x_end) & (xc >= (cfg.x_min if x_start is None else x_start)))[:, None] \
        & (np.abs(yc) < cfg.rugged_half_width)[None, :]
    heights[mask] += _block_heights(cfg, grid)[mask]


def _stairs(grid: HeightGrid, heights: np.ndarray, start: float, count: int, rise: float, depth: float) -> None:
    """Step k = 1..count over x in [start + (k-1) depth, start + k depth) at height k * rise, then a
    landing at count * rise up to the end of the grid; steps span the full width."""
    s = round((start - grid.x0) / grid.res)
    d = round(depth / grid.res)
    i = np.arange(grid.nx)
    k = np.clip((i - s) // d + 1, 0, count)
    k[i < s] = 0
    heights[i >= s, :] = (k[i >= s] * rise)[:, None]


def _build_flat(cfg: TerrainConfig, grid: HeightGrid, heights: np.ndarray) -> None:
    """flat: z = 0 everywhere."""


def _build_rugged(cfg: TerrainConfig, grid: HeightGrid, heights: np.ndarray) -> None:
    """rugged (§3.1): random 2 cm blocks up to 6 cm high ahead of and around the start."""
    _rugged_region(cfg, grid, heights, cfg.rugged_x_max)


def _build_stepped(cfg: TerrainConfig, grid: HeightGrid, heights: np.ndarray) -> None:
    """stepped (§3.1): 15 steps, 6 cm rise, 25 cm deep, from stepped_start_x."""
    _stairs(grid, heights, cfg.stepped_start_x, int(cfg.step_count), cfg.step_rise, cfg.step_depth)


def _build_complex(cfg: TerrainConfig, grid: HeightGrid, heights: np.ndarray) -> None:
    """complex (§3.1): 1.5 m rugged (up to x = complex_rugged_length) followed by 1.5 m of steps, then the landing
    (``complex_landing_blocks`` of it covered in blocks)."""
    _rugged_region(cfg, grid, heights, cfg.complex_rugged_length)
    n = complex_step_count(cfg)
    _stairs(grid, heights, cfg.complex_rugged_length, n, cfg.step_rise, cfg.step_depth)
    if cfg.complex_landing_blocks > 0:
        start = _landing_blocks_start(cfg, n)
        _rugged_region(cfg, grid, heights, start + cfg.complex_landing_blocks, start)


@dataclass(frozen=True)
class TerrainKind:
    """One terrain of ``config.TERRAINS``: ``build`` writes its heights into a zero grid, ``check`` raises
    ``ValueError`` for parameters it cannot build (after the checks common to every terrain)."""

    build: Callable[[TerrainConfig, HeightGrid, np.ndarray], None]
    check: Callable[[TerrainConfig], None]


#: the terrains, one row per name of ``config.TERRAINS`` (adding a terrain: docs/internals.md)
TERRAIN_KINDS = {
    "flat": TerrainKind(_build_flat, _check_flat),
    "rugged": TerrainKind(_build_rugged, _check_rugged),
    "stepped": TerrainKind(_build_stepped, _check_stepped),
    "complex": TerrainKind(_build_complex, _check_complex),
}
assert tuple(TERRAIN_KINDS) == TERRAINS, "one row per name of config.TERRAINS, in its order"


def course_names(cfg: TerrainConfig) -> tuple[str, ...]:
    """The courses of the curriculum's lane groups, in their order along y: ``cfg.name``, then ``lane_courses``."""
    return (cfg.name, *cfg.lane_courses)


def lane_config(cfg: TerrainConfig, level: int, group: int = 0) -> TerrainConfig:
    """The terrain of curriculum lane ``level`` of lane group ``group`` (its course ``course_names(cfg)[group]``):
    ``cfg`` one lane wide, its own block seed, and up to the course's lane (``levels - levels_past - 1``) the heights
    scaled by (level + 1) / (levels - levels_past); past it the step rise, tread and block height a share
    (level + 1 - course lanes) / levels_past of the way from ``cfg``'s to the ``hardest_*`` values (None: ``cfg``'s),
    the tread rounded to the query grid."""
    lanes = dict(width=cfg.lane_width, rugged_half_width=min(cfg.rugged_half_width, cfg.lane_width / 2),
                 seed=cfg.seed * 1000 + level + 100_000 * group, name=course_names(cfg)[group])
    course = cfg.levels - cfg.levels_past
    if level < course:
        scale = (level + 1) / course
        return without_lanes(cfg, block_height_max=cfg.block_height_max * scale, step_rise=cfg.step_rise * scale,
                             **lanes)  # fmt: skip
    t = (level + 1 - course) / cfg.levels_past

    def toward(value: float, hardest: float | None) -> float:
        return value if hardest is None else value + t * (hardest - value)

    depth = round(toward(cfg.step_depth, cfg.hardest_step_depth) / cfg.query_resolution) * cfg.query_resolution
    return without_lanes(cfg, block_height_max=toward(cfg.block_height_max, cfg.hardest_block_height_max),
                         step_rise=toward(cfg.step_rise, cfg.hardest_step_rise), step_depth=depth, **lanes)  # fmt: skip


def group_offset_y(cfg: TerrainConfig, group: int | np.ndarray) -> float | np.ndarray:
    """y of lane group ``group``'s centre (the groups of ``course_names`` side by side, centred on y = 0)."""
    return (np.asarray(group) - 0.5 * (len(course_names(cfg)) - 1)) * cfg.levels * cfg.lane_width


def env_groups(cfg: TerrainConfig, num_envs: int) -> np.ndarray:
    """The lane group each of ``num_envs`` envs plays (int32): env i the group i mod len(course_names(cfg))."""
    return (np.arange(num_envs) % len(course_names(cfg))).astype(np.int32)


def lane_center_y(cfg: TerrainConfig, level: int | np.ndarray, group: int | np.ndarray = 0) -> float | np.ndarray:
    """y of curriculum lane ``level``'s centre line in lane group ``group`` (lanes side by side, centred on their
    group's centre)."""
    return (np.asarray(level) + 0.5 - cfg.levels / 2) * cfg.lane_width + group_offset_y(cfg, group)


def build_height_grid(cfg: TerrainConfig) -> HeightGrid:
    """Height grid of terrain ``cfg.name`` over x in [x_min, x_max], |y| <= width / 2 (with curriculum levels:
    the lanes side by side, one group of them per course of ``course_names``, |y| <= groups * levels * lane_width /
    2).

    Raises ``ValueError`` for an unknown terrain name or invalid parameters.
    """
    validate_config(cfg)
    if cfg.levels:
        groups = range(len(course_names(cfg)))
        lanes = [build_height_grid(lane_config(cfg, k, g)) for g in groups for k in range(cfg.levels)]
        width = len(groups) * cfg.levels * cfg.lane_width
        return HeightGrid(np.concatenate([g.heights for g in lanes], axis=1), float(cfg.x_min), -width / 2,
                          float(cfg.query_resolution))  # fmt: skip
    grid = _empty_grid(cfg)
    heights = np.zeros(grid.heights.shape, dtype=np.float64)
    TERRAIN_KINDS[cfg.name].build(cfg, grid, heights)
    grid.heights = heights.astype(np.float32)
    return grid
