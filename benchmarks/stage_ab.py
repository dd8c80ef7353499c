"""Time per stage of an older git revision's `Simulator.step` and this tree's, side by side in one
process: the before/after of an engine change, stage by stage.

    python benchmarks/stage_ab.py --old 9902fe4 [--models ant humanoid] [--envs 1024]
                                  [--rounds 40] [--device cpu|cuda:0]

Both trees' simulators (the old one imported as `myriad_old`, as in `task_step_ab.py`) step the
same model with the same fresh random controls, taking turns every step (which goes first
alternates), each step timed stage by stage (`Simulator.step(timings=...)`: the device
synchronized after each stage; on CUDA no graph). The old revision must have that seam
(9902fe4 or later). Isaac Gym timing (dt 1/60 s in 2 substeps, TGS 4/0, contacts on), one CPU
thread, after 30 steps of settling. Prints the median ms per step of each stage for both trees
and their ratio; a drifting machine falls on both alike, and the median keeps a stray slow step
out.
"""

from __future__ import annotations

import argparse
import collections
import statistics

import torch
import warp as wp

import myriad
from task_step_ab import import_old


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="git revision to compare against")
    ap.add_argument("--models", nargs="+", default=["ant", "humanoid"],
                    choices=["ant", "humanoid"])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--rounds", type=int, default=40, help="timed steps of each tree")
    ap.add_argument("--device", default="cpu")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    old = import_old(args.old)
    for name in args.models:
        sims = []
        for package in (old, myriad):
            params = package.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                                       velocity_iterations=0)
            model = package.load(package.asset_path(f"{name}.xml"))
            sims.append(package.Simulator(model, num_envs=args.envs, device=args.device,
                                          params=params, cpu_threads=1))
        gen = torch.Generator(device=sims[1].torch_device).manual_seed(0)
        nu = sims[1].model.nu

        def controls():
            return torch.rand(args.envs, nu, generator=gen, device=sims[1].torch_device) * 2 - 1
        for _ in range(30):
            ctrl = controls()
            for sim in sims:
                sim.ctrl = ctrl
                sim.step()
        spent = [collections.defaultdict(list) for _ in sims]
        for r in range(args.rounds):
            ctrl = controls()
            for k in ((0, 1) if r % 2 else (1, 0)):
                sims[k].ctrl = ctrl
                timings = {}
                sims[k].step(timings=timings)
                for stage, seconds in timings.items():
                    spent[k][stage].append(seconds)
                spent[k]["total"].append(sum(timings.values()))
        print(f"\n{name}, {args.envs} envs, {args.device}: median ms per step over "
              f"{args.rounds} steps each\n")
        print(f"| stage | {args.old} | this tree | this / old |")
        print("|---|---|---|---|")
        for stage in spent[1]:
            before, after = (statistics.median(s[stage]) * 1e3 for s in spent)
            label = f"**{stage}**" if stage == "total" else stage.replace("_", " ")
            print(f"| {label} | {before:.3f} | {after:.3f} | {after / before:.3f} |")


if __name__ == "__main__":
    main()
