"""The PPO minibatch step with its adaptive learning rate on the device (`myriad.rl.update`) and
the rollout that counts finished episodes there (`myriad.rl.rollout`) train as rl_games' own
step and rollout do: the same weights, optimizer state and rate, bit for bit on a CPU, and
neither reads anything back to the host. Captured as a CUDA graph (`capture_update=true`; the
GPU suite runs this file with --device cuda:0) the step trains the same up to float32
rounding. A checkpoint carries the rate to a resumed run.
"""

import tempfile

import numpy as np
import pytest
import torch
from rl_games.algos_torch import torch_ext

from myriad.rl.run import compose, task_and_train_configs
from test_host_sync import recording_syncs
from myriad.rl.train import build_agent
from myriad.tasks import TASKS


def small_agent(device, rl_games_step=False, capture=False, task="Ant", episode=None,
                capture_step=False, **config):
    """An agent as `myriad train` builds it, small: 64 envs in minibatches of 256 (Ant: 16
    steps, 4 minibatches, 4 mini-epochs); the hidden layers in float32 on every CPU.
    `rl_games_step`: rl_games' own minibatch step, host-side schedule, critic step and
    rollout. `episode`: the task's episode length."""
    overrides = [f"task={task}", f"device={device}", "num_envs=64"] + (
        [f"task.env.episodeLength={episode}"] if episode else [])
    cfg = compose(overrides)
    task_cfg, train_cfg, device = task_and_train_configs(cfg, overrides)
    params = train_cfg["params"]["config"]
    params.pop("mlp_bfloat16", None)
    params.update(minibatch_size=256, **config)
    torch.manual_seed(0)
    task = TASKS[task](task_cfg, device=device)
    task.capture_step = capture_step
    run = {"train_dir": tempfile.mkdtemp(prefix="myriad_update_"), "experiment": "update",
           "max_time_s": float("inf"), "describe": {}, "capture_update": capture}
    agent = build_agent(task, train_cfg, run, seed=3)
    if rl_games_step:
        agent.minibatch_step, agent.schedule_type = None, "legacy"
        if agent.has_central_value:
            del agent.central_value_net.train_critic    # back to the class's
        agent.rollout = None
        agent.game_rewards = torch_ext.AverageMeter(1, agent.games_to_track).to(device)
        agent.game_shaped_rewards = torch_ext.AverageMeter(1, agent.games_to_track).to(device)
        agent.game_lengths = torch_ext.AverageMeter(1, agent.games_to_track).to(device)
    agent.init_tensors()
    agent.obs = agent.env_reset()
    return agent


def train_epochs(agent, epochs: int) -> None:
    base = type(agent).__mro__[2]      # ContinuousA2CBase: its epoch, with no files written
    torch.manual_seed(5)               # each agent's rollouts draw the same actions
    for _ in range(epochs):
        agent.epoch_num = agent.update_epoch()
        base.train_epoch(agent)
        if agent.minibatch_step is not None:
            agent.last_lr = agent.minibatch_step.learning_rate()


def optimizer_tensors(agent):
    return [t for state in agent.optimizer.state_dict()["state"].values()
            for t in state.values()]


@pytest.mark.parametrize("task", ["Ant", "ShadowHandOpenAI_FF"])    # the second: a critic
def test_the_device_side_loop_trains_as_rl_games_own_bit_for_bit(task):
    # 20-step episodes: the rollouts count finished episodes from the second epoch on
    ours, theirs = (small_agent("cpu", task=task, episode=20),
                    small_agent("cpu", rl_games_step=True, task=task, episode=20))
    assert ours.minibatch_step is not None and theirs.minibatch_step is None
    first_lr = ours.last_lr
    train_epochs(ours, 3)
    train_epochs(theirs, 3)
    assert ours.last_lr == theirs.last_lr
    assert ours.last_lr != first_lr, "the adaptive schedule never moved: nothing was compared"
    for (name, a), b in zip(ours.model.state_dict().items(), theirs.model.state_dict().values()):
        assert torch.equal(a, b), name
    for a, b in zip(optimizer_tensors(ours), optimizer_tensors(theirs)):
        assert torch.equal(a, b)
    if ours.has_central_value:
        for (name, a), b in zip(ours.central_value_net.state_dict().items(),
                                theirs.central_value_net.state_dict().values()):
            assert torch.equal(a, b), name
    # the normalizer keeps the tensors it had (a captured step reads those)
    assert ours.model.running_mean_std.count.item() == theirs.model.running_mean_std.count.item()
    # the episodes counted on the device: as many, the same mean up to float32 rounding (a
    # masked sum adds in another order)
    assert ours.game_rewards.current_size == theirs.game_rewards.current_size >= 64
    for meter in ("game_rewards", "game_shaped_rewards", "game_lengths"):
        np.testing.assert_allclose(getattr(ours, meter).get_mean(),
                                   getattr(theirs, meter).get_mean(), rtol=1e-5, err_msg=meter)


def test_a_checkpoint_carries_the_learning_rate_to_the_resumed_run():
    agent = small_agent("cpu")
    train_epochs(agent, 2)
    state = agent.get_full_state_weights()
    assert state["myriad"]["last_lr"] == agent.last_lr != 3e-4
    assert all(isinstance(g["lr"], float) and not g["capturable"]
               for g in state["optimizer"]["param_groups"])
    resumed = small_agent("cpu")
    resumed.set_full_state_weights(state)
    assert resumed.last_lr == agent.last_lr
    assert resumed.minibatch_step.learning_rate() == agent.last_lr
    # and rl_games' own step resumes from it too (its schedule continues from last_lr)
    theirs = small_agent("cpu", rl_games_step=True)
    theirs.set_full_state_weights(state)
    assert theirs.last_lr == agent.last_lr


def test_a_captured_step_trains_as_the_eager_one(device):
    eager, captured = small_agent(device), small_agent(device, capture=True)
    train_epochs(eager, 3)
    train_epochs(captured, 3)
    if torch.device(device).type == "cuda":
        assert captured.minibatch_step.graph is not None, "the step ran as a graph"
    else:
        assert captured.minibatch_step.graph is None, "a CPU ignores capture_update"
    assert captured.last_lr == pytest.approx(eager.last_lr, rel=1e-6)
    for (name, a), b in zip(captured.model.state_dict().items(),
                            eager.model.state_dict().values()):
        torch.testing.assert_close(a, b, rtol=1e-4, atol=1e-5, msg=name)


def test_what_the_device_side_step_cannot_take_keeps_rl_games_step():
    agent = small_agent("cpu", lr_schedule="linear")
    assert agent.minibatch_step is None and agent.schedule_type == "legacy"


def test_the_episode_meter_keeps_rl_games_running_mean():
    from myriad.rl.rollout import EpisodeMeter

    theirs, ours = torch_ext.AverageMeter(1, 100), EpisodeMeter(1, 100, "cpu")
    gen = torch.Generator().manual_seed(0)
    for share in [0.0, 0.01, 0.1, 0.5, 0.0, 0.9, 0.02] * 3:    # none ended, a few, > 100
        values = torch.randn(300, 1, generator=gen) * 50
        done = torch.rand(300, generator=gen) < share
        theirs.update(values[done])
        ours.update_where(values, done)
        assert ours.current_size == theirs.current_size
        np.testing.assert_allclose(ours.get_mean(), theirs.get_mean(), rtol=1e-5, atol=1e-5)
    ours.clear()
    assert ours.current_size == 0 and float(ours.mean) == 0.0


@pytest.mark.parametrize("task", ["Ant", "ShadowHandOpenAI_FF"])
def test_the_rollout_and_the_update_read_nothing_back(task):
    """What a GPU would wait for (test_host_sync's recorder): rl_games' rollout reads the
    finished envs back at every step (nonzero, cpu, numpy) and its update every minibatch's KL
    (item); neither happens here."""
    agent = small_agent("cpu", task=task, episode=4)      # episodes end within the rollout
    agent.vec_env.env.skip_idle_resets = False          # the step as a GPU runs it
    train_epochs(agent, 1)
    agent.epoch_num = agent.update_epoch()
    agent.set_eval()
    with recording_syncs() as syncs, torch.no_grad():
        batch = agent.play_steps()
    assert syncs == [], f"the rollout read back: {sorted(set(syncs))}"
    assert agent.game_lengths.current_size > 0
    agent.set_train()
    agent.curr_frames = batch.pop("played_frames")
    agent.prepare_dataset(batch)
    with recording_syncs() as syncs:
        for _ in range(agent.mini_epochs_num):
            for i in range(len(agent.dataset)):
                out = agent.train_actor_critic(agent.dataset[i])
                agent.dataset.update_mu_sigma(out[6], out[7])
    assert syncs == [], f"the update read back: {sorted(set(syncs))}"


def test_a_captured_rollout_steps_as_the_eager_one(device):
    """capture_step=true on CUDA: the rollout's steps, the policy's inference included, replay as
    one graph. With the policy's std near 0 (sampling draws differently inside a graph) and no
    episode ending, both rollouts store the same observations, actions and rewards."""
    buffers = []
    for capture in (False, True):
        agent = small_agent(device, capture_step=capture)
        with torch.no_grad():
            agent.model.a2c_network.sigma.fill_(-20.0)
        agent.set_eval()
        with torch.no_grad():
            agent.play_steps()
            batch = agent.play_steps()      # the second epoch: replays only
        if torch.device(device).type == "cuda":
            assert (agent.rollout.graph is not None) == capture
            assert agent.vec_env.env.capture_step is False, "the rollout's graph has the step"
        else:
            assert agent.rollout.graph is None, "a CPU ignores capture_step"
        assert not agent.experience_buffer.tensor_dict["dones"].any(), "an episode ended"
        buffers.append({k: batch[k].clone() for k in ("obses", "actions", "values", "returns")})
    for key in buffers[0]:
        torch.testing.assert_close(buffers[1][key], buffers[0][key], rtol=1e-4, atol=1e-4,
                                   msg=key)
