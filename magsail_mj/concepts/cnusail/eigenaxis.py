r"""Eigen-axis slew under a slew-rate limit (Yoo et al. 2016, Eqs. 28–38,
after Wie & Lu 1995), and the quaternion conventions of its Eqs. 2–3.

Conventions
-----------
The project stores MuJoCo's scalar-first Hamilton quaternion p = [w, x, y, z] (body → world,
``xmat``). The paper uses scalar-last q = [q1, q2, q3, q4] with the attitude matrix A(q) mapping
reference components into body components. They are the same numbers reordered:

    q_paper = [x, y, z, w],     A(q_paper) = xmatᵀ.

* error quaternion (Eq. 37 without the stray ½ and with d_c2 → q_c2, both misprints):
  p_e = p_c* ⊗ p_b (Hamilton), i.e. the body attitude relative to the command frame;
  A(q_e) = A(q) A(q_c)ᵀ. With ``shortest=True`` the sign is chosen so that q_e4 = w ≥ 0.
* eigen-angle θ_e = 2 atan2(|q_e,1:3|, |q_e4|).
* attitude matrix A(q) of Eq. 3 with q_3² on the diagonal, not the printed q_3³ (:func:`attitude_matrix`).

Rate error (Eq. 38): the command frame turns with the orbital frame R; for both commands used here
(nadir and deorbit, which share ŷ_C = ŷ_R) its rate is [0, −ω_o, 0] in command components, so

    ω_e = ω − A(q_e) [0, −ω_o, 0]ᵀ,      ω_o = |r × v|/|r|² (instantaneous orbital rate).

Control torque (Eq. 28), J the spacecraft inertia matrix:

    u = −K sat(P q_e) − C ω_e + g,   K = J diag(k_i), P = diag(p_i), C = c J,

sat the unit saturation per component (Eq. 32), g the gyroscopic compensation (``gyro_comp``;
the paper's form omits h_w): ``"Iw"`` (paper) ω × Jω, ``"Iw+hw"`` ω × (Jω + h_w), ``"none"`` 0.

Gain selection (Eqs. 33–36, corrected as below). With q_e(0) the vector part
at the start of the manoeuvre, θ̇_max the slew-rate limit, ω_n and ζ the small-angle natural
frequency and damping:

    k = 2 ω_n²,  c = 2 ζ ω_n,  k_i = c θ̇_max |q_e,i(0)|/‖q_e(0)‖,  p_i = k/k_i   (K P = k J).

While saturated, ω̇_i ≈ −k_i sgn(q_e,i) − c ω_i drives the rate to −θ̇_max q_e(0)/‖q_e(0)‖: a
rotation about the initial eigen-axis at the rate limit; near the target the law becomes
q̈_e ≈ −(k/2) q_e − c q̇_e, a second-order system with ω_n² = k/2 and 2ζω_n = c.

Small components (the paper states this clamp loosely): for the gain computation only, every |q_e,i(0)| < 0.1 is
replaced by 0.1 (``clamp_min``); the modified vector is not renormalised; the feedback uses the
true error. The eigen-angle of the modified vector is logged next to the true one, with the same
atan2 formula as θ_e and the true scalar part q_e4(0):

    θ_clamped = 2 atan2(‖q_ref‖, |q_e4(0)|),

the angle of the quaternion [q_ref, q_e4(0)] once normalised (atan2 does not depend on the common
scale). For the deorbit error [0, 0.7071, 0, 0.7071] (scalar-last) this is 91.12°, 1.12° over the
true 90° (the paper states about 1.15°). The angle of the un-normalised vector read as a unit
quaternion, 2 asin‖q_ref‖ (scalar part √(1 − ‖q_ref‖²)), would be 92.29°: the clamp adds the
0.02 of ‖q_ref‖² to the vector without taking it from the scalar part.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, Sequence

import numpy as np

from magsail_mj.quaternion import quat_conj, quat_mul
from magsail_mj.checkpoint import restorable

__all__ = [
    "quat_to_paper",
    "quat_from_paper",
    "attitude_matrix",
    "paper_error_quaternion",
    "error_quaternion",
    "eigen_angle",
    "rate_error",
    "error_quaternion_f",
    "eigen_angle_f",
    "rate_error_f",
    "orbital_rate",
    "EigenAxisGains",
    "eigen_axis_gains",
    "eigen_axis_torque",
    "gyro_compensation",
    "GyroComp",
]

GyroComp = Literal["Iw", "Iw+hw", "none"]
#: rounding allowed above 1 in the norm of a unit quaternion's vector part
_UNIT_SLACK = 1e-9


def quat_to_paper(p: np.ndarray) -> np.ndarray:
    """Scalar-first [w, x, y, z] → the paper's scalar-last [q1, q2, q3, q4] = [x, y, z, w]."""
    p = np.asarray(p, dtype=float)
    return np.concatenate([p[..., 1:], p[..., :1]], axis=-1)


def quat_from_paper(q: np.ndarray) -> np.ndarray:
    """The paper's scalar-last [q1, q2, q3, q4] → scalar-first [w, x, y, z]."""
    q = np.asarray(q, dtype=float)
    return np.concatenate([q[..., 3:], q[..., :3]], axis=-1)


def attitude_matrix(q: np.ndarray) -> np.ndarray:
    """A(q) of paper Eq. 3 with q_3² on the diagonal, not the printed q_3³ (scalar-last ``q``): maps
    reference components into body components; equals ``xmatᵀ`` of the reordered quaternion."""
    q1, q2, q3, q4 = np.asarray(q, dtype=float)
    return np.array(
        [
            [q1 * q1 - q2 * q2 - q3 * q3 + q4 * q4, 2 * (q1 * q2 + q3 * q4), 2 * (q1 * q3 - q2 * q4)],
            [2 * (q1 * q2 - q3 * q4), -q1 * q1 + q2 * q2 - q3 * q3 + q4 * q4, 2 * (q2 * q3 + q1 * q4)],
            [2 * (q1 * q3 + q2 * q4), 2 * (q2 * q3 - q1 * q4), -q1 * q1 - q2 * q2 + q3 * q3 + q4 * q4],
        ]
    )


def paper_error_quaternion(q_c: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Error quaternion of paper Eq. 37 (scalar-last), without the stray ½ and with q_c2 for the printed d_c2."""
    c1, c2, c3, c4 = np.asarray(q_c, dtype=float)
    M = np.array([[c4, c3, -c2, -c1], [-c3, c4, c1, -c2], [c2, -c1, c4, -c3], [c1, c2, c3, c4]])
    return M @ np.asarray(q, dtype=float)


def error_quaternion(p_c: np.ndarray, p_b: np.ndarray, *, shortest: bool = True) -> np.ndarray:
    """p_e = p_c* ⊗ p_b (scalar-first): body attitude relative to the command frame (Eq. 37 without its stray ½).
    With ``shortest`` the sign is flipped when w < 0 (rotation by at most π)."""
    p = quat_mul(quat_conj(p_c), p_b)
    p = p / math.sqrt(float(p @ p))
    if shortest and p[0] < 0:
        p = -p
    return p


def eigen_angle(p_e: np.ndarray) -> float | np.ndarray:
    """θ_e = 2 atan2(|vector part|, |scalar part|) [rad] of scalar-first quaternion(s)."""
    p = np.asarray(p_e, dtype=float)
    return 2.0 * np.arctan2(np.linalg.norm(p[..., 1:], axis=-1), np.abs(p[..., 0]))


def orbital_rate(r: np.ndarray, v: np.ndarray) -> float:
    """Instantaneous orbital rate ω_o = |r × v|/|r|² [rad/s]."""
    h = np.cross(r, v)
    return float(math.sqrt(float(h @ h)) / float(r @ r))


def rate_error(omega_body: np.ndarray, p_e: np.ndarray, omega_o: float) -> np.ndarray:
    """ω_e = ω − A(q_e)[0, −ω_o, 0]ᵀ (paper Eq. 38) in body components [rad/s].

    A(q_e) maps command components into body components; with p_e = [w, x, y, z] it is the
    transpose of the rotation matrix of p_e, whose middle row gives A(q_e)[:, 1]."""
    w, x, y, z = p_e
    # column 1 of A(q_e) = row 1 of R(p_e)
    col = np.array([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)])
    return np.asarray(omega_body, dtype=float) + omega_o * col


def error_quaternion_f(
    p_c: Sequence[float], p_b: Sequence[float], *, shortest: bool = True
) -> tuple[float, float, float, float]:
    """:func:`error_quaternion` of single quaternions in plain floats (the controller's per-sample
    path): p_e = p_c* ⊗ p_b / |p_c* ⊗ p_b|, sign flipped when ``shortest`` and w < 0."""
    w1, x1, y1, z1 = p_c
    x1, y1, z1 = -x1, -y1, -z1
    w2, x2, y2, z2 = p_b
    w = w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2
    x = w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2
    y = w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2
    z = w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if shortest and w < 0:
        n = -n
    return (w / n, x / n, y / n, z / n)


def eigen_angle_f(p_e: Sequence[float]) -> float:
    """:func:`eigen_angle` of one quaternion in plain floats: 2 atan2(√(x² + y² + z²), |w|) [rad]."""
    w, x, y, z = p_e
    return 2.0 * math.atan2(math.sqrt(x * x + y * y + z * z), abs(w))


def rate_error_f(omega_body: Sequence[float], p_e: Sequence[float], omega_o: float) -> np.ndarray:
    """:func:`rate_error` from plain floats: ω_e = ω + ω_o (2(xy + wz), 1 − 2(x² + z²), 2(yz − wx))."""
    w, x, y, z = p_e
    o0, o1, o2 = omega_body
    return np.array(
        (
            o0 + omega_o * (2 * (x * y + w * z)),
            o1 + omega_o * (1 - 2 * (x * x + z * z)),
            o2 + omega_o * (2 * (y * z - w * x)),
        )
    )


@restorable
@dataclass(frozen=True)
class EigenAxisGains:
    """Gains of the eigen-axis law (module docstring).

    Attributes:
      k, c: 2ω_n² [1/s²] and 2ζω_n [1/s].
      k_i: (3,) saturation levels [rad/s²]; p_i: (3,) k/k_i.
      q_ref: (3,) error vector the gains were computed from (after the 0.1 clamp).
      theta_true_rad: eigen-angle of the true error vector; theta_clamped_rad: of ``q_ref`` with the
        true scalar part, 2 atan2(‖q_ref‖, |q_e4(0)|) [rad].
      rate_max_rad_s: θ̇_max.
    """

    k: float
    c: float
    k_i: np.ndarray
    p_i: np.ndarray
    q_ref: np.ndarray
    theta_true_rad: float
    theta_clamped_rad: float
    rate_max_rad_s: float

    def as_dict(self) -> dict[str, object]:
        return {
            "k": self.k,
            "c": self.c,
            "k_i": self.k_i.tolist(),
            "p_i": self.p_i.tolist(),
            "q_ref": self.q_ref.tolist(),
            "theta_true_rad": self.theta_true_rad,
            "theta_clamped_rad": self.theta_clamped_rad,
            "rate_max_rad_s": self.rate_max_rad_s,
        }


def _angle_of_vector(q_vec: np.ndarray, scalar_abs: float) -> float:
    """Eigen-angle θ = 2 atan2(‖q_vec‖, |q4|) [rad] of the vector part ``q_vec`` with the scalar part
    ``scalar_abs`` = |q4|; for a clamped (un-normalised) vector this is the angle of [q_vec, q4]
    normalised (module docstring)."""
    return 2.0 * math.atan2(math.sqrt(float(q_vec @ q_vec)), scalar_abs)


def eigen_axis_gains(
    q_e0: np.ndarray, *, omega_n_rad_s: float, zeta: float, rate_max_rad_s: float, clamp_min: float = 0.1
) -> EigenAxisGains:
    """Gains (Eqs. 33–36, corrected as in the module docstring) from the error vector ``q_e0`` (3,) at the
    start of the manoeuvre (the vector part of a unit quaternion: its scalar part is
    √(1 − ‖q_e0‖²)), with the per-component clamp (``clamp_min``; 0 disables it).

    Raises ValueError naming the argument when ``q_e0`` is zero (no manoeuvre) and not clamped, or
    its norm exceeds 1.
    """
    if not omega_n_rad_s > 0:
        raise ValueError(f"omega_n_rad_s: must be > 0, got {omega_n_rad_s!r}")
    if not zeta > 0:
        raise ValueError(f"zeta: must be > 0, got {zeta!r}")
    if not rate_max_rad_s > 0:
        raise ValueError(f"rate_max_rad_s: must be > 0, got {rate_max_rad_s!r}")
    if not 0 <= clamp_min < 1:
        raise ValueError(f"clamp_min: must be in [0, 1), got {clamp_min!r}")
    q = np.asarray(q_e0, dtype=float).reshape(3)
    n2_true = float(q @ q)
    if not n2_true <= 1.0 + _UNIT_SLACK:
        raise ValueError(f"q_e0: the vector part of a unit quaternion has norm ≤ 1, got {math.sqrt(n2_true)!r}")
    scalar_abs = math.sqrt(max(0.0, 1.0 - n2_true))  # |q_e4(0)| of the unit error quaternion
    q_ref = np.where(np.abs(q) < clamp_min, clamp_min, np.abs(q)) if clamp_min > 0 else np.abs(q)
    nrm = float(np.linalg.norm(q_ref))
    if not nrm > 0 or np.any(q_ref == 0):
        raise ValueError(f"q_e0: every component must be non-zero for the gains (set clamp_min > 0), got {q.tolist()}")
    k = 2.0 * omega_n_rad_s**2
    c = 2.0 * zeta * omega_n_rad_s
    k_i = c * rate_max_rad_s * q_ref / nrm
    p_i = k / k_i
    return EigenAxisGains(
        k=k,
        c=c,
        k_i=k_i,
        p_i=p_i,
        q_ref=q_ref,
        theta_true_rad=_angle_of_vector(q, scalar_abs),
        theta_clamped_rad=_angle_of_vector(q_ref, scalar_abs),
        rate_max_rad_s=float(rate_max_rad_s),
    )


def gyro_compensation(omega: np.ndarray, inertia: np.ndarray, h_w: np.ndarray | None, mode: GyroComp) -> np.ndarray:
    """g = ω × Jω (``"Iw"``), ω × (Jω + h_w) (``"Iw+hw"``) or 0 (``"none"``) [N m]; the paper's form is ``"Iw"``."""
    if mode == "none":
        return np.zeros(3)
    H = inertia @ omega
    if mode == "Iw+hw":
        if h_w is None:
            raise ValueError("h_w: needed for gyro_comp = 'Iw+hw'")
        H = H + h_w
    elif mode != "Iw":
        raise ValueError(f"gyro_comp: must be 'Iw', 'Iw+hw' or 'none', got {mode!r}")
    return np.cross(omega, H)


def eigen_axis_torque(
    q_e: np.ndarray,
    omega_e: np.ndarray,
    omega: np.ndarray,
    inertia: np.ndarray,
    gains: EigenAxisGains,
    *,
    gyro_comp: GyroComp = "Iw",
    h_w: np.ndarray | None = None,
) -> np.ndarray:
    """u = −J diag(k_i) sat(P q_e) − c J ω_e + g (paper Eq. 28) [N m], body axes.

    Args:
      q_e: (3,) error vector part; omega_e: (3,) rate error [rad/s]; omega: (3,) body rate
      [rad/s]; inertia: (3, 3) J [kg m²]; gains: :func:`eigen_axis_gains`; gyro_comp, h_w: the
      gyroscopic term (h_w [N m s] body axes, needed for ``"Iw+hw"``).
    """
    s = np.clip(gains.p_i * q_e, -1.0, 1.0)
    u = -inertia @ (gains.k_i * s) - gains.c * (inertia @ omega_e)
    return u + gyro_compensation(omega, inertia, h_w, gyro_comp)
