"""Stage 6, integration: semi-implicit Euler in generalized coordinates.

qd' = qd + h·qacc, then q' = q ⊕ h·qd': hinge and slide add, free-joint positions add the
world-frame linear velocity, and quaternions (ball joints, free-joint rotations) are rotated by
the body-frame angular velocity through the exponential map and renormalized, as MuJoCo's
`mj_integratePos`.
"""

import warp as wp

from . import model as M
from .spatial import quat_integrate
from .structs import ModelArrays

FREE = wp.constant(M.JOINT_FREE)
BALL = wp.constant(M.JOINT_BALL)


@wp.kernel
def integrate(m: ModelArrays, h: float, qacc: wp.array2d(dtype=float),
              q: wp.array2d(dtype=float), qd: wp.array2d(dtype=float)):
    e = wp.tid()
    for i in range(m.nv):
        qd[e, i] = qd[e, i] + h * qacc[e, i]
    for j in range(m.njnt):
        t = m.jnt_type[j]
        a = m.jnt_qposadr[j]
        d = m.jnt_dofadr[j]
        if t == FREE or t == BALL:
            if t == FREE:
                for k in range(3):
                    q[e, a + k] = q[e, a + k] + h * qd[e, d + k]
                a = a + 3
                d = d + 3
            rot = wp.quat(q[e, a], q[e, a + 1], q[e, a + 2], q[e, a + 3])
            rot = quat_integrate(wp.normalize(rot), wp.vec3(qd[e, d], qd[e, d + 1], qd[e, d + 2]), h)
            for k in range(4):
                q[e, a + k] = rot[k]
        else:
            q[e, a] = q[e, a] + h * qd[e, d]
