"""The environment tables shared by the concept schemas (magsail_mj.environment.config):
``EnvironmentTables`` (the seven tables with free-space defaults, inherited by the truss schema
and by ``EnvironmentConfig``) and ``environment_config_of`` (a concept config's tables as one
``EnvironmentConfig``). Checked against explicit constructions (each check can fail)."""

from __future__ import annotations

from magsail_mj.concepts.current_loops.config import CurrentLoopsConfig
from magsail_mj.concepts.truss_magnetorquer.config import TrussConfig, TrussTables
from magsail_mj.config import load_config
from magsail_mj.environment.config import (
    ENVIRONMENT_TABLES,
    AtmosphereConfig,
    DragConfig,
    EnvironmentConfig,
    EnvironmentTables,
    FieldConfig,
    GravityConfig,
    OrbitConfig,
    SRPConfig,
    SunConfig,
    environment_config_of,
)
from tests.conftest import REPO

FREE_SPACE = {
    "orbit": OrbitConfig(enabled=False),
    "field": FieldConfig(model="none"),
    "atmosphere": AtmosphereConfig(model="none"),
    "sun": SunConfig(model="none"),
    "srp": SRPConfig(),
    "drag": DragConfig(),
    "gravity": GravityConfig(tidal=False),
}


def test_the_tables_and_their_free_space_defaults():
    assert tuple(EnvironmentTables.model_fields) == ENVIRONMENT_TABLES == tuple(FREE_SPACE)
    assert EnvironmentTables() == EnvironmentTables(**FREE_SPACE)
    assert EnvironmentConfig().model_dump() == EnvironmentTables(**FREE_SPACE).model_dump()


def test_truss_schema_lists_its_own_keys_first_then_the_environment_tables():
    assert list(TrussConfig.model_fields) == [*TrussTables.model_fields, *ENVIRONMENT_TABLES]
    assert not set(TrussTables.model_fields) & set(ENVIRONMENT_TABLES)


def test_a_truss_config_hands_its_own_tables_on():
    cfg = load_config(REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml")
    assert isinstance(cfg, TrussConfig) and cfg.orbit.enabled
    env = cfg.environment_config()
    assert type(env) is EnvironmentConfig
    for name in ENVIRONMENT_TABLES:
        assert getattr(env, name) is getattr(cfg, name), name


def test_a_config_without_some_tables_gets_their_free_space_defaults():
    cfg = load_config(
        REPO / "magsail_mj/concepts/current_loops/configs/slew.toml", ["orbit.enabled=true", "field.model='igrf'"]
    )
    assert isinstance(cfg, CurrentLoopsConfig) and not hasattr(cfg, "atmosphere")
    want = EnvironmentConfig(
        orbit=cfg.orbit,
        field=cfg.field,
        gravity=cfg.gravity,
        **{k: FREE_SPACE[k] for k in ("atmosphere", "sun", "srp", "drag")},
    )
    assert environment_config_of(cfg) == want == cfg.environment_config()
