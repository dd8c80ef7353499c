"""`myriad` command line.

    myriad train task=Ant [num_envs=N device=cpu|cuda:0 seed=S max_iterations=I max_time_s=T
                           experiment=NAME checkpoint=PATH resume=auto ...]   train (PPO)
    myriad play task=Ant [checkpoint=PATH num_steps=1000 video=out.mp4]   video of a policy
    myriad export task=Ant [checkpoint=PATH output=policy.onnx]    ONNX policy + .json sidecar
    myriad eval task=Ant [checkpoint=PATH episodes=100 num_envs=N seed=S judge=true
                          output=eval.json]       score the deterministic policy over episodes
    myriad demo [--model FILE ...]                                 simulate under random actions

train, play, export and eval take Hydra overrides: any key of cfg/config.yaml, and task.* / train.*
keys of the task's configs (e.g. task.env.episodeLength=500,
train.params.config.learning_rate=1e-4).
An unknown key fails, with or without Hydra's + or ++, naming the nearest valid keys.
"""

from __future__ import annotations

import argparse
import sys
import time


def _default_device() -> str:
    import torch

    return "cuda:0" if torch.cuda.is_available() else "cpu"


def sim_gravity(model, params):
    return model.gravity if params.gravity is None else params.gravity


def demo(args) -> int:
    import torch

    import myriad

    device = args.device or _default_device()
    num_envs = args.envs or (4096 if device.startswith("cuda") else 256)
    path = args.model or myriad.asset_path("ant.xml")
    model = myriad.load(path)
    gravity = None if args.gravity is None else tuple(args.gravity)
    params = myriad.SimParams(dt=1 / 60, substeps=2, gravity=gravity)
    print(f"myriad demo: {model}\n  {num_envs} envs on {device}, dt {params.dt:.4f} s x "
          f"{params.substeps} substeps, TGS {params.position_iterations} + "
          f"{params.velocity_iterations} iterations, gravity {[float(g) for g in sim_gravity(model, params)]}")
    t0 = time.perf_counter()
    sim = myriad.Simulator(model, num_envs=num_envs, device=device, params=params)
    print(f"  simulator built in {time.perf_counter() - t0:.1f} s (includes kernel compilation on "
          "a first run)")

    gen = torch.Generator(device=sim.torch_device).manual_seed(args.seed)
    start_q = sim.q.clone()
    steps = round(args.seconds / params.dt)
    report_every = max(1, steps // 10)
    t0 = time.perf_counter()
    for step in range(1, steps + 1):
        if model.nu:
            # random actions in [-scale, scale], held for 4 steps, like a policy at 15 Hz
            if step % 4 == 1:
                sim.ctrl = (torch.rand(num_envs, model.nu, generator=gen, device=sim.torch_device)
                            * 2 - 1) * args.action_scale
        else:
            sim.joint_force = torch.randn(num_envs, model.nv, generator=gen,
                                          device=sim.torch_device) * args.action_scale
        sim.step()
        if step % report_every == 0 or step == steps:
            if device.startswith("cuda"):
                torch.cuda.synchronize()
            rate = step * num_envs / (time.perf_counter() - t0)
            print(f"  t = {step * params.dt:5.2f} s   {rate:12,.0f} env-steps/s")
    moved = (sim.body_pose[:, :, :3] - sim.body_pose[:, :, :3].mean(dim=1, keepdim=True))
    finite = torch.isfinite(sim.q).all(dim=1)
    spread = (sim.q - start_q).abs().mean(dim=1)[finite]
    print(f"done: {steps} steps of {num_envs} envs ({steps * num_envs:,} env-steps)")
    print(f"  envs with finite state: {int(finite.sum())}/{num_envs}")
    print(f"  mean |q - q0| per env: min {spread.min():.3f}, mean {spread.mean():.3f}, "
          f"max {spread.max():.3f} (every env got its own random actions)")
    print(f"  body spread about the mean body position: {moved.norm(dim=2).mean():.3f} m")
    root_height = sim.body_pose[:, 0, 2]
    print(f"  first body's height: min {root_height.min():.3f}, mean {root_height.mean():.3f}, "
          f"max {root_height.max():.3f} m; contacts per env: mean "
          f"{sim.contact_count.float().mean():.1f}, max {int(sim.contact_count.max())}")
    sim.contact_overflow()  # warns, naming the capacity to raise, if contacts were dropped
    return 0 if bool(finite.all()) else 1


def _hydra_command(command: str, overrides: list[str]) -> int:
    import warnings

    import warp as wp

    wp.config.log_level = wp.LOG_WARNING      # no per-module load lines among the progress
    warnings.filterwarnings("ignore", category=FutureWarning, module="torch.jit")
    from .rl import run

    if any(a in ("-h", "--help") for a in overrides):
        print(__doc__)
        return 0
    try:
        if command == "export":
            from .rl import export
            return export.export(overrides)
        if command == "eval":
            from .rl import evaluate
            return evaluate.evaluate(overrides)
        return {"train": run.train, "play": run.play}[command](overrides)
    except KeyboardInterrupt:
        print("interrupted (the last checkpoint is kept)", file=sys.stderr)
        return 130
    except Exception as err:
        from hydra.errors import HydraException
        from omegaconf.errors import OmegaConfBaseException

        if isinstance(err, (HydraException, OmegaConfBaseException, ValueError, KeyError,
                            FileNotFoundError, RuntimeError)):
            print(f"myriad {command}: error: {err}", file=sys.stderr)
            return 2
        raise


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in ("train", "play", "export", "eval"):
        return _hydra_command(argv[0], argv[1:])
    # the raw formatter keeps the usage examples of the docstring one per line
    parser = argparse.ArgumentParser(prog="myriad", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("train", help="train a task with PPO: myriad train task=Ant (Hydra overrides)")
    sub.add_parser("play", help="video of a trained policy: myriad play task=Ant checkpoint=...")
    sub.add_parser("export", help="a trained policy as ONNX for a robot: myriad export task=Ant "
                   "checkpoint=... output=policy.onnx")
    sub.add_parser("eval", help="score a trained policy over whole episodes (mean, 95 %% CI): "
                   "myriad eval task=Ant checkpoint=... episodes=100")
    p = sub.add_parser("demo", help="simulate a batch of envs under random actions and report",
                       description="Simulate a batch of envs under random actions and report "
                       "the throughput and the state reached.\n\n  myriad demo --envs 64 "
                       "--seconds 5\n  myriad demo --model robot.xml --device cuda:0",
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--model", help="MJCF or URDF file (default: Myriad's ant)")
    p.add_argument("--envs", type=int, help="number of envs (default 256 on CPU, 4096 on CUDA)")
    p.add_argument("--device", help="cpu or cuda:N (default: cuda:0 when present)")
    p.add_argument("--seconds", type=float, default=2.0, help="simulated time")
    p.add_argument("--gravity", type=float, nargs=3, default=None,
                   help="gravity vector (default: the model's, 0 0 -9.81 unless it says otherwise)")
    p.add_argument("--action-scale", type=float, default=1.0,
                   help="random actions in [-scale, scale]")
    p.add_argument("--seed", type=int, default=0)
    args = parser.parse_args(argv)
    try:
        return {"demo": demo}[args.command](args)
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except (ValueError, FileNotFoundError) as err:  # ModelError is a ValueError
        print(f"myriad: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
