"""`Simulator.step` on one CPU thread against MuJoCo C on one thread, per scene, in one run.

    python benchmarks/step_rate.py                  # this checkout's engine
    PYTHONPATH=/path/to/other/src python benchmarks/step_rate.py    # another version, same scenes

Isaac Gym timing (dt 1/60 s in 2 substeps, TGS 4/0, contacts on); fresh random controls every
step; MuJoCo steps the same compiled model twice per env step at 1/120 s with its own solver.
Scenes: the ant and the humanoid at 1024 envs (issue 11's targets), 64 free boxes in one env
(16 envs, 512 contact slots). Prints a Markdown row per scene.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import torch
import warp as wp

import myriad
from contacts import boxes_xml


def myriad_rate(model, envs: int, slots: int, seconds: float = 3.0) -> float:
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                              velocity_iterations=0, contacts_per_env=slots)
    sim = myriad.Simulator(model, num_envs=envs, params=params, cpu_threads=1)
    gen = torch.Generator().manual_seed(0)
    for _ in range(20):                  # settle onto the floor, compile on a first run
        sim.step()
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        if model.nu:
            sim.ctrl = torch.rand(envs, model.nu, generator=gen) * 2 - 1
        sim.step()
        steps += 1
    rate = steps * envs / (time.perf_counter() - start)
    assert torch.isfinite(sim.q).all()
    return rate


def mujoco_rate(model, seconds: float = 3.0) -> float:
    mj = model.mj_model
    mj.opt.timestep = 1 / 120
    d = mujoco.MjData(mj)
    rng = np.random.default_rng(0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        if mj.nu:
            d.ctrl[:] = rng.uniform(-1, 1, mj.nu)
        mujoco.mj_step(mj, d, nstep=2)
        steps += 1
    return steps / (time.perf_counter() - start)


def main() -> None:
    wp.config.log_level = wp.LOG_WARNING
    torch.set_num_threads(1)
    scenes = [("ant", myriad.load(myriad.asset_path("ant.xml")), 1024, 64),
              ("humanoid", myriad.load(myriad.asset_path("humanoid.xml")), 1024, 64),
              ("64 boxes", myriad.load_xml(boxes_xml(), "64 boxes"), 16, 512)]
    print(f"engine: {myriad.__file__}")
    print("| scene | envs | Myriad env-steps/s (1 thread) | MuJoCo C env-steps/s (1 thread) | ratio |")
    print("|---|---|---|---|---|")
    for name, model, envs, slots in scenes:
        ours, theirs = myriad_rate(model, envs, slots), mujoco_rate(model)
        print(f"| {name} | {envs} | {ours:,.0f} | {theirs:,.0f} | {ours / theirs:.2f} |", flush=True)


if __name__ == "__main__":
    main()
