"""Train the Unitree G1 (G1Velocity) with rsl_rl's PPO (``pip install myriad[rsl_rl,anymal]``).

    python examples/rsl_rl_g1.py --minutes 20                  # 512 envs on the CPU
    python examples/rsl_rl_g1.py --device cuda:0 --num-envs 4096 --minutes 10
    python examples/rsl_rl_g1.py --task G1Rough --device cuda:0 --num-envs 4096

The runner config is Isaac Lab's for its G1 (rsl_rl: 256-128-128 ELU networks, horizon 24, 5
epochs of 4 minibatches, learning rate 1e-3 adapted at KL 0.01, entropy 0.008), except the
initial action noise (--init-std, 0.37 here as in Myriad's rl_games config: at Isaac Lab's 1.0
the robot is thrown over before it learns to stand, which a CPU's budget cannot wait out).
Training stops after --minutes of wall time; then the deterministic policy walks fresh episodes
for --eval-seconds and the script prints how far it was from its commands and how many
episodes ended in a fall (as benchmarks/anymal_tracking.py does for rl_games checkpoints).
"""

import argparse
import os
import time

import torch
from rsl_rl.runners import OnPolicyRunner

from myriad.rl.adapters import rsl_rl_env
from myriad.rl.evaluate import command_tracking


def train_cfg(env, init_std: float) -> dict:
    return {
        "num_steps_per_env": 24,
        "save_interval": 50,
        "obs_groups": env.obs_groups,
        "algorithm": {
            "class_name": "PPO", "num_learning_epochs": 5, "num_mini_batches": 4,
            "learning_rate": 1e-3, "schedule": "adaptive", "desired_kl": 0.01,
            "gamma": 0.99, "lam": 0.95, "clip_param": 0.2, "value_loss_coef": 1.0,
            "use_clipped_value_loss": True, "entropy_coef": 0.008, "max_grad_norm": 1.0,
        },
        "actor": {
            "class_name": "MLPModel", "hidden_dims": [256, 128, 128], "activation": "elu",
            "obs_normalization": True,
            "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": init_std},
        },
        "critic": {
            "class_name": "MLPModel", "hidden_dims": [256, 128, 128], "activation": "elu",
            "obs_normalization": True,
        },
    }


def tracking(env, policy, seconds: float) -> str:
    """How well `policy` tracks its commands in fresh episodes (myriad's command_tracking)."""
    env.task.reset()
    obs = env.get_observations()

    def advance():
        nonlocal obs
        obs, _, dones, extras = env.step(policy(obs))
        return dones, extras["time_outs"]

    return command_tracking(env.task, advance, seconds)


def main() -> None:
    parser = argparse.ArgumentParser(description="The G1 with rsl_rl's PPO on Myriad")
    parser.add_argument("--task", default="G1Velocity", choices=["G1Velocity", "G1Rough"])
    parser.add_argument("--num-envs", type=int, default=512)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--minutes", type=float, default=60.0)
    parser.add_argument("--init-std", type=float, default=0.37)
    parser.add_argument("--eval-seconds", type=float, default=20.0)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--log-dir", default="runs/rsl_rl_g1")
    args = parser.parse_args()

    torch.manual_seed(args.seed)
    env = rsl_rl_env(args.task, num_envs=args.num_envs, device=args.device)
    log_dir = os.path.join(args.log_dir, time.strftime("%Y-%m-%d_%H-%M-%S"))
    runner = OnPolicyRunner(env, train_cfg(env, args.init_std), log_dir=log_dir,
                            device=args.device)
    start, iterations = time.time(), 0
    # in blocks of 10 iterations until the time is up (rsl_rl's learn has no time limit);
    # the first block spreads the time-outs over the episode
    while time.time() - start < 60.0 * args.minutes:
        runner.learn(num_learning_iterations=10, init_at_random_ep_len=iterations == 0)
        iterations += 10
    runner.save(os.path.join(log_dir, f"model_{runner.current_learning_iteration}.pt"))
    steps = iterations * 24 * args.num_envs
    print(f"trained {iterations} iterations, {steps:,} env-steps in "
          f"{time.time() - start:.0f} s; checkpoint in {log_dir}")
    print(tracking(env, runner.get_inference_policy(device=args.device), args.eval_seconds))


if __name__ == "__main__":
    main()
