"""Truss tasks: one task class per scenario kind.

Checks (each can fail): a config of every kind builds its own class; the orbital metrics work on
plain arrays (an exponential decay of the rates against its analytic threshold time). That the
registered kinds are the schema's and the package layout are checked for every concept by
tests/test_layout.py.
"""

from __future__ import annotations

import numpy as np
import pytest

from magsail_mj.concepts.truss_magnetorquer import tasks as tt
from magsail_mj.concepts.truss_magnetorquer.orbital import detumble_keys
from tests.conftest import REPO
from tests.tasks_shared import built_kind

KIND_CONFIGS = {
    "cantilever": ("magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml", tt.CantileverTask),
    "free": ("magsail_mj/concepts/truss_magnetorquer/configs/libration.toml", tt.FreeTask),
    "dist_vs_central": (
        "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml",
        tt.DistVsCentralTask,
    ),
    "detumble": ("magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", tt.DetumbleTask),
    "slew": ("magsail_mj/concepts/truss_magnetorquer/configs/slew_i.toml", tt.SlewTask),
}


@pytest.mark.parametrize("kind", sorted(KIND_CONFIGS))
def test_every_kind_builds_its_own_class(kind):
    path, cls = KIND_CONFIGS[kind]
    built_kind(REPO / path, kind=kind, cls=cls, base=tt.TrussScenario)


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
