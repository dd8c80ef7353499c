"""Stage 5, the constraint solve: Temporal Gauss-Seidel (TGS) or PGS on the rows of `constraints`.

One thread per env. The solve starts from the unconstrained velocity v = qd + h·qacc and applies
row impulses λ through v += M⁻¹Jᵀ·Δλ.

TGS (`params.solver == "tgs"`): the substep h is split into N = position_iterations sub-steps of
h/N. Each is one Gauss-Seidel sweep over the rows, after which the displacement is integrated,
dq += (h/N)·v. A row's error is re-evaluated in every sweep as its initial error plus J·dq, so a
contact that has been pushed apart stops pushing: this is what makes TGS converge like real
sub-stepping at the cost of one sweep each. Penetration is resolved at speed -err/(h/N), capped
by `max_depenetration_velocity`; a gap (err > 0) lets the bodies approach by at most the gap
(speculative contact). Then `velocity_iterations` sweeps run with no position bias.

PGS (`params.solver == "pgs"`): one step of h with `position_iterations` sweeps, errors frozen at
their initial values, bias -err/h, then dq = h·v. Same rows, same cost per sweep.

Friction: the two friction rows of a contact are solved together and their impulse is projected
onto the disk |λ_t| <= μ·λ_n (an isotropic cone: friction does not depend on how the tangent
basis happens to be oriented; PhysX's per-axis clamp lets diagonal friction reach √2·μ).
Friction acts in every sweep; in position sweeps its target also undoes the drift of the
contact's two bodies since the contact began to stick (the friction anchors of `constraints`),
so static friction holds a contact where it landed instead of letting each substep's unconverged
sweeps creep. A contact of condim 4 or 6 also has a torsional row (|λ| <= μ_spin·λ_n) and two
rolling rows (a disk of radius μ_roll·λ_n), swept after its sliding rows (`_angular_rows`).
Restitution: a contact approaching faster than the bounce threshold targets a separation speed
of e times its approach speed.
"""

import warp as wp

from .. import dense
from .constraints import _col, build_contact_rows, build_dof_row
from ..types import DOF, EQUALITY, FRICTION, INACTIVE, NORMAL, ROLL, SOFT, SPIN
from ..lanes import stop, sync, warp_lanes, warp_sum, world_lane
from ..structs import Contacts, Dynamics, ModelArrays, Options, RowLayout, Rows, State

# fraction of the last substep's impulse a limit row, or the normal row of a contact with the
# ground, starts from: below 1 so that the impulses of a configuration with no solution (a hand
# pressed into the head by an arm held at its limit) decay instead of growing without bound from
# step to step. Other contact rows start from zero (`constraints.contact_rows`).
WARM = wp.constant(0.9)

vec6 = wp.types.vector(length=6, dtype=float)

# with contacts in the limit block, each contact's diagonal is J M⁻¹ Jᵀ·(1 + CONTACT_SOFTNESS)
# and each limit's J M⁻¹ Jᵀ·(1 + LIMIT_SOFTNESS). Contacts can outnumber the dofs that move
# them (a capsule's end and the foot sphere over it, a sole's corners) and a limit can depend
# on them (a foot flat on the ground holds its ankle): nearly dependent rows with different
# targets then need a finite answer, from which the pivoting drops the one that pulls. Dropped
# as dependent instead (as the two sides of a limit are), a leg's capsule 1 cm above the ground,
# approaching at its speculative 1.2 m/s, held the foot sphere under it at that speed into the
# floor, and an ankle went 0.18 rad past its limit in one step. And where the rows cannot all
# hold (a limit's correction pushing a flat foot into the ground) the contacts' softness bounds
# the impulses: at 1e-4 a G1's foot took 11 kN and its energy ran away (1331x); 0.01 kept
# robot_stress's G1, B1 and Laikago within their limits and MuJoCo's depth, 0.1 let the B1's
# feet 22 mm deep.
CONTACT_SOFTNESS = wp.constant(0.01)
LIMIT_SOFTNESS = wp.constant(1.0e-4)
# ... and below this fraction of its J M⁻¹ Jᵀ, a pivot counts as dependent (rounding): the row
# leaves the set
PIVOT_FLOOR = wp.constant(1.0e-6)
# rounds of the joint limits and the dof rows (speed caps) in a sweep: a cap's impulse moves
# the other dofs of its tree (a joint at its limit among them), the limits' move a capped dof
# past its cap again; they take turns until the dof rows (caps, dry friction) leave no limit
# below its target, or this many times, the dof rows last (robot_stress, 40 envs: a bare
# G1's wrist, spun by its hand's contacts, went 0.061 rad past its limit with its row active
# when the caps simply followed the limits; with the limits last instead, TALOS's
# mimic-coupled grippers passed theirs by up to 0.57 rad, their equalities driving them at the
# speeds the limits left past the caps).
# The caps the block's own impulses break are solved inside it (`BLOCK_CAPS`); the turns are
# for the dof rows' other work (caps the contacts broke, dry friction): with one round, a G1
# with hands went 0.257 rad past a limit in 1 of 40 envs (`robot_stress.py`), with three 0.002
LIMIT_CAP_ROUNDS = wp.constant(3)
# speed caps the joint-limit block may take in (`_cap_broken`): a dof its impulses would send
# past its cap joins it, up to this many in a solve (a plain int: `build` sizes the block with
# it). Turns alone converge slowly where two dofs are nearly one motion: a shoulder at its
# limit beside an elbow spun to its cap through a 2 cm, 10 g upper arm went 9.5 rad through
# the limit in 2 s (`test_contacts`)
BLOCK_CAPS = 8

# Gauss-Seidel passes over the normal rows of a contact patch (the contacts of one geom pair,
# e.g. a box face's four corners) in every sweep. How a face's load splits among its corners is
# settled only by iterating among them; with one pass a resting box kept rocking by ~10 µm
# (reading 0.01-0.1 rad/s) and stacks bounced; 2 passes left 0.002-0.005 m/s, 4 passes 1e-4,
PATCH_PASSES = wp.constant(4)
# ... fewer once a pass changes no row's J·v by more than this (m/s or rad/s)
PATCH_SETTLED = wp.constant(1.0e-5)



@wp.func
def _same_pair(a: wp.vec2i, b: wp.vec2i):
    return a[0] == b[0] and a[1] == b[1]


@wp.func
def _row_in_use(i: int, used: int, layout: RowLayout):
    """The i-th row in use: the contacts' rows [0, used) first, then every row from the joint
    limits on (contact slots past the env's contact count are empty)."""
    if i < used:
        return i
    return layout.joint_limits + i - used


@wp.func(inline=True)
def _dot(rows: Rows, a: wp.array3d(dtype=float), e: int, r: int, v: wp.array2d(dtype=float),
         sp: wp.vec4i, ln: wp.vec2i):
    """a[e, r] · v[e] over the row's span, the same on every lane of the world: one lane sums
    it 8 wide (`dense.row_dot`); lanes each sum their dofs and combine the parts: on CUDA with
    a world per warp through the warp's registers (`warp_sum`, a butterfly), else by writing
    the part, waiting, and adding the parts in lane order. Either is another order of the terms
    than one lane's, the same on every run. The parts go to one of two buffers in turn: a lane
    writing the next sum's part has passed the wait after which every lane read this one's."""
    if ln[1] == 1:
        return dense.row_dot(a, e, r, v, sp)
    if warp_lanes(ln[1]):       # CUDA, a world per warp: the parts meet in registers
        return warp_sum(dense.row_dot_lane(a, e, r, v, sp, ln[0], ln[1]))
    turn = rows.lane_turn[e, ln[0]] % 2
    rows.lane_turn[e, ln[0]] = turn + 1
    rows.lane_sum[e, turn, ln[0]] = dense.row_dot_lane(a, e, r, v, sp, ln[0], ln[1])
    sync()
    total = float(0.0)
    for k in range(ln[1]):
        total = total + rows.lane_sum[e, turn, k]
    return total


@wp.func(inline=True)
def _apply(v: wp.array2d(dtype=float), e: int, dl: float, a: wp.array3d(dtype=float), r: int,
           sp: wp.vec4i, ln: wp.vec2i):
    """v[e] += dl · a[e, r] over the row's span, each lane on its own dofs."""
    if ln[1] == 1:
        dense.row_apply(v, e, dl, a, r, sp)
    else:
        dense.row_apply_lane(v, e, dl, a, r, sp, ln[0], ln[1])


@wp.func_native("""
    if (start >= n) return n;
    const int* t = wp::address(type, e, r0);
    const float* cap = wp::address(k, e, r0);
    const float* bound = wp::address(mu, e, r0);
    const float* ve = wp::address(v, e, 0);
    for (int d = start; d < n; ++d)
        if (t[d] == dof_type && ((with_bound != 0 && bound[d] > 0.0f) || wp::abs(ve[d]) > cap[d]))
            return d;
    return n;
""")
def _next_dof_row(type: wp.array2d(dtype=wp.int32), mu: wp.array2d(dtype=float),
                  k: wp.array2d(dtype=float), v: wp.array2d(dtype=float), e: int, r0: int,
                  start: int, n: int, with_bound: int, dof_type: int) -> int:
    """The first dof d in [start, n) whose row r0 + d is a dof row (`dof_type`) with its speed
    past the cap (|v| > k) or, `with_bound`, with dry friction (mu > 0); n if none. Most dof
    rows do nothing in a sweep, and a humanoid's sweeps scan them several times: a plain loop
    over Warp's 2D indices cost 3 % of its step."""
    ...


@wp.func_native("""
    if (start >= n) return n;
    const int* t = wp::address(type, e, base);
    const float* er = wp::address(err, e, base);
    const float* ve = wp::address(v, e, 0);
    const float* de = wp::address(dq, e, 0);
    const int* dofs = wp::address(limit_dof, 0);
    for (int i = start; i < n; ++i) {
        if (t[i] != inactive) continue;
        const int dof = dofs[i / 2];
        float travel = hs * ve[dof];
        if (tgs != 0) travel = travel + de[dof];      // (a statement of its own: no contraction)
        const float sign = 1.0f - 2.0f * (float)(i % 2);
        const float signed_travel = sign * travel;
        if (er[i] + signed_travel < 0.0f) return i;
    }
    return n;
""")
def _next_reachable_limit(type: wp.array2d(dtype=wp.int32), err: wp.array2d(dtype=float),
                          v: wp.array2d(dtype=float), dq: wp.array2d(dtype=float),
                          limit_dof: wp.array(dtype=wp.int32), e: int, base: int, start: int,
                          n: int, hs: float, tgs: int, inactive: int) -> int:
    """The first joint-limit row i in [start, n) (row base + i) that is not in use
    (`inactive`) and that its joint would pass within a position sweep's step: err + sign·travel
    < 0, travel = hs·v (+ dq in TGS) of its dof, sign +1 for a lower limit (even i), -1 for an
    upper one (`_limit_sign`); n if none. The arithmetic of the Warp code it replaced, one
    operation a statement: the same bits. (Every position sweep scans every limit: 5 % of a
    humanoid's step as a Warp loop.)"""
    ...


@wp.func(inline=True)
def _wait(ln: wp.vec2i):
    """Before and after work one lane does for the world (reading or writing every lane's
    dofs, building a row)."""
    if ln[1] > 1:
        sync()


@wp.func(inline=True)
def _sweep(m: ModelArrays, e: int, ln: wp.vec2i, layout: RowLayout, ncontact: int,
           tendon_limits: wp.vec2i, c: Contacts, limit_dof: wp.array(dtype=wp.int32),
           first: int, biased: int, tgs: int, hs: float,
           h: float, max_depenetration: float, max_correction: float,
           factor: wp.array2d(dtype=float), rows: Rows,
           v: wp.array2d(dtype=float), dq: wp.array2d(dtype=float)):
    """One Gauss-Seidel sweep over the rows in use, updating v and the impulses rows.lam.
    Penetrations are undone at up to `max_depenetration`, limits and equalities at up to
    `max_correction` (`Options`).

    The contacts' normal rows, patch by patch, and the tendon limits; the contacts' friction
    rows, whose bounds then hold this sweep's normal impulses; the joint limits, solved
    together with the contacts they hold up (and the speed caps their impulses break); tendon
    springs and dofs, and the limits once more if the dof rows (a speed cap, dry friction) left
    one below its target; the equality constraints (each one's rows together).
    `tendon_limits`: the range of tendon-limit rows that holds the active ones (`_in_use`).

    `ln` = (lane, lanes): a world's lanes sweep its rows together, each row's J·v and
    M⁻¹Jᵀ·Δλ split over their dofs, Gauss-Seidel's order between rows kept (every lane takes
    the same decisions from the same sums); the joint-limit block, the dof rows and the
    equalities are one lane's work for now."""
    width = layout.contact_width
    k = int(0)
    while k < ncontact:      # contact patches: the run of contacts of one geom pair
        end = k + 1
        while end < ncontact and _same_pair(c.geom[e, end], c.geom[e, k]):
            end += 1
        passes = PATCH_PASSES
        if end == k + 1:
            passes = 1
        for _ in range(passes):
            change = float(0.0)
            for j in range(k, end):
                change = wp.max(change, _normal_row(m, e, ln, width * j, width, biased, tgs,
                                                    hs, h, max_depenetration, factor, rows, v,
                                                    dq))
            if change < PATCH_SETTLED:
                break
        k = end
    for r in range(tendon_limits[0], tendon_limits[1]):
        _normal_row(m, e, ln, r, 1, biased, tgs, hs, h, max_correction, factor, rows, v, dq)
    for k in range(ncontact):
        _friction_rows(e, ln, width * k + 1, width, biased, tgs, hs, rows, c, v, dq)
        if width > 3:
            _angular_rows(e, ln, width * k, width, biased, tgs, hs, rows, v, dq)
    # the joint limits last of the one-sided rows: a joint's mechanical stop has the last word
    # over contacts (a UR5's overlapping link meshes pushed its wrist 0.26 rad past its limit
    # when the limits came before the friction rows); then the dof rows, and the two again in
    # turn if the dof rows left a limit below its target (`LIMIT_CAP_ROUNDS`; a later round
    # runs the dof rows only if a dof is past its cap)
    for part in range(LIMIT_CAP_ROUNDS):
        _wait(ln)
        _limit_rows(m, e, ln, layout, c, ncontact, limit_dof, first * int(part == 0), biased,
                    tgs, hs, h, max_depenetration, max_correction, factor, rows, v, dq)
        _wait(ln)
        if first != 0 and part == 0:
            for r in range(layout.springs, layout.dofs):
                _spring_row(e, ln, r, h, rows, v)
            _wait(ln)
        if part > 0 and _past_cap(layout, rows, e, v) == 0:     # every lane the same answer
            break
        _wait(ln)
        if ln[0] == 0:
            # most dof rows do nothing in a sweep (no dry friction, speed under the cap):
            # `_next_dof_row` finds those that do. (Before the limit block instead, they kept
            # a G1 with hands within its limits in 38 of 40 envs rather than 33, but a TALOS's
            # mimic-coupled gripper joints then passed theirs in 14 rather than 2: the
            # equalities after them undo the limits)
            n = layout.end - layout.dofs
            dof = _next_dof_row(rows.type, rows.mu, rows.k, v, e, layout.dofs, 0, n, 1, DOF)
            while dof < n:
                _dof_row(m, e, layout.dofs + dof, dof, factor, rows, v)
                dof = _next_dof_row(rows.type, rows.mu, rows.k, v, e, layout.dofs, dof + 1, n, 1,
                                    DOF)
        _wait(ln)
        if part + 1 == LIMIT_CAP_ROUNDS or \
                _limits_broken(layout, limit_dof, rows, e, v) == 0:
            break
    if ln[0] == 0:
        # equalities last: the sweep ends with them holding, whatever the rows before did
        if layout.springs > layout.equalities:
            for i in range(m.neq):
                _equality(m, e, layout.equalities, i, biased, tgs, hs, max_correction, rows,
                          v, dq)
    _wait(ln)


@wp.func
def _limits_broken(layout: RowLayout, limit_dof: wp.array(dtype=wp.int32),
                   rows: Rows, e: int, v: wp.array2d(dtype=float)):
    """1 if a joint-limit candidate of this sweep's block now moves slower than its target by
    more than the block's rounding, else 0."""
    n = layout.tendon_limits - layout.joint_limits
    for t in range(_candidate_count(rows, e, n)):
        i = rows.block_cand[e, t]
        if rows.type[e, layout.joint_limits + i] == NORMAL:
            target = rows.block_target[e, i]
            if _limit_sign(i) * v[e, _limit_dof(limit_dof, i)] < \
                    target - 1.0e-3 * (1.0 + wp.abs(target)):
                return int(1)
    return int(0)


@wp.func
def _past_cap(layout: RowLayout, rows: Rows, e: int, v: wp.array2d(dtype=float)):
    """1 if a dof of env e is past its speed cap, else 0."""
    n = layout.end - layout.dofs
    return int(_next_dof_row(rows.type, rows.mu, rows.k, v, e, layout.dofs, 0, n, 0, DOF) < n)


@wp.func
def _in_use(rows: Rows, e: int, lo: int, hi: int):
    """The smallest range [first, last + 1) within [lo, hi) that holds every row in use."""
    first = hi
    last = lo - 1
    for r in range(lo, hi):
        if rows.type[e, r] >= 0:
            first = wp.min(first, r)
            last = r
    return wp.vec2i(first, wp.max(first, last + 1))


@wp.func
def _normal_target(err: float, biased: int, hs: float, h: float, max_depenetration: float,
                   bounce: float):
    """Target J·v of a non-negative row with position error err (< 0: penetration)."""
    target = float(0.0)
    if err >= 0.0:
        target = -err / h          # may close the gap, no more
        if biased != 0:
            target = -err / hs
    elif biased != 0:
        target = wp.min(-err / hs, max_depenetration)
    if bounce > 0.0:  # restitution replaces the bias for a fast approach
        target = wp.max(target, bounce)
    return target


@wp.func
def _normal_row(m: ModelArrays, e: int, ln: wp.vec2i, r: int, width: int, biased: int, tgs: int,
                hs: float, h: float, max_depenetration: float, factor: wp.array2d(dtype=float),
                rows: Rows, v: wp.array2d(dtype=float), dq: wp.array2d(dtype=float)):
    """A non-negative impulse along row r (a contact normal, first of its `width` rows, or a
    tendon limit) that removes the approach, and in biased (position) sweeps the penetration;
    returns the change of J·v it made. (Joint limits are solved together:
    `_joint_limit_block`.)"""
    if rows.type[e, r] != NORMAL:
        return 0.0
    # read before the sums' wait, after which lane 0 may build the row and every lane writes
    # the new impulse: every lane takes the same branches from the same values
    old = rows.lam[e, r]
    built = rows.inv_mass[e, r] != 0.0
    sp = rows.span[e, r]
    jv = _dot(rows, rows.jac, e, r, v, sp, ln)
    err = rows.err[e, r]
    if tgs != 0:
        err = err + _dot(rows, rows.jac, e, r, dq, sp, ln)
    target = _normal_target(err, biased, hs, h, max_depenetration, rows.bounce[e, r])
    if not built:
        # response not built yet (`constraints`): the row has had no impulse, and gets none
        # while it does not push
        if target - jv <= 0.0:
            return 0.0
        if ln[0] == 0:
            build_contact_rows(m, e, r, width, sp, factor, rows)
        _wait(ln)
        if rows.type[e, r] != NORMAL:
            return 0.0
    new = wp.max(old + (target - jv) * rows.inv_mass[e, r], 0.0)
    rows.lam[e, r] = new
    _apply(v, e, new - old, rows.minv_jt, r, rows.span[e, r], ln)
    return wp.abs(new - old) / rows.inv_mass[e, r]


@wp.func
def _equality(m: ModelArrays, e: int, base: int, i: int, biased: int, tgs: int, hs: float,
              max_depenetration: float, rows: Rows, v: wp.array2d(dtype=float),
              dq: wp.array2d(dtype=float)):
    """The rows of equality constraint i solved together, exactly: impulses Δλ (of either sign)
    with J M⁻¹ Jᵀ Δλ = target - J·v for its (up to 6) rows, by the Cholesky factor the rows
    were built with (`constraints.equality_rows`). Row by row, the three rows of a point on a
    long arm (effective masses far apart) would converge over many sweeps. Targets: in
    position sweeps the violation undone over the sub-step (its speed capped like
    depenetration), in velocity sweeps no relative motion."""
    r = base + m.eq_rowadr[i]
    if rows.type[e, r] != EQUALITY:
        return
    n = m.eq_rownum[i]
    k = m.eq_rowadr[i]
    sp = rows.span[e, r]
    x = vec6()
    for a in range(n):     # forward substitution: L y = target - J·v
        rhs = -dense.row_dot(rows.jac, e, r + a, v, sp)
        if biased != 0:
            err = rows.err[e, r + a]
            if tgs != 0:
                err = err + dense.row_dot(rows.jac, e, r + a, dq, sp)
            rhs = rhs + wp.clamp(-err / hs, -max_depenetration, max_depenetration)
        for c in range(a):
            rhs = rhs - rows.eq_chol[e, k + a, c] * x[c]
        pivot = rows.eq_chol[e, k + a, a]
        x[a] = 0.0
        if pivot > 0.0:
            x[a] = rhs / pivot
    for aa in range(n):    # back substitution: Lᵀ Δλ = y
        a = n - 1 - aa
        rhs = x[a]
        for c in range(a + 1, n):
            rhs = rhs - rows.eq_chol[e, k + c, a] * x[c]
        pivot = rows.eq_chol[e, k + a, a]
        x[a] = 0.0
        if pivot > 0.0:
            x[a] = rhs / pivot
    for a in range(n):
        if x[a] != 0.0:
            rows.lam[e, r + a] = rows.lam[e, r + a] + x[a]
            dense.row_apply(v, e, x[a], rows.minv_jt, r + a, sp)


@wp.func
def _listed(a: wp.array2d(dtype=wp.int32), e: int, n: int):
    """The entries of a list a[e] of at most n, -1 after the last."""
    k = int(0)
    while k < n:
        if a[e, k] < 0:
            break
        k += 1
    return k


@wp.func
def _candidate_count(rows: Rows, e: int, n: int):
    """The joint-limit block's candidates listed in rows.block_cand."""
    return _listed(rows.block_cand, e, n)


@wp.func(inline=True)
def _limit_rows(m: ModelArrays, e: int, ln: wp.vec2i, layout: RowLayout, c: Contacts,
                ncontact: int,
                limit_dof: wp.array(dtype=wp.int32), first: int, biased: int, tgs: int,
                hs: float, h: float, max_depenetration: float, max_correction: float,
                factor: wp.array2d(dtype=float), rows: Rows, v: wp.array2d(dtype=float),
                dq: wp.array2d(dtype=float)):
    """The joint limits of a sweep (`_joint_limit_block`), with the contacts their pushing
    limits hold up: the candidates listed in the substep's first sweep (rows within reach of
    their limit), the contacts picked in every sweep (`_block_contacts`), their impulses taken
    out of v and the new ones applied by every lane on its dofs, the block's pivoting by one
    lane.

    A limit out of reach at the substep's start joins the candidates in the sweep where its
    joint heads for it fast enough to get there: contacts can take a dof from rest to its speed
    cap within a substep (a G1's shoulder from -6 to +229 rad/s, 1.66 rad past its limit in one
    substep when its row was left out)."""
    n = layout.tendon_limits - layout.joint_limits
    base = layout.joint_limits
    if ln[0] == 0:
        k = int(0)
        if first != 0:
            for i in range(n):
                if rows.type[e, base + i] == NORMAL:
                    rows.block_cand[e, k] = i
                    k += 1
        else:
            k = _candidate_count(rows, e, n)
        k = _reachable_limits(e, layout, limit_dof, k, biased, tgs, hs, rows, v, dq)
        _block_contacts(m, e, layout, c, ncontact, limit_dof, k, rows)
    ncand = int(0)
    nentry = int(0)
    ncap = int(0)
    caps = int(0)
    for attempt in range(3):
        _wait(ln)
        if attempt > 0:
            # the contacts' new impulses can send a joint outside the block at its limit within
            # this sweep's step (a G1's hand hitting the ground spun its wrist to its 100 rad/s
            # cap, 0.18 rad past its limit in one step): solve once more with its row
            if ln[0] == 0 and nentry > ncand and attempt == 1:
                _reachable_limits(e, layout, limit_dof, ncand, biased, tgs, hs, rows, v, dq)
            _wait(ln)
            again = int(_candidate_count(rows, e, n) != ncand)
            # and a dof past its speed cap (the block's impulses may have sent it there): once
            # more with the caps the block breaks taken in (`_cap_broken`); looked for only
            # then, as it costs a tenth of a humanoid's step
            if caps == 0 and _past_cap(layout, rows, e, v) != 0:
                caps = 1
                again = 1
            if again == 0:
                break
        ncand = _candidate_count(rows, e, n)
        ncontact_in = _block_contact_count(rows, e)
        nentry = ncand + ncontact_in
        # every entry's impulse taken out of v, the caps' of the attempt before included
        for t in range(nentry + ncap):
            i = _entry(rows, e, n, ncand, ncontact_in, t)
            r = _entry_row(layout, rows, e, i)
            old = _entry_sign(rows, e, n, i) * _entry_impulse(rows, e, n, i, r)
            if old != 0.0:
                _apply(v, e, -old, rows.minv_jt, r, rows.span[e, r], ln)
        _wait(ln)
        if ln[0] == 0:
            _joint_limit_block(m, e, layout, limit_dof, ncand, ncontact_in, nentry, caps,
                               biased, tgs, hs, h, max_depenetration, max_correction, factor,
                               rows, v, dq)
        _wait(ln)
        ncap = _block_cap_count(rows, e)
        for t in range(nentry + ncap):
            i = _entry(rows, e, n, ncand, ncontact_in, t)
            r = _entry_row(layout, rows, e, i)
            new = _entry_sign(rows, e, n, i) * _entry_impulse(rows, e, n, i, r)
            if _entry_live(layout, rows, e, n, i, r) and new != 0.0:
                _apply(v, e, new, rows.minv_jt, r, rows.span[e, r], ln)


@wp.func(inline=True)
def _reachable_limits(e: int, layout: RowLayout,
                      limit_dof: wp.array(dtype=wp.int32), k: int, biased: int, tgs: int,
                      hs: float, rows: Rows, v: wp.array2d(dtype=float),
                      dq: wp.array2d(dtype=float)):
    """Add to the block's `k` candidates the limit rows out of reach at the substep's start
    that the joint would now pass within this position sweep's step (`_normal_target`:
    err + hs·J·v < 0); the velocity sweeps move nothing, and the next substep's rows see their
    speed. Ends the list with -1; returns the candidates' count."""
    n = layout.tendon_limits - layout.joint_limits
    base = layout.joint_limits
    i = int(n)
    if biased != 0:
        i = _next_reachable_limit(rows.type, rows.err, v, dq, limit_dof, e, base, 0, n, hs, tgs,
                                  INACTIVE)
    while i < n:
        r = base + i
        listed = int(0)
        for j in range(k):
            if rows.block_cand[e, j] == i:
                listed = 1   # a candidate that could not be built
        if listed == 0:
            rows.type[e, r] = NORMAL
            rows.mu[e, r] = 0.0
            rows.bounce[e, r] = 0.0
            rows.inv_mass[e, r] = 0.0
            rows.lam[e, r] = 0.0
            rows.block_cand[e, k] = i
            k += 1
        i = _next_reachable_limit(rows.type, rows.err, v, dq, limit_dof, e, base, i + 1, n, hs,
                                  tgs, INACTIVE)
    if k < n:
        rows.block_cand[e, k] = -1
    return k


@wp.func(inline=True)
def _in_span(sp: wp.vec4i, dof: int):
    return (dof >= sp[0] and dof < sp[1]) or (dof >= sp[2] and dof < sp[3])


@wp.func(inline=True)
def _block_contacts(m: ModelArrays, e: int, layout: RowLayout, c: Contacts, ncontact: int,
                    limit_dof: wp.array(dtype=wp.int32), ncand: int, rows: Rows):
    """List in rows.block_contact the contacts the limit block solves in this sweep: those that
    pushed so far in it, whose rows reach the dof of a limit that pushes (its impulse so far
    > 0), between a body and the world or another tree; the first `nblock_contact` of them
    (`SimParams.limit_block_contacts`) in slot order.

    Row by row, a contact and a limit on one chain take turns undoing each other: a B1
    quadruped folding onto its knee stops (knees at their limits, 50 kg coming down at 3 m/s)
    had its feet 40 mm into the ground after a step, the limits having the last word; with the
    contacts after the limits instead, a G1's self-contacts pushed its joints 0.78 rad past
    them. Solved together, both hold. A robot's contacts with itself stay out: overlapping
    links held by limits and equalities can ask for what no impulse gives (TALOS's
    mimic-coupled gripper links 52 mm into each other took 10⁵ N·s in the block and threw its
    wrist 5 rad past its limit); there the limits keep the last word."""
    capacity = rows.block_contact.shape[1]
    if capacity == 0:
        return
    base = layout.joint_limits
    pushing = int(0)
    for k in range(ncand):
        if rows.lam[e, base + rows.block_cand[e, k]] > 0.0:
            pushing = 1
    count = int(0)
    if pushing != 0:
        for j in range(ncontact):
            r = layout.contact_width * j
            if (count < capacity and rows.type[e, r] == NORMAL and rows.lam[e, r] > 0.0
                    and not _self_contact(m, c, e, j)):
                sp = rows.span[e, r]
                for k in range(ncand):
                    i = rows.block_cand[e, k]
                    if rows.lam[e, base + i] > 0.0 and _in_span(sp, _limit_dof(limit_dof, i)):
                        rows.block_contact[e, count] = j
                        count += 1
                        break
    if count < capacity:
        rows.block_contact[e, count] = -1


@wp.func(inline=True)
def _self_contact(m: ModelArrays, c: Contacts, e: int, j: int):
    """Whether contact j is between two bodies of one tree (a robot touching itself)."""
    g = c.geom[e, j]
    b1 = m.geom_body[g[0]]
    b2 = m.geom_body[g[1]]
    if b1 < 0 or b2 < 0:
        return False
    t1 = m.body_tree_span[b1]
    t2 = m.body_tree_span[b2]
    return t1[0] == t2[0] and t1[1] == t2[1] and t1[1] > t1[0]


@wp.func(inline=True)
def _block_contact_count(rows: Rows, e: int):
    """The contacts listed in rows.block_contact."""
    return _listed(rows.block_contact, e, rows.block_contact.shape[1])


@wp.func
def _cap_broken(layout: RowLayout, e: int, n: int, ncap: int, count: int, rows: Rows,
                v: wp.array2d(dtype=float)):
    """The dof that the limit block's active set, with its impulses so far, sends furthest
    past its speed cap, as a block_cap entry (2·dof + 1 if too fast forward), or -1 if none
    (or only dofs already listed on that side). Only dofs inside an active row's span count:
    the others are the dof rows' to cap."""
    worst = int(-1)
    most = float(0.0)
    for dof in range(layout.end - layout.dofs):
        r = layout.dofs + dof
        if rows.type[e, r] != DOF:
            continue
        w = v[e, dof]
        touched = int(0)
        for a in range(count):
            ib = rows.block_row[e, a]
            rb = _entry_row(layout, rows, e, ib)
            if _in_span(rows.span[e, rb], dof):
                touched = 1
                w = w + rows.block_lam[e, ib] * _entry_sign(rows, e, n, ib) * \
                    _limit_coupling(e, dof, 1.0, rb, rows)
        over = wp.abs(w) - rows.k[e, r]
        if touched != 0 and over > most + 1.0e-6 * (1.0 + rows.k[e, r]):
            entry = 2 * dof + int(w > 0.0)
            listed = int(0)
            for k in range(ncap):
                if rows.block_cap[e, k] == entry:
                    listed = 1
            if listed == 0:
                most = over
                worst = entry
    return worst


@wp.func(inline=True)
def _block_cap_count(rows: Rows, e: int):
    """The speed caps listed in rows.block_cap."""
    return _listed(rows.block_cap, e, rows.block_cap.shape[1])


@wp.func(inline=True)
def _entry(rows: Rows, e: int, n: int, ncand: int, ncontact_in: int, t: int):
    """Block index of the t-th entry of a sweep's block: the limit candidates, the contacts,
    then the speed caps (limit row i is i, the k-th listed contact n + k, the k-th listed cap
    n + nblock_contact + k)."""
    if t < ncand:
        return rows.block_cand[e, t]
    if t < ncand + ncontact_in:
        return n + t - ncand
    return n + rows.block_contact.shape[1] + t - ncand - ncontact_in


@wp.func(inline=True)
def _cap_entry(rows: Rows, n: int, i: int):
    """The position in rows.block_cap of block index i, or -1 if i is not a speed cap."""
    k = i - n - rows.block_contact.shape[1]
    return wp.where(k >= 0, k, -1)


@wp.func(inline=True)
def _entry_row(layout: RowLayout, rows: Rows, e: int, i: int):
    """The row of block index i: a joint-limit row, a listed contact's normal row, or a listed
    cap's dof row (which stores J = +e_dof: `_entry_sign` gives the side)."""
    n = layout.tendon_limits - layout.joint_limits
    if i < n:
        return layout.joint_limits + i
    k = _cap_entry(rows, n, i)
    if k >= 0:
        return layout.dofs + rows.block_cap[e, k] / 2
    return layout.contact_width * rows.block_contact[e, i - n]


@wp.func(inline=True)
def _entry_sign(rows: Rows, e: int, n: int, i: int):
    """J of block index i over its row's stored J: -1 for a cap on a dof too fast forward,
    else 1."""
    k = _cap_entry(rows, n, i)
    if k >= 0:
        return _limit_sign(rows.block_cap[e, k])
    return 1.0


@wp.func(inline=True)
def _entry_impulse(rows: Rows, e: int, n: int, i: int, r: int):
    """The block's impulse of entry i (row r): a cap's in block_lam (its dof row's lam holds the
    dry friction), the others' in their rows."""
    if _cap_entry(rows, n, i) >= 0:
        return rows.block_lam[e, i]
    return rows.lam[e, r]


@wp.func(inline=True)
def _entry_live(layout: RowLayout, rows: Rows, e: int, n: int, i: int, r: int):
    """Whether entry i's row is one (NORMAL: a limit or a contact; DOF: a cap), not a row that
    could not be built."""
    if _cap_entry(rows, n, i) >= 0:
        return rows.type[e, r] == DOF
    return rows.type[e, r] == NORMAL


@wp.func
def _limit_coupling(e: int, dof: int, sign: float, r: int, rows: Rows):
    """J_i·M⁻¹J_rᵀ for a joint-limit row i (J_i = sign·e_dof) and a built row r: one entry of
    r's response (zero when the dof is outside r's tree)."""
    sp = rows.span[e, r]
    if not _in_span(sp, dof):
        return 0.0
    return sign * rows.minv_jt[e, r, _col(sp, dof)]


@wp.func(inline=True)
def _rows_coupling(e: int, ra: int, rb: int, rows: Rows):
    """J_a·M⁻¹J_bᵀ of a row a and a built row b: over the dof trees their spans share (a span's
    ranges are whole trees, so two ranges are the same or apart)."""
    a = rows.span[e, ra]
    b = rows.span[e, rb]
    total = float(0.0)
    for x in range(2):
        lo = a[2 * x]
        hi = a[2 * x + 1]
        if hi > lo:
            col_a = wp.where(x == 0, 0, a[1] - a[0])
            if lo == b[0] and hi == b[1]:
                total += dense.rows_dot_at(rows.jac, ra, col_a, rows.minv_jt, rb, 0, e, hi - lo)
            elif lo == b[2] and hi == b[3]:
                total += dense.rows_dot_at(rows.jac, ra, col_a, rows.minv_jt, rb, b[1] - b[0],
                                           e, hi - lo)
    return total


@wp.func(inline=True)
def _coupling(limit_dof: wp.array(dtype=wp.int32), e: int, n: int, ia: int,
              ra: int, ib: int, rb: int, rows: Rows):
    """J_a·M⁻¹J_bᵀ of block entry ia (row ra) and entry ib (a built row rb)."""
    x = float(0.0)
    k = _cap_entry(rows, n, ia)
    if ia < n:
        x = _limit_coupling(e, _limit_dof(limit_dof, ia), _limit_sign(ia), rb, rows)
    elif k >= 0:
        cap = rows.block_cap[e, k]
        x = _limit_coupling(e, cap / 2, _limit_sign(cap), rb, rows)
    else:
        x = _rows_coupling(e, ra, rb, rows)
    return x * _entry_sign(rows, e, n, ib)


@wp.func(inline=True)
def _softness(rows: Rows, n: int, i: int):
    if i < n or _cap_entry(rows, n, i) >= 0:
        return LIMIT_SOFTNESS
    return CONTACT_SOFTNESS


@wp.func(inline=True)
def _pivot_floor(soft: int, inv_mass: float):
    """The smallest pivot of a block entry's Cholesky column (its row's 1/(J M⁻¹ Jᵀ):
    `inv_mass`) that counts it independent of the rows before it."""
    if soft != 0:
        return PIVOT_FLOOR / inv_mass
    return 1.0e-6 * inv_mass


@wp.func
def _limit_dof(limit_dof: wp.array(dtype=wp.int32), i: int):
    """The dof of joint-limit row i."""
    return limit_dof[i / 2]


@wp.func
def _limit_sign(i: int):
    """+1 for a lower limit row (even i), -1 for an upper one: J = sign·e_dof."""
    return 1.0 - 2.0 * float(i % 2)


@wp.func(inline=True)
def _joint_limit_block(m: ModelArrays, e: int, layout: RowLayout,
                       limit_dof: wp.array(dtype=wp.int32), ncand: int, ncontact_in: int,
                       nentry: int, caps: int, biased: int, tgs: int, hs: float, h: float,
                       max_depenetration: float, max_correction: float,
                       factor: wp.array2d(dtype=float), rows: Rows,
                       v: wp.array2d(dtype=float), dq: wp.array2d(dtype=float)):
    """The joint-limit rows of the env, and the contacts listed with them, solved together,
    exactly: the impulses λ ≥ 0 for which every row reaches its target J·v where it pushes and
    stays at or above it where it does not (a linear complementarity problem on A = J M⁻¹ Jᵀ).

    Row by row, Gauss-Seidel converges slowly on limits coupled through a chain (each push
    moves every joint outboard of it): a chain of six 0.1 kg links resting on its limits never
    came to rest at 4 sweeps, its joints chattering at up to 20 rad/s and 0.5 rad past the
    limits (`benchmarks/limit_chain.py`); and on a limit and a contact of one chain
    (`_block_contacts`). Here each sweep finds the active set by pivoting (Murty's principal
    pivoting: solve A_SS λ_S = target_S - w0_S by Cholesky, drop the most negative λ, add the
    most violated row outside S) from the rows that pushed or want to. For a limit row
    J_i = ±e_dof, so A_ij is one entry of row j's response; only rows that enter the active set
    are built (responses on demand, as for single rows).

    Only the pivoting is here, one lane's work: the entries (`nentry` of them: the `ncand`
    limit candidates listed by `_limit_rows`, the `ncontact_in` listed contacts, then the
    speed caps that join, if `caps`) come with their impulses taken out of v, and the new
    impulses are left in rows.lam (the caps' in block_lam) for the caller to apply
    (`_limit_rows`). Limits are corrected at up to `max_correction`, contacts at up to
    `max_depenetration`; a cap's target is the cap.
    """
    n = layout.tendon_limits - layout.joint_limits
    ncap = int(0)              # the speed caps taken in (`_cap_broken`), none yet
    if rows.block_cap.shape[1] > 0:
        rows.block_cap[e, 0] = -1
    # targets; J·v without the block's impulses (w0); the starting active set: the rows that
    # pushed, and those that want to (the limits and contacts: caps join in the pivoting)
    count = int(0)
    for t in range(nentry):
        i = _entry(rows, e, n, ncand, ncontact_in, t)
        r = _entry_row(layout, rows, e, i)
        rows.block_in[e, i] = 0
        rows.block_lam[e, i] = 0.0
        if rows.type[e, r] != NORMAL:      # could not be built in an earlier sweep
            continue
        if i < n:
            dof = _limit_dof(limit_dof, i)
            sign = _limit_sign(i)
            err = rows.err[e, r]
            if tgs != 0:
                err = err + sign * dq[e, dof]
            target = _normal_target(err, biased, hs, h, max_correction, rows.bounce[e, r])
            rows.block_w0[e, i] = sign * v[e, dof]
        else:
            sp = rows.span[e, r]
            err = rows.err[e, r]
            if tgs != 0:
                err = err + dense.row_dot(rows.jac, e, r, dq, sp)
            target = _normal_target(err, biased, hs, h, max_depenetration, rows.bounce[e, r])
            rows.block_w0[e, i] = dense.row_dot(rows.jac, e, r, v, sp)
        rows.block_target[e, i] = target
        if rows.lam[e, r] > 0.0 or target > rows.block_w0[e, i]:
            rows.block_in[e, i] = 1
            rows.block_row[e, count] = i
            count += 1
    if count == 0:
        return
    # with contacts in the block every diagonal is softened (CONTACT_SOFTNESS, LIMIT_SOFTNESS)
    soft = int(ncontact_in > 0)
    pivots = int(0)
    entries = int(nentry)      # and the caps as they join
    while pivots <= 2 * (n + nentry - ncand + rows.block_cap.shape[1]):
        pivots += 1
        # build the active rows' responses; a row that cannot be built leaves the set
        a = int(0)
        while a < count:
            i = rows.block_row[e, a]
            r = _entry_row(layout, rows, e, i)
            if rows.inv_mass[e, r] == 0.0:
                if i < n:
                    build_dof_row(m, e, r, _limit_dof(limit_dof, i), _limit_sign(i), NORMAL,
                                  factor, rows)
                elif _cap_entry(rows, n, i) >= 0:
                    build_dof_row(m, e, r, r - layout.dofs, 1.0, DOF, factor, rows)
                else:
                    build_contact_rows(m, e, r, layout.contact_width, rows.span[e, r], factor,
                                       rows)
            if not _entry_live(layout, rows, e, n, i, r):
                rows.block_in[e, i] = 0
                count -= 1
                rows.block_row[e, a] = rows.block_row[e, count]
            else:
                a += 1
        # Cholesky of A_SS (lower triangle of block_a), then λ_S = A_SS⁻¹ (target - w0)_S
        singular = int(-1)
        for a in range(count):
            ia = rows.block_row[e, a]
            ra = _entry_row(layout, rows, e, ia)
            for b in range(a + 1):
                ib = rows.block_row[e, b]
                x = _coupling(limit_dof, e, n, ia, ra, ib, _entry_row(layout, rows, e, ib),
                              rows)
                if b == a and soft != 0:
                    x = x + _softness(rows, n, ia) / rows.inv_mass[e, ra]
                for c in range(b):
                    x = x - rows.block_a[e, a, c] * rows.block_a[e, b, c]
                if b < a:
                    rows.block_a[e, a, b] = x / rows.block_a[e, b, b]
                elif x > _pivot_floor(soft, rows.inv_mass[e, ra]) and singular < 0:
                    rows.block_a[e, a, a] = wp.sqrt(x)
                elif singular < 0:
                    singular = a          # dependent on rows before it (both sides of a dof)
                    rows.block_a[e, a, a] = 1.0
        if singular >= 0:
            i = rows.block_row[e, singular]
            rows.block_in[e, i] = 0
            count -= 1
            rows.block_row[e, singular] = rows.block_row[e, count]
            continue
        for a in range(count):        # forward substitution
            i = rows.block_row[e, a]
            x = rows.block_target[e, i] - rows.block_w0[e, i]
            if soft != 0 and _cap_entry(rows, n, i) < 0:
                # the softness pulls toward the impulse before the block (a cap's: none)
                r = _entry_row(layout, rows, e, i)
                x = x + rows.lam[e, r] * _softness(rows, n, i) / rows.inv_mass[e, r]
            for c in range(a):
                x = x - rows.block_a[e, a, c] * rows.block_lam[e, rows.block_row[e, c]]
            rows.block_lam[e, i] = x / rows.block_a[e, a, a]
        for aa in range(count):       # back substitution
            a = count - 1 - aa
            i = rows.block_row[e, a]
            x = rows.block_lam[e, i]
            for c in range(a + 1, count):
                x = x - rows.block_a[e, c, a] * rows.block_lam[e, rows.block_row[e, c]]
            rows.block_lam[e, i] = x / rows.block_a[e, a, a]
        # a negative impulse leaves the set
        worst = int(-1)
        lowest = float(0.0)
        for a in range(count):
            x = rows.block_lam[e, rows.block_row[e, a]]
            if x < lowest:
                lowest = x
                worst = a
        if worst >= 0:
            i = rows.block_row[e, worst]
            rows.block_in[e, i] = 0
            rows.block_lam[e, i] = 0.0
            count -= 1
            rows.block_row[e, worst] = rows.block_row[e, count]
            continue
        # a row outside the set that the set's impulses leave short of its target joins it
        worst = int(-1)
        most = float(0.0)
        for t in range(entries):
            i = _entry(rows, e, n, ncand, ncontact_in, t)
            if rows.block_in[e, i] != 0:
                continue
            r = _entry_row(layout, rows, e, i)
            if not _entry_live(layout, rows, e, n, i, r):
                continue
            w = rows.block_w0[e, i]
            for a in range(count):
                ib = rows.block_row[e, a]
                w = w + rows.block_lam[e, ib] * _coupling(
                    limit_dof, e, n, i, r, ib, _entry_row(layout, rows, e, ib), rows)
            short = rows.block_target[e, i] - w
            if short > most + 1.0e-6 * (1.0 + wp.abs(rows.block_target[e, i])):
                most = short
                worst = i
        if worst < 0 and caps != 0 and ncap < rows.block_cap.shape[1]:
            # none: a dof the set's impulses send past its speed cap joins it
            cap = _cap_broken(layout, e, n, ncap, count, rows, v)
            if cap >= 0:
                worst = n + rows.block_contact.shape[1] + ncap
                rows.block_cap[e, ncap] = cap
                ncap += 1
                if ncap < rows.block_cap.shape[1]:
                    rows.block_cap[e, ncap] = -1
                entries += 1
                r = layout.dofs + cap / 2
                rows.block_target[e, worst] = -rows.k[e, r]
                rows.block_w0[e, worst] = _limit_sign(cap) * v[e, cap / 2]
                rows.block_lam[e, worst] = 0.0
        if worst < 0:
            break
        rows.block_in[e, worst] = 1
        rows.block_row[e, count] = worst
        count += 1
    # the new impulses (applied to the velocity by the caller)
    for t in range(entries):
        i = _entry(rows, e, n, ncand, ncontact_in, t)
        r = _entry_row(layout, rows, e, i)
        new = float(0.0)
        if rows.block_in[e, i] != 0:
            new = wp.max(rows.block_lam[e, i], 0.0)
        if _cap_entry(rows, n, i) >= 0:
            rows.block_lam[e, i] = new
        elif rows.type[e, r] == NORMAL:
            rows.lam[e, r] = new


@wp.func
def _friction_rows(e: int, ln: wp.vec2i, r: int, width: int, biased: int, tgs: int, hs: float,
                   rows: Rows, c: Contacts, v: wp.array2d(dtype=float),
                   dq: wp.array2d(dtype=float)):
    """A contact's two friction rows r, r + 1 together, their impulse projected onto the disk
    of radius mu · the normal row's impulse (row r - 1). Marks the contact slid when the
    projection cut the impulse (its anchors start afresh next substep)."""
    if rows.type[e, r] != FRICTION:
        return
    old1 = rows.lam[e, r]
    old2 = rows.lam[e, r + 1]
    limit = rows.mu[e, r] * rows.lam[e, r - 1]
    if limit == 0.0 and old1 == 0.0 and old2 == 0.0:
        return     # no normal impulse, no friction: the projection below gives zero
    sp = rows.span[e, r]
    # static friction holds the contact where it began to stick (`constraints`, the anchors):
    # position sweeps undo the drift since then, err + J_t·dq in TGS
    target_t = wp.vec2(0.0, 0.0)
    if biased != 0:
        drift = wp.vec2(rows.err[e, r], rows.err[e, r + 1])
        if tgs != 0:
            drift = drift + _row_dot2(rows, rows.jac, e, r, dq, sp, ln)
        target_t = -1.0 * drift / hs
    c.slid[e, r / width] = _disk_rows(e, ln, r, old1, old2, target_t, limit, sp, rows, v)


@wp.func(inline=True)
def _disk_rows(e: int, ln: wp.vec2i, r: int, old1: float, old2: float, target: wp.vec2,
               bound: float, sp: wp.vec4i, rows: Rows, v: wp.array2d(dtype=float)):
    """Rows r, r + 1 (impulses old1, old2 so far) toward J·v = target, both from the same
    velocity, their impulse then projected onto the disk of radius `bound`; 1 if the
    projection cut it (the contact slides or rolls), else 0."""
    jv = _row_dot2(rows, rows.jac, e, r, v, sp, ln)
    l1 = old1 + (target[0] - jv[0]) * rows.inv_mass[e, r]
    l2 = old2 + (target[1] - jv[1]) * rows.inv_mass[e, r + 1]
    norm = wp.sqrt(l1 * l1 + l2 * l2)
    cut = int(norm > bound)
    if cut != 0:
        scale = float(0.0)
        if norm > 0.0:
            scale = bound / norm
        l1 = l1 * scale
        l2 = l2 * scale
    rows.lam[e, r] = l1
    rows.lam[e, r + 1] = l2
    _apply2(e, ln, r, l1 - old1, l2 - old2, rows.minv_jt, v, sp)
    return cut


@wp.func
def _angular_rows(e: int, ln: wp.vec2i, r0: int, width: int, biased: int, tgs: int, hs: float,
                  rows: Rows, v: wp.array2d(dtype=float), dq: wp.array2d(dtype=float)):
    """The torsional row r0 + 3 of the contact whose normal row is r0, its impulse within
    ±mu_spin · the normal impulse, and with `width` 6 its two rolling rows together, projected
    onto the disk of radius mu_roll · the normal impulse (MuJoCo's condim 4 and 6; each bound
    apart from the sliding disk's, where MuJoCo's elliptic cone joins them). They stop the two
    bodies' relative rotation about those axes; in TGS position sweeps also the rotation of
    this substep's earlier sub-steps (J·dq), as the sliding rows undo their drift."""
    normal = rows.lam[e, r0]
    r = r0 + 3
    if rows.type[e, r] == SPIN:
        old = rows.lam[e, r]
        limit = rows.mu[e, r] * normal
        if limit > 0.0 or old != 0.0:
            sp = rows.span[e, r]
            spin_target = float(0.0)
            if biased != 0 and tgs != 0:
                spin_target = -_dot(rows, rows.jac, e, r, dq, sp, ln) / hs
            jv = _dot(rows, rows.jac, e, r, v, sp, ln)
            new = wp.clamp(old + (spin_target - jv) * rows.inv_mass[e, r], -limit, limit)
            rows.lam[e, r] = new
            _apply(v, e, new - old, rows.minv_jt, r, sp, ln)
    r = r0 + 4
    if width > 4 and rows.type[e, r] == ROLL:
        old1 = rows.lam[e, r]
        old2 = rows.lam[e, r + 1]
        bound = rows.mu[e, r] * normal
        if bound > 0.0 or old1 != 0.0 or old2 != 0.0:
            sp2 = rows.span[e, r]
            target = wp.vec2(0.0, 0.0)
            if biased != 0 and tgs != 0:
                target = -1.0 * _row_dot2(rows, rows.jac, e, r, dq, sp2, ln) / hs
            _disk_rows(e, ln, r, old1, old2, target, bound, sp2, rows, v)


@wp.func
def _spring_row(e: int, ln: wp.vec2i, r: int, h: float, rows: Rows,
                v: wp.array2d(dtype=float)):
    """A tendon's implicit spring-damper over the whole substep, applied once (first sweep) like
    the other forces: impulse = -(h·k·err + a·J·v) / (1 + a·w), a = h·(h·k + d). Applied per TGS
    sub-step instead, it would fight the once-per-substep external forces and leave a spurious
    velocity at equilibrium."""
    if rows.type[e, r] != SOFT:
        return
    sp = rows.span[e, r]
    k = rows.k[e, r]
    a = h * (h * k + rows.d[e, r])
    w = 1.0 / rows.inv_mass[e, r]
    old = rows.lam[e, r]      # read before the sum's wait, after which every lane writes it
    jv = _dot(rows, rows.jac, e, r, v, sp, ln)
    dl = -(h * k * rows.err[e, r] + a * jv) / (1.0 + a * w)
    rows.lam[e, r] = old + dl
    _apply(v, e, dl, rows.minv_jt, r, sp, ln)


@wp.func
def _dof_row(m: ModelArrays, e: int, r: int, dof: int, factor: wp.array2d(dtype=float),
             rows: Rows, v: wp.array2d(dtype=float)):
    """Row r along one dof, J = e_dof (J·v is the dof's own speed): its dry friction, then its
    maximum speed."""
    if rows.type[e, r] != DOF:
        return
    bound = rows.mu[e, r]
    if bound > 0.0:
        # joint friction: stop the dof, with at most frictionloss·h of impulse per substep
        old = rows.lam[e, r]
        new = wp.clamp(old - v[e, dof] * rows.inv_mass[e, r], -bound, bound)
        rows.lam[e, r] = new
        dense.row_apply(v, e, new - old, rows.minv_jt, r, rows.span[e, r])
    # maximum joint speed: a joint-space impulse brings it back inside
    jv = v[e, dof]
    cap = rows.k[e, r]
    if wp.abs(jv) > cap:
        if rows.inv_mass[e, r] == 0.0:   # first time past the cap in this substep
            build_dof_row(m, e, r, dof, 1.0, DOF, factor, rows)
        if rows.type[e, r] == DOF:
            dense.row_apply(v, e, (wp.clamp(jv, -cap, cap) - jv) * rows.inv_mass[e, r],
                            rows.minv_jt, r, rows.span[e, r])


@wp.func
def _row_dot2(rows: Rows, a: wp.array3d(dtype=float), e: int, r: int,
              v: wp.array2d(dtype=float), sp: wp.vec4i, ln: wp.vec2i):
    """(a[e, r] · v[e], a[e, r + 1] · v[e]) over the rows' span."""
    return wp.vec2(_dot(rows, a, e, r, v, sp, ln), _dot(rows, a, e, r + 1, v, sp, ln))


@wp.func
def _apply2(e: int, ln: wp.vec2i, r: int, dl1: float, dl2: float,
            minv_jt: wp.array3d(dtype=float), v: wp.array2d(dtype=float), sp: wp.vec4i):
    """v += M⁻¹J_rᵀ·dl1 + M⁻¹J_{r+1}ᵀ·dl2 over the rows' span."""
    if dl1 == 0.0 and dl2 == 0.0:
        return
    _apply(v, e, dl1, minv_jt, r, sp, ln)
    _apply(v, e, dl2, minv_jt, r + 1, sp, ln)


@wp.kernel
def solve(m: ModelArrays, opt: Options, layout: RowLayout,
          d: Dynamics,     # in: factor
          c: Contacts,     # in: count; out: slid
          # in: rows as built; out: their impulses (lam), and responses built on demand
          rows: Rows,
          # in: qd (the velocity at the start of the substep), qacc; out: qd (the new velocity),
          # qd_before (the old), dq (the displacement to integrate)
          s: State,
          lanes: int):
    """A world's lanes (one world per block: its sums are the block's) sweep its rows
    together, each lane holding the dofs i % lanes == lane of qd and dq (`_sweep`)."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    if not active:
        return      # (one world per block: a thread past the worlds is a whole block past)
    ln = wp.vec2i(lane, lanes)
    limit_dof = opt.limit_dof
    h = opt.h
    position_iterations = opt.position_iterations
    velocity_iterations = opt.velocity_iterations
    tgs = opt.tgs
    max_depenetration = opt.max_depenetration
    max_correction = opt.max_correction
    nv = m.nv
    for i in range(lane, nv, lanes):
        s.qd_before[e, i] = s.qd[e, i]
        s.qd[e, i] = s.qd[e, i] + h * s.qacc[e, i]
        s.dq[e, i] = 0.0
    ncontact = wp.min(c.count[e], layout.contact_slots)
    # rows in use: the contacts' [0, used), and all from the limits on
    used = layout.contact_width * ncontact
    for i in range(used + layout.end - layout.joint_limits):
        r = _row_in_use(i, used, layout)
        warm = float(0.0)
        if rows.type[e, r] >= 0:
            warm = rows.lam_init[e, r]
            if rows.type[e, r] == NORMAL:
                warm = WARM * rows.lam_init[e, r]
            if warm != 0.0:      # (most rows start from zero: no call, no span read)
                _apply(s.qd, e, warm, rows.minv_jt, r, rows.span[e, r], ln)
        rows.lam[e, r] = warm
    for k in range(ncontact):
        c.slid[e, k] = 0
    # a hand has 88 tendon-limit rows, seldom one active: the sweeps visit only their span
    tendon_limits = _in_use(rows, e, layout.tendon_limits, layout.equalities)
    hs = h
    if tgs != 0:
        hs = h / float(position_iterations)
    for it in range(position_iterations):
        _sweep(m, e, ln, layout, ncontact, tendon_limits, c, limit_dof, int(it == 0), 1, tgs,
               hs, h, max_depenetration, max_correction, d.factor, rows, s.qd, s.dq)
        if tgs != 0:
            for i in range(lane, nv, lanes):
                s.dq[e, i] = s.dq[e, i] + hs * s.qd[e, i]
    if tgs == 0:
        for i in range(lane, nv, lanes):
            s.dq[e, i] = h * s.qd[e, i]
    for it in range(velocity_iterations):
        _sweep(m, e, ln, layout, ncontact, tendon_limits, c, limit_dof, 0, 0, tgs, hs, h,
               max_depenetration, max_correction, d.factor, rows, s.qd, s.dq)
    # the speed caps hold exactly: a dof's row is swept before the contacts that follow it can
    # push the dof past its cap again, and one velocity sweep leaves that overshoot in place.
    # A G1 with hands curled up on itself under random torques (hundreds of contacts between
    # its light finger links) went from 750 to 29,000 rad/s in one step and then non-finite
    for dof in range(lane, layout.end - layout.dofs, lanes):
        r = layout.dofs + dof
        if rows.type[e, r] == DOF and wp.abs(s.qd[e, dof]) > rows.k[e, r]:   # (NaN stays NaN)
            s.qd[e, dof] = wp.sign(s.qd[e, dof]) * rows.k[e, r]


@wp.kernel
def constraint_forces(m: ModelArrays, opt: Options, layout: RowLayout, rows: Rows,
                      # in: the contacts; out: their forces (force, net_force)
                      c: Contacts,
                      lanes: int):
    """Forces of the last substep: per contact (on geom 2, world), net per body, per dof; a
    world's lanes take its contacts, then its bodies, then its dofs."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, c.count.shape[0])
    h = opt.h
    ncontact = int(0)
    if active:
        ncontact = wp.min(c.count[e], layout.contact_slots)
    for k in range(lane, stop(layout.contact_slots, 0, active), lanes):
        f = wp.vec3()
        if k < ncontact:
            r0 = layout.contact_width * k
            for d in range(3):
                f = f + rows.dir[e, r0 + d] * rows.lam[e, r0 + d]
            f = f / h
        c.force[e, k] = f
    if lanes > 1:
        sync()
    # each body's sum over the contacts in their order: + on geom 2's body, - on geom 1's; one
    # lane adds each contact into its two bodies, lanes gather per body (the same sums)
    for b in range(lane, stop(m.nbody, 0, active), lanes):
        net = wp.vec3()
        if lanes > 1:
            for k in range(ncontact):
                pair = c.geom[e, k]
                if m.geom_body[pair[1]] == b:
                    net = net + c.force[e, k]
                if m.geom_body[pair[0]] == b:
                    net = net - c.force[e, k]
        c.net_force[e, b] = net
    if lanes == 1:
        for k in range(ncontact):
            pair = c.geom[e, k]
            b1 = m.geom_body[pair[0]]
            b2 = m.geom_body[pair[1]]
            if b2 >= 0:
                c.net_force[e, b2] = c.net_force[e, b2] + c.force[e, k]
            if b1 >= 0:
                c.net_force[e, b1] = c.net_force[e, b1] - c.force[e, k]
    used = layout.contact_width * ncontact
    in_use = used + layout.end - layout.joint_limits
    if lanes == 1:
        # one lane: each row adds its force over its span (the native 8-wide loop)
        for i in range(stop(m.nv, 0, active)):
            rows.dof_force[e, i] = 0.0
        for rr in range(stop(in_use, 0, active)):
            r = _row_in_use(rr, used, layout)
            if rows.type[e, r] >= 0 and rows.lam[e, r] != 0.0:   # (an unbuilt dof row: none)
                dense.row_apply(rows.dof_force, e, rows.lam[e, r] / h, rows.jac, r,
                                rows.span[e, r])
    else:
        # lanes: each dof gathers the same terms in the same order, the same sum bit for bit
        for i in range(lane, stop(m.nv, 0, active), lanes):
            total = float(0.0)
            for rr in range(in_use):
                r = _row_in_use(rr, used, layout)
                if rows.type[e, r] >= 0 and rows.lam[e, r] != 0.0:
                    sp = rows.span[e, r]
                    if (i >= sp[0] and i < sp[1]) or (i >= sp[2] and i < sp[3]):
                        total = dense.add_scaled(total, rows.lam[e, r] / h,
                                                 rows.jac[e, r, _col(sp, i)])
            rows.dof_force[e, i] = total
