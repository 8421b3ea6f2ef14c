"""Shared test helpers: a small, fast truss config; the two-layer lattice point set."""

from __future__ import annotations

import copy
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.render.backend import ensure_gl_backend

# The GL backend must be chosen before any test module imports mujoco (MUJOCO_GL is read at
# import time); pytest imports this conftest before it collects the test modules.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", RuntimeWarning)
    ensure_gl_backend()

REPO = Path(__file__).resolve().parents[1]

SMALL_TRUSS = {
    "concept": "truss_magnetorquer",
    "scenario": "dist_vs_central",
    "description": "small test truss",
    "sim": {
        "duration_s": 20.0,
        "timestep_s": 0.1,
        "integrator": "RK4",
        "record_every": 5,
        "seed": 0,
        "progress": False,
    },
    "lattice": {"units": 3, "side_m": 12.0, "diagonals": "parity"},
    "mass": {"total_kg": 8.0, "central_fraction": 0.0},
    "stiffness": {"EI_Nm2": 50.0, "calibration": "cantilever"},
    "damping": {"zeta_strut": 0.1},
    "actuators": {"placement": "distributed"},
    "profile": {"kind": "bang_bang_off", "tau_max_Nm": 0.01, "t_end_s": 20.0},
}

SMALL_ORBITAL_TRUSS = {
    "concept": "truss_magnetorquer",
    "scenario": "detumble",
    "description": "small orbital truss",
    "sim": {
        "duration_s": 6.0,
        "timestep_s": 0.1,
        "integrator": "RK4",
        "record_every": 5,
        "seed": 0,
        "progress": False,
        "checkpoint_every_s": 2.0,
    },
    "lattice": {"units": 3, "side_m": 12.0},
    "mass": {"total_kg": 8.0},
    "stiffness": {"EI_Nm2": 50.0},
    "damping": {"zeta_strut": 0.1},
    "actuators": {"kind": "magnetorquer", "kappa_Am2_per_kg": 100.0, "rod_mass_kg": 2.0},
    "initial": {"omega0_rad_s": [0.01, 0.007, 0.0]},
    "orbit": {"enabled": True, "altitude_km": 800.0, "inclination_deg": 90.0, "raan_deg": 90.0},
    "field": {"model": "dipole"},
    "gravity": {"tidal": True},
    "control": {"kind": "bdot", "k_bdot_Nms_per_T2": 1e12, "cache_dir": ""},
}
"""A raw config tree of a 3 × 3-cube truss in an 800 km polar orbit, rods under B-dot (6 s)."""


@pytest.fixture
def small_truss_tree() -> dict:
    """A raw config tree of a 3 × 3-cube truss (32 nodes) with a distributed torque."""
    return copy.deepcopy(SMALL_TRUSS)


def lattice_points(N: int, d: float) -> np.ndarray:
    """Reference coordinates p_ijk = (i a - d/2, j a - d/2, (k - 1/2) a), index k N^2 + j N + i
    (the two-layer N x N lattice of the truss spec §2.1, built without the lattice module)."""
    a = d / (N - 1)
    k, j, i = np.meshgrid(np.arange(2), np.arange(N), np.arange(N), indexing="ij")
    return np.stack([i * a - d / 2, j * a - d / 2, (k - 0.5) * a], axis=-1).reshape(-1, 3)


def wait_for(predicate, timeout_s: float, what: str) -> None:
    """Poll ``predicate()`` every 50 ms until it is true; fail naming ``what`` after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.05)
