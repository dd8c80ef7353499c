"""AnymalTerrain (tasks/anymal_terrain.py): the observation layout and its terrain heights, the
reward terms on set states, the curriculum and pushes in the task, and the physics the rough
terrain must hold: the robot stands on every kind of tile, and its feet do not sink into step
edges (reference task-specs §6)."""

import importlib.util
import json
import math

import numpy as np
import pytest
import torch

import myriad
from myriad.tasks.anymal_terrain import compute_anymal_terrain_reward
from myriad.tasks.terrain import KINDS, column_kind

pytestmark = pytest.mark.skipif(importlib.util.find_spec("cmeel") is None,
                                reason="ANYmal needs example-robot-data (pip install .[anymal])")

DT = 0.02


def make(device, num_envs=4, **overrides):
    return myriad.make("AnymalTerrain", num_envs=num_envs, device=device,
                       **{"env.learn.addNoise": False, **overrides})


def place(task, levels, kinds, offset=(0.0, 0.0), height=0.62):
    """Put env i's robot on tile (levels[i], kinds[i]) at its start point + offset, standing in
    the default pose, at rest."""
    dev = task.device
    task.levels[:] = torch.as_tensor(levels, device=dev)
    task.kinds[:] = torch.as_tensor(kinds, device=dev)
    task.env_origins[:] = task.tile_origins[task.levels, task.kinds]
    states = task.envs.root_states.clone()
    states[:, 0] = 0.0
    states[:, 0, :3] = task.env_origins + torch.tensor([*offset, height], device=dev)
    states[:, 0, 6] = 1.0
    task.envs.set_root_states(states, forward=False)
    n = task.num_envs
    task.envs.set_dof_state(task.default_dof_pos.expand(n, -1).clone(),
                            torch.zeros(n, 12, device=dev))


def test_observation_layout_and_terrain_heights(device):
    task = make(device, num_envs=2)
    assert task.obs_buf.shape == (2, 188) and task.num_actions == 12
    # env 0 on a stairs-up tile off its platform (over the steps), turned 30° about z
    stairs = next(j for j in range(20) if column_kind(j, task.terrain_config)[0] == 3)
    place(task, [6, 6], [stairs, 0], offset=(2.1, 0.6))
    e = task.envs
    states = e.root_states.clone()
    yaw = math.radians(30)
    states[:, 0, 3:7] = torch.tensor([0, 0, math.sin(yaw / 2), math.cos(yaw / 2)])
    states[:, 0, 7:10] = torch.tensor([0.5, -0.2, 0.1])
    states[:, 0, 10:13] = torch.tensor([0.0, 0.0, 0.4])
    e.set_root_states(states)
    task.commands[:] = torch.tensor([0.6, -0.3, 0.2], device=task.device)
    task.actions[:] = 0.25
    task.compute_observations()
    obs = task.obs_buf.cpu().clone()
    c, s = math.cos(yaw), math.sin(yaw)
    v_body = [0.5 * c - 0.2 * s, -0.5 * s - 0.2 * c, 0.1]    # world velocity in the base frame
    np.testing.assert_allclose(obs[0, 0:3], np.array(v_body) * 2, atol=1e-5)
    np.testing.assert_allclose(obs[0, 3:6], [0, 0, 0.4 * 0.25], atol=1e-5)
    np.testing.assert_allclose(obs[0, 6:9], [0, 0, -1], atol=1e-5)
    np.testing.assert_allclose(obs[0, 9:12], [1.2, -0.6, 0.05], atol=1e-6)
    np.testing.assert_allclose(obs[:, 12:24], e.dof_pos.cpu(), atol=1e-6)    # raw angles
    np.testing.assert_allclose(obs[:, 24:36], e.dof_vel.cpu() * 0.05, atol=1e-6)
    np.testing.assert_allclose(obs[:, 176:188], 0.25)
    # the 140 heights: the generator's samples under the points, turned with the base's yaw
    # (the lower of the grid samples (⌊i⌋, ⌊j⌋), (⌊i⌋+1, ⌊j⌋+1), as the original reads them)
    cfg, raw = task.terrain_config, task.terrain.raw
    xs = [-0.8, -0.7, -0.6, -0.5, -0.4, -0.3, -0.2, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8]
    ys = [-0.5, -0.4, -0.3, -0.2, -0.1, 0.1, 0.2, 0.3, 0.4, 0.5]
    base = e.root_states[0, 0, :3].cpu().numpy()
    expected = []
    for x in xs:
        for y in ys:
            wx, wy = base[0] + c * x - s * y, base[1] + s * x + c * y
            i, j = int((wx + cfg.border) / 0.1), int((wy + cfg.border) / 0.1)
            h = min(raw[i, j], raw[i + 1, j + 1]) * cfg.vertical_scale
            expected.append(np.clip(base[2] - 0.5 - h, -1, 1) * 5)
    np.testing.assert_allclose(obs[0, 36:176], expected, atol=1e-4)
    assert np.ptp(expected) > 1.0, "the points straddle steps: the test reads a rough patch"
    # with the original's noise on, each entry moves by at most its band: ±0.2 m/s × 2 on the
    # velocities, ±0.3 m × 5 on the heights, none on the commands and actions
    bands = make(device, num_envs=2, **{"env.learn.addNoise": True}).noise_scale.cpu()
    assert bands[0:3].max() == pytest.approx(0.4) and bands[36:176].max() == pytest.approx(1.5)
    assert bands[9:12].abs().max() == 0 and bands[176:].abs().max() == 0
    task.noise_scale = bands.to(task.device)
    task.compute_observations()
    noise = task.obs_buf.cpu() - obs
    assert (noise.abs() <= bands + 1e-6).all() and noise[:, 36:176].abs().max() > 0.5


def test_reward_terms_on_set_states():
    scales = {k: v * DT for k, v in myriad.tasks.task_config("AnymalTerrain")["env"]["learn"]
              .items() if k.endswith("RewardScale")}
    n = 6
    base = torch.zeros(n, 13)
    base[:, 6] = 1.0
    commands = torch.zeros(n, 3)
    zeros12 = torch.zeros(n, 12)
    contacts = torch.zeros(n, 20, 3)
    knees, base_body = torch.tensor([3, 7, 11, 15]), 0
    air = torch.zeros(n, 4)
    first = torch.zeros(n, 4, dtype=torch.bool)
    # env 0: standing, commanded to stand: both tracking terms in full
    # env 1: commanded 1 m/s forward, standing: lin term exp(-1/0.25), and falling 0.5 m/s
    commands[1, 0] = 1.0
    base[1, 9] = -0.5
    # env 2: two knees touching; env 3: foot lands after 0.8 s in the air while commanded
    contacts[2, knees[:2], 2] = 5.0
    commands[3, 0] = 0.5
    base[3, 7] = 0.5
    air[3, 0] = 0.8
    first[3, 0] = True
    # env 4: base touches the ground (terminates); env 5: a jerky action and joint velocity
    contacts[4, base_body, 2] = 3.0
    actions = zeros12.clone()
    actions[5, 0] = 1.0
    dof_vel = zeros12.clone()
    dof_vel[5, 1] = 2.0
    torques = zeros12.clone()
    torques[5, 2] = 10.0
    reward, terminated = compute_anymal_terrain_reward(
        base, commands, torques, dof_vel, zeros12, actions, zeros12, contacts, base_body, knees,
        air, first, scales)
    track = 1.0 * DT + 0.5 * DT
    expected = [
        track,
        max(0.0, math.exp(-1 / 0.25) * DT + 0.5 * DT - 4 * 0.25 * DT),
        track - 2 * 0.25 * DT,
        track + (0.8 - 0.5) * 1.0 * DT,
        track,
        track - 2e-5 * 100 * DT - 5e-4 * 4 * DT - 0.01 * 1 * DT,
    ]
    np.testing.assert_allclose(reward, expected, rtol=1e-5, atol=1e-7)
    assert terminated.tolist() == [False, False, False, False, True, False]
    # the sum is clipped at 0: a large torque cost gives 0, not a negative reward
    torques[0] = 80.0
    reward, _ = compute_anymal_terrain_reward(
        base, commands, torques, dof_vel, zeros12, actions, zeros12, contacts, base_body, knees,
        air, first, scales)
    assert reward[0] == 0.0
    # air time counts only while a move is commanded
    commands[3, :2] = 0.0
    base[3, 7] = 0.0
    reward, _ = compute_anymal_terrain_reward(
        base, commands, torques * 0, dof_vel * 0, zeros12, zeros12, zeros12, contacts, base_body,
        knees, air, first, scales)
    assert reward[3].item() == pytest.approx(track, rel=1e-5)


def test_curriculum_pushes_and_friction_in_the_task(device):
    task = make(device, num_envs=4)
    assert task.levels.tolist() == [0, 0, 0, 0]       # everyone starts at level 0
    place(task, [2, 2, 0, 9], [0, 5, 10, 19])
    # env 0 walked 5 m (off its tile): up; env 1 stood with a command: down; env 2 stood at
    # level 0 with a command: stays at 0; env 3 walked off the top level: back to 0
    states = task.envs.root_states.clone()
    states[[0, 3], 0, 0] += 5.0
    task.envs.set_root_states(states)
    task.commands[:] = torch.tensor([0.8, 0.0, 0.0], device=task.device)
    task.reset_idx(torch.ones(4, dtype=torch.bool, device=task.device))
    assert task.levels.tolist() == [3, 1, 0, 0]
    # the verdicts, kept for `myriad eval`: the curriculum moved env 2 down, to the floor
    assert task.episode_outcomes["level_up"].tolist() == [True, False, False, True]
    assert task.episode_outcomes["level_down"].tolist() == [False, True, True, False]
    assert task.metrics()["terrain_level"] == pytest.approx(1.0)
    np.testing.assert_allclose(task.env_origins.cpu(),
                               task.tile_origins[task.levels, task.kinds].cpu())
    start = task.envs.root_states[:, 0, :3] - task.env_origins
    assert start[:, :2].abs().max() <= 0.5 and torch.allclose(start[:, 2], torch.tensor(0.62))
    # commands: slower than 0.25 m/s are zeroed with their heading
    speed = task.commands[:, :2].norm(dim=-1)
    assert ((speed == 0) | (speed > 0.25)).all()
    # a push every 15 s sets every base's horizontal velocity
    task.steps_taken.fill_(task.push_every - 1)
    before = task.envs.root_states[:, 0, 7:9].clone()
    task.step(torch.zeros(4, 12, device=task.device))
    after = task.envs.root_states[:, 0, 7:9]
    assert (after - before).abs().max() > 0.05
    # friction: env i takes bucket i mod 100, inside [0.5, 1.25]; the terrain keeps 1
    many = make(device, num_envs=101)
    friction = many.envs.sim.geom_friction.cpu()
    terrain = many.envs.model.geom_names.index("terrain")
    robot = [g for g in range(friction.shape[1]) if g != terrain]
    assert friction[:, robot].min() >= 0.5 and friction[:, robot].max() <= 1.25
    assert torch.equal(friction[0, robot], friction[100, robot])
    assert friction[:, robot].std() > 0.1 and (friction[:, terrain] == 1.0).all()


def test_the_penalty_curriculum_scales_the_costs_only():
    """k = start^(decay^(steps / 24)) multiplies the terms with a negative scale; the tracking
    and air-time terms keep theirs; start 1 (the task's config, the original) leaves all alone."""
    plain = make("cpu", num_envs=2)
    assert float(plain.penalty_factor()) == 1.0 and "penalty_factor" not in plain.metrics()
    assert plain.scaled_rewards() == plain.reward_scales
    task = make("cpu", num_envs=2, **{"env.penaltyCurriculum.start": 0.3})
    assert float(task.penalty_factor()) == pytest.approx(0.3)
    task.steps_taken.fill_(24 * 1000)
    k = 0.3 ** (0.997 ** 1000)
    assert float(task.penalty_factor()) == pytest.approx(k) and 0.94 < k < 0.95
    assert task.metrics()["penalty_factor"] == pytest.approx(k)
    scaled = task.scaled_rewards()
    assert float(scaled["linearVelocityZRewardScale"]) == pytest.approx(-4.0 * DT * k)
    assert float(scaled["torqueRewardScale"]) == pytest.approx(-2e-5 * DT * k)
    assert scaled["linearVelocityXYRewardScale"] == pytest.approx(1.0 * DT)
    assert scaled["feetAirTimeRewardScale"] == pytest.approx(1.0 * DT)
    with pytest.raises(ValueError, match="penaltyCurriculum.start=0"):
        make("cpu", num_envs=2, **{"env.penaltyCurriculum.start": 0.0})


# the terrain as the original's triangle mesh (`env.terrain.mesh`), on a grid cut to the levels
# and columns the tests use (7 levels, 10 columns: every kind; a 2 m border): 1 M triangles
AS_MESH = {"env.terrain.mesh": True, "env.terrain.levels": 7, "env.terrain.types": 10,
           "env.terrain.border": 2.0}


@pytest.mark.parametrize("surface", ["height field", "mesh"])
def test_the_robot_stands_on_every_kind_of_tile(device, surface):
    """Zero actions (PD to the default pose) on each kind of tile at level 6: once settled, the
    base stays up and within 1 cm for 10 s, and no base touches the ground; on the height field
    with risers and on the original's triangle mesh alike."""
    task = make(device, num_envs=len(KINDS), pushInterval_s=1000,
                **(AS_MESH if surface == "mesh" else {}))
    kinds_in = task.terrain_config.types
    kinds = [next(j for j in range(kinds_in) if column_kind(j, task.terrain_config)[0] == k)
             for k in range(len(KINDS))]
    place(task, [6] * len(kinds), kinds)
    for _ in range(300):                # 6 s to drop onto the legs and settle (on the rough
        # tile the start point is a bump of the noise, and the feet find the dips around it)
        task.step(torch.zeros(len(kinds), 12, device=task.device))
    settled = task.envs.root_states[:, 0, :3].clone()
    for _ in range(500):                # 10 s
        _, _, done, _ = task.step(torch.zeros(len(kinds), 12, device=task.device))
        assert not done.any(), "a base touched the ground"
    moved = (task.envs.root_states[:, 0, :3] - settled).norm(dim=-1)
    assert moved.max() < 0.01, moved
    height = task.envs.root_states[:, 0, 2] - task.env_origins[:, 2]
    assert height.min() > 0.3, height       # standing: 0.51 on flat ground


@pytest.mark.parametrize("surface", ["height field", "mesh"])
def test_friction_is_drawn_for_every_robot_geom_and_not_for_the_terrain(device, surface):
    """frictionRange applies to all of the robot's geoms, its base's too; the terrain keeps
    staticFriction (the mesh, named triangle_mesh0, once got the robot's draw)."""
    task = make(device, num_envs=2, **{"env.frictionRange": [0.7, 0.7]},
                **(AS_MESH if surface == "mesh" else {}))
    body = torch.as_tensor(task.envs.model.geom_body)
    friction = task.envs.sim.geom_friction.cpu()
    assert (body == 0).any() and torch.allclose(friction[:, body >= 0], torch.tensor(0.7))
    assert torch.allclose(friction[:, body < 0], torch.tensor(1.0))


def test_the_robot_slides_but_is_not_thrown_on_the_slippery_rough_mesh(device):
    """Zero actions on the rough slope at level 6 of the original's triangle mesh, everything
    at friction 0.5: the robot lands, crouches and slides down (0.4 m/s at most), and is never
    thrown. The mesh's folds (vertices moved under their neighbours) once had a shank taken to
    be 16 cm deep above one: it left at 11 m/s."""
    task = make(device, num_envs=1, pushInterval_s=1000, **AS_MESH,
                **{"env.terrain.staticFriction": 0.5, "env.frictionRange": [0.5, 0.5]})
    rough = next(j for j in range(task.terrain_config.types)
                 if KINDS[column_kind(j, task.terrain_config)[0]] == "rough slope")
    place(task, [6], [rough])
    fastest = 0.0
    for step in range(100):
        task.step(torch.zeros(1, 12, device=task.device))
        if step >= 30:              # landed (1.8 m/s as the legs meet the ground)
            fastest = max(fastest, float(task.envs.root_states[0, 0, 7:10].norm()))
    assert fastest < 1.0, fastest


def _penetration(centres, radius, raw, cfg):
    """How deep spheres [n, 3] reach into the stepped terrain (m): cells as columns, each at its
    lowest corner's height (on stairs every cell is flat or one step), the vertical walls
    between them; the exact distance to the union of the columns around each centre."""
    worst = []
    for c in centres:
        i0, j0 = int((c[0] + cfg.border) / 0.1), int((c[1] + cfg.border) / 0.1)
        signed = np.inf
        for i in range(i0 - 1, i0 + 2):
            for j in range(j0 - 1, j0 + 2):
                top = raw[i:i + 2, j:j + 2].min() * cfg.vertical_scale
                lo = np.array([i * 0.1 - cfg.border, j * 0.1 - cfg.border, -np.inf])
                hi = np.array([lo[0] + 0.1, lo[1] + 0.1, top])
                outside = np.maximum(np.maximum(lo - c, c - hi), 0.0)
                inside = np.min(np.minimum(c - lo, hi - c))
                signed = min(signed, np.linalg.norm(outside) if outside.any() else -inside)
        worst.append(radius - signed)
    return max(worst)


@pytest.mark.parametrize("surface", ["height field", "mesh"])
def test_feet_do_not_sink_into_step_edges(device, surface):
    """Six robots on the stairs of a stairs-up tile (0.155 m steps at level 6), set down across
    one 0.3 m step at 0.1 m intervals, under random actions for 1.5 s: they stumble over the
    step edges, feet pressing on the risers (horizontal contacts), and most topple down the
    stairs. Until its robot falls (its episode ends), no foot sphere reaches deeper than 1 cm
    into the stepped terrain (vertical risers): the height field's risers and the original's
    mesh (its walls' vertices moved under the step tops) alike."""
    torch.manual_seed(0)
    task = make(device, num_envs=6, pushInterval_s=1000,
                **(AS_MESH if surface == "mesh" else {}))
    stairs = next(j for j in range(task.terrain_config.types)
                  if column_kind(j, task.terrain_config)[0] == 3)
    place(task, [6] * 6, [stairs] * 6)
    states = task.envs.root_states.clone()
    states[:, 0, 0] += torch.tensor([-3.3, -3.2, -3.1, -3.0, -2.9, -2.8], device=task.device)
    # 0.62 m above the highest point under the robot: no foot starts inside a step
    heights = torch.as_tensor(task.terrain.heights)
    cells = ((states[:, 0, :2].cpu() + task.terrain_config.border) / 0.1).long()
    states[:, 0, 2] = torch.stack([heights[i - 6:i + 7, j - 4:j + 5].max()
                                   for i, j in cells.tolist()]).to(task.device) + 0.62
    task.envs.set_root_states(states)
    sim = task.envs.sim
    generator = torch.Generator(device=task.device).manual_seed(0)
    standing = torch.ones(6, dtype=torch.bool, device=task.device)
    deepest, riser_contacts = 0.0, 0
    for k in range(75):
        actions = torch.rand(6, 12, generator=generator, device=task.device) * 2 - 1
        task.step(actions * 0.5)
        standing &= task.progress_buf == k + 1
        feet = _foot_centres(task).reshape(6, 4, 3)[standing.cpu().numpy()]
        if len(feet):
            deepest = max(deepest, _penetration(feet.reshape(-1, 3), 0.03, task.terrain.raw,
                                                task.terrain_config))
        used = torch.arange(sim.contact_dist.shape[1], device=task.device) \
            < sim.contact_count[:, None]
        sideways = used & (sim.contact_normal[..., 2].abs() < 0.5) & (sim.contact_dist < 0.005)
        riser_contacts += int((sideways & standing[:, None]).sum())
    assert riser_contacts > 20, "the scenario must press feet on the risers"
    assert deepest < 0.01, deepest


def _foot_centres(task):
    """World centres of the four foot spheres [4·N, 3] (a sphere geom on each SHANK body)."""
    from myriad.torch_utils import quat_rotate

    e, m = task.envs, task.envs.model
    geoms = [g for g in range(len(m.geom_names)) if m.geom_type[g] == 2
             and "SHANK" in m.body_names[m.geom_body[g]]]
    assert len(geoms) == 4
    body = e.rigid_body_states[:, m.geom_body[geoms]]
    local = torch.as_tensor(m.geom_pos[geoms], dtype=torch.float32, device=task.device)
    centres = body[..., :3] + quat_rotate(body[..., 3:7], local.expand(e.num_envs, -1, -1))
    return centres.reshape(-1, 3).cpu().numpy()


def test_training_smoke_run_reports_the_terrain_level_and_resumes_its_curricula(tmp_path):
    """Two epochs, then a resume from a checkpoint whose task state says level 3 and 100
    batches of the cost curriculum: the run goes on from there, not from level 0 and k = 0.3;
    so does a fine-tune from that checkpoint shipped."""
    from myriad import cli

    args = ["train", "task=AnymalTerrain", "num_envs=16", f"train_dir={tmp_path}",
            "experiment=terrain", "train.params.config.minibatch_size=64",
            "task.env.penaltyCurriculum.start=0.3"]
    assert cli.main([*args, "max_iterations=2"]) == 0
    summary = json.loads((tmp_path / "terrain" / "summary.json").read_text())
    assert summary["epochs"] == 2 and summary["env_steps"] == 16 * 24 * 2
    assert 0.0 <= summary["terrain_level"] <= 9.0
    assert summary["penalty_factor"] == pytest.approx(0.3 ** (0.997 ** 2), abs=1e-4)
    last = tmp_path / "terrain" / "nn" / "last.pth"
    state = torch.load(last, weights_only=False, map_location="cpu")
    kept = state["myriad"]["task"]
    assert kept["steps_taken"] == 48 and kept["levels"].shape == (16, )
    kept["steps_taken"], kept["levels"] = 2400, torch.full((16, ), 3)
    torch.save(state, last)
    assert cli.main([*args, "max_iterations=3", "resume=auto"]) == 0
    summary = json.loads((tmp_path / "terrain" / "summary.json").read_text())
    assert summary["penalty_factor"] == pytest.approx(0.3 ** (0.997 ** 101), abs=1e-4)
    # 24 steps of a 1000-step episode: only robots that fell moved, one level down
    assert 2.0 <= summary["terrain_level"] <= 3.0
    # a shipped policy keeps the task state too: fine-tuning from it (a fresh optimizer, epoch
    # 0) goes on at its levels and cost factor
    from myriad.rl import shipped
    policy = tmp_path / "policy.pth"
    torch.save(shipped.stripped(state, fp16=False), policy)
    tune = [a.replace("experiment=terrain", "experiment=tuned") for a in args]
    assert cli.main([*tune, "max_iterations=1", f"checkpoint={policy}"]) == 0
    summary = json.loads((tmp_path / "tuned" / "summary.json").read_text())
    assert summary["epochs"] == 1
    assert summary["penalty_factor"] == pytest.approx(0.3 ** (0.997 ** 101), abs=1e-4)
    assert 2.0 <= summary["terrain_level"] <= 3.0
    # a checkpoint of another env count is refused, naming what does not fit
    task = make("cpu", num_envs=4)
    with pytest.raises(ValueError, match=r"levels has shape \(16,\)"):
        task.load_training_state(kept)


def test_the_robot_collides_as_the_originals_minimal_anymal():
    """The original loads anymal_minimal.urdf for this task, cylinders as capsules: the body, a
    knee drive per thigh and a sphere per foot are all that touch anything, so shanks and thighs
    pass over step edges a fuller model would catch on. The flat task keeps anymal.urdf's
    shapes, without example-robot-data's knee guards and with capsules for cylinders."""
    import mujoco
    from myriad.assets import ANYMAL_LEGS, anymal_c_spec

    def shapes(model, body):
        b = model.body(body).id
        return sorted((mujoco.mjtGeom(model.geom_type[g]).name,
                       *np.round(model.geom_size[g][:2], 3))
                      for g in range(model.ngeom) if model.geom_bodyid[g] == b)

    task = make("cpu", num_envs=1)
    m = task.envs.model.mj_model
    robot = [g for g in range(m.ngeom) if m.body(m.geom_bodyid[g]).name.startswith("anymal/")]
    assert len(robot) == 9
    assert shapes(m, "anymal/base") == [("mjGEOM_CAPSULE", 0.1, 0.375)]
    for leg in ANYMAL_LEGS:
        assert shapes(m, f"anymal/{leg}_HIP") == []
        assert shapes(m, f"anymal/{leg}_THIGH") == [("mjGEOM_CAPSULE", 0.06, 0.06)]
        assert shapes(m, f"anymal/{leg}_SHANK") == [("mjGEOM_SPHERE", 0.03, 0.0)]
    flat = anymal_c_spec().compile()
    assert mujoco.mjtGeom.mjGEOM_CYLINDER not in flat.geom_type
    for leg in ANYMAL_LEGS:           # the shank's tube and its foot, no knee guard
        assert shapes(flat, f"{leg}_SHANK") == [("mjGEOM_CAPSULE", 0.018, 0.141),
                                                ("mjGEOM_SPHERE", 0.03, 0.0)]
    assert abs(sum(flat.body_mass) - sum(m.body_mass[[m.body(b).name.startswith("anymal/")
                                                       for b in range(m.nbody)]])) < 1e-9
