"""Stage 6, integration: q ⊕ dq, the displacement accumulated by the solver.

Hinge and slide coordinates add, free-joint positions add the world-frame displacement, and
quaternions (ball joints, free-joint rotations) are rotated by the body-frame rotation vector
through the exponential map and renormalized, as MuJoCo's `mj_integratePos`. Without
constraints dq = h·(qd + h·qacc): semi-implicit Euler.

A non-finite quaternion or rotation stays NaN (normalizing would quietly make it a rotation), and
an env whose state is no longer finite is flagged in `nonfinite`.
"""

import warp as wp

from ..types import BALL, FREE
from ..lanes import stop, sync, world_lane
from ..spatial import quat_integrate
from ..structs import ModelArrays, State



@wp.kernel
def integrate(m: ModelArrays,
              s: State,     # in: dq, qd; in and out: q; out: nonfinite
              lanes: int):
    """A world's lanes take its joints."""
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, s.nonfinite.shape[0])
    for j in range(lane, stop(m.njnt, 0, active), lanes):
        t = m.jnt_type[j]
        a = m.jnt_qposadr[j]
        d = m.jnt_dofadr[j]
        if t == FREE or t == BALL:
            if t == FREE:
                for k in range(3):
                    s.q[e, a + k] = s.q[e, a + k] + s.dq[e, d + k]
                a = a + 3
                d = d + 3
            rot = wp.quat(s.q[e, a], s.q[e, a + 1], s.q[e, a + 2], s.q[e, a + 3])
            w = wp.vec3(s.dq[e, d], s.dq[e, d + 1], s.dq[e, d + 2])
            if wp.isfinite(rot) and wp.isfinite(w):
                rot = quat_integrate(wp.normalize(rot), w, 1.0)
            else:  # normalize and the exponential map would turn NaN into a valid rotation
                rot = wp.quat(wp.nan, wp.nan, wp.nan, wp.nan)
            for k in range(4):
                s.q[e, a + k] = rot[k]
        else:
            s.q[e, a] = s.q[e, a] + s.dq[e, d]
    if lanes > 1:
        sync()
    # flag an env whose state is no longer finite; it stays flagged until its owner resets it
    bad = int(0)
    for i in range(lane, stop(s.q.shape[1], 0, active), lanes):
        if not wp.isfinite(s.q[e, i]):
            bad = 1
    for i in range(lane, stop(m.nv, 0, active), lanes):
        if not wp.isfinite(s.qd[e, i]):
            bad = 1
    if bad != 0:
        s.nonfinite[e] = 1
