"""Actuators, joint springs and fixed-tendon springs: against MuJoCo, and against closed forms."""

import math

import mujoco
import numpy as np
import pytest
import torch

import myriad
from oracle import free_motion_mujoco

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

SPRINGS_AND_MOTORS = """<mujoco><worldbody>
<body name="a" pos="0 0 1"><joint name="h1" type="hinge" axis="0 1 0" stiffness="3" springref="0.3" damping="0.1"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
  <body name="b" pos="0.3 0 0"><joint name="h2" type="hinge" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="1"/>
    <body name="c" pos="0.3 0 0"><joint name="s3" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.05" mass="0.5"/></body></body></body>
</worldbody>
<actuator>
  <motor name="m1" joint="h1" gear="3" ctrlrange="-1 1" ctrllimited="true"/>
  <motor name="m2" joint="h2" gear="2" forcerange="-0.5 0.5" forcelimited="true"/>
</actuator></mujoco>"""


def test_motors_and_joint_springs_match_mujoco(device):
    """Motor force = gear x clamp(ctrl) within forcerange; explicit joint springs."""
    model = myriad.load_xml(SPRINGS_AND_MOTORS, "springs_and_motors")
    mj, d = free_motion_mujoco(model, 0.002)
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=0.002, substeps=1))
    rng = np.random.default_rng(0)
    for _ in range(300):
        u = rng.normal(size=2) * 2  # often outside ctrlrange and forcerange
        d.ctrl[:] = u
        sim.ctrl[0] = torch.as_tensor(u, dtype=torch.float32)
        mujoco.mj_step(mj, d)
        sim.step()
    np.testing.assert_allclose(sim.q[0].cpu().numpy(), d.qpos, atol=1e-4)
    np.testing.assert_allclose(sim.qd[0].cpu().numpy(), d.qvel, atol=1e-4 * (1 + np.abs(d.qvel).max()))
    # the actuator force of the last substep, in joint space (gear x clamped force)
    np.testing.assert_allclose(sim.dof_actuator_force[0].cpu().numpy(), d.qfrc_actuator, atol=1e-5)


def _slider(actuator: str, mass: float = 2.0) -> myriad.Model:
    return myriad.load_xml(f"""<mujoco><option gravity="0 0 0"/><worldbody>
      <body name="slider"><joint name="x" type="slide" axis="1 0 0"/>
      <geom type="sphere" size="0.1" mass="{mass}"/></body></worldbody>
      <actuator>{actuator}</actuator></mujoco>""", "slider")


def test_position_actuator_step_response_is_second_order(device):
    """Implicit PD: a mass on a slide joint follows the damped-oscillator closed form.

    Joint-space gains are gear² x (kp, kv) and the target is ctrl / gear.
    """
    mass, kp, kv, gear, target = 2.0, 50.0, 4.0, 2.0, 1.5
    model = _slider(f'<position name="p" joint="x" kp="{kp}" kv="{kv}" gear="{gear}"/>', mass)
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=1e-3, substeps=1))
    sim.ctrl[:] = target
    k, c = gear**2 * kp, gear**2 * kv
    wn = math.sqrt(k / mass)
    zeta = c / (2 * math.sqrt(k * mass))
    assert zeta < 1  # the test is about the underdamped closed form
    wd = wn * math.sqrt(1 - zeta**2)
    x_final = target / gear
    worst = 0.0
    for step in range(1, 3001):
        sim.step()
        t = step * 1e-3
        x = x_final * (1 - math.exp(-zeta * wn * t) * (math.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * math.sin(wd * t)))
        worst = max(worst, abs(sim.q[0, 0].item() - x))
    # first-order integration error at h = 1 ms: within 1% of the step size
    assert worst < 0.01 * x_final, worst
    assert sim.q[0, 0].item() == pytest.approx(x_final, abs=1e-3)


def test_stiff_position_drive_is_stable_where_explicit_would_explode(device):
    """kp·h²/m = 1e4: an explicit PD update diverges; the implicit drive settles on its target."""
    mass, kp, h = 0.01, 1e4 * 0.01 / (1 / 120) ** 2, 1 / 120
    model = _slider(f'<position name="p" joint="x" kp="{kp}" kv="0"/>', mass)
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=h, substeps=1))
    sim.ctrl[:] = 0.3
    trace = []
    for _ in range(200):
        sim.step()
        trace.append(sim.q[0, 0].item())
    assert np.all(np.isfinite(trace))
    assert max(abs(x) for x in trace) < 0.3 * 1.01  # no overshoot beyond 1%
    assert trace[-1] == pytest.approx(0.3, abs=1e-4)


def test_velocity_actuator_is_first_order(device):
    mass, kv, gear, target = 2.0, 3.0, 1.5, 0.6
    model = _slider(f'<velocity name="v" joint="x" kv="{kv}" gear="{gear}"/>', mass)
    h = 1e-3
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=h, substeps=1))
    sim.ctrl[:] = target
    for _ in range(500):
        sim.step()
    rate = gear**2 * kv / mass
    expected = target / gear * (1 - math.exp(-rate * 0.5))
    assert sim.qd[0, 0].item() == pytest.approx(expected, rel=0.01)


def test_force_range_clamps_a_position_drive(device):
    model = _slider('<position name="p" joint="x" kp="1000" forcerange="-2 2" forcelimited="true"/>', 1.0)
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=1e-3, substeps=1))
    sim.ctrl[:] = 10.0
    for _ in range(100):
        sim.step()
    # saturated: constant 2 N on 1 kg for 0.1 s
    assert sim.qd[0, 0].item() == pytest.approx(2.0 * 0.1, rel=1e-3)
    assert sim.dof_actuator_force[0, 0].item() == pytest.approx(2.0)


def test_ctrl_of_each_env_drives_only_that_env(device):
    model = _slider('<motor name="m" joint="x" gear="2"/>', 1.0)
    sim = myriad.Simulator(model, num_envs=3, device=device, params=myriad.SimParams(dt=0.01, substeps=1))
    sim.ctrl = torch.tensor([[0.0], [1.0], [-3.0]], device=sim.torch_device)
    sim.step()
    np.testing.assert_allclose(sim.qd[:, 0].cpu().numpy(), [0.0, 0.02, -0.06], rtol=1e-5, atol=1e-7)
