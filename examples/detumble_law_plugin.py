"""A detumble law of your own, run beside the shipped ones on the same initial conditions.

    .venv/bin/python examples/detumble_law_plugin.py [--worlds N] [--duration-s S]

The law (a saturating rate-damping law through the field, m = k (ω × B)/‖B‖ clipped by the
controller) is a plain function of the sample's inputs returning a typed ``MagneticDipole``. Once
registered it is named by ``control.bdot_law`` like a shipped law, with its parameters in
``control.bdot_law_params``, and every world of the batch below runs it exactly as a single run
would. Printed (JSON): per law, the median end rate and the worlds below 0.3 °/s at the end.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

import magsail_mj
from magsail_mj.commands import MagneticDipole
from magsail_mj.control.detumble_plugins import DetumbleInputs, register_detumble_law

CONFIG = "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"


def field_rate_damper(inputs: DetumbleInputs, params: dict[str, float]) -> MagneticDipole:
    """m = k (ω × B)/‖B‖ [A m²]: the torque m × B = −k ‖B‖ (ω − (ω·b̂) b̂) damps the rate across B."""
    B = inputs.field_body_T
    B_norm_T = math.sqrt(float(B @ B))
    if B_norm_T == 0.0:
        return MagneticDipole(dipole_body_Am2=np.zeros(3))
    m = params["gain_Am2s"] * np.cross(inputs.rate_body_rad_s, B) / B_norm_T
    return MagneticDipole(dipole_body_Am2=m)


def main(worlds: int = 8, duration_s: float = 3000.0) -> dict:
    register_detumble_law("field_rate_damper", field_rate_damper)
    rng = np.random.default_rng(2016)
    rates = [rng.normal(size=3) for _ in range(worlds)]
    initial = [f"initial.omega0_deg_s={(6.0 * r / np.linalg.norm(r)).tolist()}" for r in rates]
    laws = {
        "proportional": [],
        "b_cross": ['control.bdot_law="b_cross"'],
        "field_rate_damper": ['control.bdot_law="field_rate_damper"', "control.bdot_law_params={gain_Am2s = 300.0}"],
    }
    out = {}
    for name, law in laws.items():
        shared = [f"sim.duration_s={duration_s}", 'sim.loads="compiled"']
        sim = magsail_mj.load(CONFIG, shared, world_overrides=[[*law, o] for o in initial])
        result = sim.run(progress=False)
        end = [math.degrees(np.linalg.norm(w.records["qvel"][-1][3:6])) for w in result.worlds]
        out[name] = {"median_end_rate_deg_s": float(np.median(end)), "below_0p3dps": int(np.sum(np.array(end) < 0.3))}
    print(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=8)
    parser.add_argument("--duration-s", type=float, default=3000.0)
    args = parser.parse_args()
    main(args.worlds, args.duration_s)
