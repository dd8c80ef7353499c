"""`Simulator`: batched state of `num_envs` copies of a `Model`, and the step pipeline.

Read `Simulator.step` first: it lists the stages of one substep in order. Every buffer is
allocated here, once; `step()` allocates nothing and, on CUDA, is captured once as a CUDA graph
and replayed. State and parameters are exposed as zero-copy torch views of the Warp arrays.
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import warnings
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch
import warp as wp

from . import (collision, constraints, dynamics, forces, integrate, kinematics, sensors,
               solver_tgs)
from .model import Model
from .structs import EnvParams, ModelArrays


@dataclasses.dataclass(frozen=True)
class SimParams:
    """Time stepping and solver settings (PhysX/Isaac Gym names and defaults).

    The contact and solver settings are read by the constraint solver.
    """

    dt: float = 1.0 / 60.0                # one step()
    substeps: int = 2                     # step() = substeps × substep of dt / substeps
    gravity: tuple | None = None          # None: the model's <option gravity> (default 0 0 -9.81)
    solver: str = "tgs"                   # "tgs" or "pgs"
    position_iterations: int = 4
    velocity_iterations: int = 1
    contact_offset: float = 0.02          # shapes closer than this generate contacts (m)
    rest_offset: float = 0.0              # shapes come to rest at this separation (m)
    bounce_threshold_velocity: float = 0.2    # no restitution below this approach speed (m/s)
    max_depenetration_velocity: float = 10.0  # cap on the speed that resolves penetration (m/s)
    max_joint_velocity: float = 100.0     # default per-dof speed cap (PhysX's default), rad/s or m/s
    contacts_per_env: int = 64            # contact capacity of each env
    constraints: bool = True              # False: smooth dynamics only (no contacts, no limits)
    self_collisions: bool = True          # bodies of one articulation collide with each other

    def __post_init__(self):
        def bad(field, why):
            raise ValueError(f"SimParams.{field}={getattr(self, field)!r}: {why}")

        if not (isinstance(self.dt, (int, float)) and math.isfinite(self.dt) and self.dt > 0):
            bad("dt", "must be a positive, finite number of seconds")
        for name in ("substeps", "position_iterations"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                bad(name, "must be an integer >= 1")
        for name in ("velocity_iterations", "contacts_per_env"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 0:
                bad(name, "must be an integer >= 0")
        if self.solver not in ("tgs", "pgs"):
            bad("solver", "must be 'tgs' or 'pgs'")
        if self.gravity is not None and np.shape(self.gravity) != (3,):
            bad("gravity", "must be three numbers (x, y, z) or None")
        for name in ("contact_offset", "rest_offset", "bounce_threshold_velocity",
                     "max_depenetration_velocity", "max_joint_velocity"):
            if not math.isfinite(getattr(self, name)) or getattr(self, name) < 0:
                bad(name, "must be a finite number >= 0")
        if self.rest_offset > self.contact_offset:
            bad("rest_offset", f"must not exceed contact_offset={self.contact_offset}")


class _View:
    """A writable per-env tensor: reading gives the zero-copy view, assigning copies into it."""

    def __set_name__(self, owner, name):
        self.name = name

    def __get__(self, sim, owner=None):
        if sim is None:
            return self
        return sim._views[self.name]

    def __set__(self, sim, value):
        view = sim._views[self.name]
        if not isinstance(value, torch.Tensor):
            value = torch.as_tensor(value, dtype=view.dtype, device=view.device)
        try:
            fits = torch.broadcast_shapes(value.shape, view.shape) == view.shape
        except RuntimeError:
            fits = False
        if not fits:
            raise ValueError(f"sim.{self.name}: cannot write a tensor of shape {tuple(value.shape)} "
                             f"into shape {tuple(view.shape)}")
        if value.device != view.device:
            raise ValueError(f"sim.{self.name}: value is on {value.device}, the simulator on {view.device}")
        view.copy_(value)


def device_name(device) -> str:
    """'cpu' or 'cuda:N' for 'cpu', 'cuda' (cuda:0) or 'cuda:N' (a str, torch or Warp device);
    any other name raises a one-line ValueError. Whether that GPU exists is not checked here."""
    name = str(device).strip()
    kind, colon, index = name.partition(":")
    if name == "cpu":
        return name
    if kind != "cuda" or colon and not (index.isascii() and index.isdigit()):
        raise ValueError(f"device {name!r}: expected 'cpu', 'cuda' or 'cuda:N'")
    return f"cuda:{int(index) if colon else 0}"


def _resolve_device(device) -> wp.context.Device:
    """The Warp device of `device` (see `device_name`); a GPU that is not there raises a
    one-line ValueError."""
    name = device_name(device)
    try:
        return wp.get_device(name)
    except Exception:
        available = [str(d) for d in wp.get_devices()]
        raise ValueError(f"device {name!r} is not available (no such GPU); Warp sees "
                         f"{available}") from None


def tree_spans(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """[lo, hi) of the dof tree of each dof [nv, 2] and of each body's moving dofs [nbody, 2].

    A dof tree is a top dof (no parent dof) with all its descendants: in MuJoCo's depth-first
    order its dofs are contiguous, and dofs of different trees never couple in the mass matrix.
    """
    top = np.arange(model.nv)
    for i in range(model.nv):                      # parents come first in MuJoCo's order
        if model.dof_parent[i] >= 0:
            top[i] = top[model.dof_parent[i]]
    dof_span = np.zeros((model.nv, 2), np.int32)
    for t in np.unique(top):
        members = np.flatnonzero(top == t)
        assert members[-1] - members[0] + 1 == len(members), "a dof tree is not contiguous"
        dof_span[members] = (members[0], members[-1] + 1)
    body_span = np.zeros((model.nbody, 2), np.int32)
    moved = model.body_last_dof >= 0
    body_span[moved] = dof_span[model.body_last_dof[moved]]
    return dof_span, body_span


def _model_arrays(model: Model, device) -> ModelArrays:
    def arr(a, dtype):
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=device)

    i32, f32 = wp.int32, wp.float32
    s = ModelArrays()
    s.nbody, s.nv, s.njnt, s.nu, s.ntendon = (model.nbody, model.nv, model.njnt, model.nu,
                                              model.ntendon)
    s.body_parent = arr(model.body_parent, i32)
    s.body_root = arr(model.body_root, i32)
    s.body_pos = arr(model.body_pos, wp.vec3)
    s.body_quat = arr(model.body_quat, wp.quat)
    s.body_ipos = arr(model.body_ipos, wp.vec3)
    s.body_iquat = arr(model.body_iquat, wp.quat)
    s.body_jntadr = arr(model.body_jntadr, i32)
    s.body_jntnum = arr(model.body_jntnum, i32)
    s.body_last_dof = arr(model.body_last_dof, i32)
    s.jnt_type = arr(model.jnt_type, i32)
    s.jnt_qposadr = arr(model.jnt_qposadr, i32)
    s.jnt_dofadr = arr(model.jnt_dofadr, i32)
    s.jnt_pos = arr(model.jnt_pos.reshape(-1, 3), wp.vec3)
    s.jnt_axis = arr(model.jnt_axis.reshape(-1, 3), wp.vec3)
    s.jnt_springref = arr(model.jnt_springref, f32)
    s.jnt_actfrclimited = arr(model.jnt_actfrclimited, i32)
    s.jnt_actfrcrange = arr(model.jnt_actfrcrange.reshape(-1, 2), wp.vec2)
    s.qpos0 = arr(model.qpos0, f32)
    s.dof_body = arr(model.dof_body, i32)
    s.dof_parent = arr(model.dof_parent, i32)
    dof_span, body_span = tree_spans(model)
    s.dof_tree_span = arr(dof_span, wp.vec2i)
    s.body_tree_span = arr(body_span, wp.vec2i)
    s.dof_madr = arr(dynamics.mass_matrix_layout(dof_span)[0], i32)
    s.site_body = arr(model.site_body, i32)
    s.site_pos = arr(model.site_pos.reshape(-1, 3), wp.vec3)
    s.site_quat = arr(model.site_quat.reshape(-1, 4), wp.quat)
    s.actuator_kind = arr(model.actuator_kind, i32)
    s.actuator_dof = arr(model.actuator_dof, i32)
    s.actuator_qposadr = arr(model.jnt_qposadr[model.dof_jnt[model.actuator_dof]], i32)
    s.actuator_ctrllimited = arr(model.actuator_ctrllimited, i32)
    s.actuator_ctrlrange = arr(model.actuator_ctrlrange.reshape(-1, 2), wp.vec2)
    s.actuator_forcelimited = arr(model.actuator_forcelimited, i32)
    s.actuator_forcerange = arr(model.actuator_forcerange.reshape(-1, 2), wp.vec2)
    s.tendon_adr = arr(model.tendon_adr, i32)
    s.tendon_num = arr(model.tendon_num, i32)
    s.wrap_jnt = arr(model.wrap_jnt, i32)
    s.wrap_coef = arr(model.wrap_coef, f32)
    s.wrap_recip = arr(model.wrap_recip, f32)
    s.tendon_limited = arr(model.tendon_limited, i32)
    return s


class Simulator:
    """`num_envs` independent copies of `model`, stepped together on one device."""

    # state and inputs
    q = _View()              # [N, nq] generalized positions (quaternions xyzw)
    qd = _View()             # [N, nv] generalized velocities
    joint_force = _View()    # [N, nv] generalized force applied during the next step
    body_force = _View()     # [N, nbody, 6] force at the center of mass, then torque; world axes
    ctrl = _View()           # [N, nu] actuator inputs
    # per-env parameters (each env may differ; domain randomization writes these)
    body_mass = _View()      # [N, nbody]
    body_inertia = _View()   # [N, nbody, 3] principal moments
    geom_friction = _View()  # [N, ngeom] sliding friction coefficient (pairs average)
    geom_restitution = _View()  # [N, ngeom] restitution coefficient (pairs average)
    geom_size = _View()      # [N, ngeom, 3] MuJoCo's size parameters (primitives)
    geom_pos = _View()       # [N, ngeom, 3] position in the body frame
    nonfinite = _View()      # [N] 1 once an env's state or input (ctrl, joint_force, body_force)
    #                          went non-finite (its state is then NaN); the task resets it
    dof_damping = _View()    # [N, nv]
    dof_armature = _View()   # [N, nv]
    dof_frictionloss = _View()  # [N, nv] joint (dry) friction, force or torque
    dof_max_velocity = _View()  # [N, nv] maximum joint speed (rad/s or m/s)
    joint_stiffness = _View()  # [N, njnt]
    joint_range = _View()    # [N, njnt, 2]
    actuator_gear = _View()  # [N, nu]
    actuator_gain = _View()  # [N, nu] motors: force per unit ctrl
    actuator_kp = _View()    # [N, nu] position actuators
    actuator_kv = _View()    # [N, nu] position and velocity actuators
    tendon_stiffness = _View()  # [N, ntendon]
    tendon_damping = _View()    # [N, ntendon]
    tendon_range = _View()      # [N, ntendon, 2] lower, upper length limits
    tendon_limit_stiffness = _View()  # [N, ntendon] 0: hard limits; > 0: limit spring
    tendon_rest_length = _View()      # [N, ntendon]
    tendon_offset = _View()           # [N, ntendon]
    gravity = _View()        # [N, 3]

    def __init__(self, model: Model, num_envs: int = 1, device="cpu",
                 params: SimParams | None = None, cpu_threads: int | None = None):
        if not isinstance(model, Model):
            raise TypeError(f"model must be a myriad.Model (from myriad.load), not {type(model).__name__}")
        if not isinstance(num_envs, int) or isinstance(num_envs, bool) or num_envs < 1:
            raise ValueError(f"num_envs={num_envs!r}: must be an integer >= 1")
        params = SimParams() if params is None else params
        if not isinstance(params, SimParams):
            raise TypeError(f"params must be a myriad.SimParams, not {type(params).__name__}")
        wp.init()
        self.model, self.params, self.num_envs = model, params, num_envs
        self.device = _resolve_device(device)
        self.torch_device = wp.device_to_torch(self.device)
        self.h = params.dt / params.substeps
        self._graph = None
        self._jac = {}
        self._warned_overflow = False
        if cpu_threads is not None and (not isinstance(cpu_threads, int) or cpu_threads < 1):
            raise ValueError(f"cpu_threads={cpu_threads!r}: must be an integer >= 1 (or None: "
                             "one per CPU core)")

        N, dev = num_envs, self.device
        m = model
        self._m = _model_arrays(model, dev)

        # memory of per-env arrays (first dimension N), which CPU threads split by env
        self._per_env_ptrs = set()

        def per_env(a):
            self._per_env_ptrs.add(a.ptr)
            return a

        def zeros(*shape, dtype=wp.float32):
            return per_env(wp.zeros(shape, dtype=dtype, device=dev))

        def tiled(values, dtype=wp.float32):
            values = np.asarray(values, dtype=np.float32)
            return per_env(wp.array(np.ascontiguousarray(
                np.broadcast_to(values, (N,) + values.shape)), dtype=dtype, device=dev))

        gravity = m.gravity if params.gravity is None else np.asarray(params.gravity)
        p = EnvParams()
        p.body_mass = tiled(m.body_mass)
        p.body_inertia = tiled(m.body_inertia, wp.vec3)
        p.jnt_stiffness = tiled(m.jnt_stiffness)
        p.dof_damping = tiled(m.dof_damping)
        p.dof_armature = tiled(m.dof_armature)
        p.actuator_gear = tiled(m.actuator_gear)
        p.actuator_gain = tiled(m.actuator_gain)
        p.actuator_kp = tiled(m.actuator_kp)
        p.actuator_kv = tiled(m.actuator_kv)
        p.tendon_stiffness = tiled(m.tendon_stiffness)
        p.tendon_damping = tiled(m.tendon_damping)
        p.tendon_limit_stiffness = tiled(m.tendon_limit_stiffness)
        p.tendon_rest_length = tiled(m.tendon_rest_length)
        p.tendon_offset = tiled(m.tendon_offset)
        p.tendon_range = tiled(m.tendon_range.reshape(-1, 2), wp.vec2)
        p.gravity = tiled(gravity, wp.vec3)
        self._p = p

        # state
        self._q = tiled(m.qpos0)
        self._qd = zeros(N, m.nv)
        self._qacc = zeros(N, m.nv)
        self._joint_force = zeros(N, m.nv)
        self._body_force = zeros(N, m.nbody, dtype=wp.spatial_vector)
        self._qfrc_applied = zeros(N, m.nv)
        self._wrench = zeros(N, m.nbody, dtype=wp.spatial_vector)
        self._ctrl = zeros(N, m.nu)
        # derived quantities
        self._body_x = zeros(N, m.nbody, dtype=wp.transform)
        self._body_com = zeros(N, m.nbody, dtype=wp.vec3)
        self._body_iframe = zeros(N, m.nbody, dtype=wp.quat)
        self._body_vel = zeros(N, m.nbody, dtype=wp.spatial_vector)
        self._jnt_anchor = zeros(N, m.njnt, dtype=wp.vec3)
        self._jnt_xaxis = zeros(N, m.njnt, dtype=wp.vec3)
        self._site_x = zeros(N, m.nsite, dtype=wp.transform)
        self._cvel = zeros(N, m.nbody, dtype=wp.spatial_vector)
        self._cdof = zeros(N, m.nv, dtype=wp.spatial_vector)
        self._cdof_dot = zeros(N, m.nv, dtype=wp.spatial_vector)
        self._cacc = zeros(N, m.nbody, dtype=wp.spatial_vector)
        self._cfrc = zeros(N, m.nbody, dtype=wp.spatial_vector)
        self._crb_m = zeros(N, m.nbody)
        self._crb_h = zeros(N, m.nbody, dtype=wp.vec3)
        self._crb_i = zeros(N, m.nbody, dtype=wp.mat33)
        # the mass matrix and its factor: one square block per dof tree (`dynamics`)
        dof_span = tree_spans(model)[0]
        madr, msize = dynamics.mass_matrix_layout(dof_span)
        self._qm = zeros(N, msize)
        self._factor = zeros(N, msize)
        # where the blocks' entries go in a dense [nv, nv] matrix (the `mass_matrix` property)
        blocks = [(i, j) for i in range(m.nv) for j in range(*dof_span[i])]
        self._qm_dense_at = torch.as_tensor(np.asarray(blocks, np.int64).reshape(-1, 2).T,
                                            device=self.torch_device)
        self._qm_block_at = torch.as_tensor(np.asarray([madr[i] + j for i, j in blocks], np.int64),
                                            device=self.torch_device)
        self._bias = zeros(N, m.nv)
        self._qfrc = zeros(N, m.nv)
        self._qfrc_actuator = zeros(N, m.nv)
        self._implicit_diag = zeros(N, m.nv)
        # parameters the constraint solver reads
        self._geom_friction = tiled(m.geom_friction[:, 0])
        self._joint_range = tiled(m.jnt_range.reshape(-1, 2), wp.vec2)
        self._dof_frictionloss = tiled(m.dof_frictionloss)
        self._dof_max_velocity = tiled(np.full(m.nv, params.max_joint_velocity, np.float32))

        # collision: candidate pairs fixed now; contacts go to per-env slots
        pairs = (collision.candidate_pairs(model, params.self_collisions) if params.constraints
                 else np.zeros((0, 2)))
        self._pairs = wp.array(pairs, dtype=wp.vec2i, device=dev)
        self._geom_type = wp.array(m.geom_type, dtype=wp.int32, device=dev)
        self._geom_size = tiled(m.geom_size, wp.vec3)     # per env: object scale randomization
        self._geom_body = wp.array(m.geom_body, dtype=wp.int32, device=dev)
        self._geom_pos = tiled(m.geom_pos, wp.vec3)
        self._site_pos = tiled(m.site_pos.reshape(-1, 3), wp.vec3)
        self._geom_quat = wp.array(m.geom_quat, dtype=wp.quat, device=dev)
        self._geom_dataid = wp.array(m.geom_dataid, dtype=wp.int32, device=dev)
        self._meshes = collision.Meshes()
        self._meshes.vert = wp.array(m.mesh_vert.reshape(-1, 3), dtype=wp.vec3, device=dev)
        self._meshes.vertadr = wp.array(m.mesh_vertadr, dtype=wp.int32, device=dev)
        self._meshes.vertnum = wp.array(m.mesh_vertnum, dtype=wp.int32, device=dev)
        verts = m.mesh_vert.reshape(-1, 3)
        rbound = [float(np.linalg.norm(verts[a:a + k], axis=1).max(initial=0.0))
                  for a, k in zip(m.mesh_vertadr, m.mesh_vertnum)]
        self._meshes.rbound = wp.array(np.asarray(rbound, np.float32), dtype=float, device=dev)
        self._hfields = collision.HFields()
        self._hfields.size = wp.array(m.hfield_size.reshape(-1, 4), dtype=wp.vec4, device=dev)
        self._hfields.nrow = wp.array(m.hfield_nrow, dtype=wp.int32, device=dev)
        self._hfields.ncol = wp.array(m.hfield_ncol, dtype=wp.int32, device=dev)
        self._hfields.adr = wp.array(m.hfield_adr, dtype=wp.int32, device=dev)
        self._hfields.data = wp.array(m.hfield_data, dtype=wp.float32, device=dev)
        self._geom_x = zeros(N, m.ngeom, dtype=wp.transform)
        self._contacts = collision.ContactBuffers(N, params.contacts_per_env if len(pairs) else 0,
                                                  dev)
        for buf in (self._contacts.count, self._contacts.geom, self._contacts.pos,
                    self._contacts.normal, self._contacts.dist, self._contacts.key):
            per_env(buf)
        self._geom_restitution = zeros(N, m.ngeom)
        # constraint rows: 3 per contact slot, 2 per limited joint, 2 per limited tendon
        limited = [j for j in range(m.njnt) if m.jnt_limited[j] and params.constraints]
        self._limit_jnt = wp.array(np.asarray(limited, np.int32), dtype=wp.int32, device=dev)
        limited_tendons = [t for t in range(m.ntendon) if m.tendon_limited[t] and params.constraints]
        self._limit_tendon = wp.array(np.asarray(limited_tendons, np.int32), dtype=wp.int32,
                                      device=dev)
        # ... one spring-damper row per tendon (present with or without `constraints`), and one
        # row per dof for joint friction and the maximum joint speed
        self._rows_at = constraints.row_layout(self._contacts.capacity, len(limited),
                                               len(limited_tendons), m.ntendon,
                                               m.nv if params.constraints else 0)
        self.nrow = self._rows_at.end
        R = self.nrow
        self._row_type = zeros(N, R, dtype=wp.int32)
        self._row_err = zeros(N, R)
        self._row_inv_mass = zeros(N, R)
        self._row_mu = zeros(N, R)
        self._row_bounce = zeros(N, R)
        self._row_dir = zeros(N, R, dtype=wp.vec3)
        self._row_k = zeros(N, R)
        self._row_d = zeros(N, R)
        self._row_span = zeros(N, R, dtype=wp.vec4i)   # the dof ranges a row touches
        # J and M⁻¹Jᵀ of each row, over the dofs of its span only (`constraints`)
        tendon_dofs = [m.jnt_dofadr[m.wrap_jnt[a:a + k]] for a, k in zip(m.tendon_adr, m.tendon_num)]
        self.row_width = constraints.row_width(dof_span, tendon_dofs)
        self._jac_rows = zeros(N, R, self.row_width)
        self._minv_jt = zeros(N, R, self.row_width)
        self._lam = zeros(N, R)
        self._lam_init = zeros(N, R)
        self._prev_key = zeros(N, self._contacts.capacity, dtype=wp.int32)
        self._prev_count = zeros(N, dtype=wp.int32)
        self._dq = zeros(N, m.nv)
        self._qd_before = zeros(N, m.nv)
        # force/torque sensors: one 6D wrench per site that carries a force or torque sensor
        self.sensor_sites = list(dict.fromkeys(int(s) for s in m.sensor_site))
        self._sensor_site = wp.array(np.asarray(self.sensor_sites, np.int32), dtype=wp.int32, device=dev)
        self._sensor_site_body = wp.array(np.asarray(m.site_body[self.sensor_sites], np.int32)
                                          if self.sensor_sites else np.zeros(0, np.int32),
                                          dtype=wp.int32, device=dev)
        self._sensor_wrench = zeros(N, len(self.sensor_sites), dtype=wp.spatial_vector)
        # MuJoCo's sensordata order: (site slot, 0 for force / 3 for torque) of each sensor
        self._sensor_columns = [(self.sensor_sites.index(int(site)), 0 if kind == "force" else 3)
                                for site, kind in zip(m.sensor_site, m.sensor_type)]
        self._contact_force = zeros(N, self._contacts.capacity, dtype=wp.vec3)
        self._net_contact_force = zeros(N, m.nbody, dtype=wp.vec3)
        self._dof_constraint_force = zeros(N, m.nv)
        self._nonfinite = zeros(N, dtype=wp.int32)

        t = wp.to_torch
        self._views = {
            "q": t(self._q), "qd": t(self._qd), "joint_force": t(self._joint_force),
            "body_force": t(self._body_force),
            "ctrl": t(self._ctrl),
            "body_mass": t(p.body_mass), "body_inertia": t(p.body_inertia),
            "geom_friction": t(self._geom_friction), "geom_size": t(self._geom_size),
            "geom_pos": t(self._geom_pos), "geom_restitution": t(self._geom_restitution),
            "dof_damping": t(p.dof_damping), "nonfinite": t(self._nonfinite),
            "dof_armature": t(p.dof_armature), "joint_stiffness": t(p.jnt_stiffness),
            "joint_range": t(self._joint_range), "dof_frictionloss": t(self._dof_frictionloss),
            "dof_max_velocity": t(self._dof_max_velocity), "actuator_gear": t(p.actuator_gear),
            "actuator_gain": t(p.actuator_gain), "actuator_kp": t(p.actuator_kp),
            "actuator_kv": t(p.actuator_kv), "tendon_stiffness": t(p.tendon_stiffness),
            "tendon_damping": t(p.tendon_damping), "tendon_range": t(p.tendon_range),
            "tendon_limit_stiffness": t(p.tendon_limit_stiffness),
            "tendon_rest_length": t(p.tendon_rest_length), "tendon_offset": t(p.tendon_offset),
            "gravity": t(p.gravity),
        }
        # read-only outputs (views too: they change in place as the simulation advances)
        self.body_pose = t(self._body_x)          # [N, nbody, 7] position, quaternion xyzw
        self.body_vel = t(self._body_vel)         # [N, nbody, 6] linear (of the body origin), angular; world
        self.body_com = t(self._body_com)         # [N, nbody, 3] centers of mass, world
        self.site_pose = t(self._site_x)          # [N, nsite, 7]
        self.bias_force = t(self._bias)           # [N, nv] C(q, qd)·qd + g(q)
        self.qacc = t(self._qacc)                 # [N, nv] acceleration of the last substep
        self.dof_actuator_force = t(self._qfrc_actuator)  # [N, nv] generalized actuator force
        self.geom_pose = t(self._geom_x)          # [N, ngeom, 7] as of the last collision stage
        c = self._contacts
        self.contact_count = t(c.count)           # [N] contacts found (above capacity: overflow)
        self.contact_geom = t(c.geom)             # [N, capacity, 2] geom 1, geom 2
        self.contact_pos = t(c.pos)               # [N, capacity, 3] midpoint between the surfaces
        self.contact_normal = t(c.normal)         # [N, capacity, 3] from geom 1 to geom 2
        self.contact_dist = t(c.dist)             # [N, capacity] signed distance, < 0: penetration
        self.contact_force = t(self._contact_force)   # [N, capacity, 3] on geom 2, world
        self.net_contact_force = t(self._net_contact_force)  # [N, nbody, 3]
        self.dof_constraint_force = t(self._dof_constraint_force)  # [N, nv]
        # [N, len(sensor_sites), 6]: force then torque that each sensor site's body receives
        # from its parent, in the site frame (MuJoCo's force/torque sensor semantics)
        self.sensor_wrench = t(self._sensor_wrench)

        self._setup_cpu_shards(cpu_threads)
        self.forward()

    # ------------------------------------------------------------------ pipeline
    def step(self) -> None:
        """Advance every env by `params.dt`."""
        if self.device.is_cuda:
            self._run_on_device(self._step_graph)
        else:
            self._run_sharded(self._step_kernels)

    def _step_kernels(self) -> None:
        for _ in range(self.params.substeps):
            self._kinematics()
            self._collision()
            self._dynamics()
            self._applied_forces()
            self._solve_unconstrained()
            self._constraint_rows()
            self._solve_constraints()
            self._integrate()
        self._kinematics()  # poses and velocities of the new state, for the caller
        self._constraint_outputs()

    def forward(self) -> None:
        """Recompute poses, velocities, mass matrix and bias forces from q, qd (no time passes)."""
        def run():
            self._kinematics()
            self._dynamics()
        self._run_on_device(run) if self.device.is_cuda else self._run_sharded(run)

    def collide(self) -> None:
        """Contact detection alone, at the current kinematics (for debugging: step() runs it)."""
        self._run_on_device(self._collision) if self.device.is_cuda else self._collision()

    def _collision(self) -> None:
        n, m, c = self.num_envs, self.model, self._contacts
        if c.capacity == 0:
            return
        self._launch(kinematics.attached_frames, (n, m.ngeom), [
            self._geom_body, self._geom_pos, self._geom_quat, self._body_x, self._geom_x])
        self._shard_of(c.count).zero_()
        if len(self._pairs):
            # a GPU runs a thread per (env, pair); a CPU thread per env walks its pairs
            kernel, dim = ((collision.narrowphase, (n, len(self._pairs))) if self.device.is_cuda
                           else (collision.narrowphase_per_env, n))
            self._launch(kernel, dim, [
                self._pairs, self._geom_type, self._geom_size, self._geom_dataid, self._meshes,
                self._hfields, self._geom_x,
                self.params.contact_offset, c.capacity, c.count, c.geom, c.key, c.pos, c.normal,
                c.dist])

    def _launch(self, kernel, dim, inputs) -> None:
        shard = getattr(self._shard_local, "range", None)
        if shard is not None:     # a CPU thread's share of the envs: per-env arrays sliced
            inputs = [self._shard_of(a) for a in inputs]
            size = shard[1] - shard[0]
            dim = (size,) + tuple(dim[1:]) if isinstance(dim, tuple) else size
        wp.launch(kernel, dim=dim, inputs=inputs, device=self.device)

    # ------------------------------------------------------------------ CPU threads
    def _setup_cpu_shards(self, cpu_threads) -> None:
        """On CPU, split the envs into contiguous shards stepped by one thread each.

        Warp runs a CPU kernel on the calling thread and releases the GIL while it runs, so
        shards of envs advance in parallel; every kernel is per env, so the result is the same
        bit for bit. A shard's launches see views of the per-env arrays (those allocated per env
        in __init__) restricted to its envs; model-wide arrays are passed whole.
        """
        self._shard_local = threading.local()
        self._shards, self._pool = [], None
        if self.device.is_cuda:
            return
        threads = cpu_threads or max(1, min(os.cpu_count() or 1, self.num_envs // 64))
        threads = min(threads, self.num_envs)
        if threads == 1:
            return
        bounds = np.linspace(0, self.num_envs, threads + 1).round().astype(int)
        self._shards = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
        self._shard_params = {}
        for a, b in self._shards:
            p = EnvParams()
            for name in EnvParams.vars:
                whole = getattr(self._p, name)
                setattr(p, name, whole[a:b] if whole.size else whole)   # empty: nothing to read
            self._shard_params[(a, b)] = p
        self._pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="myriad-sim")
        weakref.finalize(self, self._pool.shutdown, wait=False)

    def _shard_of(self, a):
        """`a` restricted to the current thread's envs (unchanged outside a sharded run)."""
        shard = getattr(self._shard_local, "range", None)
        if shard is None:
            return a
        if a is self._p:
            return self._shard_params[shard]
        # per-env memory (views such as reshapes included); model-wide arrays pass whole
        if isinstance(a, wp.array) and a.size and a.shape[0] == self.num_envs \
                and a.ptr in self._per_env_ptrs:
            return a[shard[0]:shard[1]]
        return a

    def _run_sharded(self, fn) -> None:
        if not self._shards:
            fn()
            return

        def run(shard):
            self._shard_local.range = shard
            try:
                fn()
            finally:
                self._shard_local.range = None

        for future in [self._pool.submit(run, shard) for shard in self._shards]:
            future.result()

    def _kinematics(self) -> None:
        self._launch(kinematics.kinematics, self.num_envs, [
            self._m, self._q, self._qd, self._body_x, self._body_com, self._body_iframe,
            self._body_vel, self._jnt_anchor, self._jnt_xaxis, self._cvel, self._cdof,
            self._cdof_dot])
        if self.model.nsite:
            self._launch(kinematics.attached_frames, (self.num_envs, self.model.nsite),
                         [self._m.site_body, self._site_pos, self._m.site_quat, self._body_x,
                          self._site_x])

    def _dynamics(self) -> None:
        self._launch(dynamics.mass_matrix, self.num_envs, [
            self._m, self._p, self._body_x, self._body_com, self._body_iframe, self._cdof,
            self._crb_m, self._crb_h, self._crb_i, self._qm])
        self._launch(dynamics.bias_forces, self.num_envs, [
            self._m, self._p, self._body_x, self._body_com, self._body_iframe, self._qd, self._cvel,
            self._cdof, self._cdof_dot, self._cacc, self._cfrc, self._bias])

    def _applied_forces(self) -> None:
        self._launch(forces.body_wrenches, self.num_envs, [
            self._m, self._body_x, self._body_com, self._cdof, self._joint_force, self._body_force,
            self._wrench, self._qfrc_applied, self._nonfinite])
        self._launch(forces.generalized_forces, self.num_envs, [
            self._m, self._p, self.h, self._q, self._qd, self._ctrl, self._qfrc_applied, self._bias,
            self._qfrc_actuator, self._qfrc, self._implicit_diag, self._nonfinite])

    def _solve_unconstrained(self) -> None:
        self._launch(dynamics.solve_acceleration, self.num_envs, [
            self._m, self._qm, self._implicit_diag, self._qfrc, self._factor,
            self._qacc.reshape((self.num_envs, 1, self.model.nv))])

    def _constraint_rows(self) -> None:
        if self.nrow == 0:
            return
        c, p = self._contacts, self.params
        self._launch(constraints.build_rows, self.num_envs, [
            self._m, self._rows_at, self.h, p.rest_offset, p.bounce_threshold_velocity,
            self._geom_body, self._geom_friction, self._geom_restitution, c.capacity, c.count,
            c.geom, c.key, c.pos, c.normal, c.dist, self._prev_key, self._prev_count, self._lam,
            self._limit_jnt, self._joint_range, self._limit_tendon, self._p,
            self._dof_frictionloss, self._dof_max_velocity, self._body_x, self._cdof,
            self._q, self._qd, self._qacc, self._factor, self._row_type, self._row_err,
            self._row_inv_mass, self._row_mu, self._row_bounce, self._row_dir, self._row_k,
            self._row_d, self._row_span, self._jac_rows, self._minv_jt, self._lam_init])

    def _solve_constraints(self) -> None:
        p = self.params
        self._launch(solver_tgs.solve, self.num_envs, [
            self._m, self._rows_at, self._contacts.capacity, self._contacts.count,
            self._limit_jnt, self.h, p.position_iterations, p.velocity_iterations,
            int(p.solver == "tgs"), p.max_depenetration_velocity, self._row_type, self._row_err, self._row_inv_mass,
            self._row_mu, self._row_bounce, self._row_k, self._row_d, self._row_span,
            self._factor, self._jac_rows, self._minv_jt, self._lam_init, self._qacc, self._qd,
            self._qd_before, self._dq, self._lam])

    def _integrate(self) -> None:
        self._launch(integrate.integrate, self.num_envs,
                     [self._m, self._dq, self._q, self._qd, self._nonfinite])

    def contact_overflow(self) -> int:
        """Number of envs whose contacts did not all fit their slots in the last substep.

        The extra contacts were dropped (never written elsewhere). The first time any overflow is
        seen, a warning names the capacity to raise. Reads the device: call it from the host
        loop now and then, not inside a captured step.
        """
        over = int((self.contact_count > self._contacts.capacity).sum())
        if over and not self._warned_overflow:
            self._warned_overflow = True
            warnings.warn(f"{over} of {self.num_envs} envs found more than their "
                          f"{self._contacts.capacity} contact slots (most: "
                          f"{int(self.contact_count.max())}); raise "
                          "SimParams(contacts_per_env=...)", RuntimeWarning, stacklevel=2)
        return over

    @property
    def mass_matrix(self) -> torch.Tensor:
        """[N, nv, nv] joint-space mass matrix with armature, of the current kinematics.

        A new dense tensor built from the stored blocks (one per dof tree) on each read: zero
        between dofs of different trees.
        """
        n, nv = self.num_envs, self.model.nv
        dense = torch.zeros(n, nv, nv, device=self.torch_device)
        rows, cols = self._qm_dense_at
        dense[:, rows, cols] = wp.to_torch(self._qm)[:, self._qm_block_at]
        return dense

    @property
    def sensor_data(self) -> torch.Tensor:
        """[N, nsensor, 3]: each MJCF force/torque sensor's reading, in the model's order."""
        if not self._sensor_columns:
            return self.sensor_wrench.new_zeros(self.num_envs, 0, 3)
        return torch.stack([self.sensor_wrench[:, s, c:c + 3] for s, c in self._sensor_columns], 1)

    def _constraint_outputs(self) -> None:
        c = self._contacts
        self._launch(solver_tgs.constraint_forces, self.num_envs, [
            self._m, self._rows_at, self.h, self._geom_body, c.capacity, c.count, c.geom,
            self._row_dir, self._lam, self._row_type, self._row_span, self._jac_rows,
            self._contact_force,
            self._net_contact_force, self._dof_constraint_force])
        if self.sensor_sites:  # site poses are current: the final kinematics computed them
            self._launch(sensors.force_sensors, self.num_envs, [
                self._m, self._p, self.h, self._body_x, self._body_com, self._body_iframe,
                self._cvel, self._cdof, self._cdof_dot, self._qd, self._qd_before,
                self._geom_body, c.capacity, c.count, c.geom, c.pos, self._contact_force,
                self._sensor_site_body, self._sensor_site, self._site_x, self._cacc, self._cfrc,
                self._sensor_wrench])

    # ------------------------------------------------------------------ CUDA
    def _step_graph(self) -> None:
        if self._graph is None:
            # every kernel module is compiled and loaded before the capture starts
            wp.load_module("myriad.physics", device=self.device, recursive=True)
            with wp.ScopedCapture(device=self.device, stream=self._stream) as capture:
                self._step_kernels()
            self._graph = capture.graph
        wp.capture_launch(self._graph, stream=self._stream)

    def _run_on_device(self, fn) -> None:
        """Run `fn`'s launches on Warp's stream, ordered after and before torch's work."""
        if not hasattr(self, "_stream"):
            self._stream = wp.Stream(self.device)
        torch_stream = wp.stream_from_torch(torch.cuda.current_stream(self.torch_device))
        self._stream.wait_stream(torch_stream)
        with wp.ScopedStream(self._stream):
            fn()
        torch_stream.wait_stream(self._stream)

    # ------------------------------------------------------------------ Jacobians
    def body_jacobians(self) -> torch.Tensor:
        """[N, nbody, 6, nv] at each body origin, world frame: rows 0-2 linear, 3-5 angular.

        Computed from the current kinematics (after step() or forward()); the returned tensor is
        overwritten by the next call.
        """
        return self._jacobians("body", kinematics.body_jacobians, self.model.nbody, [])

    def site_jacobians(self) -> torch.Tensor:
        """[N, nsite, 6, nv] at each site, world frame: rows 0-2 linear, 3-5 angular."""
        return self._jacobians("site", kinematics.site_jacobians, self.model.nsite, [self._site_x])

    def _jacobians(self, kind, kernel, count, extra_inputs) -> torch.Tensor:
        if kind not in self._jac:  # allocated on first use: most tasks never ask
            self._jac[kind] = wp.zeros((self.num_envs, count, 6, self.model.nv), dtype=wp.float32,
                                       device=self.device)
        inputs = [self._m, self._body_x, *extra_inputs, self._cdof, self._jac[kind]]
        launch = lambda: self._launch(kernel, (self.num_envs, count), inputs)
        self._run_on_device(launch) if self.device.is_cuda else launch()
        return wp.to_torch(self._jac[kind])

    def __repr__(self) -> str:
        return f"Simulator({self.model!r}, num_envs={self.num_envs}, device={self.device})"
