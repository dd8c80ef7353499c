"""PPO's rollout with nothing read back to the host between env steps.

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
"""

from __future__ import annotations

import time

import torch
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

    def __len__(self) -> int:
        return self.current_size

    def get_mean(self):
        return self.mean.squeeze(0).cpu().numpy()

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

    def update(self, values: torch.Tensor) -> None:        # rl_games' call: every row counts
        self.update_where(values, torch.ones(len(values), dtype=torch.bool,
                                             device=values.device))

    def clear(self) -> None:
        self.size.zero_()
        self.mean.fill_(0)


def use_episode_meters(agent) -> None:
    """The agent's three episode meters (reward, shaped reward, length) as `EpisodeMeter`s."""
    device = agent.ppo_device
    agent.game_rewards = EpisodeMeter(agent.value_size, agent.games_to_track, device)
    agent.game_shaped_rewards = EpisodeMeter(agent.value_size, agent.games_to_track, device)
    agent.game_lengths = EpisodeMeter(1, agent.games_to_track, device)


def play_steps(agent) -> dict:
    """rl_games' A2CBase.play_steps (a non-recurrent policy, no action masks) with the finished
    episodes counted on the device."""
    buffer = agent.experience_buffer
    step_time = 0.0
    for n in range(agent.horizon_length):
        res_dict = agent.get_action_values(agent.obs)
        buffer.update_data("obses", n, agent.obs["obs"])
        buffer.update_data("dones", n, agent.dones)
        for k in agent.update_list:
            buffer.update_data(k, n, res_dict[k])
        if agent.has_central_value:
            buffer.update_data("states", n, agent.obs["states"])

        step_start = time.perf_counter()
        agent.obs, rewards, agent.dones, infos = agent.env_step(res_dict["actions"])
        step_time += time.perf_counter() - step_start

        shaped_rewards = agent.rewards_shaper(rewards)
        if agent.value_bootstrap and "time_outs" in infos:
            shaped_rewards.add_(agent.gamma * res_dict["values"]
                                * agent.cast_obs(infos["time_outs"]).unsqueeze(1).float())
        buffer.update_data("rewards", n, shaped_rewards)

        agent.current_rewards.add_(rewards)
        agent.current_shaped_rewards.add_(shaped_rewards)
        agent.current_lengths.add_(1)

        done = agent.dones.bool()       # one agent per env (num_agents 1): each row an env
        agent.game_rewards.update_where(agent.current_rewards, done)
        agent.game_shaped_rewards.update_where(agent.current_shaped_rewards, done)
        agent.game_lengths.update_where(agent.current_lengths, done)
        if any(key in infos for key in OBSERVED_INFOS):     # not Myriad's tasks' infos
            agent.algo_observer.process_infos(infos, done.nonzero(as_tuple=False))

        not_dones = (1.0 - agent.dones.float()).unsqueeze(1)
        agent.current_rewards.mul_(not_dones)
        agent.current_shaped_rewards.mul_(not_dones)
        agent.current_lengths.mul_(not_dones.squeeze(1))

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
    batch_dict["step_time"] = step_time
    return batch_dict
