"""The `isaacgym` compatibility layer: Isaac Gym Preview 4 scripts run unchanged on Myriad.

Each test is written the way IsaacGymEnvs' tasks call the original (gymapi / gymtorch /
gymutil), and checks the result against Myriad's own API or closed-form physics.
"""

import math
import sys

import numpy as np
import pytest
import torch

from isaacgym import gymapi, gymtorch, gymutil
from isaacgym._cameras import looks
from isaacgym.torch_utils import (get_euler_xyz, quat_apply, quat_from_euler_xyz, quat_mul,
                                  quat_rotate_inverse, to_torch)

import myriad
from myriad.api import Scene

# a cart on a rail with a pole, shaped as IsaacGymEnvs' assets/urdf/cartpole.urdf: a rail link
# (the fixed base), a prismatic cart, a revolute pole (written here for the test)
CARTPOLE_URDF = """<?xml version="1.0"?>
<robot name="cartpole">
  <link name="slider">
    <visual><geometry><box size="0.03 8 0.03"/></geometry></visual>
    <collision><geometry><box size="0.03 8 0.03"/></geometry></collision>
    <inertial><mass value="1"/>
      <inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="slider_to_cart" type="prismatic">
    <axis xyz="0 1 0"/>
    <parent link="slider"/><child link="cart"/>
    <limit effort="400" lower="-4" upper="4" velocity="100"/>
  </joint>
  <link name="cart">
    <visual><geometry><box size="0.2 0.25 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.25 0.2"/></geometry></collision>
    <inertial><mass value="1"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="cart_to_pole" type="continuous">
    <axis xyz="1 0 0"/>
    <origin xyz="0.12 0 0"/>
    <parent link="cart"/><child link="pole"/>
  </joint>
  <link name="pole">
    <visual><origin xyz="0 0 0.47"/><geometry><box size="0.04 0.06 1.0"/></geometry></visual>
    <collision><origin xyz="0 0 0.47"/><geometry><box size="0.04 0.06 1.0"/></geometry></collision>
    <inertial><origin xyz="0 0 0.47"/><mass value="1"/>
      <inertia ixx="0.083" iyy="0.083" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
</robot>
"""

NUM_ENVS = 16


@pytest.fixture(scope="module")
def cartpole_file(tmp_path_factory):
    folder = tmp_path_factory.mktemp("assets") / "urdf"
    folder.mkdir()
    (folder / "cartpole.urdf").write_text(CARTPOLE_URDF)
    return folder / "cartpole.urdf"


def cartpole_sim_params():
    """Cartpole.yaml's sim section, as VecTask.__parse_sim_params fills it."""
    p = gymapi.SimParams()
    p.dt = 0.0166
    p.substeps = 2
    p.up_axis = gymapi.UP_AXIS_Z
    p.gravity = gymapi.Vec3(0.0, 0.0, -9.81)
    p.use_gpu_pipeline = False
    p.num_client_threads = 0
    for k, v in dict(num_threads=4, solver_type=1, use_gpu=False, num_position_iterations=4,
                     num_velocity_iterations=0, contact_offset=0.02, rest_offset=0.001,
                     bounce_threshold_velocity=0.2, max_depenetration_velocity=100.0,
                     default_buffer_size_multiplier=2.0, max_gpu_contact_pairs=1048576,
                     num_subscenes=4).items():
        setattr(p.physx, k, v)
    p.physx.contact_collection = gymapi.ContactCollection(0)
    return p


def make_cartpole(cartpole_file, num_envs=NUM_ENVS):
    """Cartpole._create_envs, line for line in the original's style (z up)."""
    gym = gymapi.acquire_gym()
    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, cartpole_sim_params())
    plane_params = gymapi.PlaneParams()
    plane_params.normal = gymapi.Vec3(0.0, 0.0, 1.0)
    gym.add_ground(sim, plane_params)
    spacing = 4.0
    lower = gymapi.Vec3(0.5 * -spacing, -spacing, 0.0)
    upper = gymapi.Vec3(0.5 * spacing, spacing, spacing)
    asset_options = gymapi.AssetOptions()
    asset_options.fix_base_link = True
    asset = gym.load_asset(sim, str(cartpole_file.parent), cartpole_file.name, asset_options)
    num_dof = gym.get_asset_dof_count(asset)
    pose = gymapi.Transform()
    pose.p.z = 2.0
    pose.r = gymapi.Quat(0.0, 0.0, 0.0, 1.0)
    envs, handles = [], []
    for i in range(num_envs):
        env_ptr = gym.create_env(sim, lower, upper, int(np.sqrt(num_envs)))
        handle = gym.create_actor(env_ptr, asset, pose, "cartpole", i, 1, 0)
        dof_props = gym.get_actor_dof_properties(env_ptr, handle)
        dof_props["driveMode"][0] = gymapi.DOF_MODE_EFFORT
        dof_props["driveMode"][1] = gymapi.DOF_MODE_NONE
        dof_props["stiffness"][:] = 0.0
        dof_props["damping"][:] = 0.0
        gym.set_actor_dof_properties(env_ptr, handle, dof_props)
        envs.append(env_ptr)
        handles.append(handle)
    gym.prepare_sim(sim)
    return gym, sim, asset, num_dof, envs, handles


def test_cartpole_matches_myriad_api(cartpole_file):
    gym, sim, asset, num_dof, envs, handles = make_cartpole(cartpole_file)
    assert num_dof == 2
    assert gym.get_asset_dof_names(asset) == ["slider_to_cart", "cart_to_pole"]
    assert gym.get_asset_rigid_body_names(asset) == ["slider", "cart", "pole"]
    assert gym.get_asset_rigid_body_dict(asset) == {"slider": 0, "cart": 1, "pole": 2}
    assert gym.find_asset_rigid_body_index(asset, "pole") == 2
    assert gym.get_env_count(sim) == NUM_ENVS
    assert gym.find_actor_rigid_body_handle(envs[3], handles[3], "pole") == 2
    assert gym.get_actor_index(envs[3], handles[3], gymapi.DOMAIN_SIM) == 3

    # the tensors: flat, env-major, zero-copy views refreshed in place
    dof_state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim))
    contacts = gymtorch.wrap_tensor(gym.acquire_net_contact_force_tensor(sim))
    assert dof_state.shape == (NUM_ENVS * num_dof, 2)
    assert root.shape == (NUM_ENVS, 13) and bodies.shape == (NUM_ENVS * 3, 13)
    assert contacts.shape == (NUM_ENVS * 3, 3)
    assert gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim)) is dof_state
    dof_pos = dof_state.view(NUM_ENVS, num_dof, 2)[..., 0]
    dof_vel = dof_state.view(NUM_ENVS, num_dof, 2)[..., 1]
    torch.testing.assert_close(root[:, :3], torch.tensor([[0.0, 0.0, 2.0]]).expand(NUM_ENVS, 3))

    # Myriad's own API on the same scene
    scene = Scene().add_ground()
    scene.add_actor("cartpole", cartpole_file, pos=(0, 0, 2.0), fix_base=True,
                    dof_mode=("effort", "none"))
    ref = scene.build(NUM_ENVS, params=myriad.SimParams(
        dt=0.0166, substeps=2, gravity=(0, 0, -9.81), position_iterations=4,
        velocity_iterations=0, contact_offset=0.02, rest_offset=0.001,
        max_depenetration_velocity=100.0))

    # Cartpole.reset_idx for all envs, then pushes as pre_physics_step makes them
    gen = torch.Generator().manual_seed(0)
    positions = 0.2 * (torch.rand((NUM_ENVS, num_dof), generator=gen) - 0.5)
    velocities = 0.5 * (torch.rand((NUM_ENVS, num_dof), generator=gen) - 0.5)
    dof_pos[:] = positions
    dof_vel[:] = velocities
    env_ids = torch.arange(NUM_ENVS, dtype=torch.int32)
    gym.set_dof_state_tensor_indexed(sim, gymtorch.unwrap_tensor(dof_state),
                                     gymtorch.unwrap_tensor(env_ids), len(env_ids))
    ref.set_dof_state(positions.clone(), velocities.clone())
    torch.testing.assert_close(dof_pos, ref.dof_pos)
    for step in range(40):
        actions = torch.rand(NUM_ENVS, generator=gen) * 2 - 1
        forces = torch.zeros(NUM_ENVS * num_dof, dtype=torch.float)
        forces[::num_dof] = actions * 400.0
        gym.set_dof_actuation_force_tensor(sim, gymtorch.unwrap_tensor(forces))
        gym.simulate(sim)
        gym.fetch_results(sim, True)
        gym.refresh_dof_state_tensor(sim)
        ref.set_dof_efforts(forces.view(NUM_ENVS, num_dof).clone())
        ref.step()
        torch.testing.assert_close(dof_pos, ref.dof_pos, rtol=1e-5, atol=1e-5)
        torch.testing.assert_close(dof_vel, ref.dof_vel, rtol=1e-5, atol=1e-5)
    gym.refresh_rigid_body_state_tensor(sim)
    torch.testing.assert_close(bodies.view(NUM_ENVS, 3, 13), ref.rigid_body_states,
                               rtol=1e-5, atol=1e-5)
    assert gym.get_sim_time(sim) == pytest.approx(40 * 0.0166)
    assert dof_pos[:, 1].abs().max() > 0.05        # the pushes did move the poles


def test_indexed_resets_touch_only_given_envs(cartpole_file):
    gym, sim, _, num_dof, envs, _ = make_cartpole(cartpole_file, num_envs=6)
    dof_state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    for _ in range(5):      # everybody moves
        forces = torch.zeros(6 * num_dof)
        forces[::num_dof] = 50.0
        gym.set_dof_actuation_force_tensor(sim, gymtorch.unwrap_tensor(forces))
        gym.simulate(sim)
    gym.refresh_dof_state_tensor(sim)
    before = dof_state.clone()
    # write new values everywhere in the tensor, but apply them to envs 1 and 4 only
    dof_state[:] = 0.25
    ids = torch.tensor([1, 4], dtype=torch.int32)
    gym.set_dof_state_tensor_indexed(sim, gymtorch.unwrap_tensor(dof_state),
                                     gymtorch.unwrap_tensor(ids), len(ids))
    gym.refresh_dof_state_tensor(sim)
    after = dof_state.view(6, num_dof, 2)
    expect = before.view(6, num_dof, 2).clone()
    expect[[1, 4]] = 0.25
    torch.testing.assert_close(after, expect)

    # root states: free boxes, reset one actor by its sim-domain index
    gym = gymapi.acquire_gym()
    p = gymapi.SimParams()
    p.up_axis, p.gravity = gymapi.UP_AXIS_Z, gymapi.Vec3(0, 0, -9.81)
    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, p)
    box = gym.create_box(sim, 0.2, 0.2, 0.2, gymapi.AssetOptions())
    ball = gym.create_sphere(sim, 0.1, gymapi.AssetOptions())
    for i in range(3):
        env = gym.create_env(sim, gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1), 2)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(0, 0, 1.0 + i)), "box", i, 0)
        gym.create_actor(env, ball, gymapi.Transform(gymapi.Vec3(1, 0, 1.0)), "ball", i, 0)
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    assert root.shape == (6, 13)
    # each env's own start pose: the box of env i starts at z = 1 + i
    torch.testing.assert_close(root.view(3, 2, 13)[:, 0, 2], torch.tensor([1.0, 2.0, 3.0]))
    gym.simulate(sim)
    gym.refresh_actor_root_state_tensor(sim)
    before = root.clone()
    root[:, 2] = 5.0
    root[:, 7:13] = 0.0
    ids = torch.tensor([gym.get_actor_index(gym.get_env(sim, 1), 1, gymapi.DOMAIN_SIM)],
                       dtype=torch.int32)          # env 1's ball: sim index 3
    assert int(ids[0]) == 3
    gym.set_actor_root_state_tensor_indexed(sim, gymtorch.unwrap_tensor(root),
                                            gymtorch.unwrap_tensor(ids), 1)
    gym.refresh_actor_root_state_tensor(sim)
    expect = before.clone()
    expect[3, 2] = 5.0
    expect[3, 7:13] = 0.0
    torch.testing.assert_close(root, expect)


def test_falling_box_lands_on_y_up_ground():
    """Y up, Isaac Gym's default: gravity along -y, the ground plane's normal along +y."""
    gym = gymapi.acquire_gym()
    p = gymapi.SimParams()              # defaults: UP_AXIS_Y, gravity (0, -9.8, 0)
    assert p.up_axis == gymapi.UP_AXIS_Y and p.gravity.y == pytest.approx(-9.8)
    p.dt, p.substeps = 1 / 60, 2
    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, p)
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 1, 0)
    gym.add_ground(sim, plane)
    box = gym.create_box(sim, 0.3, 0.2, 0.4, gymapi.AssetOptions())
    for i in range(2):
        env = gym.create_env(sim, gymapi.Vec3(-1, 0, -1), gymapi.Vec3(1, 1, 1), 2)
        pose = gymapi.Transform(gymapi.Vec3(0.5, 1.0, -0.25))
        gym.create_actor(env, box, pose, "box", i, 0)
    gym.prepare_sim(sim)
    root = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    for step in range(12):      # free fall first: y = 1 - g t² / 2
        gym.simulate(sim)
    gym.refresh_actor_root_state_tensor(sim)
    t = 12 / 60
    assert root[0, 1].item() == pytest.approx(1.0 - 0.5 * 9.8 * t * t, abs=0.01)
    assert root[0, 8].item() == pytest.approx(-9.8 * t, abs=0.05)
    for step in range(78):
        gym.simulate(sim)
    gym.refresh_actor_root_state_tensor(sim)
    # at rest on the plane y = 0: the box's centre half its height (0.2 / 2) above
    torch.testing.assert_close(root[:, 1], torch.full((2,), 0.1), atol=5e-3, rtol=0)
    torch.testing.assert_close(root[:, [0, 2]], torch.tensor([[0.5, -0.25]] * 2), atol=1e-3,
                               rtol=0)
    assert root[:, 7:13].abs().max() < 0.05
    contacts = gymtorch.wrap_tensor(gym.acquire_net_contact_force_tensor(sim))
    gym.refresh_net_contact_force_tensor(sim)
    mass = 0.3 * 0.2 * 0.4 * 1000.0             # the default density
    torch.testing.assert_close(contacts[:, 1], torch.full((2,), mass * 9.8), rtol=0.05, atol=0)


def test_errors_name_what_is_missing(cartpole_file):
    gym = gymapi.acquire_gym()
    with pytest.raises(NotImplementedError, match=r"isaacgym\.gymapi\.Gym\."
                                                  r"create_usd_exporter is not provided"):
        gym.create_usd_exporter(None)
    with pytest.raises(TypeError, match="expected a Sim and an Env"):
        gym.get_camera_image(None, None, 0, gymapi.IMAGE_COLOR)
    assert not hasattr(gym, "create_cloth_grid")    # still an AttributeError for hasattr
    with pytest.raises(NotImplementedError, match="gymapi.SoftMaterial"):
        gymapi.SoftMaterial
    with pytest.raises(NotImplementedError, match="SIM_FLEX"):
        gym.create_sim(0, 0, gymapi.SIM_FLEX, gymapi.SimParams())

    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, cartpole_sim_params())
    options = gymapi.AssetOptions()
    options.override_inertia = True
    with pytest.raises(NotImplementedError, match="override_inertia"):
        gym.load_asset(sim, str(cartpole_file.parent), cartpole_file.name, options)
    options = gymapi.AssetOptions()
    options.fix_base_link = True
    cartpole = gym.load_asset(sim, str(cartpole_file.parent), cartpole_file.name, options)
    box = gym.create_box(sim, 0.1, 0.1, 0.1)
    lower, upper = gymapi.Vec3(-1, -1, 0), gymapi.Vec3(1, 1, 1)
    env0 = gym.create_env(sim, lower, upper, 2)
    gym.create_actor(env0, cartpole, gymapi.Transform(), "cartpole", 0, 1)
    env1 = gym.create_env(sim, lower, upper, 2)
    gym.create_actor(env1, box, gymapi.Transform(), "box", 1, 1)
    with pytest.raises(ValueError, match=r"env 1 actor 0 'box' .*cartpole.*same actors"):
        gym.prepare_sim(sim)
    # acquiring a tensor before prepare_sim builds the sim (Isaac Gym allows it), with the
    # same checks; a sim without envs cannot be built
    with pytest.raises(ValueError, match=r"env 1 actor 0 'box'"):
        gym.acquire_dof_state_tensor(sim)
    with pytest.raises(RuntimeError, match="prepare_sim"):
        gym.acquire_dof_state_tensor(gym.create_sim(0, 0, gymapi.SIM_PHYSX,
                                                    cartpole_sim_params()))


def test_parse_arguments(monkeypatch):
    custom = [{"name": "--num_envs", "type": int, "default": 16, "help": "envs"},
              {"name": "--record", "action": "store_true"}]
    monkeypatch.setattr(sys, "argv", ["prog", "--sim_device", "cpu", "--pipeline", "gpu",
                                      "--num_threads", "2", "--subscenes", "4", "--physx",
                                      "--num_envs", "8", "--headless"])
    args = gymutil.parse_arguments(description="t", headless=True, custom_parameters=custom)
    assert (args.sim_device_type, args.compute_device_id) == ("cpu", 0)
    assert not args.use_gpu and not args.use_gpu_pipeline       # no GPU pipeline on the CPU
    assert args.physics_engine == gymapi.SIM_PHYSX and args.headless
    assert (args.num_threads, args.subscenes, args.slices) == (2, 4, 4)
    assert args.num_envs == 8 and args.record is False and args.graphics_device_id == 0
    params = gymutil.parse_sim_params(args, {"sim": {"dt": 0.005, "up_axis": "y",
                                                     "gravity": [0, -9.81, 0],
                                                     "physx": {"num_position_iterations": 8}}})
    assert params.dt == 0.005 and params.up_axis == gymapi.UP_AXIS_Y
    assert params.gravity.y == pytest.approx(-9.81) and params.physx.num_threads == 2
    assert params.physx.num_position_iterations == 8 and not params.use_gpu_pipeline

    monkeypatch.setattr(sys, "argv", ["prog", "--sim_device", "cuda:1", "--flex"])
    args = gymutil.parse_arguments()
    assert (args.sim_device_type, args.compute_device_id) == ("cuda", 1)
    assert args.use_gpu and args.use_gpu_pipeline and args.physics_engine == gymapi.SIM_FLEX
    assert args.slices == 0


def test_math_conventions():
    q = gymapi.Quat.from_axis_angle(gymapi.Vec3(0, 0, 1), math.pi / 2)
    v = q.rotate(gymapi.Vec3(1, 0, 0))
    assert (v.x, v.y, v.z) == pytest.approx((0, 1, 0), abs=1e-9)
    r = gymapi.Quat.from_euler_zyx(0.3, -0.2, 1.1)
    assert r.to_euler_zyx() == pytest.approx((0.3, -0.2, 1.1))
    t = gymapi.Transform(gymapi.Vec3(1, 2, 3), q)
    p = t.inverse().transform_point(t.transform_point(gymapi.Vec3(0.5, -1, 2)))
    assert (p.x, p.y, p.z) == pytest.approx((0.5, -1, 2))
    # torch_utils agrees with gymapi.Quat (x, y, z, w)
    qt = to_torch([[r.x, r.y, r.z, r.w]], device="cpu")
    u = r.rotate(gymapi.Vec3(0.1, 0.2, 0.3))
    torch.testing.assert_close(quat_apply(qt, torch.tensor([[0.1, 0.2, 0.3]])),
                               torch.tensor([[u.x, u.y, u.z]]))
    torch.testing.assert_close(quat_from_euler_xyz(*[torch.tensor([a]) for a in
                                                     (0.3, -0.2, 1.1)]), qt)
    roll, pitch, yaw = get_euler_xyz(qt)
    assert (roll.item(), pitch.item(), yaw.item()) == pytest.approx(
        (0.3, 2 * math.pi - 0.2, 1.1), abs=1e-5)
    qq = q * r
    torch.testing.assert_close(quat_mul(to_torch([[q.x, q.y, q.z, q.w]], device="cpu"), qt),
                               torch.tensor([[qq.x, qq.y, qq.z, qq.w]]))
    torch.testing.assert_close(quat_rotate_inverse(qt, quat_apply(qt, torch.ones(1, 3))),
                               torch.ones(1, 3))
    # from_buffer: a record's bytes, a record, or numbers
    record = np.zeros((), gymapi.Transform.dtype)
    record["p"]["y"], record["r"]["z"], record["r"]["w"] = 2.0, 0.6, 0.8
    for buf in (record.tobytes(), record):
        back = gymapi.Transform.from_buffer(buf)
        assert (back.p.y, back.r.z, back.r.w) == pytest.approx((2.0, 0.6, 0.8))
    assert gymapi.Quat.from_buffer(record["r"]) == gymapi.Quat(0, 0, np.float32(0.6),
                                                               np.float32(0.8))
    assert gymapi.Vec3.from_buffer([1, 2, 3]) == gymapi.Vec3(1, 2, 3)
    frame = gymapi.DofFrame.from_buffer(np.arange(6, dtype=np.float32).tobytes())
    assert (frame.origin.z, frame.axis.x) == (2.0, 3.0)
    assert gymapi.Velocity.from_buffer(np.ones(6)).angular == gymapi.Vec3(1, 1, 1)


def test_position_drive_gains_stick_to_each_env(cartpole_file):
    """DOF_MODE_POS with per-env stiffness set between create_actor calls (how projects
    randomize): the slider reaches its target in every env, the stiffer drive faster."""
    gym = gymapi.acquire_gym()
    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, cartpole_sim_params())
    options = gymapi.AssetOptions()
    options.fix_base_link = True
    options.default_dof_drive_mode = gymapi.DOF_MODE_POS
    asset = gym.load_asset(sim, str(cartpole_file.parent), cartpole_file.name, options)
    assert (gym.get_asset_dof_properties(asset)["driveMode"] == gymapi.DOF_MODE_POS).all()
    for i, kp in enumerate((200.0, 2000.0)):
        env = gym.create_env(sim, gymapi.Vec3(), gymapi.Vec3(), 1)
        h = gym.create_actor(env, asset, gymapi.Transform(gymapi.Vec3(0, 0, 2)), "cp", i, 1)
        props = gym.get_actor_dof_properties(env, h)
        props["stiffness"][0], props["damping"][0] = kp, 2 * math.sqrt(kp * 2.0)
        props["stiffness"][1], props["damping"][1] = 500.0, 20.0   # holds the pole up
        gym.set_actor_dof_properties(env, h, props)
    gym.prepare_sim(sim)
    assert gym.get_actor_dof_properties(gym.get_env(sim, 1), 0)["stiffness"][0] == 2000.0
    dof_state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim)).view(2, 2, 2)
    targets = torch.tensor([0.5, 0.0, 0.5, 0.0])
    gym.set_dof_position_target_tensor(sim, gymtorch.unwrap_tensor(targets))
    for _ in range(12):
        gym.simulate(sim)
    gym.refresh_dof_state_tensor(sim)
    assert dof_state[1, 0, 0] > dof_state[0, 0, 0] + 0.05    # the stiffer drive is ahead
    for _ in range(250):
        gym.simulate(sim)
    gym.refresh_dof_state_tensor(sim)
    torch.testing.assert_close(dof_state[..., 0], torch.tensor([[0.5, 0.0]] * 2), atol=2e-3,
                               rtol=0)


def _two_link_sim(tmp_path, fix_base_link: bool):
    """4 envs of the cartpole, fixed (an arm) or free (a floating base), dof states random."""
    (tmp_path / "cartpole.urdf").write_text(CARTPOLE_URDF)
    gym = gymapi.acquire_gym()
    sim = gym.create_sim(-1, -1, gymapi.SIM_PHYSX, cartpole_sim_params())
    options = gymapi.AssetOptions()
    options.fix_base_link = fix_base_link
    asset = gym.load_asset(sim, str(tmp_path), "cartpole.urdf", options)
    for i in range(4):
        env = gym.create_env(sim, gymapi.Vec3(-2, -2, 0), gymapi.Vec3(2, 2, 2), 2)
        pose = gymapi.Transform(gymapi.Vec3(0, 0, 2))
        gym.create_actor(env, asset, pose, "cartpole", i, 1, 0)
    gym.prepare_sim(sim)
    return gym, sim


def _rigid_velocities(gym, sim):
    gym.refresh_rigid_body_state_tensor(sim)
    bodies = gymtorch.wrap_tensor(gym.acquire_rigid_body_state_tensor(sim)).view(4, -1, 13)
    return bodies[..., 7:10], bodies[..., 10:13]


def test_jacobian_of_a_fixed_arm_maps_dof_speeds_to_link_velocities(tmp_path):
    """acquire_jacobian_tensor on a fixed base: [envs, links - 1, 6, dofs], linear rows first at
    each link's origin; J·qd gives the links' velocities of the rigid body state tensor."""
    gym, sim = _two_link_sim(tmp_path, fix_base_link=True)
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    dofs[:, 1] = torch.randn(dofs.shape[0], generator=torch.Generator().manual_seed(0))
    gym.set_dof_state_tensor(sim, gymtorch.unwrap_tensor(dofs))
    jac = gymtorch.wrap_tensor(gym.acquire_jacobian_tensor(sim, "cartpole"))
    gym.refresh_jacobian_tensors(sim)
    assert tuple(jac.shape) == (4, 2, 6, 2)                       # cart, pole; 2 dofs
    qd = dofs[:, 1].view(4, 2)
    lin, ang = _rigid_velocities(gym, sim)
    twist = torch.einsum("elrc,ec->elr", jac, qd)
    torch.testing.assert_close(twist[..., :3], lin[:, 1:], atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(twist[..., 3:], ang[:, 1:], atol=1e-5, rtol=1e-5)
    mass = gymtorch.wrap_tensor(gym.acquire_mass_matrix_tensor(sim, "cartpole"))
    gym.refresh_mass_matrix_tensors(sim)
    assert tuple(mass.shape) == (4, 2, 2)
    torch.testing.assert_close(mass, mass.transpose(1, 2))


def test_jacobian_and_mass_matrix_of_a_floating_base_use_world_axes(tmp_path):
    """A free base: 6 + dofs columns, the base's (linear, angular) velocity in world axes as the
    root state tensor gives it; J·[v, w, qd] = every link's velocity, and ½ uᵀ M u is the
    kinetic energy Myriad computes from its own (body-axes) velocities."""
    gym, sim = _two_link_sim(tmp_path, fix_base_link=False)
    gen = torch.Generator().manual_seed(1)
    roots = gymtorch.wrap_tensor(gym.acquire_actor_root_state_tensor(sim))
    angle = 0.7
    roots[:, 3:7] = torch.tensor([math.sin(angle / 2) * 0.6, math.sin(angle / 2) * 0.8, 0.0,
                                  math.cos(angle / 2)])
    roots[:, 7:13] = torch.randn(4, 6, generator=gen)
    gym.set_actor_root_state_tensor(sim, gymtorch.unwrap_tensor(roots))
    dofs = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    dofs[:, 1] = torch.randn(dofs.shape[0], generator=gen)
    gym.set_dof_state_tensor(sim, gymtorch.unwrap_tensor(dofs))
    jac = gymtorch.wrap_tensor(gym.acquire_jacobian_tensor(sim, "cartpole"))
    mass = gymtorch.wrap_tensor(gym.acquire_mass_matrix_tensor(sim, "cartpole"))
    gym.refresh_jacobian_tensors(sim)
    gym.refresh_mass_matrix_tensors(sim)
    assert tuple(jac.shape) == (4, 3, 6, 8) and tuple(mass.shape) == (4, 8, 8)
    gym.refresh_actor_root_state_tensor(sim)
    u = torch.cat([roots[:, 7:13], dofs[:, 1].view(4, 2)], dim=1)   # world-axes base velocity
    lin, ang = _rigid_velocities(gym, sim)
    twist = torch.einsum("elrc,ec->elr", jac, u)
    torch.testing.assert_close(twist[..., :3], lin, atol=1e-4, rtol=1e-4)
    torch.testing.assert_close(twist[..., 3:], ang, atol=1e-4, rtol=1e-4)
    energy = 0.5 * torch.einsum("ei,eij,ej->e", u, mass, u)
    own = sim.myriad.sim
    expected = 0.5 * torch.einsum("ei,eij,ej->e", own.qd, own.mass_matrix, own.qd)
    torch.testing.assert_close(energy, expected, atol=1e-4, rtol=1e-4)


def test_parse_sim_config_writes_legged_gyms_sim_dict():
    """legged_gym hands its sim config to gymutil.parse_sim_config as a nested dict."""
    params = gymapi.SimParams()
    gymutil.parse_sim_config({"dt": 0.005, "substeps": 1, "gravity": [0.0, 0.0, -9.81],
                              "up_axis": 1, "physx": {"num_position_iterations": 4,
                                                      "contact_offset": 0.01,
                                                      "contact_collection": 2}}, params)
    assert params.dt == 0.005 and params.substeps == 1 and params.up_axis == gymapi.UP_AXIS_Z
    assert (params.gravity.x, params.gravity.y, params.gravity.z) == (0.0, 0.0, -9.81)
    assert params.physx.contact_offset == 0.01
    assert params.physx.contact_collection == gymapi.ContactCollection(2)
    with pytest.raises(AttributeError, match="no attribute 'dtt'"):
        gymutil.parse_sim_config({"dtt": 0.01}, params)


def test_line_geometries_are_the_shapes_they_name():
    """gymutil's line geometries (what IsaacGymEnvs' and legged_gym's debug drawings use):
    Vec3 records [num_lines, 2] and one color per line, their pose applied, in closed form."""
    def floats(records):
        return np.stack([records["x"], records["y"], records["z"]], axis=-1)

    axes = gymutil.AxesGeometry(0.5)
    assert axes.num_lines() == 3 and axes.vertices().shape == (3, 2)
    np.testing.assert_allclose(floats(axes.vertices())[:, 1], 0.5 * np.eye(3))
    np.testing.assert_allclose(floats(axes.colors()), np.eye(3))       # x red, y green, z blue

    box = gymutil.WireframeBoxGeometry(0.2, 0.4, 0.6, color=(0, 1, 0))
    edges = floats(box.vertices())
    assert edges.shape == (12, 2, 3)
    # 4 edges along each axis, each as long as the box's side; every end a corner
    lengths = np.sort(np.linalg.norm(edges[:, 1] - edges[:, 0], axis=-1))
    np.testing.assert_allclose(lengths, np.repeat([0.2, 0.4, 0.6], 4), atol=1e-6)
    np.testing.assert_allclose(np.abs(edges), np.broadcast_to([0.1, 0.2, 0.3], edges.shape),
                               atol=1e-6)
    np.testing.assert_allclose(floats(box.colors()), np.tile([0.0, 1.0, 0.0], (12, 1)))
    bbox = gymutil.WireframeBBoxGeometry([[0, 0, 0], [1, 2, 3]])
    assert floats(bbox.vertices()).min() == 0 and floats(bbox.vertices()).max() == 3

    # a sphere: 2 · lats · lons segments with both ends on it, alternating the two colors; at
    # its pose (1, 2, 3) turned 90° about z
    pose = gymapi.Transform(gymapi.Vec3(1, 2, 3), gymapi.Quat.from_axis_angle(
        gymapi.Vec3(0, 0, 1), math.pi / 2))
    sphere = gymutil.WireframeSphereGeometry(0.3, 6, 4, pose, (1, 0, 0), (0, 0, 1))
    ends = floats(sphere.vertices())
    assert sphere.num_lines() == 2 * 6 * 4
    np.testing.assert_allclose(np.linalg.norm(ends - [1, 2, 3], axis=-1), 0.3, atol=1e-6)
    np.testing.assert_allclose(floats(sphere.colors())[:2], [[1, 0, 0], [0, 0, 1]])
    # draw_lines moves the geometry by its pose: the box's corner (0.1, 0.2, 0.3) turned 90°
    # about z and moved to (1, 2, 3) is (0.8, 2.1, 3.3)
    moved = floats(box.instance_verts(pose)).reshape(-1, 3)
    assert np.isclose(moved, [0.8, 2.1, 3.3], atol=1e-6).all(axis=1).any()


def _classic_scene(cartpole_file, num_envs=3):
    """`num_envs` envs of a fixed cartpole (its cart on a position drive, its pole free) and a
    0.2 m box (8 kg) resting on the ground."""
    gym = gymapi.acquire_gym()
    sim = gym.create_sim(-1, -1, gymapi.SIM_PHYSX, cartpole_sim_params())
    plane = gymapi.PlaneParams()
    plane.normal = gymapi.Vec3(0, 0, 1)
    gym.add_ground(sim, plane)
    options = gymapi.AssetOptions()
    options.fix_base_link = True
    cartpole = gym.load_asset(sim, str(cartpole_file.parent), cartpole_file.name, options)
    box = gym.create_box(sim, 0.2, 0.2, 0.2, gymapi.AssetOptions())
    envs = []
    for i in range(num_envs):
        env = gym.create_env(sim, gymapi.Vec3(-2, -2, 0), gymapi.Vec3(2, 2, 2), 2)
        handle = gym.create_actor(env, cartpole, gymapi.Transform(gymapi.Vec3(0, 0, 2)),
                                  "cartpole", i, 1, 0)
        props = gym.get_actor_dof_properties(env, handle)
        props["driveMode"] = (gymapi.DOF_MODE_POS, gymapi.DOF_MODE_EFFORT)
        props["stiffness"], props["damping"] = (400.0, 0.0), (40.0, 0.0)
        gym.set_actor_dof_properties(env, handle, props)
        gym.create_actor(env, box, gymapi.Transform(gymapi.Vec3(1, 0, 0.1)), "box", i, 0, 0)
        envs.append(env)
    gym.prepare_sim(sim)
    return gym, sim, envs


def test_classic_calls_on_one_body_dof_and_joint(cartpole_file):
    """Isaac Gym's per-handle calls (its examples' style) against the tensor calls on a twin
    sim, and against closed forms: handles and names, DOF and joint frames, one DOF's target
    and effort, a root body's pose and velocity, forces on one body, and the contacts."""
    gym, sim, envs = _classic_scene(cartpole_file)
    twin, twin_sim, _ = _classic_scene(cartpole_file)
    env = envs[1]
    # handles (env domain) and names
    assert gym.get_env_joint_count(env) == 2 and gym.get_sim_joint_count(sim) == 6
    assert gym.get_joint_handle(env, "cartpole", "cart_to_pole") == 1
    assert gym.get_joint_name(env, 1) == "cart_to_pole"
    assert gym.get_joint_type_string(gym.get_asset_joint_type(
        gym.get_actor_asset(env, 0), 0)) == "JOINT_PRISMATIC"
    box = gym.get_actor_rigid_body_handle(env, 1, 0)
    assert box == 3 == gym.get_rigid_handle(env, "box", "box")
    assert gym.get_rigid_name(env, box) == "box"
    assert gym.get_actor_dof_handle(env, 0, 1) == 1
    assert gym.get_actor_joint_index(env, 0, 1, gymapi.DOMAIN_SIM) == 3
    with pytest.raises(IndexError, match="3 bodies"):
        gym.get_actor_rigid_body_handle(env, 0, 3)
    with pytest.raises(ValueError, match="not a rigid body handle of env 1"):
        gym.get_rigid_name(env, 4)
    # the URDF's joints: the rail's axis y at the base (z = 2), the pole's axis x 0.12 m along
    # colors: the model's until set, then the one set; segmentation ids: the actor's until set
    c = gym.get_rigid_body_color(env, 1, 0, gymapi.MESH_VISUAL)
    assert (c.x, c.y, c.z) == pytest.approx(tuple(gym.get_actor_asset(env, 1).mj.geom_rgba[0, :3]))
    before = looks(sim)
    gym.set_rigid_body_color(env, 1, 0, gymapi.MESH_VISUAL, gymapi.Vec3(0.9, 0.1, 0.2))
    gym.set_rigid_body_segmentation_id(envs[2], 0, 1, 5)
    # the looks cameras and the page draw: env 1 and 2 made again, into new arrays (a page
    # holding the old ones sees the change), the same as all envs made afresh
    after = looks(sim)
    assert after is not before and not np.array_equal(after.rgba[1], before.rgba[1])
    assert np.array_equal(after.rgba[[0, 2]], before.rgba[[0, 2]])
    assert after.dressed[1].sum() >= 1 and not after.dressed[[0, 2]].any()
    assert (after.segment[2] == 5).sum() >= 1 and not (after.segment[[0, 1]] == 5).any()
    sim.looks = None
    assert all(np.array_equal(a, b) for a, b in zip(after, looks(sim)))
    c = gym.get_rigid_body_color(env, 1, 0, gymapi.MESH_VISUAL)
    assert (c.x, c.y, c.z) == pytest.approx((0.9, 0.1, 0.2))
    assert gym.get_rigid_body_segmentation_id(env, 1, 0) == 0
    frames = gym.get_actor_dof_frames(env, 0)
    np.testing.assert_allclose([tuple(frames["origin"][1]), tuple(frames["axis"][0]),
                                tuple(frames["axis"][1])],
                               [(0.12, 0, 2), (0, 1, 0), (1, 0, 0)], atol=1e-6)

    # one DOF's target and another's effort: as the tensor calls on the twin
    gym.set_dof_target_position(env, 0, 0.3)
    gym.apply_dof_effort(env, 1, 2.0)
    assert gym.get_dof_target_position(env, 0) == pytest.approx(0.3)
    gym.set_joint_target_position(env, 0, 0.2)          # joint 0 (the rail) moves DOF 0
    assert gym.get_dof_target_position(env, 0) == pytest.approx(0.2)
    gym.set_joint_target_position(env, 0, 0.3)
    targets = torch.zeros(3, 2)
    targets[1, 0] = 0.3
    efforts = torch.zeros(3, 2)
    efforts[1, 1] = 2.0
    twin.set_dof_position_target_tensor(twin_sim, gymtorch.unwrap_tensor(targets.view(-1)))
    twin.set_dof_actuation_force_tensor(twin_sim, gymtorch.unwrap_tensor(efforts.view(-1)))
    # a root's pose and velocity (the box, env 1) against the twin's root state tensor
    gym.set_rigid_transform(env, box, gymapi.Transform(gymapi.Vec3(1.0, 0.5, 0.6)))
    gym.set_rigid_linear_velocity(env, box, gymapi.Vec3(0.0, 0.0, 1.0))
    root = gymtorch.wrap_tensor(twin.acquire_actor_root_state_tensor(twin_sim))
    twin.refresh_actor_root_state_tensor(twin_sim)
    new = root.clone()
    new[3, :3] = torch.tensor([1.0, 0.5, 0.6])
    new[3, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])
    new[3, 7:13] = torch.tensor([0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    twin.set_actor_root_state_tensor(twin_sim, gymtorch.unwrap_tensor(new))
    for step in range(20):
        gym.simulate(sim)
        twin.simulate(twin_sim)
    ours = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    gym.refresh_dof_state_tensor(sim)
    twin.refresh_dof_state_tensor(twin_sim)
    theirs = gymtorch.wrap_tensor(twin.acquire_dof_state_tensor(twin_sim))
    torch.testing.assert_close(ours, theirs, atol=0, rtol=0)
    assert gym.get_dof_position(env, 1) == ours[3, 0].item() != 0.0     # the pole moved
    assert gym.get_joint_velocity(env, 1) == ours[3, 1].item()
    twin.refresh_actor_root_state_tensor(twin_sim)
    p = gym.get_rigid_transform(env, box).p
    assert (p.x, p.y, p.z) == pytest.approx(root[3, :3].tolist(), abs=0)
    v = gym.get_rigid_linear_velocity(env, box)
    assert (v.x, v.y, v.z) == pytest.approx(root[3, 7:10].tolist(), abs=0)
    # the vector forms: the same body in several envs at once
    poses = gym.get_vec_rigid_transform([envs[2], env], box)
    assert poses.shape == (2,) and poses["p"]["z"][1] == p.z and poses["r"]["w"][1] == \
        pytest.approx(root[3, 6].item(), abs=0)
    speeds = gym.get_vec_rigid_linear_velocity(envs, box)
    assert speeds["z"].tolist() == pytest.approx(root[[1, 3, 5], 9].tolist(), abs=0)
    mixed = gym.get_vec_rigid_transform([envs[0], env], [box, 0])     # one handle per env
    assert mixed["p"]["z"][1] == pytest.approx(2.0) and mixed["p"]["x"][0] == \
        pytest.approx(root[1, 0].item(), abs=0)
    dofs = gym.get_vec_actor_dof_states(envs, [0, 0, 0], gymapi.STATE_ALL)
    assert dofs.shape == (3, 2) and dofs["pos"][1].tolist() == ours[2:4, 0].tolist()
    assert (gym.get_vec_actor_dof_states(envs, 0, gymapi.STATE_POS)["vel"] == 0).all()
    with pytest.raises(ValueError, match="the actors have \\[0, 2\\] DOFs"):
        gym.get_vec_actor_dof_states(envs[:2], [0, 1])
    # a link's pose follows its DOFs: setting it is refused, naming the root to set instead
    with pytest.raises(NotImplementedError, match=r"body 1 \('cart'\), a link of actor "
                                                  r"'cartpole'.*root body \(0\)"):
        gym.set_rigid_linear_velocity(env, 1, gymapi.Vec3(1, 0, 0))
    states = gym.get_actor_rigid_body_states(env, 1, gymapi.STATE_ALL)
    states["pose"]["p"]["z"] = 0.9
    states["vel"]["linear"]["z"] = 5.0
    gym.set_actor_rigid_body_states(env, 1, states, gymapi.STATE_POS)   # the pose only
    after = gym.get_actor_rigid_body_states(env, 1, gymapi.STATE_ALL)
    assert after["pose"]["p"]["z"][0] == pytest.approx(0.9)
    assert after["vel"]["linear"]["z"][0] == pytest.approx(float(root[3, 9]), abs=1e-6)


def test_classic_forces_and_contacts_on_one_body(cartpole_file):
    """apply_body_forces / apply_body_force_at_pos act on one body of one env for one
    simulate (closed forms for a free box); get_env_rigid_contacts reports the resting box's
    contacts with the ground as Isaac Gym's RigidContact records."""
    gym, sim, envs = _classic_scene(cartpole_file, num_envs=2)
    for step in range(60):                      # the boxes settle on the ground
        gym.simulate(sim)
    env = envs[0]
    box = gym.get_rigid_handle(env, "box", "box")
    contacts = gym.get_env_rigid_contacts(env)
    assert len(contacts) == 4                  # the four corners of the bottom face
    assert (contacts["body0"] == -1).all() and (contacts["body1"] == box).all()
    assert (contacts["env0"] == -1).all() and (contacts["env1"] == 0).all()
    np.testing.assert_allclose(contacts["normal"]["z"], 1.0, atol=1e-6)
    np.testing.assert_allclose(contacts["lambda"].sum(), 8.0 * 9.81, rtol=0.01)
    for axis in "xy":                          # in the box's frame: its bottom corners
        np.testing.assert_allclose(np.abs(contacts["localPos1"][axis]), 0.1, atol=1e-3)
    np.testing.assert_allclose(contacts["localPos1"]["z"], -0.1, atol=2e-3)
    np.testing.assert_allclose(contacts["friction"], 1.0)
    forces = gym.get_env_rigid_contact_forces(env)
    assert forces.shape == (4,) and forces["z"][box] == pytest.approx(8.0 * 9.81, rel=0.01)
    assert gym.get_rigid_contacts(sim).shape == (8,)

    # lifted (turned 90° about z) and spun in one env only: 200 N up through the center of
    # mass for one simulate, and for another a 10 N force along the box's y at 0.1 m along its
    # x, given in the box's frame: in the world, -x at +y
    dt = cartpole_sim_params().dt
    turned = gymapi.Quat.from_axis_angle(gymapi.Vec3(0, 0, 1), math.pi / 2)
    gym.set_rigid_transform(env, box, gymapi.Transform(gymapi.Vec3(1, 0, 1.0), turned))
    gym.simulate(sim)
    v0 = gym.get_rigid_linear_velocity(env, box).z
    gym.apply_body_forces(env, box, gymapi.Vec3(0, 0, 200.0), None, gymapi.ENV_SPACE)
    gym.simulate(sim)
    assert gym.get_rigid_linear_velocity(env, box).z - v0 == pytest.approx(
        (200.0 / 8.0 - 9.81) * dt, rel=1e-3)
    assert gym.get_rigid_linear_velocity(envs[1], box).z == pytest.approx(0.0, abs=1e-3)
    gym.simulate(sim)                          # the force lasted one simulate
    assert gym.get_rigid_linear_velocity(env, box).z - v0 == pytest.approx(
        (200.0 / 8.0 - 9.81) * dt - 9.81 * dt, rel=1e-3)
    w0, u0 = gym.get_rigid_angular_velocity(env, box), gym.get_rigid_linear_velocity(env, box)
    gym.apply_body_force_at_pos(env, box, gymapi.Vec3(0, 10.0, 0), gymapi.Vec3(0.1, 0, 0),
                                gymapi.LOCAL_SPACE)
    gym.simulate(sim)
    inertia = 8.0 * (0.2 ** 2 + 0.2 ** 2) / 12.0
    w, u = gym.get_rigid_angular_velocity(env, box), gym.get_rigid_linear_velocity(env, box)
    assert w.z - w0.z == pytest.approx(0.1 * 10.0 / inertia * dt, rel=1e-3)
    assert u.x - u0.x == pytest.approx(-10.0 / 8.0 * dt, rel=1e-3)
    assert u.y - u0.y == pytest.approx(0.0, abs=1e-6)
    with pytest.raises(NotImplementedError, match="Flex backend only"):
        gym.set_rigid_body_state_tensor(sim, None)
    gym.destroy_env(envs[1])                   # as code tearing a sim down does
    with pytest.raises(NotImplementedError, match=r"simulate after destroy_env of envs \[1\]"):
        gym.simulate(sim)
    gym.destroy_sim(sim)
