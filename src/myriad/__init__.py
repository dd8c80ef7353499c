"""Myriad: massively parallel rigid-body physics and robot learning, on CPU and NVIDIA GPUs."""

from importlib import resources as _resources

from .physics import Model, ModelError, SimParams, Simulator, from_mujoco, load, load_xml

__version__ = "0.1.0"


def asset_path(name: str) -> str:
    """Path of a model shipped with Myriad, e.g. ``asset_path("ant.xml")``."""
    path = _resources.files(__package__) / "assets" / name
    if not path.is_file():
        shipped = sorted(p.name for p in (_resources.files(__package__) / "assets").iterdir())
        raise FileNotFoundError(f"no asset named {name!r}; Myriad ships {shipped}")
    return str(path)


__all__ = ["Model", "ModelError", "SimParams", "Simulator", "asset_path", "from_mujoco", "load",
           "load_xml"]
