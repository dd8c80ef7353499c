"""Stage 3, dynamics: joint-space mass matrix (CRBA), bias forces (RNEA) and the solve for qacc.

One thread per env. All spatial quantities of a tree are taken at that tree's reference point
(see `spatial`), so composite inertias of a parent and its children add directly.

The mass matrix has the branch-induced sparsity of the kinematic tree: entry (i, j) is nonzero
only if dof j is on the path from dof i to the world (`dof_parent` chain). The factorization
M = Lᵀ D L and the solves below touch only those entries (Featherstone's LTDL, as MuJoCo's
`mj_factorM`), so their cost is O(nv · depth²) instead of O(nv³).

Storage: M and its factor are block-diagonal over dof trees (dofs of different trees never
couple), so each env stores only the square block of each tree, one after another:
entry (i, j) of the same tree sits at `dof_madr[i] + j` (`structs.mass_matrix_layout`). 64 free boxes
keep 64 blocks of 6×6 instead of a 384×384 matrix.
"""

import warp as wp

from .spatial import force_cross, inertia_about_point, inertia_times
from .structs import EnvParams, ModelArrays


@wp.kernel
def mass_matrix(m: ModelArrays, p: EnvParams, body_x: wp.array2d(dtype=wp.transform),
                body_com: wp.array2d(dtype=wp.vec3), body_iframe: wp.array2d(dtype=wp.quat),
                cdof: wp.array2d(dtype=wp.spatial_vector),
                # scratch: composite rigid-body inertia of each subtree
                crb_m: wp.array2d(dtype=float), crb_h: wp.array2d(dtype=wp.vec3),
                crb_i: wp.array2d(dtype=wp.mat33),
                qm: wp.array2d(dtype=float)):
    e = wp.tid()
    for b in range(m.nbody):
        ref = wp.transform_get_translation(body_x[e, m.body_root[b]])
        mass = p.body_mass[e, b]
        c = body_com[e, b] - ref
        crb_m[e, b] = mass
        crb_h[e, b] = mass * c
        crb_i[e, b] = inertia_about_point(mass, c, p.body_inertia[e, b], body_iframe[e, b])
    # children before parents: accumulate subtrees (same tree => same reference point)
    for k in range(m.nbody):
        b = m.nbody - 1 - k
        parent = m.body_parent[b]
        if parent >= 0:
            crb_m[e, parent] = crb_m[e, parent] + crb_m[e, b]
            crb_h[e, parent] = crb_h[e, parent] + crb_h[e, b]
            crb_i[e, parent] = crb_i[e, parent] + crb_i[e, b]
    for i in range(m.nv):
        b = m.dof_body[i]
        f = inertia_times(crb_m[e, b], crb_h[e, b], crb_i[e, b], cdof[e, i])
        mi = m.dof_madr[i]
        qm[e, mi + i] = wp.dot(cdof[e, i], f) + p.dof_armature[e, i]
        j = m.dof_parent[i]
        while j >= 0:
            mij = wp.dot(cdof[e, j], f)
            qm[e, mi + j] = mij
            qm[e, m.dof_madr[j] + i] = mij
            j = m.dof_parent[j]


@wp.func
def body_forces(m: ModelArrays, p: EnvParams, e: int, body_x: wp.array2d(dtype=wp.transform),
                body_com: wp.array2d(dtype=wp.vec3), body_iframe: wp.array2d(dtype=wp.quat),
                qd: wp.array2d(dtype=float), qd_before: wp.array2d(dtype=float), inv_h: float,
                cvel: wp.array2d(dtype=wp.spatial_vector),
                cdof: wp.array2d(dtype=wp.spatial_vector),
                cdof_dot: wp.array2d(dtype=wp.spatial_vector),
                cacc: wp.array2d(dtype=wp.spatial_vector), cfrc: wp.array2d(dtype=wp.spatial_vector)):
    """Forward pass of Newton-Euler: each body's acceleration and the force it needs, I·a + v ×* I·v.

    Accelerations come from the velocity-product terms plus (qd - qd_before)·inv_h (inv_h = 0:
    none, for the bias force). Gravity enters as an upward acceleration of the world.
    """
    world_acc = wp.spatial_vector(wp.vec3(), -p.gravity[e])
    for b in range(m.nbody):
        parent = m.body_parent[b]
        a = world_acc
        if parent >= 0:
            a = cacc[e, parent]
        if m.body_jntnum[b] > 0:
            for i in range(m.jnt_dofadr[m.body_jntadr[b]], m.body_last_dof[b] + 1):
                a = a + cdof_dot[e, i] * qd[e, i] + cdof[e, i] * ((qd[e, i] - qd_before[e, i]) * inv_h)
        cacc[e, b] = a
        ref = wp.transform_get_translation(body_x[e, m.body_root[b]])
        mass = p.body_mass[e, b]
        c = body_com[e, b] - ref
        h = mass * c
        rot_inertia = inertia_about_point(mass, c, p.body_inertia[e, b], body_iframe[e, b])
        v = cvel[e, b]
        cfrc[e, b] = inertia_times(mass, h, rot_inertia, a) + force_cross(
            v, inertia_times(mass, h, rot_inertia, v))


@wp.func
def accumulate_subtrees(m: ModelArrays, e: int, cfrc: wp.array2d(dtype=wp.spatial_vector)):
    """Children before parents: each body's force becomes that of its whole subtree."""
    for k in range(m.nbody):
        b = m.nbody - 1 - k
        parent = m.body_parent[b]
        if parent >= 0:
            cfrc[e, parent] = cfrc[e, parent] + cfrc[e, b]


@wp.kernel
def bias_forces(m: ModelArrays, p: EnvParams, body_x: wp.array2d(dtype=wp.transform),
                body_com: wp.array2d(dtype=wp.vec3), body_iframe: wp.array2d(dtype=wp.quat),
                qd: wp.array2d(dtype=float), cvel: wp.array2d(dtype=wp.spatial_vector),
                cdof: wp.array2d(dtype=wp.spatial_vector),
                cdof_dot: wp.array2d(dtype=wp.spatial_vector),
                # scratch
                cacc: wp.array2d(dtype=wp.spatial_vector), cfrc: wp.array2d(dtype=wp.spatial_vector),
                bias: wp.array2d(dtype=float)):
    """Recursive Newton-Euler at qdd = 0: Coriolis, centrifugal and gravity (MuJoCo's qfrc_bias)."""
    e = wp.tid()
    body_forces(m, p, e, body_x, body_com, body_iframe, qd, qd, 0.0, cvel, cdof, cdof_dot, cacc,
                cfrc)
    accumulate_subtrees(m, e, cfrc)
    for i in range(m.nv):
        bias[e, i] = wp.dot(cdof[e, i], cfrc[e, m.dof_body[i]])


@wp.func
def factor_matrix(m: ModelArrays, e: int, qm: wp.array2d(dtype=float),
                  implicit_diag: wp.array2d(dtype=float), factor: wp.array2d(dtype=float)):
    """factor <- Lᵀ D L of (M + diag(implicit_diag)), eliminating from the leaves up.

    `implicit_diag` holds the joint-space damping and stiffness of implicit terms (h·d + h²·k):
    on M's diagonal they make joint damping and PD drives unconditionally stable. `factor`
    keeps L (unit, strictly lower part, on the ancestor pattern) and D (its diagonal).
    """
    nv = m.nv
    for i in range(nv):
        mi = m.dof_madr[i]
        factor[e, mi + i] = qm[e, mi + i] + implicit_diag[e, i]
        j = m.dof_parent[i]
        while j >= 0:
            factor[e, mi + j] = qm[e, mi + j]
            j = m.dof_parent[j]
    for kk in range(nv):
        k = nv - 1 - kk
        mk = m.dof_madr[k]
        dk = factor[e, mk + k]
        i = m.dof_parent[k]
        while i >= 0:
            lki = factor[e, mk + i] / dk
            mi = m.dof_madr[i]
            j = i
            while j >= 0:
                factor[e, mi + j] = factor[e, mi + j] - lki * factor[e, mk + j]
                j = m.dof_parent[j]
            factor[e, mk + i] = lki
            i = m.dof_parent[i]


@wp.func
def solve_span(m: ModelArrays, e: int, factor: wp.array2d(dtype=float),
               x: wp.array3d(dtype=float), r: int, lo: int, hi: int, col: int):
    """x[e, r] <- (Lᵀ D L)⁻¹ x[e, r] over the dofs [lo, hi), a whole number of dof trees (the
    factor never couples two trees), walking only the ancestor chains. Dof lo sits in column
    `col` of x (rows store only the dofs they touch: `constraints`), dof i in col + i - lo."""
    o = col - lo
    for kk in range(lo, hi):
        k = hi - 1 - (kk - lo)
        xk = x[e, r, o + k]
        if xk != 0.0:      # a row's J is often zero off its bodies' ancestor chains
            mk = m.dof_madr[k]
            j = m.dof_parent[k]
            while j >= 0:
                x[e, r, o + j] = x[e, r, o + j] - factor[e, mk + j] * xk
                j = m.dof_parent[j]
    for k in range(lo, hi):
        x[e, r, o + k] = x[e, r, o + k] / factor[e, m.dof_madr[k] + k]
    for k in range(lo, hi):
        mk = m.dof_madr[k]
        j = m.dof_parent[k]
        while j >= 0:
            x[e, r, o + k] = x[e, r, o + k] - factor[e, mk + j] * x[e, r, o + j]
            j = m.dof_parent[j]


@wp.func
def solve_span3(m: ModelArrays, e: int, factor: wp.array2d(dtype=float),
                x: wp.array3d(dtype=float), r: int, lo: int, hi: int, col: int):
    """`solve_span` of rows r, r+1, r+2 together (a contact's normal and friction rows): one
    walk of the ancestor chains and one read of the factor serve all three."""
    o = col - lo
    for kk in range(lo, hi):
        k = hi - 1 - (kk - lo)
        xk = wp.vec3(x[e, r, o + k], x[e, r + 1, o + k], x[e, r + 2, o + k])
        if xk[0] != 0.0 or xk[1] != 0.0 or xk[2] != 0.0:
            mk = m.dof_madr[k]
            j = m.dof_parent[k]
            while j >= 0:
                f = factor[e, mk + j]
                x[e, r, o + j] = x[e, r, o + j] - f * xk[0]
                x[e, r + 1, o + j] = x[e, r + 1, o + j] - f * xk[1]
                x[e, r + 2, o + j] = x[e, r + 2, o + j] - f * xk[2]
                j = m.dof_parent[j]
    for k in range(lo, hi):
        d = factor[e, m.dof_madr[k] + k]
        x[e, r, o + k] = x[e, r, o + k] / d
        x[e, r + 1, o + k] = x[e, r + 1, o + k] / d
        x[e, r + 2, o + k] = x[e, r + 2, o + k] / d
    for k in range(lo, hi):
        xk = wp.vec3(x[e, r, o + k], x[e, r + 1, o + k], x[e, r + 2, o + k])
        mk = m.dof_madr[k]
        j = m.dof_parent[k]
        while j >= 0:
            xk = xk - factor[e, mk + j] * wp.vec3(x[e, r, o + j], x[e, r + 1, o + j],
                                                x[e, r + 2, o + j])
            j = m.dof_parent[j]
        x[e, r, o + k] = xk[0]
        x[e, r + 1, o + k] = xk[1]
        x[e, r + 2, o + k] = xk[2]


@wp.func
def solve_in_place(m: ModelArrays, e: int, factor: wp.array2d(dtype=float),
                   x: wp.array3d(dtype=float), r: int):
    """x[e, r, :] <- (Lᵀ D L)⁻¹ x[e, r, :]."""
    solve_span(m, e, factor, x, r, 0, m.nv, 0)


@wp.kernel
def solve_acceleration(m: ModelArrays, qm: wp.array2d(dtype=float),
                       implicit_diag: wp.array2d(dtype=float), qfrc: wp.array2d(dtype=float),
                       factor: wp.array2d(dtype=float), qacc: wp.array3d(dtype=float)):
    """Unconstrained qacc = (M + implicit_diag)⁻¹ qfrc (qacc viewed as [N, 1, nv])."""
    e = wp.tid()
    factor_matrix(m, e, qm, implicit_diag, factor)
    for i in range(m.nv):
        qacc[e, 0, i] = qfrc[e, i]
    solve_in_place(m, e, factor, qacc, 0)
