"""When a training run first reached each reward milestone, read from its progress.csv.

    python benchmarks/milestones.py runs/ant_gpu 3000 6000

Prints the wall time (from the start of training, kernel compilation and env build excluded:
`built in ...` in the run's log says how long those took) and env-steps at which the mean
episode reward first reached each milestone, and the training loop's throughput: the median of
the per-epoch env-steps/s (physics, observations, rewards, resets, policy and PPO update).
"""

import argparse
import csv
import json
import os
import statistics


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", help="runs/<experiment> folder")
    ap.add_argument("milestones", type=float, nargs="*")
    args = ap.parse_args()
    with open(os.path.join(args.run, "progress.csv")) as f:
        rows = list(csv.DictReader(f))
    with open(os.path.join(args.run, "summary.json")) as f:
        summary = json.load(f)
    rates = [float(r["env_steps_per_s"]) for r in rows[3:]] or \
        [float(r["env_steps_per_s"]) for r in rows]
    print(f"{args.run}: {summary['task']}, {summary['num_envs']} envs on {summary['device']} "
          f"({summary.get('machine', '?')}); {len(rows)} epochs, {int(rows[-1]['env_steps']):,} "
          f"env-steps in {float(rows[-1]['wall_s']):.1f} s; best mean reward "
          f"{summary['best_mean_reward']}; median {statistics.median(rates):,.0f} env-steps/s "
          f"per epoch")
    for goal in args.milestones:
        hit = next((r for r in rows if r["mean_reward"] and float(r["mean_reward"]) >= goal), None)
        print(f"  reward {goal:g}: " + ("not reached" if hit is None else
              f"{float(hit['wall_s']):.1f} s, {int(hit['env_steps']):,} env-steps, "
              f"epoch {hit['epoch']}"))


if __name__ == "__main__":
    main()
