"""Willis et al. (2024)'s case with their own initial-condition sampling instead of the sweep's.

Their Monte Carlo (``final/monte_carlo_controllers.jl`` and ``src/satellite_simulator.jl`` of their
repository ``RoboticExplorationLab/non-monotonic-detumbling``) draws the body rate along ``rand(3)``
normalised (the positive octant of their body axes) and the attitude (body → ECI) as the rotation by
an angle uniform in 0–2π about an axis ``rand(3)`` normalised; the sweep ``willis_manchester_mc.toml``
draws a direction uniform on the sphere with the body on the orbit frame. This runs ``--trials`` of
their draws (NumPy, ``--seed``; inclination uniform 20–160°, RAAN and argument of latitude uniform
0–360°) per law as one batch of worlds, 2 h each: their rate and attitude are moved onto this case's
principal body axes (theirs 22.5° about z from them) and the attitude written as
``initial.q_err0_wxyz`` relative to the nadir frame at t0. Prints, per law, the 51st of 100 times to
‖J ω‖ < 1 % of its start [h] and the share done by 1.98 h (as ``willis_manchester_compare.py``).

    nice -n 10 python scripts/willis_manchester_their_draws.py --seed 5 --trials 100
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
from scipy.spatial.transform import Rotation

import magsail_mj
from magsail_mj.concepts.cnusail.metrics import momentum_detumble_time
from magsail_mj.concepts.cnusail.modes import Mode, command_quaternion
from magsail_mj.quaternion import quat_from_matrix, quat_mul

CASE = "magsail_mj/concepts/cnusail/configs/willis_manchester.toml"
MU_M3_S2 = 3.986004418e14
A_M = (6378.137 + 400.0) * 1e3
#: their inertia [kg m²] in their body axes (py4_inertia_matrix)
J_THEIRS = 1.58 / 1.504 * np.array([[0.0043, -0.0003, 0.0], [-0.0003, 0.0049, 0.0], [0.0, 0.0, 0.0035]])
J_PRINCIPAL = np.array([0.0043867, 0.0052782, 0.0036769])


def principal_axes() -> np.ndarray:
    """(3, 3): columns the case's body axes x, y, z (moments 0.00439, 0.00528, 0.00368) in theirs."""
    V = np.linalg.eigh(J_THEIRS)[1][:, [1, 2, 0]]
    return V * np.array([1.0, 1.0, np.sign(np.linalg.det(V))])


def circular_state(inc_deg: float, raan_deg: float, u_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """ECI position [m] and velocity [m/s] on the 400 km circular orbit at argument of latitude u."""
    i, O, u = np.radians([inc_deg, raan_deg, u_deg])
    r = np.array(
        [
            math.cos(O) * math.cos(u) - math.sin(O) * math.sin(u) * math.cos(i),
            math.sin(O) * math.cos(u) + math.cos(O) * math.sin(u) * math.cos(i),
            math.sin(u) * math.sin(i),
        ]
    )
    v = np.array(
        [
            -math.cos(O) * math.sin(u) - math.sin(O) * math.cos(u) * math.cos(i),
            -math.sin(O) * math.sin(u) + math.cos(O) * math.cos(u) * math.cos(i),
            math.cos(u) * math.sin(i),
        ]
    )
    return A_M * r, math.sqrt(MU_M3_S2 / A_M) * v


def their_draw(rng: np.random.Generator, V: np.ndarray) -> list[str]:
    """One trial of their sampling as overrides of this case."""
    inc, raan, u = rng.uniform(20.0, 160.0), rng.uniform(0.0, 360.0), rng.uniform(0.0, 360.0)
    axis = rng.random(3)
    Q_theirs = Rotation.from_rotvec(axis / np.linalg.norm(axis) * rng.uniform(0.0, 2.0 * math.pi)).as_matrix()
    direction = rng.random(3)
    omega = V.T @ (30.0 * direction / np.linalg.norm(direction))
    r, v = circular_state(inc, raan, u)
    p_c = command_quaternion(Mode.NADIR, r, v)
    p_e = quat_mul(p_c * np.array([1.0, -1.0, -1.0, -1.0]), quat_from_matrix(Q_theirs @ V))
    return [
        f"orbit.inclination_deg={inc!r}",
        f"orbit.raan_deg={raan!r}",
        f"orbit.arg_lat0_deg={u!r}",
        "initial.omega0_deg_s=[" + ", ".join(repr(float(x)) for x in omega) + "]",
        "initial.q_err0_wxyz=[" + ", ".join(repr(float(x)) for x in p_e) + "]",
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=5)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--law", action="append", default=None, help="control.bdot_law (repeatable)")
    args = ap.parse_args()
    laws = args.law or ["b_cross", "proportional"]
    rng, V = np.random.default_rng(args.seed), principal_axes()
    draws = [their_draw(rng, V) for _ in range(args.trials)]
    worlds = [[f'control.bdot_law="{law}"', *d] for d in draws for law in laws]
    result = magsail_mj.load(CASE, ["sim.progress=false"], world_overrides=worlds).run()
    times: dict[str, list[float]] = {law: [] for law in laws}
    for world, overrides in zip(result.worlds, worlds):
        t = momentum_detumble_time(world.records["t"], world.records["qvel"][:, 3:6], J_PRINCIPAL)
        times[overrides[0].split('"')[1]].append(math.inf if t is None else t / 3600.0)
    out = {
        law: {
            "n": len(t),
            "half_mark_h": float(np.sort(t)[len(t) // 2]),
            "share_within_1p98h_pct": 100.0 * float(np.mean(np.array(t) <= 1.98)),
        }
        for law, t in times.items()
    }
    print(json.dumps({"seed": args.seed, "trials": args.trials, "wall_time_s": result.wall_time_s, **out}, indent=2))


if __name__ == "__main__":
    main()
