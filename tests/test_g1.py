"""The Unitree G1 (assets.g1_spec) and its velocity task (tasks/g1.py): the capsules that stand
in for its meshes, the model against MuJoCo, standing on its drives, and the task's
observation, commands, terminations and reward terms on set states. The smooth dynamics
against MuJoCo are test_smooth_dynamics.py's (the G1 is one of its models)."""

import importlib.util
import math
import os

import mujoco
import numpy as np
import pytest
import torch

import myriad
from myriad.assets import G1, capsule_around, g1_spec, installed_file, stl_vertices

pytestmark = pytest.mark.skipif(importlib.util.find_spec("cmeel") is None,
                                reason="the G1 needs example-robot-data (pip install .[anymal])")


def make(device, num_envs=4, **overrides):
    return myriad.make("G1Velocity", num_envs=num_envs, device=device,
                       **{"env.learn.addNoise": False, **overrides})


def test_capsule_around_recovers_a_sampled_capsule():
    rng = np.random.default_rng(0)
    axis = np.array([1.0, 2.0, -0.5]) / np.linalg.norm([1.0, 2.0, -0.5])
    side = np.cross(axis, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    up = np.cross(axis, side)
    # points on a capsule's surface: radius 0.04, segment half-length 0.1, centre (0.1, 0, 0.2)
    t = rng.uniform(-0.1, 0.1, 4000)
    angle = rng.uniform(0, 2 * np.pi, 4000)
    ring = 0.04 * (np.cos(angle)[:, None] * side + np.sin(angle)[:, None] * up)
    caps = np.concatenate([[0.14 * axis], [-0.14 * axis]])     # the two tips
    points = np.concatenate([t[:, None] * axis + ring, caps]) + [0.1, 0.0, 0.2]
    centre, found_axis, radius, half = capsule_around(points, quantile=0.5)
    np.testing.assert_allclose(centre, [0.1, 0.0, 0.2], atol=2e-3)
    assert abs(abs(found_axis @ axis) - 1.0) < 1e-4
    assert radius == pytest.approx(0.04, abs=1e-3)
    assert half == pytest.approx(0.1, abs=2e-3)


def test_g1_model_capsules_and_masses():
    spec = g1_spec()
    model = spec.compile()
    hinges = [j for j in range(model.njnt) if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    assert len(hinges) == 29 and model.nv == 35
    assert mujoco.mjtGeom.mjGEOM_MESH not in set(model.geom_type)
    # the URDF's link masses, fused (33.34 kg in all), and its effort limits as force ranges
    assert model.body_mass.sum() == pytest.approx(33.341142, abs=1e-5)
    knee = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "left_knee_joint")
    np.testing.assert_allclose(model.jnt_actfrcrange[knee], [-139, 139])
    assert np.all(model.dof_armature[6:] == 0.01)
    # each fitted capsule holds most of its link's mesh (the 90 % quantile of distances)
    meshes = os.path.join(os.path.dirname(os.path.dirname(installed_file(
        "example-robot-data", G1, "anymal"))), "meshes")
    vertices = stl_vertices(os.path.join(meshes, "left_knee_link.STL"))
    geom = next(g for g in range(model.ngeom) if model.geom_bodyid[g] == mujoco.mj_name2id(
        model, mujoco.mjtObj.mjOBJ_BODY, "left_knee_link"))
    assert model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_CAPSULE
    axis = np.zeros(9)
    mujoco.mju_quat2Mat(axis, model.geom_quat[geom])
    axis = axis.reshape(3, 3)[:, 2]
    rel = vertices - model.geom_pos[geom]
    along = np.clip(rel @ axis, -model.geom_size[geom, 1], model.geom_size[geom, 1])
    distance = np.linalg.norm(rel - along[:, None] * axis, axis=1)
    inside = np.mean(distance <= model.geom_size[geom, 0] + 1e-6)
    assert 0.85 <= inside < 1.0


def test_g1_stands_on_its_drives_as_in_mujoco(device):
    """Held at the default pose by its drives, the robot settles on its feet and stays up for
    half a second, then topples forward slowly, as a robot with fixed targets must; MuJoCo,
    stepping the same scene (its soft contacts, 5 ms steps), does the same: the pelvis at the
    same height and tilting forward at the same pace."""
    task = make(device, num_envs=2, **{"env.pushInterval_s": 1000})
    task.commands.zero_()
    task.envs.set_root_states(task.initial_root_states)     # upright, at rest, facing +x
    task.envs.set_dof_state(task.default_dof_pos.expand(2, -1).clone(),
                            torch.zeros(2, 29, device=task.device))
    model = task.build_scene().compose()[0].compile()
    model.opt.timestep, model.opt.integrator = 0.005, mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    data = mujoco.MjData(model)
    data.qpos[7:] = data.ctrl[:] = task.default_dof_pos.cpu().numpy()
    weight = 33.341142 * 9.81
    for step in range(1, 51):                           # 1 s of 20 ms steps
        task.step(torch.zeros(2, 29, device=task.device))
        for _ in range(4):
            mujoco.mj_step(model, data)
        base = task.envs.root_states[0, 0].cpu().numpy()
        pitch = 2 * np.arcsin(base[4])                  # about y; the quaternion is x, y, z, w
        pitch_mujoco = 2 * np.arcsin(data.qpos[5])
        if step == 25:                                  # 0.5 s: standing still
            assert base[2] == pytest.approx(data.qpos[2], abs=0.005)
            assert base[2] == pytest.approx(0.774, abs=0.005)
            assert abs(pitch) < 0.03 and abs(pitch_mujoco) < 0.03
            feet = task.envs.net_contact_force[0, task.feet, 2].sum().item()
            assert feet == pytest.approx(weight, rel=0.05)
    # 1 s: both tip forward, by similar angles
    assert 0.03 < pitch_mujoco and 0.03 < pitch
    assert pitch == pytest.approx(pitch_mujoco, abs=0.05)    # measured 0.107 and 0.124 rad
    assert torch.all(task.progress_buf == 50)           # no env has fallen or been reset


def test_g1_observation_and_terms(device):
    task = make(device, num_envs=2)
    assert task.obs_buf.shape == (2, 101) and task.num_actions == 29
    e = task.envs
    states = e.root_states.clone()
    states[:, 0, 7:10] = torch.tensor([0.4, -0.2, 0.0])
    states[:, 0, 10:13] = torch.tensor([0.0, 0.0, 0.5])
    e.set_root_states(states)
    task.commands[:] = torch.tensor([0.4, -0.2, 0.5], device=task.device)
    task.compute_observations()
    obs = task.obs_buf
    yaw = 2 * torch.atan2(states[:, 0, 5], states[:, 0, 6])
    np.testing.assert_allclose(obs[:, 9:12].cpu().numpy(), [[0.8, -0.4, 0.125]] * 2, atol=1e-6)
    np.testing.assert_allclose(obs[:, 6:9].cpu().numpy(), [[0, 0, -1]] * 2, atol=1e-5)
    np.testing.assert_allclose(obs[:, 99:101].cpu().numpy(), [[0, 1]] * 2, atol=1e-6)  # phase 0
    task.progress_buf[:] = torch.tensor([10, 30])      # 0.2 s, 0.6 s of the 0.8 s period
    np.testing.assert_allclose(task.gait_phase().cpu().numpy(), [0.25, 0.75], atol=1e-6)
    # the base velocity in the base frame: the world velocity turned by -yaw
    c, s = torch.cos(yaw), torch.sin(yaw)
    expected = torch.stack((c * 0.4 - s * 0.2, -s * 0.4 - c * 0.2), -1) * 2
    np.testing.assert_allclose(obs[:, 0:2].cpu().numpy(), expected.cpu().numpy(), atol=1e-5)
    # commands met exactly in the yaw frame: both tracking terms at their maximum
    from myriad.tasks.g1 import compute_g1_reward
    N = 2
    zeros = torch.zeros(N, 29, device=task.device)
    scales = {k: 0.0 for k in task.reward_scales}
    scales.update(linearVelocityXYRewardScale=1.0, angularVelocityZRewardScale=1.0)
    base = e.root_states[:, 0].clone()
    base[:, 7:9] = torch.stack((c * 0.4 + s * 0.2, s * 0.4 - c * 0.2), -1)
    no_feet = torch.zeros(N, 2, dtype=torch.bool, device=task.device)
    reward, fell = compute_g1_reward(
        base, task.commands, zeros, e.dof_pos, zeros, zeros, zeros, zeros,
        task.default_dof_pos, task.soft_limits, task.deviation_dofs, e.net_contact_force * 0,
        task.bodies_ending, torch.zeros(N, 2, dtype=torch.bool, device=task.device),
        torch.zeros(N, 2, device=task.device), torch.zeros(N, 2, device=task.device),
        torch.zeros(N, 2, 2, device=task.device), no_feet, no_feet.float(),
        task.gravity_dir[:N], task.forward_axis[:N], 0.02, 1.0, 0.08, scales,
        base[:, 3:7], torch.ones(N, 29, device=task.device), task.learn,
        torch.zeros(N, 3, device=task.device), torch.zeros(N, 2, device=task.device))
    np.testing.assert_allclose(reward.cpu().numpy(), 2.0, atol=1e-5)
    assert not fell.any()


def test_g1_angular_momentum_is_mujocos(device):
    """`Envs.angular_momentum`, which the angular-momentum term charges, is MuJoCo's
    subtree_angmom of the pelvis (the whole robot about its centre of mass) in random states: a
    tumbling, drifting base and every joint moving; and the term pays −scale·|L|²."""
    from myriad.tasks.g1 import compute_g1_reward
    task = make(device, num_envs=3)
    e, dev, N = task.envs, task.device, 3
    mj = e.model.mj_model
    rng = np.random.default_rng(0)
    expected = []
    for env in range(N):
        d = mujoco.MjData(mj)
        d.qpos[:] = mj.qpos0
        quat = rng.normal(size=4)
        d.qpos[3:7] = quat / np.linalg.norm(quat)
        d.qpos[7:] += rng.uniform(-0.3, 0.3, size=mj.nq - 7)
        d.qvel[:] = rng.normal(size=mj.nv) * 2.0
        mujoco.mj_forward(mj, d)
        mujoco.mj_subtreeVel(mj, d)
        e.sim.q[env] = torch.as_tensor(e.model.qpos_from_mujoco(d.qpos), dtype=torch.float32)
        e.sim.qd[env] = torch.as_tensor(d.qvel, dtype=torch.float32)
        expected.append(d.subtree_angmom[e.actor_bodies("g1")[0] + 1].copy())
    e.forward()
    momentum = e.angular_momentum("g1")
    assert momentum.shape == (N, 3)
    shares = e.angular_momentum("g1", per_body=True)
    assert shares.shape == (N, 30, 3)
    torch.testing.assert_close(shares.sum(1), momentum)
    expected = np.array(expected)
    assert np.all(np.linalg.norm(expected, axis=1) > 0.5)      # measured 7.8 to 8.4 kg·m²/s
    np.testing.assert_allclose(momentum.cpu().numpy(), expected, atol=1e-4 * 4, rtol=1e-4)
    # the term: −scale·|L|², nothing else switched on
    scales = {k: 0.0 for k in task.reward_scales}
    scales.update(angularMomentumRewardScale=-0.5)
    zeros = torch.zeros(N, 29, device=dev)
    no_feet = torch.zeros(N, 2, dtype=torch.bool, device=dev)
    reward, _ = compute_g1_reward(
        e.root_states[:, 0], torch.zeros(N, 3, device=dev), zeros, e.dof_pos, zeros, zeros,
        zeros, zeros, task.default_dof_pos, task.soft_limits, task.deviation_dofs,
        e.net_contact_force * 0, task.bodies_ending, no_feet, torch.zeros(N, 2, device=dev),
        torch.zeros(N, 2, device=dev), torch.zeros(N, 2, 2, device=dev), no_feet,
        no_feet.float(), task.gravity_dir, task.forward_axis, 0.02, math.pi, 0.08, scales,
        e.root_states[:, 0, 3:7], torch.ones(N, 29, device=dev), task.learn, momentum,
        torch.zeros(N, 2, device=dev))
    np.testing.assert_allclose(reward.cpu().numpy(), -0.5 * np.sum(expected ** 2, axis=1),
                               rtol=1e-3)


def test_g1_upright_and_pose_terms(device):
    """The upright term is exp(−|g_xy|²/σ²) of the torso's tilt; the pose term exp(−mean((q −
    q0)²/std²)) with each env's tolerances; the task picks the standing tolerances for a zero
    command and the walking ones for a moving one."""
    from myriad.tasks.g1 import compute_g1_reward
    task = make(device, num_envs=2)
    dev, N = task.device, 2
    scales = {k: 0.0 for k in task.reward_scales}
    scales.update(uprightRewardScale=1.0, poseRewardScale=10.0)
    kernels = dict(task.learn, uprightSigma2=0.2)
    base = task.envs.root_states[:, 0].clone()
    tilt = 0.3                                  # env 1's torso tilted 0.3 rad about x
    torso = torch.tensor([[0.0, 0, 0, 1], [math.sin(tilt / 2), 0, 0, math.cos(tilt / 2)]],
                         device=dev)
    dof_pos = task.default_dof_pos.expand(N, -1).clone()
    dof_pos[1, :3] += 0.1                       # three joints 0.1 rad off, with std 0.2
    std = torch.full((N, 29), 0.2, device=dev)
    zeros = torch.zeros(N, 29, device=dev)
    no_feet = torch.zeros(N, 2, dtype=torch.bool, device=dev)
    reward, _ = compute_g1_reward(
        base, torch.zeros(N, 3, device=dev), zeros, dof_pos, zeros, zeros, zeros, zeros,
        task.default_dof_pos, task.soft_limits, task.deviation_dofs,
        task.envs.net_contact_force * 0, task.bodies_ending, no_feet,
        torch.zeros(N, 2, device=dev), torch.zeros(N, 2, device=dev),
        torch.zeros(N, 2, 2, device=dev), no_feet, no_feet.float(), task.gravity_dir,
        task.forward_axis, 0.02, 1.0, 0.08, scales, torso, std, kernels,
        torch.zeros(N, 3, device=dev), torch.zeros(N, 2, device=dev))
    pose = math.exp(-3 * 0.25 / 29)             # mean of (0.1/0.2)² over 29 joints
    np.testing.assert_allclose(reward.cpu().numpy(),
                               [1.0 + 10.0, math.exp(-math.sin(tilt) ** 2 / 0.2) + 10.0 * pose],
                               rtol=1e-5)
    # the task's tolerances: the standing table for a zero command, the walking one otherwise
    knee = task.joint_names.index("left_knee_joint")
    assert task.pose_std[0, knee] == pytest.approx(0.05)
    assert task.pose_std[1, knee] == pytest.approx(0.35)


def test_g1_single_stance_gait_clock_and_tilt(device):
    """The air-time term pays the single-stance phase's duration (capped at 0.4 s) only with a
    moving command; the gait terms pay each foot whose contact is what the clock wants and
    charge a foot in the air for missing its swing height; a touching foot pays for turning
    about the vertical; a base tilted past maxTilt has fallen and pays the termination term."""
    from myriad.tasks.g1 import compute_g1_reward
    task = make(device, num_envs=3)
    dev, N = task.device, 3
    scales = {k: 0.0 for k in task.reward_scales}
    scales.update(feetAirTimeRewardScale=1.0, terminationRewardScale=-10.0,
                  gaitContactRewardScale=0.5, swingHeightRewardScale=-100.0,
                  feetTwistRewardScale=-1.0)
    base = task.envs.root_states[:, 0].clone()
    base[:, 7:13] = 0
    tilt = 1.2                                      # env 2: tilted about x beyond 1 rad
    base[2, 3:7] = torch.tensor([math.sin(tilt / 2), 0, 0, math.cos(tilt / 2)])
    base[:2, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])
    commands = torch.tensor([[0.5, 0, 0], [0.0, 0, 0], [0.5, 0, 0]], device=dev)
    contact = torch.tensor([[True, False]] * 3, device=dev)
    contact_time = torch.tensor([[0.3, 0.0]] * 3, device=dev)
    air_time = torch.tensor([[0.0, 0.6]] * 3, device=dev)
    # the clock: env 0 left in stance, right in swing (both as wanted); envs 1, 2 the reverse
    gait_stance = torch.tensor([[True, False], [False, True], [False, True]], device=dev)
    foot_z = torch.tensor([[0.03, 0.18]] * 3, device=dev)     # the right foot 0.1 m too high
    zeros = torch.zeros(N, 29, device=dev)
    reward, fell = compute_g1_reward(
        base, commands, zeros, task.default_dof_pos.expand(N, -1), zeros, zeros, zeros,
        zeros, task.default_dof_pos, task.soft_limits, task.deviation_dofs,
        task.envs.net_contact_force * 0, task.bodies_ending, contact, air_time, contact_time,
        torch.zeros(N, 2, 2, device=dev), gait_stance, foot_z, task.gravity_dir,
        task.forward_axis, 0.02, 1.0, 0.08, scales, base[:, 3:7],
        torch.ones(N, 29, device=dev), task.learn, torch.zeros(N, 3, device=dev),
        torch.tensor([[0.4, 2.0]] * 3, device=dev))     # the left foot, touching, twists
    # env 0: in single stance, the phase's time is min(0.3 in contact, 0.6 in the air) = 0.3;
    # both feet as the clock wants (+1.0); the right foot 0.1 m above its swing height (-1.0)
    # each env's touching left foot twists at 0.4 rad/s (-0.4); the right one is in the air
    np.testing.assert_allclose(reward.cpu().numpy(), [0.3 + 1.0 - 1.0 - 0.4, 0.0 - 1.0 - 0.4,
                                                      0.3 - 1.0 - 10.0 - 0.4], atol=1e-5)
    assert fell.tolist() == [False, False, True]


def test_g1_fall_ends_the_episode_and_commands_resample(device):
    task = make(device, num_envs=2, **{"env.commands.resample_s": 0.1,
                                       "env.commands.standing": 0.0})
    states = task.envs.root_states.clone()
    states[0, 0, 3:7] = torch.tensor([math.sin(0.8), 0.0, 0.0, math.cos(0.8)])  # 1.6 rad
    task.envs.set_root_states(states)
    _, _, resets, extras = task.step(torch.zeros(2, 29, device=task.device))
    assert resets.tolist() == [1, 0] and extras["time_outs"].tolist() == [0, 0]
    before = task.commands.clone()
    for _ in range(5):                             # resample_s 0.1: every 5 steps
        task.step(torch.zeros(2, 29, device=task.device))
    assert not torch.equal(before[1], task.commands[1])
    assert torch.all(task.commands[:, 0] >= 0) and torch.all(task.commands[:, 0] <= 1)


def test_g1_sole_torsional_friction_is_condim_4_on_the_eight_sole_spheres(device):
    """`env.soleTorsionalFriction` (m) gives the sole spheres, and only them, MuJoCo's condim 4
    with that torsional coefficient: the contacts then have four rows (the default keeps
    three); a negative value is refused naming the key."""
    task = make(device, num_envs=1, **{"env.soleTorsionalFriction": 0.03})
    model = task.build_scene().compose()[0].compile()
    spun = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, model.geom_bodyid[g])
            for g in range(model.ngeom) if model.geom_condim[g] == 4]
    assert sorted(set(spun)) == ["g1/left_ankle_roll_link", "g1/right_ankle_roll_link"]
    assert len(spun) == 8
    assert np.allclose(model.geom_friction[model.geom_condim == 4, 1], 0.03)
    assert task.envs.sim.device_model.layout.contact_width == 4
    assert make(device, num_envs=1).envs.sim.device_model.layout.contact_width == 3
    with pytest.raises(ValueError, match="env.soleTorsionalFriction: -0.01 m must be >= 0"):
        make(device, num_envs=1, **{"env.soleTorsionalFriction": -0.01})


def test_g1_config_errors_name_the_joint():
    from myriad.tasks.g1 import by_pattern
    assert by_pattern(["left_knee_joint", "waist_yaw_joint"],
                      {".*_knee_joint": 1.0, "waist_.*": 2.0}, "gains") == [1.0, 2.0]
    with pytest.raises(ValueError, match="env.control.gains: no entry matches joint "
                                         "'left_hip_pitch_joint'"):
        by_pattern(["left_hip_pitch_joint"], {".*_knee_joint": [200.0, 5.0]},
                   "env.control.gains")


def test_g1_mirror_image_is_the_robots_own(device):
    """The task's left-right mirror (symmetry augmentation's `mirror_observations`,
    `mirror_actions`): a state and its mirror image through the x-z plane, set in two envs,
    put every body where the other's twin is with y flipped, and give observations that
    `mirror_observations` maps one onto the other."""
    task = make(device, num_envs=2)
    e, dev = task.envs, task.device
    gen = torch.Generator().manual_seed(3)

    def rand(*shape, scale=1.0):
        return ((torch.rand(*shape, generator=gen) * 2 - 1) * scale).to(dev)
    flip = torch.tensor([1.0, -1.0, 1.0], device=dev)
    axial = torch.tensor([-1.0, 1.0, -1.0], device=dev)       # ω, and a quaternion's x, y, z
    states = e.root_states.clone()
    quat = torch.nn.functional.normalize(torch.cat((rand(3, scale=0.3),
                                                    torch.ones(1, device=dev))), dim=0)
    states[0, 0, :3] = torch.tensor([0.3, 0.2, 0.9], device=dev)
    states[0, 0, 3:7], states[0, 0, 7:10], states[0, 0, 10:13] = quat, rand(3), rand(3)
    states[1, 0, :3] = states[0, 0, :3] * flip
    states[1, 0, 3:6], states[1, 0, 6] = quat[:3] * axial, quat[3]
    states[1, 0, 7:10], states[1, 0, 10:13] = states[0, 0, 7:10] * flip, \
        states[0, 0, 10:13] * axial
    index, sign = task.joint_mirror()
    pos = task.default_dof_pos + rand(29, scale=0.3)
    vel = rand(29, scale=2.0)
    e.set_root_states(states, forward=False)
    e.set_dof_state(torch.stack((pos, sign * pos[index])),
                    torch.stack((vel, sign * vel[index])))
    # the bodies (not the world): each one's twin (the other side's body of the same name)
    # where it is, mirrored
    names = [e.model.mj_model.body(b).name for b in range(1, e.model.mj_model.nbody)]
    twin = [names.index(n.replace("left_", "@").replace("right_", "left_")
                        .replace("@", "right_")) for n in names]
    body = e.rigid_body_states
    torch.testing.assert_close(body[1, twin, :3], body[0, :, :3] * flip, atol=1e-5, rtol=0)
    # the observations: commands, last actions and the gait clock mirrored too (the other
    # foot's phase: half the 0.8 s period, 20 steps, later)
    task.commands[:] = torch.stack((torch.tensor([0.6, 0.3, -0.7], device=dev),
                                    torch.tensor([0.6, -0.3, 0.7], device=dev)))
    actions = rand(29)
    task.actions[:] = torch.stack((actions, sign * actions[index]))
    task.progress_buf[:] = torch.tensor([7, 27], device=dev)
    obs = task.observations()
    torch.testing.assert_close(task.mirror_observations(obs[:1])[0], obs[1], atol=1e-5, rtol=0)
    torch.testing.assert_close(task.mirror_actions(task.actions[:1])[0], task.actions[1])
    # a mirror twice is the identity
    torch.testing.assert_close(task.mirror_observations(task.mirror_observations(obs)), obs)
    assert sorted(index.tolist()) == list(range(29)) and (index[index] == torch.arange(
        29, device=dev)).all()


def test_symmetry_augmentation_adds_each_minibatchs_mirror_image(tmp_path, capsys):
    """`train.params.config.symmetry=true`: each minibatch holds its rows and then their
    mirror images, with the same advantages; a task with no mirror has no such key."""
    from myriad import cli
    from myriad.rl import agent as agent_module

    seen = {}
    prepare = agent_module.MyriadAgent.prepare_dataset

    def keep(self, batch_dict):
        prepare(self, batch_dict)
        seen.update(values={k: v.clone() for k, v in self.dataset.values_dict.items()
                            if v is not None}, rows=self.minibatch_size,
                    task=self.vec_env.env, dataset=(len(self.dataset),
                                                    self.dataset.minibatch_size))
    import unittest.mock
    with unittest.mock.patch.object(agent_module.MyriadAgent, "prepare_dataset", keep):
        assert cli.main(["train", "task=G1Velocity", "device=cpu", "num_envs=8",
                         "max_iterations=1", f"train_dir={tmp_path}",
                         "train.params.config.minibatch_size=64",
                         "train.params.config.symmetry=true"]) == 0
    values, rows, task = seen["values"], seen["rows"], seen["task"]
    batch = 8 * 24
    assert values["obs"].shape == (2 * batch, 101)
    assert seen["dataset"] == (batch // rows, 2 * rows)        # as many minibatches, twice the rows
    first = slice(0, rows)
    twin = slice(rows, 2 * rows)
    torch.testing.assert_close(values["obs"][twin], task.mirror_observations(values["obs"][first]))
    torch.testing.assert_close(values["actions"][twin],
                               task.mirror_actions(values["actions"][first]))
    torch.testing.assert_close(values["sigma"][twin],
                               task.mirror_actions(values["sigma"][first]).abs())
    for key in ("advantages", "returns", "old_logp_actions", "old_values"):
        torch.testing.assert_close(values[key][twin], values[key][first])
    assert cli.main(["train", "task=Ant", "device=cpu", "num_envs=8", "max_iterations=1",
                     f"train_dir={tmp_path}", "train.params.config.symmetry=true"]) == 2
    assert "no key train.params.config.symmetry" in capsys.readouterr().err


def test_g1_rough_heights_and_curriculum(device):
    """G1Rough: the 140 heights read the terrain under the base as AnymalTerrain's do, and a
    robot that walked off its tile starts its next episode a level up (the shared curriculum)."""
    task = myriad.make("G1Rough", num_envs=2, device=device, **{"env.learn.addNoise": False})
    assert task.obs_buf.shape == (2, 241)
    # its mirror reads each height at the point mirrored through the x-z plane
    from myriad.tasks.terrain import height_points
    index, sign = task.observation_mirror()
    points = height_points(device)
    torch.testing.assert_close(points[index[101:] - 101], points * torch.tensor(
        [1.0, -1.0, 1.0], device=device))
    assert (sign[101:] == 1).all() and len(index) == 241
    base = task.envs.root_states[:, 0]
    expected = torch.clamp(base[:, 2:3] - 0.5 - task.terrain_heights(base), -1, 1) * 5.0
    np.testing.assert_allclose(task.obs_buf[:, 101:].cpu().numpy(), expected.cpu().numpy(),
                               atol=1e-6)
    # at the start every robot stands over its tile's start point
    np.testing.assert_allclose((base[:, :2] - task.env_origins[:, :2]).abs().max().item(), 0.25,
                               atol=0.26)
    states = task.envs.root_states.clone()
    states[0, 0, :2] = task.env_origins[0, :2] + torch.tensor([5.0, 0.0], device=task.device)
    task.envs.set_root_states(states)
    task.move_levels = True
    done = torch.tensor([True, False], device=task.device)
    task.commands[:] = torch.tensor([[0.5, 0, 0], [0.5, 0, 0]], device=task.device)
    task.reset_idx(done)
    assert task.levels.tolist() == [1, 0]
    assert task.metrics() == {"terrain_level": 0.5}
    np.testing.assert_allclose(task.env_origins[0].cpu().numpy(),
                               task.tile_origins[1, task.kinds[0]].cpu().numpy())
