"""Soak: every task under uniform random actions in [-1, 1] for `--episodes` episode lengths,
counting what went non-finite and what overflowed its contact slots. No policy.

    python benchmarks/soak.py                                   # every task, 4096 envs, cuda:0
    python benchmarks/soak.py --device cpu --envs 8 --tasks Ant Humanoid --episodes 0.05

Counted per task, on the device (read once at the end, so the loop never waits on it):
  non-finite states     envs whose simulator state went non-finite (`sim.nonfinite`), once per
                        episode: read as the task resets them, since `VecTask.step` ends such an
                        episode and clears the flag in the same step
  non-finite obs, rew   env-steps whose observations (and states) or reward held a NaN or inf as
                        the task computed them, before `VecTask.step` hides them (nan_to_num of
                        the observations, reward 0 for a broken env)
  contact overflow      env-steps that found more contacts than their slots, in the last
                        substep of the step (`sim.contact_overflow()` counts the same, once)
  env-steps/s           after the first 5 steps, counting included

Exit code 1 if anything went non-finite. Tasks whose optional robot package is missing are
skipped with the reason. --budget-s: after a task's first steps, its remaining time is
estimated; a task that does not fit its share of the budget left (that divided by the tasks
left) is shortened to one episode length, or else stopped after its first steps; a task is
skipped when less time is left than the tasks so far took to build and take their first steps,
on average. The table and the last line say what was cut or skipped.
"""

from __future__ import annotations

import argparse
import gc
import sys
import time

import torch
import warp as wp

import myriad
from myriad.tasks import TASKS

PROBE = 20       # steps timed to estimate a task's run (after the first 5, which build graphs)


def sync(device: str) -> None:
    if device.startswith("cuda"):
        torch.cuda.synchronize(device)


def counting(task) -> dict:
    """Wrap the task's reset_idx and post_physics_step to count on the device (see above)."""
    counts = {k: torch.zeros((), dtype=torch.long, device=task.device)
              for k in ("states", "obs", "rewards", "overflow")}
    sim, reset_idx, post_physics_step = task.envs.sim, task.reset_idx, task.post_physics_step

    def counted_reset(env_ids):
        counts["states"] += (sim.nonfinite != 0).sum()
        reset_idx(env_ids)

    def counted_post():
        post_physics_step()
        obs = torch.cat([task.obs_buf, task.states_buf], dim=1)
        counts["obs"] += (~torch.isfinite(obs)).any(dim=1).sum()
        counts["rewards"] += (~torch.isfinite(task.rew_buf)).sum()
        counts["overflow"] += (sim.contact_count > sim.contact_capacity).sum()

    task.reset_idx, task.post_physics_step = counted_reset, counted_post
    return counts


def soak(name: str, n: int, device: str, episodes: float, share_s: float) -> dict:
    start = time.perf_counter()
    task = myriad.make(name, num_envs=n, device=device)
    counts = counting(task)
    task.reset()
    gen = torch.Generator(device=task.device).manual_seed(0)
    actions = torch.empty(n, task.num_actions, device=task.device)
    step = lambda: task.step(actions.uniform_(-1, 1, generator=gen))
    steps = max(1, round(episodes * task.max_episode_length))
    note = ""
    done = warm = min(5, steps)          # graph captures and the first kernel loads: untimed
    for _ in range(done):
        step()
    sync(device)
    probe_start = time.perf_counter()
    probe = min(PROBE, steps - done)
    for _ in range(probe):
        step()
    sync(device)
    done += probe
    per_step = (time.perf_counter() - probe_start) / max(probe, 1)
    elapsed = time.perf_counter() - start        # building included
    if elapsed + per_step * (steps - done) > share_s:
        one = min(steps, task.max_episode_length)
        if one < steps and elapsed + per_step * (one - done) <= share_s:
            steps, note = one, f"shortened to 1 episode ({one} steps) to fit {share_s:.0f} s"
        else:
            steps, note = done, (f"cut after {done} steps: {per_step * steps:.0f} s "
                                 f"estimated, {share_s:.0f} s share")
    for _ in range(steps - done):
        step()
    sync(device)
    seconds = time.perf_counter() - probe_start
    sim = task.envs.sim
    sim.contact_overflow()      # its warning names the capacity to raise
    row = dict(task=name, envs=n, steps=steps, episode_length=task.max_episode_length,
               env_steps_per_s=n * (steps - warm) / seconds if steps > warm else 0.0,
               seconds=time.perf_counter() - start, setup_s=elapsed, note=note,
               contact_capacity=sim.contact_capacity, **{k: int(v) for k, v in counts.items()})
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--envs", type=int, default=4096)
    ap.add_argument("--tasks", nargs="+", choices=list(TASKS), default=list(TASKS))
    ap.add_argument("--episodes", type=float, default=2.0, help="episode lengths per env")
    ap.add_argument("--budget-s", type=float, default=420.0)
    args = ap.parse_args()
    clock = time.perf_counter()
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    where = torch.cuda.get_device_name(args.device) if args.device.startswith("cuda") else "CPU"
    print(f"soak on {args.device} ({where}): {args.envs} envs, {args.episodes:g} episode lengths, "
          f"uniform random actions; budget {args.budget_s:.0f} s", flush=True)
    rows, skipped = [], []
    for i, name in enumerate(args.tasks):
        left = args.budget_s - (time.perf_counter() - clock)
        setups = [r["setup_s"] for r in rows]       # building and the first steps, so far
        if left <= 0 or setups and left < sum(setups) / len(setups):
            skipped.append(f"{name} ({left:.0f} s left)")
            print(f"skipping {skipped[-1]}", flush=True)
            continue
        try:
            row = soak(name, args.envs, args.device, args.episodes, left / (len(args.tasks) - i))
            gc.collect()            # the task's arrays, before the next task allocates
        except myriad.ModelError as err:      # a robot package that is not installed
            skipped.append(f"{name} ({err})")
            print(f"skipping {skipped[-1]}", flush=True)
            continue
        rows.append(row)
        if row["note"]:
            skipped.append(f"{name}: {row['note']}")
        print(f"[{time.perf_counter() - clock:.0f} s] {name}: {row['steps']} steps, "
              f"{row['env_steps_per_s']:,.0f} env-steps/s, non-finite states {row['states']}, "
              f"obs {row['obs']}, rewards {row['rewards']}, contact overflow {row['overflow']}"
              + (f"; {row['note']}" if row["note"] else ""), flush=True)
    print("\n| task | envs | steps (episode) | env-steps/s | non-finite states (episodes) | "
          "non-finite obs (env-steps) | non-finite rewards (env-steps) | contact overflow "
          "(env-steps) | note |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['task']} | {r['envs']} | {r['steps']} ({r['episode_length']}) | "
              f"{r['env_steps_per_s']:,.0f} | {r['states']} | {r['obs']} | {r['rewards']} | "
              f"{r['overflow']} | {r['note']} |")
    print("\nskipped: " + ("; ".join(skipped) if skipped else "nothing"))
    bad = sum(r["states"] + r["obs"] + r["rewards"] for r in rows)
    print("non-finite: " + (f"{bad} (FAIL)" if bad else "none"))
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
