"""Physics speed of the Shadow Hand task's step against MuJoCo C stepping the same hand and cube.

    python benchmarks/hand_speed.py [--envs 1024] [--rounds 20]

Issue 13's target: at 1024 envs, Myriad's physics step on one CPU thread at least as fast per
core as MuJoCo C (one thread, its own solver). The model is the task's own composed scene
(`myriad.make("ShadowHand")`: OpenAI's hand, the 5 cm cube, the ground), at the task's settings
(dt 1/60 s in 2 substeps, TGS 8 position / 0 velocity iterations, contact offset 2 mm). Both
engines start from the task's reset state of env 0, get fresh random targets in the actuators'
control ranges every step, and take turns in rounds (one step of all envs for Myriad, as many
env-steps for MuJoCo, two 1/120 s mj_step each), so that a shared machine's drift falls on both.
Printed: env-steps/s of each and the ratio.
"""

from __future__ import annotations

import argparse
import copy
import time

import mujoco
import numpy as np
import torch
import warp as wp

import myriad


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--rounds", type=int, default=20)
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING

    task = myriad.make("ShadowHand", num_envs=1)
    task.reset()
    model, params = task.envs.model, task.sim_params
    start_q = task.envs.sim.q[0].clone()
    sim = myriad.Simulator(model, num_envs=args.envs, params=params, cpu_threads=1)
    sim.q = start_q.expand(args.envs, -1).contiguous()
    sim.forward()
    lo, hi = (torch.as_tensor(model.actuator_ctrlrange[:, k]) for k in (0, 1))
    gen = torch.Generator().manual_seed(0)

    mj = copy.deepcopy(model.mj_model)
    mj.opt.timestep = params.dt / params.substeps
    d = mujoco.MjData(mj)
    d.qpos[:] = model.qpos_to_mujoco(start_q.numpy().astype(np.float64))
    mujoco.mj_forward(mj, d)

    def targets(n):
        return lo + (hi - lo) * torch.rand(n, model.nu, generator=gen)

    ours = theirs = 0.0
    for r in range(args.rounds + 2):          # the first two rounds warm up (kernel loads)
        ctrl = targets(args.envs)
        t0 = time.perf_counter()
        sim.ctrl = ctrl
        sim.step()
        t1 = time.perf_counter()
        for k in range(args.envs):
            d.ctrl[:] = ctrl[k].numpy()
            mujoco.mj_step(mj, d, nstep=params.substeps)
        t2 = time.perf_counter()
        if r >= 2:
            ours += t1 - t0
            theirs += t2 - t1
    steps = args.rounds * args.envs
    finite = bool(torch.isfinite(sim.q).all())
    print(f"Shadow Hand and cube, {args.envs} envs, one thread each, {args.rounds} rounds")
    print(f"| engine | env-steps/s |\n|---|---|\n| Myriad | {steps / ours:,.0f} |\n"
          f"| MuJoCo C | {steps / theirs:,.0f} |\nratio Myriad / MuJoCo C: "
          f"{theirs / ours:.2f} (Myriad finite: {finite}; contacts per env: most "
          f"{int(sim.contact_count.max())} of {sim.contact_capacity})")


if __name__ == "__main__":
    main()
