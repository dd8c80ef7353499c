"""Task-step throughput of an older git revision against this tree, both in one process.

    python benchmarks/task_step_ab.py --old 182de2b --tasks Ant Humanoid --envs 1024
    python benchmarks/task_step_ab.py --old 182de2b --tasks Ant terminationHeight=-1

The old revision's src/myriad is extracted (git archive) as the package `myriad_old`, and the
tasks of both trees are stepped in turn with the same random actions, each variant going first
in turn: drift of the machine's speed and other processes' load fall on all variants alike (on a
shared 2-core machine separate runs differ by up to 5×). Variants: `old`; `new` as it runs by
default; and, where the task has `skip_idle_resets`, `new-always` with it off, which runs the
masked reset every step as on a GPU. Prints env-steps/s per variant (envs × steps / the sum of
that variant's step times) and the fraction of steps in which no env finished. key=value
arguments override the tasks' env config (numbers).
"""

from __future__ import annotations

import argparse
import atexit
import io
import os
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time

import torch
import warp as wp

import myriad


def import_old(revision: str):
    root = subprocess.run(["git", "rev-parse", "--show-toplevel"], capture_output=True,
                          text=True, check=True, cwd=os.path.dirname(__file__)).stdout.strip()
    archive = subprocess.run(["git", "archive", revision, "src/myriad"], capture_output=True,
                             check=True, cwd=root).stdout
    folder = tempfile.mkdtemp(prefix="myriad_old_")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    tarfile.open(fileobj=io.BytesIO(archive)).extractall(folder)
    os.rename(os.path.join(folder, "src", "myriad"), os.path.join(folder, "myriad_old"))
    tasks_init = os.path.join(folder, "myriad_old", "tasks", "__init__.py")
    text = open(tasks_init).read().replace('resources.files("myriad")',
                                           'resources.files("myriad_old")')
    open(tasks_init, "w").write(text)
    sys.path.insert(0, folder)
    import myriad_old
    return myriad_old


def compare(old, name: str, n: int, steps: int, overrides: dict) -> None:
    tasks = {}
    for variant, package in (("old", old), ("new", myriad), ("new-always", myriad)):
        torch.manual_seed(0)
        task = package.make(name, num_envs=n, device="cpu", **overrides)
        if variant == "new-always":
            if not hasattr(task, "skip_idle_resets"):
                continue
            task.skip_idle_resets = False
        task.reset()
        tasks[variant] = task
    gen = torch.Generator().manual_seed(1)
    spent, idle, order = dict.fromkeys(tasks, 0.0), dict.fromkeys(tasks, 0), list(tasks)
    for i in range(steps + 5):                       # 5 warm-up steps
        actions = torch.rand(n, tasks["old"].num_actions, generator=gen) * 2 - 1
        for variant in order[i % len(order):] + order[:i % len(order)]:
            start = time.perf_counter()
            _, _, resets, _ = tasks[variant].step(actions)
            if i >= 5:
                spent[variant] += time.perf_counter() - start
                idle[variant] += not resets.any()
    print(f"| {name} | {n} | " + " | ".join(
        f"{n * steps / spent[v]:,.0f} ({idle[v] / steps:.2f})" for v in tasks) + " |",
        flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--old", required=True, help="git revision to compare against")
    ap.add_argument("--tasks", nargs="+", default=["Ant", "Humanoid"])
    ap.add_argument("--envs", type=int, default=1024)
    ap.add_argument("--steps", type=int, default=150)
    ap.add_argument("overrides", nargs="*", help="env config key=value (numbers)")
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    overrides = {k: float(v) for k, v in (o.split("=", 1) for o in args.overrides)}
    old = import_old(args.old)
    print(f"task.step env-steps/s on CPU, {args.steps} steps after 5 under random actions"
          + "".join(f", {o}" for o in args.overrides)
          + "; in brackets the fraction of steps where no env finished")
    print("| task | envs | old | new | new-always |\n|---|---|---|---|---|")
    for name in args.tasks:
        compare(old, name, args.envs, args.steps, overrides)


if __name__ == "__main__":
    main()
