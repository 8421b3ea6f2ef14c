"""Distributed (or centralised) torque realised as force pairs across struts.

Robb et al. 2022a, Sec. 2 (generic strut torquer). A pair of equal
and opposite forces on the two end nodes of a strut makes a pure couple perpendicular to the
strut. For actuated strut ``s`` from node ``i`` to node ``j`` (current vector ``r = r_j − r_i``,
length ``ℓ``, direction ``ê``) define the local normal

    n = (r_i^top − r_i^bottom) + (r_j^top − r_j^bottom),   n⊥ = n − (n·ê) ê,   n̂⊥ = n⊥/|n⊥|

(the column through each end node, so the normal follows the local deformation), and the
in-plane torque axis ``û = ê × n̂⊥``. With strut torques ``a_s`` about ``û`` and ``c_s`` about
``n̂⊥`` the forces are

    F_j = (a_s n̂⊥ + c_s (n̂⊥ × ê)) / ℓ,     F_i = −F_j,

whose couple is ``ℓ ê × F_j = a_s û + c_s n̂⊥`` (zero net force, no axial component).

A commanded body torque ``τ = (τ₁, τ₂, τ₃)`` is shared as follows: ``τ₁`` over the y1-struts
(``û ≈ +x1``), ``τ₂`` over the x1-struts (``û ≈ −y1``, so ``a_s = −τ₂/N_x``) and ``τ₃`` over all
actuated struts about their normals. With the undeformed lattice the total couple is exactly
``τ``; as the plate deforms each actuator's couple turns with its own strut (the
"local" torque axis). ``torque_axis="bestfit"`` takes ``n̂`` = body z1 of the best-fit rotation
instead (a sensitivity variant).
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from magsail_mj.estimation.attitude import best_fit_rotation
from magsail_mj.lattice.geometry import Lattice
from magsail_mj.loads.base import StepState

__all__ = ["StrutTorqueLoad", "strut_couple_forces"]


def strut_couple_forces(r_i, r_j, n, a, c):
    """Force on node ``j`` (``F_i = −F_j``) for couples ``a`` about ``ê × n̂⊥`` and ``c`` about ``n̂⊥``.

    Args:
      r_i, r_j: (M, 3) end positions; n: (M, 3) normal estimate (any length, not along ê);
      a, c: (M,) couple magnitudes [N m].
    Returns:
      F_j: (M, 3) [N].
    """
    r = r_j - r_i
    ell = np.sqrt(np.einsum("ij,ij->i", r, r))
    e = r / ell[:, None]
    n_perp = n - np.einsum("ij,ij->i", n, e)[:, None] * e
    n_hat = n_perp / np.sqrt(np.einsum("ij,ij->i", n_perp, n_perp))[:, None]
    # w = n̂ × ê, written out (np.cross costs more than the arithmetic for a few hundred rows)
    w = np.empty_like(e)
    w[:, 0] = n_hat[:, 1] * e[:, 2] - n_hat[:, 2] * e[:, 1]
    w[:, 1] = n_hat[:, 2] * e[:, 0] - n_hat[:, 0] * e[:, 2]
    w[:, 2] = n_hat[:, 0] * e[:, 1] - n_hat[:, 1] * e[:, 0]
    return (a[:, None] * n_hat + c[:, None] * w) / ell[:, None]


class StrutTorqueLoad:
    """Commanded body torque realised by force pairs on chosen struts.

    Args:
      lattice: the lattice (for strut ends and the columns through them).
      struts: indices of the actuated struts (x1- or y1-edges, any layer).
      command: function(state) → body torque ``(τ₁, τ₂, τ₃)`` [N m].
      torque_axis: ``"local"`` (default) or ``"bestfit"``.
      body_offset: body index of node 0 (1 when node i is body i + 1).
    """

    name = "strut_torque"

    def __init__(
        self,
        lattice: Lattice,
        struts: np.ndarray,
        *,
        command: Callable[[StepState], np.ndarray],
        torque_axis: str = "local",
        body_offset: int = 1,
    ):
        struts = np.asarray(struts, dtype=int)
        if struts.ndim != 1 or struts.size == 0:
            raise ValueError("struts: expected a non-empty 1-D index array")
        if torque_axis not in ("local", "bestfit"):
            raise ValueError(f"torque_axis: must be 'local' or 'bestfit', got {torque_axis!r}")
        ends = lattice.struts[struts]
        dij = lattice.ijk[ends[:, 1]] - lattice.ijk[ends[:, 0]]
        is_y = (dij[:, 0] == 0) & (dij[:, 1] == 1) & (dij[:, 2] == 0)
        is_x = (dij[:, 0] == 1) & (dij[:, 1] == 0) & (dij[:, 2] == 0)
        if not np.all(is_x | is_y):
            raise ValueError("struts: every actuated strut must be an x1- or y1-edge")
        N2 = lattice.nodes_per_side**2
        col = lambda nodes: nodes % N2  # bottom node of each column  # noqa: E731
        self.i = ends[:, 0] + body_offset
        self.j = ends[:, 1] + body_offset
        self.i_bot, self.i_top = col(ends[:, 0]) + body_offset, col(ends[:, 0]) + N2 + body_offset
        self.j_bot, self.j_top = col(ends[:, 1]) + body_offset, col(ends[:, 1]) + N2 + body_offset
        self.w1 = np.where(is_y, 1.0 / max(is_y.sum(), 1), 0.0)  # share of τ₁ (about û ≈ +x1)
        self.w2 = np.where(is_x, -1.0 / max(is_x.sum(), 1), 0.0)  # share of τ₂ (û ≈ −y1)
        self.w3 = np.full(struts.size, 1.0 / struts.size)  # share of τ₃ (about n̂)
        self.struts = struts
        self.command = command
        self.torque_axis = torque_axis
        self.body_offset = body_offset
        self._ref = lattice.nodes
        self.last_force_j = np.zeros((struts.size, 3))
        self.last_command = np.zeros(3)

    def strut_torques(self, tau_body: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-strut couples ``(a_s, c_s)`` for a body torque command."""
        tau_body = np.asarray(tau_body, dtype=float)
        return self.w1 * tau_body[0] + self.w2 * tau_body[1], self.w3 * tau_body[2]

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        tau = np.asarray(self.command(state), dtype=float)
        self.last_command = tau
        if not np.any(tau):
            self.last_force_j[:] = 0.0
            return
        pos = state.pos
        if self.torque_axis == "local":
            n = (pos[self.i_top] - pos[self.i_bot]) + (pos[self.j_top] - pos[self.j_bot])
        else:
            R, _ = best_fit_rotation(self._ref, pos[self.body_offset : self.body_offset + self._ref.shape[0]])
            n = np.broadcast_to(R[:, 2], (self.struts.size, 3))
        a, c = self.strut_torques(tau)
        F = strut_couple_forces(pos[self.i], pos[self.j], n, a, c)
        self.last_force_j = F
        for k in range(3):
            xfrc[:, k] += np.bincount(self.j, F[:, k], xfrc.shape[0]) - np.bincount(self.i, F[:, k], xfrc.shape[0])

    def activity(self, n_tendons: int) -> np.ndarray:
        """(n_tendons,) int8 sign of each actuated strut's couple (for rendering)."""
        out = np.zeros(n_tendons, dtype=np.int8)
        a, c = self.strut_torques(self.last_command)
        out[self.struts] = np.sign(np.where(a != 0, a * np.where(self.w2 != 0, -1, 1), c)).astype(np.int8)
        return out
