"""ANYmal (flat): a quadruped tracks commanded base velocities (seed A.2.2, Tables 5-7).

The robot is ANYbotics' ANYmal C from the `example-robot-data` package (`pip install
"myriad[anymal]"`), read from its URDF with fixes applied in code (`myriad.assets.anymal_c_spec`),
colliding as the original's `anymal.urdf` (example-robot-data's knee guards dropped, cylinders
as capsules).

Actions (12): position-drive targets, target = actionScale × action + default joint angle
(drives Kp 85, Kd 2; efforts limited to the URDF's 80 N·m).
Commands per episode: forward velocity U[-2, 2] m/s, lateral U[-1, 1] m/s, yaw rate U[-1, 1] rad/s.

Observation (48), Table 5:
    [0:3]    base linear velocity, base frame, × linearVelocityScale (2)
    [3:6]    base angular velocity, base frame, × angularVelocityScale (0.25)
    [6:9]    gravity direction in the base frame (unit vector)
    [9:12]   commands (x, y, yaw) × (2, 2, 0.25)
    [12:24]  joint angles - default angles (× dofPositionScale 1)
    [24:36]  joint velocities × dofVelocityScale (0.05)
    [36:48]  last actions
Reward (Table 7, flat terrain), with φ(x) = exp(-|x|²/0.25) and dt the control step (0.02 s):
    1·dt·φ(v*_xy - v_xy) + 0.5·dt·φ(ω*_z - ω_z) - 2e-5·dt·|τ|², clipped at 0 (as the original).
An episode ends when the base or a thigh touches the ground (contact force > 1 N), or after
episodeLength_s = 50 s.

Deviations: the original rotates gravity by the base orientation instead of its inverse for
the observation (giving the gravity direction in a mirrored frame); we report the gravity
direction in the base frame, as Table 5 says. The torque weight is Table 7's 2e-5 (the original
config has 2.5e-5).
"""

from __future__ import annotations

import torch

from ..api import Scene
from ..assets import anymal_c_spec
from .base import VecTask
from ..torch_utils import env_mask, quat_rotate_inverse, where_rows

class Anymal(VecTask):
    num_obs = 48
    num_actions = 12

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        cfg["env"]["episodeLength"] = round(env["episodeLength_s"] / (
            cfg["sim"]["dt"] * env.get("controlFrequencyInv", 1)))
        learn = env["learn"]
        self.lin_vel_scale = learn["linearVelocityScale"]
        self.ang_vel_scale = learn["angularVelocityScale"]
        self.dof_pos_scale = learn["dofPositionScale"]
        self.dof_vel_scale = learn["dofVelocityScale"]
        self.action_scale = env["control"]["actionScale"]
        self.command_ranges = env["randomCommandVelocityRanges"]
        super().__init__(cfg, device)
        # reward weights per control step (Table 7's weights × dt)
        self.reward_weights = {k: learn[k] * self.dt for k in
                               ("linearVelocityXYRewardScale", "angularVelocityZRewardScale",
                                "torqueRewardScale")}
        e, dev = self.envs, self.device
        self.default_dof_pos = default_joint_angles(e, env["defaultJointAngles"], dev)
        self.base = e.body_index("anymal/base")
        self.thighs = torch.tensor([i for i, n in enumerate(e.body_names) if "THIGH" in n],
                                   device=dev)
        self.initial_root_states = e.root_states.clone()
        self.commands = torch.zeros(self.num_envs, 3, device=dev)
        self.command_scale = torch.tensor([self.lin_vel_scale, self.lin_vel_scale,
                                           self.ang_vel_scale], device=dev)
        self.gravity_dir = torch.tensor([0.0, 0.0, -1.0], device=dev).repeat(self.num_envs, 1)
        self.reset()

    def create_envs(self):
        env = self.cfg["env"]
        control = env["control"]
        scene = Scene().add_ground(friction=env["plane"]["staticFriction"],
                                   restitution=env["plane"]["restitution"])
        scene.add_actor("anymal", anymal_c_spec(), pos=tuple(env["baseInitState"]["pos"]),
                        quat=tuple(env["baseInitState"]["rot"]), self_collisions=False,
                        dof_mode="position", stiffness=control["stiffness"],
                        damping=control["damping"])
        return scene.build(self.num_envs, self.device, self.sim_params)

    def pre_physics_step(self, actions):
        self.actions[:] = actions
        self.envs.set_dof_position_targets(self.action_scale * actions + self.default_dof_pos)

    def post_physics_step(self):
        self.compute_observations()
        e = self.envs
        torques = e.sim.dof_actuator_force[:, e.dof_columns]
        self.rew_buf[:], terminated = compute_anymal_reward(
            e.root_states[:, 0], self.commands, torques, e.net_contact_force, self.base,
            self.thighs, self.reward_weights)
        self.reset_buf[:] = terminated.long()

    def compute_observations(self):
        e = self.envs
        self.obs_buf[:] = compute_anymal_observations(
            e.root_states[:, 0], self.commands * self.command_scale, e.dof_pos,
            self.default_dof_pos, e.dof_vel, self.gravity_dir, self.actions, self.lin_vel_scale,
            self.ang_vel_scale, self.dof_pos_scale, self.dof_vel_scale)

    def reset_idx(self, env_ids):
        done, n, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        pos = self.default_dof_pos * torch.empty(n, self.num_actions, device=dev).uniform_(0.5, 1.5)
        vel = torch.empty(n, self.num_actions, device=dev).uniform_(-0.1, 0.1)
        self.envs.set_root_states(self.initial_root_states, done, forward=False)
        self.envs.set_dof_state(pos, vel, done)
        r = self.command_ranges
        commands = torch.stack([torch.empty(n, device=dev).uniform_(*r[key])
                                for key in ("linear_x", "linear_y", "yaw")], dim=-1)
        self.commands[:] = where_rows(done, commands, self.commands)
        self.actions.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)


def default_joint_angles(envs, defaults: dict, device) -> torch.Tensor:
    """The config's `defaultJointAngles` (by joint name) as a [dofs] tensor in the envs' DOF
    order; a KeyError names the joints the config lacks."""
    names = [n.split("/", 1)[1] for n in envs.dof_names]
    missing = sorted(set(names) - set(defaults))
    if missing:
        raise KeyError(f"env.defaultJointAngles lacks {missing}")
    return torch.tensor([defaults[n] for n in names], device=device)


def compute_anymal_observations(base_state, commands_scaled, dof_pos, default_dof_pos, dof_vel,
                                gravity_dir, actions, lin_vel_scale, ang_vel_scale,
                                dof_pos_scale, dof_vel_scale):
    quat = base_state[:, 3:7]
    return torch.cat((
        quat_rotate_inverse(quat, base_state[:, 7:10]) * lin_vel_scale,
        quat_rotate_inverse(quat, base_state[:, 10:13]) * ang_vel_scale,
        quat_rotate_inverse(quat, gravity_dir),
        commands_scaled,
        (dof_pos - default_dof_pos) * dof_pos_scale,
        dof_vel * dof_vel_scale,
        actions,
    ), dim=-1)


def compute_anymal_reward(base_state, commands, torques, contact_forces, base, thighs, weights):
    """Table 7 (flat terrain); returns (reward, terminated)."""
    quat = base_state[:, 3:7]
    lin_vel = quat_rotate_inverse(quat, base_state[:, 7:10])
    ang_vel = quat_rotate_inverse(quat, base_state[:, 10:13])
    lin_error = torch.sum((commands[:, :2] - lin_vel[:, :2]) ** 2, dim=-1)
    yaw_error = (commands[:, 2] - ang_vel[:, 2]) ** 2
    reward = (torch.exp(-lin_error / 0.25) * weights["linearVelocityXYRewardScale"]
              + torch.exp(-yaw_error / 0.25) * weights["angularVelocityZRewardScale"]
              - torch.sum(torques**2, dim=-1) * weights["torqueRewardScale"])
    reward = torch.clamp(reward, min=0.0)
    terminated = (torch.norm(contact_forces[:, base], dim=-1) > 1.0) | torch.any(
        torch.norm(contact_forces[:, thighs], dim=-1) > 1.0, dim=-1)
    return reward, terminated
