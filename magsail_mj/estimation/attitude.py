r"""Attitude of a flexible body: best-fit rotation, SO(3) log/exp, body rates, Euler angles.

Pure NumPy, vectorised over time: wherever an argument is a time series, the leading axis is
time and no Python loop runs over steps or nodes.

Frames and conventions
----------------------
* A rotation matrix ``R`` maps **body components to world (inertial) components**:
  ``v_world = R @ v_body``. For the lattice, the body frame is the best-fit frame.
* Quaternions are scalar-first ``[w, x, y, z]`` (as MuJoCo stores them) and describe the same
  body-to-world rotation as ``R``.
* Angles are in radians; rotation vectors are ``theta * axis`` with ``theta`` in ``[0, pi]``.
* ``hat(w)`` is the skew matrix with ``hat(w) @ v == cross(w, v)``; ``vee`` is its inverse.
"""

from __future__ import annotations

from typing import Literal, NamedTuple

import math

import numpy as np

from magsail_mj.estimation._arrays import as_masses, as_point_series, as_points, as_rotations
from magsail_mj.quaternion import quat_from_matrix, quat_to_matrix

__all__ = [
    "best_fit_rotation",
    "BestFitRotation",
    "so3_log",
    "so3_exp",
    "hat",
    "vee",
    "body_rates",
    "body_rate_step",
    "euler_zyx",
    "rotation_from_euler_zyx",
    "rotation_angle",
    "quat_from_matrix",
    "matrix_from_quat",
    "ParticleInertia",
    "particle_inertia",
]


# --------------------------------------------------------------------------------------------
# skew helpers
# --------------------------------------------------------------------------------------------
def hat(w: np.ndarray) -> np.ndarray:
    """Skew matrix ``(..., 3, 3)`` of vectors ``w`` ``(..., 3)``: ``hat(w) @ v = w x v``."""
    w = np.asarray(w, dtype=float)
    if w.shape[-1:] != (3,):
        raise ValueError(f"w: expected shape (..., 3), got {w.shape}")
    z = np.zeros_like(w[..., 0])
    x, y, zz = w[..., 0], w[..., 1], w[..., 2]
    return np.stack(
        [
            np.stack([z, -zz, y], axis=-1),
            np.stack([zz, z, -x], axis=-1),
            np.stack([-y, x, z], axis=-1),
        ],
        axis=-2,
    )


def vee(S: np.ndarray) -> np.ndarray:
    """Vector ``(..., 3)`` of the skew part of ``S`` ``(..., 3, 3)``: ``vee((S - S^T)/2)``.

    For an exactly skew ``S`` this is the inverse of :func:`hat`.
    """
    S = as_rotations(S, "S")
    return 0.5 * np.stack(
        [S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]],
        axis=-1,
    )


# --------------------------------------------------------------------------------------------
# best-fit rotation
# --------------------------------------------------------------------------------------------
def best_fit_rotation(p_ref: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Least-squares rigid motion mapping reference body coordinates onto current positions.

    Solves (squared norms, and the map goes from ``p`` to ``q``)

    .. math:: \min_{R\in SO(3),\,d}\ \sum_{i=1}^n \lVert R\,p_i + d - q_i\rVert^2

    by the Arun–Huang–Blostein (Kabsch) SVD method, all points unweighted:

    1. centroids :math:`\bar p`, :math:`\bar q`; centred :math:`p_i' = p_i-\bar p`;
    2. :math:`H = \sum_i p_i' (q_i-\bar q)^{\mathsf T}`, SVD :math:`H = U\Sigma V^{\mathsf T}`;
    3. :math:`R = V\,\mathrm{diag}(1, 1, \det(VU^{\mathsf T}))\,U^{\mathsf T}` (never a
       reflection), :math:`d = \bar q - R\bar p`.

    For a time series all ``T`` SVDs are done in one batched ``numpy.linalg.svd`` call. For
    repeated calls with the same reference (a controller, every step) build a
    :class:`BestFitRotation` once; it skips the per-call checks of ``p_ref`` (~3x faster
    for one 800-node configuration).

    Args:
      p_ref: ``(n, 3)`` reference (undeformed) body-frame coordinates [m], ``n >= 3`` and not
        all collinear (for the lattice: the coordinates ``p_ijk``).
      q: ``(n, 3)`` or ``(T, n, 3)`` current world positions [m] of the same points, same order.

    Returns:
      ``(R, d)``: ``R`` ``(3, 3)`` or ``(T, 3, 3)`` maps body components to world components
      (``q_i ≈ R p_i + d``); ``d`` ``(3,)`` or ``(T, 3)`` is the translation [m].
    """
    return BestFitRotation(p_ref)(q)


class BestFitRotation:
    """Kabsch best fit against a fixed reference set (see :func:`best_fit_rotation`).

    ``fit = BestFitRotation(p_ref)`` precomputes the centred reference; ``R, d = fit(q)``
    accepts ``(n, 3)`` or ``(T, n, 3)``.
    """

    def __init__(self, p_ref: np.ndarray) -> None:
        p = as_points(p_ref, "p_ref", min_points=3)
        self.n = p.shape[0]
        self.p_bar = p.mean(axis=0)
        pc = p - self.p_bar
        ev = np.linalg.eigvalsh(pc.T @ pc)  # squared singular values, ascending
        if not ev[1] > 1e-12 * ev[2]:  # sigma_2 / sigma_1 < 1e-6: numerically collinear
            raise ValueError("p_ref: points are collinear (or coincident); the rotation is undefined")
        self._pcT = np.ascontiguousarray(pc.T)
        self._pc_sum = pc.sum(axis=0)
        self._w = np.full(self.n, 1.0 / self.n)

    def __call__(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        qq = q if isinstance(q, np.ndarray) and q.dtype == np.float64 else None
        if qq is not None and qq.shape == (self.n, 3):
            return self._single(qq)
        if qq is None or qq.ndim not in (2, 3) or qq.shape[-2:] != (self.n, 3):
            qq = as_point_series(q, "q", n=self.n, min_points=3)
        q_bar = self._w @ qq
        # H = sum_i pc_i (q_i - q_bar)^T = pc^T q - (sum_i pc_i) q_bar^T, with no (T, n, 3)
        # copy; the second term removes the rounding residue of sum_i pc_i. The rounding left in
        # pc^T q is ~eps |q_bar| sum|pc_i|, negligible against |H| ~ sum|pc_i|^2 while |q_bar|
        # is not many orders of magnitude larger than the body (true in the orbit-following
        # world frame).
        H = self._pcT @ qq - self._pc_sum[:, None] * q_bar[..., None, :]
        bad = ~np.isfinite(H).all(axis=(-2, -1))
        if np.any(bad):
            where = "" if H.ndim == 2 else f" at time index {int(np.argmax(bad))}"
            raise ValueError(f"q: contains NaN or Inf{where}")
        U, _, Vt = np.linalg.svd(H)
        V = np.swapaxes(Vt, -1, -2)
        Ut = np.swapaxes(U, -1, -2)
        sgn = np.where(np.linalg.det(V @ Ut) < 0.0, -1.0, 1.0)
        V[..., :, 2] *= sgn[..., None]
        R = V @ Ut
        d = q_bar - R @ self.p_bar
        return R, d

    def _single(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One (n, 3) configuration: the same steps as the batched path with fewer array calls
        (this runs at every control sample)."""
        q_bar = self._w @ q
        H = self._pcT @ q - np.outer(self._pc_sum, q_bar)
        if not math.isfinite(float(H.sum())):  # a NaN, or an Inf (alone or with −Inf)
            raise ValueError("q: contains NaN or Inf")
        U, _, Vt = np.linalg.svd(H)
        R = Vt.T @ U.T
        if np.linalg.det(R) < 0.0:
            Vt[2] *= -1.0
            R = Vt.T @ U.T
        return R, q_bar - R @ self.p_bar


# --------------------------------------------------------------------------------------------
# SO(3) log / exp
# --------------------------------------------------------------------------------------------
def so3_log(R: np.ndarray) -> np.ndarray:
    r"""Rotation vector ``theta * axis`` (``(..., 3)``, ``theta`` in ``[0, pi]``) of ``R``.

    ``theta = atan2(|s|, (tr R - 1)/2)`` with ``s = vee(R - R^T)/2 = sin(theta) axis``, which is
    accurate over the whole range (no ``arccos``). Three regimes, all evaluated vectorised:

    * ``theta < 1e-4``: ``omega = s (1 + theta^2/6 + 7 theta^4/360)`` (series of
      ``theta/sin theta``), exact to rounding near the identity;
    * ``cos theta >= -1/2``: ``omega = s theta / |s|``;
    * ``cos theta < -1/2`` (near ``pi``, where ``s`` vanishes): the axis comes from the
      symmetric part, ``(R + R^T)/2 - cos(theta) I = (1 - cos theta) axis axis^T``, using its
      column with the largest diagonal entry; its sign is chosen so that ``axis . s >= 0``.

    Args:
      R: ``(..., 3, 3)`` rotation matrices.
    """
    R = as_rotations(R, "R")
    s = vee(R)
    sn = np.linalg.norm(s, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    theta = np.arctan2(sn, c)

    with np.errstate(divide="ignore", invalid="ignore"):
        th2 = theta * theta
        series = 1.0 + th2 / 6.0 + 7.0 * th2 * th2 / 360.0
        factor = np.where(theta < 1e-4, series, theta / np.where(sn > 0, sn, 1.0))
        w_regular = factor[..., None] * s

        # near-pi branch
        B = 0.5 * (R + np.swapaxes(R, -1, -2)) - c[..., None, None] * np.eye(3)
        diag = np.diagonal(B, axis1=-2, axis2=-1)
        m = np.argmax(diag, axis=-1)
        col = np.take_along_axis(B, m[..., None, None].repeat(3, axis=-2), axis=-1)[..., 0]
        nrm = np.linalg.norm(col, axis=-1)
        axis = col / np.where(nrm > 0, nrm, 1.0)[..., None]
        flip = np.sum(axis * s, axis=-1) < 0
        axis = np.where(flip[..., None], -axis, axis)
        w_pi = theta[..., None] * axis

    return np.where((c < -0.5)[..., None], w_pi, w_regular)


def so3_exp(rotvec: np.ndarray) -> np.ndarray:
    r"""Rotation matrix ``(..., 3, 3)`` of rotation vectors ``(..., 3)`` (Rodrigues).

    :math:`R = I + \frac{\sin\theta}{\theta}K + \frac{1-\cos\theta}{\theta^2}K^2`,
    ``K = hat(rotvec)``, with Taylor series of both coefficients for ``theta < 1e-4``.
    """
    w = np.asarray(rotvec, dtype=float)
    if w.shape[-1:] != (3,):
        raise ValueError(f"rotvec: expected shape (..., 3), got {w.shape}")
    th2 = np.sum(w * w, axis=-1)
    th = np.sqrt(th2)
    small = th < 1e-4
    with np.errstate(divide="ignore", invalid="ignore"):
        A = np.where(small, 1.0 - th2 / 6.0 + th2 * th2 / 120.0, np.sin(th) / th)
        Bc = np.where(small, 0.5 - th2 / 24.0 + th2 * th2 / 720.0, (1.0 - np.cos(th)) / th2)
    K = hat(w)
    return np.eye(3) + A[..., None, None] * K + Bc[..., None, None] * (K @ K)


# --------------------------------------------------------------------------------------------
# body rates
# --------------------------------------------------------------------------------------------
def body_rate_step(
    R_prev: np.ndarray,
    R: np.ndarray,
    dt: float | np.ndarray,
    *,
    method: Literal["log", "first_order"] = "log",
) -> np.ndarray:
    r"""Body-frame rate from two consecutive best-fit rotations.

    * ``method="log"``: :math:`\omega = \mathrm{vee}(\log(R_{k-1}^{\mathsf T}R_k))/\delta t`;
      exact for a constant body rate over the step.
    * ``method="first_order"``:
      :math:`\omega = \mathrm{vee}(\mathrm{skew}(R_{k-1}^{\mathsf T}R_k))/\delta t`; for a
      constant rate it returns :math:`\omega\,\sin(|\omega|\delta t)/(|\omega|\delta t)`.

    Either way the backward difference estimates the mean rate over the step, i.e. the rate at
    ``t_k`` to ``O(dt)`` for a time-varying rate.

    Args:
      R_prev, R: ``(..., 3, 3)`` body-to-world rotations at ``t_{k-1}`` and ``t_k``.
      dt: step ``t_k - t_{k-1}`` [s], > 0 (scalar or broadcastable to the leading shape).
      method: ``"log"`` (default) or ``"first_order"``.

    Returns:
      ``(..., 3)`` angular velocity in body components [rad/s].
    """
    Rp = as_rotations(R_prev, "R_prev")
    Rc = as_rotations(R, "R")
    dt_arr = np.asarray(dt, dtype=float)
    if np.any(~(dt_arr > 0)):
        raise ValueError(f"dt: must be > 0, got {dt!r}")
    M = np.swapaxes(Rp, -1, -2) @ Rc
    if method == "log":
        dphi = so3_log(M)
    elif method == "first_order":
        dphi = vee(M)
    else:
        raise ValueError(f"method: expected 'log' or 'first_order', got {method!r}")
    return dphi / dt_arr[..., None]


def body_rates(
    R_seq: np.ndarray,
    dt: float | np.ndarray,
    *,
    method: Literal["log", "first_order"] = "log",
    omega0: np.ndarray | None = None,
) -> np.ndarray:
    r"""Body rates of a time series of rotations by backward differences.

    :math:`\omega_k = \mathrm{vee}(\log(R_{k-1}^{\mathsf T}R_k))/\delta t` for ``k >= 1``
    (``method="log"``) or with the first-order ``skew`` in place of ``log``
    (``method="first_order"``); see :func:`body_rate_step`. ``omega_0`` is the known initial
    rate ``omega0`` (zero by default).

    Args:
      R_seq: ``(T, 3, 3)`` body-to-world rotations at uniformly or non-uniformly spaced times.
      dt: step [s]: a scalar, or ``(T-1,)`` array of ``t_k - t_{k-1}``.
      method: ``"log"`` or ``"first_order"``.
      omega0: ``(3,)`` body rate at ``k = 0`` [rad/s]; ``None`` means zero.

    Returns:
      ``(T, 3)`` angular velocity in body components [rad/s].
    """
    R_seq = as_rotations(R_seq, "R_seq")
    if R_seq.ndim != 3:
        raise ValueError(f"R_seq: expected shape (T, 3, 3), got {R_seq.shape}")
    T = R_seq.shape[0]
    dt_arr = np.asarray(dt, dtype=float)
    if dt_arr.ndim not in (0, 1) or (dt_arr.ndim == 1 and dt_arr.shape[0] != max(T - 1, 0)):
        raise ValueError(f"dt: expected a scalar or shape ({max(T - 1, 0)},), got {dt_arr.shape}")
    if omega0 is None:
        w0 = np.zeros(3)
    else:
        w0 = np.asarray(omega0, dtype=float)
        if w0.shape != (3,):
            raise ValueError(f"omega0: expected shape (3,), got {w0.shape}")
    out = np.empty((T, 3))
    if T == 0:
        return out
    out[0] = w0
    if T > 1:
        out[1:] = body_rate_step(R_seq[:-1], R_seq[1:], dt_arr, method=method)
    return out


# --------------------------------------------------------------------------------------------
# Euler angles and rotation angle
# --------------------------------------------------------------------------------------------
def euler_zyx(R: np.ndarray, *, unwrap: bool = False) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""ZYX intrinsic angles ``(psi, theta, phi)`` with ``R = Rz(psi) Ry(theta) Rx(phi)``.

    ``psi = atan2(R21, R11)``, ``phi = atan2(R32, R33)`` (1-based indices) and
    ``theta = atan2(-R31, hypot(R32, R33))``, which equals the textbook ``-arcsin(R31)`` for a
    rotation matrix but stays accurate near ``theta = ±pi/2`` (where ``psi`` and ``phi`` are
    singular anyway: use :func:`rotation_angle` there).

    Args:
      R: ``(..., 3, 3)`` body-to-world rotations.
      unwrap: unwrap ``psi`` and ``phi`` along axis 0 (time) with ``numpy.unwrap``, so they are
        continuous in time (``theta`` lies in ``[-pi/2, pi/2]`` and needs none). Needs
        ``R.ndim >= 3``.

    Returns:
      ``(psi, theta, phi)`` [rad], each of shape ``R.shape[:-2]``.
    """
    R = as_rotations(R, "R")
    psi = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    theta = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 2, 1], R[..., 2, 2]))
    phi = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    if unwrap:
        if R.ndim < 3:
            raise ValueError(f"R: unwrap needs a time series (T, 3, 3), got {R.shape}")
        psi = np.unwrap(psi, axis=0)
        phi = np.unwrap(phi, axis=0)
    return psi, theta, phi


def rotation_from_euler_zyx(psi: np.ndarray, theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    r"""``R = Rz(psi) Ry(theta) Rx(phi)`` (body-to-world), broadcast over the angles [rad]."""
    psi, theta, phi = np.broadcast_arrays(
        np.asarray(psi, dtype=float), np.asarray(theta, dtype=float), np.asarray(phi, dtype=float)
    )
    cps, sps = np.cos(psi), np.sin(psi)
    cth, sth = np.cos(theta), np.sin(theta)
    cph, sph = np.cos(phi), np.sin(phi)
    return np.stack(
        [
            np.stack([cps * cth, cps * sth * sph - sps * cph, cps * sth * cph + sps * sph], -1),
            np.stack([sps * cth, sps * sth * sph + cps * cph, sps * sth * cph - cps * sph], -1),
            np.stack([-sth, cth * sph, cth * cph], -1),
        ],
        axis=-2,
    )


def rotation_angle(R: np.ndarray, *, relative_to: np.ndarray | None = None) -> np.ndarray:
    r"""Rotation angle in ``[0, pi]`` [rad] of ``R`` (or of ``relative_to^T R``).

    ``theta = atan2(|vee(R - R^T)|/2, (tr R - 1)/2)``: accurate at both ends of the range.
    With ``relative_to = R_0`` this is the angle of :math:`R_0^{\mathsf T}R` plotted beside the
    Euler angles; with ``relative_to = R_ref`` it is the attitude-error angle.

    Args:
      R: ``(..., 3, 3)`` rotations.
      relative_to: ``(..., 3, 3)`` rotation broadcastable against ``R``, or ``None``.
    """
    R = as_rotations(R, "R")
    if relative_to is not None:
        R0 = as_rotations(relative_to, "relative_to")
        R = np.swapaxes(R0, -1, -2) @ R
    sn = np.linalg.norm(vee(R), axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
    return np.arctan2(sn, c)


# --------------------------------------------------------------------------------------------
# quaternions (scalar-first [w, x, y, z])
# --------------------------------------------------------------------------------------------
def matrix_from_quat(q: np.ndarray) -> np.ndarray:
    """Rotation matrix ``(..., 3, 3)`` of quaternions ``[w, x, y, z]`` (normalised first): alias of
    :func:`magsail_mj.quaternion.quat_to_matrix` with ``normalise=True``, kept for its callers.
    ``quat_from_matrix`` is :func:`magsail_mj.quaternion.quat_from_matrix` (re-exported)."""
    return quat_to_matrix(q, normalise=True)


# --------------------------------------------------------------------------------------------
# inertia of the particle set
# --------------------------------------------------------------------------------------------
class ParticleInertia(NamedTuple):
    """Inertia of a particle set about its centre of mass (see :func:`particle_inertia`).

    Attributes:
      moments: ``(..., 3)`` Eq. 21 moments ``[I1, I2, I3]`` about the axes of the input frame
        through the COM (the diagonal of ``tensor``) [kg m^2].
      tensor: ``(..., 3, 3)`` full inertia tensor about the COM, input-frame axes [kg m^2].
      principal: ``(..., 3)`` eigenvalues of ``tensor``, ascending [kg m^2].
      com: ``(..., 3)`` centre of mass [m].
      mass: total mass [kg].
    """

    moments: np.ndarray
    tensor: np.ndarray
    principal: np.ndarray
    com: np.ndarray
    mass: float


def particle_inertia(p: np.ndarray, m: float | np.ndarray) -> ParticleInertia:
    r"""Inertia of point masses about their centre of mass (Robb et al. 2022a, Eq. 21, computed from the particles).

    With :math:`r_i = p_i - p_c`, :math:`p_c = \sum m_i p_i / \sum m_i`:

    .. math:: J = \sum_i m_i\,(\lVert r_i\rVert^2 I - r_i r_i^{\mathsf T}),\qquad
              \mathcal I_1 = \sum_i m_i (y_i^2 + z_i^2)\ \text{etc. (the diagonal of } J).

    For the undeformed lattice in body coordinates ``J`` is diagonal and ``moments`` are the
    principal moments the controller uses (75 m, 200 kg, 800 particles:
    ``I1 = I2 ≈ 1.0440e5``, ``I3 ≈ 2.0724e5`` kg m²; not the paper's printed values, **O3**).

    Args:
      p: ``(n, 3)`` or ``(T, n, 3)`` positions [m] in the frame whose axes the result uses.
      m: particle mass [kg], a scalar (all equal) or ``(n,)``; all ``>= 0`` with a positive sum.
    """
    pp = as_point_series(p, "p")
    n = pp.shape[-2]
    mm = as_masses(m, "m", n, sign_error="m: masses must be >= 0 with a positive total")
    M = float(mm.sum())
    com = np.einsum("n,...nj->...j", mm, pp) / M
    r = pp - com[..., None, :]
    S = np.einsum("n,...ni,...nj->...ij", mm, r, r)  # second moment sum m r r^T
    tensor = np.trace(S, axis1=-2, axis2=-1)[..., None, None] * np.eye(3) - S
    moments = np.diagonal(tensor, axis1=-2, axis2=-1).copy()
    principal = np.linalg.eigvalsh(tensor)
    return ParticleInertia(moments=moments, tensor=tensor, principal=principal, com=com, mass=M)
