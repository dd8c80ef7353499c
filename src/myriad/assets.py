"""Robot models: those written for Myriad (the XML files of the `assets/` folder beside this
module, `myriad.asset_path`) and those that come from packages installed from the registry,
found where pip put them, with the fixes each needs applied in memory at load time (an
installed file is never edited). Every task gets its robot from here.

| robot       | extra            | package: file                                                       |
|-------------|------------------|---------------------------------------------------------------------|
| ANYmal C    | `myriad[anymal]` | example-robot-data: robots/anymal_c_simple_description/urdf/anymal.urdf |
| Unitree G1  | `myriad[anymal]` | example-robot-data: robots/g1_description/urdf/g1_29dof_rev_1_0.urdf (meshes/*.STL read to fit capsules) |
| Shadow Hand | `myriad[hands]`  | gymnasium-robotics: envs/assets/hand/{robot,shared,shared_asset}.xml (OpenAI's) |
| Allegro     | `myriad[hands]`  | example-robot-data: robots/allegro_hand_description/urdf/allegro_right_hand.urdf |
| Franka Panda | `myriad[arms]`  | example-robot-data: robots/panda_description/urdf/panda.urdf (arm, hand, fingers) |
| TriFinger Pro | `myriad[arms]` | robot-properties-fingers: urdf/pro/trifingerpro.urdf, meshes/high_table_boundary.stl |
| AMP humanoid | `myriad[amp]`   | pybullet: pybullet_data/humanoid/humanoid.urdf (DeepMimic's; clips in data/motions/) |

Nothing is downloaded at run time: a missing package is a `ModelError` naming the extra that
installs it.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import re
import site
import sys
import tempfile
from xml.etree import ElementTree

import mujoco
import numpy as np

from .physics import ModelError

# the MJCF files written for Myriad (package data beside this module)
MJCF_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "assets")


def asset_path(name: str) -> str:
    """Path of a model shipped with Myriad, e.g. ``asset_path("ant.xml")``."""
    path = os.path.join(MJCF_DIR, name)
    if not os.path.isfile(path):
        shipped = sorted(p for p in os.listdir(MJCF_DIR) if p.endswith(".xml"))
        raise FileNotFoundError(f"no asset named {name!r}; Myriad ships {shipped}")
    return path


def installed_file(package: str, path: str, extra: str) -> str:
    """The path of `path` inside the installed `package` (an importable package, or a cmeel
    package such as example-robot-data, whose files live under site-packages' cmeel.prefix)."""
    spec = importlib.util.find_spec(package.replace("-", "_"))
    roots = list(spec.submodule_search_locations or []) if spec else []
    for root in list(site.getsitepackages()) + [site.getusersitepackages()] + sys.path:
        roots += glob.glob(os.path.join(root, "cmeel.prefix", "share", package))
    for root in roots:
        found = os.path.join(root, path)
        if os.path.isfile(found):
            return found
    raise ModelError(f"{path} comes from the {package} package, which is not installed: pip "
                     f"install \"myriad[{extra}]\" (or pip install {package})")


def urdf_spec(path: str, header: str, root_link: str | None = None,
              text_fixes: dict[str, str] | None = None, edit=None) -> mujoco.MjSpec:
    """A URDF compiled by MuJoCo with `header`'s <mujoco><compiler .../></mujoco> options, a
    free joint to `root_link` (None: fixed to the world), exact text replacements and `edit`
    (a function changing the parsed file's root element in place), written back as MJCF (fixed
    links become frames of their parents) and read as a spec."""
    with open(path) as f:
        text = f.read()
    for old, new in (text_fixes or {}).items():
        if old not in text:
            raise ModelError(f"{path}: not the file these fixes were written for ({old!r} is "
                             "not in it)")
        text = text.replace(old, new)
    if edit is not None:
        root = ElementTree.fromstring(text)
        edit(root)
        text = ElementTree.tostring(root, encoding="unicode")
    if root_link is not None:
        header += ('<link name="world"/><joint name="root" type="floating">'
                   f'<parent link="world"/><child link="{root_link}"/></joint>')
    text, found = re.subn(r"(<robot[^>]*>)", lambda m: m.group(1) + header, text, count=1)
    if not found:
        raise ModelError(f"{path}: no <robot> element")
    try:
        model = mujoco.MjModel.from_xml_string(text)
    except Exception as err:
        raise ModelError(f"{path}: MuJoCo rejected the fixed URDF: {err}") from err
    with tempfile.TemporaryDirectory() as folder:
        saved = os.path.join(folder, "model.xml")
        mujoco.mj_saveLastXML(saved, model)
        spec = mujoco.MjSpec.from_file(saved)
    # the saved file forgets this flag, and its rounded inertias can fail the check again
    spec.compiler.balanceinertia = 'balanceinertia="true"' in header
    return spec


def cylinders_as_capsules(spec: mujoco.MjSpec) -> None:
    """Every cylinder of `spec` a capsule of the same radius and half-length (rounded ends
    added), as Isaac Gym's `replace_cylinder_with_capsule` loads them."""
    for geom in spec.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_CYLINDER:
            geom.type = mujoco.mjtGeom.mjGEOM_CAPSULE


def urdf_velocity_limits(urdf: str | ElementTree.Element) -> dict[str, float]:
    """Each joint's `<limit velocity=...>` in a URDF (rad/s or m/s), by joint name; `urdf`: the
    file's path, or its parsed root element. MuJoCo's importer drops it; Isaac Gym applies it as
    the DOF's maximum speed (`Envs.sim.dof_max_velocity`), which a task that follows the
    original sets from this."""
    root = urdf
    if isinstance(urdf, str):
        try:
            root = ElementTree.parse(urdf).getroot()
        except ElementTree.ParseError as err:
            raise ModelError(f"{urdf}: not readable as XML: {err}") from err
    return {joint.get("name"): float(limit.get("velocity"))
            for joint in root.iter("joint")
            if (limit := joint.find("limit")) is not None and limit.get("velocity") is not None}


def dof_max_velocity(urdf: str | ElementTree.Element, dof_names: list[str]) -> list[float]:
    """`urdf_velocity_limits` in the order of `dof_names` (an actor's `Envs.dof_names`: joint
    names, their "actor/" prefix dropped), ready for `Envs.sim.dof_max_velocity`."""
    limits = urdf_velocity_limits(urdf)
    joints = [name.rsplit("/", 1)[-1] for name in dof_names]
    missing = [j for j in joints if j not in limits]
    if missing:
        raise ModelError(f"{urdf if isinstance(urdf, str) else 'the URDF'}: no <limit "
                         f"velocity> for joints {missing}")
    return [limits[j] for j in joints]

# ---------------------------------------------------------------------------- ANYmal C
ANYMAL_C = "robots/anymal_c_simple_description/urdf/anymal.urdf"


def anymal_c_spec(minimal: bool = False) -> mujoco.MjSpec:
    """ANYmal C of example-robot-data with a free base and the original's collision shapes,
    fixed in memory:
    - visual meshes are dropped (they are .dae files MuJoCo cannot read; collision uses
      primitives);
    - inertias are the URDF's (MuJoCo would otherwise recompute them from the collision geoms:
      81.5 kg instead of 52.1 kg);
    - the link `hatch` declares a singular inertia (all six entries 0.001): its products of
      inertia are zeroed; the camera links violate the triangle inequality and are balanced;
    - fixed links are fused into their parents, leaving the base and the 12 leg links;
    - collision shapes as the original's files have them (the kinematics are the same):
      IsaacGymEnvs' `anymal.urdf` (the flat task) has none on the `*_shank_fixed` links, which
      example-robot-data gives a knee guard (a cylinder and a box each); its
      `anymal_minimal.urdf` (`minimal=True`, the terrain task) keeps only a cylinder for the
      body (radius 0.1 m, 0.75 m long), one per knee drive on the thighs (0.06 m, 0.12 m) and a
      sphere per foot (0.03 m);
    - cylinders become capsules of the same radius and half-length, as the original loads both
      (`replace_cylinder_with_capsule`).
    """
    singular = '<inertia ixx="0.001" ixy="0.001" ixz="0.001" iyy="0.001" iyz="0.001" izz="0.001"/>'
    spec = urdf_spec(
        installed_file("example-robot-data", ANYMAL_C, "anymal"),
        '<mujoco><compiler discardvisual="true" inertiafromgeom="false" balanceinertia="true" '
        'fusestatic="true"/></mujoco>', root_link="base",
        text_fixes={singular: '<inertia ixx="0.001" ixy="0" ixz="0" iyy="0.001" iyz="0" '
                              'izz="0.001"/>'},
        edit=_anymal_minimal_collisions if minimal else _anymal_collisions)
    cylinders_as_capsules(spec)
    return spec


ANYMAL_LEGS = ("LF", "RF", "LH", "RH")


def _anymal_collisions(robot: ElementTree.Element) -> None:
    """IsaacGymEnvs' anymal.urdf: example-robot-data's shapes without the knee guards."""
    for link in robot.iter("link"):
        if link.get("name", "").endswith("_shank_fixed"):
            for shape in link.findall("collision"):
                link.remove(shape)


def _anymal_minimal_collisions(robot: ElementTree.Element) -> None:
    """IsaacGymEnvs' anymal_minimal.urdf: a body cylinder, a cylinder per knee drive, a sphere
    per foot, in the same links' frames."""
    along_x = "0 1.57079632679 0"
    shapes = {"base": ("0 0 0", along_x, '<cylinder length="0.75" radius="0.1"/>')}
    for leg in ANYMAL_LEGS:
        shapes[f"{leg}_KFE"] = ("-0.05 0 0", along_x, '<cylinder length="0.12" radius="0.06"/>')
        shapes[f"{leg}_FOOT"] = ("0 0 0.0225", "0 0 0", '<sphere radius="0.03"/>')
    for link in robot.iter("link"):
        for shape in link.findall("collision"):
            link.remove(shape)
        if (name := link.get("name")) in shapes:
            xyz, rpy, geometry = shapes.pop(name)
            link.append(ElementTree.fromstring(f'<collision><origin xyz="{xyz}" rpy="{rpy}"/>'
                                               f'<geometry>{geometry}</geometry></collision>'))
    if shapes:
        raise ModelError(f"ANYmal C: no links {sorted(shapes)} for the minimal collision shapes")


# ---------------------------------------------------------------------------- Unitree G1
G1 = "robots/g1_description/urdf/g1_29dof_rev_1_0.urdf"
G1_PACKAGE = "package://example-robot-data/"
G1_ARMATURE = 0.01       # kg·m², every joint: Isaac Lab's G1 actuator groups all use 0.01


def capsule_around(vertices: np.ndarray, quantile: float = 0.9) -> tuple[np.ndarray, np.ndarray,
                                                                         float, float]:
    """A capsule standing in for a link's mesh: along the vertices' principal axis, its radius
    the `quantile` of their distances from that axis (a few outlying flanges and bolts are left
    out), its ends at the vertices' extremes along it. Returns (centre, axis, radius,
    half-length of the segment)."""
    centre = vertices.mean(axis=0)
    offsets = vertices - centre
    axis = np.linalg.eigh(offsets.T @ offsets)[1][:, -1]
    along = offsets @ axis
    radius = float(np.quantile(np.linalg.norm(offsets - along[:, None] * axis, axis=1), quantile))
    centre = centre + axis * 0.5 * (along.max() + along.min())
    return centre, axis, radius, max(0.0, 0.5 * (along.max() - along.min()) - radius)


def _rpy_z_to(axis: np.ndarray) -> tuple[float, float, float]:
    """URDF roll-pitch-yaw of a frame whose z axis is `axis`."""
    z = axis / np.linalg.norm(axis)
    x = np.cross([0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0], z)
    x /= np.linalg.norm(x)
    R = np.column_stack([x, np.cross(z, x), z])
    return (float(np.arctan2(R[2, 1], R[2, 2])), float(np.arcsin(-np.clip(R[2, 0], -1, 1))),
            float(np.arctan2(R[1, 0], R[0, 0])))


def g1_spec(armature: float = G1_ARMATURE) -> mujoco.MjSpec:
    """Unitree's G1 (29 DOF, rev 1.0) of example-robot-data with a free pelvis, its collision
    meshes replaced by capsules, as the peers' G1 tasks replace them with primitives:
    - each mesh collision (pelvis contour, hips, knees, ankle pitch links, torso, logo, head,
      shoulder yaw, elbows, wrists) becomes the capsule `capsule_around` fits to the STL's
      vertices in the link's frame (a sphere where the capsule would be shorter than 1 cm);
      the URDF's own primitives stay: the shoulders' cylinders
      (as capsules, Isaac Gym's replace_cylinder_with_capsule) and the four 5 mm spheres at the
      corners of each foot sole, which are the feet;
    - inertias are the URDF's; fixed links (contour, logo, head, IMUs, cameras, rubber hands)
      are fused into their parents, leaving the pelvis and 29 jointed links;
    - every joint gets `armature` (the URDF gives none; the motors' reflected inertia is of
      this order) and keeps the URDF's effort limit as its actuator force range.
    """
    path = installed_file("example-robot-data", G1, "anymal")
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(path))))
    text = open(path).read()

    def capsule(match: re.Match) -> str:
        mesh = match.group(1).replace(G1_PACKAGE, root + "/")
        centre, axis, radius, half = capsule_around(stl_vertices(mesh))
        roll, pitch, yaw = _rpy_z_to(axis)
        shape = (f'<cylinder radius="{radius:.5f}" length="{2 * half:.5f}"/>' if half > 0.005
                 else f'<sphere radius="{radius:.5f}"/>')      # a round link
        return (f'<collision><origin xyz="{centre[0]:.5f} {centre[1]:.5f} {centre[2]:.5f}" '
                f'rpy="{roll:.5f} {pitch:.5f} {yaw:.5f}"/><geometry>{shape}</geometry>'
                '</collision>')

    # every mesh collision sits at its link's origin (checked: the pattern requires it)
    text, meshes = re.subn(
        r'<collision>\s*<origin xyz="0 0 0" rpy="0 0 0"\s*/>\s*<geometry>\s*'
        r'<mesh filename="([^"]+)"\s*/>\s*</geometry>\s*</collision>', capsule, text)
    if meshes != 24 or re.search(r"<collision>(?:(?!</collision>).)*<mesh", text, re.S):
        raise ModelError(f"{path}: not the file g1_spec was written for ({meshes} mesh "
                         "collisions at link origins, expected 24)")
    with tempfile.NamedTemporaryFile("w", suffix=".urdf", delete=False) as fixed:
        fixed.write(text)
    try:
        spec = urdf_spec(fixed.name, '<mujoco><compiler discardvisual="true" '
                         'inertiafromgeom="false" fusestatic="true"/></mujoco>',
                         root_link="pelvis")
    finally:
        os.unlink(fixed.name)
    cylinders_as_capsules(spec)
    for joint in spec.joints:
        if joint.type != mujoco.mjtJoint.mjJNT_FREE:
            joint.armature = armature
    return spec


# ---------------------------------------------------------------------------- Shadow Hand
SHADOW_HAND = "envs/assets/hand"
SHADOW_FINGERTIPS = ("ffdistal", "mfdistal", "rfdistal", "lfdistal", "thdistal")
SHADOW_COUPLINGS = ("FF", "MF", "RF", "LF")     # tendons robot0:T_{F}J1c couple J1 and J0
SHADOW_TENDON_LIMIT_STIFFNESS = 30.0            # PhysX fixed-tendon settings of the original
SHADOW_TENDON_DAMPING = 0.1


def shadow_hand_spec() -> mujoco.MjSpec:
    """OpenAI's Shadow Hand, as gymnasium-robotics ships it (the model the seed's results were
    produced with): 24 joints, 20 position actuators (kp 1, wrist 5), 44 fixed tendons, the
    explicit finger-thumb contact pairs. Only the hand: the scene's floor, cube and target are
    the task's. Fixes, in memory:
    - a 6-axis force sensor (`<force>` and `<torque>` at a site on the body origin) on each
      fingertip body robot0:{ff,mf,rf,lf,th}distal, as the original adds;
    - the coupling tendons robot0:T_{FF,MF,RF,LF}J1c get PhysX's semantics, which MJCF cannot
      say: pass `shadow_hand_tendons` to `Scene.build(fix_model=...)`;
    - the file's <size> memory and user-data counts are dropped (they are MuJoCo C's buffer
      sizes, which Myriad does not use and which clash with the scene's when attached).
    The root body robot0:hand mount keeps the file's pose (the palm up, fingers along -y, after
    the mount's rotation: `SHADOW_MOUNT_QUAT`).
    """
    folder = os.path.dirname(installed_file("gymnasium-robotics",
                                            f"{SHADOW_HAND}/robot.xml", "hands"))
    assets = os.path.dirname(folder)
    text = f"""<mujoco model="shadow_hand">
  <compiler angle="radian" coordinate="local" meshdir="{assets}/stls/hand"
            texturedir="{assets}/textures"/>
  <include file="{folder}/shared.xml"/>
  <asset><include file="{folder}/shared_asset.xml"/></asset>
  <worldbody><include file="{folder}/robot.xml"/></worldbody>
</mujoco>"""
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "shadow_hand.xml")
        with open(path, "w") as f:
            f.write(text)
        try:
            spec = mujoco.MjSpec.from_file(path)
        except Exception as err:
            raise ModelError(f"{folder}: MuJoCo rejected the Shadow Hand: {err}") from err
    for name in ("njmax", "nconmax", "nuser_jnt", "nuser_site", "nuser_tendon",
                 "nuser_actuator", "nuser_sensor"):
        setattr(spec, name, -1)
    for tip in SHADOW_FINGERTIPS:
        site = spec.body(f"robot0:{tip}").add_site(name=f"robot0:{tip}_wrench", pos=[0, 0, 0])
        spec.add_sensor(name=f"robot0:{tip}_force", type=mujoco.mjtSensor.mjSENS_FORCE,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
        spec.add_sensor(name=f"robot0:{tip}_torque", type=mujoco.mjtSensor.mjSENS_TORQUE,
                        objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
    return spec


def physx_tendons(model, names: list[str], limit_stiffness: float, damping: float) -> None:
    """Give the fixed tendons `names` of `model` (in place) PhysX's semantics as Isaac Gym's
    importer sets them: each joint receives the tendon force times its recipCoefficient, 1/coef
    (the MJCF import's N·coef gives MuJoCo's coef·force instead), a limit spring of stiffness
    `limit_stiffness` outside the tendon's range and `damping` (both per the tendon's N joints,
    `docs/physics.md`). For the Shadow Hand's couplings (coefs 0.007, range ±0.001), MuJoCo's
    weighting turned the original's limit stiffness 30 into 0.0002 N·m per mm of stretch
    (PhysX's: about 2), and the distal joints hung loose."""
    for name in names:
        if name not in model.tendon_names:
            raise ModelError(f"{model.source}: no tendon {name!r} to give PhysX semantics")
        t = model.tendon_names.index(name)
        wraps = slice(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t])
        model.wrap_recip[wraps] = 1.0 / model.wrap_coef[wraps]
        model.tendon_limit_stiffness[t] = limit_stiffness
        model.tendon_damping[t] = damping


def shadow_hand_tendons(model, prefix: str = "hand/") -> None:
    """The original's settings of the Shadow Hand's four coupling tendons (limit stiffness 30,
    damping 0.1, PhysX semantics), for `Scene.build(fix_model=...)`; `prefix`: the actor's."""
    physx_tendons(model, [f"{prefix}robot0:T_{f}J1c" for f in SHADOW_COUPLINGS],
                  SHADOW_TENDON_LIMIT_STIFFNESS, SHADOW_TENDON_DAMPING)


# ---------------------------------------------------------------------------- Allegro
ALLEGRO_HAND = "robots/allegro_hand_description/urdf/allegro_right_hand.urdf"


def allegro_hand_spec(friction: float = 0.01, armature: float = 0.001,
                      effort: float = 0.5) -> mujoco.MjSpec:
    """Wonik's Allegro right hand of example-robot-data (16 joints, boxes and sphere tips), with
    the original's joint settings in place of the URDF's: dry friction 0.01 (the URDF's 5-12 N·m
    would hold every finger still against its 0.5 N·m drives), armature 0.001 and the drive
    effort limit 0.5 N·m (each joint's actuatorfrcrange). The URDF's joint damping (3-10
    N·m·s/rad) stays in the spec: `Scene.add_actor(dof_mode="position", damping=)` replaces it
    with the drive's (the original's 0.1), as Isaac Gym has one damping per DOF. Fixed links
    are fused; the palm gets a free joint (so that it stays one body:
    `Scene.add_actor(fix_base=True)` removes the joint). The thumb's second link overlaps the
    palm by 0.6 mm at every pose near the start: the pair is excluded."""
    spec = urdf_spec(installed_file("example-robot-data", ALLEGRO_HAND, "hands"),
                     '<mujoco><compiler discardvisual="true" balanceinertia="true" '
                     'fusestatic="true"/></mujoco>', root_link="palm_link")
    for joint in spec.joints:
        if joint.type == mujoco.mjtJoint.mjJNT_FREE:
            continue
        joint.frictionloss = friction
        joint.armature = armature
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
        joint.actfrcrange = [-effort, effort]
    spec.add_exclude(bodyname1="palm_link", bodyname2="link_13.0")
    return spec


def allegro_max_velocity(dof_names: list[str]) -> list[float]:
    """The speed limits of example-robot-data's Allegro URDF for `dof_names`
    (`dof_max_velocity`): 7 rad/s on every joint."""
    return dof_max_velocity(installed_file("example-robot-data", ALLEGRO_HAND, "hands"),
                            dof_names)


# ---------------------------------------------------------------------------- Franka Panda
FRANKA = "robots/panda_description/urdf/panda.urdf"
FRANKA_ROBOTS = "package://example-robot-data/robots/"
FRANKA_GRIP_SITE = 0.1025            # the original's grip point, along the hand's z (m)
FRANKA_FINGERTIP = (0.0015, 0.0441)  # the original's fingertip points: toward the other finger
                                     # (y, its sign per finger) and along the finger's z (m)


def franka_max_velocity(dof_names: list[str]) -> list[float]:
    """The speed limits of example-robot-data's Panda URDF for `dof_names` (`dof_max_velocity`):
    2.175 rad/s for joints 1-4, 2.61 for 5-7, 0.2 m/s for each finger."""
    return dof_max_velocity(installed_file("example-robot-data", FRANKA, "arms"), dof_names)


def franka_spec() -> mujoco.MjSpec:
    """The Franka Panda with its gripper, as example-robot-data ships it: 7 arm joints, two
    finger joints of which the second mimics the first (a joint equality), collision meshes for
    the links and boxes for the fingers. Fixed links stay bodies (`panda_hand` is the body whose
    Jacobian an operational-space controller uses), and the points the original adds are sites:
    `panda_grip_site` 0.1025 m along the hand's z, and `panda_{left,right}finger_tip` 0.0441 m
    along each finger's z, 1.5 mm toward the other finger. The joints have no damping of their
    own: the original writes its DOF damping over the URDF's 0.3 (0 on the arm, which its
    controller drives by torque, and 100 on the fingers, their drives' gain, which the scene's
    drives carry). The base is fixed (no free joint);
    the URDF's mesh paths are resolved to the installed package's folder. Three pairs of wrist
    links whose meshes overlap in every pose (5 to 41 mm) are excluded from colliding."""
    path = installed_file("example-robot-data", FRANKA, "arms")
    robots = path[: -len(FRANKA)]
    spec = urdf_spec(path, '<mujoco><compiler discardvisual="true" balanceinertia="true" '
                           'fusestatic="false"/></mujoco>',
                     text_fixes={FRANKA_ROBOTS: robots + "robots/"})
    for joint in spec.joints:
        joint.damping = [0.0, 0.0, 0.0]
    spec.body("panda_hand").add_site(name="panda_grip_site", pos=[0, 0, FRANKA_GRIP_SITE])
    toward, along = FRANKA_FINGERTIP
    spec.body("panda_leftfinger").add_site(name="panda_leftfinger_tip", pos=[0, toward, along])
    spec.body("panda_rightfinger").add_site(name="panda_rightfinger_tip",
                                            pos=[0, -toward, along])
    # collision meshes that overlap in every pose (the wrist's links round the hand)
    for one, two in (("panda_link5", "panda_hand"), ("panda_link7", "panda_hand"),
                     ("panda_link5", "panda_link7")):
        spec.add_exclude(bodyname1=one, bodyname2=two)
    return spec


# ---------------------------------------------------------------------------- TriFinger Pro
TRIFINGER = "urdf/pro/trifingerpro.urdf"
TRIFINGER_PACKAGE = "package://robot_properties_fingers/"
TRIFINGER_ANGLES = (0, 120, 240)          # the fingers' suffixes: their mounting angle (deg)
TRIFINGER_ARENA_RADIUS = 0.195            # m: the boundary wall's inner radius at the floor


def trifinger_spec(friction: float = 1.0, hull_vertices: int = 64) -> mujoco.MjSpec:
    """TriFinger Pro of robot-properties-fingers: three 3-joint fingers hanging from a frame
    0.29 m above the floor, their links collided as the convex hulls of their meshes, each hull
    cut to `hull_vertices` corners (64: within 1.2 mm of the full hull; the original decomposes
    the links with V-HACD into hulls of up to 256; the upper, middle and tip links are nearly
    convex), with `friction`. Fixed links stay bodies: finger_tip_link_{0,120,240} are the
    fingertips whose poses, velocities and wrenches the task observes, each with a force and a
    torque sensor at its origin. The base is fixed to the world (no free joint); the URDF's mesh
    paths are resolved to the installed package's folder."""
    path = installed_file("robot_properties_fingers", TRIFINGER, "arms")
    package = os.path.dirname(os.path.dirname(os.path.dirname(path)))
    spec = urdf_spec(path, '<mujoco><compiler discardvisual="true" balanceinertia="true" '
                           'fusestatic="false"/></mujoco>',
                     text_fixes={TRIFINGER_PACKAGE: package + "/"})
    for mesh in spec.meshes:
        mesh.maxhullvert = hull_vertices
    for geom in spec.geoms:
        geom.friction = [friction, geom.friction[1], geom.friction[2]]
    for angle in TRIFINGER_ANGLES:
        tip = spec.body(f"finger_tip_link_{angle}")
        site = tip.add_site(name=f"finger_tip_{angle}_wrench", pos=[0, 0, 0])
        for kind, name in ((mujoco.mjtSensor.mjSENS_FORCE, "force"),
                           (mujoco.mjtSensor.mjSENS_TORQUE, "torque")):
            spec.add_sensor(name=f"finger_tip_{angle}_{name}", type=kind,
                            objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site.name)
    return spec


def stl_vertices(path: str) -> np.ndarray:
    """[n, 3] distinct vertices of a binary STL file."""
    data = open(path, "rb").read()
    count = int(np.frombuffer(data, np.uint32, 1, 80)[0]) if len(data) >= 84 else -1
    if count < 0 or len(data) != 84 + 50 * count:
        raise ModelError(f"{path}: not a binary STL file ({len(data)} bytes)")
    rows = np.frombuffer(data, np.dtype([("normal", "<f4", 3), ("corners", "<f4", (3, 3)),
                                         ("attribute", "<u2")]), count, 84)
    return np.unique(rows["corners"].reshape(-1, 3), axis=0)


def trifinger_boundary_spec(sectors: int = 32) -> mujoco.MjSpec:
    """The wall round TriFinger's arena (robot-properties-fingers' high_table_boundary.stl: a
    ring 0.195 m inside at the floor, widening in steps to 0.28 m at its top, 0.175 m high) as
    one static body of `sectors` convex pieces: the hull of the mesh's vertices within each
    sector of angle (sectors overlap by a third of their width, leaving no gap between them).
    A hull fills the steps of the wall's inside into a smooth cone, and its flat inner face
    lies at most 0.195·(1 - cos(π/sectors)) (1 mm for 32) inside the round wall."""
    points = stl_vertices(installed_file("robot_properties_fingers",
                                         "meshes/high_table_boundary.stl", "arms"))
    radius = np.hypot(points[:, 0], points[:, 1])
    points = points[radius > 0.9 * TRIFINGER_ARENA_RADIUS]   # the file's few stray points inside
    angle = np.arctan2(points[:, 1], points[:, 0])
    width = 2 * np.pi / sectors
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(name="boundary")
    for k in range(sectors):
        offset = np.angle(np.exp(1j * (angle - (k + 0.5) * width)))   # from the sector's middle
        piece = points[np.abs(offset) <= width * (0.5 + 1 / 6)]
        spec.add_mesh(name=f"boundary_{k}", uservert=piece.astype(np.float64).ravel().tolist())
        body.add_geom(name=f"boundary_{k}", type=mujoco.mjtGeom.mjGEOM_MESH,
                      meshname=f"boundary_{k}", rgba=[0.3, 0.3, 0.35, 1.0])
    return spec


# ---------------------------------------------------------------------------- AMP humanoid
AMP_HUMANOID = "humanoid/humanoid.urdf"
AMP_SCALE = 0.25             # the URDF is drawn at 4x a metre; the DeepMimic clips are in metres
AMP_START_HEIGHT = 0.89      # the original's start: pelvis 0.89 m above the ground
# (URDF link, body, joint) in the original AMP humanoid's tree order, which sets the 28 DoF's
# order: abdomen 3, neck 3, right shoulder 3, right elbow, left shoulder 3, left elbow, right
# hip 3, right knee, right ankle 3, left hip 3, left knee, left ankle 3
AMP_BODIES = (
    ("root", "pelvis", None), ("chest", "torso", "abdomen"), ("neck", "head", "neck"),
    ("right_shoulder", "right_upper_arm", "right_shoulder"),
    ("right_elbow", "right_lower_arm", "right_elbow"), ("right_wrist", "right_hand", None),
    ("left_shoulder", "left_upper_arm", "left_shoulder"),
    ("left_elbow", "left_lower_arm", "left_elbow"), ("left_wrist", "left_hand", None),
    ("right_hip", "right_thigh", "right_hip"), ("right_knee", "right_shin", "right_knee"),
    ("right_ankle", "right_foot", "right_ankle"),
    ("left_hip", "left_thigh", "left_hip"), ("left_knee", "left_shin", "left_knee"),
    ("left_ankle", "left_foot", "left_ankle"))
AMP_KEY_BODIES = ("right_hand", "left_hand", "right_foot", "left_foot")
AMP_HINGES = ("right_elbow", "left_elbow", "right_knee", "left_knee")    # the 1-DoF joints
# (joint, DoF count) in the model's order: 28 DoF in all
AMP_DOFS = tuple((joint, 1 if joint in AMP_HINGES else 3) for _, _, joint in AMP_BODIES if joint)
# PD drive gains per joint (stiffness N·m/rad, damping N·m·s/rad): the original's MJCF's
AMP_PD_GAINS = {"abdomen": (600.0, 60.0), "neck": (50.0, 5.0), "shoulder": (200.0, 20.0),
                "elbow": (150.0, 15.0), "hip": (300.0, 30.0), "knee": (300.0, 30.0),
                "ankle": (200.0, 20.0)}


def amp_humanoid_gains() -> tuple[list[float], list[float]]:
    """(stiffness, damping) of the 28 DoF in the model's order (AMP_PD_GAINS by joint)."""
    gains = [AMP_PD_GAINS[joint.split("_")[-1]] for joint, width in AMP_DOFS
             for _ in range(width)]
    return [kp for kp, _ in gains], [kd for _, kd in gains]


def y_up_to_z_up(v) -> np.ndarray:
    """A vector of the URDF's y-up frame (x forward, z to the right) in a z-up frame (x
    forward, y to the left): a quarter turn about x."""
    v = np.asarray(v, float)
    return np.array([v[0], -v[2], v[1]])


def amp_humanoid_spec(ball_joints: bool = False) -> mujoco.MjSpec:
    """The humanoid of the DeepMimic clips (pybullet_data's humanoid.urdf), as the original AMP
    humanoid: 15 bodies, a free pelvis, 28 DoF (each spherical joint as hinges about x, y, z, in
    AMP_BODIES' order), at metric scale and z-up. Built from the URDF's numbers, since MuJoCo's
    URDF reader has no spherical joints. Every link's frame is parallel to the world's at the
    zero pose (the URDF has no rotations), so positions and hinge axes only turn from y-up to
    z-up. Link masses are the URDF's (45 kg in all); its inertias are placeholders (0.1 at 4x
    scale), so each body's inertia comes from its one collision shape at that mass.
    ball_joints=True keeps each spherical joint one ball joint (MuJoCo's; 8 of them and 4 hinges:
    a model that holds any clip pose exactly, to check poses against)."""
    import xml.etree.ElementTree as ET

    path = installed_file("pybullet_data", AMP_HUMANOID, "amp")
    try:                    # the file ends in a NUL byte, which no XML parser takes
        root = ET.fromstring(open(path, "rb").read().rstrip(b"\0"))
    except ET.ParseError as err:
        raise ModelError(f"{path}: not a readable URDF ({err})") from err

    def vec(element, attribute="xyz"):
        return np.array([float(x) for x in element.get(attribute).split()])

    links = {link.get("name"): link for link in root.iter("link")}
    joints = {joint.find("child").get("link"): joint for joint in root.iter("joint")}
    spec = mujoco.MjSpec()
    spec.modelname = "amp_humanoid"
    spec.compiler.degree = False        # the URDF's limits are radians
    bodies = {}
    for urdf, name, joint_name in AMP_BODIES:
        joint = joints[urdf]
        if urdf == "root":
            body = spec.worldbody.add_body(name=name, pos=[0, 0, AMP_START_HEIGHT])
            body.add_freejoint(name="root")
        else:
            parent = bodies[joint.find("parent").get("link")]
            offset = y_up_to_z_up(vec(joint.find("origin")) * AMP_SCALE)
            body = parent.add_body(name=name, pos=offset)
        bodies[urdf] = body
        kind = joint.get("type")
        if kind == "spherical" and ball_joints:
            body.add_joint(name=joint_name, type=mujoco.mjtJoint.mjJNT_BALL)
        elif kind == "spherical":
            for axis, direction in zip("xyz", np.eye(3)):
                body.add_joint(name=f"{joint_name}_{axis}", type=mujoco.mjtJoint.mjJNT_HINGE,
                               axis=direction)
        elif kind == "revolute":
            limit = joint.find("limit")
            body.add_joint(name=joint_name, type=mujoco.mjtJoint.mjJNT_HINGE,
                           axis=y_up_to_z_up(vec(joint.find("axis"))),
                           limited=mujoco.mjtLimited.mjLIMITED_TRUE,
                           range=[float(limit.get("lower")), float(limit.get("upper"))])
        elif urdf != "root" and kind != "fixed":
            raise ModelError(f"{path}: joint {joint.get('name')!r} of type {kind!r} (expected "
                             "spherical, revolute or fixed)")
        link = links[urdf]
        collision = link.find("collision")
        centre = y_up_to_z_up(vec(collision.find("origin")) * AMP_SCALE)
        shape = collision.find("geometry")[0]
        mass = float(link.find("inertial/mass").get("value"))
        if shape.tag == "sphere":
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=centre, mass=mass,
                          size=[float(shape.get("radius")) * AMP_SCALE, 0, 0])
        elif shape.tag == "capsule":
            # pybullet's capsule runs along its frame's z, turned onto the link's y (its length)
            # by the origin's roll of -90°: along the limb, which is z here
            half = float(shape.get("length")) * AMP_SCALE / 2
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CAPSULE, mass=mass,
                          fromto=np.concatenate([centre - [0, 0, half], centre + [0, 0, half]]),
                          size=[float(shape.get("radius")) * AMP_SCALE, 0, 0])
        elif shape.tag == "box":
            full = np.abs(y_up_to_z_up(vec(shape, "size"))) * AMP_SCALE
            body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=centre, mass=mass,
                          size=full / 2)
        else:
            raise ModelError(f"{path}: link {urdf!r} has a {shape.tag} collision shape "
                             "(expected sphere, capsule or box)")
    return spec
