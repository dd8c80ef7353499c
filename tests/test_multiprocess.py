"""Training in several processes (`torchrun ... -m myriad.train multi_gpu=true`) on rl_games'
multi-GPU path, here two CPU processes with gloo: every process holds the same policy after
every update although each collects its own data, rank 0 alone writes the run's files (its
env-steps counting both processes'), and a stop signal saves and ends both processes."""

import json
import os
import signal
import subprocess
import sys
import textwrap
import time

import pytest
import torch

from myriad import cli
from myriad.rl import run

# Runs `myriad.train` in each process that torchrun starts, after wrapping the agent's epoch so
# that each process saves, after every PPO update, its network's state (weights and normalizers)
# and its last observations; and it leaves its pid and exit status. Test-only: nothing of this
# is in the package.
WORKER = textwrap.dedent("""
    import os, sys
    import torch
    from myriad.rl import agent as training

    out = sys.argv.pop(1)
    rank = int(os.environ["RANK"])
    with open(os.path.join(out, f"rank{rank}.pid"), "w") as f:
        f.write(str(os.getpid()))
    train_epoch = training.MyriadAgent.train_epoch

    def dumping_train_epoch(self):
        try:
            return train_epoch(self)
        finally:
            state = {k: v.detach().cpu().clone() for k, v in self.model.state_dict().items()}
            torch.save({"model": state, "obs": self.obs["obs"].cpu().clone()},
                       os.path.join(out, f"rank{self.global_rank}_epoch{self.epoch_num}.pt"))
    training.MyriadAgent.train_epoch = dumping_train_epoch
    set_full_state_weights = training.MyriadAgent.set_full_state_weights

    def dumping_set_full_state_weights(self, weights, set_epoch=True):
        set_full_state_weights(self, weights, set_epoch)
        torch.save(self.vec_env.env.training_state(),
                   os.path.join(out, f"rank{self.global_rank}_resumed_task.pt"))
    training.MyriadAgent.set_full_state_weights = dumping_set_full_state_weights

    from myriad.train import main
    code = main()
    with open(os.path.join(out, f"rank{rank}.rc"), "w") as f:
        f.write(str(code))
    sys.exit(code)
""")


def test_two_cpu_processes_train_one_policy_and_only_rank_0_writes(tmp_path):
    dumps = tmp_path / "dumps"
    dumps.mkdir()
    worker = tmp_path / "worker.py"
    worker.write_text(WORKER)
    runs = tmp_path / "runs"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2",
         str(worker), str(dumps), "task=Ant", "device=cpu", "multi_gpu=true", "num_envs=32",
         "max_iterations=100000", f"train_dir={runs}", "experiment=mp"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    curve = runs / "mp" / "progress.csv"
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and proc.poll() is None:
        if curve.is_file() and len(curve.read_text().splitlines()) >= 3:     # 2 epochs done
            break
        time.sleep(0.2)
    assert proc.poll() is None, proc.stdout.read()
    proc.send_signal(signal.SIGTERM)         # torchrun passes it on to both processes
    out, _ = proc.communicate(timeout=120)

    # both processes stopped at the same epoch, with 128 + SIGTERM, and are gone
    for rank in (0, 1):
        assert (dumps / f"rank{rank}.rc").read_text() == str(128 + signal.SIGTERM), out
        with pytest.raises(ProcessLookupError):
            os.kill(int((dumps / f"rank{rank}.pid").read_text()), 0)
    assert "stopped by SIGTERM" in out

    # rank 0's files: a checkpoint of the last epoch and a summary that agrees with it; the
    # env-steps count both processes' (32 envs in all × horizon 16 per epoch)
    folder = runs / "mp"
    summary = json.loads((folder / "summary.json").read_text())
    state = torch.load(folder / "nn" / "last.pth", weights_only=False, map_location="cpu")
    epochs = state["epoch"]
    assert epochs >= 2 and summary["epochs"] == summary["checkpoint_epoch"] == epochs
    assert summary["env_steps"] == state["frame"] == 32 * 16 * epochs
    assert summary["num_envs"] == 32 and summary["processes"] == 2

    # after every update both processes hold the same weights and normalizer statistics,
    # although they stepped different envs (seed + rank); the checkpoint holds them too
    for epoch in range(1, epochs + 1):
        zero, one = (torch.load(dumps / f"rank{rank}_epoch{epoch}.pt") for rank in (0, 1))
        assert zero["model"].keys() == one["model"].keys()
        for key, value in zero["model"].items():
            assert torch.equal(value, one["model"][key]), (epoch, key)
        assert not torch.equal(zero["obs"], one["obs"]), "the processes' envs differ"
    assert not list(dumps.glob(f"rank*_epoch{epochs + 1}.pt")), "both stopped at one epoch"
    for key, value in zero["model"].items():
        assert torch.equal(value, state["model"][key].cpu()), key
    assert any("running_mean_std" in key for key in state["model"])

    # only rank 0 wrote: one line per epoch, one event file, no half-written or extra files
    assert len(curve.read_text().splitlines()) == 1 + epochs
    assert len(os.listdir(folder / "summaries")) == 1
    assert sorted(os.listdir(folder)) == ["nn", "progress.csv", "summaries", "summary.json"]
    assert os.listdir(folder / "nn") == ["last.pth"]
    assert sorted(os.listdir(runs)) == ["mp"]


def test_each_process_resumes_its_own_terrain_levels_and_the_metrics_cover_all(tmp_path):
    """AnymalTerrain in two processes: the checkpoint keeps both processes' terrain levels,
    `terrain_level` is the mean over both processes' envs, and on resume each process continues
    from its own levels (set here to 2 for rank 0's envs and 5 for rank 1's)."""
    worker = tmp_path / "worker.py"
    worker.write_text(WORKER)
    dumps, runs = tmp_path / "dumps", tmp_path / "runs"
    dumps.mkdir()
    env = {**os.environ, "OMP_NUM_THREADS": "1"}

    def train(*extra):
        done = subprocess.run(
            [sys.executable, "-m", "torch.distributed.run", "--standalone",
             "--nproc_per_node=2", str(worker), str(dumps), "task=AnymalTerrain", "device=cpu",
             "multi_gpu=true", "num_envs=16", "train.params.config.minibatch_size=64",
             f"train_dir={runs}", "experiment=terrain", *extra],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stdout

    train("max_iterations=2")
    last = runs / "terrain" / "nn" / "last.pth"
    state = torch.load(last, weights_only=False, map_location="cpu")
    by_rank = state["myriad"]["task_by_rank"]
    assert len(by_rank) == 2 and all(s["levels"].shape == (8, ) for s in by_rank)
    assert torch.equal(by_rank[0]["levels"], state["myriad"]["task"]["levels"])
    summary = json.loads((runs / "terrain" / "summary.json").read_text())
    both = torch.cat([s["levels"] for s in by_rank]).float().mean()
    assert summary["terrain_level"] == pytest.approx(float(both), abs=1e-6)

    state["myriad"]["task"]["levels"] = torch.full((8, ), 2)
    by_rank[0]["levels"], by_rank[1]["levels"] = torch.full((8, ), 2), torch.full((8, ), 5)
    torch.save(state, last)
    train("max_iterations=3", "resume=auto")
    for rank, level in ((0, 2), (1, 5)):
        resumed = torch.load(dumps / f"rank{rank}_resumed_task.pt")
        assert torch.equal(resumed["levels"], torch.full((8, ), level)), rank
        assert resumed["steps_taken"] == by_rank[rank]["steps_taken"] == 48


def test_envs_and_minibatches_are_shared_among_the_processes():
    cfg = run.compose(["task=Ant", "device=cpu", "num_envs=64",
                       "train.params.config.minibatch_size=256"])
    task_cfg, train_cfg, _ = run.task_and_train_configs(cfg, processes=2)
    assert task_cfg["env"]["numEnvs"] == 32
    assert train_cfg["params"]["config"]["minibatch_size"] == 128
    cfg = run.compose(["task=Ant", "device=cpu", "num_envs=33"])
    with pytest.raises(ValueError, match="num_envs=33.*multiple of 2"):
        run.task_and_train_configs(cfg, processes=2)


def test_multi_gpu_needs_torchrun_and_a_device_kind(tmp_path, capsys, monkeypatch):
    for name in ("RANK", "LOCAL_RANK", "WORLD_SIZE", "MASTER_ADDR", "MASTER_PORT"):
        monkeypatch.delenv(name, raising=False)
    def train(*extra):
        defaults = {"task": "Ant", "device": "cpu", "num_envs": "32", "train_dir": tmp_path,
                    "multi_gpu": "true"}
        defaults.update(arg.split("=", 1) for arg in extra)
        return cli.main(["train", *(f"{k}={v}" for k, v in defaults.items())])
    assert train() == 2
    assert "torchrun --nproc_per_node" in capsys.readouterr().err
    for name, value in (("RANK", "0"), ("LOCAL_RANK", "0"), ("WORLD_SIZE", "2"),
                        ("MASTER_ADDR", "127.0.0.1"), ("MASTER_PORT", "29599")):
        monkeypatch.setenv(name, value)
    assert train("device=cuda:1") == 2
    assert "cuda:LOCAL_RANK" in capsys.readouterr().err
    assert train("num_envs=33") == 2            # found before any process waits for another
    assert "multiple of 2" in capsys.readouterr().err
    assert train("multi_gpu=yes") == 2
    assert "true or false" in capsys.readouterr().err
    assert not list(tmp_path.iterdir()), "nothing written"
