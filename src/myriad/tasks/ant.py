"""Ant: a four-legged walker runs toward a target 1000 m ahead along +x (seed A.2.1, Table 2).

Observation (60), in the order of Table 2:
    [0]      torso height
    [1:4]    torso linear velocity, torso frame
    [4:7]    torso angular velocity, torso frame
    [7:10]   yaw, roll, angle to target
    [10:12]  up projection (torso z axis · world z), heading projection (torso x axis · direction
             to target)
    [12:20]  DOF positions scaled to [-1, 1] over their limits
    [20:28]  DOF velocities × dofVelocityScale
    [28:52]  foot force/torque sensors (4 × (force, torque)) × contactForceScale
    [52:60]  last actions
Reward (A.2.1, the original's coefficients in cfg/task/Ant.yaml):
    progress (potential - previous potential, potential = -distance to target / dt)
    + 0.5 alive + upWeight·[up projection > 0.93] + heading term
    - actionsCost·Σa² - energyCost·Σ|a·scaled dof velocity| - jointsAtLimitCost·#(|scaled dof| > 0.99)
    and deathCost instead when the torso is below terminationHeight (which also ends the episode).
Actions: joint torques = action × gear (15) × powerScale.

Deviations from the original, on purpose:
- angle to target is atan2 of the target's (y, x) offset minus yaw (the original takes the z
  offset in place of y), and angles are wrapped to (-π, π];
- the joints-at-limit count takes both limits (the original counts only the upper one);
- the start height is 0.62 m, where our ant's feet (shins at 60°) touch the ground.
"""

from __future__ import annotations

import torch

from ..assets import asset_path
from ..api import Scene
from .base import VecTask
from ..torch_utils import env_mask, heading_up_and_angles, quat_rotate_inverse, unscale


def dof_gears(envs) -> torch.Tensor:
    """[dofs] gear of the MJCF motor on each DOF (the original reads its efforts from them)."""
    m, dof_cols = envs.model, envs.dof_columns.tolist()
    gears = torch.zeros(envs.num_dofs, device=envs.device)
    for a in range(m.nu):
        gears[dof_cols.index(int(m.actuator_dof[a]))] = float(m.actuator_gear[a])
    return gears


class Ant(VecTask):
    num_obs = 60
    num_actions = 8

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        self.heading_weight = env["headingWeight"]
        self.up_weight = env["upWeight"]
        self.actions_cost = env["actionsCost"]
        self.energy_cost = env["energyCost"]
        self.joints_at_limit_cost = env["jointsAtLimitCost"]
        self.death_cost = env["deathCost"]
        self.termination_height = env["terminationHeight"]
        self.dof_vel_scale = env["dofVelocityScale"]
        self.contact_force_scale = env["contactForceScale"]
        self.power_scale = env["powerScale"]
        super().__init__(cfg, device)

        e, dev = self.envs, self.device
        self.initial_root_states = e.root_states.clone()
        limits = e.dof_limits()[0]
        self.dof_lower, self.dof_upper = limits[:, 0], limits[:, 1]
        self.initial_dof_pos = torch.clamp(e.dof_pos[0].clone(), self.dof_lower, self.dof_upper)
        self.gears = dof_gears(e)
        self.targets = torch.tensor([1000.0, 0.0, 0.0], device=dev).repeat(self.num_envs, 1)
        self.potentials = torch.zeros(self.num_envs, device=dev)
        self.prev_potentials = torch.zeros(self.num_envs, device=dev)
        self.reset()

    def create_envs(self):
        env = self.cfg["env"]
        plane = env["plane"]
        scene = Scene().add_ground(friction=plane["staticFriction"],
                                   restitution=plane["restitution"])
        scene.add_actor("ant", asset_path(env["asset"]), pos=(0.0, 0.0, env["startHeight"]),
                        self_collisions=False)
        return scene.build(self.num_envs, self.device, self.sim_params)

    def pre_physics_step(self, actions):
        self.actions[:] = actions
        self.envs.set_dof_efforts(actions * self.gears * self.power_scale)

    def post_physics_step(self):
        self.compute_observations()
        self.rew_buf[:], terminated = compute_ant_reward(
            self.obs_buf, self.actions, self.potentials, self.prev_potentials, self.up_weight,
            self.heading_weight, self.actions_cost, self.energy_cost, self.joints_at_limit_cost,
            self.termination_height, self.death_cost)
        self.reset_buf[:] = terminated.long()

    def compute_observations(self):
        e = self.envs
        self.prev_potentials[:] = self.potentials
        self.obs_buf[:], self.potentials[:] = compute_ant_observations(
            e.root_states[:, 0], self.targets, e.dof_pos, e.dof_vel, self.dof_lower,
            self.dof_upper, self.dof_vel_scale, e.force_sensors, self.contact_force_scale,
            self.actions, self.dt)

    def reset_idx(self, env_ids):
        done, n, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        noise_pos = torch.empty(n, self.num_actions, device=dev).uniform_(-0.2, 0.2)
        noise_vel = torch.empty(n, self.num_actions, device=dev).uniform_(-0.1, 0.1)
        pos = torch.clamp(self.initial_dof_pos + noise_pos, self.dof_lower, self.dof_upper)
        self.envs.set_root_states(self.initial_root_states, done, forward=False)
        self.envs.set_dof_state(pos, noise_vel, done)
        self.actions.masked_fill_(done[:, None], 0.0)
        to_target = self.targets - self.initial_root_states[:, 0, :3]
        to_target[:, 2] = 0.0
        self.potentials[:] = torch.where(done, -torch.norm(to_target, dim=-1) / self.dt,
                                         self.potentials)
        self.progress_buf.masked_fill_(done, 0)


def torso_observations(torso_state, targets, dt, angular_velocity_scale=1.0):
    """The first 12 values of Tables 2 and 3 (torso height, torso-frame linear and angular
    velocity, yaw, roll, angle to target, up and heading projections) and the new potential,
    from the torso's root state [N, 13]."""
    pos, quat = torso_state[:, 0:3], torso_state[:, 3:7]
    to_target = targets - pos
    to_target[:, 2] = 0.0
    potentials = -torch.norm(to_target, dim=-1) / dt
    up_proj, heading_proj, roll, yaw, angle_to_target = heading_up_and_angles(quat, to_target)
    obs = torch.cat((
        pos[:, 2:3],
        quat_rotate_inverse(quat, torso_state[:, 7:10]),
        quat_rotate_inverse(quat, torso_state[:, 10:13]) * angular_velocity_scale,
        yaw[:, None], roll[:, None], angle_to_target[:, None],
        up_proj[:, None], heading_proj[:, None],
    ), dim=-1)
    return obs, potentials


def progress_up_heading(obs, potentials, prev_potentials, up_weight, heading_weight):
    """The A.2.1 terms the walkers share: progress + upright bonus + heading term."""
    heading_proj = obs[:, 11]
    heading_reward = torch.where(heading_proj > 0.8, torch.full_like(heading_proj, heading_weight),
                                 heading_weight * heading_proj / 0.8)
    up_reward = torch.where(obs[:, 10] > 0.93, up_weight, 0.0)
    return potentials - prev_potentials + up_reward + heading_reward


def compute_ant_observations(torso_state, targets, dof_pos, dof_vel, dof_lower, dof_upper,
                             dof_vel_scale, sensor_wrenches, contact_force_scale, actions, dt):
    """Table 2 observation and the new potential, from the torso's root state [N, 13]."""
    torso, potentials = torso_observations(torso_state, targets, dt)
    obs = torch.cat((
        torso,
        unscale(dof_pos, dof_lower, dof_upper),
        dof_vel * dof_vel_scale,
        sensor_wrenches.reshape(len(torso), -1) * contact_force_scale,
        actions,
    ), dim=-1)
    return obs, potentials


def compute_ant_reward(obs, actions, potentials, prev_potentials, up_weight, heading_weight,
                       actions_cost, energy_cost, joints_at_limit_cost, termination_height,
                       death_cost):
    """A.2.1 reward from the Table 2 observation; returns (reward, terminated)."""
    action_penalty = actions_cost * torch.sum(actions**2, dim=-1)
    energy_penalty = energy_cost * torch.sum(torch.abs(actions * obs[:, 20:28]), dim=-1)
    limit_penalty = joints_at_limit_cost * torch.sum(torch.abs(obs[:, 12:20]) > 0.99, dim=-1)
    alive_reward = 0.5
    reward = (progress_up_heading(obs, potentials, prev_potentials, up_weight, heading_weight)
              + alive_reward - action_penalty - energy_penalty - limit_penalty)
    fallen = obs[:, 0] < termination_height
    reward = torch.where(fallen, torch.full_like(reward, death_cost), reward)
    return reward, fallen
