"""Current-loops concept layout: one task class per scenario kind, registered by name; no import
cycle, imports at module top; metrics and plots import no task module (each check can fail)."""

from __future__ import annotations

import typing

import pytest

from magsail_mj.concepts import task_kinds
from magsail_mj.config import load_config
from magsail_mj.scenario import build_scenario
from magsail_mj.concepts.current_loops import tasks as ct
from magsail_mj.concepts.current_loops.config import CurrentLoopsConfig
from tests.conftest import REPO

KIND_CONFIGS = {
    "sweep": ("magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml", ct.LoopsSweepTask),
    "slew": ("magsail_mj/concepts/current_loops/configs/slew.toml", ct.LoopsSlewTask),
    "slew_rigid": ("magsail_mj/concepts/current_loops/configs/slew_rigid.toml", ct.LoopsRigidSlewTask),
}


def test_registered_kinds_are_the_schema_scenarios():
    kinds = typing.get_args(CurrentLoopsConfig.model_fields["scenario"].annotation)
    assert sorted(kinds) == task_kinds("current_loops")


@pytest.mark.parametrize("kind", sorted(KIND_CONFIGS))
def test_every_kind_builds_its_own_class(kind):
    path, cls = KIND_CONFIGS[kind]
    cfg = load_config(REPO / path, ["lattice.units=3", "sim.duration_s=2"])
    assert cfg.scenario == kind
    sc = build_scenario(cfg)
    assert type(sc) is cls and isinstance(sc, ct.LoopsScenario)
    info = sc.render_info()
    assert info["overlay"] == list(cls.OVERLAY)
    # the rigid surrogate is one free body (7 qpos); the flexible plate has 3 per particle
    assert sc.model.nq == (7 if cls is ct.LoopsRigidSlewTask else 3 * sc.lm.lattice.n_nodes)
    assert ("strut_colours" in info) == issubclass(cls, ct.FlexibleLoopsTask)
