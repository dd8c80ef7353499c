"""PPO's minibatch step with nothing read back to the host, and on CUDA as one captured graph.

rl_games' update loop reads every minibatch's KL to the host (`kl.item()`) to adapt the learning
rate (`lr_schedule: adaptive`, `schedule_type: legacy`): on a GPU each read waits for the step's
kernels to finish, so the host cannot queue the next minibatch's while the card runs. Here the
same rule runs on the device: the learning rate is a 0-d tensor that Adam reads in place, and
after each minibatch `lr = max(lr / 1.5, min_lr)` where KL > 2 × kl_threshold,
`lr = min(lr × 1.5, max_lr)` where KL < kl_threshold / 2, as `torch.where`s in float64 (the
arithmetic of rl_games' Python floats). The host reads the rate once per epoch.

With the step free of host reads, CUDA can capture it whole (`capture_update=true`): the
forward, the clipped losses, the backward, the gradient clip, Adam and the rate's update replay
as one graph per minibatch instead of a few hundred launches. One thing in rl_games' forward
would not replay: the observation normalizer, in training mode, replaces its statistics with new
tensors (a graph would keep reading the old ones). So the normalizer's update runs before the
step, outside it, writing into the same tensors, and the step normalizes with them in eval mode:
the statistics and the normalized observations are the ones rl_games' forward computes.

Everything else is rl_games' own code (`A2CAgent.calc_gradients`, its losses, its Adam): on a
CPU the step gives the same weights as rl_games' loop, bit for bit (tests/test_update.py).
Where this cannot hold the agent keeps rl_games' step (`unsupported` says why).
"""

from __future__ import annotations

import torch
from rl_games.common import schedulers

# the minibatch's entries that A2CAgent.calc_gradients reads (non-recurrent policies)
INPUTS = ("obs", "actions", "old_logp_actions", "advantages", "old_values", "returns", "mu",
          "sigma")
WARMUP_STEPS = 3        # eager steps on a side stream before the capture, as torch asks


def in_place(normalizer, update) -> None:
    """Run `update()`, which updates a running mean/std module (rl_games' `RunningMeanStd`) in
    training mode, and leave its new statistics in the tensors it had before: its update
    replaces them with new ones, and a captured graph would go on reading the old."""
    names = ("running_mean", "running_var", "count")
    held = [getattr(normalizer, name) for name in names]
    update()
    with torch.no_grad():
        for name, tensor in zip(names, held):
            new = getattr(normalizer, name)
            if new is not tensor:
                tensor.copy_(new)
                setattr(normalizer, name, tensor)


def unsupported(agent) -> str | None:
    """Why the device-side step cannot stand in for rl_games' on this agent; None if it can."""
    if agent.is_rnn:
        return "a recurrent policy (its minibatches carry sequences and states)"
    if agent.multi_gpu:
        return "several processes (the KL and the gradients are averaged across them)"
    if agent.mixed_precision:
        return "mixed_precision (its gradient scaler steps Adam on the host's decision)"
    if agent.use_diagnostics:
        return "use_diagnostics (PpoDiagnostics reads each minibatch's values)"
    if isinstance(agent.obs_shape, dict):
        return "dict observations"
    if not isinstance(agent.scheduler, (schedulers.AdaptiveScheduler,
                                        schedulers.IdentityScheduler)):
        return f"lr_schedule {agent.config.get('lr_schedule')} (adaptive and constant are " \
            "run on the device)"
    if isinstance(agent.scheduler, schedulers.AdaptiveScheduler) and \
            agent.schedule_type != "legacy":
        return f"schedule_type {agent.schedule_type} (legacy, per minibatch, is run on the device)"
    return None


def critic_loss_kept_on_device(critic) -> None:
    """rl_games' asymmetric critic (`CentralValueTrain`) reads every minibatch's loss to the host
    (`loss.item()`), only to average it for TensorBoard: the same step, its loss left on the
    device (the summary writer reads the average once per epoch)."""
    def train_critic(minibatch):
        critic.train()
        return critic.calc_gradients(minibatch).detach()
    critic.train_critic = train_critic


class MinibatchStep:
    """Called in place of `A2CAgent.train_actor_critic` with one minibatch (rl_games' dataset
    item); returns what that returns. `capture`: on CUDA, replay the step as a CUDA graph."""

    def __init__(self, agent, capture: bool):
        self.agent = agent
        self.device = torch.device(agent.ppo_device)
        self.capture = capture and self.device.type == "cuda"
        self.adaptive = isinstance(agent.scheduler, schedulers.AdaptiveScheduler)
        # the schedule's state in float64, as rl_games' Python floats; CUDA's fused Adam reads
        # a float32 rate, a CPU's reads the float64 one as its double
        self.lr = torch.tensor(float(agent.last_lr), dtype=torch.float64, device=self.device)
        self.adam_lr = self.lr if self.device.type == "cpu" else \
            torch.tensor(float(agent.last_lr), dtype=torch.float32, device=self.device)
        # rl_games' loop then leaves the rate to us: neither of its scheduler branches runs
        agent.schedule_type = "myriad"
        self.normalizer = agent.model.running_mean_std if agent.normalize_input else None
        self.inputs: dict[str, torch.Tensor] = {}
        self.outputs: tuple = ()
        self.graph: torch.cuda.CUDAGraph | None = None
        self.eager_steps = 0

    # ---------------------------------------------------------------- the learning rate
    def set_learning_rate(self, lr: float) -> None:
        """A new rate from the host (a resumed run's)."""
        self.lr.fill_(lr)
        if self.adam_lr is not self.lr:
            self.adam_lr.fill_(lr)

    def learning_rate(self) -> float:
        """The rate now (one read: once per epoch)."""
        return float(self.lr)

    def _adapt_learning_rate(self, kl: torch.Tensor) -> None:
        """rl_games' AdaptiveScheduler.update on the device (its comparisons in float64)."""
        rule = self.agent.scheduler
        kl = kl.double()
        lower = torch.clamp(self.lr / 1.5, min=rule.min_lr)
        higher = torch.clamp(self.lr * 1.5, max=rule.max_lr)
        lr = torch.where(kl > 2.0 * rule.kl_threshold, lower, self.lr)
        self.lr.copy_(torch.where(kl < 0.5 * rule.kl_threshold, higher, lr))
        if self.adam_lr is not self.lr:
            self.adam_lr.copy_(self.lr)

    # ---------------------------------------------------------------- the step
    def _update_normalizer(self) -> None:
        """The observation normalizer's update with this minibatch, as its training-mode
        forward does it, written into the tensors it had (the graph reads those)."""
        obs = self.agent._preproc_obs(self.inputs["obs"])
        with torch.no_grad():
            in_place(self.normalizer, lambda: self.normalizer(obs))

    def _step(self) -> None:
        """What a replay runs: rl_games' gradient step on `self.inputs`, then the rate."""
        agent = self.agent
        agent.calc_gradients(self.inputs)
        a_loss, c_loss, entropy, kl, _, lr_mul, mu, sigma, b_loss = agent.train_result
        if self.adaptive:
            self._adapt_learning_rate(kl)
        self.outputs = (a_loss, c_loss, entropy, kl, lr_mul, mu, sigma, b_loss)

    def __call__(self, minibatch: dict) -> tuple:
        agent = self.agent
        agent.set_train()
        if not self.capture:
            self.inputs = {k: minibatch[k] for k in INPUTS}
        elif not self.inputs or any(minibatch[k].shape != v.shape
                                    for k, v in self.inputs.items()):
            # the first minibatch, or a new minibatch size: the graph's own inputs, a new graph
            self.inputs = {k: minibatch[k].clone() for k in INPUTS}
            self.graph, self.eager_steps = None, 0
        else:
            for k in INPUTS:
                self.inputs[k].copy_(minibatch[k])
        for group in agent.optimizer.param_groups:      # a resume's load_state_dict resets them
            group["lr"] = self.adam_lr
            group["capturable"] = self.capture
        if self.normalizer is not None and self.normalizer.training:
            self._update_normalizer()
            self.normalizer.eval()      # until the next call's set_train(), as rl_games does
        self._run()
        a_loss, c_loss, entropy, kl, lr_mul, mu, sigma, b_loss = self.outputs
        if self.graph is not None:      # a replay overwrites these: rl_games keeps the losses
            a_loss, c_loss, entropy, kl, b_loss = (
                t.clone() if isinstance(t, torch.Tensor) else t
                for t in (a_loss, c_loss, entropy, kl, b_loss))
        return a_loss, c_loss, entropy, kl, agent.last_lr, lr_mul, mu, sigma, b_loss

    def _run(self) -> None:
        if not self.capture:
            self._step()
            return
        if self.graph is not None:
            self.graph.replay()
            return
        if self.eager_steps < WARMUP_STEPS:
            # torch's rule for capturing: warm the step up on a side stream first (its
            # libraries' workspaces, autograd's state); these are real steps
            side = torch.cuda.Stream(self.device)
            side.wait_stream(torch.cuda.current_stream(self.device))
            with torch.cuda.stream(side):
                self._step()
            torch.cuda.current_stream(self.device).wait_stream(side)
            self.eager_steps += 1
            return
        graph = torch.cuda.CUDAGraph()
        # recorded, not run (the replay below runs it); thread-local: a viewer's copies on
        # another thread go on meanwhile
        with torch.cuda.graph(graph, capture_error_mode="thread_local"):
            self._step()
        self.graph = graph
        self.graph.replay()
