"""Motion clips for Adversarial Motion Priors: DeepMimic's humanoid clips, read into the AMP
humanoid's coordinates (`myriad.assets.amp_humanoid_spec`: metric, z-up, 28 DoF) and sampled at
any time (reference task-specs §7, "Motion lib").

A clip file is DeepMimic's JSON: {"Loop": ..., "Frames": [[dt, root position (3), root rotation
(w, x, y, z), then per joint a rotation (w, x, y, z) or, for knees and elbows, an angle], ...]}
in DeepMimic's joint order, y-up. pybullet's package ships 15 of them (`clip_path("walk")`).

Sampling follows the original's motion library: a clip by weight, a time uniform over the clip;
the frames f0 = ⌊phase·(frames−1)⌋ and f1 = f0 + 1 around it; positions (root, key bodies)
interpolated linearly, rotations (root, joints) spherically; velocities those of f0. Each
3-DoF joint's position is the exponential map (axis·angle) of its rotation in its parent's frame,
its velocity the finite difference of those rotations (the last frame repeats the one before).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass

import numpy as np
import torch

from ..assets import (AMP_BODIES, AMP_HINGES, AMP_KEY_BODIES, amp_humanoid_spec, installed_file,
                      y_up_to_z_up)
from ..physics import ModelError
from ..torch_utils import (quat_conjugate, quat_from_angle_axis, quat_mul, quat_rotate,
                           quat_to_exp_map, slerp)

# DeepMimic's joint order in a frame, after dt, root position and root rotation
CLIP_JOINTS = ("abdomen", "neck", "right_hip", "right_knee", "right_ankle", "right_shoulder",
               "right_elbow", "left_hip", "left_knee", "left_ankle", "left_shoulder", "left_elbow")
HINGES = AMP_HINGES
FRAME_SIZE = 1 + 3 + 4 + sum(1 if j in HINGES else 4 for j in CLIP_JOINTS)     # 44


def clip_path(name: str) -> str:
    """A clip of pybullet's package by name ("walk", "run", "backflip", ...), or a file path."""
    if os.sep in name or name.endswith((".txt", ".json")):
        return name
    return installed_file("pybullet_data", f"data/motions/humanoid3d_{name}.txt", "amp")


def read_clip(path: str) -> tuple[float, np.ndarray]:
    """(frame time in s, frames [F, 43]) of a DeepMimic clip file, checked."""
    if not os.path.isfile(path):
        raise ModelError(f"{path}: no such motion file (motion_file= takes a path or one of "
                         "pybullet's clip names: walk, run, jump, backflip, ...)")
    try:
        with open(path) as f:
            frames = json.load(f)["Frames"]
        frames = np.asarray(frames, dtype=np.float64)
    except (ValueError, KeyError, TypeError) as err:
        raise ModelError(f"{path}: not a DeepMimic motion file ({type(err).__name__}: {err}); "
                         'expected JSON {"Frames": [[dt, 43 numbers], ...]}') from err
    if frames.ndim != 2 or frames.shape[1] != FRAME_SIZE or len(frames) < 2:
        raise ModelError(f"{path}: frames of shape {list(frames.shape)}; a clip needs at least 2 "
                         f"frames of {FRAME_SIZE} numbers (dt, root position and rotation, "
                         "12 joints)")
    if not np.isfinite(frames).all():
        bad = int(np.flatnonzero(~np.isfinite(frames).all(axis=1))[0])
        raise ModelError(f"{path}: frame {bad} holds a NaN or infinity")
    dt = frames[0, 0]
    if dt <= 0:
        raise ModelError(f"{path}: frame time {dt} must be > 0")
    return float(dt), frames[:, 1:]


def _rotation(wxyz: np.ndarray) -> np.ndarray:
    """DeepMimic's y-up (w, x, y, z) as a z-up (x, y, z, w): the same turn with its axis turned."""
    q = np.concatenate([y_up_to_z_up(wxyz[..., 1:].T).T, wxyz[..., :1]], axis=-1)
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


@dataclass
class MotionState:
    """The humanoid's state in a clip at some times, [n, ...] each; quaternions (x, y, z, w)."""
    root_pos: torch.Tensor          # [n, 3] m, world
    root_rot: torch.Tensor          # [n, 4]
    root_vel: torch.Tensor          # [n, 3] m/s, world
    root_ang_vel: torch.Tensor      # [n, 3] rad/s, world
    dof_pos: torch.Tensor           # [n, 28] in the model's DoF order (exp maps and hinge angles)
    dof_vel: torch.Tensor           # [n, 28]
    key_pos: torch.Tensor           # [n, 4, 3] world positions of AMP_KEY_BODIES


class MotionLib:
    """Clips as one set of frame tensors on `device`, sampled at any time."""

    def __init__(self, clips: list[str], weights: list[float] | None = None, device="cpu"):
        if not clips:
            raise ValueError("MotionLib: no clips given")
        weights = [1.0] * len(clips) if weights is None else list(weights)
        if len(weights) != len(clips) or min(weights) < 0 or sum(weights) <= 0:
            raise ValueError(f"MotionLib: weights {weights} must be one non-negative number per "
                             f"clip ({len(clips)}), not all 0")
        self.device = torch.device(device)
        self._tree()
        frames, self.dt, self.num_frames = [], [], []
        for path in clips:
            dt, raw = read_clip(clip_path(path))
            self.dt.append(dt)
            self.num_frames.append(len(raw))
            frames.append(self._convert(raw, dt))
        self.frames = {k: torch.cat([f[k] for f in frames]).to(self.device) for k in frames[0]}
        count = torch.tensor(self.num_frames)
        self.first = (torch.cumsum(count, 0) - count).to(self.device)
        self.num_frames = count.to(self.device)
        self.dt = torch.tensor(self.dt, dtype=torch.float32, device=self.device)
        self.duration = (self.num_frames - 1) * self.dt
        self.weights = torch.tensor(weights, dtype=torch.float32, device=self.device)
        self.weights /= self.weights.sum()

    # ------------------------------------------------------------------ the body tree
    def _tree(self) -> None:
        """Parents, offsets, and each body's joint (3-DoF, hinge axis or none), from the model."""
        model = amp_humanoid_spec().compile()
        self.body_names = [name for _, name, _ in AMP_BODIES]
        index = {name: i for i, name in enumerate(self.body_names)}
        self.parent = [index.get(model.body(int(model.body(b).parentid[0])).name, -1)
                       for b in self.body_names]
        self.offset = torch.tensor(np.array([model.body(b).pos for b in self.body_names]),
                                   dtype=torch.float32)
        self.joint = {}         # body index -> (joint name, hinge axis or None)
        for i, (_, body, joint) in enumerate(AMP_BODIES):
            if joint in HINGES:
                self.joint[i] = (joint, torch.tensor(model.joint(joint).axis, dtype=torch.float32))
            elif joint is not None:
                self.joint[i] = (joint, None)
        self.key = [index[b] for b in AMP_KEY_BODIES]
        dofs = 0
        self.dof_slice = {}     # joint name -> slice of the 28 DoF
        for i in sorted(self.joint):
            name, axis = self.joint[i]
            width = 1 if axis is not None else 3
            self.dof_slice[name] = slice(dofs, dofs + width)
            dofs += width
        self.num_dof = dofs

    def _convert(self, raw: np.ndarray, dt: float) -> dict[str, torch.Tensor]:
        """One clip's frames in the model's coordinates, with velocities and key positions."""
        n = len(raw)
        root_pos = torch.tensor(y_up_to_z_up(raw[:, 0:3].T).T, dtype=torch.float32)
        root_rot = torch.tensor(_rotation(raw[:, 3:7]), dtype=torch.float32)
        local = torch.zeros(n, len(self.body_names), 4)
        local[..., 3] = 1.0
        angles = {}
        column = 7
        joints_at = {name: i for i, (name, _) in self.joint.items()}
        for name in CLIP_JOINTS:
            body = joints_at[name]
            if name in HINGES:
                angles[name] = torch.tensor(raw[:, column], dtype=torch.float32)
                local[:, body] = quat_from_angle_axis(angles[name], self.joint[body][1].expand(n, 3))
                column += 1
            else:
                local[:, body] = torch.tensor(_rotation(raw[:, column:column + 4]),
                                              dtype=torch.float32)
                column += 4

        def rate(q):            # angular velocity between frames, the last repeated
            w = quat_to_exp_map(quat_mul(q[1:], quat_conjugate(q[:-1]))) / dt
            return torch.cat([w, w[-1:]])

        def diff(x):
            v = (x[1:] - x[:-1]) / dt
            return torch.cat([v, v[-1:]])

        dof_vel = torch.zeros(n, self.num_dof)
        for body, (name, axis) in self.joint.items():
            dof_vel[:, self.dof_slice[name]] = diff(angles[name])[:, None] if axis is not None \
                else rate(local[:, body])
        return {"root_pos": root_pos, "root_rot": root_rot, "root_vel": diff(root_pos),
                "root_ang_vel": rate(root_rot), "local_rot": local, "dof_vel": dof_vel,
                "hinge": torch.stack([angles[h] for h in HINGES], dim=1),
                "key_pos": self.forward_kinematics(root_pos, root_rot, local)[:, self.key]}

    def forward_kinematics(self, root_pos, root_rot, local_rot) -> torch.Tensor:
        """World positions [n, bodies, 3] of every body for root poses and local rotations."""
        pos, rot = [None] * len(self.body_names), [None] * len(self.body_names)
        for b, p in enumerate(self.parent):
            if p < 0:
                pos[b], rot[b] = root_pos, quat_mul(root_rot, local_rot[:, b])
            else:
                pos[b] = pos[p] + quat_rotate(rot[p], self.offset[b].to(root_pos).expand_as(root_pos))
                rot[b] = quat_mul(rot[p], local_rot[:, b])
        return torch.stack(pos, dim=1)

    # ------------------------------------------------------------------ sampling
    def sample_clips(self, n: int, generator: torch.Generator | None = None) -> torch.Tensor:
        return torch.multinomial(self.weights, n, replacement=True, generator=generator)

    def sample_times(self, clips: torch.Tensor,
                     generator: torch.Generator | None = None) -> torch.Tensor:
        u = torch.rand(clips.shape, device=self.device, generator=generator)
        return u * self.duration[clips]

    def state(self, clips: torch.Tensor, times: torch.Tensor) -> MotionState:
        """The clips' states at `times` (s, clamped to each clip's span)."""
        frames = self.num_frames[clips]
        phase = (times / self.duration[clips]).clamp(0.0, 1.0)
        # a time at a frame (k·dt, rounded) is that frame's, not the end of the one before
        f0 = torch.minimum((phase * (frames - 1) + 1e-4).long(), frames - 1)
        f1 = torch.minimum(f0 + 1, frames - 1)
        blend = ((times.clamp(min=0.0) - f0 * self.dt[clips]) / self.dt[clips]).clamp(0.0, 1.0)
        i0, i1 = self.first[clips] + f0, self.first[clips] + f1
        get = self.frames
        b = blend[:, None]
        local = slerp(get["local_rot"][i0], get["local_rot"][i1], blend[:, None])
        hinge = get["hinge"][i0] * (1 - b) + get["hinge"][i1] * b
        dof_pos = torch.zeros(len(clips), self.num_dof, device=self.device)
        for body, (name, axis) in self.joint.items():
            cut = self.dof_slice[name]
            h = HINGES.index(name) if axis is not None else 0
            dof_pos[:, cut] = hinge[:, h:h + 1] if axis is not None \
                else quat_to_exp_map(local[:, body])
        return MotionState(
            root_pos=get["root_pos"][i0] * (1 - b) + get["root_pos"][i1] * b,
            root_rot=slerp(get["root_rot"][i0], get["root_rot"][i1], blend),
            root_vel=get["root_vel"][i0], root_ang_vel=get["root_ang_vel"][i0],
            dof_pos=dof_pos, dof_vel=get["dof_vel"][i0],
            key_pos=get["key_pos"][i0] * (1 - b[..., None]) + get["key_pos"][i1] * b[..., None])


__all__ = ["MotionLib", "MotionState", "clip_path", "read_clip"]
