"""The original's Allegro hand beside Myriad's, in Myriad's AllegroHand task: what a hand that
holds its fingers still does with a cube let go where the original lets it go.

    python benchmarks/allegro_original_hand.py --isaacgymenvs PATH [--envs 128] [--seconds 10]

PATH: a checkout of IsaacGymEnvs, whose assets/urdf/kuka_allegro_description holds the hand the
original trains (`allegro_touch_sensor.urdf`, its links' meshes taken as convex hulls, as PhysX
takes them); Myriad ships no copy. That hand is placed as the original places it (its root
`allegro_mount` at (0, 0, 0.5) turned R_y(π)·R_x(0.47π)·R_z(π/4)) with the original's joint
settings (drives kp 3, kd 0.1, effort 0.5, dry friction 0.01, armature 0.001, its URDF's speed
limits of 6.283 rad/s, its links colliding with each other but not with their parents, as
Isaac Gym's URDF loader and filter -1 let them), and the cube is let go at the
original's (0, -0.2, 0.56); Myriad's own hand is the task as it ships. Printed for each hand:

- zero actions (every target mid-range), `--envs` envs for `--seconds` with the task's reset
  noise: episodes ended (the cube 24 cm from its goal), and how far the cube's median position
  lies from where it was let go, toward the palm (+y);
- the fingers held straight (every target 0), no reset noise, 2 s: the cube's distance from its
  goal at the end, and how far it moved over the last second.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from xml.etree import ElementTree

import mujoco
import torch
import warp as wp

import myriad
from myriad.assets import dof_max_velocity, urdf_spec
from myriad.tasks import apply_overrides, task_config
from myriad.tasks.hands import HAND_POS, AllegroHand
from myriad.torch_utils import quat_from_angle_axis, quat_mul

HAND = "assets/urdf/kuka_allegro_description"
ORIGINAL_START = (0.0, -0.2, 0.56)


def original_hand_spec(root: str) -> tuple[mujoco.MjSpec, ElementTree.Element]:
    """The original's hand from an IsaacGymEnvs checkout, with its joint settings, and its
    URDF (parsed)."""
    urdf = os.path.join(root, HAND, "allegro_touch_sensor.urdf")
    if not os.path.isfile(urdf):
        raise SystemExit(f"--isaacgymenvs {root}: no {HAND}/allegro_touch_sensor.urdf there")
    text = open(urdf).read()
    # its mesh paths are relative to two different folders: made absolute
    text = text.replace('filename="kuka_allegro_description/',
                        f'filename="{os.path.join(root, "assets/urdf")}/kuka_allegro_description/')
    text = text.replace('filename="meshes/', f'filename="{os.path.join(root, HAND)}/meshes/')
    with tempfile.TemporaryDirectory() as folder:
        fixed = os.path.join(folder, "allegro.urdf")
        with open(fixed, "w") as f:
            f.write(text)
        spec = urdf_spec(fixed, '<mujoco><compiler discardvisual="true" fusestatic="true" '
                         'inertiafromgeom="false" balanceinertia="true"/></mujoco>',
                         root_link="allegro_mount")
    for joint in spec.joints:
        if joint.type != mujoco.mjtJoint.mjJNT_FREE:
            joint.frictionloss, joint.armature = 0.01, 0.001
            joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE
            joint.actfrcrange = [-0.5, 0.5]
    return spec, ElementTree.fromstring(text)


class OriginalAllegroHand(AllegroHand):
    """AllegroHand with the original's hand, placed and set as the original does."""
    isaacgymenvs: str = ""

    def hand_actor(self, scene):
        self.hand_spec, self.hand_urdf = original_hand_spec(self.isaacgymenvs)
        axes = torch.eye(3)
        turn = quat_mul(quat_mul(quat_from_angle_axis(torch.tensor([math.pi]), axes[1:2]),
                                 quat_from_angle_axis(torch.tensor([0.47 * math.pi]), axes[0:1])),
                        quat_from_angle_axis(torch.tensor([0.25 * math.pi]), axes[2:3]))[0]
        control = self.cfg["env"]["control"]
        return scene.add_actor("hand", self.hand_spec, pos=HAND_POS, quat=tuple(turn.tolist()),
                               fix_base=True, dof_mode="position",
                               stiffness=control["stiffness"], damping=control["damping"],
                               gravity=False)

    def dof_speed_limits(self) -> list[float]:
        return dof_max_velocity(self.hand_urdf, self.envs.dof_names)     # 6.283 rad/s


def make(original: str | None, num_envs: int, **overrides):
    if original is None:
        return myriad.make("AllegroHand", num_envs=num_envs, **overrides)
    cfg = task_config("AllegroHand")
    cfg.pop("cpu", None)
    apply_overrides(cfg, {"numEnvs": num_envs, "objectStartPos": list(ORIGINAL_START),
                          **overrides}, "AllegroHand")
    OriginalAllegroHand.isaacgymenvs = original
    return OriginalAllegroHand(cfg)


def measure(original: str | None, envs: int, seconds: float) -> str:
    task = make(original, envs)
    task.reset()
    ended, positions = 0, []
    for _ in range(round(seconds / task.dt)):
        done = task.step(torch.zeros(envs, task.num_actions))[2]
        ended += int(done.sum())
        positions.append(task.envs.root_states[:, task.cube, 0:3].clone())
    median = torch.stack(positions).flatten(0, 1).median(0).values
    swept = float(median[1] - task.cube_start_pos[1])

    task = make(original, 2, resetPositionNoise=0.0, resetDofPosRandomInterval=0.0)
    task.reset()
    straight = (2 * (0 - task.dof_lower) / (task.dof_upper - task.dof_lower) - 1).clamp(-1, 1)
    path = []
    for _ in range(round(2.0 / task.dt)):
        task.step(straight.repeat(2, 1))
        path.append(task.envs.root_states[0, task.cube, 0:3].clone())
    second = round(1.0 / task.dt)
    return (f"zero actions, {envs} envs x {seconds:g} s: {ended} episodes ended, the cube's "
            f"median position {100 * swept:+.1f} cm from its start toward the palm; straight "
            f"fingers, 2 s: {100 * float((path[-1] - task.goal_pos[0]).norm()):.1f} cm from its "
            f"goal, moved {1000 * float((path[-1] - path[-1 - second]).norm()):.2f} mm over the "
            f"last second")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--isaacgymenvs", required=True, metavar="PATH")
    ap.add_argument("--envs", type=int, default=128)
    ap.add_argument("--seconds", type=float, default=10.0)
    args = ap.parse_args()
    wp.config.log_level = wp.LOG_WARNING
    torch.manual_seed(0)
    print("Myriad's hand:    ", measure(None, args.envs, args.seconds))
    torch.manual_seed(0)
    print("the original's:   ", measure(args.isaacgymenvs, args.envs, args.seconds))


if __name__ == "__main__":
    main()
