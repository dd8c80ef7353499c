"""Stage 1, kinematics: body frames, joint axes and velocities from q and qd.

A world's lanes (`lanes`) take the bodies of one tree level at a time, parents' level first,
applying each body's joints in MuJoCo's order, so the poses agree with `mj_kinematics`. The same
pass computes the motion subspace of every dof (`cdof`, a spatial motion vector per dof at the
tree's reference point), its time derivative `cdof_dot`, and body velocities, as `mj_comVel`
does. A body reads only its parent's (and its tree root's) results: one lane per world gives
the same numbers as many.
"""

import warp as wp

from ..lanes import level_body, level_range, sync, world_lane
from ..types import BALL, FREE, HINGE, SLIDE
from ..spatial import motion_cross, velocity_at
from ..structs import EnvParams, ModelArrays, State



@wp.func
def _quat_at(q: wp.array2d(dtype=float), e: int, a: int):
    return wp.normalize(wp.quat(q[e, a], q[e, a + 1], q[e, a + 2], q[e, a + 3]))


@wp.kernel
def kinematics(m: ModelArrays,
               # in: q, qd, mocap_pos, mocap_quat; out: body_x, body_com, body_iframe, body_vel, jnt_anchor, jnt_xaxis,
               # cvel, cdof, cdof_dot
               s: State,
               lanes: int):
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    for k in range(m.nlevel):
        start, end = level_range(m, k, lane, lanes, active, False)
        for i in range(start, end, lanes):
            b = level_body(m, i, lanes, False)
            parent = m.body_parent[b]
            pos = m.body_pos[b]
            rot = m.body_quat[b]
            v = wp.spatial_vector()
            if parent >= 0:
                px = s.body_x[e, parent]
                pos = wp.transform_point(px, pos)
                rot = wp.transform_get_rotation(px) * rot
                v = s.cvel[e, parent]
            elif m.body_mocapid[b] >= 0:   # posed by the user, at rest as far as dynamics knows
                pos = s.mocap_pos[e, m.body_mocapid[b]]
                rot = s.mocap_quat[e, m.body_mocapid[b]]

            jbeg = m.body_jntadr[b]
            jend = jbeg + m.body_jntnum[b]
            # positions: compose this body's joints in order, as mj_kinematics
            for j in range(jbeg, jend):
                t = m.jnt_type[j]
                a = m.jnt_qposadr[j]
                if t == FREE:
                    pos = wp.vec3(s.q[e, a], s.q[e, a + 1], s.q[e, a + 2])
                    rot = _quat_at(s.q, e, a + 3)
                    s.jnt_anchor[e, j] = pos
                else:
                    # a joint's anchor and axis are fixed on the parent side: record them before the
                    # joint moves the body
                    anchor = pos + wp.quat_rotate(rot, m.jnt_pos[j])
                    axis = wp.quat_rotate(rot, m.jnt_axis[j])
                    s.jnt_anchor[e, j] = anchor
                    s.jnt_xaxis[e, j] = axis
                    if t == SLIDE:
                        pos = pos + axis * (s.q[e, a] - m.qpos0[a])
                    else:
                        if t == BALL:
                            rot = rot * _quat_at(s.q, e, a)
                        else:
                            rot = rot * wp.quat_from_axis_angle(m.jnt_axis[j],
                                                                s.q[e, a] - m.qpos0[a])
                        pos = anchor - wp.quat_rotate(rot, m.jnt_pos[j])
            rot = wp.normalize(rot)
            s.body_x[e, b] = wp.transform(pos, rot)
            s.body_com[e, b] = pos + wp.quat_rotate(rot, m.body_ipos[b])
            s.body_iframe[e, b] = rot * m.body_iquat[b]

            # motion subspaces and velocities, at the reference point of this body's tree
            # (mj_comVel)
            ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
            for j in range(jbeg, jend):
                t = m.jnt_type[j]
                da = m.jnt_dofadr[j]
                anchor = s.jnt_anchor[e, j]
                if t == SLIDE or t == HINGE:
                    axis = s.jnt_xaxis[e, j]
                    motion = wp.spatial_vector(wp.vec3(), axis)
                    if t == HINGE:
                        motion = wp.spatial_vector(axis, wp.cross(axis, ref - anchor))
                    s.cdof[e, da] = motion
                    s.cdof_dot[e, da] = motion_cross(v, motion)
                    v = v + motion * s.qd[e, da]
                else:
                    if t == FREE:
                        # translation along fixed world axes: no derivative
                        for k in range(3):
                            motion = wp.spatial_vector()
                            motion[3 + k] = 1.0
                            s.cdof[e, da + k] = motion
                            s.cdof_dot[e, da + k] = wp.spatial_vector()
                            v = v + motion * s.qd[e, da + k]
                        da = da + 3
                    # rotation about the body's own axes (free and ball joints; like MuJoCo, the
                    # body's final orientation, assuming no later joint on the same body rotates it)
                    vrot = v
                    for k in range(3):
                        basis = wp.vec3()
                        basis[k] = 1.0
                        axis = wp.quat_rotate(rot, basis)
                        motion = wp.spatial_vector(axis, wp.cross(axis, ref - anchor))
                        s.cdof[e, da + k] = motion
                        s.cdof_dot[e, da + k] = motion_cross(v, motion)
                        vrot = vrot + motion * s.qd[e, da + k]
                    v = vrot
            s.cvel[e, b] = v
            s.body_vel[e, b] = wp.spatial_vector(velocity_at(v, pos - ref), wp.spatial_top(v))

        if lanes > 1:
            sync()


@wp.func
def geom_frame(m: ModelArrays, p: EnvParams, s: State, e: int, g: int):
    """World pose of geom g from its body's pose (a geom of the world: its own)."""
    x = wp.transform(p.geom_pos[e, g], m.geom_quat[g])
    b = m.geom_body[g]
    if b >= 0:
        x = s.body_x[e, b] * x
    return x


@wp.kernel
def site_frames(m: ModelArrays, p: EnvParams,
                # in: body_x; out: site_x
                s: State):
    """World frame of each site (a frame fixed to a body; body -1 is the world)."""
    e, i = wp.tid()
    x = wp.transform(p.site_pos[e, i], m.site_quat[i])
    b = m.site_body[i]
    if b >= 0:
        x = s.body_x[e, b] * x
    s.site_x[e, i] = x


@wp.func
def _jacobian_at(m: ModelArrays, s: State, e: int, body: int, point: wp.vec3,
                 jac: wp.array4d(dtype=float), row: int):
    for i in range(m.nv):
        for r in range(6):
            jac[e, row, r, i] = 0.0
    if body < 0:
        return
    ref = wp.transform_get_translation(s.body_x[e, m.body_root[body]])
    j = m.body_last_dof[body]
    while j >= 0:
        motion = s.cdof[e, j]
        lin = velocity_at(motion, point - ref)
        ang = wp.spatial_top(motion)
        for r in range(3):
            jac[e, row, r, j] = lin[r]
            jac[e, row, 3 + r, j] = ang[r]
        j = m.dof_parent[j]


@wp.kernel
def body_jacobians(m: ModelArrays, s: State, jac: wp.array4d(dtype=float)):
    """[env, body, 6, nv]: rows 0-2 linear velocity of the body origin, rows 3-5 angular."""
    e, b = wp.tid()
    _jacobian_at(m, s, e, b, wp.transform_get_translation(s.body_x[e, b]), jac, b)


@wp.kernel
def site_jacobians(m: ModelArrays, s: State, jac: wp.array4d(dtype=float)):
    e, i = wp.tid()
    _jacobian_at(m, s, e, m.site_body[i], wp.transform_get_translation(s.site_x[e, i]), jac, i)
