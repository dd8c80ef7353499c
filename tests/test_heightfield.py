"""Height-field risers (`Model.hfield_riser`, collision.heightfield): a steep cell of a coarse grid
is a vertical step, as Isaac Gym's terrain makes it, instead of MuJoCo's one-cell ramp.

The step grid: 0.1 m spacing along x and y, samples of column 12 and beyond 0.15 m high, the rest
at 0: with a riser the wall stands at x = 0.2 (column 12's grid line), without one the surface
ramps up over the cell 0.1 < x < 0.2. Isaac Gym's settings: dt 1/60, 2 substeps, TGS with 4
position and 1 velocity iteration.
"""

import numpy as np
import pytest
import torch

import myriad

pytestmark = pytest.mark.lanes   # also run with MYRIAD_CPU_BLOCK_DIM=32 (tests/test_lanes.py)

ISAAC = myriad.SimParams(dt=1 / 60, substeps=2, position_iterations=4, velocity_iterations=1)

STEP = 0.15           # m
WALL_X = 0.2          # the high samples' first grid line
R = 0.03              # a robot's foot
RISER = 0.05          # m: Isaac Gym's slope threshold 0.5 on this 0.1 m grid


def _grid(heights: np.ndarray, body: str, riser: float, spacing: float = 0.1) -> myriad.Model:
    """A height field of `heights` (m, lowest 0; row i at y = -half + i · spacing, column j at
    x = -half + j · spacing) centred at the origin, and `body`."""
    nrow, ncol = heights.shape
    top = heights.max() if heights.max() > 0 else 1.0
    # MJCF's elevation lists the rows from +y down, as an image's
    elevation = " ".join(f"{h / top:.6f}" for h in heights[::-1].ravel())
    size = f"{spacing * (ncol - 1) / 2} {spacing * (nrow - 1) / 2} {top} 0.1"
    model = myriad.load_xml(f"""<mujoco><asset><hfield name="terrain" nrow="{nrow}" ncol="{ncol}"
      size="{size}" elevation="{elevation}"/></asset><worldbody>
      <geom type="hfield" hfield="terrain"/>{body}</worldbody></mujoco>""", "terrain")
    assert model.hfield_riser.tolist() == [0.0]      # MuJoCo's surface unless asked
    model.hfield_riser[:] = riser
    return model


def _step_grid() -> np.ndarray:
    heights = np.zeros((5, 21))                  # x in [-1, 1], y in [-0.2, 0.2]
    heights[:, 12:] = STEP
    return heights


def _sphere(x: float, y: float, z: float, name: str = "foot") -> str:
    return (f'<body name="{name}" pos="{x} {y} {z}"><freejoint/>'
            f'<geom type="sphere" size="{R}" mass="0.2"/></body>')


def _depth_into_step(center: np.ndarray, radius: float) -> float:
    """Penetration of a sphere into the true stepped solid: the floor z < 0 and the block
    x > WALL_X, z < STEP (its vertical wall, its top and the edge between)."""
    x, z = center[0], center[2]
    floor = z
    out_x, out_z = max(WALL_X - x, 0.0), max(z - STEP, 0.0)
    block = np.hypot(out_x, out_z) if out_x > 0 or out_z > 0 else -min(x - WALL_X, STEP - z)
    return radius - min(floor, block)


def _contacts(sim, env: int = 0):
    n = int(sim.contact_count[env])
    return sim.contact_dist[env, :n].cpu().numpy(), sim.contact_normal[env, :n].cpu().numpy()


def test_riser_zero_or_above_every_rise_is_mujocos_surface(device):
    """On a rough grid, riser 0 (the importer's) and a riser above every height difference give
    the same contacts to the bit, for every kind of probe; on the step grid, riser 0 is the
    triangulated ramp: a sphere over the steep cell is measured along the ramp's normal."""
    rng = np.random.default_rng(3)
    heights = rng.uniform(0.0, 0.08, (7, 7))
    shapes = ['type="sphere" size="0.03"', 'type="capsule" size="0.03 0.06"',
              'type="box" size="0.05 0.04 0.03"', 'type="cylinder" size="0.04 0.03"']
    bodies = "".join(f'<body pos="{-0.2 + 0.13 * k} {0.1 - 0.07 * k} 0.07" euler="{20 * k} 10 0">'
                     f'<freejoint/><geom {g} mass="1"/></body>' for k, g in enumerate(shapes))
    found = []
    for riser in (0.0, 0.5):
        sim = myriad.Simulator(_grid(heights, bodies, riser), num_envs=1, device=device,
                               params=myriad.SimParams(contact_offset=0.1))
        sim.collide()
        found.append([t[0, :int(sim.contact_count[0])].cpu().numpy()
                      for t in (sim.contact_geom, sim.contact_pos, sim.contact_normal,
                                sim.contact_dist)])
    assert len(found[0][3]) >= 8
    for a, b in zip(*found):
        np.testing.assert_array_equal(a, b)

    z = 0.1                                      # over the ramp's middle (x = 0.15, height 0.075)
    sim = myriad.Simulator(_grid(_step_grid(), _sphere(0.15, 0.0, z), 0.0), num_envs=1,
                           device=device, params=myriad.SimParams(contact_offset=0.1))
    sim.collide()
    dist, normal = _contacts(sim)
    slope = STEP / 0.1
    assert dist == pytest.approx([(z - 0.075) / np.hypot(1.0, slope) - R], abs=1e-5)
    np.testing.assert_allclose(normal[0], np.array([-slope, 0.0, 1.0]) / np.hypot(1.0, slope),
                               atol=1e-5)


def test_riser_contacts_are_the_wall_its_top_edge_and_a_post(device):
    """The contacts of spheres held still, with a riser, against the exact stepped shapes: below
    the top the floor and the wall (horizontal); over the ledge the top edge; beside a single
    raised sample, its post (horizontal, from the sample's corner)."""
    heights = _step_grid()
    heights[0, 3] = STEP                         # a single high sample: a post at (-0.7, -0.2)
    bodies = (_sphere(0.15, 0.0, 0.06, "low") + _sphere(0.18, -0.1, STEP + 0.02, "ledge")
              + _sphere(-0.73, -0.16, 0.04, "post"))
    sim = myriad.Simulator(_grid(heights, bodies, riser=RISER), num_envs=1, device=device,
                           params=myriad.SimParams(contact_offset=0.1))
    sim.collide()
    dist, normal = _contacts(sim)
    pair = sim.contact_geom[0, :len(dist)].cpu().numpy()
    geom = np.where(pair[:, 0] == 0, pair[:, 1], -1)   # the spheres' contacts with the terrain
    # the low sphere: the flat floor (the cell's high corners lowered), then the wall 5 cm ahead
    np.testing.assert_allclose(dist[geom == 1], [0.06 - R, 0.05 - R], atol=1e-5)
    np.testing.assert_allclose(normal[geom == 1], [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]], atol=1e-5)
    # the ledge sphere (centre 2 cm before the wall, 2 cm above its top): the top edge only
    (d,), (n,) = dist[geom == 2], normal[geom == 2]
    assert d == pytest.approx(np.hypot(0.02, 0.02) - R, abs=1e-5)
    np.testing.assert_allclose(n, [-np.sqrt(0.5), 0.0, np.sqrt(0.5)], atol=1e-5)
    # the sphere beside the single sample: its floor and the post, 5 cm away diagonally
    np.testing.assert_allclose(dist[geom == 3], [0.04 - R, 0.05 - R], atol=1e-5)
    np.testing.assert_allclose(normal[geom == 3], [[0.0, 0.0, 1.0], [-0.6, 0.8, 0.0]], atol=1e-5)


def test_a_pushed_sphere_stops_at_a_riser_and_is_lifted_by_the_ramp_without_one(device):
    """A foot driven into a 0.15 m step on a 0.1 m grid: with a riser it stops against the wall
    and stays on the floor; on MuJoCo's surface (riser 0) the same push lifts it off the floor
    at the one-cell ramp, short of the step."""
    path = {}
    for riser in (RISER, 0.0):
        sim = myriad.Simulator(_grid(_step_grid(), _sphere(0.05, 0.0, R), riser), num_envs=1,
                               device=device, params=ISAAC)
        weight = 0.2 * 9.81
        force = torch.zeros_like(sim.body_force)
        centres = []
        for _ in range(120):
            push = 10.0 * (0.3 - sim.qd[0, 0].item())       # N per m/s below the drive speed
            force[0, 0, 0] = min(max(push, -3.0 * weight), 3.0 * weight)
            sim.body_force = force
            sim.step()
            centres.append(sim.q[0, :3].cpu().numpy().copy())
        path[riser] = np.asarray(centres)
    wall = path[RISER]
    assert wall[:, 0].max() <= WALL_X - R + 2e-3          # stopped at the wall
    assert wall[-1, 0] >= WALL_X - R - 2e-3               # against it, not bounced off
    assert wall[:, 2].max() < R + 5e-3                    # on the floor: did not climb
    # MuJoCo's surface: the centre's probe meets the ramp only past the crease, at x = 0.1; the
    # ramp's normal there throws the foot back and up, and it hangs on the crease a centimetre
    # off the floor, short of the step (the behaviour the risers remove)
    ramp = path[0.0]
    assert ramp[:, 0].max() < WALL_X - R - 0.05 and ramp[:, 2].max() > R + 5e-3


def test_spheres_rest_on_the_ledge_and_against_the_riser(device):
    """One sphere on the step's top, its centre 1 cm from the edge (overhanging it), one on the
    floor touching the riser, one capsule lying along the riser: all rest, within 1 cm of the
    true stepped shape."""
    capsule = (f'<body name="capsule" pos="{WALL_X - R - 1e-3} 0.1 {R}" euler="90 0 0">'
               f'<freejoint/><geom type="capsule" size="{R} 0.04" mass="0.3"/></body>')
    bodies = (_sphere(WALL_X + 0.01, -0.1, STEP + R, "ledge")
              + _sphere(WALL_X - R - 1e-3, 0.0, R, "floor") + capsule)
    sim = myriad.Simulator(_grid(_step_grid(), bodies, riser=RISER), num_envs=1, device=device,
                           params=ISAAC)
    speed, depth = [], []
    for _ in range(120):
        sim.step()
        speed.append(sim.qd[0].abs().max().item())
        q = sim.q[0].cpu().numpy()
        ends = [q[14:17] + s * np.array([0.0, 0.04, 0.0]) for s in (-1, 1)]   # capsule, ~level
        depth.append(max(_depth_into_step(c, R) for c in [q[0:3], q[7:10], *ends]))
    assert max(depth) < 1e-2
    assert max(speed[60:]) < 1e-2
    q = sim.q[0].cpu().numpy()
    assert q[0] == pytest.approx(WALL_X + 0.01, abs=2e-3)
    assert q[2] == pytest.approx(STEP + R, abs=2e-3)
    assert q[7] == pytest.approx(WALL_X - R, abs=3e-3) and q[9] == pytest.approx(R, abs=2e-3)
    assert q[14] == pytest.approx(WALL_X - R, abs=3e-3) and q[16] == pytest.approx(R, abs=2e-3)


def test_boxes_rest_on_a_stepped_grid(device):
    """Boxes (corner probes: the floor alone) on the plateau and on the floor against the riser,
    their corners over the steep cell: both rest at their floor's height with a riser."""
    boxes = (f'<body pos="0.55 0 {STEP + 0.06}"><freejoint/>'
             '<geom type="box" size="0.05 0.05 0.05" mass="1"/></body>'
             f'<body pos="{WALL_X - 0.055} 0 0.06"><freejoint/>'
             '<geom type="box" size="0.05 0.05 0.05" mass="1"/></body>')
    sim = myriad.Simulator(_grid(_step_grid(), boxes, riser=RISER), num_envs=1, device=device,
                           params=ISAAC)
    speed = []
    for _ in range(120):
        sim.step()
        speed.append(sim.qd[0].abs().max().item())
    q = sim.q[0].cpu().numpy()
    assert q[2] == pytest.approx(STEP + 0.05, abs=2e-3)
    assert q[7] == pytest.approx(WALL_X - 0.055, abs=2e-3)    # not thrown off the steep cell
    assert q[9] == pytest.approx(0.05, abs=2e-3)
    assert max(speed[60:]) < 1e-2
    np.testing.assert_allclose(np.abs(q[[3, 4, 5, 6, 10, 11, 12, 13]]), [0, 0, 0, 1] * 2,
                               atol=1e-2)
