r"""The MSAC four-phase shape cycle as smooth joint trajectories.

Shape coordinates of one wing (both wings are driven with the same values):

* ``phi`` [rad]: bending (hinge) angle of the wing relative to the bus, about the hinge axis;
* ``s`` [m]: slide displacement of the whole rigid wing away from its root (extension DOF);
  ``s = 0`` is the rest length, ``s_e > s_c`` are the extended and contracted values.

A cycle of period ``Δt`` visits four waypoints ``P0 → P1 → P2 → P3 → P0`` of the ``(phi, s)``
plane, one straight segment per phase. The paper's MSAC path is

====== ================= ===================== ==========================
phase  from → to          motion                duration
====== ================= ===================== ==========================
I→II   (φa, se)→(φb, se)  bend while extended   ``f0 Δt`` (``t_be``)
II→III (φb, se)→(φb, sc)  contract              ``f1 Δt`` (``t_c``)
III→IV (φb, sc)→(φa, sc)  bend back, contracted ``f2 Δt`` (``t_bc``)
IV→I   (φa, sc)→(φa, se)  extend                ``f3 Δt`` (``t_e``)
====== ================= ===================== ==========================

Inside phase ``j`` (local time ``τ ∈ [0, T_j]``, ``u = τ/T_j``) the shape moves along its
segment with a blend ``S(u)``:

.. math::
    q(τ) = P_j + S(u)\,(P_{j+1} - P_j),\quad
    \dot q = \frac{S'(u)}{T_j}(P_{j+1}-P_j),\quad
    \ddot q = \frac{S''(u)}{T_j^2}(P_{j+1}-P_j).

``min_jerk`` is the quintic ``S = 10u³ − 15u⁴ + 6u⁵`` (``S' = S'' = 0`` at both
ends, so position, velocity and acceleration are continuous across phases); ``cubic``
(``3u² − 2u³``, velocity-continuous) and ``cosine`` (``(1 − cos πu)/2``) exist to test that the
per-cycle rotation depends only on the path, not its timing.

Patterns (the waypoint sets):

* ``msac`` — the cycle above;
* ``reversed`` — the same loop traversed backwards, segment durations reversed too (bend while
  *contracted* first; the exact time reversal of ``msac``, T3);
* ``bend_only`` — bend ``φa → φb`` and back at fixed ``s = se`` (reciprocal, T2);
* ``extend_only`` — extend/contract at fixed ``φ = φa`` (reciprocal, T2).

All functions are vectorised over time; :func:`cycle_state_scalar` is the plain per-sample
reference the vectorised :func:`cycle_state` is tested against.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, NamedTuple

import numpy as np

from magsail_mj.checkpoint import restorable

__all__ = [
    "Blend",
    "Pattern",
    "CyclePath",
    "CycleState",
    "blend",
    "cycle_state",
    "cycle_state_scalar",
    "PHASE_LABELS",
]

Blend = Literal["min_jerk", "cubic", "cosine"]
Pattern = Literal["msac", "reversed", "bend_only", "extend_only"]

#: On-screen names of the four phases of the ``msac`` pattern.
PHASE_LABELS = ("I→II bend (extended)", "II→III contract", "III→IV bend back (contracted)", "IV→I extend")


def blend(u: np.ndarray | float, kind: Blend = "min_jerk") -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Blend ``S(u)`` and its derivatives ``S'(u)``, ``S''(u)`` for ``u`` in ``[0, 1]``.

    * ``min_jerk``: ``S = 10u³ − 15u⁴ + 6u⁵``, ``S' = 30u²(1−u)²``, ``S'' = 60u(1−u)(1−2u)``;
    * ``cubic``: ``S = 3u² − 2u³``, ``S' = 6u(1−u)``, ``S'' = 6 − 12u``;
    * ``cosine``: ``S = (1 − cos πu)/2``, ``S' = (π/2) sin πu``, ``S'' = (π²/2) cos πu``.

    ``u`` is clipped to ``[0, 1]``. Returns three arrays of the shape of ``u``.
    """
    u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
    if kind == "min_jerk":
        return (
            u**3 * (10.0 + u * (-15.0 + 6.0 * u)),
            30.0 * u**2 * (1.0 - u) ** 2,
            60.0 * u * (1.0 - u) * (1.0 - 2.0 * u),
        )
    if kind == "cubic":
        return u * u * (3.0 - 2.0 * u), 6.0 * u * (1.0 - u), 6.0 - 12.0 * u
    if kind == "cosine":
        return (0.5 * (1.0 - np.cos(np.pi * u)), 0.5 * np.pi * np.sin(np.pi * u), 0.5 * np.pi**2 * np.cos(np.pi * u))
    raise ValueError(f"kind: must be one of 'min_jerk', 'cubic', 'cosine', got {kind!r}")


@restorable
class CycleState(NamedTuple):
    """Desired shape state at the requested times (arrays of the shape of ``t``).

    ``phi``, ``phi_dot``, ``phi_ddot`` [rad, rad/s, rad/s²]; ``s``, ``s_dot``, ``s_ddot``
    [m, m/s, m/s²]; ``phase`` (int, 0..3) the phase index; ``cycle`` (int) the cycle index.
    """

    phi: np.ndarray
    phi_dot: np.ndarray
    phi_ddot: np.ndarray
    s: np.ndarray
    s_dot: np.ndarray
    s_ddot: np.ndarray
    phase: np.ndarray
    cycle: np.ndarray


@restorable
@dataclass(frozen=True)
class CyclePath:
    """A periodic four-phase shape path.

    Attributes:
      phi_a_rad: bend limit ``φa`` (start of the cycle) [rad].
      phi_b_rad: bend limit ``φb`` [rad]; signed (the stroke is ``φa − φb``).
      s_e_m: extended slide value ``se`` [m].
      s_c_m: contracted slide value ``sc`` [m] (``sc < se`` for a non-degenerate cycle).
      period_s: cycle period ``Δt = 1/f`` [s].
      fractions: ``(t_be, t_c, t_bc, t_e)/Δt``, each > 0, summing to 1.
      blend: blend of each phase (see :func:`blend`).
      pattern: waypoint set (see module docs).
    """

    phi_a_rad: float
    phi_b_rad: float
    s_e_m: float
    s_c_m: float
    period_s: float
    fractions: tuple[float, float, float, float] = (0.4, 0.1, 0.4, 0.1)
    blend: Blend = "min_jerk"
    pattern: Pattern = "msac"

    def __post_init__(self) -> None:
        for name in ("phi_a_rad", "phi_b_rad", "s_e_m", "s_c_m", "period_s"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise ValueError(f"{name}: must be finite, got {v!r}")
        if not self.period_s > 0:
            raise ValueError(f"period_s: must be > 0, got {self.period_s!r}")
        fr = tuple(float(x) for x in self.fractions)
        if len(fr) != 4 or any(not x > 0 for x in fr) or abs(sum(fr) - 1.0) > 1e-9:
            raise ValueError(f"fractions: need four values > 0 summing to 1, got {self.fractions!r}")
        object.__setattr__(self, "fractions", fr)
        if self.pattern not in ("msac", "reversed", "bend_only", "extend_only"):
            raise ValueError(
                f"pattern: must be one of 'msac', 'reversed', 'bend_only', 'extend_only', got {self.pattern!r}"
            )
        blend(0.5, self.blend)  # validates the blend name

    # ------------------------------------------------------------------ geometry
    @property
    def waypoints(self) -> np.ndarray:
        """(5, 2) waypoints ``(phi, s)`` of the cycle, first repeated at the end."""
        a, b, e, c = self.phi_a_rad, self.phi_b_rad, self.s_e_m, self.s_c_m
        pts = {
            "msac": [(a, e), (b, e), (b, c), (a, c)],
            "reversed": [(a, e), (a, c), (b, c), (b, e)],
            "bend_only": [(a, e), (b, e), (b, e), (a, e)],
            "extend_only": [(a, e), (a, c), (a, c), (a, e)],
        }[self.pattern]
        return np.array(pts + [pts[0]], dtype=float)

    @property
    def segment_fractions(self) -> tuple[float, float, float, float]:
        """Durations of the four path segments as fractions of ``Δt``.

        ``fractions`` for every pattern except ``reversed``, whose segments are those of the
        ``msac`` loop in reverse order, so they take ``(t_e, t_bc, t_c, t_be)``: the reversed
        cycle is the exact time reversal of the MSAC cycle.
        """
        f = self.fractions
        return (f[3], f[2], f[1], f[0]) if self.pattern == "reversed" else f

    @property
    def phase_bounds_s(self) -> np.ndarray:
        """(5,) start times of the path segments within a cycle, ending with ``Δt`` [s]."""
        return self.period_s * np.concatenate([[0.0], np.cumsum(self.segment_fractions)])

    @property
    def initial(self) -> tuple[float, float]:
        """Shape ``(phi, s)`` at the start of every cycle (Phase I) [rad, m]."""
        p = self.waypoints[0]
        return float(p[0]), float(p[1])

    @property
    def frequency_hz(self) -> float:
        """Cycle frequency ``1/Δt`` [Hz]."""
        return 1.0 / self.period_s


def cycle_state(path: CyclePath, t: np.ndarray | float) -> CycleState:
    """Desired shape state of ``path`` at times ``t`` [s] (vectorised; ``t >= 0``).

    Cycle ``k = floor(t/Δt)``, local time ``τ = t − kΔt``, phase ``j`` with
    ``b_j ≤ τ < b_{j+1}`` (``b`` = :attr:`CyclePath.phase_bounds_s`); see the module docs for
    the equations.
    """
    t = np.asarray(t, dtype=float)
    if np.any(~np.isfinite(t)) or np.any(t < 0):
        raise ValueError("t: times must be finite and >= 0")
    T = path.period_s
    cyc = np.floor(t / T)
    tau = t - cyc * T
    # round-off: tau may equal T within an ulp when t is a multiple of T
    wrap = tau >= T
    cyc = np.where(wrap, cyc + 1, cyc)
    tau = np.where(wrap, tau - T, tau)
    bounds = path.phase_bounds_s
    j = np.clip(np.searchsorted(bounds, tau, side="right") - 1, 0, 3)
    dur = np.diff(bounds)[j]
    u = (tau - bounds[j]) / dur
    S, dS, ddS = blend(u, path.blend)
    wp = path.waypoints
    p0, d = wp[j], wp[j + 1] - wp[j]
    return CycleState(
        phi=p0[..., 0] + S * d[..., 0],
        phi_dot=dS / dur * d[..., 0],
        phi_ddot=ddS / dur**2 * d[..., 0],
        s=p0[..., 1] + S * d[..., 1],
        s_dot=dS / dur * d[..., 1],
        s_ddot=ddS / dur**2 * d[..., 1],
        phase=j.astype(np.int64),
        cycle=cyc.astype(np.int64),
    )


def cycle_state_scalar(path: CyclePath, t: float) -> tuple[float, float, float, float, float, float, int]:
    """Plain per-sample reference of :func:`cycle_state` (one time, Python arithmetic).

    Returns ``(phi, phi_dot, phi_ddot, s, s_dot, s_ddot, phase)``.
    """
    T = path.period_s
    k = math.floor(t / T)
    tau = t - k * T
    if tau >= T:
        tau -= T
    start = 0.0
    for j, f in enumerate(path.segment_fractions):
        dur = f * T
        if tau < start + dur or j == 3:
            break
        start += dur
    u = min(max((tau - start) / dur, 0.0), 1.0)
    if path.blend == "min_jerk":
        S, dS, ddS = 10 * u**3 - 15 * u**4 + 6 * u**5, 30 * u**2 * (1 - u) ** 2, 60 * u * (1 - u) * (1 - 2 * u)
    elif path.blend == "cubic":
        S, dS, ddS = 3 * u**2 - 2 * u**3, 6 * u * (1 - u), 6 - 12 * u
    else:
        S, dS, ddS = (
            0.5 * (1 - math.cos(math.pi * u)),
            0.5 * math.pi * math.sin(math.pi * u),
            0.5 * math.pi**2 * math.cos(math.pi * u),
        )
    wp = path.waypoints
    (p0, s0), (p1, s1) = wp[j], wp[j + 1]
    return (
        p0 + S * (p1 - p0),
        dS / dur * (p1 - p0),
        ddS / dur**2 * (p1 - p0),
        s0 + S * (s1 - s0),
        dS / dur * (s1 - s0),
        ddS / dur**2 * (s1 - s0),
        j,
    )
