"""Torsional and rolling friction (MuJoCo's condim 4 and 6): a contact's torque about its normal
is at most mu_spin times its normal force, about its tangents at most mu_roll times it. Checked
on a ball, where nothing else resists the motion, against the closed form and MuJoCo C."""

import mujoco
import numpy as np
import pytest
import torch

import myriad

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

PARAMS = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=1)
G, MASS, RADIUS = 9.81, 1.0, 0.1
INERTIA = 0.4 * MASS * RADIUS ** 2          # a solid ball's, about any axis


def _ball_xml(condim: int, friction: str, cone: str = "pyramidal") -> str:
    """A 1 kg, 10 cm ball resting on a plane (condim 3, MuJoCo's default friction 1 0.005
    0.0001); the contact takes the ball's condim and the larger of each coefficient. `cone`:
    MuJoCo's friction cone (Myriad's bounds each friction apart)."""
    return f"""<mujoco><option timestep="{1 / 120}" cone="{cone}"/><worldbody>
      <geom name="floor" type="plane" size="5 5 0.1"/>
      <body name="ball" pos="0 0 {RADIUS}"><freejoint/>
        <geom name="ball" size="{RADIUS}" mass="{MASS}" condim="{condim}" friction="{friction}"/>
      </body></worldbody></mujoco>"""


def _mujoco_run(xml: str, seconds: float, torque_z: float = 0.0, qvel=None) -> np.ndarray:
    """MuJoCo C's free-joint velocities (6) at each 1/60 s over `seconds`: the same ball, the
    same torque (xfrc_applied) or initial velocity."""
    mj = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(mj)
    if qvel is not None:
        data.qvel[:] = qvel
    data.xfrc_applied[1, 5] = torque_z
    out = []
    for _ in range(int(round(seconds * 60))):
        mujoco.mj_step(mj, data, nstep=2)
        out.append(data.qvel.copy())
    return np.asarray(out)


def _myriad_run(xml: str, seconds: float, device, torque_z: float = 0.0, qvel=None):
    sim = myriad.Simulator(myriad.load_xml(xml, "ball"), num_envs=1, device=device,
                           params=PARAMS)
    if qvel is not None:
        sim.qd = torch.tensor([qvel], dtype=torch.float32, device=sim.qd.device)
    out = []
    for _ in range(int(round(seconds * 60))):
        wrench = torch.zeros_like(sim.body_force)
        wrench[0, 0, 5] = torque_z
        sim.body_force = wrench
        sim.step()
        out.append(sim.qd[0].cpu().numpy().copy())
    return np.asarray(out)


def test_a_model_without_condim_4_keeps_three_rows_per_contact():
    for condim, width in ((3, 3), (4, 4), (6, 6)):
        sim = myriad.Simulator(myriad.load_xml(_ball_xml(condim, "1 0.02 0.01"), "ball"),
                               params=PARAMS)
        assert sim.device_model.layout.contact_width == width


@pytest.mark.parametrize("ratio", [0.5, 1.5])
def test_torsional_friction_holds_a_spin_torque_below_mu_n_and_passes_the_excess(ratio, device):
    """A torque about the vertical of `ratio` times mu_spin·m·g (mu_spin = 0.02 m, the ball's;
    the floor's is 0.005): below 1 the ball does not turn (under 0.01 rad/s for 1 s; MuJoCo's
    soft contact settles into a steady creep, its spin rising by less than 1 % of tau/I per
    second over the last 0.5 s); above, it spins up at (tau - mu_spin·m·g)/I within 5 %,
    as MuJoCo's does (within 5 % of it). At condim 3 nothing holds it: tau/I within 2 %."""
    mu_spin = 0.02
    tau = ratio * mu_spin * MASS * G
    xml = _ball_xml(4, f"1 {mu_spin} 0.0001")
    ours = _myriad_run(xml, 1.0, device, torque_z=tau)[:, 5]
    theirs = _mujoco_run(xml, 1.0, torque_z=tau)[:, 5]
    if ratio < 1:
        assert np.abs(ours).max() < 0.01
        # MuJoCo's soft contact turns the ball at a steady creep (0.74 rad/s) instead
        assert abs(theirs[-1] - theirs[29]) / 0.5 < 0.01 * tau / INERTIA
    else:
        expected = (tau - mu_spin * MASS * G) / INERTIA
        accel = (ours[-1] - ours[14]) / (45 / 60)          # from 0.25 s to 1 s
        accel_mujoco = (theirs[-1] - theirs[14]) / (45 / 60)
        assert accel == pytest.approx(expected, rel=0.05)
        assert accel == pytest.approx(accel_mujoco, rel=0.05)
    free = _myriad_run(_ball_xml(3, f"1 {mu_spin} 0.0001"), 0.5, device, torque_z=tau)[:, 5]
    assert (free[-1] - free[14]) / (15 / 60) == pytest.approx(tau / INERTIA, rel=0.02)


def test_rolling_friction_slows_a_rolling_ball_at_mu_roll_g_over_1_4_r(device):
    """A ball rolling at 1 m/s without slipping, mu_roll = 0.01 m (condim 6): the torque
    mu_roll·m·g about the tangent slows it at mu_roll·g / (1.4 R) = 0.70 m/s² (the friction
    force keeps it rolling: m·a·R + I·a/R = mu_roll·m·g), within 5 %, as MuJoCo's with an
    elliptic cone within 5 % (0.699; its default pyramidal cone gives 0.665, 5.1 % under the
    closed form, its soft contact bouncing the ball at ±5 cm/s); it keeps rolling (the contact point's speed under 1 cm/s). At condim 3 it rolls on (speed
    within 1 % of 1 m/s after 1 s)."""
    mu_roll, v0 = 0.01, 1.0
    qvel = [v0, 0.0, 0.0, 0.0, v0 / RADIUS, 0.0]     # angular: the ball's own axes (= world's)
    xml = _ball_xml(6, f"1 0.005 {mu_roll}", cone="elliptic")
    ours = _myriad_run(xml, 1.0, device, qvel=qvel)
    theirs = _mujoco_run(xml, 1.0, qvel=qvel)
    expected = mu_roll * G / (1.4 * RADIUS)
    decel = (ours[14, 0] - ours[-1, 0]) / (45 / 60)
    decel_mujoco = (theirs[14, 0] - theirs[-1, 0]) / (45 / 60)
    assert decel == pytest.approx(expected, rel=0.05)
    assert decel == pytest.approx(decel_mujoco, rel=0.05)
    # contact point: v + w × (-R z); the ball's axes stay the world's up to its spin about y
    slip = np.abs(ours[:, 0] - RADIUS * ours[:, 4])
    assert slip.max() < 0.01
    rolling = _myriad_run(_ball_xml(3, f"1 0.005 {mu_roll}"), 1.0, device, qvel=qvel)
    assert rolling[-1, 0] == pytest.approx(v0, rel=0.01)
