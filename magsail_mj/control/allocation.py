"""Torque distribution over a two-family rod array: signed numbers of activated rods N1, N2.

Robb et al. 2022a, Eqs. 10–13, with the corrections and choices stated below.
All vectors are in **body** components (``x1, y1, z1``); the caller rotates the world field
``B_b = Rᵀ B``. Family 1 rods point along ``x̂1``, family 2 along ``ŷ1``, each of dipole
``m_f`` [A m²]. One rod of each family gives the torque [N m]

    τ1 = m_1 x̂1 × B_b = m_1 (0, −B_z, B_y),      τ2 = m_2 ŷ1 × B_b = m_2 (B_z, 0, −B_x),

both normal to ``B``, with ``τ1·τ2 = −m_1 m_2 (x̂1·B)(ŷ1·B)`` (this corrects the
paper's middle line of Eq. 10). ``N_f`` rods of family ``f`` on with polarity ``sign(N_f)``
deliver ``T = N1 τ1 + N2 τ2``.

``mode="paper"`` (default; the paper's single Gauss–Seidel sweep)::

    N1 = clip(rnd(T_ref·τ1 / |τ1|²), ±N_max,1)
    N2 = clip(rnd((T_ref·τ2 − N1 τ1·τ2) / |τ2|²), ±N_max,2)

``mode="exact"``: solve the Gram system ``[[τ1·τ1, τ1·τ2], [τ1·τ2, τ2·τ2]] x = [T·τ1, T·τ2]``,
``N1 = clip(rnd(x1))``, then ``N2`` from the residual as above. When
``det < 1e-6 |τ1|²|τ2|²`` (field near the plate plane, ``τ1 ∥ τ2``) that sample falls back to the
paper's mode (reported as ``"exact_fallback"``).

Details: ``rnd`` is symmetric round-half-away-from-zero,
``sign(x) ⌊|x| + ½⌋`` (computed without the ``0.49999999999999994 + 0.5 = 1`` rounding trap),
so ``T_ref`` and ``−T_ref`` give mirror-image commands; the clip to ``±N_max`` (380 per family on
the truss) happens before ``N2`` is computed; a family whose single-rod torque is
negligible, ``|τ_f| ≤ 1e-9 m_f |B|`` (field along its rods, or ``m_f = 0``), gets ``N_f = 0``.

:func:`allocate` is the per-sample scalar version (plain Python floats, a few µs);
:func:`allocate_batch` the vectorised one over many samples (tested against the scalar one);
:class:`TorqueDistributor` chains the allocation with the cached Lloyd selection of
:mod:`magsail_mj.control.lloyd` and returns the rod polarity vector of one control sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Sequence

import numpy as np

from magsail_mj.control.lloyd import LloydSelector, Symmetry

__all__ = [
    "AllocationMode",
    "Allocation",
    "AllocationBatch",
    "round_half_away",
    "rod_torques",
    "allocate",
    "allocate_batch",
    "allocation_mode_difference",
    "TorqueDistributor",
]

AllocationMode = Literal["paper", "exact"]

TINY_TORQUE_REL = 1e-9
"""A family is unusable when ``|τ_f| ≤ TINY_TORQUE_REL · m_f |B|``."""

SINGULAR_GRAM_REL = 1e-6
"""Exact mode falls back to the paper's when ``det G < SINGULAR_GRAM_REL |τ1|²|τ2|²``."""


def round_half_away(x):
    """Symmetric rounding ``sign(x) ⌊|x| + ½⌋``, scalar or array (floats out)."""
    ax = np.abs(np.asarray(x, dtype=float))
    f = np.floor(ax)
    r = f + (ax - f >= 0.5)
    return np.copysign(r, x) if np.ndim(x) else float(math.copysign(float(r), float(x)))


def _rnd(x: float) -> int:
    ax = abs(x)
    f = math.floor(ax)
    r = f + 1 if ax - f >= 0.5 else f
    return int(r) if x >= 0 else -int(r)


def _rnd_clip(x: float, n_max: int, name: str) -> tuple[int, int]:
    """``(rnd(x), clip(rnd(x), ±n_max))`` for any float ``x``: a demand beyond ``n_max + 1`` (an
    infinite one included: a rod dipole or field so small that ``x`` overflowed) rounds to
    ``±(n_max + 1)``, which clips the same; NaN is a ``ValueError`` naming ``name``."""
    if x != x:
        raise ValueError(f"{name}: the rod demand is NaN (the reference torque or field overflowed float64)")
    if not abs(x) < n_max + 1:
        r = n_max + 1 if x > 0 else -(n_max + 1)
    else:
        r = _rnd(x)
    return r, max(-n_max, min(n_max, r))


def _round_clip(x: np.ndarray, n_max: int) -> np.ndarray:
    """:func:`_rnd_clip`'s ``rnd`` over an array (int64): beyond ``n_max + 1`` (inf included) the
    demand rounds to ``±(n_max + 1)``; NaN is a ``ValueError``."""
    if np.isnan(x).any():
        raise ValueError("T_ref_body: a rod demand is NaN (the reference torque or field overflowed float64)")
    return round_half_away(np.clip(x, -(n_max + 1), n_max + 1)).astype(np.int64)


def _m_pair(m_rod_Am2, name: str = "m_rod_Am2") -> tuple[float, float]:
    if np.ndim(m_rod_Am2) == 0:
        m = (float(m_rod_Am2), float(m_rod_Am2))
    else:
        m = tuple(float(v) for v in m_rod_Am2)
    if len(m) != 2 or not all(math.isfinite(v) and v >= 0 for v in m):
        raise ValueError(f"{name}: expected one or two numbers >= 0 [A m²], got {m_rod_Am2!r}")
    return m  # type: ignore[return-value]


def _n_pair(n_max) -> tuple[int, int]:
    n = (n_max, n_max) if np.ndim(n_max) == 0 else tuple(n_max)
    if len(n) != 2 or not all(int(v) == v and v >= 0 for v in n):
        raise ValueError(f"n_max: expected one or two integers >= 0, got {n_max!r}")
    return int(n[0]), int(n[1])


def _check_mode(mode: str) -> None:
    if mode not in ("paper", "exact"):
        raise ValueError(f"mode: must be 'paper' or 'exact', got {mode!r}")


def rod_torques(B_body, *, m_rod_Am2: float | Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """Single-rod torques ``τ1 = m_1 x̂1 × B_b`` and ``τ2 = m_2 ŷ1 × B_b`` [N m].

    ``B_body``: (3,) or (K, 3) field in body components [T]; returns arrays of the same shape.
    """
    m1, m2 = _m_pair(m_rod_Am2)
    B = np.asarray(B_body, dtype=float)
    if B.shape[-1:] != (3,):
        raise ValueError(f"B_body: expected (3,) or (K, 3) [T], got shape {B.shape}")
    z = np.zeros_like(B[..., 0])
    t1 = m1 * np.stack([z, -B[..., 2], B[..., 1]], axis=-1)
    t2 = m2 * np.stack([B[..., 2], z, -B[..., 0]], axis=-1)
    return t1, t2


@dataclass(frozen=True, slots=True)
class Allocation:
    """One allocation.

    Attributes:
      N1, N2: signed numbers of activated rods (the sign is the polarity of the family).
      x1, x2: the unrounded, unclipped values that were rounded to N1 and N2.
      mode: ``"paper"``, ``"exact"``, or ``"exact_fallback"`` (exact asked, Gram matrix singular).
      clipped1, clipped2: the rounded demand exceeded ``N_max`` (saturation: all rods on).
      tau1_body, tau2_body: single-rod torques τ1, τ2, body components [N m].
    """

    N1: int
    N2: int
    x1: float
    x2: float
    mode: str
    clipped1: bool
    clipped2: bool
    tau1_body: tuple[float, float, float]
    tau2_body: tuple[float, float, float]

    @property
    def torque_body(self) -> np.ndarray:
        """Delivered torque ``N1 τ1 + N2 τ2`` in body components [N m]."""
        return self.N1 * np.asarray(self.tau1_body) + self.N2 * np.asarray(self.tau2_body)


def allocate(
    T_ref_body,
    B_body,
    *,
    m_rod_Am2: float | Sequence[float],
    n_max: int | Sequence[int],
    mode: AllocationMode = "paper",
) -> Allocation:
    """Signed rod counts ``(N1, N2)`` for the reference torque ``T_ref_body`` (Eqs. 11–13).

    Args:
      T_ref_body: (3,) reference torque, body components [N m].
      B_body: (3,) field, body components [T].
      m_rod_Am2: rod dipole [A m²], one value or one per family.
      n_max: rods per family (saturation limit), one value or ``(N_max,1, N_max,2)``.
      mode: ``"paper"`` (default) or ``"exact"``.
    """
    _check_mode(mode)
    m1, m2 = _m_pair(m_rod_Am2)
    n1max, n2max = _n_pair(n_max)
    try:
        Tx, Ty, Tz = (float(v) for v in T_ref_body)
    except (TypeError, ValueError):
        raise ValueError(f"T_ref_body: expected 3 numbers [N m], got {T_ref_body!r}") from None
    try:
        Bx, By, Bz = (float(v) for v in B_body)
    except (TypeError, ValueError):
        raise ValueError(f"B_body: expected 3 numbers [T], got {B_body!r}") from None
    if not all(map(math.isfinite, (Tx, Ty, Tz))):
        raise ValueError(f"T_ref_body: must be finite, got {T_ref_body!r}")
    if not all(map(math.isfinite, (Bx, By, Bz))):
        raise ValueError(f"B_body: must be finite, got {B_body!r}")
    return _allocate_core(Tx, Ty, Tz, Bx, By, Bz, m1, m2, n1max, n2max, mode == "exact")


def _allocate_core(
    Tx: float,
    Ty: float,
    Tz: float,
    Bx: float,
    By: float,
    Bz: float,
    m1: float,
    m2: float,
    n1max: int,
    n2max: int,
    exact: bool,
) -> Allocation:
    """The Eqs. 11–13 arithmetic on plain floats (validated inputs), scale-free.

    With τ_f = m_f u_f (``u1 = x̂1 × B``, ``u2 = ŷ1 × B``) every product of dipoles cancels:
    ``x1 = T·u1 / (m1 |u1|²)`` (paper) or ``(|u2|² T·u1 − u1·u2 T·u2) / (m1 det')`` (exact, ``det'``
    the Gram determinant of u1, u2), ``x2 = (T·u2 − N1 m1 u1·u2) / (m2 |u2|²)``; the tests
    ``|τ_f|² > (1e-9 m_f)² |B|²`` and ``det ≥ 1e-6 |τ1|²|τ2|²`` are the same on u. So no
    intermediate overflows for any finite rod dipole (``(m B)²`` did for m = 1e300 A m²) and an
    infinite demand saturates."""
    t1 = (0.0, -m1 * Bz, m1 * By)
    t2 = (m2 * Bz, 0.0, -m2 * Bx)
    a = Bz * Bz + By * By  # |u1|²
    b = Bz * Bz + Bx * Bx  # |u2|²
    c = -By * Bx  # u1·u2
    B2 = Bx * Bx + By * By + Bz * Bz
    tiny = TINY_TORQUE_REL * TINY_TORQUE_REL * B2
    ok1 = m1 > 0 and a > tiny
    ok2 = m2 > 0 and b > tiny
    Tu1 = -Ty * Bz + Tz * By
    Tu2 = Tx * Bz - Tz * Bx
    used = "paper"
    if exact:
        det = a * b - c * c
        if ok1 and ok2 and det >= SINGULAR_GRAM_REL * a * b:
            x1 = (b * Tu1 - c * Tu2) / det / m1
            used = "exact"
        else:
            x1 = Tu1 / a / m1 if ok1 else 0.0
            used = "exact_fallback"
    else:
        x1 = Tu1 / a / m1 if ok1 else 0.0
    r1, N1 = _rnd_clip(x1, n1max, "T_ref_body")
    x2 = (Tu2 - N1 * m1 * c) / b / m2 if ok2 else 0.0
    r2, N2 = _rnd_clip(x2, n2max, "T_ref_body")
    return Allocation(
        N1=N1,
        N2=N2,
        x1=x1,
        x2=x2,
        mode=used,
        clipped1=abs(r1) > n1max,
        clipped2=abs(r2) > n2max,
        tau1_body=t1,
        tau2_body=t2,
    )


@dataclass(frozen=True)
class AllocationBatch:
    """Allocations of K samples (arrays of shape (K,)); see :class:`Allocation`.

    ``fallback`` marks the exact-mode samples that used the paper's mode; ``torque_body`` is
    (K, 3).
    """

    N1: np.ndarray
    N2: np.ndarray
    x1: np.ndarray
    x2: np.ndarray
    fallback: np.ndarray
    clipped1: np.ndarray
    clipped2: np.ndarray
    tau1_body: np.ndarray
    tau2_body: np.ndarray

    @property
    def torque_body(self) -> np.ndarray:
        return self.N1[:, None] * self.tau1_body + self.N2[:, None] * self.tau2_body


def allocate_batch(
    T_ref_body,
    B_body,
    *,
    m_rod_Am2: float | Sequence[float],
    n_max: int | Sequence[int],
    mode: AllocationMode = "paper",
) -> AllocationBatch:
    """:func:`allocate` vectorised over K samples: ``T_ref_body`` and ``B_body`` of shape (K, 3)."""
    _check_mode(mode)
    m1, m2 = _m_pair(m_rod_Am2)
    n1max, n2max = _n_pair(n_max)
    T = np.asarray(T_ref_body, dtype=float)
    B = np.asarray(B_body, dtype=float)
    if T.ndim != 2 or T.shape[1] != 3:
        raise ValueError(f"T_ref_body: expected shape (K, 3) [N m], got {T.shape}")
    if B.shape != T.shape:
        raise ValueError(f"B_body: expected shape {T.shape} like T_ref_body [T], got {B.shape}")
    if not (np.all(np.isfinite(T)) and np.all(np.isfinite(B))):
        raise ValueError("T_ref_body, B_body: must be finite")
    t1, t2 = rod_torques(B, m_rod_Am2=(m1, m2))
    # the scale-free arithmetic of _allocate_core (u_f = τ_f / m_f)
    u1, u2 = rod_torques(B, m_rod_Am2=(1.0, 1.0))
    a = np.einsum("ij,ij->i", u1, u1)
    b = np.einsum("ij,ij->i", u2, u2)
    c = np.einsum("ij,ij->i", u1, u2)
    B2 = np.einsum("ij,ij->i", B, B)
    tiny = TINY_TORQUE_REL * TINY_TORQUE_REL * B2
    ok1 = (a > tiny) & (m1 > 0)
    ok2 = (b > tiny) & (m2 > 0)
    Tu1 = np.einsum("ij,ij->i", T, u1)
    Tu2 = np.einsum("ij,ij->i", T, u2)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x1 = np.where(ok1, Tu1 / np.where(ok1, a, 1.0) / (m1 if m1 > 0 else 1.0), 0.0)
        fallback = np.zeros(T.shape[0], dtype=bool)
        if mode == "exact":
            det = a * b - c * c
            good = ok1 & ok2 & (det >= SINGULAR_GRAM_REL * a * b)
            x1 = np.where(good, (b * Tu1 - c * Tu2) / np.where(good, det, 1.0) / (m1 if m1 > 0 else 1.0), x1)
            fallback = ~good
        r1 = _round_clip(x1, n1max)
        N1 = np.clip(r1, -n1max, n1max)
        x2 = np.where(ok2, (Tu2 - N1 * m1 * c) / np.where(ok2, b, 1.0) / (m2 if m2 > 0 else 1.0), 0.0)
    r2 = _round_clip(x2, n2max)
    N2 = np.clip(r2, -n2max, n2max)
    return AllocationBatch(
        N1=N1,
        N2=N2,
        x1=x1,
        x2=x2,
        fallback=fallback,
        clipped1=np.abs(r1) > n1max,
        clipped2=np.abs(r2) > n2max,
        tau1_body=t1,
        tau2_body=t2,
    )


def allocation_mode_difference(
    T_ref_body, B_body, *, m_rod_Am2: float | Sequence[float], n_max: int | Sequence[int]
) -> dict[str, float]:
    """How often and by how much the paper and exact modes differ over K samples.

    Returns flat SI keys: ``n_samples``, ``fraction_counts_differ``, ``fraction_exact_fallback``,
    ``torque_diff_max_Nm`` / ``torque_diff_mean_Nm`` (``|T_exact − T_paper|``) and the
    tracking errors ``|T − T_ref|`` of each mode (``err_paper_mean_Nm``, ``err_exact_mean_Nm``,
    ``err_paper_max_Nm``, ``err_exact_max_Nm``).
    """
    p = allocate_batch(T_ref_body, B_body, m_rod_Am2=m_rod_Am2, n_max=n_max, mode="paper")
    e = allocate_batch(T_ref_body, B_body, m_rod_Am2=m_rod_Am2, n_max=n_max, mode="exact")
    T = np.asarray(T_ref_body, dtype=float)
    dT = np.linalg.norm(e.torque_body - p.torque_body, axis=1)
    ep = np.linalg.norm(p.torque_body - T, axis=1)
    ee = np.linalg.norm(e.torque_body - T, axis=1)
    K = T.shape[0]
    nan = float("nan")
    return {
        "n_samples": K,
        "fraction_counts_differ": float(np.mean((p.N1 != e.N1) | (p.N2 != e.N2))) if K else nan,
        "fraction_exact_fallback": float(np.mean(e.fallback)) if K else nan,
        "torque_diff_max_Nm": float(dT.max()) if K else nan,
        "torque_diff_mean_Nm": float(dT.mean()) if K else nan,
        "err_paper_mean_Nm": float(ep.mean()) if K else nan,
        "err_exact_mean_Nm": float(ee.mean()) if K else nan,
        "err_paper_max_Nm": float(ep.max()) if K else nan,
        "err_exact_max_Nm": float(ee.max()) if K else nan,
    }


class TorqueDistributor:
    """One control sample: reference torque and field (body) → rod polarities.

    Args:
      selector: the cached Lloyd selection (two families; its site counts are ``N_max``).
      m_rod_Am2: rod dipole [A m²], one value or one per family.
      mode: ``"paper"`` (default) or ``"exact"``.

    Calling it returns ``(polarity, allocation)``: the (n_rods,) int8 polarity vector for
    ``state.ctrl.polarity`` of :class:`magsail_mj.loads.magnetorquer_rods.MagnetorquerRodLoad`
    and the :class:`Allocation`. Each new ``|N_f|`` costs one Lloyd run the first time (unless
    precomputed or cached on disk); afterwards a call costs a few tens of µs.
    """

    def __init__(self, selector: LloydSelector, *, m_rod_Am2: float | Sequence[float], mode: AllocationMode = "paper"):
        _check_mode(mode)
        if len(selector.n_sites) != 2:
            raise ValueError(f"selector: needs two rod families, got {len(selector.n_sites)}")
        self.selector = selector
        self.m_rod_Am2 = _m_pair(m_rod_Am2)
        self.n_max = selector.n_sites
        self.mode = mode

    @classmethod
    def for_rods(
        cls,
        rods,
        *,
        m_rod_Am2: float | Sequence[float],
        mode: AllocationMode = "paper",
        seed: int = 0,
        tol_rel: float = 1e-6,
        max_iter: int = 10_000,
        cache_dir: str | Path | None = None,
        symmetry: Symmetry = "none",
    ) -> "TorqueDistributor":
        """Distributor for a :class:`~magsail_mj.loads.magnetorquer_rods.RodArray` (truss rods);
        ``symmetry`` as in :class:`~magsail_mj.control.lloyd.LloydSelector`."""
        sel = LloydSelector(
            [rods.family_sites(0), rods.family_sites(1)],
            region=rods.region,
            seed=seed,
            tol_rel=tol_rel,
            max_iter=max_iter,
            cache_dir=cache_dir,
            symmetry=symmetry,
        )
        return cls(sel, m_rod_Am2=m_rod_Am2, mode=mode)

    def __call__(self, T_ref_body, B_body) -> tuple[np.ndarray, Allocation]:
        T = np.asarray(T_ref_body, dtype=float)
        B = np.asarray(B_body, dtype=float)
        if T.shape != (3,) or B.shape != (3,):
            raise ValueError(f"T_ref_body, B_body: expected 3 components each, got shapes {T.shape}, {B.shape}")
        Tx, Ty, Tz = T.tolist()
        Bx, By, Bz = B.tolist()
        if not all(map(math.isfinite, (Tx, Ty, Tz, Bx, By, Bz))):
            raise ValueError(f"T_ref_body, B_body: must be finite, got {T_ref_body!r}, {B_body!r}")
        al = _allocate_core(Tx, Ty, Tz, Bx, By, Bz, *self.m_rod_Am2, *self.n_max, self.mode == "exact")
        return self.selector.polarity((al.N1, al.N2)), al
