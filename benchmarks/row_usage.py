"""How many of an env's constraint rows are built, and how many of those never push.

    python benchmarks/row_usage.py [--envs 256] [--steps 60]

The ant and the humanoid under fresh random controls every step (Isaac Gym timing, dt 1/60 s in
2 substeps, TGS 4/0). After the last step, per env on average: contacts, contact normal rows
and joint-limit rows that are active, and how many of those ended the substep with no impulse
and no warm start (rows whose response M⁻¹Jᵀ the solver never needs to build).
"""

from __future__ import annotations

import argparse

import torch
import warp as wp

import myriad
from myriad.physics.types import NORMAL


def usage(name: str, envs: int, steps: int) -> dict:
    model = myriad.load(myriad.asset_path(f"{name}.xml"))
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=0)
    sim = myriad.Simulator(model, num_envs=envs, params=params, cpu_threads=1)
    gen = torch.Generator().manual_seed(0)
    for _ in range(steps):
        sim.ctrl = torch.rand(envs, model.nu, generator=gen) * 2 - 1
        sim.step()
    rows = sim.data.rows
    row_type, lam, lam_init = (wp.to_torch(a) for a in (rows.type, rows.lam, rows.lam_init))
    layout = sim.device_model.layout
    ncontact = sim.contact_count.clamp(max=sim.contact_capacity)
    normal = torch.zeros_like(row_type, dtype=torch.bool)
    width = layout.contact_width
    normal[:, 0:layout.joint_limits:width] = (torch.arange(layout.contact_slots)[None]
                                              < ncontact[:, None])
    limits = torch.zeros_like(normal)
    limits[:, layout.joint_limits:layout.tendon_limits] = True
    idle = (lam == 0) & (lam_init == 0)
    out = {"contacts": ncontact.float().mean().item()}
    for label, mask in (("contact normal rows", normal), ("joint-limit rows", limits)):
        active = mask & (row_type == NORMAL)
        out[label] = (active.sum(1).float().mean().item(),
                      (active & idle).sum(1).float().mean().item())
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=256)
    ap.add_argument("--steps", type=int, default=60)
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    print("| model | contacts | contact normal rows: active / never pushed | "
          "joint-limit rows: active / never pushed |")
    print("|---|---|---|---|")
    for name in ("ant", "humanoid"):
        u = usage(name, args.envs, args.steps)
        cells = [f"{a:.1f} / {b:.1f}" for a, b in (u["contact normal rows"], u["joint-limit rows"])]
        print(f"| {name} | {u['contacts']:.1f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
