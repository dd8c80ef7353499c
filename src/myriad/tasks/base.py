"""`VecTask`: the batched RL environment every task derives from (the original's semantics).

One `step(actions)`:
  1. clip the actions to ±clipActions; `pre_physics_step(actions)` turns them into inputs
  2. `controlFrequencyInv` physics steps, each after `apply_control()` (a control law that runs
     at the physics rate: AnymalTerrain's PD torques)
  3. `progress_buf += 1`; `post_physics_step()` computes observations, rewards and terminations
  4. envs that terminated or reached `episodeLength` steps are reset (`reset_idx`), and their
     observations recomputed, so the returned observation of a finished env is the first of its
     next episode (rl_games' convention); `extras["time_outs"]` marks episodes cut by the time
     limit, apart from terminations. The reset is masked: every env's reset values are drawn
     and only the finished envs' kept, so that no step waits to learn from the device which
     envs finished (the whole step, physics and task code, could run as one CUDA graph). On a
     CPU, where asking costs nothing, steps in which no env finished skip it
     (`skip_idle_resets`). With `keep_final_obs` set, `extras["final_obs"]` holds the
     observation dict of every env as it was before the reset (what gymnasium calls the final
     observation of a finished episode)
  5. returns `({"obs": clipped observations[, "states": ...]}, rewards, resets, extras)`

A NaN or infinite action is never passed on: its env steps with a zero action, gets reward 0,
is reset, and is counted in `nonfinite_action_count` (the trainer warns and reports the count).

All buffers live on the simulation device. The original resets finished envs one step late
(their state is written at the start of the next step); here the reset happens in the same step.
"""

from __future__ import annotations

import math
import operator

import gymnasium as gym
import mujoco
import numpy as np
import torch

from ..physics import SimParams
from ..torch_utils import env_mask


# a task's `sim.physx` keys -> SimParams fields: the original's, Myriad's own two, and the
# body speed cap the original sets as an asset option (AssetOptions.max_angular_velocity)
PHYSX_KEYS = {"num_position_iterations": "position_iterations",
              "num_velocity_iterations": "velocity_iterations",
              "contact_offset": "contact_offset", "rest_offset": "rest_offset",
              "bounce_threshold_velocity": "bounce_threshold_velocity",
              "max_depenetration_velocity": "max_depenetration_velocity",
              "contacts_per_env": "contacts_per_env",
              "limit_block_contacts": "limit_block_contacts",
              "max_angular_velocity": "max_angular_velocity"}


def sim_params(sim_cfg: dict) -> SimParams:
    """SimParams from a task's `sim` section (the original's keys, PhysX settings under physx)."""
    physx = dict(sim_cfg.get("physx", {}))
    solver = {0: "pgs", 1: "tgs"}[int(physx.pop("solver_type", 1))]
    keys = PHYSX_KEYS
    unknown = sorted(set(physx) - set(keys))
    if unknown:
        raise KeyError(f"sim.physx: unknown keys {unknown}; valid: {sorted(keys) + ['solver_type']}")
    values = {keys[k]: v for k, v in physx.items()}
    if "max_depenetration_velocity" in values:     # PhysX's one cap: contacts and joints
        values["max_correction_velocity"] = values["max_depenetration_velocity"]
    return SimParams(dt=float(sim_cfg["dt"]), substeps=int(sim_cfg.get("substeps", 1)),
                     gravity=tuple(sim_cfg.get("gravity", (0.0, 0.0, -9.81))), solver=solver,
                     filter_ancestors=1, **values)     # PhysX filters the parent alone


def box_spec(name: str, size, density: float = 1000.0, rgba=(0.6, 0.6, 0.6, 1.0)) -> mujoco.MjSpec:
    """One box body (size: full edge lengths, m; density kg/m³) as an actor's model: free, or
    fixed with `Scene.add_actor(fix_base=True)` (a cube to handle, a table)."""
    spec = mujoco.MjSpec()
    spec.worldbody.add_body(name=name).add_geom(
        name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=[s / 2 for s in size], density=density,
        rgba=list(rgba))
    return spec


class EpisodeShares:
    """Shares of finished episodes that ended with each named flag (a task's `success_rate`),
    over windows of at least `window` episodes: counted over fewer, the shares lean to the
    episodes that end early (a 30-minute FrankaCubeStack run read success_rate 1.0 from single
    early-stacked episodes between two time-out waves). `read()` gives the last full window's
    shares. Counting stays on the device; only `read` syncs."""

    def __init__(self, names: tuple, window: int, device):
        self.window = window
        self.finished = torch.zeros((), device=device)
        self.counts = {name: torch.zeros((), device=device) for name in names}
        self.shown = {name: 0.0 for name in names}

    def count(self, done: torch.Tensor, **flags: torch.Tensor) -> None:
        """Add the episodes that `done` [N] ends, and those of them with each flag [N]."""
        self.finished += done.sum()
        for name, flag in flags.items():
            self.counts[name] += (done & flag).sum()

    def read(self) -> dict[str, float]:
        finished = float(self.finished)
        if finished >= self.window:
            self.shown = {name: float(c) / finished for name, c in self.counts.items()}
            self.finished.zero_()
            for c in self.counts.values():
                c.zero_()
        return dict(self.shown)


class VecTask:
    num_obs: int
    num_actions: int
    num_states: int = 0

    def __init__(self, cfg: dict, device: str = "cpu"):
        self.cfg = cfg
        env = cfg["env"]
        self.device = torch.device(device)
        from . import config_float, config_int  # here: myriad.tasks imports this module

        self.num_envs = config_int(env["numEnvs"], "env.numEnvs", minimum=1)
        self.max_episode_length = config_int(env["episodeLength"], "env.episodeLength", minimum=1)
        self.control_freq_inv = config_int(env.get("controlFrequencyInv", 1),
                                           "env.controlFrequencyInv", minimum=1)
        self.clip_obs = config_float(env.get("clipObservations", math.inf), "env.clipObservations")
        self.clip_actions = config_float(env.get("clipActions", 1.0), "env.clipActions")
        self.sim_params = sim_params(cfg["sim"])
        self.dt = self.sim_params.dt * self.control_freq_inv     # one env step, seconds

        self.envs = self.create_envs()
        caps = self.dof_speed_limits()
        if caps is not None:
            self.envs.sim.dof_max_velocity[:, self.envs.dof_columns] = torch.as_tensor(
                caps, dtype=torch.float32, device=self.device)
        self.randomizer = None
        if cfg.get("randomization", {}).get("enabled", False):
            from ..randomization import Randomizer
            self.randomizer = Randomizer(cfg["randomization"], self)
        N, dev = self.num_envs, self.device
        self.obs_buf = torch.zeros(N, self.num_obs, device=dev)
        self.states_buf = torch.zeros(N, self.num_states, device=dev)
        self.rew_buf = torch.zeros(N, device=dev)
        self.reset_buf = torch.zeros(N, dtype=torch.long, device=dev)
        self.timeout_buf = torch.zeros(N, dtype=torch.long, device=dev)
        self.progress_buf = torch.zeros(N, dtype=torch.long, device=dev)
        self.actions = torch.zeros(N, self.num_actions, device=dev)
        # env-steps whose action held a NaN or inf, per env, since the last take (on the device:
        # counting never syncs with the host)
        self.nonfinite_action_count = torch.zeros(N, dtype=torch.long, device=dev)
        # env-steps that found more contacts than the env's slots (the rest were dropped), and
        # the most contacts an env found, since the last take (`take_contact_overflow`)
        self.contact_overflow_count = torch.zeros(N, dtype=torch.long, device=dev)
        self.most_contacts = torch.zeros(N, dtype=torch.long, device=dev)
        self.extras: dict = {}
        self.obs_dict: dict = {}
        # what the episodes reached, per env, as the task records it in each step before that
        # step's resets clear it ({name: [N] tensor}; read where the step's `done` is set): the
        # success measures `myriad eval` reports (hands: goals reached in a row; Franka and
        # Trifinger: success flags). Empty for tasks judged by their return alone.
        self.episode_outcomes: dict[str, torch.Tensor] = {}
        # A masked reset in a step where no env finished changes nothing but still runs
        # forward() and the observations for every env. On a CPU, learning that no env finished
        # waits for nothing, so such steps skip it (and a task's pushes that are not due: `runs`);
        # on a GPU the step never asks.
        self.skip_idle_resets = self.device.type == "cpu"
        # On CUDA, True runs `step` as one CUDA graph: actions, physics, observations, rewards,
        # resets and the task's schedules, captured at the second call (the first runs as
        # usual: the warm-up a capture needs) and replayed after. The returned tensors are then
        # the same ones at every step, overwritten by the next (as Isaac Gym's buffers are).
        # Possible because a step reads nothing back and does the same work every time
        # (tests/test_host_sync.py), and because tasks write the buffers a step reads in place
        # (a tensor attribute replaced after the capture would not be seen). A CPU ignores it.
        self.capture_step = False
        # the live page drawing this task's envs during training (`myriad.viewer`), if any
        self.viewer = None
        self._step_graph, self._step_actions, self._step_outputs = None, None, None
        # With same-step resets the returned observation of a finished env is already the first
        # of its next episode; a consumer that bootstraps from the last one (gymnasium's
        # info["final_obs"], `myriad.make_vec`) sets this to get it in extras["final_obs"]
        self.keep_final_obs = False

        self.observation_space = gym.spaces.Box(-self.clip_obs, self.clip_obs, (self.num_obs,),
                                                np.float32)
        self.action_space = gym.spaces.Box(-1.0, 1.0, (self.num_actions,), np.float32)
        self.state_space = gym.spaces.Box(-self.clip_obs, self.clip_obs, (self.num_states,),
                                          np.float32)

    # ------------------------------------------------------------------ subclass interface
    def create_envs(self):
        """Build the scene and return `myriad.api.Envs` with `self.num_envs` envs."""
        raise NotImplementedError

    def dof_speed_limits(self) -> float | list[float] | None:
        """The DOFs' speed caps (rad/s or m/s; one value, or one per DOF of `envs.dof_names`),
        applied once after `create_envs`; None keeps the simulator's (PhysX's default, 100).
        Isaac Gym applies a URDF's velocity limits, which MuJoCo's importer drops: a task whose
        original follows them returns them here (`assets.dof_max_velocity`)."""
        return None

    def pre_physics_step(self, actions: torch.Tensor) -> None:
        raise NotImplementedError

    def apply_control(self) -> None:
        """Before each physics step of an env step: write inputs that follow the state at the
        physics rate (torques of a PD law computed in the task). Most tasks set their inputs
        once in pre_physics_step and leave this empty."""

    def post_physics_step(self) -> None:
        """Fill obs_buf, rew_buf and reset_buf (terminations; time-outs are added by step)."""
        raise NotImplementedError

    def compute_observations(self) -> None:
        raise NotImplementedError

    def reset_idx(self, env_ids: torch.Tensor) -> None:
        """Start new episodes in the envs `env_ids` names: a bool mask [N] or indices. Compute
        every env's reset values and write them under `torch_utils.env_mask(env_ids, N)`
        (torch.where, masked_fill_, the `Envs` writers given a mask): nothing here may read the
        device back."""
        raise NotImplementedError

    # ------------------------------------------------------------------ the loop
    def step(self, actions: torch.Tensor):
        if actions.shape != (self.num_envs, self.num_actions):
            raise ValueError(f"step: actions must have shape {(self.num_envs, self.num_actions)}, "
                             f"not {tuple(actions.shape)}")
        if self.capture_step and self.device.type == "cuda":
            return self._replay_step(actions)
        return self._step(actions)

    def _replay_step(self, actions: torch.Tensor):
        """`step` as one CUDA graph (`capture_step`): its input copied into the graph's own
        actions tensor, the graph replayed; the first call runs the step as usual, the second
        captures it (which runs nothing) and replays it once."""
        if self._step_actions is None:
            self._step_actions = torch.zeros(self.num_envs, self.num_actions,
                                             device=self.device)
            return self._step(actions)
        self._step_actions.copy_(actions)
        if self._step_graph is None:
            graph = torch.cuda.CUDAGraph()
            # thread-local: another thread's CUDA calls (a viewer's copies) go on meanwhile
            with torch.cuda.graph(graph, capture_error_mode="thread_local"):
                obs, rewards, resets, extras = self._step(self._step_actions)
            # the graph's own output tensors (an eager reset() puts others into obs_dict)
            self._step_outputs = dict(obs), rewards, resets, dict(extras)
            self._step_graph = graph
        self._step_graph.replay()
        obs, rewards, resets, extras = self._step_outputs
        self.obs_dict.update(obs)
        self.extras.update(extras)
        return self.obs_dict, rewards, resets, self.extras

    def _step(self, actions: torch.Tensor):
        actions = actions.to(self.device, torch.float32)
        # an env given a NaN or infinite action is counted, steps with a zero action (clipping
        # would silently turn inf into a full-scale command), gets reward 0 and is reset
        bad_action = ~torch.isfinite(actions).all(dim=1)
        self.nonfinite_action_count += bad_action.long()
        actions = torch.where(bad_action[:, None], 0.0, actions)
        dr = self.randomizer
        if dr is not None:
            actions = dr.perturb_actions(actions)
        actions = torch.clamp(actions, -self.clip_actions, self.clip_actions)
        self.pre_physics_step(actions)
        for i in range(self.control_freq_inv):
            self.apply_control()
            if dr is not None:
                dr.apply_random_forces(new_draws=i == 0)
            self.envs.step()
        self.progress_buf += 1
        found = self.envs.sim.contact_count.long()
        self.contact_overflow_count += (found > self.envs.sim.contact_capacity).long()
        torch.maximum(self.most_contacts, found, out=self.most_contacts)
        if dr is not None:
            dr.on_step()
        self.post_physics_step()
        timeout = self.timed_out()
        self.timeout_buf[:] = (timeout & (self.reset_buf == 0)).long()
        # a non-finite env (blown-up physics) ends its episode; its reward must stay finite
        broken = (self.envs.sim.nonfinite != 0) | bad_action
        self.rew_buf[:] = torch.where(torch.isfinite(self.rew_buf) & ~bad_action, self.rew_buf, 0.0)
        self.reset_buf[:] = (self.reset_buf.bool() | timeout | broken).long()
        self.extras["time_outs"] = self.timeout_buf.clone()
        done = self.reset_buf.bool()
        if self.keep_final_obs:     # every env's observation before the reset replaces some
            self.extras["final_obs"] = dict(self._obs())
        if self.runs(done):
            if dr is not None:
                dr.on_reset(done)       # new physical parameters before the new episode starts
            self.reset_idx(done)
            self.envs.sim.nonfinite.masked_fill_(done, 0)
            self.compute_observations()
        return self._obs(), self.rew_buf, self.reset_buf, self.extras

    def runs(self, due: torch.Tensor) -> bool:
        """Whether masked work of the step (resets, a task's pushes) must run, `due` a bool
        tensor of the envs it concerns or one flag: always on a GPU, where it runs masked and
        nothing is asked; on a CPU, where asking waits for nothing, only when something is due
        (`skip_idle_resets`)."""
        return not self.skip_idle_resets or bool(due.any())

    def timed_out(self) -> torch.Tensor:
        """[N] bool: the envs whose episode reaches `episodeLength` steps in this step (read after
        `progress_buf += 1`, in `post_physics_step`). `step` ends them and flags them in
        `time_outs`; a task reads this to count finished episodes, and never sets `reset_buf` for
        them, or its time-outs would read as terminations."""
        return self.progress_buf >= self.max_episode_length

    # What a checkpoint keeps of the task: the attributes (dotted names) that span episodes, the
    # schedules and curricula a resumed run must continue rather than restart. The envs
    # themselves start fresh episodes on resume.
    checkpointed: tuple[str, ...] = ()

    def _checkpointed(self) -> list[str]:
        return list(self.checkpointed) + (["randomizer.env_steps"] if self.randomizer else [])

    def training_state(self) -> dict:
        """The `checkpointed` attributes (and the randomizer's schedule), tensors on the CPU."""
        state = {}
        for name in self._checkpointed():
            value = operator.attrgetter(name)(self)
            state[name] = value.detach().cpu().clone() if torch.is_tensor(value) else value
        return state

    def load_training_state(self, state: dict) -> None:
        """Continue from `training_state()` of a run that was stopped (before its first reset)."""
        names = self._checkpointed()
        unknown = sorted(set(state) - set(names))
        if unknown:
            raise ValueError(f"{type(self).__name__}: the checkpoint's task state has {unknown}, "
                             f"which this task does not keep (it keeps {names})")
        for name, value in state.items():
            owner_name, _, attr = name.rpartition(".")
            owner = operator.attrgetter(owner_name)(self) if owner_name else self
            current = getattr(owner, attr)
            if torch.is_tensor(current):
                # a counter kept on the host by checkpoints of earlier versions
                value = torch.as_tensor(value) if isinstance(value, (int, float)) else value
                if tuple(value.shape) != tuple(current.shape):
                    raise ValueError(f"{type(self).__name__}: the checkpoint's {name} has shape "
                                     f"{tuple(value.shape)}, this task's {tuple(current.shape)} "
                                     "(a run with another num_envs?)")
                current.copy_(value)
            else:
                setattr(owner, attr, value)

    def reset(self, env_ids=None) -> dict:
        """Reset every env, or those `env_ids` names (a bool mask [N] or indices); returns the
        observation dict."""
        self.reset_idx(torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
                       if env_ids is None else env_mask(env_ids, self.num_envs))
        self.compute_observations()
        return self._obs()

    def _obs(self) -> dict:
        obs = torch.nan_to_num(self.obs_buf)
        if self.randomizer is not None:
            obs = self.randomizer.perturb_observations(obs)
        self.obs_dict["obs"] = torch.clamp(obs, -self.clip_obs, self.clip_obs)
        if self.num_states > 0:
            self.obs_dict["states"] = torch.clamp(self.states_buf, -self.clip_obs, self.clip_obs)
        return self.obs_dict

    def take_nonfinite_actions(self) -> int:
        """Env-steps with a NaN or infinite action since the last call (reads the device once)."""
        count = int(self.nonfinite_action_count.sum())
        self.nonfinite_action_count.zero_()
        return count

    def draw_robot_friction(self, friction_range, bucket_count: int) -> None:
        """The robot's friction, as the ANYmal and G1 tasks randomize it: `bucket_count` values
        drawn uniformly from `friction_range`, env i taking bucket i mod the count, on every
        geom of the robot's bodies (not the world's: the ground, a height field, a mesh)."""
        e, dev = self.envs, self.device
        lo, hi = friction_range
        buckets = torch.empty(int(bucket_count), device=dev).uniform_(lo, hi)
        robot_geoms = torch.nonzero(torch.as_tensor(e.model.geom_body) >= 0).flatten().tolist()
        e.sim.geom_friction[:, robot_geoms] = buckets[torch.arange(self.num_envs, device=dev)
                                                      % len(buckets)][:, None]

    def take_contact_overflow(self) -> tuple[int, int]:
        """(env-steps whose contacts did not all fit the env's slots, the most contacts an env
        found) since the last call; reads the device once."""
        counts = torch.stack([self.contact_overflow_count.sum(), self.most_contacts.max()])
        over, most = (int(x) for x in counts.tolist())
        self.contact_overflow_count.zero_()
        self.most_contacts.zero_()
        return over, most

    def get_number_of_agents(self) -> int:
        return 1
