"""Rough terrain for legged robots: the original AnymalTerrain's grid of tiles, its height samples
around the base and its curriculum (seed A.2.2; reference task-specs §6).

The terrain is one height map that every env shares: `levels` rows × `types` columns of square
tiles (8 m), ringed by a flat border (20 m), sampled every `horizontal_scale` (0.1 m) in integer
steps of `vertical_scale` (5 mm), as the original builds it. Row i is difficulty i / levels; the
column picks the kind of tile by the cumulative proportions [0.1, 0.2, 0.55, 0.8, 1.0]:

    smooth slope     a pyramid, slope 0.4·difficulty (first half of its columns: a pit)
    rough slope      the same plus uniform noise ±0.1 m on a 0.2 m grid (first half: a pit)
    stairs down      to the centre (the robot climbs out), step 0.05 + 0.175·difficulty m, 0.31 m wide
    stairs up        to the centre
    obstacles        40 boxes of 1-2 m, heights ±h, ±h/2, h = 0.025 + 0.15·difficulty

(the step and box heights are `step_height` and `obstacle_height`: a task may start them at 0,
making its level 0 flat ground but for the rough slope's noise, as G1Rough does).

Every tile keeps a flat 3 m platform at its centre, where its robots start: the env origin is the
tile's centre at the highest point within its central 2 × 2 m.

Grid index (i, j) is at world (i·horizontal_scale − border, j·horizontal_scale − border): the
first index runs along x, as in the original.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from ..torch_utils import quat_rotate

KINDS = ("smooth slope", "rough slope", "stairs down", "stairs up", "obstacles")


@dataclass
class TerrainConfig:
    """The original's terrain settings (AnymalTerrain.yaml)."""
    levels: int = 10                    # rows of tiles: difficulty level / levels
    types: int = 20                     # columns of tiles
    tile: float = 8.0                   # tile side (m)
    border: float = 20.0                # flat margin round the grid (m)
    horizontal_scale: float = 0.1       # grid spacing (m)
    vertical_scale: float = 0.005       # height unit (m)
    proportions: tuple = (0.1, 0.1, 0.35, 0.25, 0.2)   # of KINDS, in column order
    platform: float = 3.0               # flat centre of every tile (m)
    slope: float = 0.4                  # at difficulty 1
    step_width: float = 0.31            # stairs (m)
    step_height: tuple = (0.05, 0.175)  # stairs' step: a + b·difficulty (m)
    obstacle_height: tuple = (0.025, 0.15)   # obstacle boxes' h: a + b·difficulty (m)
    rough_noise: float = 0.1            # rough slope: heights in ±this (m) ...
    rough_step: float = 0.025           # ... in steps of this (m) ...
    rough_grid: float = 0.2             # ... drawn on a grid this coarse (m), then interpolated
    obstacles: int = 40                 # boxes per obstacle tile
    obstacle_size: tuple = (1.0, 2.0)   # box sides from [lo, hi) (m)

    def __post_init__(self):
        if self.levels < 1 or self.types < 1:
            raise ValueError(f"terrain: levels ({self.levels}) and types ({self.types}) must be "
                             ">= 1")
        if len(self.proportions) != len(KINDS) or min(self.proportions) < 0 \
                or abs(sum(self.proportions) - 1.0) > 1e-6:
            raise ValueError(f"terrain: proportions {list(self.proportions)} must be "
                             f"{len(KINDS)} non-negative shares of {list(KINDS)} summing to 1")
        for name in ("step_height", "obstacle_height"):
            a, b = getattr(self, name)
            if a < 0 or b < 0:
                raise ValueError(f"terrain: {name} {[a, b]} (a + b·difficulty m) must be "
                                 "non-negative")
        if not 0 < self.platform < self.tile:
            raise ValueError(f"terrain: platform {self.platform} m must lie inside the "
                             f"{self.tile} m tile")

    @property
    def tile_cells(self) -> int:
        return int(self.tile / self.horizontal_scale)

    @property
    def border_cells(self) -> int:
        return int(self.border / self.horizontal_scale)


@dataclass
class Terrain:
    """A generated terrain: the shared height map, and where each tile's robots start."""
    config: TerrainConfig
    raw: np.ndarray                 # [rows, cols] int32: heights in units of vertical_scale
    heights: np.ndarray             # [rows, cols] float32 (m); index (i, j) as the module says
    origins: np.ndarray             # [levels, types, 3] (m): each tile's start point
    kind: list = field(default_factory=list)    # KINDS index of each column


def column_kind(column: int, config: TerrainConfig) -> tuple[int, bool]:
    """(KINDS index, inverted) of a column: choice = column / types against the cumulative
    proportions; the first half of the slope columns are pits, as in the original (stairs are
    "down" throughout their share: step heights negative, the centre lowest)."""
    choice = column / config.types
    edges = np.cumsum(config.proportions)
    kind = int(min(np.searchsorted(edges, choice, side="right"), len(KINDS) - 1))
    start = edges[kind - 1] if kind else 0.0
    inverted = kind in (0, 1) and choice < start + config.proportions[kind] / 2 - 1e-9
    return kind, bool(inverted)


def _pyramid_slope(cells: int, slope: float, platform: int, config: TerrainConfig) -> np.ndarray:
    """A pyramid rising `slope` (m/m) from the tile's edges, cut flat at the platform's height."""
    ramp = 1.0 - np.abs(np.arange(cells) - cells // 2) / (cells // 2)   # 0 at the edges, 1 centre
    top = int(slope * (config.horizontal_scale / config.vertical_scale) * (cells / 2))
    raw = (top * ramp[:, None] * ramp[None, :]).astype(np.int32)         # truncated, as int16
    lo = cells // 2 - platform // 2
    level = raw[lo, lo]
    return np.clip(raw, min(level, 0), max(level, 0))


def _uniform_noise(cells: int, rng: np.random.Generator, config: TerrainConfig) -> np.ndarray:
    """Heights drawn from {−noise, …, +noise} (step `rough_step`) on a coarse grid, linearly
    interpolated to the tile's cells and rounded to height units."""
    unit = config.vertical_scale
    levels = np.arange(-round(config.rough_noise / unit),
                       round(config.rough_noise / unit) + round(config.rough_step / unit),
                       round(config.rough_step / unit))
    coarse_n = int(cells * config.horizontal_scale / config.rough_grid)
    coarse = rng.choice(levels, (coarse_n, coarse_n)).astype(np.float64)
    at = np.linspace(0.0, coarse_n - 1, cells)          # each cell's place on the coarse grid
    lo = np.minimum(at.astype(int), coarse_n - 2)
    w = at - lo
    rows = coarse[lo] * (1 - w)[:, None] + coarse[lo + 1] * w[:, None]
    both = rows[:, lo] * (1 - w)[None, :] + rows[:, lo + 1] * w[None, :]
    return np.rint(both).astype(np.int32)


def _pyramid_stairs(cells: int, step_height: int, step_width: int, platform: int) -> np.ndarray:
    """Concentric square steps of `step_width` cells, each `step_height` units above the last
    (negative: down towards the centre), until the inner square is no wider than the platform."""
    raw = np.zeros((cells, cells), dtype=np.int32)
    lo, hi, height = 0, cells, 0
    while hi - lo > platform:
        lo, hi, height = lo + step_width, hi - step_width, height + step_height
        raw[lo:hi, lo:hi] = height
    return raw


def _obstacles(cells: int, height: int, rng: np.random.Generator, platform: int,
               config: TerrainConfig) -> np.ndarray:
    """Boxes of random sides at heights ±h, ±h/2, placed on a 4-cell lattice; the platform
    cleared back to 0."""
    raw = np.zeros((cells, cells), dtype=np.int32)
    sides = np.arange(int(config.obstacle_size[0] / config.horizontal_scale),
                      int(config.obstacle_size[1] / config.horizontal_scale), 4)
    tops = np.array([-height, -height // 2, height // 2, height])     # floor division, as the original
    for _ in range(config.obstacles):
        w, l = rng.choice(sides), rng.choice(sides)
        i, j = rng.choice(np.arange(0, cells - w, 4)), rng.choice(np.arange(0, cells - l, 4))
        raw[i:i + w, j:j + l] = rng.choice(tops)
    lo, hi = (cells - platform) // 2, (cells + platform) // 2
    raw[lo:hi, lo:hi] = 0
    return raw


def tile_heights(kind: int, inverted: bool, difficulty: float, rng: np.random.Generator,
                 config: TerrainConfig) -> np.ndarray:
    """One tile's heights in height units ([cells, cells] int32)."""
    cells, unit = config.tile_cells, config.vertical_scale
    platform = int(config.platform / config.horizontal_scale)
    slope = config.slope * difficulty * (-1.0 if inverted else 1.0)
    if kind == 0:
        return _pyramid_slope(cells, slope, platform, config)
    if kind == 1:
        return _pyramid_slope(cells, slope, platform, config) + _uniform_noise(cells, rng, config)
    if kind in (2, 3):
        a, b = config.step_height
        step = int((a + b * difficulty) / unit) * (-1 if kind == 2 else 1)
        return _pyramid_stairs(cells, step, int(config.step_width / config.horizontal_scale),
                               platform)
    a, b = config.obstacle_height
    return _obstacles(cells, int((a + b * difficulty) / unit), rng, platform, config)


def generate_terrain(config: TerrainConfig | None = None, seed: int = 0) -> Terrain:
    """The whole grid of tiles (row = level, column = kind of tile) inside its flat border."""
    config = config or TerrainConfig()
    rng = np.random.default_rng(seed)
    cells, border = config.tile_cells, config.border_cells
    raw = np.zeros((config.levels * cells + 2 * border, config.types * cells + 2 * border),
                   dtype=np.int32)
    origins = np.zeros((config.levels, config.types, 3))
    centre = slice(int((config.tile / 2 - 1) / config.horizontal_scale),
                   int((config.tile / 2 + 1) / config.horizontal_scale))
    kinds = []
    for j in range(config.types):
        kind, inverted = column_kind(j, config)
        kinds.append(kind)
        for i in range(config.levels):
            tile = tile_heights(kind, inverted, i / config.levels, rng, config)
            raw[border + i * cells:border + (i + 1) * cells,
                border + j * cells:border + (j + 1) * cells] = tile
            origins[i, j] = ((i + 0.5) * config.tile, (j + 0.5) * config.tile,
                             tile[centre, centre].max() * config.vertical_scale)
    return Terrain(config, raw, (raw * config.vertical_scale).astype(np.float32), origins, kinds)


def heightfield_to_mesh(height_field_raw: np.ndarray, horizontal_scale: float,
                        vertical_scale: float, slope_threshold: float | None = None):
    """The height field as a triangle mesh, as Isaac Gym's terrain_utils builds it for PhysX
    (`isaacgym.terrain_utils.convert_heightfield_to_trimesh` is this function): vertices
    [rows·cols, 3] float32 (m; sample (i, j) at (i·horizontal_scale, j·horizontal_scale),
    row-major), triangles [2·(rows-1)·(cols-1), 3] uint32, counter-clockwise seen from above.
    With `slope_threshold` (m/m): a vertex whose neighbour along x or y is higher by more than
    threshold·horizontal_scale moves horizontally under that neighbour, making the step a
    vertical wall."""
    hf = np.asarray(height_field_raw)
    if hf.ndim != 2 or min(hf.shape) < 2:
        raise ValueError(f"heightfield_to_mesh: height_field_raw must be a 2-D grid "
                         f"of at least 2 x 2 samples, not shape {hf.shape}")
    rows, cols = hf.shape
    x = np.arange(rows, dtype=np.float64)[:, None] * np.ones((1, cols))
    y = np.ones((rows, 1)) * np.arange(cols, dtype=np.float64)[None, :]
    if slope_threshold is not None:
        jump = slope_threshold * horizontal_scale / vertical_scale    # in raw units
        h = hf.astype(np.float64)
        move_x, move_y = np.zeros((rows, cols)), np.zeros((rows, cols))
        move_x[:-1, :] += h[1:, :] - h[:-1, :] > jump       # next sample along x is higher
        move_x[1:, :] -= h[:-1, :] - h[1:, :] > jump        # previous one is higher
        move_y[:, :-1] += h[:, 1:] - h[:, :-1] > jump
        move_y[:, 1:] -= h[:, :-1] - h[:, 1:] > jump
        x += move_x
        y += move_y
        x, y = np.clip(x, 0, rows - 1), np.clip(y, 0, cols - 1)   # the border stays put
    vertices = np.stack([x.ravel() * horizontal_scale, y.ravel() * horizontal_scale,
                         hf.ravel().astype(np.float64) * vertical_scale], axis=1)
    corner = (np.arange(rows - 1)[:, None] * cols + np.arange(cols - 1)[None, :]).ravel()
    triangles = np.empty((2 * corner.size, 3), dtype=np.uint32)
    triangles[0::2] = np.stack([corner, corner + cols + 1, corner + 1], axis=1)
    triangles[1::2] = np.stack([corner, corner + cols, corner + cols + 1], axis=1)
    return vertices.astype(np.float32), triangles


def height_points(device="cpu") -> torch.Tensor:
    """The 140 points [140, 3] (base frame, yaw only; z = 0) where the policy reads the terrain:
    x in ±0.2…±0.8 m and y in ±0.1…±0.5 m, every 0.1 m (x-major)."""
    xs = torch.tensor([-0.8, -0.7, -0.6, -0.5, -0.4, -0.3, -0.2, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8])
    ys = torch.tensor([-0.5, -0.4, -0.3, -0.2, -0.1, 0.1, 0.2, 0.3, 0.4, 0.5])
    gx, gy = torch.meshgrid(xs, ys, indexing="ij")
    return torch.stack([gx.flatten(), gy.flatten(), torch.zeros(gx.numel())], dim=1).to(device)


def sample_heights(heights: torch.Tensor, points_xy: torch.Tensor,
                   config: TerrainConfig) -> torch.Tensor:
    """Terrain height (m) under world points [..., 2], as the original reads it: the lower of
    the grid samples at (⌊i⌋, ⌊j⌋) and (⌊i⌋ + 1, ⌊j⌋ + 1), indices clamped inside the map (a
    cautious reading at a step edge: the lower side)."""
    ij = ((points_xy + config.border) / config.horizontal_scale).long()
    i = ij[..., 0].clamp(0, heights.shape[0] - 2)
    j = ij[..., 1].clamp(0, heights.shape[1] - 2)
    return torch.minimum(heights[i, j], heights[i + 1, j + 1])


def level_verdicts(walked: torch.Tensor, command_speed: torch.Tensor, episode_s: float,
                   config: TerrainConfig) -> tuple[torch.Tensor, torch.Tensor]:
    """The curriculum's verdict on episodes: (up, down) [N] flags. Up: the robot left its tile
    (walked farther than half a tile from its origin); down: it walked less than a quarter of
    what its command asked over a whole episode."""
    return walked > config.tile / 2, walked < command_speed * episode_s * 0.25


def next_levels(levels: torch.Tensor, walked: torch.Tensor, command_speed: torch.Tensor,
                episode_s: float, config: TerrainConfig) -> torch.Tensor:
    """The curriculum at reset (`level_verdicts`): down a level, or up one; level 0 is the
    floor, and passing the top level starts over at 0 (so robots that master the terrain keep
    sampling all of it; in that steady state the mean level is (levels - 1) / 2, 4.5 of 10)."""
    up, down = level_verdicts(walked, command_speed, episode_s, config)
    return (levels - down.long() + up.long()).clamp(min=0) % config.levels


TERRAIN_KEYS = ("levels", "types", "proportions", "tile", "border", "horizontal_scale",
                "vertical_scale")
TERRAIN_OPTIONAL_KEYS = ("step_height", "obstacle_height", "rough_noise")   # else the defaults
# read by the task from env.terrain besides the grid's shape
TERRAIN_TASK_KEYS = ("seed", "mesh", "slopeThreshold", "staticFriction", "curriculum")


class TerrainCurriculum:
    """What a `VecTask` on the terrain grid shares (AnymalTerrain, G1Rough): the grid built from
    `env.terrain` before the envs (`init_terrain`), the scene's height field (`add_terrain`),
    each env's tile and its level curriculum (`init_levels`, `next_origins`), the heights under
    the base (`terrain_heights`) and the `terrain_level` metric. The task keeps `levels` in its
    `checkpointed`."""

    def init_terrain(self, env: dict) -> None:
        """Before `VecTask.__init__` (which builds the scene): the grid."""
        terrain = env["terrain"]
        known = TERRAIN_KEYS + TERRAIN_OPTIONAL_KEYS + TERRAIN_TASK_KEYS
        unknown = sorted(set(terrain) - set(known))
        if unknown:     # a task file's typo would otherwise leave that setting at its default
            raise ValueError(f"env.terrain: unknown keys {unknown}; the keys it reads: "
                             f"{', '.join(sorted(known))}")
        keys = TERRAIN_KEYS + tuple(k for k in TERRAIN_OPTIONAL_KEYS if k in terrain)
        self.terrain_config = TerrainConfig(**{
            k: (tuple(terrain[k]) if isinstance(TerrainConfig.__dataclass_fields__[k].default,
                                                tuple) else terrain[k]) for k in keys})
        self.terrain = generate_terrain(self.terrain_config, seed=int(terrain["seed"]))

    def add_terrain(self, scene, env: dict):
        """`scene` with the grid as its shared height field (geom "terrain"), or with
        `env.terrain.mesh` as the triangle mesh the original gives PhysX (its steps' vertices
        moved under their tops: vertical walls), collided as its triangles (slower; the
        height field's risers give the same walls)."""
        t, c = self.terrain, self.terrain_config
        if env["terrain"].get("mesh", False):
            vertices, triangles = heightfield_to_mesh(t.raw, c.horizontal_scale,
                                                      c.vertical_scale,
                                                      env["terrain"]["slopeThreshold"])
            vertices[:, :2] -= c.border
            return scene.add_triangle_mesh(vertices, triangles,
                                           friction=env["terrain"]["staticFriction"])
        return scene.add_terrain(
            t.heights, c.horizontal_scale, origin=(-c.border, -c.border),
            friction=env["terrain"]["staticFriction"],
            riser=env["terrain"]["slopeThreshold"] * c.horizontal_scale)

    def init_levels(self, env: dict) -> None:
        """After `VecTask.__init__`: the heights and tiles on the device, every env on level 0,
        the kinds of tile spread evenly over the envs (as the original assigns them)."""
        dev, N = self.device, self.num_envs
        self.heights = torch.as_tensor(self.terrain.heights, device=dev)
        self.tile_origins = torch.as_tensor(self.terrain.origins, dtype=torch.float32, device=dev)
        self.height_points = height_points(dev)
        self.curriculum = bool(env["terrain"]["curriculum"])
        self.levels = torch.zeros(N, dtype=torch.long, device=dev)
        self.kinds = torch.div(torch.arange(N, device=dev) * self.terrain_config.types, N,
                               rounding_mode="floor")
        self.env_origins = self.tile_origins[self.levels, self.kinds]
        self.move_levels = False      # the curriculum moves robots whose episodes end in step

    def reset(self, env_ids=None) -> dict:
        """Every env to a fresh episode on the level it holds: the curriculum moves a robot only
        when its episode ends in a step, not at the trainer's first reset or a resumed run's."""
        self.move_levels = False
        obs = super().reset(env_ids)
        self.move_levels = self.curriculum
        return obs

    def spread_levels(self) -> None:
        """Every level on every kind of tile: the envs of each kind (a contiguous block) take
        levels (rank in the block + the block's index) mod levels, so a level sees many kinds
        even with few envs per kind, and with `levels` × `types` envs (or a multiple) each tile
        gets one."""
        first = torch.searchsorted(self.kinds, self.kinds, right=False)   # kinds are sorted
        rank = torch.arange(self.num_envs, device=self.device) - first
        block = torch.unique_consecutive(self.kinds, return_inverse=True)[1]
        self.levels[:] = (rank + block) % self.terrain_config.levels
        self.env_origins[:] = self.tile_origins[self.levels, self.kinds]

    def load_training_state(self, state: dict) -> None:
        super().load_training_state(state)
        self.env_origins[:] = self.tile_origins[self.levels, self.kinds]

    def metrics(self) -> dict[str, float]:
        return {"terrain_level": float(self.levels.float().mean())}

    def next_origins(self, done: torch.Tensor, command_speed: torch.Tensor) -> None:
        """At a reset of the envs `done` [N]: the curriculum's verdict on each finished episode
        by how far its base walked from its origin against `command_speed` [N] over the episode,
        kept as `episode_outcomes` `level_up` (it left its tile) and `level_down` (it walked less
        than a quarter of its command), and the move it makes (if on)."""
        walked = torch.norm(self.envs.root_states[:, 0, :2] - self.env_origins[:, :2], dim=-1)
        args = (walked, command_speed, self.cfg["env"]["episodeLength_s"], self.terrain_config)
        self.episode_outcomes["level_up"], self.episode_outcomes["level_down"] = \
            level_verdicts(*args)
        if not self.move_levels:
            return
        self.levels[:] = torch.where(done, next_levels(self.levels, *args), self.levels)
        self.env_origins[:] = self.tile_origins[self.levels, self.kinds]

    def start_root_states(self, height: float, xy_noise: float) -> torch.Tensor:
        """[N, 13] root states at rest over each env's origin: `height` above it, x and y each
        ± `xy_noise`, upright."""
        n, dev = self.num_envs, self.device
        root = torch.zeros(n, 13, device=dev)
        root[:, :3] = self.env_origins
        root[:, 2] += height
        root[:, :2] += torch.empty(n, 2, device=dev).uniform_(-xy_noise, xy_noise)
        root[:, 6] = 1.0
        return root

    def terrain_heights(self, base_state: torch.Tensor) -> torch.Tensor:
        """Terrain height [N, 140] under the sample points around each base (turned by yaw)."""
        quat = base_state[:, 3:7]
        yaw_only = torch.zeros_like(quat)
        yaw_only[:, 2:4] = quat[:, 2:4]
        yaw_only = yaw_only / yaw_only.norm(dim=-1, keepdim=True).clamp_min(1e-9)
        points = quat_rotate(yaw_only[:, None].expand(-1, len(self.height_points), 4),
                             self.height_points.expand(self.num_envs, -1, 3))
        return sample_heights(self.heights, points[..., :2] + base_state[:, None, :2],
                              self.terrain_config)
