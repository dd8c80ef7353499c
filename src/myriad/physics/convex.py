"""Convex decomposition of a triangle mesh file (V-HACD 4 through `vhacdx`), cached on disk.

MuJoCo collides a mesh as its convex hull, so a non-convex collision mesh (a bowl, a finger's
hollow link, an arena's border) needs cutting into convex pieces to collide as its shape.
`convex_pieces` returns the paths of `.obj` files, one per piece, already scaled.
"""

from __future__ import annotations

import hashlib
import json
import os

import numpy as np

_CACHE = os.path.join(os.path.expanduser("~"), ".cache", "myriad", "vhacd")


def convex_pieces(file: str, scale=(1.0, 1.0, 1.0), max_hulls: int = 10,
                  resolution: int = 100_000, max_vertices: int = 64) -> list[str]:
    """The convex pieces of the mesh in `file` (any format trimesh reads), scaled by `scale`:
    a list of `.obj` paths in ~/.cache/myriad/vhacd (made once per file content and settings).
    Raises ImportError without vhacdx and trimesh."""
    import trimesh
    import vhacdx

    with open(file, "rb") as f:
        content = f.read()
    settings = dict(scale=[float(s) for s in scale], max_hulls=int(max_hulls),
                    resolution=int(resolution), max_vertices=int(max_vertices))
    key = hashlib.sha1(content + json.dumps(settings, sort_keys=True).encode()).hexdigest()[:16]
    folder = os.path.join(_CACHE, f"{os.path.splitext(os.path.basename(file))[0]}-{key}")
    done = os.path.join(folder, "pieces.json")
    if os.path.isfile(done):
        with open(done) as f:
            return [os.path.join(folder, name) for name in json.load(f)]
    mesh = trimesh.load(file, force="mesh")
    vertices = np.asarray(mesh.vertices, np.float64) * np.asarray(settings["scale"])
    hulls = vhacdx.compute_vhacd(vertices, np.asarray(mesh.faces, np.uint32),
                                 maxConvexHulls=max(settings["max_hulls"], 1),
                                 resolution=max(settings["resolution"], 10_000),
                                 maxNumVerticesPerCH=max(settings["max_vertices"], 4))
    os.makedirs(folder, exist_ok=True)
    names = []
    for k, (points, faces) in enumerate(hulls):
        centred = np.asarray(points) - np.mean(points, axis=0)
        if len(faces) < 4 or np.linalg.svd(centred, compute_uv=False)[-1] < 1e-7:
            continue                # flat: no volume, and MuJoCo cannot make its hull
        name = f"piece{k}.obj"
        trimesh.Trimesh(points, faces, process=False).export(os.path.join(folder, name),
                                                            file_type="obj")
        names.append(name)
    if not names:
        raise ValueError(f"{file}: V-HACD found no convex piece")
    with open(done + ".part", "w") as f:
        json.dump(names, f)
    os.replace(done + ".part", done)
    return [os.path.join(folder, name) for name in names]


def convex_pieces_of(vertices: np.ndarray, triangles: np.ndarray, **settings) -> list[str]:
    """`convex_pieces` of a mesh given as arrays (vertices [n, 3] m, triangles [m, 3]): written
    once as an `.obj` in the cache, then cut as a file is."""
    import trimesh

    vertices = np.ascontiguousarray(vertices, dtype=np.float64).reshape(-1, 3)
    triangles = np.ascontiguousarray(triangles, dtype=np.int64).reshape(-1, 3)
    key = hashlib.sha1(vertices.tobytes() + triangles.tobytes()).hexdigest()[:16]
    file = os.path.join(_CACHE, f"mesh-{key}.obj")
    if not os.path.isfile(file):
        os.makedirs(_CACHE, exist_ok=True)
        trimesh.Trimesh(vertices, triangles, process=False).export(file + ".part.obj",
                                                                   file_type="obj")
        os.replace(file + ".part.obj", file)
    return convex_pieces(file, **settings)

