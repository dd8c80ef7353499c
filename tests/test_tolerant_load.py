"""`load_asset`: what Isaac Gym loads and MuJoCo refuses is repaired before MuJoCo's compiler,
each repair with a RuntimeWarning naming the file and the element; what cannot be repaired stays
a ModelError naming the file. The models reproduce the defects of real files (IsaacGymEnvs'
assets, example-robot-data's ANYmal C) in a few lines each."""

import warnings

import mujoco
import numpy as np
import pytest

import myriad
from myriad import ModelError
from myriad.physics.tolerant import asset_spec
from myriad.physics.types import GeomType

# a tetrahedron: the smallest mesh MuJoCo reads
TET_OBJ = "v 0 0 0\nv .1 0 0\nv 0 .1 0\nv 0 0 .1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"


def _write(folder, name, text):
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return str(path)


def _load(path, **options):
    """The model and the messages of the RuntimeWarnings that name a file in `path`'s folder."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = myriad.load_asset(path, **options)
    folder = str(path).rsplit("/", 1)[0]
    return model, [str(w.message) for w in caught
                   if w.category is RuntimeWarning and str(w.message).startswith(folder)]


def _one(messages, *parts):
    """The one message that contains all `parts`."""
    found = [m for m in messages if all(p in m for p in parts)]
    assert len(found) == 1, (parts, messages)
    return found[0]


def _box(mass, x, y, z):
    return mass / 12 * np.array([y * y + z * z, x * x + z * z, x * x + y * y])


# --------------------------------------------------------------------------- 1. materials
def test_undefined_material_reference_is_dropped(tmp_path):
    """IsaacGymEnvs mjcf/nv_humanoid.xml: the class "body" draws with material="self" and the
    floor with material="grid", neither defined in the file."""
    path = _write(tmp_path, "nv_humanoid.xml", """<mujoco model="humanoid">
  <default><default class="body">
    <geom type="capsule" condim="1" material="self"/>
    <joint type="hinge" damping="0.1" limited="true"/>
  </default></default>
  <worldbody>
    <geom name="floor" type="plane" conaffinity="1" size="100 100 .2" material="grid"/>
    <body name="torso" pos="0 0 1.5" childclass="body">
      <freejoint name="root"/>
      <geom name="torso" fromto="0 -.07 0 0 .07 0" size=".07"/>
      <body name="head" pos="0 0 .19"><joint name="neck" axis="0 1 0" range="-45 45"/>
        <geom name="head" type="sphere" size=".09"/></body>
    </body>
  </worldbody>
</mujoco>""")
    with pytest.raises(ModelError, match="material 'grid' not found"):
        myriad.load(path)
    model, messages = _load(path)
    assert "geom 'torso', geom 'head'" in _one(messages, "material 'self' is not defined")
    assert "geom 'floor'" in _one(messages, "material 'grid' is not defined")
    assert len(messages) == 2
    assert model.nq == 8 and model.ngeom == 3      # nothing but the references is gone


def test_texture_with_missing_image_and_undefined_texture_are_dropped(tmp_path):
    path = _write(tmp_path, "textured.xml", """<mujoco><asset>
      <texture name="wood" type="2d" file="no_such_wood.png"/>
      <material name="table" texture="wood"/><material name="cloth" texture="undefined_tex"/>
    </asset><worldbody><body name="b"><freejoint/><geom size=".1" material="table"/>
      <geom size=".05" pos="0 0 .1" material="cloth"/></body></worldbody></mujoco>""")
    model, messages = _load(path)
    _one(messages, "texture 'wood'", "no_such_wood.png", "dropped")
    _one(messages, "texture 'wood' is not defined", "material 'table'")
    _one(messages, "texture 'undefined_tex' is not defined", "material 'cloth'")
    assert model.ngeom == 2


# --------------------------------------------------------------------------- 2. options
def test_unknown_option_attributes_are_removed_with_their_line(tmp_path):
    """IsaacGymEnvs mjcf/open_ai_assets/hand/shadow_hand.xml: <option apirate>, here with the
    other option attributes MuJoCo dropped (collision=, the flag passive), one in an included
    file. Each is found from MuJoCo's own error message."""
    _write(tmp_path, "shared.xml", """<mujoco>
  <visual>
    <map fogstart="3" fogend="5" fogdensity="1"/>
  </visual>
</mujoco>""")
    path = _write(tmp_path, "shadow_hand.xml", """<?xml version="1.0"?>
<mujoco>
    <compiler angle="radian" coordinate="local"></compiler>
    <option timestep="0.002" iterations="20"
            apirate="200" collision="all">
        <flag warmstart="enable" passive="disable"></flag>
    </option>
    <include file="shared.xml"></include>
    <worldbody><body name="palm"><freejoint/><geom size=".05"/></body></worldbody>
</mujoco>""")
    with pytest.raises(ModelError, match="unrecognized attribute: 'apirate'"):
        myriad.load(path)
    model, messages = _load(path)
    _one(messages, "shadow_hand.xml: line 4: <option> attribute apirate=\"200\"", "removed")
    _one(messages, "shadow_hand.xml: line 4: <option> attribute collision=\"all\"", "removed")
    _one(messages, "line 6: <flag> attribute passive=\"disable\"",
         "replaced by spring=\"disable\" damper=\"disable\"")
    _one(messages, "shared.xml: line 3: <map> attribute fogdensity=\"1\"", "removed")
    assert len(messages) == 4
    assert model.timestep == pytest.approx(0.002)   # the attributes MuJoCo knows are kept
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opt = asset_spec(path).compile().opt
    assert opt.iterations == 20
    disabled = mujoco.mjtDisableBit
    assert opt.disableflags & disabled.mjDSBL_SPRING and opt.disableflags & disabled.mjDSBL_DAMPER


@pytest.mark.parametrize("element", [
    '<compiler exactmeshinertia="true"/>',                      # changes inertias: not dropped
    '<worldbody><body><freejoint/><geom size=".1" bogus="1"/></body></worldbody>'])
def test_unknown_attribute_of_a_physical_element_stays_an_error(tmp_path, element):
    path = _write(tmp_path, "physical.xml", f"<mujoco>{element}</mujoco>")
    with pytest.raises(ModelError, match=r"physical.xml: .*unrecognized attribute"):
        myriad.load_asset(path)


# --------------------------------------------------------------------------- 3. bare inertial
CARTPOLE_URDF = """<?xml version="1.0"?>
<robot name="cartpole">
  <link name="slider">
    <visual><geometry><box size="0.03 8 0.03"/></geometry>
      <material name="slider_mat"><color rgba="0.9 0.6 0.2 1"/></material></visual>
    <collision><geometry><box size="0.03 8 0.03"/></geometry></collision>
  </link>
  <link name="cart">
    <visual><geometry><box size="0.2 0.25 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.25 0.2"/></geometry></collision>
    <inertial><mass value="1"/></inertial>
  </link>
  <link name="pole">
    <visual><geometry><box size="0.04 0.06 1.0"/></geometry><origin xyz="0 0 0.47"/></visual>
    <collision><geometry><box size="0.04 0.06 1.0"/></geometry><origin xyz="0 0 0.47"/></collision>
    <inertial><mass value="1"/><origin xyz="0 0 0.47"/></inertial>
  </link>
  <joint name="slider_to_cart" type="prismatic">
    <axis xyz="0 1 0"/><origin xyz="0 0 0"/><parent link="slider"/><child link="cart"/>
    <limit effort="1000.0" lower="-4" upper="4" velocity="100"/>
  </joint>
  <joint name="cart_to_pole" type="continuous">
    <axis xyz="1 0 0"/><origin xyz="0.12 0 0"/><parent link="cart"/><child link="pole"/>
    <limit effort="1000.0" velocity="8"/>
  </joint>
</robot>"""


def test_inertial_without_inertia_gets_that_of_its_collision_box(tmp_path):
    """IsaacGymEnvs urdf/cartpole.urdf: <inertial> gives the mass only."""
    path = _write(tmp_path, "cartpole.urdf", CARTPOLE_URDF)
    with pytest.raises(ModelError, match="missing element: 'inertia'"):
        myriad.load(path)
    model, messages = _load(path, fix_base_link=True)
    for link in ("cart", "pole"):
        _one(messages, f"link '{link}': <inertial> has no <inertia>", "collision primitive")
    assert model.nq == 2                                # the slider is the fixed base
    cart, pole = model.body_names.index("cart"), model.body_names.index("pole")
    np.testing.assert_allclose(np.sort(model.body_inertia[cart]), np.sort(_box(1, .2, .25, .2)),
                               rtol=1e-6)
    np.testing.assert_allclose(np.sort(model.body_inertia[pole]), np.sort(_box(1, .04, .06, 1)),
                               rtol=1e-6)
    np.testing.assert_allclose(model.body_ipos[pole], [0, 0, 0.47], atol=1e-7)


def test_inertial_without_inertia_off_centre_and_without_primitives(tmp_path):
    """The collision box 0.5 m above the inertial origin adds m d^2 (parallel axes); a link
    that collides through a mesh gets the default: a uniform 0.1 m cube of its mass."""
    _write(tmp_path, "tet.obj", TET_OBJ)
    path = _write(tmp_path, "bare.urdf", """<robot name="bare">
  <link name="arm"><collision><origin xyz="0 0 0.5"/><geometry><box size=".1 .2 .3"/></geometry>
    </collision><inertial><mass value="2"/></inertial></link>
  <link name="tip"><collision><geometry><mesh filename="tet.obj"/></geometry></collision>
    <inertial><mass value="3"/></inertial></link>
  <joint name="j" type="revolute"><parent link="arm"/><child link="tip"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>""")
    model, messages = _load(path)
    _one(messages, "link 'tip'", "uniform 0.1 m cube")
    arm, tip = model.body_names.index("arm"), model.body_names.index("tip")
    expected = _box(2, .1, .2, .3) + 2 * np.array([0.25, 0.25, 0])
    np.testing.assert_allclose(np.sort(model.body_inertia[arm]), np.sort(expected), rtol=1e-6)
    np.testing.assert_allclose(model.body_inertia[tip], [3 * 0.01 / 6] * 3, rtol=1e-6)


# --------------------------------------------------------------------------- 4. package://, .dae
PANDA_URDF = """<robot name="panda">
  <link name="panda_link0">
    <visual><geometry><mesh filename="package://franka_description/meshes/visual/link0.dae"/>
      </geometry></visual>
    <collision><geometry><mesh filename="package://franka_description/meshes/collision/link0.obj"/>
      </geometry></collision>
  </link>
  <link name="panda_link1">
    <visual><geometry><mesh filename="package://franka_description/meshes/visual/link1.obj"/>
      </geometry></visual>
    <collision><geometry><mesh filename="package://franka_description/meshes/collision/{link1}"/>
      </geometry></collision>
    <inertial><mass value="1"/><inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/>
    </inertial>
  </link>
  <joint name="panda_joint1" type="revolute"><parent link="panda_link0"/><child link="panda_link1"/>
    <axis xyz="0 0 1"/><limit lower="-2.9" upper="2.9" effort="87" velocity="2.2"/></joint>
</robot>"""


def _franka_tree(root, link1="link1.dae"):
    """IsaacGymEnvs urdf/franka_description: package:// meshes, visuals in COLLADA."""
    package = root / "franka_description"
    for name in ("visual/link0.dae", "visual/link1.obj", "collision/link0.obj",
                 "collision/link1.dae", "collision/link1.obj"):
        _write(package / "meshes", name, "<COLLADA/>" if name.endswith(".dae") else TET_OBJ)
    return _write(package / "robots", "franka_panda.urdf", PANDA_URDF.format(link1=link1))


def test_package_meshes_resolve_and_collada_is_replaced_or_dropped(tmp_path):
    path = _franka_tree(tmp_path)
    with pytest.raises(ModelError, match="package:"):
        myriad.load(path)
    model, messages = _load(path, fix_base_link=True)
    _one(messages, "1 visual mesh(es)", "link 'panda_link0' (package://franka_description/"
                                        "meshes/visual/link0.dae)")
    _one(messages, "link 'panda_link1': collision mesh", "link1.dae",
         str(tmp_path / "franka_description/meshes/collision/link1.obj"))
    assert len(messages) == 2
    kinds = sorted(int(t) for t in model.geom_type)
    assert kinds == [GeomType.MESH] * 3           # 2 collision meshes + the .obj visual
    assert model.nq == 1


def test_package_paths_and_ros_package_path(tmp_path, monkeypatch):
    """A URDF outside its package finds it through `package_paths` or ROS_PACKAGE_PATH."""
    _franka_tree(tmp_path / "share")
    path = _write(tmp_path / "elsewhere", "panda.urdf", PANDA_URDF.format(link1="link1.obj"))
    monkeypatch.delenv("ROS_PACKAGE_PATH", raising=False)
    missing = "link 'panda_link0': collision mesh 'package://franka_description/meshes/"
    with pytest.raises(ModelError, match=missing + "collision/link0.obj' not found"):
        myriad.load_asset(path)
    with pytest.warns(RuntimeWarning, match="visual mesh"):
        assert myriad.load_asset(path, package_paths=[tmp_path / "share"]).nq == 8
    monkeypatch.setenv("ROS_PACKAGE_PATH", f"/nonexistent:{tmp_path / 'share'}")
    with pytest.warns(RuntimeWarning, match="visual mesh"):
        assert myriad.load_asset(path).nq == 8


def test_collada_collision_without_substitute_is_an_error(tmp_path):
    path = _franka_tree(tmp_path, link1="link1.dae")
    (tmp_path / "franka_description/meshes/collision/link1.obj").unlink()
    uri = "package://franka_description/meshes/collision/link1.dae"
    with pytest.raises(ModelError, match=f"franka_panda.urdf: link 'panda_link1': collision mesh "
                                         f"'{uri}': MuJoCo cannot read this format"):
        myriad.load_asset(path)


# --------------------------------------------------------------------------- 5. balancing
# example-robot-data's ANYmal C: the depth camera's inertia and the singular inertia of `hatch`
ANYMAL_LINKS_URDF = """<robot name="anymal_parts">
  <link name="depth_camera_front_camera"><inertial><origin rpy="0 0 0" xyz="0.01 0 0.01"/>
    <mass value="0.16043"/><inertia ixx="0.000637051" ixy="0.000484569" ixz="0.000424211"
      iyy="0.000929402" iyz="5.138e-06" izz="0.000484569"/></inertial></link>
  <link name="hatch"><inertial><mass value="0.142"/><inertia ixx="0.001" ixy="0.001" ixz="0.001"
      iyy="0.001" iyz="0.001" izz="0.001"/></inertial></link>
  <link name="lidar"><inertial><mass value="0.3"/>
      <inertia ixx="0.001" iyy="0.001" izz="0.003" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="to_hatch" type="revolute"><parent link="depth_camera_front_camera"/>
    <child link="hatch"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
  <joint name="to_lidar" type="revolute"><parent link="depth_camera_front_camera"/>
    <child link="lidar"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>
  </joint>
</robot>"""


def _principal(body):
    if np.isfinite(body.fullinertia[0]):
        xx, yy, zz, xy, xz, yz = body.fullinertia
        return np.linalg.eigh(np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]]))
    return np.sort(body.inertia), None


def test_inertia_breaking_the_triangle_inequality_is_balanced(tmp_path):
    path = _write(tmp_path, "anymal_parts.urdf", ANYMAL_LINKS_URDF)
    with pytest.raises(ModelError, match="inertia must satisfy A \\+ B >= C"):
        myriad.load(path)
    before = mujoco.MjSpec.from_string(ANYMAL_LINKS_URDF)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        after = asset_spec(path)
    messages = [str(w.message) for w in caught]
    for link in ("depth_camera_front_camera", "hatch", "lidar"):
        _one(messages, f"anymal_parts.urdf: link '{link}': principal inertia", "balanced to")
        (a, b, c), axes = _principal(before.body(link))
        a, b = max(a, 0), max(b, 0)
        (a2, b2, c2), axes2 = _principal(after.body(link))
        assert a2 + b2 >= c2 and c2 == pytest.approx(c, rel=1e-9)       # largest kept
        # the smallest two raised by the same amount, just enough: a' + b' = c
        assert a2 - a == pytest.approx(b2 - b, rel=1e-6, abs=1e-12)
        assert a2 + b2 == pytest.approx(c, rel=1e-8)
        if axes is not None and link != "hatch":   # the principal axes are kept
            np.testing.assert_allclose(np.abs(axes.T @ axes2), np.eye(3), atol=1e-6)
    assert _one(messages, "link 'lidar'").endswith(
        "(0.001, 0.001, 0.003) breaks A + B >= C; balanced to (0.0015, 0.0015, 0.003) by raising "
        "the two smallest moments")
    model, _ = _load(path)
    lidar = model.body_names.index("lidar")
    np.testing.assert_allclose(np.sort(model.body_inertia[lidar]), [0.0015, 0.0015, 0.003],
                               rtol=1e-6)


SIGN_SLIP_URDF = """<robot name="finger">
  <link name="base"/>
  <link name="lower">
    <inertial><origin xyz="0 0 -0.05"/><mass value="0.05"/>
      <inertia ixx="0.0001" iyy="0.0001" izz="0.00002" ixy="0.00015" ixz="0" iyz="0"/></inertial>
    <collision><geometry><box size="0.01 0.01 0.1"/></geometry></collision>
  </link>
  <joint name="j" type="revolute"><parent link="base"/><child link="lower"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="10"/></joint>
</robot>"""


def test_a_negative_principal_moment_counts_as_zero_then_is_balanced(tmp_path):
    """A product of inertia with a sign slip (eigenvalues -5e-5, 2e-5, 2.5e-4, as
    example-robot-data's finger_edu has one): MuJoCo refuses; load_asset takes the negative
    moment as 0 and raises the two smallest to a + b = c, the largest and the axes kept."""
    path = _write(tmp_path, "finger.urdf", SIGN_SLIP_URDF)
    with pytest.raises(ModelError, match="positive eigenvalues"):
        myriad.load(path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = myriad.load_asset(path, fix_base_link=True)
    message = _one([str(w.message) for w in caught], "link 'lower': principal inertia")
    assert "balanced to" in message
    lower = model.body_names.index("lower")
    moments = np.sort(model.body_inertia[lower])
    assert moments[2] == pytest.approx(2.5e-4, rel=1e-5)
    floor = 1e-3 * 2.5e-4            # the negative moment first goes up to the floor
    raise_by = (2.5e-4 - floor - 2e-5) / 2
    np.testing.assert_allclose(moments[:2], [floor + raise_by, 2e-5 + raise_by], rtol=1e-4)


def test_a_zero_moment_is_raised_to_the_floor(tmp_path):
    """A rod's axis written as 0 (finger_edu's lower link: 1.2e-4, 1.2e-4, 0): MuJoCo refuses a
    zero eigenvalue; load_asset raises it to 1e-3 of the largest, the others kept."""
    path = _write(tmp_path, "rod.urdf", SIGN_SLIP_URDF.replace(
        'ixx="0.0001" iyy="0.0001" izz="0.00002" ixy="0.00015"',
        'ixx="0.00012" iyy="0.00012" izz="0" ixy="0"'))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = myriad.load_asset(path, fix_base_link=True)
    assert "has a moment at or below 0.001 of the largest" in _one(
        [str(w.message) for w in caught], "link 'lower'")
    moments = np.sort(model.body_inertia[model.body_names.index("lower")])
    np.testing.assert_allclose(moments, [1.2e-7, 1.2e-4, 1.2e-4], rtol=1e-4)


def test_the_real_anymal_c_loads(tmp_path):
    """The whole example-robot-data ANYmal C (where installed): package:// meshes, 45 COLLADA
    visuals, five unbalanced inertias; a free base and 12 joints."""
    from myriad.assets import ANYMAL_C, installed_file
    try:
        path = installed_file("example-robot-data", ANYMAL_C, "anymal")
    except ModelError:
        pytest.skip("example-robot-data is not installed")
    model, messages = _load(path)
    assert model.nq == 19 and model.body_names[0] == "base"
    assert sum("balanced to" in m for m in messages) == 5
    _one(messages, "45 visual mesh(es)")


# --------------------------------------------------------------------------- 6. the base
BALL_URDF = """<?xml version="1.0"?>
<robot name="ball">
  <link name="ball">
    <visual><geometry><sphere radius="0.1"/></geometry></visual>
    <collision><geometry><sphere radius="0.1"/></geometry></collision>
    <inertial><mass value="1"/>
      <inertia ixx="0.004" iyy="0.004" izz="0.004" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
</robot>"""


def test_the_base_is_free_unless_fixed(tmp_path):
    """Isaac Gym: a single-link URDF is a free body (MuJoCo alone welds it to the world)."""
    path = _write(tmp_path, "ball.urdf", BALL_URDF)
    assert myriad.load(path).nq == 0
    model, messages = _load(path)
    assert messages == [] and model.nq == 7 and model.body_names == ["ball"]
    assert model.body_mass[0] == pytest.approx(1)
    sim = myriad.Simulator(model, num_envs=1)
    z0 = sim.q[0, 2].item()
    for _ in range(5):
        sim.step()
    assert sim.q[0, 2].item() < z0 - 1e-3                # it falls
    fixed, _ = _load(path, fix_base_link=True)
    assert fixed.nq == 0


@pytest.mark.parametrize("root, fix_base_link, nq", [
    ("", False, 7),                              # no joint: a free joint is added
    ("", True, 0),
    ("<freejoint/>", True, 0),                   # fix_base_link removes the free joint
    ("<freejoint/>", False, 7),
    # other joints of the root: a fixed base keeps them; a free base replaces them by a free
    # joint, as Isaac Gym floats IsaacGymEnvs' Ingenuity (a locked hinge on its chassis, which
    # its task does not count among the 4 DOFs)
    ("<joint type='slide' axis='1 0 0'/>", True, 1),
    ("<joint type='slide' axis='1 0 0'/>", False, 7),
])
def test_mjcf_root_follows_fix_base_link(tmp_path, root, fix_base_link, nq):
    path = _write(tmp_path, "root.xml", f"""<mujoco><worldbody><body name="base" pos="0 0 1">
      {root}<geom size=".1"/><body name="arm"><joint type="hinge"/><geom size=".05"/></body>
      </body></worldbody></mujoco>""")
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert myriad.load_asset(path, fix_base_link=fix_base_link).nq == nq + 1
    replaced = [w for w in seen if "replaced by a free joint" in str(w.message)]
    assert len(replaced) == (1 if "slide" in root and not fix_base_link else 0)


# --------------------------------------------------------------------------- 7. unfixable
@pytest.mark.parametrize("name, text, message", [
    ("broken.xml", "<mujoco><worldbody><body><geom size='0.1'/></worldbody>", "MuJoCo rejected"),
    ("broken.urdf", "<robot name='r'><link name='a'></robot>", "malformed XML"),
    ("joint.xml", """<mujoco><worldbody><body><joint type="weird"/><geom size=".1"/></body>
      </worldbody></mujoco>""", "invalid keyword: 'weird'"),
    ("joint.urdf", """<robot name="r"><link name="a"/><link name="b"/><joint name="j" type="weird">
      <parent link="a"/><child link="b"/></joint></robot>""", "invalid joint type"),
    ("missing_mesh.xml", """<mujoco><asset><mesh name="m" file="nope.obj"/></asset><worldbody>
      <body><freejoint/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>""", "nope.obj"),
])
def test_what_cannot_be_repaired_stays_a_model_error(tmp_path, name, text, message):
    path = _write(tmp_path, name, text)
    with pytest.raises(ModelError, match=f"{name}: .*{message}"):
        myriad.load_asset(path)
    with pytest.raises(ModelError, match="nothing.xml: no such model file"):
        myriad.load_asset(tmp_path / "nothing.xml")


# --------------------------------------------------------------------------- 8. IsaacGymEnvs'
def test_repeated_names_and_locked_ranges_of_a_generated_mjcf(tmp_path):
    """IsaacGymEnvs' Ingenuity writes an MJCF whose rotors' joints share names and have the
    range 0 0 (it spins them at reset): Isaac Gym loads it, MuJoCo refuses both."""
    path = _write(tmp_path, "rotors.xml", """<mujoco><worldbody><body name="chassis">
      <freejoint/><geom size=".1"/>
      <body name="rotor"><joint name="roll" type="hinge" limited="true" range="0 0"/>
        <geom size=".05"/></body>
      <body name="dummy"><joint name="roll" type="hinge" limited="true" range="0 0"/>
        <geom size=".05"/></body></body></worldbody></mujoco>""")
    model, messages = _load(path)
    assert model.joint_names[1:] == ["roll", "roll_2"]
    assert any("second <joint> named 'roll' renamed roll_2" in m for m in messages)
    assert any("one-value range" in m and "made unlimited" in m for m in messages)
    assert not model.jnt_limited[1:].any()


def test_urdf_density_inertials_duplicates_and_meshes_from_the_asset_root(tmp_path):
    """IsaacGymEnvs' cube URDFs give a <density> instead of a <mass>; Trifinger's fingertips
    have two <inertial>s; the Allegro URDF writes mesh paths from the asset root."""
    for folder in ("meshes", "urdf"):
        (tmp_path / "robots" / folder).mkdir(parents=True)
    (tmp_path / "robots" / "meshes" / "tip.obj").write_text(
        "v 0 0 0\nv 0.02 0 0\nv 0 0.02 0\nv 0 0 0.02\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
    path = _write(tmp_path / "robots" / "urdf", "cube.urdf", """<robot name="cube">
      <link name="cube"><collision><geometry><box size="0.1 0.1 0.1"/></geometry></collision>
        <visual><geometry><mesh filename="robots/meshes/tip.obj"/></geometry></visual>
        <inertial><density value="500.0"/></inertial></link>
      <joint name="j" type="revolute"><parent link="cube"/><child link="tip"/>
        <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <link name="tip"><collision><geometry><mesh filename="robots/meshes/tip.obj"/></geometry>
        </collision>
        <inertial><mass value="0.03"/><inertia ixx="1e-6" iyy="1e-6" izz="1e-6" ixy="0"
          ixz="0" iyz="0"/></inertial>
        <inertial><mass value="0.009"/><inertia ixx="2e-6" iyy="2e-6" izz="3e-7" ixy="0"
          ixz="0" iyz="0"/></inertial></link></robot>""")
    model, messages = _load(path, package_paths=(str(tmp_path),))
    assert model.body_mass[model.body_names.index("cube")] == pytest.approx(0.5)  # 500 × 0.001
    assert model.body_mass[model.body_names.index("tip")] == pytest.approx(0.03)  # the first
    assert any("<density> (500 kg/m³) and no <mass>" in m for m in messages)
    assert any("2 <inertial> elements; the first is used" in m for m in messages)


def test_a_glb_drawing_mesh_is_converted(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    trimesh.creation.box((0.2, 0.2, 0.2)).export(tmp_path / "shell.glb")
    path = _write(tmp_path, "drawn.xml", """<mujoco><asset><mesh name="shell" file="shell.glb"/>
      </asset><worldbody><body name="b"><freejoint/><geom size=".1"/>
      <geom type="mesh" mesh="shell" contype="0" conaffinity="0"/></body></worldbody></mujoco>""")
    model, messages = _load(path)
    assert any("read with trimesh" in m for m in messages)
    assert model.ngeom == 2
