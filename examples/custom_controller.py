"""A controller of your own on a shipped spacecraft: rate damping through the cubesat's wheels.

    .venv/bin/python examples/custom_controller.py [DURATION_S]

The law sees only the step state (through the spacecraft's attitude sensor) and returns a typed
``BodyTorque``; the cubesat's wheel actuator turns it into motor torques and records the torque it
requested and the one the wheels delivered.
"""

import sys

import numpy as np

import magsail_mj
from magsail_mj.commands import BodyTorque, attach
from magsail_mj.loads.body_torque_actuators import attitude_sensor, body_torque_actuator


class RateDamper:
    """T = −k ω (body axes), sampled every ``period_s`` and held in between."""

    def __init__(self, sensor, gain_Nms: float, period_s: float = 0.5):
        self.sensor, self.gain_Nms, self.period_s = sensor, gain_Nms, period_s

    def update(self, state) -> BodyTorque:
        _, omega_body = self.sensor(state)
        return BodyTorque(torque_body_Nm=-self.gain_Nms * np.asarray(omega_body))


def main(duration_s: float = 120.0) -> dict:
    sim = magsail_mj.load("magsail_mj/concepts/cnusail/configs/detumble_pre.toml", [f"sim.duration_s={duration_s}"])
    run = attach(sim, RateDamper(attitude_sensor(sim), gain_Nms=5e-3), body_torque_actuator(sim)).run()
    rate = np.linalg.norm(run.records["qvel"][:, 3:6], axis=1)
    out = {
        "status": run.status,
        "rate_start_deg_s": float(np.degrees(rate[0])),
        "rate_end_deg_s": float(np.degrees(rate[-1])),
    }
    print(out)
    return out


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:]))
