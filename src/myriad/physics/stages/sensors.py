"""Stage 7, outputs: MuJoCo's sensors, with MuJoCo's meaning, at the end of each step.

`Model.sensor_*` lists the sensors in MuJoCo's order; `sensor_readings` writes their values into
the flat `sensor_data` [N, nsensordata], laid out as MuJoCo's `d.sensordata` (quaternions
w, x, y, z), a world's lanes taking its sensors, each as `mj_sensorPos/Vel/Acc` do. What a sensor
reads, and when:

- position and velocity sensors (joint position and velocity, frame position, orientation, axes
  and velocities, velocimeter, gyro) read the new state: the kinematics after the last substep,
  what MuJoCo's `mj_forward` reads at that state;
- acceleration and force sensors (accelerometer, frame accelerations, force, torque, touch,
  actuator and joint actuator force) read what the step did: the accelerations it produced,
  (qd - qd_before) / h of its last substep, at the new poses, and the contact and actuator
  forces of that substep. (After `mj_step`, MuJoCo's `d.sensordata` holds the sensors of the
  state before the step, since they run inside its `mj_forward`, before the integration.)

The accelerations come from `force_sensors`, launched only when a sensor needs them. A force/
torque sensor on a site reads the wrench that the site's body receives from its parent: what the
body's whole subtree needs, given its motion, minus what the outside world (contacts and the
applied `body_force`) supplies. It is the recursive Newton-Euler pass again, with the
accelerations the step actually produced and those forces as external ones; the result is
given at the site, in the site's frame. The same pass leaves each body's acceleration in `d.cacc` (gravity included as an upward
acceleration of the world), which the accelerometers and frame accelerations read.
"""

import warp as wp

from ..lanes import stop, sync, world_lane
from .dynamics import articulated_factor, body_inertia, newton_euler, subtree_sums
from .kinematics import geom_frame
from ..spatial import inertia_matrix, velocity_at
from ..structs import Contacts, Control, Dynamics, EnvParams, ModelArrays, Options, State
from ..types import (BOX, CAPSULE, CYLINDER, DATA_POSITIVE, DATA_REAL, ELLIPSOID, OBJ_BODY,
                    OBJ_GEOM, OBJ_SITE, OBJ_UNKNOWN, SENS_ACCELEROMETER, SENS_ACTUATORFRC,
                    SENS_FORCE, SENS_FRAMEANGACC, SENS_FRAMELINACC,
                    SENS_FRAMELINVEL, SENS_FRAMEPOS, SENS_FRAMEQUAT, SENS_FRAMEXAXIS,
                    SENS_FRAMEZAXIS, SENS_GYRO, SENS_JOINTACTFRC, SENS_JOINTPOS, SENS_JOINTVEL,
                    SENS_TORQUE, SENS_TOUCH, SENS_VELOCIMETER, SPHERE)


@wp.kernel
def force_sensors(m: ModelArrays, p: EnvParams, opt: Options,
                  sensor_site_body: wp.array(dtype=wp.int32),
                  sensor_site: wp.array(dtype=wp.int32),
                  # in: body_x, body_com, body_iframe, cvel, cdof, cdof_dot, qd, qd_before, qacc,
                  # site_x; out: sensor_wrench, [env, sensor site] (force, torque) in the site
                  # frame; with `split`, also sensor_constraint and sensor_forward
                  s: State,
                  u: Control,    # in: body_force
                  c: Contacts,   # in: count, geom, pos, force
                  # in: implicit_diag, wrench (`split`); out: cacc (read by `sensor_readings`);
                  # scratch: cfrc, wrench, articulated, factor
                  d: Dynamics,
                  split: int,
                  lanes: int):
    """A world's lanes take its bodies level by level, then its sensor sites.

    With `split` (`Model.force_sensor_split`), first the two parts PhysX's articulation sensors
    report, about the site, world axes (Isaac Gym's ForceSensorProperties; docs/isaacgym.md):
    - forward dynamics: minus the articulated zero-acceleration force of the body's subtree,
      IA·(a_smooth - gravity's) - w_smooth: IA the subtree's articulated-body inertia,
      a_smooth the body's acceleration under the unconstrained dynamics (qacc), classical as
      PhysX's (its centre of mass's), w_smooth the wrench its joint carries under them
      (Newton-Euler with qacc, less the applied and fluid forces). A link hanging at rest
      reads minus its subtree's weight;
    - constraint solver: the contact forces on the body's subtree (a foot's: its ground
      reaction). Joint limits, drives and tendons, which act inside the articulation, add none.
    """
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    h = opt.h
    ncontact = int(0)
    if active:
        ncontact = wp.min(c.count[e], c.force.shape[1])
    if split != 0:
        # the articulated inertias at the new poses, where the Newton-Euler passes run (the
        # last substep's factor left them at its start; the next one builds its own)
        articulated_factor(m, p, s, e, lane, lanes, active, d.implicit_diag, d.articulated,
                           d.factor)
        newton_euler(m, p, s, e, lane, lanes, active, s.qd_before, 0.0, s.qacc, True, d)
        if lanes > 1:
            sync()
        subtree_sums(m, e, lane, lanes, active, d.cfrc)
        gravity = wp.spatial_vector()
        if active:
            gravity = wp.spatial_vector(wp.vec3(), -p.gravity[e])
        for i in range(lane, stop(sensor_site.shape[0], 0, active), lanes):
            b = sensor_site_body[i]
            ia = d.articulated[e, b]
            if lanes > 1:    # the factor left each body's IA less its own dofs: add them back
                mass, hh, rot_inertia = body_inertia(m, p, s, e, b)
                ia = inertia_matrix(mass, hh, rot_inertia)
                for k in range(m.body_child_adr[b], m.body_child_adr[b] + m.body_child_num[b]):
                    ia = ia + d.articulated[e, m.body_child[k]]
            # PhysX's link accelerations are classical: its centre of mass's, not the spatial
            # acceleration's linear part (they differ by w × v_com, a uniform field)
            ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
            v = s.cvel[e, b]
            classical = wp.spatial_vector(
                wp.vec3(), wp.cross(wp.spatial_top(v), velocity_at(v, s.body_com[e, b] - ref)))
            forward = (ia * (d.cacc[e, b] + classical - gravity)
                       - (d.cfrc[e, b] - d.wrench[e, b]))
            s.sensor_forward[e, i] = at_site(m, s, e, b, sensor_site[i], forward)
        if lanes > 1:
            sync()
        for b in range(lane, stop(m.nbody, 0, active), lanes):
            d.wrench[e, b] = wp.spatial_vector()
        if lanes > 1:
            sync()
        subtract_contacts(m, s, c, e, lane, lanes, active, ncontact, d.wrench)
        subtree_sums(m, e, lane, lanes, active, d.wrench)
        for i in range(lane, stop(sensor_site.shape[0], 0, active), lanes):
            b = sensor_site_body[i]
            s.sensor_constraint[e, i] = at_site(m, s, e, b, sensor_site[i], -d.wrench[e, b])
        if lanes > 1:
            sync()
    newton_euler(m, p, s, e, lane, lanes, active, s.qd_before, 1.0 / h, s.qacc, False, d)
    # the applied forces are external too (MuJoCo's xfrc_applied in cfrc_ext)
    for b in range(lane, stop(m.nbody, 0, active), lanes):
        f = wp.spatial_top(u.body_force[e, b])
        arm = s.body_com[e, b] - wp.transform_get_translation(s.body_x[e, m.body_root[b]])
        d.cfrc[e, b] = d.cfrc[e, b] - wp.spatial_vector(
            wp.spatial_bottom(u.body_force[e, b]) + wp.cross(arm, f), f)
    if lanes > 1:
        sync()
    subtract_contacts(m, s, c, e, lane, lanes, active, ncontact, d.cfrc)
    subtree_sums(m, e, lane, lanes, active, d.cfrc)
    for i in range(lane, stop(sensor_site.shape[0], 0, active), lanes):
        b = sensor_site_body[i]
        total = at_site(m, s, e, b, sensor_site[i], d.cfrc[e, b])
        rot = wp.transform_get_rotation(s.site_x[e, sensor_site[i]])
        s.sensor_wrench[e, i] = wp.spatial_vector(
            wp.quat_rotate_inv(rot, wp.spatial_top(total)),
            wp.quat_rotate_inv(rot, wp.spatial_bottom(total)))


@wp.func(inline=True)
def at_site(m: ModelArrays, s: State, e: int, b: int, site: int, w: wp.spatial_vector):
    """A wrench of body b's tree (torque, force about the tree's reference point) as (force,
    torque about the site), world axes."""
    point = wp.transform_get_translation(s.site_x[e, site])
    ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
    force = wp.spatial_bottom(w)
    return wp.spatial_vector(force, wp.spatial_top(w) - wp.cross(point - ref, force))


@wp.func(inline=True)
def subtract_contacts(m: ModelArrays, s: State, c: Contacts, e: int, lane: int, lanes: int,
                      active: bool, ncontact: int, x: wp.array2d(dtype=wp.spatial_vector)):
    """x[b] -= the wrench the contacts put on body b, in their order (the force on geom 2, minus
    it on geom 1): one lane takes each contact to its two bodies; lanes gather per body (the
    same sums)."""
    for i in range(stop(ncontact, 0, active and lanes == 1)):
        for side in range(2):
            contact_wrench_out(m, s, c, e, i, side, m.geom_body[c.geom[e, i][side]], x)
    for b in range(lane, stop(m.nbody, 0, active and lanes > 1), lanes):
        for i in range(ncontact):
            for side in range(2):
                contact_wrench_out(m, s, c, e, i, side, b, x)
    if lanes > 1:
        sync()


@wp.func(inline=True)
def contact_wrench_out(m: ModelArrays, s: State, c: Contacts, e: int, k: int, side: int,
                       b: int, cfrc: wp.array2d(dtype=wp.spatial_vector)):
    """cfrc[b] -= the wrench contact k puts on body b (its geom 2's body: the contact force;
    geom 1's: minus it), if b is the body on that side of it."""
    if b >= 0 and m.geom_body[c.geom[e, k][side]] == b:
        sign = 1.0
        if side == 0:
            sign = -1.0
        ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
        fb = c.force[e, k] * sign
        cfrc[e, b] = cfrc[e, b] - wp.spatial_vector(wp.cross(c.pos[e, k] - ref, fb), fb)


# ------------------------------------------------------------------ objects and their frames
@wp.func
def object_body(m: ModelArrays, objtype: int, objid: int):
    """The body an object moves with (-1: the world)."""
    if objtype == OBJ_GEOM:
        return m.geom_body[objid]
    if objtype == OBJ_SITE:
        return m.site_body[objid]
    return objid


@wp.func
def object_frame(m: ModelArrays, p: EnvParams, s: State, e: int, objtype: int, objid: int):
    """World pose of a site, a geom, a body's inertial frame (BODY: center of mass, principal
    axes) or a body's own frame (XBODY); body -1, the world, is the identity."""
    if objtype == OBJ_SITE:
        return s.site_x[e, objid]
    if objtype == OBJ_GEOM:
        # from the bodies, not `geom_x`: that is the collision stage's, before the last substep
        return geom_frame(m, p, s, e, objid)
    if objid < 0:
        return wp.transform_identity()
    if objtype == OBJ_BODY:
        return wp.transform(s.body_com[e, objid], s.body_iframe[e, objid])
    return s.body_x[e, objid]


@wp.func
def object_velocity(m: ModelArrays, s: State, e: int, b: int, point: wp.vec3):
    """(angular, linear) velocity of the point `point` moving with body b, world axes (MuJoCo's
    mj_objectVelocity). A body no dof moves (the world, bodies welded to it) is at rest."""
    if b < 0:
        return wp.spatial_vector()
    if m.body_last_dof[b] < 0:
        return wp.spatial_vector()
    v = s.cvel[e, b]
    ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
    return wp.spatial_vector(wp.spatial_top(v), velocity_at(v, point - ref))


@wp.func
def object_acceleration(m: ModelArrays, p: EnvParams, s: State, d: Dynamics, e: int, b: int,
                        point: wp.vec3):
    """(angular, linear) acceleration of the point moving with body b, world axes (MuJoCo's
    mj_objectAcceleration): the spatial acceleration cacc taken at the point, plus ω × v, which
    turns it into the point's own acceleration. cacc counts gravity as an upward acceleration
    of the world, so a body at rest reads +g up, and so does the world itself and a body welded
    to it (as MuJoCo 4.0 does; MuJoCo 3.3.7 to 3.12 read 0 on a body no dof moves)."""
    if b < 0:
        return wp.spatial_vector(wp.vec3(), -p.gravity[e])
    v = s.cvel[e, b]
    a = d.cacc[e, b]
    r = point - wp.transform_get_translation(s.body_x[e, m.body_root[b]])
    linear = velocity_at(a, r) + wp.cross(wp.spatial_top(v), velocity_at(v, r))
    return wp.spatial_vector(wp.spatial_top(a), linear)


@wp.func
def frame_vector(m: ModelArrays, p: EnvParams, s: State, d: Dynamics, e: int, i: int, t: int):
    """The 3 values of sensor i, of type t: a site sensor (accelerometer, velocimeter, gyro: in
    the site's frame) or a frame sensor (world axes, or the reference frame's if it has one)."""
    objtype = m.sensor_objtype[i]
    x = object_frame(m, p, s, e, objtype, m.sensor_objid[i])
    pos = wp.transform_get_translation(x)
    rot = wp.transform_get_rotation(x)
    b = object_body(m, objtype, m.sensor_objid[i])
    # accelerations: MuJoCo takes no reference frame for them
    if t == SENS_ACCELEROMETER or t == SENS_FRAMELINACC or t == SENS_FRAMEANGACC:
        acc = object_acceleration(m, p, s, d, e, b, pos)
        if t == SENS_ACCELEROMETER:
            return wp.quat_rotate_inv(rot, wp.spatial_bottom(acc))
        if t == SENS_FRAMELINACC:
            return wp.spatial_bottom(acc)
        return wp.spatial_top(acc)
    if t == SENS_VELOCIMETER or t == SENS_GYRO:
        vel = object_velocity(m, s, e, b, pos)
        if t == SENS_VELOCIMETER:
            return wp.quat_rotate_inv(rot, wp.spatial_bottom(vel))
        return wp.quat_rotate_inv(rot, wp.spatial_top(vel))

    reftype = m.sensor_reftype[i]
    xr = wp.transform_identity()
    if reftype != OBJ_UNKNOWN:
        xr = object_frame(m, p, s, e, reftype, m.sensor_refid[i])
    ref_pos = wp.transform_get_translation(xr)
    ref_rot = wp.transform_get_rotation(xr)
    if t == SENS_FRAMEPOS:
        return wp.quat_rotate_inv(ref_rot, pos - ref_pos)
    if t >= SENS_FRAMEXAXIS and t <= SENS_FRAMEZAXIS:
        basis = wp.vec3()
        basis[t - SENS_FRAMEXAXIS] = 1.0
        return wp.quat_rotate_inv(ref_rot, wp.quat_rotate(rot, basis))
    # FRAMELINVEL, FRAMEANGVEL: relative to the reference frame, which may move and turn
    vel = object_velocity(m, s, e, b, pos)
    angular = wp.spatial_top(vel)
    linear = wp.spatial_bottom(vel)
    if reftype != OBJ_UNKNOWN:
        ref_vel = object_velocity(m, s, e, object_body(m, reftype, m.sensor_refid[i]), ref_pos)
        angular = angular - wp.spatial_top(ref_vel)
        linear = (linear - wp.spatial_bottom(ref_vel)
                  - wp.cross(wp.spatial_top(ref_vel), pos - ref_pos))
    if t == SENS_FRAMELINVEL:
        return wp.quat_rotate_inv(ref_rot, linear)
    return wp.quat_rotate_inv(ref_rot, angular)


# ------------------------------------------------------------------ touch
@wp.func
def _slab(p: float, v: float, half: float, span: wp.vec2):
    """The part of the ray parameters `span` where p + t·v lies in [-half, half]."""
    if wp.abs(v) < 1.0e-12:   # parallel to the slab: inside it all along, or never
        if wp.abs(p) > half:
            return wp.vec2(1.0, 0.0)
        return span
    t1 = (-half - p) / v
    t2 = (half - p) / v
    return wp.vec2(wp.max(span[0], wp.min(t1, t2)), wp.min(span[1], wp.max(t1, t2)))


@wp.func
def _meets_ball(p: wp.vec3, v: wp.vec3, radius: float):
    """The ray p + t·v, t >= 0, comes within `radius` of the origin."""
    t = wp.max(0.0, -wp.dot(p, v) / wp.dot(v, v))
    q = p + v * t
    return wp.dot(q, q) <= radius * radius


@wp.func
def _meets_cylinder(p: wp.vec3, v: wp.vec3, radius: float, half: float):
    """The ray meets the cylinder of `radius` about z, |z| <= half."""
    span = _slab(p[2], v[2], half, wp.vec2(0.0, 1.0e30))
    a = v[0] * v[0] + v[1] * v[1]
    b = v[0] * p[0] + v[1] * p[1]
    c = p[0] * p[0] + p[1] * p[1] - radius * radius
    if a < 1.0e-24:           # along the axis: inside the radius all along, or never
        return c <= 0.0 and span[0] <= span[1]
    disc = b * b - a * c
    if disc < 0.0:
        return False
    root = wp.sqrt(disc)
    return wp.max(span[0], (-b - root) / a) <= wp.min(span[1], (-b + root) / a)


@wp.func
def in_zone(site_type: int, size: wp.vec3, x: wp.transform, point: wp.vec3, direction: wp.vec3):
    """The ray from `point` along `direction` meets the site's volume, as MuJoCo's mju_rayGeom
    >= 0 (always true when the point is inside). The volumes are convex: the ray meets one when
    the ray's parameters t >= 0 inside it are not empty."""
    rot = wp.transform_get_rotation(x)
    p = wp.quat_rotate_inv(rot, point - wp.transform_get_translation(x))
    v = wp.quat_rotate_inv(rot, direction)
    if site_type == SPHERE:
        return _meets_ball(p, v, size[0])
    if site_type == ELLIPSOID:
        return _meets_ball(wp.cw_div(p, size), wp.cw_div(v, size), 1.0)
    if site_type == CYLINDER:
        return _meets_cylinder(p, v, size[0], size[1])
    if site_type == CAPSULE:
        end = wp.vec3(0.0, 0.0, size[1])
        return (_meets_cylinder(p, v, size[0], size[1]) or _meets_ball(p - end, v, size[0])
                or _meets_ball(p + end, v, size[0]))
    if site_type == BOX:
        span = wp.vec2(0.0, 1.0e30)
        for k in range(3):
            span = _slab(p[k], v[k], size[k], span)
        return span[0] <= span[1]
    return False


@wp.func
def touch(m: ModelArrays, s: State, c: Contacts, e: int, site: int):
    """Sum of the normal forces of the contacts of the site's body whose point, looking away
    from the body along the contact normal, sees the site's zone (MuJoCo's touch sensor)."""
    b = m.site_body[site]
    x = s.site_x[e, site]
    total = float(0.0)
    for k in range(wp.min(c.count[e], c.force.shape[1])):
        pair = c.geom[e, k]
        b1 = m.geom_body[pair[0]]
        b2 = m.geom_body[pair[1]]
        if b1 == b or b2 == b:
            normal = c.normal[e, k]               # from geom 1 to geom 2
            fn = wp.dot(c.force[e, k], normal)    # force on geom 2 pushes it along the normal
            if fn > 0.0:
                ray = normal
                if b2 == b:
                    ray = -normal
                if in_zone(m.site_type[site], m.site_size[site], x, c.pos[e, k], ray):
                    total += fn
    return total


# ------------------------------------------------------------------ all sensors
@wp.func
def joint_actuator_force(m: ModelArrays, p: EnvParams, d: Dynamics, e: int, j: int):
    """The actuators' summed force at hinge or slide joint j, clamped to its actuator force
    range (MuJoCo's qfrc_actuator; ours, `dof_actuator_force`, adds the implicit drives'
    prediction of the step)."""
    dof = m.jnt_dofadr[j]
    f = float(0.0)
    for n in range(m.dof_trn_adr[dof], m.dof_trn_adr[dof] + m.dof_trn_num[dof]):
        k = m.dof_trn[n]
        a = m.trn_actuator[k]
        f += p.actuator_gear[e, a] * m.trn_coef[k] * d.actuator_force[e, a]
    if m.jnt_actfrclimited[j] != 0:
        r = m.jnt_actfrcrange[j]
        f = wp.clamp(f, r[0], r[1])
    return f


@wp.kernel
def sensor_readings(m: ModelArrays, p: EnvParams,
                    # in: q, qd, body_x, body_com, body_iframe, cvel, site_x, sensor_wrench;
                    # out: sensor_data
                    s: State,
                    c: Contacts,   # in: count, geom, pos, normal, force
                    d: Dynamics,   # in: actuator_force; cacc (`force_sensors`) if a sensor needs it
                    lanes: int):
    """A world's lanes take its sensors."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    for i in range(lane, stop(m.nsensor, 0, active), lanes):
        t = m.sensor_type[i]
        obj = m.sensor_objid[i]
        adr = m.sensor_adr[i]
        if t == SENS_JOINTPOS:
            s.sensor_data[e, adr] = s.q[e, m.jnt_qposadr[obj]]
        elif t == SENS_JOINTVEL:
            s.sensor_data[e, adr] = s.qd[e, m.jnt_dofadr[obj]]
        elif t == SENS_ACTUATORFRC:
            s.sensor_data[e, adr] = d.actuator_force[e, obj]
        elif t == SENS_JOINTACTFRC:
            s.sensor_data[e, adr] = joint_actuator_force(m, p, d, e, obj)
        elif t == SENS_TOUCH:
            s.sensor_data[e, adr] = touch(m, s, c, e, obj)
        elif t == SENS_FRAMEQUAT:
            rot = wp.transform_get_rotation(object_frame(m, p, s, e, m.sensor_objtype[i], obj))
            if m.sensor_reftype[i] != OBJ_UNKNOWN:
                ref = object_frame(m, p, s, e, m.sensor_reftype[i], m.sensor_refid[i])
                rot = wp.quat_inverse(wp.transform_get_rotation(ref)) * rot
            s.sensor_data[e, adr] = rot[3]           # MuJoCo's order: w, x, y, z
            for k in range(3):
                s.sensor_data[e, adr + 1 + k] = rot[k]
        else:
            v = wp.vec3()
            if t == SENS_FORCE:
                v = wp.spatial_top(s.sensor_wrench[e, m.sensor_slot[i]])
            elif t == SENS_TORQUE:
                v = wp.spatial_bottom(s.sensor_wrench[e, m.sensor_slot[i]])
            else:
                v = frame_vector(m, p, s, d, e, i, t)
            for k in range(3):
                s.sensor_data[e, adr + k] = v[k]
        # MuJoCo's cutoff: real values clamped to [-cutoff, cutoff], positive ones to <= cutoff;
        # axes and quaternions never
        cutoff = m.sensor_cutoff[i]
        if cutoff > 0.0:
            kind = m.sensor_datatype[i]
            for k in range(m.sensor_dim[i]):
                if kind == DATA_REAL:
                    s.sensor_data[e, adr + k] = wp.clamp(s.sensor_data[e, adr + k], -cutoff, cutoff)
                elif kind == DATA_POSITIVE:
                    s.sensor_data[e, adr + k] = wp.min(s.sensor_data[e, adr + k], cutoff)
