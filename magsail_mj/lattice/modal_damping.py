r"""Co-rotated Caughey (modal) damping of a flexible lattice (Robb et al. 2022b, Eq. 15).

Force on the particles, world components (``r``, ``ṙ`` the flattened world positions and
velocities of the ``n`` nodes):

.. math::

    \mathbf F^{damp}=-\tilde R\,\boldsymbol\gamma\,\tilde R^T\dot{\mathbf r},\qquad
    \tilde R=\mathbf I_n\otimes R_\theta ,

with :math:`\boldsymbol\gamma` the body-frame Caughey matrix of
:mod:`magsail_mj.lattice.modes` (components in the frame of the undeformed ``nodes``) and
:math:`R_\theta` (body → world) the **mass-weighted** best-fit rotation of the current node set
against ``nodes`` about the centres of mass:
:math:`H=\sum_im_i(\mathbf r_{0i}-\mathbf c_0)(\mathbf r_i-\mathbf c)^T=USV^T`,
:math:`R_\theta=V\,\mathrm{diag}(1,1,\det VU^T)\,U^T`. Rigid motion of the rotated structure is
then undamped. ``frame="inertial"`` uses :math:`R_\theta=I` (the paper's literal
:math:`\boldsymbol\gamma\dot{\mathbf r}`, which damps large rigid rotations: sensitivity only).

Before the product the rigid-body part of the body-frame velocity is removed exactly,
:math:`\mathbf v\leftarrow\mathbf v-\Phi_r\Phi_r^T\mathbf M\mathbf v` (:math:`\Phi_r` the six
M-orthonormal rigid modes of ``nodes``). Mathematically a no-op
(:math:`\boldsymbol\gamma\Phi_r=0`), it keeps the float32 product from leaking a spurious
rigid-body damping of order :math:`10^{-7}\lVert\boldsymbol\gamma\rVert\lVert\mathbf v\rVert`.

Dissipated power (for the energy balance):
:math:`P=\dot{\mathbf r}^T\tilde R\boldsymbol\gamma\tilde R^T\dot{\mathbf r}=-\mathbf F^{damp}\cdot\dot{\mathbf r}\ge0`.

Injection
---------
* ``add(state, xfrc)`` (the project's single door, :mod:`magsail_mj.loads.base`): the force is
  computed once per step and held over the step (first order in the damping term).
* :func:`passive_damping` (context manager): a process-global ``mjcb_passive`` callback adds the
  force into ``qfrc_passive`` of the particles' slide DOFs, so RK4 evaluates it at every stage.

Forms of the product
--------------------
* ``"dense"`` (default, the reference): the stored ``3n × 3n`` γ, one dense mat-vec.
* ``"low_rank"``: exact for ``capped_rayleigh`` (strut dashpots ``b = c k`` plus a low-rank part).
* ``"polynomial"``: :mod:`magsail_mj.lattice.low_rank_polynomial`, a polynomial of the sparse
  mass-scaled stiffness plus an exact low-rank correction of the first ``n_low`` modes; every
  mode above them gets its scheduled ratio within ``rtol`` (relative), no mode is coupled to
  another, and the cost is ``degree`` sparse mat-vecs instead of the dense product.
"""

from __future__ import annotations

import contextlib
from typing import Iterator, Literal

import mujoco
import numpy as np

from magsail_mj.lattice.modes import (
    LowRankCaughey,
    Modes,
    caughey_low_rank,
    caughey_matrix,
    damping_ratios,
    lattice_modes,
)
from magsail_mj.lattice.low_rank_polynomial import PolynomialCaughey, caughey_polynomial
from magsail_mj.loads.base import StepState

__all__ = ["FORMS", "ModalDampingLoad", "weighted_best_fit_rotation", "passive_damping", "PassiveDamping"]

FORMS = ("dense", "low_rank", "polynomial")
"""Ways to apply γ (module docstring, "Forms of the product")."""


def weighted_best_fit_rotation(ref_c: np.ndarray, w: np.ndarray, pos: np.ndarray) -> np.ndarray:
    r"""Mass-weighted Kabsch rotation (body → world) of ``pos`` against a centred reference.

    Args:
      ref_c: ``(n, 3)`` reference positions minus their weighted centroid.
      w: ``(n,)`` weights (masses).
      pos: ``(n, 3)`` current positions.
    Returns:
      ``(3, 3)`` :math:`R` minimising :math:`\sum_iw_i|R\,\mathrm{ref}_i+d-\mathrm{pos}_i|^2`.
    """
    c = (w @ pos) / w.sum()
    H = (ref_c * w[:, None]).T @ (pos - c)
    U, _, Vt = np.linalg.svd(H)
    V = Vt.T
    if np.linalg.det(V @ U.T) < 0.0:
        V[:, 2] *= -1.0
    return V @ U.T


class ModalDampingLoad:
    r"""Co-rotated Caughey damping as a :class:`~magsail_mj.loads.base.Load` (module docstring).

    Args:
      modes: the lattice's modes (gives ``nodes``' rigid basis and the masses).
      nodes: ``(n, 3)`` undeformed node positions [m] (the frame of ``gamma``).
      gamma: dense ``(3n, 3n)`` Caughey matrix [N s/m] (:func:`~magsail_mj.lattice.modes.caughey_matrix`)
        or a :class:`~magsail_mj.lattice.modes.LowRankCaughey` (then only its low-rank part is
        applied here; its ``c K`` part must be in the model as tendon damping ``b = c k``), or a
        :class:`~magsail_mj.lattice.low_rank_polynomial.PolynomialCaughey` (applied whole).
      frame: ``"body"`` (co-rotated, default) or ``"inertial"`` (literal Eq. 12).
      dtype: storage/product type of a dense ``gamma``: ``np.float32`` (default; half the memory
        traffic, see README for the measured accuracy) or ``np.float64``.
      body_offset: node ``i`` is body ``i + body_offset`` (1 for the truss models).
      remove_rigid: project the rigid-body velocity out before the product (default ``True``).

    Attributes:
      last_power_W: dissipated power :math:`P` of the last evaluation [W].
      last_forces: ``(n, 3)`` world-frame forces of the last evaluation [N].
      last_R: the last :math:`R_\theta` (body → world).
      modes: the ``modes`` given.
      ratios: the damping ratios (set by :meth:`for_lattice`, else ``None``).
    """

    name = "modal_damping"

    def __init__(
        self,
        *,
        modes: Modes,
        nodes: np.ndarray,
        gamma: np.ndarray | LowRankCaughey | PolynomialCaughey,
        frame: Literal["body", "inertial"] = "body",
        dtype=np.float32,
        body_offset: int = 1,
        remove_rigid: bool = True,
    ) -> None:
        nodes = np.asarray(nodes, dtype=float)
        n = modes.masses.size
        if nodes.shape != (n, 3):
            raise ValueError(f"nodes: expected shape ({n}, 3), got {nodes.shape}")
        if frame not in ("body", "inertial"):
            raise ValueError(f"frame: must be 'body' or 'inertial', got {frame!r}")
        if np.dtype(dtype) not in (np.dtype(np.float32), np.dtype(np.float64)):
            raise ValueError(f"dtype: must be float32 or float64, got {dtype!r}")
        if int(body_offset) != body_offset or body_offset < 0:
            raise ValueError(f"body_offset: must be an integer >= 0, got {body_offset!r}")
        self.n = n
        self.frame = frame
        self.body_offset = int(body_offset)
        self.masses = modes.masses.copy()
        self._m3 = np.repeat(self.masses, 3)
        self._ref_c = nodes - (self.masses @ nodes) / self.masses.sum()
        self._rigid = np.ascontiguousarray(modes.rigid_phi) if remove_rigid and modes.n_rigid else None
        self._rigid_M = (self._rigid * self._m3[:, None]).T.copy() if self._rigid is not None else None
        if isinstance(gamma, (LowRankCaughey, PolynomialCaughey)):
            if gamma.U.shape[0] != 3 * n:
                raise ValueError(f"gamma: low-rank U has {gamma.U.shape[0]} rows, expected {3 * n}")
            self._dense = None
            self._low = gamma
            self.dtype = np.dtype(gamma.U.dtype)
        else:
            g = np.asarray(gamma)
            if g.shape != (3 * n, 3 * n):
                raise ValueError(f"gamma: expected shape ({3 * n}, {3 * n}), got {g.shape}")
            self._dense = np.ascontiguousarray(g, dtype=dtype)
            self._low = None
            self.dtype = np.dtype(dtype)
        self.last_power_W = 0.0
        self.last_R = np.eye(3)
        self.last_forces = np.zeros((n, 3))
        self.modes = modes
        self.ratios: np.ndarray | None = None
        self._sl = slice(self.body_offset, self.body_offset + n)

    @classmethod
    def for_lattice(
        cls,
        *,
        nodes: np.ndarray,
        struts: np.ndarray,
        k: np.ndarray,
        masses: np.ndarray,
        schedule: Literal["paper_max", "capped_rayleigh"] = "paper_max",
        xi_low: float = 0.01,
        n_low: int = 100,
        xi_cap: float = 10.0,
        form: Literal["dense", "low_rank", "polynomial"] = "dense",
        rtol: float = 0.02,
        frame: Literal["body", "inertial"] = "body",
        dtype=np.float32,
        body_offset: int = 1,
        cache_dir=None,
        modes: Modes | None = None,
    ) -> "ModalDampingLoad":
        """Modes (cached, or ``modes`` if given), schedule and γ of a free lattice in one call.

        ``form="low_rank"`` (only sensible with ``"capped_rayleigh"``) returns a load applying
        the low-rank part only; the model then needs tendon damping ``load.tendon_damping(k)``.
        ``form="polynomial"``: every mode above ``n_low`` gets its ratio within ``rtol``
        (relative; :func:`~magsail_mj.lattice.low_rank_polynomial.caughey_polynomial`), the others
        exactly (low-rank factor in float64 whatever ``dtype``); ``rtol`` is ignored by the other forms.
        """
        if form not in FORMS:
            raise ValueError(f"form: must be one of {FORMS}, got {form!r}")
        if modes is None:
            modes = lattice_modes(nodes, struts, k, masses, cache_dir=cache_dir)
        xi = damping_ratios(
            modes.omega, n_rigid=modes.n_rigid, schedule=schedule, xi_low=xi_low, n_low=n_low, xi_cap=xi_cap
        )
        if form == "dense":
            gamma = caughey_matrix(modes, xi, dtype=dtype)
        elif form == "low_rank":
            gamma = caughey_low_rank(modes, xi, n_low=n_low, xi_low=xi_low)
        else:
            # float64 low-rank factor: in float32 its round-off (~1e-7 of p(λ) ≈ 20 ω) would be
            # ~0.5 % of the ξ = 0.01 ratios it corrects (measured at N = 12), for ~0.05 ms saved
            gamma = caughey_polynomial(modes, xi, nodes=nodes, struts=struts, k=k, n_low=n_low, rtol=rtol)
        load = cls(modes=modes, nodes=nodes, gamma=gamma, frame=frame, dtype=dtype, body_offset=body_offset)
        load.ratios = xi
        return load

    def tendon_damping(self, k: np.ndarray) -> np.ndarray:
        """Strut dashpots ``b = c k`` the model needs with a low-rank γ (zeros for a dense γ)."""
        k = np.asarray(k, dtype=float)
        return self._low.tendon_damping(k) if isinstance(self._low, LowRankCaughey) else np.zeros_like(k)

    @property
    def polynomial(self) -> PolynomialCaughey | None:
        """The polynomial-plus-low-rank γ of the ``polynomial`` form (``None`` for the others)."""
        return self._low if isinstance(self._low, PolynomialCaughey) else None

    @property
    def effective_ratios(self) -> np.ndarray | None:
        """Damping ratio each mode gets (``polynomial`` form; the schedule ``ratios`` otherwise)."""
        if isinstance(self._low, PolynomialCaughey):
            return self._low.effective_ratios(self.modes.omega)
        return self.ratios

    # ------------------------------------------------------------------ core
    def rotation(self, pos: np.ndarray) -> np.ndarray:
        """:math:`R_\\theta` (body → world) of node positions ``pos`` ``(n, 3)``; ``I`` if inertial."""
        if self.frame == "inertial":
            return np.eye(3)
        return weighted_best_fit_rotation(self._ref_c, self.masses, pos)

    def gamma_apply(self, v_body: np.ndarray) -> np.ndarray:
        r""":math:`\boldsymbol\gamma\mathbf v` for a flattened body-frame velocity ``(3n,)`` [N]."""
        v = v_body
        if self._rigid is not None:
            v = v - self._rigid @ (self._rigid_M @ v)
        if self._dense is not None:
            if self.dtype == np.float32:
                return (self._dense @ v.astype(np.float32)).astype(np.float64)
            return self._dense @ v
        return self._low.apply(v)

    def forces(self, pos: np.ndarray, vel: np.ndarray) -> np.ndarray:
        r"""``(n, 3)`` world-frame damping forces :math:`-\tilde R\gamma\tilde R^T\dot r` [N].

        Also sets :attr:`last_power_W` and :attr:`last_R`.
        """
        R = self.rotation(pos)
        v_body = (vel @ R).reshape(-1)  # R^T v_i for every node
        g = self.gamma_apply(v_body).reshape(self.n, 3)
        F = -(g @ R.T)
        self.last_R = R
        self.last_forces = F
        self.last_power_W = float(-np.einsum("ij,ij->", F, vel))
        return F

    def power(self, pos: np.ndarray, vel: np.ndarray) -> float:
        r"""Dissipated power :math:`\dot r^T\tilde R\gamma\tilde R^T\dot r` [W] at ``(pos, vel)``."""
        self.forces(pos, vel)
        return self.last_power_W

    # ------------------------------------------------------------------ Load protocol
    def add(self, state: StepState, xfrc: np.ndarray) -> None:
        """Add the held damping force of the current state into ``xfrc[:, :3]`` (world frame)."""
        xfrc[self._sl, :3] += self.forces(state.pos[self._sl], state.vel[self._sl])


class PassiveDamping:
    """``mjcb_passive`` callback adding a :class:`ModalDampingLoad` force into ``qfrc_passive``.

    The callback acts only on the model it was built for (other models stepped in the same
    process while it is installed are left alone). Node ``i`` must be a body with three
    world-aligned slide joints (the truss builder's particles); its position is
    ``body_pos + qpos[x, y, z]``.

    Attributes:
      calls: number of evaluations (4 per RK4 step).
      last_power_W: dissipated power of the last evaluation [W].
    """

    def __init__(self, model: mujoco.MjModel, load: ModalDampingLoad) -> None:
        bodies = np.arange(load.body_offset, load.body_offset + load.n)
        if bodies[-1] >= model.nbody:
            raise ValueError(f"model: has {model.nbody} bodies, the load needs {bodies[-1] + 1}")
        jn = model.body_jntnum[bodies]
        if np.any(jn != 3):
            raise ValueError("model: every damped node must have exactly three slide joints")
        ja = model.body_jntadr[bodies][:, None] + np.arange(3)
        if np.any(model.jnt_type[ja] != mujoco.mjtJoint.mjJNT_SLIDE) or not np.allclose(
            model.jnt_axis[ja], np.broadcast_to(np.eye(3), ja.shape + (3,))
        ):
            raise ValueError("model: node joints must be world-aligned x, y, z slide joints")
        self.model = model
        self.load = load
        self._address = model._address
        self._q = model.jnt_qposadr[ja]
        self._v = model.jnt_dofadr[ja].ravel()
        self._pos0 = model.body_pos[bodies].copy()
        self.calls = 0
        self.last_power_W = 0.0

    def __call__(self, m: mujoco.MjModel, d: mujoco.MjData) -> None:
        if m._address != self._address:
            return
        pos = self._pos0 + d.qpos[self._q]
        vel = d.qvel[self._v].reshape(-1, 3)
        F = self.load.forces(pos, vel)
        d.qfrc_passive[self._v] += F.ravel()
        self.calls += 1
        self.last_power_W = self.load.last_power_W


@contextlib.contextmanager
def passive_damping(model: mujoco.MjModel, load: ModalDampingLoad) -> Iterator[PassiveDamping]:
    """Install the damping as MuJoCo's (process-global) ``mjcb_passive`` for the ``with`` block.

    The previous callback is restored on exit, also on error. Refuses to replace a callback
    that is already installed (two users of the global hook would silently exclude each other).

    Usage::

        with passive_damping(model, load) as cb:
            sim.run()      # the load must NOT also be in sim.loads
    """
    prev = mujoco.get_mjcb_passive()
    if prev is not None:
        raise RuntimeError("passive_damping: an mjcb_passive callback is already installed")
    cb = PassiveDamping(model, load)
    mujoco.set_mjcb_passive(cb)
    try:
        yield cb
    finally:
        mujoco.set_mjcb_passive(prev)
