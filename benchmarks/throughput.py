"""Throughput and memory of the simulator and of every task, on one device (GPU or CPU).

    python benchmarks/throughput.py --device cuda:0                    # the whole table
    python benchmarks/throughput.py --device cuda:0 --only physics --physics-envs 8192

Three measurements, each printed as a Markdown table:
  physics  `Simulator.step` of the ant and the humanoid (Isaac Gym timing: dt 1/60 s in 2
           substeps, TGS 4/0, contacts on), fresh uniform random controls written from torch
           before every step. Reported as env-steps/s and as physics steps/s, which counts each
           substep once: the unit of MuJoCo Warp's and MJX's published figures, whose one step
           is one integrator step of one world.
  task     each task's whole `VecTask.step` (actions -> physics -> observations, rewards,
           resets in torch) under random actions, no policy: the rollout side of training;
           on CUDA also with the whole step captured as one graph (`capture_step`).
  memory   device memory a task takes at `--memory-envs` envs after a few steps (free memory
           before minus after, so the CUDA context is left out, torch's caches included), and
           that divided by the env count. CUDA only.

Timings synchronize the device before reading the clock, after a warm-up that compiles the
kernels and captures the CUDA graph.
"""

from __future__ import annotations

import argparse
import gc
import time

import torch
import warp as wp

import myriad
from myriad.tasks import TASKS


def sync(device: str) -> None:
    if device.startswith("cuda"):
        torch.cuda.synchronize(device)


def timed(step, device: str, min_seconds: float, warmup: int = 5) -> tuple[float, int]:
    """Seconds and count of calls of `step`, at least min_seconds of them, after a warm-up."""
    for _ in range(warmup):
        step()
    sync(device)
    calls, start = 0, time.perf_counter()
    while True:
        for _ in range(20):
            step()
        calls += 20
        sync(device)
        elapsed = time.perf_counter() - start
        if elapsed >= min_seconds:
            return elapsed, calls


def physics(device: str, envs: list[int], seconds: float) -> None:
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=0)
    print("\n| model | envs | env-steps/s | physics steps/s (substeps) | envs finite |")
    print("|---|---|---|---|---|")
    for asset in ("ant.xml", "humanoid.xml"):
        model = myriad.load(myriad.asset_path(asset))
        for n in envs:
            sim = myriad.Simulator(model, num_envs=n, device=device, params=params)
            gen = torch.Generator(device=sim.torch_device).manual_seed(0)
            ctrl = torch.empty(n, model.nu, device=sim.torch_device)

            def step():
                sim.ctrl = ctrl.uniform_(-1, 1, generator=gen)
                sim.step()
            elapsed, calls = timed(step, device, seconds)
            rate = n * calls / elapsed
            finite = int(torch.isfinite(sim.q).all(dim=1).sum())
            print(f"| {asset[:-4]} (nv={model.nv}) | {n} | {rate:,.0f} | "
                  f"{rate * params.substeps:,.0f} | {finite}/{n} |", flush=True)
            del sim
            gc.collect()


def make_task(name: str, n: int, device: str):
    try:
        return myriad.make(name, num_envs=n, device=device)
    except myriad.ModelError as err:      # ANYmal without its extra installed
        print(f"| {name} | {n} | skipped: {err} |")
        return None


def tasks(device: str, n: int, seconds: float) -> None:
    cuda = device.startswith("cuda")
    print(f"\n| task | envs | task.step env-steps/s (random actions, no policy) |"
          + (" the step captured whole (capture_step) |" if cuda else ""))
    print("|---|---|---|" + ("---|" if cuda else ""))
    for name in TASKS:
        rates = []
        for capture in ((False, True) if cuda else (False,)):
            task = make_task(name, n, device)
            if task is None:
                break
            task.capture_step = capture
            task.reset()
            actions = torch.empty(n, task.num_actions, device=task.device)
            try:
                elapsed, calls = timed(lambda: task.step(actions.uniform_(-1, 1)), device,
                                       seconds)
                rates.append(f"{n * calls / elapsed:,.0f}")
            except RuntimeError as err:     # a capture CUDA refused: say which, go on
                rates.append(f"failed: {str(err).splitlines()[0][:120]}")
            del task
            gc.collect()
        if rates:
            print(f"| {name} | {n} | " + " | ".join(rates) + " |", flush=True)


def memory(device: str, n: int) -> None:
    if not device.startswith("cuda"):
        print("\nmemory: measured on CUDA only")
        return
    print(f"\n| task | envs | device memory | per env |")
    print("|---|---|---|---|")
    for name in TASKS:
        gc.collect()
        torch.cuda.empty_cache()
        sync(device)
        free_before = torch.cuda.mem_get_info(device)[0]
        task = make_task(name, n, device)
        if task is None:
            continue
        task.reset()
        actions = torch.zeros(n, task.num_actions, device=task.device)
        for _ in range(3):
            task.step(actions)
        sync(device)
        used = free_before - torch.cuda.mem_get_info(device)[0]
        print(f"| {name} | {n} | {used / 2**30:.2f} GiB | {used / n / 1024:.1f} KiB |", flush=True)
        del task, actions
        gc.collect()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cuda:0" if torch.cuda.is_available() else "cpu")
    ap.add_argument("--only", choices=["physics", "task", "memory"], nargs="*")
    ap.add_argument("--physics-envs", type=int, nargs="+", default=[1024, 4096, 8192, 16384])
    ap.add_argument("--task-envs", type=int, default=4096)
    ap.add_argument("--memory-envs", type=int, default=16384)
    ap.add_argument("--seconds", type=float, default=3.0, help="timed seconds per row")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    only = set(args.only or ["physics", "task", "memory"])
    where = torch.cuda.get_device_name(args.device) if args.device.startswith("cuda") else "CPU"
    print(f"device {args.device} ({where}), warp {wp.__version__}, torch {torch.__version__}")
    if "physics" in only:
        physics(args.device, args.physics_envs, args.seconds)
    if "task" in only:
        tasks(args.device, args.task_envs, args.seconds)
    if "memory" in only:
        memory(args.device, args.memory_envs)


if __name__ == "__main__":
    main()
