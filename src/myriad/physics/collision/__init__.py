"""Stage 2, collision: candidate geom pairs fixed at model build, narrowphase per (env, pair)
(on a GPU) or per env (on a CPU)."""

import numpy as np
import warp as wp

from .convex import Meshes
from .heightfield import HFields
from .narrowphase import (CANDIDATES_PER_SLOT, geom_frames, keep_deepest, narrowphase,
                          narrowphase_per_env, order_by_pair)
from .pairs import candidate_pairs, pair_friction

__all__ = ["CANDIDATES_PER_SLOT", "HFields", "Meshes", "candidate_pairs", "geom_frames",
           "keep_deepest", "narrowphase", "narrowphase_per_env", "order_by_pair", "pair_friction",
           "shape_data"]


def shape_data(model, device) -> tuple[Meshes, HFields]:
    """The vertices of each mesh's convex hull (with its bounding radius and box) and the height fields
    on the device, shared by all envs. Collision reads only the hull's corners (supports,
    probes, plane contacts): a scanned robot mesh has 10-20 times as many vertices inside or on
    its hull faces, and every support query would visit them all."""
    def arr(a, dtype):
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=device)

    verts = model.mesh_vert.reshape(-1, 3)
    hulls = [np.unique(model.mesh_hull_face[a:a + k]) for a, k in
             zip(model.mesh_hull_faceadr, model.mesh_hull_facenum)]
    corners = np.concatenate([verts[ids] for ids in hulls] + [np.zeros((0, 3), np.float32)])
    counts = np.asarray([len(ids) for ids in hulls], np.int32)
    meshes = Meshes()
    meshes.vert = arr(corners.astype(np.float32), wp.vec3)
    meshes.vertadr = arr(np.cumsum(counts) - counts, wp.int32)
    meshes.vertnum = arr(counts, wp.int32)
    meshes.rbound = arr(np.asarray([np.linalg.norm(verts[ids], axis=1).max(initial=0.0)
                                    for ids in hulls], np.float32), float)
    low = np.asarray([verts[ids].min(axis=0) if len(ids) else np.zeros(3) for ids in hulls],
                     np.float32).reshape(-1, 3)
    high = np.asarray([verts[ids].max(axis=0) if len(ids) else np.zeros(3) for ids in hulls],
                      np.float32).reshape(-1, 3)
    meshes.box_center = arr((low + high) / 2, wp.vec3)
    meshes.box_half = arr((high - low) / 2, wp.vec3)
    hfields = HFields()
    hfields.size = arr(model.hfield_size.reshape(-1, 4), wp.vec4)
    hfields.nrow = arr(model.hfield_nrow, wp.int32)
    hfields.ncol = arr(model.hfield_ncol, wp.int32)
    hfields.adr = arr(model.hfield_adr, wp.int32)
    hfields.data = arr(model.hfield_data, wp.float32)
    hfields.riser = arr(model.hfield_riser, wp.float32)
    return meshes, hfields
