"""Unitree G1: a 29-DOF humanoid tracks commanded planar and yaw velocities (issue 40, item 3).

Not in the seed: built in the style of the ANYmal tasks and of the peers' G1 velocity tasks
(Isaac Lab's G1 flat, mjlab, MuJoCo Playground), which train it with PD position targets and
these kinds of terms. The robot is example-robot-data's G1 (`myriad.assets.g1_spec`: meshes
replaced by fitted capsules, 5 mm spheres at the sole's corners as the feet, armature 0.01).

Actions (29): position-drive targets, target = actionScale × action + default joint angle, with
the drives' gains per joint group (`control.gains`: hips 150/5, knees and waist 200/5, ankles
40/2, arms 40/10 N·m/rad and N·m·s/rad) and the URDF's effort limits.
Commands: vx ~ U(commands.linear_x), vy ~ U(commands.linear_y), yaw rate ~ U(commands.yaw),
drawn at reset and every `commands.resample_s`; a share `commands.standing` of draws is zero.

Observation (101):
    [0:3]    base linear velocity, base frame, × linearVelocityScale (2)
    [3:6]    base angular velocity, base frame, × angularVelocityScale (0.25)
    [6:9]    gravity direction in the base frame (unit vector)
    [9:12]   commands (vx, vy, yaw rate) × (2, 2, 0.25)
    [12:41]  joint angles - default angles
    [41:70]  joint velocities × dofVelocityScale (0.05)
    [70:99]  last actions
    [99:101] the gait clock: sin, cos of 2π·phase, phase = (time in the episode / gait.period_s)
             mod 1
  plus uniform noise ± the config's noise × the same scales, each step (commands and actions
  have none).
Reward, each term × dt (0.02 s), scales and widths in `env.learn` (no clipping). As committed,
run 1's terms (Isaac Lab's G1 flat; the best of three CPU hours, docs/results.md) and run 12's
twist term:
    +1.0·exp(−|v*_xy − v_xy|²/0.25), v_xy in the yaw frame   +1.0·exp(−(ω*_z − ω_z)²/0.25)
    −0.2·v_z²  −0.05·|ω_xy|²  −1.0·|g_xy|² (base tilt)
    −2e-6·Στ²  −1e-7·Σq̈²  −0.005·Σ(a − a_prev)²  −1.0·Σ(distance beyond the soft limits)
    +0.75·min(time in the current single-stance phase, 0.4 s), when |v*_xy| > 0.1
    −0.1·Σ_feet |v_foot,xy| while the foot touches the ground (sliding)
    −0.3·Σ_feet |ω_foot,z| while the foot touches the ground (twisting; rad/s): a foot on one
      or two of its 5 mm sole spheres pivots about the vertical, which the ankle's velocity
      does not show (run 12, which met the yaw bar, added it)
    −0.1·Σ|q − q0| over hip yaw and roll, waist, arms (stay near the default pose)
    −200 when the episode ends in a fall.
  At scale 0 as committed (set in the YAML to use them):
    mjlab's whole-body angular momentum, −|L|² (kg²·m⁴/s², about the robot's centre of mass,
      `Envs.angular_momentum`): the legs' swing must be countered by the arms, not the pelvis;
    mjlab's (run 3): exp(−|g_xy|²/0.2) of the torso (upright) and exp(−mean_j((q_j −
      q0_j)²/std_j²)) (pose), std_j from `poseStd`'s standing (0.05 rad), walking or running
      table by the command's |v*_xy| + |ω*_z|;
    Unitree's (run 2): Σ_feet [foot touching = the gait clock has it in stance] (the left foot
      in stance for the first stanceShare 0.55 of each 0.8 s period, the right half a period
      later), −Σ_feet (z_foot − 0.08 m)² while the foot is in the air, an alive bonus.
An episode ends in a fall when the pelvis or torso touches the ground (|F| > 1 N) or the base
tilts more than `env.maxTilt` rad; otherwise after episodeLength_s = 20 s. Every `pushInterval_s`
(one clock for all envs) every base is pushed: v_xy set to U(−pushVelocity, pushVelocity).
Each robot's friction is one of `frictionBuckets` values in `frictionRange` (env i: i mod B).
The sole spheres have no torsional friction (condim 3, as the peers' G1 feet); a positive
`soleTorsionalFriction` (m) gives them MuJoCo's condim 4 with it (docs/results.md: it stops the
stance feet pivoting, not the yaw error).
"""

from __future__ import annotations

import math
import re

import mujoco
import torch

from ..api import Scene
from ..assets import g1_spec
from ..torch_utils import env_mask, quat_from_angle_axis, quat_rotate, quat_rotate_inverse, \
    where_rows
from .base import VecTask
from .terrain import TerrainCurriculum, height_points


def by_pattern(names: list[str], table: dict, what: str) -> list:
    """Each name's value in `table`, whose keys are regular expressions matched in order; a
    ValueError names a joint that none matches."""
    values = []
    for name in names:
        value = next((v for pattern, v in table.items() if re.fullmatch(pattern, name)), None)
        if value is None:
            raise ValueError(f"{what}: no entry matches joint {name!r} (keys are regular "
                             f"expressions: {list(table)})")
        values.append(value)
    return values


class G1Velocity(VecTask):
    num_obs = 101
    num_actions = 29
    checkpointed = ("steps_taken",)     # the push clock

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        control_dt = cfg["sim"]["dt"] * env.get("controlFrequencyInv", 1)
        env["episodeLength"] = round(env["episodeLength_s"] / control_dt)
        self.learn = env["learn"]
        self.action_scale = env["control"]["actionScale"]
        super().__init__(cfg, device)
        e, dev, N = self.envs, self.device, self.num_envs
        self.joint_names = [n.split("/", 1)[1] for n in e.dof_names]
        self.default_dof_pos = torch.tensor(
            by_pattern(self.joint_names, dict(env["defaultJointAngles"]) | {".*": 0.0},
                       "env.defaultJointAngles"), device=dev)
        self.deviation_dofs = torch.tensor(
            [i for i, n in enumerate(self.joint_names)
             if re.fullmatch(env["learn"]["deviationJoints"], n)], device=dev)
        limits = e.dof_limits()[0]
        middle, half = limits.mean(-1), 0.5 * (limits[:, 1] - limits[:, 0])
        soft = env["learn"]["softLimitFactor"]
        self.soft_limits = torch.stack((middle - soft * half, middle + soft * half), -1)
        self.bodies_ending = torch.tensor([e.body_index(f"g1/{n}") for n in ("pelvis",
                                                                            "torso_link")],
                                          device=dev)
        self.torso = e.body_index("g1/torso_link")
        pose = self.learn["poseStd"]
        # [3, 29]: each joint's tolerance standing, walking, running (rad)
        self.pose_std = torch.tensor([by_pattern(self.joint_names, dict(pose[regime]),
                                                 f"env.learn.poseStd.{regime}")
                                      for regime in ("standing", "walking", "running")],
                                     device=dev)
        self.pose_thresholds = (pose["walkingThreshold"], pose["runningThreshold"])
        self.feet = torch.tensor([e.body_index(f"g1/{side}_ankle_roll_link")
                                  for side in ("left", "right")], device=dev)
        self.reward_scales = {k: v * self.dt for k, v in self.learn.items()
                              if k.endswith("RewardScale")}

        self.draw_robot_friction(env["frictionRange"], env["frictionBuckets"])

        self.commands = torch.zeros(N, 3, device=dev)          # vx, vy, yaw rate
        self.command_scale = torch.tensor([self.learn["linearVelocityScale"]] * 2
                                          + [self.learn["angularVelocityScale"]], device=dev)
        self.resample_every = max(1, round(env["commands"]["resample_s"] / self.dt))
        self.last_actions = torch.zeros(N, self.num_actions, device=dev)
        self.last_dof_vel = torch.zeros(N, self.num_actions, device=dev)
        self.feet_air_time = torch.zeros(N, 2, device=dev)
        self.feet_contact_time = torch.zeros(N, 2, device=dev)
        self.no_angular_momentum = torch.zeros(N, 3, device=dev)   # (read only)
        self.gravity_dir = torch.tensor([0.0, 0.0, -1.0], device=dev).expand(N, 3)
        self.forward_axis = torch.tensor([1.0, 0.0, 0.0], device=dev).expand(N, 3)
        self.up_axis = torch.tensor([0.0, 0.0, 1.0], device=dev).expand(N, 3)
        self.noise_scale = self._noise_scale()
        gait = env["gait"]
        self.gait_period, self.stance_share = gait["period_s"], gait["stanceShare"]
        self.leg_offsets = torch.tensor([0.0, gait["rightOffset"]], device=dev)
        self.push_every = max(1, round(env["pushInterval_s"] / self.dt))
        self.steps_taken = torch.zeros((), dtype=torch.int64, device=dev)
        self.initial_root_states = e.root_states.clone()
        # the left-right mirror as signed permutations (symmetry augmentation)
        self.action_mirror = self.joint_mirror()
        self.obs_mirror = self.observation_mirror()
        self.init_state()
        self.reset()

    def init_state(self) -> None:
        """State a variant adds once the envs exist, before the first reset."""

    # ------------------------------------------------------------------ symmetry
    def joint_mirror(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The joints' left-right mirror image, as a signed permutation ([29] index, [29] sign:
        mirrored q[:, i] = sign[i] · q[:, index[i]]): each joint's twin is the other side's joint
        of the same name (the waist's its own); roll and yaw angles change sign through the
        base's x-z plane, pitch angles do not (`tests/test_g1.py` checks it against the
        model's kinematics)."""
        twin = {"left_": "right_", "right_": "left_"}
        index, sign = [], []
        for name in self.joint_names:
            side = next((s for s in twin if name.startswith(s)), None)
            other = name if side is None else twin[side] + name[len(side):]
            index.append(self.joint_names.index(other))
            sign.append(-1.0 if re.search(r"_(roll|yaw)_", name) else 1.0)
        return (torch.tensor(index, device=self.device),
                torch.tensor(sign, device=self.device))

    def observation_mirror(self) -> tuple[torch.Tensor, torch.Tensor]:
        """The observation's mirror image (the module docstring's layout) as a signed
        permutation: y of the linear velocity, gravity and command flips, x and z of the
        angular velocity (an axial vector) and the yaw command flip, the joint entries as
        `joint_mirror`, and the gait clock moves half a period (the other foot's phase)."""
        joints, joint_sign = self.joint_mirror()
        n = self.num_actions
        index = [torch.arange(12, device=self.device)] + [12 + k * n + joints for k in range(3)] \
            + [torch.tensor([12 + 3 * n, 13 + 3 * n], device=self.device)]
        sign = [torch.tensor([1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, 1.0, -1.0, -1.0],
                             device=self.device)] + [joint_sign] * 3 \
            + [torch.tensor([-1.0, -1.0], device=self.device)]
        return torch.cat(index), torch.cat(sign)

    def mirror_observations(self, obs: torch.Tensor) -> torch.Tensor:
        """[B, num_obs] -> the observations of the mirrored robot (`observation_mirror`)."""
        index, sign = self.obs_mirror
        return obs[:, index] * sign

    def mirror_actions(self, actions: torch.Tensor) -> torch.Tensor:
        """[B, 29] -> the mirrored robot's actions (drive targets about a mirror-symmetric
        default pose: `joint_mirror`)."""
        index, sign = self.action_mirror
        return actions[:, index] * sign

    def _noise_scale(self) -> torch.Tensor:
        """Half-width of the uniform noise on each observation entry (scaled units)."""
        learn, level = self.learn, self.learn["noiseLevel"] * float(self.learn["addNoise"])
        n = self.num_actions
        parts = [(3, learn["linearVelocityNoise"] * learn["linearVelocityScale"]),
                 (3, learn["angularVelocityNoise"] * learn["angularVelocityScale"]),
                 (3, learn["gravityNoise"]), (3, 0.0),
                 (n, learn["dofPositionNoise"]),
                 (n, learn["dofVelocityNoise"] * learn["dofVelocityScale"]),
                 (n, 0.0), (2, 0.0)]
        return torch.cat([torch.full((k,), s * level) for k, s in parts]).to(self.device)

    def add_floor(self, scene: Scene, env: dict) -> Scene:
        return scene.add_ground(friction=env["plane"]["staticFriction"],
                                restitution=env["plane"]["restitution"])

    def create_envs(self):
        return self.build_scene().build(self.num_envs, self.device, self.sim_params)

    def build_scene(self) -> Scene:
        """One env: the floor and the G1 with its drives (MuJoCo can compile it too)."""
        env = self.cfg["env"]
        spec = g1_spec()
        torsion = float(env.get("soleTorsionalFriction", 0.0))
        if torsion < 0:
            raise ValueError(f"env.soleTorsionalFriction: {torsion} m must be >= 0")
        if torsion > 0:
            for geom in spec.geoms:      # the feet: the only spheres on the ankle roll links
                if geom.type == mujoco.mjtGeom.mjGEOM_SPHERE and "ankle_roll" in geom.parent.name:
                    geom.condim = 4
                    geom.friction = [geom.friction[0], torsion, geom.friction[2]]
        names = [j.name for j in spec.joints if j.type != 0]     # 0: the free joint
        gains = by_pattern(names, env["control"]["gains"], "env.control.gains")
        scene = self.add_floor(Scene(), env)
        scene.add_actor("g1", spec, pos=tuple(env["baseInitState"]["pos"]), quat=(0, 0, 0, 1),
                        self_collisions=False, dof_mode="position",
                        stiffness=[g[0] for g in gains], damping=[g[1] for g in gains])
        return scene

    # ------------------------------------------------------------------ step
    def pre_physics_step(self, actions):
        self.actions[:] = actions
        self.envs.set_dof_position_targets(self.action_scale * actions + self.default_dof_pos)

    def post_physics_step(self):
        e = self.envs
        self.steps_taken += 1
        due = self.steps_taken % self.push_every == 0
        if self.runs(due):
            self.push_robots(due)
        # drawn every step and kept where due: cheaper than asking whether any env is due
        resample = (self.progress_buf % self.resample_every == 0) & (self.progress_buf > 0)
        self.commands[:] = where_rows(resample, self.draw_commands(), self.commands)
        contact = e.net_contact_force[:, self.feet, 2] > 1.0
        self.feet_air_time[:] = torch.where(contact, 0.0, self.feet_air_time + self.dt)
        self.feet_contact_time[:] = torch.where(contact, self.feet_contact_time + self.dt, 0.0)
        torques = e.sim.dof_actuator_force[:, e.dof_columns]
        # each leg's phase; a leg is due on the ground in the first stanceShare of its cycle
        stance = torch.remainder(self.gait_phase()[:, None] + self.leg_offsets, 1.0) \
            < self.stance_share
        # each env's pose tolerance by how fast it is told to move (standing, walking, running)
        speed = torch.norm(self.commands[:, :2], dim=-1) + self.commands[:, 2].abs()
        regime = (speed >= self.pose_thresholds[0]).long() + (speed >= self.pose_thresholds[1])
        self.rew_buf[:], terminated = compute_g1_reward(
            e.root_states[:, 0], self.commands, torques, e.dof_pos, e.dof_vel,
            self.last_dof_vel, self.actions, self.last_actions, self.default_dof_pos,
            self.soft_limits, self.deviation_dofs, e.net_contact_force, self.bodies_ending,
            contact, self.feet_air_time, self.feet_contact_time,
            e.rigid_body_states[:, self.feet, 7:9], stance, e.rigid_body_states[:, self.feet, 2],
            self.gravity_dir, self.forward_axis, self.dt, self.cfg["env"]["maxTilt"],
            self.cfg["env"]["gait"]["swingHeight"], self.reward_scales,
            e.rigid_body_states[:, self.torso, 3:7], self.pose_std[regime], self.learn,
            self.angular_momentum(), e.rigid_body_states[:, self.feet, 12])
        self.reset_buf[:] = terminated.long()
        self.episode_outcomes["fell"] = terminated
        self.last_actions[:] = self.actions
        self.last_dof_vel[:] = e.dof_vel
        self.compute_observations()

    def angular_momentum(self) -> torch.Tensor:
        """[N, 3] the robot's about its centre of mass, or zeros while its term's scale is 0
        (as committed: not worth the per-body pass each step)."""
        if self.reward_scales["angularMomentumRewardScale"] == 0.0:
            return self.no_angular_momentum
        return self.envs.angular_momentum("g1")

    def push_robots(self, due: torch.Tensor):
        """Every base's v_xy set to U(−pushVelocity, pushVelocity) where `due` (a bool scalar
        on the device) says it is time."""
        states = self.envs.root_states.clone()
        push = self.cfg["env"]["pushVelocity"]
        states[:, 0, 7:9] = torch.empty(self.num_envs, 2, device=self.device).uniform_(-push,
                                                                                        push)
        self.envs.set_root_states(states, due.expand(self.num_envs))

    def draw_commands(self) -> torch.Tensor:
        """[N, 3] fresh commands for every env (the caller keeps those it needs)."""
        c, n, dev = self.cfg["env"]["commands"], self.num_envs, self.device
        commands = torch.stack([torch.empty(n, device=dev).uniform_(*c[key])
                                for key in ("linear_x", "linear_y", "yaw")], dim=-1)
        moving = torch.rand(n, device=dev) >= c["standing"]
        return commands * moving[:, None]

    def gait_phase(self) -> torch.Tensor:
        """[N] the gait clock, in [0, 1): the share of the period since the episode began."""
        return torch.remainder(self.progress_buf * (self.dt / self.gait_period), 1.0)

    def observations(self) -> torch.Tensor:
        e, learn = self.envs, self.learn
        return compute_g1_observations(
            e.root_states[:, 0], self.commands * self.command_scale, e.dof_pos,
            self.default_dof_pos, e.dof_vel, self.gravity_dir, self.actions, self.gait_phase(),
            learn["linearVelocityScale"], learn["angularVelocityScale"],
            learn["dofVelocityScale"])

    def compute_observations(self):
        obs = self.observations()
        self.obs_buf[:] = obs + (2.0 * torch.rand_like(obs) - 1.0) * self.noise_scale

    # ------------------------------------------------------------------ reset
    def start_states(self, done: torch.Tensor) -> torch.Tensor:
        """[N, actors, 13] root states to start the envs `done` from (their yaw is drawn
        after): the initial pose."""
        return self.initial_root_states.clone()

    def reset_idx(self, env_ids):
        done, n, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        e = self.envs
        states = self.start_states(done)
        yaw = torch.empty(n, device=dev).uniform_(-math.pi, math.pi)
        states[:, 0, 3:7] = quat_from_angle_axis(yaw, self.up_axis)
        e.set_root_states(states, done, forward=False)
        pos = self.default_dof_pos * torch.empty(n, self.num_actions, device=dev).uniform_(0.5,
                                                                                           1.5)
        e.set_dof_state(pos, torch.zeros(n, self.num_actions, device=dev), done)
        self.commands[:] = where_rows(done, self.draw_commands(), self.commands)
        for buf in (self.actions, self.last_actions, self.last_dof_vel, self.feet_air_time,
                    self.feet_contact_time):
            buf.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)


def compute_g1_observations(base_state, commands_scaled, dof_pos, default_dof_pos, dof_vel,
                            gravity_dir, actions, phase, lin_vel_scale, ang_vel_scale,
                            dof_vel_scale):
    quat = base_state[:, 3:7]
    return torch.cat((
        quat_rotate_inverse(quat, base_state[:, 7:10]) * lin_vel_scale,
        quat_rotate_inverse(quat, base_state[:, 10:13]) * ang_vel_scale,
        quat_rotate_inverse(quat, gravity_dir),
        commands_scaled,
        dof_pos - default_dof_pos,
        dof_vel * dof_vel_scale,
        actions,
        torch.sin(2 * math.pi * phase)[:, None],
        torch.cos(2 * math.pi * phase)[:, None],
    ), dim=-1)


def compute_g1_reward(base_state, commands, torques, dof_pos, dof_vel, last_dof_vel, actions,
                      last_actions, default_dof_pos, soft_limits, deviation_dofs,
                      contact_forces, bodies_ending, foot_contact, air_time, contact_time,
                      foot_vel_xy, gait_stance, foot_z, gravity_dir, forward_axis, dt, max_tilt,
                      swing_height, scales, torso_quat, pose_std, kernels, angular_momentum,
                      foot_yaw_rate):
    """The module docstring's terms (each scale already × dt); returns (reward, fell).
    `gait_stance` [N, 2]: whether the gait clock has each foot on the ground; `foot_z` [N, 2] the
    ankle roll links' heights; `gravity_dir`, `forward_axis` [N, 3]: world -z and +x;
    `torso_quat` [N, 4]; `pose_std` [N, dofs]: each joint's pose tolerance (rad); `kernels`:
    the widths σ² of the exponential terms (`env.learn`'s ...Sigma2); `angular_momentum` [N, 3]
    the robot's about its centre of mass (kg·m²/s); `foot_yaw_rate` [N, 2] the ankle roll links'
    angular velocity about the world vertical (rad/s)."""
    quat = base_state[:, 3:7]
    lin_vel = quat_rotate_inverse(quat, base_state[:, 7:10])
    ang_vel = quat_rotate_inverse(quat, base_state[:, 10:13])
    gravity = quat_rotate_inverse(quat, gravity_dir)
    # the base's velocity in its yaw frame: heading without the tilt
    forward = quat_rotate(quat, forward_axis)
    heading = torch.atan2(forward[:, 1], forward[:, 0])
    cos, sin = torch.cos(heading), torch.sin(heading)
    v = base_state[:, 7:9]
    v_yaw = torch.stack((cos * v[:, 0] + sin * v[:, 1], -sin * v[:, 0] + cos * v[:, 1]), -1)
    lin_error = torch.sum((commands[:, :2] - v_yaw) ** 2, dim=-1)
    yaw_error = (commands[:, 2] - base_state[:, 12]) ** 2
    torso_tilt = torch.sum(quat_rotate_inverse(torso_quat, gravity_dir)[:, :2] ** 2, dim=-1)
    pose_error = torch.mean(((dof_pos - default_dof_pos) / pose_std) ** 2, dim=-1)

    single_stance = foot_contact.sum(-1) == 1
    in_mode = torch.where(foot_contact, contact_time, air_time)
    single_stance_time = torch.clamp(
        torch.where(single_stance[:, None], in_mode, 0.0).min(-1).values, max=0.4) \
        * (torch.norm(commands[:, :2], dim=-1) > 0.1)
    beyond = (torch.clamp(dof_pos - soft_limits[:, 1], min=0.0)
              + torch.clamp(soft_limits[:, 0] - dof_pos, min=0.0)).sum(-1)
    fell = torch.any(torch.norm(contact_forces[:, bodies_ending], dim=-1) > 1.0, dim=-1) \
        | (gravity[:, 2] > -math.cos(max_tilt))
    reward = (torch.exp(-lin_error / kernels["linearVelocitySigma2"])
              * scales["linearVelocityXYRewardScale"]
              + torch.exp(-yaw_error / kernels["angularVelocitySigma2"])
              * scales["angularVelocityZRewardScale"]
              + torch.exp(-torso_tilt / kernels["uprightSigma2"]) * scales["uprightRewardScale"]
              + torch.exp(-pose_error) * scales["poseRewardScale"]
              + lin_vel[:, 2] ** 2 * scales["linearVelocityZRewardScale"]
              + torch.sum(ang_vel[:, :2] ** 2, dim=-1) * scales["angularVelocityXYRewardScale"]
              + torch.sum(angular_momentum ** 2, dim=-1) * scales["angularMomentumRewardScale"]
              + torch.sum(gravity[:, :2] ** 2, dim=-1) * scales["orientationRewardScale"]
              + torch.sum(torques ** 2, dim=-1) * scales["torqueRewardScale"]
              + torch.sum(((dof_vel - last_dof_vel) / dt) ** 2, dim=-1)
              * scales["jointAccRewardScale"]
              + torch.sum((actions - last_actions) ** 2, dim=-1) * scales["actionRateRewardScale"]
              + beyond * scales["jointLimitRewardScale"]
              + single_stance_time * scales["feetAirTimeRewardScale"]
              + torch.sum(torch.norm(foot_vel_xy, dim=-1) * foot_contact, dim=-1)
              * scales["feetSlideRewardScale"]
              + torch.sum(foot_yaw_rate.abs() * foot_contact, dim=-1)
              * scales["feetTwistRewardScale"]
              + torch.sum((dof_pos - default_dof_pos)[:, deviation_dofs].abs(), dim=-1)
              * scales["jointDeviationRewardScale"]
              + (foot_contact == gait_stance).sum(-1) * scales["gaitContactRewardScale"]
              + torch.sum((foot_z - swing_height) ** 2 * ~foot_contact, dim=-1)
              * scales["swingHeightRewardScale"]
              + scales["aliveRewardScale"]
              + fell * scales["terminationRewardScale"])
    return reward, fell


class G1Rough(TerrainCurriculum, G1Velocity):
    """The G1 on the AnymalTerrain grid of tiles (`myriad.tasks.terrain`: slopes, rough slopes,
    stairs, obstacles; 10 levels) with its level curriculum, reading the terrain's 140 heights
    around the base as AnymalTerrain does. The G1Velocity task otherwise (commands, drives,
    rewards, pushes, friction); a robot starts `baseInitState.height` above its tile's start
    point, x and y ± `baseInitState.xyNoise`.

    Observation (241): G1Velocity's 101, then
        [101:241]  terrain heights, clip(z_base − 0.5 − h, −1, 1) × heightMeasurementScale (5),
                  at `terrain.height_points()` (14 × 10 points around the base, turned with
                  its yaw), noise ± heightMeasurementNoise × the scale.
    Metric: `terrain_level`, the mean level of the envs.
    """
    num_obs = 241
    checkpointed = ("steps_taken", "levels")     # push clock; terrain levels

    def __init__(self, cfg: dict, device: str = "cpu"):
        self.init_terrain(cfg["env"])
        super().__init__(cfg, device)

    def init_state(self) -> None:
        self.init_levels(self.cfg["env"])

    def add_floor(self, scene: Scene, env: dict) -> Scene:
        return self.add_terrain(scene, env)

    def _noise_scale(self) -> torch.Tensor:
        learn = self.learn
        level = learn["noiseLevel"] * float(learn["addNoise"])
        heights = torch.full((len(height_points()),), learn["heightMeasurementNoise"]
                             * learn["heightMeasurementScale"] * level)
        return torch.cat((super()._noise_scale(), heights.to(self.device)))

    def observation_mirror(self) -> tuple[torch.Tensor, torch.Tensor]:
        """G1Velocity's, then each height read at its point's mirror image (y negated) among
        `terrain.height_points`."""
        index, sign = super().observation_mirror()
        points = height_points(self.device)
        mirrored = points * torch.tensor([1.0, -1.0, 1.0], device=self.device)
        grid = torch.cdist(mirrored, points).argmin(-1)
        return torch.cat((index, G1Velocity.num_obs + grid)), \
            torch.cat((sign, torch.ones(len(points), device=self.device)))

    def observations(self) -> torch.Tensor:
        base = self.envs.root_states[:, 0]
        heights = torch.clamp(base[:, 2:3] - 0.5 - self.terrain_heights(base), -1.0, 1.0)
        return torch.cat((super().observations(),
                          heights * self.learn["heightMeasurementScale"]), dim=-1)

    def start_states(self, done: torch.Tensor) -> torch.Tensor:
        """Over each env's tile (moved by the curriculum first)."""
        self.next_origins(done, torch.norm(self.commands[:, :2], dim=-1))
        states = self.envs.root_states.clone()
        start = self.cfg["env"]["baseInitState"]
        states[:, 0] = self.start_root_states(start["height"], start["xyNoise"])
        return states
