"""Lorentz forces on current-carrying circuits in a uniform field (Eq. 16).

For every directed segment e = (a → b) of circuit L with multiplicity s_e (world frame, SI)::

    f_e = ½ s_e I_L (r_b − r_a) × B        [N],     F_a += f_e,   F_b += f_e

i.e. half of the element force goes to each end node, evaluated on the **current** (deformed)
node positions r [m], with the current I_L [A] and the uniform field B [T] in world axes. For a
closed circuit the node forces sum to zero and their moment is exactly the dipole torque::

    Σ_i F_i = 0,      Σ_i r_i × F_i = Σ_e (r_a + r_b) × f_e = m_L × B,   m_L = I_L a_L,
    a_L = ½ Σ_e s_e r_a × r_b,

for any positions (the terms ½ Σ r_b (r_b·B) − r_a (r_a·B) and |r_b|² − |r_a|² telescope).

Segments of all circuits are stacked once (:class:`CircuitSegments`); each evaluation is a few
array operations and three ``np.bincount`` scatters, with no Python loop over segments.

The self-field of the wires is neglected in the dynamics; :func:`self_field_max_T` is the
diagnostic (Eq. 17).
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from magsail_mj.geometry.current_loops import Circuit

from magsail_mj.loads.base import StepState

__all__ = [
    "MU0",
    "CircuitSegments",
    "lorentz_node_forces",
    "total_dipole",
    "vector_areas",
    "lorentz_wrench",
    "self_field_max_T",
    "LorentzLoad",
]

#: Vacuum permeability [T m / A].
MU0 = 4e-7 * np.pi


class CircuitSegments:
    """The segments of several circuits stacked into flat index arrays (built once).

    Attributes:
      src, dst: (S,) int node indices of every segment (a → b).
      mult: (S,) float multiplicities s_e.
      circuit_id: (S,) int index of the circuit each segment belongs to.
      n_circuits: number of circuits.
      names: circuit names, in order (the order of the ``currents_A`` vectors).
      axes: (n_circuits,) dipole axis of each circuit (0/1/2 = x/y/z).
      n_nodes: 1 + the largest node index used (positions need at least this many rows).
    """

    def __init__(self, circuits: Sequence[Circuit]) -> None:
        circuits = list(circuits)
        if not circuits:
            raise ValueError("circuits: must hold at least one Circuit, got none")
        names = [c.name for c in circuits]
        if len(set(names)) != len(names):
            raise ValueError(f"circuits: names must be unique, got {names}")
        self.circuits = tuple(circuits)
        self.names = tuple(names)
        self.axes = np.array([c.axis for c in circuits], dtype=np.int64)
        self.n_circuits = len(circuits)
        self.src = np.concatenate([c.src for c in circuits]).astype(np.int64)
        self.dst = np.concatenate([c.dst for c in circuits]).astype(np.int64)
        self.mult = np.concatenate([c.mult for c in circuits]).astype(float)
        self.circuit_id = np.concatenate([np.full(c.src.size, k, dtype=np.int64) for k, c in enumerate(circuits)])
        self.n_nodes = int(max(self.src.max(), self.dst.max())) + 1
        # flat (3 node + component) indices: gathers and the scatter work on raveled arrays
        self._src3 = (3 * self.src[:, None] + np.arange(3)[None, :]).ravel()
        self._dst3 = (3 * self.dst[:, None] + np.arange(3)[None, :]).ravel()
        self._flat3 = np.concatenate([self._src3, self._dst3])
        for arr in (self.axes, self.src, self.dst, self.mult, self.circuit_id, self._src3, self._dst3, self._flat3):
            arr.setflags(write=False)

    @property
    def n_segments(self) -> int:
        return int(self.src.size)

    def segment_currents(self, currents_A) -> np.ndarray:
        """(S,) s_e I_L(e) [A] for circuit currents ``currents_A`` (n_circuits,)."""
        I = np.asarray(currents_A, dtype=float).reshape(-1)
        if I.size != self.n_circuits:
            raise ValueError(f"currents_A: need {self.n_circuits} values (circuits {list(self.names)}), got {I.size}")
        return self.mult * I[self.circuit_id]

    def __repr__(self) -> str:
        return f"CircuitSegments(names={list(self.names)}, n_segments={self.n_segments})"


def _field(B) -> np.ndarray:
    B = np.asarray(B, dtype=float)
    if B.shape != (3,):
        raise ValueError(f"B: must be a uniform world-frame vector of 3 components [T], got shape {B.shape}")
    return B


def _positions(pos, segs: CircuitSegments) -> np.ndarray:
    pos = np.asarray(pos, dtype=float)
    if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] < segs.n_nodes:
        raise ValueError(f"pos: must be (n_nodes >= {segs.n_nodes}, 3) node positions [m], got shape {pos.shape}")
    return pos


def lorentz_node_forces(pos, segs: CircuitSegments, currents_A, B) -> np.ndarray:
    """Node forces of Eq. 16, (n_nodes, 3) [N] with n_nodes = ``pos.shape[0]``.

    ``pos``: (n_nodes, 3) current node positions [m]; ``currents_A``: (n_circuits,) [A];
    ``B``: (3,) uniform field in the same axes as ``pos`` [T].

    Since f_e = g_e × B with g_e = ½ s_e I (r_b − r_a), the per-node sum is
    F_i = (Σ_(e ∋ i) g_e) × B: one ``np.bincount`` scatter of g (flat index 3 i + component),
    then one cross product per node.
    """
    pos = _positions(pos, segs)
    B = _field(B)
    flat = np.ascontiguousarray(pos).ravel()
    d = np.take(flat, segs._dst3) - np.take(flat, segs._src3)  # (3S,) r_b − r_a
    g = np.repeat(0.5 * segs.segment_currents(currents_A), 3) * d
    n = pos.shape[0]
    G = np.bincount(segs._flat3, weights=np.concatenate([g, g]), minlength=3 * n).reshape(n, 3)
    F = np.empty_like(G)
    F[:, 0] = G[:, 1] * B[2] - G[:, 2] * B[1]
    F[:, 1] = G[:, 2] * B[0] - G[:, 0] * B[2]
    F[:, 2] = G[:, 0] * B[1] - G[:, 1] * B[0]
    return F


def vector_areas(pos, segs: CircuitSegments) -> np.ndarray:
    """(n_circuits, 3) vector areas a_L = ½ Σ s_e r_a × r_b [m²] on positions ``pos``."""
    pos = _positions(pos, segs)
    w = 0.5 * segs.mult[:, None] * np.cross(pos[segs.src], pos[segs.dst])
    out = np.empty((segs.n_circuits, 3))
    for c in range(3):
        out[:, c] = np.bincount(segs.circuit_id, weights=w[:, c], minlength=segs.n_circuits)
    return out


def total_dipole(pos, segs: CircuitSegments, currents_A) -> np.ndarray:
    """Total magnetic dipole m = Σ_L I_L a_L [A m²] (same axes as ``pos``)."""
    pos = _positions(pos, segs)
    sI = segs.segment_currents(currents_A)
    return 0.5 * (sI[:, None] * np.cross(pos[segs.src], pos[segs.dst])).sum(axis=0)


def lorentz_wrench(pos, segs: CircuitSegments, currents_A, B, about) -> tuple[np.ndarray, np.ndarray]:
    """Resultant of the Eq. 16 node forces as a wrench on a rigid body.

    Returns ``(force, torque)``: force = Σ F_i [N] (zero for closed circuits up to rounding) and
    torque = Σ (r_i − about) × F_i [N m] about the point ``about`` (3,) [m]; for closed circuits
    torque = m × B whatever ``about`` is.
    """
    F = lorentz_node_forces(pos, segs, currents_A, B)
    p = np.asarray(pos, dtype=float)
    about = np.asarray(about, dtype=float).reshape(3)
    return F.sum(axis=0), np.cross(p - about, F).sum(axis=0)


def self_field_max_T(pos, segs: CircuitSegments, currents_A, *, parallel_cos: float = 0.9, chunk: int = 512) -> float:
    """Largest wire self-field at a segment due to its nearest parallel neighbour [T] (Eq. 17).

    Definition. For each segment e (midpoint c_e, unit direction ê, length l_e) the *parallel
    neighbours* are the other segments e' with |ê·ê'| ≥ ``parallel_cos`` that lie abreast of it,
    |(c_e' − c_e)·ê| < ½ l_e, and do not run on the same two nodes (wires of different circuits
    sharing a strut are one bundle). Their distance is the perpendicular offset
    r = |(c_e' − c_e) − ((c_e' − c_e)·ê) ê|. The nearest such neighbour (smallest r) gives
    B_w(e) = μ0 |s_e' I_e'| / (2π r), the infinite straight-wire field. The function returns
    max_e B_w(e) (0 when no segment has a parallel neighbour, or all currents are zero).

    All pairs, vectorised in chunks of ``chunk`` rows (memory ~ 8 chunk × S floats): a diagnostic
    for a run's start/end or a decimated record (0.2–1.5 s for the 3 244 segments of F at N = 27
    on a shared 2-core machine), not for every step.
    """
    pos = _positions(pos, segs)
    sI = np.abs(segs.segment_currents(currents_A))
    a, b = pos[segs.src], pos[segs.dst]
    c = 0.5 * (a + b)
    c = c - c.mean(axis=0)  # centred: smaller rounding in the expansions below
    d = b - a
    l = np.linalg.norm(d, axis=1)
    e = d / l[:, None]
    cc = np.einsum("sc,sc->s", c, c)
    ce = np.einsum("sc,sc->s", c, e)
    lo = np.minimum(segs.src, segs.dst)
    hi = np.maximum(segs.src, segs.dst)
    best = 0.0
    S = c.shape[0]
    for k0 in range(0, S, chunk):  # chunks of rows; all pair terms by matrix products
        k1 = min(S, k0 + chunk)
        # |c_j − c_i|² and (c_j − c_i)·ê_i without (k, S, 3) temporaries
        dist2 = cc[k0:k1, None] + cc[None, :] - 2.0 * (c[k0:k1] @ c.T)
        axial = e[k0:k1] @ c.T - ce[k0:k1, None]
        perp2 = dist2 - axial**2
        ok = (np.abs(e[k0:k1] @ e.T) >= parallel_cos) & (np.abs(axial) < 0.5 * l[k0:k1, None])
        ok &= ~((lo[k0:k1, None] == lo[None, :]) & (hi[k0:k1, None] == hi[None, :]))
        ok &= perp2 > 0.0
        r2 = np.where(ok, perp2, np.inf)
        j = np.argmin(r2, axis=1)
        rmin2 = r2[np.arange(k1 - k0), j]
        has = np.isfinite(rmin2)
        if np.any(has):
            Bw = MU0 * sI[j[has]] / (2.0 * np.pi * np.sqrt(rmin2[has]))
            best = max(best, float(Bw.max()))
    return best


class LorentzLoad:
    """Eq. 16 node forces on a lattice whose node i is MuJoCo body ``i + 1`` (the Load protocol).

    Currents: ``state.ctrl.currents_A`` when the controller command has that attribute (and it
    is not ``None``), else the fixed ``currents_A`` given here. Field: the fixed world vector
    ``B_world`` [T] when given, else ``state.env.B_eci`` (ECI = world axes). Only the force
    rows ``xfrc[1 : n_nodes + 1, :3]`` are written.

    After each :meth:`add`, ``last_forces`` (n_nodes, 3) [N], ``last_currents_A`` and
    ``last_B`` hold what was applied (for diagnostics such as the magnetic torque about the CM,
    :meth:`torque_about`).
    """

    name = "lorentz"

    def __init__(
        self,
        circuits: Sequence[Circuit] | CircuitSegments,
        *,
        n_nodes: int | None = None,
        currents_A=None,
        B_world=None,
        body_offset: int = 1,
    ) -> None:
        self.segs = circuits if isinstance(circuits, CircuitSegments) else CircuitSegments(circuits)
        if n_nodes is None:
            n_nodes = self.segs.n_nodes
        if int(n_nodes) != n_nodes or n_nodes < self.segs.n_nodes:
            raise ValueError(
                f"n_nodes: must be an integer >= {self.segs.n_nodes} (largest node index used + 1), got {n_nodes!r}"
            )
        self.n_nodes = int(n_nodes)
        if int(body_offset) != body_offset or body_offset < 0:
            raise ValueError(f"body_offset: must be an integer >= 0, got {body_offset!r}")
        self.body_offset = int(body_offset)
        self.currents_A = None
        if currents_A is not None:
            self.segs.segment_currents(currents_A)  # checks the count
            self.currents_A = np.asarray(currents_A, dtype=float).reshape(-1).copy()
        self.B_world = None if B_world is None else _field(B_world).copy()
        self.last_forces = np.zeros((self.n_nodes, 3))
        self.last_currents_A = np.zeros(self.segs.n_circuits)
        self.last_B = np.zeros(3)

    def currents(self, state: StepState) -> np.ndarray:
        cmd = getattr(state.ctrl, "currents_A", None) if state.ctrl is not None else None
        if cmd is not None:
            return np.asarray(cmd, dtype=float).reshape(-1)
        if self.currents_A is None:
            raise ValueError(
                "LorentzLoad: no currents — the controller command has no currents_A and no fixed currents_A was given"
            )
        return self.currents_A

    def field(self, state: StepState) -> np.ndarray:
        if self.B_world is not None:
            return self.B_world
        if state.env is None:
            raise ValueError("LorentzLoad: no field — state.env is None and no fixed B_world was given")
        return np.asarray(state.env.B_eci, dtype=float)

    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        i0 = self.body_offset
        pos = state.pos[i0 : i0 + self.n_nodes]
        I = self.currents(state)
        B = self.field(state)
        F = lorentz_node_forces(pos, self.segs, I, B)
        xfrc[i0 : i0 + self.n_nodes, :3] += F
        self.last_forces = F
        self.last_currents_A = np.array(I, dtype=float)
        self.last_B = np.array(B, dtype=float)

    def torque_about(self, pos, point) -> np.ndarray:
        """Σ (r_i − point) × F_i [N m] of the last applied forces, ``pos`` (n_nodes, 3) node positions."""
        p = np.asarray(pos, dtype=float)[: self.n_nodes]
        return np.cross(p - np.asarray(point, dtype=float).reshape(3), self.last_forces).sum(axis=0)
