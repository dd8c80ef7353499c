"""Spatial algebra for the kernels (Featherstone's 6D vectors, MuJoCo's com-based convention).

A motion vector is ``spatial_vector(angular, linear)`` and a force vector is
``spatial_vector(torque, force)``, both expressed in world orientation at a reference point: the
position of the tree's root body (one point per articulation tree, so that precision does not
degrade when a robot walks far from the world origin). The pairing motion·force is the plain
6D dot product.

A rigid-body inertia at the reference point is kept as (m, h, I): mass, h = m·c where c is the
center of mass relative to the point, and the 3x3 rotational inertia about the point.
"""

import warp as wp


@wp.func
def motion_cross(v: wp.spatial_vector, s: wp.spatial_vector):
    """v ×m s: rate of change of a motion vector s carried along by the motion v."""
    w = wp.spatial_top(v)
    vl = wp.spatial_bottom(v)
    sw = wp.spatial_top(s)
    sl = wp.spatial_bottom(s)
    return wp.spatial_vector(wp.cross(w, sw), wp.cross(w, sl) + wp.cross(vl, sw))


@wp.func
def force_cross(v: wp.spatial_vector, f: wp.spatial_vector):
    """v ×* f: rate of change of a force (momentum) vector f carried along by the motion v."""
    w = wp.spatial_top(v)
    vl = wp.spatial_bottom(v)
    t = wp.spatial_top(f)
    fl = wp.spatial_bottom(f)
    return wp.spatial_vector(wp.cross(w, t) + wp.cross(vl, fl), wp.cross(w, fl))


@wp.func
def inertia_times(m: float, h: wp.vec3, rot_inertia: wp.mat33, s: wp.spatial_vector):
    """Momentum (angular about the point, linear) of a body moving with motion s."""
    w = wp.spatial_top(s)
    v = wp.spatial_bottom(s)
    return wp.spatial_vector(rot_inertia * w + wp.cross(h, v), m * v - wp.cross(h, w))


@wp.func
def inertia_matrix(m: float, h: wp.vec3, rot_inertia: wp.mat33):
    """`inertia_times` as a 6×6 matrix: [[I, [h]×], [-[h]×, m·1]]."""
    hx = wp.skew(h)
    out = wp.spatial_matrix()
    for i in range(3):
        for j in range(3):
            out[i, j] = rot_inertia[i, j]
            out[i, j + 3] = hx[i, j]
            out[i + 3, j] = -hx[i, j]
        out[i + 3, i + 3] = m
    return out


@wp.func
def inertia_about_point(m: float, c: wp.vec3, principal: wp.vec3, frame: wp.quat):
    """Rotational inertia about a point at -c from the center of mass (parallel-axis theorem)."""
    r = wp.quat_to_matrix(frame)
    ic = r * wp.diag(principal) * wp.transpose(r)
    return ic + m * (wp.dot(c, c) * wp.identity(n=3, dtype=float) - wp.outer(c, c))


@wp.func
def velocity_at(v: wp.spatial_vector, offset: wp.vec3):
    """Linear velocity of the point at `offset` from the reference point."""
    return wp.spatial_bottom(v) + wp.cross(wp.spatial_top(v), offset)


@wp.func
def quat_integrate(q: wp.quat, omega_local: wp.vec3, h: float):
    """Rotate q by the body-frame angular velocity omega over time h (exponential map)."""
    angle = wp.length(omega_local) * h
    if angle > 0.0:
        q = q * wp.quat_from_axis_angle(wp.normalize(omega_local), angle)
    return wp.normalize(q)


@wp.func
def row_finite(a: wp.array2d(dtype=float), e: int, n: int):
    """True when the first n entries of row e of `a` are all finite."""
    for i in range(n):
        if not wp.isfinite(a[e, i]):
            return False
    return True


@wp.func
def tangents(n: wp.vec3):
    """Two unit vectors that make (n, t1, t2) a right-handed orthonormal basis; which pair does
    not matter to their users (the friction disk, a face's corners), only that it is fixed."""
    t1 = wp.cross(n, wp.vec3(1.0, 0.0, 0.0))
    if wp.length_sq(t1) < 1.0e-6:
        t1 = wp.cross(n, wp.vec3(0.0, 1.0, 0.0))
    t1 = wp.normalize(t1)
    return t1, wp.cross(n, t1)
