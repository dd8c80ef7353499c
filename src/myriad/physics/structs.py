"""The engine's data, declared once: what each array holds, its shape and units.

Declarations only: `build` makes them on the device, the stages (`stages/`) read and write
them, `runtime` launches the kernels over them.

Shared by all envs, built from the `Model` once (`build.device_model`):

| struct              | holds                                                          |
|---------------------|----------------------------------------------------------------|
| `ModelArrays`       | the structure: tree, joints, dofs, geoms, sites, actuators     |
| `Meshes`, `HFields` | collision shapes: convex hull corners, height fields           |
| `Options`           | the step's settings: substep, iterations, offsets, thresholds  |
| `RowLayout`         | where each family of constraint rows starts                    |

Everything else has one entry per env, a leading dimension of `num_envs`, and is declared below
as a field of one of six structs:

| struct      | holds                                                        | who writes it        |
|-------------|--------------------------------------------------------------|----------------------|
| `EnvParams` | physical parameters each env may have its own of            | user, randomization  |
| `State`     | q, qd and what kinematics derives from them                  | the step             |
| `Control`   | actuator inputs, applied joint forces and body wrenches      | user, task           |
| `Dynamics`  | mass matrix, its factor, bias and generalized forces         | the step             |
| `Contacts`  | the contacts found in each env's slots and their forces      | collision, solver    |
| `Rows`      | constraint rows: Jacobians, responses, bounds, impulses      | constraints, solver  |

A field is declared as `name = per_env(*dims, dtype=..., doc=..., public=...)`: `dims` are the
sizes after the env dimension, named after the built model's sizes (`"nv"`, `"nbody"`, ...).
`build.allocate` makes every field of a struct in one loop, `runtime` gives the struct restricted
to a range of envs (a CPU thread's share), and a field with a `public` name is the `Simulator`
attribute of that name: a zero-copy torch view, writable where `writable`. A field added to a
declaration is allocated, sharded and (if public) exposed without another line of code.
"""

from typing import NamedTuple

import warp as wp


class Field(NamedTuple):
    dims: tuple               # sizes after the env dimension: names of Simulator sizes, or ints
    dtype: object             # Warp type of one element
    doc: str                  # meaning, units
    public: str | None        # name of the Simulator's torch view of it; None: internal
    writable: bool            # the view may be assigned (sim.q = ...)


def per_env(*dims, dtype=wp.float32, doc: str = "", public: str | bool | None = None,
            writable: bool = False) -> Field:
    """public: the view's name, or True for the field's own name."""
    return Field(dims, dtype, doc, public, writable)


def declared(cls):
    """A wp.struct of per-env arrays from a class of `name = per_env(...)` fields; the
    declarations stay on it as `.fields`, in order."""
    fields = {name: f._replace(public=name) if f.public is True else f
              for name, f in vars(cls).items() if isinstance(f, Field)}
    arrays = type(cls.__name__, (), {
        "__doc__": cls.__doc__, "__module__": cls.__module__, "__qualname__": cls.__qualname__,
        "__annotations__": {name: wp.array(dtype=f.dtype, ndim=1 + len(f.dims))
                            for name, f in fields.items()}})
    struct = wp.struct(arrays)
    struct.fields = fields
    return struct


def field_shape(f: Field, num_envs: int, sizes: dict) -> tuple:
    return (num_envs,) + tuple(sizes[d] if isinstance(d, str) else d for d in f.dims)


# a public view of a field declared over the first size shows only the second's leading part:
# the contacts in use, not the narrowphase's overflow places
VIEWED_AS = {"ncandidate": "ncontact"}


fluid_coefs = wp.types.vector(length=12, dtype=wp.float32)


@wp.struct
class ModelArrays:
    nbody: int
    nv: int
    njnt: int
    nu: int
    ntendon: int
    nsensor: int

    body_parent: wp.array(dtype=wp.int32)
    body_root: wp.array(dtype=wp.int32)
    body_pos: wp.array(dtype=wp.vec3)
    body_quat: wp.array(dtype=wp.quat)
    body_ipos: wp.array(dtype=wp.vec3)
    body_iquat: wp.array(dtype=wp.quat)
    body_jntadr: wp.array(dtype=wp.int32)
    body_jntnum: wp.array(dtype=wp.int32)
    body_last_dof: wp.array(dtype=wp.int32)
    body_subtree_end: wp.array(dtype=wp.int32)   # b's subtree is the bodies [b, end) (MuJoCo's
                                                 # depth-first order)
    body_gravcomp: wp.array(dtype=float)
    body_mocapid: wp.array(dtype=wp.int32)     # a mocap body's row of State.mocap_pos, else -1
    body_geomadr: wp.array(dtype=wp.int32)     # its geoms: geom_adr .. + geomnum (MuJoCo's)
    body_geomnum: wp.array(dtype=wp.int32)
    body_fluid_ellipsoid: wp.array(dtype=wp.int32)   # 1: MuJoCo's ellipsoid fluid model (a geom
                                                     # with fluidshape="ellipsoid"), else the box
    # the tree by levels (`build.tree_levels`), for kernels whose lanes take one level's bodies
    # at a time: level k holds the bodies with k ancestors, level_body[level_adr[k]:
    # level_adr[k + 1]] in ascending order; a body's children are body_child[body_child_adr[b]:
    # body_child_adr[b] + body_child_num[b]], highest index first (the order in which a walk
    # of the bodies from the last to the first adds them into their parent)
    nlevel: int
    level_adr: wp.array(dtype=wp.int32)        # [nlevel + 1]
    level_body: wp.array(dtype=wp.int32)       # [nbody]
    body_child_adr: wp.array(dtype=wp.int32)   # [nbody]
    body_child_num: wp.array(dtype=wp.int32)   # [nbody]
    body_child: wp.array(dtype=wp.int32)       # [nbody - number of roots]

    jnt_type: wp.array(dtype=wp.int32)
    jnt_qposadr: wp.array(dtype=wp.int32)
    jnt_dofadr: wp.array(dtype=wp.int32)
    jnt_pos: wp.array(dtype=wp.vec3)
    jnt_axis: wp.array(dtype=wp.vec3)
    jnt_springref: wp.array(dtype=float)
    jnt_actfrclimited: wp.array(dtype=wp.int32)
    jnt_actfrcrange: wp.array(dtype=wp.vec2)
    qpos0: wp.array(dtype=float)

    dof_body: wp.array(dtype=wp.int32)
    dof_parent: wp.array(dtype=wp.int32)
    dof_jnt: wp.array(dtype=wp.int32)
    # the actuator transmission entries on each dof (`trn_*`), in actuator order:
    # dof_trn[dof_trn_adr[i]: dof_trn_adr[i] + dof_trn_num[i]]
    dof_trn_adr: wp.array(dtype=wp.int32)   # [nv]
    dof_trn_num: wp.array(dtype=wp.int32)   # [nv]
    dof_trn: wp.array(dtype=wp.int32)       # [ntrn]
    ntree: int
    tree_dofs: wp.array(dtype=wp.vec2i)   # [ntree] [lo, hi) of each dof tree, in dof order
    # [lo, hi) of the dofs in the same dof tree (a dof, its ancestors and descendants): the
    # mass matrix is block-diagonal over these trees, so a row's response stays inside them
    dof_tree_span: wp.array(dtype=wp.vec2i)
    body_tree_span: wp.array(dtype=wp.vec2i)   # of the dofs that move a body; (0, 0) if none
    # the mass matrix and its factor keep, per dof i, one contiguous row of entries: (i, i)
    # at dof_madr[i], then (i, j) for each ancestor j of i, nearest first (`mass_matrix_layout`);
    # mass_col holds each entry's column j. The row of an ancestor is a tail of i's row.
    dof_madr: wp.array(dtype=wp.int32)
    dof_mnum: wp.array(dtype=wp.int32)     # entries in dof i's row: 1 + its ancestors
    mass_col: wp.array(dtype=wp.int32)

    geom_type: wp.array(dtype=wp.int32)     # types.GeomType
    geom_body: wp.array(dtype=wp.int32)     # -1: the world (static geometry)
    geom_quat: wp.array(dtype=wp.quat)      # orientation in the body frame
    geom_dataid: wp.array(dtype=wp.int32)   # mesh or height field, -1 if none
    geom_fluid: wp.array(dtype=fluid_coefs)  # the ellipsoid fluid model's coefficients: on (0/1),
                                             # blunt, slender, angular drag, Kutta, Magnus lift,
                                             # virtual mass [3], virtual inertia [3] (MuJoCo's)
    # [ncandidate pairs] friction of candidate pair k's contacts (k = contact key // 32):
    # sliding, set by an explicit <pair> (-1: the average of its geoms' geom_friction),
    # torsional and rolling (m; 0: none) (`pairs.pair_friction`)
    pair_friction: wp.array(dtype=wp.vec3)

    site_body: wp.array(dtype=wp.int32)
    site_pos: wp.array(dtype=wp.vec3)
    site_quat: wp.array(dtype=wp.quat)
    site_type: wp.array(dtype=wp.int32)     # the zone of a touch sensor: sphere ... box
    site_size: wp.array(dtype=wp.vec3)

    # actuators (`Model`): kinds, transmissions as entries (dof, qpos, coef), activations
    actuator_kind: wp.array(dtype=wp.int32)       # types.ActuatorKind
    actuator_trnadr: wp.array(dtype=wp.int32)     # first entry
    actuator_trnnum: wp.array(dtype=wp.int32)     # 1: a joint (implicit drive), more: a tendon
    trn_actuator: wp.array(dtype=wp.int32)
    trn_dof: wp.array(dtype=wp.int32)
    trn_qposadr: wp.array(dtype=wp.int32)
    trn_coef: wp.array(dtype=float)
    actuator_trnsite: wp.array(dtype=wp.int32)        # site transmission: the site, else -1
    actuator_trnspatial: wp.array(dtype=wp.int32)     # spatial tendon: its row, else -1
    actuator_site_gear: wp.array(dtype=wp.spatial_vector)   # its wrench: force, torque (site)
    actuator_bias: wp.array(dtype=float)          # affine: constant force
    actuator_gain_lv: wp.array(dtype=wp.vec2)     # affine: the gain's terms in length, velocity
    actuator_dyntype: wp.array(dtype=wp.int32)    # types.DynType
    actuator_tau: wp.array(dtype=float)           # filter time constant (s)
    actuator_actlimited: wp.array(dtype=wp.int32)
    actuator_actrange: wp.array(dtype=wp.vec2)
    actuator_actearly: wp.array(dtype=wp.int32)
    actuator_ctrllimited: wp.array(dtype=wp.int32)
    actuator_ctrlrange: wp.array(dtype=wp.vec2)
    actuator_forcelimited: wp.array(dtype=wp.int32)
    actuator_forcerange: wp.array(dtype=wp.vec2)

    tendon_adr: wp.array(dtype=wp.int32)
    tendon_num: wp.array(dtype=wp.int32)
    tendon_spatial: wp.array(dtype=wp.int32)    # its row of State.ten_length / ten_J; -1: fixed
    tendon_dofspan: wp.array(dtype=wp.vec2i)    # spatial: [lo, hi) of the dofs its path moves
    spatial_tendon: wp.array(dtype=wp.int32)    # [nspatial] the tendon of each row
    wrap_type: wp.array(dtype=wp.int32)         # types.WrapType
    wrap_jnt: wp.array(dtype=wp.int32)
    wrap_coef: wp.array(dtype=float)
    wrap_recip: wp.array(dtype=float)
    tendon_limited: wp.array(dtype=wp.int32)

    neq: int
    eq_type: wp.array(dtype=wp.int32)       # types.EqualityType
    eq_obj1: wp.array(dtype=wp.int32)       # body (-1: world), joint or tendon
    eq_obj2: wp.array(dtype=wp.int32)
    eq_ref: wp.array(dtype=wp.vec2)         # joint/tendon: x1_0, x2_0
    eq_rowadr: wp.array(dtype=wp.int32)     # first row, counted from the equality family's
    eq_rownum: wp.array(dtype=wp.int32)     # rows: 3 connect, 6 (3 without rotation) weld, 1

    # sensors, in MuJoCo's order (`Model`, `sensors`)
    sensor_type: wp.array(dtype=wp.int32)
    sensor_objtype: wp.array(dtype=wp.int32)
    sensor_objid: wp.array(dtype=wp.int32)
    sensor_reftype: wp.array(dtype=wp.int32)
    sensor_refid: wp.array(dtype=wp.int32)
    sensor_adr: wp.array(dtype=wp.int32)
    sensor_dim: wp.array(dtype=wp.int32)
    sensor_datatype: wp.array(dtype=wp.int32)
    sensor_cutoff: wp.array(dtype=float)
    sensor_slot: wp.array(dtype=wp.int32)   # force/torque: its site's row of sensor_wrench; else -1


@wp.struct
class Meshes:
    """Convex hulls of the model's meshes (collision reads only their corners)."""
    vert: wp.array(dtype=wp.vec3)      # every mesh's convex hull corners, mesh frame
    vertadr: wp.array(dtype=wp.int32)
    vertnum: wp.array(dtype=wp.int32)
    rbound: wp.array(dtype=float)      # per mesh: largest vertex distance from the mesh origin
    box_center: wp.array(dtype=wp.vec3)   # per mesh: the box round its hull, in the mesh frame
    box_half: wp.array(dtype=wp.vec3)     # (a TRIMESH geom's mesh: round all its vertices)
    bvh: wp.array(dtype=wp.uint64)        # per mesh: the `wp.Mesh` id of its triangles where a
                                          # TRIMESH geom uses it, else 0
    ridge: wp.array(dtype=wp.int32)       # per face of those meshes: bit j set where its edge j
                                          # (vertices j, j + 1) is a ridge (build.ridge_edges)
    ridgeadr: wp.array(dtype=wp.int32)    # per mesh: its first face's place in `ridge`


@wp.struct
class HFields:
    """The model's height fields."""
    size: wp.array(dtype=wp.vec4)     # x half-size, y half-size, top height, base depth
    nrow: wp.array(dtype=wp.int32)    # rows run along y
    ncol: wp.array(dtype=wp.int32)    # columns run along x
    adr: wp.array(dtype=wp.int32)
    data: wp.array(dtype=float)       # heights in [0, 1], times the top height
    riser: wp.array(dtype=float)      # m: a steeper rise in a cell is a vertical wall; 0: none


@wp.struct
class Options:
    """The step's settings on the device, from `SimParams` (PhysX's names and meaning)."""
    h: float                      # substep length, dt / substeps (s)
    position_iterations: int      # TGS: sub-steps of h, one sweep each; PGS: sweeps
    velocity_iterations: int      # sweeps without position bias after them
    tgs: int                      # 1: TGS, 0: PGS
    contact_offset: float         # shapes closer than this make contacts (m)
    rest_offset: float            # shapes come to rest this far apart (m)
    bounce_threshold: float       # no restitution below this approach speed (m/s)
    max_depenetration: float      # cap on the speed that resolves a penetration (m/s)
    max_correction: float         # cap on the speed that undoes a limit's or an equality's error
    limit_jnt: wp.array(dtype=wp.int32)     # the limited joints, in the order of their rows
    limit_dof: wp.array(dtype=wp.int32)     # ... and each one's dof
    limit_tendon: wp.array(dtype=wp.int32)  # the limited tendons, in the order of their rows


@wp.struct
class RowLayout:
    """Where each family of rows starts among an env's rows, fixed when the simulator is built.
    The families are contiguous, in this order: contacts from row 0 (`contact_width` rows per
    contact slot: normal, two sliding friction, then torsional and two rolling friction where
    the model has them), joint limits (2 per limited joint: lower, upper), hard tendon limits
    (2 per limited tendon), equality constraints (`ModelArrays.eq_rownum` each), tendon
    spring-dampers (1 per tendon), dofs (1 per dof: dry friction and speed cap; none without
    constraints)."""
    contact_slots: int   # contacts an env holds (its rows: [0, contact_width · contact_slots))
    contact_width: int   # rows per contact slot: 3, 4 (torsional friction) or 6 (and rolling)
    joint_limits: int    # first joint-limit row
    tendon_limits: int   # first tendon-limit row
    equalities: int      # first equality row
    springs: int         # first tendon spring-damper row
    dofs: int            # first dof row
    end: int             # number of rows


# ---------------------------------------------------------------------------------- per env
@declared
class EnvParams:
    """Physical parameters of each env, initialized from the model; domain randomization and
    users write them between steps."""
    body_mass = per_env("nbody", doc="mass (kg)", public=True, writable=True)
    body_inertia = per_env("nbody", dtype=wp.vec3, doc="principal moments of inertia about the "
                           "center of mass (kg·m²)", public=True, writable=True)
    geom_friction = per_env("ngeom", doc="sliding friction coefficient; a contact uses its two "
                            "geoms' average", public=True, writable=True)
    geom_restitution = per_env("ngeom", doc="restitution coefficient; a contact uses the two "
                               "geoms' average", public=True, writable=True)
    geom_size = per_env("ngeom", dtype=wp.vec3, doc="MuJoCo's size parameters (m), primitives",
                        public=True, writable=True)
    geom_pos = per_env("ngeom", dtype=wp.vec3, doc="position in the body frame (m)",
                       public=True, writable=True)
    site_pos = per_env("nsite", dtype=wp.vec3, doc="position in the body frame (m)")
    joint_stiffness = per_env("njnt", doc="spring stiffness toward the spring reference "
                              "(N·m/rad or N/m)", public=True, writable=True)
    joint_range = per_env("njnt", dtype=wp.vec2, doc="lower, upper limit (rad or m) of a "
                          "limited joint", public=True, writable=True)
    dof_damping = per_env("nv", doc="viscous damping (N·m·s/rad or N·s/m)", public=True,
                          writable=True)
    dof_armature = per_env("nv", doc="rotor inertia added to the mass matrix diagonal",
                           public=True, writable=True)
    dof_frictionloss = per_env("nv", doc="joint (dry) friction, force or torque",
                               public=True, writable=True)
    dof_max_velocity = per_env("nv", doc="maximum joint speed (rad/s or m/s)",
                               public=True, writable=True)
    body_max_angular_velocity = per_env("nbody", doc="speed cap of the body's rotation (rad/s): "
                                        "faster, it is pulled back (forces.speed_cap_wrench)",
                                        public=True, writable=True)
    body_max_linear_velocity = per_env("nbody", doc="speed cap of the body's center of mass "
                                       "(m/s): faster, it is pulled back", public=True,
                                       writable=True)
    actuator_gear = per_env("nu", doc="transmission ratio", public=True, writable=True)
    actuator_gain = per_env("nu", doc="motors and general (affine) actuators: force per unit "
                            "input", public=True, writable=True)
    actuator_kp = per_env("nu", doc="position and affine actuators: stiffness", public=True,
                          writable=True)
    actuator_kv = per_env("nu", doc="position, velocity and affine actuators: damping",
                          public=True, writable=True)
    tendon_stiffness = per_env("ntendon", doc="spring stiffness along the tendon length",
                               public=True, writable=True)
    tendon_damping = per_env("ntendon", doc="damping along the tendon length",
                             public=True, writable=True)
    tendon_range = per_env("ntendon", dtype=wp.vec2, doc="lower, upper length limits",
                           public=True, writable=True)
    tendon_limit_stiffness = per_env("ntendon", doc="0: hard length limits; > 0: a limit spring",
                                     public=True, writable=True)
    tendon_rest_length = per_env("ntendon", doc="spring rest length", public=True,
                                 writable=True)
    tendon_offset = per_env("ntendon", doc="length at q = 0", public=True,
                            writable=True)
    gravity = per_env(dtype=wp.vec3, doc="gravitational acceleration, world (m/s²)",
                      public=True, writable=True)
    fluid_density = per_env(doc="density of the medium (kg/m³): quadratic drag of MuJoCo's "
                            "inertia-box fluid model; 0: none", public=True, writable=True)
    fluid_viscosity = per_env(doc="viscosity of the medium (Pa·s): linear drag; 0: none",
                              public=True, writable=True)
    wind = per_env(dtype=wp.vec3, doc="velocity of the medium, world (m/s)", public=True,
                   writable=True)
    eq_active = per_env("neq", dtype=wp.int32, doc="1: the equality constraint holds, 0: it is "
                        "off (MuJoCo's eq_active)", public=True, writable=True)
    eq_anchor = per_env("neq", 2, dtype=wp.vec3, doc="connect/weld: the point on body 1 (its "
                        "frame) and on body 2 (its frame) that the constraint joins (m)",
                        public=True, writable=True)
    eq_frame = per_env("neq", 2, dtype=wp.quat, doc="weld: the orientations (xyzw) on body 1 "
                       "and body 2 that the weld keeps aligned", public=True, writable=True)
    eq_polycoef = per_env("neq", 5, doc="joint/tendon: x1 - x1_0 = c0 + c1·y + c2·y² + c3·y³ "
                          "+ c4·y⁴, y = x2 - x2_0", public=True, writable=True)


@declared
class State:
    """The generalized state and what kinematics derives from it. World frame unless noted;
    the motion subspaces `c*` are taken at each tree's root (see `spatial`)."""
    q = per_env("nq", doc="generalized positions (free and ball joints: quaternions xyzw)",
                public=True, writable=True)
    qd = per_env("nv", doc="generalized velocities", public=True, writable=True)
    qacc = per_env("nv", doc="unconstrained acceleration of the last substep", public=True)
    qd_before = per_env("nv", doc="qd at the start of the last substep")
    dq = per_env("nv", doc="the solver's displacement of the substep, integrated into q")
    body_x = per_env("nbody", dtype=wp.transform, doc="pose of the body frame: position, "
                     "quaternion xyzw", public="body_pose")
    body_com = per_env("nbody", dtype=wp.vec3, doc="center of mass (m)", public=True)
    body_iframe = per_env("nbody", dtype=wp.quat, doc="orientation of the principal axes of "
                          "inertia, world (quaternion xyzw)", public=True)
    body_vel = per_env("nbody", dtype=wp.spatial_vector, doc="linear velocity of the body origin, "
                       "then angular velocity", public=True)
    site_x = per_env("nsite", dtype=wp.transform, doc="pose of each site", public="site_pose")
    geom_x = per_env("ngeom", dtype=wp.transform, doc="pose of each geom, as of the last "
                     "collision stage", public="geom_pose")
    geom_bound = per_env("ngeom", dtype=wp.vec4, doc="bounding sphere of each geom as of the last "
                         "collision stage: world center, radius (m); 0 for planes and height "
                         "fields")
    jnt_anchor = per_env("njnt", dtype=wp.vec3, doc="joint anchor point")
    jnt_xaxis = per_env("njnt", dtype=wp.vec3, doc="joint axis")
    cvel = per_env("nbody", dtype=wp.spatial_vector, doc="spatial velocity at the tree root")
    cdof = per_env("nv", dtype=wp.spatial_vector, doc="motion subspace of each dof")
    cdof_dot = per_env("nv", dtype=wp.spatial_vector, doc="its time derivative")
    sensor_wrench = per_env("nsensor_site", dtype=wp.spatial_vector, doc="force then torque that "
                            "each force/torque sensor site's body receives from its parent, site "
                            "frame (MuJoCo's force/torque sensors; rows: sim.sensor_sites)",
                            public=True)
    sensor_constraint = per_env("nsensor_split", dtype=wp.spatial_vector, doc="with "
                                "Model.force_sensor_split: force then torque about each sensor "
                                "site, world axes, of the contacts on its body's subtree (PhysX's "
                                "constraint-solver part)", public=True)
    sensor_forward = per_env("nsensor_split", dtype=wp.spatial_vector, doc="with "
                             "Model.force_sensor_split: force then torque about each sensor site, "
                             "world axes, minus the articulated zero-acceleration force of its "
                             "body's subtree (PhysX's forward-dynamics part)", public=True)
    sensor_data = per_env("nsensordata", doc="every sensor's values after the last step, in "
                          "MuJoCo's sensordata order (Model.sensor_adr, sensor_dim; "
                          "quaternions w, x, y, z)", public=True)
    ten_length = per_env("nspatial", doc="length of each spatial tendon's path (m), without the "
                         "offset (`tendons`)")
    ten_J = per_env("nspatial", "nv", doc="its derivative by each dof: the moment arms")
    mocap_pos = per_env("nmocap", dtype=wp.vec3, doc="position of each mocap body, world (m): "
                        "kinematic bodies the user moves (MuJoCo's mocap_pos)", public=True,
                        writable=True)
    mocap_quat = per_env("nmocap", dtype=wp.quat, doc="orientation of each mocap body, "
                         "quaternion xyzw (normalized when used)", public=True, writable=True)
    act = per_env("nu", doc="activation of each actuator with activation dynamics (its input "
                  "instead of ctrl; 0 for the others)", public=True, writable=True)
    nonfinite = per_env(dtype=wp.int32, doc="1 once the env's state or input went non-finite "
                        "(its state is then NaN); the task resets it", public=True,
                        writable=True)


@declared
class Control:
    """Inputs applied during the next step (held through its substeps)."""
    ctrl = per_env("nu", doc="actuator inputs", public=True, writable=True)
    joint_force = per_env("nv", doc="generalized force", public=True, writable=True)
    body_force = per_env("nbody", dtype=wp.spatial_vector, doc="force at the center of mass, then "
                         "torque, world axes (N, N·m)", public=True, writable=True)


@declared
class Dynamics:
    """Terms of the equation of motion of the current substep."""
    qm = per_env("nmass", doc="mass matrix with armature: each dof's row over itself and its "
                 "ancestors (`mass_matrix_layout`)")
    factor = per_env("nmass", doc="Lᵀ D L factor of M + implicit_diag, same layout: L strictly "
                     "below the diagonal, D⁻¹ on it")
    bias = per_env("nv", doc="C(q, qd)·qd + g(q)", public="bias_force")
    qfrc = per_env("nv", doc="explicit generalized force minus bias")
    qfrc_applied = per_env("nv", doc="generalized force of joint_force, body_force and the "
                           "fluid forces")
    qfrc_actuator = per_env("nv", doc="generalized actuator force", public="dof_actuator_force")
    actuator_force = per_env("nu", doc="each actuator's force before the gear at the start of "
                             "the last substep, clamped to its force range (MuJoCo's "
                             "actuator_force)", public=True)
    implicit_diag = per_env("nv", doc="h·d + h²·k of implicit dampers and drives, added to M's "
                            "diagonal in the solve")
    wrench = per_env("nbody", dtype=wp.spatial_vector, doc="body_force at the tree root")
    cacc = per_env("nbody", dtype=wp.spatial_vector, doc="RNEA: spatial acceleration")
    cfrc = per_env("nbody", dtype=wp.spatial_vector, doc="RNEA: subtree force")
    crb_m = per_env("nbody", doc="CRBA: subtree mass")
    crb_h = per_env("nbody", dtype=wp.vec3, doc="CRBA: subtree first moment")
    crb_i = per_env("nbody", dtype=wp.mat33, doc="CRBA: subtree inertia")
    articulated = per_env("nbody", dtype=wp.spatial_matrix, doc="articulated-body inertia of "
                          "each body's subtree at its tree's reference point (factor scratch)")
    # the implicit integrator's scratch (`dynamics.implicit_acceleration`; empty for "euler")
    coriolis_frc = per_env("nbody_implicit", dtype=wp.spatial_vector, doc="implicit: the "
                           "derivative of each body's subtree force (RNEA) in one dof's speed")
    coriolis_inertia = per_env("nbody_implicit", dtype=wp.spatial_matrix, doc="implicit: each "
                               "body's spatial inertia at its tree's reference point")
    coriolis_momentum = per_env("nbody_implicit", dtype=wp.spatial_vector, doc="implicit: each "
                                "body's spatial momentum I·cvel")
    coriolis_deriv = per_env("nv_implicit", "tree_implicit", doc="implicit: row j holds column j "
                             "of ∂bias/∂qd over j's dof tree, then of (M + implicit_diag)⁻¹ "
                             "times it, then of the matrix the solve eliminates")


@declared
class Contacts:
    """Contacts of the last collision stage, in `ncontact` slots per env, and their forces.

    The narrowphase writes into `ncandidate` (a few times `ncontact`) places; when an env finds
    more contacts than its slots, `collision.keep_deepest` keeps the deepest `ncontact` of them
    in the first slots (in their order), so that an overflow drops the contacts that matter
    least (those still apart, inside the contact offset) and not whichever came last."""
    count = per_env(dtype=wp.int32, doc="contacts found; above the capacity: overflow (the rest "
                    "were dropped)", public="contact_count")
    geom = per_env("ncandidate", dtype=wp.vec2i, doc="geom 1, geom 2", public="contact_geom")
    key = per_env("ncandidate", dtype=wp.int32, doc="identity across substeps: 32 × the candidate "
                  "pair's index + the feature (e.g. which box corner), to find the same contact's anchors next substep")
    pos = per_env("ncandidate", dtype=wp.vec3, doc="midpoint between the surfaces",
                  public="contact_pos")
    normal = per_env("ncandidate", dtype=wp.vec3, doc="from geom 1 to geom 2",
                     public="contact_normal")
    dist = per_env("ncandidate", doc="signed distance, < 0: penetration (m)", public="contact_dist")
    force = per_env("ncontact", dtype=wp.vec3, doc="force on geom 2 in the last substep, world (N)",
                    public="contact_force")
    net_force = per_env("nbody", dtype=wp.vec3, doc="sum of the contact forces on each body (N)",
                        public="net_contact_force")
    anchor = per_env("ncontact", 2, dtype=wp.vec3, doc="static friction anchors: the contact "
                     "point when the contact began to stick, in body 1's frame and in body 2's")
    prev_anchor = per_env("ncontact", 2, dtype=wp.vec3, doc="the last substep's anchors")
    slid = per_env("ncontact", dtype=wp.int32, doc="1 if the friction disk cut the contact's "
                   "friction impulse in the last sweep (it slides)")
    prev_key = per_env("ncontact", dtype=wp.int32, doc="the last substep's keys (warm start)")
    match = per_env("ncontact", dtype=wp.int32, doc="the slot of the same contact (key) in the "
                    "last substep, -1 if it is new")
    prev_count = per_env(dtype=wp.int32, doc="the last substep's contacts in use")


@declared
class Rows:
    """Constraint rows at fixed slots (`constraints.RowLayout`); J and M⁻¹Jᵀ over the dofs of
    each row's span only (`row_width` columns)."""
    type = per_env("nrow", dtype=wp.int32, doc="types.RowType")
    err = per_env("nrow", doc="position error at the start of the substep (m or rad); < 0 violates")
    inv_mass = per_env("nrow", doc="1 / (J M⁻¹ Jᵀ); 0 while the response is not built")
    mu = per_env("nrow", doc="contacts: friction coefficient; dof rows: impulse bound")
    bounce = per_env("nrow", doc="restitution target speed (m/s), 0 if none")
    dir = per_env("nrow", dtype=wp.vec3, doc="contacts: the row's direction, world")
    k = per_env("nrow", doc="soft rows: stiffness; dof rows: speed cap; contact normals: "
                "1/m1 + 1/m2 of the two bodies")
    d = per_env("nrow", doc="soft rows: damping")
    span = per_env("nrow", dtype=wp.vec4i, doc="the two dof ranges [lo, hi) the row touches")
    jac = per_env("nrow", "row_width", doc="J over the span's dofs")
    minv_jt = per_env("nrow", "row_width", doc="M⁻¹Jᵀ over the span's dofs")
    lam = per_env("nrow", doc="impulse of the last substep (N·s or N·m·s)")
    lam_init = per_env("nrow", doc="starting impulse of the substep (warm start)")
    dof_force = per_env("nv", doc="generalized force of all rows in the last substep",
                        public="dof_constraint_force")
    # scratch of the joint-limit block solve (`solver_tgs`), indexed by block entry: joint-limit
    # row i at i, the k-th contact of block_contact at nlimit + k, the k-th speed cap of
    # block_cap at nlimit + nblock_contact + k
    block_target = per_env("nblock", doc="limit block: target J·v of the row in this sweep")
    block_w0 = per_env("nblock", doc="limit block: J·v with every block impulse taken out")
    block_lam = per_env("nblock", doc="limit block: the impulses being solved for")
    block_in = per_env("nblock", dtype=wp.int32, doc="limit block: 1 if in the active set")
    block_cand = per_env("nlimit", dtype=wp.int32, doc="limit block: the limit rows within "
                         "reach of their limits in this substep, -1 after the last")
    block_contact = per_env("nblock_contact", dtype=wp.int32, doc="limit block: the contacts "
                            "solved with the limits in this sweep (their slots), -1 after the "
                            "last")
    block_cap = per_env("nblock_cap", dtype=wp.int32, doc="limit block: the dofs past their "
                        "speed cap solved with the limits, 2·dof + (1 if too fast forward), "
                        "-1 after the last")
    block_row = per_env("nblock", dtype=wp.int32, doc="limit block: the active set, in order")
    block_a = per_env("nblock", "nblock", doc="limit block: Cholesky factor of J M⁻¹ Jᵀ on the "
                      "active set")
    lane_sum = per_env(2, "nlane", doc="the solve's sums across a world's lanes: each lane's "
                       "part, in one of two buffers taken in turn (`solver_tgs._dot`)")
    lane_turn = per_env("nlane", dtype=wp.int32, doc="each lane's count of those sums (which "
                        "buffer is next)")
    eq_chol = per_env("neqrow", 6, doc="equality rows: row i of the Cholesky factor of their "
                      "constraint's J M⁻¹ Jᵀ (columns up to i; a zero diagonal for a row "
                      "dependent on those before it)")


STRUCTS = (EnvParams, State, Control, Dynamics, Contacts, Rows)
