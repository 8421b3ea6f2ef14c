r"""Searching for a controller for truss slews III and IV on a reduced rigid model (Robb et al. 2022a, Sec. 4.3).

The reduced model is the rigid twin of ``scripts/truss_rigid_slew.py`` made cheap: one rigid body
with the particle inertia, the classical gravity-gradient torque and the field and orbit of the
config (its own ``Environment``, sampled every second), the rods as the total dipole
``m = (N_1 m_1, N_2 m_2, 0)`` of the allocation (the Lloyd selection only places the rods), no
rate estimation, control and RK4 every ``--dt`` seconds (1 s; the twin steps at 0.1 s). On slew I
with the listed gains it ends 0.77° off and settles at 8 231 s; the twin: 0.775° and 8 230 s.

Modes (each prints one JSON line per run):

* ``pd``: quaternion PD (``T_ref = −P_q q_e − P_ω ω``, optionally minus the gravity-gradient
  torque) through the allocation, with the listed gains or gains of one natural frequency
  ``ω_n`` (``P_q = 2 J ω_n²``, ``P_ω = 2 J ω_n``, critically damped), with and without the
  compensation;
* ``hold``: the rods off, the listed gains, and low in-plane gains (``P_q = (0.4, 0.4, 2) N m``)
  with and without the compensation, started 4° off the target at rest;
* ``programme``: an open-loop dipole programme, piecewise constant over ``--segment`` seconds up
  to ``--horizon``, that minimises ``(error/1°)² + (|ω|/2e-5 rad/s)²`` at the horizon
  (L-BFGS-B, forward-difference gradient over a batch of copies of the model, RK4 at 10 s).

    python scripts/truss_slew_control_search.py pd slew_iii slew_iv
    python scripts/truss_slew_control_search.py hold slew_iv
    python scripts/truss_slew_control_search.py programme slew_iv --iterations 200
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Callable

import numpy as np
from scipy.optimize import minimize

import magsail_mj
from magsail_mj.control.allocation import allocate
from magsail_mj.estimation.attitude import particle_inertia
from magsail_mj.quaternion import error_quaternion, quat_from_axis_angle, quat_mul

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "truss_magnetorquer" / "configs"
LISTED = ((10.0, 50.0, 1.0), (1600.0, 8000.0, 800.0))
"""The configs' gains P_q [N m], P_ω [N m s]."""


def load_case(config_id: str) -> dict:
    """Field and position every second over the run, inertia, attitudes and rod limits of a config."""
    sc = magsail_mj.load(MODELS / f"{config_id}.toml").scenario
    cfg = sc.cfg
    t = np.arange(0.0, cfg.sim.duration_s + 2.0, 1.0)
    env = sc.environment.sample_many(t)
    m_rod = np.asarray(sc.rod_load.m_rod_Am2, dtype=float)
    n_max = np.asarray(sc.rod_load.rods.n_per_family)
    return {
        "B": env["B_eci"],
        "r": env["r_ref_eci"],
        "J": particle_inertia(sc.tm.lattice.nodes, sc.tm.masses).tensor,
        "mu": float(sc.environment.mu),
        "q0": np.asarray(cfg.q0_wxyz, dtype=float),
        "q_ref": np.asarray(cfg.maneuver.q_ref_wxyz, dtype=float),
        "m_rod": m_rod,
        "n_max": n_max,
        "M": m_rod * n_max,
        "duration_s": float(cfg.sim.duration_s),
    }


def _to_body(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``R(q)ᵀ v`` for quaternions (P, 4) and one inertial vector (3,)."""
    vq = np.concatenate([np.zeros(q.shape[:-1] + (1,)), np.broadcast_to(v, q.shape[:-1] + (3,))], axis=-1)
    return quat_mul(quat_mul(q * np.array([1.0, -1.0, -1.0, -1.0]), vq), q)[..., 1:]


def _gravity_gradient(r_b: np.ndarray, J: np.ndarray, mu: float) -> np.ndarray:
    """``3μ/r³ r̂ × J r̂`` [N m] for positions (P, 3) in body axes."""
    rn = np.linalg.norm(r_b, axis=-1, keepdims=True)
    u = r_b / rn
    return 3.0 * mu / rn**3 * np.cross(u, u @ J.T)


def _rhs(case: dict, q: np.ndarray, w: np.ndarray, m_b: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """``(q̇, ω̇)`` of the rigid body with body dipoles ``m_b`` (P, 3) at time ``t`` (field interpolated)."""
    k = int(t)
    f = t - k
    B = (1 - f) * case["B"][k] + f * case["B"][k + 1]
    r = (1 - f) * case["r"][k] + f * case["r"][k + 1]
    J = case["J"]
    T = np.cross(m_b, _to_body(q, B)) + _gravity_gradient(_to_body(q, r), J, case["mu"]) - np.cross(w, w @ J.T)
    q_dot = 0.5 * quat_mul(q, np.concatenate([np.zeros(w.shape[:-1] + (1,)), w], axis=-1))
    return q_dot, np.linalg.solve(J, T.T).T


def _rk4(case: dict, q: np.ndarray, w: np.ndarray, m_b: np.ndarray, t: float, dt: float):
    """One RK4 step with the dipoles held."""
    k1 = _rhs(case, q, w, m_b, t)
    k2 = _rhs(case, q + 0.5 * dt * k1[0], w + 0.5 * dt * k1[1], m_b, t + 0.5 * dt)
    k3 = _rhs(case, q + 0.5 * dt * k2[0], w + 0.5 * dt * k2[1], m_b, t + 0.5 * dt)
    k4 = _rhs(case, q + dt * k3[0], w + dt * k3[1], m_b, t + dt)
    q = q + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
    w = w + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    return q / np.linalg.norm(q, axis=-1, keepdims=True), w


def _error_deg(case: dict, q: np.ndarray) -> np.ndarray:
    qe = quat_mul(np.broadcast_to(case["q_ref"] * np.array([1.0, -1.0, -1.0, -1.0]), q.shape), q)
    return np.degrees(2 * np.arctan2(np.linalg.norm(qe[..., 1:], axis=-1), np.abs(qe[..., 0])))


Law = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def pd_law(case: dict, Pq: np.ndarray, Pw: np.ndarray, *, gg_comp: bool) -> Law:
    """Quaternion PD through the allocation (``mode="paper"``): ``(q, ω, B_b, r_b) → m_b``."""

    def law(q: np.ndarray, w: np.ndarray, B_b: np.ndarray, r_b: np.ndarray) -> np.ndarray:
        T = -Pq * error_quaternion(case["q_ref"], q)[1:] - Pw * w
        if gg_comp:
            T = T - _gravity_gradient(r_b[None], case["J"], case["mu"])[0]
        a = allocate(T, B_b, m_rod_Am2=tuple(case["m_rod"]), n_max=tuple(int(n) for n in case["n_max"]))
        return np.array([a.N1 * case["m_rod"][0], a.N2 * case["m_rod"][1], 0.0])

    return law


def closed_loop(case: dict, law: Law | None, *, q0: np.ndarray, duration_s: float, dt: float) -> dict:
    """Run ``law`` (``None``: rods off) from ``q0`` at rest; error history every ``dt`` and its figures."""
    q, w = q0[None].copy(), np.zeros((1, 3))
    n = int(round(duration_s / dt))
    err = np.empty(n + 1)
    for k in range(n + 1):
        err[k] = _error_deg(case, q)[0]
        if k == n:
            break
        t = k * dt
        m_b = (
            np.zeros(3)
            if law is None
            else law(q[0], w[0], _to_body(q, case["B"][int(t)])[0], _to_body(q, case["r"][int(t)])[0])
        )
        q, w = _rk4(case, q, w, m_b[None], t, dt)
    t = np.arange(n + 1) * dt
    below = err < 5.0
    stay = (
        float(t[np.nonzero(~below)[0][-1] + 1]) if below[-1] and not below.all() else (0.0 if below.all() else math.nan)
    )
    return {
        "final_error_deg": round(float(err[-1]), 2),
        "max_error_deg": round(float(err.max()), 1),
        "t_err_below_5deg_stay_s": stay,
        "t_err_below_5deg_first_s": float(t[below][0]) if below.any() else math.nan,
        "err_every_0p5h_deg": [round(float(np.interp(s, t, err)), 1) for s in np.arange(1800.0, t[-1] + 1, 1800.0)],
    }


def gain_sets(case: dict) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The listed gains and critically damped gains of natural frequency 1e-3 and 3e-4 rad/s."""
    Jd = np.diag(case["J"])
    out = [("listed", np.array(LISTED[0]), np.array(LISTED[1]))]
    for wn in (1e-3, 3e-4):
        out.append((f"wn={wn:g}", 2 * Jd * wn**2, 2 * Jd * wn))
    return out


def search_pd(config_id: str, *, dt: float) -> None:
    case = load_case(config_id)
    for name, Pq, Pw in gain_sets(case):
        for gg in (True, False):
            res = closed_loop(
                case, pd_law(case, Pq, Pw, gg_comp=gg), q0=case["q0"], duration_s=case["duration_s"], dt=dt
            )
            print(json.dumps({"id": config_id, "mode": "pd", "gains": name, "gg_comp": gg, **res}), flush=True)


def search_hold(config_id: str, *, dt: float, duration_s: float) -> None:
    """Start 4° off the target (about body (1, 0.5, 0.2)) at rest: the rods off, then the PD laws."""
    case = load_case(config_id)
    q0 = quat_mul(case["q_ref"], quat_from_axis_angle(np.array([1.0, 0.5, 0.2]), math.radians(4.0)))
    res = closed_loop(case, None, q0=q0, duration_s=duration_s, dt=dt)
    print(json.dumps({"id": config_id, "mode": "hold", "law": "rods off", **res}), flush=True)
    Jd = np.diag(case["J"])
    listed = ("listed", np.array(LISTED[0]), np.array(LISTED[1]))
    low = ("in-plane P_q 0.4 N m", np.array([0.4, 0.4, 2.0]), np.array([150.0, 150.0, 2 * Jd[2] * 2.2e-3]))
    for (name, Pq, Pw), gg in ((listed, True), (low, True), (low, False)):
        res = closed_loop(case, pd_law(case, Pq, Pw, gg_comp=gg), q0=q0, duration_s=duration_s, dt=dt)
        print(json.dumps({"id": config_id, "mode": "hold", "gains": name, "gg_comp": gg, **res}), flush=True)


def programme_run(case: dict, X: np.ndarray, *, segment_s: float, horizon_s: float, dt: float = 10.0):
    """Final ``(q, ω)`` of the programmes ``X`` (P, n_seg, 2) (fractions of ``M_f``), from ``q0`` at rest."""
    P, n_seg = X.shape[0], X.shape[1]
    q, w = np.tile(case["q0"], (P, 1)), np.zeros((P, 3))
    for k in range(int(round(horizon_s / dt))):
        s = min(int(k * dt / segment_s), n_seg - 1)
        m_b = np.zeros((P, 3))
        m_b[:, :2] = X[:, s, :] * case["M"]
        q, w = _rk4(case, q, w, m_b, k * dt, dt)
    return q, w


def search_programme(config_id: str, *, segment_s: float, horizon_s: float, iterations: int, seed: int) -> None:
    case = load_case(config_id)
    n_seg = int(round(horizon_s / segment_s))
    nv, h = 2 * n_seg, 1e-4

    def cost(q, w):
        return (_error_deg(case, q) / 1.0) ** 2 + (np.linalg.norm(w, axis=-1) / 2e-5) ** 2

    def f_and_grad(x):
        X = np.repeat(x[None], nv + 1, axis=0)
        X[1:] += h * np.eye(nv)
        c = cost(*programme_run(case, X.reshape(nv + 1, n_seg, 2), segment_s=segment_s, horizon_s=horizon_s))
        return float(c[0]), (c[1:] - c[0]) / h

    x0 = np.random.default_rng(seed).uniform(-0.3, 0.3, nv)
    t0 = time.perf_counter()
    res = minimize(
        f_and_grad, x0, jac=True, method="L-BFGS-B", bounds=[(-1 + h, 1 - h)] * nv, options={"maxiter": iterations}
    )
    q, w = programme_run(case, res.x.reshape(1, n_seg, 2), segment_s=segment_s, horizon_s=horizon_s)
    print(
        json.dumps(
            {
                "id": config_id,
                "mode": "programme",
                "horizon_s": horizon_s,
                "segment_s": segment_s,
                "iterations": int(res.nit),
                "error_deg": round(float(_error_deg(case, q)[0]), 2),
                "rate_rad_s": float(np.linalg.norm(w[0])),
                "wall_s": round(time.perf_counter() - t0, 1),
            }
        ),
        flush=True,
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mode", choices=("pd", "hold", "programme"))
    ap.add_argument("ids", nargs="+", help="slew config stems")
    ap.add_argument("--dt", type=float, default=1.0, help="control and RK4 step of pd/hold [s]")
    ap.add_argument("--hold-duration", type=float, default=10000.0, help="length of the hold runs [s]")
    ap.add_argument("--segment", type=float, default=300.0, help="programme segment [s]")
    ap.add_argument("--horizon", type=float, default=5400.0, help="programme horizon [s]")
    ap.add_argument("--iterations", type=int, default=60, help="L-BFGS-B iterations")
    ap.add_argument("--seed", type=int, default=0, help="seed of the programme's starting guess")
    args = ap.parse_args(argv)
    for cid in args.ids:
        if not (MODELS / f"{cid}.toml").exists():
            print(f"error: ids: no config magsail_mj/concepts/truss_magnetorquer/configs/{cid}.toml", file=sys.stderr)
            return 2
    for cid in args.ids:
        if args.mode == "pd":
            search_pd(cid, dt=args.dt)
        elif args.mode == "hold":
            search_hold(cid, dt=args.dt, duration_s=args.hold_duration)
        else:
            search_programme(
                cid, segment_s=args.segment, horizon_s=args.horizon, iterations=args.iterations, seed=args.seed
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
