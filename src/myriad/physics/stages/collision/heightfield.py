"""Height fields (MuJoCo's hfield): a grid of heights, each cell split into two triangles.

Contacts are point queries against the surface: the points of the other shape that can touch
terrain first (a sphere's center, a capsule's segment ends and middle, a box's corners, a
cylinder's rims, an ellipsoid's support point, a mesh's vertices) each look up the triangle
under them and measure their distance along its normal. This is the classic terrain test for
legged robots; it is exact on a triangle's face and approximates where a shape straddles a crease.

Risers (`HFields.riser`, opt-in per height field; 0: MuJoCo's surface): on a coarse grid a
stair step is a steep ramp one cell wide, which feet slide up and sink into. Isaac Gym's
terrain (`convert_heightfield_to_trimesh`, slope_threshold) makes such faces vertical walls, and
so does this: in a cell where a corner stands higher than the cell's lowest corner by more than
the riser height (along x, y or a diagonal), that corner is a cliff top; the cell's floor is
built with the cliff tops lowered to the lowest corner (a gentle slope between the other
corners still tilts it), so the lower floor runs under the whole cell and the wall stands on the
grid line of the high samples, where the next cell (all high) carries the top. Each cell edge
between two cliff tops is a wall from the floor up to the edge's heights; a single cliff top is
a post, the end of the walls of the neighbouring cells. Round probes (sphere centers, capsule
points) also meet the nearest wall or post of their cell (`riser_contact`): sideways while below
its top, at its top edge above. Points of radius 0 (box corners, cylinder rims, mesh vertices,
the ellipsoid's support point) meet only the floor of the cell they are over, on either side of
a step, which is the stepped surface seen from above: a corner pushed past a riser is lifted
onto the top, unless it is nearer the riser's face than the top (then it leaves sideways).
"""

import warp as wp

from ...structs import HFields, Meshes
from ...types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE
from .convex import box_corner, support


@wp.func
def _height(hf: HFields, h: int, i: int, j: int):
    return hf.data[hf.adr[h] + i * hf.ncol[h] + j] * hf.size[h][2]


@wp.func
def _cell(hf: HFields, h: int, local: wp.vec3):
    """(found, row i, column j, fractions u, v of the cell along x and y, (x0, y0, dx, dy): its
    corner (i, j) and size) of the cell under `local` (in the height field's frame)."""
    size = hf.size[h]
    nrow = hf.nrow[h]
    ncol = hf.ncol[h]
    dx = 2.0 * size[0] / float(ncol - 1)
    dy = 2.0 * size[1] / float(nrow - 1)
    fx = (local[0] + size[0]) / dx
    fy = (local[1] + size[1]) / dy
    # written so that NaN (a blown-up body) is outside too: int(NaN) would index anywhere
    if not (fx >= 0.0 and fy >= 0.0 and fx <= float(ncol - 1) and fy <= float(nrow - 1)):
        return 0, 0, 0, 0.0, 0.0, wp.vec4()
    j = wp.min(int(fx), ncol - 2)
    i = wp.min(int(fy), nrow - 2)
    return 1, i, j, fx - float(j), fy - float(i), wp.vec4(-size[0] + float(j) * dx,
                                                          -size[1] + float(i) * dy, dx, dy)


@wp.func
def _corners(hf: HFields, h: int, i: int, j: int):
    """Heights of cell (i, j)'s corners, counterclockwise from (i, j): (i, j), (i, j+1),
    (i+1, j+1), (i+1, j)."""
    return wp.vec4(_height(hf, h, i, j), _height(hf, h, i, j + 1),
                   _height(hf, h, i + 1, j + 1), _height(hf, h, i + 1, j))


@wp.func
def _corner(cell: wp.vec4, k: int):
    """(x, y) of corner k (`_corners`' order) of the cell (x0, y0, dx, dy)."""
    return wp.vec2(cell[0] + cell[2] * float((k + 1) // 2 % 2), cell[1] + cell[3] * float(k // 2))


@wp.func
def _lowest(c: wp.vec4):
    return wp.min(wp.min(c[0], c[1]), wp.min(c[2], c[3]))


@wp.func
def surface(hf: HFields, h: int, x: wp.transform, point: wp.vec3):
    """(found, up normal in the world, signed distance of `point` above the triangle under it)."""
    local = wp.transform_point(wp.transform_inverse(x), point)
    found, i, j, u, v, cell = _cell(hf, h, local)
    if found == 0:
        return 0, wp.vec3(), 0.0
    x0 = cell[0]
    y0 = cell[1]
    dx = cell[2]
    dy = cell[3]
    c = _corners(hf, h, i, j)
    riser = hf.riser[h]
    if riser > 0.0:
        # the floor of a steep cell: its cliff tops lowered to the lowest corner (module doc)
        low = _lowest(c)
        for k in range(4):
            if c[k] > low + riser:
                c[k] = low
    p00 = wp.vec3(x0, y0, c[0])
    p11 = wp.vec3(x0 + dx, y0 + dy, c[2])
    # each cell is split along its (i, j) - (i+1, j+1) diagonal
    other = wp.vec3(x0 + dx, y0, c[1])
    if v > u:
        other = wp.vec3(x0, y0 + dy, c[3])
    n = wp.normalize(wp.cross(p11 - p00, other - p00))
    if n[2] < 0.0:
        n = -n
    dist = wp.dot(local - p00, n)
    if riser > 0.0 and dist < 0.0:
        # a point sunk into a step's top beside its riser (a shank's corner that crossed the
        # riser's line from the low side) leaves sideways when that is shorter than up: lifted
        # onto the top instead, it was kicked up to a step's height at once
        for side in range(4):
            depth, out, low = _riser_side(hf, h, i, j, side, local, cell)
            if depth >= 0.0 and depth < -dist and local[2] > low:
                dist = -depth
                n = out
    return 1, wp.quat_rotate(wp.transform_get_rotation(x), n), dist


@wp.func
def _sample(hf: HFields, h: int, i: int, j: int, outside: float):
    """Height of sample (i, j), or `outside` past the grid's edge."""
    if i < 0 or j < 0 or i >= hf.nrow[h] or j >= hf.ncol[h]:
        return outside
    return _height(hf, h, i, j)


@wp.func
def _riser_side(hf: HFields, h: int, i: int, j: int, side: int, local: wp.vec3, cell: wp.vec4):
    """(how far `local` is inside from edge `side` of cell (i, j): 0 -x, 1 +x, 2 -y, 3 +y;
    the outward normal; the floor beyond it) where that edge tops a riser down to the next cell
    (both its samples higher than the samples beyond by more than the riser), else depth -1."""
    a_i = i
    a_j = j
    b_i = i + 1
    b_j = j
    di = 0
    dj = -1
    depth = local[0] - cell[0]
    out = wp.vec3(-1.0, 0.0, 0.0)
    if side == 1:
        a_j = j + 1
        b_j = j + 1
        dj = 1
        depth = cell[0] + cell[2] - local[0]
        out = wp.vec3(1.0, 0.0, 0.0)
    elif side == 2:
        b_i = i
        b_j = j + 1
        di = -1
        dj = 0
        depth = local[1] - cell[1]
        out = wp.vec3(0.0, -1.0, 0.0)
    elif side == 3:
        a_i = i + 1
        b_i = i + 1
        b_j = j + 1
        di = 1
        dj = 0
        depth = cell[1] + cell[3] - local[1]
        out = wp.vec3(0.0, 1.0, 0.0)
    top_a = _height(hf, h, a_i, a_j)
    top_b = _height(hf, h, b_i, b_j)
    below_a = _sample(hf, h, a_i + di, a_j + dj, top_a)
    below_b = _sample(hf, h, b_i + di, b_j + dj, top_b)
    riser = hf.riser[h]
    if top_a - below_a > riser and top_b - below_b > riser:
        return depth, out, wp.max(below_a, below_b)
    return -1.0, out, 0.0


@wp.func
def riser_contact(hf: HFields, h: int, x: wp.transform, point: wp.vec3):
    """(found, normal in the world, distance of `point`) to the nearest riser wall of the cell
    under it (found = 0 where the cell has no cliff top; call only where hf.riser[h] > 0).

    A cell edge between two cliff tops is a wall on the edge's grid line, from the floor up to
    the straight line between the two tops; an edge with one cliff top ends at a post (a vertical
    segment up to that top) at the corner: the end of the walls that the neighbouring cells carry,
    which a point in this cell can be nearer to than to any of its own. The point lies inside the
    cell, on the walls' low side. Below a wall's top the distance is horizontal and the normal
    points from the wall into the cell; above it, both go from the top edge to the point, so that
    a foot rolls over a ledge instead of snagging on it."""
    local = wp.transform_point(wp.transform_inverse(x), point)
    inside, i, j, u, v, cell = _cell(hf, h, local)
    if inside == 0:
        return 0, wp.vec3(), 0.0
    c = _corners(hf, h, i, j)
    top = _lowest(c) + hf.riser[h]
    found = int(0)
    best = float(0.0)
    normal = wp.vec3()
    for k in range(4):
        # edge k runs counterclockwise from corner k to corner k + 1
        k1 = (k + 1) % 4
        if c[k] > top or c[k1] > top:
            a = _corner(cell, k)
            edge = _corner(cell, k1) - a
            t = float(0.0)      # the post at corner k
            if c[k] <= top:
                t = 1.0         # the post at corner k + 1
            elif c[k1] > top:   # the wall: the point's foot on the edge
                t = wp.clamp(wp.dot(wp.vec2(local[0], local[1]) - a, edge) / wp.dot(edge, edge),
                             0.0, 1.0)
            q = a + edge * t
            height = c[k] + (c[k1] - c[k]) * t
            d = wp.vec3(local[0] - q[0], local[1] - q[1], 0.0)
            if local[2] > height:
                d = wp.vec3(d[0], d[1], local[2] - height)
            dist = wp.length(d)
            n = wp.vec3()
            if dist > 1.0e-9:
                n = d / dist
            else:   # on the wall's line: out of it, into the cell
                n = wp.normalize(wp.vec3(-edge[1], edge[0], 0.0))
            if found == 0 or dist < best:
                found = 1
                best = dist
                normal = n
    return found, wp.quat_rotate(wp.transform_get_rotation(x), normal), best


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
