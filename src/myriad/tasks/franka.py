"""FrankaCubeStack: a Franka Panda picks up a 5 cm cube and stands it on a 7 cm one, commanded in
task space through an operational-space controller (seed A.2.2, Table 9; reference task-specs
§5, the original's franka_cube_stack.py).

The scene, in env coordinates: a table (1.2 × 1.2 × 0.05 m, top at z = 1.025), a stand
(0.2 × 0.2 × 0.1 m at (-0.5, 0, 1.075)) and on it the Panda of example-robot-data
(`myriad.assets.franka_spec`) at (-0.45, 0, 1.125), fixed, gravity off (the original's); cube A
(0.05 m) and cube B (0.07 m), density 1000, on the table. The arm's 7 joints take torques
clamped to their effort limits (87 N·m for joints 1-4, 12 N·m for 5-7); the two fingers are
position-driven (kp 5000, kd 100, at most 200 N) between 0 (closed) and 0.04 m (open). Every
DOF keeps the URDF's speed limit, as Isaac Gym applies it: 2.175 rad/s (joints 1-4), 2.61 (5-7),
0.2 m/s (fingers).

Actions (7, "osc"): a[0:6] · (0.1, 0.1, 0.1, 0.5, 0.5, 0.5) is the task-space error Δpose of
the grip point (m, axis-angle rad), a[6] ≥ 0 opens the gripper, < 0 closes it. The controller
(`osc_torques`): Λ = (J M⁻¹ Jᵀ)⁻¹ with J the 6 × 7 Jacobian of panda_hand and M the arm's
mass matrix; τ = Jᵀ Λ (kp·Δpose − kd·v) with v the grip point's 6D velocity, plus the null-space
term (I − Jᵀ Λ J M⁻¹) M (kp_null·wrap(q₀ − q) − kd_null·q̇) holding the arm near its start pose.
Actions ("joint_tor", 8): τ = a[0:7] · effort limits, and the gripper as above.

Observation (19 with "osc", 26 with "joint_tor"), Table 9 in the original's code order:
    [0:4]    cube A quaternion (x, y, z, w)
    [4:7]    cube A position
    [7:10]   cube B position − cube A position
    [10:13]  grip point position
    [13:17]  grip point quaternion
    [17:19]  finger positions ("osc"); [17:26] all 9 joint positions ("joint_tor")

Reward (A.2.2, the original's code), with d, d_l, d_r the distances from cube A to the grip
point and to the two fingertips, h the height of cube A's centre above the table:
    reach = 1 − tanh(10·(d + d_l + d_r)/3)
    lifted = h − 0.05 > 0.04
    align = (1 − tanh(10·‖B − A + (0, 0, 0.06)‖))·lifted;  reach ← max(reach, align)
    stacked = ‖(B − A)_xy‖ < 0.02 and |h − 0.095| < 0.02 and d > 0.04 (the gripper let go)
    r = 16 if stacked, else 0.1·reach + 1.5·lifted + 2.0·align
An episode ends when the cubes are stacked (a termination), or after 300 steps (a time-out,
which PPO bootstraps).

Resets: cube B anywhere on the table within ±0.25 m of its centre, turned about z by up to
±45°; cube A the same, at least 0.17 m from B (drawn up to 100 times, as the original); the arm
at q₀ + U(−0.25, 0.25) per joint, clamped to its limits, the fingers at 0.035 m, at rest.

Metrics (`metrics`, in the progress line, TensorBoard and summary.json): `success_rate`, the
share of the last finished episodes (at least num_envs) that ended stacked; `lift_rate`, the
share in which cube A was lifted in the gripper at some point (lifted as the reward says, its
centre within 2 cm of the grip point: a policy that knocks the cube into the air also earns the
reward's lift term, and it happens early in training).

Deviations from the original, on purpose: cube B starts resting on the table (the original
sets its height with cube A's size, 1 cm into the table, and PhysX pushes it out on the first
step); the fingers are the example-robot-data gripper's (the second finger mimics the first
through a joint equality; the original drives two independent fingers to the same target).
"""

from __future__ import annotations

import math

import torch

from ..api import Scene
from ..assets import franka_max_velocity, franka_spec
from ..torch_utils import env_mask, quat_from_angle_axis, unit_axis, where_rows, wrap_angle
from .base import EpisodeShares, VecTask, box_spec

CONTROL_TYPES = {"osc": 7, "joint_tor": 8}
TABLE_SIZE, TABLE_POS = (1.2, 1.2, 0.05), (0.0, 0.0, 1.0)
STAND_SIZE, STAND_POS = (0.2, 0.2, 0.1), (-0.5, 0.0, 1.075)
ROBOT_POS = (-0.45, 0.0, 1.125)
TABLE_TOP = TABLE_POS[2] + TABLE_SIZE[2] / 2
ARM_EFFORT = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)      # N·m, the Panda's limits
FINGER_KP, FINGER_KD, FINGER_EFFORT = 5000.0, 100.0, 200.0    # N/m, N·s/m, N (the original's)
FINGER_OPEN, FINGER_START = 0.04, 0.035
CUBE_A, CUBE_B = 0.05, 0.07      # m, edge lengths
HELD = 0.02       # m: cube A's centre this close to the grip point is in the gripper (lift_rate)
SINGULAR_DAMPING = 1e-6   # added to J M⁻¹ Jᵀ's diagonal (1/kg, 1/(kg·m²); its entries: 0.1-100)


def osc_torques(dpose: torch.Tensor, eef_vel: torch.Tensor, jacobian: torch.Tensor,
                mass_matrix: torch.Tensor, q: torch.Tensor, qd: torch.Tensor,
                q_rest: torch.Tensor, kp: float, kd: float, kp_null: float,
                kd_null: float) -> torch.Tensor:
    """Joint torques [N, n] of an operational-space controller (the original's, batched):
    τ = Jᵀ Λ (kp·Δpose − kd·v) + (I − Jᵀ Λ J M⁻¹) M (kp_null·wrap(q_rest − q) − kd_null·q̇),
    Λ = (J M⁻¹ Jᵀ)⁻¹. `dpose`, `eef_vel` [N, 6] (linear, angular), `jacobian` [N, 6, n],
    `mass_matrix` [N, n, n]. With q̇ = 0 and no other forces, the end effector accelerates at
    kp·Δpose (J̇q̇ = 0); the null-space term changes no task-space acceleration.

    Near a kinematic singularity J M⁻¹ Jᵀ loses rank: SINGULAR_DAMPING on its diagonal keeps Λ
    finite (a 30-minute training run met an exactly singular matrix once and stopped). An env
    whose matrices still cannot be inverted gets zero torque rather than stopping the run."""
    m_inv, m_failed = torch.linalg.inv_ex(mass_matrix)
    jt = jacobian.transpose(1, 2)
    damping = SINGULAR_DAMPING * torch.eye(jacobian.shape[1], device=q.device)
    task_mass, t_failed = torch.linalg.inv_ex(jacobian @ m_inv @ jt + damping)
    tau = jt @ task_mass @ (kp * dpose - kd * eef_vel).unsqueeze(-1)
    rest = kp_null * wrap_angle(q_rest - q) - kd_null * qd
    eye = torch.eye(q.shape[1], device=q.device).expand_as(mass_matrix)
    null = eye - jt @ task_mass @ jacobian @ m_inv
    tau = (tau + null @ mass_matrix @ rest.unsqueeze(-1)).squeeze(-1)
    usable = (m_failed == 0) & (t_failed == 0) & torch.isfinite(tau).all(dim=1)
    return torch.where(usable[:, None], tau, 0.0)


class FrankaCubeStack(VecTask):
    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        self.control_type = env["controlType"]
        if self.control_type not in CONTROL_TYPES:
            raise ValueError(f"env.controlType={self.control_type!r}; valid: "
                             f"{sorted(CONTROL_TYPES)}")
        self.num_actions = CONTROL_TYPES[self.control_type]
        self.num_obs = 19 if self.control_type == "osc" else 26
        self.rewards = {k: float(env[k]) for k in (
            "distRewardScale", "liftRewardScale", "alignRewardScale", "stackRewardScale")}
        self.osc = {k: float(env[k]) for k in ("kp", "kp_null")}
        self.osc["kd"], self.osc["kd_null"] = 2 * math.sqrt(self.osc["kp"]), \
            2 * math.sqrt(self.osc["kp_null"])
        self.action_scale = torch.tensor(env["commandLimit"], dtype=torch.float32)
        self.dof_noise = float(env["frankaDofNoise"])
        self.position_noise = float(env["startPositionNoise"])
        self.rotation_noise = float(env["startRotationNoise"])
        self.q_rest = torch.tensor(env["frankaDefaultDofPos"], dtype=torch.float32)
        if self.action_scale.shape != (6,) or self.q_rest.shape != (9,):
            raise ValueError("env.commandLimit needs 6 values (Δpose) and env.frankaDefaultDofPos "
                             "9 (7 arm joints, 2 fingers)")
        super().__init__(cfg, device)

        e, dev, N = self.envs, self.device, self.num_envs
        self.action_scale, self.q_rest = self.action_scale.to(dev), self.q_rest.to(dev)
        limits = e.dof_limits()[0]
        self.dof_lower, self.dof_upper = limits[:, 0], limits[:, 1]
        self.effort = torch.tensor(ARM_EFFORT, device=dev)
        names = e.model.site_names
        sites = [names.index(f"franka/{s}") for s in (
            "panda_grip_site", "panda_leftfinger_tip", "panda_rightfinger_tip")]
        self.sites = torch.tensor(sites, device=dev)
        self.grip_site = sites[0]       # a Python int: indexing with a tensor reads it back
        self.hand = e.body_index("franka/panda_hand")
        self.hand_in_actor = e.actor_bodies("franka").index(self.hand)     # its Jacobian's row
        e.sim.body_jacobians()      # their buffer allocated now, not inside the first step
        self.cube_a, self.cube_b = e.actor_index("cubeA"), e.actor_index("cubeB")
        self.efforts = torch.zeros(N, e.num_dofs, device=dev)
        self.finger_targets = torch.full((N, e.num_dofs), FINGER_START, device=dev)
        self.lifted_ever = torch.zeros(N, dtype=torch.bool, device=dev)
        self.shares = EpisodeShares(("success_rate", "lift_rate"), N, dev)
        self.initial_root_states = e.root_states.clone()
        self.reset()

    # ------------------------------------------------------------------ scene
    def create_envs(self):
        scene = Scene().add_ground()
        scene.add_actor("table", box_spec("table", TABLE_SIZE), pos=TABLE_POS,
                        fix_base=True)
        scene.add_actor("stand", box_spec("stand", STAND_SIZE), pos=STAND_POS,
                        fix_base=True)
        franka = franka_spec()
        for finger in ("panda_finger_joint1", "panda_finger_joint2"):
            franka.joint(finger).actfrcrange = [-FINGER_EFFORT, FINGER_EFFORT]
        scene.add_actor("franka", franka, pos=ROBOT_POS, fix_base=True, gravity=False,
                        dof_mode=["effort"] * 7 + ["position"] * 2,
                        stiffness=[0.0] * 7 + [FINGER_KP] * 2,
                        damping=[0.0] * 7 + [FINGER_KD] * 2)
        scene.add_actor("cubeA", box_spec("cubeA", [CUBE_A] * 3, rgba=(0.6, 0.1, 0.0, 1.0)),
                        pos=(0.1, 0.0, TABLE_TOP + CUBE_A / 2))
        scene.add_actor("cubeB", box_spec("cubeB", [CUBE_B] * 3, rgba=(0.0, 0.4, 0.1, 1.0)),
                        pos=(-0.1, 0.0, TABLE_TOP + CUBE_B / 2))
        return scene.build(self.num_envs, self.device, self.sim_params)

    def dof_speed_limits(self) -> list[float]:
        """The URDF's speed limits, which Isaac Gym applies: the fingers close at 0.2 m/s
        (0.2 s from open), not in one physics step. Unlimited, they struck the cube away: a
        scripted reach-close-lift lifted it in 18 % of envs, not 76 %."""
        return franka_max_velocity(self.envs.dof_names)

    # ------------------------------------------------------------------ state
    def grip_poses(self) -> torch.Tensor:
        """[N, 3, 7] poses of the grip point and the two fingertips."""
        return self.envs.sim.site_pose[:, self.sites]

    def grip_velocity(self) -> torch.Tensor:
        """[N, 6] linear and angular velocity of the grip point."""
        hand = self.envs.rigid_body_states[:, self.hand]
        angular = hand[:, 10:13]
        grip = self.envs.sim.site_pose[:, self.grip_site, 0:3]
        return torch.cat((hand[:, 7:10] + torch.cross(angular, grip - hand[:, 0:3], dim=-1),
                          angular), dim=-1)

    # ------------------------------------------------------------------ step
    def pre_physics_step(self, actions):
        self.actions[:] = actions
        e = self.envs
        if self.control_type == "osc":
            eef_vel = self.grip_velocity()
            jacobian = e.jacobians("franka")[:, self.hand_in_actor, :, :7]
            mass = e.mass_matrix("franka")[:, :7, :7]
            tau = osc_torques(actions[:, :6] * self.action_scale, eef_vel, jacobian, mass,
                              e.dof_pos[:, :7], e.dof_vel[:, :7], self.q_rest[:7],
                              **self.osc)
        else:
            tau = actions[:, :7] * self.effort
        self.efforts[:, :7] = torch.clamp(tau, -self.effort, self.effort)
        e.set_dof_efforts(self.efforts)
        opened = actions[:, -1:] >= 0.0
        self.finger_targets[:, 7:9] = torch.where(opened, FINGER_OPEN, 0.0)
        e.set_dof_position_targets(self.finger_targets)

    def post_physics_step(self):
        a = self.envs.root_states[:, self.cube_a, 0:3]
        b = self.envs.root_states[:, self.cube_b, 0:3]
        sites = self.grip_poses()
        self.rew_buf[:], stacked, lifted = compute_franka_reward(
            a, b, sites[:, 0, 0:3], sites[:, 1, 0:3], sites[:, 2, 0:3], CUBE_A, CUBE_B,
            **self.rewards)
        # a lift counts for lift_rate with the cube in the gripper (its centre within 2 cm of the
        # grip point): the reward's `lifted` also pays a cube knocked into the air
        held = torch.norm(a - sites[:, 0, 0:3], dim=-1) < HELD
        self.lifted_ever |= lifted & held
        # a stack ends the episode; the time limit is the base's, a time-out PPO bootstraps (the
        # original flags it a step late and never bootstraps it; the observation has no clock)
        self.reset_buf[:] = stacked.long()
        done = stacked | self.timed_out()
        self.episode_outcomes = {"success_rate": stacked, "lift_rate": self.lifted_ever.clone()}
        self.shares.count(done, **self.episode_outcomes)
        self.compute_observations()

    def metrics(self) -> dict[str, float]:
        """Shares of the last finished episodes (at least num_envs of them) that ended stacked,
        and in which cube A was lifted in the gripper (`EpisodeShares`)."""
        return self.shares.read()

    # ------------------------------------------------------------------ observations
    def compute_observations(self):
        e = self.envs
        a = e.root_states[:, self.cube_a]
        b = e.root_states[:, self.cube_b]
        sites = self.grip_poses()
        joints = e.dof_pos[:, 7:9] if self.control_type == "osc" else e.dof_pos
        self.obs_buf[:] = torch.cat((a[:, 3:7], a[:, 0:3], b[:, 0:3] - a[:, 0:3],
                                     sites[:, 0, 0:3], sites[:, 0, 3:7], joints), dim=-1)

    # ------------------------------------------------------------------ resets
    def reset_idx(self, env_ids):
        done, N, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        e = self.envs
        roots = self.initial_root_states.clone()
        b_xy = self._cube_xy(N)
        # cube A: the first of 100 draws at least 0.17 m (twice the two cubes' half diagonals)
        # from B
        tries = self._cube_xy(N * 100).view(N, 100, 2)
        apart = (tries - b_xy[:, None]).norm(dim=-1) >= (CUBE_A + CUBE_B) \
            * math.sqrt(2)
        first = torch.where(apart.any(dim=1), apart.float().argmax(dim=1), 99)
        a_xy = tries[torch.arange(N, device=dev), first]
        for cube, xy, size in ((self.cube_a, a_xy, CUBE_A),
                               (self.cube_b, b_xy, CUBE_B)):
            roots[:, cube, 0:2] = xy
            roots[:, cube, 2] = TABLE_TOP + size / 2
            yaw = self.rotation_noise * (2.0 * torch.rand(N, device=dev) - 1.0)
            roots[:, cube, 3:7] = quat_from_angle_axis(yaw, unit_axis(roots[:, cube, 0:3], 2))
            roots[:, cube, 7:13] = 0.0
        e.set_root_states(roots, done, forward=False)
        noise = self.dof_noise * (2.0 * torch.rand(N, e.num_dofs, device=dev) - 1.0)
        pos = torch.clamp(self.q_rest + noise, self.dof_lower, self.dof_upper)
        pos[:, 7:9] = FINGER_START
        e.set_dof_state(pos, torch.zeros_like(pos), done)
        self.finger_targets[:] = where_rows(done, pos, self.finger_targets)
        e.set_dof_position_targets(self.finger_targets)
        self.efforts.masked_fill_(done[:, None], 0.0)
        e.set_dof_efforts(self.efforts)
        self.lifted_ever.masked_fill_(done, False)
        self.actions.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)

    def _cube_xy(self, n: int) -> torch.Tensor:
        return self.position_noise * (2.0 * torch.rand(n, 2, device=self.device) - 1.0)

    video_camera = {"lookat": (-0.1, 0.0, 1.2), "distance": 2.0, "elevation": -20.0,
                    "azimuth": 150.0}


def compute_franka_reward(cube_a, cube_b, grip, left_tip, right_tip, size_a, size_b,
                          distRewardScale, liftRewardScale, alignRewardScale,
                          stackRewardScale):
    """(reward, stacked, lifted) of A.2.2 as the original's code computes them."""
    d = torch.norm(cube_a - grip, dim=-1)
    d_l = torch.norm(cube_a - left_tip, dim=-1)
    d_r = torch.norm(cube_a - right_tip, dim=-1)
    reach = 1.0 - torch.tanh(10.0 * (d + d_l + d_r) / 3.0)
    height = cube_a[:, 2] - TABLE_TOP
    lifted = (height - size_a) > 0.04
    above_b = cube_b - cube_a
    above_b[:, 2] += (size_a + size_b) / 2
    align = (1.0 - torch.tanh(10.0 * torch.norm(above_b, dim=-1))) * lifted
    reach = torch.max(reach, align)
    stacked = ((torch.norm((cube_b - cube_a)[:, 0:2], dim=-1) < 0.02)
               & (torch.abs(height - size_b - size_a / 2) < 0.02) & (d > 0.04))
    shaped = distRewardScale * reach + liftRewardScale * lifted + alignRewardScale * align
    reward = torch.where(stacked, stackRewardScale * torch.ones_like(shaped), shaped)
    return reward, stacked, lifted
