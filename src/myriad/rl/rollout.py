"""PPO's rollout with nothing read back to the host between env steps, and on CUDA each env
step with the policy's inference as one captured graph.

rl_games' `play_steps` finds the envs whose episode ended at each step with `dones.nonzero()`,
which on a GPU waits for the step to finish, and then averages their returns in `AverageMeter`s
whose sizes are host numbers. Here the same rollout keeps those statistics on the device:
`EpisodeMeter` is rl_games' running mean (over the last `games_to_track` episodes, weighted as
its `update` weights them) with the finished episodes selected by a mask instead of by index.
The host reads the meters once per epoch, when the progress line is printed. Everything else is
rl_games' own code in rl_games' order (its `get_action_values`, `env_step`, experience buffer,
value bootstrap on time-outs and `discount_values`), so the weights trained are the same bit for
bit; the printed mean reward agrees to float32 rounding (a masked sum adds in another order than
a mean over the selected rows).

With `capture_step=true` on CUDA the whole rollout step (the policy's inference and sampling,
the experience buffer's writes, the env step, the rewards' bookkeeping) is captured as one CUDA
graph and replayed for every step: the buffers are written at a step index held on the device,
the observations and dones the next step reads are copied into tensors the graph owns, and the
normalizers keep their tensors (`myriad.rl.update` for the observations', the agent's
`prepare_dataset` for the values'). The epoch's time split then counts the policy's inference
with the physics (one replay is both).
"""

from __future__ import annotations

import time

import torch
from rl_games.common import a2c_common
from rl_games.common.a2c_common import swap_and_flatten01

# infos keys that rl_games' default observer turns into game scores, one env at a time
OBSERVED_INFOS = ("scores", "battle_won", "lives")


class EpisodeMeter(torch.nn.Module):
    """rl_games' `AverageMeter` with its size on the device: `update_where(values, done)` takes
    the rows of `values` where `done` is set, without reading how many there are."""

    def __init__(self, in_shape, max_size, device):
        super().__init__()
        self.max_size = max_size
        self.register_buffer("mean", torch.zeros(in_shape, dtype=torch.float32, device=device))
        self.register_buffer("size", torch.zeros((), dtype=torch.long, device=device))

    @property
    def current_size(self) -> int:                  # rl_games reads it once per epoch
        return int(self.size)

    def get_mean(self):
        """[in_shape] (rl_games' meter squeezes a [1, n] mean to [n]: its rows come indexed
        by `nonzero()`'s [k, 1] indices)"""
        return self.mean.cpu().numpy()

    def update_where(self, values: torch.Tensor, done: torch.Tensor) -> None:
        values = values.float().reshape(len(done), -1)
        count = done.sum()
        new_mean = (values * done[:, None]).sum(0) / count.clamp_min(1)
        size = count.clamp(max=self.max_size)
        old_size = torch.minimum(self.max_size - size, self.size)
        total = old_size + size
        mean = (self.mean * old_size + new_mean * size) / total.clamp_min(1)
        ended = count > 0
        self.mean.copy_(torch.where(ended, mean, self.mean))
        self.size.copy_(torch.where(ended, total, self.size))

    def clear(self) -> None:
        self.size.zero_()
        self.mean.fill_(0)


def use_episode_meters(agent) -> None:
    """The agent's three episode meters (reward, shaped reward, length) as `EpisodeMeter`s."""
    device = agent.ppo_device
    agent.game_rewards = EpisodeMeter(agent.value_size, agent.games_to_track, device)
    agent.game_shaped_rewards = EpisodeMeter(agent.value_size, agent.games_to_track, device)
    agent.game_lengths = EpisodeMeter(1, agent.games_to_track, device)


def capture_unsupported(agent) -> str | None:
    """Why this agent's rollout step cannot be captured as a graph; None if it can."""
    if agent.minibatch_step is None:
        return "rl_games' own minibatch step (its normalizer replaces the tensors a graph reads)"
    if agent.has_central_value:
        return "an asymmetric critic (its normalizers replace the tensors a graph reads)"
    if type(agent).env_step is not a2c_common.A2CBase.env_step:
        return f"{type(agent).__name__}'s own env_step (it keeps per-step data on the host)"
    if agent.multi_gpu:
        return "several processes"
    return None


class Rollout:
    """rl_games' A2CBase.play_steps (a non-recurrent policy, no action masks) with the finished
    episodes counted on the device (the agent's meters: `use_episode_meters`), and with
    `capture` on CUDA each step replayed as a CUDA graph."""

    def __init__(self, agent, capture: bool):
        self.agent = agent
        self.device = torch.device(agent.ppo_device)
        self.capture = capture and self.device.type == "cuda"
        self.index = torch.zeros(1, dtype=torch.long, device=self.device)   # the step, 0..H-1
        self.obs: dict[str, torch.Tensor] = {}      # what the next step reads, owned here
        self.dones: torch.Tensor | None = None
        self.graph: torch.cuda.CUDAGraph | None = None
        self.step_time = 0.0

    def _write(self, name: str, value: torch.Tensor) -> None:
        stored = self.agent.experience_buffer.tensor_dict[name]
        stored.index_copy_(0, self.index, value.to(stored.dtype).unsqueeze(0))

    def _step(self) -> None:
        """One env step of the rollout, at step `self.index`."""
        agent = self.agent
        res_dict = agent.get_action_values(agent.obs)
        self._write("obses", agent.obs["obs"])
        self._write("dones", agent.dones)
        for k in agent.update_list:
            self._write(k, res_dict[k])
        if agent.has_central_value:
            self._write("states", agent.obs["states"])

        start = time.perf_counter()
        obs, rewards, dones, infos = agent.env_step(res_dict["actions"])
        self.step_time += time.perf_counter() - start       # rl_games' split on a CPU
        shaped_rewards = agent.rewards_shaper(rewards)
        if agent.value_bootstrap and "time_outs" in infos:
            shaped_rewards.add_(agent.gamma * res_dict["values"]
                                * agent.cast_obs(infos["time_outs"]).unsqueeze(1).float())
        self._write("rewards", shaped_rewards)

        agent.current_rewards.add_(rewards)
        agent.current_shaped_rewards.add_(shaped_rewards)
        agent.current_lengths.add_(1)
        done = dones.bool()         # one agent per env (num_agents 1): each row an env
        agent.game_rewards.update_where(agent.current_rewards, done)
        agent.game_shaped_rewards.update_where(agent.current_shaped_rewards, done)
        agent.game_lengths.update_where(agent.current_lengths, done)
        if any(key in infos for key in OBSERVED_INFOS):     # not Myriad's tasks' infos
            agent.algo_observer.process_infos(infos, done.nonzero(as_tuple=False))
        not_dones = (1.0 - dones.float()).unsqueeze(1)
        agent.current_rewards.mul_(not_dones)
        agent.current_shaped_rewards.mul_(not_dones)
        agent.current_lengths.mul_(not_dones.squeeze(1))

        for key, value in obs.items():      # for the next step, in the tensors it reads
            self.obs[key].copy_(value)
        self.dones.copy_(dones)

    def _own_inputs(self) -> None:
        """The observations and dones the steps read, in tensors of this rollout's (the ones a
        graph reads): the first time new ones, after that (an env reset rebinds the agent's)
        the agent's values copied into them."""
        agent = self.agent
        if not self.obs:
            self.obs = {k: v.clone() for k, v in agent.obs.items()}
            self.dones = agent.dones.clone()
        else:
            for k, v in agent.obs.items():
                if self.obs[k] is not v:
                    self.obs[k].copy_(v)
            if agent.dones is not self.dones:
                self.dones.copy_(agent.dones)
        agent.obs, agent.dones = dict(self.obs), self.dones

    def _run_step(self, first: bool) -> None:
        """One step, eagerly or replayed (`first`: the rollout's step 0)."""
        clock = self.agent.vec_env.clock
        if not self.capture or (first and self.graph is None):
            self._step()                    # eager (the first step: warms the step up)
        else:
            if self.graph is None:
                graph = torch.cuda.CUDAGraph()
                clock.paused = True         # no timing events inside a graph
                try:
                    # thread-local: a viewer's copies on another thread go on meanwhile
                    with torch.cuda.graph(graph, capture_error_mode="thread_local"):
                        self._step()
                finally:
                    clock.paused = False
                self.graph = graph
            start = time.perf_counter()
            clock.step(self.graph.replay)
            self.step_time += time.perf_counter() - start

    def play(self) -> dict:
        agent = self.agent
        self._own_inputs()
        self.step_time = 0.0            # host seconds in env steps (replays, when captured)
        for n in range(agent.horizon_length):
            self.index.fill_(n)
            self._run_step(first=n == 0)

        buffer = agent.experience_buffer
        last_values = agent.get_values(agent.obs)
        fdones = agent.dones.float()
        mb_fdones = buffer.tensor_dict["dones"].float()
        mb_values = buffer.tensor_dict["values"]
        mb_rewards = buffer.tensor_dict["rewards"]
        mb_advs = agent.discount_values(fdones, last_values, mb_fdones, mb_values, mb_rewards)
        mb_returns = mb_advs + mb_values
        batch_dict = buffer.get_transformed_list(swap_and_flatten01, agent.tensor_list)
        batch_dict["returns"] = swap_and_flatten01(mb_returns)
        batch_dict["played_frames"] = agent.batch_size
        batch_dict["step_time"] = self.step_time
        return batch_dict
