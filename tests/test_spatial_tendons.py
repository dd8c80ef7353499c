"""Spatial tendons (issue 40): paths through sites, wrapping round spheres and cylinders
(with side sites), pulleys; their lengths and moment arms against MuJoCo's, and the limits,
springs and actuators that act through them."""

import mujoco
import numpy as np
import pytest
import torch

import myriad
from oracle import free_motion_mujoco, random_qpos

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

# an arm whose flexor runs from the world over a cylinder at the elbow (a side site keeps it
# on top) and round a sphere at the wrist, and a split tendon that pulleys share between two
# points of the hand
ARM = """<mujoco><option gravity="0 0 -9.81"/><worldbody>
<site name="anchor" pos="0 0 2"/>
<body name="upper" pos="0 0 1.5"><joint name="shoulder" type="hinge" axis="0 1 0" damping="0.05"/>
  <geom name="upper_geom" type="capsule" fromto="0 0 0 0.4 0 0" size="0.03" mass="1" contype="0" conaffinity="0"/>
  <site name="s_upper" pos="0.2 0 0.05"/>
  <geom name="elbow_wrap" type="cylinder" pos="0.4 0 0" zaxis="0 1 0" size="0.05 0.05" contype="0" conaffinity="0" mass="0"/>
  <site name="side" pos="0.4 0 0.2"/>
  <body name="lower" pos="0.4 0 0"><joint name="elbow" type="hinge" axis="0 1 0" damping="0.05"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.025" mass="0.6" contype="0" conaffinity="0"/>
    <site name="s_lower" pos="0.15 0 0.03"/>
    <geom name="knob" type="sphere" pos="0.3 0 0" size="0.04" contype="0" conaffinity="0" mass="0"/>
    <body name="hand" pos="0.3 0 0"><joint name="wrist" type="hinge" axis="0 0 1" damping="0.02"/>
      <geom type="box" pos="0.05 0 0" size="0.05 0.02 0.02" mass="0.2" contype="0" conaffinity="0"/>
      <site name="s_hand" pos="0.08 0.02 0"/><site name="s_hand2" pos="0.08 -0.02 0"/>
</body></body></body></worldbody>
<tendon>
  <spatial name="flexor" stiffness="3" damping="0.1" range="0.3 1.2" limited="true">
    <site site="anchor"/><site site="s_upper"/><geom geom="elbow_wrap" sidesite="side"/><site site="s_lower"/>
    <geom geom="knob"/><site site="s_hand"/>
  </spatial>
  <spatial name="split">
    <site site="s_upper"/><site site="s_lower"/>
    <pulley divisor="2"/><site site="s_lower"/><site site="s_hand"/>
    <pulley divisor="2"/><site site="s_lower"/><site site="s_hand2"/>
  </spatial>
</tendon>
<actuator><motor name="pull" tendon="flexor" gear="2"/><general name="grip" tendon="split" gainprm="5" biastype="affine" biasprm="0 -20 -1"/></actuator>
</mujoco>"""


def _mujoco_tendons(model, qpos):
    mj = model.mj_model
    mj.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    d = mujoco.MjData(mj)
    d.qpos[:] = qpos
    mujoco.mj_forward(mj, d)
    # the geoms the flexor's path wrapped round (MuJoCo lists each wrap's two tangent points)
    path = d.wrap_obj.ravel()[:d.ten_wrapnum[0]]
    return (d.ten_length.copy(), d.ten_J.reshape(mj.ntendon, mj.nv).copy(),
            frozenset(int(g) for g in path if g >= 0))


def test_lengths_and_moment_arms_match_mujoco(device):
    """Over random poses (wrapped and unwrapped, both sides of each geom): every tendon's length
    and its derivative by each dof, as MuJoCo computes them."""
    model = myriad.load_xml(ARM, "arm")
    assert model.tendon_spatial.tolist() == [0, 1]
    rng = np.random.default_rng(0)
    poses = np.stack([random_qpos(model.mj_model, rng, scale=1.2) for _ in range(64)])
    sim = myriad.Simulator(model, num_envs=len(poses), device=device)
    sim.q = torch.as_tensor(poses, dtype=torch.float32, device=sim.torch_device)
    sim.forward()
    lengths = sim.data.state.ten_length.numpy()
    arms = sim.data.state.ten_J.numpy()
    cases = set()
    for k, qpos in enumerate(poses):
        length, jac, wrapped = _mujoco_tendons(model, qpos)
        np.testing.assert_allclose(lengths[k], length, atol=2e-5, err_msg=f"pose {k}")
        np.testing.assert_allclose(arms[k], jac, atol=2e-4, err_msg=f"pose {k}")
        cases.add(wrapped)
    cylinder, sphere = model.geom_names.index("elbow_wrap"), model.geom_names.index("knob")
    # the poses cover: no wrap, each geom alone, both
    assert cases == {frozenset(), frozenset({cylinder}), frozenset({sphere}),
                     frozenset({cylinder, sphere})}, cases


def test_actuated_arm_matches_mujoco(device):
    """A motor and an affine servo pulling through spatial tendons, with the tendon spring and
    damper: the arm moves as MuJoCo's (its spring is explicit there, implicit here: small
    stiffness, so the two steps agree closely)."""
    model = myriad.load_xml(ARM.replace('limited="true"', 'limited="false"'), "arm")
    mj, d = free_motion_mujoco(model, 0.002)
    mj.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1))
    for step in range(400):
        u = np.array([2.0 * np.sin(step * 0.02), 0.3 + 0.2 * np.cos(step * 0.03)])
        d.ctrl[:] = u
        sim.ctrl[0] = torch.as_tensor(u, dtype=torch.float32)
        mujoco.mj_step(mj, d)
        sim.step()
    np.testing.assert_allclose(sim.q[0].cpu().numpy(), d.qpos, atol=2e-3)
    np.testing.assert_allclose(sim.actuator_force[0].cpu().numpy(), d.actuator_force, atol=2e-2)


def test_tendon_limit_holds(device):
    """The flexor's upper length limit (1.2 m) holds a hanging arm pulled down by a motor."""
    model = myriad.load_xml(ARM, "arm")
    sim = myriad.Simulator(model, num_envs=2, device=device)
    sim.ctrl[:, 0] = torch.tensor([-30.0, 0.0])   # the motor shortens the flexor: pull the other way
    worst = 0.0
    for _ in range(240):
        sim.step()
        sim.forward()
        worst = max(worst, float(sim.data.state.ten_length.numpy()[:, 0].max()))
    assert np.all(np.isfinite(sim.q.cpu().numpy()))
    assert worst < 1.2 + 2e-3, worst
