"""Generalized forces of one substep: user forces, fluid forces, actuators, joint springs and
dampers; and the actuators' activations (`integrate_activations`).

Writes the explicit force `qfrc` (already minus the bias forces) and `implicit_diag`, the diagonal
joint-space terms h·d + h²·k that the solve adds to the mass matrix. Implicit terms are exact for
the linearized update qd' = qd + h·qacc, q' = q + h·qd':
  joint damping d:        f = -d·qd'                      -> rhs -d·qd,            diag h·d
  position actuator:      f = g·(kp·(u - g·q') - kv·g·qd') -> rhs g·(kp·(u - g·q - h·g·qd) - kv·g·qd),
                                                             diag g²·(h·kv + h²·kp)
  velocity actuator:      f = g·kv·(u - g·qd')            -> rhs g·kv·(u - g·qd),  diag g²·h·kv
A general affine actuator on a joint is implicit like a position actuator in its stabilizing
bias terms; an actuator on a fixed tendon is explicit, as in MuJoCo's Euler step (docs/physics.md,
"Implicit terms"). An actuator whose predicted force (qacc = 0) exceeds its force range applies
the clamped force explicitly instead; so does a joint whose summed actuator force exceeds its effort limit. Joint
springs are explicit, as in MuJoCo. Fixed-tendon springs are soft constraint rows of the solver
(implicit along the tendon only, see `constraints`).

Non-finite input (NaN or ±inf in an env's `ctrl`, `joint_force` or `body_force`) is never clamped
or dropped: the env is flagged in `nonfinite` and every one of its generalized forces becomes NaN,
so its whole state is NaN after the substep, exactly like an env whose state went non-finite. The
other envs are untouched (every kernel is per env).
"""

import warp as wp

from ..lanes import stop, sync, world_lane
from ..types import (CAPSULE, CYLINDER, DYN_FILTER, DYN_FILTEREXACT, DYN_INTEGRATOR,
                     DYN_NONE, HINGE, MOTOR, POSITION, SLIDE, SPHERE, VELOCITY)
from ..spatial import row_finite
from ..spatial import velocity_at
from .dynamics import subtree_sums
from .kinematics import geom_frame
from ..structs import Control, Dynamics, EnvParams, ModelArrays, Options, State



@wp.func
def site_wrench(m: ModelArrays, s: State, e: int, site: int, a: int):
    """Actuator a's wrench per unit force at its site, as the power pairing with a motion
    subspace at the tree's reference point wants it: (torque about that point, force)."""
    x = s.site_x[e, site]
    rot = wp.transform_get_rotation(x)
    gear = m.actuator_site_gear[a]
    force = wp.quat_rotate(rot, wp.spatial_top(gear))
    torque = wp.quat_rotate(rot, wp.spatial_bottom(gear))
    ref = wp.transform_get_translation(s.body_x[e, m.body_root[m.site_body[site]]])
    return wp.spatial_vector(torque + wp.cross(wp.transform_get_translation(x) - ref, force),
                             force)


@wp.func
def clamped_ctrl(m: ModelArrays, c: Control, e: int, a: int):
    u = c.ctrl[e, a]
    if m.actuator_ctrllimited[a] != 0:
        r = m.actuator_ctrlrange[a]
        u = wp.clamp(u, r[0], r[1])
    return u


@wp.func
def next_activation(m: ModelArrays, s: State, c: Control, e: int, a: int, h: float):
    """Actuator a's activation after a substep of h (MuJoCo's act_dot, integrated), from the
    clamped ctrl; clamped to its activation range if limited."""
    u = clamped_ctrl(m, c, e, a)
    act = s.act[e, a]
    kind = m.actuator_dyntype[a]
    tau = wp.max(m.actuator_tau[a], 1.0e-10)
    if kind == DYN_INTEGRATOR:
        act = act + h * u
    elif kind == DYN_FILTER:
        act = act + h * (u - act) / tau
    elif kind == DYN_FILTEREXACT:
        act = act + (u - act) * (1.0 - wp.exp(-h / tau))
    if m.actuator_actlimited[a] != 0:
        r = m.actuator_actrange[a]
        act = wp.clamp(act, r[0], r[1])
    return act


@wp.func
def actuator_input(m: ModelArrays, s: State, c: Control, e: int, a: int, h: float):
    """What actuator a's gain multiplies: its clamped ctrl, or its activation (the one this
    substep ends with, for actearly)."""
    if m.actuator_dyntype[a] != DYN_NONE:
        if m.actuator_actearly[a] != 0:
            return next_activation(m, s, c, e, a, h)
        return s.act[e, a]
    return clamped_ctrl(m, c, e, a)


@wp.kernel
def integrate_activations(m: ModelArrays, opt: Options,
                          s: State,     # in and out: act
                          c: Control):  # in: ctrl
    """Each actuator with activation dynamics: its activation one substep on (a thread per
    env and actuator; run after the substep's forces used the old one)."""
    e, a = wp.tid()
    if m.actuator_dyntype[a] != DYN_NONE:
        s.act[e, a] = next_activation(m, s, c, e, a, opt.h)


@wp.kernel
def generalized_forces(m: ModelArrays, p: EnvParams, opt: Options,
                       s: State,      # in: q, qd; out: nonfinite
                       c: Control,    # in: ctrl
                       # in: qfrc_applied, bias; out: qfrc_actuator, actuator_force, qfrc,
                       # implicit_diag
                       d: Dynamics,
                       lanes: int):
    """Explicit generalized force `qfrc` (minus the bias) and the implicit diagonal of this
    substep, from the applied forces (`body_wrenches`), actuators, damping and joint springs:
    a world's lanes take its dofs, each dof with its actuators (in their order) and its joint."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    h = opt.h
    # non-finite input: the clamps below would turn a NaN ctrl into a bound, so the check
    # looks at the inputs themselves; the env is flagged and its forces poisoned, never patched
    bad = False
    if active:
        bad = not (row_finite(c.ctrl, e, m.nu) and row_finite(d.qfrc_applied, e, m.nv))
        if bad and lane == 0:
            s.nonfinite[e] = 1
    for i in range(lane, stop(m.nv, 0, active), lanes):
        damping = p.dof_damping[e, i]
        qfrc = d.qfrc_applied[e, i] - d.bias[e, i] - damping * s.qd[e, i]
        implicit = h * damping
        actuated = float(0.0)
        # each actuator on this dof: a tendon's is computed by each of its dofs' lanes (a few
        # redundant flops rather than a sync), and reported by its first entry's
        for n in range(m.dof_trn_adr[i], m.dof_trn_adr[i] + m.dof_trn_num[i]):
            k = m.dof_trn[n]     # the transmission entry
            a = m.trn_actuator[k]
            g = p.actuator_gear[e, a]
            u = actuator_input(m, s, c, e, a, h)
            # the transmission's length and velocity before the gear: Σ coef·q, Σ coef·qd; a
            # site's: 0 and the speed along its wrench, Σ (cdof · wrench)·qd
            adr = m.actuator_trnadr[a]
            site = m.actuator_trnsite[a]
            spatial = m.actuator_trnspatial[a]     # a spatial tendon's moment arms: ten_J
            wrench = wp.spatial_vector()
            if site >= 0:
                wrench = site_wrench(m, s, e, site, a)
            q_trn = float(0.0)
            qd_trn = float(0.0)
            if spatial >= 0:
                q_trn = s.ten_length[e, spatial]
            for t in range(adr, adr + m.actuator_trnnum[a]):
                if site >= 0:
                    qd_trn += wp.dot(s.cdof[e, m.trn_dof[t]], wrench) * s.qd[e, m.trn_dof[t]]
                elif spatial >= 0:
                    qd_trn += s.ten_J[e, spatial, m.trn_dof[t]] * s.qd[e, m.trn_dof[t]]
                else:
                    q_trn += m.trn_coef[t] * s.q[e, m.trn_qposadr[t]]
                    qd_trn += m.trn_coef[t] * s.qd[e, m.trn_dof[t]]
            # a joint's drive is implicit in the step (its terms on the mass matrix diagonal);
            # a tendon's or a site's couples several dofs and is explicit, as in MuJoCo's Euler
            implicit_drive = m.actuator_trnnum[a] == 1 and site < 0 and spatial < 0
            kind = m.actuator_kind[a]
            # `reported`: the force at this state (MuJoCo's actuator_force); `force`: what the
            # step applies, with an implicit drive's prediction of the position (-kp·h·v)
            reported = float(0.0)
            force = float(0.0)
            stiff = float(0.0)
            damp = float(0.0)
            if kind == MOTOR:
                force = p.actuator_gain[e, a] * u
                reported = force
            elif kind == VELOCITY:
                force = p.actuator_kv[e, a] * (u - g * qd_trn)
                reported = force
                damp = p.actuator_kv[e, a]
            elif kind == POSITION:
                kp = p.actuator_kp[e, a]
                kv = p.actuator_kv[e, a]
                length = g * q_trn
                reported = kp * (u - length) - kv * g * qd_trn
                force = reported
                if implicit_drive:
                    force = kp * (u - length - h * g * qd_trn) - kv * g * qd_trn
                    stiff = kp
                damp = kv
            else:   # AFFINE
                kp = p.actuator_kp[e, a]
                kv = p.actuator_kv[e, a]
                lv = m.actuator_gain_lv[a]
                gain = p.actuator_gain[e, a] + lv[0] * g * q_trn + lv[1] * g * qd_trn
                reported = gain * u + m.actuator_bias[a] - kp * g * q_trn - kv * g * qd_trn
                force = reported
                if kp >= 0.0 and kv >= 0.0:   # a stabilizing bias only
                    force = reported - kp * h * g * qd_trn
                    stiff = kp
                    damp = kv
            if not implicit_drive:
                force = reported
                stiff = 0.0
                damp = 0.0
            if m.actuator_forcelimited[a] != 0:
                r = m.actuator_forcerange[a]
                reported = wp.clamp(reported, r[0], r[1])
                if force < r[0] or force > r[1]:
                    force = wp.clamp(force, r[0], r[1])
                    stiff = 0.0
                    damp = 0.0
            if k == adr:
                d.actuator_force[e, a] = reported
                if bad:
                    d.actuator_force[e, a] = wp.nan
            moment = g * m.trn_coef[k]
            if site >= 0:
                moment = g * wp.dot(s.cdof[e, i], wrench)
            elif spatial >= 0:
                moment = g * s.ten_J[e, spatial, i]
            actuated = actuated + moment * force
            implicit = implicit + moment * moment * (h * damp + h * h * stiff)
        j = m.dof_jnt[i]
        t = m.jnt_type[j]
        if t == HINGE or t == SLIDE:
            qfrc = qfrc - p.joint_stiffness[e, j] * (s.q[e, m.jnt_qposadr[j]]
                                                     - m.jnt_springref[j])
            # effort limit on the joint's total actuator force (URDF effort, MJCF
            # actuatorfrcrange)
            if m.jnt_actfrclimited[j] != 0:
                r = m.jnt_actfrcrange[j]
                if actuated < r[0] or actuated > r[1]:
                    actuated = wp.clamp(actuated, r[0], r[1])
                    implicit = h * damping
        d.qfrc_actuator[e, i] = actuated
        d.qfrc[e, i] = qfrc + actuated
        d.implicit_diag[e, i] = implicit
        if bad:
            d.qfrc_actuator[e, i] = wp.nan
            d.qfrc[e, i] = wp.nan


@wp.func
def fluid_wrench(p: EnvParams, s: State, e: int, b: int, ref: wp.vec3):
    """MuJoCo's inertia-box fluid model: the force and torque (world, at the center of mass) of
    env e's medium on body b, from the box of the body's mass and inertia moving through it.
    Viscous drag is linear in the velocity (Stokes, on the sphere of the box's mean side),
    density's drag quadratic on each face of the box; `ref`: the body tree's reference point."""
    density = p.fluid_density[e]
    viscosity = p.fluid_viscosity[e]
    mass = p.body_mass[e, b]
    if mass < 1.0e-15:              # (the caller asks only where the env has a medium)
        return wp.spatial_vector()
    inertia = p.body_inertia[e, b]
    box = wp.vec3(wp.sqrt(wp.max(1.0e-15, inertia[1] + inertia[2] - inertia[0]) / mass * 6.0),
                  wp.sqrt(wp.max(1.0e-15, inertia[0] + inertia[2] - inertia[1]) / mass * 6.0),
                  wp.sqrt(wp.max(1.0e-15, inertia[0] + inertia[1] - inertia[2]) / mass * 6.0))
    frame = s.body_iframe[e, b]
    cvel = s.cvel[e, b]
    # velocities relative to the medium, in the frame of the principal axes
    w = wp.quat_rotate_inv(frame, wp.spatial_top(cvel))
    v = wp.quat_rotate_inv(frame, velocity_at(cvel, s.body_com[e, b] - ref) - p.wind[e])
    torque = wp.vec3()
    force = wp.vec3()
    if viscosity > 0.0:
        diameter = (box[0] + box[1] + box[2]) / 3.0
        torque = -wp.pi * diameter * diameter * diameter * viscosity * w
        force = -3.0 * wp.pi * diameter * viscosity * v
    if density > 0.0:
        b4 = wp.cw_mul(wp.cw_mul(box, box), wp.cw_mul(box, box))
        force -= 0.5 * density * wp.vec3(box[1] * box[2] * wp.abs(v[0]) * v[0],
                                          box[0] * box[2] * wp.abs(v[1]) * v[1],
                                          box[0] * box[1] * wp.abs(v[2]) * v[2])
        torque -= density / 64.0 * wp.vec3(box[0] * (b4[1] + b4[2]) * wp.abs(w[0]) * w[0],
                                            box[1] * (b4[0] + b4[2]) * wp.abs(w[1]) * w[1],
                                            box[2] * (b4[0] + b4[1]) * wp.abs(w[2]) * w[2])
    return wp.spatial_vector(wp.quat_rotate(frame, force), wp.quat_rotate(frame, torque))


@wp.func
def _semi_axes(kind: int, size: wp.vec3):
    """A geom's ellipsoid for the fluid model: its three semi-axes (MuJoCo's)."""
    if kind == SPHERE:
        return wp.vec3(size[0], size[0], size[0])
    if kind == CAPSULE:
        return wp.vec3(size[0], size[0], size[1] + size[0])
    if kind == CYLINDER:
        return wp.vec3(size[0], size[0], size[1])
    return size


@wp.func
def _pow4(x: float):
    return (x * x) * (x * x)


@wp.func
def _largest_moment(size: wp.vec3, axis: int):
    """8/15·π·d·(largest other semi-axis)⁴: the moment of the ellipsoid about `axis` were it
    round in its widest section."""
    d0 = size[axis]
    d1 = size[(axis + 1) % 3]
    d2 = size[(axis + 2) % 3]
    return 8.0 / 15.0 * wp.pi * d0 * _pow4(wp.max(d1, d2))


@wp.func
def ellipsoid_fluid_wrench(m: ModelArrays, p: EnvParams, s: State, e: int, b: int,
                           ref: wp.vec3):
    """MuJoCo's ellipsoid fluid model (geoms with fluidshape="ellipsoid"): for each such geom of
    body b, the forces of the medium on its ellipsoid moving through it (added mass, Magnus and
    Kutta lift, Stokes drag, blunt and slender quadratic drag, angular drag, each with the
    geom's fluidcoef), as (force, torque) at the body's center of mass, world."""
    density = p.fluid_density[e]
    viscosity = p.fluid_viscosity[e]
    total_force = wp.vec3()
    total_torque = wp.vec3()
    com = s.body_com[e, b]
    cvel = s.cvel[e, b]
    if p.body_mass[e, b] < 1.0e-15:
        return wp.spatial_vector()
    for g in range(m.body_geomadr[b], m.body_geomadr[b] + m.body_geomnum[b]):
        coef = m.geom_fluid[g]
        if coef[0] == 0.0:
            continue
        size = _semi_axes(m.geom_type[g], p.geom_size[e, g])
        frame = geom_frame(m, p, s, e, g)
        rot = wp.transform_get_rotation(frame)
        pos = wp.transform_get_translation(frame)
        w = wp.quat_rotate_inv(rot, wp.spatial_top(cvel))
        v = wp.quat_rotate_inv(rot, velocity_at(cvel, pos - ref) - p.wind[e])
        blunt = coef[1]
        slender = coef[2]
        angular = coef[3]
        kutta = coef[4]
        magnus = coef[5]
        virtual_mass = wp.vec3(coef[6], coef[7], coef[8])
        virtual_inertia = wp.vec3(coef[9], coef[10], coef[11])
        # added mass: the medium carried along, its momentum turned by the body's rotation
        momentum = density * wp.cw_mul(virtual_mass, v)
        angular_momentum = density * wp.cw_mul(virtual_inertia, w)
        force = wp.cross(momentum, w)
        torque = wp.cross(momentum, v) + wp.cross(angular_momentum, w)
        # lift and drag
        volume = 4.0 / 3.0 * wp.pi * size[0] * size[1] * size[2]
        d_max = wp.max(wp.max(size[0], size[1]), size[2])
        d_min = wp.min(wp.min(size[0], size[1]), size[2])
        d_mid = size[0] + size[1] + size[2] - d_max - d_min
        area_max = wp.pi * d_max * d_mid
        magnus_force = magnus * density * volume * wp.cross(w, v)
        yz = size[1] * size[2]
        zx = size[2] * size[0]
        xy = size[0] * size[1]
        proj_den = _pow4(yz) * v[0] * v[0] + _pow4(zx) * v[1] * v[1] + _pow4(xy) * v[2] * v[2]
        proj_num = yz * yz * v[0] * v[0] + zx * zx * v[1] * v[1] + xy * xy * v[2] * v[2]
        area = wp.pi * wp.sqrt(proj_den / wp.max(1.0e-15, proj_num))   # seen along v
        normal = wp.vec3(yz * yz * v[0], zx * zx * v[1], xy * xy * v[2])
        speed = wp.length(v)
        cos_alpha = proj_num / wp.max(1.0e-15, speed * proj_den)
        circulation = kutta * density * cos_alpha * area * wp.cross(normal, v)
        kutta_force = wp.cross(circulation, v)
        sphere_d = 2.0 / 3.0 * (size[0] + size[1] + size[2])
        i_max = 8.0 / 15.0 * wp.pi * d_mid * _pow4(d_max)
        moments = wp.vec3(_largest_moment(size, 0), _largest_moment(size, 1),
                          _largest_moment(size, 2))
        spin_drag = wp.cw_mul(w, angular * moments + slender * (wp.vec3(i_max, i_max, i_max)
                                                                 - moments))
        linear_drag = (viscosity * 3.0 * wp.pi * sphere_d
                       + density * speed * (area * blunt + slender * (area_max - area)))
        angular_drag = (viscosity * wp.pi * sphere_d * sphere_d * sphere_d
                        + density * wp.length(spin_drag))
        torque = torque - angular_drag * w
        force = force + magnus_force + kutta_force - linear_drag * v
        force = coef[0] * wp.quat_rotate(rot, force)
        torque = coef[0] * wp.quat_rotate(rot, torque)
        total_force += force
        total_torque += torque + wp.cross(pos - com, force)
    return wp.spatial_vector(total_force, total_torque)


@wp.func
def speed_cap_wrench(p: EnvParams, s: State, e: int, b: int, ref: wp.vec3, h: float):
    """PhysX's body speed caps (maxAngularVelocity, maxLinearVelocity): the (force at the
    center of mass, torque) that would bring body b back to its caps within the substep h if
    it were free, -I·ω·(1 - cap/|ω|)/h and -m·v·(1 - cap/|v|)/h; zero below them. Its joints
    share the pull with the rest of its tree, so it slows less than a free body would."""
    cvel = s.cvel[e, b]
    w = wp.spatial_top(cvel)
    v = velocity_at(cvel, s.body_com[e, b] - ref)
    torque = wp.vec3()
    force = wp.vec3()
    w_cap = p.body_max_angular_velocity[e, b]
    v_cap = p.body_max_linear_velocity[e, b]
    if wp.dot(w, w) > w_cap * w_cap:
        frame = s.body_iframe[e, b]
        spin = wp.cw_mul(p.body_inertia[e, b], wp.quat_rotate_inv(frame, w))
        torque = -(1.0 - w_cap / wp.length(w)) / h * wp.quat_rotate(frame, spin)
    if wp.dot(v, v) > v_cap * v_cap:
        force = -(1.0 - v_cap / wp.length(v)) / h * p.body_mass[e, b] * v
    return wp.spatial_vector(force, torque)


@wp.kernel
def body_wrenches(m: ModelArrays, p: EnvParams, opt: Options,
                  s: State,      # in: body_x, body_com, cdof, cvel; out: nonfinite
                  c: Control,    # in: joint_force, body_force
                  # out: qfrc_applied; scratch: wrench (each body's, then its subtree's)
                  d: Dynamics,
                  lanes: int):
    """qfrc_applied = joint_force + Jᵀ·(force at the center of mass, torque) of every body:
    its body_force plus its env's fluid forces (`fluid_wrench`) and the pull of its speed caps
    (`speed_cap_wrench`).

    `body_force[e, b]` is (force, torque) in world axes, the force acting at the body's center of
    mass. A dof feels the wrenches of all bodies it carries: Σ over its subtree, projected on the
    dof's motion vector (so no per-body Jacobian is ever formed). A non-finite `body_force`
    flags the env and makes all of its `qfrc_applied` NaN, even on a body that no dof carries
    (a non-finite `joint_force` reaches `generalized_forces` through `qfrc_applied`).
    """
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    bad = int(0)
    for b in range(stop(m.nbody, 0, active)):        # every lane reads them all
        if not wp.isfinite(c.body_force[e, b]):
            bad = 1
    for b in range(lane, stop(m.nbody, 0, active), lanes):
        f = wp.spatial_top(c.body_force[e, b])
        torque = wp.spatial_bottom(c.body_force[e, b])
        ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
        if p.fluid_density[e] > 0.0 or p.fluid_viscosity[e] > 0.0:
            fluid = wp.spatial_vector()
            if m.body_fluid_ellipsoid[b] != 0:
                fluid = ellipsoid_fluid_wrench(m, p, s, e, b, ref)
            else:
                fluid = fluid_wrench(p, s, e, b, ref)
            f = f + wp.spatial_top(fluid)
            torque = torque + wp.spatial_bottom(fluid)
        pull = speed_cap_wrench(p, s, e, b, ref, opt.h)
        f = f + wp.spatial_top(pull)
        torque = torque + wp.spatial_bottom(pull)
        arm = s.body_com[e, b] - ref
        d.wrench[e, b] = wp.spatial_vector(torque + wp.cross(arm, f), f)
    if lanes > 1:
        sync()
    subtree_sums(m, e, lane, lanes, active, d.wrench)
    for i in range(lane, stop(m.nv, 0, active), lanes):
        d.qfrc_applied[e, i] = (c.joint_force[e, i]
                                + wp.dot(s.cdof[e, i], d.wrench[e, m.dof_body[i]]))
        if bad != 0:
            d.qfrc_applied[e, i] = wp.nan
    if bad != 0 and lane == 0:
        s.nonfinite[e] = 1
