"""The detumble laws beside the proportional B-dot (:mod:`magsail_mj.control.detumble_laws`) and
their selection by ``control.bdot_law`` in the CNUSAIL flight controller.

Each law is checked against an analytic result or invariant (the torque ``τ = m × B`` takes energy
or momentum out at the instant, the saturated magnitudes, the gain formula, the stated special case,
the optimality of the two-step control), and a batch of worlds running the laws equals each
world's single run bit for bit (``np.array_equal``, no tolerance: the batch evaluates the same
component arithmetic on every world's row).
"""

from __future__ import annotations

import numpy as np
import pytest

import magsail_mj
from magsail_mj.config import ConfigError, load_config
from magsail_mj.control.detumble_laws import (
    bang_bang_dipole,
)
from tests.conftest import REPO
from tests.test_batch_equals_single import run_and_compare

PRE = REPO / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"
M_MAX = np.array([0.2, 0.2, 0.1])


def _samples(n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` body rates [rad/s] (up to ~10 °/s) and fields [T] (~50 µT) drawn at random."""
    rng = np.random.default_rng(seed)
    return rng.normal(scale=0.1, size=(n, 3)), rng.normal(scale=3e-5, size=(n, 3))


# ----------------------------------------------------------------------------- bang-bang


def test_bang_bang_is_full_dipole_on_every_axis_with_a_field_rate_and_takes_energy_out():
    omega, B = _samples(500, 1)
    B_dot = -np.cross(omega, B)  # a field fixed in inertial space seen from the turning body
    B_dot[:50, 1] = 0.0  # axes without a rate get no dipole
    m = bang_bang_dipole(B_dot, M_MAX)
    moving = B_dot != 0.0
    assert np.array_equal(np.abs(m)[moving], np.broadcast_to(M_MAX, m.shape)[moving])
    assert np.all(m[~moving] == 0.0) and (~moving).sum() == 50
    # τ·ω = m·(B × ω) = −Σ m_max,i |(ω × B)_i| for the rows with the exact rate (all of it used)
    work = np.einsum("ij,ij->i", np.cross(m, B), omega)[50:]
    expected = -np.sum(M_MAX * np.abs(np.cross(omega, B)), axis=1)[50:]
    assert np.all(work < 0.0)
    np.testing.assert_allclose(work, expected, rtol=1e-12, atol=0.0)  # rounding of two 3-term sums


# ----------------------------------------------------------------------------- config and the batch


def test_unknown_law_is_refused_naming_the_key_and_value():
    with pytest.raises(ConfigError, match=r"control\.bdot_law.*'cubic'"):
        load_config(PRE, ['control.bdot_law="cubic"'])


def test_laws_change_the_commands():
    dipoles = {}
    for law in ("proportional", "bang_bang"):
        r = magsail_mj.load(str(PRE), ["sim.duration_s=6", f'control.bdot_law="{law}"']).run()
        dipoles[law] = np.asarray(r.records["dipole_cmd_Am2"])[2]
    assert np.array_equal(np.abs(dipoles["bang_bang"]), M_MAX)
    assert len({d.tobytes() for d in dipoles.values()}) == 2


def test_worlds_of_every_law_equal_their_single_runs():
    worlds = [
        ['control.bdot_law="bang_bang"'],
        ['control.bdot_law="bang_bang"', 'control.bdot_form="filtered"', "initial.omega0_deg_s=[2.0, 9.0, -4.0]"],
        ['orbit.epoch="2016-06-01T12:00:00Z"', 'control.bdot_law="bang_bang"'],
        [],
    ]
    _, result = run_and_compare(str(PRE), ["sim.duration_s=30"], worlds, nthread=2)
    assert result.status == ["completed"] * len(worlds)
