"""Train Ant with rsl_rl's PPO (``pip install myriad[rsl_rl]``: rsl-rl-lib 5.x) on Myriad.

    python examples/rsl_rl_ant.py                              # 1024 envs on the CPU
    python examples/rsl_rl_ant.py --device cuda:0 --num-envs 4096

`myriad.rl.adapters.rsl_rl_env` gives the task as an `rsl_rl.env.VecEnv`; the runner config is
Isaac Lab's for its Ant (rsl_rl, 400-200-100 ELU networks, horizon 32, 5 epochs of 4
minibatches, adaptive learning rate at KL 0.008) with observations normalized. rsl_rl prints a
summary per iteration and writes TensorBoard logs and checkpoints under --log-dir.
"""

import argparse
import os
import time

import torch
from rsl_rl.runners import OnPolicyRunner

from myriad.rl.adapters import rsl_rl_env


def train_cfg(env, save_interval: int) -> dict:
    return {
        "num_steps_per_env": 32,
        "save_interval": save_interval,
        "obs_groups": env.obs_groups,      # actor: "policy"; critic: "critic" or "policy"
        "algorithm": {
            "class_name": "PPO", "num_learning_epochs": 5, "num_mini_batches": 4,
            "learning_rate": 5e-4, "schedule": "adaptive", "desired_kl": 0.008,
            "gamma": 0.99, "lam": 0.95, "clip_param": 0.2, "value_loss_coef": 1.0,
            "use_clipped_value_loss": True, "entropy_coef": 0.0, "max_grad_norm": 1.0,
        },
        "actor": {
            "class_name": "MLPModel", "hidden_dims": [400, 200, 100], "activation": "elu",
            "obs_normalization": True,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0},
        },
        "critic": {
            "class_name": "MLPModel", "hidden_dims": [400, 200, 100], "activation": "elu",
            "obs_normalization": True,
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description="Ant with rsl_rl's PPO on Myriad")
    parser.add_argument("--task", default="Ant")
    parser.add_argument("--num-envs", type=int, default=1024)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--iterations", type=int, default=500)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--log-dir", default="runs/rsl_rl_ant")
    args = parser.parse_args()

    torch.manual_seed(args.seed)
    env = rsl_rl_env(args.task, num_envs=args.num_envs, device=args.device)
    log_dir = os.path.join(args.log_dir, time.strftime("%Y-%m-%d_%H-%M-%S"))
    runner = OnPolicyRunner(env, train_cfg(env, save_interval=100), log_dir=log_dir,
                            device=args.device)
    # spread the first time-outs over the episode so that rollouts never see them all at once
    runner.learn(num_learning_iterations=args.iterations, init_at_random_ep_len=True)


if __name__ == "__main__":
    main()
