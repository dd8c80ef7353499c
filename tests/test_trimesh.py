"""Static triangle meshes (`Model.collide_as_triangles`, `Scene.add_triangle_mesh`,
stages/collision/trimesh.py): a mesh collided as its triangles, not its convex hull.

Scenes use Isaac Gym's settings (dt 1/60 in 2 substeps, TGS); heights are checked against the
exact geometry: a shape resting on a face rests at its half-height, a sphere beside a ridge is
measured to the ridge's edge.
"""

import mujoco
import numpy as np
import pytest
import torch

import myriad
from myriad.api import Scene
from myriad.physics import ModelError
from myriad.physics.types import GeomType

PARAMS = myriad.SimParams(dt=1 / 60, substeps=2)

W, H = 0.5, 0.3        # the bin: a 1 m square floor at z = 0, walls 0.3 m high, faces inward
BIN_VERTICES = np.array([[-W, -W, 0], [W, -W, 0], [W, W, 0], [-W, W, 0],
                         [-W, -W, H], [W, -W, H], [W, W, H], [-W, W, H]], float)
BIN_TRIANGLES = np.array([[0, 1, 2], [0, 2, 3],       # floor, normal +z
                          [0, 4, 5], [0, 5, 1],       # wall y = -W, normal +y
                          [1, 5, 6], [1, 6, 2],       # x = +W, normal -x
                          [2, 6, 7], [2, 7, 3],       # y = +W, normal -y
                          [3, 7, 4], [3, 4, 0]])      # x = -W, normal +x

SHAPES = ['type="sphere" size="0.05"', 'type="box" size="0.05 0.04 0.03"',
          'type="capsule" size="0.03 0.06"', 'type="cylinder" size="0.04 0.03"']


def _resting_height(geom: str, quat_xyzw) -> float:
    """Height of a shape's center above a flat floor it rests on in orientation `quat_xyzw`:
    its support along -z."""
    kind, size = geom.split('"')[1], [float(v) for v in geom.split('"')[3].split()]
    x, y, z, w = quat_xyzw
    axis_z = np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    if kind == "sphere":
        return size[0]
    if kind == "capsule":
        return size[0] + size[1] * abs(axis_z[2])
    if kind == "cylinder":
        return size[1] * abs(axis_z[2]) + size[0] * np.sqrt(max(0.0, 1 - axis_z[2] ** 2))
    world_z_row = np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])
    return float(np.abs(world_z_row) @ np.asarray(size))      # a box


def _mesh_xml(vertices, triangles, bodies: str, pos="0 0 0", assets: str = "") -> str:
    verts = " ".join(f"{x:.9g}" for x in np.asarray(vertices).ravel())
    faces = " ".join(str(int(i)) for i in np.asarray(triangles).ravel())
    return (f'<mujoco><asset><mesh name="m" vertex="{verts}" face="{faces}" inertia="shell"/>'
            f'{assets}</asset><worldbody><geom name="m" type="mesh" mesh="m" pos="{pos}" contype="0" '
            f'conaffinity="0"/>{bodies}</worldbody></mujoco>')


def _simulator(xml: str, num_envs: int = 1, device="cpu") -> myriad.Simulator:
    model = myriad.load_xml(xml, "trimesh")
    model.collide_as_triangles("m")
    assert model.geom_type[model.geom_names.index("m")] == GeomType.TRIMESH
    return myriad.Simulator(model, num_envs=num_envs, device=device, params=PARAMS)


def test_shapes_dropped_into_a_bin_rest_on_its_floor(device):
    """Each shape, dropped tilted into the bin, lands on its floor (its convex hull would hold
    them at the rim, 0.3 m up) and comes to rest, its center at its exact support height for
    the orientation it came to rest in (a cylinder on its side: its radius), within 1 mm."""
    bodies = "".join(f'<body pos="{-0.3 + 0.2 * k} {0.1 * (k % 2)} 0.5" euler="{20 + 10 * k} 30 '
                     f'{15 * k}"><freejoint/><geom {geom} mass="0.2"/></body>'
                     for k, geom in enumerate(SHAPES))
    sim = _simulator(_mesh_xml(BIN_VERTICES, BIN_TRIANGLES, bodies), device=device)
    for _ in range(240):
        sim.step()
    q = sim.q[0].cpu().numpy().reshape(-1, 7)
    v = sim.qd[0].cpu().numpy().reshape(-1, 6)
    for k, geom in enumerate(SHAPES):
        assert q[k, 2] == pytest.approx(_resting_height(geom, q[k, 3:]), abs=1e-3), geom
        assert np.abs(v[k]).max() < 0.05, geom


def test_walls_keep_a_thrown_ball_inside(device):
    """A ball thrown at 3.6 m/s towards a corner meets the walls (faces whose normals point into
    the bin) and stays inside, resting on the floor at the end. At impact it may reach into a
    wall by a few millimetres, as into any static shape at that speed (25 mm per substep)."""
    r = 0.05
    sim = _simulator(_mesh_xml(BIN_VERTICES, BIN_TRIANGLES,
                               f'<body pos="0 0 0.1"><freejoint/><geom type="sphere" size="{r}" '
                               f'mass="0.2"/></body>'), device=device)
    sim.qd[0, 0:3] = torch.tensor([3.0, 2.0, 0.0])
    farthest = 0.0
    for _ in range(300):
        sim.step()
        farthest = max(farthest, float(sim.q[0, 0:2].abs().max()))
    assert farthest < W - r + 5e-3
    assert float(sim.q[0, 2]) == pytest.approx(r, abs=1e-3)


def test_a_sphere_beside_a_ridge_is_measured_to_the_edge(device):
    """A roof-shaped ridge (two faces meeting along y at x = 0, z = 0.1, sloping down at 45°):
    a sphere above and beside the ridge line, nearer its edge than either face's plane would
    say, gets one contact whose distance is to the edge and whose normal points from the edge
    to the sphere's center (a height field would measure along the face normal below it)."""
    r, center = 0.05, np.array([0.03, 0.0, 0.1 + 0.052])
    sim = _simulator(_mesh_xml(RIDGE_VERTICES, RIDGE_TRIANGLES,
                               f'<body pos="{center[0]} {center[1]} {center[2]}"><freejoint/>'
                               f'<geom type="sphere" size="{r}"/></body>'), device=device)
    edge = np.array([0.0, 0.0, 0.1])
    _one_contact(sim, np.linalg.norm(center - edge) - r,
                 (center - edge) / np.linalg.norm(center - edge))


def _one_contact(sim, dist, normal):
    """After collide(): env 0 has exactly one contact, at `dist` along `normal` (1e-5)."""
    sim.collide()
    assert int(sim.contact_count[0]) == 1
    assert float(sim.contact_dist[0, 0]) == pytest.approx(dist, abs=1e-5)
    np.testing.assert_allclose(sim.contact_normal[0, 0].cpu().numpy(), normal, atol=1e-5)


RIDGE_VERTICES = [[-1, -1, -1.0], [0, -1, 0.1], [0, 1, 0.1], [-1, 1, -1.0], [1, -1, -1.0],
                  [1, 1, -1.0]]
RIDGE_TRIANGLES = [[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]]


def test_shapes_lying_across_a_ridge_meet_its_edge(device):
    """A box, a capsule, a cylinder and an ellipsoid lying across the ridge of the roof (their
    long axes along x, over its edge along y at z = 0.1), 2 mm above it: each touches the edge,
    at 2 mm along +z (the faces fall away at 45° below them). The box's corners and the
    cylinder's rims are far from any face: only the ridge test sees the edge under them."""
    gap = 0.002
    shapes = [('type="box" size="0.1 0.04 0.03"', 0.03, ""),
              ('type="capsule" size="0.03 0.1"', 0.03, 'euler="0 90 0"'),
              ('type="cylinder" size="0.04 0.1"', 0.04, 'euler="0 90 0"'),
              ('type="ellipsoid" size="0.1 0.04 0.03"', 0.03, "")]
    bodies = "".join(f'<body pos="0 {-0.6 + 0.4 * k} {0.1 + low + gap}" {turn}><freejoint/>'
                     f'<geom {geom}/></body>' for k, (geom, low, turn) in enumerate(shapes))
    sim = _simulator(_mesh_xml(RIDGE_VERTICES, RIDGE_TRIANGLES, bodies), device=device)
    sim.collide()
    n = int(sim.contact_count[0])
    body = sim.model.geom_body[sim.contact_geom[0, :n, 1].cpu().numpy()]
    dist = sim.contact_dist[0, :n].cpu().numpy()
    normal = sim.contact_normal[0, :n].cpu().numpy()
    for k, (geom, _, _) in enumerate(shapes):
        mine = np.flatnonzero(body == k)
        assert len(mine), geom
        nearest = mine[np.argmin(dist[mine])]
        assert dist[nearest] == pytest.approx(gap, abs=2e-5), geom
        np.testing.assert_allclose(normal[nearest], [0, 0, 1], atol=1e-3, err_msg=geom)


def test_a_sphere_in_a_corner_touches_both_faces(device):
    """A sphere in the bin's corner between the floor and the wall x = -W, 1 mm from each:
    two contacts, one with each face (the closest feature alone would give the nearer one),
    each at its exact distance along that face's normal."""
    r = 0.05
    sim = _simulator(_mesh_xml(BIN_VERTICES, BIN_TRIANGLES,
                               f'<body pos="{-W + r + 0.001} 0 {r + 0.0012}"><freejoint/>'
                               f'<geom type="sphere" size="{r}"/></body>'), device=device)
    sim.collide()
    n = int(sim.contact_count[0])
    normals = sim.contact_normal[0, :n].cpu().numpy()
    dists = sim.contact_dist[0, :n].cpu().numpy()
    assert n == 2
    order = np.argsort(-normals[:, 2])          # the floor's first
    np.testing.assert_allclose(normals[order], [[0, 0, 1], [1, 0, 0]], atol=1e-6)
    np.testing.assert_allclose(dists[order], [0.0012, 0.001], atol=1e-6)


# a fin 2 cm tall on a 4 m floor: two faces share its top edge (y from -0.1 to 0.1) and lean
# past each other to its foot, each facing out and a little down: the fold a height field's
# vertex moved under its neighbour makes (`heightfield_to_mesh` with a slope threshold)
FIN_VERTICES = [[-2, -2, 0], [2, -2, 0], [2, 2, 0], [-2, 2, 0],
                [0, -0.1, 0.02], [0, 0.1, 0.02], [-0.001, 0, 0], [0.001, 0, 0]]
FIN_TRIANGLES = [[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 5, 7]]


def test_a_sphere_above_a_folded_fin_is_outside(device):
    """A sphere 1 cm above the fin's top edge: one contact, 1 cm along +z. The angle-weighted
    normal at the edge, the sum of the two faces' normals, points down and called the sphere
    7 cm deep (an ANYmal's shank was thrown off such a fin on the original's terrain mesh);
    the faces around it, the floor with the fin, do not enclose it."""
    r = 0.03
    sim = _simulator(_mesh_xml(FIN_VERTICES, FIN_TRIANGLES,
                               f'<body pos="0 0 {0.02 + r + 0.01}"><freejoint/>'
                               f'<geom type="sphere" size="{r}"/></body>'), device=device)
    _one_contact(sim, 0.01, [0, 0, 1])


def test_a_sphere_pressed_on_a_thin_wall_meets_its_near_face_only(device):
    """A wall 5 mm thick (a face at x = 0 facing -x, its back at x = 0.005 facing +x), a sphere
    of radius 3 cm 1 cm into its near face: one contact, that face's, pushing the sphere back
    along -x. Its center is also within its radius behind the back face, which is no side the
    sphere presses on: a contact with it pushed the sphere on through the wall."""
    vertices = [[0, -1, -1], [0, 1, -1], [0, 1, 1], [0, -1, 1],
                [0.005, -1, -1], [0.005, 1, -1], [0.005, 1, 1], [0.005, -1, 1]]
    triangles = [[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]]
    sim = _simulator(_mesh_xml(vertices, triangles, '<body pos="-0.02 0 0"><freejoint/>'
                               '<geom type="sphere" size="0.03"/></body>'), device=device)
    _one_contact(sim, -0.01, [-1, 0, 0])


def _box(half, kind: str):
    """A box geom of half-sizes `half` as a primitive, or as a convex mesh (its 8 corners; the
    asset to add): (geom attributes, asset)."""
    if kind == "box":
        return f'type="box" size="{" ".join(map(str, half))}"', ""
    corners = " ".join(f"{sx * half[0]} {sy * half[1]} {sz * half[2]}"
                       for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1))
    name = "box_" + "_".join(str(h).replace(".", "p") for h in half)
    return f'type="mesh" mesh="{name}"', f'<mesh name="{name}" vertex="{corners}"/>'


@pytest.mark.parametrize("kind", ["box", "mesh"])
def test_a_box_over_a_table_edge_rests_on_the_edge(device, kind):
    """A box hanging 40 % over the edge of a table mesh (its center of mass over the table)
    rests level, held by its two corners on the table and the table's edge under its face; with
    60 % over the edge it tips off. Corners alone would give no support under the overhang: a
    convex mesh box meets the edge too (the edge against its hull, GJK/EPA)."""
    # the table top: a 1 m square at z = 0, x in [-1, 0]; a closed slab 0.1 m thick
    top = [[-1, -0.5, 0], [0, -0.5, 0], [0, 0.5, 0], [-1, 0.5, 0]]
    bottom = [[x, y, -0.1] for x, y, _ in top]
    vertices = np.array(top + bottom, float)
    triangles = [[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6],          # top +z, bottom -z
                 [1, 5, 6], [1, 6, 2], [0, 3, 7], [0, 7, 4],           # x = 0 (+x), x = -1
                 [0, 4, 5], [0, 5, 1], [3, 2, 6], [3, 6, 7]]           # y = -0.5, y = +0.5
    half = 0.1
    geom, asset = _box((half, 0.05, 0.05), kind)
    bodies = "".join(f'<body pos="{half * (2 * share - 1)} {0.25 * k - 0.125} {0.05 + 0.001}">'
                     f'<freejoint/><geom {geom} mass="1"/></body>'
                     for k, share in enumerate((0.4, 0.6)))
    sim = _simulator(_mesh_xml(vertices, triangles, bodies, assets=asset), device=device)
    for _ in range(120):
        sim.step()
    q = sim.q[0].cpu().numpy().reshape(-1, 7)
    # held: level (its quaternion's x, y near 0) at its half-height
    assert q[0, 2] == pytest.approx(0.05, abs=2e-3)
    assert np.abs(q[0, 3:5]).max() < 0.02
    # tipped: fell below the table top
    assert q[1, 2] < -0.05


@pytest.mark.parametrize("kind", ["box", "mesh"])
def test_a_box_lands_on_a_spike(device, kind):
    """A pyramid whose apex stands 0.2 m above a 1 m base: a box dropped onto the apex is held
    by it (a mesh vertex inside the box's face), not let through to the base as probes of the
    box's corners alone would; a convex mesh box too."""
    vertices = [[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0], [0, 0, 0.2]]
    triangles = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 2, 1], [0, 3, 2]]
    geom, asset = _box((0.05, 0.05, 0.02), kind)
    sim = _simulator(_mesh_xml(vertices, triangles,
                               f'<body pos="0 0 0.3"><freejoint/><geom {geom} mass="0.2"/>'
                               '</body>', assets=asset), device=device)
    for _ in range(30):
        sim.step()
    assert float(sim.q[0, 2]) == pytest.approx(0.22, abs=3e-3)


def _slab(lo, hi, first: int):
    """A closed box from corner lo to corner hi, triangles facing out, its vertices numbered from
    `first`: (vertices, triangles)."""
    (x0, y0, z0), (x1, y1, z1) = lo, hi
    top = [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]]
    vertices = top + [[x, y, z0] for x, y, _ in top]
    triangles = [[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6], [1, 5, 6], [1, 6, 2],
                 [0, 3, 7], [0, 7, 4], [0, 4, 5], [0, 5, 1], [3, 2, 6], [3, 6, 7]]
    return vertices, [[first + i for i in t] for t in triangles]


def test_an_ellipsoid_lies_across_two_rails(device):
    """A cigar-shaped ellipsoid (radii 0.25, 0.04, 0.04 m) laid across two rails 0.2 m apart,
    its middle over the gap: the rails' inner top edges reach into its sides, away from its
    one probe (its point deepest toward the nearest surface, which sees one rail at most), and
    hold it level at the height where they meet it (free to roll along the rails about its
    round long axis, as it does)."""
    left, t1 = _slab((-0.2, -0.5, -0.3), (-0.1, 0.5, 0.0), 0)
    right, t2 = _slab((0.1, -0.5, -0.3), (0.2, 0.5, 0.0), 8)
    sim = _simulator(_mesh_xml(left + right, t1 + t2,
                               '<body pos="0 0 0.045"><freejoint/><geom type="ellipsoid" '
                               'size="0.25 0.04 0.04" mass="0.5"/></body>'), device=device)
    for _ in range(120):
        sim.step()
    q = sim.q[0].cpu().numpy()
    rest = 0.04 * np.sqrt(1 - (0.1 / 0.25) ** 2)      # the surface's depth at x = ±0.1
    assert q[2] == pytest.approx(rest, abs=2e-3)
    x, y, z, w = q[3:7]
    assert abs(2 * (x * z - w * y)) < 0.02 and abs(q[0]) < 0.01     # its long axis level


def test_scene_places_a_triangle_mesh_for_every_env(device):
    """`Scene.add_triangle_mesh`: the bin, raised by 0.2 m and turned about z, holds a ball in
    each of two envs at the raised floor; the mesh is drawn in MuJoCo's model (a mesh geom)
    and collides in Myriad's as its triangles."""
    scene = Scene().add_triangle_mesh(BIN_VERTICES, BIN_TRIANGLES, pos=(0.0, 0.0, 0.2),
                                      quat=(0.0, 0.0, np.sin(0.3), np.cos(0.3)))
    ball = mujoco.MjSpec.from_string(
        '<mujoco><worldbody><body pos="0.1 0 0.7"><freejoint/><geom type="sphere" size="0.05" '
        'mass="0.2"/></body></worldbody></mujoco>')
    envs = scene.add_actor("ball", ball, pos=None).build(2, device=device, params=PARAMS)
    model = envs.model
    g = model.geom_names.index("triangle_mesh0")
    assert model.geom_type[g] == GeomType.TRIMESH
    assert model.mj_model.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH
    for _ in range(90):
        envs.step()
    z = envs.root_states[:, 0, 2].cpu().numpy()
    np.testing.assert_allclose(z, 0.25, atol=1e-3)


def test_ridges_are_the_edges_that_bend_away():
    """`build.ridge_edges`: of a closed slab, the 12 edges of the box and none of its faces'
    diagonals; of the open bin, the 4 rims of its walls (no neighbour) and none of its concave
    edges (floor to wall, wall to wall) or its floor's diagonal. Each edge marked once."""
    from myriad.physics.build import ridge_edges

    def marked(vertices, triangles):
        bits = ridge_edges(np.asarray(vertices, float), np.asarray(triangles))
        f = np.asarray(triangles)
        return sorted(tuple(sorted((int(f[i, j]), int(f[i, (j + 1) % 3]))))
                      for i in range(len(f)) for j in range(3) if bits[i] >> j & 1)

    slab = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], float)
    # a cube's 12 triangles, counterclockwise from outside (vertex = x + 2y + 4z)
    cube = [[0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6], [0, 1, 5], [0, 5, 4],
            [2, 6, 7], [2, 7, 3], [0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5]]
    edges = marked(slab, cube)
    assert len(edges) == 12 and len(set(edges)) == 12
    assert all(np.abs(slab[a] - slab[b]).sum() == 1 for a, b in edges)    # box edges only
    assert marked(BIN_VERTICES, BIN_TRIANGLES) == [(4, 5), (4, 7), (5, 6), (6, 7)]


def test_bad_meshes_are_refused_with_their_reason():
    scene = Scene()
    with pytest.raises(ValueError, match=r"\[V, 3\]"):
        scene.add_triangle_mesh(np.zeros((4, 2)), [[0, 1, 2]])
    with pytest.raises(ValueError, match=r"in \[0, 8\)"):
        scene.add_triangle_mesh(BIN_VERTICES, [[0, 1, 8]])
    with pytest.raises(ValueError, match="integer"):
        scene.add_triangle_mesh(BIN_VERTICES, [[0.0, 1.0, 2.0]])
    with pytest.raises(ValueError, match="zero area"):
        scene.add_triangle_mesh(BIN_VERTICES, [[0, 0, 1]])
    moving = myriad.load_xml(
        '<mujoco><asset><mesh name="m" vertex="0 0 0 1 0 0 0 1 0 0 0 1"/></asset><worldbody>'
        '<body name="lid"><freejoint/><geom name="m" type="mesh" mesh="m"/></body>'
        '<geom name="floor" type="plane" size="1 1 1"/></worldbody></mujoco>', "moving")
    with pytest.raises(ModelError, match="'lid', which moves"):
        moving.collide_as_triangles("m")
    with pytest.raises(ModelError, match="is a plane, not a mesh"):
        moving.collide_as_triangles("floor")
