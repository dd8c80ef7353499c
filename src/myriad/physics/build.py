"""Building the engine's data on its device, once: everything the step derives from a `Model`
at start-up, the way MuJoCo Warp's `io.py` builds its device model.

    dm = device_model(model, params, device)    # shared by all envs: `DeviceModel`
    data = allocate_data(dm, num_envs)           # per env: `Data`, every declared struct

`device_model` decides everything fixed for the simulator's life, in one place: the candidate
geom pairs (`pairs`), the tree spans and the mass matrix's sparse layout, the equality, limit
and row layouts, the constraint row width, the collision shapes, the step's `Options`, the
sizes that the per-env declarations (`structs`) are allocated with, and the initial values of
the per-env parameters and state. Nothing here runs per step.
"""

from __future__ import annotations

import dataclasses
import mmap

import numpy as np
import warp as wp

from . import pairs as pair_rules
from .model import Model, ModelError, dof_tree_spans
from .params import SimParams
from .runtime.launch import block_threads
from .stages.collision import CANDIDATES_PER_SLOT, contact_bound
from .stages.solver_tgs import BLOCK_CAPS
from .structs import (STRUCTS, Control, Contacts, Dynamics, EnvParams, HFields, Meshes,
                      ModelArrays, Options, RowLayout, Rows, State, field_shape)
from .types import EqualityType, GeomType, SensorType


@dataclasses.dataclass
class DeviceModel:
    """What the step reads that is the same for every env, on the device."""
    m: ModelArrays            # the structure: tree, joints, geoms, actuators, ...
    opt: Options              # substep length, solver settings, limited joints and tendons
    layout: RowLayout         # where each family of constraint rows starts
    pairs: wp.array           # [npair] vec2i: candidate geom pairs, fixed (`pairs`)
    meshes: Meshes
    hfields: HFields
    triangle_meshes: list     # the `wp.Mesh` BVHs that `meshes.bvh` names (kept alive here)
    sizes: dict               # the named sizes of the per-env declarations ("nv", "nrow", ...)
    sensor_sites: list        # sites carrying a force or torque sensor (rows of sensor_wrench)
    sensor_site: wp.array     # [nsensor_site] int32: those sites
    sensor_site_body: wp.array   # [nsensor_site] int32: their bodies
    sensor_accelerations: bool   # a sensor reads accelerations or forces between bodies
    sensor_split: bool           # force sensors also split as PhysX reports them (Model.force_sensor_split)
    activations: bool         # an actuator has activation dynamics (`forces.integrate_activations`)
    implicit: bool            # SimParams.integrator == "implicit" (`dynamics.implicit_acceleration`)
    mass_entries: np.ndarray  # [2, nmass] (row, column) of each stored mass-matrix entry
    initial: dict             # per-env struct -> {field: one env's initial value}

    @property
    def contact_capacity(self) -> int:
        return self.layout.contact_slots

    @property
    def nrow(self) -> int:
        return self.layout.end


class Data:
    """Every per-env struct of one simulator (`structs.STRUCTS`), allocated once; `structs`
    maps each struct type to its instance."""

    def __init__(self, structs: dict):
        self.structs = structs
        self.env_params: EnvParams = structs[EnvParams]
        self.state: State = structs[State]
        self.control: Control = structs[Control]
        self.dynamics: Dynamics = structs[Dynamics]
        self.contacts: Contacts = structs[Contacts]
        self.rows: Rows = structs[Rows]

    def arrays(self):
        """(struct, field name, array) of every per-env array."""
        for struct, instance in self.structs.items():
            for name in struct.fields:
                yield struct, name, getattr(instance, name)


def device_model(model: Model, params: SimParams, device) -> DeviceModel:
    """Everything fixed for the life of a simulator of `model` with `params` on `device`."""
    m, dev = model, device
    # model-wide collision data: candidate pairs fixed now (with the friction of the explicit
    # ones, in ModelArrays), shapes, meshes, height fields
    pairs = (pair_rules.candidate_pairs(model, params.self_collisions, params.filter_ancestors)
             if params.constraints else np.zeros((0, 2), np.int32))
    # contact slots: the setting, but never more than the pairs can fill (the ant's 13 pairs
    # with the floor: 25 of 64), and narrowphase places up to CANDIDATES_PER_SLOT per slot for
    # `keep_deepest` to choose from, again no more than the pairs can fill
    most = contact_bound(m.geom_type, pairs)
    contact_capacity = min(params.contacts_per_env, most)
    candidate_places = min(CANDIDATES_PER_SLOT * contact_capacity, most)
    meshes, hfields, triangle_meshes = shape_data(model, dev)

    # constraint rows: 3 per contact slot (4 or 6 with torsional or rolling friction), 2 per
    # limited joint, 2 per limited tendon, one spring-damper row per tendon (present with or
    # without `constraints`), and one row per dof for joint friction and the maximum joint speed
    limited = [j for j in range(m.njnt) if m.jnt_limited[j] and params.constraints]
    limited_tendons = [t for t in range(m.ntendon) if m.tendon_limited[t] and params.constraints]
    equality_rownum = int(equality_rows(m)["eq_rownum"].sum()) if params.constraints else 0
    friction = pair_rules.pair_friction(model, pairs)
    layout = row_layout(contact_capacity, pair_rules.contact_width(friction), len(limited),
                        len(limited_tendons), equality_rownum, m.ntendon,
                        m.nv if params.constraints else 0)
    dof_span = tree_spans(model)[0]
    tendon_dofs = [np.arange(*m.tendon_dofspan[t]) if m.tendon_spatial[t] >= 0
                   else m.jnt_dofadr[m.wrap_jnt[a:a + k]]
                   for t, (a, k) in enumerate(zip(m.tendon_adr, m.tendon_num))]
    # a tendon equality's row spans both tendons' dofs
    tendon_dofs += [np.concatenate([tendon_dofs[t] for t in (t1, t2) if t >= 0])
                    for kind, t1, t2 in zip(m.eq_type, m.eq_obj1, m.eq_obj2)
                    if kind == EqualityType.TENDON]
    madr, mnum, mass_col = mass_matrix_layout(m.dof_parent)

    opt = Options()
    opt.h = params.dt / params.substeps
    opt.position_iterations = params.position_iterations
    opt.velocity_iterations = params.velocity_iterations
    opt.tgs = int(params.solver == "tgs")
    opt.contact_offset = params.contact_offset
    opt.rest_offset = params.rest_offset
    opt.bounce_threshold = params.bounce_threshold_velocity
    opt.max_depenetration = params.max_depenetration_velocity
    opt.max_correction = params.max_correction_velocity
    opt.limit_jnt = wp.array(np.asarray(limited, np.int32), dtype=wp.int32, device=dev)
    opt.limit_dof = wp.array(np.asarray(m.jnt_dofadr, np.int32)[np.asarray(limited, np.int64)],
                             dtype=wp.int32, device=dev)
    opt.limit_tendon = wp.array(np.asarray(limited_tendons, np.int32), dtype=wp.int32, device=dev)

    # sensors (`stages.sensors`): one 6D wrench per site that carries a force or torque sensor,
    # and the Newton-Euler pass that gives it (and every body's acceleration) only when a
    # sensor reads accelerations or forces between bodies
    sensor_sites = m.force_sensor_sites
    sensor_accelerations = bool(np.isin(m.sensor_type, [
        SensorType.FORCE, SensorType.TORQUE, SensorType.ACCELEROMETER,
        SensorType.FRAMELINACC, SensorType.FRAMEANGACC]).any())

    # contacts the joint-limit block may take in (`SimParams.limit_block_contacts`)
    block_contacts = min(contact_capacity, params.limit_block_contacts) if len(limited) else 0
    # ... and the dofs past their speed cap it solves with them (`solver_tgs.BLOCK_CAPS`)
    block_caps = min(m.nv, BLOCK_CAPS) if len(limited) else 0
    sizes = dict(nq=m.nq, nv=m.nv, nbody=m.nbody, njnt=m.njnt, nu=m.nu, ntendon=m.ntendon,
                 nmocap=m.nmocap, nspatial=int((m.tendon_spatial >= 0).sum()),
                 ngeom=m.ngeom, nsite=m.nsite, nsensor_site=len(sensor_sites),
                 nsensor_split=len(sensor_sites) if m.force_sensor_split else 0,
                 nsensordata=m.nsensordata, ncontact=contact_capacity,
                 ncandidate=candidate_places, nrow=layout.end,
                 row_width=row_width(dof_span, tendon_dofs), nmass=len(mass_col),
                 nlimit=2 * len(limited), nblock_contact=block_contacts, nblock_cap=block_caps,
                 nblock=2 * len(limited) + block_contacts + block_caps, neq=m.neq,
                 neqrow=equality_rownum,
                 nlane=block_threads(dev))
    implicit = params.integrator == "implicit"
    if implicit and not depth_first(m.body_parent):     # its kernel walks subtrees as ranges
        raise ModelError(f"{m.source}: integrator='implicit' needs the bodies in depth-first "
                         "order (each one's descendants right after it), as MuJoCo compiles them")
    tree_width = int((dof_span[:, 1] - dof_span[:, 0]).max()) if m.nv else 0
    sizes.update(nbody_implicit=m.nbody if implicit else 0, nv_implicit=m.nv if implicit else 0,
                 tree_implicit=tree_width if implicit else 0)
    mocap = np.argsort(np.where(m.body_mocapid >= 0, m.body_mocapid, m.nbody))[:m.nmocap]
    gravity = m.gravity if params.gravity is None else np.asarray(params.gravity)
    initial = {
        EnvParams: dict(
            body_mass=m.body_mass, body_inertia=m.body_inertia,
            geom_friction=m.geom_friction[:, 0], geom_restitution=np.zeros(m.ngeom),
            geom_size=m.geom_size, geom_pos=m.geom_pos, site_pos=m.site_pos.reshape(-1, 3),
            joint_stiffness=m.jnt_stiffness, joint_range=m.jnt_range.reshape(-1, 2),
            dof_damping=m.dof_damping, dof_armature=m.dof_armature,
            dof_frictionloss=m.dof_frictionloss,
            dof_max_velocity=np.full(m.nv, params.max_joint_velocity),
            body_max_angular_velocity=np.full(m.nbody, params.max_angular_velocity),
            body_max_linear_velocity=np.full(m.nbody, params.max_linear_velocity),
            actuator_gear=m.actuator_gear, actuator_gain=m.actuator_gain,
            actuator_kp=m.actuator_kp, actuator_kv=m.actuator_kv,
            tendon_stiffness=m.tendon_stiffness, tendon_damping=m.tendon_damping,
            tendon_range=m.tendon_range.reshape(-1, 2),
            tendon_limit_stiffness=m.tendon_limit_stiffness,
            tendon_rest_length=m.tendon_rest_length, tendon_offset=m.tendon_offset,
            gravity=gravity, fluid_density=m.density, fluid_viscosity=m.viscosity, wind=m.wind,
            eq_active=m.eq_active & params.constraints,
            eq_anchor=m.eq_anchor, eq_frame=m.eq_frame, eq_polycoef=m.eq_polycoef),
        State: dict(q=m.qpos0, mocap_pos=m.body_pos[mocap], mocap_quat=m.body_quat[mocap]),
    }
    return DeviceModel(
        m=model_arrays(model, dev, friction), opt=opt,
        layout=layout, pairs=wp.array(pairs, dtype=wp.vec2i, device=dev), meshes=meshes,
        hfields=hfields, triangle_meshes=triangle_meshes, sizes=sizes, sensor_sites=sensor_sites,
        sensor_site=wp.array(np.asarray(sensor_sites, np.int32), dtype=wp.int32, device=dev),
        sensor_site_body=wp.array(np.asarray(m.site_body[sensor_sites], np.int32)
                                  if sensor_sites else np.zeros(0, np.int32),
                                  dtype=wp.int32, device=dev),
        sensor_accelerations=sensor_accelerations,
        sensor_split=bool(m.force_sensor_split and sensor_sites),
        activations=bool(np.any(m.actuator_dyntype != 0)), implicit=implicit,
        mass_entries=np.stack([np.repeat(np.arange(m.nv), mnum), mass_col]), initial=initial)


def allocate_data(dm: DeviceModel, num_envs: int, device) -> Data:
    """Every per-env struct for `num_envs` envs, initialized from the model (`dm.initial`)."""
    return Data({struct: allocate(struct, num_envs, dm.sizes, device, dm.initial.get(struct))
                 for struct in STRUCTS})


# ------------------------------------------------------------------ the model's derived layouts
def tree_spans(model) -> tuple[np.ndarray, np.ndarray]:
    """[lo, hi) of the dof tree of each dof [nv, 2] (`model.dof_tree_spans`) and of each body's
    moving dofs [nbody, 2]."""
    dof_span = dof_tree_spans(model.dof_parent)
    body_span = np.zeros((model.nbody, 2), np.int32)
    moved = model.body_last_dof >= 0
    body_span[moved] = dof_span[model.body_last_dof[moved]]
    return dof_span, body_span


def subtree_ends(body_parent: np.ndarray) -> np.ndarray:
    """[nbody] int32: one past the last descendant of each body. In MuJoCo's depth-first order
    (`depth_first`) body b's subtree is the bodies b .. end - 1."""
    end = np.arange(1, len(body_parent) + 1, dtype=np.int32)
    for b in range(len(body_parent) - 1, -1, -1):      # children first, up to their parents
        if body_parent[b] >= 0:
            end[body_parent[b]] = max(end[body_parent[b]], end[b])
    return end


def depth_first(body_parent: np.ndarray) -> bool:
    """Whether every body's descendants follow it directly (MuJoCo compiles bodies so)."""
    n = len(body_parent)
    children = [[] for _ in range(n)]
    for b in range(n):
        if body_parent[b] >= 0:
            children[body_parent[b]].append(b)
    order, stack = [], [b for b in range(n - 1, -1, -1) if body_parent[b] < 0]
    while stack:
        b = stack.pop()
        order.append(b)
        stack.extend(reversed(children[b]))
    return order == list(range(n))


def mass_matrix_layout(dof_parent: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(dof_madr [nv], dof_mnum [nv], mass_col [nmass]): where the entries of M that can be
    nonzero sit in a per-env array of nmass floats (MuJoCo's sparse mass matrix, lower half).

    M(i, j) is nonzero only for j = i or an ancestor of i on its `dof_parent` chain. Dof i's row
    holds those entries contiguously from dof_madr[i]: (i, i), then (i, parent), (i,
    grandparent), ... (dof_mnum[i] of them); mass_col gives each entry's column. Since the
    ancestors of an ancestor j are the rest of i's chain, j's row and the tail of i's row from
    (i, j) on have the same columns in the same order: the factorization and the solves run
    over contiguous entries instead of walking `dof_parent`.
    """
    cols = []
    for i in range(len(dof_parent)):
        chain = [i]
        while dof_parent[chain[-1]] >= 0:
            chain.append(int(dof_parent[chain[-1]]))
        cols.append(chain)
    mnum = np.asarray([len(c) for c in cols], np.int32)
    madr = (np.cumsum(mnum) - mnum).astype(np.int32)
    mass_col = np.asarray([j for c in cols for j in c], np.int32)
    return madr, mnum, mass_col


def tree_levels(model) -> dict:
    """The bodies by depth and each body's children (`ModelArrays.level_adr` ...), the dof
    trees, and each dof's actuator transmission entries: the index lists that let a kernel's lanes share a world's
    bodies, trees or dofs."""
    depth = np.zeros(model.nbody, np.int32)
    for b in range(model.nbody):                   # parents come first in MuJoCo's order
        if model.body_parent[b] >= 0:
            depth[b] = depth[model.body_parent[b]] + 1
    nlevel = int(depth.max()) + 1 if model.nbody else 0
    level_body = np.argsort(depth, kind="stable").astype(np.int32)
    level_adr = np.searchsorted(depth[level_body], np.arange(nlevel + 1)).astype(np.int32)
    children = [[] for _ in range(model.nbody)]
    for b in range(model.nbody - 1, -1, -1):       # highest index first
        if model.body_parent[b] >= 0:
            children[model.body_parent[b]].append(b)
    child_num = np.asarray([len(c) for c in children], np.int32)
    dof_span = tree_spans(model)[0]
    acts = [np.flatnonzero(model.trn_dof == i) for i in range(model.nv)]   # in actuator order
    act_num = np.asarray([len(a) for a in acts], np.int32)
    return dict(nlevel=nlevel, level_adr=level_adr, level_body=level_body,
                body_child_adr=(np.cumsum(child_num) - child_num).astype(np.int32),
                body_child_num=child_num,
                body_child=np.asarray([c for cs in children for c in cs], np.int32),
                ntree=len(np.unique(dof_span[:, 0])),
                tree_dofs=np.unique(dof_span, axis=0).reshape(-1, 2).astype(np.int32),
                dof_trn_adr=(np.cumsum(act_num) - act_num).astype(np.int32),
                dof_trn_num=act_num,
                dof_trn=np.concatenate(acts + [np.zeros(0, np.int64)]).astype(np.int32))


def equality_rows(model) -> dict:
    """eq_rowadr, eq_rownum: each equality constraint's rows within the equality family."""
    rownum = np.asarray([6 if t == EqualityType.WELD and rot else
                         3 if t in (EqualityType.CONNECT, EqualityType.WELD) else 1
                         for t, rot in zip(model.eq_type, model.eq_rotation)], np.int32)
    return dict(eq_rownum=rownum, eq_rowadr=(np.cumsum(rownum) - rownum).astype(np.int32))


def model_arrays(model, device, pair_friction=None) -> ModelArrays:
    """`model` on the device: each field of ModelArrays is the Model's attribute of the same
    name, except the few derived here. `pair_friction`: per candidate pair of the simulator
    (`pairs.pair_friction`); None: no candidate pairs."""
    dof_span, body_span = tree_spans(model)
    madr, mnum, mass_col = mass_matrix_layout(model.dof_parent)
    sites = model.force_sensor_sites
    slot = [sites.index(int(o)) if t in (SensorType.FORCE, SensorType.TORQUE) else -1
            for t, o in zip(model.sensor_type, model.sensor_objid)]
    derived = dict(dof_tree_span=dof_span, body_tree_span=body_span,
                   body_subtree_end=subtree_ends(model.body_parent),
                   dof_madr=madr, dof_mnum=mnum, mass_col=mass_col,
                   **equality_rows(model), **tree_levels(model),
                   sensor_slot=np.asarray(slot, np.int32),
                   spatial_tendon=np.flatnonzero(model.tendon_spatial >= 0).astype(np.int32),
                   body_fluid_ellipsoid=np.asarray(
                       [bool((model.geom_fluid[a:a + n, 0] > 0).any())
                        for a, n in zip(model.body_geomadr, model.body_geomnum)], np.int32),
                   pair_friction=np.zeros((0, 3), np.float32) if pair_friction is None
                   else pair_friction)
    out = ModelArrays()
    for name, var in ModelArrays.vars.items():
        value = derived[name] if name in derived else getattr(model, name)
        if not isinstance(var.type, wp.array):       # a size
            setattr(out, name, int(value))
            continue
        dtype = var.type.dtype
        scalar = getattr(dtype, "_wp_scalar_type_", dtype)       # of a vector type, or itself
        value = np.ascontiguousarray(value, {wp.float32: np.float32, wp.int32: np.int32}[scalar])
        if scalar is not dtype:
            value = value.reshape(-1, dtype._length_)
        setattr(out, name, wp.array(value, dtype=dtype, device=device))
    return out


# ------------------------------------------------------------------ constraint rows
def row_layout(contact_slots: int, contact_width: int, limited_joints: int,
               limited_tendons: int, equality_rows: int, tendons: int,
               dof_rows: int) -> RowLayout:
    layout = RowLayout()
    layout.contact_slots = contact_slots
    layout.contact_width = contact_width
    layout.joint_limits = contact_width * contact_slots
    layout.tendon_limits = layout.joint_limits + 2 * limited_joints
    layout.equalities = layout.tendon_limits + 2 * limited_tendons
    layout.springs = layout.equalities + equality_rows
    layout.dofs = layout.springs + tendons
    layout.end = layout.dofs + dof_rows
    return layout




def row_width(dof_tree_span, tendon_dofs) -> int:
    """Columns a row needs: its widest possible span, at most nv. A contact touches two dof
    trees at most, a tendon row the trees between its joints' (one range), any other row one
    tree. `dof_tree_span` [nv, 2] per dof; `tendon_dofs` the dofs of each tendon's joints."""
    nv = len(dof_tree_span)
    sizes = sorted({(int(lo), int(hi)) for lo, hi in dof_tree_span}, key=lambda s: s[0] - s[1])
    widest = sum(hi - lo for lo, hi in sizes[:2])
    for dofs in tendon_dofs:
        if len(dofs):
            spans = dof_tree_span[list(dofs)]
            widest = max(widest, int(spans[:, 1].max() - spans[:, 0].min()))
    return min(widest, nv)


# ------------------------------------------------------------------ collision shapes
# a triangle mesh's edge is a ridge (it can reach into a shape between the shape's probes)
# where its two faces meet at more than this angle, convex; a flat run of triangles has none
RIDGE_ANGLE = np.radians(10.0)


def ridge_edges(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """[nface] int32: bit j set where edge j of a face (its vertices j, j + 1) is a ridge: its
    neighbour across it bends away (convex) by more than RIDGE_ANGLE, or it has no neighbour
    (the rim of an open surface), or more than one. An edge of two faces is marked in one of
    them (the one that walks it from its lower vertex id), so that it is met once."""
    v = np.asarray(vertices, np.float64)
    f = np.asarray(faces, np.int64)
    normal = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-30)
    nf = len(f)
    a = f.reshape(-1)                                   # edge 3·face + j: f[j] -> f[j + 1]
    b = f[:, [1, 2, 0]].reshape(-1)
    third = f[:, [2, 0, 1]].reshape(-1)
    key = np.minimum(a, b) * (int(v.shape[0]) + 1) + np.maximum(a, b)
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]
    start = np.r_[True, sorted_key[1:] != sorted_key[:-1]]
    group = np.cumsum(start) - 1
    size = np.bincount(group)[group]
    # the twin of each edge of a pair: its group's other member
    first = np.flatnonzero(start)[group]
    twin = np.where(np.arange(len(order)) == first, first + 1, first)
    twin = order[np.minimum(twin, len(order) - 1)]
    edge = order
    face = edge // 3
    other = twin // 3
    bends = (np.einsum("ij,ij->i", normal[face], normal[other]) < np.cos(RIDGE_ANGLE)) & \
        (np.einsum("ij,ij->i", v[third[twin]] - v[a[edge]], normal[face]) < 0.0)
    ridge = np.where(size == 2, bends & (a[edge] < b[edge]), True)
    bits = np.zeros(3 * nf, np.int32)
    bits[edge] = ridge
    return (bits.reshape(nf, 3) << np.arange(3)).sum(axis=1).astype(np.int32)


def shape_data(model, device) -> tuple[Meshes, HFields, list]:
    """The vertices of each mesh's convex hull (with its bounding radius and box), the
    triangle meshes' BVHs and the height fields on the device, shared by all envs. Collision
    reads only the hull's corners (supports, probes, plane contacts): a scanned robot mesh has
    10-20 times as many vertices inside or on its hull faces, and every support query would
    visit them all. A mesh a TRIMESH geom uses gets a `wp.Mesh` of its own triangles (the
    third value: they must live as long as the ids in `Meshes.bvh`), and its bounds hold all
    of its vertices."""
    def arr(a, dtype):
        return wp.array(np.ascontiguousarray(a), dtype=dtype, device=device)

    verts = model.mesh_vert.reshape(-1, 3)
    triangles = set(model.geom_dataid[model.geom_type == GeomType.TRIMESH].tolist())
    hulls = [np.unique(model.mesh_hull_face[a:a + k]) for a, k in
             zip(model.mesh_hull_faceadr, model.mesh_hull_facenum)]
    corners = np.concatenate([verts[ids] for ids in hulls] + [np.zeros((0, 3), np.float32)])
    counts = np.asarray([len(ids) for ids in hulls], np.int32)
    bounded = [np.arange(a, a + k) if i in triangles else hulls[i]
               for i, (a, k) in enumerate(zip(model.mesh_vertadr, model.mesh_vertnum))]
    meshes = Meshes()
    meshes.vert = arr(corners.astype(np.float32), wp.vec3)
    meshes.vertadr = arr(np.cumsum(counts) - counts, wp.int32)
    meshes.vertnum = arr(counts, wp.int32)
    meshes.rbound = arr(np.asarray([np.linalg.norm(verts[ids], axis=1).max(initial=0.0)
                                    for ids in bounded], np.float32), float)
    low = np.asarray([verts[ids].min(axis=0) if len(ids) else np.zeros(3) for ids in bounded],
                     np.float32).reshape(-1, 3)
    high = np.asarray([verts[ids].max(axis=0) if len(ids) else np.zeros(3) for ids in bounded],
                      np.float32).reshape(-1, 3)
    meshes.box_center = arr((low + high) / 2, wp.vec3)
    meshes.box_half = arr((high - low) / 2, wp.vec3)
    bvhs, ridges, ridgeadr, used = {}, [], np.zeros(len(counts), np.int32), 0
    for i in sorted(triangles):
        a, k = model.mesh_vertadr[i], model.mesh_vertnum[i]
        f, nf = model.mesh_faceadr[i], model.mesh_facenum[i]
        faces = model.mesh_face[f:f + nf].reshape(-1, 3)
        bvhs[i] = wp.Mesh(points=arr(verts[a:a + k].astype(np.float32), wp.vec3),
                          indices=arr(faces.reshape(-1), wp.int32))
        ridges.append(ridge_edges(verts[a:a + k], faces))
        ridgeadr[i] = used
        used += nf
    meshes.bvh = arr(np.asarray([bvhs[i].id if i in bvhs else 0 for i in range(len(counts))],
                                np.uint64), wp.uint64)
    meshes.ridge = arr(np.concatenate(ridges) if ridges else np.zeros(0, np.int32), wp.int32)
    meshes.ridgeadr = arr(ridgeadr, wp.int32)
    hfields = HFields()
    hfields.size = arr(model.hfield_size.reshape(-1, 4), wp.vec4)
    hfields.nrow = arr(model.hfield_nrow, wp.int32)
    hfields.ncol = arr(model.hfield_ncol, wp.int32)
    hfields.adr = arr(model.hfield_adr, wp.int32)
    hfields.data = arr(model.hfield_data, wp.float32)
    hfields.riser = arr(model.hfield_riser, wp.float32)
    return meshes, hfields, list(bvhs.values())


# ------------------------------------------------------------------ per-env memory
def allocate(struct, num_envs: int, sizes: dict, device, values: dict | None = None):
    """An instance of `struct` with every field allocated: zeros, or the per-env copy of
    values[name] (one env's value, broadcast to all). On a CPU the fields share one block of
    host memory (`_host_memory`)."""
    out = struct()
    shapes = {name: field_shape(f, num_envs, sizes) for name, f in struct.fields.items()}
    if wp.get_device(device).is_cpu:
        arrays = _host_arrays({name: (shapes[name], f.dtype) for name, f in struct.fields.items()})
    else:
        arrays = {name: wp.zeros(shapes[name], dtype=f.dtype, device=device)
                  for name, f in struct.fields.items()}
    for name, array in arrays.items():
        if values is not None and name in values:
            scalar = getattr(struct.fields[name].dtype, "_wp_scalar_type_",
                             struct.fields[name].dtype)
            one = np.asarray(values[name], wp.dtype_to_numpy(scalar))
            assert one.shape[:len(shapes[name]) - 1] == shapes[name][1:], (name, one.shape)
            array.assign(np.ascontiguousarray(np.broadcast_to(one, (num_envs,) + one.shape)))
        setattr(out, name, array)
    return out


HUGE_PAGE = 1 << 21


def _host_arrays(fields: dict) -> dict:
    """Zeroed CPU arrays {name: (shape, dtype)} laid out one after another (64-byte aligned)
    in one block from `_host_memory`."""
    layout, size = {}, 0
    for name, (shape, dtype) in fields.items():
        inner = tuple(getattr(dtype, "_shape_", ()))
        scalar = wp.dtype_to_numpy(getattr(dtype, "_wp_scalar_type_", dtype))
        nbytes = int(np.prod(shape)) * wp.types.type_size_in_bytes(dtype)
        layout[name] = (size, nbytes, shape + inner, scalar, dtype)
        size += -(-nbytes // 64) * 64
    memory = _host_memory(size)
    # an empty field gets no address: sharing the next field's would alias the two for Warp's
    # CPU graph capture, which keys memory by address (AnymalTerrain's second shard)
    return {name: wp.array(memory[at:at + nbytes].view(scalar).reshape(full), dtype=dtype,
                           device="cpu", copy=False) if nbytes
            else wp.zeros(fields[name][0], dtype=dtype, device="cpu")
            for name, (at, nbytes, full, scalar, dtype) in layout.items()}


def _host_memory(nbytes: int) -> np.ndarray:
    """nbytes of zeroed host memory. Where the OS offers transparent huge pages on request
    (Linux, `madvise` mode), a block of 2 MB or more is an anonymous mapping advised to use
    them: the per-env arrays of 1024 envs span tens of MB, touched env after env by every
    stage, and with 4 KB pages more of the address translations miss the TLB (humanoid step
    1-3 % faster with huge pages, ant 1-2 %, benchmarks/step_ab.py on two machines)."""
    if nbytes < HUGE_PAGE or not hasattr(mmap, "MADV_HUGEPAGE"):
        return np.zeros(nbytes, np.uint8)
    size = -(-nbytes // HUGE_PAGE) * HUGE_PAGE
    # private and anonymous: zero pages, none touched yet (a shared mapping would be shmem,
    # which takes huge pages only where the system allows them for shmem too)
    block = mmap.mmap(-1, size + HUGE_PAGE, flags=mmap.MAP_PRIVATE | mmap.MAP_ANONYMOUS)
    start = (-np.frombuffer(block, np.uint8).ctypes.data) % HUGE_PAGE   # 2 MB aligned
    try:
        block.madvise(mmap.MADV_HUGEPAGE, start, size)
    except OSError:
        pass                                      # THP off: ordinary pages
    return np.frombuffer(block, np.uint8)[start:start + nbytes]
