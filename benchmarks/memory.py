"""Device memory per env of a simulator, and what 16,384 envs of a hand-and-cube model take.

The hand stand-in: a fixed palm with five fingers of 4-5 hinges (24 DoF, capsules) and a free
cube (6 DoF): 30 DoF, 64 contact slots per env, as the memory target of the contacts issue.
Memory is measured (the capacity of every array the simulator allocates, at 2 envs minus 1 env),
not estimated.

    python benchmarks/memory.py
"""

from __future__ import annotations

import warp as wp

import myriad


def hand_and_cube_xml() -> str:
    fingers = []
    for f, (x, joints) in enumerate([(-0.04, 5), (-0.02, 5), (0.0, 5), (0.02, 5), (0.05, 4)]):
        xml, close = [], []
        for j in range(joints):
            pos = f"{x} 0 0.1" if j == 0 else "0 0 0.03"
            axis = "0 1 0" if j != 1 else "1 0 0"
            xml.append(f'<body pos="{pos}"><joint type="hinge" axis="{axis}" range="-0.3 1.5" limited="true"/>'
                       f'<geom type="capsule" fromto="0 0 0 0 0 0.03" size="0.008" mass="0.02"/>')
            close.append("</body>")
        fingers.append("".join(xml) + "".join(close))
    return f"""<mujoco><worldbody><geom type="plane" size="1 1 0.1"/>
      <body name="palm" pos="0 0 0.3"><geom type="box" size="0.05 0.01 0.1" mass="0.5"/>{''.join(fingers)}</body>
      <body name="cube" pos="0 -0.05 0.45"><freejoint/><geom type="box" size="0.03 0.03 0.03" mass="0.1"/></body>
      </worldbody></mujoco>"""


def memory_per_env(model, params, device="cpu") -> int:
    def total(n):
        sim = myriad.Simulator(model, num_envs=n, device=device, params=params)
        return sim.nbytes
    return total(2) - total(1)


def main() -> None:
    wp.config.log_level = wp.LOG_WARNING
    params = myriad.SimParams(contacts_per_env=64)
    rows = [("ant", myriad.load(myriad.asset_path("ant.xml"))),
            ("humanoid", myriad.load(myriad.asset_path("humanoid.xml"))),
            ("hand-and-cube (30 DoF)", myriad.load_xml(hand_and_cube_xml(), "hand-and-cube"))]
    print("| model | nv | constraint rows | bytes per env (64 contact slots) | 16,384 envs |")
    print("|---|---|---|---|---|")
    for name, model in rows:
        per_env = memory_per_env(model, params)
        nrow = myriad.Simulator(model, params=params).nrow
        print(f"| {name} | {model.nv} | {nrow} | {per_env:,} | {per_env * 16384 / 2**30:.2f} GiB |")


if __name__ == "__main__":
    main()
