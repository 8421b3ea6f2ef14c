"""Hostile config values: every numeric leaf of the shipped configs set to non-finite, zero,
negative, huge, tiny and wrongly typed values.

The contract (``magsail_mj.config``): either :func:`load_config` / :func:`parse_config` raises a
``ConfigError`` whose message names the key path, or the value is valid and the scenario builds
(``build_scenario``) without any exception and without an overflow warning.

Validate and run agree: whenever ``magsail validate`` accepts a config (the schema with its
derived quantities, then the memory estimate), the simulation builds (``magsail_mj.load``) and
steps without an exception, ending any way a run documents (``running``, ``completed``,
``diverged``, ``structure_failed``): every numeric key of every shipped config, defaults included,
set to extreme finite values. A small fixed budget runs by default; the whole sweep is marked slow.
"""

from __future__ import annotations

import copy
import functools
import math
import re
import tomllib
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import magsail_mj
from magsail_mj.checks import is_symmetric
from magsail_mj.concepts.cnusail.modes import DETUMBLE_LAWS
from magsail_mj.config import ConfigError, apply_overrides, load_config, parse_config
from magsail_mj.resources import MemoryLimitError, check_memory, estimate_run_bytes, msac_drive_bytes
from magsail_mj.scenario import build_scenario
from magsail_mj.structure.fileformat import is_structure_file
from magsail_mj.sweep import is_sweep_file
from tests.conftest import REPO

# One shipped config per concept, with overrides that make a build take well under a second.
FUZZED = {
    "truss_magnetorquer": (
        "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml",
        ["lattice.units=3", "sim.duration_s=20.0"],
    ),  # noqa: E501
    "current_loops": (
        "magsail_mj/concepts/current_loops/configs/slew.toml",
        ["lattice.units=3", "sim.duration_s=20.0"],
    ),  # noqa: E501
    "reflector": ("magsail_mj/concepts/reflector/configs/detumble.toml", ["plate.side_m=4.0", "sim.duration_s=20.0"]),
    "cnusail": ("magsail_mj/concepts/cnusail/configs/detumble_pre.toml", ["sim.duration_s=20.0"]),
    "msac": ("magsail_mj/concepts/msac/configs/paper_1khz.toml", ["sim.duration_s=0.01"]),
    # the CNUSAIL detumble laws' keys as leaves (the B×ω gain is a leaf while unused here)
    "cnusail_non_monotonic": (
        "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
        [
            "sim.duration_s=20.0",
            'control.bdot_law="non_monotonic"',
            "control.nonmonotonic_gain_per_Nms=3000.0",
            "control.nonmonotonic_alpha=100.0",
            "control.nonmonotonic_lookahead_s=600.0",
            "control.bcross_gain_Nms=4e-5",
        ],
    ),
}

# Further scenario kinds, swept deterministically with the extreme values.
EXTRA = {
    "truss_cantilever": ("magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml", ["lattice.units=3"]),
    "truss_dist_vs_central": (
        "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.toml",  # noqa: E501
        ["lattice.units=3"],
    ),
    "truss_slew": (
        "magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml",
        ["lattice.units=3", "sim.duration_s=20.0"],
    ),  # noqa: E501
    "loops_sweep": ("magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml", ["lattice.units=3"]),
    "loops_slew_rigid": (
        "magsail_mj/concepts/current_loops/configs/slew_rigid.toml",
        ["lattice.units=3", "sim.duration_s=20.0"],
    ),  # noqa: E501
    "reflector_pitch": (
        "magsail_mj/concepts/reflector/configs/tracking_10g.toml",
        ["plate.side_m=4.0", "sim.duration_s=20.0"],
    ),  # noqa: E501
    "reflector_caps": (
        "magsail_mj/concepts/reflector/configs/pitch/b3_caps_sigma10.toml",
        ["plate.side_m=4.0", "sim.duration_s=20.0"],
    ),  # noqa: E501
    "cnusail_lifetime": ("magsail_mj/concepts/cnusail/configs/lifetime.toml", []),
    "cnusail_nadir": ("magsail_mj/concepts/cnusail/configs/nadir_post.toml", ["sim.duration_s=20.0"]),
    "cnusail_bang_bang": (
        "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
        ["sim.duration_s=20.0", 'control.bdot_law="bang_bang"'],
    ),
    "cnusail_b_cross": (
        "magsail_mj/concepts/cnusail/configs/detumble_post.toml",
        ["sim.duration_s=20.0", 'control.bdot_law="b_cross"', "control.bcross_gain_Nms=4e-5"],
    ),
    "msac_lumped": ("magsail_mj/concepts/msac/configs/lumped.toml", []),
    "msac_sweep": ("magsail_mj/concepts/msac/configs/sweeps/stroke.toml", ["sim.duration_s=0.01"]),
}

HOSTILE: list[Any] = [math.nan, math.inf, -math.inf, 0, -1, 1e300, -1e300, 1e-300, "x", True, [1.0], {}]

# Keys whose schema documents that they accept infinity (none today).
ALLOW_INFINITY: set[str] = set()

Leaf = tuple[tuple[str, ...], int | None]


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def numeric_leaves(tree: dict[str, Any], prefix: tuple[str, ...] = ()) -> list[Leaf]:
    """``(key path, index)`` of every number in ``tree``: scalars (index None) and the items of
    arrays of numbers."""
    out: list[Leaf] = []
    for key, value in tree.items():
        path = (*prefix, key)
        if isinstance(value, dict):
            out += numeric_leaves(value, path)
        elif _is_number(value):
            out.append((path, None))
        elif isinstance(value, list) and value and all(_is_number(v) for v in value):
            out += [(path, i) for i in range(len(value))]
    return out


def with_leaf(tree: dict[str, Any], leaf: Leaf, value: Any) -> dict[str, Any]:
    """A deep copy of ``tree`` with ``leaf`` set to ``value``."""
    out = copy.deepcopy(tree)
    path, index = leaf
    node = out
    for part in path[:-1]:
        node = node[part]
    if index is None:
        node[path[-1]] = value
    else:
        node[path[-1]][index] = value
    return out


def leaf_name(leaf: Leaf) -> str:
    """The key path a ConfigError must name (``initial.omega0_rad_s`` for an array item)."""
    return ".".join(leaf[0])


def _base_tree(path: str, overrides: list[str]) -> dict[str, Any]:
    return apply_overrides(tomllib.loads((REPO / path).read_text()), overrides)


BASES = {name: _base_tree(*where) for name, where in {**FUZZED, **EXTRA}.items()}
LEAVES = {name: numeric_leaves(tree) for name, tree in BASES.items()}


def check_named_or_builds(tree: dict[str, Any], leaf: Leaf, value: Any) -> str:
    """The contract for one hostile value: ``"refused"`` or ``"built"``; fails otherwise."""
    key = leaf_name(leaf)
    try:
        cfg = parse_config(with_leaf(tree, leaf, value))
    except ConfigError as err:
        assert key in str(err), f"{key} = {value!r}: the error does not name the key:\n{err}"
        return "refused"
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # overflow in a derived quantity
        build_scenario(cfg)
    return "built"


@pytest.mark.parametrize("concept", sorted(BASES))
def test_fuzzed_configs_build_unchanged(concept):
    cfg = parse_config(BASES[concept])
    assert build_scenario(cfg).spec is not None
    assert len(LEAVES[concept]) >= 5, LEAVES[concept]


def _fuzz(concept: str):
    @settings(max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
    @given(index=st.integers(0, len(LEAVES[concept]) - 1), value=st.sampled_from(HOSTILE))
    def run(index: int, value: Any) -> None:
        check_named_or_builds(BASES[concept], LEAVES[concept][index], value)

    return run


@pytest.mark.parametrize("concept", sorted(FUZZED))
def test_hostile_leaf_is_named_or_builds(concept):
    _fuzz(concept)()


@pytest.mark.parametrize("concept", sorted(BASES))
def test_extremes_of_every_leaf_named_or_build(concept):
    """Deterministic sweep of the values that broke the schema before (huge and tiny magnitudes
    overflow or underflow derived masses, inertias and counts)."""
    outcomes = {"refused": 0, "built": 0}
    for leaf in LEAVES[concept]:
        for value in (1e300, 1e-300, -1, 0):
            outcomes[check_named_or_builds(BASES[concept], leaf, value)] += 1
    assert outcomes["refused"] > 0 and outcomes["built"] > 0, outcomes


def _shipped_configs() -> list[Path]:
    paths = sorted((REPO / "magsail_mj" / "concepts").rglob("*.toml"))
    return [p for p in paths if not is_sweep_file(p) and not is_structure_file(p)]


def test_every_numeric_leaf_of_every_shipped_config_refuses_non_finite():
    configs = _shipped_configs()
    assert len(configs) > 50
    checked = 0
    for path in configs:
        tree = tomllib.loads(path.read_text())
        for leaf in numeric_leaves(tree):
            key = leaf_name(leaf)
            if key in ALLOW_INFINITY:
                continue
            for value in (math.nan, math.inf, -math.inf):
                with pytest.raises(ConfigError) as err:
                    parse_config(with_leaf(tree, leaf, value))
                assert key in str(err.value), f"{path.relative_to(REPO)}: {key} = {value}:\n{err.value}"
                line = next(ln for ln in err.value.problems if key in ln)
                assert "must" in line, line
                checked += 1
    assert checked > 3000, checked


@settings(max_examples=40, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow])
@given(value=st.one_of(st.sampled_from(DETUMBLE_LAWS), st.text(max_size=12), st.sampled_from(HOSTILE)))
def test_detumble_law_is_named_or_builds(value: Any) -> None:
    """``control.bdot_law``: one of the laws builds, anything else is refused naming the key."""
    leaf = (("control", "bdot_law"), None)
    tree = with_leaf(BASES["cnusail"], leaf, value)
    try:
        cfg = parse_config(tree)
    except ConfigError as err:
        assert "control.bdot_law" in str(err) and value not in DETUMBLE_LAWS, err
        return
    assert value in DETUMBLE_LAWS
    build_scenario(cfg)


@pytest.mark.parametrize("value", ["2", True, [2.0], {"a": 1}])
def test_wrong_types_are_never_coerced(value):
    tree = BASES["truss_magnetorquer"]
    for leaf in [(("sim", "duration_s"), None), (("lattice", "units"), None), (("initial", "omega0_rad_s"), 0)]:
        with pytest.raises(ConfigError, match=leaf_name(leaf).replace(".", r"\.")):
            parse_config(with_leaf(tree, leaf, value))


# ----------------------------------------------------------------------------- validate and run agree

# Overrides that make a build and a few steps cheap (a run's duration sizes its orbit and field
# tables); applied before the extreme value, which wins.
TINY_RUN = {"truss_magnetorquer": ["lattice.units=3"], "current_loops": ["lattice.units=3"]}
#: the most modal-damping modes kept exactly on a 3-unit lattice (32 nodes: 96 dofs, 6 rigid, and
#: one above them for the polynomial form)
TINY_N_LOW = 89
TINY_DURATION_S = {"msac": 0.01}  # the others 1 s; never below 3 time steps nor above the config's own
EXTREME_FINITE: list[Any] = [1e300, -1e300, 1e-300, 2**62, 2**31 - 1]
RUN_STATUSES = {"running", "completed", "diverged", "structure_failed"}
STEPS = 3


@functools.lru_cache(maxsize=None)
def _tiny_tree(path: Path) -> tuple[dict[str, Any], tuple[Leaf, ...]]:
    """The validated config of ``path`` at a tiny size, dumped with every default, and its numeric
    leaves (presentation keys left out: they change no number of a run)."""
    tree = tomllib.loads(path.read_text())
    overrides = list(TINY_RUN.get(tree.get("concept"), []))
    if tree.get("concept") == "current_loops" and tree.get("damping", {}).get("n_low", 0) > TINY_N_LOW:
        overrides.append(f"damping.n_low={TINY_N_LOW}")  # a larger count fits the full-size lattice only
    sim = tree.get("sim", {})
    if "duration_s" in sim and "timestep_s" in sim:
        tiny = max(TINY_DURATION_S.get(tree.get("concept"), 1.0), 3.0 * sim["timestep_s"])
        overrides.append(f"sim.duration_s={float(min(sim['duration_s'], tiny))!r}")
    if "cache_dir" in tree.get("control", {}):  # no on-disk Lloyd cache shared between test processes
        overrides.append('control.cache_dir=""')
    cfg = load_config(path, overrides)
    dumped = cfg.model_dump(mode="json")
    return dumped, tuple(leaf for leaf in numeric_leaves(dumped) if leaf[0][0] != "render")


def check_validate_and_run_agree(tree: dict[str, Any], leaf: Leaf, value: Any) -> str:
    """``"refused"`` (a ConfigError naming the key, or the memory estimate) or ``"ran"``: the
    simulation of the accepted config built and stepped, ending in a documented status."""
    key = leaf_name(leaf)
    try:
        cfg = parse_config(with_leaf(tree, leaf, value))
    except ConfigError as err:
        assert key in str(err), f"{key} = {value!r}: the error does not name the key:\n{err}"
        return "refused"
    try:
        check_memory(estimate_run_bytes(cfg), what="validate")
    except MemoryLimitError:
        return "refused"
    sim = magsail_mj.load(cfg)
    if hasattr(sim, "step"):  # the concept runners without a step loop (sweeps, lifetime) only build
        status = sim.step(STEPS)
        assert status in RUN_STATUSES, f"{key} = {value!r}: {status}: {sim.message}"
    return "ran"


def test_the_issue_reproducers_are_refused_by_validation():
    """Validation computes the derived quantities the build uses: the B-dot gain of a 1e300 A
    current limit (the run said "gain: must be > 0, got inf" with no key) is refused naming the key
    and its value; a 1e300 A m²/kg rod (an OverflowError in the allocation) validates and runs."""
    with pytest.raises(ConfigError, match=r"coil\.I_max_A: the B-dot gain .* overflows float64 .*1e\+300"):
        load_config(REPO / "magsail_mj/concepts/reflector/configs/detumble.toml", ["coil.I_max_A=1e300"])
    tree, _ = _tiny_tree(REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml")
    assert check_validate_and_run_agree(tree, (("actuators", "kappa_Am2_kg"), None), 1e300) == "ran"
    # further derived quantities the sweep found overflowing in the build (each ended the run
    # with an exception after validation passed)
    for config, override, key in (
        ("truss_magnetorquer/configs/slew_i.toml", "mass.total_kg=1e300", "mass.total_kg"),  # gg compensation
        ("reflector/configs/tracking_10g.toml", "control.omega_n_rad_s=1e300", "control.omega_n_rad_s"),  # P_q
        ("cnusail/configs/nadir_post.toml", "control.omega_n_rad_s=1e300", "control.omega_n_rad_s"),  # k = 2 ω_n²
        ("cnusail/configs/nadir_post.toml", "spacecraft.sail_area_m2=1e-300", "spacecraft.sail_area_m2"),  # booms
        ("cnusail/configs/nadir_post.toml", "spacecraft.bus_size_m=[-1e300, 0.1, 0.3]", "spacecraft.bus_size_m"),
        # the J2 propagation failed (RuntimeError): J2 <= 1/2, 3 J2 (R/r_p)² <= 0.1
        ("cnusail/configs/detumble_pre.toml", f"orbit.J2={2**62}", "orbit.J2"),
        ("cnusail/configs/detumble_pre.toml", f"orbit.J2={2**31 - 1}", "orbit.J2"),
        ("cnusail/configs/detumble_pre.toml", f"orbit.j2_radius_km={2**62}", "orbit.j2_radius_km"),
    ):
        with pytest.raises(ConfigError, match=re.escape(key)):
            load_config(REPO / "magsail_mj/concepts" / config, [override])


@pytest.mark.parametrize(
    ("config", "key", "value"),
    [
        ("current_loops/configs/slew_rigid.toml", "lattice.side_m", 2**62),
        ("current_loops/configs/slew_rigid.toml", "lattice.side_m", 2**31 - 1),
        ("current_loops/configs/slew_rigid.toml", "mass.areal_density_kg_m2", 2**31 - 1),
        ("truss_magnetorquer/configs/gg_ablation_slew_i.toml", "lattice.side_m", 2**31 - 1),
    ],
)
def test_huge_valid_inertias_pass_the_symmetry_checks(config: str, key: str, value: int) -> None:
    """A huge but valid inertia (entries near 1e70 kg m²) is symmetric to the rounding of its
    largest entry: the gravity-gradient load's and the controller's checks are relative to that
    scale (an absolute floor refused them, an exception in the build after validation passed)."""
    tree, _ = _tiny_tree(REPO / "magsail_mj/concepts" / config)
    assert check_validate_and_run_agree(tree, (tuple(key.split(".")), None), value) == "ran"


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("wings.length_m", 2**31 - 1),  # the held-torque calibration: SVD did not converge
        ("wings.length_m", 2**62),  # an IndexError in the build
        ("wings.width_m", 2**62),
        ("wings.thickness_m", 2**62),  # singular matrix
        ("wings.areal_density_kg_m2", 2**62),
        ("wings.hinge_offset_m", 2**31 - 1),
        ("wings.hinge_offset_m", 1e300),
        ("wings.slide_stiffness_N_m", 2**62),
        ("wings.root_inertia_kgm2", 1e300),
    ],
)
def test_msac_bodies_lost_in_rounding_are_refused(key: str, value: float) -> None:
    """Wings whose mass or inertia spreads beyond float64's rounding from the other bodies', or
    whose slide spring the step cannot resolve, made the held-torque calibration fail after
    validation passed (LinAlgError, IndexError): validation refuses them naming the key."""
    tree, _ = _tiny_tree(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml")
    assert check_validate_and_run_agree(tree, (tuple(key.split(".")), None), value) == "refused"


@pytest.mark.parametrize("key", ["drive.calibration_cycles", "drive.chunk_cycles"])
def test_msac_cycle_counts_are_inside_the_memory_estimate(key: str) -> None:
    """2^62 cycles made the drive's arrays exceed NumPy's size after validation passed: the chunk
    and calibration buffers are counted in the memory estimate, which refuses them."""
    tree, _ = _tiny_tree(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml")
    assert check_validate_and_run_agree(tree, (tuple(key.split(".")), None), 2**62) == "refused"
    assert msac_drive_bytes(parse_config(tree)) > 0


def test_symmetry_is_relative_to_the_scale():
    """Rounding of the largest entry passes at any scale; a real asymmetry or a non-finite entry
    does not."""
    J = np.diag([1.0, 2.0, 3.0]) * 1e70
    J[0, 1], J[1, 0] = 1e58, 1e58 * (1 + 1e-15)
    assert is_symmetric(J) and is_symmetric(J * 1e-140) and is_symmetric(np.zeros((3, 3)))
    J[0, 1] = 1e60
    assert not is_symmetric(J)
    assert not is_symmetric(np.full((3, 3), np.inf)) and not is_symmetric(np.ones(3))


def test_validate_and_run_agree_on_extreme_values():
    """A fixed budget of (shipped config, numeric key, extreme value) draws."""
    configs = _shipped_configs()

    @settings(max_examples=6, deadline=None, derandomize=True, suppress_health_check=list(HealthCheck))
    @given(path=st.sampled_from(configs), data=st.data(), value=st.sampled_from(EXTREME_FINITE))
    def run(path: Path, data: st.DataObject, value: Any) -> None:
        tree, leaves = _tiny_tree(path)
        leaf = data.draw(st.sampled_from(leaves), label="leaf")
        check_validate_and_run_agree(tree, leaf, value)

    run()


@pytest.mark.slow
def test_validate_and_run_agree_on_every_key_of_every_kind_of_config():
    """Every numeric key of one config per (concept, scenario) at every extreme value, then a long
    hypothesis campaign over all shipped configs (minutes)."""
    kinds: dict[tuple[str, str], Path] = {}
    for path in _shipped_configs():
        tree = tomllib.loads(path.read_text())
        kinds.setdefault((tree["concept"], str(tree.get("scenario")).split("/")[0]), path)
    failures = []
    for path in kinds.values():
        tree, leaves = _tiny_tree(path)
        for leaf in leaves:
            if (tree["concept"], leaf_name(leaf)) in OPEN:
                continue
            for value in EXTREME_FINITE:
                try:
                    check_validate_and_run_agree(tree, leaf, value)
                except Exception as err:  # noqa: BLE001 - collect every disagreement of the sweep
                    where = f"{path.relative_to(REPO)}: {leaf_name(leaf)} = {value!r}"
                    failures.append(f"{where}: {type(err).__name__}: {err}")
    assert not failures, "\n".join(failures)


# Disagreements the sweep found that are not fixed yet (the build's own code, outside the
# validators): kept visible here, left out of the slow sweep until fixed.
OPEN: dict[tuple[str, str], str] = {}


def test_modal_damping_needs_the_modes_it_keeps() -> None:
    """The polynomial modal damping fits the modes above n_low: a current-loops lattice shrunk
    below them (n_low = 100 on 3 units: 90 elastic modes) validated and then failed in the build;
    validation refuses it naming damping.n_low and the lattice size. The dense form damps every
    mode at xi_low then, and is accepted."""
    config = REPO / "magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml"
    with pytest.raises(ConfigError, match=r"damping\.n_low: the 3-unit lattice has 90 elastic modes"):
        load_config(config, ["lattice.units=3", "damping.n_low=100", 'damping.form="polynomial"'])
    load_config(config, ["lattice.units=3", "damping.n_low=89", 'damping.form="polynomial"'])
    load_config(config, ["lattice.units=3", "damping.n_low=100", 'damping.form="dense"'])
