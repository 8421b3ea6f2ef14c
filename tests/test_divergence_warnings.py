"""MuJoCo's warnings that make a step's numbers wrong end the run as diverged, dated: bad states,
and constraints or contacts dropped because the arena is full (a welded beam loop would otherwise
come apart without a word)."""

from __future__ import annotations

import mujoco
import pytest

from magsail_mj.divergence import BAD_STATE_WARNINGS, DivergenceError, WarningWatch, disable_autoreset

_WELDED = """<mujoco><size memory="{memory}"/><worldbody>
<body name="a"><freejoint/><geom size=".1" mass="1" contype="0" conaffinity="0"/></body>
<body name="b" pos="0 0 1"><freejoint/><geom size=".1" mass="1" contype="0" conaffinity="0"/></body>
</worldbody><equality><weld body1="a" body2="b"/><connect body1="a" anchor="0 0 0"/></equality></mujoco>"""


def _welded(memory: str) -> tuple[mujoco.MjModel, mujoco.MjData]:
    model = mujoco.MjModel.from_xml_string(_WELDED.format(memory=memory))
    disable_autoreset(model)
    return model, mujoco.MjData(model)


def test_dropped_constraints_are_a_divergence_named_and_dated():
    model, data = _welded("2K")  # too small for the weld's and the connect's nine rows
    watch = WarningWatch(data)
    mujoco.mj_step(model, data)
    assert watch.raised() == ["CNSTRFULL"]
    with pytest.raises(DivergenceError, match=r"CNSTRFULL at t = 0 s: the arena is too small") as err:
        watch.check(0.0)
    assert err.value.t_s == 0.0


def test_an_arena_that_holds_the_constraints_raises_nothing():
    model, data = _welded("1M")
    watch = WarningWatch(data)
    for _ in range(10):
        mujoco.mj_step(model, data)
    assert data.nefc == 9  # the weld's and the connect's rows were in the step
    assert watch.raised() == []
    watch.check(data.time)


def test_every_watched_warning_has_a_cause():
    names = {w.name for w in BAD_STATE_WARNINGS}
    assert {"mjWARN_CNSTRFULL", "mjWARN_CONTACTFULL", "mjWARN_BADQACC"} <= names
    assert all(BAD_STATE_WARNINGS[w] for w in BAD_STATE_WARNINGS)
