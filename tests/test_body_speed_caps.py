"""Body speed caps (PhysX's maxAngularVelocity / maxLinearVelocity, Isaac Gym's AssetOptions
max_angular_velocity 64 rad/s and max_linear_velocity 1000 m/s by default): a body faster than
its cap feels the wrench that would bring it back to the cap in one substep were it free."""

import math

import mujoco
import numpy as np
import pytest
import torch

import myriad

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

# a free box (principal axes along its frame) and a pendulum: a rod on a hinge about z
BODIES = """<mujoco><option gravity="0 0 0"/><worldbody>
<body name="box" pos="0 0 1"><freejoint/>
  <geom type="box" size="0.2 0.1 0.05" mass="2" contype="0" conaffinity="0"/></body>
<body name="rod" pos="2 0 1"><joint name="hinge" type="hinge" axis="0 0 1"/>
  <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02" mass="0.5" contype="0"
        conaffinity="0"/></body>
</worldbody></mujoco>"""


def spun(device, spin, speed, hinge, **caps):
    """One substep of 10 ms from the box spinning at `spin` rad/s about its z axis and moving
    at `speed` m/s along x, the rod turning at `hinge` rad/s; the new qd (the dofs' own speed
    cap out of the way)."""
    model = myriad.load_xml(BODIES, "spun")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(
        dt=0.01, substeps=1, max_joint_velocity=1e4, **caps))
    qd = torch.zeros(1, model.nv)
    qd[0, 0], qd[0, 5], qd[0, 6] = speed, spin, hinge
    sim.qd = qd.to(sim.torch_device)
    sim.step()
    return sim.qd[0].cpu().double().numpy(), model


def test_free_body_is_brought_back_to_its_caps(device):
    """Spinning about a principal axis (no gyroscopic torque), the box is at its caps after one
    substep; below them nothing changes, bit for bit against no cap at all."""
    qd, _ = spun(device, 100.0, 2000.0, 0.0)
    assert qd[5] == pytest.approx(64.0, rel=1e-5)
    assert qd[0] == pytest.approx(1000.0, rel=1e-5)
    qd, _ = spun(device, 100.0, 2000.0, 0.0, max_angular_velocity=30.0, max_linear_velocity=5.0)
    assert qd[5] == pytest.approx(30.0, rel=1e-5) and qd[0] == pytest.approx(5.0, rel=1e-5)
    slow, _ = spun(device, 50.0, 900.0, 50.0)
    free, _ = spun(device, 50.0, 900.0, 50.0, max_angular_velocity=math.inf,
                   max_linear_velocity=math.inf)
    assert np.array_equal(slow, free) and slow[5] == pytest.approx(50.0)


def test_a_link_shares_the_pull_with_its_joint(device):
    """The rod's cap pulls with the torque -I·ω·(1 - cap/ω)/h about its center of mass, which
    its hinge turns into the rod's rotation about the hinge, whose inertia is the rod's own plus
    m·r²: it slows by that share only, never to the cap, and its center of mass's speed (ω·r)
    has no cap of its own here."""
    qd, model = spun(device, 0.0, 0.0, 100.0)
    mj = model.mj_model
    rod = mj.body("rod").id
    frame = np.zeros(9)
    mujoco.mju_quat2Mat(frame, mj.body_iquat[rod])
    frame = frame.reshape(3, 3)                          # the rod's principal axes
    own = (frame @ np.diag(mj.body_inertia[rod]) @ frame.T)[2, 2]  # about its center, along z
    r = np.linalg.norm(mj.body_ipos[rod])
    about_hinge = own + mj.body_mass[rod] * r * r
    expected = 100.0 - own / about_hinge * (100.0 - 64.0)
    assert qd[6] == pytest.approx(expected, rel=1e-4)
    assert 64.0 < qd[6] < 99.0


def test_caps_are_per_env_and_per_body(device):
    """`sim.body_max_angular_velocity` [envs, bodies]: env 0 at the default, env 1 without cap
    on the box, env 2 with the box capped at 10 rad/s."""
    model = myriad.load_xml(BODIES, "spun")
    sim = myriad.Simulator(model, num_envs=3, device=device,
                           params=myriad.SimParams(dt=0.01, substeps=1))
    box = model.body_names.index("box")
    caps = sim.body_max_angular_velocity.clone()
    assert torch.all(caps == 64.0) and torch.all(sim.body_max_linear_velocity == 1000.0)
    caps[1, box], caps[2, box] = math.inf, 10.0
    sim.body_max_angular_velocity = caps
    qd = torch.zeros(3, model.nv, device=sim.torch_device)
    qd[:, 5] = 100.0
    sim.qd = qd
    sim.step()
    np.testing.assert_allclose(sim.qd[:, 5].cpu().numpy(), [64.0, 100.0, 10.0], rtol=1e-5)


def test_bad_caps_are_named():
    for name in ("max_angular_velocity", "max_linear_velocity"):
        for bad in (0.0, -1.0, float("nan")):
            with pytest.raises(ValueError, match=name):
                myriad.SimParams(**{name: bad})
