"""Piecewise-cubic tables on a uniform time grid with O(1) evaluation.

Each channel is a cubic polynomial per grid interval, stored as coefficients ``c[k, p, ch]`` of
τ^p with τ = t − t_k ∈ [0, h]. Evaluation finds the interval by one division (no search) and
runs Horner's rule on one row: cost independent of the table length.

Two constructors:

* :meth:`CubicTable.hermite` – cubic Hermite from values and exact derivatives at the nodes
  (used for r with v, and v with a; error ≈ h⁴/384 · max|y⁗|).
* :meth:`CubicTable.spline` – not-a-knot cubic spline through node values (SciPy
  ``CubicSpline``), used where no derivative is available (the magnetic field).
"""

from __future__ import annotations

import numpy as np
from scipy.interpolate import CubicSpline

__all__ = ["CubicTable"]


class CubicTable:
    """Piecewise cubic in t on the uniform grid t_k = t0 + k h, k = 0 … K.

    Args:
      t0: first node [s]; h: grid step [s]; coef: (K, 4, nch) coefficients of τ⁰ … τ³.
    """

    def __init__(self, t0: float, h: float, coef: np.ndarray) -> None:
        if not h > 0:
            raise ValueError(f"h: grid step must be > 0 s, got {h!r}")
        coef = np.ascontiguousarray(coef, dtype=float)
        if coef.ndim != 3 or coef.shape[1] != 4:
            raise ValueError(f"coef: must have shape (K, 4, nch), got {coef.shape}")
        self.t0 = float(t0)
        self.h = float(h)
        self.coef = coef
        self.K = coef.shape[0]
        self.t_end = self.t0 + self.K * self.h

    @property
    def nch(self) -> int:
        return self.coef.shape[2]

    @classmethod
    def hermite(cls, t0: float, h: float, y: np.ndarray, dy: np.ndarray) -> "CubicTable":
        """Cubic Hermite through node values ``y`` (K+1, nch) with node derivatives ``dy``."""
        y = np.asarray(y, dtype=float).reshape(len(y), -1)
        dy = np.asarray(dy, dtype=float).reshape(len(dy), -1)
        y0, y1, d0, d1 = y[:-1], y[1:], dy[:-1], dy[1:]
        dq = (y1 - y0) / h
        c2 = (3.0 * dq - 2.0 * d0 - d1) / h
        c3 = (d0 + d1 - 2.0 * dq) / (h * h)
        return cls(t0, h, np.stack([y0, d0, c2, c3], axis=1))

    @classmethod
    def spline(cls, t0: float, h: float, y: np.ndarray) -> "CubicTable":
        """Not-a-knot cubic spline through node values ``y`` (K+1, nch) (needs K ≥ 3)."""
        y = np.asarray(y, dtype=float).reshape(len(y), -1)
        t = t0 + h * np.arange(len(y))
        if len(y) < 4:
            # too few nodes for not-a-knot: fall back to a cubic Hermite with spline slopes
            cs = CubicSpline(t, y, axis=0, bc_type="natural")
            return cls.hermite(t0, h, y, cs(t, 1))
        cs = CubicSpline(t, y, axis=0, bc_type="not-a-knot")
        # cs.c: (4, K, nch), highest power first
        return cls(t0, h, np.transpose(cs.c[::-1], (1, 0, 2)))

    @classmethod
    def concat(cls, tables: list["CubicTable"]) -> "CubicTable":
        """Stack the channels of tables that share one grid."""
        t0, h, K = tables[0].t0, tables[0].h, tables[0].K
        for tb in tables[1:]:
            if (tb.t0, tb.h, tb.K) != (t0, h, K):
                raise ValueError("tables: all tables must share one grid (t0, h, K)")
        return cls(t0, h, np.concatenate([tb.coef for tb in tables], axis=2))

    def _locate(self, t: float) -> tuple[int, float]:
        s = (t - self.t0) / self.h
        i = int(s)
        if i >= self.K:
            i = self.K - 1
        elif i < 0:
            i = 0
        return i, t - (self.t0 + i * self.h)

    def __call__(self, t: float) -> np.ndarray:
        """Values of all channels at the scalar time ``t`` (nch,)."""
        i, tau = self._locate(t)
        c = self.coef[i]
        return c[0] + tau * (c[1] + tau * (c[2] + tau * c[3]))

    def value_and_derivative(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Values and time derivatives of all channels at the scalar time ``t``."""
        out = self.value_and_derivative_rows(t)
        return out[0], out[1]

    def value_and_derivative_rows(self, t: float) -> np.ndarray:
        """(2, nch) array: row 0 the values, row 1 the time derivatives at scalar ``t``
        (one 2×4 by 4×nch product)."""
        i, tau = self._locate(t)
        t2 = tau * tau
        P = np.array(((1.0, tau, t2, t2 * tau), (0.0, 1.0, 2.0 * tau, 3.0 * t2)))
        return P @ self.coef[i]

    def evaluate(self, t: np.ndarray) -> np.ndarray:
        """Vectorised evaluation at times ``t`` (n,) → (n, nch)."""
        t = np.asarray(t, dtype=float)
        i = np.clip(np.floor((t - self.t0) / self.h).astype(int), 0, self.K - 1)
        tau = (t - (self.t0 + i * self.h))[..., None]
        c = self.coef[i]
        return c[..., 0, :] + tau * (c[..., 1, :] + tau * (c[..., 2, :] + tau * c[..., 3, :]))
