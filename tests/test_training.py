"""`myriad train` / `myriad play` end to end on a tiny budget: a few PPO epochs on 32 envs, the
run's files, resuming, config errors, and a video of the policy."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import pytest
import torch

import myriad

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
    # the split accounts for the epochs' time, on a GPU too (CUDA events there, not host timers
    # that see only the launches): no part negative, together at most the wall time
    split = [summary[k] for k in ("physics_s", "policy_s", "update_s")]
    assert min(split) >= 0 and sum(split) <= summary["wall_s"] + 0.02, summary
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


def test_two_runs_of_one_seed_train_the_same_policy_start_up_draws_included(tmp_path):
    # the OpenAI hand draws its cube's scale and masses when the task is built, before the
    # agent exists: from the run's seed too (this torch seeds itself from the OS at import)
    for name in ("one", "two"):
        assert cli.main(["train", "task=ShadowHandOpenAI_FF", "device=cpu", "num_envs=16",
                         f"train_dir={tmp_path}", "max_iterations=1",
                         f"experiment={name}"]) == 0
    one, two = (torch.load(tmp_path / name / "nn" / "last.pth", weights_only=False)["model"]
                for name in ("one", "two"))
    for key in one:
        assert torch.equal(one[key], two[key]), key


def test_max_time_stops_cleanly_with_a_checkpoint(tmp_path, device):
    args = train_args(tmp_path, "max_time_s=0.01", "experiment=timed", device=device)
    assert cli.main(["train", *args]) == 0
    summary = json.loads((tmp_path / "timed" / "summary.json").read_text())
    assert summary["epochs"] == 1 and (tmp_path / "timed" / "nn" / "last.pth").is_file()


def test_bad_configs_fail_naming_the_problem(tmp_path, capsys, unshipped_task):
    assert cli.main(["train", "task=Nope", f"train_dir={tmp_path}"]) == 2
    err = capsys.readouterr().err
    assert "task/Nope" in err and "Ant" in err                # Hydra lists the valid tasks
    assert cli.main(["train", "task=Ant", "num_envz=3"]) == 2
    assert "num_envz" in capsys.readouterr().err
    assert cli.main(["train", *train_args(tmp_path, "max_time_s=-1")]) == 2
    assert "max_time_s=-1" in capsys.readouterr().err
    assert cli.main(["play", f"task={unshipped_task}", f"train_dir={tmp_path}"]) == 2
    assert f"no trained {unshipped_task} run" in capsys.readouterr().err


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


def test_the_command_line_wins_over_the_cpu_profile():
    """ShadowHand's CPU profile sets a smaller network and a minibatch; either, set on the
    command line, stays as set, as do the task keys the profile sets (before 2026-12-01 the
    profile's task section replaced them without a word)."""
    cfg = run.compose(["task=ShadowHand", "device=cpu"])
    _, train_cfg, _ = run.task_and_train_configs(cfg)
    assert train_cfg["params"]["network"]["mlp"]["units"] == [512, 256, 128]
    assert train_cfg["params"]["config"]["minibatch_size"] == 2048
    overrides = ["task=ShadowHand", "device=cpu", "train.params.network.mlp.units=[64,64]",
                 "train.params.config.minibatch_size=4096"]
    _, train_cfg, _ = run.task_and_train_configs(run.compose(overrides), overrides)
    assert train_cfg["params"]["network"]["mlp"]["units"] == [64, 64]
    assert train_cfg["params"]["config"]["minibatch_size"] == 4096
    # and a task key the profile also sets: the cost curriculum of AnymalTerrain's profile
    # (start 0.05, decay 0.999) keeps the decay given and the profile's start
    overrides = ["task=AnymalTerrain", "device=cpu", "task.env.penaltyCurriculum.decay=1",
                 "task.env.numEnvs=64"]
    task_cfg, _, _ = run.task_and_train_configs(run.compose(overrides), overrides)
    assert task_cfg["env"]["penaltyCurriculum"] == {"start": 0.05, "decay": 1}
    assert task_cfg["env"]["numEnvs"] == 64


def test_an_asymmetric_critics_minibatch_follows_num_envs_too():
    """rl_games refuses a central_value_config minibatch that does not divide the batch."""
    cfg = run.compose(["task=ShadowHandOpenAI_FF", "device=cpu", "num_envs=64"])
    _, train_cfg, _ = run.task_and_train_configs(cfg)
    ppo = train_cfg["params"]["config"]
    assert ppo["minibatch_size"] == 512 and ppo["central_value_config"]["minibatch_size"] == 512


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_signal_saves_a_checkpoint_and_a_consistent_summary(tmp_path, device, signum):
    """SIGINT (Ctrl-C) or SIGTERM (docker stop, Slurm) sent to a real training process: it
    finishes the epoch, exits with 128 + the signal number, and nn/last.pth holds the epoch that
    summary.json reports."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "myriad.cli", "train",
         *train_args(tmp_path, "experiment=stop", "max_iterations=100000", device=device)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    curve = tmp_path / "stop" / "progress.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if curve.is_file() and len(curve.read_text().splitlines()) >= 3:
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.stdout.read()
    proc.send_signal(signum)
    out, _ = proc.communicate(timeout=120)
    assert proc.returncode == 128 + signum, out
    assert f"stopped by {signal.Signals(signum).name}" in out
    summary = json.loads((tmp_path / "stop" / "summary.json").read_text())
    state = torch.load(tmp_path / "stop" / "nn" / "last.pth", weights_only=False,
                       map_location="cpu")
    assert "model" in state and state["epoch"] >= 2
    assert summary["epochs"] == summary["checkpoint_epoch"] == state["epoch"]
    assert summary["env_steps"] == state["frame"] == 32 * 16 * state["epoch"]


def test_a_signal_during_the_summary_write_stops_after_the_next_saved_epoch(tmp_path, device,
                                                                          monkeypatch):
    """The window the subprocess test above hits only by chance (CI once): the signal lands after
    the epoch's save decision, while summary.json is written. The run must not stop there without
    a checkpoint; it stops at the end of the next epoch, saved."""
    from myriad.rl import agent as train_module
    write_summary = train_module.MyriadAgent.write_summary

    def signal_arrives_meanwhile(agent, *args):
        write_summary(agent, *args)
        if agent.epoch_num == 2 and agent.stop_signal is None:
            agent.stop_signal = signal.SIGINT
    monkeypatch.setattr(train_module.MyriadAgent, "write_summary", signal_arrives_meanwhile)
    args = train_args(tmp_path, "max_iterations=10", "experiment=race", device=device)
    assert cli.main(["train", *args]) == 128 + signal.SIGINT
    summary = json.loads((tmp_path / "race" / "summary.json").read_text())
    state = torch.load(tmp_path / "race" / "nn" / "last.pth", weights_only=False,
                       map_location="cpu")
    assert summary["epochs"] == summary["checkpoint_epoch"] == state["epoch"] == 3


def _curve(folder):
    with open(folder / "progress.csv") as f:
        return list(csv.DictReader(f))


def test_resume_continues_counters_time_and_never_replaces_the_best_with_a_worse(tmp_path,
                                                                                  device):
    # 16-step episodes: every epoch finishes episodes, so rewards exist from the first epoch
    common = ["task.env.episodeLength=16", "train.params.config.save_best_after=0"]
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=3", "experiment=r",
                                          *common, device=device)]) == 0
    folder = tmp_path / "r"
    first = json.loads((folder / "summary.json").read_text())
    best_file = folder / "nn" / "Ant.pth"
    assert best_file.is_file() and first["best_mean_reward"] is not None
    state = torch.load(folder / "nn" / "last.pth", weights_only=False, map_location="cpu")
    kept = state["myriad"]
    assert kept["wall_s"] > 0 and kept["best_mean_reward"] == first["best_mean_reward"]
    assert {"torch", "numpy", "python"} <= set(kept["rng"]) and "optimizer" in state
    assert "running_mean_std" in str(state["model"].keys()), "observation normalizer saved"

    # as if the best policy so far had scored far above anything the resumed run will reach
    kept["best_saved_reward"] = 1e9
    torch.save(state, folder / "nn" / "last.pth")
    best_before = best_file.read_bytes()
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=6", "resume=auto",
                                          "experiment=r", *common, device=device)]) == 0
    assert best_file.read_bytes() == best_before, "a worse policy replaced the best one"
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["epochs"] == 6 and summary["env_steps"] == 32 * 16 * 6
    assert summary["checkpoint_epoch"] == 6
    assert summary["wall_s"] > first["wall_s"], "wall time continues, it does not restart at 0"
    assert summary["best_mean_reward"] >= first["best_mean_reward"]
    curve = _curve(folder)
    assert [int(r["epoch"]) for r in curve] == [1, 2, 3, 4, 5, 6]
    walls = [float(r["wall_s"]) for r in curve]
    assert walls == sorted(walls), walls
    # env-steps/s over the whole run stays a real rate (not env-steps over the resumed part)
    rate = summary["env_steps"] / summary["wall_s"]      # wall_s is rounded to 10 ms
    assert summary["env_steps_per_s"] == pytest.approx(rate, rel=0.05)

    # a resumed run's envs start their episodes together, so its first two episode lengths'
    # means (here 2 × 16 steps / horizon 16 = epochs 7 and 8) are not the policy's: no best
    # is taken from them, even over a best every mean exceeds
    state = torch.load(folder / "nn" / "last.pth", weights_only=False, map_location="cpu")
    state["myriad"]["best_mean_reward"] = -1e9
    torch.save(state, folder / "nn" / "last.pth")
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=7", "resume=auto",
                                          "experiment=r", *common, device=device)]) == 0
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["epochs"] == 7 and summary["mean_reward"] is not None
    assert summary["best_mean_reward"] == -1e9


def test_resume_auto_starts_fresh_when_there_is_nothing_to_resume(tmp_path, capsys):
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=1", "resume=auto",
                                          "experiment=new")]) == 0
    assert "nothing" not in capsys.readouterr().err
    assert json.loads((tmp_path / "new" / "summary.json").read_text())["epochs"] == 1
    assert cli.main(["train", *train_args(tmp_path, "resume=auto",
                                          f"checkpoint={tmp_path}/new/nn/last.pth")]) == 2
    assert "not both" in capsys.readouterr().err


def test_nonfinite_actions_are_counted_warned_and_reported(tmp_path, device, monkeypatch):
    from myriad.rl import agent as training

    step = training.MyriadVecEnv.step

    def nan_in_env_0(self, actions):
        actions = actions.clone()
        actions[0, 0] = float("nan")
        return step(self, actions)
    monkeypatch.setattr(training.MyriadVecEnv, "step", nan_in_env_0)
    with pytest.warns(RuntimeWarning, match="actions of the policy were NaN or infinite"):
        assert cli.main(["train", *train_args(tmp_path, "max_iterations=2", "experiment=nan",
                                              device=device)]) == 0
    # one bad action per env-step of env 0: 16 per epoch
    assert [int(r["nonfinite_actions"]) for r in _curve(tmp_path / "nan")] == [16, 16]
    assert json.loads((tmp_path / "nan" / "summary.json").read_text())["nonfinite_actions"] == 32


def test_nonfinite_action_flags_and_resets_only_its_env(device):
    task = myriad.make("Ant", num_envs=3, device=device)
    task.reset()
    actions = torch.zeros(3, 8, device=device)
    actions[1, 2] = float("inf")
    _, reward, resets, _ = task.step(actions)
    assert task.take_nonfinite_actions() == 1 and task.take_nonfinite_actions() == 0
    assert resets.tolist() == [0, 1, 0] and torch.isfinite(reward).all()


def test_a_diverged_policy_stops_training_without_overwriting_the_checkpoint(tmp_path,
                                                                             monkeypatch,
                                                                             capsys):
    from myriad.rl import agent as training

    epoch = training.MyriadAgent.train_epoch

    def diverge_at_epoch_3(self):
        if self.epoch_num == 3:
            with torch.no_grad():
                next(self.model.parameters()).fill_(float("nan"))
        return epoch(self)
    monkeypatch.setattr(training.MyriadAgent, "train_epoch", diverge_at_epoch_3)
    args = train_args(tmp_path, "max_iterations=5", "experiment=div")
    assert cli.main(["train", *args]) == 2
    assert "weights became NaN or infinite" in capsys.readouterr().err
    assert not (tmp_path / "div" / "nn" / "last.pth").exists(), "a NaN policy was saved"


def test_first_run_progress_names_what_compiles_and_the_final_line_has_numbers(tmp_path,
                                                                                capsys):
    from myriad.physics.runtime import load_kernels

    lines = []
    load_kernels("cpu", report=lines.append, notice_after_s=0.0)   # every module "slow"
    assert any("compiling myriad.physics.stages.dynamics for cpu" in line for line in lines)
    assert any(line.strip().startswith("done in") for line in lines)
    assert lines[-1].startswith("  physics kernels ready for cpu in")
    assert cli.main(["train", *train_args(tmp_path, "max_iterations=1", "experiment=f")]) == 0
    out = capsys.readouterr().out
    assert "loading the physics kernels for cpu" in out
    final = out.strip().splitlines()[-1]
    assert "None" not in final and "no episode finished yet" in final, final


def test_play_names_an_unreadable_checkpoint(tmp_path, capsys):
    bad = tmp_path / "broken.pth"
    bad.write_text("not a checkpoint")
    assert cli.main(["play", "task=Ant", f"checkpoint={bad}", "num_steps=1"]) == 2
    assert f"checkpoint {bad}: not a readable rl_games checkpoint" in capsys.readouterr().err
    assert cli.main(["train", *train_args(tmp_path, f"checkpoint={bad}")]) == 2
    assert f"checkpoint {bad}: cannot resume from it" in capsys.readouterr().err


def test_bfloat16_mlps_keep_float32_outputs_weights_and_checkpoint_keys():
    """`mlp_bfloat16`: the hidden layers run in bfloat16 on a CPU that has it natively; what
    comes out, the weights, their gradients and the state_dict stay float32 and unchanged."""
    from myriad.rl.agent import use_bfloat16_mlps

    class Network(torch.nn.Module):       # rl_games' layout: trunks, then float32 heads
        def __init__(self):
            super().__init__()
            self.actor_mlp = torch.nn.Sequential(torch.nn.Linear(16, 64), torch.nn.ELU())
            self.critic_mlp = torch.nn.Sequential()
            self.mu = torch.nn.Linear(64, 4)

        def forward(self, x):
            return self.mu(self.actor_mlp(x))

    torch.manual_seed(0)
    net, x = Network(), torch.randn(32, 16)
    plain = net(x).detach()
    keys = list(net.state_dict())
    if not use_bfloat16_mlps(net, "cpu"):
        pytest.skip("this CPU has no native bfloat16 matrix products")
    out = net(x)
    assert out.dtype == torch.float32
    assert list(net.state_dict()) == keys
    # bfloat16 keeps 8 bits of mantissa: the outputs agree to a few parts in a hundred
    assert torch.allclose(out, plain, atol=0.05 * plain.abs().max().item()), (out - plain).abs().max()
    out.square().mean().backward()
    assert all(p.grad is not None and p.grad.dtype == torch.float32 for p in net.parameters())


def test_contacts_past_the_slots_are_counted_and_warned_with_the_capacity_to_set(tmp_path):
    """Ant with 2 contact slots per env: once its feet are down, the contacts past them are
    dropped. Training warns with the number to set and summary.json counts the env-steps."""
    with pytest.warns(RuntimeWarning, match=r"Raise task.sim.physx.contacts_per_env to \d+"):
        assert cli.main(["train", *train_args(tmp_path, "max_iterations=2", "experiment=few",
                                              "+task.sim.physx.contacts_per_env=2")]) == 0
    summary = json.loads((tmp_path / "few" / "summary.json").read_text())
    assert 0 < summary["contact_overflow_steps"] <= 32 * 16 * 2
    task = myriad.make("Ant", num_envs=2, **{"sim.physx.contacts_per_env": 2})
    for _ in range(60):                     # 1 s: the ant lands on its feet
        task.step(torch.zeros(2, 8))
    over, most = task.take_contact_overflow()
    assert over > 0 and most > 2 and task.take_contact_overflow() == (0, 0)
