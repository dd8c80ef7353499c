"""MJCF and URDF import: MuJoCo's compiler parses the file, we read the compiled `MjModel`.

MuJoCo resolves defaults, `fromto`, inertias from geoms, meshes and URDF conversion; we only
check that what it produced is something our engine simulates faithfully. Anything else raises
`ModelError` naming the file and the element, so that a model never runs silently approximated.

A non-finite number (NaN, infinity, or beyond float32's range) anywhere in the model is a
`ModelError` too, naming the element and the attribute: MuJoCo compiles most of them with only a
warning on stderr, and every env would be NaN after its first step. Two generic checks find
them: one over every attribute of the file's text (MuJoCo reads NaN in some attributes as "not
given", e.g. a geom's mass="nan" silently becomes the mass from its density), and one over every
float field of the compiled `MjModel` (included files, models built in code or by a scene).
"""

from __future__ import annotations

import os
import warnings
import xml.parsers.expat

import mujoco
import numpy as np

from .model import Model, ModelError, dof_tree_spans
from .types import ActuatorKind, DynType, EqualityType, JointType, ObjType, SensorType


def load(path: str | os.PathLike) -> Model:
    """Read an MJCF (.xml) or URDF (.urdf) file into a `Model`."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ModelError(f"{path}: no such model file")
    try:
        mj_model = mujoco.MjModel.from_xml_path(path)
    except Exception as err:  # MuJoCo raises ValueError with the element and line in the text
        raise ModelError(f"{path}: MuJoCo rejected the model: {err}") from err
    with open(path, "rb") as f:
        _check_finite_text(f.read(), path, os.path.dirname(path))
    return from_mujoco(mj_model, source=path)


def load_xml(xml: str, source: str = "<string>") -> Model:
    """Read MJCF text (handy for models generated in code)."""
    try:
        mj_model = mujoco.MjModel.from_xml_string(xml)
    except Exception as err:
        raise ModelError(f"{source}: MuJoCo rejected the model: {err}") from err
    _check_finite_text(xml, source, None)
    return from_mujoco(mj_model, source=source)


def _name(m, objtype, i: int) -> str:
    return mujoco.mj_id2name(m, objtype, i) or ""


def _label(m, objtype, i: int, kind: str) -> str:
    name = _name(m, objtype, i)
    return f"{kind} {name!r}" if name else f"{kind} #{i} (unnamed)"


def _xyzw(wxyz: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(wxyz[..., [1, 2, 3, 0]], dtype=np.float32)


# copies, always: MuJoCo's int32 arrays would otherwise be shared, and a change to the Model
# (`Model.collide_as_triangles`) would change the MjModel that renders and checks it
def _f32(a) -> np.ndarray:
    return np.array(a, dtype=np.float32, order="C")


def _i32(a) -> np.ndarray:
    return np.array(a, dtype=np.int32, order="C")


_F32_MAX = float(np.finfo(np.float32).max)


def _finite(a) -> np.ndarray:
    """True where a value is finite once stored as float32 (what the engine computes in)."""
    a = np.asarray(a, dtype=np.float64)
    return np.isfinite(a) & (np.abs(a) <= _F32_MAX)


_NOT_FINITE = "is not finite (NaN, infinity, or beyond float32's range)"
# attributes that hold names, never numbers (a body may be called "inf")
_NAME_ATTRIBUTES = {"name", "class", "childclass", "model", "file", "prefix"}


def _nonfinite_number(value: str) -> bool:
    """`value` is a list of numbers and one of them is not finite."""
    try:
        numbers = [float(t) for t in value.replace(",", " ").split()]
    except ValueError:
        return False  # text, not numbers
    return bool(numbers) and not _finite(numbers).all()


def _check_finite_text(text: str | bytes, source: str, base_dir: str | None) -> None:
    """Raise `ModelError` at the first attribute written with a non-finite number.

    Works on MJCF and URDF alike (the file's own element and attribute names, with the line);
    follows MJCF `<include file=...>` relative to the model's folder.
    """
    hits, names, stack, includes = [], set(), [], []
    parser = xml.parsers.expat.ParserCreate()

    def start(tag, attrs):
        label = attrs.get("name") or (attrs.get("class", "") if tag == "default" else "")
        names.update(attrs[k] for k in ("name", "class", "childclass") if k in attrs)
        for attr, value in attrs.items():
            if attr not in _NAME_ATTRIBUTES and _nonfinite_number(value):
                named = [f"{t} {n!r}" for t, n in stack if n]
                owner = (f"{tag} {label!r}" if label else f"{tag} in {named[-1]}" if named
                         else f"{tag} (unnamed)")
                hits.append((value, f"{source}: line {parser.CurrentLineNumber}: {owner}: "
                                    f"{attr}=\"{value}\" {_NOT_FINITE}"))
        if tag == "include" and base_dir is not None and "file" in attrs:
            includes.append(os.path.join(base_dir, attrs["file"]))
        stack.append((tag, label))

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(text, True)
    except xml.parsers.expat.ExpatError:
        return  # MuJoCo compiled it; whatever expat dislikes, the MjModel check still runs
    for value, message in hits:
        if value.strip() not in names:  # a reference to an element named like a number
            raise ModelError(message)
    for included in includes:
        if os.path.isfile(included):
            with open(included, "rb") as f:
                _check_finite_text(f.read(), included, base_dir)


# MjModel field -> the attribute it is compiled from, named in the message. These fields are
# checked first and in this order, so that the value a user wrote is named rather than the
# quantities MuJoCo derived from it (a NaN body pos also makes qpos0, dof_M0, ... NaN).
_FIELD_ATTRIBUTE = {
    "body_pos": "<body pos>", "body_quat": "<body quat> (or euler, axisangle, xyaxes, zaxis)",
    "body_gravcomp": "<body gravcomp>",
    "jnt_pos": "<joint pos>", "jnt_axis": "<joint axis>", "jnt_range": "<joint range>",
    "jnt_stiffness": "<joint stiffness>", "jnt_actfrcrange": "<joint actuatorfrcrange>",
    "jnt_margin": "<joint margin>", "jnt_solref": "<joint solreflimit>",
    "jnt_solimp": "<joint solimplimit>",
    "qpos0": "<joint ref>", "qpos_spring": "<joint springref>",
    "dof_damping": "<joint damping>", "dof_armature": "<joint armature>",
    "dof_frictionloss": "<joint frictionloss>", "dof_solref": "<joint solreffriction>",
    "dof_solimp": "<joint solimpfriction>",
    "geom_pos": "<geom pos> (or fromto)", "geom_quat": "<geom quat> (or euler, fromto, ...)",
    "geom_size": "<geom size> (or fromto)", "geom_friction": "<geom friction>",
    "geom_margin": "<geom margin>", "geom_gap": "<geom gap>", "geom_solref": "<geom solref>",
    "geom_solimp": "<geom solimp>", "geom_solmix": "<geom solmix>", "geom_rgba": "<geom rgba>",
    # after the geoms: MuJoCo computes a body's inertia from its geoms when it has no <inertial>
    "body_ipos": "<inertial pos> (or the geoms it is computed from)",
    "body_iquat": "<inertial quat> (or the geoms it is computed from)",
    "body_mass": "<inertial mass> (or its geoms' size, mass, density)",
    "body_inertia": "<inertial diaginertia> (or fullinertia, or its geoms)",
    "site_pos": "<site pos>", "site_quat": "<site quat>", "site_size": "<site size>",
    "actuator_gear": "<actuator gear>", "actuator_ctrlrange": "<actuator ctrlrange>",
    "actuator_forcerange": "<actuator forcerange>",
    "actuator_gainprm": "<actuator gainprm> (or kp, kv)",
    "actuator_biasprm": "<actuator biasprm> (or kp, kv)",
    "tendon_stiffness": "<tendon stiffness>", "tendon_damping": "<tendon damping>",
    "tendon_range": "<tendon range>", "tendon_lengthspring": "<tendon springlength>",
    "wrap_prm": "<tendon><joint coef>",
    "mesh_vert": "<mesh vertex> (or its file, scale)", "hfield_data": "<hfield elevation> (or file)",
    "hfield_size": "<hfield size>", "key_qpos": "<key qpos>", "key_qvel": "<key qvel>",
}
# field prefix -> (object type, MuJoCo's count of such elements, word in messages)
_FIELD_KIND = {
    "body": ("mjOBJ_BODY", "nbody", "body"), "jnt": ("mjOBJ_JOINT", "njnt", "joint"),
    "geom": ("mjOBJ_GEOM", "ngeom", "geom"), "site": ("mjOBJ_SITE", "nsite", "site"),
    "cam": ("mjOBJ_CAMERA", "ncam", "camera"), "light": ("mjOBJ_LIGHT", "nlight", "light"),
    "mesh": ("mjOBJ_MESH", "nmesh", "mesh"), "hfield": ("mjOBJ_HFIELD", "nhfield", "hfield"),
    "mat": ("mjOBJ_MATERIAL", "nmat", "material"), "pair": ("mjOBJ_PAIR", "npair", "pair"),
    "eq": ("mjOBJ_EQUALITY", "neq", "equality constraint"),
    "tendon": ("mjOBJ_TENDON", "ntendon", "tendon"),
    "actuator": ("mjOBJ_ACTUATOR", "nu", "actuator"), "sensor": ("mjOBJ_SENSOR", "nsensor", "sensor"),
    "key": ("mjOBJ_KEY", "nkey", "keyframe"), "flex": ("mjOBJ_FLEX", "nflex", "flex"),
    "skin": ("mjOBJ_SKIN", "nskin", "skin"), "numeric": ("mjOBJ_NUMERIC", "nnumeric", "numeric"),
}


def _field_owner(m, field: str, row: int) -> str:
    """The element that row `row` of MjModel field `field` belongs to, as `_label` writes it."""
    o = mujoco.mjtObj
    if field.startswith("dof_") and row < m.nv:   # a dof is named by its joint
        return _label(m, o.mjOBJ_JOINT, int(m.dof_jntid[row]), "joint")
    if field.startswith("qpos") and row < m.nq:
        return _label(m, o.mjOBJ_JOINT, int(np.searchsorted(m.jnt_qposadr, row, "right") - 1),
                      "joint")
    if field.startswith("wrap_") and row < m.nwrap:
        return _label(m, o.mjOBJ_TENDON,
                      int(np.searchsorted(m.tendon_adr, row, "right") - 1), "tendon")
    if field.startswith("mesh_vert") and row < m.nmeshvert:
        return _label(m, o.mjOBJ_MESH, int(np.searchsorted(m.mesh_vertadr, row, "right") - 1),
                      "mesh")
    if field.startswith("hfield_data") and row < m.nhfielddata:
        return _label(m, o.mjOBJ_HFIELD, int(np.searchsorted(m.hfield_adr, row, "right") - 1),
                      "hfield")
    kind = _FIELD_KIND.get(field.split("_")[0])
    if kind is not None and getattr(m, kind[1]) == getattr(m, field).shape[0]:
        return _label(m, getattr(o, kind[0]), row, kind[2])
    return f"row {row}"


def _check_finite(m, source: str) -> None:
    """Raise `ModelError` naming the element and attribute of the first non-finite number in any
    float field of the compiled model (and of its <option>)."""
    fields = [f for f in dir(m) if not f.startswith("_")
              and isinstance(getattr(m, f, None), np.ndarray) and getattr(m, f).dtype.kind == "f"]
    fields.sort(key=lambda f: list(_FIELD_ATTRIBUTE).index(f) if f in _FIELD_ATTRIBUTE
                else len(_FIELD_ATTRIBUTE))   # stable: the rest in alphabetical order
    for field in fields:
        a = getattr(m, field)
        ok = _finite(a).reshape(len(a), -1).all(axis=1) if a.size else np.ones(0, bool)
        if ok.all():
            continue
        row = int(np.flatnonzero(~ok)[0])
        values = " ".join(f"{v:g}" for v in np.ravel(a[row]))
        what = _FIELD_ATTRIBUTE.get(field, f"MjModel.{field}")
        raise ModelError(f"{source}: {_field_owner(m, field, row)}: {what} = {values} "
                         f"{_NOT_FINITE}")
    for struct in ("opt", "stat"):
        for name in dir(getattr(m, struct)):
            value = getattr(getattr(m, struct), name)
            if not name.startswith("_") and isinstance(value, (float, np.ndarray)) \
                    and np.asarray(value).dtype.kind == "f" and not _finite(value).all():
                values = " ".join(f"{v:g}" for v in np.ravel(value))
                what = f"<option {name}>" if struct == "opt" else f"MjModel.stat.{name}"
                raise ModelError(f"{source}: {what} = {values} {_NOT_FINITE}")


def _check_supported(m, source: str) -> None:
    """Reject every feature whose physics we would otherwise silently drop or change."""
    o = mujoco.mjtObj

    def fail(what: str) -> None:
        raise ModelError(f"{source}: {what}")

    for i in range(m.neq):
        label = _label(m, o.mjOBJ_EQUALITY, i, "equality constraint")
        kind = int(m.eq_type[i])
        if kind not in {int(t) for t in EqualityType}:
            fail(f"{label}: {mujoco.mjtEq(kind).name} equality constraints are not supported "
                 "(connect, weld, joint and tendon are)")
    if m.nflex:
        fail("flex (deformable) elements are not supported")
    if m.nplugin:
        fail("engine plugins are not supported")
    for j in range(m.njnt):
        if m.jnt_actgravcomp[j]:
            fail(f"{_label(m, o.mjOBJ_JOINT, j, 'joint')}: actuatorgravcomp (gravity "
                 "compensation through the actuators) is not supported; the body's own "
                 "gravcomp is")
    for j in range(m.njnt):
        label = _label(m, o.mjOBJ_JOINT, j, "joint")
        if m.jnt_type[j] in (JointType.FREE, JointType.BALL) and m.jnt_stiffness[j] != 0:
            fail(f"{label}: stiffness on free and ball joints is not supported")
        if np.any(m.jnt_stiffnesspoly[j] != 0):
            fail(f"{label}: polynomial stiffness is not supported")
    if np.any(m.dof_dampingpoly != 0):
        fail("polynomial joint damping is not supported")
    for t in range(m.ntendon):
        label = _label(m, o.mjOBJ_TENDON, t, "tendon")
        adr, num = m.tendon_adr[t], m.tendon_num[t]
        if m.wrap_type[adr] == mujoco.mjtWrap.mjWRAP_JOINT:
            for w in range(adr, adr + num):
                if m.jnt_type[m.wrap_objid[w]] not in (JointType.HINGE, JointType.SLIDE):
                    fail(f"{label}: a fixed tendon may only span hinge and slide joints")
        if m.tendon_armature[t] != 0 or np.any(m.tendon_stiffnesspoly[t] != 0) \
                or np.any(m.tendon_dampingpoly[t] != 0):
            fail(f"{label}: tendon armature and polynomial springs are not supported")
        if m.tendon_lengthspring[t, 0] != m.tendon_lengthspring[t, 1]:
            fail(f"{label}: a springlength dead band (two values) is not supported")
    _check_side_sites(m, fail)
    trn = mujoco.mjtTrn
    for a in range(m.nu):
        label = _label(m, o.mjOBJ_ACTUATOR, a, "actuator")
        kind, target = int(m.actuator_trntype[a]), m.actuator_trnid[a, 0]
        if kind not in (trn.mjTRN_JOINT, trn.mjTRN_JOINTINPARENT, trn.mjTRN_TENDON,
                        trn.mjTRN_SITE):
            fail(f"{label}: {trn(kind).name} transmissions are not supported (joint, "
                 "fixed-tendon and site ones are)")
        if kind == trn.mjTRN_SITE and m.actuator_trnid[a, 1] >= 0:
            fail(f"{label}: a site transmission with a refsite is not supported (without one, "
                 "it is)")
        if kind in (trn.mjTRN_JOINT, trn.mjTRN_JOINTINPARENT) and \
                m.jnt_type[target] not in (JointType.HINGE, JointType.SLIDE):
            fail(f"{label}: actuators may only drive hinge and slide joints")
        if m.actuator_dyntype[a] not in {int(t) for t in DynType}:
            fail(f"{label}: {mujoco.mjtDyn(m.actuator_dyntype[a]).name} activation dynamics "
                 "are not supported (none, integrator, filter and filterexact are)")
        if m.actuator_actnum[a] > 1:
            fail(f"{label}: an actuator with {m.actuator_actnum[a]} activations is not supported")
        if m.actuator_delay[a] != 0 or m.actuator_damping[a] != 0 or m.actuator_armature[a] != 0:
            fail(f"{label}: actuator delay, damping and armature are not supported")
        _actuator_kind(m, a, fail)
    for g in range(m.ngeom):
        if m.geom_type[g] not in range(8):
            fail(f"{_label(m, o.mjOBJ_GEOM, g, 'geom')}: geom type {mujoco.mjtGeom(m.geom_type[g]).name} "
                 "is not supported")


def _check_side_sites(m, fail) -> None:
    """A side site inside its wrapping geom asks for MuJoCo's inside wrap, which Myriad does not
    do: refused, judged at the model's initial pose (one forward kinematics for all)."""
    wraps = [w for w in range(m.nwrap) if round(m.wrap_prm[w]) >= 0 and int(m.wrap_type[w]) in
             (mujoco.mjtWrap.mjWRAP_SPHERE, mujoco.mjtWrap.mjWRAP_CYLINDER)]
    if not wraps:
        return
    data = mujoco.MjData(m)
    mujoco.mj_kinematics(m, data)
    for w in wraps:
        side, g = int(round(m.wrap_prm[w])), m.wrap_objid[w]
        local = data.geom_xmat[g].reshape(3, 3).T @ (data.site_xpos[side] - data.geom_xpos[g])
        if np.linalg.norm(local) < m.geom_size[g, 0]:
            t = int(np.searchsorted(m.tendon_adr, w, "right") - 1)
            fail(f"{_label(m, mujoco.mjtObj.mjOBJ_TENDON, t, 'tendon')}: its side site "
                 f"{_name(m, mujoco.mjtObj.mjOBJ_SITE, side)!r} lies inside the geom it wraps: "
                 "MuJoCo's inside wrapping is not supported")


def _tendon_paths(m, body_last_dof: np.ndarray) -> dict:
    """tendon_spatial (row of each spatial tendon, -1 for fixed ones) and tendon_dofspan: the
    dofs a spatial tendon's path moves with, as one range over their dof trees."""
    spatial = np.full(m.ntendon, -1)
    span = np.zeros((m.ntendon, 2))
    dof_span = dof_tree_spans(m.dof_parentid)
    for t in range(m.ntendon):
        adr, num = m.tendon_adr[t], m.tendon_num[t]
        if m.wrap_type[adr] == mujoco.mjtWrap.mjWRAP_JOINT:
            continue
        spatial[t] = spatial.max() + 1
        bodies = [m.site_bodyid[o] if k == mujoco.mjtWrap.mjWRAP_SITE else m.geom_bodyid[o]
                  for k, o in zip(m.wrap_type[adr:adr + num], m.wrap_objid[adr:adr + num])
                  if k != mujoco.mjtWrap.mjWRAP_PULLEY]
        moving = [body_last_dof[b - 1] for b in set(bodies) if b > 0 and body_last_dof[b - 1] >= 0]
        if moving:
            span[t] = (dof_span[moving, 0].min(), dof_span[moving, 1].max())
    return dict(tendon_spatial=_i32(spatial), tendon_dofspan=_i32(span),
                wrap_type=_i32(m.wrap_type))


def _actuator_kind(m, a: int, fail) -> int:
    """Classify an actuator: MuJoCo's motor, position and velocity shortcuts (whatever their
    activation dynamics, e.g. intvelocity is a position actuator on an integrated input), else
    a general affine one."""
    gain, bias = m.actuator_gainprm[a], m.actuator_biasprm[a]
    label = _label(m, mujoco.mjtObj.mjOBJ_ACTUATOR, a, "actuator")
    gaintype, biastype = int(m.actuator_gaintype[a]), int(m.actuator_biastype[a])
    if gaintype not in (mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtGain.mjGAIN_AFFINE) or \
            biastype not in (mujoco.mjtBias.mjBIAS_NONE, mujoco.mjtBias.mjBIAS_AFFINE):
        fail(f"{label}: {mujoco.mjtGain(gaintype).name} gain / {mujoco.mjtBias(biastype).name} "
             "bias is not supported (fixed and affine ones are)")
    fixed = gaintype == mujoco.mjtGain.mjGAIN_FIXED or not np.any(gain[1:3])
    if fixed and (biastype == mujoco.mjtBias.mjBIAS_NONE or not np.any(bias[:3])):
        return ActuatorKind.MOTOR
    if fixed and bias[0] == 0:
        if np.isclose(bias[1], -gain[0]) and bias[1] != 0:
            return ActuatorKind.POSITION  # force = kp*(u - length) - kv*velocity
        if bias[1] == 0 and np.isclose(bias[2], -gain[0]):
            return ActuatorKind.VELOCITY  # force = kv*(u - velocity)
    return ActuatorKind.AFFINE


_FRAME_SENSORS = {SensorType.FRAMEPOS, SensorType.FRAMEQUAT, SensorType.FRAMEXAXIS,
                  SensorType.FRAMEYAXIS, SensorType.FRAMEZAXIS, SensorType.FRAMELINVEL,
                  SensorType.FRAMEANGVEL, SensorType.FRAMELINACC, SensorType.FRAMEANGACC}
_FRAME_OBJECTS = {ObjType.BODY, ObjType.XBODY, ObjType.GEOM, ObjType.SITE}


def _sensor_skipped(m, s: int) -> str | None:
    """Why Myriad does not compute sensor s (None: it does)."""
    kind = int(m.sensor_type[s])
    if kind not in set(SensorType):
        return mujoco.mjtSensor(kind).name
    if m.sensor_delay[s] > 0 or m.sensor_interval[s, 0] > 0:
        return f"{mujoco.mjtSensor(kind).name} with a delay or an interval"
    if kind in _FRAME_SENSORS:
        reftype = int(m.sensor_reftype[s]) if m.sensor_refid[s] >= 0 else int(ObjType.UNKNOWN)
        if int(m.sensor_objtype[s]) not in _FRAME_OBJECTS or \
                reftype not in _FRAME_OBJECTS | {ObjType.UNKNOWN}:
            return f"{mujoco.mjtSensor(kind).name} of a camera"   # Myriad has no cameras
    return None


def _sensors(m, source: str) -> dict:
    """The sensors Myriad computes (`sensors`), in MuJoCo's order, as the Model's sensor_*
    fields. Other sensors do not change the dynamics: they are skipped with one warning naming
    them, rather than refusing a model a user brought for its robot; the values of the kept
    ones stay in MuJoCo's order, closed up where a skipped one was."""
    o = mujoco.mjtObj
    reasons = {s: _sensor_skipped(m, s) for s in range(m.nsensor)}
    kept = [s for s in range(m.nsensor) if reasons[s] is None]
    skipped = [f"{_label(m, o.mjOBJ_SENSOR, s, 'sensor')} ({reasons[s]})"
               for s in range(m.nsensor) if reasons[s] is not None]
    if skipped:
        warnings.warn(f"{source}: {len(skipped)} sensor(s) skipped, not computed: "
                      f"{', '.join(skipped[:6])}{' ...' if len(skipped) > 6 else ''}; "
                      "sim.sensor_data holds the others, in the model's order",
                      RuntimeWarning, stacklevel=4)

    def our_id(objtype, objid):   # our bodies have no world body: MuJoCo's b is our b - 1
        body = np.isin(objtype, [ObjType.BODY, ObjType.XBODY])
        return _i32(np.where(body, objid - 1, objid))

    kept = np.asarray(kept, np.int64)
    objtype, refid = _i32(m.sensor_objtype[kept]), m.sensor_refid[kept]
    reftype = _i32(np.where(refid >= 0, m.sensor_reftype[kept], ObjType.UNKNOWN))
    dim = _i32(m.sensor_dim[kept])
    return dict(
        nsensor=len(kept), nsensordata=int(dim.sum()),
        sensor_names=[_name(m, o.mjOBJ_SENSOR, s) for s in kept],
        sensor_type=_i32(m.sensor_type[kept]), sensor_objtype=objtype,
        sensor_objid=our_id(objtype, m.sensor_objid[kept]), sensor_reftype=reftype,
        sensor_refid=_i32(np.where(refid >= 0, our_id(reftype, refid), -1)),
        sensor_dim=dim, sensor_adr=_i32(np.cumsum(dim) - dim),
        sensor_datatype=_i32(m.sensor_datatype[kept]), sensor_cutoff=_f32(m.sensor_cutoff[kept]))


def _mesh_hulls(m, source: str):
    """Convex hull triangles of every mesh, from MuJoCo's hull graph. A mesh only drawn (every
    geom using it has contype and conaffinity 0) may have none, e.g. a flat decal: it gets an
    empty hull, since it never collides."""
    faces, faceadr, facenum = [], [], []
    nface = 0
    mesh_geoms = m.geom_type == mujoco.mjtGeom.mjGEOM_MESH
    collides = (m.geom_contype != 0) | (m.geom_conaffinity != 0)
    for i in range(m.nmesh):
        adr = m.mesh_graphadr[i]
        if adr < 0 and not (mesh_geoms & (m.geom_dataid == i) & collides).any():
            faceadr.append(nface)
            facenum.append(0)
            continue
        if adr < 0:
            raise ModelError(f"{source}: {_label(m, mujoco.mjtObj.mjOBJ_MESH, i, 'mesh')}: MuJoCo "
                             "computed no convex hull for it, and a geom that collides uses it")
        g = m.mesh_graph[adr:]
        numvert, numface = int(g[0]), int(g[1])
        # layout: numvert, numface, vert_edgeadr[numvert], vert_globalid[numvert],
        #         edge_localid[numvert + 3*numface], face_globalid[3*numface]
        face_globalid = g[2 + 3 * numvert + 3 * numface: 2 + 3 * numvert + 6 * numface]
        tri = face_globalid.reshape(numface, 3) + m.mesh_vertadr[i]
        faces.append(tri)
        faceadr.append(nface)
        facenum.append(numface)
        nface += numface
    face = np.concatenate(faces) if faces else np.zeros((0, 3))
    return _i32(face), _i32(faceadr), _i32(facenum)


def from_mujoco(m, source: str = "<MjModel>") -> Model:
    """Build a `Model` from a compiled `mujoco.MjModel`."""
    _check_finite(m, source)
    _check_supported(m, source)
    o = mujoco.mjtObj
    nbody = m.nbody - 1  # without the world body

    body_parent = _i32(m.body_parentid[1:] - 1)
    body_root = _i32(m.body_rootid[1:] - 1)
    body_jntadr = _i32(m.body_jntadr[1:])
    body_jntnum = _i32(m.body_jntnum[1:])
    # last dof that moves each body: its own last dof, else its parent's (bodies are topological)
    body_last_dof = np.full(nbody, -1, np.int32)
    for b in range(nbody):
        if m.body_dofnum[b + 1] > 0:
            body_last_dof[b] = m.body_dofadr[b + 1] + m.body_dofnum[b + 1] - 1
        elif body_parent[b] >= 0:
            body_last_dof[b] = body_last_dof[body_parent[b]]

    qpos0 = m.qpos0.astype(np.float32)
    qpos_spring = m.qpos_spring.astype(np.float32)
    jnt_springref = np.zeros(m.njnt, np.float32)
    for j in range(m.njnt):
        if m.jnt_type[j] in (JointType.HINGE, JointType.SLIDE):
            jnt_springref[j] = qpos_spring[m.jnt_qposadr[j]]

    nu = m.nu
    kind = np.array([_actuator_kind(m, a, None) for a in range(nu)], np.int32).reshape(nu)
    gainprm, biasprm = m.actuator_gainprm[:, :3], m.actuator_biasprm[:, :3]
    affine_gain = (m.actuator_gaintype == mujoco.mjtGain.mjGAIN_AFFINE)[:, None]
    affine_bias = (m.actuator_biastype == mujoco.mjtBias.mjBIAS_AFFINE)[:, None]
    gainprm = np.where(affine_gain, gainprm, gainprm * [1, 0, 0])
    biasprm = np.where(affine_bias, biasprm, 0.0)
    is_kind = lambda *kinds: np.isin(kind, kinds)   # noqa: E731
    gain = np.where(is_kind(ActuatorKind.MOTOR, ActuatorKind.AFFINE), gainprm[:, 0], 0.0)
    kp = np.where(is_kind(ActuatorKind.POSITION), gainprm[:, 0],
                  np.where(is_kind(ActuatorKind.AFFINE), -biasprm[:, 1], 0.0))
    kv = np.where(is_kind(ActuatorKind.POSITION, ActuatorKind.AFFINE), -biasprm[:, 2],
                  np.where(is_kind(ActuatorKind.VELOCITY), gainprm[:, 0], 0.0))
    tendon_paths = _tendon_paths(m, body_last_dof)
    transmissions = _transmissions(m, tendon_paths, body_last_dof)

    hull_face, hull_faceadr, hull_facenum = _mesh_hulls(m, source)
    sensors = _sensors(m, source)

    model = Model(
        source=source, mj_model=m,
        nq=m.nq, nv=m.nv, nbody=nbody, njnt=m.njnt, ngeom=m.ngeom, nsite=m.nsite, nu=nu,
        nmocap=m.nmocap,
        ntendon=m.ntendon, neq=m.neq,
        body_names=[_name(m, o.mjOBJ_BODY, b) for b in range(1, m.nbody)],
        joint_names=[_name(m, o.mjOBJ_JOINT, j) for j in range(m.njnt)],
        geom_names=[_name(m, o.mjOBJ_GEOM, g) for g in range(m.ngeom)],
        site_names=[_name(m, o.mjOBJ_SITE, s) for s in range(m.nsite)],
        actuator_names=[_name(m, o.mjOBJ_ACTUATOR, a) for a in range(nu)],
        tendon_names=[_name(m, o.mjOBJ_TENDON, t) for t in range(m.ntendon)],
        body_parent=body_parent, body_root=body_root,
        body_pos=_f32(m.body_pos[1:]), body_quat=_xyzw(m.body_quat[1:]),
        body_ipos=_f32(m.body_ipos[1:]), body_iquat=_xyzw(m.body_iquat[1:]),
        body_mass=_f32(m.body_mass[1:]), body_inertia=_f32(m.body_inertia[1:]),
        body_gravcomp=_f32(m.body_gravcomp[1:]), body_mocapid=_i32(m.body_mocapid[1:]),
        body_geomadr=_i32(m.body_geomadr[1:]), body_geomnum=_i32(m.body_geomnum[1:]),
        body_jntadr=body_jntadr, body_jntnum=body_jntnum, body_last_dof=body_last_dof,
        jnt_type=_i32(m.jnt_type), jnt_body=_i32(m.jnt_bodyid - 1),
        jnt_qposadr=_i32(m.jnt_qposadr), jnt_dofadr=_i32(m.jnt_dofadr),
        jnt_pos=_f32(m.jnt_pos), jnt_axis=_f32(m.jnt_axis),
        jnt_stiffness=_f32(m.jnt_stiffness), jnt_springref=jnt_springref,
        jnt_limited=m.jnt_limited.astype(bool), jnt_range=_f32(m.jnt_range),
        jnt_actfrclimited=m.jnt_actfrclimited.astype(bool), jnt_actfrcrange=_f32(m.jnt_actfrcrange),
        qpos0=_f32(_qpos_xyzw(m, qpos0)),
        dof_body=_i32(m.dof_bodyid - 1), dof_jnt=_i32(m.dof_jntid), dof_parent=_i32(m.dof_parentid),
        dof_armature=_f32(m.dof_armature), dof_damping=_f32(m.dof_damping),
        dof_frictionloss=_f32(m.dof_frictionloss),
        geom_type=_i32(m.geom_type), geom_body=_i32(m.geom_bodyid - 1),
        geom_pos=_f32(m.geom_pos), geom_quat=_xyzw(m.geom_quat), geom_size=_f32(m.geom_size),
        geom_friction=_f32(m.geom_friction), geom_contype=_i32(m.geom_contype),
        geom_conaffinity=_i32(m.geom_conaffinity), geom_condim=_i32(m.geom_condim),
        geom_dataid=_i32(m.geom_dataid), geom_fluid=_f32(m.geom_fluid.reshape(-1, 12)),
        mesh_vert=_f32(m.mesh_vert), mesh_vertadr=_i32(m.mesh_vertadr),
        mesh_vertnum=_i32(m.mesh_vertnum), mesh_face=_i32(m.mesh_face.reshape(-1, 3)),
        mesh_faceadr=_i32(m.mesh_faceadr), mesh_facenum=_i32(m.mesh_facenum),
        mesh_hull_face=hull_face,
        mesh_hull_faceadr=hull_faceadr, mesh_hull_facenum=hull_facenum,
        hfield_size=_f32(m.hfield_size), hfield_nrow=_i32(m.hfield_nrow),
        hfield_ncol=_i32(m.hfield_ncol), hfield_adr=_i32(m.hfield_adr),
        hfield_data=_f32(m.hfield_data),
        hfield_riser=np.zeros(m.nhfield, np.float32),   # MuJoCo has no risers: its surface
        site_body=_i32(m.site_bodyid - 1), site_pos=_f32(m.site_pos), site_quat=_xyzw(m.site_quat),
        site_type=_i32(m.site_type), site_size=_f32(m.site_size),
        actuator_kind=kind, **transmissions,
        # a site actuator's gear is its 6D wrench (actuator_site_gear): its scalar gear is 1
        actuator_gear=_f32(np.where(transmissions["actuator_trnsite"] >= 0, 1.0,
                                    m.actuator_gear[:, 0])),
        actuator_gain=_f32(gain), actuator_kp=_f32(kp), actuator_kv=_f32(kv),
        actuator_bias=_f32(np.where(is_kind(ActuatorKind.AFFINE), biasprm[:, 0], 0.0)),
        actuator_gain_lv=_f32(np.where(is_kind(ActuatorKind.AFFINE)[:, None], gainprm[:, 1:3],
                                       0.0)),
        actuator_dyntype=_i32(m.actuator_dyntype), actuator_tau=_f32(m.actuator_dynprm[:, 0]),
        actuator_actlimited=m.actuator_actlimited.astype(bool),
        actuator_actrange=_f32(m.actuator_actrange),
        actuator_actearly=m.actuator_actearly.astype(bool),
        actuator_ctrllimited=m.actuator_ctrllimited.astype(bool),
        actuator_ctrlrange=_f32(m.actuator_ctrlrange),
        actuator_forcelimited=m.actuator_forcelimited.astype(bool),
        actuator_forcerange=_f32(m.actuator_forcerange),
        tendon_adr=_i32(m.tendon_adr), tendon_num=_i32(m.tendon_num), **tendon_paths,
        # MJCF fixed tendon -> PhysX-style tendon: every joint is a non-root tendon joint and
        # recip_coef = N·coef, so each joint gets coef·(-k·(L - L0) - d·dL/dt), as in MuJoCo;
        # a `limited` tendon gets a hard limit (limit stiffness 0)
        wrap_jnt=_i32(m.wrap_objid), wrap_coef=_f32(m.wrap_prm),
        wrap_recip=_f32(m.wrap_prm * np.repeat(m.tendon_num, m.tendon_num)) if m.ntendon
        else np.zeros(0, np.float32),
        tendon_stiffness=_f32(m.tendon_stiffness), tendon_damping=_f32(m.tendon_damping),
        tendon_rest_length=_f32(m.tendon_lengthspring[:, 0]),
        tendon_offset=np.zeros(m.ntendon, np.float32),
        tendon_limited=m.tendon_limited.astype(bool), tendon_range=_f32(m.tendon_range),
        tendon_limit_stiffness=np.zeros(m.ntendon, np.float32),
        **sensors,
        exclude_body_pairs=_i32(_exclude_pairs(m)),
        **_explicit_pairs(m),
        **_equalities(m),
        gravity=_f32(m.opt.gravity), timestep=float(m.opt.timestep),
        density=float(m.opt.density), viscosity=float(m.opt.viscosity), wind=_f32(m.opt.wind),
    )
    return model


def _transmissions(m, tendon_paths: dict, body_last_dof: np.ndarray) -> dict:
    """Each actuator's transmission as entries (dof, qpos, coef), in actuator order: a joint is
    one entry of coef 1, a fixed tendon its joints with their coefficients (MuJoCo's tendon
    length, without an offset: Σ coef·q)."""
    entries, site, site_gear = [], np.full(m.nu, -1), np.zeros((m.nu, 6))
    spatial = np.full(m.nu, -1)
    for a in range(m.nu):
        target, kind = m.actuator_trnid[a, 0], int(m.actuator_trntype[a])
        if kind == mujoco.mjtTrn.mjTRN_SITE:
            # a wrench at the site: every dof carrying the site's body, its moment arm computed
            # each substep from the site's pose (coef unused)
            site[a], site_gear[a] = target, m.actuator_gear[a]
            body, dofs = m.site_bodyid[target], []
            dof = body_last_dof[body - 1] if body > 0 else -1
            while dof >= 0:
                dofs.append(dof)
                dof = m.dof_parentid[dof]
            entries.append([(a, d, 0, 0.0) for d in dofs])
            continue
        if kind == mujoco.mjtTrn.mjTRN_TENDON and tendon_paths["tendon_spatial"][target] >= 0:
            # a spatial tendon: every dof of its span, the moment arms its Jacobian's
            spatial[a] = tendon_paths["tendon_spatial"][target]
            lo, hi = tendon_paths["tendon_dofspan"][target]
            entries.append([(a, d, 0, 0.0) for d in range(lo, hi)])
            continue
        if kind == mujoco.mjtTrn.mjTRN_TENDON:
            adr, num = m.tendon_adr[target], m.tendon_num[target]
            joints, coefs = m.wrap_objid[adr:adr + num], m.wrap_prm[adr:adr + num]
        else:
            joints, coefs = [target], [1.0]
        entries.append([(a, m.jnt_dofadr[j], m.jnt_qposadr[j], c) for j, c in zip(joints, coefs)])
    num = np.asarray([len(e) for e in entries], np.int32)
    flat = np.asarray([x for e in entries for x in e], np.float64).reshape(-1, 4)
    first = np.cumsum(num) - num
    return dict(actuator_dof=_i32([e[0][1] if e else -1 for e in entries]),
                actuator_trnadr=_i32(first), actuator_trnnum=num,
                trn_actuator=_i32(flat[:, 0]), trn_dof=_i32(flat[:, 1]),
                trn_qposadr=_i32(flat[:, 2]), trn_coef=_f32(flat[:, 3]),
                actuator_trnsite=_i32(site), actuator_site_gear=_f32(site_gear),
                actuator_trnspatial=_i32(spatial))


def _equalities(m) -> dict:
    """The Model's eq_* fields from MuJoCo's, with one meaning for body and site semantics: a
    frame on each body (anchor point, orientation) that the constraint brings together."""
    neq = m.neq
    anchor = np.zeros((neq, 2, 3))
    frame = np.tile([0.0, 0.0, 0.0, 1.0], (neq, 2, 1))
    obj = np.stack([m.eq_obj1id, m.eq_obj2id], axis=1).astype(np.int64) if neq else \
        np.zeros((0, 2), np.int64)
    ref = np.zeros((neq, 2))
    for i in range(neq):
        kind, data = int(m.eq_type[i]), m.eq_data[i]
        if kind in (EqualityType.CONNECT, EqualityType.WELD):
            if m.eq_objtype[i] == mujoco.mjtObj.mjOBJ_SITE:
                sites = obj[i].copy()
                obj[i] = m.site_bodyid[sites]
                anchor[i] = m.site_pos[sites]
                if kind == EqualityType.WELD:
                    frame[i] = _xyzw(m.site_quat[sites])
            elif kind == EqualityType.CONNECT:
                anchor[i] = data[0:3], data[3:6]       # on body 1, on body 2
            else:
                # MuJoCo's weld: the point data[3:6] of body 1 on the point data[0:3] (the
                # anchor) of body 2, and body 1's frame turned by relpose onto body 2's
                anchor[i] = data[3:6], data[0:3]
                frame[i, 0] = _xyzw(data[6:10] / np.linalg.norm(data[6:10]))
            obj[i] -= 1                                # our body ids: world -1
        else:
            for side in range(2):
                x = obj[i, side]
                if x >= 0:
                    ref[i, side] = (m.qpos0[m.jnt_qposadr[x]] if kind == EqualityType.JOINT
                                    else m.tendon_length0[x])
    return dict(eq_type=_i32(m.eq_type), eq_obj1=_i32(obj[:, 0]), eq_obj2=_i32(obj[:, 1]),
                eq_active=m.eq_active0.astype(bool), eq_anchor=_f32(anchor), eq_frame=_f32(frame),
                eq_rotation=(m.eq_data[:, 10] != 0) if neq else np.zeros(0, bool),
                eq_polycoef=_f32(m.eq_data[:, :5]) if neq else np.zeros((0, 5), np.float32),
                eq_ref=_f32(ref))


def _qpos_xyzw(m, qpos: np.ndarray) -> np.ndarray:
    out = qpos.copy()
    for j in range(m.njnt):
        if m.jnt_type[j] in (JointType.FREE, JointType.BALL):
            a = m.jnt_qposadr[j] + (3 if m.jnt_type[j] == JointType.FREE else 0)
            out[a:a + 4] = qpos[[a + 1, a + 2, a + 3, a]]
    return out


def _explicit_pairs(m) -> dict:
    """The Model's pair_* fields from MuJoCo's <contact><pair> elements.

    A pair's own friction replaces its geoms': its first tangent coefficient as the sliding
    friction (0 for a condim 1 pair), its torsional one where its condim is 4 or 6, its first
    rolling one where it is 6 (`pair_friction`, [npair, 3]). The pair's margin and gap are not
    used: every pair has the simulator's contact_offset (`SimParams`), PhysX's one offset. Its
    solref, solimp and solreffriction do not apply either: contacts are hard rows."""
    if not m.npair:
        return dict(pair_geoms=np.zeros((0, 2), np.int32),
                    pair_friction=np.zeros((0, 3), np.float32))
    geoms = np.stack([m.pair_geom1, m.pair_geom2], axis=1)
    dim = m.pair_dim
    friction = np.stack([np.where(dim == 1, 0.0, m.pair_friction[:, 0]),
                         np.where(dim >= 4, m.pair_friction[:, 2], 0.0),
                         np.where(dim >= 6, m.pair_friction[:, 3], 0.0)], axis=1)
    return dict(pair_geoms=_i32(geoms), pair_friction=_f32(friction))


def _exclude_pairs(m) -> np.ndarray:
    # exclude_signature = (body1 << 16) + body2, in MuJoCo's body ids (0 = world)
    sig = np.asarray(m.exclude_signature, dtype=np.int64)
    return np.stack([(sig >> 16) - 1, (sig & 0xFFFF) - 1], axis=1) if len(sig) else np.zeros((0, 2))
