"""Offscreen video of env 0, drawn by MuJoCo's renderer from our simulated states.

Headless machines need an offscreen OpenGL: EGL (Mesa's software or a GPU driver) or OSMesa.
`myriad` picks EGL unless MUJOCO_GL says otherwise; it must be chosen before MuJoCo is imported.
"""

from __future__ import annotations

import os

import numpy as np


class VideoWriter:
    """Collects frames of env 0 of an `Envs` and writes an .mp4 (ffmpeg) or .gif on close."""

    def __init__(self, path: str, envs, fps: int, size=(480, 640)):
        import mujoco

        ext = os.path.splitext(path)[1].lower()
        if ext not in (".mp4", ".gif"):
            raise ValueError(f"video={path}: the file must end in .mp4 or .gif")
        self.path, self.envs, self.fps = path, envs, fps
        self.mj_model = envs.model.mj_model
        self.data = mujoco.MjData(self.mj_model)
        self.mj_model.vis.global_.offwidth = max(self.mj_model.vis.global_.offwidth, size[1])
        self.mj_model.vis.global_.offheight = max(self.mj_model.vis.global_.offheight, size[0])
        try:
            self.renderer = mujoco.Renderer(self.mj_model, height=size[0], width=size[1])
        except Exception as err:
            raise RuntimeError(
                f"MuJoCo could not open an offscreen OpenGL context (MUJOCO_GL="
                f"{os.environ.get('MUJOCO_GL', 'unset')}): {err}. On a headless Linux machine "
                "install Mesa's EGL (apt install libegl1) or OSMesa (apt install libosmesa6) and "
                "set MUJOCO_GL=egl or MUJOCO_GL=osmesa.") from err
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        self.camera.trackbodyid = envs.actor_root_body[0] + 1     # MuJoCo counts the world body
        self.camera.distance, self.camera.elevation, self.camera.azimuth = 4.0, -20.0, 120.0
        self.frames = []

    def add_frame(self) -> None:
        import mujoco

        q = self.envs.sim.q[0].detach().cpu().numpy().astype(np.float64)
        self.data.qpos[:] = self.envs.model.qpos_to_mujoco(q)
        mujoco.mj_kinematics(self.mj_model, self.data)
        mujoco.mj_comPos(self.mj_model, self.data)    # subtree centers: the camera follows them
        self.renderer.update_scene(self.data, camera=self.camera)
        self.frames.append(self.renderer.render().copy())

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        import imageio.v2 as imageio

        self.renderer.close()
        if not self.frames:
            return
        os.makedirs(os.path.dirname(os.path.abspath(self.path)), exist_ok=True)
        tmp = self.path + ".tmp" + os.path.splitext(self.path)[1]
        if self.path.lower().endswith(".gif"):
            imageio.mimsave(tmp, self.frames, duration=1000 / self.fps, loop=0)
        else:
            imageio.mimsave(tmp, self.frames, fps=self.fps, macro_block_size=8)
        os.replace(tmp, self.path)
