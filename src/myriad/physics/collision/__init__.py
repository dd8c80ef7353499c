"""Stage 2, collision: candidate geom pairs fixed at model build, narrowphase per (env, pair)."""

from .convex import Meshes
from .heightfield import HFields
from .narrowphase import ContactBuffers, narrowphase
from .pairs import candidate_pairs

__all__ = ["HFields", "Meshes", "ContactBuffers", "candidate_pairs", "narrowphase"]
