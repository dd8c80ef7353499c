"""Domain randomization: distributions, operations, setup_only, frequency, schedules, noise,
random forces (A.4.1), and start-up errors."""

import math

import pytest
import torch

from myriad.randomization import RandomizationError, sample
from myriad.tasks import TASKS, task_config

N = 256


def ant_with(dr, num_envs=N, device="cpu", **env):
    cfg = task_config("Ant")
    cfg.pop("cpu")
    cfg["env"]["numEnvs"] = num_envs
    cfg["env"].update(env)
    cfg["randomization"] = {"enabled": True, **dr}
    return TASKS["Ant"](cfg, device=device)


def spec(dist, lo, hi, op="scaling", **extra):
    return {"range": [lo, hi], "distribution": dist, "operation": op, **extra}


def test_samplers_follow_their_distributions():
    """Fixed seed, 200k samples: moments and bounds of each distribution (tolerances ~5σ of the
    sampling error)."""
    torch.manual_seed(0)
    n = 200_000
    u = sample(spec("uniform", 0.5, 1.5), (n,), "cpu")
    assert u.min() >= 0.5 and u.max() <= 1.5
    assert abs(u.mean() - 1.0) < 5 * (1 / math.sqrt(12)) / math.sqrt(n)
    assert abs(u.var() - 1 / 12) < 2e-3
    g = sample(spec("gaussian", 0.2, 0.3, "additive"), (n,), "cpu")
    assert abs(g.mean() - 0.2) < 5 * 0.3 / math.sqrt(n) and abs(g.std() - 0.3) < 3e-3
    lu = sample(spec("loguniform", 0.3, 3.0), (n,), "cpu")
    assert lu.min() >= 0.3 and lu.max() <= 3.0
    logs = torch.log(lu)        # uniform in [log 0.3, log 3]
    width = math.log(3.0) - math.log(0.3)
    assert abs(logs.mean() - (math.log(0.3) + width / 2)) < 5 * width / math.sqrt(12 * n)
    # a Kolmogorov-Smirnov distance check on the log-uniform CDF
    x = torch.sort(logs).values
    cdf = (x - math.log(0.3)) / width
    ks = (cdf - torch.arange(1, n + 1) / n).abs().max()
    assert ks < 1.63 / math.sqrt(n)        # 99% critical value
    # a ramp of 0 means no change; 0.5 halves the spread around the identity
    assert torch.all(sample(spec("uniform", 0.5, 1.5), (10,), "cpu", ramp=0.0) == 1.0)
    half = sample(spec("uniform", 0.5, 1.5), (n,), "cpu", ramp=0.5)
    assert half.min() >= 0.75 and half.max() <= 1.25


def test_actor_and_sim_parameters_are_sampled_per_env_from_the_originals():
    torch.manual_seed(1)
    task = ant_with({"frequency": 1, "sim_params": {"gravity": spec("gaussian", 0, 0.4,
                                                                      "additive")},
                     "actor_params": {"ant": {
                         "rigid_body_properties": {"mass": spec("uniform", 0.5, 1.5)},
                         "rigid_shape_properties": {"friction": spec("uniform", 0.7, 1.3)},
                         "dof_properties": {
                             "damping": spec("loguniform", 0.3, 3.0),
                             "upper": spec("uniform", -0.1, 0.1, "additive")}}}})
    sim, model = task.envs.sim, task.envs.model
    ratio = sim.body_mass / torch.as_tensor(model.body_mass)
    assert ratio.min() >= 0.5 and ratio.max() <= 1.5 and ratio.std() > 0.2
    # inertia scales with mass
    inertia_ratio = sim.body_inertia / torch.as_tensor(model.body_inertia)
    torch.testing.assert_close(inertia_ratio, ratio[..., None].expand_as(inertia_ratio))
    ant_geoms = [g for g in range(model.ngeom) if model.geom_body[g] >= 0]
    f = sim.geom_friction[:, ant_geoms] / torch.as_tensor(model.geom_friction[ant_geoms, 0])
    assert f.min() >= 0.7 and f.max() <= 1.3
    assert torch.all(sim.geom_friction[:, model.geom_names.index("ground")] == 1.0), \
        "the ground is not an actor: untouched"
    d = sim.dof_damping[:, 6:] / torch.as_tensor(model.dof_damping[6:])
    assert d.min() >= 0.3 and d.max() <= 3.0
    assert torch.all(sim.dof_damping[:, :6] == 0), "the free joint is not a DOF"
    upper = sim.joint_range[:, 1:, 1] - torch.as_tensor(model.jnt_range[1:, 1])
    assert upper.abs().max() <= 0.1 + 1e-6 and upper.std() > 0.03
    assert sim.gravity[:, 2].std() > 0.3 and abs(sim.gravity[:, 2].mean() + 9.81) < 0.1
    # re-sampling draws again from the originals: values never compound
    before = sim.body_mass.clone()
    for _ in range(30):
        task.randomizer.resample(torch.arange(N))
    ratio = sim.body_mass / torch.as_tensor(model.body_mass)
    assert ratio.min() >= 0.5 and ratio.max() <= 1.5 and not torch.equal(before, sim.body_mass)


def test_setup_only_never_changes_and_frequency_is_honoured():
    torch.manual_seed(2)
    task = ant_with({"frequency": 30, "actor_params": {"ant": {
        "rigid_body_properties": {"mass": spec("uniform", 0.5, 1.5, setup_only=True)},
        "rigid_shape_properties": {"friction": spec("uniform", 0.5, 1.5)}}}},
        num_envs=4, episodeLength=10, terminationHeight=0.0)
    sim = task.envs.sim
    mass, friction = sim.body_mass.clone(), sim.geom_friction.clone()
    actions = torch.zeros(4, 8)
    for step in range(1, 71):
        task.step(actions)
        assert torch.equal(sim.body_mass, mass), "setup_only parameters never change"
        changed = ~torch.all(sim.geom_friction == friction, dim=1)
        # episodes end at steps 10, 20, ...; a re-sample needs 30 steps since the last one,
        # so it happens at the resets of steps 30 and 60 only, for every env at once
        assert torch.all(changed == (step in (30, 60))), step
        friction = sim.geom_friction.clone()


def test_observation_and_action_noise():
    torch.manual_seed(3)
    task = ant_with({"observations": spec("gaussian", 0.0, 0.01, "additive",
                                          range_correlated=[0.0, 0.05]),
                     "actions": spec("gaussian", 0.0, 0.2, "additive")}, num_envs=512)
    obs = task.reset()["obs"]
    noise = obs - torch.clamp(task.obs_buf, -5, 5)
    # per env a correlated offset (std 0.05) plus fresh noise (std 0.01)
    assert abs(noise.std() - math.hypot(0.05, 0.01)) < 0.003
    correlated = task.randomizer.obs_correlated.clone()
    torch.testing.assert_close((noise - correlated).std(), torch.tensor(0.01), atol=5e-4, rtol=0)
    obs2 = task._obs()["obs"]
    fresh = (obs2 - obs)
    assert abs(fresh.std() - 0.01 * math.sqrt(2)) < 1e-3, "uncorrelated noise is new each step"
    # action noise reaches the torques (before clipping to ±1)
    task.step(torch.zeros(512, 8))
    assert abs(task.actions.std() - 0.2) < 0.01


def test_random_forces_follow_the_a41_process():
    """Probability log-uniform in [0.1%, 10%] per env, Gaussian force σ = scale·mass per axis,
    decaying ×0.99 every 50 ms (here 1/60 s per physics step: 0.99^(1/3) per step)."""
    torch.manual_seed(4)
    task = ant_with({"random_forces": {"body": "ant/torso", "probability_range": [0.001, 0.1],
                                       "scale": 1.0, "decay": 0.99, "decay_interval_s": 0.05}},
                    num_envs=4096)
    dr = task.randomizer
    p = dr.force_probability
    assert p.min() >= 0.001 and p.max() <= 0.1
    assert abs(torch.log(p).mean() - (math.log(0.001) + math.log(0.1)) / 2) < 0.05
    assert dr.force_decay == pytest.approx(0.99 ** ((1 / 60) / 0.05))
    # decay only: no new draws
    dr.forces[:] = 1.0
    dr.apply_random_forces(new_draws=False)
    assert torch.allclose(dr.forces, torch.full_like(dr.forces, dr.force_decay))
    # draws: with probability 1 every env gets a new N(0, (scale·mass)²) force per axis
    dr.force_probability[:] = 1.0
    dr.apply_random_forces(new_draws=True)
    mass = float(task.envs.sim.body_mass[0, 0])
    assert abs(dr.forces.std() - mass) < 0.05 * mass and abs(dr.forces.mean()) < 0.05 * mass
    # with probability p, about a fraction p of the envs draws
    dr.forces[:] = 0.0
    dr.force_probability[:] = 0.05
    task.envs.sim.body_force.zero_()
    dr.apply_random_forces(new_draws=True)
    drawn = (dr.forces.abs().sum(1) > 0).float().mean()
    assert abs(drawn - 0.05) < 5 * math.sqrt(0.05 * 0.95 / 4096)
    # the force reaches the body for the next physics step
    assert torch.allclose(task.envs.sim.body_force[:, 0, :3], dr.forces)


@pytest.mark.parametrize("dr, message", [
    ({"actor_params": {"ant": {"rigid_body_properties": {"mas": spec("uniform", 0.5, 1)}}}},
     r"rigid_body_properties.mas: unknown parameter; valid: \['mass'\]"),
    ({"actor_params": {"robot": {}}}, r"no such actor; the actors are \['ant'\]"),
    ({"actor_params": {"ant": {"rigid_body_properties": {"mass": spec("uniform", 2, 1)}}}},
     "low > high"),
    ({"actor_params": {"ant": {"dof_properties": {"damping": spec("loguniform", 0, 1)}}}},
     "loguniform needs low > 0"),
    ({"sim_params": {"gravity": spec("gaussian", 0, -1, "additive")}}, "std must be >= 0"),
    ({"sim_params": {"gravity": spec("normal", 0, 1, "additive")}}, "distribution='normal'"),
    ({"frequncy": 3}, "unknown keys \\['frequncy'\\]"),
    ({"actor_params": {"ant": {"scale": spec("uniform", 0.9, 1.1)}}}, "setup_only: true"),
    ({"actor_params": {"ant": {"scale": spec("uniform", 0.9, 1.1, setup_only=True)}}},
     "only single-body actors"),
    ({"actor_params": {"ant": {"dof_properties": {"drive_stiffness": spec("uniform", 0.9, 1)}}}},
     "has no position or velocity drives"),
    ({"observations": spec("gaussian", 0, 1, "additive", schedule="linear")},
     "needs schedule_steps > 0"),
])
def test_bad_randomization_configs_fail_at_start_up(dr, message):
    with pytest.raises(RandomizationError, match=message):
        ant_with(dr, num_envs=2)


def test_tendon_drive_and_limit_parameters(tmp_path):
    """Tendon gains and limits, drive gains and joint limits of a position-driven actor."""
    from types import SimpleNamespace

    import myriad
    from myriad.api import Scene
    from myriad.randomization import Randomizer

    path = tmp_path / "finger.xml"
    path.write_text("""<mujoco><compiler angle="radian"/><worldbody><body name="base">
      <body name="a"><joint name="j1" type="hinge" axis="0 1 0" range="-1 1"/>
        <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01"/>
        <body name="b" pos="0.1 0 0"><joint name="j2" type="hinge" axis="0 1 0" range="-1 1"/>
          <geom type="capsule" fromto="0 0 0 0.1 0 0" size="0.01"/></body></body></body>
      </worldbody><tendon><fixed name="t" stiffness="2" damping="0.5" limited="true"
        range="-0.5 0.5"><joint joint="j1" coef="1"/><joint joint="j2" coef="-1"/></fixed>
      </tendon></mujoco>""")
    envs = Scene().add_actor("f", str(path), fix_base=True, dof_mode="position", stiffness=3.0,
                             damping=0.1).build(N)
    task = SimpleNamespace(envs=envs, num_envs=N, device=envs.device, num_obs=1, num_actions=1,
                           dt=1 / 60, sim_params=myriad.SimParams())
    torch.manual_seed(5)
    Randomizer({"actor_params": {"f": {
        "tendon_properties": {"damping": spec("loguniform", 0.3, 3.0),
                              "stiffness": spec("loguniform", 0.75, 1.5),
                              "upper": spec("uniform", -0.1, 0.1, "additive")},
        "dof_properties": {"drive_stiffness": spec("uniform", 0.5, 2.0),
                           "drive_damping": spec("uniform", 0.5, 2.0),
                           "lower": spec("gaussian", 0.0, 0.05, "additive")}}}}, task)
    sim = envs.sim
    damping, stiffness = sim.tendon_damping[:, 0] / 0.5, sim.tendon_stiffness[:, 0] / 2.0
    assert damping.min() >= 0.3 and damping.max() <= 3.0 and damping.std() > 0.3
    assert stiffness.min() >= 0.75 and stiffness.max() <= 1.5
    upper = sim.tendon_range[:, 0, 1] - 0.5
    assert upper.abs().max() <= 0.1 + 1e-6 and upper.std() > 0.03
    assert torch.all(sim.tendon_range[:, 0, 0] == -0.5), "the lower tendon limit is untouched"
    kp, kv = sim.actuator_kp / 3.0, sim.actuator_kv / 0.1
    assert kp.min() >= 0.5 and kp.max() <= 2.0 and kv.min() >= 0.5 and kv.max() <= 2.0
    lower = sim.joint_range[:, :, 0] + 1.0
    assert abs(lower.std() - 0.05) < 0.01 and torch.all(sim.joint_range[:, :, 1] == 1.0)


def test_scaling_noise_multiplies():
    torch.manual_seed(6)
    task = ant_with({"observations": spec("gaussian", 1.0, 0.1, range_correlated=[1.0, 0.0])},
                    num_envs=512)
    task.obs_buf[:] = 2.0
    obs = task._obs()["obs"]
    assert abs(obs.mean() - 2.0) < 0.01 and abs(obs.std() - 0.2) < 0.01


def test_object_scale_changes_geometry_and_mass_per_env(tmp_path):
    """Boxes scaled by s per env rest at s × half-size on the ground, with mass × s³."""
    from types import SimpleNamespace

    import myriad
    from myriad.api import Scene
    from myriad.randomization import Randomizer

    path = tmp_path / "cube.xml"
    path.write_text("""<mujoco><worldbody><body name="cube">
        <geom type="box" size="0.05 0.05 0.05" mass="0.2"/></body></worldbody></mujoco>""")
    envs = Scene().add_ground().add_actor("cube", str(path), pos=(0, 0, 0.2)).build(8)
    task = SimpleNamespace(envs=envs, num_envs=8, device=envs.device, num_obs=1, num_actions=1,
                           dt=1 / 60, sim_params=myriad.SimParams())
    torch.manual_seed(7)
    dr = Randomizer({"actor_params": {"cube": {
        "scale": spec("uniform", 0.5, 2.0, setup_only=True),
        "rigid_body_properties": {"mass": spec("uniform", 1.0, 1.0)}}}}, task)
    s = dr.actor_scale["cube"]
    assert s.min() >= 0.5 and s.max() <= 2.0 and s.std() > 0.2
    torch.testing.assert_close(envs.sim.geom_size[:, 1], 0.05 * s[:, None].expand(8, 3))
    # the mass parameter starts from the scaled mass
    torch.testing.assert_close(envs.sim.body_mass[:, 0], 0.2 * s**3)
    for _ in range(120):
        envs.step()
    torch.testing.assert_close(envs.root_states[:, 0, 2], 0.05 * s, atol=2e-3, rtol=0)
