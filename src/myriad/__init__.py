"""Myriad: massively parallel rigid-body physics and robot learning, on CPU and NVIDIA GPUs."""

import os as _os
import sys as _sys

# Videos are drawn by MuJoCo's offscreen renderer, whose OpenGL backend is fixed when MuJoCo is
# imported: on a Linux machine without a display, use EGL (works on Mesa with no GPU), else
# OSMesa. With neither library MuJoCo's import itself would fail (PyOpenGL finds no EGL), so
# rendering is switched off and only `myriad play` says what to install.
if _sys.platform.startswith("linux") and not _os.environ.get("DISPLAY") \
        and "MUJOCO_GL" not in _os.environ:
    from ctypes.util import find_library as _find_library
    _os.environ["MUJOCO_GL"] = ("egl" if _find_library("EGL") else
                                "osmesa" if _find_library("OSMesa") else "disable")

from .physics import (Model, ModelError, SimParams, Simulator, from_mujoco, load, load_asset,
                      load_xml)
from .assets import asset_path
from .rl.vector import make_vec

__version__ = "0.1.0"


def make(name: str, num_envs: int | None = None, device: str = "cpu", **overrides):
    """Build a task by name (see `myriad.tasks.make`): ``myriad.make("Ant", num_envs=512)``."""
    from .tasks import make as _make
    return _make(name, num_envs=num_envs, device=device, **overrides)


__all__ = ["Model", "ModelError", "SimParams", "Simulator", "asset_path", "from_mujoco", "load",
           "load_asset", "load_xml", "make", "make_vec"]
