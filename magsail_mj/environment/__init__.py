"""Orbit, frames and time, geomagnetic field, Sun and atmosphere (README: Orbit and space environment).

The runtime entry point is :class:`Environment` (precompute along the reference orbit once,
``sample(t)`` per step in O(1)); its config tables live in :mod:`.config`.
"""

from magsail_mj.environment.config import (
    AtmosphereConfig,
    DragConfig,
    EnvironmentConfig,
    FieldConfig,
    GravityConfig,
    OrbitConfig,
    SRPConfig,
    SunConfig,
    check_environment,
)
from magsail_mj.environment.environment import Environment, EnvSample, elements_from_config
from magsail_mj.environment.orbit import OrbitalElements, ReferenceOrbit

__all__ = [
    "AtmosphereConfig",
    "DragConfig",
    "EnvironmentConfig",
    "FieldConfig",
    "GravityConfig",
    "OrbitConfig",
    "SRPConfig",
    "SunConfig",
    "check_environment",
    "Environment",
    "EnvSample",
    "elements_from_config",
    "OrbitalElements",
    "ReferenceOrbit",
]
