"""HumanoidAMP's observation (seed Table 8; reference task-specs §7), shared by the policy and
the discriminator: one frame of the humanoid, 105 numbers, in the original code's layout (the
paper's Table 8 counts 108, with 15 key-point values where the code has 4 key bodies):

    [0]        root height (m)
    [1:7]      root rotation, world: the rotated x and z axes ("tan-norm")
    [7:10]     root linear velocity in the heading frame (yaw only)
    [10:13]    root angular velocity in the heading frame
    [13:65]    DoF positions: each 3-DoF joint's three values read as an exponential map, as the
               tan-norm of that rotation (8 × 6), each hinge's angle (4 × 1), in the model's order
    [65:93]    DoF velocities (28), as they are
    [93:105]   hands and feet relative to the root, in the heading frame (4 × 3)

The AMP observation of a step is this frame and the one before it (210); `myriad train` trains
the task with the AMP agent (`myriad.rl.amp`).
"""

from __future__ import annotations

from itertools import accumulate

import torch

from ..api import Scene
from ..assets import (AMP_DOFS, AMP_KEY_BODIES, AMP_START_HEIGHT, amp_humanoid_gains,
                      amp_humanoid_spec)
from ..torch_utils import (env_mask, exp_map_to_quat, quat_from_angle_axis, quat_rotate,
                           unit_axis, where_rows)
from .base import VecTask

# (width, start) of each joint's DoF in the model's order: 3 for spherical joints, 1 for hinges
_WIDTHS = [width for _, width in AMP_DOFS]
DOF_GROUPS = list(zip(_WIDTHS, accumulate([0] + _WIDTHS)))
NUM_DOF = sum(_WIDTHS)                               # 28
NUM_OBS = 1 + 6 + 3 + 3 + sum(6 if w == 3 else 1 for w, _ in DOF_GROUPS) + NUM_DOF + 4 * 3   # 105


def heading_inverse(rot: torch.Tensor) -> torch.Tensor:
    """The rotation about z that undoes `rot`'s heading (the yaw of its x axis)."""
    x_axis = quat_rotate(rot, unit_axis(rot[..., :3], 0))
    heading = torch.atan2(x_axis[..., 1], x_axis[..., 0])
    return quat_from_angle_axis(-heading, unit_axis(x_axis, 2))


def tan_norm(rot: torch.Tensor) -> torch.Tensor:
    """[..., 6]: the rotated x axis and z axis, a continuous code of a rotation."""
    like = rot[..., :3]
    return torch.cat([quat_rotate(rot, unit_axis(like, 0)), quat_rotate(rot, unit_axis(like, 2))],
                     dim=-1)


def amp_observations(root_pos, root_rot, root_vel, root_ang_vel, dof_pos, dof_vel,
                     key_pos) -> torch.Tensor:
    """The 105-number frame [n, 105] (layout in the module's docstring); quaternions (x, y, z, w),
    key_pos [n, 4, 3] world."""
    heading = heading_inverse(root_rot)
    dof_obs = [tan_norm(exp_map_to_quat(dof_pos[:, s:s + 3])) if w == 3 else dof_pos[:, s:s + 1]
               for w, s in DOF_GROUPS]
    local_keys = quat_rotate(heading[:, None].expand(-1, key_pos.shape[1], -1),
                             key_pos - root_pos[:, None])
    return torch.cat([root_pos[:, 2:3], tan_norm(root_rot), quat_rotate(heading, root_vel),
                      quat_rotate(heading, root_ang_vel), *dof_obs, dof_vel,
                      local_keys.reshape(len(root_pos), -1)], dim=-1)


def clip_observations(state) -> torch.Tensor:
    """The frame [n, 105] of clip states (`motion.MotionState`)."""
    return amp_observations(state.root_pos, state.root_rot, state.root_vel, state.root_ang_vel,
                            state.dof_pos, state.dof_vel, state.key_pos)


STATE_INITS = ("Default", "Start", "Random", "Hybrid")


class HumanoidAMP(VecTask):
    """The AMP humanoid imitating motion clips' style: actions are PD targets (3-DoF joints
    ±π, hinges their range's middle ± 0.7 × range), the task reward is 1, and each step leaves
    the AMP observation pair (this frame, the one before) in `extras["amp_obs"]` for the
    discriminator, whose demo pairs `fetch_amp_obs_demo` draws from the clips.

    Resets (`env.stateInit`): Default stands the humanoid at the origin, pelvis 0.89 m up, every
    joint at 0 (the clips' rest pose: arms down); Start and Random take a clip's state at its
    start or at a random time; Hybrid picks Random with probability `hybridInitProb`, else
    Default. An episode ends early when a body other than the feet touches the ground while
    below `terminationHeight` (from the second step on)."""

    num_obs = NUM_OBS
    num_actions = NUM_DOF
    # the clip a policy learned: play, eval and a resumed run restore it from the checkpoint
    # (a walk policy started from the default run clip's poses would be judged on another task)
    checkpointed = ("motion_file",)

    def __init__(self, cfg: dict, device: str = "cpu"):
        env = cfg["env"]
        if env["stateInit"] not in STATE_INITS:
            raise ValueError(f"env.stateInit={env['stateInit']!r}: expected one of {STATE_INITS}")
        self.state_init = env["stateInit"]
        self.hybrid_init_prob = float(env["hybridInitProb"])
        self.termination_height = float(env["terminationHeight"])
        self.device = device
        self.motion_file = env["motion_file"]
        super().__init__(cfg, device)
        e, dev = self.envs, self.device
        self.key_bodies = torch.tensor([e.body_index(f"humanoid/{b}") for b in AMP_KEY_BODIES],
                                       device=dev)
        feet = [e.body_index(f"humanoid/{b}") for b in ("right_foot", "left_foot")]
        self.non_feet = torch.tensor([b for b in range(e.num_bodies)
                                      if b not in feet and e.body_names[b].startswith("humanoid/")],
                                     device=dev)
        lower, upper = e.dof_limits()[0].T
        three = torch.tensor([w == 3 for w, s in DOF_GROUPS for _ in range(w)], device=dev)
        self.pd_offset = torch.where(three, 0.0, 0.5 * (lower + upper))
        self.pd_scale = torch.where(three, torch.pi, 0.7 * (upper - lower))
        self.amp_obs = torch.zeros(self.num_envs, 2, NUM_OBS, device=dev)
        self.episode_outcomes["fell"] = torch.zeros(self.num_envs, dtype=torch.bool, device=dev)
        self.default_root = e.root_states.clone()
        self.reset()

    @property
    def motion_file(self) -> str:
        """The clip (a name or a path) the resets and the discriminator's demos come from."""
        return self._motion_file

    @motion_file.setter
    def motion_file(self, clip: str) -> None:
        from .motion import MotionLib

        if clip == getattr(self, "_motion_file", None):
            return
        if hasattr(self, "_motion_file"):
            print(f"HumanoidAMP: the checkpoint was trained on the clip {clip!r}: its episodes "
                  f"start from it (not {self._motion_file!r})", flush=True)
        self.motion = MotionLib([clip], device=self.device)
        self._motion_file = str(clip)

    def create_envs(self):
        plane = self.cfg["env"]["plane"]
        scene = Scene().add_ground(friction=plane["staticFriction"],
                                   restitution=plane["restitution"])
        stiffness, damping = amp_humanoid_gains()
        scene.add_actor("humanoid", amp_humanoid_spec(), pos=(0.0, 0.0, AMP_START_HEIGHT),
                        dof_mode="position", stiffness=stiffness, damping=damping)
        return scene.build(self.num_envs, self.device, self.sim_params)

    def pre_physics_step(self, actions):
        self.actions[:] = actions
        self.envs.set_dof_position_targets(self.pd_offset + self.pd_scale * actions)

    def post_physics_step(self):
        self.compute_observations()
        e = self.envs
        self.rew_buf[:] = 1.0
        body = e.rigid_body_states[:, self.non_feet]
        touching = (e.net_contact_force[:, self.non_feet].abs() > 0.1).any(dim=-1)
        fallen = (touching & (body[..., 2] < self.termination_height)).any(dim=-1)
        terminated = fallen & (self.progress_buf > 1)
        self.reset_buf[:] = terminated.long()
        self.episode_outcomes["fell"] = terminated
        self.amp_obs[:, 1] = self.amp_obs[:, 0]
        self.amp_obs[:, 0] = self.obs_buf
        # a copy: the reset that may follow in this step rewrites the history in place
        self.extras["amp_obs"] = self.amp_obs.reshape(self.num_envs, -1).clone()

    def compute_observations(self):
        e = self.envs
        root = e.root_states[:, 0]
        self.obs_buf[:] = amp_observations(
            root[:, 0:3], root[:, 3:7], root[:, 7:10], root[:, 10:13], e.dof_pos, e.dof_vel,
            e.rigid_body_states[:, self.key_bodies, 0:3])

    def reset_idx(self, env_ids):
        done, n, dev = env_mask(env_ids, self.num_envs), self.num_envs, self.device
        clips = self.motion.sample_clips(n)
        times = self.motion.sample_times(clips) if self.state_init in ("Random", "Hybrid") \
            else torch.zeros(n, device=dev)
        from_clip = torch.full((n,), self.state_init != "Default", device=dev)
        if self.state_init == "Hybrid":
            from_clip = torch.rand(n, device=dev) < self.hybrid_init_prob
        clip = self.motion.state(clips, times)
        root = torch.cat([clip.root_pos, clip.root_rot, clip.root_vel, clip.root_ang_vel], -1)
        root = where_rows(from_clip, root[:, None], self.default_root)
        zeros = torch.zeros(n, NUM_DOF, device=dev)
        self.envs.set_root_states(root, done, forward=False)
        self.envs.set_dof_state(where_rows(from_clip, clip.dof_pos, zeros),
                                where_rows(from_clip, clip.dof_vel, zeros), done)
        # the AMP history: a clip reset's previous frame from the clip; a default reset's is
        # its first frame repeated (filled by the first step's shift)
        history = clip_observations(self.motion.state(clips, times - self.dt))
        self.compute_observations()
        self.amp_obs[:, 0] = torch.where(done[:, None], self.obs_buf, self.amp_obs[:, 0])
        self.amp_obs[:, 1] = torch.where((done & from_clip)[:, None], history,
                                         torch.where(done[:, None], self.obs_buf,
                                                     self.amp_obs[:, 1]))
        self.actions.masked_fill_(done[:, None], 0.0)
        self.progress_buf.masked_fill_(done, 0)

    def fetch_amp_obs_demo(self, n: int) -> torch.Tensor:
        """n demo AMP observation pairs [n, 210] (a clip's frame at a random time and the frame
        one control step earlier)."""
        clips = self.motion.sample_clips(n)
        times = self.motion.sample_times(clips)
        return torch.cat([clip_observations(self.motion.state(clips, times - k * self.dt))
                          for k in (0, 1)], -1)
