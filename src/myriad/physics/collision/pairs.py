"""Candidate geom pairs, decided once at model build (MuJoCo's filtering rules).

A pair (g1, g2) can touch when its geoms are on different bodies, not both static, pass the
contype/conaffinity test ((contype1 & conaffinity2) | (contype2 & conaffinity1)), are not a
parent-child body pair (unless the parent is the world), and are not excluded by an MJCF
<exclude>. Pairs are ordered so that geom type 1 <= geom type 2 (a plane always comes first);
contact normals point from geom 1 to geom 2.
"""

from __future__ import annotations

import numpy as np


def candidate_pairs(model, self_collision=True) -> np.ndarray:
    """[npair, 2] geom indices of every pair that may collide.

    `self_collision`: whether the bodies of one articulation (a tree below the world) collide with
    each other: one bool for all trees, or one per tree root body (a dict {root body: bool}).
    """
    body = model.geom_body
    parent = np.where(body >= 0, model.body_parent[np.maximum(body, 0)], -2)
    root = np.where(body >= 0, model.body_root[np.maximum(body, 0)], -1)
    excluded = {tuple(sorted(p)) for p in model.exclude_body_pairs.tolist()}
    pairs = []
    for g1 in range(model.ngeom):
        for g2 in range(g1 + 1, model.ngeom):
            b1, b2 = body[g1], body[g2]
            if b1 == b2:                       # same body, or both static
                continue
            if not ((model.geom_contype[g1] & model.geom_conaffinity[g2])
                    or (model.geom_contype[g2] & model.geom_conaffinity[g1])):
                continue
            if (b1 >= 0 and parent[g2] == b1) or (b2 >= 0 and parent[g1] == b2):
                continue                       # parent and child (the world is nobody's parent here)
            if tuple(sorted((b1, b2))) in excluded:
                continue
            if b1 >= 0 and root[g1] == root[g2]:
                allowed = self_collision if isinstance(self_collision, bool) \
                    else self_collision.get(int(root[g1]), True)
                if not allowed:
                    continue
            if model.geom_type[g1] <= model.geom_type[g2]:
                pairs.append((g1, g2))
            else:
                pairs.append((g2, g1))
    return np.asarray(pairs, dtype=np.int32).reshape(-1, 2)
