"""TGS against PGS on the same rows at the same cost (the same number of sweeps).

Two scenes at Isaac Gym's timing (dt 1/60, 2 substeps):
- cantilever: a horizontal chain of 10 hinge links held level against gravity by their joint
  limits only, the tip body 100x heavier than a link (mass ratio 1:100): in reduced coordinates a
  hanging chain has no joint error to measure, so the chain's joints hold it through limits.
  Error: how far the tip sags (mm) in one step from rest, level, on the limits: the exact
  answer is zero, and what is left is the solver's residual at that many sweeps.
- stack: 5 boxes stacked on the floor. Errors after 10 s: the deepest penetration (mm) and the
  largest horizontal drift of a box (mm).

    python benchmarks/solver_convergence.py
"""

from __future__ import annotations

import platform

import warp as wp

import myriad


def cantilever_xml(nlink: int = 10, ratio: float = 100.0) -> str:
    xml, close = [], []
    for i in range(nlink):
        mass = ratio if i == nlink - 1 else 1.0
        pos = "0 0 1" if i == 0 else "0.2 0 0"
        # a hinge about y; the limit range [0, 0.5] lets the link rise but not sag below level
        xml.append(f'<body name="l{i}" pos="{pos}"><joint name="j{i}" type="hinge" axis="0 -1 0" '
                   f'limited="true" range="0 0.5"/><geom type="capsule" fromto="0 0 0 0.2 0 0" '
                   f'size="0.02" mass="{mass}" contype="0" conaffinity="0"/>')
        close.append("</body>")
    return (f'<mujoco><compiler angle="radian"/><worldbody>{"".join(xml)}{"".join(close)}'
            f"</worldbody></mujoco>")


def stack_xml(n: int = 5) -> str:
    boxes = "".join(f'<body name="b{i}" pos="0 0 {0.1 + 0.2 * i:.3f}"><freejoint/>'
                    f'<geom type="box" size="0.1 0.1 0.1" mass="1"/></body>' for i in range(n))
    return f'<mujoco><worldbody><geom type="plane" size="10 10 0.1"/>{boxes}</worldbody></mujoco>'


def cantilever_error(solver: str, position_iterations: int, velocity_iterations: int) -> float:
    model = myriad.load_xml(cantilever_xml(), "cantilever")
    sim = myriad.Simulator(model, params=myriad.SimParams(
        solver=solver, position_iterations=position_iterations,
        velocity_iterations=velocity_iterations))
    level = sim.body_pose[0, -1, 2].item()
    sim.step()
    return 1e3 * (level - sim.body_pose[0, -1, 2].item())


def stack_error(solver: str, position_iterations: int, velocity_iterations: int):
    model = myriad.load_xml(stack_xml(), "stack")
    sim = myriad.Simulator(model, params=myriad.SimParams(
        solver=solver, position_iterations=position_iterations,
        velocity_iterations=velocity_iterations))
    start = sim.body_pose[0, :, :2].clone()
    for _ in range(600):
        sim.step()
    n = int(sim.contact_count[0])
    depth = max(0.0, -sim.contact_dist[0, :n].min().item()) if n else 0.0
    drift = (sim.body_pose[0, :, :2] - start).norm(dim=1).max().item()
    return depth * 1e3, drift * 1e3


def main() -> None:
    wp.config.log_level = wp.LOG_WARNING
    print(f"machine: {platform.machine()}, warp {wp.__version__}; dt 1/60, 2 substeps")
    print("| sweeps (position + velocity) | solver | cantilever tip sag in one step (mm) | "
          "stack penetration (mm) | stack drift in 10 s (mm) |")
    print("|---|---|---|---|---|")
    for pos_it, vel_it in [(2, 1), (4, 1), (8, 1), (16, 1), (32, 1)]:
        for solver in ("tgs", "pgs"):
            sag = cantilever_error(solver, pos_it, vel_it)
            depth, drift = stack_error(solver, pos_it, vel_it)
            print(f"| {pos_it} + {vel_it} | {solver.upper()} | {sag:.2f} | {depth:.2f} | {drift:.1f} |",
                  flush=True)


if __name__ == "__main__":
    main()
