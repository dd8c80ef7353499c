"""`isaacgym` on Myriad: run Isaac Gym Preview 4 Python code unchanged, on Myriad's engine.

    from isaacgym import gymapi, gymtorch, gymutil
    from isaacgym.torch_utils import *

`gymapi` (the Gym object, parameters, math types, enums), `gymtorch` (wrap_tensor /
unwrap_tensor), `gymutil` (command-line flags), `torch_utils` (batched quaternion helpers in
Isaac Gym's conventions) and `terrain_utils` (height-field terrain generators and their mesh)
are provided; IsaacGymEnvs' and legged_gym's own train.py run on them unmodified
(benchmarks/isaacgym_projects.sh). What is supported, what raises `NotImplementedError` and how
the semantics map: docs/isaacgym.md.

Importing `isaacgym` before or after `torch` both work (the original required it first).
"""

# myriad first: it picks MuJoCo's offscreen OpenGL (EGL on a machine without a display), which
# MuJoCo fixes when it is imported; gymapi imports MuJoCo (camera sensors, viewer images)
import myriad  # noqa: E402,F401,I001
from . import gymapi, gymtorch, gymutil, terrain_utils, torch_utils  # noqa: E402,F401

__all__ = ["gymapi", "gymtorch", "gymutil", "terrain_utils", "torch_utils"]
