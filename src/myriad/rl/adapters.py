"""Myriad tasks for other RL libraries' trainers: rsl_rl and skrl (``pip install myriad[rsl_rl]``,
``myriad[skrl]``). Each adapter is a thin view of one batched `VecTask`: tensors stay on the
task's device, nothing is copied or looped over envs, and the task's same-step resets are kept
(the observation returned for a finished env is the first of its next episode, as both libraries
expect from Isaac Lab).

    env = rsl_rl_env("Ant", num_envs=4096, device="cuda:0")    # rsl_rl.env.VecEnv
    runner = OnPolicyRunner(env, {..., "obs_groups": env.obs_groups}, log_dir, device="cuda:0")

    env = skrl_env("Ant", num_envs=4096, device="cuda:0")      # skrl.envs.wrappers.torch.Wrapper
    agent = PPO(models=..., observation_space=env.observation_space,
                state_space=env.state_space, action_space=env.action_space, ...)

Both take `myriad.make`'s arguments (task name, ``num_envs``, ``device``, config overrides); the
classes `RslRlVecEnv(task)` and `SkrlVecEnv(task)` wrap a task built already. Time-outs reach
both libraries' bootstrapping: rsl_rl reads ``extras["time_outs"]``, skrl gets them as
``truncated`` (set its PPO ``time_limit_bootstrap=True``).

Targets: rsl-rl-lib 5.x (observations as a TensorDict of groups) and skrl 2.x (torch).
"""

from __future__ import annotations

from typing import Any

import torch

from ..tasks import VecTask, make

try:
    from rsl_rl.env import VecEnv as _RslRlVecEnvBase
    from tensordict import TensorDict
except ImportError:         # rsl_rl is optional: the class below then refuses to be built
    _RslRlVecEnvBase, TensorDict = object, None
try:
    from skrl.envs.wrappers.torch import Wrapper as _SkrlWrapperBase
except ImportError:
    _SkrlWrapperBase = object


def _require(module, package: str, extra: str) -> None:
    if module is None or module is object:
        raise ImportError(f"this adapter needs {package}: pip install myriad[{extra}]")


class RslRlVecEnv(_RslRlVecEnvBase):
    """A `VecTask` as rsl_rl's `VecEnv` (rsl-rl-lib 5.x).

    Observations are a TensorDict with the group ``"policy"`` (the task's observations) and, for
    an asymmetric task (``num_states > 0``), ``"critic"`` (its privileged states): Isaac Lab's
    group names. `obs_groups` maps rsl_rl's observation sets onto them (actor: policy; critic:
    critic, or policy when the task has no states); pass it as the runner config's
    ``"obs_groups"``. ``episode_length_buf`` is the task's ``progress_buf`` (writable: rsl_rl's
    ``init_at_random_ep_len`` spreads the first time-outs through it). ``extras`` are the task's,
    with ``"time_outs"``."""

    def __init__(self, task: VecTask):
        _require(TensorDict, "rsl-rl-lib", "rsl_rl")
        self.task = task
        self.num_envs = task.num_envs
        self.num_actions = task.num_actions
        self.max_episode_length = task.max_episode_length
        self.device = task.device
        self.cfg = task.cfg
        self.obs_groups = {"actor": ["policy"],
                           "critic": ["critic" if task.num_states > 0 else "policy"]}
        self._obs = self._groups(task.reset())

    @property
    def episode_length_buf(self) -> torch.Tensor:
        return self.task.progress_buf

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        self.task.progress_buf[:] = value

    def _groups(self, obs_dict: dict) -> TensorDict:
        groups = {"policy": obs_dict["obs"]}
        if "states" in obs_dict:
            groups["critic"] = obs_dict["states"]
        return TensorDict(groups, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        return self._obs

    def step(self, actions: torch.Tensor) -> tuple[TensorDict, torch.Tensor, torch.Tensor, dict]:
        obs_dict, rewards, resets, extras = self.task.step(actions)
        self._obs = self._groups(obs_dict)
        # the task's buffers are overwritten by the next step: hand out copies
        return self._obs, rewards.clone(), resets.clone(), extras

    def close(self) -> None:
        pass


class SkrlVecEnv(_SkrlWrapperBase):
    """A `VecTask` as an skrl torch environment wrapper (skrl 2.x): ``reset() -> (obs, info)``,
    ``step(actions) -> (obs, reward, terminated, truncated, info)`` with reward, terminated and
    truncated shaped ``[num_envs, 1]`` (skrl's convention), ``state()`` the privileged states of
    an asymmetric task (else None). ``reset()`` starts new episodes in every env; during
    training the envs reset themselves in the step that ends their episode."""

    def __init__(self, task: VecTask):
        _require(_SkrlWrapperBase, "skrl", "skrl")
        super().__init__(task)
        self.task = task
        self._states = None

    @property
    def observation_space(self):
        return self.task.observation_space

    @property
    def action_space(self):
        return self.task.action_space

    @property
    def state_space(self):
        return self.task.state_space if self.task.num_states > 0 else None

    def reset(self) -> tuple[torch.Tensor, dict[str, Any]]:
        obs_dict = self.task.reset()
        self._states = obs_dict.get("states")
        return obs_dict["obs"], {}

    def step(self, actions: torch.Tensor):
        obs_dict, rewards, resets, extras = self.task.step(actions)
        self._states = obs_dict.get("states")
        truncated = extras["time_outs"].bool()
        terminated = resets.bool() & ~truncated
        return (obs_dict["obs"], rewards.clone().view(-1, 1), terminated.view(-1, 1),
                truncated.view(-1, 1), extras)

    def state(self) -> torch.Tensor | None:
        return self._states

    def render(self, *args, **kwargs) -> None:
        return None

    def close(self) -> None:
        pass


def rsl_rl_env(name: str, num_envs: int | None = None, device: str = "cpu",
               **overrides) -> RslRlVecEnv:
    """`myriad.make(name, ...)` as an rsl_rl `VecEnv` (see `RslRlVecEnv`)."""
    _require(TensorDict, "rsl-rl-lib", "rsl_rl")
    return RslRlVecEnv(make(name, num_envs=num_envs, device=device, **overrides))


def skrl_env(name: str, num_envs: int | None = None, device: str = "cpu",
             **overrides) -> SkrlVecEnv:
    """`myriad.make(name, ...)` as an skrl torch env wrapper (see `SkrlVecEnv`)."""
    _require(_SkrlWrapperBase, "skrl", "skrl")
    return SkrlVecEnv(make(name, num_envs=num_envs, device=device, **overrides))


__all__ = ["RslRlVecEnv", "SkrlVecEnv", "rsl_rl_env", "skrl_env"]
