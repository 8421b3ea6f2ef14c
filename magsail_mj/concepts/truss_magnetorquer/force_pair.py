r"""The magnetorquer rod's force pair as the paper prints it, beside the corrected form we use.

The paper (Robb et al. 2022, Eq. 4) turns the couple of a rod with dipole
``m = m_d r̂_ij`` in a uniform field ``B`` into a force pair on the strut's end particles
``i`` and ``j`` (``r_ij = r_j − r_i``, ``r = |r_ij|``, ``r̂_ji = −r̂_ij``, ``m_d`` signed: the
polarity times the rod dipole):

    printed:     F_i = −F_j = (1/r) [ m_d B − ½ m_d (B·r̂_ji) r̂_ji ]                       [N]

The form the project uses by default (``actuators.force_pair = "corrected"``,
:func:`magsail_mj.loads.magnetorquer_rods.rod_pair_forces`) is

    corrected:   F_j = −F_i = (m_d / r) [ B − (B·r̂_ij) r̂_ij ] = (m × B) × r_ij / r²

Algebra of the printed pair (every line is tested in ``tests/test_truss_variants.py``):

* net force ``F_i + F_j = 0`` (it is a pair);
* moment about the strut midpoint ``r_ji × F_i = m_d r̂_ji × B = −m × B``: the **full**
  magnitude of the rod's couple with the **opposite sign** (the ½ multiplies a term along the
  strut, which has no moment);
* axial part ``F_i · r̂_ji = (m_d / 2r) (B·r̂_ji)``: the ½ leaves half of ``B``'s component along
  the strut, a tension ``T = −(m·B) / (2r)`` [N] in the strut (positive pulls the ends apart);
* perpendicular part: exactly minus the corrected pair's.

So ``printed = −corrected + axial pair``. A third variant, ``"printed_sign_fixed"``, is the
printed expression with its sign corrected (``F_j = −F_i = (m_d/r)[B − ½ (B·r̂_ij) r̂_ij]``): the
corrected couple ``m × B`` plus an axial pair of tension ``T = +(m·B)/(2r)``; it isolates the
effect of the ½ (a spurious axial strut load) from the sign, which turns every controller's
torque around.
"""

from __future__ import annotations

from typing import Literal

import numpy as np

from magsail_mj.lattice.geometry import Lattice
from magsail_mj.loads.base import StepState
from magsail_mj.loads.magnetorquer_rods import MagnetorquerRodLoad, rod_dipole_Am2, rod_pair_forces
from magsail_mj.vec3 import cross3

__all__ = ["FORCE_PAIRS", "ForcePair", "printed_pair_forces", "pair_forces", "couple_sign", "VariantPairRodLoad"]

ForcePair = Literal["corrected", "printed", "printed_sign_fixed"]
FORCE_PAIRS: tuple[str, ...] = ("corrected", "printed", "printed_sign_fixed")
"""The ``actuators.force_pair`` values."""


def printed_pair_forces(r_i: np.ndarray, r_j: np.ndarray, dipole: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Force ``F_j`` (``F_i = −F_j``) of the paper's Eq. 4 exactly as printed (module docstring).

    ``F_i = (1/r)[m_d B − ½ m_d (B·r̂_ji) r̂_ji]`` with ``r̂_ji = (r_i − r_j)/r``; the axial term
    is even in ``r̂``, so ``F_j = −(m_d/r)[B − ½ (B·r̂_ij) r̂_ij]``.

    Args:
      r_i, r_j: (M, 3) end positions [m].
      dipole: (M,) signed dipoles ``m_d = s m_rod`` [A m²].
      B: (3,) or (M, 3) field [T], same axes as the positions.
    Returns:
      (M, 3) forces on the ``j`` ends [N].
    """
    return -_half_axial_pair(r_i, r_j, dipole, B)


def _half_axial_pair(r_i: np.ndarray, r_j: np.ndarray, dipole: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``(m_d/r)[B − ½ (B·r̂) r̂]`` on the ``j`` ends, vectorised over the rods [N]."""
    B = np.asarray(B, dtype=float)
    r = r_j - r_i
    r2 = np.einsum("ij,ij->i", r, r)
    k = np.asarray(dipole, dtype=float) / np.sqrt(r2)
    rB = r @ B if B.ndim == 1 else np.einsum("ij,ij->i", r, B)
    return k[:, None] * np.broadcast_to(B, r.shape) - (0.5 * k * rB / r2)[:, None] * r


def pair_forces(kind: str, r_i: np.ndarray, r_j: np.ndarray, dipole: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Force ``F_j`` (``F_i = −F_j``) of the force-pair variant ``kind`` (:data:`FORCE_PAIRS`) [N]."""
    if kind == "corrected":
        return rod_pair_forces(r_i, r_j, dipole, B)
    if kind == "printed":
        return printed_pair_forces(r_i, r_j, dipole, B)
    if kind == "printed_sign_fixed":
        return _half_axial_pair(r_i, r_j, dipole, B)
    raise ValueError(f"force_pair: must be one of {list(FORCE_PAIRS)}, got {kind!r}")


def couple_sign(kind: str) -> float:
    """Sign of the pair's moment relative to ``m × B``: −1 for ``"printed"``, else +1."""
    if kind not in FORCE_PAIRS:
        raise ValueError(f"force_pair: must be one of {list(FORCE_PAIRS)}, got {kind!r}")
    return -1.0 if kind == "printed" else 1.0


class VariantPairRodLoad(MagnetorquerRodLoad):
    """The rod array of :class:`~magsail_mj.loads.magnetorquer_rods.MagnetorquerRodLoad` with the
    force pair ``force_pair`` (:data:`FORCE_PAIRS`); ``"corrected"`` is the parent exactly.

    :meth:`torque_world` returns the moment the pairs actually apply (``−Σ m × B`` for the
    printed pair), so the recorded ``torque_ac_body_Nm`` is the torque the structure receives.
    """

    def __init__(self, lattice: Lattice, *, m_rod_Am2, force_pair: ForcePair = "corrected", **kw):
        super().__init__(lattice, m_rod_Am2=m_rod_Am2, **kw)
        self.sign = couple_sign(force_pair)
        self.force_pair = force_pair

    @classmethod
    def from_variant(
        cls,
        lattice: Lattice,
        *,
        kappa_Am2_kg: float,
        rod_mass_kg: float,
        basis: str = "per_family",
        force_pair: ForcePair = "corrected",
    ) -> "VariantPairRodLoad":
        """Rod dipoles from the basis (:func:`~magsail_mj.loads.magnetorquer_rods.rod_dipole_Am2`)."""
        n = (lattice.struts_of_kind("x_edge", layer=1).size, lattice.struts_of_kind("y_edge", layer=1).size)
        m = rod_dipole_Am2(kappa_Am2_kg=kappa_Am2_kg, rod_mass_kg=rod_mass_kg, rods_per_family=n, basis=basis)
        return cls(lattice, m_rod_Am2=m, force_pair=force_pair)

    def torque_world(self, state: StepState) -> np.ndarray:
        """Moment of all pairs about any point, world axes [N m]: ``±Σ_r m_r × B``."""
        return self.sign * cross3(self.total_dipole_world(state.pos, self.polarity(state)), self.field(state))

    def forces(self, pos: np.ndarray, polarity, B: np.ndarray) -> np.ndarray:
        """(n_rods, 3) forces ``F_j`` of the variant on the far end of every rod [N]."""
        pol = self.check_polarity(polarity)
        return pair_forces(self.force_pair, pos[self.i], pos[self.j], pol * self.m_of_rod, np.asarray(B, dtype=float))

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the variant's pairs to ``xfrc[:, :3]`` (one gather, one sparse incidence product)."""
        if self.force_pair == "corrected":
            super().add(state, xfrc)
            return
        dip = self._held_dipoles(state)
        if dip is None:
            return
        n = self.n_rods
        ends = state.pos.take(self._ji, axis=0)  # rows: r_j of every rod, then r_i
        F = pair_forces(self.force_pair, ends[n:], ends[:n], dip, self.field(state))
        xfrc[:, :3] += self._incidence(xfrc.shape[0]) @ F
