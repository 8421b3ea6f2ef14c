"""Conducting paths built into the two-layer truss, pure NumPy.

A **circuit** L carries one current I_L. It is a set of directed unit segments (a → b) over
axis-aligned lattice edges (x-edges, y-edges, verticals), each with an integer multiplicity
``mult``. The generator walks the wire along its path; afterwards opposite passes
over the same strut cancel, each strut keeps one segment oriented along the net current
(``mult > 0``), and struts whose passes cancel completely are dropped. The physical wire,
cancelled passes included, is kept as ``wire_src, wire_dst, wire_count`` (it sets the wire
length of the reconstructed Table 1, the mass and the resistance).

Notation: ``n`` units (cubes) per side, node ``(i, j, ℓ)`` with ``i, j ∈ {0..n}`` and
``ℓ ∈ {0 = bottom, 1 = top}``, flat index ``ℓ (n+1)² + j (n+1) + i`` (the lattice generator's
order), reference position ``(−D/2 + i w, −D/2 + j w, (ℓ − ½) w)`` with ``w = D/n``.

Vector area (exact for straight segments, on any node positions, body or world frame)::

    a_L = ½ Σ_(a→b) mult · r_a × r_b            [m²],     m_L = I_L a_L   [A m²]

Sign convention: a positive current gives a dipole along the circuit's positive axis; every
sub-loop winds counter-clockwise seen from that axis' tip.

Geometries:

* ``A``  — one perimeter loop on the top layer (+z).
* ``B``  — ⌈n/2⌉ concentric rings [k, n−k]², top layer for even k, bottom for odd k (+z).
* ``C_x``/``C_y`` — one D × w loop in every lattice plane normal to x / y, n+1 in series.
* ``D_x``/``D_y`` — one continuous winding: ¾ turn per lattice plane, a unit step to the next
  plane, closure around the last plane and a return on one layer. The paper does not say how the
  winding is closed; ``d_return`` chooses the return (:data:`D_RETURNS`):

  - ``"centre"`` (default): along the plate's middle line, index c = ⌈n/2⌉ (D_x on the bottom
    layer at y = y_c, D_y on the top layer at x = x_c). The area along the plate normal is then
    exactly zero; the in-plane parasitic component (along y for D_x) is s w², s the number of
    unit steps on the top layer (about D²/(2n)).
  - ``"edge"``: straight along the plate edge at index 0 on the same layer (D_x: y = 0, bottom;
    D_y: x = 0, top). Against ``"centre"`` it adds the rectangle n × c w² on that layer, a normal
    area of −n c w² for D_x and +n c w² for D_y (about D²/2).
  - ``"other_layer"``: the middle-line return on the other layer, reached by one vertical at each
    end of the middle line. Against ``"centre"`` it adds the D × w rectangle in the plane of the
    middle line, −n w² along the in-plane parasitic axis (D_x: along y, D_y: along x): that
    component becomes (s − n) w², about the opposite of the centre return's.

  D_y is D_x turned half a turn about the plate's diagonal x = y, node (i, j, ℓ) → (j, i, 1 − ℓ),
  for every return: a_(D_y) = (a_y, a_x, −a_z) of D_x.
* ``F``  — B + D_x + D_y (three circuits); the section-5 set is ``["C_x", "C_y", "B"]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from math import ceil
from typing import Iterable, Literal, Sequence, get_args

import numpy as np

from magsail_mj.lattice.geometry import STRUT_KINDS, Lattice

__all__ = [
    "CIRCUIT_NAMES",
    "AXIS_OF",
    "Circuit",
    "circuit",
    "circuits",
    "circuit_from_path",
    "SECTION5_SET",
    "D_RETURNS",
    "DReturn",
    "expand_names",
]

#: Names accepted by :func:`circuit`.
CIRCUIT_NAMES = ("A", "B", "C_x", "C_y", "D_x", "D_y")
#: Dipole axis (0 = x, 1 = y, 2 = z) of each circuit.
AXIS_OF = {"A": 2, "B": 2, "C_x": 0, "C_y": 1, "D_x": 0, "D_y": 1}
#: Composite names accepted by :func:`circuits`.
COMPOSITES = {"F": ("B", "D_x", "D_y")}
#: The three-axis set (x, y, z).
SECTION5_SET = ("C_x", "C_y", "B")
#: How the D winding is closed (see the module docstring); ``"centre"`` is the default.
DReturn = Literal["centre", "edge", "other_layer"]
D_RETURNS: tuple[str, ...] = get_args(DReturn)

_AXIS_KINDS = tuple(STRUT_KINDS.index(k) for k in ("x_edge", "y_edge", "vertical"))


@dataclass(frozen=True)
class Circuit:
    """One circuit: directed unit segments with multiplicities, and the wire that makes them.

    Attributes:
      name: geometry name (``"A"``, ``"B"``, ``"C_x"`` …).
      axis: dipole axis, 0/1/2 = x/y/z (a positive current gives a dipole along +axis).
      src, dst: (S,) int node indices of the net-current segments (a → b).
      mult: (S,) int multiplicities, all ≥ 1 (net passes a → b over that strut).
      wire_src, wire_dst: (W,) int node indices of every strut the wire runs on (any
        orientation), including struts whose passes cancel.
      wire_count: (W,) int number of wire passes over that strut.
    """

    name: str
    axis: int
    src: np.ndarray
    dst: np.ndarray
    mult: np.ndarray
    wire_src: np.ndarray
    wire_dst: np.ndarray
    wire_count: np.ndarray

    @property
    def n_segments(self) -> int:
        return int(self.src.size)

    def vector_area(self, pos: np.ndarray) -> np.ndarray:
        """a_L = ½ Σ mult r_a × r_b [m²] for node positions ``pos`` (n_nodes, 3) [m].

        Exact for straight segments and independent of the origin (the circuit is closed); works
        on deformed positions.
        """
        pos = np.asarray(pos, dtype=float)
        return 0.5 * (self.mult[:, None] * np.cross(pos[self.src], pos[self.dst])).sum(axis=0)

    def length(self, pos: np.ndarray) -> float:
        """Wire length Σ passes · |r_b − r_a| [m] (cancelled passes included)."""
        pos = np.asarray(pos, dtype=float)
        d = pos[self.wire_dst] - pos[self.wire_src]
        return float((self.wire_count * np.linalg.norm(d, axis=1)).sum())

    def net_length(self, pos: np.ndarray) -> float:
        """Length of conductor carrying net current, Σ mult · |r_b − r_a| [m]."""
        pos = np.asarray(pos, dtype=float)
        d = pos[self.dst] - pos[self.src]
        return float((self.mult * np.linalg.norm(d, axis=1)).sum())

    def strut_index(self, lattice: Lattice) -> np.ndarray:
        """(S,) index into ``lattice.struts`` of the strut under each segment.

        Raises ValueError when a segment joins two nodes that no strut joins.
        """
        return _strut_lookup(lattice, self.src, self.dst)

    def net_flow(self, n_nodes: int) -> np.ndarray:
        """(n_nodes,) out-flow − in-flow at every node (zero for a closed circuit), in units of I."""
        return np.bincount(self.src, weights=self.mult, minlength=n_nodes) - np.bincount(
            self.dst, weights=self.mult, minlength=n_nodes
        )


def _strut_lookup(lattice: Lattice, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    n = lattice.n_nodes
    s = lattice.struts
    keys = np.minimum(s[:, 0], s[:, 1]) * n + np.maximum(s[:, 0], s[:, 1])
    order = np.argsort(keys)
    q = np.minimum(a, b) * n + np.maximum(a, b)
    at = np.clip(np.searchsorted(keys[order], q), 0, keys.size - 1)
    found = keys[order][at] == q
    if not np.all(found):
        k = int(np.flatnonzero(~found)[0])
        raise ValueError(f"segment {int(a[k])} -> {int(b[k])}: no lattice strut joins these nodes")
    return order[at]


def circuit_from_path(name: str, axis: int, corners: Sequence[tuple[int, int, int]], *, units: int) -> Circuit:
    """Build a :class:`Circuit` from a wire path given by its corner points.

    ``corners`` is a sequence of paths, each a list of integer nodes ``(i, j, ℓ)``; consecutive
    corners must differ in one coordinate only (a straight run along x, y or z). The path is cut
    into unit segments, opposite passes over a strut cancel, and the result is oriented along
    the net current.
    """
    if axis not in (0, 1, 2):
        raise ValueError(f"axis: must be 0, 1 or 2, got {axis!r}")
    N = units + 1
    a_list: list[np.ndarray] = []
    b_list: list[np.ndarray] = []
    for path in corners:
        for p, q in zip(path[:-1], path[1:]):
            p, q = np.asarray(p, dtype=np.int64), np.asarray(q, dtype=np.int64)
            diff = q - p
            moving = np.flatnonzero(diff)
            if moving.size != 1:
                raise ValueError(
                    f"corners: run {tuple(p)} -> {tuple(q)} of circuit {name!r} is not "
                    "a straight run along one lattice axis"
                )
            ax = int(moving[0])
            steps = int(abs(diff[ax]))
            unit = np.zeros(3, dtype=np.int64)
            unit[ax] = np.sign(diff[ax])
            k = np.arange(steps)[:, None]
            a_list.append(p + k * unit)
            b_list.append(p + (k + 1) * unit)
    A = np.concatenate(a_list)
    Bn = np.concatenate(b_list)
    hi = np.array([units, units, 1])
    for arr in (A, Bn):
        if np.any(arr < 0) or np.any(arr > hi):
            raise ValueError(f"corners: circuit {name!r} leaves the lattice (units={units})")

    def flat(ijk: np.ndarray) -> np.ndarray:
        return ijk[:, 2] * N * N + ijk[:, 1] * N + ijk[:, 0]

    a, b = flat(A), flat(Bn)
    lo, hi_ = np.minimum(a, b), np.maximum(a, b)
    sign = np.where(a < b, 1, -1)
    n_nodes = 2 * N * N
    key = lo * n_nodes + hi_
    uniq, inv = np.unique(key, return_inverse=True)
    net = np.bincount(inv, weights=sign).astype(np.int64)
    passes = np.bincount(inv).astype(np.int64)
    u_lo, u_hi = uniq // n_nodes, uniq % n_nodes
    keep = net != 0
    src = np.where(net > 0, u_lo, u_hi)[keep]
    dst = np.where(net > 0, u_hi, u_lo)[keep]
    mult = np.abs(net[keep])
    out = Circuit(
        name=name, axis=int(axis), src=src, dst=dst, mult=mult, wire_src=u_lo, wire_dst=u_hi, wire_count=passes
    )
    for arr in (out.src, out.dst, out.mult, out.wire_src, out.wire_dst, out.wire_count):
        arr.setflags(write=False)
    return out


def _ring(k: int, n: int, layer: int) -> list[tuple[int, int, int]]:
    """Counter-clockwise (about +z) square ring [k, n−k]² on ``layer``."""
    lo, hi = k, n - k
    return [(lo, lo, layer), (hi, lo, layer), (hi, hi, layer), (lo, hi, layer), (lo, lo, layer)]


def _paths_A(n: int) -> list[list[tuple[int, int, int]]]:
    return [_ring(0, n, 1)]


def _paths_B(n: int) -> list[list[tuple[int, int, int]]]:
    return [_ring(k, n, 1 if k % 2 == 0 else 0) for k in range(ceil(n / 2))]


def _paths_C(n: int, axis: int) -> list[list[tuple[int, int, int]]]:
    if axis == 0:  # loops in the yz planes x = x_i
        return [[(i, 0, 0), (i, n, 0), (i, n, 1), (i, 0, 1), (i, 0, 0)] for i in range(n + 1)]
    # loops in the xz planes y = y_j
    return [[(0, j, 1), (n, j, 1), (n, j, 0), (0, j, 0), (0, j, 1)] for j in range(n + 1)]


def _paths_D(n: int, axis: int, d_return: str = "centre") -> list[list[tuple[int, int, int]]]:
    """One continuous winding as a single closed path of corner points.

    The helix and its closure end at the start corner of the last plane; ``d_return`` (checked by
    :func:`circuit`) chooses the run back to the start corner of the first plane (module docstring).
    """
    half = ceil(n / 2)
    if axis == 0:

        def corner(k: int, c: int) -> tuple[int, int, int]:
            return ((k, 0, 0), (k, n, 0), (k, n, 1), (k, 0, 1))[c]

        returns = {  # from (n, 0, 0) to (0, 0, 0)
            "centre": [(n, half, 0), (0, half, 0), (0, 0, 0)],  # bottom layer, y = y_c
            "edge": [(0, 0, 0)],  # bottom layer, y = 0
            "other_layer": [(n, half, 0), (n, half, 1), (0, half, 1), (0, half, 0), (0, 0, 0)],
        }
    else:

        def corner(k: int, c: int) -> tuple[int, int, int]:
            return ((0, k, 1), (n, k, 1), (n, k, 0), (0, k, 0))[c]

        returns = {  # from (0, n, 1) to (0, 0, 1)
            "centre": [(half, n, 1), (half, 0, 1), (0, 0, 1)],  # top layer, x = x_c
            "edge": [(0, 0, 1)],  # top layer, x = 0
            "other_layer": [(half, n, 1), (half, n, 0), (half, 0, 0), (half, 0, 1), (0, 0, 1)],
        }
    path = [corner(0, 0)]
    c = 0
    for k in range(n + 1):
        for _ in range(3):
            c = (c + 1) % 4
            path.append(corner(k, c))
        if k < n:
            path.append(corner(k + 1, c))  # unit step along +axis
    while c != 0:  # closure: (n+1) mod 4 sides
        c = (c + 1) % 4
        path.append(corner(n, c))
    path.extend(returns[d_return])
    return [path]


def circuit(lattice: Lattice, name: str, *, d_return: DReturn = "centre") -> Circuit:
    """The circuit ``name`` (one of :data:`CIRCUIT_NAMES`) on ``lattice``.

    ``d_return`` (one of :data:`D_RETURNS`) closes the D windings; the other geometries ignore it.
    """
    if name not in CIRCUIT_NAMES:
        raise ValueError(f"name: must be one of {CIRCUIT_NAMES}, got {name!r}")
    if d_return not in D_RETURNS:
        raise ValueError(f"d_return: must be one of {D_RETURNS}, got {d_return!r}")
    n = lattice.units
    if name == "A":
        paths = _paths_A(n)
    elif name == "B":
        paths = _paths_B(n)
    elif name.startswith("C_"):
        paths = _paths_C(n, AXIS_OF[name])
    else:
        paths = _paths_D(n, AXIS_OF[name], d_return)
    c = circuit_from_path(name, AXIS_OF[name], paths, units=n)
    c.strut_index(lattice)  # every segment must lie on a lattice strut
    return c


def expand_names(names: Iterable[str]) -> list[str]:
    """Expand composites (``"F"`` → B, D_x, D_y); reject unknown and repeated names."""
    if isinstance(names, str):
        names = [names]
    out: list[str] = []
    for nm in names:
        parts = COMPOSITES.get(nm, (nm,))
        for p in parts:
            if p not in CIRCUIT_NAMES:
                raise ValueError(f"names: {nm!r} is not a circuit; allowed: {CIRCUIT_NAMES + tuple(COMPOSITES)}")
            if p in out:
                raise ValueError(f"names: circuit {p!r} appears twice in {list(names)!r}")
            out.append(p)
    if not out:
        raise ValueError("names: must name at least one circuit, got none")
    return out


def circuits(lattice: Lattice, names: Iterable[str], *, d_return: DReturn = "centre") -> list[Circuit]:
    """Circuits for ``names`` (``"F"`` expands to B, D_x, D_y), in the order given; ``d_return``
    closes the D windings (:func:`circuit`)."""
    return [circuit(lattice, nm, d_return=d_return) for nm in expand_names(names)]
