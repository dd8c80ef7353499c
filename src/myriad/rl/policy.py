"""A trained rl_games policy as a plain function: observations -> deterministic actions; and
the checkpoint's network, in whichever of the candidate train configs its weights fit."""

from __future__ import annotations

import contextlib
import io
import os

import torch
from torch import nn


def load_policy(checkpoint: str, train_cfgs: dict | list[dict], task,
                restore_task: bool = False):
    """The policy's mean action (clamped to [-1, 1]) for a batch of observations of `task`:
    `policy(obs, new_episode=None)`. A recurrent policy (an `rnn` section) carries its state
    from call to call, one per env, zero at the start and for the envs that `new_episode` [N]
    (bool: the `done` of the step that produced `obs`) marks. `train_cfgs`: the train config,
    or the candidates whose network the weights may fit (`run.network_choices`).
    `restore_task`: also give `task` the checkpoint's task state (`restore_task_state`), from
    the same read."""
    state = read_checkpoint(checkpoint)
    candidates = [train_cfgs] if isinstance(train_cfgs, dict) else list(train_cfgs)
    network, _ = load_network(state, candidates, task.num_obs, task.num_actions,
                              type(task).__name__, checkpoint)
    if restore_task:
        restore_task_state(task, state)
    return policy_from_network(network, task)


def build_network(train_cfg: dict, num_obs: int, num_actions: int) -> nn.Module:
    """The rl_games model (`ModelBuilder`) of the train config for these sizes, as `myriad
    play` builds it, on the CPU; construction messages silenced."""
    from rl_games.algos_torch.model_builder import ModelBuilder

    params = train_cfg["params"]
    config = params["config"]
    with contextlib.redirect_stdout(io.StringIO()):      # "build mlp", "RunningMeanStd: ..."
        return ModelBuilder().load(params).build({
            "actions_num": num_actions, "input_shape": (num_obs,), "num_seqs": 1,
            "value_size": 1, "normalize_value": config.get("normalize_value", False),
            "normalize_input": config.get("normalize_input", False)})


def read_checkpoint(checkpoint: str) -> dict:
    """The checkpoint's dict on the CPU, or a one-line error."""
    if not os.path.isfile(checkpoint):
        raise FileNotFoundError(f"checkpoint={checkpoint}: no such file")
    try:
        state = torch.load(checkpoint, map_location="cpu", weights_only=False)
    except Exception as err:        # truncated, or not a torch file: torch raises several kinds
        raise ValueError(f"checkpoint {checkpoint}: not a readable rl_games checkpoint "
                         f"({type(err).__name__}: {err})") from err
    if not isinstance(state, dict) or "model" not in state:
        raise ValueError(f"checkpoint {checkpoint}: not an rl_games checkpoint (no 'model' "
                         "weights)")
    # torch.compile'd runs save their keys with this prefix (rl_games strips it too)
    state["model"] = {k.removeprefix("_orig_mod."): v for k, v in state["model"].items()}
    return state


def load_network(state: dict, train_cfgs: list[dict], num_obs: int, num_actions: int,
                 task: str, checkpoint: str) -> tuple[nn.Module, dict]:
    """The rl_games model with the checkpoint's weights, in eval mode on the CPU, and the train
    config it was built from: the first of `train_cfgs` (candidate network shapes: the task's
    network and, where a CPU profile changes it, the profile's) whose network the weights fit.
    Weights that fit none fail naming the task and the first mismatch."""
    first_error = None
    for train_cfg in train_cfgs:
        network = build_network(train_cfg, num_obs, num_actions)
        try:
            network.load_state_dict(state["model"])
        except RuntimeError as err:        # missing or unexpected keys, size mismatches
            first_error = first_error or err
            continue
        return network.eval(), train_cfg
    detail = str(first_error).strip().splitlines()
    shown = "; ".join(line.strip() for line in detail[1:4]) or detail[0]
    raise ValueError(f"checkpoint {checkpoint} does not fit the {task} policy network of the "
                     f"train config ({num_obs} observations, {num_actions} actions): is it "
                     f"another task's checkpoint, or was it trained with other network "
                     f"settings? {shown}")


def restore_task_state(task, state: dict) -> list[str] | None:
    """Give `task` what spanned episodes in the training that wrote the checkpoint `state`
    (AnymalTerrain's levels, HumanoidAMP's clip, a randomization schedule), where its shapes fit
    this task's envs; returns the names restored, or None (a note says why, when there were
    some)."""
    saved = (state.get("myriad") or {}).get("task") or {}
    if not saved:
        return None
    try:
        task.load_training_state(saved)
    except ValueError as err:
        print(f"note: the checkpoint's task state is not restored: {err}", flush=True)
        return None
    return sorted(saved)


def policy_from_network(network, task):
    """`load_policy`'s function for a network that already holds its weights (`myriad eval`
    picks the network the checkpoint fits with `load_network`)."""
    network.to(task.device).eval()
    states = None
    if network.is_rnn():            # [layers, 1, units] defaults, one row per env instead
        states = [torch.zeros(s.shape[0], task.num_envs, s.shape[2], device=task.device)
                  for s in network.get_default_rnn_state()]

    def policy(obs: torch.Tensor, new_episode: torch.Tensor | None = None) -> torch.Tensor:
        nonlocal states
        if states is not None and new_episode is not None:
            keep = (~new_episode.bool()).float()[None, :, None]
            states = [s * keep for s in states]
        out = network({"is_train": False, "prev_actions": None, "obs": obs,
                       "rnn_states": states})
        if states is not None:
            states = list(out["rnn_states"])
        return torch.clamp(out["mus"], -1.0, 1.0)

    return policy
