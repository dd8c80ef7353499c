"""Third-party robots under random actuation: does Myriad stay finite where MuJoCo does?

    python benchmarks/corpus.py                        # the whole corpus (about 80 models)
    python benchmarks/corpus.py --only 'gymnasium/*' solo/solo12 --seconds 2 --envs 4
    python benchmarks/corpus.py --list                 # the corpus names, nothing run
    (cd benchmarks && python corpus.py ...) works the same.

The measuring instrument for issue 12, item 1 ("never explode on third-party robots"). The
corpus is every model its users are likely to bring first and that this machine already holds:
  (a) every MJCF in gymnasium's `envs/mujoco/assets/*.xml`, loaded as they are (`myriad.load`);
  (b) every URDF under example-robot-data's `robots/` folder. MuJoCo compiles the URDF with
      three load-time fixes a user would make too: `package://` mesh paths become absolute
      paths; `<compiler discardvisual="true">` drops visual meshes (often .dae files MuJoCo
      cannot read; collision geometry is kept); `balanceinertia="true"`, the fix MuJoCo's own
      error message names, for the links whose inertia violates the triangle inequality. A URDF
      MuJoCo still rejects is loaded as Isaac Gym's importer would load it, by
      `myriad.load_asset` (its repairs: .dae visuals dropped, .dae collision meshes replaced by a
      same-named .stl/.obj, inertias balanced or taken from the collision geometry; the note says
      so and counts them); only what that cannot repair stays "MuJoCo rejects: <its reason>".
      Mobile robots (`MOBILE`, a fixed list of description folders checked by hand: legged,
      humanoid, wheeled and flying robots) get a floating base (a `world` link and a floating
      joint to the URDF's root link, as `myriad.tasks.anymal` does) and a ground plane; the
      base is raised so that the lowest collision geometry is 1 cm above the ground at the
      initial pose (`mujoco.mj_geomDistance` of each geom to the plane). Everything else
      (arms, hands, pendulums) stays fixed to the world, with no ground.
A model Myriad refuses (`myriad.ModelError`: equality constraints, unsupported sensors, ...) is
a row "refused: <reason>": a refusal is an honest answer, an explosion is not.

Per model: `--envs` envs (4) for `--seconds` of simulated time (2), at Myriad's defaults
(`myriad.SimParams()`: Isaac Gym's dt 1/60 s in 2 substeps, TGS 4/1) for every model, also
those authored for a finer timestep (URDFs get MuJoCo's 0.002 s): that timing is what users
get, and it is the one to survive. The note names a model's own timestep when it is finer.
Random actuation, redrawn every 0.1 s from one seeded generator: actuator inputs uniform in
each ctrlrange ([-1, 1] where unlimited); a model without actuators gets random joint torques
on its hinge and slide dofs (a floating base is not driven), uniform in ±10/(M⁻¹)_ii, the
torque that alone would accelerate the dof at 10 rad/s² (or m/s²) at the initial pose.
MuJoCo C steps the same compiled model (`model.mj_model`, a copy with timestep = Myriad's
substep, two mj_step per control step) from the same initial state with env 0's inputs
(`ctrl` or `qfrc_applied`). MuJoCo never says "non-finite": on a bad position, velocity or
acceleration it warns and resets to qpos0, which is counted here as non-finite.

Measured for both engines (Myriad over all envs, MuJoCo its one run):
  finite        every q and qd finite at every step (else: the first time it was not);
  max|qd|       largest joint speed seen (rad/s or m/s, free joints included);
  limit excess  worst violation of a hinge/slide joint limit, max(0, q - hi, lo - q) (rad or m),
                beyond the joint's violation at t = 0 (several URDFs start with qpos0 = 0
                outside their joint ranges; the solver then pushes them in, which is not an
                excess);
  penetration   signed distance of the deepest contact (negative: overlap), in mm, at rest at
                t = 0 (the model's own overlap, which the solver pushes apart) and the worst
                over the run. Myriad reports contacts from 2 cm apart (contact_offset), MuJoCo
                only touching ones (margin 0): "none" means no contact at all;
  wall time     seconds each engine spent stepping (Myriad with its CPU threads, MuJoCo one).
Rows print as each model finishes; one model's crash is its row, not the end of the run.
"""

from __future__ import annotations

import argparse
import copy
import fnmatch
import glob
import math
import os
import re
import sys
import tempfile
import time
import traceback
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import torch
import warp as wp

import myriad

CONTROL_PERIOD = 0.1     # s between fresh random inputs
TORQUE_ACCEL = 10.0      # rad/s² (m/s²) that a random joint torque gives its dof alone
CLEARANCE = 0.01         # m between a mobile robot's lowest geometry and the ground
HINGE_SLIDE = (int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE))  # Myriad's too

# MuJoCo's warnings (compiler and mj_step), collected by `main` into the note of the model
MUJOCO_WARNINGS: list[str] = []

# description folders of example-robot-data whose robots move about (legs, wheels, rotors)
MOBILE = {"a1", "alexander", "anymal_b_simple", "anymal_c_simple", "b1", "bolt", "borinot",
          "cassie", "centauro", "g1", "go1", "go2", "hector", "hextilt", "human", "hyq", "icub",
          "iris", "laikago", "pr2", "quadruped", "romeo", "simple_humanoid", "solo", "talos_data",
          "tiago", "tiago_pro"}
FIXED_FILES = {"talos_left_arm"}    # an arm alone, in a mobile robot's folder


class MujocoRejects(Exception):
    """MuJoCo itself cannot compile the file (so there is nothing for Myriad to load)."""


# ---------------------------------------------------------------------------- the corpus
def gymnasium_assets() -> list[str]:
    import gymnasium
    folder = os.path.join(os.path.dirname(gymnasium.__file__), "envs", "mujoco", "assets")
    return sorted(glob.glob(os.path.join(folder, "*.xml")))


def robots_folder() -> str | None:
    """example-robot-data's robots/ folder, inside site-packages' cmeel.prefix."""
    import site
    for root in list(site.getsitepackages()) + [site.getusersitepackages()] + sys.path:
        folder = os.path.join(root, "cmeel.prefix", "share", "example-robot-data", "robots")
        if os.path.isdir(folder):
            return folder
    return None


def one_line(err: Exception) -> str:
    """MuJoCo's error in one line: the message and the element it names."""
    lines = [s.strip() for s in str(err).splitlines() if s.strip()]
    lines = [s.removeprefix("Error: ") for s in lines if not s.startswith("The static bodies")]
    return "; ".join(lines[:2])


def urdf_xml(path: str, mobile: bool) -> str:
    """MJCF text of a URDF, compiled by MuJoCo with the fixes in the module docstring; a
    mobile robot gets a floating base, a ground plane and 1 cm of clearance."""
    robots = robots_folder()
    with open(path) as f:
        text = f.read()
    # package://example-robot-data/robots/x/..., package:///example-robot-data/..., package://x/...
    text = re.sub(r"package://+(?:example-robot-data/robots/)?", robots + "/", text)
    header = '<mujoco><compiler discardvisual="true" balanceinertia="true"/></mujoco>'
    if mobile:
        tree = ET.fromstring(text)
        children = {child.get("link") for child in tree.findall("joint/child")}
        root = next(link.get("name") for link in tree.findall("link")
                    if link.get("name") not in children)
        header += ('<link name="world"/><joint name="floating_base" type="floating">'
                   f'<parent link="world"/><child link="{root}"/></joint>')
    text, found = re.subn(r"(<robot[^>]*>)", lambda m: m.group(1) + header, text, count=1)
    if not found:
        raise MujocoRejects("no <robot> element")
    try:
        compiled = mujoco.MjModel.from_xml_string(text)
    except Exception as err:
        raise MujocoRejects(one_line(err)) from err
    with tempfile.TemporaryDirectory() as folder:     # the fused model, written back as MJCF
        mujoco.mj_saveLastXML(os.path.join(folder, "model.xml"), compiled)
        spec = mujoco.MjSpec.from_file(os.path.join(folder, "model.xml"))
    spec.compiler.balanceinertia = True               # the saved file forgets the flag
    if not mobile:
        return spec.to_xml()
    return on_ground(spec)


def tolerant_xml(path: str, mobile: bool) -> str:
    """MJCF text of a URDF MuJoCo rejects, as `myriad.load_asset` repairs it (the base free for
    a mobile robot, on a ground with 1 cm of clearance; fixed otherwise); its repairs are
    RuntimeWarnings, counted in the row's note."""
    spec = myriad.physics.tolerant.asset_spec(path, fix_base_link=not mobile)
    if not mobile:
        return spec.to_xml()
    return on_ground(spec)


def on_ground(spec) -> str:
    """A ground plane under the robot of `spec`, its base raised to 1 cm above it."""
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1])
    m = spec.compile()
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    # the world body's geoms compile first: the ground is found by name, not by its place
    plane = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "ground")
    touches = [g for g in range(m.ngeom) if g != plane and (
        (m.geom_contype[g] & m.geom_conaffinity[plane])
        or (m.geom_contype[plane] & m.geom_conaffinity[g]))]
    if touches:
        lowest = min(mujoco.mj_geomDistance(m, d, g, plane, 100.0, None) for g in touches)
        base = spec.worldbody.first_body()
        base.pos = base.pos + [0.0, 0.0, CLEARANCE - lowest]
    return spec.to_xml()


def corpus_models() -> list[tuple[str, str, object]]:
    """[(name, source, loader)]: loader() -> (myriad.Model, note); it raises MujocoRejects or
    myriad.ModelError."""
    models = []
    for path in gymnasium_assets():
        name = "gymnasium/" + os.path.splitext(os.path.basename(path))[0]
        models.append((name, "gymnasium", lambda path=path: (myriad.load(path), "")))
    robots = robots_folder()
    for path in sorted(glob.glob(os.path.join(robots or "/nonexistent", "**", "*.urdf"),
                                 recursive=True)):
        folder = os.path.relpath(path, robots).split(os.sep)[0].removesuffix("_description")
        stem = os.path.splitext(os.path.basename(path))[0]
        mobile = folder in MOBILE and stem not in FIXED_FILES
        name = f"{folder}/{stem}"

        def loader(path=path, mobile=mobile, name=name):
            note = "floating base on ground" if mobile else "fixed base"
            try:
                xml = urdf_xml(path, mobile)
            except MujocoRejects as rejected:
                # what Isaac Gym's importer would load: myriad.load_asset's repairs
                with warnings.catch_warnings(record=True) as repairs:
                    warnings.simplefilter("always")
                    try:
                        xml = tolerant_xml(path, mobile)
                        mujoco.MjModel.from_xml_string(xml)    # compiles, repaired?
                    except Exception:  # noqa: BLE001  not repairable: MuJoCo's reason stands
                        raise rejected from None
                note += (f"; MuJoCo rejects ({rejected}), loaded by myriad.load_asset "
                         f"({len(repairs)} repairs)")
            try:
                model = myriad.load_xml(xml, name)
            except myriad.ModelError as err:
                with open(path) as f:
                    mimic = "equality" in str(err) and "<mimic" in f.read()
                if mimic:   # say where the equality came from: the user wrote none
                    raise myriad.ModelError(f"{err} (MuJoCo turns the URDF's <mimic> joints "
                                            "into joint equalities)") from err
                raise
            return model, note
        models.append((name, "example-robot-data", loader))
    return models


# ---------------------------------------------------------------------------- one model
def random_inputs(model, changes: int, envs: int, gen) -> tuple[str, torch.Tensor]:
    """("ctrl" | "joint_force", [changes, envs, n]) random inputs, one set per control period.
    The torque scale comes from MuJoCo's mass matrix at qpos0, so that it does not depend on the
    engine under test."""
    if model.nu:
        limited = torch.as_tensor(model.actuator_ctrllimited, dtype=torch.bool)
        span = torch.as_tensor(model.actuator_ctrlrange, dtype=torch.float32)
        lo = torch.where(limited, span[:, 0], -1.0)
        hi = torch.where(limited, span[:, 1], 1.0)
        return "ctrl", lo + (hi - lo) * torch.rand(changes, envs, model.nu, generator=gen)
    m = model.mj_model
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    mass = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, mass)
    scale = TORQUE_ACCEL / torch.as_tensor(np.linalg.inv(mass).diagonal().copy()).float()
    driven = torch.as_tensor(np.isin(model.jnt_type[model.dof_jnt], HINGE_SLIDE))
    scale = torch.where(driven, scale, 0.0)
    return "joint_force", scale * (2 * torch.rand(changes, envs, model.nv, generator=gen) - 1)


def limited_joints(model) -> tuple[np.ndarray, np.ndarray]:
    """(joint ids, qpos addresses) of the limited hinge and slide joints."""
    joints = [j for j in range(model.njnt)
              if model.jnt_limited[j] and model.jnt_type[j] in HINGE_SLIDE]
    return np.asarray(joints, np.int64), np.asarray(model.jnt_qposadr[joints], np.int64)


def myriad_deepest(sim) -> torch.Tensor:
    """Signed distance of the deepest contact of all envs (+inf without contacts)."""
    if sim.contact_capacity == 0:
        return torch.tensor(math.inf)
    valid = torch.arange(sim.contact_capacity) < sim.contact_count[:, None]
    return torch.where(valid, sim.contact_dist, math.inf).min()


def mujoco_deepest(d) -> float:
    return float(d.contact.dist[:d.ncon].min()) if d.ncon else math.inf


def run_model(name: str, loader, seconds: float = 2.0, envs: int = 4,
              params: myriad.SimParams | None = None) -> dict:
    """Random actuation of one model in Myriad and in MuJoCo; the measurements as a dict."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model, note = loader()
    notes = [note] + [str(w.message).splitlines()[0] for w in caught
                      if issubclass(w.category, (UserWarning, RuntimeWarning))]
    said = [w for w in dict.fromkeys(MUJOCO_WARNINGS) if "unstable" not in w]
    notes += [f"MuJoCo: {w}" for w in said[:2]] + [f"(+{len(said) - 2} more)"] * (len(said) > 2)
    MUJOCO_WARNINGS.clear()
    if model.nv == 0:
        return dict(name=name, nq=0, nv=0, status="nothing moves (nv = 0)", note="; ".join(notes))
    params = params or myriad.SimParams()
    h = params.dt / params.substeps
    if model.mj_model.opt.timestep < h - 1e-12:
        notes.append(f"model dt {model.mj_model.opt.timestep:g} s")
    steps = round(seconds / params.dt)
    hold = max(1, round(CONTROL_PERIOD / params.dt))
    joints, qadr = limited_joints(model)

    # -- Myriad: all envs, batched; statistics accumulate on tensors, read once at the end
    sim = myriad.Simulator(model, num_envs=envs, params=params)
    gen = torch.Generator().manual_seed(0)
    kind, inputs = random_inputs(model, -(-steps // hold), envs, gen)
    sim.collide()
    rest = myriad_deepest(sim)
    worst, max_qd, excess = torch.tensor(math.inf), torch.tensor(0.0), torch.tensor(0.0)
    if len(joints):
        q, (lo, hi) = sim.q[:, qadr], sim.joint_range[:, joints].unbind(-1)
        start_over = torch.maximum(q - hi, lo - q).clamp(min=0.0)     # the start's violation
    first_bad = torch.full((envs,), -1)
    most_contacts = torch.tensor(0)
    start = time.perf_counter()
    for step in range(steps):
        if step % hold == 0:
            if bool((first_bad >= 0).all()):    # every env is NaN: nothing left to measure
                notes.append(f"Myriad stopped at t={step * params.dt:.2f} s (all envs NaN)")
                break
            setattr(sim, kind, inputs[step // hold])
        sim.step()
        bad = ~(torch.isfinite(sim.q).all(1) & torch.isfinite(sim.qd).all(1))
        first_bad = torch.where(bad & (first_bad < 0), step, first_bad)
        max_qd = torch.maximum(max_qd, sim.qd.abs().nan_to_num(0.0).max())
        if len(joints):
            q, (lo, hi) = sim.q[:, qadr], sim.joint_range[:, joints].unbind(-1)
            over = (torch.maximum(q - hi, lo - q) - start_over).nan_to_num(0.0).clamp(min=0.0)
            excess = torch.maximum(excess, over.max())
        worst = torch.minimum(worst, myriad_deepest(sim))
        most_contacts = torch.maximum(most_contacts, sim.contact_count.max())
    ours_s = time.perf_counter() - start
    if int(most_contacts) > sim.contact_capacity:
        notes.append(f"contacts overflowed ({int(most_contacts)} > {sim.contact_capacity} slots)")

    # -- MuJoCo C: env 0's inputs, the same compiled model at Myriad's substep
    mj = copy.deepcopy(model.mj_model)
    mj.opt.timestep = h
    d = mujoco.MjData(mj)
    mujoco.mj_forward(mj, d)
    mj_rest, mj_worst, mj_excess, mj_bad = mujoco_deepest(d), math.inf, 0.0, -1
    lo, hi = mj.jnt_range[joints].T
    mj_start_over = np.maximum(np.maximum(d.qpos[qadr] - hi, lo - d.qpos[qadr]), 0.0)
    resets = [mujoco.mjtWarning.mjWARN_BADQPOS, mujoco.mjtWarning.mjWARN_BADQVEL,
              mujoco.mjtWarning.mjWARN_BADQACC]
    start = time.perf_counter()
    for step in range(steps):
        if step % hold == 0:
            target = d.ctrl if kind == "ctrl" else d.qfrc_applied
            target[:] = inputs[step // hold][0].numpy()
        mujoco.mj_step(mj, d, nstep=params.substeps)
        finite = np.isfinite(d.qpos).all() and np.isfinite(d.qvel).all()
        if mj_bad < 0 and (not finite or any(d.warning[w].number for w in resets)):
            mj_bad = step
        if len(joints):
            q = d.qpos[qadr]
            over = np.maximum(q - hi, lo - q) - mj_start_over
            mj_excess = max(mj_excess, float(np.nan_to_num(over).max()))
        mj_worst = min(mj_worst, mujoco_deepest(d))
    theirs_s = time.perf_counter() - start
    MUJOCO_WARNINGS.clear()     # "unstable" resets: the MuJoCo finite column says it

    bad_envs = int((first_bad >= 0).sum())
    return dict(
        name=name, nq=model.nq, nv=model.nv, status="ok", inputs=kind,
        finite=bad_envs == 0,
        nonfinite_at=float(first_bad[first_bad >= 0].min() + 1) * params.dt if bad_envs else None,
        nonfinite_envs=bad_envs,
        max_qd=float(max_qd), limit_excess=float(excess),
        penetration_rest=float(rest), penetration_worst=float(worst),
        mujoco_finite=mj_bad < 0,
        mujoco_nonfinite_at=(mj_bad + 1) * params.dt if mj_bad >= 0 else None,
        mujoco_limit_excess=mj_excess, mujoco_penetration_rest=mj_rest,
        mujoco_penetration_worst=mj_worst,
        myriad_s=ours_s, mujoco_s=theirs_s, note="; ".join(n for n in notes if n))


# ---------------------------------------------------------------------------- the table
COLUMNS = ["model", "source", "nq/nv", "Myriad finite", "max\\|qd\\|", "limit excess",
           "penetration mm (rest → worst)", "MuJoCo finite", "MuJoCo limit excess",
           "MuJoCo penetration mm", "wall s (Myriad / MuJoCo)", "note"]


def mm(rest: float, worst: float) -> str:
    show = lambda x: ("none" if math.isinf(x) else f"{x * 1e3:.1f}" if abs(x) < 10  # noqa: E731
                      else f"{x * 1e3:.3g}")
    return f"{show(rest)} → {show(worst)}"


def row(result: dict, source: str) -> str:
    r = result
    cells = [r["name"], source]
    if r["status"] != "ok":
        cells += [f"{r['nq']}/{r['nv']}" if "nv" in r else "–", r["status"]]
        cells += ["–"] * (len(COLUMNS) - len(cells) - 1) + [r.get("note", "")]
    else:
        ours = "yes" if r["finite"] else \
            f"**no** (t={r['nonfinite_at']:.2f} s, {r['nonfinite_envs']} envs)"
        theirs = "yes" if r["mujoco_finite"] else f"no (t={r['mujoco_nonfinite_at']:.2f} s)"
        cells += [f"{r['nq']}/{r['nv']}", ours, f"{r['max_qd']:.3g}", f"{r['limit_excess']:.3g}",
                  mm(r["penetration_rest"], r["penetration_worst"]), theirs,
                  f"{r['mujoco_limit_excess']:.3g}",
                  mm(r["mujoco_penetration_rest"], r["mujoco_penetration_worst"]),
                  f"{r['myriad_s']:.1f} / {r['mujoco_s']:.2f}", r["note"]]
    return "| " + " | ".join(str(c).replace("|", "\\|").replace("\n", " ") for c in cells) + " |"


def short(text: str) -> str:
    """A message with the long install paths cut to the part that names the file."""
    robots = robots_folder()
    text = text.replace(robots + "/", "robots/") if robots else text
    return re.sub(r"/\S+/site-packages/", "", text).replace("\n", " ")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="+", metavar="NAME",
                        help="names or glob patterns (e.g. 'gymnasium/*', 'solo/*')")
    parser.add_argument("--seconds", type=float, default=2.0, help="simulated seconds per model")
    parser.add_argument("--envs", type=int, default=4)
    parser.add_argument("--list", action="store_true", help="print the corpus names and exit")
    parser.add_argument("--no-self-collisions", action="store_true",
                        help="Myriad's SimParams(self_collisions=False) (MuJoCo unchanged)")
    parser.add_argument("--integrator", choices=("euler", "implicit"), default="euler",
                        help="Myriad's SimParams(integrator=...) (MuJoCo unchanged)")
    args = parser.parse_args()
    params = myriad.SimParams(self_collisions=not args.no_self_collisions,
                              integrator=args.integrator)

    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    models = corpus_models()
    if args.only:
        models = [m for m in models if any(fnmatch.fnmatchcase(m[0], p) for p in args.only)]
    if args.list:
        for name, source, _ in models:
            print(f"{name}  ({source})")
        return

    mujoco.set_mju_user_warning(MUJOCO_WARNINGS.append)   # into the notes, not the table
    print(f"engine: {myriad.__file__}; {args.envs} envs, {args.seconds:g} s each, "
          f"dt {params.dt:.4g} s in {params.substeps} substeps, "
          f"self-collisions {'on' if params.self_collisions else 'off'}, "
          f"integrator {params.integrator}\n")
    print("| " + " | ".join(COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS), flush=True)
    start = time.perf_counter()
    for name, source, loader in models:
        try:
            result = run_model(name, loader, args.seconds, args.envs, params)
        except MujocoRejects as err:
            result = dict(name=name, status="MuJoCo rejects", note=short(str(err)))
        except myriad.ModelError as err:    # the message starts with the file or the name
            reason = short(re.sub(r"^\S+: ", "", str(err)))
            result = dict(name=name, status=f"refused: {reason}")
        except Exception as err:  # noqa: BLE001  a crash is this model's row, not the end
            where = traceback.extract_tb(err.__traceback__)[-1]
            result = dict(name=name, status=f"**crashed**: {type(err).__name__}: {err} "
                          f"({os.path.basename(where.filename)}:{where.lineno})")
        print(row(result, source), flush=True)
    print(f"\n{len(models)} models in {time.perf_counter() - start:.0f} s", flush=True)


if __name__ == "__main__":
    main()
