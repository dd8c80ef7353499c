"""General convex-convex contact: support functions and Minkowski Portal Refinement (MPR).

For pairs without a closed form (ellipsoids, cylinders, convex meshes against the other convex
shapes), MPR (Snethen, "XenoCollide", Game Programming Gems 7) finds the penetration of the
Minkowski difference A - B along the line from its interior point (c_A - c_B) through the
origin: the portal it refines is the boundary patch that line exits through, whose normal is the
contact normal (from A to B) and whose distance to the origin is the depth. Both shapes are
inflated by half the contact offset, so shapes that are apart by less than the offset also give
a (speculative) contact with a positive distance. One contact point per pair: the points of A
and B that the portal's barycentric weights pick, and their midpoint.
"""

import warp as wp

from ..types import BOX, CAPSULE, CYLINDER, ELLIPSOID, SPHERE

MPR_ITERATIONS = wp.constant(48)

# a GJK simplex: up to four points of A (or of B), one per row
mat43 = wp.types.matrix(shape=(4, 3), dtype=float)


@wp.struct
class Meshes:
    vert: wp.array(dtype=wp.vec3)      # all mesh vertices, mesh frame
    vertadr: wp.array(dtype=wp.int32)
    vertnum: wp.array(dtype=wp.int32)
    rbound: wp.array(dtype=float)      # per mesh: largest vertex distance from the mesh origin


@wp.func
def bounding_radius(t: int, s: wp.vec3, dataid: int, meshes: Meshes):
    """Radius of a sphere about the geom's origin that holds the whole shape (not for planes
    and height fields, which are unbounded or hold their own broadphase)."""
    if t == SPHERE:
        return s[0]
    if t == CAPSULE:
        return s[0] + s[1]
    if t == ELLIPSOID:
        return wp.max(s[0], wp.max(s[1], s[2]))
    if t == CYLINDER:
        return wp.sqrt(s[0] * s[0] + s[1] * s[1])
    if t == BOX:
        return wp.length(s)
    return meshes.rbound[dataid]


@wp.func
def _sgn(x: float):
    if x >= 0.0:
        return 1.0
    return -1.0


@wp.func
def box_corner(half: wp.vec3, k: int):
    """Corner k (0-7) of a box: bit 0, 1, 2 of k flip x, y, z to the negative side."""
    corner = wp.vec3(half[0], half[1], half[2])
    if k & 1:
        corner[0] = -corner[0]
    if k & 2:
        corner[1] = -corner[1]
    if k & 4:
        corner[2] = -corner[2]
    return corner


@wp.func
def support_local(t: int, size: wp.vec3, mesh: int, meshes: Meshes, d: wp.vec3):
    """The shape's farthest point along d, in its own frame."""
    if t == SPHERE:
        return wp.normalize(d) * size[0]
    if t == CAPSULE:
        return wp.normalize(d) * size[0] + wp.vec3(0.0, 0.0, _sgn(d[2]) * size[1])
    if t == ELLIPSOID:
        sd = wp.cw_mul(size, d)
        return wp.cw_mul(size, sd) / wp.max(wp.length(sd), 1.0e-12)
    if t == CYLINDER:
        radial = wp.vec3(d[0], d[1], 0.0)
        r = wp.length(radial)
        point = wp.vec3(0.0, 0.0, _sgn(d[2]) * size[1])
        if r > 1.0e-12:
            point = point + radial * (size[0] / r)
        return point
    if t == BOX:
        return wp.vec3(_sgn(d[0]) * size[0], _sgn(d[1]) * size[1], _sgn(d[2]) * size[2])
    # mesh: the vertex farthest along d (the hull's support is a vertex)
    beg = meshes.vertadr[mesh]
    best = meshes.vert[beg]
    best_dot = wp.dot(best, d)
    for i in range(beg + 1, beg + meshes.vertnum[mesh]):
        v = meshes.vert[i]
        s = wp.dot(v, d)
        if s > best_dot:
            best_dot = s
            best = v
    return best


@wp.func
def support(t: int, size: wp.vec3, mesh: int, meshes: Meshes, x: wp.transform, d: wp.vec3,
            inflate: float):
    """World-frame support point of the shape grown by `inflate` in every direction."""
    rot = wp.transform_get_rotation(x)
    local = support_local(t, size, mesh, meshes, wp.quat_rotate_inv(rot, d))
    return wp.transform_point(x, local) + wp.normalize(d) * inflate


@wp.struct
class Portal:
    v: wp.vec3   # point of the Minkowski difference A - B
    a: wp.vec3   # its point on A
    b: wp.vec3   # its point on B


@wp.func
def _minkowski(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3, m2: int,
               x2: wp.transform, meshes: Meshes, d: wp.vec3, inflate: float):
    p = Portal()
    p.a = support(t1, s1, m1, meshes, x1, d, inflate)
    p.b = support(t2, s2, m2, meshes, x2, -d, inflate)
    p.v = p.a - p.b
    return p


@wp.func
def mpr(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3, m2: int,
        x2: wp.transform, meshes: Meshes, margin: float):
    """(hit, normal from 1 to 2, signed distance, midpoint) of two convex shapes.

    hit is 0 when the shapes are farther apart than `margin`.
    """
    inflate = 0.5 * margin
    miss = wp.vec3()
    # interior point of A - B
    v0 = wp.transform_get_translation(x1) - wp.transform_get_translation(x2)
    if wp.length_sq(v0) < 1.0e-18:
        v0 = wp.vec3(1.0e-6, 0.0, 0.0)
    n = -v0
    p1 = _minkowski(t1, s1, m1, x1, t2, s2, m2, x2, meshes, n, inflate)
    if wp.dot(p1.v, n) <= 0.0:
        return 0, miss, 0.0, miss
    n = wp.cross(p1.v, v0)
    if wp.length_sq(n) < 1.0e-18:
        # the origin lies on the segment v0 -> v1: the normal is that segment's direction
        normal = wp.normalize(-v0)
        depth = wp.dot(p1.v, normal)
        return 1, normal, margin - depth, 0.5 * (p1.a + p1.b)
    p2 = _minkowski(t1, s1, m1, x1, t2, s2, m2, x2, meshes, n, inflate)
    if wp.dot(p2.v, n) <= 0.0:
        return 0, miss, 0.0, miss
    n = wp.cross(p1.v - v0, p2.v - v0)
    if wp.dot(n, v0) > 0.0:
        tmp = p1
        p1 = p2
        p2 = tmp
        n = -n
    # portal discovery: a triangle (v1, v2, v3) that the ray from v0 through the origin crosses
    p3 = Portal()
    found = int(0)
    for it in range(MPR_ITERATIONS):
        if found == 0:
            p3 = _minkowski(t1, s1, m1, x1, t2, s2, m2, x2, meshes, n, inflate)
            if wp.dot(p3.v, n) <= 0.0:
                return 0, miss, 0.0, miss
            if wp.dot(wp.cross(p1.v, p3.v), v0) < 0.0:
                p2 = p3
                n = wp.cross(p1.v - v0, p3.v - v0)
            elif wp.dot(wp.cross(p3.v, p2.v), v0) < 0.0:
                p1 = p3
                n = wp.cross(p3.v - v0, p2.v - v0)
            else:
                found = 1
    # portal refinement: push the portal out to the boundary of A - B
    for it in range(MPR_ITERATIONS):
        n = wp.cross(p2.v - p1.v, p3.v - p1.v)
        length = wp.length(n)
        if length < 1.0e-18:
            break
        n = n / length
        if wp.dot(n, p1.v - v0) < 0.0:  # outward: away from the interior point
            n = -n
        p4 = _minkowski(t1, s1, m1, x1, t2, s2, m2, x2, meshes, n, inflate)
        if wp.dot(p4.v, n) <= 0.0 and wp.dot(p1.v, n) < 0.0:
            return 0, miss, 0.0, miss  # the origin is outside, beyond the boundary
        if wp.dot(p4.v - p3.v, n) <= 1.0e-7 or it == MPR_ITERATIONS - 1:
            break
        c = wp.cross(p4.v, v0)
        if wp.dot(p1.v, c) > 0.0:
            if wp.dot(p2.v, c) > 0.0:
                p1 = p4
            else:
                p3 = p4
        else:
            if wp.dot(p3.v, c) > 0.0:
                p2 = p4
            else:
                p1 = p4
    n = wp.normalize(wp.cross(p2.v - p1.v, p3.v - p1.v))
    if wp.dot(n, p1.v - v0) < 0.0:
        n = -n
    depth = wp.dot(p1.v, n)
    if depth < 0.0:
        return 0, miss, 0.0, miss
    # barycentric weights of the origin's projection onto the portal
    q = n * depth
    w1 = wp.length(wp.cross(p2.v - q, p3.v - q))
    w2 = wp.length(wp.cross(p3.v - q, p1.v - q))
    w3 = wp.length(wp.cross(p1.v - q, p2.v - q))
    total = w1 + w2 + w3
    if total < 1.0e-18:
        w1 = 1.0
        total = 1.0
    on_a = (p1.a * w1 + p2.a * w2 + p3.a * w3) / total
    on_b = (p1.b * w1 + p2.b * w2 + p3.b * w3) / total
    # the normal of A - B's boundary points from A to B
    return 1, n, margin - depth, 0.5 * (on_a + on_b)


@wp.func
def _overlap(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3, m2: int,
             x2: wp.transform, meshes: Meshes, n: wp.vec3):
    """How far B must move along n to separate from A: h_A(n) + h_B(-n) measured along n."""
    a = support(t1, s1, m1, meshes, x1, n, 0.0)
    b = support(t2, s2, m2, meshes, x2, -n, 0.0)
    return wp.dot(a - b, n)


@wp.func
def _face_axis(t: int, x: wp.transform, other: wp.vec3, k: int):
    """Candidate separating direction k (0-2) of a shape with flat faces, else zero."""
    rot = wp.transform_get_rotation(x)
    if t == BOX:
        basis = wp.vec3()
        basis[k] = 1.0
        return wp.quat_rotate(rot, basis)
    if t == CYLINDER:
        axis = wp.quat_rotate(rot, wp.vec3(0.0, 0.0, 1.0))
        if k == 0:
            return axis
        if k == 1:  # radial, toward the other shape
            d = other - wp.transform_get_translation(x)
            radial = d - axis * wp.dot(d, axis)
            if wp.length_sq(radial) > 1.0e-12:
                return wp.normalize(radial)
    return wp.vec3()


@wp.func
def _closest_on_triangle(a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Barycentric weights of the point of triangle abc closest to the origin (Ericson 5.1.5)."""
    ab = b - a
    ac = c - a
    ap = -a
    d1 = wp.dot(ab, ap)
    d2 = wp.dot(ac, ap)
    if d1 <= 0.0 and d2 <= 0.0:
        return wp.vec3(1.0, 0.0, 0.0)
    bp = -b
    d3 = wp.dot(ab, bp)
    d4 = wp.dot(ac, bp)
    if d3 >= 0.0 and d4 <= d3:
        return wp.vec3(0.0, 1.0, 0.0)
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        t = d1 / (d1 - d3)
        return wp.vec3(1.0 - t, t, 0.0)
    cp = -c
    d5 = wp.dot(ab, cp)
    d6 = wp.dot(ac, cp)
    if d6 >= 0.0 and d5 <= d6:
        return wp.vec3(0.0, 0.0, 1.0)
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return wp.vec3(1.0 - t, 0.0, t)
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return wp.vec3(0.0, 1.0 - t, t)
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return wp.vec3(1.0 - v - w, v, w)


@wp.func
def gjk(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3, m2: int,
        x2: wp.transform, meshes: Meshes):
    """Distance between two convex shapes (Gilbert-Johnson-Keerthi) and the closest points.

    Returns (separated, distance, point on A, point on B); separated is 0 when they overlap.
    The simplex (at most a tetrahedron) is kept as points of A - B with their witnesses.
    """
    va = mat43()
    vb = mat43()
    d = wp.transform_get_translation(x2) - wp.transform_get_translation(x1)
    if wp.length_sq(d) < 1.0e-18:
        d = wp.vec3(1.0, 0.0, 0.0)
    pa = support(t1, s1, m1, meshes, x1, d, 0.0)
    pb = support(t2, s2, m2, meshes, x2, -d, 0.0)
    va[0] = pa
    vb[0] = pb
    n = int(1)
    v = pa - pb
    ca = pa
    cb = pb
    for it in range(64):
        vv = wp.dot(v, v)
        if vv < 1.0e-14:
            return 0, 0.0, ca, cb
        pa = support(t1, s1, m1, meshes, x1, -v, 0.0)
        pb = support(t2, s2, m2, meshes, x2, v, 0.0)
        w = pa - pb
        if vv - wp.dot(v, w) <= 1.0e-10 * vv + 1.0e-14:
            break  # no progress: v is the closest point
        va[n] = pa
        vb[n] = pb
        n += 1
        # closest point of the simplex to the origin, keeping only the supporting vertices
        if n == 2:
            a = va[0] - vb[0]
            b = va[1] - vb[1]
            ab = b - a
            t = wp.clamp(-wp.dot(a, ab) / wp.max(wp.dot(ab, ab), 1.0e-18), 0.0, 1.0)
            ca = va[0] + (va[1] - va[0]) * t
            cb = vb[0] + (vb[1] - vb[0]) * t
            if t <= 0.0:
                n = 1
            elif t >= 1.0:
                va[0] = va[1]
                vb[0] = vb[1]
                n = 1
        elif n == 3:
            bary = _closest_on_triangle(va[0] - vb[0], va[1] - vb[1], va[2] - vb[2])
            ca = va[0] * bary[0] + va[1] * bary[1] + va[2] * bary[2]
            cb = vb[0] * bary[0] + vb[1] * bary[1] + vb[2] * bary[2]
            k = int(0)
            for i in range(3):
                if bary[i] > 0.0:
                    va[k] = va[i]
                    vb[k] = vb[i]
                    k += 1
            n = k
        else:
            # tetrahedron: the origin is inside unless a face sees it; take the best face
            best = float(1.0e30)
            inside = int(1)
            keep = wp.vec3i(0, 1, 2)
            bary_best = wp.vec3()
            for f in range(4):
                i0 = (f + 1) % 4
                i1 = (f + 2) % 4
                i2 = (f + 3) % 4
                p0 = va[i0] - vb[i0]
                p1 = va[i1] - vb[i1]
                p2 = va[i2] - vb[i2]
                opp = va[f] - vb[f]
                normal = wp.cross(p1 - p0, p2 - p0)
                # the origin is on the far side of this face from the fourth vertex
                if wp.dot(normal, -p0) * wp.dot(normal, opp - p0) < 0.0:
                    inside = 0
                    bary = _closest_on_triangle(p0, p1, p2)
                    q = p0 * bary[0] + p1 * bary[1] + p2 * bary[2]
                    if wp.dot(q, q) < best:
                        best = wp.dot(q, q)
                        keep = wp.vec3i(i0, i1, i2)
                        bary_best = bary
            if inside != 0:
                return 0, 0.0, ca, cb
            na = mat43()
            nb = mat43()
            k = int(0)
            ca = wp.vec3()
            cb = wp.vec3()
            for i in range(3):
                ca = ca + va[keep[i]] * bary_best[i]
                cb = cb + vb[keep[i]] * bary_best[i]
                if bary_best[i] > 0.0:
                    na[k] = va[keep[i]]
                    nb[k] = vb[keep[i]]
                    k += 1
            va = na
            vb = nb
            n = k
        v = ca - cb
    return 1, wp.length(ca - cb), ca, cb


@wp.func
def convex_contact(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3,
                   m2: int, x2: wp.transform, meshes: Meshes, margin: float):
    """Contact of two convex shapes.

    Apart: GJK's exact distance, normal and closest points. Overlapping: MPR, then the flat-face
    directions of boxes and cylinders and their cross products as candidate normals, the one
    needing the least translation winning (a separating-axis estimate of the minimum
    translation, exact where a face or edge pair is in contact). MPR alone measures depth along
    the line between the centers, which overstates a shallow edge-on-face contact seen from an
    oblique line."""
    # apart: GJK's closest points give the exact distance and normal
    separated, gap, on_a, on_b = gjk(t1, s1, m1, x1, t2, s2, m2, x2, meshes)
    if separated != 0 and gap > 1.0e-6:
        if gap >= margin:
            return 0, wp.vec3(), 0.0, wp.vec3()
        return 1, (on_b - on_a) / gap, gap, 0.5 * (on_a + on_b)
    hit, n, dist, pos = mpr(t1, s1, m1, x1, t2, s2, m2, x2, meshes, margin)
    if hit == 0 or dist >= 0.0:
        return hit, n, dist, pos
    best = -dist
    c1 = wp.transform_get_translation(x1)
    c2 = wp.transform_get_translation(x2)
    # candidates: A's face directions, B's, then the cross products of the two (edge on edge)
    for cand in range(15):
        side = int(0)
        axis = wp.vec3()
        if cand < 3:
            axis = _face_axis(t1, x1, c2, cand)
        elif cand < 6:
            side = 1
            axis = _face_axis(t2, x2, c1, cand - 3)
        else:
            side = 2
            axis = wp.cross(_face_axis(t1, x1, c2, (cand - 6) // 3), _face_axis(t2, x2, c1, (cand - 6) % 3))
            if wp.length_sq(axis) > 1.0e-6:
                axis = wp.normalize(axis)
        if wp.length_sq(axis) > 0.5:
            if wp.dot(axis, c2 - c1) < 0.0:
                axis = -axis
            depth = _overlap(t1, s1, m1, x1, t2, s2, m2, x2, meshes, axis)
            if depth < best:
                best = depth
                n = axis
                # the contact sits at the deepest point of the shape facing the flat face
                a = support(t1, s1, m1, meshes, x1, axis, 0.0)
                b = support(t2, s2, m2, meshes, x2, -axis, 0.0)
                if side == 0:
                    pos = b + axis * (0.5 * depth)
                elif side == 1:
                    pos = a - axis * (0.5 * depth)
                else:
                    pos = 0.5 * (a + b)
    return hit, n, -best, pos
