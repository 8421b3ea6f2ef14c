"""The memory estimate of a structure config counts the model validation compiled: its bodies, the
mass matrix's non-zeros (beam chains fill ``d (d + 1) / 2``) and the arena the builder set (welded
beam cycles need more), so it bounds what MuJoCo allocates for model and data."""

from __future__ import annotations

import math

import mujoco
import pytest

from magsail_mj.config import parse_config
from magsail_mj.resources import estimate_model_bytes, structure_model_bytes
from magsail_mj.scenario import build_scenario


def _beams(n: int, *, closed: bool) -> dict:
    """A free boom of ``n`` straight beams 1 m long (or a ring of ``n`` beams), 0.1 kg per node."""
    if closed:
        radius = n / (2 * math.pi)
        nodes = [
            [radius * math.cos(2 * math.pi * k / n), radius * math.sin(2 * math.pi * k / n), 0.0] for k in range(n)
        ]
        ends = [[k, (k + 1) % n] for k in range(n)]
    else:
        nodes = [[float(k), 0.0, 0.0] for k in range(n + 1)]
        ends = [[k, k + 1] for k in range(n)]
    return {
        "concept": "structure",
        "scenario": "free",
        "sim": {"duration_s": 0.1, "timestep_s": 1e-4, "progress": False},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 0.1},
            "member_groups": [
                {"kind": "beam", "name": "boom", "nodes": ends, "EA_N": 1e4, "EI_Nm2": 10.0, "GJ_Nm2": 8.0}
            ],
        },
    }


@pytest.mark.parametrize(("n", "closed"), [(120, False), (48, True)], ids=["boom_120", "ring_48"])
def test_estimate_bounds_what_mujoco_allocates(n, closed):
    cfg = parse_config(_beams(n, closed=closed))
    model = build_scenario(cfg).spec.compile()
    data = mujoco.MjData(model)
    measured = model.nbuffer + data.nbuffer + data.narena
    own = cfg.model_bytes()
    assert own == structure_model_bytes(
        n_nodes=len(cfg.structure.structure.positions_m),
        n_members=n,
        nv=model.nv,
        nbody=model.nbody,
        ntendon=model.ntendon,
        mass_nnz=model.nM,
        arena_bytes=model.narena,
    )
    # the buffers are fitted (16 kB + per dof, body, tendon and mass non-zero), the arena exact and
    # the build's 16 kB per dof on top: above what MuJoCo holds, within a few times of it
    assert measured <= own <= 4 * measured, (own, measured)
    assert estimate_model_bytes(cfg) >= own
