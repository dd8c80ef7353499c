"""The rough-terrain generator, its height samples and its curriculum (tasks/terrain.py) against
the original's rules (reference task-specs §6), computed here in closed form."""

import numpy as np
import pytest
import torch

from myriad.tasks.terrain import (KINDS, TerrainConfig, TerrainCurriculum, column_kind,
                                  generate_terrain, height_points, level_verdicts, next_levels,
                                  sample_heights, tile_heights)

CONFIG = TerrainConfig()
UNIT = CONFIG.vertical_scale


@pytest.fixture(scope="module")
def terrain():
    return generate_terrain(CONFIG, seed=3)


def _tile(terrain, level, column):
    """Heights of one tile in height units (5 mm), [80, 80]."""
    b, n = CONFIG.border_cells, CONFIG.tile_cells
    return terrain.raw[b + level * n:b + (level + 1) * n, b + column * n:b + (column + 1) * n]


def test_columns_follow_the_cumulative_proportions():
    kinds = [column_kind(j, CONFIG) for j in range(20)]
    assert [k for k, _ in kinds] == [0] * 2 + [1] * 2 + [2] * 7 + [3] * 5 + [4] * 4
    assert [j for j, (_, inverted) in enumerate(kinds) if inverted] == [0, 2]   # the two pits
    assert KINDS[2] == "stairs down" and KINDS[3] == "stairs up"


def test_the_map_is_the_tiles_inside_a_flat_border(terrain):
    assert terrain.heights.shape == (10 * 80 + 400, 20 * 80 + 400)
    b = CONFIG.border_cells
    for edge in (terrain.heights[:b], terrain.heights[-b:], terrain.heights[:, :b],
                 terrain.heights[:, -b:]):
        assert not edge.any()
    np.testing.assert_allclose(terrain.heights, terrain.raw * UNIT, atol=1e-6)


@pytest.mark.parametrize("column", [4, 12])
def test_stairs_are_concentric_steps_of_the_levels_height(terrain, column):
    """Height of a cell = step × rings of width 3 cells (0.31 m) around it, at most 9 (the
    centre square is no wider than the 3 m platform); down (negative) in the stairs-down
    columns."""
    sign = -1 if column_kind(column, CONFIG)[0] == 2 else 1
    a = np.arange(80)
    inward = np.minimum(a, 79 - a)
    for level in (0, 5, 9):
        difficulty = level / 10
        step = int((0.05 + 0.175 * difficulty) / UNIT) * sign
        rings = np.minimum(np.minimum.outer(inward, inward) // 3, 9)
        np.testing.assert_array_equal(_tile(terrain, level, column), step * rings)


def test_slopes_are_pyramids_cut_flat_at_the_platform(terrain):
    for level in (3, 9):
        for column, sign in ((0, -1), (1, 1)):
            tile = _tile(terrain, level, column)
            top = sign * round(0.4 * level / 10 * 20 * 40)   # slope × (0.1 / 0.005) × half-tile
            ramp = 1 - np.abs(np.arange(80) - 40) / 40
            cone = np.trunc(top * ramp[:, None] * ramp[None, :])
            flat = cone[25, 25]                  # the platform's edge (3 m wide, centred)
            np.testing.assert_array_equal(tile, np.clip(cone, min(flat, 0), max(flat, 0)))
            assert abs(flat) > abs(top) * 0.38 and (tile[25:55, 25:55] == flat).all()


def test_rough_slopes_add_bounded_noise(terrain):
    smooth = tile_heights(0, False, 0.5, np.random.default_rng(0), CONFIG)
    rough = _tile(terrain, 5, 3) - smooth
    assert np.abs(rough).max() <= 20 and rough.std() > 5      # ±0.1 m, and really rough


def test_obstacles_take_the_four_heights_and_spare_the_platform(terrain):
    for level in (0, 9):
        difficulty = level / 10
        h = int((0.025 + 0.15 * difficulty) / UNIT)
        tile = _tile(terrain, level, 17)
        assert set(np.unique(tile)) <= {0, -h, -h // 2, h // 2, h}
        assert len(set(np.unique(tile)) - {0}) >= 3          # 40 boxes: most heights appear
        assert not tile[25:55, 25:55].any()


def test_origins_are_tile_centres_at_the_highest_point_of_the_middle(terrain):
    for level, column in ((0, 0), (9, 4), (9, 12), (4, 17)):
        x, y, z = terrain.origins[level, column]
        assert (x, y) == ((level + 0.5) * 8.0, (column + 0.5) * 8.0)
        assert z == pytest.approx(_tile(terrain, level, column)[30:50, 30:50].max() * UNIT)
    assert terrain.origins[9, 12, 2] == pytest.approx(9 * int(0.2075 / UNIT) * UNIT)  # top step


def test_height_samples_read_the_generators_heights(terrain):
    """At the 140 points round bases spread over the map, yawed at random: the sample is the
    lower of the two grid heights the original reads, and equals the stairs' closed-form height
    wherever both grid points lie on the same step."""
    points = height_points()
    assert points.shape == (140, 3)
    assert points[:, 0].abs().min() == pytest.approx(0.2) and points[:, 1].abs().max() == 0.5
    gen = torch.Generator().manual_seed(0)
    bases = torch.rand(64, 2, generator=gen) * torch.tensor([80.0, 160.0])
    yaw = torch.rand(64, generator=gen) * 2 * torch.pi
    c, s = torch.cos(yaw)[:, None], torch.sin(yaw)[:, None]
    world = torch.stack([bases[:, :1] + c * points[:, 0] - s * points[:, 1],
                         bases[:, 1:] + s * points[:, 0] + c * points[:, 1]], dim=-1)
    heights = torch.from_numpy(terrain.heights)
    sampled = sample_heights(heights, world, CONFIG)
    assert sampled.shape == (64, 140)
    i = ((world[..., 0] + 20) / 0.1).long()
    j = ((world[..., 1] + 20) / 0.1).long()
    torch.testing.assert_close(sampled, torch.minimum(heights[i, j], heights[i + 1, j + 1]))

    # one stairs-up tile in closed form, at points strewn over it
    level, column = 6, 13
    step = int((0.05 + 0.175 * 0.6) / UNIT) * UNIT
    xy = torch.rand(4000, 2, generator=gen) * 8 + torch.tensor([level * 8.0, column * 8.0])
    local = ((xy - torch.tensor([level * 8.0, column * 8.0])) / 0.1).floor().long()

    def analytic(cells):
        inward = torch.minimum(cells, 79 - cells).clamp(min=0)
        return torch.minimum(inward.min(dim=-1).values // 3, torch.tensor(9)) * step

    here, diagonal = analytic(local), analytic((local + 1).clamp(max=79))
    same = here == diagonal
    assert same.float().mean() > 0.5
    got = sample_heights(heights, xy, CONFIG)
    torch.testing.assert_close(got[same], here[same].float(), atol=1e-6, rtol=0)
    assert ((got[~same] - here[~same]).abs() <= step + 1e-6).all()   # within one step


def test_samples_off_the_map_are_clamped_to_its_edge(terrain):
    heights = torch.from_numpy(terrain.heights)
    far = torch.tensor([[-100.0, -100.0], [500.0, 500.0]])
    assert torch.equal(sample_heights(heights, far, CONFIG), torch.zeros(2))


def test_the_curriculum_moves_robots_by_how_far_they_walked():
    levels = torch.tensor([0, 3, 3, 3, 9, 5, 5])
    walked = torch.tensor([0.1, 0.5, 2.0, 4.5, 4.5, 3.0, 4.5])
    speed = torch.tensor([1.0, 1.0, 0.1, 0.5, 0.5, 0.0, 1.0])
    # 20 s episodes: down when walked < speed × 5 m; up when walked > 4 m (left the tile);
    # both (the last: left its tile, yet short of its command) cancel, as in the original
    assert next_levels(levels, walked, speed, 20.0, CONFIG).tolist() == [0, 2, 3, 4, 0, 5, 5]
    up, down = level_verdicts(walked, speed, 20.0, CONFIG)
    assert up.tolist() == [False, False, False, True, True, False, True]
    assert down.tolist() == [True, True, False, False, False, False, True]


def _spread(num_envs, levels=10, types=20):
    """`TerrainCurriculum.spread_levels` on `num_envs` envs, kinds assigned as `init_levels`
    does; returns (levels, kinds)."""
    from types import SimpleNamespace
    kinds = torch.div(torch.arange(num_envs) * types, num_envs, rounding_mode="floor")
    task = SimpleNamespace(terrain_config=TerrainConfig(levels=levels, types=types),
                           num_envs=num_envs, kinds=kinds, device="cpu",
                           levels=torch.zeros(num_envs, dtype=torch.long),
                           tile_origins=torch.rand(levels, types, 3),
                           env_origins=torch.zeros(num_envs, 3))
    TerrainCurriculum.spread_levels(task)
    assert torch.equal(task.env_origins, task.tile_origins[task.levels, task.kinds])
    return task.levels, kinds


def test_spread_levels_put_every_level_on_every_kind_of_tile():
    # 200 envs: each of the 10 x 20 tiles exactly once; 400: twice
    for n in (200, 400):
        levels, kinds = _spread(n)
        tiles = torch.bincount(levels * 20 + kinds, minlength=200)
        assert (tiles == n // 200).all()
    # 100 envs (5 per kind): every level 10 times, over kinds of several columns, not only
    # the even kinds on levels 0-4 that level = i mod 10 would give
    levels, kinds = _spread(100)
    assert (torch.bincount(levels, minlength=10) == 10).all()
    for level in range(10):
        assert len(set(kinds[levels == level].tolist())) == 10
    # 10 envs (every other kind, one env each): each level once
    levels, kinds = _spread(10)
    assert sorted(levels.tolist()) == list(range(10)) and len(set(kinds.tolist())) == 10


def test_impossible_terrain_settings_are_named():
    with pytest.raises(ValueError, match="proportions"):
        TerrainConfig(proportions=(0.5, 0.5, 0.5, 0.0, 0.0))
    with pytest.raises(ValueError, match="platform"):
        TerrainConfig(platform=9.0)
    with pytest.raises(ValueError, match="levels"):
        TerrainConfig(levels=0)
    with pytest.raises(ValueError, match="step_height"):
        TerrainConfig(step_height=(-0.05, 0.1))
    # a typo in a task file's env.terrain is named (it would leave the setting at its default)
    import yaml
    from importlib.resources import files
    env = yaml.safe_load((files("myriad") / "cfg/task/G1Rough.yaml").read_text())["env"]
    env["terrain"]["stepHeight"] = env["terrain"].pop("step_height")
    with pytest.raises(ValueError, match=r"env.terrain: unknown keys \['stepHeight'\].*"
                                         r"step_height"):
        TerrainCurriculum().init_terrain(env)


def test_steps_and_boxes_that_start_at_zero_leave_level_0_flat():
    """G1Rough's terrain: stairs and obstacles grow from 0, so its first level is flat ground
    on every tile but the slopes (whose slope is 0 there, only the rough slope's noise left),
    while the top level keeps real steps."""
    config = TerrainConfig(step_height=(0.0, 0.15), obstacle_height=(0.0, 0.1), rough_noise=0.05)
    terrain = generate_terrain(config, seed=0)
    cells, border = config.tile_cells, config.border_cells
    for column in range(config.types):
        kind, _ = column_kind(column, config)
        tile = terrain.raw[border:border + cells, border + column * cells:
                           border + (column + 1) * cells]
        if kind == 0 or kind >= 2:
            assert (tile == 0).all(), (column, KINDS[kind])
        else:
            assert 0 < np.abs(tile).max() * config.vertical_scale <= 0.05 + 1e-9
    top = config.levels - 1
    stairs = [c for c in range(config.types) if column_kind(c, config)[0] == 3][0]
    tile = terrain.raw[border + top * cells:border + (top + 1) * cells,
                       border + stairs * cells:border + (stairs + 1) * cells]
    steps = np.unique(np.abs(np.diff(tile, axis=0)))
    assert steps.max() * config.vertical_scale == pytest.approx(0.135, abs=config.vertical_scale)
