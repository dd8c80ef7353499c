"""PPO on a Myriad task through the gymnasium vector API, CleanRL style: one file, read top to
bottom, one config. The env is `myriad.make_vec` unchanged; its batches are torch tensors on the
device, so the whole loop runs there with no copies.

    python examples/cleanrl_ppo_ant.py                       # Ant, 1024 envs on the CPU
    python examples/cleanrl_ppo_ant.py --device cuda:0 --num-envs 4096 --num-minibatches 4

What the gymnasium semantics ask of the loop (Myriad's autoreset is SAME_STEP):
- the `obs` a step returns for a finished env is already the first of its next episode, so the
  rollout marks `terminated | truncated` as the end of the trajectory;
- a time-out (`truncated`) is not a terminal state: its value is bootstrapped from the episode's
  last observation, `info["final_obs"]`, folded into that step's reward.

The other choices follow the rl_games configuration Myriad's Ant was tuned with (cfg/train/
AntPPO.yaml; docs/results.md has the steps that brought this script level with it): one
256-128-64 ELU trunk shared by the policy mean and the value head, zero biases at the start;
rewards scaled by 0.01; values learned in standardized units (running statistics of values and
returns); advantages standardized over the whole batch; horizon 16, 4 epochs of 2 minibatches on
the CPU; clipped value loss weighted 2 (× 0.5); gradients not clipped; the learning rate adapted
after every minibatch to keep near 0.008 the KL between the policy of one pass over the batch
and the next (rl_games keeps each pass's means and stds for the next; measured from the
rollout's policy instead, the KL grows with every epoch and holds the learning rate down); a
small penalty on action means beyond ±1.1; observations standardized by running statistics.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import time

import torch
import torch.nn as nn

import myriad


@dataclasses.dataclass
class Config:
    task: str = "Ant"
    num_envs: int = 1024
    device: str = "cpu"
    seed: int = 1
    total_timesteps: int = 16_000_000
    num_steps: int = 16                   # rollout horizon per env
    num_minibatches: int = 2
    update_epochs: int = 4
    learning_rate: float = 3e-4
    kl_target: float = 0.008              # the learning rate adapts to keep the KL near this
    gamma: float = 0.99
    gae_lambda: float = 0.95
    clip_coef: float = 0.2
    vf_coef: float = 2.0
    bounds_coef: float = 1e-4
    max_grad_norm: float = 0.0            # 0: no clipping (AntPPO.yaml: truncate_grads False)
    reward_scale: float = 0.01
    hidden: tuple[int, ...] = (256, 128, 64)
    max_time_s: float = 0.0               # stop after this many seconds (0: no limit)
    log_every: int = 10                   # iterations between progress lines
    save_path: str = "runs/cleanrl_ppo_ant.pt"


def parse_config() -> Config:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    for field in dataclasses.fields(Config):
        flag = "--" + field.name.replace("_", "-")
        if field.name == "hidden":
            parser.add_argument(flag, type=int, nargs="+", default=field.default)
        else:
            parser.add_argument(flag, type=type(field.default), default=field.default)
    args = vars(parser.parse_args())
    return Config(**{**args, "hidden": tuple(args["hidden"])})


class RunningNorm(nn.Module):
    """Standardizes by a running mean and variance (merged batch by batch)."""

    def __init__(self, size: int | tuple = ()):
        super().__init__()
        self.register_buffer("mean", torch.zeros(size))
        self.register_buffer("var", torch.ones(size))
        self.register_buffer("count", torch.tensor(1e-4))

    def update(self, x: torch.Tensor) -> None:
        batch_mean, batch_var, n = x.mean(0), x.var(0, unbiased=False), x.shape[0]
        delta, total = batch_mean - self.mean, self.count + n
        self.mean += delta * n / total
        self.var = (self.var * self.count + batch_var * n
                    + delta ** 2 * self.count * n / total) / total
        self.count = total

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return torch.clamp((x - self.mean) / torch.sqrt(self.var + 1e-8), -5.0, 5.0)

    def unnormalize(self, x: torch.Tensor) -> torch.Tensor:
        return x * torch.sqrt(self.var + 1e-8) + self.mean


class Agent(nn.Module):
    """Policy mean and value from one shared trunk; a state-independent log std."""

    def __init__(self, num_obs: int, num_actions: int, hidden: tuple[int, ...]):
        super().__init__()
        self.obs_norm = RunningNorm(num_obs)
        self.value_norm = RunningNorm()          # values are learned standardized
        sizes = [num_obs, *hidden]
        self.trunk = nn.Sequential(*[layer for i in range(len(hidden)) for layer in
                                     (nn.Linear(sizes[i], sizes[i + 1]), nn.ELU())])
        self.actor_mean = nn.Linear(hidden[-1], num_actions)
        self.actor_logstd = nn.Parameter(torch.zeros(num_actions))
        self.value_head = nn.Linear(hidden[-1], 1)
        for layer in self.modules():            # rl_games' "default" initializer: zero biases
            if isinstance(layer, nn.Linear):
                nn.init.zeros_(layer.bias)

    def forward(self, norm_obs: torch.Tensor):
        """(policy mean, standardized value) of standardized observations."""
        features = self.trunk(norm_obs)
        return self.actor_mean(features), self.value_head(features).squeeze(-1)

    def value(self, norm_obs: torch.Tensor) -> torch.Tensor:
        """The value in reward units."""
        return self.value_norm.unnormalize(self(norm_obs)[1])

    def std(self, like: torch.Tensor) -> torch.Tensor:
        return self.actor_logstd.exp().expand_as(like)


def gaussian_kl(mean_old, std_old, mean, std) -> torch.Tensor:
    """KL(old ‖ new) of diagonal Gaussians, summed over actions, averaged over the batch."""
    return (torch.log(std / std_old) + (std_old ** 2 + (mean_old - mean) ** 2) / (2 * std ** 2)
            - 0.5).sum(-1).mean()


def main(cfg: Config) -> None:
    torch.manual_seed(cfg.seed)
    envs = myriad.make_vec(cfg.task, num_envs=cfg.num_envs, device=cfg.device)
    dev, N, T = envs.device, envs.num_envs, cfg.num_steps
    num_obs = envs.single_observation_space.shape[0]
    num_actions = envs.single_action_space.shape[0]
    agent = Agent(num_obs, num_actions, cfg.hidden).to(dev)
    optimizer = torch.optim.Adam(agent.parameters(), lr=cfg.learning_rate, eps=1e-8)
    lr = cfg.learning_rate

    # rollout storage: observations are stored normalized, as the policy saw them
    obs_buf = torch.zeros(T, N, num_obs, device=dev)
    actions_buf = torch.zeros(T, N, num_actions, device=dev)
    logprobs_buf = torch.zeros(T, N, device=dev)
    means_buf = torch.zeros(T, N, num_actions, device=dev)   # the policy's, for the exact KL
    rewards_buf = torch.zeros(T, N, device=dev)
    ends_buf = torch.zeros(T, N, device=dev)          # 1 where the step ended its episode
    values_buf = torch.zeros(T, N, device=dev)

    # episode statistics, kept on the device and read once per progress line
    episode_return = torch.zeros(N, device=dev)
    finished_returns = torch.zeros((), device=dev)
    finished_count = torch.zeros((), device=dev)

    batch_size = N * T
    minibatch_size = batch_size // cfg.num_minibatches
    iterations = cfg.total_timesteps // batch_size
    next_obs, _ = envs.reset(seed=cfg.seed)
    start = time.time()
    try:
        for iteration in range(1, iterations + 1):
            # ---- rollout
            with torch.no_grad():
                for step in range(T):
                    agent.obs_norm.update(next_obs)
                    norm_obs = agent.obs_norm(next_obs)
                    mean, value = agent(norm_obs)
                    dist = torch.distributions.Normal(mean, agent.std(mean))
                    action = dist.sample()
                    obs_buf[step], actions_buf[step], means_buf[step] = norm_obs, action, mean
                    logprobs_buf[step] = dist.log_prob(action).sum(-1)
                    values_buf[step] = agent.value_norm.unnormalize(value)

                    next_obs, reward, terminated, truncated, info = envs.step(action)
                    ended = terminated | truncated
                    # a time-out is no terminal state: bootstrap from the episode's last
                    # observation
                    final_value = agent.value(agent.obs_norm(info["final_obs"]))
                    rewards_buf[step] = cfg.reward_scale * reward \
                        + cfg.gamma * final_value * truncated
                    ends_buf[step] = ended.float()

                    episode_return += reward
                    finished_returns += (episode_return * ended).sum()
                    finished_count += ended.sum()
                    episode_return *= ~ended

                # ---- generalized advantage estimation
                next_value = agent.value(agent.obs_norm(next_obs))
                advantages = torch.zeros_like(rewards_buf)
                last_gae = torch.zeros(N, device=dev)
                for t in reversed(range(T)):
                    following = next_value if t == T - 1 else values_buf[t + 1]
                    not_end = 1.0 - ends_buf[t]
                    delta = rewards_buf[t] + cfg.gamma * following * not_end - values_buf[t]
                    last_gae = delta + cfg.gamma * cfg.gae_lambda * not_end * last_gae
                    advantages[t] = last_gae
                returns = advantages + values_buf

            # ---- PPO update, values and returns in standardized units
            agent.value_norm.update(torch.cat((values_buf.reshape(-1), returns.reshape(-1))))
            b_obs, b_actions = obs_buf.reshape(batch_size, -1), actions_buf.reshape(batch_size, -1)
            b_logprobs, b_means = logprobs_buf.reshape(-1), means_buf.reshape(batch_size, -1)
            b_stds = agent.std(b_means).detach().clone()
            b_advantages = advantages.reshape(-1)
            b_advantages = (b_advantages - b_advantages.mean()) / (b_advantages.std() + 1e-8)
            b_returns = agent.value_norm(returns.reshape(-1))
            b_values = agent.value_norm(values_buf.reshape(-1))
            for _ in range(cfg.update_epochs):
                order = torch.randperm(batch_size, device=dev)
                kls = []
                for first in range(0, batch_size, minibatch_size):
                    mb = order[first:first + minibatch_size]
                    mean, value = agent(b_obs[mb])
                    std = agent.std(mean)
                    dist = torch.distributions.Normal(mean, std)
                    logratio = dist.log_prob(b_actions[mb]).sum(-1) - b_logprobs[mb]
                    ratio = logratio.exp()
                    adv = b_advantages[mb]
                    clipped_ratio = torch.clamp(ratio, 1 - cfg.clip_coef, 1 + cfg.clip_coef)
                    pg_loss = torch.max(-adv * ratio, -adv * clipped_ratio).mean()

                    value_clipped = b_values[mb] + torch.clamp(value - b_values[mb],
                                                               -cfg.clip_coef, cfg.clip_coef)
                    v_loss = torch.max((value - b_returns[mb]) ** 2,
                                       (value_clipped - b_returns[mb]) ** 2).mean()

                    # keep action means inside the actions' range
                    bounds_loss = (torch.relu(mean - 1.1) ** 2
                                   + torch.relu(-1.1 - mean) ** 2).sum(-1).mean()

                    loss = pg_loss + 0.5 * cfg.vf_coef * v_loss + cfg.bounds_coef * bounds_loss
                    optimizer.zero_grad()
                    loss.backward()
                    if cfg.max_grad_norm > 0:
                        nn.utils.clip_grad_norm_(agent.parameters(), cfg.max_grad_norm)
                    optimizer.step()

                    # adaptive learning rate (rl_games' "legacy" rule), after every minibatch,
                    # on the KL from the policy this minibatch saw one epoch before (rl_games
                    # keeps the means and stds of each pass for the next; the ratio still uses
                    # the rollout's log-probabilities)
                    with torch.no_grad():
                        kl = float(gaussian_kl(b_means[mb], b_stds[mb], mean, std))
                        b_means[mb], b_stds[mb] = mean, std
                    kls.append(kl)
                    if kl > 2.0 * cfg.kl_target:
                        lr = max(lr / 1.5, 1e-6)
                    elif kl < 0.5 * cfg.kl_target:
                        lr = min(lr * 1.5, 1e-2)
                    for group in optimizer.param_groups:
                        group["lr"] = lr
            kl = sum(kls) / len(kls)

            if iteration % cfg.log_every == 0 or iteration == iterations:
                count = float(finished_count)
                mean_return = float(finished_returns) / count if count else float("nan")
                finished_returns.zero_()
                finished_count.zero_()
                steps = iteration * batch_size
                elapsed = time.time() - start
                print(f"iter {iteration:5d}  {elapsed:7.1f} s  env-steps {steps:10d}  "
                      f"steps/s {steps / elapsed:8.0f}  "
                      f"episode return {mean_return:8.1f} ({count:.0f} episodes)  "
                      f"value loss {float(v_loss.detach()):.4f}  kl {kl:.4f}  lr {lr:.1e}",
                      flush=True)
            if cfg.max_time_s and time.time() - start > cfg.max_time_s:
                break
    finally:   # a finished, stopped or interrupted run keeps its agent
        if cfg.save_path:
            os.makedirs(os.path.dirname(cfg.save_path) or ".", exist_ok=True)
            torch.save({"agent": agent.state_dict(), "config": dataclasses.asdict(cfg)},
                       cfg.save_path)
            print(f"saved {cfg.save_path}")


if __name__ == "__main__":
    main(parse_config())
