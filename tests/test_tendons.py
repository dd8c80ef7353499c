"""Fixed tendons with PhysX semantics (imported from MJCF): coupling, limits, equilibria."""

import numpy as np
import pytest
import torch

import myriad

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

PAIR = """<mujoco><compiler angle="radian"/><option gravity="0 0 0"/><worldbody>
  <body name="a"><joint name="j1" type="hinge" axis="0 0 1" damping="0.05"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/></body>
  <body name="b" pos="0 1 0"><joint name="j2" type="hinge" axis="0 0 1" damping="0.05" stiffness="{k2}"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.5"/></body></worldbody>
  <tendon><fixed name="couple" stiffness="{k}" damping="0.5" springlength="0" {limit}>
    <joint joint="j1" coef="1"/><joint joint="j2" coef="-1"/></fixed></tendon>
  <actuator><motor name="push" joint="j1"/></actuator></mujoco>"""

PARAMS = myriad.SimParams(dt=1 / 60, substeps=2)


def test_tendon_spring_equilibrium(device):
    """Torque tau on j1, tendon spring k on L = q1 - q2, joint spring k2 on j2:
    at rest q2 = tau / k2 and q1 - q2 = tau / k."""
    k, k2, tau = 40.0, 10.0, 0.8
    model = myriad.load_xml(PAIR.format(k=k, k2=k2, limit=""), "pair")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=PARAMS)
    sim.ctrl[:] = tau
    for _ in range(600):
        sim.step()
    q1, q2 = sim.q[0].tolist()
    assert q2 == pytest.approx(tau / k2, rel=1e-3)
    assert q1 - q2 == pytest.approx(tau / k, rel=1e-3)


def test_coupled_pair_keeps_its_coupling(device):
    """A stiff tendon makes the driven joint carry the free one along: q2 tracks q1."""
    model = myriad.load_xml(PAIR.format(k=2000.0, k2=0.0, limit=""), "pair")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=PARAMS)
    worst, swing = 0.0, 0.0
    for step in range(300):
        sim.ctrl[:] = 0.3 * np.sin(step / 20.0)
        sim.step()
        worst = max(worst, abs(sim.q[0, 0].item() - sim.q[0, 1].item()))
        swing = max(swing, abs(sim.q[0, 1].item()))
    assert swing > 0.2  # the free joint was carried through a large motion
    assert worst < 0.01, worst  # coupling error below 0.01 rad throughout


def push_against_limit(sim, gap_limit: float) -> float:
    """Drive j1 with +2 in env 0 and -2 in env 1 for 300 steps: the most q1 - q2 went past
    ±gap_limit. The limit must drag the second joint along."""
    sim.ctrl = torch.tensor([[2.0], [-2.0]], device=sim.torch_device)
    worst = 0.0
    for _ in range(300):
        sim.step()
        gap = (sim.q[:, 0] - sim.q[:, 1]).cpu().numpy()
        worst = max(worst, gap[0] - gap_limit, -gap_limit - gap[1])
    assert sim.q[0, 1].item() > 1.0 and sim.q[1, 1].item() < -1.0
    return worst


def test_hard_tendon_limit_holds(device):
    model = myriad.load_xml(PAIR.format(k=0.0, k2=0.0, limit='limited="true" range="-0.1 0.1"'), "pair")
    sim = myriad.Simulator(model, num_envs=2, device=device, params=PARAMS)
    worst = push_against_limit(sim, 0.1)
    assert worst < 0.02, worst


def test_hard_tendon_limit_in_small_length_units(device):
    """Coefficients of 0.01 (the Shadow Hand's): the limit L = 0.01 (q1 - q2) <= 0.004 still
    holds q1 - q2 at 0.4 rad, and its rows stay unbuilt while the joints are far from it."""
    xml = PAIR.format(k=0.0, k2=0.0, limit='limited="true" range="-0.004 0.004"')
    xml = xml.replace('coef="1"', 'coef="0.01"').replace('coef="-1"', 'coef="-0.01"')
    sim = myriad.Simulator(myriad.load_xml(xml, "pair"), num_envs=2, device=device,
                           params=PARAMS)
    sim.step()
    layout = sim.device_model.layout
    limit_rows = sim.data.rows.type.numpy()[:, layout.tendon_limits:layout.equalities]
    assert (limit_rows == -1).all(), limit_rows      # L = 0: 0.4 rad from either side
    worst = push_against_limit(sim, 0.4)
    assert worst < 0.02, worst


def test_soft_tendon_limit_is_a_spring(device):
    """With a limit stiffness the limit is a spring outside [lower, upper] (PhysX)."""
    tau, k_lim = 0.5, 25.0
    model = myriad.load_xml(PAIR.format(k=0.0, k2=10.0, limit='limited="true" range="-0.1 0.1"'), "pair")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=PARAMS)
    sim.tendon_limit_stiffness[:] = k_lim
    sim.ctrl[:] = tau
    for _ in range(900):
        sim.step()
    q1, q2 = sim.q[0].tolist()
    # j1: tau = k_lim (L - 0.1); j2: k_lim (L - 0.1) = k2 q2
    assert q1 - q2 == pytest.approx(0.1 + tau / k_lim, rel=1e-3)
    assert q2 == pytest.approx(tau / 10.0, rel=1e-3)


def test_physx_tendon_offset_and_recip_coef(device):
    """L = offset + sum coef q; joint i receives recip_i / N times the spring force."""
    model = myriad.load_xml(PAIR.format(k=10.0, k2=0.0, limit=""), "pair")
    model.wrap_recip[:] = [1.0, -3.0]  # joint 2 gets three times the (opposite) share
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=1e-3, substeps=1))
    sim.tendon_offset[:] = 0.2
    sim.dof_damping[:] = 0.0
    sim.tendon_damping[:] = 0.0
    sim.step()
    # from rest at q = 0: L = 0.2, tension -k·L = -2, forces recip/N · tension
    f = sim.mass_matrix[0].diagonal() * sim.qd[0] / 1e-3
    np.testing.assert_allclose(f.cpu().numpy(), [1.0 / 2 * -2.0, -3.0 / 2 * -2.0], rtol=2e-2)
