r"""Surface flatness: total-least-squares average plane and surface standard deviation.

Robb et al. 2022a, surface standard deviation, applied to the top-layer nodes (``N^2`` points), at
every recorded time. Vectorised over time: ``points`` may be ``(n, 3)`` or ``(T, n, 3)``.

The plane normal is the right singular vector with the smallest singular value of the centred
point matrix ``X`` (``n × 3``). It is computed as the eigenvector of the smallest eigenvalue of
the 3×3 scatter matrix ``X^T X`` (the same vector; one batched ``eigh`` per time series). The
heights are then recomputed from the points, ``h_i = (x_i - x̄)·n̂``, so the SD keeps full
precision (it is not taken from the eigenvalue, which would lose half the digits).
"""

from __future__ import annotations

import numpy as np

from magsail_mj.estimation._arrays import as_point_series

__all__ = ["average_plane", "surface_heights", "surface_sd"]


def average_plane(points: np.ndarray, *, orient: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    r"""Total-least-squares plane through a point set.

    Centroid :math:`\bar x = \frac1n\sum_i x_i`; unit normal :math:`\hat n` = right singular
    vector of the smallest singular value of the centred matrix
    :math:`X = [x_i - \bar x]_i` (computed from :math:`X^{\mathsf T}X`).

    Args:
      points: ``(n, 3)`` or ``(T, n, 3)`` positions [m], ``n >= 3``, any frame.
      orient: optional ``(3,)`` or ``(T, 3)`` direction; the normal's sign is chosen so that
        ``n̂ · orient >= 0`` (e.g. the best-fit body ``z1`` axis, ``R[..., :, 2]``). Without it
        the component of largest magnitude of ``n̂`` is made positive (deterministic).

    Returns:
      ``(centroid, normal)``, each ``(3,)`` or ``(T, 3)``, in the frame of ``points``.
    """
    x = as_point_series(points, "points", min_points=3)
    c = x.mean(axis=-2)
    X = x - c[..., None, :]
    C = np.matmul(np.swapaxes(X, -1, -2), X)
    _, vecs = np.linalg.eigh(C)
    nrm = vecs[..., :, 0]
    if orient is None:
        k = np.argmax(np.abs(nrm), axis=-1)
        s = np.take_along_axis(nrm, k[..., None], axis=-1)[..., 0]
    else:
        o = np.asarray(orient, dtype=float)
        if o.shape[-1:] != (3,) or o.ndim > nrm.ndim:
            raise ValueError(f"orient: expected shape (3,) or {nrm.shape}, got {o.shape}")
        s = np.sum(nrm * o, axis=-1)
    nrm = np.where((s < 0)[..., None], -nrm, nrm)
    return c, nrm


def surface_heights(points: np.ndarray, *, orient: np.ndarray | None = None) -> np.ndarray:
    r"""Signed normal distances :math:`h_i = (x_i-\bar x)\cdot\hat n` [m].

    Returns ``(n,)`` or ``(T, n)``; sign follows :func:`average_plane`'s ``orient``.
    """
    x = as_point_series(points, "points", min_points=3)
    c, n = average_plane(x, orient=orient)
    return np.einsum("...ij,...j->...i", x - c[..., None, :], n)


def surface_sd(points: np.ndarray) -> np.ndarray | float:
    r"""Surface standard deviation :math:`\sigma_{SD}=\sqrt{\frac1n\sum_i h_i^2}` [m].

    Population SD of the signed distances to the total-least-squares plane (their mean is zero
    by construction). Invariant under rigid motions of ``points``; zero for a flat set.

    Note: because the plane is fitted, any part of a deformation that is correlated with the
    in-plane coordinates (e.g. the odd ripple ``A sin(2πx/d)`` over ``x ∈ [-d/2, d/2]``) is
    absorbed as a tilt; the SD is the RMS of the residual, not of the raw deformation.

    Args:
      points: ``(n, 3)`` or ``(T, n, 3)`` top-layer positions [m].

    Returns:
      a float for ``(n, 3)`` input, else ``(T,)``.
    """
    h = surface_heights(points)
    sd = np.sqrt(np.mean(h * h, axis=-1))
    return float(sd) if sd.ndim == 0 else sd
