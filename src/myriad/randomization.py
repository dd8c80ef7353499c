"""Domain randomization driven by the `randomization` section of a task's YAML (seed A.4.1).

    randomization:
      enabled: true
      frequency: 720                  # env steps between re-samples of an env's parameters
      observations: {range: [0, 0.002], range_correlated: [0, 0.001],
                     operation: additive, distribution: gaussian}
      actions:      {range: [0, 0.05], range_correlated: [0, 0.015],
                     operation: additive, distribution: gaussian}
      sim_params:
        gravity: {range: [0, 0.4], operation: additive, distribution: gaussian}
      actor_params:
        <actor>:
          rigid_body_properties:
            mass: {range: [0.5, 1.5], operation: scaling, distribution: uniform, setup_only: true}
          rigid_shape_properties:
            friction: {range: [0.7, 1.3], operation: scaling, distribution: uniform}
            restitution: {range: [0, 0.4], operation: additive, distribution: uniform}
          dof_properties:             # damping, stiffness (passive spring), armature, friction,
            damping: {...}            # lower, upper, drive_stiffness, drive_damping
          tendon_properties:          # stiffness, damping, limit_stiffness, lower, upper
            damping: {range: [0.3, 3.0], operation: scaling, distribution: loguniform}
        <object>:
          scale: {range: [0.95, 1.05], operation: scaling, distribution: uniform, setup_only: true}
      random_forces:                  # A.4.1, on one body of an actor
        body: object/object
        probability_range: [0.001, 0.1]   # per randomization episode, drawn log-uniformly
        scale: 1.0                    # σ of each force component = scale × body mass (m/s² × kg)
        decay: 0.99                   # the force decays by this factor ...
        decay_interval_s: 0.05        # ... every 50 ms

Distributions: `uniform` (range = [low, high]), `loguniform` ([low, high], both > 0) and
`gaussian` (range = [mean, std]). Operations: `scaling` (value = original × sample) and
`additive` (original + sample). Each parameter gets one sample per env (per DOF, body, geom or
tendon), drawn from the original value of the model, never compounded.

`scale` (per actor, `setup_only: true`, `operation: scaling`) scales a single-body actor once
at start-up: its primitive geoms' sizes and positions by s, its mass by s³ and inertia by s⁵ (the
center of mass stays where the model puts it); `Randomizer.actor_scale[actor]` holds s per env.
`setup_only: true` parameters are sampled once, when the task is built. The others are
re-sampled for envs that are being reset once at least `frequency` env steps have passed since
that env's last sample. Observation and action noise add a fresh sample every step and a
correlated sample drawn per env when its parameters are re-sampled. An optional
`schedule: linear` with `schedule_steps: S` ramps every range in from no randomization over the
first S env steps (`schedule: constant` switches it on at S).

Names follow our engine's per-env views. Where the original differs: its DOF `stiffness` and
`damping` are drive gains, here `drive_stiffness` and `drive_damping`; `num_buckets` (a PhysX
material limit) is accepted and has no effect. Everything runs batched on the simulation device; an unknown name or an impossible
range fails when the task is built, naming it.
"""

from __future__ import annotations

import math

import torch

from .torch_utils import env_mask, where_rows

DISTRIBUTIONS = ("uniform", "loguniform", "gaussian")
OPERATIONS = ("scaling", "additive")
SPEC_KEYS = {"range", "range_correlated", "operation", "distribution", "setup_only", "schedule",
             "schedule_steps", "num_buckets"}


class RandomizationError(ValueError):
    pass


def _check_spec(where: str, spec: dict, correlated_allowed: bool = False) -> dict:
    if not isinstance(spec, dict):
        raise RandomizationError(f"randomization.{where}: expected a mapping with range, "
                                 f"operation, distribution; got {spec!r}")
    unknown = sorted(set(spec) - SPEC_KEYS)
    if unknown:
        raise RandomizationError(f"randomization.{where}: unknown keys {unknown}; valid: "
                                 f"{sorted(SPEC_KEYS)}")
    dist, op = spec.get("distribution"), spec.get("operation")
    if dist not in DISTRIBUTIONS:
        raise RandomizationError(f"randomization.{where}.distribution={dist!r}; valid: "
                                 f"{DISTRIBUTIONS}")
    if op not in OPERATIONS:
        raise RandomizationError(f"randomization.{where}.operation={op!r}; valid: {OPERATIONS}")
    for key in ("range",) + (("range_correlated",) if correlated_allowed else ()):
        if key == "range_correlated" and key not in spec:
            continue
        r = spec.get(key)
        if not (isinstance(r, (list, tuple)) and len(r) == 2
                and all(isinstance(v, (int, float)) and math.isfinite(v) for v in r)):
            raise RandomizationError(f"randomization.{where}.{key}={r!r}: must be two numbers")
        lo, hi = r
        if dist == "gaussian" and hi < 0:
            raise RandomizationError(f"randomization.{where}.{key}={list(r)}: a gaussian range "
                                     "is [mean, std] and std must be >= 0")
        if dist in ("uniform", "loguniform") and lo > hi:
            raise RandomizationError(f"randomization.{where}.{key}={list(r)}: low > high")
        if dist == "loguniform" and lo <= 0:
            raise RandomizationError(f"randomization.{where}.{key}={list(r)}: loguniform needs "
                                     "low > 0")
    if "range_correlated" in spec and not correlated_allowed:
        raise RandomizationError(f"randomization.{where}: range_correlated applies to "
                                 "observations and actions only")
    schedule = spec.get("schedule")
    if schedule not in (None, "linear", "constant"):
        raise RandomizationError(f"randomization.{where}.schedule={schedule!r}; valid: linear, "
                                 "constant")
    if schedule and not (isinstance(spec.get("schedule_steps"), int) and spec["schedule_steps"] > 0):
        raise RandomizationError(f"randomization.{where}: schedule {schedule!r} needs "
                                 "schedule_steps > 0")
    return spec


def sample(spec: dict, shape, device, key: str = "range", ramp: float = 1.0) -> torch.Tensor:
    """Samples of a parameter spec; `ramp` in [0, 1] shrinks the range toward no change."""
    lo, hi = (float(v) for v in spec[key])
    identity = 0.0 if spec["operation"] == "additive" else 1.0
    if spec["distribution"] == "gaussian":           # range = [mean, std]
        mean = identity + (lo - identity) * ramp
        return torch.randn(shape, device=device) * (hi * ramp) + mean
    lo, hi = identity + (lo - identity) * ramp, identity + (hi - identity) * ramp
    if spec["distribution"] == "uniform" or lo == hi:
        return torch.rand(shape, device=device) * (hi - lo) + lo
    return torch.exp(torch.rand(shape, device=device) * (math.log(hi) - math.log(lo))
                     + math.log(lo))


class _Param:
    """One randomized quantity: a per-env engine view, the columns it owns, its original values."""

    def __init__(self, name, view_name, view, cols, spec, inertia_view=None):
        self.name, self.view_name, self.spec = name, view_name, spec
        self.cols = cols                               # index tensor into dim 1, or None
        self.original = (view if cols is None else view[:, cols]).clone()
        self.inertia_view = inertia_view               # body mass: inertia scales along

    def write(self, sim, due, ramp):
        """New samples in the envs of the bool mask `due` [N] (drawn for every env)."""
        view = getattr(sim, self.view_name)
        base = self.original
        draw = sample(self.spec, base.shape[:2] if base.dim() >= 2 else base.shape,
                      base.device, ramp=ramp)
        while draw.dim() < base.dim():
            draw = draw.unsqueeze(-1)
        value = base + draw if self.spec["operation"] == "additive" else base * draw
        if self.view_name in ("body_mass", "body_inertia", "geom_friction", "dof_damping",
                              "dof_armature", "dof_frictionloss", "joint_stiffness",
                              "actuator_kp", "actuator_kv", "tendon_stiffness", "tendon_damping",
                              "tendon_limit_stiffness"):
            value = value.clamp_min(0.0)               # physical quantities stay non-negative
        if self.view_name == "geom_restitution":
            value = value.clamp(0.0, 1.0)
        if self.cols is None:
            view.copy_(where_rows(due, value, view))
        else:
            view[:, self.cols] = where_rows(due, value, view[:, self.cols])
        if self.inertia_view is not None:             # inertia scales with mass
            ratio = (value / self.original.clamp_min(1e-12))[..., None]
            self.inertia_view[:, self.cols] = where_rows(due, self.inertia_original * ratio,
                                                         self.inertia_view[:, self.cols])


# the keys of a task's `randomization` section
SECTION_KEYS = ("enabled", "frequency", "observations", "actions", "sim_params", "actor_params",
                "random_forces")


class Randomizer:
    """Parses and validates the `randomization` section against a built task and applies it."""

    def __init__(self, cfg: dict, task):
        self.cfg, self.task = cfg, task
        envs, sim, dev = task.envs, task.envs.sim, task.device
        unknown = sorted(set(cfg) - set(SECTION_KEYS))
        if unknown:
            raise RandomizationError(f"randomization: unknown keys {unknown}; valid: "
                                     f"{sorted(SECTION_KEYS)}")
        self.frequency = int(cfg.get("frequency", 1))
        if self.frequency < 1:
            raise RandomizationError(f"randomization.frequency={self.frequency}: must be >= 1")
        self.params: list[_Param] = []
        self.env_steps = 0
        N = task.num_envs
        self.steps_since_sample = torch.zeros(N, dtype=torch.long, device=dev)

        for name, spec in (cfg.get("sim_params") or {}).items():
            if name != "gravity":
                raise RandomizationError(f"randomization.sim_params.{name}: unknown; valid: "
                                         "['gravity']")
            self.params.append(_Param("sim_params.gravity", "gravity", sim.gravity, None,
                                      _check_spec("sim_params.gravity", spec)))
        self.actor_scale = {}
        for actor, groups in (cfg.get("actor_params") or {}).items():
            if actor not in envs.actor_names:
                raise RandomizationError(f"randomization.actor_params.{actor}: no such actor; "
                                         f"the actors are {envs.actor_names}")
            groups = dict(groups or {})
            if "scale" in groups:       # first: the other parameters start from scaled values
                self.actor_scale[actor] = self._scale_actor(actor, groups.pop("scale"))
            for group, entries in groups.items():
                self._add_actor_group(actor, group, entries or {})

        self.obs_spec = self._noise_spec("observations")
        self.action_spec = self._noise_spec("actions")
        # the per-env correlated part: an offset (additive) or a factor (scaling)
        self.obs_correlated = torch.full((N, task.num_obs), self._identity(self.obs_spec),
                                         device=dev)
        self.action_correlated = torch.full((N, task.num_actions),
                                            self._identity(self.action_spec), device=dev)

        self.forces = None
        if cfg.get("random_forces"):
            self._setup_random_forces(cfg["random_forces"])

        self.resample(torch.ones(N, dtype=torch.bool, device=dev), setup=True)

    # ------------------------------------------------------------------ parsing
    def _noise_spec(self, key):
        spec = self.cfg.get(key)
        return None if not spec else _check_spec(key, spec, correlated_allowed=True)

    def _add_actor_group(self, actor, group, entries):
        envs, sim, m = self.task.envs, self.task.envs.sim, self.task.envs.model
        dev, prefix = self.task.device, actor + "/"
        where = f"actor_params.{actor}.{group}"

        def index(values):
            return torch.as_tensor(values, dtype=torch.long, device=dev)

        bodies = envs.actor_bodies(actor)
        geoms = [g for g in range(m.ngeom) if m.geom_body[g] in bodies]
        dofs = list(range(envs.actor_dof_slices[actor].start, envs.actor_dof_slices[actor].stop))
        dof_v = envs.dof_columns[dofs]
        dof_jnt = index(m.dof_jnt[dof_v.cpu().numpy()])
        tendons = [t for t, n in enumerate(m.tendon_names) if n.startswith(prefix)]
        # the position and velocity actuators on the actor's DOFs: its scene drives, or its
        # model's own (the hands'); motors have no gains to randomize
        actor_dofs = set(dof_v.tolist())
        drive_ctrl = [a for a in range(m.nu) if int(m.actuator_dof[a]) in actor_dofs
                      and (m.actuator_kp[a] != 0 or m.actuator_kv[a] != 0)]
        targets = {
            "rigid_body_properties": {"mass": ("body_mass", index(bodies))},
            "rigid_shape_properties": {"friction": ("geom_friction", index(geoms)),
                                       "restitution": ("geom_restitution", index(geoms))},
            "dof_properties": {"damping": ("dof_damping", dof_v),
                               "armature": ("dof_armature", dof_v),
                               "friction": ("dof_frictionloss", dof_v),
                               "stiffness": ("joint_stiffness", dof_jnt),
                               "lower": ("joint_range", (dof_jnt, 0)),
                               "upper": ("joint_range", (dof_jnt, 1)),
                               "drive_stiffness": ("actuator_kp", index(drive_ctrl)),
                               "drive_damping": ("actuator_kv", index(drive_ctrl))},
            "tendon_properties": {"stiffness": ("tendon_stiffness", index(tendons)),
                                  "damping": ("tendon_damping", index(tendons)),
                                  "limit_stiffness": ("tendon_limit_stiffness", index(tendons)),
                                  "lower": ("tendon_range", (index(tendons), 0)),
                                  "upper": ("tendon_range", (index(tendons), 1))},
        }
        if group not in targets:
            raise RandomizationError(f"randomization.{where}: unknown group; valid: "
                                     f"{sorted(targets) + ['scale']}")
        for name, spec in entries.items():
            if name not in targets[group]:
                raise RandomizationError(f"randomization.{where}.{name}: unknown parameter; "
                                         f"valid: {sorted(targets[group])}")
            view_name, cols = targets[group][name]
            if name.startswith("drive_") and not drive_ctrl:
                raise RandomizationError(f"randomization.{where}.{name}: actor {actor!r} has "
                                         "no position or velocity drives")
            spec = _check_spec(f"{where}.{name}", spec)
            view = getattr(sim, view_name)
            if isinstance(cols, tuple):                 # one side of a [.., 2] range
                param = _RangeSide(f"{where}.{name}", view_name, view, cols, spec)
            else:
                param = _Param(f"{where}.{name}", view_name, view, cols, spec)
            if view_name == "body_mass":
                param.inertia_view = sim.body_inertia
                param.inertia_original = sim.body_inertia[:, cols].clone()
            self.params.append(param)

    def _scale_actor(self, actor, spec) -> torch.Tensor:
        """Object scale, once at start-up: every geom's size and position in its body frame × s,
        the body's mass × s³ and inertia × s⁵ (uniform density). Returns s per env."""
        where = f"actor_params.{actor}.scale"
        spec = _check_spec(where, spec)
        if spec["operation"] != "scaling" or not spec.get("setup_only"):
            raise RandomizationError(f"randomization.{where}: needs operation: scaling and "
                                     "setup_only: true (an object is scaled once, at start-up)")
        sim, m = self.task.envs.sim, self.task.envs.model
        bodies = self.task.envs.actor_bodies(actor)
        if len(bodies) != 1:
            raise RandomizationError(f"randomization.{where}: only single-body actors (objects) "
                                     f"can be scaled; {actor!r} has {len(bodies)} bodies")
        geoms = [g for g in range(m.ngeom) if m.geom_body[g] == bodies[0]]
        unscalable = [m.geom_names[g] or str(g) for g in geoms if m.geom_type[g] in (0, 1, 7)]
        if unscalable:
            raise RandomizationError(f"randomization.{where}: geoms {unscalable} are planes, "
                                     "height fields or meshes, which cannot be scaled yet")
        scale = sample(spec, (self.task.num_envs,), self.task.device)
        cols = torch.as_tensor(geoms, dtype=torch.long, device=self.task.device)
        sim.geom_size[:, cols] *= scale[:, None, None]
        sim.geom_pos[:, cols] *= scale[:, None, None]
        sim.body_mass[:, bodies[0]] *= scale**3
        sim.body_inertia[:, bodies[0]] *= (scale**5)[:, None]
        return scale

    def _setup_random_forces(self, spec):
        known = {"body", "probability_range", "scale", "decay", "decay_interval_s"}
        unknown = sorted(set(spec) - known)
        if unknown:
            raise RandomizationError(f"randomization.random_forces: unknown keys {unknown}; "
                                     f"valid: {sorted(known)}")
        envs = self.task.envs
        try:
            self.force_body = envs.body_index(spec["body"])
        except KeyError as err:
            raise RandomizationError(f"randomization.random_forces.body: {err}") from None
        lo, hi = spec.get("probability_range", [0.001, 0.1])
        if not 0 < lo <= hi <= 1:
            raise RandomizationError(f"randomization.random_forces.probability_range={[lo, hi]}: "
                                     "need 0 < low <= high <= 1")
        self.force_probability_range = (float(lo), float(hi))
        self.force_scale = float(spec.get("scale", 1.0))
        decay, interval = float(spec.get("decay", 0.99)), float(spec.get("decay_interval_s", 0.05))
        if not (0 < decay <= 1 and interval > 0 and self.force_scale >= 0):
            raise RandomizationError("randomization.random_forces: need 0 < decay <= 1, "
                                     "decay_interval_s > 0 and scale >= 0")
        # applied every physics step: decay^(physics dt / interval)
        self.force_decay = decay ** (self.task.sim_params.dt / interval)
        N, dev = self.task.num_envs, self.task.device
        self.force_probability = torch.zeros(N, device=dev)
        self.forces = torch.zeros(N, 3, device=dev)

    # ------------------------------------------------------------------ applying
    def ramp(self, spec) -> float:
        schedule = spec.get("schedule")
        if not schedule:
            return 1.0
        steps = spec["schedule_steps"]
        if schedule == "constant":
            return 1.0 if self.env_steps >= steps else 0.0
        return min(self.env_steps, steps) / steps

    def resample(self, env_ids: torch.Tensor, setup: bool = False) -> None:
        """New parameter samples for the envs `env_ids` names, a bool mask [N] or indices
        (setup: also the setup_only parameters). Samples are drawn for every env and kept in
        the named ones: nothing is read back from the device."""
        due, sim = env_mask(env_ids, self.task.num_envs), self.task.envs.sim
        for param in self.params:
            if param.spec.get("setup_only") and not setup:
                continue
            param.write(sim, due, self.ramp(param.spec))
        for spec, buf in ((self.obs_spec, self.obs_correlated),
                          (self.action_spec, self.action_correlated)):
            if spec is not None and "range_correlated" in spec:
                buf.copy_(where_rows(due, sample(spec, buf.shape, buf.device, "range_correlated",
                                                 self.ramp(spec)), buf))
        if self.forces is not None:
            lo, hi = self.force_probability_range
            drawn = torch.exp(torch.rand(self.task.num_envs, device=self.task.device)
                              * (math.log(hi) - math.log(lo)) + math.log(lo))
            self.force_probability.copy_(torch.where(due, drawn, self.force_probability))
        self.steps_since_sample.masked_fill_(due, 0)

    def on_step(self) -> None:
        """Count one env step for every env."""
        self.env_steps += self.task.num_envs
        self.steps_since_sample += 1

    def on_reset(self, env_ids: torch.Tensor) -> None:
        """Envs about to be reset (a bool mask [N] or indices): re-sample those whose last
        sample is `frequency` steps old."""
        due = env_mask(env_ids, self.task.num_envs) & (self.steps_since_sample >= self.frequency)
        self.resample(due)

    @staticmethod
    def _identity(spec) -> float:
        return 1.0 if spec is not None and spec["operation"] == "scaling" else 0.0

    def _noise(self, spec, correlated, x):
        if spec is None:
            return x
        noise = sample(spec, x.shape, x.device, ramp=self.ramp(spec))
        if spec["operation"] == "additive":
            return x + noise + correlated
        return x * noise * correlated

    def perturb_observations(self, obs: torch.Tensor) -> torch.Tensor:
        return self._noise(self.obs_spec, self.obs_correlated, obs)

    def perturb_actions(self, actions: torch.Tensor) -> torch.Tensor:
        return self._noise(self.action_spec, self.action_correlated, actions)

    def apply_random_forces(self, new_draws: bool) -> None:
        """A.4.1, before each physics step: the forces decay; at the first physics step of an env
        step each env draws, with its probability, a new Gaussian force (σ = scale × body mass per
        axis). The force acts at the body's center of mass during that physics step."""
        if self.forces is None:
            return
        envs = self.task.envs
        self.forces *= self.force_decay
        if new_draws:
            mass = envs.sim.body_mass[:, self.force_body]
            new = torch.rand(self.task.num_envs, device=self.task.device) < self.force_probability
            draw = torch.randn_like(self.forces) * (self.force_scale * mass)[:, None]
            self.forces[:] = torch.where(new[:, None], draw, self.forces)
        full = torch.zeros(self.task.num_envs, envs.num_bodies, 3, device=self.task.device)
        full[:, self.force_body] = self.forces
        envs.apply_body_forces(forces=full)


class _RangeSide(_Param):
    """The lower or upper side of a [N, n, 2] range view (joint or tendon limits)."""

    def __init__(self, name, view_name, view, cols, spec):
        self.name, self.view_name, self.spec = name, view_name, spec
        self.cols, self.side = cols[0], cols[1]
        self.original = view[:, self.cols, self.side].clone()
        self.inertia_view = None

    def write(self, sim, due, ramp):
        base = self.original
        draw = sample(self.spec, base.shape, base.device, ramp=ramp)
        value = base + draw if self.spec["operation"] == "additive" else base * draw
        view = getattr(sim, self.view_name)
        view[:, self.cols, self.side] = where_rows(due, value, view[:, self.cols, self.side])


__all__ = ["Randomizer", "RandomizationError", "sample", "DISTRIBUTIONS", "OPERATIONS"]
