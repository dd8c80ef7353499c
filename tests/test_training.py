"""`myriad train` / `myriad play` end to end on a tiny budget: a few PPO epochs on 32 envs, the
run's files, resuming, config errors, and a video of the policy."""

import json
import os

import pytest

from myriad import cli
from myriad.rl import run


def train_args(tmp_path, *extra, device="cpu"):
    return ["task=Ant", f"device={device}", "num_envs=32", f"train_dir={tmp_path}", *extra]


def test_train_writes_checkpoint_summary_and_curve_then_resumes(tmp_path, device):
    args = train_args(tmp_path, "max_iterations=3", "experiment=smoke", device=device)
    assert cli.main(["train", *args]) == 0
    folder = tmp_path / "smoke"
    summary = json.loads((folder / "summary.json").read_text())
    # 32 envs × horizon 16 × 3 epochs
    assert summary["env_steps"] == 32 * 16 * 3 and summary["epochs"] == 3
    for key in ("wall_s", "mean_reward", "best_mean_reward", "physics_s", "policy_s", "update_s"):
        assert key in summary
    assert summary["wall_s"] > 0 and summary["physics_s"] > 0 and summary["update_s"] > 0
    assert (folder / "nn" / "last.pth").is_file()
    assert not [p for p in os.listdir(folder / "nn") if ".tmp" in p], "no half-written files"
    curve = (folder / "progress.csv").read_text().splitlines()
    assert curve[0].startswith("epoch,env_steps,wall_s,mean_reward") and len(curve) == 4
    assert os.listdir(folder / "summaries"), "TensorBoard event file"

    # the same experiment name is never overwritten: a second run gets its own folder
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=1", device=device)]) == 0
    assert (tmp_path / "Ant").is_dir()
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=1", device=device)]) == 0
    assert (tmp_path / "Ant_2").is_dir()

    # resume: the epoch count continues from the checkpoint's
    checkpoint = str(folder / "nn" / "last.pth")
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=5",
                                          f"checkpoint={checkpoint}", device=device)]) == 0
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["epochs"] == 5


def test_max_time_stops_cleanly_with_a_checkpoint(tmp_path, device):
    args = train_args(tmp_path, "max_time_s=0.01", "experiment=timed", device=device)
    assert cli.main(["train", *args]) == 0
    summary = json.loads((tmp_path / "timed" / "summary.json").read_text())
    assert summary["epochs"] == 1 and (tmp_path / "timed" / "nn" / "last.pth").is_file()


def test_bad_configs_fail_naming_the_problem(tmp_path, capsys):
    assert cli.main(["train", "task=Nope", f"train_dir={tmp_path}"]) == 2
    err = capsys.readouterr().err
    assert "task/Nope" in err and "Ant" in err                # Hydra lists the valid tasks
    assert cli.main(["train", "task=Ant", "num_envz=3"]) == 2
    assert "num_envz" in capsys.readouterr().err
    assert cli.main(["train", *train_args(tmp_path, "max_time_s=-1")]) == 2
    assert "max_time_s=-1" in capsys.readouterr().err
    assert cli.main(["play", "task=Ant", f"train_dir={tmp_path}"]) == 2
    assert "no trained Ant run" in capsys.readouterr().err


def test_play_writes_a_video(tmp_path, device):
    args = train_args(tmp_path, "max_iterations=1", "experiment=v", device=device)
    assert cli.main(["train", *args]) == 0
    try:
        import mujoco
        renderer = mujoco.Renderer(mujoco.MjModel.from_xml_string("<mujoco/>"), 16, 16)
        renderer.close()
    except Exception as err:  # no offscreen OpenGL on this machine (see docs/training.md)
        pytest.skip(f"MuJoCo's offscreen renderer is not available here: {err}")
    video = tmp_path / "ant.gif"
    assert cli.main(["play", "task=Ant", f"device={device}", f"train_dir={tmp_path}",
                     "num_steps=5",
                     f"video={video}", "video_size=[64,64]"]) == 0
    import imageio.v2 as imageio
    frames = imageio.mimread(video)
    assert len(frames) == 6 and frames[0].shape[:2] == (64, 64)
    assert frames[0].std() > 1.0, "the frame shows something"


def test_cpu_profile_applies_only_without_num_envs():
    cfg = run.compose(["task=Ant", "device=cpu"])
    task_cfg, train_cfg, device = run.task_and_train_configs(cfg)
    assert device == "cpu" and task_cfg["env"]["numEnvs"] == 1024
    assert train_cfg["params"]["config"]["minibatch_size"] == 8192
    cfg = run.compose(["task=Ant", "device=cpu", "num_envs=100"])
    task_cfg, train_cfg, _ = run.task_and_train_configs(cfg)
    assert task_cfg["env"]["numEnvs"] == 100
    ppo = train_cfg["params"]["config"]
    assert ppo["minibatch_size"] == 1600, "32768 exceeds 100 envs × 16 steps: one minibatch"
    cfg = run.compose(["task=Ant", "device=cpu", "num_envs=32",
                       "train.params.config.minibatch_size=100"])
    _, train_cfg, _ = run.task_and_train_configs(cfg)
    assert train_cfg["params"]["config"]["minibatch_size"] == 64, "512 samples: 8 of 64"


def test_ctrl_c_keeps_a_loadable_checkpoint(tmp_path, device):
    """SIGINT in the middle of training: exit code 130 and nn/last.pth is whole and loadable."""
    import signal
    import subprocess
    import sys
    import time

    import torch

    proc = subprocess.Popen(
        [sys.executable, "-m", "myriad.cli", "train",
         *train_args(tmp_path, "experiment=intr", "max_iterations=100000", device=device)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    curve = tmp_path / "intr" / "progress.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if curve.is_file() and len(curve.read_text().splitlines()) >= 3:
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.stdout.read()
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=120)
    assert proc.returncode == 130, out
    assert "saving the current policy" in out
    state = torch.load(tmp_path / "intr" / "nn" / "last.pth", weights_only=False, map_location="cpu")
    assert "model" in state and state["epoch"] >= 2


def test_play_names_an_unreadable_checkpoint(tmp_path, capsys):
    bad = tmp_path / "broken.pth"
    bad.write_text("not a checkpoint")
    assert cli.main(["play", "task=Ant", f"checkpoint={bad}", "num_steps=1"]) == 2
    assert f"checkpoint {bad}: not a readable rl_games checkpoint" in capsys.readouterr().err
    assert cli.main(["train", *train_args(tmp_path, f"checkpoint={bad}")]) == 2
    assert f"checkpoint {bad}: cannot resume from it" in capsys.readouterr().err
