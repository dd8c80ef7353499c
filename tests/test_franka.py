"""FrankaCubeStack (issue 14): observation layouts, reward terms against hand-computed values,
the operational-space law, the physics the task stands on (a grasped cube lifted without
slipping, a cube standing on the other) and a training smoke run. Needs example-robot-data (the
`.[arms]` extra): skipped without it."""

import importlib.util
import json
import math

import mujoco
import pytest
import torch

import myriad
from myriad import cli
from myriad.tasks.franka import TABLE_TOP, compute_franka_reward, osc_torques
from myriad.torch_utils import quat_conjugate, quat_mul

pytestmark = pytest.mark.skipif(importlib.util.find_spec("cmeel") is None,
                                reason="example-robot-data (myriad[arms]) is not installed")

SCALES = dict(distRewardScale=0.1, liftRewardScale=1.5, alignRewardScale=2.0,
              stackRewardScale=16.0)


@pytest.fixture(scope="module")
def task():
    return myriad.make("FrankaCubeStack", num_envs=2)


def test_observations_hold_the_cubes_the_grip_point_and_the_fingers(task):
    e = task.envs
    obs = task.reset()["obs"]
    assert obs.shape == (2, 19) and task.num_actions == 7
    a, b = e.root_states[:, task.cube_a], e.root_states[:, task.cube_b]
    grip = e.sim.site_pose[:, task.sites[0]]
    torch.testing.assert_close(obs[:, 0:4], a[:, 3:7])
    torch.testing.assert_close(obs[:, 4:7], a[:, 0:3])
    torch.testing.assert_close(obs[:, 7:10], b[:, 0:3] - a[:, 0:3])
    torch.testing.assert_close(obs[:, 10:17], grip)
    torch.testing.assert_close(obs[:, 17:19], e.dof_pos[:, 7:9])
    # resets: both cubes on the table, apart, turned about z only; the fingers at 3.5 cm
    assert torch.allclose(a[:, 2], torch.tensor(TABLE_TOP + 0.025), atol=1e-4)
    assert torch.allclose(b[:, 2], torch.tensor(TABLE_TOP + 0.035), atol=1e-4)
    assert ((a[:, 0:2] - b[:, 0:2]).norm(dim=-1) >= 0.12 * math.sqrt(2) - 1e-6).all()  # 0.17
    assert torch.allclose(a[:, 3:5], torch.zeros(2, 2), atol=1e-6)
    assert torch.allclose(e.dof_pos[:, 7:9], torch.full((2, 2), 0.035), atol=1e-5)
    # the grip point lies between the two fingertips, 0.1025 m along the hand's z
    tips = e.sim.site_pose[:, task.sites[1:], 0:3]
    assert (grip[:, 0:3] - tips.mean(dim=1)).norm(dim=-1).max() < 0.01


def test_success_rate_waits_for_num_envs_finished_episodes(task):
    """One early stacked episode alone does not read as a success rate of 1."""
    task.metrics()
    task.shares.finished += 1
    task.shares.counts["success_rate"] += 1
    before = task.metrics()["success_rate"]
    task.shares.finished += 1            # num_envs (2) episodes finished: one stacked
    assert before != 1.0 and task.metrics() == {"success_rate": 0.5, "lift_rate": 0.0}


def test_joint_torque_control_observes_every_joint():
    task = myriad.make("FrankaCubeStack", num_envs=1, **{"env.controlType": "joint_tor"})
    obs = task.reset()["obs"]
    assert obs.shape == (1, 26) and task.num_actions == 8
    torch.testing.assert_close(obs[:, 17:26], task.envs.dof_pos)
    with pytest.raises(ValueError, match="controlType"):
        myriad.make("FrankaCubeStack", num_envs=1, **{"env.controlType": "ik"})


def _reward(a, b, grip, tips=None):
    grip = torch.tensor([grip])
    left, right = (grip, grip) if tips is None else (torch.tensor([tips[0]]),
                                                    torch.tensor([tips[1]]))
    return compute_franka_reward(torch.tensor([a]), torch.tensor([b]), grip, left, right,
                                 0.05, 0.07, **SCALES)


def test_reward_terms_against_hand_computed_values():
    z_a, z_b = TABLE_TOP + 0.025, TABLE_TOP + 0.035
    # reaching: the cube on the table, the grip point 10 cm above it, the tips 10 and 12 cm away
    r, stacked, lifted = _reward([0.1, 0.0, z_a], [-0.1, 0.0, z_b], [0.1, 0.0, z_a + 0.1],
                                 tips=([0.1, 0.0, z_a + 0.1], [0.1, 0.12, z_a]))
    assert not stacked and not lifted
    assert r.item() == pytest.approx(0.1 * (1 - math.tanh(10 * (0.1 + 0.1 + 0.12) / 3)), rel=1e-5)
    # held (reach 1) and lifted 10 cm, 5 cm beside where it should sit on B:
    # 0.1 + lift 1.5 + align 2·(1 - tanh(10·|offset|))
    a = [-0.1 + 0.05, 0.0, z_a + 0.1]
    r, stacked, lifted = _reward(a, [-0.1, 0.0, z_b], a)
    align = 1 - math.tanh(10 * math.dist([-0.1, 0.0, z_b + 0.06], a))
    assert lifted and not stacked
    assert r.item() == pytest.approx(0.1 + 1.5 + 2.0 * align, rel=1e-5)
    # the same cube let go, the gripper 30 cm away: the align term stands in for reach
    far = [a[0], a[1], a[2] + 0.3]
    r, _, _ = _reward(a, [-0.1, 0.0, z_b], far)
    assert 1 - math.tanh(10 * 0.3) < align
    assert r.item() == pytest.approx(0.1 * align + 1.5 + 2.0 * align, rel=1e-5)
    # stacked, the gripper gone: 16; the gripper still on it: not yet stacked
    on_b = [-0.1, 0.005, z_b + 0.06]
    r, stacked, _ = _reward(on_b, [-0.1, 0.0, z_b], [-0.1, 0.0, z_b + 0.2])
    assert stacked and r.item() == 16.0
    r, stacked, _ = _reward(on_b, [-0.1, 0.0, z_b], on_b)
    assert not stacked and r.item() < 16.0


def test_operational_space_law_produces_the_commanded_acceleration(task):
    """From rest, with no gravity and no contact, τ of `osc_torques` accelerates the hand at
    kp·Δpose (linear and angular) within 1 %; the null-space term adds none."""
    e = task.envs
    model = e.model
    sim = myriad.Simulator(model, num_envs=1, cpu_threads=1,
                           params=myriad.SimParams(dt=1e-4, gravity=(0.0, 0.0, 0.0)))
    q = task.q_rest.clone()
    q[[1, 3, 5]] += torch.tensor([0.2, -0.3, 0.25])    # away from the rest pose: null space on
    sim.q[0, e._dof_q] = q
    sim.ctrl[:] = q[7:9]                                # finger drives at their positions
    sim.forward()
    hand = task.hand
    arm = e.dof_columns[:7]
    jacobian = sim.body_jacobians()[:, hand, :, arm]
    mass = sim.mass_matrix[:, arm][:, :, arm]
    dpose = torch.tensor([[0.02, -0.01, 0.015, 0.1, -0.05, 0.08]])
    tau = osc_torques(dpose, torch.zeros(1, 6), jacobian, mass, q[None, :7],
                      torch.zeros(1, 7), task.q_rest[None, :7], kp=150.0, kd=2 * math.sqrt(150),
                      kp_null=10.0, kd_null=2 * math.sqrt(10))
    sim.joint_force[:, arm] = tau
    sim.step()
    accel = sim.body_vel[0, hand] / 1e-4
    wanted = 150.0 * dpose[0]
    for part in (slice(0, 3), slice(3, 6)):        # linear (m/s²), angular (rad/s²)
        error = (accel[part] - wanted[part]).norm() / wanted[part].norm()
        assert error < 0.01, (part, accel, wanted)


DOWN = torch.tensor([1.0, 0.0, 0.0, 0.0])      # the hand pointing down, fingers along y (xyzw)


def test_the_controller_survives_singular_matrices():
    """A rank-deficient Jacobian (a kinematic singularity) gives finite torques; a mass matrix
    that cannot be inverted gives none, instead of an exception that stops training."""
    jacobian = torch.eye(6, 7).expand(2, 6, 7).clone()
    jacobian[:, 5] = 0.0                               # one task direction lost
    mass = torch.eye(7).expand(2, 7, 7).clone()
    mass[1] = 0.0
    tau = osc_torques(torch.ones(2, 6), torch.zeros(2, 6), jacobian, mass, torch.zeros(2, 7),
                      torch.zeros(2, 7), torch.zeros(2, 7), kp=150.0, kd=24.5, kp_null=10.0,
                      kd_null=6.3)
    assert torch.isfinite(tau).all()
    torch.testing.assert_close(tau[0, :5], torch.full((5,), 150.0), rtol=1e-4, atol=0)
    assert (tau[1] == 0).all()


def _move(task, target, gripper: float, steps: int):
    """Drive the grip point toward `target` (env coordinates), the hand pointing down, with the
    task's own actions (Δpose = the remaining error, at most the command limit)."""
    for _ in range(steps):
        grip = task.envs.sim.site_pose[:, task.sites[0]]
        turn = quat_mul(DOWN.expand_as(grip[:, 3:7]), quat_conjugate(grip[:, 3:7]))
        turn = turn * torch.where(turn[:, 3:4] < 0, -1.0, 1.0)          # the short way round
        vector = turn[:, 0:3]
        angle = 2 * torch.atan2(vector.norm(dim=-1, keepdim=True), turn[:, 3:4])
        rotation = vector / vector.norm(dim=-1, keepdim=True).clamp(min=1e-9) * angle
        dpose = torch.cat(((target - grip[:, 0:3]) / 0.1, rotation / 0.5), dim=-1)
        actions = torch.cat((torch.clamp(dpose, -1.0, 1.0),
                             torch.full((task.num_envs, 1), gripper)), dim=-1)
        task.step(actions)


def test_the_arm_has_no_damping_and_the_fingers_only_their_drives(task):
    """The original writes its DOF damping over the URDF's 0.3: 0 on the torque-driven arm and
    the finger drives' 100 (Isaac Gym's one damping per DOF), so the joints keep none."""
    mj = task.envs.model.mj_model
    hinges = [j for j in range(mj.njnt) if mj.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE]
    assert len(hinges) == 9 and (mj.dof_damping[mj.jnt_dofadr[hinges]] == 0).all()
    drives = [a for a in range(mj.nu) if mj.actuator_biasprm[a, 2] != 0]
    assert len(drives) == 2 and (-mj.actuator_biasprm[drives, 2] == 100.0).all()


def test_a_grasped_cube_is_lifted_20_cm_without_slipping():
    """The task's OSC and gripper: down over cube A, close, lift 20 cm and hold; the cube keeps
    its place in the gripper (< 5 mm over 3 s) and the episode's lift reward is earned."""
    task = myriad.make("FrankaCubeStack", num_envs=1, **{
        "env.episodeLength": 100000, "env.frankaDofNoise": 0.0, "env.startRotationNoise": 0.0})
    task.reset()
    roots = task.envs.root_states.clone()
    roots[:, task.cube_a, 0:2] = torch.tensor([0.1, -0.05])      # in reach, clear of cube B
    roots[:, task.cube_b, 0:2] = torch.tensor([-0.1, 0.2])
    task.envs.set_root_states(roots)
    cube = roots[:, task.cube_a, 0:3].clone()
    # over the cube's centre, down to it
    _move(task, cube + torch.tensor([0.0, 0.0, 0.1]), 1.0, 90)
    _move(task, cube, 1.0, 90)
    _move(task, cube, -1.0, 30)                                        # close
    _move(task, cube + torch.tensor([0.0, 0.0, 0.2]), -1.0, 90)        # lift 20 cm
    grip = task.envs.sim.site_pose[:, task.sites[0], 0:3]
    held = task.envs.root_states[:, task.cube_a, 0:3] - grip
    assert task.envs.root_states[0, task.cube_a, 2] > TABLE_TOP + 0.025 + 0.15
    _move(task, cube + torch.tensor([0.0, 0.0, 0.2]), -1.0, 180)      # hold for 3 s
    grip = task.envs.sim.site_pose[:, task.sites[0], 0:3]
    slip = (task.envs.root_states[:, task.cube_a, 0:3] - grip - held).norm()
    assert slip < 0.005, f"the cube slipped {slip * 1000:.1f} mm in the gripper"
    assert task.rew_buf[0] >= 1.5                                      # lifted
    assert task.lifted_ever[0], "lifted in the gripper: counted for lift_rate"


def test_the_fingers_close_at_the_urdfs_speed_limit():
    """The fingers keep example-robot-data's 0.2 m/s limit, as Isaac Gym applies it: from open
    to closed (0.04 m each) takes about 0.2 s, not one physics step."""
    task = myriad.make("FrankaCubeStack", num_envs=1, **{"env.episodeLength": 1000})
    task.reset()
    open_ = torch.zeros(1, 7)
    open_[:, 6] = 1.0
    for _ in range(20):
        task.step(open_)
    gap = [float(task.envs.dof_pos[0, 7])]
    for _ in range(15):                                    # 0.25 s of closing
        task.step(-open_)
        gap.append(float(task.envs.dof_pos[0, 7]))
    speeds = [(a - b) / task.dt for a, b in zip(gap, gap[1:])]
    assert gap[0] > 0.039 and gap[-1] < 0.002, gap
    assert max(speeds) < 0.2 * 1.05, f"finger speed {max(speeds):.3f} m/s > 0.2"


def test_a_noisy_scripted_grasp_lifts_the_cube_in_most_envs():
    """Reach for cube A, close when the grip point is at its centre, lift: with N(0, 0.5²) noise
    on every action (the exploration a policy starts with is N(0, 1)) the cube is lifted in the
    gripper in most of 32 envs within 400 steps. Fingers that snapped shut in one step (no speed
    limit) knocked the cube away: 4 of the 32 envs lifted it."""
    torch.manual_seed(0)
    task = myriad.make("FrankaCubeStack", num_envs=32, **{"env.episodeLength": 1000})
    task.reset()
    e = task.envs
    for _ in range(400):
        cube = e.root_states[:, task.cube_a, 0:3]
        grip = task.grip_poses()[:, 0, 0:3]
        near = (cube - grip).norm(dim=-1)
        closed = e.dof_pos[:, 7:9].sum(dim=-1) < 0.06
        target = cube + torch.tensor([0.0, 0.0, 0.3]) * ((near < 0.02) & closed)[:, None]
        actions = torch.zeros(32, 7)
        actions[:, 0:3] = torch.clamp((target - grip) / 0.1, -1.0, 1.0)
        actions[:, 6] = torch.where(near < 0.015, -1.0, 1.0)
        task.step(torch.clamp(actions + 0.5 * torch.randn_like(actions), -1.0, 1.0))
    assert task.lifted_ever.float().mean() > 0.6, task.lifted_ever.float().mean()


def test_a_cube_set_on_the_other_stands_still_for_10_s(task):
    """Cube A resting on cube B at the task's settings, the arm away: < 1 mm drift in 10 s."""
    e = task.envs
    task.reset()
    roots = e.root_states.clone()
    roots[:, task.cube_b, 0:3] = torch.tensor([0.3, 0.3, TABLE_TOP + 0.035])
    roots[:, task.cube_a, 0:3] = torch.tensor([0.3, 0.3, TABLE_TOP + 0.07 + 0.025])
    for cube in (task.cube_a, task.cube_b):
        roots[:, cube, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])
        roots[:, cube, 7:13] = 0.0
    e.set_root_states(roots)
    start = e.root_states[:, task.cube_a, 0:3].clone()
    e.set_dof_efforts(torch.zeros(2, 9))
    for _ in range(600):
        e.step()
    drift = (e.root_states[:, task.cube_a, 0:3] - start).norm(dim=-1).max()
    assert drift < 1e-3, f"cube A drifted {drift * 1000:.2f} mm on cube B"


def test_a_stack_ends_the_episode_and_the_time_limit_is_a_time_out():
    """A stack is a termination; the 300-step limit (3 here) is reported in `time_outs`, so PPO
    bootstraps it (the observation has no clock to tell the critic that the end is near)."""
    task = myriad.make("FrankaCubeStack", num_envs=2, **{"env.episodeLength": 3})
    task.reset()
    e = task.envs
    roots = e.root_states.clone()       # env 1: cube A set on cube B, the gripper far away
    roots[1, task.cube_b, 0:3] = torch.tensor([0.3, 0.3, TABLE_TOP + 0.035])
    roots[1, task.cube_a, 0:3] = torch.tensor([0.3, 0.3, TABLE_TOP + 0.07 + 0.025])
    for cube in (task.cube_a, task.cube_b):
        roots[1, cube, 3:7] = torch.tensor([0.0, 0.0, 0.0, 1.0])
        roots[1, cube, 7:13] = 0.0
    e.set_root_states(roots)
    task.metrics()
    _, reward, resets, extras = task.step(torch.zeros(2, 7))
    assert resets.tolist() == [0, 1] and extras["time_outs"].tolist() == [0, 0]
    assert reward[1].item() == 16.0
    for _ in range(2):
        _, _, resets, extras = task.step(torch.zeros(2, 7))
    assert resets.tolist() == [1, 0] and extras["time_outs"].tolist() == [1, 0]
    assert task.metrics()["success_rate"] == 0.5


def test_training_smoke_run_reports_the_success_and_lift_rates(tmp_path):
    args = ["train", "task=FrankaCubeStack", "num_envs=16", "max_iterations=2",
            f"train_dir={tmp_path}", "experiment=franka", "train.params.config.minibatch_size=64"]
    assert cli.main(args) == 0
    summary = json.loads((tmp_path / "franka" / "summary.json").read_text())
    assert summary["epochs"] == 2 and summary["env_steps"] == 16 * 32 * 2
    assert 0.0 <= summary["success_rate"] <= 1.0 and 0.0 <= summary["lift_rate"] <= 1.0
