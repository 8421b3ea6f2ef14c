"""Current-loops tasks: a config of every scenario kind builds its own task class, with the model of
its kind (rigid surrogate or flexible plate). That the registered kinds are the schema's and the
package layout are checked for every concept by tests/test_layout.py."""

from __future__ import annotations

import pytest

from magsail_mj.concepts.current_loops import tasks as ct
from tests.conftest import REPO
from tests.tasks_shared import built_kind

KIND_CONFIGS = {
    "sweep": ("magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml", ct.LoopsSweepTask),
    "slew": ("magsail_mj/concepts/current_loops/configs/slew.toml", ct.LoopsSlewTask),
    "slew_rigid": ("magsail_mj/concepts/current_loops/configs/slew_rigid.toml", ct.LoopsRigidSlewTask),
}


@pytest.mark.parametrize("kind", sorted(KIND_CONFIGS))
def test_every_kind_builds_its_own_class(kind):
    path, cls = KIND_CONFIGS[kind]
    sc = built_kind(REPO / path, kind=kind, cls=cls, base=ct.LoopsScenario)
    info = sc.render_info()
    # the rigid surrogate is one free body (7 qpos); the flexible plate has 3 per particle
    assert sc.model.nq == (7 if cls is ct.LoopsRigidSlewTask else 3 * sc.lm.lattice.n_nodes)
    assert ("strut_colours" in info) == issubclass(cls, ct.FlexibleLoopsTask)
