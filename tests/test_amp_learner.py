"""The AMP learner's parts (rl/amp.py) on set inputs: the discriminator's loss terms, its
gradient penalty, the style reward, the input normalizer and the replay buffer."""

import math

import pytest
import torch
from torch.nn import functional as F

from myriad.rl.amp import (AMPConfig, AMPDiscriminator, ReplayBuffer, discriminator_loss,
                           style_reward)

CONFIG = AMPConfig()


def _linear_disc(w, b=0.0):
    """D(x) = w·normalize(x) + b, normalizer at mean 0, variance 1 - 1e-5 (normalize = identity)."""
    disc = AMPDiscriminator(len(w), AMPConfig(units=()))
    with torch.no_grad():
        disc.logit.weight.copy_(torch.tensor([w]))
        disc.logit.bias.fill_(b)
        disc.var.fill_(1.0 - 1e-5)
    return disc


def test_the_loss_terms_of_a_linear_discriminator_are_the_formulas():
    w = [0.5, -1.0, 2.0]
    disc = _linear_disc(w, b=0.25)
    gen = torch.Generator().manual_seed(0)
    policy, demo = torch.randn(64, 3, generator=gen), torch.randn(32, 3, generator=gen) + 1.0
    loss, terms = discriminator_loss(disc, policy, demo)
    wt = torch.tensor(w)
    policy_logit, demo_logit = policy @ wt + 0.25, demo @ wt + 0.25
    bce = 0.5 * (F.softplus(policy_logit).mean() + F.softplus(-demo_logit).mean())
    norm2 = float(wt @ wt)
    torch.testing.assert_close(terms["bce"], bce)
    assert float(terms["grad_penalty"]) == pytest.approx(norm2)       # ∂D/∂x = w everywhere
    assert float(terms["logit_reg"]) == pytest.approx(norm2)
    assert float(terms["weight_decay"]) == pytest.approx(norm2)      # one layer: the same w
    expected = bce + 0.05 * norm2 + 5.0 * norm2 + 1e-4 * norm2
    torch.testing.assert_close(loss, expected)


def test_the_gradient_penalty_is_the_demo_inputs_gradient_norm():
    """A nonlinear D: the penalty equals the mean squared norm of ∂D/∂x at the demo samples,
    measured here by central differences (float64)."""
    torch.manual_seed(0)
    disc = AMPDiscriminator(4, AMPConfig(units=(16, 8))).double()
    demo = torch.randn(5, 4, dtype=torch.float64)
    _, terms = discriminator_loss(disc, torch.randn(7, 4, dtype=torch.float64), demo)
    x = disc.normalize(demo).detach()
    eps = 1e-6
    with torch.no_grad():
        grads = torch.stack([(disc(x + eps * e) - disc(x - eps * e)) / (2 * eps)
                             for e in torch.eye(4, dtype=torch.float64)], dim=-1)
    assert float(terms["grad_penalty"]) == pytest.approx(float((grads**2).sum(-1).mean()),
                                                         rel=1e-6)


def test_the_style_reward_rewards_what_looks_like_motion_capture():
    x = torch.tensor([[0.0], [2.0], [-2.0]])                  # logits 0, 20, -20
    reward = style_reward(_linear_disc([10.0]), x)
    assert reward.tolist() == pytest.approx([2 * math.log(2), -2 * math.log(1e-4), 0.0],
                                            abs=1e-6)


def test_training_the_discriminator_tells_demo_from_policy_samples():
    """200 steps on two clouds: the demo samples' logit ends above the policy's, and so does
    their style reward."""
    torch.manual_seed(0)
    disc = AMPDiscriminator(6, AMPConfig(units=(32, 16)))
    demo = torch.randn(256, 6) * 0.5 + 1.0
    policy = torch.randn(256, 6) * 0.5 - 1.0
    disc.update_normalizer(torch.cat([demo, policy]))
    opt = torch.optim.Adam(disc.parameters(), lr=1e-3)
    for _ in range(200):
        loss, terms = discriminator_loss(disc, policy, demo)
        opt.zero_grad()
        loss.backward()
        opt.step()
    assert terms["demo_logit"] > 0.5 > -0.5 > terms["policy_logit"]
    assert style_reward(disc, demo).mean() > 2 * style_reward(disc, policy).mean()


def test_the_normalizer_keeps_the_mean_and_variance_of_everything_seen():
    disc = AMPDiscriminator(3, AMPConfig(units=(4,)))
    gen = torch.Generator().manual_seed(1)
    batches = [torch.randn(n, 3, generator=gen) * s + m for n, s, m in ((100, 2.0, 1.0),
                                                                        (37, 0.5, -3.0),
                                                                        (250, 1.0, 0.0))]
    for batch in batches:
        disc.update_normalizer(batch)
    every = torch.cat(batches)
    torch.testing.assert_close(disc.mean.data, every.mean(0), atol=1e-4, rtol=0)
    torch.testing.assert_close(disc.var.data, every.var(0, unbiased=False), atol=1e-3, rtol=1e-4)


def test_the_replay_buffer_fills_then_keeps_a_share_of_new_samples():
    buffer = ReplayBuffer(1000, 2, keep=0.01)
    gen = torch.Generator().manual_seed(0)
    with pytest.raises(ValueError, match="empty"):
        buffer.sample(4)
    buffer.add(torch.zeros(600, 2))
    assert len(buffer) == 600
    buffer.add(torch.ones(100_400, 2), generator=gen)      # 400 fill it, ~1000 of the rest go in
    assert len(buffer) == 1000
    # each of the ~1000 kept replaces a random slot: a zero survives them with probability
    # (1 - 1/1000)^1000 = e^-1, so about 600·0.37 = 221 zeros are left (±3σ: ±35)
    ones = int(buffer.data[:, 0].sum())
    assert 1000 - 221 - 35 < ones < 1000 - 221 + 35
    assert buffer.sample(256, generator=gen).shape == (256, 2)
    with pytest.raises(ValueError, match="keep"):
        ReplayBuffer(10, 2, keep=1.5)
