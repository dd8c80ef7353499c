"""Stage 2, collision: candidate geom pairs fixed at model build, narrowphase per (env, pair)."""

from .convex import Meshes
from .narrowphase import SUPPORTED_PAIRS, ContactBuffers, geom_poses, narrowphase
from .pairs import candidate_pairs

__all__ = ["Meshes", "SUPPORTED_PAIRS", "ContactBuffers", "candidate_pairs", "geom_poses", "narrowphase"]
