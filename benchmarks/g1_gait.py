"""Where a G1 policy's yaw error comes from: the pelvis's swing, the stance feet's twist, the
body's angular momentum.

    python benchmarks/g1_gait.py src/myriad/policies/G1Velocity.pth [--envs 64 --seconds 6]
    python benchmarks/g1_gait.py runs/g1_twist/nn/last.pth --set env.learn.feetTwistRewardScale=-0.5

Every env walks straight ahead, the forward command spread over [0, 1] m/s, no yaw and no
lateral command, no pushes, after 1 s to settle. Over the rest of the window it reports:
- the pelvis's yaw rate: its standard deviation over time (the swing within each stride, since
  the command holds no turning), mean over the envs;
- a loaded foot (vertical contact force over 150 N: the stance foot, not a touch-down): how
  many of its four sole spheres touch the ground (within 3 mm; for two, which two), and how
  fast it turns about the vertical, overall and when all four touch;
- the whole robot's angular momentum about its centre of mass (`Envs.angular_momentum`): the
  mean square per axis, and the standard deviation of its vertical component by body group
  (legs, pelvis and torso, arms) with each group's correlation with the pelvis's yaw rate.
"""

import argparse

import torch
import yaml

import myriad
from myriad.rl.policy import load_policy
from myriad.rl.run import compose, task_and_train_configs
from myriad.torch_utils import quat_rotate

TOUCHING, LOADED = 0.003, 150.0      # m: a sole sphere this close to the ground; N: a stance foot


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("checkpoint")
    ap.add_argument("--envs", type=int, default=64)
    ap.add_argument("--seconds", type=float, default=6.0)
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a task setting, as myriad.make takes it")
    args = ap.parse_args()
    settings = {k: yaml.safe_load(v) for k, _, v in (s.partition("=") for s in args.set)}

    torch.manual_seed(0)
    _, train_cfg, _ = task_and_train_configs(compose(["task=G1Velocity", "device=cpu"]))
    n = args.envs
    task = myriad.make("G1Velocity", num_envs=n,
                       **{"env.pushInterval_s": 10 ** 6, "env.commands.resample_s": 10 ** 6,
                          **settings})
    policy = load_policy(args.checkpoint, train_cfg, task)
    envs, sim = task.envs, task.envs.sim
    obs = task.reset()["obs"]
    task.commands[:] = 0.0
    task.commands[:, 0] = torch.linspace(0.0, 1.0, n)
    bodies = envs.actor_bodies("g1")
    names = [envs.body_names[b].split("/", 1)[1] for b in bodies]
    groups = {"legs": [i for i, s in enumerate(names) if any(k in s for k in ("hip", "knee",
                                                                               "ankle"))],
              "pelvis and torso": [i for i, s in enumerate(names) if any(
                  k in s for k in ("pelvis", "waist", "torso"))],
              "arms": [i for i, s in enumerate(names) if any(k in s for k in ("shoulder", "elbow",
                                                                              "wrist"))]}
    sole, radius = sole_spheres(envs.model.mj_model, task.feet[0].item() + 1)
    settle = round(1.0 / task.dt)
    pelvis_yaw, momentum, group_z = [], [], {k: [] for k in groups}
    touching_count, twist, twist_flat, pairs = [], [], [], []
    for step in range(round(args.seconds / task.dt)):
        with torch.no_grad():
            out, *_ = task.step(policy(obs))
        obs = out["obs"]
        if step < settle:
            continue
        pelvis_yaw.append(sim.body_vel[:, bodies[0], 5].clone())
        per_body = envs.angular_momentum("g1", per_body=True)
        momentum.append(per_body.sum(1))
        for k, idx in groups.items():
            group_z[k].append(per_body[:, idx, 2].sum(-1))
        pose, vel = sim.body_pose[:, task.feet], sim.body_vel[:, task.feet]
        arm = quat_rotate(pose[:, :, None, 3:7].expand(-1, -1, 4, -1), sole.expand(n, 2, 4, 3))
        down = pose[:, :, None, 2] + arm[..., 2] - radius < TOUCHING      # [N, 2, 4]
        touching = down.sum(-1)
        loaded = envs.net_contact_force[:, task.feet, 2] > LOADED
        touching_count.append(touching[loaded])
        pairs.append(down[loaded & (touching == 2)])
        twist.append(vel[..., 5].abs()[loaded])
        twist_flat.append(vel[..., 5].abs()[loaded & (touching == 4)])
    yaw = torch.stack(pelvis_yaw)
    print(f"{n} envs walking straight, forward 0 to 1 m/s, {args.seconds:g} s after 1 s")
    print(f"pelvis yaw rate: swing (std over time) {yaw.std(0).mean():.3f} rad/s, "
          f"mean |rate| {yaw.abs().mean():.3f}")
    count = torch.cat(touching_count)
    shares = ", ".join(f"{k}: {(count == k).float().mean():.2f}" for k in range(5))
    print(f"loaded feet (F_z > {LOADED:g} N): sole spheres touching, share {shares}")
    two = torch.cat(pairs)
    heel, toe = two[:, :2].all(-1), two[:, 2:].all(-1)
    print(f"  of those on two spheres: the heel's {heel.float().mean():.2f}, the toe's "
          f"{toe.float().mean():.2f}, one side's {(~heel & ~toe).float().mean():.2f}")
    flat = torch.cat(twist_flat)
    print(f"loaded feet turning about the vertical: mean {torch.cat(twist).mean():.3f} rad/s; "
          f"with all four spheres down mean {flat.mean():.3f}, median {flat.median():.3f}")
    L = torch.stack(momentum)
    print("angular momentum about the centre of mass, mean square per axis x, y, z: "
          + ", ".join(f"{v:.2f}" for v in (L ** 2).mean((0, 1)).tolist()) + " (kg·m²/s)²")
    centred_yaw = yaw - yaw.mean(0)
    for k in groups:
        z = torch.stack(group_z[k])
        zc = z - z.mean(0)
        corr = ((zc * centred_yaw).mean(0) / (zc.std(0) * centred_yaw.std(0) + 1e-9)).mean()
        print(f"  vertical momentum of the {k}: std {z.std(0).mean():.3f} kg·m²/s, "
              f"correlation with the pelvis's yaw rate {corr:+.2f}")


def sole_spheres(mj_model, foot: int) -> tuple[torch.Tensor, float]:
    """([4, 3] positions in the foot's frame, radius) of the sphere geoms of MuJoCo body `foot`:
    the G1's feet (`myriad.assets.g1_spec`), heel pair first, as the URDF lists them."""
    import mujoco
    spheres = [g for g in range(mj_model.ngeom) if mj_model.geom_bodyid[g] == foot
               and mj_model.geom_type[g] == mujoco.mjtGeom.mjGEOM_SPHERE]
    if len(spheres) != 4:
        raise ValueError(f"body {foot}: expected the G1's four sole spheres, found "
                         f"{len(spheres)} sphere geoms")
    return (torch.tensor(mj_model.geom_pos[spheres], dtype=torch.float32),
            float(mj_model.geom_size[spheres[0], 0]))


if __name__ == "__main__":
    main()
