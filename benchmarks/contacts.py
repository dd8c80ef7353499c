"""Contact-rich stepping against MuJoCo: 64 boxes dropped in a 4x4x4 grid onto a plane per env,
and the ant on its floor under random actions (new ones every step, the same in both engines'
runs up to their different contact models).

Myriad (TGS, Isaac Gym's timing: dt 1/60 in 2 substeps, 4 position + 1 velocity iteration,
512 contact slots per env) against MuJoCo's C step on the same model (its default solver, two
1/120 s steps per env step), one MjData at a time on one thread. Both run the same 2 s of
falling, colliding and settling, from the same start. Also reports device memory per env.

    python benchmarks/contacts.py
    python benchmarks/contacts.py --scene ant --envs 1 16 256 1024
    python benchmarks/contacts.py --device cuda:0 --envs 256 1024 4096
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import mujoco
import numpy as np
import torch
import warp as wp

import myriad
from memory import memory_per_env


# convex meshes for the mesh variant of the box scene: a 16 cm cube, and an irregular hull of the
# same reach (a lopsided octahedron with its corners cut)
_CUBE = " ".join(f"{x} {y} {z}" for x in (-0.08, 0.08) for y in (-0.08, 0.08) for z in (-0.08, 0.08))
_GEM = ("0.09 0.01 0  -0.08 0 0.01  0 0.085 0  0.01 -0.075 0  0 0 0.09  0.01 0.02 -0.085  "
        "0.05 0.05 0.04  -0.05 -0.04 0.05  0.04 -0.05 -0.05  -0.05 0.04 -0.04")


def boxes_xml(n_side: int = 4, meshes: bool = False) -> str:
    """n_side^3 free boxes over a plane, each turned its own way; with `meshes`, convex meshes
    instead (cubes and irregular hulls in turn), whose pairs take the general convex path
    (GJK/EPA) instead of the box-box closed form."""
    bodies = []
    for i in range(n_side):
        for j in range(n_side):
            for k in range(n_side):
                x, y, z = (i - 1.5) * 0.25, (j - 1.5) * 0.25, 0.2 + 0.25 * k
                geom = 'type="box" size="0.08 0.08 0.08"'
                if meshes:
                    geom = f'type="mesh" mesh="{("cube", "gem")[(i + j + k) % 2]}"'
                bodies.append(f'<body pos="{x:.3f} {y:.3f} {z:.3f}" euler="{7 * i} {5 * j} {11 * k}">'
                              f'<freejoint/><geom {geom} mass="1"/></body>')
    assets = (f'<asset><mesh name="cube" vertex="{_CUBE}"/><mesh name="gem" vertex="{_GEM}"/></asset>'
              if meshes else "")
    return (f'<mujoco><compiler angle="degree"/>{assets}<worldbody><geom type="plane" size="10 10 0.1"/>'
            f'{"".join(bodies)}</worldbody></mujoco>')


PARAMS = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=1,
                          contacts_per_env=512)
STEPS = 120  # 2 s


def myriad_rate(model, num_envs: int, device: str):
    sim = myriad.Simulator(model, num_envs=num_envs, device=device, params=PARAMS)
    sync = torch.cuda.synchronize if sim.device.is_cuda else (lambda: None)
    sim.step()  # warm-up: kernel loading, graph capture
    sim.q, sim.qd = torch.as_tensor(model.qpos0), 0.0
    gen = torch.Generator(device=sim.torch_device).manual_seed(0)
    sync()
    start = time.perf_counter()
    peak = 0
    for _ in range(STEPS):
        if model.nu:
            sim.ctrl = torch.rand(num_envs, model.nu, generator=gen, device=sim.torch_device) * 2 - 1
        sim.step()
        peak = max(peak, int(sim.contact_count.max()))
    sync()
    elapsed = time.perf_counter() - start
    assert torch.isfinite(sim.q).all()
    return STEPS * num_envs / elapsed, peak


def mujoco_rate(model) -> float:
    mj = model.mj_model
    mj.opt.timestep = 1 / 120
    d = mujoco.MjData(mj)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    for _ in range(STEPS):
        if mj.nu:
            d.ctrl[:] = rng.uniform(-1, 1, mj.nu)
        mujoco.mj_step(mj, d, nstep=2)
    return STEPS / (time.perf_counter() - start)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--envs", nargs="+", type=int, default=[1, 4, 16])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--scene", choices=["boxes", "ant"], help="only this scene")
    args = parser.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    scenes = {"boxes": ("64 boxes", lambda: myriad.load_xml(boxes_xml(), "64 boxes")),
              "ant": ("ant, random actions", lambda: myriad.load(myriad.asset_path("ant.xml")))}
    print(f"machine: {platform.machine()}, {os.cpu_count()} cores; warp {wp.__version__}, "
          f"mujoco {mujoco.__version__}; device {args.device}")
    print("| scene | envs | Myriad env-steps/s | MuJoCo C env-steps/s (1 thread) | ratio | peak contacts/env |")
    print("|---|---|---|---|---|---|")
    for key, (name, load) in scenes.items():
        if args.scene and args.scene != key:
            continue
        model = load()
        reference = mujoco_rate(model)
        for n in args.envs:
            rate, peak = myriad_rate(model, n, args.device)
            print(f"| {name} (nv={model.nv}) | {n} | {rate:,.1f} | {reference:,.1f} | "
                  f"{rate / reference:.2f} | {peak} |", flush=True)
        print(f"| {name} | memory | {memory_per_env(model, PARAMS, args.device):,.0f} bytes/env | | | |")


if __name__ == "__main__":
    main()
