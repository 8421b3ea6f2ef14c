r"""Undamped modes of a spring–mass lattice and the Caughey (modal) damping matrix.

Robb et al. 2022b, Eqs. 13–15 (stiffness and Caughey damping), with the damping schedules, cost and stability
checks stated below.
Pure NumPy/SciPy. All vectors are the flattened particle coordinates
``r = (x_0, y_0, z_0, x_1, …)`` (node-major, ``3 n_nodes`` DOF) in the **body frame of the
undeformed lattice** (the frame of ``nodes``); the co-rotation into world axes is done by
:class:`magsail_mj.lattice.modal_damping.ModalDampingLoad`.

Modes
-----
:math:`\mathbf K\boldsymbol\phi=\omega^2\mathbf M\boldsymbol\phi` with the linear stiffness
:math:`\mathbf K` of :func:`magsail_mj.lattice.geometry.stiffness_matrix` (assembled at ``nodes``)
and :math:`\mathbf M=\mathrm{diag}(m_i\mathbf I_3)`. Because :math:`\mathbf M` is diagonal the
generalized problem is reduced exactly to the standard symmetric one
:math:`\mathbf M^{-1/2}\mathbf K\mathbf M^{-1/2}\boldsymbol\psi=\omega^2\boldsymbol\psi`,
:math:`\boldsymbol\phi=\mathbf M^{-1/2}\boldsymbol\psi` (what ``scipy.linalg.eigh(K, M)`` does
with a diagonal Cholesky factor), solved densely by LAPACK's divide-and-conquer ``evd``. The
columns of :math:`\Phi` are M-orthonormal (:math:`\Phi^T\mathbf M\Phi=\mathbf I`) and sorted by
rising :math:`\omega`. The ``n_rigid`` (6 for a free lattice) lowest eigenvalues are rigid-body
modes and are clamped to :math:`\omega=0`.

Eigenvectors do not depend on the scale of ``k`` or of ``masses``: the cache stores the modes of
the normalised problem (``k / max k``, ``m / mean m``) and rescales
(:math:`\omega\propto\sqrt{s_k/s_m}`, :math:`\phi\propto1/\sqrt{s_m}`), so the three ``EI``
values of a lattice share one eigen-solve.

Damping
-------
:math:`\boldsymbol\gamma=\mathbf M\big(\sum_n2\xi_n\omega_n\boldsymbol\phi_n\boldsymbol\phi_n^T\big)\mathbf M`
(Eq. 15), so :math:`\Phi^T\boldsymbol\gamma\Phi=\mathrm{diag}(2\xi_n\omega_n)` and rigid modes
(:math:`\omega=0`) are not damped. Mode numbers ``n = 1, 2, …`` of the schedule count from the
**first elastic mode** (rigid modes excluded; :data:`MODE_COUNTING`).
"""

from __future__ import annotations

import hashlib
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from scipy import linalg

from magsail_mj.lattice.geometry import stiffness_matrix
from magsail_mj.io import atomic_path

__all__ = [
    "MODE_COUNTING",
    "SCHEDULES",
    "DEFAULT_CACHE_DIR",
    "Modes",
    "LowRankCaughey",
    "StabilityProducts",
    "lattice_modes",
    "modes_cache_dir",
    "damping_ratios",
    "schedule_record",
    "caughey_matrix",
    "caughey_low_rank",
    "stability_products",
]

MODE_COUNTING = "first_elastic"
"""Schedule mode numbers start at the lowest elastic mode (the rigid modes are not counted)."""

SCHEDULES = ("paper_max", "capped_rayleigh")
DEFAULT_CACHE_DIR = Path("runs/cache/modes")
_CACHE_VERSION = 1


@dataclass(frozen=True)
class Modes:
    """Undamped modes of a lattice (see module docstring).

    Attributes:
      omega: ``(n_dof,)`` circular frequencies [rad/s], ascending; the first ``n_rigid`` are 0.
      phi: ``(n_dof, n_dof)`` M-orthonormal mode shapes (columns), body-frame components
        [kg^-1/2]; ``phi[3 i + c, n]`` is component ``c`` of node ``i`` in mode ``n``.
      masses: ``(n_nodes,)`` particle masses [kg].
      n_rigid: number of rigid-body modes clamped to ``omega = 0``.
      eigvals: ``(n_dof,)`` the computed ``omega²`` before clamping [rad²/s²] (the rigid ones
        are round-off, kept for checks).
      key: cache key (hash of the normalised nodes, struts, k, masses).
    """

    omega: np.ndarray
    phi: np.ndarray
    masses: np.ndarray
    n_rigid: int
    eigvals: np.ndarray
    key: str

    @property
    def n_dof(self) -> int:
        return self.omega.size

    @property
    def mass_diag(self) -> np.ndarray:
        """``(n_dof,)`` diagonal of ``M`` (each mass repeated for x, y, z) [kg]."""
        return np.repeat(self.masses, 3)

    @property
    def elastic(self) -> slice:
        """Column slice of the elastic modes."""
        return slice(self.n_rigid, self.n_dof)

    @property
    def rigid_phi(self) -> np.ndarray:
        """``(n_dof, n_rigid)`` M-orthonormal basis of the rigid-body motions of ``nodes``."""
        return self.phi[:, : self.n_rigid]


def modes_cache_dir(cache_dir: str | os.PathLike | None = None) -> Path:
    """Cache folder: ``cache_dir`` if given, else ``$MAGSAIL_CACHE_DIR``, else ``runs/cache/modes``."""
    if cache_dir is not None:
        return Path(cache_dir)
    env = os.environ.get("MAGSAIL_CACHE_DIR")
    return Path(env) if env else DEFAULT_CACHE_DIR


def _normalised(nodes, struts, k, masses):
    nodes = np.ascontiguousarray(nodes, dtype=float)
    struts = np.ascontiguousarray(struts, dtype=np.int64)
    k = np.ascontiguousarray(k, dtype=float)
    masses = np.ascontiguousarray(masses, dtype=float)
    n = nodes.shape[0]
    if nodes.ndim != 2 or nodes.shape[1] != 3:
        raise ValueError(f"nodes: expected shape (n, 3), got {nodes.shape}")
    if struts.ndim != 2 or struts.shape[1] != 2 or struts.min(initial=0) < 0 or struts.max(initial=0) >= n:
        raise ValueError(f"struts: expected (S, 2) node indices in 0..{n - 1}, got shape {struts.shape}")
    if k.shape != (struts.shape[0],) or not np.all(k > 0):
        raise ValueError(f"k: expected ({struts.shape[0]},) positive spring constants, got shape {k.shape}")
    if masses.shape != (n,) or not np.all(masses > 0):
        raise ValueError(f"masses: expected ({n},) positive values, got shape {masses.shape}")
    s_k = float(k.max())
    s_m = float(masses.mean())
    return nodes, struts, k / s_k, masses / s_m, s_k, s_m


def _key(nodes, struts, kn, mn, n_rigid) -> str:
    h = hashlib.sha256()
    h.update(f"v{_CACHE_VERSION};rigid={n_rigid};".encode())
    # 12 significant digits: the same lattice with another EI or sigma hashes the same.
    for a in (nodes, kn, mn):
        a = np.asarray(a, dtype=float)
        digits = 12 - int(np.ceil(np.log10(np.abs(a).max() + 1e-300)))
        h.update(np.asarray(a.shape, dtype=np.int64).tobytes())
        h.update((np.round(a, digits) + 0.0).tobytes())  # + 0.0 turns -0.0 into 0.0
    h.update(struts.tobytes())
    return h.hexdigest()[:24]


def _solve(nodes, struts, kn, mn) -> tuple[np.ndarray, np.ndarray]:
    K = stiffness_matrix(nodes, struts, kn).toarray()
    s = 1.0 / np.sqrt(np.repeat(mn, 3))
    A = K * s[:, None] * s[None, :]
    A = 0.5 * (A + A.T)
    lam, psi = linalg.eigh(A, driver="evd", overwrite_a=True, check_finite=False)
    psi *= s[:, None]  # phi = M^-1/2 psi
    return lam, psi


def lattice_modes(
    nodes: np.ndarray,
    struts: np.ndarray,
    k: np.ndarray,
    masses: np.ndarray,
    *,
    n_rigid: int = 6,
    cache_dir: str | os.PathLike | None = None,
    use_cache: bool = True,
) -> Modes:
    r"""Undamped modes of :math:`\mathbf K\phi=\omega^2\mathbf M\phi` (module docstring).

    Args:
      nodes: ``(n, 3)`` undeformed positions [m] (where ``K`` is assembled).
      struts: ``(S, 2)`` node indices.
      k: ``(S,)`` spring constants [N/m].
      masses: ``(n,)`` particle masses [kg].
      n_rigid: rigid-body modes to clamp to ``omega = 0`` (6 for a free lattice, 0 if clamped).
      cache_dir: cache folder (default :func:`modes_cache_dir`).
      use_cache: read/write the ``.npz`` cache.

    Raises:
      ValueError: bad shapes, or the ``n_rigid`` lowest eigenvalues are not separated from the
        elastic ones (``λ_{n_rigid-1} > 1e-8 λ_{n_rigid}``): the lattice is a mechanism or
        ``n_rigid`` is wrong.
    """
    if int(n_rigid) != n_rigid or not 0 <= n_rigid <= 6:
        raise ValueError(f"n_rigid: must be an integer in 0..6, got {n_rigid!r}")
    nodes, struts, kn, mn, s_k, s_m = _normalised(nodes, struts, k, masses)
    key = _key(nodes, struts, kn, mn, n_rigid)
    path = modes_cache_dir(cache_dir) / f"modes_{nodes.shape[0]}n_{key}.npz"
    lam = psi = None
    if use_cache and path.exists():
        ndof = 3 * nodes.shape[0]
        try:
            with np.load(path, allow_pickle=False) as z:
                lam, psi = z["eigvals"], z["phi"]
            if lam.shape != (ndof,) or psi.shape != (ndof, ndof) or not np.all(np.isfinite(lam)):
                raise ValueError(f"{path}: cached modes of the wrong shape")
        except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
            lam = psi = None  # unreadable/truncated cache: recompute, rewrite
    if lam is None:
        lam, psi = _solve(nodes, struts, kn, mn)
        if use_cache:
            with atomic_path(path) as tmp:
                with open(tmp, "wb") as fh:
                    np.savez(fh, eigvals=lam, phi=psi)
    if n_rigid and n_rigid < lam.size and not abs(lam[n_rigid - 1]) <= 1e-8 * lam[n_rigid]:
        raise ValueError(
            f"n_rigid: the {n_rigid} lowest eigenvalues are not rigid modes "
            f"(lambda[{n_rigid - 1}] = {lam[n_rigid - 1]:.3e}, lambda[{n_rigid}] = {lam[n_rigid]:.3e})"
        )
    eigvals = lam * (s_k / s_m)
    omega = np.sqrt(np.clip(eigvals, 0.0, None))
    omega[:n_rigid] = 0.0
    phi = psi / np.sqrt(s_m)
    return Modes(omega=omega, phi=phi, masses=mn * s_m, n_rigid=int(n_rigid), eigvals=eigvals, key=key)


def damping_ratios(
    omega: np.ndarray,
    *,
    n_rigid: int = 6,
    schedule: Literal["paper_max", "capped_rayleigh"] = "paper_max",
    xi_low: float = 0.01,
    n_low: int = 100,
    xi_cap: float = 10.0,
) -> np.ndarray:
    r"""Modal damping ratios :math:`\xi` (Robb et al. 2022b, Eq. 15) (counted from the first elastic mode).

    With elastic mode numbers ``n = 1, 2, …`` (``omega[n_rigid + n - 1]``):

    * ``n <= n_low``: :math:`\xi_n=\xi_{low}`;
    * ``n > n_low``, Rayleigh-type value :math:`\rho_n=2\xi_{low}\omega_n/\omega_{n_{low}}`
      (the printed formula; note the factor-2 jump at ``n_low + 1``), then
      ``"paper_max"``: :math:`\xi_n=\max(\rho_n,\xi_{cap})` (the literal reading, default; 10
      on these lattices) or ``"capped_rayleigh"``: :math:`\xi_n=\min(\rho_n,\xi_{cap})`.

    Rigid modes get :math:`\xi=0`.

    Args:
      omega: ``(n_dof,)`` ascending frequencies [rad/s], rigid ones first.
      n_rigid: number of leading rigid modes.
      schedule: ``"paper_max"`` or ``"capped_rayleigh"``.
      xi_low: ratio of the first ``n_low`` elastic modes.
      n_low: number of elastic modes at ``xi_low`` (>= 1).
      xi_cap: the bound 10 of the paper.

    Returns:
      ``(n_dof,)`` damping ratios (dimensionless).
    """
    omega = np.asarray(omega, dtype=float)
    if omega.ndim != 1:
        raise ValueError(f"omega: expected a 1-D array, got shape {omega.shape}")
    if schedule not in SCHEDULES:
        raise ValueError(f"schedule: must be one of {SCHEDULES}, got {schedule!r}")
    if int(n_low) != n_low or n_low < 1:
        raise ValueError(f"n_low: must be an integer >= 1, got {n_low!r}")
    if not xi_low >= 0:
        raise ValueError(f"xi_low: must be >= 0, got {xi_low!r}")
    if not xi_cap > 0:
        raise ValueError(f"xi_cap: must be > 0, got {xi_cap!r}")
    if int(n_rigid) != n_rigid or not 0 <= n_rigid <= omega.size:
        raise ValueError(f"n_rigid: must be an integer in 0..{omega.size}, got {n_rigid!r}")
    xi = np.zeros_like(omega)
    el = omega[n_rigid:]
    xi_el = np.full(el.size, float(xi_low))
    if el.size > n_low:
        w_ref = el[n_low - 1]
        if not w_ref > 0:
            raise ValueError(f"omega: elastic mode {n_low} has omega = {w_ref!r}; cannot scale")
        rho = 2.0 * xi_low * el[n_low:] / w_ref
        xi_el[n_low:] = np.maximum(rho, xi_cap) if schedule == "paper_max" else np.minimum(rho, xi_cap)
    xi[n_rigid:] = xi_el
    return xi


def schedule_record(
    *, schedule: str, xi_low: float = 0.01, n_low: int = 100, xi_cap: float = 10.0, n_rigid: int = 6
) -> dict:
    """The damping-schedule choices as a flat dict for a run manifest."""
    return {
        "damping_schedule": schedule,
        "damping_xi_low": xi_low,
        "damping_n_low": n_low,
        "damping_xi_cap": xi_cap,
        "damping_mode_counting": MODE_COUNTING,
        "damping_n_rigid_excluded": n_rigid,
    }


def _check_modes(modes: Modes, ratios: np.ndarray) -> np.ndarray:
    ratios = np.asarray(ratios, dtype=float)
    if ratios.shape != modes.omega.shape:
        raise ValueError(f"ratios: expected shape {modes.omega.shape}, got {ratios.shape}")
    if np.any(ratios < 0):
        raise ValueError("ratios: must be >= 0")
    return ratios


def caughey_matrix(modes: Modes, ratios: np.ndarray, *, dtype=np.float64) -> np.ndarray:
    r"""Dense Caughey matrix :math:`\boldsymbol\gamma=\mathbf M\Phi\,\mathrm{diag}(2\xi\omega)\,\Phi^T\mathbf M`.

    Body-frame components [N s/m], ``(n_dof, n_dof)``, symmetric positive semi-definite; its
    null space holds the rigid modes (and any mode with ``xi = 0``).

    Args:
      modes: from :func:`lattice_modes`.
      ratios: ``(n_dof,)`` from :func:`damping_ratios`.
      dtype: storage type of the result (the product is formed in float64).
    """
    ratios = _check_modes(modes, ratios)
    c = 2.0 * ratios * modes.omega
    use = np.flatnonzero(c > 0)
    U = modes.mass_diag[:, None] * modes.phi[:, use]  # M Phi
    G = (U * c[use]) @ U.T
    G = 0.5 * (G + G.T)
    return G.astype(dtype, copy=False)


@dataclass(frozen=True)
class LowRankCaughey:
    r"""Exact cheap form :math:`\boldsymbol\gamma=c\mathbf K+\mathbf U\,\mathrm{diag}(d)\,\mathbf U^T`.

    Attributes:
      c: stiffness-proportional coefficient :math:`c=4\xi_{low}/\omega_{n_{low}}` [s]; the
        :math:`c\mathbf K` part is strut (tendon) damping ``b = c k`` [N s/m], which MuJoCo
        applies natively and co-rotationally.
      U: ``(n_dof, r)`` columns :math:`\mathbf M\phi_n` of the corrected modes [kg^1/2].
      d: ``(r,)`` :math:`2\xi_n\omega_n-c\,\omega_n^2` [1/s] (negative for
        :math:`\omega_n>\omega_{n_{low}}/2`; the sum with :math:`c\mathbf K` is positive).
      modes_index: ``(r,)`` the corrected mode columns.
    """

    c: float
    U: np.ndarray
    d: np.ndarray
    modes_index: np.ndarray

    def tendon_damping(self, k: np.ndarray) -> np.ndarray:
        """Strut dashpots ``b = c k`` [N s/m] for spring constants ``k`` [N/m]."""
        return self.c * np.asarray(k, dtype=float)

    def correction_matrix(self) -> np.ndarray:
        """Dense ``U diag(d) Uᵀ`` (for checks)."""
        return (self.U * self.d) @ self.U.T

    def apply(self, v: np.ndarray) -> np.ndarray:
        """``U diag(d) Uᵀ v`` for ``v`` of shape ``(n_dof,)``."""
        return self.U @ (self.d * (self.U.T @ v))


def caughey_low_rank(
    modes: Modes, ratios: np.ndarray, *, n_low: int = 100, xi_low: float | None = None, rtol: float = 1e-9
) -> LowRankCaughey:
    r"""Split :math:`\boldsymbol\gamma` into strut damping :math:`c\mathbf K` plus a low-rank part.

    :math:`c=2\cdot2\xi_{n_{low}}/\omega_{n_{low}}` makes :math:`c\,\omega_n^2=2\xi_n\omega_n`
    for every mode on the Rayleigh branch of ``"capped_rayleigh"``; every other mode (the first
    ``n_low`` and any capped one) goes into the correction. Exact because
    :math:`\mathbf K=\mathbf M\Phi\Omega^2\Phi^T\mathbf M` (rigid modes have :math:`\omega=0`).

    Args:
      modes: from :func:`lattice_modes`.
      ratios: ``(n_dof,)`` damping ratios (any schedule; for ``"paper_max"`` the rank is large).
      n_low: elastic mode (1-based) whose frequency fixes ``c``.
      xi_low: its ratio (default: read from ``ratios``).
      rtol: modes with ``|2ξω − cω²| <= rtol · 2ξω`` need no correction.
    """
    ratios = _check_modes(modes, ratios)
    j = modes.n_rigid + int(n_low) - 1
    if not modes.n_rigid <= j < modes.n_dof:
        raise ValueError(f"n_low: must be in 1..{modes.n_dof - modes.n_rigid}, got {n_low!r}")
    xi_ref = float(ratios[j]) if xi_low is None else float(xi_low)
    c = 4.0 * xi_ref / modes.omega[j]
    target = 2.0 * ratios * modes.omega
    d_all = target - c * modes.omega**2
    idx = np.flatnonzero(np.abs(d_all) > rtol * np.maximum(target, 1e-300))
    idx = idx[idx >= modes.n_rigid]
    U = modes.mass_diag[:, None] * modes.phi[:, idx]
    return LowRankCaughey(c=float(c), U=np.ascontiguousarray(U), d=d_all[idx], modes_index=idx)


@dataclass(frozen=True)
class StabilityProducts:
    r"""RK4 stability products of the damped modes ("Stability guidance").

    Attributes:
      damping_product: :math:`\max_n 2\xi_n\omega_n\Delta t` (the product reported in the manifest).
      fastest_root_product: :math:`\max_n|\lambda_n|\Delta t` with the exact roots
        :math:`\lambda=-\omega(\xi\pm\sqrt{\xi^2-1})` (overdamped) or :math:`|\lambda|=\omega`.
      omega_max_dt: :math:`\omega_{max}\Delta t`.
      limit_passive: 2.785, RK4's real-axis bound (damping evaluated at every stage).
      limit_held: 2.0, the forward-Euler bound (damping held over the step, ``xfrc``).
    """

    damping_product: float
    fastest_root_product: float
    omega_max_dt: float
    limit_passive: float = 2.785
    limit_held: float = 2.0

    def as_dict(self) -> dict:
        return {
            "stability_2xi_omega_dt": self.damping_product,
            "stability_fastest_root_dt": self.fastest_root_product,
            "stability_omega_max_dt": self.omega_max_dt,
            "stability_limit_passive": self.limit_passive,
            "stability_limit_held": self.limit_held,
        }


def stability_products(omega: np.ndarray, ratios: np.ndarray, *, dt: float) -> StabilityProducts:
    r"""Stability products for time step ``dt`` [s] (see :class:`StabilityProducts`)."""
    omega = np.asarray(omega, dtype=float)
    ratios = np.asarray(ratios, dtype=float)
    if ratios.shape != omega.shape:
        raise ValueError(f"ratios: expected shape {omega.shape}, got {ratios.shape}")
    if not dt > 0:
        raise ValueError(f"dt: must be > 0, got {dt!r}")
    root = np.where(ratios > 1.0, omega * (ratios + np.sqrt(np.maximum(ratios**2 - 1.0, 0.0))), omega)
    return StabilityProducts(
        damping_product=float(np.max(2.0 * ratios * omega) * dt),
        fastest_root_product=float(np.max(root) * dt),
        omega_max_dt=float(np.max(omega) * dt),
    )
