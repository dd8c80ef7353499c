"""`Model`: the static description of one env, read from MuJoCo's compiled `MjModel`.

Arrays are numpy, on the host, in MuJoCo's element order. Bodies are numbered without MuJoCo's
world body: our body ``b`` is MuJoCo's body ``b + 1`` and a parent of ``-1`` is the world.
Quaternions are (x, y, z, w) everywhere, including inside ``qpos0``; `qpos_to_mujoco` and
`qpos_from_mujoco` convert a generalized position to and from MuJoCo's (w, x, y, z) layout.

Quantities that domain randomization may change (masses, inertias, friction, damping, ...) have
their model values here; the `Simulator` copies them into per-env arrays.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .types import GeomType, JointType, SensorType


class ModelError(ValueError):
    """A model file MuJoCo rejects, or a feature Myriad does not support (yet)."""


@dataclass
class Model:
    source: str                      # the file it was loaded from
    mj_model: object                 # MuJoCo's compiled model (renderer, oracle); never stepped by us

    nq: int
    nv: int
    nbody: int
    njnt: int
    ngeom: int
    nsite: int
    nu: int
    nmocap: int                      # mocap bodies (MuJoCo's): kinematic, posed per env
    ntendon: int
    nsensor: int                     # sensors Myriad computes (the model's others are skipped)
    nsensordata: int                 # their values, flat: the width of sim.sensor_data
    neq: int

    body_names: list[str]
    joint_names: list[str]
    geom_names: list[str]
    site_names: list[str]
    actuator_names: list[str]
    tendon_names: list[str]
    sensor_names: list[str]

    # bodies (topological order: a parent comes before its children)
    body_parent: np.ndarray          # [nbody] int, -1 = world
    body_root: np.ndarray            # [nbody] int, first body of the tree below the world
    body_pos: np.ndarray             # [nbody, 3] frame offset in the parent frame
    body_quat: np.ndarray            # [nbody, 4] xyzw
    body_ipos: np.ndarray            # [nbody, 3] center of mass in the body frame
    body_iquat: np.ndarray           # [nbody, 4] principal axes of inertia in the body frame
    body_mass: np.ndarray            # [nbody]
    body_inertia: np.ndarray         # [nbody, 3] principal moments
    body_gravcomp: np.ndarray        # [nbody] share of the body's weight cancelled by an applied
                                     # force at its centre of mass (MuJoCo's gravcomp; 1: no
                                     # gravity on it, Isaac Gym's disable_gravity)
    body_mocapid: np.ndarray         # [nbody] a mocap body's index in sim.mocap_pos, else -1:
                                     # a child of the world without joints, posed by the user
    body_geomadr: np.ndarray         # [nbody] first geom (a body's geoms are contiguous)
    body_geomnum: np.ndarray         # [nbody]
    body_jntadr: np.ndarray          # [nbody] first joint, -1 if none
    body_jntnum: np.ndarray          # [nbody]
    body_last_dof: np.ndarray        # [nbody] last dof moving this body (own or an ancestor's), -1 if none

    # joints
    jnt_type: np.ndarray             # [njnt] types.JointType
    jnt_body: np.ndarray             # [njnt]
    jnt_qposadr: np.ndarray          # [njnt]
    jnt_dofadr: np.ndarray           # [njnt]
    jnt_pos: np.ndarray              # [njnt, 3] anchor in the body frame
    jnt_axis: np.ndarray             # [njnt, 3] axis in the body frame
    jnt_stiffness: np.ndarray        # [njnt] passive spring (hinge and slide only)
    jnt_springref: np.ndarray        # [njnt] spring rest position
    jnt_limited: np.ndarray          # [njnt] bool
    jnt_range: np.ndarray            # [njnt, 2]
    jnt_actfrclimited: np.ndarray    # [njnt] bool: clamp the joint's summed actuator force
    jnt_actfrcrange: np.ndarray      # [njnt, 2] (URDF effort limits land here)
    qpos0: np.ndarray                # [nq] initial configuration, quaternions xyzw

    # dofs
    dof_body: np.ndarray             # [nv]
    dof_jnt: np.ndarray              # [nv]
    dof_parent: np.ndarray           # [nv] previous dof on the path to the world, -1 if none
    dof_armature: np.ndarray         # [nv]
    dof_damping: np.ndarray          # [nv]
    dof_frictionloss: np.ndarray     # [nv]

    # geoms (collision shapes; visual-only geoms are kept too, with contype = conaffinity = 0)
    geom_type: np.ndarray            # [ngeom] MuJoCo mjtGeom
    geom_body: np.ndarray            # [ngeom] -1 = world (static geometry)
    geom_pos: np.ndarray             # [ngeom, 3]
    geom_quat: np.ndarray            # [ngeom, 4] xyzw
    geom_size: np.ndarray            # [ngeom, 3] MuJoCo's size semantics
    geom_friction: np.ndarray        # [ngeom, 3] sliding, torsional (m), rolling (m); the
                                     # angular two apply at condim 4 and 6 (`pairs.pair_friction`)
    geom_contype: np.ndarray         # [ngeom]
    geom_conaffinity: np.ndarray     # [ngeom]
    geom_condim: np.ndarray          # [ngeom]
    geom_dataid: np.ndarray          # [ngeom] mesh or hfield id, -1 if none (a TRIMESH: its mesh)
    geom_fluid: np.ndarray           # [ngeom, 12] MuJoCo's ellipsoid fluid model (fluidshape,
                                     # fluidcoef, virtual mass and inertia); [:, 0] = 0: not used

    # meshes, kept as convex hulls for collision (a TRIMESH geom's mesh: as its triangles)
    mesh_vert: np.ndarray            # [nvert, 3] all mesh vertices, in the mesh frame
    mesh_vertadr: np.ndarray         # [nmesh]
    mesh_vertnum: np.ndarray         # [nmesh]
    mesh_face: np.ndarray            # [nface, 3] the mesh's own triangles: vertex ids local to
                                     # the mesh, counterclockwise seen from outside
    mesh_faceadr: np.ndarray         # [nmesh]
    mesh_facenum: np.ndarray         # [nmesh]
    mesh_hull_face: np.ndarray       # [nface, 3] vertex ids (global, into mesh_vert) of hull triangles
    mesh_hull_faceadr: np.ndarray    # [nmesh]
    mesh_hull_facenum: np.ndarray    # [nmesh]

    # height fields
    hfield_size: np.ndarray          # [nhfield, 4] x half-size, y half-size, height, base depth
    hfield_nrow: np.ndarray          # [nhfield]
    hfield_ncol: np.ndarray          # [nhfield]
    hfield_adr: np.ndarray           # [nhfield]
    hfield_data: np.ndarray          # [sum nrow*ncol] heights in [0, 1], scaled by hfield_size[2]
    hfield_riser: np.ndarray         # [nhfield] float32, metres: a height difference between
                                     # neighbouring samples (along x, y or the cell's diagonal)
                                     # above this is a vertical wall (0: off, MuJoCo's
                                     # triangulated surface); precisely, a cell's corners higher
                                     # than its lowest by more (collision.heightfield)

    # sites
    site_body: np.ndarray            # [nsite] -1 = world
    site_pos: np.ndarray             # [nsite, 3]
    site_quat: np.ndarray            # [nsite, 4] xyzw
    site_type: np.ndarray            # [nsite] geom type of the site's zone (touch sensors)
    site_size: np.ndarray            # [nsite, 3] MuJoCo's size semantics

    # actuators. Each drives a transmission: a length l = gear · Σ coef·q over its entries
    # (one entry of coef 1 for a joint, the tendon's joints for a fixed tendon), receiving
    # gear·coef·force on each entry's dof (MuJoCo's actuator_moment); a site transmission is a
    # wrench at the site, its moment arms from the site's pose, its length 0.
    actuator_kind: np.ndarray        # [nu] types.ActuatorKind
    actuator_dof: np.ndarray         # [nu] the dof the actuator drives (its first entry's)
    actuator_trnadr: np.ndarray      # [nu] first entry in trn_*
    actuator_trnnum: np.ndarray      # [nu] entries: 1 for a joint, a tendon's joint count
    trn_actuator: np.ndarray         # [ntrn] the actuator of each entry
    trn_dof: np.ndarray              # [ntrn] its hinge or slide dof
    trn_qposadr: np.ndarray          # [ntrn] that joint's qpos
    trn_coef: np.ndarray             # [ntrn] its share of the length (before the gear)
    actuator_trnsite: np.ndarray     # [nu] site transmission: the site (its entries: the dofs
                                     # carrying it), else -1
    actuator_trnspatial: np.ndarray  # [nu] spatial-tendon transmission: the tendon's row
                                     # (`tendon_spatial`), its entries the tendon's dofs; else -1
    actuator_site_gear: np.ndarray   # [nu, 6] its wrench per unit force, site frame: force,
                                     # torque (MuJoCo's 6D gear; the scalar gear is then 1)
    actuator_gear: np.ndarray        # [nu]
    actuator_gain: np.ndarray        # [nu] motor and affine: force per unit input
    actuator_kp: np.ndarray          # [nu] position and affine: stiffness (−biasprm[1])
    actuator_kv: np.ndarray          # [nu] position, velocity and affine: damping (−biasprm[2])
    actuator_bias: np.ndarray        # [nu] affine: constant force (biasprm[0])
    actuator_gain_lv: np.ndarray     # [nu, 2] affine: the gain's terms in l and v (gainprm[1:3])
    actuator_dyntype: np.ndarray     # [nu] types.DynType: NONE, or the input is an activation
    actuator_tau: np.ndarray         # [nu] filter time constant (s, dynprm[0])
    actuator_actlimited: np.ndarray  # [nu] bool: the activation is clamped to actrange
    actuator_actrange: np.ndarray    # [nu, 2]
    actuator_actearly: np.ndarray    # [nu] bool: the force uses this substep's new activation
    actuator_ctrllimited: np.ndarray # [nu] bool
    actuator_ctrlrange: np.ndarray   # [nu, 2]
    actuator_forcelimited: np.ndarray  # [nu] bool
    actuator_forcerange: np.ndarray  # [nu, 2]

    # tendons. Fixed ones, PhysX semantics (docs/physics.md): length L = offset + sum coef·q over
    # the tendon's joints; each joint receives recip_coef · (spring/damper/limit force) / N.
    # Spatial ones (MuJoCo's): L = offset + the length of a path through sites, wrapping round
    # spheres and cylinders; the force acts along dL/dq (`stages.tendons`)
    tendon_adr: np.ndarray           # [ntendon] first entry in wrap_*
    tendon_num: np.ndarray           # [ntendon] N, the number of tendon joints (path elements)
    tendon_spatial: np.ndarray       # [ntendon] a spatial tendon's row of the simulator's path
                                     # lengths and Jacobians; -1: a fixed tendon
    tendon_dofspan: np.ndarray       # [ntendon, 2] spatial: [lo, hi) of the dofs moving its path
                                     # (the dof trees between included); fixed: (0, 0)
    wrap_type: np.ndarray            # [nwrap] types.WrapType
    wrap_jnt: np.ndarray             # [nwrap] hinge or slide joint; spatial: the site or geom
    wrap_coef: np.ndarray            # [nwrap] contribution of the joint to the length; spatial:
                                     # a geom's side site (-1: none), a pulley's divisor
    wrap_recip: np.ndarray           # [nwrap] weight of the force the joint receives
    tendon_stiffness: np.ndarray     # [ntendon]
    tendon_damping: np.ndarray       # [ntendon]
    tendon_rest_length: np.ndarray   # [ntendon]
    tendon_offset: np.ndarray        # [ntendon]
    tendon_limited: np.ndarray       # [ntendon] bool
    tendon_range: np.ndarray         # [ntendon, 2] lower, upper length
    tendon_limit_stiffness: np.ndarray  # [ntendon] 0: hard limit (a constraint row); > 0: spring

    # sensors (`sensors`), in MuJoCo's order; sensor i writes its sensor_dim[i] values from
    # sensor_adr[i] of the flat sensor data, as MuJoCo's sensordata (without skipped sensors)
    sensor_type: np.ndarray          # [nsensor] types.SensorType (MuJoCo's mjtSensor)
    sensor_objtype: np.ndarray       # [nsensor] types.ObjType of the object it reads
    sensor_objid: np.ndarray         # [nsensor] that object (bodies: ours, -1 = the world)
    sensor_reftype: np.ndarray       # [nsensor] frame sensors: reference frame's ObjType, 0: world
    sensor_refid: np.ndarray         # [nsensor] its id (bodies: ours, -1 = the world)
    sensor_dim: np.ndarray           # [nsensor] number of values
    sensor_adr: np.ndarray           # [nsensor] first value in the sensor data
    sensor_datatype: np.ndarray      # [nsensor] types.DataType: how the cutoff applies
    sensor_cutoff: np.ndarray        # [nsensor] clamp of real/positive values, 0: none

    # contact filtering
    exclude_body_pairs: np.ndarray   # [nexclude, 2] body ids (-1 = world)
    # explicit contact pairs (MJCF <contact><pair>), in MuJoCo's order: always candidates,
    # whatever contype/conaffinity, parent-child and <exclude> say (`collision.candidate_pairs`)
    pair_geoms: np.ndarray           # [npair, 2] geom ids
    pair_friction: np.ndarray        # [npair, 3] sliding, torsional, rolling friction of the
                                     # pair's contacts, used instead of its geoms'; sliding 0 for
                                     # condim 1 (frictionless), torsional 0 below condim 4,
                                     # rolling 0 below condim 6

    # equality constraints (MuJoCo's <equality>), hard rows of the solve (docs/physics.md).
    # Site semantics are turned into body semantics at import: a frame on each of two bodies.
    eq_type: np.ndarray              # [neq] types.EqualityType
    eq_obj1: np.ndarray              # [neq] body (connect, weld), joint or tendon
    eq_obj2: np.ndarray              # [neq] the same kind; -1: the world (bodies) or none
    eq_active: np.ndarray            # [neq] bool, initially active
    eq_anchor: np.ndarray            # [neq, 2, 3] connect/weld: the point fixed on body 1
                                     # (body 1 frame), and on body 2 (body 2 frame)
    eq_frame: np.ndarray             # [neq, 2, 4] weld: orientation xyzw of the frame fixed on
                                     # body 1 and on body 2, which the weld keeps aligned
    eq_rotation: np.ndarray          # [neq] bool, weld: orientation held too (torquescale != 0)
    eq_polycoef: np.ndarray          # [neq, 5] joint/tendon: x1 - x1_0 = c0 + c1·y + ... + c4·y⁴,
                                     # y = x2 - x2_0 (x: joint position or tendon length)
    eq_ref: np.ndarray               # [neq, 2] x1_0, x2_0: joint qpos0 or tendon length at qpos0

    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81], np.float32))
    # the medium bodies move in (MuJoCo's <option density viscosity wind>): forces of MuJoCo's
    # inertia-box fluid model on every body with mass (`forces.fluid_wrench`); 0: none
    density: float = 0.0             # kg/m³ (air 1.2, water 1000)
    viscosity: float = 0.0           # Pa·s (air 1.8e-5, water 9e-4)
    wind: np.ndarray = field(default_factory=lambda: np.zeros(3, np.float32))   # m/s, world
    timestep: float = 1.0 / 60.0
    # force/torque sensors also split as PhysX's articulation sensors report them
    # (`sim.sensor_constraint`, `sim.sensor_forward`; `stages.sensors.force_sensors`)
    force_sensor_split: bool = False

    @property
    def quat_qpos_adr(self) -> np.ndarray:
        """qpos address of every quaternion (ball joints and the rotation of free joints)."""
        kind = np.asarray(self.jnt_type)
        free = kind == JointType.FREE
        adr = np.asarray(self.jnt_qposadr, dtype=np.int64) + 3 * free
        return adr[free | (kind == JointType.BALL)]

    def _qpos_permutation(self, to_mujoco: bool) -> np.ndarray:
        # ours (x, y, z, w) at a..a+3  <->  MuJoCo's (w, x, y, z); numpy, not a loop over the
        # joints: the viewer and the videos convert every frame
        perm = np.arange(self.nq)
        adr = self.quat_qpos_adr[:, None]
        perm[adr + np.arange(4)] = adr + np.array([3, 0, 1, 2] if to_mujoco else [1, 2, 3, 0])
        return perm

    def qpos_to_mujoco(self, q):
        """Our generalized position(s) [..., nq] in MuJoCo's qpos layout (works on numpy and torch)."""
        return q[..., self._qpos_permutation(to_mujoco=True)]

    def qpos_from_mujoco(self, qpos):
        """MuJoCo qpos [..., nq] in our layout (quaternions xyzw)."""
        return qpos[..., self._qpos_permutation(to_mujoco=False)]

    def body_index(self, name: str) -> int:
        return _index(self.body_names, name, "body")

    def joint_index(self, name: str) -> int:
        return _index(self.joint_names, name, "joint")

    def site_index(self, name: str) -> int:
        return _index(self.site_names, name, "site")

    def actuator_index(self, name: str) -> int:
        return _index(self.actuator_names, name, "actuator")

    def sensor_index(self, name: str) -> int:
        return _index(self.sensor_names, name, "sensor")

    def sensor_slice(self, name: str) -> slice:
        """The columns of `sim.sensor_data` that the sensor named `name` writes."""
        i = self.sensor_index(name)
        return slice(int(self.sensor_adr[i]), int(self.sensor_adr[i] + self.sensor_dim[i]))

    @property
    def body_static(self) -> np.ndarray:
        """[nbody] bool: the bodies that never move, welded to the world by no joint between
        them and it (a fixed-base table, the wall beside it)."""
        static = np.zeros(self.nbody, dtype=bool)
        for b in range(self.nbody):                # parents come before their children
            p = self.body_parent[b]
            static[b] = self.body_jntnum[b] == 0 and (p < 0 or static[p])
        return static

    def collide_as_triangles(self, geom: str | int, contype: int = 1,
                             conaffinity: int = 1) -> None:
        """Collide static mesh geom `geom` (a name or index) as its triangles, exactly, instead
        of as its convex hull (MuJoCo's, and Myriad's default): a bin, a table, a room, terrain
        that is not a height-field grid. The geom must not move (on the world body, or on
        bodies joined to it by no joint), and its triangles must face outward
        (counterclockwise seen from the side bodies are on; see
        `stages.collision.trimesh`). `contype`/`conaffinity` replace the geom's: a mesh put in
        MuJoCo's model with both 0 is drawn only, and MuJoCo builds no hull for it."""
        g = _index(self.geom_names, geom, "geom") if isinstance(geom, str) else int(geom)
        if not 0 <= g < self.ngeom:
            raise ValueError(f"collide_as_triangles: geom {geom} is not in [0, {self.ngeom})")
        label = self.geom_names[g] or f"geom {g}"
        if self.geom_type[g] not in (GeomType.MESH, GeomType.TRIMESH):
            raise ModelError(f"{self.source}: collide_as_triangles: {label} is a "
                             f"{GeomType(self.geom_type[g]).name.lower()}, not a mesh")
        b = int(self.geom_body[g])
        if b >= 0 and not self.body_static[b]:
            raise ModelError(f"{self.source}: collide_as_triangles: {label} is on body "
                             f"{self.body_names[b]!r}, which moves; only static meshes collide "
                             "as triangles (a moving mesh collides as its convex hull, or as "
                             "convex pieces)")
        if self.mesh_facenum[self.geom_dataid[g]] == 0:
            raise ModelError(f"{self.source}: collide_as_triangles: {label}'s mesh has no "
                             "triangles")
        self.geom_type[g] = GeomType.TRIMESH
        self.geom_contype[g] = contype
        self.geom_conaffinity[g] = conaffinity

    @property
    def force_sensor_sites(self) -> list[int]:
        """Sites that carry a force or torque sensor, each once, in the order of their first
        sensor: the rows of `sim.sensor_wrench` (Isaac Gym's force sensors)."""
        kinds = (SensorType.FORCE, SensorType.TORQUE)
        return list(dict.fromkeys(int(o) for t, o in zip(self.sensor_type, self.sensor_objid)
                                  if t in kinds))

    def __repr__(self) -> str:
        return (f"Model({self.source!r}: nq={self.nq} nv={self.nv} nbody={self.nbody} "
                f"ngeom={self.ngeom} nu={self.nu} ntendon={self.ntendon} nsensor={self.nsensor})")


def dof_tree_spans(dof_parent: np.ndarray) -> np.ndarray:
    """[lo, hi) of the dof tree of each dof [nv, 2]. A dof tree is a top dof (no parent dof)
    with all its descendants: in MuJoCo's depth-first order its dofs are contiguous, and dofs of
    different trees never couple in the mass matrix."""
    nv = len(dof_parent)
    top = np.arange(nv)
    for i in range(nv):                            # parents come first in MuJoCo's order
        if dof_parent[i] >= 0:
            top[i] = top[dof_parent[i]]
    dof_span = np.zeros((nv, 2), np.int32)
    for t in np.unique(top):
        members = np.flatnonzero(top == t)
        assert members[-1] - members[0] + 1 == len(members), "a dof tree is not contiguous"
        dof_span[members] = (members[0], members[-1] + 1)
    return dof_span


def _index(names: list[str], name: str, kind: str) -> int:
    try:
        return names.index(name)
    except ValueError:
        raise KeyError(f"no {kind} named {name!r}; the model's {kind}s are {names}") from None
