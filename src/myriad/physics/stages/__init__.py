"""The stages of a step, one module each, in the order `step.step` runs them:

1. `kinematics`  body poses and velocities, motion subspaces, site frames, Jacobians
2. `collision`   geom frames, narrowphase over the candidate pairs, contact slots
3. `dynamics`    bias forces (RNEA), the mass matrix's factor, unconstrained qacc
4. `forces`      applied, actuator, spring and damper forces; implicit terms
5. `constraints` constraint rows: contacts, limits, tendons, equalities, dof rows
6. `solver_tgs`  the TGS (or PGS) solve of the rows, and their forces afterwards
7. `integrate`   q ⊕ the solver's displacement
8. `sensors`     force/torque and MuJoCo sensors after the step
"""
