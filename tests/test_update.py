"""The PPO minibatch step with its adaptive learning rate on the device (`myriad.rl.update`)
trains as rl_games' own step does: the same weights, optimizer state and rate, bit for bit on a
CPU; captured as a CUDA graph (`capture_update=true`, the GPU suite runs this file with
--device cuda:0) the same up to float32 rounding. A checkpoint carries the rate to a resumed run.
"""

import tempfile

import pytest
import torch

from myriad.rl.run import compose, task_and_train_configs
from myriad.rl.train import build_agent
from myriad.tasks import TASKS


def ant_agent(device, rl_games_step=False, capture=False, task="Ant", **config):
    """An agent as `myriad train` builds it, small: 64 envs in minibatches of 256 (Ant: 16
    steps, 4 minibatches, 4 mini-epochs); the hidden layers in float32 on every CPU.
    `rl_games_step`: rl_games' own minibatch step, host-side schedule and critic step."""
    overrides = [f"task={task}", f"device={device}", "num_envs=64"]
    cfg = compose(overrides)
    task_cfg, train_cfg, device = task_and_train_configs(cfg, overrides)
    params = train_cfg["params"]["config"]
    params.pop("mlp_bfloat16", None)
    params.update(minibatch_size=256, **config)
    torch.manual_seed(0)
    task = TASKS[task](task_cfg, device=device)
    run = {"train_dir": tempfile.mkdtemp(prefix="myriad_update_"), "experiment": "update",
           "max_time_s": float("inf"), "describe": {}, "capture_update": capture}
    agent = build_agent(task, train_cfg, run, seed=3)
    if rl_games_step:
        agent.minibatch_step, agent.schedule_type = None, "legacy"
        if agent.has_central_value:
            del agent.central_value_net.train_critic    # back to the class's
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
def test_the_device_side_step_trains_as_rl_games_own_bit_for_bit(task):
    ours, theirs = ant_agent("cpu", task=task), ant_agent("cpu", rl_games_step=True, task=task)
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


def test_a_checkpoint_carries_the_learning_rate_to_the_resumed_run():
    agent = ant_agent("cpu")
    train_epochs(agent, 2)
    state = agent.get_full_state_weights()
    assert state["myriad"]["last_lr"] == agent.last_lr != 3e-4
    assert all(isinstance(g["lr"], float) and not g["capturable"]
               for g in state["optimizer"]["param_groups"])
    resumed = ant_agent("cpu")
    resumed.set_full_state_weights(state)
    assert resumed.last_lr == agent.last_lr
    assert resumed.minibatch_step.learning_rate() == agent.last_lr
    # and rl_games' own step resumes from it too (its schedule continues from last_lr)
    theirs = ant_agent("cpu", rl_games_step=True)
    theirs.set_full_state_weights(state)
    assert theirs.last_lr == agent.last_lr


def test_a_captured_step_trains_as_the_eager_one(device):
    eager, captured = ant_agent(device), ant_agent(device, capture=True)
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
    agent = ant_agent("cpu", lr_schedule="linear")
    assert agent.minibatch_step is None and agent.schedule_type == "legacy"
