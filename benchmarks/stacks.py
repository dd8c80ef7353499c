"""Resting stacks: how far the top box drifts, against iteration count, TGS and PGS, and MuJoCo.

    python benchmarks/stacks.py

Issue 12's stack scenes at Isaac Gym's timing (dt 1/60 s in 2 substeps): three 10 cm boxes
stacked on the floor (5 s; target < 1 mm), five (10 s; target < 5 mm), and a 5 cm cube on a
20 cm box (10 s; target < 1 mm). Boxes of 0.5 kg, friction 1, 0.5 mm gaps at the start. The
stack settles for 0.5 s, then the top box's displacement is measured until the end. MuJoCo C
steps the same model (two 1/120 s steps per env step, its own solver and soft contacts).
"""

from __future__ import annotations

import mujoco
import numpy as np
import warp as wp

import myriad


def stack_xml(half_sizes: list[float], mass: float = 0.5) -> str:
    bodies, z = [], 0.0
    for i, s in enumerate(half_sizes):
        z += s + (0.0005 if i else 0.0)
        bodies.append(f'<body pos="0 0 {z:.5f}"><freejoint/>'
                      f'<geom type="box" size="{s} {s} {s}" mass="{mass}"/></body>')
        z += s
    return ('<mujoco model="stack"><worldbody><geom type="plane" size="2 2 0.1"/>'
            f'{"".join(bodies)}</worldbody></mujoco>')


SCENES = {  # name: (box half sizes from the bottom, seconds)
    "3 boxes": ([0.05] * 3, 5.0),
    "5 boxes": ([0.05] * 5, 10.0),
    "small cube on a box": ([0.1, 0.025], 10.0),
}
SETTLE = 30


def myriad_drift(model, nbox: int, seconds: float, solver: str, iterations: int,
                 device: str = "cpu") -> float:
    params = myriad.SimParams(dt=1 / 60, substeps=2, solver=solver,
                              position_iterations=iterations, velocity_iterations=1)
    sim = myriad.Simulator(model, num_envs=1, params=params, device=device, cpu_threads=1)
    top = 7 * (nbox - 1)
    for _ in range(SETTLE):
        sim.step()
    start = sim.q[0, top:top + 3].clone()
    for _ in range(round(seconds * 60)):
        sim.step()
    return float((sim.q[0, top:top + 3] - start).norm())


def mujoco_drift(model, nbox: int, seconds: float) -> float:
    mj = model.mj_model
    mj.opt.timestep = 1 / 120
    d = mujoco.MjData(mj)
    top = 7 * (nbox - 1)
    mujoco.mj_step(mj, d, nstep=2 * SETTLE)
    start = d.qpos[top:top + 3].copy()
    mujoco.mj_step(mj, d, nstep=2 * round(seconds * 60))
    return float(np.linalg.norm(d.qpos[top:top + 3] - start))


def main() -> None:
    wp.config.log_level = wp.LOG_WARNING
    print("top box drift (mm) after settling\n")
    print("| scene | seconds | TGS 4 + 1 | TGS 8 + 1 | PGS 4 + 1 | PGS 8 + 1 | MuJoCo C |")
    print("|---|---|---|---|---|---|---|")
    for name, (sizes, seconds) in SCENES.items():
        model = myriad.load_xml(stack_xml(sizes), name)
        cells = [f"{1e3 * myriad_drift(model, len(sizes), seconds, solver, it):.2f}"
                 for solver in ("tgs", "pgs") for it in (4, 8)]
        cells.append(f"{1e3 * mujoco_drift(model, len(sizes), seconds):.2f}")
        print(f"| {name} | {seconds:g} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
