"""Stage 4, constraint rows in joint space: contacts (normal + two friction rows, and torsional
and rolling friction rows where the model asks for them), joint and tendon limits, tendon
spring-dampers, and per-dof friction and speed caps.

One function per family of rows (`build_rows`), a world's lanes (`lanes`) taking a family's items
in turn: rows are independent (only the match of each contact to the last substep's is found
by one lane, in order). Each row r has a Jacobian J_r (a 1 x nv row: the rate of the
constraint's coordinate per generalized velocity), the response M⁻¹J_rᵀ through the same LᵀDL factor as the
unconstrained solve (so implicit damping and drives are part of it), and 1/(J M⁻¹ Jᵀ). Rows sit
at fixed slots: contact slot k owns rows wk (normal), wk+1 and wk+2 (friction), w =
`RowLayout.contact_width` (3; 4 with a torsional row wk+3; 6 with two rolling rows after it),
then each limited joint owns two rows (lower, upper), then each limited tendon. Unused slots
are marked inactive and skipped.

Rows are tree-sparse: each row records in `Rows.span` the dofs it can touch, as two [lo, hi)
ranges (the dof trees of its one or two bodies, or of its dofs; the second range empty when
there is one tree). J and M⁻¹Jᵀ are zero outside them (the mass matrix is block-diagonal over
dof trees), so building, sweeping and reading a row costs its trees' size, not nv, and a row
stores only those dofs: column c < hi1 - lo1 holds dof lo1 + c, the columns after it the second
range (`_col`). The row width is the model's widest span (`row_width`): two trees, or a tendon's
trees, at most nv; 64 free boxes store 12 columns per row instead of 384.

A limit, equality or dof row, and the normal row of a contact with the ground (a plane or
height field), starts from the final impulse of the same row in the last substep (warm start);
other contact rows start from zero. A contact also carries from the last substep (found by its
pair and feature, e.g. the same box corner) its friction anchors, the points of its two bodies
where it began to stick, which its friction rows hold together.
"""

import warp as wp

from .. import dense
from .dynamics import solve_span
from ..lanes import sync, world_lane
from ..spatial import tangents, velocity_at
from ..structs import Contacts, Dynamics, EnvParams, ModelArrays, Options, RowLayout, Rows, State
from ..types import (CONNECT, DOF, EQ_JOINT, EQUALITY, FRICTION, FRICTION2, HFIELD, INACTIVE,
                    NORMAL, PLANE, SOFT, SPIN, TRIMESH, WELD)


# a contact whose J M⁻¹ Jᵀ is below this fraction of its bodies' free 1/m1 + 1/m2 is dropped
UNREACHABLE = wp.constant(1.0e-4)

# a limit row is active when the joint is within this distance (rad or m) of its limit, plus
# the distance it can travel in two substeps
LIMIT_MARGIN = wp.constant(0.1)


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
    last = m.body_last_dof[body]
    if last < 0:
        return
    chain = m.dof_madr[last]      # the mass matrix row of `last` lists it and its ancestors
    for a in range(chain, chain + m.dof_mnum[last]):
        j = m.mass_col[a]
        u = sign * velocity_at(cdof[e, j], point - ref)
        c = _col(sp, j)
        jac[e, r, c] = jac[e, r, c] + wp.dot(n, u)
        jac[e, r + 1, c] = jac[e, r + 1, c] + wp.dot(t1, u)
        jac[e, r + 2, c] = jac[e, r + 2, c] + wp.dot(t2, u)


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
def _body_spans(m: ModelArrays, b1: int, b2: int):
    """The row span of a row between bodies b1 and b2 (-1: the world): their dof trees."""
    none = wp.vec2i(0, 0)
    sp1 = none
    sp2 = none
    if b1 >= 0:
        sp1 = m.body_tree_span[b1]
    if b2 >= 0:
        sp2 = m.body_tree_span[b2]
    return _spans(sp1, sp2)


@wp.func
def _solve_rows(m: ModelArrays, e: int, factor: wp.array2d(dtype=float),
                x: wp.array3d(dtype=float), r: int, nrows: int, sp: wp.vec4i):
    """x[e, r + d] <- M⁻¹ x[e, r + d] for the nrows rows from r, of span sp."""
    solve_span(m, e, factor, x, r, nrows, sp[0], sp[1], 0)
    solve_span(m, e, factor, x, r, nrows, sp[2], sp[3], sp[1] - sp[0])


@wp.func
def _set_inv_mass(rows: Rows, e: int, r: int, sp: wp.vec4i, kind: int):
    """1/(J M⁻¹ Jᵀ) of row r, which becomes `kind`; a row that moves nothing (e.g. between two
    static shapes) is dropped."""
    w = dense.rows_dot_at(rows.jac, r, 0, rows.minv_jt, r, 0, e, _width(sp))
    if w > 1.0e-12:
        rows.inv_mass[e, r] = 1.0 / w
        rows.type[e, r] = kind
    else:
        rows.inv_mass[e, r] = 0.0
        rows.type[e, r] = INACTIVE


@wp.func
def _finish_row(m: ModelArrays, e: int, r: int, sp: wp.vec4i, factor: wp.array2d(dtype=float),
                rows: Rows, kind: int):
    """Response M⁻¹J_rᵀ and 1/(J M⁻¹ Jᵀ) of row r from its J."""
    dense.row_copy(rows.minv_jt, rows.jac, e, r, _width(sp))
    _solve_rows(m, e, factor, rows.minv_jt, r, 1, sp)
    _set_inv_mass(rows, e, r, sp, kind)


@wp.func
def _tendon_span(m: ModelArrays, t: int):
    """The dof trees of a fixed tendon's joints, as one range (the trees between them included);
    a spatial tendon's, fixed at import."""
    if m.tendon_spatial[t] >= 0:
        span = m.tendon_dofspan[t]
        return wp.vec4i(span[0], span[1], 0, 0)
    lo = m.nv
    hi = int(0)
    for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
        tree = m.dof_tree_span[m.jnt_dofadr[m.wrap_jnt[w]]]
        lo = wp.min(lo, tree[0])
        hi = wp.max(hi, tree[1])
    return wp.vec4i(lo, wp.max(lo, hi), 0, 0)


@wp.func
def tendon_length(m: ModelArrays, p: EnvParams, s: State, e: int, t: int):
    """(length, rate of change) of tendon t: offset + Σ coef · q over a fixed tendon's joints,
    offset + its path's length for a spatial one (`tendons`)."""
    length = p.tendon_offset[e, t]
    speed = float(0.0)
    row = m.tendon_spatial[t]
    if row >= 0:
        span = m.tendon_dofspan[t]
        for i in range(span[0], span[1]):
            speed = speed + s.ten_J[e, row, i] * s.qd[e, i]
        return wp.vec2(length + s.ten_length[e, row], speed)
    for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
        j = m.wrap_jnt[w]
        length = length + m.wrap_coef[w] * s.q[e, m.jnt_qposadr[j]]
        speed = speed + m.wrap_coef[w] * s.qd[e, m.jnt_dofadr[j]]
    return wp.vec2(length, speed)


@wp.kernel
def build_rows(m: ModelArrays, opt: Options, layout: RowLayout, p: EnvParams,
               s: State,        # in: q, qd, qacc, body_x, cdof
               d: Dynamics,     # in: factor
               # in: contacts, slid; out: anchor, and the keys and anchors for the next
               # substep (prev_key, prev_count, prev_anchor)
               contacts: Contacts,
               # in: the last substep's impulses (lam); out: everything else
               rows: Rows,
               lanes: int):
    """Every row of one env for this substep, family by family (`RowLayout`); a world's lanes
    take a family's items (contacts, limits, equalities, tendons, dofs) in turn: the rows are
    independent of each other."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    at = wp.vec3i(lane, lanes, int(active))
    h = opt.h
    contact_rows(m, e, at, layout.contact_width, h, opt.rest_offset, opt.bounce_threshold, p, s,
                 d.factor, contacts, rows)
    joint_limit_rows(m, e, at, layout.joint_limits, h, opt.limit_jnt, p, s, d.factor, rows)
    tendon_limit_rows(m, e, at, layout.tendon_limits, h, opt.limit_tendon, p, s, d.factor, rows)
    if layout.springs > layout.equalities:
        equality_rows(m, e, at, layout.equalities, p, s, d.factor, rows)
    tendon_spring_rows(m, e, at, layout.springs, p, s, d.factor, rows)
    dof_rows(m, e, at, layout.dofs, layout.end - layout.dofs, h, p, d.factor, rows)


@wp.func
def contact_rows(m: ModelArrays, e: int, at: wp.vec3i, width: int, h: float,
                 rest_offset: float, bounce_threshold: float, p: EnvParams, s: State,
                 factor: wp.array2d(dtype=float), c: Contacts, rows: Rows):
    """Contact slot k: rows wk (normal), wk+1, wk+2 (sliding friction), and with a width w of 4
    or 6 wk+3 (torsional friction: relative spin about the normal) and wk+4, wk+5 (rolling
    friction: relative rotation about the tangents). Slots past the contact count are skipped
    by the solver: only the used ones are built. `at`: (lane, lanes, active)."""
    ncontact = int(0)
    if at[2] != 0:      # (a thread past the last world reads nothing of it)
        ncontact = wp.min(c.count[e], c.force.shape[1])
    # the same contact (same pair and feature) in the last substep, whose friction anchors it
    # inherits: found by one lane, since contacts mostly come in the same order as in the last
    # substep and the search starts after the last match and wraps around (in the rare case
    # of two contacts of one pair sharing a key, e.g. two box corners in one face quadrant,
    # either one's anchors are a guess, and this order decides)
    if at[0] == 0 and at[2] != 0:
        hint = int(0)
        npre = c.prev_count[e]
        for k in range(ncontact):
            c.match[e, k] = -1
            for jj in range(npre):
                j = (hint + jj) % npre
                if c.prev_key[e, j] == c.key[e, k]:
                    c.match[e, k] = j
                    hint = j + 1
                    break
    if at[1] > 1:
        sync()
    for k in range(at[0], wp.where(at[2] != 0, ncontact, 0), at[1]):
        pair = c.geom[e, k]
        b1 = m.geom_body[pair[0]]
        b2 = m.geom_body[pair[1]]
        n = c.normal[e, k]
        pos = c.pos[e, k]
        # tangent basis: any orthonormal pair (the friction disk is isotropic)
        t1, t2 = tangents(n)
        sp = _body_spans(m, b1, b2)
        # an explicit <pair>'s own friction, else the two geoms' average (PhysX's combine)
        pair_mu = m.pair_friction[c.key[e, k] // 32]
        mu = pair_mu[0]
        if mu < 0.0:
            mu = 0.5 * (p.geom_friction[e, pair[0]] + p.geom_friction[e, pair[1]])
        restitution = 0.5 * (p.geom_restitution[e, pair[0]] + p.geom_restitution[e, pair[1]])
        # the rows together: normal (wk), then the two friction rows; J is the velocity of
        # body 2's point relative to body 1's, along each direction
        r0 = width * k
        for d in range(width):
            rows.span[e, r0 + d] = sp
            dense.row_fill(rows.jac, e, r0 + d, 0.0, _width(sp))
        _add_contact_jacobian(m, e, b2, pos, n, t1, t2, 1.0, s.body_x, s.cdof, rows.jac, r0, sp)
        _add_contact_jacobian(m, e, b1, pos, n, t1, t2, -1.0, s.body_x, s.cdof, rows.jac, r0, sp)
        if width > 3:
            # torsional and rolling rows: body 2's angular velocity relative to body 1's, about
            # n (and t1, t2); bounded by their coefficient times the normal impulse (`solver`)
            axes = wp.matrix_from_rows(n, t1, t2)
            _add_angular_jacobian(m, e, b2, 1.0, axes, width - 3, s.cdof, rows.jac, r0 + 3, sp)
            _add_angular_jacobian(m, e, b1, -1.0, axes, width - 3, s.cdof, rows.jac, r0 + 3, sp)
            for d in range(3, width):
                coefficient = wp.where(d == 3, pair_mu[1], pair_mu[2])
                rows.type[e, r0 + d] = wp.where(coefficient > 0.0, SPIN + d - 3, INACTIVE)
                rows.inv_mass[e, r0 + d] = 0.0
                rows.mu[e, r0 + d] = coefficient
                rows.err[e, r0 + d] = 0.0
                rows.bounce[e, r0 + d] = 0.0
                rows.lam_init[e, r0 + d] = 0.0
            rows.dir[e, r0 + 3] = n
            if width > 4:
                rows.dir[e, r0 + 4] = t1
                rows.dir[e, r0 + 5] = t2
        rows.dir[e, r0] = n
        rows.dir[e, r0 + 1] = t1
        rows.dir[e, r0 + 2] = t2
        for d in range(3):
            rows.type[e, r0 + d] = NORMAL + d      # NORMAL, FRICTION, FRICTION2
            rows.inv_mass[e, r0 + d] = 0.0         # response not built yet
            rows.mu[e, r0 + d] = mu
            rows.err[e, r0 + d] = 0.0
            rows.bounce[e, r0 + d] = 0.0
            rows.lam_init[e, r0 + d] = 0.0
        rows.err[e, r0] = c.dist[e, k] - rest_offset
        # 1/m1 + 1/m2: how easily the two bodies would move if nothing held them (a body no
        # joint moves, such as a massless fixed table, counts as the world)
        free = float(0.0)
        if b1 >= 0 and _moves(m, b1):
            free = free + 1.0 / wp.max(p.body_mass[e, b1], 1.0e-9)
        if b2 >= 0 and _moves(m, b2):
            free = free + 1.0 / wp.max(p.body_mass[e, b2], 1.0e-9)
        rows.k[e, r0] = free
        # approach speed before the solve (unconstrained velocity qd + h·qacc)
        approach = (dense.row_dot(rows.jac, e, r0, s.qd, sp)
                    + h * dense.row_dot(rows.jac, e, r0, s.qacc, sp))
        if approach < -bounce_threshold:
            rows.bounce[e, r0] = -restitution * approach
        same = c.match[e, k]
        # static friction anchors (PhysX's): the points of the two bodies that were at the
        # contact point when the contact began to stick, kept while it holds without sliding
        # (a normal impulse, the friction impulse inside the disk); the friction rows' error
        # is how far apart the two have drifted along the tangents, which the position sweeps
        # undo. The response is built by the solver once the contact first pushes (most
        # contacts in the contact offset never do), and between two moving bodies its
        # impulses start from zero: warm started from the last substep, the impulses of a
        # stack's rows fed the next substep's errors back into it, and three stacked boxes
        # rocked and turned at up to 0.7 rad/s, drifting 8.5 mm in 5 s (`benchmarks/
        # stacks.py`); with the anchors holding the contacts in place instead, 0.01 mm.
        x1 = _pose(s.body_x, e, b1)
        x2 = _pose(s.body_x, e, b2)
        held = int(0)
        if same >= 0:
            if rows.lam[e, width * same] > 0.0 and c.slid[e, same] == 0:
                held = 1
        a1 = wp.vec3()
        a2 = wp.vec3()
        if held != 0:
            a1 = c.prev_anchor[e, same, 0]
            a2 = c.prev_anchor[e, same, 1]
        else:
            a1 = wp.transform_point(wp.transform_inverse(x1), pos)
            a2 = wp.transform_point(wp.transform_inverse(x2), pos)
        c.anchor[e, k, 0] = a1
        c.anchor[e, k, 1] = a2
        # a contact with the ground (a plane, height field or static mesh: a foot) starts from
        # its normal impulse of the last substep, like a limit: a leg pressed down under load
        # otherwise sank 43 mm into the ground in a hard landing (the ant under random torques;
        # 5 mm warm). Other contacts start from zero (above); warm, a link pressed into a fixed
        # robot's base mesh at its joint limit pushed a UR5 1.4 rad past the limit
        ground = m.geom_type[pair[0]]
        if same >= 0 and (ground == PLANE or ground == HFIELD or ground == TRIMESH):
            warm_n = rows.lam[e, width * same]
            if warm_n != 0.0:
                build_contact_rows(m, e, r0, width, sp, factor, rows)
                if rows.type[e, r0] != INACTIVE:
                    rows.lam_init[e, r0] = warm_n
        drift = wp.transform_point(x2, a2) - wp.transform_point(x1, a1)
        rows.err[e, r0 + 1] = wp.dot(drift, t1)
        rows.err[e, r0 + 2] = wp.dot(drift, t2)
    if at[1] > 1:
        sync()       # every lane has read the last substep's keys and anchors
    for k in range(at[0], wp.where(at[2] != 0, ncontact, 0), at[1]):
        c.prev_key[e, k] = c.key[e, k]
        c.prev_anchor[e, k, 0] = c.anchor[e, k, 0]
        c.prev_anchor[e, k, 1] = c.anchor[e, k, 1]
    if at[0] == 0 and at[2] != 0:
        c.prev_count[e] = ncontact


@wp.func
def joint_limit_rows(m: ModelArrays, e: int, at: wp.vec3i, base: int, h: float,
                     limit_jnt: wp.array(dtype=wp.int32), p: EnvParams, s: State,
                     factor: wp.array2d(dtype=float), rows: Rows):
    """Two rows per limited joint (lower, upper), J = ±e_dof."""
    for li in range(at[0], wp.where(at[2] != 0, limit_jnt.shape[0], 0), at[1]):
        j = limit_jnt[li]
        dof = m.jnt_dofadr[j]
        x = s.q[e, m.jnt_qposadr[j]]
        # the rows out of reach stay inactive; the solver takes one in when the joint turns
        # toward its limit fast enough to reach it (`solver_tgs._limit_rows`)
        reach = LIMIT_MARGIN + 2.0 * h * wp.abs(s.qd[e, dof])
        for side in range(2):
            r = base + 2 * li + side
            _limit_row(e, r, side, x, p.joint_range[e, j], reach, rows)
            rows.inv_mass[e, r] = 0.0     # response not built yet
            # built now if the limit starts with an impulse, else by the solver once it pushes
            warm = rows.lam[e, r]   # the same limit's impulse in the last substep (0 if inactive)
            if rows.type[e, r] != INACTIVE and warm != 0.0:
                build_dof_row(m, e, r, dof, 1.0 - 2.0 * float(side), NORMAL, factor, rows)
                if rows.type[e, r] != INACTIVE:
                    rows.lam_init[e, r] = warm


@wp.func
def tendon_limit_rows(m: ModelArrays, e: int, at: wp.vec3i, base: int, h: float,
                      limit_tendon: wp.array(dtype=wp.int32), p: EnvParams, s: State,
                      factor: wp.array2d(dtype=float), rows: Rows):
    """Two rows per limited tendon with hard limits (limit stiffness 0): J = ±coef on each of
    its joints."""
    for lt in range(at[0], wp.where(at[2] != 0, limit_tendon.shape[0], 0), at[1]):
        t = limit_tendon[lt]
        beg = m.tendon_adr[t]
        length_speed = tendon_length(m, p, s, e, t)
        # the margin in the tendon's length units: what its joints travel in LIMIT_MARGIN
        # each (coefficients of 0.01 made 0.1 of length 10 rad, and the Shadow Hand's 40
        # limits that its joints' own limits never let it reach were built every substep)
        per_joint = float(0.0)
        if m.tendon_spatial[t] >= 0:     # a spatial tendon's moment arms instead
            span = m.tendon_dofspan[t]
            for i in range(span[0], span[1]):
                per_joint = per_joint + wp.abs(s.ten_J[e, m.tendon_spatial[t], i])
        else:
            for w in range(beg, beg + m.tendon_num[t]):
                per_joint = per_joint + wp.abs(m.wrap_coef[w])
        reach = LIMIT_MARGIN * per_joint + 2.0 * h * wp.abs(length_speed[1])
        for side in range(2):
            r = base + 2 * lt + side
            _limit_row(e, r, side, length_speed[0], p.tendon_range[e, t], reach, rows)
            if p.tendon_limit_stiffness[e, t] > 0.0:
                rows.type[e, r] = INACTIVE  # a limit spring (tendon_spring_rows) instead
                rows.lam_init[e, r] = 0.0
            if rows.type[e, r] != INACTIVE:
                sp = _tendon_span(m, t)
                rows.span[e, r] = sp
                dense.row_fill(rows.jac, e, r, 0.0, _width(sp))
                _tendon_add(m, s, e, t, 1.0 - 2.0 * float(side), False, rows.jac, r, sp)
                warm = rows.lam[e, r]
                _finish_row(m, e, r, sp, factor, rows, NORMAL)
                if rows.type[e, r] != INACTIVE:
                    rows.lam_init[e, r] = warm


@wp.func
def _pose(body_x: wp.array2d(dtype=wp.transform), e: int, b: int):
    """Pose of body b; the world's (b = -1) is the identity."""
    if b < 0:
        return wp.transform_identity()
    return body_x[e, b]


@wp.func
def _add_angular_jacobian(m: ModelArrays, e: int, body: int, sign: float, axes: wp.mat33,
                          count: int, cdof: wp.array2d(dtype=wp.spatial_vector),
                          jac: wp.array3d(dtype=float), r: int, sp: wp.vec4i):
    """J[r + d] += sign · axes[d]ᵀ·(angular velocity of `body`, per dof) for the first `count`
    rows d of `axes` (a weld's world axes; a contact's normal and tangents)."""
    if body < 0:
        return
    last = m.body_last_dof[body]
    if last < 0:
        return
    chain = m.dof_madr[last]
    for a in range(chain, chain + m.dof_mnum[last]):
        j = m.mass_col[a]
        w = sign * wp.spatial_top(cdof[e, j])
        c = _col(sp, j)
        for d in range(count):
            jac[e, r + d, c] = jac[e, r + d, c] + wp.dot(axes[d], w)


@wp.func
def _tendon_add(m: ModelArrays, s: State, e: int, t: int, scale: float, recip: bool,
                jac: wp.array3d(dtype=float), r: int, sp: wp.vec4i):
    """J[r] += scale · (rate of tendon t's length, per dof); `recip`: a fixed tendon's force
    weights (recip_coef) instead. A spatial tendon's force acts along its rate: the same."""
    row = m.tendon_spatial[t]
    if row >= 0:
        span = m.tendon_dofspan[t]
        for i in range(span[0], span[1]):
            c = _col(sp, i)
            jac[e, r, c] = jac[e, r, c] + scale * s.ten_J[e, row, i]
        return
    for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]):
        c = _col(sp, m.jnt_dofadr[m.wrap_jnt[w]])
        weight = m.wrap_coef[w]
        if recip:
            weight = m.wrap_recip[w]
        jac[e, r, c] = jac[e, r, c] + scale * weight


@wp.func
def _coupling(x1: float, y: float, c: wp.array3d(dtype=float), e: int, i: int):
    """(error, d error / d y) of x1 = c0 + c1·y + c2·y² + c3·y³ + c4·y⁴, MuJoCo's joint and
    tendon equality."""
    value = c[e, i, 0] + y * (c[e, i, 1] + y * (c[e, i, 2] + y * (c[e, i, 3] + y * c[e, i, 4])))
    slope = c[e, i, 1] + y * (2.0 * c[e, i, 2] + y * (3.0 * c[e, i, 3] + y * 4.0 * c[e, i, 4]))
    return wp.vec2(x1 - value, slope)


@wp.func
def _rotation_vector(q: wp.quat):
    """Axis · angle of the rotation q, the angle in [0, π]."""
    v = wp.vec3(q[0], q[1], q[2])
    w = q[3]
    if w < 0.0:
        v = -v
        w = -w
    sine = wp.length(v)
    if sine < 1.0e-9:
        return 2.0 * v
    return v * (2.0 * wp.atan2(sine, w) / sine)


@wp.func
def equality_rows(m: ModelArrays, e: int, at: wp.vec3i, base: int, p: EnvParams, s: State,
                  factor: wp.array2d(dtype=float), rows: Rows):
    """The rows of each active equality constraint (`ModelArrays.eq_rowadr`), hard and
    bilateral: err is the violation (J·v its rate), to be brought to 0.

    connect: 3 rows, the world x, y, z of p1 - p2 (the anchor points on the two bodies);
    weld: those 3, then 3 rows of the rotation vector taking body 2's frame onto body 1's
    (world axes; J: ω1 - ω2); joint and tendon: 1 row, x1 - x1_0 - poly(x2 - x2_0).
    Their responses are built now, and the Cholesky factor of the constraint's block of
    J M⁻¹ Jᵀ (`Rows.eq_chol`), which the solver uses to solve the rows of one constraint
    together."""
    for i in range(at[0], wp.where(at[2] != 0, m.neq, 0), at[1]):
        r = base + m.eq_rowadr[i]
        n = m.eq_rownum[i]
        for a in range(n):
            rows.type[e, r + a] = INACTIVE
            rows.lam_init[e, r + a] = 0.0
        if p.eq_active[e, i] == 0:
            continue
        kind = m.eq_type[i]
        o1 = m.eq_obj1[i]
        o2 = m.eq_obj2[i]
        none = wp.vec2i(0, 0)
        if kind == CONNECT or kind == WELD:
            sp = _body_spans(m, o1, o2)
            for a in range(n):
                rows.span[e, r + a] = sp
                dense.row_fill(rows.jac, e, r + a, 0.0, _width(sp))
            x1 = _pose(s.body_x, e, o1)
            x2 = _pose(s.body_x, e, o2)
            p1 = wp.transform_point(x1, p.eq_anchor[e, i, 0])
            p2 = wp.transform_point(x2, p.eq_anchor[e, i, 1])
            ex = wp.vec3(1.0, 0.0, 0.0)
            ey = wp.vec3(0.0, 1.0, 0.0)
            ez = wp.vec3(0.0, 0.0, 1.0)
            _add_contact_jacobian(m, e, o1, p1, ex, ey, ez, 1.0, s.body_x, s.cdof, rows.jac, r, sp)
            _add_contact_jacobian(m, e, o2, p2, ex, ey, ez, -1.0, s.body_x, s.cdof, rows.jac, r,
                                  sp)
            gap = p1 - p2
            for a in range(3):
                rows.err[e, r + a] = gap[a]
            if n == 6:
                q1 = wp.transform_get_rotation(x1) * p.eq_frame[e, i, 0]
                q2 = wp.transform_get_rotation(x2) * p.eq_frame[e, i, 1]
                turn = _rotation_vector(q1 * wp.quat_inverse(q2))
                for a in range(3):
                    rows.err[e, r + 3 + a] = turn[a]
                world = wp.identity(n=3, dtype=float)
                _add_angular_jacobian(m, e, o1, 1.0, world, 3, s.cdof, rows.jac, r + 3, sp)
                _add_angular_jacobian(m, e, o2, -1.0, world, 3, s.cdof, rows.jac, r + 3, sp)
        else:
            ref = m.eq_ref[i]
            sp = wp.vec4i(0, 0, 0, 0)
            val1 = float(0.0)
            val2 = float(0.0)
            if kind == EQ_JOINT:
                d1 = m.jnt_dofadr[o1]
                t2 = none
                if o2 >= 0:
                    t2 = m.dof_tree_span[m.jnt_dofadr[o2]]
                    val2 = s.q[e, m.jnt_qposadr[o2]]
                sp = _spans(m.dof_tree_span[d1], t2)
                val1 = s.q[e, m.jnt_qposadr[o1]]
            else:
                sp = _tendon_span(m, o1)
                val1 = tendon_length(m, p, s, e, o1)[0]
                if o2 >= 0:
                    other = _tendon_span(m, o2)
                    sp = wp.vec4i(wp.min(sp[0], other[0]), wp.max(sp[1], other[1]), 0, 0)
                    val2 = tendon_length(m, p, s, e, o2)[0]
            rows.span[e, r] = sp
            dense.row_fill(rows.jac, e, r, 0.0, _width(sp))
            err_slope = wp.vec2(val1 - ref[0] - p.eq_polycoef[e, i, 0], 0.0)
            if o2 >= 0:
                err_slope = _coupling(val1 - ref[0], val2 - ref[1], p.eq_polycoef, e, i)
            rows.err[e, r] = err_slope[0]
            if kind == EQ_JOINT:
                c1 = _col(sp, m.jnt_dofadr[o1])
                rows.jac[e, r, c1] = 1.0
                if o2 >= 0:
                    c2 = _col(sp, m.jnt_dofadr[o2])
                    rows.jac[e, r, c2] = rows.jac[e, r, c2] - err_slope[1]
            else:
                _tendon_add(m, s, e, o1, 1.0, False, rows.jac, r, sp)
                if o2 >= 0:
                    _tendon_add(m, s, e, o2, -err_slope[1], False, rows.jac, r, sp)
        _finish_equality(m, e, r, n, r - base, factor, rows)


@wp.func
def _finish_equality(m: ModelArrays, e: int, r: int, n: int, k: int,
                     factor: wp.array2d(dtype=float), rows: Rows):
    """Responses of an equality's n rows from r (the k-th equality row), the Cholesky factor of
    their J M⁻¹ Jᵀ into eq_chol[k...], and their warm start. A row that depends on the rows
    before it (a weld on a body with fewer than 6 dofs) gets a zero pivot: the solver leaves it
    out."""
    sp = rows.span[e, r]
    width = _width(sp)
    for a in range(n):
        dense.row_copy(rows.minv_jt, rows.jac, e, r + a, width)
    for a in range(0, n, 3):
        _solve_rows(m, e, factor, rows.minv_jt, r + a, wp.min(3, n - a), sp)
    for a in range(n):
        for b in range(a + 1):
            x = dense.rows_dot_at(rows.jac, r + a, 0, rows.minv_jt, r + b, 0, e, width)
            if b == a:
                rows.inv_mass[e, r + a] = 0.0
                if x > 1.0e-12:
                    rows.inv_mass[e, r + a] = 1.0 / x
            for c in range(b):
                x = x - rows.eq_chol[e, k + a, c] * rows.eq_chol[e, k + b, c]
            if b < a:
                pivot = rows.eq_chol[e, k + b, b]
                if pivot > 0.0:
                    x = x / pivot
                else:
                    x = 0.0
            elif x > 1.0e-6 / wp.max(rows.inv_mass[e, r + a], 1.0e-30):
                x = wp.sqrt(x)
            else:
                x = 0.0      # dependent on the rows before it
            rows.eq_chol[e, k + a, b] = x
    for a in range(n):
        rows.type[e, r + a] = EQUALITY
        rows.lam_init[e, r + a] = rows.lam[e, r + a]


@wp.func
def tendon_spring_rows(m: ModelArrays, e: int, at: wp.vec3i, base: int, p: EnvParams,
                       s: State, factor: wp.array2d(dtype=float), rows: Rows):
    """One soft row per tendon (PhysX semantics): measures L (J = coef) and pushes each joint
    with recip/N; the limit spring (limit stiffness > 0) joins outside [lower, upper]."""
    for t in range(at[0], wp.where(at[2] != 0, m.ntendon, 0), at[1]):
        r = base + t
        rows.type[e, r] = INACTIVE
        rows.lam_init[e, r] = 0.0
        count = float(m.tendon_num[t])
        if m.tendon_spatial[t] >= 0:     # MuJoCo's semantics: the force along the path's rate
            count = 1.0
        length = tendon_length(m, p, s, e, t)[0]
        stiff = p.tendon_stiffness[e, t] / count
        force = -stiff * (length - p.tendon_rest_length[e, t])
        k_lim = p.tendon_limit_stiffness[e, t] / count
        if m.tendon_limited[t] != 0 and k_lim > 0.0:
            lim = p.tendon_range[e, t]
            if length < lim[0]:
                force = force - k_lim * (length - lim[0])
                stiff = stiff + k_lim
            if length > lim[1]:
                force = force - k_lim * (length - lim[1])
                stiff = stiff + k_lim
        damp = p.tendon_damping[e, t] / count
        if stiff > 0.0 or damp > 0.0:
            sp = _tendon_span(m, t)
            rows.span[e, r] = sp
            dense.row_fill(rows.jac, e, r, 0.0, _width(sp))
            dense.row_fill(rows.minv_jt, e, r, 0.0, _width(sp))
            _tendon_add(m, s, e, t, 1.0, False, rows.jac, r, sp)
            _tendon_add(m, s, e, t, 1.0, True, rows.minv_jt, r, sp)
            _solve_rows(m, e, factor, rows.minv_jt, r, 1, sp)
            w_eff = dense.rows_dot_at(rows.jac, r, 0, rows.minv_jt, r, 0, e, _width(sp))
            if w_eff > 1.0e-12:
                rows.type[e, r] = SOFT
                rows.inv_mass[e, r] = 1.0 / w_eff
                rows.k[e, r] = stiff
                rows.d[e, r] = damp
                # the spring's error, expressed as the length offset that stiff alone would hold
                rows.err[e, r] = 0.0
                if stiff > 0.0:
                    rows.err[e, r] = -force / stiff


@wp.func
def dof_rows(m: ModelArrays, e: int, at: wp.vec3i, base: int, count: int, h: float,
             p: EnvParams, factor: wp.array2d(dtype=float), rows: Rows):
    """One row per dof, J = e_dof: dry friction (bounded impulse) and the maximum joint speed.

    Its response M⁻¹e_dof (a column of M⁻¹) is what costs; a dof without dry friction needs it
    only once the dof exceeds its cap, so it is left unbuilt here (inv_mass 0) and the solver
    builds it then (`build_dof_row`). Present always: impulses from other rows can push a dof
    past its cap within the solve (and a row only near the cap let a humanoid under random
    torques blow up: measured).
    """
    for dof in range(at[0], wp.where(at[2] != 0, count, 0), at[1]):
        r = base + dof
        warm = rows.lam[e, r]
        bound = p.dof_frictionloss[e, dof] * h
        cap = p.dof_max_velocity[e, dof]
        rows.type[e, r] = INACTIVE
        rows.lam_init[e, r] = 0.0
        if cap > 0.0:
            rows.type[e, r] = DOF
            rows.inv_mass[e, r] = 0.0
            rows.mu[e, r] = bound
            rows.k[e, r] = cap
            if bound > 0.0:
                build_dof_row(m, e, r, dof, 1.0, DOF, factor, rows)
                if rows.type[e, r] != INACTIVE:
                    rows.lam_init[e, r] = wp.clamp(warm, -bound, bound)


@wp.func
def _moves(m: ModelArrays, b: int):
    """Whether any DOF moves body b (not welded to the world)."""
    span = m.body_tree_span[b]
    return span[1] > span[0]


@wp.func
def build_contact_rows(m: ModelArrays, e: int, r0: int, width: int, sp: wp.vec4i,
                       factor: wp.array2d(dtype=float), rows: Rows):
    """Responses M⁻¹Jᵀ and 1/(J M⁻¹ Jᵀ) of a contact's `width` rows from r0 (normal, friction,
    torsional and rolling friction) from their J; friction goes with its normal row."""
    for d in range(width):
        dense.row_copy(rows.minv_jt, rows.jac, e, r0 + d, _width(sp))
    _solve_rows(m, e, factor, rows.minv_jt, r0, 3, sp)
    if width > 3:       # (a solve takes up to three rows)
        _solve_rows(m, e, factor, rows.minv_jt, r0 + 3, width - 3, sp)
    _set_inv_mass(rows, e, r0, sp, NORMAL)
    _set_inv_mass(rows, e, r0 + 1, sp, FRICTION)
    _set_inv_mass(rows, e, r0 + 2, sp, FRICTION2)
    for d in range(3, width):
        if rows.type[e, r0 + d] != INACTIVE:       # a torsional or rolling coefficient
            _set_inv_mass(rows, e, r0 + d, sp, rows.type[e, r0 + d])
    if rows.type[e, r0] == NORMAL and rows.inv_mass[e, r0] * UNREACHABLE * rows.k[e, r0] > 1.0:
        # J M⁻¹ Jᵀ below UNREACHABLE·(1/m1 + 1/m2): the joints can barely move the bodies
        # along the normal (two links of one arm, the normal through their joint axes), and
        # what they can is the noise in J. Pushing there took impulses of 10⁵ N·s and sent
        # a UR5 to 10²⁷ rad/s; the contact is dropped (it cannot deepen along a normal that
        # the joints cannot move).
        rows.type[e, r0] = INACTIVE
    if rows.type[e, r0] == INACTIVE:
        for d in range(1, width):
            rows.type[e, r0 + d] = INACTIVE


@wp.func
def build_dof_row(m: ModelArrays, e: int, r: int, dof: int, sign: float, kind: int,
                  factor: wp.array2d(dtype=float), rows: Rows):
    """Row r along one dof, J = sign·e_dof over its dof tree, as a `kind` row: its response and
    1/(J M⁻¹ Jᵀ). A joint limit (NORMAL; sign -1 for the upper side) or a dof row (DOF)."""
    sp = _spans(m.dof_tree_span[dof], wp.vec2i(0, 0))
    rows.span[e, r] = sp
    dense.row_fill(rows.jac, e, r, 0.0, _width(sp))
    rows.jac[e, r, dof - sp[0]] = sign
    _finish_row(m, e, r, sp, factor, rows, kind)


@wp.func
def _limit_row(e: int, r: int, side: int, x: float, lim: wp.vec2, reach: float, rows: Rows):
    """Mark a lower (side 0) or upper (side 1) limit row active when within reach of its limit;
    its distance to the limit is kept either way (the solver may take it in later)."""
    err = x - lim[0]
    if side == 1:
        err = lim[1] - x
    rows.type[e, r] = INACTIVE
    rows.lam_init[e, r] = 0.0
    rows.err[e, r] = err
    if err < reach:
        rows.type[e, r] = NORMAL
        rows.mu[e, r] = 0.0
        rows.bounce[e, r] = 0.0
