"""`isaacgym.gymtorch` on Myriad: tensor descriptors and torch views.

In Isaac Gym, `acquire_*_tensor` returns a descriptor (`gymapi.Tensor`) of a buffer the
simulator owns; `wrap_tensor` makes a torch tensor over the same memory, refreshed in place by
`refresh_*_tensor`; `unwrap_tensor` turns a torch tensor back into a descriptor for the
`set_*_tensor` calls. On Myriad the buffers are torch tensors from the start, so a descriptor
just holds one: `wrap_tensor` returns that very tensor object (every call the same one) and
`unwrap_tensor` holds the user's tensor without copying it.
"""

from __future__ import annotations

import torch

from .gymapi import Tensor


def wrap_tensor(gym_tensor: Tensor, offsets=None, counts=None) -> torch.Tensor:
    """The torch tensor behind a descriptor from `acquire_*_tensor` (or `unwrap_tensor`)."""
    if not isinstance(gym_tensor, Tensor):
        raise TypeError(f"gymtorch.wrap_tensor: expected an isaacgym.gymapi.Tensor (from "
                        f"gym.acquire_*_tensor), got {type(gym_tensor).__name__}")
    if offsets is not None or counts is not None:
        raise NotImplementedError("gymtorch.wrap_tensor: offsets/counts are not provided by "
                                  "Myriad yet; slice the returned tensor instead")
    return gym_tensor.torch


def unwrap_tensor(torch_tensor: torch.Tensor) -> Tensor:
    """A descriptor of `torch_tensor` (no copy) for `gym.set_*_tensor(...)` calls."""
    if not isinstance(torch_tensor, torch.Tensor):
        raise TypeError(f"gymtorch.unwrap_tensor: expected a torch.Tensor, got "
                        f"{type(torch_tensor).__name__}")
    return Tensor(torch_tensor)


__all__ = ["wrap_tensor", "unwrap_tensor"]
