r"""Linear (matrix) elastic forces of a spring lattice: the paper's printed Eq. 12 and its
co-rotational counterpart, as a load (Robb et al. 2022b, Eqs. 13–14).

With :math:`\mathbf r,\mathbf r_0\in\mathbb R^{3n}` the flattened current and undeformed node
positions (world frame, metres) and :math:`\mathbf K` the stiffness matrix **assembled once at the
undeformed geometry** (:func:`magsail_mj.lattice.geometry.stiffness_matrix`: every strut adds
:math:`k\,\hat e\hat e^T` to its two diagonal blocks and subtracts it from the two off-diagonal
ones; N/m), the elastic node forces [N] are

* ``form="paper_literal"`` — Eq. 12 of Robb et al. (2022) as printed:

  .. math:: \mathbf F = -\mathbf K\,(\mathbf r - \tilde R_\theta\mathbf r_0),
     \qquad \tilde R_\theta = \mathbf I_n\otimes R_\theta ;

* ``form="corotational"`` — the consistent small-strain form that the exact tendon springs equal
  to first order in the strain:

  .. math:: \mathbf F = -\tilde R_\theta\,\mathbf K\,
     \big[\tilde R_\theta^T(\mathbf r-\mathbf c)-(\mathbf r_0-\mathbf c_0)\big].

:math:`R_\theta` (body → world) is the mass-weighted best-fit (Kabsch) rotation of the current node
set against the undeformed one about the centres of mass :math:`\mathbf c,\mathbf c_0`
(:func:`~magsail_mj.lattice.modal_damping.weighted_best_fit_rotation`). Because :math:`\mathbf K`
annihilates rigid translations, the printed form does not depend on the point about which
:math:`\mathbf r_0` is rotated.

What the printed form gets wrong. Write the current state as a rotated, deformed lattice,
:math:`\mathbf r=\tilde R(\mathbf r_0+\mathbf u)+\mathbf d` with :math:`\mathbf u` an elastic
displacement (no rigid part, so :math:`R_\theta=R` to first order in :math:`\mathbf u`). Then the
printed force is :math:`-\mathbf K\tilde R\mathbf u`, the co-rotational (and, to first order, the
tendon) force is :math:`-\tilde R\mathbf K\mathbf u`. The two agree for :math:`R=I` and for a
rigid motion (:math:`\mathbf u=0`: both vanish) but differ by
:math:`(\tilde R\mathbf K-\mathbf K\tilde R)\mathbf u` once the plate has turned: the unrotated
matrix then pushes along the undeformed plate's strut directions. That force is still free of a
net force, but not of a net torque about the centre of mass, and it is not the gradient of a
potential. It is offered only to reproduce the paper (sensitivity; never a default).

The force is held over the step (the project's single door, ``xfrc_applied``). For an undamped
mode of frequency ω a held force multiplies the energy by ``1 + (ωΔt)²/2`` per RK4 step, an
amplitude growth rate ``ω²Δt/4``; the lattice's modal damping ``ξω`` exceeds it whenever
``ξ > ωΔt/4``.

Cost: one 3 × 3 SVD, two O(n) products and one sparse mat-vec (about 9 (n + 2S) non-zeros,
136 116 at N = 27) per evaluation: measured 0.4–1.3 ms at N = 12–27 on a loaded 2-core machine,
against 1.2–11.3 ms for the rest of a step (current-loops concept page of the docs).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy import sparse

from magsail_mj.lattice.geometry import stiffness_matrix
from magsail_mj.lattice.modal_damping import weighted_best_fit_rotation
from magsail_mj.loads.base import StepState

__all__ = ["LinearStiffnessLoad", "LINEAR_FORMS"]

LINEAR_FORMS = ("paper_literal", "corotational")


class LinearStiffnessLoad:
    r"""Elastic node forces of the stiffness matrix ``K`` (module docstring) as a load.

    Args:
      nodes: ``(n, 3)`` undeformed node positions :math:`\mathbf r_0` [m] (where ``K`` is assembled).
      struts: ``(S, 2)`` node pairs of the springs.
      k: ``(S,)`` spring constants [N/m].
      masses: ``(n,)`` node masses [kg] (weights of the best fit).
      form: ``"paper_literal"`` (printed Eq. 12) or ``"corotational"``.
      body_offset: node ``i`` is body ``i + body_offset`` (1 for the truss models).

    Attributes:
      K: the ``(3n, 3n)`` sparse (CSR) stiffness matrix [N/m].
      last_forces: ``(n, 3)`` world-frame forces of the last evaluation [N].
      last_R: the last :math:`R_\theta` (body → world).
    """

    name = "linear_stiffness"

    def __init__(
        self,
        *,
        nodes: np.ndarray,
        struts: np.ndarray,
        k: np.ndarray,
        masses: np.ndarray,
        form: Literal["paper_literal", "corotational"] = "paper_literal",
        body_offset: int = 1,
    ) -> None:
        nodes = np.asarray(nodes, dtype=float)
        if nodes.ndim != 2 or nodes.shape[1] != 3:
            raise ValueError(f"nodes: expected shape (n, 3), got {nodes.shape}")
        n = nodes.shape[0]
        masses = np.asarray(masses, dtype=float)
        if masses.shape != (n,) or np.any(~(masses > 0)):
            raise ValueError(f"masses: expected ({n},) positive values, got shape {masses.shape}")
        if form not in LINEAR_FORMS:
            raise ValueError(f"form: must be one of {LINEAR_FORMS}, got {form!r}")
        if int(body_offset) != body_offset or body_offset < 0:
            raise ValueError(f"body_offset: must be an integer >= 0, got {body_offset!r}")
        self.n = n
        self.form = form
        self.masses = masses.copy()
        self.K: sparse.csr_matrix = stiffness_matrix(nodes, np.asarray(struts), np.asarray(k, dtype=float))
        self._r0 = nodes.copy()
        self._c0 = (masses @ nodes) / masses.sum()
        self._ref_c = nodes - self._c0
        self._sl = slice(int(body_offset), int(body_offset) + n)
        self.last_R = np.eye(3)
        self.last_forces = np.zeros((n, 3))

    def rotation(self, pos: np.ndarray) -> np.ndarray:
        r""":math:`R_\theta` (body → world) of node positions ``pos`` ``(n, 3)`` [m]."""
        return weighted_best_fit_rotation(self._ref_c, self.masses, pos)

    def forces(self, pos: np.ndarray, vel: np.ndarray | None = None) -> np.ndarray:
        """``(n, 3)`` world-frame elastic forces [N] at node positions ``pos`` (``vel`` unused).

        Also sets :attr:`last_R` and :attr:`last_forces`.
        """
        R = self.rotation(pos)
        if self.form == "paper_literal":
            u = pos - self._r0 @ R.T  # r − R_θ r₀
            F = -(self.K @ u.reshape(-1)).reshape(self.n, 3)
        else:
            c = (self.masses @ pos) / self.masses.sum()
            u = (pos - c) @ R - self._ref_c  # R_θᵀ(r − c) − (r₀ − c₀)
            F = -(self.K @ u.reshape(-1)).reshape(self.n, 3) @ R.T
        self.last_R = R
        self.last_forces = F
        return F

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the held elastic force of the current state into ``xfrc[:, :3]`` (world frame)."""
        xfrc[self._sl, :3] += self.forces(state.pos[self._sl])
