r"""MSAC post-processing: yaw from quaternions, stroboscopic increments, filtering, secular rate.

Conventions: quaternions scalar-first ``[w, x, y, z]`` (MuJoCo) describing
the bus-to-world rotation; the motion is planar about world Z, so the bus yaw is
``ψ = 2·atan2(q_z, q_w)`` (exact for a rotation about Z; for a general rotation it is the yaw
of the swing–twist decomposition about Z), unwrapped along time.

Secular rate, two estimates:

1. :func:`secular_rate_fit`: the least-squares slope of the unwrapped stroboscopic yaw
   against time, ``ω̂ = Σ(t−t̄)(ψ−ψ̄) / Σ(t−t̄)²``;
2. :func:`filtered_rate`: the mean of the zero-phase (forward–backward) Butterworth low-pass
   filtered world-frame ``ω_z``, discarding an edge interval at each end against the filter's
   start/end transients.

:func:`block_average` decimates a per-step series to the filter's sampling rate (the mean of
each block of ``k`` samples). Every vectorised function here has a plain-loop counterpart in
the tests.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.signal import butter, sosfiltfilt

from magsail_mj.quaternion import quat_to_matrix

__all__ = [
    "yaw_from_quat",
    "unwrapped_yaw",
    "CycleIncrements",
    "cycle_increments",
    "secular_rate_fit",
    "block_average",
    "lowpass",
    "filtered_rate",
    "omega_world",
    "max_cycle_rate",
]


def yaw_from_quat(quat: np.ndarray) -> np.ndarray:
    """Yaw ``2·atan2(q_z, q_w)`` [rad] of ``(..., 4)`` scalar-first quaternions, in ``(−2π, 2π]``.

    Wrap with ``np.angle(np.exp(1j * yaw))`` or unwrap along time (:func:`unwrapped_yaw`).
    """
    q = np.asarray(quat, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"quat: expected shape (..., 4) [w, x, y, z], got {q.shape}")
    return 2.0 * np.arctan2(q[..., 3], q[..., 0])


def unwrapped_yaw(quat: np.ndarray) -> np.ndarray:
    """Continuous yaw [rad] of a (T, 4) quaternion time series (``np.unwrap`` along time).

    Needs successive samples to differ by less than π in yaw (one stroboscopic sample per cycle
    turns by ~1.5 mrad in the paper case).
    """
    q = np.asarray(quat, dtype=float)
    if q.ndim != 2:
        raise ValueError(f"quat: expected a (T, 4) time series, got {q.shape}")
    return np.unwrap(yaw_from_quat(q))


def omega_world(quat: np.ndarray, omega_body: np.ndarray) -> np.ndarray:
    r"""World-frame angular velocity ``ω_w = R(q) ω_b`` of (…, 4) quaternions and (…, 3) rates.

    MuJoCo's free-joint ``qvel[3:6]`` is the angular velocity in body axes.
    """
    R = quat_to_matrix(np.asarray(quat, dtype=float), normalise=True)
    return np.einsum("...ij,...j->...i", R, np.asarray(omega_body, dtype=float))


class CycleIncrements(NamedTuple):
    """Per-cycle rotations from a stroboscopic yaw series.

    ``increments``: (K,) ``ψ(t_{k+1}) − ψ(t_k)`` [rad]; ``mean``, ``std`` [rad]: over the
    increments after the first ``discard`` (population std, ``ddof = 0``); ``first``: the
    first increment (the start-up cycle) [rad]; ``count``: increments in the mean.
    """

    increments: np.ndarray
    mean: float
    std: float
    first: float
    count: int


def cycle_increments(yaw_strobe: np.ndarray, *, discard: int = 1) -> CycleIncrements:
    """Per-cycle rotation statistics of an unwrapped stroboscopic yaw series [rad].

    Args:
      yaw_strobe: (K+1,) unwrapped yaw at the start of each cycle.
      discard: leading increments excluded from the mean (start-up transient).
    """
    y = np.asarray(yaw_strobe, dtype=float)
    if y.ndim != 1:
        raise ValueError(f"yaw_strobe: expected shape (K+1,), got {y.shape}")
    if int(discard) != discard or discard < 0:
        raise ValueError(f"discard: must be an integer >= 0, got {discard!r}")
    inc = np.diff(y)
    kept = inc[int(discard) :]
    if kept.size == 0:
        raise ValueError(f"yaw_strobe: {inc.size} increment(s), none left after discard = {discard}")
    return CycleIncrements(
        increments=inc,
        mean=float(kept.mean()),
        std=float(kept.std()),
        first=float(inc[0]) if inc.size else float("nan"),
        count=int(kept.size),
    )


def secular_rate_fit(t: np.ndarray, yaw: np.ndarray) -> tuple[float, float]:
    r"""Least-squares line ``ψ ≈ ψ0 + ω̂ t`` through (unwrapped) yaw samples.

    Returns ``(ω̂ [rad/s], ψ0 [rad])``. Centred formula, ``ω̂ = Σ(t−t̄)(ψ−ψ̄)/Σ(t−t̄)²``, which
    stays accurate for 6·10⁵ samples and |ψ| ~ 10³ rad.
    """
    t, y = np.asarray(t, dtype=float), np.asarray(yaw, dtype=float)
    if t.ndim != 1 or t.shape != y.shape or t.size < 2:
        raise ValueError(f"t, yaw: expected equal shapes (T,) with T >= 2, got {t.shape}, {y.shape}")
    tm, ym = t.mean(), y.mean()
    dt = t - tm
    den = float(dt @ dt)
    if not den > 0:
        raise ValueError("t: needs at least two distinct times")
    slope = float(dt @ (y - ym)) / den
    return slope, float(ym - slope * tm)


def block_average(x: np.ndarray, block: int) -> np.ndarray:
    """Means of consecutive blocks of ``block`` samples along axis 0 (a trailing partial block
    is dropped)."""
    x = np.asarray(x, dtype=float)
    if int(block) != block or block < 1:
        raise ValueError(f"block: must be an integer >= 1, got {block!r}")
    n = (x.shape[0] // block) * block
    return x[:n].reshape((n // block, block) + x.shape[1:]).mean(axis=1)


def lowpass(x: np.ndarray, *, fs_hz: float, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass (``scipy.signal.butter`` in SOS form, ``sosfiltfilt``).

    Args:
      x: (T,) samples at rate ``fs_hz``.
      fs_hz: sampling rate [Hz].
      cutoff_hz: −3 dB cutoff of the single pass [Hz], below ``fs_hz/2``.
      order: filter order of the single pass (the forward–backward result has twice the
        attenuation slope and zero phase).
    """
    if not (fs_hz > 0 and 0 < cutoff_hz < fs_hz / 2):
        raise ValueError(f"cutoff_hz: must lie in (0, fs_hz/2) = (0, {fs_hz / 2:g}), got {cutoff_hz!r}")
    if int(order) != order or order < 1:
        raise ValueError(f"order: must be an integer >= 1, got {order!r}")
    sos = butter(int(order), cutoff_hz, btype="low", fs=fs_hz, output="sos")
    return sosfiltfilt(sos, np.asarray(x, dtype=float))


def filtered_rate(t: np.ndarray, omega_f: np.ndarray, *, edge_s: float) -> float:
    """Mean of the filtered rate over ``t[0] + edge_s ≤ t ≤ t[-1] − edge_s`` [rad/s]."""
    t, w = np.asarray(t, dtype=float), np.asarray(omega_f, dtype=float)
    keep = (t >= t[0] + edge_s) & (t <= t[-1] - edge_s)
    if not keep.any():
        raise ValueError(f"edge_s: {edge_s} s leaves no samples of a {t[-1] - t[0]:g} s series")
    return float(w[keep].mean())


def max_cycle_rate(force: np.ndarray, static: np.ndarray, capacity: np.ndarray, *, rate_hz: float) -> float:
    r"""Largest cycle rate [Hz] at which a prescribed path's actuator demand stays within capacity.

    Traversing a fixed path ``q(τ)``, ``τ = f t``, at rate ``f`` scales every velocity with
    ``f`` and every acceleration with ``f²``; with zero momentum the bus's motion is fixed by the
    shape's, so the inertial and velocity-product joint forces scale with ``g = (f/f_0)²``. A
    spring force depends on ``q`` only. From samples of the demand at rate ``f_0``,

    .. math::
        F(t; f) = (F_0(t) − S(t))\, g + S(t), \qquad |F(t; f)| \le C ,

    bounds ``g`` to an interval for each sample (all of ``g ≥ 0`` when its inertial part is zero
    and ``|S| ≤ C``, none when ``|S| > C``); their intersection is an interval
    ``[g_lo, g_hi]`` and the result is ``f_0 √g_hi`` (``inf`` when unbounded, 0 when empty).

    Args:
      force: (T, J) demand ``F_0`` of each joint at the sampled times, at rate ``rate_hz``.
      static: (T, J) its rate-independent part ``S`` (e.g. the slide spring force).
      capacity: (J,) ``C > 0`` of each joint.
      rate_hz: ``f_0`` [Hz].
    """
    F, S = np.asarray(force, dtype=float), np.asarray(static, dtype=float)
    C = np.broadcast_to(np.asarray(capacity, dtype=float), F.shape[-1:])
    if F.ndim != 2 or S.shape != F.shape:
        raise ValueError(f"force, static: expected equal shapes (T, J), got {F.shape}, {S.shape}")
    if not (np.all(C > 0) and rate_hz > 0):
        raise ValueError(f"capacity, rate_hz: must be > 0, got {C.tolist()}, {rate_hz!r}")
    a, b = F - S, S
    if np.any(np.abs(b[a == 0]) > np.broadcast_to(C, F.shape)[a == 0]):
        return 0.0
    nz = a != 0
    ends = np.stack([(-C - b)[nz] / a[nz], (C - b)[nz] / a[nz]])
    lo = float(max(0.0, ends.min(axis=0).max(initial=0.0)))
    hi = float(ends.max(axis=0).min(initial=np.inf))
    if lo > hi:
        return 0.0
    return float(rate_hz * np.sqrt(hi))
