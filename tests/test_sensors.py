"""MuJoCo's sensors (`sensors.py`): every kind Myriad computes against MuJoCo's own values, the
force/torque sensors against statics, the touch zones against MuJoCo's ray test, and the sensors
Myriad skips."""

import mujoco
import numpy as np
import pytest
import torch
import warp as wp

import myriad
from myriad.physics.stages import sensors
from oracle import free_motion_mujoco

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

# A hanging arm (hinge, then hinge + limited slide), a box resting on the floor, a ball high up
# in free fall, a post welded to the world, three kinds of actuators, and one sensor of each kind Myriad computes: on sites,
# geoms, bodies (inertial frame) and body frames, with and without a reference frame, some with
# a cutoff (real values clamped on both sides, touch from above).
SENSORS_XML = """<mujoco>
  <option timestep="0.005"/>
  <worldbody>
    <geom name="floor" type="plane" size="3 3 0.1"/>
    <site name="world_site" pos="0.1 0.2 0.3" euler="0 0 40"/>
    <body name="arm" pos="0 0 2">
      <joint name="j1" type="hinge" axis="0 1 0" damping="0.1"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.04" contype="0" conaffinity="0"/>
      <site name="elbow" pos="0.15 0.02 0" euler="10 20 30"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="j2" type="hinge" axis="0 0 1"/>
        <joint name="sl" type="slide" axis="1 0 0" range="-0.1 0.1"/>
        <geom name="fore_geom" type="box" size="0.1 0.03 0.02" pos="0.1 0 0" euler="0 10 0"
              contype="0" conaffinity="0"/>
        <site name="tip" pos="0.2 0 0.01" euler="30 0 45"/>
      </body>
    </body>
    <body name="foot" pos="1 0 0.05">
      <freejoint/>
      <geom type="box" size="0.1 0.08 0.05" mass="2"/>
      <site name="sole" type="box" pos="0 0 -0.05" size="0.11 0.09 0.02"/>
      <site name="heel" type="capsule" pos="-0.1 0 -0.05" size="0.02 0.1" euler="90 0 0"/>
      <site name="top" type="sphere" pos="0 0 0.05" size="0.03"/>
      <site name="imu" pos="0.03 0.02 0.01" euler="20 0 0"/>
    </body>
    <body name="post" pos="0.5 0.5 0.2">
      <geom type="cylinder" size="0.02 0.2" contype="0" conaffinity="0"/>
      <site name="post_site" euler="30 0 0"/>
    </body>
    <body name="ball" pos="-1 0 3">
      <freejoint/>
      <geom type="sphere" size="0.05" contype="0" conaffinity="0"/>
      <site name="imu2" euler="0 30 0"/>
    </body>
  </worldbody>
  <actuator>
    <motor name="motor" joint="j1" gear="2" ctrlrange="-1 1"/>
    <position name="servo" joint="j2" kp="5" kv="0.3"/>
    <velocity name="damper" joint="sl" kv="2" forcerange="-0.5 0.5"/>
  </actuator>
  <sensor>
    <jointpos joint="j1"/><jointvel joint="j2" cutoff="0.3"/><jointpos joint="sl"/>
    <actuatorfrc actuator="motor"/><actuatorfrc actuator="servo"/><actuatorfrc actuator="damper"/>
    <jointactuatorfrc joint="j2"/>
    <framepos objtype="site" objname="tip"/>
    <framepos objtype="body" objname="fore" reftype="site" refname="elbow"/>
    <framequat objtype="xbody" objname="fore"/>
    <framequat objtype="geom" objname="fore_geom" reftype="xbody" refname="arm"/>
    <framexaxis objtype="site" objname="tip"/>
    <frameyaxis objtype="body" objname="arm"/>
    <framezaxis objtype="geom" objname="fore_geom" reftype="site" refname="world_site"/>
    <framelinvel objtype="site" objname="tip"/>
    <framelinvel objtype="xbody" objname="fore" reftype="site" refname="elbow"/>
    <frameangvel objtype="body" objname="fore"/>
    <frameangvel objtype="geom" objname="fore_geom" reftype="xbody" refname="arm"/>
    <framelinacc objtype="site" objname="tip"/>
    <frameangacc objtype="body" objname="fore"/>
    <velocimeter site="tip"/><gyro site="tip"/><velocimeter site="imu2"/><gyro site="imu"/>
    <accelerometer site="tip" cutoff="20"/><accelerometer site="imu"/>
    <accelerometer site="imu2"/><accelerometer site="world_site"/><accelerometer site="post_site"/>
    <force site="tip"/><torque site="elbow"/>
    <touch name="sole_touch" site="sole"/><touch site="heel"/><touch site="top"/><touch site="sole" cutoff="5"/>
  </sensor>
</mujoco>"""

H = 0.005
ACTUATOR_SENSORS = (mujoco.mjtSensor.mjSENS_ACTUATORFRC, mujoco.mjtSensor.mjSENS_JOINTACTFRC)
ACCELERATION_SENSORS = (mujoco.mjtSensor.mjSENS_ACCELEROMETER, mujoco.mjtSensor.mjSENS_FORCE,
                        mujoco.mjtSensor.mjSENS_TORQUE, mujoco.mjtSensor.mjSENS_FRAMELINACC,
                        mujoco.mjtSensor.mjSENS_FRAMEANGACC)


@pytest.fixture(scope="module")
def model():
    return myriad.load_xml(SENSORS_XML, "sensors")


def _columns(mj, kinds):
    return np.concatenate([np.arange(mj.sensor_adr[i], mj.sensor_adr[i] + mj.sensor_dim[i])
                           for i in range(mj.nsensor) if mj.sensor_type[i] in [int(k) for k in kinds]])


def test_every_sensor_reads_what_mujoco_reads_at_the_same_state(model, device):
    """Two envs on two CPU threads, random controls: after each step every sensor but touch reads
    what MuJoCo's own sensors read (d.sensordata, same order and layout) at the same state:
    - position and velocity sensors: mj_forward at the new state;
    - accelerometers, frame accelerations, force and torque: mj_inverse at the new state with
      the step's acceleration (qd - qd_before) / h, which Myriad's read too;
    - actuator forces: mj_forward at the state the step started from, with its controls (MuJoCo's
      actuator_force is the force at the start of the step, which the step applied).
    Touch depends on the contact solver: `test_resting_and_falling_bodies_read_like_mujoco`."""
    mj = model.mj_model
    assert model.nsensor == mj.nsensor and model.nsensordata == mj.nsensordata
    sim = myriad.Simulator(model, num_envs=2, device=device, cpu_threads=2,
                           params=myriad.SimParams(dt=H, substeps=1))
    d = mujoco.MjData(mj)
    actuated = _columns(mj, ACTUATOR_SENSORS)
    accelerated = _columns(mj, ACCELERATION_SENSORS)
    touch = _columns(mj, (mujoco.mjtSensor.mjSENS_TOUCH,))
    kinematic = np.setdiff1d(np.arange(mj.nsensordata), np.concatenate([actuated, accelerated, touch]))
    gen = torch.Generator().manual_seed(1)
    worst = {}
    for step in range(40):
        ctrl = torch.rand(2, model.nu, generator=gen) * 4 - 2      # beyond the motor's ctrlrange
        sim.ctrl = ctrl.to(sim.torch_device)
        q0, qd0 = sim.q.cpu().numpy().copy(), sim.qd.cpu().numpy().copy()
        sim.step()
        if step % 8 != 7:
            continue
        ours = sim.sensor_data.cpu().numpy()
        q, qd = sim.q.cpu().numpy(), sim.qd.cpu().numpy()
        for e in range(2):
            d.qpos[:], d.qvel[:], d.ctrl[:] = model.qpos_to_mujoco(q0[e]), qd0[e], ctrl[e].numpy()
            mujoco.mj_forward(mj, d)
            before = d.sensordata.copy()
            d.qpos[:], d.qvel[:] = model.qpos_to_mujoco(q[e]), qd[e]
            mujoco.mj_forward(mj, d)
            after = d.sensordata.copy()
            d.qacc[:] = (qd[e] - qd0[e]) / H
            mujoco.mj_inverse(mj, d)
            inverse = d.sensordata.copy()
            for name, cols, expected in (("kinematic", kinematic, after),
                                         ("actuator", actuated, before),
                                         ("acceleration", accelerated, inverse)):
                err = np.abs(ours[e, cols] - expected[cols]) / (1 + np.abs(expected[cols]))
                worst[name] = max(worst.get(name, 0.0), float(err.max()))
    # float32 against MuJoCo's float64, relative to 1 + |value|: the kinematics agree to ~1e-6;
    # accelerations and forces go through one more Newton-Euler pass (~1e-5 seen)
    assert worst["kinematic"] < 1e-4, worst
    assert worst["actuator"] < 1e-4, worst
    assert worst["acceleration"] < 1e-4, worst


def test_resting_and_falling_bodies_read_like_mujoco(model, device):
    """Myriad and MuJoCo stepped side by side from the same state for 0.5 s: the box comes to
    rest on the floor, the ball falls freely. At the state both reach, MuJoCo's sensors (after
    mj_forward: MuJoCo's sensordata after mj_step describes the state before the step) and ours
    agree: the sole's touch sensor carries the weight, the heel's (a capsule zone across the back
    edge) part of it, the top's nothing; the accelerometer at rest reads +g, rotated into the
    site's frame, the falling one 0; the falling ball's speed is the same."""
    mj = model.mj_model
    sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(dt=H, substeps=1))
    d = mujoco.MjData(mj)
    for _ in range(100):
        sim.step()
        mujoco.mj_step(mj, d)
    mujoco.mj_forward(mj, d)
    ours, theirs = sim.sensor_data[0].cpu().numpy(), d.sensordata

    def reading(kind, site):
        i = next(i for i in range(mj.nsensor) if mj.sensor_type[i] == int(kind)
                 and mj.sensor_objid[i] == mj.site(site).id)
        cols = slice(mj.sensor_adr[i], mj.sensor_adr[i] + mj.sensor_dim[i])
        return ours[cols], theirs[cols]

    S = mujoco.mjtSensor
    weight = 2 * 9.81
    sole, heel, top = (reading(S.mjSENS_TOUCH, s) for s in ("sole", "heel", "top"))
    capped = ours[mj.sensor_adr[mj.nsensor - 1]], theirs[mj.sensor_adr[mj.nsensor - 1]]
    # at rest both solvers carry the weight; how the box's four corner contacts share it is
    # statically indeterminate (the heel sees two of them), so the heel is held to 10 %
    np.testing.assert_allclose(sole[0], weight, rtol=1e-3)
    np.testing.assert_allclose(sole[0], sole[1], rtol=1e-2)
    np.testing.assert_allclose(heel[0], heel[1], atol=0.1 * weight)
    assert 0.2 * weight < heel[0] < 0.8 * weight
    assert top[0] == 0 and top[1] == 0
    assert capped[0] == capped[1] == 5.0                          # a positive cutoff
    # accelerometers: at rest +g in the site frame (to the resting box's leftover motion),
    # in free fall 0, on a world site +g (MuJoCo 4.0: the world's own acceleration)
    rest, fall, world = (reading(S.mjSENS_ACCELEROMETER, s) for s in ("imu", "imu2", "world_site"))
    np.testing.assert_allclose(rest[0], rest[1], atol=2e-2)
    np.testing.assert_allclose(np.linalg.norm(rest[0]), 9.81, atol=2e-2)
    np.testing.assert_allclose(fall[0], 0, atol=1e-3)
    np.testing.assert_allclose(fall[1], 0, atol=1e-9)
    np.testing.assert_allclose(world[0], [0, 0, 9.81], atol=1e-6)
    np.testing.assert_allclose(world[0], world[1], atol=1e-6)
    velocimeter = reading(S.mjSENS_VELOCIMETER, "imu2")
    np.testing.assert_allclose(velocimeter[0], velocimeter[1], atol=1e-4)   # same Euler steps
    gyro = reading(S.mjSENS_GYRO, "imu")
    np.testing.assert_allclose(gyro[0], gyro[1], atol=1e-2)


def test_touch_zones_are_mujocos_ray_test():
    """Touch counts a contact when the ray from its point, away from the sensor's body, meets
    the site's zone: `sensors.in_zone` against MuJoCo's mju_rayGeom >= 0 for every site shape,
    on random rays from inside, near and far."""
    rng = np.random.default_rng(0)
    shapes = [mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE,
              mujoco.mjtGeom.mjGEOM_ELLIPSOID, mujoco.mjtGeom.mjGEOM_CYLINDER,
              mujoco.mjtGeom.mjGEOM_BOX]
    n = 400
    kinds = np.repeat(np.arange(len(shapes)), n)
    size = rng.uniform(0.05, 0.3, (len(kinds), 3))
    pos = rng.normal(size=(len(kinds), 3)) * 0.1
    quat = rng.normal(size=(len(kinds), 4))
    quat /= np.linalg.norm(quat, axis=1, keepdims=True)
    point = pos + rng.normal(size=(len(kinds), 3)) * 0.3
    # toward the shape, roughly, half of them: grazing rays make both outcomes common
    toward = (pos - point) * rng.choice([-1.0, 1.0], (len(kinds), 1))
    direction = toward / np.linalg.norm(toward, axis=1, keepdims=True)
    direction += rng.normal(size=(len(kinds), 3)) * 0.4
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    expected = []
    for k in range(len(kinds)):
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, quat[k])
        expected.append(mujoco.mju_rayGeom(pos[k], mat, size[k], point[k], direction[k],
                                           int(shapes[kinds[k]])) >= 0)
    xform = np.concatenate([pos, quat[:, [1, 2, 3, 0]]], 1)
    out = wp.zeros(len(kinds), dtype=wp.int32)
    wp.launch(_in_zone, dim=len(kinds), inputs=[
        wp.array(np.asarray([int(shapes[k]) for k in kinds], np.int32), dtype=wp.int32),
        wp.array(size, dtype=wp.vec3), wp.array(xform, dtype=wp.transform),
        wp.array(point, dtype=wp.vec3), wp.array(direction, dtype=wp.vec3), out])
    got = out.numpy().astype(bool)
    for k in range(len(shapes)):                            # both outcomes well represented
        assert 0.2 < np.mean(np.asarray(expected)[kinds == k]) < 0.8, shapes[k]
    np.testing.assert_array_equal(got, expected)


@wp.kernel
def _in_zone(kind: wp.array(dtype=wp.int32), size: wp.array(dtype=wp.vec3),
             x: wp.array(dtype=wp.transform), point: wp.array(dtype=wp.vec3),
             direction: wp.array(dtype=wp.vec3), out: wp.array(dtype=wp.int32)):
    i = wp.tid()
    if sensors.in_zone(kind[i], size[i], x[i], point[i], direction[i]):
        out[i] = 1


def test_unsupported_sensors_are_skipped_with_one_warning_naming_them():
    xml = SENSORS_XML.replace("<sensor>", """<sensor>
    <rangefinder name="lidar" site="tip"/><subtreecom name="com" body="arm"/>""")
    with pytest.warns(RuntimeWarning, match=r"with_extras: 2 sensor\(s\) skipped, not computed: "
                      r"sensor 'lidar' \(mjSENS_RANGEFINDER\), sensor 'com' \(mjSENS_SUBTREECOM\)"):
        model = myriad.load_xml(xml, "with_extras")
    reference = myriad.load_xml(SENSORS_XML, "sensors")
    # the others keep MuJoCo's order, closed up over the skipped ones
    np.testing.assert_array_equal(model.sensor_type, reference.sensor_type)
    np.testing.assert_array_equal(model.sensor_adr, reference.sensor_adr)
    assert model.nsensordata == reference.nsensordata == model.mj_model.nsensordata - 4
    assert model.sensor_slice("sole_touch") == slice(model.mj_model.sensor("sole_touch").adr[0] - 4,
                                                     model.mj_model.sensor("sole_touch").adr[0] - 3)
    with pytest.raises(KeyError, match="no sensor named 'lidar'"):
        model.sensor_index("lidar")


def test_force_torque_sensors_match_mujoco_inverse_dynamics(device):
    """In free flight under random joint forces and forces applied to the bodies, each foot
    sensor reads what MuJoCo's sensors read for the same state, acceleration and applied
    forces (mj_inverse, xfrc_applied): an applied force is external, as a contact is, not
    something the joint carries."""
    model = myriad.load(myriad.asset_path("ant.xml"))
    h = 1 / 120
    sim = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(dt=h, substeps=1, constraints=False))
    gen = torch.Generator().manual_seed(0)
    for _ in range(20):
        sim.joint_force = (torch.randn(2, model.nv, generator=gen) * 0.5).to(sim.torch_device)
        sim.body_force = (torch.randn(2, model.nbody, 6, generator=gen) * 0.3).to(
            sim.torch_device)
        before = sim.qd.cpu().numpy().copy()
        sim.step()
    mj, d = free_motion_mujoco(model, h)
    readings = sim.sensor_data.cpu().numpy()
    assert readings.shape == (2, mj.nsensordata)
    for e in range(2):
        d.qpos[:] = model.qpos_to_mujoco(sim.q[e].cpu().numpy())
        d.qvel[:] = sim.qd[e].cpu().numpy()
        d.qacc[:] = (d.qvel - before[e]) / h
        d.xfrc_applied[1:] = sim.body_force[e].cpu().numpy()
        mujoco.mj_inverse(mj, d)
        expected = d.sensordata
        scale = np.abs(expected).max()
        np.testing.assert_allclose(readings[e], expected, atol=1e-4 * scale + 1e-5)
        # sensor_wrench: the same values per sensor site, force then torque
        np.testing.assert_array_equal(readings[e].reshape(-1, 6),
                                      sim.sensor_wrench[e].cpu().numpy())


def test_standing_ant_feet_carry_its_weight(device):
    model = myriad.load(myriad.asset_path("ant.xml"))
    sim = myriad.Simulator(model, num_envs=1, device=device)
    for _ in range(600):  # settle for 10 s (the legs fold onto their joint limits)
        sim.step()
    # it stands still: its pose moves by less than 1e-4 (m or rad) over one more second (its
    # velocity reading keeps ~0.01 rad/s of the solve's residual at rest: docs/physics.md)
    pose = sim.q[0].clone()
    for _ in range(60):
        sim.step()
    assert (sim.q[0] - pose).abs().max().item() < 1e-4
    assert sim.qd.abs().max().item() < 2e-2
    # each foot body: parent force + ground contact + its weight = 0; summed over the feet the
    # parents hold -(total weight) + (feet weight): the ground carries the whole ant.
    # Averaged over one more second: in this four-foot stance (friction statically
    # indeterminate, legs on their limits) 4 + 1 sweeps leave the friction impulses of the last
    # substep jittering by up to ~4 % of the weight from step to step (the contact issue);
    # each step is held to 5 %, the average to the tolerances of an equilibrium.
    total = float(model.body_mass.sum())
    weight = 9.81 * total
    feet = [model.site_body[s] for s in sim.sensor_sites]
    feet_mass = float(model.body_mass[feet].sum())
    sensed, ground = [], []
    for _ in range(60):
        sim.step()
        rot = sim.site_pose[0, sim.sensor_sites, 3:].cpu().numpy()
        world_forces = np.zeros(3)
        for k, (qx, qy, qz, qw) in enumerate(rot):
            r = np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)],
                          [2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)],
                          [2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)]])
            world_forces += r @ sim.sensor_wrench[0, k, :3].cpu().numpy()
        sensed.append(world_forces)
        ground.append(sim.net_contact_force[0].sum(0).cpu().numpy())
    sensed, ground = np.asarray(sensed), np.asarray(ground)
    np.testing.assert_allclose(sensed, np.broadcast_to([0, 0, -9.81 * (total - feet_mass)], sensed.shape),
                               atol=5e-2 * weight)
    np.testing.assert_allclose(ground, np.broadcast_to([0, 0, weight], ground.shape), atol=5e-2 * weight)
    np.testing.assert_allclose(sensed.mean(0), [0, 0, -9.81 * (total - feet_mass)], atol=2e-2 * weight)
    np.testing.assert_allclose(ground.mean(0), [0, 0, weight], atol=1e-2 * weight)


# Two links hanging from a hinge each, a sensor at each joint; the force sensors also split
# as PhysX's articulation sensors report them (Model.force_sensor_split, docs/isaacgym.md).
CHAIN_XML = """<mujoco><option timestep="0.005"/><worldbody>
  <body name="upper" pos="0 0 2"><joint type="hinge" axis="0 1 0" damping="0.5"/>
    <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.04" mass="1"/>
    <site name="s_upper" pos="0 0 -0.1" euler="0 20 0"/>
    <body name="lower" pos="0 0 -0.5"><joint type="hinge" axis="0 1 0" damping="0.5"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.04" mass="2"/>
      <site name="s_lower"/>
    </body></body></worldbody>
  <sensor><force site="s_upper"/><torque site="s_upper"/><force site="s_lower"/></sensor>
</mujoco>"""


def test_split_force_sensors_read_physx_forward_dynamics_and_constraint_parts(device):
    """Hanging at rest each link's forward-dynamics part is minus the weight of its subtree
    (PhysX: minus the articulated zero-acceleration force) and the constraint part is 0
    (joints act inside the articulation). Swinging, the leaf's forward part stays exactly its
    weight in force (its joint wrench and its articulated inertia times its classical
    acceleration differ by the external forces alone), the upper link's does not. The split
    leaves the MuJoCo-meaning readings bit for bit as they were."""
    plain = myriad.load_xml(CHAIN_XML, "chain")
    split = myriad.load_xml(CHAIN_XML, "chain")
    split.force_sensor_split = True
    params = myriad.SimParams(dt=0.005, substeps=2)
    sims = [myriad.Simulator(mdl, num_envs=2, device=device, params=params)
            for mdl in (plain, split)]
    assert sims[0].sensor_forward.shape == (2, 0, 6)     # nothing without the split
    start = torch.tensor([[0.0, 0.0], [0.9, -1.2]], device=sims[1].torch_device)
    for sim in sims:
        sim.q = start
        for _ in range(40):
            sim.step()
    torch.testing.assert_close(sims[1].sensor_wrench, sims[0].sensor_wrench, rtol=0, atol=0)
    torch.testing.assert_close(sims[1].sensor_data, sims[0].sensor_data, rtol=0, atol=0)
    sim = sims[1]
    g = 9.81
    forward = sim.sensor_forward.cpu().numpy()
    constraint = sim.sensor_constraint.cpu().numpy()
    assert np.abs(constraint).max() == 0.0              # no contacts in this scene
    np.testing.assert_allclose(forward[0, :, :3], [[0, 0, -3 * g], [0, 0, -2 * g]], atol=1e-4)
    np.testing.assert_allclose(forward[0, :, 3:], 0.0, atol=1e-4)   # sites on the vertical line
    assert sim.qd[1].abs().min().item() > 0.5            # env 1 swings
    np.testing.assert_allclose(forward[1, 1, :3], [0, 0, -2 * g], atol=1e-4 * g)
    assert np.abs(forward[1, 0, :3] - [0, 0, -3 * g]).max() > 0.5
    # the leaf's torque about its joint: its weight's moment about the site there
    com = sim.body_com[1, 1].cpu().numpy()
    site = sim.site_pose[1, sim.sensor_sites[1], :3].cpu().numpy()
    np.testing.assert_allclose(forward[1, 1, 3:], np.cross(com - site, [0, 0, -2 * g]),
                               atol=1e-4 * g)


def test_split_force_sensors_on_a_standing_ants_feet(device):
    """Each foot of an ant at rest on the ground: the constraint part is the ground's force on
    that foot (what `net_contact_force` reports for it: the feet are leaves), the forward part
    minus the foot's weight, and the two together minus the MuJoCo-meaning reading (the force
    the parent gives the foot), as the foot is at rest."""
    model = myriad.load(myriad.asset_path("ant.xml"))
    model.force_sensor_split = True
    sim = myriad.Simulator(model, num_envs=1, device=device)
    for _ in range(600):
        sim.step()
    assert sim.qd.abs().max().item() < 2e-2
    feet = [int(model.site_body[s]) for s in sim.sensor_sites]
    assert all(not (model.body_parent == b).any() for b in feet)
    weight = 9.81 * float(model.body_mass.sum())
    constraint = sim.sensor_constraint[0].cpu().numpy()
    forward = sim.sensor_forward[0].cpu().numpy()
    np.testing.assert_allclose(constraint[:, :3], sim.net_contact_force[0, feet].cpu().numpy(),
                               atol=1e-5 * weight)
    assert constraint[:, 2].sum() == pytest.approx(weight, rel=0.05)
    np.testing.assert_allclose(forward[:, :3], np.outer(-9.81 * model.body_mass[feet],
                                                        [0, 0, 1]), atol=2e-3 * weight)
    rot = sim.site_pose[0, sim.sensor_sites, 3:].cpu().numpy()
    parent = np.stack([_rotate(q, w[:3]) for q, w in zip(rot, sim.sensor_wrench[0].cpu().numpy())])
    np.testing.assert_allclose(forward[:, :3] + constraint[:, :3], -parent, atol=1e-2 * weight)


def _rotate(q, v):
    """v rotated by the quaternion q (x, y, z, w)."""
    x, y, z, w = q
    u = np.array([x, y, z])
    return v + 2 * np.cross(u, np.cross(u, v) + w * v)
