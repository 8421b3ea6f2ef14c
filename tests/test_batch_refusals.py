"""What one batch cannot run is refused before anything runs, naming the world, the key and the values."""

from __future__ import annotations

import pytest

import magsail_mj
from magsail_mj.batch import load_batch
from magsail_mj.config import ConfigError
from tests.conftest import REPO
from tests.test_batch_equals_single import PRE

SHARED = ["sim.duration_s=10"]


def refused(world_overrides, *, config=PRE, shared=SHARED) -> str:
    with pytest.raises(ConfigError) as err:
        magsail_mj.load(config, shared, world_overrides=world_overrides)
    return str(err.value)


def test_a_key_that_changes_the_models_sizes_is_refused_by_name():
    text = refused([[], ['spacecraft.configuration="deployed"']])
    assert "world 1: spacecraft.configuration: changes the sizes of the compiled model (" in text
    assert "ngeom 18 → 24" in text and "'stowed'" in text and "'deployed'" in text
    text = refused([["render.markers=false"], []])
    assert "world 1: render.markers: changes the sizes of the compiled model" in text


def test_keys_every_world_must_share_are_refused_by_name():
    text = refused([[], ["sim.timestep_s=0.1"], ["actuators.mtq.cycle_s=4.0"]])
    assert "world 1: sim.timestep_s: must be the same in every world of a batch" in text
    assert "world 0 has 0.2, got 0.1" in text
    assert "world 2: actuators.mtq.cycle_s: must be the same in every world of a batch" in text


def test_what_the_batch_does_not_run_is_refused_by_name():
    text = refused([[], ['control.mode="eigen_axis"', "control.sensors.gyro_noise_rad_s=1e-5"]])
    assert "world 1: control.mode: the batch runs the B-dot detumble law ('bdot') only" in text
    assert "world 1: control.sensors.gyro_noise_rad_s: sensor noise is not run in a batch" in text
    text = refused([['actuators.wheels.electrical="substep"']])
    assert "world 0: actuators.wheels.electrical: the batch runs the quasi-static armature only" in text
    reflector = str(REPO / "magsail_mj/concepts/reflector/configs/detumble.toml")
    assert "concept: the batch runs cnusail, truss_magnetorquer only (for now), got 'reflector'" in refused(
        [[], []], config=reflector
    )


def test_invalid_worlds_and_arguments_are_named():
    text = refused([[], ["spacecraft.mass_kg=-1.0"], ["spacecraft.nope=1"]])
    assert "world 1: spacecraft.mass_kg" in text and "world 2: spacecraft.nope" in text
    with pytest.raises(ValueError, match="worlds: must be an integer >= 1, got 0"):
        load_batch(PRE, SHARED, worlds=0)
    with pytest.raises(ValueError, match="world_overrides: 2 lists for worlds = 3"):
        load_batch(PRE, SHARED, worlds=3, world_overrides=[[], []])
    with pytest.raises(ValueError, match="world_overrides: must be a list of lists"):
        load_batch(PRE, SHARED, world_overrides=["sim.seed=1"])
    for nthread in (0, 257):
        with pytest.raises(ValueError, match=f"nthread: must be an integer from 1 to 256, got {nthread}"):
            load_batch(PRE, SHARED, worlds=2, nthread=nthread)
