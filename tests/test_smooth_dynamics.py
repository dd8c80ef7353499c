"""Smooth dynamics against MuJoCo (the oracle) on the same model.

Each quantity is compared for several envs at once, each env at its own random state, so the
batching is checked along with the physics. Tolerances are float32-sized, stated per check,
relative to the scale of the quantity where it spans orders of magnitude.
"""

import copy
import importlib.util
import math

import mujoco
import numpy as np
import pytest
import torch

import myriad
from myriad.assets import g1_spec
from myriad.physics.importer import from_mujoco
from models import capsule_chain_xml, chain_xml, random_tree_xml
from oracle import free_motion_mujoco, full_mass_matrix, random_qpos

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

NUM_ENVS = 4

MODELS = {
    "ant": lambda: myriad.load(myriad.asset_path("ant.xml")),
    "humanoid": lambda: myriad.load(myriad.asset_path("humanoid.xml")),
    "random_tree": lambda: myriad.load_xml(random_tree_xml(seed=7, nbody=30), "random_tree"),
    "chain_1to1000": lambda: myriad.load_xml(chain_xml(nlink=10, mass_ratio=1000.0), "chain"),
}
if importlib.util.find_spec("cmeel") is not None:       # example-robot-data (.[anymal])
    MODELS["g1"] = lambda: from_mujoco(g1_spec().compile(), source="g1")


# Trajectory tolerances after 100 steps: positions (m or rad) and velocities (relative to their
# largest value). float32 forward dynamics carries a relative error of about cond(M)·2⁻²³ (see
# the conditioning test): ~1e-4 for the robots, but cond(M) ≈ 5e4 for the 1:1000 chain, whose
# accelerations are good to ~5e-4 relative, and whose velocities drift apart from MuJoCo's
# float64 ones by up to ~2.5e-2 relative over 100 steps of whipping motion (measured).
TRAJECTORY_TOL = {"ant": (1e-3, 1e-3), "humanoid": (1e-3, 1e-3), "random_tree": (1e-3, 1e-3),
                  "chain_1to1000": (1e-2, 5e-2), "g1": (1e-3, 1e-3)}


@pytest.fixture(scope="module", params=list(MODELS))
def model(request):
    model = MODELS[request.param]()
    model.test_name = request.param
    return model


def test_test_models_are_what_they_claim(model):
    name = model.test_name
    if name == "humanoid":
        assert (model.nq, model.nv, model.nu) == (28, 27, 21)
    if name == "ant":
        assert (model.nq, model.nv, model.nu) == (15, 14, 8)
    if name == "g1":
        assert (model.nq, model.nv, model.nbody) == (36, 35, 30)      # the pelvis, 29 links
    if name == "random_tree":
        assert model.nbody == 30 and set(model.jnt_type.tolist()) == {0, 1, 2, 3}
        assert any(n >= 2 for n in model.body_jntnum), "no body with two joints"
    if name == "chain_1to1000":
        assert model.nbody == 10
        assert model.body_mass.max() / model.body_mass.min() == pytest.approx(1000.0, rel=1e-3)


def _set_random_states(model, sim, seed):
    """Random q, qd per env; returns MuJoCo's MjData for each env, after mj_forward."""
    mj = model.mj_model
    rng = np.random.default_rng(seed)
    datas = []
    for e in range(sim.num_envs):
        d = mujoco.MjData(mj)
        d.qpos[:] = random_qpos(mj, rng)
        d.qvel[:] = rng.normal(size=mj.nv)
        mujoco.mj_forward(mj, d)
        sim.q[e] = torch.as_tensor(model.qpos_from_mujoco(d.qpos), dtype=torch.float32)
        sim.qd[e] = torch.as_tensor(d.qvel, dtype=torch.float32)
        datas.append(d)
    sim.forward()
    return datas


def test_kinematics_mass_matrix_bias_and_jacobians(model, device):
    sim = myriad.Simulator(model, num_envs=NUM_ENVS, device=device)
    datas = _set_random_states(model, sim, seed=1)
    mj = model.mj_model
    pose = sim.body_pose.cpu().numpy()
    vel = sim.body_vel.cpu().numpy()
    qm = sim.mass_matrix.cpu().numpy()
    bias = sim.bias_force.cpu().numpy()
    jac = sim.body_jacobians().cpu().numpy()
    for e, d in enumerate(datas):
        # body frames: positions within 1e-5 m, orientations within 1e-5 (quaternion sign-free)
        np.testing.assert_allclose(pose[e, :, :3], d.xpos[1:], atol=1e-5)
        quat = d.xquat[1:][:, [1, 2, 3, 0]]
        sign = np.sign(np.sum(pose[e, :, 3:] * quat, axis=1, keepdims=True))
        np.testing.assert_allclose(pose[e, :, 3:] * sign, quat, atol=1e-5)
        # centers of mass
        np.testing.assert_allclose(sim.body_com[e].cpu().numpy(), d.xipos[1:], atol=1e-5)
        # mass matrix and bias forces: relative to their largest entry
        m_ref = full_mass_matrix(mj, d)
        np.testing.assert_allclose(qm[e], m_ref, atol=2e-6 * np.abs(m_ref).max())
        np.testing.assert_allclose(bias[e], d.qfrc_bias, atol=2e-5 * np.abs(d.qfrc_bias).max())
        for b in range(model.nbody):
            # body velocity (linear at the body origin, angular), world frame
            ref = np.zeros(6)
            mujoco.mj_objectVelocity(mj, d, mujoco.mjtObj.mjOBJ_XBODY, b + 1, ref, 0)
            scale = 1e-5 * (1 + np.abs(ref).max())
            np.testing.assert_allclose(vel[e, b, :3], ref[3:], atol=scale)
            np.testing.assert_allclose(vel[e, b, 3:], ref[:3], atol=scale)
            # Jacobian at the body origin
            jacp, jacr = np.zeros((3, mj.nv)), np.zeros((3, mj.nv))
            mujoco.mj_jacBody(mj, d, jacp, jacr, b + 1)
            np.testing.assert_allclose(jac[e, b, :3], jacp, atol=1e-5)
            np.testing.assert_allclose(jac[e, b, 3:], jacr, atol=1e-5)


def test_acceleration_error_is_bounded_by_conditioning(model, device):
    """One substep's qacc against MuJoCo: relative error below 10·cond(M)·2⁻²³ (float32).

    Both integrate damping implicitly: the acceleration used is (M + h·D)⁻¹·M·qacc_explicit.
    """
    substep = 0.002
    mj, _ = free_motion_mujoco(model, substep)
    sim = myriad.Simulator(model, num_envs=NUM_ENVS, device=device,
                           params=myriad.SimParams(dt=substep, substeps=1, constraints=False))
    datas = _set_random_states(model, sim, seed=4)
    sim.step()
    qacc = sim.qacc.cpu().numpy()
    for e, d in enumerate(datas):
        mass = full_mass_matrix(mj, d)
        cond = np.linalg.cond(mass)
        mujoco.mj_forward(mj, d)
        expected = np.linalg.solve(mass + substep * np.diag(mj.dof_damping), mass @ d.qacc)
        err = np.abs(qacc[e] - expected).max() / np.abs(expected).max()
        assert err < 10 * cond * 2.0**-23, (err, cond)


def test_a_long_light_chain_is_not_limited_by_its_conditioning(device):
    """100 capsules of 0.1 m and 0.1 kg in a hinge chain: cond(M) ≈ 3e8, beyond float32.

    Held out straight, its qacc is within 3 % of MuJoCo's (float64): the factor comes from the
    articulated-body inertias, where an LDL of the float32 M was off by 200 %. Hanging and
    swung by 0.3 rad, it stays finite for 2 s (Isaac Gym's timing), no faster than MuJoCo's
    (it went non-finite in its second step before).
    """
    straight = myriad.load_xml(capsule_chain_xml(100, direction=(1, 0, 0)), "straight")
    sim = myriad.Simulator(straight, device=device,
                           params=myriad.SimParams(dt=1e-4, substeps=1, constraints=False))
    sim.step()                     # qacc of the start state
    d = mujoco.MjData(straight.mj_model)
    mujoco.mj_forward(straight.mj_model, d)
    err = np.abs(sim.qacc[0].cpu().numpy() - d.qacc).max() / np.abs(d.qacc).max()
    assert err < 0.03, err

    hanging = myriad.load_xml(capsule_chain_xml(100), "hanging")
    sim = myriad.Simulator(hanging, device=device, params=myriad.SimParams(dt=1 / 60, substeps=2))
    sim.q[0, 0] = 0.3
    mj = hanging.mj_model
    mj.opt.timestep = 1 / 120
    d = mujoco.MjData(mj)
    d.qpos[0] = 0.3
    ours = theirs = 0.0
    for _ in range(120):
        sim.step()
        ours = max(ours, sim.qd.abs().max().item())
        for _ in range(2):
            mujoco.mj_step(mj, d)
            theirs = max(theirs, np.abs(d.qvel).max())
    assert torch.isfinite(sim.q).all() and torch.isfinite(sim.qd).all()
    assert ours < 1.5 * theirs, (ours, theirs)


def test_body_wrenches_act_like_mujoco_xfrc_applied(model, device):
    """sim.body_force (force at the center of mass, torque; world) is MuJoCo's xfrc_applied:
    the generalized force it adds, qacc·M difference, matches Jᵀ·wrench from MuJoCo."""
    substep = 0.002
    mj = model.mj_model
    sim = myriad.Simulator(model, num_envs=NUM_ENVS, device=device,
                           params=myriad.SimParams(dt=substep, substeps=1, constraints=False))
    datas = _set_random_states(model, sim, seed=5)
    rng = np.random.default_rng(6)
    wrench = rng.normal(size=(NUM_ENVS, model.nbody, 6)) * 10.0
    sim.body_force = torch.as_tensor(wrench, dtype=torch.float32, device=sim.torch_device)
    sim.forward()
    applied = sim.data.dynamics.qfrc_applied.numpy()
    for e, d in enumerate(datas):
        expected = np.zeros(mj.nv)
        for b in range(model.nbody):
            # qfrc of a force at the body's center of mass and a torque: J_comᵀ f + J_rotᵀ τ
            mujoco.mj_applyFT(mj, d, wrench[e, b, :3], wrench[e, b, 3:], d.xipos[b + 1], b + 1,
                              expected)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(applied[e], expected, atol=1e-4 * scale)


def test_site_poses_and_jacobians(device):
    model = myriad.load(myriad.asset_path("ant.xml"))
    assert model.nsite > 0
    sim = myriad.Simulator(model, num_envs=2, device=device)
    datas = _set_random_states(model, sim, seed=3)
    mj = model.mj_model
    jac = sim.site_jacobians().cpu().numpy()
    for e, d in enumerate(datas):
        np.testing.assert_allclose(sim.site_pose[e, :, :3].cpu().numpy(), d.site_xpos, atol=1e-5)
        for s in range(model.nsite):
            jacp, jacr = np.zeros((3, mj.nv)), np.zeros((3, mj.nv))
            mujoco.mj_jacSite(mj, d, jacp, jacr, s)
            np.testing.assert_allclose(jac[e, s, :3], jacp, atol=1e-5)
            np.testing.assert_allclose(jac[e, s, 3:], jacr, atol=1e-5)


def test_free_motion_matches_mujoco(model, device):
    """100 steps (2 substeps each) under random generalized forces, no contacts, per env."""
    substep = 0.002
    mj, _ = free_motion_mujoco(model, substep)
    sim = myriad.Simulator(model, num_envs=NUM_ENVS, device=device,
                           params=myriad.SimParams(dt=2 * substep, substeps=2, constraints=False))
    datas = _set_random_states(model, sim, seed=2)
    rng = np.random.default_rng(5)
    # forces scaled by the mass-matrix diagonal: accelerations of order 0.1 on every dof
    force_scale = 0.1 * np.diagonal(sim.mass_matrix[0].cpu().numpy())
    for _ in range(100):
        forces = rng.normal(size=(NUM_ENVS, mj.nv)) * force_scale
        sim.joint_force = torch.as_tensor(forces, dtype=torch.float32, device=sim.torch_device)
        for e, d in enumerate(datas):
            d.qfrc_applied[:] = forces[e]
            mujoco.mj_step(mj, d)
            mujoco.mj_step(mj, d)
        sim.step()
    q = sim.q.cpu().numpy()
    qd = sim.qd.cpu().numpy()
    q_tol, qd_tol = TRAJECTORY_TOL[model.test_name]
    for e, d in enumerate(datas):
        assert np.all(np.isfinite(q[e]))
        np.testing.assert_allclose(q[e], model.qpos_from_mujoco(d.qpos), atol=q_tol)
        np.testing.assert_allclose(qd[e], d.qvel, atol=qd_tol * (1 + np.abs(d.qvel).max()))
    # after step(), poses describe the new state
    d = datas[0]
    mujoco.mj_kinematics(mj, d)
    np.testing.assert_allclose(sim.body_pose[0, :, :3].cpu().numpy(), d.xpos[1:], atol=1e-3)


def test_implicit_integrator_is_mujocos_implicit(model, device):
    """integrator="implicit": one substep from random states with fast joints (qd ~ 10 rad/s)
    gives MuJoCo's "implicit" velocities (the Coriolis and centrifugal forces' derivative in
    qd, dof damping), which differ from Euler's by far more than the tolerance."""
    h = 1.0 / 120.0
    mj, _ = free_motion_mujoco(model, h)
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT
    sim = myriad.Simulator(model, num_envs=NUM_ENVS, device=device, params=myriad.SimParams(
        dt=h, substeps=1, constraints=False, integrator="implicit"))
    datas = _set_random_states(model, sim, seed=3)
    euler = []
    for e, d in enumerate(datas):
        d.qvel[:] *= 10.0
        sim.qd[e] = torch.as_tensor(d.qvel, dtype=torch.float32)
        explicit = copy.deepcopy(d)
        mj.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
        mujoco.mj_step(mj, explicit)
        euler.append(explicit.qvel.copy())
        mj.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT
        mujoco.mj_step(mj, d)
    sim.step()
    qd = sim.qd.cpu().numpy()
    apart = []
    for e, d in enumerate(datas):
        scale = 1 + np.abs(d.qvel).max()
        np.testing.assert_allclose(qd[e], d.qvel, atol=1e-4 * scale)
        apart.append(np.abs(euler[e] - d.qvel).max() / scale)
    assert max(apart) > 20 * 1e-4      # the check above tells the two integrators apart


def test_implicit_integrator_keeps_a_fast_spin_bounded(device):
    """A free box with a flapping two-link tail, no gravity, 2 s at h = 1/120 s: explicit
    Euler (MuJoCo's alike) feeds the velocity-product forces back into the spin without bound;
    the implicit integrator never gains energy and loses what MuJoCo's implicit loses."""
    xml = """<mujoco><option gravity="0 0 0"/><worldbody><body><freejoint/>
      <geom type="box" size="0.2 0.05 0.02" mass="1"/>
      <body pos="0.2 0 0"><joint type="hinge" axis="0 0 1"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01" mass="0.05"/>
        <body pos="0.1 0 0"><joint type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.05 0 0" size="0.008" mass="0.01"/></body>
      </body></body></worldbody></mujoco>"""
    model = myriad.load_xml(xml, "spinning_tail")
    qd0 = [0.0, 0.0, 0.0, 3.0, 20.0, 5.0, 30.0, -40.0]
    mj = copy.deepcopy(model.mj_model)
    mj.opt.timestep = 1.0 / 120.0
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT
    d = mujoco.MjData(mj)
    d.qvel[:] = qd0
    mujoco.mj_step(mj, d, nstep=240)
    kinetic = {}
    for integrator in ("euler", "implicit"):
        sim = myriad.Simulator(model, num_envs=1, device=device, params=myriad.SimParams(
            dt=1.0 / 60.0, substeps=2, constraints=False, integrator=integrator,
            max_angular_velocity=math.inf))         # MuJoCo has no body speed caps
        sim.qd[:] = torch.tensor([qd0])
        energy = []
        for _ in range(120):
            sim.step()
            qd = sim.qd[0].double()
            energy.append(float(0.5 * qd @ sim.mass_matrix[0].double() @ qd))
        kinetic[integrator] = np.nan_to_num(np.asarray(energy), nan=np.inf)
    rest = mujoco.MjData(mj)
    mujoco.mj_forward(mj, rest)
    start = 0.5 * np.asarray(qd0) @ full_mass_matrix(mj, rest) @ np.asarray(qd0)
    mujoco.mj_forward(mj, d)
    mj_end = 0.5 * d.qvel @ full_mass_matrix(mj, d) @ d.qvel
    assert kinetic["euler"].max() > 100 * start
    assert kinetic["implicit"].max() <= start * (1 + 1e-3)
    assert abs(kinetic["implicit"][-1] - mj_end) < 0.02 * start


def test_implicit_integrator_keeps_contact_impulses(device):
    """The implicit step rescales a substep's whole velocity change, contact impulses
    included: a box resting on the ground stays at rest and its contacts carry its weight,
    spinning or not (a box spun at 20 rad/s about the vertical keeps spinning, slowed by friction
    alone, and stays on the ground)."""
    xml = """<mujoco><worldbody><geom type="plane" size="5 5 0.1" friction="0.05"/>
      <body pos="0 0 0.05"><freejoint/>
        <geom type="box" size="0.2 0.1 0.05" mass="2" friction="0.05"/></body>
      </worldbody></mujoco>"""
    model = myriad.load_xml(xml, "resting_box")
    sim = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(integrator="implicit"))
    sim.qd[1, 5] = 20.0
    for _ in range(60):
        sim.step()
    qd = sim.qd.cpu()
    assert qd[0].abs().max() < 1e-3
    weight = 2.0 * 9.81
    force = sim.contact_force[0, :int(sim.contact_count[0])].cpu().sum(0)
    assert abs(float(force[2]) - weight) < 0.01 * weight
    assert abs(float(sim.q[1, 2]) - 0.05) < 2e-3         # on the ground
    assert 0.0 < float(qd[1, 5]) < 20.0 and qd[1, :5].abs().max() < 0.05


def test_gravity_compensation_is_mujocos_gravcomp(device):
    """A body's gravcomp cancels that share of its weight (Isaac Gym's disable_gravity is 1):
    the bias force is MuJoCo's qfrc_bias less its qfrc_gravcomp, and a fully compensated arm
    hangs still where gravity would swing it."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <body name="a" gravcomp="1"><joint type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03"/>
        <body name="b" pos="0.3 0 0" gravcomp="0.5"><joint type="hinge" axis="0 1 0"/>
          <geom type="capsule" fromto="0 0 0 0.3 0 0.1" size="0.03"/>
          <body name="c" pos="0.3 0 0.1"><joint type="hinge" axis="1 0 0"/>
            <geom type="box" size="0.05 0.02 0.04" pos="0.05 0 0"/></body></body></body>
      </worldbody></mujoco>""", "gravcomp")
    sim = myriad.Simulator(model, num_envs=2, device=device)
    mj = model.mj_model
    d = mujoco.MjData(mj)
    d.qpos[:] = [0.3, -0.7, 0.4]
    d.qvel[:] = [1.0, -2.0, 0.5]
    mujoco.mj_forward(mj, d)
    sim.q = torch.as_tensor(d.qpos, dtype=torch.float32, device=sim.torch_device)
    sim.qd = torch.as_tensor(d.qvel, dtype=torch.float32, device=sim.torch_device)
    sim.forward()
    expected = d.qfrc_bias - d.qfrc_gravcomp
    assert np.abs(d.qfrc_gravcomp).max() > 0.1                  # the compensation matters here
    np.testing.assert_allclose(sim.bias_force[0].cpu().numpy(), expected,
                               atol=2e-5 * np.abs(expected).max() + 1e-6)
    still = myriad.load_xml("""<mujoco><worldbody>
      <body name="arm" gravcomp="1"><joint type="hinge" axis="0 1 0"/>
        <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/></body></worldbody></mujoco>""",
                            "held")
    sim = myriad.Simulator(still, num_envs=1, device=device)
    for _ in range(60):
        sim.step()
    assert abs(sim.q[0, 0].item()) < 1e-6                     # without gravcomp: falls
