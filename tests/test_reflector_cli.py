"""``magsail torque coil`` (Robb et al. 2020, Eqs. 1–4): one JSON object on stdout, bad options exit 2."""

from __future__ import annotations

import json

import pytest

from magsail_mj.cli import main
from tests.conftest import COIL_REPORT_KEYS


def test_torque_coil_prints_capability_and_torque_vectors(capsys):
    rc = main(["torque", "coil", "--side-m", "20", "--segment-m", "1", "--current-a", "10", "--field-t", "30e-6"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["T_max_ycoil_Nm"] == pytest.approx(0.75 * 20 * 10 * 10 * 30e-6)
    assert out["m_max_Am2"] == pytest.approx(out["T_max_ycoil_Nm"] / 30e-6)
    assert set(COIL_REPORT_KEYS) <= set(out)
    for path in ("ycoil", "xcoil", "zloop"):
        for ax in "xyz":
            assert len(out["paths"][path][f"T_B{ax}_Nm"]) == 3


def test_torque_coil_options_depth_pitch_rows(capsys):
    assert main(["torque", "coil", "--side-m", "20", "--depth-m", "2", "--pitch-cells", "1", "--rows", "8"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["depth_m"] == 2.0 and out["pitch_cells"] == 1 and out["rows"] == 8
    assert out["T_max_ycoil_Nm"] == pytest.approx(0.75 * 8 * 20 * 10 * 1 * 2 * 30e-6)


@pytest.mark.parametrize(
    "argv,option",
    [
        (["--side-m", "20.5"], "--side-m"),
        (["--pitch-cells", "0"], "--pitch-cells"),
        (["--current-a", "-1"], "--current-a"),
        (["--rows", "0"], "--rows"),
    ],
)
def test_torque_coil_bad_option_exits_2_and_names_it(capsys, argv, option):
    rc = main(["torque", "coil", *argv])
    assert rc == 2
    err = capsys.readouterr().err
    assert option in err


def test_torque_coil_non_number_exits_2_naming_the_option(capsys):
    assert main(["torque", "coil", "--field-t", "abc"]) == 2
    assert capsys.readouterr().err.startswith("error: --field-t: expected a finite number > 0, got 'abc'")


@pytest.mark.parametrize("value", ["nan", "inf", "-inf", "0", "-1e-300"])
def test_torque_coil_non_finite_or_non_positive_exits_2(capsys, value):
    assert main(["torque", "coil", f"--segment-m={value}"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err.startswith("error: --segment-m:") and value in cap.err


def test_torque_coil_huge_input_is_refused_before_allocating(capsys):
    """1e6 m of 1 mm segments (1e9 cells per side, ~1e18 path nodes) is refused at once with the
    estimate and the limit; the defaults pass under a 1 GiB limit."""
    assert main(["torque", "coil", "--side-m", "1e6", "--segment-m", "1e-3"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: coil paths of side_m = 1000000.0 m") and "needs about" in err and "limit of" in err
    assert main(["--memory-limit", "1G", "torque", "coil"]) == 0
    assert main(["--memory-limit", "1M", "torque", "coil"]) == 2
    assert "limit of 1 MiB" in capsys.readouterr().err
