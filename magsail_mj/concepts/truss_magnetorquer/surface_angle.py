r"""Local surface angle of the deformed top layer (our reading of Robb et al. 2022a).

At one chosen time (e.g. the time of maximum surface SD):

1. The top-layer nodes are expressed in the **average-plane frame** (the average
   plane of the top layer, not the body ``x1 y1`` plane): origin at the centroid, normal
   :math:`\hat n` from the total-least-squares fit, oriented along the best-fit body
   ``z1``; in-plane axes :math:`\hat e_u` = the best-fit body ``x1`` projected onto the plane and
   normalised, :math:`\hat e_v = \hat n\times\hat e_u` (the projected ``y1`` made exactly
   orthogonal). Coordinates :math:`u, v` (in-plane) and :math:`w` (height along :math:`\hat n`).
2. A continuous surface :math:`w(u, v)` is fitted:

   * ``method="cubic"`` (the paper's choice): ``scipy.interpolate.CloughTocher2DInterpolator``
     on the Delaunay triangulation of the scattered nodes (like MATLAB's cubic ``griddata``),
     evaluated on a regular grid of spacing ``spacing_m`` inside the convex hull; gradient by
     finite differences (central, one-sided next to the hull); triangle-shaped artefacts and
     boundary overshoot are expected with this method;
   * ``method="spline"``: an interpolating bicubic spline on the reference node grid. The
     surface is fitted parametrically, :math:`(u, v, w)(s, t)` with ``s``, ``t`` the node
     column/row means of ``u``/``v`` (the undeformed in-plane grid up to in-plane strain), so
     in-plane displacements are accounted for exactly; the tangent vectors come from the
     spline derivatives and the slope from the surface normal
     :math:`N = r_s\times r_t`: :math:`\tan\alpha = \sqrt{N_u^2+N_v^2}/|N_w| = |\nabla w|`.
     Needs the top-layer nodes as an ``N × N`` grid in **j-major** order (flat index
     ``j N + i``, ``i`` along ``x1``), as the lattice generator produces them.

3. :math:`\alpha = \arctan|\nabla w|` [rad]: the angle between the tangent plane and the
   average plane.
4. Statistics over the grid points with a finite ``alpha``: median, 95th percentile, maximum,
   and the maximum along the outer edge (grid points within ``edge_band_m`` of the boundary of
   the node hull; default one cube edge, estimated as the median nearest-neighbour node
   spacing).

**Memory is bounded whatever the positions.** The evaluation grid has at most
:data:`MAX_GRID_SIDE` samples along each axis: when the nodes span more than
``(MAX_GRID_SIDE - 3) × spacing_m`` (a structure that blew up spans kilometres, or 10¹³ m), the
spacing is widened to ``extent / (MAX_GRID_SIDE - 3)`` and reported (``SurfaceAngle.spacing_m``,
the summary's ``surface_angle_spacing_m``). A 100 m plate at the default 0.25 m needs 401 samples
and is not affected. The distance of the grid samples to the hull's boundary is computed in
blocks of at most :data:`HULL_BLOCK_BYTES`, so the hull's facet count (up to the node count for a
crumpled layer) does not multiply the grid. The peak is then at most
:func:`surface_angle_bytes` (:data:`GRID_SAMPLE_BYTES` per grid sample, measured), which the
memory estimate (:mod:`magsail_mj.resources`) counts.

**Why the fitted maps have boundary artefacts, and the artefact-free cell angles.** Both fits
extrapolate at the boundary: the Clough–Tocher interpolant estimates each node's gradient from
its neighbours (a curvature-minimising global fit), which at a boundary node sees one side only,
and the finite-difference gradient of the 0.25 m grid turns one-sided next to the hull; the
interpolating bicubic spline takes its end derivatives from the "not-a-knot" condition, i.e. the
third derivative of the last interior interval carried out to the edge. Either way the slope
at the edge is an extrapolation of the interior, so ``max`` and ``edge_max`` (which sit at the
edge for a bent plate) can overshoot. :func:`cell_surface_angle` uses no fit: each cell of the
``N × N`` top-layer grid (four nodes ``r_{j,i} … r_{j+1,i+1}``) gives the plane of its own
bilinear patch at the cell centre, spanned by the mean edge vectors

.. math:: \mathbf a = \tfrac12(\mathbf r_{j,i+1}-\mathbf r_{j,i}+\mathbf r_{j+1,i+1}-\mathbf r_{j+1,i}),\quad
          \mathbf b = \tfrac12(\mathbf r_{j+1,i}-\mathbf r_{j,i}+\mathbf r_{j+1,i+1}-\mathbf r_{j,i+1}),

normal :math:`\mathbf N = \mathbf a\times\mathbf b` (average-plane frame) and
:math:`\alpha = \arctan(\sqrt{N_u^2+N_v^2}/|N_w|)`. Only the cell's own nodes enter, so a
boundary cell is as accurate as an interior one; for any quadratic height ``w(u, v)`` on the
undeformed grid the angle is the exact angle at the cell centre (the mean edge differences are
central differences there). The edge statistic is the maximum over the cells along the outer
ring (the centres half a cube edge inside the boundary).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.interpolate import CloughTocher2DInterpolator, RectBivariateSpline
from scipy.spatial import ConvexHull, Delaunay, cKDTree

from magsail_mj.estimation._arrays import as_points, as_rotations

from magsail_mj.analysis.flatness import average_plane

__all__ = [
    "GRID_SAMPLE_BYTES",
    "HULL_BLOCK_BYTES",
    "MAX_GRID_SIDE",
    "SurfaceAngle",
    "CellSurfaceAngle",
    "grid_spacing",
    "plane_frame",
    "local_surface_angle",
    "cell_surface_angle",
    "surface_angle_bytes",
]

#: the most samples along either axis of the evaluation grid of :func:`local_surface_angle` (the
#: spacing is widened beyond it; 512² samples hold at most :func:`surface_angle_bytes` ≈ 0.1 GiB)
MAX_GRID_SIDE = 512
#: the most bytes of the (samples × hull facets) matrix of the hull distance at once
HULL_BLOCK_BYTES = 8 * 2**20
#: peak bytes per grid sample of :func:`local_surface_angle` (tracemalloc, the hull block included:
#: 135–260 B for N = 6 … 60 nodes per side on 75–120 m plates and on layers blown up to 10⁷ m with
#: the cubic fit, 190 B with the spline), rounded up
GRID_SAMPLE_BYTES = 400.0


@dataclass(frozen=True)
class SurfaceAngle:
    """Result of :func:`local_surface_angle`.

    Attributes:
      u, v: ``(nu,)``, ``(nv,)`` regular grid axes [m] (for ``"spline"``: the parameter grid,
        which is the in-plane position up to in-plane strain; see ``u_points``/``v_points``).
      alpha: ``(nv, nu)`` local surface angle [rad]; NaN outside the node hull.
      w: ``(nv, nu)`` fitted height above the average plane [m]; NaN outside.
      u_points, v_points: ``(nv, nu)`` in-plane position of every grid sample [m].
      edge_mask: ``(nv, nu)`` True for samples within ``edge_band_m`` of the boundary.
      median, p95, max, edge_max: statistics of the finite ``alpha`` values [rad].
      edge_band_m: width of the edge band used [m].
      spacing_m: the grid spacing used [m]: the requested one, or wider when the nodes span more
        than ``MAX_GRID_SIDE - 3`` of it.
      method: ``"cubic"`` or ``"spline"``.
      centroid, normal, e_u, e_v: ``(3,)`` the average-plane frame, in the input frame.
    """

    u: np.ndarray = field(repr=False)
    v: np.ndarray = field(repr=False)
    alpha: np.ndarray = field(repr=False)
    w: np.ndarray = field(repr=False)
    u_points: np.ndarray = field(repr=False)
    v_points: np.ndarray = field(repr=False)
    edge_mask: np.ndarray = field(repr=False)
    median: float
    p95: float
    max: float
    edge_max: float
    edge_band_m: float
    method: str
    centroid: np.ndarray
    normal: np.ndarray
    e_u: np.ndarray
    e_v: np.ndarray
    spacing_m: float = 0.25


def grid_spacing(extent_m: float, spacing_m: float) -> float:
    """The evaluation grid's spacing [m] for nodes spanning ``extent_m`` (the larger in-plane side
    of their bounding box): ``spacing_m``, or ``extent_m / (MAX_GRID_SIDE - 3)`` when that is
    wider, so that each axis (aligned on 0, ends included) has at most :data:`MAX_GRID_SIDE`
    samples."""
    extent = float(extent_m)
    if not (np.isfinite(extent) and extent >= 0):
        raise ValueError(f"extent_m: must be a finite number >= 0, got {extent_m!r}")
    return max(float(spacing_m), extent / (MAX_GRID_SIDE - 3))


def surface_angle_bytes(n_points: int) -> float:
    """The most memory :func:`local_surface_angle` allocates for ``n_points`` top-layer nodes
    [bytes], whatever their positions: :data:`MAX_GRID_SIDE`² grid samples of
    :data:`GRID_SAMPLE_BYTES`, one hull-distance block (:data:`HULL_BLOCK_BYTES`) and the
    triangulation and interpolant of the nodes (1 kB per node)."""
    return MAX_GRID_SIDE**2 * GRID_SAMPLE_BYTES + HULL_BLOCK_BYTES + 1024.0 * float(n_points)


def plane_frame(points: np.ndarray, R_body: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    r"""Average-plane frame of a point set (step 1 of the surface-angle method).

    Returns ``(centroid, normal, e_u, e_v)``, all ``(3,)``: ``normal`` is the TLS normal with
    ``normal · z1 >= 0``; ``e_u`` the normalised projection of body ``x1 = R_body[:, 0]`` on the
    plane; ``e_v = normal × e_u``.
    """
    x = as_points(points, "points", min_points=3)
    R = as_rotations(R_body, "R_body")
    if R.shape != (3, 3):
        raise ValueError(f"R_body: expected shape (3, 3), got {R.shape}")
    c, n = average_plane(x, orient=R[:, 2])
    x1 = R[:, 0]
    eu = x1 - np.dot(x1, n) * n
    nu = np.linalg.norm(eu)
    if not nu > 1e-6:
        raise ValueError("R_body: body x1 axis is (nearly) normal to the average plane")
    eu = eu / nu
    ev = np.cross(n, eu)
    return c, n, eu, ev


def _fd_gradient(W: np.ndarray, h_v: float, h_u: float) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference gradient of a grid with NaN holes: central where both neighbours are
    finite, one-sided where only one is, NaN otherwise. Returns ``(dW/dv, dW/du)``."""

    def one_axis(A: np.ndarray, h: float, axis: int) -> np.ndarray:
        P = np.full(A.shape, np.nan)
        M = np.full(A.shape, np.nan)
        lo = [slice(None)] * 2
        hi = [slice(None)] * 2
        lo[axis] = slice(0, -1)
        hi[axis] = slice(1, None)
        diff = (A[tuple(hi)] - A[tuple(lo)]) / h  # forward diff at lo, backward diff at hi
        P[tuple(lo)] = diff
        M[tuple(hi)] = diff
        central = 0.5 * (P + M)
        return np.where(np.isfinite(central), central, np.where(np.isfinite(P), P, M))

    return one_axis(W, h_v, 0), one_axis(W, h_u, 1)


def _axis(lo: float, hi: float, h: float) -> np.ndarray:
    """Regular axis with spacing ``h``, aligned on 0, covering ``[lo, hi]`` (inclusive)."""
    eps = 1e-9 * max(1.0, abs(lo), abs(hi)) / h
    i0 = int(np.ceil(lo / h - eps))
    i1 = int(np.floor(hi / h + eps))
    return h * np.arange(i0, i1 + 1, dtype=float)


def _hull_distance(nodes_uv: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Distance [m] from each query point to the boundary of the nodes' convex hull (positive
    inside; negative outside), in blocks of query points whose (points × facets) matrix holds at
    most :data:`HULL_BLOCK_BYTES`."""
    hull = ConvexHull(nodes_uv)
    eq = hull.equations  # unit outward normals: n.x + b <= 0 inside
    step = max(1, HULL_BLOCK_BYTES // (8 * eq.shape[0]))
    out = np.empty(query.shape[0])
    for k in range(0, query.shape[0], step):
        out[k : k + step] = -np.max(query[k : k + step] @ eq[:, :2].T + eq[:, 2], axis=-1)
    return out


def _stats(alpha: np.ndarray, edge: np.ndarray) -> tuple[float, float, float, float]:
    fin = np.isfinite(alpha)
    a = alpha[fin]
    if a.size == 0:
        return (np.nan,) * 4
    ae = alpha[fin & edge]
    return (
        float(np.median(a)),
        float(np.percentile(a, 95.0)),
        float(a.max()),
        float(ae.max()) if ae.size else np.nan,
    )


def local_surface_angle(
    top_points: np.ndarray,
    R_body: np.ndarray,
    *,
    spacing_m: float = 0.25,
    method: Literal["cubic", "spline"] = "cubic",
    nodes_per_side: int | None = None,
    edge_band_m: float | None = None,
) -> SurfaceAngle:
    r"""Local surface angle map and statistics of the top layer at one time.

    See the module docstring for the frame, the two fitting methods and the statistics.

    Args:
      top_points: ``(n, 3)`` top-layer node positions [m] (world frame). For
        ``method="spline"`` an ``N × N`` grid in j-major order (index ``j N + i``).
      R_body: ``(3, 3)`` best-fit body-to-world rotation at the same time.
      spacing_m: evaluation grid spacing [m] (default 0.25 m); widened to keep at most
        :data:`MAX_GRID_SIDE` samples per axis (:func:`grid_spacing`; the result's ``spacing_m``).
      method: ``"cubic"`` (Clough–Tocher, default) or ``"spline"`` (bicubic on the node grid).
      nodes_per_side: ``N`` for ``"spline"``; default ``sqrt(n)`` (ignored by ``"cubic"``).
      edge_band_m: width of the boundary band for ``edge_max`` [m]; default one cube edge
        (median nearest-neighbour node spacing in the plane).

    Returns:
      :class:`SurfaceAngle` (angles in radians).
    """
    x = as_points(top_points, "top_points", min_points=3)
    if not (np.isfinite(spacing_m) and spacing_m > 0):
        raise ValueError(f"spacing_m: must be a finite number > 0, got {spacing_m!r}")
    if not np.all(np.isfinite(x)):
        raise ValueError("top_points: contains NaN or Inf")
    c, n, eu, ev = plane_frame(x, R_body)
    X = x - c
    uv = np.stack([X @ eu, X @ ev], axis=-1)
    wn = X @ n
    if not (np.all(np.isfinite(uv)) and np.all(np.isfinite(wn))):
        raise ValueError("top_points: too large for the average-plane frame (its coordinates overflow)")

    if edge_band_m is None:
        dist, _ = cKDTree(uv).query(uv, k=2)
        band = float(np.median(dist[:, 1]))
    else:
        band = float(edge_band_m)
        if not (np.isfinite(band) and band >= 0):
            raise ValueError(f"edge_band_m: must be a finite number >= 0, got {edge_band_m!r}")

    h = grid_spacing(float(np.max(np.ptp(uv, axis=0))), spacing_m)
    if method == "cubic":
        tri = Delaunay(uv)
        interp = CloughTocher2DInterpolator(tri, wn)
        ua = _axis(uv[:, 0].min(), uv[:, 0].max(), h)
        va = _axis(uv[:, 1].min(), uv[:, 1].max(), h)
        U, V = np.meshgrid(ua, va)  # (nv, nu)
        W = interp(U, V)
        gv, gu = _fd_gradient(W, h, h)
        alpha = np.arctan(np.hypot(gu, gv))
        dist_b = _hull_distance(uv, np.stack([U.ravel(), V.ravel()], -1)).reshape(U.shape)
        Up, Vp = U, V
    elif method == "spline":
        N = nodes_per_side if nodes_per_side is not None else int(round(np.sqrt(x.shape[0])))
        if N * N != x.shape[0]:
            raise ValueError(
                f"nodes_per_side: {N}^2 != number of top_points ({x.shape[0]}); method='spline' needs an N x N grid"
            )
        if N < 4:
            raise ValueError(f"nodes_per_side: bicubic spline needs N >= 4, got {N}")
        ug = uv[:, 0].reshape(N, N)  # [j, i]
        vg = uv[:, 1].reshape(N, N)
        wg = wn.reshape(N, N)
        s = ug.mean(axis=0)  # along i
        t = vg.mean(axis=1)  # along j
        if not (np.all(np.diff(s) > 0) and np.all(np.diff(t) > 0)):
            raise ValueError(
                "top_points: not an N x N grid in j-major order (index j*N + i, i along body "
                "x1, j along body y1), or too distorted for method='spline'"
            )
        sa = _axis(s[0], s[-1], h)
        ta = _axis(t[0], t[-1], h)
        spl = [RectBivariateSpline(t, s, g, kx=3, ky=3, s=0) for g in (ug, vg, wg)]
        r_s = np.stack([f(ta, sa, dy=1) for f in spl], axis=-1)  # (nt, ns, 3)
        r_t = np.stack([f(ta, sa, dx=1) for f in spl], axis=-1)
        Nrm = np.cross(r_s, r_t)
        alpha = np.arctan2(np.hypot(Nrm[..., 0], Nrm[..., 1]), np.abs(Nrm[..., 2]))
        W = spl[2](ta, sa)
        Up = spl[0](ta, sa)
        Vp = spl[1](ta, sa)
        ua, va = sa, ta
        S, Tg = np.meshgrid(sa, ta)
        dist_b = np.minimum.reduce([S - s[0], s[-1] - S, Tg - t[0], t[-1] - Tg])
    else:
        raise ValueError(f"method: expected 'cubic' or 'spline', got {method!r}")

    edge = (dist_b <= band + 1e-12 * max(1.0, band)) & np.isfinite(alpha)
    med, p95, amax, emax = _stats(alpha, edge)
    return SurfaceAngle(
        u=ua,
        v=va,
        alpha=alpha,
        w=W,
        u_points=Up,
        v_points=Vp,
        edge_mask=edge,
        median=med,
        p95=p95,
        max=amax,
        edge_max=emax,
        edge_band_m=band,
        method=method,
        centroid=c,
        normal=n,
        e_u=eu,
        e_v=ev,
        spacing_m=h,
    )


@dataclass(frozen=True)
class CellSurfaceAngle:
    """Result of :func:`cell_surface_angle`: ``alpha`` ``(N−1, N−1)`` angle of every top-layer cell
    [rad] (index ``[j, i]``), ``edge_mask`` True on the outer ring of cells; ``median``, ``p95``,
    ``max``, ``edge_max`` their statistics [rad]."""

    alpha: np.ndarray = field(repr=False)
    edge_mask: np.ndarray = field(repr=False)
    median: float
    p95: float
    max: float
    edge_max: float


def cell_surface_angle(top_points: np.ndarray, R_body: np.ndarray, *, nodes_per_side: int) -> CellSurfaceAngle:
    """Angle of every top-layer cell's own plane to the average plane (no fit; module docstring).

    Args:
      top_points: ``(N², 3)`` top-layer node positions [m], j-major (index ``j N + i``).
      R_body: ``(3, 3)`` best-fit body-to-world rotation at the same time (orients the normal).
      nodes_per_side: ``N`` (≥ 2).

    Returns:
      :class:`CellSurfaceAngle` (radians).
    """
    x = as_points(top_points, "top_points", min_points=4)
    N = int(nodes_per_side)
    if N < 2 or N * N != x.shape[0]:
        raise ValueError(f"nodes_per_side: {N}^2 must equal the number of top_points ({x.shape[0]}), N >= 2")
    if not np.all(np.isfinite(x)):
        raise ValueError("top_points: contains NaN or Inf")
    c, n, eu, ev = plane_frame(x, R_body)
    g = ((x - c) @ np.stack([eu, ev, n], axis=1)).reshape(N, N, 3)  # [j, i, (u, v, w)]
    a = 0.5 * (g[:-1, 1:] - g[:-1, :-1] + g[1:, 1:] - g[1:, :-1])
    b = 0.5 * (g[1:, :-1] - g[:-1, :-1] + g[1:, 1:] - g[:-1, 1:])
    Nrm = np.cross(a, b)
    alpha = np.arctan2(np.hypot(Nrm[..., 0], Nrm[..., 1]), np.abs(Nrm[..., 2]))
    edge = np.zeros(alpha.shape, dtype=bool)
    edge[[0, -1], :] = True
    edge[:, [0, -1]] = True
    med, p95, amax, emax = _stats(alpha, edge)
    return CellSurfaceAngle(alpha=alpha, edge_mask=edge, median=med, p95=p95, max=amax, edge_max=emax)
