"""A page in the browser that draws envs live, built on viser (the library mjlab's viewer uses).

    viewer = myriad.viewer.serve(envs)            # prints the URL; returns at once
    ...                                            # step the envs as usual
    viewer.close()

The page shows a few envs side by side (their bodies drawn from the model's own geoms and
colours; planes as a grid, height fields as their triangles), a field to choose which envs, a
camera that can follow a body, and toggles for contact points with their forces and for joint
frames. A background thread draws at the page's frame rate while a page is connected: it copies
the shown envs' joint positions (and contacts, when shown) once per frame and places the bodies
with MuJoCo's kinematics on the host. With no page connected it does nothing at all, and it
never touches the step itself (no per-step host read comes back with it).

The small interface other front ends drive (the Isaac Gym layer's viewer calls map onto it):
`draw()`, `look_at(target, eye)`, `add_button(label, event, key)`, `add_key(key, label, event)`,
`listen_clicks()`, `events()` (button clicks, key presses and clicks in the scene since the last
call), `set_geom_colors(rgb, chosen)`, `closed`, `close()`; for `myriad
play`, `paused`, `take("step" | "reset")`, `speed` (each control also on a key: `PLAY_KEYS`); for
training, `show_progress(text)`.
"""

from __future__ import annotations

import queue
import threading
import time

import mujoco
import numpy as np
import torch

from .shapes import shapes

INSTALL = 'pip install "myriad[viewer]"   (or: pip install viser)'
# the keys a page can bind (viser's hotkeys)
KEYS = tuple(chr(c) for c in range(ord("A"), ord("Z") + 1)) + tuple("0123456789") + (
    "space", "enter", "escape", "tab", "backspace", "delete", "insert", "home", "end", "pageup",
    "pagedown", "arrowup", "arrowdown", "arrowleft", "arrowright")
# play's keys: MuJoCo simulate's for pause, step and reset; the speed on the arrows
PLAY_KEYS = {"pause": "space", "step": "arrowright", "reset": "backspace",
             "slower": "arrowdown", "faster": "arrowup"}
# the share of one core the drawing may take while training runs (`Viewer(budget=...)`): drawing
# holds Python's lock, which the training thread then waits for; at 20 frames/s a page cost
# Ant's training 8.4 % (`benchmarks/viewer_cost.py`, docs/performance.md)
TRAINING_BUDGET = 0.04


def require_viser():
    """The viser module, or an ImportError naming the install command."""
    try:
        import viser
    except ImportError as err:
        raise ImportError(f"viewer=web needs viser, which is not installed: {INSTALL}") from err
    return viser


def robot_width(m: mujoco.MjModel) -> float:
    """The horizontal size (m) of what the model holds besides the world body, at qpos0."""
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    moving = m.geom_bodyid > 0
    if not moving.any():
        return 1.0
    radius = m.geom_rbound[moving][:, None]
    lo = (d.geom_xpos[moving] - radius).min(axis=0)
    hi = (d.geom_xpos[moving] + radius).max(axis=0)
    return float(max(hi[:2] - lo[:2]))


def mat_to_wxyz(mats: np.ndarray) -> np.ndarray:
    """[n, 9] row-major rotation matrices to [n, 4] unit quaternions (w, x, y, z)."""
    out = np.empty((len(mats), 4))
    for i, mat in enumerate(mats):
        mujoco.mju_mat2Quat(out[i], mat)
    return out


class Viewer:
    """The page (module docstring). `envs`: a `myriad.api.Envs`; `shown`: how many envs are drawn
    side by side (from `first`); `spacing`: metres between them (0: drawn where they are, for
    tasks whose envs already stand apart, such as a shared terrain); `controls`: the play
    controls (pause, step, reset, speed); `markers`: a function returning the task's markers
    for an env (`VecTask.video_markers`-style dicts: type "box", size, pos, quat xyzw, rgba);
    `origins`: [num_envs, 3], where each env is drawn instead (Isaac Gym's grid of envs);
    `drawing`: a MuJoCo model of the same bodies and geoms to draw from instead of the envs'
    own (its geom groups and colours say what is drawn and how)."""

    def __init__(self, envs, port: int = 8080, host: str = "127.0.0.1", shown: int = 4,
                 first: int = 0, spacing: float | None = None, controls: bool = False,
                 markers=None, fps: float = 20.0, budget: float | None = None, origins=None,
                 drawing=None):
        viser = require_viser()
        n = envs.num_envs
        if not 1 <= shown:
            raise ValueError(f"viewer: shown={shown}: must be >= 1")
        if not 0 <= first < n:
            raise ValueError(f"viewer: first={first}: the envs are 0..{n - 1}")
        if not fps > 0:
            raise ValueError(f"viewer: fps={fps}: must be > 0")
        if budget is not None and not 0 < budget <= 1:
            raise ValueError(f"viewer: budget={budget}: a share of one core, in (0, 1]")
        self.budget = budget
        own = envs.model.mj_model
        if drawing is not None and (drawing.nbody, drawing.ngeom, drawing.nq) != \
                (own.nbody, own.ngeom, own.nq):
            raise ValueError(f"viewer: the drawing model has {drawing.nbody} bodies, "
                             f"{drawing.ngeom} geoms and nq {drawing.nq}; the envs' "
                             f"{own.nbody}, {own.ngeom} and {own.nq}")
        self.envs, self.mj = envs, own if drawing is None else drawing
        self.count = min(shown, n)
        self.first = min(first, n - self.count)
        if spacing is None:          # envs over one shared terrain already stand apart
            spacing = 0.0 if self.mj.nhfield else robot_width(self.mj) + 0.5
        self.spacing, self.fps, self.markers = float(spacing), float(fps), markers
        if origins is not None:
            origins = np.asarray(origins, dtype=np.float64)
            if origins.shape != (n, 3):
                raise ValueError(f"viewer: origins of shape {origins.shape}: one (x, y, z) per "
                                 f"env, ({n}, 3)")
        self.origins = origins
        self.offsets = self._offsets()
        self._lines: dict = {}           # env -> [(points [K, 2, 3], colors [K, 3])], env frame
        self._lines_version = 0          # set_lines' calls
        self._lines_drawn = None         # the (version, first env) last sent, or None
        self._colors = None              # set_geom_colors' (rgb, chosen)
        self._colors_version = 0
        self._colors_drawn = None        # the (version, first env) last sent
        self.lines = None                # their segments on the page
        self._data = [mujoco.MjData(self.mj) for _ in range(self.count)]
        self._events: queue.SimpleQueue = queue.SimpleQueue()
        self._lock = threading.Lock()
        self._closed = threading.Event()
        self._connected = threading.Event()
        self.frames_drawn = 0            # frames the page was sent (a test reads it)
        self.paused, self.speed = False, 1.0
        self._asked: set[str] = set()    # the page's requests not yet taken (`take`)
        self._stream = None              # on a GPU, the stream of the viewer's copies
        self._camera = None              # (target, eye) of the last look_at
        self._clicks = False             # listen_clicks called
        # the last click in the scene: (x, y) on the canvas, 0..1 from its top left; the ray
        # under it (origin, unit direction; world)
        self.click_position, self.click_ray = None, None

        self.server = viser.ViserServer(host=host, port=port, verbose=False)
        self.url = f"http://{host}:{self.server.get_port()}"
        self.server.scene.set_up_direction("+z")
        self.server.on_client_connect(self._on_connect)
        self.server.on_client_disconnect(self._on_disconnect)
        self.controls = controls
        self._build_scene()
        self._build_gui(controls)
        self._thread = threading.Thread(target=self._pump, name="myriad-viewer", daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ the scene
    def _build_scene(self) -> None:
        """One batched mesh per moving geom (an instance per shown env: one message per geom
        and frame), world geoms drawn once where they are, planes as a grid."""
        scene, m = self.server.scene, self.mj
        drawn, planes = shapes(m)
        if planes:
            scene.add_grid("/ground", width=200.0, height=200.0, cell_size=1.0,
                           section_size=5.0, infinite_grid=True, plane_opacity=0.15,
                           plane_color=(210, 210, 200))
        d = mujoco.MjData(m)
        mujoco.mj_kinematics(m, d)
        identity = np.tile([1.0, 0.0, 0.0, 0.0], (self.count, 1))
        self.geoms, self.meshes, self._model_rgb = [], [], []
        for s in drawn:
            opacity = None if s.opacity >= 1 else s.opacity
            if s.body == 0:          # the world's geoms (terrain, walls): drawn once
                scene.add_mesh_simple(f"/world/{s.name}", s.vertices, s.faces, color=s.rgb,
                                      opacity=opacity, position=d.geom_xpos[s.geom],
                                      wxyz=mat_to_wxyz(d.geom_xmat[s.geom][None])[0])
                continue
            self.geoms.append(s.geom)
            self._model_rgb.append(s.rgb)
            self.meshes.append(scene.add_batched_meshes_simple(
                f"/bodies/{s.name}", s.vertices, s.faces, batched_wxyzs=identity,
                batched_positions=np.zeros((self.count, 3)), batched_colors=s.rgb,
                opacity=opacity, lod="off"))
        self.joint_axes = scene.add_batched_axes(
            "/joint_frames", batched_wxyzs=np.tile(identity[:1], (self.count * (m.nbody - 1), 1)),
            batched_positions=np.zeros((self.count * (m.nbody - 1), 3)), axes_length=0.1,
            axes_radius=0.005, visible=False)
        # body poses of the shown envs as last drawn: [shown, nbody, 7] (position, wxyz)
        self.body_poses = np.zeros((self.count, m.nbody, 7))
        self.contacts = [None] * self.count
        self._marker_handles: dict[str, object] = {}

    def _build_gui(self, controls: bool) -> None:
        gui, n = self.server.gui, self.envs.num_envs
        self.first_env = gui.add_number("first env shown", self.first, min=0,
                                        max=max(0, n - self.count), step=1)
        names = ["(none)"] + [mujoco.mj_id2name(self.mj, mujoco.mjtObj.mjOBJ_BODY, b)
                              or f"body{b}" for b in range(1, self.mj.nbody)]
        self.follow = gui.add_dropdown("camera follows", names,
                                       initial_value=names[min(1, len(names) - 1)])
        self.show_contacts = gui.add_checkbox("contact points and forces", False)
        # a hand's contacts carry a few newtons, a humanoid's feet several hundred: the
        # segments' scale is the user's to set (log10 of metres per newton)
        self.force_scale = gui.add_slider("contact force scale, log10 m/N", min=-5.0, max=-1.0,
                                          step=0.25, initial_value=-3.0)
        self.show_joints = gui.add_checkbox("joint frames", False)
        self.show_markers = gui.add_checkbox("markers", True)
        self.first_env.on_update(lambda _: self._event("first env", int(self.first_env.value)))
        self.show_joints.on_update(
            lambda _: setattr(self.joint_axes, "visible", bool(self.show_joints.value)))
        if controls:
            # each control also on a key, MuJoCo simulate's where it has one (`PLAY_KEYS`)
            self.pause = gui.add_checkbox(f"pause ({PLAY_KEYS['pause']})", False)
            self.pause.on_update(lambda _: setattr(self, "paused", bool(self.pause.value)))
            self.add_button("single step", "step", key=PLAY_KEYS["step"])
            self.add_button("reset shown envs", "reset", key=PLAY_KEYS["reset"])
            self.slow = gui.add_slider(f"speed ({PLAY_KEYS['slower']}, {PLAY_KEYS['faster']})",
                                       min=0.05, max=1.0, step=0.05, initial_value=1.0)
            self.slow.on_update(lambda _: setattr(self, "speed", float(self.slow.value)))
            self.add_key(PLAY_KEYS["pause"], "pause / go on", "pause")
            self.add_key(PLAY_KEYS["slower"], "slower", "slower")
            self.add_key(PLAY_KEYS["faster"], "faster", "faster")
        # last: its changing text never moves the controls under a pointer
        self.progress = gui.add_markdown("")

    # ------------------------------------------------------------------ events
    def _event(self, kind: str, value) -> None:
        self._events.put((kind, value))

    def _ask(self, what: str, kind: str = "button") -> None:
        with self._lock:
            self._asked.add(what)
        self._event(kind, what)

    def _key(self, what: str) -> None:
        """A key's press: the play keys act on the controls as the page's own would."""
        if self.controls and what == "pause":
            self.pause.value = not self.pause.value          # its on_update sets `paused`
        elif self.controls and what in ("slower", "faster"):
            step = -self.slow.step if what == "slower" else self.slow.step
            self.slow.value = round(min(self.slow.max, max(self.slow.min,
                                                          self.slow.value + step)), 2)
        self._ask(what, kind="key")

    def _on_connect(self, client) -> None:
        if self._camera is not None:                 # the last look_at, for a late page too
            target, eye = self._camera
            client.camera.look_at = target
            if eye is not None:
                client.camera.position = eye
        self._connected.set()
        self._event("connect", client.client_id)

    def add_button(self, label: str, event: str, key: str | None = None) -> None:
        """A button on the page; a click is the event ("button", `event`), also for `take`;
        with `key` (`add_key`) the key does the same as a click."""
        button = self.server.gui.add_button(label if key is None else f"{label} ({key})")
        button.on_click(lambda _: self._ask(event))
        if key is not None:
            self.add_key(key, label, event)

    def add_key(self, key: str, label: str, event: str) -> None:
        """A key of the page: a press (while the page, not one of its text fields, has the
        focus) is the event ("key", `event`), also for `take`. `key`: "A"-"Z", "0"-"9",
        "space", "enter", "escape", "tab", "backspace", "delete", "insert", "home", "end",
        "pageup", "pagedown", "arrowup", "arrowdown", "arrowleft", "arrowright" (`KEYS`). The
        page's command palette (Ctrl+K) lists the keys with their labels."""
        if key not in KEYS:
            raise ValueError(f"viewer: key {key!r}: the page's keys are {', '.join(KEYS)}")
        command = self.server.gui.add_command(label, hotkey=key, description=f"key: {key}")
        command.on_trigger(lambda _: self._key(event))

    def listen_clicks(self) -> None:
        """Clicks in the scene (the left button, no modifier key; a drag still turns the
        camera) become events ("click", (x, y)): where on the canvas, (0, 0) its top left and
        (1, 1) its bottom right. `click_position` and `click_ray` keep the last one."""
        if self._clicks:
            return
        self._clicks = True

        @self.server.scene.on_click()
        def _(event) -> None:
            self._click(event.screen_pos, event.ray_origin, event.ray_direction)

    def _click(self, position, origin, direction) -> None:
        self.click_position = (float(position[0]), float(position[1]))
        self.click_ray = (np.asarray(origin, dtype=np.float64),
                          np.asarray(direction, dtype=np.float64))
        self._event("click", self.click_position)

    def _on_disconnect(self, client) -> None:
        if not self.server.get_clients():
            self._connected.clear()
        self._event("disconnect", client.client_id)

    def events(self) -> list[tuple[str, object]]:
        """The page's events since the last call: ("button", event) of a click, ("key", event)
        of a key's press ("step", "reset", "pause", "slower", "faster" in play), ("click",
        (x, y)) of a click in the scene (`listen_clicks`), ("first env", k), ("connect" |
        "disconnect", client id)."""
        out = []
        while True:
            try:
                out.append(self._events.get_nowait())
            except queue.Empty:
                return out

    def take(self, what: str) -> bool:
        """Whether the page asked for `what` ("step": a single step of paused play; "reset":
        the shown envs reset) since the last take; each request is taken once."""
        with self._lock:
            asked = what in self._asked
            self._asked.discard(what)
        return asked

    @property
    def shown_envs(self) -> list[int]:
        return list(range(self.first, self.first + self.count))

    @property
    def closed(self) -> bool:
        return self._closed.is_set()

    @property
    def connected(self) -> bool:
        return self._connected.is_set()

    # ------------------------------------------------------------------ drawing
    def show_progress(self, text: str) -> None:
        """A line of progress on the page (training: epoch, env-steps/s, reward, metrics)."""
        self.progress.content = text
        self.server.flush()              # else the last line can wait for the next message

    def look_at(self, target, eye=None) -> None:
        """Every page's camera toward `target` (world, m), from `eye` if given (pages that
        connect later too)."""
        self._camera = (np.asarray(target, dtype=np.float64),
                        None if eye is None else np.asarray(eye, dtype=np.float64))
        for client in self.server.get_clients().values():
            client.camera.look_at = np.asarray(target, dtype=np.float64)
            if eye is not None:
                client.camera.position = np.asarray(eye, dtype=np.float64)

    def camera_pose(self):
        """(position, wxyz) of the first open page's camera (world; its frame as OpenCV's:
        looking along +z, y down), or None while no page is open."""
        for client in self.server.get_clients().values():
            return (np.asarray(client.camera.position, dtype=np.float64),
                    np.asarray(client.camera.wxyz, dtype=np.float64))
        return None

    def _offsets(self) -> np.ndarray:
        """[shown, 3]: where each shown env is drawn: at its origin, or beside the one before
        it along y."""
        if self.origins is not None:
            return self.origins[self.first:self.first + self.count].copy()
        return np.outer(np.arange(self.count), [0.0, self.spacing, 0.0])

    def set_lines(self, lines: dict) -> None:
        """Line segments to draw with the envs until the next call (or a change to `lines`
        followed by a call): {env: [(points [K, 2, 3] in that env's frame, colors [K, 3] in
        0..1), ...]}; those of envs not shown are not drawn."""
        self._lines = lines
        self._lines_version += 1

    def draw(self) -> None:
        """Place the shown envs' bodies at their current state (one copy of their joint
        positions to the host, MuJoCo's kinematics there)."""
        first = int(self.first_env.value)
        self.first = min(max(first, 0), self.envs.num_envs - self.count)
        self.offsets = self._offsets()
        rows = slice(self.first, self.first + self.count)
        sim = self.envs.sim
        show_contacts = bool(self.show_contacts.value)
        read = [sim.q[rows]] + ([sim.contact_count[rows], sim.contact_pos[rows],
                                 sim.contact_force[rows]] if show_contacts else [])
        read = self._to_host(read)
        qpos = self.envs.model.qpos_to_mujoco(read[0].astype(np.float64))
        if show_contacts:
            count, pos, force = read[1:]
        m, g = self.mj, self.geoms
        geom_pos = np.empty((self.count, len(g), 3))
        geom_wxyz = np.empty((self.count, len(g), 4))
        for k in range(self.count):
            d = self._data[k]
            d.qpos[:] = qpos[k]
            mujoco.mj_kinematics(m, d)
            geom_pos[k] = d.geom_xpos[g] + self.offsets[k]
            geom_wxyz[k] = mat_to_wxyz(d.geom_xmat[g])
            self.body_poses[k, :, :3] = d.xpos + self.offsets[k]
            self.body_poses[k, :, 3:] = d.xquat
        with self.server.atomic():
            for i, mesh in enumerate(self.meshes):
                mesh.batched_positions = geom_pos[:, i]
                mesh.batched_wxyzs = geom_wxyz[:, i]
            if self.joint_axes.visible:
                self.joint_axes.batched_positions = self.body_poses[:, 1:, :3].reshape(-1, 3)
                self.joint_axes.batched_wxyzs = self.body_poses[:, 1:, 3:].reshape(-1, 4)
            for k in range(self.count):
                if show_contacts:
                    self._draw_contacts(k, count[k], pos[k], force[k])
                elif self.contacts[k] is not None:
                    self.contacts[k].visible = False
            if self.markers is not None:
                self._draw_markers()
            self._draw_lines()
            self._draw_colors()
        self.frames_drawn += 1

    def set_geom_colors(self, rgb, chosen) -> None:
        """Each env's own geom colors from the next frame: `rgb` [num_envs, ngeom, 3] in
        0..1 where `chosen` [num_envs, ngeom] is true, the model's color elsewhere."""
        n = self.envs.num_envs
        rgb, chosen = np.asarray(rgb, dtype=np.float64), np.asarray(chosen, dtype=bool)
        if rgb.shape != (n, self.mj.ngeom, 3) or chosen.shape != (n, self.mj.ngeom):
            raise ValueError(f"viewer: geom colors of shape {rgb.shape} and {chosen.shape}: "
                             f"({n}, {self.mj.ngeom}, 3) and ({n}, {self.mj.ngeom})")
        with self._lock:
            self._colors = (rgb, chosen)
            self._colors_version += 1

    def _draw_colors(self) -> None:
        """The shown envs' geom colors (sent again only when they or the envs shown changed)."""
        with self._lock:
            colors, drawn = self._colors, (self._colors_version, self.first)
        if colors is None or self._colors_drawn == drawn:
            return
        self._colors_drawn = drawn
        rows = slice(self.first, self.first + self.count)
        rgb, chosen = colors[0][rows], colors[1][rows]
        for i, (mesh, g) in enumerate(zip(self.meshes, self.geoms)):
            mine = np.where(chosen[:, g, None], np.clip(rgb[:, g] * 255.0, 0, 255),
                            np.asarray(self._model_rgb[i], dtype=np.float64))
            mesh.batched_colors = np.round(mine).astype(np.uint8)

    def _draw_lines(self) -> None:
        """The lines of `set_lines` that belong to shown envs, at their envs' places (sent
        again only when the lines or the envs shown changed)."""
        drawn = (self._lines_version, self.first)
        if self._lines_drawn == drawn:
            return
        self._lines_drawn = drawn
        points, colors = [], []
        for k, env in enumerate(self.shown_envs):
            for p, c in list(self._lines.get(env, ())):
                points.append(p + self.offsets[k])
                colors.append(c)
        if self.lines is not None:
            self.lines.remove()
            self.lines = None
        if points:
            rgb = np.clip(np.concatenate(colors) * 255.0, 0, 255).astype(np.uint8)
            self.lines = self.server.scene.add_line_segments(
                "/lines", np.concatenate(points).astype(np.float32),
                colors=np.repeat(rgb[:, None], 2, axis=1), thickness=2.0,
                thickness_units="screen")

    def _to_host(self, tensors: list) -> list[np.ndarray]:
        """Copies of the shown envs' tensors on the host. On a GPU through a stream of the
        viewer's own: the training's stream never waits for them (a copy may catch a step
        half-done, which a drawing can bear)."""
        if tensors[0].device.type != "cuda":
            return [t.detach().numpy().copy() for t in tensors]
        if self._stream is None:
            self._stream = torch.cuda.Stream(tensors[0].device)
        with torch.cuda.stream(self._stream):
            host = [t.detach().to("cpu", non_blocking=True) for t in tensors]
        self._stream.synchronize()
        return [h.numpy() for h in host]

    def _draw_contacts(self, k, count, pos, force) -> None:
        """Contact points as segments along their force, 10^`force_scale` m per newton (the
        default: 1 cm per 10 N), at least 2 cm long."""
        used = min(int(count), len(force))
        if used == 0:
            if self.contacts[k] is not None:
                self.contacts[k].visible = False
            return
        start = pos[:used] + self.offsets[k]
        f = force[:used]
        length = np.linalg.norm(f, axis=-1, keepdims=True)
        direction = np.where(length > 1e-9, f / np.maximum(length, 1e-9), [0.0, 0.0, 1.0])
        metres_per_newton = 10.0 ** float(self.force_scale.value)
        end = start + direction * np.maximum(length * metres_per_newton, 0.02)
        points = np.stack([start, end], axis=1).astype(np.float32)
        if self.contacts[k] is not None:
            self.contacts[k].remove()
        self.contacts[k] = self.server.scene.add_line_segments(
            f"/contacts{k}", points, colors=(230, 40, 40), thickness=3.0,
            thickness_units="screen")

    def _draw_markers(self) -> None:
        visible = bool(self.show_markers.value)
        for k, env in enumerate(self.shown_envs):
            for i, marker in enumerate(self.markers(env) if visible else []):
                name = f"/markers{k}/{i}"
                x, y, z, w = marker["quat"]
                pos = np.asarray(marker["pos"], dtype=np.float64) + self.offsets[k]
                handle = self._marker_handles.get(name)
                if handle is None:
                    rgba = marker["rgba"]
                    handle = self._marker_handles[name] = self.server.scene.add_box(
                        name, color=tuple(int(255 * c) for c in rgba[:3]),
                        dimensions=tuple(2 * np.asarray(marker["size"], dtype=np.float64)),
                        opacity=float(rgba[3]) if rgba[3] < 1 else None)
                handle.position, handle.wxyz = pos, (w, x, y, z)
                handle.visible = True
        if not visible:
            for handle in self._marker_handles.values():
                handle.visible = False

    def _follow(self) -> None:
        name = self.follow.value
        if name == "(none)":
            return
        b = mujoco.mj_name2id(self.mj, mujoco.mjtObj.mjOBJ_BODY, name)
        if b >= 0:
            self.look_at(self.body_poses[0, b, :3])

    def _pump(self) -> None:
        """Draw at `fps` while a page is connected, or less often when a frame takes more than
        `budget` of the time between frames (its wall time: waiting for Python's lock counts,
        so a busy trainer slows the page, not the page the trainer); with none, wait (no work
        at all)."""
        while not self._closed.is_set():
            if not self._connected.wait(timeout=0.2):
                continue
            start = time.monotonic()
            try:
                self.draw()
                self._follow()
            except Exception as err:       # the sim went away or changed: say so on the page
                if self._closed.is_set():
                    return
                self.show_progress(f"**the viewer stopped drawing:** {type(err).__name__}: {err}")
                return
            took = time.monotonic() - start
            period = 1.0 / self.fps
            if self.budget is not None:
                period = max(period, took / self.budget)
            self._closed.wait(max(0.0, period - took))

    def close(self, message: str = "the run ended: this page no longer updates") -> None:
        """Stop drawing and serving; open pages keep the last picture and say `message`."""
        if self._closed.is_set():
            return
        self._closed.set()
        self._thread.join(timeout=2.0)
        self.show_progress(f"**{message}**")        # (flushed)
        time.sleep(0.2)                  # the message leaves before the server goes
        self.server.stop()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def serve(envs, port: int = 8080, host: str = "127.0.0.1", **kwargs) -> Viewer:
    """Serve a page drawing `envs` live (module docstring); prints the URL and returns the
    `Viewer` at once. Keyword arguments as `Viewer`'s."""
    viewer = Viewer(envs, port=port, host=host, **kwargs)
    print(f"viewer: {viewer.url}  (from another machine: ssh -L {viewer.server.get_port()}:"
          f"localhost:{viewer.server.get_port()} <this machine>, then open "
          f"http://localhost:{viewer.server.get_port()})", flush=True)
    return viewer
