r"""Structural diagnostics of a spring–mass lattice.

Strut lengths, strains and strain energy, kinetic energy relative to the best-fit rigid motion,
and the inside-out (inverted tetrahedron) test of the structural failure flag. All functions
accept a single configuration ``(n, 3)`` or a time series ``(T, n, 3)`` (world frame, metres)
and are vectorised; strut quantities of long time series are evaluated in blocks of time steps
so that temporaries stay below ~32 MB (a loop over blocks, never over steps or struts).

Index conventions: ``struts`` is ``(S, 2)`` node indices, ``tets`` is ``(m, 4)`` node indices;
for the two-layer lattice the flat node index is ``k N^2 + j N + i``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from magsail_mj.estimation._arrays import as_index_array, as_masses, as_point_series, map_time_blocks

__all__ = [
    "strut_lengths",
    "strut_strain",
    "strain_energy",
    "KineticEnergySplit",
    "kinetic_energy_split",
    "relative_kinetic_energy",
    "signed_tet_volumes",
    "inverted_cells",
    "lattice_cube_tetrahedra",
    "FailureCheck",
    "structural_failure",
]


def _per_strut(value: object, name: str, n_struts: int) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if a.ndim == 0:
        return np.full(n_struts, float(a))
    if a.shape != (n_struts,):
        raise ValueError(f"{name}: expected a scalar or shape ({n_struts},), got {a.shape}")
    return a


def _lengths(x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Strut lengths of validated inputs, blocked over time for memory.

    Component by component (three passes over contiguous ``(..., S)`` arrays), which is about
    five times faster than ``norm`` over a ``(..., S, 3)`` gather.
    """
    a, b = np.ascontiguousarray(s[:, 0]), np.ascontiguousarray(s[:, 1])  # 3x faster take

    def f(xb: np.ndarray) -> np.ndarray:
        acc = None
        for c in range(3):
            xc = xb[..., c]
            dc = np.take(xc, b, axis=-1) - np.take(xc, a, axis=-1)
            acc = dc * dc if acc is None else acc + dc * dc
        return np.sqrt(acc)

    return map_time_blocks(f, (x,), 3 * s.shape[0])


def strut_lengths(pos: np.ndarray, struts: np.ndarray) -> np.ndarray:
    r"""Current strut lengths :math:`r_s = \lVert x_{b(s)} - x_{a(s)}\rVert` [m].

    Args:
      pos: ``(n, 3)`` or ``(T, n, 3)`` node positions [m].
      struts: ``(S, 2)`` integer node indices ``(a, b)``.

    Returns:
      ``(S,)`` or ``(T, S)``.
    """
    x = as_point_series(pos, "pos")
    s = as_index_array(struts, "struts", width=2, n_nodes=x.shape[-2])
    return _lengths(x, s)


def strut_strain(pos: np.ndarray, struts: np.ndarray, l0: float | np.ndarray) -> np.ndarray:
    r"""Signed engineering strain :math:`\varepsilon_s = (r_s - l_{0,s})/l_{0,s}`.

    The failure criterion uses :math:`\max_s|\varepsilon_s| > 0.5`.

    Args:
      pos: ``(n, 3)`` or ``(T, n, 3)`` node positions [m].
      struts: ``(S, 2)`` node indices.
      l0: rest lengths [m], scalar or ``(S,)``, all ``> 0``.

    Returns:
      ``(S,)`` or ``(T, S)`` (dimensionless).
    """
    x = as_point_series(pos, "pos")
    s = as_index_array(struts, "struts", width=2, n_nodes=x.shape[-2])
    L0 = _per_strut(l0, "l0", s.shape[0])
    if np.any(~(L0 > 0)):
        raise ValueError("l0: rest lengths must be > 0")
    return (_lengths(x, s) - L0) / L0


def strain_energy(
    pos: np.ndarray, struts: np.ndarray, k: float | np.ndarray, l0: float | np.ndarray
) -> np.ndarray | float:
    r"""Elastic energy of the struts :math:`E = \tfrac12\sum_s k_s (r_s - l_{0,s})^2` [J].

    Args:
      pos: ``(n, 3)`` or ``(T, n, 3)`` node positions [m].
      struts: ``(S, 2)`` node indices.
      k: axial stiffness [N/m], scalar or ``(S,)``.
      l0: rest lengths [m], scalar or ``(S,)``.

    Returns:
      a float for ``(n, 3)`` input, else ``(T,)``.
    """
    x = as_point_series(pos, "pos")
    s = as_index_array(struts, "struts", width=2, n_nodes=x.shape[-2])
    K = _per_strut(k, "k", s.shape[0])
    L0 = _per_strut(l0, "l0", s.shape[0])

    def f(xb: np.ndarray) -> np.ndarray:
        ext = _lengths(xb, s) - L0
        return 0.5 * (ext * ext) @ K

    E = map_time_blocks(f, (x,), 3 * s.shape[0])
    return float(E) if np.ndim(E) == 0 else E


class KineticEnergySplit(NamedTuple):
    """Kinetic energy split of a particle set (see :func:`kinetic_energy_split`); all [J]
    except ``omega`` [rad/s, world components], each ``()`` or ``(T,)`` / ``(T, 3)``."""

    total: np.ndarray
    translational: np.ndarray
    rotational: np.ndarray
    relative: np.ndarray
    omega: np.ndarray


def kinetic_energy_split(pos: np.ndarray, vel: np.ndarray, masses: float | np.ndarray) -> KineticEnergySplit:
    r"""Split the kinetic energy into COM, best-fit rigid rotation, and the rest.

    With :math:`M=\sum m_i`, COM :math:`x_c`, :math:`v_c`, and :math:`r_i = x_i-x_c`,
    :math:`u_i = v_i - v_c`:

    * angular momentum about the COM :math:`L = \sum m_i\, r_i\times u_i`;
    * inertia tensor of the **current** configuration
      :math:`J = \sum m_i(\lVert r_i\rVert^2 I - r_i r_i^{\mathsf T})`;
    * rigid rate :math:`\omega = J^{-1}L`, which is the least-squares fit
      :math:`\arg\min_\omega \sum m_i\lVert u_i-\omega\times r_i\rVert^2` (normal equations
      :math:`J\omega = L`);
    * ``total`` :math:`=\tfrac12\sum m_i\lVert v_i\rVert^2`, ``translational``
      :math:`=\tfrac12 M\lVert v_c\rVert^2`, ``rotational`` :math:`=\tfrac12\omega\cdot L`,
      ``relative`` :math:`=\tfrac12\sum m_i\lVert u_i-\omega\times r_i\rVert^2`
      (= total − translational − rotational, computed directly so that a rigid motion gives
      zero to rounding).

    Args:
      pos: ``(n, 3)`` or ``(T, n, 3)`` positions [m].
      vel: same shape, velocities [m/s].
      masses: scalar or ``(n,)`` [kg].
    """
    x = as_point_series(pos, "pos", min_points=1)
    v = as_point_series(vel, "vel", n=x.shape[-2])
    if v.shape != x.shape:
        raise ValueError(f"vel: expected shape {x.shape} (as pos), got {v.shape}")
    m = as_masses(masses, "masses", x.shape[-2])
    return map_time_blocks(lambda xb, vb: _ke_split(xb, vb, m), (x, v), 12 * x.shape[-2])


def _ke_split(x: np.ndarray, v: np.ndarray, m: np.ndarray) -> KineticEnergySplit:
    M = m.sum()
    xc = (m @ x) / M
    vc = (m @ v) / M
    r = x - xc[..., None, :]
    u = v - vc[..., None, :]
    mr_T = np.swapaxes(r * m[:, None], -1, -2)  # (..., 3, n)
    S = mr_T @ r  # sum m r r^T
    W = mr_T @ u  # sum m r u^T
    L = np.stack(
        [W[..., 1, 2] - W[..., 2, 1], W[..., 2, 0] - W[..., 0, 2], W[..., 0, 1] - W[..., 1, 0]],
        axis=-1,
    )  # sum m r x u
    J = np.trace(S, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - S
    try:
        omega = np.linalg.solve(J, L[..., None])[..., 0]
    except np.linalg.LinAlgError:  # collinear / single-point sets: minimum-norm solution
        omega = (np.linalg.pinv(J) @ L[..., None])[..., 0]
    # du = u - omega x r, written out (np.cross is slow on large stacks)
    o = omega[..., None, :]
    du = u.copy()
    du[..., 0] -= o[..., 1] * r[..., 2] - o[..., 2] * r[..., 1]
    du[..., 1] -= o[..., 2] * r[..., 0] - o[..., 0] * r[..., 2]
    du[..., 2] -= o[..., 0] * r[..., 1] - o[..., 1] * r[..., 0]
    total = 0.5 * np.sum(v * v, axis=-1) @ m
    trans = 0.5 * M * np.sum(vc * vc, axis=-1)
    rot = 0.5 * np.sum(omega * L, axis=-1)
    rel = 0.5 * np.sum(du * du, axis=-1) @ m
    return KineticEnergySplit(total=total, translational=trans, rotational=rot, relative=rel, omega=omega)


def relative_kinetic_energy(pos: np.ndarray, vel: np.ndarray, masses: float | np.ndarray) -> np.ndarray | float:
    r"""Kinetic energy of the motion relative to the best-fit rigid motion [J].

    :math:`\tfrac12\sum_i m_i\lVert v_i - v_c - \omega\times(x_i-x_c)\rVert^2` with
    :math:`\omega = J^{-1}L` (see :func:`kinetic_energy_split`). Zero for any rigid motion; for
    a purely internal motion (zero angular momentum) it equals total minus COM kinetic energy.

    Returns a float for ``(n, 3)`` input, else ``(T,)``.
    """
    rel = kinetic_energy_split(pos, vel, masses).relative
    return float(rel) if np.ndim(rel) == 0 else rel


def signed_tet_volumes(pos: np.ndarray, tets: np.ndarray) -> np.ndarray:
    r"""Signed tetrahedron volumes :math:`V = \tfrac16 (x_1-x_0)\cdot[(x_2-x_0)\times(x_3-x_0)]`
    [m^3]; ``(m,)`` or ``(T, m)``."""
    x = as_point_series(pos, "pos")
    t = as_index_array(tets, "tets", width=4, n_nodes=x.shape[-2])
    return map_time_blocks(lambda xb: _tet_volumes(xb, t), (x,), 12 * t.shape[0])


def _tet_volumes(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Signed volumes of validated inputs, component by component."""
    idx = [np.ascontiguousarray(t[:, k]) for k in range(4)]  # contiguous: 3x faster take
    e = []  # e[c][k]: component c of edge vector k (x_k - x_0), k = 1, 2, 3
    for c in range(3):
        xc = x[..., c]
        x0 = np.take(xc, idx[0], axis=-1)
        e.append([np.take(xc, idx[k], axis=-1) - x0 for k in (1, 2, 3)])
    (a0, b0, c0), (a1, b1, c1), (a2, b2, c2) = e
    return (a0 * (b1 * c2 - b2 * c1) + a1 * (b2 * c0 - b0 * c2) + a2 * (b0 * c1 - b1 * c0)) / 6.0


def inverted_cells(pos: np.ndarray, tets: np.ndarray, *, reference: np.ndarray | None = None) -> np.ndarray:
    r"""Which tetrahedra are turned inside out (structural failure flag).

    A tetrahedron is inverted when its signed volume (:func:`signed_tet_volumes`) has changed
    sign relative to the reference (a volume of exactly zero counts as inverted: the cell has
    collapsed).

    Args:
      pos: ``(n, 3)`` or ``(T, n, 3)`` current positions [m].
      tets: ``(m, 4)`` node indices.
      reference: reference positions ``(n, 3)`` (e.g. the undeformed lattice), or reference
        signed volumes ``(m,)``; ``None`` means the tets are positively oriented in the
        reference (as :func:`lattice_cube_tetrahedra` builds them).

    Returns:
      bool ``(m,)`` or ``(T, m)``.
    """
    x = as_point_series(pos, "pos")
    t = as_index_array(tets, "tets", width=4, n_nodes=x.shape[-2])
    if reference is None:
        ref_sign = np.ones(t.shape[0])
    else:
        ref = np.asarray(reference, dtype=float)
        if ref.shape == (x.shape[-2], 3):
            ref_vol = signed_tet_volumes(ref, t)
        elif ref.shape == (t.shape[0],):
            ref_vol = ref
        else:
            raise ValueError(
                f"reference: expected positions ({x.shape[-2]}, 3) or volumes ({t.shape[0]},), got {ref.shape}"
            )
        ref_sign = np.sign(ref_vol)
        if np.any(ref_sign == 0):
            raise ValueError("reference: contains degenerate (zero-volume) tetrahedra")
    return map_time_blocks(lambda xb: _tet_volumes(xb, t) * ref_sign <= 0.0, (x,), 12 * t.shape[0])


def lattice_cube_tetrahedra(nodes_per_side: int) -> np.ndarray:
    r"""Corner tetrahedra of every cube of the two-layer lattice, positively oriented.

    For each of the ``(N-1)^2`` cubes and each of its 8 corners, the tetrahedron
    (corner, its neighbour along ``x1``, along ``y1``, along ``z1``), with the last two swapped
    where needed so the reference signed volume is ``+a^3/6``. A cube turned inside out (any
    corner's three edges no longer right-handed) inverts at least one of them.

    Flat node index ``k N^2 + j N + i``. Returns ``(8 (N-1)^2, 4)`` int64.
    """
    N = int(nodes_per_side)
    if N != nodes_per_side or N < 2:
        raise ValueError(f"nodes_per_side: expected an integer >= 2, got {nodes_per_side!r}")
    ii, jj = np.meshgrid(np.arange(N - 1), np.arange(N - 1), indexing="xy")
    ii, jj = ii.ravel(), jj.ravel()
    corners = np.array([(di, dj, dk) for dk in (0, 1) for dj in (0, 1) for di in (0, 1)])
    di, dj, dk = corners.T  # (8,)

    def idx(i, j, k):
        return k * N * N + j * N + i

    I = ii[:, None] + di[None, :]
    J = jj[:, None] + dj[None, :]
    K = np.broadcast_to(dk[None, :], I.shape)
    c0 = idx(I, J, K)
    cx = idx(ii[:, None] + (1 - di)[None, :], J, K)
    cy = idx(I, jj[:, None] + (1 - dj)[None, :], K)
    cz = idx(I, J, np.broadcast_to((1 - dk)[None, :], I.shape))
    # orientation of (±x, ±y, ±z) edges is (-1)^(di+dj+dk): swap cy, cz where negative
    neg = np.broadcast_to(((di + dj + dk) % 2 == 1)[None, :], I.shape)
    t2 = np.where(neg, cz, cy)
    t3 = np.where(neg, cy, cz)
    return np.stack([c0, cx, t2, t3], axis=-1).reshape(-1, 4).astype(np.int64)


class FailureCheck(NamedTuple):
    """Result of :func:`structural_failure`; each field ``()`` or ``(T,)``.

    Attributes:
      failed: strain above the limit or any inverted tetrahedron.
      max_abs_strain: :math:`\\max_s |\\varepsilon_s|`.
      worst_strut: index of the strut with the largest ``|strain|``.
      n_inverted: number of inverted tetrahedra (0 when no ``tets`` are given).
    """

    failed: np.ndarray
    max_abs_strain: np.ndarray
    worst_strut: np.ndarray
    n_inverted: np.ndarray


def structural_failure(
    pos: np.ndarray,
    struts: np.ndarray,
    l0: float | np.ndarray,
    *,
    tets: np.ndarray | None = None,
    reference: np.ndarray | None = None,
    strain_limit: float = 0.5,
) -> FailureCheck:
    r"""Structural failure flag: :math:`\max_s|\varepsilon_s| >` ``strain_limit``
    (default 50 %) or any tetrahedron of ``tets`` inverted (see :func:`inverted_cells`)."""
    eps = np.abs(strut_strain(pos, struts, l0))
    worst = np.argmax(eps, axis=-1)
    emax = np.take_along_axis(eps, worst[..., None], axis=-1)[..., 0]
    if tets is not None:
        n_inv = np.sum(inverted_cells(pos, tets, reference=reference), axis=-1)
    else:
        n_inv = np.zeros(emax.shape, dtype=np.int64)
    failed = (emax > strain_limit) | (n_inv > 0)
    return FailureCheck(failed=failed, max_abs_strain=emax, worst_strut=worst, n_inverted=n_inv)
