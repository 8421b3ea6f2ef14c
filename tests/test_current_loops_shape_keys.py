"""Current-loops S4/S5 shape keys: stretch and half-swing, strain-energy peaks, saturation
intervals, attitude-error swings, dominant modes over the run and its closing window, the share of
the first ten elastic modes (magsail_mj.concepts.current_loops.metrics), on synthetic series with
known answers, a lattice deformed along known modes, and one short sweep and slew run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from magsail_mj.concepts.current_loops.metrics import (
    dominant_modes,
    error_swing_keys,
    first_modes_share_keys,
    modal_energy_profile,
    modal_energy_stats,
    modal_energy_summary,
    modal_strain_energies,
    saturation_intervals,
    saturation_keys,
    strain_energy_peaks,
    stretch_keys,
)
from magsail_mj.config import load_config
from magsail_mj.estimation.attitude import so3_exp
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.modes import lattice_modes

MODELS = Path(__file__).resolve().parents[1] / "magsail_mj" / "concepts" / "current_loops" / "configs"


# ------------------------------------------------------------------ synthetic series
def test_stretch_sign_and_half_swing():
    """s_x = −0.5 (1 − e^(−t/50)) + 0.2 sin(2π t/80): compressed; late (t ≥ 500 s) it swings
    ±0.2 m about ≈ −0.5 m; s_y a pure stretch ramp to +0.3 m."""
    t = np.linspace(0.0, 1000.0, 100_001)
    sx = -0.5 * (1 - np.exp(-t / 50)) + 0.2 * np.sin(2 * np.pi * t / 80)
    sy = 0.3 * t / t[-1]
    k = stretch_keys(t, {"x": sx, "y": sy})
    assert k["stretch_x_sign"] == -1 and k["stretch_y_sign"] == 1
    assert k["stretch_x_extremum_m"] == pytest.approx(-0.7, abs=1e-6)
    assert k["stretch_x_half_swing_m"] == pytest.approx(0.2, abs=3e-5)  # the decay left: 0.5 e^-10
    # mean over 500–1000 s: −0.5 + 0.2 · 80/(2π 500) (cos 12.5π − cos 25π) = −0.5 + 0.2 · 80/(1000π)
    assert k["stretch_x_late_mean_m"] == pytest.approx(-0.5 + 0.2 * 80 / (1000 * np.pi), abs=3e-5)
    assert k["stretch_y_extremum_m"] == pytest.approx(0.3, abs=1e-12)
    assert k["stretch_y_half_swing_m"] == pytest.approx(0.075, abs=1e-12)
    assert stretch_keys(t, {"x": 0 * t})["stretch_x_sign"] == 0
    with pytest.raises(ValueError, match="late_fraction"):
        stretch_keys(t, {"x": sx}, late_fraction=1.0)


def test_strain_energy_peaks_once_late_and_twice():
    t = np.linspace(0.0, 4000.0, 4001)
    one = np.exp(-(((t - 3000.0) / 300.0) ** 2)) + 0.05 * np.sin(2 * np.pi * t / 50) ** 2  # ripple below 20 %
    k = strain_energy_peaks(t, one)
    assert k["strain_energy_peak_count"] == 1
    assert k["strain_energy_peak_times_s"] == [pytest.approx(3000.0, abs=15.0)]
    assert k["t_strain_energy_max_frac"] == pytest.approx(0.75, abs=5e-3)
    two = np.exp(-(((t - 300.0) / 100.0) ** 2)) + 0.6 * np.exp(-(((t - 2500.0) / 200.0) ** 2))
    k = strain_energy_peaks(t, two)
    assert k["strain_energy_peak_count"] == 2
    assert k["strain_energy_peak_times_s"] == [300.0, 2500.0]
    rising = t / t[-1]  # still rising at the end: the last sample is the one peak
    assert strain_energy_peaks(t, rising)["strain_energy_peak_times_s"] == [4000.0]
    assert strain_energy_peaks(t, 0 * t)["strain_energy_peak_count"] == 0


def test_saturation_intervals_and_keys():
    t = np.arange(10.0) * 2.0  # 0, 2, …, 18 s
    sat = np.zeros((10, 3), bool)
    sat[0:3, 0] = True  # 0–6 s on x
    sat[2:4, 2] = True  # 4–8 s on z (joins the x interval)
    sat[6, 1] = True  # 12–14 s on y
    sat[8:, 0] = True  # 16 s to the end
    iv = saturation_intervals(t, np.any(sat, axis=1))
    assert iv.tolist() == [[0.0, 8.0], [12.0, 14.0], [16.0, 18.0]]
    k = saturation_keys(t, sat, t_peak_s=13.0)
    assert k["saturation_interval_count"] == 3
    assert k["saturated_time_s"] == 12.0
    assert k["saturation_first_start_s"] == 0.0 and k["saturation_last_end_s"] == 18.0
    assert k["saturation_interval_count_per_axis"] == [2, 1, 1]
    assert k["saturation_interval_at_strain_energy_max"] == 1
    assert saturation_keys(t, sat, t_peak_s=10.0)["saturation_interval_at_strain_energy_max"] is None
    none = saturation_keys(t, np.zeros((10, 3), bool))
    assert none["saturation_interval_count"] == 0 and none["saturation_first_start_s"] is None


def test_error_swings_of_a_planar_damped_swing():
    """θ(t) = |A e^(−σt) sin(ω_d t)| (a planar swing through the target, within 5° from the start):
    minima (cusps) at t_k = kπ/ω_d, maxima where tan(ω_d t) = ω_d/σ, t_k = (kπ + atan(ω_d/σ))/ω_d;
    all of them to within half a record (0.5 s), the values to the sampled curve's."""
    t = np.arange(0.0, 3101.0, 1.0)
    wd, sig, A = 2 * np.pi / 400.0, 1 / 2000.0, np.radians(4.0)
    err = np.abs(A * np.exp(-sig * t) * np.sin(wd * t))
    k = error_swing_keys(t, err)
    t_min = np.pi * np.arange(1, 16) / wd
    t_max = (np.pi * np.arange(0, 16) + np.arctan(wd / sig)) / wd
    expect = np.sort(np.concatenate([t_min, t_max]))
    expect = expect[expect < 3050.0]  # the last maximum (3098 s) has no fall after it to count
    assert k["error_extrema_count"] == expect.size == 30
    assert np.allclose(k["error_extrema_t_s"], expect, atol=0.5)
    exact = np.degrees(np.abs(A * np.exp(-sig * expect) * np.sin(wd * expect)))
    assert np.allclose(k["error_extrema_deg"], exact, atol=np.degrees(A) * wd * 0.5**2)
    assert np.allclose(k["error_half_swing_s"], np.diff(k["error_extrema_t_s"]))
    assert k["error_half_swing_mean_s"] == pytest.approx((expect[-1] - expect[0]) / 29, abs=1.0 / 29)


def test_error_swings_count_from_5deg_and_ignore_ripple():
    """Wiggles above 5° before t_0 = 500 s are not counted; after it θ = c + A e^(−στ) cos(ω_d τ),
    τ = t − t_0, whose extrema lie at τ_k = (kπ − atan(σ/ω_d))/ω_d, k = 1 … 15; a 0.01° ripple at 7 s
    (below 2 % of the 2.9° largest swing) moves them by at most ~15 s and adds none, while a
    threshold of 1e-4 of the swing counts the ripple as extrema."""
    t = np.arange(0.0, 3601.0, 1.0)
    t0, c, A = 500.0, 3.0, 1.5
    wd, sig = 2 * np.pi / 400.0, 1 / 2000.0
    tau = t - t0
    deg = np.where(t < t0, 10.0 + 2.0 * np.sin(2 * np.pi * t / 100.0), c + A * np.exp(-sig * tau) * np.cos(wd * tau))
    ripple = 0.01 * np.sin(2 * np.pi * t / 7.0)
    tau_k = (np.pi * np.arange(1, 16) - np.arctan(sig / wd)) / wd
    value_k = c + (-1.0) ** np.arange(1, 16) * A * np.exp(-sig * tau_k) * wd / np.hypot(sig, wd)
    clean = error_swing_keys(t, np.radians(deg))
    assert clean["error_extrema_count"] == 15
    assert np.allclose(clean["error_extrema_t_s"], t0 + tau_k, atol=0.5)
    assert np.allclose(clean["error_extrema_deg"], value_k, atol=1e-4)
    noisy = error_swing_keys(t, np.radians(deg + ripple))
    assert noisy["error_extrema_count"] == 15
    assert np.allclose(noisy["error_extrema_t_s"], t0 + tau_k, atol=20.0)
    assert noisy["error_half_swing_mean_s"] == pytest.approx(200.0, abs=3.0)
    assert error_swing_keys(t, np.radians(deg + ripple), prominence_fraction=1e-4)["error_extrema_count"] > 100
    never = error_swing_keys(t, np.radians(6.0 + 0 * t))
    assert never["error_extrema_count"] == 0 and never["error_extrema_t_s"] == []
    assert never["error_half_swing_mean_s"] is None
    with pytest.raises(ValueError, match="prominence_fraction"):
        error_swing_keys(t, np.radians(deg), prominence_fraction=0.0)


def _modal_energies() -> tuple[np.ndarray, np.ndarray]:
    """Six records 1000 s apart, 12 elastic modes (columns 0-based): none at 0 s; early energy in
    mode 12 (1000 s); modes 1 and 11 (2000 s); the last 2000 s (3000–5000 s) modes 2, 5, 11, 12."""
    t = np.arange(6) * 1000.0
    E = np.zeros((6, 12))
    E[1, 11] = 100.0  # share of modes 1–10: 0
    E[2, [0, 10]] = [3.0, 1.0]  # 0.75
    E[3, [1, 11]] = [2.0, 2.0]  # 0.5
    E[4, [1, 10]] = [3.0, 1.0]  # 0.75
    E[5, 4] = 1.5  # 1
    return t, E


def test_modal_energy_window_and_first_ten_share_are_exact():
    t, E = _modal_energies()
    s = modal_energy_stats(t, [E], index=3)
    assert np.array_equal(s.at, E[3]) and np.allclose(s.mean, E.mean(axis=0), rtol=0, atol=1e-15)
    # window t ≥ 5000 − 2000 s: records 3, 4, 5 only; the early 100 J in mode 12 is left out
    assert np.allclose(s.window_mean, E[3:].mean(axis=0), rtol=0, atol=1e-15)
    omega = np.arange(1.0, 13.0)
    win = dominant_modes(omega, s.window_mean, prefix="w")
    assert win["w_mode"] == [2, 12, 5]
    assert win["w_share"] == pytest.approx([10 / 19, 4 / 19, 3 / 19], abs=1e-15)
    assert dominant_modes(omega, s.mean, prefix="m")["m_mode"][0] == 12
    # share of modes 1–10, record by record over the records with energy (1000–5000 s)
    assert s.share_first_mean == pytest.approx((0 + 0.75 + 0.5 + 0.75 + 1) / 5, abs=1e-15)
    assert s.share_first_window == pytest.approx((0.5 + 0.75 + 1) / 3, abs=1e-15)
    assert s.share_first_at == 0.5
    keys = first_modes_share_keys(s)
    assert keys == {
        "modal_energy_share_first10_mean": s.share_first_mean,
        "modal_energy_share_first10_at_Umax": 0.5,
        "modal_energy_share_first10_last2000s": s.share_first_window,
    }
    # blocks in record order give the same figures
    b = modal_energy_stats(t, [E[:2], E[2:5], E[5:]], index=3)
    assert b.share_first_mean == s.share_first_mean and np.array_equal(b.window_mean, s.window_mean)
    assert modal_energy_stats(t, [E], index=0).share_first_at is None
    assert modal_energy_stats(t, [0 * E], index=1).share_first_mean is None
    with pytest.raises(ValueError, match="energies"):
        modal_energy_stats(t, [E[:5]], index=0)
    with pytest.raises(ValueError, match="window_s"):
        modal_energy_stats(t, [E], index=0, window_s=0.0)
    with pytest.raises(ValueError, match="index"):
        modal_energy_stats(t, [E], index=6)


# ------------------------------------------------------------------ modal projection
@pytest.fixture(scope="module")
def small_modes():
    lat = make_lattice(units=3, side_m=30.0)
    k = np.full(lat.struts.shape[0], 20.0)
    m = np.full(lat.n_nodes, 1.5)  # uniform, as the current-loop plates
    return lat, lattice_modes(lat.nodes, lat.struts, k, m, use_cache=False)


def _deformed(lat, md, amplitudes: dict[int, float]) -> np.ndarray:
    """Nodes p + Σ a_j φ_j (elastic mode j, 0-based), then turned by 40° and moved."""
    u = sum(a * md.phi[:, md.n_rigid + j] for j, a in amplitudes.items()).reshape(-1, 3)
    R = so3_exp(np.radians(40.0) * np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8]))
    return (lat.nodes + u) @ R.T + np.array([5.0, -2.0, 1.0])


def test_single_mode_has_share_one(small_modes):
    lat, md = small_modes
    j = 4
    a = 1e-3  # kg^1/2 m: a small deformation (metres ~ 1e-4 against 10 m cells)
    E = modal_strain_energies(md, lat.nodes, _deformed(lat, md, {j: a})[None])[0]
    omega = md.omega[md.elastic]
    assert E[j] == pytest.approx(0.5 * omega[j] ** 2 * a**2, rel=1e-9)
    keys = dominant_modes(omega, E, prefix="d")
    assert keys["d_mode"][0] == j + 1
    assert keys["d_share"][0] == pytest.approx(1.0, abs=1e-9)
    assert keys["d_omega_rad_s"][0] == omega[j]


def test_two_mode_mixture_has_known_energies(small_modes):
    """a φ_2 + b φ_7: E_n = ½ ω_n² a_n², shares E_n / (E_2 + E_7) (1e-9)."""
    lat, md = small_modes
    omega = md.omega[md.elastic]
    amp = {2: 2e-3, 7: -1e-3}
    E = modal_strain_energies(md, lat.nodes, _deformed(lat, md, amp)[None])[0]
    expect = {j: 0.5 * omega[j] ** 2 * a**2 for j, a in amp.items()}
    total = sum(expect.values())
    for j, e in expect.items():
        assert E[j] == pytest.approx(e, rel=1e-9)
    assert E.sum() == pytest.approx(total, rel=1e-9)
    keys = dominant_modes(omega, E, prefix="d", count=2)
    assert sorted(keys["d_mode"]) == [3, 8]
    for mode, share in zip(keys["d_mode"], keys["d_share"]):
        assert share == pytest.approx(expect[mode - 1] / total, abs=1e-9)
    # over two records (mode 2 alone, then the mixture) the average is the mean of the energies
    x = np.stack([_deformed(lat, md, {2: 2e-3}), _deformed(lat, md, amp)])
    at, mean = modal_energy_profile(md, lat.nodes, x, index=1)
    assert np.allclose(at, E, rtol=1e-9, atol=1e-12 * total)
    assert mean[2] == pytest.approx(expect[2], rel=1e-9)
    assert mean[7] == pytest.approx(0.5 * expect[7], rel=1e-9)
    # the summary over the same records: the same energies; modes 3 and 8 both among the first ten
    s = modal_energy_summary(md, lat.nodes, x, t=np.array([0.0, 1.0]), index=1)
    assert np.allclose(s.at, at, rtol=1e-9, atol=1e-12 * total)
    assert np.allclose(s.window_mean, mean, rtol=1e-9, atol=1e-12 * total)
    assert s.share_first_at == pytest.approx(1.0, abs=1e-9)
    far = modal_energy_summary(md, lat.nodes, _deformed(lat, md, {11: 1e-3})[None], t=np.zeros(1), index=0)
    assert far.share_first_at == pytest.approx(0.0, abs=1e-9)  # mode 12 alone


# ------------------------------------------------------------------ short real runs
SMALL = ["lattice.units=4", "sim.duration_s=40.0", "sim.record_every=10", "sim.progress=false"]


def _run(tmp_path, config, more=()):
    from magsail_mj.run import run_scenario

    cfg = load_config(MODELS / config, SMALL + list(more))
    return run_scenario(cfg, tmp_path / Path(config).stem, progress=False)


def test_sweep_run_has_stretch_and_peak_keys(tmp_path):
    out = _run(tmp_path, "sweep/b_n12_ei1e3.toml")
    assert out.status == "completed"
    for axis in ("x", "y"):
        ext = out[f"stretch_{axis}_extremum_m"]
        assert out[f"stretch_{axis}_sign"] == int(np.sign(ext))
        assert 0.0 <= out[f"stretch_{axis}_half_swing_m"] <= abs(ext) + abs(out[f"stretch_{axis}_late_mean_m"])
    # the global maximum of U is always one of the counted peaks (its prominence is max U)
    assert out["strain_energy_peak_count"] >= 1
    assert out["t_strain_energy_max_s"] in out["strain_energy_peak_times_s"]


def test_slew_run_has_saturation_and_dominant_mode_keys(tmp_path):
    out = _run(tmp_path, "slew.toml")
    assert out.status == "completed"
    n = out["saturation_interval_count"]
    assert n == len(out["saturation_intervals_s"]) and 0.0 <= out["saturated_time_s"] <= 40.0
    assert (out["saturation_fraction"] > 0) == (n > 0)
    shares = out["dominant_modes_at_Umax_share"]
    assert len(shares) == 3 and shares == sorted(shares, reverse=True) and sum(shares) <= 1 + 1e-12
    # small deformation: the modal strain energies add up to the lattice's strain energy (1 %)
    assert out["dominant_modes_at_Umax_energy_sum_J"] == pytest.approx(out["strain_energy_max_J"], rel=1e-2)
    # a 40 s run lies within its last 2000 s: the window's figures are the run's
    assert out["dominant_modes_last2000s_mode"] == out["dominant_modes_mean_mode"]
    assert out["dominant_modes_last2000s_share"] == pytest.approx(out["dominant_modes_mean_share"], rel=1e-12)
    assert out["modal_energy_share_first10_last2000s"] == pytest.approx(out["modal_energy_share_first10_mean"])
    for key in ("mean", "at_Umax", "last2000s"):
        assert 0.0 <= out[f"modal_energy_share_first10_{key}"] <= 1.0
    assert len(out["error_extrema_t_s"]) == len(out["error_extrema_deg"]) == out["error_extrema_count"]
