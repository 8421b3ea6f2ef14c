"""Surface SD and average plane (the flatness measure of Robb et al. 2022a).

Point sets are the top layer (k = 1) of the truss lattice, built here.

Note on the ripple test. One might expect that ``w = A sin(2 pi x / d)`` on the reference grid
give "its analytic RMS". The SD is measured from the *fitted* total-least-squares plane, and
over ``x in [-d/2, d/2]`` this ripple is odd, so it correlates with ``x``: the fitted plane tilts
and absorbs part of it (in the continuum, small-A limit the SD is
``A sqrt(1/2 - 3/pi^2) ~ 0.443 A``, not ``A / sqrt(2)``). The analytic answer is therefore the
smallest eigenvalue of the closed-form 2 x 2 (x, w) covariance block, evaluated here from
1-D sums over one grid row, independently of the code under test. A second case,
``w = A cos(2 pi x / d)`` (even, no tilt), checks the plain discrete RMS about the mean:
``SD^2 = A^2 [(N + 1)/(2N) - 1/N^2]``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from magsail_mj.analysis.flatness import average_plane, surface_heights, surface_sd

EPS = np.finfo(float).eps


def top_layer(N: int, d: float) -> np.ndarray:
    """Top layer (k = 1) of the truss lattice, flat index j N + i."""
    a = d / (N - 1)
    j, i = np.meshgrid(np.arange(N), np.arange(N), indexing="ij")
    return np.stack([i * a - d / 2, j * a - d / 2, np.full(i.shape, a / 2)], -1).reshape(-1, 3)


unit = st.floats(-1.0, 1.0, allow_nan=False)


@settings(max_examples=50, deadline=None)
@given(
    qt=st.tuples(unit, unit, unit, unit),
    d=st.tuples(*[st.floats(-500.0, 500.0)] * 3),
)
def test_flat_plate_sd_zero_under_rigid_motion(qt, d):
    q = np.asarray(qt)
    assume(np.linalg.norm(q) > 0.1)
    R = Rotation.from_quat(q / np.linalg.norm(q), scalar_first=True).as_matrix()
    x = top_layer(20, 75.0) @ R.T + np.asarray(d)
    sd = surface_sd(x)
    # the coordinates themselves carry rounding eps * |x|; the SD cannot be smaller than that
    assert sd < 64 * EPS * np.abs(x).max()
    c, n = average_plane(x, orient=R[:, 2])
    assert np.abs(n - R[:, 2]).max() < 1e-14
    assert np.abs(c - np.asarray(d) - R[:, 2] * 75.0 / 19 / 2).max() < 64 * EPS * np.abs(x).max()


def analytic_tls_sd(N: int, d: float, w_of_x) -> float:
    """Exact TLS residual SD of a ripple w(x) on the N x N grid, from 1-D sums (see module
    docstring). y is uncorrelated with x and w, so only the (x, w) block matters."""
    a = d / (N - 1)
    x = np.arange(N) * a - d / 2
    w = w_of_x(x)
    cxx = np.mean(x * x)
    wm = np.mean(w)
    cww = np.mean((w - wm) ** 2)
    cxw = np.mean(x * (w - wm))
    lam = 0.5 * (cxx + cww) - np.sqrt(0.25 * (cxx - cww) ** 2 + cxw * cxw)
    assert lam < cxx  # smaller than the y variance, so it is the plane's residual
    return float(np.sqrt(lam))


@pytest.mark.parametrize("N,d,A", [(20, 100.0, 0.1), (20, 75.0, 1.0), (41, 20.0, 0.02)])
def test_sinusoidal_ripple_sd(N, d, A):
    p = top_layer(N, d)
    x = p[:, 0]
    R = Rotation.from_rotvec([0.3, -0.8, 2.1]).as_matrix()
    shift = np.array([12.0, -3.0, 40.0])

    w_sin = lambda xx: A * np.sin(2 * np.pi * xx / d)  # noqa: E731
    ps = p.copy()
    ps[:, 2] += w_sin(x)
    expected = analytic_tls_sd(N, d, w_sin)
    for pts in (ps, ps @ R.T + shift):
        assert surface_sd(pts) == pytest.approx(expected, rel=1e-6)
    # the plane tilts: the SD is clearly below the raw RMS A sqrt((N-1)/(2N))
    assert expected < 0.8 * A * np.sqrt((N - 1) / (2 * N))

    pc = p.copy()
    pc[:, 2] += A * np.cos(2 * np.pi * x / d)
    expected_cos = A * np.sqrt((N + 1) / (2 * N) - 1 / N**2)
    for pts in (pc, pc @ R.T + shift):
        assert surface_sd(pts) == pytest.approx(expected_cos, rel=1e-6)


def test_time_series_vectorised_and_heights():
    N, d, A = 20, 75.0, 0.5
    p = top_layer(N, d)
    amps = np.linspace(0.0, A, 30)
    Rs = Rotation.random(30, random_state=1).as_matrix()
    pts = np.repeat(p[None], 30, axis=0)
    pts[:, :, 2] += amps[:, None] * np.cos(2 * np.pi * p[None, :, 0] / d)
    pts = np.einsum("tij,tnj->tni", Rs, pts) + 7.0
    sd = surface_sd(pts)
    assert sd.shape == (30,)
    expected = amps * np.sqrt((N + 1) / (2 * N) - 1 / N**2)
    assert np.allclose(sd, expected, rtol=1e-9, atol=1e-12)
    assert sd[5] == pytest.approx(surface_sd(pts[5]), rel=1e-14)
    h = surface_heights(pts, orient=Rs[:, :, 2])
    assert h.shape == (30, N * N)
    assert np.abs(h.mean(axis=-1)).max() < 1e-12
    # oriented along body z: the cosine crest (nodes nearest x = 0) lies above the plane
    i_mid = np.argmin(np.abs(p[:, 0]))
    assert np.all(h[1:, i_mid] > 0)


def test_errors_name_argument():
    with pytest.raises(ValueError, match=r"points: expected shape \(n, 3\) or \(T, n, 3\)"):
        surface_sd(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="points: need at least 3 points"):
        surface_sd(np.zeros((2, 3)))
