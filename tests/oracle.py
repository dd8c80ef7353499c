"""MuJoCo as the oracle: the same model, configured to compute what our smooth dynamics computes."""

import mujoco
import numpy as np


def free_motion_mujoco(model, substep: float):
    """MjModel/MjData stepping like our engine without contacts: Euler with implicit damping."""
    mj = model.mj_model
    mj.opt.timestep = substep
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    return mj, mujoco.MjData(mj)


def random_qpos(mj, rng, scale=0.5) -> np.ndarray:
    """qpos0 plus a random displacement, with unit quaternions (MuJoCo layout)."""
    qpos = mj.qpos0 + rng.normal(size=mj.nq) * scale
    for j in range(mj.njnt):
        if mj.jnt_type[j] in (mujoco.mjtJoint.mjJNT_FREE, mujoco.mjtJoint.mjJNT_BALL):
            a = mj.jnt_qposadr[j] + (3 if mj.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE else 0)
            qpos[a:a + 4] /= np.linalg.norm(qpos[a:a + 4])
    return qpos


def full_mass_matrix(mj, d) -> np.ndarray:
    dense = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, d, dense)
    return dense
