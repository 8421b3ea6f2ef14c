"""The shipped truss is built through the structure path: every shipped truss config's model
(lattice → :class:`Structure` → :func:`build_structure_spec`) has the MjModel arrays that the
lattice builder (:func:`build_truss_spec`) gives the same lattice, masses, springs and dashpots,
bit for bit — so the stored regression summaries cannot move through this path."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from magsail_mj.concepts.truss_magnetorquer.model import make_cantilever_model, make_truss_model
from magsail_mj.config import load_config
from magsail_mj.lattice.mjcf import TrussModelOptions, build_truss_spec

REPO = Path(__file__).resolve().parents[1]
CONFIGS = REPO / "magsail_mj/concepts/truss_magnetorquer/configs"
# one per kind, and the plate-twist scaling (per-strut axial rigidities)
SHIPPED = [
    "detumble.toml",
    "slew_i.toml",
    "libration.toml",
    "cantilever.toml",
    "dist_vs_central/case_c_central_bangbang.toml",
    "paper_literal/detumble_plate_twist.toml",
]


def _arrays(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    names = [n for n in dir(model) if not n.startswith("_")]
    out = {}
    for name in names:
        value = getattr(model, name)
        if isinstance(value, np.ndarray):
            out[name] = value
    return out


@pytest.mark.parametrize("config", SHIPPED)
def test_shipped_truss_models_equal_the_lattice_builder(config: str) -> None:
    cfg = load_config(CONFIGS / config)
    built = make_cantilever_model(cfg) if cfg.scenario == "cantilever" else make_truss_model(cfg)
    lat = built.lattice
    fixed = built.fixed_nodes
    damping = float(np.ravel(built.spec.joints[0].damping)[0]) / built.masses[0] if fixed else 0.0
    opts = TrussModelOptions(
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        solver_tolerance=cfg.sim.solver_tolerance,
        fixed_nodes=tuple(fixed),
        node_damping_1_s=damping,
        name=f"truss_{cfg.scenario}",
    )
    reference = build_truss_spec(lat, masses=built.masses, stiffness=built.k, damping=built.gamma, options=opts)
    ours, want = _arrays(built.spec.compile()), _arrays(reference.compile())
    assert set(ours) == set(want) and len(ours) > 150
    differ = [name for name in want if not np.array_equal(ours[name], want[name], equal_nan=True)]
    assert differ == [], differ
