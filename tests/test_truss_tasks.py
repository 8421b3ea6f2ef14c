"""Truss concept layout: one task class per scenario kind, registered by name; no import cycle.

Checks (each can fail): the registered kinds are exactly the schema's ``scenario`` values; a
config of every kind builds its own class; the concept's modules import each other in one
direction only (a DAG), with every import at module top and none under ``TYPE_CHECKING``;
metrics and plots modules import no task module; the orbital metrics work on plain arrays
(an exponential decay of the rates against its analytic threshold time).
"""

from __future__ import annotations

import typing

import numpy as np
import pytest

from magsail_mj.concepts import task_kinds
from magsail_mj.config import load_config
from magsail_mj.scenario import build_scenario
from magsail_mj.concepts.truss_magnetorquer import tasks as tt
from magsail_mj.concepts.truss_magnetorquer.config import TrussConfig
from magsail_mj.concepts.truss_magnetorquer.orbital import detumble_keys
from tests.conftest import REPO

KIND_CONFIGS = {
    "cantilever": ("magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml", tt.CantileverTask),
    "free": ("magsail_mj/concepts/truss_magnetorquer/configs/libration.toml", tt.FreeTask),
    "dist_vs_central": ("magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml",
                        tt.DistVsCentralTask),
    "detumble": ("magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", tt.DetumbleTask),
    "slew": ("magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml", tt.SlewTask),
}


def test_registered_kinds_are_the_schema_scenarios():
    kinds = typing.get_args(TrussConfig.model_fields["scenario"].annotation)
    assert sorted(kinds) == task_kinds("truss_magnetorquer")


@pytest.mark.parametrize("kind", sorted(KIND_CONFIGS))
def test_every_kind_builds_its_own_class(kind):
    path, cls = KIND_CONFIGS[kind]
    cfg = load_config(REPO / path, ["lattice.units=3", "sim.duration_s=2"])
    assert cfg.scenario == kind
    sc = build_scenario(cfg)
    assert type(sc) is cls and isinstance(sc, tt.TrussScenario)
    assert sc.render_info()["overlay"] == list(cls.OVERLAY)


def test_detumble_keys_of_an_exponential_decay():
    """Rates ω_i(t) = ω0_i e^{−t/τ}: all three fall below 1e-3 rad/s at t* = τ ln(max|ω0| / 1e-3)
    (first sample at or after t*, so within one sample of 1 s) and stay there; H0 = |I ω0|."""
    tau = 300.0
    t = np.arange(0.0, 3000.0, 1.0)
    w0 = np.array([0.02, -0.01, 0.005])
    omega = w0[None, :] * np.exp(-t / tau)[:, None]
    inertia = np.diag([2.0e6, 3.0e6, 4.0e6])
    keys = detumble_keys(t, omega, inertia_kgm2=inertia, omega0_body=w0)
    t_star = tau * np.log(0.02 / 1e-3)
    assert t_star <= keys["t_rates_below_threshold_first_s"] < t_star + 1.0
    assert keys["t_rates_below_threshold_stay_s"] == keys["t_rates_below_threshold_first_s"]
    assert keys["H0_Nms"] == pytest.approx(np.linalg.norm(inertia @ w0), rel=1e-12)
    assert keys["omega_norm_max_rad_s"] == pytest.approx(np.linalg.norm(w0), rel=1e-12)
    np.testing.assert_allclose(keys["omega_final_rad_s"], w0 * np.exp(-t[-1] / tau), rtol=1e-12)
