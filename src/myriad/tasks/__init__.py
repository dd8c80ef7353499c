"""Tasks: one file per task, its config in cfg/task/<Name>.yaml; `make` builds one by name."""

from __future__ import annotations

from importlib import resources

from omegaconf import OmegaConf

from .ant import Ant
from .anymal import Anymal
from .base import VecTask
from .humanoid import Humanoid
from .ingenuity import Ingenuity

TASKS = {"Ant": Ant, "Anymal": Anymal, "Humanoid": Humanoid, "Ingenuity": Ingenuity}


def task_config(name: str) -> dict:
    """The task's YAML (cfg/task/<name>.yaml) as a plain dict."""
    if name not in TASKS:
        raise KeyError(f"unknown task {name!r}; the tasks are {sorted(TASKS)}")
    text = (resources.files("myriad") / "cfg" / "task" / f"{name}.yaml").read_text()
    return OmegaConf.to_container(OmegaConf.create(text), resolve=True)


def apply_overrides(cfg: dict, overrides: dict, where: str) -> dict:
    """Set `key=value` pairs in cfg: a dotted path ("sim.dt", "env.plane.restitution"), a bare
    key of the `env` section ("episodeLength") or a whole top-level section
    ("randomization={...}"). Unknown keys fail, listing the valid ones."""
    for key, value in overrides.items():
        if "." in key:
            path = key.split(".")
        else:       # a key of the env section, or a whole top-level section ("randomization")
            path = ["env", key] if key in cfg["env"] or key not in cfg else [key]
        node = cfg
        for i, part in enumerate(path):
            if not isinstance(node, dict) or part not in node:
                parent = ".".join(path[:i]) or "(top)"
                valid = sorted(node) if isinstance(node, dict) else []
                raise KeyError(f"{where}: no config key {key!r} ({part!r} is not in {parent}); "
                               f"valid keys there: {valid}")
            if i == len(path) - 1:
                node[part] = value
            node = node[part]
    return cfg


def make(name: str, num_envs: int | None = None, device: str = "cpu", **overrides) -> VecTask:
    """Build a task by name: `myriad.make("Ant", num_envs=512, device="cuda:0", episodeLength=500)`.

    Keyword overrides are config keys of the task's `env` section, or dotted paths into the whole
    config (write those as `**{"sim.dt": 0.01}`).
    """
    cfg = task_config(name)
    cfg.pop("cpu", None)
    if num_envs is not None:
        overrides = {"numEnvs": num_envs, **overrides}
    apply_overrides(cfg, overrides, f"task {name}")
    return TASKS[name](cfg, device=device)


__all__ = ["TASKS", "VecTask", "make", "task_config", "apply_overrides"]
