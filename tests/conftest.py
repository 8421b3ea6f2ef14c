"""Shared test helpers: a small, fast truss config; the two-layer lattice point set."""

from __future__ import annotations

import copy
import importlib.util
import subprocess
import sys
import time
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from magsail_mj.render.backend import ensure_gl_backend
from magsail_mj.structure.generators import four_boom_sail
from magsail_mj.structure.model import Structure

# The GL backend must be chosen before any test module imports mujoco (MUJOCO_GL is read at
# import time); pytest imports this conftest before it collects the test modules.
with warnings.catch_warnings():
    warnings.simplefilter("ignore", RuntimeWarning)
    ensure_gl_backend()

REPO = Path(__file__).resolve().parents[1]

#: overrides of a small current-loop or truss run with a checkpoint every simulated second: ~12k RK4
#: steps, a few seconds with the outputs (the sweep tests kill and resume it)
CHECKPOINTING_RUN = [
    "lattice.units=3",
    "sim.duration_s=12.0",
    "sim.timestep_s=0.001",
    "sim.record_every=100",
    "sim.checkpoint_every_s=1.0",
    "sim.progress=false",
]

#: the keys of the reflector coil report (``coil_torque_report``, ``magsail torque coil``)
COIL_REPORT_KEYS = (
    "T_max_ycoil_Nm",
    "T_max_xcoil_Nm",
    "T_max_zloop_Nm",
    "zloop_side_m",
    "T_max_perimeter_loop_Nm",
    "T_max_ycoil_p1_Nm",
    "T_max_ycoil_rows_plus1_Nm",
    "m_max_Am2",
    "path_length_m",
    "node_count",
    "segment_count",
    "net_force_Bx_N",
    "closed_lead_dipole_y_Am2",
)

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
    "actuators": {"kind": "magnetorquer", "kappa_Am2_kg": 100.0, "rod_mass_kg": 2.0},
    "initial": {"omega0_rad_s": [0.01, 0.007, 0.0]},
    "orbit": {"enabled": True, "altitude_km": 800.0, "inclination_deg": 90.0, "raan_deg": 90.0},
    "field": {"model": "dipole"},
    "gravity": {"tidal": True},
    "control": {"kind": "bdot", "k_bdot_Nms_T2": 1e12, "cache_dir": ""},
}
"""A raw config tree of a 3 × 3-cube truss in an 800 km polar orbit, rods under B-dot (6 s)."""


@pytest.fixture
def small_truss_tree() -> dict:
    """A raw config tree of a 3 × 3-cube truss (32 nodes) with a distributed torque."""
    return copy.deepcopy(SMALL_TRUSS)


def lattice_points(N: int, d: float) -> np.ndarray:
    """Reference coordinates p_ijk = (i a - d/2, j a - d/2, (k - 1/2) a), index k N^2 + j N + i
    (the two-layer N x N truss lattice, built without the lattice module)."""
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


def load_file_module(folder: str, name: str, *, register: bool = False) -> ModuleType:
    """The file ``<repo>/<folder>/<name>.py`` (a script or an example: not in a package) loaded as the
    module ``name``; ``register`` puts it in ``sys.modules`` before it runs (a module whose
    dataclasses look their module up while it loads needs that)."""
    spec = importlib.util.spec_from_file_location(name, REPO / folder / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    if register:
        sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def start_cli(argv: list[str], *, cwd: Path, module: str = "magsail_mj.cli") -> subprocess.Popen:
    """``python -m <module> <argv>`` started in ``cwd``, its stdout and stderr piped as text."""
    return subprocess.Popen(
        [sys.executable, "-m", module, *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=cwd
    )


def small_sail(*, n_segments: int = 3, hub_mass_kg: float = 10.0, hub_inertia_kg_m2=1.0) -> Structure:
    """A 20 m four-boom sail for the structure tests: a rigid hub, four booms of ``n_segments``
    beams (EA 1e5 N, EI 1000/1500 N m², GJ 800 N m², 0.1 kg/m) and a 10 g/m² membrane."""
    return four_boom_sail(
        side_m=20.0,
        n_segments=n_segments,
        boom_EA_N=1e5,
        boom_EI_Nm2=[1000.0, 1500.0],
        boom_GJ_Nm2=800.0,
        boom_linear_density_kg_m=0.1,
        membrane_areal_density_kg_m2=0.01,
        reflectivity=[0.9, 0.05, 0.05],
        hub_mass_kg=hub_mass_kg,
        hub_inertia_kg_m2=hub_inertia_kg_m2,
    )
