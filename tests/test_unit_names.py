"""One unit-suffix grammar for every name (:mod:`magsail_mj.units_grammar`), and the deprecation
aliases of the config keys it renamed.

Checked: the parser reads the spellings the conventions page defines; every config key of every
concept and every summary key of the stored regression summaries either carries a suffix of the
grammar or is a dimensionless number named as such, and none is spelled the old way; the page's
table lists every suffix in use with the unit the grammar reads; an old config spelling loads (TOML
or ``--set``) with a ``DeprecationWarning`` into the same config as the new one, and both
spellings together are refused naming both; over random names, the rename map, its inverse and the
aliases of the config base agree; ``scripts/rename_units.py`` renames whole identifiers only, JSON
keys but not values, and is idempotent.
"""

from __future__ import annotations

import collections
import importlib.util
import json
import re
import typing
import warnings
from pathlib import Path

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel, create_model

from magsail_mj.config import ConfigError, StrictModel, concept_models, load_config, numbers_tree
from magsail_mj.units_grammar import (
    ALIAS_REMOVAL_VERSION,
    KEPT_NAMES,
    RENAMED_SUFFIXES,
    deprecated_aliases,
    new_name,
    old_spellings,
    parse_group,
    split_unit,
    unit_label,
)

ROOT = Path(__file__).resolve().parents[1]
CONVENTIONS = ROOT / "docs" / "conventions.md"
SUMMARIES = ROOT / "tests" / "data" / "regression_summaries.json"

#: words that mark a floating-point key as dimensionless (a ratio, a fraction, a coefficient ...)
DIMENSIONLESS_WORDS = frozenset(
    {
        "amplification",
        "coefficient",
        "diff",
        "drift",
        "eccentricity",
        "emissivity",
        "err",
        "exaggeration",
        "factor",
        "frac",
        "fraction",
        "fractions",
        "over",
        "product",
        "ratio",
        "rel",
        "rtol",
        "scale",
        "share",
        "strain",
        "tol",
        "tolerance",
        "wxyz",
        "xi",
        "zeta",
    }
)
#: floating-point keys without a unit whose name says so by no word of :data:`DIMENSIONLESS_WORDS`
DIMENSIONLESS_NAMES = frozenset(
    {
        "J2",  # Earth's oblateness coefficient
        "terminal_weight",  # truss MPC: weight of the horizon's last step relative to the others
        "effort_weight",  # truss MPC: weight of the dipole normalised by its limit
        "step_weight",  # truss MPC: weight of the plan's change, normalised as the effort
        "ap",  # geomagnetic Ap index
        "kg",  # [mass] point masses: the key is the unit itself (a mass in kg)
        "kappa",  # current loops: the light-branch parameter of the paper's Eq. 9
        "bdot_gain",  # reflector summary: the B-dot gain of the plate
        "n_orbits",
        "omega_c_dt",
        "servo_omega_dt",
        "time_lapse",
        "q_target",
        "direction",
        "direction_eci",
        "gain_clamp_min",
        "perturbation_seed",
        "collapse_thickness_units",
        "replay_settle_change",
        "prestrain",  # structure: a member's strain at its reference length
        "reflectivity",  # structure: a panel's reflected and absorbed fractions
        "orientation",  # structure: a beam section's direction vector
        "nonmonotonic_alpha",  # CNUSAIL: the weight of the look-ahead term in the detumble law's cost
        "bdot_law_params",  # CNUSAIL: a plug-in law's parameters, each name carrying its own unit suffix
    }
)


def _walk(model: type[BaseModel], prefix: str = "") -> typing.Iterator[tuple[str, typing.Any]]:
    """``(dotted key path, annotation)`` of every key of ``model`` and of the tables inside it."""
    for name, field in model.model_fields.items():
        yield prefix + name, field.annotation
        stack = [field.annotation]
        while stack:
            a = stack.pop()
            if isinstance(a, type) and issubclass(a, BaseModel):
                yield from _walk(a, f"{prefix}{name}.")
            else:
                stack.extend(typing.get_args(a))


def _holds_float(annotation: typing.Any) -> bool:
    return annotation is float or any(_holds_float(a) for a in typing.get_args(annotation))


def _config_keys() -> dict[str, typing.Any]:
    """Every ``concept: key.path`` with its annotation."""
    return {f"{c}: {path}": a for c, m in concept_models().items() for path, a in _walk(m)}


def _summary_values() -> dict[str, typing.Any]:
    """Every summary key of the stored regression summaries with one of its values."""
    return {k: v for summary in json.loads(SUMMARIES.read_text()).values() for k, v in summary.items()}


def _dimensionless(name: str) -> bool:
    return name in DIMENSIONLESS_NAMES or bool(DIMENSIONLESS_WORDS & set(name.lower().split("_")))


def _conventions_table() -> dict[str, str]:
    """Suffix → unit of the "Unit suffixes in use" table of the conventions page."""
    text = CONVENTIONS.read_text().split("## Unit suffixes in use", 1)[1].split("\n## ", 1)[0]
    return dict(re.findall(r"^\| `_(\w+)` \| ([^|]+?) \|", text, flags=re.MULTILINE))


# ----------------------------------------------------------------------------- the grammar


@pytest.mark.parametrize(
    "name, label",
    [
        ("omega_rad_s", "rad/s"),
        ("accel_m_s2", "m/s²"),
        ("rho_kg_m3", "kg/m³"),
        ("flux_W_m2", "W/m²"),
        ("slide_stiffness_N_m", "N/m"),
        ("torque_max_Nm", "N·m"),
        ("h_Nms", "N·m·s"),
        ("EI_Nm2", "N·m²"),
        ("inertia_kgm2", "kg·m²"),
        ("dipole_Am2", "A·m²"),
        ("areal_density_kg_m2", "kg/m²"),
        ("gain_Nm_rad", "N·m/rad"),
        ("gamma_Ns_m", "N·s/m"),
        ("bdot_gain_Am2s_T", "A·m²·s/T"),
        ("mu_m3_s2", "m³/s²"),
        ("alpha_per_K", "1/K"),
        ("field_uT", "µT"),
        ("B_nT", "nT"),
        ("rho_ref_ohmm", "Ω·m"),
        ("torque_matrix_Nm_AT", "N·m/(A·T)"),
        ("lifetime_days", "days"),
    ],
)
def test_suffix_reads_as_the_conventions_page_says(name, label):
    assert unit_label(name) == label


@pytest.mark.parametrize("name", ["zeta", "max_strain", "units", "exaggeration", "record_every"])
def test_a_name_without_a_suffix_has_no_unit(name):
    assert split_unit(name) == (name, None)
    assert unit_label(name) == ""


def test_a_prefixed_symbol_stands_alone_in_its_group():
    assert parse_group("Nms") == (("N", 1), ("m", 1), ("s", 1))  # never N·ms
    assert parse_group("ms") == (("ms", 1),)
    assert parse_group("NmT") == (("N", 1), ("m", 1), ("T", 1))  # never N·mT
    assert parse_group("kgm2") == (("kg", 1), ("m", 2))
    assert parse_group("Nkm") is None
    assert parse_group("per") is None


def test_quantity_is_what_precedes_the_longest_suffix():
    assert split_unit("omega_body_rad_s")[0] == "omega_body"
    assert split_unit("T_max_Nm")[0] == "T_max"
    assert split_unit("steps_per_s")[0] == "steps"


# ----------------------------------------------------------------------------- names in use


def test_every_config_key_follows_the_grammar():
    bad = []
    for where, annotation in _config_keys().items():
        name = where.rsplit(".", 1)[-1].split(" ")[-1]
        if new_name(name) is not None:
            bad.append(f"{where}: old spelling, now {new_name(name)}")
        elif _holds_float(annotation) and split_unit(name)[1] is None and not _dimensionless(name):
            bad.append(f"{where}: a number without a unit suffix (or add it to the dimensionless names)")
    assert not bad, "\n".join(bad)


def test_every_summary_key_follows_the_grammar():
    bad = []
    for name, value in _summary_values().items():
        if new_name(name) is not None:
            bad.append(f"{name}: old spelling, now {new_name(name)}")
        elif isinstance(value, float) and split_unit(name)[1] is None and not _dimensionless(name):
            bad.append(f"{name}: a number without a unit suffix (or add it to the dimensionless names)")
    assert not bad, "\n".join(bad)


def test_conventions_table_lists_every_suffix_in_use_with_its_unit():
    table = _conventions_table()
    names = [w.rsplit(".", 1)[-1].split(" ")[-1] for w in _config_keys()] + list(_summary_values())
    in_use = {}
    for name in names:
        quantity, unit = split_unit(name)
        if unit is not None:
            in_use.setdefault(name[len(quantity) + 1 :], name)
    missing = {s: n for s, n in in_use.items() if s not in table}
    assert not missing, f"suffixes in use but not on the conventions page: {missing}"
    wrong = {s: (u, unit_label("x_" + s)) for s, u in table.items() if unit_label("x_" + s) != u}
    assert not wrong, f"table unit differs from the grammar's reading: {wrong}"


def test_dimensionless_names_are_still_in_use():
    names = {w.rsplit(".", 1)[-1].split(" ")[-1] for w in _config_keys()} | set(_summary_values())
    assert not DIMENSIONLESS_NAMES - names, f"stale dimensionless names: {sorted(DIMENSIONLESS_NAMES - names)}"


# ----------------------------------------------------------------------------- deprecation aliases

TRUSS = ROOT / "magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml"
LOOPS = ROOT / "magsail_mj/concepts/current_loops/configs/slew.toml"


def _old_spelling_file(path: Path, tmp_path: Path, key: str) -> Path:
    """A copy of ``path`` whose line ``key = ...`` spells ``key`` the old way."""
    (old,) = old_spellings(key)
    text = path.read_text()
    assert re.search(rf"^{key} =", text, flags=re.MULTILINE), f"{path.name} has no line {key} ="
    out = tmp_path / path.name
    out.write_text(re.sub(rf"^{key} =", f"{old} =", text, flags=re.MULTILINE))
    return out


@pytest.mark.parametrize(("path", "key"), [(TRUSS, "EI_Nm2"), (LOOPS, "kp_Nm"), (LOOPS, "kw_Nms")])
def test_old_spelling_in_a_file_loads_the_same_config_with_a_warning(tmp_path, path, key):
    old_file = _old_spelling_file(path, tmp_path, key)
    with pytest.warns(DeprecationWarning, match=rf"'{old_spellings(key)[0]}'.*'{key}'.*{ALIAS_REMOVAL_VERSION}"):
        old = load_config(old_file)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)
        new = load_config(path)
    assert numbers_tree(old) == numbers_tree(new)


def test_old_spelling_by_set_overrides_the_files_new_key(caplog):
    with pytest.warns(DeprecationWarning, match=r"'stiffness\.EI_N_m2'.*'stiffness\.EI_Nm2'"):
        cfg = load_config(TRUSS, ["stiffness.EI_N_m2=123.0"])
    assert cfg.stiffness.EI_Nm2 == 123.0
    assert "stiffness.EI_N_m2" in caplog.text  # logged, too
    assert numbers_tree(cfg) == numbers_tree(load_config(TRUSS, ["stiffness.EI_Nm2=123.0"]))


def test_new_spelling_by_set_overrides_the_files_old_key(tmp_path):
    old_file = _old_spelling_file(TRUSS, tmp_path, "EI_Nm2")
    with pytest.warns(DeprecationWarning):
        cfg = load_config(old_file, ["stiffness.EI_Nm2=7.0"])
    assert cfg.stiffness.EI_Nm2 == 7.0


def test_both_spellings_in_a_file_are_refused_naming_both(tmp_path):
    text = TRUSS.read_text().replace("EI_Nm2 = 1000.0", "EI_Nm2 = 1000.0\nEI_N_m2 = 1000.0")
    assert "EI_N_m2" in text
    both = tmp_path / "both.toml"
    both.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_config(both)
    assert "stiffness.EI_Nm2" in str(err.value) and "stiffness.EI_N_m2" in str(err.value)


def test_both_spellings_by_set_are_refused_naming_both():
    with pytest.raises(ConfigError) as err, warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        load_config(TRUSS, ["stiffness.EI_N_m2=5.0", "stiffness.EI_Nm2=4.0"])
    assert "stiffness.EI_Nm2" in str(err.value) and "stiffness.EI_N_m2" in str(err.value)


def test_unknown_key_that_is_no_old_spelling_stays_unknown():
    with pytest.raises(ConfigError, match=r"stiffness\.EI_kN_m2: unknown key"):
        load_config(TRUSS, ["stiffness.EI_kN_m2=5.0"])


# ----------------------------------------------------------------------------- the map, over names

_STEMS = st.from_regex(r"[a-z][a-z0-9]{0,6}(_[a-z][a-z0-9]{0,6}){0,3}", fullmatch=True)


@settings(max_examples=150, deadline=None)
@given(stem=_STEMS, pair=st.sampled_from(RENAMED_SUFFIXES))
def test_rename_map_inverse_and_aliases_agree(stem, pair):
    before, after = pair
    old, new = stem + before, stem + after
    assume(old not in KEPT_NAMES and parse_group(stem.rsplit("_", 1)[-1]) is None)
    assert new_name(old) == new
    assert new_name(new) is None  # the new spelling is final
    assert old in old_spellings(new)
    quantity, unit = split_unit(new)
    assert quantity == stem and unit is not None
    assert deprecated_aliases((new, "other")).get(old) == new
    table = create_model("Table", __base__=StrictModel, **{new: (float, ...)})
    with pytest.warns(DeprecationWarning, match=re.escape(f"'{old}'")):
        assert table.model_validate({old: 1.5}) == table.model_validate({new: 1.5})
    with pytest.raises(ValueError, match=re.escape(old)):
        table.model_validate({old: 1.5, new: 1.5})


# ----------------------------------------------------------------------------- the rename script

_spec = importlib.util.spec_from_file_location("rename_units", ROOT / "scripts" / "rename_units.py")
rename_units = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(rename_units)


def _renamed(text: str, *, json_keys: bool = False) -> str:
    rename = rename_units.rename_json_keys if json_keys else rename_units.rename_text
    return rename(text, collections.Counter(), [])


def test_rename_touches_whole_identifiers_only():
    src = "cap_N_m = 1\nx = cfg.kw_N_m_s + areal_density_kg_m2 + inertia_kg_m2\nMAIN_N_mode = 2  # cap_N_mx\n"
    assert _renamed(src) == (
        "cap_Nm = 1\nx = cfg.kw_Nms + areal_density_kg_m2 + inertia_kgm2\nMAIN_N_mode = 2  # cap_N_mx\n"
    )


def test_rename_reaches_generated_names_and_unit_strings_but_not_bare_suffixes():
    src = 'f"T_B{ax}_N_m", "disturbance_max[_{a,b}]_N_m", {"torque": "N_m"}, name.endswith("_N_m")'
    out = 'f"T_B{ax}_Nm", "disturbance_max[_{a,b}]_Nm", {"torque": "Nm"}, name.endswith("_N_m")'
    assert _renamed(src) == out


def test_rename_of_json_changes_keys_only():
    src = '{\n  "cap_N_m": 0.25,\n  "label": "cap_N_m",\n  "nested": {"h_N_m_s": [1, 2]}\n}'
    assert (
        _renamed(src, json_keys=True) == '{\n  "cap_Nm": 0.25,\n  "label": "cap_N_m",\n  "nested": {"h_Nms": [1, 2]}\n}'
    )


def test_rename_is_idempotent():
    src = "kappa_Am2_per_kg, k_bdot_Nms_per_T2, slide_damping_N_s_m, K_b_V_s_rad, rho_ref_ohm_m"
    once = _renamed(src)
    assert once == "kappa_Am2_kg, k_bdot_Nms_T2, slide_damping_Ns_m, K_b_Vs_rad, rho_ref_ohmm"
    assert _renamed(once) == once
