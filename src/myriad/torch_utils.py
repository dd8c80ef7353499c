"""Batched rotation helpers in torch, shared by the tensor API and the task observations.

Quaternions are (x, y, z, w).
"""

import torch


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    u, w = q[..., :3], q[..., 3:4]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v + w * t + torch.cross(u, t, dim=-1)


def quat_rotate_inverse(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    return quat_rotate(torch.cat((-q[..., :3], q[..., 3:4]), dim=-1), v)


def quat_mul(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """The rotation a·b (b first, then a)."""
    av, aw, bv, bw = a[..., :3], a[..., 3:4], b[..., :3], b[..., 3:4]
    return torch.cat((aw * bv + bw * av + torch.cross(av, bv, dim=-1),
                      aw * bw - (av * bv).sum(-1, keepdim=True)), dim=-1)


def quat_conjugate(q: torch.Tensor) -> torch.Tensor:
    return torch.cat((-q[..., :3], q[..., 3:4]), dim=-1)


def quat_from_angle_axis(angle: torch.Tensor, axis: torch.Tensor) -> torch.Tensor:
    """Rotations by `angle` [...] about the unit `axis` [..., 3]."""
    half = 0.5 * angle[..., None]
    return torch.cat((axis * torch.sin(half), torch.cos(half)), dim=-1)


def rotation_angle(q: torch.Tensor) -> torch.Tensor:
    """The angle of rotation of q in [0, π] (the seed's 2·asin of the vector part's norm)."""
    return 2.0 * torch.asin(torch.clamp(torch.norm(q[..., :3], dim=-1), max=1.0))


def angle_between(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """The angle in [0, π] of the rotation from orientation b to orientation a (a cube's to
    its goal's: the hand and Trifinger tasks' success test, reward and evaluation)."""
    return rotation_angle(quat_mul(a, quat_conjugate(b)))


def quat_to_exp_map(q: torch.Tensor) -> torch.Tensor:
    """axis·angle [..., 3] of q, angle in [0, π] (q and -q give the same)."""
    q = torch.where(q[..., 3:4] < 0, -q, q)
    sin_half = torch.norm(q[..., :3], dim=-1, keepdim=True)
    angle = 2.0 * torch.atan2(sin_half, q[..., 3:4])
    # angle / sin(angle/2) → 2 as the rotation vanishes
    factor = torch.where(sin_half > 1e-9, angle / sin_half.clamp(min=1e-9), torch.full_like(angle, 2.0))
    return q[..., :3] * factor


def exp_map_to_quat(v: torch.Tensor) -> torch.Tensor:
    """The rotation by |v| about v / |v| (identity for v = 0)."""
    angle = torch.norm(v, dim=-1)
    axis = v / angle.clamp(min=1e-12)[..., None]
    return quat_from_angle_axis(angle, axis)


def slerp(q0: torch.Tensor, q1: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
    """Spherical interpolation from q0 (t = 0) to q1 (t = 1) [..., 4] along the shorter arc;
    t [...] or [..., 1]."""
    t = t[..., None] if t.dim() < q0.dim() else t
    cos = (q0 * q1).sum(-1, keepdim=True)
    q1 = torch.where(cos < 0, -q1, q1)
    cos = cos.abs().clamp(max=1.0)
    angle = torch.acos(cos)
    sin = torch.sin(angle)
    near = sin < 1e-6                       # nearly the same rotation: lerp, then normalize
    w0 = torch.where(near, 1.0 - t, torch.sin((1.0 - t) * angle) / sin.clamp(min=1e-6))
    w1 = torch.where(near, t, torch.sin(t * angle) / sin.clamp(min=1e-6))
    q = w0 * q0 + w1 * q1
    return q / torch.norm(q, dim=-1, keepdim=True)


def unscale(x: torch.Tensor, lower: torch.Tensor, upper: torch.Tensor) -> torch.Tensor:
    """Map [lower, upper] to [-1, 1]."""
    return (2.0 * x - upper - lower) / (upper - lower)


def scale(x: torch.Tensor, lower: torch.Tensor, upper: torch.Tensor) -> torch.Tensor:
    """Map [-1, 1] to [lower, upper]."""
    return lower + 0.5 * (x + 1.0) * (upper - lower)


def wrap_angle(a: torch.Tensor) -> torch.Tensor:
    """To (-π, π]."""
    return torch.atan2(torch.sin(a), torch.cos(a))


def euler_xyz(q: torch.Tensor):
    """Roll, pitch, yaw of q = Rz(yaw)·Ry(pitch)·Rx(roll), each in (-π, π]."""
    x, y, z, w = q.unbind(-1)
    roll = torch.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = torch.asin(torch.clamp(2.0 * (w * y - z * x), -1.0, 1.0))
    yaw = torch.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return roll, pitch, yaw


def heading_up_and_angles(quat: torch.Tensor, to_target: torch.Tensor):
    """Up projection, heading projection, roll, yaw and angle to the target of a torso whose
    forward axis is +x and up axis +z; `to_target` is the horizontal offset to the target."""
    up = quat_rotate(quat, unit_axis(to_target, 2))
    heading = quat_rotate(quat, unit_axis(to_target, 0))
    direction = torch.nn.functional.normalize(to_target, dim=-1)
    roll, _, yaw = euler_xyz(quat)
    angle_to_target = wrap_angle(torch.atan2(to_target[:, 1], to_target[:, 0]) - yaw)
    return up[:, 2], (heading * direction).sum(-1), roll, yaw, angle_to_target


def unit_axis(like: torch.Tensor, axis: int) -> torch.Tensor:
    """Unit vectors along x, y or z (axis 0, 1, 2) shaped like `like` [..., 3], filled on its
    device: `torch.tensor([0, 0, 1])` would copy from the host, which waits for a GPU."""
    e = torch.zeros_like(like)
    e[..., axis] = 1.0
    return e


def env_mask(env_ids: torch.Tensor, num_envs: int) -> torch.Tensor:
    """[num_envs] bool: the envs `env_ids` names, a bool mask (returned as is) or indices."""
    if env_ids.dtype == torch.bool:
        return env_ids
    mask = torch.zeros(num_envs, dtype=torch.bool, device=env_ids.device)
    return mask.index_fill_(0, env_ids.long(), True)


def where_rows(mask: torch.Tensor, new: torch.Tensor, old: torch.Tensor) -> torch.Tensor:
    """`new` in the rows (envs, dim 0) where `mask` [N] is true, `old` elsewhere. Both are
    computed for every env, so nothing depends on how many are selected and no mask is read
    back to the host (x[mask] would)."""
    return torch.where(mask.view(-1, *[1] * (new.dim() - 1)), new, old)


__all__ = ["quat_rotate", "quat_rotate_inverse", "quat_mul", "quat_conjugate",
           "quat_from_angle_axis", "rotation_angle", "wrap_angle", "euler_xyz",
           "heading_up_and_angles", "env_mask", "unit_axis", "scale", "unscale", "where_rows",
           "quat_to_exp_map", "exp_map_to_quat", "slerp"]
