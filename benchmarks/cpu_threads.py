"""Env-steps/s of the CPU simulator with one thread against one thread per core.

    python benchmarks/cpu_threads.py [--envs 1024] [--steps 100]

For the ant and the humanoid at Isaac Gym's timing (dt 1/60 s in 2 substeps, TGS 4/0) under
random actions: `Simulator.step` alone, then the Ant task's whole `step` (observations, rewards,
resets in torch), with torch using its default threads and with one torch thread.
"""

import argparse
import time

import torch
import warp as wp

import myriad


def rate(step, envs, steps):
    for _ in range(10):
        step()
    start = time.perf_counter()
    for _ in range(steps):
        step()
    return envs * steps / (time.perf_counter() - start)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=100)
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    n = args.envs
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=0)
    for asset in ("ant.xml", "humanoid.xml"):
        model = myriad.load(myriad.asset_path(asset))
        for threads in (1, None):
            sim = myriad.Simulator(model, n, params=params, cpu_threads=threads)

            def step():
                sim.ctrl = torch.rand(n, model.nu) * 2 - 1
                sim.step()
            print(f"{asset:13s} Simulator.step, {len(sim.runtime.shards) or 1} thread(s): "
                  f"{rate(step, n, args.steps):9,.0f} env-steps/s")
    task = myriad.make("Ant", num_envs=n)
    sim = task.envs.sim
    shards = sim.runtime.shards

    def task_step():
        task.step(torch.rand(n, 8) * 2 - 1)
    for label, physics_shards, torch_threads in (("1 physics thread", [], None),
                                                 ("physics threads", shards, None),
                                                 ("physics threads, 1 torch thread", shards, 1)):
        sim.runtime.shards = physics_shards
        default_threads = torch.get_num_threads()
        if torch_threads:
            torch.set_num_threads(torch_threads)
        print(f"Ant task.step, {label}: {rate(task_step, n, args.steps):9,.0f} env-steps/s")
        torch.set_num_threads(default_threads)


if __name__ == "__main__":
    main()
