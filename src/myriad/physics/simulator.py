"""`Simulator`: `num_envs` copies of a `Model` stepped together on one device; a thin front.

What it holds, each built in its own place: the device model and the per-env data (`build`),
the runtime that launches kernels on the device (`runtime`), and the public tensors, zero-copy
torch views of the fields declared `public` in `structs` (sim.q, sim.body_mass,
sim.contact_force, ...). A step is `step.step`, the stages in order; `step()` allocates nothing
and, on CUDA, is captured once as a CUDA graph and replayed.
"""

from __future__ import annotations

import time
import warnings

import torch
import warp as wp

from . import build, step as pipeline
from .model import Model
from .params import SimParams
from .runtime import Runtime, resolve_device
from .stages import kinematics, dynamics
from .structs import STRUCTS, VIEWED_AS, Field


class Simulator:
    """`num_envs` independent copies of `model`, stepped together on one device."""

    # Public tensors (sim.q, sim.ctrl, sim.body_mass, sim.contact_force, ...) are the fields
    # declared with a `public` name in `structs` (`add_public_views`, after the class).

    SUBSTEP_STAGES = pipeline.SUBSTEP_STAGES
    FINAL_STAGES = pipeline.FINAL_STAGES

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
        #: what every env shares, on the device (`build.DeviceModel`): for inspection
        self.device_model = build.device_model(model, params, self.device)
        #: every per-env array (`build.Data`: data.state, data.rows, ...): for inspection
        self.data = build.allocate_data(self.device_model, num_envs, self.device)
        #: launches the kernels (`runtime.Runtime`); `runtime.shards`: the CPU threads' envs
        self.runtime = Runtime(self.device, num_envs, self.data.structs, cpu_threads)
        self.sizes = self.device_model.sizes
        self.contact_capacity = self.device_model.contact_capacity
        self.nrow = self.device_model.nrow
        self.row_width = self.sizes["row_width"]
        self.sensor_sites = self.device_model.sensor_sites
        self._views = {f.public: public_tensor(getattr(self.data.structs[struct], name), f,
                                               self.sizes)
                       for struct in STRUCTS for name, f in struct.fields.items() if f.public}
        self._jac = {}
        self._warned_overflow = False
        # where each stored mass-matrix entry (i, j) goes in a dense [nv, nv] matrix, and its
        # mirror (j, i) (`mass_matrix`): on the device once, so that a read copies nothing over
        rows, cols = torch.as_tensor(self.device_model.mass_entries, dtype=torch.int64,
                                     device=self.torch_device)
        self._qm_dense_at = (torch.cat([rows, cols]), torch.cat([cols, rows]))
        self._qm = wp.to_torch(self.data.dynamics.qm)
        self.forward()

    # ------------------------------------------------------------------ the step
    def step(self, timings: dict | None = None) -> None:
        """Advance every env by `params.dt`.

        timings: for profiling; a dict that receives, per stage name (`SUBSTEP_STAGES`,
        `FINAL_STAGES`), the seconds the stage took in this step, added to what it holds. The
        step then runs stage by stage, the device synchronized after each (on CUDA without the
        step's graph, so the stages sum to more than a graphed step); results are the same.
        With several CPU threads, each stage's time is summed over the threads.
        """
        rt, dm, d, substeps = self.runtime, self.device_model, self.data, self.params.substeps
        if timings is None:
            rt.run_step(lambda: pipeline.step(rt, dm, d, substeps))
            return

        def timed(name, run):
            rt.synchronize()
            start = time.perf_counter()
            run(rt, dm, d)
            rt.synchronize()
            timings[name] = timings.get(name, 0.0) + time.perf_counter() - start
        rt.run(lambda: pipeline.step(rt, dm, d, substeps, timed))

    def forward(self) -> None:
        """Recompute poses, velocities, bias forces and applied forces from q, qd and the
        controls (no time passes)."""
        self.runtime.run(lambda: pipeline.forward(self.runtime, self.device_model, self.data))

    def collide(self) -> None:
        """Contact detection alone, at the current kinematics (for debugging: step() runs it)."""
        self.runtime.run(lambda: pipeline.run_collision(self.runtime, self.device_model,
                                                        self.data))

    # ------------------------------------------------------------------ read-outs
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

        Computed on each read (the step factors M without forming it: `stages.dynamics`), as a
        new dense tensor: zero between dofs of which neither is an ancestor of the other.
        """
        d, dm = self.data, self.device_model
        self.runtime.run(lambda: self.runtime.launch(
            dynamics.mass_matrix, self.num_envs, [dm.m, d.env_params, d.state, d.dynamics]))
        n, nv = self.num_envs, self.model.nv
        dense = torch.zeros(n, nv, nv, device=self.torch_device)
        dense[:, self._qm_dense_at[0], self._qm_dense_at[1]] = self._qm.repeat(1, 2)
        return dense

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
            array = wp.zeros((self.num_envs, count, 6, self.model.nv), dtype=wp.float32,
                             device=self.device)
            self._jac[kind] = (array, wp.to_torch(array))
        array, view = self._jac[kind]
        inputs = [self.device_model.m, self.data.state, array]
        # the output is not a per-env struct, which CPU shards would see whole: one thread
        self.runtime.run(lambda: self.runtime.launch(kernel, (self.num_envs, count), inputs),
                         whole=True)
        return view

    @property
    def nbytes(self) -> int:
        """Bytes of every per-env array this simulator allocated (not the optional Jacobians)."""
        return sum(a.capacity for _, _, a in self.data.arrays())

    def __repr__(self) -> str:
        return f"Simulator({self.model!r}, num_envs={self.num_envs}, device={self.device})"


# ---------------------------------------------------------------------------------- public views
def public_tensor(array: wp.array, f: Field, sizes: dict) -> torch.Tensor:
    """The zero-copy torch view of a declared field that its public name shows."""
    view = wp.to_torch(array)
    for axis, d in enumerate(f.dims, start=1):
        if d in VIEWED_AS:
            view = view.narrow(axis, 0, sizes[VIEWED_AS[d]])
    return view


class PublicView:
    """A public per-env tensor of the simulator: a zero-copy torch view of a declared field;
    assigning to a writable one copies into it (broadcasting, shape checked)."""

    def __init__(self, name: str, field: Field):
        self.name, self.writable = name, field.writable
        dims = ", ".join(["N"] + [str(VIEWED_AS.get(d, d)) for d in field.dims])
        self.__doc__ = f"[{dims}] {field.doc}" + ("" if field.writable else " (read-only)")

    def __get__(self, sim, owner=None):
        if sim is None:
            return self
        return sim._views[self.name]

    def __set__(self, sim, value):
        if not self.writable:
            raise AttributeError(f"sim.{self.name} is read-only (the step computes it)")
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


def add_public_views(cls) -> None:
    """Every field declared with a public name becomes a `PublicView` attribute of `cls` (the
    Simulator), read from the instance's `_views`."""
    for struct in STRUCTS:
        for name, f in struct.fields.items():
            if f.public:
                setattr(cls, f.public, PublicView(f.public, f))


add_public_views(Simulator)
