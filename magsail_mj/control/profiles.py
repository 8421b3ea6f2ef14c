"""Open-loop torque profiles of the distributed-vs-centralised experiment.

Robb et al. 2022a: Table 1 (bang-bang-off) and Eq. 9 (versine-shaped; its third line's
denominator is read as ``t_v``, not the printed ``t``).
With ``t₋ = t_end/3``, ``t₀ = 2 t_end/3``:

bang-bang-off: ``+τ_max`` on ``[0, t₋]``, ``−τ_max`` on ``(t₋, t₀]``, 0 after.

versine (ramp time ``t_v``, default ``t_end/10``)::

    ½[1 − cos(π t/t_v)]                      0 ≤ t ≤ t_v
    1                                        t_v < t ≤ t₋ − t_v
    cos(π/2 · (t − (t₋ − t_v))/t_v)          t₋ − t_v < t ≤ t₋ + t_v
    −1                                       t₋ + t_v < t ≤ t₀ − t_v
    −½[1 + cos(π (t₀ − t_v − t)/t_v)]        t₀ − t_v < t ≤ t₀
    0                                        t > t₀

times ``τ_max``. Both are rest-to-rest for a rigid body (zero net impulse).

versine as printed (``versine_printed``): Eq. 9 with its third line as the paper prints it,
``cos(π/2 · (t₋ − t_v − t)/t)`` on ``t₋ − t_v < t ≤ t₋ + t_v``, every other line as above.
An option to test the paper as printed; it is not rest-to-rest (see :func:`versine_printed`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["bang_bang_off", "versine", "versine_printed", "torque_profile", "PROFILE_KINDS"]

PROFILE_KINDS: tuple[str, ...] = ("bang_bang_off", "versine", "versine_printed")
"""The profile kinds :func:`torque_profile` dispatches on."""


def bang_bang_off(t, *, tau_max: float, t_end: float):
    """Bang-bang-off profile at time(s) ``t`` [s]; returns N m."""
    t = np.asarray(t, dtype=float)
    t_minus, t_zero = t_end / 3.0, 2.0 * t_end / 3.0
    out = np.where(t <= t_minus, tau_max, np.where(t <= t_zero, -tau_max, 0.0))
    return np.where(t < 0, 0.0, out)


def versine(t, *, tau_max: float, t_end: float, t_v: float | None = None):
    """Versine-shaped profile (Robb et al. 2022a, Eq. 9, with its misprint corrected) at time(s) ``t`` [s]; N m."""
    t = np.asarray(t, dtype=float)
    t_v = t_end / 10.0 if t_v is None else float(t_v)
    t_minus, t_zero = t_end / 3.0, 2.0 * t_end / 3.0
    if not 0 < t_v <= t_minus / 2:
        raise ValueError(f"t_v: must be in (0, t_end/6], got {t_v}")
    conds = [
        t < 0,
        t <= t_v,
        t <= t_minus - t_v,
        t <= t_minus + t_v,
        t <= t_zero - t_v,
        t <= t_zero,
    ]
    vals = [
        np.zeros_like(t),
        0.5 * (1.0 - np.cos(np.pi * t / t_v)),
        np.ones_like(t),
        np.cos(0.5 * np.pi * (t - (t_minus - t_v)) / t_v),
        -np.ones_like(t),
        -0.5 * (1.0 + np.cos(np.pi * (t_zero - t_v - t) / t_v)),
    ]
    return tau_max * np.select(conds, vals, default=0.0)


def versine_printed(t, *, tau_max: float, t_end: float, t_v: float | None = None):
    """Versine-shaped profile of Robb et al. 2022a, Eq. 9, exactly as printed, at time(s) ``t`` [s]; N m.

    The paper prints the third line (``t₋ − t_v < t ≤ t₋ + t_v``) with ``t``, not ``t_v``, in
    the denominator::

        τ/τ_max = cos(π/2 · (t₋ − t_v − t)/t)

    Every other line is that of :func:`versine` (the corrected profile, which has ``t_v`` there).
    The two agree outside ``(t₋ − t_v, t₋ + t_v]``. The printed line is +1 at ``t = t₋ − t_v``
    (continuous with the plateau) but reaches only ``cos(π t_v/(t₋ + t_v))`` at ``t = t₋ + t_v``
    (≈ 0.748 for the defaults ``t_v = t_end/10``, ``t₋ = t_end/3``) instead of −1, so the torque
    jumps by ``−τ_max [1 + cos(π t_v/(t₋ + t_v))]`` to −τ_max there. The positive lobe is then
    longer than the negative one: the net impulse is
    ``τ_max ∫_{t₋−t_v}^{t₋+t_v} [cos(π/2 · (t₋ − t_v − t)/t) − cos(π/2 · (t − t₋ + t_v)/t_v)] dt``
    (the corrected line integrates to zero over that window), ≈ +1.77 τ_max t_v for the defaults
    (31.9 N m s for τ_max = 0.1 N m, t_end = 1800 s),
    so a rigid body is not brought to rest: it keeps turning at ``ω = impulse/I`` after ``t₀``.
    An option to test the paper as printed, never a default.
    """
    t = np.asarray(t, dtype=float)
    t_v_ = t_end / 10.0 if t_v is None else float(t_v)
    t_minus = t_end / 3.0
    out = versine(t, tau_max=tau_max, t_end=t_end, t_v=t_v)  # validates t_v
    window = (t > t_minus - t_v_) & (t <= t_minus + t_v_)
    with np.errstate(divide="ignore", invalid="ignore"):
        printed = tau_max * np.cos(0.5 * np.pi * (t_minus - t_v_ - t) / t)
    return np.where(window, printed, out)


def torque_profile(kind: str, t, *, tau_max: float, t_end: float, t_v: float | None = None):
    """Dispatch on ``kind`` = ``"bang_bang_off"`` | ``"versine"`` | ``"versine_printed"``."""
    if kind == "bang_bang_off":
        return bang_bang_off(t, tau_max=tau_max, t_end=t_end)
    if kind == "versine":
        return versine(t, tau_max=tau_max, t_end=t_end, t_v=t_v)
    if kind == "versine_printed":
        return versine_printed(t, tau_max=tau_max, t_end=t_end, t_v=t_v)
    raise ValueError(f"kind: must be one of {list(PROFILE_KINDS)}, got {kind!r}")
