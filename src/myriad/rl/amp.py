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
