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
AntPPO.yaml): 256-128-64 ELU networks, rewards scaled by 0.01, horizon 16, 4 epochs of 2
minibatches on the CPU, clipped value loss weighted 2 (× 0.5), learning rate adapted to a KL of
0.008, a small penalty on action means beyond ±1.1, observations standardized by running
statistics.
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
    max_grad_norm: float = 1.0
    reward_scale: float = 0.01
    hidden: tuple[int, ...] = (256, 128, 64)
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
    """Standardizes observations by their running mean and variance (merged batch by batch)."""

    def __init__(self, size: int):
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


def mlp(sizes: list[int]) -> nn.Sequential:
    layers = []
    for i in range(len(sizes) - 1):
        layers += [nn.Linear(sizes[i], sizes[i + 1]), nn.ELU()]
    return nn.Sequential(*layers[:-1])      # no activation after the output layer


class Agent(nn.Module):
    def __init__(self, num_obs: int, num_actions: int, hidden: tuple[int, ...]):
        super().__init__()
        self.obs_norm = RunningNorm(num_obs)
        self.actor_mean = mlp([num_obs, *hidden, num_actions])
        self.actor_logstd = nn.Parameter(torch.zeros(num_actions))
        self.critic = mlp([num_obs, *hidden, 1])

    def value(self, norm_obs: torch.Tensor) -> torch.Tensor:
        return self.critic(norm_obs).squeeze(-1)

    def policy(self, norm_obs: torch.Tensor) -> torch.distributions.Normal:
        mean = self.actor_mean(norm_obs)
        return torch.distributions.Normal(mean, self.actor_logstd.exp().expand_as(mean))


def main(cfg: Config) -> None:
    torch.manual_seed(cfg.seed)
    envs = myriad.make_vec(cfg.task, num_envs=cfg.num_envs, device=cfg.device)
    dev, N, T = envs.device, envs.num_envs, cfg.num_steps
    num_obs = envs.single_observation_space.shape[0]
    num_actions = envs.single_action_space.shape[0]
    agent = Agent(num_obs, num_actions, cfg.hidden).to(dev)
    optimizer = torch.optim.Adam(agent.parameters(), lr=cfg.learning_rate, eps=1e-5)
    lr = cfg.learning_rate

    # rollout storage: observations are stored normalized, as the policy saw them
    obs_buf = torch.zeros(T, N, num_obs, device=dev)
    actions_buf = torch.zeros(T, N, num_actions, device=dev)
    logprobs_buf = torch.zeros(T, N, device=dev)
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
    for iteration in range(1, iterations + 1):
        # ---- rollout
        with torch.no_grad():
            for step in range(T):
                agent.obs_norm.update(next_obs)
                norm_obs = agent.obs_norm(next_obs)
                dist = agent.policy(norm_obs)
                action = dist.sample()
                obs_buf[step], actions_buf[step] = norm_obs, action
                logprobs_buf[step] = dist.log_prob(action).sum(-1)
                values_buf[step] = agent.value(norm_obs)

                next_obs, reward, terminated, truncated, info = envs.step(action)
                ended = terminated | truncated
                # a time-out is no terminal state: bootstrap from the episode's last observation
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

        # ---- PPO update
        b_obs, b_actions = obs_buf.reshape(batch_size, -1), actions_buf.reshape(batch_size, -1)
        b_logprobs, b_advantages = logprobs_buf.reshape(-1), advantages.reshape(-1)
        b_returns, b_values = returns.reshape(-1), values_buf.reshape(-1)
        for _ in range(cfg.update_epochs):
            order = torch.randperm(batch_size, device=dev)
            kls = []
            for first in range(0, batch_size, minibatch_size):
                mb = order[first:first + minibatch_size]
                dist = agent.policy(b_obs[mb])
                logratio = dist.log_prob(b_actions[mb]).sum(-1) - b_logprobs[mb]
                ratio = logratio.exp()
                with torch.no_grad():
                    kls.append(((ratio - 1) - logratio).mean())

                adv = b_advantages[mb]
                adv = (adv - adv.mean()) / (adv.std() + 1e-8)
                pg_loss = torch.max(-adv * ratio,
                                    -adv * torch.clamp(ratio, 1 - cfg.clip_coef, 1 + cfg.clip_coef)
                                    ).mean()

                value = agent.value(b_obs[mb])
                value_clipped = b_values[mb] + torch.clamp(value - b_values[mb],
                                                           -cfg.clip_coef, cfg.clip_coef)
                v_loss = torch.max((value - b_returns[mb]) ** 2,
                                   (value_clipped - b_returns[mb]) ** 2).mean()

                mean = dist.mean          # keep action means inside the actions' range
                bounds_loss = (torch.relu(mean - 1.1) ** 2 + torch.relu(-1.1 - mean) ** 2).sum(-1)

                loss = pg_loss + 0.5 * cfg.vf_coef * v_loss + cfg.bounds_coef * bounds_loss.mean()
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), cfg.max_grad_norm)
                optimizer.step()

            # adaptive learning rate (rl_games' "legacy" rule); one read of the device per epoch
            kl = float(torch.stack(kls).mean())
            if kl > 2.0 * cfg.kl_target:
                lr = max(lr / 1.5, 1e-6)
            elif kl < 0.5 * cfg.kl_target:
                lr = min(lr * 1.5, 1e-2)
            for group in optimizer.param_groups:
                group["lr"] = lr

        if iteration % cfg.log_every == 0 or iteration == iterations:
            count = float(finished_count)
            mean_return = float(finished_returns) / count if count else float("nan")
            finished_returns.zero_()
            finished_count.zero_()
            steps = iteration * batch_size
            print(f"iter {iteration:5d}  env-steps {steps:10d}  "
                  f"steps/s {steps / (time.time() - start):8.0f}  "
                  f"episode return {mean_return:8.1f} ({count:.0f} episodes)  "
                  f"value loss {float(v_loss.detach()):.4f}  kl {kl:.4f}  lr {lr:.1e}", flush=True)

    if cfg.save_path:
        os.makedirs(os.path.dirname(cfg.save_path) or ".", exist_ok=True)
        torch.save({"agent": agent.state_dict(), "config": dataclasses.asdict(cfg)},
                   cfg.save_path)
        print(f"saved {cfg.save_path}")


if __name__ == "__main__":
    main(parse_config())
