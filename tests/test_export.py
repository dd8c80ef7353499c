"""`myriad export`: a tiny training run's policy as ONNX, run with onnxruntime on observations
recorded from the task, against the torch policy (`myriad play`'s), an LSTM policy with its
state fed back, the JSON sidecar, and the errors."""

import json

import numpy as np
import pytest
import torch

ort = pytest.importorskip("onnxruntime")

from myriad import cli  # noqa: E402
from myriad.rl import policy, run  # noqa: E402
from myriad.tasks import TASKS  # noqa: E402

# ShadowHandOpenAI_LSTM's policy and critic, shrunk to train and export in seconds
LSTM_SMALL = ["train.params.network.rnn.units=16", "train.params.network.mlp.units=[16]",
              "train.params.config.central_value_config.network.rnn.units=16",
              "train.params.config.central_value_config.network.mlp.units=[16]",
              "train.params.config.horizon_length=4"]


def configs(*overrides):
    cfg = run.compose(["device=cpu", *overrides])
    return run.task_and_train_configs(cfg, list(overrides))[:2]


def session(path):
    return ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])


@pytest.fixture(scope="module")
def ant_checkpoint(tmp_path_factory):
    runs = tmp_path_factory.mktemp("runs")
    assert cli.main(["train", "task=Ant", "device=cpu", "num_envs=32", "max_iterations=1",
                     f"train_dir={runs}", "experiment=ant"]) == 0
    return runs / "ant" / "nn" / "last.pth"


def test_ant_onnx_matches_the_torch_policy_and_the_sidecar_describes_it(ant_checkpoint,
                                                                        tmp_path):
    from myriad.rl.policy import load_policy

    output = tmp_path / "deploy" / "ant.onnx"
    assert cli.main(["export", "task=Ant", f"checkpoint={ant_checkpoint}",
                     f"output={output}"]) == 0

    # observations recorded from stepping the task with the torch policy (what play runs)
    task_cfg, train_cfg = configs("task=Ant", "num_envs=8")
    task = TASKS["Ant"](task_cfg, device="cpu")
    policy = load_policy(str(ant_checkpoint), train_cfg, task)
    obs, recorded, actions = task.reset()["obs"], [], []
    with torch.no_grad():
        for _ in range(12):
            recorded.append(obs.clone())
            actions.append(policy(obs))
            obs = task.step(actions[-1])[0]["obs"]
    recorded, actions = torch.cat(recorded), torch.cat(actions)       # [96, 60], [96, 8]
    sess = session(output)
    onnx_actions, = sess.run(None, {"obs": recorded.numpy()})
    np.testing.assert_allclose(onnx_actions, actions.numpy(), rtol=0, atol=1e-5)
    # the task's observation clip is inside the graph too: raw values beyond it give the
    # actions of the clipped ones; and one observation at a time (the batch axis is dynamic)
    raw = recorded[:5] * 20.0
    with torch.no_grad():
        expected = policy(torch.clamp(raw, -task.clip_obs, task.clip_obs))
    onnx_actions, = sess.run(["actions"], {"obs": raw.numpy()})
    np.testing.assert_allclose(onnx_actions, expected.numpy(), rtol=0, atol=1e-5)
    one, = sess.run(None, {"obs": recorded[:1].numpy()})
    np.testing.assert_allclose(one, actions[:1].numpy(), rtol=0, atol=1e-5)

    side = json.loads((tmp_path / "deploy" / "ant.json").read_text())
    assert side["task"] == "Ant" and side["onnx"] == "ant.onnx"
    assert side["observation"]["size"] == 60 and side["observation"]["clip"] == 5.0
    layout = side["observation"]["layout"]
    assert layout[0]["slice"] == [0, 1] and layout[-1] == {"name": "last actions",
                                                           "slice": [52, 60]}
    assert side["action"]["size"] == 8 and side["action"]["clipActions"] == 1.0
    assert side["action"]["scaling"]["gear"] == {f"ant/{j}_{k}": 15.0 for k in range(1, 5)
                                                 for j in ("hip", "ankle")}
    sim_dt, decimation = task_cfg["sim"]["dt"], task_cfg["env"].get("controlFrequencyInv", 1)
    assert side["control"]["rate_hz"] == pytest.approx(1 / (sim_dt * decimation), rel=1e-6)
    assert side["inputs"] == [{"name": "obs", "shape": ["batch", 60], "dtype": "float32"}]
    assert side["outputs"] == [{"name": "actions", "shape": ["batch", 8], "dtype": "float32"}]
    assert [(i.name, i.shape) for i in sess.get_inputs()] == [("obs", ["batch", 60])]
    assert [(o.name, o.shape) for o in sess.get_outputs()] == [("actions", ["batch", 8])]
    assert side["recurrent"] is None and side["critic_states"] is None
    assert side["checkpoint"] == str(ant_checkpoint) and side["epoch"] == 1
    assert side["env_steps"] == 32 * 16


def test_lstm_policy_exports_its_state_and_matches_step_by_step(tmp_path):
    """ShadowHandOpenAI_LSTM: an LSTM policy and an asymmetric critic. The graph is the actor
    only (42 observations, not the critic's 211 states); h and c go in and come out, and fed
    back step after step the actions and states match the rl_games network's."""
    from rl_games.algos_torch.model_builder import ModelBuilder

    args = ["task=ShadowHandOpenAI_LSTM", *LSTM_SMALL]
    assert cli.main(["train", *args, "device=cpu", "num_envs=4", "max_iterations=1",
                     f"train_dir={tmp_path}", "experiment=lstm"]) == 0
    checkpoint = tmp_path / "lstm" / "nn" / "last.pth"
    output = tmp_path / "hand.onnx"
    assert cli.main(["export", *args, f"checkpoint={checkpoint}", f"output={output}"]) == 0

    side = json.loads((tmp_path / "hand.json").read_text())
    assert side["observation"]["size"] == 42 and side["critic_states"] == 211
    assert side["recurrent"] == {"type": "lstm", "layers": 1, "units": 16,
                                 "state_inputs": ["h_in", "c_in"],
                                 "state_outputs": ["h_out", "c_out"],
                                 "usage": side["recurrent"]["usage"]}
    assert side["control"]["rate_hz"] == pytest.approx(20.0)
    assert side["action"]["scaling"]["actionsMovingAverage"] == 0.3
    sess = session(output)
    assert [(i.name, i.shape) for i in sess.get_inputs()] == [
        ("obs", ["batch", 42]), ("h_in", [1, "batch", 16]), ("c_in", [1, "batch", 16])]
    assert [o.name for o in sess.get_outputs()] == ["actions", "h_out", "c_out"]
    assert [i["name"] for i in side["inputs"]] == ["obs", "h_in", "c_in"]

    # the torch reference: the checkpoint's rl_games network, states passed explicitly
    task_cfg, train_cfg = configs(*args, "num_envs=2")
    task = TASKS["ShadowHandOpenAI_LSTM"](task_cfg, device="cpu")
    params = train_cfg["params"]
    net = ModelBuilder().load(params).build({
        "actions_num": task.num_actions, "input_shape": (task.num_obs,), "num_seqs": 1,
        "value_size": 1, "normalize_value": True, "normalize_input": True})
    net.load_state_dict(torch.load(checkpoint, weights_only=False)["model"])
    net.eval()
    h, c = torch.zeros(1, 2, 16), torch.zeros(1, 2, 16)       # zeros at the episode start
    h_onnx, c_onnx = h.numpy(), c.numpy()
    # and `myriad play`'s policy, which carries the state itself (zeroed by `done`)
    from myriad.rl.policy import load_policy
    play_policy = load_policy(str(checkpoint), train_cfg, task)
    obs, done = task.reset()["obs"], None
    for step in range(6):
        with torch.no_grad():
            played = play_policy(obs.clone(), done)
        with torch.no_grad():
            out = net({"is_train": False, "prev_actions": None, "obs": obs.clone(),
                       "rnn_states": (h, c)})
        actions, (h, c) = torch.clamp(out["mus"], -1.0, 1.0), out["rnn_states"]
        onnx_actions, h_onnx, c_onnx = sess.run(None, {"obs": obs.numpy(), "h_in": h_onnx,
                                                       "c_in": c_onnx})
        np.testing.assert_allclose(onnx_actions, actions.numpy(), rtol=0, atol=1e-5,
                                   err_msg=f"step {step}")
        np.testing.assert_allclose(played.numpy(), actions.numpy(), rtol=0, atol=1e-6)
        np.testing.assert_allclose(h_onnx, h.numpy(), rtol=0, atol=1e-5)
        np.testing.assert_allclose(c_onnx, c.numpy(), rtol=0, atol=1e-5)
        obs, _, done, _ = task.step(actions)
        obs = obs["obs"]
        # a finished episode starts again from zeros, in both
        keep = (~done.bool()).float()[None, :, None]
        h, c = h * keep, c * keep
        h_onnx, c_onnx = h_onnx * keep.numpy(), c_onnx * keep.numpy()
    assert np.abs(c_onnx).max() > 0, "the state carries something"


def test_export_without_output_writes_next_to_the_run(ant_checkpoint, capsys):
    assert cli.main(["export", "task=Ant", f"checkpoint={ant_checkpoint}"]) == 0
    folder = ant_checkpoint.parent.parent
    assert (folder / "Ant.onnx").is_file() and (folder / "Ant.json").is_file()
    assert "Ant.onnx" in capsys.readouterr().out


def test_export_errors_name_the_problem(ant_checkpoint, tmp_path, capsys, unshipped_task):
    def fails(*args):
        assert cli.main(["export", *args]) == 2
        return capsys.readouterr().err

    err = fails("task=Ant", f"checkpoint={tmp_path / 'nope.pth'}",
                f"output={tmp_path / 'p.onnx'}")
    assert "nope.pth: no such file" in err
    err = fails("task=Ant", f"checkpoint={ant_checkpoint}", f"output={tmp_path / 'p.pt'}")
    assert "p.pt: the file name must end in .onnx" in err
    err = fails("task=Ingenuity", f"checkpoint={ant_checkpoint}",
                f"output={tmp_path / 'p.onnx'}")
    assert "does not fit the Ingenuity policy network" in err and "another task's" in err
    assert "size mismatch" in err
    err = fails("task=Nope", f"output={tmp_path / 'p.onnx'}")
    assert "task/Nope" in err and "Ant" in err
    broken = tmp_path / "broken.pth"
    broken.write_bytes(ant_checkpoint.read_bytes()[:1000])
    err = fails("task=Ant", f"checkpoint={broken}", f"output={tmp_path / 'p.onnx'}")
    assert "not a readable rl_games checkpoint" in err
    err = fails(f"task={unshipped_task}", f"train_dir={tmp_path / 'empty'}",
                f"output={tmp_path / 'p.onnx'}")
    assert f"no trained {unshipped_task} run" in err
    assert not list(tmp_path.glob("*.onnx")) and not list(tmp_path.glob("*.json"))


# rl_games network variants beyond the shipped configs: each exported graph is checked against
# the rl_games network's own forward (export.verify_onnx) with random normalisation statistics
VARIANTS = {
    "mlp": {},
    "separate_lstm_layer_norm": {"separate": True, "rnn": {"name": "lstm", "units": 8,
                                                          "layers": 1, "before_mlp": True,
                                                          "layer_norm": True}},
    "gru_after_mlp_concat": {"rnn": {"name": "gru", "units": 6, "layers": 2,
                                     "concat_input": True, "concat_output": True}},
    "separate_gru_no_normalization": {"separate": True, "normalize_input": False,
                                      "rnn": {"name": "gru", "units": 4, "layers": 1}},
}


def variant_network(variant):
    _, train_cfg = configs("task=Ant")
    network = train_cfg["params"]["network"]
    network["mlp"]["units"] = [16, 8]
    changes = dict(VARIANTS[variant])
    train_cfg["params"]["config"]["normalize_input"] = changes.pop("normalize_input", True)
    network.update(changes)
    torch.manual_seed(1)
    net = policy.build_network(train_cfg, 13, 5).eval()
    if train_cfg["params"]["config"]["normalize_input"]:
        rms = net.running_mean_std
        rms.running_mean.copy_(torch.randn(13, dtype=torch.float64))
        rms.running_var.copy_(torch.rand(13, dtype=torch.float64) * 3 + 1e-3)
    return net


@pytest.mark.parametrize("variant", sorted(VARIANTS))
def test_network_variants_match_rl_games(variant, tmp_path):
    from myriad.rl import export

    net = variant_network(variant)
    actor = export.OnnxActor(net, clip_obs=5.0).eval()
    path = str(tmp_path / "v.onnx")
    assert export.write_onnx(actor, 13, path) == export.OPSET
    worst = export.verify_onnx(path, net, actor, 13, steps=4, batch=3)
    assert worst is not None and worst < 1e-5, worst


def test_the_torch_export_based_exporter_gives_the_same_graph(tmp_path):
    """The fallback for a torch without the TorchScript exporter (`write_onnx(dynamo=True)`)."""
    pytest.importorskip("onnxscript")
    from myriad.rl import export

    net = variant_network("separate_lstm_layer_norm")
    actor = export.OnnxActor(net, clip_obs=5.0).eval()
    path = str(tmp_path / "d.onnx")
    assert export.write_onnx(actor, 13, path, dynamo=True) == 18
    worst = export.verify_onnx(path, net, actor, 13, steps=4, batch=3)
    assert worst is not None and worst < 1e-5, worst
    names = [i.name for i in session(path).get_inputs()]
    assert names == ["obs", "h_in", "c_in"]


def test_a_checkpoint_of_the_cpu_profile_network_exports(tmp_path):
    """ShadowHand's CPU profile trains a smaller network than its config's: a checkpoint of
    either (trained on a GPU, or on a CPU without num_envs=) exports; here the profile's, which
    `myriad export` tries second."""
    _, full = configs("task=ShadowHand", "num_envs=1")
    _, profile = configs("task=ShadowHand")
    units = profile["params"]["network"]["mlp"]["units"]
    assert units != full["params"]["network"]["mlp"]["units"]
    net = policy.build_network(profile, 211, 20)
    checkpoint = tmp_path / "hand.pth"
    torch.save({"model": net.state_dict(), "epoch": 7, "frame": 1234}, checkpoint)
    output = tmp_path / "hand.onnx"
    assert cli.main(["export", "task=ShadowHand", f"checkpoint={checkpoint}",
                     f"output={output}"]) == 0
    side = json.loads(output.with_suffix(".json").read_text())
    assert side["epoch"] == 7 and side["env_steps"] == 1234
    assert side["observation"]["size"] == 211 and "layout" not in side["observation"]
    assert side["action"]["size"] == 20 and len(side["action"]["scaling"]["lower"]) == 24
    assert [o.shape for o in session(output).get_outputs()] == [["batch", 20]]


def test_a_graph_that_disagrees_with_the_policy_is_not_kept(ant_checkpoint, tmp_path,
                                                            monkeypatch, capsys):
    from myriad.rl import export

    monkeypatch.setattr(export, "verify_onnx", lambda *args, **kwargs: 0.5)
    assert cli.main(["export", "task=Ant", f"checkpoint={ant_checkpoint}",
                     f"output={tmp_path / 'p.onnx'}"]) == 2
    assert "differ from the policy's by 0.5" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
