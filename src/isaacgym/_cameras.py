"""Isaac Gym's camera sensors on Myriad: each env's cameras drawn by MuJoCo's offscreen
renderer from the simulated state (`gym.create_camera_sensor`, `render_all_camera_sensors`,
`get_camera_image`, `get_camera_image_gpu_tensor`, ...; docs/isaacgym.md).

Conventions, as Isaac Gym's: a camera's pose is in its env's frame and it looks along its +x
axis with +z up; colour images are RGBA uint8 ([height, width * 4] from `get_camera_image`,
[height, width, 4] as a tensor), depth images float32 [height, width], the negative distance
along the view axis (-inf where nothing is hit), segmentation images int32 [height, width],
each pixel the segmentation id of the actor (or of the body, `set_rigid_body_segmentation_id`)
it shows, 0 for the ground and the background. The view matrix maps a row vector [x, y, z, 1]
of the env's frame to OpenGL camera coordinates (looking along -z, y up), the projection
matrix is OpenGL's perspective one, both transposed for row vectors.

What is drawn, as Isaac Gym draws it: a body's visual geoms (those that collide with nothing),
or its collision shapes where it has no visual geom (a primitive asset); with the camera's
`use_collision_geometry`, the collision shapes instead (`drawing_groups`). Each env is drawn in
its own looks (`Looks`): the colors `set_rigid_body_color` and the
textures `set_rigid_body_texture` gave its bodies, and its segmentation ids. Textures need them
in MuJoCo's model: once a texture exists, the sim's scene is compiled again for drawing only,
with a 2D texture and a material per Isaac Gym texture (the physics' model is not touched).

Rendering is per camera on the host (one MuJoCo scene per env state); it costs what the
pixels cost and never runs inside a step.
"""

from __future__ import annotations

import copy
import math
import os
from typing import NamedTuple

import numpy as np
import torch

from .gymapi import _quat_matrix as _rotation     # 3x3 rotation of a quaternion (x, y, z, w)

IMAGE_COLOR, IMAGE_DEPTH, IMAGE_SEGMENTATION = 0, 1, 2
FOLLOW_POSITION, FOLLOW_TRANSFORM = 0, 1


def look_rotation(position, target, up, call: str) -> np.ndarray:
    """3x3 rotation whose columns are a camera's axes looking from `position` at `target`:
    x ahead, y to the left, z up (as near `up` as looking ahead allows)."""
    forward = np.asarray(target, float) - np.asarray(position, float)
    if np.linalg.norm(forward) < 1e-9:
        raise ValueError(f"{call}: the target is the camera's own position")
    forward /= np.linalg.norm(forward)
    side = np.cross(np.asarray(up, float), forward)
    if np.linalg.norm(side) < 1e-9:                 # looking straight along up
        side = np.cross([1.0, 0.0, 0.0], forward)
    side /= np.linalg.norm(side)
    return np.stack([forward, side, np.cross(forward, side)], axis=1)


def vertical_fov(props) -> float:
    """Degrees, from CameraProperties' horizontal field of view and aspect ratio."""
    h = math.radians(float(props.horizontal_fov))
    return math.degrees(2 * math.atan(math.tan(h / 2) * props.height / props.width))


# the drawing model's geom groups (`drawing_groups`): drawn always, a body's visual geoms, its
# collision shapes where it has visual geoms (hidden as MuJoCo's viewer hides group 3), never
ALWAYS, VISUAL, COLLISION, NEVER = 0, 1, 3, 5


def visual_geoms(m) -> np.ndarray:
    """[ngeom] bool: the geoms drawn as visual geometry, those that collide with nothing in
    the groups MuJoCo draws (0-2)."""
    return (np.asarray(m.geom_contype) == 0) & (np.asarray(m.geom_conaffinity) == 0) & \
        (np.asarray(m.geom_group) < 3)


def drawing_groups(m) -> None:
    """Regroup the geoms of `m` (a drawing model, in place): ALWAYS the world's drawn geoms and
    the collision shapes of bodies with no visual geom, VISUAL the visual geoms (collide with
    nothing) of the groups MuJoCo draws (0-2), COLLISION the collision shapes of bodies that
    have such visual geoms, NEVER the rest. The page and `write_viewer_image_to_file` draw
    ALWAYS and VISUAL (MuJoCo's groups 0-2); a camera with use_collision_geometry draws
    ALWAYS and COLLISION."""
    body, visual = np.asarray(m.geom_bodyid), visual_geoms(m)
    drawn_only = (np.asarray(m.geom_contype) == 0) & (np.asarray(m.geom_conaffinity) == 0)
    has_visual = np.zeros(m.nbody, bool)
    has_visual[body[visual]] = True
    out = np.full(m.ngeom, NEVER, np.asarray(m.geom_group).dtype)
    world = body == 0
    out[world & (np.asarray(m.geom_group) < 3)] = ALWAYS
    out[~world & visual] = VISUAL
    colliding = ~world & ~drawn_only
    out[colliding & has_visual[body]] = COLLISION
    out[colliding & ~has_visual[body]] = ALWAYS
    m.geom_group[:] = out


def drawing_option(collision: bool = False):
    """The MjvOption drawing what `drawing_groups` says is seen."""
    import mujoco
    option = mujoco.MjvOption()
    option.geomgroup[:] = 0
    option.geomgroup[ALWAYS] = 1
    option.geomgroup[COLLISION if collision else VISUAL] = 1
    return option


class Looks(NamedTuple):
    """How each env's geoms are drawn, from the Isaac Gym calls that set it."""
    rgba: np.ndarray      # [envs, ngeom, 4] float32: color (white under a texture not tinted)
    texture: np.ndarray   # [envs, ngeom] int32: texture handle on the geom, -1 for none
    dressed: np.ndarray   # [envs, ngeom] bool: a color or texture set (else the model's look)
    segment: np.ndarray   # [envs, ngeom + 1] int32: segmentation id (the last: background, 0)


def looks(sim) -> Looks:
    """The envs' looks, kept in `sim.looks`: made for every env when there are none, and
    afterwards only for the envs in `sim.restyled` (those whose color, texture or segmentation
    id changed since), into a new `Looks` so that whoever holds the old one sees the change.
    A body's "visual" geoms are its `visual_geoms`, or all its geoms when it has none (a
    primitive asset draws its collision shape); its "collision" geoms are those that collide.
    Textures go on first, so that a color set on the same geoms tints them."""
    if sim.looks is not None and not sim.restyled:
        return sim.looks
    m = sim.myriad.model.mj_model
    if sim.looks is None:
        n_envs = len(sim.envs)
        sim.looks = Looks(np.tile(np.asarray(m.geom_rgba, np.float32), (n_envs, 1, 1)),
                          np.full((n_envs, m.ngeom), -1, np.int32),
                          np.zeros((n_envs, m.ngeom), bool),
                          np.zeros((n_envs, m.ngeom + 1), np.int32))
        envs = sim.envs
    else:
        sim.looks = Looks(*(a.copy() for a in sim.looks))
        envs = [sim.envs[e] for e in sorted(sim.restyled)]
    sim.restyled = set()
    rgba, texture, dressed, segment = sim.looks
    actors = _actor_geoms(sim)
    for env in envs:
        e = env.index
        rgba[e], texture[e], dressed[e], segment[e] = m.geom_rgba, -1, False, 0
        for (every, kinds), actor in zip(actors, env.actors):
            segment[e, every] = actor.segmentation_id
            for b, sid in actor.body_segmentation.items():
                segment[e, kinds[b]["all"]] = sid
            for (b, kind), handle in sorted(actor.body_textures.items(),
                                            key=lambda item: item[0][1] == "visual"):
                geoms = kinds[b][kind]
                texture[e, geoms] = handle
                rgba[e, geoms, :3] = 1.0
                dressed[e, geoms] = True
            for (b, kind), color in sorted(actor.body_colors.items(),
                                           key=lambda item: item[0][1] == "visual"):
                rgba[e, kinds[b][kind], :3] = (color.x, color.y, color.z)
                dressed[e, kinds[b][kind]] = True
    return sim.looks


def _actor_geoms(sim) -> list:
    """Per actor slot: (its geoms, per body {"visual": geoms, "collision": geoms, "all":
    geoms}) in the built model."""
    built = sim.myriad
    m = built.model.mj_model
    geom_body = np.asarray(built.model.geom_body)      # Myriad's bodies: MuJoCo's id - 1
    visual = visual_geoms(m)
    colliding = (np.asarray(m.geom_contype) != 0) | (np.asarray(m.geom_conaffinity) != 0)
    out = []
    for k in range(len(sim.envs[0].actors)):
        kinds = []
        for b in built.actor_bodies(f"a{k}"):
            mine = np.flatnonzero(geom_body == b)
            kinds.append({"visual": mine[visual[mine]] if visual[mine].any() else mine,
                          "collision": mine[colliding[mine]], "all": mine})
        out.append((np.concatenate([kind["all"] for kind in kinds]), kinds))
    return out


def dress(scene, first: int, looks_: Looks, e: int, materials: dict) -> None:
    """The scene's geoms from `first` on (env e's bodies, as mjv_updateScene or
    mjv_addGeoms put them there) in env e's colors and textures; the others as MuJoCo drew
    them."""
    import mujoco
    rgba, texture, dressed = looks_.rgba[e], looks_.texture[e], looks_.dressed[e]
    if not dressed.any():
        return
    geom_type = int(mujoco.mjtObj.mjOBJ_GEOM)
    for i in range(first, scene.ngeom):
        g = scene.geoms[i]
        if g.objtype != geom_type or g.objid < 0 or not dressed[g.objid]:
            continue
        g.rgba[:] = rgba[g.objid]
        material = materials.get(int(texture[g.objid]))
        if material is not None:             # the renderer takes a geom's texture from it
            g.matid = material


class Camera:
    """One camera sensor of one env: its properties, its pose or the body it rides on, its
    last images."""

    def __init__(self, env, handle: int, props):
        self.env, self.handle, self.props = env, handle, props
        self.position = np.array([1.0, 0.0, 1.0])
        self.rotation = np.eye(3)               # columns: its x (view), y, z (up) axes
        self.body = None                        # (env body handle, offset pose, follow mode)
        self.images: dict[int, np.ndarray] = {}
        self.tensors: dict[int, torch.Tensor] = {}

    def look(self, position, target, up) -> None:
        self.position = np.asarray(position, float)
        self.rotation = look_rotation(position, target, up, "set_camera_location")

    def pose(self, body_states: torch.Tensor):
        """(position, rotation) in the env's frame now (following its body if attached)."""
        if self.body is None:
            return self.position, self.rotation
        handle, offset, mode = self.body
        state = body_states[self.env.index, handle].detach().cpu().double().numpy()
        r_body = _rotation(state[3:7])
        r_off = _rotation([offset.r.x, offset.r.y, offset.r.z, offset.r.w])
        p_off = np.array([offset.p.x, offset.p.y, offset.p.z])
        if int(mode) == FOLLOW_TRANSFORM:
            return state[:3] + r_body @ p_off, r_body @ r_off
        return state[:3] + p_off, r_off

    def vertical_fov(self) -> float:
        return vertical_fov(self.props)

    def matrices(self, body_states) -> tuple[np.ndarray, np.ndarray]:
        """(view, projection), 4x4, for row vectors (see the module's docstring)."""
        position, rotation = self.pose(body_states)
        # OpenGL camera axes in the env's frame: x right, y up, z backwards
        gl = np.stack([-rotation[:, 1], rotation[:, 2], -rotation[:, 0]], axis=1)
        view = np.eye(4)
        view[:3, :3] = gl.T
        view[:3, 3] = -gl.T @ position
        near, far = float(self.props.near_plane), float(self.props.far_plane)
        f = 1.0 / math.tan(math.radians(self.vertical_fov()) / 2)
        aspect = self.props.width / self.props.height
        proj = np.zeros((4, 4))
        proj[0, 0], proj[1, 1] = f / aspect, f
        proj[2, 2], proj[2, 3] = (far + near) / (near - far), 2 * far * near / (near - far)
        proj[3, 2] = -1.0
        return view.T.astype(np.float32), proj.T.astype(np.float32)


class Cameras:
    """A sim's camera sensors and the renderers that draw them."""

    def __init__(self, sim):
        self.sim = sim
        self.cameras: list[Camera] = []
        self._made: dict[int, int] = {}        # env index -> cameras made in it
        self._renderers: dict[tuple[int, int], object] = {}
        self._data = None
        self._model = None                     # the MuJoCo model drawn (`model`)
        self._textures = None                  # the texture handles it was compiled with
        self._materials: dict[int, int] = {}   # texture handle -> its material's id in it

    def create(self, env, props) -> Camera:
        if not (int(props.width) >= 1 and int(props.height) >= 1
                and 0 < float(props.horizontal_fov) < 180
                and 0 < float(props.near_plane) < float(props.far_plane)):
            raise ValueError(f"create_camera_sensor: width {props.width}, height "
                             f"{props.height} must be >= 1, horizontal_fov "
                             f"{props.horizontal_fov} in (0, 180) degrees and 0 < near_plane "
                             f"{props.near_plane} < far_plane {props.far_plane}")
        # the env's next handle (a destroyed camera's handle is not given again)
        handle = self._made.get(env.index, 0)
        self._made[env.index] = handle + 1
        camera = Camera(env, handle, props)
        self.cameras.append(camera)
        return camera

    def find(self, env, handle: int) -> Camera:
        for c in self.cameras:
            if c.env is env and c.handle == int(handle):
                return c
        raise ValueError(f"camera handle {handle} is not a camera sensor of env {env.index}")

    # ------------------------------------------------------------------ rendering
    def model(self):
        """The MuJoCo model drawn (`drawing_groups`): a copy of the sim's, or with textures
        the sim's scene compiled again with a 2D texture and a material per texture handle
        (`_materials`). A new set of textures makes a new model, and new renderers for it."""
        import mujoco
        sim = self.sim
        handles = tuple(sorted(sim.textures))
        if self._model is not None and handles == self._textures:
            return self._model
        for renderer in self._renderers.values():
            renderer.close()
        self._renderers, self._data, self._materials = {}, None, {}
        if not handles:
            self._model = copy.deepcopy(sim.myriad.model.mj_model)
        else:
            spec, _ = sim.scene.compose()
            for h in handles:
                pixels = sim.textures[h]
                height, width = pixels.shape[:2]
                spec.add_texture(name=f"isaacgym_texture{h}",
                                 type=mujoco.mjtTexture.mjTEXTURE_2D, width=width,
                                 height=height, nchannel=4).data = pixels.tobytes()
                roles = [""] * int(mujoco.mjtTextureRole.mjNTEXROLE)
                roles[int(mujoco.mjtTextureRole.mjTEXROLE_RGB)] = f"isaacgym_texture{h}"
                spec.add_material(name=f"isaacgym_material{h}", textures=roles)
            self._model = spec.compile()
            if self._model.ngeom != sim.myriad.model.mj_model.ngeom:
                raise RuntimeError("camera sensors: the scene compiled with its textures has "
                                   f"{self._model.ngeom} geoms, the sim's model "
                                   f"{sim.myriad.model.mj_model.ngeom}")
            self._materials = {h: self._model.material(f"isaacgym_material{h}").id
                               for h in handles}
        drawing_groups(self._model)
        self._textures = handles
        return self._model

    def _renderer(self, mj, width: int, height: int):
        import mujoco
        key = (width, height)
        if key not in self._renderers:
            from myriad.rl.video import before_offscreen_gl
            before_offscreen_gl()
            mj.vis.global_.offwidth = max(mj.vis.global_.offwidth, width)
            mj.vis.global_.offheight = max(mj.vis.global_.offheight, height)
            try:
                self._renderers[key] = mujoco.Renderer(mj, height=height, width=width)
            except Exception as err:
                raise RuntimeError(
                    f"camera sensors: MuJoCo could not open an offscreen OpenGL context "
                    f"(MUJOCO_GL={os.environ.get('MUJOCO_GL', 'unset')}): {err}. On a headless "
                    "Linux machine install Mesa's EGL (apt install libegl1) or OSMesa (apt "
                    "install libosmesa6) and set MUJOCO_GL=egl or MUJOCO_GL=osmesa") from err
        return self._renderers[key]

    def _pose(self, e: int) -> None:
        """The MjData drawn from at env e's simulated state."""
        import mujoco
        built, mj = self.sim.myriad, self.model()
        if self._data is None:
            self._data = mujoco.MjData(mj)
        q = built.sim.q[e].detach().cpu().numpy().astype(np.float64)
        self._data.qpos[:] = built.model.qpos_to_mujoco(q)
        mujoco.mj_kinematics(mj, self._data)

    def render_all(self) -> None:
        built = self.sim.myriad
        mj = self.model()
        extent = max(float(mj.stat.extent), 1e-9)
        bodies = built.rigid_body_states
        by_env: dict[int, list[Camera]] = {}
        for c in self.cameras:
            by_env.setdefault(c.env.index, []).append(c)
        for e, cameras in by_env.items():
            self._pose(e)
            for c in cameras:
                self._render(c, mj, extent, bodies, e)

    def render_view(self, position, forward, up, size: tuple[int, int], fovy: float,
                    near: float, far: float, envs: list[int], origins) -> np.ndarray:
        """RGB [height, width, 3] of `envs` drawn at their `origins` (the viewer's grid) around
        the shared ground, seen from `position` along `forward` (world)."""
        import mujoco

        mj = self.model()
        looks_ = looks(self.sim)
        width, height = size
        renderer = self._renderer(mj, width, height)
        extent = max(float(mj.stat.extent), 1e-9)
        mj.vis.global_.fovy = fovy
        mj.vis.map.znear, mj.vis.map.zfar = near / extent, far / extent
        scene, option, perturb = renderer.scene, drawing_option(), mujoco.MjvPerturb()
        for k, (e, origin) in enumerate(zip(envs, origins)):
            self._pose(e)
            before = 0 if k == 0 else scene.ngeom
            if k == 0:       # the ground and the first env's bodies
                renderer.update_scene(self._data, scene_option=option)
            else:            # the next env's bodies only
                mujoco.mjv_addGeoms(mj, self._data, option, perturb,
                                    int(mujoco.mjtCatBit.mjCAT_DYNAMIC), scene)
            for g in range(before, scene.ngeom):
                if scene.geoms[g].category == int(mujoco.mjtCatBit.mjCAT_DYNAMIC):
                    scene.geoms[g].pos[:] += np.asarray(origin, np.float64)
            dress(scene, before, looks_, e, self._materials)
        for gl in scene.camera:
            gl.pos[:], gl.forward[:], gl.up[:] = position, forward, up
        return renderer.render().copy()

    def _render(self, camera: Camera, mj, extent: float, bodies, e: int) -> None:
        import mujoco

        props = camera.props
        width, height = int(props.width), int(props.height)
        renderer = self._renderer(mj, width, height)
        mj.vis.global_.fovy = camera.vertical_fov()
        mj.vis.map.znear = float(props.near_plane) / extent
        mj.vis.map.zfar = float(props.far_plane) / extent
        position, rotation = camera.pose(bodies)
        looks_ = looks(self.sim)
        option = drawing_option(bool(props.use_collision_geometry))
        images = {}
        for kind in (IMAGE_COLOR, IMAGE_DEPTH, IMAGE_SEGMENTATION):
            if kind == IMAGE_DEPTH:
                renderer.enable_depth_rendering()
            elif kind == IMAGE_SEGMENTATION:
                renderer.enable_segmentation_rendering()
            renderer.update_scene(self._data, scene_option=option)
            if kind == IMAGE_COLOR:
                dress(renderer.scene, 0, looks_, e, self._materials)
            for gl in renderer.scene.camera:
                gl.pos[:] = position
                gl.forward[:] = rotation[:, 0]
                gl.up[:] = rotation[:, 2]
            pixels = renderer.render()
            renderer.disable_depth_rendering()
            renderer.disable_segmentation_rendering()
            if kind == IMAGE_COLOR:
                rgba = np.empty((height, width, 4), np.uint8)
                rgba[..., :3], rgba[..., 3] = pixels, 255
                images[kind] = rgba
            elif kind == IMAGE_DEPTH:
                depth = -np.asarray(pixels, np.float32)
                depth[depth <= -0.999 * float(props.far_plane)] = -np.inf
                images[kind] = depth
            else:
                objid, objtype = pixels[..., 0], pixels[..., 1]
                geom = np.where(objtype == int(mujoco.mjtObj.mjOBJ_GEOM), objid, -1)
                images[kind] = looks_.segment[e][geom]
        camera.images = images
        for kind, tensor in camera.tensors.items():
            tensor.copy_(torch.from_numpy(images[kind]))
