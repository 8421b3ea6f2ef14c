"""Magnetorquer rods in the top-layer struts: per-rod force pairs in a uniform field.

Robb et al. 2022a: rod force pair (corrected form), the two rod families and the
rod dipole basis (Table 2).

Rods. Family 1 sits in the top-layer ``x1``-struts, family 2 in the top-layer ``y1``-struts
(``N(N−1)`` each: 380 + 380 for the 20 × 20-node lattice). Rods are numbered family 1 first, each
family in the order of ``Lattice.struts_of_kind(kind, layer=1)``. Rod ``r`` in strut ``i → j``
(``j`` the node with the larger i- or j-index, so the positive direction is ``+x1`` / ``+y1`` in
the undeformed lattice) has the dipole

    m_r = s_r m_f r̂_ij,          r_ij = r_j − r_i (current, deformed strut), r̂_ij = r_ij / |r_ij|,

with polarity ``s_r ∈ {−1, 0, +1}`` and the family's rod dipole ``m_f`` [A m²]. In the uniform
field ``B`` (world = ECI axes, the same at every node) the rod feels the pure couple
``τ_r = m_r × B``, realised as the force pair perpendicular to the strut (boxed form; we
correct the paper's factor ½ and sign)

    F_j = −F_i = (m_r × B) × r_ij / |r_ij|² = (s_r m_f / |r_ij|) [B − (B·r̂_ij) r̂_ij]      [N].

Its moment about the strut midpoint is ``r_ij × F_j = m_r × B``, the net force is zero and
``F · r_ij = 0``. The pair therefore adds exactly ``Σ_r m_r × B`` to the structure's total
torque about any point, for any deformation.

Rod dipole basis. With dipole-to-mass ratio ``κ_τ`` [A m²/kg] and rod mass
``M_τ`` [kg], ``basis="per_family"`` (default, reading (b)) gives ``m_f = κ_τ M_τ / n_f``
(26.32 A m² for 10 000 A m² over 380 rods), ``basis="total"`` (reading (a)) shares
``κ_τ M_τ`` over all rods of both families (13.16 A m²).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np
from scipy import sparse

from magsail_mj.lattice.geometry import Lattice
from magsail_mj.loads.base import StepState
from magsail_mj.vec3 import cross3

__all__ = [
    "RodArray",
    "rod_array",
    "rod_dipole_Am2",
    "rod_pair_forces",
    "MagnetorquerRodLoad",
]

DipoleBasis = Literal["per_family", "total"]


@dataclass(frozen=True)
class RodArray:
    """Geometry of the two rod families of a lattice.

    Attributes:
      struts: (n_rods,) strut index of each rod (family 1 first).
      family: (n_rods,) 0 for family 1 (x1-struts), 1 for family 2 (y1-struts).
      ends: (n_rods, 2) node indices ``(i, j)``; ``r_j − r_i`` is the rod's positive direction.
      sites_xy: (n_rods, 2) undeformed strut midpoints in body ``(x1, y1)`` [m].
      n_per_family: rods per family ``(n_1, n_2)``.
      region: ``(x_min, y_min, x_max, y_max)`` = ``(−d/2, −d/2, d/2, d/2)`` [m].
    """

    struts: np.ndarray
    family: np.ndarray
    ends: np.ndarray
    sites_xy: np.ndarray
    n_per_family: tuple[int, int]
    region: tuple[float, float, float, float]

    @property
    def n_rods(self) -> int:
        return int(self.struts.size)

    def family_slice(self, family: int) -> slice:
        """Slice of the rods of ``family`` (0 or 1) in the rod numbering."""
        if family not in (0, 1):
            raise ValueError(f"family: must be 0 (x1-rods) or 1 (y1-rods), got {family!r}")
        n1 = self.n_per_family[0]
        return slice(0, n1) if family == 0 else slice(n1, n1 + self.n_per_family[1])

    def family_sites(self, family: int) -> np.ndarray:
        """(n_f, 2) undeformed midpoints of the rods of ``family`` [m]."""
        return self.sites_xy[self.family_slice(family)]


def rod_array(lattice: Lattice) -> RodArray:
    """Rods of the top-layer x1- and y1-struts of ``lattice``."""
    s1 = lattice.struts_of_kind("x_edge", layer=1)
    s2 = lattice.struts_of_kind("y_edge", layer=1)
    struts = np.concatenate([s1, s2]).astype(np.int64)
    ends = lattice.struts[struts].astype(np.int64)
    d = lattice.ijk[ends[:, 1]] - lattice.ijk[ends[:, 0]]
    fam = np.concatenate([np.zeros(s1.size, np.int8), np.ones(s2.size, np.int8)])
    expect = np.where(fam[:, None] == 0, [1, 0, 0], [0, 1, 0])
    if not np.array_equal(d, expect):  # pragma: no cover - guaranteed by make_lattice
        raise ValueError("lattice: top-layer edges are not ordered along +x1 / +y1")
    mid = 0.5 * (lattice.nodes[ends[:, 0]] + lattice.nodes[ends[:, 1]])
    h = lattice.side_m / 2
    for arr in (struts, ends, fam, mid):
        arr.setflags(write=False)
    return RodArray(
        struts=struts,
        family=fam,
        ends=ends,
        sites_xy=mid[:, :2].copy(),
        n_per_family=(int(s1.size), int(s2.size)),
        region=(-h, -h, h, h),
    )


def rod_dipole_Am2(
    *, kappa_Am2_kg: float, rod_mass_kg: float, rods_per_family: Sequence[int], basis: DipoleBasis = "per_family"
) -> tuple[float, float]:
    """Dipole of one rod in each family [A m²].

    ``per_family``: ``m_f = κ_τ M_τ / n_f`` (the full ``κ_τ M_τ`` per family);
    ``total``: ``m_f = κ_τ M_τ / (n_1 + n_2)`` (shared by both families).
    """
    if not (np.isfinite(kappa_Am2_kg) and kappa_Am2_kg >= 0):
        raise ValueError(f"kappa_Am2_kg: must be a number >= 0, got {kappa_Am2_kg!r}")
    if not (np.isfinite(rod_mass_kg) and rod_mass_kg >= 0):
        raise ValueError(f"rod_mass_kg: must be a number >= 0, got {rod_mass_kg!r}")
    n = tuple(int(v) for v in rods_per_family)
    if len(n) != 2 or min(n) < 1:
        raise ValueError(f"rods_per_family: expected two counts >= 1, got {rods_per_family!r}")
    total = kappa_Am2_kg * rod_mass_kg
    if basis == "per_family":
        return total / n[0], total / n[1]
    if basis == "total":
        return total / (n[0] + n[1]), total / (n[0] + n[1])
    raise ValueError(f"basis: must be 'per_family' or 'total', got {basis!r}")


def rod_pair_forces(r_i: np.ndarray, r_j: np.ndarray, dipole: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Force ``F_j`` (``F_i = −F_j``) on the far end of rods of signed dipole ``dipole``.

    ``F_j = (dipole / |r|) [B − (B·r̂) r̂]`` with ``r = r_j − r_i``, i.e.
    ``(m × B) × r / |r|²`` for ``m = dipole · r̂``.

    Args:
      r_i, r_j: (M, 3) end positions [m].
      dipole: (M,) signed dipoles ``s m_f`` [A m²].
      B: (3,) or (M, 3) field [T], same axes as the positions.
    Returns:
      (M, 3) forces on the ``j`` ends [N].
    """
    B = np.asarray(B, dtype=float)
    r = r_j - r_i
    r2 = np.einsum("ij,ij->i", r, r)
    k = np.asarray(dipole, dtype=float) / (r2 * np.sqrt(r2))
    if B.ndim == 1:
        out = (k * r2)[:, None] * B
        rB = r @ B
    else:
        out = (k * r2)[:, None] * B
        rB = np.einsum("ij,ij->i", r, B)
    out -= (k * rB)[:, None] * r
    return out


class MagnetorquerRodLoad:
    """All magnetorquer rods of a truss as force pairs in a uniform field.

    Args:
      lattice: the truss lattice (rods in its top-layer x1- and y1-struts).
      m_rod_Am2: rod dipole [A m²], one number for both families or ``(m_1, m_2)``; see
        :func:`rod_dipole_Am2` / :meth:`from_basis` for the Table 2 basis.
      B_eci: fixed uniform field [T] (world axes) for tests and free-space runs; default
        ``None`` reads ``state.env.B_eci`` every step.
      body_offset: MuJoCo body index of node 0 (node ``i`` is body ``i + 1``).

    The polarities come from the zero-order-held controller command: ``state.ctrl.polarity``,
    an (n_rods,) int8 array in {−1, 0, +1} in the rod numbering of :func:`rod_array`
    (``state.ctrl`` ``None`` means all rods off).
    """

    name = "magnetorquer_rods"

    def __init__(
        self,
        lattice: Lattice,
        *,
        m_rod_Am2: float | Sequence[float],
        B_eci: Sequence[float] | None = None,
        body_offset: int = 1,
    ):
        self.rods = rod_array(lattice)
        m = (
            np.broadcast_to(np.asarray(m_rod_Am2, dtype=float), (2,))
            if np.ndim(m_rod_Am2) == 0
            else np.asarray(m_rod_Am2, dtype=float)
        )
        if m.shape != (2,) or not np.all(np.isfinite(m)) or np.any(m < 0):
            raise ValueError(f"m_rod_Am2: expected one or two numbers >= 0 [A m²], got {m_rod_Am2!r}")
        self.m_rod_Am2 = (float(m[0]), float(m[1]))
        self.m_of_rod = m[self.rods.family].astype(float)
        self.m_of_rod.setflags(write=False)
        if B_eci is not None:
            B = np.asarray(B_eci, dtype=float)
            if B.shape != (3,) or not np.all(np.isfinite(B)):
                raise ValueError(f"B_eci: expected 3 finite components [T], got {B_eci!r}")
            self.B_fixed: np.ndarray | None = B
        else:
            self.B_fixed = None
        self.body_offset = int(body_offset)
        self.i = self.rods.ends[:, 0] + self.body_offset
        self.j = self.rods.ends[:, 1] + self.body_offset
        self._ji = np.concatenate([self.j, self.i])
        self._inc = None
        self.last_polarity = np.zeros(self.rods.n_rods, dtype=np.int8)
        self._held_source: np.ndarray | None = None
        self._held_dip: np.ndarray | None = None

    @classmethod
    def from_basis(
        cls,
        lattice: Lattice,
        *,
        kappa_Am2_kg: float,
        rod_mass_kg: float,
        basis: DipoleBasis = "per_family",
        B_eci: Sequence[float] | None = None,
        body_offset: int = 1,
    ) -> "MagnetorquerRodLoad":
        """Load whose rod dipoles follow the Table 2 basis, see :func:`rod_dipole_Am2`."""
        rods = rod_array(lattice)
        m = rod_dipole_Am2(
            kappa_Am2_kg=kappa_Am2_kg, rod_mass_kg=rod_mass_kg, rods_per_family=rods.n_per_family, basis=basis
        )
        return cls(lattice, m_rod_Am2=m, B_eci=B_eci, body_offset=body_offset)

    @property
    def n_rods(self) -> int:
        return self.rods.n_rods

    # -- inputs
    def field(self, state: StepState) -> np.ndarray:
        """Uniform field [T], world axes: the fixed ``B_eci`` or ``state.env.B_eci``."""
        if self.B_fixed is not None:
            return self.B_fixed
        if state.env is None:
            raise ValueError(
                "state.env: the rod load needs an environment sample with B_eci (or a fixed B_eci at construction)"
            )
        return np.asarray(state.env.B_eci, dtype=float)

    def polarity(self, state: StepState) -> np.ndarray:
        """(n_rods,) polarities from ``state.ctrl.polarity`` (or ``state.ctrl["polarity"]``);
        zeros when ``state.ctrl`` is None."""
        ctrl = state.ctrl
        if ctrl is None:
            return np.zeros(self.n_rods, dtype=np.int8)
        pol = ctrl.get("polarity") if isinstance(ctrl, dict) else getattr(ctrl, "polarity", None)
        if pol is None:
            raise ValueError("state.ctrl: the rod load needs a command with a 'polarity' array")
        return self.check_polarity(pol)

    def check_polarity(self, polarity) -> np.ndarray:
        """``polarity`` as an (n_rods,) int array in {−1, 0, +1}, or a ValueError naming it."""
        pol = np.asarray(polarity)
        if pol.shape != (self.n_rods,) or pol.dtype.kind not in "iub":
            raise ValueError(
                f"polarity: expected an ({self.n_rods},) integer array, got shape {pol.shape} dtype {pol.dtype}"
            )
        if pol.size and (pol.min() < -1 or pol.max() > 1):
            raise ValueError("polarity: values must be -1, 0 or +1")
        return pol

    # -- physics
    def dipoles_world(self, pos: np.ndarray, polarity) -> np.ndarray:
        """(n_rods, 3) rod dipoles ``s m_f r̂_ij`` along the current struts, world axes [A m²]."""
        pol = self.check_polarity(polarity)
        r = pos[self.j] - pos[self.i]
        scale = pol * self.m_of_rod / np.sqrt(np.einsum("ij,ij->i", r, r))
        return scale[:, None] * r

    def total_dipole_world(self, pos: np.ndarray, polarity) -> np.ndarray:
        """Σ m_r over all rods, world axes [A m²]."""
        return self.dipoles_world(pos, polarity).sum(axis=0)

    def torque_world(self, state: StepState) -> np.ndarray:
        """The rods' total torque ``Σ_r m_r × B`` on the structure, world axes [N m].

        Equal to the moment of all force pairs about any point (each pair is a pure couple).
        """
        return cross3(self.total_dipole_world(state.pos, self.polarity(state)), self.field(state))

    def forces(self, pos: np.ndarray, polarity, B: np.ndarray) -> np.ndarray:
        """(n_rods, 3) forces ``F_j`` on the far end of every rod (``F_i = −F_j``) [N]."""
        pol = self.check_polarity(polarity)
        return rod_pair_forces(pos[self.i], pos[self.j], pol * self.m_of_rod, np.asarray(B, dtype=float))

    def _incidence(self, nbody: int):
        """(nbody, n_rods) sparse matrix with +1 at (j_r, r) and −1 at (i_r, r), built once."""
        if self._inc is None or self._inc.shape[0] != nbody:
            if max(self.i.max(), self.j.max()) >= nbody:
                raise ValueError(f"xfrc: has {nbody} bodies, the rods need body {max(self.i.max(), self.j.max())}")
            n = self.n_rods
            rows = np.concatenate([self.j, self.i])
            cols = np.concatenate([np.arange(n), np.arange(n)])
            vals = np.concatenate([np.ones(n), -np.ones(n)])
            self._inc = sparse.csr_matrix((vals, (rows, cols)), shape=(nbody, n))
        return self._inc

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the force pairs of all rods to ``xfrc[:, :3]`` (world frame).

        Vectorised over every rod (off rods have zero dipole): one gather of the end positions,
        the force pair, and one sparse product with the ±1 rod–body incidence matrix.
        """
        dip = self._held_dipoles(state)
        if dip is None:
            return
        B = self.field(state)
        n = self.n_rods
        ends = state.pos.take(self._ji, axis=0)  # rows: r_j of every rod, then r_i
        F = rod_pair_forces(ends[n:], ends[:n], dip, B)
        xfrc[:, :3] += self._incidence(xfrc.shape[0]) @ F

    def _held_dipoles(self, state: StepState) -> np.ndarray | None:
        """Signed dipoles ``s m_f`` of the held command (``None`` when every rod is off).

        The command is held between control samples, so its validation and the dipole vector
        are redone only when the polarity differs from the last one seen.
        """
        ctrl = state.ctrl
        pol = ctrl.get("polarity") if isinstance(ctrl, dict) else getattr(ctrl, "polarity", None)
        if pol is not None and pol is self._held_source and np.array_equal(pol, self.last_polarity):
            return self._held_dip
        pol = self.polarity(state)
        self.last_polarity = pol.astype(np.int8, copy=True)
        self._held_source = pol if ctrl is not None else None
        self._held_dip = pol * self.m_of_rod if pol.any() else None
        return self._held_dip

    def activity(self, n_tendons: int) -> np.ndarray:
        """(n_tendons,) int8 polarity of the rod in each strut (tendon ``s`` = strut ``s``), for rendering."""
        out = np.zeros(int(n_tendons), dtype=np.int8)
        out[self.rods.struts] = self.last_polarity
        return out
