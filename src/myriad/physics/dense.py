"""Loops over contiguous runs of floats: a constraint row's columns, a dof's row of the factor.

Every row-sized loop of the engine goes through these few functions: J·v and v += M⁻¹Jᵀ·λ
over a row's span (`row_dot`, `row_apply`) and building rows (`row_fill`, `row_copy`,
`rows_dot_at`). They are native code
(`wp.func_native`, compiled by Warp for the CPU and for CUDA alike) because a Warp array index
wraps negative indices and multiplies by the stride on every access, and a `range` loop with
runtime bounds keeps a generic iterator: in these loops that overhead, not the arithmetic, was
the cost on a CPU (moving the factorization's inner loop here
took the humanoid's unconstrained-solve stage from 4.8 to 3.7 ms per step at 1024 envs, one
thread; the factorization now has a form of its own, `dynamics.articulated_factor`). Here each
loop walks plain pointers from one address.

Rows: `a[e, r]` of an [env, row, column] array, holding the dofs of its span `sp` (two dof
ranges [sp[0], sp[1]) and [sp[2], sp[3]), stored one after the other: `constraints`);
velocities `v[e]` of an [env, dof] array. Every engine array is contiguous (allocated whole by
`build.allocate`; a CPU shard is a range of envs). Nothing happens for an empty run.

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
    const float* row = wp::address(a, e, r, 0);
    const float* ve = wp::address(v, e, 0);
    float s = 0.0f;
    const int n1 = sp[1] - sp[0];
    const float* v1 = ve + sp[0];
""" + VECTOR_LOOP + """
    for (int i = 0; i < n1; ++i) s += row[i] * v1[i];
    const int n2 = sp[3] - sp[2];
    const float* v2 = ve + sp[2];
""" + VECTOR_LOOP + """
    for (int i = 0; i < n2; ++i) s += row[n1 + i] * v2[i];
    return s;
""")
def row_dot(a: wp.array3d(dtype=float), e: int, r: int, v: wp.array2d(dtype=float),
            sp: wp.vec4i) -> float:
    """a[e, r] · v[e] over the row's span."""
    ...


@wp.func_native("""
    if (dl == 0.0f) return;
    const float* row = wp::address(a, e, r, 0);
    float* ve = wp::address(v, e, 0);
    const int n1 = sp[1] - sp[0];
    float* v1 = ve + sp[0];
""" + VECTOR_LOOP + """
    for (int i = 0; i < n1; ++i) v1[i] += dl * row[i];
    const int n2 = sp[3] - sp[2];
    float* v2 = ve + sp[2];
""" + VECTOR_LOOP + """
    for (int i = 0; i < n2; ++i) v2[i] += dl * row[n1 + i];
""")
def row_apply(v: wp.array2d(dtype=float), e: int, dl: float, a: wp.array3d(dtype=float), r: int,
              sp: wp.vec4i):
    """v[e] += dl · a[e, r] over the row's span: a row's response M⁻¹J_rᵀ applied to the
    velocity, or, given J, a row's generalized force."""
    ...


# a world's dofs are shared among its lanes by index: dof i is lane i % lanes's (the
# cooperative solve: each lane reads and writes its own dofs of v, so only sums cross lanes)
_LANE_RANGES = """
    const int n1 = sp[1] - sp[0];
    const int s1 = sp[0] + ((lane - sp[0] % lanes) % lanes + lanes) % lanes;
    const int s2 = sp[2] + ((lane - sp[2] % lanes) % lanes + lanes) % lanes;
"""


@wp.func_native("""
    const float* row = wp::address(a, e, r, 0);
    const float* ve = wp::address(v, e, 0);
    float s = 0.0f;
""" + _LANE_RANGES + """
    for (int i = s1; i < sp[1]; i += lanes) s += row[i - sp[0]] * ve[i];
    for (int i = s2; i < sp[3]; i += lanes) s += row[n1 + i - sp[2]] * ve[i];
    return s;
""")
def row_dot_lane(a: wp.array3d(dtype=float), e: int, r: int, v: wp.array2d(dtype=float),
                 sp: wp.vec4i, lane: int, lanes: int) -> float:
    """The part of a[e, r] · v[e] over the row's span on `lane`'s dofs (i % lanes == lane)."""
    ...


@wp.func_native("""
    if (dl == 0.0f) return;
    const float* row = wp::address(a, e, r, 0);
    float* ve = wp::address(v, e, 0);
""" + _LANE_RANGES + """
    for (int i = s1; i < sp[1]; i += lanes) ve[i] += dl * row[i - sp[0]];
    for (int i = s2; i < sp[3]; i += lanes) ve[i] += dl * row[n1 + i - sp[2]];
""")
def row_apply_lane(v: wp.array2d(dtype=float), e: int, dl: float, a: wp.array3d(dtype=float),
                   r: int, sp: wp.vec4i, lane: int, lanes: int):
    """v[e] += dl · a[e, r] over the row's span, on `lane`'s dofs only (the same arithmetic
    per entry as row_apply)."""
    ...


@wp.func_native("""
    return acc + dl * x;
""")
def add_scaled(acc: float, dl: float, x: float) -> float:
    """acc + dl·x, in the form row_apply's loop writes it (`v += dl * row`): the compiler
    contracts both alike (an FMA on CPUs and GPUs that have one), so a sum gathered one term
    at a time equals the one row_apply scatters, bit for bit."""
    ...


@wp.func_native("""
    const float* ap = wp::address(a, e, ra, oa);
    const float* bp = wp::address(b, e, rb, ob);
    float s = 0.0f;
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) s += ap[i] * bp[i];
    return s;
""")
def rows_dot_at(a: wp.array3d(dtype=float), ra: int, oa: int, b: wp.array3d(dtype=float),
                rb: int, ob: int, e: int, n: int) -> float:
    """a[e, ra, oa:oa + n] · b[e, rb, ob:ob + n]: J_a M⁻¹ J_bᵀ from J_a and the response of b
    over a dof range the two rows' spans share, at its columns in each (with ra = rb and both
    offsets 0, a row's J M⁻¹ Jᵀ)."""
    ...


@wp.func_native("""
    float* yp = wp::address(y, e, r, 0);
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) yp[i] = value;
""")
def row_fill(y: wp.array3d(dtype=float), e: int, r: int, value: float, n: int):
    """y[e, r, :n] = value."""
    ...


@wp.func_native("""
    float* yp = wp::address(y, e, r, 0);
    const float* xp = wp::address(x, e, r, 0);
""" + VECTOR_LOOP + """
    for (int i = 0; i < n; ++i) yp[i] = xp[i];
""")
def row_copy(y: wp.array3d(dtype=float), x: wp.array3d(dtype=float), e: int, r: int, n: int):
    """y[e, r, :n] = x[e, r, :n]."""
    ...
