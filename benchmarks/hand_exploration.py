"""How far a fresh policy's random actions turn a hand task's cube, and how often they drop it.

    python benchmarks/hand_exploration.py [--task AllegroHand] [--envs 128] [--seconds 10]

A fresh policy's actions are N(0, 1) around a mean near 0, clipped to [-1, 1]; the task steps
with such actions, new each step, episodes ending and resetting as in training. Printed: the
cube's rotation over one second (rad; only the windows in which no episode ended, since a reset
turns the cube too), the share of those windows above 0.5 rad, and the episodes that ended
(drops, mostly). What exploration gives the learner to start from: a cube that never turns
teaches nothing about turning it, one that is always dropped nothing about holding it.
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
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    torch.manual_seed(args.seed)
    task = myriad.make(args.task, num_envs=args.envs)
    task.reset()
    window = round(1.0 / task.dt)                     # env steps in one second
    steps = max(round(args.seconds / task.dt), window + 1)
    rotations, ended = [], []
    for _ in range(steps):
        actions = torch.randn(args.envs, task.num_actions, device=task.device).clamp(-1.0, 1.0)
        done = task.step(actions)[2]
        ended.append(done.bool().clone())
        rotations.append(task.envs.root_states[:, task.cube, 3:7].clone())
    rotations, ended = torch.stack(rotations), torch.stack(ended)     # [steps, N, 4], [steps, N]
    ends_so_far = torch.cumsum(ended.int(), dim=0)
    clean = (ends_so_far[window:] - ends_so_far[:-window]) == 0
    turn = angle_between(rotations[window:], rotations[:-window])[clean]
    print(f"{args.task}, {args.envs} envs x {steps} env steps ({steps * task.dt:.1f} s), "
          f"random actions N(0, 1) clipped, seed {args.seed}")
    print(f"cube rotation over 1 s ({int(clean.sum())} windows without a reset): mean "
          f"{turn.mean():.3f} rad, median {turn.median():.3f}, above 0.5 rad "
          f"{(turn > 0.5).float().mean():.3f}; episodes ended: {int(ended.sum())}")


if __name__ == "__main__":
    main()
