"""One corpus robot under the corpus's random inputs, per env: how far past its limits, how deep
into contacts, whether its energy runs away (issue 40, item 2's measuring instrument).

    python benchmarks/robot_stress.py g1/g1_29dof_with_hand_rev_1_0 --envs 40
    python benchmarks/robot_stress.py talos_data/talos_full_v2 --envs 40 --seconds 2 substeps=4

`benchmarks/corpus.py` gives one line per model over all envs; this splits it per env, since
the runs are chaotic and one env's blow-up decides the maximum: the envs more than 0.05 rad (or
m) past a limit, the median env, the envs whose energy (kinetic + potential) grew above 1.5× its
start, the longest run of steps a dof spent at its speed cap, the contact-slot overflow, and the
joints that went furthest past their limits. Inputs are corpus.py's (`random_inputs`, the same
seed); trailing key=value pairs override `myriad.SimParams`. `--mujoco` steps MuJoCo C on every
env's inputs too (the issue's depth mark is MuJoCo's worst env; corpus.py runs env 0 only).
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import math
import time
import warnings

import mujoco
import numpy as np
import torch
import warp as wp

import corpus
import myriad
from myriad.physics.structs import Control, State


def load(name: str):
    for model_name, _source, loader in corpus.corpus_models():
        if model_name == name:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                return loader()[0]
    raise SystemExit(f"no corpus model named {name!r}; `python benchmarks/corpus.py --list`")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model", help="a corpus name, e.g. g1/g1_29dof_with_hand_rev_1_0")
    ap.add_argument("--envs", type=int, default=40)
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--seed", type=int, default=0,
                    help="of the random inputs (0: corpus.py's); a run is chaotic, so one seed's "
                         "worst env says little about a change that moves every trajectory")
    ap.add_argument("--trace", type=int, metavar="ENV",
                    help="also print, for env ENV, the steps whose energy rose most: the "
                         "contacts then (bodies, depth, force), the joints past their limits "
                         "and the dofs at their speed cap, and each step's energy change "
                         "split into the inputs' work, the smooth dynamics' integration (the "
                         "same state stepped without constraints) and the constraints")
    ap.add_argument("--trace-steps", metavar="A:B",
                    help="with --trace, also one line for each step from A to B (exclusive): "
                         "its energy split and its fastest-spinning body (how a runaway "
                         "starts, where the five largest rises show it under way)")
    ap.add_argument("--mujoco", action="store_true",
                    help="also step MuJoCo C on every env's inputs (the same compiled model at "
                         "Myriad's substep, as corpus.py does for env 0) and print its limit "
                         "excess and deepest contact beside Myriad's: the issue's mark is "
                         "MuJoCo's worst env")
    ap.add_argument("params", nargs="*", help="SimParams overrides, key=value")
    args = ap.parse_args()
    params = myriad.SimParams(**sim_overrides(args.params))
    model = load(args.model)
    sim = myriad.Simulator(model, num_envs=args.envs, params=params)
    steps = round(args.seconds / params.dt)
    hold = max(1, round(corpus.CONTROL_PERIOD / params.dt))
    joints, qadr = corpus.limited_joints(model)
    kind, inputs = corpus.random_inputs(model, -(-steps // hold), args.envs,
                                        torch.Generator().manual_seed(args.seed))
    sim.collide()
    lo, hi = sim.joint_range[:, joints].unbind(-1)
    q0 = sim.q[:, qadr]
    start_over = torch.maximum(q0 - hi, lo - q0).clamp(min=0)   # a model's own start outside
    cap = sim.dof_max_velocity.clone()

    def energy(s=sim):
        qd = s.qd
        kinetic = 0.5 * torch.einsum("ei,eij,ej->e", qd, s.mass_matrix, qd)
        weight = s.body_mass[..., None] * s.gravity[:, None, :]
        return kinetic - (weight * s.body_com).sum((1, 2))

    e0 = energy()
    e_max = e0.clone()
    excess = torch.zeros(args.envs, len(joints))
    streak = torch.zeros(args.envs, model.nv, dtype=torch.int64)
    longest = torch.zeros_like(streak)
    deepest = torch.full((args.envs,), math.inf)
    overflow = 0
    trace = []
    probe = oracle = None
    if args.trace is not None:
        probe = myriad.Simulator(model, num_envs=1, params=dataclasses.replace(
            params, constraints=False))
        oracle = _smooth_mujoco(model, params)
    start = time.perf_counter()
    for step in range(steps):
        if step % hold == 0:
            setattr(sim, kind, inputs[step // hold])
        if probe is not None:
            split = _energy_split(sim, probe, oracle, args.trace, energy, params.dt)
        sim.step()
        q = sim.q[:, qadr]
        over = (torch.maximum(q - hi, lo - q) - start_over).nan_to_num(math.inf).clamp(min=0)
        excess = torch.maximum(excess, over)
        at_cap = sim.qd.abs() >= cap * 0.999
        streak = torch.where(at_cap, streak + 1, 0)
        longest = torch.maximum(longest, streak)
        count = sim.contact_count
        overflow += int((count > sim.contact_capacity).sum())
        used = torch.arange(sim.contact_capacity) < count[:, None]
        deepest = torch.minimum(deepest, torch.where(used, sim.contact_dist, math.inf).amin(1))
        now = energy().nan_to_num(math.inf)
        e_max = torch.maximum(e_max, now)
        if args.trace is not None:
            trace.append(_snapshot(sim, model, args.trace, step, float(now[args.trace]), over,
                                   joints, at_cap) | split(float(now[args.trace])))
    wall = time.perf_counter() - start
    per_env = excess.amax(1)
    runaway = e_max > 1.5 * e0.abs().clamp(min=1.0)
    print(f"{args.model}, {args.envs} envs, {args.seconds} s, {params}: {wall:.1f} s wall")
    print(f"  limit excess: worst {float(per_env.max()):.3f}, median env {float(per_env.median()):.3f}, "
          f"envs over 0.05: {int((per_env > 0.05).sum())}/{args.envs}")
    print(f"  deepest contact: worst {float(deepest.min()) * 1e3:.1f} mm, median env "
          f"{float(deepest.median()) * 1e3:.1f} mm")
    print(f"  energy runaway (> 1.5x start): {int(runaway.sum())}/{args.envs} envs, "
          f"worst {float((e_max / e0.abs().clamp(min=1.0)).max()):.0f}x"
          + (f" (envs {torch.nonzero(runaway).flatten().tolist()[:8]})"
             if runaway.any() else ""))
    print(f"  longest run at a speed cap: {int(longest.max())} steps; contact-slot overflow in "
          f"{overflow} of {steps * args.envs} env-steps (capacity {sim.contact_capacity})")
    worst = torch.argsort(excess.amax(0), descending=True)
    for i in worst[:6].tolist():
        if float(excess[:, i].max()) < 0.05:
            break
        print(f"    {model.joint_names[joints[i]]}: {float(excess[:, i].max()):.3f} past its limit "
              f"(env {int(excess[:, i].argmax())})")
    if args.mujoco:
        mj_excess, mj_deepest, mj_bad = _mujoco_envs(model, params, kind, inputs, hold, steps,
                                                     joints, qadr)
        ok = ~mj_bad
        print(f"  MuJoCo C, the same inputs per env: reset for a bad state in {int(mj_bad.sum())}/"
              f"{args.envs} envs (their steps before it count); limit excess worst "
              f"{mj_excess.max():.3f} (of envs that stayed finite "
              f"{mj_excess[ok].max(initial=0.0):.3f}), median env {np.median(mj_excess):.3f}, "
              f"envs over 0.05: {int((mj_excess > 0.05).sum())}; deepest contact worst "
              f"{mj_deepest.min() * 1e3:.1f} mm (of envs that stayed finite "
              f"{mj_deepest[ok].min(initial=math.inf) * 1e3:.1f}), median env "
              f"{np.median(mj_deepest) * 1e3:.1f} mm")
        print(f"  Myriad envs deeper than MuJoCo's worst env: "
              f"{int((deepest.numpy() < mj_deepest.min()).sum())}/{args.envs}")
    if trace:
        _print_trace(trace, float(e0[args.trace]))
        if args.trace_steps:
            first, last = (int(k) for k in args.trace_steps.split(":"))
            for k in range(max(first, 1), min(last, len(trace))):
                t = trace[k]
                print(f"    step {t['step']}: {trace[k - 1]['energy']:.1f} -> {t['energy']:.1f} J "
                      f"(work {t['work']:+.1f}, smooth {t['smooth']:+.1f} [MuJoCo "
                      f"{t['mujoco_smooth']:+.1f}], constraints {t['constraints']:+.1f}); fastest "
                      f"{t['fastest'][0]} at {t['fastest'][1]:.0f} rad/s, {t['fastest'][2]} "
                      f"bodies above their angular speed cap")


def sim_overrides(items: list[str]) -> dict:
    """SimParams overrides from key=value words: whole numbers ints, other numbers (inf
    too) floats, words strings."""
    overrides = {}
    for item in items:
        key, value = item.split("=", 1)
        for kind in (int, float, str):
            try:
                overrides[key] = kind(value)
                break
            except ValueError:
                pass
    return overrides


def _mujoco_envs(model, params, kind: str, inputs: torch.Tensor, hold: int, steps: int,
                 joints, qadr) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """MuJoCo C stepping each env's inputs from the initial state, the model compiled with
    Myriad's substep as its timestep: per env, the worst limit excess beyond the start's (rad or
    m), the deepest contact's signed distance (m; inf with no contact), and whether MuJoCo
    reset the env for a bad state (non-finite or huge accelerations: its figures then stop at
    the step before)."""
    mj = copy.deepcopy(model.mj_model)
    mj.opt.timestep = params.dt / params.substeps
    envs = inputs.shape[1]
    excess, deepest, bad = np.zeros(envs), np.full(envs, math.inf), np.zeros(envs, bool)
    lo, hi = mj.jnt_range[joints].T
    resets = [mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
              mujoco.mjtWarning.mjWARN_BADQACC]
    for env in range(envs):
        d = mujoco.MjData(mj)
        mujoco.mj_forward(mj, d)
        start_over = np.maximum(np.maximum(d.qpos[qadr] - hi, lo - d.qpos[qadr]), 0.0)
        for step in range(steps):
            if step % hold == 0:
                target = d.ctrl if kind == "ctrl" else d.qfrc_applied
                target[:] = inputs[step // hold][env].numpy()
            mujoco.mj_step(mj, d, nstep=params.substeps)
            if (any(d.warning[w].number for w in resets)
                    or not (np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all())):
                bad[env] = True
                break
            if len(joints):
                over = np.maximum(d.qpos[qadr] - hi, lo - d.qpos[qadr]) - start_over
                excess[env] = max(excess[env], float(over.max()))
            deepest[env] = min(deepest[env], corpus.mujoco_deepest(d))
    return excess, deepest, bad


def _work(sim, env: int, qd_before: torch.Tensor, dt: float) -> float:
    """The inputs' work on env `env` over the step just taken (joint forces and actuators,
    at the mean of the step's start and end speeds)."""
    force = sim.joint_force[env] + sim.dof_actuator_force[env]
    return float(force @ (qd_before + sim.qd[env])) * dt / 2


def _smooth_mujoco(model, params):
    """MuJoCo stepping the same model with the same integrator and substep and no constraints:
    `(mj, substeps)`, the oracle of the trace's smooth part."""
    mj = copy.deepcopy(model.mj_model)
    mj.opt.timestep = params.dt / params.substeps
    mj.opt.integrator = {"euler": mujoco.mjtIntegrator.mjINT_EULER,
                         "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT}[params.integrator]
    mj.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    mj.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    return mj, params.substeps


def _mujoco_gain(model, oracle, q, qd, ctrl, force) -> float:
    """MuJoCo's energy change (kinetic + potential) less the inputs' work over one step from
    (q, qd) under `ctrl` and joint forces `force`, constraints off."""
    mj, substeps = oracle
    d = mujoco.MjData(mj)
    d.qpos[:] = model.qpos_to_mujoco(q.double().numpy())
    d.qvel[:] = qd.double().numpy()
    d.ctrl[:] = ctrl.double().numpy()
    d.qfrc_applied[:] = force.double().numpy()
    mujoco.mj_forward(mj, d)
    before, work = d.energy.sum(), 0.0
    for _ in range(substeps):
        speed = d.qvel.copy()
        mujoco.mj_step(mj, d)
        work += (d.qfrc_applied + d.qfrc_actuator) @ (speed + d.qvel) * mj.opt.timestep / 2
    mujoco.mj_forward(mj, d)
    return float(d.energy.sum() - before - work)


def _energy_split(sim, probe, oracle, env: int, energy, dt: float):
    """Step `probe` (one env, no constraints) from env `env`'s state and inputs now, and MuJoCo
    (`oracle`) alike; returns the function that, given the env's energy after its own step,
    splits the change into the inputs' work, the smooth integration's gain (the probe's change
    less its inputs' work; MuJoCo's beside it) and the constraints' (the rest)."""
    theirs = {(struct, name): array for struct, name, array in sim.data.arrays()}
    for struct, name, ours in probe.data.arrays():
        if struct in (State, Control) and theirs[struct, name].shape[1:] == ours.shape[1:]:
            wp.to_torch(ours)[0].copy_(wp.to_torch(theirs[struct, name])[env])
    probe.forward()
    before = float(energy(probe)[0])
    qd = sim.qd[env].clone()
    mujoco_smooth = _mujoco_gain(probe.model, oracle, sim.q[env], qd, sim.ctrl[env],
                                 sim.joint_force[env])
    probe.step()
    smooth = float(energy(probe)[0]) - before - _work(probe, 0, qd, dt)

    def split(after: float) -> dict:
        work = _work(sim, env, qd, dt)
        return {"work": work, "smooth": smooth, "mujoco_smooth": mujoco_smooth,
                "constraints": after - before - work - smooth}
    return split


def _body(model, geom: int) -> str:
    b = int(model.geom_body[geom])
    return "world" if b < 0 else (model.body_names[b] or f"body {b}")


def _snapshot(sim, model, env: int, step: int, energy: float, over, joints, at_cap) -> dict:
    """What env `env` holds after `step`: its energy, contacts, limit excess and capped dofs."""
    n = min(int(sim.contact_count[env]), sim.contact_capacity)
    contacts = [(f"{_body(model, g1)}-{_body(model, g2)}", float(d), float(f.norm()))
                for (g1, g2), d, f in zip(sim.contact_geom[env, :n].tolist(),
                                          sim.contact_dist[env, :n], sim.contact_force[env, :n])]
    past = [(model.joint_names[joints[i]], float(over[env, i]))
            for i in torch.nonzero(over[env] > 0.01).flatten().tolist()]
    capped = torch.nonzero(at_cap[env]).flatten().tolist()
    spin = sim.body_vel[env, :, 3:].norm(dim=-1)
    b = int(spin.argmax())
    fastest = (model.body_names[b], float(spin[b]),
               int((spin > sim.body_max_angular_velocity[env]).sum()))
    return {"step": step, "energy": energy, "contacts": contacts, "past": past, "capped": capped,
            "fastest": fastest}


def _print_trace(trace: list, e0: float) -> None:
    """The 5 steps whose energy rose most, with what the env held then, and where all the
    energy gained came from."""
    rises = sorted(range(1, len(trace)), key=lambda k: trace[k - 1]["energy"] - trace[k]["energy"])
    print(f"  trace: energy {e0:.1f} J at the start, {trace[-1]['energy']:.1f} J at the end; "
          "summed over the steps that gained: "
          + ", ".join(f"{part} {sum(max(t[part], 0.0) for t in trace):.1f} J"
                      for part in ("work", "smooth", "constraints")))
    for k in sorted(rises[:5]):
        t = trace[k]
        print(f"    step {t['step']}: {trace[k - 1]['energy']:.1f} -> {t['energy']:.1f} J "
              f"(work {t['work']:+.1f}, smooth {t['smooth']:+.1f} [MuJoCo from the same state "
              f"{t['mujoco_smooth']:+.1f}], constraints {t['constraints']:+.1f}); "
              f"{len(t['contacts'])} contacts, dofs at their cap {t['capped']}")
        for pair, depth, force in sorted(t["contacts"], key=lambda c: -c[2])[:6]:
            print(f"      {pair}: {depth * 1e3:.1f} mm, {force:.0f} N")
        for name, excess in t["past"]:
            print(f"      {name}: {excess:.3f} past its limit")


if __name__ == "__main__":
    main()
