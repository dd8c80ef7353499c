"""The PPO loop's rollout and update three ways each, side by side: rl_games' own (the rollout
reads the finished envs back at every env step, the update every minibatch's KL), Myriad's
with nothing read back (`myriad.rl.rollout`, `myriad.rl.update`: the default), and those
captured as CUDA graphs (the rollout's whole step with `capture_step=true`, the update's
minibatch step with `capture_update=true`; CUDA only).

    python benchmarks/loop_steps.py --device cuda:0 --task Ant --envs 4096
    python benchmarks/loop_steps.py --device cuda:0 --task ShadowHand --envs 16384
    python benchmarks/loop_steps.py                         # a CPU: the first two of each

The task and agent are built as `myriad train` builds them (on a CPU its CPU profile unless
--envs says otherwise) and two epochs warm up. Then, the variants in turn, a rollout (horizon
env steps, the policy acting) and the update of one kept rollout (every mini-epoch's
minibatches as rl_games' loop runs them, with the mu/sigma write-back and the schedule), each
timed from a synchronized device to a synchronized device. Printed: the median of --repeats per
variant, and the speed-up over rl_games'.
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
                        help="rollouts and updates timed per variant, the variants interleaved")
    args = parser.parse_args()

    from rl_games.algos_torch import torch_ext

    from myriad.rl.rollout import Rollout
    from myriad.rl.update import MinibatchStep

    overrides = [f"task={args.task}", f"device={args.device}"]
    if args.envs is not None:
        overrides.append(f"num_envs={args.envs}")
    task, agent, train_cfg, epoch = training_agent(overrides)
    cuda = torch.device(agent.ppo_device).type == "cuda"
    if agent.minibatch_step is None or agent.rollout is None:
        raise SystemExit(f"{args.task}: Myriad's rollout or minibatch step does not apply")
    ours = agent.rollout
    meters = {name: getattr(agent, name)
              for name in ("game_rewards", "game_shaped_rewards", "game_lengths")}
    rl_meters = {name: torch_ext.AverageMeter(m.mean.shape[0], agent.games_to_track)
                 .to(agent.ppo_device) for name, m in meters.items()}
    rollouts = {"rl_games' play_steps": (None, rl_meters), "nothing read back": (ours, meters)}
    steps = {"rl_games' step": None, "nothing read back": agent.minibatch_step}
    if cuda:
        rollouts["captured step"] = (Rollout(agent, capture=True), meters)
        steps["captured step"] = MinibatchStep(agent, capture=True)
    epoch()                                 # warm-up: kernels, the first normalizer update
    epoch(keep=True)                        # the rollout whose update is timed
    dataset = agent.dataset.values_dict

    def sync():
        if cuda:
            torch.cuda.synchronize(agent.ppo_device)

    def use_step(step):
        agent.minibatch_step = step
        agent.schedule_type = "legacy" if step is None else "myriad"
        if step is None:        # rl_games' step reads a host number; ours set a tensor
            for group in agent.optimizer.param_groups:
                group["lr"], group["capturable"] = float(agent.last_lr), False
        else:
            step.set_learning_rate(agent.last_lr)

    def timed(run) -> float:
        sync()
        start = time.perf_counter()
        run()
        sync()
        return time.perf_counter() - start

    def play():
        agent.set_eval()
        with torch.no_grad():
            agent.play_steps()

    times = {("rollout", name): [] for name in rollouts}
    times.update({("update", name): [] for name in steps})
    for round_ in range(args.repeats + 1):     # the first round warms up (and captures)
        for name, (rollout, meter_set) in rollouts.items():
            agent.rollout = rollout
            for attr, meter in meter_set.items():
                setattr(agent, attr, meter)
            t = timed(play)
            if round_:
                times[("rollout", name)].append(t)
        agent.dataset.update_values_dict(dataset)      # the kept rollout's, for every update
        for name, step in steps.items():
            use_step(step)
            agent.set_train()
            t = timed(lambda: update_loop(agent))
            if round_:
                times[("update", name)].append(t)
            if step is not None:
                agent.last_lr = step.learning_rate()
    minibatches = agent.mini_epochs_num * len(agent.dataset)
    print(f"{args.task} on {args.device}: {task.num_envs} envs × horizon {agent.horizon_length};"
          f" {agent.mini_epochs_num} mini-epochs of {len(agent.dataset)} minibatches of "
          f"{agent.minibatch_size}; median of {args.repeats} per variant, interleaved")
    print("| part | variant | ms | per env step or minibatch (ms) | speed-up |")
    print("|---|---|---|---|---|")
    for part, per in (("rollout", agent.horizon_length), ("update", minibatches)):
        base = None
        for (p, name), ts in times.items():
            if p != part:
                continue
            t = statistics.median(ts)
            base = base or t
            print(f"| {part} | {name} | {t * 1e3:.1f} | {t * 1e3 / per:.2f} | {base / t:.2f}× |")


if __name__ == "__main__":
    main()
