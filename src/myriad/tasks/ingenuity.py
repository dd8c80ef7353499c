"""Ingenuity: a coaxial Mars helicopter flies to targets and hovers there (seed A.2.2, Table 4).

Mars gravity (3.721 m/s²). Actions (6): per rotor (lower, upper) a lateral fraction (x, y) and
a vertical thrust command (z). The thrust on a rotor, in its own frame, is
    z = thrustScale · clamp(action_z × 2000, ±2000)          (thrustScale = dt, as the original)
    x, y = z · clamp(action_xy, ±lateralFraction)
applied as a body force at the rotor's center during the next physics step.

Observation (13), Table 4: offset to the target / 3, root quaternion (x, y, z, w), linear
velocity / 2, angular velocity / π (world frame).

Reward (A.2.2): R = R_pos · (1 + R_upright + R_spin) with
    R_pos = 1 / (1 + distance²),  R_upright = uprightWeight / (1 + (1 - up_z)²),
    R_spin = 1 / (1 + ω_z²).
An episode ends early when the helicopter is more than 8 m from its target or its chassis center
drops below 0.5 m. Targets are drawn uniformly in x, y ∈ [-2.5, 2.5], z ∈ [1, 2] at each reset and
every `targetInterval` (500) steps.

Deviation: the appendix writes R_upright with weight 1 and leaves its argument garbled; we use
the tilt 1 - up_z and the weight 5 that the original task ran with (`uprightWeight`), which is
what its published learning curves measure.
"""

from __future__ import annotations

import math

import torch

from ..assets import asset_path
from ..api import Scene
from .base import VecTask
from ..torch_utils import env_mask, quat_rotate, unit_axis, where_rows


class Ingenuity(VecTask):
    num_obs = 13
    num_actions = 6

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        self.thrust_limit = env["thrustLimit"]
        self.thrust_action_scale = env["thrustActionScale"]
        self.lateral_fraction = env["lateralFraction"]
        self.upright_weight = env["uprightWeight"]
        self.target_interval = env["targetInterval"]
        self.max_target_distance = env["maxTargetDistance"]
        self.min_height = env["minHeight"]
        super().__init__(cfg, device)
        e = self.envs
        self.rotors = torch.tensor([e.body_index("ingenuity/rotor_0"),
                                    e.body_index("ingenuity/rotor_1")], device=self.device)
        self.thrust_scale = self.sim_params.dt
        self.initial_root_states = e.root_states.clone()
        self.targets = torch.zeros(self.num_envs, 3, device=self.device)
        self.forces = torch.zeros(self.num_envs, e.num_bodies, 3, device=self.device)
        self.reset()

    def create_envs(self):
        scene = Scene().add_ground(friction=1.0)
        scene.add_actor("ingenuity", asset_path(self.cfg["env"]["asset"]),
                        pos=(0.0, 0.0, self.cfg["env"]["startHeight"]))
        return scene.build(self.num_envs, self.device, self.sim_params)

    def new_targets(self, env_ids):
        n = self.num_envs
        xy = torch.rand(n, 2, device=self.device) * 5.0 - 2.5
        z = torch.rand(n, 1, device=self.device) + 1.0
        new = torch.cat((xy, z), dim=-1)
        self.targets[:] = where_rows(env_mask(env_ids, self.num_envs), new, self.targets)

    def pre_physics_step(self, actions):
        self.new_targets((self.progress_buf % self.target_interval == 0) & (self.progress_buf > 0))
        per_rotor = actions.reshape(-1, 2, 3)     # slices: a list index is copied from the host
        vertical = self.thrust_scale * torch.clamp(per_rotor[..., 2] * self.thrust_action_scale,
                                                   -self.thrust_limit, self.thrust_limit)
        lateral = torch.clamp(per_rotor[..., 0:2], -self.lateral_fraction, self.lateral_fraction)
        self.forces[:, self.rotors, 2] = vertical
        self.forces[:, self.rotors, 0:2] = vertical[..., None] * lateral
        self.envs.apply_body_forces(forces=self.forces, frame="local")

    def post_physics_step(self):
        self.compute_observations()
        root = self.envs.root_states[:, 0]
        self.rew_buf[:], terminated = compute_ingenuity_reward(
            root[:, 0:3], self.targets, root[:, 3:7], root[:, 10:13], self.upright_weight,
            self.max_target_distance, self.min_height)
        self.reset_buf[:] = terminated.long()

    def compute_observations(self):
        root = self.envs.root_states[:, 0]
        self.obs_buf[:, 0:3] = (self.targets - root[:, 0:3]) / 3.0
        self.obs_buf[:, 3:7] = root[:, 3:7]
        self.obs_buf[:, 7:10] = root[:, 7:10] / 2.0
        self.obs_buf[:, 10:13] = root[:, 10:13] / math.pi

    def reset_idx(self, env_ids):
        done = env_mask(env_ids, self.num_envs)
        self.new_targets(done)
        root = self.initial_root_states.clone()
        offset = torch.rand(self.num_envs, 3, device=self.device)
        root[:, 0, 0:2] += offset[:, 0:2] * 3.0 - 1.5
        root[:, 0, 2] += offset[:, 2] * 1.7 - 0.2
        self.envs.set_root_states(root, done)
        self.progress_buf.masked_fill_(done, 0)


def compute_ingenuity_reward(pos, targets, quat, angvel, upright_weight, max_target_distance,
                             min_height):
    """A.2.2 reward; returns (reward, terminated)."""
    distance = torch.norm(targets - pos, dim=-1)
    pos_reward = 1.0 / (1.0 + distance**2)
    up_z = quat_rotate(quat, unit_axis(pos, 2))[:, 2]
    tilt = 1.0 - up_z
    upright_reward = upright_weight / (1.0 + tilt**2)
    spin_reward = 1.0 / (1.0 + angvel[:, 2]**2)
    reward = pos_reward * (1.0 + upright_reward + spin_reward)
    terminated = (distance > max_target_distance) | (pos[:, 2] < min_height)
    return reward, terminated
