r"""Form-finding of cable nets by the force density method (Schek 1974).

A net of ``m`` cables on ``n`` nodes, cable ``e`` from node ``a_e`` to node ``b_e``, carries in
cable ``e`` the tension ``T_e = q_e L_e``, ``q_e > 0`` its force density [N/m] and ``L_e`` its
length. With the branch–node incidence ``C`` (``m × n``: ``+1`` at ``a_e``, ``−1`` at ``b_e``)
and ``Q = diag(q)``, the cable forces on the nodes are ``−Cᵀ Q C x`` (``x`` the ``n × 3``
positions): node ``i`` is pulled by ``Σ_e q_e (x_j − x_i)`` over its cables ``e`` to nodes ``j``.
Holding the support nodes ``s`` at their positions, the free nodes ``f`` are in equilibrium with
no external load where

    C_fᵀ Q C_f x_f = −C_fᵀ Q C_s x_s,

a linear system in ``x_f`` (one solve per coordinate, the same symmetric matrix ``D_ff =
C_fᵀ Q C_f``): the method's point is that fixing ``q`` instead of the tensions makes the
equilibrium shape linear. ``D_ff`` is positive definite when ``q > 0`` and every free node is
joined to a support by a chain of cables (otherwise a group of free nodes has nothing to hold it
and the shape is undetermined). The tensions follow from the found lengths, ``T = q L``; a cable
of axial rigidity ``EA`` that carries ``T`` at length ``L`` has the rest length
``l0 = L / (1 + T / EA)``.

Frames and units: the positions' frame, SI (m, N/m, N). Pure NumPy and SciPy (sparse).
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

__all__ = ["cable_resultants_N", "force_density_shape", "incidence", "rest_lengths_m"]


def _check_net(
    n_nodes: int, cables: np.ndarray, force_density_N_m: np.ndarray | float
) -> tuple[np.ndarray, np.ndarray]:
    ends = np.asarray(cables, dtype=np.int64)
    if ends.ndim != 2 or ends.shape[1] != 2 or ends.size == 0:
        raise ValueError(f"cables: must be an (m, 2) array of node indices with m >= 1, got shape {ends.shape}")
    if ends.min() < 0 or ends.max() >= n_nodes or np.any(ends[:, 0] == ends[:, 1]):
        raise ValueError(f"cables: node indices must be in [0, {n_nodes}) and differ at the two ends")
    q = np.array(np.broadcast_to(np.asarray(force_density_N_m, dtype=float), (len(ends),)), dtype=float)
    if not np.all(np.isfinite(q)) or np.any(q <= 0):
        raise ValueError(f"force_density_N_m: every force density must be finite and > 0, got min {q.min()!r}")
    return ends, q


def incidence(n_nodes: int, cables: np.ndarray) -> sparse.csr_matrix:
    """The ``m × n`` branch–node incidence ``C``: row ``e`` holds ``+1`` at cable ``e``'s first node
    and ``−1`` at its second."""
    ends = np.asarray(cables, dtype=np.int64).reshape(-1, 2)
    m = len(ends)
    rows = np.repeat(np.arange(m), 2)
    values = np.tile([1.0, -1.0], m)
    return sparse.csr_matrix((values, (rows, ends.ravel())), shape=(m, n_nodes))


def force_density_shape(
    positions_m: np.ndarray,
    cables: np.ndarray,
    force_density_N_m: np.ndarray | float,
    *,
    supports: np.ndarray,
) -> np.ndarray:
    """(n, 3) positions [m] of the net in equilibrium under the force densities
    ``force_density_N_m`` (one per cable or one for all, N/m, > 0): the support nodes
    ``supports`` keep ``positions_m``, every other node is placed by the force density method
    (module docstring) — nodes that no cable touches keep their positions too. Raises
    ``ValueError`` naming the argument for a malformed net or a group of free nodes that no chain
    of cables joins to a support."""
    p = np.asarray(positions_m, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or not np.all(np.isfinite(p)):
        raise ValueError(f"positions_m: must be a finite (n, 3) array, got shape {p.shape}")
    n = len(p)
    ends, q = _check_net(n, cables, force_density_N_m)
    fixed = np.zeros(n, dtype=bool)
    held = np.asarray(supports, dtype=np.int64).ravel()
    if held.size == 0 or held.min() < 0 or held.max() >= n:
        raise ValueError(f"supports: must be one or more node indices in [0, {n}), got {supports!r}")
    fixed[held] = True
    fixed[np.setdiff1d(np.arange(n), ends.ravel())] = True
    free = np.flatnonzero(~fixed)
    out = p.copy()
    if free.size == 0:
        return out
    C = incidence(n, ends)
    D = (C.T @ sparse.diags(q) @ C).tocsr()
    graph = D.copy()
    graph.data[:] = 1.0
    _, label = connected_components(graph, directed=False)
    anchored = np.zeros(label.max() + 1, dtype=bool)
    anchored[label[fixed]] = True
    loose = free[~anchored[label[free]]]
    if loose.size:
        raise ValueError(f"supports: free nodes {loose[:10].tolist()} are joined to no support by the cables")
    D_ff = D[free][:, free].tocsc()
    D_fs = D[free][:, fixed]
    out[free] = splu(D_ff).solve(-(D_fs @ p[fixed]))
    return out


def cable_resultants_N(
    positions_m: np.ndarray, cables: np.ndarray, force_density_N_m: np.ndarray | float
) -> np.ndarray:
    """(n, 3) resultant of the cable forces on every node [N], ``Σ_e q_e (x_j − x_i)`` over the
    cables ``e`` of node ``i`` (``−Cᵀ Q C x``): zero at a free node of a form-found net."""
    p = np.asarray(positions_m, dtype=float)
    ends, q = _check_net(len(p), cables, force_density_N_m)
    pull = q[:, None] * (p[ends[:, 1]] - p[ends[:, 0]])
    out = np.zeros_like(p)
    np.add.at(out, ends[:, 0], pull)
    np.add.at(out, ends[:, 1], -pull)
    return out


def rest_lengths_m(lengths_m: np.ndarray, tension_N: np.ndarray, EA_N: np.ndarray | float) -> np.ndarray:
    """Rest lengths ``l0 = L / (1 + T / EA)`` [m] of cables of axial rigidity ``EA_N`` that carry
    ``tension_N`` at ``lengths_m`` (the axial force law ``N = EA (L / l0 − 1)`` inverted)."""
    L = np.asarray(lengths_m, dtype=float)
    EA = np.broadcast_to(np.asarray(EA_N, dtype=float), L.shape)
    if not np.all(np.isfinite(EA)) or np.any(EA <= 0):
        raise ValueError(f"EA_N: must be finite and > 0, got {EA_N!r}")
    return L / (1.0 + np.asarray(tension_N, dtype=float) / EA)
