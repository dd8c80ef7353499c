"""Candidate geom pairs, decided once at model build (MuJoCo's filtering rules).

A pair (g1, g2) can touch when its geoms are on different bodies, not both static (on the world
or on bodies joined to it by no joint: a fixed-base table and the wall beside it), pass the
contype/conaffinity test ((contype1 & conaffinity2) | (contype2 & conaffinity1)), are not a
parent-child body pair (unless the parent is the world) nor, with
`SimParams.filter_ancestors=2` (the default; tasks and Isaac Gym keep MuJoCo's and PhysX's 1),
a body and its grandparent, and are not excluded by an MJCF <exclude>. Bodies joined by a connect or weld equality do not collide either (PhysX's default
for jointed bodies: a weld holding two touching bodies together left their contact nothing to
do but push harder each step, and a driven arm carrying a welded tool blew up). Pairs are
ordered so that geom type 1 <= geom type 2, a static triangle mesh (TRIMESH) counted as a
height field (the ground types always come first); contact normals point from geom 1 to geom 2.

An explicit MJCF <contact><pair> (`Model.pair_geoms`) is a candidate whatever the filters above
say (contype/conaffinity, parent-child, <exclude>, a connect or weld), as in MuJoCo; the pair
that the filters would have made of the same two geoms is not added again: the explicit one,
with its own friction (`pair_friction`), replaces it. Three rules still apply to it: a pair of
geoms on one body (or both static) is dropped, since it cannot push anything; the simulator's
`self_collisions` switch, when off, turns off an articulation's explicit pairs too; and the
rule on overlaps at rest below. A pair's own margin and gap are not used: every pair has the
simulator's one contact_offset (PhysX's semantics).

One more rule MuJoCo does not have: two geoms of one articulation that overlap (by more than 0.1 mm)
in the model's initial pose (qpos0), or a fixed-base robot's link that overlaps the static
geometry it is mounted on, are not a pair, and a warning names them. Robot files often overlap
a link's collision mesh with its grandparent's (a hip mesh reaching into the base): MuJoCo's
soft contacts push such pairs apart with a bounded force, but as hard rows against joints and
limits that keep them overlapped they asked for ever larger impulses, and the robot exploded
at rest (Solo-12 in its fourth step, with no input: `benchmarks/corpus.py`).
"""

from __future__ import annotations

import warnings

import mujoco
import numpy as np

from .types import EqualityType, GeomType, JointType


def _near_ancestors(body_parent: np.ndarray, generations: int) -> set:
    """{(body, ancestor)} for the ancestors up to `generations` generations above each body
    (1: its parent), the world not among them."""
    near = set()
    for b in range(len(body_parent)):
        a = int(body_parent[b])
        for _ in range(generations):
            if a < 0:
                break
            near.add((b, a))
            a = int(body_parent[a])
    return near


def candidate_pairs(model, self_collision=True, ancestors: int = 1) -> np.ndarray:
    """[npair, 2] geom indices of every pair that may collide, the model's explicit pairs
    among them (`pair_friction` gives their friction, per candidate pair).

    `self_collision`: whether the bodies of one articulation (a tree below the world) collide with
    each other: one bool for all trees, or one per tree root body (a dict {root body: bool}).
    `ancestors`: a body does not collide with its parent, nor, from 2, with the bodies up to
    that many generations above it (`SimParams.filter_ancestors`).
    """
    body = model.geom_body
    near = _near_ancestors(model.body_parent, ancestors)
    root = np.where(body >= 0, model.body_root[np.maximum(body, 0)], -1)
    excluded = {tuple(sorted(p)) for p in model.exclude_body_pairs.tolist()}
    jointed = np.isin(model.eq_type, (EqualityType.CONNECT, EqualityType.WELD))
    excluded |= {tuple(sorted(p)) for p in
                 np.stack([model.eq_obj1, model.eq_obj2], 1)[jointed].tolist()}
    explicit = _explicit(model)
    # bodies welded to the world (no joint between them and it) move no more than the world
    static = np.where(body >= 0, model.body_static[np.maximum(body, 0)], True)
    pairs = []
    for g1 in range(model.ngeom):
        for g2 in range(g1 + 1, model.ngeom):
            b1, b2 = body[g1], body[g2]
            if b1 == b2 or (static[g1] and static[g2]):     # same body, or both static
                continue
            if (g1, g2) not in explicit:       # an explicit pair passes the model's filters
                if not ((model.geom_contype[g1] & model.geom_conaffinity[g2])
                        or (model.geom_contype[g2] & model.geom_conaffinity[g1])):
                    continue
                if (b1, b2) in near or (b2, b1) in near:
                    continue       # a parent (a grandparent too, with ancestors >= 2)
                if tuple(sorted((b1, b2))) in excluded:
                    continue
            if b1 >= 0 and root[g1] == root[g2]:
                allowed = self_collision if isinstance(self_collision, bool) \
                    else self_collision.get(int(root[g1]), True)
                if not allowed:
                    continue
            if _order(model.geom_type[g1]) <= _order(model.geom_type[g2]):
                pairs.append((g1, g2))
            else:
                pairs.append((g2, g1))
    pairs = np.asarray(pairs, dtype=np.int32).reshape(-1, 2)
    return pairs[~_overlapping_at_rest(model, pairs)]


def _order(geom_type) -> int:
    """A type's place in a pair: a static triangle mesh goes first, as terrain does."""
    return GeomType.HFIELD if geom_type == GeomType.TRIMESH else int(geom_type)


def _explicit(model) -> dict:
    """{(g1, g2) with g1 < g2: (sliding, torsional, rolling) friction} of the model's explicit
    pairs. A pair named twice (the Shadow Hand's shared.xml names one finger pair twice) is one
    candidate, with the friction of its first <pair>: MuJoCo would collide it twice, doubling
    its contacts."""
    explicit = {}
    friction = np.asarray(model.pair_friction, np.float32).reshape(-1, 3)
    for (g1, g2), mu in zip(model.pair_geoms.tolist(), friction.tolist()):
        explicit.setdefault((min(g1, g2), max(g1, g2)), mu)
    return explicit


def pair_friction(model, pairs: np.ndarray) -> np.ndarray:
    """[npair, 3] float32, per candidate pair k (`constraints.contact_rows` reads it by the
    contact's pair index, key // 32):

    - [k, 0], sliding: an explicit <pair>'s own; 0 where both geoms have condim 1 (MuJoCo's
      contact takes the larger condim of its two geoms: frictionless only if both are); -1
      where the average of the two geoms' `geom_friction` applies, randomizable per env;
    - [k, 1], torsional (m: the torque about the normal is at most this times the normal
      force), where the contact's condim is 4 or 6, else 0;
    - [k, 2], rolling (m, about the two tangents), where its condim is 6, else 0.

    The angular coefficients come from MuJoCo models only (Isaac Gym's torsion and rolling
    friction are not applied: `docs/physics.md`), and follow MuJoCo's rule for the contact of
    two geoms: the higher `priority`'s condim and friction, or with equal priorities the
    larger condim and each coefficient's larger value. An explicit pair's friction is the
    model's, the same in every env: randomizing geom_friction does not change it."""
    explicit = _explicit(model)
    condim = np.asarray(model.geom_condim)
    friction = np.asarray(model.geom_friction, np.float32).reshape(-1, 3)
    mj = getattr(model, "mj_model", None)
    priority = (np.asarray(mj.geom_priority) if mj is not None and mj.ngeom == len(condim)
                else np.zeros(len(condim), np.int32))
    out = np.zeros((len(pairs), 3), np.float32)
    for k, (g1, g2) in enumerate(pairs.tolist()):
        mu = explicit.get((min(g1, g2), max(g1, g2)))
        if mu is None:
            if priority[g1] != priority[g2]:
                g = g1 if priority[g1] > priority[g2] else g2
                dim, spin, roll = condim[g], friction[g, 1], friction[g, 2]
            else:
                dim = max(condim[g1], condim[g2])
                spin, roll = np.maximum(friction[g1, 1:3], friction[g2, 1:3])
            mu = (0.0 if condim[g1] == 1 and condim[g2] == 1 else -1.0,
                  spin if dim >= 4 else 0.0, roll if dim >= 6 else 0.0)
        out[k] = mu
    return out


def contact_width(friction: np.ndarray) -> int:
    """Rows per contact slot for candidate pairs of `pair_friction`: normal and two sliding
    rows, then a torsional row if a pair has torsional friction, then two rolling rows if one
    has rolling friction (a model of condim 3 contacts keeps three)."""
    if len(friction) and (friction[:, 2] > 0).any():
        return 6
    if len(friction) and (friction[:, 1] > 0).any():
        return 4
    return 3


# overlaps shallower than this (m) are parts meant to touch; the solver separates them gently
REST_OVERLAP = 1e-4


def _overlapping_at_rest(model, pairs: np.ndarray) -> np.ndarray:
    """Mask of the pairs between parts of one robot that overlap at qpos0 (see the module's
    docstring); warns with their names and depths."""
    body, root = model.geom_body, model.body_root
    free_root = np.array([model.body_jntnum[r] > 0
                          and model.jnt_type[model.body_jntadr[r]] == JointType.FREE
                          for r in range(model.nbody)], dtype=bool)
    ground = (GeomType.PLANE, GeomType.HFIELD, GeomType.TRIMESH)

    def same_robot(g1, g2):
        b1, b2 = body[g1], body[g2]
        if GeomType.TRIMESH in (model.geom_type[g1], model.geom_type[g2]):
            return False        # MuJoCo knows it as a hull, or as a drawn-only mesh
        if b1 >= 0 and b2 >= 0:
            return root[b1] == root[b2]
        b, static = (b2, g1) if b1 < 0 else (b1, g2)
        return not free_root[root[b]] and model.geom_type[static] not in ground

    mask = np.zeros(len(pairs), dtype=bool)
    candidates = [k for k, (g1, g2) in enumerate(pairs) if same_robot(g1, g2)]
    if not candidates:
        return mask
    mj = model.mj_model
    data = mujoco.MjData(mj)
    data.qpos[:] = mj.qpos0         # MuJoCo's own (w, x, y, z quaternions; Model's are x, y, z, w)
    mujoco.mj_kinematics(mj, data)
    found = []
    for k in candidates:
        g1, g2 = (int(g) for g in pairs[k])
        depth = mujoco.mj_geomDistance(mj, data, g1, g2, 0.0, None)
        if depth < -REST_OVERLAP:
            mask[k] = True
            found.append((depth, g1, g2))
    if found:
        found.sort()
        def name(g):      # URDF geoms have no names: their links do
            body = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_BODY, int(mj.geom_bodyid[g]))
            return mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_GEOM, g) or f"{body}'s geom {g}"

        listed = ", ".join(f"{name(g1)}-{name(g2)} ({-1e3 * depth:.1f} mm)"
                           for depth, g1, g2 in found[:5])
        more = f" and {len(found) - 5} more" if len(found) > 5 else ""
        explicit = _explicit(model)
        named = any((min(g1, g2), max(g1, g2)) in explicit for _, g1, g2 in found)
        warnings.warn(f"{model.source}: {len(found)} geom pair(s) of one robot overlap in its "
                      f"initial pose and will not collide: {listed}{more}. Add "
                      "<contact><exclude> for them" + (" (and remove their <pair>)" if named
                                                       else "") + " to silence this.",
                      RuntimeWarning, stacklevel=4)
    return mask
