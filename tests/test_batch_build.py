"""The batch builds each world as its single run does: the cubesat and the task it assembles from
shared parts hold the attributes of the concept's own objects, with the same values."""

from __future__ import annotations

import numpy as np

import magsail_mj
from magsail_mj.concepts.cnusail.batch import CnusailWorlds
from magsail_mj.concepts.cnusail.model import CnusailModel
from magsail_mj.concepts.cnusail.tasks import AttitudeTask
from magsail_mj.config import load_config
from tests.test_batch_equals_single import PRE


def test_world_parts_are_the_concepts_objects():
    cfgs = [load_config(PRE, ["sim.duration_s=10", f"spacecraft.mass_kg={m}"]) for m in (4.0, 4.0, 4.2)]
    worlds = CnusailWorlds(cfgs)
    assert worlds.world_model.tolist() == [0, 0, 1] and worlds.world_env.tolist() == [0, 0, 0]
    own = CnusailModel(cfgs[2])
    mine = worlds.cubesats[2]
    assert vars(mine).keys() == vars(own).keys()
    assert mine.params == own.params and mine.orbit_period_s == own.orbit_period_s
    assert np.array_equal(mine.inertia, own.inertia)
    assert vars(mine.disturbances).keys() == vars(own.disturbances).keys()
    assert mine.spec.to_xml() == own.spec.to_xml()
    task = worlds.scenario(2)
    ref = AttitudeTask(cfgs[2])
    ref.controller = ref.make_controller()
    assert vars(task).keys() == vars(ref).keys()
    assert task.manifest_extra() == ref.manifest_extra() and task.render_info() == ref.render_info()


def test_each_worlds_identity_is_its_single_runs():
    worlds = [[], ["spacecraft.mass_kg=4.2"]]
    sim = magsail_mj.load(PRE, ["sim.duration_s=10"], world_overrides=worlds)
    for k, extra in enumerate(worlds):
        assert sim.identities[k] == magsail_mj.load(PRE, ["sim.duration_s=10", *extra]).identity
