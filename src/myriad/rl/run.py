"""`myriad train` and `myriad play`: Hydra config composition, device and CPU-profile choice,
and the playback of a trained policy into a video rendered by MuJoCo."""

from __future__ import annotations

import glob
import json
import math
import os
import time

from omegaconf import OmegaConf


def compose(overrides: list[str]):
    """config.yaml + task/<T>.yaml + train/<T>PPO.yaml with command-line overrides (Hydra)."""
    from hydra import compose as hydra_compose, initialize_config_module

    with initialize_config_module(config_module="myriad.cfg", version_base=None):
        return hydra_compose(config_name="config", overrides=overrides)


def resolve_device(device: str) -> str:
    import torch

    if device == "auto":
        return "cuda:0" if torch.cuda.is_available() else "cpu"
    return device


def task_and_train_configs(cfg) -> tuple[dict, dict, str]:
    """Plain dicts of the task and train configs with the top-level options applied."""
    device = resolve_device(cfg.device)
    task_cfg = OmegaConf.to_container(cfg.task, resolve=True)
    train_cfg = OmegaConf.to_container(cfg.train, resolve=True)
    cpu_task, cpu_train = task_cfg.pop("cpu", {}), train_cfg.pop("cpu", {})
    if not device.startswith("cuda"):
        # CPU profile: fewer envs and a minibatch to match (unless the user chose num_envs)
        if cfg.num_envs is None:
            task_cfg["env"].update(cpu_task)
            train_cfg["params"]["config"].update(cpu_train)
    if cfg.num_envs is not None:
        if int(cfg.num_envs) < 1:
            raise ValueError(f"num_envs={cfg.num_envs}: must be >= 1")
        task_cfg["env"]["numEnvs"] = int(cfg.num_envs)
    # PPO splits num_envs × horizon_length samples into equal minibatches: keep the minibatch
    # size a divisor, as close as possible below the configured one
    ppo = train_cfg["params"]["config"]
    batch = int(task_cfg["env"]["numEnvs"]) * ppo["horizon_length"]
    count = max(1, math.ceil(batch / ppo["minibatch_size"]))
    while batch % count:
        count += 1
    if batch // count != ppo["minibatch_size"]:
        print(f"minibatch_size {ppo['minibatch_size']} -> {batch // count}: {count} equal "
              f"minibatches of num_envs × horizon_length = {batch} samples")
        ppo["minibatch_size"] = batch // count
    if cfg.max_iterations is not None:
        train_cfg["params"]["config"]["max_epochs"] = int(cfg.max_iterations)
    return task_cfg, train_cfg, device


def free_experiment_name(train_dir: str, name: str) -> str:
    """`name`, or name_2, name_3 ... so that an earlier run's files are never overwritten."""
    candidate, k = name, 1
    while os.path.exists(os.path.join(train_dir, candidate)):
        k += 1
        candidate = f"{name}_{k}"
    return candidate


def train(overrides: list[str]) -> int:
    from ..tasks import TASKS
    from .train import train as run_training

    cfg = compose(overrides)
    task_cfg, train_cfg, device = task_and_train_configs(cfg)
    name = task_cfg["name"]
    if cfg.checkpoint and not os.path.isfile(cfg.checkpoint):
        raise FileNotFoundError(f"checkpoint={cfg.checkpoint}: no such file")
    folder = os.path.dirname(os.path.abspath(cfg.checkpoint)) if cfg.checkpoint else ""
    if cfg.experiment is None and os.path.basename(folder) == "nn":
        experiment = os.path.basename(os.path.dirname(folder))   # resume in runs/<experiment>/
    else:           # a checkpoint from elsewhere starts a new run folder
        experiment = cfg.experiment or free_experiment_name(cfg.train_dir, name)
    max_time = math.inf if cfg.max_time_s is None else float(cfg.max_time_s)
    if not max_time > 0:
        raise ValueError(f"max_time_s={cfg.max_time_s}: must be > 0")
    t0 = time.monotonic()
    print(f"building {name}: {task_cfg['env']['numEnvs']} envs on {device} (a first run compiles "
          "the physics kernels: about a minute on a laptop CPU)", flush=True)
    task = TASKS[name](task_cfg, device=device)
    print(f"built in {time.monotonic() - t0:.1f} s", flush=True)
    run = {"train_dir": cfg.train_dir, "experiment": experiment, "max_time_s": max_time,
           "describe": {"task": name, "device": device, "num_envs": task.num_envs,
                        "seed": int(cfg.seed),
                        "minibatch_size": train_cfg["params"]["config"]["minibatch_size"],
                        "machine": f"{os.cpu_count()} CPU cores" + (
                            "" if device == "cpu" else f", {_gpu_name(device)}")}}
    summary = run_training(task, train_cfg, run, int(cfg.seed), cfg.checkpoint)
    print(f"done: {summary['env_steps']:,} env-steps in {summary['wall_s']:.0f} s; mean reward "
          f"{summary['mean_reward']}, best {summary['best_mean_reward']}; checkpoint "
          f"{summary['checkpoint']}")
    return 0


def _gpu_name(device: str) -> str:
    import torch

    return torch.cuda.get_device_name(torch.device(device))


def latest_checkpoint(train_dir: str, task: str) -> str:
    runs = []
    for path in glob.glob(os.path.join(train_dir, "*", "summary.json")):
        with open(path) as f:
            if json.load(f).get("task") == task and os.path.isfile(
                    os.path.join(os.path.dirname(path), "nn", "last.pth")):
                runs.append((os.path.getmtime(path), os.path.dirname(path)))
    if not runs:
        raise FileNotFoundError(f"no trained {task} run under {train_dir}/: train one with "
                                f"`myriad train task={task}` or pass checkpoint=<file.pth>")
    return os.path.join(max(runs)[1], "nn", "last.pth")


def play(overrides: list[str]) -> int:
    """Run a trained policy in one env and write a video of it."""
    import torch

    from ..tasks import TASKS
    from .policy import load_policy
    from .video import VideoWriter

    cfg = compose(overrides)
    task_cfg, train_cfg, device = task_and_train_configs(cfg)
    name = task_cfg["name"]
    checkpoint = cfg.checkpoint or latest_checkpoint(cfg.train_dir, name)
    if not os.path.isfile(checkpoint):
        raise FileNotFoundError(f"checkpoint={checkpoint}: no such file")
    task_cfg["env"]["numEnvs"] = int(cfg.num_envs or 1)
    task = TASKS[name](task_cfg, device=device)
    policy = load_policy(checkpoint, train_cfg, task)
    video = cfg.video or os.path.join(os.path.dirname(os.path.dirname(checkpoint)), f"{name}.mp4")
    fps = round(1.0 / task.dt)
    obs = task.reset()["obs"]
    episode_reward, finished = torch.zeros(task.num_envs, device=task.device), []
    with VideoWriter(video, task.envs, fps=fps, size=tuple(cfg.video_size)) as writer:
        writer.add_frame()
        for step in range(int(cfg.num_steps)):
            with torch.no_grad():
                obs, reward, done, _ = task.step(policy(obs))
            obs = obs["obs"]
            episode_reward += reward
            if bool(done[0]):
                finished.append(float(episode_reward[0]))
            episode_reward[done.bool()] = 0.0
            writer.add_frame()
            if (step + 1) % 200 == 0:
                print(f"  {step + 1}/{cfg.num_steps} steps", flush=True)
    shown = f"episode rewards {[round(r, 1) for r in finished]}" if finished else \
        f"reward so far {float(episode_reward[0]):.1f} (episode not finished)"
    print(f"wrote {video} ({cfg.num_steps} steps at {fps} fps); env 0: {shown}")
    return 0
