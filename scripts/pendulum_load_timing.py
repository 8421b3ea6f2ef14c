"""The magnetic pendulum's convergence and energy drift for each load timing.

A free rigid body (principal inertia 1, 1.5, 2 kg m²) with a body-fixed dipole m = (0, 0, 1) A m²
in the uniform field B = (1, 0, 0) T (torque (R m) × B), released from the tumbling state of
tests/test_load_timing.py, stepped with MuJoCo's RK4:

* ``start`` and ``midpoint``: the Python path, the torque held over the step in ``xfrc_applied``
  (``Simulation``, ``load_timing``);
* ``stage``: the compiled plugin ``magsail.dipole_in_field`` (:mod:`magsail_mj.compiled.dipole`),
  evaluated at every RK4 stage.

Prints a Markdown table of the attitude error after 6 s (about one swing) at δt = 0.05, 0.025,
0.0125 s against SciPy's DOP853 at rtol 1e-13 (``rigid_dipole_attitude``) and the observed order
of each halving, then the largest energy error |E − E₀| of E = ½ωᵀJω − (R m)·B over 600 s at
δt = 0.05 s, sampled every 100 steps::

    python scripts/pendulum_load_timing.py
"""

from __future__ import annotations

import magsail_mj  # noqa: F401  (picks the GL backend before MuJoCo loads)

import mujoco
import numpy as np

from magsail_mj.compiled.dipole import add_dipole_in_field
from magsail_mj.concepts.current_loops.rigid_reference import rigid_dipole_attitude
from magsail_mj.quaternion import quat_to_matrix
from magsail_mj.sim import Simulation

DIPOLE_BODY_AM2 = np.array([0.0, 0.0, 1.0])
FIELD_WORLD_T = np.array([1.0, 0.0, 0.0])
INERTIA_KG_M2 = np.array([1.0, 1.5, 2.0])
Q0 = np.array([np.cos(0.6), np.sin(0.6) / np.sqrt(2), np.sin(0.6) / np.sqrt(2), 0.0])
W0_BODY = np.array([0.3, -0.2, 0.5])
STEPS_S = (0.05, 0.025, 0.0125)
TIMINGS = ("start", "midpoint", "stage")


class DipoleLoad:
    """The Python load: world torque (R m) × B [N m] on body 1 into ``xfrc_applied``."""

    def add(self, state, xfrc: np.ndarray) -> None:
        xfrc[1, 3:] += np.cross(quat_to_matrix(state.xquat[1], normalise=True) @ DIPOLE_BODY_AM2, FIELD_WORLD_T)


def _model(dt: float, *, compiled: bool) -> mujoco.MjModel:
    spec = mujoco.MjSpec()
    spec.option.gravity = [0, 0, 0]
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    spec.option.timestep = dt
    body = spec.worldbody.add_body(name="bus", mass=1.0, inertia=INERTIA_KG_M2.tolist())
    body.add_freejoint()
    if compiled:
        add_dipole_in_field(spec, body="bus", dipole_body_Am2=DIPOLE_BODY_AM2, field_world_T=FIELD_WORLD_T)
    return spec.compile()


def _init(data: mujoco.MjData) -> None:
    data.qpos[3:7], data.qvel[3:6] = Q0, W0_BODY


def _stepper(dt: float, timing: str, duration_s: float):
    """(data, step(n)) of a run with the given load timing."""
    if timing == "stage":
        model = _model(dt, compiled=True)
        data = mujoco.MjData(model)
        _init(data)
        return data, lambda n: mujoco.mj_step(model, data, n)
    sim = Simulation(
        model=_model(dt, compiled=False),
        duration_s=duration_s,
        loads=[DipoleLoad()],
        init=_init,
        record_every=10**9,
        load_timing=timing,
    )
    return sim.data, sim.step


def _energy_J(data: mujoco.MjData) -> float:
    R = quat_to_matrix(data.qpos[3:7], normalise=True)
    w = data.qvel[3:6]
    return 0.5 * float(np.sum(INERTIA_KG_M2 * w * w)) - float((R @ DIPOLE_BODY_AM2) @ FIELD_WORLD_T)


def _angle(Ra: np.ndarray, Rb: np.ndarray) -> float:
    D = Ra.T @ Rb
    s = 0.5 * np.linalg.norm([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
    return float(np.arctan2(s, 0.5 * (np.trace(D) - 1)))


def main() -> None:
    R_ref, _ = rigid_dipole_attitude(
        np.array([0.0, 6.0]),
        inertia=np.diag(INERTIA_KG_M2),
        dipole_body=DIPOLE_BODY_AM2,
        field_world=FIELD_WORLD_T,
        R0=quat_to_matrix(Q0),
        omega0_body=W0_BODY,
        rtol=1e-13,
        atol=1e-15,
    )
    errors = {}
    for timing in TIMINGS:
        errors[timing] = []
        for dt in STEPS_S:
            data, step = _stepper(dt, timing, 6.0)
            step(int(round(6.0 / dt)))
            errors[timing].append(_angle(quat_to_matrix(data.qpos[3:7], normalise=True), R_ref[-1]))
    print("| δt [s] | " + " | ".join(f"{t}: error [rad] | order" for t in TIMINGS) + " |")
    print("| --- " * (1 + 2 * len(TIMINGS)) + "|")
    for i, dt in enumerate(STEPS_S):
        cells = []
        for timing in TIMINGS:
            e = errors[timing]
            cells += [f"{e[i]:.2e}", f"{np.log2(e[i - 1] / e[i]):.2f}" if i else "–"]
        print(f"| {dt} | " + " | ".join(cells) + " |")
    for timing in TIMINGS:
        data, step = _stepper(0.05, timing, 600.0)
        e0, worst = _energy_J(data), 0.0
        for _ in range(120):
            step(100)
            worst = max(worst, abs(_energy_J(data) - e0))
        print(f"energy drift over 600 s at δt = 0.05 s, {timing}: {worst:.2e} J (E0 = {e0:.4f} J)")


if __name__ == "__main__":
    main()
