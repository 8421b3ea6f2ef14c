"""Two-layer cubic truss lattice (pure NumPy).

Robb et al. 2022a. A square plate of side ``d`` made of ``n`` × ``n`` cubic
units (``N = n + 1`` nodes per side, two node layers, ``2 N²`` nodes; the
paper's "20 units" count nodes per side, i.e. ``n = 19`` cubes). Cube edge ``a = d / n``.

Node ``(i, j, k)``, ``i, j ∈ {0..N-1}``, ``k ∈ {0 (bottom), 1 (top)}`` has flat index
``k N² + j N + i`` and reference body-frame position
``p = (i a − d/2, j a − d/2, (k − ½) a)`` (origin at the undeformed centre of mass for uniform
masses; x1 along i, y1 along j, z1 = plate normal, bottom → top).

Struts: every cube edge, plus one diagonal on every square face joining the
two corners with even ``i + j + k`` (``diagonals="parity"``), or both diagonals
(``diagonals="X"``). The strut table is built once; every strut has its kind, its rest length
and its spring constant ``k_s = EA / l0_s``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Literal

import numpy as np
from scipy import sparse

__all__ = [
    "STRUT_KINDS",
    "Lattice",
    "make_lattice",
    "axial_rigidity_from_EI",
    "stiffness_matrix",
    "node_index",
    "strain_check",
]

# Strut kinds, in the order they are generated.
STRUT_KINDS = (
    "x_edge",  # (i,j,k)-(i+1,j,k)
    "y_edge",  # (i,j,k)-(i,j+1,k)
    "vertical",  # (i,j,0)-(i,j,1)
    "xy_diagonal",  # diagonal of a top/bottom face
    "xz_diagonal",  # diagonal of a vertical face in the x1-z1 plane
    "yz_diagonal",  # diagonal of a vertical face in the y1-z1 plane
)


def node_index(i, j, k, nodes_per_side: int):
    """Flat node index ``k N² + j N + i`` (works on arrays)."""
    N = nodes_per_side
    return np.asarray(k) * N * N + np.asarray(j) * N + np.asarray(i)


@dataclass(frozen=True)
class Lattice:
    """Geometry, strut table and mass of a two-layer truss.

    Attributes:
      units: cubes per side ``n``.
      side_m: plate side ``d`` [m].
      diagonals: ``"parity"`` or ``"X"``.
      nodes: (2N², 3) reference body-frame positions [m].
      struts: (S, 2) node indices ``(a, b)``; for edges ``b`` has the larger i/j/k index.
      kind: (S,) index into :data:`STRUT_KINDS`.
      rest_length: (S,) undeformed lengths ``l0`` [m].
      ijk: (2N², 3) integer node coordinates.
    """

    units: int
    side_m: float
    diagonals: str
    nodes: np.ndarray
    struts: np.ndarray
    kind: np.ndarray
    rest_length: np.ndarray
    ijk: np.ndarray
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def nodes_per_side(self) -> int:
        return self.units + 1

    @property
    def cube_edge_m(self) -> float:
        return self.side_m / self.units

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def n_struts(self) -> int:
        return self.struts.shape[0]

    @property
    def top_nodes(self) -> np.ndarray:
        """Indices of the top layer (k = 1), ordered j-major (index j N + i within the layer)."""
        N = self.nodes_per_side
        return np.arange(N * N, 2 * N * N)

    @property
    def bottom_nodes(self) -> np.ndarray:
        N = self.nodes_per_side
        return np.arange(N * N)

    def struts_of_kind(self, name: str, *, layer: int | None = None) -> np.ndarray:
        """Indices of struts of kind ``name`` (optionally only those in layer ``k``)."""
        if name not in STRUT_KINDS:
            raise ValueError(f"name: must be one of {STRUT_KINDS}, got {name!r}")
        sel = self.kind == STRUT_KINDS.index(name)
        if layer is not None:
            k = self.ijk[self.struts[:, 0], 2]
            sel &= (k == layer) & (self.ijk[self.struts[:, 1], 2] == layer)
        return np.flatnonzero(sel)

    def find_strut(self, a: int, b: int) -> int:
        """Index of the strut joining nodes ``a`` and ``b`` (either order)."""
        key = self._cache.get("pairs")
        if key is None:
            key = {tuple(sorted(s)): n for n, s in enumerate(self.struts.tolist())}
            self._cache["pairs"] = key
        try:
            return key[tuple(sorted((int(a), int(b))))]
        except KeyError:
            raise ValueError(f"no strut joins nodes {a} and {b}") from None

    def cube_corner_nodes(self) -> np.ndarray:
        """(n², 8) node indices of every cube: corners ordered (di, dj, dk) binary, di fastest."""
        n, N = self.units, self.nodes_per_side
        i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="xy")
        i, j = i.ravel(), j.ravel()
        cols = []
        for dk in (0, 1):
            for dj in (0, 1):
                for di in (0, 1):
                    cols.append(node_index(i + di, j + dj, dk, N))
        return np.stack(cols, axis=1)

    def cube_tetrahedra(self) -> np.ndarray:
        """(5 n², 4) node indices: each cube cut into 5 tetrahedra (for inside-out checks).

        The signed volume of each, in the order given, is positive in the undeformed lattice.
        """
        c = self.cube_corner_nodes()
        # corners: 0=(000) 1=(100) 2=(010) 3=(110) 4=(001) 5=(101) 6=(011) 7=(111)
        pattern = np.array([[0, 1, 2, 4], [1, 3, 2, 7], [1, 4, 5, 7], [2, 7, 6, 4], [1, 2, 4, 7]])
        tets = c[:, pattern].reshape(-1, 4)
        p = self.nodes[tets]
        vol = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p[:, 3] - p[:, 0])
        flip = vol < 0
        tets[flip] = tets[flip][:, [0, 2, 1, 3]]
        return tets


def strain_check(lattice: Lattice, *, body_offset: int = 1) -> Callable[[np.ndarray], tuple[float, int]]:
    """The run's divergence check (``Simulation.strain_check``): ``pos`` (nbody, 3) world body
    positions → (largest strut strain |l/l0 − 1|, its strut index); node ``i`` is body
    ``i + body_offset``."""
    a, b = lattice.struts[:, 0] + body_offset, lattice.struts[:, 1] + body_offset
    inv_l0_sq = 1.0 / lattice.rest_length**2

    def check(pos: np.ndarray) -> tuple[float, int]:
        # (l/l0)² of every strut; the largest |l/l0 − 1| is at its largest or smallest value
        r = pos.take(b, axis=0)
        r -= pos.take(a, axis=0)
        ratio2 = np.einsum("ij,ij->i", r, r) * inv_l0_sq
        i_max, i_min = int(np.argmax(ratio2)), int(np.argmin(ratio2))
        stretch, squeeze = math.sqrt(ratio2[i_max]) - 1.0, 1.0 - math.sqrt(ratio2[i_min])
        return (stretch, i_max) if stretch >= squeeze else (squeeze, i_min)

    return check


def make_lattice(*, units: int, side_m: float, diagonals: Literal["parity", "X"] = "parity") -> Lattice:
    """Build the lattice of ``units`` × ``units`` cubes of total side ``side_m``."""
    if int(units) != units or units < 1:
        raise ValueError(f"units: must be an integer >= 1, got {units!r}")
    if not side_m > 0:
        raise ValueError(f"side_m: must be > 0, got {side_m!r}")
    if diagonals not in ("parity", "X"):
        raise ValueError(f"diagonals: must be 'parity' or 'X', got {diagonals!r}")
    n = int(units)
    N = n + 1
    a = side_m / n
    k, j, i = np.meshgrid(np.arange(2), np.arange(N), np.arange(N), indexing="ij")
    ijk = np.stack([i.ravel(), j.ravel(), k.ravel()], axis=1)
    nodes = np.column_stack([ijk[:, 0] * a - side_m / 2, ijk[:, 1] * a - side_m / 2, (ijk[:, 2] - 0.5) * a])

    def idx(ii, jj, kk):
        return node_index(ii, jj, kk, N)

    pairs: list[np.ndarray] = []
    kinds: list[np.ndarray] = []

    def add(kind: str, p0: np.ndarray, p1: np.ndarray) -> None:
        pairs.append(np.stack([p0, p1], axis=1))
        kinds.append(np.full(p0.size, STRUT_KINDS.index(kind)))

    # Cube edges.
    kk, jj, ii = (g.ravel() for g in np.meshgrid(np.arange(2), np.arange(N), np.arange(n), indexing="ij"))
    add("x_edge", idx(ii, jj, kk), idx(ii + 1, jj, kk))
    kk, jj, ii = (g.ravel() for g in np.meshgrid(np.arange(2), np.arange(n), np.arange(N), indexing="ij"))
    add("y_edge", idx(ii, jj, kk), idx(ii, jj + 1, kk))
    jj, ii = (g.ravel() for g in np.meshgrid(np.arange(N), np.arange(N), indexing="ij"))
    add("vertical", idx(ii, jj, 0), idx(ii, jj, 1))

    both = diagonals == "X"

    def face_diagonals(kind: str, c00, c11, c10, c01, parity_of_c00) -> None:
        """A face with corners c00,c10,c01,c11: diagonal c00-c11 or c10-c01 by parity."""
        even = parity_of_c00 % 2 == 0
        if both:
            add(kind, c00, c11)
            add(kind, c10, c01)
        else:
            add(kind, np.where(even, c00, c10), np.where(even, c11, c01))

    # Top/bottom faces (x-y plane), corners (i,j),(i+1,j+1) vs (i+1,j),(i,j+1).
    kk, jj, ii = (g.ravel() for g in np.meshgrid(np.arange(2), np.arange(n), np.arange(n), indexing="ij"))
    face_diagonals(
        "xy_diagonal", idx(ii, jj, kk), idx(ii + 1, jj + 1, kk), idx(ii + 1, jj, kk), idx(ii, jj + 1, kk), ii + jj + kk
    )
    # Vertical faces in the x-z plane (fixed j): corners (i,k=0),(i+1,k=1) vs (i+1,0),(i,1).
    jj, ii = (g.ravel() for g in np.meshgrid(np.arange(N), np.arange(n), indexing="ij"))
    face_diagonals("xz_diagonal", idx(ii, jj, 0), idx(ii + 1, jj, 1), idx(ii + 1, jj, 0), idx(ii, jj, 1), ii + jj)
    # Vertical faces in the y-z plane (fixed i).
    jj, ii = (g.ravel() for g in np.meshgrid(np.arange(n), np.arange(N), indexing="ij"))
    face_diagonals("yz_diagonal", idx(ii, jj, 0), idx(ii, jj + 1, 1), idx(ii, jj + 1, 0), idx(ii, jj, 1), ii + jj)

    struts = np.concatenate(pairs).astype(np.int64)
    kind = np.concatenate(kinds).astype(np.int8)
    rest = np.linalg.norm(nodes[struts[:, 1]] - nodes[struts[:, 0]], axis=1)
    for arr in (nodes, struts, kind, rest, ijk):
        arr.setflags(write=False)
    return Lattice(
        units=n,
        side_m=float(side_m),
        diagonals=diagonals,
        nodes=nodes,
        struts=struts,
        kind=kind,
        rest_length=rest,
        ijk=ijk,
    )


def axial_rigidity_from_EI(EI_Nm2: float, *, nodes_per_side: int, cube_edge_m: float) -> float:
    """Strut axial rigidity ``EA = 2 EI / (N a²)`` (Eq. 8).

    The plate counts as ``N/2`` four-longeron trusses in parallel, each with
    ``EI_truss = 2 EA R_c²`` and ``R_c = a/√2``.
    """
    return 2.0 * EI_Nm2 / (nodes_per_side * cube_edge_m**2)


def stiffness_matrix(positions: np.ndarray, struts: np.ndarray, k: np.ndarray):
    """Assembled linear stiffness matrix (3n × 3n, scipy.sparse CSR) of axial springs.

    Each strut contributes ``k ê êᵀ`` blocks (ê the unit vector at ``positions``):
    ``+`` on the diagonal blocks, ``−`` on the off-diagonal ones. Unstressed springs only
    (no geometric stiffness), which is the linearisation about the stress-free lattice.
    """
    e = positions[struts[:, 1]] - positions[struts[:, 0]]
    e /= np.linalg.norm(e, axis=1, keepdims=True)
    blocks = np.asarray(k)[:, None, None] * e[:, :, None] * e[:, None, :]  # (S,3,3)
    a, b = struts[:, 0], struts[:, 1]
    r3 = np.arange(3)
    rows, cols, vals = [], [], []
    for p, q, sign in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
        rr = (3 * p[:, None, None] + r3[None, :, None]) + 0 * r3[None, None, :]
        cc = (3 * q[:, None, None] + r3[None, None, :]) + 0 * r3[None, :, None]
        rows.append(rr.ravel())
        cols.append(cc.ravel())
        vals.append(sign * blocks.ravel())
    n = positions.shape[0] * 3
    return sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
