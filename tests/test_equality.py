"""Equality constraints (MuJoCo's <equality>: joint, connect, weld, tendon) are hard rows of the
solve: they hold to solver precision at the default `SimParams` (dt 1/60 s in 2 substeps, TGS
4 + 1), where MuJoCo's soft equalities give way by millimetres and dissipate energy."""

import mujoco
import numpy as np
import pytest
import torch

import myriad

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

# two fingers on slides; the second follows the first through MuJoCo's quartic coupling
# q2 - q2_0 = c0 + c1·(q1 - q1_0) + c2·(q1 - q1_0)², as a URDF <mimic> joint becomes
FINGERS = """<mujoco><option timestep="0.002"/>
<worldbody><body name="hand" pos="0 0 1">
  <body name="f1"><joint name="j1" type="slide" axis="1 0 0" range="-0.1 0.1"/>
    <geom type="box" size="0.01 0.01 0.05" mass="0.1"/></body>
  <body name="f2" pos="0 0.1 0"><joint name="j2" type="slide" axis="1 0 0" range="-0.1 0.1"/>
    <geom type="box" size="0.01 0.01 0.05" mass="0.3"/></body>
</body></worldbody>
<equality><joint joint1="j2" joint2="j1" polycoef="0.01 -1 0.5 0 0"/></equality>
<actuator><position joint="j1" kp="20" kv="2"/></actuator>
</mujoco>"""

# a parallelogram four-bar: the third link's free end is connected back to the world
FOUR_BAR = """<mujoco><option timestep="0.001"/>
<worldbody>
 <body name="a" pos="0 0 1"><joint name="ja" type="hinge" axis="0 1 0"/>
  <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/>
  <body name="b" pos="0.3 0 0"><joint name="jb" type="hinge" axis="0 1 0"/>
   <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.02" mass="1"/>
   <body name="c" pos="0 0 -0.4"><joint name="jc" type="hinge" axis="0 1 0"/>
    <geom type="capsule" fromto="0 0 0 -0.3 0 0" size="0.02" mass="1"/></body></body></body>
</worldbody>
<equality><connect body1="c" body2="world" anchor="-0.3 0 0"/></equality>
</mujoco>"""

# a free box welded where it starts, and a box welded to the end of a driven arm
WELDS = """<mujoco>
<worldbody>
 <body name="held" pos="0.5 0 0.5" euler="0.3 0.2 0.1"><freejoint/>
  <geom type="box" size="0.05 0.1 0.05" mass="0.5"/></body>
 <body name="arm" pos="0 0 1"><joint name="shoulder" type="hinge" axis="0 1 0"/>
  <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.02" mass="1"/></body>
 <body name="tool" pos="0.45 0 1.05"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
</worldbody>
<equality><weld body1="held"/><weld body1="tool" body2="arm"/></equality>
<actuator><position joint="shoulder" kp="200" kv="20"/></actuator>
</mujoco>"""


def _step_recording(sim, steps, record):
    out = []
    for _ in range(steps):
        sim.step()
        out.append(record(sim))
    return np.stack(out)


def test_a_mimic_joint_follows_its_leader_through_mujocos_polynomial():
    model = myriad.load_xml(FINGERS, "fingers.xml")
    assert model.neq == 1
    sim = myriad.Simulator(model, num_envs=2)
    sim.q = torch.tensor([0.0, 0.01])                                   # coupled at the start
    sim.ctrl = torch.tensor([[0.08], [-0.06]])
    q = _step_recording(sim, 120, lambda s: s.q.numpy().copy())       # 2 s
    lead, follow = q[..., 0], q[..., 1]
    assert np.abs(lead[-1] - [0.08, -0.06]).max() < 2e-3               # the drive got there
    expected = 0.01 - lead + 0.5 * lead ** 2
    assert np.abs(follow - expected).max() < 1e-5                      # hard: solver precision

    # against MuJoCo: the leader's motion (its drive moves both fingers, the follower's mass
    # reflected through the coupling) within 3 mm over the run (the gap peaks at 2.3 mm while
    # accelerating: Myriad's implicit drive at h = 1/120 s, MuJoCo at 0.002 s), and MuJoCo's
    # soft equality lets the follower lag by more than Myriad's error
    m, d = model.mj_model, mujoco.MjData(model.mj_model)
    d.qpos[:] = [0.0, 0.01]
    d.ctrl[:] = 0.08
    theirs = []
    for _ in range(120):
        for _ in range(round(sim.params.dt / m.opt.timestep)):
            mujoco.mj_step(m, d)
        theirs.append(d.qpos.copy())
    theirs = np.stack(theirs)
    assert np.abs(theirs[:, 0] - lead[:, 0]).max() < 3e-3
    assert np.abs(theirs[:, 1] - (0.01 - theirs[:, 0] + 0.5 * theirs[:, 0] ** 2)).max() > 1e-5


def test_a_connect_closes_a_four_bar_linkage_and_conserves_its_energy():
    model = myriad.load_xml(FOUR_BAR, "four_bar.xml")
    m = model.mj_model
    sim = myriad.Simulator(model, num_envs=1)
    sim.q = torch.tensor([[0.3, -0.3, 0.3]])    # a parallelogram, the loop closed
    sim.forward()
    tip = _step_recording(sim, 120, lambda s: s.body_pose[0, 2].numpy().copy())
    q = sim.q[0].numpy()
    # the free end of link c stays on the world point it started at: (0, 0, 0.6)
    x, y, z, w = tip[:, 3:].T
    u = np.stack([x, y, z], 1)
    arm = np.array([-0.3, 0.0, 0.0])
    end = tip[:, :3] + arm + 2 * w[:, None] * np.cross(u, arm) + 2 * np.cross(u, np.cross(u, arm))
    assert np.abs(end - [0.0, 0.0, 0.6]).max() < 2e-4
    assert abs(q[0] + q[1]) < 1e-3 and abs(q[0] - q[2]) < 1e-3        # still a parallelogram

    # energy, measured by MuJoCo on Myriad's states: a closed loop that swings for 2 s keeps
    # it within 1 % (MuJoCo's own soft connect dissipates 8 % of it over the same swing)
    energy = mujoco.MjData(m)
    m.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    sim.q = torch.tensor([[0.3, -0.3, 0.3]])
    sim.qd = torch.zeros(1, 3)
    sim.forward()
    seen = []
    for _ in range(120):
        sim.step()
        energy.qpos[:] = sim.q[0].numpy()
        energy.qvel[:] = sim.qd[0].numpy()
        mujoco.mj_forward(m, energy)
        seen.append(energy.energy.sum())
    seen = np.asarray(seen)
    assert np.ptp(seen) < 0.01 * abs(seen.mean())


def _quat_angle(a, b):
    """Angle (rad) between orientations a and b (xyzw, [..., 4])."""
    return 2 * np.arccos(np.clip(np.abs((a * b).sum(-1)), 0.0, 1.0))


def test_welds_hold_a_box_in_place_and_carry_one_on_a_moving_arm():
    model = myriad.load_xml(WELDS, "welds.xml")
    sim = myriad.Simulator(model, num_envs=1)
    held, arm, tool = (model.body_index(n) for n in ("held", "arm", "tool"))
    start = sim.body_pose[0].numpy().copy()
    sim.ctrl = torch.tensor([[1.2]])                      # swing the arm up by 1.2 rad
    poses = _step_recording(sim, 120, lambda s: s.body_pose[0].numpy().copy())
    assert abs(sim.q[0, 7].item() - 1.2) < 0.02          # the arm got there, carrying the tool
    # the free box stays where it was welded, against gravity
    assert np.abs(poses[:, held, :3] - start[held, :3]).max() < 2e-4
    assert _quat_angle(poses[:, held, 3:], start[held, 3:]).max() < 2e-3
    # the tool keeps its pose in the arm's frame: its distance from the shoulder and its
    # orientation relative to the arm's. While the arm whips round (3 rad/s), each substep's
    # rows are linear in the motion and the tool lags by about r·(ω·h)²/2 until the next
    # substep corrects it: 1.3 mm at 2 substeps, 0.36 mm at 4, 0.09 mm at 8 (at rest, 1e-7 m)
    reach = np.linalg.norm(poses[:, tool, :3] - poses[:, arm, :3], axis=-1)
    assert np.abs(reach - np.linalg.norm(start[tool, :3] - start[arm, :3])).max() < 2e-3
    assert np.abs(reach[-20:] - np.linalg.norm(start[tool, :3] - start[arm, :3])).max() < 1e-5
    rel0 = _relative(start[arm, 3:], start[tool, 3:])
    rel = _relative(poses[:, arm, 3:], poses[:, tool, 3:])
    assert _quat_angle(rel, rel0).max() < 5e-3


def _relative(a, b):
    """conj(a) · b for xyzw quaternions [..., 4]."""
    ax, ay, az, aw = np.moveaxis(-a[..., :3], -1, 0).tolist() + [a[..., 3]]
    bx, by, bz, bw = np.moveaxis(b, -1, 0)
    return np.stack([aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx,
                     aw * bz + ax * by - ay * bx + az * bw,
                     aw * bw - ax * bx - ay * by - az * bz], -1)


def test_a_tendon_equality_couples_two_tendon_lengths():
    xml = """<mujoco><worldbody>
     <body pos="0 0 1"><joint name="a" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body>
     <body pos="0 1 1"><joint name="b" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="2"/>
      <body pos="0.3 0 0"><joint name="c" type="hinge" axis="0 1 0"/>
       <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body></body>
    </worldbody>
    <tendon><fixed name="ta"><joint joint="a" coef="1"/></fixed>
            <fixed name="tbc"><joint joint="b" coef="1"/><joint joint="c" coef="0.5"/></fixed></tendon>
    <equality><tendon tendon1="ta" tendon2="tbc" polycoef="0 2 0 0 0"/></equality>
    </mujoco>"""
    model = myriad.load_xml(xml, "tendons.xml")
    sim = myriad.Simulator(model, num_envs=1)
    q = _step_recording(sim, 90, lambda s: s.q[0].numpy().copy())      # falling under gravity
    assert np.ptp(q[:, 0]) > 0.5                                        # it moved
    assert np.abs(q[:, 0] - 2 * (q[:, 1] + 0.5 * q[:, 2])).max() < 1e-4


def test_an_equality_can_be_switched_off_per_env():
    model = myriad.load_xml(FINGERS, "fingers.xml")
    sim = myriad.Simulator(model, num_envs=2)
    assert sim.eq_active.tolist() == [[1], [1]]
    sim.eq_active = torch.tensor([[1], [0]], dtype=torch.int32)
    sim.joint_force = torch.tensor([0.0, 1.0])              # push the follower only
    q = _step_recording(sim, 30, lambda s: s.q.numpy().copy())
    coupled = 0.01 - q[:, 0, 0] + 0.5 * q[:, 0, 0] ** 2
    assert np.abs(q[:, 0, 1] - coupled).max() < 1e-5       # env 0: still coupled
    assert q[-1, 1, 1] > 0.05 and abs(q[-1, 1, 0]) < 1e-3  # env 1: the follower ran off alone


def test_the_panda_of_example_robot_data_loads_with_its_mimic_finger():
    """MuJoCo turns the URDF's <mimic> into a joint equality: finger 2 = finger 1. Under 1 s of
    the corpus's random joint torques (each finger pushed on its own), both fingers move as
    one."""
    corpus = pytest.importorskip("corpus")          # benchmarks/corpus.py
    if corpus.robots_folder() is None:
        pytest.skip("example-robot-data is not installed (pip install -e '.[all]')")
    loaders = {name: loader for name, _, loader in corpus.corpus_models()}
    model, _ = loaders["panda/panda"]()
    # (its link pair that overlaps at the start, two joints apart, is no candidate:
    # SimParams.filter_ancestors)
    sim = myriad.Simulator(model, num_envs=2)
    fingers = [model.jnt_qposadr[model.joint_index(f"panda_finger_joint{k}")] for k in (1, 2)]
    kind, inputs = corpus.random_inputs(model, 10, 2, torch.Generator().manual_seed(0))
    spread, gap = 0.0, 0.0
    for step in range(60):
        if step % 6 == 0:
            setattr(sim, kind, inputs[step // 6])
        sim.step()
        q = sim.q[:, fingers]
        spread = max(spread, (q[:, 0] - q[:, 0].mean()).abs().max().item())
        gap = max(gap, (q[:, 0] - q[:, 1]).abs().max().item())
    assert torch.isfinite(sim.q).all()
    assert spread > 1e-3            # the fingers did move
    assert gap < 1e-5
