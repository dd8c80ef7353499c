"""Train Ant with skrl's PPO (``pip install myriad[skrl]``: skrl 2.x, torch) on Myriad.

    python examples/skrl_ant.py                                # 1024 envs on the CPU
    python examples/skrl_ant.py --device cuda:0 --num-envs 4096

`myriad.rl.adapters.skrl_env` gives the task as an skrl torch env wrapper. The agent follows
the rl_games configuration Myriad's Ant was tuned with (256-128-64 ELU networks, horizon 16,
4 epochs of 2 minibatches, rewards scaled by 0.01, adaptive learning rate at KL 0.008),
with observations and values standardized and time-outs bootstrapped (skrl's
`time_limit_bootstrap`, fed by the adapter's `truncated`). A line of progress is printed every
--log-every rollouts; TensorBoard logs and checkpoints go under --log-dir.
"""

import argparse

import numpy as np
import torch
import torch.nn as nn
from skrl.agents.torch.ppo import PPO, PPO_CFG
from skrl.memories.torch import RandomMemory
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
from skrl.resources.preprocessors.torch import RunningStandardScaler
from skrl.resources.schedulers.torch import KLAdaptiveLR
from skrl.trainers.torch import SequentialTrainer

from myriad.rl.adapters import skrl_env

HIDDEN = (256, 128, 64)


def mlp(sizes):
    layers = []
    for i in range(len(sizes) - 1):
        layers += [nn.Linear(sizes[i], sizes[i + 1]), nn.ELU()]
    return nn.Sequential(*layers[:-1])


class Policy(GaussianMixin, Model):
    def __init__(self, env):
        Model.__init__(self, observation_space=env.observation_space,
                       action_space=env.action_space, device=env.device)
        GaussianMixin.__init__(self, clip_actions=False)
        self.net = mlp([self.num_observations, *HIDDEN, self.num_actions])
        self.log_std = nn.Parameter(torch.zeros(self.num_actions))

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {"log_std": self.log_std}


class Value(DeterministicMixin, Model):
    def __init__(self, env):
        Model.__init__(self, observation_space=env.observation_space,
                       action_space=env.action_space, device=env.device)
        DeterministicMixin.__init__(self)
        self.net = mlp([self.num_observations, *HIDDEN, 1])

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {}


class PrintingPPO(PPO):
    """skrl's PPO that also prints what it writes to TensorBoard."""

    def write_tracking_data(self, *, timestep: int, timesteps: int) -> None:
        data = self.tracking_data

        def mean(key):
            return np.mean(data[key]) if data.get(key) else float("nan")

        env_steps = timestep * self.memory.num_envs
        print(f"timestep {timestep:7d}/{timesteps}  env-steps {env_steps:10d}  "
              f"episode return {mean('Reward / Total reward (mean)'):8.1f}  "
              f"episode length {mean('Episode / Total timesteps (mean)'):6.1f}  "
              f"value loss {mean('Loss / Value loss'):.4f}", flush=True)
        super().write_tracking_data(timestep=timestep, timesteps=timesteps)


def main() -> None:
    parser = argparse.ArgumentParser(description="Ant with skrl's PPO on Myriad")
    parser.add_argument("--task", default="Ant")
    parser.add_argument("--num-envs", type=int, default=1024)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--timesteps", type=int, default=16000, help="env steps per env")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--log-every", type=int, default=10, help="rollouts between lines")
    parser.add_argument("--log-dir", default="runs/skrl_ant")
    args = parser.parse_args()

    torch.manual_seed(args.seed)
    env = skrl_env(args.task, num_envs=args.num_envs, device=args.device)
    rollouts = 16
    cfg = PPO_CFG(
        rollouts=rollouts, learning_epochs=4, mini_batches=2, discount_factor=0.99,
        gae_lambda=0.95, learning_rate=3e-4, learning_rate_scheduler=KLAdaptiveLR,
        learning_rate_scheduler_kwargs={"kl_threshold": 0.008},
        observation_preprocessor=RunningStandardScaler,
        observation_preprocessor_kwargs={"size": env.observation_space, "device": env.device},
        value_preprocessor=RunningStandardScaler,
        value_preprocessor_kwargs={"size": 1, "device": env.device},
        ratio_clip=0.2, value_clip=0.2, value_loss_scale=2.0, grad_norm_clip=1.0,
        entropy_loss_scale=0.0, time_limit_bootstrap=True,
        rewards_shaper=lambda rewards, timestep, timesteps: rewards * 0.01)
    cfg.experiment.directory = args.log_dir
    cfg.experiment.write_interval = rollouts * args.log_every
    cfg.experiment.checkpoint_interval = rollouts * 100
    agent = PrintingPPO(
        models={"policy": Policy(env), "value": Value(env)},
        memory=RandomMemory(memory_size=rollouts, num_envs=env.num_envs, device=env.device),
        cfg=cfg, observation_space=env.observation_space, state_space=env.state_space,
        action_space=env.action_space, device=env.device)
    trainer = SequentialTrainer(env=env, agents=agent, cfg={
        "timesteps": args.timesteps, "headless": True, "disable_progressbar": True})
    trainer.train()


if __name__ == "__main__":
    main()
