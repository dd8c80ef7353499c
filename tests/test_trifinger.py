"""Trifinger (issue 14): observation and critic layouts, reward terms against hand-computed
values, resets, success counting, the arena's wall, a fingertip pressing the cube into the
floor with full torque, and a training smoke run. Needs robot-properties-fingers (the `.[arms]`
extra): skipped without it."""

import importlib.util
import json
import math

import pytest
import torch

import myriad
from myriad import cli
from myriad.tasks.trifinger import (TRIFINGER_ARENA_RADIUS, compute_trifinger_reward,
                                    cube_corners, logistic_kernel)
from myriad.torch_utils import quat_from_angle_axis, quat_mul, rotation_angle

pytestmark = pytest.mark.skipif(importlib.util.find_spec("robot_properties_fingers") is None,
                                reason="robot-properties-fingers (myriad[arms]) is not installed")

WEIGHTS = dict(fingerMovePenalty=-0.5, fingerReachObjectRate=-250.0, poseWeight=2000.0,
               keypointsKernelScale=30.0, positionKernelScale=50.0)
CUBE = 0.065
SPAWN = TRIFINGER_ARENA_RADIUS - CUBE * math.sqrt(3) / 2     # 0.1387 m


def plain(num_envs=4, **env):
    """The task without domain randomization (exact observations, nominal physics)."""
    return myriad.make("Trifinger", num_envs=num_envs, **{"randomization.enabled": False},
                       **{f"env.{k}": v for k, v in env.items()})


@pytest.fixture(scope="module")
def task():
    return plain()


def test_observations_and_critic_states_follow_tables_12_and_13(task):
    e = task.envs
    obs = task.reset()
    o, s = obs["obs"], obs["states"]
    assert o.shape == (4, 41) and s.shape == (4, 113) and task.num_actions == 9
    lower = torch.tensor([-0.33, 0.0, -2.7] * 3)
    upper = torch.tensor([1.0, 1.57, 0.0] * 3)
    torch.testing.assert_close(o[:, 0:9], (2 * e.dof_pos - upper - lower) / (upper - lower))
    torch.testing.assert_close(o[:, 9:18], e.dof_vel / 10.0)
    cube = e.root_states[:, task.cube]
    bounds = torch.tensor([0.3, 0.3, 0.3])
    low = torch.tensor([-0.3, -0.3, 0.0])
    torch.testing.assert_close(o[:, 18:21], (2 * cube[:, 0:3] - bounds - low) / (bounds - low))
    torch.testing.assert_close(o[:, 21:25], cube[:, 3:7])
    torch.testing.assert_close(o[:, 25:28], (2 * task.goal_pos - bounds - low) / (bounds - low))
    torch.testing.assert_close(o[:, 28:32], task.goal_rot)
    torch.testing.assert_close(o[:, 32:41], task.actions)
    # the critic: the same 41, the cube's velocities, the fingertips' states, torques, wrenches
    torch.testing.assert_close(s[:, 0:41], o)
    torch.testing.assert_close(s[:, 41:47], cube[:, 7:13])
    tips = e.rigid_body_states[:, task.fingertips].reshape(4, 39)
    torch.testing.assert_close(s[:, 47:86], tips.clamp(-5, 5))
    torch.testing.assert_close(s[:, 86:95], e.dof_forces.clamp(-5, 5))
    wrenches = e.force_sensors[:, task.fingertip_sensors].reshape(4, 18)
    torch.testing.assert_close(s[:, 95:113], wrenches.clamp(-5, 5))


def test_resets_put_the_fingers_home_and_the_cube_and_goal_in_the_arena():
    t = plain(num_envs=256)
    t.reset()
    e = t.envs
    torch.testing.assert_close(e.dof_pos, torch.tensor([0.0, 0.9, -2.0] * 3).expand(256, 9))
    cube = e.root_states[:, t.cube]
    assert (cube[:, 0:2].norm(dim=-1) <= SPAWN + 1e-6).all()
    assert torch.allclose(cube[:, 2], torch.tensor(CUBE / 2 + 0.0015), atol=1e-5)
    assert torch.allclose(cube[:, 3:5], torch.zeros(256, 2), atol=1e-6)   # turned about z only
    assert (t.goal_pos[:, 0:2].norm(dim=-1) <= SPAWN + 1e-6).all()
    assert (t.goal_pos[:, 2] >= CUBE * math.sqrt(3) / 2 - 1e-6).all()
    assert (t.goal_pos[:, 2] <= 0.1 + 1e-6).all()
    torch.testing.assert_close(t.goal_rot.norm(dim=-1), torch.ones(256))
    # uniform orientations: the angle from identity has mean π/2 + 2/π (1.89 rad) on SO(3)
    assert abs(rotation_angle(t.goal_rot).mean().item() - (math.pi / 2 + 2 / math.pi)) < 0.1


@pytest.mark.parametrize("difficulty", [-1, 1, 2, 3])
def test_the_easier_difficulties_draw_the_originals_goals_and_ignore_orientation(difficulty):
    t = plain(num_envs=256, difficulty=difficulty, episodeLength=3)
    t.reset()
    rest = CUBE / 2
    assert (t.goal_pos[:, 0:2].norm(dim=-1) <= SPAWN + 1e-6).all()
    if difficulty in (-1, 1):                       # on the table
        torch.testing.assert_close(t.goal_pos[:, 2], torch.full((256,), rest))
    elif difficulty == 2:                           # one goal, 5 cm up at the centre
        torch.testing.assert_close(t.goal_pos, torch.tensor([0.0, 0.0, rest + 0.05]).expand(256, 3))
    else:                                           # in the air, up to 0.1 m
        assert (t.goal_pos[:, 2] >= rest - 1e-6).all() and (t.goal_pos[:, 2] <= 0.1 + 1e-6).all()
        assert t.goal_pos[:, 2].std() > 0.01
    angle = rotation_angle(t.goal_rot)
    if difficulty == -1:                            # turned about z only, any angle
        assert torch.allclose(t.goal_rot[:, 0:2], torch.zeros(256, 2), atol=1e-6)
        assert angle.max() > 2.5
    else:
        assert angle.abs().max() < 1e-6
    # success is the position alone: a cube at its goal's position but turned 90° counts
    t.goal_pos[:] = t.envs.root_states[:, t.cube, 0:3]
    t.goal_rot[:] = quat_mul(t.envs.root_states[:, t.cube, 3:7], quat_from_angle_axis(
        torch.full((256,), math.pi / 2), torch.tensor([1.0, 0.0, 0.0]).expand(256, 3)))
    t.metrics()
    for _ in range(t.max_episode_length):
        t.step(torch.zeros(256, 9))
    assert t.metrics()["success_rate"] > 0.95


def test_an_unknown_difficulty_is_named():
    with pytest.raises(ValueError, match="difficulty=5.*4 \\(in the air"):
        plain(difficulty=5)


def test_reward_terms_against_hand_computed_values():
    dt = 0.02
    cube = torch.tensor([[0.0, 0.0, 0.0325]])
    rot = torch.tensor([[0.0, 0.0, 0.0, 1.0]])
    tips = torch.tensor([[[0.1, 0.0, 0.0325], [0.0, 0.1, 0.0325], [-0.1, 0.0, 0.0325]]])

    def reward(tips_now, cube_now, goal_pos, goal_rot, reach=True, form="keypoints"):
        return compute_trifinger_reward(tips_now, tips, cube_now, rot, cube, goal_pos, goal_rot,
                                        dt, torch.tensor(reach), CUBE, form, **WEIGHTS)

    # at the goal, nothing moving: the keypoint term alone, 2000·0.02·K(0) = 10
    torch.testing.assert_close(reward(tips, cube, cube, rot), torch.tensor([10.0]))
    # the paper's form at the goal: 2000·0.02·(K_50(0) + 1/0.01) = 10 + 4000
    torch.testing.assert_close(reward(tips, cube, cube, rot, form="position_rotation"),
                               torch.tensor([4010.0]))
    # the first finger moves 1 cm toward the cube in one step: speed 0.5 m/s costs
    # 0.5·0.25 = 0.125; the distance falls by 1 cm: +250·0.01 = 2.5 (only while reach is on)
    moved = tips.clone()
    moved[0, 0, 0] -= 0.01
    torch.testing.assert_close(reward(moved, cube, cube, rot), torch.tensor([10.0 - 0.125 + 2.5]))
    torch.testing.assert_close(reward(moved, cube, cube, rot, reach=False),
                               torch.tensor([10.0 - 0.125]))
    # the goal 2 cm above: every corner is 2 cm off, 40·K_30(0.02) = 40/(e^0.6 + 2 + e^-0.6)
    goal = cube + torch.tensor([0.0, 0.0, 0.02])
    expected = 40.0 / (math.exp(0.6) + 2 + math.exp(-0.6))
    torch.testing.assert_close(reward(tips, cube, goal, rot), torch.tensor([expected]))
    # the goal turned by 90° about z: each corner lands where its neighbour was, s away
    turned = quat_from_angle_axis(torch.tensor([math.pi / 2]), torch.tensor([[0.0, 0.0, 1.0]]))
    gaps = (cube_corners(cube, rot, CUBE) - cube_corners(cube, turned, CUBE)).norm(dim=-1)
    torch.testing.assert_close(gaps, torch.full((1, 8), CUBE))   # each corner to its neighbour
    torch.testing.assert_close(reward(tips, cube, cube, turned),
                               40.0 * logistic_kernel(torch.tensor([CUBE]), 30.0))
    angle_term = 40.0 / (3 * math.pi / 2 + 0.01)
    torch.testing.assert_close(reward(tips, cube, cube, turned, form="position_rotation"),
                               torch.tensor([10.0 + angle_term]))


def test_success_rate_counts_cubes_at_the_goal_when_episodes_end():
    t = plain(num_envs=4, episodeLength=3)
    t.reset()
    e = t.envs
    t.metrics()
    for _ in range(2):
        t.step(torch.zeros(4, 9))
    # two envs get their goal where their cube is (within 1 cm and 0.2 rad), two far from it
    cube = e.root_states[:, t.cube]
    t.goal_pos[:] = cube[:, 0:3] + torch.tensor([0.01, 0.0, 0.0])
    t.goal_rot[:] = cube[:, 3:7]
    t.goal_pos[2:, 0] += 0.05
    _, _, resets, extras = t.step(torch.zeros(4, 9))    # the third step ends every episode
    assert t.metrics() == {"success_rate": 0.5}
    # as a time-out, which PPO bootstraps (the actor's observation has no clock)
    assert resets.tolist() == [1] * 4 and extras["time_outs"].tolist() == [1] * 4


def test_the_wall_keeps_a_cube_thrown_at_it_inside_the_arena(task):
    """The cube slides at 2.5 m/s toward the wall, along each of 8 directions: the wall's convex
    sectors stop it where the wall stands (0.195 m from the centre below 3.5 cm, less the
    sectors' 1 mm chords): no corner of the cube's lower half passes it."""
    t = plain(num_envs=8)
    e = t.envs
    angles = torch.arange(8) * (2 * math.pi / 8) + 0.1
    direction = torch.stack((torch.cos(angles), torch.sin(angles), torch.zeros(8)), dim=-1)
    roots = e.root_states.clone()
    roots[:, t.cube, 0:3] = direction * 0.1 + torch.tensor([0.0, 0.0, CUBE / 2 + 0.001])
    roots[:, t.cube, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])
    roots[:, t.cube, 7:10] = 2.5 * direction
    roots[:, t.cube, 10:13] = 0.0
    e.set_root_states(roots)
    e.set_dof_state(torch.tensor([0.0, 1.5, -2.7] * 3).expand(8, 9).contiguous(),
                    torch.zeros(8, 9))         # fingers folded up, out of the way
    farthest = torch.zeros(8)
    for _ in range(50):                        # 1 s
        e.step()
        cube = e.root_states[:, t.cube]
        corners = cube_corners(cube[:, 0:3], cube[:, 3:7], CUBE)
        radius = torch.where(corners[..., 2] < 0.035, corners[..., 0:2].norm(dim=-1), 0.0)
        farthest = torch.maximum(farthest, radius.max(dim=1).values)
    assert (farthest < TRIFINGER_ARENA_RADIUS + 0.003).all(), farthest
    assert (farthest > TRIFINGER_ARENA_RADIUS - 0.01).all(), farthest   # it did reach the wall
    assert (e.root_states[:, t.cube, 2] < CUBE).all()                  # and stayed down


def test_a_fingertip_pressing_the_cube_into_the_floor_neither_passes_through_nor_launches_it():
    """Finger 0 brings its tip down onto the cube's top (a task-space spring, 1 s), then pushes
    down with full torque for 3 s (τ = Jᵀ·F along -z, scaled so that its largest joint torque is
    the motors' 0.36 N·m); the other two fingers hold their start pose. The cube neither sinks
    into the table nor is thrown; the fingertip stays on the cube's top face, pressing on it."""
    t = plain(num_envs=1)
    e = t.envs
    home = torch.tensor([0.0, 0.9, -2.0] * 3)
    tip = e.rigid_body_states[0, t.fingertips[0], 0:3].clone()
    roots = e.root_states.clone()
    roots[0, t.cube, 0:3] = torch.tensor([tip[0], tip[1], CUBE / 2])
    roots[0, t.cube, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])
    roots[0, t.cube, 7:13] = 0.0
    e.set_root_states(roots)
    tip_row = e.actor_bodies("robot").index(int(t.fingertips[0]))
    above = torch.tensor([tip[0], tip[1], CUBE + 0.005])
    resting, worst_sink, worst_speed, lowest_tip, pressing = None, 0.0, 0.0, 1.0, 1e9
    for step in range(200):                   # 1 s down, 3 s pressing, at 50 Hz
        jac = e.jacobians("robot")[0, tip_row, 0:3, 0:3]          # finger 0's joints
        p, v = e.rigid_body_states[0, t.fingertips[0], 0:3], e.rigid_body_states[0, t.fingertips[0], 7:10]
        tau = torch.zeros(9)
        if step < 50:
            tau[0:3] = (jac.T @ (20.0 * (above - p) - 1.0 * v)).clamp(-0.36, 0.36)
        else:
            press = jac.T @ torch.tensor([0.0, 0.0, -1.0])
            tau[0:3] = 0.36 * press / press.abs().max()
        tau[3:9] = (5.0 * (home[3:9] - e.dof_pos[0, 3:9]) - 0.1 * e.dof_vel[0, 3:9]).clamp(
            -0.36, 0.36)
        e.set_dof_efforts(tau[None])
        e.step()
        cube = e.root_states[0, t.cube]
        tip_z = float(e.rigid_body_states[0, t.fingertips[0], 2])
        if step == 49:
            resting = tip_z                   # on the cube, before the full push
        if step >= 50:
            worst_sink = max(worst_sink, CUBE / 2 - float(cube[2]))
            worst_speed = max(worst_speed, float(cube[7:10].norm()))
            lowest_tip = min(lowest_tip, tip_z)
            pressing = min(pressing, float(e.net_contact_force[0, t.fingertips[0], 2]))
    assert resting is not None and resting < CUBE + 0.02       # the tip came down onto the cube
    assert worst_sink < 0.002, worst_sink              # not pressed into the table
    assert worst_speed < 0.1, worst_speed              # not thrown
    assert lowest_tip > resting - 0.002, (lowest_tip, resting)   # not through the top face
    assert pressing > 1.0, pressing                    # and pushing on it all along (N)


def test_training_smoke_run_reports_the_success_rate(tmp_path):
    args = ["train", "task=Trifinger", "num_envs=16", "max_iterations=2", f"train_dir={tmp_path}",
            "experiment=trifinger", "train.params.config.minibatch_size=64",
            "train.params.config.central_value_config.minibatch_size=64"]
    assert cli.main(args) == 0
    summary = json.loads((tmp_path / "trifinger" / "summary.json").read_text())
    assert summary["epochs"] == 2 and summary["env_steps"] == 16 * 8 * 2
    assert 0.0 <= summary["success_rate"] <= 1.0
