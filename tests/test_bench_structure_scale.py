"""``scripts/bench_structure_scale.py``'s measuring parts: the fitted exponent, MuJoCo's two compile
phases called again through ``ctypes`` (their signatures are MuJoCo 4.0.0's; a changed one must
fail here, not mis-time), and the attach timer of the build."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from magsail_mj.lattice import mjcf as lattice_mjcf
from magsail_mj.structure.generators import square_plate_lattice
from magsail_mj.structure.mjcf import build_structure_spec
from tests.conftest import load_file_module

bench = load_file_module("scripts", "bench_structure_scale")


def _plate_spec(units: int) -> mujoco.MjSpec:
    plate = square_plate_lattice(units=units, side_m=10.0, EA_N=1.0e5, total_mass_kg=10.0, zeta_strut=0.01)
    return build_structure_spec(plate, timestep_s=1e-3, integrator="Euler", strut_elements="flex")


@pytest.mark.parametrize("power", [1.0, 1.5, 2.0])
def test_fitted_exponent_recovers_a_power_law(power: float) -> None:
    """``t = 3e-6 n^p`` at three sizes gives ``p`` (to 1e-12: a least-squares line through three
    exact points of a line, in floating point), and a single size or a zero time gives None."""
    nodes = [2048, 6050, 20000]
    seconds = [3e-6 * n**power for n in nodes]
    assert bench.fitted_exponent(nodes, seconds) == pytest.approx(power, abs=1e-12)
    assert bench.fitted_exponent([2048, 2048], [1.0, 2.0]) is None
    assert bench.fitted_exponent(nodes, [0.0, 1.0, 2.0]) is None


def test_mujoco_phases_are_called_on_the_compiled_arrays() -> None:
    """``mj_makeBSparse`` called again rebuilds the compiled model's ``B_colind`` (checked inside:
    an argument in the wrong place would give another array) and ``mj_validateReferences`` finds
    the model valid; both take time."""
    model = _plate_spec(3).compile()
    seconds = bench.time_mujoco_phases(model)
    assert set(seconds) == set(bench.MUJOCO_PHASES)
    assert all(t > 0 for t in seconds.values())


def test_mujoco_phases_refuse_a_b_matrix_that_differs() -> None:
    """A model whose ``B_colind`` was altered after the compile makes the rebuilt ``B`` differ, and
    the timer stops with an error naming the phase rather than report a time."""
    model = _plate_spec(3).compile()
    model.B_colind[-1] += 1
    with pytest.raises(SystemExit, match="mj_makeBSparse"):
        bench.time_mujoco_phases(model)


def test_attach_timer_sees_every_attach_and_restores_the_method(monkeypatch) -> None:
    """Forced through scratch specs, the build's attaches are all timed (groups into the returned
    spec, chunks into their groups: together one fewer than the chunks plus the groups), and the
    method is MuJoCo's again after the block."""
    monkeypatch.setattr(lattice_mjcf, "SPEC_DIRECT_BODIES", 0)
    monkeypatch.setattr(lattice_mjcf, "SPEC_CHUNK_BODIES", 4)
    attach = mujoco.MjSpec.attach
    with bench._timed_attaches() as calls:
        spec = _plate_spec(3)  # 32 particles: 8 chunks, groups of isqrt(8) = 2
    assert mujoco.MjSpec.attach is attach
    into_spec = [dt for receiver, dt in calls if receiver is spec]
    assert len(into_spec) == 4 and len(calls) == 8
    assert all(dt >= 0 for _, dt in calls)
    assert np.isfinite(sum(dt for _, dt in calls))
