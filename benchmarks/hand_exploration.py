"""How far a fresh policy's random actions turn a hand task's cube, and how often they drop it.

    python benchmarks/hand_exploration.py [--task AllegroHand] [--envs 128] [--seconds 10]
        [--actions random|zero] [--start X Y Z]

A fresh policy's actions are N(0, 1) around a mean near 0, clipped to [-1, 1]; the task steps
with such actions, new each step, episodes ending and resetting as in training. Printed: the
cube's rotation over one second (rad; only the windows in which no episode ended, since a reset
turns the cube too), the share of those windows above 0.5 rad, and the episodes that ended
(drops, mostly). What exploration gives the learner to start from: a cube that never turns
teaches nothing about turning it, one that is always dropped nothing about holding it.
`--actions zero` holds every action at 0 instead (a hand that does nothing: mid-range
targets); `--start` lets the cube go elsewhere (the task's `objectStartPos`, m). Also printed:
the cube's median position over the run.
"""

from __future__ import annotations

import argparse

import torch
import warp as wp

import myriad
from myriad.torch_utils import angle_between


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--task", default="AllegroHand")
    ap.add_argument("--envs", type=int, default=128)
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--actions", choices=("random", "zero"), default="random")
    ap.add_argument("--start", type=float, nargs=3, metavar=("X", "Y", "Z"))
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    torch.manual_seed(args.seed)
    overrides = {"objectStartPos": args.start} if args.start else {}
    task = myriad.make(args.task, num_envs=args.envs, **overrides)
    task.reset()
    window = round(1.0 / task.dt)                     # env steps in one second
    steps = max(round(args.seconds / task.dt), window + 1)
    rotations, positions, ended = [], [], []
    for _ in range(steps):
        actions = torch.randn(args.envs, task.num_actions, device=task.device).clamp(-1.0, 1.0)
        if args.actions == "zero":
            actions.zero_()         # drawn all the same: the seed's stream stays the random run's
        done = task.step(actions)[2]
        ended.append(done.bool().clone())
        rotations.append(task.envs.root_states[:, task.cube, 3:7].clone())
        positions.append(task.envs.root_states[:, task.cube, 0:3].clone())
    rotations, ended = torch.stack(rotations), torch.stack(ended)     # [steps, N, 4], [steps, N]
    ends_so_far = torch.cumsum(ended.int(), dim=0)
    clean = (ends_so_far[window:] - ends_so_far[:-window]) == 0
    turn = angle_between(rotations[window:], rotations[:-window])[clean]
    what = "random actions N(0, 1) clipped" if args.actions == "random" else "zero actions"
    print(f"{args.task}, {args.envs} envs x {steps} env steps ({steps * task.dt:.1f} s), "
          f"{what}, cube let go at {tuple(task.cube_start)}, seed {args.seed}")
    print(f"cube rotation over 1 s ({int(clean.sum())} windows without a reset): mean "
          f"{turn.mean():.3f} rad, median {turn.median():.3f}, above 0.5 rad "
          f"{(turn > 0.5).float().mean():.3f}; episodes ended: {int(ended.sum())}; cube's median "
          f"position {[round(v, 3) for v in torch.stack(positions).flatten(0, 1).median(0).values.tolist()]}")


if __name__ == "__main__":
    main()
