"""`myriad eval`: the deterministic policy (the actor's mean action) over whole episodes, scored
with the task's own success measure, as the Isaac Gym paper reports it.

    myriad eval task=ShadowHand [checkpoint=PATH num_envs=N episodes=100 seed=S judge=true
                                 output=eval.json]

What is measured, per finished episode (each a mean with a 95 % confidence interval over the
episodes):
  - every task: `episode_reward` (the undiscounted return) and `episode_length` (env steps);
  - hand tasks: `consecutive_successes`, the goals reached in a row before the episode ended (a
    drop, the time limit, or the variant's maxConsecutiveSuccesses), at the variant's own
    successTolerance and episodeLength; counted from the task's own `successes` buffer; and
    `goal_angle` (rad), the mean over the episode's steps of the cube's angle to its goal, and
    `cube_spin` (rad/s), that of the cube's angular speed (whether the policy moves it at all);
  - FrankaCubeStack, Trifinger: `success_rate`, the share of episodes that ended in the task's
    success (the flags the task counts its `success_rate` metric from; Franka also `lift_rate`);
    Trifinger also `fingertip_distance` (m), the mean over the episode's steps of the three
    fingertips' mean distance to the cube's centre (how close the fingers keep to it), and the
    cube's distance to its goal position as the episode ends (`goal_distance`, m) and how much
    nearer it ended than it started (`goal_approach`, m);
  - Anymal, AnymalTerrain, G1Velocity, G1Rough: `tracking_error_lin` (m/s, |commanded -
    actual| base-frame planar velocity) and `tracking_error_yaw` (rad/s), averaged over the
    episode's steps (as benchmarks/anymal_tracking.py measures them, but over whole episodes);
    the terrain tasks also `terrain_level`, the curriculum level each episode was played at (and
    the envs' mean level at the end), and the curriculum's verdict on it: `level_up`, the share
    of episodes whose robot left its tile (the curriculum moves it up), and `level_down`, the
    share that walked less than a quarter of their command (moved down), each also level by
    level (`by_level`); the G1 tasks also `fell`, the share of episodes that ended in a fall;
  - HumanoidAMP: `speed` (m/s, the root's straight-line horizontal distance over the episode
    per second), `fell` and `pose_error` (rad, to the nearest clip frame), not the
    discriminator's reward (`WalkProbe`).

Terrain levels (`levels=`): `restored`, the checkpoint's curriculum state (each env on the level
the training left it at; at another env count than the run's, every env on level 0), or
`spread`, every level on every kind of tile (`TerrainCurriculum.spread_levels`; with num_envs a
multiple of levels × kinds, 200, every tile equally), whose `level_up` is then the figure: what
the policy crosses, not where the training happened to stand. Under the original's curriculum a
level's robots that all cross move on and past the top start over at level 0, so a policy that
crosses everything holds a mean level of 4.5 of 10; a higher mean means robots held back below
a level they fail. From the spread's moves per level the report also gives the levels the
curriculum would hold the policy's robots at in the long run (`curriculum_levels`,
`curriculum_mean_level`: `curriculum_stationary`), the training's mean level as a property of
the policy, at any env count.

Episodes: each env contributes at most ceil(episodes / num_envs) episodes, its first ones, and
the evaluation stops once `episodes` are collected (the envs keep running meanwhile). Taking the
first episodes to finish in any env would favour short ones (early falls and drops); with
num_envs dividing episodes (the default num_envs is episodes, up to 256 on a CPU and 4096 on a
GPU) every env gives the same number and nothing is favoured.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import time

import torch

from ..torch_utils import angle_between

HAND_TASKS = ("ShadowHand", "ShadowHandOpenAI_FF", "ShadowHandOpenAI_LSTM", "AllegroHand")
SUCCESS_RATE_TASKS = ("FrankaCubeStack", "Trifinger")
TRACKING_TASKS = ("Anymal", "AnymalTerrain", "G1Velocity", "G1Rough")

# the top-level keys a judged evaluation may set: none of them changes the task
JUDGE_ALLOWED = {"task", "train", "checkpoint", "num_envs", "seed", "episodes", "judge",
                 "device", "output", "train_dir", "task.env.numEnvs", "levels"}
TERRAIN_LEVELS = ("restored", "spread")
PROGRESS_EVERY_S = 10.0

# two-sided 95 % quantiles of Student's t for 1..30 degrees of freedom
_T95 = (12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
        2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
        2.060, 2.056, 2.052, 2.048, 2.045, 2.042)


def mean_ci(values) -> dict:
    """Mean, sample standard deviation and the 95 % confidence interval of the mean (Student's
    t) of a list of per-episode values; n < 2 gives no interval (null)."""
    values = [float(v) for v in values]
    n = len(values)
    if n == 0:
        return {"mean": None, "ci95": None, "half_width": None, "std": None, "n": 0}
    mean = sum(values) / n
    if n < 2:
        return {"mean": mean, "ci95": None, "half_width": None, "std": None, "n": 1}
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))
    t = _T95[n - 2] if n - 1 <= len(_T95) else 1.96
    half = t * std / math.sqrt(n)
    return {"mean": mean, "ci95": [mean - half, mean + half], "half_width": half, "std": std,
            "n": n}


def wilson_ci(successes: int, n: int) -> list[float] | None:
    """The 95 % Wilson score interval of a success rate (sensible at 0 and 1, where the t
    interval collapses to a point)."""
    if n == 0:
        return None
    z, p = 1.96, successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return [max(0.0, centre - half), min(1.0, centre + half)]


class ConsecutiveSuccesses:
    """Goals reached in a row per env: `update(reached, done)` adds this step's goals and
    returns every env's count as of the end of the step (read it for the `done` envs: their
    episode's count), then restarts the envs that `done` marks."""

    def __init__(self, num_envs: int, device="cpu"):
        self.count = torch.zeros(num_envs, device=device)

    def update(self, reached: torch.Tensor, done: torch.Tensor) -> torch.Tensor:
        self.count += reached.float()
        ended = self.count.clone()
        self.count.masked_fill_(done.bool(), 0.0)
        return ended


def consecutive_successes(reached, done) -> list[float]:
    """The count of each episode that ends in a scripted sequence of [T, N] (or [T]) goal and
    episode-end flags, in the order the episodes end (env order within a step)."""
    reached, done = torch.as_tensor(reached), torch.as_tensor(done).bool()
    if reached.dim() == 1:
        reached, done = reached[:, None], done[:, None]
    counter, out = ConsecutiveSuccesses(reached.shape[1]), []
    for r, d in zip(reached, done):
        out += counter.update(r, d)[d].tolist()
    return out


class EpisodeCollector:
    """Per-episode values of finished episodes: the return and length of each, and what a probe
    measures at its end. Each env gives at most `quota` (= ceil(episodes / num_envs)) episodes,
    its first; with more envs than episodes only the first `episodes` envs count (the first
    episodes to end would be the short ones, falls: AnymalTerrain's 100 of 512 envs were played
    a level higher than the 512's mean); `full` once `episodes` are collected."""

    def __init__(self, num_envs: int, episodes: int, device="cpu"):
        self.episodes = episodes
        self.quota = math.ceil(episodes / num_envs)
        self.counted = torch.arange(num_envs, device=device) < episodes
        self.returns = torch.zeros(num_envs, dtype=torch.float64, device=device)
        self.lengths = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.taken = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.values: dict[str, list[float]] = {"episode_reward": [], "episode_length": []}

    @property
    def collected(self) -> int:
        return len(self.values["episode_reward"])

    @property
    def full(self) -> bool:
        return self.collected >= self.episodes

    def add(self, rewards: torch.Tensor, done: torch.Tensor, measures: dict | None = None) -> int:
        """One env step: `rewards` [N], `done` [N] and, for the finished envs, `measures` (name
        -> [N] values, read where `done`). Returns the episodes taken in this step."""
        self.returns += rewards.to(self.returns.dtype)
        self.lengths += 1
        done = done.bool()
        if not bool(done.any()):
            return 0
        ids = torch.nonzero(done & (self.taken < self.quota) & self.counted).flatten()
        ids = ids[:max(0, self.episodes - self.collected)]
        self.taken[done] += 1
        for name, column in (("episode_reward", self.returns), ("episode_length", self.lengths),
                             *(measures or {}).items()):
            self.values.setdefault(name, []).extend(column[ids].double().tolist())
        self.returns.masked_fill_(done, 0.0)
        self.lengths.masked_fill_(done, 0)
        return len(ids)


# ------------------------------------------------------------------ what each task reports
class Probe:
    """What a task family measures per episode beyond the return: `before_step`, then
    `after_step(done)` -> {name: [N] values at the end of the finishing envs' episodes}."""
    primary = "episode_reward"

    def __init__(self, task):
        self.task = task

    def reset(self) -> dict:
        """The first reset of every env, before any episode is counted."""
        return self.task.reset()

    def before_step(self) -> None:
        pass

    def after_step(self, done: torch.Tensor) -> dict:
        return {}

    def describe(self) -> dict:
        """Task settings the figure depends on."""
        env = self.task.cfg["env"]
        return {k: env[k] for k in ("episodeLength", "episodeLength_s") if k in env} | {
            "max_episode_length": int(self.task.max_episode_length)}

    def extra(self, values: dict[str, list[float]]) -> dict:
        """What the report adds from the episodes' `values`."""
        return {}


class EpisodeMeans:
    """Per env, the mean over its episode's steps of per-step values (a probe's errors and
    distances). A finished env's state is already its next episode's, so the step that ends
    an episode does not count."""

    def __init__(self, num_envs: int, device, *names: str):
        self.steps = torch.zeros(num_envs, dtype=torch.float64, device=device)
        self.sums = {name: torch.zeros_like(self.steps) for name in names}

    def add(self, done: torch.Tensor, **values: torch.Tensor) -> tuple[dict, torch.Tensor]:
        """Count one step of `values` ([N] each); returns ({name: [N] means so far}, [N] steps
        counted, at least 1) and starts the finished envs' (`done`) next episodes."""
        live = (~done).double()
        self.steps += live
        for name, value in values.items():
            self.sums[name] += live * value.double()
        steps = self.steps.clamp(min=1.0)
        means = {name: total / steps for name, total in self.sums.items()}
        for buf in (self.steps, *self.sums.values()):
            buf.masked_fill_(done, 0.0)
        return means, steps


class HandProbe(Probe):
    """Consecutive successes from the task's `successes` count as the task records it at the
    end of each step's episodes (`episode_outcomes`, before its resets zero it), and per episode
    the mean over its steps of the cube's angle to its goal (`goal_angle`, rad): how far a
    policy that reaches no goal within the tolerance still turns the cube towards them, and
    of its angular speed (`cube_spin`, rad/s): whether it turns the cube at all, or holds it
    still."""
    primary = "consecutive_successes"

    def __init__(self, task):
        super().__init__(task)
        self.counter = ConsecutiveSuccesses(task.num_envs, task.device)
        self.before = task.successes.clone()
        self.means = EpisodeMeans(task.num_envs, task.device, "goal_angle", "cube_spin")

    def reset(self):
        out = super().reset()
        self.before = self.task.successes.clone()   # the reset drew new goals: count from here
        return out

    def after_step(self, done):
        reached = (self.task.episode_outcomes["successes"] - self.before).clamp(min=0.0)
        self.before = self.task.successes.clone()
        cube = self.task.envs.root_states[:, self.task.cube]
        angle = angle_between(cube[:, 3:7], self.task.goal_rot)
        means, _ = self.means.add(done, goal_angle=angle, cube_spin=cube[:, 10:13].norm(dim=-1))
        return {"consecutive_successes": self.counter.update(reached, done)} | means

    def describe(self):
        env = self.task.cfg["env"]
        return super().describe() | {k: env.get(k) for k in (
            "successTolerance", "maxConsecutiveSuccesses", "fallDistance")}


class ShareProbe(Probe):
    """Success (and Franka's lift) flags of finishing episodes, as the task records them
    (`episode_outcomes`) for its `success_rate` metric."""
    primary = "success_rate"

    def after_step(self, done):
        return {name: flag.float() for name, flag in self.task.episode_outcomes.items()}

    def describe(self):
        env = self.task.cfg["env"]
        return super().describe() | {k: v for k, v in env.items() if "Tolerance" in k}


class TrifingerProbe(ShareProbe):
    """Trifinger's success flags; per episode the mean over its steps of the fingertips' mean
    distance to the cube's centre (`fingertip_distance`, m); the cube's distance to its goal
    position as the episode ends (`goal_distance`, m: the success's 2 cm test, as a distance),
    and how much nearer the goal than it started (`goal_approach`, m)."""

    def __init__(self, task):
        super().__init__(task)
        self.means = EpisodeMeans(task.num_envs, task.device, "fingertip_distance")
        self.start = None

    def _cube_goal_distance(self):
        cube = self.task.envs.root_states[:, self.task.cube, 0:3]
        return torch.norm(cube - self.task.goal_pos, dim=-1)

    def reset(self):
        out = super().reset()
        self.start = self._cube_goal_distance()
        return out

    def after_step(self, done):
        e = self.task.envs
        tips = e.rigid_body_states[:, self.task.fingertips, 0:3]
        cube = e.root_states[:, self.task.cube, None, 0:3]
        means, _ = self.means.add(done, fingertip_distance=torch.norm(tips - cube, dim=-1)
                                  .mean(-1))
        final = self.task.goal_distance             # before the finished envs' resets
        ends = {"goal_distance": final, "goal_approach": self.start - final}
        # a finished env's state is already its next episode's start
        self.start = torch.where(done, self._cube_goal_distance(), self.start)
        return super().after_step(done) | means | ends


def base_velocity(task) -> torch.Tensor:
    """[N, 3]: each env's base forward and lateral velocity (m/s) and yaw rate (rad/s), in the
    base's own frame: what a velocity command (`task.commands`) asks of it."""
    from ..torch_utils import quat_rotate_inverse

    root = task.envs.root_states[:, 0]
    lin = quat_rotate_inverse(root[:, 3:7], root[:, 7:10])
    ang = quat_rotate_inverse(root[:, 3:7], root[:, 10:13])
    return torch.stack((lin[:, 0], lin[:, 1], ang[:, 2]), dim=-1)


def command_tracking(task, advance, seconds: float) -> str:
    """Steps `task` for `seconds` with `advance()` (one env step of the policy under test;
    returns (dones, time_outs)) from fresh episodes, and says how well it tracked its commands:
    the mean |command - actual| per axis (`base_velocity`) over the second half, next to what
    standing still would score, and the share of episodes (running at the start or begun since)
    that ended in a fall."""
    steps = round(seconds / task.dt)
    errors, still, falls, episodes = [], [], 0, task.num_envs
    for step in range(steps):
        with torch.no_grad():
            dones, time_outs = advance()
        falls += int((dones.bool() & ~time_outs.bool()).sum())
        episodes += int(dones.bool().sum())
        if step >= steps // 2:
            errors.append((task.commands - base_velocity(task)).abs())
            still.append(task.commands.abs())
    err, base = torch.cat(errors).mean(0), torch.cat(still).mean(0)
    return (f"mean |command - actual| forward {err[0]:.3f} m/s, lateral {err[1]:.3f} m/s, "
            f"yaw {err[2]:.3f} rad/s (standing still: {base[0]:.3f}, {base[1]:.3f}, "
            f"{base[2]:.3f}); episodes ended by a fall: {falls} of {episodes} "
            f"({100 * falls / episodes:.1f} %)")


class TrackingProbe(Probe):
    """Mean |commanded - actual| base velocity over each episode's steps (base frame: planar
    velocity norm, yaw rate); the terrain tasks: also the level each episode was played at and
    the curriculum's verdict on it (`level_up`, `level_down`), the primary figure the mean level
    (`levels="restored"`) or the share of episodes that crossed their tile (`"spread"`)."""
    primary = "tracking_error_lin"

    def __init__(self, task, levels: str = "restored"):
        super().__init__(task)
        self.means = EpisodeMeans(task.num_envs, task.device, "tracking_error_lin",
                                  "tracking_error_yaw")
        self.terrain = hasattr(task, "levels")
        self.level_mode = levels
        if self.terrain:
            self.primary = "level_up" if levels == "spread" else "terrain_level"
            self.levels = task.levels.clone()

    def reset(self):
        # the curriculum moves an env's level when its episode ends; the first reset ends none
        moving = getattr(self.task, "move_levels", False)
        if self.terrain:
            self.task.move_levels = False
        try:
            return super().reset()
        finally:
            if self.terrain:
                self.task.move_levels = moving

    def before_step(self):
        if self.terrain:
            self.levels = self.task.levels.clone()

    def after_step(self, done):
        actual = base_velocity(self.task)
        cmd = self.task.commands
        out, _ = self.means.add(done, tracking_error_lin=torch.norm(cmd[:, :2] - actual[:, :2],
                                                                    dim=-1),
                                tracking_error_yaw=(cmd[:, 2] - actual[:, 2]).abs())
        if self.terrain:
            out["terrain_level"] = self.levels.double()
        out |= {name: flag.double() for name, flag in self.task.episode_outcomes.items()}
        return out

    def extra(self, values):
        if not self.terrain:
            return {}
        played = torch.tensor(values.get("terrain_level", []), dtype=torch.long)
        columns = {name: torch.tensor(values[name], dtype=torch.float64)
                   for name in ("level_up", "level_down", "tracking_error_lin") if name in values}
        by_level = {}
        for level in played.unique().tolist():
            at = played == level
            by_level[str(level)] = {"episodes": int(at.sum())} | {
                name: float(column[at].mean()) for name, column in columns.items()}
        out = {"levels": self.level_mode,
               "final_mean_terrain_level": float(self.task.levels.float().mean()),
               "by_level": by_level}
        n_levels = self.task.terrain_config.levels
        if len(by_level) == n_levels and "level_up" in values:
            moves = columns["level_up"] - columns["level_down"]
            share = curriculum_stationary(played, moves, n_levels)
            out["curriculum_levels"] = share.tolist()
            out["curriculum_mean_level"] = float((share * torch.arange(n_levels)).sum())
        return out


def curriculum_stationary(levels: torch.Tensor, moves: torch.Tensor, n_levels: int,
                          episodes: int = 10_000) -> torch.Tensor:
    """[n_levels]: the share of robots on each level that the curriculum holds in the long run,
    for a policy whose episodes played at `levels` [E] moved (+1 up, -1 down, 0 stay) as
    `moves` [E] (every level played). The chain's step from level l takes that level's shares
    of moves (down floored at 0, up from the top to 0: `next_levels`); robots start at level 0,
    as in training, and the shares are averaged over `episodes` episodes after as many more
    (an average, since a policy that always climbs cycles through the levels without
    settling). Kinds of tile are pooled per level, as the training's envs (each on one kind)
    are."""
    step = torch.zeros(n_levels, n_levels, dtype=torch.float64)
    for level in range(n_levels):
        at = moves[levels == level].double()
        step[level, (level + 1) % n_levels] += (at > 0).double().mean()
        step[level, max(level - 1, 0)] += (at < 0).double().mean()
        step[level, level] += (at == 0).double().mean()
    share = torch.zeros(n_levels, dtype=torch.float64)
    share[0] = 1.0
    total = torch.zeros_like(share)
    for episode in range(2 * episodes):
        if episode >= episodes:
            total += share
        share = share @ step
    return total / episodes


class WalkProbe(Probe):
    """HumanoidAMP: how far and how steadily the policy walks, and how close its poses stay to
    the clips'. Per episode: `speed` (m/s), the root's straight-line horizontal distance from
    the episode's first state to its last over the time between; `fell`, 1 when the episode
    ended by the task's fall (a body other than the feet on the ground), not its time limit;
    `pose_error` (rad), over the episode's steps the mean |q - q_clip| over the DoFs to the
    clip frame nearest the pose (3-DoF joints as their exponential-map coordinates)."""
    primary = "speed"

    def __init__(self, task):
        super().__init__(task)
        n, dev, motion = task.num_envs, task.device, task.motion
        poses = []
        for clip, frames in enumerate(motion.num_frames.tolist()):
            ids = torch.full((frames,), clip, device=dev)
            poses.append(motion.state(ids, torch.arange(frames, device=dev) * motion.dt[clip])
                         .dof_pos)
        self.clip_poses = torch.cat(poses)                        # [frames, dofs]
        self.start = torch.zeros(n, 2, device=dev)
        self.last = torch.zeros(n, 2, device=dev)
        self.means = EpisodeMeans(n, dev, "pose_error")

    def _xy(self):
        return self.task.envs.root_states[:, 0, :2].clone()

    def reset(self):
        out = super().reset()
        self.start, self.last = self._xy(), self._xy()
        return out

    def after_step(self, done):
        xy, live = self._xy(), ~done
        # a finished env's state is already its next episode's: its last live state stands
        self.last = torch.where(live[:, None], xy, self.last)
        q = self.task.envs.dof_pos
        nearest = torch.cdist(q, self.clip_poses).argmin(dim=1)
        means, steps = self.means.add(done, pose_error=(q - self.clip_poses[nearest]).abs()
                                      .mean(dim=1))
        out = {"speed": torch.norm(self.last - self.start, dim=1).double() / (steps * self.task.dt),
               "fell": self.task.episode_outcomes["fell"].double()} | means
        self.start = torch.where(done[:, None], xy, self.start)
        self.last = torch.where(done[:, None], xy, self.last)
        return out


def probe_for(name: str, task, levels: str = "restored") -> Probe:
    if name == "HumanoidAMP":
        return WalkProbe(task)
    if name in HAND_TASKS:
        return HandProbe(task)
    if name == "Trifinger":
        return TrifingerProbe(task)
    if name in SUCCESS_RATE_TASKS:
        return ShareProbe(task)
    if name in TRACKING_TASKS:
        return TrackingProbe(task, levels)
    return Probe(task)


# ------------------------------------------------------------------ the loop
def run_episodes(task, policy, episodes: int, probe: Probe | None = None, report=None,
                 report_every_s: float = PROGRESS_EVERY_S) -> dict:
    """Step `task` under `policy(obs, new_episode)` until `episodes` episodes are collected (or
    Ctrl-C: `partial` true). Returns the collector's per-episode values, the env steps and the
    wall time."""
    probe = probe or Probe(task)
    collector = EpisodeCollector(task.num_envs, episodes, task.device)
    obs, done, steps, partial = probe.reset()["obs"], None, 0, False
    started = last_report = time.monotonic()
    try:
        while not collector.full:
            probe.before_step()
            with torch.no_grad():
                out, rewards, resets, _ = task.step(policy(obs, done))
            obs, done = out["obs"], resets.bool().clone()
            steps += 1
            collector.add(rewards, done, probe.after_step(done))
            now = time.monotonic()
            if report is not None and now - last_report >= report_every_s:
                last_report = now
                report(f"  {collector.collected}/{episodes} episodes ({steps:,} steps, "
                       f"{now - started:.0f} s)")
    except KeyboardInterrupt:
        partial = True
    return {"values": collector.values, "episodes": collector.collected, "steps": steps,
            "env_steps": steps * task.num_envs, "wall_s": time.monotonic() - started,
            "partial": partial}


def summarize(values: dict[str, list[float]]) -> dict:
    results = {name: mean_ci(v) for name, v in values.items()}
    for name in ("success_rate", "lift_rate", "level_up", "level_down"):
        if name in values and values[name]:
            results[name]["wilson95"] = wilson_ci(round(sum(values[name])), len(values[name]))
    return results


# ------------------------------------------------------------------ the command
def check_judged(overrides: list[str]) -> None:
    """judge=true: refuse every override that changes the task (anything but JUDGE_ALLOWED)."""
    from .run import given_keys

    changed = sorted(k for k in given_keys(overrides) if k not in JUDGE_ALLOWED
                     and not k.startswith("train.") and not k.startswith("hydra."))
    if changed:
        shown = ", ".join(next(o for o in overrides if o.split("=", 1)[0].lstrip("+~") == k)
                          for k in changed)
        raise ValueError(f"judge=true: {shown} would change the task (its success tolerance, "
                         "episode length, randomization ... as configured are what a judged "
                         "figure means); only num_envs=, seed=, episodes=, checkpoint=, "
                         "device=, output=, levels= may be given")


def checkpoint_task(checkpoint: str) -> str | None:
    """The task of the run that wrote `checkpoint` (`<run>/nn/x.pth` with `<run>/summary.json`),
    or None where that is not known."""
    folder = os.path.dirname(os.path.abspath(checkpoint))
    if os.path.basename(folder) != "nn":
        return None
    try:
        with open(os.path.join(os.path.dirname(folder), "summary.json")) as f:
            return json.load(f).get("task")
    except (OSError, ValueError):
        return None


def evaluate(overrides: list[str]) -> int:
    """`myriad eval task=<T> [checkpoint=PATH num_envs=N episodes=K seed=S judge=true
    output=FILE.json]`."""
    from ..tasks import TASKS, config_int
    from . import run, shipped
    from .policy import load_network, policy_from_network, read_checkpoint, restore_task_state
    from .agent import atomic_json
    from .train import seed_all

    cfg = run.compose(overrides)
    if not isinstance(cfg.judge, bool):
        raise ValueError(f"judge={cfg.judge}: true or false")
    if cfg.judge:
        check_judged(overrides)
    episodes = config_int(cfg.episodes, "episodes", minimum=1)
    if cfg.levels not in TERRAIN_LEVELS:
        raise ValueError(f"levels={cfg.levels}: one of {', '.join(TERRAIN_LEVELS)}")
    if cfg.output is not None and not str(cfg.output).endswith(".json"):
        raise ValueError(f"output={cfg.output}: the file name must end in .json")
    device = run.resolve_device(cfg.device)
    if cfg.num_envs is None:
        cfg.num_envs = min(episodes, 4096 if device.startswith("cuda") else 256)
    with contextlib.redirect_stdout(io.StringIO()):       # minibatch adjustments: not ours
        task_cfg, train_cfg, _ = run.task_and_train_configs(cfg, overrides)
    # the train config's network or its CPU profile's: the weights pick the one they fit
    train_cfgs = run.network_choices(cfg, overrides, train_cfg)
    cfg.seed = config_int(cfg.seed, "seed")
    name = task_cfg["name"]
    checkpoint = run.policy_checkpoint(cfg, name)
    state = read_checkpoint(checkpoint)          # missing or unreadable: a one-line error
    written_by = checkpoint_task(checkpoint)
    if written_by is not None and written_by != name:
        raise ValueError(f"checkpoint {checkpoint} was written by a {written_by} run (its "
                         f"summary.json), not {name}: give task={written_by} or a {name} "
                         "checkpoint")
    output = str(cfg.output or run.output_beside(checkpoint, cfg.train_dir,
                                                  f"{name}_eval.json" if
                                                  shipped.is_shipped(checkpoint) else
                                                  "eval.json"))

    seed = int(cfg.seed)
    seed_all(seed)
    task = TASKS[name](task_cfg, device=device)
    restored = restore_task_state(task, state)
    if cfg.levels == "spread":
        if not hasattr(task, "spread_levels"):
            raise ValueError(f"levels=spread: {name} has no terrain levels (AnymalTerrain and "
                             "G1Rough have)")
        task.spread_levels()
    network, _ = load_network(state, train_cfgs, task.num_obs, task.num_actions, name,
                              checkpoint)
    policy = policy_from_network(network, task)
    probe = probe_for(name, task, cfg.levels)
    print(f"evaluating {checkpoint} on {name}: {episodes} episodes, {task.num_envs} envs on "
          f"{device}, seed {seed}" + (", judged" if cfg.judge else ""), flush=True)
    measured = run_episodes(task, policy, episodes, probe,
                            report=lambda line: print(line, flush=True))
    results = summarize(measured["values"])
    report = {
        "task": name, "checkpoint": os.path.abspath(checkpoint), "epoch": state.get("epoch"),
        "primary": probe.primary, "results": results,
        "episodes": measured["episodes"], "episodes_requested": episodes,
        "partial": measured["partial"], "judge": bool(cfg.judge),
        "num_envs": task.num_envs, "seed": seed, "device": device,
        "env_steps": measured["env_steps"], "wall_s": round(measured["wall_s"], 2),
        "task_settings": probe.describe(), "task_state_from_checkpoint": restored,
        **probe.extra(measured["values"]),
        "overrides": list(overrides),
        "deterministic": "the actor's mean action, clamped to [-1, 1]"}
    os.makedirs(os.path.dirname(os.path.abspath(output)), exist_ok=True)
    atomic_json(output, report)
    if report.get("by_level"):
        print("by level (episodes, level_up, level_down): " + ", ".join(
            f"{level}: {r['episodes']}, {r.get('level_up', 0):.2f}, {r.get('level_down', 0):.2f}"
            for level, r in report["by_level"].items()), flush=True)
    if "curriculum_mean_level" in report:
        print(f"the curriculum would hold this policy's robots at a mean level of "
              f"{report['curriculum_mean_level']:.2f} (levels 0..: " + ", ".join(
                  f"{share:.2f}" for share in report["curriculum_levels"]) + ")", flush=True)
    print(format_line(report) + f"; wrote {output}", flush=True)
    return 130 if measured["partial"] else 0


def format_line(report: dict) -> str:
    def shown(name):
        r = report["results"].get(name)
        if not r or r["mean"] is None:
            return f"{name}: no episode finished"
        ci = "" if r["ci95"] is None else f" ± {r['half_width']:.3g}"
        return f"{name} {r['mean']:.4g}{ci}"
    names = [report["primary"]] + [n for n in report["results"] if n != report["primary"]]
    head = ("interrupted: partial result, " if report["partial"] else "") + \
        f"{report['episodes']} episodes"
    return head + ": " + ", ".join(shown(n) for n in names) + " (95 % CI)"
