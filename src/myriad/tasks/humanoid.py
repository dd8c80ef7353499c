"""Humanoid: a 21-joint humanoid runs toward a target 1000 m ahead along +x (seed A.2.1, Table 3).

It shares the Ant's scene, actuation (torque = action × motor gear × powerScale), resets and
potential; the observation adds DOF forces and the reward weighs energy and joint limits by
each motor's strength.

Observation (108), in the order of Table 3:
    [0]       torso height
    [1:4]     torso linear velocity, torso frame
    [4:7]     torso angular velocity, torso frame, × angularVelocityScale
    [7:10]    yaw, roll, angle to target
    [10:12]   up projection, heading projection
    [12:33]   DOF positions scaled to [-1, 1] over their limits
    [33:54]   DOF velocities × dofVelocityScale
    [54:75]   DOF forces × contactForceScale
    [75:87]   foot force/torque sensors (2 × (force, torque)) × contactForceScale
    [87:108]  last actions
Reward (A.2.1, the original's coefficients in cfg/task/Humanoid.yaml), with
r_i = gear_i / max gear (normalized motor strength):
    progress + aliveReward + upWeight·[up > 0.93] + heading term - actionsCost·Σa²
    - energyCost·Σ|a_i·scaled dof velocity_i|·r_i
    - Σ over joints with |scaled position| > 0.98 of jointsAtLimitCost·(|scaled| - 0.98)/0.02·r_i
    and deathCost instead when the torso is below terminationHeight (ending the episode).
Deviations from the original: those of the Ant (angle to target from the y offset, wrapped
angles).
"""

from __future__ import annotations

import torch

from ..torch_utils import unscale
from .ant import Ant, progress_up_heading, torso_observations


class Humanoid(Ant):
    num_obs = 108
    num_actions = 21

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        self.alive_reward = env["aliveReward"]
        self.angular_velocity_scale = env["angularVelocityScale"]
        super().__init__(cfg, device)
        self.motor_strength = self.gears / self.gears.max()

    def post_physics_step(self):
        self.compute_observations()
        self.rew_buf[:], terminated = compute_humanoid_reward(
            self.obs_buf, self.actions, self.potentials, self.prev_potentials,
            self.motor_strength, self.alive_reward, self.up_weight, self.heading_weight,
            self.actions_cost, self.energy_cost, self.joints_at_limit_cost,
            self.termination_height, self.death_cost)
        self.reset_buf[:] = terminated.long()

    def compute_observations(self):
        e = self.envs
        self.prev_potentials[:] = self.potentials
        self.obs_buf[:], self.potentials[:] = compute_humanoid_observations(
            e.root_states[:, 0], self.targets, e.dof_pos, e.dof_vel, e.dof_forces,
            self.dof_lower, self.dof_upper, self.dof_vel_scale, self.angular_velocity_scale,
            e.force_sensors, self.contact_force_scale, self.actions, self.dt)


def compute_humanoid_observations(torso_state, targets, dof_pos, dof_vel, dof_force, dof_lower,
                                  dof_upper, dof_vel_scale, angular_velocity_scale,
                                  sensor_wrenches, contact_force_scale, actions, dt):
    """Table 3 observation and the new potential, from the torso's root state [N, 13]."""
    torso, potentials = torso_observations(torso_state, targets, dt, angular_velocity_scale)
    obs = torch.cat((
        torso,
        unscale(dof_pos, dof_lower, dof_upper),
        dof_vel * dof_vel_scale,
        dof_force * contact_force_scale,
        sensor_wrenches.reshape(len(torso), -1) * contact_force_scale,
        actions,
    ), dim=-1)
    return obs, potentials


def compute_humanoid_reward(obs, actions, potentials, prev_potentials, motor_strength,
                            alive_reward, up_weight, heading_weight, actions_cost, energy_cost,
                            joints_at_limit_cost, termination_height, death_cost):
    """A.2.1 reward from the Table 3 observation; returns (reward, terminated)."""
    n = actions.shape[1]
    dof_scaled, dof_vel_scaled = obs[:, 12:12 + n], obs[:, 12 + n:12 + 2 * n]
    action_penalty = actions_cost * torch.sum(actions**2, dim=-1)
    energy_penalty = energy_cost * torch.sum(torch.abs(actions * dof_vel_scaled) * motor_strength,
                                             dim=-1)
    beyond = torch.abs(dof_scaled) - 0.98
    limit_penalty = torch.sum(torch.where(beyond > 0, joints_at_limit_cost * beyond / 0.02, 0.0)
                              * motor_strength, dim=-1)
    reward = (progress_up_heading(obs, potentials, prev_potentials, up_weight, heading_weight)
              + alive_reward - action_penalty - energy_penalty - limit_penalty)
    fallen = obs[:, 0] < termination_height
    reward = torch.where(fallen, torch.full_like(reward, death_cost), reward)
    return reward, fallen
