"""Scaling law of the rod mass fraction (Robb et al. 2022a, Sec. 4.1) and its script.

Tolerances: closed forms are a few flops; comparisons at 1e-12 relative. The angle sweep for the
maximum of Eq. 14 uses 20 001 samples of [0, π/2], which resolves the peak to ~1e-8 relative.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.analysis.scaling import (
    ScalingInputs,
    actuator_torque_max,
    dipole_field_magnitude,
    gravity_gradient_torque,
    gravity_gradient_torque_max,
    load_scaling_inputs,
    plate_inertia,
    rod_mass_fraction,
    scaling_report,
    scaling_tables,
    side_at_rod_mass_fraction,
)
from magsail_mj.config import ConfigError
from magsail_mj.environment.constants import B0_DIPOLE, MU_EARTH, R_E_TRUSS
from tests.conftest import load_file_module

REPO = Path(__file__).resolve().parents[1]


@settings(max_examples=100, deadline=None)
@given(d=st.floats(0.5, 500.0), kappa=st.floats(1.0, 1000.0), M=st.floats(1.0, 1e5), alt_km=st.floats(200.0, 40_000.0))
def test_closed_form_is_the_ratio_of_the_two_torques(d, kappa, M, alt_km):
    """λ_f = T_grav,max / (κ M B): the same at every radius and mass (Sec. 4.1)."""
    r = R_E_TRUSS + alt_km * 1e3
    ratio = gravity_gradient_torque_max(M, d, r) / (kappa * M * dipole_field_magnitude(r))
    assert rod_mass_fraction(d, kappa) == pytest.approx(ratio, rel=1e-12)
    # With M_τ = λ_f M the actuator torque matches the peak gravity-gradient torque exactly.
    lam = rod_mass_fraction(d, kappa)
    B = dipole_field_magnitude(r)
    assert actuator_torque_max(kappa, lam * M, B) == pytest.approx(gravity_gradient_torque_max(M, d, r), rel=1e-12)


def test_proportional_to_d_squared_and_inverse_kappa():
    d = np.array([1.0, 2.0, 10.0, 75.0, 200.0])
    lam = rod_mass_fraction(d, 100.0)
    np.testing.assert_allclose(lam / lam[0], d**2, rtol=1e-12)
    k = np.array([10.0, 50.0, 100.0, 200.0])
    lk = rod_mass_fraction(75.0, k)
    np.testing.assert_allclose(lk * k, lk[0] * k[0], rtol=1e-12)
    grid = rod_mass_fraction(d[None, :], k[:, None])
    assert grid.shape == (4, 5)
    np.testing.assert_allclose(side_at_rod_mass_fraction(rod_mass_fraction(d, 50.0), 50.0), d, rtol=1e-12)
    expect = MU_EARTH * 75.0**2 / (8 * B0_DIPOLE * R_E_TRUSS**3 * 100.0)
    assert rod_mass_fraction(75.0, 100.0) == pytest.approx(expect, rel=1e-15)


@pytest.mark.parametrize("alt_km", [400.0, 800.0, 20_000.0])
def test_eq14_thin_plate_at_45_degrees_is_the_maximum(alt_km):
    M, d = 200.0, 75.0
    r = R_E_TRUSS + alt_km * 1e3
    I = plate_inertia(M, d)
    np.testing.assert_allclose(np.diag(I), [M * d * d / 12, M * d * d / 12, M * d * d / 6])
    s = np.sqrt(0.5)
    T45 = gravity_gradient_torque(r * np.array([s, 0.0, s]), I)
    Tmax = gravity_gradient_torque_max(M, d, r)
    assert np.linalg.norm(T45) == pytest.approx(Tmax, rel=1e-12)
    assert Tmax == pytest.approx(MU_EARTH * M * d**2 / (8 * r**3), rel=1e-15)
    # It is the maximum over the angle between the local vertical and the plate normal.
    th = np.linspace(0.0, np.pi / 2, 20_001)
    rb = r * np.column_stack([np.sin(th), np.zeros_like(th), np.cos(th)])
    Tn = np.linalg.norm(gravity_gradient_torque(rb, I), axis=1)
    assert Tn.max() == pytest.approx(Tmax, rel=1e-8)
    assert th[np.argmax(Tn)] == pytest.approx(np.pi / 4, abs=1e-4)
    # Any rotation about the normal gives the same magnitude (I1 = I2).
    rb2 = r * np.array([s * np.cos(0.7), s * np.sin(0.7), s])
    assert np.linalg.norm(gravity_gradient_torque(rb2, I)) == pytest.approx(Tmax, rel=1e-12)


def test_eq14_matches_component_formula_for_a_general_inertia():
    rng = np.random.default_rng(5)
    A = rng.normal(size=(3, 3))
    I = A @ A.T + 3 * np.eye(3)
    rb = rng.normal(size=(6, 3)) * 7e6
    T = gravity_gradient_torque(rb, I)
    for k in range(6):
        r = np.linalg.norm(rb[k])
        np.testing.assert_allclose(T[k], 3 * MU_EARTH / r**5 * np.cross(rb[k], I @ rb[k]), rtol=1e-13)


def test_scaling_report_keys_and_values():
    rep = scaling_report(75.0, 100.0)
    json.dumps(rep)
    for key in ("lambda_f", "d_at_lambda_f_1_m", "T_grav_max_Nm", "T_ac_max_Nm", "B_dipole_T"):
        assert isinstance(rep[key], float)
    r = R_E_TRUSS + 800e3
    B = B0_DIPOLE * (R_E_TRUSS / r) ** 3
    assert rep["radius_m"] == r
    assert rep["B_dipole_T"] == pytest.approx(B, rel=1e-15)
    assert rep["T_grav_max_Nm"] == pytest.approx(MU_EARTH * 200 * 75**2 / (8 * r**3), rel=1e-15)
    assert rep["T_ac_max_Nm"] == pytest.approx(100 * 100 * B, rel=1e-15)
    assert rep["lambda_f"] == pytest.approx(rod_mass_fraction(75.0, 100.0), rel=1e-15)
    assert rep["d_at_lambda_f_1_m"] == pytest.approx(side_at_rod_mass_fraction(1.0, 100.0), rel=1e-15)
    assert rep["authority_margin"] == pytest.approx(rep["T_ac_max_Nm"] / rep["T_grav_max_Nm"], rel=1e-12)
    many = scaling_report([75.0, 100.0], [10.0, 50.0, 100.0])
    assert np.shape(many["lambda_f"]) == (3, 2)
    assert len(many["d_at_lambda_f_1_m"]) == 3 and len(many["T_grav_max_Nm"]) == 2
    assert many["lambda_f"][2][0] == pytest.approx(rep["lambda_f"], rel=1e-15)
    with pytest.raises(ValueError, match="side_m"):
        scaling_report(-1.0, 100.0)
    with pytest.raises(ValueError, match="kappa"):
        scaling_report(75.0, 0.0)
    with pytest.raises(ValueError, match="rod_mass_kg"):
        scaling_report(75.0, 100.0, rod_mass_kg=300.0)


def test_inputs_validation_and_toml(tmp_path):
    p = tmp_path / "scaling.toml"
    p.write_text('concept = "truss_magnetorquer"\n[scaling]\nkappas_Am2_kg = [20.0, 40.0]\nside_max_m = 150.0\n')
    inp = load_scaling_inputs(p)
    assert inp.kappas_Am2_kg == [20.0, 40.0] and inp.side_max_m == 150.0
    p.write_text("[scaling]\nside_max_m = -3.0\n")
    with pytest.raises(ConfigError, match="scaling.side_max_m"):
        load_scaling_inputs(p)
    p.write_text("[scaling]\nkappa = 3.0\n")
    with pytest.raises(ConfigError, match="scaling.kappa"):
        load_scaling_inputs(p)
    tab = scaling_tables(ScalingInputs())
    assert set(tab["lambda_f"]) == {"kappa=10", "kappa=50", "kappa=100", "kappa=200"}
    assert tab["lambda_f"]["kappa=100"]["d=75"] == pytest.approx(rod_mass_fraction(75.0, 100.0), rel=1e-15)


def test_scaling_script_writes_plot_and_json(tmp_path, capsys):
    mod = load_file_module("scripts", "scaling_magnetorquer")
    assert mod.main(["--out", str(tmp_path)]) == 0
    printed = json.loads(capsys.readouterr().out)
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert printed == saved
    assert (tmp_path / "lambda_f_vs_side.png").stat().st_size > 10_000
    assert "| 100 |" in (tmp_path / "table.md").read_text()


def test_cli_prints_one_json_object(capsys):
    import json

    from magsail_mj.cli import main

    assert main(["scaling", "magnetorquer", "--side-m", "75", "--kappa", "100"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["side_m"] == 75.0 and 0 < report["lambda_f"] < 1
    assert main(["scaling", "magnetorquer", "--side-m", "-1", "--kappa", "100"]) == 2
    assert "error: --side-m" in capsys.readouterr().err
