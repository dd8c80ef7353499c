"""Narrowphase: contacts of each candidate pair in each env, closed forms per type pair.

One thread per (env, pair). A contact is kept when the signed distance between the surfaces is
below the contact offset (PhysX's contactOffset; MuJoCo's margin). It records, as MuJoCo does,
the two geoms, the midpoint between the surfaces, the normal from geom 1 to geom 2 and the
signed distance (negative: penetration). Contacts go to the env's preallocated slots through an
atomic counter; a count above the capacity is the overflow, reported by the simulator, and
nothing is ever written outside an env's slots.
"""

from __future__ import annotations

import numpy as np
import warp as wp

PLANE = wp.constant(0)
SPHERE = wp.constant(2)
CAPSULE = wp.constant(3)
BOX = wp.constant(6)

# (type1, type2) with type1 <= type2, MuJoCo geom type numbers
SUPPORTED_PAIRS = {(0, 2), (0, 3), (0, 6), (2, 2), (2, 3), (2, 6), (3, 3)}


class ContactBuffers:
    """Per-env contact slots: `capacity` contacts per env."""

    def __init__(self, num_envs: int, capacity: int, device):
        self.capacity = capacity
        self.count = wp.zeros(num_envs, dtype=wp.int32, device=device)   # may exceed capacity
        self.geom = wp.zeros((num_envs, capacity), dtype=wp.vec2i, device=device)
        self.pos = wp.zeros((num_envs, capacity), dtype=wp.vec3, device=device)
        self.normal = wp.zeros((num_envs, capacity), dtype=wp.vec3, device=device)
        self.dist = wp.zeros((num_envs, capacity), dtype=wp.float32, device=device)
        # identity of a contact across substeps (pair index and feature, e.g. which box corner),
        # for warm-starting the solver
        self.key = wp.zeros((num_envs, capacity), dtype=wp.int32, device=device)


@wp.func
def _emit(e: int, pair: wp.vec2i, key: int, pos: wp.vec3, normal: wp.vec3, dist: float,
          margin: float, capacity: int, count: wp.array(dtype=wp.int32),
          c_geom: wp.array2d(dtype=wp.vec2i), c_key: wp.array2d(dtype=wp.int32),
          c_pos: wp.array2d(dtype=wp.vec3), c_normal: wp.array2d(dtype=wp.vec3),
          c_dist: wp.array2d(dtype=float)):
    if dist < margin:
        slot = wp.atomic_add(count, e, 1)
        if slot < capacity:
            c_geom[e, slot] = pair
            c_key[e, slot] = key
            c_pos[e, slot] = pos
            c_normal[e, slot] = normal
            c_dist[e, slot] = dist


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


@wp.kernel
def narrowphase(pairs: wp.array(dtype=wp.vec2i), geom_type: wp.array(dtype=wp.int32),
                geom_size: wp.array(dtype=wp.vec3), geom_x: wp.array2d(dtype=wp.transform),
                margin: float, capacity: int, count: wp.array(dtype=wp.int32),
                c_geom: wp.array2d(dtype=wp.vec2i), c_key: wp.array2d(dtype=wp.int32),
                c_pos: wp.array2d(dtype=wp.vec3),
                c_normal: wp.array2d(dtype=wp.vec3), c_dist: wp.array2d(dtype=float)):
    e, p = wp.tid()
    pair = pairs[p]
    g1 = pair[0]
    g2 = pair[1]
    t1 = geom_type[g1]
    t2 = geom_type[g2]
    x1 = geom_x[e, g1]
    x2 = geom_x[e, g2]
    s1 = geom_size[g1]
    s2 = geom_size[g2]
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
                _emit(e, pair, p * 8 + k, center - n * (s2[0] + 0.5 * dist), n, dist, margin,
                      capacity, count, c_geom, c_key, c_pos, c_normal, c_dist)
        elif t2 == BOX:
            # corners below the offset, at most four (a box resting on a face touches with four)
            found = int(0)
            for k in range(8):
                corner = wp.vec3(s2[0], s2[1], s2[2])
                if k & 1:
                    corner[0] = -corner[0]
                if k & 2:
                    corner[1] = -corner[1]
                if k & 4:
                    corner[2] = -corner[2]
                point = wp.transform_point(x2, corner)
                dist = wp.dot(point - c1, n)
                if dist < margin and found < 4:
                    found += 1
                    _emit(e, pair, p * 8 + k, point - n * (0.5 * dist), n, dist, margin, capacity,
                          count, c_geom, c_key, c_pos, c_normal, c_dist)
    elif t1 == SPHERE:
        if t2 == SPHERE or t2 == CAPSULE:
            other = c2
            if t2 == CAPSULE:
                other = _closest_on_segment(_segment(x2, s2[1], -1.0), _segment(x2, s2[1], 1.0), c1)
            n, dist, pos = _spheres(c1, s1[0], other, s2[0])
            _emit(e, pair, p * 8, pos, n, dist, margin, capacity, count, c_geom, c_key, c_pos,
                  c_normal, c_dist)
        elif t2 == BOX:
            local = wp.transform_point(wp.transform_inverse(x2), c1)
            clamped = wp.vec3(wp.clamp(local[0], -s2[0], s2[0]), wp.clamp(local[1], -s2[1], s2[1]),
                              wp.clamp(local[2], -s2[2], s2[2]))
            rot = wp.transform_get_rotation(x2)
            r = s1[0]
            if wp.length_sq(local - clamped) > 1.0e-12:
                # center outside the box: nearest box point
                b = wp.transform_point(x2, clamped)
                gap = wp.length(b - c1)
                n = (b - c1) / gap
                dist = gap - r
                _emit(e, pair, p * 8, 0.5 * (c1 + n * r + b), n, dist, margin, capacity, count,
                      c_geom, c_key, c_pos, c_normal, c_dist)
            else:
                # center inside: leave through the nearest face
                axis = int(0)
                depth = s2[0] - wp.abs(local[0])
                for k in range(1, 3):
                    dk = s2[k] - wp.abs(local[k])
                    if dk < depth:
                        depth = dk
                        axis = k
                out = wp.vec3()
                out[axis] = wp.sign(local[axis])
                if out[axis] == 0.0:
                    out[axis] = 1.0
                u = wp.quat_rotate(rot, out)
                n = -u
                b = c1 + u * depth
                _emit(e, pair, p * 8, 0.5 * (c1 - u * r + b), n, -(depth + r), margin, capacity,
                      count, c_geom, c_key, c_pos, c_normal, c_dist)
    elif t1 == CAPSULE and t2 == CAPSULE:
        a1 = _segment(x1, s1[1], -1.0)
        b1 = _segment(x1, s1[1], 1.0)
        a2 = _segment(x2, s2[1], -1.0)
        b2 = _segment(x2, s2[1], 1.0)
        st = _closest_between_segments(a1, b1, a2, b2)
        n, dist, pos = _spheres(a1 + (b1 - a1) * st[0], s1[0], a2 + (b2 - a2) * st[1], s2[0])
        _emit(e, pair, p * 8, pos, n, dist, margin, capacity, count, c_geom, c_key, c_pos,
              c_normal, c_dist)


@wp.kernel
def geom_poses(geom_body: wp.array(dtype=wp.int32), geom_pos: wp.array(dtype=wp.vec3),
               geom_quat: wp.array(dtype=wp.quat), body_x: wp.array2d(dtype=wp.transform),
               geom_x: wp.array2d(dtype=wp.transform)):
    e, g = wp.tid()
    x = wp.transform(geom_pos[g], geom_quat[g])
    b = geom_body[g]
    if b >= 0:
        x = body_x[e, b] * x
    geom_x[e, g] = x


def unsupported_pairs(model, pairs: np.ndarray) -> list[tuple[str, str]]:
    """Type names of candidate pairs the narrowphase cannot handle yet."""
    from ..model import GEOM_TYPES

    missing = set()
    for g1, g2 in pairs:
        key = (int(model.geom_type[g1]), int(model.geom_type[g2]))
        if key not in SUPPORTED_PAIRS:
            missing.add((GEOM_TYPES[key[0]], GEOM_TYPES[key[1]]))
    return sorted(missing)
