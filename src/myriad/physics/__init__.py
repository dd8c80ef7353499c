"""The physics engine: model import, batched state, and the step pipeline."""

from .runtime import configure_modules
from .importer import from_mujoco, load, load_xml
from .model import Model, ModelError
from .params import SimParams
from .simulator import Simulator
from .tolerant import load_asset

__all__ = ["Model", "ModelError", "SimParams", "Simulator", "from_mujoco", "load", "load_asset",
           "load_xml"]

configure_modules()
