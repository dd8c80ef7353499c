"""Unitree's pretrained walking policies, trained in Isaac Gym (PhysX), run on Myriad through
unitree_rl_gym's own environment code, and in MuJoCo C through its sim-to-sim loop.

    bash benchmarks/isaacgym_projects.sh setup unitree_rl_gym ../unitree_rl_gym
    ../unitree_rl_gym/.venv-myriad/bin/python benchmarks/unitree_pretrained.py --robot g1 \
        [--envs 64 --seconds 10]

unitree_rl_gym ships, for the G1 (12 DOF), the H1 and the H1-2, a policy Unitree trained with
its legged_gym tasks on Isaac Gym (`deploy/pre_train/<robot>/motion.pt`: an LSTM of 64 and a
32-unit actor, TorchScript, one env) and `deploy/deploy_mujoco/deploy_mujoco.py`, which walks
it in MuJoCo from its own MJCF scene (2 ms steps, PD torques computed in Python every step, a
policy step every 20 ms). Here the same weights drive, batched over envs:

- **Myriad**: unitree_rl_gym's `legged_gym` task for the robot (`task_registry.make_env`, its
  URDF, its 5 ms PhysX-style steps and PD drives, its observations), unmodified, with the
  settings its `play.py` uses (no observation noise, no pushes, no friction randomization) and
  every env held at one command;
- **MuJoCo C**: `deploy_mujoco.py`'s loop on Unitree's MJCF scene, one env after another,
  each started as legged_gym resets an env (joints at default × U(0.5, 1.5), base velocities
  U(−0.5, 0.5)).

With `--mjcf [KEY=VALUE ...]`, a third: Myriad's own engine (`myriad.Simulator`) on Unitree's MJCF
scene with deploy_mujoco's loop, batched, at `myriad.SimParams` given as KEY=VALUE (default
deploy_mujoco's 2 ms step; e.g. `dt=0.005 substeps=1 velocity_iterations=0 contact_offset=0.01`
with `--decimation 4` are legged_gym's physics settings): which part of a difference between
the first two is the engine's, and which the URDF path's and the settings'.

Reported per command: the mean base velocity (forward, lateral m/s; yaw rad/s, in the base's
frame) over the last half of the window, the mean absolute error to the command there, and the
falls (envs reset before the window ended, for Myriad by the task's own termination: a pelvis
contact or the base tilted; for MuJoCo the same test: the base's up axis more than 1 rad off
vertical, or the pelvis below 0.3 m).
"""

import argparse
import os
import sys
import time

import numpy as np
import torch
import yaml

COMMANDS = [(0.0, 0.0, 0.0), (0.5, 0.0, 0.0), (1.0, 0.0, 0.0), (0.5, 0.0, 0.5), (0.0, 0.3, 0.0)]


class BatchedPolicy:
    """The TorchScript policy's LSTM and actor with one hidden state per env (the exported
    module keeps a single env's state in its buffers)."""

    def __init__(self, path: str, num_envs: int):
        scripted = torch.jit.load(path, map_location="cpu")
        weights = dict(scripted.named_parameters())
        hidden = weights["memory.weight_hh_l0"].shape[1]
        self.lstm = torch.nn.LSTM(weights["memory.weight_ih_l0"].shape[1], hidden)
        self.lstm.load_state_dict({k[len("memory."):]: v for k, v in weights.items()
                                   if k.startswith("memory.")})
        first, last = weights["actor.0.weight"], weights["actor.2.weight"]
        self.actor = torch.nn.Sequential(torch.nn.Linear(first.shape[1], first.shape[0]),
                                         torch.nn.ELU(),
                                         torch.nn.Linear(last.shape[1], last.shape[0]))
        self.actor.load_state_dict({k[len("actor."):]: v for k, v in weights.items()
                                    if k.startswith("actor.")})
        self.state = (torch.zeros(1, num_envs, hidden), torch.zeros(1, num_envs, hidden))
        self.scripted = scripted

    @torch.no_grad()
    def __call__(self, obs: torch.Tensor) -> torch.Tensor:
        out, self.state = self.lstm(obs[None], self.state)
        return self.actor(out[0])

    def reset(self, done: torch.Tensor) -> None:
        for s in self.state:
            s[:, done] = 0.0


def on_myriad(args, root: str, policy_path: str, commands: list) -> list:
    from legged_gym.envs import task_registry
    from legged_gym.utils import get_args

    rows = []
    for command in commands:
        sys.argv = [sys.argv[0], f"--task={args.robot}", "--sim_device=cpu", "--rl_device=cpu",
                    "--headless", f"--num_envs={args.envs}", f"--seed={args.seed}"]
        env_cfg, _ = task_registry.get_cfgs(name=args.robot)
        env_cfg.env.num_envs = args.envs
        env_cfg.noise.add_noise = False                  # as its play.py
        env_cfg.domain_rand.randomize_friction = False
        env_cfg.domain_rand.push_robots = False
        env_cfg.terrain.curriculum = False
        env_cfg.commands.heading_command = False
        env_cfg.commands.resampling_time = 1e9
        vx, vy, wz = command
        env_cfg.commands.ranges.lin_vel_x = [vx, vx]
        env_cfg.commands.ranges.lin_vel_y = [vy, vy]
        env_cfg.commands.ranges.ang_vel_yaw = [wz, wz]
        env, _ = task_registry.make_env(name=args.robot, args=get_args(), env_cfg=env_cfg)
        policy = BatchedPolicy(policy_path, args.envs)
        # the actors are created at their env's origin, z = 0, feet in the ground (the
        # original's behaviour too): start from the task's own reset of every env
        obs, _ = env.reset()
        steps = int(round(args.seconds / env.dt))
        fell = torch.zeros(args.envs, dtype=torch.bool)
        velocity = torch.zeros(args.envs, 3); error = torch.zeros(args.envs, 3); counted = 0
        target = torch.tensor(command)
        start = time.perf_counter()
        for step in range(steps):
            obs, _, _, dones, extras = env.step(policy(obs))
            done = dones.bool()
            fell |= done & ~extras["time_outs"].bool()
            policy.reset(done)
            if step >= steps // 2:
                v = torch.cat((env.base_lin_vel[:, :2], env.base_ang_vel[:, 2:3]), dim=-1).cpu()
                velocity += v; error += (v - target).abs(); counted += 1
        wall = time.perf_counter() - start
        keep = ~fell                        # the envs that never fell (as for MuJoCo below)
        rows.append((command, (velocity / counted)[keep].mean(0).tolist(),
                     (error / counted)[keep].mean(0).tolist(), int(fell.sum()), args.envs, wall))
        env.gym.destroy_sim(env.sim)
    return rows


def deploy_observation(robot_config: dict, angular_velocity, gravity, command, q, qd, action,
                       seconds: float) -> torch.Tensor:
    """deploy_mujoco.py's observation [n, num_obs] (float32) from tensors [n, ...]: the base's
    angular velocity (its frame) and gravity direction, the scaled command, the joints'
    offsets from the default pose and speeds, the last action, the 0.8 s gait clock."""
    n = q.shape[0]
    default = torch.as_tensor(robot_config["default_angles"], dtype=q.dtype)
    scale = torch.as_tensor(robot_config["cmd_scale"], dtype=q.dtype)
    phase = seconds % 0.8 / 0.8
    clock = torch.tensor([[np.sin(2 * np.pi * phase), np.cos(2 * np.pi * phase)]], dtype=q.dtype)
    return torch.cat((angular_velocity * robot_config["ang_vel_scale"], gravity,
                      (torch.as_tensor(command, dtype=q.dtype) * scale).expand(n, 3),
                      (q - default) * robot_config["dof_pos_scale"],
                      qd * robot_config["dof_vel_scale"], action.to(q.dtype),
                      clock.expand(n, 2)), dim=-1).float()


def on_mujoco(args, root: str, robot_config: dict, policy_path: str, commands: list) -> list:
    import mujoco

    xml = robot_config["xml_path"].replace("{LEGGED_GYM_ROOT_DIR}", root)
    model = mujoco.MjModel.from_xml_path(xml)
    model.opt.timestep = robot_config["simulation_dt"]
    data = mujoco.MjData(model)
    kp = np.array(robot_config["kps"]); kd = np.array(robot_config["kds"])
    default = np.array(robot_config["default_angles"])
    decimation = robot_config["control_decimation"]
    n_act = robot_config["num_actions"]
    steps = int(round(args.seconds / model.opt.timestep))
    rng = np.random.default_rng(args.seed)
    policy = BatchedPolicy(policy_path, 1)
    rows = []
    for command in commands:
        velocity = np.zeros(3); error = np.zeros(3); counted = 0; falls = 0
        start = time.perf_counter()
        for _ in range(args.mujoco_envs):
            mujoco.mj_resetData(model, data)
            data.qpos[7:] = default * rng.uniform(0.5, 1.5, n_act)
            data.qvel[:6] = rng.uniform(-0.5, 0.5, 6)
            # legged_gym draws the base velocities in world axes; MuJoCo's free joint takes
            # the angular one in the base's frame, which is the world's at the start
            policy.reset(torch.ones(1, dtype=torch.bool))
            action = np.zeros(n_act); target = default.copy()
            v_sum = np.zeros(3); e_sum = np.zeros(3); n = 0; fell = False
            for step in range(steps):
                data.ctrl[:] = (target - data.qpos[7:]) * kp - data.qvel[6:] * kd
                mujoco.mj_step(model, data)
                if (step + 1) % decimation:
                    continue
                quat = data.qpos[3:7]
                up = np.empty(3); mujoco.mju_rotVecQuat(up, np.array([0.0, 0.0, 1.0]), quat)
                if up[2] < np.cos(1.0) or data.qpos[2] < 0.3:
                    fell = True
                    break
                gravity = np.empty(3)
                inverse = np.empty(4); mujoco.mju_negQuat(inverse, quat)
                mujoco.mju_rotVecQuat(gravity, np.array([0.0, 0.0, -1.0]), inverse)
                obs = deploy_observation(
                    robot_config, *(torch.from_numpy(x)[None] for x in (
                        data.qvel[3:6], gravity)), command,
                    *(torch.from_numpy(x)[None] for x in (data.qpos[7:], data.qvel[6:],
                                                         action)),
                    (step + 1) * model.opt.timestep)
                action = policy(obs)[0].numpy()
                target = action * robot_config["action_scale"] + default
                if step >= steps // 2:
                    lin = np.empty(3); mujoco.mju_rotVecQuat(lin, data.qvel[:3], inverse)
                    v = np.array([lin[0], lin[1], data.qvel[5]])
                    v_sum += v; e_sum += np.abs(v - command); n += 1
            if fell:
                falls += 1
            elif n:
                velocity += v_sum / n; error += e_sum / n; counted += 1
        wall = time.perf_counter() - start
        c = max(counted, 1)
        rows.append((command, (velocity / c).tolist(), (error / c).tolist(), falls,
                     args.mujoco_envs, wall))
    return rows


def on_myriad_mjcf(args, root: str, robot_config: dict, policy_path: str, commands: list,
                   settings: dict) -> list:
    import myriad
    from myriad.torch_utils import quat_rotate_inverse

    model = myriad.load(robot_config["xml_path"].replace("{LEGGED_GYM_ROOT_DIR}", root))
    params = myriad.SimParams(**{"dt": robot_config["simulation_dt"], "substeps": 1, **settings})
    decimation = args.decimation or robot_config["control_decimation"]
    kp = torch.tensor(robot_config["kps"]); kd = torch.tensor(robot_config["kds"])
    default = torch.tensor(robot_config["default_angles"], dtype=torch.float32)
    n, n_act = args.envs, robot_config["num_actions"]
    steps = int(round(args.seconds / params.dt))
    down = torch.tensor([[0.0, 0.0, -1.0]]).expand(n, 3)
    generator = torch.Generator().manual_seed(args.seed)
    rows = []
    for command in commands:
        sim = myriad.Simulator(model, num_envs=n, params=params)
        q, qd = sim.q.clone(), sim.qd.clone()       # started as legged_gym resets an env
        q[:, 7:] = default * (0.5 + torch.rand(n, n_act, generator=generator))
        qd[:, :6] = torch.rand(n, 6, generator=generator) - 0.5
        sim.q, sim.qd = q, qd
        policy = BatchedPolicy(policy_path, n)
        action = torch.zeros(n, n_act); target = default.repeat(n, 1)
        c = torch.tensor(command)
        fell = torch.zeros(n, dtype=torch.bool)
        velocity = torch.zeros(n, 3); error = torch.zeros(n, 3); counted = 0
        start = time.perf_counter()
        for step in range(steps):
            sim.ctrl = (target - sim.q[:, 7:]) * kp - sim.qd[:, 6:] * kd
            sim.step()
            if (step + 1) % decimation:
                continue
            quat = sim.q[:, 3:7]                    # x, y, z, w
            gravity = quat_rotate_inverse(quat, down)
            fell |= (gravity[:, 2] > -np.cos(1.0)) | (sim.q[:, 2] < 0.3)
            action = policy(deploy_observation(robot_config, sim.qd[:, 3:6], gravity, command,
                                               sim.q[:, 7:], sim.qd[:, 6:], action,
                                               (step + 1) * params.dt))
            target = action * robot_config["action_scale"] + default
            if step >= steps // 2:
                linear = quat_rotate_inverse(quat, sim.qd[:, :3])
                v = torch.cat((linear[:, :2], sim.qd[:, 5:6]), dim=-1)
                velocity += v; error += (v - c).abs(); counted += 1
        wall = time.perf_counter() - start
        keep = ~fell
        rows.append((command, (velocity / counted)[keep].mean(0).tolist(),
                     (error / counted)[keep].mean(0).tolist(), int(fell.sum()), n, wall))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="g1", choices=["g1", "h1", "h1_2"])
    ap.add_argument("--envs", type=int, default=64, help="Myriad's envs per command")
    ap.add_argument("--mujoco-envs", type=int, default=16, help="MuJoCo C's runs per command")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--skip-task", action="store_true", help="leave out unitree_rl_gym's task")
    ap.add_argument("--skip-mujoco", action="store_true")
    ap.add_argument("--mjcf", nargs="*", metavar="KEY=VALUE",
                    help="also Myriad's engine on Unitree's MJCF with deploy_mujoco's loop, at "
                         "these myriad.SimParams")
    ap.add_argument("--decimation", type=int,
                    help="with --mjcf: physics steps per policy step (default the deploy "
                         "config's, for its 2 ms step)")
    args = ap.parse_args()
    settings = {}
    for item in args.mjcf or []:
        key, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--mjcf {item}: expected KEY=VALUE")
        settings[key] = yaml.safe_load(value)
    from legged_gym import LEGGED_GYM_ROOT_DIR as root

    with open(os.path.join(root, "deploy/deploy_mujoco/configs", f"{args.robot}.yaml")) as f:
        robot_config = yaml.safe_load(f)
    policy_path = robot_config["policy_path"].replace("{LEGGED_GYM_ROOT_DIR}", root)
    torch.manual_seed(args.seed)
    results = {}
    if not args.skip_task:
        results["Myriad (unitree_rl_gym's task)"] = on_myriad(args, root, policy_path, COMMANDS)
    if args.mjcf is not None:
        label = " ".join(args.mjcf) or "its 2 ms step"
        results[f"Myriad's engine, the MJCF, deploy's loop ({label})"] = on_myriad_mjcf(
            args, root, robot_config, policy_path, COMMANDS, settings)
    if not args.skip_mujoco:
        results["MuJoCo C (deploy_mujoco's loop)"] = on_mujoco(args, root, robot_config,
                                                               policy_path, COMMANDS)
    print(f"\nUnitree's pretrained {args.robot} policy, {args.seconds:g} s per env, "
          "means over the last half")
    print("| simulator | command (vx, vy, wz) | base velocity (vx, vy, wz) | |error| "
          "(vx, vy, wz) | falls | wall s |")
    print("|---|---|---|---|---|---|")
    for name, rows in results.items():
        for command, v, e, falls, n, wall in rows:
            print(f"| {name} | {command[0]:.1f}, {command[1]:.1f}, {command[2]:.1f} | "
                  + ", ".join(f"{x:+.3f}" for x in v) + " | "
                  + ", ".join(f"{x:.3f}" for x in e) + f" | {falls}/{n} | {wall:.1f} |")
    for name, rows in results.items():
        mean = np.mean([e for _, _, e, _, _, _ in rows], axis=0)
        print(f"{name}: mean |error| over the commands " + ", ".join(f"{x:.3f}" for x in mean)
              + f"; falls {sum(r[3] for r in rows)}/{sum(r[4] for r in rows)}")


if __name__ == "__main__":
    main()
