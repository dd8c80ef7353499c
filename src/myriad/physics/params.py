"""`SimParams`: time stepping and solver settings, checked when made."""

import dataclasses
import math

import numpy as np


@dataclasses.dataclass(frozen=True)
class SimParams:
    """Time stepping and solver settings (PhysX/Isaac Gym names and defaults).

    The contact and solver settings are read by the constraint solver.
    """

    dt: float = 1.0 / 60.0                # one step()
    substeps: int = 2                     # step() = substeps × substep of dt / substeps
    gravity: tuple | None = None          # None: the model's <option gravity> (default 0 0 -9.81)
    solver: str = "tgs"                   # "tgs" or "pgs"
    # "euler": MuJoCo's semi-implicit Euler (dof damping implicit). "implicit": also the
    # Coriolis and centrifugal forces' derivative in velocity, as MuJoCo's "implicit": explicit,
    # their term gains energy on links spinning at h·ω of a few tenths (a G1's hand whipped to
    # 80 rad/s: +30 to +1200 J a step at h = 8.3 ms, MuJoCo's Euler alike; `robot_stress.py`)
    integrator: str = "euler"
    position_iterations: int = 4
    velocity_iterations: int = 1
    contact_offset: float = 0.02          # shapes closer than this generate contacts (m)
    rest_offset: float = 0.0              # shapes come to rest at this separation (m)
    bounce_threshold_velocity: float = 0.2    # no restitution below this approach speed (m/s)
    # caps on the speeds at which the solver undoes errors (m/s; rad/s for a hinge's limit):
    # a contact's penetration, 1 m/s as Isaac Lab's robots (G1, H1, ANYmal) set it: at 10, a
    # G1 under random torques pumped energy through contacts between neighbouring links that
    # a limit held in place (1000x in 2 s in 2 of 40 envs; `benchmarks/robot_stress.py`).
    # Limits and equalities keep 10: capped at 1, TALOS's mimic grippers lagged past their
    # limits. A task's `physx.max_depenetration_velocity` (Isaac Gym's one setting) sets both
    max_depenetration_velocity: float = 1.0
    max_correction_velocity: float = 10.0
    max_joint_velocity: float = 100.0     # default per-dof speed cap (PhysX's default), rad/s or m/s
    # default per-body speed caps, Isaac Gym's (AssetOptions.max_angular_velocity, rad/s, and
    # max_linear_velocity, m/s): a body above one is pulled back toward it as PhysX pulls its
    # links (`forces.speed_cap_wrench`; docs/physics.md, "Body speed caps"). math.inf: no cap
    max_angular_velocity: float = 64.0
    max_linear_velocity: float = 1000.0
    contacts_per_env: int = 64            # contact slots of each env (fewer if its pairs cannot fill them)
    constraints: bool = True              # False: smooth dynamics only (no contacts, no limits)
    self_collisions: bool = True          # bodies of one articulation collide with each other
    # a body does not collide with its ancestors up to this many generations above it: 1, its
    # parent only (MuJoCo's and PhysX's filter); 2 also skips its grandparent, whose contacts
    # with it (across the link between them: a pelvis and an upper torso, a torso and an upper
    # arm) fought the two joints and ran TALOS's energy away in 14 of 120 envs
    # (`benchmarks/robot_stress.py`). A task's settings and Isaac Gym's keep 1
    filter_ancestors: int = 2
    # contacts the joint-limit block may solve together with the limits in a sweep
    # (`solver_tgs._block_contacts`): a body's contacts with the world or another tree that a
    # pushing limit holds up. 16 keeps every humanoid and quadruped of the corpus at or above
    # MuJoCo's depth, at 1.06-1.1x the step's time, and trained no task worse. 0: the limits
    # are solved alone, after the contacts, and have the last word: a legged robot falling onto
    # its limit stops, then drives its feet into the ground (a B1 40 mm, MuJoCo 20 mm over 40
    # envs). docs/physics.md, "Contacts join the limit block"
    limit_block_contacts: int = 16

    def __post_init__(self):
        def bad(field, why):
            raise ValueError(f"SimParams.{field}={getattr(self, field)!r}: {why}")

        if not (isinstance(self.dt, (int, float)) and math.isfinite(self.dt) and self.dt > 0):
            bad("dt", "must be a positive, finite number of seconds")
        for name in ("substeps", "position_iterations", "filter_ancestors"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 1:
                bad(name, "must be an integer >= 1")
        for name in ("velocity_iterations", "contacts_per_env", "limit_block_contacts"):
            v = getattr(self, name)
            if not isinstance(v, int) or isinstance(v, bool) or v < 0:
                bad(name, "must be an integer >= 0")
        if self.solver not in ("tgs", "pgs"):
            bad("solver", "must be 'tgs' or 'pgs'")
        if not isinstance(self.constraints, bool):
            bad("constraints", "must be True or False")
        if not isinstance(self.self_collisions, (bool, dict)):
            bad("self_collisions", "must be True or False (or a dict: articulation root body "
                "-> True/False)")
        if self.integrator not in ("euler", "implicit"):
            bad("integrator", "must be 'euler' or 'implicit'")
        if self.gravity is not None and np.shape(self.gravity) != (3,):
            bad("gravity", "must be three numbers (x, y, z) or None")
        for name in ("contact_offset", "rest_offset", "bounce_threshold_velocity",
                     "max_depenetration_velocity", "max_correction_velocity",
                     "max_joint_velocity"):
            if not math.isfinite(getattr(self, name)) or getattr(self, name) < 0:
                bad(name, "must be a finite number >= 0")
        for name in ("max_angular_velocity", "max_linear_velocity"):
            if not getattr(self, name) > 0:
                bad(name, "must be > 0 (math.inf for no cap)")
        if self.rest_offset > self.contact_offset:
            bad("rest_offset", f"must not exceed contact_offset={self.contact_offset}")
