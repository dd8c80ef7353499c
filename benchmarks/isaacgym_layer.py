"""What Myriad's `isaacgym` layer costs: the same scene stepped through Isaac Gym's calls and
through Myriad's own API, side by side in one process (issue 41's target: within 10 %).

    python benchmarks/isaacgym_layer.py [--envs 512] [--rounds 20] [--steps 20] [--device cpu]

The scene is IsaacGymEnvs' Ant loop on Myriad's ant (assets/ant.xml) on a ground plane: each
step sets random DOF efforts, steps the physics and reads the state back. Through `isaacgym`:
`set_dof_actuation_force_tensor`, `simulate`, `fetch_results`, `refresh_actor_root_state_tensor`,
`refresh_dof_state_tensor`, `refresh_force_sensor_tensor` with four foot force sensors made by
`create_asset_force_sensor` (the file's own four are not imported). Through Myriad:
`Envs.set_dof_efforts`, `Envs.step` (which refreshes root and DOF states; the foot sensors are
the file's). Same timing (dt 1/60 s, 2 substeps, TGS 4/1). The two take turns in short rounds,
the first in turn changing every round, so a drifting machine falls on both alike; the figure is
the median over rounds of each side's env-steps per second, and their ratio.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings

import torch

import myriad
from isaacgym import gymapi, gymtorch
from myriad.api import Scene


def through_isaacgym(num_envs: int, device: str):
    gym = gymapi.acquire_gym()
    params = gymapi.SimParams()
    params.up_axis = gymapi.UP_AXIS_Z
    params.gravity = gymapi.Vec3(0.0, 0.0, -9.81)
    params.dt, params.substeps = 1 / 60, 2
    params.physx.num_position_iterations, params.physx.num_velocity_iterations = 4, 1
    params.use_gpu_pipeline = device != "cpu"
    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, params)
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    options = gymapi.AssetOptions()
    options.angular_damping = 0.0
    options.default_dof_drive_mode = gymapi.DOF_MODE_NONE
    path = myriad.asset_path("ant.xml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        asset = gym.load_asset(sim, os.path.dirname(path), os.path.basename(path), options)
    feet = [gym.find_asset_rigid_body_index(asset, f"{leg}_foot")
            for leg in ("front_left", "back_left", "back_right", "front_right")]
    for body in feet:
        gym.create_asset_force_sensor(asset, body, gymapi.Transform())
    for i in range(num_envs):
        env = gym.create_env(sim, gymapi.Vec3(-2, -2, 0), gymapi.Vec3(2, 2, 2), 32)
        gym.create_actor(env, asset, gymapi.Transform(gymapi.Vec3(0, 0, 0.62)), "ant", i, 1, 0)
    gym.prepare_sim(sim)
    gym.acquire_actor_root_state_tensor(sim)
    gym.acquire_dof_state_tensor(sim)
    gym.acquire_force_sensor_tensor(sim)
    dofs = gym.get_asset_dof_count(asset)

    def step(efforts):
        gym.set_dof_actuation_force_tensor(sim, gymtorch.unwrap_tensor(efforts))
        gym.simulate(sim)
        gym.fetch_results(sim, True)
        gym.refresh_actor_root_state_tensor(sim)
        gym.refresh_dof_state_tensor(sim)
        gym.refresh_force_sensor_tensor(sim)
    return step, dofs


def through_myriad(num_envs: int, device: str):
    envs = Scene().add_ground().add_actor("ant", myriad.asset_path("ant.xml"),
                                          pos=(0, 0, 0.62)).build(
        num_envs, device=device, params=myriad.SimParams(dt=1 / 60, substeps=2))

    def step(efforts):
        envs.set_dof_efforts(efforts.view(num_envs, -1))
        envs.step()
    return step, envs.num_dofs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--envs", type=int, default=512)
    ap.add_argument("--rounds", type=int, default=20)
    ap.add_argument("--steps", type=int, default=20, help="env steps per side per round")
    ap.add_argument("--device", default="cpu")
    args = ap.parse_args()
    if args.rounds < 2:
        raise SystemExit("--rounds must be >= 2 (sides alternate who goes first)")
    sides = {"isaacgym": through_isaacgym(args.envs, args.device),
             "myriad": through_myriad(args.envs, args.device)}
    dofs = sides["myriad"][1]
    assert sides["isaacgym"][1] == dofs
    gen = torch.Generator().manual_seed(0)
    rates = {name: [] for name in sides}
    for name, (step, _) in sides.items():            # warm-up: kernels compiled and loaded
        for _ in range(3):
            step((torch.rand(args.envs * dofs, generator=gen) * 2 - 1).to(args.device))
    for r in range(args.rounds):
        order = list(sides) if r % 2 == 0 else list(reversed(sides))
        for name in order:
            step = sides[name][0]
            efforts = [(torch.rand(args.envs * dofs, generator=gen) * 2 - 1).to(args.device)
                       for _ in range(args.steps)]
            if args.device != "cpu":
                torch.cuda.synchronize()
            start = time.perf_counter()
            for e in efforts:
                step(e)
            if args.device != "cpu":
                torch.cuda.synchronize()
            rates[name].append(args.envs * args.steps / (time.perf_counter() - start))
    med = {name: statistics.median(v) for name, v in rates.items()}
    print(f"ant, {args.envs} envs, {args.device}, {args.rounds} rounds of {args.steps} steps")
    for name, value in med.items():
        print(f"  through {name:9s} {value:12,.0f} env-steps/s (median; spread "
              f"{min(rates[name]):,.0f}-{max(rates[name]):,.0f})")
    print(f"  isaacgym / myriad: {med['isaacgym'] / med['myriad']:.3f}")


if __name__ == "__main__":
    main()
