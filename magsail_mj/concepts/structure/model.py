"""Model of the ``structure`` concept: the MuJoCo model of the config's structure, where its nodes
and masses are in it, and the rigid initial state.

The model is :func:`magsail_mj.structure.mjcf.build_structure_spec` of the structure with the
rods' and the current loops' wires' mass
(:meth:`~magsail_mj.concepts.structure.config.StructureConfig.structure_with_rods`):
particles on slide joints, beam nodes and rigid parts as bodies of kinematic trees, struts and
cables as spatial tendons, panels drawn as a skin.

Frames: the world frame is the structure frame at the reference (free space) or the
orbit-following frame (axes = ECI, origin on the reference orbit); a node's world position is its
body's position plus the body's rotation applied to the node's offset in the body
(:class:`NodeFrames`; zero but for nodes held by rigid parts). Units SI.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
from scipy import sparse

from magsail_mj.concepts.structure.circuits import LoopEdges
from magsail_mj.concepts.structure.config import StructureConfig
from magsail_mj.estimation.attitude import matrix_from_quat
from magsail_mj.structure.mjcf import StructureModelIndex, build_structure_spec
from magsail_mj.structure.model import MEMBER_KINDS, Structure

__all__ = [
    "MassPoints",
    "NodeFrames",
    "cross_rows",
    "quat_matrices",
    "StructureModel",
    "make_structure_model",
    "rigid_initial_state",
]

_BEAM = MEMBER_KINDS.index("beam")
_CABLE = MEMBER_KINDS.index("cable")


def quat_matrices(q: np.ndarray) -> np.ndarray:
    """(k, 3, 3) rotation matrices (body → world) of (k, 4) unit quaternions ``[w, x, y, z]`` (the
    runner's ``xquat`` rows are unit), the entries of :func:`magsail_mj.quaternion.quat_to_matrix`
    in one stack (this runs every step)."""
    w, x, y, z = np.asarray(q, dtype=float).reshape(-1, 4).T
    rows = (
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    )  # fmt: skip
    return np.stack(rows, axis=-1).reshape(-1, 3, 3)


def cross_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k, 3) row-wise cross products ``a × b`` (``numpy.cross`` without its axis handling)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


class NodeFrames:
    """World positions of a set of points fixed in the model's bodies, and the wrench of forces
    applied at them, from the runner's body poses (``state.pos``, ``state.xquat``).

    Args:
      body: (k,) body of each point.
      offset_m: (k, 3) the point in its body's frame [m] (zero: the body origin).
      body_com_m: (nbody, 3) each body's centre of mass in its own frame (``model.body_ipos``) [m].

    ``positions`` is ``x_k = pos_b + R_b offset_k``; ``apply`` adds ``Σ F_k`` to each body's force
    and ``Σ R_b (offset_k − com_b) × F_k`` to its torque about its centre of mass (the layout of
    ``xfrc_applied``), vectorised with index arrays built once (the rotations are computed only for
    the points off their body's origin or centre of mass).
    """

    def __init__(self, body: np.ndarray, offset_m: np.ndarray, body_com_m: np.ndarray) -> None:
        self.body = np.asarray(body, dtype=np.int64)
        self.offset_m = np.asarray(offset_m, dtype=float).reshape(-1, 3)
        self.body_com_m = np.asarray(body_com_m, dtype=float)
        self.arm_m = self.offset_m - self.body_com_m[self.body]
        self.moved = np.flatnonzero(np.any(self.offset_m != 0.0, axis=1))
        self.levered = np.flatnonzero(np.any(self.arm_m != 0.0, axis=1))
        self.one_per_body = np.unique(self.body).size == self.body.size  # forces add row by row
        self._sum = None

    @property
    def n(self) -> int:
        return int(self.body.size)

    def subset(self, points: np.ndarray) -> NodeFrames:
        """The frames of the points ``points`` (indices into these)."""
        k = np.asarray(points, dtype=np.int64)
        return NodeFrames(self.body[k], self.offset_m[k], self.body_com_m)

    def positions(self, pos: np.ndarray, xquat: np.ndarray) -> np.ndarray:
        """(k, 3) world positions of the points [m]."""
        x = pos[self.body]
        if self.moved.size:
            k = self.moved
            R = quat_matrices(xquat[self.body[k]])
            x[k] += np.einsum("kij,kj->ki", R, self.offset_m[k])
        return x

    def _summing(self, nbody: int) -> sparse.csr_matrix:
        """(nbody, k) incidence: body ← point, built once."""
        if self._sum is None or self._sum.shape[0] != nbody:
            k = self.n
            self._sum = sparse.csr_matrix((np.ones(k), (self.body, np.arange(k))), shape=(nbody, k))
        return self._sum

    def apply(self, force_N: np.ndarray, xquat: np.ndarray, xfrc: np.ndarray) -> None:
        """Add the forces ``force_N`` (k, 3) [N, world] at the points into ``xfrc`` (nbody, 6)."""
        if self.one_per_body:
            xfrc[self.body, :3] += force_N
        else:
            xfrc[:, :3] += self._summing(xfrc.shape[0]) @ force_N
        if self.levered.size:
            k = self.levered
            R = quat_matrices(xquat[self.body[k]])
            arm = np.einsum("kij,kj->ki", R, self.arm_m[k])
            np.add.at(xfrc[:, 3:], self.body[k], cross_rows(arm, force_N[k]))


@dataclass(frozen=True)
class MassPoints:
    """The structure's mass as points of the model: every node's lumped mass at the node, and each
    rigid part's own mass at its centre (:attr:`frames` places them); their total is the
    structure's mass. ``part_inertia_kg_m2`` (P, 3, 3): each part's own inertia about its centre,
    in its body's frame (the structure axes at the reference); ``part_point`` the index of each
    part's point."""

    frames: NodeFrames
    mass_kg: np.ndarray
    part_point: np.ndarray
    part_inertia_kg_m2: np.ndarray

    def center_of_mass(self, x: np.ndarray) -> np.ndarray:
        """(3,) the centre of mass of the points at positions ``x`` (k, 3) [m]."""
        return self.mass_kg @ x / self.mass_kg.sum()


@dataclass
class StructureModel:
    """Everything derived from a config's structure.

    Attributes:
      structure: the structure with the rods' and wires' mass.
      spec: the MjSpec (:func:`~magsail_mj.structure.mjcf.build_structure_spec`).
      model: the compiled model.
      index: where the nodes, members and parts are in the model.
      nodes: the world positions of the nodes (and forces at them) from the body poses.
      mass_points: nodes and parts as mass points (tidal gravity, centre of mass).
      total_mass_kg: the structure's mass [kg]; center_of_mass_m: (3,) at the reference [m];
      inertia_kg_m2: (3, 3) about it, structure axes [kg m²].
      rod_members: (R,) members carrying rods; rod_dipole_max_Am2: (R,) their largest dipoles [A m²].
      loops: the current loops' directed edges and current limits (``None`` without ``[loops]``).
    """

    structure: Structure
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    index: StructureModelIndex
    nodes: NodeFrames
    mass_points: MassPoints
    total_mass_kg: float
    center_of_mass_m: np.ndarray
    inertia_kg_m2: np.ndarray
    rod_members: np.ndarray
    rod_dipole_max_Am2: np.ndarray
    loops: LoopEdges | None = None

    @property
    def extent_m(self) -> float:
        """The largest side of the nodes' bounding box [m] (1 m for a point)."""
        extent = float(np.ptp(self.structure.positions_m, axis=0).max()) if self.structure.n_nodes else 0.0
        return extent if extent > 0 else 1.0


def _mass_points(
    structure: Structure, model: mujoco.MjModel, index: StructureModelIndex, nodes: NodeFrames
) -> MassPoints:
    parts = structure.rigid_parts
    body = np.concatenate([nodes.body, index.part_body]).astype(np.int64)
    offset = np.vstack([nodes.offset_m, np.zeros((len(parts), 3))])
    mass = np.concatenate([structure.lumped_masses(), [p.mass_kg for p in parts]])
    inertia = np.array([p.inertia_kg_m2 for p in parts], dtype=float).reshape(-1, 3, 3)
    frames = NodeFrames(body, offset, model.body_ipos)
    return MassPoints(
        frames=frames,
        mass_kg=mass,
        part_point=structure.n_nodes + np.arange(len(parts)),
        part_inertia_kg_m2=inertia,
    )


def make_structure_model(cfg: StructureConfig) -> StructureModel:
    """The model of a validated config: its structure with the rods, the MjSpec (``sim.timestep_s``,
    ``sim.integrator``, ``sim.solver_tolerance``), the compiled model and its index arrays."""
    structure = cfg.structure_with_rods()
    spec = build_structure_spec(
        structure,
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        solver_tolerance=cfg.sim.solver_tolerance,
        name=f"structure_{cfg.scenario}_{structure.name}",
    )
    model = spec.compile()
    index = StructureModelIndex.from_model(model, structure)
    nodes = NodeFrames(index.node_body, model.site_pos[index.node_site], model.body_ipos)
    total, com, inertia = structure.mass_properties()
    return StructureModel(
        structure=structure,
        spec=spec,
        model=model,
        index=index,
        nodes=nodes,
        mass_points=_mass_points(structure, model, index, nodes),
        total_mass_kg=float(total),
        center_of_mass_m=com,
        inertia_kg_m2=inertia,
        rod_members=cfg.rod_members(),
        rod_dipole_max_Am2=cfg.rod_dipole_max_Am2(),
        loops=cfg.loop_edges(),
    )


def rigid_initial_state(sm: StructureModel, data: mujoco.MjData, *, q0_wxyz, omega0_body_rad_s) -> None:
    """Set ``data`` to the structure rotated rigidly by ``R(q0)`` about its centre of mass ``c`` and
    spinning at ``ω`` (body axes): a particle at ``c + R (p − c)`` with velocity
    ``(R ω) × R (p − c)``; a free tree root (a beam node or rigid part on a free joint, origin
    ``o``) at ``c + R (o − c)`` with orientation ``q0``, linear velocity ``(R ω) × R (o − c)`` and
    angular velocity ``ω`` (MuJoCo's free joint takes it in the body's frame); every joint inside a
    tree at its reference (no deformation, no relative motion). A structure with fixed components
    starts at its reference at rest (the config allows nothing else)."""
    m = sm.model
    data.qpos[:] = m.qpos0
    data.qvel[:] = 0.0
    q = np.asarray(q0_wxyz, dtype=float)
    q = q / np.linalg.norm(q)
    R = matrix_from_quat(q)
    w_body = np.asarray(omega0_body_rad_s, dtype=float)
    w_world = R @ w_body
    c = sm.center_of_mass_m
    qadr, vadr = sm.index.node_slide_qposadr, sm.index.node_slide_dofadr
    particle = np.all(qadr >= 0, axis=1)
    if particle.any():
        p = sm.structure.positions_m[particle]
        x = (p - c) @ R.T + c
        data.qpos[qadr[particle]] = x - p
        data.qvel[vadr[particle]] = np.cross(w_world, x - c)
    free = np.flatnonzero(m.jnt_type == mujoco.mjtJoint.mjJNT_FREE)
    if free.size:
        o = m.body_pos[m.jnt_bodyid[free]]  # roots hang from the world: their reference position
        x = (o - c) @ R.T + c
        qa, va = m.jnt_qposadr[free][:, None], m.jnt_dofadr[free][:, None]
        data.qpos[qa + np.arange(3)] = x
        data.qpos[qa + 3 + np.arange(4)] = q
        data.qvel[va + np.arange(3)] = np.cross(w_world, x - c)
        data.qvel[va + 3 + np.arange(3)] = w_body
