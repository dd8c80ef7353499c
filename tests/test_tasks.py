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
    with pytest.raises(KeyError, match=r"unknown task 'Ants'; the tasks are \['Ant'"):
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
