r"""Loads of the ``structure`` concept, vectorised over nodes and members with index arrays built
once (the one door: each adds into ``xfrc_applied``, :mod:`magsail_mj.loads.base`).

:class:`NodeTidalLoad`
    The exact tidal force on every mass point of the structure (each node's lumped mass at the
    node, each rigid part's own mass at its centre), ``F_k = m_k [g(r_ref + x_k) − g(r_ref)]``
    (:func:`magsail_mj.environment.gravity.tidal_acceleration`, two-body plus J2 when the
    reference orbit has it), applied at the point (a node held by a rigid part gives its part a
    torque too), and the gravity-gradient torque of each rigid part's own inertia,
    ``3μ/|r|⁵ r × (I_w r)`` with ``r = r_ref + x_part`` and ``I_w = R I Rᵀ``. Not modelled: the
    gradient torque on a beam node's small rotational inertia.

:class:`RodDipoleLoad`
    One magnetorquer rod along each member of a member set: rod ``r`` on member ``a → b`` has the
    dipole ``m_r = u_r m_max,r r̂`` along the member's current axis ``r̂ = (x_b − x_a)/|x_b − x_a|``,
    ``u_r ∈ [−1, 1]`` the held command's activation (``state.ctrl.activation``; no command: off).
    In the uniform field ``B`` (world axes, the field at the reference point) its couple
    ``m_r × B`` is applied as the force pair perpendicular to the member,
    ``F_b = −F_a = (m_r × B) × r_ab / |r_ab|²``
    (:func:`magsail_mj.loads.magnetorquer_rods.rod_pair_forces`): zero net force and the moment
    ``m_r × B`` about any point, for any deformation.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse

from magsail_mj.concepts.structure.model import MassPoints, NodeFrames, cross_rows, quat_matrices
from magsail_mj.environment.gravity import tidal_acceleration
from magsail_mj.loads.base import StepState
from magsail_mj.loads.magnetorquer_rods import rod_pair_forces
from magsail_mj.vec3 import cross3

__all__ = ["NodeTidalLoad", "RodDipoleLoad"]


class NodeTidalLoad:
    """Tidal gravity on every mass point of the structure (module docstring).

    Args:
      points: the structure's mass points (:class:`~magsail_mj.concepts.structure.model.MassPoints`).
      mu, j2, J2, R_j2: the environment's gravity (``Environment.gravity_params``).
    """

    name = "tidal_gravity"

    def __init__(self, points: MassPoints, *, mu: float, j2: bool, J2: float, R_j2: float) -> None:
        self.points = points
        self.mass_col = np.asarray(points.mass_kg, dtype=float)[:, None]
        self.mu, self.j2, self.J2, self.R_j2 = float(mu), bool(j2), float(J2), float(R_j2)

    def forces(self, r_ref: np.ndarray, x: np.ndarray) -> np.ndarray:
        """(k, 3) tidal forces [N] on the points at world positions ``x`` [m]."""
        a = tidal_acceleration(r_ref, x, mu=self.mu, j2=self.j2, J2=self.J2, R=self.R_j2)
        return self.mass_col * a

    def part_torques(self, r_ref: np.ndarray, x: np.ndarray, xquat: np.ndarray) -> np.ndarray:
        """(P, 3) gravity-gradient torques of the parts' own inertia [N m], world axes."""
        p = self.points
        k = p.part_point
        r = np.asarray(r_ref, dtype=float) + x[k]
        R = quat_matrices(xquat[p.frames.body[k]])
        r_body = np.einsum("kji,kj->ki", R, r)  # Rᵀ r: I_w r = R I Rᵀ r
        r2 = np.einsum("ki,ki->k", r, r)
        scale = 3.0 * self.mu / (r2 * r2 * np.sqrt(r2))
        torque_body = cross_rows(r_body, np.einsum("kij,kj->ki", p.part_inertia_kg_m2, r_body))
        return scale[:, None] * np.einsum("kij,kj->ki", R, torque_body)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the tidal forces (and the parts' gradient torques) into ``xfrc`` (world frame)."""
        r_ref = np.asarray(state.env.r_ref_eci, dtype=float)
        frames = self.points.frames
        x = frames.positions(state.pos, state.xquat)
        frames.apply(self.forces(r_ref, x), state.xquat, xfrc)
        k = self.points.part_point
        if k.size and np.any(self.points.part_inertia_kg_m2):
            np.add.at(xfrc[:, 3:], frames.body[k], self.part_torques(r_ref, x, state.xquat))


class RodDipoleLoad:
    """Magnetorquer rods along members (module docstring).

    Args:
      nodes: the nodes' frames (:class:`~magsail_mj.concepts.structure.model.NodeFrames`).
      ends: (R, 2) end nodes ``(a, b)`` of each rod's member.
      dipole_max_Am2: (R,) each rod's largest dipole [A m²].
      B_fixed_T: a fixed uniform field [T] (tests); default ``None`` reads ``state.env.B_eci``.
    """

    name = "magnetorquer_rods"

    def __init__(
        self, nodes: NodeFrames, ends: np.ndarray, dipole_max_Am2: np.ndarray, *, B_fixed_T: np.ndarray | None = None
    ) -> None:
        self.nodes = nodes
        self.ends = np.asarray(ends, dtype=np.int64).reshape(-1, 2)
        self.dipole_max_Am2 = np.asarray(dipole_max_Am2, dtype=float)
        if self.dipole_max_Am2.shape != (self.ends.shape[0],):
            raise ValueError(
                f"dipole_max_Am2: one dipole per rod ({self.ends.shape[0]}) needed, "
                f"got shape {self.dipole_max_Am2.shape}"
            )
        self.B_fixed_T = None if B_fixed_T is None else np.asarray(B_fixed_T, dtype=float)
        used = np.unique(self.ends)
        self.used = used  # the nodes the rods use, ascending; the rods index them locally
        local = np.searchsorted(used, self.ends)
        self._a, self._b = local[:, 0], local[:, 1]
        n = self.ends.shape[0]
        rows = np.concatenate([self._b, self._a])
        vals = np.concatenate([np.ones(n), -np.ones(n)])
        self._pair = sparse.csr_matrix((vals, (rows, np.tile(np.arange(n), 2))), shape=(used.size, n))
        self.used_frames = nodes.subset(used)

    @property
    def n_rods(self) -> int:
        return int(self.ends.shape[0])

    def field(self, state: StepState) -> np.ndarray:
        """The uniform field [T], world axes: the fixed one or ``state.env.B_eci``."""
        if self.B_fixed_T is not None:
            return self.B_fixed_T
        return np.asarray(state.env.B_eci, dtype=float)

    @staticmethod
    def activation(state: StepState) -> np.ndarray | None:
        """The held command's activations ``u`` (``None``: no command yet, every rod off)."""
        ctrl = state.ctrl
        return None if ctrl is None else ctrl.activation

    def dipoles_world(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        """(R, 3) rod dipoles ``u m_max r̂`` [A m²] with the rods' end nodes at ``x`` (used nodes)."""
        r = x[self._b] - x[self._a]
        scale = u * self.dipole_max_Am2 / np.sqrt(np.einsum("ij,ij->i", r, r))
        return scale[:, None] * r

    def torque_world(self, state: StepState) -> np.ndarray:
        """``Σ m_r × B`` [N m], world axes: the rods' torque about any point."""
        u = self.activation(state)
        if u is None:
            return np.zeros(3)
        x = self.node_positions(state)
        return cross3(self.dipoles_world(x, u).sum(axis=0), self.field(state))

    def node_positions(self, state: StepState) -> np.ndarray:
        """(k, 3) world positions of the nodes the rods use (``used``, in order) [m]."""
        return self.used_frames.positions(state.pos, state.xquat)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add every rod's force pair into ``xfrc`` (vectorised over the rods)."""
        u = self.activation(state)
        if u is None or not np.any(u):
            return
        x = self.node_positions(state)
        F = rod_pair_forces(x[self._a], x[self._b], u * self.dipole_max_Am2, self.field(state))
        self.used_frames.apply(self._pair @ F, state.xquat, xfrc)
