"""How well a trained ANYmal or G1 policy tracks its velocity commands.

    python benchmarks/anymal_tracking.py runs/bench_cpu_anymal/nn/last.pth [--envs 256 --seconds 10]
    python benchmarks/anymal_tracking.py runs/terrain/nn/last.pth --task AnymalTerrain \
        --tiles rough --level 4
    python benchmarks/anymal_tracking.py runs/G1Velocity/nn/last.pth --task G1Velocity --seconds 20
    python benchmarks/anymal_tracking.py runs/G1Rough/nn/last.pth --task G1Rough --seconds 20 \
        --tiles stairs-up --level 3
    python benchmarks/anymal_tracking.py src/myriad/policies/G1Velocity.pth --task G1Velocity \
        --sweep --envs 100 --seconds 10

For AnymalTerrain and G1Rough, `--tiles` puts every env on tiles of one kind (flat: the
smooth slope's level 0, which is level ground; rough, stairs-up, stairs-down, obstacles, slope:
that kind at `--level`), the envs spread over the kind's columns, with the curriculum off.

Runs the deterministic policy in fresh episodes (commands drawn as in training) and reports the
mean absolute error between commanded and actual base velocity in the base frame (forward,
lateral, yaw rate) over the last half of the window, next to what standing still would score,
and the share of episodes (those running at the start and those begun since) that ended in a fall.
"""

import argparse

import torch
import yaml

import myriad
from myriad.rl.evaluate import command_tracking
from myriad.rl.policy import load_policy
from myriad.rl.run import compose, task_and_train_configs


TERRAIN_TASKS = ("AnymalTerrain", "G1Rough")     # on the terrain grid: --tiles, --level
# --tiles: (KINDS index, pits / stairs inverted or not)
TILES = {"flat": (0, False), "slope": (0, False), "rough": (1, None), "stairs-up": (3, None),
         "stairs-down": (2, None), "obstacles": (4, None)}


def put_on_tiles(task, kind: int, inverted, level: int) -> None:
    """Every env on a tile of `kind` at `level` (the kind's columns in turn)."""
    from myriad.tasks.terrain import column_kind

    columns = [j for j in range(task.terrain_config.types)
               if column_kind(j, task.terrain_config)[0] == kind
               and inverted in (None, column_kind(j, task.terrain_config)[1])]
    n = task.num_envs
    task.kinds[:] = torch.tensor(columns)[torch.arange(n) % len(columns)]
    task.levels[:] = level
    task.env_origins[:] = task.tile_origins[task.levels, task.kinds]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--envs", type=int, default=256)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--task", default="Anymal",
                    choices=["Anymal", *TERRAIN_TASKS, "G1Velocity"])
    ap.add_argument("--tiles", default="flat", choices=list(TILES))
    ap.add_argument("--level", type=int, default=0, help="terrain tasks: difficulty row 0-9")
    ap.add_argument("--sweep", action="store_true", help="hold each env at one command of a "
                    "grid of forward speeds and yaw rates: the response to each")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a task setting, as myriad.make takes it (e.g. "
                    "sim.physx.limit_block_contacts=16: the physics the policy trained with)")
    args = ap.parse_args()
    settings = {}
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--set {item}: expected KEY=VALUE")
        settings[key] = yaml.safe_load(value)

    torch.manual_seed(0)
    _, train_cfg, _ = task_and_train_configs(compose([f"task={args.task}", "device=cpu"]))
    if args.task not in TERRAIN_TASKS:
        task = myriad.make(args.task, num_envs=args.envs, **settings)
    else:
        task = myriad.make(args.task, num_envs=args.envs,
                           **{"env.terrain.curriculum": False, **settings})
        put_on_tiles(task, *TILES[args.tiles], 0 if args.tiles == "flat" else args.level)
    policy = load_policy(args.checkpoint, train_cfg, task)
    obs = task.reset()["obs"]

    def advance():
        nonlocal obs
        out, _, resets, extras = task.step(policy(obs))
        obs = out["obs"]
        return resets, extras["time_outs"]

    if args.sweep:
        return sweep(task, advance, args.seconds)
    print(f"{args.envs} envs, {args.seconds:g} s, last half: "
          + command_tracking(task, advance, args.seconds)
          + (f"; tiles {args.tiles}, level {args.level}" if args.task in TERRAIN_TASKS
             else ""))


def sweep(task, advance, seconds: float) -> None:
    """Each env held at one command of a grid (forward 0 and 0.5 m/s × yaw -1 ... 1 rad/s,
    no lateral), no pushes: the mean velocity each command gets over the last half, and the
    turning gain (the least-squares slope of the yaw rate on the commanded one)."""
    from myriad.rl.evaluate import base_velocity

    yaws = torch.tensor([-1.0, -0.5, 0.0, 0.5, 1.0], device=task.device)
    grid = torch.cartesian_prod(torch.tensor([0.0, 0.5], device=task.device), yaws)
    cell = torch.arange(task.num_envs, device=task.device) % len(grid)
    commands = torch.stack((grid[cell, 0], torch.zeros_like(cell, dtype=torch.float),
                            grid[cell, 1]), dim=-1)
    task.draw_commands = lambda: commands.clone()       # every resample keeps the grid
    task.commands[:] = commands
    if hasattr(task, "push_every"):
        task.push_every = 10 ** 9
    steps = round(seconds / task.dt)
    counted = steps - steps // 2
    mean = torch.zeros_like(commands)
    square = torch.zeros_like(commands)         # of the velocity, for its swing about the mean
    error = torch.zeros_like(commands)          # |command - velocity|, step by step
    for step in range(steps):
        with torch.no_grad():
            advance()
        if step >= steps // 2:
            v = base_velocity(task)
            mean += v / counted
            square += v * v / counted
            error += (commands - v).abs() / counted
    print(f"{task.num_envs} envs, {seconds:g} s, no pushes, mean velocity over the last half "
          "(forward m/s, lateral m/s, yaw rad/s) per command:")
    for k, (vx, yaw) in enumerate(grid.tolist()):
        v = mean[cell == k].mean(0).tolist()
        print(f"  command forward {vx:.1f}, yaw {yaw:+.1f}: {v[0]:+.3f} {v[1]:+.3f} {v[2]:+.3f}")
    c, y = commands[:, 2], mean[:, 2]
    gain = float(((c - c.mean()) * (y - y.mean())).sum() / ((c - c.mean()) ** 2).sum())
    print(f"turning gain (yaw rate per commanded yaw rate): {gain:.2f}")
    # the yaw error step by step, against its two parts: the mean rate's miss (what the gain
    # and a bias leave) and the rate's swing about its mean within the window (the stride's)
    swing = (square[:, 2] - mean[:, 2] ** 2).clamp(min=0).sqrt()
    print(f"yaw error |command - rate| over all steps {error[:, 2].mean():.3f} rad/s: the mean "
          f"rate's miss {(mean[:, 2] - c).abs().mean():.3f}, the rate's swing about its mean "
          f"(standard deviation) {swing.mean():.3f}")


if __name__ == "__main__":
    main()
