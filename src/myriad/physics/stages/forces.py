"""Generalized forces of one substep: user forces, actuators, joint springs and dampers.

Writes the explicit force `qfrc` (already minus the bias forces) and `implicit_diag`, the diagonal
joint-space terms h·d + h²·k that the solve adds to the mass matrix. Implicit terms are exact for
the linearized update qd' = qd + h·qacc, q' = q + h·qd':
  joint damping d:        f = -d·qd'                      -> rhs -d·qd,            diag h·d
  position actuator:      f = g·(kp·(u - g·q') - kv·g·qd') -> rhs g·(kp·(u - g·q - h·g·qd) - kv·g·qd),
                                                             diag g²·(h·kv + h²·kp)
  velocity actuator:      f = g·kv·(u - g·qd')            -> rhs g·kv·(u - g·qd),  diag g²·h·kv
An actuator whose predicted force (qacc = 0) exceeds its force range applies the clamped force
explicitly instead; so does a joint whose summed actuator force exceeds its effort limit. Joint
springs are explicit, as in MuJoCo. Fixed-tendon springs are soft constraint rows of the solver
(implicit along the tendon only, see `constraints`).

Non-finite input (NaN or ±inf in an env's `ctrl`, `joint_force` or `body_force`) is never clamped
or dropped: the env is flagged in `nonfinite` and every one of its generalized forces becomes NaN,
so its whole state is NaN after the substep, exactly like an env whose state went non-finite. The
other envs are untouched (every kernel is per env).
"""

import warp as wp

from ..lanes import stop, sync, world_lane
from ..types import HINGE, MOTOR, POSITION, SLIDE
from ..spatial import row_finite
from .dynamics import subtree_sums
from ..structs import Control, Dynamics, EnvParams, ModelArrays, Options, State



@wp.kernel
def generalized_forces(m: ModelArrays, p: EnvParams, opt: Options,
                       s: State,      # in: q, qd; out: nonfinite
                       c: Control,    # in: ctrl
                       # in: qfrc_applied, bias; out: qfrc_actuator, actuator_force, qfrc,
                       # implicit_diag
                       d: Dynamics,
                       lanes: int):
    """Explicit generalized force `qfrc` (minus the bias) and the implicit diagonal of this
    substep, from the applied forces (`body_wrenches`), actuators, damping and joint springs:
    a world's lanes take its dofs, each dof with its actuators (in their order) and its joint."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    h = opt.h
    # non-finite input: the clamps below would turn a NaN ctrl into a bound, so the check
    # looks at the inputs themselves; the env is flagged and its forces poisoned, never patched
    bad = False
    if active:
        bad = not (row_finite(c.ctrl, e, m.nu) and row_finite(d.qfrc_applied, e, m.nv))
        if bad and lane == 0:
            s.nonfinite[e] = 1
    for i in range(lane, stop(m.nv, 0, active), lanes):
        damping = p.dof_damping[e, i]
        qfrc = d.qfrc_applied[e, i] - d.bias[e, i] - damping * s.qd[e, i]
        implicit = h * damping
        actuated = float(0.0)
        for k in range(m.dof_actuator_adr[i], m.dof_actuator_adr[i] + m.dof_actuator_num[i]):
            a = m.dof_actuator[k]
            g = p.actuator_gear[e, a]
            u = c.ctrl[e, a]
            if m.actuator_ctrllimited[a] != 0:
                r = m.actuator_ctrlrange[a]
                u = wp.clamp(u, r[0], r[1])
            kind = m.actuator_kind[a]
            force = float(0.0)
            stiff = float(0.0)
            damp = float(0.0)
            if kind == MOTOR:
                force = p.actuator_gain[e, a] * u
            else:
                kv = p.actuator_kv[e, a]
                if kind == POSITION:
                    kp = p.actuator_kp[e, a]
                    length = g * s.q[e, m.actuator_qposadr[a]]
                    force = kp * (u - length - h * g * s.qd[e, i]) - kv * g * s.qd[e, i]
                    stiff = kp
                else:
                    force = kv * (u - g * s.qd[e, i])
                damp = kv
            # what MuJoCo reports as actuator_force: the force at this state, without the
            # implicit step's prediction of the position (-kp·h·g·qd above), clamped to the
            # force range
            reported = force
            if kind == POSITION:
                reported = (p.actuator_kp[e, a] * (u - g * s.q[e, m.actuator_qposadr[a]])
                            - p.actuator_kv[e, a] * g * s.qd[e, i])
            if m.actuator_forcelimited[a] != 0:
                r = m.actuator_forcerange[a]
                reported = wp.clamp(reported, r[0], r[1])
                if force < r[0] or force > r[1]:
                    force = wp.clamp(force, r[0], r[1])
                    stiff = 0.0
                    damp = 0.0
            d.actuator_force[e, a] = reported
            if bad:
                d.actuator_force[e, a] = wp.nan
            actuated = actuated + g * force
            implicit = implicit + g * g * (h * damp + h * h * stiff)
        j = m.dof_jnt[i]
        t = m.jnt_type[j]
        if t == HINGE or t == SLIDE:
            qfrc = qfrc - p.joint_stiffness[e, j] * (s.q[e, m.jnt_qposadr[j]]
                                                     - m.jnt_springref[j])
            # effort limit on the joint's total actuator force (URDF effort, MJCF
            # actuatorfrcrange)
            if m.jnt_actfrclimited[j] != 0:
                r = m.jnt_actfrcrange[j]
                if actuated < r[0] or actuated > r[1]:
                    actuated = wp.clamp(actuated, r[0], r[1])
                    implicit = h * damping
        d.qfrc_actuator[e, i] = actuated
        d.qfrc[e, i] = qfrc + actuated
        d.implicit_diag[e, i] = implicit
        if bad:
            d.qfrc_actuator[e, i] = wp.nan
            d.qfrc[e, i] = wp.nan


@wp.kernel
def body_wrenches(m: ModelArrays,
                  s: State,      # in: body_x, body_com, cdof; out: nonfinite
                  c: Control,    # in: joint_force, body_force
                  # out: qfrc_applied; scratch: wrench (each body's, then its subtree's)
                  d: Dynamics,
                  lanes: int):
    """qfrc_applied = joint_force + Jᵀ·(force at the center of mass, torque) of every body.

    `body_force[e, b]` is (force, torque) in world axes, the force acting at the body's center of
    mass. A dof feels the wrenches of all bodies it carries: Σ over its subtree, projected on the
    dof's motion vector (so no per-body Jacobian is ever formed). A non-finite `body_force`
    flags the env and makes all of its `qfrc_applied` NaN, even on a body that no dof carries
    (a non-finite `joint_force` reaches `generalized_forces` through `qfrc_applied`).
    """
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    bad = int(0)
    for b in range(stop(m.nbody, 0, active)):        # every lane reads them all
        if not wp.isfinite(c.body_force[e, b]):
            bad = 1
    for b in range(lane, stop(m.nbody, 0, active), lanes):
        f = wp.spatial_top(c.body_force[e, b])
        torque = wp.spatial_bottom(c.body_force[e, b])
        arm = s.body_com[e, b] - wp.transform_get_translation(s.body_x[e, m.body_root[b]])
        d.wrench[e, b] = wp.spatial_vector(torque + wp.cross(arm, f), f)
    if lanes > 1:
        sync()
    subtree_sums(m, e, lane, lanes, active, d.wrench)
    for i in range(lane, stop(m.nv, 0, active), lanes):
        d.qfrc_applied[e, i] = (c.joint_force[e, i]
                                + wp.dot(s.cdof[e, i], d.wrench[e, m.dof_body[i]]))
        if bad != 0:
            d.qfrc_applied[e, i] = wp.nan
    if bad != 0 and lane == 0:
        s.nonfinite[e] = 1
