"""Offscreen video of env 0, drawn by MuJoCo's renderer from our simulated states.

Headless machines need an offscreen OpenGL: EGL (Mesa's software or a GPU driver) or OSMesa.
`myriad` picks EGL unless MUJOCO_GL says otherwise; it must be chosen before MuJoCo is imported.
"""

from __future__ import annotations

import os

import numpy as np


def before_offscreen_gl() -> None:
    """Loads triton (torch.compile's compiler), if installed, before MuJoCo opens an offscreen
    OpenGL context: Mesa's software EGL and triton each carry LLVM, and importing triton after
    Mesa's has loaded crashes the process (torch.compile imports it, e.g. rl_games 1.6.5's
    model compilation after an env with cameras was built). Loaded first, both work."""
    import importlib.util
    if importlib.util.find_spec("triton") is not None:
        try:
            import triton  # noqa: F401
        except Exception:
            pass


class VideoWriter:
    """Collects frames of env 0 of an `Envs` and writes an .mp4 (ffmpeg) or .gif on close."""

    def __init__(self, path: str, envs, fps: int, size=(480, 640), task=None):
        """`task`, if given, may shape the view: `video_camera` (a dict of distance, elevation,
        azimuth, and lookat for a fixed camera instead of following actor 0) and
        `video_markers()` (shapes drawn but not simulated, such as a goal: a list of dicts
        with type "box", size (half extents), pos, quat (x, y, z, w) and rgba)."""
        import mujoco

        ext = os.path.splitext(path)[1].lower()
        if ext not in (".mp4", ".gif"):
            raise ValueError(f"video={path}: the file must end in .mp4 or .gif")
        self.path, self.envs, self.fps = path, envs, fps
        self.mj_model = envs.model.mj_model
        self.data = mujoco.MjData(self.mj_model)
        self.mj_model.vis.global_.offwidth = max(self.mj_model.vis.global_.offwidth, size[1])
        self.mj_model.vis.global_.offheight = max(self.mj_model.vis.global_.offheight, size[0])
        # the near clipping plane is a share of the model's extent, which a 500 m ground makes
        # 100 m: 1 m, which cut away a hand seen from 0.9 m. At most 1 cm instead
        extent = max(float(self.mj_model.stat.extent), 1e-9)
        self.mj_model.vis.map.znear = min(float(self.mj_model.vis.map.znear), 0.01 / extent)
        before_offscreen_gl()
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
        view = getattr(task, "video_camera", None)
        if view:
            self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
            self.camera.lookat[:] = view["lookat"]
            self.camera.distance = view["distance"]
            self.camera.elevation, self.camera.azimuth = view["elevation"], view["azimuth"]
        self.markers = getattr(task, "video_markers", None)
        self.frames = []

    def add_frame(self) -> None:
        import mujoco

        q = self.envs.sim.q[0].detach().cpu().numpy().astype(np.float64)
        self.data.qpos[:] = self.envs.model.qpos_to_mujoco(q)
        mujoco.mj_kinematics(self.mj_model, self.data)
        mujoco.mj_comPos(self.mj_model, self.data)    # subtree centers: the camera follows them
        self.renderer.update_scene(self.data, camera=self.camera)
        for marker in (self.markers() if self.markers else []):
            self._draw(marker)
        self.frames.append(self.renderer.render().copy())

    def _draw(self, marker: dict) -> None:
        import mujoco

        scene = self.renderer.scene
        if scene.ngeom >= scene.maxgeom:
            return
        x, y, z, w = marker["quat"]
        mat = np.zeros(9)
        mujoco.mju_quat2Mat(mat, np.array([w, x, y, z], dtype=np.float64))
        kind = {"box": mujoco.mjtGeom.mjGEOM_BOX}[marker["type"]]
        mujoco.mjv_initGeom(scene.geoms[scene.ngeom], kind, np.asarray(marker["size"], float),
                            np.asarray(marker["pos"], float), mat,
                            np.asarray(marker["rgba"], np.float32))
        scene.ngeom += 1

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
