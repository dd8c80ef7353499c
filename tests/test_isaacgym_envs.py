"""What IsaacGymEnvs' tasks call beyond the basic API (issue 41, item 2), in the original's
style: terrain_utils and triangle-mesh terrain (AnymalTerrain), force sensors (Ant, Humanoid,
the hands, BallBalance), collapse_fixed_joints and fixed-joint indices (Franka, the hands,
ANYmal), attractors (BallBalance), tendons (ShadowHand), actor scale (Trifinger's object),
tensors acquired before prepare_sim (FrankaCubeStack), start poses (FrankaCabinet), V-HACD
(Trifinger). Physics is checked against closed forms or Myriad's own API on the same scene.
"""


import math
import time

import numpy as np
import pytest
import torch

from isaacgym import gymapi, gymtorch, gymutil
from isaacgym import terrain_utils as tu
from isaacgym.torch_utils import quat_rotate, quat_rotate_inverse
from test_host_sync import recording_syncs

G = 9.81


def z_up_sim(dt=1 / 100, substeps=1):
    gym = gymapi.acquire_gym()
    p = gymapi.SimParams()
    p.up_axis = gymapi.UP_AXIS_Z
    p.gravity = gymapi.Vec3(0.0, 0.0, -G)
    p.dt, p.substeps = dt, substeps
    return gym, gym.create_sim(-1, -1, gymapi.SIM_PHYSX, p)


def envs_with(gym, sim, asset, poses, name="actor"):
    envs = []
    for i, pose in enumerate(poses):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2)
        gym.create_actor(env, asset, pose, name, i, 0, 0)
        envs.append(env)
    return envs


def fixed_base_asset(folder, name, text, **options):
    """A new z-up sim and the asset `text` written to folder/name, its base fixed, `options`
    (AssetOptions attributes) set: (gym, sim, asset, the AssetOptions)."""
    (folder / name).write_text(text)
    gym, sim = z_up_sim()
    asset_options = gymapi.AssetOptions()
    asset_options.fix_base_link = True
    for key, value in options.items():
        setattr(asset_options, key, value)
    return gym, sim, gym.load_asset(sim, str(folder), name, asset_options), asset_options


def settle(gym, sim, steps):
    for _ in range(steps):
        gym.simulate(sim)
        gym.fetch_results(sim, True)
    gym.refresh_actor_root_state_tensor(sim)


# ------------------------------------------------------------------ terrain_utils
def tile(width=40, length=30):
    return tu.SubTerrain("t", width=width, length=length, vertical_scale=0.005,
                         horizontal_scale=0.1)


def test_terrain_generators_build_the_shapes_they_name():
    t = tu.sloped_terrain(tile(), slope=0.5)
    # 0.5 m per m: 0.05 m per 0.1 m sample, 10 raw units of 5 mm
    assert t.height_field_raw.dtype == np.int16 and t.height_field_raw.shape == (40, 30)
    assert (t.height_field_raw[:, 0] == 10 * np.arange(40)).all()
    assert (t.height_field_raw == t.height_field_raw[:, :1]).all()

    t = tu.pyramid_sloped_terrain(tile(), slope=0.2, platform_size=1.0)
    h = t.height_field_raw
    assert h[0].max() == 0 and h[:, 0].max() == 0               # 0 at the edges
    top = h.max()
    assert top > 0 and (h[20 - 5:20 + 5, 15 - 5:15 + 5] == top).all()   # a flat platform
    assert (np.diff(h[:20, 15]) >= 0).all()                      # rising to it

    t = tu.pyramid_stairs_terrain(tile(), step_width=0.3, step_height=-0.1, platform_size=1.0)
    h = t.height_field_raw
    levels = np.unique(h)
    assert levels.max() == 0 and (levels % 20 == 0).all()        # 0.1 m steps down, from 0
    assert h[20, 15] == levels.min() and h[0, 0] == 0

    np.random.seed(0)
    t = tu.discrete_obstacles_terrain(tile(), 0.2, 0.5, 1.0, 20, platform_size=1.0)
    assert set(np.unique(t.height_field_raw)) <= {-40, -20, 0, 20, 40}
    assert (t.height_field_raw[15:25, 10:20] == 0).all()         # the central platform

    t = tu.random_uniform_terrain(tile(), -0.05, 0.05, step=0.01, downsampled_scale=0.5)
    assert -10 <= t.height_field_raw.min() and t.height_field_raw.max() <= 10
    assert np.unique(t.height_field_raw).size > 3

    t = tu.stairs_terrain(tile(), step_width=0.5, step_height=0.05)
    assert (t.height_field_raw[:, 0] == 10 * (np.arange(40) // 5)).all()

    t = tu.wave_terrain(tile(), num_waves=2, amplitude=0.1)
    assert np.abs(t.height_field_raw).max() <= 40

    t = tu.stepping_stones_terrain(tile(), stone_size=0.5, stone_distance=0.2, max_height=0.05,
                                   platform_size=1.0, depth=-1.0)
    h = t.height_field_raw
    assert h.min() == -200 and (h[15:25, 10:20] == 0).all()
    assert ((h > -200) & ((h < -10) | (h > 10))).sum() == 0     # stones within ±0.05 m


def test_trimesh_of_a_height_field():
    raw = np.zeros((4, 3), np.int16)
    raw[2:, :] = 40                          # a 0.2 m step between rows 1 and 2
    v, t = tu.convert_heightfield_to_trimesh(raw, 0.1, 0.005)
    assert v.shape == (12, 3) and t.shape == (12, 3) and t.dtype == np.uint32
    np.testing.assert_allclose(v[:, 2], raw.ravel() * 0.005, atol=1e-7)
    a, b, c = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
    assert (np.cross(b - a, c - a)[:, 2] > 0).all()               # every triangle faces up
    # steeper than the threshold: the lower row's vertices move under the higher row
    v, _ = tu.convert_heightfield_to_trimesh(raw, 0.1, 0.005, slope_threshold=0.75)
    np.testing.assert_allclose(v.reshape(4, 3, 3)[1, :, 0], 0.2, atol=1e-6)
    np.testing.assert_allclose(v.reshape(4, 3, 3)[[0, 2, 3], 0, 0], [0.0, 0.2, 0.3], atol=1e-6)


def stairs_mesh():
    """A stepped pyramid of 0.1 m steps, 0.5 m deep, as AnymalTerrain makes its mesh."""
    t = tu.SubTerrain("stairs", width=60, length=60, vertical_scale=0.005, horizontal_scale=0.1)
    tu.pyramid_stairs_terrain(t, step_width=0.5, step_height=0.1, platform_size=1.0)
    vertices, triangles = tu.convert_heightfield_to_trimesh(t.height_field_raw, 0.1, 0.005,
                                                            slope_threshold=0.75)
    return t, vertices, triangles


def test_a_box_rests_on_each_step_of_a_triangle_mesh_terrain():
    t, vertices, triangles = stairs_mesh()
    gym, sim = z_up_sim()
    params = gymapi.TriangleMeshParams()
    params.nb_vertices, params.nb_triangles = len(vertices), len(triangles)
    params.transform.p = gymapi.Vec3(-3.0, -3.0, 0.0)
    gym.add_triangle_mesh(sim, vertices.flatten(order="C"), triangles.flatten(order="C"),
                          params)
    # every 0.1 m step became a wall, and there is no smaller step: any riser below 0.1 m
    # makes the same walls (the slope threshold × spacing, 0.075 m, among them)
    assert 0.0 < sim.terrain["riser"] < 0.1
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    # world x = -3 + 0.1 i: samples 2 (edge), 7 (first step), 27 (platform)
    xs = [-2.8, -2.25, -0.25]
    heights = [t.height_field_raw[round((x + 3) / 0.1), 30] * 0.005 for x in xs]
    assert heights == pytest.approx([0.0, 0.1, 0.5])
    envs_with(gym, sim, box, [gymapi.Transform(gymapi.Vec3(x, 0.0, h + 0.3))
                              for x, h in zip(xs, heights)])
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    settle(gym, sim, 150)
    np.testing.assert_allclose(root[:, 2].numpy(), np.array(heights) + 0.1, atol=5e-3)
    assert root[:, 7:].abs().max() < 0.05


def test_a_heightfield_holds_a_box_at_its_height():
    gym, sim = z_up_sim()
    params = gymapi.TriangleMeshParams()
    params.nb_vertices, params.nb_triangles = 4, 1
    with pytest.raises(ValueError, match="triangle indices"):
        gym.add_triangle_mesh(sim, np.zeros(12, np.float32), np.array([0, 1, 7], np.uint32),
                              params)
    # a flat height field 100 raw units (0.5 m) high, 2 m across
    hf = gymapi.HeightFieldParams()
    hf.nbRows = hf.nbColumns = 21
    hf.row_scale = hf.column_scale = 0.1
    hf.vertical_scale = 0.005
    hf.transform.p = gymapi.Vec3(-1.0, -1.0, 0.0)
    gym.add_heightfield(sim, np.full((21, 21), 100, np.int16), hf)
    # a second one, 0.25 m high, with other row and column spacings: simulated as triangles
    hf.row_scale, hf.column_scale = 0.1, 0.2
    hf.nbRows = 11                      # samples along y (terrain_utils' columns)
    hf.transform.p = gymapi.Vec3(2.0, -1.0, 0.0)
    gym.add_heightfield(sim, np.full((21, 11), 50, np.int16), hf)
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    envs_with(gym, sim, box, [gymapi.Transform(gymapi.Vec3(0.0, 0.0, 0.8)),
                              gymapi.Transform(gymapi.Vec3(3.0, 0.0, 0.8))])
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    settle(gym, sim, 120)
    np.testing.assert_allclose(root[:, 2].numpy(), [0.6, 0.35], atol=5e-3)



def test_asset_speed_caps_hold_a_spinning_box():
    """AssetOptions.max_angular_velocity (Isaac Gym's default 64 rad/s; Factory sets 2π) caps
    a body's spin as PhysX does: a box spun at 100 rad/s about its vertical axis, in the air,
    turns at the cap after one simulate; the asset without a smaller cap keeps Isaac Gym's 64."""
    gym, sim = z_up_sim()
    default = gym.create_box(sim, 0.2, 0.2, 0.2)
    options = gymapi.AssetOptions()
    options.max_angular_velocity = 2 * math.pi
    slow = gym.create_box(sim, 0.2, 0.2, 0.2, options)
    env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
    gym.create_actor(env, default, gymapi.Transform(gymapi.Vec3(0, 0, 5)), "default", 0, 0, 0)
    gym.create_actor(env, slow, gymapi.Transform(gymapi.Vec3(1, 0, 5)), "slow", 0, 0, 0)
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    gym.refresh_actor_root_state_tensor(sim)
    spin = root.clone()
    spin[:, 12] = 100.0
    gym.set_actor_root_state_tensor(sim, gymtorch.unwrap_tensor(spin))
    settle(gym, sim, 1)
    np.testing.assert_allclose(root[:, 12].numpy(), [64.0, 2 * math.pi], rtol=1e-4)


# ------------------------------------------------------------------ force sensors
PENDULUM = """<mujoco><worldbody>
  <body name="mount" pos="0 0 1">
    <geom type="box" size=".05 .05 .05" contype="0" conaffinity="0"/>
    <body name="bob" pos="0 0 -0.1">
      <joint name="swing" type="hinge" axis="0 1 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.4" size="0.02"/>
      <site name="foot"/>
    </body>
  </body></worldbody>
  <sensor><force site="foot"/><torque site="foot"/></sensor>
</mujoco>"""


def _props(forward=True, constraint=True, world=False):
    props = gymapi.ForceSensorProperties()
    props.enable_forward_dynamics_forces = forward
    props.enable_constraint_solver_forces = constraint
    props.use_world_frame = world
    return props


def test_force_sensors_read_physx_parts_on_a_swinging_pendulum(tmp_path):
    """PhysX's articulation sensor on a bob swinging freely on a hinge (no contacts): the
    forward-dynamics part is minus the articulated zero-acceleration force, for this leaf its
    weight at its centre of mass (-m g), whatever its motion; the constraint part is 0 (the
    joint acts inside the articulation); the default reads their sum in the sensor's frame."""
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "pendulum.xml", PENDULUM,
                                          default_dof_drive_mode=gymapi.DOF_MODE_NONE)
    assert gym.get_asset_force_sensor_count(asset) == 0      # the file's sensors: not imported
    bob = gym.find_asset_rigid_body_index(asset, "bob")
    assert gym.create_asset_force_sensor(asset, bob, gymapi.Transform()) == 0
    assert gym.create_asset_force_sensor(asset, bob, gymapi.Transform(),
                                         _props(constraint=False, world=True)) == 1
    assert gym.create_asset_force_sensor(asset, bob, gymapi.Transform(),
                                         _props(forward=False, world=True)) == 2
    with pytest.raises(TypeError, match="ForceSensorProperties"):
        gym.create_asset_force_sensor(asset, bob, gymapi.Transform(), gymapi.Transform())
    envs = envs_with(gym, sim, asset, [gymapi.Transform()] * 3)
    assert gym.get_sim_force_sensor_count(sim) == 9
    assert gym.get_actor_force_sensor_count(envs[0], 0) == 3
    gym.prepare_sim(sim)
    sensors = gymtorch.wrap_tensor(gym.acquire_force_sensor_tensor(sim))
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim))
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    dofs[:, 0] = torch.tensor([0.0, 0.5, -1.0])
    gym.set_dof_state_tensor(sim, gymtorch.unwrap_tensor(dofs))
    for _ in range(30):
        gym.simulate(sim)
    gym.refresh_force_sensor_tensor(sim)
    gym.refresh_rigid_body_state_tensor(sim)
    gym.refresh_dof_state_tensor(sim)
    assert sensors.shape == (9, 6)
    readings = sensors.reshape(3, 3, 6)
    mass = gym.get_actor_rigid_body_properties(envs[0], 0)[bob].mass
    weight = torch.tensor([0.0, 0.0, -mass * G])
    assert dofs[1:, 1].abs().min().item() > 0.5                # envs 1 and 2 swing
    # forward dynamics, world axes: the weight, and its moment about the sensor (the joint)
    quat = bodies.reshape(3, -1, 13)[:, bob, 3:7]
    com = quat_rotate(quat, torch.tensor([[0.0, 0.0, -0.2]] * 3))   # the capsule's middle
    torch.testing.assert_close(readings[:, 1, :3], weight.expand(3, 3), atol=1e-4 * mass * G,
                               rtol=0)
    torch.testing.assert_close(readings[:, 1, 3:], torch.cross(com, weight.expand(3, 3), dim=1),
                               atol=1e-4 * mass * G, rtol=0)
    assert readings[:, 2].abs().max().item() == 0.0              # no contacts
    # the default: both parts, in the sensor's (the bob's) frame
    torch.testing.assert_close(readings[:, 0, :3], quat_rotate_inverse(quat, readings[:, 1, :3]),
                               atol=1e-4 * mass * G, rtol=0)
    torch.testing.assert_close(readings[:, 0, 3:], quat_rotate_inverse(quat, readings[:, 1, 3:]),
                               atol=1e-4 * mass * G, rtol=0)
    # at rest hanging straight down: minus the bob's weight, no moment
    torch.testing.assert_close(readings[0, 0], torch.cat([weight, torch.zeros(3)]),
                               atol=1e-4 * mass * G, rtol=0)
    # a refresh, as IsaacGymEnvs does every step, moves nothing between host and device
    with recording_syncs() as syncs:
        gym.refresh_force_sensor_tensor(sim)
    assert syncs == []
    # one sensor as an object: env 2's third sensor is row 2·3 + 2 of the tensor
    sensor = gym.get_actor_force_sensor(envs[2], 0, 2)
    assert sensor.get_global_index() == 8
    data = sensor.get_forces()
    assert [data.force.x, data.force.y, data.force.z, data.torque.x, data.torque.y,
            data.torque.z] == pytest.approx(sensors[8].tolist(), abs=1e-6)
    with pytest.raises(IndexError, match="has 3 force sensors; index 3"):
        gym.get_actor_force_sensor(envs[0], 0, 3)


def test_constraint_force_sensors_tell_standing_from_lifted(tmp_path):
    """legged_gym's foot sensors (forward dynamics off, constraint solver on, world frame)
    read the ground's force on the body: a box resting on the ground reads its weight up, one
    held in the air (fixed to the world far above) reads 0, so `Fz > 1` tells contact; with
    forward dynamics only, both read minus the weight."""
    gym, sim = z_up_sim()
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    gym.create_asset_force_sensor(box, 0, gymapi.Transform(), _props(forward=False, world=True))
    gym.create_asset_force_sensor(box, 0, gymapi.Transform(), _props(constraint=False,
                                                                      world=True))
    envs_with(gym, sim, box, [gymapi.Transform(gymapi.Vec3(0, 0, 0.1)),
                              gymapi.Transform(gymapi.Vec3(0, 0, 0.1))])
    gym.prepare_sim(sim)
    sensors = gymtorch.wrap_tensor(gym.acquire_force_sensor_tensor(sim)).reshape(2, 2, 6)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    mass = 0.2 ** 3 * 1000.0
    for step in range(60):
        root[1, 2], root[1, 7:] = 5.0, 0.0        # env 1's box held high, at rest
        gym.set_actor_root_state_tensor(sim, gymtorch.unwrap_tensor(root))
        gym.simulate(sim)
        gym.refresh_actor_root_state_tensor(sim)
    gym.refresh_force_sensor_tensor(sim)
    assert sensors[0, 0, 2].item() == pytest.approx(mass * G, rel=0.02)
    assert sensors[0, 0, 2].item() > 1 and abs(sensors[1, 0, 2].item()) < 1
    assert sensors[1, 0].abs().max().item() == 0.0
    torch.testing.assert_close(sensors[:, 1, :3],
                               torch.tensor([[0.0, 0.0, -mass * G]] * 2), atol=1e-3, rtol=0)


# ------------------------------------------------------------------ fixed joints
ARM_URDF = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"><inertial><mass value="2"/><inertia ixx=".01" iyy=".01" izz=".01"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size=".1 .1 .1"/></geometry></collision></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" effort="10"
    velocity="5"/></joint>
  <link name="upper"><inertial><origin xyz="0 0 0.15"/><mass value="1"/><inertia ixx=".01"
    iyy=".01" izz=".001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 0.15"/><geometry><box size=".04 .04 .3"/></geometry>
    </collision></link>
  <joint name="hand_joint" type="fixed"><parent link="upper"/><child link="hand"/>
    <origin xyz="0 0 0.3"/></joint>
  <link name="hand"><inertial><mass value="0.5"/><inertia ixx=".001" iyy=".001" izz=".001"
    ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><geometry><sphere radius="0.04"/></geometry></collision></link>
</robot>"""


def test_fixed_joints_count_as_isaac_gym_counts_them_and_collapse_into_their_parent(tmp_path):
    gym, sim, arm, options = fixed_base_asset(tmp_path, "arm.urdf", ARM_URDF)
    # joint i moves body i + 1, the fixed one too (FrankaCubeStack indexes the Jacobian so)
    assert gym.get_asset_joint_dict(arm) == {"shoulder": 0, "hand_joint": 1}
    assert gym.get_asset_rigid_body_dict(arm) == {"base": 0, "upper": 1, "hand": 2}
    options.collapse_fixed_joints = True
    collapsed = gym.load_asset(sim, str(tmp_path), "arm.urdf", options)
    assert gym.get_asset_rigid_body_names(collapsed) == ["base", "upper"]
    assert gym.get_asset_rigid_shape_count(collapsed) == 3          # the hand's sphere moved
    upper = collapsed.body_props[1]
    assert upper.mass == pytest.approx(1.5)
    assert upper.com.z == pytest.approx((1.0 * 0.15 + 0.5 * 0.3) / 1.5)
    # a fixed joint with dont_collapse="true" keeps its link (legged_gym's ANYmal finds its
    # FOOT links so, and penalizes contacts of the shanks, not of the feet)
    (tmp_path / "kept.urdf").write_text(ARM_URDF.replace('name="hand_joint" type="fixed"',
                                                         'name="hand_joint" type="fixed" '
                                                         'dont_collapse="true"'))
    kept = gym.load_asset(sim, str(tmp_path), "kept.urdf", options)
    assert gym.get_asset_rigid_body_names(kept) == ["base", "upper", "hand"]
    assert [p.mass for p in kept.body_props] == pytest.approx([2.0, 1.0, 0.5])
    # the start pose of a body, before prepare_sim (FrankaCabinet reads it to place props)
    env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
    gym.create_actor(env, arm, gymapi.Transform(gymapi.Vec3(0.5, 0.0, 1.0)), "arm", 0, 0, 0)
    hand = gym.find_actor_rigid_body_handle(env, 0, "hand")
    before = gym.get_rigid_transform(env, hand)
    assert (before.p.x, before.p.y, before.p.z) == pytest.approx((0.5, 0.0, 1.4))
    gym.prepare_sim(sim)
    after = gym.get_rigid_transform(env, hand)
    assert (after.p.x, after.p.y, after.p.z) == pytest.approx((0.5, 0.0, 1.4), abs=1e-5)


def test_a_urdf_joints_velocity_limit_is_its_dofs_maximum_speed(tmp_path):
    """Isaac Gym reads `<limit velocity="5">` into the DOF's `velocity` property (legged_gym's
    dof_vel_limits), and PhysX holds the joint to it. The arm's shoulder, pushed by 10 N·m
    from rest for 0.2 s (about 25 rad/s unhindered, short of its position limits at 5 and
    7 rad/s), turns at 5 rad/s in env 0 and at the 7 rad/s set for env 1; an MJCF file has
    no such limit (PhysX's default, 100)."""
    gym, sim, arm, _ = fixed_base_asset(tmp_path, "arm.urdf", ARM_URDF,
                                        disable_gravity=True)
    assert gym.get_asset_dof_properties(arm)["velocity"].tolist() == [5.0]
    envs = envs_with(gym, sim, arm, [gymapi.Transform()] * 2)
    props = gym.get_actor_dof_properties(envs[1], 0)
    props["velocity"][0] = 7.0
    gym.set_actor_dof_properties(envs[1], 0, props)
    gym.prepare_sim(sim)
    state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim)).view(2, 2)
    effort = torch.full((2,), 10.0)
    for _ in range(20):
        gym.set_dof_actuation_force_tensor(sim, gymtorch.unwrap_tensor(effort))
        gym.simulate(sim)
        gym.fetch_results(sim, True)
    gym.refresh_dof_state_tensor(sim)
    torch.testing.assert_close(state[:, 1], torch.tensor([5.0, 7.0]), atol=1e-4, rtol=0)
    gym2, sim2, lever, _ = fixed_base_asset(tmp_path, "lever.xml", TENDON_LEVER)
    assert gym2.get_asset_dof_properties(lever)["velocity"].tolist() == [100.0]


def test_acquiring_a_tensor_before_prepare_sim_builds_the_sim(tmp_path):
    gym, sim, arm, _ = fixed_base_asset(tmp_path, "arm.urdf", ARM_URDF)
    envs = envs_with(gym, sim, arm, [gymapi.Transform()] * 2)
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))    # as FrankaCubeStack
    assert dofs.shape == (2, 2) and sim.myriad is not None
    assert gym.prepare_sim(sim)                                      # then a no-op
    assert gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim)) is dofs
    with pytest.raises(NotImplementedError, match="create_actor after prepare_sim"):
        gym.create_actor(envs[0], arm, gymapi.Transform(), "late", 0, 0, 0)


# ------------------------------------------------------------------ attractors, scale
def test_an_attractor_holds_a_box_corner_at_its_target():
    gym, sim = z_up_sim()
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
    gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0.1, 0.0, 0.9)), "box", 0, 0, 0)
    props = gymapi.AttractorProperties()
    props.stiffness, props.damping = 5e7, 5e3
    props.axes = gymapi.AXIS_TRANSLATION
    props.rigid_handle = 0
    props.offset.p = gymapi.Vec3(-0.1, 0.0, 0.1)            # the top of one face's edge
    props.target.p = gymapi.Vec3(0.0, 0.0, 1.0)             # where it is at the start
    gym.create_rigid_body_attractor(env, props)
    gym.prepare_sim(sim)
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim))
    for _ in range(300):                   # 3 s: it swings about the point and damps nowhere
        gym.simulate(sim)
    gym.refresh_rigid_body_state_tensor(sim)
    p, q = bodies[0, :3], bodies[0, 3:7]
    held = p + rotate(q, torch.tensor([-0.1, 0.0, 0.1]))
    torch.testing.assert_close(held, torch.tensor([0.0, 0.0, 1.0]), atol=2e-3, rtol=0)
    assert p[2].item() < 0.95            # the box hangs below the point (it swung)
    props.axes = gymapi.AXIS_ROTATION
    with pytest.raises(NotImplementedError, match="axes"):
        gym.create_rigid_body_attractor(gym.create_env(z_up_sim()[1], gymapi.Vec3(),
                                                       gymapi.Vec3(1, 1, 1), 1), props)


def test_attractor_targets_move_per_env():
    """set_attractor_target: a box's top held by an attractor at a target of its env's own,
    set before prepare_sim in one env and after it in the other; the held point follows."""
    gym, sim = z_up_sim()
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    envs = envs_with(gym, sim, box, [gymapi.Transform(gymapi.Vec3(0.0, 0.0, 0.9))] * 2)
    props = gymapi.AttractorProperties()
    props.stiffness, props.damping = 5e7, 5e3
    props.axes = gymapi.AXIS_TRANSLATION
    props.rigid_handle = 0
    props.offset.p = gymapi.Vec3(0.0, 0.0, 0.1)             # the middle of the top face
    props.target.p = gymapi.Vec3(0.0, 0.0, 1.0)
    handles = [gym.create_rigid_body_attractor(env, props) for env in envs]
    gym.set_attractor_target(envs[1], handles[1], gymapi.Transform(gymapi.Vec3(0.05, 0.0, 1.0)))
    gym.prepare_sim(sim)
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim))
    settle(gym, sim, 60)
    assert gym.get_attractor_properties(envs[1], handles[1]).target.p.x == pytest.approx(0.05)
    gym.set_attractor_target(envs[0], handles[0], gymapi.Transform(gymapi.Vec3(0.0, 0.1, 1.1)))
    settle(gym, sim, 200)
    gym.refresh_rigid_body_state_tensor(sim)
    held = torch.stack([bodies[e, :3] + rotate(bodies[e, 3:7], torch.tensor([0.0, 0.0, 0.1]))
                        for e in range(2)])
    torch.testing.assert_close(held, torch.tensor([[0.0, 0.1, 1.1], [0.05, 0.0, 1.0]]),
                               atol=2e-3, rtol=0)
    with pytest.raises(ValueError, match="attractor handle 3"):
        gym.set_attractor_target(envs[0], 3, gymapi.Transform())
    # its properties: a new target moves it as set_attractor_target does; its body cannot change
    props = gym.get_attractor_properties(envs[1], handles[1])
    props.target.p = gymapi.Vec3(0.0, -0.05, 1.0)
    gym.set_attractor_properties(envs[1], handles[1], props)
    settle(gym, sim, 200)
    gym.refresh_rigid_body_state_tensor(sim)
    top = bodies[1, :3] + rotate(bodies[1, 3:7], torch.tensor([0.0, 0.0, 0.1]))
    torch.testing.assert_close(top, torch.tensor([0.0, -0.05, 1.0]), atol=2e-3, rtol=0)
    props.rigid_handle = 1
    with pytest.raises(NotImplementedError, match=r"changing \['rigid_handle'\]"):
        gym.set_attractor_properties(envs[1], handles[1], props)


def rotate(q, v):
    """v turned by the quaternion q (x, y, z, w)."""
    u, w = q[:3], q[3]
    return v + 2 * w * torch.cross(u, v, dim=0) + 2 * torch.cross(u, torch.cross(u, v, dim=0),
                                                                  dim=0)


def test_set_actor_scale_scales_an_object_per_env():
    gym, sim = z_up_sim()
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    box = gym.create_box(sim, 0.1, 0.1, 0.1)
    envs = envs_with(gym, sim, box, [gymapi.Transform(gymapi.Vec3(0, 0, 0.3))] * 2)
    assert gym.set_actor_scale(envs[1], 0, 2.0) and gym.get_actor_scale(envs[1], 0) == 2.0
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    settle(gym, sim, 120)
    torch.testing.assert_close(root[:, 2], torch.tensor([0.05, 0.1]), atol=3e-3, rtol=0)
    mass = sim.myriad.sim.body_mass[:, sim.myriad.actor_bodies("a0")[0]]
    torch.testing.assert_close(mass, torch.tensor([1.0, 8.0]), rtol=1e-5, atol=0)


# ------------------------------------------------------------------ tendons
TENDON_HAND = """<mujoco><worldbody><body name="palm">
  <geom type="box" size=".05 .05 .01"/>
  <body name="proximal" pos="0 0 .02"><joint name="j1" type="hinge" axis="1 0 0"/>
    <geom type="capsule" fromto="0 0 0 0 0 .04" size=".01"/>
    <body name="distal" pos="0 0 .04"><joint name="j2" type="hinge" axis="1 0 0"/>
      <geom type="capsule" fromto="0 0 0 0 0 .03" size=".01"/></body></body></body>
  </worldbody>
  <tendon><fixed name="couple" limited="true" range="-0.001 0.001">
    <joint joint="j1" coef="0.007"/><joint joint="j2" coef="-0.007"/></fixed></tendon>
</mujoco>"""


def test_tendon_properties_take_physx_semantics(tmp_path):
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "finger.xml", TENDON_HAND)
    assert gym.get_asset_tendon_count(asset) == 1
    assert gym.get_asset_tendon_name(asset, 0) == "couple"
    props = gym.get_asset_tendon_properties(asset)
    assert props[0].limit_stiffness == 1.0 and props[0].is_fixed_limited   # the options' default
    assert (props[0].num_joints, props[0].num_attachments, props[0].type) == \
        (2, 0, gymapi.TendonType.TENDON_FIXED)
    assert (props[0].fixed_lower_limit, props[0].fixed_upper_limit) == \
        pytest.approx((-0.001, 0.001))
    props[0].limit_stiffness, props[0].damping = 30.0, 0.1             # as ShadowHand sets them
    assert gym.set_asset_tendon_properties(asset, props)
    props[0].is_fixed_limited = False
    with pytest.raises(NotImplementedError, match="is_fixed_limited"):
        gym.set_asset_tendon_properties(asset, props)
    props[0].is_fixed_limited, props[0].fixed_lower_limit = True, 0.01
    with pytest.raises(ValueError, match="fixed_lower_limit 0.01 above fixed_upper_limit "
                                         "0.001"):
        gym.set_asset_tendon_properties(asset, props)
    envs = envs_with(gym, sim, asset, [gymapi.Transform()] * 2)
    # an actor's own values, in its env alone: env 1's damping before prepare_sim, env 0's
    # limit stiffness after it
    mine = gym.get_actor_tendon_properties(envs[1], 0)
    mine[0].damping = 0.5
    gym.set_actor_tendon_properties(envs[1], 0, mine)
    gym.prepare_sim(sim)
    m = sim.myriad.model
    t = m.tendon_names.index("a0/couple")
    assert m.tendon_limit_stiffness[t] == pytest.approx(30.0)
    assert m.tendon_damping[t] == pytest.approx(0.1)
    mine = gym.get_actor_tendon_properties(envs[0], 0)
    mine[0].limit_stiffness = 10.0
    gym.set_actor_tendon_properties(envs[0], 0, mine)
    own = sim.myriad.sim
    torch.testing.assert_close(own.tendon_limit_stiffness[:, t], torch.tensor([10.0, 30.0]))
    torch.testing.assert_close(own.tendon_damping[:, t], torch.tensor([0.1, 0.5]))
    assert gym.get_actor_tendon_properties(envs[1], 0)[0].damping == pytest.approx(0.5)
    # the file's joints and coefficients, through the asset and through an actor
    assert gym.get_asset_fixed_tendon_joint_coefficients(asset, 0) == pytest.approx(
        [0.007, -0.007])
    assert [gym.get_actor_fixed_tendon_joint_name(envs[1], 0, 0, j) for j in (0, 1)] == \
        ["j1", "j2"]
    assert gym.get_actor_tendon_count(envs[0], 0) == 1
    assert gym.find_actor_tendon_index(envs[0], 0, "couple") == 0
    assert gym.find_actor_fixed_tendon_joint_index(envs[0], 0, 0, "j2") == 1
    gym.debug_print_asset(asset, str(tmp_path / "asset.txt"))
    text = (tmp_path / "asset.txt").read_text()
    assert "joint 1: j2 (JOINT_REVOLUTE)" in text and "tendon 0: couple" in text
    assert "dof 0: j1 (DOF_ROTATION): hasLimits=" in text
    with pytest.raises(IndexError, match="1 tendons, not an index 1"):
        gym.get_asset_fixed_tendon_joint_coefficients(asset, 1)


def test_tendon_limits_and_spring_per_actor(tmp_path):
    """An actor's own tendon limits and spring stiffness hold in its env alone: the coupled
    joints' tendon length (0.007·(q1 - q2)) pushed by opposite torques stops at env 1's wider
    limit, and env 0 keeps the file's."""
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "finger.xml", TENDON_HAND)
    props = gym.get_asset_tendon_properties(asset)
    props[0].limit_stiffness = 0.0                      # hard limits (Myriad's 0)
    gym.set_asset_tendon_properties(asset, props)
    envs = envs_with(gym, sim, asset, [gymapi.Transform()] * 2)
    wide = gym.get_actor_tendon_properties(envs[1], 0)
    wide[0].fixed_lower_limit, wide[0].fixed_upper_limit = -0.003, 0.003
    wide[0].stiffness = 0.0
    gym.set_actor_tendon_properties(envs[1], 0, wide)
    gym.prepare_sim(sim)
    own = sim.myriad.sim
    t = sim.myriad.model.tendon_names.index("a0/couple")
    torch.testing.assert_close(own.tendon_range[:, t].cpu(),
                               torch.tensor([[-0.001, 0.001], [-0.003, 0.003]]))
    dofs = gym.acquire_dof_state_tensor(sim)
    state = gymtorch.wrap_tensor(dofs).view(2, 2, 2)
    effort = torch.tensor([0.02, -0.02]).repeat(2, 1)
    for _ in range(120):
        gym.set_dof_actuation_force_tensor(sim, gymtorch.unwrap_tensor(effort.reshape(-1)))
        gym.simulate(sim)
        gym.fetch_results(sim, True)
        gym.refresh_dof_state_tensor(sim)
    length = 0.007 * (state[:, 0, 0] - state[:, 1, 0])
    assert abs(float(length[0]) - 0.001) < 2e-4
    assert abs(float(length[1]) - 0.003) < 5e-4


TENDON_LEVER = """<mujoco><worldbody><body name="base">
  <geom type="box" size=".05 .05 .01"/>
  <body name="lever" pos="0 0 .02"><joint name="turn" type="hinge" axis="0 0 1"/>
    <geom type="capsule" fromto="0 0 0 .2 0 0" size=".02"/></body></body></worldbody>
  <tendon><fixed name="spring" limited="true" range="-0.4 1"><joint joint="turn" coef="1"/>
  </fixed></tendon>
</mujoco>"""


def test_tendon_spring_rest_length_and_offset(tmp_path):
    """PhysX's fixed tendon: the spring pulls Σ coef·q + offset to the rest length, and the
    limits hold Σ coef·q itself. A lever turning about the vertical, spring rest length 0.2:
    offset 0 settles at 0.2 rad, offset 0.5 at -0.3, and offset 0.7 (set after prepare_sim)
    at the lower limit -0.4 rather than at -0.5."""
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "lever.xml", TENDON_LEVER)
    props = gym.get_asset_tendon_properties(asset)
    props[0].stiffness, props[0].damping = 1.0, 0.2
    props[0].fixed_spring_rest_length, props[0].limit_stiffness = 0.2, 0.0
    gym.set_asset_tendon_properties(asset, props)
    envs = envs_with(gym, sim, asset, [gymapi.Transform()] * 3)
    assert gym.get_actor_tendon_offset(envs[1], 0, 0) == 0.0
    assert gym.set_actor_tendon_offset(envs[1], 0, 0, 0.5)
    gym.prepare_sim(sim)
    gym.set_actor_tendon_offset(envs[2], 0, 0, 0.7)
    assert gym.get_actor_tendon_offset(envs[2], 0, 0) == pytest.approx(0.7)
    with pytest.raises(IndexError, match="has 1 tendons, not an index 1"):
        gym.set_actor_tendon_offset(envs[0], 0, 1, 0.1)
    state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim)).view(3, 2)
    for _ in range(300):
        gym.simulate(sim)
        gym.fetch_results(sim, True)
    gym.refresh_dof_state_tensor(sim)
    torch.testing.assert_close(state[:, 0], torch.tensor([0.2, -0.3, -0.4]), atol=5e-3,
                               rtol=0)
    assert float(state[:, 1].abs().max()) < 1e-2          # at rest there


def test_fixed_tendon_joint_coefficients_set_the_tendons_length(tmp_path):
    """A tendon's joint coefficients set on the asset (or on every actor alike, before
    prepare_sim) change its length Σ coef·q: with coefficient 2 the lever's spring (rest
    length 0.2) settles at 0.1 rad, not 0.2, and with -2 at -0.1; its lower limit (-0.4)
    then holds at -0.2. Coefficients that differ between envs, or come after prepare_sim,
    are refused with what to do; so are the wrong count and a zero."""
    def settled(coef_asset, coef_actor=None, rest=0.2):
        gym, sim, asset, _ = fixed_base_asset(tmp_path, "lever.xml", TENDON_LEVER)
        props = gym.get_asset_tendon_properties(asset)
        props[0].stiffness, props[0].damping = 1.0, 0.2
        props[0].fixed_spring_rest_length, props[0].limit_stiffness = rest, 0.0
        gym.set_asset_tendon_properties(asset, props)
        assert gym.set_asset_fixed_tendon_joint_coefficients(asset, 0, [coef_asset])
        assert gym.get_asset_fixed_tendon_joint_coefficients(asset, 0) == [coef_asset]
        envs = envs_with(gym, sim, asset, [gymapi.Transform()] * 2)
        if coef_actor is not None:
            for env in envs:
                gym.set_actor_fixed_tendon_joint_coefficients(env, 0, 0, [coef_actor])
            assert gym.get_actor_fixed_tendon_joint_coefficients(envs[1], 0, 0) == [coef_actor]
        gym.prepare_sim(sim)
        state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim)).view(2, 2)
        for _ in range(300):
            gym.simulate(sim)
            gym.fetch_results(sim, True)
        gym.refresh_dof_state_tensor(sim)
        assert float(state[:, 1].abs().max()) < 1e-2                # at rest
        return state[:, 0], gym, sim, envs

    q, gym, sim, envs = settled(2.0)
    torch.testing.assert_close(q, torch.full((2,), 0.1), atol=5e-3, rtol=0)
    with pytest.raises(NotImplementedError, match="after prepare_sim.*before prepare_sim"):
        gym.set_actor_fixed_tendon_joint_coefficients(envs[0], 0, 0, [1.0])
    q = settled(2.0, coef_actor=-2.0)[0]
    torch.testing.assert_close(q, torch.full((2,), -0.1), atol=5e-3, rtol=0)
    q = settled(2.0, rest=-1.0)[0]                  # the spring pulls past the lower limit
    torch.testing.assert_close(q, torch.full((2,), -0.2), atol=5e-3, rtol=0)
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "lever.xml", TENDON_LEVER)
    envs = envs_with(gym, sim, asset, [gymapi.Transform()] * 2)
    gym.set_actor_fixed_tendon_joint_coefficients(envs[1], 0, 0, [3.0])
    with pytest.raises(NotImplementedError, match="env 1 has other fixed tendon joint "
                                                  "coefficients than in env 0"):
        gym.prepare_sim(sim)
    with pytest.raises(ValueError, match="couples 1 joints: give 1 finite, non-zero"):
        gym.set_asset_fixed_tendon_joint_coefficients(asset, 0, [1.0, 2.0])
    with pytest.raises(ValueError, match="non-zero"):
        gym.set_actor_fixed_tendon_joint_coefficients(envs[0], 0, 0, [0.0])


def test_create_aggregate_and_tensor_descriptors(tmp_path):
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "lever.xml", TENDON_LEVER)
    env = envs_with(gym, sim, asset, [gymapi.Transform()])[0]
    assert gym.create_aggregate(env, [0])
    with pytest.raises(IndexError, match="no actor handle 3"):
        gym.create_aggregate(env, [3])
    gym.prepare_sim(sim)
    dofs = gym.acquire_dof_state_tensor(sim)
    t = gymtorch.wrap_tensor(dofs)
    assert dofs.ndim == 2 and dofs.data_ptr == dofs.data_address == t.data_ptr()


# ------------------------------------------------------------------ convex decomposition
def bowl_obj(path):
    """A square bowl 0.4 m wide and 0.1 m deep with 0.02 m walls, closed, as an .obj."""
    import trimesh
    outer = trimesh.creation.box((0.4, 0.4, 0.1))
    inner = trimesh.creation.box((0.36, 0.36, 0.1))
    inner.apply_translation((0, 0, 0.02))
    bowl = outer.difference(inner) if trimesh.boolean.engines_available else None
    if bowl is None:            # no boolean engine: five boxes, one watertight mesh each side
        parts = [trimesh.creation.box((0.4, 0.4, 0.02), trimesh.transformations
                                      .translation_matrix((0, 0, -0.04)))]
        for x, y, sx, sy in ((0.19, 0, 0.02, 0.4), (-0.19, 0, 0.02, 0.4),
                             (0, 0.19, 0.4, 0.02), (0, -0.19, 0.4, 0.02)):
            parts.append(trimesh.creation.box((sx, sy, 0.1), trimesh.transformations
                                              .translation_matrix((x, y, 0))))
        bowl = trimesh.util.concatenate(parts)
    bowl.export(path)


def test_vhacd_lets_a_ball_fall_into_a_bowl(tmp_path):
    pytest.importorskip("vhacdx", reason="V-HACD needs vhacdx (pip install -e '.[isaacgym]')")
    pytest.importorskip("trimesh")
    bowl_obj(tmp_path / "bowl.obj")
    (tmp_path / "bowl.urdf").write_text("""<robot name="bowl"><link name="bowl">
      <inertial><mass value="1"/><inertia ixx=".01" iyy=".01" izz=".01" ixy="0" ixz="0"
      iyz="0"/></inertial><collision><geometry><mesh filename="bowl.obj"/></geometry>
      </collision></link></robot>""")
    rests = {}
    for vhacd in (False, True):
        gym, sim = z_up_sim()
        options = gymapi.AssetOptions()
        options.fix_base_link = True
        options.vhacd_enabled = vhacd
        options.vhacd_params.max_convex_hulls = 16
        bowl = gym.load_asset(sim, str(tmp_path), "bowl.urdf", options)
        ball = gym.create_sphere(sim, 0.03)
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
        gym.create_actor(env, bowl, gymapi.Transform(gymapi.Vec3(0, 0, 0.05)), "bowl", 0, 0, 0)
        gym.create_actor(env, ball, gymapi.Transform(gymapi.Vec3(0, 0, 0.3)), "ball", 0, 0, 0)
        if vhacd:
            assert gym.get_asset_rigid_shape_count(bowl) > 1            # cut into pieces
        gym.prepare_sim(sim)
        root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
        settle(gym, sim, 100)
        rests[vhacd] = root[1, 2].item()
    # the bowl's convex hull holds the ball at its rim (0.1 + 0.03); its pieces let it onto the
    # floor (0.02 + 0.03)
    assert rests[False] == pytest.approx(0.13, abs=5e-3)
    assert rests[True] == pytest.approx(0.05, abs=5e-3)


def test_a_static_mesh_that_is_not_a_grid_holds_a_ball_inside_it(tmp_path):
    """A bowl given as a triangle mesh (not a height field's grid) collides as its triangles:
    it holds a ball on its floor, not on the rim its convex hull would have."""
    trimesh = pytest.importorskip("trimesh")
    bowl_obj(tmp_path / "bowl.obj")
    bowl = trimesh.load(tmp_path / "bowl.obj", force="mesh")
    gym, sim = z_up_sim()
    params = gymapi.TriangleMeshParams()
    params.nb_vertices, params.nb_triangles = len(bowl.vertices), len(bowl.faces)
    params.transform.p = gymapi.Vec3(0.0, 0.0, 0.05)
    gym.add_triangle_mesh(sim, np.asarray(bowl.vertices, np.float32).ravel(),
                          np.asarray(bowl.faces, np.uint32).ravel(), params)
    ball = gym.create_sphere(sim, 0.03)
    envs_with(gym, sim, ball, [gymapi.Transform(gymapi.Vec3(0.05, 0.0, 0.3))] * 2)
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    settle(gym, sim, 100)
    torch.testing.assert_close(root[:, 2], torch.full((2,), 0.05), atol=5e-3, rtol=0)


# ------------------------------------------------------------------ small helpers
def test_drawing_geoms_weigh_nothing(tmp_path):
    """Geoms that take no part in contacts only draw, as in Isaac Gym: IsaacGymEnvs' Ingenuity
    draws its chassis with such a mesh, which at MuJoCo's default density weighed 14 kg; a body
    with nothing else gets 1 g."""
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "drawn.xml", """<mujoco><worldbody>
      <body name="base"><geom type="box" size=".1 .1 .1" density="100"/>
        <geom type="box" size=".5 .5 .5" contype="0" conaffinity="0"/>
        <body name="flag" pos="0 0 .2"><joint type="hinge"/>
          <geom type="box" size=".05 .05 .05" contype="0" conaffinity="0"/></body>
      </body></worldbody></mujoco>""")
    masses = [p.mass for p in asset.body_props]
    assert masses == pytest.approx([100 * 0.2 ** 3, 1e-3])


def test_helpers_tasks_call_while_building():
    import xml.etree.ElementTree as ET
    root = ET.Element("mujoco")
    ET.SubElement(ET.SubElement(root, "worldbody"), "body")
    gymutil._indent_xml(root)                      # Ingenuity and Quadcopter write MJCF so
    assert ET.tostring(root).decode() == "<mujoco>\n  <worldbody>\n    <body />\n  </worldbody>\n</mujoco>"
    axes = gymutil.AxesGeometry(0.2)               # drawn into no viewer: nothing happens
    gymutil.draw_lines(axes, gymapi.acquire_gym(), None, None, gymapi.Transform())
    gym, sim = z_up_sim()
    env = gym.create_env(sim, gymapi.Vec3(), gymapi.Vec3(1, 1, 1), 1)
    assert gym.begin_aggregate(env, 10, 10, True) and gym.end_aggregate(env)


def test_refresh_recomputes_only_what_could_have_changed(tmp_path, monkeypatch):
    """simulate refreshes the state tensors already: the refresh_* calls a task makes after it
    recompute nothing, unless the tensors were edited (an edit not passed to a set_* call is
    overwritten, as in Isaac Gym) or the state was set."""
    gym, sim, arm, _ = fixed_base_asset(tmp_path, "arm.urdf", ARM_URDF)
    envs_with(gym, sim, arm, [gymapi.Transform()] * 2)
    gym.prepare_sim(sim)
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    calls = []
    refresh = type(sim.myriad).refresh
    monkeypatch.setattr(type(sim.myriad), "refresh",
                        lambda self: (calls.append(1), refresh(self))[1])
    gym.simulate(sim)
    calls.clear()
    gym.refresh_dof_state_tensor(sim)
    gym.refresh_actor_root_state_tensor(sim)
    assert calls == []
    truth = dofs.clone()
    dofs[0, 0] = 1.0                                   # an edit not passed to set_*
    gym.refresh_dof_state_tensor(sim)
    assert calls == [1] and torch.equal(dofs, truth)
    dofs[0, 0] = 0.5
    gym.set_dof_state_tensor(sim, gymtorch.unwrap_tensor(dofs))
    gym.refresh_dof_state_tensor(sim)
    assert len(calls) > 1 and dofs[0, 0].item() == pytest.approx(0.5)


def test_per_actor_calls_read_and_write_the_tensors(tmp_path):
    """Isaac Gym's older numpy calls, one actor at a time, as its examples use them."""
    gym, sim, arm, _ = fixed_base_asset(tmp_path, "arm.urdf", ARM_URDF,
                                        default_dof_drive_mode=gymapi.DOF_MODE_POS)
    envs = envs_with(gym, sim, arm, [gymapi.Transform()] * 3)
    gym.prepare_sim(sim)
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim)).view(3, -1, 13)
    states = gym.get_actor_dof_states(envs[1], 0, gymapi.STATE_ALL)
    assert states.dtype == gymapi.DofState and states.shape == (1,)
    states["pos"] = 0.4
    assert gym.set_actor_dof_states(envs[1], 0, states, gymapi.STATE_POS)
    gym.refresh_dof_state_tensor(sim)
    assert dofs[:, 0].tolist() == pytest.approx([0.0, 0.4, 0.0])      # env 1 only
    hand = gym.get_actor_rigid_body_states(envs[1], 0, gymapi.STATE_ALL)[2]
    gym.refresh_rigid_body_state_tensor(sim)
    assert [hand["pose"]["p"][k] for k in "xyz"] == pytest.approx(bodies[1, 2, :3].tolist())
    assert gym.get_env_rigid_body_states(envs[1], gymapi.STATE_POS).shape == (3,)
    assert gym.set_actor_dof_position_targets(envs[2], 0, np.array([0.3], np.float32))
    assert gym.get_actor_dof_position_targets(envs[2], 0).tolist() == pytest.approx([0.3])
    assert gym.get_actor_dof_position_targets(envs[0], 0).tolist() == [0.0]
    props = gym.get_actor_dof_properties(envs[2], 0)
    props["stiffness"], props["damping"] = 100.0, 10.0
    gym.set_actor_dof_properties(envs[2], 0, props)
    for _ in range(200):
        gym.simulate(sim)
    gym.refresh_dof_state_tensor(sim)
    assert dofs[2, 0].item() == pytest.approx(0.3, abs=0.05)          # driven to its target
    forces = gym.get_actor_dof_forces(envs[2], 0)
    assert forces.dtype == np.float32 and forces.shape == (1,)


# ------------------------------------------------------------------ camera sensors
def renderer_or_skip():
    import mujoco
    from myriad.rl.video import before_offscreen_gl
    before_offscreen_gl()           # else a later torch.compile (triton) crashes this process
    try:
        mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 8, 8).close()
    except Exception as err:
        pytest.skip(f"no offscreen OpenGL for MuJoCo's renderer: {err}")


def test_camera_sensors_see_depth_segmentation_and_colour_of_each_env():
    """Two envs, a box at a different height in each, a camera looking straight down from
    2 m: its depth image reads the box top and the ground, its segmentation the box's id, its
    view and projection matrices put the depth pixels back where the box top is."""
    renderer_or_skip()
    gym, sim = z_up_sim()
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    box = gym.create_box(sim, 0.4, 0.4, 0.4, gymapi.AssetOptions())
    props = gymapi.CameraProperties()
    props.width, props.height, props.horizontal_fov = 64, 48, 60.0
    props.enable_tensors = True
    envs, cams = [], []
    for i, z in enumerate((0.2, 0.7)):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, z)), "box", i, 0,
                         segmentationId=7)
        cam = gym.create_camera_sensor(env, props)
        gym.set_camera_location(cam, env, gymapi.Vec3(0.0, 0.0, 2.0), gymapi.Vec3(0.001, 0, 0))
        envs.append(env)
        cams.append(cam)
    gym.prepare_sim(sim)
    colour = gymtorch.wrap_tensor(gym.get_camera_image_gpu_tensor(sim, envs[1], cams[1],
                                                                   gymapi.IMAGE_COLOR))
    gym.render_all_camera_sensors(sim)
    gym.start_access_image_tensors(sim)
    for env, cam, top in zip(envs, cams, (0.4, 0.9)):
        depth = gym.get_camera_image(sim, env, cam, gymapi.IMAGE_DEPTH)
        seg = gym.get_camera_image(sim, env, cam, gymapi.IMAGE_SEGMENTATION)
        rgba = gym.get_camera_image(sim, env, cam, gymapi.IMAGE_COLOR)
        assert depth.shape == (48, 64) and seg.shape == (48, 64) and rgba.shape == (48, 256)
        assert depth[24, 32] == pytest.approx(-(2.0 - top), abs=0.01)      # the box top
        assert depth[0, 0] == pytest.approx(-2.0, abs=0.01)     # the ground: depth along z
        assert seg[24, 32] == 7 and seg[0, 0] == 0
    # an oblique camera in env 0, seeing the box from the side: every pixel put back into the env
    # with Isaac Gym's matrices (as point-cloud code does) lands on the ground where the
    # segmentation says ground, and in the box where it says box
    gym.set_camera_location(cams[0], envs[0], gymapi.Vec3(-1.2, -0.6, 1.4),
                            gymapi.Vec3(0.0, 0.2, 0.2))
    gym.render_all_camera_sensors(sim)
    depth = gym.get_camera_image(sim, envs[0], cams[0], gymapi.IMAGE_DEPTH)
    seg = gym.get_camera_image(sim, envs[0], cams[0], gymapi.IMAGE_SEGMENTATION)
    view = gym.get_camera_view_matrix(sim, envs[0], cams[0])
    proj = gym.get_camera_proj_matrix(sim, envs[0], cams[0])
    rows, cols = np.mgrid[0:48, 0:64]
    u = (cols + 0.5 - 32) / 32                          # normalized device coordinates
    v = (24 - rows - 0.5) / 24                          # (image rows run downwards)
    points = np.stack([-u * depth / proj[0, 0], -v * depth / proj[1, 1], depth,
                       np.ones_like(depth)], axis=-1) @ np.linalg.inv(view)
    ground = (seg == 0) & np.isfinite(depth)
    assert ground.sum() > 500 and np.abs(points[ground, 2]).max() < 0.02
    inside = seg == 7
    assert inside.sum() > 50
    assert np.abs(points[inside, :2]).max() < 0.21
    assert points[inside, 2].min() > -0.01 and points[inside, 2].max() < 0.41
    gym.end_access_image_tensors(sim)
    assert colour.shape == (48, 64, 4) and colour.dtype == torch.uint8
    assert torch.equal(colour.reshape(48, -1).cpu(),
                       torch.from_numpy(gym.get_camera_image(sim, envs[1], cams[1],
                                                             gymapi.IMAGE_COLOR)))
    # a destroyed camera is gone; the env's next camera takes a new handle
    gym.destroy_camera_sensor(sim, envs[0], cams[0])
    with pytest.raises(ValueError, match="not a camera sensor of env 0"):
        gym.get_camera_image(sim, envs[0], cams[0], gymapi.IMAGE_DEPTH)
    assert gym.create_camera_sensor(envs[0], props) == cams[0] + 1


def test_camera_images_show_each_envs_colors_textures_and_segmentation_ids(tmp_path):
    """Per-env looks in camera images, as visual domain randomization sets them: a camera
    straight above a box in each of three envs sees it green where set_rigid_body_color made
    it green, half red and half blue where a texture from a file covers it, in the model's
    grey elsewhere; a ball's segmentation id set in one env shows there only. A texture made
    after the first render draws too, and a freed one leaves its body in its color."""
    import imageio.v2 as imageio
    renderer_or_skip()
    gym, sim = z_up_sim()
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    box = gym.create_box(sim, 0.6, 0.6, 0.4)
    ball = gym.create_sphere(sim, 0.1)
    picture = np.zeros((32, 32, 3), np.uint8)
    picture[:, :16, 0] = picture[:, 16:, 2] = 255               # red | blue
    imageio.imwrite(tmp_path / "halves.png", picture)
    halves = gym.create_texture_from_file(sim, str(tmp_path / "halves.png"))
    props = gymapi.CameraProperties()
    props.width, props.height, props.horizontal_fov = 64, 64, 60.0
    envs, cams = [], []
    for i in range(3):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 3)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 0.2)), "box", i, 0, 1)
        gym.create_actor(env, ball, gymapi.Transform(gymapi.Vec3(0.6, 0, 0.1)), "ball", i, 0, 2)
        cam = gym.create_camera_sensor(env, props)
        gym.set_camera_location(cam, env, gymapi.Vec3(0.0, 0.0, 1.5), gymapi.Vec3(0.001, 0, 0))
        envs.append(env)
        cams.append(cam)
    gym.set_rigid_body_color(envs[0], 0, 0, gymapi.MESH_VISUAL, gymapi.Vec3(0.1, 0.9, 0.1))
    gym.set_rigid_body_texture(envs[1], 0, 0, gymapi.MESH_VISUAL, halves)
    gym.set_rigid_body_segmentation_id(envs[2], 1, 0, 9)
    gym.prepare_sim(sim)

    def images(e):
        gym.render_all_camera_sensors(sim)
        rgb = gym.get_camera_image(sim, envs[e], cams[e], gymapi.IMAGE_COLOR)
        seg = gym.get_camera_image(sim, envs[e], cams[e], gymapi.IMAGE_SEGMENTATION)
        return rgb.reshape(64, 64, 4)[..., :3].astype(float), seg

    def shares(rgb, seg):
        """(green, red, blue, grey) shares of the box's pixels."""
        top = rgb[seg == 1]
        r, g, b = top[:, 0], top[:, 1], top[:, 2]
        return ((g > 2 * r + 20) & (g > 2 * b + 20)).mean(), \
            ((r > 2 * g + 20) & (r > 2 * b + 20)).mean(), \
            ((b > 2 * r + 20) & (b > 2 * g + 20)).mean(), \
            ((np.ptp(top, axis=1) < 20) & (r > 30)).mean()

    (rgb0, seg0), (rgb1, seg1), (rgb2, seg2) = images(0), images(1), images(2)
    assert (seg0 == 1).sum() > 200
    green, red, blue, grey = shares(rgb0, seg0)
    assert green > 0.95, f"env 0: {green:.0%} of the box green"
    green, red, blue, grey = shares(rgb1, seg1)
    assert red > 0.3 and blue > 0.3 and red + blue > 0.9, f"env 1: {red:.0%} red, {blue:.0%} blue"
    green, red, blue, grey = shares(rgb2, seg2)
    assert grey > 0.95, f"env 2: {grey:.0%} of the box grey"
    assert (seg2 == 9).sum() > 20 and not (seg2 == 2).any()        # the ball, with its new id
    assert (seg0 == 2).sum() > 20 and not (seg0 == 9).any()
    color = gym.get_rigid_body_color(envs[0], 0, 0, gymapi.MESH_VISUAL)
    assert (color.x, color.y, color.z) == pytest.approx((0.1, 0.9, 0.1))
    assert gym.get_rigid_body_texture(envs[1], 0, 0, gymapi.MESH_VISUAL) == halves
    assert gym.get_rigid_body_texture(envs[0], 0, 0, gymapi.MESH_VISUAL) == gymapi.INVALID_HANDLE
    # a texture made now (the drawing model is compiled again), tinted by env 0's green
    pixels = np.full((4, 4, 4), 255, np.uint8)
    white = gym.create_texture_from_buffer(sim, 4, 4, pixels.reshape(4, 16))
    gym.set_rigid_body_texture(envs[0], 0, 0, gymapi.MESH_VISUAL_AND_COLLISION, white)
    gym.set_rigid_body_texture(envs[2], 0, 0, gymapi.MESH_VISUAL, halves)
    green, red, blue, grey = shares(*images(0))
    assert green > 0.95
    green, red, blue, grey = shares(*images(2))
    assert red > 0.3 and blue > 0.3
    gym.free_texture(sim, halves)
    green, red, blue, grey = shares(*images(1))
    assert grey > 0.95, f"env 1 after free_texture: {grey:.0%} grey"
    assert gym.get_rigid_body_texture(envs[1], 0, 0, gymapi.MESH_VISUAL) == gymapi.INVALID_HANDLE
    # what is wrong is named
    with pytest.raises(FileNotFoundError, match="no file"):
        gym.create_texture_from_file(sim, str(tmp_path / "missing.png"))
    with pytest.raises(ValueError, match="4 x 4 RGBA pixels take 64 uint8 values; got 48"):
        gym.create_texture_from_buffer(sim, 4, 4, np.zeros((4, 12), np.uint8))
    with pytest.raises(ValueError, match=f"{halves} is not a texture of this sim"):
        gym.set_rigid_body_texture(envs[0], 0, 0, gymapi.MESH_VISUAL, halves)
    with pytest.raises(IndexError, match="has 1 bodies, not an index 3"):
        gym.set_rigid_body_color(envs[0], 0, 3, gymapi.MESH_VISUAL, gymapi.Vec3(1, 0, 0))


VISUAL_BOX = """<robot name="post"><link name="post">
  <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/>
  </inertial>
  <visual><geometry><box size="0.3 0.3 0.3"/></geometry></visual>
  <collision><geometry><sphere radius="0.1"/></geometry></collision></link></robot>"""


def test_cameras_draw_visual_geometry_or_on_request_the_collision_shapes(tmp_path):
    """As Isaac Gym's cameras: a link's visual geometry is drawn (not its collision shape
    over it), and the collision shapes instead with use_collision_geometry. A link whose
    visual is a 0.3 m box and whose collision shape a 0.1 m sphere, seen from above: its
    segmentation covers a square or a disk about a quarter of it; the depth at the square's
    corner is the box top's or the ground's."""
    renderer_or_skip()
    gym, sim, asset, _ = fixed_base_asset(tmp_path, "post.urdf", VISUAL_BOX)
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    cams, envs = [], []
    for collision in (False, True):
        props = gymapi.CameraProperties()
        props.width, props.height, props.horizontal_fov = 64, 64, 60.0
        props.use_collision_geometry = collision
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2)
        gym.create_actor(env, asset, gymapi.Transform(gymapi.Vec3(0, 0, 0.15)), "post", 0, 0, 4)
        cam = gym.create_camera_sensor(env, props)
        gym.set_camera_location(cam, env, gymapi.Vec3(0, 0, 1.5), gymapi.Vec3(0.001, 0, 0))
        cams.append(cam)
        envs.append(env)
    gym.prepare_sim(sim)
    gym.render_all_camera_sensors(sim)
    seen = [gym.get_camera_image(sim, e, c, gymapi.IMAGE_SEGMENTATION) for e, c in zip(envs, cams)]
    depth = [gym.get_camera_image(sim, e, c, gymapi.IMAGE_DEPTH) for e, c in zip(envs, cams)]
    box, ball = (int((s == 4).sum()) for s in seen)
    # 0.3 m at 1.2 m is 14 pixels across here; the disk, 0.1 m at 1.25 m, a quarter the area
    assert 170 < box < 220 and 0.2 < ball / box < 0.35, (box, ball)
    corner = np.argwhere(seen[0] == 4).max(axis=0)                # the square's far corner
    assert depth[0][tuple(corner)] == pytest.approx(-1.2, abs=0.02)        # the box top
    assert depth[1][tuple(corner)] == pytest.approx(-1.5, abs=0.05)        # the ground


def test_performance_timers_add_up_the_time_of_each_activity():
    """Performance timers count the wall time spent in the calls of each activity since they
    were last read: a loop of simulate, refresh and sync_frame_time spends its time in
    physics_sim, physics_data_movement and frame_idling, which add up to the loop's time; a
    read starts them again; timers made later count from then on."""
    gym, sim = z_up_sim(dt=0.1)
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
    gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 1)), "box", 0, 0, 0)
    gym.prepare_sim(sim)
    early = gym.create_performance_timers(sim)
    start = time.perf_counter()
    for _ in range(4):
        gym.simulate(sim)
        gym.fetch_results(sim, True)
        gym.refresh_actor_root_state_tensor(sim)
        gym.sync_frame_time(sim)                   # waits out the rest of dt
    loop = time.perf_counter() - start
    late = gym.create_performance_timers(sim)
    timers = gym.get_performance_timers(sim, early)
    assert timers.physics_sim > 0 and timers.physics_data_movement > 0
    assert timers.frame_idling > 0.1              # 3 waits of 0.1 s less each step's work
    assert timers.graphics_sensor_rendering == timers.graphics_viewer_rendering == 0.0
    counted = (timers.physics_sim + timers.physics_data_movement + timers.frame_idling)
    assert timers.total_time == pytest.approx(counted)
    assert 0.8 * loop < counted <= loop
    gym.simulate(sim)
    again, later = gym.get_performance_timers(sim, early), gym.get_performance_timers(sim, late)
    assert again.frame_idling == 0.0 and 0 < again.physics_sim < timers.physics_sim
    assert later.physics_sim == pytest.approx(again.physics_sim)
    assert gym.get_elapsed_time(sim) > loop and gym.get_sim_time(sim) == pytest.approx(0.5)
    gym.destroy_performance_timers(sim, early)
    with pytest.raises(ValueError, match="not a performance timers handle"):
        gym.get_performance_timers(sim, early)


def test_a_setter_leaves_the_other_tensors_pending_edits_alone(tmp_path):
    """IsaacGymEnvs' resets edit a wrapped tensor in place and pass it to its setter after
    another setter ran (Ant: dof edits, then the root setter, then the dof setter; Ingenuity:
    root edits, then the dof setter, then the root setter). In Isaac Gym a setter writes the
    simulation only; the tensors change at the next refresh, so neither edit is lost."""
    gym, sim = z_up_sim()
    box = gym.create_box(sim, 0.2, 0.2, 0.2)
    _, _, arm, _ = fixed_base_asset(tmp_path, "arm.urdf", ARM_URDF)
    arm = gym.load_asset(sim, str(tmp_path), "arm.urdf", arm.options)
    for i in range(2):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 1)), "box", i, 0, 0)
        gym.create_actor(env, arm, gymapi.Transform(), "arm", i, 0, 0)
    gym.prepare_sim(sim)
    roots = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim)).view(2, 2, 13)
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    everything = torch.arange(4, dtype=torch.int32)
    for order in ("dof first", "root first"):
        roots[:, 0, 0] = torch.tensor([0.3, -0.3]) * (1 if order == "dof first" else 2)
        dofs[:, 0] = torch.tensor([0.2, -0.2]) * (1 if order == "dof first" else 2)
        want_roots, want_dofs = roots[:, 0, 0].clone(), dofs[:, 0].clone()
        setters = [lambda: gym.set_dof_state_tensor_indexed(
                       sim, gymtorch.unwrap_tensor(dofs), gymtorch.unwrap_tensor(everything), 4),
                   lambda: gym.set_actor_root_state_tensor_indexed(
                       sim, gymtorch.unwrap_tensor(roots.view(-1, 13)),
                       gymtorch.unwrap_tensor(everything), 4)]
        for setter in (setters if order == "dof first" else setters[::-1]):
            setter()
        gym.refresh_actor_root_state_tensor(sim)
        gym.refresh_dof_state_tensor(sim)
        torch.testing.assert_close(roots[:, 0, 0], want_roots)
        torch.testing.assert_close(dofs[:, 0], want_dofs)


# ------------------------------------------------------------------ collision filters
FOLDED_ARM = """<robot name="arm">
  <link name="base"><collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
    <inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="upper"><collision><geometry><sphere radius="0.02"/></geometry></collision>
    <inertial><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="lower"><collision><origin xyz="0.2 0 0"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
    <inertial><origin xyz="0.2 0 0"/><mass value="0.1"/><inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="10" velocity="10"/></joint>
</robot>"""


@pytest.mark.parametrize("filter, collides", [(-1, True), (0, True), (1, False)])
def test_an_actors_filter_decides_its_self_collisions_minus_one_keeps_the_assets(
        tmp_path, filter, collides):
    """Isaac Gym's create_actor filter: 0 lets an actor's links collide with each other (a link
    never with its parent), a nonzero bitmask stops it, and -1 (the default; the hands' tasks
    pass it) keeps the asset loader's shape filters, which are 0. The arm's lower link, held
    out level, falls about its elbow onto its base, its grandparent: it lands on it only where
    self-collisions are on, else it swings down through it."""
    (tmp_path / "arm.urdf").write_text(FOLDED_ARM)
    gym = gymapi.acquire_gym()
    p = gymapi.SimParams()
    p.up_axis, p.gravity = gymapi.UP_AXIS_Z, gymapi.Vec3(0.0, 0.0, -G)
    sim = gym.create_sim(-1, -1, gymapi.SIM_PHYSX, p)
    options = gymapi.AssetOptions()
    options.fix_base_link = True
    asset = gym.load_asset(sim, str(tmp_path), "arm.urdf", options)
    env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 1)
    actor = gym.create_actor(env, asset, gymapi.Transform(), "arm", 0, filter, 0)
    shapes = gym.get_actor_rigid_shape_properties(env, actor)
    assert [s.filter for s in shapes] == [0 if filter == -1 else filter] * 3
    gym.set_actor_rigid_shape_properties(env, actor, shapes)        # read back unchanged: fine
    shapes[2].filter = 4
    with pytest.raises(NotImplementedError, match="filter=4"):
        gym.set_actor_rigid_shape_properties(env, actor, shapes)
    gym.prepare_sim(sim)
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim))
    contacts = gymtorch.wrap_tensor(gym.acquire_net_contact_force_tensor(sim))
    lower = gym.find_actor_rigid_body_index(env, actor, "lower", gymapi.DOMAIN_SIM)
    pushed, lowest = 0.0, 1.0
    for _ in range(100):                                           # 1 s
        settle(gym, sim, 1)
        gym.refresh_net_contact_force_tensor(sim)
        gym.refresh_rigid_body_state_tensor(sim)
        pushed = max(pushed, float(contacts[lower].norm()))
        # the box's centre, 0.2 m out along the link: 0.3 m high held level, 0.1 m hanging
        centre = bodies[lower:lower + 1, 0:3] + quat_rotate(
            bodies[lower:lower + 1, 3:7], torch.tensor([[0.2, 0.0, 0.0]]))
        lowest = min(lowest, float(centre[0, 2]))
    if collides:         # it lands on the base's top edge about 49 degrees down (0.15 m high)
        assert pushed > 0.1 and lowest > 0.13, (pushed, lowest)
    else:
        assert pushed == 0.0 and lowest < 0.11, (pushed, lowest)
