"""The GPU's launch configuration, on the CPU: cooperative kernels (`myriad.physics.lanes`) give
the one-lane numbers with any number of lanes per world and any number of worlds per block
(bit for bit around the solve; the solve within float32's summation order), and a world's
trajectory depends neither on its index nor on the worlds stepped beside it.

`MYRIAD_CPU_BLOCK_DIM=N` makes a CPU simulator launch the cooperative kernels in blocks of N
threads, through Warp's cooperative CPU fibers, exactly as CUDA does (`runtime.BlockDim`: lanes
per world, worlds per block); it is read when a simulator is built, so one test process can
compare configurations side by side. Around the solve every item of a world (a body, a dof, a
joint, a row) is computed by one lane in the same arithmetic and sums keep a fixed order, so
those comparisons are exact; the solve's lanes share each row's sums.
"""

import dataclasses

import numpy as np
import pytest
import torch
import warp as wp

import myriad
from memory import hand_and_cube_xml      # benchmarks/memory.py: the 30-DoF stand-in
from myriad.physics import step
from myriad.physics.lanes import world_lane

pytestmark = pytest.mark.lanes

MODELS = {"ant": lambda: myriad.load(myriad.asset_path("ant.xml")),
          "humanoid": lambda: myriad.load(myriad.asset_path("humanoid.xml")),
          "hand-and-cube": lambda: myriad.load_xml(hand_and_cube_xml(), "hand-and-cube")}


def run(model, controls: torch.Tensor, block_dim: int, monkeypatch,
        device: str = "cpu") -> torch.Tensor:
    """q after stepping one env per row of `controls` [steps, envs, nu] with blocks of
    `block_dim` CPU threads (on CUDA: `runtime.BlockDim`'s)."""
    monkeypatch.setenv("MYRIAD_CPU_BLOCK_DIM", str(block_dim))
    sim = myriad.Simulator(model, num_envs=controls.shape[1], device=device, cpu_threads=1)
    for ctrl in controls.to(sim.torch_device):
        sim.ctrl = ctrl
        sim.step()
    assert int(sim.contact_count.sum()) > 0        # contacts were part of it
    return sim.q.cpu().clone()


@pytest.mark.parametrize("name", list(MODELS))
def test_the_stages_around_the_solve_give_the_one_lane_results_bit_for_bit(name, monkeypatch):
    """10 steps with contacts, the solve one lane per world (the default): one lane per world against
    blocks of 32 threads (the CUDA configuration: several worlds per block, the last block
    partly empty) and of 3 (lanes that do not divide the items evenly)."""
    monkeypatch.setattr(step, "BLOCK_DIM", dataclasses.replace(step.BLOCK_DIM, solve=1))
    model = MODELS[name]()
    controls = torch.rand(10, 5, model.nu, generator=torch.Generator().manual_seed(0)) * 2 - 1
    one_lane = run(model, controls, 1, monkeypatch)
    assert torch.isfinite(one_lane).all()
    assert torch.equal(run(model, controls, 1, monkeypatch), one_lane)        # run to run
    for block_dim in (32, 3):
        assert torch.equal(run(model, controls, block_dim, monkeypatch), one_lane), block_dim


@pytest.mark.parametrize("name, scale", [("ant", 1.0), ("hand-and-cube", 1.0), ("humanoid", 0.0)])
def test_the_cooperative_solve_matches_the_one_lane_solve(name, scale, monkeypatch):
    """The cooperative solve (`BlockDim(solve=0)`: a world per block; not the default) sums
    each row's J·v in another order than one lane (a block-wide reduction): 10 steps with contacts stay within 1e-5 of the one-lane joint positions, and
    repeat bit for bit. (The humanoid lies down under no input: under random torques its
    unconverged sweeps amplify the last bits, 1e-3 after 10 steps, as any change of the sums'
    order does.)"""
    monkeypatch.setattr(step, "BLOCK_DIM", dataclasses.replace(step.BLOCK_DIM, solve=0))
    model = MODELS[name]()
    controls = scale * (torch.rand(10, 5, model.nu,
                                   generator=torch.Generator().manual_seed(0)) * 2 - 1)
    one_lane = run(model, controls, 1, monkeypatch)
    lanes = {block_dim: run(model, controls, block_dim, monkeypatch) for block_dim in (32, 3)}
    for block_dim, q in lanes.items():
        assert (q - one_lane).abs().max() < 1e-5, block_dim
    assert torch.equal(run(model, controls, 32, monkeypatch), lanes[32])     # run to run


@pytest.mark.parametrize("block_dim", [1, 32])
def test_a_worlds_trajectory_repeats_and_does_not_depend_on_its_index_or_neighbours(
        block_dim, monkeypatch, device):
    """The humanoid's world 3 of 5 steps exactly as in a second run, as the same world alone,
    and as the last of 9 (on CUDA too, where contacts are found by a thread per pair)."""
    if device != "cpu" and block_dim != 1:
        pytest.skip("MYRIAD_CPU_BLOCK_DIM is the CPU's; CUDA runs runtime.BlockDim")
    model = MODELS["humanoid"]()
    controls = torch.rand(10, 5, model.nu, generator=torch.Generator().manual_seed(1)) * 2 - 1
    batch = run(model, controls, block_dim, monkeypatch, device)
    assert torch.equal(run(model, controls, block_dim, monkeypatch, device), batch)
    alone = run(model, controls[:, 3:4], block_dim, monkeypatch, device)
    others = torch.rand(10, 8, model.nu, generator=torch.Generator().manual_seed(2)) * 2 - 1
    last = run(model, torch.cat([others, controls[:, 3:4]], dim=1), block_dim, monkeypatch,
               device)
    assert torch.equal(alone[0], batch[3])
    assert torch.equal(last[8], batch[3])


def test_a_bad_block_dim_is_named(monkeypatch):
    monkeypatch.setenv("MYRIAD_CPU_BLOCK_DIM", "many")
    with pytest.raises(ValueError, match="MYRIAD_CPU_BLOCK_DIM='many'"):
        myriad.Simulator(MODELS["ant"](), num_envs=1)


@wp.kernel
def _who_runs(out: wp.array2d(dtype=int), lanes: int):
    block, thread = wp.tid()
    e, lane, active = world_lane(block, thread, lanes, out.shape[0])
    if active:
        out[e, lane] = 100 * lanes + wp.block_dim()


@pytest.mark.parametrize("block_dim, expected", [(1, [101, 0, 0, 0]), (32, [432] * 4),
                                                 (2, [202, 202, 0, 0])])
def test_the_block_dim_reaches_the_kernels(block_dim, expected, monkeypatch):
    """Each world gets min(4, block_dim) lanes in blocks of block_dim threads: the launch runs
    as configured (so the comparisons above did compare configurations)."""
    monkeypatch.setenv("MYRIAD_CPU_BLOCK_DIM", str(block_dim))
    sim = myriad.Simulator(MODELS["ant"](), num_envs=5, cpu_threads=1)
    out = wp.zeros((5, 4), dtype=int, device="cpu")
    sim.runtime.launch_lanes(_who_runs, 4, [out])
    np.testing.assert_array_equal(out.numpy(), np.tile(expected, (5, 1)))


def test_a_block_dim_the_kernels_cannot_run_is_refused():
    """The sweeps wait on the block inside loops as long as each world's contact count, so their
    lanes are one thread or the whole block (several worlds per block hung an H100); other lane
    counts must divide the block's threads."""
    from myriad.physics.runtime.launch import BlockDim
    with pytest.raises(ValueError, match="BlockDim.solve=8: must be 1"):
        BlockDim(solve=8)
    with pytest.raises(ValueError, match="BlockDim.bodies=3: must divide threads=32"):
        BlockDim(bodies=3)
    assert BlockDim().solve == 1 and BlockDim(solve=0).solve == 0
