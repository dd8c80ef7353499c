"""Stage 2, collision: narrowphase over the candidate geom pairs fixed when the model was built
(`pairs`), per (env, pair) on a GPU or per env on a CPU."""

from .narrowphase import (CANDIDATES_PER_SLOT, contact_bound, geom_frames, keep_deepest,
                          narrowphase, narrowphase_per_env, order_by_pair, redo_overflowed)

__all__ = ["CANDIDATES_PER_SLOT", "contact_bound", "geom_frames", "keep_deepest", "narrowphase",
           "narrowphase_per_env", "order_by_pair", "redo_overflowed"]
