"""`isaacgym.terrain_utils` on Myriad: height-field terrain generators and their triangle mesh.

Isaac Gym's terrain helpers, as locomotion code (IsaacGymEnvs' AnymalTerrain, legged_gym and its
forks) calls them. A `SubTerrain` holds `height_field_raw`, an int16 grid [width, length] of
heights in units of `vertical_scale` metres, sample (i, j) at (i, j)·`horizontal_scale` metres;
each generator adds its pattern to that grid in place and returns the terrain. Arguments are in
metres (heights, sizes) or dimensionless (slopes), as in the original. Randomness comes from
NumPy's global generator (`np.random`), which those projects seed.

`convert_heightfield_to_trimesh` turns a raw grid into the vertices and triangles that
`gym.add_triangle_mesh` takes: one vertex per sample (row-major), two triangles per cell, normals
up; with a slope threshold, a vertex below a neighbour that is steeper than the threshold moves
under that neighbour, so steps become vertical walls instead of ramps. Myriad's
`add_triangle_mesh` recognizes such a grid mesh and simulates it as a height field with those
walls (`myriad.api.Scene.add_terrain(riser=...)`); any other mesh collides as its triangles.
"""

from __future__ import annotations

import numpy as np

# the same mesh Myriad's AnymalTerrain builds for its `terrain.mesh` option
from myriad.tasks.terrain import heightfield_to_mesh as convert_heightfield_to_trimesh

__all__ = ["SubTerrain", "random_uniform_terrain", "sloped_terrain", "pyramid_sloped_terrain",
           "discrete_obstacles_terrain", "wave_terrain", "stairs_terrain",
           "pyramid_stairs_terrain", "stepping_stones_terrain",
           "convert_heightfield_to_trimesh"]


class SubTerrain:
    """One tile of terrain: `height_field_raw` [width, length] int16, heights in units of
    `vertical_scale` (m); samples `horizontal_scale` (m) apart."""

    def __init__(self, terrain_name: str = "terrain", width: int = 256, length: int = 256,
                 vertical_scale: float = 1.0, horizontal_scale: float = 1.0):
        if not (int(width) >= 1 and int(length) >= 1):
            raise ValueError(f"SubTerrain: width={width} and length={length} must be >= 1 samples")
        if not (vertical_scale > 0 and horizontal_scale > 0):
            raise ValueError(f"SubTerrain: vertical_scale={vertical_scale} and "
                             f"horizontal_scale={horizontal_scale} must be > 0")
        self.terrain_name = terrain_name
        self.width, self.length = int(width), int(length)
        self.vertical_scale, self.horizontal_scale = vertical_scale, horizontal_scale
        self.height_field_raw = np.zeros((self.width, self.length), dtype=np.int16)


def _cells(terrain: SubTerrain, metres: float) -> int:
    return int(metres / terrain.horizontal_scale)


def _raw(terrain: SubTerrain, metres: float) -> int:
    return int(metres / terrain.vertical_scale)


def _add(terrain: SubTerrain, heights: np.ndarray) -> SubTerrain:
    terrain.height_field_raw += heights.astype(terrain.height_field_raw.dtype)
    return terrain


def _flatten_platform(terrain: SubTerrain, platform_size: float, value: int = 0) -> None:
    """Sets the square of side `platform_size` (m) at the tile's centre to `value` (raw)."""
    half = _cells(terrain, platform_size) // 2
    cx, cy = terrain.width // 2, terrain.length // 2
    terrain.height_field_raw[max(cx - half, 0):cx + half, max(cy - half, 0):cy + half] = value


def random_uniform_terrain(terrain: SubTerrain, min_height: float, max_height: float,
                           step: float = 1, downsampled_scale: float | None = None) -> SubTerrain:
    """Adds noise: heights drawn uniformly from {min_height, min_height + step, ...,
    max_height} (m) on a coarser grid `downsampled_scale` (m) apart (default: the tile's own),
    interpolated bilinearly onto the tile's samples."""
    if not max_height >= min_height or not step > 0:
        raise ValueError(f"random_uniform_terrain: need min_height <= max_height and step > 0, "
                         f"got {min_height}, {max_height}, {step}")
    scale = terrain.horizontal_scale if downsampled_scale is None else downsampled_scale
    if not scale > 0:
        raise ValueError(f"random_uniform_terrain: downsampled_scale={downsampled_scale} must "
                         f"be > 0")
    low, high, quantum = _raw(terrain, min_height), _raw(terrain, max_height), \
        max(_raw(terrain, step), 1)
    levels = np.arange(low, high + quantum, quantum)
    coarse_w = max(int(terrain.width * terrain.horizontal_scale / scale), 2)
    coarse_l = max(int(terrain.length * terrain.horizontal_scale / scale), 2)
    coarse = np.random.choice(levels, (coarse_w, coarse_l)).astype(np.float64)
    # the coarse grid spans the tile: its first and last samples on the tile's first and last
    u = np.linspace(0, coarse_w - 1, terrain.width)
    v = np.linspace(0, coarse_l - 1, terrain.length)
    i0 = np.minimum(u.astype(int), coarse_w - 2)
    j0 = np.minimum(v.astype(int), coarse_l - 2)
    fu, fv = (u - i0)[:, None], (v - j0)[None, :]
    c = lambda di, dj: coarse[np.ix_(i0 + di, j0 + dj)]  # noqa: E731
    noise = (c(0, 0) * (1 - fu) * (1 - fv) + c(1, 0) * fu * (1 - fv)
             + c(0, 1) * (1 - fu) * fv + c(1, 1) * fu * fv)
    return _add(terrain, np.rint(noise))


def sloped_terrain(terrain: SubTerrain, slope: float = 1) -> SubTerrain:
    """Adds a plane rising along the first axis (x): `slope` metres per metre, 0 at x = 0."""
    x = np.arange(terrain.width)[:, None]
    rise = slope * terrain.horizontal_scale / terrain.vertical_scale * x
    return _add(terrain, np.broadcast_to(rise, terrain.height_field_raw.shape))


def pyramid_sloped_terrain(terrain: SubTerrain, slope: float = 1,
                           platform_size: float = 1.0) -> SubTerrain:
    """Adds a four-sided pyramid, 0 at the tile's edges, rising at `slope` (m/m; negative: a
    pit) towards the centre, cut flat at the height it reaches around a central square of side
    `platform_size` (m)."""
    cx, cy = terrain.width // 2, terrain.length // 2
    x = np.arange(terrain.width)[:, None]
    y = np.arange(terrain.length)[None, :]
    fx = (cx - np.abs(cx - x)) / max(cx, 1)            # 0 at the edges, 1 at the centre
    fy = (cy - np.abs(cy - y)) / max(cy, 1)
    top = slope * terrain.horizontal_scale / terrain.vertical_scale * (terrain.width / 2)
    heights = np.rint(top * fx * fy)
    half = _cells(terrain, platform_size) // 2
    cut = heights[min(max(cx - half, 0), terrain.width - 1), min(max(cy - half, 0),
                                                                   terrain.length - 1)]
    heights = np.clip(heights, min(cut, 0), max(cut, 0))
    return _add(terrain, heights)


def discrete_obstacles_terrain(terrain: SubTerrain, max_height: float, min_size: float,
                               max_size: float, num_rects: int,
                               platform_size: float = 1.0) -> SubTerrain:
    """Sets `num_rects` random rectangles (sides from `min_size` to `max_size` m in 4-sample
    steps) to heights drawn from {-max_height, -max_height/2, max_height/2, max_height} (m);
    a central square of side `platform_size` (m) is flattened to 0."""
    top = _raw(terrain, max_height)
    levels = np.array([-top, -top // 2, top // 2, top])
    lo, hi = _cells(terrain, min_size), _cells(terrain, max_size)
    sizes = np.arange(lo, hi, 4) if hi > lo else np.array([max(lo, 1)])
    sizes = np.maximum(sizes, 1)
    for _ in range(int(num_rects)):
        w, l = int(np.random.choice(sizes)), int(np.random.choice(sizes))
        x = np.random.randint(0, max(terrain.width - w, 1))
        y = np.random.randint(0, max(terrain.length - l, 1))
        terrain.height_field_raw[x:x + w, y:y + l] = np.random.choice(levels)
    _flatten_platform(terrain, platform_size)
    return terrain


def wave_terrain(terrain: SubTerrain, num_waves: int = 1, amplitude: float = 1.0) -> SubTerrain:
    """Adds amplitude·(sin along x + cos along y) (m), `num_waves` periods over the tile's
    length."""
    if num_waves <= 0:
        return terrain
    period = terrain.length / (num_waves * 2 * np.pi)
    x = np.arange(terrain.width)[:, None]
    y = np.arange(terrain.length)[None, :]
    a = amplitude / terrain.vertical_scale
    return _add(terrain, np.rint(a * np.sin(x / period) + a * np.cos(y / period)))


def stairs_terrain(terrain: SubTerrain, step_width: float, step_height: float) -> SubTerrain:
    """Adds straight stairs along x: each `step_width` (m) deep, `step_height` (m) higher
    than the one before (negative: down), the first at 0."""
    depth = max(_cells(terrain, step_width), 1)
    rise = _raw(terrain, step_height)
    steps = (np.arange(terrain.width) // depth)[:, None] * rise
    return _add(terrain, np.broadcast_to(steps, terrain.height_field_raw.shape))


def pyramid_stairs_terrain(terrain: SubTerrain, step_width: float, step_height: float,
                           platform_size: float = 1.0) -> SubTerrain:
    """Sets concentric square steps, each `step_width` (m) in from the last and `step_height`
    (m) higher (negative: a stepped pit), until the inner square is no wider than
    `platform_size` (m)."""
    depth, rise = max(_cells(terrain, step_width), 1), _raw(terrain, step_height)
    platform = _cells(terrain, platform_size)
    x0, x1, y0, y1, height = 0, terrain.width, 0, terrain.length, 0
    while x1 - x0 > platform and y1 - y0 > platform:
        x0, x1, y0, y1 = x0 + depth, x1 - depth, y0 + depth, y1 - depth
        if x0 >= x1 or y0 >= y1:
            break
        height += rise
        terrain.height_field_raw[x0:x1, y0:y1] = height
    return terrain


def stepping_stones_terrain(terrain: SubTerrain, stone_size: float, stone_distance: float,
                            max_height: float, platform_size: float = 1.0,
                            depth: float = -10) -> SubTerrain:
    """Sets the tile to `depth` (m) with square stones of side `stone_size` (m), `stone_distance`
    (m) apart, laid row by row along the tile's longer side, each at a height drawn from
    [-max_height, max_height) (m); a central square of side `platform_size` (m) at 0."""
    size, gap = max(_cells(terrain, stone_size), 1), _cells(terrain, stone_distance)
    top = _raw(terrain, max_height)
    heights = np.arange(-top, top, step=1) if top > 0 else np.array([0])
    hf = terrain.height_field_raw
    hf[:, :] = _raw(terrain, depth)
    along_x = terrain.length < terrain.width     # rows across the longer side
    long_n, short_n = (terrain.width, terrain.length) if along_x else \
        (terrain.length, terrain.width)
    start = 0
    while start < short_n:
        stop = min(short_n, start + size)
        offset = np.random.randint(0, size)
        first = max(0, offset - gap)
        cells = [(first, offset)] + [(s, min(long_n, s + size))
                                     for s in range(offset + gap, long_n, size + gap)]
        for a, b in cells:
            if a < b:
                height = np.random.choice(heights)
                if along_x:
                    hf[a:b, start:stop] = height
                else:
                    hf[start:stop, a:b] = height
        start += size + gap
    _flatten_platform(terrain, platform_size)
    return terrain
