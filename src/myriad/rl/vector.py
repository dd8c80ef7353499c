"""Myriad tasks as gymnasium vector environments: ``myriad.make_vec("Ant", num_envs=64)``.

A `MyriadVectorEnv` is a `gymnasium.vector.VectorEnv` over one batched `VecTask`; nothing is
stepped env by env. It keeps gymnasium's step API and the task's speed:

    obs, info = envs.reset(seed=0)
    obs, reward, terminated, truncated, info = envs.step(actions)

- Arrays are torch tensors on the task's device (zero-copy, no host sync), or numpy arrays on
  the host with ``numpy=True`` (one device-to-host copy per step).
- ``terminated``: the episode ended in a terminal state (a fall, a success, a blown-up
  simulation); ``truncated``: it was cut by the time limit (the task's ``extras["time_outs"]``).
  Both are bool ``[num_envs]``; rewards are float32 ``[num_envs]``.
- Autoreset: ``metadata["autoreset_mode"] = AutoresetMode.SAME_STEP``. An env whose episode ends
  is reset inside the same ``step``: the returned ``obs`` row is already the first observation
  of its next episode, and the last observation of the finished episode is in
  ``info["final_obs"]``, with ``info["_final_obs"]`` the bool mask of the envs that finished.
  Gymnasium's own vector envs give ``final_obs`` as an object array holding None for the others;
  here it is one batched array ``[num_envs, num_obs]`` (no per-env Python objects, no host
  sync), whose other rows hold the step's ``obs``: so ``info["final_obs"]`` is, for every env,
  the observation that followed the action in the same episode, the one to bootstrap a value
  from at a time-out.
- Asymmetric tasks (``num_states > 0``: Trifinger, the asymmetric Shadow Hand) put their
  privileged critic observations in ``info["states"]`` and ``info["final_states"]`` (same mask).
  Other task extras (HumanoidAMP's ``amp_obs``) are passed on in ``info`` under their names.
- ``reset(seed=s)`` seeds torch's generators (`torch.manual_seed`: global, CPU and CUDA), which
  every task and domain randomization draw from, and gymnasium's ``np_random``; it resets every
  env. The spaces are seeded apart, as in gymnasium (``envs.action_space.seed(s)``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import torch
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

if TYPE_CHECKING:       # `import myriad` imports this module, and the tasks only when used
    from ..tasks import VecTask


class MyriadVectorEnv(VectorEnv):
    """A `VecTask` as a gymnasium `VectorEnv` (same-step autoreset; see the module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(self, task: VecTask, numpy: bool = False):
        self.task = task
        self.numpy = numpy
        self.num_envs = task.num_envs
        self.device = task.device
        self.single_observation_space = task.observation_space
        self.single_action_space = task.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        task.keep_final_obs = True

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict[str, Any]]:
        if options:
            raise ValueError(f"reset: options {sorted(options)} are not supported; Myriad resets "
                             f"every env (finished ones reset themselves inside step)")
        super().reset(seed=seed)
        if seed is not None:
            torch.manual_seed(seed)
        obs_dict = self.task.reset()
        info = {"states": obs_dict["states"]} if "states" in obs_dict else {}
        return self._out(obs_dict["obs"]), self._out(info)

    def step(self, actions) -> tuple[Any, Any, Any, Any, dict[str, Any]]:
        # the task checks the shape (ValueError naming it) and moves the actions to its device
        obs_dict, rewards, resets, extras = self.task.step(torch.as_tensor(actions))
        obs = obs_dict["obs"]
        done = resets.bool()
        truncated = extras["time_outs"].bool()
        info = {key: value for key, value in extras.items()
                if key not in ("time_outs", "final_obs")}
        info["final_obs"] = torch.where(done[:, None], extras["final_obs"]["obs"], obs)
        info["_final_obs"] = done
        if "states" in obs_dict:
            info["states"] = obs_dict["states"]
            info["final_states"] = torch.where(done[:, None], extras["final_obs"]["states"],
                                               obs_dict["states"])
        # the task's reward buffer is overwritten by the next step: hand out a copy
        return (self._out(obs), self._out(rewards.clone()), self._out(done & ~truncated),
                self._out(truncated), self._out(info))

    def _out(self, value):
        """Tensors (also inside dicts) as numpy arrays when asked for, else as they are."""
        if not self.numpy:
            return value
        if isinstance(value, dict):
            return {key: self._out(v) for key, v in value.items()}
        if isinstance(value, torch.Tensor):
            return value.detach().cpu().numpy()
        return value

    def __repr__(self) -> str:
        name = self.task.cfg.get("name", type(self.task).__name__)
        return (f"MyriadVectorEnv({name}, num_envs={self.num_envs}, "
                f"device={self.device}{', numpy' if self.numpy else ''})")


def make_vec(name: str, num_envs: int | None = None, device: str = "cpu", numpy: bool = False,
             **overrides) -> MyriadVectorEnv:
    """Build a task by name as a gymnasium vector env (``myriad.make`` takes the same ``name``,
    ``num_envs``, ``device`` and config overrides): torch tensors on ``device``, or numpy arrays
    with ``numpy=True``. An unknown name raises ``myriad.make``'s KeyError listing the tasks."""
    from ..tasks import make

    return MyriadVectorEnv(make(name, num_envs=num_envs, device=device, **overrides), numpy=numpy)


__all__ = ["MyriadVectorEnv", "make_vec"]
