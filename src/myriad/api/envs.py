"""`Envs`: `num_envs` copies of a `Scene`, read and written as Isaac Gym-style tensors.

State tensors are buffers on the simulation device, shaped per env, refreshed by `step()` and
`forward()` (Isaac Gym's acquire + refresh in one):

    root_states        [N, actors, 13]  position, quaternion xyzw, linear velocity (of the root
                                        body's origin), angular velocity; world frame
    dof_pos, dof_vel   [N, dofs]        hinge and slide joints of all actors, actor by actor
    dof_state          [N, dofs, 2]     (position, velocity)
    rigid_body_states  [N, bodies, 13]  as root_states, for every body
    net_contact_force  [N, bodies, 3]   sum of contact forces on each body, world frame
    force_sensors      [N, sensors, 6]  force, torque from the parent, in the sensor site frame
    dof_forces         [N, dofs]        effort + drive + joint-limit/friction force on each dof

Writers take tensors on the simulation device, float32, of the exact shape they document.
`env_ids` picks the envs a state writer changes:
  - a bool mask [N] with values for every env [N, ...]: only the masked rows are written, and
    nothing is read back from the device (the form for code inside a step: a task's resets);
  - a bool mask [N] with values for the selected envs only, in order (counting them reads the
    device back once);
  - a 1-D int32/int64 tensor of distinct ids in [0, N) with one value row per id (checked with
    one read-back from the device).
Anything else raises `ValueError` naming the writer, the expected and the given shape, dtype and
device. State writes take effect at once: `forward()` is run for you, so the tensors above
already show the new state (pass forward=False to all but the last of several writes in a row
to run it once).
"""

from __future__ import annotations

import numpy as np
import torch

from ..physics import Model, SimParams, Simulator
from ..physics.types import JointType
from ..torch_utils import quat_rotate, quat_rotate_inverse, where_rows


class Envs:
    def __init__(self, model: Model, actors, drives: dict, ground: dict | None, num_envs: int,
                 device, params: SimParams | None):
        self.model, self.actors = model, list(actors)
        self.sim = Simulator(model, num_envs=num_envs, device=device, params=params)
        self.num_envs, self.device = num_envs, torch.device(self.sim.torch_device)
        m = model

        # --- index maps from actors / DOFs / bodies to the simulator's columns
        self.actor_names = [a.name for a in self.actors]
        body_actor = np.array([self.actor_names.index(n.split("/", 1)[0]) for n in m.body_names])
        self._body_actor, self._actor_columns_cache = body_actor, {}
        for name in self.actor_names:     # on the device now, not in a task's first step
            self._actor_columns(name)
        self.actor_root_body = [int(np.flatnonzero(body_actor == i)[0])
                                for i in range(len(self.actors))]
        self.actor_fixed = [bool(a.fix_base) for a in self.actors]
        dof_joints = [j for j in range(m.njnt) if m.jnt_type[j] in (JointType.HINGE, JointType.SLIDE)]
        self.dof_names = [m.joint_names[j] for j in dof_joints]
        self.body_names = list(m.body_names)
        self.sensor_names = [m.site_names[s] for s in self.sim.sensor_sites]
        self.num_actors, self.num_dofs = len(self.actors), len(dof_joints)
        self.num_bodies, self.num_sensors = m.nbody, len(self.sensor_names)
        dof_actor = body_actor[m.jnt_body[dof_joints]] if dof_joints else np.zeros(0, int)
        self.actor_dof_slices = {}
        for i, name in enumerate(self.actor_names):
            cols = np.flatnonzero(dof_actor == i)
            self.actor_dof_slices[name] = slice(int(cols[0]), int(cols[-1]) + 1) if len(cols) \
                else slice(0, 0)
        long = dict(dtype=torch.long, device=self.device)
        self._dof_q = torch.as_tensor(m.jnt_qposadr[dof_joints], **long)
        # the simulator's q̇ columns (and qpos columns) of the DOFs, in DOF order
        self.dof_columns = torch.as_tensor(m.jnt_dofadr[dof_joints], **long)
        free_root = [i for i in range(self.num_actors) if not self.actor_fixed[i]]
        for i in free_root:
            b = self.actor_root_body[i]
            if m.body_jntnum[b] != 1 or m.jnt_type[m.body_jntadr[b]] != JointType.FREE:
                raise ValueError(f"actor {self.actor_names[i]!r}: a free base needs its root body "
                                 "to have exactly one joint, a free joint")
        self._free_actors = torch.as_tensor(free_root, **long)
        root_jnt = [m.body_jntadr[self.actor_root_body[i]] for i in free_root]
        # q columns (position, quaternion) and q̇ columns (v, ω) of each free actor's root joint
        self._root_q_cols = torch.as_tensor(m.jnt_qposadr[root_jnt], **long)[:, None] \
            + torch.arange(7, **long)
        self._root_v_cols = torch.as_tensor(m.jnt_dofadr[root_jnt], **long)[:, None] \
            + torch.arange(6, **long)
        self._root_body = torch.as_tensor(self.actor_root_body, **long)
        # drive actuators: the sim.ctrl column of each DOF's position or velocity drive
        drive_col = np.full(self.num_dofs, -1)
        for a, names in drives.items():
            for n in names:
                drive_col[self.dof_names.index(n[: -len("/drive")])] = m.actuator_names.index(n)
        self._drive_dofs = torch.as_tensor(np.flatnonzero(drive_col >= 0), **long)
        self._drive_ctrl = torch.as_tensor(drive_col[drive_col >= 0], **long)
        if ground is not None:
            self.sim.geom_restitution[:, m.geom_names.index("ground")] = ground["restitution"]

        # --- state buffers
        N, f32 = num_envs, dict(dtype=torch.float32, device=self.device)
        self.root_states = torch.zeros(N, self.num_actors, 13, **f32)
        self.dof_state = torch.zeros(N, self.num_dofs, 2, **f32)
        self.dof_pos, self.dof_vel = self.dof_state[..., 0], self.dof_state[..., 1]
        self.rigid_body_states = torch.zeros(N, m.nbody, 13, **f32)
        self.net_contact_force = self.sim.net_contact_force            # [N, nbody, 3] view
        self.force_sensors = self.sim.sensor_wrench                    # [N, nsensor, 6] view
        self.dof_forces = torch.zeros(N, self.num_dofs, **f32)
        self.dof_position_targets = torch.zeros(N, self.num_dofs, **f32)
        self.dof_velocity_targets = torch.zeros(N, self.num_dofs, **f32)
        self.refresh()

    # ------------------------------------------------------------------ lookups
    def _lookup(self, names: list[str], name: str, kind: str) -> int:
        if name in names:
            return names.index(name)
        matches = [i for i, n in enumerate(names) if n.split("/", 1)[-1] == name]
        if len(matches) == 1:
            return matches[0]
        if len(matches) > 1:
            raise KeyError(f"{kind} {name!r} is ambiguous: {[names[i] for i in matches]}; "
                           "use 'actor/name'")
        raise KeyError(f"no {kind} named {name!r}; the {kind}s are {names}")

    def actor_index(self, name: str) -> int:
        return self._lookup(self.actor_names, name, "actor")

    def dof_index(self, name: str) -> int:
        return self._lookup(self.dof_names, name, "DOF")

    def body_index(self, name: str) -> int:
        return self._lookup(self.body_names, name, "body")

    def sensor_index(self, name: str) -> int:
        return self._lookup(self.sensor_names, name, "force sensor")

    def dof_limits(self) -> torch.Tensor:
        """[N, dofs, 2] lower, upper limit of each DOF (±inf where the joint is unlimited)."""
        m = self.model
        joints = m.dof_jnt[self.dof_columns.cpu().numpy()]
        rng = self.sim.joint_range[:, torch.as_tensor(joints, device=self.device)].clone()
        unlimited = torch.as_tensor(~m.jnt_limited[joints].astype(bool), device=self.device)
        rng[:, unlimited, 0], rng[:, unlimited, 1] = -torch.inf, torch.inf
        return rng

    # ------------------------------------------------------------------ stepping
    def step(self) -> None:
        """Advance every env by `sim.params.dt`; refresh the state tensors; clear body forces."""
        self.sim.step()
        self.sim.body_force.zero_()
        self.refresh()

    def forward(self) -> None:
        """Recompute derived quantities after a state write; refresh the state tensors."""
        self.sim.forward()
        self.refresh()

    def refresh(self) -> None:
        sim = self.sim
        pose, vel = sim.body_pose, sim.body_vel
        self.rigid_body_states[..., :7] = pose
        self.rigid_body_states[..., 7:] = vel
        self.root_states.copy_(self.rigid_body_states[:, self._root_body])
        self.dof_pos.copy_(sim.q[:, self._dof_q])
        self.dof_vel.copy_(sim.qd[:, self.dof_columns])
        self.dof_forces.copy_((sim.joint_force + sim.dof_actuator_force
                               + sim.dof_constraint_force)[:, self.dof_columns])

    # ------------------------------------------------------------------ writers
    def _check(self, writer: str, value, shape: tuple) -> torch.Tensor:
        if not isinstance(value, torch.Tensor):
            raise ValueError(f"{writer}: expected a torch.Tensor of shape {shape}, got "
                             f"{type(value).__name__}")
        problems = []
        if tuple(value.shape) != tuple(shape):
            problems.append(f"shape {tuple(value.shape)} (expected {tuple(shape)})")
        if value.dtype != torch.float32:
            problems.append(f"dtype {value.dtype} (expected torch.float32)")
        if value.device != self.device:
            problems.append(f"device {value.device} (expected {self.device})")
        if problems:
            raise ValueError(f"{writer}: the tensor has " + ", ".join(problems))
        return value

    def _env_ids(self, writer: str, env_ids, values=None) -> torch.Tensor | slice:
        """None -> all envs; a bool mask [N] -> the mask itself when `values` has a row for every
        env (a masked write), else its indices; a 1-D int32/int64 tensor of distinct env indices
        in [0, N) -> index tensor. Anything else (an id out of range, negative ones included, an
        id given twice, another dtype) raises ValueError naming the writer.

        Cost: a masked write reads nothing back. The others read the device back once, which
        waits for the work queued before it: a mask's `nonzero()`, or for indices one small
        tensor holding their min, max and number of repeats, reduced together on the device.
        """
        if env_ids is None:
            return slice(None)
        if not isinstance(env_ids, torch.Tensor) or env_ids.device != self.device:
            given = (f"a tensor on {env_ids.device}" if isinstance(env_ids, torch.Tensor)
                     else type(env_ids).__name__)
            raise ValueError(f"{writer}: env_ids must be a torch tensor on {self.device}, "
                             f"not {given}")
        if env_ids.dtype == torch.bool:
            if env_ids.shape != (self.num_envs,):
                raise ValueError(f"{writer}: a boolean env_ids mask must have shape "
                                 f"({self.num_envs},), not {tuple(env_ids.shape)}")
            if isinstance(values, torch.Tensor) and values.dim() and len(values) == self.num_envs:
                return env_ids
            return env_ids.nonzero().flatten()
        if env_ids.dtype not in (torch.int32, torch.int64) or env_ids.dim() != 1:
            raise ValueError(f"{writer}: env_ids must be a 1-D integer tensor (int32 or int64) "
                             f"or a bool mask of shape ({self.num_envs},), not {env_ids.dtype} of "
                             f"shape {tuple(env_ids.shape)}")
        ids = env_ids.long()
        if len(ids) == 0:
            return ids
        ordered = ids.sort().values
        repeated = ordered[1:] == ordered[:-1]
        low, high, repeats = torch.stack((ordered[0], ordered[-1], repeated.sum())).tolist()
        if low < 0 or high >= self.num_envs:
            bad = ordered[(ordered < 0) | (ordered >= self.num_envs)]
            shown = bad[:8].tolist() + (["..."] if len(bad) > 8 else [])
            raise ValueError(f"{writer}: env_ids {shown} out of range: ids must lie in "
                             f"[0, {self.num_envs})")
        if repeats:
            twice = ordered[1:][repeated].unique()
            shown = twice[:8].tolist() + (["..."] if len(twice) > 8 else [])
            raise ValueError(f"{writer}: env_ids {shown} given more than once: each env may be "
                             "written once per call")
        return ids

    def _count(self, ids) -> int:
        """Rows the values of a write have: one per env for all envs or a mask, else per id."""
        return len(ids) if isinstance(ids, torch.Tensor) and ids.dtype != torch.bool \
            else self.num_envs

    def _write(self, target: torch.Tensor, cols: torch.Tensor, values: torch.Tensor, ids) -> None:
        """target[env, cols] = values for the envs `ids` selects (from `_env_ids`)."""
        if isinstance(ids, torch.Tensor) and ids.dtype == torch.bool:
            target[:, cols] = where_rows(ids, values, target[:, cols])
        else:
            rows = torch.arange(self.num_envs, device=self.device)[ids]
            target[rows.view(-1, *[1] * cols.dim()), cols] = values

    def set_root_states(self, states: torch.Tensor, env_ids=None, forward: bool = True) -> None:
        """Teleport actors: states [N or len(env_ids), actors, 13] as in `root_states`.

        Rows of fixed-base actors are ignored: their base is welded to the world.
        forward=False leaves the derived tensors stale, for a caller that writes more state
        right after (the last write recomputes them once).
        """
        ids = self._env_ids("set_root_states", env_ids, states)
        states = self._check("set_root_states", states,
                             (self._count(ids), self.num_actors, 13))[:, self._free_actors]
        quat = torch.nn.functional.normalize(states[..., 3:7], dim=-1)
        pose = torch.cat((states[..., :3], quat), dim=-1)
        velocity = torch.cat((states[..., 7:10], quat_rotate_inverse(quat, states[..., 10:13])),
                             dim=-1)                       # a free joint's ω is in its body frame
        self._write(self.sim.q, self._root_q_cols, pose, ids)
        self._write(self.sim.qd, self._root_v_cols, velocity, ids)
        if forward:
            self.forward()

    def set_dof_state(self, pos: torch.Tensor, vel: torch.Tensor, env_ids=None,
                      forward: bool = True) -> None:
        """Set DOF positions and velocities [N or len(env_ids), dofs] (forward as above)."""
        ids = self._env_ids("set_dof_state", env_ids, pos)
        shape = (self._count(ids), self.num_dofs)
        pos = self._check("set_dof_state (pos)", pos, shape)
        vel = self._check("set_dof_state (vel)", vel, shape)
        self._write(self.sim.q, self._dof_q, pos, ids)
        self._write(self.sim.qd, self.dof_columns, vel, ids)
        if forward:
            self.forward()

    def set_dof_efforts(self, efforts: torch.Tensor) -> None:
        """Generalized force on each DOF [N, dofs], applied every step until changed."""
        efforts = self._check("set_dof_efforts", efforts, (self.num_envs, self.num_dofs))
        self.sim.joint_force[:, self.dof_columns] = efforts

    def set_dof_position_targets(self, targets: torch.Tensor) -> None:
        """Targets [N, dofs] of the position drives (entries of other DOFs are kept, unused)."""
        self.dof_position_targets.copy_(
            self._check("set_dof_position_targets", targets, (self.num_envs, self.num_dofs)))
        self.sim.ctrl[:, self._drive_ctrl] = self.dof_position_targets[:, self._drive_dofs]

    def set_dof_velocity_targets(self, targets: torch.Tensor) -> None:
        """Targets [N, dofs] of the velocity drives."""
        self.dof_velocity_targets.copy_(
            self._check("set_dof_velocity_targets", targets, (self.num_envs, self.num_dofs)))
        self.sim.ctrl[:, self._drive_ctrl] = self.dof_velocity_targets[:, self._drive_dofs]

    def apply_body_forces(self, forces: torch.Tensor | None = None,
                          torques: torch.Tensor | None = None,
                          positions: torch.Tensor | None = None, frame: str = "world") -> None:
        """Forces and torques [N, bodies, 3] on bodies during the next `step()` only.

        Forces act at the center of mass, or at `positions` [N, bodies, 3] (world points, or
        points in the body frame with frame="local"). With frame="local" the vectors are in each
        body's frame. Calls before one step add up.
        """
        if frame not in ("world", "local"):
            raise ValueError(f"apply_body_forces: frame={frame!r}; valid: 'world', 'local'")
        shape = (self.num_envs, self.num_bodies, 3)
        checked = [None if v is None else self._check(f"apply_body_forces ({name})", v, shape)
                   for name, v in (("forces", forces), ("torques", torques),
                                   ("positions", positions))]
        force, torque = world_wrench(self.sim.body_pose, self.sim.body_com, *checked,
                                     local=frame == "local")
        self.sim.body_force[..., :3] += force
        self.sim.body_force[..., 3:] += torque

    # ------------------------------------------------------------------ per-articulation algebra
    def jacobians(self, actor: str) -> torch.Tensor:
        """[N, actor bodies, 6, actor dofs incl. a free base's 6] body-origin Jacobians (linear
        rows first), columns in the simulator's dof order for that actor."""
        bodies, cols = self._actor_columns(actor)
        jac = self.sim.body_jacobians()
        return jac[:, bodies][..., cols]

    def mass_matrix(self, actor: str) -> torch.Tensor:
        """[N, actor dofs, actor dofs] joint-space mass matrix (with armature) of one actor."""
        _, cols = self._actor_columns(actor)
        return self.sim.mass_matrix[:, cols][:, :, cols]

    def angular_momentum(self, actor: str, per_body: bool = False) -> torch.Tensor:
        """[N, 3] the actor's angular momentum about its centre of mass, world axes (kg·m²/s):
        each body's spin I·ω plus its mass's moment m·(c − c̄) × (v_c − v̄) about the common
        centre c̄ (MuJoCo's subtreeangmom of the actor's root body). `per_body`: [N, actor
        bodies, 3], each body's share instead (their sum is the first)."""
        bodies, _ = self._actor_columns(actor)
        s = self.sim
        mass = s.body_mass[:, bodies, None]                          # [N, B, 1]
        com, omega = s.body_com[:, bodies], s.body_vel[:, bodies, 3:]
        v_com = s.body_vel[:, bodies, :3] + torch.cross(omega, com - s.body_pose[:, bodies, :3],
                                                        dim=-1)
        total = mass.sum(-2, keepdim=True)
        c_bar = (mass * com).sum(-2, keepdim=True) / total
        v_bar = (mass * v_com).sum(-2, keepdim=True) / total
        frame = s.body_iframe[:, bodies]
        spin = quat_rotate(frame, s.body_inertia[:, bodies] * quat_rotate_inverse(frame, omega))
        shares = spin + mass * torch.cross(com - c_bar, v_com - v_bar, dim=-1)
        return shares if per_body else shares.sum(-2)

    def actor_bodies(self, actor: str) -> list[int]:
        """Indices of the actor's bodies (into bodies, `rigid_body_states`, `sim.body_mass`)."""
        return np.flatnonzero(self._body_actor == self.actor_index(actor)).tolist()

    def _actor_columns(self, actor: str):
        """(bodies, q̇ columns) of an actor as index tensors, computed once per actor."""
        i = self.actor_index(actor)
        if i not in self._actor_columns_cache:
            bodies = np.flatnonzero(self._body_actor == i)
            cols = np.flatnonzero(np.isin(self.model.dof_body, bodies))
            self._actor_columns_cache[i] = tuple(
                torch.as_tensor(a, dtype=torch.long, device=self.device) for a in (bodies, cols))
        return self._actor_columns_cache[i]

    def __repr__(self) -> str:
        return (f"Envs({self.num_envs} envs on {self.device}: actors {self.actor_names}, "
                f"{self.num_dofs} dofs, {self.num_bodies} bodies, {self.num_sensors} sensors)")


def world_wrench(pose: torch.Tensor, com: torch.Tensor, force: torch.Tensor | None = None,
                 torque: torch.Tensor | None = None, position: torch.Tensor | None = None,
                 local: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
    """(force, torque about the center of mass), world axes, [..., 3] each, of a force at
    `position` (at the center of mass if None) and a torque on bodies at `pose` [..., 7]
    (position, quaternion xyzw) with centers of mass `com` [..., 3] (world). With `local`
    the vectors and the point are in each body's frame."""
    rot = pose[..., 3:7]
    zero = torch.zeros_like(com)
    f = zero if force is None else (quat_rotate(rot, force) if local else force)
    t = zero if torque is None else (quat_rotate(rot, torque) if local else torque)
    if force is not None and position is not None:
        p = quat_rotate(rot, position) + pose[..., :3] if local else position
        t = t + torch.cross(p - com, f, dim=-1)
    return f, t
