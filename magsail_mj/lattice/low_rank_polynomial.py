r"""Caughey damping as a polynomial of the sparse stiffness plus a low-rank correction.

The dense Caughey matrix (Eq. 15 of the paper, :func:`~magsail_mj.lattice.modes.caughey_matrix`)

.. math::

    \boldsymbol\gamma=\mathbf M\Phi\,\mathrm{diag}(c_n)\,\Phi^T\mathbf M,\qquad c_n=2\xi_n\omega_n ,

costs one dense ``3n × 3n`` mat-vec per evaluation. Written with the mass-scaled stiffness
:math:`\mathbf A=\mathbf M^{-1/2}\mathbf K\mathbf M^{-1/2}` (eigenpairs
:math:`(\lambda_n=\omega_n^2,\ \boldsymbol\psi_n=\mathbf M^{1/2}\boldsymbol\phi_n)`, orthonormal), any
:math:`\boldsymbol\gamma` whose modal rates are a function :math:`c(\lambda)` is
:math:`\mathbf M^{1/2}c(\mathbf A)\mathbf M^{1/2}`. The schedules of the paper are such a function
above mode ``n_low`` (``paper_max``: :math:`c=2\xi_{cap}\sqrt\lambda`, ξ = 10 on these lattices;
``capped_rayleigh``: :math:`c\propto\lambda`) and arbitrary below it. So

.. math::

    \boldsymbol\gamma\approx\mathbf M^{1/2}p(\mathbf A)\mathbf M^{1/2}
    +\mathbf U\,\mathrm{diag}\big(c_j-p(\lambda_j)\big)\,\mathbf U^T,\qquad
    \mathbf U=\mathbf M\Phi_C ,

with :math:`p` a polynomial of degree :math:`d` fitted to :math:`c_n` over the modes above
``n_low`` (the set :math:`H`) and :math:`C` the remaining modes (rigid and the first ``n_low``
elastic ones), which the correction makes exact. A polynomial of :math:`\mathbf A` is diagonal
in the modal basis, so the operator couples no modes: mode :math:`n` gets the rate
:math:`p(\lambda_n)` (:math:`n\in H`) or :math:`c_n` (:math:`n\in C`), i.e. the damping ratio
:math:`\zeta_n=p(\lambda_n)/(2\omega_n)` with the relative error
:math:`|p(\lambda_n)/c_n-1|\le` ``rtol`` stated per mode (:attr:`PolynomialCaughey.ratio_error`).
For any velocity :math:`\lVert(\boldsymbol\gamma_p-\boldsymbol\gamma)\mathbf v\rVert_{\mathbf M^{-1}}
\le\mathrm{rtol}\,\lVert\boldsymbol\gamma\mathbf v\rVert_{\mathbf M^{-1}}`.

:math:`p` is the relative minimax fit on the actual eigenvalues of :math:`H` (Lawson's
iteratively reweighted least squares in the Chebyshev basis of the interval
:math:`[\lambda_{min}^H,\lambda_{max}^H]`), of the smallest degree that meets ``rtol``. It is
applied with Clenshaw's recurrence: :math:`d` sparse mat-vecs of :math:`\mathbf A` and a
``3n × |C|`` low-rank product, against the dense ``3n × 3n`` one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.polynomial import chebyshev

from magsail_mj.lattice.geometry import stiffness_matrix
from magsail_mj.lattice.modes import Modes

__all__ = ["PolynomialCaughey", "caughey_polynomial", "relative_minimax_chebyshev"]

LAWSON_ITERATIONS = 500
"""Most reweighting passes of the relative minimax fit."""
LAWSON_RTOL = 1e-4
"""The fit stops when a pass lowers the largest relative error by less than this fraction."""


def relative_minimax_chebyshev(
    lam: np.ndarray, target: np.ndarray, *, degree: int, interval: tuple[float, float]
) -> tuple[np.ndarray, float]:
    r"""Chebyshev coefficients of :math:`p` minimising :math:`\max_i|p(\lambda_i)/t_i-1|`.

    Lawson's algorithm: weighted least squares with weights :math:`w_i/t_i^2`, the weights
    multiplied by the current error after each pass (converges to the discrete minimax).

    Args:
      lam: ``(m,)`` points [rad²/s²].
      target: ``(m,)`` positive values :math:`t_i` [1/s].
      degree: polynomial degree (>= 0).
      interval: ``(a, b)`` with ``a < b``, the Chebyshev interval (mapped to ``[-1, 1]``).
    Returns:
      ``(degree + 1,)`` coefficients in the Chebyshev basis of ``interval`` and the largest
      relative error on ``lam``.
    """
    if int(degree) != degree or degree < 0:
        raise ValueError(f"degree: must be an integer >= 0, got {degree!r}")
    if not np.all(target > 0):
        raise ValueError("target: must be > 0 everywhere")
    a, b = interval
    V = chebyshev.chebvander(_to_unit(lam, a, b), int(degree)) / target[:, None]
    w = np.full(lam.size, 1.0 / lam.size)
    best, best_err = None, np.inf
    for _ in range(LAWSON_ITERATIONS):
        Vw = V * w[:, None]  # weighted normal equations (the Chebyshev basis keeps them well conditioned)
        coef = np.linalg.solve(Vw.T @ V, Vw.sum(axis=0))
        r = np.abs(V @ coef - 1.0)
        err = float(r.max())
        if err < best_err * (1.0 - LAWSON_RTOL):
            best, best_err = coef, err
        elif err >= best_err:
            break  # no longer improving: the discrete minimax is reached to LAWSON_RTOL
        w = w * r
        if not w.sum() > 0:
            break
        w /= w.sum()
    return best, best_err


def _to_unit(lam: np.ndarray, a: float, b: float) -> np.ndarray:
    return (2.0 * lam - (a + b)) / (b - a)


@dataclass(frozen=True)
class PolynomialCaughey:
    r""":math:`\boldsymbol\gamma_p=\mathbf M^{1/2}p(\mathbf A)\mathbf M^{1/2}+\mathbf U\mathrm{diag}(d)\mathbf U^T`.

    Attributes:
      A: ``(3n, 3n)`` sparse CSR :math:`\mathbf M^{-1/2}\mathbf K\mathbf M^{-1/2}` [1/s²].
      two_x: ``2 X`` = :math:`(4\mathbf A-2(a+b)\mathbf I)/(b-a)`, the recurrence's matrix (dimensionless).
      sqrt_m: ``(3n,)`` :math:`\sqrt{m}` per DOF [kg^1/2].
      coef: ``(d + 1,)`` Chebyshev coefficients of :math:`p` on ``interval`` [1/s].
      interval: ``(a, b)`` the fit interval of :math:`\lambda` [rad²/s²].
      U: ``(3n, r)`` columns :math:`\mathbf M\boldsymbol\phi_j` of the corrected modes [kg^1/2]
        (stored as ``dtype``).
      d: ``(r,)`` :math:`c_j-p(\lambda_j)` [1/s].
      modes_index: ``(r,)`` the corrected mode columns.
      rates: ``(3n,)`` the modal rates the operator applies (:math:`p(\lambda_n)` or :math:`c_n`) [1/s].
      ratio_error: ``(3n,)`` relative error of each mode's damping ratio against the schedule
        (0 for the corrected modes and for undamped ones).
    """

    A: sp.csr_matrix
    two_x: sp.csr_matrix
    sqrt_m: np.ndarray
    coef: np.ndarray
    interval: tuple[float, float]
    U: np.ndarray
    d: np.ndarray
    modes_index: np.ndarray
    rates: np.ndarray
    ratio_error: np.ndarray

    @property
    def degree(self) -> int:
        """Degree of :math:`p` (= sparse mat-vecs per application)."""
        return self.coef.size - 1

    def effective_ratios(self, omega: np.ndarray) -> np.ndarray:
        r"""Damping ratio each mode gets, :math:`\zeta_n=\mathrm{rate}_n/(2\omega_n)` (0 for rigid modes)."""
        omega = np.asarray(omega, dtype=float)
        return np.divide(self.rates, 2.0 * omega, out=np.zeros_like(self.rates), where=omega > 0)

    def poly_apply(self, y: np.ndarray) -> np.ndarray:
        r""":math:`p(\mathbf A)\mathbf y` by Clenshaw's recurrence (``y``: ``(3n,)`` or ``(3n, k)``).

        With :math:`\mathbf X=(2\mathbf A-(a+b)\mathbf I)/(b-a)` (``[a, b]`` onto ``[-1, 1]``):
        :math:`b_k=c_k\mathbf y+2\mathbf Xb_{k+1}-b_{k+2}`, :math:`p(\mathbf A)\mathbf y=c_0\mathbf y+\mathbf Xb_1-b_2`.
        """
        c = self.coef
        if c.size == 1:
            return c[0] * y
        X2 = self.two_x
        b1 = c[-1] * y
        b2 = np.zeros_like(b1)
        for ck in c[-2:0:-1]:
            t = X2 @ b1
            t -= b2
            t += ck * y
            b1, b2 = t, b1
        out = X2 @ b1
        out *= 0.5
        out -= b2
        out += c[0] * y
        return out

    def apply(self, v: np.ndarray) -> np.ndarray:
        """:math:`\\boldsymbol\\gamma_p\\mathbf v` [N] of body-frame velocities ``v`` ``(3n,)``/``(3n, k)`` [m/s]."""
        col = (slice(None),) + (None,) * (v.ndim - 1)  # broadcast the per-DOF/per-mode factors over columns
        sm = self.sqrt_m[col]
        out = self.poly_apply(sm * v)
        out *= sm
        w = self.U.T @ v.astype(self.U.dtype, copy=False)
        w *= self.d[col].astype(self.U.dtype, copy=False)
        out += self.U @ w
        return out


def _fit_set(modes: Modes, ratios: np.ndarray, n_low: int) -> np.ndarray:
    first = modes.n_rigid + int(n_low)
    if not modes.n_rigid < first < modes.n_dof:
        raise ValueError(f"n_low: must be in 1..{modes.n_dof - modes.n_rigid - 1}, got {n_low!r}")
    idx = np.arange(first, modes.n_dof)
    return idx[ratios[idx] * modes.omega[idx] > 0]


def caughey_polynomial(
    modes: Modes,
    ratios: np.ndarray,
    *,
    nodes: np.ndarray,
    struts: np.ndarray,
    k: np.ndarray,
    n_low: int = 100,
    rtol: float = 0.02,
    max_degree: int = 30,
    dtype=np.float64,
) -> PolynomialCaughey:
    r"""Build :class:`PolynomialCaughey` for ``modes`` and ``ratios`` (module docstring).

    Args:
      modes: from :func:`~magsail_mj.lattice.modes.lattice_modes` of the same lattice.
      ratios: ``(3n,)`` damping ratios (:func:`~magsail_mj.lattice.modes.damping_ratios`).
      nodes, struts, k: the lattice (``K`` is assembled at ``nodes``) [m], indices, [N/m].
      n_low: modes above the first ``n_low`` elastic ones are fitted, the others corrected.
      rtol: largest relative error of a fitted mode's damping ratio (0 < rtol < 1).
      max_degree: give up above this degree.
      dtype: storage/product type of the low-rank factor ``U`` (``np.float32`` halves its memory
        traffic; the correction then carries float32 round-off, ~1e-7 of :math:`p(\lambda_j)`).
    Raises:
      ValueError: bad arguments, or no degree up to ``max_degree`` meets ``rtol``.
    """
    if not 0.0 < rtol < 1.0:
        raise ValueError(f"rtol: must be in (0, 1), got {rtol!r}")
    if int(max_degree) != max_degree or max_degree < 1:
        raise ValueError(f"max_degree: must be an integer >= 1, got {max_degree!r}")
    if np.dtype(dtype) not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise ValueError(f"dtype: must be float32 or float64, got {dtype!r}")
    ratios = np.asarray(ratios, dtype=float)
    if ratios.shape != modes.omega.shape:
        raise ValueError(f"ratios: expected shape {modes.omega.shape}, got {ratios.shape}")
    target = 2.0 * ratios * modes.omega
    lam = modes.omega**2
    H = _fit_set(modes, ratios, n_low)
    a, b = float(lam[H].min()), float(lam[H].max())
    if not b > a:
        b = a * (1.0 + 1e-6) + 1e-300
    for degree in range(int(max_degree) + 1):
        coef, err = relative_minimax_chebyshev(lam[H], target[H], degree=degree, interval=(a, b))
        if err <= rtol:
            break
    else:
        raise ValueError(f"rtol: {rtol:g} not reached up to max_degree = {max_degree} (error {err:.3g})")
    p = chebyshev.chebval(_to_unit(lam, a, b), coef)
    C = np.setdiff1d(np.arange(modes.n_dof), H)
    rates = target.copy()
    rates[H] = p[H]
    ratio_error = np.zeros_like(target)
    ratio_error[H] = np.abs(p[H] / target[H] - 1.0)
    sqrt_m = np.sqrt(modes.mass_diag)
    K = stiffness_matrix(np.asarray(nodes, dtype=float), np.asarray(struts), np.asarray(k, dtype=float))
    if K.shape != (modes.n_dof, modes.n_dof):
        raise ValueError(f"nodes: stiffness of shape {K.shape} does not match {modes.n_dof} modal DOF")
    Minv = sp.diags(1.0 / sqrt_m)
    A = (Minv @ K @ Minv).tocsr()
    A.sort_indices()
    X2 = ((4.0 / (b - a)) * A - (2.0 * (a + b) / (b - a)) * sp.identity(A.shape[0], format="csr")).tocsr()
    X2.sort_indices()
    return PolynomialCaughey(
        A=A,
        two_x=X2,
        sqrt_m=sqrt_m,
        coef=coef,
        interval=(a, b),
        U=np.ascontiguousarray(modes.mass_diag[:, None] * modes.phi[:, C], dtype=dtype),
        d=target[C] - p[C],
        modes_index=C,
        rates=rates,
        ratio_error=ratio_error,
    )
