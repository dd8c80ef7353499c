"""A tolerant asset front end: load what Isaac Gym loads, even where MuJoCo's compiler refuses.

`load` hands a file to MuJoCo unchanged. Isaac Gym's importers accept files MuJoCo refuses
(IsaacGymEnvs' own assets among them), so `load_asset` repairs those first, each repair with one
`RuntimeWarning` naming the file, the element (and line, where known) and what was done:

MJCF
- an attribute MuJoCo does not know on an element that only sets options, memory or drawing
  (`<option apirate collision>`, `<flag>` names that no longer exist, `<size>`, `<visual>`'s
  children, `<statistic>`) is removed; the flag `passive` becomes its successors `spring` and
  `damper`. Isaac Gym reads none of these. MuJoCo's own error message names the attribute: the
  file is parsed, the one attribute removed, and parsed again (a bounded number of times).
  An unknown attribute anywhere else (a geom, a joint, the compiler) stays a `ModelError`.
URDF
- a link with several `<inertial>` elements keeps the first (as URDF readers do);
- an `<inertial>` with a `<density>` (Isaac Gym's extension) and no `<mass>` gets the mass of
  that density filling its link's collision primitives;
- an `<inertial>` without `<inertia>` gets the inertia of its link's collision primitives
  (box, cylinder, sphere: closed forms, the mass shared by volume, moved to the inertial frame
  by the parallel-axis theorem); without primitive collision geometry, that of a uniform 0.1 m
  cube of the given mass (m * 0.01 / 6 about each axis);
- `package://pkg/...` mesh paths are resolved against a folder named `pkg` found upward from
  the file, in `package_paths`, or in `ROS_PACKAGE_PATH`;
- a visual mesh MuJoCo cannot read (`.dae`) or cannot find is dropped (visuals only draw); a
  collision mesh in such a format is replaced by a same-named `.stl`/`.obj` next to it, else it
  is a `ModelError`.
- a mesh in a format MuJoCo cannot read (`.glb`, ...) is replaced by a same-named `.stl`/`.obj`
  next to it, else converted to `.obj` with trimesh where installed; failing both, if only
  non-colliding geoms (contype = conaffinity = 0) use it, the
  mesh and those geoms are dropped (they only draw); else it is a `ModelError`.
Both
- a reference to a material or texture that is not defined (or a texture whose image file is
  missing) is dropped: materials and textures only draw;
- an inertia whose principal moments a <= b <= c break the triangle inequality (a + b < c, which
  MuJoCo refuses) is balanced by raising the two smallest moments by half the deficit each,
  (c - a - b) / 2 (plus 1e-9 c against rounding), so that a + b = c: the smallest change, in
  the sum of squares, that makes the inertia physical; the principal axes and the largest
  moment are kept. MuJoCo's `balanceinertia` instead sets all three moments to their mean,
  which also lowers the largest. A moment of 0 or below (a thin rod's axis written as 0, a
  sign slip in a product of inertia; MuJoCo refuses both) is first raised to 1e-3 of the
  largest, then the rule above applies.
- Isaac Gym's base: the root body is free-floating unless `fix_base_link` (MuJoCo welds a URDF's
  root link to the world). A root body without joints gets a free joint; with
  `fix_base_link=True`, a root's free joint is removed. This is an option, not a repair: no
  warning. A root with other joints and no `fix_base_link` has them replaced by a free joint
  (Isaac Gym floats it; one warning).
- a limited joint whose range is a single value (lower = upper) is made unlimited (Isaac Gym
  sets no limit there).
Anything else MuJoCo refuses stays a `ModelError` naming the file and the element.
"""

from __future__ import annotations

import os
import re
import sys
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np

from .importer import _check_finite_text, from_mujoco
from .model import Model, ModelError

_MAX_REPAIRS = 100
# elements whose attributes set options, memory or drawing only (Isaac Gym reads none of them)
_OPTION_ELEMENTS = {"option", "flag", "size", "statistic", "visual", "global", "quality",
                    "headlight", "map", "scale", "rgba"}
_FLAG_SUCCESSORS = {"passive": ("spring", "damper")}  # MuJoCo 3.0 split this flag in two
_REPEATED_NAME = re.compile(r"repeated name '([^']+)' in (\w+)")
_UNKNOWN_ATTRIBUTE = re.compile(r"unrecognized attribute: '([^']+)'\s*Element '([^']+)'")
_MESH_FORMATS = (".stl", ".obj", ".msh")  # what MuJoCo's compiler reads
_MOMENT_FLOOR = 1e-3  # the smallest principal moment kept, as a share of the largest
_DEFAULT_CUBE = 0.1  # m: the side of the uniform cube whose inertia a bare <inertial> gets


def load_asset(path, *, fix_base_link: bool = False, package_paths=()) -> Model:
    """Read an MJCF or URDF file into a `Model` as Isaac Gym would: repaired where MuJoCo
    refuses it (see the module's docstring), the root free-floating unless `fix_base_link`."""
    path = os.fspath(path)
    spec = asset_spec(path, fix_base_link=fix_base_link, package_paths=package_paths)
    try:
        mj_model = spec.compile()
    except Exception as err:
        raise ModelError(f"{path}: MuJoCo rejected the model: {err}") from err
    with open(path, "rb") as f:
        _check_finite_text(f.read(), path, os.path.dirname(path))
    return from_mujoco(mj_model, source=path)


def asset_spec(path, *, fix_base_link: bool = False, package_paths=()) -> mujoco.MjSpec:
    """The repaired `MjSpec` of an MJCF or URDF file (warnings emitted), not yet compiled."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ModelError(f"{path}: no such model file")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    folder = os.path.dirname(os.path.abspath(path))
    if re.search(r"<robot[\s>]", _blank_comments(text)):
        urdf = True
        text = _repair_urdf(path, text, folder, package_paths)
        try:
            spec = mujoco.MjSpec.from_string(text)
        except Exception as err:  # the text was rewritten: its lines may not be the file's
            raise ModelError(f"{path}: MuJoCo rejected the model (line numbers are those of "
                             f"the repaired URDF): {err}") from err
    else:
        urdf = False
        spec = _parse_mjcf(path, text, folder)
    spec.modelfiledir = os.path.join(folder, "")  # assets resolve as if read from the file
    _drop_missing_drawing_assets(spec, path)
    if not urdf:
        _drop_unreadable_visual_meshes(spec, path, folder)
    _balance_inertias(spec, path, "link" if urdf else "body")
    _set_base(spec, fix_base_link)
    _open_locked_ranges(spec, path)
    return spec


def _warn(message: str) -> None:
    """A `RuntimeWarning` attributed to the first caller outside this module."""
    frame, level = sys._getframe(0), 1
    while frame is not None and frame.f_globals.get("__name__") == __name__:
        frame, level = frame.f_back, level + 1
    warnings.warn(message, RuntimeWarning, stacklevel=level)


def _some(labels: list[str], shown: int = 6) -> str:
    return ", ".join(labels[:shown]) + (f" and {len(labels) - shown} more" if len(labels) > shown
                                        else "")


def _blank_comments(text: str) -> str:
    """`text` with comments blanked out, offsets and line numbers unchanged."""
    return re.sub(r"<!--.*?-->", lambda m: re.sub(r"[^\n]", " ", m.group()), text, flags=re.S)


# ---------------------------------------------------------------------------------- MJCF
def _parse_mjcf(path: str, text: str, folder: str) -> mujoco.MjSpec:
    """Parse, removing one unknown option/drawing attribute per MuJoCo error, and parse again.
    Included files are read here and passed in memory, so that they can be repaired too."""
    texts = {path: text}
    pending = [text]
    while pending:
        for name in re.findall(r"<include\s[^>]*?file\s*=\s*[\"']([^\"']+)", _blank_comments(
                pending.pop())):
            full = os.path.join(folder, name)
            if name not in texts and os.path.isfile(full):
                with open(full, encoding="utf-8") as f:
                    texts[name] = f.read()
                pending.append(texts[name])
    for _ in range(_MAX_REPAIRS):
        try:
            return mujoco.MjSpec.from_string(texts[path], include={
                k: v.encode() for k, v in texts.items() if k != path})
        except Exception as err:
            found = _UNKNOWN_ATTRIBUTE.search(str(err))
            repeated = _REPEATED_NAME.search(str(err))
            if repeated and _rename_repeated(texts, path, folder, repeated.group(2),
                                             repeated.group(1)):
                continue
            if not (found and found.group(2) in _OPTION_ELEMENTS
                    and _remove_attribute(texts, path, folder, found.group(2), found.group(1))):
                raise ModelError(f"{path}: MuJoCo rejected the model: {err}") from err
    raise ModelError(f"{path}: more than {_MAX_REPAIRS} unknown attributes; not repaired")


def _rename_repeated(texts: dict, path: str, folder: str, tag: str, name: str) -> bool:
    """Give the second `<tag name="name">` in the model's files a unique name (`name_2`, ...;
    references by name still mean the first); warn with the file and the line. False if there
    is no second one (the name is repeated across kinds MuJoCo keeps apart, or in a form this
    does not read)."""
    named = re.compile(rf"<{re.escape(tag)}\b[^>]*?\sname\s*=\s*([\"'])({re.escape(name)})\1")
    taken = set(re.findall(r"\sname\s*=\s*[\"']([^\"']+)", "".join(texts.values())))
    seen = 0
    for file, text in texts.items():
        for match in named.finditer(_blank_comments(text)):
            seen += 1
            if seen < 2:
                continue
            k = 2
            while f"{name}_{k}" in taken:
                k += 1
            texts[file] = text[:match.start(2)] + f"{name}_{k}" + text[match.end(2):]
            line = text.count("\n", 0, match.start()) + 1
            _warn(f"{file if file == path else os.path.join(folder, file)}: line {line}: a "
                  f"second <{tag}> named {name!r} renamed {name}_{k} (MuJoCo needs unique "
                  f"names; references by name mean the first)")
            return True
    return False


def _remove_attribute(texts: dict, path: str, folder: str, tag: str, attr: str) -> bool:
    """Remove (or, for a renamed flag, rename) `attr` from the first `<tag>` that has it in the
    model's files; warn with the file and the line. False if none has it."""
    attribute = re.compile(rf"\s{re.escape(attr)}\s*=\s*(\"[^\"]*\"|'[^']*')")
    for name, text in texts.items():
        for tag_match in re.finditer(rf"<{re.escape(tag)}\b[^>]*>", _blank_comments(text)):
            found = attribute.search(text, tag_match.start(), tag_match.end())
            if not found:
                continue
            value = found.group(1)
            line = text.count("\n", 0, tag_match.start()) + 1
            new = " ".join(f"{s}={value}" for s in _FLAG_SUCCESSORS.get(attr, ()))
            texts[name] = text[:found.start()] + (" " + new if new else "") + text[found.end():]
            file = name if name == path else os.path.join(folder, name)
            _warn(f"{file}: line {line}: <{tag}> attribute {attr}={value} is unknown to MuJoCo "
                  f"{mujoco.__version__}; " + (f"replaced by {new}" if new else "removed")
                  + " (it only sets options or drawing, which Isaac Gym does not read)")
            return True
    return False


# ---------------------------------------------------------------------------------- URDF
def _repair_urdf(path: str, text: str, folder: str, package_paths) -> str:
    """The URDF text with inertias completed, mesh paths absolute, unreadable meshes handled,
    and the MuJoCo options that keep visuals and full paths."""
    try:
        robot = ET.fromstring(text)
    except ET.ParseError as err:
        raise ModelError(f"{path}: malformed XML: {err}") from err
    mj = robot.find("mujoco")
    if mj is None:
        mj = ET.Element("mujoco")
        robot.insert(0, mj)
    compiler = mj.find("compiler")
    if compiler is None:
        compiler = ET.SubElement(mj, "compiler")
    base = os.path.join(folder, compiler.get("meshdir", ""))
    compiler.set("meshdir", base)
    compiler.attrib.setdefault("strippath", "false")
    compiler.attrib.setdefault("discardvisual", "false")
    roots = [*map(os.fspath, package_paths),
             *filter(None, os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep))]
    dropped = []
    for link in robot.iter("link"):
        name = link.get("name", "")
        extra = link.findall("inertial")[1:]
        for inertial in extra:      # URDF readers (urdfdom, Isaac Gym's) take the first
            link.remove(inertial)
        if extra:
            _warn(f"{path}: link {name!r} has {len(extra) + 1} <inertial> elements; the first "
                  "is used, as URDF readers do")
        for inertial in link.findall("inertial"):
            _mass_from_density(path, name, link, inertial)
            if inertial.find("inertia") is None:
                _complete_inertia(path, name, link, inertial)
        for kind in ("visual", "collision"):
            for element in link.findall(kind):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                uri = mesh.get("filename", "")
                file = _resolve(uri, base, folder, roots)
                if file and not file.lower().endswith(_MESH_FORMATS) and kind == "collision":
                    stem = os.path.splitext(file)[0]
                    substitute = next((stem + e for e in (".stl", ".obj", ".STL", ".OBJ")
                                       if os.path.isfile(stem + e)), None)
                    if substitute is None:
                        raise ModelError(f"{path}: link {name!r}: collision mesh {uri!r}: MuJoCo "
                                         "cannot read this format, and no .stl or .obj of the "
                                         "same name is next to it")
                    _warn(f"{path}: link {name!r}: collision mesh {uri!r} is in a format MuJoCo "
                          f"cannot read; using {substitute} instead")
                    file = substitute
                if file and file.lower().endswith(_MESH_FORMATS):
                    mesh.set("filename", file)
                elif kind == "visual":
                    dropped.append(f"link {name!r} ({uri})")
                    link.remove(element)
                else:
                    raise ModelError(f"{path}: link {name!r}: collision mesh {uri!r} not found")
    if dropped:
        _warn(f"{path}: {len(dropped)} visual mesh(es) MuJoCo cannot read or find dropped (they "
              f"only draw): {_some(dropped)}")
    return ET.tostring(robot, encoding="unicode")


def _resolve(uri: str, base: str, folder: str, roots) -> str | None:
    """The absolute path of a URDF mesh `filename`, None where it is not found. `package://pkg/
    rest` is looked for in a folder named `pkg` upward from the file, then in each of `roots`
    (a folder `pkg` directly inside it, or the root itself if so named; not recursively).
    A relative path is looked for from the file's mesh base, then from each folder upward of
    the file and from each of `roots` (Isaac Gym resolves IsaacGymEnvs' Allegro meshes,
    written from the asset root, that way)."""
    if uri.startswith("file://"):
        uri = uri[len("file://"):]
    if not uri.startswith("package://"):
        if os.path.isabs(uri):
            return uri if os.path.isfile(uri) else None
        up, candidates = folder, [base]
        while os.path.dirname(up) != up:
            candidates.append(up)
            up = os.path.dirname(up)
        for candidate in candidates + [os.fspath(r) for r in roots]:
            file = os.path.join(candidate, uri)
            if os.path.isfile(file):
                return os.path.abspath(file)
        return None
    package, _, rest = uri[len("package://"):].partition("/")
    candidates, up = [], folder
    while True:
        candidates += [os.path.join(up, package), up]
        if os.path.dirname(up) == up:
            break
        up = os.path.dirname(up)
    for root in roots:
        candidates += [os.path.join(root, package), root]
    for candidate in candidates:  # only folders named `pkg`
        if os.path.basename(os.path.normpath(candidate)) == package \
                and os.path.isfile(os.path.join(candidate, rest)):
            return os.path.abspath(os.path.join(candidate, rest))
    return None


def _numbers(element, attr: str, default: str) -> np.ndarray:
    """The numbers of `element`'s attribute `attr` (`default` where it or the element is absent)."""
    text = element.get(attr) if element is not None else None
    return np.array((text or default).split(), dtype=float)


def _frame(origin) -> tuple[np.ndarray, np.ndarray]:
    """Position and rotation matrix of a URDF `<origin xyz rpy>` (rpy: fixed-axis x, y, z)."""
    (r, p, y), xyz = _numbers(origin, "rpy", "0 0 0"), _numbers(origin, "xyz", "0 0 0")
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return xyz, rz @ ry @ rx


def _primitive(geometry) -> tuple[float, np.ndarray] | None:
    """Volume and inertia per unit mass (about the centre, in the geometry's frame) of a URDF
    box, cylinder (axis z) or sphere; None for anything else."""
    shape = geometry[0] if geometry is not None and len(geometry) else None
    if shape is None:
        return None
    if shape.tag == "box":
        x, y, z = _numbers(shape, "size", "0 0 0")
        return x * y * z, np.diag([y * y + z * z, x * x + z * z, x * x + y * y]) / 12
    if shape.tag == "cylinder":
        r, h = float(shape.get("radius", 0)), float(shape.get("length", 0))
        side = (3 * r * r + h * h) / 12
        return np.pi * r * r * h, np.diag([side, side, r * r / 2])
    if shape.tag == "sphere":
        r = float(shape.get("radius", 0))
        return 4 / 3 * np.pi * r ** 3, np.eye(3) * 0.4 * r * r
    return None


def _mass_from_density(path: str, link_name: str, link, inertial) -> None:
    """An `<inertial>` that gives a `<density>` (Isaac Gym's extension) instead of a `<mass>`:
    the mass is that density times the volume of the link's collision primitives; the
    `<density>` element, which MuJoCo does not know, is removed either way."""
    density = inertial.find("density")
    if density is None:
        return
    inertial.remove(density)
    if inertial.find("mass") is not None:
        return
    value = float(density.get("value", "nan"))
    parts = [_primitive(c.find("geometry")) for c in link.findall("collision")]
    if not (value > 0) or not parts or any(p is None for p in parts):
        raise ModelError(f"{path}: link {link_name!r}: <inertial> gives <density "
                         f"value={density.get('value')!r}> and no <mass>; a mass from a density "
                         "needs a positive density and box, cylinder or sphere collisions")
    mass = value * sum(p[0] for p in parts)
    ET.SubElement(inertial, "mass", {"value": repr(float(mass))})
    _warn(f"{path}: link {link_name!r}: <inertial> has a <density> ({value:g} kg/m³) and no "
          f"<mass>: mass {mass:.6g} kg from the volume of its collision primitives")


def _complete_inertia(path: str, link_name: str, link, inertial) -> None:
    """Add the `<inertia>` an `<inertial>` lacks (see the module's docstring for the rule)."""
    mass = float(_numbers(inertial.find("mass"), "value", "0")[0])
    center, rotation = _frame(inertial.find("origin"))
    parts = []
    for collision in link.findall("collision"):
        part = _primitive(collision.find("geometry"))
        if part is None:
            parts = []
            break
        parts.append((*part, *_frame(collision.find("origin"))))
    volume = sum(p[0] for p in parts)
    if volume > 0:
        inertia = np.zeros((3, 3))
        for v, unit, pos, rot in parts:
            m, d = mass * v / volume, pos - center
            inertia += m * (rot @ unit @ rot.T + d @ d * np.eye(3) - np.outer(d, d))
        inertia = rotation.T @ inertia @ rotation  # in the inertial frame
        how = (f"computed from its {len(parts)} collision primitive(s) "
               f"({', '.join(c.find('geometry')[0].tag for c in link.findall('collision'))})")
    else:
        inertia = np.eye(3) * mass * _DEFAULT_CUBE ** 2 / 6
        how = f"that of a uniform {_DEFAULT_CUBE} m cube (no primitive collision geometry)"
    values = dict(ixx=inertia[0, 0], iyy=inertia[1, 1], izz=inertia[2, 2], ixy=inertia[0, 1],
                  ixz=inertia[0, 2], iyz=inertia[1, 2])
    ET.SubElement(inertial, "inertia", {k: repr(float(v)) for k, v in values.items()})
    _warn(f"{path}: link {link_name!r}: <inertial> has no <inertia>; with mass {mass:g}, "
          f"{how}: " + " ".join(f"{k}={v:.6g}" for k, v in values.items()))


# ---------------------------------------------------------------------------------- spec
def _drop_missing_drawing_assets(spec: mujoco.MjSpec, path: str) -> None:
    """Drop textures whose image file is missing, and references to undefined materials or
    textures (they only draw): one warning per missing name, listing the elements."""
    folder = spec.modelfiledir
    dirs = [os.path.join(folder, d) for d in (spec.compiler.texturedir, spec.compiler.meshdir, "")]
    for texture in list(spec.textures):
        if texture.file and not any(os.path.isfile(os.path.join(d, texture.file)) for d in dirs):
            _warn(f"{path}: texture {texture.name!r}: image file {texture.file!r} not found; "
                  "texture dropped (it only draws)")
            spec.delete(texture)
    users: dict[tuple[str, str], list[str]] = {}
    textures = {t.name for t in spec.textures}
    for material in spec.materials:
        names = list(material.textures)
        for i, name in enumerate(names):
            if name and name not in textures:
                users.setdefault(("texture", name), []).append(f"material {material.name!r}")
                names[i] = ""
        material.textures = names
    materials = {m.name for m in spec.materials}
    for kind, elements in (("geom", spec.geoms), ("site", spec.sites),
                           ("tendon", spec.tendons), ("skin", spec.skins)):
        for i, element in enumerate(elements):
            if element.material and element.material not in materials:
                label = f"{kind} {element.name!r}" if element.name else f"{kind} #{i} (unnamed)"
                users.setdefault(("material", element.material), []).append(label)
                element.material = ""
    for (kind, name), labels in users.items():
        _warn(f"{path}: {kind} {name!r} is not defined; reference dropped from {_some(labels)} "
              f"({kind}s only draw)")


def _drop_unreadable_visual_meshes(spec: mujoco.MjSpec, path: str, folder: str) -> None:
    """MJCF meshes in a format MuJoCo cannot read (`.glb`, `.dae`, ...): replaced by a
    same-named `.stl`/`.obj` next to them if there is one; else, when only drawing geoms
    (contype = conaffinity = 0) use them, the mesh and those geoms are dropped (Isaac Gym draws
    them and gives them no mass); used by a colliding geom, a `ModelError`."""
    dropped = []
    for mesh in list(spec.meshes):
        stem, ext = os.path.splitext(mesh.file)
        if not mesh.file or ext.lower() in _MESH_FORMATS:
            continue
        base = os.path.join(folder, spec.meshdir or "")
        twin = next((stem + e for e in (".stl", ".obj")
                     if os.path.isfile(os.path.join(base, stem + e))), None)
        if twin is not None:
            mesh.file = twin
            continue
        converted = _converted_mesh(os.path.join(base, mesh.file))
        if converted is not None:
            mesh.file = converted
            _warn(f"{path}: mesh {mesh.name!r} ({os.path.basename(stem + ext)}) is in a format "
                  f"MuJoCo cannot read; read with trimesh and written as {converted}")
            continue
        users = [g for g in spec.geoms if g.meshname == mesh.name]
        colliding = [g.name or "(unnamed)" for g in users if g.contype or g.conaffinity]
        if colliding:
            raise ModelError(f"{path}: mesh {mesh.name!r} ({mesh.file}) is in a format MuJoCo "
                             f"cannot read and collides (geoms {_some(colliding)}); give an "
                             ".stl or .obj of it")
        for g in users:
            spec.delete(g)
        spec.delete(mesh)
        dropped.append(f"{mesh.name} ({mesh.file}, {len(users)} geom(s))")
    if dropped:
        _warn(f"{path}: {len(dropped)} drawing mesh(es) in a format MuJoCo cannot read dropped "
              f"with their non-colliding geoms: {_some(dropped)}")


def _converted_mesh(file: str) -> str | None:
    """`file` (a `.glb`, `.gltf`, `.dae`, `.ply`, ...) read with trimesh, when installed, and
    written as an `.obj` in ~/.cache/myriad/meshes (once per content); None when it cannot be
    read that way."""
    try:
        import hashlib
        import trimesh
        with open(file, "rb") as f:
            digest = hashlib.sha1(f.read()).hexdigest()[:16]
        folder = os.path.join(os.path.expanduser("~"), ".cache", "myriad", "meshes")
        out = os.path.join(folder, f"{os.path.splitext(os.path.basename(file))[0]}-{digest}.obj")
        if not os.path.isfile(out):
            mesh = trimesh.load(file, force="mesh")
            if len(mesh.faces) == 0:
                return None
            os.makedirs(folder, exist_ok=True)
            mesh.export(out + ".part", file_type="obj")
            os.replace(out + ".part", out)
        return out
    except Exception:       # no trimesh, or a file it cannot read either
        return None


def _balance_inertias(spec: mujoco.MjSpec, path: str, kind: str) -> None:
    """Balance each explicit inertia that breaks the triangle inequality (rule: module's
    docstring); warn naming the body and the principal moments before and after."""
    for body in spec.bodies:
        if not body.explicitinertial:
            continue
        full = np.isfinite(body.fullinertia[0])
        if full:
            xx, yy, zz, xy, xz, yz = body.fullinertia
            matrix = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        else:
            matrix = np.diag(body.inertia)
        moments, axes = np.linalg.eigh(matrix)  # ascending
        a, b, c = moments
        floor = _MOMENT_FLOOR * c
        if c <= 0 or (a >= floor and a + b >= c):   # physical, or nothing to balance against
            continue
        # a moment of 0 (a thin rod's axis written as 0) or below (a sign slip in a product
        # of inertia, as URDF exports make) is raised to the floor, MuJoCo refusing both; then
        # the two smallest are raised together where they break the triangle inequality
        a, b = max(a, floor), max(b, floor)
        raise_by = max(0.0, (c * (1 + 1e-9) - a - b) / 2)
        new = np.array([a + raise_by, b + raise_by, c])
        if full:
            m = axes @ np.diag(new) @ axes.T
            body.fullinertia = [m[0, 0], m[1, 1], m[2, 2], m[0, 1], m[0, 2], m[1, 2]]
        else:
            inertia = np.array(body.inertia, dtype=float)
            order = np.argsort(inertia, kind="stable")
            inertia[order] = new
            body.inertia = inertia
        fault = ("breaks A + B >= C" if moments[0] >= floor else
                 f"has a moment at or below {_MOMENT_FLOOR:g} of the largest")
        _warn(f"{path}: {kind} {body.name!r}: principal inertia "
              f"({moments[0]:.6g}, {moments[1]:.6g}, {c:.6g}) {fault}; balanced to "
              f"({new[0]:.6g}, {new[1]:.6g}, {c:.6g}) by raising the two smallest moments")


def _open_locked_ranges(spec: mujoco.MjSpec, path: str) -> None:
    """A limited joint whose range is one value (lower = upper), which MuJoCo refuses, is made
    unlimited: Isaac Gym sets no limit there. IsaacGymEnvs' Ingenuity writes its rotors'
    hinges so and spins its drawn rotors at 50 rad/s on them at every reset, which a locked
    joint would stop with a kick to the whole copter."""
    empty = []
    for j in spec.joints:
        if j.limited == mujoco.mjtLimited.mjLIMITED_TRUE and j.range[0] == j.range[1]:
            j.limited = mujoco.mjtLimited.mjLIMITED_FALSE
            empty.append(j.name or "(unnamed)")
    if empty:
        _warn(f"{path}: joints {_some(empty)} have a one-value range (lower = upper, which "
              "MuJoCo refuses); made unlimited, as Isaac Gym sets no limit there")


def _set_base(spec: mujoco.MjSpec, fix_base_link: bool) -> None:
    """Isaac Gym's base: free unless `fix_base_link` (the first body of the world is the root)."""
    root = spec.worldbody.first_body()
    if root is None or root.mocap:  # a mocap body is moved by the user, never by joints
        return
    joints = list(root.joints)
    free = len(joints) == 1 and joints[0].type == mujoco.mjtJoint.mjJNT_FREE
    if joints and not free and not fix_base_link:
        # Isaac Gym floats the root whatever joints the file gives it (IsaacGymEnvs'
        # Ingenuity: a locked hinge on its chassis, not among its DOFs)
        names = [j.name or "(unnamed)" for j in joints]
        for j in joints:
            spec.delete(j)
        _warn(f"root body {root.name!r}: joints {names} replaced by a free joint (Isaac Gym's "
              "base is free unless fix_base_link)")
        joints = []
    if not joints and not fix_base_link:
        root.add_freejoint()
    elif fix_base_link and len(joints) == 1 and joints[0].type == mujoco.mjtJoint.mjJNT_FREE:
        spec.delete(joints[0])
