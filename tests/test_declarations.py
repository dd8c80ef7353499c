"""The per-env data is declared once (`myriad.physics.structs`): every declared field is allocated
with its declared shape, every public one is the simulator's zero-copy view of it, and every one
is split between CPU threads. The checks loop over the declarations, so a field added to one is
checked here without another line of test."""

import pytest
import torch
import warp as wp

import myriad
from myriad.physics import structs
from myriad.physics.simulator import PublicView, Simulator
from myriad.physics.structs import VIEWED_AS


@pytest.fixture(scope="module")
def sim():
    # the ant: actuators, joint limits, contacts; 7 envs on 3 threads: uneven shards
    model = myriad.load(myriad.asset_path("ant.xml"))
    sim = Simulator(model, num_envs=7, params=myriad.SimParams(contacts_per_env=16),
                    cpu_threads=3)
    sim.step()
    return sim


def declared_fields():
    return [(struct, name, f) for struct in structs.STRUCTS for name, f in struct.fields.items()]


def test_every_declared_field_is_allocated_with_its_shape(sim):
    for struct, name, f in declared_fields():
        array = getattr(sim.data.structs[struct], name)
        assert array.shape == structs.field_shape(f, sim.num_envs, sim.sizes), name
        assert array.dtype == f.dtype, name
        assert array.device == sim.device, name


def test_public_tensors_are_exactly_the_public_fields_and_share_their_memory(sim):
    public = {}
    for struct, name, f in declared_fields():
        if f.public:
            assert f.public not in public, f"two fields are public as {f.public}"
            public[f.public] = f
            array = getattr(sim.data.structs[struct], name)
            view = getattr(sim, f.public)
            if array.size:
                assert view.data_ptr() == array.ptr, f.public          # zero copy
            # the shape declared, where the view shows the leading part of a size (VIEWED_AS)
            shown = [sim.sizes[VIEWED_AS.get(d, d)] if isinstance(d, str) else d for d in f.dims]
            assert tuple(view.shape[:array.ndim]) == (sim.num_envs, *shown), f.public
    descriptors = {n for n, v in vars(Simulator).items() if isinstance(v, PublicView)}
    assert descriptors == set(public)
    for name, f in public.items():
        value = getattr(sim, name).clone()
        if f.writable:
            setattr(sim, name, value)             # a writable view takes a tensor of its shape
        else:
            with pytest.raises(AttributeError, match="read-only"):
                setattr(sim, name, value)


def test_every_field_is_split_between_cpu_threads(sim):
    rt = sim.runtime
    assert len(rt.shards) == 3
    covered = 0
    for lo, hi in rt.shards:
        with rt.in_shard(lo, hi):
            for struct, name, f in declared_fields():
                whole = getattr(sim.data.structs[struct], name)
                part = getattr(rt.shard_of(sim.data.structs[struct]), name)
                if whole.size == 0:
                    continue
                # the shard's rows of the same memory, reached from the struct or the array
                assert part.shape == (hi - lo,) + whole.shape[1:], name
                assert part.ptr == whole.ptr + lo * whole.strides[0], name
                assert rt.shard_of(whole).ptr == part.ptr, name
        covered += hi - lo
    assert covered == sim.num_envs
    # model-wide arrays are shared whole by every thread
    with rt.in_shard(*rt.shards[1]):
        assert rt.shard_of(sim.device_model.m) is sim.device_model.m
        assert rt.shard_of(sim.device_model.pairs) is sim.device_model.pairs


def test_a_shard_writes_only_its_envs(sim):
    """A kernel launched on one shard's view of a declared field changes that shard's envs only."""
    rt = sim.runtime
    lo, hi = rt.shards[1]
    q = sim.q.clone()
    with rt.in_shard(lo, hi):
        rt.shard_of(sim.data.state.q).fill_(7.0)
    changed = (sim.q != q).any(dim=1)
    assert torch.equal(changed, (torch.arange(sim.num_envs) >= lo) & (torch.arange(sim.num_envs) < hi))
    sim.q = q
    wp.synchronize()


def test_a_timed_step_names_every_stage_and_gives_the_same_state():
    """`Simulator.step(timings=...)` (the profiling seam) runs the same stages stage by stage."""
    model = myriad.load(myriad.asset_path("ant.xml"))
    plain, timed = (myriad.Simulator(model, num_envs=3) for _ in range(2))
    timings = {}
    for _ in range(3):
        for sim in (plain, timed):
            sim.ctrl = torch.linspace(-1, 1, model.nu).expand(3, -1)
        plain.step()
        timed.step(timings=timings)
    assert torch.equal(plain.q, timed.q)
    assert set(timings) == set(Simulator.SUBSTEP_STAGES + Simulator.FINAL_STAGES)
    assert all(t >= 0.0 for t in timings.values())
