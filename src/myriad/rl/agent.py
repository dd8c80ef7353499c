"""rl_games' PPO as Myriad trains with it: the env adapter and an agent that keeps time and the
user's files safe (`train.train` builds it and runs it behind `myriad train`).

Files of a run, under runs/<experiment>/:
    nn/last.pth         the newest checkpoint (written atomically: a crash or a signal leaves the
                        previous one whole); nn/<Task>.pth is the best mean reward so far, only
                        ever replaced by a better one, across resumes too (a resumed run judges
                        none in its first two episode lengths: its envs start together)
    summary.json        epochs, env_steps, wall_s, mean_reward (last mean episode reward),
                        best_mean_reward, the time split (physics / policy / update), the count
                        of non-finite actions, and the checkpoint with the epoch it holds
    progress.csv        one line per PPO epoch: the learning curve
    summaries/          TensorBoard scalars (rl_games' and ours)

A checkpoint holds everything a run needs to continue as if never stopped: the networks, the
optimizer, the observation/value normalizers, the epoch and env-step counters, the wall time, the
best reward, the random generators' states and what spans episodes in the task
(`VecTask.checkpointed`: terrain levels, a reward term's schedule, the randomization schedule);
the envs themselves start fresh episodes.

SIGINT (Ctrl-C) and SIGTERM (docker stop, Slurm, Kubernetes) finish the current epoch, save
nn/last.pth and summary.json, and exit with 128 + the signal number; a second signal saves at
once, mid-epoch.

Several processes (`multi_gpu=true` under torchrun, one process per GPU, or per CPU process):
the process group is started by run.py (NCCL on GPUs, gloo on CPUs) and each process trains its
share of the envs on rl_games' own multi-GPU path: the parameters broadcast from rank 0 before
the first epoch, gradients averaged across the processes at every minibatch, the KL and rank 0's
learning rate shared. Added here: after each update the observation and value normalizers
merge what every process added to them (so that all processes hold the same statistics, and the
checkpoint those of all envs); after each epoch the processes agree on stopping (a signal,
max_time_s) and on the count of non-finite actions, and share their task metrics (averaged) and
task state (kept by rank 0's checkpoints, each process's own restored on resume); only rank 0
writes the run's files and prints the progress line, its env_steps counting the steps of all
processes.
"""

from __future__ import annotations

import contextlib
import csv
import json
import math
import os
import pickle
import random
import signal
import time
import warnings

import numpy as np

import torch
import torch.distributed as dist
from rl_games.algos_torch import a2c_continuous
from rl_games.common import a2c_common, env_configurations, vecenv

from . import rollout, update


def atomic_write(path: str, write) -> None:
    """Write through a temporary file and rename: readers never see a half-written file."""
    tmp = f"{path}.tmp{os.getpid()}"
    write(tmp)
    os.replace(tmp, path)


def atomic_json(path: str, data: dict) -> None:
    def write(tmp):
        with open(tmp, "w") as f:
            json.dump(data, f, indent=2)
    atomic_write(path, write)


class EpochClock:
    """Where an epoch's time went: physics (the env steps), policy (the rest of the rollout:
    acting, storing) and update (PPO's, and the AMP discriminator's).

    On a CPU, rl_games' host timers say it. On a GPU they do not: work is queued, an env step
    returns before its kernels run, and the wait lands in whatever next reads a result (the
    policy's rollout, mostly). There the split comes from CUDA events recorded on the stream
    that the step's Warp launches are ordered on, read once per epoch."""

    def __init__(self, device):
        self.cuda = torch.device(device).type == "cuda"
        self.steps: list[tuple[torch.cuda.Event, torch.cuda.Event]] = []
        self.marks: dict[str, torch.cuda.Event] = {}
        self.paused = False     # while a graph is captured: its replays are timed instead

    def _event(self):
        event = torch.cuda.Event(enable_timing=True)
        event.record()
        return event

    def mark(self, name: str) -> None:
        if self.cuda:
            self.marks[name] = self._event()

    def step(self, run_step):
        if not self.cuda or self.paused:
            return run_step()
        begin = self._event()
        out = run_step()
        self.steps.append((begin, self._event()))
        return out

    def split(self, step_time: float, play_time: float, update_time: float):
        """(physics_s, policy_s, update_s) of the epoch that just ended (marks "play",
        "played" and "end"), from the host timers on a CPU, from the events on a GPU."""
        if not self.cuda or not {"play", "played", "end"} <= self.marks.keys():
            self.steps.clear()
            return step_time, play_time - step_time, update_time
        self.marks["end"].synchronize()
        physics = sum(a.elapsed_time(b) for a, b in self.steps) / 1e3
        play = self.marks["play"].elapsed_time(self.marks["played"]) / 1e3
        update = self.marks["played"].elapsed_time(self.marks["end"]) / 1e3
        self.steps.clear()
        self.marks.clear()
        return physics, play - physics, update


class MyriadVecEnv(vecenv.IVecEnv):
    """rl_games' view of a `VecTask` (already batched and on the device: nothing to convert)."""

    def __init__(self, config_name, num_actors, **kwargs):
        self.env = env_configurations.configurations[config_name]["env_creator"](**kwargs)
        self.clock = EpochClock(self.env.device)

    def step(self, actions):
        return self.clock.step(lambda: self.env.step(actions))

    def reset(self):
        return self.env.reset()

    def get_number_of_agents(self):
        return 1

    def get_env_info(self):
        info = {"action_space": self.env.action_space,
                "observation_space": self.env.observation_space}
        if self.env.num_states > 0:
            info["state_space"] = self.env.state_space
        return info


def use_bfloat16_mlps(model: torch.nn.Module, device) -> bool:
    """Run the hidden MLPs of an rl_games network (`actor_mlp`, `critic_mlp`) under CPU
    bfloat16 autocast, on a CPU with native bfloat16 matrix products (AVX-512 BF16 or AMX):
    their matrix products in bfloat16, everything after them (action means, values, log
    probabilities, losses, the optimizer, the weights) in float32. The modules and their
    state_dict keys are unchanged, so checkpoints load either way. On such a CPU the Shadow
    Hand's 512-512-256-128 update runs 1.8x faster (forward, backward and Adam on 2048
    samples, two cores: 43 -> 23 ms); elsewhere bfloat16 is emulated and slower, so nothing
    changes. Returns whether anything runs in bfloat16."""
    if torch.device(device).type != "cpu":
        return False         # a GPU: rl_games' mixed_precision is the setting there
    if not torch.ops.mkldnn._is_mkldnn_bf16_supported():
        print("mlp_bfloat16: this CPU has no native bfloat16 matrix products; float32 kept")
        return False
    wrapped = False
    for net in model.modules():
        for name in ("actor_mlp", "critic_mlp"):
            mlp = getattr(net, name, None)
            if isinstance(mlp, torch.nn.Sequential) and len(mlp) > 0:
                mlp.forward = _in_bfloat16(mlp.forward)
                wrapped = True
    return wrapped


def _in_bfloat16(forward):
    def run(x):
        with torch.autocast("cpu", dtype=torch.bfloat16):
            return forward(x).float()
    return run


class TrainingStopped(Exception):
    """A stop signal arrived; the run was saved at the end of an epoch."""

    def __init__(self, signum: int):
        super().__init__(f"stopped by {signal.Signals(signum).name}")
        self.signum = signum


# ---------------------------------------------------------------- several processes
@contextlib.contextmanager
def _summary_writer_on_rank_0_only(rank: int):
    """rl_games builds its TensorBoard writer in A2CBase.__init__ when `global_rank == 0`, a rank
    it knows only on its own multi-GPU set-up, which we keep off (see
    `MyriadAgent.join_processes`). On the other ranks hand it None, as its own set-up does: they
    write no event file."""
    if rank == 0:
        yield
        return
    original = a2c_common.SummaryWriter
    a2c_common.SummaryWriter = lambda *args, **kwargs: None
    try:
        yield
    finally:
        a2c_common.SummaryWriter = original


def _normalizers(nets) -> list[torch.nn.Module]:
    """The running mean/variance normalizers (observations, values) inside rl_games networks:
    modules with running_mean, running_var and count buffers (they are TorchScript modules, so
    found by their buffers, not their class)."""
    return [m for m in torch.nn.ModuleList(nets).modules()
            if all(isinstance(getattr(m, name, None), torch.Tensor)
                   for name in ("running_mean", "running_var", "count"))]


def _to_cpu(tree):
    """A checkpoint's tensors moved to the CPU (for a broadcast: every rank copies them to its own
    device when it loads them)."""
    if isinstance(tree, torch.Tensor):
        return tree.cpu()
    if isinstance(tree, dict):
        return {k: _to_cpu(v) for k, v in tree.items()}
    if isinstance(tree, (list, tuple)):
        return type(tree)(_to_cpu(v) for v in tree)
    return tree


def from_rank_0(compute, distributed: dict | None):
    """`compute()` run on rank 0 alone, its value (or its exception) on every rank: one
    broadcast. A single process just runs it."""
    if distributed is None:
        return compute()
    box = [None]
    if distributed["rank"] == 0:
        try:
            box = [(True, compute())]
        except Exception as err:        # every rank raises it, none waits for rank 0 forever
            try:
                pickle.dumps(err)
            except Exception:
                err = RuntimeError(f"{type(err).__name__}: {err}")
            box = [(False, err)]
    dist.broadcast_object_list(box, src=0)
    ok, value = box[0]
    if not ok:
        raise value
    return value


class MyriadAgent(a2c_continuous.A2CAgent):
    """rl_games' continuous PPO agent plus: a wall-time limit, a progress line per epoch,
    atomic and complete checkpoints, resume, stop signals, `summary.json` and `progress.csv`;
    with `run["distributed"]`, one of several processes training together (module docstring)."""

    def __init__(self, base_name, params):
        self.run_cfg = params["config"].pop("myriad")
        mlp_bfloat16 = params["config"].pop("mlp_bfloat16", False)
        self.symmetry = bool(params["config"].pop("symmetry", False))
        distributed = self.run_cfg.get("distributed")
        rank = 0 if distributed is None else distributed["rank"]
        if rank != 0:
            # as rl_games' multi-GPU set-up does on the other ranks: rank 0's learning-rate
            # schedule decides (update_lr broadcasts its rate), rank 0 prints
            params["config"].update(print_stats=False, lr_schedule=None)
        with _summary_writer_on_rank_0_only(rank):
            super().__init__(base_name, params)
        if distributed is not None:
            self.join_processes(distributed)
        if self.symmetry:
            task = self.vec_env.env
            if not hasattr(task, "mirror_observations"):
                raise ValueError(f"train.params.config.symmetry=true: task "
                                 f"{type(task).__name__} declares no left-right mirror "
                                 "(mirror_observations, mirror_actions; the G1 tasks do)")
            if self.is_rnn or self.has_central_value:
                raise ValueError("train.params.config.symmetry=true: not with a recurrent "
                                 "policy or an asymmetric critic")
        if mlp_bfloat16:       # the policy's network and the asymmetric critic's, if any
            critic = getattr(self, "central_value_net", None)
            use_bfloat16_mlps(torch.nn.ModuleList(
                [self.model] + ([critic.model] if critic is not None else [])), self.device)
        # the minibatch step with the adaptive learning rate on the device (myriad.rl.update),
        # captured as a CUDA graph with capture_update=true; rl_games' own where it cannot be
        capture = bool(self.run_cfg.get("capture_update", False))
        why_not = update.unsupported(self)
        if why_not is not None and capture and torch.device(self.device).type == "cuda":
            raise ValueError(f"capture_update=true: not with {why_not}")
        self.minibatch_step = update.MinibatchStep(self, capture) if why_not is None else None
        if self.minibatch_step is not None and self.has_central_value:
            update.critic_loss_kept_on_device(self.central_value_net)
        # the rollout counts finished episodes on the device (myriad.rl.rollout), and with
        # capture_step=true on CUDA replays each step, the policy's inference included, as one
        # graph (the task's own step graph then stays off); a recurrent policy's, or one with
        # action masks, keeps rl_games' rollout
        self.rollout = None
        if not self.is_rnn and not self.use_action_masks:
            task = self.vec_env.env
            whole = task.capture_step and task.device.type == "cuda" and \
                rollout.capture_unsupported(self) is None
            rollout.use_episode_meters(self)
            self.rollout = rollout.Rollout(self, capture=whole)
            if whole:
                task.capture_step = False
        self.started = time.monotonic()
        self.time_split = {"physics_s": 0.0, "policy_s": 0.0, "update_s": 0.0}
        self.best_mean_reward = None        # best mean episode reward seen, any epoch
        self.best_saved_reward = -math.inf  # reward of the policy in nn/<Task>.pth
        self.restored_best = None
        self.settled_epoch = 0              # the first epoch whose mean reward counts as a best
        self.nonfinite_actions = 0          # env-steps whose action had a NaN or inf
        self.contact_overflow_steps = 0     # env-steps that found more contacts than slots
        # the shipped policy this run was fine-tuned from (`shipped.lineage`), kept through
        # resumes: shipping the run counts that policy's training too
        self.fine_tuned_from = None
        self.checkpoint_epoch = None        # the epoch nn/last.pth holds
        self.frames_not_counted = 0         # this epoch's env-steps, before rl_games adds them
        self.stop_signal = None
        self.task_states = None             # several processes: each one's task state, by rank
        self.last_save = time.monotonic()
        self.curve_path = os.path.join(self.experiment_dir, "progress.csv")
        # a task's own scalars (`metrics()`, e.g. the hands' consecutive_successes): columns
        # of progress.csv after ours, in the progress line, summary.json and TensorBoard
        self.metric_names = sorted(self.task_metrics())
        if not self.writes_files:
            return
        with open(self.curve_path, "a", newline="") as f:
            if f.tell() == 0:
                csv.writer(f).writerow(["epoch", "env_steps", "wall_s", "mean_reward",
                                        "env_steps_per_s", "physics_s", "policy_s", "update_s",
                                        "nonfinite_actions"] + self.metric_names)

    def task_metrics(self) -> dict[str, float]:
        metrics = getattr(self.vec_env.env, "metrics", None)
        return metrics() if metrics is not None else {}

    def share_task_state(self) -> dict[str, float]:
        """This epoch's task metrics over all processes' envs. Several processes: each metric is
        a mean over a process's envs (or its last episodes) and every process holds as many, so
        the processes' means are averaged; and every process's checkpointed task state (its
        envs' terrain levels) is kept for rank 0's checkpoints, so that a resumed run gives
        each process back its own. One all-gather of a few small objects per epoch."""
        metrics = self.task_metrics()
        if not self.multi_gpu:
            return metrics
        state = getattr(self.vec_env.env, "training_state", dict)()
        table = [None] * self.world_size
        dist.all_gather_object(table, (metrics, state))
        self.task_states = [theirs for _, theirs in table]
        return {k: sum(m[k] for m, _ in table) / self.world_size for k in metrics}

    # ---------------------------------------------------------------- several processes
    @property
    def writes_files(self) -> bool:
        """Whether this process writes the run's files and prints: rank 0, or the only one."""
        return self.global_rank == 0

    def join_processes(self, distributed: dict) -> None:
        """Switch on rl_games' multi-GPU path (`multi_gpu`: gradient all-reduce, the parameter
        broadcast at the start of train(), the KL average, rank 0's learning rate and exit
        decision) in the process group that run.py started.

        Why not rl_games' own set-up (config `multi_gpu: true`): A2CBase.__init__ then calls
        `dist.init_process_group("nccl", ...)`, which fails on a CPU (no NCCL there: gloo is its
        backend) and, the group being ours already, everywhere; and it then moves the agent to
        cuda:LOCAL_RANK, a device a CPU process does not have. So the constructor runs rl_games'
        single-process set-up on our device (the rank-dependent parts of its multi-GPU set-up are
        done in __init__ above), and the flag is switched on here, before train()."""
        rank, world = distributed["rank"], distributed["world_size"]
        # train() calls torch.cuda.set_device(self.local_rank) on this path: the GPU's index, and
        # on a CPU -1, which torch documents as set_device's no-op
        local = distributed["local_rank"] if self.ppo_device.startswith("cuda") else -1
        critic = getattr(self, "central_value_net", None)
        for agent in (self, critic):        # the asymmetric critic averages its gradients too
            if agent is not None:
                agent.multi_gpu = True
                agent.global_rank, agent.local_rank, agent.world_size = rank, local, world
        self.normalizers = _normalizers(
            [self.model] + ([critic.model] if critic is not None else []))
        self.normalizers_before = []

    def remember_normalizers(self) -> None:
        """The normalizers' statistics before an epoch's update (the same in every process)."""
        if self.multi_gpu:
            self.normalizers_before = [(m.running_mean.clone(), m.running_var.clone(),
                                        m.count.clone()) for m in self.normalizers]

    def merge_normalizers(self) -> None:
        """After an epoch's update each process's normalizers hold the statistics from before it
        (mean0, var0, count0, the same everywhere) merged with its own batches; rl_games averages
        gradients, not these. Replace them everywhere with the statistics from before merged with
        the batches of all processes: one all-reduce of each process's count, sum and sum of
        squares (in float64), from which the K - 1 extra copies of the statistics from before are
        taken away. Exact (the running merge is associative), and the same in every process."""
        if not self.multi_gpu or not self.normalizers:
            return
        parts = []
        for m in self.normalizers:
            mean, var, count = m.running_mean.double(), m.running_var.double(), m.count.double()
            parts += [(mean * count).reshape(-1), ((var + mean * mean) * count).reshape(-1),
                      count.reshape(1)]
        sums = torch.cat(parts)
        dist.all_reduce(sums, op=dist.ReduceOp.SUM)
        extra, at = self.world_size - 1, 0
        with torch.no_grad():
            for m, (mean0, var0, count0) in zip(self.normalizers, self.normalizers_before):
                k = mean0.numel()
                mean0, var0, count0 = mean0.double().reshape(-1), var0.double().reshape(-1), \
                    count0.double()
                count = sums[at + 2 * k] - extra * count0
                mean = (sums[at:at + k] - extra * mean0 * count0) / count
                square = (sums[at + k:at + 2 * k]
                          - extra * (var0 + mean0 * mean0) * count0) / count
                var = (square - mean * mean).clamp_min(0.0)
                m.running_mean.copy_(mean.view_as(m.running_mean))
                m.running_var.copy_(var.view_as(m.running_var))
                m.count.copy_(count.view_as(m.count))
                at += 2 * k + 1

    def agree(self, stop, out_of_time: bool, nonfinite: int):
        """After an epoch, what all processes act on: the stop signal any of them got (the
        largest number), whether any is out of time, and the sum of their non-finite actions.
        One all-gather of three numbers; a single process returns its own."""
        if not self.multi_gpu:
            return stop, out_of_time, nonfinite
        mine = torch.tensor([stop or 0, int(out_of_time), nonfinite], dtype=torch.int64,
                            device=self.ppo_device)
        table = [torch.zeros_like(mine) for _ in range(self.world_size)]
        dist.all_gather(table, mine)
        signals, late, bad = torch.stack(table).cpu().T.tolist()
        return (max(signals) or None), any(late), sum(bad)

    def wait_for_rank_0(self) -> None:
        """All processes wait here for rank 0 (e.g. to finish writing before they exit together:
        torchrun stops every process as soon as one exits with an error)."""
        if self.multi_gpu:
            dist.barrier()

    # ---------------------------------------------------------------- checkpoints
    def save(self, fn) -> bool:
        """Every rl_games save goes through here: the best-policy file is written only for a
        better policy than the one it holds, and never a policy with non-finite weights.
        Returns whether the file was written."""
        if not self.writes_files:
            return False
        best = fn == os.path.join(self.nn_dir, self.config["name"])
        if best and not self.mean_rewards > self.best_saved_reward or not self.weights_finite():
            return False
        if best:
            self.best_saved_reward = float(self.mean_rewards)
        state = self.get_full_state_weights()
        atomic_write(fn + ".pth", lambda tmp: torch.save(state, tmp))
        return True

    def save_last(self):
        if not self.writes_files:
            return
        if not self.save(os.path.join(self.nn_dir, "last")):
            print(f"not saving epoch {self.epoch_num}: the policy's weights are non-finite; "
                  f"nn/last.pth keeps epoch {self.checkpoint_epoch}", flush=True)
            return
        self.checkpoint_epoch = self.epoch_num
        self.last_save = time.monotonic()

    def weights_finite(self) -> bool:
        """One reduction on the device, one read back."""
        return bool(torch.stack([torch.isfinite(p).all() for p in self.model.parameters()]).all())

    def get_full_state_weights(self):
        state = super().get_full_state_weights()
        state["frame"] = self.frame + self.frames_not_counted
        for group in state["optimizer"]["param_groups"]:    # copies of the optimizer's
            # the device-side schedule's rate is a tensor there; a checkpoint holds a number,
            # which any device (and rl_games' own step) can resume from
            group["lr"], group["capturable"] = float(group["lr"]), False
        # several processes: each has one GPU, and reading (or, on resume, setting) the
        # generators of all would open a CUDA context on every GPU from each process
        cuda = torch.cuda.get_rng_state_all() \
            if torch.cuda.is_available() and not self.multi_gpu else None
        state["myriad"] = {
            "wall_s": time.monotonic() - self.started, "time_split": dict(self.time_split),
            # the adaptive schedule's rate: rl_games keeps it in the agent, not the checkpoint,
            # and a resumed run would restart the schedule from the config's learning_rate
            "last_lr": float(self.last_lr),
            "best_mean_reward": self.best_mean_reward,
            "best_saved_reward": self.best_saved_reward,
            "nonfinite_actions": self.nonfinite_actions,
            "contact_overflow_steps": self.contact_overflow_steps,
            "fine_tuned_from": self.fine_tuned_from,
            "task": getattr(self.vec_env.env, "training_state", dict)(),
            "task_by_rank": self.task_states,    # several processes: as of the last epoch's end
            "rng": {"torch": torch.get_rng_state(), "cuda": cuda,
                    "numpy": np.random.get_state(), "python": random.getstate()}}
        return state

    def set_full_state_weights(self, weights, set_epoch=True):
        super().set_full_state_weights(weights, set_epoch)
        ours = weights.get("myriad")
        if ours is None:        # a checkpoint from before resume kept these: best reward only
            self.restored_best = weights.get("last_mean_rewards")
            return
        self.started = time.monotonic() - ours["wall_s"]
        self.time_split = dict(ours["time_split"])
        self.best_mean_reward = ours["best_mean_reward"]
        self.best_saved_reward = ours["best_saved_reward"]
        self.restored_best = self.best_saved_reward
        # the envs start fresh episodes together, so the last finished episodes are first the
        # early drops and then one wave of whole-length ones: not the policy's mean (ShadowHand
        # read −10, then 1850 against its 1530) until they have ended about two episodes each.
        # Neither the best reward nor the best-policy file is judged from that window.
        self.settled_epoch = self.epoch_num + math.ceil(
            2 * self.vec_env.env.max_episode_length / self.horizon_length)
        self.save_best_after = max(self.save_best_after, self.settled_epoch)
        self.nonfinite_actions = ours["nonfinite_actions"]
        if "last_lr" in ours:
            self.last_lr = ours["last_lr"]
            if self.minibatch_step is not None:
                self.minibatch_step.set_learning_rate(self.last_lr)
        self.contact_overflow_steps = ours.get("contact_overflow_steps", 0)
        self.fine_tuned_from = ours.get("fine_tuned_from")
        task = self.own_task_state(ours)
        if task:
            self.vec_env.env.load_training_state(task)
        self.checkpoint_epoch = self.epoch_num
        rng = ours["rng"]
        torch.set_rng_state(rng["torch"])
        if rng["cuda"] is not None and torch.cuda.is_available() and not self.multi_gpu \
                and len(rng["cuda"]) == torch.cuda.device_count():
            torch.cuda.set_rng_state_all(rng["cuda"])
        np.random.set_state(rng["numpy"])
        random.setstate(rng["python"])
        if self.multi_gpu:
            self.reseed_after_resume()

    def own_task_state(self, ours: dict) -> dict | None:
        """This process's task state in a checkpoint: rank 0's is `task`, the others' are in
        `task_by_rank` (a checkpoint of several processes). A checkpoint of another process
        count gives every process rank 0's."""
        by_rank = ours.get("task_by_rank")
        processes = 1 if by_rank is None else len(by_rank)
        if processes != self.world_size:
            if ours.get("task") and self.writes_files:
                warnings.warn(f"the checkpoint was written by {processes} process(es) and this "
                              f"run has {self.world_size}: every process continues from rank "
                              "0's task state (its terrain levels, schedules)", RuntimeWarning,
                              stacklevel=2)
            return ours.get("task")
        return ours.get("task") if self.global_rank == 0 else by_rank[self.global_rank]

    def reseed_after_resume(self):
        """Several processes: the checkpoint holds rank 0's CPU random generators, which rank 0
        continues, and no CUDA generator (see get_full_state_weights). Another rank restoring
        rank 0's would repeat its draws (its envs' resets, its actions), and every rank's CUDA
        generator would restart from seed + rank: they draw new streams from (seed, rank,
        epoch) instead."""
        seed = self.run_cfg["describe"]["seed"] % 2**63
        state = np.random.SeedSequence([seed, self.global_rank, self.epoch_num])
        seed = int(state.generate_state(1, np.uint64)[0] % 2**63)
        if self.global_rank != 0:
            torch.manual_seed(seed)         # the CUDA generators too
            np.random.seed(seed % 2**32)
            random.seed(seed)
        elif self.ppo_device.startswith("cuda"):
            torch.cuda.manual_seed(seed)    # this process's GPU

    def update_epoch(self):
        # rl_games' train() forgets the best reward it restored; give it back before the first
        # epoch so that its "new best" test compares with the resumed run's best
        if self.restored_best is not None:
            self.last_mean_rewards = self.restored_best
            self.restored_best = None
        return super().update_epoch()

    # ---------------------------------------------------------------- one epoch
    def train_actor_critic(self, input_dict):
        if self.minibatch_step is None:
            return super().train_actor_critic(input_dict)
        return self.minibatch_step(input_dict)

    def play_steps(self):
        self.vec_env.clock.mark("play")
        batch = self.rollout.play() if self.rollout is not None else super().play_steps()
        self.vec_env.clock.mark("played")
        return batch

    def play_steps_rnn(self):
        self.vec_env.clock.mark("play")
        batch = super().play_steps_rnn()
        self.vec_env.clock.mark("played")
        return batch

    def prepare_dataset(self, batch_dict):
        if self.normalize_value:    # its statistics stay in the tensors a captured rollout reads
            update.in_place(self.value_mean_std, lambda: super(MyriadAgent, self)
                            .prepare_dataset(batch_dict))
        else:
            super().prepare_dataset(batch_dict)
        if self.symmetry:
            self.add_mirror_images()

    def add_mirror_images(self) -> None:
        """Symmetry augmentation (`symmetry: true`), as legged robots' PPO trainers offer it:
        each minibatch also holds the mirror images of its samples (the task's
        `mirror_observations`, `mirror_actions`) with the same advantage, return, value and
        log-probability, which holds for a policy as symmetric as the robot and its task. From
        one sample the policy learns a motion for both sides, and a left-right bias it picks up
        costs it. The minibatches keep their count and double in size: as many gradient steps,
        each on twice the rows."""
        task, values = self.vec_env.env, self.dataset.values_dict
        n, rows = self.batch_size, self.minibatch_size
        mirrored = {"obs": task.mirror_observations(values["obs"]),
                    "actions": task.mirror_actions(values["actions"]),
                    "mu": task.mirror_actions(values["mu"]),
                    "sigma": task.mirror_actions(values["sigma"]).abs()}
        for key, value in values.items():
            if value is None:
                continue
            twin = mirrored.get(key, value)
            # minibatch k: its own rows, then their mirror images
            values[key] = torch.cat((value.reshape(n // rows, rows, *value.shape[1:]),
                                     twin.reshape(n // rows, rows, *value.shape[1:])),
                                    dim=1).reshape(2 * n, *value.shape[1:])
        self.dataset.batch_size, self.dataset.minibatch_size = 2 * n, 2 * rows

    def train_epoch(self):
        self.remember_normalizers()
        try:
            out = super().train_epoch()
        except Exception:
            if not self.weights_finite():    # e.g. torch refusing to sample from a NaN std
                self.raise_diverged()
            raise
        self.merge_normalizers()
        if self.minibatch_step is not None:     # the rate the device's schedule reached
            self.last_lr = self.minibatch_step.learning_rate()
            out = out[:9] + (self.last_lr,) + out[10:]
        self.vec_env.clock.mark("end")
        step_time, play_time, update_time, total_time = out[:4]
        physics_s, policy_s, update_s = self.vec_env.clock.split(step_time, play_time, update_time)
        self.time_split["physics_s"] += physics_s
        self.time_split["policy_s"] += policy_s
        self.time_split["update_s"] += update_s
        wall = time.monotonic() - self.started
        # read the flag once: a signal arriving after the save decision must wait for the next
        # epoch, not stop this one without a checkpoint
        stop = self.stop_signal
        bad_now = self.vec_env.env.take_nonfinite_actions()
        # several processes stop at the same epoch (one got the signal, or is out of time)
        stop, out_of_time, bad_now = self.agree(stop, wall >= self.run_cfg["max_time_s"],
                                                bad_now)
        # rl_games adds this epoch's env-steps (of all processes) to self.frame only after we
        # return: checkpoints saved from here on must count them already
        self.frames_not_counted = self.curr_frames * self.world_size
        env_steps = self.frame + self.frames_not_counted
        mean = None
        if self.game_rewards.current_size > 0:
            mean = float(self.game_rewards.get_mean()[0])
            if self.best_mean_reward is None:
                self.best_mean_reward = mean
            elif self.epoch_num >= self.settled_epoch:
                self.best_mean_reward = max(self.best_mean_reward, mean)
        if bad_now and not self.nonfinite_actions and self.writes_files:
            warnings.warn(f"epoch {self.epoch_num}: {bad_now} actions of the policy were NaN or "
                          "infinite; their envs are reset. The count is in the progress line, "
                          "progress.csv and TensorBoard (myriad/nonfinite_actions).",
                          RuntimeWarning, stacklevel=2)
        self.nonfinite_actions += bad_now
        self.note_contact_overflow()
        self.metrics = self.share_task_state()
        if self.writes_files:
            self.report_epoch(env_steps, total_time, wall, mean, bad_now,
                              (physics_s, policy_s, update_s))
        if not self.weights_finite():   # the same weights on every process: all stop here
            if self.writes_files:
                self.write_summary(env_steps, wall, mean)
            self.wait_for_rank_0()
            self.raise_diverged()
        if out_of_time and self.max_epochs != self.epoch_num:
            if self.writes_files:
                print(f"max_time_s={self.run_cfg['max_time_s']} reached: stopping after this "
                      "epoch")
            self.max_epochs = self.epoch_num       # rl_games' loop then saves and stops cleanly
        if self.writes_files:
            if stop is not None or out_of_time or \
                    time.monotonic() - self.last_save > 60 or self.epoch_num >= self.max_epochs:
                self.save_last()
            self.write_summary(env_steps, wall, mean)
        if stop is not None:
            self.wait_for_rank_0()      # its files are whole before any process exits
            raise TrainingStopped(stop)
        self.frames_not_counted = 0
        return out

    def report_epoch(self, env_steps, total_time, wall, mean, bad_now, split):
        """The progress line, TensorBoard's scalars and progress.csv's line of an epoch."""
        physics_s, policy_s, update_s = split
        rate = self.curr_frames * self.world_size / max(total_time, 1e-9)
        reward = "  (no episode finished yet)" if mean is None else \
            f"  reward {mean:9.1f}  best {self.best_mean_reward:9.1f}"
        flags = f"  non-finite actions {bad_now}" if bad_now else ""
        shown = "".join(f"  {k} {v:.2f}" for k, v in self.metrics.items())
        print(f"epoch {self.epoch_num:5d}/{self.max_epochs}  {env_steps:>11,d} steps  "
              f"{rate:9,.0f} steps/s  {wall:7.0f} s{reward}{shown}{flags}", flush=True)
        viewer = self.vec_env.env.viewer
        if viewer is not None:
            viewer.show_progress(
                f"**training** epoch {self.epoch_num}/{self.max_epochs} · {env_steps:,} "
                f"env-steps · {rate:,.0f} env-steps/s · {wall:.0f} s"
                + ("" if mean is None else f" · reward {mean:.1f} (best "
                   f"{self.best_mean_reward:.1f})")
                + "".join(f" · {k} {v:.2f}" for k, v in self.metrics.items()))
        self.writer.add_scalar("myriad/env_steps_per_s", rate, env_steps)
        self.writer.add_scalar("myriad/nonfinite_actions", bad_now, env_steps)
        for k, v in self.metrics.items():
            self.writer.add_scalar(f"myriad/{k}", v, env_steps)
        with open(self.curve_path, "a", newline="") as f:
            csv.writer(f).writerow([self.epoch_num, env_steps, f"{wall:.2f}",
                                    "" if mean is None else f"{mean:.3f}", f"{rate:.0f}",
                                    f"{physics_s:.4f}", f"{policy_s:.4f}",
                                    f"{update_s:.4f}", bad_now]
                                   + [f"{self.metrics.get(k, math.nan):.4f}"
                                      for k in self.metric_names])

    def raise_diverged(self):
        kept = ("no checkpoint was saved before" if self.checkpoint_epoch is None else
                f"nn/last.pth keeps epoch {self.checkpoint_epoch}")
        raise RuntimeError(
            f"epoch {self.epoch_num}: the policy's weights became NaN or infinite (the PPO "
            f"update diverged); {kept}. Lower train.params.config.learning_rate or check the "
            "task's observations and rewards.")

    def note_contact_overflow(self):
        """Contacts past an env's slots are dropped (a foot goes through the ground): the first
        epoch that saw it warns with the capacity to set; summary.json keeps the count."""
        env = self.vec_env.env
        over, most = env.take_contact_overflow()
        if over and not self.contact_overflow_steps and self.writes_files:
            capacity = env.envs.sim.contact_capacity
            warnings.warn(f"epoch {self.epoch_num}: {over} env-steps found more contacts than "
                          f"their {capacity} slots (most: {most}); the rest were dropped. Raise "
                          f"task.sim.physx.contacts_per_env to {most} or more.",
                          RuntimeWarning, stacklevel=2)
        self.contact_overflow_steps += over

    def write_summary(self, env_steps, wall, mean):
        atomic_json(os.path.join(self.experiment_dir, "summary.json"), {
            **self.run_cfg["describe"], "epochs": self.epoch_num, "env_steps": int(env_steps),
            "wall_s": round(wall, 2), "mean_reward": mean,
            "best_mean_reward": self.best_mean_reward,
            "env_steps_per_s": round(env_steps / max(wall, 1e-9)),
            **{k: round(v, 2) for k, v in self.time_split.items()},
            "nonfinite_actions": self.nonfinite_actions,
            "contact_overflow_steps": self.contact_overflow_steps,
            **{k: round(v, 4) for k, v in getattr(self, "metrics", {}).items()},
            "checkpoint": os.path.join(self.nn_dir, "last.pth"),
            "checkpoint_epoch": self.checkpoint_epoch,
            **({"fine_tuned_from": self.fine_tuned_from} if self.fine_tuned_from else {})})
