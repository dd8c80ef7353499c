"""How well a trained ANYmal policy tracks its velocity commands.

    python benchmarks/anymal_tracking.py runs/bench_cpu_anymal/nn/last.pth [--envs 256 --seconds 10]

Runs the deterministic policy in fresh episodes (commands drawn as in training) and reports the
mean absolute error between commanded and actual base velocity in the base frame (forward,
lateral, yaw rate) over the last half of the window, next to what standing still would score.
"""

import argparse

import torch

import myriad
from myriad.rl.policy import load_policy
from myriad.rl.run import compose, task_and_train_configs
from myriad.torch_utils import quat_rotate_inverse


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--envs", type=int, default=256)
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args()

    torch.manual_seed(0)
    _, train_cfg, _ = task_and_train_configs(compose(["task=Anymal", "device=cpu"]))
    task = myriad.make("Anymal", num_envs=args.envs)
    policy = load_policy(args.checkpoint, train_cfg, task)
    obs = task.reset()["obs"]
    steps = round(args.seconds / task.dt)
    errors, still, falls = [], [], 0
    for step in range(steps):
        with torch.no_grad():
            out, _, resets, extras = task.step(policy(obs))
        obs = out["obs"]
        falls += int((resets.bool() & ~extras["time_outs"].bool()).sum())
        if step >= steps // 2:
            root = task.envs.root_states[:, 0]
            lin = quat_rotate_inverse(root[:, 3:7], root[:, 7:10])
            ang = quat_rotate_inverse(root[:, 3:7], root[:, 10:13])
            actual = torch.stack((lin[:, 0], lin[:, 1], ang[:, 2]), dim=-1)
            errors.append((task.commands - actual).abs())
            still.append(task.commands.abs())
    err = torch.cat(errors).mean(0)
    base = torch.cat(still).mean(0)
    print(f"{args.envs} envs, {args.seconds:g} s, last half: mean |command - actual| "
          f"forward {err[0]:.3f} m/s, lateral {err[1]:.3f} m/s, yaw {err[2]:.3f} rad/s "
          f"(standing still: {base[0]:.3f}, {base[1]:.3f}, {base[2]:.3f}); "
          f"episodes ended by a fall: {falls}")


if __name__ == "__main__":
    main()
