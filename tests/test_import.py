"""Import: what MuJoCo compiles becomes a Model; what it rejects, or we do not support, is a
ModelError naming the file and the element."""

import importlib.util
import os
import warnings

import numpy as np
import pytest

import myriad
from myriad import ModelError
from myriad.physics.types import SensorType


def _write(tmp_path, name, text):
    path = tmp_path / name
    path.write_text(text)
    return str(path)


def test_missing_file(tmp_path):
    with pytest.raises(ModelError, match="nope.xml: no such model file"):
        myriad.load(tmp_path / "nope.xml")


def test_malformed_xml_names_the_file(tmp_path):
    path = _write(tmp_path, "broken.xml", "<mujoco><worldbody><body><geom size='0.1'/></worldbody>")
    with pytest.raises(ModelError, match="broken.xml: MuJoCo rejected the model"):
        myriad.load(path)


def test_invalid_element_names_element(tmp_path):
    path = _write(tmp_path, "bad_joint.xml", """<mujoco><worldbody><body name="b">
        <joint name="j" type="hinge" axis="0 0 0"/><geom size="0.1"/></body></worldbody></mujoco>""")
    with pytest.raises(ModelError, match=r"bad_joint.xml: .*(axis|Element)"):
        myriad.load(path)


@pytest.mark.parametrize("snippet, message", [
    ("""<worldbody><site name="s0" pos="-1 0 0"/><site name="in" pos="0.01 0 0"/>
        <geom name="pin" type="sphere" size="0.1"/>
        <body name="a" pos="1 0 0"><freejoint/><geom size=".1"/><site name="s1"/></body></worldbody>
        <tendon><spatial name="rope"><site site="s0"/><geom geom="pin" sidesite="in"/><site site="s1"/>
        </spatial></tendon>""",
     "tendon 'rope': its side site 'in' lies inside the geom it wraps"),
    ("""<worldbody><body name="a"><joint name="h" type="hinge"/><geom size=".1"/></body></worldbody>
        <actuator><general name="user_dyn" joint="h" dyntype="user" dynprm="0.1"/></actuator>""",
     "actuator 'user_dyn': mjDYN_USER activation dynamics"),
    ("""<worldbody><body name="a" gravcomp="1"><joint name="h" type="hinge" actuatorgravcomp="true"/>
        <geom size=".1"/></body></worldbody>""", "joint 'h': actuatorgravcomp"),
])
def test_unsupported_features_are_errors(tmp_path, snippet, message):
    path = _write(tmp_path, "unsupported.xml", f"<mujoco>{snippet}</mujoco>")
    with pytest.raises(ModelError, match=f"unsupported.xml: {message}"):
        myriad.load(path)


def test_what_does_not_touch_the_dynamics_is_skipped_not_refused(tmp_path):
    """A sensor Myriad does not compute is skipped with a warning naming it (the sensors around
    it are kept, in order), and a flat mesh only drawn (no convex hull) loads."""
    path = _write(tmp_path, "extras.xml", """<mujoco>
      <asset><mesh name="decal" vertex="0 0 0 1 0 0 0 1 0 1 1 0" face="0 1 2 1 3 2" inertia="shell"/></asset>
      <worldbody><geom type="plane" size="2 2 0.1"/>
        <body name="a" pos="0 0 0.3"><freejoint/><geom type="box" size="0.1 0.1 0.1"/>
          <geom type="mesh" mesh="decal" contype="0" conaffinity="0" group="1" mass="0"/>
          <site name="imu"/></body></worldbody>
      <sensor><rangefinder name="range" site="imu"/><force name="f" site="imu"/>
        <subtreecom name="com" body="a"/></sensor></mujoco>""")
    with pytest.warns(RuntimeWarning, match=r"extras.xml: 2 sensor\(s\) skipped.*'range'.*'com'"):
        model = myriad.load(path)
    assert model.sensor_names == ["f"] and list(model.sensor_type) == [SensorType.FORCE]
    sim = myriad.Simulator(model, num_envs=1)
    for _ in range(60):
        sim.step()
    assert sim.sensor_data.shape == (1, 3)
    assert abs(sim.q[0, 2].item() - 0.1) < 2e-3          # the box rests on the plane
    # a collision mesh still needs its hull
    collides = open(path).read().replace(' contype="0" conaffinity="0"', "")
    with pytest.raises(ModelError, match="mesh 'decal'"):
        myriad.load_xml(collides, "collides")


def test_every_geom_type_and_mesh_hull(tmp_path):
    cube = " ".join(f"{x} {y} {z}" for x in (-1, 1) for y in (-1, 1) for z in (-1, 1))
    path = _write(tmp_path, "shapes.xml", f"""<mujoco>
      <asset>
        <mesh name="cube" vertex="{cube}" scale="0.1 0.1 0.1"/>
        <hfield name="terrain" nrow="3" ncol="3" size="1 1 0.2 0.1" elevation="0 0 0 0 1 0 0 0 0"/>
      </asset>
      <worldbody>
        <geom name="floor" type="plane" size="5 5 0.1"/>
        <geom name="ground" type="hfield" hfield="terrain" pos="3 0 0"/>
        <body name="b" pos="0 0 1"><freejoint/>
          <geom name="sphere" type="sphere" size="0.1"/>
          <geom name="capsule" type="capsule" size="0.05 0.2"/>
          <geom name="ellipsoid" type="ellipsoid" size="0.1 0.2 0.3"/>
          <geom name="cylinder" type="cylinder" size="0.1 0.2"/>
          <geom name="box" type="box" size="0.1 0.2 0.3"/>
          <geom name="mesh" type="mesh" mesh="cube"/>
        </body>
      </worldbody></mujoco>""")
    model = myriad.load(path)
    assert model.geom_names == ["floor", "ground", "sphere", "capsule", "ellipsoid", "cylinder",
                                "box", "mesh"]
    assert model.geom_type.tolist() == [0, 1, 2, 3, 4, 5, 6, 7]
    assert model.geom_body.tolist() == [-1, -1, 0, 0, 0, 0, 0, 0]
    # the mesh's hull: 12 triangles on the cube's 8 corners, at +-0.1 in the mesh frame
    assert model.mesh_hull_facenum.tolist() == [12]
    hull_points = model.mesh_vert[np.unique(model.mesh_hull_face)]
    np.testing.assert_allclose(np.abs(hull_points), 0.1, atol=1e-6)
    assert len(hull_points) == 8
    assert model.hfield_nrow.tolist() == [3] and model.hfield_data.max() == pytest.approx(1.0)


def test_urdf(tmp_path):
    path = _write(tmp_path, "arm.urdf", """<robot name="arm">
      <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="upper"><inertial><origin xyz="0 0 0.2"/><mass value="0.5"/>
        <inertia ixx="0.005" iyy="0.005" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
        <collision><origin xyz="0 0 0.2"/><geometry><cylinder radius="0.03" length="0.4"/></geometry></collision></link>
      <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
        <origin xyz="0 0 0.1"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="3"/></joint>
    </robot>""")
    model = myriad.load(path)
    assert model.joint_names == ["shoulder"]
    assert model.nv == 1 and "upper" in model.body_names
    assert model.jnt_range[0].tolist() == pytest.approx([-1.5, 1.5])
    assert model.body_mass[model.body_index("upper")] == pytest.approx(0.5)


def test_model_contents_of_the_ant():
    model = myriad.load(myriad.asset_path("ant.xml"))
    assert model.nq == 15 and model.nv == 14 and model.nu == 8
    assert list(model.sensor_type) == [SensorType.FORCE, SensorType.TORQUE] * 4
    assert np.all(model.actuator_gear == 15.0)
    # quaternions are stored xyzw: the free joint's initial rotation is the identity
    np.testing.assert_allclose(model.qpos0[3:7], [0, 0, 0, 1])
    q = model.qpos_from_mujoco(model.mj_model.qpos0)
    np.testing.assert_allclose(q, model.qpos0, atol=1e-7)
    np.testing.assert_allclose(model.qpos_to_mujoco(q), model.mj_model.qpos0, atol=1e-7)
    with pytest.raises(KeyError, match="no body named 'tail'"):
        model.body_index("tail")


# ---------------------------------------------------------------- non-finite numbers
# MuJoCo compiles most of these with a warning on stderr only; every env would be NaN after one
# step. Each must be a ModelError naming the file, the element and the attribute.
NONFINITE_MJCF = [
    # (the model, message of the check on the file's text, message of the check on the MjModel)
    ("""<worldbody><body name="torso" pos="0 nan 1"><freejoint/><geom size="0.1"/></body></worldbody>""",
     r"line 1: body 'torso': pos=\"0 nan 1\" is not finite",
     r"body 'torso': <body pos> = 0 nan 1 is not finite"),
    ("""<worldbody><body pos="0 nan 1"><freejoint/><geom size="0.1"/></body></worldbody>""",
     r"line 1: body \(unnamed\): pos=\"0 nan 1\" is not finite",
     r"body #1 \(unnamed\): <body pos> = 0 nan 1 is not finite"),
    ("""<worldbody><body><freejoint/><geom name="brick" type="box" size="0.1 inf 0.1"/></body></worldbody>""",
     r"line 1: geom 'brick': size=\"0.1 inf 0.1\" is not finite",
     r"geom 'brick': <geom size> \(or fromto\) = 0.1 inf 0.1 is not finite"),
    ("""<worldbody><body name="arm">
          <joint name="elbow" type="hinge" range="-1 nan"/><geom size="0.1"/></body></worldbody>""",
     r"line 2: joint 'elbow': range=\"-1 nan\" is not finite",
     r"joint 'elbow': <joint range> = -1 nan is not finite"),
    ("""<option gravity="0 0 -inf"/><worldbody><body><freejoint/><geom size="0.1"/></body></worldbody>""",
     r"line 1: option \(unnamed\): gravity=\"0 0 -inf\" is not finite",
     r"<option gravity> = 0 0 -inf is not finite"),
    # finite as a double, infinite in the float32 the engine computes in
    ("""<worldbody><body name="far" pos="0 1e39 0"><freejoint/><geom size="0.1"/></body></worldbody>""",
     r"line 1: body 'far': pos=\"0 1e39 0\" is not finite",
     r"body 'far': <body pos> = 0 1e\+39 0 is not finite"),
]


@pytest.mark.parametrize("snippet, text_message, model_message", NONFINITE_MJCF)
def test_non_finite_numbers_in_mjcf_are_errors(tmp_path, snippet, text_message, model_message):
    import mujoco
    xml = f"<mujoco>{snippet}</mujoco>"
    path = _write(tmp_path, "nan.xml", xml)
    with pytest.raises(ModelError, match=f"nan.xml: {text_message}"):
        myriad.load(path)
    with pytest.raises(ModelError, match=f"generated: {text_message}"):
        myriad.load_xml(xml, "generated")
    # the check of the compiled model alone (what a scene or an MjModel built in code goes through)
    with pytest.raises(ModelError, match=f"compiled: {model_message}"):
        myriad.from_mujoco(mujoco.MjModel.from_xml_string(xml), "compiled")


def test_non_finite_number_that_mujoco_hides_is_an_error():
    """MuJoCo reads mass="nan" as "not given" and computes the mass from the density: the
    compiled model is finite, only the file's text shows it."""
    xml = """<mujoco><worldbody><body name="b"><freejoint/>
        <geom name="ball" size="0.1" mass="nan"/></body></worldbody></mujoco>"""
    with pytest.raises(ModelError, match=r"<string>: line 2: geom 'ball': mass=\"nan\" is not finite"):
        myriad.load_xml(xml)


def test_non_finite_number_in_an_included_file(tmp_path):
    _write(tmp_path, "part.xml", """<mujoco><worldbody>
        <body name="b"><freejoint/><geom size="0.1" friction="nan"/></body></worldbody></mujoco>""")
    path = _write(tmp_path, "main.xml", '<mujoco><include file="part.xml"/></mujoco>')
    with pytest.raises(ModelError, match=r"part.xml: line 2: geom in body 'b': friction=\"nan\""):
        myriad.load(path)


def test_non_finite_number_in_urdf_names_the_joint(tmp_path):
    import mujoco
    path = _write(tmp_path, "arm_nan.urdf", """<robot name="arm">
      <link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="upper"><inertial><mass value="0.5"/>
        <inertia ixx="0.005" iyy="0.005" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
        <origin xyz="0 nan 0.1"/><axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="10" velocity="3"/></joint>
    </robot>""")
    with pytest.raises(ModelError, match=r"arm_nan.urdf: line 6: origin in joint 'shoulder': "
                                         r"xyz=\"0 nan 0.1\" is not finite"):
        myriad.load(path)
    # compiled, the joint origin is the pose of the child link's body
    with pytest.raises(ModelError, match=r"arm: body 'upper': <body pos> = .*nan.* is not finite"):
        myriad.from_mujoco(mujoco.MjModel.from_xml_path(path), "arm")


def test_names_that_read_as_numbers_are_not_numbers():
    model = myriad.load_xml("""<mujoco><worldbody><body name="inf"><joint name="nan" type="hinge"/>
        <geom size="0.1"/></body></worldbody><actuator><motor joint="nan"/></actuator></mujoco>""")
    assert model.body_names == ["inf"] and model.joint_names == ["nan"]


def _gymnasium_robotics_asset(name: str) -> str:
    """A model file of gymnasium-robotics, found without importing the package (its __init__
    imports pettingzoo, mujoco-py era extras, ...: a `pytest.importorskip` would skip the test
    wherever those are missing, though the XML is there); the test is skipped without it."""
    spec = importlib.util.find_spec("gymnasium_robotics")
    if spec is None or not spec.submodule_search_locations:
        pytest.skip("gymnasium-robotics is not installed (pip install --no-deps "
                    "gymnasium-robotics==1.4.2)")
    return os.path.join(spec.submodule_search_locations[0], "envs", "assets", name)


def test_shadow_hand_with_explicit_contact_pairs_loads_and_steps():
    """OpenAI's Shadow Hand (gymnasium-robotics' manipulate_block.xml): its shared.xml declares
    19 frictionless (condim 1) <pair>s between the fingers and the thumb, whose geoms'
    contype/conaffinity (1/0) keep them apart otherwise. It loads; each distinct pair is a
    candidate once (one is named twice), frictionless; the hand steps, finite."""
    from myriad.physics.pairs import candidate_pairs, pair_friction
    model = myriad.load(_gymnasium_robotics_asset("hand/manipulate_block.xml"))
    assert model.pair_geoms.shape == (19, 2) and np.all(model.pair_friction == 0.0)
    names = model.geom_names
    pairs = candidate_pairs(model)
    mu = dict(zip((tuple(sorted((names[a], names[b]))) for a, b in pairs),
                  pair_friction(model, pairs)[:, 0].tolist()))
    assert len(mu) == len(pairs), "each pair once"
    explicit = {tuple(sorted((names[a], names[b]))) for a, b in model.pair_geoms}
    assert len(explicit) == 18
    assert all(mu[p] == 0.0 for p in explicit)
    assert mu[("robot0:C_ffdistal", "robot0:C_thdistal")] == 0.0
    assert sum(1 for v in mu.values() if v >= 0.0) == 18     # the others: the geoms' average
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)       # no overlap at rest among them
        sim = myriad.Simulator(model, num_envs=2)
    for _ in range(10):
        sim.step()
    assert sim.nonfinite.sum() == 0 and np.isfinite(sim.q.numpy()).all()
