"""MSAC post-processing: yaw, increments, secular-rate fit, block average,
zero-phase low-pass — each against a plain reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magsail_mj.concepts.msac.metrics import (
    block_average,
    cycle_increments,
    filtered_rate,
    lowpass,
    omega_world,
    secular_rate_fit,
    unwrapped_yaw,
    yaw_from_quat,
)
from magsail_mj.estimation.attitude import matrix_from_quat


def quat_z(psi):
    psi = np.asarray(psi, dtype=float)
    return np.stack([np.cos(psi / 2), 0 * psi, 0 * psi, np.sin(psi / 2)], axis=-1)


def test_yaw_of_rotations_about_z():
    psi = np.linspace(-3.1, 3.1, 101)
    assert np.allclose(np.angle(np.exp(1j * yaw_from_quat(quat_z(psi)))), psi, atol=1e-14)
    # q and -q are the same rotation: the wrapped yaw agrees
    assert np.allclose(np.angle(np.exp(1j * yaw_from_quat(-quat_z(psi)))), psi, atol=1e-14)


def test_unwrapped_yaw_follows_many_turns():
    t = np.linspace(0, 600, 60001)
    psi = 1.5444 * t + 0.2 * np.sin(2 * np.pi * 3 * t)
    got = unwrapped_yaw(quat_z(psi))
    assert np.allclose(got - got[0], psi - psi[0], atol=1e-9)


def test_cycle_increments_match_loop():
    rng = np.random.default_rng(2)
    y = np.cumsum(rng.normal(1.5e-3, 1e-6, 50))
    ci = cycle_increments(y, discard=2)
    inc = [y[i + 1] - y[i] for i in range(len(y) - 1)]
    kept = inc[2:]
    mean = sum(kept) / len(kept)
    std = math.sqrt(sum((x - mean) ** 2 for x in kept) / len(kept))
    assert ci.mean == pytest.approx(mean, rel=1e-12) and ci.std == pytest.approx(std, rel=1e-9)
    assert ci.first == inc[0] and ci.count == len(kept)
    with pytest.raises(ValueError, match="discard"):
        cycle_increments(y[:2], discard=1)


def test_secular_rate_fit_matches_plain_least_squares():
    rng = np.random.default_rng(4)
    t = np.sort(rng.uniform(0, 600, 2000))
    y = 0.3 + 1.5444 * t + rng.normal(0, 1e-3, t.size)
    slope, icpt = secular_rate_fit(t, y)
    n = len(t)
    st, sy = sum(t), sum(y)
    stt = sum(x * x for x in t)
    sty = sum(a * b for a, b in zip(t, y))
    ref = (n * sty - st * sy) / (n * stt - st * st)
    assert slope == pytest.approx(ref, rel=1e-9)
    assert slope == pytest.approx(np.polyfit(t, y, 1)[0], rel=1e-10)
    assert icpt == pytest.approx(0.3, abs=1e-3)


def test_block_average_matches_loop():
    x = np.random.default_rng(1).normal(size=103)
    got = block_average(x, 10)
    ref = [sum(x[10 * i : 10 * i + 10]) / 10 for i in range(10)]
    assert np.allclose(got, ref, rtol=1e-14)
    with pytest.raises(ValueError, match="block"):
        block_average(x, 0)


def test_lowpass_is_zero_phase_and_removes_the_cycle():
    fs = 5000.0
    t = np.arange(0, 20.0, 1 / fs)
    slow = 1.5 + 0.3 * np.sin(2 * np.pi * 0.2 * t)  # far below the 10 Hz cutoff
    fast = 900.0 * np.sin(2 * np.pi * 1000.0 * t)  # the 1 kHz cycle content
    y = lowpass(slow + fast, fs_hz=fs, cutoff_hz=10.0, order=4)
    core = (t > 2) & (t < 18)
    # 1 kHz is attenuated by (10/1000)^8 = 1e-16 twice over; the slow sine passes undelayed
    # (zero phase) with gain |H(0.2 Hz)|² = 1 − O((0.2/10)^8)
    assert np.max(np.abs(y[core] - slow[core])) < 1e-6
    keep = (t >= t[0] + 2.0) & (t <= t[-1] - 2.0)
    assert filtered_rate(t, y, edge_s=2.0) == pytest.approx(slow[keep].mean(), abs=1e-6)
    with pytest.raises(ValueError, match="cutoff_hz"):
        lowpass(y, fs_hz=100.0, cutoff_hz=60.0)


def test_omega_world_matches_loop():
    rng = np.random.default_rng(7)
    q = rng.normal(size=(20, 4))
    w = rng.normal(size=(20, 3))
    got = omega_world(q, w)
    ref = np.array([matrix_from_quat(q[i]) @ w[i] for i in range(20)])
    assert np.allclose(got, ref, atol=1e-14)
