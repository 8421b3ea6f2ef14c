"""One body-torque law, three spacecraft: the truss with magnetorquer rods, the CNUSAIL cubesat and
the gossamer reflector, each driven through its dm_control environment.

The law is :class:`magsail_mj.control.quaternion_feedback.QuaternionPD`,
``T = −P_q q_e,vec − P_ω ω_e`` [N m, body axes], with gains from a closed-loop bandwidth,
``P_q = 2 I ω_n²`` and ``P_ω = 2 ζ ω_n I`` per principal axis. It reads the environment's
observation through a small sensor adapter: the error quaternion and rate error to the task's
target (the truss slew's ``target_wxyz``, the cubesat's ``pointing_error_wxyz``/``rate_error_rad_s``,
the reflector's steering reference ``target_wxyz``/``target_rate_rad_s``) and so always regulates
to the identity error. Each environment turns the request into its own hardware's torque:

* truss (``truss/slew_I``, ``action="torque"``): the rod allocation (Robb et al. 2022a, Eqs. 11–13) and Lloyd selection;
  delivered = the rods' torque ``Σ m_r × B`` on the deformed struts (``torque_ac_body_Nm``);
* cubesat (``cnusail/nadir``, ``action="torque_dipole"``, dipole 0): the reaction-wheel driver;
  delivered = the motor reaction on the bus ``−T_M`` (``T_M_Nm``; bearing friction left out);
* reflector (``reflector/pitch_tracking``): projection ⟂ B and the coil torque cap;
  delivered = the applied ``torque_body_Nm``.

Printed per spacecraft: steps, wall time per environment step, the return, the final error angle,
the mean requested and delivered torque magnitudes and the mean cosine between them (1 = delivered
along the request).

    python examples/same_law_three_concepts.py --duration-s 60 --units 3
"""

from __future__ import annotations

import argparse
import json
import math
import time
from typing import Any

import numpy as np

from magsail_mj import envs
from magsail_mj.control.quaternion_feedback import QuaternionPD
from magsail_mj.quaternion import error_quaternion

CASES = {
    # task, environment options, ω_n [rad/s], (request key, delivered key, sign of delivered)
    "truss": ("truss/slew_I", {"action": "torque"}, 0.005, ("torque_ref_body_Nm", "torque_ac_body_Nm", 1.0)),
    "cubesat": ("cnusail/nadir", {"action": "torque_dipole"}, 0.05, ("u_cmd_Nm", "T_M_Nm", -1.0)),
    "reflector": ("reflector/pitch_tracking", {}, 0.01, ("T_ref_body_Nm", "torque_body_Nm", 1.0)),
}
ZETA = 0.7


def error_sensor(obs: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """``(q_e, ω_e)``: attitude and rate relative to the task's target, from the observation."""
    if "pointing_error_wxyz" in obs:
        return obs["pointing_error_wxyz"], obs["rate_error_rad_s"]
    q_e = error_quaternion(obs["target_wxyz"], obs["attitude_wxyz"])
    rate = obs["body_rate_rad_s"] - obs.get("target_rate_rad_s", np.zeros(3))
    return q_e, rate


def principal_inertia(env: Any) -> np.ndarray:
    """Principal moments [kg m²] for the gain design: a lattice's particle inertia about its centre
    of mass, else the diagonal inertia of the spacecraft's free body."""
    physics = env.physics
    kin, model = physics.sim.kin, physics.model
    if kin.part_body.size:
        p, m = kin.pos0[kin.part_body], model.body_mass[kin.part_body]
        r = p - np.average(p, axis=0, weights=m)
        J = np.einsum("i,ij,ik->jk", m, r, r)
        return np.linalg.eigvalsh(np.trace(J) * np.eye(3) - J)
    return np.asarray(model.body_inertia[int(kin.free_body[0])], dtype=float)


def torque_action(env: Any, torque: np.ndarray) -> np.ndarray:
    """The environment's action for a body-torque request (the cubesat's dipole part is zero)."""
    n = env.action_spec().shape[0]
    return np.concatenate([torque, np.zeros(n - 3)])


def drive(name: str, *, duration_s: float, units: int) -> dict[str, Any]:
    """Run the law on one spacecraft; return its figures."""
    task, options, omega_n, (req_key, del_key, sign) = CASES[name]
    overrides = [f"sim.duration_s={duration_s}"]
    if name == "truss":
        overrides += [f"lattice.units={units}"]
    env = envs.load(task, overrides, randomize=False, **options)
    pd = QuaternionPD.from_bandwidth(
        sensor=error_sensor,
        q_ref_wxyz=(1.0, 0.0, 0.0, 0.0),
        inertia_kgm2=principal_inertia(env),
        omega_n_rad_s=omega_n,
        zeta=ZETA,
        period_s=env.control_timestep(),
    )
    wall0 = time.perf_counter()
    total, steps = envs.run_episode(env, lambda ts: torque_action(env, pd.update(ts.observation).torque_body_Nm))
    wall = time.perf_counter() - wall0
    rec = env.physics.result().records
    req, dlv = np.asarray(rec[req_key], dtype=float), sign * np.asarray(rec[del_key], dtype=float)
    n_req, n_del = np.linalg.norm(req, axis=1), np.linalg.norm(dlv, axis=1)
    both = (n_req > 0) & (n_del > 0)
    cos = np.einsum("ij,ij->i", req[both], dlv[both]) / (n_req[both] * n_del[both])
    q_e, _ = error_sensor(env.task.current_observation(env.physics))
    return {
        "spacecraft": name,
        "task": task,
        "steps": steps,
        "wall_per_step_ms": 1e3 * wall / max(steps, 1),
        "return": total,
        "final_error_deg": math.degrees(2 * math.acos(min(1.0, abs(float(q_e[0]))))),
        "mean_request_Nm": float(n_req.mean()),
        "mean_delivered_Nm": float(n_del.mean()),
        "mean_cos_request_delivered": float(cos.mean()) if cos.size else float("nan"),
        "status": env.physics.status,
    }


def main(argv: list[str] | None = None) -> list[dict[str, Any]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration-s", type=float, default=60.0, help="simulated time per spacecraft [s]")
    parser.add_argument("--units", type=int, default=3, help="truss cubes per side (the shipped truss has 19)")
    args = parser.parse_args(argv)
    rows = []
    for name in CASES:
        row = drive(name, duration_s=args.duration_s, units=args.units)
        print(json.dumps(row))
        rows.append(row)
    return rows


if __name__ == "__main__":
    main()
