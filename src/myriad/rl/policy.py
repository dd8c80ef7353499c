"""A trained rl_games policy as a plain function: observations -> deterministic actions."""

from __future__ import annotations

import torch
from rl_games.algos_torch import torch_ext
from rl_games.algos_torch.model_builder import ModelBuilder


def load_policy(checkpoint: str, train_cfg: dict, task, restore_task: bool = False):
    """The policy's mean action (clamped to [-1, 1]) for a batch of observations of `task`:
    `policy(obs, new_episode=None)`. A recurrent policy (an `rnn` section) carries its state
    from call to call, one per env, zero at the start and for the envs that `new_episode` [N]
    (bool: the `done` of the step that produced `obs`) marks. `restore_task`: also give `task`
    the checkpoint's task state (`restore_task_state`), from the same read."""
    params = train_cfg["params"]
    config = params["config"]
    network = ModelBuilder().load(params).build({
        "actions_num": task.num_actions, "input_shape": (task.num_obs,), "num_seqs": 1,
        "value_size": 1, "normalize_value": config.get("normalize_value", False),
        "normalize_input": config.get("normalize_input", False)})
    try:
        state = torch_ext.load_checkpoint(checkpoint)
    except Exception as err:  # truncated or not a checkpoint: torch raises several kinds
        raise ValueError(f"checkpoint {checkpoint}: not a readable rl_games checkpoint "
                         f"({type(err).__name__}: {err})") from err
    try:
        network.load_state_dict(state["model"])
    except (RuntimeError, KeyError) as err:
        raise ValueError(f"checkpoint {checkpoint} does not fit the {type(task).__name__} network "
                         f"of the train config ({config.get('name')}): {err}") from err
    if restore_task:
        restore_task_state(task, state)
    return policy_from_network(network, task)


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
    picks the network the checkpoint fits with `export.load_network`)."""
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
