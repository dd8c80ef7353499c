"""Mocap bodies (issue 40): kinematic bodies each env poses through `sim.mocap_pos` and
`sim.mocap_quat`, carrying children, touching other bodies, and holding a weld (MuJoCo's
teleoperation idiom)."""

import mujoco
import numpy as np
import pytest
import torch

import myriad
from oracle import free_motion_mujoco

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

PENDULUM_ON_MOCAP = """<mujoco><worldbody>
<body name="handle" mocap="true" pos="0 0 1" quat="1 0 0 0">
  <geom type="box" size="0.05 0.05 0.05" contype="0" conaffinity="0"/>
  <body name="rod" pos="0 0 -0.05"><joint name="swing" type="hinge" axis="0 1 0" damping="0.01"/>
    <geom type="capsule" fromto="0 0 0 0.3 0 -0.3" size="0.02" mass="0.5" contype="0" conaffinity="0"/>
    <body name="rod2" pos="0.3 0 -0.3"><joint name="swing2" type="hinge" axis="1 0 0"/>
      <geom type="capsule" fromto="0 0 0 0 0.2 0" size="0.02" mass="0.2" contype="0" conaffinity="0"/>
</body></body></body></worldbody></mujoco>"""


def _mujoco_quat(xyzw):
    return np.asarray([xyzw[3], xyzw[0], xyzw[1], xyzw[2]])


def test_pendulum_hanging_from_a_moving_mocap_body_matches_mujoco(device):
    """A double pendulum on a mocap body moved and turned every step: the same motion as
    MuJoCo's (both take a mocap body as at rest: moving it carries its children's frames along
    without any inertial force), and sim.body_pose of the handle is the pose written."""
    model = myriad.load_xml(PENDULUM_ON_MOCAP, "mocap_pendulum")
    assert model.nmocap == 1 and model.body_mocapid.tolist() == [0, -1, -1]
    mj, d = free_motion_mujoco(model, 0.002)
    sim = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(dt=0.002, substeps=1))
    np.testing.assert_allclose(sim.mocap_pos[0, 0].cpu().numpy(), [0, 0, 1])
    for step in range(500):
        t = step * 0.002
        pos = np.array([0.3 * np.sin(3 * t), 0.1 * t, 1.0 + 0.2 * np.cos(2 * t)])
        angle = 0.8 * np.sin(2 * t)
        xyzw = np.array([0.0, 0.0, np.sin(angle / 2), np.cos(angle / 2)])
        d.mocap_pos[0], d.mocap_quat[0] = pos, _mujoco_quat(xyzw)
        sim.mocap_pos[0, 0] = torch.as_tensor(pos, dtype=torch.float32)
        sim.mocap_quat[0, 0] = torch.as_tensor(xyzw, dtype=torch.float32)
        mujoco.mj_step(mj, d)
        sim.step()
    np.testing.assert_allclose(sim.q[0].cpu().numpy(), d.qpos, atol=2e-4)
    np.testing.assert_allclose(sim.qd[0].cpu().numpy(), d.qvel, atol=2e-3)
    np.testing.assert_allclose(sim.body_pose[0, 0, :3].cpu().numpy(), pos, atol=1e-6)
    # env 1 kept its handle where the model put it, and swings as MuJoCo's pendulum on a
    # handle left alone
    np.testing.assert_allclose(sim.body_pose[1, 0, :3].cpu().numpy(), [0, 0, 1], atol=1e-6)
    still = mujoco.MjData(mj)
    for _ in range(500):
        mujoco.mj_step(mj, still)
    np.testing.assert_allclose(sim.q[1].cpu().numpy(), still.qpos, atol=2e-4)


def test_mocap_paddle_lifts_a_box_by_contact(device):
    """A mocap platform raised under a free box carries it up: contacts with a mocap body push
    like contacts with the ground."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <geom type="plane" size="2 2 0.1"/>
      <body name="platform" mocap="true" pos="0 0 0.05"><geom type="box" size="0.3 0.3 0.05"/></body>
      <body name="box" pos="0 0 0.2"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="0.5"/></body>
      </worldbody></mujoco>""", "paddle")
    sim = myriad.Simulator(model, num_envs=2, device=device, params=myriad.SimParams(dt=1 / 120))
    for _ in range(60):
        sim.step()
    box = model.body_index("box")
    assert sim.body_pose[0, box, 2].item() == pytest.approx(0.15, abs=3e-3)   # resting on it
    for step in range(120):      # env 0's platform rises 0.3 m in 1 s; env 1's stays
        sim.mocap_pos[0, 0, 2] = 0.05 + 0.3 * min(1.0, (step + 1) / 120)
        sim.step()
    for _ in range(60):
        sim.step()
    z = sim.body_pose[:, box, 2].cpu().numpy()
    np.testing.assert_allclose(z, [0.45, 0.15], atol=5e-3)


def test_weld_to_mocap_drags_a_body_along(device):
    """MuJoCo's teleoperation idiom: a free body welded to a mocap body follows its pose."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <body name="target" mocap="true" pos="0 0 1"><geom type="sphere" size="0.01" contype="0" conaffinity="0"/></body>
      <body name="hand" pos="0 0 1"><freejoint/><geom type="box" size="0.05 0.03 0.02" mass="0.4"/></body>
      </worldbody><equality><weld body1="hand" body2="target"/></equality></mujoco>""", "teleop")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=1 / 120))
    goal = np.array([0.2, -0.1, 1.3])
    xyzw = np.array([0.0, np.sin(0.4), 0.0, np.cos(0.4)])
    sim.mocap_pos[0, 0] = torch.as_tensor(goal, dtype=torch.float32)
    sim.mocap_quat[0, 0] = torch.as_tensor(xyzw, dtype=torch.float32)
    for _ in range(120):
        sim.step()
    hand = model.body_index("hand")
    pose = sim.body_pose[0, hand].cpu().numpy()
    np.testing.assert_allclose(pose[:3], goal, atol=1e-3)
    assert abs(np.dot(pose[3:], xyzw)) == pytest.approx(1.0, abs=1e-5)
