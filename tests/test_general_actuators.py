"""MuJoCo's general actuators as users write them (issue 40): fixed-tendon transmissions, affine
gains and biases, activation dynamics (integrator, filter, filterexact, actearly, actlimited),
against MuJoCo stepped on the same controls, and the features still refused."""

import math

import mujoco
import numpy as np
import pytest
import torch

import myriad
from oracle import free_motion_mujoco

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

# a parallel gripper driven through a fixed tendon, as Menagerie's Robotiq 2F-85 and ALOHA
# grippers are, on a lifted base and with a swinging arm: every actuator here is explicit in
# MuJoCo's Euler step and in ours (tendon transmissions, or no position/velocity bias), so the
# two step the same equations
GRIPPER = """<mujoco><option timestep="0.002"/><worldbody>
<body name="base" pos="0 0 1">
  <joint name="lift" type="slide" axis="0 0 1" damping="2"/>
  <geom type="box" size="0.05 0.05 0.02" mass="1" contype="0" conaffinity="0"/>
  <body name="left" pos="0.05 0 0"><joint name="l" type="slide" axis="1 0 0" damping="0.5"/>
    <geom type="box" size="0.01 0.02 0.04" mass="0.1" contype="0" conaffinity="0"/></body>
  <body name="right" pos="-0.05 0 0"><joint name="r" type="slide" axis="-1 0 0" damping="0.5"/>
    <geom type="box" size="0.01 0.02 0.04" mass="0.1" contype="0" conaffinity="0"/></body>
  <body name="arm" pos="0 0 -0.1"><joint name="h" type="hinge" axis="0 1 0" damping="0.1"/>
    <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.02" mass="0.3" contype="0" conaffinity="0"/>
    <body name="tip" pos="0.2 0 0"><joint name="h2" type="hinge" axis="0 1 0" damping="0.05"/>
      <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.015" mass="0.1" contype="0" conaffinity="0"/>
    </body></body>
</body></worldbody>
<tendon><fixed name="split"><joint joint="l" coef="0.5"/><joint joint="r" coef="0.5"/></fixed>
  <fixed name="arm_sum"><joint joint="h" coef="1"/><joint joint="h2" coef="-0.5"/></fixed></tendon>
<actuator>
  <general name="grip" tendon="split" ctrlrange="0 255" ctrllimited="true" forcerange="-5 5"
           forcelimited="true" gainprm="0.02 0 0" biastype="affine" biasprm="0 -100 -10"/>
  <general name="lift" joint="lift" dyntype="filter" dynprm="0.05" gainprm="30"/>
  <general name="swing" joint="h" gaintype="affine" gainprm="0.5 0.2 0.05"
           biastype="affine" biasprm="0.1 0 0"/>
  <general name="fold" tendon="arm_sum" dyntype="filterexact" dynprm="0.02" gainprm="0.3"
           biastype="affine" biasprm="0 -2 -0.1" actearly="true"/>
  <general name="wrist" joint="h2" dyntype="integrator" actlimited="true" actrange="-0.4 0.3"
           gainprm="0.2" ctrlrange="-1 1" ctrllimited="true"/>
  <motor name="squeeze" tendon="split" gear="3" ctrlrange="-1 1" ctrllimited="true"/>
</actuator></mujoco>"""


def test_gripper_actuators_match_mujoco(device):
    """Tendon transmissions, affine gains and biases, every kind of activation: q, qd, the
    activations and the actuator forces follow MuJoCo's Euler step over 400 steps of random
    ctrl (often outside the ctrl and force ranges)."""
    model = myriad.load_xml(GRIPPER, "gripper")
    assert [int(k) for k in model.actuator_kind] == [3, 0, 3, 3, 0, 0]   # affine or motor
    mj, d = free_motion_mujoco(model, 0.002)
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1))
    rng = np.random.default_rng(1)
    scale = np.array([300.0, 1.0, 2.0, 3.0, 2.0, 1.5])
    with_act = mj.actuator_actadr >= 0
    for step in range(400):
        if step % 20 == 0:
            u = rng.uniform(-1, 1, size=6) * scale
            d.ctrl[:] = u
            sim.ctrl[0] = torch.as_tensor(u, dtype=torch.float32)
        mujoco.mj_step(mj, d)
        sim.step()
    np.testing.assert_allclose(sim.q[0].cpu().numpy(), d.qpos, atol=2e-4)
    np.testing.assert_allclose(sim.qd[0].cpu().numpy(), d.qvel,
                               atol=2e-4 * (1 + np.abs(d.qvel).max()))
    act = sim.act[0].cpu().numpy()
    np.testing.assert_allclose(act[with_act], d.act[mj.actuator_actadr[with_act]], atol=1e-4)
    assert np.all(act[~with_act] == 0)
    # MuJoCo's actuator_force is that of its last step's start: ours is too
    np.testing.assert_allclose(sim.actuator_force[0].cpu().numpy(), d.actuator_force,
                               atol=1e-3 * (1 + np.abs(d.actuator_force).max()))
    np.testing.assert_allclose(sim.dof_actuator_force[0].cpu().numpy(), d.qfrc_actuator,
                               atol=1e-3 * (1 + np.abs(d.qfrc_actuator).max()))


def test_tendon_actuator_moves_both_fingers_equally(device):
    """A tendon's force reaches each of its joints times its coefficient: the symmetric
    gripper's fingers move together, and the tendon's length settles where the affine bias
    balances the gain: 0.02·ctrl = 100·length."""
    model = myriad.load_xml(GRIPPER, "gripper")
    sim = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1, gravity=(0, 0, 0)))
    sim.ctrl[:, 0] = torch.tensor([100.0, 255.0])
    for _ in range(1500):
        sim.step()
    left, right = model.joint_index("l"), model.joint_index("r")
    q = sim.q.cpu().numpy()
    np.testing.assert_allclose(q[:, left], q[:, right], atol=1e-6)
    length = 0.5 * q[:, left] + 0.5 * q[:, right]
    np.testing.assert_allclose(length, 0.02 * np.array([100.0, 255.0]) / 100.0, rtol=1e-3)


def test_intvelocity_integrates_its_ctrl_within_its_range(device):
    """MuJoCo's intvelocity: the activation integrates ctrl (a velocity) and is clamped to
    actrange; the joint, a position servo on the activation, follows it."""
    model = myriad.load_xml("""<mujoco><option gravity="0 0 0"/><worldbody>
      <body><joint name="x" type="slide" axis="1 0 0"/><geom type="sphere" size="0.1" mass="1"/>
      </body></worldbody><actuator>
      <intvelocity name="v" joint="x" kp="400" kv="40" actrange="-0.5 0.25"/></actuator></mujoco>""",
                            "intvelocity")
    assert model.actuator_kind[0] == myriad.physics.types.ActuatorKind.POSITION
    h = 0.01
    sim = myriad.Simulator(model, num_envs=2, device=device, params=myriad.SimParams(dt=h, substeps=1))
    sim.ctrl[:, 0] = torch.tensor([0.1, -10.0])
    for _ in range(10):
        sim.step()
    np.testing.assert_allclose(sim.act[:, 0].cpu().numpy(), [0.1 * 10 * h, -0.5], rtol=1e-5)
    for _ in range(300):
        sim.step()
    np.testing.assert_allclose(sim.act[:, 0].cpu().numpy(), [0.25, -0.5], rtol=1e-6)
    np.testing.assert_allclose(sim.q[:, 0].cpu().numpy(), [0.25, -0.5], atol=1e-3)


def test_filter_time_constant(device):
    """A filtered motor's activation relaxes to ctrl as 1 - exp(-t/tau) (filterexact: to float
    precision at any step; filter: Euler's (1 - h/tau)^n)."""
    tau, h, n = 0.05, 0.01, 20
    model = myriad.load_xml(f"""<mujoco><option gravity="0 0 0"/><worldbody>
      <body><joint name="x" type="slide" axis="1 0 0"/><geom type="sphere" size="0.1" mass="1"/>
      </body></worldbody><actuator>
      <general joint="x" dyntype="filterexact" dynprm="{tau}"/>
      <general joint="x" dyntype="filter" dynprm="{tau}"/></actuator></mujoco>""", "filters")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=h, substeps=1))
    sim.ctrl[:] = 2.0
    for _ in range(n):
        sim.step()
    exact, euler = sim.act[0].cpu().numpy()
    assert exact == pytest.approx(2.0 * (1 - math.exp(-n * h / tau)), rel=1e-5)
    assert euler == pytest.approx(2.0 * (1 - (1 - h / tau) ** n), rel=1e-5)


@pytest.mark.parametrize("actuator, named", [
    ('<muscle name="mu" joint="x"/>', "'mu': mjDYN_MUSCLE activation dynamics"),
    ('<motor name="st" site="s" refsite="s" gear="1 0 0 0 0 0"/>', "'st': a site transmission "
     "with a refsite"),
    ('<general name="dl" joint="x" delay="0.01" nsample="2"/>', "'dl': actuator delay"),
])
def test_unsupported_actuators_are_named(actuator, named):
    xml = f"""<mujoco><worldbody><body><joint name="x" type="slide" axis="1 0 0" range="-1 1"/>
      <geom type="sphere" size="0.1" mass="1"/><site name="s"/></body></worldbody>
      <actuator>{actuator}</actuator></mujoco>"""
    with pytest.raises(myriad.ModelError, match=named):
        myriad.load_xml(xml, "unsupported")


# a quadrotor as Menagerie's Skydio X2 and Crazyflie drive theirs: thrust and yaw moment at four
# sites (gear "0 0 1 0 0 ±k"), plus a thruster on a hinged boom and a position-like servo
# pushing along a site's axis (a site actuator's length is 0, its speed along the wrench)
QUADROTOR = """<mujoco><option timestep="0.002"/><worldbody>
<body name="frame" pos="0 0 1"><freejoint/>
  <geom type="box" size="0.1 0.1 0.02" mass="0.8" contype="0" conaffinity="0"/>
  <site name="r1" pos="0.1 0.1 0"/><site name="r2" pos="-0.1 0.1 0"/>
  <site name="r3" pos="-0.1 -0.1 0"/><site name="r4" pos="0.1 -0.1 0" euler="0.2 0 0"/>
  <body name="boom" pos="0 0 -0.05"><joint name="tilt" type="hinge" axis="0 1 0" damping="0.01"/>
    <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.1" contype="0" conaffinity="0"/>
    <site name="tip" pos="0.2 0 0" euler="0 0.3 0"/></body>
</body></worldbody>
<actuator>
  <motor site="r1" gear="0 0 1 0 0 -0.02" ctrlrange="0 6" ctrllimited="true"/>
  <motor site="r2" gear="0 0 1 0 0 0.02" ctrlrange="0 6" ctrllimited="true"/>
  <motor site="r3" gear="0 0 1 0 0 -0.02" ctrlrange="0 6" ctrllimited="true"/>
  <motor site="r4" gear="0 0 1 0 0 0.02" ctrlrange="0 6" ctrllimited="true"/>
  <general site="tip" gear="1 0 0.5 0 0.1 0" gainprm="0.5" biastype="affine" biasprm="0 0 -0.2"
           dyntype="filter" dynprm="0.03"/>
</actuator></mujoco>"""


def test_site_thrusters_match_mujoco(device):
    """Site transmissions: a wrench at the site along its 6D gear, on every dof that carries it
    (the free frame's, and the boom's hinge for the tip thruster)."""
    model = myriad.load_xml(QUADROTOR, "quadrotor")
    assert model.actuator_trnsite.tolist() == [0, 1, 2, 3, 4]
    mj, d = free_motion_mujoco(model, 0.002)
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1))
    rng = np.random.default_rng(3)
    for step in range(300):
        if step % 25 == 0:
            u = np.concatenate([rng.uniform(1.5, 3.0, 4), rng.uniform(-1, 1, 1)])
            d.ctrl[:] = u
            sim.ctrl[0] = torch.as_tensor(u, dtype=torch.float32)
        mujoco.mj_step(mj, d)
        sim.step()
    q = model.qpos_to_mujoco(sim.q[0].cpu().numpy())
    np.testing.assert_allclose(q, d.qpos, atol=5e-4)
    np.testing.assert_allclose(sim.qd[0].cpu().numpy(), d.qvel, atol=2e-3)
    np.testing.assert_allclose(sim.dof_actuator_force[0].cpu().numpy(), d.qfrc_actuator,
                               atol=1e-3 * (1 + np.abs(d.qfrc_actuator).max()))
    np.testing.assert_allclose(sim.actuator_force[0].cpu().numpy(), d.actuator_force, atol=1e-3)
