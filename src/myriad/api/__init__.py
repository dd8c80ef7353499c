"""The Isaac Gym-style layer: envs of several actors, state tensors, actuation, indexed resets.

    scene = myriad.api.Scene().add_ground()
    scene.add_actor("ant", myriad.asset_path("ant.xml"), pos=(0, 0, 0.62))
    envs = scene.build(num_envs=1024, device="cpu", params=myriad.SimParams(...))
    envs.set_dof_efforts(torch.zeros(1024, envs.num_dofs)); envs.step()
    envs.root_states, envs.dof_pos, envs.rigid_body_states, envs.force_sensors
"""

from .envs import Envs
from .scene import DOF_MODES, Actor, Scene

__all__ = ["DOF_MODES", "Actor", "Envs", "Scene"]
