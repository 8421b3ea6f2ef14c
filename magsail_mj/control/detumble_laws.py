r"""Magnetic detumble law beside the proportional B-dot (:mod:`magsail_mj.control.bdot`).

Every function works on stacks of body-axis vectors (``(..., 3)``, one row per spacecraft) with
component arithmetic only (no reductions through BLAS), so a batch of worlds and a single run that
calls it with one row get the same bits. The torque of a dipole m [A m²] in the field B [T] is
``τ = m × B`` (body axes); a stationary field seen from a body turning at ω has ``Ḃ_B = −ω × B_B``.

* **Bang-bang B-dot** (:func:`bang_bang_dipole`): ``m_i = −m_max,i sign(Ḃ_i)`` per axis, with the
  Ḃ estimate of the proportional law (finite difference or filtered). For the exact Ḃ = −ω × B,
  ``τ·ω = m·(B × ω) = −Σ m_max,i |(ω × B)_i| ≤ 0``: the coils take kinetic energy out at every
  instant, at full dipole on every axis where Ḃ is not zero.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "bang_bang_dipole",
]


def bang_bang_dipole(B_dot: np.ndarray, m_max_Am2: np.ndarray) -> np.ndarray:
    """Bang-bang B-dot ``m_i = −m_max,i sign(Ḃ_i)`` [A m²] for the field rate ``B_dot`` [T/s]
    (body axes, ``(..., 3)``): full dipole on every axis whose Ḃ is not zero, none where it is."""
    return -np.asarray(m_max_Am2, dtype=float) * np.sign(B_dot)
