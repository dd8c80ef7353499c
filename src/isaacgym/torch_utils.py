"""`isaacgym.torch_utils` on Myriad: batched rotation and sampling helpers in Isaac Gym's
conventions.

Quaternions are (x, y, z, w), as in Isaac Gym and in Myriad. The functions are TorchScript
functions, so that a task's own `@torch.jit.script` code may call them, as it could the
original's. Angles of `get_euler_xyz` are in [0, 2π), as the original returns them.
"""

from __future__ import annotations

import warnings

import numpy as np
import torch


def _script(fn):
    """TorchScript `fn` (recent torch warns that TorchScript is deprecated: not for ours)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        warnings.simplefilter("ignore", DeprecationWarning)
        return torch.jit.script(fn)


def to_torch(x, dtype=torch.float, device="cuda:0", requires_grad=False) -> torch.Tensor:
    """`torch.tensor(x)` on `device` (the original's default device is "cuda:0"; on a machine
    without CUDA the tensor is made on the CPU instead)."""
    if str(device).startswith("cuda") and not torch.cuda.is_available():
        device = "cpu"
    return torch.tensor(x, dtype=dtype, device=device, requires_grad=requires_grad)


@_script
def normalize(x, eps: float = 1e-9):
    """x / |x| along the last dimension (|x| clamped below by eps)."""
    return x / x.norm(p=2, dim=-1).clamp(min=eps, max=None).unsqueeze(-1)


@_script
def quat_unit(a):
    return normalize(a)


@_script
def quat_mul(a, b):
    """Hamilton product a·b of quaternions (x, y, z, w): the rotation b, then a."""
    shape = a.shape
    a = a.reshape(-1, 4)
    b = b.reshape(-1, 4)
    ax, ay, az, aw = a[:, 0], a[:, 1], a[:, 2], a[:, 3]
    bx, by, bz, bw = b[:, 0], b[:, 1], b[:, 2], b[:, 3]
    x = aw * bx + ax * bw + ay * bz - az * by
    y = aw * by - ax * bz + ay * bw + az * bx
    z = aw * bz + ax * by - ay * bx + az * bw
    w = aw * bw - ax * bx - ay * by - az * bz
    return torch.stack([x, y, z, w], dim=-1).view(shape)


@_script
def quat_conjugate(a):
    shape = a.shape
    a = a.reshape(-1, 4)
    return torch.cat((-a[:, :3], a[:, -1:]), dim=-1).view(shape)


@_script
def quat_apply(a, b):
    """Rotate the vectors b [..., 3] by the quaternions a [..., 4]."""
    shape = b.shape
    a = a.reshape(-1, 4)
    b = b.reshape(-1, 3)
    u = a[:, :3]
    t = 2.0 * torch.cross(u, b, dim=-1)
    return (b + a[:, 3:] * t + torch.cross(u, t, dim=-1)).view(shape)


@_script
def quat_rotate(q, v):
    """Rotate v [N, 3] by q [N, 4]."""
    u = q[:, :3]
    w = q[:, 3:]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v + w * t + torch.cross(u, t, dim=-1)


@_script
def quat_rotate_inverse(q, v):
    """Rotate v [N, 3] by the inverse of q [N, 4]."""
    u = -q[:, :3]
    w = q[:, 3:]
    t = 2.0 * torch.cross(u, v, dim=-1)
    return v + w * t + torch.cross(u, t, dim=-1)


@_script
def quat_from_angle_axis(angle, axis):
    """Rotations by `angle` [N] about `axis` [N, 3] (normalized here)."""
    half = (angle / 2).unsqueeze(-1)
    xyz = normalize(axis) * half.sin()
    return quat_unit(torch.cat([xyz, half.cos()], dim=-1))


@_script
def normalize_angle(x):
    """To (-π, π]."""
    return torch.atan2(torch.sin(x), torch.cos(x))


@_script
def tf_inverse(q, t):
    q_inv = quat_conjugate(q)
    return q_inv, -quat_apply(q_inv, t)


@_script
def tf_apply(q, t, v):
    return quat_apply(q, v) + t


@_script
def tf_vector(q, v):
    return quat_apply(q, v)


@_script
def tf_combine(q1, t1, q2, t2):
    return quat_mul(q1, q2), quat_apply(q1, t2) + t1


@_script
def get_basis_vector(q, v):
    return quat_rotate(q, v)


def get_axis_params(value, axis_idx, x_value=0., dtype=float, n_dims=3):
    """A list of `n_dims` numbers: `value` at `axis_idx`, zeros elsewhere, and `x_value` in
    the first place (as the original, which overwrites place 0 last: with axis_idx 0 the result
    starts with x_value)."""
    params = [0.0] * n_dims
    params[axis_idx] = value
    params[0] = x_value
    return [dtype(p) for p in params]


@_script
def copysign(a: float, b):
    """|a| with the sign of each entry of b [N] (0 where b is 0, as torch.sign)."""
    mag = torch.full(b.shape, abs(a), device=b.device, dtype=torch.float)
    return mag * torch.sign(b)


@_script
def get_euler_xyz(q):
    """Roll, pitch, yaw [N] of q [N, 4] = Rz(yaw)·Ry(pitch)·Rx(roll), each in [0, 2π)."""
    qx, qy, qz, qw = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    roll = torch.atan2(2.0 * (qw * qx + qy * qz), qw * qw - qx * qx - qy * qy + qz * qz)
    sinp = 2.0 * (qw * qy - qz * qx)
    pitch = torch.where(torch.abs(sinp) >= 1, copysign(np.pi / 2.0, sinp),
                        torch.asin(sinp.clamp(-1.0, 1.0)))
    yaw = torch.atan2(2.0 * (qw * qz + qx * qy), qw * qw + qx * qx - qy * qy - qz * qz)
    two_pi = 2.0 * np.pi
    return roll % two_pi, pitch % two_pi, yaw % two_pi


@_script
def quat_from_euler_xyz(roll, pitch, yaw):
    """The quaternions [..., 4] of Rz(yaw)·Ry(pitch)·Rx(roll)."""
    cy, sy = torch.cos(yaw * 0.5), torch.sin(yaw * 0.5)
    cr, sr = torch.cos(roll * 0.5), torch.sin(roll * 0.5)
    cp, sp = torch.cos(pitch * 0.5), torch.sin(pitch * 0.5)
    qw = cy * cr * cp + sy * sr * sp
    qx = cy * sr * cp - sy * cr * sp
    qy = cy * cr * sp + sy * sr * cp
    qz = sy * cr * cp - cy * sr * sp
    return torch.stack([qx, qy, qz, qw], dim=-1)


def torch_rand_float(lower: float, upper: float, shape, device: str) -> torch.Tensor:
    """Uniform samples in [lower, upper) of `shape` (a tuple) on `device`."""
    return (upper - lower) * torch.rand(*shape, device=device) + lower


def torch_random_dir_2(shape, device: str) -> torch.Tensor:
    """Random unit vectors in the plane: `shape` (N, 1) gives [N, 2]."""
    angle = torch_rand_float(-np.pi, np.pi, shape, device).squeeze(-1)
    return torch.stack([torch.cos(angle), torch.sin(angle)], dim=-1)


@_script
def tensor_clamp(t, min_t, max_t):
    return torch.max(torch.min(t, max_t), min_t)


@_script
def scale(x, lower, upper):
    """[-1, 1] to [lower, upper]."""
    return 0.5 * (x + 1.0) * (upper - lower) + lower


@_script
def unscale(x, lower, upper):
    """[lower, upper] to [-1, 1]."""
    return (2.0 * x - upper - lower) / (upper - lower)


def unscale_np(x, lower, upper):
    return (2.0 * x - upper - lower) / (upper - lower)


@_script
def saturate(x, lower, upper):
    return torch.max(torch.min(x, upper), lower)


__all__ = ["to_torch", "normalize", "quat_unit", "quat_mul", "quat_conjugate", "quat_apply",
           "quat_rotate", "quat_rotate_inverse", "quat_from_angle_axis", "normalize_angle",
           "tf_inverse", "tf_apply", "tf_vector", "tf_combine", "get_basis_vector",
           "get_axis_params", "copysign", "get_euler_xyz", "quat_from_euler_xyz",
           "torch_rand_float", "torch_random_dir_2", "tensor_clamp", "scale", "unscale",
           "unscale_np", "saturate", "np", "torch"]
