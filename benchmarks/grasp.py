"""Grasp and lift: how far a squeezed cube slips in two PD-driven fingers, against iteration
count, TGS and PGS, and MuJoCo.

    python benchmarks/grasp.py

Issue 12, item 7. Three scenes (`SCENES`):
  "two drives", "mimic joint": a hand on a vertical slide (lift) and a vertical hinge (wrist)
      carries two box fingers on slides along x, each a position drive (kp 400, kv 10) told to
      close past the cube, which squeezes it with about 10 N; or one drive moves the first
      finger and a joint equality makes the second follow (q2 = q1, the axes opposed).
  "panda": the Franka Panda URDF of example-robot-data as `corpus` loads it (its finger 2
      mimics finger 1: a joint equality), fixed on a floor, position drives on its 7 joints and
      on finger 1 (kp 400, kv 10). Its own finger collision boxes hold the cube; the arm follows
      a path of joint targets found by inverse kinematics, the pads around the cube pointing
      down, then straight up.
The cube is 5 cm, 0.1 kg, friction 1. Schedule at Isaac Gym's timing (dt 1/60 s in 2
substeps): settle 0.25 s, close 0.5 s, lift 20 cm at 0.5 m/s, hold 3 s (the slip: how far the
cube moved relative to the hand over the hold), turn the wrist a quarter turn in 0.5 s and hold
1 s (thrown: how far the cube moved in the hand from the end of the hold). MuJoCo C
(implicitfast, for the stiff drives) steps the same model and controls at two 1/120 s steps
per control step.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import torch
import warp as wp

import myriad

import corpus             # benchmarks/corpus.py: example-robot-data and its URDFs' load fixes

DT = 1 / 60
SETTLE, CLOSE, LIFT, HOLD, TURN, AFTER = 0.25, 0.5, 0.4, 3.0, 0.5, 1.0
LIFT_SPEED = 0.5          # m/s
TURN_ANGLE = math.pi / 2  # rad


def grasp_xml(mimic: bool) -> str:
    second = ('<equality><joint joint1="right" joint2="left" polycoef="0 1 0 0 0"/></equality>'
              if mimic else "")
    right_drive = "" if mimic else '<position name="right" joint="right" kp="400" kv="10"/>'
    return f"""<mujoco model="grasp"><option timestep="0.002" integrator="implicitfast"/>
  <default><geom friction="1 0.005 0.0001"/></default>
  <worldbody>
    <geom name="floor" type="plane" size="1 1 0.1"/>
    <body name="hand" pos="0 0 0.0255">
      <joint name="lift" type="slide" axis="0 0 1"/>
      <joint name="wrist" type="hinge" axis="0 0 1"/>
      <geom name="palm" type="box" size="0.07 0.02 0.005" pos="0 0 0.06" mass="0.5"/>
      <body name="left" pos="-0.06 0 0">
        <joint name="left" type="slide" axis="1 0 0" range="0 0.05"/>
        <geom type="box" size="0.01 0.02 0.03" mass="0.05"/>
      </body>
      <body name="right" pos="0.06 0 0">
        <joint name="right" type="slide" axis="-1 0 0" range="0 0.05"/>
        <geom type="box" size="0.01 0.02 0.03" mass="0.05"/>
      </body>
    </body>
    <body name="cube" pos="0 0 0.0255"><freejoint/>
      <geom type="box" size="0.025 0.025 0.025" mass="0.1"/></body>
  </worldbody>
  {second}
  <actuator>
    <position name="lift" joint="lift" kp="5000" kv="300"/>
    <position name="wrist" joint="wrist" kp="50" kv="5"/>
    <position name="left" joint="left" kp="400" kv="10"/>
    {right_drive}
  </actuator>
</mujoco>"""


# --- the Panda of example-robot-data: its own arm, hand and fingers (one driven, one mimic)
PANDA_TCP = 0.2107          # between the finger pads' centres, from link 7's origin along z (m)
PANDA_CUBE = np.array([0.45, 0.0, 0.025])     # where the cube rests on the floor
# arm drives stiff enough that the hand follows the path under gravity, except the wrist's two
# light joints: at kp 5000 joint 7 (about 0.02 kg m²) chatters at ±15 rad/s after the turn at
# this timestep, in MuJoCo C as in Myriad
PANDA_ARM_KP = [5000.0] * 5 + [500.0] * 2
PANDA_ARM_KV = [100.0] * 5 + [20.0] * 2


def panda_spec():
    """The Panda URDF compiled as `corpus` loads it (its <mimic> finger: a joint equality), on
    a floor, with a site between the pads and a cube there; position drives on the 7 arm joints
    and on finger 1."""
    robots = corpus.robots_folder()
    if robots is None:
        raise FileNotFoundError("example-robot-data is not installed (pip install "
                                "example-robot-data)")
    spec = mujoco.MjSpec.from_string(corpus.urdf_xml(
        f"{robots}/panda_description/urdf/panda.urdf", mobile=False))
    spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[1, 1, 0.1])
    spec.body("panda_link7").add_site(name="tcp", pos=[0, 0, PANDA_TCP])
    cube = spec.worldbody.add_body(name="cube", pos=PANDA_CUBE)
    cube.add_freejoint()
    cube.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025] * 3, mass=0.1)
    for geom in spec.geoms:
        geom.friction = [1.0, 0.005, 0.0001]
    for k in range(1, 8):
        spec.add_actuator(name=f"arm{k}", target=f"panda_joint{k}",
                          trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(
                              kp=PANDA_ARM_KP[k - 1], kv=PANDA_ARM_KV[k - 1])
    spec.add_actuator(name="fingers", target="panda_finger_joint1",
                      trntype=mujoco.mjtTrn.mjTRN_JOINT).set_to_position(kp=400, kv=10)
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    return spec


def panda_path(spec) -> np.ndarray:
    """[steps, 7] arm joint targets: the pads around the cube, pointing down with the fingers
    along y, for the settle and the close; then the lift, straight up at LIFT_SPEED, each
    control step's pose found by damped least squares from the last."""
    m = spec.compile()
    d = mujoco.MjData(m)
    tcp, finger = m.site("tcp").id, m.body("panda_leftfinger").id
    lo, hi = m.jnt_range[:7].T

    def reach(q, target):
        d.qpos[:7] = q
        for _ in range(300):
            mujoco.mj_kinematics(m, d)
            frame = d.xmat[finger].reshape(3, 3)  # z: out of the hand; y: the fingers' axis
            error = np.concatenate([target - d.site_xpos[tcp],
                                    0.5 * np.cross(frame[:, 2], [0, 0, -1.0])   # each: the
                                    + 0.5 * np.cross(frame[:, 1], [0, 1.0, 0])])  # angle, twice
            if np.linalg.norm(error) < 1e-9:
                break
            mujoco.mj_comPos(m, d)
            jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jacSite(m, d, jp, jr, tcp)
            jac = np.vstack([jp[:, :7], jr[:, :7]])
            step = jac.T @ np.linalg.solve(jac @ jac.T + 1e-6 * np.eye(6), error)
            step *= min(1.0, 0.05 / np.abs(step).max())   # small steps: no wander off
            d.qpos[:7] = np.clip(d.qpos[:7] + step, lo, hi)
        if np.linalg.norm(error) > 1e-6:
            raise RuntimeError(f"the Panda cannot reach {target}: error {error}")
        return d.qpos[:7].copy()

    q = reach(np.array([0.0, 0.3, 0.0, -2.4, 0.0, 2.7, -2.356]), PANDA_CUBE)   # a seed near it
    path = [q] * round((SETTLE + CLOSE) / DT)
    for k in range(round(LIFT / DT)):
        q = reach(q, PANDA_CUBE + [0, 0, LIFT_SPEED * DT * (k + 1)])
        path.append(q)
    return np.asarray(path)


def panda_scene() -> tuple[str, np.ndarray, np.ndarray]:
    """(MJCF, [steps, 8] controls: 7 arm targets and the fingers' target, the robot's start)."""
    spec = panda_spec()
    path = panda_path(spec)
    top = path[-1]
    turn = round(TURN / DT)
    wrist = [top + np.eye(7)[6] * TURN_ANGLE * (k + 1) / turn for k in range(turn)]
    arm = np.concatenate([path, [top] * round(HOLD / DT), wrist, [wrist[-1]] * round(AFTER / DT)])
    fingers = np.zeros((len(arm), 1))          # told to close past the cube (each pad 25 mm in)
    fingers[:round(SETTLE / DT)] = 0.04        # open while the arm settles
    start = np.concatenate([path[0], [0.04, 0.04]])     # the fingers open (the URDF: closed)
    return spec.to_xml(), np.concatenate([arm, fingers], axis=1).astype(np.float32), start


def schedule(nu: int) -> np.ndarray:
    """[steps, nu] controls: lift target, wrist target, finger target(s)."""
    phases = [(SETTLE, 0.0, 0.0, 0.0), (CLOSE, 0.0, 0.0, 0.05)]
    out = []
    for seconds, lift, wrist, finger in phases:
        out += [[lift, wrist, finger]] * round(seconds / DT)
    for k in range(round(LIFT / DT)):
        out.append([LIFT_SPEED * DT * (k + 1), 0.0, 0.05])
    top = LIFT_SPEED * LIFT
    out += [[top, 0.0, 0.05]] * round(HOLD / DT)
    turn = round(TURN / DT)
    out += [[top, TURN_ANGLE * (k + 1) / turn, 0.05] for k in range(turn)]
    out += [[top, TURN_ANGLE, 0.05]] * round(AFTER / DT)
    ctrl = np.asarray(out, np.float32)
    return np.concatenate([ctrl, ctrl[:, 2:3]], axis=1) if nu == 4 else ctrl


def _measure(hand_pos, hand_quat_xyzw, cube_pos) -> dict:
    """slip over the hold (cube relative to the hand, in the hand's frame), how far it moved
    in the hand during and after the turn, how high it was lifted and how far the wrist
    turned."""
    def in_hand(k):
        x, y, z, w = hand_quat_xyzw[k]
        u = np.array([-x, -y, -z])
        v = cube_pos[k] - hand_pos[k]
        return v + 2 * w * np.cross(u, v) + 2 * np.cross(u, np.cross(u, v))
    start = round((SETTLE + CLOSE + LIFT) / DT)
    end = start + round(HOLD / DT)
    slip = np.linalg.norm(in_hand(end - 1) - in_hand(start))
    thrown = max(np.linalg.norm(in_hand(k) - in_hand(end - 1)) for k in range(end, len(cube_pos)))
    lifted = cube_pos[end - 1][2] - cube_pos[0][2]
    cos_half = abs(np.dot(hand_quat_xyzw[-1], hand_quat_xyzw[end - 1]))   # the turn's angle
    turned = 2 * math.acos(min(1.0, cos_half))
    return {"slip": float(slip), "thrown": float(thrown), "lifted": float(lifted),
            "turned": turned}


SCENES = ("two drives", "mimic joint", "panda")


def scene(name: str) -> tuple[str, np.ndarray, str, np.ndarray | None]:
    """(MJCF, [steps, nu] controls, the hand's body, the robot's start q or None)."""
    if name == "panda":
        xml, ctrl, start = panda_scene()
        return xml, ctrl, "panda_link7", start
    model_xml = grasp_xml(mimic=name == "mimic joint")
    nu = 3 if name == "mimic joint" else 4
    return model_xml, schedule(nu), "hand", None


def myriad_grasp(name: str, solver: str = "tgs", iterations: int = 4,
                 device: str = "cpu") -> dict:
    xml, ctrl, hand_body, start = scene(name)
    model = myriad.load_xml(xml, "grasp")
    params = myriad.SimParams(dt=DT, substeps=2, solver=solver, position_iterations=iterations,
                              velocity_iterations=1)
    sim = myriad.Simulator(model, num_envs=1, params=params, device=device, cpu_threads=1)
    if start is not None:
        q = sim.q.clone()
        q[:, :len(start)] = torch.as_tensor(start)
        sim.q = q
        sim.forward()
    hand, cube = model.body_index(hand_body), model.body_index("cube")
    ctrl = torch.as_tensor(ctrl, device=sim.torch_device)
    poses = []
    for k in range(len(ctrl)):
        sim.ctrl = ctrl[k]
        sim.step()
        poses.append(sim.body_pose[0, [hand, cube]].cpu().numpy().copy())
    poses = np.asarray(poses)
    return _measure(poses[:, 0, :3], poses[:, 0, 3:], poses[:, 1, :3])


def mujoco_grasp(name: str) -> dict:
    xml, ctrl, hand_body, start = scene(name)
    mj = myriad.load_xml(xml, "grasp").mj_model
    mj.opt.timestep = DT / 2
    d = mujoco.MjData(mj)
    if start is not None:
        d.qpos[:len(start)] = start
    hand, cube = mj.body(hand_body).id, mj.body("cube").id
    hp, hq, cp = [], [], []
    for row in ctrl:
        d.ctrl[:] = row
        mujoco.mj_step(mj, d, nstep=2)
        hp.append(d.xpos[hand].copy())
        hq.append(d.xquat[hand][[1, 2, 3, 0]].copy())
        cp.append(d.xpos[cube].copy())
    return _measure(np.asarray(hp), np.asarray(hq), np.asarray(cp))


def main() -> None:
    wp.config.log_level = wp.LOG_WARNING
    print("cube slip in the hand over a 3 s hold / its largest move in the hand during and "
          "after a quarter turn of the wrist (mm)\n")
    print("| fingers | TGS 4 + 1 | TGS 8 + 1 | PGS 4 + 1 | PGS 8 + 1 | MuJoCo C |")
    print("|---|---|---|---|---|---|")
    for name in SCENES:
        cells = []
        for solver in ("tgs", "pgs"):
            for it in (4, 8):
                r = myriad_grasp(name, solver, it)
                cells.append(f"{1e3 * r['slip']:.2f} / {1e3 * r['thrown']:.1f}")
        r = mujoco_grasp(name)
        cells.append(f"{1e3 * r['slip']:.2f} / {1e3 * r['thrown']:.1f}")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
