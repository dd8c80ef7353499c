"""Time per stage of one `Simulator.step`, for the ant, the humanoid and hand-and-cube models.

    python benchmarks/stage_profile.py [--envs 1024] [--steps 20] [--device cpu] [--threads 1]
        [--models ant,humanoid,hand-and-cube,shadow-hand,franka] [--iterations 4] [--settle 30]

`shadow-hand` is the ShadowHand task's composed scene (OpenAI's hand, the cube, the ground;
needs gymnasium-robotics); `franka` the FrankaCubeStack task's (needs example-robot-data). Both
tasks run `--iterations 8`.

Isaac Gym timing (dt 1/60 s in 2 substeps, TGS `--iterations`/0, contacts on), fresh random
controls before every step (as `step_rate.py`), after `--settle` steps of them. Each stage of
the step is timed on its own (`Simulator.step(timings=...)`: the device is synchronized after
each, so on CUDA this runs without the step's CUDA graph and the sum exceeds a graph-captured
step); the table gives ms per step and the share of the total.
"""

from __future__ import annotations

import argparse
import collections

import torch
import warp as wp

import myriad

STAGES = list(dict.fromkeys(myriad.Simulator.SUBSTEP_STAGES + myriad.Simulator.FINAL_STAGES))


def profile(model, n: int, steps: int, device: str, threads: int | None, iterations: int = 4,
            settle: int = 30, dt: float = 1 / 60, substeps: int = 2) -> dict:
    """ms per step of each stage (`STAGES`), over `steps` steps of `n` envs of `model`."""
    params = myriad.SimParams(dt=dt, substeps=substeps, position_iterations=iterations,
                              velocity_iterations=0)
    sim = myriad.Simulator(model, num_envs=n, device=device, params=params, cpu_threads=threads)
    gen = torch.Generator(device=sim.torch_device).manual_seed(0)

    def new_controls():
        if model.nu:
            sim.ctrl = torch.rand(n, model.nu, generator=gen, device=sim.torch_device) * 2 - 1
    for _ in range(settle):
        new_controls()
        sim.step()
    spent = collections.Counter()
    for _ in range(steps):
        new_controls()
        sim.step(timings=spent)
    return {name: spent[name] / steps * 1e3 for name in STAGES}


def main() -> None:
    from memory import hand_and_cube_xml      # benchmarks/memory.py: the 30-DoF stand-in

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--threads", type=int, default=1, help="CPU threads (default 1)")
    ap.add_argument("--iterations", type=int, default=4, help="TGS position iterations")
    ap.add_argument("--settle", type=int, default=30, help="steps before the timed ones")
    ap.add_argument("--models", default="ant,humanoid,hand-and-cube",
                    help="comma-separated subset of ant, humanoid, hand-and-cube, shadow-hand, "
                    "franka")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    models = {"ant": lambda: myriad.load(myriad.asset_path("ant.xml")),
              "humanoid": lambda: myriad.load(myriad.asset_path("humanoid.xml")),
              "hand-and-cube": lambda: myriad.load_xml(hand_and_cube_xml(), "hand-and-cube"),
              "shadow-hand": lambda: myriad.make("ShadowHand", num_envs=1).envs.model,
              "franka": lambda: myriad.make("FrankaCubeStack", num_envs=1).envs.model}
    chosen = args.models.split(",")
    if unknown := set(chosen) - set(models):
        ap.error(f"--models: unknown {sorted(unknown)}; choose from {list(models)}")
    rows = {name: profile(models[name](), args.envs, args.steps, args.device, args.threads,
                          args.iterations, args.settle)
            for name in chosen}
    print(f"ms per step ({args.envs} envs, {args.device}, {args.threads} thread(s)); share of "
          "the step in brackets\n")
    print("| stage | " + " | ".join(rows) + " |")
    print("|---|" + "---|" * len(rows))
    for stage in STAGES:
        cells = [f"{r[stage]:.2f} ({100 * r[stage] / sum(r.values()):.0f} %)" for r in rows.values()]
        print(f"| {stage.replace('_', ' ')} | " + " | ".join(cells) + " |")
    print("| **total** | " + " | ".join(f"{sum(r.values()):.2f}" for r in rows.values()) + " |")


if __name__ == "__main__":
    main()
