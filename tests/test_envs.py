"""Envs are independent: a change to one env's parameters or state changes no other env."""

import numpy as np
import pytest
import torch

import myriad


@pytest.fixture(scope="module")
def ant():
    return myriad.load(myriad.asset_path("ant.xml"))


def _run(sim, steps=30, seed=0):
    g = torch.Generator().manual_seed(seed)
    for _ in range(steps):
        sim.joint_force = (torch.randn(sim.num_envs, sim.model.nv, generator=g) * 2).to(sim.torch_device)
        sim.step()
    return sim.q.cpu().clone(), sim.qd.cpu().clone()


def test_changing_one_env_changes_no_other(ant, device):
    ref = myriad.Simulator(ant, num_envs=4, device=device)
    q_ref, qd_ref = _run(ref)

    # one change at a time, to one env: every other env stays bit-identical to the reference
    for e, change in enumerate([lambda s: s.q[0, 2].add_(0.5),
                                lambda s: s.body_mass[1].mul_(3.0),
                                lambda s: s.dof_damping[2].add_(1.0),
                                lambda s: s.gravity[3].zero_()]):
        sim = myriad.Simulator(ant, num_envs=4, device=device)
        change(sim)
        q, qd = _run(sim)
        for o in range(4):
            if o != e:
                assert torch.equal(q[o], q_ref[o]) and torch.equal(qd[o], qd_ref[o]), (e, o)
        assert not torch.allclose(q[e], q_ref[e], atol=1e-4)


def test_per_env_gravity(ant, device):
    sim = myriad.Simulator(ant, num_envs=2, device=device, params=myriad.SimParams(constraints=False))
    sim.gravity[1] = torch.tensor([0.0, 0.0, -3.721], device=sim.torch_device)  # Mars
    for _ in range(30):
        sim.step()
    # free fall of the whole ant (no contacts yet), semi-implicit Euler over n substeps of h:
    # v_k = k·g·h, so the drop is g·h²·n(n+1)/2 (= ½·g·t²·(1 + 1/n))
    n, h = 30 * sim.params.substeps, sim.h
    drop = (ant.qpos0[2] - sim.q[:, 2].cpu()).numpy()
    np.testing.assert_allclose(drop, np.array([9.81, 3.721]) * h * h * n * (n + 1) / 2, rtol=1e-5)


def test_writes_are_validated(ant, device):
    sim = myriad.Simulator(ant, num_envs=3, device=device)
    with pytest.raises(ValueError, match=r"sim\.q: cannot write a tensor of shape \(5,\) into shape \(3, 15\)"):
        sim.q = torch.zeros(5)
    with pytest.raises(ValueError, match=r"sim\.body_mass"):
        sim.body_mass = torch.ones(3, ant.nbody + 1)
    sim.q = torch.as_tensor(ant.qpos0, device=sim.torch_device)  # broadcasting one configuration to every env is fine
    sim.ctrl = 0.5
    assert torch.all(sim.ctrl == 0.5)


def test_bad_constructor_arguments(ant):
    with pytest.raises(ValueError, match="num_envs"):
        myriad.Simulator(ant, num_envs=0)
    with pytest.raises(ValueError, match="substeps"):
        myriad.SimParams(substeps=0)
    with pytest.raises(ValueError, match="dt"):
        myriad.SimParams(dt=-1.0)
    with pytest.raises(ValueError, match=r"integrator='rk4': must be 'euler' or 'implicit'"):
        myriad.SimParams(integrator="rk4")
    with pytest.raises(ValueError, match=r"self_collisions=0: must be True or False"):
        myriad.SimParams(self_collisions=0)
    with pytest.raises(ValueError, match=r"constraints='no': must be True or False"):
        myriad.SimParams(constraints="no")
    with pytest.raises(ValueError, match="not available"):
        myriad.Simulator(ant, device="cuda:7")
    with pytest.raises(TypeError, match="myriad.Model"):
        myriad.Simulator("ant.xml")
