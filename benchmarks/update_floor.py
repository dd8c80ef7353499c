"""The PPO update's time against the floor its matrix products set, on this machine.

    python benchmarks/update_floor.py                      # Ant, its CPU profile
    python benchmarks/update_floor.py --task Humanoid --epochs 4
    python benchmarks/update_floor.py --task Ant --envs 512 --minibatch 4096

The task and the rl_games agent are built as `myriad train` builds them (the task's CPU profile
unless --envs/--minibatch say otherwise) and run whole epochs, rollout then update, in float32
(the first epoch a warm-up): their split, per env-step of the rollout, as `myriad train` reports
it. Then the last rollout's update is run again `--repeats` times, in float32 and with the hidden
MLPs in bfloat16 (`mlp_bfloat16`, where the CPU multiplies bfloat16 natively: AVX-512 BF16 or
AMX) in turn, so that the machine's drift falls on both alike; beside each, its floor: the
update's matrix products alone (every Linear layer's forward x·Wᵀ, the weight's gradient and,
except the first layer's, the input's, for each minibatch of each mini-epoch), as bare `torch.mm`
on tensors of those shapes and dtype, with torch's threads as set.

Whatever the update takes above its floor is the rest of PPO (the activations, losses, the Adam
step, the normalizers, rl_games' bookkeeping per minibatch); below the floor only fewer or
cheaper flops go.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time

import torch


def linear_shapes(model: torch.nn.Module) -> list[tuple[int, int]]:
    return [(m.in_features, m.out_features) for m in model.modules()
            if isinstance(m, torch.nn.Linear)]


def matmul_seconds(shapes, rows: int, passes: int, dtype, repeats: int = 5) -> float:
    """Seconds for `passes` forward+backward passes of `rows` samples through layers of these
    (in, out) shapes, as bare matrix products (the median of `repeats` timings)."""
    tensors = []
    for k, (n_in, n_out) in enumerate(shapes):
        x = torch.randn(rows, n_in, dtype=dtype)
        w = torch.randn(n_out, n_in, dtype=dtype)
        g = torch.randn(rows, n_out, dtype=dtype)
        tensors.append((k, x, w, g))

    def one_pass():
        for k, x, w, g in tensors:
            torch.mm(x, w.t())              # forward
            torch.mm(g.t(), x)              # the weight's gradient
            if k:                           # the input's gradient (observations need none)
                torch.mm(g, w)

    one_pass()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(passes):
            one_pass()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def training_agent(overrides: list[str], float32: bool = False):
    """(task, agent, train config, epoch) as `myriad train` builds them from `overrides` (its
    CPU profile on a CPU), the agent ready for its loop; `epoch(keep=False)` runs one rl_games
    epoch, rollout then update, writing no files, and returns its (step, play, update) seconds;
    `keep` leaves the rollout's dataset in place for more updates. `float32`: the hidden MLPs
    in float32 whatever the train config says."""
    from myriad.physics.runtime import load_kernels
    from myriad.rl.run import compose, task_and_train_configs
    from myriad.rl.train import build_agent
    from myriad.tasks import TASKS

    cfg = compose(overrides)
    task_cfg, train_cfg, device = task_and_train_configs(cfg, overrides)
    if float32:
        train_cfg["params"]["config"].pop("mlp_bfloat16", None)
    load_kernels(device)
    task = TASKS[task_cfg["name"]](task_cfg, device=device)
    run = {"train_dir": tempfile.mkdtemp(prefix="myriad_bench_"), "experiment": "bench",
           "max_time_s": float("inf"), "describe": {}}
    agent = build_agent(task, train_cfg, run, int(cfg.seed))
    # rl_games' train() up to its loop, then its epochs (the base class's: no files written)
    base = type(agent).__mro__[2]                # MyriadAgent -> A2CAgent -> ContinuousA2CBase
    agent.init_tensors()
    agent.obs = agent.env_reset()

    def epoch(keep: bool = False):
        agent.epoch_num = agent.update_epoch()
        times = base.train_epoch(agent)[:3]
        if not keep:
            agent.dataset.update_values_dict(None)
        return times
    return task, agent, train_cfg, epoch


def update_seconds(agent) -> float:
    """One update of rl_games' PPO (its mini-epochs over the minibatches) on the dataset of the
    last rollout, as its train_epoch runs it. rl_games sets the observation normalizer to eval
    mode after the first mini-epoch, but its train_actor_critic calls set_train() for every
    minibatch, which sets it back: the normalizer learns from every mini-epoch's minibatches
    (rl_games 1.6.5: an Ant update of 4 mini-epochs × 4 minibatches found it in training mode
    at all 16 steps)."""
    normalizer = agent.model.running_mean_std if agent.normalize_input else None
    t0 = time.perf_counter()
    for _ in range(agent.mini_epochs_num):
        for i in range(len(agent.dataset)):
            agent.train_actor_critic(agent.dataset[i])
        if normalizer is not None:
            normalizer.eval()
    seconds = time.perf_counter() - t0
    if normalizer is not None:
        normalizer.train()          # as set_train() leaves it for the next update
    return seconds


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", default="Ant")
    parser.add_argument("--envs", type=int, default=None, help="default: the CPU profile's")
    parser.add_argument("--minibatch", type=int, default=None, help="default: the profile's")
    parser.add_argument("--epochs", type=int, default=4, help="timed epochs (after one warm-up)")
    parser.add_argument("--repeats", type=int, default=6,
                        help="updates timed per variant, the variants interleaved")
    args = parser.parse_args()

    from myriad.rl.agent import use_bfloat16_mlps

    overrides = [f"task={args.task}", "device=cpu"]
    if args.envs is not None:
        overrides.append(f"num_envs={args.envs}")
    if args.minibatch is not None:
        overrides.append(f"train.params.config.minibatch_size={args.minibatch}")
    task, agent, train_cfg, epoch = training_agent(overrides, float32=True)    # float32 first
    split = []
    for k in range(args.epochs + 1):
        step_time, play_time, update_time = epoch(keep=k == args.epochs)
        if k:
            split.append((step_time, play_time - step_time, update_time))
    frames = task.num_envs * agent.horizon_length
    physics, policy, update = (statistics.median(s[k] for s in split) for k in range(3))

    # the last rollout's update again, float32 and bfloat16 in turn, each with its floor
    config = train_cfg["params"]["config"]
    minibatch = config["minibatch_size"]
    passes = config["mini_epochs"] * (frames // minibatch)
    shapes = linear_shapes(agent.model)
    mlps = [(mlp, mlp.forward) for net in agent.model.modules()
            for mlp in (getattr(net, n, None) for n in ("actor_mlp", "critic_mlp"))
            if isinstance(mlp, torch.nn.Sequential) and len(mlp) > 0]
    native_bf16 = torch.ops.mkldnn._is_mkldnn_bf16_supported()
    wrapped = {mlp: None for mlp, _ in mlps}
    if native_bf16:
        use_bfloat16_mlps(agent.model, task.device)
        wrapped = {mlp: mlp.forward for mlp, _ in mlps}
    times = {"float32": [], "bfloat16": [], "floor float32": [], "floor bfloat16": []}
    agent.set_train()
    for _ in range(args.repeats):
        for mlp, forward in mlps:
            mlp.forward = forward
        times["float32"].append(update_seconds(agent))
        times["floor float32"].append(matmul_seconds(shapes, minibatch, passes, torch.float32, 1))
        if native_bf16:
            for mlp, _ in mlps:
                mlp.forward = wrapped[mlp]
            times["bfloat16"].append(update_seconds(agent))
            times["floor bfloat16"].append(
                matmul_seconds(shapes, minibatch, passes, torch.bfloat16, 1))

    us = 1e6 / frames
    med = {k: statistics.median(v) * us for k, v in times.items() if v}
    print(f"{args.task}: {task.num_envs} envs × horizon {agent.horizon_length} = {frames} "
          f"samples per epoch; {config['mini_epochs']} mini-epochs of {frames // minibatch} "
          f"minibatches of {minibatch}; layers {shapes}; torch threads "
          f"{torch.get_num_threads()}, {os.cpu_count()} CPU cores")
    print(f"training epochs, float32, median of {args.epochs} (µs per env-step): physics "
          f"{physics * us:.1f}  policy {policy * us:.1f}  update {update * us:.1f}")
    print(f"the update alone, median of {args.repeats} interleaved (µs per env-step):")
    print("| | update | its matrix products alone | update / products |")
    print("|---|---|---|---|")
    for dtype in ("float32", "bfloat16"):
        if dtype in med:
            print(f"| {dtype} | {med[dtype]:.1f} | {med['floor ' + dtype]:.1f} | "
                  f"{med[dtype] / med['floor ' + dtype]:.2f} |")
        else:
            print(f"| {dtype} | not native on this CPU | | |")


if __name__ == "__main__":
    main()
