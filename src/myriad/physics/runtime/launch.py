"""Where and how the step's kernels run: `Runtime` launches them on the CUDA stream (the whole
step captured once as a CUDA graph and replayed) or on the CPU, the envs split into shards, one
thread each. The block sizes of the cooperative kernels (`lanes`) are declared here (`BlockDim`).

Warp runs a CPU kernel on the calling thread and releases the GIL while it runs, so shards of
envs advance in parallel; every kernel reads and writes its own envs only, so the result is the
same bit for bit with any number of threads. A shard's launches see the per-env structs
(`build.Data`) and their arrays restricted to its envs (`shard`); model-wide arrays are passed
whole. On a CPU thread denormal floats are flushed to zero while the engine runs (`float_mode`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import threading
import weakref
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import torch
import warp as wp

from . import float_mode


@dataclasses.dataclass(frozen=True)
class BlockDim:
    """Threads per block and lanes per world of the cooperative kernels (`lanes`) on CUDA.

    A block holds threads // lanes worlds. One warp per block keeps `sync()` cheap; lanes per
    world follow the parallel work a world offers: a tree level's bodies (widest level: ant 4,
    humanoid 3, a five-finger hand 5) or its dofs and joints (14 to 36 in the seed's tasks).

    The sweeps run one thread per world: on an H100 (2026-11-27, 8,192 worlds,
    `benchmarks/lane_sweep.py`) a block of 32 lanes per world took 10.9 ms per humanoid step
    where one lane took 6.4 (ant 2.1 against 0.62): each row's sum waits on the block twice and
    goes through device memory, for spans of a few dofs. For bodies, rows and dofs the lane
    counts from 2 to 32 were within 20 % of each other, a few tenths of a millisecond.
    """
    threads: int = 32
    bodies: int = 4      # over a tree level's bodies: kinematics, dynamics, forces, force sensors
    dofs: int = 8        # over dofs, joints, contacts or sensors: generalized forces,
                         # integration, constraint forces, sensor readings
    rows: int = 8        # over a family of constraint rows' items: building the rows
    solve: int = 1       # the sweeps: 1, or 0 for a world per block (its sums are the block's)

    def __post_init__(self):
        for name in ("bodies", "dofs", "rows"):
            lanes = getattr(self, name)
            if not 1 <= lanes <= self.threads or self.threads % lanes:
                raise ValueError(f"BlockDim.{name}={lanes}: must divide threads={self.threads}")
        if self.solve not in (0, 1):
            # the sweeps wait on the block inside loops as long as a world's contact count:
            # several worlds in one block would wait different numbers of times (a GPU hangs)
            raise ValueError(f"BlockDim.solve={self.solve}: must be 1 (a thread per world) or 0 "
                             "(a world per block)")


BLOCK_DIM = BlockDim()


def cpu_block_dim() -> int:
    """Threads per block of the cooperative kernels on a CPU: 1 (one lane per world, the CPU's
    own path), or N from the environment variable MYRIAD_CPU_BLOCK_DIM (2 to 1024), which runs
    them as CUDA does, through Warp's cooperative CPU fibers (for tests of the GPU's launch
    configuration on a machine without one)."""
    value = os.environ.get("MYRIAD_CPU_BLOCK_DIM", "1").strip() or "1"
    if not value.isdigit() or not 1 <= int(value) <= 1024:
        raise ValueError(f"MYRIAD_CPU_BLOCK_DIM={value!r}: must be an integer from 1 to 1024")
    return int(value)


def block_threads(device) -> int:
    """Threads per block of the cooperative kernels on `device`."""
    return BLOCK_DIM.threads if wp.get_device(device).is_cuda else cpu_block_dim()


def shard(struct, whole, lo: int, hi: int):
    """`whole` (an instance of a declared per-env struct) restricted to envs [lo, hi): every
    field a view of its rows, no copy."""
    part = struct()
    for name in struct.fields:
        array = getattr(whole, name)
        setattr(part, name, array[lo:hi] if array.size else array)  # empty: nothing to read
    return part


class Runtime:
    """Runs a simulator's launches on its device: `launch` inside `run` (a stage, forward(), a
    read-out) or `run_step` (the step: a CUDA graph, replayed; on a CPU, the shards)."""

    def __init__(self, device, num_envs: int, structs: dict, cpu_threads: int | None):
        if cpu_threads is not None and (not isinstance(cpu_threads, int) or cpu_threads < 1):
            raise ValueError(f"cpu_threads={cpu_threads!r}: must be an integer >= 1 (or None: "
                             "one per CPU core)")
        self.device, self.num_envs = device, num_envs
        self._graph = None
        self._cpu_graphs, self._steps_run = None, 0     # the step on a CPU (`_run_sharded`)
        self._local = threading.local()     # .range: the envs of this thread's shard
        self.shards, self._pool, self._parts = [], None, {}
        self._control_words = wp.zeros(1, dtype=wp.uint32, device="cpu")   # float_mode
        self.block_threads = block_threads(device)
        if self.block_threads > 1 and not device.is_cuda:
            wp.config.enable_cpu_blocks = True
        if device.is_cuda:
            self._stream = wp.Stream(device)
            return
        threads = cpu_threads or max(1, min(os.cpu_count() or 1, num_envs // 64))
        threads = min(threads, num_envs)
        if threads == 1:
            return
        bounds = np.linspace(0, num_envs, threads + 1).round().astype(int)
        self.shards = [(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:])]
        self._control_words = wp.zeros(len(self.shards), dtype=wp.uint32, device="cpu")
        # each per-env struct, and each of its arrays (by address), per shard
        for struct, whole in structs.items():
            for lo, hi in self.shards:
                part = shard(struct, whole, lo, hi)
                self._parts[(lo, hi), id(whole)] = part
                for name in struct.fields:
                    array = getattr(whole, name)
                    if array.size:
                        self._parts[(lo, hi), array.ptr] = getattr(part, name)
        self._pool = ThreadPoolExecutor(max_workers=threads, thread_name_prefix="myriad-sim")
        weakref.finalize(self, self._pool.shutdown, wait=False)

    # ------------------------------------------------------------------ launching
    def launch(self, kernel, dim, inputs) -> None:
        """wp.launch of `kernel` over `dim` (the env count first), restricted to the calling
        thread's shard of envs inside a sharded run."""
        shard = getattr(self._local, "range", None)
        if shard is not None:     # a CPU thread's share of the envs: per-env arrays sliced
            inputs = [self.shard_of(a) for a in inputs]
            size = shard[1] - shard[0]
            dim = (size,) + tuple(dim[1:]) if isinstance(dim, tuple) else size
        wp.launch(kernel, dim=dim, inputs=inputs, device=self.device)

    def launch_lanes(self, kernel, lanes: int, inputs) -> None:
        """Launch a cooperative kernel (`lanes`) with `lanes` threads per world (at most the
        block's threads; 0: the whole block, one world per block) and as many worlds per block
        as fit; the kernel takes the lane count as its last argument."""
        lanes = self.block_threads if lanes == 0 else max(1, min(lanes, self.block_threads))
        per_block = self.block_threads // lanes
        shard = getattr(self._local, "range", None)
        if shard is not None:
            inputs = [self.shard_of(a) for a in inputs]
        worlds = self.num_envs if shard is None else shard[1] - shard[0]
        threads = per_block * lanes
        # (blocks, threads) with blocks of `threads`: wp.tid() is (block, thread), as
        # wp.launch_tiled gives, without its extra Python work per launch
        wp.launch(kernel, dim=(-(-worlds // per_block), threads), inputs=[*inputs, lanes],
                  block_dim=threads, device=self.device)

    def shard_of(self, a):
        """`a` restricted to the current thread's envs (unchanged outside a sharded run)."""
        shard = getattr(self._local, "range", None)
        if shard is None:
            return a
        if isinstance(a, wp.array):
            if not a.size or (shard, a.ptr) not in self._parts:
                return a        # model-wide, or empty
            part = self._parts[shard, a.ptr]
            # a view of a per-env array with another shape (qacc as [N, 1, nv]) keeps its shape
            return part if part.shape[1:] == a.shape[1:] else a[shard[0]:shard[1]]
        return self._parts.get((shard, id(a)), a)

    @contextlib.contextmanager
    def in_shard(self, lo: int, hi: int):
        """Launches and `shard_of` inside see envs [lo, hi) (one of `shards`) alone."""
        self._local.range = (lo, hi)
        try:
            yield
        finally:
            self._local.range = None

    # ------------------------------------------------------------------ running
    def run(self, fn, whole: bool = False) -> None:
        """fn's per-env launches: on the device's stream, or on the CPU shards; `whole`: on the
        calling CPU thread over all envs (launches whose outputs are not per-env structs)."""
        if self.device.is_cuda:
            self._run_on_device(fn)
        elif whole:
            fn()
        else:
            self._run_sharded(fn)

    def run_step(self, fn) -> None:
        """fn's launches as the step: on CUDA captured as a graph the first time (every kernel
        module loaded before the capture) and replayed after, or, when torch is capturing a
        graph of its own (a task's whole step, `VecTask.capture_step`), launched into that
        capture; on a CPU, each shard's launches captured as a CPU graph at the second call
        (the first loads the kernels) and replayed after (`_run_sharded`)."""
        if not self.device.is_cuda:
            return self._run_sharded(fn, step=True)

        def replay():
            if self._graph is None:
                wp.load_module("myriad.physics", device=self.device, recursive=True)
                # only the engine's modules: the default would first load every Warp module
                # the process imported (another library's, compiled for nothing)
                with wp.ScopedCapture(device=self.device, stream=self._stream,
                                      force_module_load=False) as capture:
                    fn()
                self._graph = capture.graph
            wp.capture_launch(self._graph, stream=self._stream)
        if torch.cuda.is_current_stream_capturing():
            wp.load_module("myriad.physics", device=self.device, recursive=True)
            replay = fn
        self._run_on_device(replay)

    def _run_on_device(self, fn) -> None:
        """Run `fn`'s launches on Warp's stream, ordered after and before torch's work; inside
        a capture of torch's, on torch's capturing stream itself (the launches become nodes
        of its graph)."""
        torch_stream = wp.stream_from_torch(torch.cuda.current_stream(
            wp.device_to_torch(self.device)))
        if torch.cuda.is_current_stream_capturing():
            # no wait on Warp's own stream: a capture may depend on captured work only
            with wp.ScopedStream(torch_stream, sync_enter=False):
                fn()
            return
        self._stream.wait_stream(torch_stream)
        with wp.ScopedStream(self._stream):
            fn()
        torch_stream.wait_stream(self._stream)

    def _run_sharded(self, fn, step: bool = False) -> None:
        """Run fn's launches on this thread, or each shard's on a pool thread, with denormals
        flushed to zero on the thread (`float_mode`).

        `step`: fn is the step, whose launches and arguments are the same at every call (as
        the CUDA graph needs them to be). From its second call on, each shard replays a CPU
        graph of them (Warp's CPU capture records the launches without running them), which
        skips the Python work of packing some thirty launches' arguments: about 1.5 ms a
        step on this project's CPU, a few percent of a 1024-env ant step and most of a
        small one's. The replay runs the same kernels on the same arrays: results are
        identical."""
        keys = self.shards or [None]

        def eager(k, key):
            with self.in_shard(*key) if key else contextlib.nullcontext():
                fn()

        def replay(k, key):
            if self._cpu_graphs[k] is None:
                return eager(k, key)
            try:
                wp.capture_launch(self._cpu_graphs[k])
            except RuntimeError:
                # Warp could not bind an argument's memory (as it could not for two arrays at
                # one address: build._host_arrays); it checks every launch's arguments before
                # running any, so this shard runs its launches eagerly from now on
                self._cpu_graphs[k] = None
                eager(k, key)

        launches = eager
        if step:
            if self._cpu_graphs is None and self._steps_run >= 1:
                graphs = []
                for k, key in enumerate(keys):
                    with wp.ScopedCapture(device=self.device) as capture:
                        eager(k, key)
                    graphs.append(capture.graph)
                self._cpu_graphs = graphs
            self._steps_run += 1
            if self._cpu_graphs is not None:
                launches = replay

        def run(k, key):
            # around the replay, not inside the graph: a replay runs on this thread, in the
            # mode this sets (tests/test_api.py)
            with float_mode.flushing_denormals(self._control_words[k:k + 1]):
                launches(k, key)

        if not self.shards:
            run(0, None)
            return
        for future in [self._pool.submit(run, k, key) for k, key in enumerate(keys)]:
            future.result()

    @property
    def replaying(self) -> bool:
        """Whether the step now replays a captured graph (CUDA's, or every CPU shard's)."""
        return self._graph is not None or (
            self._cpu_graphs is not None and all(g is not None for g in self._cpu_graphs))

    def synchronize(self) -> None:
        if self.device.is_cuda:
            wp.synchronize_device(self.device)
