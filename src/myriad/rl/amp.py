"""Adversarial Motion Priors, the learner's side: the discriminator, its loss, the style reward
and the replay buffer of policy samples (reference isaac-gym-facts §3 "AMP", task-specs §7).

The discriminator D tells pairs of AMP observations (frame t and t−1 of the humanoid, 2 × 105)
drawn from motion clips (label 1) from those the policy produced (label 0, this epoch's and older
ones from the replay buffer). Its loss, as the original's:

    0.5·(BCE(D(policy, replay) → 0) + BCE(D(demo) → 1))
    + 0.05·Σ w_out²                    logit regularisation: the output layer's weights only
    + 5·mean ‖∂D/∂x_demo‖²             gradient penalty on the (normalized) demo inputs
    + 1e-4·Σ w²                        weight decay over every layer's weights

and the policy's reward for a pair is −log(max(1 − sigmoid(D), 1e-4)) × 2: high where D takes
the pair for motion capture. The inputs are normalized by a running mean and variance first.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn
from torch.nn import functional as F


@dataclass
class AMPConfig:
    """The original's AMP settings (HumanoidAMPPPO.yaml)."""
    units: tuple = (1024, 512)          # discriminator hidden layers, ReLU
    logit_reg: float = 0.05
    grad_penalty: float = 5.0
    weight_decay: float = 1e-4
    reward_scale: float = 2.0
    replay_size: int = 1_000_000
    replay_keep: float = 0.01           # once full, the share of new samples that go in


class AMPDiscriminator(nn.Module):
    """D(x): an MLP over normalized AMP observations to one logit."""

    def __init__(self, num_inputs: int, config: AMPConfig = AMPConfig()):
        super().__init__()
        layers, width = [], num_inputs
        for units in config.units:
            layers += [nn.Linear(width, units), nn.ReLU()]
            width = units
        self.trunk = nn.Sequential(*layers)
        self.logit = nn.Linear(width, 1)
        nn.init.uniform_(self.logit.weight, -1.0, 1.0)     # the original's output layer
        nn.init.zeros_(self.logit.bias)
        self.mean = nn.Parameter(torch.zeros(num_inputs), requires_grad=False)
        self.var = nn.Parameter(torch.ones(num_inputs), requires_grad=False)
        self.count = nn.Parameter(torch.tensor(1e-4), requires_grad=False)

    def update_normalizer(self, x: torch.Tensor) -> None:
        """Merge a batch [n, inputs] into the running mean and variance (Chan et al.)."""
        n = x.shape[0]
        mean, var = x.mean(0), x.var(0, unbiased=False)
        total = self.count + n
        delta = mean - self.mean
        self.var.copy_((self.var * self.count + var * n + delta**2 * self.count * n / total)
                       / total)
        self.mean.add_(delta * n / total)
        self.count.copy_(total)

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        return ((x - self.mean) / torch.sqrt(self.var + 1e-5)).clamp(-5.0, 5.0)

    def forward(self, x_normalized: torch.Tensor) -> torch.Tensor:
        """Logits [n] of inputs already normalized."""
        return self.logit(self.trunk(x_normalized)).squeeze(-1)

    def weights(self) -> list[torch.Tensor]:
        return [m.weight for m in self.modules() if isinstance(m, nn.Linear)]


def discriminator_loss(disc: AMPDiscriminator, policy_obs: torch.Tensor,
                       demo_obs: torch.Tensor, config: AMPConfig = AMPConfig()):
    """(loss, terms) for one minibatch: `policy_obs` [n, inputs] the policy's (this epoch's and
    replayed) samples, `demo_obs` [m, inputs] motion-capture pairs; both raw (normalized here)."""
    policy_logit = disc(disc.normalize(policy_obs))
    demo_in = disc.normalize(demo_obs).requires_grad_(True)
    demo_logit = disc(demo_in)
    bce = 0.5 * (F.binary_cross_entropy_with_logits(policy_logit, torch.zeros_like(policy_logit))
                 + F.binary_cross_entropy_with_logits(demo_logit, torch.ones_like(demo_logit)))
    logit_reg = torch.sum(disc.logit.weight**2)
    grad, = torch.autograd.grad(demo_logit.sum(), demo_in, create_graph=True)
    grad_penalty = torch.mean(torch.sum(grad**2, dim=-1))
    weight_decay = sum(torch.sum(w**2) for w in disc.weights())
    loss = (bce + config.logit_reg * logit_reg + config.grad_penalty * grad_penalty
            + config.weight_decay * weight_decay)
    terms = {"bce": bce.detach(), "logit_reg": logit_reg.detach(),
             "grad_penalty": grad_penalty.detach(), "weight_decay": weight_decay.detach(),
             "policy_logit": policy_logit.mean().detach(), "demo_logit": demo_logit.mean().detach()}
    return loss, terms


@torch.no_grad()
def style_reward(disc: AMPDiscriminator, amp_obs: torch.Tensor,
                 config: AMPConfig = AMPConfig()) -> torch.Tensor:
    """The policy's reward [n] for its AMP observation pairs [n, inputs]."""
    prob = torch.sigmoid(disc(disc.normalize(amp_obs)))
    return -torch.log(torch.clamp(1.0 - prob, min=1e-4)) * config.reward_scale


class ReplayBuffer:
    """The policy's past AMP samples: every sample goes in until `size` are held; after that
    each new one replaces a random old one with probability `keep` (so the buffer spans the
    whole run, not its last epochs)."""

    def __init__(self, size: int, num_inputs: int, keep: float, device="cpu"):
        if size < 1 or not 0.0 <= keep <= 1.0:
            raise ValueError(f"ReplayBuffer: size {size} must be >= 1 and keep {keep} in [0, 1]")
        self.data = torch.zeros(size, num_inputs, device=device)
        self.held, self.keep = 0, keep

    def __len__(self) -> int:
        return self.held

    def add(self, samples: torch.Tensor, generator: torch.Generator | None = None) -> None:
        room = min(len(self.data) - self.held, len(samples))
        self.data[self.held:self.held + room] = samples[:room]
        self.held += room
        rest = samples[room:]
        if len(rest):
            kept = rest[torch.rand(len(rest), device=rest.device, generator=generator) < self.keep]
            slots = torch.randint(0, self.held, (len(kept),), device=rest.device,
                                  generator=generator)
            self.data[slots] = kept

    def sample(self, n: int, generator: torch.Generator | None = None) -> torch.Tensor:
        if self.held == 0:
            raise ValueError("ReplayBuffer.sample: the buffer is empty")
        return self.data[torch.randint(0, self.held, (n,), device=self.data.device,
                                       generator=generator)]


# ---------------------------------------------------------------------------- the agent
from .agent import MyriadAgent  # noqa: E402  (agent imports rl_games; the parts above do not)

AMP_METRICS = ("style_reward", "disc_loss", "demo_logit", "policy_logit")


class AMPAgent(MyriadAgent):
    """rl_games' PPO with Adversarial Motion Priors (the original's AMP agent, simplified where
    said): each step's reward is task_reward_w × the task's + style_reward_w × the style reward
    of the step's AMP pair under the current discriminator; after each rollout the
    discriminator trains on the rollout's pairs, as many replayed ones and as many pairs drawn
    from the clips (`task.fetch_amp_obs_demo`), in the PPO update's minibatches and epochs.

    Deviations: the discriminator has its own Adam optimizer (same learning rate) instead of
    sharing the policy's loss and optimizer; demo pairs are drawn from the motion library for
    each minibatch instead of from a pre-filled buffer of them (the same distribution); the
    replay buffer is not saved in checkpoints (a resumed run refills it)."""

    def __init__(self, base_name, params):
        settings = dict(params["config"].pop("amp"))
        self.task_reward_w = float(settings.pop("task_reward_w"))
        self.style_reward_w = float(settings.pop("style_reward_w"))
        self.amp_batch = int(settings.pop("batch"))
        learning_rate = float(settings.pop("learning_rate"))
        self.amp_config = AMPConfig(**{k: tuple(v) if k == "units" else v
                                       for k, v in settings.items()})
        self.amp_stats = {name: 0.0 for name in AMP_METRICS}
        super().__init__(base_name, params)
        task = self.vec_env.env
        if not hasattr(task, "fetch_amp_obs_demo"):
            raise ValueError(f"task {type(task).__name__} has no motion clips: the AMP agent needs "
                             "a task with fetch_amp_obs_demo (HumanoidAMP)")
        self.num_amp_obs = task.fetch_amp_obs_demo(1).shape[1]
        self.disc = AMPDiscriminator(self.num_amp_obs, self.amp_config).to(self.ppo_device)
        self.disc_optimizer = torch.optim.Adam(self.disc.parameters(), lr=learning_rate)
        self.replay = ReplayBuffer(self.amp_config.replay_size, self.num_amp_obs,
                                   self.amp_config.replay_keep, self.ppo_device)
        self.rollout_amp = []
        self.rollout_style = []
        sigma = getattr(self.model.a2c_network, "sigma", None)
        if sigma is not None:       # the original keeps the policy's std at its start value
            sigma.requires_grad_(False)

    def task_metrics(self) -> dict[str, float]:
        return {**super().task_metrics(), **self.amp_stats}

    def env_step(self, actions):
        obs, rewards, dones, infos = super().env_step(actions)
        amp_obs = infos["amp_obs"]
        style = style_reward(self.disc, amp_obs, self.amp_config)
        self.rollout_amp.append(amp_obs)
        self.rollout_style.append(style.mean())
        rewards = self.task_reward_w * rewards + self.style_reward_w * style.unsqueeze(1)
        return obs, rewards, dones, infos

    def prepare_dataset(self, batch_dict):
        super().prepare_dataset(batch_dict)
        self.update_discriminator()

    def update_discriminator(self) -> None:
        policy = torch.cat(self.rollout_amp)
        task = self.vec_env.env
        self.disc.update_normalizer(torch.cat([policy, task.fetch_amp_obs_demo(len(policy))]))
        per_minibatch = len(policy) // self.num_minibatches
        rows = min(self.amp_batch, per_minibatch)
        losses = []
        for _ in range(self.mini_epochs_num):
            order = torch.randperm(len(policy), device=policy.device)
            for start in range(0, len(policy) - per_minibatch + 1, per_minibatch):
                agent = policy[order[start:start + rows]]
                if len(self.replay):
                    agent = torch.cat([agent, self.replay.sample(rows)])
                demo = task.fetch_amp_obs_demo(rows)
                loss, terms = discriminator_loss(self.disc, agent, demo, self.amp_config)
                self.disc_optimizer.zero_grad()
                loss.backward()
                self.disc_optimizer.step()
                losses.append(torch.stack([loss.detach(), terms["demo_logit"],
                                           terms["policy_logit"]]))
        self.replay.add(policy)
        mean = torch.stack(losses).mean(0).tolist()
        self.amp_stats = {"style_reward": float(torch.stack(self.rollout_style).mean()),
                          "disc_loss": mean[0], "demo_logit": mean[1], "policy_logit": mean[2]}
        self.rollout_amp, self.rollout_style = [], []

    def get_full_state_weights(self):
        state = super().get_full_state_weights()
        state["amp"] = {"disc": self.disc.state_dict(),
                        "optimizer": self.disc_optimizer.state_dict()}
        return state

    def set_full_state_weights(self, weights, set_epoch=True):
        super().set_full_state_weights(weights, set_epoch)
        if "amp" in weights:
            self.disc.load_state_dict(weights["amp"]["disc"])
            self.disc_optimizer.load_state_dict(weights["amp"]["optimizer"])
