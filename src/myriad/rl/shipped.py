"""Trained policies that come with Myriad (`checkpoint=shipped`), and how one is made.

    myriad play task=Ant                          # no Ant run yet: the shipped policy
    myriad play task=Ant checkpoint=shipped       # the shipped policy, whatever runs exist
    myriad eval task=Ant checkpoint=shipped       # its figure, as the manifest gives it
    myriad train task=Ant checkpoint=shipped      # fine-tune from it, with a fresh optimizer

A shipped policy is `myriad/policies/<Task>.pth` in the package: what the deterministic policy
and a fine-tune need (rl_games' `model` dict with the observation and value normalizers, the
asymmetric critic where the task has one, the task state its run's checkpoint held), without
the optimizer, the random generators or the run's timers; the network's layers in float16 where
that leaves each figure of the evaluation within the float32 policy's 95 % interval
(`half_agrees`). `myriad/policies/manifest.json` says, per task, how the policy was made and
what it reaches: the training command, the code revision,
the machine, env-steps and wall time of the run, the `myriad eval` figure of the shipped file
itself, and the same evaluation of a fresh policy of the task (`baseline`: its network as
training starts), against which `check_of` picks the figure that shows what training added.
A policy no figure of which tells it from a fresh one within `MAX_CHECK_EPISODES` is not shipped.
Maintainers ship a run's checkpoint with

    python -m myriad.rl.shipped runs/NAME/nn/last.pth [--episodes 100]   # or nn/<Task>.pth
    python -m myriad.rl.shipped --baseline TASK ...      # (re)measure shipped tasks' baselines
    python -m myriad.rl.shipped --reevaluate TASK ... --why "..."   # after a change to a task
"""

from __future__ import annotations

import argparse
import contextlib
import datetime
import io
import json
import math
import os
import tempfile
from importlib import resources

import torch

MANIFEST = "manifest.json"
# checkpoint keys a shipped policy keeps: the actor-critic with its normalizers, the asymmetric
# critic and its statistics, the epoch and env-steps it was trained for, the task state
KEPT = ("model", "assymetric_vf_nets", "central_val_stats", "epoch", "frame")
# the figures a shipped policy is checked on (`check_of`), better when higher; LOWER's when lower.
# Not terrain_level: the levels are the training's state, restored only at the run's env count
HIGHER = ("episode_reward", "consecutive_successes", "success_rate", "lift_rate", "speed",
          "goal_approach")
LOWER = ("tracking_error_lin", "tracking_error_yaw", "fingertip_distance", "goal_angle",
         "goal_distance", "pose_error", "fell")
# at most the manifest's own episode count: a difference its 100 episodes cannot show at
# CHECK_SIGMAS is not one training made
MAX_CHECK_EPISODES = 100
# the checked bound sits this many standard errors (of the check's episode count) from both the
# shipped figure and the fresh policy's
CHECK_SIGMAS = 3.0
# and over at least this many episodes: a rare failure (ANYmal's fall at the start, about one
# episode in a hundred, which the evaluation's spread hardly shows) must not decide it alone
MIN_CHECK_EPISODES = 16
# how far below its figure a shipped policy may fall where the test can afford to check it that
# closely: half a figure that is better higher, twice one (an error) that is better lower. A
# policy that kept only that much has lost what training gave it, fresh or not
SHORTFALL = {"higher": 0.5, "lower": 1.0}
# what a run fine-tuned from a shipped policy keeps of that policy's manifest entry
LINEAGE = ("command", "revision", "machine", "date", "env_steps", "wall_s")


def folder() -> str:
    """The package's policies folder (it may hold no policy yet)."""
    return str(resources.files("myriad") / "policies")


def manifest() -> dict:
    """Task name -> how its shipped policy was made and what `myriad eval` measured."""
    path = os.path.join(folder(), MANIFEST)
    if not os.path.isfile(path):
        return {}
    with open(path) as f:
        return json.load(f)


def checkpoint_for(task: str) -> str:
    """The shipped policy file of `task`, or a FileNotFoundError naming the tasks that have one."""
    entry = manifest().get(task)
    path = os.path.join(folder(), entry["file"]) if entry else None
    if path is None or not os.path.isfile(path):
        have = ", ".join(sorted(manifest())) or "none yet"
        raise FileNotFoundError(f"checkpoint=shipped: no policy of {task} ships with Myriad "
                                f"(shipped: {have}); train one with `myriad train task={task}`")
    return path


def lineage(task: str) -> dict:
    """What `task`'s shipped policy had been trained for, as a run fine-tuned from it records
    it (in its checkpoints and summary.json: `fine_tuned_from`): its command, revision, machine,
    date, and the env-steps and wall time of all the runs it came from."""
    entry = manifest()[task]
    return {k: entry.get(k) for k in LINEAGE}


def is_shipped(path: str) -> bool:
    return os.path.dirname(os.path.abspath(path)) == os.path.abspath(folder())


def weights_only(state: dict) -> bool:
    """A shipped policy (weights and normalizers, no optimizer): trained on from, not resumed."""
    return "optimizer" not in state


def stripped(state: dict, fp16: bool) -> dict:
    """What a shipped policy keeps of a run's checkpoint; with `fp16`, the networks' layers in
    float16 (the normalizers' statistics keep their precision)."""
    out = {k: state[k] for k in KEPT if k in state}
    task_state = (state.get("myriad") or {}).get("task")
    if task_state:
        out["myriad"] = {"task": task_state}
    if fp16:
        for key in ("model", "assymetric_vf_nets"):
            if key in out:
                out[key] = {k: v.half() if torch.is_tensor(v) and v.is_floating_point()
                            and "mean_std" not in k else v for k, v in out[key].items()}
    return out


def check_of(entry: dict) -> tuple[str, float, int] | None:
    """(measure, bound, episodes): the first figure of the entry's evaluation (its primary
    first) that tells the shipped policy from a fresh one (`entry["baseline"]`) in at most
    MAX_CHECK_EPISODES episodes. The bound lies between the two means: as near the shipped
    figure as SHORTFALL allows where that fits the episode budget, else halfway; the episodes
    are enough that it is CHECK_SIGMAS standard errors of each one's per-episode spread from
    its mean, so that the shipped policy passes and a fresh one fails. None if no figure
    does."""
    shipped_results = entry["eval"]["results"]
    fresh_results = (entry.get("baseline") or {}).get("results") or {}
    primary = entry["eval"]["primary"]
    for measure in [primary] + [m for m in shipped_results if m != primary]:
        if measure not in HIGHER + LOWER or measure not in fresh_results:
            continue
        mine, fresh = shipped_results[measure], fresh_results[measure]
        sign = 1 if measure in HIGHER else -1
        gap = sign * (mine["mean"] - fresh["mean"])
        if not gap > 0:
            continue
        near = SHORTFALL["higher" if sign > 0 else "lower"] * abs(mine["mean"])
        for tolerance in (min(gap / 2, near), gap / 2):     # the bound's distance from mine
            if not tolerance > 0:
                continue
            episodes = max(MIN_CHECK_EPISODES, math.ceil(max(
                (CHECK_SIGMAS * (mine["std"] or 0.0) / tolerance) ** 2,
                (CHECK_SIGMAS * (fresh["std"] or 0.0) / (gap - tolerance)) ** 2)))
            if episodes <= MAX_CHECK_EPISODES:
                return measure, mine["mean"] - sign * tolerance, episodes
    return None


def half_agrees(full: dict, half: dict, primary: str) -> bool:
    """Whether the float16 policy's evaluation (`half`) keeps the primary figure and every
    figure the check may use (HIGHER, LOWER) within the float32 policy's (`full`) own 95 %
    intervals: a primary at 0 either way (no success yet) says nothing about the rest."""
    for measure in full:
        if measure not in half or measure not in (primary,) + HIGHER + LOWER:
            continue
        width = full[measure]["half_width"]
        if width is None or abs(half[measure]["mean"] - full[measure]["mean"]) > width:
            return False
    return True


def fresh_policy(task: str, train_dir: str) -> str:
    """A checkpoint of `task`'s policy as training starts: its networks' initial weights (one
    epoch at learning rate 0, seed 0) with the observation statistics of that epoch's rollout."""
    from ..cli import main as cli
    with contextlib.redirect_stdout(io.StringIO()):
        code = cli(["train", f"task={task}", "max_iterations=1",
                    "train.params.config.learning_rate=0", "seed=0", f"train_dir={train_dir}",
                    "experiment=fresh"])
    path = os.path.join(train_dir, "fresh", "nn", "last.pth")
    if code or not os.path.isfile(path):
        raise RuntimeError(f"{task}: the fresh policy's one epoch failed (exit {code})")
    return path


def baseline(task: str, episodes: int = 100, num_envs: int | None = None) -> dict:
    """The evaluation a shipped policy gets, of a fresh policy of `task` (`fresh_policy`)."""
    with tempfile.TemporaryDirectory() as tmp:
        path = fresh_policy(task, tmp)
        with contextlib.redirect_stdout(io.StringIO()):
            report = _evaluate(task, path, episodes, os.path.join(tmp, "eval.json"), num_envs)
    return {"command": f"myriad train task={task} max_iterations=1 "
                       f"train.params.config.learning_rate=0 seed=0; myriad eval task={task} "
                       f"checkpoint=<its nn/last.pth> episodes={episodes} "
                       + (f"num_envs={num_envs} " if num_envs else "") + "seed=0",
            "results": report["results"], "episodes": report["episodes"],
            "num_envs": report["num_envs"], "date": datetime.date.today().isoformat()}


def _evaluate(task: str, path: str, episodes: int, output: str,
              num_envs: int | None = None) -> dict:
    from .evaluate import evaluate
    evaluate([f"task={task}", f"checkpoint={path}", f"episodes={episodes}", "seed=0",
              f"output={output}"] + ([f"num_envs={num_envs}"] if num_envs else []))
    with open(output) as f:
        return json.load(f)


def ship(checkpoint: str, command: str | None = None, episodes: int = 100,
         rev: str | None = None, machine: str | None = None,
         num_envs: int | None = None) -> dict:
    """Write `checkpoint`'s policy as its task's shipped policy, evaluated, into the manifest.
    `num_envs`: the evaluation's (default: eval's own); the run's own count restores what
    spans episodes in training (AnymalTerrain's levels), which another count cannot."""
    from .evaluate import checkpoint_task
    from .policy import read_checkpoint
    from .run import revision
    from .agent import atomic_json, atomic_write

    state = read_checkpoint(checkpoint)
    run_dir = os.path.dirname(os.path.dirname(os.path.abspath(checkpoint)))
    try:
        with open(os.path.join(run_dir, "summary.json")) as f:
            summary = json.load(f)
    except (OSError, ValueError) as err:
        raise ValueError(f"{checkpoint}: its run's summary.json is not readable ({err}): ship "
                         "a checkpoint of a finished `myriad train` run") from None
    # the checkpoint's own progress: a run's best checkpoint (nn/<Task>.pth) is not its last
    progress = {"env_steps": state.get("frame"),
                "wall_s": (state.get("myriad") or {}).get("wall_s"),
                "mean_reward": state.get("last_mean_rewards"), "epoch": state.get("epoch")}
    if state.get("epoch") == summary.get("checkpoint_epoch"):
        # the run's last checkpoint: its summary has that epoch's mean reward, while
        # rl_games' last_mean_rewards is the best of the run so far
        del progress["mean_reward"]
    summary |= {k: float(v) if k in ("wall_s", "mean_reward") else int(v)
                for k, v in progress.items() if v is not None}
    before = (state.get("myriad") or {}).get("fine_tuned_from")
    if before:      # a fine-tune of a shipped policy: the policy's training is both runs
        command = command or f"{before['command']}; then {summary.get('command')}"
        for key in ("env_steps", "wall_s"):
            summary[key] += before[key]
    task = checkpoint_task(checkpoint)
    figures = {}
    with tempfile.TemporaryDirectory() as tmp:
        for fp16 in (False, True):
            path = os.path.join(tmp, f"{task}{'_fp16' if fp16 else ''}.pth")
            torch.save(stripped(state, fp16), path)
            print(f"evaluating the {'float16' if fp16 else 'float32'} policy ...", flush=True)
            with contextlib.redirect_stdout(io.StringIO()):
                figures[fp16] = _evaluate(task, path, episodes, path + ".json", num_envs)
        full, half = (figures[f]["results"][figures[f]["primary"]] for f in (False, True))
        fp16 = half_agrees(figures[False]["results"], figures[True]["results"],
                          figures[False]["primary"])
        chosen = os.path.join(tmp, f"{task}{'_fp16' if fp16 else ''}.pth")
        with open(chosen, "rb") as f:
            data = f.read()
    report = figures[fp16]
    entry = {
        "file": f"{task}.pth", "bytes": len(data), "dtype": "float16" if fp16 else "float32",
        "command": command or summary.get("command"),
        "revision": rev or summary.get("revision") or revision(),
        "machine": machine or summary.get("machine"),
        "device": summary.get("device"), "num_envs": summary.get("num_envs"),
        "seed": summary.get("seed"), "env_steps": summary.get("env_steps"),
        "wall_s": summary.get("wall_s"), "training_mean_reward": summary.get("mean_reward"),
        "epoch": summary.get("epoch"),
        **({"fine_tuned_from": before} if before else {}),
        "eval": {"command": f"myriad eval task={task} checkpoint=shipped episodes={episodes} "
                            + (f"num_envs={num_envs} " if num_envs else "") + "seed=0",
                 "primary": report["primary"], "results": report["results"],
                 "episodes": report["episodes"], "num_envs": report["num_envs"],
                 "device": report["device"],
                 "float32_mean": full["mean"], "float16_mean": half["mean"]},
        "date": datetime.date.today().isoformat()}
    print("evaluating a fresh policy of the task ...", flush=True)
    entry["baseline"] = baseline(task, episodes, num_envs)
    if check_of(entry) is None:
        raise ValueError(f"{checkpoint}: no figure of its evaluation tells it from a fresh "
                         f"{task} policy within {MAX_CHECK_EPISODES} episodes (shipped "
                         f"{_figures(entry['eval']['results'])}; fresh "
                         f"{_figures(entry['baseline']['results'])}): not shipped")
    os.makedirs(folder(), exist_ok=True)
    target = os.path.join(folder(), f"{task}.pth")

    def write(tmp_path):
        with open(tmp_path, "wb") as f:
            f.write(data)
    atomic_write(target, write)
    entries = manifest()
    entries[task] = entry
    atomic_json(os.path.join(folder(), MANIFEST), dict(sorted(entries.items())))
    r = report["results"][report["primary"]]
    print(f"shipped {task}: {target} ({len(data) / 1024:.0f} KiB, {entry['dtype']}); "
          f"{report['primary']} {r['mean']:.4g} ± {r['half_width']:.3g} over "
          f"{report['episodes']} episodes (float32 {full['mean']:.4g}, float16 "
          f"{half['mean']:.4g})", flush=True)
    return entry


def _figures(results: dict) -> str:
    return ", ".join(f"{k} {v['mean']:.4g}" for k, v in results.items() if k in HIGHER + LOWER)


def _entry(task: str) -> tuple[dict, dict, int | None]:
    """The manifest, `task`'s entry in it, and the env count its evaluation was given (None:
    eval's own)."""
    entries = manifest()
    if task not in entries:
        raise ValueError(f"{task} ships no policy (shipped: {', '.join(sorted(entries))})")
    entry = entries[task]
    return entries, entry, (entry["eval"]["num_envs"] if "num_envs=" in entry["eval"]["command"]
                            else None)


def add_baselines(tasks: list[str], episodes: int | None = None) -> None:
    """Measure (again) the fresh-policy baselines of shipped tasks, into the manifest: as many
    episodes on as many envs as the shipped policy's evaluation."""
    from .agent import atomic_json
    for task in tasks:
        entries, entry, num_envs = _entry(task)
        print(f"{task}: evaluating a fresh policy ...", flush=True)
        entry["baseline"] = baseline(task, episodes or entry["eval"]["episodes"], num_envs)
        check = check_of(entry)
        print(f"{task}: fresh {_figures(entry['baseline']['results'])}; shipped "
              f"{_figures(entry['eval']['results'])}; checked: "
              + (f"{check[0]} beyond {check[1]:.4g} over {check[2]} episodes" if check
                 else "NO FIGURE tells the two apart"), flush=True)
        atomic_json(os.path.join(folder(), MANIFEST), dict(sorted(entries.items())))


def reevaluate(tasks: list[str], why: str) -> None:
    """Evaluate shipped policies again, as they are, and fresh policies of their tasks, after a
    change to the tasks (`why`): the manifest keeps how each was trained and gets the new
    figures, with this tree's revision and the reason. A policy that no figure tells from a
    fresh one any more is not kept silently: the error names it, to withdraw or retrain."""
    from .agent import atomic_json
    from .run import revision
    for task in tasks:
        entries, entry, num_envs = _entry(task)
        episodes = entry["eval"]["episodes"]
        print(f"{task}: evaluating the shipped policy ...", flush=True)
        with tempfile.TemporaryDirectory() as tmp, contextlib.redirect_stdout(io.StringIO()):
            report = _evaluate(task, checkpoint_for(task), episodes,
                               os.path.join(tmp, "eval.json"), num_envs)
        ran = entry["dtype"]
        entry["eval"] |= {"results": report["results"], "episodes": report["episodes"],
                          "num_envs": report["num_envs"], "device": report["device"],
                          f"{ran}_mean": report["results"][report["primary"]]["mean"],
                          "revision": revision(), "date": datetime.date.today().isoformat(),
                          "why": why}
        # the other precision's figure belongs to the old task: the file holds only this one
        entry["eval"].pop("float32_mean" if ran == "float16" else "float16_mean", None)
        print(f"{task}: evaluating a fresh policy ...", flush=True)
        entry["baseline"] = baseline(task, episodes, num_envs)
        if check_of(entry) is None:
            raise ValueError(f"{task}: no figure tells the shipped policy from a fresh one now "
                             f"(shipped {_figures(entry['eval']['results'])}; fresh "
                             f"{_figures(entry['baseline']['results'])}): withdraw or retrain it")
        atomic_json(os.path.join(folder(), MANIFEST), dict(sorted(entries.items())))
        r = report["results"][report["primary"]]
        print(f"{task}: {report['primary']} {r['mean']:.4g} ± {r['half_width']:.3g} over "
              f"{report['episodes']} episodes; fresh {_figures(entry['baseline']['results'])}",
              flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description="Ship a run's policy with Myriad: strip its "
                                 "checkpoint, evaluate it and a fresh policy of its task, and "
                                 "write the manifest entry.")
    ap.add_argument("checkpoint", nargs="?", help="a finished run's nn/last.pth, or its best "
                    "(nn/<Task>.pth)")
    ap.add_argument("--baseline", nargs="+", metavar="TASK",
                    help="only measure these shipped tasks' fresh-policy baselines")
    ap.add_argument("--reevaluate", nargs="+", metavar="TASK",
                    help="evaluate these shipped policies and fresh ones again after a change "
                         "to their tasks (give --why)")
    ap.add_argument("--why", help="with --reevaluate: the change, for the manifest")
    ap.add_argument("--command", help="the command that trained it (default: its summary's)")
    ap.add_argument("--episodes", type=int, help="of each evaluation (default 100; with "
                    "--baseline, the shipped policy's own evaluation's)")
    ap.add_argument("--revision", help="the code revision it was trained with (default: its "
                    "summary's, else this tree's)")
    ap.add_argument("--machine", help="the machine it was trained on (default: its summary's)")
    ap.add_argument("--num-envs", type=int, help="envs of the evaluation (default: eval's; "
                    "the run's own count restores AnymalTerrain's levels)")
    args = ap.parse_args()
    if args.baseline:
        add_baselines(args.baseline, args.episodes)
        return
    if args.reevaluate:
        if not args.why:
            ap.error("--reevaluate needs --why: the change to the tasks")
        reevaluate(args.reevaluate, args.why)
        return
    if not args.checkpoint:
        ap.error("give a checkpoint to ship, or --baseline TASK ...")
    ship(args.checkpoint, args.command, args.episodes or 100, args.revision, args.machine,
         args.num_envs)


if __name__ == "__main__":
    main()
