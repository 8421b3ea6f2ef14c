"""Which rods to switch on: Lloyd's algorithm (centroidal Voronoi tessellation), snapped to sites.

Robb et al. 2022a, Sec. 3 (rod selection). To spread ``|N_f|``
activated rods of a family evenly over the array:

1. region: the axis-aligned rectangle covered by the array (for the truss ``[−d/2, d/2]²`` in
   body ``x1, y1``; for the 10 × 10 demonstration the unit square);
2. draw ``|N_f|`` uniform random generators in the region from ``numpy.random.default_rng(seed)``;
3. Lloyd iteration: move every generator to the centroid ``c_i = ∫_{V_i} x dA / |V_i|`` of its
   Voronoi cell ``V_i`` clipped to the region, until the largest move
   ``max_i |c_i − g_i| < tol_rel · L`` (``L`` the longer side of the region; default
   ``tol_rel = 1e-6``, at most ``max_iter = 10 000`` iterations). The limit is a centroidal
   Voronoi tessellation (CVT);
4. snap the generators to the sites of the family by the optimal one-to-one assignment that
   minimises ``Σ |g_i − s_σ(i)|²`` (``scipy.optimize.linear_sum_assignment``), so that exactly
   ``|N_f|`` distinct sites are chosen (plain nearest-site snapping can pick a site twice);
5. the caller activates those rods with polarity ``sign(N_f)``.

Exact clipped cells. The cells are computed exactly with the reflection trick: adding the mirror
images of a generator across the region's sides makes those sides Voronoi edges of its cell, and
mirror images of *other* generators never cut into a cell inside the region. Only the mirrors
that are needed are added: a generator gets the mirror across a side once its cell reaches past
that side (checked on every iteration from the cell vertices, the circumcentres of the Delaunay
triangles), which keeps the triangulation about 4 × smaller than mirroring everything, with the
same cells. Cell areas and centroids come from the Delaunay triangulation alone
(``scipy.spatial.Delaunay``): the cell of vertex ``v`` is the sum over its triangles ``t`` of the
signed quadrilaterals ``(v, m_vb, c_t, m_vc)`` (edge midpoints ``m``, circumcentre ``c_t``), which is
vectorised over all triangles. Inside :func:`lloyd` the triangulation is kept from one iteration
to the next while it is still Delaunay for the moved generators (checked exactly: no flipped
triangle, every edge locally Delaunay, convex hull), so qhull runs on ~10 % of the iterations;
the iterates equal those of re-triangulating every time to rounding. :func:`voronoi_cells`
builds the ordered cell polygons the plain way (``scipy.spatial.Voronoi`` with all four mirrors)
for plots and as the slow reference.

Mirror-symmetric selections (``symmetry="mirror_xy"``). A selection mirror-symmetric about both
centre lines ``x = x_c``, ``y = y_c`` of the region is a union of *orbits* of the two mirrors: four
sites ``(x_c ± a, y_c ± b)``, two on a centre line, one at the centre (:func:`mirror_orbits`; the
sites must be mirror-symmetric themselves). For ``|N_f|`` rods:

1. ``q = min(⌊|N_f|/4⌋, number of four-site orbits)`` generators run Lloyd's algorithm in the
   upper-right quadrant ``[x_c, x_max] × [y_c, y_max]``; mirrored across the centre lines they are a
   centroidal Voronoi tessellation of the whole region (the reflection argument above: the
   quadrant's sides are edges of the mirrored cells);
2. the ``q`` generators are snapped one-to-one to the quadrant points ``(x_c + |x − x_c|,
   y_c + |y − y_c|)`` of the four-site orbits (the optimal assignment of step 4; its cost is a
   quarter of that of the mirrored generators against the orbits' sites), and all four sites of
   each chosen orbit are switched on;
3. the remaining ``|N_f| − 4q`` rods come from two-site orbits, then one-site orbits, one orbit at a
   time: the one whose sites lie farthest from the sites already chosen (ties, and the first pick
   of an empty selection: the one nearest the quadrant's centre).

An odd count needs a one-site orbit, a site at the region's centre; without one (the truss: no
strut midpoint lies at the centre) the selection has ``|N_f| − 1`` sites, so the delivered torque
is that of one rod fewer than commanded. The generators of ``q`` are shared by the families, as
without symmetry.

Runtime use. The pattern depends only on ``|N_f|``, the region, the seed, the
tolerance and the symmetry, so :class:`LloydSelector` computes each count once (lazily, or all up front with
:meth:`LloydSelector.precompute`), keeps it in memory, and optionally on disk keyed by region, seed,
tolerance and iteration cap. Both families share the generators of a count (same region and
seed); only the snapping differs. A control call is then a dictionary look-up.
"""

from __future__ import annotations

import hashlib
import json
import time
import zipfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Literal, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import Delaunay, Voronoi, cKDTree

from magsail_mj.checkpoint import restorable
from magsail_mj.io import atomic_path

#: the selections of the shipped configs, computed once (``scripts/ship_lloyd_selections.py``) and
#: installed with the package; :class:`LloydSelector` reads them after its own cache, never writes them
SHIPPED_DIR = Path(__file__).resolve().parent.parent / "data" / "lloyd"

__all__ = [
    "Region",
    "Symmetry",
    "SYMMETRIES",
    "LloydResult",
    "MirrorOrbits",
    "as_region",
    "mirror_orbits",
    "initial_generators",
    "nn_spacing_cv",
    "covering_radius",
    "voronoi_centroids",
    "voronoi_cells",
    "lloyd",
    "snap_to_sites",
    "LloydSelector",
]

Region = tuple[float, float, float, float]
"""Axis-aligned rectangle ``(x_min, y_min, x_max, y_max)`` [m, or any length unit]."""

_ALGO_VERSION = "lloyd-delaunay-v1"  # part of the disk-cache key

Symmetry = Literal["none", "mirror_xy"]
"""Symmetry of a selection: none, or mirror-symmetric about both centre lines of the region."""
SYMMETRIES: tuple[str, ...] = ("none", "mirror_xy")
"""The values of :data:`Symmetry`."""
_MIRROR_TOL_REL = 1e-9  # a site's mirror image is a site when closer than this × the longer side


def as_region(region: Sequence[float]) -> Region:
    """Validate ``region`` = ``(x_min, y_min, x_max, y_max)`` with positive width and height."""
    r = tuple(float(v) for v in region)
    if len(r) != 4 or not all(np.isfinite(r)):
        raise ValueError(f"region: expected 4 finite numbers (x_min, y_min, x_max, y_max), got {region!r}")
    if not (r[2] > r[0] and r[3] > r[1]):
        raise ValueError(f"region: needs x_max > x_min and y_max > y_min, got {region!r}")
    return r  # type: ignore[return-value]


def _mirrors(points: np.ndarray, region: Region) -> list[np.ndarray]:
    """Mirror images of ``points`` across the sides x_min, x_max, y_min, y_max (in that order)."""
    x0, y0, x1, y1 = region
    x, y = points[:, 0], points[:, 1]
    return [
        np.column_stack([2 * x0 - x, y]),
        np.column_stack([2 * x1 - x, y]),
        np.column_stack([x, 2 * y0 - y]),
        np.column_stack([x, 2 * y1 - y]),
    ]


def _circumcentres(tri_pts: np.ndarray) -> np.ndarray:
    """(T, 2) circumcentres of the triangles ``tri_pts`` (T, 3, 2)."""
    a = tri_pts[:, 0]
    b = tri_pts[:, 1] - a
    c = tri_pts[:, 2] - a
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    b2 = b[:, 0] ** 2 + b[:, 1] ** 2
    c2 = c[:, 0] ** 2 + c[:, 1] ** 2
    ux = (c[:, 1] * b2 - b[:, 1] * c2) / d
    uy = (b[:, 0] * c2 - c[:, 0] * b2) / d
    return np.column_stack([ux, uy]) + a


def _initial_mirror_mask(points: np.ndarray, region: Region) -> np.ndarray:
    """(n, 4) guess of the mirrors needed: generators within ~2.5 mean spacings of a side."""
    n = points.shape[0]
    x0, y0, x1, y1 = region
    if n < 8:
        return np.ones((n, 4), dtype=bool)
    h = 2.5 * np.sqrt((x1 - x0) * (y1 - y0) / n)
    x, y = points[:, 0], points[:, 1]
    return np.column_stack([x - x0 < h, x1 - x < h, y - y0 < h, y1 - y < h])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


class _CellSolver:
    """Exact clipped Voronoi cells of a (moving) generator set.

    Holds the mirror mask and the last Delaunay triangulation of generators + mirrors. With
    ``reuse=True`` the triangulation is kept while it is still the Delaunay triangulation of the
    moved points: no triangle flipped, every interior edge locally Delaunay (the opposite vertex
    of the neighbour is not inside the circumcircle, to a relative 1e-10 of R², where either
    diagonal of a near-cocircular quad gives the same cells to that order) and a convex outer
    boundary; by the local-Delaunay theorem the triangulation is then Delaunay. Lloyd moves
    shrink geometrically, so after the first iterations qhull is rarely called.
    """

    def __init__(self, region: Region, *, reuse: bool):
        self.region = region
        self.reuse = reuse
        self.mask: np.ndarray | None = None
        self.S: np.ndarray | None = None
        self.qhull_calls = 0
        x0, y0, x1, y1 = region
        self.eps = 1e-12 * max(x1 - x0, y1 - y0)
        # Mirror k maps (x, y) to (sx x + bx, sy y + by): across x_min, x_max, y_min, y_max.
        self._affine = np.array(
            [[1, 0, 1, 0], [-1, 2 * x0, 1, 0], [-1, 2 * x1, 1, 0], [1, 0, -1, 2 * y0], [1, 0, -1, 2 * y1]], dtype=float
        )

    def _set_mask(self, mask: np.ndarray) -> None:
        self.mask = mask
        n = mask.shape[0]
        src = [np.arange(n)] + [np.flatnonzero(mask[:, k]) for k in range(4)]
        kind = np.concatenate([np.full(v.size, k) for k, v in enumerate(src)])
        self._src = np.concatenate(src)
        aff = self._affine[kind]
        self._scale = aff[:, [0, 2]]
        self._shift = aff[:, [1, 3]]
        self.S = None

    def _points(self, P: np.ndarray) -> np.ndarray:
        return P[self._src] * self._scale + self._shift

    def _triangulate(self, Q: np.ndarray, n: int) -> None:
        tri = Delaunay(Q)
        self.qhull_calls += 1
        S, Nb = tri.simplices, tri.neighbors
        V = Q[S]
        self.S = S
        self.orient = np.sign(_cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]))
        # Triangles with a generator as a vertex carry the cells; generators on the outer
        # boundary have unbounded cells and need mirrors (all four, to be safe).
        orig = S < n
        self.sub = np.flatnonzero(orig.any(axis=1))
        self.S_sub = S[self.sub]
        self.orig_sub = orig[self.sub]
        # (triangle, generator corner) pairs: corner, next and previous corner, triangle.
        t_p, k_p = np.nonzero(orig)
        self.pk, self.pn, self.pp = S[t_p, k_p], S[t_p, (k_p + 1) % 3], S[t_p, (k_p + 2) % 3]
        self.pt = t_p
        self.hull_need = np.zeros(n, dtype=bool)
        hull = Nb < 0
        for k in range(3):
            for kk in ((k + 1) % 3, (k + 2) % 3):
                v = S[hull[:, k], kk]
                self.hull_need[v[v < n]] = True
        if not self.reuse:
            return
        inner = ~hull
        t_idx, k_idx = np.nonzero(inner)
        nb = Nb[t_idx, k_idx]
        once = t_idx < nb  # the in-circle test of an edge is symmetric
        t_idx, nb = t_idx[once], nb[once]
        kk = np.argmax(Nb[nb] == t_idx[:, None], axis=1)
        self.opp_t, self.opp_v = t_idx, S[nb, kk]
        # Outer boundary, directed with the interior on the left: a -> b, and next[b].
        t_h, k_h = np.nonzero(hull)
        a = S[t_h, (k_h + 1) % 3]
        b = S[t_h, (k_h + 2) % 3]
        flip = self.orient[t_h] < 0
        a, b = np.where(flip, b, a), np.where(flip, a, b)
        nxt = np.full(Q.shape[0], -1)
        nxt[a] = b
        self.hull_a, self.hull_b, self.hull_c = a, b, nxt[b]

    def _still_delaunay(self, Q: np.ndarray, V: np.ndarray, cc: np.ndarray) -> bool:
        o = np.sign(_cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]))
        if not np.array_equal(o, self.orient):
            return False
        R2 = ((V[:, 0] - cc) ** 2).sum(axis=1)
        d2 = ((Q[self.opp_v] - cc[self.opp_t]) ** 2).sum(axis=1)
        if np.any(d2 < R2[self.opp_t] * (1.0 - 1e-10)):
            return False
        pa, pb, pc = Q[self.hull_a], Q[self.hull_b], Q[self.hull_c]
        turn = _cross(pb - pa, pc - pb)
        scale = ((pb - pa) ** 2).sum(axis=1) + ((pc - pb) ** 2).sum(axis=1)
        return bool(np.all(turn >= -1e-12 * scale))

    def centroids(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(centroids (n, 2), areas (n,)) of the cells of ``P`` clipped to the region."""
        n = P.shape[0]
        if self.mask is None or self.mask.shape[0] != n:
            self._set_mask(_initial_mirror_mask(P, self.region))
        for _ in range(8):
            Q = self._points(P)
            if self.S is not None and self.reuse:
                V = Q[self.S]
                cc = _circumcentres(V)
                if not self._still_delaunay(Q, V, cc):
                    self.S = None
            else:
                self.S = None
            if self.S is None:
                self._triangulate(Q, n)
                V = Q[self.S]
                cc = _circumcentres(V)
            need = self._needed_mirrors(n, cc[self.sub])
            if not (need & ~self.mask).any():
                return self._cells(n, Q, cc)
            self._set_mask(self.mask | need)
        # All four mirrors of every generator always give bounded cells clipped to the region.
        self._set_mask(np.ones((n, 4), dtype=bool))
        Q = self._points(P)
        self._triangulate(Q, n)
        return self._cells(n, Q, _circumcentres(Q[self.S]))

    def _needed_mirrors(self, n: int, cc: np.ndarray) -> np.ndarray:
        """(n, 4) mirrors the current cells show to be needed (unbounded or crossing a side)."""
        need = np.zeros((n, 4), dtype=bool)
        need[self.hull_need] = True
        x0, y0, x1, y1 = self.region
        eps = self.eps
        outside = (cc[:, 0] < x0 - eps, cc[:, 0] > x1 + eps, cc[:, 1] < y0 - eps, cc[:, 1] > y1 + eps)
        for side, out in enumerate(outside):
            if out.any():
                hit = self.orig_sub & out[:, None]
                need[self.S_sub[hit], side] = True
        return need

    def _cells(self, n: int, Q: np.ndarray, cc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Area and centroid of each cell from its (triangle, corner) pieces.

        The piece of corner ``v`` of triangle ``t`` (circumcentre ``c``, other corners ``v_n``,
        ``v_p`` in the triangle's order, orientation ``o = ±1``) is the signed quadrilateral
        ``(v, v + e_n, c, v + e_p)`` with ``e_n = (v_n − v)/2``, ``e_p = (v_p − v)/2``,
        ``u = c − v``: area ``A = ½ o (e_n × u + u × e_p)`` and first moment
        ``A v + [A_1 (e_n + u) + A_2 (u + e_p)] / 3``.
        """
        v = Q[self.pk]
        en = 0.5 * (Q[self.pn] - v)
        ep = 0.5 * (Q[self.pp] - v)
        u = cc[self.pt] - v
        o = 0.5 * self.orient[self.pt]
        A1 = o * (en[:, 0] * u[:, 1] - en[:, 1] * u[:, 0])
        A2 = o * (u[:, 0] * ep[:, 1] - u[:, 1] * ep[:, 0])
        A = A1 + A2
        mx = A * v[:, 0] + (A1 * (en[:, 0] + u[:, 0]) + A2 * (u[:, 0] + ep[:, 0])) / 3.0
        my = A * v[:, 1] + (A1 * (en[:, 1] + u[:, 1]) + A2 * (u[:, 1] + ep[:, 1])) / 3.0
        area = np.bincount(self.pk, A, n)
        cx = np.bincount(self.pk, mx, n)
        cy = np.bincount(self.pk, my, n)
        if not np.all(area > 0):
            bad = np.flatnonzero(~(area > 0))
            raise RuntimeError(
                f"points: generators {bad.tolist()} have empty Voronoi cells "
                "(duplicate generators or generators on the region's boundary)"
            )
        return np.column_stack([cx / area, cy / area]), area


def voronoi_centroids(points: np.ndarray, region: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """Centroids and areas of the Voronoi cells of ``points`` clipped to ``region`` (exact).

    Args:
      points: (n, 2) distinct generators strictly inside the region.
      region: ``(x_min, y_min, x_max, y_max)``.
    Returns:
      ``(centroids (n, 2), areas (n,))``: ``c_i = ∫_{V_i} x dA / |V_i|`` and ``|V_i|``.
    """
    region = as_region(region)
    P = _check_points(points, region)
    if P.shape[0] == 0:
        return np.zeros((0, 2)), np.zeros(0)
    return _CellSolver(region, reuse=False).centroids(P)


def _check_points(points, region: Region) -> np.ndarray:
    P = np.asarray(points, dtype=float)
    if P.ndim != 2 or P.shape[1] != 2:
        raise ValueError(f"points: expected shape (n, 2), got {P.shape}")
    x0, y0, x1, y1 = region
    if not np.all((P[:, 0] > x0) & (P[:, 0] < x1) & (P[:, 1] > y0) & (P[:, 1] < y1)):
        raise ValueError("points: every generator must lie strictly inside the region")
    return P


def voronoi_cells(points: np.ndarray, region: Sequence[float]) -> list[np.ndarray]:
    """Ordered polygons (counter-clockwise, (k, 2) each) of the Voronoi cells clipped to ``region``.

    Plain reference: ``scipy.spatial.Voronoi`` of the generators and all four sets of mirror
    images; cell ``i`` is the region of generator ``i``, its vertices sorted by angle about it.
    Used for the figures and to test :func:`voronoi_centroids`.
    """
    region = as_region(region)
    P = np.asarray(points, dtype=float)
    n = P.shape[0]
    if n == 0:
        return []
    vor = Voronoi(np.concatenate([P] + _mirrors(P, region)))
    cells = []
    for i in range(n):
        verts = vor.regions[vor.point_region[i]]
        if -1 in verts or len(verts) < 3:  # pragma: no cover - impossible with the mirrors
            raise RuntimeError(f"voronoi_cells: cell {i} is unbounded")
        poly = vor.vertices[verts]
        ang = np.arctan2(poly[:, 1] - P[i, 1], poly[:, 0] - P[i, 0])
        cells.append(poly[np.argsort(ang)])
    return cells


@restorable  # a selection made during a run is part of its checkpoint (the rebuilt run has not made it)
@dataclass(frozen=True)
class LloydResult:
    """Outcome of :func:`lloyd`.

    Attributes:
      generators: (n, 2) final generators (a CVT when ``converged``).
      iterations: Lloyd updates made.
      converged: the last move was below ``tol_rel · L``.
      max_move: the largest generator move of the last update [length unit of the region].
      time_s: wall-clock time of the run [s].
    """

    generators: np.ndarray
    iterations: int
    converged: bool
    max_move: float
    time_s: float


def _check_lloyd_options(tol_rel: float, max_iter: int) -> None:
    if not (np.isfinite(tol_rel) and tol_rel > 0):
        raise ValueError(f"tol_rel: must be a number > 0, got {tol_rel!r}")
    if int(max_iter) != max_iter or max_iter < 0:
        raise ValueError(f"max_iter: must be an integer >= 0, got {max_iter!r}")


def initial_generators(count: int, region: Sequence[float], *, seed: int) -> np.ndarray:
    """(count, 2) uniform random generators in ``region`` from ``default_rng(seed)``."""
    if int(count) != count or count < 0:
        raise ValueError(f"count: must be an integer >= 0, got {count!r}")
    x0, y0, x1, y1 = as_region(region)
    rng = np.random.default_rng(seed)
    P = rng.uniform((x0, y0), (x1, y1), size=(int(count), 2))
    # uniform() is half-open; keep generators strictly inside so no cell is degenerate.
    tiny = 1e-12 * max(x1 - x0, y1 - y0)
    return np.clip(P, (x0 + tiny, y0 + tiny), (x1 - tiny, y1 - tiny))


def lloyd(
    count_or_points: int | np.ndarray,
    *,
    region: Sequence[float],
    seed: int = 0,
    tol_rel: float = 1e-6,
    max_iter: int = 10_000,
    reuse_triangulation: bool = True,
) -> LloydResult:
    """Lloyd's algorithm in a rectangle.

    Args:
      count_or_points: number of generators (drawn by :func:`initial_generators` with ``seed``),
        or an (n, 2) array of initial generators.
      region: ``(x_min, y_min, x_max, y_max)``.
      seed: RNG seed of the initial generators.
      tol_rel: stop when the largest move is below ``tol_rel`` × the longer side of the region.
      max_iter: cap on the number of updates.
      reuse_triangulation: keep the Delaunay triangulation between iterations while it stays
        Delaunay (same iterates to ~1e-10 of the spacing, several times faster); ``False``
        re-triangulates every iteration.
    """
    region = as_region(region)
    _check_lloyd_options(tol_rel, max_iter)
    t0 = time.perf_counter()
    if isinstance(count_or_points, (int, np.integer)):
        P = initial_generators(int(count_or_points), region, seed=seed)
    else:
        P = _check_points(np.array(count_or_points, dtype=float), region)
    tol = tol_rel * max(region[2] - region[0], region[3] - region[1])
    n = P.shape[0]
    if n == 0:
        return LloydResult(P, 0, True, 0.0, time.perf_counter() - t0)
    solver = _CellSolver(region, reuse=reuse_triangulation)
    it, move = 0, np.inf
    while it < max_iter:
        C, _ = solver.centroids(P)
        d = C - P
        move = float(np.sqrt(np.max(d[:, 0] ** 2 + d[:, 1] ** 2)))
        P = C
        it += 1
        if move < tol:
            break
    return LloydResult(P, it, bool(move < tol), move, time.perf_counter() - t0)


def snap_to_sites(generators: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """Distinct site indices, one per generator, minimising ``Σ |g_i − s_σ(i)|²``.

    Returns the chosen site indices sorted ascending ((n,) int64). ``len(generators)`` must not
    exceed ``len(sites)``; with equal numbers every site is chosen.
    """
    G = np.asarray(generators, dtype=float).reshape(-1, 2)
    Sx = np.asarray(sites, dtype=float)
    if Sx.ndim != 2 or Sx.shape[1] != 2:
        raise ValueError(f"sites: expected shape (m, 2), got {Sx.shape}")
    if G.shape[0] > Sx.shape[0]:
        raise ValueError(f"generators: {G.shape[0]} generators but only {Sx.shape[0]} sites")
    if G.shape[0] == 0:
        return np.zeros(0, dtype=np.int64)
    if G.shape[0] == Sx.shape[0]:
        return np.arange(Sx.shape[0], dtype=np.int64)
    cost = ((G[:, None, :] - Sx[None, :, :]) ** 2).sum(axis=2)
    _, cols = linear_sum_assignment(cost)
    return np.sort(cols.astype(np.int64))


@dataclass(frozen=True)
class MirrorOrbits:
    """The sites of one family grouped by the mirrors about both centre lines of a region.

    Attributes:
      members: (n_orbits, 4) site indices of each orbit: its lowest-index site ``(x, y)`` and the
        sites at ``(2 x_c − x, y)``, ``(x, 2 y_c − y)``, ``(2 x_c − x, 2 y_c − y)`` (repeated where
        the site lies on a centre line).
      size: (n_orbits,) distinct sites of each orbit: 4, 2 (on one centre line) or 1 (the centre).
      rep: (n_orbits, 2) the orbit's point in the upper-right quadrant,
        ``(x_c + |x − x_c|, y_c + |y − y_c|)`` [length unit of the region].
      centre: ``(x_c, y_c)``, the centre of the region.
    """

    members: np.ndarray
    size: np.ndarray
    rep: np.ndarray
    centre: tuple[float, float]

    def sites_of(self, orbits: np.ndarray) -> np.ndarray:
        """Sorted distinct site indices of ``orbits`` ((k,) int64)."""
        return np.unique(self.members[np.asarray(orbits, dtype=np.int64)].ravel()).astype(np.int64)


def mirror_orbits(sites: np.ndarray, region: Sequence[float]) -> MirrorOrbits:
    """Orbits of ``sites`` ((n, 2)) under the mirrors about the centre lines of ``region``.

    Every mirror image of a site must be a site, to ``1e-9`` of the region's longer side; otherwise
    ``ValueError`` naming the first site whose image is missing and its distance to the nearest site.
    """
    reg = as_region(region)
    S = np.asarray(sites, dtype=float)
    if S.ndim != 2 or S.shape[1] != 2 or S.shape[0] == 0:
        raise ValueError(f"sites: expected a non-empty (n, 2) array, got shape {S.shape}")
    xc, yc = 0.5 * (reg[0] + reg[2]), 0.5 * (reg[1] + reg[3])
    tol = _MIRROR_TOL_REL * max(reg[2] - reg[0], reg[3] - reg[1])
    tree = cKDTree(S)
    columns = [np.arange(S.shape[0], dtype=np.int64)]
    for name, (sx, sy) in (("x = x_c", (-1.0, 1.0)), ("y = y_c", (1.0, -1.0)), ("both centre lines", (-1.0, -1.0))):
        image = np.column_stack([xc + sx * (S[:, 0] - xc), yc + sy * (S[:, 1] - yc)])
        dist, idx = tree.query(image)
        if dist.max() > tol:
            bad = int(np.argmax(dist))
            raise ValueError(
                f"sites: symmetry 'mirror_xy' needs sites mirror-symmetric about x_c = {xc:g}, y_c = {yc:g}; "
                f"the mirror image of site {bad} {S[bad].tolist()} across {name} is {dist[bad]:.3g} "
                "from the nearest site"
            )
        columns.append(idx.astype(np.int64))
    M = np.column_stack(columns)
    first = np.flatnonzero(M.min(axis=1) == columns[0])  # one row per orbit: its lowest-index site
    members = M[first]
    ordered = np.sort(members, axis=1)
    size = 1 + np.count_nonzero(np.diff(ordered, axis=1), axis=1)
    rep = np.column_stack([xc + np.abs(S[first, 0] - xc), yc + np.abs(S[first, 1] - yc)])
    return MirrorOrbits(members, size, rep, (xc, yc))


# --------------------------------------------------------------------------- runtime selector


def _lloyd_job(args):
    count, region, seed, tol_rel, max_iter = args
    return count, lloyd(count, region=region, seed=seed, tol_rel=tol_rel, max_iter=max_iter)


def _read_cache(path: Path | None, read, *, delete_bad: bool = True):
    """``read(path)`` of a cache file, or ``None`` when there is none or it is unreadable, truncated or
    of the wrong shape; such a file is deleted (``delete_bad``) so that it is computed again and
    rewritten (the shipped, read-only selections are never deleted, only passed over)."""
    if path is None or not path.is_file():
        return None
    try:
        return read(path)
    except (OSError, ValueError, KeyError, EOFError, TypeError, zipfile.BadZipFile):
        if delete_bad:
            path.unlink(missing_ok=True)
        return None


def _valid_selection(sel: np.ndarray, count: int, n_sites: int) -> np.ndarray:
    """A cached snapped selection: ``count`` distinct site indices in ``[0, n_sites)``."""
    sel = np.asarray(sel)
    if (
        sel.shape != (count,)
        or not np.issubdtype(sel.dtype, np.integer)
        or (count and (sel.min() < 0 or sel.max() >= n_sites))
        or np.unique(sel).size != count
    ):
        raise ValueError(f"cached selection: expected {count} distinct indices below {n_sites}")
    return sel.astype(np.int64, copy=False)


def _load_result(path: Path, count: int) -> LloydResult:
    """A cached Lloyd result of ``count`` finite (count, 2) generators."""
    with np.load(path, allow_pickle=False) as z:
        res = LloydResult(
            np.asarray(z["generators"], dtype=float),
            int(z["iterations"]),
            bool(z["converged"]),
            float(z["max_move"]),
            float(z["time_s"]),
        )
    if res.generators.shape != (count, 2) or not np.all(np.isfinite(res.generators)):
        raise ValueError(f"cached generators: expected a finite ({count}, 2) array")
    return res


class LloydSelector:
    """Cached rod selection for arrays of site families sharing one region.

    Args:
      sites: one (n_f, 2) array of site positions per family, in region coordinates (for the
        truss: body ``x1, y1`` of the strut midpoints).
      region: ``(x_min, y_min, x_max, y_max)`` covered by the array.
      seed: seed of the initial generators (default ``sim.seed``).
      tol_rel, max_iter: Lloyd stopping rule (see :func:`lloyd`).
      cache_dir: optional folder of the on-disk cache; one ``.npz`` of generators per count
        under a sub-folder named by a hash of (region, seed, tol_rel, max_iter, algorithm
        version), and beside them one ``.npy`` of snapped site indices per (family, count) under
        ``sites_<hash of the family's sites>/`` (the snap is a linear assignment, ~2 ms).
      shipped_dir: a read-only folder of the same layout consulted after ``cache_dir`` (default
        :data:`SHIPPED_DIR`, the selections of the shipped configs installed with the package, so
        a fresh checkout runs them without minutes of Lloyd iterations; ``None``: none).
      symmetry: ``"none"`` (default) or ``"mirror_xy"``: selections mirror-symmetric about both
        centre lines of the region (module docstring; the sites must be mirror-symmetric, and an
        odd count without a site at the centre selects one site fewer). Part of the cache key
        when not ``"none"``.

    The families' rods are numbered consecutively (family 0 first), as in
    :class:`magsail_mj.loads.magnetorquer_rods.RodArray`; :meth:`polarity` returns the int8
    polarity vector over all of them.
    """

    def __init__(
        self,
        sites: Sequence[np.ndarray],
        *,
        region: Sequence[float],
        seed: int = 0,
        tol_rel: float = 1e-6,
        max_iter: int = 10_000,
        cache_dir: str | Path | None = None,
        shipped_dir: str | Path | None = SHIPPED_DIR,
        symmetry: Symmetry = "none",
    ):
        self.region = as_region(region)
        _check_lloyd_options(tol_rel, max_iter)
        if symmetry not in SYMMETRIES:
            raise ValueError(f"symmetry: must be one of {list(SYMMETRIES)}, got {symmetry!r}")
        if int(seed) != seed or seed < 0:
            raise ValueError(f"seed: must be an integer >= 0, got {seed!r}")
        fams = [np.asarray(s, dtype=float) for s in sites]
        if not fams:
            raise ValueError("sites: need at least one family")
        for f, s in enumerate(fams):
            if s.ndim != 2 or s.shape[1] != 2 or s.shape[0] == 0:
                raise ValueError(f"sites[{f}]: expected a non-empty (n, 2) array, got shape {s.shape}")
        self.sites = fams
        self.symmetry: Symmetry = symmetry
        #: per family, the mirror orbits of its sites (``symmetry="mirror_xy"``; else None)
        self.orbits = [mirror_orbits(s, self.region) for s in fams] if symmetry == "mirror_xy" else None
        x0, y0, x1, y1 = self.region
        #: where the generators live: the region, or its upper-right quadrant with ``"mirror_xy"``
        self.lloyd_region: Region = self.region if symmetry == "none" else (0.5 * (x0 + x1), 0.5 * (y0 + y1), x1, y1)
        self.n_sites = tuple(s.shape[0] for s in fams)
        self.offsets = tuple(int(v) for v in np.concatenate([[0], np.cumsum(self.n_sites)[:-1]]))
        self.n_rods = int(sum(self.n_sites))
        self.seed = int(seed)
        self.tol_rel = float(tol_rel)
        self.max_iter = int(max_iter)
        self.cache_dir = None if cache_dir is None else Path(cache_dir) / f"lloyd_{self.cache_key()}"
        self.shipped_dir = None if shipped_dir is None else Path(shipped_dir) / f"lloyd_{self.cache_key()}"
        self._sites_key = [hashlib.sha256(np.ascontiguousarray(f).tobytes()).hexdigest()[:16] for f in fams]
        self._gen: dict[int, LloydResult] = {}
        self._sel: dict[tuple[int, int], np.ndarray] = {}
        self._global: dict[tuple[int, int], np.ndarray] = {}
        self.stats = {
            "lloyd_runs": 0,
            "lloyd_time_s": 0.0,
            "disk_hits": 0,
            "snap_time_s": 0.0,
            "snap_disk_hits": 0,
            "shipped_hits": 0,
        }

    def cache_key(self) -> str:
        """Hash of what the generators depend on (region, seed, tolerance, cap, algorithm; the
        symmetry when not ``"none"``, so the keys of plain selections are those they always had)."""
        fields: dict[str, object] = {
            "region": list(self.region),
            "seed": self.seed,
            "tol_rel": self.tol_rel,
            "max_iter": self.max_iter,
            "algo": _ALGO_VERSION,
        }
        if self.symmetry != "none":
            fields["symmetry"] = self.symmetry
        blob = json.dumps(fields, sort_keys=True)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]

    # -- generators
    def _disk_path(self, count: int, *, shipped: bool = False) -> Path | None:
        root = self.shipped_dir if shipped else self.cache_dir
        return None if root is None else root / f"n{count:05d}.npz"

    def _snap_path(self, family: int, count: int, *, shipped: bool = False) -> Path | None:
        root = self.shipped_dir if shipped else self.cache_dir
        return None if root is None else root / f"sites_{self._sites_key[family]}" / f"n{count:05d}.npy"

    def _on_disk(self, count: int) -> bool:
        """Whether the generators of ``count`` are in the cache or among the shipped ones."""
        paths = (self._disk_path(count), self._disk_path(count, shipped=True))
        return any(p is not None and p.is_file() for p in paths)

    def _snapped(self, family: int, count: int) -> np.ndarray:
        """Snapped selection of ``count`` sites of ``family``: from disk, else snapped and stored."""
        path = self._snap_path(family, count)

        size = self.selection_size(family, count)

        def read(p: Path) -> np.ndarray:
            return _valid_selection(np.load(p, allow_pickle=False), size, self.n_sites[family])

        cached = _read_cache(path, read)
        if cached is not None:
            self.stats["snap_disk_hits"] += 1
            return cached
        cached = _read_cache(self._snap_path(family, count, shipped=True), read, delete_bad=False)
        if cached is not None:
            self.stats["shipped_hits"] += 1
            return cached
        if self.orbits is None:
            gen = self.result(count).generators
            t0 = time.perf_counter()
            sel = snap_to_sites(gen, self.sites[family])
        else:
            t0 = time.perf_counter()
            sel = self._symmetric_selection(family, count)
        self.stats["snap_time_s"] += time.perf_counter() - t0
        if path is not None:
            with atomic_path(path, suffix=".npy") as tmp:
                with open(tmp, "wb") as fh:
                    np.save(fh, sel)
        return sel

    def _store(self, count: int, res: LloydResult) -> None:
        self._gen[count] = res
        path = self._disk_path(count)
        if path is not None and not path.exists():
            with atomic_path(path, suffix=".npz") as tmp:
                with open(tmp, "wb") as fh:
                    np.savez(
                        fh,
                        generators=res.generators,
                        iterations=res.iterations,
                        converged=res.converged,
                        max_move=res.max_move,
                        time_s=res.time_s,
                    )

    def _check_count(self, count: int) -> int:
        if int(count) != count or count < 0:
            raise ValueError(f"count: must be an integer >= 0, got {count!r}")
        return int(count)

    # -- mirror-symmetric selections
    def _orbit_counts(self, family: int, count: int) -> tuple[int, int, int]:
        """``(q, p, s)``: four-, two- and one-site orbits of the symmetric selection of ``count``."""
        size = self.orbits[family].size
        q = min(count // 4, int(np.count_nonzero(size == 4)))
        p = min((count - 4 * q) // 2, int(np.count_nonzero(size == 2)))
        s = min(count - 4 * q - 2 * p, int(np.count_nonzero(size == 1)))
        return q, p, s

    def selection_size(self, family: int, count: int) -> int:
        """Number of sites the selection of ``count`` switches on: ``count``, or with
        ``"mirror_xy"`` the sites of its orbits (one fewer for an odd count without a centre site)."""
        if self.orbits is None or count == self.n_sites[family]:
            return count
        q, p, s = self._orbit_counts(family, count)
        return 4 * q + 2 * p + s

    def _lloyd_count(self, family: int, count: int) -> int | None:
        """Generators of the Lloyd run the selection of ``count`` in ``family`` needs (None: none)."""
        if count >= self.n_sites[family]:
            return None
        if self.orbits is None:
            return count
        q = self._orbit_counts(family, count)[0]
        return q if 0 < q < np.count_nonzero(self.orbits[family].size == 4) else None

    def _symmetric_selection(self, family: int, count: int) -> np.ndarray:
        """Sorted site indices of the mirror-symmetric selection of ``count`` (module docstring)."""
        orb = self.orbits[family]
        q, p, s = self._orbit_counts(family, count)
        quads = np.flatnonzero(orb.size == 4)
        if q == quads.size:
            chosen = quads
        elif q:
            chosen = quads[snap_to_sites(self.result(q).generators, orb.rep[quads])]
        else:
            chosen = np.zeros(0, dtype=np.int64)
        sites = self.sites[family]
        x0, y0, x1, y1 = self.lloyd_region
        tie = _MIRROR_TOL_REL * max(self.region[2] - self.region[0], self.region[3] - self.region[1])
        for size, n_add in ((2, p), (1, s)):
            pool = np.flatnonzero(orb.size == size)
            # distance of each orbit's quadrant point to the quadrant's centre: the tie-break
            to_centre = np.hypot(orb.rep[pool, 0] - 0.5 * (x0 + x1), orb.rep[pool, 1] - 0.5 * (y0 + y1))
            for _ in range(n_add):
                free = ~np.isin(pool, chosen)
                if chosen.size:
                    far, _ = cKDTree(sites[orb.sites_of(chosen)]).query(sites[orb.members[pool, 0]])
                else:
                    far = np.full(pool.size, np.inf)
                far = np.where(free, far, -np.inf)
                best = far.max()
                near_best = free & ((far >= best - tie) | np.isinf(best))
                pick = pool[np.flatnonzero(near_best)[np.argmin(to_centre[near_best])]]
                chosen = np.append(chosen, pick)
        return orb.sites_of(chosen)

    def result(self, count: int) -> LloydResult:
        """The Lloyd result for ``count`` generators in :attr:`lloyd_region` (the region, or its
        upper-right quadrant with ``"mirror_xy"``): memory, then disk, then computed."""
        count = self._check_count(count)
        res = self._gen.get(count)
        if res is not None:
            return res
        path = self._disk_path(count)
        res = _read_cache(path, lambda p: _load_result(p, count))
        if res is not None:
            self.stats["disk_hits"] += 1
            self._gen[count] = res
            return res
        res = _read_cache(self._disk_path(count, shipped=True), lambda p: _load_result(p, count), delete_bad=False)
        if res is not None:
            self.stats["shipped_hits"] += 1
            self._gen[count] = res
            return res
        res = lloyd(count, region=self.lloyd_region, seed=self.seed, tol_rel=self.tol_rel, max_iter=self.max_iter)
        self.stats["lloyd_runs"] += 1
        self.stats["lloyd_time_s"] += res.time_s
        self._store(count, res)
        return res

    def precompute(self, counts: Iterable[int] | None = None, *, workers: int = 1) -> None:
        """Compute (and cache) the generators of ``counts`` (default: 0 … largest family size).

        ``workers > 1`` runs the Lloyd iterations in that many processes.
        """
        if int(workers) != workers or workers < 1:
            raise ValueError(f"workers: must be an integer >= 1, got {workers!r}")
        wanted = [self._check_count(c) for c in (range(max(self.n_sites) + 1) if counts is None else counts)]
        if wanted and max(wanted) > max(self.n_sites):
            raise ValueError(f"counts: at most {max(self.n_sites)} sites per family, got {max(wanted)}")
        # A count equal to every family's size selects all sites and needs no Lloyd run (nor, with
        # "mirror_xy", one that takes every four-site orbit); the largest counts go first so that
        # the worker processes finish together.
        needed = {self._lloyd_count(f, c) for c in wanted for f in range(len(self.sites)) if c <= self.n_sites[f]}
        todo = sorted(needed - {None}, reverse=True)
        todo = [c for c in todo if c not in self._gen and not self._on_disk(c)]
        if workers == 1 or len(todo) < 2:
            for c in todo:
                self.result(c)
        else:
            jobs = [(c, self.lloyd_region, self.seed, self.tol_rel, self.max_iter) for c in todo]
            with ProcessPoolExecutor(max_workers=int(workers)) as ex:
                for c, res in ex.map(_lloyd_job, jobs, chunksize=1):
                    self.stats["lloyd_runs"] += 1
                    self.stats["lloyd_time_s"] += res.time_s
                    self._store(c, res)
        for c in wanted:
            for f in range(len(self.sites)):
                if c <= self.n_sites[f]:
                    self.selected(f, c)

    # -- selection
    def selected(self, family: int, count: int) -> np.ndarray:
        """Sorted indices (within ``family``) of the ``count`` sites to activate; read-only (with
        ``"mirror_xy"``: :meth:`selection_size` sites, one fewer for an odd count without a centre site)."""
        if int(family) != family or not 0 <= family < len(self.sites):
            raise ValueError(f"family: must be 0 … {len(self.sites) - 1}, got {family!r}")
        count = self._check_count(count)
        if count > self.n_sites[family]:
            raise ValueError(f"count: family {family} has {self.n_sites[family]} sites, got {count}")
        key = (int(family), count)
        sel = self._sel.get(key)
        if sel is None:
            if count == self.n_sites[family]:  # every site: no Lloyd run needed
                sel = np.arange(count, dtype=np.int64)
            else:
                sel = self._snapped(family, count)
            sel.setflags(write=False)
            self._sel[key] = sel
        return sel

    def polarity(self, counts: Sequence[int]) -> np.ndarray:
        """(n_rods,) int8 polarities for the signed counts ``N_f`` of each family.

        ``|N_f|`` rods of family ``f`` (the cached selection; with ``"mirror_xy"`` its
        :meth:`selection_size`) get ``sign(N_f)``; all others 0.
        """
        if len(counts) != len(self.sites):
            raise ValueError(f"counts: expected {len(self.sites)} signed counts, got {len(counts)}")
        out = np.zeros(self.n_rods, dtype=np.int8)
        for f, N in enumerate(counts):
            if N:
                key = (f, abs(int(N)))
                idx = self._global.get(key)
                if idx is None:
                    idx = self.offsets[f] + self.selected(f, key[1])
                    self._global[key] = idx
                out[idx] = 1 if N > 0 else -1
        return out


def nn_spacing_cv(points: np.ndarray) -> float:
    """Coefficient of variation (std/mean) of the nearest-neighbour distances of ``points``."""
    P = np.asarray(points, dtype=float)
    if P.shape[0] < 2:
        return float("nan")
    d, _ = cKDTree(P).query(P, k=2)
    nn = d[:, 1]
    return float(nn.std() / nn.mean())


def covering_radius(points: np.ndarray, region: Sequence[float], *, samples_per_side: int = 201) -> float:
    """Largest distance from a point of ``region`` to the nearest of ``points`` (evenness measure),
    evaluated on a ``samples_per_side²`` grid including the boundary."""
    x0, y0, x1, y1 = as_region(region)
    P = np.asarray(points, dtype=float)
    if P.shape[0] == 0:
        return float("inf")
    gx, gy = np.meshgrid(np.linspace(x0, x1, samples_per_side), np.linspace(y0, y1, samples_per_side))
    d, _ = cKDTree(P).query(np.column_stack([gx.ravel(), gy.ravel()]))
    return float(d.max())
