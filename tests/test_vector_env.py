"""Myriad tasks as gymnasium vector envs (`myriad.make_vec`): spaces, shapes and dtypes in torch
and numpy, the terminated/truncated split, same-step autoreset with info["final_obs"] checked
against a twin env whose episode goes on, seeding, gymnasium's own checks and wrappers on the
real library, and a step that never reads the device."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from gymnasium.spaces import Box
from gymnasium.utils import env_checker
from gymnasium.utils.env_checker import data_equivalence
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.wrappers.vector import RecordEpisodeStatistics

import myriad
from myriad.rl.vector import MyriadVectorEnv
from test_host_sync import recording_syncs

N = 8


def random_actions(n, seed, steps):
    g = torch.Generator().manual_seed(seed)
    return [torch.rand(n, 8, generator=g) * 2 - 1 for _ in range(steps)]


def test_spaces_and_metadata():
    envs = myriad.make_vec("Ant", num_envs=N)
    assert isinstance(envs, VectorEnv) and envs.unwrapped is envs and envs.num_envs == N
    assert envs.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert envs.single_observation_space == Box(-5.0, 5.0, (60,), np.float32)   # clipObservations
    assert envs.single_action_space == Box(-1.0, 1.0, (8,), np.float32)
    assert envs.observation_space == Box(-5.0, 5.0, (N, 60), np.float32)
    assert envs.action_space == Box(-1.0, 1.0, (N, 8), np.float32)
    assert repr(envs) == f"MyriadVectorEnv(Ant, num_envs={N}, device=cpu)"


def test_torch_reset_and_step_give_tensors_on_the_device():
    envs = myriad.make_vec("Ant", num_envs=N)
    obs, info = envs.reset(seed=0)
    assert isinstance(obs, torch.Tensor) and obs.shape == (N, 60) and obs.dtype == torch.float32
    assert obs.device == envs.device == torch.device("cpu") and info == {}
    obs, reward, terminated, truncated, info = envs.step(torch.zeros(N, 8))
    assert obs.shape == (N, 60) and obs.dtype == torch.float32
    assert reward.shape == (N,) and reward.dtype == torch.float32
    assert terminated.dtype == truncated.dtype == torch.bool
    assert terminated.shape == truncated.shape == (N,)
    assert set(info) == {"final_obs", "_final_obs"}
    assert info["final_obs"].shape == (N, 60) and info["_final_obs"].dtype == torch.bool
    assert torch.isfinite(reward).all() and (obs.abs() <= 5.0).all()


def test_numpy_mode_gives_arrays_in_the_spaces():
    envs = myriad.make_vec("Ant", num_envs=N, numpy=True)
    obs, info = envs.reset(seed=0)
    assert isinstance(obs, np.ndarray) and obs in envs.observation_space
    envs.action_space.seed(0)
    obs, reward, terminated, truncated, info = envs.step(envs.action_space.sample())
    assert isinstance(obs, np.ndarray) and obs.dtype == np.float32 and obs in envs.observation_space
    assert reward.dtype == np.float32 and reward.shape == (N,)
    assert terminated.dtype == truncated.dtype == np.bool_ and terminated.shape == (N,)
    assert isinstance(info["final_obs"], np.ndarray) and info["final_obs"].shape == (N, 60)
    assert info["_final_obs"].dtype == np.bool_


def test_torch_and_numpy_modes_give_the_same_numbers():
    """Up to a time-out and its reset (episodeLength 2). Resets draw from torch's global
    generator, so the two envs run one after the other."""

    def rollout(numpy):
        envs = myriad.make_vec("Ant", num_envs=N, episodeLength=2, numpy=numpy)
        out = [envs.reset(seed=5)[0]]
        for actions in random_actions(N, 1, 2):
            obs, reward, terminated, truncated, info = envs.step(
                actions.numpy() if numpy else actions)
            out += [obs, reward, terminated, truncated, info["final_obs"], info["_final_obs"]]
        return [x if numpy else x.numpy() for x in out]

    as_torch, as_numpy = rollout(False), rollout(True)
    assert data_equivalence(as_torch, as_numpy, exact=True)
    assert as_numpy[-3].all()           # the last step went through a time-out


def twins(**done_overrides):
    """An Ant env that ends its episodes (the overrides) and one whose episodes go on, seeded
    alike: until the first ends, both live through the same states."""
    ending = myriad.make_vec("Ant", num_envs=N, **done_overrides)
    going_on = myriad.make_vec("Ant", num_envs=N, episodeLength=1000, terminationHeight=-10.0)
    for envs in (ending, going_on):
        envs.reset(seed=11)
    return ending, going_on


def test_time_out_is_truncated_and_final_obs_is_the_observation_before_the_reset():
    ending, going_on = twins(episodeLength=3, terminationHeight=-10.0)
    for step, actions in enumerate(random_actions(N, 2, 3), start=1):
        obs, reward, terminated, truncated, info = ending.step(actions)
        twin_obs, twin_reward, *_ = going_on.step(actions)
        assert not terminated.any()
        assert torch.equal(truncated, torch.full((N,), step == 3))
        assert torch.equal(info["_final_obs"], truncated)
        assert torch.equal(reward, twin_reward)
    assert torch.equal(info["final_obs"], twin_obs)     # the episode's last observation ...
    assert not torch.equal(obs, twin_obs)               # ... and not the new episode's first
    assert (ending.task.progress_buf == 0).all()
    # the new episode starts at the task's start pose: torso height 0.62
    torch.testing.assert_close(obs[:, 0], torch.full((N,), 0.62), atol=1e-5, rtol=0)


def test_termination_is_terminated_not_truncated_with_its_final_obs():
    ending, going_on = twins(terminationHeight=10.0)     # every torso is "too low": ends at once
    actions = random_actions(N, 3, 1)[0]
    obs, reward, terminated, truncated, info = ending.step(actions)
    twin_obs, *_ = going_on.step(actions)
    assert terminated.all() and not truncated.any() and info["_final_obs"].all()
    assert torch.equal(info["final_obs"], twin_obs)
    assert (reward == -2.0).all()                        # deathCost
    assert not torch.equal(obs, twin_obs)


def test_final_obs_of_the_envs_that_go_on_is_their_observation():
    envs = myriad.make_vec("Ant", num_envs=N, episodeLength=4)
    envs.reset(seed=0)
    envs.task.progress_buf[: N // 2] = 2        # half the envs time out two steps early
    seen = torch.zeros(N, dtype=torch.bool)
    for actions in random_actions(N, 4, 4):
        obs, _, terminated, truncated, info = envs.step(actions)
        done = info["_final_obs"]
        assert torch.equal(done, terminated | truncated) and not (terminated & truncated).any()
        assert torch.equal(info["final_obs"][~done], obs[~done])
        seen |= done
        if 0 < done.sum() < N:
            assert not torch.equal(info["final_obs"][done], obs[done])
    assert seen.all()


def test_seeded_resets_repeat_and_differ_by_seed():
    envs = myriad.make_vec("Ant", num_envs=N)
    actions = random_actions(N, 5, 3)

    def rollout(seed):
        # a reset runs no physics: the foot sensors in the reset observation (28:52) still hold
        # the last step's readings, so that part depends on what ran before
        out = [envs.reset(seed=seed)[0][:, :28]]
        out += [envs.step(a)[0] for a in actions]
        return [o.numpy() for o in out]

    first, again, other = rollout(3), rollout(3), rollout(4)
    assert data_equivalence(first, again, exact=True)
    assert not data_equivalence(first[0], other[0])


@pytest.mark.filterwarnings("ignore:.*Casting input x to numpy array")     # a tensor in a Box
@pytest.mark.parametrize("numpy", [True, False])
def test_gymnasium_env_checks(numpy):
    """gymnasium's env checks that also apply to a vector env, on one env (they test
    `if terminated`). Its check_step_determinism wants Python bools: the test above does it."""
    envs = myriad.make_vec("Ant", num_envs=1, numpy=numpy)
    for check in (env_checker.check_reset_seed_determinism, env_checker.check_reset_options,
                  env_checker.check_reset_return_type, env_checker.check_returned_data_not_reused):
        check(envs)


def test_gymnasium_record_episode_statistics_wrapper():
    envs = RecordEpisodeStatistics(myriad.make_vec("Ant", num_envs=N, episodeLength=4,
                                                   numpy=True))
    envs.reset(seed=0)
    returns = np.zeros(N)
    for step in range(1, 5):
        _, reward, terminated, truncated, info = envs.step(np.zeros((N, 8), np.float32))
        returns += reward
        assert ("episode" in info) == (step == 4)
    np.testing.assert_array_equal(info["episode"]["l"], 4)
    np.testing.assert_allclose(info["episode"]["r"], returns, rtol=1e-6)
    assert info["_episode"].all() and truncated.all()


def test_bad_input_fails_clearly():
    envs = myriad.make_vec("Ant", num_envs=N)
    with pytest.raises(ValueError, match=r"\(8, 8\).*\(8, 7\)"):
        envs.step(torch.zeros(N, 7))
    with pytest.raises(ValueError, match="reset_mask"):
        envs.reset(options={"reset_mask": np.ones(N, bool)})
    with pytest.raises(KeyError, match="unknown task 'Antt'"):
        myriad.make_vec("Antt")


def test_step_never_reads_the_device():
    envs = myriad.make_vec("Ant", num_envs=4, episodeLength=2)
    envs.task.skip_idle_resets = False                  # the step as a GPU runs it
    envs.reset(seed=0)
    timed_out = []
    for actions in random_actions(4, 6, 3):
        with recording_syncs() as syncs:
            _, _, _, truncated, _ = envs.step(actions)
        assert syncs == [], sorted(set(syncs))
        timed_out.append(bool(truncated.all()))
    assert timed_out == [False, True, False]


def test_a_built_task_wraps_and_rl_games_never_sees_final_obs():
    task = myriad.make("Ant", num_envs=4)
    assert "final_obs" not in task.step(torch.zeros(4, 8))[3]
    envs = MyriadVectorEnv(task, numpy=True)
    assert isinstance(envs.step(np.zeros((4, 8)))[0], np.ndarray)
    assert "final_obs" in task.extras


@pytest.mark.skipif(importlib.util.find_spec("robot_properties_fingers") is None,
                    reason="Trifinger needs robot-properties-fingers (myriad[arms])")
def test_asymmetric_task_gives_its_states_in_info():
    envs = myriad.make_vec("Trifinger", num_envs=2, episodeLength=2)
    _, info = envs.reset(seed=0)
    assert info["states"].shape == (2, 113)
    for _ in range(2):
        _, _, _, _, info = envs.step(torch.zeros(2, 9))
    assert info["_final_obs"].all()         # Trifinger ends its episodes itself at the limit
    assert info["states"].shape == info["final_states"].shape == (2, 113)
    assert not torch.equal(info["states"], info["final_states"])


def test_the_cleanrl_example_trains_and_keeps_its_agent(tmp_path, capsys, monkeypatch):
    """examples/cleanrl_ppo_ant.py, two PPO iterations on 16 envs: the update runs (finite value
    loss and KL on its progress line) and the agent is saved with changed parameters."""
    path = Path(__file__).parent.parent / "examples" / "cleanrl_ppo_ant.py"
    spec = importlib.util.spec_from_file_location("cleanrl_ppo_ant", path)
    example = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, example)     # its dataclass looks itself up
    spec.loader.exec_module(example)
    runs = {}
    for iterations in (0, 2):          # the same seed: the same agent before its updates
        runs[iterations] = tmp_path / f"agent_{iterations}.pt"
        example.main(example.Config(num_envs=16, total_timesteps=16 * 16 * iterations,
                                    log_every=1, save_path=str(runs[iterations])))
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("iter")]
    assert len(lines) == 2
    value_loss, kl = float(lines[-1].split("value loss")[1].split()[0]), \
        float(lines[-1].split("kl")[1].split()[0])
    assert np.isfinite(value_loss) and np.isfinite(kl) and kl > 0
    before, after = (torch.load(runs[k])["agent"] for k in (0, 2))
    assert torch.equal(before["obs_norm.mean"], torch.zeros(60))
    assert not torch.equal(after["actor_mean.weight"], before["actor_mean.weight"])
    assert not torch.equal(after["value_head.weight"], before["value_head.weight"])
