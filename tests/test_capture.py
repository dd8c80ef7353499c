"""A task's whole step captured as one CUDA graph (`VecTask.capture_step`) steps as the step run
op by op: the same observations, rewards, resets and episode counters, resets inside the graph
included, and an eager `reset()` between replays is seen by the graph. On a CPU the setting is
ignored (the same comparison then holds trivially); the GPU suite runs this with --device cuda:0.
"""

import torch

import myriad


def twins(device, **env):
    """Two Ant tasks built alike: one stepped op by op, one with its step captured."""
    tasks = []
    for capture in (False, True):
        torch.manual_seed(0)
        task = myriad.make("Ant", num_envs=64, device=device, **env)
        task.capture_step = capture
        task.reset()
        tasks.append(task)
    return tasks


def step_both(eager, captured, actions):
    out = [task.step(actions) for task in (eager, captured)]
    return [(o[0]["obs"].clone(), o[1].clone(), o[2].clone()) for o in out]


def test_a_captured_step_steps_as_the_eager_one(device):
    # short episodes: resets (random initial states: the two tasks draw differently inside and
    # outside a graph, so states are compared up to the first reset, counters throughout)
    eager, captured = twins(device, episodeLength=6)
    gen = torch.Generator(device=eager.device).manual_seed(1)
    for k in range(14):
        actions = torch.rand(64, eager.num_actions, generator=gen, device=eager.device) * 2 - 1
        (obs_e, rew_e, reset_e), (obs_c, rew_c, reset_c) = step_both(eager, captured, actions)
        assert torch.equal(reset_e, reset_c), f"step {k}: resets differ"
        assert torch.equal(eager.progress_buf, captured.progress_buf)
        assert torch.isfinite(obs_c).all() and torch.isfinite(rew_c).all()
        if k < 5:       # before the first time-out's reset
            torch.testing.assert_close(obs_c, obs_e, atol=1e-5, rtol=1e-5)
            torch.testing.assert_close(rew_c, rew_e, atol=1e-5, rtol=1e-5)
    assert int(captured.reset_buf.sum()) >= 0 and bool((eager.progress_buf < 6).all())
    if torch.device(device).type == "cuda":
        assert captured._step_graph is not None, "the step ran as a graph"
    else:
        assert captured._step_graph is None, "a CPU ignores capture_step"


def test_an_eager_reset_between_replays_is_seen(device):
    _, captured = twins(device)
    actions = torch.zeros(64, captured.num_actions, device=captured.device)
    for _ in range(3):
        captured.step(actions)
    assert bool((captured.progress_buf == 3).all())
    captured.reset()                    # op by op, outside the graph: counters back to 0
    obs = captured.step(actions)[0]["obs"]
    assert obs is captured.obs_dict["obs"] and torch.isfinite(obs).all()
    assert bool((captured.progress_buf == 1).all()), "the graph continued from the reset"

