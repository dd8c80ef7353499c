"""One step of the engine, stage by stage: read `step` first.

Each stage is a few kernel launches of a module in `stages/`, over the launch dimensions written
here: the env count first, then the elements a thread takes (geoms, pairs, sites); cooperative
kernels (`lanes`) take `lanes` threads per env, their counts declared in `runtime.BlockDim`.
`rt` (a `runtime.Runtime`) launches them on the device, `dm` (a `build.DeviceModel`) is what all
envs share, `d` (a `build.Data`) the per-env structs.
"""

from __future__ import annotations

from .runtime.launch import BLOCK_DIM
from .stages import (collision, constraints, dynamics, forces, integrate, kinematics, sensors,
                     solver_tgs, tendons)

# the stages of one substep, in order, then those that run once after the last substep
SUBSTEP_STAGES = ("kinematics", "collision", "dynamics", "applied_forces", "solve_unconstrained",
                  "constraint_rows", "solve_constraints", "integrate")
FINAL_STAGES = ("kinematics", "constraint_outputs")


def step(rt, dm, d, substeps: int, stage=None) -> None:
    """Advance every env by `substeps` substeps of dm.opt.h. `stage(name, run)` runs each stage
    (default: run it), so that a caller can time them."""
    stage = stage or (lambda name, run: run(rt, dm, d))
    for _ in range(substeps):
        for name in SUBSTEP_STAGES:
            stage(name, STAGES[name])
    for name in FINAL_STAGES:     # poses and velocities of the new state, for the caller
        stage(name, STAGES[name])


def forward(rt, dm, d) -> None:
    """Poses, velocities, bias and applied forces from q, qd (no time passes)."""
    run_kinematics(rt, dm, d)
    run_dynamics(rt, dm, d)
    rt.launch_lanes(forces.body_wrenches, BLOCK_DIM.bodies,
                    [dm.m, d.env_params, dm.opt, d.state, d.control, d.dynamics])


# ---------------------------------------------------------------------------------- the stages
def run_kinematics(rt, dm, d) -> None:
    rt.launch_lanes(kinematics.kinematics, BLOCK_DIM.bodies, [dm.m, d.state])
    if dm.sizes["nsite"]:
        rt.launch(kinematics.site_frames, (rt.num_envs, dm.sizes["nsite"]),
                  [dm.m, d.env_params, d.state])
    if dm.sizes["nspatial"]:
        rt.launch(tendons.spatial_tendons, (rt.num_envs, dm.sizes["nspatial"]),
                  [dm.m, d.env_params, d.state])


def run_collision(rt, dm, d) -> None:
    if dm.contact_capacity == 0:
        return
    n, c = rt.num_envs, d.contacts
    rt.launch(collision.geom_frames, (n, dm.sizes["ngeom"]),
              [dm.m, d.env_params, dm.meshes, d.state])
    rt.shard_of(c.count).zero_()
    if dm.pairs.shape[0]:
        # a GPU runs a thread per (env, pair), whose contacts take places through an atomic
        # counter, then puts them in the order a CPU thread gives by walking an env's pairs;
        # an env that overflowed its places is walked again that way, so which contacts were
        # kept never depends on which atomic came first
        inputs = [dm.m, dm.opt, dm.pairs, d.env_params, dm.meshes, dm.hfields, d.state, c]
        if rt.device.is_cuda:
            rt.launch(collision.narrowphase, (n, dm.pairs.shape[0]), inputs)
            rt.launch(collision.redo_overflowed, n, inputs)
            rt.launch(collision.order_by_pair, n, [c])
        else:
            rt.launch(collision.narrowphase_per_env, n, inputs)
        rt.launch(collision.keep_deepest, n, [c])


def run_dynamics(rt, dm, d) -> None:
    rt.launch_lanes(dynamics.bias_forces, BLOCK_DIM.bodies,
                    [dm.m, d.env_params, d.state, d.dynamics])


def run_applied_forces(rt, dm, d) -> None:
    rt.launch_lanes(forces.body_wrenches, BLOCK_DIM.bodies,
                    [dm.m, d.env_params, dm.opt, d.state, d.control, d.dynamics])
    rt.launch_lanes(forces.generalized_forces, BLOCK_DIM.dofs,
                    [dm.m, d.env_params, dm.opt, d.state, d.control, d.dynamics])


def run_solve_unconstrained(rt, dm, d) -> None:
    rt.launch_lanes(dynamics.solve_acceleration, BLOCK_DIM.bodies, [
        dm.m, d.env_params, d.state, d.dynamics,
        d.state.qacc.reshape((rt.num_envs, 1, dm.sizes["nv"]))])
    if dm.implicit:
        rt.launch(dynamics.implicit_acceleration, rt.num_envs,
                  [dm.m, d.env_params, dm.opt, d.state, d.dynamics])


def run_constraint_rows(rt, dm, d) -> None:
    if dm.nrow == 0:
        return
    rt.launch_lanes(constraints.build_rows, BLOCK_DIM.rows, [
        dm.m, dm.opt, dm.layout, d.env_params, d.state, d.dynamics, d.contacts, d.rows])


def run_solve_constraints(rt, dm, d) -> None:
    rt.launch_lanes(solver_tgs.solve, BLOCK_DIM.solve,
                    [dm.m, dm.opt, dm.layout, d.dynamics, d.contacts, d.rows, d.state])


def run_integrate(rt, dm, d) -> None:
    rt.launch_lanes(integrate.integrate, BLOCK_DIM.dofs, [dm.m, d.state])
    if dm.activations:
        rt.launch(forces.integrate_activations, (rt.num_envs, dm.sizes["nu"]),
                  [dm.m, dm.opt, d.state, d.control])


def run_constraint_outputs(rt, dm, d) -> None:
    rt.launch_lanes(solver_tgs.constraint_forces, BLOCK_DIM.dofs,
                    [dm.m, dm.opt, dm.layout, d.rows, d.contacts])
    # sensors: site poses and velocities are current (the final kinematics computed them)
    if dm.sensor_accelerations:
        rt.launch_lanes(sensors.force_sensors, BLOCK_DIM.bodies, [
            dm.m, d.env_params, dm.opt, dm.sensor_site_body, dm.sensor_site, d.state,
            d.control, d.contacts, d.dynamics, int(dm.sensor_split)])
    if dm.m.nsensor:
        rt.launch_lanes(sensors.sensor_readings, BLOCK_DIM.dofs,
                        [dm.m, d.env_params, d.state, d.contacts, d.dynamics])


STAGES = {"kinematics": run_kinematics, "collision": run_collision, "dynamics": run_dynamics,
          "applied_forces": run_applied_forces, "solve_unconstrained": run_solve_unconstrained,
          "constraint_rows": run_constraint_rows, "solve_constraints": run_solve_constraints,
          "integrate": run_integrate, "constraint_outputs": run_constraint_outputs}
