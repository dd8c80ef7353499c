"""The Shadow Hand task (issue 13): observation layouts, reward terms against hand-computed
values, goal resets and success counting, the hand's physics against MuJoCo, and a training
smoke run. Needs gymnasium-robotics (the `.[hands]` extra): skipped without it."""

import copy
import importlib.util
import json
import math

import mujoco
import numpy as np
import pytest
import torch

import myriad
from myriad import cli
from myriad.tasks.hands import compute_hand_reward
from myriad.torch_utils import quat_from_angle_axis

pytestmark = pytest.mark.skipif(importlib.util.find_spec("gymnasium_robotics") is None,
                                reason="gymnasium-robotics (myriad[hands]) is not installed")

CONSTANTS = dict(distRewardScale=-10.0, rotRewardScale=1.0, rotEps=0.1,
                 actionPenaltyScale=-0.0002, reachGoalBonus=250.0, fallDistance=0.24,
                 fallPenalty=-50.0, successTolerance=0.1)


@pytest.fixture(scope="module")
def hand():
    return myriad.make("ShadowHand", num_envs=2)


def _still(task, cube_pos, cube_quat=(0.0, 0.0, 0.0, 1.0)):
    """Joints at 0, targets at mid-range, the cube at a pose, everything at rest."""
    e = task.envs
    roots = task.initial_root_states.clone()
    roots[:, task.cube, 0:3] = torch.tensor(cube_pos)
    roots[:, task.cube, 3:7] = torch.tensor(cube_quat)
    roots[:, task.cube, 7:13] = 0.0
    e.set_root_states(roots, forward=False)
    e.set_dof_state(torch.zeros(task.num_envs, e.num_dofs), torch.zeros(task.num_envs, e.num_dofs))
    mid = 0.5 * (task.dof_lower + task.dof_upper)[task.actuated]
    e.sim.ctrl[:] = mid
    return mid


def test_full_state_observation_holds_table_10_in_the_originals_order(hand):
    task = hand
    obs = task.reset()["obs"]
    assert obs.shape == (2, 211) and "states" not in task.obs_dict
    actions = torch.linspace(-0.9, 0.9, 40).reshape(2, 20)
    obs = task.step(actions)[0]["obs"]
    e = task.envs
    cube = e.root_states[:, task.cube]
    tips = e.rigid_body_states[:, task.fingertips]
    lo, hi = task.dof_lower, task.dof_upper
    torch.testing.assert_close(obs[:, 0:24], ((2 * e.dof_pos - hi - lo) / (hi - lo)).clamp(-5, 5))
    torch.testing.assert_close(obs[:, 24:48], (0.2 * e.dof_vel).clamp(-5, 5))
    torch.testing.assert_close(obs[:, 72:79], cube[:, 0:7])
    torch.testing.assert_close(obs[:, 85:88], task.goal_pos)
    torch.testing.assert_close(obs[:, 88:92], task.goal_rot)
    torch.testing.assert_close(obs[:, 96:99], tips[:, 0, 0:3])               # ff tip position
    torch.testing.assert_close(obs[:, 148:151], tips[:, 4, 0:3])             # thumb tip
    torch.testing.assert_close(obs[:, 191:211], actions)
    assert obs[:, 161:191].abs().sum() > 0                                  # the tip wrenches


def test_openai_observation_is_table_11_with_the_full_state_for_the_critic():
    task = myriad.make("ShadowHand", num_envs=2, observationType="openai",
                       asymmetric_observations=True)
    out = task.reset()
    assert out["obs"].shape == (2, 42) and out["states"].shape == (2, 211)
    cube = task.envs.root_states[:, task.cube]
    tips = task.envs.rigid_body_states[:, task.fingertips, 0:3]
    torch.testing.assert_close(out["obs"][:, 0:15], tips.reshape(2, 15))
    torch.testing.assert_close(out["obs"][:, 15:18], cube[:, 0:3])
    torch.testing.assert_close(out["states"][:, 72:75], cube[:, 0:3])


def test_reward_terms_against_hand_computed_values():
    goal_pos = torch.tensor([[0.0, -0.39, 0.56]] * 3)
    goal_rot = torch.tensor([[0.0, 0.0, 0.0, 1.0]] * 3)
    x = torch.tensor([[1.0, 0.0, 0.0]] * 3)
    angles = torch.tensor([0.5, 0.05, 0.5])
    cube_rot = quat_from_angle_axis(angles, x)
    cube_pos = goal_pos + torch.tensor([[0.1, 0.0, 0.0], [0.02, 0.0, 0.0], [0.0, 0.3, 0.0]])
    actions = torch.ones(3, 20)
    reward, ends, reached, successes = compute_hand_reward(
        cube_pos, cube_rot, goal_pos, goal_rot, actions, torch.zeros(3), torch.zeros(3),
        600, 0, **CONSTANTS)
    penalty = -0.0002 * 20
    expected = torch.tensor([-10 * 0.1 + 1 / (0.5 + 0.1) + penalty,                 # plain
                             -10 * 0.02 + 1 / (0.05 + 0.1) + penalty + 250,         # success
                             -10 * 0.3 + 1 / (0.5 + 0.1) + penalty - 50])           # fell
    torch.testing.assert_close(reward, expected, rtol=1e-5, atol=1e-5)
    assert reached.tolist() == [False, True, False] and ends.tolist() == [False, False, True]
    assert successes.tolist() == [0.0, 1.0, 0.0]
    # with a limit of consecutive successes: the last success ends the episode; running out
    # of time without one adds half the fall penalty
    reward, ends, _, _ = compute_hand_reward(
        cube_pos[:2], cube_rot[:2], goal_pos[:2], goal_rot[:2], actions[:2],
        torch.tensor([0.0, 49.0]), torch.tensor([600, 10]), 600, 50, **CONSTANTS)
    assert ends.tolist() == [False, True]
    torch.testing.assert_close(reward[0], expected[0] - 25.0)


def test_a_success_draws_a_new_goal_and_finished_episodes_update_the_running_average(hand):
    task = hand
    task.reset()
    e = task.envs
    _still(task, (0.0, -0.36, 0.535))
    task.goal_rot[0] = e.root_states[0, task.cube, 3:7]     # env 0 holds its goal already
    old_goal = task.goal_rot.clone()
    task.step(torch.zeros(2, 20))
    assert task.successes.tolist() == [1.0, 0.0]
    assert not torch.equal(task.goal_rot[0], old_goal[0])    # a new goal for env 0 only
    assert torch.equal(task.goal_rot[1], old_goal[1])
    assert task.reset_buf.tolist() == [0, 0]                 # a success does not end it
    # env 0 runs out of time with its one success: the average moves 0.1 of the way to 1
    before = float(task.consecutive_successes)
    task.progress_buf[0] = task.max_episode_length - 1
    task.step(torch.zeros(2, 20))
    assert float(task.consecutive_successes) == pytest.approx(0.9 * before + 0.1 * 1.0)
    assert task.successes[0] == 0 and task.progress_buf[0] == 0       # a fresh episode


def test_a_cube_dropped_on_the_palm_rests_where_mujoco_puts_it(hand):
    """Mid-range targets, the cube let go 1.5-3 cm above the palm: after 10 s it rests within
    2 cm of MuJoCo C's resting place (5 mm measured; dropped from 6 cm the two tumble into
    different spots 27 mm apart), no more than 2 mm in a finger or the palm, and still."""
    task = hand
    task.reset()
    e = task.envs
    start = (0.01, -0.35, 0.55)
    mid = _still(task, start)
    path, deepest = [], 0.0
    for _ in range(600):
        e.step()
        path.append(e.root_states[0, task.cube, 0:3].clone())
        n = min(int(e.sim.contact_count[0]), e.sim.contact_capacity)
        deepest = min(deepest, float(e.sim.contact_dist[0, :n].min()) if n else 0.0)
    ours = path[-1].numpy()
    mj = copy.deepcopy(e.model.mj_model)
    mj.opt.timestep = task.sim_params.dt / task.sim_params.substeps
    d = mujoco.MjData(mj)
    free = [j for j in range(mj.njnt) if mj.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE][0]
    a = mj.jnt_qposadr[free]
    d.qpos[a:a + 7] = [*start, 1.0, 0.0, 0.0, 0.0]
    d.ctrl[:] = mid.numpy()
    mujoco.mj_step(mj, d, nstep=1200)
    theirs = d.qpos[a:a + 3]
    assert np.linalg.norm(ours - theirs) < 0.02, (ours, theirs)
    assert deepest > -2e-3
    assert (path[-1] - path[300]).norm() < 5e-4             # nothing creeps over the last 5 s


def test_a_finger_pushed_past_its_limit_and_the_coupled_joints(hand):
    """A torque pushing FFJ2 past its upper limit: within 0.01 rad of it. Each distal joint J0
    follows its middle joint J1 through the tendon T_*J1c (L = 0.00705·J0 - 0.00805·J1, range
    ±0.001): with every finger curled to mid-range, L stays within the range plus the small
    stretch of PhysX's limit spring (stiffness 30)."""
    task = hand
    task.reset()
    e = task.envs
    _still(task, (0.3, 0.3, 0.1))                            # the cube out of the way
    ffj2 = e.dof_index("robot0:FFJ2")
    force = torch.zeros(2, e.num_dofs)
    force[:, ffj2] = 0.5                                     # N·m, against the actuator's 0.9 cap
    e.sim.ctrl[:, task.actuated.tolist().index(ffj2)] = task.dof_upper[ffj2]
    worst_limit, worst_tendon = 0.0, 0.0
    for _ in range(120):
        e.set_dof_efforts(force)
        e.step()
        worst_limit = max(worst_limit, float((e.dof_pos[:, ffj2] - task.dof_upper[ffj2]).max()))
        for f in ("FF", "MF", "RF", "LF"):
            j0, j1 = e.dof_index(f"robot0:{f}J0"), e.dof_index(f"robot0:{f}J1")
            length = 0.00705 * e.dof_pos[:, j0] - 0.00805 * e.dof_pos[:, j1]
            worst_tendon = max(worst_tendon, float(length.abs().max()))
    assert worst_limit < 0.01
    assert worst_tendon < 0.001 + 5e-4, worst_tendon


def test_random_targets_stay_finite_and_the_cube_never_flies():
    """The issue's 10,000 steps on 64 envs is `benchmarks/hand_random.py`; here 16 envs for
    600 steps (10 s): every env finite, the cube never faster than 5 m/s."""
    task = myriad.make("ShadowHand", num_envs=16)
    task.reset()
    fastest = 0.0
    for _ in range(600):
        obs = task.step(2 * torch.rand(16, 20) - 1)[0]["obs"]
        assert torch.isfinite(obs).all() and int(task.envs.sim.nonfinite.sum()) == 0
        fastest = max(fastest, float(task.envs.root_states[:, task.cube, 7:10].norm(dim=-1).max()))
    assert fastest < 5.0


def test_shadow_hand_trains_and_reports_consecutive_successes(tmp_path):
    args = ["task=ShadowHand", "device=cpu", "num_envs=32", f"train_dir={tmp_path}",
            "max_iterations=2", "experiment=hand", "train.params.config.minibatch_size=256"]
    assert cli.main(["train", *args]) == 0
    summary = json.loads((tmp_path / "hand" / "summary.json").read_text())
    assert summary["epochs"] == 2 and "consecutive_successes" in summary
    header = (tmp_path / "hand" / "progress.csv").read_text().splitlines()[0]
    assert header.endswith(",consecutive_successes")
    assert math.isfinite(summary["consecutive_successes"])


def test_allegro_observation_is_table_10_without_fingertips():
    """88 values: joint positions, velocities and forces (16 each), cube pose and velocities,
    goal pose, relative rotation, last actions."""
    task = myriad.make("AllegroHand", num_envs=2)
    obs = task.reset()["obs"]
    assert obs.shape == (2, 88) and task.num_actions == 16
    actions = torch.linspace(-0.5, 0.5, 32).reshape(2, 16)
    obs = task.step(actions)[0]["obs"]
    cube = task.envs.root_states[:, task.cube]
    torch.testing.assert_close(obs[:, 48:55], cube[:, 0:7])
    torch.testing.assert_close(obs[:, 61:64], task.goal_pos)
    torch.testing.assert_close(obs[:, 72:88], actions)


def test_allegro_cube_starts_on_the_fingers_where_the_original_lets_it_go():
    """The original lets its cube go over the proximal phalanges, 5.9 cm out along the fingers
    from the middle finger's first joint and 7.0 cm above it (its URDF's kinematics), its goal
    position 4 cm lower. Here too: held straight (targets 0), the fingers keep the cube within
    4 cm of that goal, still (2.3 cm; the original's hand in this engine 2.4 cm,
    benchmarks/allegro_original_hand.py); zero actions target
    mid-range and curl the fingers into a claw that sweeps it toward the palm."""
    task = myriad.make("AllegroHand", num_envs=2, resetPositionNoise=0.0,
                       resetDofPosRandomInterval=0.0)
    task.reset()
    e = task.envs
    bodies = e.rigid_body_states[0, :, 0:3]
    joint = bodies[e.body_index("hand/link_4.0")]
    finger = bodies[e.body_index("hand/link_7.0")] - joint          # straight at the reset
    finger = finger / finger.norm()
    offset = task.cube_start_pos - joint
    along = offset @ finger
    assert abs(along - 0.059) < 0.002 and abs((offset - along * finger).norm() - 0.070) < 0.002
    straight = 2 * (0 - task.dof_lower) / (task.dof_upper - task.dof_lower) - 1
    actions = torch.stack([straight.clamp(-1, 1), torch.zeros(16)])   # env 0 flat, env 1 zero
    path = []
    for _ in range(60):                                        # 2 s at 30 Hz
        task.step(actions)
        path.append(e.root_states[:, task.cube, 0:3].clone())
    flat, clawed = path[-1][0], path[29][1]
    assert (flat - task.goal_pos[0]).norm() < 0.04
    assert (path[-1][0] - path[-31][0]).norm() < 1e-3            # still over the last second
    assert clawed[1] - task.cube_start_pos[1] > 0.05            # 1 s: > 5 cm toward the palm (+y)


def test_allegro_fingers_are_damped_once_by_their_drives():
    """Isaac Gym has one damping per DOF, the position drive's gain (the original's 0.1): the
    joints keep none of their own, and a step of the targets to three quarters of each joint's
    range is 70 % done in 0.1 s on the fingers' flexion joints with the speed caps lifted (here
    0.73, the fingers touching each other; with the damping counted twice, drive and joint,
    0.43 over all joints). With the URDF's 7 rad/s caps on, no joint turns faster."""
    task = myriad.make("AllegroHand", num_envs=1)
    task.reset()
    mj = task.envs.model.mj_model
    drives = [a for a in range(mj.nu) if mj.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT]
    dofs = [mj.jnt_dofadr[mj.actuator_trnid[a, 0]] for a in drives]
    assert len(dofs) == 16 and (mj.dof_damping[dofs] == 0).all()
    assert np.allclose(-mj.actuator_biasprm[drives, 2], task.cfg["env"]["control"]["damping"])
    e = task.envs
    start = e.dof_pos[0].clone()
    target = task.dof_lower + 0.75 * (task.dof_upper - task.dof_lower)
    caps = e.sim.dof_max_velocity[0, e.dof_columns].clone()
    assert torch.allclose(caps, torch.full((16,), 7.0))          # the URDF's speed limits
    e.sim.dof_max_velocity[:, e.dof_columns] = 100.0             # PhysX's default: the drive alone
    for _ in range(6):                                         # 0.1 s at dt 1/60
        e.set_dof_position_targets(target[None].contiguous())
        e.step()
        e.refresh()
    # the three fingers' flexion joints: the spread joints and the thumb's first two are swung
    # by the curling fingers' reactions and blocked by their neighbours
    flexion = [1, 2, 3, 5, 6, 7, 9, 10, 11]
    done = ((e.dof_pos[0] - start) / (target - start))[flexion]
    assert done.median() > 0.7 and done.max() < 1.1, done
    # with the caps the same step is slower: no joint turns faster than 7 rad/s
    e.sim.dof_max_velocity[:, e.dof_columns] = caps
    e.set_dof_state(start[None], torch.zeros(1, 16))
    fastest = 0.0
    for _ in range(6):
        e.set_dof_position_targets(target[None].contiguous())
        e.step()
        e.refresh()
        fastest = max(fastest, float(e.dof_vel[0].abs().max()))
    assert 6.0 < fastest < 7.0 * 1.01, fastest


@pytest.mark.parametrize("name", ["ShadowHandOpenAI_FF", "ShadowHandOpenAI_LSTM"])
def test_the_openai_variants_build_randomized_and_step(name):
    """Their configs: 20 Hz, moving average 0.3, tolerance 0.4, 50 successes at most, Table 15's
    randomization with random cube forces; the actor sees 42 values, the critic 211."""
    task = myriad.make(name, num_envs=4)
    assert (task.control_freq_inv, task.moving_average, task.max_consecutive_successes) == (3, 0.3, 50)
    assert task.rewards["successTolerance"] == 0.4 and task.rewards["fallPenalty"] == -50.0
    assert task.randomizer is not None and task.randomizer.forces is not None
    out = task.reset()
    for _ in range(10):
        out = task.step(2 * torch.rand(4, 20) - 1)[0]
    assert out["obs"].shape == (4, 42) and out["states"].shape == (4, 211)
    assert torch.isfinite(out["obs"]).all() and torch.isfinite(out["states"]).all()
