"""Fluid forces (issue 40): MuJoCo's inertia-box model of the medium's density, viscosity and
wind, per env, against MuJoCo stepped on the same model."""

import mujoco
import numpy as np
import pytest
import torch

import myriad
from oracle import free_motion_mujoco

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

# a tumbling free box and a flapping two-link chain, in a dense viscous medium with wind
SWIMMERS = """<mujoco><option density="800" viscosity="0.05" wind="0.5 -0.3 0.2"/><worldbody>
<body name="box" pos="0 0 1"><freejoint/>
  <geom type="box" size="0.2 0.05 0.1" mass="2" contype="0" conaffinity="0"/></body>
<body name="base" pos="1 0 1">
  <body name="link1"><joint name="a" type="hinge" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5" contype="0" conaffinity="0"/>
    <body name="link2" pos="0.3 0 0"><joint name="b" type="hinge" axis="0 1 0"/>
      <geom type="box" pos="0.1 0 0" size="0.1 0.02 0.08" mass="0.3" contype="0" conaffinity="0"/>
</body></body></body></worldbody>
<actuator><motor joint="a"/><motor joint="b"/></actuator></mujoco>"""


def test_inertia_box_fluid_matches_mujoco(device):
    model = myriad.load_xml(SWIMMERS, "swimmers")
    mj, d = free_motion_mujoco(model, 0.002)
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1))
    qvel0 = np.array([0.5, -1.0, 2.0, 3.0, -2.0, 4.0, 5.0, -3.0])  # fast enough for drag to matter
    d.qvel[:] = qvel0
    sim.qd[0] = torch.as_tensor(qvel0, dtype=torch.float32)
    for step in range(300):
        u = np.array([np.sin(step * 0.05), np.cos(step * 0.07)]) * 2.0
        d.ctrl[:] = u
        sim.ctrl[0] = torch.as_tensor(u, dtype=torch.float32)
        mujoco.mj_step(mj, d)
        sim.step()
    assert np.abs(d.qfrc_fluid).max() > 0.5     # the medium's forces matter here
    q = model.qpos_to_mujoco(sim.q[0].cpu().numpy())
    np.testing.assert_allclose(q, d.qpos, atol=5e-4)
    np.testing.assert_allclose(sim.qd[0].cpu().numpy(), d.qvel, atol=2e-3)


def test_medium_is_per_env(device):
    """Env 1 without a medium falls freely; env 0's box in water sinks at a terminal speed
    where drag and weight balance; env 2's wind carries a light body along."""
    model = myriad.load_xml("""<mujoco><worldbody><body name="ball" pos="0 0 10"><freejoint/>
      <geom type="sphere" size="0.05" mass="0.6" contype="0" conaffinity="0"/></body>
      </worldbody></mujoco>""", "ball")
    sim = myriad.Simulator(model, num_envs=3, device=device,
                           params=myriad.SimParams(dt=0.005, substeps=1))
    sim.fluid_density = torch.tensor([1000.0, 0.0, 1.2], device=sim.torch_device)
    sim.wind[2] = torch.tensor([5.0, 0.0, 0.0])
    for _ in range(400):             # 2 s
        sim.step()
    vz = sim.qd[:, 2].cpu().numpy()
    assert vz[1] == pytest.approx(-9.81 * 2.0, rel=1e-3)        # free fall
    # terminal speed: m g = 0.5 ρ A v², A the inertia box's face (a sphere's box: side
    # sqrt(6 (I1 + I2 - I0) / m), each I = 2/5 m r²)
    side = np.sqrt(6 * 0.4 * 0.05**2)
    v_terminal = np.sqrt(0.6 * 9.81 / (0.5 * 1000.0 * side * side))
    assert vz[0] == pytest.approx(-v_terminal, rel=1e-3)
    assert 0.1 < sim.qd[2, 0].item() < 5.0 and sim.qd[0, 0].item() == 0.0   # toward the wind's


# a glider (a flat box wing and a capsule fuselage, each its own ellipsoid with lift) and a
# spinning ball (Magnus lift), thrown through a dense medium with wind
GLIDERS = """<mujoco><option density="50" viscosity="0.01" wind="1 0 -0.5"/><worldbody>
<body name="glider" pos="0 0 2"><freejoint/>
  <geom type="box" size="0.3 0.1 0.01" mass="0.3" fluidshape="ellipsoid" contype="0" conaffinity="0"/>
  <geom type="capsule" fromto="-0.2 0 0.02 0.2 0 0.02" size="0.02" mass="0.1" fluidshape="ellipsoid"
        fluidcoef="0.4 0.3 1.2 1.5 0.8" contype="0" conaffinity="0"/></body>
<body name="ball" pos="1 0 2"><freejoint/>
  <geom type="sphere" size="0.05" mass="0.2" fluidshape="ellipsoid" fluidcoef="0.5 0.25 1.5 1 2"
        contype="0" conaffinity="0"/>
  <geom type="cylinder" size="0.02 0.1" pos="0 0 0.1" mass="0.05" contype="0" conaffinity="0"/></body>
</worldbody></mujoco>"""


def test_ellipsoid_fluid_model_matches_mujoco(device):
    """MuJoCo's ellipsoid model (fluidshape="ellipsoid": added mass, Magnus and Kutta lift,
    viscous, blunt, slender and angular drag, per geom), against MuJoCo's trajectories; a geom
    without it on such a body feels nothing (the ball's cylinder)."""
    model = myriad.load_xml(GLIDERS, "gliders")
    mj, d = free_motion_mujoco(model, 0.002)
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1))
    qvel0 = np.array([4.0, 0.5, 1.0, 0.3, -2.0, 1.0, 1.0, 3.0, 0.0, 20.0, -5.0, 10.0])
    d.qvel[:] = qvel0
    sim.qd[0] = torch.as_tensor(qvel0, dtype=torch.float32)
    for _ in range(300):
        mujoco.mj_step(mj, d)
        sim.step()
    assert np.abs(d.qfrc_fluid).max() > 0.5
    q = model.qpos_to_mujoco(sim.q[0].cpu().numpy())
    np.testing.assert_allclose(q, d.qpos, atol=1e-3)
    np.testing.assert_allclose(sim.qd[0].cpu().numpy(), d.qvel, atol=5e-3 * (1 + np.abs(d.qvel).max()))
