"""Terrain curriculum: lanes of increasing difficulty, the level-update kernel against its NumPy reference,
and an env whose robots move between lanes (CPU)."""

from dataclasses import replace

import numpy as np
import pytest
import torch
import warp as wp

from hexnewton.config import HexConfig, SimConfig, TaskConfig, TerrainConfig
from hexnewton.mdp.env import make_env
from hexnewton.mdp.events import (curriculum_kernel, curriculum_reference, lane_count_kernel, lane_count_reference,
                                  placement_kernel, start_levels, strict_from)
from hexnewton.mdp.status import NONFINITE, SUCCESS
from hexnewton.mdp.terms import height_field_from_grid
from hexnewton.terrain import build_height_grid, max_terrain_height_np, terrain_height_np
from hexnewton.terrain.heightmap import lane_center_y

DEV = "cpu"


def test_lanes_scale_the_terrain():
    cfg = TerrainConfig(name="stepped", levels=4)
    grid = build_height_grid(cfg)
    assert grid.heights.shape[1] * grid.res == pytest.approx(4 * cfg.lane_width)
    x = np.arange(0.0, 4.9, 0.01)
    for k in range(4):
        h = terrain_height_np(grid, x, np.full_like(x, lane_center_y(cfg, k)))
        rises = np.diff(h)[np.diff(h) > 1e-6]
        np.testing.assert_allclose(rises, cfg.step_rise * (k + 1) / 4, atol=1e-6)
    # the last lane is the paper's staircase itself
    paper = build_height_grid(TerrainConfig(name="stepped"))
    np.testing.assert_array_equal(terrain_height_np(grid, x, np.full_like(x, lane_center_y(cfg, 3))),
                                  terrain_height_np(paper, x, np.zeros_like(x)))  # fmt: skip
    rugged = TerrainConfig(name="rugged", levels=3, lane_width=1.0)
    g = build_height_grid(rugged)
    for k in range(3):
        y = lane_center_y(rugged, k) + np.linspace(-0.45, 0.45, 40)
        h = terrain_height_np(g, np.full_like(y, 0.5)[:, None] + np.linspace(0, 2, 50)[None, :], y[:, None])
        assert 0.5 * rugged.block_height_max * (k + 1) / 3 < h.max() <= rugged.block_height_max * (k + 1) / 3 + 1e-6


def _lanes_past_reference(cfg: TerrainConfig) -> list[tuple[float, float, float]]:
    """Float64 (rise, tread, block height) of every lane: up to the course's lane the course scaled by
    (k + 1) / (L - P), past it P equal steps toward the hardest lane, treads on the 1 cm grid."""
    course, out = cfg.levels - cfg.levels_past, []
    for k in range(cfg.levels):
        if k < course:
            s = (k + 1) / course
            out.append((cfg.step_rise * s, cfg.step_depth, cfg.block_height_max * s))
            continue
        t = (k + 1 - course) / cfg.levels_past
        tread = np.round((cfg.step_depth + t * (cfg.hardest_step_depth - cfg.step_depth)) * 100.0) / 100.0
        out.append((cfg.step_rise + t * (cfg.hardest_step_rise - cfg.step_rise), tread,
                    cfg.block_height_max + t * (cfg.hardest_block_height_max - cfg.block_height_max)))
    return out


def test_lanes_past_the_course():
    """``levels_past``: the hardest lanes go beyond the complex course (``complex-margin``'s lanes) and the generated
    grid holds, lane by lane, the float64 reference's stairs (every step's height along the centre line) and blocks
    (the lane's own seeded draws of 0 to its block height)."""
    from hexnewton.tasks import MARGIN_LANES

    cfg = TerrainConfig(name="complex", levels=10, start_levels=3, **MARGIN_LANES)
    ref = _lanes_past_reference(cfg)
    assert [(round(r, 4), round(d, 2), round(b, 4)) for r, d, b in ref[6:]] == [
        (0.06, 0.25, 0.06), (0.07, 0.23, 0.07), (0.08, 0.2, 0.08), (0.09, 0.18, 0.09)]
    grid = build_height_grid(cfg)
    x = np.arange(cfg.x_min, cfg.x_max, cfg.query_resolution) + 0.5 * cfg.query_resolution
    for k, (rise, tread, block) in enumerate(ref):
        y = lane_center_y(cfg, k)
        count = round(cfg.complex_stepped_length / tread)
        step = np.clip(np.floor((x - cfg.complex_rugged_length) / tread + 1e-9) + 1, 0, count)
        stairs = x >= cfg.complex_rugged_length
        np.testing.assert_allclose(terrain_height_np(grid, x[stairs], np.full(stairs.sum(), y)), rise * step[stairs],
                                   atol=1e-6)  # fmt: skip
        # the blocks: one draw in [0, block] per 2 cm block of the lane's lattice (seed 1000 x terrain seed + lane)
        nbx, nby = round((cfg.x_max - cfg.x_min) / cfg.block_size), round(cfg.lane_width / cfg.block_size)
        draws = np.random.default_rng(cfg.seed * 1000 + k).uniform(0.0, block, size=(nbx, nby))
        bx = cfg.x_min + (np.arange(nbx) + 0.5) * cfg.block_size
        by = y - cfg.lane_width / 2 + (np.arange(nby) + 0.5) * cfg.block_size
        rugged = bx < cfg.complex_rugged_length
        got = terrain_height_np(grid, bx[rugged][:, None], by[None, :])
        np.testing.assert_allclose(got, draws[rugged], atol=1e-6)
        assert got.max() > 0.99 * block
    # the hardest_* values change nothing without lanes past the course
    plain = build_height_grid(replace(cfg, levels_past=0))
    last = TerrainConfig(name="complex", levels=10, start_levels=3)
    np.testing.assert_array_equal(plain.heights, build_height_grid(last).heights)


@pytest.mark.parametrize("bad, message", [
    ({"levels": 3, "levels_past": 3}, "levels_past must be an integer in [0, levels - 1 = 2]"),
    ({"levels": 3, "levels_past": 1, "hardest_step_rise": -0.01}, "hardest_step_rise must be >= 0 or None"),
    ({"levels": 3, "levels_past": 1, "hardest_step_depth": 0.0}, "step_depth must be positive"),
    ({"levels": -1}, "levels must be an integer >= 0"),
    ({"levels": 3, "start_levels": 4}, "start_levels must be an integer in [1, levels = 3]"),
    ({"levels": 3, "lane_width": 0.0}, "lane_width must be positive"),
    ({"levels": 3, "climb": 0}, "climb must be an integer >= 1"),
    ({"levels": 3, "lane_width": 1.005}, "width (1.005 m) must be a multiple of query_resolution"),
])  # fmt: skip
def test_bad_curriculum_config(bad, message):
    with pytest.raises(ValueError) as err:
        build_height_grid(TerrainConfig(name="rugged", **bad))
    assert message in str(err.value)


@pytest.mark.parametrize(("strict", "climb", "share", "own_way"),
                         [(None, 1, 0.0, False), (3, 1, 0.0, False), (None, 2, 0.0, False), (None, 1, 0.5, False),
                          (None, 1, 0.0, True)])  # fmt: skip
def test_curriculum_kernel_matches_reference(strict, climb, share, own_way):
    """``strict`` (``strict_from``, the first lane past the course with ``past_down`` "miss"): None, none; ``climb``:
    lanes up per goal; ``share``: ``past_share`` over the last two lanes (the episodes that ended on a drawn lane keep
    their level; the next ones are drawn with that probability)."""
    rng = np.random.default_rng(0)
    cfg = TerrainConfig(name="complex", levels=5, lane_width=1.0)
    grid = build_height_grid(cfg)
    hf = height_field_from_grid(grid, DEV)
    n, levels, goal, footprint, clearance = 512, cfg.levels, 3.5, 0.28, 0.15
    status = rng.integers(0, 6, n).astype(np.int32)
    level = rng.integers(0, levels, n).astype(np.int32)
    walked = rng.uniform(-0.5, 3.5, n)
    start = np.stack([rng.uniform(-0.2, 0.2, n), rng.uniform(-2, 2, n)], axis=1).astype(np.float32)
    # the distance walked counts along the goal's course (+x on the straight tasks; here in every direction), the
    # offset across it not
    other = np.random.default_rng(1)  # (its own draws: the others' stay as they were)
    angle = other.uniform(-np.pi, np.pi, n)
    course = np.stack([np.cos(angle), np.sin(angle)], axis=1).astype(np.float32)
    across = other.uniform(-1.0, 1.0, n)
    q = np.zeros((n, 25), np.float32)
    q[:, :2] = start + walked[:, None] * course + across[:, None] * np.stack([-course[:, 1], course[:, 0]], axis=1)
    offset = rng.uniform(-0.3, 0.3, n).astype(np.float32)
    lane_in = np.full((n, 2), 9.0, np.float32)
    # each episode's goal (own_way: start_progress, the episode's own way from its start to its goal halves)
    goal_xy = (start + rng.uniform(1.0, goal, n)[:, None] * course).astype(np.float32)
    arr = lambda a, dt=None: wp.array(a, dtype=dt, device=DEV) if dt else wp.array(a, device=DEV)  # noqa: E731
    past = 2
    played = np.where(rng.random(n) < share, rng.integers(levels - past, levels, n), level).astype(np.int32)
    level_wp, lane_wp, z_wp = arr(level), arr(lane_in, wp.vec2), arr(np.full(n, 9.0, np.float32))
    played_wp = arr(played)
    wp.launch(curriculum_kernel, dim=n,
              inputs=[arr(status), arr(q), arr(start, wp.vec2), arr(course, wp.vec2), arr(goal_xy, wp.vec2), goal,
                      own_way, levels, climb,
                      levels if strict is None else strict,
                      cfg.lane_width, arr(offset), hf, footprint, clearance, past, share, 3,
                      arr(np.array([5], np.int32))],
              outputs=[level_wp, played_wp, lane_wp, z_wp], device=DEV)  # fmt: skip
    got, played_next = level_wp.numpy(), played_wp.numpy()
    top = (status == SUCCESS) & (level == levels - 1) & (played == level)
    assert top.any() and np.all((got[top] >= 0) & (got[top] < levels))
    walked_along = ((q[:, :2].astype(np.float64) - start) * course).sum(axis=1)
    way = np.linalg.norm(goal_xy.astype(np.float64) - start, axis=1) if own_way else None
    want = curriculum_reference(status, walked_along, level, goal, levels, got, strict, climb, played, way)
    np.testing.assert_array_equal(got, want)
    moved = (status != 0) & (status != NONFINITE)
    # the next episode: on a lane past the course drawn with probability share, else on the level's lane
    assert np.all(played_next[~moved] == played[~moved])
    np.testing.assert_allclose(lane_wp.numpy()[moved, 1], lane_center_y(cfg, played_next[moved]) + offset[moved],
                               atol=1e-5)  # fmt: skip
    if share:
        drawn = moved & (played_next != got)
        assert (moved & (played != level)).any() and abs(drawn.mean() / moved.mean() - share) < 0.1
        assert set(np.unique(played_next[drawn])) == {levels - 2, levels - 1}  # both lanes past the course drawn
        return
    np.testing.assert_array_equal(played_next[moved], got[moved])
    up = (status == SUCCESS) & (level + 1 < levels)
    np.testing.assert_array_equal(got[up], np.minimum(level[up] + climb, levels - 1))
    half = 0.5 * (way if own_way else goal)
    missed = (status != 0) & (status != SUCCESS) & (status != NONFINITE) & (walked >= half) & (level >= 3)
    assert missed.any()
    np.testing.assert_array_equal(got[missed], level[missed] - 1 if strict else level[missed])
    y = lane_center_y(cfg, got) + offset
    np.testing.assert_allclose(lane_wp.numpy()[moved], np.stack([np.zeros(n), y], 1)[moved], atol=1e-5)
    z = max_terrain_height_np(grid, np.zeros(n), y, footprint) + clearance
    np.testing.assert_allclose(z_wp.numpy()[moved], z[moved], atol=1e-5)
    assert np.all(lane_wp.numpy()[~moved] == 9.0) and np.all(z_wp.numpy()[~moved] == 9.0)  # untouched
    # placement alone puts every env on its level's lane
    wp.launch(placement_kernel, dim=n, inputs=[level_wp, levels, cfg.lane_width, arr(offset), hf, footprint, clearance],
              outputs=[lane_wp, z_wp], device=DEV)  # fmt: skip
    np.testing.assert_allclose(lane_wp.numpy()[:, 1], y, atol=1e-5)


def test_past_share_needs_lanes_past_the_course():
    with pytest.raises(ValueError, match="needs levels_past > 0"):
        build_height_grid(TerrainConfig(name="complex", levels=4, past_share=0.2))
    with pytest.raises(ValueError, match="needs a curriculum"):
        build_height_grid(TerrainConfig(name="complex", past_share=0.2))
    with pytest.raises(ValueError, match=r"past_share must be in \[0, 1\]"):
        build_height_grid(TerrainConfig(name="complex", levels=4, levels_past=1, past_share=1.5))


def test_strict_from():
    past = TerrainConfig(name="complex", levels=10, levels_past=3)
    assert strict_from(replace(past, past_down="miss")) == 7 and strict_from(past) == 10
    assert strict_from(TerrainConfig(name="complex", levels=10, past_down="miss")) == 10  # no lanes past the course


def test_start_levels_spread():
    assert start_levels(8, 3).tolist() == [0, 0, 0, 1, 1, 1, 2, 2]
    assert start_levels(5, 1).tolist() == [0] * 5


@pytest.mark.slow  # end to end: 15 s or more on a 2-core CPU
def test_env_moves_robots_between_lanes():
    """Robots start on their lanes; walking the (short) goal promotes them and the next episode starts one lane
    over; the level is logged."""
    cfg = HexConfig(sim=replace(SimConfig(), num_envs=6, device=DEV),
                    terrain=TerrainConfig(name="complex", levels=4, start_levels=2),
                    task=replace(TaskConfig(), goal_distance=1.0))  # fmt: skip
    env = make_env(cfg)
    lv0 = env.level.numpy().copy()
    assert lv0.tolist() == [0, 0, 0, 1, 1, 1]
    centre = lane_center_y(cfg.terrain, lv0)
    assert np.all(np.abs(env.start.numpy()[:, 1] - centre) <= cfg.sim.spawn_y_spread + cfg.task.reset_lateral + 1e-5)
    act = torch.zeros(6, 15)  # mid-range CPG parameters walk ~1 m in a few seconds
    promoted = np.zeros(6, bool)
    for _ in range(300):
        _, _, done, extras = env.step(act)
        d = done.numpy().astype(bool)
        if d.any():
            success = env.status.numpy() == SUCCESS
            assert np.all(env.level.numpy()[d & success] == np.minimum(lv0[d & success] + 1, 3))
            promoted |= d & success
            ys = env.start.numpy()[:, 1]
            lanes = lane_center_y(cfg.terrain, env.level.numpy())
            assert np.all(np.abs(ys - lanes)[d] <= cfg.sim.spawn_y_spread + cfg.task.reset_lateral + 1e-5)
            lv0 = env.level.numpy().copy()
    assert promoted.sum() >= 3, "mid-range gaits should reach a 1 m goal on the easiest lanes"
    assert float(extras["log"]["Curriculum/mean_level"]) == pytest.approx(env.level.numpy().mean())
    stats = env.episode_stats()
    assert stats["mean_level"] == pytest.approx(env.level.numpy().mean())
    # the ring remembers each finished episode's level: the last level's success rate (time-to-skill) is its own
    ring = env._ring.numpy()
    played = ring[~np.isnan(ring[:, 7])]
    top = played[:, 7] == 3
    assert stats["top_level_episodes"] == top.sum() and set(np.unique(played[:, 7])) <= {0, 1, 2, 3}
    if top.any():
        assert stats["top_level_success_rate"] == pytest.approx(played[top, 2].mean())


def test_lane_courses_hold_each_course_whole():
    """``lane_courses``: one group of lanes per course side by side along y; the first group is the terrain's own
    grid unchanged, and each other group's lane k is that course's lane k (its stairs at the lane's scaled rise, its
    blocks its own draws); env i plays group i mod 3."""
    from hexnewton.terrain.heightmap import env_groups, lane_config

    one = TerrainConfig(name="complex", levels=3, lane_width=1.0)
    cfg = replace(one, lane_courses=("rugged", "stepped"))
    grid, own = build_height_grid(cfg), build_height_grid(one)
    assert grid.heights.shape == (own.nx, 3 * own.ny) and grid.y0 == pytest.approx(-4.5)
    np.testing.assert_array_equal(grid.heights[:, : own.ny], own.heights)
    x = np.arange(cfg.x_min, cfg.x_max, cfg.query_resolution) + 0.5 * cfg.query_resolution
    for k in range(3):
        y = lane_center_y(cfg, k, 2)  # the stepped group: the paper's staircase, rise scaled by (k + 1) / 3
        step = np.clip(np.floor((x - cfg.stepped_start_x) / cfg.step_depth + 1e-9) + 1, 0, cfg.step_count)
        np.testing.assert_allclose(terrain_height_np(grid, x, np.full_like(x, y)), cfg.step_rise * (k + 1) / 3 * step,
                                   atol=1e-6)  # fmt: skip
        rugged = lane_config(cfg, k, 1)  # the rugged group: blocks from x_min to rugged_x_max, its own seed
        assert rugged.name == "rugged" and rugged.seed != lane_config(cfg, k, 0).seed
        ys = lane_center_y(cfg, k, 1) + np.linspace(-0.45, 0.45, 30)
        xs = np.linspace(0.0, cfg.rugged_x_max - 0.05, 60)
        h = terrain_height_np(grid, xs[None, :], ys[:, None])
        np.testing.assert_array_equal(h, terrain_height_np(build_height_grid(rugged), xs[None, :],
                                                           (ys - lane_center_y(cfg, k, 1))[:, None]))  # fmt: skip
        assert 0.5 * cfg.block_height_max * (k + 1) / 3 < h.max() <= cfg.block_height_max * (k + 1) / 3 + 1e-6
    assert env_groups(cfg, 5).tolist() == [0, 1, 2, 0, 1] and env_groups(one, 3).tolist() == [0, 0, 0]
    assert lane_center_y(one, 1) == lane_center_y(replace(one, lane_courses=()), 1, 0) == 0.0


@pytest.mark.parametrize("bad, message", [
    (dict(lane_courses=("rugged",)), "needs a curriculum"),
    (dict(levels=2, lane_courses=("moon",)), "unknown terrain 'moon'"),
    (dict(levels=2, lane_courses=("complex",)), "each course once"),
    (dict(name="flat", levels=2, lane_courses=("rugged",)), "beside a flat terrain"),
])  # fmt: skip
def test_lane_courses_checked(bad, message):
    with pytest.raises(ValueError, match=message):
        build_height_grid(replace(TerrainConfig(name="complex"), **bad))


@pytest.mark.slow  # builds an env: a few seconds on a 2-core CPU
def test_env_places_each_env_on_its_course():
    """Envs of a curriculum with ``lane_courses`` start on their level's lane of their own group."""
    from hexnewton.terrain.heightmap import env_groups

    cfg = HexConfig(sim=replace(SimConfig(), num_envs=6, device=DEV),
                    terrain=TerrainConfig(name="complex", levels=2, start_levels=2, lane_courses=("rugged", "stepped")))
    env = make_env(cfg)
    centre = lane_center_y(cfg.terrain, env.level.numpy(), env_groups(cfg.terrain, 6))
    assert np.all(np.abs(env.start.numpy()[:, 1] - centre) <= cfg.sim.spawn_y_spread + cfg.task.reset_lateral + 1e-5)
    assert len(np.unique(np.round(centre, 3))) >= 3


def test_lane_count_kernel_matches_reference():
    """Every finished episode counted on its lane group and played lane, successes apart (random states)."""
    rng = np.random.default_rng(4)
    n, levels, groups = 700, 6, 3
    status = rng.integers(0, 6, n).astype(np.int32)
    played = rng.integers(0, levels, n).astype(np.int32)
    group = rng.integers(0, groups, n).astype(np.int32)
    start = rng.integers(0, 50, (groups * levels, 2)).astype(np.int32)
    counts = wp.array(start, device=DEV)
    wp.launch(lane_count_kernel, dim=n, inputs=[wp.array(status, device=DEV), wp.array(played, device=DEV),
                                               wp.array(group, device=DEV), levels], outputs=[counts], device=DEV)
    want = start + lane_count_reference(status, played, group, levels, groups)
    np.testing.assert_array_equal(counts.numpy(), want)
    added = want - start
    assert added[:, 1].sum() == (status == SUCCESS).sum() and added[:, 0].sum() == (status != 0).sum()


def test_start_progress_places_episodes_along_the_lane():
    """``start_progress``: each reset starts x in [0, p] ahead of its lane's start, above the ground there, toward the
    lane's goal (goal_distance ahead of the lane's start); the lane counts add up to the finished episodes."""
    p = 2.0
    cfg = HexConfig(terrain=TerrainConfig(name="complex", levels=4, start_levels=4, lane_width=1.0,
                                          start_progress=p),
                    sim=SimConfig(num_envs=32, device=DEV), task=TaskConfig(seed=3))  # fmt: skip
    env = make_env(cfg)
    lane = env.lane.numpy()
    start, goal = env.goals.start.numpy(), env.goals.goal.numpy()
    ahead = start[:, 0] - lane[:, 0]
    assert np.all((ahead >= 0) & (ahead <= p)) and ahead.std() > 0.3
    np.testing.assert_allclose(goal[:, 0], lane[:, 0] + cfg.task.goal_distance, atol=1e-5)
    grid = env.world.terrain.grid
    z = max_terrain_height_np(grid, start[:, 0], start[:, 1], env.world.footprint) + env.world.spawn_clearance
    np.testing.assert_allclose(env.world.joint_q_wp.numpy()[:, 2], z, atol=1e-5)
    assert (z > 0.05).any()  # some start on the stairs, above their treads
    for _ in range(40):
        env.step(torch.zeros(env.num_envs, env.num_actions))
    counts = env.lane_counts()
    assert counts.shape == (1, 4, 2) and counts[..., 0].sum() == int(env._cursor.numpy()[0])
    with pytest.raises(Exception, match="start_progress must be below"):
        make_env(replace(cfg, terrain=replace(cfg.terrain, start_progress=3.0)))
    with pytest.raises(ValueError, match="start_progress 1.0 needs a curriculum"):
        build_height_grid(TerrainConfig(name="rugged", start_progress=1.0))
