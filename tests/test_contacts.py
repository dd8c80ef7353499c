"""Contacts, friction, restitution and joint limits against closed-form physics.

Isaac Gym's settings unless a test says otherwise: dt 1/60, 2 substeps, TGS with 4 position and
1 velocity iteration.
"""

import dataclasses
import math

import numpy as np
import pytest
import torch

import myriad
import stacks                                            # benchmarks/stacks.py
from limit_chain import chain_xml as limit_chain_xml     # benchmarks/limit_chain.py

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

ISAAC = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=1)


def _scene(bodies: str, floor_quat="1 0 0 0", floor_friction=1.0, extra="") -> myriad.Model:
    return myriad.load_xml(f"""<mujoco><worldbody>
      <geom name="floor" type="plane" size="20 20 0.1" quat="{floor_quat}" friction="{floor_friction} 0 0"/>
      {bodies}</worldbody>{extra}</mujoco>""", "scene")


def _box_on_incline(deg: float, mu: float) -> myriad.Model:
    th = math.radians(deg)
    quat = f"{math.cos(th / 2)} {math.sin(th / 2)} 0 0"  # tilt about x: the slope descends toward -y
    normal = np.array([0.0, -math.sin(th), math.cos(th)])
    pos = " ".join(f"{x:.6f}" for x in normal * 0.1)
    return _scene(f'<body name="box" pos="{pos}" quat="{quat}"><freejoint/>'
                  f'<geom type="box" size="0.1 0.1 0.1" mass="1" friction="{mu} 0 0"/></body>',
                  floor_quat=quat, floor_friction=mu)


@pytest.mark.parametrize("deg", [15.0, 25.0, 35.0, 45.0])
def test_box_on_incline_sticks_below_friction_angle_and_slides_above(deg, device):
    mu = 0.5  # friction angle atan(0.5) = 26.57 degrees
    sim = myriad.Simulator(_box_on_incline(deg, mu), num_envs=1, device=device, params=ISAAC)
    for _ in range(30):  # settle
        sim.step()
    v0 = sim.qd[0, :3].cpu().numpy().copy()
    for _ in range(60):  # 1 s
        sim.step()
    accel = np.linalg.norm(sim.qd[0, :3].cpu().numpy() - v0)
    th = math.radians(deg)
    if th < math.atan(mu):
        assert accel < 1e-3, accel  # sticks
    else:
        expected = 9.81 * (math.sin(th) - mu * math.cos(th))
        assert accel == pytest.approx(expected, rel=0.03)


def test_box_at_rest_drifts_less_than_a_millimetre_in_ten_seconds(device):
    sim = myriad.Simulator(_scene('<body pos="0.3 -0.2 0.1"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1"/></body>'),
                           num_envs=1, device=device, params=ISAAC)
    start = sim.q[0, :3].clone()
    for _ in range(600):
        sim.step()
    drift = (sim.q[0, :3] - start).norm().item()
    assert drift < 1e-3, drift
    # it carries its weight: net contact force on the box = m g, up
    np.testing.assert_allclose(sim.net_contact_force[0, 0].cpu().numpy(), [0, 0, 9.81], atol=1e-3)


def test_a_box_rests_on_a_massless_body_welded_to_the_world(device):
    """A table made of a jointless, massless body (a plane or a box on it: a task's fixed-base
    actor) holds a box as the world's floor does; its contacts were once dropped, the table
    counting as infinitely light."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <body name="table"><geom type="plane" size="1 1 0.1" mass="0"/>
        <geom type="box" size="0.1 0.1 0.05" pos="0.5 0 0.05" mass="0"/></body>
      <body pos="0 0 0.2"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
      <body pos="0.5 0 0.3"><freejoint/><geom type="box" size="0.05 0.05 0.05" mass="1"/></body>
      </worldbody></mujoco>""", "tables")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=ISAAC)
    for _ in range(120):
        sim.step()
    np.testing.assert_allclose(sim.q[0, [2, 9]].cpu().numpy(), [0.05, 0.15], atol=2e-3)


def test_dropped_sphere_never_tunnels_and_rests_at_its_radius(device):
    sim = myriad.Simulator(_scene('<body pos="0 0 1"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>'),
                           num_envs=1, device=device, params=ISAAC)
    lowest = 1.0
    for _ in range(300):
        sim.step()
        lowest = min(lowest, sim.q[0, 2].item())
    assert lowest > 0.1 - 0.01  # never more than 1 cm into the floor, never through it
    assert sim.q[0, 2].item() == pytest.approx(0.1, abs=1e-3)
    assert sim.qd[0].abs().max().item() < 1e-3


def test_restitution_bounces_to_e_squared_height(device):
    sim = myriad.Simulator(_scene('<body pos="0 0 1.1"><freejoint/><geom type="sphere" size="0.1" mass="1"/></body>'),
                           num_envs=1, device=device,
                           params=myriad.SimParams(dt=1 / 240, substeps=1, position_iterations=4,
                                                   velocity_iterations=1))
    sim.geom_restitution[:] = 0.8  # floor and sphere: the pair averages to 0.8
    peak, falling_again, bounced = 0.0, False, False
    for _ in range(2000):
        sim.step()
        vz = sim.qd[0, 2].item()
        if vz > 0:
            bounced = True
        if bounced and vz <= 0 and not falling_again:
            falling_again = True
            peak = sim.q[0, 2].item() - 0.1
            break
    assert bounced and falling_again
    assert peak == pytest.approx(0.8**2 * 1.0, rel=0.05)


def test_hinge_driven_into_its_limit_stays_within_0_02_rad(device):
    model = myriad.load_xml("""<mujoco><compiler angle="radian"/><option gravity="0 0 0"/><worldbody>
      <body name="arm"><joint name="hinge" type="hinge" axis="0 0 1" limited="true" range="-0.5 0.5"/>
        <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03" mass="1"/></body></worldbody>
      <actuator><motor joint="hinge" gear="100"/></actuator></mujoco>""", "arm")
    sim = myriad.Simulator(model, num_envs=2, device=device, params=ISAAC)
    sim.ctrl = torch.tensor([[1.0], [-1.0]], device=sim.torch_device)  # 100 N·m into either limit
    worst = 0.0
    for _ in range(300):
        sim.step()
        worst = max(worst, sim.q[0, 0].item() - 0.5, -0.5 - sim.q[1, 0].item())
    assert worst < 0.02, worst
    assert sim.q[0, 0].item() == pytest.approx(0.5, abs=0.02)
    assert sim.q[1, 0].item() == pytest.approx(-0.5, abs=0.02)
    # the limit carries the motor's torque
    assert sim.dof_constraint_force[0, 0].item() == pytest.approx(-100.0, rel=0.02)


@pytest.mark.parametrize("length, mass", [(0.1, 0.1), (0.02, 0.01)])
def test_a_speed_cap_beside_a_joint_at_its_limit_does_not_push_it_through(length, mass, device):
    """A shoulder driven into its limits, a heavy forearm spun by its own motor up to the 5 rad/s
    speed cap. The upper arm is short and light, so the two dofs are strongly coupled (as a
    G1's wrist roll, pitch and yaw are) and the cap's impulse on the elbow moves the shoulder
    too: applied after the limits, it turned the shoulder up to 0.149 rad through its limit in
    2 s with a 10 cm, 100 g upper arm; the limits and the caps taking turns in a sweep left
    0.027, and 9.5 rad with a 2 cm, 10 g one (the two dofs nearly one motion). The caps the
    limits' impulses break are now solved with them in the limit block: 0.0000 for both."""
    model = myriad.load_xml(f"""<mujoco><compiler angle="radian"/><option gravity="0 0 0"/>
      <worldbody><body name="upper">
        <joint name="shoulder" type="hinge" axis="0 0 1" limited="true" range="-0.5 0.5"/>
        <geom type="capsule" fromto="0 0 0 {length} 0 0" size="0.005" mass="{mass}"/>
        <body name="lower" pos="{length} 0 0"><joint name="elbow" type="hinge" axis="0 0 1"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02" mass="1"/></body></body>
      </worldbody><actuator><motor joint="shoulder"/><motor joint="elbow"/></actuator>
      </mujoco>""", "arm")
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                              velocity_iterations=1, max_joint_velocity=5.0)
    torques = [[t1, t2] for t1 in (1.0, 10.0) for t2 in (0.5, 5.0, -0.5, -5.0)]
    sim = myriad.Simulator(model, num_envs=len(torques), device=device, params=params)
    sim.ctrl = torch.tensor(torques, device=sim.torch_device)
    excess = fastest = 0.0
    for _ in range(120):
        sim.step()
        excess = max(excess, (sim.q[:, 0].abs() - 0.5).max().item())
        fastest = max(fastest, sim.qd.abs().max().item())
    assert excess < 0.005, excess
    assert fastest <= 5.0 + 1e-4, fastest


@pytest.mark.parametrize("nlink, tip_ratio", [(6, 20.0), (10, 100.0)])
@pytest.mark.parametrize("solver", ["tgs", "pgs"])
def test_a_chain_resting_on_its_joint_limits_stays_on_them(nlink, tip_ratio, solver, device):
    """Limits coupled through a chain with a heavy tip, at 4 + 1 iterations: within 0.01 rad of
    the limits and at rest over the 5th second (row-by-row Gauss-Seidel left the 6-link chain
    chattering at ~20 rad/s, 0.5 rad past its limits; MuJoCo's soft limits sag 0.8 rad)."""
    model = myriad.load_xml(limit_chain_xml(nlink, tip_ratio), "limit_chain")
    params = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                              velocity_iterations=1, solver=solver)
    sim = myriad.Simulator(model, num_envs=1, device=device, params=params)
    excess = speed = 0.0
    for step in range(300):
        sim.step()
        if step >= 240:
            excess = max(excess, sim.q.max().item())          # the upper limits are all 0
            speed = max(speed, sim.qd.abs().max().item())
    assert excess < 0.01, excess
    assert speed < 0.05, speed
    # each limit carries the weight outboard of it (the tip's share dominates)
    g, length, mass = 9.81, 0.1, 0.1
    masses = [mass] * (nlink - 1) + [mass * tip_ratio]
    torque = sum(mk * g * (length * (k + 0.5)) for k, mk in enumerate(masses))
    assert sim.dof_constraint_force[0, 0].item() == pytest.approx(-torque, rel=0.02)


def test_a_heavy_body_landing_on_a_leg_held_by_its_limit_keeps_the_foot_out_of_the_floor(
        device):
    """50 kg coming down at 3 m/s onto a frictionless leg whose knee is at its limit: the foot's
    contact and the knee's limit must stop it together. Solved one after the other (the
    default), the limit (last) undoes the contact in every sweep: the foot goes 110 mm into the
    floor and the body bounces for seconds. Solved together (`SimParams.limit_block_contacts`),
    the foot stays within 12 mm on landing and the body comes to rest on it, the knee on its
    limit."""
    model = _scene("""<body name="base" pos="0 0 0.45"><joint name="z" type="slide" axis="0 0 1"/>
        <geom type="box" size=".15 .15 .05" mass="50" friction="0 0 0"/>
        <body name="calf" pos="0 0 -0.05">
          <joint name="knee" type="hinge" axis="0 1 0" range="-0.1 0.8"/>
          <geom type="capsule" fromto="0 0 0 0.2 0 -0.2" size="0.02" mass="0.5" friction="0 0 0"/>
          <geom name="foot" type="sphere" pos="0.2 0 -0.2" size="0.03" mass="0.1"
                friction="0 0 0"/></body></body>""", floor_friction=0.0)
    params = dataclasses.replace(ISAAC, limit_block_contacts=16)
    sim = myriad.Simulator(model, num_envs=1, device=device, params=params)
    sim.qd = torch.tensor([[-3.0, 0.0]], device=sim.torch_device)
    lower = math.radians(-0.1)                   # MJCF ranges are in degrees
    deepest = excess = 0.0
    for _ in range(120):
        sim.step()
        n = int(sim.contact_count[0])
        deepest = min(deepest, sim.contact_dist[0, :n].min().item() if n else 0.0)
        excess = max(excess, lower - sim.q[0, 1].item())
    assert deepest > -0.012, deepest
    assert excess < 0.01, excess
    assert abs(sim.qd[0, 0].item()) < 0.01
    weight = 50.6 * 9.81
    assert sim.contact_force[0, :, 2].sum().item() == pytest.approx(weight, rel=0.02)


def test_envs_with_different_friction_and_mass_behave_differently_and_independently(device):
    sim = myriad.Simulator(_box_on_incline(35.0, 0.5), num_envs=4, device=device, params=ISAAC)
    sim.geom_friction[1] = 1.0   # env 1: mu 1.0 > tan 35: sticks
    sim.body_mass[2] *= 5.0      # env 2: heavier, same friction: slides the same (mass cancels)
    sim.geom_friction[3] = 0.2   # env 3: slides faster
    for step in range(60):
        sim.step()
        if step == 29:
            held = sim.q[1, :3].clone()
    speed = sim.qd[:, :3].norm(dim=1).cpu().numpy()
    # env 1 sticks: it stays put within 0.1 mm over the last half second (its velocity reading
    # keeps a few mm/s of the solve's residual at rest: docs/physics.md)
    assert (sim.q[1, :3] - held).norm().item() < 1e-4
    assert speed[1] < 1e-2
    assert speed[2] == pytest.approx(speed[0], rel=0.02)
    assert speed[3] > speed[0] * 1.5
    th = math.radians(35.0)
    for e, mu in [(0, 0.5), (3, 0.2)]:
        assert speed[e] == pytest.approx(9.81 * (math.sin(th) - mu * math.cos(th)) * 1.0, rel=0.05)


def test_stack_of_five_boxes_stands_ten_seconds(device):
    bodies = "".join(f'<body name="b{i}" pos="0 0 {0.1 + 0.2 * i:.3f}"><freejoint/>'
                     f'<geom type="box" size="0.1 0.1 0.1" mass="1"/></body>' for i in range(5))
    sim = myriad.Simulator(_scene(bodies), num_envs=1, device=device, params=ISAAC)
    start = sim.body_pose[0].cpu().numpy().copy()
    for _ in range(600):
        sim.step()
    pose = sim.body_pose[0].cpu().numpy()
    # each box still sits on the one below: centers within 2.5 cm sideways (a box is 20 cm
    # wide), heights within 5 mm, tilts below 2 degrees
    offsets = np.linalg.norm(np.diff(pose[:, :2], axis=0), axis=1)
    assert offsets.max() < 0.025, offsets
    np.testing.assert_allclose(pose[:, 2], start[:, 2], atol=5e-3)
    tilt = np.degrees(2 * np.arcsin(np.clip(np.linalg.norm(pose[:, 3:5], axis=1), 0, 1)))
    assert tilt.max() < 2.0, tilt
    assert int(sim.contact_count[0]) == 20  # four corners at each of the five interfaces


# issue 12's resting stacks (`benchmarks/stacks.py`, with MuJoCo's figures): 10 cm boxes of
# 0.5 kg, friction 1, 0.5 mm apart at the start; the top box's drift after a 0.5 s settle.
# Before friction anchors and cold-started contact rows: 8.5, 25 and 25 mm at 4 + 1.
@pytest.mark.parametrize("iterations", [4, 8])
@pytest.mark.parametrize("scene, limit", [("3 boxes", 1e-3), ("5 boxes", 5e-3),
                                          ("small cube on a box", 1e-3)])
def test_resting_stacks_hold_still(scene, limit, iterations, device):
    sizes, seconds = stacks.SCENES[scene]
    model = myriad.load_xml(stacks.stack_xml(sizes), scene)
    assert stacks.myriad_drift(model, len(sizes), seconds, "tgs", iterations, device) < limit


def test_a_convex_mesh_cube_rests_on_a_convex_mesh_slab(device):
    """At its analytic height (slab top + half the cube) within 2 mm, creeping < 1 mm in 5 s
    (12 mm with one contact point per convex pair; 0.6 mm with the face's corners)."""
    cube = " ".join(f"{x} {y} {z}" for x in (-0.05, 0.05) for y in (-0.05, 0.05) for z in (-0.05, 0.05))
    slab = " ".join(f"{x} {y} {z}" for x in (-0.3, 0.3) for y in (-0.3, 0.3) for z in (-0.02, 0.02))
    model = myriad.load_xml(f"""<mujoco><asset><mesh name="cube" vertex="{cube}"/>
      <mesh name="slab" vertex="{slab}"/></asset><worldbody>
      <geom name="floor" type="plane" size="20 20 0.1"/>
      <body pos="0 0 0.02"><freejoint/><geom type="mesh" mesh="slab" mass="5"/></body>
      <body pos="0.05 -0.03 0.0905" euler="0 0 0.3"><freejoint/><geom type="mesh" mesh="cube" mass="0.5"/></body>
      </worldbody></mujoco>""", "mesh on mesh")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=ISAAC)
    for _ in range(30):
        sim.step()
    start = sim.q[0, 7:10].clone()
    for _ in range(300):
        sim.step()
    assert sim.q[0, 9].item() == pytest.approx(0.04 + 0.05, abs=2e-3)
    assert (sim.q[0, 7:10] - start).norm().item() < 1e-3


def test_a_flat_soles_contacts_stay_put_whichever_vertex_is_deepest(device):
    """A foot mesh whose sole (30 × 3 cm, 33 vertices) is flat but for a 0.1 mm bulge in its
    middle, on the floor in four poses a hair apart (level, heel or toe 0.3 mm lower, rolled
    0.15 mm): the deepest vertex is a different one in each, and the four contacts are the same
    four points, spanning the sole's length and width. Built from the deepest vertex, the four
    moved with it from step to step, and the H1's walking policy (feet: such a mesh) swayed
    three times as much as in MuJoCo (docs/results.md, unitree_rl_gym)."""
    xs = np.linspace(-0.1, 0.2, 11)
    sole = [(x, y, -0.07 - 1e-4 * (1 - ((x - 0.05) / 0.15) ** 2) * (1 - (y / 0.015) ** 2))
            for x in xs for y in (-0.015, 0.0, 0.015)]
    top = [(x, y, 0.0) for x in (-0.08, 0.18) for y in (-0.03, 0.03)]
    vertices = " ".join(f"{x:.6f} {y:.6f} {z:.7f}" for x, y, z in sole + top)
    model = myriad.load_xml(f"""<mujoco><asset><mesh name="foot" vertex="{vertices}"/></asset>
      <worldbody><geom name="floor" type="plane" size="5 5 0.1"/>
      <body name="foot" pos="0 0 0.0705"><freejoint/><geom type="mesh" mesh="foot" mass="0.6"/>
      </body></worldbody></mujoco>""", "foot")
    params = dataclasses.replace(ISAAC, contact_offset=0.01)
    sim = myriad.Simulator(model, num_envs=4, device=device, params=params)
    q = sim.q.clone()                   # free joint: position, quaternion (x, y, z, w)
    # about the sole's middle: its ends 0.3 mm (pitch), its edges 0.15 mm (roll) apart
    for env, (axis, angle) in enumerate([(1, 0.0), (1, 2e-3), (1, -2e-3), (0, 1e-2)]):
        q[env, 3 + axis] = math.sin(angle / 2)
        q[env, 6] = math.cos(angle / 2)
    sim.q = q
    sim.forward()                       # the poses, then the contacts at them
    sim.collide()
    points = []
    for env in range(4):
        count = int(sim.contact_count[env])
        assert count == 4
        xy = sim.contact_pos[env, :count, :2].cpu()
        assert (xy[:, 0].max() - xy[:, 0].min()).item() == pytest.approx(0.30, abs=1e-3)
        assert (xy[:, 1].max() - xy[:, 1].min()).item() == pytest.approx(0.03, abs=1e-3)
        points.append(xy)
    for env in range(1, 4):       # the same four points (the roll moves them 0.7 mm sideways)
        assert torch.cdist(points[0], points[env]).amin(1).max().item() < 1.5e-3, points


def test_joint_friction_holds_below_and_slips_above_its_frictionloss(device):
    model = myriad.load_xml("""<mujoco><option gravity="0 0 0"/><worldbody>
      <body name="slider"><joint name="x" type="slide" axis="1 0 0" frictionloss="2"/>
        <geom type="sphere" size="0.1" mass="1"/></body></worldbody>
      <actuator><motor joint="x"/></actuator></mujoco>""", "slider")
    sim = myriad.Simulator(model, num_envs=2, device=device, params=ISAAC)
    sim.ctrl = torch.tensor([[1.5], [3.0]], device=sim.torch_device)  # below / above 2 N
    for _ in range(60):
        sim.step()
    assert abs(sim.qd[0, 0].item()) < 1e-5  # held
    assert sim.qd[1, 0].item() == pytest.approx((3.0 - 2.0) * 1.0, rel=1e-3)  # 1 m/s² for 1 s


def test_max_joint_velocity_caps_a_driven_joint_and_a_struck_one(device):
    """PhysX's maximum joint velocity: a hinge spun up by a steady torque levels off at its cap
    (env 0), and one kicked well past it by a single large impulse is brought back within the
    same step (env 1)."""
    model = myriad.load_xml("""<mujoco><option gravity="0 0 0"/><worldbody>
      <body name="wheel"><joint name="spin" type="hinge" axis="0 0 1"/>
        <geom type="cylinder" size="0.2 0.05" mass="2"/></body></worldbody>
      <actuator><motor joint="spin"/></actuator></mujoco>""", "wheel")
    sim = myriad.Simulator(model, num_envs=2, device=device, params=ISAAC)
    sim.dof_max_velocity = 5.0
    sim.ctrl = torch.tensor([[0.5], [0.0]], device=sim.torch_device)   # 0.5 N·m on I = 0.04
    for _ in range(120):                 # unconstrained, 12.5 rad/s² would reach 25 rad/s
        sim.step()
    assert sim.qd[0, 0].item() == pytest.approx(5.0, abs=1e-3)
    sim.qd[1, 0] = 0.0
    sim.joint_force = torch.tensor([[0.0], [60.0]], device=sim.torch_device)   # +25 rad/s in h
    sim.step()
    assert abs(sim.qd[1, 0].item()) <= 5.0 + 1e-3


@pytest.mark.parametrize("geom, rest_height", [
    ('type="cylinder" size="0.1 0.15"', 0.15),                 # standing on a cap
    ('type="ellipsoid" size="0.1 0.12 0.08"', 0.08),
    ('type="mesh" mesh="cube"', 0.1),                          # a convex mesh, on a face
])
def test_convex_shapes_come_to_rest_on_the_floor(geom, rest_height, device):
    cube = " ".join(f"{x} {y} {z}" for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1))
    model = myriad.load_xml(f"""<mujoco><asset><mesh name="cube" vertex="{cube}"/></asset><worldbody>
      <geom name="floor" type="plane" size="20 20 0.1"/>
      <body pos="0.1 0.2 0.4"><freejoint/><geom {geom} mass="1"/></body></worldbody></mujoco>""", "drop")
    sim = myriad.Simulator(model, num_envs=1, device=device, params=ISAAC)
    speed = []
    for _ in range(300):
        sim.step()
        speed.append(sim.qd[0].abs().max())
    assert sim.q[0, 2].item() == pytest.approx(rest_height, abs=2e-3)
    # at rest over the last 100 steps, not only at the last one (a cylinder on its cap once
    # kept rocking at up to 0.4 m/s or rad/s and passed only when the last step fell still)
    assert torch.stack(speed[200:]).max().item() < 1e-2
    np.testing.assert_allclose(sim.q[0, 3:7].abs().cpu().numpy(), [0, 0, 0, 1], atol=1e-2)  # upright


def _terrain(heights: np.ndarray, size: str, body: str) -> myriad.Model:
    nrow, ncol = heights.shape
    elevation = " ".join(f"{h:.6f}" for h in heights.ravel())
    return myriad.load_xml(f"""<mujoco><asset><hfield name="terrain" nrow="{nrow}" ncol="{ncol}"
      size="{size}" elevation="{elevation}"/></asset><worldbody>
      <geom type="hfield" hfield="terrain"/>{body}</worldbody></mujoco>""", "terrain")


def test_box_rests_on_a_flat_height_field(device):
    heights = np.ones((5, 5))
    heights[0, 0] = 0.0  # MuJoCo normalizes elevations to [0, 1]: one low corner, a 0.2 m plateau
    model = _terrain(heights, "2 2 0.2 0.1", '<body pos="0.3 0.2 0.5"><freejoint/>'
                     '<geom type="box" size="0.1 0.1 0.1" mass="1"/></body>')
    sim = myriad.Simulator(model, num_envs=1, device=device, params=ISAAC)
    for _ in range(240):
        sim.step()
    assert sim.q[0, 2].item() == pytest.approx(0.2 + 0.1, abs=2e-3)
    assert sim.qd[0].abs().max().item() < 1e-2


def test_sphere_rolls_down_a_height_field_ramp_at_five_sevenths_g_sin(device):
    """Rolling without slipping: a = 5/7 g sin(theta) for a solid sphere."""
    slope = 0.25  # rise over run along x
    x = np.linspace(-2.0, 2.0, 9)
    heights = np.tile((slope * (x + 2.0)) / 1.0, (5, 1))  # top height 1 m: data = height in m
    model = _terrain(heights, "2 2 1 0.1", '<body pos="0.5 0 1.5"><freejoint/>'
                     '<geom type="sphere" size="0.1" mass="1"/></body>')
    sim = myriad.Simulator(model, num_envs=1, device=device, params=ISAAC)
    theta = np.arctan(slope)
    # place it on the ramp, at rest
    sim.q[0, 2] = slope * (0.5 + 2.0) + 0.1 / np.cos(theta)
    for _ in range(10):
        sim.step()
    v0 = sim.qd[0, :3].cpu().numpy().copy()
    for _ in range(30):
        sim.step()
    accel = np.linalg.norm(sim.qd[0, :3].cpu().numpy() - v0) / 0.5
    assert accel == pytest.approx(5 / 7 * 9.81 * np.sin(theta), rel=0.03)
    assert sim.qd[0, 0].item() < 0  # downhill, toward -x


@pytest.mark.parametrize("caps, contact_speed, limit_speed", [
    ({}, 1.0, 10.0),                                       # the defaults
    ({"max_depenetration_velocity": 4.0, "max_correction_velocity": 2.0}, 4.0, 2.0)])
def test_penetration_and_limit_errors_are_undone_at_their_own_capped_speeds(
        caps, contact_speed, limit_speed, device):
    """A box 5 cm into the ground and a hinge 0.5 rad past its limit, no gravity, one substep
    of 1/120 s: each is pushed out at its cap (contacts: max_depenetration_velocity, limits:
    max_correction_velocity), which the error asks for many times over (5 cm or 0.5 rad in a
    2 ms sweep), so each moves by its cap times the substep."""
    model = myriad.load_xml("""<mujoco><option gravity="0 0 0"/><worldbody>
      <geom type="plane" size="5 5 0.1"/>
      <body pos="0 0 0.05"><freejoint/><geom type="box" size="0.1 0.1 0.1" mass="1"/></body>
      <body pos="2 0 1"><joint type="hinge" axis="0 0 1" range="-0.5 0.5" limited="true"/>
        <geom type="capsule" fromto="0 0 0 0.5 0 0" size="0.03" mass="1"/></body>
      </worldbody></mujoco>""", "caps")
    h = 1 / 120
    sim = myriad.Simulator(model, num_envs=1, device=device,
                           params=myriad.SimParams(dt=h, substeps=1, **caps))
    q = sim.q.clone()
    q[0, 7] = 1.0                          # the hinge: 0.5 rad past its upper limit
    sim.q = q
    sim.step()
    assert sim.q[0, 2].item() - 0.05 == pytest.approx(contact_speed * h, rel=1e-3)  # the box
    assert 1.0 - sim.q[0, 7].item() == pytest.approx(limit_speed * h, rel=1e-3)     # the hinge
