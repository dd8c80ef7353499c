"""In-hand reorientation of a cube to goal after goal (seed A.2.3, Tables 10, 11, 14, 15;
reference task-specs §1-§3): the Shadow Hand and the Allegro hand. `ShadowHand` is the standard
task; `ShadowHandOpenAI_FF` and `ShadowHandOpenAI_LSTM` are the same class with their own
configs (20 Hz control, action moving average 0.3, actor observations of Table 11 and the
critic's of Table 10, domain randomization, random forces on the cube). `AllegroHand` is the
Shadow formulation on the Allegro hand (below).

The hand is OpenAI's, from gymnasium-robotics (`myriad.assets.shadow_hand_spec`), fixed at
(0, 0, 0.5) with gravity off (the original's), driven by its own 20 position actuators (kp 1,
the wrist 5); its 24 joints include the four distal joints coupled to their middle joints by
the tendons T_{FF,MF,RF,LF}J1c (limit stiffness 30, damping 0.1). The cube (5 cm, density 567)
starts at (0, -0.39, 0.60) over the palm; the goal is an orientation only, at the fixed target
position (0, -0.39, 0.56).

Actions (20) in [-1, 1]: target = scale(a, lower, upper) of each actuated joint, then
target = α·target + (1 - α)·previous target (α = actionsMovingAverage), clamped to the limits.

Observation "full_state" (211), Table 10 in the original's code order:
    [0:24]     joint positions unscaled to [-1, 1] by their limits
    [24:48]    joint velocities × velObsScale (0.2)
    [48:72]    joint forces × forceTorqueObsScale (10)
    [72:79]    cube position, quaternion (x, y, z, w)
    [79:82]    cube linear velocity
    [82:85]    cube angular velocity × velObsScale
    [85:92]    goal position, quaternion
    [92:96]    q_cube · conj(q_goal)
    [96:161]   five fingertips (ff, mf, rf, lf, th) × [position 3, quaternion 4, linear velocity
               3, angular velocity 3]
    [161:191]  five fingertip force/torque sensors × forceTorqueObsScale
    [191:211]  last actions
Observation "openai" (42), Table 11: fingertip positions 15, cube position 3,
q_cube · conj(q_goal) 4, last actions 20.

Reward, with θ = 2·asin(min(|vector part of q_cube · conj(q_goal)|, 1)) and d = |p_cube - p_goal|:
    distRewardScale·d + rotRewardScale/(|θ| + rotEps) + actionPenaltyScale·Σa²
    + reachGoalBonus when θ ≤ successTolerance (a success: a new goal is drawn, the cube is left
      where it is), + fallPenalty when d ≥ fallDistance (the episode ends).
With maxConsecutiveSuccesses > 0 the episode clock restarts at each success, the episode ends
after that many, and running out of time adds fallPenalty / 2.
`consecutive_successes`: whenever envs finish episodes, cs ← a·(mean successes of those envs) +
(1 - a)·cs with a = averFactor (0.1); the trainer reports it (`metrics`).

Allegro (task-specs §3): Wonik's 16-joint hand of example-robot-data
(`myriad.assets.allegro_hand_spec`), position drives kp 3, kd 0.1 (the joints' only damping, as
Isaac Gym's one per DOF), effort 0.5 N·m, at (0, 0, 0.5) with the palm up and the fingers along
-y, gravity off, its links colliding with each other but not with their parents (the original's
collision filter -1 keeps the URDF loader's filters, which let every link pair collide; PhysX
skips jointed pairs), joint speeds capped at the URDF's 7 rad/s (Isaac Gym applies a URDF's
limits); a 6.5 cm cube (density 400) let go where the original lets it go in its hand, over the
proximal phalanges (0, -0.0659, 0.5636): 5.9 cm out along the fingers from the middle finger's
first joint and 7.0 cm above it, the goal position 4 cm lower. Zero actions target mid-range,
which curls the fingers into a claw that sweeps the cube toward the palm; held straight, the
fingers keep it 2-3 cm from its goal (the original's hand too:
`benchmarks/allegro_original_hand.py`); 30 Hz control; no fingertip terms, so "full_state" is 88
values: joint positions, velocities and forces (16 each), cube pose 7, linear and angular
velocity 6, goal pose 7, relative rotation 4, last actions 16. Reward, success and resets as the
Shadow Hand's.

Deviations from the original: a success draws the new goal in the same step (the original
draws it at the start of the next step), so the observation after a success already shows the
new goal; the goal is not a body in the simulation (the original's goal cube touches nothing
and feels no gravity: it only draws the goal); the original's body damping (Isaac Gym's default
0.5 /s on the cube's rotation, 0.01 on the hand's links) is not applied, as Myriad has no body
damping (on a cube turning at 10 rad/s about 4e-4 N·m, against finger torques up to 0.5 N·m).
Allegro's hand is example-robot-data's (box links, sphere tips, Wonik's joint ranges), not the
original's `allegro_touch_sensor.urdf` (mesh links, sensor tips, wider ranges: the spread joints
±0.558 rad against ±0.47), so an action's target differs by up to 0.044 rad on the fingers and
0.12 rad on the thumb's first two joints.
"""

from __future__ import annotations

import math

import torch

from ..api import Scene
from ..assets import (SHADOW_FINGERTIPS, allegro_hand_spec, allegro_max_velocity,
                      shadow_hand_spec, shadow_hand_tendons)
from ..torch_utils import (angle_between, env_mask, quat_conjugate, quat_from_angle_axis,
                           quat_mul, scale, unit_axis, unscale, where_rows)
from .base import VecTask, box_spec

OBSERVATION_TYPES = ("full_state", "openai")
HAND_POS = (0.0, 0.0, 0.5)


class InHandTask(VecTask):
    """A hand fixed in space turns a cube to random goal orientations; a subclass names the
    hand (`hand_actor`), its fingertips and its cube."""
    fingertips_names: tuple = ()
    cube_size: float
    cube_density: float

    def hand_actor(self, scene: Scene) -> Scene:
        raise NotImplementedError

    def fix_model(self, model) -> None:
        """Changes to the built model that MJCF cannot say (PhysX semantics)."""

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        self.obs_type = env["observationType"]
        if self.obs_type not in OBSERVATION_TYPES or (self.obs_type == "openai"
                                                      and not self.fingertips_names):
            valid = OBSERVATION_TYPES if self.fingertips_names else OBSERVATION_TYPES[:1]
            raise ValueError(f"env.observationType={self.obs_type!r}; valid: {list(valid)}")
        self.asymmetric = bool(env["asymmetric_observations"])
        self.rewards = {k: float(env[k]) for k in (
            "distRewardScale", "rotRewardScale", "rotEps", "actionPenaltyScale",
            "reachGoalBonus", "fallDistance", "fallPenalty", "successTolerance")}
        self.max_consecutive_successes = int(env["maxConsecutiveSuccesses"])
        self.aver_factor = float(env["averFactor"])
        self.moving_average = float(env["actionsMovingAverage"])
        self.vel_obs_scale = float(env["velObsScale"])
        self.force_torque_obs_scale = float(env["forceTorqueObsScale"])
        self.reset_position_noise = float(env["resetPositionNoise"])
        self.reset_dof_pos_noise = float(env["resetDofPosRandomInterval"])
        self.reset_dof_vel_noise = float(env["resetDofVelRandomInterval"])
        self.cube_start = tuple(env["objectStartPos"])
        if not 0.0 < self.moving_average <= 1.0:
            raise ValueError(f"env.actionsMovingAverage={self.moving_average}: must be in (0, 1]")
        super().__init__(cfg, device)

        e, dev, N = self.envs, self.device, self.num_envs
        m = e.model
        limits = e.dof_limits()[0]
        self.dof_lower, self.dof_upper = limits[:, 0], limits[:, 1]
        # the DOF each actuator drives (the hand's 20 position actuators, in the model's order)
        dof_cols = e.dof_columns.tolist()
        self.actuated = torch.tensor([dof_cols.index(int(d)) for d in m.actuator_dof],
                                     device=dev)
        self.cube = e.actor_index("object")

        self.cube_start_pos = torch.tensor(self.cube_start, device=dev)
        self.goal_pos = (self.cube_start_pos - torch.tensor([0.0, 0.0, 0.04], device=dev)
                         ).repeat(N, 1)
        self.goal_rot = torch.zeros(N, 4, device=dev)
        self.goal_rot[:, 3] = 1.0
        self.prev_targets = torch.zeros(N, e.num_dofs, device=dev)
        self.successes = torch.zeros(N, device=dev)
        self.consecutive_successes = torch.zeros((), device=dev)
        self.initial_root_states = e.root_states.clone()
        self.reset()

    # ------------------------------------------------------------------ scene
    def create_envs(self):
        scene = self.hand_actor(Scene().add_ground())
        scene.add_actor("object", box_spec("object", [self.cube_size] * 3, self.cube_density,
                                           rgba=(0.9, 0.5, 0.1, 1.0)),
                        pos=self.cube_start)
        e = scene.build(self.num_envs, self.device, self.sim_params, fix_model=self.fix_model)
        # the observation sizes follow from the hand: Table 10's layout (211 for the Shadow
        # Hand, 88 for Allegro), or Table 11's (42)
        self.fingertips = torch.tensor([e.body_index(f"hand/{t}") for t in self.fingertips_names],
                                       dtype=torch.long, device=e.device)
        self.fingertip_sensors = torch.tensor(
            [e.sensor_index(f"hand/{t}_wrench") for t in self.fingertips_names],
            dtype=torch.long, device=e.device)
        tips = len(self.fingertips_names)
        full = 3 * e.num_dofs + 13 + 11 + 13 * tips + 6 * tips + self.num_actions
        self.num_obs = full if self.obs_type == "full_state" else 3 * tips + 3 + 4 + self.num_actions
        self.num_states = full if self.asymmetric else 0
        return e

    # ------------------------------------------------------------------ step
    def pre_physics_step(self, actions):
        self.actions[:] = actions
        lower, upper = self.dof_lower[self.actuated], self.dof_upper[self.actuated]
        targets = scale(actions, lower, upper)
        targets = (self.moving_average * targets
                   + (1.0 - self.moving_average) * self.prev_targets[:, self.actuated])
        targets = torch.clamp(targets, lower, upper)
        self.prev_targets[:, self.actuated] = targets
        self.envs.sim.ctrl[:] = targets

    def post_physics_step(self):
        cube = self.envs.root_states[:, self.cube]
        self.rew_buf[:], reset, reached, self.successes[:] = compute_hand_reward(
            cube[:, 0:3], cube[:, 3:7], self.goal_pos, self.goal_rot, self.actions,
            self.successes, self.progress_buf, self.max_episode_length,
            self.max_consecutive_successes, **self.rewards)
        self.reset_buf[:] = reset.long()
        if self.max_consecutive_successes > 0:         # each goal gets the whole episode
            self.progress_buf.masked_fill_(reached, 0)
        self._new_goals(reached)
        self._count_finished(reset | self.timed_out())
        self.compute_observations()

    def _new_goals(self, envs: torch.Tensor) -> None:
        self.goal_rot[:] = where_rows(envs, random_orientation(self.num_envs, self.device),
                                      self.goal_rot)

    def _count_finished(self, finished: torch.Tensor) -> None:
        """The original's running average of the successes of envs that finished an episode
        (kept on the device: no step waits for it)."""
        self.episode_outcomes = {"successes": self.successes.clone()}
        count = finished.sum()
        mean = (self.successes * finished).sum() / count.clamp(min=1)
        updated = self.aver_factor * mean + (1.0 - self.aver_factor) * self.consecutive_successes
        self.consecutive_successes = torch.where(count > 0, updated, self.consecutive_successes)

    # the goal drawn beside the hand in videos (the original's goal cube: the target position
    # plus this offset), and a camera on the hand
    goal_display_offset = (-0.2, -0.06, 0.12)
    video_camera = {"lookat": (-0.1, -0.38, 0.58), "distance": 0.5, "elevation": -25.0,
                    "azimuth": 90.0}

    def video_markers(self, env: int = 0) -> list[dict]:
        """An env's goal orientation, as a cube beside the hand (not simulated)."""
        pos = self.goal_pos[env].cpu() + torch.tensor(self.goal_display_offset)
        return [{"type": "box", "size": [self.cube_size / 2] * 3, "pos": pos.tolist(),
                 "quat": self.goal_rot[env].tolist(), "rgba": [0.2, 0.8, 0.3, 0.6]}]

    def metrics(self) -> dict[str, float]:
        """Scalars the trainer reports with each epoch."""
        return {"consecutive_successes": float(self.consecutive_successes)}

    # ------------------------------------------------------------------ observations
    def compute_observations(self):
        e = self.envs
        cube = e.root_states[:, self.cube]
        tips = e.rigid_body_states[:, self.fingertips]                   # [N, 5, 13]
        relative = quat_mul(cube[:, 3:7], quat_conjugate(self.goal_rot))
        if self.obs_type == "openai":
            self.obs_buf[:] = torch.cat((tips[..., 0:3].reshape(self.num_envs, -1),
                                         cube[:, 0:3], relative, self.actions), dim=-1)
        if self.obs_type != "full_state" and not self.num_states:
            return                           # Table 10's layout is not needed
        full = torch.cat((
            unscale(e.dof_pos, self.dof_lower, self.dof_upper),
            self.vel_obs_scale * e.dof_vel,
            self.force_torque_obs_scale * e.dof_forces,
            cube[:, 0:7],
            cube[:, 7:10],
            self.vel_obs_scale * cube[:, 10:13],
            self.goal_pos, self.goal_rot,
            relative,
            tips.reshape(self.num_envs, -1),
            self.force_torque_obs_scale * e.force_sensors[:, self.fingertip_sensors].reshape(
                self.num_envs, -1),
            self.actions,
        ), dim=-1)
        if self.obs_type == "full_state":
            self.obs_buf[:] = full
        if self.num_states:
            self.states_buf[:] = full

    # ------------------------------------------------------------------ resets
    def reset_idx(self, env_ids):
        done, N, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        e = self.envs
        roots = self.initial_root_states.clone()
        noise = self.reset_position_noise * (2.0 * torch.rand(N, 3, device=dev) - 1.0)
        roots[:, self.cube, 0:3] = self.cube_start_pos + noise
        roots[:, self.cube, 3:7] = random_orientation(N, dev)
        roots[:, self.cube, 7:13] = 0.0
        e.set_root_states(roots, done, forward=False)
        # joints: the original's 0.2 of a uniform draw over each range, from the zero pose
        delta = self.dof_lower + (self.dof_upper - self.dof_lower) * torch.rand(
            N, e.num_dofs, device=dev)
        pos = self.reset_dof_pos_noise * delta
        vel = self.reset_dof_vel_noise * (2.0 * torch.rand(N, e.num_dofs, device=dev) - 1.0)
        e.set_dof_state(pos, vel, done)
        self.prev_targets[:] = where_rows(done, pos, self.prev_targets)
        e.sim.ctrl[:] = self.prev_targets[:, self.actuated]
        self._new_goals(done)
        self.successes.masked_fill_(done, 0.0)
        self.actions.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)


def random_orientation(n: int, device) -> torch.Tensor:
    """The original's random rotation R_x(π·u1)·R_y(π·u2), u ~ U(-1, 1) (not uniform on SO(3))."""
    u = 2.0 * torch.rand(n, 2, device=device) - 1.0
    x = unit_axis(torch.zeros(n, 3, device=device), 0)
    y = unit_axis(x, 1)
    return quat_mul(quat_from_angle_axis(math.pi * u[:, 0], x),
                    quat_from_angle_axis(math.pi * u[:, 1], y))


def compute_hand_reward(cube_pos, cube_rot, goal_pos, goal_rot, actions, successes,
                        progress, max_episode_length, max_consecutive_successes,
                        distRewardScale, rotRewardScale, rotEps, actionPenaltyScale,
                        reachGoalBonus, fallDistance, fallPenalty, successTolerance):
    """(reward, episode ends, goal reached, successes) as the seed's A.2.3 and the original's
    code: position and orientation terms, an action penalty, the success bonus and the fall
    penalty."""
    distance = torch.norm(cube_pos - goal_pos, dim=-1)
    angle = angle_between(cube_rot, goal_rot)
    reward = (distRewardScale * distance + rotRewardScale / (torch.abs(angle) + rotEps)
              + actionPenaltyScale * torch.sum(actions ** 2, dim=-1))
    reached = torch.abs(angle) <= successTolerance
    successes = successes + reached.float()
    reward = reward + reachGoalBonus * reached.float()
    fell = distance >= fallDistance
    reward = reward + fallPenalty * fell.float()
    ends = fell
    if max_consecutive_successes > 0:
        ends = ends | (successes >= max_consecutive_successes)
        timed_out = (progress >= max_episode_length) & ~reached
        reward = reward + 0.5 * fallPenalty * timed_out.float()
    return reward, ends, reached, successes


class ShadowHand(InHandTask):
    num_actions = 20
    fingertips_names = tuple(f"robot0:{t}" for t in SHADOW_FINGERTIPS)
    cube_size, cube_density = 0.05, 567.0

    def hand_actor(self, scene: Scene) -> Scene:
        return scene.add_actor("hand", shadow_hand_spec(), pos=HAND_POS, quat=None,
                               fix_base=True, dof_mode="none", gravity=False)

    def fix_model(self, model) -> None:
        shadow_hand_tendons(model)


class AllegroHand(InHandTask):
    num_actions = 16
    cube_size, cube_density = 0.065, 400.0
    video_camera = {"lookat": (-0.03, -0.06, 0.55), "distance": 0.5, "elevation": -30.0,
                    "azimuth": 150.0}     # from the thumb's side, onto the cube over the fingers

    def hand_actor(self, scene: Scene) -> Scene:
        y, x, z = (torch.tensor([[0.0, 1.0, 0.0]]), torch.tensor([[1.0, 0.0, 0.0]]),
                   torch.tensor([[0.0, 0.0, 1.0]]))
        # the original's R_y(π)·R_x(0.47π)·R_z(π/4) turns its own URDF's palm up; this URDF's
        # palm frame sits a quarter turn further about the fingers' axis, so -π/2 here
        turn = quat_mul(quat_mul(quat_from_angle_axis(torch.tensor([math.pi]), y),
                                 quat_from_angle_axis(torch.tensor([0.47 * math.pi]), x)),
                        quat_from_angle_axis(torch.tensor([-0.5 * math.pi]), z))[0]
        control = self.cfg["env"]["control"]
        # self-collisions on: the original's filter -1 keeps its URDF loader's filters (all 0),
        # so its fingers block each other and the thumb
        return scene.add_actor("hand", allegro_hand_spec(), pos=HAND_POS,
                               quat=tuple(turn.tolist()), fix_base=True, dof_mode="position",
                               stiffness=control["stiffness"], damping=control["damping"],
                               gravity=False)

    def dof_speed_limits(self) -> list[float]:
        """Each hand DOF's speed cap (rad/s): the URDF's (7), which Isaac Gym applies and
        MuJoCo's importer drops; from straight to mid-range targets the fingers curl at most
        this fast."""
        return allegro_max_velocity(self.envs.dof_names)
