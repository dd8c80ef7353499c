"""Stage 7, outputs: force/torque sensors, MuJoCo's semantics.

A force/torque sensor on a site reads the wrench that the site's body receives from its parent:
what the body's whole subtree needs, given its motion, minus what the outside world (contacts)
supplies. It is the recursive Newton-Euler pass again, with the accelerations the step actually
produced, (qd - qd_before) / h, and the contact forces as external forces; the result is given
at the site, in the site's frame.
"""

import warp as wp

from .dynamics import accumulate_subtrees, body_forces
from .structs import Contacts, Dynamics, EnvParams, ModelArrays, State


@wp.kernel
def force_sensors(m: ModelArrays, p: EnvParams, h: float,
                  sensor_site_body: wp.array(dtype=wp.int32),
                  sensor_site: wp.array(dtype=wp.int32),
                  # in: body_x, body_com, body_iframe, cvel, cdof, cdof_dot, qd, qd_before, site_x;
                  # out: sensor_wrench, [env, sensor site] (force, torque) in the site frame
                  s: State,
                  c: Contacts,   # in: count, geom, pos, force
                  d: Dynamics):  # scratch: cacc, cfrc
    e = wp.tid()
    body_forces(m, p, s, e, s.qd_before, 1.0 / h, d)
    # contacts are external forces: subtract what they supply (force on geom 2, minus on geom 1)
    for k in range(wp.min(c.count[e], c.geom.shape[1])):
        pair = c.geom[e, k]
        f = c.force[e, k]
        for side in range(2):
            b = m.geom_body[pair[side]]
            if b >= 0:
                sign = 1.0
                if side == 0:
                    sign = -1.0
                ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
                fb = f * sign
                d.cfrc[e, b] = d.cfrc[e, b] - wp.spatial_vector(wp.cross(c.pos[e, k] - ref, fb), fb)
    accumulate_subtrees(m, e, d.cfrc)
    for i in range(sensor_site.shape[0]):
        b = sensor_site_body[i]
        x = s.site_x[e, sensor_site[i]]
        point = wp.transform_get_translation(x)
        ref = wp.transform_get_translation(s.body_x[e, m.body_root[b]])
        total = d.cfrc[e, b]
        force = wp.spatial_bottom(total)
        torque = wp.spatial_top(total) - wp.cross(point - ref, force)  # about the site
        rot = wp.transform_get_rotation(x)
        s.sensor_wrench[e, i] = wp.spatial_vector(wp.quat_rotate_inv(rot, force),
                                                  wp.quat_rotate_inv(rot, torque))
