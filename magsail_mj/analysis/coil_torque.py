r"""Lorentz torque of a conducting path in a uniform field (paper Eqs. 1–4).

Structure frame (centre of mass at the origin), SI units. For consecutive nodes ``r_i``,
``r_{i+1}`` of a path carrying the node-order current ``I`` in a uniform field **B**:

.. math::

   \mathbf L_i = \mathbf r_{i+1} - \mathbf r_i \quad (2),\qquad
   \mathbf f_i = I\,\mathbf L_i\times\mathbf B \quad (1),\qquad
   \boldsymbol\tau_i = \tfrac12(\mathbf r_i + \mathbf r_{i+1})\times\mathbf f_i \quad (3),

   \mathbf T = \sum_{i=1}^{K-1}\tfrac12 I(\mathbf r_i + \mathbf r_{i+1})\times
               [(\mathbf r_{i+1}-\mathbf r_i)\times\mathbf B] \quad (4).

``T`` is linear in ``B`` and ``I``: :func:`torque_matrix` gives the 3×3 ``M`` with
``T = I · M B`` (column ``e`` = torque for unit current and ``B = ê_e``). Also here: the net
force of the open path ``F = I (r_K − r_1) × B``, the dipole of the path closed by straight
leads to the centre ``m = (I/2) Σ r_i × r_{i+1}``, and the normative **capability metric**
: for the y-coil ``T_max = |ẑ · T(B_ref x̂)|`` at ``I = I_max``, for the x-coil
``|ẑ · T(B_ref ŷ)|``, for the in-plane loop ``|x̂ · T(B_ref ŷ)|``. In the dynamic scenarios each
path is an ideal dipole of at most ``m_max = T_max / B_ref``.

:func:`coil_torque_report` assembles the ``coil_torque`` keys (the stdout JSON of
``magsail torque coil``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from magsail_mj.analysis.scaling import require_finite
from magsail_mj.geometry.reflector_coil import CoilPath, coil_x, coil_y, square_loop
from magsail_mj.resources import check_memory, coil_report_bytes

__all__ = [
    "capability",
    "closed_lead_dipole",
    "coil_torque_report",
    "loop_side_for_capability",
    "net_force",
    "path_report",
    "path_torque",
    "segment_torques",
    "torque_matrix",
]

# the component and field direction of each path's capability metric:
# axis of the path → (field direction e, torque component c) with T_max = |c · T(B_ref ê_e)|
_CAPABILITY = {1: (0, 2), 0: (1, 2), 2: (1, 0)}


def _nodes(nodes: np.ndarray) -> np.ndarray:
    r = np.asarray(nodes, dtype=float)
    if r.ndim != 2 or r.shape[1] != 3 or r.shape[0] < 2:
        raise ValueError(f"nodes: expected a (K, 3) array with K >= 2, got shape {r.shape}")
    return r


def segment_torques(nodes: np.ndarray, B: np.ndarray, *, current: float) -> np.ndarray:
    """Per-segment torques τ_i of Eq. 3 [N m], (K−1, 3): force I L_i × B at the segment midpoint."""
    r = _nodes(nodes)
    Bv = np.asarray(B, dtype=float)
    L = r[1:] - r[:-1]
    mid = 0.5 * (r[1:] + r[:-1])
    return np.cross(mid, current * np.cross(L, Bv))


def path_torque(nodes: np.ndarray, B: np.ndarray, *, current: float) -> np.ndarray:
    """Total torque T of Eq. 4 about the origin [N m], (3,)."""
    return segment_torques(nodes, B, current=current).sum(axis=0)


def torque_matrix(nodes: np.ndarray) -> np.ndarray:
    r"""3×3 matrix ``M`` with ``T = I · M B`` [N m / (A T)] for the node-order current.

    Using ``c × (L × B) = L (c·B) − B (c·L)`` with ``c_i`` the midpoint:
    ``M = Σ_i L_i c_iᵀ − (Σ_i c_i·L_i) 𝟙``.
    """
    r = _nodes(nodes)
    L = r[1:] - r[:-1]
    c = 0.5 * (r[1:] + r[:-1])
    return L.T @ c - np.einsum("ij,ij->", c, L) * np.eye(3)


def net_force(nodes: np.ndarray, B: np.ndarray, *, current: float) -> np.ndarray:
    """Net Lorentz force of the open path ``F = I (r_K − r_1) × B`` [N]."""
    r = _nodes(nodes)
    return current * np.cross(r[-1] - r[0], np.asarray(B, dtype=float))


def closed_lead_dipole(nodes: np.ndarray, *, current: float) -> np.ndarray:
    """Dipole of the path closed by straight leads to the centre, ``m = (I/2) Σ r_i × r_{i+1}`` [A m²]."""
    r = _nodes(nodes)
    return 0.5 * current * np.cross(r[:-1], r[1:]).sum(axis=0)


def capability(path: CoilPath, *, current_A: float, field_T: float) -> float:
    """Normative capability metric T_max of ``path`` at ``I = current_A``, ``|B_ref| = field_T`` [N m]."""
    e, comp = _CAPABILITY[path.axis]
    M = torque_matrix(path.nodes)
    return float(abs(current_A * field_T * M[comp, e]))


def loop_side_for_capability(
    target_Nm: float, *, side_m: float, segment_m: float, depth_m: float, current_A: float, field_T: float
) -> tuple[float, float]:
    """Side [m] of the lattice-aligned square loop (plane z = −h/2, centred) whose capability
    ``|x̂·T(B_ref ŷ)| = I s² B_ref`` is closest to ``target_Nm`` (assumption A3), and that capability.

    Candidate sides are the even multiples of ``segment_m`` up to ``side_m``.
    """
    k_max = int(np.floor(side_m / (2 * segment_m) + 1e-9))
    if k_max < 1:
        raise ValueError(f"side_m: {side_m!r} m holds no centred loop of segment_m = {segment_m!r} m")
    sides = 2 * segment_m * np.arange(1, k_max + 1)
    caps = current_A * field_T * sides**2
    k = int(np.argmin(np.abs(caps - target_Nm)))
    side = float(sides[k])
    loop = CoilPath("zloop", square_loop(side, segment_m, z=-depth_m / 2, d=side_m), axis=2, s_path=+1)
    return side, capability(loop, current_A=current_A, field_T=field_T)


def path_report(path: CoilPath, *, current_A: float, field_T: float) -> dict[str, Any]:
    """The torque capability (Robb et al. 2020, Eqs. 1–4) of one path at
    ``I = I_max`` (node-order current ``s_path I_max``).

    Keys: ``node_count``, ``segment_count``, ``length_m``, ``s_path``, ``torque_matrix_Nm_AT``
    (node-order current), ``T_max_Nm``, ``T_Bx_Nm``, ``T_By_Nm``, ``T_Bz_Nm`` (full torque
    vectors for ``B = B_ref ê``), ``singular_values_Nm`` (of ``I M B_ref``), ``net_force_B{x,y,z}_N``,
    ``closed_lead_dipole_Am2``.
    """
    M = torque_matrix(path.nodes)
    I = path.s_path * current_A
    out: dict[str, Any] = {
        "node_count": int(path.nodes.shape[0]),
        "segment_count": path.segment_count,
        "length_m": path.length_m,
        "s_path": int(path.s_path),
        "torque_matrix_Nm_AT": M.tolist(),
        "T_max_Nm": capability(path, current_A=current_A, field_T=field_T),
    }
    for k, ax in enumerate("xyz"):
        out[f"T_B{ax}_Nm"] = (I * field_T * M[:, k]).tolist()
    # σ(I B M) = |I B| σ(M): the path's own matrix is decomposed, then scaled (no SVD of overflowed values)
    out["singular_values_Nm"] = (abs(I * field_T) * np.linalg.svd(M, compute_uv=False)).tolist()
    for k, ax in enumerate("xyz"):
        out[f"net_force_B{ax}_N"] = net_force(path.nodes, field_T * np.eye(3)[k], current=I).tolist()
    out["closed_lead_dipole_Am2"] = closed_lead_dipole(path.nodes, current=I).tolist()
    return out


def coil_torque_report(
    *,
    side_m: float = 100.0,
    segment_m: float = 1.0,
    depth_m: float | None = None,
    current_A: float = 10.0,
    field_T: float = 30e-6,
    pitch_cells: int = 2,
    rows: int | None = None,
) -> dict[str, Any]:
    """The ``coil_torque`` figures plus the full per-path report.

    Flat keys: ``T_max_ycoil_Nm``, ``T_max_xcoil_Nm``, ``T_max_zloop_Nm``, ``zloop_side_m``,
    ``T_max_perimeter_loop_Nm``, ``T_max_ycoil_p1_Nm``, ``T_max_ycoil_rows_plus1_Nm``,
    ``m_max_Am2`` (= T_max,y / B_ref), ``path_length_m``, ``node_count``, ``segment_count``,
    ``net_force_Bx_N`` (|F| of the y-coil for B = B_ref x̂), ``closed_lead_dipole_y_Am2`` (y
    component of the y-coil's closed-lead dipole for the positive, +y-dipole current). The nested
    ``paths`` table holds :func:`path_report` of each path.

    Raises ValueError naming the argument for a bad value, a non-finite result, or
    :class:`magsail_mj.resources.MemoryLimitError` when the paths would need more memory than the
    limit (estimated from their node counts before any is built).
    """
    inputs = {
        "side_m": side_m,
        "segment_m": segment_m,
        "depth_m": depth_m,
        "current_A": current_A,
        "field_T": field_T,
        "pitch_cells": pitch_cells,
        "rows": rows,
    }
    h, n = _check_report_inputs(**inputs)
    check_memory(
        coil_report_bytes(side_m=side_m, segment_m=segment_m, pitch_cells=pitch_cells, rows=rows),
        what=f"coil paths of side_m = {side_m!r} m with segment_m = {segment_m!r} m "
        f"({n} cells per side, pitch_cells = {pitch_cells!r}, rows = {rows!r})",
    )
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        return require_finite(
            _coil_report(
                side_m=side_m,
                segment_m=segment_m,
                h=h,
                n=n,
                current_A=current_A,
                field_T=field_T,
                pitch_cells=pitch_cells,
                rows=rows,
            ),
            inputs={k: v for k, v in inputs.items() if v is not None},
        )


def _check_report_inputs(
    *,
    side_m: float,
    segment_m: float,
    depth_m: float | None,
    current_A: float,
    field_T: float,
    pitch_cells: int,
    rows: int | None,
) -> tuple[float, int]:
    """``(depth h, cells per side n)`` after checking every argument (names the bad one)."""
    for name, v in (("side_m", side_m), ("segment_m", segment_m), ("current_A", current_A), ("field_T", field_T)):
        if (
            isinstance(v, bool)
            or not isinstance(v, (int, float, np.integer, np.floating))
            or not (np.isfinite(v) and v > 0)
        ):
            raise ValueError(f"{name}: must be a finite number > 0, got {v!r}")
    h = segment_m if depth_m is None else depth_m
    if (
        isinstance(h, bool)
        or not isinstance(h, (int, float, np.integer, np.floating))
        or not (np.isfinite(h) and h > 0)
    ):
        raise ValueError(f"depth_m: must be a finite number > 0, got {depth_m!r}")
    for name, v in (("pitch_cells", pitch_cells), ("rows", rows)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1):
            raise ValueError(f"{name}: must be an integer >= 1, got {v!r}")
    ratio = side_m / segment_m
    if not np.isfinite(ratio) or ratio > 1e15:
        raise ValueError(
            f"side_m: {side_m!r} m is {ratio:.3g} segments of segment_m = {segment_m!r} m; too many to build a path"
        )
    n = round(ratio)
    if n < 1 or abs(n * segment_m - side_m) > 1e-9 * side_m:
        raise ValueError(f"side_m: must be a whole multiple of segment_m = {segment_m!r} m, got {side_m!r}")
    if pitch_cells > n:
        raise ValueError(f"pitch_cells: {pitch_cells} exceeds the {n} cells per side")
    if rows is not None and rows > n + 1:
        raise ValueError(f"rows: must be at most {n + 1} (n + 1 row planes), got {rows!r}")
    return float(h), int(n)


def _coil_report(
    *,
    side_m: float,
    segment_m: float,
    h: float,
    n: int,
    current_A: float,
    field_T: float,
    pitch_cells: int,
    rows: int | None,
) -> dict[str, Any]:
    """The figures of :func:`coil_torque_report` for checked inputs."""
    kw = {"current_A": current_A, "field_T": field_T}
    ycoil = CoilPath("ycoil", coil_y(side_m, segment_m, h, p=pitch_cells, n_row=rows), axis=1, s_path=-1)
    xcoil = CoilPath("xcoil", coil_x(side_m, segment_m, h, p=pitch_cells, n_row=rows), axis=0, s_path=+1)
    T_y = capability(ycoil, **kw)
    zside, T_z = loop_side_for_capability(T_y, side_m=side_m, segment_m=segment_m, depth_m=h, **kw)
    zloop = CoilPath("zloop", square_loop(zside, segment_m, z=-h / 2, d=side_m), axis=2, s_path=+1)
    paths = {"ycoil": ycoil, "xcoil": xcoil, "zloop": zloop}
    perim = None
    if n % 2 == 0:
        perim = CoilPath("perimeter_loop", square_loop(side_m, segment_m, z=-h / 2, d=side_m), axis=2, s_path=+1)
        paths["perimeter_loop"] = perim
    p1 = CoilPath("ycoil_p1", coil_y(side_m, segment_m, h, p=1, n_row=rows), axis=1, s_path=-1)
    rp1 = CoilPath("ycoil_rows_plus1", coil_y(side_m, segment_m, h, p=pitch_cells, n_row=n + 1), axis=1, s_path=-1)
    paths["ycoil_p1"] = p1
    paths["ycoil_rows_plus1"] = rp1
    reports = {name: path_report(path, **kw) for name, path in paths.items()}
    y = reports["ycoil"]
    return {
        "side_m": side_m,
        "segment_m": segment_m,
        "depth_m": h,
        "current_A": current_A,
        "field_T": field_T,
        "pitch_cells": pitch_cells,
        "rows": n if rows is None else rows,
        "T_max_ycoil_Nm": T_y,
        "T_max_xcoil_Nm": reports["xcoil"]["T_max_Nm"],
        "T_max_zloop_Nm": T_z,
        "zloop_side_m": zside,
        "T_max_perimeter_loop_Nm": reports["perimeter_loop"]["T_max_Nm"] if perim is not None else None,
        "T_max_ycoil_p1_Nm": reports["ycoil_p1"]["T_max_Nm"],
        "T_max_ycoil_rows_plus1_Nm": reports["ycoil_rows_plus1"]["T_max_Nm"],
        "m_max_Am2": T_y / field_T,
        "path_length_m": y["length_m"],
        "node_count": y["node_count"],
        "segment_count": y["segment_count"],
        "net_force_Bx_N": float(np.linalg.norm(y["net_force_Bx_N"])),
        "closed_lead_dipole_y_Am2": y["closed_lead_dipole_Am2"][1],
        "paths": reports,
    }
