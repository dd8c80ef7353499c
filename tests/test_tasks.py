"""Tasks: `myriad.make`, VecTask semantics, and the Ant observation and reward against values
computed by hand from set states."""

import math

import pytest
import torch

import myriad
from myriad.tasks.ant import compute_ant_reward


@pytest.fixture(scope="module")
def ant(device):
    return myriad.make("Ant", num_envs=2, device=device)


def test_make_rejects_unknown_tasks_and_keys():
    with pytest.raises(KeyError, match=r"unknown task 'Ants'; the tasks are \[.*'Ant', "):
        myriad.make("Ants")
    with pytest.raises(KeyError, match="no config key 'episodeLen'.*episodeLength"):
        myriad.make("Ant", num_envs=2, episodeLen=10)
    with pytest.raises(KeyError, match="no config key 'sim.dtt'"):
        myriad.make("Ant", num_envs=2, **{"sim.dtt": 0.01})
    with pytest.raises(ValueError, match="env.episodeLength=0: must be >= 1"):
        myriad.make("Ant", num_envs=2, episodeLength=0)


def test_ant_spaces_and_reset(ant):
    assert (ant.num_obs, ant.num_actions, ant.num_states) == (60, 8, 0)
    assert ant.observation_space.shape == (60,) and ant.action_space.shape == (8,)
    obs = ant.reset()["obs"]
    assert obs.shape == (2, 60) and obs.device == ant.device
    torch.testing.assert_close(obs[:, 0].cpu(), torch.full((2,), 0.62))
    # reset noise keeps the joints inside their limits and differs between envs
    assert torch.all(obs[:, 12:20].abs() <= 1.0) and not torch.equal(obs[0, 12:20], obs[1, 12:20])
    assert torch.all(obs[:, 52:60] == 0), "a new episode starts with zero last actions"
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 8\)"):
        ant.step(torch.zeros(2, 7))


def test_ant_observation_layout_on_a_set_state(ant, device):
    """Set the torso pose and velocity and the joints; check every slot of Table 2's layout."""
    e = ant.envs
    yaw = math.radians(30)
    root = torch.zeros(2, 1, 13, device=device)
    root[:, 0, :3] = torch.tensor([1.0, 2.0, 0.5])
    root[:, 0, 3:7] = torch.tensor([0, 0, math.sin(yaw / 2), math.cos(yaw / 2)])
    root[:, 0, 7:10] = torch.tensor([1.0, 0.0, 0.2])
    root[:, 0, 10:13] = torch.tensor([0.0, 0.0, 0.5])
    e.set_root_states(root)
    lower, upper = ant.dof_lower.cpu(), ant.dof_upper.cpu()
    pos = (lower + 0.25 * (upper - lower)).repeat(2, 1)     # a quarter of the way: scaled -0.5
    vel = torch.arange(8.0).repeat(2, 1)
    e.set_dof_state(pos.to(device), vel.to(device))
    ant.actions[:] = torch.linspace(-1, 1, 8, device=device)
    ant.compute_observations()
    obs = ant.obs_buf[0].cpu()

    assert obs[0] == pytest.approx(0.5)
    c, s = math.cos(yaw), math.sin(yaw)
    torch.testing.assert_close(obs[1:4], torch.tensor([c, -s, 0.2]), atol=1e-5, rtol=0)
    torch.testing.assert_close(obs[4:7], torch.tensor([0.0, 0.0, 0.5]), atol=1e-5, rtol=0)
    assert obs[7] == pytest.approx(yaw, abs=1e-5)                       # yaw
    assert obs[8] == pytest.approx(0.0, abs=1e-5)                       # roll
    to_target = torch.tensor([999.0, -2.0])
    assert obs[9] == pytest.approx(math.atan2(-2.0, 999.0) - yaw, abs=1e-5)
    assert obs[10] == pytest.approx(1.0, abs=1e-6)                      # upright
    heading = (c * to_target[0] + s * to_target[1]) / to_target.norm()
    assert obs[11] == pytest.approx(float(heading), abs=1e-5)
    torch.testing.assert_close(obs[12:20], torch.full((8,), -0.5), atol=1e-5, rtol=0)
    torch.testing.assert_close(obs[20:28], torch.arange(8.0) * 0.2, atol=1e-5, rtol=0)
    torch.testing.assert_close(obs[28:52], e.force_sensors[0].reshape(-1).cpu() * 0.1)
    torch.testing.assert_close(obs[52:60], torch.linspace(-1, 1, 8))
    # the potential is minus the horizontal distance to the target per control step
    assert float(ant.potentials[0]) == pytest.approx(-float(to_target.norm()) * 60, rel=1e-5)


def test_ant_reward_terms_by_hand():
    obs = torch.zeros(3, 60)
    obs[:, 0] = torch.tensor([0.6, 0.6, 0.2])           # env 2 has fallen
    obs[:, 10] = torch.tensor([0.95, 0.9, 1.0])         # up projection: 0.95 > 0.93 earns upWeight
    obs[:, 11] = torch.tensor([0.4, 0.9, 1.0])          # heading: 0.4 -> 0.5 * 0.4 / 0.8
    obs[0, 12:20] = torch.tensor([0.995, -0.999, 0.5, 0, 0, 0, 0, 0])   # two joints at a limit
    obs[:, 20:28] = 0.5                                 # scaled dof velocities
    actions = torch.zeros(3, 8)
    actions[0] = torch.tensor([1.0, -1.0, 0.5, 0, 0, 0, 0, 0])
    potentials = torch.tensor([-100.0, -50.0, -10.0])
    prev = torch.tensor([-102.0, -50.0, -10.0])
    reward, terminated = compute_ant_reward(
        obs, actions, potentials, prev, up_weight=0.1, heading_weight=0.5, actions_cost=0.005,
        energy_cost=0.05, joints_at_limit_cost=0.1, termination_height=0.31, death_cost=-2.0)
    progress, alive, up, heading = 2.0, 0.5, 0.1, 0.25
    action_cost = 0.005 * (1 + 1 + 0.25)
    energy = 0.05 * (0.5 * (1 + 1 + 0.5))
    limits = 0.1 * 2
    expected0 = progress + alive + up + heading - action_cost - energy - limits
    assert float(reward[0]) == pytest.approx(expected0, abs=1e-6)
    assert float(reward[1]) == pytest.approx(0.0 + 0.5 + 0.0 + 0.5, abs=1e-6)
    assert float(reward[2]) == pytest.approx(-2.0)
    assert terminated.tolist() == [False, False, True]


def test_time_outs_are_reported_apart_from_terminations(device):
    task = myriad.make("Ant", num_envs=3, device=device, episodeLength=4, terminationHeight=0.0)
    task.reset()
    for step in range(1, 5):
        obs, reward, resets, extras = task.step(torch.zeros(3, 8, device=device))
        assert torch.isfinite(reward).all()
        if step < 4:
            assert resets.sum() == 0 and extras["time_outs"].sum() == 0
    assert resets.tolist() == [1, 1, 1] and extras["time_outs"].tolist() == [1, 1, 1]
    assert task.progress_buf.tolist() == [0, 0, 0]
    # the returned observation already belongs to the next episode
    torch.testing.assert_close(obs["obs"][:, 0].cpu(), torch.full((3,), 0.62))
    # a torso below terminationHeight ends the episode as a termination, not a time-out
    task = myriad.make("Ant", num_envs=2, device=device, terminationHeight=5.0)
    task.reset()
    _, reward, resets, extras = task.step(torch.zeros(2, 8, device=device))
    assert resets.tolist() == [1, 1] and extras["time_outs"].tolist() == [0, 0]
    assert reward.tolist() == [-2.0, -2.0]


def test_humanoid_observation_layout_and_reward_terms(device):
    from myriad.tasks.humanoid import compute_humanoid_reward

    task = myriad.make("Humanoid", num_envs=2, device=device)
    assert (task.num_obs, task.num_actions) == (108, 21)
    e = task.envs
    obs = task.reset()["obs"]
    torch.testing.assert_close(obs[:, 0].cpu(), torch.full((2,), 1.34))
    root = e.root_states.clone()
    root[:, 0, 10:13] = torch.tensor([0.0, 0.0, 2.0], device=device)
    e.set_root_states(root)
    task.actions[:] = 0.5
    task.compute_observations()
    o = task.obs_buf[0].cpu()
    assert o[6] == pytest.approx(2.0 * 0.25, abs=1e-5), "angular velocity × 0.25"
    torch.testing.assert_close(o[33:54], e.dof_vel[0].cpu() * 0.1)
    torch.testing.assert_close(o[54:75], e.dof_forces[0].cpu() * 0.01)
    torch.testing.assert_close(o[75:87], e.force_sensors[0].reshape(-1).cpu() * 0.01)
    assert torch.all(o[87:108] == 0.5)
    # gears: abdomen 67.5, hip_y 135 (the strongest): normalized strengths 0.5 and 1
    strength = task.motor_strength.cpu()
    assert strength.max() == 1.0 and strength[0] == pytest.approx(0.5)

    # reward by hand: two joints past 0.98 of their range, energy weighted by strength
    obs = torch.zeros(2, 108)
    obs[:, 0] = torch.tensor([1.2, 0.5])
    obs[:, 10], obs[:, 11] = 1.0, 1.0
    obs[0, 12] = 0.99             # joint 0 (strength 0.5): 0.25·(0.01/0.02)·0.5
    obs[0, 17] = -1.0             # joint 5 = right_hip_y (strength 1): 0.25·(0.02/0.02)·1
    obs[0, 33] = 0.3              # scaled velocity of joint 0
    actions = torch.zeros(2, 21)
    actions[0, 0] = -1.0
    reward, terminated = compute_humanoid_reward(
        obs, actions, torch.tensor([-10.0, 0.0]), torch.tensor([-10.5, 0.0]), strength,
        alive_reward=2.0, up_weight=0.1, heading_weight=0.5, actions_cost=0.01,
        energy_cost=0.05, joints_at_limit_cost=0.25, termination_height=0.8, death_cost=-1.0)
    expected = (0.5 + 2.0 + 0.1 + 0.5 - 0.01 * 1.0 - 0.05 * 0.3 * 0.5
                - (0.25 * 0.5 * 0.5 + 0.25 * 1.0 * 1.0))
    assert float(reward[0]) == pytest.approx(expected, abs=1e-5)
    assert float(reward[1]) == -1.0 and terminated.tolist() == [False, True]


def test_ingenuity_thrust_observation_and_reward(device):
    from myriad.tasks.ingenuity import compute_ingenuity_reward

    task = myriad.make("Ingenuity", num_envs=3, device=device)
    e = task.envs
    assert (task.num_obs, task.num_actions) == (13, 6)
    assert e.sim.gravity[0, 2].item() == pytest.approx(-3.721)
    obs = task.reset()["obs"]
    root = e.root_states[:, 0]
    torch.testing.assert_close(obs[:, 0:3], (task.targets - root[:, :3]) / 3)
    torch.testing.assert_close(obs[:, 3:7], root[:, 3:7])
    # targets in x, y ∈ [-2.5, 2.5], z ∈ [1, 2]
    assert task.targets[:, :2].abs().max() <= 2.5 and task.targets[:, 2].min() >= 1.0
    # thrust equal to the weight hovers: the height stays put over one second
    mass = float(e.sim.body_mass[0].sum())
    hover = mass * 3.721 / 2 / task.sim_params.dt / 2000.0
    start = e.root_states[:, 0, :3].clone()
    actions = torch.zeros(3, 6, device=device)
    actions[:, [2, 5]] = hover
    for _ in range(100):
        task.step(actions)
    assert (e.root_states[:, 0, :3] - start).abs().max() < 1e-3
    # 10 % more thrust: z rises by ½·(0.1 g)·t² (semi-implicit Euler: ·(1 + dt/t))
    actions[:, [2, 5]] = 1.1 * hover
    start = e.root_states[:, 0, 2].clone()
    task.progress_buf[:] = 1          # keep the targets fixed: no new target at step 500
    for _ in range(100):
        task.step(actions)
    rise = 0.5 * 0.1 * 3.721 * 1.0 * 1.01
    torch.testing.assert_close((e.root_states[:, 0, 2] - start).cpu(), torch.full((3,), rise),
                               rtol=0.01, atol=0)

    # reward by hand
    pos = torch.tensor([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.4]])
    targets = torch.tensor([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    tilt = math.radians(60)           # up_z = 0.5
    quat = torch.tensor([[0, 0, 0, 1.0], [math.sin(tilt / 2), 0, 0, math.cos(tilt / 2)],
                         [0, 0, 0, 1.0]])
    angvel = torch.tensor([[0.0, 0.0, 0.0], [0.0, 0.0, 2.0], [0.0, 0.0, 0.0]])
    reward, terminated = compute_ingenuity_reward(pos, targets, quat, angvel, 5.0, 8.0, 0.5)
    assert float(reward[0]) == pytest.approx(1.0 * (1 + 5.0 + 1.0))
    assert float(reward[1]) == pytest.approx(0.5 * (1 + 5.0 / 1.25 + 1.0 / 5.0), rel=1e-5)
    assert terminated.tolist() == [False, False, True]


def test_make_accepts_a_randomization_section(device):
    task = myriad.make("Ant", num_envs=2, device=device, randomization={
        "enabled": True, "sim_params": {"gravity": {"range": [0.0, 0.5], "operation": "additive",
                                                   "distribution": "gaussian"}}})
    assert task.randomizer is not None
    assert not torch.equal(task.envs.sim.gravity[0], task.envs.sim.gravity[1])


def test_anymal_model_observation_and_reward(device):
    pytest.importorskip("cmeel", reason="ANYmal needs example-robot-data (pip install .[anymal])")
    from myriad.tasks.anymal import compute_anymal_reward

    task = myriad.make("Anymal", num_envs=2, device=device)
    e = task.envs
    assert (task.num_obs, task.num_actions, task.max_episode_length) == (48, 12, 2500)
    assert e.model.body_mass.sum() == pytest.approx(52.13, abs=0.01), "URDF inertias, fused"
    assert e.num_bodies == 13 and e.dof_names[0] == "anymal/LF_HAA"
    # actions are position targets around the default pose, with the config's gains
    actions = torch.zeros(2, 12, device=device)
    actions[:, 1] = 0.4
    task.step(actions)
    torch.testing.assert_close(e.dof_position_targets[0, 1],
                               task.default_dof_pos[1] + 0.2)
    assert float(e.sim.actuator_kp[0, 0]) == 85.0 and float(e.sim.actuator_kv[0, 0]) == 2.0

    # observation on a set state: base turned 90° about z, moving along world y
    root = e.root_states.clone()
    root[:, 0, 3:7] = torch.tensor([0, 0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    root[:, 0, 7:10] = torch.tensor([0.0, 1.0, 0.0])
    root[:, 0, 10:13] = torch.tensor([0.0, 0.0, 0.8])
    e.set_root_states(root)
    task.commands[:] = torch.tensor([1.0, 0.0, 0.4])
    task.compute_observations()
    o = task.obs_buf[0].cpu()
    torch.testing.assert_close(o[0:3], torch.tensor([2.0, 0.0, 0.0]), atol=1e-5, rtol=0)
    torch.testing.assert_close(o[3:6], torch.tensor([0.0, 0.0, 0.2]), atol=1e-5, rtol=0)
    torch.testing.assert_close(o[6:9], torch.tensor([0.0, 0.0, -1.0]), atol=1e-5, rtol=0)
    torch.testing.assert_close(o[9:12], torch.tensor([2.0, 0.0, 0.1]))
    torch.testing.assert_close(o[12:24], (e.dof_pos[0] - task.default_dof_pos).cpu())
    torch.testing.assert_close(o[24:36], e.dof_vel[0].cpu() * 0.05)

    # reward by hand: that state tracks the command exactly except a yaw-rate error of 0.4
    dt = 0.02
    weights = {"linearVelocityXYRewardScale": 1.0 * dt, "angularVelocityZRewardScale": 0.5 * dt,
               "torqueRewardScale": 2e-5 * dt}
    torques = torch.zeros(1, 12)
    torques[0, 0] = 10.0
    contacts = torch.zeros(1, 13, 3)
    reward, terminated = compute_anymal_reward(
        root[:1, 0].cpu(), torch.tensor([[1.0, 0.0, 0.4]]), torques, contacts, 0,
        torch.tensor([2]), weights)
    expected = dt * (1.0 + 0.5 * math.exp(-0.16 / 0.25)) - 2e-5 * dt * 100.0
    assert float(reward[0]) == pytest.approx(expected, rel=1e-5) and not bool(terminated[0])
    contacts[0, 2, 2] = 5.0       # a thigh on the ground ends the episode
    assert bool(compute_anymal_reward(root[:1, 0].cpu(), torch.zeros(1, 3), torques, contacts,
                                      0, torch.tensor([2]), weights)[1][0])
