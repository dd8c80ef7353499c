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
  or vertex), which stays right across creases and ridges; an inside is confirmed by the
  winding of the faces round the point (`local_winding`: a fold's normals cancel). A round
  probe (a sphere's center, a capsule's points) also meets every other face whose prism it
  stands in, within its radius (`face_plane`): a foot in the corner of a step touches the
  tread and the riser, not only the nearer of the two.
- The mesh's ridges (edges whose faces bend away, or an open surface's rims:
  `build.ridge_edges`) into boxes, capsules, cylinders and convex meshes (a capsule: segment
  to segment; a box or a cylinder: golden section on its signed distance along the edge; a
  convex mesh: the edge as a capsule of radius 0 against its hull, GJK/EPA): an edge or vertex
  of the mesh under a face of the shape, between the shape's own probes (a box lying over a
  table's edge, a shank across a step's edge), makes a contact at its deepest point in the
  shape. Up to 16 contacts past the probes' per pair.

What it does not see: a mesh edge into an ellipsoid's side, and a shape pushed through a thin wall
farther than its own size in one step (a probe is matched to a face only within the
shape's bounding radius behind it: beyond that it is taken to be on the other side, not
inside). Triangles must face outward (counterclockwise seen from the side bodies are on): an
open surface such as terrain has an inside, the side its triangles face away from.
"""

import warp as wp


@wp.func
def local_winding(bvh: wp.uint64, local: wp.vec3, reach: float):
    """The winding number about `local` (mesh frame) of the faces whose bounds come within
    `reach` of it: the sum of their solid angles over 4π (Van Oosterom and Strackee), positive
    seen from behind. Only these faces: an open surface (a bin, terrain) has no winding number
    that tells its sides apart far from it, but the faces around a point do: by an edge where
    the inside spans an angle θ (π on a face), 1 - θ/2π inside and -θ/2π outside."""
    near = wp.vec3(reach, reach, reach)
    query = wp.mesh_query_aabb(bvh, local - near, local + near)
    face = int(0)
    angle = float(0.0)
    while wp.mesh_query_aabb_next(query, face):
        a = wp.mesh_get_point(bvh, 3 * face) - local
        b = wp.mesh_get_point(bvh, 3 * face + 1) - local
        c = wp.mesh_get_point(bvh, 3 * face + 2) - local
        la = wp.length(a)
        lb = wp.length(b)
        lc = wp.length(c)
        angle += 2.0 * wp.atan2(wp.dot(a, wp.cross(b, c)),
                                la * lb * lc + wp.dot(a, b) * lc + wp.dot(b, c) * la
                                + wp.dot(c, a) * lb)
    return angle / (4.0 * wp.pi)


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
    sign = query.sign
    if sign < 0.0 and length > 1.0e-4 and local_winding(bvh, local, 3.0 * length) <= 0.0:
        # inside, by the angle-weighted normal at the closest feature, which cancels where the
        # surface folds back on itself (a height field's vertices moved under their neighbours
        # make fins of two opposite faces: a point 16 cm above one was taken to be inside, and
        # an ANYmal's shank was thrown); the faces around the point do not hold it
        sign = 1.0
    n = wp.mesh_eval_face_normal(bvh, query.face)
    if length > 1.0e-9:
        n = d * (sign / length)     # inside, d points inward: the normal is -d
    return 1, wp.quat_rotate(wp.transform_get_rotation(x), n), length * sign, query.face


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
