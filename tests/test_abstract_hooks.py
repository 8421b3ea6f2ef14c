"""Base-class hooks every subclass must implement are abstract methods: a subclass that forgets
one cannot be instantiated, and the ``TypeError`` names the missing method (checked for each
hook of each base by a subclass that implements all the others; each check can fail)."""

from __future__ import annotations

import pytest

from magsail_mj.concepts.current_loops.tasks import LoopsScenario
from magsail_mj.concepts.msac.tasks import MsacTask
from magsail_mj.concepts.reflector.tasks import ReflectorTask
from magsail_mj.concepts.truss_magnetorquer.tasks import OrbitalTrussTask, TrussScenario
from magsail_mj.envs.core import AttitudeTask

HOOKS = {
    AttitudeTask: {"observe", "shipped_action"},
    ReflectorTask: {"make_controller", "initial_state", "render_text"},
    TrussScenario: {"postprocess", "task_plots"},
    OrbitalTrussTask: {"kind_metrics"},
    LoopsScenario: {"build_spec", "loads", "probes", "metrics", "task_plots"},
    MsacTask: {"simulation", "summarise"},
}
"""Base class → its abstract hooks."""


def _missing_one(base: type, missing: str) -> type:
    """A subclass of ``base`` implementing every abstract hook but ``missing``."""
    body = {name: (lambda self, *args, **kwargs: None) for name in HOOKS[base] if name != missing}
    return type(f"Forgot_{missing}", (base,), body)


@pytest.mark.parametrize("base", list(HOOKS), ids=lambda c: c.__name__)
def test_the_hooks_are_the_abstract_methods(base: type) -> None:
    assert set(base.__abstractmethods__) == HOOKS[base]


@pytest.mark.parametrize(
    ("base", "missing"),
    [(b, m) for b, hooks in HOOKS.items() for m in sorted(hooks)],
    ids=lambda x: x if isinstance(x, str) else x.__name__,
)
def test_a_subclass_without_a_hook_fails_at_construction_naming_it(base: type, missing: str) -> None:
    cls = _missing_one(base, missing)
    with pytest.raises(TypeError, match=rf"abstract .*\b{missing}\b"):
        cls(None)  # the check precedes __init__: no argument is looked at


@pytest.mark.parametrize("base", list(HOOKS), ids=lambda c: c.__name__)
def test_a_subclass_with_every_hook_is_not_abstract(base: type) -> None:
    assert not _missing_one(base, "").__abstractmethods__
