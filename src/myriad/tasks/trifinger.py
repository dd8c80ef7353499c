"""Trifinger: the three fingers of a TriFinger Pro move a cube to a goal position and orientation
(seed A.2.3, Tables 12, 13; reference task-specs §4, the original's trifinger.py at difficulty 4,
the setup whose policy went to the real robot).

The scene, in env coordinates: the robot of robot-properties-fingers (`myriad.assets.
trifinger_spec`) fixed at the origin, its fingers hanging from 0.29 m; a table, friction 0.1, whose
top is the floor z = 0 (a plane, drawn 0.71 × 0.76 m); the arena's wall round it (inner radius
0.195 m at the floor, 0.175 m high, `trifinger_boundary_spec`); the cube (6.5 cm, 0.08 kg,
friction 1). Physics: 0.02 s per step in 4 substeps (50 Hz control), TGS 8 + 0.

Actions (9) in [-1, 1], torques: τ = 0.36·a, clamped to ±0.36 N·m, less a safety damping
(0.08, 0.08, 0.04)·q̇ per finger, clamped again. The joints' speed is capped at 10 rad/s (PhysX's
maximum joint velocity, as the original sets it).

Observation (41, each value mapped to [-1, 1]; Table 12, the original's code order):
    [0:9]    joint positions, unscaled by the joint limits (per finger: [-0.33, 1.0], [0, 1.57],
             [-2.7, 0])
    [9:18]   joint velocities / 10 rad/s
    [18:25]  cube position (x, y / 0.3; z unscaled from [0, 0.3]), quaternion (x, y, z, w)
    [25:32]  goal position (as the cube's), quaternion
    [32:41]  last actions
Critic states (113, Table 13): the 41 above (without the observation noise), the cube's linear
and angular velocity 6, the three fingertips' position, quaternion, linear and angular velocity
(3 × 13), the joint torques 9 and the fingertips' force/torque sensors (3 × 6).

Reward per step, with f_i the fingertips, c the cube, dt = 0.02:
    finger movement: fingerMovePenalty (-0.5) · Σ_i ‖(f_i,t − f_i,t−1)/dt‖²
    reach rate:      fingerReachObjectRate (-250) · Σ_i (‖f_i,t − c_t‖ − ‖f_i,t−1 − c_t−1‖),
                     only while env steps × num_envs ≤ reachStepsThreshold (5e7)
    pose, "keypoints" (the original's config): poseWeight (2000) · dt · mean over the cube's 8
                     corners of K_30(‖k_cube − k_goal‖), K_a(x) = 1 / (e^(a·x) + 2 + e^(−a·x))
    pose, "position_rotation" (the paper's formula): poseWeight · dt · K_50(‖p − p*‖)
                     + poseWeight · dt / (3·|θ| + 0.01), θ the angle between the orientations
An episode lasts 750 steps (15 s) and has no early end: it ends in a time-out, which PPO
bootstraps. `success_rate` (progress line, TensorBoard, summary.json): the share of the last
finished episodes (at least num_envs) whose cube ended within 2 cm and 0.4 rad of the goal (2 cm
alone below difficulty 4).

Resets: the fingers at (0, 0.9, -2.0) each, at rest; the cube on the floor at a uniform point of
the disk of radius 0.195 − 0.0563 (the arena less the cube's half diagonal), turned about z
uniformly; the goal at a uniform point of that disk, 0.0563-0.1 m high, uniformly oriented
(`difficulty` 4, the default; the original's easier goals -1 to 3 are `DIFFICULTIES`).
Domain randomization (cfg `randomization`): observation and action noise, gravity, the joint
limits, the cube's size, mass and friction, the table's friction.

Deviations from the original, on purpose: the links collide as one convex hull each (64
corners), not V-HACD's decompositions; the wall is 32 convex sectors of its mesh; no restitution
on the fingers (PhysX 0.8); the table's top reaches past its
edges (a cube thrown over the wall lands beyond it); no extra physics step after a reset.
"""

from __future__ import annotations

import math

import mujoco
import torch

from ..api import Scene
from ..assets import (TRIFINGER_ANGLES, TRIFINGER_ARENA_RADIUS, trifinger_boundary_spec,
                      trifinger_spec)
from ..torch_utils import (angle_between, env_mask, quat_from_angle_axis, quat_rotate,
                           unit_axis, unscale, where_rows)
from .base import EpisodeShares, VecTask, box_spec

POSE_FORMS = ("keypoints", "position_rotation")
# the original's goal difficulties: goal position (and orientation) drawn at each reset
DIFFICULTIES = {
    -1: "on the table, turned about z",
    1: "on the table, not turned",
    2: "fixed 5 cm above the cube's resting height at the centre, not turned",
    3: "in the air (resting height to 0.1 m), not turned",
    4: "in the air (half diagonal to 0.1 m), any orientation (success needs it too)",
}
JOINT_LOWER = (-0.33, 0.0, -2.7)          # per finger (rad)
JOINT_UPPER = (1.0, 1.57, 0.0)
JOINT_START = (0.0, 0.9, -2.0)
MAX_VELOCITY = 10.0                       # rad/s: the joints' speed cap, the observation's scale
MAX_TORQUE = 0.36                         # N·m
SAFETY_DAMPING = (0.08, 0.08, 0.04)       # N·m·s/rad, per finger joint
TABLE_SIZE = (0.71, 0.76)                 # m, as drawn: the plane z = 0 is unbounded
TABLE_FRICTION = 0.1
POSITION_BOUND = (0.3, 0.3, 0.3)          # |x|, |y| ≤ 0.3; 0 ≤ z ≤ 0.3 (m)


class Trifinger(VecTask):
    num_actions = 9
    num_obs = 41
    checkpointed = ("steps_taken", )     # the reach term's schedule

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        self.num_states = 113 if env["asymmetric_obs"] else 0
        self.cube_size = float(env["cubeSize"])
        self.cube_density = float(env["cubeDensity"])
        self.pose_form = env["poseRewardForm"]
        self.difficulty = env["difficulty"]
        if self.difficulty not in DIFFICULTIES:
            raise ValueError(f"env.difficulty={env['difficulty']!r}; valid: "
                             + "; ".join(f"{k} ({v})" for k, v in DIFFICULTIES.items()))
        if self.pose_form not in POSE_FORMS:
            raise ValueError(f"env.poseRewardForm={self.pose_form!r}; valid: {list(POSE_FORMS)}")
        self.rewards = {k: float(env[k]) for k in (
            "fingerMovePenalty", "fingerReachObjectRate", "poseWeight", "keypointsKernelScale",
            "positionKernelScale")}
        self.reach_steps = float(env["reachStepsThreshold"])
        self.position_tolerance = float(env["successPositionTolerance"])
        # below difficulty 4 the goal's orientation is not part of the task (the original)
        self.orientation_tolerance = (float(env["successOrientationTolerance"])
                                      if self.difficulty == 4 else math.inf)
        super().__init__(cfg, device)

        e, dev, N = self.envs, self.device, self.num_envs
        self.joint_lower = torch.tensor(JOINT_LOWER * 3, device=dev)
        self.joint_upper = torch.tensor(JOINT_UPPER * 3, device=dev)
        self.joint_start = torch.tensor(JOINT_START * 3, device=dev)
        self.safety_damping = torch.tensor(SAFETY_DAMPING * 3, device=dev)
        upper = torch.tensor(POSITION_BOUND, device=dev)
        self.position_bounds = (upper * torch.tensor([-1.0, -1.0, 0.0], device=dev), upper)
        self.cube = e.actor_index("object")
        self.fingertips = torch.tensor([e.body_index(f"robot/finger_tip_link_{a}")
                                        for a in TRIFINGER_ANGLES], device=dev)
        self.fingertip_sensors = torch.tensor([e.sensor_index(f"robot/finger_tip_{a}_wrench")
                                               for a in TRIFINGER_ANGLES], device=dev)
        self.torques = torch.zeros(N, e.num_dofs, device=dev)
        self.goal_pos = torch.zeros(N, 3, device=dev)
        self.goal_rot = torch.zeros(N, 4, device=dev)
        self.prev_tips = torch.zeros(N, 3, 3, device=dev)
        self.prev_cube = torch.zeros(N, 3, device=dev)
        # the cube's distance to its goal (m) as the last step ended, before any reset: what
        # `myriad eval` reads of an episode's end
        self.goal_distance = torch.zeros(N, device=dev)
        # env steps since the task was built (the reach term's schedule), on the device: a step
        # captured once as a CUDA graph reads it where it is at every replay
        self.steps_taken = torch.zeros((), dtype=torch.int64, device=dev)
        self.shares = EpisodeShares(("success_rate",), N, dev)
        self.initial_root_states = e.root_states.clone()
        self.reset()

    # ------------------------------------------------------------------ scene
    def create_envs(self):
        # the table's top as a plane (drawn 0.71 × 0.76 m): a box would put every finger link
        # inside its bounding sphere, and through a convex-convex test each substep
        table = mujoco.MjSpec()
        table.worldbody.add_body(name="table").add_geom(
            name="table", type=mujoco.mjtGeom.mjGEOM_PLANE,
            size=[TABLE_SIZE[0] / 2, TABLE_SIZE[1] / 2, 0.01],
            friction=[TABLE_FRICTION, 0.005, 0.0001], rgba=[0.75, 0.75, 0.72, 1.0])
        scene = (Scene()
                 .add_actor("robot", trifinger_spec(), pos=(0.0, 0.0, 0.0), fix_base=True)
                 .add_actor("table", table, pos=(0.0, 0.0, 0.0), fix_base=True)
                 .add_actor("boundary", trifinger_boundary_spec(), pos=(0.0, 0.0, 0.0),
                            fix_base=True)
                 .add_actor("object", box_spec("object", [self.cube_size] * 3,
                                               self.cube_density, rgba=(0.9, 0.5, 0.1, 1.0)),
                            pos=(0.0, 0.0, self.cube_size / 2)))
        return scene.build(self.num_envs, self.device, self.sim_params)

    def dof_speed_limits(self) -> float:
        return MAX_VELOCITY             # the motors' 10 rad/s

    # ------------------------------------------------------------------ step
    def pre_physics_step(self, actions):
        self.actions[:] = actions
        tau = torch.clamp(MAX_TORQUE * actions, -MAX_TORQUE, MAX_TORQUE)
        tau = tau - self.safety_damping * self.envs.dof_vel
        self.torques[:] = torch.clamp(tau, -MAX_TORQUE, MAX_TORQUE)
        self.envs.set_dof_efforts(self.torques)

    def post_physics_step(self):
        e = self.envs
        self.steps_taken += 1
        cube = e.root_states[:, self.cube]
        tips = e.rigid_body_states[:, self.fingertips, 0:3]
        reach_active = self.steps_taken * self.num_envs <= self.reach_steps
        self.rew_buf[:] = compute_trifinger_reward(
            tips, self.prev_tips, cube[:, 0:3], cube[:, 3:7], self.prev_cube, self.goal_pos,
            self.goal_rot, self.dt, reach_active, self.cube_size, self.pose_form, **self.rewards)
        self.prev_tips[:] = tips
        self.prev_cube[:] = cube[:, 0:3]
        # episodes end only at the time limit, which the base reports in `time_outs` (PPO
        # bootstraps it: the actor's observation has no clock)
        self.reset_buf.zero_()
        done = self.timed_out()
        success = reached_goal(cube[:, 0:3], cube[:, 3:7], self.goal_pos, self.goal_rot,
                               self.position_tolerance, self.orientation_tolerance)
        self.episode_outcomes = {"success_rate": success}
        self.goal_distance[:] = torch.norm(cube[:, 0:3] - self.goal_pos, dim=-1)
        self.shares.count(done, **self.episode_outcomes)
        self.compute_observations()

    def metrics(self) -> dict[str, float]:
        """The share of the last finished episodes (at least num_envs of them) whose cube ended
        at the goal (`EpisodeShares`)."""
        return self.shares.read()

    # ------------------------------------------------------------------ observations
    def compute_observations(self):
        e = self.envs
        cube = e.root_states[:, self.cube]
        lower, upper = self.position_bounds
        self.obs_buf[:] = torch.cat((
            unscale(e.dof_pos, self.joint_lower, self.joint_upper),
            e.dof_vel / MAX_VELOCITY,
            unscale(cube[:, 0:3], lower, upper), cube[:, 3:7],
            unscale(self.goal_pos, lower, upper), self.goal_rot,
            self.actions), dim=-1)
        if self.num_states:
            N = self.num_envs
            self.states_buf[:] = torch.cat((
                self.obs_buf,
                cube[:, 7:13],
                e.rigid_body_states[:, self.fingertips].reshape(N, -1),
                e.dof_forces,
                e.force_sensors[:, self.fingertip_sensors].reshape(N, -1)), dim=-1)

    # ------------------------------------------------------------------ resets
    def reset_idx(self, env_ids):
        done, N, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        e = self.envs
        roots = self.initial_root_states.clone()
        half_diagonal = self.cube_size * math.sqrt(3) / 2
        spawn = TRIFINGER_ARENA_RADIUS - half_diagonal
        roots[:, self.cube, 0:2] = disk_points(N, spawn, dev)
        roots[:, self.cube, 2] = self.cube_size / 2 + 0.0015
        yaw = 2 * math.pi * torch.rand(N, device=dev)
        roots[:, self.cube, 3:7] = quat_from_angle_axis(yaw, unit_axis(roots[:, self.cube, 0:3],
                                                                       2))
        roots[:, self.cube, 7:13] = 0.0
        e.set_root_states(roots, done, forward=False)
        pos = self.joint_start.expand(N, -1)
        e.set_dof_state(pos, torch.zeros_like(pos), done)
        goal_pos, goal_rot = self.sample_goals(N, spawn)
        self.goal_pos[:] = where_rows(done, goal_pos, self.goal_pos)
        self.goal_rot[:] = where_rows(done, goal_rot, self.goal_rot)
        self.prev_tips[:] = where_rows(done, e.rigid_body_states[:, self.fingertips, 0:3],
                                       self.prev_tips)
        self.prev_cube[:] = where_rows(done, e.root_states[:, self.cube, 0:3], self.prev_cube)
        self.torques.masked_fill_(done[:, None], 0.0)
        e.set_dof_efforts(self.torques)
        self.actions.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)

    def sample_goals(self, n: int, radius: float) -> tuple[torch.Tensor, torch.Tensor]:
        """[n, 3] goal positions and [n, 4] orientations at `difficulty` (`DIFFICULTIES`), in the
        disk of `radius` where the goal's position varies."""
        dev, rest = self.device, self.cube_size / 2
        pos = torch.cat((disk_points(n, radius, dev), torch.full((n, 1), rest, device=dev)), -1)
        rot = unit_axis(torch.zeros(n, 4, device=dev), 3)            # identity (x, y, z, w)
        if self.difficulty == -1:
            rot = quat_from_angle_axis(2 * math.pi * torch.rand(n, device=dev), unit_axis(pos, 2))
        elif self.difficulty == 2:
            pos[:, 0:2] = 0.0
            pos[:, 2] += 0.05
        elif self.difficulty == 3:
            pos[:, 2] += (0.1 - rest) * torch.rand(n, device=dev)
        elif self.difficulty == 4:
            half_diagonal = self.cube_size * math.sqrt(3) / 2   # clear of the floor when turned
            pos[:, 2] = half_diagonal + (0.1 - half_diagonal) * torch.rand(n, device=dev)
            rot = uniform_orientation(n, dev)
        return pos, rot

    # videos: the goal drawn where it is, as a see-through cube, and a camera on the arena
    video_camera = {"lookat": (0.0, 0.0, 0.06), "distance": 0.75, "elevation": -40.0,
                    "azimuth": 60.0}

    def video_markers(self, env: int = 0) -> list[dict]:
        """An env's goal pose, as a see-through cube (not simulated)."""
        return [{"type": "box", "size": [self.cube_size / 2] * 3,
                 "pos": self.goal_pos[env].tolist(), "quat": self.goal_rot[env].tolist(),
                 "rgba": [0.2, 0.8, 0.3, 0.4]}]


def disk_points(n: int, radius: float, device) -> torch.Tensor:
    """[n, 2] points uniform in the disk of `radius` about the origin."""
    r = radius * torch.sqrt(torch.rand(n, device=device))
    phi = 2 * math.pi * torch.rand(n, device=device)
    return torch.stack((r * torch.cos(phi), r * torch.sin(phi)), dim=-1)


def uniform_orientation(n: int, device) -> torch.Tensor:
    """[n, 4] rotations uniform on SO(3): normalized 4-D Gaussian samples."""
    q = torch.randn(n, 4, device=device)
    return q / q.norm(dim=-1, keepdim=True).clamp(min=1e-12)


def logistic_kernel(x: torch.Tensor, scale: float) -> torch.Tensor:
    """K(x) = 1 / (e^(scale·x) + 2 + e^(−scale·x)): 0.25 at x = 0, falling off over ~1/scale."""
    sx = scale * x
    return 1.0 / (torch.exp(sx) + 2.0 + torch.exp(-sx))


def cube_corners(pos: torch.Tensor, rot: torch.Tensor, size: float) -> torch.Tensor:
    """[N, 8, 3] the corners of cubes of edge `size` at `pos` [N, 3], turned by `rot` [N, 4]."""
    # corner k's sign along axis i is bit i of k (made on the device: no host data per step)
    bits = torch.arange(8, device=pos.device)[:, None] >> torch.arange(3, device=pos.device)
    signs = (bits & 1).to(pos.dtype) * 2.0 - 1.0
    local = 0.5 * size * signs.expand(pos.shape[0], 8, 3)
    return pos[:, None] + quat_rotate(rot[:, None].expand(-1, 8, 4).reshape(-1, 4),
                                      local.reshape(-1, 3)).view(-1, 8, 3)


def reached_goal(cube_pos, cube_rot, goal_pos, goal_rot, position_tolerance,
                 orientation_tolerance) -> torch.Tensor:
    """The cube within `position_tolerance` (m) and `orientation_tolerance` (rad) of the goal."""
    angle = angle_between(cube_rot, goal_rot)
    return ((torch.norm(cube_pos - goal_pos, dim=-1) <= position_tolerance)
            & (torch.abs(angle) <= orientation_tolerance))


def compute_trifinger_reward(tips, prev_tips, cube_pos, cube_rot, prev_cube_pos, goal_pos,
                             goal_rot, dt, reach_active, cube_size, pose_form,
                             fingerMovePenalty, fingerReachObjectRate, poseWeight,
                             keypointsKernelScale, positionKernelScale):
    """The reward of A.2.3 as the original's code computes it (module docstring): `tips`,
    `prev_tips` [N, 3, 3] fingertip positions now and a step ago, the cube's position now and a
    step ago, its orientation, and the goal pose."""
    speed = (tips - prev_tips) / dt
    reward = fingerMovePenalty * speed.pow(2).sum(dim=(1, 2))
    # reach_active: a bool tensor (the schedule is decided on the device)
    now = torch.norm(tips - cube_pos[:, None], dim=-1)
    before = torch.norm(prev_tips - prev_cube_pos[:, None], dim=-1)
    reward = reward + torch.where(reach_active, fingerReachObjectRate * (now - before).sum(dim=-1),
                                  0.0)
    if pose_form == "keypoints":
        gap = torch.norm(cube_corners(cube_pos, cube_rot, cube_size)
                         - cube_corners(goal_pos, goal_rot, cube_size), dim=-1)
        reward = reward + poseWeight * dt * logistic_kernel(gap, keypointsKernelScale).mean(-1)
    else:
        angle = angle_between(cube_rot, goal_rot)
        distance = torch.norm(cube_pos - goal_pos, dim=-1)
        reward = (reward + poseWeight * dt * logistic_kernel(distance, positionKernelScale)
                  + poseWeight * dt / (3.0 * torch.abs(angle) + 0.01))
    return reward
