"""Height fields (MuJoCo's hfield): a grid of heights, each cell split into two triangles.

Contacts are point queries against the surface: the points of the other shape that can touch
terrain first (a sphere's center, a capsule's segment ends and middle, a box's corners, a
cylinder's rims, an ellipsoid's support point, a mesh's vertices) each look up the triangle
under them and measure their distance along its normal. This is the classic terrain test for
legged robots; it is exact on a triangle's face and approximates where a shape straddles a crease.
"""

import warp as wp

from ..types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE
from .convex import Meshes, box_corner, support


@wp.struct
class HFields:
    size: wp.array(dtype=wp.vec4)     # x half-size, y half-size, top height, base depth
    nrow: wp.array(dtype=wp.int32)    # rows run along y
    ncol: wp.array(dtype=wp.int32)    # columns run along x
    adr: wp.array(dtype=wp.int32)
    data: wp.array(dtype=float)       # heights in [0, 1], times the top height


@wp.func
def _height(hf: HFields, h: int, i: int, j: int):
    return hf.data[hf.adr[h] + i * hf.ncol[h] + j] * hf.size[h][2]


@wp.func
def surface(hf: HFields, h: int, x: wp.transform, point: wp.vec3):
    """(found, up normal in the world, signed distance of `point` above the triangle under it)."""
    local = wp.transform_point(wp.transform_inverse(x), point)
    size = hf.size[h]
    nrow = hf.nrow[h]
    ncol = hf.ncol[h]
    dx = 2.0 * size[0] / float(ncol - 1)
    dy = 2.0 * size[1] / float(nrow - 1)
    fx = (local[0] + size[0]) / dx
    fy = (local[1] + size[1]) / dy
    if fx < 0.0 or fy < 0.0 or fx > float(ncol - 1) or fy > float(nrow - 1):
        return 0, wp.vec3(), 0.0
    j = wp.min(int(fx), ncol - 2)
    i = wp.min(int(fy), nrow - 2)
    u = fx - float(j)
    v = fy - float(i)
    x0 = -size[0] + float(j) * dx
    y0 = -size[1] + float(i) * dy
    p00 = wp.vec3(x0, y0, _height(hf, h, i, j))
    p11 = wp.vec3(x0 + dx, y0 + dy, _height(hf, h, i + 1, j + 1))
    # each cell is split along its (i, j) - (i+1, j+1) diagonal
    other = wp.vec3(x0 + dx, y0, _height(hf, h, i, j + 1))
    if v > u:
        other = wp.vec3(x0, y0 + dy, _height(hf, h, i + 1, j))
    n = wp.normalize(wp.cross(p11 - p00, other - p00))
    if n[2] < 0.0:
        n = -n
    return 1, wp.quat_rotate(wp.transform_get_rotation(x), n), wp.dot(local - p00, n)


@wp.func
def probe_point(t: int, size: wp.vec3, mesh: int, meshes: Meshes, x: wp.transform, k: int):
    """(valid, point, radius) of the k-th probe of a shape: the points that can touch first."""
    if t == SPHERE:
        if k == 0:
            return 1, wp.transform_get_translation(x), size[0]
    elif t == CAPSULE:
        if k < 3:
            return 1, wp.transform_point(x, wp.vec3(0.0, 0.0, size[1] * float(k - 1))), size[0]
    elif t == BOX:
        if k < 8:
            return 1, wp.transform_point(x, box_corner(size, k)), 0.0
    elif t == CYLINDER:
        if k < 16:
            angle = float(k % 8) * 0.7853981633974483
            z = size[1]
            if k >= 8:
                z = -size[1]
            return 1, wp.transform_point(x, wp.vec3(size[0] * wp.cos(angle), size[0] * wp.sin(angle), z)), 0.0
    elif t == MESH:
        if k < meshes.vertnum[mesh]:
            return 1, wp.transform_point(x, meshes.vert[meshes.vertadr[mesh] + k]), 0.0
    return 0, wp.vec3(), 0.0


@wp.func
def ellipsoid_probe(hf: HFields, h: int, xh: wp.transform, size: wp.vec3, meshes: Meshes,
                    x: wp.transform):
    """The ellipsoid's point farthest down the terrain normal under its center."""
    found, n, dist = surface(hf, h, xh, wp.transform_get_translation(x))
    if found == 0:
        n = wp.quat_rotate(wp.transform_get_rotation(xh), wp.vec3(0.0, 0.0, 1.0))
    return support(ELLIPSOID, size, -1, meshes, x, -n, 0.0)
