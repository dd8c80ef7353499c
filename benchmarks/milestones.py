"""When a training run first reached each reward milestone, read from its progress.csv.

    python benchmarks/milestones.py runs/ant_gpu 3000 6000

Prints the wall time (from the start of training, kernel compilation and env build excluded:
`built in ...` in the run's log says how long those took) and env-steps at which the mean
episode reward first reached each milestone, and the training loop's throughput: the median of
the per-epoch env-steps/s (physics, observations, rewards, resets, policy and PPO update).

    python benchmarks/milestones.py runs/humanoid_a runs/humanoid_b --at 5e6 10e6 22e6

With --at, each run's mean reward and task metrics (consecutive successes, ...) at the first
epoch at or past each env-step count as well: two training set-ups compared per sample.
"""

import argparse
import csv
import json
import os
import statistics


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", nargs="+", help="runs/<experiment> folder(s)")
    ap.add_argument("--milestones", "-m", type=float, nargs="*", default=[],
                    help="mean episode rewards to find the first epoch reaching")
    ap.add_argument("--at", type=float, nargs="*", default=[],
                    help="env-step counts to read each run's mean reward and metrics at")
    args = ap.parse_args()
    # the older form `milestones.py RUN 3000 6000`: numbers after the run are milestones
    runs = [r for r in args.run if not _is_number(r)]
    args.milestones += [float(r) for r in args.run if _is_number(r)]
    for run in runs:
        report(run, args.milestones, args.at)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def report(run: str, milestones: list[float], marks: list[float]) -> None:
    if not os.path.isdir(run):
        raise SystemExit(f"milestones.py: {run}: no such run folder")
    with open(os.path.join(run, "progress.csv")) as f:
        rows = list(csv.DictReader(f))
    with open(os.path.join(run, "summary.json")) as f:
        summary = json.load(f)
    rates = [float(r["env_steps_per_s"]) for r in rows[3:]] or \
        [float(r["env_steps_per_s"]) for r in rows]
    print(f"{run}: {summary['task']}, {summary['num_envs']} envs on {summary['device']} "
          f"({summary.get('machine', '?')}); {len(rows)} epochs, {int(rows[-1]['env_steps']):,} "
          f"env-steps in {float(rows[-1]['wall_s']):.1f} s; best mean reward "
          f"{summary['best_mean_reward']}; median {statistics.median(rates):,.0f} env-steps/s "
          f"per epoch")
    for goal in milestones:
        hit = next((r for r in rows if r["mean_reward"] and float(r["mean_reward"]) >= goal), None)
        print(f"  reward {goal:g}: " + ("not reached" if hit is None else
              f"{float(hit['wall_s']):.1f} s, {int(hit['env_steps']):,} env-steps, "
              f"epoch {hit['epoch']}"))
    metrics = [k for k in rows[0] if k not in _PROGRESS_COLUMNS]
    for mark in marks:
        row = next((r for r in rows if float(r["env_steps"]) >= mark), None)
        if row is None:
            print(f"  at {mark:,.0f} env-steps: the run stopped at {int(rows[-1]['env_steps']):,}")
            continue
        shown = "".join(f", {k} {float(row[k]):.2f}" for k in metrics if row[k] != "")
        print(f"  at {mark:,.0f} env-steps (epoch {row['epoch']}, {int(row['env_steps']):,}): "
              f"mean reward {row['mean_reward'] or '-'}{shown}")


# progress.csv's columns before the task's metrics (rl.agent.MyriadAgent.report_epoch)
_PROGRESS_COLUMNS = ("epoch", "env_steps", "wall_s", "mean_reward", "env_steps_per_s",
                     "physics_s", "policy_s", "update_s", "nonfinite_actions")


if __name__ == "__main__":
    main()
