"""`VecTask.step` never waits for the device, so that physics and task code could be captured
together as one CUDA graph: no op inside it reads a device value back to the host.

On a CPU nothing is transferred, so the test records the ops that WOULD wait for a GPU: a
tensor read as a Python number (`item`, `int(t)`, `if t:` ...: `_local_scalar_dense`), ops
whose output size depends on the data (`nonzero`, boolean-mask indexing, `unique` ...), host
data copied to the device (`torch.tensor(...)`: a synchronous copy from pageable memory), and
the host reads that bypass the dispatcher on a CPU tensor (`tolist`, `numpy`, `cpu`).

On a CPU the step does ask once whether any env finished (`VecTask.skip_idle_resets`, free
there): the test turns that off to run the step as a GPU runs it, and checks that the question
is all the CPU default adds.
"""

from contextlib import contextmanager

import pytest
import torch
import warp as wp
from torch.utils._python_dispatch import TorchDispatchMode

import myriad
from myriad.api import Scene
from myriad.tasks import TASKS as TASK_CLASSES, apply_overrides, task_config

aten = torch.ops.aten

# ops that wait for the device whatever their arguments
SYNCING = {
    aten._local_scalar_dense.default,       # item(), int(t), float(t), bool(t), `if t:`
    aten.is_nonzero.default,
    aten.equal.default,                     # torch.equal returns a Python bool
    aten.nonzero.default,                   # torch.where(cond), mask.nonzero()
    aten.masked_select.default,
    aten.masked_scatter.default, aten.masked_scatter_.default,
    aten._unique.default, aten._unique2.default, aten.unique_dim.default,
    aten.unique_consecutive.default,
    aten.bincount.default,
    aten.lift_fresh.default,                # torch.tensor(host data, device=...)
}
# ops that wait when an index is a boolean mask (x[mask], x[mask] = y)
INDEXING = {aten.index.Tensor, aten.index_put.default, aten.index_put_.default,
            aten._index_put_impl_.default}


def bool_index(args) -> bool:
    return any(isinstance(i, torch.Tensor) and i.dtype in (torch.bool, torch.uint8)
               for i in args[1])


class SyncRecorder(TorchDispatchMode):
    def __init__(self):
        super().__init__()
        self.syncs = []

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        if (func in SYNCING or (func in INDEXING and bool_index(args))
                or (func is aten.repeat_interleave.Tensor and kwargs.get("output_size") is None)
                or (func in (aten._to_copy.default, aten.copy_.default)
                    and _crosses_to_host(func, args, kwargs))):
            self.syncs.append(str(func))
        return func(*args, **kwargs)


def _crosses_to_host(func, args, kwargs) -> bool:
    """A copy from a device tensor into host memory (never true on a CPU-only run)."""
    if func is aten.copy_.default:
        return args[0].device.type == "cpu" and args[1].device.type != "cpu"
    target = kwargs.get("device")
    return target is not None and torch.device(target).type == "cpu" \
        and args[0].device.type != "cpu"


@contextmanager
def recording_syncs():
    """Records every op that would wait for a GPU; yields the list of their names."""
    recorder = SyncRecorder()
    originals = {name: getattr(torch.Tensor, name) for name in ("tolist", "numpy", "cpu")}

    def guard(name):
        def read_back(self, *args, **kwargs):
            recorder.syncs.append(f"Tensor.{name}")
            return originals[name](self, *args, **kwargs)
        return read_back

    try:
        for name in originals:
            setattr(torch.Tensor, name, guard(name))
        with recorder:
            yield recorder.syncs
    finally:
        for name, method in originals.items():
            setattr(torch.Tensor, name, method)


@pytest.mark.parametrize("name, read", [
    ("item", lambda x, m: x[0].item()),
    ("int", lambda x, m: int(x.sum())),
    ("if", lambda x, m: 1 if m.any() else 0),
    ("tolist", lambda x, m: x.tolist()),
    ("numpy", lambda x, m: x.numpy()),
    ("cpu", lambda x, m: x.cpu()),
    ("nonzero", lambda x, m: m.nonzero()),
    ("mask index", lambda x, m: x[m]),
    ("mask write", lambda x, m: x.__setitem__(m, x[:2].clone())),
    ("len of a mask's ids", lambda x, m: len(torch.where(m)[0])),
    ("host data", lambda x, m: x + torch.tensor([1.0, 2.0, 3.0, 4.0])),
    ("list index", lambda x, m: x[[0, 2]]),
    ("unique", lambda x, m: x.unique()),
])
def test_the_recorder_sees_each_kind_of_read_back(name, read):
    x, m = torch.arange(4.0), torch.tensor([True, False, True, False])
    with recording_syncs() as syncs:
        read(x, m)
    assert syncs, name


def test_the_recorder_lets_masked_work_through():
    x, m = torch.arange(4.0), torch.tensor([True, False, True, False])
    with recording_syncs() as syncs:
        y = torch.where(m, x, 0.0)
        x.masked_fill_(m, 1.0)
        x[:, None][torch.arange(2)] = 5.0
        torch.zeros(4, dtype=torch.bool).index_fill_(0, torch.arange(2), True)
    assert syncs == [] and y.shape == (4,)


RANDOMIZATION = {
    "enabled": True, "frequency": 1,
    "observations": {"range": [0, 0.002], "range_correlated": [0, 0.001],
                     "operation": "additive", "distribution": "gaussian"},
    "actions": {"range": [0, 0.05], "range_correlated": [0, 0.015], "operation": "additive",
                "distribution": "gaussian"},
    "sim_params": {"gravity": {"range": [0, 0.4], "operation": "additive",
                               "distribution": "gaussian"}},
}


def randomization(actor, body, dofs=True):
    """Every kind of parameter, re-sampled at every reset (frequency 1)."""
    uniform = {"operation": "scaling", "distribution": "uniform"}
    params = {"rigid_body_properties": {"mass": {"range": [0.5, 1.5], **uniform}},
              "rigid_shape_properties": {"friction": {"range": [0.7, 1.3], **uniform}}}
    if dofs:
        params["dof_properties"] = {
            "damping": {"range": [0.3, 3.0], "operation": "scaling",
                        "distribution": "loguniform"},
            "upper": {"range": [-0.05, 0.05], "operation": "additive",
                      "distribution": "uniform"}}
    forces = {"body": body, "probability_range": [0.5, 1.0], "scale": 1.0}
    return {**RANDOMIZATION, "actor_params": {actor: params}, "random_forces": forces}


TASKS = {   # few envs, short episodes: resets, time-outs and re-samples in a few steps
    "Ant": (randomization("ant", "ant/torso"), dict(episodeLength=3)),
    "Humanoid": (randomization("ant", "ant/torso"), dict(episodeLength=3)),  # its actor: "ant"
    "Ingenuity": (randomization("ingenuity", "ingenuity/chassis", dofs=False),
                  dict(episodeLength=4, targetInterval=2)),
    "Anymal": (randomization("anymal", "anymal/base"), dict(episodeLength_s=0.06)),
    "HumanoidAMP": (randomization("humanoid", "humanoid/pelvis"), dict(episodeLength=3)),
    "AnymalTerrain": (randomization("anymal", "anymal/base"),     # pushes, cost curriculum
                      dict(episodeLength_s=0.06, pushInterval_s=0.04,
                           penaltyCurriculum={"start": 0.3, "decay": 0.99})),
    "G1Velocity": (randomization("g1", "g1/pelvis"),            # pushes, command re-draws
                   {"episodeLength_s": 0.06, "pushInterval_s": 0.04,
                    "env.commands.resample_s": 0.04}),
    "G1Rough": (None, dict(episodeLength_s=0.06, pushInterval_s=0.04)),    # + curriculum
    "ShadowHand": (randomization("hand", "object/object"), dict(episodeLength=3)),
    "ShadowHandOpenAI_FF": (None, dict(episodeLength=3)),     # its own randomization
    "AllegroHand": (randomization("hand", "object/object"), dict(episodeLength=3)),
    "FrankaCubeStack": (randomization("cubeA", "cubeA/cubeA", dofs=False),
                        dict(episodeLength=3)),
    "Trifinger": (None, dict(episodeLength=3, reachStepsThreshold=16)),  # its own randomization;
    # the reach term ends after the 4th step
}


def build(name: str, frequency: int = 1):
    """`name` with 4 envs, its `TASKS` settings (randomization re-sampled at resets once
    `frequency` steps passed), stepping as a GPU steps it; reset."""
    if name in ("Anymal", "AnymalTerrain", "G1Velocity", "G1Rough"):
        pytest.importorskip("cmeel", reason="ANYmal and the G1 need example-robot-data")
    if name == "HumanoidAMP":
        pytest.importorskip("pybullet_data", reason="HumanoidAMP needs pybullet (.[amp])")
    torch.manual_seed(0)
    dr, overrides = TASKS[name]
    cfg = apply_overrides(task_config(name), {"numEnvs": 4, **overrides}, name)
    if dr is not None:
        cfg["randomization"] = {**dr, "frequency": frequency}
    task = TASK_CLASSES[name](cfg, device="cpu")
    task.skip_idle_resets = False           # the step as a GPU runs it
    task.reset()
    return task


@pytest.mark.parametrize("name", list(TASKS))
def test_task_step_never_reads_the_device(name):
    task = build(name)
    actions = torch.rand(4, task.num_actions) * 2 - 1
    actions[1, 0] = float("nan")                          # a non-finite action ...
    task.envs.sim.qd[2, 0] = float("nan")                 # ... and a blown-up state
    seen_reset, seen_timeout = False, False
    for _ in range(7):
        with recording_syncs() as syncs:
            _, _, resets, extras = task.step(actions)
        assert syncs == [], f"{name}: step read the device back via {sorted(set(syncs))}"
        seen_reset |= bool(resets.any())
        seen_timeout |= bool(extras["time_outs"].any())
        actions = torch.rand(4, task.num_actions) * 2 - 1
    assert seen_reset and seen_timeout, "the steps must cover resets and time-outs"
    assert int(task.nonfinite_action_count.sum()) == 1
    assert task.envs.sim.nonfinite.tolist() == [0, 0, 0, 0], "flags cleared by the reset"
    # on a CPU the step asks once whether any env finished (free there), and nothing else
    # (the tasks with pushes also whether a push is due)
    task.skip_idle_resets = True
    with recording_syncs() as syncs:
        task.step(actions)
    pushes = name in ("AnymalTerrain", "G1Velocity", "G1Rough")
    assert syncs == ["aten._local_scalar_dense.default"] * (2 if pushes else 1)


class TraceRecorder(TorchDispatchMode):
    """Each op dispatched, with its arguments other than tensors (sizes, dims, Python numbers):
    what a CUDA graph captured from one call of the step would replay at every later call."""

    def __init__(self):
        super().__init__()
        self.trace = []

    def __torch_dispatch__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        self.trace.append((str(func), _constants(args), _constants(tuple(kwargs.items()))))
        return func(*args, **kwargs)


def _constants(value):
    """`value` with every tensor and array replaced by its kind (its contents may change from
    step to step; a graph reads them where they are)."""
    if isinstance(value, (tuple, list)):
        return tuple(_constants(v) for v in value)
    if isinstance(value, torch.Tensor):
        return ("tensor", value.dtype, tuple(value.shape))
    if isinstance(value, wp.array):
        return ("array", value.dtype, value.shape)
    if isinstance(value, (bool, int, float, str, type(None), torch.dtype, torch.device,
                          torch.layout, torch.memory_format)):
        return value
    return type(value).__name__        # a Warp struct, a generator: its fields are arrays


@contextmanager
def recording_trace():
    """The step's ops (`TraceRecorder`) and its Warp launches (kernel, dims, arguments other
    than arrays), in order; yields the list."""
    recorder = TraceRecorder()
    launch = wp.launch

    def recorded_launch(kernel, dim=None, inputs=(), *args, **kwargs):
        recorder.trace.append(("launch", kernel.key, _constants(dim), _constants(inputs),
                               kwargs.get("block_dim")))
        return launch(kernel, dim, inputs, *args, **kwargs)

    wp.launch = recorded_launch
    try:
        with recorder:
            yield recorder.trace
    finally:
        wp.launch = launch


@pytest.mark.parametrize("name", list(TASKS))
def test_task_step_does_the_same_work_at_every_step(name):
    """Captured once as a CUDA graph, the task's step (actions, physics, observations, rewards,
    resets, randomization and its schedules, pushes, curricula) is replayed at every later step:
    so every step, the ones that reset envs, re-sample parameters or push robots included,
    must dispatch the same ops and launches with the same constants, its decisions taken on
    the device (`torch.where` over envs, not Python `if`s on counters)."""
    task = build(name, frequency=3)         # re-sampled at some steps' resets only
    # the warm-up a capture runs first; on a CPU the physics also captures its own graph at
    # its second step and replays it after (`Runtime.replaying`): warm up past that too
    for _ in range(2):
        task.step(torch.rand(4, task.num_actions) * 2 - 1)
    traces, resets = [], []
    for _ in range(8):
        actions = torch.rand(4, task.num_actions) * 2 - 1
        with recording_trace() as trace:
            _, _, reset, _ = task.step(actions)
        traces.append(trace)
        resets.append(bool(reset.any()))
    assert any(resets) and not all(resets), "the steps must include resets and steps without"
    for k, trace in enumerate(traces[1:], 1):
        if trace != traces[0]:
            first = next(i for i, (a, b) in enumerate(zip(trace, traces[0])) if a != b) \
                if any(a != b for a, b in zip(trace, traces[0])) else min(len(trace),
                                                                         len(traces[0]))
            raise AssertionError(
                f"{name}: step {k + 1} does other work than step 1 ({len(trace)} against "
                f"{len(traces[0])} ops and launches), first at #{first}: "
                f"{trace[first] if first < len(trace) else 'ends'} against "
                f"{traces[0][first] if first < len(traces[0]) else 'ends'}")


def test_masked_writes_change_only_their_envs_and_read_nothing_back():
    e = Scene().add_ground().add_actor("a", myriad.asset_path("ant.xml"),
                                       pos=(0, 0, 0.62)).build(4)
    e.set_dof_efforts(torch.rand(4, 8) * 10 - 5)
    for _ in range(5):
        e.step()
    before_q, before_qd = e.sim.q.clone(), e.sim.qd.clone()
    states = e.root_states.clone()
    states[:, 0, :3] = torch.tensor([[0.0, 0, 1], [1, 0, 1], [2, 0, 1], [3, 0, 1]])
    states[:, 0, 7:] = 0.5
    pos, vel = e.dof_pos.clone() * 0.5, torch.full((4, 8), 0.25)
    mask = torch.tensor([False, True, False, True])
    with recording_syncs() as syncs:
        e.set_root_states(states, mask, forward=False)
        e.set_dof_state(pos, vel, mask)
    assert syncs == []
    ids, others = [1, 3], [0, 2]
    torch.testing.assert_close(e.root_states[ids], states[ids], atol=1e-5, rtol=0)
    assert torch.equal(e.dof_pos[ids], pos[ids]) and torch.equal(e.dof_vel[ids], vel[ids])
    assert torch.equal(e.sim.q[others], before_q[others])
    assert torch.equal(e.sim.qd[others], before_qd[others])
    # a mask with values for its selected envs only must count them: one read-back
    pos, vel = pos[ids] * 0.5, vel[ids]
    with recording_syncs() as syncs:
        e.set_dof_state(pos, vel, mask)
    assert syncs == ["aten.nonzero.default"]
    assert torch.equal(e.dof_pos[ids], pos)
    assert torch.equal(e.sim.q[others], before_q[others])
