"""The PPO update's minibatch step three ways, side by side on one rollout: rl_games' own (the
KL read to the host after every minibatch for the adaptive learning rate), Myriad's with the
rate on the device (`myriad.rl.update`, the default), and that one captured as a CUDA graph
(`capture_update=true`; CUDA only).

    python benchmarks/update_step.py --device cuda:0 --task Ant --envs 4096
    python benchmarks/update_step.py --device cuda:0 --task ShadowHand --envs 16384
    python benchmarks/update_step.py                        # a CPU: the first two

The task and agent are built as `myriad train` builds them (on a CPU its CPU profile unless
--envs says otherwise), one epoch warms up, and the next rollout's update is then run again and
again, the variants in turn, each as rl_games' update loop runs it (every mini-epoch's
minibatches, the mu/sigma write-back, the schedule), timed from a synchronized device to a
synchronized device. Printed: the update's time per variant (median of --repeats), per
minibatch, and against rl_games'.
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch
from update_floor import training_agent


def update_loop(agent) -> None:
    """rl_games' update loop (ContinuousA2CBase.train_epoch after the dataset is prepared),
    without its statistics lists."""
    for _ in range(agent.mini_epochs_num):
        for i in range(len(agent.dataset)):
            out = agent.train_actor_critic(agent.dataset[i])
            kl, cmu, csigma = out[3], out[6], out[7]
            agent.dataset.update_mu_sigma(cmu, csigma)
            if agent.schedule_type == "legacy":
                agent.last_lr, agent.entropy_coef = agent.scheduler.update(
                    agent.last_lr, agent.entropy_coef, agent.epoch_num, 0, kl.item())
                agent.update_lr(agent.last_lr)
        if agent.normalize_input:
            agent.model.running_mean_std.eval()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="Ant")
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--envs", type=int, default=None, help="default: the task's (on a CPU "
                        "its CPU profile's)")
    parser.add_argument("--repeats", type=int, default=8,
                        help="updates timed per variant, the variants interleaved")
    args = parser.parse_args()

    from myriad.rl.update import MinibatchStep

    overrides = [f"task={args.task}", f"device={args.device}"]
    if args.envs is not None:
        overrides.append(f"num_envs={args.envs}")
    task, agent, train_cfg, epoch = training_agent(overrides)
    cuda = torch.device(agent.ppo_device).type == "cuda"
    if agent.minibatch_step is None:
        raise SystemExit(f"{args.task}: the device-side step does not apply to this agent")
    steps = {"rl_games' step": None, "device-side rate": agent.minibatch_step}
    if cuda:
        steps["captured graph"] = MinibatchStep(agent, capture=True)
    epoch()                                 # warm-up: kernels, the first normalizer update
    epoch(keep=True)                        # the rollout whose update is timed

    def use(step):
        agent.minibatch_step = step
        agent.schedule_type = "legacy" if step is None else "myriad"
        if step is None:        # rl_games' step reads a host number; ours set a tensor
            for group in agent.optimizer.param_groups:
                group["lr"], group["capturable"] = float(agent.last_lr), False
        else:
            step.set_learning_rate(agent.last_lr)

    def sync():
        if cuda:
            torch.cuda.synchronize(agent.ppo_device)

    times = {name: [] for name in steps}
    for round_ in range(args.repeats + 1):     # the first round warms up (and captures)
        for name, step in steps.items():
            use(step)
            agent.set_train()
            sync()
            t0 = time.perf_counter()
            update_loop(agent)
            sync()
            if round_:
                times[name].append(time.perf_counter() - t0)
            if step is not None:
                agent.last_lr = step.learning_rate()
    minibatches = agent.mini_epochs_num * len(agent.dataset)
    base = statistics.median(times["rl_games' step"])
    print(f"{args.task} on {args.device}: {task.num_envs} envs × horizon {agent.horizon_length};"
          f" {agent.mini_epochs_num} mini-epochs of {len(agent.dataset)} minibatches of "
          f"{agent.minibatch_size}; median of {args.repeats} updates per variant, interleaved")
    print("| minibatch step | update (ms) | per minibatch (ms) | speed-up |")
    print("|---|---|---|---|")
    for name, ts in times.items():
        t = statistics.median(ts)
        print(f"| {name} | {t * 1e3:.1f} | {t * 1e3 / minibatches:.2f} | {base / t:.2f}× |")


if __name__ == "__main__":
    main()
