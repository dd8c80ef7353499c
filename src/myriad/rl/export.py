"""`myriad export`: a trained policy as one ONNX file and a JSON sidecar, for a real robot.

    myriad export task=Anymal checkpoint=runs/Anymal/nn/last.pth output=anymal.onnx

The graph takes the task's raw observations (what `task.step` returns: the task's own scaling
applied, before rl_games' normalisation) and gives the deterministic action that `myriad play`
runs: the mean of the policy's Gaussian, clamped to [-1, 1]. Inside the graph, in order:

    x = clamp(obs, -clipObservations, clipObservations)                  the task's clip
    x = clamp((x - mean) / sqrt(var + 1e-5), -5, 5)                       rl_games' RunningMeanStd
    actions = clamp(mu(x), -1, 1)                                         the actor's mean

with the checkpoint's running mean and variance (rl_games keeps them in float64 and normalises
with their float32 values: so does the graph). Only the actor is exported: the value head and an
asymmetric task's central value (the critic fed privileged states) are left out.

A recurrent policy (a train config with an `rnn` section, e.g. ShadowHandOpenAI_LSTM) carries its
state through explicit inputs and outputs: an LSTM takes `h_in`, `c_in` and returns `h_out`,
`c_out` (a GRU only `h_in` → `h_out`), each [layers, batch, units]; feed zeros at an episode's
start and each step's outputs back as the next step's inputs.

Names and shapes (batch is dynamic):
    inputs   obs [batch, num_obs] float32  (+ h_in, c_in [layers, batch, units])
    outputs  actions [batch, num_actions] float32  (+ h_out, c_out)

The sidecar (the ONNX path with .json) says what a robot needs around the graph: the task, the
observation size, clip and layout (for the tasks in `OBSERVATION_LAYOUTS`), the action size,
meaning and scaling (`ACTIONS`, values read from the built task), the control rate, the graph's
inputs and outputs, the checkpoint and its epoch.

Export runs on the CPU whatever `device=` says (the task is built with one env, only to be
read), loads checkpoints trained on a GPU, and accepts either network of a task whose CPU
profile changes it (`load_network`). With onnxruntime installed, the written graph is run on
random observations against rl_games' own network before anything is kept (`verify_onnx`).

The exporter is torch's TorchScript-based one (`dynamo=False`; it needs the `onnx` package:
`pip install "myriad[export]"`): it takes a second where the torch.export-based one takes 5 to
10 and needs `onnxscript` too, writes one self-contained file with a dynamic batch axis at
opset 17, and turns `nn.LSTM` into ONNX's LSTM operator; the graph is a fixed sequence of
operators with no control flow, which that exporter handles fully. torch has deprecated it
since 2.9: where a torch no longer has it, the torch.export-based one is used
(`write_onnx(dynamo=True)`, tested to give the same actions).
"""

from __future__ import annotations

import contextlib
import copy
import importlib.util
import io
import json
import math
import os
import time
import warnings

import torch
from torch import nn

from .policy import load_network, read_checkpoint

# ONNX operator set of the graph: 17 has LayerNormalization (the LSTM policies' layer norm) as
# one operator; onnxruntime has run it since 1.14
OPSET = 17

# Observation layouts, [start, end) slices with names, from the tasks' module docstrings (each
# task's docstring is the reference; a layout whose sizes do not add up to the built task's
# observation size is left out of the sidecar rather than written wrong)
_SHADOW_OPENAI = [("fingertip positions (ff, mf, rf, lf, th) × xyz", 0, 15),
                  ("cube position", 15, 18),
                  ("cube quaternion · conj(goal quaternion) (x, y, z, w)", 18, 22),
                  ("last actions", 22, 42)]
_G1 = [("base linear velocity, base frame, × linearVelocityScale", 0, 3),
       ("base angular velocity, base frame, × angularVelocityScale", 3, 6),
       ("gravity direction in the base frame", 6, 9),
       ("commands (vx, vy, yaw rate) × (linear, linear, angular velocity scales)", 9, 12),
       ("joint angles - default joint angles", 12, 41),
       ("joint velocities × dofVelocityScale", 41, 70), ("last actions", 70, 99),
       ("gait clock: sin, cos of 2π·phase", 99, 101)]
OBSERVATION_LAYOUTS = {
    "Ant": [("torso height", 0, 1), ("torso linear velocity, torso frame", 1, 4),
            ("torso angular velocity, torso frame", 4, 7), ("yaw, roll, angle to target", 7, 10),
            ("up projection, heading projection", 10, 12),
            ("DOF positions scaled to [-1, 1] over their limits", 12, 20),
            ("DOF velocities × dofVelocityScale", 20, 28),
            ("foot force/torque sensors (4 × (force, torque)) × contactForceScale", 28, 52),
            ("last actions", 52, 60)],
    "Humanoid": [("torso height", 0, 1), ("torso linear velocity, torso frame", 1, 4),
                 ("torso angular velocity, torso frame, × angularVelocityScale", 4, 7),
                 ("yaw, roll, angle to target", 7, 10),
                 ("up projection, heading projection", 10, 12),
                 ("DOF positions scaled to [-1, 1] over their limits", 12, 33),
                 ("DOF velocities × dofVelocityScale", 33, 54),
                 ("DOF forces × contactForceScale", 54, 75),
                 ("foot force/torque sensors (2 × (force, torque)) × contactForceScale", 75, 87),
                 ("last actions", 87, 108)],
    "Anymal": [("base linear velocity, base frame, × linearVelocityScale", 0, 3),
               ("base angular velocity, base frame, × angularVelocityScale", 3, 6),
               ("gravity direction in the base frame", 6, 9),
               ("commands (vx, vy, yaw rate) × (linear, linear, angular velocity scales)", 9, 12),
               ("joint angles - default joint angles, × dofPositionScale", 12, 24),
               ("joint velocities × dofVelocityScale", 24, 36), ("last actions", 36, 48)],
    "AnymalTerrain": [("base linear velocity, base frame, × 2", 0, 3),
                      ("base angular velocity, base frame, × 0.25", 3, 6),
                      ("gravity direction in the base frame", 6, 9),
                      ("commands (vx, vy, yaw rate) × (2, 2, 0.25)", 9, 12),
                      ("joint angles", 12, 24), ("joint velocities × 0.05", 24, 36),
                      ("terrain heights: clip(z_base - 0.5 - h, -1, 1) × 5 at 14 × 10 points",
                       36, 176), ("last actions", 176, 188)],
    "G1Velocity": _G1,
    "G1Rough": _G1 + [("terrain heights: clip(z_base - 0.5 - h, -1, 1) × 5 at 14 × 10 points",
                       101, 241)],
    "Ingenuity": [("offset to the target / 3", 0, 3), ("root quaternion (x, y, z, w)", 3, 7),
                  ("linear velocity / 2, world frame", 7, 10),
                  ("angular velocity / π, world frame", 10, 13)],
    "Trifinger": [("joint positions, unscaled to [-1, 1] by the joint limits", 0, 9),
                  ("joint velocities / 10 rad/s", 9, 18),
                  ("cube position (x, y / 0.3; z unscaled from [0, 0.3]), quaternion", 18, 25),
                  ("goal position (as the cube's), quaternion", 25, 32), ("last actions", 32, 41)],
    "ShadowHandOpenAI_FF": _SHADOW_OPENAI,
    "ShadowHandOpenAI_LSTM": _SHADOW_OPENAI,
}

# What an action means, and the task attributes that scale it (tensors of one value per joint
# are written per joint name)
_HAND = ("position targets of the actuated joints: target = lower + (action + 1) / 2 × "
         "(upper - lower), then target = α·target + (1 - α)·previous target (α = actionsMovingAverage), "
         "clamped to the limits", {"actionsMovingAverage": "moving_average",
                                   "lower": "dof_lower", "upper": "dof_upper"})
_WALKER = ("joint torques: torque = action × motor gear × powerScale",
           {"gear": "gears", "powerScale": "power_scale"})
_G1_ACTIONS = ("position-drive targets: target = actionScale × action + defaultJointAngles "
               "(drive gains per joint group: env.control.gains)",
               {"actionScale": "action_scale", "defaultJointAngles": "default_dof_pos"})
ACTIONS = {
    "Ant": _WALKER,
    "Humanoid": _WALKER,
    "Anymal": ("position-drive targets: target = actionScale × action + defaultJointAngles",
               {"actionScale": "action_scale", "defaultJointAngles": "default_dof_pos"}),
    "AnymalTerrain": ("PD torques at the physics rate: torque = clip(Kp·(actionScale × action + "
                      "defaultJointAngles - q) - Kd·q̇, ±torqueLimit)",
                      {"actionScale": "action_scale", "defaultJointAngles": "default_dof_pos",
                       "Kp": "kp", "Kd": "kd", "torqueLimit": "torque_limit"}),
    "G1Velocity": _G1_ACTIONS, "G1Rough": _G1_ACTIONS,
    "Trifinger": ("joint torques: τ = 0.36 N·m × action, less a safety damping (0.08, 0.08, "
                  "0.04)·q̇ per finger, clamped to ±0.36 N·m", {}),
    "Ingenuity": ("per rotor (lower, upper): lateral thrust fractions x, y (clamped to "
                  "±lateralFraction) and a vertical thrust command z (× thrustActionScale)",
                  {"thrustActionScale": "thrust_action_scale"}),
    "FrankaCubeStack": ("'osc': a[0:6] × commandLimit is the grip point's task-space pose error, "
                        "a[6] >= 0 opens the gripper; 'joint_tor': a[0:7] × effort limits",
                        {"commandLimit": "action_scale"}),
    "HumanoidAMP": ("PD position targets: target = pd_offset + pd_scale × action",
                    {"pd_offset": "pd_offset", "pd_scale": "pd_scale"}),
    "ShadowHand": _HAND, "ShadowHandOpenAI_FF": _HAND, "ShadowHandOpenAI_LSTM": _HAND,
    "AllegroHand": _HAND,
}


class OnnxActor(nn.Module):
    """The actor of an rl_games continuous actor-critic (`continuous_a2c_logstd` with the
    `actor_critic` network, MLP with an optional LSTM or GRU), with the task's observation clip
    and rl_games' input normalisation in front: raw observations -> clamp(mean action, -1, 1).

    forward(obs[, h, c]) -> actions[, h_out, c_out]; the recurrent state is
    [layers, batch, units]."""

    def __init__(self, model: nn.Module, clip_obs: float):
        super().__init__()
        net = model.a2c_network
        unsupported = [what for what, bad in (
            ("a CNN", getattr(net, "has_cnn", False)),
            ("a discrete action space", not getattr(net, "is_continuous", False)),
            ("an identity RNN", net.has_rnn and net.rnn_name not in ("lstm", "gru")))
            if bad]
        if unsupported:
            raise ValueError(f"export: the policy network has {', '.join(unsupported)}; only "
                             "continuous MLP policies, with an optional LSTM or GRU, export")
        self.clip_obs = float(clip_obs)
        self.normalize = bool(model.normalize_input)
        if self.normalize:
            rms = model.running_mean_std
            # rl_games: (x - mean.float()) / sqrt(var.float() + eps), clamped to ±5
            self.register_buffer("obs_mean", rms.running_mean.detach().float().clone())
            self.epsilon = float(rms.epsilon)
            self.register_buffer("obs_std", torch.sqrt(rms.running_var.detach().float()
                                                       + self.epsilon))
        sep = net.separate
        self.mlp = net.actor_mlp
        self.mu, self.mu_act = net.mu, net.mu_act
        self.rnn_kind = net.rnn_name if net.has_rnn else None
        if self.rnn_kind:
            self.rnn = (net.a_rnn if sep else net.rnn).rnn      # the torch.nn.LSTM / GRU inside
            self.layer_norm = ((net.a_layer_norm if sep else net.layer_norm)
                               if net.rnn_ln else None)
            self.rnn_before_mlp = net.is_rnn_before_mlp
            self.concat_input, self.concat_output = net.rnn_concat_input, net.rnn_concat_output
            self.rnn_layers, self.rnn_units = net.rnn_layers, net.rnn_units

    def normalized(self, obs: torch.Tensor) -> torch.Tensor:
        x = obs
        if math.isfinite(self.clip_obs):
            x = torch.clamp(x, -self.clip_obs, self.clip_obs)
        if self.normalize:
            x = torch.clamp((x - self.obs_mean) / self.obs_std, -5.0, 5.0)
        return x

    def forward(self, obs: torch.Tensor, *state: torch.Tensor):
        x = self.normalized(obs)
        if not self.rnn_kind:
            return torch.clamp(self.mu_act(self.mu(self.mlp(x))), -1.0, 1.0)
        inputs = x
        if not self.rnn_before_mlp:
            x = self.mlp(x)
            if self.concat_input:
                x = torch.cat([x, inputs], dim=1)
        hidden = (state[0], state[1]) if self.rnn_kind == "lstm" else state[0]
        out, hidden = self.rnn(x.unsqueeze(0), hidden)        # one step: [1, batch, features]
        x = out.squeeze(0)
        if self.layer_norm is not None:
            x = self.layer_norm(x)
        if self.concat_output:
            x = torch.cat([x, inputs], dim=1)
        if self.rnn_before_mlp:
            x = self.mlp(x)
        actions = torch.clamp(self.mu_act(self.mu(x)), -1.0, 1.0)
        return (actions, *hidden) if self.rnn_kind == "lstm" else (actions, hidden)

    def state_names(self) -> tuple[list[str], list[str]]:
        if self.rnn_kind == "lstm":
            return ["h_in", "c_in"], ["h_out", "c_out"]
        return (["h_in"], ["h_out"]) if self.rnn_kind else ([], [])

    def zero_state(self, batch: int) -> list[torch.Tensor]:
        if not self.rnn_kind:
            return []
        shape = (self.rnn_layers, batch, self.rnn_units)
        return [torch.zeros(shape) for _ in self.state_names()[0]]


def _plain(value):
    """A task attribute as JSON: numbers rounded to float32 precision, tensors as lists."""
    if isinstance(value, torch.Tensor):
        value = value.detach().cpu()
        return float(value) if value.dim() == 0 else [_plain(v) for v in value.tolist()]
    if isinstance(value, float):
        return float(f"{value:.7g}")
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def _action_scaling(task, attributes: dict) -> dict:
    """The scaling values the task holds, per joint name where one value per DOF."""
    envs = getattr(task, "envs", None)
    dof_names = list(getattr(envs, "dof_names", []) or [])
    actuated = getattr(task, "actuated", None)
    scaling = {}
    for key, attribute in attributes.items():
        value = getattr(task, attribute, None)
        if value is None:
            continue
        if isinstance(value, torch.Tensor) and value.dim() == 1 and dof_names \
                and len(value) == len(dof_names):
            names = dof_names
            scaling[key] = {n: _plain(v) for n, v in zip(names, value.tolist())}
        else:
            scaling[key] = _plain(value)
    if actuated is not None and dof_names:      # the hands: which DOFs the actions drive
        index = actuated.tolist() if isinstance(actuated, torch.Tensor) else list(actuated)
        if all(isinstance(i, int) for i in index):
            scaling["actuated_joints"] = [dof_names[i] for i in index]
    return scaling


def sidecar(name: str, task, actor: OnnxActor, onnx_path: str, checkpoint: str,
            state: dict) -> dict:
    """The JSON next to the ONNX file (the module's docstring lists what it says)."""
    sim_dt, decimation = float(task.sim_params.dt), int(task.control_freq_inv)
    num_obs, num_actions = task.num_obs, task.num_actions
    state_in, state_out = actor.state_names()
    rnn_shape = [actor.rnn_layers, "batch", actor.rnn_units] if actor.rnn_kind else None
    clip = _plain(task.clip_obs) if math.isfinite(task.clip_obs) else None
    observation = {
        "size": num_obs,
        "clip": clip,
        "in_graph": ("feed raw observations (the task's own scaling applied, as in its "
                     "layout): the graph clamps them to ±clip"
                     + (", then normalizes them" if actor.normalize else "")),
        "normalization": {
            "formula": "clamp((x - mean) / sqrt(var + epsilon), -5, 5)",
            "epsilon": float(actor.epsilon), "clip": 5.0,
            "statistics": "the checkpoint's running mean and variance (rl_games' "
                          "RunningMeanStd), constants of the graph"} if actor.normalize else None,
    }
    layout = OBSERVATION_LAYOUTS.get(name)
    if layout and layout[-1][2] == num_obs and all(a[2] == b[1] for a, b in
                                                   zip(layout, layout[1:])):
        observation["layout"] = [{"name": n, "slice": [start, end]} for n, start, end in layout]
    meaning, attributes = ACTIONS.get(name, (None, {}))
    return {
        "task": name,
        "onnx": os.path.basename(onnx_path),
        "opset": OPSET,
        "inputs": [{"name": "obs", "shape": ["batch", num_obs], "dtype": "float32"}]
                  + [{"name": n, "shape": rnn_shape, "dtype": "float32"} for n in state_in],
        "outputs": [{"name": "actions", "shape": ["batch", num_actions], "dtype": "float32"}]
                   + [{"name": n, "shape": rnn_shape, "dtype": "float32"} for n in state_out],
        "observation": observation,
        "action": {
            "size": num_actions,
            "range": [-1.0, 1.0],
            "clipActions": _plain(task.clip_actions),
            "meaning": meaning,
            "scaling": _action_scaling(task, attributes),
            "note": "the graph's output is the action `myriad play` steps the task with; the "
                    "task clips it to ±clipActions and applies the meaning and scaling above",
        },
        "control": {"rate_hz": float(f"{1.0 / (sim_dt * decimation):.7g}"),
                    "dt": float(f"{sim_dt * decimation:.7g}"), "sim_dt": sim_dt,
                    "controlFrequencyInv": decimation},
        "recurrent": None if not actor.rnn_kind else {
            "type": actor.rnn_kind, "layers": actor.rnn_layers, "units": actor.rnn_units,
            "state_inputs": state_in, "state_outputs": state_out,
            "usage": "zeros at an episode's start; feed each step's outputs back as the next "
                     "step's inputs"},
        "actor_only": True,
        "critic_states": int(getattr(task, "num_states", 0)) or None,
        "checkpoint": os.path.abspath(checkpoint),
        "epoch": state.get("epoch"),
        "env_steps": state.get("frame"),
        "exported": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
    }


def write_onnx(actor: OnnxActor, num_obs: int, path: str, dynamo: bool = False) -> int:
    """torch.onnx.export of the actor, the batch axis dynamic; returns the graph's opset.

    `dynamo=False` (the default): torch's TorchScript-based exporter (the module docstring says
    why). `dynamo=True`: the torch.export-based one (needs `onnxscript`; opset 18, its
    lowest), which is also taken should a torch no longer have the former."""
    if importlib.util.find_spec("onnx") is None:
        raise RuntimeError("export needs the onnx package: pip install 'myriad[export]' (onnx "
                           "and onnxruntime)")
    state_in, state_out = actor.state_names()
    example = (torch.zeros(2, num_obs), *actor.zero_state(2))
    names = {"input_names": ["obs", *state_in], "output_names": ["actions", *state_out]}
    with warnings.catch_warnings(), torch.no_grad(), \
            contextlib.redirect_stdout(io.StringIO()):
        # the TorchScript exporter's deprecation notice, the tracer's notes on the LSTM
        warnings.simplefilter("ignore")
        if not dynamo:
            dynamic = {"obs": {0: "batch"}, "actions": {0: "batch"}}
            dynamic.update({n: {1: "batch"} for n in state_in + state_out})
            try:
                torch.onnx.export(actor, example, path, dynamic_axes=dynamic,
                                  opset_version=OPSET, dynamo=False, **names)
                return OPSET
            except (ImportError, NotImplementedError) as err:
                if "onnx" in str(err).lower() and "install" in str(err).lower():
                    raise
                # a torch without the TorchScript exporter: the other one
        if importlib.util.find_spec("onnxscript") is None:
            raise RuntimeError("this torch exports ONNX only with torch.export, which needs "
                               "the onnxscript package: pip install onnxscript")
        batch = torch.export.Dim("batch")
        shapes = ({0: batch}, tuple({1: batch} for _ in state_in)) if state_in else ({0: batch},)
        torch.onnx.export(actor, example, path, dynamic_shapes=shapes, opset_version=18,
                          dynamo=True, external_data=False, **names)
        return 18


def verify_onnx(path: str, network: nn.Module, actor: OnnxActor, num_obs: int,
                steps: int = 3, batch: int = 4) -> float | None:
    """Largest difference between the ONNX graph (run by onnxruntime, when installed) and
    rl_games' own network (its forward, as `myriad play` calls it) on random observations
    inside the task's clip, over `steps` steps with the recurrent state fed back; None
    without onnxruntime. Guards the graph against drifting from rl_games."""
    try:
        import onnxruntime
    except ImportError:
        return None
    sess = onnxruntime.InferenceSession(path, providers=["CPUExecutionProvider"])
    state_in, _ = actor.state_names()
    gen = torch.Generator().manual_seed(0)
    # rl_games' states: the actor's, then (a separate network) the critic's
    states = actor.zero_state(batch) * (2 if network.a2c_network.separate else 1)
    onnx_states = [z.numpy() for z in actor.zero_state(batch)]
    clip = actor.clip_obs if math.isfinite(actor.clip_obs) else 10.0
    worst = 0.0
    with torch.random.fork_rng(devices=[]), torch.no_grad():
        for _ in range(steps):
            obs = torch.clamp(torch.randn(batch, num_obs, generator=gen) * 2.0, -clip, clip)
            out = network({"is_train": False, "prev_actions": None, "obs": obs.clone(),
                           "rnn_states": tuple(states) if states else None})
            expected = [torch.clamp(out["mus"], -1.0, 1.0)]
            if states:
                states = list(out["rnn_states"])
                expected += states[:len(state_in)]
            got = sess.run(None, {"obs": obs.numpy(), **dict(zip(state_in, onnx_states))})
            onnx_states = got[1:]
            worst = max([worst] + [float(abs(g - e.numpy()).max())
                                   for g, e in zip(got, expected)])
    return worst


def export_policy(name: str, task, train_cfgs: list[dict], checkpoint: str, output: str,
                  dynamo: bool = False) -> dict:
    """Write `output` (.onnx) and its sidecar (.json) for the policy in `checkpoint` of the
    built task `task`; returns the sidecar. `train_cfgs`: the candidate train configs
    (`load_network`); `dynamo`: the exporter (`write_onnx`). The graph is checked against
    rl_games' network with onnxruntime when it is installed (`verify_onnx`)."""
    if not str(output).endswith(".onnx"):
        raise ValueError(f"output={output}: the file name must end in .onnx")
    state = read_checkpoint(checkpoint)
    network, _ = load_network(state, train_cfgs, task.num_obs, task.num_actions, name, checkpoint)
    actor = OnnxActor(network, task.clip_obs).eval()
    folder = os.path.dirname(os.path.abspath(output))
    os.makedirs(folder, exist_ok=True)
    opset = OPSET

    def write(tmp):
        nonlocal opset
        opset = write_onnx(actor, task.num_obs, tmp, dynamo)
        worst = verify_onnx(tmp, network, actor, task.num_obs)
        if worst is not None and not worst <= 1e-4:
            raise RuntimeError(f"export: the ONNX graph's actions differ from the policy's by "
                               f"{worst:.3g} (onnxruntime {_version('onnxruntime')}, torch "
                               f"{torch.__version__}); nothing written")
    try:
        atomic_write(output, write)
    finally:
        leftover = f"{output}.tmp{os.getpid()}"           # a failed write leaves nothing
        if os.path.exists(leftover):
            os.remove(leftover)
    info = sidecar(name, task, actor, output, checkpoint, state)
    info["opset"] = opset

    def write_json(tmp):
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump(info, f, indent=2, ensure_ascii=False)
            f.write("\n")
    atomic_write(sidecar_path(output), write_json)
    return info


def atomic_write(path: str, write) -> None:
    """`write(tmp)`, then rename: a reader never sees a half-written file (myriad.rl.agent's,
    without importing rl_games' trainer, whose import takes seconds)."""
    tmp = f"{path}.tmp{os.getpid()}"
    write(tmp)
    os.replace(tmp, path)


def _version(package: str) -> str:
    from importlib import metadata

    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "not installed"


def sidecar_path(output: str) -> str:
    return output[: -len(".onnx")] + ".json"


def export(overrides: list[str]) -> int:
    """`myriad export task=<T> [checkpoint=PATH] [output=policy.onnx]`; on the CPU."""
    from ..tasks import TASKS
    from . import run

    cfg = run.compose(overrides)
    if cfg.output is not None and not str(cfg.output).endswith(".onnx"):
        raise ValueError(f"output={cfg.output}: the file name must end in .onnx")
    cfg.device = "cpu"            # the graph is device-free; the task is built only to be read
    if cfg.num_envs is None:
        cfg.num_envs = 1
    with contextlib.redirect_stdout(io.StringIO()):       # minibatch adjustments: not ours
        task_cfg, train_cfg, _ = run.task_and_train_configs(cfg, overrides)
    # the train config's network or its CPU profile's: the weights pick the one they fit
    train_cfgs = run.network_choices(cfg, overrides, train_cfg)
    name = task_cfg["name"]
    checkpoint = run.policy_checkpoint(cfg, name)
    output = cfg.output or run.output_beside(checkpoint, cfg.train_dir, f"{name}.onnx")
    task_cfg["env"]["numEnvs"] = 1
    task = TASKS[name](copy.deepcopy(task_cfg), device="cpu")
    info = export_policy(name, task, train_cfgs, str(checkpoint), str(output))
    shapes = ", ".join(f"{i['name']} {i['shape']}" for i in info["inputs"]) + " -> " + \
        ", ".join(f"{o['name']} {o['shape']}" for o in info["outputs"])
    print(f"wrote {output} ({shapes}; epoch {info['epoch']} of {checkpoint}, "
          f"{info['control']['rate_hz']:g} Hz) and {sidecar_path(str(output))}")
    return 0
