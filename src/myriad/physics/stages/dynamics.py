"""Stage 3, dynamics: bias forces (RNEA), the factor of the mass matrix from the articulated-body
inertias, the solve for qacc, and the mass matrix itself (CRBA) for `Simulator.mass_matrix`.

A world's lanes (`lanes`) take the bodies of one tree level at a time: parents first for the
accelerations, children first for the subtree sums, where each body gathers its children's
share (highest index first, the order of a walk from the last body to the first); then its
dofs or its dof trees. All spatial quantities of a tree are taken at that tree's reference point
(see `spatial`), so inertias of a parent and its children add directly.

The mass matrix has the branch-induced sparsity of the kinematic tree: entry (i, j) is nonzero
only if dof j is on the path from dof i to the world (`dof_parent` chain). The factor
M = Lᵀ D L and the solves below touch only those entries (Featherstone's LTDL, as MuJoCo's
`mj_factorM`), so their cost is O(nv · depth²) instead of O(nv³).

Storage (MuJoCo's sparse layout, `structs.mass_matrix_layout`): M and its factor keep, for each
dof i, one contiguous row: (i, i) at `dof_madr[i]`, then (i, j) for its ancestors j, nearest
first, `dof_mnum[i]` entries in all, columns in `mass_col`. The solves read each row in one
run: no `dof_parent` chain is walked. 64 free boxes store 64 × 21 entries; the humanoid 27 rows
of at most 15 (243 in all, against 729 for its square block).
"""

import warp as wp

from ..lanes import level_body, level_range, stop, sync, world_lane
from ..spatial import (force_cross, inertia_about_point, inertia_matrix, inertia_times,
                       motion_cross)
from ..structs import Dynamics, EnvParams, ModelArrays, Options, State
from ..types import BALL, FREE


@wp.func
def body_inertia(m: ModelArrays, p: EnvParams, s: State, e: int, b: int):
    """Body b's inertia at its tree's reference point: (mass, first moment h = m·c, rotational
    inertia about the point)."""
    mass = p.body_mass[e, b]
    c = s.body_com[e, b] - wp.transform_get_translation(s.body_x[e, m.body_root[b]])
    return mass, mass * c, inertia_about_point(mass, c, p.body_inertia[e, b],
                                               s.body_iframe[e, b])


@wp.kernel
def mass_matrix(m: ModelArrays, p: EnvParams,
                s: State,       # in: body_x, body_com, body_iframe, cdof
                d: Dynamics):   # out: qm; scratch: crb_m, crb_h, crb_i (subtree inertias)
    """Joint-space mass matrix with armature (CRBA), in the sparse layout above."""
    e = wp.tid()
    for b in range(m.nbody):
        mass, h, rot_inertia = body_inertia(m, p, s, e, b)
        d.crb_m[e, b] = mass
        d.crb_h[e, b] = h
        d.crb_i[e, b] = rot_inertia
    # children before parents: accumulate subtrees (same tree => same reference point)
    for k in range(m.nbody):
        b = m.nbody - 1 - k
        parent = m.body_parent[b]
        if parent >= 0:
            d.crb_m[e, parent] = d.crb_m[e, parent] + d.crb_m[e, b]
            d.crb_h[e, parent] = d.crb_h[e, parent] + d.crb_h[e, b]
            d.crb_i[e, parent] = d.crb_i[e, parent] + d.crb_i[e, b]
    for i in range(m.nv):
        b = m.dof_body[i]
        f = inertia_times(d.crb_m[e, b], d.crb_h[e, b], d.crb_i[e, b], s.cdof[e, i])
        a = m.dof_madr[i]
        d.qm[e, a] = wp.dot(s.cdof[e, i], f) + p.dof_armature[e, i]
        for t in range(1, m.dof_mnum[i]):
            d.qm[e, a + t] = wp.dot(s.cdof[e, m.mass_col[a + t]], f)


@wp.func(inline=True)
def newton_euler(m: ModelArrays, p: EnvParams, s: State, e: int, lane: int, lanes: int,
                 active: bool, qd_before: wp.array2d(dtype=float), inv_h: float,
                 qacc: wp.array2d(dtype=float), from_qacc: bool, d: Dynamics):
    """Forward pass of Newton-Euler, level by level (parents first): each body's acceleration
    and the force it needs, I·a + v ×* I·v, into d.cacc and d.cfrc.

    Accelerations come from the velocity-product terms plus (qd - qd_before)·inv_h (inv_h = 0:
    none, for the bias force), or plus `qacc` when `from_qacc`. Gravity enters as an upward
    acceleration of the world, less the share `body_gravcomp` of each body's weight that an
    applied force at its centre of mass holds up (MuJoCo's gravcomp). (A function called once per thread, the bodies' work inline:
    a CPU build passes the structs to a function by value, a copy per call.)
    """
    world_acc = wp.spatial_vector()
    if active:      # (a thread past the last world reads nothing of it)
        world_acc = wp.spatial_vector(wp.vec3(), -p.gravity[e])
    for k in range(m.nlevel):
        start, end = level_range(m, k, lane, lanes, active, False)
        for i in range(start, end, lanes):
            b = level_body(m, i, lanes, False)
            parent = m.body_parent[b]
            a = world_acc
            if parent >= 0:
                a = d.cacc[e, parent]
            if m.body_jntnum[b] > 0:
                for k in range(m.jnt_dofadr[m.body_jntadr[b]], m.body_last_dof[b] + 1):
                    rate = (s.qd[e, k] - qd_before[e, k]) * inv_h
                    if from_qacc:
                        rate = qacc[e, k]
                    a = a + s.cdof_dot[e, k] * s.qd[e, k] + s.cdof[e, k] * rate
            d.cacc[e, b] = a
            mass, h, rot_inertia = body_inertia(m, p, s, e, b)
            v = s.cvel[e, b]
            d.cfrc[e, b] = inertia_times(mass, h, rot_inertia, a) + force_cross(
                v, inertia_times(mass, h, rot_inertia, v))
            if m.body_gravcomp[b] != 0.0:
                d.cfrc[e, b] = d.cfrc[e, b] - m.body_gravcomp[b] * inertia_times(
                    mass, h, rot_inertia, world_acc)
        if lanes > 1:
            sync()


@wp.func(inline=True)
def subtree_sums(m: ModelArrays, e: int, lane: int, lanes: int, active: bool,
                 x: wp.array2d(dtype=wp.spatial_vector)):
    """x[b] <- the sum of x over b's subtree. One lane walks the bodies from the last to the
    first, adding each into its parent; lanes go level by level (children first), each body
    gathering its children's, highest index first: the same sums in the same order."""
    if lanes == 1:
        for k in range(stop(m.nbody, 0, active)):
            b = m.nbody - 1 - k
            parent = m.body_parent[b]
            if parent >= 0:
                x[e, parent] = x[e, parent] + x[e, b]
    else:
        for k in range(m.nlevel):
            start, end = level_range(m, k, lane, lanes, active, True)
            for i in range(start, end, lanes):
                b = level_body(m, i, lanes, True)
                total = x[e, b]
                for c in range(m.body_child_adr[b], m.body_child_adr[b] + m.body_child_num[b]):
                    total = total + x[e, m.body_child[c]]
                x[e, b] = total
            sync()


@wp.kernel
def bias_forces(m: ModelArrays, p: EnvParams,
                s: State,       # in: body_x, body_com, body_iframe, qd, cvel, cdof, cdof_dot
                d: Dynamics,    # out: bias; scratch: cacc, cfrc
                lanes: int):
    """Recursive Newton-Euler at qdd = 0: Coriolis, centrifugal and gravity (MuJoCo's qfrc_bias)."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    newton_euler(m, p, s, e, lane, lanes, active, s.qd, 0.0, s.qacc, False, d)
    subtree_sums(m, e, lane, lanes, active, d.cfrc)
    for i in range(lane, stop(m.nv, 0, active), lanes):
        d.bias[e, i] = wp.dot(s.cdof[e, i], d.cfrc[e, m.dof_body[i]])


@wp.func(inline=True)
def articulated_factor(m: ModelArrays, p: EnvParams, s: State, e: int, lane: int, lanes: int,
                       active: bool, implicit_diag: wp.array2d(dtype=float),
                       articulated: wp.array2d(dtype=wp.spatial_matrix),
                       factor: wp.array2d(dtype=float)):
    """factor <- Lᵀ D L of (M + diag(implicit_diag)), from the articulated-body inertias.

    Eliminating dofs from the leaves up (MuJoCo's `mj_factorM` on M) leaves, at dof i, the
    articulated-body inertia IA of i's subtree (Featherstone's ABA): D_i = Sᵢᵀ·IA·Sᵢ (plus
    armature and the implicit terms), L_ij = Sⱼᵀ·IA·Sᵢ / D_i for each ancestor dof j, and the
    parent's IA gains IA − (IA·Sᵢ)(IA·Sᵢ)ᵀ / D_i. The factor is the same; the arithmetic is
    not. Forming M first adds the subtree inertias up to the root (a 100-link chain's root
    entry is 10⁶ times its tip's), and in float32 the elimination then subtracts numbers that
    agree in all their digits: M of a 100-link chain of 0.1 m capsules has condition number
    3·10⁸, its LDL gave qacc wrong by 200 % and the chain exploded under gravity in one step.
    Built from the articulated inertias, which never grow past what a subtree carries, the
    same chain's qacc is within 1 % of MuJoCo's (float64), a 20-link chain's within 1e-4.
    `implicit_diag` holds h·d + h²·k of implicit dampers and drives; `factor` keeps L (strictly
    lower part, on the ancestor pattern) and D⁻¹ (on its diagonal: the solves multiply by it).

    Leaves first: body b takes its own inertia plus what each child passes on, eliminates its
    own dofs from the last to the first, and passes the rest on. One lane walks the bodies from
    the last to the first, adding what b passes on into its parent's slot; lanes go level by
    level, b gathering its children's (left in their own slots), highest index first: the same
    sums in the same order.
    """
    for b in range(lane, stop(m.nbody, 0, active), lanes):
        mass, h, rot_inertia = body_inertia(m, p, s, e, b)
        articulated[e, b] = inertia_matrix(mass, h, rot_inertia)
    if lanes > 1:
        sync()
    for k in range(m.nlevel):
        start, end = level_range(m, k, lane, lanes, active, True)
        for n in range(start, end, lanes):
            b = level_body(m, n, lanes, True)
            ia = articulated[e, b]
            if lanes > 1:
                for c in range(m.body_child_adr[b], m.body_child_adr[b] + m.body_child_num[b]):
                    ia = ia + articulated[e, m.body_child[c]]
            parent = m.body_parent[b]
            if m.body_jntnum[b] > 0:
                first = m.jnt_dofadr[m.body_jntadr[b]]
                i = m.body_last_dof[b]
                while i >= first:
                    u = ia * s.cdof[e, i]
                    inv_d = 1.0 / (wp.dot(s.cdof[e, i], u) + p.dof_armature[e, i]
                                   + implicit_diag[e, i])
                    a = m.dof_madr[i]
                    factor[e, a] = inv_d
                    for t in range(1, m.dof_mnum[i]):
                        factor[e, a + t] = wp.dot(s.cdof[e, m.mass_col[a + t]], u) * inv_d
                    if i > first or parent >= 0:      # a tree's first dof passes nothing on
                        ia = ia - wp.outer(u, u) * inv_d
                    i -= 1
            if lanes > 1:
                articulated[e, b] = ia
            elif parent >= 0:
                articulated[e, parent] = articulated[e, parent] + ia
        if lanes > 1:
            sync()


@wp.func_native("""
    if (hi <= lo) return;
    const float* F = wp::address(factor, e, 0);
    const int* adr = wp::address(m.dof_madr, 0);
    const int* num = wp::address(m.dof_mnum, 0);
    const int* cols = wp::address(m.mass_col, 0);
    const int o = col - lo;                 // dof k of row d sits at X[d][o + k]
    float* X[3];
    for (int d = 0; d < nrows; ++d) X[d] = wp::address(x, e, r + d, 0);
    for (int k = hi - 1; k >= lo; --k) {    // x <- L⁻ᵀ x, leaves first
        const float* fk = F + adr[k];
        const int* ck = cols + adr[k];
        for (int d = 0; d < nrows; ++d) {
            const float xk = X[d][o + k];
            if (xk == 0.0f) continue;       // a row's J is zero off its bodies' chains
            for (int t = 1; t < num[k]; ++t) X[d][o + ck[t]] -= fk[t] * xk;
        }
    }
    for (int k = lo; k < hi; ++k)           // D⁻¹
        for (int d = 0; d < nrows; ++d) X[d][o + k] *= F[adr[k]];
    for (int k = lo; k < hi; ++k) {         // x <- L⁻¹ x, root first: two partial sums a row
        const float* fk = F + adr[k];
        const int* ck = cols + adr[k];
        const int n = num[k];
        for (int d = 0; d < nrows; ++d) {
            float* Xd = X[d] + o;
            float s0 = Xd[k], s1 = 0.0f;
            int t = 1;
            for (; t + 1 < n; t += 2) {
                s0 -= fk[t] * Xd[ck[t]];
                s1 -= fk[t + 1] * Xd[ck[t + 1]];
            }
            if (t < n) s0 -= fk[t] * Xd[ck[t]];
            Xd[k] = s0 + s1;
        }
    }
""")
def solve_span(m: ModelArrays, e: int, factor: wp.array2d(dtype=float),
               x: wp.array3d(dtype=float), r: int, nrows: int, lo: int, hi: int, col: int):
    """x[e, r + d] <- (Lᵀ D L)⁻¹ x[e, r + d] for the nrows (1 to 3) rows from r, over the dofs
    [lo, hi), a whole number of dof trees (the factor never couples two trees); dof lo sits in
    column `col` of x (rows store only the dofs they touch: `constraints`), dof i in
    col + i - lo.

    MuJoCo's `mj_solveM` on the sparse rows: x <- L⁻ᵀ x (each dof, leaves first, subtracts
    its multiple of its row from its ancestors), x <- D⁻¹ x, x <- L⁻¹ x (each dof, root first,
    subtracts its row's dot product with its ancestors' entries). Native code: this is the
    engine's hottest loop (every constraint row built is one solve), and Warp's indexing
    costs more than its arithmetic. A contact's three rows go together, reading each dof's
    factor row once for all three; the dot products keep two partial sums, since one sum's
    chain of dependent adds bounds a CPU.
    """
    ...


@wp.kernel
def solve_acceleration(m: ModelArrays, p: EnvParams,
                       s: State,                        # in: body_x, body_com, body_iframe, cdof
                       d: Dynamics,                     # in: implicit_diag, qfrc; out: factor;
                                                        # scratch: articulated
                       qacc: wp.array3d(dtype=float),   # out: State.qacc viewed as [N, 1, nv]
                       lanes: int):
    """Unconstrained qacc = (M + implicit_diag)⁻¹ qfrc, and the factor the constraint rows use."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    articulated_factor(m, p, s, e, lane, lanes, active, d.implicit_diag, d.articulated, d.factor)
    # the solve, a dof tree per lane: the factor never couples two trees
    for t in range(lane, stop(m.ntree, 0, active), lanes):
        tree = m.tree_dofs[t]
        for i in range(tree[0], tree[1]):
            qacc[e, 0, i] = d.qfrc[e, i]
        solve_span(m, e, d.factor, qacc, 0, 1, tree[0], tree[1], tree[0])


@wp.func
def _group_end(m: ModelArrays, j: int):
    """One past the last dof whose velocity sums with dof j's before any later dof's motion
    subspace moves (`kinematics`): a ball's or a free joint's rotation triple together."""
    jnt = m.dof_jnt[j]
    da = m.jnt_dofadr[jnt]
    t = m.jnt_type[jnt]
    end = j + 1
    if t == BALL:
        end = da + 3
    elif t == FREE and j - da >= 3:
        end = da + 6
    return end


@wp.kernel
def implicit_acceleration(m: ModelArrays, p: EnvParams, opt: Options,
                          s: State,     # in: body_x, body_com, body_iframe, qd, cvel, cdof,
                                        # cdof_dot; in and out: qacc
                          d: Dynamics):  # in: factor; scratch: coriolis_*
    """qacc <- (M + implicit_diag + h·∂bias/∂qd)⁻¹ qfrc, from the explicit qacc = (M +
    implicit_diag)⁻¹ qfrc: MuJoCo's "implicit" integrator for the velocity-product forces
    (its `mjd_rne_vel`), dof damping implicit as before. One thread per world.

    Column j of ∂bias/∂qd, by differentiating Newton-Euler (`newton_euler`) in qd_j: only the
    subtree of j's body moves with it, each of its bodies with velocity derivative cdof_j and
    acceleration derivative cdof_j × (cvel_b - w_j) + cdof_dot_j (w_j: the velocity of j's body
    up to j's own dofs); their force derivatives I·δa + δv ×* I·v + v ×* I·δv sum up the
    subtree; row i reads cdof_i · that sum at i's body when it moves with j, at j's body when
    i's is an ancestor (no other body's force changes), and 0 otherwise. Then, per dof tree
    (the matrix couples no two), B = (M + implicit_diag)⁻¹ ∂bias/∂qd column by column with the
    factor, and (I + h·B) qacc_new = qacc by Gaussian elimination with partial pivoting: O(n³)
    in the tree's n dofs."""
    e = wp.tid()
    h = opt.h
    for b in range(m.nbody):
        mass, hm, rot = body_inertia(m, p, s, e, b)
        inertia = inertia_matrix(mass, hm, rot)
        d.coriolis_inertia[e, b] = inertia
        d.coriolis_momentum[e, b] = inertia * s.cvel[e, b]
    for t in range(m.ntree):
        span = m.tree_dofs[t]
        lo = span[0]
        n = span[1] - lo
        for j in range(lo, span[1]):
            bj = m.dof_body[j]
            cj = s.cdof[e, j]
            w = wp.spatial_vector()
            if m.body_parent[bj] >= 0:
                w = s.cvel[e, m.body_parent[bj]]
            for k in range(m.jnt_dofadr[m.body_jntadr[bj]], _group_end(m, j)):
                w = w + s.cdof[e, k] * s.qd[e, k]
            last = m.body_subtree_end[bj]
            for b in range(bj, last):
                inertia = d.coriolis_inertia[e, b]
                v = s.cvel[e, b]
                da = motion_cross(cj, v - w) + s.cdof_dot[e, j]
                d.coriolis_frc[e, b] = (inertia * da + force_cross(cj, d.coriolis_momentum[e, b])
                                        + force_cross(v, inertia * cj))
            for k in range(last - 1 - bj):
                b = last - 1 - k
                parent = m.body_parent[b]
                d.coriolis_frc[e, parent] = d.coriolis_frc[e, parent] + d.coriolis_frc[e, b]
            for i in range(lo, span[1]):
                bi = m.dof_body[i]
                x = float(0.0)
                if bi >= bj and bi < last:              # i's body moves with j
                    x = wp.dot(s.cdof[e, i], d.coriolis_frc[e, bi])
                elif bi < bj and m.body_subtree_end[bi] >= last:   # an ancestor: all of j's
                    x = wp.dot(s.cdof[e, i], d.coriolis_frc[e, bj])
                d.coriolis_deriv[e, j, i - lo] = x
            solve_span(m, e, d.factor, d.coriolis_deriv, j, 1, lo, span[1], 0)
        # A = I + h·B, A[r, c] kept at coriolis_deriv[lo + c, r]; eliminate with row pivoting
        for c in range(n):
            for r in range(n):
                x = h * d.coriolis_deriv[e, lo + c, r]
                if r == c:
                    x = x + 1.0
                d.coriolis_deriv[e, lo + c, r] = x
        for c in range(n):
            pivot = c
            best = wp.abs(d.coriolis_deriv[e, lo + c, c])
            for r in range(c + 1, n):
                if wp.abs(d.coriolis_deriv[e, lo + c, r]) > best:
                    best = wp.abs(d.coriolis_deriv[e, lo + c, r])
                    pivot = r
            if pivot != c:
                for k in range(n):
                    x = d.coriolis_deriv[e, lo + k, c]
                    d.coriolis_deriv[e, lo + k, c] = d.coriolis_deriv[e, lo + k, pivot]
                    d.coriolis_deriv[e, lo + k, pivot] = x
                x = s.qacc[e, lo + c]
                s.qacc[e, lo + c] = s.qacc[e, lo + pivot]
                s.qacc[e, lo + pivot] = x
            diag = d.coriolis_deriv[e, lo + c, c]
            for r in range(c + 1, n):
                f = d.coriolis_deriv[e, lo + c, r] / diag
                if f != 0.0:
                    for k in range(c, n):
                        d.coriolis_deriv[e, lo + k, r] = (d.coriolis_deriv[e, lo + k, r]
                                                          - f * d.coriolis_deriv[e, lo + k, c])
                    s.qacc[e, lo + r] = s.qacc[e, lo + r] - f * s.qacc[e, lo + c]
        for cc in range(n):
            r = n - 1 - cc
            x = s.qacc[e, lo + r]
            for k in range(r + 1, n):
                x = x - d.coriolis_deriv[e, lo + k, r] * s.qacc[e, lo + k]
            s.qacc[e, lo + r] = x / d.coriolis_deriv[e, lo + r, r]
