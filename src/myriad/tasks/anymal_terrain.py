"""ANYmal on rough terrain: velocity tracking over slopes, stairs and obstacles with a curriculum
(seed A.2.2, Tables 5-7 with the terrain's 140 heights; reference task-specs §6).

The terrain (`myriad.tasks.terrain`: 10 levels × 20 kinds of 8 m tiles) is one height field that
every env shares, with vertical risers where a face is steeper than the original's slope
threshold. A robot starts on its tile's platform; at each reset the curriculum moves it a level
up if it walked off its tile, down if it walked less than a quarter of what its command asked.

The robot is the flat task's ANYmal C (`myriad.assets.anymal_c_spec`) colliding as the
original's `anymal_minimal.urdf`: a capsule for the body, one per knee drive (part of the thigh)
and a sphere per foot; its shanks and the rest of its thighs touch nothing.

Control at the physics rate: each of the 4 physics steps (5 ms) of an action applies
torque = clip(Kp·(0.5·a + q0 − q) − Kd·q̇, ±80) with Kp 80, Kd 2, computed here in torch.
Commands at reset: vx, vy ~ U(−1, 1) m/s and a heading ~ U(−π, π), all zeroed below 0.25 m/s;
each step the yaw-rate command turns the base to the heading: clip(0.5·wrap(heading* − heading), ±1).

Observation (188):
    [0:3]      base linear velocity, base frame, × 2
    [3:6]      base angular velocity, base frame, × 0.25
    [6:9]      gravity direction in the base frame
    [9:12]     commands (vx, vy, yaw rate) × (2, 2, 0.25)
    [12:24]    joint angles × 1 (raw angles, as the original; the flat task uses q − q0)
    [24:36]    joint velocities × 0.05
    [36:176]   terrain heights, clip(z_base − 0.5 − h, −1, 1) × 5, at `terrain.height_points()`
               (14 × 10 points around the base, turned with its yaw)
    [176:188]  last actions
  plus uniform noise ± the config's noise × the same scales, each step (commands and actions
  have none).
Reward, each term × dt (0.02 s), the sum clipped at 0, scales in `env.learn`:
    +1.0·exp(−|v*_xy − v_xy|²/0.25)  +0.5·exp(−(ω*_z − ω_z)²/0.25)  −4·v_z²  −0.05·|ω_xy|²
    −2e-5·Στ²  −5e-4·Σ(q̇_prev − q̇)²  −0.25·(thighs touching, |F| > 1 N)  −0.01·Σ(a_prev − a)²
    +1.0·Σ_feet (air time − 0.5 s) at each foot's first contact, when |v*_xy| > 0.1
  (the original's zero-weight terms, orientation, base height, stumble, hip and termination,
  are left out).
  With `env.penaltyCurriculum` the costs (the terms with a negative scale) are multiplied by
  k = start^(decay^(steps / 24)), which grows from `start` towards 1 (Hwangbo et al. 2019's
  curriculum factor; `start` 1 is the original, without it; the CPU profile starts at 0.05).
An episode ends when the base touches anything (|F| > 1 N), or after 20 s. Every 15 s (one
counter for all envs) every base is pushed: its v_xy set to U(−1, 1) m/s. Each robot's friction
is one of 100 values in U[0.5, 1.25] (env i takes value i mod 100), averaged with the terrain's 1.

Metric (progress line, TensorBoard, summary.json): `terrain_level`, the mean level of the envs.
"""

from __future__ import annotations

import torch

from ..api import Scene
from ..assets import anymal_c_spec
from ..torch_utils import env_mask, quat_rotate, quat_rotate_inverse, where_rows, wrap_angle
from .anymal import default_joint_angles
from .base import VecTask
from .terrain import TerrainCurriculum


class AnymalTerrain(TerrainCurriculum, VecTask):
    num_obs = 188
    num_actions = 12
    checkpointed = ("steps_taken", "levels")     # push clock and cost factor; terrain levels

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        control_dt = cfg["sim"]["dt"] * env.get("controlFrequencyInv", 1)
        env["episodeLength"] = round(env["episodeLength_s"] / control_dt)
        self.learn = env["learn"]
        self.init_terrain(env)
        control = env["control"]
        self.kp, self.kd = control["stiffness"], control["damping"]
        self.torque_limit, self.action_scale = control["torqueLimit"], control["actionScale"]
        super().__init__(cfg, device)
        e, dev, N = self.envs, self.device, self.num_envs
        self.default_dof_pos = default_joint_angles(e, env["defaultJointAngles"], dev)
        self.base = e.body_index("anymal/base")
        self.feet = torch.tensor([i for i, n in enumerate(e.body_names) if "SHANK" in n],
                                 device=dev)
        self.knees = torch.tensor([i for i, n in enumerate(e.body_names) if "THIGH" in n],
                                  device=dev)
        self.reward_scales = {k: v * self.dt for k, v in self.learn.items()
                              if k.endswith("RewardScale")}
        curriculum = env.get("penaltyCurriculum", {"start": 1.0, "decay": 1.0})
        self.penalty_start, self.penalty_decay = curriculum["start"], curriculum["decay"]
        for key in ("start", "decay"):
            if not 0.0 < curriculum[key] <= 1.0:
                raise ValueError(f"task.env.penaltyCurriculum.{key}={curriculum[key]}: "
                                 "expected a value in (0, 1]")

        self.init_levels(env)

        # the robot's friction: one of `frictionBuckets` values per env (env i: bucket i mod B)
        self.draw_robot_friction(env["frictionRange"], env["frictionBuckets"])

        self.commands = torch.zeros(N, 3, device=dev)          # vx, vy, yaw rate
        self.heading_command = torch.zeros(N, device=dev)
        self.command_scale = torch.tensor([self.learn["linearVelocityScale"]] * 2
                                          + [self.learn["angularVelocityScale"]], device=dev)
        self.torques = torch.zeros(N, self.num_actions, device=dev)
        self.last_actions = torch.zeros(N, self.num_actions, device=dev)
        self.last_dof_vel = torch.zeros(N, self.num_actions, device=dev)
        self.feet_air_time = torch.zeros(N, len(self.feet), device=dev)
        self.measured_heights = torch.zeros(N, len(self.height_points), device=dev)
        self.gravity_dir = torch.tensor([0.0, 0.0, -1.0], device=dev).expand(N, 3)
        self.forward_axis = torch.tensor([1.0, 0.0, 0.0], device=dev).expand(N, 3)
        self.noise_scale = self._noise_scale()
        self.push_every = max(1, round(env["pushInterval_s"] / self.dt))
        # control steps since the task was built: the push clock and the cost curriculum's, on
        # the device (a step captured once as a CUDA graph reads it where it is at each replay)
        self.steps_taken = torch.zeros((), dtype=torch.int64, device=dev)
        self.reset()

    def _noise_scale(self) -> torch.Tensor:
        """Half-width of the uniform noise on each observation entry (scaled units)."""
        learn, level = self.learn, self.learn["noiseLevel"] * float(self.learn["addNoise"])
        parts = [(3, learn["linearVelocityNoise"] * learn["linearVelocityScale"]),
                 (3, learn["angularVelocityNoise"] * learn["angularVelocityScale"]),
                 (3, learn["gravityNoise"]), (3, 0.0),
                 (12, learn["dofPositionNoise"] * learn["dofPositionScale"]),
                 (12, learn["dofVelocityNoise"] * learn["dofVelocityScale"]),
                 (140, learn["heightMeasurementNoise"] * learn["heightMeasurementScale"]),
                 (12, 0.0)]
        return torch.cat([torch.full((n, ), s * level) for n, s in parts]).to(self.device)

    def create_envs(self):
        scene = self.add_terrain(Scene(), self.cfg["env"])
        # the original's anymal_minimal.urdf: a body, knee drives and feet collide
        scene.add_actor("anymal", anymal_c_spec(minimal=True), pos=(0.0, 0.0, 1.0),
                        self_collisions=False, dof_mode="effort")
        return scene.build(self.num_envs, self.device, self.sim_params)

    def metrics(self) -> dict[str, float]:
        metrics = super().metrics()
        if self.penalty_start < 1.0:
            metrics["penalty_factor"] = float(self.penalty_factor())
        return metrics

    def penalty_factor(self) -> torch.Tensor:
        """The curriculum's factor on the costs now: start^(decay^(control steps / 24)), a
        float64 scalar on the device."""
        return self.penalty_start ** (self.penalty_decay ** (self.steps_taken.double() / 24))

    def scaled_rewards(self) -> dict:
        """The reward scales (× dt), the costs × the curriculum's factor (scalars on the device;
        the other terms' Python numbers)."""
        if self.penalty_start == 1.0:       # no curriculum: the factor is 1 for ever
            return self.reward_scales
        k = self.penalty_factor()
        return {name: scale * k if scale < 0 else scale
                for name, scale in self.reward_scales.items()}

    # ------------------------------------------------------------------ step
    def pre_physics_step(self, actions):
        self.actions[:] = actions

    def apply_control(self):
        e = self.envs
        target = self.action_scale * self.actions + self.default_dof_pos
        self.torques[:] = torch.clamp(self.kp * (target - e.dof_pos) - self.kd * e.dof_vel,
                                      -self.torque_limit, self.torque_limit)
        e.set_dof_efforts(self.torques)

    def post_physics_step(self):
        e = self.envs
        self.steps_taken += 1
        due = self.steps_taken % self.push_every == 0
        if self.runs(due):
            self.push_robots(due)
        base = e.root_states[:, 0]
        forward = quat_rotate(base[:, 3:7], self.forward_axis)
        heading = torch.atan2(forward[:, 1], forward[:, 0])
        self.commands[:, 2] = torch.clamp(0.5 * wrap_angle(self.heading_command - heading),
                                          -1.0, 1.0)
        contact = e.net_contact_force[:, self.feet, 2] > 1.0
        first_contact = (self.feet_air_time > 0.0) & contact
        self.feet_air_time += self.dt
        self.rew_buf[:], terminated = compute_anymal_terrain_reward(
            base, self.commands, self.torques, e.dof_vel, self.last_dof_vel, self.actions,
            self.last_actions, e.net_contact_force, self.base, self.knees, self.feet_air_time,
            first_contact, self.scaled_rewards())
        self.feet_air_time *= ~contact
        self.reset_buf[:] = terminated.long()
        self.last_actions[:] = self.actions
        self.last_dof_vel[:] = e.dof_vel
        self.compute_observations()

    def push_robots(self, due: torch.Tensor):
        """Every base's v_xy set to U(−pushVelocity, pushVelocity) where `due` (a bool scalar
        on the device) says it is time; the velocities are drawn whenever this runs (at every
        step on a GPU, `runs`)."""
        states = self.envs.root_states.clone()
        states[:, 0, 7:9] = torch.empty(self.num_envs, 2, device=self.device).uniform_(
            -self.cfg["env"]["pushVelocity"], self.cfg["env"]["pushVelocity"])
        self.envs.set_root_states(states, due.expand(self.num_envs))

    def compute_observations(self):
        e, learn = self.envs, self.learn
        base = e.root_states[:, 0]
        self.measured_heights[:] = self.terrain_heights(base)
        obs = compute_anymal_terrain_observations(
            base, self.commands * self.command_scale, e.dof_pos, e.dof_vel, self.gravity_dir,
            self.measured_heights, self.actions, learn["linearVelocityScale"],
            learn["angularVelocityScale"], learn["dofPositionScale"], learn["dofVelocityScale"],
            learn["heightMeasurementScale"])
        noise = (2.0 * torch.rand_like(obs) - 1.0) * self.noise_scale
        self.obs_buf[:] = obs + noise

    # ------------------------------------------------------------------ reset
    def reset_idx(self, env_ids):
        done, n, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        e = self.envs
        self.next_origins(done, torch.norm(self.commands[:, :2], dim=-1))
        states = e.root_states.clone()
        start = self.cfg["env"]["baseInitState"]
        states[:, 0] = self.start_root_states(start["height"], start["xyNoise"])
        e.set_root_states(states, done, forward=False)
        pos = self.default_dof_pos * torch.empty(n, self.num_actions, device=dev).uniform_(0.5, 1.5)
        vel = torch.empty(n, self.num_actions, device=dev).uniform_(-0.1, 0.1)
        e.set_dof_state(pos, vel, done)

        r = self.cfg["env"]["commands"]
        commands = torch.stack([torch.empty(n, device=dev).uniform_(*r["linear_x"]),
                                torch.empty(n, device=dev).uniform_(*r["linear_y"]),
                                torch.zeros(n, device=dev)], dim=-1)
        heading = torch.empty(n, device=dev).uniform_(*r["heading"])
        moving = torch.norm(commands[:, :2], dim=-1) > r["minimumSpeed"]
        self.commands[:] = where_rows(done, commands * moving[:, None], self.commands)
        self.heading_command[:] = torch.where(done, heading * moving, self.heading_command)
        for buf in (self.actions, self.last_actions, self.last_dof_vel, self.feet_air_time):
            buf.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)


def compute_anymal_terrain_observations(base_state, commands_scaled, dof_pos, dof_vel,
                                        gravity_dir, heights, actions, lin_vel_scale,
                                        ang_vel_scale, dof_pos_scale, dof_vel_scale,
                                        height_scale):
    quat = base_state[:, 3:7]
    return torch.cat((
        quat_rotate_inverse(quat, base_state[:, 7:10]) * lin_vel_scale,
        quat_rotate_inverse(quat, base_state[:, 10:13]) * ang_vel_scale,
        quat_rotate_inverse(quat, gravity_dir),
        commands_scaled,
        dof_pos * dof_pos_scale,
        dof_vel * dof_vel_scale,
        torch.clamp(base_state[:, 2:3] - 0.5 - heights, -1.0, 1.0) * height_scale,
        actions,
    ), dim=-1)


def compute_anymal_terrain_reward(base_state, commands, torques, dof_vel, last_dof_vel, actions,
                                  last_actions, contact_forces, base, knees, feet_air_time,
                                  first_contact, scales):
    """The nine terms of task-specs §6 (each scale already × dt); returns (reward, terminated).
    `feet_air_time` [N, 4] is each foot's time off the ground including this step,
    `first_contact` [N, 4] whether the foot touched down in this step."""
    quat = base_state[:, 3:7]
    lin_vel = quat_rotate_inverse(quat, base_state[:, 7:10])
    ang_vel = quat_rotate_inverse(quat, base_state[:, 10:13])
    lin_error = torch.sum((commands[:, :2] - lin_vel[:, :2]) ** 2, dim=-1)
    yaw_error = (commands[:, 2] - ang_vel[:, 2]) ** 2
    knee_hits = torch.sum(torch.norm(contact_forces[:, knees], dim=-1) > 1.0, dim=-1)
    air_time = torch.sum((feet_air_time - 0.5) * first_contact, dim=-1) \
        * (torch.norm(commands[:, :2], dim=-1) > 0.1)
    reward = (torch.exp(-lin_error / 0.25) * scales["linearVelocityXYRewardScale"]
              + torch.exp(-yaw_error / 0.25) * scales["angularVelocityZRewardScale"]
              + lin_vel[:, 2] ** 2 * scales["linearVelocityZRewardScale"]
              + torch.sum(ang_vel[:, :2] ** 2, dim=-1) * scales["angularVelocityXYRewardScale"]
              + torch.sum(torques ** 2, dim=-1) * scales["torqueRewardScale"]
              + torch.sum((last_dof_vel - dof_vel) ** 2, dim=-1) * scales["jointAccRewardScale"]
              + knee_hits * scales["kneeCollisionRewardScale"]
              + torch.sum((last_actions - actions) ** 2, dim=-1) * scales["actionRateRewardScale"]
              + air_time * scales["feetAirTimeRewardScale"])
    terminated = torch.norm(contact_forces[:, base], dim=-1) > 1.0
    return torch.clamp(reward, min=0.0), terminated
