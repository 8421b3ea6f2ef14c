"""Summaries must not change under a restructuring: short runs against stored references.

``tests/data/regression_summaries.json`` holds the summary of a short run (30 time steps; MSAC: 6
cycles; the lifetime analysis whole) of every shipped config, stored by
``scripts/store_regression_summaries.py`` before a change. The default run checks one config of
every scenario kind; the ``slow`` run checks them all. Floats must agree to 1e-9 relative (the
order of floating-point operations may change in a refactor; anything beyond is a change of the
physics), everything else exactly; timing keys are not compared, and keys added to a summary since
the references were stored are allowed (a removed or changed key is not).

MuJoCo and LAPACK take different vectorised paths on different CPUs, so the same code gives
summaries that differ beyond 1e-9 from one machine to another (measured: 1e-8 relative in the
17-day lifetime propagation, round-off-level figures such as a 1e-23 N m gravity-gradient torque of
a symmetric bus, the order of two near-degenerate modes). Each CPU family seen has its own stored
reference set (``tests/data/regression_summaries*.json``, each stored from a commit whose summaries
match the primary set on the machines it was stored on; a further set holds only the configs that
differ on its CPU: ``_epyc_avx512``, the AVX-512 EPYC, three configs whose round-off differs at
1e-13 to 1e-7 relative: the lifetime propagation and the 1 kHz MSAC runs), and a summary must
match one of them to the stated tolerance: a change of the physics moves it away from all of them.
"""

from __future__ import annotations

import importlib.util
import json

import pytest

from tests.conftest import REPO

_spec = importlib.util.spec_from_file_location(
    "store_regression_summaries", REPO / "scripts" / "store_regression_summaries.py"
)
store = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(store)

STORED = json.loads(store.OUT.read_text())
#: every stored reference set: the primary one first, then one per further CPU family
REFERENCES = [STORED] + [
    json.loads(p.read_text()) for p in sorted(store.OUT.parent.glob("regression_summaries_*.json"))
]
ONE_PER_KIND = [
    "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
    "magsail_mj/concepts/cnusail/configs/nadir_pre.toml",
    "magsail_mj/concepts/cnusail/configs/deorbit_recalc.toml",  # noqa: E501
    "magsail_mj/concepts/cnusail/configs/pd_vs_eigenaxis.toml",
    "magsail_mj/concepts/cnusail/configs/lifetime.toml",
    "magsail_mj/concepts/current_loops/configs/slew.toml",
    "magsail_mj/concepts/current_loops/configs/slew_rigid.toml",
    "magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml",
    "magsail_mj/concepts/msac/configs/lumped.toml",
    "magsail_mj/concepts/msac/configs/paper_1khz.toml",
    "magsail_mj/concepts/msac/configs/sweeps/stroke.toml",  # noqa: E501
    "magsail_mj/concepts/reflector/configs/detumble.toml",
    "magsail_mj/concepts/reflector/configs/tracking_10g.toml",
    "magsail_mj/concepts/reflector/configs/pitch/b3_caps_sigma10.toml",
    "magsail_mj/concepts/structure/configs/sail_detumble.toml",
    "magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml",
    "magsail_mj/concepts/truss_magnetorquer/configs/libration.toml",  # noqa: E501
    "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml",
    "magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml",  # noqa: E501
    "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml",
]


#: configs whose numbers pass through a fresh LAPACK eigendecomposition (the current-loop modal
#: damping): its eigenvectors differ in the last bits between CPUs and between a cached and a
#: recomputed basis, which the dynamics carry to ~1e-8 relative in the summary (measured 4e-9 on a
#: fresh checkout), and figures at round-off level (an energy-balance error of 4e-12) change by
#: percents; 1e-6 relative or 1e-9 absolute still catches any change of the physics.
EIGEN_REL, EIGEN_ABS = 1e-6, 1e-9
EIGEN_CONFIGS = (
    "magsail_mj/concepts/current_loops/configs/slew.toml",
    "magsail_mj/concepts/current_loops/configs/sweep",
)  # noqa: E501
#: in those configs, the indices of the dominant modes (keys ending ``_mode``) are not compared:
#: the square lattice's modes come in pairs of equal frequency, and which of a pair a fresh
#: eigendecomposition numbers first changes from run to run (seen: 516/517 and 409/410 on one
#: machine); the modes' energies and frequencies stay compared
EIGEN_UNORDERED_SUFFIX = "_mode"


def _check(key: str) -> None:
    assert key in STORED, f"{key}: no stored summary (run scripts/store_regression_summaries.py --only {key})"
    now = store.short_summary(REPO / key)
    rel, abs_tol = (EIGEN_REL, EIGEN_ABS) if key.startswith(EIGEN_CONFIGS) else (1e-9, 1e-300)
    refs = [ref[key] for ref in REFERENCES if key in ref]
    if key.startswith(EIGEN_CONFIGS):
        now = {k: v for k, v in now.items() if not k.endswith(EIGEN_UNORDERED_SUFFIX)}
        refs = [{k: v for k, v in ref.items() if not k.endswith(EIGEN_UNORDERED_SUFFIX)} for ref in refs]
    found = [store.differences(ref, now, rel=rel, abs_tol=abs_tol) for ref in refs]
    problems = found[0]
    assert not all(found), f"{key} (differs from all {len(found)} reference sets; from the first):\n  " + "\n  ".join(
        problems
    )


def test_every_shipped_config_has_a_stored_summary():
    shipped = {str(p.relative_to(REPO)) for p in store.shipped_configs()}
    assert shipped <= set(STORED), sorted(shipped - set(STORED))


@pytest.mark.parametrize("key", ONE_PER_KIND)
def test_summary_of_every_scenario_kind_unchanged(key):
    _check(key)


@pytest.mark.slow
@pytest.mark.parametrize("key", sorted(STORED))
def test_summary_of_every_shipped_config_unchanged(key):
    _check(key)


def test_comparison_sees_a_change():
    """The comparison itself: 1e-9 relative passes, 1e-6 fails, a changed string or key fails."""
    base = {"a": 1.0, "b": "x", "c": [1.0, 2.0], "d": None}
    assert not store.differences(base, {"a": 1.0 + 1e-10, "b": "x", "c": [1.0, 2.0], "d": None})
    assert store.differences(base, {"a": 1.0 + 1e-6, "b": "x", "c": [1.0, 2.0], "d": None})
    assert store.differences(base, {"a": 1.0, "b": "y", "c": [1.0, 2.0], "d": None})
    assert store.differences(base, {"a": 1.0, "b": "x", "c": [1.0, 2.0]})  # a key gone
    assert not store.differences(base, {**base, "new_key_s": 3.0})  # an addition is allowed
