"""Stage 2, collision: candidate geom pairs fixed at model build, narrowphase per (env, pair)
(on a GPU) or per env (on a CPU)."""

import numpy as np
import warp as wp

from .convex import Meshes
from .heightfield import HFields
from .narrowphase import (CANDIDATES_PER_SLOT, geom_frames, keep_deepest, narrowphase,
                          narrowphase_per_env)
from .pairs import candidate_pairs, pair_friction

__all__ = ["CANDIDATES_PER_SLOT", "HFields", "Meshes", "candidate_pairs", "geom_frames",
           "keep_deepest", "narrowphase", "narrowphase_per_env", "pair_friction", "shape_data"]


def shape_data(model, device) -> tuple[Meshes, HFields]:
    """The model's mesh vertices (with each mesh's bounding radius) and height fields on the
    device, shared by all envs."""
    def arr(a, dtype):
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=device)

    meshes = Meshes()
    verts = model.mesh_vert.reshape(-1, 3)
    meshes.vert = arr(verts, wp.vec3)
    meshes.vertadr = arr(model.mesh_vertadr, wp.int32)
    meshes.vertnum = arr(model.mesh_vertnum, wp.int32)
    meshes.rbound = arr(np.asarray([np.linalg.norm(verts[a:a + k], axis=1).max(initial=0.0)
                                    for a, k in zip(model.mesh_vertadr, model.mesh_vertnum)],
                                   np.float32), float)
    hfields = HFields()
    hfields.size = arr(model.hfield_size.reshape(-1, 4), wp.vec4)
    hfields.nrow = arr(model.hfield_nrow, wp.int32)
    hfields.ncol = arr(model.hfield_ncol, wp.int32)
    hfields.adr = arr(model.hfield_adr, wp.int32)
    hfields.data = arr(model.hfield_data, wp.float32)
    return meshes, hfields
