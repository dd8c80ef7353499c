"""Stage 4, constraint rows in joint space: contacts (normal + two friction rows) and joint limits.

One thread per env. Each row r has a Jacobian J_r (a 1 x nv row: the rate of the constraint's
coordinate per generalized velocity), the response M⁻¹J_rᵀ through the same LᵀDL factor as the
unconstrained solve (so implicit damping and drives are part of it), and 1/(J M⁻¹ Jᵀ). Rows sit
at fixed slots: contact slot k owns rows 3k (normal), 3k+1 and 3k+2 (friction), then each
limited joint owns two rows (lower, upper), then each limited tendon. Unused slots are marked inactive and skipped.

Rows are tree-sparse: each row records in `row_span` the dofs it can touch, as two [lo, hi)
ranges (the dof trees of its one or two bodies, or of its dofs; the second range empty when
there is one tree). J and M⁻¹Jᵀ are zero outside them (the mass matrix is block-diagonal over
dof trees), so building, sweeping and reading a row costs its trees' size, not nv, and a row
stores only those dofs: column c < hi1 - lo1 holds dof lo1 + c, the columns after it the second
range (`_col`). The row width is the model's widest span (`row_width`): two trees, or a tendon's
trees, at most nv; 64 free boxes store 12 columns per row instead of 384.

Each row's starting impulse (warm start) is the final impulse of the same constraint in the last
substep: the same contact (pair and feature, e.g. the same box corner) or the same limit. A
resting contact then starts converged instead of being rebuilt from zero by a few sweeps.
"""

import warp as wp

from .dynamics import solve_span, solve_span3
from .spatial import velocity_at
from .structs import EnvParams, ModelArrays
from .types import DOF, FRICTION, FRICTION2, INACTIVE, NORMAL, SOFT


@wp.struct
class RowLayout:
    """Where each family of rows starts among an env's rows, fixed when the simulator is built.
    The families are contiguous, in this order: contacts from row 0 (3 rows per contact slot:
    normal, two friction), joint limits (2 per limited joint: lower, upper), hard tendon limits
    (2 per limited tendon), tendon spring-dampers (1 per tendon), dofs (1 per dof: dry friction
    and speed cap; none without constraints)."""
    joint_limits: int    # first joint-limit row
    tendon_limits: int   # first tendon-limit row
    springs: int         # first tendon spring-damper row
    dofs: int            # first dof row
    end: int             # number of rows


def row_layout(contact_slots: int, limited_joints: int, limited_tendons: int, tendons: int,
               dof_rows: int) -> RowLayout:
    layout = RowLayout()
    layout.joint_limits = 3 * contact_slots
    layout.tendon_limits = layout.joint_limits + 2 * limited_joints
    layout.springs = layout.tendon_limits + 2 * limited_tendons
    layout.dofs = layout.springs + tendons
    layout.end = layout.dofs + dof_rows
    return layout


# a limit row is active when the joint is within this distance (rad or m) of its limit, plus
# the distance it can travel in two substeps
LIMIT_MARGIN = wp.constant(0.1)


def row_width(dof_tree_span, tendon_dofs) -> int:
    """Columns a row needs: its widest possible span, at most nv. A contact touches two dof
    trees at most, a tendon row the trees between its joints' (one range), any other row one
    tree. `dof_tree_span` [nv, 2] per dof; `tendon_dofs` the dofs of each tendon's joints."""
    nv = len(dof_tree_span)
    sizes = sorted({(int(lo), int(hi)) for lo, hi in dof_tree_span}, key=lambda s: s[0] - s[1])
    widest = sum(hi - lo for lo, hi in sizes[:2])
    for dofs in tendon_dofs:
        if len(dofs):
            spans = dof_tree_span[list(dofs)]
            widest = max(widest, int(spans[:, 1].max() - spans[:, 0].min()))
    return min(widest, nv)


@wp.func
def _col(sp: wp.vec4i, i: int):
    """The column of dof i in a row of span sp (i lies in one of its two ranges)."""
    if i >= sp[0] and i < sp[1]:
        return i - sp[0]
    return sp[1] - sp[0] + i - sp[2]


@wp.func
def _width(sp: wp.vec4i):
    return sp[1] - sp[0] + sp[3] - sp[2]


@wp.func
def _add_contact_jacobian(m: ModelArrays, e: int, body: int, point: wp.vec3, n: wp.vec3,
                          t1: wp.vec3, t2: wp.vec3, sign: float,
                          body_x: wp.array2d(dtype=wp.transform),
                          cdof: wp.array2d(dtype=wp.spatial_vector), jac: wp.array3d(dtype=float),
                          r: int, sp: wp.vec4i):
    """J[r + d] += sign · (n, t1, t2)[d]ᵀ · (velocity of `point` fixed to `body`, per dof), for
    the three rows r, r+1, r+2 of a contact: one walk of the body's ancestor dofs."""
    if body < 0:
        return
    ref = wp.transform_get_translation(body_x[e, m.body_root[body]])
    j = m.body_last_dof[body]
    while j >= 0:
        u = sign * velocity_at(cdof[e, j], point - ref)
        c = _col(sp, j)
        jac[e, r, c] = jac[e, r, c] + wp.dot(n, u)
        jac[e, r + 1, c] = jac[e, r + 1, c] + wp.dot(t1, u)
        jac[e, r + 2, c] = jac[e, r + 2, c] + wp.dot(t2, u)
        j = m.dof_parent[j]


@wp.func
def _spans(a: wp.vec2i, b: wp.vec2i):
    """Two dof ranges as one row span (lo1, hi1, lo2, hi2): the second is empty when it is the
    first or when either is empty."""
    if a[0] == a[1] or (a[0] == b[0] and a[1] == b[1]):
        return wp.vec4i(b[0], b[1], 0, 0)
    if b[0] == b[1]:
        return wp.vec4i(a[0], a[1], 0, 0)
    return wp.vec4i(a[0], a[1], b[0], b[1])


@wp.func
def _zero_row(a: wp.array3d(dtype=float), e: int, r: int, sp: wp.vec4i):
    for c in range(_width(sp)):
        a[e, r, c] = 0.0


@wp.func
def _row_dot(a: wp.array3d(dtype=float), e: int, r: int, v: wp.array2d(dtype=float),
             sp: wp.vec4i):
    """a[e, r] · v[e] over the row's span."""
    s = float(0.0)
    o = sp[1] - sp[0] - sp[2]     # column of dof i in the second range: o + i
    for i in range(sp[0], sp[1]):
        s = s + a[e, r, i - sp[0]] * v[e, i]
    for i in range(sp[2], sp[3]):
        s = s + a[e, r, o + i] * v[e, i]
    return s


@wp.func
def _row_norm(jac: wp.array3d(dtype=float), minv_jt: wp.array3d(dtype=float), e: int, r: int,
              sp: wp.vec4i):
    """J_r M⁻¹ J_rᵀ over the row's span."""
    s = float(0.0)
    for c in range(_width(sp)):
        s = s + jac[e, r, c] * minv_jt[e, r, c]
    return s


@wp.func
def _solve_row(m: ModelArrays, e: int, factor: wp.array2d(dtype=float),
               x: wp.array3d(dtype=float), r: int, sp: wp.vec4i):
    solve_span(m, e, factor, x, r, sp[0], sp[1], 0)
    solve_span(m, e, factor, x, r, sp[2], sp[3], sp[1] - sp[0])


@wp.func
def _set_inv_mass(jac: wp.array3d(dtype=float), minv_jt: wp.array3d(dtype=float), e: int, r: int,
                  sp: wp.vec4i, row_inv_mass: wp.array2d(dtype=float),
                  row_type: wp.array2d(dtype=wp.int32), kind: int):
    """1/(J M⁻¹ Jᵀ) of row r, which becomes `kind`; a row that moves nothing (e.g. between two
    static shapes) is dropped."""
    w = _row_norm(jac, minv_jt, e, r, sp)
    if w > 1.0e-12:
        row_inv_mass[e, r] = 1.0 / w
        row_type[e, r] = kind
    else:
        row_inv_mass[e, r] = 0.0
        row_type[e, r] = INACTIVE


@wp.func
def _copy_row(src: wp.array3d(dtype=float), dst: wp.array3d(dtype=float), e: int, r: int,
              sp: wp.vec4i):
    for c in range(_width(sp)):
        dst[e, r, c] = src[e, r, c]


@wp.func
def _finish_row(m: ModelArrays, e: int, r: int, sp: wp.vec4i, jac: wp.array3d(dtype=float),
                factor: wp.array2d(dtype=float), minv_jt: wp.array3d(dtype=float),
                row_inv_mass: wp.array2d(dtype=float), row_type: wp.array2d(dtype=wp.int32),
                kind: int):
    """Response M⁻¹J_rᵀ and 1/(J M⁻¹ Jᵀ) of row r from its J."""
    _copy_row(jac, minv_jt, e, r, sp)
    _solve_row(m, e, factor, minv_jt, r, sp)
    _set_inv_mass(jac, minv_jt, e, r, sp, row_inv_mass, row_type, kind)


@wp.func
def _tendon_span(m: ModelArrays, t: int):
    """The dof trees of a fixed tendon's joints, as one range (the trees between them included)."""
    lo = m.nv
    hi = int(0)
    for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
        tree = m.dof_tree_span[m.jnt_dofadr[m.wrap_jnt[w]]]
        lo = wp.min(lo, tree[0])
        hi = wp.max(hi, tree[1])
    return wp.vec4i(lo, wp.max(lo, hi), 0, 0)


@wp.kernel
def build_rows(m: ModelArrays, layout: RowLayout, h: float, rest_offset: float,
               bounce_threshold: float,
               geom_body: wp.array(dtype=wp.int32), geom_friction: wp.array2d(dtype=float),
               geom_restitution: wp.array2d(dtype=float),
               contact_capacity: int, contact_count: wp.array(dtype=wp.int32),
               contact_geom: wp.array2d(dtype=wp.vec2i), contact_key: wp.array2d(dtype=wp.int32),
               contact_pos: wp.array2d(dtype=wp.vec3),
               contact_normal: wp.array2d(dtype=wp.vec3), contact_dist: wp.array2d(dtype=float),
               # warm start: the last substep's contact keys and final impulses
               prev_key: wp.array2d(dtype=wp.int32), prev_count: wp.array(dtype=wp.int32),
               lam: wp.array2d(dtype=float),
               limit_jnt: wp.array(dtype=wp.int32), joint_range: wp.array2d(dtype=wp.vec2),
               limit_tendon: wp.array(dtype=wp.int32), params: EnvParams,
               dof_frictionloss: wp.array2d(dtype=float),
               dof_max_velocity: wp.array2d(dtype=float),
               body_x: wp.array2d(dtype=wp.transform), cdof: wp.array2d(dtype=wp.spatial_vector),
               q: wp.array2d(dtype=float), qd: wp.array2d(dtype=float),
               qacc: wp.array2d(dtype=float), factor: wp.array2d(dtype=float),
               # outputs
               row_type: wp.array2d(dtype=wp.int32), row_err: wp.array2d(dtype=float),
               row_inv_mass: wp.array2d(dtype=float), row_mu: wp.array2d(dtype=float),
               row_bounce: wp.array2d(dtype=float), row_dir: wp.array2d(dtype=wp.vec3),
               row_k: wp.array2d(dtype=float), row_d: wp.array2d(dtype=float),
               row_span: wp.array2d(dtype=wp.vec4i),
               jac: wp.array3d(dtype=float), minv_jt: wp.array3d(dtype=float),
               lam_init: wp.array2d(dtype=float)):
    e = wp.tid()
    ncontact = wp.min(contact_count[e], contact_capacity)
    # slots past the contact count are skipped by the solver: only the used ones are built
    hint = int(0)
    for k in range(ncontact):
        pair = contact_geom[e, k]
        b1 = geom_body[pair[0]]
        b2 = geom_body[pair[1]]
        n = contact_normal[e, k]
        p = contact_pos[e, k]
        # tangent basis: any orthonormal pair (the friction disk is isotropic)
        t1 = wp.cross(n, wp.vec3(1.0, 0.0, 0.0))
        if wp.length_sq(t1) < 1.0e-6:
            t1 = wp.cross(n, wp.vec3(0.0, 1.0, 0.0))
        t1 = wp.normalize(t1)
        t2 = wp.cross(n, t1)
        none = wp.vec2i(0, 0)
        sp1 = none
        sp2 = none
        if b1 >= 0:
            sp1 = m.body_tree_span[b1]
        if b2 >= 0:
            sp2 = m.body_tree_span[b2]
        sp = _spans(sp1, sp2)
        mu = 0.5 * (geom_friction[e, pair[0]] + geom_friction[e, pair[1]])
        restitution = 0.5 * (geom_restitution[e, pair[0]] + geom_restitution[e, pair[1]])
        # the three rows together: normal (3k), then the two friction rows; J is the velocity
        # of body 2's point relative to body 1's, along each direction
        r0 = 3 * k
        for d in range(3):
            row_span[e, r0 + d] = sp
            _zero_row(jac, e, r0 + d, sp)
        _add_contact_jacobian(m, e, b2, p, n, t1, t2, 1.0, body_x, cdof, jac, r0, sp)
        _add_contact_jacobian(m, e, b1, p, n, t1, t2, -1.0, body_x, cdof, jac, r0, sp)
        row_dir[e, r0] = n
        row_dir[e, r0 + 1] = t1
        row_dir[e, r0 + 2] = t2
        for d in range(3):
            row_type[e, r0 + d] = NORMAL + d      # NORMAL, FRICTION, FRICTION2
            row_inv_mass[e, r0 + d] = 0.0         # response not built yet
            row_mu[e, r0 + d] = mu
            row_err[e, r0 + d] = 0.0
            row_bounce[e, r0 + d] = 0.0
            lam_init[e, r0 + d] = 0.0
        row_err[e, r0] = contact_dist[e, k] - rest_offset
        # approach speed before the solve (unconstrained velocity qd + h·qacc)
        approach = _row_dot(jac, e, r0, qd, sp) + h * _row_dot(jac, e, r0, qacc, sp)
        if approach < -bounce_threshold:
            row_bounce[e, r0] = -restitution * approach
        # warm start from the same contact (same pair and feature) of the last substep
        # (contacts mostly come in the same order as in the last substep, so the search starts
        # after the last match and wraps around; in the rare case of two contacts of one pair
        # sharing a key, e.g. two box corners in one face quadrant, either impulse is a guess)
        same = int(-1)
        npre = prev_count[e]
        for jj in range(npre):
            j = (hint + jj) % npre
            if prev_key[e, j] == contact_key[e, k]:
                same = j
                hint = j + 1
                break
        # the response is built now if the contact starts with an impulse, else by the solver
        # once the contact first pushes (most contacts in the contact offset never do)
        if same >= 0:
            warm3 = wp.vec3(lam[e, 3 * same], lam[e, 3 * same + 1], lam[e, 3 * same + 2])
            if warm3[0] != 0.0 or warm3[1] != 0.0 or warm3[2] != 0.0:
                build_contact_rows(m, e, r0, sp, jac, factor, minv_jt, row_inv_mass, row_type)
                for d in range(3):
                    if row_type[e, r0 + d] != INACTIVE:
                        lam_init[e, r0 + d] = warm3[d]
    for k in range(ncontact):
        prev_key[e, k] = contact_key[e, k]
    prev_count[e] = ncontact

    base = layout.joint_limits
    for li in range(limit_jnt.shape[0]):
        j = limit_jnt[li]
        dof = m.jnt_dofadr[j]
        x = q[e, m.jnt_qposadr[j]]
        reach = LIMIT_MARGIN + 2.0 * h * wp.abs(qd[e, dof])
        for side in range(2):
            r = base + 2 * li + side
            _limit_row(m, e, r, side, x, joint_range[e, j], reach, h, jac, factor, minv_jt,
                       row_inv_mass, row_type, row_err, row_mu, row_bounce, lam, lam_init)
            row_inv_mass[e, r] = 0.0     # response not built yet
            # built now if the limit starts with an impulse, else by the solver once it pushes
            warm = lam[e, r]   # the same limit's impulse in the last substep (0 if inactive)
            if row_type[e, r] != INACTIVE and warm != 0.0:
                build_dof_row(m, e, r, dof, 1.0 - 2.0 * float(side), NORMAL, jac, factor,
                              minv_jt, row_inv_mass, row_type, row_span)
                if row_type[e, r] != INACTIVE:
                    lam_init[e, r] = warm
    # hard tendon limits (limit stiffness 0): J = coef on each tendon joint
    base = layout.tendon_limits
    for lt in range(limit_tendon.shape[0]):
        t = limit_tendon[lt]
        beg = m.tendon_adr[t]
        length = params.tendon_offset[e, t]
        speed = float(0.0)
        for w in range(beg, beg + m.tendon_num[t]):
            jj = m.wrap_jnt[w]
            length = length + m.wrap_coef[w] * q[e, m.jnt_qposadr[jj]]
            speed = speed + m.wrap_coef[w] * qd[e, m.jnt_dofadr[jj]]
        reach = LIMIT_MARGIN + 2.0 * h * wp.abs(speed)
        for side in range(2):
            r = base + 2 * lt + side
            _limit_row(m, e, r, side, length, params.tendon_range[e, t], reach, h, jac, factor,
                       minv_jt, row_inv_mass, row_type, row_err, row_mu, row_bounce, lam, lam_init)
            if params.tendon_limit_stiffness[e, t] > 0.0:
                row_type[e, r] = INACTIVE  # a limit spring (forces stage) instead
                lam_init[e, r] = 0.0
            if row_type[e, r] != INACTIVE:
                sp = _tendon_span(m, t)
                row_span[e, r] = sp
                _zero_row(jac, e, r, sp)
                for w in range(beg, beg + m.tendon_num[t]):
                    c = m.jnt_dofadr[m.wrap_jnt[w]] - sp[0]
                    jac[e, r, c] = jac[e, r, c] + (1.0 - 2.0 * float(side)) * m.wrap_coef[w]
                warm = lam[e, r]
                _finish_row(m, e, r, sp, jac, factor, minv_jt, row_inv_mass, row_type, NORMAL)
                if row_type[e, r] != INACTIVE:
                    lam_init[e, r] = warm
    # tendon spring-dampers (PhysX semantics): one soft row per tendon measuring L (J = coef) and
    # pushing each joint with recip/N; the limit spring (limit stiffness > 0) joins outside
    # [lower, upper]
    base = layout.springs
    for t in range(m.ntendon):
        r = base + t
        row_type[e, r] = INACTIVE
        lam_init[e, r] = 0.0
        beg = m.tendon_adr[t]
        count = float(m.tendon_num[t])
        length = params.tendon_offset[e, t]
        for wi in range(beg, beg + m.tendon_num[t]):
            length = length + m.wrap_coef[wi] * q[e, m.jnt_qposadr[m.wrap_jnt[wi]]]
        stiff = params.tendon_stiffness[e, t] / count
        force = -stiff * (length - params.tendon_rest_length[e, t])
        k_lim = params.tendon_limit_stiffness[e, t] / count
        if m.tendon_limited[t] != 0 and k_lim > 0.0:
            lim = params.tendon_range[e, t]
            if length < lim[0]:
                force = force - k_lim * (length - lim[0])
                stiff = stiff + k_lim
            if length > lim[1]:
                force = force - k_lim * (length - lim[1])
                stiff = stiff + k_lim
        damp = params.tendon_damping[e, t] / count
        if stiff > 0.0 or damp > 0.0:
            sp = _tendon_span(m, t)
            row_span[e, r] = sp
            _zero_row(jac, e, r, sp)
            _zero_row(minv_jt, e, r, sp)
            for wi in range(beg, beg + m.tendon_num[t]):
                c = m.jnt_dofadr[m.wrap_jnt[wi]] - sp[0]
                jac[e, r, c] = jac[e, r, c] + m.wrap_coef[wi]
                minv_jt[e, r, c] = minv_jt[e, r, c] + m.wrap_recip[wi]
            _solve_row(m, e, factor, minv_jt, r, sp)
            w_eff = _row_norm(jac, minv_jt, e, r, sp)
            if w_eff > 1.0e-12:
                row_type[e, r] = SOFT
                row_inv_mass[e, r] = 1.0 / w_eff
                row_k[e, r] = stiff
                row_d[e, r] = damp
                # the spring's error, expressed as the length offset that stiff alone would hold
                row_err[e, r] = 0.0
                if stiff > 0.0:
                    row_err[e, r] = -force / stiff
    # one row per dof, J = e_dof: dry friction (bounded impulse) and the maximum joint speed.
    # Its response M⁻¹e_dof (a column of M⁻¹) is what costs; a dof without dry friction needs it
    # only once the dof exceeds its cap, so it is left unbuilt here (row_inv_mass 0) and the
    # solver builds it then (`build_dof_row`). Present always: impulses from other rows can push
    # a dof past its cap within the solve (and a row only near the cap let a humanoid under
    # random torques blow up: measured).
    base = layout.dofs
    for dof in range(layout.end - layout.dofs):
        r = base + dof
        warm = lam[e, r]
        bound = dof_frictionloss[e, dof] * h
        cap = dof_max_velocity[e, dof]
        row_type[e, r] = INACTIVE
        lam_init[e, r] = 0.0
        if cap > 0.0:
            row_type[e, r] = DOF
            row_inv_mass[e, r] = 0.0
            row_mu[e, r] = bound
            row_k[e, r] = cap
            if bound > 0.0:
                build_dof_row(m, e, r, dof, 1.0, DOF, jac, factor, minv_jt, row_inv_mass,
                              row_type, row_span)
                if row_type[e, r] != INACTIVE:
                    lam_init[e, r] = wp.clamp(warm, -bound, bound)


@wp.func
def build_contact_rows(m: ModelArrays, e: int, r0: int, sp: wp.vec4i,
                       jac: wp.array3d(dtype=float), factor: wp.array2d(dtype=float),
                       minv_jt: wp.array3d(dtype=float), row_inv_mass: wp.array2d(dtype=float),
                       row_type: wp.array2d(dtype=wp.int32)):
    """Responses M⁻¹Jᵀ and 1/(J M⁻¹ Jᵀ) of a contact's three rows r0 (normal), r0+1, r0+2
    (friction) from their J, in one walk of the factor; friction goes with its normal row."""
    for d in range(3):
        _copy_row(jac, minv_jt, e, r0 + d, sp)
    solve_span3(m, e, factor, minv_jt, r0, sp[0], sp[1], 0)
    solve_span3(m, e, factor, minv_jt, r0, sp[2], sp[3], sp[1] - sp[0])
    _set_inv_mass(jac, minv_jt, e, r0, sp, row_inv_mass, row_type, NORMAL)
    _set_inv_mass(jac, minv_jt, e, r0 + 1, sp, row_inv_mass, row_type, FRICTION)
    _set_inv_mass(jac, minv_jt, e, r0 + 2, sp, row_inv_mass, row_type, FRICTION2)
    if row_type[e, r0] == INACTIVE:
        row_type[e, r0 + 1] = INACTIVE
        row_type[e, r0 + 2] = INACTIVE


@wp.func
def build_dof_row(m: ModelArrays, e: int, r: int, dof: int, sign: float, kind: int,
                  jac: wp.array3d(dtype=float), factor: wp.array2d(dtype=float),
                  minv_jt: wp.array3d(dtype=float), row_inv_mass: wp.array2d(dtype=float),
                  row_type: wp.array2d(dtype=wp.int32), row_span: wp.array2d(dtype=wp.vec4i)):
    """Row r along one dof, J = sign·e_dof over its dof tree, as a `kind` row: its response and
    1/(J M⁻¹ Jᵀ). A joint limit (NORMAL; sign -1 for the upper side) or a dof row (DOF)."""
    sp = _spans(m.dof_tree_span[dof], wp.vec2i(0, 0))
    row_span[e, r] = sp
    _zero_row(jac, e, r, sp)
    jac[e, r, dof - sp[0]] = sign
    _finish_row(m, e, r, sp, jac, factor, minv_jt, row_inv_mass, row_type, kind)


@wp.func
def _limit_row(m: ModelArrays, e: int, r: int, side: int, x: float, lim: wp.vec2, reach: float,
               h: float, jac: wp.array3d(dtype=float), factor: wp.array2d(dtype=float),
               minv_jt: wp.array3d(dtype=float), row_inv_mass: wp.array2d(dtype=float),
               row_type: wp.array2d(dtype=wp.int32), row_err: wp.array2d(dtype=float),
               row_mu: wp.array2d(dtype=float), row_bounce: wp.array2d(dtype=float),
               lam: wp.array2d(dtype=float), lam_init: wp.array2d(dtype=float)):
    """Mark a lower (side 0) or upper (side 1) limit row active when within reach of its limit."""
    err = x - lim[0]
    if side == 1:
        err = lim[1] - x
    row_type[e, r] = INACTIVE
    lam_init[e, r] = 0.0
    if err < reach:
        row_type[e, r] = NORMAL
        row_err[e, r] = err
        row_mu[e, r] = 0.0
        row_bounce[e, r] = 0.0
