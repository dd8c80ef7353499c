"""Lanes per world of the cooperative kernels (`runtime.BlockDim`), swept on one GPU: physics
steps/s and time per stage for each lane count, the best count per kind of work, and a check that
every lane count gives the same state bit for bit.

    python benchmarks/lane_sweep.py --device cuda:0 [--models humanoid ant] [--worlds 8192]

Each model is set up as in `gpu_peers.py` (same MJCF, timestep, keyframe, control noise, one
substep, TGS 4/0) and stepped once per configuration: first every kind of work at the same lane
count L (1, 2, 4, 8, 16, 32: the lane counts that divide the 32-thread block, so no kernel is
compiled again; the solve 1 lane, or 0 = the whole block, for L > 1), then the best L per kind (the sum of its stages' times, below) together, then
the default `BlockDim()`. A kind's count only changes which threads take a world's items, not the
arithmetic (`physics/lanes.py`), except the solve's: its sums add each lane's part in lane order
(`solver_tgs._dot`), so configurations with the same solve lane count must end in the same state
(the table's state hash: q and qd after the run, the same control sequence each time).

    bodies  kinematics, dynamics, solve unconstrained (tree levels' bodies)
    rows    constraint rows (a family's items)
    solve   solve constraints (1, or 0: a world per block; `BlockDim` refuses others)
    dofs    integrate, constraint outputs (dofs, joints, contacts, sensors)
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import hashlib
import time

import torch
import warp as wp

import gpu_peers
from myriad.physics import step as pipeline
from myriad.physics.runtime.launch import BlockDim

KINDS = {"bodies": ("kinematics", "dynamics", "solve_unconstrained"),
         "rows": ("constraint_rows",), "solve": ("solve_constraints",),
         "dofs": ("integrate", "constraint_outputs")}
LANES = (1, 2, 4, 8, 16, 32)


def measure(model, mjm, n: int, steps: int, dev: str, block: BlockDim) -> dict:
    pipeline.BLOCK_DIM = block
    controls = gpu_peers.Controls(mjm, dev)
    sim = gpu_peers.myriad_sim(model, mjm, n, dev)
    row = gpu_peers.stepped(sim.step, n, dev, None, controls, sim.ctrl, steps)
    row["stage_ms"] = gpu_peers.stage_ms(sim, controls)
    state = torch.cat([sim.q.flatten(), sim.qd.flatten()]).cpu().numpy().tobytes()
    row["hash"] = hashlib.sha1(state).hexdigest()[:10]
    row["nonfinite"] = int((sim.nonfinite != 0).sum())
    del sim
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--models", nargs="+", default=["humanoid", "ant"],
                    choices=["humanoid", "ant", "shadow-hand"])
    ap.add_argument("--worlds", type=int, default=8192)
    ap.add_argument("--steps", type=int, default=100, help="timed steps per configuration")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    where = torch.cuda.get_device_name(args.device) if args.device.startswith("cuda") else "CPU"
    print(f"lane sweep on {args.device} ({where}), "
          f"{args.worlds} worlds, {args.steps} timed steps, block of {BlockDim.threads} threads",
          flush=True)
    for name in args.models:
        mjm, model = gpu_peers.load(name)
        # the sweeps wait on the block inside loops whose length is the world's (its contacts):
        # their lanes are 1 (no wait) or the whole block (0), never several worlds per block
        configs = [(f"all {L}", BlockDim(bodies=L, dofs=L, rows=L, solve=1 if L == 1 else 0))
                   for L in LANES]
        rows = []
        for label, block in configs:
            start = time.perf_counter()
            rows.append((label, block, measure(model, mjm, args.worlds, args.steps, args.device,
                                               block)))
            print(f"  {name} {label}: {rows[-1][2]['steps_per_s']:,.0f} steps/s "
                  f"({time.perf_counter() - start:.1f} s)", flush=True)
        best = {kind: min(LANES, key=lambda L: sum(
            rows[LANES.index(L)][2]["stage_ms"][s] for s in stages))
            for kind, stages in KINDS.items()}
        best["solve"] = 1 if best["solve"] == 1 else 0
        for label, block in (("best per kind", BlockDim(**best)), ("default", BlockDim())):
            rows.append((label, block, measure(model, mjm, args.worlds, args.steps, args.device,
                                               block)))
        print(f"\n{name}, {args.worlds} worlds: physics steps/s (CUDA graph) and ms per stage "
              "(stages synchronized, no graph)\n")
        stages = list(gpu_peers.STAGES)
        print("| lanes (bodies/rows/solve/dofs) | steps/s | " + " | ".join(
            s.replace("_", " ") for s in stages) + " | state hash | non-finite |")
        print("|---|---|" + "---|" * len(stages) + "---|---|")
        for label, block, r in rows:
            lanes = "/".join(str(getattr(block, k)) for k in KINDS)
            print(f"| {label} ({lanes}) | {r['steps_per_s']:,.0f} | " + " | ".join(
                f"{r['stage_ms'][s]:.3f}" for s in stages) + f" | {r['hash']} | "
                f"{r['nonfinite']} |")
        by_solve = collections.defaultdict(set)
        for _, block, r in rows:
            by_solve[block.solve or block.threads].add(r["hash"])
        same = all(len(h) == 1 for h in by_solve.values())
        print(f"\nsame state wherever the solve's lane count is the same: "
              f"{'yes' if same else 'NO'}; best per kind: "
              f"{dataclasses.asdict(BlockDim(**best))}\n", flush=True)


if __name__ == "__main__":
    main()
