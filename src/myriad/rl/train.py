"""Training with rl_games' PPO: the env adapter, an agent that keeps time and the user's files
safe, and `train(cfg)` behind `myriad train`.

Files of a run, under runs/<experiment>/:
    nn/last.pth         the newest checkpoint (written atomically: a crash or Ctrl-C leaves the
                        previous one whole); nn/<Task>.pth is the best mean reward so far
    summary.json        env_steps, wall_s, mean_reward (last mean episode reward),
                        best_mean_reward, and the time split (physics / policy / update)
    progress.csv        one line per PPO epoch: the learning curve
    summaries/          TensorBoard scalars (rl_games' and ours)
"""

from __future__ import annotations

import csv
import json
import os
import time

import torch
from rl_games.algos_torch import a2c_continuous
from rl_games.common import env_configurations, vecenv
from rl_games.torch_runner import Runner


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


class MyriadVecEnv(vecenv.IVecEnv):
    """rl_games' view of a `VecTask` (already batched and on the device: nothing to convert)."""

    def __init__(self, config_name, num_actors, **kwargs):
        self.env = env_configurations.configurations[config_name]["env_creator"](**kwargs)

    def step(self, actions):
        return self.env.step(actions)

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


class MyriadAgent(a2c_continuous.A2CAgent):
    """rl_games' continuous PPO agent plus: a wall-time limit, a progress line per epoch,
    atomic checkpoints, `summary.json` and `progress.csv`."""

    def __init__(self, base_name, params):
        self.run_cfg = params["config"].pop("myriad")
        super().__init__(base_name, params)
        self.started = time.monotonic()
        self.time_split = {"physics_s": 0.0, "policy_s": 0.0, "update_s": 0.0}
        self.best_mean_reward = None
        self.last_save = time.monotonic()
        self.curve_path = os.path.join(self.experiment_dir, "progress.csv")
        with open(self.curve_path, "a", newline="") as f:
            if f.tell() == 0:
                csv.writer(f).writerow(["epoch", "env_steps", "wall_s", "mean_reward",
                                        "env_steps_per_s", "physics_s", "policy_s", "update_s"])

    # checkpoints: rl_games' names, written atomically
    def save(self, fn):
        state = self.get_full_state_weights()
        atomic_write(fn + ".pth", lambda tmp: torch.save(state, tmp))

    def save_last(self):
        self.save(os.path.join(self.nn_dir, "last"))
        self.last_save = time.monotonic()

    def train_epoch(self):
        out = super().train_epoch()
        step_time, play_time, update_time, total_time = out[:4]
        self.time_split["physics_s"] += step_time
        self.time_split["policy_s"] += play_time - step_time
        self.time_split["update_s"] += update_time
        env_steps = self.frame + self.curr_frames          # rl_games adds curr_frames after us
        wall = time.monotonic() - self.started
        mean = None
        if self.game_rewards.current_size > 0:
            mean = float(self.game_rewards.get_mean()[0])
            self.best_mean_reward = mean if self.best_mean_reward is None \
                else max(self.best_mean_reward, mean)
        rate = self.curr_frames / max(total_time, 1e-9)
        reward = "  (no episode finished yet)" if mean is None else \
            f"  reward {mean:9.1f}  best {self.best_mean_reward:9.1f}"
        print(f"epoch {self.epoch_num:5d}/{self.max_epochs}  {env_steps:>11,d} steps  "
              f"{rate:9,.0f} steps/s  {wall:7.0f} s{reward}", flush=True)
        self.writer.add_scalar("myriad/env_steps_per_s", rate, env_steps)
        with open(self.curve_path, "a", newline="") as f:
            csv.writer(f).writerow([self.epoch_num, env_steps, f"{wall:.2f}",
                                    "" if mean is None else f"{mean:.3f}", f"{rate:.0f}",
                                    f"{step_time:.4f}", f"{play_time - step_time:.4f}",
                                    f"{update_time:.4f}"])
        out_of_time = wall >= self.run_cfg["max_time_s"]
        if out_of_time and self.max_epochs != self.epoch_num:
            print(f"max_time_s={self.run_cfg['max_time_s']} reached: stopping after this epoch")
            self.max_epochs = self.epoch_num       # rl_games' loop then saves and stops cleanly
        if out_of_time or time.monotonic() - self.last_save > 60 or \
                self.epoch_num >= self.max_epochs:
            self.save_last()
        self.write_summary(env_steps, wall, mean)
        return out

    def write_summary(self, env_steps, wall, mean):
        atomic_json(os.path.join(self.experiment_dir, "summary.json"), {
            **self.run_cfg["describe"], "epochs": self.epoch_num, "env_steps": int(env_steps),
            "wall_s": round(wall, 2), "mean_reward": mean,
            "best_mean_reward": self.best_mean_reward,
            "env_steps_per_s": round(env_steps / max(wall, 1e-9)),
            **{k: round(v, 2) for k, v in self.time_split.items()},
            "checkpoint": os.path.join(self.nn_dir, "last.pth")})


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
    params["seed"] = seed
    runner = Runner()
    runner.algo_factory.register_builder("a2c_continuous",
                                         lambda **kwargs: MyriadAgent(**kwargs))
    runner.load({"params": params})
    return runner.algo_factory.create(runner.algo_name, base_name="run", params=runner.params)


def train(task, train_cfg: dict, run: dict, seed: int, checkpoint: str | None = None) -> dict:
    """Train until max_iterations or max_time_s; returns the summary. Ctrl-C saves and stops."""
    agent = build_agent(task, train_cfg, run, seed)
    if checkpoint:
        try:
            agent.restore(checkpoint)
        except Exception as err:  # truncated file, or a checkpoint of another task's network
            raise ValueError(f"checkpoint {checkpoint}: cannot resume from it "
                             f"({type(err).__name__}: {err})") from err
    print(f"training {run['describe']['task']} with {task.num_envs} envs on {task.device}; "
          f"run files in {agent.experiment_dir}", flush=True)
    try:
        agent.train()
    except KeyboardInterrupt:
        print("\ninterrupted: saving the current policy to nn/last.pth", flush=True)
        agent.save_last()
        raise
    finally:
        agent.writer.flush()
    with open(os.path.join(agent.experiment_dir, "summary.json")) as f:
        return json.load(f)
