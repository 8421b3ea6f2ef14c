r"""Whether a model's time step is stable for its stiffest modes: the growth of a small disturbance per step.

A spring-mass model stepped explicitly is stable only while ``ω Δt`` of its highest mode stays
inside the integrator's stability region (undamped: ``ω Δt < 2`` for MuJoCo's semi-implicit
Euler, ``< 2.785`` for RK4; MuJoCo integrates spring stiffness explicitly with every
integrator). Past it the highest modes grow by a factor ``|λ| > 1`` per step from round-off, the
run blows up, and the blow-up first shows as a member strained past its limit — read as a
failed structure where the step was at fault.

:func:`step_growth` estimates the spectral radius ``ρ`` of the linearised step map
``x_{k+1} = A x_k`` about the model's reference state at rest (``qpos0``, zero velocity, no
applied loads) by power iteration with finite differences: the state ``x = (δq, δv Δt)``
(positions in the tangent space, ``mj_integratePos`` / ``mj_differentiatePos``; velocities scaled
by the step so that both halves are of one size near the stability limit) is perturbed by
``ε = 10⁻⁷`` along the current vector, stepped once with ``mj_step``, and its difference from the
reference state's own step (pre-stressed members move it) divided by ``ε``. ``ρ`` is the geometric
mean of the growth over the second half of the iterations.
Modes of zero frequency (rigid-body motions) grow linearly, not geometrically, and read as
``1 + ln 2 / (n/2)`` (1.014 at the default 100 iterations); a mode past the stability limit grows
geometrically: 3 % past the limit reads 1.11 (RK4) to 1.6 (Euler) on a two-mass spring
(``tests/test_structure_stability.py``), so :data:`UNSTABLE_GROWTH` = 1.05 separates the two.
A mode less than about 3 % past the limit grows too slowly to be told apart here; the run's own
divergence checks still catch it.

:func:`stable_timestep_s` proposes a step for a structure alone (no task config to give one): the
undamped limits ``2 / ω_max`` (Euler) and ``2.785 / ω_max`` (RK4) of its highest natural
frequency ``ω_max`` (the largest eigenvalue of ``K_r q = ω² M_r q``, the modal analysis's reduced
stiffness and lumped mass, by Lanczos iteration: sparse, no factor of ``K``), times
:data:`STEP_SAFETY`. MuJoCo's model of the same structure is not the modal model (beam chains,
tendon attachments, rotary inertia of the node bodies), so the step is then checked on the
compiled model with :func:`step_growth`.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from scipy.sparse.linalg import eigsh

from magsail_mj.structure.assembly import Assembly

__all__ = [
    "STABILITY_LIMITS",
    "STEP_SAFETY",
    "UNSTABLE_GROWTH",
    "highest_frequency_rad_s",
    "largest_stable_fraction",
    "stable_timestep_s",
    "step_growth",
]

#: undamped stability limit of ``ω Δt`` for each explicit integrator (module docstring)
STABILITY_LIMITS = {"Euler": 2.0, "RK4": 2.785}
#: fraction of the undamped limit :func:`stable_timestep_s` proposes (room for the difference between
#: the modal model and MuJoCo's, and for damping, which moves Euler's limit down)
STEP_SAFETY = 0.5

#: growth per step above which the step is unstable (module docstring)
UNSTABLE_GROWTH = 1.05
_EPS = 1e-7


def step_growth(model: mujoco.MjModel, *, iterations: int = 100, seed: int = 0) -> float:
    """Spectral radius of the linearised step about ``qpos0`` at rest (module docstring).

    Args:
      model: the compiled model, with its time step and integrator.
      iterations: power iterations (one ``mj_step`` each).
      seed: seed of the random start vector.
    """
    nv, h = model.nv, float(model.opt.timestep)
    if nv == 0:
        return 0.0
    data = mujoco.MjData(model)
    q0 = np.array(model.qpos0)
    mujoco.mj_resetData(model, data)
    mujoco.mj_step(model, data)  # the reference state's own step (pre-stressed members move it)
    q1, v1 = np.array(data.qpos), np.array(data.qvel)
    vector = np.random.default_rng(seed).standard_normal(2 * nv)
    vector /= np.linalg.norm(vector)
    qpos, dq = np.empty_like(q0), np.empty(nv)
    logs = np.empty(iterations)
    for i in range(iterations):
        mujoco.mj_resetData(model, data)
        qpos[:] = q0
        mujoco.mj_integratePos(model, qpos, vector[:nv] * _EPS, 1.0)
        data.qpos[:] = qpos
        data.qvel[:] = vector[nv:] * (_EPS / h)
        mujoco.mj_step(model, data)
        mujoco.mj_differentiatePos(model, dq, 1.0, q1, data.qpos)
        stepped = np.concatenate([dq, (data.qvel - v1) * h]) / _EPS
        norm = float(np.linalg.norm(stepped))
        if not math.isfinite(norm) or norm == 0.0:
            return math.inf if not math.isfinite(norm) else 0.0
        logs[i] = math.log(norm)
        vector = stepped / norm
    return math.exp(float(np.mean(logs[iterations // 2 :])))


def largest_stable_fraction(model: mujoco.MjModel, *, halvings: int = 6, iterations: int = 100) -> float | None:
    """The largest ``2⁻ᵏ`` (``k = 1 … halvings``) at which the model's step ``2⁻ᵏ Δt`` is stable
    (:func:`step_growth` at most :data:`UNSTABLE_GROWTH`), or ``None``. The model's time step is
    restored."""
    h = float(model.opt.timestep)
    try:
        for k in range(1, halvings + 1):
            model.opt.timestep = h / 2**k
            if step_growth(model, iterations=iterations) <= UNSTABLE_GROWTH:
                return 1.0 / 2**k
        return None
    finally:
        model.opt.timestep = h


def highest_frequency_rad_s(assembly: Assembly) -> float:
    """The highest natural frequency ``ω_max`` [rad/s] of the assembled structure: the largest
    eigenvalue of ``K_r q = ω² M_r q`` (Lanczos, relative tolerance 1e-3; 0 for a structure without
    stiffness)."""
    if assembly.K_r.shape[0] == 0 or assembly.K_r.nnz == 0:
        return 0.0
    if assembly.K_r.shape[0] == 1:
        return math.sqrt(max(float(assembly.K_r[0, 0] / assembly.M_r[0, 0]), 0.0))
    lam = eigsh(assembly.K_r, k=1, M=assembly.M_r, which="LA", return_eigenvectors=False, tol=1e-3)
    return math.sqrt(max(float(lam[0]), 0.0))


def stable_timestep_s(omega_max_rad_s: float, integrator: str) -> float:
    """:data:`STEP_SAFETY` times the undamped limit ``c / ω_max`` of ``integrator``
    (:data:`STABILITY_LIMITS`) [s]; ``math.inf`` for ``ω_max = 0``.

    Raises:
      ValueError: ``integrator`` has no limit here (an implicit integrator: named).
    """
    if integrator not in STABILITY_LIMITS:
        raise ValueError(f"integrator: must be one of {sorted(STABILITY_LIMITS)}, got {integrator!r}")
    if omega_max_rad_s <= 0.0:
        return math.inf
    return STEP_SAFETY * STABILITY_LIMITS[integrator] / omega_max_rad_s
