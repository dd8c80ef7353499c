"""Force/torque sensors: MuJoCo's semantics, checked against MuJoCo and against statics."""

import mujoco
import numpy as np
import torch

import myriad
from oracle import free_motion_mujoco


def test_force_torque_sensors_match_mujoco_inverse_dynamics(device):
    """In free flight under random joint forces, each foot sensor reads what MuJoCo's sensors
    read for the same state and acceleration (mj_inverse)."""
    model = myriad.load(myriad.asset_path("ant.xml"))
    h = 1 / 120
    sim = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(dt=h, substeps=1, constraints=False))
    gen = torch.Generator().manual_seed(0)
    for _ in range(20):
        sim.joint_force = (torch.randn(2, model.nv, generator=gen) * 0.5).to(sim.torch_device)
        before = sim.qd.cpu().numpy().copy()
        sim.step()
    mj, d = free_motion_mujoco(model, h)
    readings = sim.sensor_data.cpu().numpy()
    for e in range(2):
        d.qpos[:] = model.qpos_to_mujoco(sim.q[e].cpu().numpy())
        d.qvel[:] = sim.qd[e].cpu().numpy()
        d.qacc[:] = (d.qvel - before[e]) / h
        mujoco.mj_inverse(mj, d)
        expected = d.sensordata.reshape(-1, 3)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(readings[e], expected, atol=1e-4 * scale + 1e-5)


def test_standing_ant_feet_carry_its_weight(device):
    model = myriad.load(myriad.asset_path("ant.xml"))
    sim = myriad.Simulator(model, num_envs=1, device=device)
    for _ in range(600):  # settle for 10 s (the legs fold onto their joint limits)
        sim.step()
    # it stands still: its pose moves by less than 1e-4 (m or rad) over one more second (its
    # velocity reading keeps ~0.01 rad/s of the solve's residual at rest: docs/physics.md)
    pose = sim.q[0].clone()
    for _ in range(60):
        sim.step()
    assert (sim.q[0] - pose).abs().max().item() < 1e-4
    assert sim.qd.abs().max().item() < 2e-2
    # each foot body: parent force + ground contact + its weight = 0; summed over the feet the
    # parents hold -(total weight) + (feet weight): the ground carries the whole ant.
    # Averaged over one more second: in this four-foot stance (friction statically
    # indeterminate, legs on their limits) 4 + 1 sweeps leave the friction impulses of the last
    # substep jittering by up to ~4 % of the weight from step to step (the contact issue);
    # each step is held to 5 %, the average to the tolerances of an equilibrium.
    total = float(model.body_mass.sum())
    weight = 9.81 * total
    feet = [model.site_body[s] for s in sim.sensor_sites]
    feet_mass = float(model.body_mass[feet].sum())
    sensed, ground = [], []
    for _ in range(60):
        sim.step()
        rot = sim.site_pose[0, sim.sensor_sites, 3:].cpu().numpy()
        world_forces = np.zeros(3)
        for k, (qx, qy, qz, qw) in enumerate(rot):
            r = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                          [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                          [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])
            world_forces += r @ sim.sensor_wrench[0, k, :3].cpu().numpy()
        sensed.append(world_forces)
        ground.append(sim.net_contact_force[0].sum(0).cpu().numpy())
    sensed, ground = np.asarray(sensed), np.asarray(ground)
    np.testing.assert_allclose(sensed, np.broadcast_to([0, 0, -9.81 * (total - feet_mass)], sensed.shape),
                               atol=5e-2 * weight)
    np.testing.assert_allclose(ground, np.broadcast_to([0, 0, weight], ground.shape), atol=5e-2 * weight)
    np.testing.assert_allclose(sensed.mean(0), [0, 0, -9.81 * (total - feet_mass)], atol=2e-2 * weight)
    np.testing.assert_allclose(ground.mean(0), [0, 0, weight], atol=1e-2 * weight)
