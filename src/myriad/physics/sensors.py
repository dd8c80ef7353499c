"""Stage 7, outputs: force/torque sensors, MuJoCo's semantics.

A force/torque sensor on a site reads the wrench that the site's body receives from its parent:
what the body's whole subtree needs, given its motion, minus what the outside world (contacts)
supplies. It is the recursive Newton-Euler pass again, with the accelerations the step actually
produced, (qd - qd_before) / h, and the contact forces as external forces; the result is given
at the site, in the site's frame.
"""

import warp as wp

from .dynamics import accumulate_subtrees, body_forces
from .structs import EnvParams, ModelArrays


@wp.kernel
def force_sensors(m: ModelArrays, p: EnvParams, h: float,
                  body_x: wp.array2d(dtype=wp.transform), body_com: wp.array2d(dtype=wp.vec3),
                  body_iframe: wp.array2d(dtype=wp.quat), cvel: wp.array2d(dtype=wp.spatial_vector),
                  cdof: wp.array2d(dtype=wp.spatial_vector),
                  cdof_dot: wp.array2d(dtype=wp.spatial_vector),
                  qd: wp.array2d(dtype=float), qd_before: wp.array2d(dtype=float),
                  geom_body: wp.array(dtype=wp.int32), contact_capacity: int,
                  contact_count: wp.array(dtype=wp.int32), contact_geom: wp.array2d(dtype=wp.vec2i),
                  contact_pos: wp.array2d(dtype=wp.vec3), contact_force: wp.array2d(dtype=wp.vec3),
                  sensor_site_body: wp.array(dtype=wp.int32),
                  sensor_site: wp.array(dtype=wp.int32), site_x: wp.array2d(dtype=wp.transform),
                  # scratch
                  cacc: wp.array2d(dtype=wp.spatial_vector), cfrc: wp.array2d(dtype=wp.spatial_vector),
                  # output: [env, sensor site] (force, torque) in the site frame
                  wrench: wp.array2d(dtype=wp.spatial_vector)):
    e = wp.tid()
    body_forces(m, p, e, body_x, body_com, body_iframe, qd, qd_before, 1.0 / h, cvel, cdof,
                cdof_dot, cacc, cfrc)
    # contacts are external forces: subtract what they supply (force on geom 2, minus on geom 1)
    for k in range(wp.min(contact_count[e], contact_capacity)):
        pair = contact_geom[e, k]
        f = contact_force[e, k]
        for side in range(2):
            b = geom_body[pair[side]]
            if b >= 0:
                sign = 1.0
                if side == 0:
                    sign = -1.0
                ref = wp.transform_get_translation(body_x[e, m.body_root[b]])
                fb = f * sign
                cfrc[e, b] = cfrc[e, b] - wp.spatial_vector(wp.cross(contact_pos[e, k] - ref, fb), fb)
    accumulate_subtrees(m, e, cfrc)
    for s in range(sensor_site.shape[0]):
        b = sensor_site_body[s]
        x = site_x[e, sensor_site[s]]
        point = wp.transform_get_translation(x)
        ref = wp.transform_get_translation(body_x[e, m.body_root[b]])
        total = cfrc[e, b]
        force = wp.spatial_bottom(total)
        torque = wp.spatial_top(total) - wp.cross(point - ref, force)  # about the site
        rot = wp.transform_get_rotation(x)
        wrench[e, s] = wp.spatial_vector(wp.quat_rotate_inv(rot, force), wp.quat_rotate_inv(rot, torque))
