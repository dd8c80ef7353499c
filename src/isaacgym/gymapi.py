"""`isaacgym.gymapi` on Myriad: the Gym object, its parameter structs, math types and enums.

The classic Isaac Gym flow runs unchanged:

    gym = gymapi.acquire_gym()
    sim = gym.create_sim(0, 0, gymapi.SIM_PHYSX, sim_params)
    gym.add_ground(sim, gymapi.PlaneParams())
    asset = gym.load_asset(sim, root, "urdf/cartpole.urdf", options)
    for i in range(num_envs):
        env = gym.create_env(sim, lower, upper, num_per_row)
        actor = gym.create_actor(env, asset, pose, "cartpole", i, 1, 0)
        gym.set_actor_dof_properties(env, actor, props)
    gym.prepare_sim(sim)                      # builds one Myriad Scene, num_envs copies
    dof_state = gymtorch.wrap_tensor(gym.acquire_dof_state_tensor(sim))
    gym.set_dof_actuation_force_tensor(sim, gymtorch.unwrap_tensor(efforts))
    gym.simulate(sim); gym.fetch_results(sim, True); gym.refresh_dof_state_tensor(sim)

Until `prepare_sim` the calls only record what each env holds; `prepare_sim` checks that every
env holds the same actors (same assets, same order), composes them into one `myriad.api.Scene`,
builds the batched `myriad.api.Envs` and writes each env's recorded properties (DOF drive gains,
limits, friction, masses...) into Myriad's per-env parameters. A call this module does not
provide raises `NotImplementedError` naming it; so does an option that would change the physics
and that Myriad does not honour yet. docs/isaacgym.md lists both.

Coordinates: each env has its own frame, the frame the actor poses of `create_actor` and the
tensor API's positions are given in (Isaac Gym's env-local frame); Myriad's envs never collide
with each other, so every env sits at the origin of its own world. `create_env`'s grid origins
are kept for `get_env_origin` only. Y-up sims work: gravity is the vector in `SimParams.gravity`
and the ground plane's normal is that of `PlaneParams.normal`; nothing assumes z is up.
"""

from __future__ import annotations

import copy
import enum
import functools
import math
import os
import time
import warnings

import mujoco
import numpy as np
import torch

from myriad.torch_utils import quat_rotate, quat_rotate_inverse

_FLT_MAX = float(np.finfo(np.float32).max)
_DOCS = "see docs/isaacgym.md in the Myriad repository"


class NotProvidedError(NotImplementedError, AttributeError):
    """A call or name of Isaac Gym that Myriad does not provide (yet). It is also an
    AttributeError, so that `hasattr` and `getattr(obj, name, default)` keep working."""


def _not_provided(what: str) -> NotProvidedError:
    return NotProvidedError(f"{what} is not provided by Myriad yet; {_DOCS}")


def _unsupported(what: str, why: str = "") -> NotImplementedError:
    return NotImplementedError(f"{what} is not supported by Myriad yet" + (f": {why}" if why
                                                                             else "") + f"; {_DOCS}")


# ---------------------------------------------------------------------------------- enums
class SimType(enum.IntEnum):
    SIM_PHYSX = 0
    SIM_FLEX = 1


class UpAxis(enum.IntEnum):
    UP_AXIS_Y = 0
    UP_AXIS_Z = 1


class DofDriveMode(enum.IntEnum):
    DOF_MODE_NONE = 0
    DOF_MODE_POS = 1
    DOF_MODE_VEL = 2
    DOF_MODE_EFFORT = 3


class DofType(enum.IntEnum):
    DOF_INVALID = -1
    DOF_ROTATION = 0
    DOF_TRANSLATION = 1


class JointType(enum.IntEnum):
    JOINT_INVALID = -1
    JOINT_FIXED = 0
    JOINT_REVOLUTE = 1
    JOINT_PRISMATIC = 2
    JOINT_BALL = 3
    JOINT_PLANAR = 4
    JOINT_FLOATING = 5


class IndexDomain(enum.IntEnum):
    DOMAIN_ACTOR = 0
    DOMAIN_ENV = 1
    DOMAIN_SIM = 2


class CoordinateSpace(enum.IntEnum):
    ENV_SPACE = 0
    LOCAL_SPACE = 1
    GLOBAL_SPACE = 2


class ContactCollection(enum.IntEnum):
    CC_NEVER = 0
    CC_LAST_SUBSTEP = 1
    CC_ALL_SUBSTEPS = 2


class MeshType(enum.IntEnum):
    MESH_NONE = 0
    MESH_COLLISION = 1
    MESH_VISUAL = 2
    MESH_VISUAL_AND_COLLISION = 3


class MeshNormalMode(enum.IntEnum):
    FROM_ASSET = 0
    COMPUTE_PER_VERTEX = 1
    COMPUTE_PER_FACE = 2


class ImageType(enum.IntEnum):
    IMAGE_COLOR = 0
    IMAGE_DEPTH = 1
    IMAGE_SEGMENTATION = 2
    IMAGE_OPTICAL_FLOW = 3


class TendonType(enum.IntEnum):
    TENDON_FIXED = 0
    TENDON_SPATIAL = 1


class CameraFollowMode(enum.IntEnum):
    FOLLOW_POSITION = 0
    FOLLOW_TRANSFORM = 1


_KEYS = ("SPACE APOSTROPHE COMMA MINUS PERIOD SLASH 0 1 2 3 4 5 6 7 8 9 SEMICOLON EQUAL A B C D E "
         "F G H I J K L M N O P Q R S T U V W X Y Z LEFT_BRACKET BACKSLASH RIGHT_BRACKET "
         "GRAVE_ACCENT ESCAPE ENTER TAB BACKSPACE INSERT DEL RIGHT LEFT DOWN UP PAGE_UP PAGE_DOWN "
         "HOME END CAPS_LOCK SCROLL_LOCK NUM_LOCK PRINT_SCREEN PAUSE F1 F2 F3 F4 F5 F6 F7 F8 F9 "
         "F10 F11 F12 NUMPAD_0 NUMPAD_1 NUMPAD_2 NUMPAD_3 NUMPAD_4 NUMPAD_5 NUMPAD_6 NUMPAD_7 "
         "NUMPAD_8 NUMPAD_9 NUMPAD_DEL NUMPAD_DIVIDE NUMPAD_MULTIPLY NUMPAD_SUBTRACT NUMPAD_ADD "
         "NUMPAD_ENTER NUMPAD_EQUAL LEFT_SHIFT LEFT_CONTROL LEFT_ALT LEFT_SUPER RIGHT_SHIFT "
         "RIGHT_CONTROL RIGHT_ALT RIGHT_SUPER MENU").split()
KeyboardInput = enum.IntEnum("KeyboardInput", [f"KEY_{k}" for k in _KEYS], start=0)
# Isaac Gym's keys that the viewer's page binds (`myriad.viewer.web.KEYS`); the others are
# buttons only
PAGE_KEYS = {k: k for k in _KEYS if len(k) == 1 and k.isalnum()} | {
    "SPACE": "space", "ESCAPE": "escape", "ENTER": "enter", "TAB": "tab",
    "BACKSPACE": "backspace", "INSERT": "insert", "DEL": "delete", "HOME": "home", "END": "end",
    "PAGE_UP": "pageup", "PAGE_DOWN": "pagedown", "UP": "arrowup", "DOWN": "arrowdown",
    "LEFT": "arrowleft", "RIGHT": "arrowright"}
MouseInput = enum.IntEnum("MouseInput", [f"MOUSE_{k}" for k in (
    "LEFT_BUTTON", "RIGHT_BUTTON", "MIDDLE_BUTTON", "FORWARD_BUTTON", "BACK_BUTTON",
    "SCROLL_RIGHT", "SCROLL_LEFT", "SCROLL_UP", "SCROLL_DOWN", "MOVE_RIGHT", "MOVE_LEFT",
    "MOVE_UP", "MOVE_DOWN")], start=0)

for _enum in (SimType, UpAxis, DofDriveMode, DofType, JointType, IndexDomain, CoordinateSpace,
              ContactCollection, MeshType, MeshNormalMode, ImageType, TendonType,
              CameraFollowMode, KeyboardInput, MouseInput):
    globals().update(_enum.__members__)

STATE_NONE, STATE_POS, STATE_VEL, STATE_ALL = 0, 1, 2, 3
# the geoms of a body a color or texture call is for (`_cameras.looks`)
_MESH_KINDS = {int(MeshType.MESH_VISUAL): ("visual",),
               int(MeshType.MESH_COLLISION): ("collision",),
               int(MeshType.MESH_VISUAL_AND_COLLISION): ("visual", "collision")}
RIGID_BODY_NONE, RIGID_BODY_DISABLE_GRAVITY, RIGID_BODY_DISABLE_SIMULATION = 0, 1, 2
RIGID_BODY_ENABLE_GYROSCOPIC_FORCES = 4
AXIS_NONE, AXIS_X, AXIS_Y, AXIS_Z, AXIS_TWIST = 0, 1, 2, 4, 8
AXIS_SWING_1, AXIS_SWING_2 = 16, 32
AXIS_TRANSLATION, AXIS_ROTATION, AXIS_ALL = 7, 56, 63
INVALID_HANDLE = -1
DEFAULT_VIEWER_WIDTH, DEFAULT_VIEWER_HEIGHT = 1600, 900


# ---------------------------------------------------------------------------------- math
def _buffer_floats(buf) -> np.ndarray:
    """The floats of what `from_buffer` takes: float32 bytes (a record's buffer), a record of
    float32 fields (Vec3.dtype, Transform.dtype, ...) or an array of numbers."""
    if isinstance(buf, (bytes, bytearray, memoryview)):
        return np.frombuffer(buf, np.float32).astype(np.float64)
    array = np.asarray(buf)
    if array.dtype.names:
        return np.frombuffer(array.tobytes(), np.float32).astype(np.float64)
    return array.astype(np.float64).reshape(-1)


class Vec3:
    """A 3-vector (x, y, z)."""
    dtype = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4")])

    __slots__ = ("x", "y", "z")

    def __init__(self, x: float = 0.0, y: float = 0.0, z: float = 0.0):
        self.x, self.y, self.z = float(x), float(y), float(z)

    def _t(self):
        return np.array([self.x, self.y, self.z])

    @classmethod
    def _of(cls, a) -> "Vec3":
        return cls(*(float(v) for v in a))

    def __add__(self, o): return Vec3._of(self._t() + o._t())
    def __sub__(self, o): return Vec3._of(self._t() - o._t())
    def __neg__(self): return Vec3._of(-self._t())
    def __mul__(self, s): return Vec3._of(self._t() * float(s))
    __rmul__ = __mul__
    def __truediv__(self, s): return Vec3._of(self._t() / float(s))
    def __eq__(self, o): return isinstance(o, Vec3) and np.allclose(self._t(), o._t(), 0, 0)
    def __hash__(self): return hash((self.x, self.y, self.z))
    def dot(self, o) -> float: return float(self._t() @ o._t())
    def cross(self, o) -> "Vec3": return Vec3._of(np.cross(self._t(), o._t()))
    def length(self) -> float: return float(np.linalg.norm(self._t()))
    def length_sq(self) -> float: return float(self._t() @ self._t())

    def normalize(self) -> "Vec3":
        n = self.length()
        return Vec3._of(self._t() / n) if n > 0 else Vec3(self.x, self.y, self.z)

    @staticmethod
    def from_buffer(buf) -> "Vec3":
        return Vec3(*_buffer_floats(buf)[:3])

    def __getstate__(self): return (self.x, self.y, self.z)
    def __setstate__(self, s): self.x, self.y, self.z = s
    def __repr__(self): return f"Vec3({self.x:g}, {self.y:g}, {self.z:g})"


class PerformanceTimers:
    """Seconds of wall time spent in each activity since the timers were last read
    (`get_performance_timers`); see `_TIMED` for the calls each one counts."""
    FIELDS = ("frame_idling", "graphics_image_retrieval", "graphics_sensor_rendering",
              "graphics_viewer_rendering", "physics_data_movement", "physics_sim")

    def __init__(self):
        for name in self.FIELDS:
            setattr(self, name, 0.0)
        self.total_time = 0.0

    def __repr__(self):
        return "PerformanceTimers(" + ", ".join(
            f"{name}={getattr(self, name):.6f}" for name in self.FIELDS + ("total_time",)) + ")"


class Vec2:
    __slots__ = ("x", "y")

    def __init__(self, x: float = 0.0, y: float = 0.0):
        self.x, self.y = float(x), float(y)

    def __repr__(self): return f"Vec2({self.x:g}, {self.y:g})"


class Int2:
    __slots__ = ("x", "y")

    def __init__(self, x: int = 0, y: int = 0):
        self.x, self.y = int(x), int(y)

    def __repr__(self): return f"Int2({self.x}, {self.y})"


class Int3:
    __slots__ = ("x", "y", "z")

    def __init__(self, x: int = 0, y: int = 0, z: int = 0):
        self.x, self.y, self.z = int(x), int(y), int(z)

    def __repr__(self): return f"Int3({self.x}, {self.y}, {self.z})"


class Quat:
    """A rotation quaternion (x, y, z, w); the default is the identity."""
    dtype = np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("w", "<f4")])

    __slots__ = ("x", "y", "z", "w")

    def __init__(self, x: float = 0.0, y: float = 0.0, z: float = 0.0, w: float = 1.0):
        self.x, self.y, self.z, self.w = float(x), float(y), float(z), float(w)

    def _t(self):
        return np.array([self.x, self.y, self.z, self.w])

    @staticmethod
    def from_axis_angle(axis: Vec3, angle: float) -> "Quat":
        a = axis._t()
        n = np.linalg.norm(a)
        a = a / n if n > 0 else a
        s = math.sin(0.5 * float(angle))
        return Quat(*(a * s), math.cos(0.5 * float(angle)))

    @staticmethod
    def from_euler_zyx(roll: float, pitch: float, yaw: float) -> "Quat":
        """The rotation Rz(yaw)·Ry(pitch)·Rx(roll)."""
        cr, sr = math.cos(roll / 2), math.sin(roll / 2)
        cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
        cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
        return Quat(sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
                    cr * cp * sy - sr * sp * cy, cr * cp * cy + sr * sp * sy)

    def to_euler_zyx(self) -> tuple:
        """(roll, pitch, yaw) with self = Rz(yaw)·Ry(pitch)·Rx(roll)."""
        x, y, z, w = self._t()
        roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
        pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        return roll, pitch, yaw

    def __mul__(self, o: "Quat") -> "Quat":
        ax, ay, az, aw = self._t()
        bx, by, bz, bw = o._t()
        return Quat(aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
                    aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)

    def rotate(self, v: Vec3) -> Vec3:
        return Vec3._of(self.rotate_xyz(v._t()))

    def rotate_xyz(self, v: np.ndarray) -> np.ndarray:
        """[..., 3] floats rotated by this quaternion."""
        u, w = self._t()[:3], self.w
        t = 2.0 * np.cross(u, v)
        return v + w * t + np.cross(u, t)

    def inverse(self) -> "Quat":
        n = float(self._t() @ self._t())
        return Quat(-self.x / n, -self.y / n, -self.z / n, self.w / n)

    def normalize(self) -> "Quat":
        n = float(np.linalg.norm(self._t()))
        return Quat(*(self._t() / n)) if n > 0 else Quat()

    @staticmethod
    def from_buffer(buf) -> "Quat":
        return Quat(*_buffer_floats(buf)[:4])

    def __eq__(self, o): return isinstance(o, Quat) and np.allclose(self._t(), o._t(), 0, 0)
    def __hash__(self): return hash((self.x, self.y, self.z, self.w))
    def __getstate__(self): return (self.x, self.y, self.z, self.w)
    def __setstate__(self, s): self.x, self.y, self.z, self.w = s
    def __repr__(self): return f"Quat({self.x:g}, {self.y:g}, {self.z:g}, {self.w:g})"


class Transform:
    """A pose: position `p` (Vec3) and rotation `r` (Quat)."""
    dtype = np.dtype([("p", Vec3.dtype), ("r", Quat.dtype)])

    def __init__(self, p: Vec3 | None = None, r: Quat | None = None):
        self.p = Vec3() if p is None else Vec3(p.x, p.y, p.z)
        self.r = Quat() if r is None else Quat(r.x, r.y, r.z, r.w)

    def transform_point(self, v: Vec3) -> Vec3:
        return self.r.rotate(v) + self.p

    def transform_vector(self, v: Vec3) -> Vec3:
        return self.r.rotate(v)

    def transform_points(self, points):
        """Each point moved by this transform: a list of Vec3, or an array of Vec3 records
        (any shape; Isaac Gym's line vertices) returned as one of the same shape."""
        if isinstance(points, np.ndarray) and points.dtype.names:
            return _records(self.r.rotate_xyz(_xyz(points)) + self.p._t())
        return [self.transform_point(v) for v in points]

    def transform_vectors(self, vectors):
        if isinstance(vectors, np.ndarray) and vectors.dtype.names:
            return _records(self.r.rotate_xyz(_xyz(vectors)))
        return [self.transform_vector(v) for v in vectors]

    def inverse(self) -> "Transform":
        r = self.r.inverse()
        return Transform(-r.rotate(self.p), r)

    def __mul__(self, o: "Transform") -> "Transform":
        return Transform(self.transform_point(o.p), self.r * o.r)

    @staticmethod
    def from_buffer(buf) -> "Transform":
        b = _buffer_floats(buf)
        return Transform(Vec3(*b[:3]), Quat(*b[3:7]))

    def __getstate__(self): return (self.p.__getstate__(), self.r.__getstate__())

    def __setstate__(self, s):
        self.p, self.r = Vec3(*s[0]), Quat(*s[1])

    def __repr__(self): return f"Transform(p={self.p}, r={self.r})"


class Mat33:
    """A 3×3 matrix with rows x, y, z (Vec3)."""

    def __init__(self, x: Vec3 | None = None, y: Vec3 | None = None, z: Vec3 | None = None):
        self.x = x or Vec3(1, 0, 0)
        self.y = y or Vec3(0, 1, 0)
        self.z = z or Vec3(0, 0, 1)

    def _t(self):
        return np.array([self.x._t(), self.y._t(), self.z._t()])

    @classmethod
    def _of(cls, m) -> "Mat33":
        return cls(Vec3._of(m[0]), Vec3._of(m[1]), Vec3._of(m[2]))

    def __repr__(self): return f"Mat33({self.x}, {self.y}, {self.z})"


class DofFrame:
    """Where a DOF's joint is (`origin`) and the direction it acts along or about (`axis`)."""
    dtype = np.dtype([("origin", Vec3.dtype), ("axis", Vec3.dtype)])

    def __init__(self, origin: Vec3 | None = None, axis: Vec3 | None = None):
        self.origin, self.axis = origin or Vec3(), axis or Vec3()

    @staticmethod
    def from_buffer(buf) -> "DofFrame":
        b = _buffer_floats(buf)
        return DofFrame(Vec3(*b[:3]), Vec3(*b[3:6]))

    def __repr__(self):
        return f"DofFrame(origin={self.origin}, axis={self.axis})"


class Velocity:
    def __init__(self, linear: Vec3 | None = None, angular: Vec3 | None = None):
        self.linear, self.angular = linear or Vec3(), angular or Vec3()

    @staticmethod
    def from_buffer(buf) -> "Velocity":
        b = _buffer_floats(buf)
        return Velocity(Vec3(*b[:3]), Vec3(*b[3:6]))


DofState = np.dtype([("pos", "<f4"), ("vel", "<f4")])
RigidBodyState = np.dtype([("pose", Transform.dtype),
                           ("vel", [("linear", Vec3.dtype), ("angular", Vec3.dtype)])])
RigidContact = np.dtype([("env0", "<i4"), ("env1", "<i4"), ("body0", "<i4"), ("body1", "<i4"),
                         ("localPos0", Vec3.dtype), ("localPos1", Vec3.dtype),
                         ("minDist", "<f4"), ("initialOverlap", "<f4"), ("normal", Vec3.dtype),
                         ("offset0", Vec3.dtype), ("offset1", Vec3.dtype), ("lambda", "<f4"),
                         ("lambdaFriction", [("x", "<f4"), ("y", "<f4")]), ("friction", "<f4"),
                         ("torsionFriction", "<f4"), ("rollingFriction", "<f4")])
DofProperties = np.dtype([("hasLimits", "?"), ("lower", "<f4"), ("upper", "<f4"),
                          ("driveMode", "<i4"), ("velocity", "<f4"), ("effort", "<f4"),
                          ("stiffness", "<f4"), ("damping", "<f4"), ("friction", "<f4"),
                          ("armature", "<f4")])


# ---------------------------------------------------------------------------------- params
class _Struct:
    """Plain attributes with Isaac Gym's defaults; unknown attributes are refused (a typo in
    a setattr loop over a config should not pass silently)."""
    _fields: dict = {}

    def __init__(self, **kwargs):
        for k, v in self._fields.items():
            object.__setattr__(self, k, copy.copy(v))
        for k, v in kwargs.items():
            setattr(self, k, v)

    def __setattr__(self, name, value):
        if name not in self._fields:
            raise AttributeError(f"{type(self).__name__} has no attribute {name!r}; its "
                                 f"attributes are {sorted(self._fields)}")
        object.__setattr__(self, name, value)

    def __getstate__(self):
        return {k: getattr(self, k) for k in self._fields}

    def __setstate__(self, state):
        for k, v in state.items():
            object.__setattr__(self, k, v)

    def __repr__(self):
        return f"{type(self).__name__}(" + ", ".join(f"{k}={getattr(self, k)!r}"
                                                      for k in self._fields) + ")"


class PhysXParams(_Struct):
    _fields = dict(solver_type=1, num_position_iterations=4, num_velocity_iterations=1,
                   contact_offset=0.02, rest_offset=0.001, bounce_threshold_velocity=0.2,
                   max_depenetration_velocity=100.0, friction_offset_threshold=0.04,
                   friction_correlation_distance=0.025, num_threads=0, num_subscenes=0,
                   use_gpu=False, max_gpu_contact_pairs=1024 * 1024,
                   default_buffer_size_multiplier=2.0,
                   contact_collection=ContactCollection.CC_ALL_SUBSTEPS,
                   always_use_articulations=False)


class FlexParams(_Struct):
    _fields = dict(solver_type=5, num_outer_iterations=4, num_inner_iterations=15,
                   relaxation=0.75, warm_start=0.4, contact_regularization=1e-7,
                   deterministic_mode=False, dynamic_friction=0.0, static_friction=0.0,
                   particle_friction=0.0, friction_mode=2, geometric_stiffness=1.0,
                   max_rigid_contacts=1024 * 1024, max_soft_contacts=1024 * 1024,
                   return_contacts=False, shape_collision_distance=0.0,
                   shape_collision_margin=0.0)


class SimParams(_Struct):
    _fields = dict(dt=1.0 / 60.0, substeps=2, up_axis=UpAxis.UP_AXIS_Y,
                   gravity=Vec3(0.0, -9.8, 0.0), use_gpu_pipeline=False, num_client_threads=0,
                   enable_actor_creation_warning=True, stress_visualization=False,
                   stress_visualization_min=0.0, stress_visualization_max=1e5,
                   physx=PhysXParams(), flex=FlexParams())


class PlaneParams(_Struct):
    _fields = dict(normal=Vec3(0.0, 1.0, 0.0), distance=0.0, static_friction=1.0,
                   dynamic_friction=1.0, restitution=0.0, segmentation_id=0)


class VhacdParams(_Struct):
    _fields = dict(resolution=100000, max_convex_hulls=10, max_num_vertices_per_ch=64,
                   concavity=0.0, plane_downsampling=4, convex_hull_downsampling=4,
                   alpha=0.05, beta=0.05, mode=0, pca=0, ocl_acceleration=True,
                   min_volume_per_ch=0.0001, convex_hull_approximation=True)


class AssetOptions(_Struct):
    _fields = dict(fix_base_link=False, default_dof_drive_mode=DofDriveMode.DOF_MODE_POS,
                   disable_gravity=False, armature=0.0, use_physx_armature=False,
                   density=1000.0, angular_damping=0.5, linear_damping=0.0,
                   max_angular_velocity=64.0, max_linear_velocity=1000.0,
                   flip_visual_attachments=False, collapse_fixed_joints=False,
                   replace_cylinder_with_capsule=False, thickness=0.02,
                   use_mesh_materials=False, mesh_normal_mode=MeshNormalMode.FROM_ASSET,
                   override_com=False, override_inertia=False, vhacd_enabled=False,
                   vhacd_params=VhacdParams(), convex_decomposition_from_submeshes=False,
                   enable_gyroscopic_forces=True, slices_per_cylinder=20,
                   min_particle_mass=1e-9, tendon_limit_stiffness=1.0)


class CameraProperties(_Struct):
    _fields = dict(width=DEFAULT_VIEWER_WIDTH, height=DEFAULT_VIEWER_HEIGHT,
                   horizontal_fov=90.0, near_plane=0.1, far_plane=1000.0, supersampling_horizontal=1,
                   supersampling_vertical=1, use_collision_geometry=False,
                   enable_tensors=False)


class RigidShapeProperties(_Struct):
    _fields = dict(friction=1.0, restitution=0.0, rolling_friction=0.0, torsion_friction=0.0,
                   compliance=0.0, contact_offset=0.02, rest_offset=0.001, thickness=0.0,
                   filter=0)


class RigidBodyProperties(_Struct):
    _fields = dict(mass=1.0, invMass=1.0, com=Vec3(), inertia=Mat33(), invInertia=Mat33(),
                   flags=RIGID_BODY_NONE)


class ForceSensorProperties(_Struct):
    _fields = dict(enable_forward_dynamics_forces=True, enable_constraint_solver_forces=True,
                   use_world_frame=False)


class SpatialForce:
    """A force and a torque (Vec3 each): what `ForceSensor.get_forces` returns."""

    def __init__(self, force: Vec3 | None = None, torque: Vec3 | None = None):
        self.force = Vec3() if force is None else force
        self.torque = Vec3() if torque is None else torque

    def __repr__(self):
        return f"SpatialForce(force={self.force}, torque={self.torque})"


class ForceSensor:
    """One force sensor of a prepared sim (`gym.get_actor_force_sensor`)."""

    def __init__(self, sim, row: int):
        self._sim, self._row = sim, row

    def get_global_index(self) -> int:
        """Its row in the sim's force sensor tensor."""
        return self._row

    def get_forces(self) -> SpatialForce:
        """Its reading after the last step (force, torque), as the tensor's row."""
        _refresh_force_sensors(self._sim)
        v = self._sim.sensor_readings.view(-1, 6)[self._row].tolist()
        return SpatialForce(Vec3(*v[:3]), Vec3(*v[3:]))


class HeightFieldParams(_Struct):
    _fields = dict(column_scale=1.0, row_scale=1.0, vertical_scale=1.0, nbRows=0, nbColumns=0,
                   transform=Transform(), static_friction=1.0, dynamic_friction=1.0,
                   restitution=0.0, segmentation_id=0)


class TriangleMeshParams(_Struct):
    _fields = dict(nb_vertices=0, nb_triangles=0, transform=Transform(), static_friction=1.0,
                   dynamic_friction=1.0, restitution=0.0, segmentation_id=0)


class AttractorProperties(_Struct):
    _fields = dict(axes=0, damping=0.0, offset=Transform(), rigid_handle=-1, stiffness=0.0,
                   target=Transform())


class TendonProperties(_Struct):
    """A fixed tendon's properties, by Isaac Gym's names: the spring (`stiffness`,
    `fixed_spring_rest_length`), the length limits (`is_fixed_limited`, `fixed_lower_limit`,
    `fixed_upper_limit`, `limit_stiffness`) and `damping`; `num_joints`, `num_attachments` and
    `type` describe the tendon and stay the asset's."""
    _fields = dict(damping=0.0, stiffness=0.0, fixed_spring_rest_length=0.0,
                   is_fixed_limited=False, limit_stiffness=0.0, fixed_lower_limit=0.0,
                   fixed_upper_limit=0.0, num_joints=0, num_attachments=0,
                   type=TendonType.TENDON_FIXED)


class ActuatorProperties(_Struct):
    _fields = dict(type=0, motor_effort=0.0, kp=0.0, kv=0.0, control_limited=False,
                   lower_control_limit=0.0, upper_control_limit=0.0, force_limited=False,
                   lower_force_limit=0.0, upper_force_limit=0.0)


class IndexRange:
    def __init__(self, start: int = 0, count: int = 0):
        self.start, self.count = int(start), int(count)

    def __repr__(self): return f"IndexRange(start={self.start}, count={self.count})"


class Version:
    major, minor = 1, 0

    def __repr__(self): return "Version(1.0, preview 4 API on Myriad)"


# ---------------------------------------------------------------------------------- handles
class Tensor:
    """A tensor descriptor: what `acquire_*_tensor` returns and `gymtorch.unwrap_tensor`
    makes. `gymtorch.wrap_tensor` gives back the torch tensor it holds."""

    def __init__(self, t: torch.Tensor):
        self.torch = t

    @property
    def device(self):
        return self.torch.device

    @property
    def shape(self):
        return tuple(self.torch.shape)

    @property
    def dtype(self):
        return self.torch.dtype

    @property
    def ndim(self):
        return self.torch.dim()

    @property
    def data_ptr(self):
        return self.torch.data_ptr()

    @property
    def data_address(self):
        return self.torch.data_ptr()

    @property
    def own_data(self):
        return False

    def __repr__(self):
        return f"gymapi.Tensor(shape={self.shape}, dtype={self.dtype}, device={self.device})"


class Asset:
    """What `load_asset` and `create_box` etc. return: a model spec with Isaac Gym's options
    applied, and its structure (bodies, DOFs, shapes) and default properties."""

    def __init__(self, spec: mujoco.MjSpec, options: AssetOptions, source: str,
                 actuators: list | None = None, fixed_joints: dict | None = None):
        self.spec, self.options, self.source = spec, copy.deepcopy(options), source
        self.actuators = actuators or []
        self.force_sensors: list[str] = []     # site names, in create_asset_force_sensor order
        # each one's ForceSensorProperties: (forward dynamics, constraint solver, world frame)
        self.force_sensor_flags: list[tuple[bool, bool, bool]] = []
        self.fix_base = bool(options.fix_base_link)
        probe = spec.copy()
        probe.compiler.fusestatic = False       # Isaac Gym keeps fixed-joint links apart
        try:
            m = probe.compile()
        except Exception as err:
            raise _model_error(f"{source}: MuJoCo rejected the model: {err}") from err
        self.mj = m
        self.body_names = [m.body(b).name for b in range(1, m.nbody)]
        self.body_ids = list(range(1, m.nbody))
        self.dof_joints = [j for j in range(m.njnt) if int(m.jnt_type[j]) in (
            int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))]
        self.dof_names = [m.joint(j).name for j in self.dof_joints]
        # Isaac Gym's joints: each non-root body's joints, in body order, a body without any
        # counting one fixed joint (named as in a URDF, else after its body); the root's own
        # joint (free or none) is not one. So joint i of a chain of single joints moves body
        # i + 1, as IsaacGymEnvs indexes the Jacobian by a joint's index.
        fixed = self.fixed_joint_names = fixed_joints or {}
        self.joint_names, self.joint_bodies, self.joint_mj = [], [], []   # (mj: -1 fixed)
        for i, b in enumerate(self.body_ids[1:], start=1):
            own = list(range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]))
            self.joint_names += [m.joint(j).name for j in own] or \
                [fixed.get(m.body(b).name, m.body(b).name + "_fixed")]
            self.joint_mj += own or [-1]
            self.joint_bodies += [i] * max(len(own), 1)
        # collision shapes, in Myriad's geom order (bodies' geoms; the world's are left out)
        self.shape_geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0
                            and (m.geom_contype[g] or m.geom_conaffinity[g])]
        self.body_geoms = [g for g in range(m.ngeom) if m.geom_bodyid[g] != 0]
        self.dof_props = self._default_dof_props(m)
        self.shape_props = [RigidShapeProperties(friction=float(m.geom_friction[g, 0]))
                            for g in self.shape_geoms]
        # fixed tendons: Isaac Gym imports them as PhysX fixed tendons (its semantics:
        # myriad.assets.physx_tendons), limit stiffness from the options, damping from the file
        self.tendon_names = [m.tendon(t).name for t in range(m.ntendon)]
        self.tendon_props = [TendonProperties(
            damping=float(m.tendon_damping[t, 0] if m.tendon_damping.ndim > 1
                          else m.tendon_damping[t]),
            stiffness=float(np.ravel(m.tendon_stiffness[t])[0]),
            fixed_spring_rest_length=float(m.tendon_lengthspring[t, 0]),
            is_fixed_limited=bool(m.tendon_limited[t]),
            limit_stiffness=float(options.tendon_limit_stiffness),
            fixed_lower_limit=float(m.tendon_range[t, 0]),
            fixed_upper_limit=float(m.tendon_range[t, 1]),
            num_joints=int(m.tendon_num[t])) for t in range(m.ntendon)]
        self.tendon_coefs: dict[int, list] = {}   # set_asset_fixed_tendon_joint_coefficients
        spatial = [self.tendon_names[t] for t in range(m.ntendon)
                   if any(int(m.wrap_type[w]) != int(mujoco.mjtWrap.mjWRAP_JOINT)
                          for w in range(m.tendon_adr[t], m.tendon_adr[t] + m.tendon_num[t]))]
        if spatial:
            raise _unsupported(f"{source}: spatial tendons {spatial[:4]}",
                               "Isaac Gym imports fixed (joint) tendons only")
        self.body_props = []
        for b in self.body_ids:
            mass = float(m.body_mass[b])
            rot = _quat_matrix(_wxyz_to_xyzw(m.body_iquat[b]))
            inertia = rot @ np.diag(m.body_inertia[b]) @ rot.T
            self.body_props.append(RigidBodyProperties(
                mass=mass, invMass=1.0 / mass if mass > 0 else 0.0,
                com=Vec3._of(m.body_ipos[b]), inertia=Mat33._of(inertia),
                invInertia=Mat33._of(np.linalg.pinv(inertia)),
                flags=RIGID_BODY_DISABLE_GRAVITY if options.disable_gravity else RIGID_BODY_NONE))

    def _default_dof_props(self, m) -> np.ndarray:
        props = np.zeros(len(self.dof_joints), dtype=DofProperties)
        for i, j in enumerate(self.dof_joints):
            d = m.jnt_dofadr[j]
            limited = bool(m.jnt_limited[j])
            props[i]["hasLimits"] = limited
            props[i]["lower"] = m.jnt_range[j, 0] if limited else -_FLT_MAX
            props[i]["upper"] = m.jnt_range[j, 1] if limited else _FLT_MAX
            props[i]["driveMode"] = int(self.options.default_dof_drive_mode)
            props[i]["velocity"] = _DEFAULT_MAX_JOINT_VELOCITY
            props[i]["effort"] = m.jnt_actfrcrange[j, 1] if m.jnt_actfrclimited[j] else _FLT_MAX
            props[i]["stiffness"] = m.jnt_stiffness[j]
            props[i]["damping"] = m.dof_damping[d]
            props[i]["friction"] = m.dof_frictionloss[d]
            props[i]["armature"] = m.dof_armature[d]
        return props

    def start_pose(self, body: int) -> "Transform":
        """Body `body`'s pose relative to the root body's frame, joints at their defaults."""
        data = mujoco.MjData(self.mj)
        mujoco.mj_kinematics(self.mj, data)
        root, b = self.body_ids[0], self.body_ids[body]

        def pose(i):
            return Transform(Vec3(*data.xpos[i]), Quat(*_wxyz_to_xyzw(data.xquat[i])))
        return pose(root).inverse() * pose(b)

    @property
    def num_bodies(self): return len(self.body_names)

    @property
    def num_dofs(self): return len(self.dof_names)

    def __repr__(self):
        return (f"gymapi.Asset({self.source}: {self.num_bodies} bodies, {self.num_dofs} dofs, "
                f"{len(self.shape_geoms)} shapes)")


_DEFAULT_MAX_JOINT_VELOCITY = 100.0    # PhysX's default joint speed cap (rad/s or m/s)


def _model_error(message):
    from myriad.physics import ModelError
    return ModelError(message)


def _wxyz_to_xyzw(q):
    return np.array([q[1], q[2], q[3], q[0]], dtype=float)


def _quat_matrix(q) -> np.ndarray:
    x, y, z, w = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


class _Actor:
    def __init__(self, env, index, asset: Asset, pose: Transform, name: str, group: int,
                 filter: int, segmentation_id: int):
        self.env, self.index, self.asset = env, index, asset
        self.pose = Transform(pose.p, pose.r)
        self.name, self.group, self.filter = name, int(group), int(filter)
        # filter -1 keeps the asset loader's shape filters, which are 0 (every shape collides):
        # an actor so created collides with itself (but a link with its parent) and as 0 with
        # others; any other value is the bitmask of every one of the actor's shapes
        self.shape_filter = 0 if self.filter == -1 else self.filter
        self.segmentation_id = segmentation_id
        self.body_segmentation: dict = {}   # body index -> segmentation id (camera images)
        # (body index, "visual" | "collision") -> set_rigid_body_color's Vec3 / texture handle
        self.body_colors: dict = {}
        self.body_textures: dict = {}
        self.dof_props = asset.dof_props.copy()
        self.shape_props = copy.deepcopy(asset.shape_props)
        for props in self.shape_props:           # what Isaac Gym reports back per shape
            props.filter = self.shape_filter
        self.body_props = copy.deepcopy(asset.body_props)
        self.tendon_props = copy.deepcopy(asset.tendon_props)
        self.tendon_offsets = [0.0] * len(asset.tendon_props)   # set_actor_tendon_offset
        self.tendon_coefs = copy.deepcopy(asset.tendon_coefs)     # tendon -> joint coefs
        self.scale = 1.0         # set_actor_scale
        self.body_offset = 0     # index of its first body in the env (set by create_actor)
        self.dof_offset = 0
        self.joint_offset = 0


class Env:
    """One env: the actors created in it, in order."""

    def __init__(self, sim, index: int, lower: Vec3, upper: Vec3, num_per_row: int):
        self.sim, self.index = sim, index
        self.lower, self.upper, self.num_per_row = lower, upper, max(int(num_per_row), 1)
        row, col = divmod(index, self.num_per_row)
        spacing = upper - lower
        self.origin = Vec3(col * spacing.x, row * spacing.y, 0.0)
        self.actors: list[_Actor] = []
        self.attractors: list[tuple] = []      # (actor index, asset body index, props)
        self.destroyed = False                 # destroy_env

    def __repr__(self):
        return f"gymapi.Env({self.index}: {[a.name for a in self.actors]})"


class ActionEvent:
    """A subscribed key's action (`query_viewer_action_events`): `action`, `value` (1: pressed)."""

    def __init__(self, action: str, value: float = 1.0):
        self.action, self.value = action, float(value)

    def __repr__(self):
        return f"ActionEvent({self.action!r}, {self.value})"


def _records(values: np.ndarray, dtype: np.dtype = Vec3.dtype) -> np.ndarray:
    """Records of `dtype` (Vec3's, Quat's) of [..., fields] floats, in the fields' order."""
    out = np.empty(values.shape[:-1], dtype)
    for k, name in enumerate(dtype.names):
        out[name] = values[..., k]
    return out


def _xyz(records: np.ndarray) -> np.ndarray:
    """[..., 3] floats of Vec3 records (`_records` undone)."""
    return np.stack([records["x"], records["y"], records["z"]], axis=-1).astype(np.float64)


def _floats(values, what: str) -> np.ndarray:
    """Floats of Vec3 records (Isaac Gym's line vertices and colors), arrays or lists."""
    array = np.asarray(values)
    if array.dtype.names:
        array = _xyz(array)
    try:
        return np.asarray(array, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"gym.add_lines: {what} must be numbers or Vec3 records, got "
                         f"{array.dtype}") from None


class Viewer:
    """What `create_viewer` returns: Myriad's page in the browser (`myriad.viewer`), served
    once the sim is prepared (at `create_viewer` if it is already, else at the first viewer
    call after `prepare_sim`). Subscribed keys are buttons on the page; a subscribed left
    mouse button listens to clicks in the page's scene."""

    def __init__(self, sim, props):
        self.sim, self.props = sim, props
        self.web = None                  # myriad.viewer.web.Viewer, once served
        self.buttons: dict = {}          # action -> key, subscribed (buttons once served)
        self.clicks: list[str] = []      # actions of MOUSE_LEFT_BUTTON, subscribed
        self.looks_sent = None           # the sim's looks the page was last given
        self.camera = None               # (target, eye) asked before serving
        self.last_sync = None            # sync_frame_time's clock
        self.lines: dict = {}            # add_lines': env index -> [(points [K, 2, 3], colors)]

    def add_button(self, action: str, key: str) -> None:
        """`action`'s button on the page, and Isaac Gym's `key` (its KeyboardInput name without
        KEY_) as the page's key where the page has that key (`PAGE_KEYS`)."""
        page_key = PAGE_KEYS.get(key)
        if page_key is None:
            self.web.add_button(f"{action} ({key})", action)
        else:
            self.web.add_button(action, action, key=page_key)

    def serve(self):
        """The page, served now if the sim is prepared (else None for now)."""
        if self.web is None and self.sim.myriad is not None and not self.sim.closed:
            from myriad.viewer import serve
            port = int(os.environ.get("MYRIAD_VIEWER_PORT", "8080"))
            origins = [(e.origin.x, e.origin.y, e.origin.z) for e in self.sim.envs]
            self.web = serve(self.sim.myriad, port=port, origins=origins,
                             drawing=self.sim.cameras.model())
            self.web.set_lines(self.lines)
            for action, key in self.buttons.items():
                self.add_button(action, key)
            if self.clicks:
                self.web.listen_clicks()
            if self.camera is not None:
                self.web.look_at(*self.camera)
        if self.web is not None:
            self.send_looks()
        return self.web

    def send_looks(self) -> None:
        """The envs' colors (set_rigid_body_color) to the page, when they changed; a textured
        geom in its texture's mean color, tinted."""
        from ._cameras import looks
        now = looks(self.sim)            # the same object until a look changes
        if now is self.looks_sent:
            return
        was, self.looks_sent = self.looks_sent, now
        if not now.dressed.any() and (was is None or not was.dressed.any()):
            return                       # the model's colors, as the page drew them
        rgb = now.rgba[..., :3].astype(np.float64)
        for handle, pixels in self.sim.textures.items():
            rgb[now.texture == handle] *= pixels[..., :3].reshape(-1, 3).mean(0) / 255.0
        self.web.set_geom_colors(rgb, now.dressed)


class Sim:
    """A simulation: parameters, ground, envs; after `prepare_sim` the Myriad `Envs`."""

    def __init__(self, gym, device: str, params: SimParams):
        self.gym, self.device, self.params = gym, device, copy.deepcopy(params)
        self.ground: PlaneParams | None = None
        self.terrain: dict | None = None        # Scene.add_terrain's arguments
        self.triangle_meshes: list = []         # Scene.add_triangle_mesh's arguments
        from ._cameras import Cameras
        self.cameras = Cameras(self)            # camera sensors
        self.envs: list[Env] = []
        self.assets: list[Asset] = []
        self.myriad = None          # myriad.api.Envs, after prepare_sim
        self.algebra = {}           # ("jacobian" | "mass_matrix", actor slot) -> its tensor
        self.scene = None           # the myriad Scene prepare_sim built (cameras draw from it)
        self.textures: dict = {}    # texture handle -> RGBA uint8 [height, width, 4]
        self.texture_count = 0      # handles given (a freed one is not given again)
        self.looks = None           # _cameras.Looks of the envs (None: to be made for all)
        self.restyled: set = set()  # envs whose color, texture or segmentation id changed since
        self.time, self.frames = 0.0, 0
        self.fresh = None           # the state tensors' versions when last refreshed (_refresh)
        self.closed = False
        self.started = time.perf_counter()      # get_elapsed_time's clock
        self.timers: dict[int, dict] = {}       # performance timers' handle -> field -> seconds
        self.timer_count = 0
        self.timing = False                     # inside a timed call (`_timed`)

    def __repr__(self):
        state = "prepared" if self.myriad is not None else "not prepared"
        return f"gymapi.Sim({len(self.envs)} envs on {self.device}, {state})"


# ---------------------------------------------------------------------------------- the scene
def _scene_class():
    """A `myriad.api.Scene` whose ground plane may have any normal (Isaac Gym's PlaneParams)
    and whose actors may be kept from colliding with each other (collision groups/filters)."""
    from myriad.api import Scene

    class _IsaacScene(Scene):
        plane_normal = (0.0, 0.0, 1.0)
        plane_distance = 0.0
        excluded_pairs: list = []       # (actor name, actor name) that must not collide
        attractors: list = []           # (body's full name, AttractorProperties)

        def compose(self):
            spec, drives = super().compose()
            if self.ground is not None:
                n = np.asarray(self.plane_normal, float)
                n = n / np.linalg.norm(n)
                ground = next(g for g in spec.geoms if g.name == "ground")
                # MuJoCo's plane has normal +z in its frame: rotate z onto n; n·x + d = 0
                z = np.array([0.0, 0.0, 1.0])
                axis = np.cross(z, n)
                s, c = np.linalg.norm(axis), float(z @ n)
                if s < 1e-12:
                    quat = [1.0, 0.0, 0.0, 0.0] if c > 0 else [0.0, 1.0, 0.0, 0.0]
                else:
                    angle = math.atan2(s, c)
                    axis = axis / s
                    quat = [math.cos(angle / 2), *(axis * math.sin(angle / 2))]
                ground.quat = quat
                ground.pos = (-self.plane_distance * n).tolist()
            for i, (body, props) in enumerate(self.attractors):
                o, t = props.offset, props.target
                ro, rt = o.r.normalize(), t.r.normalize()
                spec.body(body).add_site(name=f"attractor{i}/offset", pos=[o.p.x, o.p.y, o.p.z],
                                         quat=[ro.w, ro.x, ro.y, ro.z])
                spec.worldbody.add_site(name=f"attractor{i}/target", pos=[t.p.x, t.p.y, t.p.z],
                                        quat=[rt.w, rt.x, rt.y, rt.z])
                kind = (mujoco.mjtEq.mjEQ_CONNECT if int(props.axes) == AXIS_TRANSLATION
                        else mujoco.mjtEq.mjEQ_WELD)
                spec.add_equality(name=f"attractor{i}", type=kind,
                                  objtype=mujoco.mjtObj.mjOBJ_SITE,
                                  name1=f"attractor{i}/offset", name2=f"attractor{i}/target")
            for a, b in self.excluded_pairs:
                bodies_a = [x.name for x in spec.bodies if x.name.startswith(a + "/")]
                bodies_b = [x.name for x in spec.bodies if x.name.startswith(b + "/")]
                for x in bodies_a:
                    for y in bodies_b:
                        spec.add_exclude(bodyname1=x, bodyname2=y)
            return spec, drives

    return _IsaacScene


_MODES = {int(DofDriveMode.DOF_MODE_NONE): "none", int(DofDriveMode.DOF_MODE_POS): "position",
          int(DofDriveMode.DOF_MODE_VEL): "velocity", int(DofDriveMode.DOF_MODE_EFFORT): "effort"}


def _collide(a: _Actor, b: _Actor) -> bool:
    """Isaac Gym's rule for two actors of one env: same collision group (or either -1), and
    no common bit in their shapes' filters."""
    same_group = a.group == b.group or a.group == -1 or b.group == -1
    return same_group and (a.shape_filter & b.shape_filter) == 0


# ---------------------------------------------------------------------------------- Gym
class Gym:
    """The Isaac Gym interface on Myriad (see the module's docstring)."""

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        raise _not_provided(f"isaacgym.gymapi.Gym.{name}")

    def get_version(self) -> Version:
        return Version()

    # ------------------------------------------------------------------ sim
    def create_sim(self, compute_device: int = 0, graphics_device: int = 0,
                   type: SimType = SimType.SIM_PHYSX, params: SimParams | None = None) -> Sim:
        params = SimParams() if params is None else params
        if int(type) == SimType.SIM_FLEX:
            raise NotImplementedError(f"gym.create_sim: the Flex backend (SIM_FLEX) is not "
                                      f"provided by Myriad; use SIM_PHYSX ({_DOCS})")
        if int(type) != SimType.SIM_PHYSX:
            raise ValueError(f"gym.create_sim: unknown sim type {type!r}")
        if params.use_gpu_pipeline:
            if not torch.cuda.is_available():
                raise RuntimeError("gym.create_sim: SimParams.use_gpu_pipeline=True needs a CUDA "
                                   "GPU, and torch sees none; run with the CPU pipeline "
                                   "(--sim_device cpu --pipeline cpu, or "
                                   "sim_params.use_gpu_pipeline = False)")
            device = f"cuda:{int(compute_device)}"
        else:
            device = "cpu"
        _myriad_params(params)      # check the parameters now, not at prepare_sim
        return Sim(self, device, params)

    def get_sim_params(self, sim: Sim) -> SimParams:
        return copy.deepcopy(sim.params)

    def set_sim_params(self, sim: Sim, params: SimParams) -> None:
        if sim.myriad is None:
            _myriad_params(params)
            sim.params = copy.deepcopy(params)
            return
        old, new = _myriad_params(sim.params), _myriad_params(params)
        changed = [f for f in ("dt", "substeps", "solver", "position_iterations",
                               "velocity_iterations", "contact_offset", "rest_offset",
                               "bounce_threshold_velocity", "max_depenetration_velocity")
                   if getattr(old, f) != getattr(new, f)]
        if changed:
            raise _unsupported(f"gym.set_sim_params after prepare_sim changing {changed}",
                               "only gravity can change once the sim is built")
        sim.myriad.sim.gravity[:] = torch.tensor(new.gravity, dtype=torch.float32,
                                                 device=sim.myriad.device)
        sim.params = copy.deepcopy(params)

    def add_ground(self, sim: Sim, params: PlaneParams) -> None:
        self._before_prepare(sim, "add_ground")
        n = params.normal
        if n.length() < 1e-9:
            raise ValueError("gym.add_ground: PlaneParams.normal must not be zero")
        if not math.isclose(params.static_friction, params.dynamic_friction, rel_tol=1e-6,
                            abs_tol=1e-9):
            raise _unsupported(
                f"gym.add_ground with static_friction={params.static_friction} != "
                f"dynamic_friction={params.dynamic_friction}",
                "Myriad's contacts have one Coulomb coefficient; give both the same value")
        if sim.ground is not None:
            raise _unsupported("a second gym.add_ground", "a sim has one ground plane")
        sim.ground = copy.deepcopy(params)

    def add_heightfield(self, sim: Sim, heightsamples, params: HeightFieldParams) -> None:
        """A static height field shared by every env: `heightsamples` (int16, nbColumns ×
        nbRows values, e.g. terrain_utils' [x, y] grid) scaled by `vertical_scale`; sample
        (i, j) at (i·row_scale, j·column_scale) moved by `transform.p` (m). The sim's first
        one, unrotated with one spacing, is Myriad's height field; any other is simulated as
        the same surface in triangles."""
        self._before_prepare(sim, "add_heightfield")
        raw = np.asarray(heightsamples)
        rows, cols = int(params.nbColumns), int(params.nbRows)
        if raw.size != rows * cols or rows < 2 or cols < 2:
            raise ValueError(f"gym.add_heightfield: {raw.size} height samples for nbRows="
                             f"{params.nbRows} x nbColumns={params.nbColumns}")
        grid = raw.reshape(rows, cols)
        if not _height_field_fits(sim, params) or not math.isclose(
                params.row_scale, params.column_scale, rel_tol=1e-6):
            from myriad.tasks.terrain import heightfield_to_mesh
            vertices, triangles = heightfield_to_mesh(grid, 1.0, float(params.vertical_scale))
            vertices[:, 0] *= float(params.row_scale)
            vertices[:, 1] *= float(params.column_scale)
            self._add_triangles(sim, "add_heightfield", vertices, triangles, params)
            return
        heights = grid.astype(np.float64) * float(params.vertical_scale)
        self._add_terrain(sim, "add_heightfield", heights, float(params.row_scale), params,
                          riser=0.0)

    def add_triangle_mesh(self, sim: Sim, vertices, triangles,
                          params: TriangleMeshParams) -> None:
        """A static triangle mesh shared by every env. A mesh made from a height field
        (terrain_utils.convert_heightfield_to_trimesh: one vertex per grid sample, steps
        steeper than its slope threshold made vertical walls) is simulated as that height
        field with those walls, exactly (and faster). Any other mesh (a table, a bin, a room)
        collides as its triangles (`Scene.add_triangle_mesh`), exactly: its triangles must
        face outward, as PhysX's do."""
        self._before_prepare(sim, "add_triangle_mesh")
        v = np.asarray(vertices, dtype=np.float64).reshape(-1)
        t = np.asarray(triangles).reshape(-1)
        nv, nt = int(params.nb_vertices), int(params.nb_triangles)
        if v.size != 3 * nv or t.size != 3 * nt:
            raise ValueError(f"gym.add_triangle_mesh: {v.size} vertex and {t.size} triangle "
                             f"values for nb_vertices={nv}, nb_triangles={nt} (3 values each)")
        if nt == 0 or t.min(initial=0) < 0 or t.max(initial=0) >= nv:
            raise ValueError(f"gym.add_triangle_mesh: triangle indices must lie in [0, {nv}) "
                             f"and there must be triangles")
        # a height-field grid becomes the sim's one height field where it fits there; every
        # other mesh (or a second grid) collides as its triangles
        grid = _height_grid(v.reshape(-1, 3), t.reshape(-1, 3).astype(np.int64)) \
            if _height_field_fits(sim, params) else None
        if grid is None:
            self._add_triangles(sim, "add_triangle_mesh", v.reshape(-1, 3), t.reshape(-1, 3),
                                params)
            return
        heights, spacing, origin, riser = grid
        self._add_terrain(sim, "add_triangle_mesh", heights, spacing, params, riser=riser,
                          origin=origin)

    def _add_triangles(self, sim, call, vertices, triangles, params) -> None:
        """A static mesh that collides as its triangles (`Scene.add_triangle_mesh`)."""
        self._check_static_params(call, params)
        pose = params.transform
        r = pose.r.normalize()
        sim.triangle_meshes.append(dict(
            vertices=np.asarray(vertices, np.float64), triangles=np.asarray(triangles),
            pos=(pose.p.x, pose.p.y, pose.p.z), quat=(r.x, r.y, r.z, r.w),
            friction=float(params.static_friction)))

    def _check_static_params(self, call, params) -> None:
        if not math.isclose(params.static_friction, params.dynamic_friction, rel_tol=1e-6,
                            abs_tol=1e-9):
            raise _unsupported(f"gym.{call} with static_friction={params.static_friction} != "
                               f"dynamic_friction={params.dynamic_friction}",
                               "Myriad's contacts have one Coulomb coefficient")
        if float(params.restitution) != 0.0:
            raise _unsupported(f"gym.{call} with restitution={params.restitution}",
                               "Myriad's static shapes here do not bounce")

    def _add_terrain(self, sim, call, heights, spacing, params, riser, origin=(0.0, 0.0)):
        """The sim's one height field (the callers send a second one, or a rotated one, to
        `_add_triangles`)."""
        pose = params.transform
        self._check_static_params(call, params)
        sim.terrain = dict(heights=heights + pose.p.z, horizontal_scale=spacing,
                           origin=(origin[0] + pose.p.x, origin[1] + pose.p.y),
                           friction=float(params.static_friction), riser=float(riser))

    def prepare_sim(self, sim: Sim) -> bool:
        if sim.myriad is not None:
            return True
        _prepare(sim)
        return True

    def simulate(self, sim: Sim) -> None:
        envs = self._envs(sim, "simulate")
        gone = [e.index for e in sim.envs if e.destroyed]
        if gone:
            raise _unsupported(f"gym.simulate after destroy_env of envs {gone}", "Myriad builds "
                               "all envs together: destroy the sim (destroy_sim) to end them")
        envs.step()                     # refreshes the state tensors
        sim.fresh = _versions(envs)
        sim.time += sim.params.dt
        sim.frames += 1

    def fetch_results(self, sim: Sim, wait: bool = True) -> None:
        """Nothing to fetch: `simulate` refreshed the state tensors already. While performance
        timers exist, `wait` waits for the GPU, so that their physics_sim holds the time the
        step took on it (Myriad's GPU step runs asynchronously otherwise)."""
        if wait and sim.timers and str(sim.device).startswith("cuda"):
            torch.cuda.synchronize(sim.device)

    def get_sim_time(self, sim: Sim) -> float:
        """Simulated seconds: dt per `simulate`."""
        return sim.time

    def get_elapsed_time(self, sim: Sim) -> float:
        """Wall-clock seconds since `create_sim`."""
        return time.perf_counter() - sim.started

    # ------------------------------------------------------------------ performance timers
    def create_performance_timers(self, sim: Sim) -> int:
        """A set of timers that add up the wall time spent in the calls `_TIMED` lists from
        now on: its handle for `get_performance_timers`."""
        handle = sim.timer_count
        sim.timer_count += 1
        sim.timers[handle] = dict.fromkeys(PerformanceTimers.FIELDS, 0.0)
        return handle

    def get_performance_timers(self, sim: Sim, timers: int) -> PerformanceTimers:
        """The seconds each activity took since these timers were created or last read
        (they start again from zero)."""
        if int(timers) not in sim.timers:
            raise ValueError(f"gym.get_performance_timers: {timers} is not a performance timers "
                             f"handle of this sim (create_performance_timers)")
        out = PerformanceTimers()
        for name, seconds in sim.timers[int(timers)].items():
            setattr(out, name, seconds)
        out.total_time = sum(sim.timers[int(timers)].values())
        sim.timers[int(timers)] = dict.fromkeys(PerformanceTimers.FIELDS, 0.0)
        return out

    def destroy_performance_timers(self, sim: Sim, timers: int) -> None:
        if sim.timers.pop(int(timers), None) is None:
            raise ValueError(f"gym.destroy_performance_timers: {timers} is not a performance "
                             f"timers handle of this sim")

    def get_frame_count(self, sim: Sim) -> int:
        return sim.frames

    def destroy_env(self, env: Env) -> None:
        """Marks the env destroyed, as code tearing a sim down does before destroy_sim; a sim
        cannot go on without one of its envs (simulate then raises)."""
        if not isinstance(env, Env):
            raise TypeError(f"gym.destroy_env: expected an Env, got {type(env).__name__}")
        env.destroyed = True

    def destroy_sim(self, sim: Sim) -> None:
        sim.myriad, sim.envs, sim.closed = None, [], True

    # ------------------------------------------------------------------ viewer
    def create_viewer(self, sim: Sim, props: CameraProperties | None = None):
        """Myriad's viewer is a page in the browser (`myriad.viewer`, needs `.[viewer]`): the
        URL is printed once the sim is prepared; `MYRIAD_VIEWER_PORT` picks the port (8080).
        Without viser installed: a warning and None, so code written for headless runs
        (`if self.viewer:`) goes on. The envs shown are drawn at their grid origins
        (`create_env`'s spacing and envs per row), as Isaac Gym's viewer places them."""
        from myriad.viewer.web import INSTALL
        try:
            import viser  # noqa: F401
        except ImportError:
            warnings.warn(f"isaacgym on Myriad: gym.create_viewer returns None: Myriad's viewer "
                          f"is a page in the browser and needs viser ({INSTALL}); or run "
                          f"headless", RuntimeWarning, stacklevel=2)
            return None
        viewer = Viewer(sim, props)
        viewer.serve()
        return viewer

    def get_viewer_size(self, viewer) -> Int2:
        """The CameraProperties' width and height the viewer was created with (the page itself
        takes the browser window's size)."""
        props = viewer.props if isinstance(viewer, Viewer) and viewer.props else \
            CameraProperties()
        return Int2(props.width, props.height)

    def get_viewer_camera_transform(self, viewer, env) -> Transform:
        """The viewer's camera in `env`'s frame (the world's for None), in Isaac Gym's camera
        frame: looking along +z, +y up, +x to the left: the open page's camera, else where
        viewer_camera_look_at put it."""
        if not isinstance(viewer, Viewer):
            raise TypeError(f"gym.get_viewer_camera_transform: expected a Viewer (from "
                            f"gym.create_viewer), got {type(viewer).__name__}")
        page = viewer.web.camera_pose() if viewer.serve() is not None else None
        if page is not None:
            eye, wxyz = page
            rot = np.empty(9)
            mujoco.mju_quat2Mat(rot, wxyz)
            opencv = rot.reshape(3, 3)
        elif viewer.camera is not None:
            from ._cameras import look_rotation
            target, eye = (np.asarray(v, float) for v in viewer.camera)
            ahead, left, up = look_rotation(eye, target, _up(viewer.sim),
                                            "viewer_camera_look_at").T
            opencv = np.stack([-left, -up, ahead], axis=1)
        else:
            raise RuntimeError("gym.get_viewer_camera_transform: the camera has no pose yet: "
                               "no page is open and viewer_camera_look_at was not called")
        # Isaac Gym's camera frame is OpenCV's turned half a turn about the view axis
        frame = opencv * np.array([-1.0, -1.0, 1.0])
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, frame.reshape(-1))
        o = env.origin if isinstance(env, Env) else Vec3()
        return Transform(Vec3(eye[0] - o.x, eye[1] - o.y, eye[2] - o.z), Quat(*q[1:], q[0]))

    def write_viewer_image_to_file(self, viewer, filename: str) -> None:
        """A PNG of what the viewer shows: the envs the page shows at their grid origins, seen
        from the viewer's camera (get_viewer_camera_transform) at the viewer's size and field
        of view, drawn by MuJoCo's offscreen renderer from the simulated state (the lines
        add_lines drew and the contact arrows are not in it). IsaacGymEnvs' record_frames
        writes its frames with this."""
        import imageio.v2 as imageio

        from ._cameras import vertical_fov
        camera = self.get_viewer_camera_transform(viewer, None)
        web, sim = viewer.serve(), viewer.sim
        if web is None:
            raise RuntimeError("gym.write_viewer_image_to_file: the viewer shows nothing before "
                               "gym.prepare_sim(sim)")
        props = viewer.props or CameraProperties()
        ahead, up = camera.r.rotate(Vec3(0, 0, 1)), camera.r.rotate(Vec3(0, 1, 0))
        envs = web.shown_envs
        origins = [(sim.envs[e].origin.x, sim.envs[e].origin.y, sim.envs[e].origin.z)
                   for e in envs]
        rgb = sim.cameras.render_view(camera.p._t(), ahead._t(), up._t(),
                                      (int(props.width), int(props.height)),
                                      vertical_fov(props),
                                      float(props.near_plane), float(props.far_plane),
                                      envs, origins)
        os.makedirs(os.path.dirname(os.path.abspath(filename)), exist_ok=True)
        imageio.imwrite(filename, rgb)

    def destroy_viewer(self, viewer) -> None:
        if isinstance(viewer, Viewer) and viewer.web is not None:
            viewer.web.close()

    def step_graphics(self, sim: Sim) -> None:
        pass                    # the page draws itself at its own frame rate

    def draw_viewer(self, viewer, sim: Sim, render_collision: bool = True) -> None:
        """Nothing per step: the page's own thread draws the shown envs while a page is open
        (no per-step host read); this only serves it once the sim is prepared."""
        if isinstance(viewer, Viewer):
            viewer.serve()

    def sync_frame_time(self, sim: Sim) -> None:
        """Waits until `dt` of real time has passed since the last call (Isaac Gym's)."""
        viewer_clock = getattr(sim, "sync_clock", None)
        now = time.perf_counter()
        if viewer_clock is not None:
            wait = float(sim.params.dt) - (now - viewer_clock)
            if wait > 0:
                time.sleep(wait)
        sim.sync_clock = time.perf_counter()

    def poll_viewer_events(self, viewer) -> None:
        if isinstance(viewer, Viewer):
            viewer.serve()

    def query_viewer_has_closed(self, viewer) -> bool:
        return isinstance(viewer, Viewer) and viewer.web is not None and viewer.web.closed

    def query_viewer_action_events(self, viewer) -> list:
        """The subscribed actions since the last call, in the order they happened: a key's
        press on the page and its button's click, each one event of value 1 (the page reports
        a press, not its release); a click in the scene, for each action subscribed to
        MOUSE_LEFT_BUTTON, the press (1) and the release (0)."""
        if not isinstance(viewer, Viewer) or viewer.serve() is None:
            return []
        out = []
        for kind, value in viewer.web.events():
            if kind in ("key", "button") and value in viewer.buttons:
                out.append(ActionEvent(value))
            elif kind == "click":
                out += [ActionEvent(a, v) for a in viewer.clicks for v in (1.0, 0.0)]
        return out

    def subscribe_viewer_keyboard_event(self, viewer, key, action: str) -> None:
        """The key on the page (`PAGE_KEYS`; F-keys, the numpad and the modifiers are not
        among them) and a button labelled with the action and the key."""
        if isinstance(viewer, Viewer) and action not in viewer.buttons:
            name = getattr(key, "name", str(key)).removeprefix("KEY_")
            viewer.buttons[action] = name
            if viewer.web is not None:
                viewer.add_button(action, name)

    def subscribe_viewer_mouse_event(self, viewer, button, action: str) -> None:
        """MOUSE_LEFT_BUTTON: a click in the page's scene (no drag: a drag turns the camera)
        is `action`'s press and release (`query_viewer_action_events`), at the position
        `get_viewer_mouse_position` gives. The page reports no other button, no scroll and
        no motion: subscribing one warns that its action will not come."""
        if not isinstance(viewer, Viewer):
            return
        if int(button) != int(MouseInput.MOUSE_LEFT_BUTTON):
            name = getattr(button, "name", None) or MouseInput(int(button)).name
            warnings.warn(f"gym.subscribe_viewer_mouse_event: Myriad's viewer page reports "
                          f"left-button clicks only: {name} ({action!r}) will not come",
                          RuntimeWarning, stacklevel=2)
            return
        if action not in viewer.clicks:
            viewer.clicks.append(action)
            if viewer.web is not None:
                viewer.web.listen_clicks()

    def get_viewer_mouse_position(self, viewer) -> Vec2:
        """Where the last click in the page's scene was, normalized to the canvas: x from
        its left edge, y from its top, each 0..1 (the centre, (0.5, 0.5), before a click).
        Only clicks are seen: the page does not report the pointer's motion."""
        if not isinstance(viewer, Viewer):
            raise TypeError(f"gym.get_viewer_mouse_position: expected a Viewer (from "
                            f"gym.create_viewer), got {type(viewer).__name__}")
        web = viewer.serve()
        x, y = (0.5, 0.5) if web is None or web.click_position is None else web.click_position
        return Vec2(x, y)

    def viewer_camera_look_at(self, viewer, env, pos: Vec3, target: Vec3) -> None:
        """The page's camera at `pos` looking at `target`, in `env`'s frame (the env drawn at
        its grid origin), or the world's for None."""
        if isinstance(viewer, Viewer):
            o = env.origin if isinstance(env, Env) else Vec3()
            viewer.camera = ((target.x + o.x, target.y + o.y, target.z + o.z),
                             (pos.x + o.x, pos.y + o.y, pos.z + o.z))
            if viewer.serve() is not None:
                viewer.web.look_at(*viewer.camera)

    def clear_lines(self, viewer) -> None:
        """Removes every line `add_lines` drew."""
        if isinstance(viewer, Viewer):
            viewer.lines = {}
            if viewer.web is not None:
                viewer.web.set_lines(viewer.lines)

    def add_lines(self, viewer, env, num_lines, vertices, colors) -> None:
        """Draws `num_lines` segments in `env`'s frame until `clear_lines`: `vertices` their
        2·num_lines end points (Vec3 records [num_lines, 2], or floats [num_lines, 6] or
        [2·num_lines, 3]), `colors` one RGB in 0..1 per line (Vec3 records or floats). The
        page draws the lines of the envs it shows, each env at its grid origin."""
        if not isinstance(viewer, Viewer):
            return
        n = int(num_lines)
        points, rgb = _floats(vertices, "vertices"), _floats(colors, "colors")
        if points.size != n * 6 or rgb.size != n * 3:
            raise ValueError(f"gym.add_lines: {n} lines take {2 * n} vertices and {n} colors "
                             f"(3 floats each); got {points.size / 3:g} vertices and "
                             f"{rgb.size / 3:g} colors")
        index = env.index if isinstance(env, Env) else 0    # None: the world (env 0's frame)
        viewer.lines.setdefault(index, []).append((points.reshape(n, 2, 3), rgb.reshape(n, 3)))
        if viewer.web is not None:
            viewer.web.set_lines(viewer.lines)

    def draw_env_rigid_contacts(self, viewer, env, color, scale: float, flip_normals: bool
                                ) -> None:
        """The page's contact drawing turned on: each shown env's contacts as segments along
        their forces, `scale` metres per newton (the page's slider, 1e-5..0.1); in the page's
        red, not `color`."""
        if isinstance(viewer, Viewer) and viewer.serve() is not None:
            viewer.web.show_contacts.value = True
            viewer.web.force_scale.value = float(np.clip(np.log10(max(float(scale), 1e-12)),
                                                         -5.0, -1.0))

    def _looked_at(self, call: str, env, actor_handle, rigid_body_index, mesh_type):
        """(actor, body index, mesh kinds) of a color or texture call, checked."""
        actor = self._actor(env, actor_handle)
        b = int(rigid_body_index)
        if not 0 <= b < actor.asset.num_bodies:
            raise IndexError(f"gym.{call}: actor {actor.name!r} has {actor.asset.num_bodies} "
                             f"bodies, not an index {b}")
        kinds = _MESH_KINDS.get(int(mesh_type))
        if kinds is None:
            raise ValueError(f"gym.{call}: mesh type {mesh_type!r}: one of MESH_VISUAL, "
                             f"MESH_COLLISION, MESH_VISUAL_AND_COLLISION")
        return actor, b, kinds

    def set_rigid_body_color(self, env, actor_handle, rigid_body_index, mesh_type, color):
        """The body's color in this env: camera images, `write_viewer_image_to_file` and the
        viewer's page draw it (MESH_VISUAL: its visual geoms, or all its geoms when it has
        none apart from its collision shapes, as an Isaac Gym primitive asset; MESH_COLLISION:
        its collision geoms). A texture on the body is tinted by it."""
        actor, b, kinds = self._looked_at("set_rigid_body_color", env, actor_handle,
                                          rigid_body_index, mesh_type)
        for kind in kinds:
            actor.body_colors[(b, kind)] = Vec3(color.x, color.y, color.z)
        env.sim.restyled.add(env.index)

    def get_rigid_body_color(self, env, actor_handle, rigid_body_index, mesh_type) -> Vec3:
        """The color set_rigid_body_color gave, else the body's first geom's in its model."""
        actor, b, kinds = self._looked_at("get_rigid_body_color", env, actor_handle,
                                          rigid_body_index, mesh_type)
        color = actor.body_colors.get((b, kinds[0]))
        if color is None:
            m = actor.asset.mj
            body = actor.asset.body_ids[b]
            geoms = [g for g in actor.asset.body_geoms if m.geom_bodyid[g] == body]
            color = Vec3(*m.geom_rgba[geoms[0], :3]) if geoms else Vec3(1.0, 1.0, 1.0)
        return Vec3(color.x, color.y, color.z)

    # ------------------------------------------------------------------ textures
    def create_texture_from_file(self, sim: Sim, filename: str) -> int:
        """A texture from an image file (PNG, JPEG, ... as imageio reads them) for
        `set_rigid_body_texture`: its handle."""
        import imageio.v2 as imageio
        if not os.path.isfile(filename):
            raise FileNotFoundError(f"gym.create_texture_from_file: no file {filename!r}")
        try:
            image = np.asarray(imageio.imread(filename))
        except Exception as err:
            raise ValueError(f"gym.create_texture_from_file: {filename!r} is not an image "
                             f"imageio can read: {err}") from None
        if image.ndim == 2:
            image = np.repeat(image[..., None], 3, axis=-1)
        if image.ndim != 3 or image.shape[-1] not in (3, 4) or image.dtype != np.uint8:
            raise ValueError(f"gym.create_texture_from_file: {filename!r}: an image of shape "
                             f"{image.shape} and type {image.dtype}; textures are 8-bit grey, "
                             f"RGB or RGBA")
        if image.shape[-1] == 3:
            image = np.concatenate([image, np.full(image.shape[:2] + (1,), 255, np.uint8)], -1)
        return self._texture(sim, image)

    def create_texture_from_buffer(self, sim: Sim, width: int, height: int, pixels) -> int:
        """A texture of `width` x `height` RGBA pixels (uint8, row after row from the top:
        height x width x 4 values in any shape) for `set_rigid_body_texture`: its handle."""
        w, h = int(width), int(height)
        data = np.asarray(pixels)
        if w < 1 or h < 1 or data.dtype != np.uint8 or data.size != w * h * 4:
            raise ValueError(f"gym.create_texture_from_buffer: {w} x {h} RGBA pixels take "
                             f"{max(w * h * 4, 0)} uint8 values; got {data.size} of "
                             f"{data.dtype}")
        return self._texture(sim, data.reshape(h, w, 4).copy())

    def _texture(self, sim: Sim, rgba: np.ndarray) -> int:
        handle = sim.texture_count
        sim.texture_count += 1
        sim.textures[handle] = rgba
        return handle

    def free_texture(self, sim: Sim, texture: int) -> None:
        """Forgets the texture: bodies it was on are drawn in their colors again."""
        if sim.textures.pop(int(texture), None) is None:
            raise ValueError(f"gym.free_texture: {texture} is not a texture of this sim")
        for env in sim.envs:
            for actor in env.actors:
                actor.body_textures = {k: t for k, t in actor.body_textures.items()
                                       if t != int(texture)}
        sim.looks = None

    def set_rigid_body_texture(self, env, actor_handle, rigid_body_index, mesh_type,
                               texture) -> None:
        """The texture (`create_texture_from_*`) on the body's geoms in this env (which ones:
        as set_rigid_body_color), in camera images and `write_viewer_image_to_file` (MuJoCo's
        renderer, which maps a picture onto a primitive by its own rule); the viewer's page
        draws the body in its color."""
        actor, b, kinds = self._looked_at("set_rigid_body_texture", env, actor_handle,
                                          rigid_body_index, mesh_type)
        if int(texture) not in env.sim.textures:
            raise ValueError(f"gym.set_rigid_body_texture: {texture} is not a texture of "
                             f"this sim (create_texture_from_file / _from_buffer)")
        for kind in kinds:
            actor.body_textures[(b, kind)] = int(texture)
        env.sim.restyled.add(env.index)

    def get_rigid_body_texture(self, env, actor_handle, rigid_body_index, mesh_type) -> int:
        """The texture set_rigid_body_texture put on the body, else INVALID_HANDLE."""
        actor, b, kinds = self._looked_at("get_rigid_body_texture", env, actor_handle,
                                          rigid_body_index, mesh_type)
        return actor.body_textures.get((b, kinds[0]), INVALID_HANDLE)

    def get_rigid_body_segmentation_id(self, env, actor_handle, rigid_body_index) -> int:
        actor = self._actor(env, actor_handle)
        return actor.body_segmentation.get(int(rigid_body_index), actor.segmentation_id)

    def set_rigid_body_segmentation_id(self, env, actor_handle, rigid_body_index, sid):
        """The id camera sensors' segmentation images show for this body (else its actor's)."""
        self._actor(env, actor_handle).body_segmentation[int(rigid_body_index)] = int(sid)
        env.sim.restyled.add(env.index)

    # ------------------------------------------------------------------ camera sensors
    def create_camera_sensor(self, env: Env, props: CameraProperties) -> int:
        """A camera of `env` (docs/isaacgym.md, "Camera sensors"): MuJoCo's offscreen renderer
        draws it at `render_all_camera_sensors`. Returns its handle within the env."""
        if not isinstance(env, Env):
            raise TypeError(f"gym.create_camera_sensor: expected an Env, got "
                            f"{type(env).__name__}")
        return env.sim.cameras.create(env, copy.deepcopy(props)).handle

    def set_camera_location(self, camera_handle: int, env: Env, position: Vec3,
                            target: Vec3) -> None:
        camera = env.sim.cameras.find(env, camera_handle)
        camera.body = None
        camera.look((position.x, position.y, position.z), (target.x, target.y, target.z),
                    _up(env.sim))

    def set_camera_transform(self, camera_handle: int, env: Env, transform: Transform) -> None:
        """The camera at `transform` in the env's frame (it looks along the transform's +x)."""
        camera = env.sim.cameras.find(env, camera_handle)
        r = transform.r.normalize()
        camera.body = None
        camera.position = np.array([transform.p.x, transform.p.y, transform.p.z])
        camera.rotation = _quat_matrix([r.x, r.y, r.z, r.w])

    def attach_camera_to_body(self, camera_handle: int, env: Env, body_handle: int,
                              transform: Transform, follow_mode) -> None:
        """The camera rides on the env's body `body_handle` (env domain) at `transform`
        (FOLLOW_TRANSFORM), or at its position plus `transform.p` facing `transform.r`
        (FOLLOW_POSITION)."""
        camera = env.sim.cameras.find(env, camera_handle)
        count = sum(a.asset.num_bodies for a in env.actors)
        if not 0 <= int(body_handle) < count:
            raise ValueError(f"gym.attach_camera_to_body: {body_handle} is not a body of env "
                             f"{env.index} ({count} bodies)")
        camera.body = (int(body_handle), copy.deepcopy(transform), int(follow_mode))

    def _camera(self, sim: Sim, env: Env, handle: int):
        if not isinstance(sim, Sim) or not isinstance(env, Env):
            raise TypeError(f"gym camera call: expected a Sim and an Env, got "
                            f"{type(sim).__name__} and {type(env).__name__}")
        return sim.cameras.find(env, handle)

    def destroy_camera_sensor(self, sim: Sim, env: Env, camera_handle: int) -> None:
        sim.cameras.cameras.remove(self._camera(sim, env, camera_handle))

    def set_light_parameters(self, sim: Sim, light_index: int, intensity: Vec3, ambient: Vec3,
                             direction: Vec3) -> None:
        """Accepted, and not applied: the page and the offscreen images keep MuJoCo's lights
        (drawing only, no effect on the motion)."""
        if not isinstance(sim, Sim):
            raise TypeError(f"gym.set_light_parameters: expected a Sim, got {type(sim).__name__}")

    def render_all_camera_sensors(self, sim: Sim) -> None:
        self._envs(sim, "render_all_camera_sensors")
        sim.cameras.render_all()

    def start_access_image_tensors(self, sim: Sim) -> None:
        pass            # the tensors are written by render_all_camera_sensors

    def end_access_image_tensors(self, sim: Sim) -> None:
        pass

    def get_camera_image(self, sim: Sim, env: Env, camera_handle: int, image_type):
        """The camera's last image: IMAGE_COLOR uint8 [height, width * 4] (RGBA), IMAGE_DEPTH
        float32 [height, width], IMAGE_SEGMENTATION int32 [height, width]."""
        camera = self._camera(sim, env, camera_handle)
        image = self._image(camera, image_type, "get_camera_image")
        return image.reshape(image.shape[0], -1) if int(image_type) == IMAGE_COLOR else image

    def get_camera_image_gpu_tensor(self, sim: Sim, env: Env, camera_handle: int,
                                    image_type) -> Tensor:
        """A tensor on the sim's device that `render_all_camera_sensors` rewrites in place:
        colour [height, width, 4] uint8, depth [height, width] float32, segmentation int32."""
        camera = self._camera(sim, env, camera_handle)
        if not camera.props.enable_tensors:
            raise ValueError("gym.get_camera_image_gpu_tensor: the camera was made without "
                             "CameraProperties.enable_tensors = True")
        kind = int(image_type)
        if kind not in camera.tensors:
            image = self._image(camera, kind, "get_camera_image_gpu_tensor", render_first=True)
            camera.tensors[kind] = torch.from_numpy(image.copy()).to(sim.myriad.device)
        return Tensor(camera.tensors[kind])

    def _image(self, camera, image_type, call: str, render_first: bool = False) -> np.ndarray:
        kind = int(image_type)
        if kind not in (IMAGE_COLOR, IMAGE_DEPTH, IMAGE_SEGMENTATION):
            raise _unsupported(f"gym.{call} with image type {image_type}",
                               "IMAGE_COLOR, IMAGE_DEPTH and IMAGE_SEGMENTATION are")
        if kind not in camera.images:
            if not render_first:
                raise RuntimeError(f"gym.{call}: call gym.render_all_camera_sensors(sim) first")
            camera.env.sim.cameras.render_all()
        return camera.images[kind]

    def get_camera_view_matrix(self, sim: Sim, env: Env, camera_handle: int) -> np.ndarray:
        return self._camera(sim, env, camera_handle).matrices(
            self._envs(sim, "get_camera_view_matrix").rigid_body_states)[0]

    def get_camera_proj_matrix(self, sim: Sim, env: Env, camera_handle: int) -> np.ndarray:
        return self._camera(sim, env, camera_handle).matrices(
            self._envs(sim, "get_camera_proj_matrix").rigid_body_states)[1]

    def get_camera_transform(self, sim: Sim, env: Env, camera_handle: int) -> Transform:
        camera = self._camera(sim, env, camera_handle)
        position, rotation = camera.pose(self._envs(sim, "get_camera_transform")
                                         .rigid_body_states)
        q = np.zeros(4)
        mujoco.mju_mat2Quat(q, np.ascontiguousarray(rotation, dtype=np.float64).ravel())
        return Transform(Vec3(*position), Quat(q[1], q[2], q[3], q[0]))

    def write_camera_image_to_file(self, sim: Sim, env: Env, camera_handle: int, image_type,
                                   filename: str) -> None:
        import imageio.v2 as imageio
        camera = self._camera(sim, env, camera_handle)
        image = self._image(camera, image_type, "write_camera_image_to_file")
        if int(image_type) != IMAGE_COLOR:
            raise _unsupported("gym.write_camera_image_to_file of a depth or segmentation "
                               "image", "colour images are written; read the others with "
                               "get_camera_image")
        imageio.imwrite(filename, image)

    # ------------------------------------------------------------------ assets
    def load_asset(self, sim: Sim, rootpath: str, filename: str,
                   options: AssetOptions | None = None) -> Asset:
        self._before_prepare(sim, "load_asset")
        from myriad.physics.tolerant import asset_spec

        options = AssetOptions() if options is None else options
        _check_asset_options(options)
        path = os.path.join(rootpath, filename)
        spec = asset_spec(path, fix_base_link=bool(options.fix_base_link),
                          package_paths=(rootpath,))
        for sensor in list(spec.sensors):   # Isaac Gym imports no sensors from a file: its
            spec.delete(sensor)             # force sensors come from create_asset_force_sensor
        _weightless_drawing(spec)
        actuators = _take_actuators(spec)
        fixed, keep, speed_limits = _urdf_joint_facts(path)
        asset = _finish_asset(spec, options, path, actuators, (fixed, keep))
        _urdf_speed_limits(asset, speed_limits)
        sim.assets.append(asset)
        return asset

    load_urdf = load_asset
    load_mjcf = load_asset

    def create_box(self, sim: Sim, width: float, height: float, depth: float,
                   options: AssetOptions | None = None) -> Asset:
        """A box of size width (x) × height (y) × depth (z), of the options' density."""
        return self._primitive(sim, "box", options, size=[width / 2, height / 2, depth / 2])

    def create_sphere(self, sim: Sim, radius: float, options: AssetOptions | None = None):
        return self._primitive(sim, "sphere", options, size=[radius, 0, 0])

    def create_capsule(self, sim: Sim, radius: float, width: float,
                       options: AssetOptions | None = None) -> Asset:
        """A capsule along x: `width` the length of its cylindrical part, `radius` its caps'."""
        return self._primitive(sim, "capsule", options, size=[radius, width / 2, 0],
                               quat=[math.cos(math.pi / 4), 0, math.sin(math.pi / 4), 0])

    def _primitive(self, sim, kind, options, size, quat=(1, 0, 0, 0)) -> Asset:
        self._before_prepare(sim, f"create_{kind}")
        options = AssetOptions() if options is None else options
        _check_asset_options(options)
        if min(size[:1]) <= 0 or any(s < 0 for s in size):
            raise ValueError(f"gym.create_{kind}: sizes must be positive, got {size}")
        spec = mujoco.MjSpec()
        body = spec.worldbody.add_body(name=kind)
        body.add_geom(name=kind, type=getattr(mujoco.mjtGeom, f"mjGEOM_{kind.upper()}"),
                      size=list(size), quat=list(quat), density=float(options.density))
        if not options.fix_base_link:
            body.add_freejoint()
        asset = _finish_asset(spec, options, f"create_{kind}{tuple(size)}", [])
        sim.assets.append(asset)
        return asset

    def get_asset_dof_count(self, asset: Asset) -> int:
        return asset.num_dofs

    def get_asset_rigid_body_count(self, asset: Asset) -> int:
        return asset.num_bodies

    def get_asset_rigid_shape_count(self, asset: Asset) -> int:
        return len(asset.shape_geoms)

    def get_asset_joint_count(self, asset: Asset) -> int:
        return len(asset.joint_names)

    def get_asset_actuator_count(self, asset: Asset) -> int:
        return len(asset.actuators)

    def get_asset_dof_names(self, asset: Asset) -> list:
        return list(asset.dof_names)

    def get_asset_dof_name(self, asset: Asset, index: int) -> str:
        return asset.dof_names[index]

    def get_asset_rigid_body_names(self, asset: Asset) -> list:
        return list(asset.body_names)

    def get_asset_rigid_body_name(self, asset: Asset, index: int) -> str:
        return asset.body_names[index]

    def get_asset_joint_names(self, asset: Asset) -> list:
        return list(asset.joint_names)

    def get_asset_dof_dict(self, asset: Asset) -> dict:
        return {n: i for i, n in enumerate(asset.dof_names)}

    def get_asset_rigid_body_dict(self, asset: Asset) -> dict:
        return {n: i for i, n in enumerate(asset.body_names)}

    def get_asset_joint_dict(self, asset: Asset) -> dict:
        return {n: i for i, n in enumerate(asset.joint_names)}

    def find_asset_dof_index(self, asset: Asset, name: str) -> int:
        return asset.dof_names.index(name) if name in asset.dof_names else INVALID_HANDLE

    def find_asset_rigid_body_index(self, asset: Asset, name: str) -> int:
        return asset.body_names.index(name) if name in asset.body_names else INVALID_HANDLE

    def find_asset_joint_index(self, asset: Asset, name: str) -> int:
        return asset.joint_names.index(name) if name in asset.joint_names else INVALID_HANDLE

    def get_asset_dof_type(self, asset: Asset, index: int) -> DofType:
        j = asset.dof_joints[index]
        return (DofType.DOF_TRANSLATION if int(asset.mj.jnt_type[j])
                == int(mujoco.mjtJoint.mjJNT_SLIDE)
                else DofType.DOF_ROTATION)

    def debug_print_asset(self, asset: Asset, outpath: str | None = None) -> None:
        """The asset's bodies, joints, DOFs (with their properties), shapes and tendons, as
        text on stdout or into `outpath`."""
        lines = [repr(asset)]
        lines += [f"body {i}: {n}" for i, n in enumerate(asset.body_names)]
        lines += [f"joint {i}: {n} "
                  f"({self.get_joint_type_string(self.get_asset_joint_type(asset, i))})"
                  for i, n in enumerate(asset.joint_names)]
        for i, (n, p) in enumerate(zip(asset.dof_names, asset.dof_props)):
            fields = ", ".join(f"{k}={p[k]}" for k in DofProperties.names)
            kind = self.get_dof_type_string(self.get_asset_dof_type(asset, i))
            lines.append(f"dof {i}: {n} ({kind}): {fields}")
        lines += [f"shape {i}: geom {g} of body {asset.mj.body(asset.mj.geom_bodyid[g]).name}, "
                  f"friction {p.friction:g}" for i, (g, p) in
                  enumerate(zip(asset.shape_geoms, asset.shape_props))]
        lines += [f"tendon {i}: {n}" for i, n in enumerate(asset.tendon_names)]
        text = "\n".join(lines) + "\n"
        if outpath:
            with open(outpath, "w") as f:
                f.write(text)
        else:
            print(text, end="")

    def get_asset_dof_properties(self, asset: Asset) -> np.ndarray:
        return asset.dof_props.copy()

    def get_asset_rigid_shape_properties(self, asset: Asset) -> list:
        return copy.deepcopy(asset.shape_props)

    def set_asset_rigid_shape_properties(self, asset: Asset, props: list) -> bool:
        _check_shape_props(props, len(asset.shape_geoms), "set_asset_rigid_shape_properties")
        asset.shape_props = copy.deepcopy(list(props))
        return True

    def get_asset_actuator_properties(self, asset: Asset) -> list:
        return copy.deepcopy([a["props"] for a in asset.actuators])

    def get_asset_actuator_name(self, asset: Asset, index: int) -> str:
        return asset.actuators[index]["name"]

    def get_asset_actuator_joint_name(self, asset: Asset, index: int) -> str:
        return asset.actuators[index]["joint"]

    def find_asset_actuator_index(self, asset: Asset, name: str) -> int:
        names = [a["name"] for a in asset.actuators]
        return names.index(name) if name in names else INVALID_HANDLE

    def create_asset_force_sensor(self, asset: Asset, body_idx: int, local_pose: Transform,
                                  props: ForceSensorProperties | None = None) -> int:
        """A force sensor on the asset's body `body_idx` at `local_pose` (in the body's frame):
        in every actor made from the asset afterwards it reads, about that point, what PhysX's
        articulation sensors read: with `enable_forward_dynamics_forces`, minus the articulated
        zero-acceleration force of the body's subtree (gravity, applied forces, joint efforts,
        velocity terms: a link hanging at rest reads minus its subtree's weight), with
        `enable_constraint_solver_forces` the contact forces on the subtree (a foot's ground
        reaction); in the sensor's frame, or in world axes with `use_world_frame`
        (docs/isaacgym.md). Returns its index within the asset."""
        if not isinstance(asset, Asset):
            raise TypeError(f"gym.create_asset_force_sensor: expected an Asset, got "
                            f"{type(asset).__name__}")
        if not 0 <= int(body_idx) < asset.num_bodies:
            raise ValueError(f"gym.create_asset_force_sensor: body_idx={body_idx} is not a body "
                             f"of {asset.source} ({asset.num_bodies} bodies)")
        props = ForceSensorProperties() if props is None else props
        if not isinstance(props, ForceSensorProperties):
            raise TypeError(f"gym.create_asset_force_sensor: props must be a "
                            f"gymapi.ForceSensorProperties, not {type(props).__name__}")
        body = asset.spec.body(asset.body_names[int(body_idx)])
        name = f"force_sensor_{len(asset.force_sensors)}"
        p, r = local_pose.p, local_pose.r.normalize()
        body.add_site(name=name, pos=[p.x, p.y, p.z], quat=[r.w, r.x, r.y, r.z])
        asset.spec.add_sensor(name=f"{name}_force", type=mujoco.mjtSensor.mjSENS_FORCE,
                              objtype=mujoco.mjtObj.mjOBJ_SITE, objname=name)
        asset.spec.add_sensor(name=f"{name}_torque", type=mujoco.mjtSensor.mjSENS_TORQUE,
                              objtype=mujoco.mjtObj.mjOBJ_SITE, objname=name)
        asset.force_sensors.append(name)
        asset.force_sensor_flags.append((bool(props.enable_forward_dynamics_forces),
                                         bool(props.enable_constraint_solver_forces),
                                         bool(props.use_world_frame)))
        return len(asset.force_sensors) - 1

    def create_rigid_body_attractor(self, env: Env, props: AttractorProperties) -> int:
        """Holds the point `offset` of the body `rigid_handle` (an env-domain body handle) at
        `target` (the env's frame): on all translation axes (AXIS_TRANSLATION) a ball joint to
        the world, on all axes (AXIS_ALL) a weld. Myriad holds it as a hard constraint (Isaac
        Gym's stiffness and damping are springs); every env must hold the same attractors."""
        if not isinstance(env, Env):
            raise TypeError(f"gym.create_rigid_body_attractor: expected an Env, got "
                            f"{type(env).__name__}")
        self._before_prepare(env.sim, "create_rigid_body_attractor")
        axes = int(props.axes)
        if axes not in (AXIS_TRANSLATION, AXIS_ALL):
            raise _unsupported(f"gym.create_rigid_body_attractor with axes={axes}",
                               "AXIS_TRANSLATION (a ball joint) and AXIS_ALL (a weld) are")
        handle = int(props.rigid_handle)
        for k, actor in enumerate(env.actors):
            if actor.body_offset <= handle < actor.body_offset + actor.asset.num_bodies:
                break
        else:
            raise ValueError(f"gym.create_rigid_body_attractor: rigid_handle={handle} is not a "
                             f"body of env {env.index}")
        if float(props.stiffness) < 1e6:
            _warn_once(f"an attractor of stiffness {props.stiffness:g} N/m is held as a hard "
                       "constraint (Myriad has no attractor springs)")
        env.attractors.append((k, handle - actor.body_offset, copy.deepcopy(props)))
        return len(env.attractors) - 1

    def set_attractor_target(self, env: Env, attractor_handle: int, target: Transform) -> None:
        """Moves the attractor's target (the env's frame) in this env alone, before or after
        prepare_sim (the constraint's world point, and its orientation for a weld)."""
        props = self._attractor(env, attractor_handle, "set_attractor_target")
        props.target = copy.deepcopy(target)
        if env.sim.myriad is not None:
            _apply_attractor_targets(env.sim, [env])

    def set_attractor_properties(self, env: Env, attractor_handle: int,
                                 props: AttractorProperties) -> None:
        """A new target (as set_attractor_target), stiffness or damping (Myriad holds every
        attractor as a hard constraint); its body, offset and axes are fixed at creation."""
        old = self._attractor(env, attractor_handle, "set_attractor_properties")
        fixed = [f for f in ("axes", "rigid_handle")
                 if int(getattr(props, f)) != int(getattr(old, f))]
        if props.offset.p != old.offset.p or props.offset.r != old.offset.r:
            fixed.append("offset")
        if fixed:
            raise _unsupported(f"gym.set_attractor_properties changing {fixed}", "an attractor's "
                               "body, offset and axes are set by create_rigid_body_attractor")
        if float(props.stiffness) < 1e6:
            _warn_once(f"an attractor of stiffness {props.stiffness:g} N/m is held as a hard "
                       "constraint (Myriad has no attractor springs)")
        old.stiffness, old.damping = float(props.stiffness), float(props.damping)
        self.set_attractor_target(env, attractor_handle, props.target)

    def get_attractor_properties(self, env: Env, attractor_handle: int) -> AttractorProperties:
        return copy.deepcopy(self._attractor(env, attractor_handle, "get_attractor_properties"))

    def _attractor(self, env: Env, handle: int, call: str) -> AttractorProperties:
        if not isinstance(env, Env):
            raise TypeError(f"gym.{call}: expected an Env, got {type(env).__name__}")
        if not 0 <= int(handle) < len(env.attractors):
            raise ValueError(f"gym.{call}: attractor handle {handle}; env {env.index} has "
                             f"{len(env.attractors)} attractor(s)")
        return env.attractors[int(handle)][2]

    def begin_aggregate(self, env: Env, max_bodies: int, max_shapes: int,
                        self_collisions: bool) -> bool:
        """PhysX's broad-phase grouping of an env's actors: no effect on the motion, none here
        (collisions between the actors follow their collision groups and filters)."""
        if not isinstance(env, Env):
            raise TypeError(f"gym.begin_aggregate: expected an Env, got {type(env).__name__}")
        return True

    def create_aggregate(self, env: Env, actors: list) -> bool:
        """The CPU pipeline's form of begin/end_aggregate, for actors already created: no
        effect on the motion here either."""
        for handle in actors:
            self._actor(env, handle)
        return True

    def end_aggregate(self, env: Env) -> bool:
        if not isinstance(env, Env):
            raise TypeError(f"gym.end_aggregate: expected an Env, got {type(env).__name__}")
        return True

    def enable_actor_dof_force_sensors(self, env: Env, handle: int) -> bool:
        """Isaac Gym computes the DOF force tensor only for actors enabled here; Myriad computes
        it for every actor, so this only checks the handle."""
        self._actor(env, handle)
        return True

    def get_asset_tendon_count(self, asset: Asset) -> int:
        return len(asset.tendon_names)

    def get_asset_tendon_name(self, asset: Asset, index: int) -> str:
        return asset.tendon_names[int(index)]

    def find_asset_tendon_index(self, asset: Asset, name: str) -> int:
        return asset.tendon_names.index(name) if name in asset.tendon_names else INVALID_HANDLE

    def get_asset_tendon_properties(self, asset: Asset) -> list:
        return copy.deepcopy(asset.tendon_props)

    def set_asset_tendon_properties(self, asset: Asset, props: list) -> bool:
        """Each tendon's limit stiffness and damping (PhysX's semantics); its limits, spring and
        joints stay the file's. Actors created after this take them."""
        asset.tendon_props = _checked_tendon_props("set_asset_tendon_properties", asset, props)
        return True

    def get_actor_tendon_properties(self, env: Env, handle: int) -> list:
        return copy.deepcopy(self._actor(env, handle).tendon_props)

    def set_actor_tendon_properties(self, env: Env, handle: int, props: list) -> bool:
        """This actor's tendons' limit stiffness and damping, in its env alone, before or after
        prepare_sim (its limits, spring and joints stay the asset's)."""
        actor = self._actor(env, handle)
        actor.tendon_props = _checked_tendon_props("set_actor_tendon_properties", actor.asset,
                                                   props)
        if env.sim.myriad is not None:
            _apply_tendon_props(env.sim, [actor])
        return True

    def get_actor_tendon_offset(self, env: Env, handle: int, index: int) -> float:
        actor = self._actor(env, handle)
        return actor.tendon_offsets[self._tendon(actor.asset, index, "get_actor_tendon_offset")]

    def set_actor_tendon_offset(self, env: Env, handle: int, index: int, offset: float) -> bool:
        """PhysX's length offset of one of this actor's tendons, in its env alone: added to
        the accumulated length Σ coef·q where the spring reads it, so that an offset actuates
        the tendon (shortens or lengthens it); the length limits stay on Σ coef·q."""
        actor = self._actor(env, handle)
        actor.tendon_offsets[self._tendon(actor.asset, index, "set_actor_tendon_offset")] = \
            float(offset)
        if env.sim.myriad is not None:
            _apply_tendon_props(env.sim, [actor])
        return True

    def get_asset_force_sensor_count(self, asset: Asset) -> int:
        return len(asset.force_sensors)

    def get_actor_force_sensor_count(self, env: Env, handle: int) -> int:
        return len(self._actor(env, handle).asset.force_sensors)

    def get_actor_force_sensor(self, env: Env, handle: int, index: int) -> ForceSensor:
        """The actor's force sensor `index` (creation order in its asset), after prepare_sim:
        `get_forces()` reads it from the sim's force sensor tensor (refreshed first), and
        `get_global_index()` is its row there."""
        actor = self._actor(env, handle)
        count = len(actor.asset.force_sensors)
        if not 0 <= int(index) < count:
            raise IndexError(f"gym.get_actor_force_sensor: actor {actor.name!r} has {count} "
                             f"force sensors; index {index} is not one")
        sim = env.sim
        if sim.myriad is None:
            raise RuntimeError("gym.get_actor_force_sensor: call gym.prepare_sim first (the "
                               "sensors read the prepared sim)")
        before = sum(len(a.asset.force_sensors) for a in env.actors[:env.actors.index(actor)])
        per_env = len(sim.sensor_flags)
        return ForceSensor(sim, env.index * per_env + before + int(index))

    def get_sim_force_sensor_count(self, sim: Sim) -> int:
        return sum(len(a.asset.force_sensors) for env in sim.envs for a in env.actors)

    def acquire_force_sensor_tensor(self, sim: Sim) -> Tensor:
        """[envs · sensors per env, 6]: force then torque, env by env, actor by actor, each
        actor's sensors in creation order."""
        envs = self._envs(sim, "acquire_force_sensor_tensor")
        return Tensor(sim.myriad_views("force_sensor", envs))

    def refresh_force_sensor_tensor(self, sim: Sim) -> bool:
        self._envs(sim, "refresh_force_sensor_tensor")
        _refresh_force_sensors(sim)
        return True

    def get_asset_rigid_body_shape_indices(self, asset: Asset) -> list:
        out = []
        for b in asset.body_ids:
            geoms = [i for i, g in enumerate(asset.shape_geoms) if asset.mj.geom_bodyid[g] == b]
            out.append(IndexRange(geoms[0] if geoms else 0, len(geoms)))
        return out

    # ------------------------------------------------------------------ envs and actors
    def create_env(self, sim: Sim, lower: Vec3, upper: Vec3, num_per_row: int) -> Env:
        self._before_prepare(sim, "create_env")
        env = Env(sim, len(sim.envs), lower, upper, num_per_row)
        sim.envs.append(env)
        return env

    def get_env(self, sim: Sim, index: int) -> Env:
        return sim.envs[index]

    def get_env_count(self, sim: Sim) -> int:
        return len(sim.envs)

    def get_env_origin(self, env: Env) -> Vec3:
        return Vec3(env.origin.x, env.origin.y, env.origin.z)

    def create_actor(self, env: Env, asset: Asset, pose: Transform, name: str | None = None,
                     group: int = -1, filter: int = -1, segmentationId: int = 0) -> int:
        self._before_prepare(env.sim, "create_actor")
        if not isinstance(asset, Asset):
            raise TypeError(f"gym.create_actor: expected an Asset, got {type(asset).__name__}")
        index = len(env.actors)
        actor = _Actor(env, index, asset, pose, name if name is not None else f"actor{index}",
                       group, filter, segmentationId)
        if env.actors:
            last = env.actors[-1]
            actor.body_offset = last.body_offset + last.asset.num_bodies
            actor.dof_offset = last.dof_offset + last.asset.num_dofs
            actor.joint_offset = last.joint_offset + len(last.asset.joint_names)
        env.actors.append(actor)
        return index

    def get_actor_count(self, env: Env) -> int:
        return len(env.actors)

    def get_sim_actor_count(self, sim: Sim) -> int:
        return sum(len(e.actors) for e in sim.envs)

    def get_sim_dof_count(self, sim: Sim) -> int:
        return sum(a.asset.num_dofs for e in sim.envs for a in e.actors)

    def get_sim_rigid_body_count(self, sim: Sim) -> int:
        return sum(a.asset.num_bodies for e in sim.envs for a in e.actors)

    def get_env_dof_count(self, env: Env) -> int:
        return sum(a.asset.num_dofs for a in env.actors)

    def get_env_rigid_body_count(self, env: Env) -> int:
        return sum(a.asset.num_bodies for a in env.actors)

    def _actor(self, env: Env, handle: int) -> _Actor:
        if not isinstance(env, Env):
            raise TypeError(f"expected an Env (from gym.create_env), got {type(env).__name__}")
        if not 0 <= int(handle) < len(env.actors):
            raise IndexError(f"env {env.index} has no actor handle {handle} (it has "
                             f"{len(env.actors)} actors)")
        return env.actors[int(handle)]

    def get_actor_name(self, env: Env, handle: int) -> str:
        return self._actor(env, handle).name

    def get_actor_handle(self, env: Env, index: int) -> int:
        self._actor(env, index)
        return int(index)

    def find_actor_handle(self, env: Env, name: str) -> int:
        for a in env.actors:
            if a.name == name:
                return a.index
        return INVALID_HANDLE

    def get_actor_asset(self, env: Env, handle: int) -> Asset:
        return self._actor(env, handle).asset

    def get_actor_index(self, env: Env, handle: int, domain: IndexDomain) -> int:
        actor = self._actor(env, handle)
        if int(domain) == IndexDomain.DOMAIN_SIM:
            return env.index * len(env.actors) + actor.index
        return actor.index

    def find_actor_index(self, env: Env, name: str, domain: IndexDomain) -> int:
        handle = self.find_actor_handle(env, name)
        return INVALID_HANDLE if handle < 0 else self.get_actor_index(env, handle, domain)

    def get_actor_dof_count(self, env: Env, handle: int) -> int:
        return self._actor(env, handle).asset.num_dofs

    def get_actor_rigid_body_count(self, env: Env, handle: int) -> int:
        return self._actor(env, handle).asset.num_bodies

    def get_actor_rigid_shape_count(self, env: Env, handle: int) -> int:
        return len(self._actor(env, handle).asset.shape_geoms)

    def get_actor_joint_count(self, env: Env, handle: int) -> int:
        return len(self._actor(env, handle).asset.joint_names)

    def get_actor_dof_names(self, env: Env, handle: int) -> list:
        return list(self._actor(env, handle).asset.dof_names)

    def get_actor_rigid_body_names(self, env: Env, handle: int) -> list:
        return list(self._actor(env, handle).asset.body_names)

    def get_actor_joint_names(self, env: Env, handle: int) -> list:
        return list(self._actor(env, handle).asset.joint_names)

    def get_actor_dof_dict(self, env: Env, handle: int) -> dict:
        return self.get_asset_dof_dict(self._actor(env, handle).asset)

    # ------------------------------------------------------------------ per-actor state
    # Isaac Gym's older, non-tensor calls (its examples use them): numpy in and out, one actor
    # at a time, on top of the tensor calls (each set_* here is one indexed tensor write)
    def _actor_slice(self, env: Env, handle: int, call: str):
        actor = self._actor(env, handle)
        envs = self._envs(env.sim, call)
        return envs, actor, slice(actor.dof_offset, actor.dof_offset + actor.asset.num_dofs)

    def _sim_index(self, env: Env, actor) -> Tensor:
        index = env.index * len(env.actors) + actor.index
        return Tensor(torch.tensor([index], dtype=torch.int32, device=env.sim.myriad.device))

    def get_actor_dof_states(self, env: Env, handle: int, flags: int = STATE_ALL) -> np.ndarray:
        envs, actor, dofs = self._actor_slice(env, handle, "get_actor_dof_states")
        self._refresh(env.sim, "get_actor_dof_states")
        out = np.zeros(actor.asset.num_dofs, dtype=DofState)
        values = envs.dof_state[env.index, dofs].cpu().numpy()
        if int(flags) & STATE_POS:
            out["pos"] = values[:, 0]
        if int(flags) & STATE_VEL:
            out["vel"] = values[:, 1]
        return out

    def set_actor_dof_states(self, env: Env, handle: int, dof_states,
                             flags: int = STATE_ALL) -> bool:
        envs, actor, dofs = self._actor_slice(env, handle, "set_actor_dof_states")
        states = np.asarray(dof_states)
        if states.shape != (actor.asset.num_dofs,):
            raise ValueError(f"gym.set_actor_dof_states: {states.shape} states for actor "
                             f"{actor.name!r}'s {actor.asset.num_dofs} DOFs")
        self._refresh(env.sim, "set_actor_dof_states")
        values = envs.dof_state.clone()
        for bit, field, column in ((STATE_POS, "pos", 0), (STATE_VEL, "vel", 1)):
            if int(flags) & bit:
                values[env.index, dofs, column] = torch.as_tensor(
                    np.asarray(states[field], np.float32), device=envs.device)
        return self.set_dof_state_tensor_indexed(env.sim, Tensor(values.view(-1, 2)),
                                                 self._sim_index(env, actor), 1)

    def get_actor_rigid_body_states(self, env: Env, handle: int,
                                    flags: int = STATE_ALL) -> np.ndarray:
        actor = self._actor(env, handle)
        return self._body_states(env, slice(actor.body_offset,
                                            actor.body_offset + actor.asset.num_bodies), flags)

    def get_env_rigid_body_states(self, env: Env, flags: int = STATE_ALL) -> np.ndarray:
        return self._body_states(env, slice(None), flags)

    def _body_states(self, env: Env, bodies: slice, flags: int) -> np.ndarray:
        rows = self._body_row(env, "get_actor_rigid_body_states")[bodies].cpu()
        out = np.zeros(len(rows), dtype=RigidBodyState)
        x = rows.numpy()
        if int(flags) & STATE_POS:
            for k, name in enumerate("xyz"):
                out["pose"]["p"][name] = x[:, k]
            for k, name in enumerate("xyzw"):
                out["pose"]["r"][name] = x[:, 3 + k]
        if int(flags) & STATE_VEL:
            for k, name in enumerate("xyz"):
                out["vel"]["linear"][name] = x[:, 7 + k]
                out["vel"]["angular"][name] = x[:, 10 + k]
        return out

    def get_actor_dof_forces(self, env: Env, handle: int) -> np.ndarray:
        envs, actor, dofs = self._actor_slice(env, handle, "get_actor_dof_forces")
        self._refresh(env.sim, "get_actor_dof_forces")
        return envs.dof_forces[env.index, dofs].cpu().numpy().astype(np.float32)

    def apply_actor_dof_efforts(self, env: Env, handle: int, efforts) -> bool:
        envs, actor, dofs = self._actor_slice(env, handle, "apply_actor_dof_efforts")
        values = envs.sim.joint_force[:, envs.dof_columns].clone()
        values[env.index, dofs] = torch.as_tensor(np.asarray(efforts, np.float32),
                                                  device=envs.device)
        return self.set_dof_actuation_force_tensor(env.sim, Tensor(values.reshape(-1)))

    def _actor_targets(self, env, handle, targets, kind, call) -> bool:
        envs, actor, dofs = self._actor_slice(env, handle, call)
        store = env.sim.position_targets if kind == "pos" else env.sim.velocity_targets
        values = store.clone()
        values[env.index, dofs] = torch.as_tensor(np.asarray(targets, np.float32),
                                                  device=envs.device)
        return self._set_targets(env.sim, call, Tensor(values.reshape(-1)), kind)

    def set_actor_dof_position_targets(self, env: Env, handle: int, targets) -> bool:
        return self._actor_targets(env, handle, targets, "pos", "set_actor_dof_position_targets")

    def set_actor_dof_velocity_targets(self, env: Env, handle: int, targets) -> bool:
        return self._actor_targets(env, handle, targets, "vel", "set_actor_dof_velocity_targets")

    def get_actor_dof_position_targets(self, env: Env, handle: int) -> np.ndarray:
        envs, actor, dofs = self._actor_slice(env, handle, "get_actor_dof_position_targets")
        return env.sim.position_targets[env.index, dofs].cpu().numpy().astype(np.float32)

    def get_actor_dof_velocity_targets(self, env: Env, handle: int) -> np.ndarray:
        envs, actor, dofs = self._actor_slice(env, handle, "get_actor_dof_velocity_targets")
        return env.sim.velocity_targets[env.index, dofs].cpu().numpy().astype(np.float32)

    def set_actor_scale(self, env: Env, handle: int, scale: float) -> bool:
        """Scales a single-body actor (an object) in this env before prepare_sim: its shapes'
        sizes and positions × scale, its mass × scale³ and inertia × scale⁵. Primitive shapes
        only (Myriad cannot scale a mesh or a height field per env)."""
        actor = self._actor(env, handle)
        self._before_prepare(env.sim, "set_actor_scale")
        scale = float(scale)
        if not scale > 0:
            raise ValueError(f"gym.set_actor_scale: scale={scale} must be > 0")
        if scale != 1.0:
            if actor.asset.num_bodies != 1:
                raise _unsupported(f"gym.set_actor_scale on actor {actor.name!r} with "
                                   f"{actor.asset.num_bodies} bodies", "single-body actors "
                                   "(objects) can be scaled")
            m = actor.asset.mj
            meshes = [m.geom(g).name or str(g) for g in actor.asset.shape_geoms
                      if int(m.geom_type[g]) in (int(mujoco.mjtGeom.mjGEOM_MESH),
                                                  int(mujoco.mjtGeom.mjGEOM_HFIELD),
                                                  int(mujoco.mjtGeom.mjGEOM_PLANE))]
            if meshes:
                raise _unsupported(f"gym.set_actor_scale on actor {actor.name!r}, whose shapes "
                                   f"{meshes} are meshes", "primitive shapes can be scaled")
        actor.scale = scale
        return True

    def get_actor_scale(self, env: Env, handle: int) -> float:
        return self._actor(env, handle).scale

    def get_actor_joint_dict(self, env: Env, handle: int) -> dict:
        return self.get_asset_joint_dict(self._actor(env, handle).asset)

    def get_rigid_transform(self, env: Env, handle: int) -> Transform:
        """The pose of the env's body `handle` (env-domain), in the env's frame: from the
        simulated state once the sim is prepared; before, the pose it starts in (its actor's
        pose, the asset's joints at their defaults)."""
        actor, _ = self._body(env, handle, "get_rigid_transform")
        if env.sim.myriad is not None:
            x = self._body_row(env, "get_rigid_transform")[int(handle)].tolist()
            return Transform(Vec3(*x[:3]), Quat(*x[3:7]))
        return actor.pose * actor.asset.start_pose(int(handle) - actor.body_offset)

    def get_actor_rigid_body_dict(self, env: Env, handle: int) -> dict:
        return self.get_asset_rigid_body_dict(self._actor(env, handle).asset)

    def find_actor_dof_handle(self, env: Env, handle: int, name: str) -> int:
        actor = self._actor(env, handle)
        i = self.find_asset_dof_index(actor.asset, name)
        return INVALID_HANDLE if i < 0 else actor.dof_offset + i

    def find_actor_dof_index(self, env: Env, handle: int, name: str, domain) -> int:
        actor = self._actor(env, handle)
        i = self.find_asset_dof_index(actor.asset, name)
        if i < 0:
            return INVALID_HANDLE
        return self._in_domain(env, actor, i, domain, "DOF")

    def find_actor_rigid_body_handle(self, env: Env, handle: int, name: str) -> int:
        actor = self._actor(env, handle)
        i = self.find_asset_rigid_body_index(actor.asset, name)
        return INVALID_HANDLE if i < 0 else actor.body_offset + i

    def find_actor_rigid_body_index(self, env: Env, handle: int, name: str, domain) -> int:
        actor = self._actor(env, handle)
        i = self.find_asset_rigid_body_index(actor.asset, name)
        if i < 0:
            return INVALID_HANDLE
        return self._in_domain(env, actor, i, domain, "body")

    def get_actor_rigid_body_index(self, env: Env, handle: int, index: int, domain) -> int:
        return self._in_domain(env, self._actor(env, handle), int(index), domain, "body")

    def get_actor_dof_index(self, env: Env, handle: int, index: int, domain) -> int:
        return self._in_domain(env, self._actor(env, handle), int(index), domain, "DOF")

    def get_actor_root_rigid_body_handle(self, env: Env, handle: int) -> int:
        return self._actor(env, handle).body_offset

    def _in_domain(self, env, actor, i, domain, kind) -> int:
        """The actor's `i`-th body, DOF or joint (`kind`) indexed in `domain`."""
        offset = self._span(actor, kind)[0]
        if int(domain) == IndexDomain.DOMAIN_ACTOR:
            return i
        if int(domain) == IndexDomain.DOMAIN_ENV:
            return offset + i
        return env.index * sum(self._span(a, kind)[1] for a in env.actors) + offset + i

    # ------------------------------------------------------------------ one body, DOF, joint
    # Isaac Gym's older calls on one body, DOF or joint by its handle (env domain), as its
    # examples and many scripts use them; they read and write the same state as the tensors
    def _span(self, actor, kind: str) -> tuple[int, int]:
        """(first env-domain handle, count) of the actor's bodies, DOFs or joints."""
        return {"body": (actor.body_offset, actor.asset.num_bodies),
                "DOF": (actor.dof_offset, actor.asset.num_dofs),
                "joint": (actor.joint_offset, len(actor.asset.joint_names))}[kind]

    def _owner(self, env: Env, handle: int, kind: str, call: str):
        """(actor, index within the actor) of the env-domain body, DOF or joint `handle`."""
        h = int(handle)
        for a in env.actors:
            first, count = self._span(a, kind)
            if first <= h < first + count:
                return a, h - first
        total = sum(self._span(a, kind)[1] for a in env.actors)
        name, plural = {"body": ("rigid body", "bodies"), "DOF": ("DOF", "DOFs"),
                        "joint": ("joint", "joints")}[kind]
        raise ValueError(f"gym.{call}: {handle} is not a {name} handle of env {env.index} (it "
                         f"has {total} {plural})")

    def _body(self, env: Env, handle: int, call: str):
        """(actor, env-domain body index) of body handle `handle` in `env`."""
        actor, _ = self._owner(env, handle, "body", call)
        return actor, int(handle)

    def _dof(self, env: Env, handle: int, call: str) -> int:
        self._owner(env, handle, "DOF", call)
        return int(handle)

    def _joint(self, env: Env, handle: int, call: str):
        """(actor, the joint's index in its asset) of joint handle `handle` in `env`."""
        return self._owner(env, handle, "joint", call)

    def _body_row(self, env: Env, call: str) -> torch.Tensor:
        """The env's rigid body states [bodies, 13] (env frame), refreshed."""
        envs = self._envs(env.sim, call)
        self._refresh(env.sim, call)
        return envs.rigid_body_states[env.index]

    def get_rigid_handle(self, env: Env, actor_name: str, body_name: str) -> int:
        actor = self.find_actor_handle(env, actor_name)
        return INVALID_HANDLE if actor < 0 else \
            self.find_actor_rigid_body_handle(env, actor, body_name)

    def get_rigid_name(self, env: Env, handle: int) -> str:
        actor, b = self._body(env, handle, "get_rigid_name")
        return actor.asset.body_names[b - actor.body_offset]

    def get_actor_rigid_body_handle(self, env: Env, handle: int, index: int) -> int:
        return self._handle_of(env, handle, index, "body", "get_actor_rigid_body_handle")

    def get_actor_dof_handle(self, env: Env, handle: int, index: int) -> int:
        return self._handle_of(env, handle, index, "DOF", "get_actor_dof_handle")

    def get_actor_joint_handle(self, env: Env, handle: int, index: int) -> int:
        return self._handle_of(env, handle, index, "joint", "get_actor_joint_handle")

    def _handle_of(self, env: Env, handle: int, index: int, kind: str, call: str) -> int:
        """The env-domain handle of the actor's `index`-th body, DOF or joint."""
        actor = self._actor(env, handle)
        offset, count = self._span(actor, kind)
        if not 0 <= int(index) < count:
            plural = "bodies" if kind == "body" else kind + "s"
            raise IndexError(f"gym.{call}: actor {actor.name!r} has {count} {plural}, not an "
                             f"index {index}")
        return offset + int(index)

    def find_actor_joint_handle(self, env: Env, handle: int, name: str) -> int:
        actor = self._actor(env, handle)
        i = self.find_asset_joint_index(actor.asset, name)
        return INVALID_HANDLE if i < 0 else actor.joint_offset + i

    def get_joint_handle(self, env: Env, actor_name: str, joint_name: str) -> int:
        actor = self.find_actor_handle(env, actor_name)
        return INVALID_HANDLE if actor < 0 else \
            self.find_actor_joint_handle(env, actor, joint_name)

    def get_actor_joint_index(self, env: Env, handle: int, index: int, domain) -> int:
        return self._in_domain(env, self._actor(env, handle), int(index), domain, "joint")

    def find_actor_joint_index(self, env: Env, handle: int, name: str, domain) -> int:
        i = self.find_asset_joint_index(self._actor(env, handle).asset, name)
        return INVALID_HANDLE if i < 0 else self.get_actor_joint_index(env, handle, i, domain)

    def get_joint_name(self, env: Env, handle: int) -> str:
        actor, j = self._joint(env, handle, "get_joint_name")
        return actor.asset.joint_names[j]

    def get_asset_joint_name(self, asset: Asset, index: int) -> str:
        return asset.joint_names[index]

    def get_asset_joint_type(self, asset: Asset, index: int) -> JointType:
        j = asset.joint_mj[index]
        if j < 0:
            return JointType.JOINT_FIXED
        return {int(mujoco.mjtJoint.mjJNT_HINGE): JointType.JOINT_REVOLUTE,
                int(mujoco.mjtJoint.mjJNT_SLIDE): JointType.JOINT_PRISMATIC,
                int(mujoco.mjtJoint.mjJNT_BALL): JointType.JOINT_BALL,
                int(mujoco.mjtJoint.mjJNT_FREE): JointType.JOINT_FLOATING}[
                    int(asset.mj.jnt_type[j])]

    def get_env_joint_count(self, env: Env) -> int:
        return sum(len(a.asset.joint_names) for a in env.actors)

    def get_sim_joint_count(self, sim: Sim) -> int:
        return sum(self.get_env_joint_count(e) for e in sim.envs)

    def get_dof_type_string(self, dof_type) -> str:
        return DofType(int(dof_type)).name

    def get_joint_type_string(self, joint_type) -> str:
        return JointType(int(joint_type)).name

    def get_actor_rigid_body_shape_indices(self, env: Env, handle: int) -> list:
        """Each body's shapes as a range of the actor's own shapes (the order of
        get_actor_rigid_shape_properties)."""
        return self.get_asset_rigid_body_shape_indices(self._actor(env, handle).asset)

    # actuators and fixed tendons of an actor: its asset's (Myriad keeps them per asset)
    def get_actor_actuator_count(self, env: Env, handle: int) -> int:
        return self.get_asset_actuator_count(self._actor(env, handle).asset)

    def get_actor_actuator_name(self, env: Env, handle: int, index: int) -> str:
        return self.get_asset_actuator_name(self._actor(env, handle).asset, index)

    def get_actor_actuator_joint_name(self, env: Env, handle: int, index: int) -> str:
        return self.get_asset_actuator_joint_name(self._actor(env, handle).asset, index)

    def get_actor_actuator_properties(self, env: Env, handle: int) -> list:
        return self.get_asset_actuator_properties(self._actor(env, handle).asset)

    def find_actor_actuator_index(self, env: Env, handle: int, name: str) -> int:
        return self.find_asset_actuator_index(self._actor(env, handle).asset, name)

    def get_actor_tendon_count(self, env: Env, handle: int) -> int:
        return self.get_asset_tendon_count(self._actor(env, handle).asset)

    def get_actor_tendon_name(self, env: Env, handle: int, index: int) -> str:
        return self.get_asset_tendon_name(self._actor(env, handle).asset, index)

    def find_actor_tendon_index(self, env: Env, handle: int, name: str) -> int:
        return self.find_asset_tendon_index(self._actor(env, handle).asset, name)

    def _tendon(self, asset: Asset, tendon: int, call: str) -> int:
        """The asset's tendon index `tendon`, checked."""
        if not 0 <= int(tendon) < len(asset.tendon_names):
            raise IndexError(f"gym.{call}: the asset has {len(asset.tendon_names)} tendons, not "
                             f"an index {tendon}")
        return int(tendon)

    def _tendon_wraps(self, asset: Asset, tendon: int, call: str) -> range:
        t = self._tendon(asset, tendon, call)
        adr = int(asset.mj.tendon_adr[t])
        return range(adr, adr + int(asset.mj.tendon_num[t]))

    def get_asset_fixed_tendon_joint_coefficients(self, asset: Asset, tendon: int) -> list:
        wraps = self._tendon_wraps(asset, tendon, "get_asset_fixed_tendon_joint_coefficients")
        own = asset.tendon_coefs.get(int(tendon))
        return list(own) if own is not None else [float(asset.mj.wrap_prm[w]) for w in wraps]

    def _tendon_coefs(self, asset: Asset, tendon: int, coefficients, call: str) -> list:
        """`coefficients` for the tendon's joints, checked: one per joint, none zero (each
        joint takes the tendon's force times 1/coef, PhysX's recipCoefficient)."""
        wraps = self._tendon_wraps(asset, tendon, call)
        coefs = [float(c) for c in coefficients]
        if len(coefs) != len(wraps) or not all(np.isfinite(coefs)) or 0.0 in coefs:
            raise ValueError(f"gym.{call}: tendon {asset.tendon_names[int(tendon)]!r} couples "
                             f"{len(wraps)} joints: give {len(wraps)} finite, non-zero "
                             f"coefficients, not {coefs}")
        return coefs

    def set_asset_fixed_tendon_joint_coefficients(self, asset: Asset, tendon: int,
                                                  coefficients) -> bool:
        """The tendon's joint coefficients (its length is Σ coef·q) for the actors created
        from the asset after this call."""
        asset.tendon_coefs[int(tendon)] = self._tendon_coefs(
            asset, tendon, coefficients, "set_asset_fixed_tendon_joint_coefficients")
        return True

    def set_actor_fixed_tendon_joint_coefficients(self, env: Env, handle: int, tendon: int,
                                                  coefficients) -> bool:
        """The actor's tendon joint coefficients, before `prepare_sim`. Myriad's envs share
        them: every env's actor must end up with the same ones (prepare_sim says which env
        differs), and after prepare_sim they cannot change."""
        actor = self._actor(env, handle)
        call = "set_actor_fixed_tendon_joint_coefficients"
        coefs = self._tendon_coefs(actor.asset, tendon, coefficients, call)
        if env.sim.myriad is not None:
            raise _unsupported(f"gym.{call} after prepare_sim",
                               "the coefficients are compiled into the model all envs share: "
                               "set them before prepare_sim")
        actor.tendon_coefs[int(tendon)] = coefs
        return True

    def get_asset_fixed_tendon_joint_name(self, asset: Asset, tendon: int, joint: int) -> str:
        wraps = self._tendon_wraps(asset, tendon, "get_asset_fixed_tendon_joint_name")
        return asset.mj.joint(int(asset.mj.wrap_objid[wraps[int(joint)]])).name

    def find_actor_fixed_tendon_joint_index(self, env: Env, handle: int, tendon: int,
                                            name: str) -> int:
        asset = self._actor(env, handle).asset
        wraps = self._tendon_wraps(asset, tendon, "find_actor_fixed_tendon_joint_index")
        names = [asset.mj.joint(int(asset.mj.wrap_objid[w])).name for w in wraps]
        return names.index(name) if name in names else INVALID_HANDLE

    def get_actor_fixed_tendon_joint_coefficients(self, env: Env, handle: int,
                                                  tendon: int) -> list:
        actor = self._actor(env, handle)
        own = actor.tendon_coefs.get(int(tendon))
        if own is not None:
            self._tendon(actor.asset, tendon, "get_actor_fixed_tendon_joint_coefficients")
            return list(own)
        return self.get_asset_fixed_tendon_joint_coefficients(actor.asset, tendon)

    def get_actor_fixed_tendon_joint_name(self, env: Env, handle: int, tendon: int,
                                          joint: int) -> str:
        return self.get_asset_fixed_tendon_joint_name(self._actor(env, handle).asset, tendon,
                                                      joint)

    # bodies: poses and velocities in the env's frame; setting one moves an actor's root
    def _vec3(self, env: Env, handle: int, columns: slice, call: str) -> Vec3:
        self._body(env, handle, call)
        return Vec3(*self._body_row(env, call)[int(handle), columns].tolist())

    def get_rigid_linear_velocity(self, env: Env, handle: int) -> Vec3:
        return self._vec3(env, handle, slice(7, 10), "get_rigid_linear_velocity")

    def get_rigid_angular_velocity(self, env: Env, handle: int) -> Vec3:
        return self._vec3(env, handle, slice(10, 13), "get_rigid_angular_velocity")

    def _set_root(self, env: Env, actor, state: torch.Tensor, columns, call: str) -> None:
        """Write `columns` of the actor's root state [13] in env (the others as they are)."""
        envs = self._envs(env.sim, call)
        new = self._root_now(envs).clone()
        new[env.index, actor.index, columns] = state[columns].to(new)
        only = torch.zeros(envs.num_envs, dtype=torch.bool, device=envs.device)
        only[env.index] = True
        envs.set_root_states(new, env_ids=only, forward=False)
        envs.sim.forward()

    def get_vec_rigid_transform(self, envs: list, handle) -> np.ndarray:
        """A body's pose in each of `envs` (in its env's frame), as Transform records: body
        `handle` in every env, or handle[i] in envs[i]."""
        rows = self._vec_rows(envs, handle, "get_vec_rigid_transform")
        out = np.zeros(len(rows), Transform.dtype)
        out["p"], out["r"] = _records(rows[:, :3]), _records(rows[:, 3:7], Quat.dtype)
        return out

    def get_vec_rigid_linear_velocity(self, envs: list, handle) -> np.ndarray:
        return _records(self._vec_rows(envs, handle, "get_vec_rigid_linear_velocity")[:, 7:10])

    def get_vec_rigid_angular_velocity(self, envs: list, handle) -> np.ndarray:
        return _records(self._vec_rows(envs, handle, "get_vec_rigid_angular_velocity")[:, 10:])

    def _vec_rows(self, envs: list, handles, call: str) -> np.ndarray:
        """[len(envs), 13] states of a body in each env (one read for all): body `handles`
        in every env, or, given a list, handles[i] in envs[i]."""
        handles = self._per_env(envs, handles, call)
        if not envs:
            return np.zeros((0, 13), np.float32)
        for env, handle in zip(envs, handles):
            self._body(env, handle, call)
        states = self._envs(envs[0].sim, call)
        self._refresh(envs[0].sim, call)
        index = torch.tensor([e.index for e in envs], device=states.device)
        return states.rigid_body_states[index, torch.tensor(handles)].cpu().numpy()

    def _per_env(self, envs: list, handles, call: str) -> list:
        """One handle per env: `handles` for all, or a list as long as `envs`."""
        if isinstance(handles, (int, np.integer)):
            return [int(handles)] * len(envs)
        handles = [int(h) for h in handles]
        if len(handles) != len(envs):
            raise ValueError(f"gym.{call}: {len(handles)} handles for {len(envs)} envs (one "
                             "per env, or one for all)")
        return handles

    def get_vec_actor_dof_states(self, envs: list, actors, flags: int = STATE_ALL) -> np.ndarray:
        """[len(envs), DOFs] DofState records of an actor in each env (`actors`: its handle in
        every env, or one handle per env); the actors must have as many DOFs."""
        call = "get_vec_actor_dof_states"
        actors = self._per_env(envs, actors, call)
        chosen = [self._actor(env, a) for env, a in zip(envs, actors)]
        counts = {a.asset.num_dofs for a in chosen}
        if len(counts) > 1:
            raise ValueError(f"gym.{call}: the actors have {sorted(counts)} DOFs; one array "
                             "needs the same count in every env")
        out = np.zeros((len(envs), counts.pop() if counts else 0), DofState)
        if not envs:
            return out
        states = self._envs(envs[0].sim, call)
        self._refresh(envs[0].sim, call)
        index = torch.tensor([e.index for e in envs], device=states.device)
        columns = torch.tensor([[a.dof_offset + d for d in range(a.asset.num_dofs)]
                                for a in chosen], device=states.device)
        values = states.dof_state[index[:, None], columns].cpu().numpy()
        if int(flags) & STATE_POS:
            out["pos"] = values[..., 0]
        if int(flags) & STATE_VEL:
            out["vel"] = values[..., 1]
        return out

    def _root_body(self, env: Env, handle: int, call: str):
        actor, b = self._body(env, handle, call)
        if b != actor.body_offset:
            raise _unsupported(f"gym.{call} on body {handle} "
                               f"({actor.asset.body_names[b - actor.body_offset]!r}), a link of "
                               f"actor {actor.name!r}", "a link's pose follows its DOF states "
                               "(set_actor_dof_states); set its root body "
                               f"({actor.body_offset}) instead")
        return actor

    def set_rigid_transform(self, env: Env, handle: int, transform: Transform) -> None:
        actor = self._root_body(env, handle, "set_rigid_transform")
        p, r = transform.p, transform.r
        state = torch.tensor([p.x, p.y, p.z, r.x, r.y, r.z, r.w] + [0.0] * 6)
        self._set_root(env, actor, state, slice(0, 7), "set_rigid_transform")

    def set_rigid_linear_velocity(self, env: Env, handle: int, velocity: Vec3) -> None:
        actor = self._root_body(env, handle, "set_rigid_linear_velocity")
        state = torch.zeros(13)
        state[7:10] = torch.tensor([velocity.x, velocity.y, velocity.z])
        self._set_root(env, actor, state, slice(7, 10), "set_rigid_linear_velocity")

    def set_rigid_angular_velocity(self, env: Env, handle: int, velocity: Vec3) -> None:
        actor = self._root_body(env, handle, "set_rigid_angular_velocity")
        state = torch.zeros(13)
        state[10:13] = torch.tensor([velocity.x, velocity.y, velocity.z])
        self._set_root(env, actor, state, slice(10, 13), "set_rigid_angular_velocity")

    def set_actor_rigid_body_states(self, env: Env, handle: int, states,
                                    flags: int = STATE_ALL) -> bool:
        """The actor's root body takes its state from `states` (the actor's bodies, as
        get_actor_rigid_body_states gives them); an articulated actor's other bodies follow
        from its root and its DOF states (set_actor_dof_states), as in PhysX's
        reduced-coordinate articulations, so their entries are not read."""
        actor = self._actor(env, handle)
        states = np.asarray(states)
        if states.shape != (actor.asset.num_bodies,) or states.dtype != RigidBodyState:
            raise ValueError(f"gym.set_actor_rigid_body_states: expected "
                             f"{actor.asset.num_bodies} RigidBodyState records for actor "
                             f"{actor.name!r}, got {states.shape} of {states.dtype}")
        self._refresh(env.sim, "set_actor_rigid_body_states")
        root = states[0]
        state = torch.tensor([*root["pose"]["p"].item(), *root["pose"]["r"].item(),
                              *root["vel"]["linear"].item(), *root["vel"]["angular"].item()])
        columns = [c for c in range(13) if int(flags) & (STATE_POS if c < 7 else STATE_VEL)]
        if columns:
            self._set_root(env, actor, state, columns, "set_actor_rigid_body_states")
        return True

    def set_env_rigid_body_states(self, env: Env, states, flags: int = STATE_ALL) -> bool:
        states = np.asarray(states)
        if states.shape != (self.get_env_rigid_body_count(env),):
            raise ValueError(f"gym.set_env_rigid_body_states: {states.shape} states for env "
                             f"{env.index}'s {self.get_env_rigid_body_count(env)} bodies")
        for a in env.actors:
            self.set_actor_rigid_body_states(
                env, a.index, states[a.body_offset:a.body_offset + a.asset.num_bodies], flags)
        return True

    def get_sim_rigid_body_states(self, sim: Sim, flags: int = STATE_ALL) -> np.ndarray:
        return np.concatenate([self.get_env_rigid_body_states(e, flags) for e in sim.envs])

    def set_sim_rigid_body_states(self, sim: Sim, states, flags: int = STATE_ALL) -> bool:
        states = np.asarray(states)
        per_env = self.get_env_rigid_body_count(sim.envs[0]) if sim.envs else 0
        if states.shape != (per_env * len(sim.envs),):
            raise ValueError(f"gym.set_sim_rigid_body_states: {states.shape} states for the "
                             f"sim's {per_env * len(sim.envs)} bodies")
        for e in sim.envs:
            self.set_env_rigid_body_states(e, states[e.index * per_env:(e.index + 1) * per_env],
                                           flags)
        return True

    def set_rigid_body_state_tensor(self, sim: Sim, states) -> bool:
        raise _unsupported("gym.set_rigid_body_state_tensor", "Isaac Gym offers it with the "
                           "Flex backend only; with PhysX, set the roots "
                           "(set_actor_root_state_tensor) and the DOF states "
                           "(set_dof_state_tensor)")

    def apply_body_forces(self, env: Env, rigidHandle: int, force: Vec3 | None = None,
                          torque: Vec3 | None = None,
                          space=CoordinateSpace.ENV_SPACE) -> None:
        """A force at the body's center of mass and a torque, for the next simulate only."""
        self._body_wrench(env, rigidHandle, force, torque, None, space, "apply_body_forces")

    def apply_body_force_at_pos(self, env: Env, rigidHandle: int, force: Vec3,
                                pos: Vec3 | None = None,
                                space=CoordinateSpace.ENV_SPACE) -> None:
        """A force at point `pos` (the center of mass if None), for the next simulate only."""
        self._body_wrench(env, rigidHandle, force, None, pos, space, "apply_body_force_at_pos")

    def _body_wrench(self, env, handle, force, torque, pos, space, call) -> None:
        from myriad.api.envs import world_wrench
        envs = self._envs(env.sim, call)
        _, b = self._body(env, handle, call)
        s = envs.sim

        def vec(v):
            return None if v is None else torch.tensor([[float(v.x), float(v.y), float(v.z)]],
                                                       device=envs.device)
        f, t = world_wrench(s.body_pose[env.index, b][None], s.body_com[env.index, b][None],
                            vec(force), vec(torque), vec(pos),
                            local=_frame(space) == "local")
        s.body_force[env.index, b, :3] += f[0]
        s.body_force[env.index, b, 3:] += t[0]

    # DOFs: state, targets and efforts of one DOF
    def get_dof_position(self, env: Env, handle: int) -> float:
        return self._dof_state(env, handle, 0, "get_dof_position")

    def get_dof_velocity(self, env: Env, handle: int) -> float:
        return self._dof_state(env, handle, 1, "get_dof_velocity")

    def _dof_state(self, env, handle, column, call) -> float:
        d = self._dof(env, handle, call)
        envs = self._envs(env.sim, call)
        self._refresh(env.sim, call)
        return float(envs.dof_state[env.index, d, column])

    def apply_dof_effort(self, env: Env, handle: int, effort: float) -> None:
        """The DOF's effort (N or N·m), kept until changed, as set_dof_actuation_force_tensor."""
        d = self._dof(env, handle, "apply_dof_effort")
        envs = self._envs(env.sim, "apply_dof_effort")
        envs.sim.joint_force[env.index, envs.dof_columns[d]] = float(effort)

    def set_dof_target_position(self, env: Env, handle: int, target: float) -> None:
        self._dof_target(env, handle, target, "pos", "set_dof_target_position")

    def set_dof_target_velocity(self, env: Env, handle: int, target: float) -> None:
        self._dof_target(env, handle, target, "vel", "set_dof_target_velocity")

    def get_dof_target_position(self, env: Env, handle: int) -> float:
        d = self._dof(env, handle, "get_dof_target_position")
        self._envs(env.sim, "get_dof_target_position")
        return float(env.sim.position_targets[env.index, d])

    def get_dof_target_velocity(self, env: Env, handle: int) -> float:
        d = self._dof(env, handle, "get_dof_target_velocity")
        self._envs(env.sim, "get_dof_target_velocity")
        return float(env.sim.velocity_targets[env.index, d])

    def _dof_target(self, env, handle, target, kind, call) -> None:
        d = self._dof(env, handle, call)
        envs = self._envs(env.sim, call)
        store = env.sim.position_targets if kind == "pos" else env.sim.velocity_targets
        store[env.index, d] = float(target)
        dofs, cols = env.sim.drive_dofs[kind], env.sim.drive_ctrl[kind]
        if len(dofs):
            envs.sim.ctrl[env.index, cols] = store[env.index, dofs]

    # joints: a joint with one DOF reads as that DOF; frames in the env's frame
    def _joint_dof(self, env, handle, call) -> int:
        actor, j = self._joint(env, handle, call)
        mj = actor.asset.joint_mj[j]
        if mj < 0:
            return -1
        if mj not in actor.asset.dof_joints:
            kind = self.get_joint_type_string(self.get_asset_joint_type(actor.asset, j))
            raise ValueError(f"gym.{call}: joint {actor.asset.joint_names[j]!r} of actor "
                             f"{actor.name!r} is a {kind} with several DOFs: read them with "
                             "get_actor_dof_states")
        return actor.dof_offset + actor.asset.dof_joints.index(mj)

    def get_joint_position(self, env: Env, handle: int) -> float:
        d = self._joint_dof(env, handle, "get_joint_position")
        return 0.0 if d < 0 else self.get_dof_position(env, d)

    def get_joint_velocity(self, env: Env, handle: int) -> float:
        d = self._joint_dof(env, handle, "get_joint_velocity")
        return 0.0 if d < 0 else self.get_dof_velocity(env, d)

    def get_joint_target_position(self, env: Env, handle: int) -> float:
        d = self._joint_dof(env, handle, "get_joint_target_position")
        return 0.0 if d < 0 else self.get_dof_target_position(env, d)

    def get_joint_target_velocity(self, env: Env, handle: int) -> float:
        d = self._joint_dof(env, handle, "get_joint_target_velocity")
        return 0.0 if d < 0 else self.get_dof_target_velocity(env, d)

    def set_joint_target_position(self, env: Env, handle: int, target: float) -> None:
        d = self._joint_dof(env, handle, "set_joint_target_position")
        if d >= 0:
            self.set_dof_target_position(env, d, target)

    def set_joint_target_velocity(self, env: Env, handle: int, target: float) -> None:
        d = self._joint_dof(env, handle, "set_joint_target_velocity")
        if d >= 0:
            self.set_dof_target_velocity(env, d, target)

    def _joint_frame(self, env: Env, actor, j: int, call: str):
        """(anchor, axis, child body's rotation xyzw) of joint j of actor, env frame."""
        rows = self._body_row(env, call)
        b = actor.body_offset + actor.asset.joint_bodies[j]
        pose = rows[b, :7].double()
        mj, m = actor.asset.joint_mj[j], actor.asset.mj
        local = torch.tensor(m.jnt_pos[mj] if mj >= 0 else np.zeros(3), dtype=torch.float64)
        axis = torch.tensor(m.jnt_axis[mj] if mj >= 0 else np.zeros(3), dtype=torch.float64)
        anchor = quat_rotate(pose[None, 3:7], local[None])[0] + pose[:3]
        return anchor, quat_rotate(pose[None, 3:7], axis[None])[0], pose[3:7]

    def get_joint_transform(self, env: Env, handle: int) -> Transform:
        """The joint's frame: at its anchor, turned as its child body."""
        actor, j = self._joint(env, handle, "get_joint_transform")
        anchor, _, rot = self._joint_frame(env, actor, j, "get_joint_transform")
        return Transform(Vec3(*anchor.tolist()), Quat(*rot.tolist()))

    def get_actor_joint_transforms(self, env: Env, handle: int) -> np.ndarray:
        actor = self._actor(env, handle)
        out = np.zeros(len(actor.asset.joint_names), Transform.dtype)
        for j in range(len(out)):
            t = self.get_joint_transform(env, actor.joint_offset + j)
            out[j] = ((t.p.x, t.p.y, t.p.z), (t.r.x, t.r.y, t.r.z, t.r.w))
        return out

    def get_dof_frame(self, env: Env, handle: int) -> DofFrame:
        """Where the DOF's joint is (env frame) and the direction it acts along or about."""
        actor, d = self._owner(env, handle, "DOF", "get_dof_frame")
        j = actor.asset.joint_mj.index(actor.asset.dof_joints[d])
        anchor, axis, _ = self._joint_frame(env, actor, j, "get_dof_frame")
        return DofFrame(Vec3(*anchor.tolist()), Vec3(*axis.tolist()))

    def get_actor_dof_frames(self, env: Env, handle: int) -> np.ndarray:
        actor = self._actor(env, handle)
        out = np.zeros(actor.asset.num_dofs, DofFrame.dtype)
        for i in range(actor.asset.num_dofs):
            f = self.get_dof_frame(env, actor.dof_offset + i)
            out[i] = ((f.origin.x, f.origin.y, f.origin.z), (f.axis.x, f.axis.y, f.axis.z))
        return out

    # contacts of the last simulate
    def get_env_rigid_contacts(self, env: Env) -> np.ndarray:
        """The env's contacts in the last substep, as RigidContact records: bodies in the env
        domain (-1: the ground or other static geometry), `normal` from body0 to body1
        (world), `lambda` the normal force (N), `lambdaFriction` the friction force's
        magnitude (and 0), `initialOverlap` the penetration depth, `localPos*` the contact
        point in each body's frame (for the ground: in the env's frame)."""
        envs = self._envs(env.sim, "get_env_rigid_contacts")
        s, e = envs.sim, env.index
        n = min(int(s.contact_count[e]), int(s.contact_force.shape[1]))
        out = np.zeros(n, RigidContact)
        if not n:
            return out
        geom = s.contact_geom[e, :n].long().cpu()
        body = torch.as_tensor(envs.model.geom_body)[geom]                 # [n, 2], -1 static
        pos, normal = s.contact_pos[e, :n].cpu(), s.contact_normal[e, :n].cpu()
        force = s.contact_force[e, :n].cpu()
        lam = (force * normal).sum(-1)
        mu = s.geom_friction[e].cpu()[geom].mean(-1)    # the engine's combine: the average
        poses = s.body_pose[e].cpu()
        out["env0"] = np.where(body[:, 0] >= 0, e, -1)
        out["env1"] = np.where(body[:, 1] >= 0, e, -1)
        out["body0"], out["body1"] = body[:, 0].numpy(), body[:, 1].numpy()
        for k, key in ((0, "localPos0"), (1, "localPos1")):
            b = body[:, k].clamp(min=0)
            local = quat_rotate_inverse(poses[b, 3:7], pos - poses[b, :3])
            out[key] = _records(torch.where(body[:, k, None] >= 0, local, pos).numpy())
        out["normal"] = _records(normal.numpy())
        out["initialOverlap"] = (-s.contact_dist[e, :n].cpu()).clamp(min=0).numpy()
        out["lambda"] = lam.numpy()
        out["lambdaFriction"]["x"] = (force - lam[:, None] * normal).norm(dim=-1).numpy()
        out["friction"] = mu.numpy()
        return out

    def get_rigid_contacts(self, sim: Sim) -> np.ndarray:
        return np.concatenate([self.get_env_rigid_contacts(e) for e in sim.envs]) if sim.envs \
            else np.zeros(0, RigidContact)

    def get_env_rigid_contact_forces(self, env: Env) -> np.ndarray:
        """Each body's net contact force (N, world) in the last substep, as Vec3 records."""
        envs = self._envs(env.sim, "get_env_rigid_contact_forces")
        return _records(envs.net_contact_force[env.index].cpu().numpy())

    def get_rigid_contact_forces(self, sim: Sim) -> np.ndarray:
        return self.get_vec_env_rigid_contact_forces(sim.envs)

    def get_vec_env_rigid_contact_forces(self, envs: list) -> np.ndarray:
        return np.concatenate([self.get_env_rigid_contact_forces(e) for e in envs])

    # ------------------------------------------------------------------ actor properties
    def get_actor_dof_properties(self, env: Env, handle: int) -> np.ndarray:
        return self._actor(env, handle).dof_props.copy()

    def set_actor_dof_properties(self, env: Env, handle: int, props) -> bool:
        actor = self._actor(env, handle)
        props = np.asarray(props)
        if props.dtype.names is None or set(DofProperties.names) - set(props.dtype.names):
            raise ValueError("set_actor_dof_properties: expected the structured array of "
                             "get_actor_dof_properties (fields "
                             f"{list(DofProperties.names)})")
        if props.shape != actor.dof_props.shape:
            raise ValueError(f"set_actor_dof_properties: {props.shape[0] if props.ndim else 0} "
                             f"entries for actor {actor.name!r} with {actor.asset.num_dofs} "
                             "DOFs")
        new = actor.dof_props.copy()
        for f in DofProperties.names:
            new[f] = props[f]
        bad = [int(m) for m in new["driveMode"] if int(m) not in _MODES]
        if bad:
            raise ValueError(f"set_actor_dof_properties: unknown driveMode {bad}")
        changed = new["hasLimits"] != actor.asset.dof_props["hasLimits"]
        if changed.any():
            names = [actor.asset.dof_names[i] for i in np.flatnonzero(changed)]
            raise _unsupported(f"set_actor_dof_properties changing hasLimits of {names}",
                               "whether a joint is limited is fixed by the asset")
        vel_stiff = (new["driveMode"] == DofDriveMode.DOF_MODE_VEL) & (new["stiffness"] != 0)
        if vel_stiff.any():
            names = [actor.asset.dof_names[i] for i in np.flatnonzero(vel_stiff)]
            raise _unsupported(f"DOF_MODE_VEL with stiffness != 0 on {names}",
                               "a velocity drive has damping only; set stiffness to 0")
        sim = env.sim
        if sim.myriad is not None:
            if (new["driveMode"] != actor.dof_props["driveMode"]).any():
                raise _unsupported("set_actor_dof_properties changing driveMode after "
                                   "prepare_sim", "drive modes are fixed when the sim is built")
            actor.dof_props = new
            _apply_dof_props(sim, [actor])
            if (new["effort"] != actor.asset.dof_props["effort"]).any():
                _check_efforts(sim, built=True)
        else:
            actor.dof_props = new
        return True

    def get_actor_rigid_shape_properties(self, env: Env, handle: int) -> list:
        return copy.deepcopy(self._actor(env, handle).shape_props)

    def set_actor_rigid_shape_properties(self, env: Env, handle: int, props: list) -> bool:
        actor = self._actor(env, handle)
        _check_shape_props(props, len(actor.asset.shape_geoms),
                           "set_actor_rigid_shape_properties", actor.shape_filter)
        actor.shape_props = copy.deepcopy(list(props))
        if env.sim.myriad is not None:
            _apply_shape_props(env.sim, [actor])
        return True

    def get_actor_rigid_body_properties(self, env: Env, handle: int) -> list:
        return copy.deepcopy(self._actor(env, handle).body_props)

    def set_actor_rigid_body_properties(self, env: Env, handle: int, props: list,
                                        recomputeInertia: bool = False) -> bool:
        actor = self._actor(env, handle)
        if len(props) != actor.asset.num_bodies:
            raise ValueError(f"set_actor_rigid_body_properties: {len(props)} entries for actor "
                             f"{actor.name!r} with {actor.asset.num_bodies} bodies")
        new = copy.deepcopy(list(props))
        for i, (p, old) in enumerate(zip(new, actor.body_props)):
            body = actor.asset.body_names[i]
            if not (p.mass > 0):
                raise ValueError(f"set_actor_rigid_body_properties: body {body!r}: mass "
                                 f"{p.mass} must be > 0")
            if not np.allclose(p.com._t(), old.com._t(), atol=1e-7):
                raise _unsupported(f"set_actor_rigid_body_properties changing the com of body "
                                   f"{body!r}", "centres of mass are fixed by the asset")
            if (int(p.flags) & RIGID_BODY_DISABLE_GRAVITY) != (int(old.flags)
                                                               & RIGID_BODY_DISABLE_GRAVITY):
                raise _unsupported(f"set_actor_rigid_body_properties changing "
                                   f"RIGID_BODY_DISABLE_GRAVITY of body {body!r}",
                                   "use AssetOptions.disable_gravity")
            if recomputeInertia and old.mass > 0:
                p.inertia = Mat33._of(old.inertia._t() * (p.mass / old.mass))
            p.invMass = 1.0 / p.mass
            p.invInertia = Mat33._of(np.linalg.pinv(p.inertia._t()))
        actor.body_props = new
        if env.sim.myriad is not None:
            _apply_body_props(env.sim, [actor])
        return True

    # ------------------------------------------------------------------ tensors
    def _envs(self, sim: Sim, call: str):
        if not isinstance(sim, Sim):
            raise TypeError(f"gym.{call}: expected a Sim (from gym.create_sim), got "
                            f"{type(sim).__name__}")
        if sim.myriad is None and call.startswith("acquire_") and sim.envs \
                and sim.envs[0].actors and not sim.closed:
            # Isaac Gym hands out tensors before prepare_sim (valid after it); Myriad's
            # buffers exist once the sim is built, so acquiring one builds it now: every env
            # and actor must exist by then, as prepare_sim would need
            _prepare(sim)
        if sim.myriad is None:
            raise RuntimeError(f"gym.{call}: call gym.prepare_sim(sim) first, after creating "
                               "the envs and actors")
        if call.startswith(("set_", "apply_")):
            sim.fresh = None            # the state may change: the next refresh_* recomputes
        return sim.myriad

    def _refresh(self, sim: Sim, call: str) -> bool:
        """Recompute the state tensors from the simulator, unless nothing could have changed
        them since the last time: no call that writes the state, no simulate, and no edit of
        the tensors themselves (torch's version counters), which Isaac Gym's refresh would
        overwrite. `simulate` refreshes them already, so the refresh_* calls tasks make after
        it cost nothing."""
        envs = self._envs(sim, call)
        if sim.fresh != _versions(envs):
            envs.refresh()
            sim.fresh = _versions(envs)
        return True

    def _before_prepare(self, sim: Sim, call: str) -> None:
        if sim.closed:
            raise RuntimeError(f"gym.{call}: the sim was destroyed")
        if sim.myriad is not None:
            raise _unsupported(f"gym.{call} after prepare_sim",
                               "a Myriad sim is built once, from all envs and actors")

    def acquire_actor_root_state_tensor(self, sim: Sim) -> Tensor:
        envs = self._envs(sim, "acquire_actor_root_state_tensor")
        return Tensor(sim.myriad_views("root", envs))

    def acquire_dof_state_tensor(self, sim: Sim) -> Tensor:
        envs = self._envs(sim, "acquire_dof_state_tensor")
        return Tensor(sim.myriad_views("dof", envs))

    def acquire_rigid_body_state_tensor(self, sim: Sim) -> Tensor:
        envs = self._envs(sim, "acquire_rigid_body_state_tensor")
        return Tensor(sim.myriad_views("body", envs))

    def acquire_net_contact_force_tensor(self, sim: Sim) -> Tensor:
        envs = self._envs(sim, "acquire_net_contact_force_tensor")
        return Tensor(sim.myriad_views("contact", envs))

    def acquire_dof_force_tensor(self, sim: Sim) -> Tensor:
        envs = self._envs(sim, "acquire_dof_force_tensor")
        return Tensor(sim.myriad_views("dof_force", envs))

    def refresh_actor_root_state_tensor(self, sim: Sim) -> bool:
        return self._refresh(sim, "refresh_actor_root_state_tensor")

    def refresh_dof_state_tensor(self, sim: Sim) -> bool:
        return self._refresh(sim, "refresh_dof_state_tensor")

    def refresh_rigid_body_state_tensor(self, sim: Sim) -> bool:
        return self._refresh(sim, "refresh_rigid_body_state_tensor")

    def refresh_dof_force_tensor(self, sim: Sim) -> bool:
        return self._refresh(sim, "refresh_dof_force_tensor")

    def refresh_net_contact_force_tensor(self, sim: Sim) -> bool:
        self._envs(sim, "refresh_net_contact_force_tensor")   # a view of the simulator's
        return True

    def _actor_slot(self, sim: Sim, name: str, call: str) -> int:
        names = [a.name for a in sim.envs[0].actors]
        if name not in names:
            raise ValueError(f"gym.{call}: no actor named {name!r}; env 0's actors are {names}")
        return names.index(name)

    def acquire_jacobian_tensor(self, sim: Sim, name: str) -> Tensor:
        """[num_envs, links, 6, dofs] of actor `name` (linear rows first, at each link's
        origin, world axes): a fixed base's root link has no row; a free base's 6 velocity
        columns (linear, angular, world axes) come first. Updated by refresh_jacobian_tensors."""
        return self._acquire_algebra(sim, name, "jacobian", "acquire_jacobian_tensor")

    def acquire_mass_matrix_tensor(self, sim: Sim, name: str) -> Tensor:
        """[num_envs, dofs, dofs] joint-space mass matrix of actor `name` (a free base's 6
        columns first, world axes). Updated by refresh_mass_matrix_tensors."""
        return self._acquire_algebra(sim, name, "mass_matrix", "acquire_mass_matrix_tensor")

    def refresh_jacobian_tensors(self, sim: Sim) -> bool:
        return self._refresh_algebra(sim, "jacobian", "refresh_jacobian_tensors")

    def refresh_mass_matrix_tensors(self, sim: Sim) -> bool:
        return self._refresh_algebra(sim, "mass_matrix", "refresh_mass_matrix_tensors")

    def _acquire_algebra(self, sim: Sim, name: str, kind: str, call: str) -> Tensor:
        """Actor `name`'s tensor of `kind` (computed on first acquire; the same object after)."""
        envs = self._envs(sim, call)
        key = (kind, self._actor_slot(sim, name, call))
        if key not in sim.algebra:
            sim.algebra[key] = _actor_algebra(sim, envs, *key)
        return Tensor(sim.algebra[key])

    def _refresh_algebra(self, sim: Sim, kind: str, call: str) -> bool:
        """Every acquired tensor of `kind`, recomputed in place."""
        envs = self._envs(sim, call)
        for (held, k), tensor in sim.algebra.items():
            if held == kind:
                tensor.copy_(_actor_algebra(sim, envs, held, k))
        return True

    def _values(self, sim: Sim, call: str, desc, per_env_shape: tuple) -> torch.Tensor:
        """The tensor behind `desc` as [num_envs, *per_env_shape], float32 on the sim's
        device (Isaac Gym's flat layouts, env-major)."""
        envs = self._envs(sim, call)
        t = desc.torch if isinstance(desc, Tensor) else desc
        if not isinstance(t, torch.Tensor):
            raise TypeError(f"gym.{call}: expected a gymapi.Tensor (gymtorch.unwrap_tensor(...))"
                            f", got {type(desc).__name__}")
        if t.device != envs.device or t.dtype != torch.float32:
            raise ValueError(f"gym.{call}: the tensor is {t.dtype} on {t.device}; expected "
                             f"torch.float32 on {envs.device}")
        n = int(np.prod(per_env_shape))
        if t.numel() != envs.num_envs * n:
            flat = (envs.num_envs * per_env_shape[0],) + tuple(per_env_shape[1:])
            raise ValueError(f"gym.{call}: the tensor has shape {tuple(t.shape)}; expected "
                             f"{flat} (all envs, env-major)")
        return t.reshape(envs.num_envs, *per_env_shape)

    def _actor_selection(self, sim: Sim, call: str, indices, count) -> torch.Tensor:
        """[num_envs, num_actors] bool: the actors named by int32 sim-domain indices."""
        envs = self._envs(sim, call)
        t = indices.torch if isinstance(indices, Tensor) else indices
        if not isinstance(t, torch.Tensor) or t.dtype != torch.int32:
            raise ValueError(f"gym.{call}: actor indices must be an int32 tensor "
                             "(gymtorch.unwrap_tensor(ids.to(torch.int32)))")
        t = t.reshape(-1)[: int(count)].to(envs.device).long()
        A = envs.num_actors
        sel = torch.zeros(envs.num_envs * A, dtype=torch.bool, device=envs.device)
        if len(t):
            low, high = torch.stack((t.min(), t.max())).tolist()
            if low < 0 or high >= envs.num_envs * A:
                raise ValueError(f"gym.{call}: actor index out of range [0, "
                                 f"{envs.num_envs * A}): got min {low}, max {high}")
            sel[t] = True
        return sel.view(envs.num_envs, A)

    def _root_now(self, envs) -> torch.Tensor:
        sim = envs.sim
        both = torch.cat((sim.body_pose, sim.body_vel), dim=-1)
        return both[:, envs._root_body]

    def set_actor_root_state_tensor(self, sim: Sim, root_states) -> bool:
        envs = self._envs(sim, "set_actor_root_state_tensor")
        values = self._values(sim, "set_actor_root_state_tensor", root_states,
                              (envs.num_actors, 13))
        envs.set_root_states(values.clone(), forward=False)
        envs.sim.forward()      # the state tensors change at the next refresh, as in Isaac Gym
        return True

    def set_actor_root_state_tensor_indexed(self, sim: Sim, root_states, indices,
                                            count: int) -> bool:
        call = "set_actor_root_state_tensor_indexed"
        envs = self._envs(sim, call)
        values = self._values(sim, call, root_states, (envs.num_actors, 13))
        sel = self._actor_selection(sim, call, indices, count)
        new = torch.where(sel[..., None], values, self._root_now(envs))
        envs.set_root_states(new, env_ids=sel.any(dim=1), forward=False)
        envs.sim.forward()
        return True

    def set_dof_state_tensor(self, sim: Sim, dof_states) -> bool:
        envs = self._envs(sim, "set_dof_state_tensor")
        values = self._values(sim, "set_dof_state_tensor", dof_states, (envs.num_dofs, 2))
        envs.set_dof_state(values[..., 0].clone(), values[..., 1].clone(), forward=False)
        envs.sim.forward()
        return True

    def set_dof_state_tensor_indexed(self, sim: Sim, dof_states, indices, count: int) -> bool:
        call = "set_dof_state_tensor_indexed"
        envs = self._envs(sim, call)
        values = self._values(sim, call, dof_states, (envs.num_dofs, 2))
        mask = self._actor_selection(sim, call, indices, count)[:, sim.dof_actor]
        s = envs.sim
        pos = torch.where(mask, values[..., 0], s.q[:, envs._dof_q])
        vel = torch.where(mask, values[..., 1], s.qd[:, envs.dof_columns])
        envs.set_dof_state(pos, vel, env_ids=mask.any(dim=1), forward=False)
        envs.sim.forward()
        return True

    def set_dof_actuation_force_tensor(self, sim: Sim, forces) -> bool:
        envs = self._envs(sim, "set_dof_actuation_force_tensor")
        envs.set_dof_efforts(self._values(sim, "set_dof_actuation_force_tensor", forces,
                                          (envs.num_dofs,)).clone())
        return True

    def set_dof_actuation_force_tensor_indexed(self, sim: Sim, forces, indices, count) -> bool:
        call = "set_dof_actuation_force_tensor_indexed"
        envs = self._envs(sim, call)
        values = self._values(sim, call, forces, (envs.num_dofs,))
        mask = self._actor_selection(sim, call, indices, count)[:, sim.dof_actor]
        current = envs.sim.joint_force[:, envs.dof_columns]
        envs.set_dof_efforts(torch.where(mask, values, current))
        return True

    def _set_targets(self, sim, call, targets, kind, indices=None, count=None) -> bool:
        envs = self._envs(sim, call)
        values = self._values(sim, call, targets, (envs.num_dofs,))
        store = sim.position_targets if kind == "pos" else sim.velocity_targets
        if indices is None:
            store.copy_(values)
        else:
            mask = self._actor_selection(sim, call, indices, count)[:, sim.dof_actor]
            store.copy_(torch.where(mask, values, store))
        dofs, cols = sim.drive_dofs[kind], sim.drive_ctrl[kind]
        if len(dofs):
            envs.sim.ctrl[:, cols] = store[:, dofs]
        return True

    def set_dof_position_target_tensor(self, sim: Sim, targets) -> bool:
        return self._set_targets(sim, "set_dof_position_target_tensor", targets, "pos")

    def set_dof_position_target_tensor_indexed(self, sim, targets, indices, count) -> bool:
        return self._set_targets(sim, "set_dof_position_target_tensor_indexed", targets, "pos",
                                 indices, count)

    def set_dof_velocity_target_tensor(self, sim: Sim, targets) -> bool:
        return self._set_targets(sim, "set_dof_velocity_target_tensor", targets, "vel")

    def set_dof_velocity_target_tensor_indexed(self, sim, targets, indices, count) -> bool:
        return self._set_targets(sim, "set_dof_velocity_target_tensor_indexed", targets, "vel",
                                 indices, count)

    def apply_rigid_body_force_tensors(self, sim: Sim, forceTensor=None, torqueTensor=None,
                                       space=CoordinateSpace.ENV_SPACE) -> bool:
        call = "apply_rigid_body_force_tensors"
        envs = self._envs(sim, call)
        shape = (envs.num_bodies, 3)
        forces = None if forceTensor is None else self._values(sim, call, forceTensor, shape)
        torques = None if torqueTensor is None else self._values(sim, call, torqueTensor, shape)
        envs.apply_body_forces(forces, torques, frame=_frame(space))
        return True

    def apply_rigid_body_force_at_pos_tensors(self, sim: Sim, forceTensor, posTensor=None,
                                              space=CoordinateSpace.ENV_SPACE) -> bool:
        call = "apply_rigid_body_force_at_pos_tensors"
        envs = self._envs(sim, call)
        shape = (envs.num_bodies, 3)
        forces = self._values(sim, call, forceTensor, shape)
        pos = None if posTensor is None else self._values(sim, call, posTensor, shape)
        envs.apply_body_forces(forces, positions=pos, frame=_frame(space))
        return True


def _up(sim: Sim) -> tuple:
    """The sim's up direction (its SimParams.up_axis)."""
    return (0.0, 1.0, 0.0) if int(sim.params.up_axis) == UpAxis.UP_AXIS_Y else (0.0, 0.0, 1.0)


def _frame(space) -> str:
    """ENV_SPACE and GLOBAL_SPACE are both the world frame of a Myriad env (envs have no
    offsets between them); LOCAL_SPACE is each body's frame."""
    return "local" if int(space) == CoordinateSpace.LOCAL_SPACE else "world"


# ---------------------------------------------------------------------------------- helpers
def _myriad_params(params: SimParams):
    """Isaac Gym's SimParams as `myriad.SimParams` (ValueError if out of range)."""
    from myriad.physics import SimParams as MyriadParams

    px = params.physx
    if px.solver_type not in (0, 1):
        raise ValueError(f"SimParams.physx.solver_type={px.solver_type}: 0 (PGS) or 1 (TGS)")
    if not 1 <= int(px.num_position_iterations) <= 255:
        raise ValueError("SimParams.physx.num_position_iterations must lie in [1, 255]")
    if not 0 <= int(px.num_velocity_iterations) <= 255:
        raise ValueError("SimParams.physx.num_velocity_iterations must lie in [0, 255]")
    g = params.gravity
    return MyriadParams(
        dt=float(params.dt), substeps=int(params.substeps), gravity=(g.x, g.y, g.z),
        solver="tgs" if int(px.solver_type) == 1 else "pgs",
        position_iterations=int(px.num_position_iterations),
        velocity_iterations=int(px.num_velocity_iterations),
        contact_offset=float(px.contact_offset), rest_offset=float(px.rest_offset),
        bounce_threshold_velocity=float(px.bounce_threshold_velocity),
        max_depenetration_velocity=float(px.max_depenetration_velocity),
        max_correction_velocity=float(px.max_depenetration_velocity),
        max_joint_velocity=_DEFAULT_MAX_JOINT_VELOCITY,
        filter_ancestors=1)            # PhysX filters a link's parent alone


# options honoured, accepted because they only draw or import, and refused when not default
_DRAWING_OPTIONS = ("flip_visual_attachments", "use_mesh_materials", "mesh_normal_mode",
                    "slices_per_cylinder", "min_particle_mass",
                    "vhacd_params")


def _check_asset_options(o: AssetOptions) -> None:
    """Refuse options that would change the physics and that Myriad does not honour."""
    d = AssetOptions()
    refused = []
    for name in ("override_com", "override_inertia", "convex_decomposition_from_submeshes"):
        if bool(getattr(o, name)) != bool(getattr(d, name)):
            refused.append(f"{name}={getattr(o, name)!r}")
    if not o.enable_gyroscopic_forces:
        refused.append("enable_gyroscopic_forces=False (Myriad's dynamics always include them)")
    # body velocity damping: Myriad has none, which is the value 0 exactly. Rates up to PhysX's
    # default angular one (0.5 /s: under 1 % of a body's speed per 20 ms step) are accepted with
    # a warning; larger ones, which would shape the motion, are refused
    for name in ("linear_damping", "angular_damping"):
        v = float(getattr(o, name))
        if v > _DAMPING_ACCEPTED or v < 0:
            refused.append(f"{name}={v} (Myriad applies no body velocity damping; 0 is exact, "
                           f"rates up to {_DAMPING_ACCEPTED} /s are accepted unapplied)")
        elif v != 0.0 and v != getattr(d, name):
            _warn_once(f"AssetOptions.{name}={v} is not applied (Myriad has no body velocity "
                       "damping: bodies keep their speed where PhysX would lose "
                       f"{100 * v:.3g} % of it per second)")
    for name in ("max_linear_velocity", "max_angular_velocity"):     # `_apply_speed_caps`
        v = float(getattr(o, name))
        if not v > 0:
            refused.append(f"{name}={v} (must be > 0)")
    if not (o.density > 0):
        refused.append(f"density={o.density} (must be > 0)")
    if int(o.default_dof_drive_mode) not in _MODES:
        raise ValueError(f"AssetOptions.default_dof_drive_mode={o.default_dof_drive_mode!r}")
    if refused:
        raise NotImplementedError("AssetOptions not supported by Myriad yet: "
                                  + "; ".join(refused) + f"; {_DOCS}")
    if float(o.thickness) != d.thickness:
        warnings.warn(f"isaacgym on Myriad: AssetOptions.thickness={o.thickness} is not applied "
                      "(contacts use SimParams.physx.contact_offset / rest_offset)",
                      RuntimeWarning, stacklevel=3)


_DAMPING_ACCEPTED = 0.5
_warned: set = set()


def _warn_once(message: str) -> None:
    if message not in _warned:
        _warned.add(message)
        warnings.warn(f"isaacgym on Myriad: {message}; {_DOCS}", RuntimeWarning,
                      stacklevel=4)


def _take_actuators(spec: mujoco.MjSpec) -> list:
    """Record the MJCF actuators (Isaac Gym reports them; its tasks read motor_effort and
    apply DOF forces themselves) and remove them: Isaac Gym never drives them."""
    out = []
    for act in list(spec.actuators):
        gear = float(act.gear[0])
        props = ActuatorProperties(
            motor_effort=gear, control_limited=bool(act.ctrllimited == 1),
            lower_control_limit=float(act.ctrlrange[0]),
            upper_control_limit=float(act.ctrlrange[1]),
            force_limited=bool(act.forcelimited == 1), lower_force_limit=float(act.forcerange[0]),
            upper_force_limit=float(act.forcerange[1]))
        out.append({"name": act.name, "joint": act.target, "props": props})
        spec.delete(act)
    return out


def _decompose_meshes(spec: mujoco.MjSpec, params: VhacdParams, source: str) -> None:
    """Isaac Gym's vhacd_enabled: every colliding mesh geom replaced by the convex pieces V-HACD
    cuts its mesh into (MuJoCo would collide the mesh as its one convex hull), each piece a mesh
    geom of the same body, pose, contact settings and material. V-HACD 4 (`vhacdx`): of
    `VhacdParams` it reads resolution, max_convex_hulls and max_num_vertices_per_ch (the
    older V-HACD's concavity, alpha, beta, ... have no counterpart). Pieces are cached per mesh
    and parameters in ~/.cache/myriad/vhacd."""
    from myriad.physics.convex import convex_pieces
    base = os.path.join(spec.modelfiledir or "", spec.meshdir or "")
    meshes = {m.name: m for m in spec.meshes}
    for geom in [g for g in spec.geoms if g.type == mujoco.mjtGeom.mjGEOM_MESH
                 and (g.contype or g.conaffinity)]:
        mesh = meshes.get(geom.meshname)
        if mesh is None or not mesh.file:
            continue
        file = mesh.file if os.path.isabs(mesh.file) else os.path.join(base, mesh.file)
        try:
            pieces = convex_pieces(file, tuple(float(x) for x in mesh.scale),
                                   max_hulls=int(params.max_convex_hulls),
                                   resolution=int(params.resolution),
                                   max_vertices=int(params.max_num_vertices_per_ch))
        except ImportError as err:
            raise _unsupported(f"AssetOptions.vhacd_enabled=True on {source}",
                               f"it needs vhacdx and trimesh (pip install vhacdx trimesh): {err}")
        body = geom.parent
        for k, piece in enumerate(pieces):
            name = f"{mesh.name}__vhacd{k}"
            if name not in meshes:
                meshes[name] = spec.add_mesh(name=name, file=piece)
            body.add_geom(name=f"{geom.name}__vhacd{k}" if geom.name else "", type=geom.type,
                          meshname=name, pos=list(geom.pos), quat=list(geom.quat),
                          contype=geom.contype, conaffinity=geom.conaffinity,
                          condim=geom.condim, friction=list(geom.friction),
                          priority=geom.priority, margin=geom.margin, gap=geom.gap,
                          density=geom.density, group=geom.group)
        spec.delete(geom)


_DRAWN_BODY_MASS = 1e-3     # kg: a body with drawing geoms only (its inertia: a 1 cm ball's)


def _weightless_drawing(spec: mujoco.MjSpec) -> None:
    """Geoms that neither collide nor are collided with (contype = conaffinity = 0) only draw,
    and weigh nothing, as in Isaac Gym (IsaacGymEnvs' Ingenuity draws its chassis and rotors
    with such meshes, 14 kg of them at MuJoCo's default density). A body left with no mass gets
    1 g (MuJoCo needs a moving body to have some)."""
    for body in spec.bodies:
        if body.name == "world" or body.explicitinertial:
            continue
        weighed = False
        for geom in body.geoms:
            if geom.contype == 0 and geom.conaffinity == 0 and not geom.mass > 0:
                geom.density = 0.0
            else:
                weighed = True
        if not weighed and list(body.geoms):
            body.explicitinertial = True
            body.mass = _DRAWN_BODY_MASS
            body.ipos = [0.0, 0.0, 0.0]
            body.inertia = [0.4 * _DRAWN_BODY_MASS * 0.01 ** 2] * 3


def _urdf_joint_facts(path: str) -> tuple[dict, set, dict]:
    """What MuJoCo's URDF importer drops, from one read of the file: ({child link: joint name}
    of the fixed joints (MuJoCo's model keeps no name for them), {child links whose fixed joint
    says dont_collapse="true"}, {joint name: its `<limit velocity=...>`}); empty for other
    files."""
    if not path.lower().endswith(".urdf"):
        return {}, set(), {}
    import xml.etree.ElementTree as ET
    from myriad.assets import urdf_velocity_limits
    try:
        robot = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return {}, set(), {}
    fixed = [j for j in robot.iter("joint")
             if j.get("type") == "fixed" and j.find("child") is not None]
    return ({j.find("child").get("link"): j.get("name") for j in fixed},
            {j.find("child").get("link") for j in fixed
             if j.get("dont_collapse", "").strip().lower() in ("true", "1")},
            urdf_velocity_limits(robot))


def _urdf_speed_limits(asset: Asset, limits: dict) -> None:
    """A URDF joint's `<limit velocity=...>` (`limits`, by joint name) as its DOF's `velocity`
    property, as Isaac Gym reads it: the DOF's maximum speed, which the engine holds
    (`dof_max_velocity`, PhysX's maxJointVelocity). 0 or absent: PhysX's default of 100."""
    for i, name in enumerate(asset.dof_names):
        if limits.get(name, 0.0) > 0.0:
            asset.dof_props[i]["velocity"] = limits[name]


def _collapse_fixed_joints(spec: mujoco.MjSpec, source: str, keep: set = frozenset()) -> None:
    """Isaac Gym's collapse_fixed_joints: every link on a fixed joint (a body without joints,
    other than the root) merged into its parent: its shapes and sites move there, its mass and
    inertia are added to the parent's (MuJoCo's fusestatic, which turns the spec's fused bodies
    into frames). The root stays a body, fixed base or not, and so do the links in `keep` (a
    URDF joint's dont_collapse="true": legged_gym's ANYmal keeps its FOOT links so, to find its
    feet by name and tell their contacts from the shanks'): each holds a joint while MuJoCo
    fuses the others."""
    root = spec.worldbody.bodies[0]
    anchors = [root.add_freejoint(name="__collapse_anchor")] if not list(root.joints) else []
    for b in spec.bodies:
        if b.name in keep and not list(b.joints):
            anchors.append(b.add_joint(name=f"__keep_{b.name}", type=mujoco.mjtJoint.mjJNT_SLIDE))
    spec.compiler.fusestatic = True
    try:
        spec.compile()
    except Exception as err:
        raise _model_error(f"{source}: collapse_fixed_joints: MuJoCo rejected the merged "
                           f"model: {err}") from err
    finally:
        spec.compiler.fusestatic = False
        for anchor in anchors:
            spec.delete(anchor)


def _finish_asset(spec: mujoco.MjSpec, options: AssetOptions, source: str,
                  actuators: list, fixed_joints: tuple[dict, set] | None = None) -> Asset:
    """Apply density, armature and collapse_fixed_joints to a spec; make the Asset."""
    roots = spec.worldbody.bodies
    if len(roots) != 1:
        raise _model_error(f"{source}: an asset must have exactly one body under the world "
                           f"(one articulation or rigid body); it has {len(roots)}")
    bodies = [b for b in spec.bodies if b.name != "world"]
    for b in bodies:
        if not b.explicitinertial:
            for g in b.geoms:
                if not (g.mass > 0) and float(options.density) != 1000.0:
                    g.density = float(options.density)
    names, kept = fixed_joints or ({}, set())
    if options.collapse_fixed_joints:
        _collapse_fixed_joints(spec, source, kept)
        bodies = [b for b in spec.bodies if b.name != "world"]
    if options.vhacd_enabled:
        _decompose_meshes(spec, options.vhacd_params, source)
    if options.replace_cylinder_with_capsule:
        from myriad.assets import cylinders_as_capsules
        cylinders_as_capsules(spec)
    armature = float(options.armature)
    if armature:
        if options.use_physx_armature:
            for j in spec.joints:
                if j.type in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE):
                    j.armature = j.armature + armature
        else:           # PhysX: added to the diagonal of every link's inertia tensor
            probe = spec.copy()
            probe.compiler.fusestatic = False
            m = probe.compile()
            for b in bodies:
                i = m.body(b.name).id
                b.explicitinertial = True
                b.mass = float(m.body_mass[i])
                b.ipos = m.body_ipos[i].tolist()
                b.iquat = m.body_iquat[i].tolist()
                b.inertia = (m.body_inertia[i] + armature).tolist()
                b.fullinertia = [np.nan] * 6
    return Asset(spec, options, source, actuators, names)


def _height_grid(vertices: np.ndarray, triangles: np.ndarray):
    """(heights [rows, cols] m, spacing m, origin (x, y) m, riser m) when the mesh is a height
    field's grid as terrain_utils.convert_heightfield_to_trimesh makes it (vertex i·cols + j
    at sample (i, j), two triangles per cell, any vertex possibly moved one sample along x
    and/or y under a higher neighbour); None for any other mesh."""
    n, m = len(vertices), len(triangles)
    total = n - m // 2 + 1                  # rows + cols, from n = rows·cols, m = 2(rows-1)(cols-1)
    disc = total * total - 4 * n
    if m % 2 or disc < 0 or triangles.min(initial=0) < 0 or triangles.max(initial=0) >= n:
        return None
    root = int(round(math.sqrt(disc)))
    if root * root != disc:
        return None
    for rows in {(total + root) // 2, (total - root) // 2}:
        cols = total - rows
        if rows < 2 or cols < 2 or rows * cols != n:
            continue
        i, j = np.divmod(triangles, cols)
        # every triangle inside one cell: its samples span one row and one column step
        if not ((np.ptp(i, axis=1) == 1) & (np.ptp(j, axis=1) == 1)).all():
            continue
        x = vertices[:, 0].reshape(rows, cols)
        y = vertices[:, 1].reshape(rows, cols)
        z = vertices[:, 2].reshape(rows, cols)
        # the spacing over long runs (float32 vertices far out round each step by ~1e-5 m):
        # the median over the far half of the rows (columns), moved vertices being rare
        far_i, far_j = np.arange(rows // 2, rows), np.arange(cols // 2, cols)
        spacing = float(np.median((x[far_i] - x[:1]) / far_i[:, None]))
        spacing_y = float(np.median((y[:, far_j] - y[:, :1]) / far_j[None, :]))
        if not spacing > 0 or not math.isclose(spacing_y, spacing, rel_tol=1e-4):
            continue
        x0, y0 = float(np.median(x - np.arange(rows)[:, None] * spacing)), \
            float(np.median(y - np.arange(cols)[None, :] * spacing))
        move_x = (x - x0) / spacing - np.arange(rows)[:, None]
        move_y = (y - y0) / spacing - np.arange(cols)[None, :]
        if not (np.allclose(move_x, np.rint(move_x), atol=1e-3)
                and np.allclose(move_y, np.rint(move_y), atol=1e-3)):
            continue
        move_x, move_y = np.rint(move_x), np.rint(move_y)
        if np.abs(move_x).max() > 1 or np.abs(move_y).max() > 1:
            continue
        return z.copy(), spacing, (x0, y0), _riser(z, move_x, move_y)
    return None


def _riser(z: np.ndarray, move_x: np.ndarray, move_y: np.ndarray) -> float:
    """The wall height the mesh's moved vertices imply: every step a vertex moved under is
    higher than it, every step an unambiguous vertex (one higher neighbour along the axis) did
    not move under is not; 0 (no walls) when no vertex moved."""
    walls, slopes = [], []
    for h, move in ((z, move_x), (z.T, move_y.T)):
        up = h[1:] - h[:-1]                             # step to the next sample along the axis
        lower_first, lower_next = move[:-1], move[1:]
        walls += [up[(up > 0) & (lower_first == 1)], -up[(up < 0) & (lower_next == -1)]]
        # a vertex whose one higher neighbour along the axis it did not move under
        higher_prev = np.zeros_like(h, dtype=bool)
        higher_prev[1:] = h[:-1] > h[1:]
        higher_next = np.zeros_like(h, dtype=bool)
        higher_next[:-1] = h[1:] > h[:-1]
        alone_next = higher_next[:-1] & ~higher_prev[:-1] & (lower_first == 0)
        alone_prev = higher_prev[1:] & ~higher_next[1:] & (lower_next == 0)
        slopes += [up[alone_next], -up[alone_prev]]
    wall = np.concatenate(walls)
    if wall.size == 0:
        return 0.0
    slope = np.concatenate(slopes)
    low, high = (float(slope.max()) if slope.size else 0.0), float(wall.min())
    return (low + high) / 2 if low < high else high * (1 - 1e-6)


def _check_shape_props(props, count: int, call: str, shape_filter: int = 0) -> None:
    if len(props) != count:
        raise ValueError(f"{call}: {len(props)} entries for {count} collision shapes")
    d = RigidShapeProperties()
    for i, p in enumerate(props):
        if not (p.friction >= 0 and 0 <= p.restitution <= 1):
            raise ValueError(f"{call}: shape {i}: friction {p.friction} must be >= 0 and "
                             f"restitution {p.restitution} in [0, 1]")
        if p.filter != shape_filter:
            raise _unsupported(f"{call}: shape {i}: filter={p.filter} (the actor's is "
                               f"{shape_filter})", "collision filters are honoured per actor "
                               "(create_actor's filter), not per shape")
        if getattr(p, "compliance") != d.compliance:
            raise _unsupported(f"{call}: shape {i}: compliance={p.compliance}",
                               "Myriad honours friction and restitution per shape")
        for name in ("rolling_friction", "torsion_friction"):
            if getattr(p, name) != getattr(d, name):
                _warn_once(f"{call}: {name} is not applied (what Isaac Gym's PhysX makes of "
                           "it is not documented; Myriad's torsional and rolling friction are "
                           "MuJoCo's, from MJCF geoms of condim 4 and 6)")


# ---------------------------------------------------------------------------------- prepare
def _prepare(sim: Sim) -> None:
    envs = sim.envs
    if not envs:
        raise ValueError("gym.prepare_sim: the sim has no envs; call gym.create_env and "
                         "gym.create_actor first")
    first = envs[0]
    if not first.actors:
        raise ValueError("gym.prepare_sim: env 0 has no actors")
    for env in envs[1:]:
        for k in range(max(len(env.actors), len(first.actors))):
            a = env.actors[k] if k < len(env.actors) else None
            b = first.actors[k] if k < len(first.actors) else None
            if a is None or b is None or a.asset is not b.asset:
                what = (f"has no actor {k} where env 0 has {b.name!r} ({b.asset.source})"
                        if a is None else
                        f"has an extra actor {k} {a.name!r} ({a.asset.source})" if b is None else
                        f"actor {k} {a.name!r} is made from {a.asset.source}, env 0's actor {k} "
                        f"{b.name!r} from {b.asset.source}")
                raise ValueError(f"gym.prepare_sim: env {env.index} {what}. Myriad needs every "
                                 "env to hold the same actors (same assets, same order)")
    for env in envs:
        for a, b in zip(env.actors, first.actors):
            if a.asset.fix_base and (a.pose.p != b.pose.p or a.pose.r != b.pose.r):
                raise _unsupported(f"gym.prepare_sim: fixed-base actor {a.name!r} of env "
                                   f"{env.index} at another pose than in env 0",
                                   "a fixed base is welded at the same pose in every env")
            if (a.dof_props["driveMode"] != b.dof_props["driveMode"]).any():
                raise _unsupported(f"gym.prepare_sim: actor {a.name!r} of env {env.index} has "
                                   "other DOF drive modes than in env 0",
                                   "drive modes must be the same in every env")
            if _actor_tendon_coefs(a) != _actor_tendon_coefs(b):
                raise _unsupported(f"gym.prepare_sim: actor {a.name!r} of env {env.index} has "
                                   "other fixed tendon joint coefficients than in env 0",
                                   "the coefficients must be the same in every env")
    A = len(first.actors)
    pairs = {}
    for env in envs:
        for i in range(A):
            for j in range(i + 1, A):
                c = _collide(env.actors[i], env.actors[j])
                if pairs.setdefault((i, j), c) != c:
                    raise _unsupported(f"gym.prepare_sim: actors {i} and {j} collide in env 0 "
                                       f"but not in env {env.index} (or the reverse)",
                                       "collision groups/filters must act alike in every env")
    scene = _scene_class()()
    names = [f"a{k}" for k in range(A)]
    self_collide = []
    for env in envs:
        for k, a in enumerate(env.actors):
            sc = a.shape_filter == 0
            if env.index == 0:
                self_collide.append(sc)
            elif self_collide[k] != sc:
                raise _unsupported(f"gym.prepare_sim: actor {a.name!r}: self-collisions on in "
                                   f"one env and off in another (filter)")
    if sim.terrain is not None:
        scene.add_terrain(**sim.terrain)
    if sim.ground is not None:
        g = sim.ground
        scene.add_ground(friction=float(g.static_friction), restitution=float(g.restitution))
        scene.plane_normal = (g.normal.x, g.normal.y, g.normal.z)
        scene.plane_distance = float(g.distance)
    scene.excluded_pairs = [(names[i], names[j]) for (i, j), c in pairs.items() if not c]
    scene.attractors = _attractors(envs, names)
    for mesh in sim.triangle_meshes:
        scene.add_triangle_mesh(**mesh)
    for k, a in enumerate(first.actors):
        modes = [_MODES[int(m)] for m in a.dof_props["driveMode"]]
        p, r = a.pose.p, a.pose.r.normalize()
        scene.add_actor(names[k], a.asset.spec, pos=(p.x, p.y, p.z), quat=(r.x, r.y, r.z, r.w),
                        fix_base=a.asset.fix_base, self_collisions=self_collide[k],
                        dof_mode=modes if modes else "effort", stiffness=1.0, damping=1.0,
                        gravity=not a.asset.options.disable_gravity)
    params = _myriad_params(sim.params)
    efforts = _check_efforts(sim, built=False)

    def fix_model(model):
        for j, (limited, value) in efforts.items():
            model.jnt_actfrclimited[j] = limited
            model.jnt_actfrcrange[j] = (-value, value) if limited else (0.0, 0.0)
        from myriad.assets import physx_tendons
        model.force_sensor_split = True         # PhysX's parts (`_refresh_force_sensors`)
        for k, a in enumerate(first.actors):
            for t, coefs in a.tendon_coefs.items():     # before physx_tendons' 1/coef
                i = model.tendon_names.index(f"{names[k]}/{a.asset.tendon_names[t]}")
                adr = int(model.tendon_adr[i])
                model.wrap_coef[adr:adr + len(coefs)] = coefs
            for name, props in zip(a.asset.tendon_names, a.asset.tendon_props):
                physx_tendons(model, [f"{names[k]}/{name}"], float(props.limit_stiffness),
                              float(props.damping))

    built = scene.build(len(envs), device=sim.device, params=params, fix_model=fix_model)
    sim.myriad, sim.scene, sim.looks = built, scene, None
    _index_maps(sim)
    # each env's own start pose of free actors
    poses = torch.zeros(len(envs), A, 13)
    for env in envs:
        for k, a in enumerate(env.actors):
            r = a.pose.r.normalize()
            poses[env.index, k, :7] = torch.tensor([a.pose.p.x, a.pose.p.y, a.pose.p.z,
                                                    r.x, r.y, r.z, r.w])
    built.set_root_states(poses.to(built.device), forward=False)
    all_actors = [a for env in envs for a in env.actors]
    _apply_dof_props(sim, all_actors)
    _apply_shape_props(sim, all_actors)
    _apply_body_props(sim, all_actors)
    _apply_speed_caps(sim)
    _apply_tendon_props(sim, all_actors)
    _apply_attractor_targets(sim, envs)
    _apply_scales(sim)
    built.forward()


def _apply_scales(sim: Sim) -> None:
    """`set_actor_scale` values into Myriad's per-env geometry and mass: each geom's size and
    position in its body × s, the body's mass × s³ and inertia × s⁵ (uniform density)."""
    built, m = sim.myriad, sim.myriad.model
    for k, first in enumerate(sim.envs[0].actors):
        scale = torch.tensor([env.actors[k].scale for env in sim.envs], dtype=torch.float32)
        if bool((scale == 1.0).all()):
            continue
        bodies = built.actor_bodies(f"a{k}")
        geoms = [g for g in range(m.ngeom) if m.geom_body[g] in bodies
                 and int(m.geom_type[g]) != int(mujoco.mjtGeom.mjGEOM_MESH)]   # drawn only
        s = scale.to(built.device)
        cols = torch.as_tensor(geoms, dtype=torch.long, device=built.device)
        built.sim.geom_size[:, cols] *= s[:, None, None]
        built.sim.geom_pos[:, cols] *= s[:, None, None]
        built.sim.body_mass[:, bodies[0]] *= s**3
        built.sim.body_inertia[:, bodies[0]] *= (s**5)[:, None]


def _actor_algebra(sim: Sim, envs, kind: str, k: int) -> torch.Tensor:
    """Actor slot k's Jacobian or mass matrix in Isaac Gym's (PhysX's) layout, from Myriad's:
    a fixed base's root link row dropped; a free base's angular velocity columns turned from
    the base's own axes (MuJoCo's free joint) to world axes, which Isaac Gym's root states use:
    with w_body = Rᵀ w_world, J_world = J_body Rᵀ and M_world = Tᵀ M T, T = diag(I, Rᵀ, I)."""
    actor = sim.envs[0].actors[k]
    name = f"a{k}"
    if kind == "jacobian":
        value = envs.jacobians(name)
        if actor.asset.fix_base:
            return value[:, 1:].contiguous()
    else:
        value = envs.mass_matrix(name)
        if actor.asset.fix_base:
            return value.contiguous()
    root = envs.actor_bodies(name)[0]
    quat = envs.sim.body_pose[:, root, 3:7]                             # xyzw, world from base
    eye = torch.eye(3, device=value.device).expand(quat.shape[0], 3, 3)
    rot = torch.stack([quat_rotate(quat, eye[:, :, i]) for i in range(3)], dim=-1)   # R
    t = torch.eye(value.shape[-1], device=value.device).repeat(quat.shape[0], 1, 1)
    t[:, 3:6, 3:6] = rot.transpose(1, 2)
    if kind == "jacobian":
        return (value @ t[:, None]).contiguous()
    return (t.transpose(1, 2) @ value @ t).contiguous()


def _index_maps(sim: Sim) -> None:
    built, m = sim.myriad, sim.myriad.model
    dev = built.device
    long = dict(dtype=torch.long, device=dev)
    first = sim.envs[0].actors
    dof_actor = [k for k, a in enumerate(first) for _ in range(a.asset.num_dofs)]
    if len(dof_actor) != built.num_dofs or built.num_bodies != sum(a.asset.num_bodies
                                                                   for a in first):
        raise RuntimeError(f"isaacgym on Myriad: the built model has {built.num_dofs} DOFs and "
                           f"{built.num_bodies} bodies; the assets have {len(dof_actor)} and "
                           f"{sum(a.asset.num_bodies for a in first)} (a bug: please report)")
    sim.dof_actor = torch.as_tensor(dof_actor, **long)
    sim.drive_dofs, sim.drive_ctrl = {}, {}
    modes = np.concatenate([a.dof_props["driveMode"] for a in first]) if dof_actor else \
        np.zeros(0, int)
    for kind, mode in (("pos", DofDriveMode.DOF_MODE_POS), ("vel", DofDriveMode.DOF_MODE_VEL)):
        dofs = np.flatnonzero(modes == int(mode))
        cols = [m.actuator_names.index(built.dof_names[d] + "/drive") for d in dofs]
        sim.drive_dofs[kind] = torch.as_tensor(dofs, **long)
        sim.drive_ctrl[kind] = torch.as_tensor(cols, **long)
    sim.dof_joint = [m.dof_jnt[int(c)] for c in built.dof_columns.cpu().numpy()]
    N = built.num_envs
    sim.position_targets = torch.zeros(N, built.num_dofs, dtype=torch.float32, device=dev)
    sim.velocity_targets = torch.zeros(N, built.num_dofs, dtype=torch.float32, device=dev)
    # the actor's geoms in Myriad's order: its bodies' collision geoms
    sim.actor_shape_geoms = []
    for k, a in enumerate(first):
        prefix = f"a{k}/"
        geoms = [g for g in range(m.ngeom) if m.geom_body[g] >= 0
                 and m.body_names[m.geom_body[g]].startswith(prefix)
                 and (m.geom_contype[g] or m.geom_conaffinity[g])]
        if len(geoms) != len(a.asset.shape_geoms):
            raise RuntimeError(f"isaacgym on Myriad: actor {a.name!r} has {len(geoms)} "
                               f"collision geoms built, {len(a.asset.shape_geoms)} in its asset")
        sim.actor_shape_geoms.append(geoms)

    # force sensors: what each one's flags take of the parts, and which turn to its frame
    flags = torch.tensor([f for a in first for f in a.asset.force_sensor_flags],
                         dtype=torch.float32, device=dev).reshape(-1, 3)
    if len(flags) != len(built.sim.sensor_sites):
        raise RuntimeError(f"isaacgym on Myriad: {len(built.sim.sensor_sites)} force sensor "
                           f"sites built, {len(flags)} sensors made (a bug: please report)")
    sim.sensor_flags = flags
    sim.sensor_site_rows = torch.as_tensor(built.sim.sensor_sites, **long)  # into site_pose
    sim.sensor_readings = torch.zeros(N, len(flags), 6, device=dev)

    def views(kind, envs):
        if kind == "force_sensor":
            _refresh_force_sensors(sim)
            return sim.sensor_readings.view(-1, 6)
        if kind not in sim._views:
            source = {"root": envs.root_states, "dof": envs.dof_state,
                      "body": envs.rigid_body_states, "contact": envs.net_contact_force,
                      "dof_force": envs.dof_forces, "force_sensor": envs.force_sensors}[kind]
            width = {"root": 13, "dof": 2, "body": 13, "contact": 3, "dof_force": None,
                     "force_sensor": 6}[kind]
            sim._views[kind] = (source.view(-1, width) if width else source.view(-1))
        return sim._views[kind]

    sim._views = {}
    sim.myriad_views = views


def _refresh_force_sensors(sim: Sim) -> None:
    """The force sensor tensor from the step's parts (`myriad.Simulator.sensor_forward`,
    `sensor_constraint`: about each sensor's point, world axes), as each sensor's
    ForceSensorProperties take them, in place."""
    if not len(sim.sensor_flags):
        return
    engine = sim.myriad.sim
    forward, constraint = sim.sensor_flags[:, 0, None], sim.sensor_flags[:, 1, None]
    world = engine.sensor_forward * forward + engine.sensor_constraint * constraint
    quat = engine.site_pose[:, sim.sensor_site_rows, 3:].reshape(-1, 4)   # xyzw, env by env
    local = torch.cat([quat_rotate_inverse(quat, world[..., part].reshape(-1, 3))
                       for part in (slice(0, 3), slice(3, 6))], -1).reshape(world.shape)
    # (indices on the device, no mask indexing: a GPU pipeline moves nothing between host and
    # device here)
    torch.where(sim.sensor_flags[:, 2, None] == 0, local, world, out=sim.sensor_readings)


def _attractors(envs: list, names: list) -> list:
    """(body's full name, props) of env 0's attractors, which every env must repeat (each with
    its own target: `_apply_attractor_targets`)."""
    def key(env):
        return [(k, b, int(p.axes), repr(p.offset)) for k, b, p in env.attractors]
    for env in envs[1:]:
        if key(env) != key(envs[0]):
            raise _unsupported(f"gym.prepare_sim: env {env.index}'s attractors differ from env "
                               "0's", "every env must hold the same attractors (bodies, axes "
                               "and offsets; the targets may differ)")
    first = envs[0]
    return [(f"{names[k]}/{first.actors[k].asset.body_names[b]}", p)
            for k, b, p in first.attractors]


def _versions(envs) -> tuple:
    """The version counters of the state tensors `refresh` writes (views share theirs)."""
    return (envs.root_states._version, envs.dof_state._version,
            envs.rigid_body_states._version, envs.dof_forces._version)


def _check_efforts(sim: Sim, built: bool) -> dict:
    """{joint: (limited, effort)} where the DOF effort limits differ from the built model's:
    they must be the same in every env (one limit per joint in Myriad)."""
    first = sim.envs[0].actors
    out = {}
    for k, a in enumerate(first):
        column = np.stack([env.actors[k].dof_props["effort"] for env in sim.envs]) \
            if a.asset.num_dofs else np.zeros((len(sim.envs), 0))
        varies = (column != column[0]).any(axis=0)
        if varies.any():
            names = [a.asset.dof_names[i] for i in np.flatnonzero(varies)]
            raise _unsupported(f"DOF effort limits of {names} (actor {a.name!r}) that differ "
                               "between envs", "one effort limit per DOF for all envs")
        changed = column[0] != a.asset.dof_props["effort"]
        if changed.any() and built:
            names = [a.asset.dof_names[i] for i in np.flatnonzero(changed)]
            raise _unsupported(f"set_actor_dof_properties changing the effort limit of {names} "
                               "after prepare_sim", "effort limits are set when the sim is built")
        for i in np.flatnonzero(changed):
            joint = a.asset.dof_joints[i]
            value = float(column[0, i])
            # the asset's joint order within the composed model: offset by earlier actors
            out[sum(f.asset.mj.njnt for f in first[:k]) + joint] = (value < _FLT_MAX, value)
    return out


def _height_field_fits(sim: Sim, params) -> bool:
    """Whether a height field (or a grid mesh) with these params can be the sim's one height
    field: none yet, and placed unrotated (Myriad's is placed by a translation)."""
    return sim.terrain is None and abs(abs(params.transform.r.normalize().w) - 1.0) <= 1e-6


def _apply_attractor_targets(sim: Sim, envs: list) -> None:
    """Each env's attractor targets into its constraints' world points (and frames)."""
    built = sim.myriad
    mj, s = built.model.mj_model, built.sim
    for env in envs:
        for i, (_, _, props) in enumerate(env.attractors):
            eq = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_EQUALITY, f"attractor{i}")
            p, r = props.target.p, props.target.r.normalize()
            s.eq_anchor[env.index, eq, 1] = torch.tensor([p.x, p.y, p.z])
            s.eq_frame[env.index, eq, 1] = torch.tensor([r.x, r.y, r.z, r.w])


def _checked_tendon_props(call: str, asset: Asset, props: list) -> list:
    """A copy of `props` for the asset's tendons: damping, the spring and the limits may change
    (per actor: Myriad's per-env tendon parameters); whether a tendon is limited, its joints
    and its type must stay the asset's (they decide the rows the engine builds)."""
    if len(props) != len(asset.tendon_props):
        raise ValueError(f"gym.{call}: {len(props)} entries for {len(asset.tendon_props)} "
                         f"tendons of {asset.source}")
    for i, (new, old) in enumerate(zip(props, asset.tendon_props)):
        name = asset.tendon_names[i]
        for field in ("is_fixed_limited", "num_joints", "num_attachments", "type"):
            if getattr(new, field) != getattr(old, field):
                raise _unsupported(f"gym.{call} changing {field} of tendon {name!r}",
                                   "limit_stiffness, damping, stiffness, "
                                   "fixed_spring_rest_length, fixed_lower_limit and "
                                   "fixed_upper_limit can change")
        if not (new.limit_stiffness >= 0 and new.damping >= 0 and new.stiffness >= 0):
            raise ValueError(f"gym.{call}: tendon {name!r}: limit_stiffness, damping and "
                             f"stiffness must be >= 0")
        if not new.fixed_lower_limit <= new.fixed_upper_limit:
            raise ValueError(f"gym.{call}: tendon {name!r}: fixed_lower_limit "
                             f"{new.fixed_lower_limit} above fixed_upper_limit "
                             f"{new.fixed_upper_limit}")
    return copy.deepcopy(list(props))


def _apply_tendon_props(sim: Sim, actors: list) -> None:
    """Each actor's tendon properties and offsets into its env's parameters. PhysX's offset
    is added to the accumulated length Σ coef·q where the spring reads it (no force at
    Σ coef·q + offset = rest length), not where the limits do: Myriad's rest length takes it."""
    built = sim.myriad
    names, s = built.model.tendon_names, built.sim
    for actor in actors:
        e = actor.env.index
        for name, props, offset in zip(actor.asset.tendon_names, actor.tendon_props,
                                       actor.tendon_offsets):
            t = names.index(f"a{actor.index}/{name}")
            s.tendon_limit_stiffness[e, t] = float(props.limit_stiffness)
            s.tendon_damping[e, t] = float(props.damping)
            s.tendon_stiffness[e, t] = float(props.stiffness)
            s.tendon_rest_length[e, t] = float(props.fixed_spring_rest_length) - float(offset)
            s.tendon_range[e, t] = torch.tensor([float(props.fixed_lower_limit),
                                                 float(props.fixed_upper_limit)])


def _apply_dof_props(sim: Sim, actors: list) -> None:
    """DOF properties into Myriad's per-env parameters (see docs/isaacgym.md for the map)."""
    built = sim.myriad
    s, m = built.sim, built.model
    for actor in actors:
        e, p = actor.env.index, actor.dof_props
        for i in range(actor.asset.num_dofs):
            d = actor.dof_offset + i
            col = int(built.dof_columns[d])
            j = sim.dof_joint[d]
            mode = int(p["driveMode"][i])
            kp, kv = float(p["stiffness"][i]), float(p["damping"][i])
            if mode in (DofDriveMode.DOF_MODE_POS, DofDriveMode.DOF_MODE_VEL):
                name = built.dof_names[d] + "/drive"
                a = m.actuator_names.index(name)
                s.actuator_kp[e, a] = kp if mode == DofDriveMode.DOF_MODE_POS else 0.0
                s.actuator_kv[e, a] = kv
                s.joint_stiffness[e, j] = 0.0
                s.dof_damping[e, col] = 0.0
            else:       # no drive: the gains act as a spring to 0 and a damper
                s.joint_stiffness[e, j] = kp
                s.dof_damping[e, col] = kv
            s.dof_frictionloss[e, col] = float(p["friction"][i])
            s.dof_armature[e, col] = float(p["armature"][i])
            s.dof_max_velocity[e, col] = float(p["velocity"][i])
            if p["hasLimits"][i]:
                s.joint_range[e, j, 0] = float(p["lower"][i])
                s.joint_range[e, j, 1] = float(p["upper"][i])


def _apply_shape_props(sim: Sim, actors: list) -> None:
    s = sim.myriad.sim
    for actor in actors:
        geoms = sim.actor_shape_geoms[actor.index]
        for g, prop in zip(geoms, actor.shape_props):
            s.geom_friction[actor.env.index, g] = float(prop.friction)
            s.geom_restitution[actor.env.index, g] = float(prop.restitution)


def _apply_speed_caps(sim: Sim) -> None:
    """Each asset's body speed caps (AssetOptions.max_angular_velocity, max_linear_velocity)
    on its actors' bodies, one slice per actor slot: every env holds the same assets."""
    s = sim.myriad.sim
    for actor in sim.envs[0].actors:
        bodies = slice(actor.body_offset, actor.body_offset + actor.asset.num_bodies)
        s.body_max_angular_velocity[:, bodies] = float(actor.asset.options.max_angular_velocity)
        s.body_max_linear_velocity[:, bodies] = float(actor.asset.options.max_linear_velocity)


def _apply_body_props(sim: Sim, actors: list) -> None:
    built = sim.myriad
    s, m = built.sim, built.model
    for actor in actors:
        for i, prop in enumerate(actor.body_props):
            b = actor.body_offset + i
            s.body_mass[actor.env.index, b] = float(prop.mass)
            rot = _quat_matrix(m.body_iquat[b])     # Myriad's principal axes (xyzw)
            principal = rot.T @ prop.inertia._t() @ rot
            off = principal - np.diag(np.diag(principal))
            if np.abs(off).max() > 1e-6 * max(np.abs(principal).max(), 1e-12):
                name = actor.asset.body_names[i]
                raise _unsupported(f"set_actor_rigid_body_properties: body {name!r}: an inertia "
                                   "with other principal axes than the asset's",
                                   "Myriad keeps each body's principal axes")
            s.body_inertia[actor.env.index, b] = torch.as_tensor(np.diag(principal).copy(),
                                                                 dtype=torch.float32)


# the calls whose wall time each performance timer adds up (a timed call inside another counts
# once, for the outer one)
_TIMED = {"physics_sim": ("simulate", "fetch_results"),
          "physics_data_movement": tuple(
              name for name in vars(Gym) if name.startswith("refresh_")
              or (name.startswith(("set_", "apply_")) and "_tensor" in name)),
          "graphics_sensor_rendering": ("render_all_camera_sensors",),
          "graphics_image_retrieval": ("get_camera_image", "start_access_image_tensors"),
          "graphics_viewer_rendering": ("step_graphics", "draw_viewer"),
          "frame_idling": ("sync_frame_time",)}


def _timed(method, field: str):
    @functools.wraps(method)
    def timed(self, *args, **kwargs):
        sim = next((a for a in args[:2] if isinstance(a, Sim)), None)
        if sim is None or not sim.timers or sim.timing:
            return method(self, *args, **kwargs)
        sim.timing, start = True, time.perf_counter()
        try:
            return method(self, *args, **kwargs)
        finally:
            sim.timing = False
            seconds = time.perf_counter() - start
            for fields in sim.timers.values():
                fields[field] += seconds
    return timed


for _field, _names in _TIMED.items():
    for _name in _names:
        setattr(Gym, _name, _timed(getattr(Gym, _name), _field))


def _actor_tendon_coefs(actor: _Actor) -> list:
    """The actor's joint coefficients of each of its fixed tendons (its own, else the
    asset's)."""
    return [_GYM.get_actor_fixed_tendon_joint_coefficients(actor.env, actor.index, t)
            for t in range(len(actor.asset.tendon_names))]


def acquire_gym() -> Gym:
    """The Gym interface (one object; any number of sims)."""
    return _GYM


_GYM = Gym()


def __getattr__(name):
    if name.startswith("__"):
        raise AttributeError(name)
    raise _not_provided(f"isaacgym.gymapi.{name}")
