"""Device-side bundles of arrays handed to the kernels.

`ModelArrays` holds the structure shared by all envs (the tree, joint types, frames); `EnvParams`
holds every quantity that may differ between envs, each with a leading env dimension. Both are
built once by the `Simulator`.
"""

import warp as wp


@wp.struct
class ModelArrays:
    nbody: int
    nv: int
    njnt: int
    nu: int
    ntendon: int

    body_parent: wp.array(dtype=wp.int32)
    body_root: wp.array(dtype=wp.int32)
    body_pos: wp.array(dtype=wp.vec3)
    body_quat: wp.array(dtype=wp.quat)
    body_ipos: wp.array(dtype=wp.vec3)
    body_iquat: wp.array(dtype=wp.quat)
    body_jntadr: wp.array(dtype=wp.int32)
    body_jntnum: wp.array(dtype=wp.int32)
    body_last_dof: wp.array(dtype=wp.int32)

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
    # [lo, hi) of the dofs in the same dof tree (a dof, its ancestors and descendants): the
    # mass matrix is block-diagonal over these trees, so a row's response stays inside them
    dof_tree_span: wp.array(dtype=wp.vec2i)
    body_tree_span: wp.array(dtype=wp.vec2i)   # of the dofs that move a body; (0, 0) if none
    # entry (i, j) of the mass matrix and its factor (i, j in one dof tree) sits at
    # dof_madr[i] + j of an env's block-diagonal storage (`dynamics.mass_matrix_layout`)
    dof_madr: wp.array(dtype=wp.int32)

    site_body: wp.array(dtype=wp.int32)
    site_pos: wp.array(dtype=wp.vec3)
    site_quat: wp.array(dtype=wp.quat)

    actuator_kind: wp.array(dtype=wp.int32)
    actuator_dof: wp.array(dtype=wp.int32)
    actuator_qposadr: wp.array(dtype=wp.int32)
    actuator_ctrllimited: wp.array(dtype=wp.int32)
    actuator_ctrlrange: wp.array(dtype=wp.vec2)
    actuator_forcelimited: wp.array(dtype=wp.int32)
    actuator_forcerange: wp.array(dtype=wp.vec2)

    tendon_adr: wp.array(dtype=wp.int32)
    tendon_num: wp.array(dtype=wp.int32)
    wrap_jnt: wp.array(dtype=wp.int32)
    wrap_coef: wp.array(dtype=float)
    wrap_recip: wp.array(dtype=float)
    tendon_limited: wp.array(dtype=wp.int32)


@wp.struct
class EnvParams:
    body_mass: wp.array2d(dtype=float)
    body_inertia: wp.array2d(dtype=wp.vec3)
    jnt_stiffness: wp.array2d(dtype=float)
    dof_damping: wp.array2d(dtype=float)
    dof_armature: wp.array2d(dtype=float)
    actuator_gear: wp.array2d(dtype=float)
    actuator_gain: wp.array2d(dtype=float)
    actuator_kp: wp.array2d(dtype=float)
    actuator_kv: wp.array2d(dtype=float)
    tendon_stiffness: wp.array2d(dtype=float)
    tendon_damping: wp.array2d(dtype=float)
    tendon_limit_stiffness: wp.array2d(dtype=float)
    tendon_rest_length: wp.array2d(dtype=float)
    tendon_offset: wp.array2d(dtype=float)
    tendon_range: wp.array2d(dtype=wp.vec2)
    gravity: wp.array(dtype=wp.vec3)
