"""MuJoCo Warp and Myriad stepping the same MJCF models on the same GPU, in one process, one after
the other: physics steps/s, device memory per world, state health, and Myriad's time per stage.

    python benchmarks/gpu_peers.py                                   # defaults below, cuda:0
    python benchmarks/gpu_peers.py --models humanoid --worlds 4096 8192 --json peers.json
    python benchmarks/gpu_peers.py --device cpu --worlds 2 --steps 3 --models ant   # smoke check

Models: `humanoid` is the 27-DoF humanoid of MuJoCo Warp's published nightly figure
(mujoco_warp/test_data/humanoid/humanoid.xml: Newton, 10 iterations, 20 line-search
iterations, timestep 0.005 s), `ant` Myriad's ant.xml, `shadow-hand` the ShadowHand task's
hand-and-cube scene (needs gymnasium-robotics). Both engines read the same MJCF.

The comparison is pinned to MuJoCo Warp's nightly benchmark (mujoco_warp/testspeed.py with
_src/cli.py, default flags):
  MuJoCo Warp  the model's own solver settings; `put_model`, then `put_data(nworld=N,
               nconmax=None, njmax=None)` from keyframe 0 (mj_resetDataKeyframe) when the model
               has one; `opt.warn_overflow = 0` (testspeed's overflow check reads d.overflow
               after the steps instead of printing from kernels); one `mjw.step` captured in a
               CUDA graph and replayed.
  Myriad       the same timestep in one substep, TGS 4/0, contacts on (64 slots per env), the
               keyframe's qpos (quaternions reordered) and ctrl.
  controls     testspeed's Ornstein-Uhlenbeck noise (std 0.01, rate 0.1 s) around the
               keyframe's ctrl (else the middle of the ctrl range), written into both engines'
               ctrl from torch before every step, same seed. Chosen over uniform random controls
               so that the humanoid row reproduces the published figure's workload (under these
               near-constant controls the humanoid sinks from its squat to the floor within the
               first second, then lies there on ~12 contacts); uniform random controls are
               throughput.py's. testspeed draws the noise from a Halton sequence and applies
               none to models without a keyframe; here it is torch.rand, on every model.
  timing       testspeed's: per step, write controls, synchronize, clock, step, synchronize,
               clock; physics steps/s = worlds x steps / the summed step times. One physics step
               = one MuJoCo Warp step = one Myriad substep (`Simulator.step` with substeps=1).
               testspeed times 1000 steps from the start (--steps 1000 comes close); the default
               200 after 13 untimed ones cover mostly the humanoid's fall.
  memory       free device memory before building minus after building and 3 steps, / worlds
               (kernel modules loaded on the way count in a model's first row). CUDA only.
  profile      Myriad's stages (`sim.step(timings=...)`: synchronized after each stage, no CUDA
               graph) at --profile-worlds, or the largest world count run if it is not listed.

On --device cpu both engines run on Warp's CPU backend (testspeed refuses the CPU; put_model,
put_data and step work there, no graph): a smoke check of this script, not a comparison.
MuJoCo Warp's kernels are not in precompile_cuda.py's cache: each model's first row includes
their compile ("first 3 steps" in the state table). Rows run by world count, smallest first, every
model at each count, so a --budget-s cut drops the largest counts. A row whose estimate (the
model's previous row, scaled by the world count) does not fit the budget is skipped and listed.
"""

from __future__ import annotations

import argparse
import collections
import gc
import json
import math
import os
import time
from importlib import metadata, resources

import mujoco
import numpy as np
import torch
import warp as wp

import myriad

NOISE_STD, NOISE_RATE = 0.01, 0.1         # testspeed's --noise_std, --noise_rate
WARMUP = 10                               # steps after the first 3, before the timed ones
PROFILE_STEPS = 20
STAGES = list(dict.fromkeys(myriad.Simulator.SUBSTEP_STAGES + myriad.Simulator.FINAL_STAGES))


def load(name: str):
    """MuJoCo Warp's MjModel and Myriad's Model of one model, from the same MJCF."""
    if name == "shadow-hand":
        model = myriad.make("ShadowHand", num_envs=1).envs.model
        return model.mj_model, model
    path = str(resources.files("mujoco_warp") / "test_data" / "humanoid" / "humanoid.xml"
               if name == "humanoid" else myriad.asset_path("ant.xml"))
    return mujoco.MjSpec.from_file(path).compile(), myriad.load(path)   # as cli.load_model


class Controls:
    """testspeed's control noise (cli._ctrl_noise), in place on a [worlds, nu] tensor."""

    def __init__(self, mjm, device: str):
        limited = mjm.actuator_ctrllimited.astype(bool)
        lo, hi = mjm.actuator_ctrlrange.T
        t = lambda a: torch.as_tensor(np.asarray(a, np.float32), device=device)
        self.centre = t(mjm.key_ctrl[0] if mjm.nkey else np.where(limited, (lo + hi) / 2, 0))
        self.half = t(np.where(limited, (hi - lo) / 2, 1))
        self.lo, self.hi = t(np.where(limited, lo, -np.inf)), t(np.where(limited, hi, np.inf))
        self.rate = math.exp(-mjm.opt.timestep / NOISE_RATE)
        self.scale = NOISE_STD * math.sqrt(1 - self.rate ** 2)
        self.gen = torch.Generator(device=device).manual_seed(0)   # reseeded per engine

    def __call__(self, ctrl: torch.Tensor) -> None:
        noise = torch.rand(ctrl.shape, generator=self.gen, device=ctrl.device) * 2 - 1
        ctrl.mul_(self.rate).add_((1 - self.rate) * self.centre + self.scale * self.half * noise)
        torch.minimum(torch.maximum(ctrl, self.lo), self.hi, out=ctrl)


def free_memory(device: str) -> int | None:
    if not device.startswith("cuda"):
        return None
    gc.collect()
    torch.cuda.empty_cache()
    wp.synchronize_device(device)
    return wp.get_device(device).free_memory


def run(step, controls, ctrl: torch.Tensor, steps: int, device: str) -> float:
    """Seconds spent inside `step` over `steps` steps, new controls before each (testspeed)."""
    spent = 0.0
    for _ in range(steps):
        controls(ctrl)
        wp.synchronize_device(device)
        start = time.perf_counter()
        step()
        wp.synchronize_device(device)
        spent += time.perf_counter() - start
    return spent


def stepped(step, n: int, device: str, free0, controls, ctrl, steps: int) -> dict:
    """First 3 steps (compile, graph capture), memory, warm-up, then the timed steps."""
    start = time.perf_counter()
    for _ in range(3):
        step()
    wp.synchronize_device(device)
    first = time.perf_counter() - start
    free1 = free_memory(device)
    run(step, controls, ctrl, WARMUP, device)
    spent = run(step, controls, ctrl, steps, device)
    return dict(steps_per_s=n * steps / spent, first_steps_s=first,
                kib_per_world=None if free0 is None else (free0 - free1) / n / 1024)


def mujoco_warp_row(mjm, n: int, steps: int, device: str, controls) -> dict:
    import mujoco_warp as mjw

    mjd = mujoco.MjData(mjm)
    if mjm.nkey:
        mujoco.mj_resetDataKeyframe(mjm, mjd, 0)
    free0 = free_memory(device)
    with wp.ScopedDevice(device):
        m = mjw.put_model(mjm)
        m.opt.warn_overflow = 0
        d = mjw.put_data(mjm, mjd, nworld=n, nconmax=None, njmax=None)
        if wp.get_device(device).is_cuda:
            graph = []

            def step():
                if not graph:       # loads only the modules the step launches (CUDA >= 12.3)
                    with wp.ScopedCapture(force_module_load=False) as capture:
                        mjw.step(m, d)
                    graph.append(capture.graph)
                wp.capture_launch(graph[0])
        else:                                   # no graphs on the CPU
            step = lambda: mjw.step(m, d)
        row = stepped(step, n, device, free0, controls, wp.to_torch(d.ctrl), steps)
        finite = np.isfinite(d.qpos.numpy()).all(1) & np.isfinite(d.qvel.numpy()).all(1)
        overflow = d.overflow.numpy()
        limits = mjw.OverflowType.ITERATIONS | mjw.OverflowType.LS_ITERATIONS
        flags = mjw.OverflowType(int(np.bitwise_or.reduce(overflow & ~limits)))
        return row | dict(nonfinite=int((~finite).sum()),
                          overflow_worlds=int((overflow & ~limits != 0).sum()),
                          overflow_flags=flags.name if flags else "", iteration_limit_worlds=int(
                              (overflow & limits != 0).sum()),
                          contacts_per_world=float(d.nacon.numpy()[0]) / n,
                          max_nefc=int(d.nefc.numpy().max()), naconmax=d.naconmax, njmax=d.njmax)


def myriad_sim(model, mjm, n: int, device: str):
    """Myriad's simulator of the comparison: the model's timestep in one substep, TGS 4/0, at
    the keyframe's qpos and ctrl when the model has one."""
    params = myriad.SimParams(dt=float(mjm.opt.timestep), substeps=1, position_iterations=4,
                              velocity_iterations=0)
    sim = myriad.Simulator(model, num_envs=n, device=device, params=params)
    if mjm.nkey:
        sim.q = model.qpos_from_mujoco(mjm.key_qpos[0])
        sim.ctrl = mjm.key_ctrl[0]
        sim.forward()
    return sim


def stage_ms(sim, controls) -> dict:
    """Milliseconds per step of each stage over PROFILE_STEPS steps (stages synchronized)."""
    spent = collections.Counter()
    for _ in range(PROFILE_STEPS):
        controls(sim.ctrl)
        sim.step(timings=spent)
    return {s: spent[s] / PROFILE_STEPS * 1e3 for s in STAGES}


def myriad_row(model, mjm, n: int, steps: int, device: str, controls, profile: bool) -> dict:
    free0 = free_memory(device)
    sim = myriad_sim(model, mjm, n, device)
    row = stepped(sim.step, n, device, free0, controls, sim.ctrl, steps)
    if profile:
        row["profile_ms"] = stage_ms(sim, controls)
    return row | dict(nonfinite=int((sim.nonfinite != 0).sum()),
                      contact_overflow=sim.contact_overflow(),
                      contacts_per_world=float(sim.contact_count.float().mean()))


def guarded(fn, *args) -> dict:
    """One engine's row, or the error that ended it (an overflow, out of memory) as the row."""
    try:
        return fn(*args)
    except Exception as err:  # noqa: BLE001 - printed in the table instead of ending the run
        return dict(error=f"{type(err).__name__}: {err}".splitlines()[0][:120])
    finally:
        gc.collect()


def fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def tables(rows: list[dict], skipped: list[str]) -> None:
    print("\nphysics steps/s (one step of one world) and device memory per world\n")
    print("| model | worlds | MuJoCo Warp | Myriad | Myriad / MJW | MJW KiB/world | "
          "Myriad KiB/world |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        a, b = r["mujoco_warp"], r["myriad"]
        rate = lambda e: e.get("error") or f"{e['steps_per_s']:,.0f}"
        ratio = (f"{b['steps_per_s'] / a['steps_per_s']:.2f}"
                 if "error" not in a and "error" not in b else "-")
        kib = [fmt(e.get("kib_per_world"), ".1f") for e in (a, b)]
        print(f"| {r['model']} | {r['worlds']} | {rate(a)} | {rate(b)} | {ratio} | {kib[0]} | "
              f"{kib[1]} |")
    print("\nstate after the run (non-finite: worlds whose state is not finite; MJW overflow: "
          "worlds that overflowed a contact/constraint buffer; iteration limit: worlds whose "
          "solver or line search hit its limit in some step)\n")
    print("| model | worlds | MJW non-finite | MJW overflow | MJW iteration limit | MJW contacts"
          "/world, max nefc | Myriad non-finite | Myriad contact overflow | Myriad contacts"
          "/world | first 3 steps s (MJW / Myriad) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        a, b = r["mujoco_warp"], r["myriad"]
        mjw_cells = (["error"] * 4 if "error" in a else [
            a["nonfinite"], f"{a['overflow_worlds']} {a['overflow_flags']}".strip(),
            a["iteration_limit_worlds"], f"{a['contacts_per_world']:.1f}, {a['max_nefc']}"])
        my_cells = (["error"] * 3 if "error" in b else [
            b["nonfinite"], b["contact_overflow"], f"{b['contacts_per_world']:.1f}"])
        first = " / ".join(fmt(e.get("first_steps_s"), ".1f") for e in (a, b))
        print(f"| {r['model']} | {r['worlds']} | " + " | ".join(map(str, mjw_cells + my_cells))
              + f" | {first} |")
    profiled = [r for r in rows if "profile_ms" in r["myriad"]]
    if profiled:
        print(f"\nMyriad ms per physics step by stage ({profiled[0]['worlds']} worlds; stages "
              "synchronized, no CUDA graph); share of the step in brackets\n")
        print("| stage | " + " | ".join(r["model"] for r in profiled) + " |")
        print("|---|" + "---|" * len(profiled))
        ms = [r["myriad"]["profile_ms"] for r in profiled]
        for stage in STAGES:
            print(f"| {stage.replace('_', ' ')} | " + " | ".join(
                f"{p[stage]:.3f} ({100 * p[stage] / sum(p.values()):.0f} %)" for p in ms) + " |")
        print("| **total** | " + " | ".join(f"{sum(p.values()):.3f}" for p in ms) + " |")
    print("\nskipped: " + ("; ".join(skipped) if skipped else "nothing"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--device", default="cuda:0")
    ap.add_argument("--models", nargs="+", default=["humanoid", "ant", "shadow-hand"],
                    choices=["humanoid", "ant", "shadow-hand"])
    ap.add_argument("--worlds", type=int, nargs="+",
                    default=[1024, 4096, 8192, 16384, 32768, 65536])
    ap.add_argument("--steps", type=int, default=200, help="timed steps per row")
    ap.add_argument("--profile-worlds", type=int, default=8192)
    ap.add_argument("--budget-s", type=float, default=420.0)
    ap.add_argument("--json", help="write every number to this file")
    args = ap.parse_args()
    clock = time.perf_counter()
    wp.config.log_level = wp.LOG_WARNING
    # MuJoCo Warp's modules (not in precompile_cuda.py's cache) compile on every core
    wp.config.load_module_max_workers = os.cpu_count()
    wp.init()
    dev = args.device
    if dev.startswith("cuda"):
        # freed Warp arrays go back to the device at each synchronize, so that each row's
        # "free memory before" is not inflated by the previous row's pooled arrays
        wp.set_mempool_release_threshold(dev, 0)
    where = torch.cuda.get_device_name(dev) if dev.startswith("cuda") else "CPU"
    print(f"device {dev} ({where}); mujoco-warp {metadata.version('mujoco-warp')}, mujoco "
          f"{mujoco.__version__}, warp {wp.__version__}, torch {torch.__version__}\n"
          "MuJoCo Warp as testspeed.py: the model's solver, put_data defaults, keyframe 0, "
          "one mjw.step CUDA graph (none on the CPU); Myriad: same dt, 1 substep, TGS 4/0, "
          f"contacts on; both: testspeed's OU control noise (std {NOISE_STD}, rate "
          f"{NOISE_RATE}); {args.steps} timed steps; budget {args.budget_s:.0f} s", flush=True)
    models, skipped = {}, []
    for name in args.models:
        try:
            models[name] = load(name)
        except myriad.ModelError as err:        # ShadowHand without gymnasium-robotics
            skipped.append(f"{name}: {err}")
            print(f"skipping {name}: {err}", flush=True)
    worlds = sorted(set(args.worlds))
    profile_at = args.profile_worlds if args.profile_worlds in worlds else worlds[-1]
    rows, last, first_row_s, over_budget = [], {}, [], {}
    for n in worlds:
        for name, (mjm, model) in models.items():
            used = time.perf_counter() - clock
            if name in last:        # the model's previous row, its compile left out, scaled
                prev_n, prev_s = last[name]
                estimate = prev_s * n / prev_n
            else:                   # a model's first row: compile included, as others' were
                estimate = max(first_row_s, default=0.0)
            if used + estimate > args.budget_s:
                over_budget.setdefault(name, []).append(n)
                print(f"[{used:.0f} s] skipping {name} at {n} worlds: estimated {estimate:.0f} s, "
                      f"{args.budget_s - used:.0f} s left", flush=True)
                continue
            print(f"[{used:.0f} s] {name} at {n} worlds ...", flush=True)
            start = time.perf_counter()
            controls = Controls(mjm, dev)
            row = dict(model=name, worlds=n, nv=mjm.nv, timestep=mjm.opt.timestep,
                       mujoco_warp=guarded(mujoco_warp_row, mjm, n, args.steps, dev, controls))
            controls.gen.manual_seed(0)
            row["myriad"] = guarded(myriad_row, model, mjm, n, args.steps, dev, controls,
                                    n == profile_at)
            seconds = time.perf_counter() - start
            rows.append(row | dict(seconds=seconds))
            if name not in last:
                first_row_s.append(seconds)
            compile_s = sum(row[e].get("first_steps_s", 0.0) for e in ("mujoco_warp", "myriad"))
            last[name] = (n, max(seconds - compile_s, 0.1 * seconds))
            said = [f"{e}: " + (r.get("error") or f"{r['steps_per_s']:,.0f} steps/s")
                    for e, r in (("MuJoCo Warp", row["mujoco_warp"]), ("Myriad", row["myriad"]))]
            print(f"[{time.perf_counter() - clock:.0f} s] {name} {n} worlds: "
                  + ", ".join(said) + f" ({seconds:.1f} s)", flush=True)
    skipped += [f"{name} at {', '.join(map(str, ns))} worlds (budget)"
                for name, ns in over_budget.items()]
    tables(rows, skipped)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(dict(device=dev, device_name=where, steps=args.steps, rows=rows,
                           skipped=skipped, stages=STAGES), f, indent=1)


if __name__ == "__main__":
    main()
