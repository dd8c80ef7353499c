"""Loops over contiguous runs of floats: a constraint row's columns, a dof's row of the factor.

Every row-sized loop of the engine (J·v, v += M⁻¹Jᵀ·λ, the LᵀDL factorization) goes through
these few functions. They are native code (`wp.func_native`, compiled by Warp for
the CPU and for CUDA alike) because a Warp array index wraps negative indices and multiplies by
the stride on every access, and a `range` loop with runtime bounds keeps a generic iterator: in
these loops that overhead, not the arithmetic, was the cost on a CPU (moving the
factorization's inner loop here took the humanoid's unconstrained-solve stage from 4.8 to 3.7 ms
per step at 1024 envs, one thread). Here each loop walks plain pointers from one checked start.

Arguments are 1D views (`a[e, r]`, `v[e]`), contiguous in their last dimension as every
engine array is (allocated whole by `structs.allocate`; a CPU shard is a range of envs); `*_at`
is the offset of the run's first element in its view, `n` the run's length (nothing happens
for n <= 0).

On a CPU the contiguous loops are vectorized 8 floats wide (`VECTOR_LOOP`: clang's default
width here, 16 floats × 4, never runs for rows of 6 to 30 floats); sums are then accumulated in
8 lanes and added at the end, a different rounding order from one term after the other. CUDA
compiles each loop as written, one term after the other. (The sparse LᵀDL solve, which walks a
factor row's columns, is native code of its own: `dynamics.solve_span`.)
"""

import warp as wp

VECTOR_LOOP = """
#if defined(__clang__) && !defined(__CUDA_ARCH__)
#pragma clang loop vectorize_width(8) interleave_count(1)
#endif
"""


@wp.func_native("""
    float s = init;
    if (n <= 0) return s;
    const float* ap = wp::address(a, a_at);
    const float* bp = wp::address(b, b_at);
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) s += ap[i] * bp[i];
    return s;
""")
def dot(init: float, a: wp.array(dtype=float), a_at: int, b: wp.array(dtype=float), b_at: int,
        n: int) -> float:
    """init + Σ a[a_at + i] · b[b_at + i]."""
    ...


@wp.func_native("""
    if (n <= 0) return;
    float* yp = wp::address(y, y_at);
    const float* xp = wp::address(x, x_at);
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) yp[i] += alpha * xp[i];
""")
def axpy(y: wp.array(dtype=float), y_at: int, alpha: float, x: wp.array(dtype=float), x_at: int,
         n: int):
    """y[y_at + i] += alpha · x[x_at + i]."""
    ...


@wp.func_native("""
    if (n <= 0) return;
    float* yp = wp::address(y, y_at);
    const float* xp = wp::address(x, x_at);
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) yp[i] = xp[i];
""")
def copy(y: wp.array(dtype=float), y_at: int, x: wp.array(dtype=float), x_at: int, n: int):
    """y[y_at + i] = x[x_at + i]."""
    ...


@wp.func_native("""
    if (n <= 0) return;
    float* yp = wp::address(y, y_at);
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) yp[i] = value;
""")
def fill(y: wp.array(dtype=float), y_at: int, value: float, n: int):
    """y[y_at + i] = value."""
    ...
