"""Random targets on the hand tasks: does every env stay finite, and does a squeezed cube ever fly?

    python benchmarks/hand_random.py [--task ShadowHand] [--envs 64] [--steps 10000]

Issue 13's physics check at full length (tests/test_hands.py runs 16 envs for 600 steps): the
task steps with uniformly random actions in [-1, 1] (new each step, so the fingers slam from
limit to limit and squeeze the cube between them), episodes ending and resetting as in
training. Printed: whether every env stayed finite at every step, the fastest the cube ever
moved (m/s; the issue's bound is 5), the worst joint-limit excess (rad) and the deepest contact
(mm), and the episodes that ended.
"""

from __future__ import annotations

import argparse
import time

import torch
import warp as wp

import myriad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--task", default="ShadowHand")
    ap.add_argument("--envs", type=int, default=64)
    ap.add_argument("--steps", type=int, default=10_000)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    torch.manual_seed(args.seed)
    task = myriad.make(args.task, num_envs=args.envs)
    task.reset()
    e = task.envs
    lo, hi = task.dof_lower, task.dof_upper
    fastest = excess = 0.0
    deepest = 0.0
    nonfinite = episodes = 0
    start = time.perf_counter()
    for step in range(args.steps):
        _, _, done, _ = task.step(2 * torch.rand(args.envs, task.num_actions) - 1)
        nonfinite += int(e.sim.nonfinite.sum()) + int((~torch.isfinite(e.sim.q)).any(1).sum())
        episodes += int(done.sum())
        fastest = max(fastest, float(e.root_states[:, task.cube, 7:10].norm(dim=-1).max()))
        excess = max(excess, float(torch.maximum(e.dof_pos - hi, lo - e.dof_pos).max()))
        slots = torch.arange(e.sim.contact_capacity) < e.sim.contact_count[:, None]
        if e.sim.contact_capacity:
            deepest = min(deepest, float(torch.where(slots, e.sim.contact_dist, 0.0).min()))
        if (step + 1) % 1000 == 0:
            print(f"  {step + 1} steps, {time.perf_counter() - start:.0f} s", flush=True)
    print(f"{args.task}: {args.envs} envs x {args.steps} steps of random actions "
          f"({time.perf_counter() - start:.0f} s)")
    print(f"| all finite | fastest cube (m/s) | worst limit excess (rad) | deepest contact (mm) "
          f"| episodes ended |\n|---|---|---|---|---|\n| {'yes' if nonfinite == 0 else 'no'} | "
          f"{fastest:.2f} | {excess:.4f} | {1e3 * deepest:.2f} | {episodes} |")


if __name__ == "__main__":
    main()
