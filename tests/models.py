"""Test models generated in code: a random kinematic tree and a chain with a wide mass spread."""

import numpy as np


def _quat_str(rng) -> str:
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    return " ".join(f"{x:.6f}" for x in q)


def random_tree_xml(seed: int, nbody: int = 30) -> str:
    """A tree of `nbody` bodies mixing free, ball, hinge, slide and two-hinge bodies.

    Body 0 hangs off the world by a free joint; every later body picks a random earlier parent,
    so the tree has branches of varying depth. Frames, centers of mass, principal axes,
    inertias, joint anchors and axes are all random.
    """
    rng = np.random.default_rng(seed)
    kinds = ["ball", "hinge", "slide", "hinge2"]
    children: dict[int, list[int]] = {i: [] for i in range(-1, nbody)}
    children[-1].append(0)
    for b in range(1, nbody):
        children[int(rng.integers(0, b))].append(b)
    joint = {0: "free"}
    for b in range(1, nbody):
        joint[b] = kinds[b % 4] if b < 8 else kinds[int(rng.integers(0, 4))]

    def vec(scale):
        return " ".join(f"{x:.6f}" for x in rng.uniform(-scale, scale, 3))

    def axis():
        a = rng.normal(size=3)
        return " ".join(f"{x:.6f}" for x in a / np.linalg.norm(a))

    def body(b: int, depth: int) -> str:
        pos = vec(0.3) if b else "0 0 1"
        xml = [f'{"  " * depth}<body name="b{b}" pos="{pos}" quat="{_quat_str(rng)}">']
        inertia = " ".join(f"{x:.6f}" for x in rng.uniform(0.05, 0.1, 3))
        xml.append(f'<inertial pos="{vec(0.1)}" quat="{_quat_str(rng)}" mass="{rng.uniform(0.5, 2):.4f}" '
                   f'diaginertia="{inertia}"/>')
        arm = f'armature="{rng.uniform(0, 0.05):.4f}" damping="{rng.uniform(0, 0.2):.4f}"'
        k = joint[b]
        if k == "free":
            xml.append('<freejoint name="j0"/>')
        elif k == "ball":
            xml.append(f'<joint name="j{b}" type="ball" pos="{vec(0.1)}" {arm}/>')
        elif k == "slide":
            xml.append(f'<joint name="j{b}" type="slide" pos="{vec(0.1)}" axis="{axis()}" {arm}/>')
        elif k == "hinge":
            xml.append(f'<joint name="j{b}" type="hinge" pos="{vec(0.1)}" axis="{axis()}" {arm}/>')
        else:
            xml.append(f'<joint name="j{b}a" type="hinge" pos="{vec(0.1)}" axis="{axis()}" {arm}/>')
            xml.append(f'<joint name="j{b}b" type="hinge" pos="{vec(0.1)}" axis="{axis()}" {arm}/>')
        xml.append(f'<geom type="capsule" size="0.03" fromto="0 0 0 {vec(0.2)}" contype="0" conaffinity="0"/>')
        for c in children[b]:
            xml.append(body(c, depth + 1))
        xml.append("</body>")
        return "\n".join(xml)

    return f"""<mujoco model="random_tree_{seed}">
  <option timestep="0.002"/>
  <worldbody>
{body(0, 1)}
  </worldbody>
</mujoco>"""


def chain_xml(nlink: int = 10, mass_ratio: float = 1000.0) -> str:
    """A hinge chain hanging from the world whose link masses span 1 : mass_ratio geometrically."""
    masses = np.geomspace(1.0, mass_ratio, nlink)
    xml, close = [], []
    for i, m in enumerate(masses):
        axis = "0 1 0" if i % 2 == 0 else "1 0 0"
        pos = "0 0 2" if i == 0 else "0 0 -0.2"
        xml.append(f'<body name="link{i}" pos="{pos}">'
                   f'<joint name="hinge{i}" type="hinge" axis="{axis}" damping="0.01"/>'
                   f'<geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02" mass="{m:.6f}" '
                   f'contype="0" conaffinity="0"/>')
        close.append("</body>")
    return f"""<mujoco model="chain">
  <worldbody>
    {''.join(xml)}{''.join(close)}
  </worldbody>
</mujoco>"""


def capsule_chain_xml(nlink: int, direction=(0.0, 0.0, -1.0), length: float = 0.1,
                      mass: float = 0.1) -> str:
    """`nlink` capsules of `length` and `mass` in a hinge chain (axes along y) from a point 0.1 m
    above nlink·length, each link pointing along `direction`; no floor, no collisions."""
    step = " ".join(f"{length * c:g}" for c in direction)
    xml = []
    for i in range(nlink):
        pos = f"0 0 {length * nlink + 0.1:g}" if i == 0 else step
        xml.append(f'<body name="link{i}" pos="{pos}"><joint name="hinge{i}" axis="0 1 0"/>'
                   f'<geom type="capsule" fromto="0 0 0 {step}" size="0.01" mass="{mass:g}" '
                   'contype="0" conaffinity="0"/>')
    return (f'<mujoco model="capsule_chain"><worldbody>{"".join(xml)}{"</body>" * nlink}'
            "</worldbody></mujoco>")
