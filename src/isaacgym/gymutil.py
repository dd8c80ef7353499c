"""`isaacgym.gymutil` on Myriad: the standard command-line flags and SimParams from them.

`parse_arguments` adds Isaac Gym's flags to an argparse parser and derives the same fields:

    --sim_device cuda:0 | cpu       sim_device_type ("cuda"/"cpu"), compute_device_id (int)
    --pipeline gpu | cpu            use_gpu_pipeline (forced False when sim_device is the CPU)
    --graphics_device_id N
    --physx | --flex                physics_engine (gymapi.SIM_PHYSX / gymapi.SIM_FLEX)
    --num_threads N  --subscenes N  --slices N (default: subscenes)
    --headless, --nographics        when asked for (headless=True, no_graphics=True)

plus `use_gpu` (sim_device_type == "cuda"). On Myriad only the CPU pipeline runs without a GPU:
pass `--sim_device cpu --pipeline cpu` there (the original's defaults are cuda:0 and gpu).

Also Isaac Gym's line geometries (axes, boxes, bounding boxes, spheres, and users' own
`LineGeometry` subclasses) and `draw_lines`, which puts them on Myriad's page through
`gym.add_lines`.
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from . import gymapi


def parse_device_str(device_str: str):
    """"cuda:1" -> ("cuda", 1); "cpu" -> ("cpu", 0); "cuda" -> ("cuda", 0)."""
    kind, _, index = str(device_str).partition(":")
    kind = kind.lower()
    if kind not in ("cpu", "cuda"):
        raise ValueError(f"invalid device string {device_str!r}: expected 'cpu', 'cuda' or "
                         "'cuda:N'")
    return kind, int(index) if index else 0


def parse_arguments(description="Isaac Gym Example", headless=False, no_graphics=False,
                    custom_parameters=None):
    """Parse `sys.argv` with the standard flags and `custom_parameters`: a list of dicts with
    "name" (e.g. "--num_envs") and optionally "type", "default", "help", "action"."""
    parser = argparse.ArgumentParser(description=description)
    if headless:
        parser.add_argument("--headless", action="store_true", help="Run headless without "
                            "creating a viewer window")
    if no_graphics:
        parser.add_argument("--nographics", action="store_true",
                            help="Disable graphics context creation, no viewer window or "
                                 "camera sensors")
    parser.add_argument("--sim_device", type=str, default="cuda:0",
                        help="Physics device as in torch: cuda:0 or cpu")
    parser.add_argument("--pipeline", type=str, default="gpu",
                        help="Tensor API pipeline (cpu or gpu)")
    parser.add_argument("--graphics_device_id", type=int, default=0,
                        help="Graphics device id")
    engine = parser.add_mutually_exclusive_group()
    engine.add_argument("--flex", action="store_true", help="Use the FleX physics engine")
    engine.add_argument("--physx", action="store_true", help="Use the PhysX physics engine")
    parser.add_argument("--num_threads", type=int, default=0, help="Number of cores used by "
                        "PhysX")
    parser.add_argument("--subscenes", type=int, default=0, help="Number of PhysX subscenes")
    parser.add_argument("--slices", type=int, help="Number of client threads that process env "
                        "slices")
    for p in custom_parameters or []:
        if "name" not in p:
            warnings.warn(f"gymutil.parse_arguments: custom parameter without a name: {p}",
                          RuntimeWarning, stacklevel=2)
            continue
        kwargs = {k: p[k] for k in ("type", "default", "help", "action", "nargs", "choices",
                                    "required") if k in p}
        if "action" in kwargs:
            kwargs.pop("type", None)
        parser.add_argument(p["name"], **kwargs)
    args = parser.parse_args()

    args.sim_device_type, args.compute_device_id = parse_device_str(args.sim_device)
    pipeline = args.pipeline.lower()
    if pipeline not in ("cpu", "gpu", "cuda"):
        parser.error(f"invalid pipeline {args.pipeline!r}: expected 'cpu' or 'gpu'")
    args.use_gpu_pipeline = pipeline in ("gpu", "cuda")
    if args.sim_device_type != "cuda" and args.flex:
        print("Can't use Flex with CPU. Changing sim device to 'cuda:0'")
        args.sim_device, args.sim_device_type, args.compute_device_id = "cuda:0", "cuda", 0
    if args.sim_device_type != "cuda" and args.use_gpu_pipeline:
        print("Can't use GPU pipeline with CPU Physics. Changing pipeline to 'CPU'.")
        args.pipeline, args.use_gpu_pipeline = "CPU", False
    args.physics_engine = gymapi.SIM_FLEX if args.flex else gymapi.SIM_PHYSX
    args.use_gpu = args.sim_device_type == "cuda"
    if args.slices is None:
        args.slices = args.subscenes
    return args


def parse_sim_params(args, cfg=None, cfg_sim=None):
    """A gymapi.SimParams from the parsed flags, then the "sim" section of `cfg` (or
    `cfg_sim`): dt, substeps, up_axis ("y"/"z" or the enum), gravity, use_gpu_pipeline and
    the "physx" / "flex" sub-sections (attribute by attribute)."""
    params = gymapi.SimParams()
    params.up_axis = gymapi.UP_AXIS_Z
    params.gravity = gymapi.Vec3(0.0, 0.0, -9.81)
    if args.physics_engine == gymapi.SIM_FLEX:
        params.flex.shape_collision_margin = 0.01
        params.flex.num_outer_iterations = 4
        params.flex.num_inner_iterations = 10
    else:
        params.physx.solver_type = 1
        params.physx.num_position_iterations = 4
        params.physx.num_velocity_iterations = 1
        params.physx.num_threads = args.num_threads
        params.physx.use_gpu = args.use_gpu
        params.physx.num_subscenes = args.subscenes
    params.use_gpu_pipeline = args.use_gpu_pipeline
    section = cfg_sim if cfg_sim is not None else (cfg or {}).get("sim")
    if section:
        parse_sim_config({k: v for k, v in section.items()
                          if k in gymapi.SimParams._fields}, params)
    if args.physics_engine == gymapi.SIM_PHYSX and args.num_threads > 0:
        params.physx.num_threads = args.num_threads
    return params


def parse_sim_config(cfg: dict, params) -> None:
    """Writes a dict of SimParams values into `params` (legged_gym's sim config): dt, substeps,
    up_axis (0/1, "y"/"z" or the enum), gravity (a list), use_gpu_pipeline, and the "physx" /
    "flex" sub-dicts attribute by attribute (contact_collection as its enum). An unknown key
    raises AttributeError naming it."""
    for key, value in cfg.items():
        if key == "up_axis":
            value = {"y": gymapi.UP_AXIS_Y, "z": gymapi.UP_AXIS_Z}.get(value, value)
            params.up_axis = gymapi.UpAxis(int(value))
        elif key == "gravity":
            params.gravity = gymapi.Vec3(*value)
        elif key in ("physx", "flex"):
            target = getattr(params, key)
            for k, v in value.items():
                if k == "contact_collection":
                    v = gymapi.ContactCollection(int(v))
                setattr(target, k, v)
        else:
            setattr(params, key, value)


def _indent_xml(elem, level: int = 0) -> None:
    """Indents an `xml.etree.ElementTree` element in place, two spaces per level (Isaac Gym's
    private helper, which tasks that write MJCF files call before saving them)."""
    pad = "\n" + "  " * level
    children = list(elem)
    if children:
        if not (elem.text or "").strip():
            elem.text = pad + "  "
        for child in children:
            _indent_xml(child, level + 1)
        if not (children[-1].tail or "").strip():
            children[-1].tail = pad
    if level and not (elem.tail or "").strip():
        elem.tail = pad


class LineGeometry:
    """A shape drawn as line segments (Isaac Gym's gymutil geometries): `vertices()` its
    segments' end points [num_lines, 2] and `colors()` one RGB in 0..1 per segment [num_lines],
    both as Vec3 records, in the geometry's frame (its `pose`, if given, already applied).
    Subclasses set `verts` and `_colors` (as users' own geometries do) or override the two."""

    def _set(self, segments, colors, pose=None) -> None:
        """From floats: `segments` [n, 2, 3], `colors` [n, 3]."""
        verts = gymapi._records(np.asarray(segments, dtype=np.float64))
        self.verts = verts if pose is None else pose.transform_points(verts)
        self._colors = gymapi._records(np.asarray(colors, dtype=np.float64))

    def vertices(self):
        return self.verts

    def colors(self):
        return self._colors

    def num_lines(self) -> int:
        return len(self.vertices())

    def instance_verts(self, pose):
        """The vertices moved by `pose` (a gymapi.Transform)."""
        return pose.transform_points(self.vertices())


def _color(color, default=(1.0, 0.0, 0.0)) -> np.ndarray:
    c = default if color is None else color
    if isinstance(c, gymapi.Vec3):
        c = (c.x, c.y, c.z)
    return np.asarray(c, dtype=np.float64).reshape(3)


def _box_edges(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """[12, 2, 3]: the edges of the box with corners `lo`, `hi`."""
    corner = np.array([[(hi if (k >> a) & 1 else lo)[a] for a in range(3)] for k in range(8)])
    return np.array([(corner[k], corner[k | 1 << a]) for k in range(8) for a in range(3)
                     if not (k >> a) & 1])


class AxesGeometry(LineGeometry):
    """A frame's three axes, `scale` long: x red, y green, z blue."""

    def __init__(self, scale: float = 1.0, pose=None):
        ends = np.eye(3) * float(scale)
        self._set(np.stack([np.zeros((3, 3)), ends], axis=1), np.eye(3), pose)


class WireframeBoxGeometry(LineGeometry):
    """The 12 edges of an `xdim` × `ydim` × `zdim` box centred on its frame."""

    def __init__(self, xdim: float = 1.0, ydim: float = 1.0, zdim: float = 1.0, pose=None,
                 color=None):
        half = np.array([xdim, ydim, zdim], dtype=np.float64) / 2.0
        self._set(_box_edges(-half, half), np.tile(_color(color), (12, 1)), pose)


class WireframeBBoxGeometry(LineGeometry):
    """The 12 edges of the box between `bbox`'s two corners ([2, 3]: lowest, highest)."""

    def __init__(self, bbox, pose=None, color=None):
        lo, hi = np.asarray(bbox, dtype=np.float64).reshape(2, 3)
        self._set(_box_edges(lo, hi), np.tile(_color(color), (12, 1)), pose)


class WireframeSphereGeometry(LineGeometry):
    """A sphere of `radius` as `num_lats` half-meridians round its y axis, each cut into
    `num_lons` segments (`color`), and the arcs of latitude joining them at each cut
    (`color2`, else `color`): 2 · num_lats · num_lons lines."""

    def __init__(self, radius: float = 1.0, num_lats: int = 8, num_lons: int = 8, pose=None,
                 color=None, color2=None):
        color = _color(color)
        color2 = color if color2 is None else _color(color2)
        u = 2.0 * np.pi * np.arange(num_lats) / num_lats          # round the y axis
        v = np.pi * np.arange(num_lons + 1) / num_lons            # from +y to -y
        uu, vv = np.meshgrid(u, v, indexing="ij")

        def point(a, b):
            return radius * np.stack([np.sin(b) * np.sin(a), np.cos(b),
                                      np.sin(b) * np.cos(a)], axis=-1)

        meridians = np.stack([point(uu[:, :-1], vv[:, :-1]), point(uu[:, 1:], vv[:, 1:])], -2)
        arcs = np.stack([point(uu[:, 1:], vv[:, 1:]),
                         point(uu[:, 1:] + 2.0 * np.pi / num_lats, vv[:, 1:])], -2)
        segments = np.stack([meridians, arcs], axis=2).reshape(-1, 2, 3)
        colors = np.tile(np.stack([color, color2]), (num_lats * num_lons, 1))
        self._set(segments, colors, pose)


def draw_lines(geom, gym, viewer, env, pose) -> None:
    """Draws `geom` at `pose` (in `env`'s frame) in `viewer` until `gym.clear_lines`; nothing
    without a viewer (headless runs)."""
    gym.add_lines(viewer, env, geom.num_lines(), geom.instance_verts(pose), geom.colors())


def __getattr__(name):
    if name.startswith("__"):
        raise AttributeError(name)
    raise gymapi._not_provided(f"isaacgym.gymutil.{name}")


__all__ = ["parse_arguments", "parse_device_str", "parse_sim_params", "parse_sim_config", "AxesGeometry",
           "WireframeBoxGeometry", "WireframeSphereGeometry", "WireframeBBoxGeometry",
           "draw_lines"]
