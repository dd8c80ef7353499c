"""Narrowphase: contacts of each candidate pair in each env, closed forms per type pair.

One thread per (env, pair). A contact is kept when the signed distance between the surfaces is
below the contact offset (PhysX's contactOffset; MuJoCo's margin). It records, as MuJoCo does,
the two geoms, the midpoint between the surfaces, the normal from geom 1 to geom 2 and the
signed distance (negative: penetration). Contacts go to the env's preallocated places through
an atomic counter; on a GPU `order_by_pair` then puts them in the CPU's order, and an env whose
contacts overflowed its places is walked again in that order (`redo_overflowed`), so that the
contacts kept never depend on which thread's atomic came first. A count above the slots is an
overflow, reported by the simulator. There are
CANDIDATES_PER_SLOT places per slot, and `keep_deepest` keeps the deepest contacts in the slots:
a robot curled up on itself (G1 with hands: 780 contacts within the offset, 64 slots) lost
whichever contacts came last, a foot's or a penetrating one's among them, and 5 of 40 envs went
non-finite (2 with the deepest kept; none once the solver also held the speed caps exactly).
Nothing is ever written outside an env's places.
"""

from __future__ import annotations

import warp as wp

from ...spatial import tangents
from ..kinematics import geom_frame
from ...structs import Contacts, EnvParams, HFields, Meshes, ModelArrays, Options, State
from ...types import (BOX, CAPSULE, CYLINDER, ELLIPSOID, HFIELD, MESH, PLANE, SPHERE, TRIMESH,
                      GeomType)
from .convex import (bounding_box, bounding_radius, box_corner, boxes_apart,
                     convex_contact, mat43, support)
from .heightfield import ellipsoid_probe, probe_point, riser_contact, surface
from .trimesh import face_plane, surface_point


# probes per shape against a height field or a triangle mesh (see heightfield.probe_point);
# meshes: at most this many of their vertices (the hull's vertices come first in MuJoCo's data)
HFIELD_PROBES = wp.constant(32)
# contacts of a shape with a triangle mesh past its probes' own (a round probe's other faces,
# the mesh's ridges into the shape), at most; each has a key of its own (see `_trimesh`)
TRIMESH_EDGES = wp.constant(16)

# a convex pair's extra contact points: the normal tilted by this (tan of the angle) to find the
# corners of each shape's contact face, and the least distance between two kept points (m)
FACE_TILT = wp.constant(0.2)
FACE_SPACING = wp.constant(1.0e-3)

# places for the narrowphase's contacts per contact slot (`keep_deepest`)
CANDIDATES_PER_SLOT = 4

# up to 8 polygon points (rows: u, v, height) while clipping a face against another
poly8 = wp.types.matrix(shape=(8, 3), dtype=float)


@wp.struct
class ContactSlots:
    """The `Contacts` fields a pair test fills (the same arrays): passed by value down the pair
    tests, which a CPU build does not inline, so it carries these six and not the struct's ten."""
    count: wp.array(dtype=wp.int32)
    geom: wp.array2d(dtype=wp.vec2i)
    key: wp.array2d(dtype=wp.int32)
    pos: wp.array2d(dtype=wp.vec3)
    normal: wp.array2d(dtype=wp.vec3)
    dist: wp.array2d(dtype=float)


@wp.func
def contact_slots(c: Contacts):
    out = ContactSlots()
    out.count = c.count
    out.geom = c.geom
    out.key = c.key
    out.pos = c.pos
    out.normal = c.normal
    out.dist = c.dist
    return out


@wp.func
def _emit(e: int, pair: wp.vec2i, key: int, pos: wp.vec3, normal: wp.vec3, dist: float,
          margin: float, out: ContactSlots):
    if dist < margin:
        slot = wp.atomic_add(out.count, e, 1)
        if slot < out.geom.shape[1]:    # past the env's places: counted (overflow), not kept
            out.geom[e, slot] = pair
            out.key[e, slot] = key
            out.pos[e, slot] = pos
            out.normal[e, slot] = normal
            out.dist[e, slot] = dist


@wp.func
def _segment(x: wp.transform, half_length: float, sign: float):
    """An end point of a capsule's segment (along the geom's local z)."""
    return wp.transform_point(x, wp.vec3(0.0, 0.0, sign * half_length))


@wp.func
def _closest_on_segment(a: wp.vec3, b: wp.vec3, p: wp.vec3):
    ab = b - a
    denom = wp.dot(ab, ab)
    t = float(0.0)
    if denom > 0.0:
        t = wp.clamp(wp.dot(p - a, ab) / denom, 0.0, 1.0)
    return a + ab * t


@wp.func
def _closest_between_segments(p1: wp.vec3, q1: wp.vec3, p2: wp.vec3, q2: wp.vec3):
    """Parameters (s, t) of the closest points p1 + s·(q1 - p1) and p2 + t·(q2 - p2)."""
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = wp.dot(d1, d1)
    e = wp.dot(d2, d2)
    f = wp.dot(d2, r)
    s = float(0.0)
    t = float(0.0)
    eps = 1.0e-12
    if a <= eps and e <= eps:
        return wp.vec2(0.0, 0.0)
    if a <= eps:
        t = wp.clamp(f / e, 0.0, 1.0)
    else:
        c = wp.dot(d1, r)
        if e <= eps:
            s = wp.clamp(-c / a, 0.0, 1.0)
        else:
            b = wp.dot(d1, d2)
            denom = a * e - b * b
            if denom > eps * a * e:
                s = wp.clamp((b * f - c * e) / denom, 0.0, 1.0)
            t = (b * s + f) / e
            if t < 0.0:
                t = 0.0
                s = wp.clamp(-c / a, 0.0, 1.0)
            elif t > 1.0:
                t = 1.0
                s = wp.clamp((b - c) / a, 0.0, 1.0)
    return wp.vec2(s, t)


@wp.func
def _spheres(c1: wp.vec3, r1: float, c2: wp.vec3, r2: float):
    """(normal from 1 to 2, signed distance, midpoint) of two spheres."""
    d = c2 - c1
    length = wp.length(d)
    n = wp.vec3(0.0, 0.0, 1.0)
    if length > 1.0e-9:
        n = d / length
    dist = length - r1 - r2
    return n, dist, c1 + n * (r1 + 0.5 * dist)


# 1/φ: a golden-section step keeps this fraction of the interval
GOLDEN = wp.constant(0.6180339887)


@wp.func
def _local_box_distance(half: wp.vec3, local: wp.vec3):
    """Signed distance from a point in the box's frame to the box surface (negative inside);
    convex and 1-Lipschitz in the point."""
    q = wp.vec3(wp.abs(local[0]) - half[0], wp.abs(local[1]) - half[1], wp.abs(local[2]) - half[2])
    outside = wp.vec3(wp.max(q[0], 0.0), wp.max(q[1], 0.0), wp.max(q[2], 0.0))
    return wp.length(outside) + wp.min(wp.max(q[0], wp.max(q[1], q[2])), 0.0)


@wp.func
def _cylinder_distance(s: wp.vec3, local: wp.vec3):
    """(signed distance from a point in the cylinder's frame to its surface, negative inside;
    the outward normal there) of the cylinder of radius s[0], half-height s[1] along z."""
    radial = wp.vec3(local[0], local[1], 0.0)
    rho = wp.length(radial)
    out = wp.vec3(1.0, 0.0, 0.0)
    if rho > 1.0e-12:
        out = radial / rho
    side = rho - s[0]
    cap = wp.abs(local[2]) - s[1]
    up = wp.vec3(0.0, 0.0, wp.sign(local[2]))
    if side > 0.0 and cap > 0.0:      # beyond a rim: to the rim's nearest point
        d = out * side + up * cap
        length = wp.length(d)
        return length, d / length
    if side > cap:
        return side, out
    return cap, up


@wp.func
def _signed_distance(kind: int, size: wp.vec3, local: wp.vec3):
    """Signed distance from a point in a box's (kind BOX) or cylinder's frame to its surface."""
    if kind == BOX:
        return _local_box_distance(size, local)
    dist, normal = _cylinder_distance(size, local)
    return dist


@wp.func
def _distance_and_normal(kind: int, size: wp.vec3, local: wp.vec3):
    """(`_signed_distance`, the outward normal of the surface nearest the point), both in the
    box's or cylinder's frame."""
    if kind == BOX:
        clamped = wp.vec3(wp.clamp(local[0], -size[0], size[0]),
                          wp.clamp(local[1], -size[1], size[1]),
                          wp.clamp(local[2], -size[2], size[2]))
        away = local - clamped
        if wp.length_sq(away) > 1.0e-24:        # outside: from the nearest surface point
            return _local_box_distance(size, local), wp.normalize(away)
        axis = int(0)                           # inside: the nearest face
        for i in range(1, 3):
            if size[i] - wp.abs(local[i]) < size[axis] - wp.abs(local[axis]):
                axis = i
        n = wp.vec3()
        n[axis] = wp.sign(local[axis])
        return _local_box_distance(size, local), n
    return _cylinder_distance(size, local)


@wp.func
def _deepest_on_segment(kind: int, size: wp.vec3, la: wp.vec3, lb: wp.vec3):
    """The parameter t in [0, 1] of the point of the segment la-lb (the shape's frame) deepest
    in a box or cylinder (`_signed_distance`, convex along the segment): golden section, one new
    distance per step, the interval shrinking to 6e-5."""
    lo = float(0.0)
    hi = float(1.0)
    m1 = hi - GOLDEN * (hi - lo)
    m2 = lo + GOLDEN * (hi - lo)
    f1 = _signed_distance(kind, size, la + (lb - la) * m1)
    f2 = _signed_distance(kind, size, la + (lb - la) * m2)
    for it in range(20):
        if f1 < f2:
            hi = m2
            m2 = m1
            f2 = f1
            m1 = hi - GOLDEN * (hi - lo)
            f1 = _signed_distance(kind, size, la + (lb - la) * m1)
        else:
            lo = m1
            m1 = m2
            f1 = f2
            m2 = lo + GOLDEN * (hi - lo)
            f2 = _signed_distance(kind, size, la + (lb - la) * m2)
    return 0.5 * (lo + hi)


@wp.func
def _sphere_box(c: wp.vec3, r: float, x: wp.transform, half: wp.vec3):
    """(normal from sphere to box, signed distance, midpoint) of a sphere and a box."""
    local = wp.transform_point(wp.transform_inverse(x), c)
    clamped = wp.vec3(wp.clamp(local[0], -half[0], half[0]), wp.clamp(local[1], -half[1], half[1]),
                      wp.clamp(local[2], -half[2], half[2]))
    if wp.length_sq(local - clamped) > 1.0e-12:
        b = wp.transform_point(x, clamped)
        gap = wp.length(b - c)
        n = (b - c) / gap
        return n, gap - r, 0.5 * (c + n * r + b)
    # center inside: leave through the nearest face
    axis = int(0)
    depth = half[0] - wp.abs(local[0])
    for k in range(1, 3):
        dk = half[k] - wp.abs(local[k])
        if dk < depth:
            depth = dk
            axis = k
    out = wp.vec3()
    out[axis] = wp.sign(local[axis])
    if out[axis] == 0.0:
        out[axis] = 1.0
    u = wp.quat_rotate(wp.transform_get_rotation(x), out)
    b = c + u * depth
    return -u, -(depth + r), 0.5 * (c - u * r + b)


@wp.func
def _clip(poly: poly8, count: int, axis: int, sign: float, limit: float):
    """Sutherland-Hodgman: keep the part of the polygon where sign·p[axis] <= limit."""
    out = poly8()
    n = int(0)
    for i in range(count):
        j = (i + 1) % count
        a = poly[i]
        b = poly[j]
        da = sign * a[axis] - limit
        db = sign * b[axis] - limit
        if da <= 0.0:
            out[n] = a
            n += 1
        if (da < 0.0 and db > 0.0) or (da > 0.0 and db < 0.0):
            out[n] = a + (b - a) * (da / (da - db))
            n += 1
    return out, n


@wp.func
def _box_axis(r: wp.mat33, k: int):
    return wp.vec3(r[0, k], r[1, k], r[2, k])


@wp.func
def _face_contacts(e: int, pair: wp.vec2i, key: int, ref_x: wp.transform, ref_half: wp.vec3,
                   ref_axis: int, n: wp.vec3, inc_x: wp.transform, inc_half: wp.vec3,
                   flip: float, margin: float, out: ContactSlots):
    """Contacts of a reference box face (outward normal n) and the incident box's face.

    The incident face is clipped to the reference face's rectangle; its points below the offset
    become contacts (at most four, spread out). `flip` orients the reported normal from geom 1.
    """
    rr = wp.quat_to_matrix(wp.transform_get_rotation(ref_x))
    ri = wp.quat_to_matrix(wp.transform_get_rotation(inc_x))
    # reference face frame: center, in-plane axes u (extent hu) and v (extent hv)
    ua = (ref_axis + 1) % 3
    va = (ref_axis + 2) % 3
    u = _box_axis(rr, ua)
    v = _box_axis(rr, va)
    center = wp.transform_get_translation(ref_x) + n * ref_half[ref_axis]
    # incident face: the face of the other box most opposed to n
    best = int(0)
    best_dot = float(1.0e9)
    for k in range(3):
        d = wp.dot(_box_axis(ri, k), n)
        if d < best_dot:
            best_dot = d
            best = k
        if -d < best_dot:
            best_dot = -d
            best = k + 3
    k = best % 3
    sgn = 1.0
    if best >= 3:
        sgn = -1.0
    face_n = _box_axis(ri, k) * sgn
    a1 = (k + 1) % 3
    a2 = (k + 2) % 3
    fc = wp.transform_get_translation(inc_x) + face_n * inc_half[k]
    e1 = _box_axis(ri, a1) * inc_half[a1]
    e2 = _box_axis(ri, a2) * inc_half[a2]
    poly = poly8()
    for i in range(4):
        s1 = 1.0
        s2 = 1.0
        if i == 1 or i == 2:
            s1 = -1.0
        if i >= 2:
            s2 = -1.0
        pt = fc + e1 * s1 + e2 * s2 - center
        poly[i] = wp.vec3(wp.dot(pt, u), wp.dot(pt, v), wp.dot(pt, n))
    npts = int(4)
    poly, npts = _clip(poly, npts, 0, 1.0, ref_half[ua])
    poly, npts = _clip(poly, npts, 0, -1.0, ref_half[ua])
    poly, npts = _clip(poly, npts, 1, 1.0, ref_half[va])
    poly, npts = _clip(poly, npts, 1, -1.0, ref_half[va])
    # keep at most four points below the offset: the deepest, the farthest from it, then the
    # farthest on either side of the line through those two
    chosen = wp.vec4i(-1, -1, -1, -1)
    for i in range(npts):
        if poly[i][2] < margin:
            if chosen[0] < 0 or poly[i][2] < poly[chosen[0]][2]:
                chosen[0] = i
    if chosen[0] >= 0:
        p0 = poly[chosen[0]]
        far = float(-1.0)
        for i in range(npts):
            if poly[i][2] < margin:
                d = (poly[i][0] - p0[0]) * (poly[i][0] - p0[0]) + (poly[i][1] - p0[1]) * (poly[i][1] - p0[1])
                if d > far and i != chosen[0]:
                    far = d
                    chosen[1] = i
        if chosen[1] >= 0:
            p1 = poly[chosen[1]]
            lo = float(0.0)
            hi = float(0.0)
            for i in range(npts):
                if poly[i][2] < margin and i != chosen[0] and i != chosen[1]:
                    side = (p1[0] - p0[0]) * (poly[i][1] - p0[1]) - (p1[1] - p0[1]) * (poly[i][0] - p0[0])
                    if side > hi:
                        hi = side
                        chosen[2] = i
                    if side < lo:
                        lo = side
                        chosen[3] = i
        for c in range(4):
            i = chosen[c]
            if i >= 0:
                pt = poly[i]
                world = center + u * pt[0] + v * pt[1] + n * pt[2]
                # identity across substeps: the quadrant of the reference face it lies in
                quadrant = int(0)
                if pt[0] > 0.0:
                    quadrant += 1
                if pt[1] > 0.0:
                    quadrant += 2
                _emit(e, pair, key + quadrant, world - n * (0.5 * pt[2]), n * flip, pt[2], margin,
                      out)


@wp.func
def _box_box(e: int, pair: wp.vec2i, key: int, x1: wp.transform, h1: wp.vec3, x2: wp.transform,
             h2: wp.vec3, margin: float, out: ContactSlots):
    """Separating-axis test over the 15 axes, then face clipping or the closest edge points."""
    r1 = wp.quat_to_matrix(wp.transform_get_rotation(x1))
    r2 = wp.quat_to_matrix(wp.transform_get_rotation(x2))
    d = wp.transform_get_translation(x2) - wp.transform_get_translation(x1)
    best_sep = float(-1.0e9)
    best_axis = int(-1)
    best_n = wp.vec3()
    for a in range(15):
        axis = wp.vec3()
        if a < 3:
            axis = _box_axis(r1, a)
        elif a < 6:
            axis = _box_axis(r2, a - 3)
        else:
            axis = wp.cross(_box_axis(r1, (a - 6) // 3), _box_axis(r2, (a - 6) % 3))
            length = wp.length(axis)
            if length < 1.0e-6:
                continue  # parallel edges: covered by the face axes
            axis = axis / length
        if wp.dot(axis, d) < 0.0:
            axis = -axis
        reach = float(0.0)
        for k in range(3):
            reach = reach + h1[k] * wp.abs(wp.dot(_box_axis(r1, k), axis))
            reach = reach + h2[k] * wp.abs(wp.dot(_box_axis(r2, k), axis))
        sep = wp.dot(d, axis) - reach
        if sep > margin:
            return  # separated beyond the offset
        # ties go to box 1's faces, then box 2's, then edges, so that the choice (and with it
        # the contacts' identities) does not flicker between substeps; faces give stable
        # multi-point contact, so an edge axis must win clearly
        if a >= 6:
            sep = sep - 1.0e-4
        elif a >= 3:
            sep = sep - 1.0e-5
        if sep > best_sep:
            best_sep = sep
            best_axis = a
            best_n = axis
    if best_axis < 3:
        _face_contacts(e, pair, key, x1, h1, best_axis, best_n, x2, h2, 1.0, margin, out)
    elif best_axis < 6:
        _face_contacts(e, pair, key, x2, h2, best_axis - 3, -best_n, x1, h1, -1.0, margin,
                       out)
    else:
        # edge-edge: the supporting edge of each box along the axis, closest points between them
        i1 = (best_axis - 6) // 3
        i2 = (best_axis - 6) % 3
        p1 = wp.transform_get_translation(x1)
        p2 = wp.transform_get_translation(x2)
        for k in range(3):
            if k != i1:
                ax = _box_axis(r1, k)
                p1 = p1 + ax * (h1[k] * wp.sign(wp.dot(ax, best_n) + 1.0e-12))
            if k != i2:
                ax = _box_axis(r2, k)
                p2 = p2 - ax * (h2[k] * wp.sign(wp.dot(ax, best_n) + 1.0e-12))
        a1 = _box_axis(r1, i1) * h1[i1]
        a2 = _box_axis(r2, i2) * h2[i2]
        st = _closest_between_segments(p1 - a1, p1 + a1, p2 - a2, p2 + a2)
        q1 = p1 - a1 + a1 * (2.0 * st[0])
        q2 = p2 - a2 + a2 * (2.0 * st[1])
        dist = wp.dot(q2 - q1, best_n)
        _emit(e, pair, key, 0.5 * (q1 + q2), best_n, dist, margin, out)


@wp.func
def _capsule_box(e: int, pair: wp.vec2i, key: int, x1: wp.transform, s1: wp.vec3,
                 x2: wp.transform, h2: wp.vec3, margin: float, out: ContactSlots):
    """Both end spheres, plus the segment's closest point when it lies between the ends.

    The signed distance from the segment to the box is convex along the segment: a golden-section
    search finds its minimum (the deepest point when the segment enters the box). A capsule
    lying on a face touches at its two ends (a stable pair of contacts). Distances are taken in
    the box's frame; since the distance is 1-Lipschitz, a segment of length L whose ends lie at
    d_a and d_b from the box comes no closer than (d_a + d_b - L) / 2 anywhere, and then the
    search is skipped (most candidate pairs of a hand: fingers near the cube, not on it).
    """
    a = _segment(x1, s1[1], -1.0)
    b = _segment(x1, s1[1], 1.0)
    to_box = wp.transform_inverse(x2)
    la = wp.transform_point(to_box, a)
    lb = wp.transform_point(to_box, b)
    reach = s1[0] + margin
    da = _local_box_distance(h2, la)
    db = _local_box_distance(h2, lb)
    if da < reach:
        n, dist, pos = _sphere_box(a, s1[0], x2, h2)
        _emit(e, pair, key, pos, n, dist, margin, out)
    if db < reach:
        n, dist, pos = _sphere_box(b, s1[0], x2, h2)
        _emit(e, pair, key + 1, pos, n, dist, margin, out)
    if da + db - 2.0 * s1[1] >= 2.0 * reach:
        return
    t = _deepest_on_segment(BOX, h2, la, lb)
    if t > 0.02 and t < 0.98:
        n, dist, pos = _sphere_box(a + (b - a) * t, s1[0], x2, h2)
        _emit(e, pair, key + 2, pos, n, dist, margin, out)


@wp.func
def _convex(e: int, pair: wp.vec2i, key: int, t1_type: int, s1: wp.vec3, m1: int,
            x1: wp.transform, t2_type: int, s2: wp.vec3, m2: int, x2: wp.transform, meshes: Meshes,
            margin: float, out: ContactSlots):
    hit, n, dist, pos = convex_contact(t1_type, s1, m1, x1, t2_type, s2, m2, x2, meshes, margin)
    if hit == 0 or dist >= margin:
        return
    _emit(e, pair, key, pos, n, dist, margin, out)
    # a face resting on a face needs more than one point, or it turns on it (a mesh cube on a
    # mesh slab crept 12 mm in 5 s): the corners of each shape's contact face, found as its
    # support points along the normal tilted four ways, each kept where it lies within the
    # other shape's reach and below the offset from the other's face (most pairs touch at a
    # corner or an edge, and give the same point back, or one outside)
    t1, t2 = tangents(n)
    face1 = wp.dot(support(t1_type, s1, m1, meshes, x1, n, 0.0), n)
    face2 = wp.dot(support(t2_type, s2, m2, meshes, x2, -n, 0.0), n)
    kept = mat43()
    nkept = int(0)
    for k in range(8):
        # diagonal tilts, so that an axis-aligned face gives its four corners
        s_a = 1.0 - 2.0 * float(k % 2)
        s_b = 1.0 - 2.0 * float((k / 2) % 2)
        tilt = (t1 * s_a + t2 * s_b) * FACE_TILT
        side = k / 4          # 0: shape 2's corners on shape 1's face; 1: shape 1's on 2's
        corner = wp.vec3()
        gap = float(0.0)
        if side == 0:
            corner = support(t2_type, s2, m2, meshes, x2, tilt - n, 0.0)
            gap = wp.dot(corner, n) - face1
        else:
            corner = support(t1_type, s1, m1, meshes, x1, n + tilt, 0.0)
            gap = face2 - wp.dot(corner, n)
        if gap >= margin or gap < dist - FACE_SPACING:
            continue          # beyond the offset, or deeper than the shapes overlap (a corner
                              # beside the other's face, under the plane of its extent)
        lateral = (corner - pos) - n * wp.dot(corner - pos, n)
        reach = wp.length(lateral)
        if reach < FACE_SPACING:
            continue          # the contact already found
        u = lateral / reach
        other = wp.vec3()
        if side == 0:
            other = support(t1_type, s1, m1, meshes, x1, u, 0.0)
        else:
            other = support(t2_type, s2, m2, meshes, x2, u, 0.0)
        if wp.dot(other - pos, u) < reach:
            continue          # beyond the other shape's face
        fresh = int(1)
        for j in range(nkept):
            if wp.length(kept[j] - corner) < FACE_SPACING:
                fresh = 0
        if fresh == 0 or nkept == 4:
            continue
        kept[nkept] = corner
        nkept += 1
        at = corner - n * (0.5 * gap)
        if side == 1:
            at = corner + n * (0.5 * gap)
        _emit(e, pair, key + 1 + k, at, n, gap, margin, out)


@wp.func
def _plane_cylinder(e: int, pair: wp.vec2i, key: int, c1: wp.vec3, n: wp.vec3, x2: wp.transform,
                    s2: wp.vec3, margin: float, out: ContactSlots):
    """The lower cap's rim at four points a quarter turn apart, starting from its lowest point,
    and the other cap's lowest rim point: a cylinder standing or lying gets a stable support.

    Standing on a cap within 0.01 rad of upright, the rim points are fixed to the body instead
    (its x axis first): there the direction of the lowest point is noise, and rim points that
    turned with it from substep to substep took their warm starts to other places on the rim
    and kept a resting cylinder rocking. The rim then lies within 0.01 · radius of the plane
    all round."""
    rot = wp.transform_get_rotation(x2)
    axis = wp.quat_rotate(rot, wp.vec3(0.0, 0.0, 1.0))
    center = wp.transform_get_translation(x2)
    # direction, in the cap plane, toward the plane (down the normal); its length is the sine
    # of the tilt
    down = -n - axis * wp.dot(-n, axis)
    if wp.length_sq(down) < 1.0e-4:
        down = wp.quat_rotate(rot, wp.vec3(1.0, 0.0, 0.0))
    down = wp.normalize(down)
    side = wp.cross(axis, down)
    lower = 1.0
    if wp.dot(axis, n) > 0.0:
        lower = -1.0
    for k in range(5):
        cap = center + axis * (lower * s2[1])
        rim = down
        if k == 1:
            rim = side
        elif k == 2:
            rim = -down
        elif k == 3:
            rim = -side
        elif k == 4:
            cap = center - axis * (lower * s2[1])
        point = cap + rim * s2[0]
        dist = wp.dot(point - c1, n)
        _emit(e, pair, key + k, point - n * (0.5 * dist), n, dist, margin, out)


@wp.func
def _farthest_in_plane(origin: int, c1: wp.vec3, n: wp.vec3, x2: wp.transform, beg: int,
                       num: int, meshes: Meshes, margin: float):
    """The hull vertex within the offset farthest from vertex `origin` along the plane (-1 if
    there is none but it)."""
    p0 = wp.transform_point(x2, meshes.vert[origin])
    far = float(-1.0)
    found = int(-1)
    for i in range(beg, beg + num):
        q = wp.transform_point(x2, meshes.vert[i])
        if wp.dot(q - c1, n) < margin and i != origin:
            d = wp.length_sq(q - p0 - n * wp.dot(q - p0, n))
            if d > far + 1.0e-12:
                far = d
                found = i
    return found


@wp.func
def _plane_mesh(e: int, pair: wp.vec2i, key: int, c1: wp.vec3, n: wp.vec3, x2: wp.transform,
                mesh: int, meshes: Meshes, margin: float, out: ContactSlots):
    """Hull vertices within the offset, at most four: the two farthest apart along the plane
    (the one farthest from the deepest, then the one farthest from that) and the farthest on
    either side of the line through those two. Not the deepest itself: on a flat sole any of
    its vertices is the deepest by a hair, a different one as the foot rocks, and four points
    built from it (the deepest, the farthest from it, ...) jumped with it from step to step;
    the H1's walking policy, whose feet are such a mesh, swayed three times as much as in
    MuJoCo under legged_gym's settings (docs/results.md, unitree_rl_gym)."""
    beg = meshes.vertadr[mesh]
    num = meshes.vertnum[mesh]
    chosen = wp.vec4i(-1, -1, -1, -1)
    deepest = int(-1)
    low = float(margin)
    for i in range(beg, beg + num):
        d = wp.dot(wp.transform_point(x2, meshes.vert[i]) - c1, n)
        if d < low:
            low = d
            deepest = i
    if deepest < 0:
        return
    chosen[0] = _farthest_in_plane(deepest, c1, n, x2, beg, num, meshes, margin)
    if chosen[0] < 0:       # the only vertex within the offset
        chosen[0] = deepest
    else:
        chosen[1] = _farthest_in_plane(chosen[0], c1, n, x2, beg, num, meshes, margin)
        p0 = wp.transform_point(x2, meshes.vert[chosen[0]])
        p1 = wp.transform_point(x2, meshes.vert[chosen[1]])
        lo = float(-1.0e-12)
        hi = float(1.0e-12)
        for i in range(beg, beg + num):
            q = wp.transform_point(x2, meshes.vert[i])
            if wp.dot(q - c1, n) < margin and i != chosen[0] and i != chosen[1]:
                side = wp.dot(wp.cross(p1 - p0, q - p0), n)
                if side > hi:
                    hi = side
                    chosen[2] = i
                if side < lo:
                    lo = side
                    chosen[3] = i
    for which in range(4):
        i = chosen[which]
        if i >= 0:
            q = wp.transform_point(x2, meshes.vert[i])
            dist = wp.dot(q - c1, n)
            _emit(e, pair, key + which, q - n * (0.5 * dist), n, dist, margin, out)


@wp.func
def _trimesh(e: int, pair: wp.vec2i, key: int, x1: wp.transform, m1: int, t2: int,
             x2: wp.transform, s2: wp.vec3, m2: int, meshes: Meshes, margin: float,
             out: ContactSlots):
    """Contacts of a shape (type t2) with a static triangle mesh (see trimesh): its probe
    points against the surface; a round probe's other faces; a cylinder's lowest rim points;
    the mesh's ridges that reach into a box, capsule, cylinder, convex mesh or ellipsoid. At most
    TRIMESH_EDGES contacts past the probes'. Keys: a probe's index (0..31; an ellipsoid's
    support point 0), then 16 + (its face, or its edge's two vertices) mod 16 (a cylinder: 16,
    17 for its rims, 18 + ... mod 14 after them), so that a contact keeps its key, and its
    friction anchors, from one substep to the next whatever else the mesh finds (a convex
    mesh of more than 16 vertices shares keys 16..31 between probes and edges: a shared key's
    anchors are a guess, `constraints`)."""
    bvh = meshes.bvh[m1]
    size = bounding_radius(t2, s2, m2, meshes)
    c2 = wp.transform_get_translation(x2)
    # the broadphase: no face in the box round the shape's bounding sphere (in the mesh's
    # frame), no contact; one walk down the BVH instead of a query per probe (terrain holds
    # a robot's every link, most of them far above it)
    rot1 = wp.transform_get_rotation(x1)
    inv1 = wp.transform_inverse(x1)
    centre = wp.transform_point(inv1, c2)
    bound = wp.vec3(size + margin, size + margin, size + margin)
    near = wp.mesh_query_aabb(bvh, centre - bound, centre + bound)
    first = int(0)
    if not wp.mesh_query_aabb_next(near, first):
        return
    extra = int(0)
    if t2 == ELLIPSOID:
        # its point deepest along the normal at the closest point to its center
        found, n, dist, face = surface_point(bvh, x1, c2, size + margin)
        if found != 0:
            point = support(t2, s2, -1, meshes, x2, -n, 0.0)
            found, n, dist, face = surface_point(bvh, x1, point, size + margin)
            if found != 0:
                _emit(e, pair, key, point - n * (0.5 * dist), n, dist, margin, out)
    else:
        for k in range(HFIELD_PROBES):
            valid, point, radius = probe_point(t2, s2, m2, meshes, x2, k)
            if valid != 0:
                # a point behind a face by more than the shape's size is taken to be beyond it
                found, n, dist, face = surface_point(bvh, x1, point,
                                                     radius + wp.max(margin, size))
                if found != 0:
                    dist -= radius
                    _emit(e, pair, key + k, point - n * (radius + 0.5 * dist), n, dist, margin,
                          out)
                if radius > 0.0:
                    # the other faces whose prisms hold the point within its radius: the second
                    # side of a crease (each face once: coplanar neighbours share their edge).
                    # A face the point is behind counts only when the point is inside: outside,
                    # it is the back of a fold (a fin's other face), not a side it presses on
                    behind = -size
                    if found != 0 and dist + radius >= 0.0:
                        behind = 0.0
                    local = wp.transform_point(inv1, point)
                    reach = wp.vec3(radius + margin, radius + margin, radius + margin)
                    query = wp.mesh_query_aabb(bvh, local - reach, local + reach)
                    other = int(0)
                    kept_n = wp.quat_rotate_inv(rot1, n)
                    while extra < TRIMESH_EDGES and wp.mesh_query_aabb_next(query, other):
                        if other != face:
                            inside, fn, height = face_plane(bvh, other, local)
                            gap = height - radius
                            if inside != 0 and gap < margin and height > behind \
                                    and wp.dot(fn, kept_n) < 0.999:
                                normal = wp.quat_rotate(rot1, fn)
                                _emit(e, pair, key + 16 + other % 16,
                                      point - normal * (radius + 0.5 * gap), normal, gap, margin,
                                      out)
                                extra += 1
    edge_keys = int(16)
    if t2 == CYLINDER:
        # a cylinder lying on its side touches along a line between its rims' lowest points,
        # which its 16 rim probes miss by up to r·(1 - cos 22.5°): each rim's point deepest
        # along the normal at the closest point to its center
        edge_keys = 18
        found, n, dist, face = surface_point(bvh, x1, c2, size + margin)
        if found != 0:
            axis = wp.quat_rotate(wp.transform_get_rotation(x2), wp.vec3(0.0, 0.0, 1.0))
            down = -n - axis * wp.dot(-n, axis)
            if wp.length(down) > 1.0e-6:
                down = wp.normalize(down) * s2[0]
                for side in range(2):
                    point = c2 + axis * (s2[1] * (2.0 * float(side) - 1.0)) + down
                    hit, normal, gap, face = surface_point(bvh, x1, point, size + margin)
                    if hit != 0:
                        _emit(e, pair, key + 16 + side, point - normal * (0.5 * gap), normal,
                              gap, margin, out)
    if t2 == SPHERE:
        return          # its closest point is exact
    # the mesh's ridges near the shape (edges whose faces bend away: on a flat run of triangles
    # the probes see all there is), each once (`ridge_edges` marks it in one of its faces)
    inv2 = wp.transform_inverse(x2)
    query = wp.mesh_query_aabb(bvh, centre - bound, centre + bound)
    face = int(0)
    while extra < TRIMESH_EDGES and wp.mesh_query_aabb_next(query, face):
        ridges = meshes.ridge[meshes.ridgeadr[m1] + face]
        for j in range(3):
            ia = 3 * face + j
            ib = 3 * face + (j + 1) % 3
            if extra < TRIMESH_EDGES and (ridges >> j) & 1 != 0:
                a = wp.transform_point(x1, wp.mesh_get_point(bvh, ia))
                b = wp.transform_point(x1, wp.mesh_get_point(bvh, ib))
                n = wp.vec3()
                dist = float(0.0)
                pos = wp.vec3()
                if t2 == CAPSULE:
                    p2 = _segment(x2, s2[1], -1.0)
                    q2 = _segment(x2, s2[1], 1.0)
                    st = _closest_between_segments(a, b, p2, q2)
                    on_edge = a + (b - a) * st[0]
                    n, dist, pos = _spheres(on_edge, 0.0, p2 + (q2 - p2) * st[1], s2[0])
                elif t2 == MESH or t2 == ELLIPSOID:
                    # the edge as a capsule of radius 0 against the shape (GJK apart, EPA
                    # overlapping): it sees an edge under a convex mesh's face between the
                    # hull's vertices, where its probes are, and one into an ellipsoid's side,
                    # away from its one probe
                    length = wp.length(b - a)
                    dist = margin
                    near_edge = wp.length(c2 - _closest_on_segment(a, b, c2)) < size + margin
                    if length > 1.0e-9 and near_edge:      # (GJK only where it can touch)
                        along = wp.quat_between_vectors(wp.vec3(0.0, 0.0, 1.0), (b - a) / length)
                        hit, hn, hd, hp = convex_contact(
                            CAPSULE, wp.vec3(0.0, 0.5 * length, 0.0), -1,
                            wp.transform(0.5 * (a + b), along), t2, s2, m2, x2, meshes, margin)
                        if hit != 0:
                            n = hn
                            dist = hd
                            pos = hp
                else:
                    # a box or a cylinder: the edge's deepest point in it
                    la = wp.transform_point(inv2, a)
                    lb = wp.transform_point(inv2, b)
                    at = la + (lb - la) * _deepest_on_segment(t2, s2, la, lb)
                    dist, out_n = _distance_and_normal(t2, s2, at)
                    n = -wp.quat_rotate(wp.transform_get_rotation(x2), out_n)
                    pos = wp.transform_point(x2, at) + n * (0.5 * dist)
                if dist < margin:
                    edge = wp.mesh_get_index(bvh, ia) * 7 + wp.mesh_get_index(bvh, ib)
                    _emit(e, pair, key + edge_keys + edge % (32 - edge_keys), pos, n, dist,
                          margin, out)
                    extra += 1


@wp.kernel
def geom_frames(m: ModelArrays, p: EnvParams, meshes: Meshes,
                s: State):   # in: body_x; out: geom_x, geom_bound
    """Each geom's pose in the world, and its bounding sphere for the broadphase (the pair test
    then reads 4 floats per geom instead of a pose, a size and a shape's radius)."""
    e, g = wp.tid()
    x = geom_frame(m, p, s, e, g)
    s.geom_x[e, g] = x
    t = m.geom_type[g]
    radius = float(0.0)
    if t != PLANE and t != HFIELD:
        radius = bounding_radius(t, p.geom_size[e, g], m.geom_dataid[g], meshes)
    center = wp.transform_get_translation(x)
    s.geom_bound[e, g] = wp.vec4(center[0], center[1], center[2], radius)


@wp.kernel
def narrowphase(m: ModelArrays, opt: Options, pairs: wp.array(dtype=wp.vec2i), p: EnvParams,
                meshes: Meshes, hfields: HFields,
                s: State,       # in: geom_x, geom_bound
                contacts: Contacts):   # in: count (zero); out: count, geom, key, pos, normal, dist
    """One thread per (env, candidate pair): the launch for a GPU."""
    e, k = wp.tid()
    _pair(m, e, k, pairs, p, meshes, hfields, opt.contact_offset, s, contact_slots(contacts))


@wp.kernel
def narrowphase_per_env(m: ModelArrays, opt: Options, pairs: wp.array(dtype=wp.vec2i),
                        p: EnvParams, meshes: Meshes, hfields: HFields, s: State,
                        contacts: Contacts):
    """One thread per env, walking its candidate pairs in order: the launch for a CPU, where a
    thread's start (reading the kernel's arguments) costs more than most pairs' broadphase test.
    Contacts land in the same slots as with `narrowphase` run on a CPU."""
    e = wp.tid()
    out = contact_slots(contacts)
    margin = opt.contact_offset
    for k in range(pairs.shape[0]):
        _pair(m, e, k, pairs, p, meshes, hfields, margin, s, out)


@wp.kernel
def redo_overflowed(m: ModelArrays, opt: Options, pairs: wp.array(dtype=wp.vec2i), p: EnvParams,
                    meshes: Meshes, hfields: HFields, s: State, contacts: Contacts):
    """An env whose contacts overflowed its places under `narrowphase` is found again by one
    thread walking its pairs in order, as `narrowphase_per_env` does: which contacts an
    overflow dropped then follows the pairs' order, not which threads' atomics came first.
    Envs within their places return at once (their contacts are put in order by
    `order_by_pair`); an overflow is rare, and the walk costs only the envs that need it."""
    e = wp.tid()
    if contacts.count[e] <= contacts.geom.shape[1]:
        return
    contacts.count[e] = 0
    out = contact_slots(contacts)
    margin = opt.contact_offset
    for k in range(pairs.shape[0]):
        _pair(m, e, k, pairs, p, meshes, hfields, margin, s, out)


@wp.kernel
def order_by_pair(c: Contacts):   # in: count, the narrowphase's places; out: the same, reordered
    """An env's contacts in the order of their candidate pairs, each pair's in the order found:
    the order `narrowphase_per_env` gives. The GPU's thread per (env, pair) takes places through
    an atomic counter, so pairs' contacts interleave, in an order that changes every substep;
    the solver's patches (runs of one pair's contacts) then broke up, and the Panda's fingers let
    a held cube slip 7 mm in a lift and turn on an H200 (0.05 mm on a CPU). A stable insertion
    sort on the pair index (a key's bits above the pair's 32 features): one thread's places rise,
    so each pair's own order is kept, and the result is the CPU's, contact for contact."""
    e = wp.tid()
    found = wp.min(c.count[e], c.geom.shape[1])
    for i in range(1, found):
        key = c.key[e, i]
        j = i
        while j > 0 and (c.key[e, j - 1] >> 5) > (key >> 5):
            j -= 1
        if j < i:
            geom = c.geom[e, i]
            pos = c.pos[e, i]
            normal = c.normal[e, i]
            dist = c.dist[e, i]
            for k in range(i, j, -1):
                c.geom[e, k] = c.geom[e, k - 1]
                c.key[e, k] = c.key[e, k - 1]
                c.pos[e, k] = c.pos[e, k - 1]
                c.normal[e, k] = c.normal[e, k - 1]
                c.dist[e, k] = c.dist[e, k - 1]
            c.geom[e, j] = geom
            c.key[e, j] = key
            c.pos[e, j] = pos
            c.normal[e, j] = normal
            c.dist[e, j] = dist


@wp.kernel
def keep_deepest(c: Contacts):   # in: count, the narrowphase's places; out: the first slots
    """An env that found more contacts than its slots keeps the deepest, in the order found (a
    pair's contacts stay together, as the solver's patches need); ties go to the first found.
    Two passes, so that the second can compact in place: the last kept contact's (distance,
    place), then the copy of every contact at or before it in that order."""
    e = wp.tid()
    slots = c.force.shape[1]
    found = wp.min(c.count[e], c.geom.shape[1])
    if found <= slots:
        return
    edge = float(0.0)
    edge_at = int(-1)
    for i in range(found):
        di = c.dist[e, i]
        ahead = int(0)      # contacts that come before i in (distance, place) order
        for j in range(found):
            dj = c.dist[e, j]
            if dj < di or (dj == di and j < i):
                ahead += 1
        if ahead == slots - 1:
            edge = di
            edge_at = i
            break
    kept = int(0)
    for i in range(found):
        di = c.dist[e, i]
        if di < edge or (di == edge and i <= edge_at):
            c.geom[e, kept] = c.geom[e, i]
            c.key[e, kept] = c.key[e, i]
            c.pos[e, kept] = c.pos[e, i]
            c.normal[e, kept] = c.normal[e, i]
            c.dist[e, kept] = di
            kept += 1


@wp.func
def _pair(m: ModelArrays, e: int, k: int, pairs: wp.array(dtype=wp.vec2i), p: EnvParams,
          meshes: Meshes, hfields: HFields, margin: float, s: State, out: ContactSlots):
    """Candidate pair k of env e: the broadphase test, then the pair's contacts."""
    pair = pairs[k]
    g1 = pair[0]
    g2 = pair[1]
    t1 = m.geom_type[g1]
    t2 = m.geom_type[g2]
    # broadphase: shapes whose bounding spheres are farther apart than the contact offset
    # cannot touch, nor can a shape whose bounding sphere lies farther above a plane (pairs are
    # ordered by type: planes and height fields come first). The pair tests are in a function
    # of their own, so that a skipped pair costs only these few locals.
    b1 = s.geom_bound[e, g1]
    b2 = s.geom_bound[e, g2]
    offset = wp.vec3(b2[0] - b1[0], b2[1] - b1[1], b2[2] - b1[2])
    if t1 == PLANE:
        if t2 != PLANE and t2 != HFIELD:
            up = wp.quat_rotate(wp.transform_get_rotation(s.geom_x[e, g1]),
                                wp.vec3(0.0, 0.0, 1.0))
            if wp.dot(offset, up) > b2[3] + margin:
                return
    elif t1 == TRIMESH:
        # the other's bounding sphere against the box round the mesh, in the mesh's frame
        x1 = s.geom_x[e, g1]
        local = wp.transform_point(wp.transform_inverse(x1), wp.vec3(b2[0], b2[1], b2[2]))
        d = local - meshes.box_center[m.geom_dataid[g1]]
        half = meshes.box_half[m.geom_dataid[g1]]
        for i in range(3):
            if wp.abs(d[i]) > half[i] + b2[3] + margin:
                return
    elif t1 != HFIELD:
        reach = b1[3] + b2[3] + margin
        if wp.length_sq(offset) > reach * reach:
            return
        if t1 == MESH or t2 == MESH:
            # a mesh's sphere holds much air round a long link: its box first (a few dot
            # products against GJK's support scans)
            c1, h1 = bounding_box(t1, p.geom_size[e, g1], m.geom_dataid[g1], meshes)
            c2, h2 = bounding_box(t2, p.geom_size[e, g2], m.geom_dataid[g2], meshes)
            if boxes_apart(s.geom_x[e, g1], c1, h1, s.geom_x[e, g2], c2, h2, margin):
                return
    if _primitives(t1, t2):
        _collide_primitives(e, k, pair, t1, t2, s.geom_x[e, g1], s.geom_x[e, g2],
                            p.geom_size[e, g1], p.geom_size[e, g2], margin, out)
    else:
        _collide_pair(e, k, pair, t1, t2, s.geom_x[e, g1], s.geom_x[e, g2], p.geom_size[e, g1],
                      p.geom_size[e, g2], m.geom_dataid, meshes, hfields, margin, out)


def most_contacts(t1: int, t2: int) -> int:
    """The most contacts the pair tests (`_collide_primitives`, `_collide_pair`) emit for one
    pair of geom types (t1 <= t2 in the pairs' order: a static triangle mesh first), read off
    their branches below; keep them in step.
    A model's contact slots never need more than the sum of this over its candidate pairs
    (`contact_bound`)."""
    if t1 == GeomType.PLANE:
        return {GeomType.SPHERE: 1, GeomType.CAPSULE: 2, GeomType.BOX: 4, GeomType.ELLIPSOID: 1,
                GeomType.CYLINDER: 5, GeomType.MESH: 4}.get(GeomType(t2), 0)
    if t1 == GeomType.HFIELD:
        # one floor contact per probe and, for round probes, one riser wall each
        return 1 if t2 == GeomType.ELLIPSOID else 2 * int(HFIELD_PROBES)
    if t1 == GeomType.TRIMESH:
        # an ellipsoid's support point or the probes, a cylinder's two rim points, the extras
        return (1 if t2 == GeomType.ELLIPSOID else int(HFIELD_PROBES) + 2) + int(TRIMESH_EDGES)
    if t1 == GeomType.SPHERE and t2 in (GeomType.SPHERE, GeomType.CAPSULE, GeomType.BOX):
        return 1
    if t1 == GeomType.CAPSULE and t2 == GeomType.CAPSULE:
        return 1
    if t1 == GeomType.CAPSULE and t2 == GeomType.BOX:
        return 3            # the two end spheres and the segment's deepest point
    if t1 == GeomType.BOX and t2 == GeomType.BOX:
        return 4            # a clipped face's four kept points, or one edge-edge point
    return 5                # `_convex`: the closest points and up to four face corners


def contact_bound(geom_type, pairs) -> int:
    """The most contacts the candidate `pairs` [npair, 2] of geoms with types `geom_type` can
    produce in one env at once: slots past it can never be filled."""
    return sum(most_contacts(int(geom_type[g1]), int(geom_type[g2])) for g1, g2 in pairs)


@wp.func
def _primitives(t1: int, t2: int):
    """Whether a pair of geom types (t1 <= t2) has a closed-form test of its own (planes,
    spheres, capsules, boxes, a plane and a cylinder): `_collide_primitives`, a smaller function
    than `_collide_pair` that takes no mesh or height-field arrays (Warp passes structs by
    value; the pair loop's call cost half as much after the split: `docs/performance.md`)."""
    if t1 == PLANE:
        return t2 == SPHERE or t2 == CAPSULE or t2 == BOX or t2 == CYLINDER
    if t1 == SPHERE:
        return t2 == SPHERE or t2 == CAPSULE or t2 == BOX
    if t1 == CAPSULE:
        return t2 == CAPSULE or t2 == BOX
    return t1 == BOX and t2 == BOX


@wp.func
def _collide_primitives(e: int, p: int, pair: wp.vec2i, t1: int, t2: int, x1: wp.transform,
                        x2: wp.transform, s1: wp.vec3, s2: wp.vec3, margin: float,
                        out: ContactSlots):
    """Contacts of geoms pair[0], pair[1] (types t1 <= t2 that `_primitives` takes, poses x1, x2,
    sizes s1, s2) of env e, appended to its contact slots; p (the pair's index) makes their
    keys."""
    c1 = wp.transform_get_translation(x1)
    c2 = wp.transform_get_translation(x2)
    if t1 == PLANE:
        n = wp.quat_rotate(wp.transform_get_rotation(x1), wp.vec3(0.0, 0.0, 1.0))
        if t2 == SPHERE or t2 == CAPSULE:
            ends = 1
            if t2 == CAPSULE:
                ends = 2
            for k in range(ends):
                center = c2
                if t2 == CAPSULE:
                    center = _segment(x2, s2[1], 2.0 * float(k) - 1.0)
                dist = wp.dot(center - c1, n) - s2[0]
                _emit(e, pair, p * 32 + k, center - n * (s2[0] + 0.5 * dist), n, dist, margin,
                      out)
        elif t2 == BOX:
            # corners below the offset, at most four (a box resting on a face touches with four)
            found = int(0)
            for k in range(8):
                point = wp.transform_point(x2, box_corner(s2, k))
                dist = wp.dot(point - c1, n)
                if dist < margin and found < 4:
                    found += 1
                    _emit(e, pair, p * 32 + k, point - n * (0.5 * dist), n, dist, margin, out)
        else:   # CYLINDER
            _plane_cylinder(e, pair, p * 32, c1, n, x2, s2, margin, out)
    elif t1 == SPHERE:
        if t2 == SPHERE or t2 == CAPSULE:
            other = c2
            if t2 == CAPSULE:
                other = _closest_on_segment(_segment(x2, s2[1], -1.0), _segment(x2, s2[1], 1.0), c1)
            n, dist, pos = _spheres(c1, s1[0], other, s2[0])
            _emit(e, pair, p * 32, pos, n, dist, margin, out)
        else:   # BOX
            n, dist, pos = _sphere_box(c1, s1[0], x2, s2)
            _emit(e, pair, p * 32, pos, n, dist, margin, out)
    elif t1 == CAPSULE and t2 == CAPSULE:
        a1 = _segment(x1, s1[1], -1.0)
        b1 = _segment(x1, s1[1], 1.0)
        a2 = _segment(x2, s2[1], -1.0)
        b2 = _segment(x2, s2[1], 1.0)
        st = _closest_between_segments(a1, b1, a2, b2)
        n, dist, pos = _spheres(a1 + (b1 - a1) * st[0], s1[0], a2 + (b2 - a2) * st[1], s2[0])
        _emit(e, pair, p * 32, pos, n, dist, margin, out)
    elif t1 == CAPSULE:     # and a BOX
        _capsule_box(e, pair, p * 32, x1, s1, x2, s2, margin, out)
    else:                   # BOX, BOX
        _box_box(e, pair, p * 32, x1, s1, x2, s2, margin, out)


@wp.func
def _collide_pair(e: int, p: int, pair: wp.vec2i, t1: int, t2: int, x1: wp.transform,
                  x2: wp.transform, s1: wp.vec3, s2: wp.vec3,
                  geom_dataid: wp.array(dtype=wp.int32), meshes: Meshes, hfields: HFields,
                  margin: float, out: ContactSlots):
    """Contacts of geoms pair[0], pair[1] (types t1 <= t2 that `_primitives` does not take:
    ellipsoids, meshes, height fields, triangle meshes, the general convex pairs; poses x1, x2,
    sizes s1, s2) of env e, appended to its contact slots; p (the pair's index) makes their
    keys."""
    g1 = pair[0]
    g2 = pair[1]
    c1 = wp.transform_get_translation(x1)
    if t1 == PLANE:
        n = wp.quat_rotate(wp.transform_get_rotation(x1), wp.vec3(0.0, 0.0, 1.0))
        if t2 == ELLIPSOID:
            point = support(t2, s2, -1, meshes, x2, -n, 0.0)
            dist = wp.dot(point - c1, n)
            _emit(e, pair, p * 32, point - n * (0.5 * dist), n, dist, margin, out)
        elif t2 == MESH:
            _plane_mesh(e, pair, p * 32, c1, n, x2, geom_dataid[g2], meshes, margin, out)
    elif t1 == HFIELD:
        h = geom_dataid[g1]
        if t2 == ELLIPSOID:
            point = ellipsoid_probe(hfields, h, x1, s2, meshes, x2)
            found, n, dist = surface(hfields, h, x1, point)
            if found != 0:
                _emit(e, pair, p * 32, point - n * (0.5 * dist), n, dist, margin, out)
        else:
            riser = hfields.riser[h]
            for k in range(HFIELD_PROBES):
                valid, point, radius = probe_point(t2, s2, geom_dataid[g2], meshes, x2, k)
                if valid != 0:
                    found, n, height = surface(hfields, h, x1, point)
                    if found != 0:
                        dist = height - radius
                        _emit(e, pair, p * 32 + k, point - n * (radius + 0.5 * dist), n, dist,
                              margin, out)
                    # a round probe also meets the nearest riser wall of its cell (radius 0:
                    # the floor alone, see heightfield); its key p * 32 + 16 + k stays apart
                    # from the floor's, as spheres and capsules have at most 3 probes
                    if riser > 0.0 and radius > 0.0:
                        wall, wn, gap = riser_contact(hfields, h, x1, point)
                        if wall != 0:
                            dist = gap - radius
                            _emit(e, pair, p * 32 + 16 + k, point - wn * (radius + 0.5 * dist),
                                  wn, dist, margin, out)
    elif t1 == TRIMESH:
        _trimesh(e, pair, p * 32, x1, geom_dataid[g1], t2, x2, s2, geom_dataid[g2], meshes,
                 margin, out)
    else:
        _convex(e, pair, p * 32, t1, s1, geom_dataid[g1], x1, t2, s2, geom_dataid[g2], x2, meshes,
                margin, out)
