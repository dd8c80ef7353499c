"""`Simulator.step` of an older git revision against this tree and MuJoCo C, in one process.

    python benchmarks/step_ab.py --old 11f1754 [--models ant humanoid boxes meshes] [--envs 1024]
                                 [--rounds 60]

Both trees' simulators (the old one imported as `myriad_old`, as in `task_step_ab.py`) and
MuJoCo (two 1/120 s steps per env step, its own solver) take turns in short rounds: each
round, one step of 1024 envs per tree and 1024 env-steps of MuJoCo twice, on one `MjData`
("MuJoCo C": one world's state stays in the core's caches, MuJoCo's peak per core) and on 1024
`MjData` ("MuJoCo C, n worlds": 1024 worlds each stepped once, the workload the trees run),
the first in turn changing every round. A shared machine's drifting speed then falls on all three alike, so
the ratios are comparable between runs even where the absolute rates are not. One CPU thread
each, Isaac Gym timing (dt 1/60 s in 2 substeps, TGS 4/0, contacts on), the same fresh random
controls for both trees every step, after a 60-step settle from the model's initial state.
`boxes` is 64 free boxes in one env (`contacts.py --scene boxes`), at 16 envs and 512 contact
slots per env, as in `step_rate.py`; `meshes` the same scene of convex meshes (cubes and
irregular hulls, `boxes_xml(meshes=True)`), whose pairs take the GJK/EPA path; the ant and the
humanoid take the default 64 slots.
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np
import torch
import warp as wp

import myriad
from contacts import boxes_xml
from robot_stress import sim_overrides
from task_step_ab import import_old


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="git revision to compare against")
    ap.add_argument("--models", nargs="+", default=["ant", "humanoid"],
                    choices=["ant", "humanoid", "boxes", "meshes"])
    ap.add_argument("--envs", type=int, default=1024, help="envs of the ant and the humanoid")
    ap.add_argument("--rounds", type=int, default=60)
    ap.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                    help="SimParams overrides for this tree's simulators only: the cost of a "
                         "setting, with --old the same revision")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    torch.set_num_threads(1)
    old = import_old(args.old)
    print(f"env-steps/s, one thread, {args.rounds} rounds; ratio to MuJoCo C (one MjData) "
          f"and to MuJoCo C on n MjData in brackets")
    print("| model | envs | old | new | MuJoCo C | MuJoCo C, n worlds | new / old |\n"
          "|---|---|---|---|---|---|---|")
    for name in args.models:
        n, slots = (16, 512) if name in ("boxes", "meshes") else (args.envs, 64)
        sims = {}
        for variant, package in (("old", old), ("new", myriad)):
            model = (package.load_xml(boxes_xml(meshes=name == "meshes"), f"64 {name}")
                     if name in ("boxes", "meshes")
                     else package.load(package.asset_path(f"{name}.xml")))
            extra = {} if package is old else sim_overrides(args.set)
            params = package.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                                       velocity_iterations=0, contacts_per_env=slots, **extra)
            sims[variant] = package.Simulator(model, num_envs=n, params=params, cpu_threads=1)
        mj = model.mj_model
        mj.opt.timestep = 1 / 120
        data = mujoco.MjData(mj)
        worlds = [mujoco.MjData(mj) for _ in range(n)]
        rng = np.random.default_rng(0)
        gen = torch.Generator().manual_seed(0)

        def step_mujoco(each):
            for d in each:
                if mj.nu:
                    d.ctrl[:] = rng.uniform(-1, 1, mj.nu)
                mujoco.mj_step(mj, d, nstep=2)
        spent = {"old": 0.0, "new": 0.0, "mujoco": 0.0, "mujoco_n": 0.0}
        order = list(spent)
        for i in range(60 + args.rounds):
            ctrl = torch.rand(n, mj.nu, generator=gen) * 2 - 1
            for variant in order[i % 4:] + order[:i % 4]:
                start = time.perf_counter()
                if variant == "mujoco":
                    step_mujoco([data] * n)
                elif variant == "mujoco_n":
                    step_mujoco(worlds)
                else:
                    if mj.nu:
                        sims[variant].ctrl = ctrl
                    sims[variant].step()
                if i >= 60:
                    spent[variant] += time.perf_counter() - start
        rate = {v: n * args.rounds / t for v, t in spent.items()}
        def vs(v):
            return f"{rate[v]:,.0f} ({rate[v] / rate['mujoco']:.2f}, " \
                   f"{rate[v] / rate['mujoco_n']:.2f})"
        print(f"| {name} | {n} | {vs('old')} | {vs('new')} | {rate['mujoco']:,.0f} | "
              f"{rate['mujoco_n']:,.0f} | {rate['new'] / rate['old']:.3f} |", flush=True)


if __name__ == "__main__":
    main()
