"""General convex-convex contact: GJK for the distance, EPA for the penetration depth.

For pairs without a closed form (ellipsoids, cylinders, convex meshes against the other convex
shapes), GJK (Gilbert-Johnson-Keerthi) gives the exact distance and closest points of shapes
that are apart. Overlapping, EPA (the expanding polytope algorithm, van den Bergen) grows a
polytope inside the Minkowski difference A - B from GJK's final simplex until its face nearest
the origin lies on the boundary: that face's distance is the penetration depth (the minimum
translation that separates the shapes) and its normal the contact normal, from A to B. Spheres
and capsules enter both as their cores (a point, a segment) grown by their radius, which keeps
the supports piecewise flat: GJK and EPA then end in a few steps instead of creeping over a
curved surface, and the radius is added back exactly. One contact point per pair: the points of
A and B that the nearest face's barycentric weights pick, and their midpoint.

Where EPA cannot start (shapes touching within its tolerance, where the origin lies on the
boundary of A - B and no polytope holds it strictly inside), Minkowski Portal Refinement (MPR;
Snethen, "XenoCollide", Game Programming Gems 7) takes over: it measures the penetration along
the line from the interior point (c_A - c_B) through the origin, on both shapes inflated by half
the contact offset, so that it also sees shapes just touching; candidate face and edge axes of
boxes and cylinders then correct its depth where one of them needs less translation.
"""

import warp as wp

from ...structs import Meshes
from ...types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE, TRIMESH

MPR_ITERATIONS = wp.constant(48)

# EPA's fixed-size polytope (a Warp thread cannot allocate): every iteration adds one vertex and,
# on a closed triangulated polytope, two faces net, so 4 + EPA_ITERATIONS vertices and
# 4 + 2 * EPA_ITERATIONS faces hold the largest one; a few faces more absorb a step whose visible
# region a rounding error left ragged. Flat-faced pairs (meshes, boxes, cores) end in a handful of
# iterations; curved ones (ellipsoids, cylinders' sides) can reach the cap, their depth then
# within 0.03 mm of the exact one in tests/test_depth.py.
EPA_ITERATIONS = wp.constant(32)
EPA_VERTS = 36
EPA_FACES = 72
# convergence: GJK's distance within this of its lower bound, EPA's upper and lower bounds on the
# depth within this of each other; relative to the sum of the two shapes' bounding radii (2e-6 m
# for two 10 cm shapes: float32 support points a few metres from the world origin carry 1e-7 m
# of rounding)
EPA_TOLERANCE = wp.constant(1.0e-5)
# steps of the search for a tetrahedron holding the origin, grown from GJK's simplex
ENCLOSE_ITERATIONS = wp.constant(24)

# a GJK simplex: up to four points of A (or of B), one per row
mat43 = wp.types.matrix(shape=(4, 3), dtype=float)
# EPA's polytope: vertices (points of A, of B, of A - B), faces (three vertex ids, counter-
# clockwise seen from outside; the three faces across their edges; unit outward normal and the
# distance of its plane from the origin), per-face flags and the horizon's edges
epa_points = wp.types.matrix(shape=(EPA_VERTS, 3), dtype=float)
epa_face_ids = wp.types.matrix(shape=(EPA_FACES, 3), dtype=wp.int32)
epa_face_normals = wp.types.matrix(shape=(EPA_FACES, 3), dtype=float)
epa_face_values = wp.types.vector(length=EPA_FACES, dtype=float)
epa_face_flags = wp.types.vector(length=EPA_FACES, dtype=wp.int32)
epa_edges = wp.types.vector(length=EPA_VERTS, dtype=wp.int32)


@wp.func
def bounding_box(t: int, s: wp.vec3, dataid: int, meshes: Meshes):
    """(center, half extents) of a box in the geom's frame that holds the whole shape."""
    if t == MESH or t == TRIMESH:
        return meshes.box_center[dataid], meshes.box_half[dataid]
    if t == SPHERE:
        return wp.vec3(), wp.vec3(s[0], s[0], s[0])
    if t == CAPSULE:
        return wp.vec3(), wp.vec3(s[0], s[0], s[0] + s[1])
    if t == CYLINDER:
        return wp.vec3(), wp.vec3(s[0], s[0], s[1])
    return wp.vec3(), s        # box, ellipsoid


@wp.func
def _face_axis_separates(d: wp.vec3, ra: wp.mat33, i: int, ha: wp.vec3, rb: wp.mat33, hb: wp.vec3,
                         margin: float):
    """Whether box A's i-th face normal separates boxes A and B (centers d apart) by more than
    `margin`: their projections on it do not reach each other."""
    a = wp.vec3(ra[0, i], ra[1, i], ra[2, i])
    reach = ha[i] + margin
    for j in range(3):
        reach += hb[j] * wp.abs(a[0] * rb[0, j] + a[1] * rb[1, j] + a[2] * rb[2, j])
    return wp.abs(wp.dot(d, a)) > reach


@wp.func
def boxes_apart(x1: wp.transform, c1: wp.vec3, h1: wp.vec3, x2: wp.transform, c2: wp.vec3,
                h2: wp.vec3, margin: float):
    """Whether two oriented boxes (centers c, half extents h in the frames x) are farther apart
    than `margin` along one of their six face normals (a separating axis: then the shapes they
    hold cannot touch)."""
    r1 = wp.quat_to_matrix(wp.transform_get_rotation(x1))
    r2 = wp.quat_to_matrix(wp.transform_get_rotation(x2))
    d = wp.transform_point(x2, c2) - wp.transform_point(x1, c1)
    apart = False
    for i in range(3):
        if (_face_axis_separates(d, r1, i, h1, r2, h2, margin)
                or _face_axis_separates(d, r2, i, h2, r1, h1, margin)):
            apart = True
    return apart


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


@wp.func
def core_radius(t: int, size: wp.vec3):
    """Radius by which a sphere or capsule exceeds its core (its center, its segment); zero for
    the other shapes, which are their own core."""
    if t == SPHERE or t == CAPSULE:
        return size[0]
    return 0.0


@wp.func
def support_core(t: int, size: wp.vec3, mesh: int, meshes: Meshes, x: wp.transform, d: wp.vec3):
    """World-frame support point of the shape's core along d (d need not be unit)."""
    if t == SPHERE:
        return wp.transform_get_translation(x)
    rot = wp.transform_get_rotation(x)
    local = wp.quat_rotate_inv(rot, d)
    if t == CAPSULE:
        return wp.transform_point(x, wp.vec3(0.0, 0.0, _sgn(local[2]) * size[1]))
    return wp.transform_point(x, support_local(t, size, mesh, meshes, local))


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
        x2: wp.transform, meshes: Meshes, tol: float, cutoff: float):
    """Distance between the cores of two convex shapes (Gilbert-Johnson-Keerthi: a sphere's
    center, a capsule's segment, any other shape whole) and their closest points.

    Returns (separated, distance, point on A, point on B, simplex points of A, of B, their
    count); separated is 0 when the cores overlap, and the simplex (at most a tetrahedron of
    points of A - B, kept with their witnesses) is then where EPA starts. The distance is good
    to `tol`: GJK stops when a step would gain less. Cores found farther apart than `cutoff`
    (a support plane of A - B that far from the origin) end the search at once: the distance
    returned is then that lower bound, and the points are not the closest ones. Most candidate
    pairs that pass the broadphase are such (a finger link and the wall sector beside it), and
    end in one or two steps instead of converging on a distance nobody reads.
    """
    va = mat43()
    vb = mat43()
    d = wp.transform_get_translation(x2) - wp.transform_get_translation(x1)
    if wp.length_sq(d) < 1.0e-18:
        d = wp.vec3(1.0, 0.0, 0.0)
    pa = support_core(t1, s1, m1, meshes, x1, d)
    pb = support_core(t2, s2, m2, meshes, x2, -d)
    va[0] = pa
    vb[0] = pb
    n = int(1)
    v = pa - pb
    ca = pa
    cb = pb
    best_vv = float(1.0e30)
    best_a = ca
    best_b = cb
    line = int(0)
    for it in range(64):
        vv = wp.dot(v, v)
        if vv < 1.0e-14:
            return 0, 0.0, ca, cb, va, vb, n
        if vv >= best_vv:
            if line != 0:
                ca = best_a
                cb = best_b
                break  # not even a line search descends: as close as float32 gets
            # no descent: rounding in a sliver simplex (a curved surface's support points
            # crowding together) sent the step back out, and it would cycle from here; go on
            # from the best point with line searches (Gilbert's original steps: slower, but
            # each one descends)
            line = 1
            ca = best_a
            cb = best_b
            v = ca - cb
            vv = best_vv
            va[0] = ca
            vb[0] = cb
            n = 1
        best_vv = vv
        best_a = ca
        best_b = cb
        pa = support_core(t1, s1, m1, meshes, x1, -v)
        pb = support_core(t2, s2, m2, meshes, x2, v)
        w = pa - pb
        if wp.dot(v, w) > cutoff * wp.sqrt(vv):
            return 1, wp.dot(v, w) / wp.sqrt(vv), ca, cb, va, vb, n
        if vv - wp.dot(v, w) <= tol * wp.sqrt(vv):
            break  # no progress (the distance is within tol): v is the closest point
        if line != 0:
            # the point nearest the origin on the segment from v to w
            d = w - v
            t = wp.clamp(-wp.dot(v, d) / wp.max(wp.dot(d, d), 1.0e-30), 0.0, 1.0)
            ca = ca + (pa - ca) * t
            cb = cb + (pb - cb) * t
            v = ca - cb
            continue
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
                # the origin is on the far side of this face from the fourth vertex, or the
                # tetrahedron is flat (then no face holds the origin in: a rounding error in the
                # sign test let a flat one pass as holding it)
                side = wp.dot(normal, opp - p0)
                if (wp.dot(normal, -p0) * side < 0.0
                        or wp.abs(side) <= 1.0e-5 * wp.length(normal) * wp.length(opp - p0)):
                    inside = 0
                    bary = _closest_on_triangle(p0, p1, p2)
                    q = p0 * bary[0] + p1 * bary[1] + p2 * bary[2]
                    if wp.dot(q, q) < best:
                        best = wp.dot(q, q)
                        keep = wp.vec3i(i0, i1, i2)
                        bary_best = bary
            if inside != 0:
                return 0, 0.0, ca, cb, va, vb, n
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
    return 1, wp.length(ca - cb), ca, cb, va, vb, n


@wp.func
def _face_plane(p0: wp.vec3, p1: wp.vec3, p2: wp.vec3, tiny: float):
    """Unit normal of triangle p0 p1 p2 (counter-clockwise seen from its front) and the signed
    distance of its plane from the origin; a sliver (twice its area below `tiny`) gets no normal
    and an infinite distance, so that EPA never picks it nor sees it from a new point."""
    c = wp.cross(p1 - p0, p2 - p0)
    length = wp.length(c)
    if length <= tiny:
        return wp.vec3(), 1.0e30
    n = c / length
    return n, wp.dot(n, p0)


@wp.func
def _barycentric(p: wp.vec3, a: wp.vec3, b: wp.vec3, c: wp.vec3):
    """Weights of p (a point of triangle abc's plane) on a, b, c, clamped into the triangle."""
    e0 = b - a
    e1 = c - a
    e2 = p - a
    d00 = wp.dot(e0, e0)
    d01 = wp.dot(e0, e1)
    d11 = wp.dot(e1, e1)
    d20 = wp.dot(e2, e0)
    d21 = wp.dot(e2, e1)
    den = d00 * d11 - d01 * d01
    if den <= 1.0e-30:
        return wp.vec3(1.0, 0.0, 0.0)
    v = wp.max((d11 * d20 - d01 * d21) / den, 0.0)
    w = wp.max((d00 * d21 - d01 * d20) / den, 0.0)
    u = wp.max(1.0 - v - w, 0.0)
    total = u + v + w
    return wp.vec3(u, v, w) / total


@wp.func
def _enclose(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3, m2: int,
             x2: wp.transform, meshes: Meshes, va: mat43, vb: mat43, count: int, tol: float):
    """A tetrahedron of points of A - B (cores) that holds the origin (inside or on a face),
    with a height above each face of more than `tol`, grown from GJK's final simplex of `count`
    points; its points of A and of B, in positive orientation (the fourth point on the side of
    the first face's normal).

    GJK stops as soon as its simplex holds the origin, or comes within 1e-7 of it with fewer
    than four points (the origin on a segment or triangle: symmetric poses), so the simplex is
    padded with support points off its span, then a face that the origin lies beyond has its
    opposite point replaced by the support point past it, as in GJK's intersection test (the
    origin may end on a face: EPA expands that face first). Returns found = 0 when the support
    point does not pass the origin by more than `tol` (the origin within `tol` of the boundary
    of A - B, shapes touching, or outside it) or the step cap is reached."""
    for k in range(1, 4):
        if k >= count:
            p0 = va[0] - vb[0]
            d = -p0
            if k == 2:
                e = va[1] - vb[1] - p0
                # perpendicular to the segment: crossed with the axis it leans on least
                axis = wp.vec3(1.0, 0.0, 0.0)
                if wp.abs(e[1]) < wp.abs(e[0]) and wp.abs(e[1]) <= wp.abs(e[2]):
                    axis = wp.vec3(0.0, 1.0, 0.0)
                elif wp.abs(e[2]) < wp.abs(e[0]):
                    axis = wp.vec3(0.0, 0.0, 1.0)
                d = wp.cross(e, axis)
            elif k == 3:
                d = wp.cross(va[1] - vb[1] - p0, va[2] - vb[2] - p0)
                if wp.dot(d, p0) > 0.0:
                    d = -d
            if wp.length_sq(d) < 1.0e-24:
                d = wp.vec3(1.0, 0.0, 0.0)
            va[k] = support_core(t1, s1, m1, meshes, x1, d)
            vb[k] = support_core(t2, s2, m2, meshes, x2, -d)
    found = int(0)
    for it in range(ENCLOSE_ITERATIONS):
        if found == 0:
            # each face (the three points other than i), its normal pointing away from point i
            worst = int(-1)
            worst_dist = float(1.0e30)
            worst_n = wp.vec3()
            flat = int(0)
            largest = float(-1.0)
            flat_i = int(0)
            flat_n = wp.vec3()
            for i in range(4):
                q0 = va[(i + 1) % 4] - vb[(i + 1) % 4]
                q1 = va[(i + 2) % 4] - vb[(i + 2) % 4]
                q2 = va[(i + 3) % 4] - vb[(i + 3) % 4]
                c = wp.cross(q1 - q0, q2 - q0)
                if wp.dot(c, va[i] - vb[i] - q0) > 0.0:
                    c = -c
                area = wp.length(c)
                if area > largest:
                    largest = area
                    flat_i = i
                    flat_n = c
                if area > 1.0e-30:
                    c = c / area
                    # how far the origin lies inside this face (negative: beyond it)
                    inside = wp.dot(c, q0)
                    height = -wp.dot(c, va[i] - vb[i] - q0)
                    if height <= tol:
                        flat = 1
                    if inside < worst_dist:
                        worst_dist = inside
                        worst = i
                        worst_n = c
                else:
                    flat = 1
            replace = int(-1)
            d = wp.vec3()
            if flat != 0:
                # no volume: replace the point opposite the largest face by the support point
                # off its plane, on the origin's side
                replace = flat_i
                d = wp.normalize(flat_n)
                q0 = va[(flat_i + 1) % 4] - vb[(flat_i + 1) % 4]
                if wp.dot(d, q0) > 0.0:
                    d = -d
            elif worst_dist >= 0.0:
                found = 1
            else:
                replace = worst
                d = worst_n
            if replace >= 0:
                pa = support_core(t1, s1, m1, meshes, x1, d)
                pb = support_core(t2, s2, m2, meshes, x2, -d)
                if wp.dot(pa - pb, d) <= tol:
                    return 0, va, vb     # the origin is on the boundary of A - B, or outside
                va[replace] = pa
                vb[replace] = pb
    if found == 0:
        return 0, va, vb
    p0 = va[0] - vb[0]
    if wp.dot(wp.cross(va[1] - vb[1] - p0, va[2] - vb[2] - p0), va[3] - vb[3] - p0) < 0.0:
        tmp = va[2]
        va[2] = va[3]
        va[3] = tmp
        tmp = vb[2]
        vb[2] = vb[3]
        vb[3] = tmp
    return 1, va, vb


@wp.func
def epa(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3, m2: int,
        x2: wp.transform, meshes: Meshes, va: mat43, vb: mat43, count: int, tol: float):
    """Penetration depth of two overlapping cores (the expanding polytope algorithm).

    Starts from GJK's simplex (`va`, `vb`, `count` points); returns (found, normal from A to B,
    depth, point on A, point on B). Each step takes the polytope's face nearest the origin (a
    lower bound on the depth) and the support point along its normal (an upper bound). Where
    they agree within `tol`, that face gives the depth, normal and witness points; where the
    least upper bound so far meets the lower bound instead, or the iteration cap (or a full
    polytope) comes first, the direction of the least upper bound and the support points along
    it do. found is 0 where no starting tetrahedron holds the origin (touching shapes): MPR then
    measures the contact."""
    found, va, vb = _enclose(t1, s1, m1, x1, t2, s2, m2, x2, meshes, va, vb, count, tol)
    if found == 0:
        return 0, wp.vec3(), 0.0, wp.vec3(), wp.vec3()
    pa = epa_points()
    pb = epa_points()
    pv = epa_points()
    for i in range(4):
        pa[i] = va[i]
        pb[i] = vb[i]
        pv[i] = va[i] - vb[i]
    nv = int(4)
    # the tetrahedron (positively oriented) with its faces outward, and which face lies across
    # each edge (edge e of a face runs from its vertex e to vertex e + 1)
    face = epa_face_ids()
    adj = epa_face_ids()
    normal = epa_face_normals()
    dist = epa_face_values()
    face[0] = wp.vec3i(0, 2, 1)
    adj[0] = wp.vec3i(3, 2, 1)
    face[1] = wp.vec3i(0, 1, 3)
    adj[1] = wp.vec3i(0, 2, 3)
    face[2] = wp.vec3i(1, 2, 3)
    adj[2] = wp.vec3i(0, 3, 1)
    face[3] = wp.vec3i(0, 3, 2)
    adj[3] = wp.vec3i(1, 2, 0)
    # a face whose doubled area is below 1e-6 (size)^2 is a sliver: float32 cross products of
    # its edges carry 1e-7 (size)^2 of rounding, and its normal would be noise
    tiny = 1.0e4 * tol * tol
    for f in range(4):
        n, d = _face_plane(pv[face[f, 0]], pv[face[f, 1]], pv[face[f, 2]], tiny)
        normal[f] = n
        dist[f] = d
    nf = int(4)
    visible = epa_face_flags()
    stack = epa_face_flags()
    # horizon edges: from vertex h_from to h_to, the face beyond it (and the edge's index
    # there), and the slot of the new face built on it
    h_from = epa_edges()
    h_to = epa_edges()
    h_face = epa_edges()
    h_edge = epa_edges()
    h_slot = epa_edges()
    best = wp.vec3i()
    best_n = wp.vec3()
    best_d = float(0.0)
    have = int(0)
    # the direction with the least support seen (the upper bound) and its support points
    upper = float(1.0e30)
    up_n = wp.vec3()
    up_a = wp.vec3()
    up_b = wp.vec3()
    converged = int(0)
    for it in range(EPA_ITERATIONS):
        # the face nearest the origin (deleted faces have face[f, 0] = -1)
        near = int(-1)
        lower = float(1.0e30)
        for f in range(nf):
            if face[f, 0] >= 0 and dist[f] < lower:
                lower = dist[f]
                near = f
        if near < 0:
            break
        best = face[near]
        best_n = normal[near]
        best_d = wp.max(lower, 0.0)     # the origin may lie on a starting face
        have = 1
        wa = support_core(t1, s1, m1, meshes, x1, best_n)
        wb = support_core(t2, s2, m2, meshes, x2, -best_n)
        w = wa - wb
        reach = wp.dot(w, best_n)
        if reach < upper:
            upper = reach
            up_n = best_n
            up_a = wa
            up_b = wb
        if reach - lower <= tol:
            converged = 1   # this face lies on the boundary of A - B
            break
        if upper - lower <= tol or nv == EPA_VERTS:
            break           # the depth is known, or no room for more: the least upper bound
        # the faces that w sees go, found by walking across edges from the nearest face so that
        # they form one patch even where rounding makes a far face look visible too; the edges
        # between them and the rest form the horizon
        for f in range(nf):
            visible[f] = 0
        visible[near] = 1
        stack[0] = near
        top = int(1)
        while top > 0:
            top -= 1
            f = stack[top]
            for e in range(3):
                g = adj[f, e]
                if visible[g] == 0 and wp.dot(normal[g], w) - dist[g] > 0.01 * tol:
                    visible[g] = 1
                    stack[top] = g
                    top += 1
        nh = int(0)
        free = EPA_FACES - nf
        broken = int(0)
        for f in range(nf):
            if face[f, 0] < 0:
                free += 1
            elif visible[f] != 0:
                free += 1
                for e in range(3):
                    g = adj[f, e]
                    if visible[g] == 0:
                        if nh == EPA_VERTS:
                            broken = 1
                        else:
                            h_from[nh] = face[f, e]
                            h_to[nh] = face[f, (e + 1) % 3]
                            h_face[nh] = g
                            # the same edge, reversed, in the face beyond
                            ge = int(0)
                            if face[g, 1] == h_to[nh]:
                                ge = 1
                            elif face[g, 2] == h_to[nh]:
                                ge = 2
                            h_edge[nh] = ge
                            nh += 1
        if broken != 0 or nh < 3 or nh > free:
            break
        for f in range(nf):
            if visible[f] != 0:
                face[f, 0] = -1
        wi = nv
        pa[wi] = wa
        pb[wi] = wb
        pv[wi] = w
        nv += 1
        # slots: deleted faces first (lowest first), then the end of the list
        cursor = int(0)
        for h in range(nh):
            while cursor < nf and face[cursor, 0] >= 0:
                cursor += 1
            h_slot[h] = cursor
            if cursor == nf:
                nf += 1
            cursor += 1
        # a fan of faces from w to the horizon; the face on the horizon edge i -> j has beyond
        # its edge j -> w the new face on the horizon edge leaving j, beyond w -> i the one
        # arriving at i
        for h in range(nh):
            i = h_from[h]
            j = h_to[h]
            slot = h_slot[h]
            after = int(-1)
            before = int(-1)
            for k in range(nh):
                if h_from[k] == j:
                    if after >= 0:
                        broken = 1
                    after = h_slot[k]
                if h_to[k] == i:
                    if before >= 0:
                        broken = 1
                    before = h_slot[k]
            if after < 0 or before < 0:
                broken = 1
            face[slot] = wp.vec3i(i, j, wi)
            adj[slot] = wp.vec3i(h_face[h], after, before)
            adj[h_face[h], h_edge[h]] = slot
            n, d = _face_plane(pv[i], pv[j], w, tiny)
            normal[slot] = n
            dist[slot] = d
        if broken != 0:
            break   # a ragged horizon (rounding): the least upper bound found so far
    if have == 0:
        return 0, wp.vec3(), 0.0, wp.vec3(), wp.vec3()
    if converged == 0:
        # the nearest face's normal is unverified (curved shapes creep, each step gaining less,
        # and a deep overlap leaves many faces nearly as near: its normal can be 30 degrees
        # off); the direction of least support is a true separating translation, longer than
        # the depth by at most the bounds' gap (ellipsoids 7 cm deep: 0.01%)
        return 1, up_n, upper, up_a, up_b
    # witness points: the origin's projection on the nearest face, in its vertices' weights
    bary = _barycentric(best_n * best_d, pv[best[0]], pv[best[1]], pv[best[2]])
    on_a = pa[best[0]] * bary[0] + pa[best[1]] * bary[1] + pa[best[2]] * bary[2]
    on_b = pb[best[0]] * bary[0] + pb[best[1]] * bary[1] + pb[best[2]] * bary[2]
    return 1, best_n, best_d, on_a, on_b


@wp.func
def convex_contact(t1: int, s1: wp.vec3, m1: int, x1: wp.transform, t2: int, s2: wp.vec3,
                   m2: int, x2: wp.transform, meshes: Meshes, margin: float):
    """Contact of two convex shapes: (hit, normal from 1 to 2, signed distance, midpoint).

    Apart: GJK's exact distance, normal and closest points (of the cores, less the radii of
    spheres and capsules). Overlapping: EPA's minimum translation. Touching, where EPA cannot
    start: MPR, then the flat-face directions of boxes and cylinders and their cross products as
    candidate normals, the one needing the least translation winning (MPR alone measures depth
    along the line between the centers, which overstates a shallow edge-on-face contact seen
    from an oblique line)."""
    if not (wp.isfinite(wp.transform_get_translation(x1))
            and wp.isfinite(wp.transform_get_translation(x2))):
        # an env gone non-finite: NaN fails every stopping test, and each of GJK's 64 and EPA's
        # 32 steps would walk a mesh's vertices (an exploded G1 took 6 s a step)
        return 0, wp.vec3(), 0.0, wp.vec3()
    r1 = core_radius(t1, s1)
    r2 = core_radius(t2, s2)
    size = bounding_radius(t1, s1, m1, meshes) + bounding_radius(t2, s2, m2, meshes)
    tol = EPA_TOLERANCE * size
    separated, gap, on_a, on_b, va, vb, count = gjk(t1, s1, m1, x1, t2, s2, m2, x2, meshes, tol,
                                                    margin + r1 + r2)
    if separated != 0 and gap > 1.0e-6:
        # apart cores: the shapes are apart or overlap by less than the radii, exactly
        dist = gap - r1 - r2
        if dist >= margin:
            return 0, wp.vec3(), 0.0, wp.vec3()
        n = (on_b - on_a) / gap
        return 1, n, dist, 0.5 * (on_a + on_b + n * (r1 - r2))
    found, n, depth, on_a, on_b = epa(t1, s1, m1, x1, t2, s2, m2, x2, meshes, va, vb, count, tol)
    if found != 0:
        return 1, n, -(depth + r1 + r2), 0.5 * (on_a + on_b + n * (r1 - r2))
    # touching (the origin within tol of the boundary of A - B: EPA found no polytope around
    # it): MPR on the shapes inflated by the offset, and the candidate axes
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
