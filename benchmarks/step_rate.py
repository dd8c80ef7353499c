"""`Simulator.step` on one CPU thread against MuJoCo C on one thread, per scene, in one run.

    python benchmarks/step_rate.py                  # this checkout's engine
    PYTHONPATH=/path/to/other/src python benchmarks/step_rate.py    # another version, same scenes
    python benchmarks/step_rate.py --integrator implicit    # both engines' implicit integrator,
                                                            # and Myriad's Euler beside them

Isaac Gym timing (dt 1/60 s in 2 substeps, TGS 4/0, contacts on); fresh random controls every
step; MuJoCo steps the same compiled model twice per env step at 1/120 s with its own solver.
The two engines run in alternating half-second slices (6 each), so that the ratio holds on a
machine whose speed drifts.
Scenes: the ant and the humanoid at 1024 envs (issue 11's targets), 64 free boxes in one env
(16 envs, 512 contact slots). Prints a Markdown row per scene.
"""

from __future__ import annotations

import time

import mujoco
import numpy as np
import torch
import warp as wp

import myriad
from contacts import boxes_xml


class MyriadRun:
    def __init__(self, model, envs: int, slots: int, integrator: str = "euler"):
        params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                                  velocity_iterations=0, contacts_per_env=slots,
                                  integrator=integrator)
        self.sim = myriad.Simulator(model, num_envs=envs, params=params, cpu_threads=1)
        self.gen = torch.Generator().manual_seed(0)
        self.envs, self.nu = envs, model.nu
        for _ in range(20):                  # settle onto the floor, compile on a first run
            self.sim.step()

    def run(self, seconds: float) -> tuple[int, float]:
        """(env-steps, seconds) of stepping for about `seconds`."""
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            if self.nu:
                self.sim.ctrl = torch.rand(self.envs, self.nu, generator=self.gen) * 2 - 1
            self.sim.step()
            steps += self.envs
        assert torch.isfinite(self.sim.q).all()
        return steps, time.perf_counter() - start


class MujocoRun:
    def __init__(self, model, integrator: str = "euler"):
        self.mj = model.mj_model
        self.mj.opt.timestep = 1 / 120
        self.mj.opt.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                                  "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT}[integrator]
        self.d = mujoco.MjData(self.mj)
        self.rng = np.random.default_rng(0)

    def run(self, seconds: float) -> tuple[int, float]:
        steps, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            if self.mj.nu:
                self.d.ctrl[:] = self.rng.uniform(-1, 1, self.mj.nu)
            mujoco.mj_step(self.mj, self.d, nstep=2)
            steps += 1
        return steps, time.perf_counter() - start


def rates(runs, rounds: int = 6, seconds: float = 0.5) -> list[float]:
    """Env-steps/s of each run, measured in alternating slices so that a machine whose speed
    drifts (shared cores) slows all runs alike and their ratio stays meaningful."""
    totals = [[0, 0.0] for _ in runs]
    for _ in range(rounds):
        for total, run in zip(totals, runs):
            steps, spent = run.run(seconds)
            total[0] += steps
            total[1] += spent
    return [steps / spent for steps, spent in totals]


def main() -> None:
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--integrator", choices=("euler", "implicit"), default="euler",
                    help="both engines' (implicit: Myriad's Euler also runs, in the same slices)")
    integrator = ap.parse_args().integrator
    wp.config.log_level = wp.LOG_WARNING
    torch.set_num_threads(1)
    scenes = [("ant", myriad.load(myriad.asset_path("ant.xml")), 1024, 64),
              ("humanoid", myriad.load(myriad.asset_path("humanoid.xml")), 1024, 64),
              ("64 boxes", myriad.load_xml(boxes_xml(), "64 boxes"), 16, 512)]
    print(f"engine: {myriad.__file__}; integrator {integrator}")
    print("| scene | envs | Myriad env-steps/s (1 thread) | MuJoCo C env-steps/s (1 thread) | ratio |"
          + (" Myriad's Euler env-steps/s | implicit / Euler time |" if integrator != "euler"
             else ""))
    print("|---|---|---|---|---|" + ("---|---|" if integrator != "euler" else ""))
    for name, model, envs, slots in scenes:
        runs = [MyriadRun(model, envs, slots, integrator), MujocoRun(model, integrator)]
        if integrator != "euler":
            runs.append(MyriadRun(model, envs, slots))
        ours, theirs, *euler = rates(runs)
        print(f"| {name} | {envs} | {ours:,.0f} | {theirs:,.0f} | {ours / theirs:.2f} |"
              + "".join(f" {e:,.0f} | {e / ours:.2f} |" for e in euler), flush=True)


if __name__ == "__main__":
    main()
