r"""Conducting paths of the gossamer reflector: node lists, pure NumPy.

Structure frame: origin at the plate centre (= centre of mass), ``x``, ``y`` in the
lattice plane, ``z`` along the plate normal. The lattice of side ``d`` is made of cubic cells of
edge ``L``, one cell deep (assumption A1, ``h = L``): nodes at ``x = −d/2 + iL``,
``y = −d/2 + jL``, ``z = ±h/2``. Every path runs along lattice members, so each segment is one
member of length ``L`` (``h`` for the vertical ones).

Paths (each an ``(K, 3)`` node array, ``K − 1`` segments, metres):

* :func:`coil_y` — the serpentine square helix with axis ‖ y (normative pseudo-code):
  three quarters of a turn in a plane ‖ xz, a one-cell step in ``y``, repeated; columns of
  pitch ``p`` cells, run alternately towards +y and −y, joined by connectors along +x. Current
  along the node order gives an axial dipole along **−y** (one turn: ½∮ r × dr = −L h ŷ), so the
  path carries ``s_path = −1``.
* :func:`coil_x` — the same list rotated by +90° about z, ``(x, y, z) → (−y, x, z)``;
  its node order gives +x, ``s_path = +1``.
* :func:`square_loop` — a lattice-aligned closed square loop in the plane ``z = −h/2``,
  centred on the origin, run counter-clockwise seen from +z (dipole along +z, ``s_path = +1``),
  used for the in-plane loop (sized by A3, see :mod:`magsail_mj.analysis.coil_torque`) and the
  perimeter loop.

The sign ``s_path`` defines each path's positive current as the one giving a dipole along the
path's +axis; forces are built with the physical node-order current ``s_path · I``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CoilPath", "coil_y", "coil_x", "square_loop", "coil_node_count", "reflector_paths"]


@dataclass(frozen=True)
class CoilPath:
    """A conducting path: its nodes, its actuation axis and its current sign.

    Attributes:
      name: label (``"ycoil"``, ``"xcoil"``, ``"zloop"``, …).
      nodes: (K, 3) node positions relative to the centre of mass, structure frame [m].
      axis: index of the axis (0 = x, 1 = y, 2 = z) along which the path's dipole points.
      s_path: +1 or −1: the node-order current is ``s_path · I`` for a dipole along +axis.
    """

    name: str
    nodes: np.ndarray
    axis: int
    s_path: int

    @property
    def segment_count(self) -> int:
        return int(self.nodes.shape[0] - 1)

    @property
    def length_m(self) -> float:
        """Total conductor length Σ|L_i| [m]."""
        return float(np.linalg.norm(np.diff(self.nodes, axis=0), axis=1).sum())


def _check_lattice(d: float, L: float, h: float | None) -> tuple[int, float]:
    if not (np.isfinite(L) and L > 0):
        raise ValueError(f"segment_m: must be > 0 m, got {L!r}")
    if not (np.isfinite(d) and d > 0):
        raise ValueError(f"side_m: must be > 0 m, got {d!r}")
    n = round(d / L)
    if n < 1 or abs(n * L - d) > 1e-9 * d:
        raise ValueError(f"side_m: must be a whole multiple of segment_m = {L!r} m, got {d!r}")
    h = L if h is None else float(h)
    if not (np.isfinite(h) and h > 0):
        raise ValueError(f"depth_m: must be > 0 m, got {h!r}")
    return int(n), h


def coil_y(d: float, L: float, h: float | None = None, *, p: int = 2, n_row: int | None = None) -> np.ndarray:
    r"""Node list of the y-axis serpentine coil (the normative pseudo-code).

    Cross-section corners of a column with left edge ``X`` (coordinates (x, z)), in traversal
    order: C0 = (X, −h/2), C1 = (X+L, −h/2), C2 = (X+L, +h/2), C3 = (X, +h/2). A three-quarter
    turn from corner ``c`` visits c, c+1, c+2, c+3 (mod 4) at fixed ``y``; then the path steps one
    row in ``y`` at corner c+3, which starts the next turn (``c ← c+3 mod 4``). Column ``j`` has
    ``X_j = −d/2 + j p L``; even columns run towards +y over rows ``k = 0 … n_row−1``
    (``y_k = −d/2 + kL``), odd columns back. Between columns a connector of ``p`` segments runs
    along +x at the current corner. First node (−d/2, −d/2, −h/2).

    Args:
      d: side length [m] (a whole multiple of ``L``).
      L: segment length = cell edge [m].
      h: lattice depth [m] (default ``L``, assumption A1).
      p: column pitch in cells (baseline 2, A2; 1 = dense routing sharing vertical members).
      n_row: three-quarter turns per column (default ``n = d/L``; ``n + 1`` uses every row plane).

    Returns:
      (K, 3) nodes [m], ``K = 4 N_col N_row + (N_col − 1)(p − 1)`` with ``N_col = n // p``.
    """
    n, h = _check_lattice(d, L, h)
    if int(p) != p or p < 1:
        raise ValueError(f"pitch_cells: must be an integer >= 1, got {p!r}")
    p = int(p)
    n_row = n if n_row is None else n_row
    if int(n_row) != n_row or not 1 <= n_row <= n + 1:
        raise ValueError(f"rows: must be an integer in [1, {n + 1}] (n + 1 row planes), got {n_row!r}")
    n_row = int(n_row)
    n_col = n // p
    if n_col < 1:
        raise ValueError(f"pitch_cells: {p} exceeds the {n} cells per side")
    corner = [(0.0, -h / 2), (L, -h / 2), (L, +h / 2), (0.0, +h / 2)]  # (dx, z) offsets
    pts: list[tuple[float, float, float]] = []
    c = 0
    for j in range(n_col):
        X = -d / 2 + j * p * L
        rows = list(range(n_row)) if j % 2 == 0 else list(reversed(range(n_row)))
        if j > 0:  # connector along +x
            dx, z = corner[c]
            y = -d / 2 + rows[0] * L
            for s in range(1, p + 1):
                pts.append((X - p * L + dx + s * L, y, z))
        for i, k in enumerate(rows):
            y = -d / 2 + k * L
            for s in range(4):  # 3/4 turn: 4 nodes, 3 segments
                dx, z = corner[(c + s) % 4]
                P = (X + dx, y, z)
                if not pts or pts[-1] != P:
                    pts.append(P)
            c = (c + 3) % 4
            if i < n_row - 1:  # step in y
                dx, z = corner[c]
                y2 = -d / 2 + rows[i + 1] * L
                pts.append((X + dx, y2, z))
    return np.asarray(pts, dtype=float)


def coil_node_count(n: int, *, p: int = 2, n_row: int | None = None) -> int:
    """Expected node count ``4·N_col·N_row + (N_col − 1)(p − 1)`` for ``n`` cells per side."""
    n_row = n if n_row is None else n_row
    n_col = n // p
    return 4 * n_col * n_row + (n_col - 1) * (p - 1)


def coil_x(d: float, L: float, h: float | None = None, *, p: int = 2, n_row: int | None = None) -> np.ndarray:
    """The x-axis coil: :func:`coil_y` rotated by +90° about z, ``(x, y, z) → (−y, x, z)``."""
    y = coil_y(d, L, h, p=p, n_row=n_row)
    return np.column_stack([-y[:, 1], y[:, 0], y[:, 2]])


def square_loop(side: float, L: float, *, z: float, d: float | None = None) -> np.ndarray:
    """Closed lattice-aligned square loop of side ``side`` centred on the origin, plane ``z``.

    Runs counter-clockwise seen from +z (vector area +side² ẑ, dipole along +z), starting and
    ending at the corner (−side/2, −side/2, z); every segment has length ``L``.

    Args:
      side: loop side [m]; ``side/2`` must be a whole multiple of ``L`` so that the corners are
        lattice nodes of a lattice whose nodes include the origin's row/column (even ``d/L``).
      L: segment length [m].
      z: plane of the loop [m] (``−h/2`` for the in-plane loop).
      d: structure side [m]; when given, the loop must fit inside it.

    Returns:
      (4·side/L + 1, 3) nodes [m], first = last.
    """
    if not (np.isfinite(L) and L > 0):
        raise ValueError(f"segment_m: must be > 0 m, got {L!r}")
    k = round(side / (2 * L))
    if k < 1 or abs(2 * k * L - side) > 1e-9 * max(side, L):
        raise ValueError(f"side: must be a positive even multiple of segment_m = {L!r} m, got {side!r}")
    if d is not None and side > d * (1 + 1e-12):
        raise ValueError(f"side: the loop ({side!r} m) must fit in the structure (side_m = {d!r} m)")
    m = 2 * k
    s = np.arange(m) * L - side / 2  # m steps per edge
    e = np.full(m, side / 2)
    xs = np.concatenate([s, e, -s, -e, [-side / 2]])
    ys = np.concatenate([-e, s, e, -s, [-side / 2]])
    return np.column_stack([xs, ys, np.full(xs.size, float(z))])


def reflector_paths(
    d: float, L: float, h: float | None = None, *, p: int = 2, n_row: int | None = None, zloop_side: float | None = None
) -> dict[str, CoilPath]:
    """The baseline set of paths: y-coil, x-coil and (if ``zloop_side``) the in-plane loop."""
    n, h = _check_lattice(d, L, h)
    out = {
        "ycoil": CoilPath("ycoil", coil_y(d, L, h, p=p, n_row=n_row), axis=1, s_path=-1),
        "xcoil": CoilPath("xcoil", coil_x(d, L, h, p=p, n_row=n_row), axis=0, s_path=+1),
    }
    if zloop_side is not None:
        out["zloop"] = CoilPath("zloop", square_loop(zloop_side, L, z=-h / 2, d=d), axis=2, s_path=+1)
    return out
