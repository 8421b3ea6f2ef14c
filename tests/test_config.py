"""Config loading: validation messages, unknown keys, overrides."""

from __future__ import annotations

import math

import pytest
from pydantic import ValidationError, model_validator

import magsail_mj.concepts as concepts_registry
from magsail_mj.config import (
    ConfigError,
    SimConfig,
    StrictModel,
    apply_overrides,
    config_hash,
    load_config,
    numbers_hash,
    parse_config,
    read_toml,
    validation_problems,
)
from magsail_mj.structure.fileformat import is_structure_file
from magsail_mj.sweep import is_sweep_file, load_sweep
from tests.conftest import REPO


def test_shipped_configs_validate():
    configs = sorted(p for p in (REPO / "magsail_mj" / "concepts").rglob("*.toml") if not is_structure_file(p))
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
    tree = apply_overrides(
        small_truss_tree, ["sim.duration_s=60", "actuators.placement=central", "initial.omega0_rad_s=[0.01, 0.0, 0.0]"]
    )
    cfg = parse_config(tree)
    assert cfg.sim.duration_s == 60.0
    assert cfg.actuators.placement == "central"
    assert cfg.initial.omega0_rad_s == (0.01, 0.0, 0.0)
    with pytest.raises(ConfigError, match="lattice.units"):
        parse_config(apply_overrides(small_truss_tree, ["lattice.units=-2"]))
    with pytest.raises(ConfigError, match="must look like key.path=value"):
        apply_overrides(small_truss_tree, ["sim.duration_s"])


def test_load_config_overrides_and_missing_file(tmp_path):
    path = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml"
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


# ----------------------------------------------------------------------------- strict values

TRUSS = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml"


@pytest.mark.parametrize(
    "override, key",
    [
        ('sim.duration_s="2"', "sim.duration_s"),
        ("sim.duration_s=true", "sim.duration_s"),
        ('sim.progress="no"', "sim.progress"),
        ("sim.progress=1", "sim.progress"),
        ("lattice.units=3.0", "lattice.units"),
        ("lattice.units=true", "lattice.units"),
        ('initial.omega0_rad_s=[0.01, "0", 0.0]', r"initial.omega0_rad_s\[1\]"),
    ],
)
def test_types_are_strict(override, key):
    with pytest.raises(ConfigError, match=key):
        load_config(TRUSS, [override])


def test_toml_int_for_float_and_arrays_for_vectors_are_fine():
    cfg = load_config(TRUSS, ["sim.duration_s=60", "initial.omega0_rad_s=[0, 0, 1]"])
    assert cfg.sim.duration_s == 60.0
    assert cfg.initial.omega0_rad_s == (0, 0, 1)


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_non_finite_time_step_says_finite(value):
    with pytest.raises(ConfigError, match=r"sim\.timestep_s: must be a finite number"):
        load_config(TRUSS, [f"sim.timestep_s={value}"])


def test_time_step_bounds_and_checkpoint_period():
    with pytest.raises(ConfigError, match=r"sim\.timestep_s: must be a number >= 1e-09"):
        load_config(TRUSS, ["sim.timestep_s=1e-12"])
    with pytest.raises(ConfigError, match=r"sim\.checkpoint_every_s: must be 0 \(never\) or at least one time step"):
        load_config(TRUSS, ["sim.checkpoint_every_s=0.01"])
    assert load_config(TRUSS, ["sim.checkpoint_every_s=0"]).sim.checkpoint_every_s == 0
    assert load_config(TRUSS, ["sim.checkpoint_every_s=0.1"]).sim.checkpoint_every_s == 0.1
    with pytest.raises(ConfigError, match=r"sim\.duration_s: must be at least one time step"):
        load_config(TRUSS, ["sim.duration_s=0.01"])
    with pytest.raises(ConfigError, match=r"sim\.duration_s: needs .* steps, more than a 64-bit step counter"):
        load_config(TRUSS, ["sim.duration_s=1e300"])


_CONFIG_OF = {
    "reflector": "magsail_mj/concepts/reflector/configs/detumble.toml",
    "cnusail": "magsail_mj/concepts/cnusail/configs/detumble_pre.toml",
    "truss": "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml",
    "loops": "magsail_mj/concepts/current_loops/configs/slew.toml",
    "msac": "magsail_mj/concepts/msac/configs/paper_1khz.toml",
}


@pytest.mark.parametrize(
    "concept, override, key",
    [
        ("reflector", "plate.side_m=inf", "plate.side_m"),
        ("reflector", "plate.side_m=1e300", "plate.side_m"),
        ("reflector", "plate.cell_m=1e-300", "plate.side_m"),
        ("cnusail", "actuators.mtq.cycle_s=inf", "actuators.mtq.cycle_s"),
        ("cnusail", "actuators.mtq.cycle_s=1e-300", "actuators.mtq.cycle_s"),
        ("cnusail", "spacecraft.mass_kg=1e-300", "spacecraft.mass_kg"),
        ("cnusail", "actuators.wheels.rotor_inertia_kgm2=1e300", "rotor_inertia_kgm2"),
        ("truss", "mass.total_kg=1e-300", "mass.total_kg"),
        ("truss", "lattice.side_m=1e300", "lattice.side_m"),
        ("truss", "orbit.altitude_km=1e300", "orbit.altitude_km"),
        ("loops", "mass.areal_density_kg_m2=1e-300", "mass.areal_density_kg_m2"),
        ("msac", "wings.length_m=1e-300", "wings.length_m"),
        ("msac", "bus.size_m=[1e300, 2.0, 3.0]", "bus.size_m"),
    ],
)
def test_extreme_magnitudes_are_config_errors_naming_the_key(concept, override, key):
    """Overflow or values MuJoCo cannot take (mass below mjMINVAL) are refused at validation."""
    with pytest.raises(ConfigError, match=key.replace(".", r"\.")):
        load_config(REPO / _CONFIG_OF[concept], [override])


def test_msac_step_error_names_the_full_key():
    with pytest.raises(ConfigError) as err:
        load_config(REPO / "magsail_mj/concepts/msac/configs/paper_1khz.toml", ["sim.timestep_s=3e-6"])
    assert err.value.problems[0].startswith("sim.timestep_s: the cycle period")
    assert "cycle.frequency_Hz" in err.value.problems[0]


def test_msac_sweep_points_are_validated_at_load():
    with pytest.raises(ConfigError) as err:
        load_config(REPO / "magsail_mj/concepts/msac/configs/sweeps/stroke.toml", ['sweep.points=[["x"], [1e300]]'])
    assert [p.split(":")[0] for p in err.value.problems] == ["sweep.points[0]", "sweep.points[1]"]
    assert "cycle.bend_b_deg" in err.value.problems[0]


# ----------------------------------------------------------------------------- overrides and files


def test_override_syntax_and_validation_problems_reported_together():
    with pytest.raises(ConfigError) as err:
        load_config(TRUSS, ["foo", "lattice.units=0", "sim.duration_s.x=1", "sim.bogus=1"])
    text = str(err.value)
    assert "--set 'foo': must look like key.path=value" in text
    assert "lattice.units: must be an integer >= 1, got 0" in text
    assert "sim.duration_s is a value, not a table" in text
    assert "sim.bogus: unknown key given by --set 'sim.bogus=1'" in text
    assert len(err.value.problems) == 4


def test_folder_binary_non_utf8_and_unreadable_configs(tmp_path, monkeypatch):
    with pytest.raises(ConfigError, match="is a folder, not a config file"):
        load_config(tmp_path)
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\x00\x01\x02\xff\xfe")
    with pytest.raises(ConfigError, match="not UTF-8"):
        load_config(binary)
    nul = tmp_path / "nul.toml"
    nul.write_bytes(b"concept = 1\x00\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_config(nul)
    locked = tmp_path / "locked.toml"
    locked.write_text(TRUSS.read_text())

    def refuse(self):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(type(locked), "read_bytes", refuse)
    with pytest.raises(ConfigError, match="cannot be read: Permission denied"):
        load_config(locked)


# ----------------------------------------------------------------------------- numbers_hash


def test_numbers_hash_ignores_presentation_keys_only():
    base = load_config(TRUSS)
    same = load_config(
        TRUSS,
        [
            "sim.progress=false",
            "sim.duration_s=18000",
            "sim.checkpoint_every_s=600",
            "render.fps=12",
            "render.exaggeration=3.0",
        ],
    )
    assert numbers_hash(same) == numbers_hash(base)
    assert config_hash(same) != config_hash(base)
    for change in ["control.k_bdot_Nms_T2=2e12", "sim.timestep_s=0.05", "sim.seed=3", "mass.total_kg=201.0"]:
        assert numbers_hash(load_config(TRUSS, [change])) != numbers_hash(base), change
    assert len(numbers_hash(base)) == 64


class _Crashy(StrictModel):
    """A table whose validator overflows (what round(inf) did before finite numbers were required)."""

    x: float = 1.0

    @model_validator(mode="after")
    def _boom(self) -> _Crashy:
        if self.x > 1e200:
            math.exp(self.x)
        return self


class _CrashyConfig(StrictModel):
    concept: str
    table: _Crashy = _Crashy()


def test_any_validator_exception_becomes_a_config_error_naming_the_table(monkeypatch):
    monkeypatch.setitem(concepts_registry.CONFIG_SCHEMAS, "crashy", _CrashyConfig)
    assert parse_config({"concept": "crashy", "table": {"x": 2.0}}).table.x == 2.0
    with pytest.raises(ConfigError) as err:
        parse_config({"concept": "crashy", "table": {"x": 1e300}})
    assert err.value.problems[0].startswith("table: its validator failed (OverflowError")
    assert "{'x': 1e+300}" in err.value.problems[0]


def test_read_toml_and_validation_problems_for_other_loaders(tmp_path):
    """Public helpers for loaders of other TOML tables (sweep files, scaling inputs)."""
    with pytest.raises(ConfigError, match="is a folder"):
        read_toml(tmp_path)
    bad = tmp_path / "latin1.toml"
    bad.write_bytes(b'name = "caf\xe9"\n')
    with pytest.raises(ConfigError, match="not UTF-8"):
        read_toml(bad)
    assert read_toml(TRUSS)["concept"] == "truss_magnetorquer"
    with pytest.raises(ValidationError) as err:
        SimConfig.model_validate({"duration_s": "2", "timestep_s": math.nan})
    assert validation_problems(err.value, prefix="sim.") == [
        "sim.duration_s: must be a number (not a string or a boolean), got '2'",
        "sim.timestep_s: must be a finite number, got nan",
    ]
