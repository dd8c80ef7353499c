"""Narrowphase against MuJoCo's collision functions on random scenes of primitives; candidate
pairs (MuJoCo's filters, explicit <contact><pair> elements)."""

import math

import mujoco
import numpy as np
import pytest
import torch
import warp as wp

import myriad
from myriad.physics.stages import collision
from myriad.physics.pairs import candidate_pairs, pair_friction
from myriad.physics.types import GeomType

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

MARGIN = 0.02
# Isaac Gym's settings: dt 1/60, 2 substeps, TGS with 4 position and 1 velocity iteration
ISAAC_PARAMS = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4,
                                velocity_iterations=1)

SHAPES = {
    "sphere": ('type="sphere" size="0.1"', 1, 1),
    "capsule": ('type="capsule" size="0.06 0.12"', 1, 1),
    "box": ('type="box" size="0.08 0.1 0.12"', 1, 1),
    "ellipsoid": ('type="ellipsoid" size="0.06 0.08 0.11"', 1, 1),
    "cylinder": ('type="cylinder" size="0.07 0.1"', 1, 1),
    "mesh": ('type="mesh" mesh="gem"', 1, 1),
}
# a convex mesh: an irregular octahedron
GEM = "0.1 0 0  -0.08 0 0  0 0.09 0  0 -0.07 0  0 0 0.12  0.01 0.02 -0.1"
# pairs for which MuJoCo and we report the same contact points one for one; for the others
# (box-box, capsule-box: several points chosen differently) the deepest contact is compared
SAME_POINTS = {("plane", "sphere"), ("plane", "capsule"), ("plane", "box"), ("sphere", "sphere"),
               ("sphere", "capsule"), ("sphere", "box"), ("capsule", "capsule"),
               ("plane", "ellipsoid")}


def _scene(seed: int, n_each: int = 2) -> str:
    rng = np.random.default_rng(seed)
    bodies = []
    for kind, (geom, contype, conaffinity) in SHAPES.items():
        for i in range(n_each):
            pos = " ".join(f"{x:.5f}" for x in rng.uniform([-0.25, -0.25, 0.0], [0.25, 0.25, 0.3]))
            quat = rng.normal(size=4)
            quat = " ".join(f"{x:.6f}" for x in quat / np.linalg.norm(quat))
            bodies.append(f'<body name="{kind}{i}" pos="{pos}" quat="{quat}"><freejoint/>'
                          f'<geom name="{kind}{i}" {geom} contype="{contype}" conaffinity="{conaffinity}" '
                          f'margin="{MARGIN}"/></body>')
    return f"""<mujoco><asset><mesh name="gem" vertex="{GEM}"/></asset><worldbody>
      <geom name="floor" type="plane" size="2 2 0.1" contype="7" conaffinity="7" margin="{MARGIN}"/>
      {''.join(bodies)}</worldbody></mujoco>"""


def _mujoco_contacts(model):
    mj = model.mj_model
    d = mujoco.MjData(mj)
    mujoco.mj_forward(mj, d)
    found = {}
    for c in d.contact[:d.ncon]:
        # MuJoCo's capsule-plane also reports the far end of a capsule whose near end touches,
        # even beyond the margin; PhysX (our semantics) keeps only contacts within the offset
        if c.dist >= MARGIN:
            continue
        found.setdefault(tuple(sorted(c.geom)), []).append((c.dist, c.pos.copy(), c.frame[:3].copy(), tuple(c.geom)))
    return found


@pytest.mark.parametrize("seed", range(10))
def test_contacts_match_mujoco(seed, device):
    model = myriad.load_xml(_scene(seed), f"scene{seed}")
    sim = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(contact_offset=MARGIN, contacts_per_env=128))
    sim.collide()
    expected = _mujoco_contacts(model)
    for e in range(2):  # both envs hold the same scene
        n = int(sim.contact_count[e])
        assert n <= 128
        ours = {}
        for k in range(n):
            g1, g2 = sim.contact_geom[e, k].tolist()
            ours.setdefault(tuple(sorted((g1, g2))), []).append(
                (sim.contact_dist[e, k].item(), sim.contact_pos[e, k].cpu().numpy(),
                 sim.contact_normal[e, k].cpu().numpy(), (g1, g2)))
        assert set(ours) == set(expected), (sorted(ours), sorted(expected))
        for key, theirs in expected.items():
            mine = sorted(ours[key], key=lambda c: c[0])
            theirs = sorted(theirs, key=lambda c: c[0])
            kinds = tuple(GeomType(t).name.lower() for t in sorted(model.geom_type[list(key)]))
            # exact closed forms: 1e-5 m and 1e-4 on the normal; clipped, searched or GJK
            # (iterative, float32): 5e-4 m and 6e-2 (a flat cap facing a flat face 2 cm away
            # leaves GJK's direction 0.05 off while its distance is good to 3e-5 m)
            d_tol, n_tol = (1e-5, 1e-4) if kinds in SAME_POINTS else (5e-4, 6e-2)
            if kinds not in SAME_POINTS:
                mine, theirs = mine[:1], theirs[:1]
                if theirs[0][0] < 0.0 and kinds not in (("box", "box"), ("capsule", "box")):
                    continue  # overlapping convex shapes: see the next test
                if theirs[0][0] < -1e-3:
                    # overlaps: capsule-box's depth is measured through the face nearest the
                    # segment's deepest point, not along MuJoCo's minimum translation; exact for
                    # shapes apart (within the offset) or touching, as compared here
                    continue
            assert len(mine) == len(theirs), key
            for (d1, p1, n1, order1), (d2, p2, n2, order2) in zip(mine, theirs):
                # same distance; normals compared in MuJoCo's geom order
                assert d1 == pytest.approx(d2, abs=d_tol), key
                sign = 1.0 if order1 == order2 else -1.0
                np.testing.assert_allclose(sign * n1, n2, atol=n_tol, err_msg=str((kinds, d1, d2)))
                if kinds in SAME_POINTS and len(theirs) == 1:
                    np.testing.assert_allclose(p1, p2, atol=1e-4)


@pytest.mark.parametrize("gap", [-0.004, 0.0, 0.006, 0.03])
def test_a_capsule_across_a_box_edge_touches_at_its_middle(gap, device):
    """A finger lying across the cube's edge: both ends far from the box (7 cm), the contact
    in the middle of the segment. Its distance is MuJoCo's to the search's 1e-4 m; beyond the
    contact offset (gap 3 cm), neither reports a contact."""
    s = 1 / math.sqrt(2)
    at = 0.05 + (gap + 0.01) * s          # the capsule's axis passes the edge at gap + radius
    model = myriad.load_xml(f"""<mujoco><option gravity="0 0 0"/><worldbody>
      <body name="cube"><freejoint/><geom name="cube" type="box" size="0.05 0.05 0.05"
        margin="{MARGIN}"/></body>
      <body name="finger" pos="{at} 0 {at}" euler="0 -45 0"><freejoint/>
        <geom name="finger" type="capsule" size="0.01 0.1" margin="{MARGIN}"/></body>
      </worldbody></mujoco>""", "edge")
    sim = myriad.Simulator(model, device=device,
                           params=myriad.SimParams(contact_offset=MARGIN, contacts_per_env=8))
    sim.collide()
    ours = sim.contact_dist[0, :int(sim.contact_count[0])].tolist()
    theirs = [c[0] for pair in _mujoco_contacts(model).values() for c in pair]
    if gap >= MARGIN:
        assert ours == [] and theirs == []
        return
    assert len(ours) == 1, "the middle contact alone: the ends are 7 cm away"
    assert ours[0] == pytest.approx(gap, abs=1e-4)
    assert ours[0] == pytest.approx(min(theirs), abs=1e-4)


def test_overlap_depth_is_mujocos_minimum_translation():
    """Overlapping convex shapes (the GJK/EPA path): our depth is MuJoCo's minimum-translation
    depth to 1e-3 at the median and never below it by more than 1%. Above it in three pairs of
    these scenes (cylinder-box 20x and 2x, capsule-mesh 1.28x): there MuJoCo's EPA reads too
    shallow; ours is the exact minimum of the support function of A - B (checked with
    tests/test_depth.py's exact_depth: 50.9 mm where MuJoCo reads 2.5 mm)."""
    ratios = []
    for seed in range(10):
        model = myriad.load_xml(_scene(seed), f"scene{seed}")
        sim = myriad.Simulator(model, params=myriad.SimParams(contact_offset=MARGIN,
                                                              contacts_per_env=128))
        sim.collide()
        expected = _mujoco_contacts(model)
        deepest = {}          # per pair: its deepest contact (a face gives its corners too)
        for k in range(int(sim.contact_count[0])):
            key = tuple(sorted(sim.contact_geom[0, k].tolist()))
            deepest[key] = min(deepest.get(key, np.inf), sim.contact_dist[0, k].item())
        for key, ours in deepest.items():
            kinds = tuple(GeomType(t).name.lower() for t in sorted(model.geom_type[list(key)]))
            if "plane" in kinds or kinds in SAME_POINTS or kinds in (("box", "box"), ("capsule", "box")):
                continue
            theirs = min(c[0] for c in expected[key])
            if theirs < -1e-3:
                ratios.append(ours / theirs)
    assert len(ratios) > 20
    assert min(ratios) > 0.99, min(ratios)
    assert abs(np.median(ratios) - 1.0) < 1e-3, np.median(ratios)


def test_candidate_pairs_follow_mujoco_filters():
    model = myriad.load_xml("""<mujoco><worldbody>
      <geom name="floor" type="plane" size="1 1 0.1"/>
      <body name="a"><freejoint/><geom name="ga" size="0.1"/>
        <body name="b" pos="0 0 0.3"><joint type="hinge"/><geom name="gb" size="0.1"/>
          <body name="c" pos="0 0 0.3"><joint type="hinge"/><geom name="gc" size="0.1"/>
            <geom name="gc_ghost" size="0.1" contype="0" conaffinity="0"/></body></body></body>
      <body name="d" pos="1 0 0"><freejoint/><geom name="gd" size="0.1"/></body>
      </worldbody><contact><exclude body1="a" body2="d"/></contact></mujoco>""")
    names = model.geom_names
    pairs = {tuple(sorted((names[a], names[b]))) for a, b in candidate_pairs(model)}
    # parent-child (a-b, b-c) filtered, grandparent a-c kept, excluded a-d dropped, ghost never
    assert pairs == {("floor", "ga"), ("floor", "gb"), ("floor", "gc"), ("floor", "gd"),
                     ("ga", "gc"), ("gb", "gd"), ("gc", "gd")}


def test_bodies_welded_to_the_world_do_not_collide_with_each_other():
    """A jointless table and a jointless wall standing on it move no more than the world: their
    pair (or either with the floor) would only fill contact slots (TriFinger's wall and table
    took 60 of 64 and pushed the fingertip's contact out); a jointless body below a moving one
    is not static, and each still meets what moves."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <geom name="floor" type="plane" size="1 1 0.1"/>
      <body name="table"><geom name="gt" type="box" size="0.5 0.5 0.01"/>
        <body name="wall"><geom name="gw" type="box" size="0.01 0.5 0.1" pos="0.49 0 0.1"/></body>
      </body>
      <body name="cube" pos="0 0 0.05"><freejoint/><geom name="gcube" type="box" size="0.03 0.03 0.03"/>
        <body name="sticker"><geom name="gs" size="0.01" pos="0 0 0.03"/></body></body>
      </worldbody></mujoco>""")
    names = model.geom_names
    pairs = {tuple(sorted((names[a], names[b]))) for a, b in candidate_pairs(model)}
    assert pairs == {("floor", "gcube"), ("gcube", "gt"), ("gcube", "gw"), ("floor", "gs"),
                     ("gs", "gt"), ("gs", "gw")}


def test_collision_reads_only_the_corners_of_a_mesh_hull():
    """A mesh's vertices inside its hull (or on its faces) can never be a support point: the
    collision stage keeps the hull's corners alone, so a cube mesh with a point at its centre and
    one in a face's middle has 8."""
    from myriad.physics.build import shape_data

    corners = " ".join(f"{x} {y} {z}" for x in (-0.1, 0.1) for y in (-0.1, 0.1) for z in (-0.1, 0.1))
    model = myriad.load_xml(f"""<mujoco><asset>
      <mesh name="m" vertex="{corners} 0 0 0 0.1 0 0"/></asset><worldbody>
      <body><freejoint/><geom type="mesh" mesh="m"/></body></worldbody></mujoco>""")
    meshes, _, _ = shape_data(model, "cpu")
    assert meshes.vertnum.numpy().tolist() == [8]
    assert np.allclose(np.abs(meshes.vert.numpy()), 0.1, atol=1e-6)
    assert meshes.rbound.numpy()[0] == pytest.approx(0.1 * math.sqrt(3), rel=1e-5)


def test_parts_of_one_robot_that_overlap_at_rest_do_not_collide_and_are_named(device):
    """A fixed arm whose second link reaches 2 cm into its base (a grandparent, so MuJoCo's
    parent-child filter keeps the pair), and whose first link is sunk into the table it stands
    on: both pairs are dropped with a warning naming them. A free box sunk 1 cm into the same
    table keeps colliding (it is another body, resting on the table), and so does the floor."""
    model = myriad.load_xml("""<mujoco><compiler angle="radian"/><worldbody>
      <geom name="floor" type="plane" size="2 2 0.1"/>
      <geom name="table" type="box" pos="0 0 0.25" size="0.5 0.5 0.25"/>
      <body name="base" pos="0 0 0.55"><geom name="base" type="box" size="0.05 0.05 0.05"/>
        <body name="link1" pos="0 0 0.05"><joint name="j1" axis="0 1 0" range="-1 1" limited="true"/>
          <geom name="link1" type="capsule" fromto="0 0 -0.36 0 0 0.2" size="0.02"/>
          <body name="link2" pos="0 0 0.2"><joint axis="0 1 0" range="-2 2" limited="true"/>
            <geom name="link2" type="capsule" fromto="0 0 0 0.04 0 -0.23" size="0.02"/>
          </body></body></body>
      <body name="box" pos="0.3 0 0.54"><freejoint/><geom name="box" type="box" size="0.05 0.05 0.05"/></body>
      </worldbody><actuator><motor joint="j1"/></actuator></mujoco>""", "overlapping_arm")
    names = model.geom_names
    with pytest.warns(RuntimeWarning, match=r"2 geom pair\(s\) of one robot overlap.*link2.*base"):
        pairs = {tuple(sorted((names[a], names[b]))) for a, b in candidate_pairs(model)}
    assert ("base", "link2") not in pairs and ("link1", "table") not in pairs
    assert ("box", "table") in pairs and ("box", "floor") in pairs and ("box", "link2") in pairs
    with pytest.warns(RuntimeWarning):
        sim = myriad.Simulator(model, num_envs=2, device=device)
    sim.ctrl = torch.tensor([[1.0], [-1.0]], device=sim.torch_device)
    for _ in range(60):
        sim.step()
    assert torch.isfinite(sim.q).all() and sim.qd.abs().max() < 20.0


def test_self_collision_switch():
    model = myriad.load(myriad.asset_path("humanoid.xml"))
    names = model.geom_names
    with_self = {tuple(sorted((names[a], names[b]))) for a, b in candidate_pairs(model)}
    without = {tuple(sorted((names[a], names[b]))) for a, b in candidate_pairs(model, False)}
    assert ("left_hand", "right_hand") in with_self
    assert all("floor" in pair for pair in without) and len(without) > 0
    root = model.body_index("torso")
    assert {tuple(sorted((names[a], names[b]))) for a, b in candidate_pairs(model, {root: False})} == without


def test_overflow_is_counted_not_written(device):
    model = myriad.load_xml(_scene(0), "scene0")
    sim = myriad.Simulator(model, num_envs=3, device=device,
                           params=myriad.SimParams(contact_offset=MARGIN, contacts_per_env=2))
    sim.collide()
    counts = sim.contact_count.cpu()
    assert torch.all(counts == counts[0]) and counts[0] > 2  # more than fit: the overflow
    assert sim.contact_geom.shape == (3, 2, 2)
    with pytest.warns(RuntimeWarning, match=r"3 of 3 envs found more than their 2 contact slots.*"
                                            r"contacts_per_env"):
        assert sim.contact_overflow() == 3
    sim.step()  # the solver uses the slots that exist; the rest were dropped
    assert torch.isfinite(sim.q).all()


def test_contact_slots_stop_at_what_the_pairs_can_fill(device):
    """Slots past what the candidate pairs can produce at once are never filled: the simulator
    sizes its slots (and its constraint rows) to that bound when the setting asks for more,
    and no pose of the shapes, however deep they overlap, finds more than each pair's most
    (`narrowphase.most_contacts`)."""
    from myriad.physics.stages.collision.narrowphase import most_contacts
    model = myriad.load_xml(_scene(3), "scene3")
    pairs = candidate_pairs(model)
    bound = collision.contact_bound(model.geom_type, pairs)
    n = 64
    sim = myriad.Simulator(model, num_envs=n, device=device,
                           params=myriad.SimParams(contact_offset=MARGIN, contacts_per_env=4096))
    assert sim.contact_capacity == bound < 4096
    # every body at a random pose in a 0.2 m cube just above the floor: shapes piled into each
    # other and into the floor, deep overlaps among them
    rng = np.random.default_rng(0)
    q = sim.q.cpu().numpy()
    for b in range(model.nbody - 1):
        quat = rng.normal(size=(n, 4))
        q[:, 7 * b:7 * b + 3] = rng.uniform([-0.1, -0.1, -0.05], [0.1, 0.1, 0.15], size=(n, 3))
        q[:, 7 * b + 3:7 * b + 7] = quat / np.linalg.norm(quat, axis=1, keepdims=True)
    sim.q = torch.as_tensor(q, device=sim.q.device)
    sim.forward()
    sim.collide()
    counts = sim.contact_count.cpu().numpy()
    assert counts.max() <= bound and sim.contact_overflow() == 0
    assert counts.mean() > 10           # the poses did pile the shapes up
    keys = sim.data.contacts.key.numpy()
    reached = set()
    for e in range(n):
        per_pair = np.bincount(keys[e, :counts[e]] // 32, minlength=len(pairs))
        for k in np.flatnonzero(per_pair):
            types = tuple(int(t) for t in model.geom_type[pairs[k]])
            assert per_pair[k] <= most_contacts(*types), (types, per_pair[k])
            if per_pair[k] == most_contacts(*types):
                reached.add(types)
    # the bound is reached, not only kept: a box in a box at four points, a box on the floor
    # at four, a capsule on the floor at both ends
    box, capsule, plane = int(GeomType.BOX), int(GeomType.CAPSULE), int(GeomType.PLANE)
    assert {(box, box), (plane, box), (plane, capsule)} <= reached, reached


def test_an_overflow_keeps_the_deepest_contacts_in_the_order_found(device):
    """Slots too few: the contacts kept are the deepest of all found, not the first found."""
    model = myriad.load_xml(_scene(0), "scene0")
    params = dict(contact_offset=MARGIN)
    every = myriad.Simulator(model, num_envs=2, device=device, params=myriad.SimParams(**params))
    every.collide()
    found = int(every.contact_count[0])
    dist, key = every.contact_dist[0, :found].cpu(), every.data.contacts.key.numpy()[0, :found]
    assert found > 3 and len(set(dist.tolist())) > 2      # distances to choose among
    slots = found // 3      # all found fit the narrowphase's places, not the slots
    few = myriad.Simulator(model, num_envs=2, device=device,
                           params=myriad.SimParams(contacts_per_env=slots, **params))
    few.collide()
    assert int(few.contact_count[0]) == found and few.contact_dist.shape == (2, slots)
    deepest = torch.sort(dist).values[:slots]
    torch.testing.assert_close(torch.sort(few.contact_dist[0].cpu()).values, deepest)
    kept = list(zip(few.data.contacts.key.numpy()[0, :slots].tolist(), few.contact_dist[0].tolist()))
    assert kept == [c for c in zip(key.tolist(), dist.tolist()) if c in kept]


def test_contacts_found_in_any_interleaving_are_put_back_in_the_cpus_order(device):
    """The GPU's thread per (env, pair) takes contact places through an atomic counter, so the
    pairs' contacts interleave; `order_by_pair` gives them the order of the CPU's walk over the
    pairs (each pair's contacts together, as the solver's patches need), contact for contact."""
    model = myriad.load_xml(_scene(0), "scene0")
    sim = myriad.Simulator(model, num_envs=3, device=device,
                           params=myriad.SimParams(contact_offset=MARGIN, contacts_per_env=128))
    sim.collide()
    c = sim.data.contacts
    found = int(sim.contact_count[0])
    assert found < 128      # no overflow: all found are in the order found
    fields = {name: getattr(c, name).numpy().copy() for name in ("geom", "key", "pos", "normal",
                                                                  "dist")}
    pair = fields["key"][0, :found] >> 5
    runs = [p for i, p in enumerate(pair) if i == 0 or p != pair[i - 1]]
    assert len(runs) == len(set(runs)) > 3, pair                 # each pair's contacts together
    assert max(np.bincount(pair)) >= 3, pair                     # patches of several contacts
    rng = np.random.default_rng(0)
    scrambled = {name: value.copy() for name, value in fields.items()}
    for e in range(sim.num_envs):
        # a random interleaving that keeps each pair's own order (one thread's places rise)
        mixed = np.argsort(rng.permutation(found))
        order = np.empty(found, dtype=int)
        for p in np.unique(pair):
            mine = np.flatnonzero(pair == p)
            order[np.sort(mixed[mine])] = mine
        assert e > 0 or not np.array_equal(order, np.arange(found))
        for name, value in scrambled.items():
            value[e, :found] = fields[name][e, order]
    for name, value in scrambled.items():
        getattr(c, name).assign(value)
    wp.launch(collision.order_by_pair, dim=sim.num_envs, inputs=[c], device=sim.device)
    for name, value in fields.items():
        np.testing.assert_array_equal(getattr(c, name).numpy()[:, :found], value[:, :found],
                                      err_msg=name)


def test_explicit_pairs_pass_the_filters_and_replace_the_dynamic_pair():
    """A <pair> is a candidate whatever contype/conaffinity, parent-child and <exclude> say;
    one the filters also make (gb-floor) is there once, with the pair's friction; a pair named
    twice keeps its first friction; a pair on one body is dropped; the self_collisions switch
    drops an articulation's explicit pairs too."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <geom name="floor" type="plane" size="1 1 0.1"/>
      <body name="a"><freejoint/><geom name="ga" size="0.1"/>
        <body name="b" pos="0 0 0.3"><joint type="hinge"/><geom name="gb" size="0.1"/>
          <geom name="gb2" pos="0 0 0.1" size="0.05" contype="0" conaffinity="0"/></body></body>
      <body name="d" pos="1 0 0"><freejoint/>
        <geom name="gd" type="box" size="0.1 0.1 0.1" contype="2" conaffinity="2"/></body>
      </worldbody><contact>
        <exclude body1="a" body2="d"/>
        <pair geom1="ga" geom2="gb" condim="1" friction="0.5 0.005 0.0001"/>
        <pair geom1="gd" geom2="ga" friction="0.3 0.005 0.0001"/>
        <pair geom1="gb" geom2="floor" friction="0.7 0.005 0.0001"/>
        <pair geom1="gb" geom2="gb2"/>
        <pair geom1="floor" geom2="gb" friction="0.9 0.005 0.0001"/>
      </contact></mujoco>""", "explicit_pairs")
    names = model.geom_names
    assert model.pair_geoms.shape == (5, 2)

    def friction_by_pair(self_collision=True):
        pairs = candidate_pairs(model, self_collision)
        assert all(model.geom_type[a] <= model.geom_type[b] for a, b in pairs)   # type-ordered
        found = [tuple(sorted((names[a], names[b]))) for a, b in pairs]
        assert len(found) == len(set(found)), "each pair once"
        return dict(zip(found, pair_friction(model, pairs)[:, 0].tolist()))

    # -1: the geoms' average; condim 1: frictionless
    assert friction_by_pair() == pytest.approx({("floor", "ga"): -1.0, ("floor", "gb"): 0.7,
                                                ("ga", "gb"): 0.0, ("ga", "gd"): 0.3})
    assert friction_by_pair(False) == pytest.approx({("floor", "ga"): -1.0, ("floor", "gb"): 0.7,
                                                     ("ga", "gd"): 0.3})


def test_torsional_and_rolling_friction_follow_mujocos_condim_and_mixing():
    """Per candidate pair (sliding, torsional, rolling): the angular coefficients only where
    the contact's condim reaches 4 and 6; between two geoms of one priority the larger condim
    and each coefficient's larger value, else the higher priority's; an explicit pair's own
    (MuJoCo's pair friction: tangent, tangent, spin, roll, roll)."""
    model = myriad.load_xml("""<mujoco><worldbody>
      <geom name="floor" type="plane" size="1 1 0.1" friction="1 0.03 0.002"/>
      <body pos="0 0 0.1"><freejoint/><geom name="c3" size="0.1" friction="1 0.05 0.01"/></body>
      <body pos="1 0 0.1"><freejoint/>
        <geom name="c4" size="0.1" condim="4" friction="1 0.01 0.01"/></body>
      <body pos="2 0 0.1"><freejoint/>
        <geom name="c6" size="0.1" condim="6" friction="1 0.01 0.001"/></body>
      <body pos="3 0 0.1"><freejoint/>
        <geom name="p" size="0.1" condim="6" priority="1" friction="0.5 0.02 0.001"/></body>
      <body pos="4 0 0.1"><freejoint/><geom name="q" size="0.1"/></body>
      </worldbody><contact>
        <pair geom1="q" geom2="floor" condim="4" friction="0.4 0.4 0.07 0.003 0.003"/>
      </contact></mujoco>""", "angular_friction")
    names = model.geom_names
    pairs = candidate_pairs(model)
    got = {tuple(sorted((names[a], names[b]))): mu
           for (a, b), mu in zip(pairs, pair_friction(model, pairs).tolist())}
    assert got[("c3", "floor")] == pytest.approx([-1.0, 0.0, 0.0])       # condim 3
    assert got[("c4", "floor")] == pytest.approx([-1.0, 0.03, 0.0])      # larger; no rolling
    assert got[("c6", "floor")] == pytest.approx([-1.0, 0.03, 0.002])
    assert got[("floor", "p")] == pytest.approx([-1.0, 0.02, 0.001])     # priority 1 wins
    assert got[("floor", "q")] == pytest.approx([0.4, 0.07, 0.0])        # the pair, condim 4
    assert got[("c4", "c6")] == pytest.approx([-1.0, 0.01, 0.01])


def _ball_on_table(pair: str) -> myriad.Model:
    """A 5 cm ball touching the top of a static table whose contype/conaffinity keep them
    apart (2 & 1 = 0), and no floor: only the <pair> (if any) holds the ball up."""
    return myriad.load_xml(f"""<mujoco><worldbody>
      <geom name="table" type="box" size="0.3 0.3 0.05" contype="2" conaffinity="2"/>
      <body name="ball" pos="0 0 0.1"><freejoint/>
        <geom name="ball" size="0.05" mass="0.5" contype="1" conaffinity="1"/></body>
      </worldbody><contact>{pair}</contact></mujoco>""", "ball_on_table")


def test_an_explicit_pair_collides_geoms_their_contype_keeps_apart(device):
    params = myriad.SimParams(dt=1 / 60, substeps=2)
    held = myriad.Simulator(_ball_on_table('<pair geom1="table" geom2="ball"/>'), num_envs=2,
                            device=device, params=params)
    fell = myriad.Simulator(_ball_on_table(""), num_envs=2, device=device, params=params)
    for _ in range(60):
        held.step()
        fell.step()
    # held: on the table within 2 mm after 1 s, at rest; without the pair: 1 s of free fall
    torch.testing.assert_close(held.q[:, 2].cpu(), torch.full((2,), 0.1), atol=2e-3, rtol=0)
    assert held.qd.abs().max() < 0.02
    assert held.contact_count.min() >= 1 and fell.contact_count.max() == 0
    assert fell.q[:, 2].max() < 0.1 - 0.5 * 9.81 * 0.9 ** 2


def _incline_xml(condim_incline: int, condim_box: int, deg: float = 20.0, contact: str = "") -> str:
    th = math.radians(deg)
    quat = f"{math.cos(th / 2)} {math.sin(th / 2)} 0 0"      # the slope descends toward -y
    pos = " ".join(f"{x:.6f}" for x in np.array([0.0, -math.sin(th), math.cos(th)]) * 0.1)
    return f"""<mujoco><worldbody>
      <geom name="incline" type="plane" size="20 20 0.1" quat="{quat}" friction="1 0 0"
            condim="{condim_incline}"/>
      <body name="box" pos="{pos}" quat="{quat}"><freejoint/>
        <geom name="box" type="box" size="0.1 0.1 0.1" mass="1" friction="1 0 0"
              condim="{condim_box}"/></body>
      </worldbody><contact>{contact}</contact></mujoco>"""


def _box_on_paired_incline(pair: str, deg: float = 20.0) -> myriad.Model:
    """A 20 cm box (friction 1, as the incline's) resting on a plane tilted by `deg` about x,
    the two named by `pair` (the filters make them a pair too: the <pair> replaces it)."""
    return myriad.load_xml(_incline_xml(3, 3, deg, pair.format(g1="incline", g2="box")),
                           "paired_incline")


def test_two_condim_1_geoms_touch_without_friction(device):
    """MuJoCo's contact takes the larger condim of its two geoms: frictionless only if both
    have condim 1. The box slides down the 20° incline at g sin 20° within 5%; with one of the
    two at condim 3 it sticks (both geoms have friction 1)."""
    th, g, dt = math.radians(20.0), 9.81, 1 / 60
    for condims, slides in (((1, 1), True), ((1, 3), False)):
        model = myriad.load_xml(_incline_xml(*condims), "condim_incline")
        sim = myriad.Simulator(model, num_envs=1, device=device, params=ISAAC_PARAMS)
        speeds = []
        for _ in range(60):
            sim.step()
            speeds.append(sim.qd[0, :3].norm().item())
        if slides:
            assert (speeds[59] - speeds[14]) / (45 * dt) == pytest.approx(g * math.sin(th),
                                                                          rel=0.05)
        else:
            assert speeds[59] < 1e-2


@pytest.mark.parametrize("pair, mu", [
    ('<pair geom1="{g1}" geom2="{g2}" condim="1"/>', 0.0),        # frictionless: slides
    ('<pair geom1="{g1}" geom2="{g2}" condim="3" friction="0.2 0.005 0.0001"/>', 0.2),
    ('<pair geom1="{g1}" geom2="{g2}" condim="3" friction="1 0.005 0.0001"/>', 1.0),  # sticks
])
def test_a_pair_sets_the_friction_of_its_contacts(pair, mu, device):
    """A box on a 20° incline, both geoms with friction 1 (which alone would hold it): the
    pair's friction decides. It slides at g·(sin 20° - mu·cos 20°) within 5% where tan 20° =
    0.36 > mu, and stays put within 0.1 mm where mu = 1."""
    th, g, dt = math.radians(20.0), 9.81, 1 / 60
    sim = myriad.Simulator(_box_on_paired_incline(pair), num_envs=1, device=device,
                           params=ISAAC_PARAMS)
    speeds, positions = [], []
    for _ in range(60):
        sim.step()
        speeds.append(sim.qd[0, :3].norm().item())
        positions.append(sim.q[0, :3].clone())
    if mu < math.tan(th):
        accel = (speeds[59] - speeds[14]) / (45 * dt)           # from 0.25 s to 1 s
        assert accel == pytest.approx(g * (math.sin(th) - mu * math.cos(th)), rel=0.05)
    else:
        assert (positions[59] - positions[29]).norm().item() < 1e-4
        assert speeds[59] < 1e-2


@pytest.mark.parametrize("slots_of_found", [3, 5])
def test_the_gpus_collision_path_keeps_the_cpus_contacts_whatever_its_atomics_did(
        slots_of_found):
    """A GPU finds contacts by a thread per (env, pair), taking places through an atomic
    counter. Here that path runs on the CPU, its places then filled with junk in a count past
    them (any order the atomics could have left): an env within its places is put in the
    pairs' order (`order_by_pair`), one past them is walked again pair by pair
    (`redo_overflowed`); either way the kept contacts are the CPU path's, contact for contact.
    With 1/3 of the contacts found in slots the places (4 per slot) hold them all; with 1/5
    they overflow."""
    model = myriad.load_xml(_scene(0), "scene0")
    probe = myriad.Simulator(model, num_envs=1, params=myriad.SimParams(contact_offset=MARGIN))
    probe.collide()
    slots = int(probe.contact_count[0]) // slots_of_found
    params = myriad.SimParams(contact_offset=MARGIN, contacts_per_env=slots)
    cpu, gpu_path = (myriad.Simulator(model, num_envs=3, params=params, cpu_threads=1)
                     for _ in range(2))
    cpu.collide()
    rt, dm, c = gpu_path.runtime, gpu_path.device_model, gpu_path.data.contacts
    inputs = [dm.m, dm.opt, dm.pairs, gpu_path.data.env_params, dm.meshes, dm.hfields,
              gpu_path.data.state, c]
    rt.launch(collision.geom_frames, (3, model.ngeom),
              [dm.m, gpu_path.data.env_params, dm.meshes, gpu_path.data.state])
    c.count.zero_()
    rt.launch(collision.narrowphase, (3, dm.pairs.shape[0]), inputs)
    places = c.geom.shape[1]
    found = c.count.numpy().copy()
    assert (found > places).all() == (slots_of_found == 5)
    if (found > places).all():     # whatever the atomics left in the places
        for name in ("geom", "key", "pos", "normal", "dist"):
            array = getattr(c, name)
            array.assign(np.random.default_rng(0).permutation(array.numpy(), axis=1))
    else:                          # pairs in reverse, each pair's own contacts in their order
        order = np.argsort(-(c.key.numpy()[:, :found[0]] >> 5), axis=1, kind="stable")
        assert not (order == np.arange(found[0])).all()
        for name in ("geom", "key", "pos", "normal", "dist"):
            array = getattr(c, name)
            value = array.numpy()
            for e in range(3):
                value[e, :found[e]] = value[e, order[e]]
            array.assign(value)
    rt.launch(collision.redo_overflowed, 3, inputs)
    rt.launch(collision.order_by_pair, 3, [c])
    rt.launch(collision.keep_deepest, 3, [c])
    assert torch.equal(gpu_path.contact_count, cpu.contact_count)
    for name in ("geom", "key", "pos", "normal", "dist"):
        np.testing.assert_array_equal(getattr(c, name).numpy()[:, :slots],
                                      getattr(cpu.data.contacts, name).numpy()[:, :slots],
                                      err_msg=name)


def test_a_body_and_its_grandparent_collide_only_when_asked():
    """SimParams.filter_ancestors: 2 (the default) skips a body's grandparent as well as its
    parent; 1 keeps MuJoCo's and PhysX's parent-only filter (the tasks' and Isaac Gym's)."""
    model = myriad.load_xml("""<mujoco><worldbody><body name="a"><freejoint/>
      <geom name="ga" type="sphere" size="0.1"/>
      <body name="b" pos="0.3 0 0"><joint type="hinge"/><geom name="gb" type="sphere" size="0.1"/>
        <body name="c" pos="0.3 0 0"><joint type="hinge"/><geom name="gc" type="sphere" size="0.1"/>
          <body name="d" pos="0.3 0 0"><joint type="hinge"/><geom name="gd" type="sphere" size="0.1"/>
      </body></body></body></body></worldbody></mujoco>""", "chain")
    g = {name: model.geom_names.index(name) for name in ("ga", "gb", "gc", "gd")}

    def pairs(ancestors):
        return {tuple(sorted(p)) for p in candidate_pairs(model, True, ancestors).tolist()}
    assert pairs(1) == {tuple(sorted((g[x], g[y]))) for x, y in
                        (("ga", "gc"), ("ga", "gd"), ("gb", "gd"))}
    assert pairs(2) == {tuple(sorted((g["ga"], g["gd"])))}
    assert myriad.SimParams().filter_ancestors == 2
    with pytest.raises(ValueError, match="filter_ancestors"):
        myriad.SimParams(filter_ancestors=0)
