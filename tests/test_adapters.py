"""The rsl_rl and skrl adapters (`myriad.rl.adapters`) against the real libraries: their
interfaces, and a few real PPO updates of each library on Ant (finite losses, parameters that
move). Each library's tests are skipped when it is not installed (`myriad[rsl_rl]`,
`myriad[skrl]`)."""

import importlib.util
import math

import pytest
import torch

from myriad.rl.adapters import rsl_rl_env, skrl_env

NUM_ENVS = 32
HORIZON = 16
needs_fingers = pytest.mark.skipif(importlib.util.find_spec("robot_properties_fingers") is None,
                                   reason="Trifinger needs robot-properties-fingers (myriad[arms])")


def changed(before, module):
    return any(not torch.equal(a, b) for a, b in zip(before, module.parameters()))


# ---------------------------------------------------------------------------------- rsl_rl
def rsl_rl_cfg(env, iterations_of_logging=1000):
    return {
        "num_steps_per_env": HORIZON, "save_interval": iterations_of_logging,
        "obs_groups": env.obs_groups,
        "algorithm": {"class_name": "PPO", "num_learning_epochs": 2, "num_mini_batches": 2,
                      "learning_rate": 3e-4, "entropy_coef": 0.0, "desired_kl": 0.01},
        "actor": {"class_name": "MLPModel", "hidden_dims": [64, 64], "activation": "elu",
                  "obs_normalization": True,
                  "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
        "critic": {"class_name": "MLPModel", "hidden_dims": [64, 64], "activation": "elu",
                   "obs_normalization": True},
    }


def test_rsl_rl_interface():
    pytest.importorskip("rsl_rl")
    from rsl_rl.env import VecEnv
    from tensordict import TensorDict

    env = rsl_rl_env("Ant", num_envs=4, episodeLength=2)
    assert isinstance(env, VecEnv)
    assert (env.num_envs, env.num_actions, env.max_episode_length) == (4, 8, 2)
    assert env.obs_groups == {"actor": ["policy"], "critic": ["policy"]}
    obs = env.get_observations()
    assert isinstance(obs, TensorDict) and set(obs.keys()) == {"policy"}
    assert obs["policy"].shape == (4, 60)
    env.episode_length_buf = torch.tensor([0, 1, 1, 0])    # rsl_rl's init_at_random_ep_len
    obs, rewards, dones, extras = env.step(torch.zeros(4, 8))
    assert obs["policy"].shape == (4, 60) and rewards.shape == dones.shape == (4,)
    assert dones.tolist() == [0, 1, 1, 0] and extras["time_outs"].tolist() == [0, 1, 1, 0]
    assert torch.equal(env.get_observations()["policy"], obs["policy"])


def test_rsl_rl_ppo_updates_ant(tmp_path):
    pytest.importorskip("rsl_rl")
    from rsl_rl.runners import OnPolicyRunner

    torch.manual_seed(0)
    env = rsl_rl_env("Ant", num_envs=NUM_ENVS, episodeLength=20)     # time-outs in the rollouts
    runner = OnPolicyRunner(env, rsl_rl_cfg(env), log_dir=str(tmp_path), device="cpu")
    actor, critic = runner.alg.actor, runner.alg.critic
    before = [p.detach().clone() for p in actor.parameters()], \
        [p.detach().clone() for p in critic.parameters()]
    losses, update = [], runner.alg.update

    def recorded_update():
        losses.append(update())
        return losses[-1]

    runner.alg.update = recorded_update
    runner.learn(num_learning_iterations=3, init_at_random_ep_len=True)
    assert len(losses) == 3
    assert all(math.isfinite(v) for loss in losses for v in loss.values()), losses
    assert changed(before[0], actor) and changed(before[1], critic)
    assert len(runner.logger.rewbuffer) > 0, "finished episodes reach rsl_rl's statistics"


@needs_fingers
def test_rsl_rl_asymmetric_task_gives_the_critic_its_states():
    pytest.importorskip("rsl_rl")
    from rsl_rl.runners import OnPolicyRunner

    env = rsl_rl_env("Trifinger", num_envs=4)
    assert env.obs_groups == {"actor": ["policy"], "critic": ["critic"]}
    obs = env.get_observations()
    assert obs["policy"].shape == (4, 41) and obs["critic"].shape == (4, 113)
    runner = OnPolicyRunner(env, rsl_rl_cfg(env), log_dir=None, device="cpu")
    assert runner.alg.critic.obs_dim == 113 and runner.alg.actor.obs_dim == 41
    runner.learn(num_learning_iterations=1)


# ---------------------------------------------------------------------------------- skrl
def skrl_agent(env, directory):
    import torch.nn as nn
    from skrl.agents.torch.ppo import PPO, PPO_CFG
    from skrl.memories.torch import RandomMemory
    from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
    from skrl.resources.preprocessors.torch import RunningStandardScaler

    class Policy(GaussianMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=env.observation_space,
                           action_space=env.action_space, device=env.device)
            GaussianMixin.__init__(self)
            self.net = nn.Sequential(nn.Linear(self.num_observations, 64), nn.ELU(),
                                     nn.Linear(64, self.num_actions))
            self.log_std = nn.Parameter(torch.zeros(self.num_actions))

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {"log_std": self.log_std}

    class Value(DeterministicMixin, Model):
        def __init__(self):
            Model.__init__(self, observation_space=env.observation_space,
                           action_space=env.action_space, device=env.device)
            DeterministicMixin.__init__(self)
            self.net = nn.Sequential(nn.Linear(self.num_observations, 64), nn.ELU(),
                                     nn.Linear(64, 1))

        def compute(self, inputs, role=""):
            return self.net(inputs["observations"]), {}

    cfg = PPO_CFG(rollouts=HORIZON, learning_epochs=2, mini_batches=2, learning_rate=3e-4,
                  time_limit_bootstrap=True, observation_preprocessor=RunningStandardScaler,
                  observation_preprocessor_kwargs={"size": env.observation_space,
                                                   "device": env.device})
    cfg.experiment.directory = str(directory)
    cfg.experiment.write_interval = 0
    cfg.experiment.checkpoint_interval = 0
    return PPO(models={"policy": Policy(), "value": Value()},
               memory=RandomMemory(memory_size=HORIZON, num_envs=env.num_envs, device=env.device),
               cfg=cfg, observation_space=env.observation_space, state_space=env.state_space,
               action_space=env.action_space, device=env.device)


def test_skrl_interface():
    pytest.importorskip("skrl")
    from skrl.envs.wrappers.torch import Wrapper

    env = skrl_env("Ant", num_envs=4, episodeLength=2, terminationHeight=-10.0)
    assert isinstance(env, Wrapper)
    assert env.num_envs == 4 and env.num_agents == 1 and env.device == torch.device("cpu")
    assert env.observation_space.shape == (60,) and env.action_space.shape == (8,)
    assert env.state_space is None
    obs, info = env.reset()
    assert obs.shape == (4, 60) and info == {} and env.state() is None
    for step in (1, 2):
        obs, rewards, terminated, truncated, info = env.step(torch.zeros(4, 8))
        assert obs.shape == (4, 60)
        assert rewards.shape == terminated.shape == truncated.shape == (4, 1)
        assert terminated.dtype == truncated.dtype == torch.bool
    assert truncated.all() and not terminated.any()


def test_skrl_ppo_updates_ant(tmp_path):
    pytest.importorskip("skrl")
    from skrl.trainers.torch import SequentialTrainer

    torch.manual_seed(0)
    env = skrl_env("Ant", num_envs=NUM_ENVS, episodeLength=20)
    agent = skrl_agent(env, tmp_path)
    before = [p.detach().clone() for p in agent.policy.parameters()], \
        [p.detach().clone() for p in agent.value.parameters()]
    trainer = SequentialTrainer(env=env, agents=agent, cfg={
        "timesteps": 3 * HORIZON, "headless": True, "disable_progressbar": True,
        "close_environment_at_exit": False})
    trainer.train()
    losses = agent.tracking_data["Loss / Policy loss"] + agent.tracking_data["Loss / Value loss"]
    assert len(losses) == 6 and all(math.isfinite(v) for v in losses), losses
    assert changed(before[0], agent.policy) and changed(before[1], agent.value)


@needs_fingers
def test_skrl_asymmetric_task_gives_its_states():
    pytest.importorskip("skrl")
    env = skrl_env("Trifinger", num_envs=4)
    assert env.state_space.shape == (113,) and env.observation_space.shape == (41,)
    obs, _ = env.reset()
    assert obs.shape == (4, 41) and env.state().shape == (4, 113)
    env.step(torch.zeros(4, 9))
    assert env.state().shape == (4, 113)
