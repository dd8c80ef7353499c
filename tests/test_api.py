"""The Isaac Gym-style tensor API: scene composition, state tensors, writers, indexed resets."""

import math
import platform

import mujoco
import numpy as np
import pytest
import torch
import warp as wp

import myriad
from myriad.api import Scene

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

ANT = myriad.asset_path("ant.xml")
N = 4


def box_xml(tmp_path, size=0.1, mass=2.0):
    path = tmp_path / "box.xml"
    path.write_text(f"""<mujoco><worldbody><body name="box">
        <geom type="box" size="{size} {size} {size}" mass="{mass}"/></body></worldbody></mujoco>""")
    return str(path)


@pytest.fixture(scope="module")
def two_ants(device):
    scene = Scene().add_ground()
    scene.add_actor("a", ANT, pos=(0, 0, 0.62))
    scene.add_actor("b", ANT, pos=(3, 1, 0.62), quat=(0, 0, math.sin(0.4), math.cos(0.4)),
                    dof_mode="position", stiffness=40.0, damping=2.0)
    return scene.build(N, device)


def test_composed_scene_names_shapes_and_start_poses(two_ants):
    e = two_ants
    assert (e.num_actors, e.num_dofs, e.num_bodies, e.num_sensors) == (2, 16, 18, 8)
    assert e.dof_names[:2] == ["a/hip_1", "a/ankle_1"] and e.dof_names[8] == "b/hip_1"
    assert e.actor_dof_slices == {"a": slice(0, 8), "b": slice(8, 16)}
    assert e.root_states.shape == (N, 2, 13)
    assert e.dof_state.shape == (N, 16, 2) and e.dof_pos.shape == e.dof_vel.shape == (N, 16)
    assert e.rigid_body_states.shape == (N, 18, 13)
    assert e.net_contact_force.shape == (N, 18, 3) and e.force_sensors.shape == (N, 8, 6)
    assert e.dof_forces.shape == (N, 16)
    root = e.root_states[0].cpu()
    torch.testing.assert_close(root[0, :7], torch.tensor([0, 0, 0.62, 0, 0, 0, 1.0]))
    torch.testing.assert_close(root[1, :7], torch.tensor(
        [3, 1, 0.62, 0, 0, math.sin(0.4), math.cos(0.4)]), atol=1e-6, rtol=0)
    # the ankles start at the model's reference angle (60 deg)
    torch.testing.assert_close(e.dof_pos[:, 1].cpu(), torch.full((N,), math.radians(60)))
    # lookups: full names, or bare names when unique
    assert e.dof_index("b/ankle_2") == 11 and e.actor_index("b") == 1
    assert e.body_index("a/torso") == 0 and e.sensor_index("b/foot_1") == 4
    with pytest.raises(KeyError, match="ambiguous"):
        e.dof_index("hip_1")
    with pytest.raises(KeyError, match="no DOF named 'knee'"):
        e.dof_index("knee")
    assert e.jacobians("a").shape == (N, 9, 6, 14) and e.mass_matrix("b").shape == (N, 14, 14)


def test_writes_are_validated(two_ants, device):
    e = two_ants
    with pytest.raises(ValueError, match=r"set_dof_efforts: the tensor has shape \(4, 15\)"):
        e.set_dof_efforts(torch.zeros(N, 15, device=device))
    with pytest.raises(ValueError, match="dtype torch.float64"):
        e.set_dof_position_targets(torch.zeros(N, 16, dtype=torch.float64, device=device))
    with pytest.raises(ValueError, match="expected a torch.Tensor"):
        e.set_dof_efforts(np.zeros((N, 16), np.float32))
    with pytest.raises(ValueError, match=r"shape \(2, 2, 13\) \(expected \(1, 2, 13\)\)"):
        e.set_root_states(torch.zeros(2, 2, 13, device=device), torch.tensor([1], device=device))
    with pytest.raises(ValueError, match="env_ids must be a 1-D integer tensor"):
        e.set_dof_state(torch.zeros(1, 16, device=device), torch.zeros(1, 16, device=device),
                        torch.tensor([1.0], device=device))
    with pytest.raises(ValueError, match="frame='body'"):
        e.apply_body_forces(frame="body")
    if device == "cpu":
        with pytest.raises(ValueError, match="device"):
            e.set_dof_efforts(torch.zeros(N, 16, device="meta"))


def test_indexed_resets_touch_only_their_envs(device):
    scene = Scene().add_ground().add_actor("a", ANT, pos=(0, 0, 0.62))
    e = scene.build(N, device)
    torch.manual_seed(0)
    e.set_dof_efforts(torch.rand(N, 8, device=device) * 10 - 5)
    for _ in range(20):
        e.step()
    before_q, before_qd = e.sim.q.clone(), e.sim.qd.clone()
    ids = torch.tensor([1, 3], device=device)
    states = torch.zeros(2, 1, 13, device=device)
    states[:, 0, :3] = torch.tensor([[5.0, 6.0, 1.0], [-1.0, 2.0, 0.8]])
    yaw = 0.7
    states[:, 0, 3:7] = torch.tensor([0, 0, math.sin(yaw / 2), math.cos(yaw / 2)])
    states[:, 0, 7:10] = torch.tensor([0.5, -0.2, 0.1])
    states[:, 0, 10:13] = torch.tensor([0.3, 0.0, 1.5])       # world frame
    e.set_root_states(states, ids)
    pos = torch.linspace(-0.3, 0.3, 8, device=device).repeat(2, 1)
    pos[:, 1::2] = 1.2                                           # ankles inside [30, 100] deg
    vel = torch.full((2, 8), 0.25, device=device)
    e.set_dof_state(pos, vel, ids)
    # written envs read back what was written (angular velocity is stored in the body frame
    # inside q̇, and reported in the world frame again)
    torch.testing.assert_close(e.root_states[ids], states, atol=1e-5, rtol=0)
    torch.testing.assert_close(e.dof_pos[ids], pos)
    torch.testing.assert_close(e.dof_vel[ids], vel)
    torch.testing.assert_close(e.rigid_body_states[ids, 0], states[:, 0], atol=1e-5, rtol=0)
    # the other envs are bit-for-bit untouched
    others = torch.tensor([0, 2], device=device)
    assert torch.equal(e.sim.q[others], before_q[others])
    assert torch.equal(e.sim.qd[others], before_qd[others])
    # a boolean mask selects the same envs
    mask = torch.tensor([False, True, False, True], device=device)
    e.set_dof_state(pos * 0 + 1.0, vel * 0, mask)
    assert torch.all(e.dof_pos[ids, 1::2] == 1.0) and torch.equal(e.sim.q[others],
                                                                  before_q[others])


def test_body_force_at_a_point_and_in_the_body_frame(tmp_path, device):
    """A free box in zero gravity: a force at its center accelerates it at F/m; the same force
    at an offset point also spins it at (r × F)/I; local-frame vectors are rotated first."""
    mass, half = 2.0, 0.1
    inertia = mass * (2 * half) ** 2 / 6.0
    scene = Scene().add_actor("box", box_xml(tmp_path, half, mass), pos=(0, 0, 1))
    params = myriad.SimParams(dt=0.01, substeps=1, gravity=(0, 0, 0))
    e = scene.build(2, device, params)
    force = torch.zeros(2, 1, 3, device=device)
    force[:, 0, 0] = 4.0
    at = torch.zeros(2, 1, 3, device=device)
    at[1, 0] = torch.tensor([0.0, 0.1, 1.0])                    # env 1: 0.1 m to the side
    at[0, 0] = torch.tensor([0.0, 0.0, 1.0])                    # env 0: the center
    e.apply_body_forces(forces=force, positions=at)
    e.step()
    lin, ang = e.root_states[:, 0, 7:10].cpu(), e.root_states[:, 0, 10:13].cpu()
    torch.testing.assert_close(lin[:, 0], torch.full((2,), 4.0 / mass * 0.01), rtol=1e-4, atol=0)
    # r × F = (0, 0.1, 0) × (4, 0, 0) = (0, 0, -0.4)
    torch.testing.assert_close(ang[1], torch.tensor([0, 0, -0.4 / inertia * 0.01]), rtol=1e-3,
                               atol=1e-7)
    assert ang[0].abs().max() < 1e-7
    # forces last one step: the next step coasts
    e.step()
    torch.testing.assert_close(e.root_states[:, 0, 7].cpu(), lin[:, 0], rtol=1e-5, atol=0)
    # a local-frame force on a box turned 90 deg about z acts along the turned axis
    turned = torch.zeros(2, 1, 13, device=device)
    turned[:, 0, 2] = 1.0
    turned[:, 0, 3:7] = torch.tensor([0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    e.set_root_states(turned)
    e.apply_body_forces(forces=force, frame="local")
    e.step()
    v = e.root_states[:, 0, 7:10].cpu()
    torch.testing.assert_close(v[:, 1], torch.full((2,), 4.0 / mass * 0.01), rtol=1e-4, atol=0)
    assert v[:, 0].abs().max() < 1e-6


def test_an_actor_without_gravity_floats_beside_one_that_falls(tmp_path, device):
    """add_actor(gravity=False) is Isaac Gym's disable_gravity: that actor's bodies feel none."""
    scene = (Scene().add_actor("floats", box_xml(tmp_path, 0.1, 1.0), pos=(0, 0, 1), gravity=False)
             .add_actor("falls", box_xml(tmp_path, 0.1, 1.0), pos=(1, 0, 1)))
    e = scene.build(1, device)
    for _ in range(30):                                             # 0.5 s
        e.step()
    z = e.root_states[0, :, 2].cpu()
    assert abs(z[0].item() - 1.0) < 1e-6
    h, n = 1 / 120, 60                          # substeps: semi-implicit Euler's free fall
    assert z[1].item() == pytest.approx(1.0 - 9.81 * h * h * n * (n + 1) / 2, abs=1e-4)


def test_drives_efforts_fixed_base_and_self_collisions(device):
    scene = Scene()
    scene.add_actor("pd", ANT, pos=(0, 0, 1), fix_base=True, dof_mode="position",
                    stiffness=20.0, damping=1.0, self_collisions=False)
    e = scene.build(2, device, myriad.SimParams(dt=1 / 60, substeps=2, gravity=(0, 0, 0)))
    assert e.model.nq == e.model.nv == 8, "fix_base removes the free joint"
    assert len(e.model.exclude_body_pairs) == 9 * 8 // 2, "every body pair of the actor excluded"
    target = torch.tensor([[0.3, 1.0, -0.2, 1.2, 0.1, 0.9, -0.3, 1.4]], device=device).repeat(2, 1)
    e.set_dof_position_targets(target)
    for _ in range(240):
        e.step()
    # a PD drive with no load settles on its target
    torch.testing.assert_close(e.dof_pos, target, atol=1e-3, rtol=0)
    assert e.dof_vel.abs().max() < 1e-3
    # the fixed base stays where it was put
    torch.testing.assert_close(e.root_states[:, 0, :3].cpu(), torch.tensor([[0, 0, 1.0]] * 2))

    with pytest.raises(ValueError, match="position drive needs stiffness > 0"):
        Scene().add_actor("x", ANT, dof_mode="position")
    with pytest.raises(ValueError, match="dof_mode='torque'"):
        Scene().add_actor("x", ANT, dof_mode="torque")
    with pytest.raises(ValueError, match="used twice"):
        Scene().add_actor("x", ANT).add_actor("x", ANT)
    with pytest.raises(myriad.ModelError, match="no such model file"):
        Scene().add_actor("x", "/nonexistent/robot.xml")


def test_a_drive_mode_per_dof(device):
    """Hips in effort mode, knees position-driven: only the knees get drives, the hips keep the
    efforts they are given; wrong lists name what is wrong. A driven DOF's one stiffness and
    damping are its drive's (Isaac Gym's one pair of gains per DOF): the file's joint spring
    and damper stay on the hips and are gone from the knees."""
    ant = mujoco.MjSpec.from_file(ANT)
    for joint in ant.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_HINGE:
            joint.stiffness, joint.damping = [3.0, 0.0, 0.0], [0.5, 0.0, 0.0]
    modes = ["effort", "position"] * 4
    e = Scene().add_actor("mixed", ant, pos=(0, 0, 1), fix_base=True, dof_mode=modes,
                          stiffness=[0.0, 20.0] * 4, damping=[0.0, 1.0] * 4).build(
        1, device, myriad.SimParams(dt=1 / 60, substeps=2, gravity=(0, 0, 0)))
    drives = [n for n in e.model.actuator_names if n.endswith("/drive")]
    assert drives == [f"{e.dof_names[k]}/drive" for k in range(1, 8, 2)], "the knees' alone"
    m = e.model
    np.testing.assert_array_equal(m.dof_damping, [0.5, 0.0] * 4)
    np.testing.assert_array_equal(m.jnt_stiffness, [3.0, 0.0] * 4)
    drive_rows = [m.actuator_names.index(n) for n in drives]
    np.testing.assert_array_equal(m.actuator_kp[drive_rows], [20.0] * 4)
    np.testing.assert_array_equal(m.actuator_kv[drive_rows], [1.0] * 4)
    e.set_dof_position_targets(torch.full((1, 8), 0.5, device=device))
    e.set_dof_efforts(torch.tensor([[0.2, 0.0] * 4], device=device))
    for _ in range(30):
        e.step()
    knees, hips = e.dof_pos[0, 1::2], e.dof_pos[0, 0::2]
    assert torch.allclose(knees, torch.full_like(knees, 0.5), atol=0.05), "driven to 0.5"
    assert (hips > 0.05).all(), f"pushed by their efforts, held by no drive: {hips}"

    with pytest.raises(ValueError, match="a position drive needs stiffness > 0"):
        Scene().add_actor("x", ANT, dof_mode=modes, stiffness=[20.0, 0.0] * 4)
    with pytest.raises(ValueError, match="one per DOF"):
        Scene().add_actor("x", ANT, dof_mode=modes, stiffness=[20.0] * 3)
    with pytest.raises(ValueError, match="valid"):
        Scene().add_actor("x", ANT, dof_mode=["effort", "torque"])
    with pytest.raises(ValueError, match="lists 2 modes for its 8 DOFs"):
        Scene().add_actor("x", ANT, fix_base=True, dof_mode=["effort", "position"],
                          stiffness=10.0).build(1, device)


def test_an_actor_without_self_collisions_loses_its_explicit_pairs_too():
    """An explicit <contact><pair> collides whatever <exclude> says (MuJoCo's rule), so an
    actor added with self_collisions=False drops its pairs as well as getting the excludes."""
    from myriad.physics.pairs import candidate_pairs
    arm = mujoco.MjSpec.from_string("""<mujoco><worldbody><body name="a"><freejoint/>
      <geom name="ga" size="0.1" contype="1" conaffinity="0"/><body name="b" pos="0 0 0.3">
        <joint type="hinge"/><geom name="gb" size="0.1" contype="1" conaffinity="0"/></body></body>
      </worldbody><contact><pair geom1="ga" geom2="gb" condim="1"/></contact></mujoco>""")
    for self_collisions, expected in [(True, [("arm/ga", "arm/gb")]), (False, [])]:
        spec, _ = Scene().add_actor("arm", arm, pos=(0, 0, 1),
                                    self_collisions=self_collisions).compose()
        model = myriad.physics.from_mujoco(spec.compile())
        names = model.geom_names
        assert [(names[a], names[b]) for a, b in candidate_pairs(model)] == expected


def test_dof_efforts_drive_the_joints(device):
    """An effort on one hinge of a fixed-base ant in zero gravity accelerates only that hinge,
    at effort / (joint-space inertia) from rest."""
    scene = Scene().add_actor("a", ANT, pos=(0, 0, 1), fix_base=True)
    e = scene.build(1, device, myriad.SimParams(dt=1e-3, substeps=1, gravity=(0, 0, 0)))
    efforts = torch.zeros(1, 8, device=device)
    efforts[0, 1] = 0.5
    e.set_dof_efforts(efforts)
    e.forward()
    m = e.mass_matrix("a")[0]
    expected = torch.linalg.solve(m + 1e-3 * torch.diag(e.sim.dof_damping[0]), efforts[0])
    e.step()
    torch.testing.assert_close(e.dof_vel[0], expected * 1e-3, rtol=1e-3, atol=1e-7)
    torch.testing.assert_close(e.dof_forces[0, 1], torch.tensor(0.5, device=device))


@wp.kernel
def _halve(a: wp.array(dtype=float), out: wp.array(dtype=float)):
    out[0] = a[0] * 0.5


@pytest.mark.skipif(platform.machine().lower() not in ("x86_64", "amd64"),
                    reason="denormals are flushed on x86 CPUs only")
def test_the_cpu_step_flushes_denormals_and_restores_the_callers_mode():
    from myriad.physics.runtime import float_mode

    tiny = np.float32(1e-38)                   # below float32's smallest normal, 1.18e-38
    a, out = wp.array([tiny], dtype=float, device="cpu"), wp.zeros(1, dtype=float, device="cpu")
    saved = wp.zeros(1, dtype=wp.uint32, device="cpu")
    with float_mode.flushing_denormals(saved):
        wp.launch(_halve, 1, [a, out], device="cpu")
        assert out.numpy()[0] == 0.0           # flushed
    wp.launch(_halve, 1, [a, out], device="cpu")
    assert out.numpy()[0] == pytest.approx(5e-39, rel=1e-6)
    # a CPU graph's replay runs on the calling thread, in the caller's mode (the step replays
    # one from its second call inside the flush)
    with wp.ScopedCapture(device="cpu") as capture:
        wp.launch(_halve, 1, [a, out], device="cpu")
    out.zero_()
    with float_mode.flushing_denormals(saved):
        wp.capture_launch(capture.graph)
        assert out.numpy()[0] == 0.0
    sim = myriad.Simulator(myriad.load(ANT), num_envs=2, cpu_threads=1)
    for _ in range(3):
        sim.step()                             # on this thread, the last two replayed
    assert sim.runtime.replaying
    assert tiny * np.float32(0.5) == pytest.approx(5e-39, rel=1e-6)
    wp.launch(_halve, 1, [a, out], device="cpu")
    assert out.numpy()[0] == pytest.approx(5e-39, rel=1e-6)
