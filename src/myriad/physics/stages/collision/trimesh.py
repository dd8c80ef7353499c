"""Static triangle meshes (`GeomType.TRIMESH`): a bin, a table, a room, terrain that is not a
height-field grid, collided as its triangles rather than as its convex hull.

The mesh's triangles live in a Warp BVH (`wp.Mesh`, built once by `build.shape_data`; a few
million triangles cost one tree, shared by all envs). Two tests make the contacts of a shape
against it (`narrowphase._trimesh`):

- The shape's probe points against the surface, as on a height field (`heightfield.probe_point`:
  a sphere's center, a capsule's segment ends and middle, a box's corners, a cylinder's rims, a
  convex mesh's first hull vertices; an ellipsoid's point deepest along the normal under its
  center): each finds the closest point of the whole mesh (`surface_point`), and its signed
  distance is exact, the sign from the angle-weighted normal at the closest feature (face, edge
  or vertex), which stays right across creases and ridges. A round probe (a sphere's center, a
  capsule's points) also meets every other face whose prism it stands in, within its radius
  (`face_plane`): a foot in the corner of a step touches the tread and the riser, not only the
  nearer of the two.
- The mesh's ridges (edges whose faces bend away, or an open surface's rims:
  `build.ridge_edges`) into boxes, capsules and cylinders (a box: `clip_to_box`, `box_depth`;
  a capsule: segment to segment; a cylinder: golden section on its signed distance along the
  edge): an edge or vertex of the mesh under a face of the shape, between the shape's own
  probes (a box lying over a table's edge, a shank across a step's edge), makes a contact at
  its deepest point in the shape. Up to 16 contacts past the probes' per pair.

What it does not see: a mesh edge crossing a convex mesh's face between its vertices (its
probes are its vertices) or an ellipsoid's side, and a shape pushed through a thin wall
farther than its own size in one step (a probe is matched to a face only within the
shape's bounding radius behind it: beyond that it is taken to be on the other side, not
inside). Triangles must face outward (counterclockwise seen from the side bodies are on): an
open surface such as terrain has an inside, the side its triangles face away from.
"""

import warp as wp


@wp.func
def surface_point(bvh: wp.uint64, x: wp.transform, point: wp.vec3, reach: float):
    """(found, outward normal at the closest point, in the world; signed distance of `point`
    from the surface: negative inside; the face it lies on) for the closest point of the mesh
    within `reach`."""
    local = wp.transform_point(wp.transform_inverse(x), point)
    query = wp.mesh_query_point_sign_normal(bvh, local, reach)
    if not query.result:
        return 0, wp.vec3(), 0.0, -1
    closest = wp.mesh_eval_position(bvh, query.face, query.u, query.v)
    d = local - closest
    length = wp.length(d)
    n = wp.mesh_eval_face_normal(bvh, query.face)
    if length > 1.0e-9:
        n = d * (query.sign / length)     # inside, d points inward: the normal is -d
    return 1, wp.quat_rotate(wp.transform_get_rotation(x), n), length * query.sign, query.face


@wp.func
def face_plane(bvh: wp.uint64, face: int, local: wp.vec3):
    """(whether `local` (mesh frame) lies in the prism over the face: its foot on the face's
    plane inside the triangle; the face's normal, mesh frame; the signed distance from that
    plane)."""
    a = wp.mesh_get_point(bvh, 3 * face)
    b = wp.mesh_get_point(bvh, 3 * face + 1)
    c = wp.mesh_get_point(bvh, 3 * face + 2)
    n = wp.cross(b - a, c - a)
    area = wp.length(n)
    if area < 1.0e-12:
        return 0, wp.vec3(), 0.0
    n = n / area
    # the foot is inside when it lies on the inner side of all three edges
    inside = int(1)
    if wp.dot(wp.cross(b - a, local - a), n) < 0.0:
        inside = 0
    if wp.dot(wp.cross(c - b, local - b), n) < 0.0:
        inside = 0
    if wp.dot(wp.cross(a - c, local - c), n) < 0.0:
        inside = 0
    return inside, n, wp.dot(local - a, n)


@wp.func
def box_depth(half: wp.vec3, local: wp.vec3):
    """(how deep `local` (box frame) lies inside the box: the least distance to a face,
    negative outside; the outward normal of that face, box frame)."""
    depth = float(1.0e30)
    n = wp.vec3()
    for i in range(3):
        d = half[i] - wp.abs(local[i])
        if d < depth:
            depth = d
            n = wp.vec3()
            if local[i] >= 0.0:
                n[i] = 1.0
            else:
                n[i] = -1.0
    return depth, n


@wp.func
def clip_to_box(half: wp.vec3, a: wp.vec3, b: wp.vec3):
    """(hit, t0, t1): the part a + t·(b - a), t in [t0, t1], of a segment (box frame) inside
    the box (Liang-Barsky); hit 0 when the segment misses it."""
    t0 = float(0.0)
    t1 = float(1.0)
    d = b - a
    for i in range(3):
        if wp.abs(d[i]) < 1.0e-12:
            if wp.abs(a[i]) > half[i]:
                return 0, 0.0, 0.0
        else:
            lo = (-half[i] - a[i]) / d[i]
            hi = (half[i] - a[i]) / d[i]
            if lo > hi:
                swap = lo
                lo = hi
                hi = swap
            t0 = wp.max(t0, lo)
            t1 = wp.min(t1, hi)
            if t0 > t1:
                return 0, 0.0, 0.0
    return 1, t0, t1
