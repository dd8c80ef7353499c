"""Grasp and lift: how far a squeezed cube slips in two PD-driven fingers, against iteration
count, TGS and PGS, and MuJoCo.

    python benchmarks/grasp.py

Issue 12, item 7. A hand on a vertical slide (lift) and a vertical hinge (wrist) carries two
box fingers on slides along x, each a position drive (kp 400, kv 10) told to close past the
cube, which squeezes it with about 10 N. "mimic": one drive moves the first finger and a joint
equality makes the second follow (q2 = q1, the fingers' axes opposed), as the Panda's URDF
gripper is loaded. The cube is 5 cm, 0.1 kg, friction 1. Schedule at Isaac Gym's timing (dt
1/60 s in 2 substeps): settle 0.25 s, close 0.5 s, lift 20 cm at 0.5 m/s, hold 3 s (the slip:
how far the cube moved relative to the hand over the hold), turn the wrist a quarter turn in
0.5 s and hold 1 s (thrown: how far the cube moved in the hand from the end of the hold). MuJoCo C (implicitfast, for the stiff lift drive) steps the same model and controls at two 1/120 s steps per control step.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import torch
import warp as wp

import myriad

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
    x, y, z, w = hand_quat_xyzw[-1]
    turned = 2 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))
    return {"slip": float(slip), "thrown": float(thrown), "lifted": float(lifted),
            "turned": turned}


def myriad_grasp(mimic: bool, solver: str = "tgs", iterations: int = 4,
                 device: str = "cpu") -> dict:
    model = myriad.load_xml(grasp_xml(mimic), "grasp")
    params = myriad.SimParams(dt=DT, substeps=2, solver=solver, position_iterations=iterations,
                              velocity_iterations=1)
    sim = myriad.Simulator(model, num_envs=1, params=params, device=device, cpu_threads=1)
    hand, cube = model.body_index("hand"), model.body_index("cube")
    ctrl = torch.as_tensor(schedule(model.nu), device=sim.torch_device)
    poses = []
    for k in range(len(ctrl)):
        sim.ctrl = ctrl[k]
        sim.step()
        poses.append(sim.body_pose[0, [hand, cube]].cpu().numpy().copy())
    poses = np.asarray(poses)
    return _measure(poses[:, 0, :3], poses[:, 0, 3:], poses[:, 1, :3])


def mujoco_grasp(mimic: bool) -> dict:
    model = myriad.load_xml(grasp_xml(mimic), "grasp")
    mj = model.mj_model
    mj.opt.timestep = DT / 2
    d = mujoco.MjData(mj)
    hand, cube = mj.body("hand").id, mj.body("cube").id
    hp, hq, cp = [], [], []
    for row in schedule(mj.nu):
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
    for mimic in (False, True):
        cells = []
        for solver in ("tgs", "pgs"):
            for it in (4, 8):
                r = myriad_grasp(mimic, solver, it)
                cells.append(f"{1e3 * r['slip']:.2f} / {1e3 * r['thrown']:.1f}")
        r = mujoco_grasp(mimic)
        cells.append(f"{1e3 * r['slip']:.2f} / {1e3 * r['thrown']:.1f}")
        name = "one drive, mimic joint" if mimic else "two drives"
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
