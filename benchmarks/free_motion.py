"""Env-steps/s of the free-motion step (smooth dynamics, no contacts), Myriad vs MuJoCo's C step.

One env step = Isaac Gym's timing for Ant/Humanoid: dt 1/60 s in 2 substeps. Every env gets its
own random generalized forces. MuJoCo steps the same model with constraints disabled and the
Euler integrator (the computation our engine does), one MjData at a time on one thread: its
env-steps/s does not depend on the env count, so it is measured once per model.

    python benchmarks/free_motion.py                       # ant and humanoid, CPU
    python benchmarks/free_motion.py --device cuda:0 --envs 1024 4096 16384
    python benchmarks/free_motion.py --compile-time        # first-run kernel compile, empty cache
"""

from __future__ import annotations

import argparse
import os
import platform
import subprocess
import sys
import tempfile
import time

import mujoco
import numpy as np
import torch
import warp as wp

import myriad


def myriad_rate(model, num_envs: int, device: str, min_seconds: float) -> float:
    sim = myriad.Simulator(model, num_envs=num_envs, device=device,
                           params=myriad.SimParams(dt=1 / 60, substeps=2, gravity=(0, 0, 0),
                                                   constraints=False))
    gen = torch.Generator(device=sim.torch_device).manual_seed(0)
    sim.joint_force = 0.1 * torch.randn(num_envs, model.nv, generator=gen, device=sim.torch_device)
    sync = torch.cuda.synchronize if sim.device.is_cuda else (lambda: None)
    q0, qd0 = sim.q.clone(), sim.qd.clone()
    for _ in range(3):  # warm-up: kernel loading, CUDA graph capture
        sim.step()
    sync()
    steps, start = 0, time.perf_counter()
    while True:
        # 1 s episodes: with no joint limits yet, steady forces would spin joints up forever
        sim.q, sim.qd = q0, qd0
        for _ in range(60):
            sim.step()
        steps += 60
        sync()
        elapsed = time.perf_counter() - start
        if elapsed >= min_seconds:
            break
    assert torch.isfinite(sim.q).all(), "benchmark state went non-finite"
    return steps * num_envs / elapsed


def mujoco_rate(model, min_seconds: float) -> float:
    mj = model.mj_model
    mj.opt.timestep = 1 / 120
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    mj.opt.gravity[:] = 0
    d = mujoco.MjData(mj)
    d.qfrc_applied[:] = 0.1 * np.random.default_rng(0).normal(size=mj.nv)
    steps, start = 0, time.perf_counter()
    while True:
        d.qpos[:], d.qvel[:] = mj.qpos0, 0  # 1 s episodes, as above
        for _ in range(60):
            mujoco.mj_step(mj, d, nstep=2)
        steps += 60
        elapsed = time.perf_counter() - start
        if elapsed >= min_seconds:
            return steps / elapsed


def memory_per_env(model, device: str) -> float:
    """Bytes of device memory per env: all simulator arrays at 2 envs minus 1 env."""
    def total(n):
        sim = myriad.Simulator(model, num_envs=n, device=device)
        return sim.nbytes
    return total(2) - total(1)


def compile_time(device: str) -> float:
    """Seconds to build a simulator and take a first step with an empty kernel cache."""
    with tempfile.TemporaryDirectory() as cache:
        code = ("import time, warp as wp; wp.config.log_level = wp.LOG_WARNING; "
                f"wp.config.kernel_cache_dir = {cache!r}; t = time.perf_counter(); import myriad; "
                "m = myriad.load(myriad.asset_path('ant.xml')); "
                f"s = myriad.Simulator(m, num_envs=1, device={device!r}); s.step(); "
                "s.body_jacobians(); s.site_jacobians(); print(time.perf_counter() - t)")
        out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
        return float(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--models", nargs="+", default=["ant", "humanoid"])
    parser.add_argument("--envs", nargs="+", type=int, default=[1, 16, 64, 256, 1024, 4096])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--seconds", type=float, default=2.0, help="minimum timing per point")
    parser.add_argument("--compile-time", action="store_true")
    args = parser.parse_args()
    wp.config.log_level = wp.LOG_WARNING

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, {platform.processor() or 'cpu'}; "
          f"warp {wp.__version__}, mujoco {mujoco.__version__}, torch {torch.__version__}; "
          f"device {args.device}")
    if args.compile_time:
        print(f"first-run kernel compile + first step (empty cache): {compile_time(args.device):.1f} s")
        return
    header = "| model | envs | Myriad env-steps/s | MuJoCo C env-steps/s (1 thread) | ratio |"
    print(header)
    print("|" + "---|" * 5)
    for name in args.models:
        model = myriad.load(myriad.asset_path(f"{name}.xml"))
        reference = mujoco_rate(model, args.seconds)
        for n in args.envs:
            rate = myriad_rate(model, n, args.device, args.seconds)
            print(f"| {name} (nv={model.nv}) | {n} | {rate:,.0f} | {reference:,.0f} | "
                  f"{rate / reference:.2f} |", flush=True)
        print(f"| {name} | memory | {memory_per_env(model, args.device):,.0f} bytes/env | | |")


if __name__ == "__main__":
    main()
