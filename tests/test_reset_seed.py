"""``Simulation.reset(seed=...)`` reseeds the run's random generators (here the CNUSAIL gyro noise)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import magsail_mj

CONFIG = str(Path(__file__).resolve().parents[1] / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")


def test_reset_seed_reseeds_the_noise():
    sim = magsail_mj.load(CONFIG, ["sim.duration_s=2", "control.sensors.gyro_noise_rad_s=1e-2"])

    def qvel(**kwargs):
        sim.reset(**kwargs)
        sim.step(10)
        return np.array(sim.records()["omega_e_rad_s"])  # the measured rate

    a, b, c, d = qvel(seed=1), qvel(seed=1), qvel(seed=2), qvel()
    assert np.array_equal(a, b)  # equal seeds, equal runs
    assert not np.array_equal(a, c)  # another seed, other noise
    assert np.array_equal(d, qvel())  # no seed: the generators' initial state, every time
    with pytest.raises(ValueError, match="seed"):
        sim.reset(seed=-1)
