r"""The truss lattice's loads over a world axis: tidal gravity on every particle and the rod force pairs.

For N worlds at once, with each world's own masses, rod dipoles, field and reference orbit, the
forces of the single run's two loads (in its order: tidal gravity first, then the rods), added to
the force rows of every world's ``xfrc_applied`` (world = ECI axes):

* tidal gravity (:class:`~magsail_mj.loads.tidal.TidalGravityLoad`, two-body path; Robb et al.
  2022a): ``F_i = k_i (f_i r − x_i)`` with ``k_i = (μ/(|r|²|r|)) m_i/(1 + f_i)``,
  ``q_i = (2 x_i·r + |x_i|²)/|r|²`` and ``f_i = (1 + q_i)^{3/2} − 1`` (the binomial series to q⁵
  when every ``|q_i| ≤ 10⁻³`` in the world, else ``expm1(1.5 log1p(q))`` on that world's row);
* magnetorquer rods (:class:`~magsail_mj.loads.magnetorquer_rods.MagnetorquerRodLoad`, the
  corrected pair): ``F_j = −F_i = (s m_f/|r|)[B − (B·r̂) r̂]``, ``r = r_j − r_i``, summed onto the
  bodies by the rod–body incidence matrix (±1), one sparse product for all worlds.

The products go through BLAS as the single run's (``x @ r``, ``(x·x) @ 1``, ``r @ B`` as one
:func:`numpy.matmul` per world, ``|r|²`` as the same :func:`numpy.einsum`), and the incidence
product sums each body's rods in the single run's order for every column, so each world's forces
equal its single run's bit for bit. The products of a per-particle factor and a vector are formed
one component at a time (``F[..., c] = (k f) r_c − k x_c``: the same two roundings per entry as
the single run's broadcast ``(k f)[:, None] * r − k[:, None] * x``, without NumPy's slow inner
loops of length 3). A world whose rods are all off gets no rod term at all (as its
single run, whose rod load then adds nothing).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.batch.worldmath import dot_blas
from magsail_mj.environment.gravity import _SERIES_Q_MAX
from magsail_mj.loads.magnetorquer_rods import MagnetorquerRodLoad
from magsail_mj.loads.tidal import TidalGravityLoad

__all__ = ["LatticeLoadWorlds"]

_ONES3 = np.ones(3)


class LatticeLoadWorlds:
    """The tidal and rod loads of N worlds (module docstring).

    Args:
      tidal: each world's tidal gravity load (all ``None``: tidal gravity off in every world).
      rods: each world's rod load (the corrected force pair).
      nbody: the model's body count.

    Raises:
      ValueError: the worlds' loads act on different bodies, or tidal gravity is on in some
        worlds only.
    """

    def __init__(self, tidal: list[TidalGravityLoad | None], rods: list[MagnetorquerRodLoad], nbody: int) -> None:
        on = {t is not None for t in tidal}
        if len(on) != 1:
            raise ValueError("tidal: tidal gravity must be on in every world or in none")
        self.tidal_on = on.pop()
        if self.tidal_on:
            bodies = {tuple(t.body_ids.tolist()) for t in tidal}
            if len(bodies) != 1:
                raise ValueError("tidal: the worlds' tidal loads act on different bodies")
            ids = tidal[0].body_ids
            self.sel = slice(int(ids[0]), int(ids[-1]) + 1) if np.all(np.diff(ids) == 1) else ids
            self.mass = np.array([t._m_col[:, 0] for t in tidal])  # (N, n) [kg]
            self.mu = np.array([t.mu for t in tidal])  # (N,) [m³/s²]
        ends = {(tuple(r.i.tolist()), tuple(r.j.tolist())) for r in rods}
        if len(ends) != 1:
            raise ValueError("rods: the worlds' rods sit in different struts")
        self.n_rods = rods[0].n_rods
        self.ji = rods[0]._ji
        self.m_of_rod = np.array([r.m_of_rod for r in rods])  # (N, R) [A m²]
        self.incidence = rods[0]._incidence(int(nbody))

    def add(self, pos: np.ndarray, r_ref: np.ndarray, B: np.ndarray, polarity: np.ndarray, xfrc: np.ndarray) -> None:
        """Add every world's tidal and rod forces to ``xfrc[:, :, :3]`` (N, nbody, 6), world axes.

        Args:
          pos: (N, nbody, 3) body positions [m]; r_ref: (N, 3) reference position [m];
          B: (N, 3) field [T]; polarity: (N, R) held rod polarities (int8).
        """
        if self.tidal_on:
            F = self._tidal(pos[:, self.sel], r_ref)
            for c in range(3):
                xfrc[:, self.sel, c] += F[c]
        on = polarity.any(axis=1)
        if not on.any():
            return
        rows = np.flatnonzero(on)
        m = len(rows)
        cols = self._rod_forces(pos[rows], polarity[rows] * self.m_of_rod[rows], B[rows])  # (R, 3 M)
        per_body = self.incidence @ cols  # (nbody, 3 M): column c·M + j is world rows[j]'s component c
        for c in range(3):
            block = per_body[:, c * m : (c + 1) * m].T
            if m == len(on):
                xfrc[:, :, c] += block
            else:
                xfrc[rows, :, c] += block

    def _tidal(self, x: np.ndarray, r: np.ndarray) -> np.ndarray:
        """(3, N, n) tidal forces [N] (by component) at positions ``x`` (N, n, 3) about ``r`` (N, 3)."""
        r2 = dot_blas(r, r)
        xr = np.matmul(x, r[:, :, None])[:, :, 0]
        xx = np.matmul(x * x, _ONES3)
        q = (2.0 * xr + xx) * (1.0 / r2)[:, None]
        qmax = np.maximum(q.max(axis=1), -q.min(axis=1))
        f = q * (1.5 + q * (0.375 + q * (-0.0625 + q * (0.0234375 - 0.01171875 * q))))
        for k in np.flatnonzero(~(qmax <= _SERIES_Q_MAX)).tolist():
            f[k] = np.expm1(1.5 * np.log1p(q[k]))
        k = (self.mu / (r2 * np.sqrt(r2)))[:, None] * self.mass / (1.0 + f)
        kf = k * f
        F = np.empty((3, *k.shape))
        for c in range(3):
            np.subtract(kf * r[:, c : c + 1], k * x[:, :, c], out=F[c])
        return F

    def _rod_forces(self, pos: np.ndarray, dip: np.ndarray, B: np.ndarray) -> np.ndarray:
        """(R, 3 M) forces on the rods' ``j`` ends [N] of M worlds
        (:func:`~magsail_mj.loads.magnetorquer_rods.rod_pair_forces`), column ``c·M + j`` holding
        component c of world j."""
        n = self.n_rods
        m = len(pos)
        ends = pos.take(self.ji, axis=1)  # rows: r_j of every rod, then r_i
        r = ends[:, :n] - ends[:, n:]
        r2 = np.einsum("nij,nij->ni", r, r)
        k = dip / (r2 * np.sqrt(r2))
        kr2 = k * r2
        krB = k * np.matmul(r, B[:, :, None])[:, :, 0]
        cols = np.empty((n, 3 * m))
        for c in range(3):
            np.subtract(kr2 * B[:, c : c + 1], krB * r[:, :, c], out=cols[:, c * m : (c + 1) * m].T)
        return cols
