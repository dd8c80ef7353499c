"""Denormal floats flushed to zero while the engine's CPU kernels run.

A value decaying towards zero (a damped finger's speed, a warm-start impulse of a contact that
has let go) passes through the denormal range below 1.2e-38, where an x86 core takes a slow
microcode path for every operation that reads or produces one. In a hand resting on its
limits that path cost more than the physics: the hand-and-cube stand-in (`benchmarks/
memory.py`) took 186 ms per step at 1024 envs on one thread with denormals, 110 ms with them
flushed (its kinematics 29 -> 8 ms). PhysX does the same around its step (SSE flush-to-zero
and denormals-are-zero); no result of the engine depends on values that small.

`flushing_denormals(saved)` sets the calling thread's SSE control word (MXCSR) to flush
results and inputs to zero, and restores the caller's word afterwards, so torch and user code
on the same thread see their own mode. It is a pair of one-thread Warp kernels because Warp
runs a CPU kernel on the calling thread, which owns the control word. On other CPUs (ARM) the
kernels do nothing. CUDA does not need it (the GPU computes denormals at full speed).
"""

from contextlib import contextmanager

import warp as wp

_X86 = "#if (defined(__x86_64__) || defined(__i386__)) && !defined(__CUDA_ARCH__)"
FLUSH_TO_ZERO, DENORMALS_ARE_ZERO = 0x8000, 0x0040       # MXCSR bits


@wp.func_native(_X86 + f"""
    const unsigned int word = __builtin_ia32_stmxcsr();
    __builtin_ia32_ldmxcsr(word | {FLUSH_TO_ZERO | DENORMALS_ARE_ZERO}u);
    return word;
#else
    return 0u;
#endif
""")
def _flush_denormals() -> wp.uint32:
    """Set flush-to-zero and denormals-are-zero; return the previous control word."""
    ...


@wp.func_native(_X86 + """
    __builtin_ia32_ldmxcsr(word);
#endif
""")
def _set_control_word(word: wp.uint32):
    ...


@wp.kernel
def enter(saved_out: wp.array(dtype=wp.uint32)):
    saved_out[0] = _flush_denormals()


@wp.kernel
def leave(saved_in: wp.array(dtype=wp.uint32)):
    _set_control_word(saved_in[0])


@contextmanager
def flushing_denormals(saved: wp.array):
    """Run the body with denormals flushed on this thread; `saved`: a one-element uint32 CPU
    array of this thread's own, which holds the caller's control word meanwhile."""
    wp.launch(enter, dim=1, inputs=[saved], device="cpu")
    try:
        yield
    finally:
        wp.launch(leave, dim=1, inputs=[saved], device="cpu")
