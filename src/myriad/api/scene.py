"""`Scene`: what one env holds (a ground and a list of actors), replicated `num_envs` times.

An actor is one asset (an MJCF or URDF file whose world body has one child: an articulation or a
single rigid body) placed at a start pose, with Isaac Gym's per-actor options: a fixed or free
base, self-collisions on or off, and a drive mode for its hinge and slide joints (its DOFs).
`Scene.build` composes all actors into one MuJoCo spec (element names become "actor/name"),
compiles it, reads it into a `myriad.Model` and returns the batched `Envs`.

Only bodies are taken from an asset file: geoms, sites and lights attached directly to its world
body (a floor, say) are left out, as Isaac Gym does; `add_ground` gives the env a floor.
"""

from __future__ import annotations

import dataclasses
import os

import mujoco
import numpy as np

from ..physics import Model, ModelError, SimParams, from_mujoco

DOF_MODES = ("effort", "position", "velocity", "none")


@dataclasses.dataclass
class Actor:
    name: str
    path: object                # file path, or a mujoco.MjSpec
    pos: tuple
    quat: tuple | None          # x, y, z, w; None: the file's
    fix_base: bool
    self_collisions: bool
    dof_mode: str | tuple       # effort: set_dof_efforts; position / velocity: implicit PD
                                # drives; one for all DOFs, or one per DOF
    stiffness: float | list     # drive gains, one value or one per DOF of the actor
    damping: float | list
    gravity: bool = True        # False: Isaac Gym's disable_gravity (each body's gravcomp 1)


class Scene:
    """Builder of one env; every env of the `Envs` it builds holds the same actors."""

    def __init__(self):
        self.actors: list[Actor] = []
        self.ground: dict | None = None
        self.terrain: dict | None = None
        self.triangle_meshes: list[dict] = []

    def add_ground(self, friction: float = 1.0, restitution: float = 0.0) -> "Scene":
        """A static plane z = 0 that every actor collides with."""
        if not (friction >= 0 and 0 <= restitution <= 1):
            raise ValueError(f"add_ground: friction={friction} must be >= 0 and "
                             f"restitution={restitution} in [0, 1]")
        self.ground = {"friction": float(friction), "restitution": float(restitution)}
        return self

    def add_terrain(self, heights, horizontal_scale: float, origin=(0.0, 0.0),
                    friction: float = 1.0, riser: float = 0.0) -> "Scene":
        """A static height field that every actor collides with (rough terrain; in place of the
        ground or beside it): `heights` [nx, ny] (m), sample (i, j) at world
        (origin[0] + i·horizontal_scale, origin[1] + j·horizontal_scale). One copy is shared by
        all envs; it does not bounce (restitution 0). `riser` (m): a height step between
        neighbouring samples larger than this is a vertical wall on the higher sample's grid
        line (the original's slope threshold × grid spacing), not a steep ramp; 0 keeps
        MuJoCo's triangulated surface."""
        heights = np.asarray(heights, dtype=np.float64)
        if heights.ndim != 2 or min(heights.shape) < 2 or not np.isfinite(heights).all():
            raise ValueError(f"add_terrain: heights must be a finite [nx, ny] grid with nx, ny "
                             f">= 2, not shape {heights.shape}")
        if not (horizontal_scale > 0 and friction >= 0 and riser >= 0):
            raise ValueError(f"add_terrain: horizontal_scale={horizontal_scale} must be > 0, "
                             f"friction={friction} >= 0 and riser={riser} >= 0")
        self.terrain = {"heights": heights, "horizontal_scale": float(horizontal_scale),
                        "origin": tuple(float(o) for o in origin), "friction": float(friction),
                        "riser": float(riser)}
        return self

    def add_triangle_mesh(self, vertices, triangles, pos=(0.0, 0.0, 0.0), quat=(0, 0, 0, 1),
                          friction: float = 1.0) -> "Scene":
        """A static triangle mesh that every actor collides with, as its triangles (a bin, a
        table, a room, terrain that is not a grid; `stages.collision.trimesh`): `vertices`
        [V, 3] (m), `triangles` [T, 3] vertex indices, counterclockwise seen from the side
        bodies are on; placed at `pos`, `quat` (x, y, z, w). One copy is shared by all envs;
        it does not bounce."""
        v = np.asarray(vertices, dtype=np.float64)
        t = np.asarray(triangles)
        if v.ndim != 2 or v.shape[1] != 3 or len(v) < 3 or not np.isfinite(v).all():
            raise ValueError(f"add_triangle_mesh: vertices must be a finite [V, 3] array with "
                             f"V >= 3, not shape {v.shape}")
        if t.ndim != 2 or t.shape[1] != 3 or len(t) == 0 or not np.issubdtype(t.dtype, np.integer):
            raise ValueError(f"add_triangle_mesh: triangles must be a non-empty [T, 3] integer "
                             f"array, not {t.dtype} of shape {t.shape}")
        if t.min() < 0 or t.max() >= len(v):
            raise ValueError(f"add_triangle_mesh: triangle vertex indices must lie in "
                             f"[0, {len(v)}); they span [{t.min()}, {t.max()}]")
        area = np.linalg.norm(np.cross(v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]), axis=1)
        if not (area > 0).any():
            raise ValueError("add_triangle_mesh: every triangle has zero area")
        if np.shape(pos) != (3,) or np.shape(quat) != (4,) or not friction >= 0:
            raise ValueError(f"add_triangle_mesh: pos must be 3 numbers, quat 4 (x, y, z, w) and "
                             f"friction={friction} >= 0")
        self.triangle_meshes.append({"vertices": v, "triangles": t[area > 0].astype(np.int32),
                                     "pos": tuple(float(p) for p in pos),
                                     "quat": tuple(float(q) for q in quat),
                                     "friction": float(friction)})
        return self

    def add_actor(self, name: str, path: str | os.PathLike | mujoco.MjSpec, pos=None, quat=(0, 0, 0, 1),
                  fix_base: bool = False, self_collisions: bool = True, dof_mode: str = "effort",
                  stiffness=0.0, damping=0.0, gravity: bool = True) -> "Scene":
        """Add an actor from a model file, or from a `mujoco.MjSpec` built in code (it is copied).
        `pos=None` keeps the root body's position from the file, `quat=None` its orientation
        (quat is x, y, z, w).

        dof_mode: "effort" (forces from `Envs.set_dof_efforts`), "position" (implicit PD drive to
        `set_dof_position_targets` with `stiffness`, `damping`), "velocity" (drive to
        `set_dof_velocity_targets` with `damping`) or "none" (passive joints); or a list of
        them, one per DOF of the actor in file order (an arm in effort mode with a position-
        driven gripper). A DOF without a drive keeps the effort it is given, and the file's
        joint spring and damping; a driven DOF's only stiffness and damping are its drive's
        (Isaac Gym's one pair of gains per DOF).
        gravity=False: gravity does not act on the actor's bodies (Isaac Gym's disable_gravity;
        MuJoCo's gravcomp 1 on each of them).
        """
        if not name or "/" in name:
            raise ValueError(f"actor name {name!r}: must be non-empty and contain no '/'")
        if any(a.name == name for a in self.actors):
            raise ValueError(f"actor name {name!r} is used twice; actor names must be unique")
        modes = [dof_mode] if isinstance(dof_mode, str) else list(dof_mode)
        if not modes or any(mode not in DOF_MODES for mode in modes):
            raise ValueError(f"actor {name!r}: dof_mode={dof_mode!r}; valid: {DOF_MODES}, or a "
                             "list of them (one per DOF)")
        if not isinstance(dof_mode, str):
            dof_mode = tuple(modes)
        for mode, gain, what in (("position", stiffness, "stiffness"),
                                 ("velocity", damping, "damping")):
            gain = np.asarray(gain, float)
            if not isinstance(dof_mode, str) and gain.size > 1 and gain.shape != (len(modes),):
                raise ValueError(f"actor {name!r}: {what} must be one value or one per DOF "
                                 f"({len(modes)}, as dof_mode)")
            driven = gain if isinstance(dof_mode, str) or gain.size == 1 else \
                gain[np.array(modes) == mode]
            if mode in modes and np.any(driven <= 0):
                raise ValueError(f"actor {name!r}: a {mode} drive needs {what} > 0")
        if (quat is not None and np.shape(quat) != (4,)) or (pos is not None
                                                              and np.shape(pos) != (3,)):
            raise ValueError(f"actor {name!r}: pos must be 3 numbers and quat 4 (x, y, z, w)")
        if not isinstance(path, mujoco.MjSpec):
            path = os.fspath(path)
            if not os.path.isfile(path):
                raise ModelError(f"{path}: no such model file (actor {name!r})")
        self.actors.append(Actor(name, path, pos, quat if quat is None else tuple(quat),
                                 fix_base, self_collisions,
                                 dof_mode, stiffness, damping, bool(gravity)))
        return self

    # ------------------------------------------------------------------ composition
    def compose(self) -> tuple[mujoco.MjSpec, dict]:
        """One MuJoCo spec of the whole env, and per actor the names of its drive actuators."""
        if not self.actors:
            raise ValueError("the scene has no actors: call add_actor first")
        spec = mujoco.MjSpec()
        spec.modelname = "+".join(a.name for a in self.actors)
        spec.worldbody.add_light(pos=[0, 0, 6], dir=[0, 0, -1],
                                 type=mujoco.mjtLightType.mjLIGHT_DIRECTIONAL)
        spec.visual.headlight.ambient = [0.4, 0.4, 0.4]
        spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
                         builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT, rgb1=[0.6, 0.75, 0.9],
                         rgb2=[0.1, 0.15, 0.2], width=256, height=256)
        if self.ground is not None:
            # the plane is infinite for collisions; its size only bounds the drawn checkerboard
            spec.add_texture(name="checker", type=mujoco.mjtTexture.mjTEXTURE_2D,
                             builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, rgb1=[0.3, 0.33, 0.38],
                             rgb2=[0.22, 0.25, 0.3], width=256, height=256)
            spec.add_material(name="ground", textures=["", "checker"], texrepeat=[500, 500])
            spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE,
                                    size=[500, 500, 1], material="ground",
                                    friction=[self.ground["friction"], 0.005, 0.0001])
        if self.terrain is not None:
            self._add_terrain(spec, self.terrain)
        for i, mesh in enumerate(self.triangle_meshes):
            # drawn only in MuJoCo's model (contype = conaffinity = 0: no hull is built for it);
            # `build` makes it collide as its triangles. A shell's inertia: it may be open
            x, y, z, w = mesh["quat"]
            spec.add_mesh(name=f"triangle_mesh{i}", uservert=mesh["vertices"].ravel().tolist(),
                          userface=mesh["triangles"].ravel().tolist(),
                          inertia=mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL)
            spec.worldbody.add_geom(name=f"triangle_mesh{i}", type=mujoco.mjtGeom.mjGEOM_MESH,
                                    meshname=f"triangle_mesh{i}", pos=list(mesh["pos"]),
                                    quat=[w, x, y, z], contype=0, conaffinity=0,
                                    rgba=[0.55, 0.55, 0.6, 1.0],
                                    friction=[mesh["friction"], 0.005, 0.0001])
        drives = {}
        for actor in self.actors:
            drives[actor.name] = self._attach(spec, actor)
        return spec, drives

    @staticmethod
    def _add_terrain(spec: mujoco.MjSpec, terrain: dict) -> None:
        """MuJoCo's hfield: rows run along y and elevations are stored normalized to [0, 1],
        scaled by the top height and raised by the geom's z."""
        heights, step = terrain["heights"], terrain["horizontal_scale"]
        low, span = heights.min(), max(float(np.ptp(heights)), 1e-6)
        half = ((heights.shape[0] - 1) * step / 2, (heights.shape[1] - 1) * step / 2)
        spec.add_material(name="terrain", rgba=[0.42, 0.45, 0.5, 1.0], specular=0.1)
        spec.add_hfield(name="terrain", nrow=heights.shape[1], ncol=heights.shape[0],
                        size=[half[0], half[1], span, 1.0],
                        userdata=((heights.T - low) / span).ravel().tolist())
        spec.worldbody.add_geom(name="terrain", type=mujoco.mjtGeom.mjGEOM_HFIELD,
                                hfieldname="terrain", material="terrain",
                                pos=[terrain["origin"][0] + half[0],
                                     terrain["origin"][1] + half[1], low],
                                friction=[terrain["friction"], 0.005, 0.0001])

    def _attach(self, spec: mujoco.MjSpec, actor: Actor) -> list[str]:
        if isinstance(actor.path, mujoco.MjSpec):
            child = actor.path.copy()
        else:
            try:
                child = mujoco.MjSpec.from_file(actor.path)
            except Exception as err:
                raise ModelError(f"{actor.path}: MuJoCo rejected the model: {err}") from err
        taken = {b.name for b in child.bodies}
        for i, body in enumerate(child.bodies[1:]):   # attach prefixes only named elements,
            if not body.name:                         # and bodies are told apart by name
                name = f"body{i}"
                while name in taken:
                    name += "_"
                body.name = name
                taken.add(name)
        roots = child.worldbody.bodies
        if len(roots) != 1:
            raise ModelError(f"{actor.path}: an actor's file must have exactly one body under the "
                             f"world body (one articulation or rigid body); it has {len(roots)}")
        root = roots[0]
        free = [j for j in root.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
        if actor.fix_base:
            for j in free:
                child.delete(j)
        elif not root.joints:
            root.add_freejoint(name="root")
        child.option.timestep = spec.option.timestep   # options are the simulator's, not the file's
        child.option.gravity = spec.option.gravity
        pos = root.pos.copy() if actor.pos is None else np.asarray(actor.pos, float)
        if actor.quat is None:       # the file's orientation (any of its forms), as a quaternion
            quat = child.compile().body_quat[1].copy()
        else:
            x, y, z, w = actor.quat
            quat = [w, x, y, z]
        root.pos, root.quat = [0, 0, 0], [1, 0, 0, 0]
        root.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT    # not the file's euler etc.
        if not actor.self_collisions:
            # an explicit <contact><pair> collides whatever <exclude> says: the actor's go too
            # (deleted from the actor's own copy: deleting an attached one can fail in MuJoCo)
            for pair in list(child.pairs):
                child.delete(pair)
        frame = spec.worldbody.add_frame(pos=pos, quat=quat)
        prefix = actor.name + "/"
        frame.attach_body(root, prefix, "")

        bodies = [b for b in spec.bodies if b.name.startswith(prefix)]
        if not actor.gravity:
            for b in bodies:
                b.gravcomp = 1.0
        if not actor.self_collisions:
            for i, b1 in enumerate(bodies):
                for b2 in bodies[i + 1:]:
                    spec.add_exclude(bodyname1=b1.name, bodyname2=b2.name)
        joints = [j for b in bodies for j in b.joints
                  if j.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE)]
        modes = actor.dof_mode
        if isinstance(modes, str):
            modes = (modes,) * len(joints)
        elif len(modes) != len(joints):
            raise ValueError(f"actor {actor.name!r}: dof_mode lists {len(modes)} modes for its "
                             f"{len(joints)} DOFs")
        try:
            stiffness = np.broadcast_to(np.asarray(actor.stiffness, float), (len(joints),))
            damping = np.broadcast_to(np.asarray(actor.damping, float), (len(joints),))
        except ValueError:
            raise ValueError(f"actor {actor.name!r}: stiffness and damping must be one value or "
                             f"one per DOF ({len(joints)})") from None
        names = []
        for j, mode, kp, kv in zip(joints, modes, stiffness, damping):
            if mode not in ("position", "velocity"):
                continue
            # Isaac Gym keeps one stiffness and one damping per DOF, and a drive's gains are
            # that pair: the file's own spring and damper on a driven joint would act twice
            j.stiffness = [0.0, 0.0, 0.0]           # (MuJoCo 4: polynomials in q and q̇)
            j.damping = [0.0, 0.0, 0.0]
            act = spec.add_actuator(name=f"{j.name}/drive", target=j.name,
                                    trntype=mujoco.mjtTrn.mjTRN_JOINT)
            if mode == "position":
                act.set_to_position(kp=float(kp), kv=float(kv))
            else:
                act.set_to_velocity(kv=float(kv))
            names.append(act.name)
        return names

    def build(self, num_envs: int, device="cpu", params: SimParams | None = None,
              fix_model=None):
        """Compile the scene and allocate `num_envs` copies of it: returns `myriad.api.Envs`.
        `fix_model(model)`, if given, changes the `myriad.Model` in place before the envs are
        made: for what MJCF cannot say (PhysX tendon semantics, say)."""
        from .envs import Envs

        spec, drives = self.compose()
        try:
            mj_model = spec.compile()
        except Exception as err:
            raise ModelError(f"scene {spec.modelname!r}: MuJoCo rejected it: {err}") from err
        model: Model = from_mujoco(mj_model, source=f"scene {spec.modelname!r}")
        if self.terrain is not None and self.terrain["riser"] > 0:
            model.hfield_riser[:] = self.terrain["riser"]
        for i in range(len(self.triangle_meshes)):
            model.collide_as_triangles(f"triangle_mesh{i}")
        if fix_model is not None:
            fix_model(model)
        return Envs(model, self.actors, drives, self.ground, num_envs, device, params)
