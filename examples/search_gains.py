"""Black-box search of the CNUSAIL detumble's B-dot gain through its dm_control environment.

    .venv/bin/python examples/search_gains.py [--config PATH] [--duration-s S] [--evaluations N]

A B-dot law written against the environment's observations drives the cubesat: at every
magnetorquer cycle boundary (``actuators.mtq.cycle_s``) it reads the magnetometer (``field_body_T``)
and commands the dipole ``m = −K (B_k − B_{k−1})/T_c`` (the config's ``control.bdot_form``), clipped
per axis to the magnetorquer limits; the environment holds it over the cycle with the blanking
window, as on the spacecraft. With ``K`` = the config's ``control.bdot_gain_Am2s_T`` it is the
shipped law.

SciPy's bounded scalar minimiser (``minimize_scalar``, method ``bounded``) searches ``log10 K`` in
``[--log10-low, --log10-high]`` for the shortest detumble time: the scenario's own
``detumble_time_s`` (the time after which ``|ω|`` stays below ``analysis.detumble_threshold_deg_s``)
from the environment's run. A run that does not detumble within the duration scores
``duration × (1 + |ω_end|/threshold)``. Printed (JSON): every evaluated gain with its time, the best
gain and its detumble time, and the shipped gain's.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from typing import Any

import numpy as np
from scipy.optimize import minimize_scalar

from magsail_mj import envs
from magsail_mj.control.bdot import make_bdot
from magsail_mj.concepts.cnusail import env as cnusail  # noqa: F401  (registers the CNUSAIL tasks)
from magsail_mj.loads.actuators_cubesat import saturate_per_axis

DEFAULT_CONFIG = "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"


class BdotPolicy:
    """``m = −K Ḃ`` from the magnetometer observation, sampled every magnetorquer cycle and held."""

    def __init__(self, env: Any, gain_Am2s_T: float) -> None:
        cfg = env.physics.cfg
        self.cfg, self.gain = cfg, float(gain_Am2s_T)
        self.dt_s = cfg.sim.timestep_s
        self.steps_cycle = int(round(cfg.actuators.mtq.cycle_s / self.dt_s))
        self.limits = cfg.actuators.mtq.limit_vector
        self.law = None
        self.m = np.zeros(3)

    def __call__(self, time_step: Any) -> np.ndarray:
        c = self.cfg.control
        if self.law is None or time_step.first():
            self.law = make_bdot(
                c.bdot_form,
                gain=self.gain,
                sample_period_s=self.cfg.actuators.mtq.cycle_s,
                omega_c_rad_s=c.bdot_omega_c_rad_s,
            )
            self.m = np.zeros(3)
        obs = time_step.observation
        k = int(round(float(obs["time_s"][0]) / self.dt_s))
        if k % self.steps_cycle == 0:
            self.m = saturate_per_axis(self.law.update(obs["field_body_T"]), self.limits)
        return self.m


def detumble_time(env: Any, gain: float) -> tuple[float | None, float]:
    """(detumble time [s] or None, final |ω| [rad/s]) of one episode with gain ``gain``."""
    policy = BdotPolicy(env, gain)
    ts = env.reset()
    while not ts.last():
        ts = env.step(policy(ts))
    summary = env.physics.summary()
    return summary["detumble_time_s"], float(np.linalg.norm(ts.observation["body_rate_rad_s"]))


def main(argv: list[str] | None = None) -> dict[str, Any]:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--config", default=DEFAULT_CONFIG)
    ap.add_argument("--duration-s", type=float, default=17347.5, help="episode length (default 3 orbits)")
    ap.add_argument("--evaluations", type=int, default=12, help="largest number of objective evaluations")
    ap.add_argument("--log10-low", type=float, default=3.5)
    ap.add_argument("--log10-high", type=float, default=5.5)
    ap.add_argument("--set", action="append", default=[], help="further config overrides (key=value)")
    args = ap.parse_args(argv)
    wall0 = time.perf_counter()
    env = envs.load(args.config, [f"sim.duration_s={args.duration_s}", *args.set], randomize=False)
    cfg = env.physics.cfg
    threshold = cfg.analysis.detumble_threshold_deg_s * math.pi / 180.0
    evaluated: list[dict[str, Any]] = []

    def score(gain: float) -> float:
        t, w_end = detumble_time(env, gain)
        value = t if t is not None else args.duration_s * (1.0 + w_end / threshold)
        evaluated.append(
            {"gain_Am2s_T": gain, "detumble_time_s": t, "rate_end_deg_s": math.degrees(w_end), "score_s": value}
        )
        print(json.dumps(evaluated[-1]), file=sys.stderr, flush=True)
        return value

    shipped = cfg.control.bdot_gain_Am2s_T
    score(shipped)
    res = minimize_scalar(
        lambda x: score(10.0**x),
        bounds=(args.log10_low, args.log10_high),
        method="bounded",
        options={"maxiter": max(1, args.evaluations - 1), "xatol": 0.02},
    )
    best = min(evaluated, key=lambda e: e["score_s"])
    out = {
        "config": args.config,
        "duration_s": args.duration_s,
        "overrides": args.set,
        "shipped_gain_Am2s_T": shipped,
        "shipped_detumble_time_s": evaluated[0]["detumble_time_s"],
        "best_gain_Am2s_T": best["gain_Am2s_T"],
        "best_detumble_time_s": best["detumble_time_s"],
        "best_score_s": best["score_s"],
        "optimizer_converged": bool(res.success),
        "evaluations": evaluated,
        "wall_s": time.perf_counter() - wall0,
    }
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    main()
