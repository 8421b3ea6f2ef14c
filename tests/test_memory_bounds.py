"""Memory stays bounded after a blow-up, and inside the estimate ``validate`` prints.

A truss whose time step is far too long blows up to 10¹⁰ m within a few records; its
post-processing once tried to allocate 105 GiB (a surface-angle grid of 0.25 m over the blown-up
extent) and the summary then held only ``postprocess_error``. Now the grid has at most
``MAX_GRID_SIDE`` samples a side, the fine time grids of the rigid reference are walked in
blocks, and post-processing of a completed and of a failed run both stay below
:func:`magsail_mj.resources.postprocess_bytes` (tracemalloc), with the failure's named metrics in
the summary.
"""

from __future__ import annotations

import math
import time
import tracemalloc
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

import magsail_mj
from magsail_mj import records as records_module
from magsail_mj import resources
from magsail_mj.concepts.truss_magnetorquer import metrics
from magsail_mj.concepts.truss_magnetorquer.surface_angle import (
    MAX_GRID_SIDE,
    local_surface_angle,
    surface_angle_bytes,
)
from magsail_mj.config import ConfigError
from magsail_mj.control.profiles import torque_profile
from magsail_mj.sweep import load_sweep
from magsail_mj.sweep.design import DESIGN_RUN_BYTES, MAX_RUNS, design_points, design_size
from tests.conftest import REPO

DETUMBLE = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml"


def _traced(fn):
    """``(fn(), peak traced bytes)``."""
    tracemalloc.start()
    try:
        out = fn()
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def _plate(N: int, side: float) -> np.ndarray:
    a = side / (N - 1)
    j, i = np.meshgrid(np.arange(N), np.arange(N), indexing="ij")
    return np.stack([i * a - side / 2, j * a - side / 2, 0.3 * np.sin(i * a / 7)], -1).reshape(-1, 3)


@pytest.mark.parametrize("method", ["cubic", "spline"])
def test_surface_angle_grid_is_bounded_whatever_the_extent(method):
    """A top layer blown up to 10⁷ m gets at most MAX_GRID_SIDE samples a side (a widened spacing,
    reported) and stays below surface_angle_bytes; a 75 m plate keeps the 0.25 m grid."""
    R = np.eye(3)
    normal = local_surface_angle(_plate(10, 30.0), R, method=method)
    assert normal.spacing_m == 0.25 and max(normal.alpha.shape) <= 121
    rng = np.random.default_rng(0)
    huge = _plate(10, 75.0) * 1e7 + rng.normal(scale=1e6, size=(100, 3))
    res, peak = _traced(lambda: local_surface_angle(huge, R, method=method))
    assert max(res.alpha.shape) <= MAX_GRID_SIDE and res.spacing_m > 1e5
    assert np.isfinite(res.median) and np.isfinite(res.max)
    assert peak < surface_angle_bytes(100), (peak, surface_angle_bytes(100))
    assert resources.SURFACE_ANGLE_MAX_BYTES + 1024.0 * 100 == surface_angle_bytes(100)
    assert resources.RECORDS_BLOCK_BYTES == records_module.BLOCK_BYTES


def test_fine_time_grids_are_walked_in_blocks(monkeypatch):
    """The rigid reference (0.01 s grid) and the commanded impulse (one point per step) of a
    5·10⁴ s run once held 5·10⁶-point arrays (40 MB each); blocked, they stay under 16 MiB, and
    with blocks of 7 points they equal the whole-grid formulas bit for bit."""
    kw = dict(tau_max=0.1, t_end=1200.0, t_v=100.0, inertia=4e4)
    t_long = np.linspace(0.0, 5e4, 21)
    _, peak = _traced(lambda: metrics.rigid_response("versine", t_long, **kw))
    assert peak < 16 * 2**20, peak
    profile = SimpleNamespace(kind="bang_bang_off", tau_max_Nm=0.1, t_end_s=1200.0, t_v_s=None)
    _, peak = _traced(lambda: metrics.commanded_impulse_Nms(profile, t_long, timestep_s=0.01))
    assert peak < 16 * 2**20, peak

    monkeypatch.setattr(metrics, "FINE_BLOCK", 7)
    t = np.arange(0.0, 30.0 + 1e-9, 0.7)
    for kind in ("versine", "bang_bang_off"):
        tf = np.arange(0.0, float(np.max(t)) + 0.01, 0.01)
        tau = torque_profile(kind, tf, tau_max=0.1, t_end=24.0, t_v=2.0)
        w = cumulative_trapezoid(tau / 4e4, tf, initial=0.0)
        phi = cumulative_trapezoid(w, tf, initial=0.0)
        got = metrics.rigid_response(kind, t, tau_max=0.1, t_end=24.0, t_v=2.0, inertia=4e4)
        np.testing.assert_array_equal(got[0], np.interp(t, tf, phi))
        np.testing.assert_array_equal(got[1], np.interp(t, tf, w))
        p = SimpleNamespace(kind=kind, tau_max_Nm=0.1, t_end_s=24.0, t_v_s=2.0)
        tk = np.arange(int(round(30.0 / 0.05)) + 1) * 0.05
        tau_k = np.asarray(torque_profile(kind, tk + 0.025, tau_max=0.1, t_end=24.0, t_v=2.0))
        cum = np.concatenate([[0.0], np.cumsum(tau_k[:-1] * 0.05)])
        got = metrics.commanded_impulse_Nms(p, t, timestep_s=0.05, load_timing="midpoint")
        np.testing.assert_array_equal(got, np.interp(t, tk, cum))


@pytest.mark.parametrize(
    ("overrides", "fails"),
    [
        (["lattice.units=3", "sim.timestep_s=5"], False),  # 61 records of a 32-node truss: completes
        (["lattice.units=6", "sim.timestep_s=10"], True),  # blows up to 10¹⁰ m within 8 records
    ],
)
def test_post_processing_stays_below_its_estimate_and_keeps_the_failure_metrics(overrides, fails):
    """The issue's reproducer on a small lattice (detumble, record every step): post-processing of
    the run, completed or blown up, peaks below ``postprocess_bytes`` of its config; a failed run's
    summary has its largest surface deviation, largest strain, time and cause of failure."""
    sim = magsail_mj.load(DETUMBLE, [*overrides, "sim.duration_s=300", "sim.record_every=1"])
    result = sim.run()
    (summary, _), peak = _traced(lambda: sim.scenario.postprocess(result))
    bound = resources.postprocess_bytes(sim.scenario.cfg)
    assert peak < bound, (resources.format_bytes(peak), resources.format_bytes(bound))
    assert "postprocess_error" not in summary
    assert summary["failed"] is fails and summary["status"] == ("structure_failed" if fails else "completed")
    for key in ("surface_sd_max_m", "strut_strain_max", "surface_angle_max_rad"):
        assert math.isfinite(summary[key]), key
    if fails:
        assert summary["strut_strain_max"] > sim.scenario.cfg.sim.max_strain
        assert math.isfinite(summary["t_failed_s"]) and "exceeds sim.max_strain" in summary["status_message"]
        assert summary["surface_angle_spacing_m"] > 0.25  # the grid was widened, and says so
    else:
        assert summary["surface_angle_spacing_m"] == 0.25


def _sweep_file(tmp_path, body: str):
    path = tmp_path / "design.toml"
    path.write_text(
        f'name = "design"\nconfig = "{REPO / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml"}"\n{body}'
    )
    return path


def test_huge_sweep_designs_are_refused_before_expansion(tmp_path):
    """A 10⁶-point grid (once still validating after 120 s) and samples = 10⁸ (once a MemoryError
    after 112 s) are refused at once, naming the keys and the count; so is a design within
    MAX_RUNS whose bookkeeping is above the memory limit."""
    values = ", ".join(str(i) for i in range(100))
    grid = _sweep_file(tmp_path, f'[grid]\n"sim.seed" = [{values}]\n"mass.a" = [{values}]\n"mass.b" = [{values}]\n')
    t0 = time.perf_counter()
    with pytest.raises(ConfigError, match=r"grid\.sim\.seed \(100\) × grid\.mass\.a \(100\) × .*1000000 runs") as err:
        load_sweep(grid)
    assert f"limit of {MAX_RUNS} runs" in str(err.value)
    mc = _sweep_file(tmp_path, '[monte_carlo]\nsamples = 100000000\n"sim.seed" = { dist = "choice", values = [1] }\n')
    with pytest.raises(ConfigError, match=r"monte_carlo\.samples \(100000000\).*100000000 runs"):
        load_sweep(mc)
    both = {"grid": {"sim": {"seed": list(range(400))}}, "monte_carlo": {"samples": 250, "seed": 0}}
    assert design_size(both) == (100_000, "grid.sim.seed (400) × monte_carlo.samples (250)")
    with (
        resources.memory_limit(int(999 * DESIGN_RUN_BYTES)),
        pytest.raises(resources.MemoryLimitError, match=r"monte_carlo.samples \(1000\) = 1000 runs"),
    ):
        design_points({"monte_carlo": {"samples": 1000, "x": {"dist": "uniform", "low": 0, "high": 1}}})
    assert time.perf_counter() - t0 < 2.0
    assert len(design_points({"monte_carlo": {"samples": 3, "x": {"dist": "uniform", "low": 0, "high": 1}}})) == 3
