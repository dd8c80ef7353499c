"""`train()` behind `myriad train`: rl_games' runner with Myriad's agent (`agent.MyriadAgent`, or
`amp.AMPAgent` for HumanoidAMP), a checkpoint to resume or fine-tune from, and the signals that
stop it with the user's files saved (the run's files: `agent`'s docstring)."""

from __future__ import annotations

import json
import os
import random
import signal
import time

import numpy as np
import torch

from rl_games.algos_torch import torch_ext
from rl_games.common import env_configurations, vecenv
from rl_games.torch_runner import Runner

from . import shipped
from .agent import MyriadAgent, MyriadVecEnv, _to_cpu, from_rank_0
from .amp import AMPAgent
from .policy import restore_task_state


def seed_all(seed: int) -> None:
    """torch's generators (CPU and CUDA), numpy's and Python's from one seed. This torch seeds
    its generator from the operating system when it is imported, so whatever draws before the
    seeding (a task's start-up draws: the OpenAI hand's cube scale and masses, the G1's) would
    differ from run to run of one seed."""
    torch.manual_seed(seed)
    np.random.seed(seed % 2**32)
    random.seed(seed)


def rl_games_params(train_cfg: dict, task, run: dict) -> dict:
    """The rl_games parameter dict for this run, from cfg/train/<Task>PPO.yaml."""
    params = json.loads(json.dumps(train_cfg["params"]))      # deep copy
    config = params["config"]
    config.update(env_name="myriad", device=str(task.device), device_name=str(task.device),
                  num_actors=task.num_envs, train_dir=run["train_dir"],
                  full_experiment_name=run["experiment"], print_stats=False,
                  myriad=run)
    batch = task.num_envs * config["horizon_length"]
    if batch % config["minibatch_size"]:
        raise ValueError(f"train.minibatch_size={config['minibatch_size']} must divide num_envs × "
                         f"horizon_length = {task.num_envs} × {config['horizon_length']} = {batch}")
    if task.device.type != "cuda":
        config["mixed_precision"] = False
    return params


def build_agent(task, train_cfg: dict, run: dict, seed: int):
    """An rl_games agent training `task` (already built) with the given PPO config."""
    env_configurations.register("myriad", {"env_creator": lambda **kwargs: task,
                                           "vecenv_type": "MYRIAD"})
    vecenv.register("MYRIAD", lambda config_name, num_actors, **kwargs:
                    MyriadVecEnv(config_name, num_actors, **kwargs))
    params = rl_games_params(train_cfg, task, run)
    distributed = run.get("distributed")
    if distributed is not None and "amp" in params["config"]:
        raise ValueError("multi_gpu=true: the AMP agent (HumanoidAMP) trains its discriminator "
                         "in each process alone; train it in one process")
    # several processes: each its own seed, as rl_games' multi-GPU runner gives (seed + rank)
    params["seed"] = seed + (0 if distributed is None else distributed["rank"])
    if distributed is not None:
        # rl_games' Runner gives torch min(4, cores / world size) CPU threads, with a world size
        # it knows only on its own multi-GPU set-up (1 here): each process would take all the
        # cores, and two on two cores ran 5x slower. Keep OMP_NUM_THREADS (torchrun sets 1 per
        # process unless it is set), else share the machine's cores among its processes.
        local = int(os.environ.get("LOCAL_WORLD_SIZE", "1"))
        params["torch_threads"] = 0 if "OMP_NUM_THREADS" in os.environ else \
            max(1, min(4, (os.cpu_count() or 1) // local))
    # rl_games seeds torch, numpy and random for a truthy seed only (`if self.seed:`), so seed=0
    # trained unseeded (two runs, two initial networks). Seeded here for every seed; rl_games
    # then seeds the others again with the same value, so their runs are as before
    seed_all(params["seed"])
    runner = Runner()
    # Adversarial Motion Priors (HumanoidAMP) or plain PPO
    agent_class = AMPAgent if "amp" in params["config"] else MyriadAgent
    runner.algo_factory.register_builder("a2c_continuous", lambda **kwargs: agent_class(**kwargs))
    runner.load({"params": params})
    return runner.algo_factory.create(runner.algo_name, base_name="run", params=runner.params)


def train(task, train_cfg: dict, run: dict, seed: int, checkpoint: str | None = None) -> dict:
    """Train until max_iterations or max_time_s; returns the summary (on a process other than
    rank 0 of several, which writes no summary: {}).

    SIGINT and SIGTERM stop at the end of the current epoch with a saved checkpoint and raise
    `TrainingStopped`; a second signal saves at once and raises KeyboardInterrupt."""
    agent = build_agent(task, train_cfg, run, seed)
    distributed = run.get("distributed")
    if checkpoint:
        def load():
            # several processes: rank 0 reads the file (other nodes need not see it) and sends
            # its contents to all
            weights = torch_ext.load_checkpoint(checkpoint)
            return weights if distributed is None else _to_cpu(weights)
        fine_tune = False
        try:
            weights = from_rank_0(load, distributed)
            fine_tune = shipped.weights_only(weights)
            if fine_tune:       # a shipped policy: its networks and normalizers, nothing else
                agent.set_weights(weights)
                if agent.has_central_value and "assymetric_vf_nets" in weights:
                    agent.central_value_net.load_state_dict(weights["assymetric_vf_nets"])
            else:
                agent.set_full_state_weights(weights)
        except Exception as err:  # truncated file, or a checkpoint of another task's network
            raise ValueError(f"checkpoint {checkpoint}: cannot "
                             f"{'train on from' if fine_tune else 'resume from'} it "
                             f"({type(err).__name__}: {err})") from err
        if fine_tune:
            # what spans episodes in the task (AnymalTerrain's levels and cost curriculum) goes
            # on from where the shipped policy stood, where its shapes fit these envs: a
            # curriculum restarted at level 0 would spend the first episodes climbing back
            kept = restore_task_state(task, weights)
            if shipped.is_shipped(checkpoint):
                agent.fine_tuned_from = shipped.lineage(run["describe"]["task"])
            print(f"fine-tuning from {checkpoint}: its networks and normalizers"
                  f"{' and the task state (' + ', '.join(kept) + ')' if kept else ''}, a fresh "
                  "optimizer, epoch 0", flush=True)
        else:
            print(f"resuming from {checkpoint}: epoch {agent.epoch_num}, {agent.frame:,} "
                  f"env-steps, best mean reward {agent.best_mean_reward}", flush=True)
    processes = "" if distributed is None else \
        f" per process, {distributed['world_size']} processes (rank 0 writes the files)"
    print(f"training {run['describe']['task']} with {task.num_envs} envs on {task.device}"
          f"{processes}; run files in {agent.experiment_dir}", flush=True)

    def on_signal(signum, frame):
        if agent.stop_signal is not None:      # the second one: no more waiting
            raise KeyboardInterrupt
        agent.stop_signal = signum
        print(f"\n{signal.Signals(signum).name}: stopping at the end of this epoch (send it again "
              "to stop at once)", flush=True)

    previous = {s: signal.signal(s, on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        agent.train()
    except KeyboardInterrupt:
        if agent.writes_files:
            print("\ninterrupted: saving the current policy to nn/last.pth", flush=True)
            agent.save_last()
            mean = float(agent.game_rewards.get_mean()[0]) \
                if agent.game_rewards.current_size else None
            agent.write_summary(agent.frame, time.monotonic() - agent.started, mean)
        raise
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        if agent.writer is not None:
            agent.writer.flush()
    if not agent.writes_files:
        return {}
    with open(os.path.join(agent.experiment_dir, "summary.json")) as f:
        return json.load(f)
