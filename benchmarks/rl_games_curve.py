"""The learning curve of a plain rl_games run (IsaacGymEnvs' train.py) from its TensorBoard
summaries, as a progress.csv that `plot_curve.py` draws, and a table at given minutes.

    python benchmarks/rl_games_curve.py ../IsaacGymEnvs/isaacgymenvs/runs/cpu_Ant_*/summaries \
        --csv /tmp/ige_ant.csv --minutes 1 2 5 10

rl_games writes the mean episode reward against frames (`rewards/step`; IsaacGymEnvs' AMP
learner: `rewards/frame`) and against its own clock (`rewards/time`, seconds of training); the
two are paired by their order (one point per epoch each).
"""

import argparse
import csv
import glob


def curve(folder: str) -> list[tuple[float, int, float]]:
    """[(seconds, env-steps, mean episode reward)] of the run whose summaries are in `folder`."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    events = EventAccumulator(folder, size_guidance={"scalars": 0})
    events.Reload()
    tags = events.Tags()["scalars"]
    steps = "rewards/step" if "rewards/step" in tags else "rewards/frame"   # AMP's learner
    if steps not in tags or "rewards/time" not in tags:
        raise SystemExit(f"{folder}: no rewards/step (or /frame) and rewards/time scalars (not "
                         f"an rl_games run, or no episode finished yet)")
    by_step, by_time = events.Scalars(steps), events.Scalars("rewards/time")
    return [(float(t.step), int(s.step), float(s.value)) for s, t in zip(by_step, by_time)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("summaries", help="the run's summaries folder (a glob is expanded)")
    ap.add_argument("--csv", help="write wall_s, env_steps, mean_reward here")
    ap.add_argument("--minutes", type=float, nargs="*", default=[],
                    help="print the reward reached at these minutes of training")
    args = ap.parse_args()
    folders = sorted(glob.glob(args.summaries))
    if len(folders) != 1:
        raise SystemExit(f"{args.summaries}: matches {len(folders)} folders, not one")
    points = curve(folders[0])
    if args.csv:
        with open(args.csv, "w", newline="") as f:
            out = csv.writer(f)
            out.writerow(["wall_s", "env_steps", "mean_reward"])
            out.writerows(points)
    print(f"{folders[0]}: {len(points)} epochs, {points[-1][1]:,} env-steps in "
          f"{points[-1][0]:.0f} s; last reward {points[-1][2]:.1f}, best "
          f"{max(p[2] for p in points):.1f}")
    for minute in args.minutes:
        seen = [p for p in points if p[0] <= minute * 60]
        if seen:
            print(f"  {minute:g} min: reward {seen[-1][2]:.1f} at {seen[-1][1]:,} env-steps")


if __name__ == "__main__":
    main()
