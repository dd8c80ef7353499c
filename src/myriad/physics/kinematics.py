"""Stage 1, kinematics: body frames, joint axes and velocities from q and qd.

One thread per env walks the bodies in topological order (parents first), applying each body's
joints in MuJoCo's order, so the poses agree with `mj_kinematics`. The same pass computes the
motion subspace of every dof (`cdof`, a spatial motion vector per dof at the tree's reference
point), its time derivative `cdof_dot`, and body velocities, as `mj_comVel` does.
"""

import warp as wp

from .types import BALL, FREE, HINGE, SLIDE
from .spatial import motion_cross, velocity_at
from .structs import ModelArrays



@wp.func
def _quat_at(q: wp.array2d(dtype=float), e: int, a: int):
    return wp.normalize(wp.quat(q[e, a], q[e, a + 1], q[e, a + 2], q[e, a + 3]))


@wp.kernel
def kinematics(m: ModelArrays, q: wp.array2d(dtype=float), qd: wp.array2d(dtype=float),
               # outputs
               body_x: wp.array2d(dtype=wp.transform),     # body frame in the world
               body_com: wp.array2d(dtype=wp.vec3),        # center of mass in the world
               body_iframe: wp.array2d(dtype=wp.quat),     # principal inertia axes in the world
               body_vel: wp.array2d(dtype=wp.spatial_vector),  # (linear at body origin, angular)
               jnt_anchor: wp.array2d(dtype=wp.vec3),      # joint anchor in the world
               jnt_xaxis: wp.array2d(dtype=wp.vec3),       # joint axis in the world
               cvel: wp.array2d(dtype=wp.spatial_vector),  # body motion at the tree reference point
               cdof: wp.array2d(dtype=wp.spatial_vector),
               cdof_dot: wp.array2d(dtype=wp.spatial_vector)):
    e = wp.tid()
    for b in range(m.nbody):
        parent = m.body_parent[b]
        pos = m.body_pos[b]
        rot = m.body_quat[b]
        v = wp.spatial_vector()
        if parent >= 0:
            px = body_x[e, parent]
            pos = wp.transform_point(px, pos)
            rot = wp.transform_get_rotation(px) * rot
            v = cvel[e, parent]

        jbeg = m.body_jntadr[b]
        jend = jbeg + m.body_jntnum[b]
        # positions: compose this body's joints in order, as mj_kinematics
        for j in range(jbeg, jend):
            t = m.jnt_type[j]
            a = m.jnt_qposadr[j]
            if t == FREE:
                pos = wp.vec3(q[e, a], q[e, a + 1], q[e, a + 2])
                rot = _quat_at(q, e, a + 3)
                jnt_anchor[e, j] = pos
            else:
                # a joint's anchor and axis are fixed on the parent side: record them before the
                # joint moves the body
                anchor = pos + wp.quat_rotate(rot, m.jnt_pos[j])
                axis = wp.quat_rotate(rot, m.jnt_axis[j])
                jnt_anchor[e, j] = anchor
                jnt_xaxis[e, j] = axis
                if t == SLIDE:
                    pos = pos + axis * (q[e, a] - m.qpos0[a])
                else:
                    if t == BALL:
                        rot = rot * _quat_at(q, e, a)
                    else:
                        rot = rot * wp.quat_from_axis_angle(m.jnt_axis[j], q[e, a] - m.qpos0[a])
                    pos = anchor - wp.quat_rotate(rot, m.jnt_pos[j])
        rot = wp.normalize(rot)
        body_x[e, b] = wp.transform(pos, rot)
        body_com[e, b] = pos + wp.quat_rotate(rot, m.body_ipos[b])
        body_iframe[e, b] = rot * m.body_iquat[b]

        # motion subspaces and velocities, at the reference point of this body's tree (mj_comVel)
        ref = wp.transform_get_translation(body_x[e, m.body_root[b]])
        for j in range(jbeg, jend):
            t = m.jnt_type[j]
            da = m.jnt_dofadr[j]
            anchor = jnt_anchor[e, j]
            if t == SLIDE or t == HINGE:
                axis = jnt_xaxis[e, j]
                s = wp.spatial_vector(wp.vec3(), axis)
                if t == HINGE:
                    s = wp.spatial_vector(axis, wp.cross(axis, ref - anchor))
                cdof[e, da] = s
                cdof_dot[e, da] = motion_cross(v, s)
                v = v + s * qd[e, da]
            else:
                if t == FREE:
                    # translation along fixed world axes: no derivative
                    for k in range(3):
                        s = wp.spatial_vector()
                        s[3 + k] = 1.0
                        cdof[e, da + k] = s
                        cdof_dot[e, da + k] = wp.spatial_vector()
                        v = v + s * qd[e, da + k]
                    da = da + 3
                # rotation about the body's own axes (free and ball joints; like MuJoCo, the
                # body's final orientation, assuming no later joint on the same body rotates it)
                vrot = v
                for k in range(3):
                    basis = wp.vec3()
                    basis[k] = 1.0
                    axis = wp.quat_rotate(rot, basis)
                    s = wp.spatial_vector(axis, wp.cross(axis, ref - anchor))
                    cdof[e, da + k] = s
                    cdof_dot[e, da + k] = motion_cross(v, s)
                    vrot = vrot + s * qd[e, da + k]
                v = vrot
        cvel[e, b] = v
        body_vel[e, b] = wp.spatial_vector(velocity_at(v, pos - ref), wp.spatial_top(v))


@wp.kernel
def attached_frames(body: wp.array(dtype=wp.int32), pos: wp.array2d(dtype=wp.vec3),
                    quat: wp.array(dtype=wp.quat), body_x: wp.array2d(dtype=wp.transform),
                    frame_x: wp.array2d(dtype=wp.transform)):
    """World frames of things fixed to bodies (sites, geoms); body -1 is the world."""
    e, i = wp.tid()
    x = wp.transform(pos[e, i], quat[i])
    b = body[i]
    if b >= 0:
        x = body_x[e, b] * x
    frame_x[e, i] = x


@wp.func
def _jacobian_at(m: ModelArrays, e: int, body: int, point: wp.vec3,
                 body_x: wp.array2d(dtype=wp.transform), cdof: wp.array2d(dtype=wp.spatial_vector),
                 jac: wp.array4d(dtype=float), row: int):
    for i in range(m.nv):
        for r in range(6):
            jac[e, row, r, i] = 0.0
    if body < 0:
        return
    ref = wp.transform_get_translation(body_x[e, m.body_root[body]])
    j = m.body_last_dof[body]
    while j >= 0:
        s = cdof[e, j]
        lin = velocity_at(s, point - ref)
        ang = wp.spatial_top(s)
        for r in range(3):
            jac[e, row, r, j] = lin[r]
            jac[e, row, 3 + r, j] = ang[r]
        j = m.dof_parent[j]


@wp.kernel
def body_jacobians(m: ModelArrays, body_x: wp.array2d(dtype=wp.transform),
                   cdof: wp.array2d(dtype=wp.spatial_vector), jac: wp.array4d(dtype=float)):
    """[env, body, 6, nv]: rows 0-2 linear velocity of the body origin, rows 3-5 angular."""
    e, b = wp.tid()
    _jacobian_at(m, e, b, wp.transform_get_translation(body_x[e, b]), body_x, cdof, jac, b)


@wp.kernel
def site_jacobians(m: ModelArrays, body_x: wp.array2d(dtype=wp.transform),
                   site_x: wp.array2d(dtype=wp.transform),
                   cdof: wp.array2d(dtype=wp.spatial_vector), jac: wp.array4d(dtype=float)):
    e, s = wp.tid()
    _jacobian_at(m, e, m.site_body[s], wp.transform_get_translation(site_x[e, s]), body_x, cdof,
                 jac, s)
