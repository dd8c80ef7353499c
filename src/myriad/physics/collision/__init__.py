"""Stage 2, collision: candidate geom pairs fixed at model build, narrowphase per (env, pair)
(on a GPU) or per env (on a CPU)."""

from .convex import Meshes
from .heightfield import HFields
from .narrowphase import ContactBuffers, narrowphase, narrowphase_per_env
from .pairs import candidate_pairs

__all__ = ["HFields", "Meshes", "ContactBuffers", "candidate_pairs", "narrowphase",
           "narrowphase_per_env"]
