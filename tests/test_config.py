"""Config loading: validation messages, unknown keys, overrides."""

from __future__ import annotations

import pytest

from magsail_mj.config import ConfigError, apply_overrides, config_hash, load_config, parse_config
from magsail_mj.sweep import is_sweep_file, load_sweep
from tests.conftest import REPO


def test_shipped_configs_validate():
    configs = sorted((REPO / "models").rglob("*.toml"))
    assert configs, "no configs shipped in models/"
    for path in configs:
        if is_sweep_file(path):
            assert load_sweep(path).runs, path  # validates every config it lists
        else:
            load_config(path)


def test_bad_value_names_key_value_and_rule(small_truss_tree):
    small_truss_tree["lattice"]["units"] = 0
    with pytest.raises(ConfigError) as err:
        parse_config(small_truss_tree)
    assert "lattice.units: must be an integer >= 1, got 0" in str(err.value)


def test_unknown_key_is_an_error(small_truss_tree):
    small_truss_tree["lattice"]["unit"] = 3
    with pytest.raises(ConfigError, match=r"lattice\.unit: unknown key"):
        parse_config(small_truss_tree)


def test_literal_choices_are_listed(small_truss_tree):
    small_truss_tree["actuators"]["placement"] = "middle"
    with pytest.raises(ConfigError, match=r"actuators\.placement: must be one of .*distributed.*got 'middle'"):
        parse_config(small_truss_tree)


def test_all_problems_reported_at_once(small_truss_tree):
    small_truss_tree["sim"]["timestep_s"] = -1
    small_truss_tree["mass"]["total_kg"] = 0
    with pytest.raises(ConfigError) as err:
        parse_config(small_truss_tree)
    assert len(err.value.problems) == 2


def test_missing_table_for_scenario(small_truss_tree):
    del small_truss_tree["profile"]
    with pytest.raises(ConfigError, match="needs the \\[actuators\\] and \\[profile\\] tables"):
        parse_config(small_truss_tree)


def test_unknown_concept(small_truss_tree):
    small_truss_tree["concept"] = "warp_drive"
    with pytest.raises(ConfigError, match="concept: must be one of"):
        parse_config(small_truss_tree)


def test_overrides_are_typed_and_validated(small_truss_tree):
    tree = apply_overrides(small_truss_tree, ["sim.duration_s=60", "actuators.placement=central",
                                              "initial.omega0_rad_s=[0.01, 0.0, 0.0]"])
    cfg = parse_config(tree)
    assert cfg.sim.duration_s == 60.0
    assert cfg.actuators.placement == "central"
    assert cfg.initial.omega0_rad_s == (0.01, 0.0, 0.0)
    with pytest.raises(ConfigError, match="lattice.units"):
        parse_config(apply_overrides(small_truss_tree, ["lattice.units=-2"]))
    with pytest.raises(ConfigError, match="must look like key.path=value"):
        apply_overrides(small_truss_tree, ["sim.duration_s"])


def test_load_config_overrides_and_missing_file(tmp_path):
    path = REPO / "models/truss_magnetorquer/dist_vs_central/case_c_central_bangbang.toml"
    cfg = load_config(path, ["sim.duration_s=60"])
    assert cfg.sim.duration_s == 60.0
    with pytest.raises(ConfigError, match="does not exist"):
        load_config(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("concept = \n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(bad)


def test_hash_changes_with_content(small_truss_tree):
    a = config_hash(parse_config(small_truss_tree))
    small_truss_tree["sim"]["seed"] = 1
    assert config_hash(parse_config(small_truss_tree)) != a
