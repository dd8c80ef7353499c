"""Where a flat-ground ANYmal policy falls: the episodes that end early, from their start.

    python benchmarks/anymal_falls.py src/myriad/policies/Anymal.pth [--envs 500 --seconds 3]

Runs the deterministic policy from one reset of `--envs` envs (commands and start poses drawn
as in training) for `--seconds` and, for each env whose episode ends in that window, prints when,
its command and which body's contact ended it (the base, or a thigh); then the share that fell
and the mean |forward command| of those against all.
"""

import argparse

import torch

import myriad
from myriad.rl.policy import load_policy
from myriad.rl.run import compose, task_and_train_configs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("checkpoint")
    ap.add_argument("--envs", type=int, default=500)
    ap.add_argument("--seconds", type=float, default=3.0)
    args = ap.parse_args()
    torch.manual_seed(0)
    _, train_cfg, _ = task_and_train_configs(compose(["task=Anymal", "device=cpu"]))
    task = myriad.make("Anymal", num_envs=args.envs)
    policy = load_policy(args.checkpoint, train_cfg, task)
    obs = task.reset()["obs"]
    commands = task.commands.clone()
    e = task.envs
    names = ["base"] + [e.body_names[i].split("/")[-1] for i in task.thighs.tolist()]
    ended = torch.zeros(args.envs, dtype=torch.bool)
    for step in range(round(args.seconds / task.dt)):
        with torch.no_grad():
            out, _, resets, _ = task.step(policy(obs))
        obs = out["obs"]
        for i in torch.nonzero(resets.bool() & ~ended).flatten().tolist():
            ended[i] = True
            force = e.net_contact_force[i][torch.cat([torch.tensor([task.base]), task.thighs])]
            touched = [n for n, f in zip(names, force.norm(dim=-1).tolist()) if f > 1.0]
            print(f"env {i}: ended at {(step + 1) * task.dt:.2f} s, command "
                  f"({commands[i, 0]:+.2f}, {commands[i, 1]:+.2f}, {commands[i, 2]:+.2f}), "
                  f"touched: {', '.join(touched) or 'none (time out)'}")
    print(f"{int(ended.sum())} of {args.envs} episodes ended within {args.seconds:g} s; mean "
          f"|forward command| {commands[ended, 0].abs().mean():.2f} m/s against "
          f"{commands[:, 0].abs().mean():.2f} over all")


if __name__ == "__main__":
    main()
