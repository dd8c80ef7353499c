"""A model's geoms as the viewer draws them: triangle meshes in their body's frame, with the
model's own colours, from MuJoCo's compiled model (the one `myriad.load` keeps as `mj_model`).

Drawn: the geoms MuJoCo's own viewer shows by default (groups 0-2) that are not fully
transparent. Planes are drawn as a grid by the page, not as a mesh; height fields as the
triangle grid of their samples.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

DRAWN_GROUPS = 3         # MuJoCo's viewer shows groups 0, 1 and 2 unless told otherwise


@dataclass
class Shape:
    """One geom ready to draw."""
    geom: int               # MuJoCo geom id
    body: int               # MuJoCo body id (0: the world)
    name: str
    vertices: np.ndarray    # [V, 3] float32, in the geom's frame (m)
    faces: np.ndarray       # [F, 3] int32
    pos: np.ndarray         # [3] geom position in its body's frame (m)
    wxyz: np.ndarray        # [4] geom orientation in its body's frame
    rgb: tuple[int, int, int]
    opacity: float


def geom_color(m: mujoco.MjModel, g: int) -> np.ndarray:
    """RGBA in [0, 1]: the material's when the geom has one, else the geom's."""
    mat = int(m.geom_matid[g])
    return np.array(m.mat_rgba[mat] if mat >= 0 else m.geom_rgba[g], dtype=np.float64)


def geom_triangles(m: mujoco.MjModel, g: int):
    """(vertices [V, 3], faces [F, 3]) of geom g in its own frame, or None for a plane."""
    import trimesh

    kind, size = int(m.geom_type[g]), np.asarray(m.geom_size[g], dtype=np.float64)
    G = mujoco.mjtGeom
    if kind == G.mjGEOM_PLANE:
        return None
    if kind == G.mjGEOM_SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    elif kind == G.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.vertices = mesh.vertices * size[:3]
    elif kind == G.mjGEOM_CAPSULE:          # half-length size[1] along z, radius size[0]
        mesh = trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[16, 8])
    elif kind == G.mjGEOM_CYLINDER:
        mesh = trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=24)
    elif kind == G.mjGEOM_BOX:
        mesh = trimesh.creation.box(extents=2 * size[:3])
    elif kind == G.mjGEOM_MESH:
        k = int(m.geom_dataid[g])
        v0, nv = int(m.mesh_vertadr[k]), int(m.mesh_vertnum[k])
        f0, nf = int(m.mesh_faceadr[k]), int(m.mesh_facenum[k])
        return (np.asarray(m.mesh_vert[v0:v0 + nv], dtype=np.float32),
                np.asarray(m.mesh_face[f0:f0 + nf], dtype=np.int32))
    elif kind == G.mjGEOM_HFIELD:
        return hfield_triangles(m, int(m.geom_dataid[g]))
    else:
        raise ValueError(f"geom {g}: MuJoCo geom type {kind} has no drawing")
    return np.asarray(mesh.vertices, dtype=np.float32), np.asarray(mesh.faces, dtype=np.int32)


def hfield_triangles(m: mujoco.MjModel, k: int):
    """The height field's samples as a grid of triangles (MuJoCo's layout: rows along y, columns
    along x, size = (x half-extent, y half-extent, top, base))."""
    rows, cols = int(m.hfield_nrow[k]), int(m.hfield_ncol[k])
    adr = int(m.hfield_adr[k])
    heights = np.asarray(m.hfield_data[adr:adr + rows * cols], dtype=np.float64).reshape(rows, cols)
    sx, sy, top, _ = m.hfield_size[k]
    x, y = np.meshgrid(np.linspace(-sx, sx, cols), np.linspace(-sy, sy, rows))
    vertices = np.stack([x, y, heights * top], axis=-1).reshape(-1, 3).astype(np.float32)
    i = np.arange(rows - 1)[:, None] * cols + np.arange(cols - 1)[None, :]
    a, b, c, d = i, i + 1, i + cols, i + cols + 1
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3),
                            np.stack([a, d, c], -1).reshape(-1, 3)]).astype(np.int32)
    return vertices, faces


def shapes(m: mujoco.MjModel) -> tuple[list[Shape], list[int]]:
    """(the drawn geoms as `Shape`s, the plane geoms' ids)."""
    out, planes = [], []
    for g in range(m.ngeom):
        rgba = geom_color(m, g)
        if int(m.geom_group[g]) >= DRAWN_GROUPS or rgba[3] <= 0.0:
            continue
        tri = geom_triangles(m, g)
        if tri is None:
            planes.append(g)
            continue
        name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or f"geom{g}"
        out.append(Shape(g, int(m.geom_bodyid[g]), name, tri[0], tri[1],
                         np.array(m.geom_pos[g]), np.array(m.geom_quat[g]),
                         tuple(int(round(255 * c)) for c in rgba[:3]), float(rgba[3])))
    return out, planes
