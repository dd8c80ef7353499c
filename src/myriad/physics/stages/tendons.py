"""Spatial tendons: each path's length and its derivative by every dof (the moment arms), from
the poses of the kinematics stage, as MuJoCo's `mj_tendon` defines them.

A path runs through sites. Between two sites it may wrap round a sphere or a cylinder: when the
straight segment would cut through the geom (or a side site asks for the other side), the path
leaves the first site along a tangent, follows the geom's surface (a great circle's arc on a
sphere, a helix on a cylinder) and reaches the second site along a tangent. A pulley divides the
branches after it by its divisor. The moment arms are those of the straight segments between
consecutive points on different bodies: the arc's own change cancels at tangency, so each
segment contributes dir·(J(end) − J(start)), dir its unit direction.

Limits, springs, equalities and actuators use a spatial tendon through `ten_length` and `ten_J`
exactly as they use a fixed tendon's coefficients (`constraints`, `forces`).
"""

import warp as wp

from ..spatial import velocity_at
from .kinematics import geom_frame
from ..structs import EnvParams, ModelArrays, State
from ..types import WRAP_CYLINDER, WRAP_PULLEY, WRAP_SPHERE

_EPS = 1.0e-9
vec5 = wp.types.vector(length=5, dtype=wp.float32)


@wp.func
def _crosses(p1: wp.vec2, p2: wp.vec2, p3: wp.vec2, p4: wp.vec2):
    """Whether the segments p1-p2 and p3-p4 intersect."""
    det = (p4[1] - p3[1]) * (p2[0] - p1[0]) - (p4[0] - p3[0]) * (p2[1] - p1[1])
    if wp.abs(det) < _EPS:
        return False
    a = ((p4[0] - p3[0]) * (p1[1] - p3[1]) - (p4[1] - p3[1]) * (p1[0] - p3[0])) / det
    b = ((p2[0] - p1[0]) * (p1[1] - p3[1]) - (p2[1] - p1[1]) * (p1[0] - p3[0])) / det
    return a >= 0.0 and a <= 1.0 and b >= 0.0 and b <= 1.0


@wp.func
def _tangent_pair(d0: wp.vec2, d1: wp.vec2, s0: float, s1: float, r2: float, radius: float,
                  sign: float):
    """Tangent points (t0, t1) from d0 and from d1 to the circle, both on one side (sign)."""
    n0 = wp.dot(d0, d0)
    n1 = wp.dot(d1, d1)
    t0 = wp.vec2(d0[0] * r2 + sign * radius * d0[1] * s0, d0[1] * r2 - sign * radius * d0[0] * s0) / n0
    t1 = wp.vec2(d1[0] * r2 - sign * radius * d1[1] * s1, d1[1] * r2 + sign * radius * d1[0] * s1) / n1
    return t0, t1


@wp.func
def _winding(a: wp.vec2, b: wp.vec2):
    """Signed angle swept from a to b round the origin, in (-π, π]."""
    return wp.atan2(a[0] * b[1] - a[1] * b[0], wp.dot(a, b))


@wp.func
def circle_wrap(d0: wp.vec2, d1: wp.vec2, side: wp.vec2, has_side: int, radius: float):
    """The path from d0 to d1 round a circle of `radius` at the origin (2D): (t0, t1, arc), the
    tangent points and the arc's length, or arc < 0 where the straight segment is the path.

    Without a side point the path wraps only where the segment cuts the circle, on the shorter
    side. With one (MuJoCo 4's rule) it is the shortest path that winds round the circle as the
    polyline d0 -> side -> d1 does: straight if the segment, clear of the circle, winds the same
    way; otherwise round the side the polyline turns."""
    none = vec5(0.0, 0.0, 0.0, 0.0, -1.0)
    r2 = radius * radius
    n0 = wp.dot(d0, d0)
    n1 = wp.dot(d1, d1)
    if n0 < r2 or n1 < r2 or radius < _EPS:
        return none
    dif = d1 - d0
    dd = wp.dot(dif, dif)
    if dd < _EPS:
        return none
    closest = d0 + wp.clamp(-wp.dot(dif, d0) / dd, 0.0, 1.0) * dif
    clear = wp.dot(closest, closest) > r2
    turn = float(0.0)
    if has_side != 0:
        turn = _winding(d0, side) + _winding(side, d1)
        if clear and wp.abs(turn - _winding(d0, d1)) < wp.pi:
            return none
    elif clear:
        return none
    s0 = wp.sqrt(n0 - r2)
    s1 = wp.sqrt(n1 - r2)
    # the two tangent pairs (clockwise, counterclockwise): the side's turn picks one, else the
    # shorter whose tangent lines do not cross
    a0, a1 = _tangent_pair(d0, d1, s0, s1, r2, radius, 1.0)
    b0, b1 = _tangent_pair(d0, d1, s0, s1, r2, radius, -1.0)
    cross_a = _crosses(d0, a0, d1, a1)
    cross_b = _crosses(d0, b0, d1, b1)
    good_a = -wp.length_sq(a0 - a1)
    good_b = -wp.length_sq(b0 - b1)
    if cross_a:
        good_a = -1.0e4
    if cross_b:
        good_b = -1.0e4
    counterclockwise = good_a <= good_b
    if has_side != 0:
        counterclockwise = turn > 0.0
    t0 = a0
    t1 = a1
    crossing = cross_a
    if counterclockwise:
        t0 = b0
        t1 = b1
        crossing = cross_b
    if crossing:
        return none
    angle = float(0.0)
    if has_side != 0:     # the polyline's winding less the tangent segments': exact near 2π
        angle = wp.abs(turn - _winding(d0, t0) - _winding(t1, d1))
    else:
        c = t0[1] * t1[0] - t0[0] * t1[1]
        angle = wp.atan2(wp.abs(c), wp.dot(t0, t1))
        if angle > 1.0e-6 and ((c > 0.0 and counterclockwise) or (c < 0.0 and not counterclockwise)):
            angle = 2.0 * wp.pi - angle
    return vec5(t0[0], t0[1], t1[0], t1[1], radius * angle)


@wp.func
def geom_wrap(x0: wp.vec3, x1: wp.vec3, frame: wp.transform, radius: float, cylinder: int,
              side: wp.vec3, has_side: int):
    """The path between world points x0 and x1 round a sphere or cylinder posed at `frame`:
    (tangent point 1, tangent point 2, (arc length, 0, 0)) in world; arc length < 0: no wrap."""
    p0 = wp.transform_point(wp.transform_inverse(frame), x0)
    p1 = wp.transform_point(wp.transform_inverse(frame), x1)
    out = wp.mat33(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0)
    if wp.length(p0) < _EPS or wp.length(p1) < _EPS:
        return out
    # the plane of the wrap: a cylinder's cross-section, or the sphere's plane through both
    axis0 = wp.vec3(1.0, 0.0, 0.0)
    axis1 = wp.vec3(0.0, 1.0, 0.0)
    if cylinder == 0:
        axis0 = wp.normalize(p0)
        normal = wp.cross(p0, p1)
        if wp.length(normal) < _EPS:     # p0, p1 in line with the centre: any plane of them
            other = wp.vec3(1.0, 1.0, 1.0)
            a = wp.vec3(wp.abs(axis0[0]), wp.abs(axis0[1]), wp.abs(axis0[2]))
            if a[1] > a[0] and a[1] > a[2]:
                other = wp.vec3(1.0, 0.0, 1.0)
            elif a[2] > a[0] and a[2] > a[1]:
                other = wp.vec3(1.0, 1.0, 0.0)
            else:
                other = wp.vec3(0.0, 1.0, 1.0)
            normal = wp.cross(axis0, other)
        axis1 = wp.normalize(wp.cross(wp.normalize(normal), axis0))
    d0 = wp.vec2(wp.dot(p0, axis0), wp.dot(p0, axis1))
    d1 = wp.vec2(wp.dot(p1, axis0), wp.dot(p1, axis1))
    sd = wp.vec2()
    if has_side != 0:
        s = wp.transform_point(wp.transform_inverse(frame), side)
        sd = wp.vec2(wp.dot(s, axis0), wp.dot(s, axis1))
        if wp.length(sd) < _EPS:
            sd = wp.vec2(1.0, 0.0)
        sd = wp.normalize(sd) * radius    # (a side site inside the geom: refused at import)
    w = circle_wrap(d0, d1, sd, has_side, radius)
    arc = w[4]
    if arc < 0.0:
        return out
    t0 = axis0 * w[0] + axis1 * w[1]
    t1 = axis0 * w[2] + axis1 * w[3]
    if cylinder != 0:
        # a helix: the height changes in proportion to the length travelled
        l0 = wp.length(wp.vec2(p0[0] - t0[0], p0[1] - t0[1]))
        l1 = wp.length(wp.vec2(p1[0] - t1[0], p1[1] - t1[1]))
        total = l0 + arc + l1
        t0 = wp.vec3(t0[0], t0[1], p0[2] + (p1[2] - p0[2]) * l0 / total)
        t1 = wp.vec3(t1[0], t1[1], p0[2] + (p1[2] - p0[2]) * (l0 + arc) / total)
        arc = wp.sqrt(arc * arc + (t1[2] - t0[2]) * (t1[2] - t0[2]))
    a = wp.transform_point(frame, t0)
    b = wp.transform_point(frame, t1)
    return wp.mat33(a[0], a[1], a[2], b[0], b[1], b[2], arc, 0.0, 0.0)


@wp.func
def _point_rate(m: ModelArrays, s: State, e: int, row: int, body: int, point: wp.vec3,
                direction: wp.vec3, scale: float):
    """ten_J[row] += scale · direction · (velocity of `point` fixed on `body`, per dof)."""
    if body < 0:
        return
    ref = wp.transform_get_translation(s.body_x[e, m.body_root[body]])
    j = m.body_last_dof[body]
    while j >= 0:
        s.ten_J[e, row, j] = s.ten_J[e, row, j] + scale * wp.dot(
            direction, velocity_at(s.cdof[e, j], point - ref))
        j = m.dof_parent[j]


@wp.func
def _segment(m: ModelArrays, s: State, e: int, row: int, a: wp.vec3, body_a: int, b: wp.vec3,
             body_b: int, scale: float):
    """A straight piece of the path from a (on body_a) to b (on body_b): its length times
    scale, its moment arms added to ten_J[row] (none between points of one body)."""
    length = wp.length(b - a)
    if body_a != body_b and length > _EPS:
        direction = (b - a) / length
        _point_rate(m, s, e, row, body_b, b, direction, scale)
        _point_rate(m, s, e, row, body_a, a, direction, -scale)
    return length * scale


@wp.func
def _site_point(s: State, e: int, site: int):
    return wp.transform_get_translation(s.site_x[e, site])


@wp.kernel
def spatial_tendons(m: ModelArrays, p: EnvParams,
                    s: State):    # in: body_x, site_x, cdof; out: ten_length, ten_J
    """A thread per env and spatial tendon: its path's length and moment arms."""
    e, row = wp.tid()
    t = m.spatial_tendon[row]
    for i in range(m.nv):
        s.ten_J[e, row, i] = 0.0
    adr = m.tendon_adr[t]
    num = m.tendon_num[t]
    length = float(0.0)
    scale = float(1.0)
    j = int(0)
    while j < num - 1:
        w = adr + j
        if m.wrap_type[w] == WRAP_PULLEY or m.wrap_type[w + 1] == WRAP_PULLEY:
            if m.wrap_type[w] == WRAP_PULLEY:
                scale = 1.0 / m.wrap_coef[w]
            j += 1
            continue
        site0 = m.wrap_jnt[w]
        x0 = _site_point(s, e, site0)
        body0 = m.site_body[site0]
        geom = int(-1)
        site1 = m.wrap_jnt[w + 1]
        kind = m.wrap_type[w + 1]
        if kind == WRAP_SPHERE or kind == WRAP_CYLINDER:
            geom = m.wrap_jnt[w + 1]
            site1 = m.wrap_jnt[w + 2]
        x1 = _site_point(s, e, site1)
        body1 = m.site_body[site1]
        arc = float(-1.0)
        wrapped = wp.mat33()
        if geom >= 0:
            frame = geom_frame(m, p, s, e, geom)
            side = int(wp.round(m.wrap_coef[w + 1]))
            side_point = wp.vec3()
            if side >= 0:
                side_point = _site_point(s, e, side)
            wrapped = geom_wrap(x0, x1, frame, p.geom_size[e, geom][0],
                                wp.where(kind == WRAP_CYLINDER, 1, 0), side_point,
                                wp.where(side >= 0, 1, 0))
            arc = wrapped[2, 0]
        if arc < 0.0:
            length += _segment(m, s, e, row, x0, body0, x1, body1, scale)
        else:
            gbody = m.geom_body[geom]
            length += _segment(m, s, e, row, x0, body0, wrapped[0], gbody, scale)
            length += arc * scale
            length += _segment(m, s, e, row, wrapped[1], gbody, x1, body1, scale)
        j += wp.where(geom >= 0, 2, 1)
    s.ten_length[e, row] = length
