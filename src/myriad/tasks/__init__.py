"""Tasks: one file per task, its config in cfg/task/<Name>.yaml; `make` builds one by name."""

from __future__ import annotations

import difflib
import math
import numbers
from importlib import resources

from omegaconf import OmegaConf

from .ant import Ant
from .anymal import Anymal
from .anymal_terrain import AnymalTerrain
from .base import VecTask
from .g1 import G1Rough, G1Velocity
from .humanoid import Humanoid
from .ingenuity import Ingenuity
from .franka import FrankaCubeStack
from .hands import AllegroHand, ShadowHand
from .humanoid_amp import HumanoidAMP
from .trifinger import Trifinger

TASKS = {"Ant": Ant, "Anymal": Anymal, "AnymalTerrain": AnymalTerrain, "Humanoid": Humanoid, "Ingenuity": Ingenuity,
         "G1Velocity": G1Velocity, "G1Rough": G1Rough,
         "ShadowHand": ShadowHand, "ShadowHandOpenAI_FF": ShadowHand,
         "ShadowHandOpenAI_LSTM": ShadowHand, "AllegroHand": AllegroHand,
         "FrankaCubeStack": FrankaCubeStack, "Trifinger": Trifinger, "HumanoidAMP": HumanoidAMP}


def config_int(value, key: str, minimum: int | None = None) -> int:
    """The config value `value` of `key` as an int, or a ValueError naming the key and the value.

    The one parser of integer settings (`num_envs`, `env.numEnvs`, `env.episodeLength` ...):
    accepts an int, a float or string with an integral value (2.0 and "2.0" are 2), and refuses
    fractions (2.5), text ("abc"), booleans and None.
    """
    number = value
    if isinstance(value, str):
        try:
            number = int(value.strip())
        except ValueError:
            try:
                number = float(value.strip())
            except ValueError:
                raise ValueError(f"{key}={value!r}: expected an integer") from None
    if isinstance(number, bool) or not isinstance(number, numbers.Real):
        raise ValueError(f"{key}={value!r}: expected an integer, not {type(value).__name__}")
    if not isinstance(number, numbers.Integral):
        if not (math.isfinite(number) and float(number).is_integer()):
            raise ValueError(f"{key}={value!r}: expected an integer, not a fraction")
    result = int(number)
    if minimum is not None and result < minimum:
        raise ValueError(f"{key}={value}: must be >= {minimum}")
    return result


def config_float(value, key: str) -> float:
    """The config value `value` of `key` as a float (inf allowed), or a ValueError naming both."""
    number = value
    if isinstance(value, str):
        try:
            number = float(value.strip())
        except ValueError:
            raise ValueError(f"{key}={value!r}: expected a number") from None
    if isinstance(number, bool) or not isinstance(number, numbers.Real) or math.isnan(number):
        raise ValueError(f"{key}={value!r}: expected a number")
    return float(number)


def task_config(name: str) -> dict:
    """The task's YAML (cfg/task/<name>.yaml) as a plain dict. A task's YAML may start from
    another's (`defaults: [Base, _self_]`, as Hydra reads it): Base's keys, then its own merged
    over them."""
    if name not in TASKS:
        raise KeyError(f"unknown task {name!r}; the tasks are {sorted(TASKS)}")
    text = (resources.files("myriad") / "cfg" / "task" / f"{name}.yaml").read_text()
    cfg = OmegaConf.create(text)
    bases = [b for b in cfg.pop("defaults", []) if b != "_self_"]
    merged = OmegaConf.merge(*[OmegaConf.create(task_config(b)) for b in bases], cfg)
    return OmegaConf.to_container(merged, resolve=True)


def apply_overrides(cfg: dict, overrides: dict, where: str) -> dict:
    """Set `key=value` pairs in cfg: a dotted path ("sim.dt", "env.plane.restitution"), a bare
    key of the `env` section ("episodeLength") or a whole top-level section
    ("randomization={...}"). Unknown keys fail, listing the valid ones; a SimParams setting of
    `sim.physx` (`base.PHYSX_KEYS`) may be added where the YAML leaves it out, as on the
    command line."""
    from .base import PHYSX_KEYS
    for key, value in overrides.items():
        if "." in key:
            path = key.split(".")
        else:       # a key of the env section, or a whole top-level section ("randomization")
            path = ["env", key] if key in cfg["env"] or key not in cfg else [key]
        node = cfg
        for i, part in enumerate(path):
            if path[:i] == ["sim", "physx"] and i == len(path) - 1 and part in PHYSX_KEYS \
                    and isinstance(node, dict):
                node.setdefault(part, value)
            if not isinstance(node, dict) or part not in node:
                parent = ".".join(path[:i]) or "(top)"
                valid = sorted(node) if isinstance(node, dict) else []
                close = difflib.get_close_matches(".".join(path), _key_paths(cfg), n=3)
                hint = f"did you mean {', '.join(close)}? " if close else ""
                raise KeyError(f"{where}: no config key {key!r} ({part!r} is not in {parent}); "
                               f"{hint}valid keys there: {valid}")
            if i == len(path) - 1:
                node[part] = value
            node = node[part]
    return cfg


def _key_paths(node, prefix: str = "") -> list[str]:
    """Every dotted key path of a nested dict ("env", "env.plane", "env.plane.restitution" ...)."""
    paths = []
    if isinstance(node, dict):
        for key, value in node.items():
            path = f"{prefix}.{key}" if prefix else str(key)
            paths += [path, *_key_paths(value, path)]
    return paths


def make(name: str, num_envs: int | None = None, device: str = "cpu", **overrides) -> VecTask:
    """Build a task by name: `myriad.make("Ant", num_envs=512, device="cuda:0", episodeLength=500)`.

    Keyword overrides are config keys of the task's `env` section, or dotted paths into the whole
    config (write those as `**{"sim.dt": 0.01}`).
    """
    from ..physics.runtime import resolve_device

    cfg = task_config(name)
    cfg.pop("cpu", None)
    resolve_device(device)     # "gpu" or a missing GPU fails in one line, before torch sees it
    if num_envs is not None:
        overrides = {"numEnvs": config_int(num_envs, "num_envs", minimum=1), **overrides}
    apply_overrides(cfg, overrides, f"task {name}")
    return TASKS[name](cfg, device=device)


__all__ = ["TASKS", "VecTask", "apply_overrides", "config_float", "config_int", "make",
           "task_config"]
