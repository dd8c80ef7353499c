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

The AMP observation of a step is this frame and the one before it (210). The task itself (PD
targets, resets from the clips, early termination) comes with the AMP agent.
"""

from __future__ import annotations

import torch

from ..assets import AMP_BODIES
from ..torch_utils import exp_map_to_quat, quat_from_angle_axis, quat_rotate

# (width, start) of each joint's DoF in the model's order: 3 for spherical joints, 1 for hinges
DOF_GROUPS = []
_start = 0
for _, _, _joint in AMP_BODIES:
    if _joint is not None:
        _width = 1 if _joint.endswith(("elbow", "knee")) else 3
        DOF_GROUPS.append((_width, _start))
        _start += _width
NUM_DOF = _start                                     # 28
NUM_OBS = 1 + 6 + 3 + 3 + sum(6 if w == 3 else 1 for w, _ in DOF_GROUPS) + NUM_DOF + 4 * 3   # 105


def heading_inverse(rot: torch.Tensor) -> torch.Tensor:
    """The rotation about z that undoes `rot`'s heading (the yaw of its x axis)."""
    x_axis = quat_rotate(rot, torch.tensor([1.0, 0.0, 0.0], device=rot.device).expand_as(rot[..., :3]))
    heading = torch.atan2(x_axis[..., 1], x_axis[..., 0])
    z = torch.tensor([0.0, 0.0, 1.0], device=rot.device).expand_as(x_axis)
    return quat_from_angle_axis(-heading, z)


def tan_norm(rot: torch.Tensor) -> torch.Tensor:
    """[..., 6]: the rotated x axis and z axis, a continuous code of a rotation."""
    shape = rot[..., :3]
    x = quat_rotate(rot, torch.tensor([1.0, 0.0, 0.0], device=rot.device).expand_as(shape))
    z = quat_rotate(rot, torch.tensor([0.0, 0.0, 1.0], device=rot.device).expand_as(shape))
    return torch.cat([x, z], dim=-1)


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
