"""Typos that used to pass (issue 10): unknown command-line keys, numbers that do not parse,
device names, env ids out of range, and the layout of `myriad --help`. Nothing here trains: each
error is raised before a task is built."""

import pytest
import torch

import myriad
from myriad import cli
from myriad.api import Scene
from myriad.physics.runtime import resolve_device
from myriad.rl import run


def _fails(capsys, *args) -> str:
    """`myriad train task=Ant *args` exits with 2 before training; its stderr."""
    assert cli.main(["train", "task=Ant", "device=cpu", *args]) == 2
    return capsys.readouterr().err


def test_unknown_command_line_keys_fail_naming_the_nearest(capsys):
    for typo in ("task.env.episodeLenght=10", "+task.env.episodeLenght=10",
                 "++task.env.episodeLenght=10"):
        err = _fails(capsys, typo)
        assert "no key task.env.episodeLenght (did you mean task.env.episodeLength?)" in err
        assert "the keys of task.env: " in err and "numEnvs" in err     # that level's keys
        assert "To append" not in err, "Hydra's hint to add the key is not given"
    err = _fails(capsys, "++num_envz=3")
    assert "no key num_envz (did you mean num_envs?)" in err and "the keys of the top level" in err
    err = _fails(capsys, "learning_rate=1e-4")         # a key of another section
    assert "did you mean train.params.config.learning_rate?" in err
    err = _fails(capsys, "task.envv.episodeLength=3", "task.env.plane={frictoin: 1}")
    assert "unknown config keys" in err and "the keys of task: " in err
    assert "no key task.env.plane.frictoin" in err, "the keys of a dict value are checked too"
    assert "task.randomization.frequncy" in _fails(capsys, "task.randomization.frequncy=5")
    # existing keys, with or without +/++, and the randomization keys its YAML leaves out
    cfg = run.compose(["+num_envs=3", "++seed=5", "task.env.plane={restitution: 0.5}",
                       "task.randomization.frequency=7",
                       "+task.randomization.actions={range: [0, 1]}"])
    assert (cfg.num_envs, cfg.seed, cfg.task.env.plane.restitution) == (3, 5, 0.5)
    assert cfg.task.env.plane.staticFriction == 1.0
    assert cfg.task.randomization.frequency == 7
    assert list(cfg.task.randomization.actions.range) == [0, 1]
    # a SimParams setting of sim.physx that the task's YAML leaves out reaches the simulator
    cfg = run.compose(["task.sim.physx.limit_block_contacts=16"])
    assert myriad.tasks.base.sim_params(cfg.task.sim).limit_block_contacts == 16
    assert "no key task.sim.physx.limit_blok_contacts" in _fails(
        capsys, "task.sim.physx.limit_blok_contacts=16")
    # ... and through myriad.make's overrides (apply_overrides), as on the command line
    from myriad.tasks import apply_overrides, task_config
    cfg = apply_overrides(task_config("Ant"), {"sim.physx.limit_block_contacts": 16}, "Ant")
    assert cfg["sim"]["physx"]["limit_block_contacts"] == 16
    with pytest.raises(KeyError, match="no config key 'sim.physx.limit_blok'"):
        apply_overrides(task_config("Ant"), {"sim.physx.limit_blok": 16}, "Ant")


def test_bad_numbers_name_their_key_and_value(capsys):
    assert "num_envs='abc': expected an integer" in _fails(capsys, "num_envs=abc")
    assert "task.env.episodeLength='abc': expected an integer" in _fails(
        capsys, 'task.env.episodeLength="abc"')
    assert "num_envs=2.5: expected an integer, not a fraction" in _fails(capsys, "num_envs=2.5")
    assert "seed=1.5" in _fails(capsys, "seed=1.5")
    assert "max_time_s='soon'" in _fails(capsys, "max_time_s=soon")
    assert "train.params.config.horizon_length=2.5" in _fails(
        capsys, "train.params.config.horizon_length=2.5")
    # an integral float is that integer
    cfg = run.compose(["task=Ant", "device=cpu", "num_envs=2.0", "max_iterations=3.0"])
    task_cfg, train_cfg, _ = run.task_and_train_configs(cfg)
    assert task_cfg["env"]["numEnvs"] == 2 and type(task_cfg["env"]["numEnvs"]) is int
    assert train_cfg["params"]["config"]["max_epochs"] == 3
    # the Python API: the same parser (myriad.tasks.config_int), before anything is built
    with pytest.raises(ValueError, match=r"num_envs=2.5: expected an integer, not a fraction"):
        myriad.make("Ant", num_envs=2.5)
    with pytest.raises(ValueError, match=r"env.episodeLength='abc': expected an integer"):
        myriad.make("Ant", num_envs=1, episodeLength="abc")
    with pytest.raises(ValueError, match=r"env.controlFrequencyInv=1.5"):
        myriad.make("Ant", num_envs=1, controlFrequencyInv=1.5)


def test_device_names_fail_in_one_line(capsys):
    err = _fails(capsys, "device=gpu")
    assert err.strip() == "myriad train: error: device=gpu: expected auto, cpu, cuda or cuda:N"
    err = _fails(capsys, "device=cuda:99")
    assert err.count("\n") == 1 and "device=cuda:99: no such GPU" in err and "available: cpu" in err
    with pytest.raises(ValueError, match=r"^device 'gpu': expected 'cpu', 'cuda' or 'cuda:N'$"):
        resolve_device("gpu")
    with pytest.raises(ValueError, match=r"^device 'cuda:99' is not available \(no such GPU\); "
                                         r"Warp sees \['cpu'"):
        resolve_device("cuda:99")
    for device in ("gpu", "cuda:99"):
        with pytest.raises(ValueError) as err:
            myriad.make("Ant", num_envs=1, device=device)
        assert "\n" not in str(err.value) and device in str(err.value)
    assert run.resolve_device("cpu") == "cpu"


@pytest.fixture(scope="module")
def envs(device):
    return Scene().add_ground().add_actor("a", myriad.asset_path("ant.xml"),
                                          pos=(0, 0, 0.62)).build(4, device)


def test_env_ids_out_of_range_repeated_or_mistyped_are_refused(envs, device):
    e = envs
    one, two = e.root_states[:1].clone(), e.root_states[:2].clone()
    pos, vel = e.dof_pos[:1].clone(), e.dof_vel[:1].clone()

    def ids(*values, dtype=torch.long):
        return torch.tensor(values, dtype=dtype, device=device)

    for write in (lambda i: e.set_root_states(one, i),
                  lambda i: e.set_dof_state(pos, vel, i)):
        with pytest.raises(ValueError, match=r"env_ids \[-1\] out of range: ids must lie in "
                                             r"\[0, 4\)"):
            write(ids(-1))
        with pytest.raises(ValueError, match=r"env_ids \[4\] out of range"):
            write(ids(4, dtype=torch.int32))
        with pytest.raises(ValueError, match="env_ids must be a 1-D integer tensor .* not "
                                             "torch.int16"):
            write(ids(1, dtype=torch.int16))
        with pytest.raises(ValueError, match="env_ids must be a 1-D integer tensor .* not "
                                             "torch.float32"):
            write(ids(1, dtype=torch.float32))
    with pytest.raises(ValueError, match=r"set_root_states: env_ids \[2\] given more than once"):
        e.set_root_states(two, ids(2, 2))
    with pytest.raises(ValueError, match=r"set_dof_state: env_ids \[2\] given more than once"):
        e.set_dof_state(e.dof_pos[:2].clone(), e.dof_vel[:2].clone(), ids(2, 2))
    # valid ids: in any order, int32 or int64, a bool mask, or none
    before = e.root_states.clone()
    moved = before[[3, 0]].clone()
    moved[:, :, 2] += torch.tensor([[1.0], [2.0]], device=device)
    e.set_root_states(moved, ids(3, 0, dtype=torch.int32))
    torch.testing.assert_close(e.root_states[[3, 0], :, 2], moved[:, :, 2])
    torch.testing.assert_close(e.root_states[1:3], before[1:3])
    e.set_root_states(before[:0].clone(), ids())
    mask = torch.tensor([True, False, False, True], device=device)
    e.set_root_states(before[[0, 3]].clone(), mask)
    torch.testing.assert_close(e.root_states, before)


def test_checking_env_ids_reads_the_gpu_back_once(envs, device):
    """The id check of an indexed write costs one read-back from the GPU (min, max, repeats)."""
    import warnings

    if not device.startswith("cuda"):
        pytest.skip("counts CUDA synchronizations: run with --device cuda:0")
    ids = torch.tensor([2, 0], device=device)
    torch.cuda.synchronize()
    torch.cuda.set_sync_debug_mode("warn")
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            checked = envs._env_ids("set_root_states", ids)
    finally:
        torch.cuda.set_sync_debug_mode("default")
    assert checked.tolist() == [2, 0]
    assert len([w for w in caught if "synchroniz" in str(w.message)]) == 1


def test_help_keeps_the_examples_on_their_lines(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["--help"])
    assert exit_.value.code == 0
    lines = capsys.readouterr().out.splitlines()
    for example in ("myriad train task=Ant [", "myriad play task=Ant [", "myriad demo ["):
        assert any(line.strip().startswith(example) for line in lines), example
    assert cli.main(["train", "--help"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert any(line.strip().startswith("myriad play task=Ant [") for line in lines)
