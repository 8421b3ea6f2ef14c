"""Current loops of the ``structure`` concept: member sets that form closed circuits (pure NumPy).

A loop is a member set whose members form one closed cycle: every node of the set is the end of
exactly two of its members, and the members are connected. The current runs along the set's
first member from its first node to its second (the order of ``members[k].nodes``) and on around
the cycle, which orients every member: the loop's directed edges ``(a_e → b_e)``. With the current
``I`` [A] and the node positions ``x`` [m], the loop's dipole is ``m = I a`` with the vector area
``a = ½ Σ_e x_a × x_b`` (right-handed about the current; independent of the origin for a closed
loop), and a member in the uniform field ``B`` feels ``f_e = I (x_b − x_a) × B``, half at each end
(:class:`magsail_mj.concepts.structure.loads.LoopLorentzLoad`).

:func:`oriented_loop` walks one set (once, when the config is validated and when the model is
built: a Python loop over the set's members, never in a step); :class:`LoopEdges` stacks the
directed edges of every loop into flat index arrays.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["LoopEdges", "LoopError", "oriented_loop", "vector_areas"]


class LoopError(ValueError):
    """A member set that is not one closed loop; the message says why, naming nodes or members."""


def oriented_loop(member_nodes: np.ndarray, members: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The directed edges ``(src, dst)`` (k,) of the loop made by ``members`` (k,), indices into the
    member table whose end nodes are ``member_nodes`` (m, 2), in the order the current runs (module
    docstring: the first member's node order sets the sense), and the member of each edge (k,).

    Raises:
      LoopError: a member listed twice, a node at which the set does not meet exactly twice (its
        degree named), or members forming more than one cycle.
    """
    k = np.asarray(members, dtype=np.int64).reshape(-1)
    if k.size < 2:
        raise LoopError(f"a closed loop needs at least 2 members, got {k.size}")
    unique, counts = np.unique(k, return_counts=True)
    if np.any(counts > 1):
        raise LoopError(f"member {int(unique[counts > 1][0])} is listed twice")
    ends = np.asarray(member_nodes, dtype=np.int64)[k]
    if np.any(ends[:, 0] == ends[:, 1]):
        raise LoopError(f"member {int(k[np.flatnonzero(ends[:, 0] == ends[:, 1])[0]])} joins a node to itself")
    nodes, degree = np.unique(ends, return_counts=True)
    bad = np.flatnonzero(degree != 2)
    if bad.size:
        listed = ", ".join(
            f"node {int(nodes[i])} ({int(degree[i])} member{'s' if degree[i] != 1 else ''})" for i in bad[:5]
        )
        more = f" and {bad.size - 5} more" if bad.size > 5 else ""
        raise LoopError(f"every node of a loop must end exactly 2 of its members: {listed}{more}")
    at: dict[int, list[int]] = {}
    for i, (a, b) in enumerate(ends.tolist()):
        at.setdefault(a, []).append(i)
        at.setdefault(b, []).append(i)
    src = np.empty(k.size, dtype=np.int64)
    dst = np.empty(k.size, dtype=np.int64)
    order = np.empty(k.size, dtype=np.int64)
    edge, node = 0, int(ends[0, 0])
    for step in range(k.size):
        a, b = ends[edge].tolist()
        nxt = b if a == node else a
        src[step], dst[step], order[step] = node, nxt, k[edge]
        node = nxt
        first, second = at[node]
        edge = second if first == edge else first
        if edge == 0:
            if step + 1 < k.size:
                raise LoopError(
                    f"its members form more than one closed loop (the one through member {int(k[0])} has "
                    f"{step + 1} of the {k.size} members)"
                )
            break
    return src, dst, order


def vector_areas(x: np.ndarray, src: np.ndarray, dst: np.ndarray, loop: np.ndarray, n_loops: int) -> np.ndarray:
    """(L, 3) vector areas ``a_L = ½ Σ_e x_a × x_b`` [m²] of the loops with node positions ``x``."""
    x = np.asarray(x, dtype=float)
    w = 0.5 * np.cross(x[src], x[dst])
    return np.stack([np.bincount(loop, weights=w[:, c], minlength=n_loops) for c in range(3)], axis=1)


@dataclass(frozen=True)
class LoopEdges:
    """The directed edges of every loop, stacked.

    Attributes:
      names: (L,) the member sets, in order (the order of the currents).
      src, dst: (S,) the end nodes of every directed edge ``a → b``.
      member: (S,) the member of every edge.
      loop: (S,) the loop of every edge.
      current_max_A: (L,) each loop's largest current [A].
    """

    names: tuple[str, ...]
    src: np.ndarray
    dst: np.ndarray
    member: np.ndarray
    loop: np.ndarray
    current_max_A: np.ndarray

    @property
    def n_loops(self) -> int:
        return len(self.names)

    @classmethod
    def from_sets(cls, member_nodes: np.ndarray, sets: dict[str, np.ndarray], current_max_A: np.ndarray) -> LoopEdges:
        """The loops of the member sets ``sets`` (name → members, in order) with their largest
        currents; :class:`LoopError` (naming the set) when one is not a closed loop."""
        src, dst, member, loop = [], [], [], []
        ends = np.asarray(member_nodes, dtype=np.int64)
        for i, (name, members) in enumerate(sets.items()):
            try:
                a, b, order = oriented_loop(ends, members)
            except LoopError as err:
                raise LoopError(f"member set {name!r}: {err}") from None
            member.append(order)
            src.append(a)
            dst.append(b)
            loop.append(np.full(a.size, i, dtype=np.int64))
        return cls(
            names=tuple(sets),
            src=np.concatenate(src),
            dst=np.concatenate(dst),
            member=np.concatenate(member).astype(np.int64),
            loop=np.concatenate(loop),
            current_max_A=np.asarray(current_max_A, dtype=float).reshape(-1),
        )

    def vector_areas(self, positions_m: np.ndarray) -> np.ndarray:
        """(L, 3) vector areas [m²] with the nodes at ``positions_m`` (n, 3)."""
        return vector_areas(positions_m, self.src, self.dst, self.loop, self.n_loops)
