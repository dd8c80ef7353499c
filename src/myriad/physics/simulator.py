"""`Simulator`: batched state of `num_envs` copies of a `Model`, and the step pipeline.

Read `Simulator.step` first: it lists the stages of one substep in order. Every per-env array
is a field declared in `structs` (EnvParams, State, Control, Dynamics, Contacts, Rows), allocated
here once; `step()` allocates nothing and, on CUDA, is captured once as a CUDA graph and
replayed. The fields declared public are the simulator's attributes (sim.q, sim.body_mass,
sim.contact_force, ...): zero-copy torch views of the Warp arrays.
"""

from __future__ import annotations

import os
import threading
import warnings
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch
import warp as wp

from . import (collision, constraints, dynamics, float_mode, forces, integrate, kinematics,
               sensors, solver_tgs)
from . import structs
from .model import Model
from .params import SimParams
from .devices import resolve_device
from .structs import EnvParams, State
from .types import EqualityType, SensorType


class Simulator:
    """`num_envs` independent copies of `model`, stepped together on one device."""

    # Public tensors (sim.q, sim.ctrl, sim.body_mass, sim.contact_force, ...) are the fields
    # declared with a `public` name in `structs` (`structs.add_public_views`, after the class).

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
        self.device = resolve_device(device)
        self.torch_device = wp.device_to_torch(self.device)
        self.h = params.dt / params.substeps
        self._graph = None
        self._jac = {}
        self._warned_overflow = False
        if cpu_threads is not None and (not isinstance(cpu_threads, int) or cpu_threads < 1):
            raise ValueError(f"cpu_threads={cpu_threads!r}: must be an integer >= 1 (or None: "
                             "one per CPU core)")

        N, dev, m = num_envs, self.device, model
        # model-wide collision data: candidate pairs fixed now (with the friction of the
        # explicit ones, in ModelArrays), shapes, meshes, height fields
        pairs = (collision.candidate_pairs(model, params.self_collisions) if params.constraints
                 else np.zeros((0, 2), np.int32))
        self._m = structs.model_arrays(model, dev, collision.pair_friction(model, pairs))
        self._pairs = wp.array(pairs, dtype=wp.vec2i, device=dev)
        self.contact_capacity = params.contacts_per_env if len(pairs) else 0
        self._meshes, self._hfields = collision.shape_data(model, dev)

        # constraint rows: 3 per contact slot, 2 per limited joint, 2 per limited tendon, one
        # spring-damper row per tendon (present with or without `constraints`), and one row per
        # dof for joint friction and the maximum joint speed
        limited = [j for j in range(m.njnt) if m.jnt_limited[j] and params.constraints]
        self._limit_jnt = wp.array(np.asarray(limited, np.int32), dtype=wp.int32, device=dev)
        limited_tendons = [t for t in range(m.ntendon) if m.tendon_limited[t] and params.constraints]
        self._limit_tendon = wp.array(np.asarray(limited_tendons, np.int32), dtype=wp.int32,
                                      device=dev)
        equality_rows = int(structs.equality_rows(m)["eq_rownum"].sum()) if params.constraints else 0
        self._rows_at = constraints.row_layout(self.contact_capacity, len(limited),
                                               len(limited_tendons), equality_rows, m.ntendon,
                                               m.nv if params.constraints else 0)
        self.nrow = self._rows_at.end
        dof_span = structs.tree_spans(model)[0]
        tendon_dofs = [m.jnt_dofadr[m.wrap_jnt[a:a + k]] for a, k in zip(m.tendon_adr, m.tendon_num)]
        # a tendon equality's row spans both tendons' dofs
        tendon_dofs += [np.concatenate([tendon_dofs[t] for t in (t1, t2) if t >= 0])
                        for kind, t1, t2 in zip(m.eq_type, m.eq_obj1, m.eq_obj2)
                        if kind == EqualityType.TENDON]
        self.row_width = constraints.row_width(dof_span, tendon_dofs)
        madr, mnum, mass_col = structs.mass_matrix_layout(m.dof_parent)

        # sensors (`sensors`): one 6D wrench per site that carries a force or torque sensor, and
        # the Newton-Euler pass that gives it (and every body's acceleration) only when a sensor
        # reads accelerations or forces between bodies
        self.sensor_sites = m.force_sensor_sites
        self._sensor_site = wp.array(np.asarray(self.sensor_sites, np.int32), dtype=wp.int32, device=dev)
        self._sensor_site_body = wp.array(np.asarray(m.site_body[self.sensor_sites], np.int32)
                                          if self.sensor_sites else np.zeros(0, np.int32),
                                          dtype=wp.int32, device=dev)
        self._sensor_accelerations = bool(np.isin(m.sensor_type, [
            SensorType.FORCE, SensorType.TORQUE, SensorType.ACCELEROMETER,
            SensorType.FRAMELINACC, SensorType.FRAMEANGACC]).any())

        # every per-env array: the declared structs (`structs`), allocated in one loop each
        self.sizes = dict(nq=m.nq, nv=m.nv, nbody=m.nbody, njnt=m.njnt, nu=m.nu,
                          ntendon=m.ntendon, ngeom=m.ngeom, nsite=m.nsite,
                          nsensor_site=len(self.sensor_sites), nsensordata=m.nsensordata,
                          ncontact=self.contact_capacity,
                          ncandidate=collision.CANDIDATES_PER_SLOT * self.contact_capacity,
                          nrow=self.nrow, row_width=self.row_width, nmass=len(mass_col),
                          nlimit=2 * len(limited), neq=m.neq, neqrow=equality_rows)
        gravity = m.gravity if params.gravity is None else np.asarray(params.gravity)
        initial = {
            EnvParams: dict(
                body_mass=m.body_mass, body_inertia=m.body_inertia,
                geom_friction=m.geom_friction[:, 0], geom_restitution=np.zeros(m.ngeom),
                geom_size=m.geom_size, geom_pos=m.geom_pos, site_pos=m.site_pos.reshape(-1, 3),
                joint_stiffness=m.jnt_stiffness, joint_range=m.jnt_range.reshape(-1, 2),
                dof_damping=m.dof_damping, dof_armature=m.dof_armature,
                dof_frictionloss=m.dof_frictionloss,
                dof_max_velocity=np.full(m.nv, params.max_joint_velocity),
                actuator_gear=m.actuator_gear, actuator_gain=m.actuator_gain,
                actuator_kp=m.actuator_kp, actuator_kv=m.actuator_kv,
                tendon_stiffness=m.tendon_stiffness, tendon_damping=m.tendon_damping,
                tendon_range=m.tendon_range.reshape(-1, 2),
                tendon_limit_stiffness=m.tendon_limit_stiffness,
                tendon_rest_length=m.tendon_rest_length, tendon_offset=m.tendon_offset,
                gravity=gravity, eq_active=m.eq_active & params.constraints,
                eq_anchor=m.eq_anchor, eq_frame=m.eq_frame, eq_polycoef=m.eq_polycoef),
            State: dict(q=m.qpos0),
        }
        self._structs = {struct: structs.allocate(struct, N, self.sizes, dev, initial.get(struct))
                         for struct in structs.STRUCTS}
        self._p, self._s, self._c, self._d, self._contacts, self._rows = (
            self._structs[struct] for struct in structs.STRUCTS)
        self._views = {f.public: structs.public_tensor(getattr(self._structs[struct], name), f,
                                                       self.sizes)
                       for struct in structs.STRUCTS for name, f in struct.fields.items()
                       if f.public}

        # where each stored entry (i, j) of the mass matrix goes in a dense [nv, nv] matrix, and
        # its mirror (j, i) (`mass_matrix`)
        entry_row = np.repeat(np.arange(m.nv), mnum)
        self._qm_dense_at = torch.as_tensor(np.stack([np.concatenate([entry_row, mass_col]),
                                                      np.concatenate([mass_col, entry_row])]),
                                            dtype=torch.int64, device=self.torch_device)

        self._setup_cpu_shards(cpu_threads)
        self.forward()

    # ------------------------------------------------------------------ pipeline
    # the stages of one substep, in order, then those that run once after the last substep
    SUBSTEP_STAGES = ("kinematics", "collision", "dynamics", "applied_forces",
                      "solve_unconstrained", "constraint_rows", "solve_constraints", "integrate")
    FINAL_STAGES = ("kinematics", "constraint_outputs")

    def step(self, timings: dict | None = None) -> None:
        """Advance every env by `params.dt`.

        timings: for profiling; a dict that receives, per stage name (`SUBSTEP_STAGES`,
        `FINAL_STAGES`), the seconds the stage took in this step, added to what it holds. The
        step then runs stage by stage, the device synchronized after each (on CUDA without the
        step's graph, so the stages sum to more than a graphed step); results are the same.
        With several CPU threads, each stage's time is summed over the threads.
        """
        run = self._step_kernels if timings is None else lambda: self._timed_stages(timings)
        if self.device.is_cuda:
            self._run_on_device(self._step_graph if timings is None else run)
        else:
            self._run_sharded(run)

    def _step_kernels(self, stage=None) -> None:
        stage = stage or (lambda name: getattr(self, "_" + name)())
        for _ in range(self.params.substeps):
            for name in self.SUBSTEP_STAGES:
                stage(name)
        for name in self.FINAL_STAGES:  # poses and velocities of the new state, for the caller
            stage(name)

    def _timed_stages(self, timings: dict) -> None:
        import time

        def stage(name):
            sync = (lambda: wp.synchronize_device(self.device)) if self.device.is_cuda else (
                lambda: None)
            sync()
            start = time.perf_counter()
            getattr(self, "_" + name)()
            sync()
            timings[name] = timings.get(name, 0.0) + time.perf_counter() - start
        self._step_kernels(stage)

    def forward(self) -> None:
        """Recompute poses, velocities and bias forces from q, qd (no time passes)."""
        def run():
            self._kinematics()
            self._dynamics()
        self._run(run)

    def collide(self) -> None:
        """Contact detection alone, at the current kinematics (for debugging: step() runs it)."""
        self._run_on_device(self._collision) if self.device.is_cuda else self._collision()

    def _collision(self) -> None:
        n, m, c, st = self.num_envs, self.model, self._contacts, self._s
        if self.contact_capacity == 0:
            return
        self._launch(collision.geom_frames, (n, m.ngeom), [self._m, self._p, self._meshes, st])
        self._shard_of(c.count).zero_()
        if len(self._pairs):
            # a GPU runs a thread per (env, pair); a CPU thread per env walks its pairs
            kernel, dim = ((collision.narrowphase, (n, len(self._pairs))) if self.device.is_cuda
                           else (collision.narrowphase_per_env, n))
            self._launch(kernel, dim, [self._m, self._pairs, self._p, self._meshes, self._hfields,
                                       self.params.contact_offset, st, c])
            if self.device.is_cuda:
                self._launch(collision.order_by_pair, n, [c])
            self._launch(collision.keep_deepest, n, [c])

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
        bit for bit. A shard's launches see the declared per-env structs (`structs.shard`) and
        their arrays restricted to its envs; model-wide arrays are passed whole.
        """
        self._shard_local = threading.local()
        self._shards, self._pool = [], None
        self._control_words = wp.zeros(1, dtype=wp.uint32, device="cpu")   # float_mode
        if self.device.is_cuda:
            return
        threads = cpu_threads or max(1, min(os.cpu_count() or 1, self.num_envs // 64))
        threads = min(threads, self.num_envs)
        if threads == 1:
            return
        bounds = np.linspace(0, self.num_envs, threads + 1).round().astype(int)
        self._shards = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
        self._control_words = wp.zeros(len(self._shards), dtype=wp.uint32, device="cpu")
        # each per-env struct, and each of its arrays (by address), per shard
        self._shard_parts = {}
        for struct, whole in self._structs.items():
            for lo, hi in self._shards:
                part = structs.shard(struct, whole, lo, hi)
                self._shard_parts[(lo, hi), id(whole)] = part
                for name in struct.fields:
                    array = getattr(whole, name)
                    if array.size:
                        self._shard_parts[(lo, hi), array.ptr] = getattr(part, name)
        self._pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="myriad-sim")
        weakref.finalize(self, self._pool.shutdown, wait=False)

    def _shard_of(self, a):
        """`a` restricted to the current thread's envs (unchanged outside a sharded run)."""
        shard = getattr(self._shard_local, "range", None)
        if shard is None:
            return a
        if isinstance(a, wp.array):
            if not a.size or (shard, a.ptr) not in self._shard_parts:
                return a        # model-wide, or empty
            part = self._shard_parts[shard, a.ptr]
            # a view of a per-env array with another shape (qacc as [N, 1, nv]) keeps its shape
            return part if part.shape[1:] == a.shape[1:] else a[shard[0]:shard[1]]
        return self._shard_parts.get((shard, id(a)), a)

    def _run(self, fn) -> None:
        """fn's per-env launches: on the device's stream, or on the CPU shards."""
        self._run_on_device(fn) if self.device.is_cuda else self._run_sharded(fn)

    def _run_sharded(self, fn) -> None:
        """Run fn's launches on this thread, or each shard's on a pool thread, with denormals
        flushed to zero on the thread (`float_mode`)."""
        if not self._shards:
            with float_mode.flushing_denormals(self._control_words):
                fn()
            return

        def run(k, shard):
            self._shard_local.range = shard
            try:
                with float_mode.flushing_denormals(self._control_words[k:k + 1]):
                    fn()
            finally:
                self._shard_local.range = None

        for future in [self._pool.submit(run, k, shard) for k, shard in enumerate(self._shards)]:
            future.result()

    def _kinematics(self) -> None:
        self._launch(kinematics.kinematics, self.num_envs, [self._m, self._s])
        if self.model.nsite:
            self._launch(kinematics.site_frames, (self.num_envs, self.model.nsite),
                         [self._m, self._p, self._s])

    def _dynamics(self) -> None:
        self._launch(dynamics.bias_forces, self.num_envs, [self._m, self._p, self._s, self._d])

    def _applied_forces(self) -> None:
        self._launch(forces.body_wrenches, self.num_envs, [self._m, self._s, self._c, self._d])
        self._launch(forces.generalized_forces, self.num_envs,
                     [self._m, self._p, self.h, self._s, self._c, self._d])

    def _solve_unconstrained(self) -> None:
        self._launch(dynamics.solve_acceleration, self.num_envs, [
            self._m, self._p, self._s, self._d,
            self._s.qacc.reshape((self.num_envs, 1, self.model.nv))])

    def _constraint_rows(self) -> None:
        if self.nrow == 0:
            return
        sp = self.params
        self._launch(constraints.build_rows, self.num_envs, [
            self._m, self._rows_at, self.h, sp.rest_offset, sp.bounce_threshold_velocity,
            self._limit_jnt, self._limit_tendon, self._p, self._s, self._d, self._contacts,
            self._rows])

    def _solve_constraints(self) -> None:
        sp = self.params
        self._launch(solver_tgs.solve, self.num_envs, [
            self._m, self._rows_at, self._limit_jnt, self.h, sp.position_iterations,
            sp.velocity_iterations, int(sp.solver == "tgs"), sp.max_depenetration_velocity,
            self._d, self._contacts, self._rows, self._s])

    def _integrate(self) -> None:
        self._launch(integrate.integrate, self.num_envs, [self._m, self._s])

    def contact_overflow(self) -> int:
        """Number of envs whose contacts did not all fit their slots in the last substep.

        The extra contacts were dropped (never written elsewhere). The first time any overflow is
        seen, a warning names the capacity to raise. Reads the device: call it from the host
        loop now and then, not inside a captured step.
        """
        over = int((self.contact_count > self.contact_capacity).sum())
        if over and not self._warned_overflow:
            self._warned_overflow = True
            warnings.warn(f"{over} of {self.num_envs} envs found more than their "
                          f"{self.contact_capacity} contact slots (most: "
                          f"{int(self.contact_count.max())}); raise "
                          "SimParams(contacts_per_env=...)", RuntimeWarning, stacklevel=2)
        return over

    @property
    def mass_matrix(self) -> torch.Tensor:
        """[N, nv, nv] joint-space mass matrix with armature, of the current kinematics (after
        step() or forward()).

        Computed on each read (the step factors M without forming it: `dynamics`), as a new
        dense tensor: zero between dofs of which neither is an ancestor of the other.
        """
        self._run(lambda: self._launch(dynamics.mass_matrix, self.num_envs,
                                       [self._m, self._p, self._s, self._d]))
        n, nv = self.num_envs, self.model.nv
        dense = torch.zeros(n, nv, nv, device=self.torch_device)
        rows, cols = self._qm_dense_at
        dense[:, rows, cols] = wp.to_torch(self._d.qm).repeat(1, 2)
        return dense

    def _constraint_outputs(self) -> None:
        self._launch(solver_tgs.constraint_forces, self.num_envs, [
            self._m, self._rows_at, self.h, self._rows, self._contacts])
        # sensors: site poses and velocities are current (the final kinematics computed them)
        if self._sensor_accelerations:
            self._launch(sensors.force_sensors, self.num_envs, [
                self._m, self._p, self.h, self._sensor_site_body, self._sensor_site, self._s,
                self._contacts, self._d])
        if self.model.nsensor:
            self._launch(sensors.sensor_readings, self.num_envs, [
                self._m, self._p, self._s, self._contacts, self._d])

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
        return self._jacobians("body", kinematics.body_jacobians, self.model.nbody)

    def site_jacobians(self) -> torch.Tensor:
        """[N, nsite, 6, nv] at each site, world frame: rows 0-2 linear, 3-5 angular."""
        return self._jacobians("site", kinematics.site_jacobians, self.model.nsite)

    def _jacobians(self, kind, kernel, count) -> torch.Tensor:
        if kind not in self._jac:  # allocated on first use: most tasks never ask
            self._jac[kind] = wp.zeros((self.num_envs, count, 6, self.model.nv), dtype=wp.float32,
                                       device=self.device)
        inputs = [self._m, self._s, self._jac[kind]]
        launch = lambda: self._launch(kernel, (self.num_envs, count), inputs)
        self._run_on_device(launch) if self.device.is_cuda else launch()
        return wp.to_torch(self._jac[kind])

    def __repr__(self) -> str:
        return f"Simulator({self.model!r}, num_envs={self.num_envs}, device={self.device})"


structs.add_public_views(Simulator)
