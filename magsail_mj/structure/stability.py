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
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

__all__ = ["UNSTABLE_GROWTH", "largest_stable_fraction", "step_growth"]

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
