"""`myriad train` and `myriad play`: Hydra config composition, device and CPU-profile choice,
and the playback of a trained policy into a video rendered by MuJoCo.

`multi_gpu=true` under torchrun trains in several processes, one per GPU (or per CPU process):
`torchrun --nproc_per_node=K -m myriad.train task=Ant multi_gpu=true ...`. Each process reads its
place from torchrun's environment (RANK, LOCAL_RANK, WORLD_SIZE, MASTER_ADDR, MASTER_PORT),
takes cuda:LOCAL_RANK with NCCL on GPUs or the CPU with gloo, builds num_envs / K envs with seed
+ rank, and trains on rl_games' multi-GPU path (rl/agent.py); rank 0 alone chooses the run
folder, reads a checkpoint to resume from (and sends it to the others) and writes the files.
"""

from __future__ import annotations

import copy
import difflib
import glob
import json
import math
import contextlib
import os
import platform
import subprocess
import time

from omegaconf import OmegaConf

# How long a process waits in a collective (all-reduce, broadcast, barrier) for the others before
# it fails: long enough for a first run's kernel compilation, which the processes of a machine do
# one after another. A process that crashes does not make the others wait that long: torchrun
# stops them all as soon as one fails, and gloo fails a collective whose peer has gone.
PROCESS_GROUP_TIMEOUT_S = 30 * 60


def _merge(into: dict, changes: dict, path: str = "", kept: tuple = ()) -> None:
    """Set `changes` in `into`, descending into nested sections (a central_value_config's
    minibatch_size changes alone), except at the dotted paths `kept` and below them (what the
    command line set; `path` is `into`'s own)."""
    for key, value in changes.items():
        where = f"{path}.{key}"
        if any(where == k or where.startswith(k + ".") for k in kept):
            continue
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _merge(into[key], value, where, kept)
        else:
            into[key] = value


def compose(overrides: list[str]):
    """config.yaml + task/<T>.yaml + train/<T>PPO.yaml with command-line overrides (Hydra).

    Every key is checked first (`check_overrides`): an unknown one fails naming the nearest valid
    keys, whether it is written `key=`, `+key=` or `++key=`."""
    from hydra import compose as hydra_compose, initialize_config_module

    with initialize_config_module(config_module="myriad.cfg", version_base=None):
        def composed(items):
            return hydra_compose(config_name="config", overrides=items)

        return composed(check_overrides(overrides, composed))


# Sections whose keys the command line may add although the task's YAML leaves them out: a
# task's `randomization` (its YAML holds only `enabled: false`; what goes below is checked by
# myriad.randomization.Randomizer when the task is built) and the SimParams settings of its
# `sim.physx` (`tasks.base.PHYSX_KEYS`, e.g. contacts_per_env, limit_block_contacts)
from ..randomization import SECTION_KEYS as RANDOMIZATION_KEYS  # noqa: E402
from ..tasks.base import PHYSX_KEYS  # noqa: E402
OPEN_SECTIONS = {"task.randomization": tuple(RANDOMIZATION_KEYS),
                 "task.sim.physx": tuple(PHYSX_KEYS) + ("solver_type",)}


def check_overrides(overrides: list[str], composed) -> list[str]:
    """The overrides, each key checked against the configs it would change.

    Config-group choices (`task=`, `train=`) and `hydra.*` go to Hydra as they are; every other
    key must exist in config.yaml, the chosen task/<T>.yaml or train/<T>PPO.yaml (as composed by
    `composed(group choices)`), also when written `+key=` or `++key=`: this project adds no keys
    from the command line. Unknown keys raise one ValueError listing, for each, the nearest
    valid dotted keys and the valid keys at its level. Keys of a dict value
    (`task.env.plane={restitution: 0.5}`) are checked alike. The returned overrides are what
    Hydra accepts: `+` dropped (the key exists), `++` for the keys `OPEN_SECTIONS` lets it add.
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser
    from hydra.core.override_parser.types import OverrideType

    parsed = OverridesParser.create().parse_overrides(list(overrides))
    groups = _config_groups()

    def is_group(o) -> bool:
        return o.is_hydra_override() or o.key_or_group in groups or "/" in o.key_or_group

    tree = OmegaConf.to_container(composed([o.input_line for o in parsed if is_group(o)]),
                                  resolve=False)
    checked, problems = [], []
    for o in parsed:
        if is_group(o):
            checked.append(o.input_line)
            continue
        value = None if o.type == OverrideType.DEL else o.value()
        found = [_find_key(tree, path) for path in _value_paths(o.key_or_group, value)]
        errors = [f for f in found if f not in ("exists", "new")]
        if errors:
            problems += [f"{o.input_line}: {error}" for error in errors]
            continue
        line = o.input_line.strip()
        if o.type != OverrideType.DEL:
            line = line.lstrip("+")
            if "new" in found:
                line = "++" + line
        checked.append(line)
    if problems:
        task = tree.get("task", {}).get("name")
        train = next((str(o.value()) for o in parsed if o.key_or_group == "train"
                      and o.type != OverrideType.DEL), f"{task}PPO")
        where = f"config.yaml, task/{task}.yaml, train/{train}.yaml"
        raise ValueError("unknown config key" + ("s" if len(problems) > 1 else "")
                         + f" ({where}):\n  " + "\n  ".join(problems))
    return checked


def _config_groups() -> set[str]:
    """The config groups of myriad.cfg (its folders: task, train)."""
    from importlib import resources

    return {p.name for p in resources.files("myriad.cfg").iterdir()
            if p.is_dir() and not p.name.startswith(("_", "."))}


def _value_paths(key: str, value) -> list[str]:
    """`key`, or for a dict value the dotted key of each of its leaves."""
    if not isinstance(value, dict) or not value:
        return [key]
    paths = []
    for k, v in value.items():
        paths += _value_paths(f"{key}.{k}", v)
    return paths


def _find_key(tree: dict, path: str) -> str:
    """"exists", "new" (a key `OPEN_SECTIONS` lets the command line add), or the message
    naming the unknown key, the nearest valid keys and the valid keys at its level."""
    parts = path.split(".")
    node = tree
    for i, part in enumerate(parts):
        if part in OPEN_SECTIONS.get(".".join(parts[:i]), ()):
            for rest in parts[i:]:      # below: open, checked by the Randomizer
                if not (isinstance(node, dict) and rest in node):
                    return "new"
                node = node[rest]
            return "exists"
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
            node = node[int(part)]
        else:
            return _unknown_key(tree, path, parts[:i], node)
    return "exists"


def _unknown_key(tree: dict, path: str, parent: list[str], node) -> str:
    from ..tasks import _key_paths

    paths = _key_paths(tree)
    name = path.rsplit(".", 1)[-1]
    nearest = [p for p in paths if p.rsplit(".", 1)[-1] == name]    # the same name elsewhere
    close = difflib.get_close_matches(path, paths, n=5, cutoff=0.6)
    if close:   # the nearest, and those about as near (a shared long prefix lifts every ratio)
        best = difflib.SequenceMatcher(None, path, close[0]).ratio()
        nearest += [p for p in close
                    if difflib.SequenceMatcher(None, path, p).ratio() >= best - 0.1]
    nearest = [p for p in dict.fromkeys(nearest) if not path.startswith(p + ".")][:5]
    where = ".".join(parent) or "the top level"
    message = f"no key {path}"
    if nearest:
        message += f" (did you mean {' or '.join(nearest)}?)"
    if isinstance(node, dict):
        valid = sorted(set(node) | set(OPEN_SECTIONS.get(where, ())))
        return f"{message}; the keys of {where}: {', '.join(map(str, valid))}"
    return f"{message}; {where} is {node!r}, which has no keys"


def resolve_device(device) -> str:
    """`device=` of the command line as a torch device name: auto (cuda:0 when a GPU is present,
    else cpu), cpu, cuda (cuda:0) or cuda:N. Another name, or a GPU that is not there, fails in
    one line."""
    import torch

    from ..physics.runtime import device_name

    name = str(device).strip()
    if name == "auto":
        return "cuda:0" if torch.cuda.is_available() else "cpu"
    try:
        name = device_name(name)
    except ValueError:
        raise ValueError(f"device={device}: expected auto, cpu, cuda or cuda:N") from None
    if name == "cpu":
        return name
    gpu, count = int(name[5:]), torch.cuda.device_count()
    if gpu >= count:
        available = ", ".join(["cpu"] + [f"cuda:{k}" for k in range(count)])
        raise ValueError(f"device={device}: no such GPU ({count} CUDA device"
                         f"{'' if count == 1 else 's'} visible); available: {available}")
    return name


def given_keys(overrides) -> set[str]:
    """The keys the command line set (`key=`, `+key=`, `++key=`, `~key=`)."""
    return {o.split("=", 1)[0].lstrip("+~") for o in overrides if "=" in o}


def task_and_train_configs(cfg, overrides=(), processes: int = 1) -> tuple[dict, dict, str]:
    """Plain dicts of the task and train configs with the top-level options applied.

    Numbers are checked here, before anything is built, each failure naming its key and value
    (`config_int`: integer keys refuse fractions such as 2.5 and accept 2.0). The checked
    top-level values are written back into cfg as ints and floats.

    `processes` > 1 (multi_gpu): the configs of one process of that many. num_envs and the
    minibatch sizes are the totals; each process gets its share (num_envs must divide), so that
    an epoch makes as many gradient steps, each over as many samples, as in one process."""
    from ..tasks import config_float, config_int

    device = resolve_device(cfg.device)
    for key, minimum in (("num_envs", 1), ("max_iterations", 1), ("seed", None),
                         ("num_steps", 1)):
        if cfg[key] is not None or key in ("seed", "num_steps"):
            cfg[key] = config_int(cfg[key], key, minimum)
    if cfg.max_time_s is not None:
        cfg.max_time_s = config_float(cfg.max_time_s, "max_time_s")
    task_cfg = OmegaConf.to_container(cfg.task, resolve=True)
    train_cfg = OmegaConf.to_container(cfg.train, resolve=True)
    cpu_task, cpu_train = task_cfg.pop("cpu", {}), train_cfg.pop("cpu", {})
    if not device.startswith("cuda"):
        # CPU profile: fewer envs and a minibatch to match, perhaps a smaller network (its
        # `network` section; unless the user chose num_envs)
        if cfg.num_envs is None:
            # what the command line set wins over the profile, in the task as in training (a
            # dotted key: `task=X` and `train=Y` choose the configs the profile then adjusts)
            kept = tuple(k for k in given_keys(overrides) if "." in k)
            _merge(task_cfg["env"], cpu_task, "task.env", kept)
            cpu_train = dict(cpu_train)
            _merge(train_cfg["params"]["network"], cpu_train.pop("network", {}),
                   "train.params.network", kept)
            _merge(train_cfg["params"]["config"], cpu_train, "train.params.config", kept)
    if cfg.num_envs is not None:
        task_cfg["env"]["numEnvs"] = cfg.num_envs
    if cfg.get("motion_file") is not None:
        if "motion_file" not in task_cfg["env"]:
            raise ValueError(f"motion_file={cfg.motion_file}: task {task_cfg['name']} takes no "
                             "motion clips (HumanoidAMP does)")
        task_cfg["env"]["motion_file"] = str(cfg.motion_file)
    env, ppo = task_cfg["env"], train_cfg["params"]["config"]
    for section, prefix, keys in ((env, "task.env", ("numEnvs", "episodeLength",
                                                     "controlFrequencyInv")),
                                  (ppo, "train.params.config", ("horizon_length",
                                                                "minibatch_size"))):
        for key in keys:
            if key in section:
                section[key] = config_int(section[key], f"{prefix}.{key}", minimum=1)
    if processes > 1:
        total = env["numEnvs"]
        if total % processes:
            raise ValueError(f"num_envs={total}: multi_gpu=true shares the envs among the "
                             f"{processes} processes: give a multiple of {processes}")
        env["numEnvs"] = total // processes
        for section in (ppo, ppo.get("central_value_config") or {}):
            if "minibatch_size" in section:
                section["minibatch_size"] = max(1, int(section["minibatch_size"]) // processes)
    # PPO splits num_envs × horizon_length samples into equal minibatches, and so does an
    # asymmetric critic (central_value_config): keep each minibatch size a divisor, as close
    # as possible below the configured one
    batch = env["numEnvs"] * ppo["horizon_length"]
    for name, section in (("minibatch_size", ppo),
                          ("central_value_config.minibatch_size",
                           ppo.get("central_value_config") or {})):
        if "minibatch_size" not in section:
            continue
        count = max(1, math.ceil(batch / section["minibatch_size"]))
        while batch % count:
            count += 1
        if batch // count != section["minibatch_size"]:
            print(f"{name} {section['minibatch_size']} -> {batch // count}: {count} equal "
                  f"minibatches of num_envs × horizon_length = {batch} samples")
            section["minibatch_size"] = batch // count
    if processes > 1:
        print(f"multi_gpu: {processes} processes × {env['numEnvs']} envs (num_envs "
              f"{env['numEnvs'] * processes}), minibatches of {ppo['minibatch_size']} per process")
    if cfg.max_iterations is not None:
        ppo["max_epochs"] = cfg.max_iterations
    return task_cfg, train_cfg, device


def free_experiment_name(train_dir: str, name: str) -> str:
    """`name`, or name_2, name_3 ... so that an earlier run's files are never overwritten."""
    candidate, k = name, 1
    while os.path.exists(os.path.join(train_dir, candidate)):
        k += 1
        candidate = f"{name}_{k}"
    return candidate


def newest_run(train_dir: str, task: str) -> str | None:
    """Folder of the newest run of `task` under train_dir that has a checkpoint, or None."""
    runs = []
    for path in glob.glob(os.path.join(train_dir, "*", "summary.json")):
        try:
            with open(path) as f:
                same_task = json.load(f).get("task") == task
        except (OSError, ValueError):     # a summary being written, or damaged: not a candidate
            continue
        folder = os.path.dirname(path)
        if same_task and os.path.isfile(os.path.join(folder, "nn", "last.pth")):
            runs.append((os.path.getmtime(os.path.join(folder, "nn", "last.pth")), folder))
    return max(runs)[1] if runs else None


def network_choices(cfg, overrides: list[str], train_cfg: dict) -> list[dict]:
    """The train configs whose networks a checkpoint of the task may hold: `train_cfg` (as
    composed for this device and num_envs) and, where the task's CPU profile changes a network
    (ShadowHand's MLP, the OpenAI LSTM's units) and `train_cfg` does not have it, the same with
    the profile's networks: a policy trained on a CPU without num_envs= (as every shipped one)
    then plays, evaluates and trains on on a GPU or at any env count. What the command line set
    wins over the profile, as in training."""
    profile = OmegaConf.to_container(cfg.train, resolve=True).get("cpu", {})
    kept = tuple(k for k in given_keys(overrides) if "." in k)
    other = copy.deepcopy(train_cfg)
    params = other["params"]
    _merge(params["network"], profile.get("network", {}), "train.params.network", kept)
    critic = params["config"].get("central_value_config")
    if critic and "network" in (profile.get("central_value_config") or {}):
        _merge(critic["network"], profile["central_value_config"]["network"],
               "train.params.config.central_value_config.network", kept)
    return [train_cfg] if other == train_cfg else [train_cfg, other]


def fitting_train_config(checkpoint: str, choices: list[dict], task) -> dict:
    """The first of `choices` (`network_choices`) whose networks the checkpoint's weights fit,
    saying so when it is the CPU profile's (a shipped policy trained on on a GPU); none fits:
    the first, and training fails naming the mismatch as it loads the weights."""
    from .policy import load_network, read_checkpoint

    if len(choices) == 1:
        return choices[0]
    try:
        _, chosen = load_network(read_checkpoint(checkpoint), choices, task.num_obs,
                                 task.num_actions, type(task).__name__, checkpoint)
    except ValueError:
        return choices[0]
    if chosen is not choices[0]:
        print(f"{checkpoint} holds the networks of the task's CPU profile: training on with "
              "them", flush=True)
    return chosen


def checkpoint_and_experiment(cfg, task: str) -> tuple[str | None, str]:
    """The checkpoint to resume from (or None) and the run folder name, from `checkpoint=`,
    `resume=auto` and `experiment=`."""
    if cfg.resume not in (None, "auto"):
        raise ValueError(f"resume={cfg.resume}: the only value is 'auto' (the newest checkpoint "
                         "of experiment=..., or of the task's newest run); give a file with "
                         "checkpoint=PATH")
    if cfg.resume and cfg.checkpoint:
        raise ValueError("give checkpoint=PATH or resume=auto, not both")
    checkpoint = cfg.checkpoint
    if checkpoint == "shipped":          # fine-tuned in a new run folder
        from .shipped import checkpoint_for
        checkpoint = checkpoint_for(task)
    # Hydra reads experiment=nan or experiment=7 as numbers: a folder name is text
    experiment = None if cfg.experiment is None else str(cfg.experiment)
    if cfg.resume:
        folder = (os.path.join(cfg.train_dir, experiment) if experiment
                  else newest_run(cfg.train_dir, task))
        last = os.path.join(folder, "nn", "last.pth") if folder else None
        if last and os.path.isfile(last):
            checkpoint = last
        else:
            print(f"resume=auto: no checkpoint of {experiment or task} under "
                  f"{cfg.train_dir}/ yet: starting a new run", flush=True)
    if checkpoint and not os.path.isfile(checkpoint):
        raise FileNotFoundError(f"checkpoint={checkpoint}: no such file")
    folder = os.path.dirname(os.path.abspath(checkpoint)) if checkpoint else ""
    if experiment is None and os.path.basename(folder) == "nn":
        return checkpoint, os.path.basename(os.path.dirname(folder))  # resume in its run folder
    # a checkpoint from elsewhere starts a new run folder
    return checkpoint, experiment or free_experiment_name(cfg.train_dir, task)


def processes_from_env(cfg) -> dict | None:
    """multi_gpu=true: this process's place among those torchrun started (rank, local_rank,
    world_size from its environment), its device (cuda:LOCAL_RANK, or the CPU) and the process
    group's backend (NCCL on GPUs, gloo on CPUs). multi_gpu=false: None."""
    if not isinstance(cfg.multi_gpu, bool):
        raise ValueError(f"multi_gpu={cfg.multi_gpu}: true or false")
    if not cfg.multi_gpu:
        return None
    names = ("RANK", "LOCAL_RANK", "WORLD_SIZE", "MASTER_ADDR", "MASTER_PORT")
    missing = [name for name in names if name not in os.environ]
    if missing:
        raise ValueError("multi_gpu=true: start one process per GPU (or CPU process) with "
                         "torchrun: torchrun --nproc_per_node=K -m myriad.train task=... "
                         f"multi_gpu=true ({', '.join(missing)} not set)")
    rank, local_rank, world_size = (int(os.environ[name]) for name in names[:3])
    place = {"rank": rank, "local_rank": local_rank, "world_size": world_size}
    if str(cfg.device).strip() not in ("auto", "cpu", "cuda"):
        raise ValueError(f"device={cfg.device}: with multi_gpu=true give device=cuda, cpu or "
                         "auto: each process takes the GPU of its local rank, cuda:LOCAL_RANK "
                         "(choose the GPUs with CUDA_VISIBLE_DEVICES)")
    if not resolve_device(cfg.device).startswith("cuda"):
        return {**place, "device": "cpu", "backend": "gloo"}
    import torch

    count = torch.cuda.device_count()
    if local_rank >= count:
        raise ValueError(f"multi_gpu=true: local rank {local_rank} has no GPU of its own ({count} "
                         f"visible): start at most {count} processes per machine "
                         "(torchrun --nproc_per_node)")
    return {**place, "device": f"cuda:{local_rank}", "backend": "nccl"}


def start_process_group(distributed: dict) -> None:
    """Start the process group ourselves, with the backend this device needs: rl_games'
    multi-GPU set-up hardcodes NCCL, which has no CPU support (see MyriadAgent.join_processes)."""
    import datetime

    import torch
    import torch.distributed as dist

    extra = {}
    if distributed["backend"] == "nccl":
        torch.cuda.set_device(distributed["local_rank"])
        extra["device_id"] = torch.device(distributed["device"])
    dist.init_process_group(distributed["backend"], rank=distributed["rank"],
                            world_size=distributed["world_size"],
                            timeout=datetime.timedelta(seconds=PROCESS_GROUP_TIMEOUT_S), **extra)


def train(overrides: list[str]) -> int:
    cfg = compose(overrides)
    distributed = processes_from_env(cfg)
    with contextlib.ExitStack() as stack:
        if distributed is not None and distributed["rank"] != 0:
            # rank 0 prints the progress; the others only their warnings and errors (stderr)
            stack.enter_context(contextlib.redirect_stdout(
                stack.enter_context(open(os.devnull, "w"))))
        return _train(cfg, overrides, distributed)


def _train(cfg, overrides: list[str], distributed: dict | None) -> int:
    from ..physics.runtime import load_kernels
    from ..tasks import TASKS
    from .agent import TrainingStopped, from_rank_0
    from .train import seed_all, train as run_training

    processes = 1
    if distributed is not None:
        cfg.device, processes = distributed["device"], distributed["world_size"]
    task_cfg, train_cfg, device = task_and_train_configs(cfg, overrides, processes)
    name = task_cfg["name"]
    if distributed is None:
        checkpoint, experiment = checkpoint_and_experiment(cfg, name)
    max_time = math.inf if cfg.max_time_s is None else float(cfg.max_time_s)
    if not max_time > 0:
        raise ValueError(f"max_time_s={cfg.max_time_s}: must be > 0")
    for key in ("capture_step", "capture_update"):
        if not isinstance(cfg[key], bool):
            raise ValueError(f"{key}={cfg[key]!r}: must be true or false")
    if distributed is not None:
        start_process_group(distributed)
    task = None
    try:
        if distributed is not None:
            def choose():
                # rank 0 names the run folder (and makes it, so that the name is taken) for all
                chosen = checkpoint_and_experiment(cfg, name)
                for sub in ("nn", "summaries"):
                    os.makedirs(os.path.join(cfg.train_dir, chosen[1], sub), exist_ok=True)
                return chosen
            checkpoint, experiment = from_rank_0(choose, distributed)

        def load():
            print(f"loading the physics kernels for {device}", flush=True)
            load_kernels(device, report=lambda line: print(line, flush=True))
        if distributed is None:
            load()
        else:
            # the first process of each machine compiles what its kernel cache lacks; the others
            # then load it from the cache instead of compiling it too
            import torch.distributed as dist

            if distributed["local_rank"] == 0:
                load()
            dist.barrier()
            if distributed["local_rank"] != 0:
                load()
        t0 = time.monotonic()
        print(f"building {name}: {task_cfg['env']['numEnvs']} envs on {device}", flush=True)
        # the task's start-up draws from the run's seed (each process its own, as the agent's)
        seed_all(int(cfg.seed) + (0 if distributed is None else distributed["rank"]))
        task = TASKS[name](task_cfg, device=device)
        task.capture_step = cfg.capture_step
        print(f"built in {time.monotonic() - t0:.1f} s", flush=True)
        if checkpoint:
            train_cfg = from_rank_0(lambda: fitting_train_config(
                checkpoint, network_choices(cfg, overrides, train_cfg), task), distributed)
        # the page only watches: it never pauses or resets training; rank 0 serves it
        task.viewer = open_viewer(cfg, task, controls=False) \
            if distributed is None or distributed["rank"] == 0 else None
        minibatch = train_cfg["params"]["config"]["minibatch_size"]
        run = {"train_dir": cfg.train_dir, "experiment": experiment, "max_time_s": max_time,
               "capture_update": cfg.capture_update,
               "describe": {"task": name, "device": device,
                            "num_envs": task.num_envs * processes, "seed": int(cfg.seed),
                            "minibatch_size": minibatch * processes,
                            "machine": f"{os.cpu_count()} CPU cores ({cpu_name()})" + (
                                "" if device == "cpu" else f", {_gpu_name(device)}"),
                            "command": "myriad train " + " ".join(overrides),
                            "revision": revision()}}
        if distributed is not None:
            run["describe"]["processes"] = processes
            run["distributed"] = distributed
        try:
            summary = run_training(task, train_cfg, run, int(cfg.seed), checkpoint)
        except TrainingStopped as stop:
            if distributed is not None and distributed["rank"] != 0:
                return 128 + stop.signum
            with open(os.path.join(cfg.train_dir, experiment, "summary.json")) as f:
                summary = json.load(f)
            print(f"{stop}: nn/last.pth holds epoch {summary['checkpoint_epoch']} "
                  f"({summary['env_steps']:,} env-steps); resume with checkpoint="
                  f"{summary['checkpoint']} or resume=auto", flush=True)
            return 128 + stop.signum
    finally:
        if task is not None and task.viewer is not None:
            task.viewer.close("training ended: this page no longer updates")
        if distributed is not None:
            import torch.distributed as dist

            if dist.is_initialized():
                dist.destroy_process_group()
    if not summary:         # a process other than rank 0: nothing to report
        return 0
    if summary["mean_reward"] is None:
        rewards = "no episode finished yet (train longer to see a reward)"
    else:
        rewards = (f"mean reward {summary['mean_reward']:.1f}, best "
                   f"{summary['best_mean_reward']:.1f}")
    print(f"done: {summary['env_steps']:,} env-steps in {summary['wall_s']:.0f} s "
          f"({summary['env_steps_per_s']:,} env-steps/s); {rewards}; checkpoint "
          f"{summary['checkpoint']} (epoch {summary['checkpoint_epoch']})")
    return 0


def _gpu_name(device: str) -> str:
    import torch

    return torch.cuda.get_device_name(torch.device(device))


def cpu_name() -> str:
    """The processor's model name (Linux), else its architecture."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.machine()


def revision() -> str:
    """The source tree's git revision (+dirty when it has changes), or the package's version."""
    here = os.path.dirname(os.path.abspath(__file__))
    try:
        rev = subprocess.run(["git", "describe", "--always", "--dirty=+dirty"], cwd=here,
                             capture_output=True, text=True, timeout=10, check=True)
        return rev.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        from importlib.metadata import version
        return f"myriad {version('myriad')}"


def policy_checkpoint(cfg, task: str) -> str:
    """The checkpoint `play` and `eval` run: checkpoint=PATH; checkpoint=shipped, the policy that
    comes with Myriad (`shipped.py`); none given, the newest run's nn/last.pth, or the shipped
    policy while the task has no run under train_dir."""
    from . import shipped

    if cfg.checkpoint == "shipped":
        return shipped.checkpoint_for(task)
    if cfg.checkpoint:
        if not os.path.isfile(str(cfg.checkpoint)):
            raise FileNotFoundError(f"checkpoint={cfg.checkpoint}: no such file")
        return str(cfg.checkpoint)
    folder = newest_run(cfg.train_dir, task)
    if folder is not None:
        return os.path.join(folder, "nn", "last.pth")
    try:
        path = shipped.checkpoint_for(task)
    except FileNotFoundError:
        raise FileNotFoundError(f"no trained {task} run under {cfg.train_dir}/ and no shipped "
                                f"{task} policy: train one with `myriad train task={task}` or "
                                "pass checkpoint=<file.pth>") from None
    print(f"no {task} run under {cfg.train_dir}/: running the shipped policy ({path})",
          flush=True)
    return path


def output_beside(checkpoint: str, train_dir: str, file: str) -> str:
    """Where play's video and eval's report go by default: the checkpoint's run folder, or for
    a shipped policy train_dir/shipped/ (never inside the installed package)."""
    from . import shipped

    if shipped.is_shipped(checkpoint):
        return os.path.join(train_dir, "shipped", file)
    return os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(checkpoint))), file)


def open_viewer(cfg, task, controls: bool):
    """The live page of `viewer=web` for `task`'s envs (None without `viewer`)."""
    if cfg.viewer is None:
        return None
    if cfg.viewer != "web":
        raise ValueError(f"viewer={cfg.viewer}: the one viewer is `web` (a page in the browser)")
    from ..viewer import require_viser, serve
    from ..viewer.web import TRAINING_BUDGET

    try:
        require_viser()
    except ImportError as err:
        raise ValueError(str(err)) from None
    return serve(task.envs, port=int(cfg.viewer_port), host=str(cfg.viewer_host),
                 shown=int(cfg.viewer_envs), controls=controls,
                 markers=getattr(task, "video_markers", None),
                 budget=None if controls else TRAINING_BUDGET)    # training runs beside it


def play(overrides: list[str]) -> int:
    """Run a trained policy in one env and write a video of it; with `viewer=web`, in a few envs
    drawn live on a page (pause, single step, reset, speed), until Ctrl-C unless `num_steps` is
    given, and with a video only if `video` is."""
    import torch

    from ..tasks import TASKS
    from .policy import load_policy
    from .train import seed_all
    from .video import VideoWriter

    cfg = compose(overrides)
    task_cfg, train_cfg, device = task_and_train_configs(cfg, overrides)
    name = task_cfg["name"]
    checkpoint = policy_checkpoint(cfg, name)
    given = given_keys(overrides)
    watching = cfg.viewer is not None
    task_cfg["env"]["numEnvs"] = int(cfg.num_envs or (cfg.viewer_envs if watching else 1))
    seed_all(int(cfg.seed))
    task = TASKS[name](task_cfg, device=device)
    # the task as training left it where it fits (HumanoidAMP's clip; AnymalTerrain's levels
    # at the run's env count), as eval does
    policy = load_policy(checkpoint, network_choices(cfg, overrides, train_cfg), task,
                         restore_task=True)
    video = cfg.video or output_beside(checkpoint, cfg.train_dir, f"{name}.mp4")
    steps = None if watching and "num_steps" not in given else int(cfg.num_steps)
    fps = round(1.0 / task.dt)
    viewer = open_viewer(cfg, task, controls=True)
    obs = task.reset()["obs"]
    episode_reward, finished = torch.zeros(task.num_envs, device=task.device), []
    writer = VideoWriter(video, task.envs, fps=fps, size=tuple(cfg.video_size), task=task) \
        if not watching or "video" in given else None
    step = 0

    def show(step):
        viewer.show_progress(f"**play** step {step}, env 0's episode reward "
                             f"{float(episode_reward[0]):.1f}")
    if viewer is not None:
        show(0)           # from the start: a page paused before the first step says where
    try:
        with writer if writer is not None else contextlib.nullcontext():
            if writer is not None:
                writer.add_frame()
            done = None
            while steps is None or step < steps:
                if viewer is not None:
                    if viewer.take("reset"):
                        shown = torch.as_tensor(viewer.shown_envs, device=task.device)
                        obs, done = task.reset(shown)["obs"], None
                        episode_reward[shown] = 0.0
                    if viewer.paused and not viewer.take("step"):
                        time.sleep(0.02)
                        continue
                started = time.monotonic()
                with torch.no_grad():
                    obs, reward, done, _ = task.step(policy(obs, done))
                obs = obs["obs"]
                episode_reward += reward
                if bool(done[0]):
                    finished.append(float(episode_reward[0]))
                episode_reward[done.bool()] = 0.0
                if writer is not None:
                    writer.add_frame()
                step += 1
                if steps is not None and step % 200 == 0:
                    print(f"  {step}/{steps} steps", flush=True)
                if viewer is not None:         # real time, or slower
                    show(step)
                    time.sleep(max(0.0, task.dt / viewer.speed - (time.monotonic() - started)))
    finally:
        if viewer is not None:
            viewer.close(f"play ended after {step} steps: this page no longer updates")
    shown = f"episode rewards {[round(r, 1) for r in finished]}" if finished else \
        f"reward so far {float(episode_reward[0]):.1f} (episode not finished)"
    wrote = f"wrote {video} " if writer is not None else ""
    print(f"{wrote}({step} steps at {fps} fps); env 0: {shown}")
    return 0
