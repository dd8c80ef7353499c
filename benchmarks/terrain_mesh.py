"""AnymalTerrain on its two surfaces, side by side in one process: the height field with risers
(Myriad's default) and the triangle mesh the original gives PhysX (`env.terrain.mesh`,
collided as its triangles through a BVH).

    python benchmarks/terrain_mesh.py --envs 512 --rounds 6 --steps 20
    python benchmarks/terrain_mesh.py --envs 4096 --device cuda:0

Prints, per surface: the time to build the task (the mesh's MuJoCo compile and its BVH
included), the triangles, and the task's env-steps/s over interleaved rounds of random actions
(the same half-scale actions for both, the same start states; each surface goes first in turn,
so drift of a shared machine falls on both alike); then the ratio mesh / height field. Robots
start spread over every tile of the full 10 × 20 grid (4.8 M triangles), the curriculum off.
"""

from __future__ import annotations

import argparse
import time

import torch

import myriad
from myriad.physics.types import GeomType

SURFACES = {"height field": {}, "mesh": {"env.terrain.mesh": True}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", type=int, default=512)
    parser.add_argument("--rounds", type=int, default=6)
    parser.add_argument("--steps", type=int, default=20, help="task steps per round")
    parser.add_argument("--device", default="cpu")
    args = parser.parse_args()

    tasks, built = {}, {}
    for name, overrides in SURFACES.items():
        torch.manual_seed(0)          # the same start states on both surfaces
        start = time.perf_counter()
        task = myriad.make("AnymalTerrain", num_envs=args.envs, device=args.device,
                           **{"env.terrain.curriculum": False, **overrides})
        built[name] = time.perf_counter() - start
        # every tile in use: levels and kinds spread over the envs
        n, cfg = task.num_envs, task.terrain_config
        task.levels[:] = torch.arange(n, device=task.device) % cfg.levels
        task.env_origins[:] = task.tile_origins[task.levels, task.kinds]
        task.reset()
        tasks[name] = task
        model = task.envs.model
        terrain = model.geom_dataid[model.geom_type == GeomType.TRIMESH]
        triangles = int(model.mesh_facenum[terrain].sum())
        print(f"{name:>12}: built in {built[name]:6.1f} s, {triangles:,} triangles",
              flush=True)

    generator = torch.Generator(device=args.device).manual_seed(0)
    # half-scale random targets: robots stumble about, as early in training, without most
    # of them lying on the ground (which would make the count of contacts, not the surface,
    # set the pace)
    actions = [(torch.rand(args.envs, 12, generator=generator, device=args.device) * 2 - 1) * 0.5
               for _ in range(args.steps)]
    seconds = {name: 0.0 for name in tasks}
    names = list(tasks)
    for r in range(args.rounds):
        for name in names[r % 2:] + names[:r % 2]:
            task = tasks[name]
            if args.device != "cpu":
                torch.cuda.synchronize()
            start = time.perf_counter()
            for a in actions:
                task.step(a)
            if args.device != "cpu":
                torch.cuda.synchronize()
            seconds[name] += time.perf_counter() - start
        print(f"round {r + 1}/{args.rounds}: " + ", ".join(
            f"{name} {args.envs * args.steps * (r + 1) / seconds[name]:,.0f}" for name in names),
            flush=True)
    rate = {name: args.envs * args.steps * args.rounds / seconds[name] for name in names}
    for name in names:
        contacts = tasks[name].envs.sim.contact_count.float().mean()
        print(f"{name:>12}: {rate[name]:,.0f} env-steps/s ({float(contacts):.1f} contacts per "
              f"env at the end)")
    print(f"mesh / height field: {rate['mesh'] / rate['height field']:.3f}")


if __name__ == "__main__":
    main()
