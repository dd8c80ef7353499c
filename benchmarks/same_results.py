"""Check that an engine change leaves the step results unchanged, bit for bit.

    python benchmarks/same_results.py save ref.npz       # on the tree before the change
    python benchmarks/same_results.py compare ref.npz    # on the tree after it

The ant, the humanoid and the hand-and-cube stand-in, 8 envs each, and 64 boxes dropped on a
plane (2 envs: many trees, contacts between two of them), 150 steps of seeded random controls
on one CPU thread: the final q and `dof_constraint_force` are saved, or compared
exactly (the largest absolute difference per array is printed; 0.0 means identical).
With `--tasks`, every task of the seed as well (4 envs, 40 steps of seeded random actions,
resets included: observations, rewards and the simulator's q), which reaches the kernels the
four models do not (tendons, equalities, sensors, meshes, height fields); tasks whose robot
package is not installed are skipped and named.
"""

from __future__ import annotations

import sys

import numpy as np
import torch
import warp as wp

import myriad
from contacts import PARAMS as BOX_PARAMS, boxes_xml
from memory import hand_and_cube_xml      # benchmarks/memory.py: the 30-DoF stand-in


MODELS = ("ant", "humanoid", "hand-and-cube", "64 boxes")


def results() -> dict[str, np.ndarray]:
    models = {"ant": myriad.load(myriad.asset_path("ant.xml")),
              "humanoid": myriad.load(myriad.asset_path("humanoid.xml")),
              "hand-and-cube": myriad.load_xml(hand_and_cube_xml(), "hand-and-cube"),
              "64 boxes": myriad.load_xml(boxes_xml(), "64 boxes")}
    out = {}
    for name, model in models.items():
        n = 2 if name == "64 boxes" else 8
        sim = myriad.Simulator(model, num_envs=n, cpu_threads=1,
                               params=BOX_PARAMS if name == "64 boxes" else None)
        gen = torch.Generator().manual_seed(0)
        for _ in range(150):
            sim.ctrl = torch.rand(n, model.nu, generator=gen) * 2 - 1
            sim.step()
        out[f"{name} q"] = sim.q.numpy().copy()
        out[f"{name} dof_constraint_force"] = sim.dof_constraint_force.numpy().copy()
    return out


def task_results() -> dict[str, np.ndarray]:
    from myriad.tasks import TASKS

    out = {}
    for name in TASKS:
        torch.manual_seed(0)
        try:
            task = myriad.make(name, num_envs=4)
        except (ImportError, ModuleNotFoundError) as missing:
            print(f"{name}: skipped ({missing})")
            continue
        gen = torch.Generator().manual_seed(1)
        task.reset()
        rewards = []
        for _ in range(40):
            actions = torch.rand(task.num_envs, task.num_actions, generator=gen) * 2 - 1
            obs, rew, done, extras = task.step(actions)
            rewards.append(rew.clone())
        out[f"{name} obs"] = obs["obs"].numpy().copy()
        out[f"{name} rewards"] = torch.stack(rewards).numpy()
        out[f"{name} q"] = task.envs.sim.q.numpy().copy()
    return out


def main() -> None:
    args = [a for a in sys.argv[1:] if a != "--tasks"]
    if len(args) != 2 or args[0] not in ("save", "compare"):
        sys.exit(__doc__)
    wp.config.log_level = wp.LOG_WARNING
    mode, path = args
    now = results()
    if "--tasks" in sys.argv:
        now.update(task_results())
    if mode == "save":
        np.savez(path, **now)
        print(f"saved {len(now)} arrays to {path}")
        return
    before = np.load(path)
    # a task's arrays are expected only with --tasks
    missing = sorted(k for k in set(before.files) - set(now)
                     if "--tasks" in sys.argv or k.rsplit(" ", 1)[0] in MODELS)
    same = not missing
    if missing:
        print(f"not computed now: {missing}")
    for key, value in now.items():
        if key not in before.files:         # a task or model added since the reference
            print(f"{key}: new, not in the reference")
            continue
        diff = float(np.abs(value - before[key]).max())
        same &= diff == 0.0
        print(f"{key}: max |difference| {diff}")
    print("identical" if same else "DIFFERENT")
    sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
