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


LOOPS = REPO / "magsail_mj/concepts/current_loops/configs"


@pytest.mark.parametrize("config", ["slew.toml", "sweep/a_n12_ei1e3.toml", "paper_literal/slew_literal.toml"])
def test_shipped_current_loop_models_equal_the_lattice_builder(config: str) -> None:
    """The current loops' lattice is built through the structure path too: tendon springs for
    ``stiffness.form = "tendon"``, none for the linear forms (a load), never a dashpot."""
    from magsail_mj.concepts.current_loops.model import make_loops_model

    cfg = load_config(LOOPS / config)
    built = make_loops_model(cfg)
    linear = cfg.stiffness.form != "tendon"
    assert built.structure.stiffness_model == ("members" if not linear else cfg.stiffness.form)
    assert (built.structure.modal_damping is not None) == cfg.damping.enabled
    opts = TrussModelOptions(
        timestep_s=cfg.sim.timestep_s,
        integrator=cfg.sim.integrator,
        solver_tolerance=cfg.sim.solver_tolerance,
        name=f"current_loops_{cfg.scenario}",
    )
    tendon_k = np.zeros_like(built.k) if linear else built.k
    reference = build_truss_spec(built.lattice, masses=built.masses, stiffness=tendon_k, damping=0.0, options=opts)
    for flag in ("CONSTRAINT", "EQUALITY", "FRICTIONLOSS", "LIMIT"):
        reference.option.disableflags |= int(getattr(mujoco.mjtDisableBit, f"mjDSBL_{flag}"))
    ours, want = _arrays(built.spec.compile()), _arrays(reference.compile())
    differ = [name for name in want if not np.array_equal(ours[name], want[name], equal_nan=True)]
    assert differ == [], differ
    assert np.array_equal(built.structure.members.stiffness_N_m, built.k)  # the structure keeps the springs


def test_a_linear_stiffness_model_holds_struts_only() -> None:
    """The co-rotated linear K is the struts' (a load): a beam or cable in such a structure is
    refused by the builder, naming the member; with struts the tendons carry no spring."""
    import dataclasses

    from magsail_mj.structure.mjcf import build_structure_spec
    from magsail_mj.structure.model import Members, Structure, StructureError

    positions = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    members = Members.build([[0, 1], [1, 2], [2, 0]], positions_m=positions, EA_N=10.0)
    plain = Structure(name="t", positions_m=positions, node_mass_kg=np.ones(3), members=members)
    linear = dataclasses.replace(plain, stiffness_model="corotational")
    model = build_structure_spec(linear, timestep_s=0.01, integrator="RK4").compile()
    assert np.all(model.tendon_stiffness == 0.0)
    assert np.all(build_structure_spec(plain, timestep_s=0.01, integrator="RK4").compile().tendon_stiffness > 0)
    beams = Members.build([[0, 1], [1, 2]], positions_m=positions, kind="beam", EA_N=10.0, EI_Nm2=1.0, GJ_Nm2=1.0)
    with_beam = dataclasses.replace(
        linear,
        members=Members.concatenate(
            [members.__class__(**{f: getattr(members, f)[:1] for f in members.__dataclass_fields__}), beams]
        ),
    )
    with pytest.raises(
        StructureError, match=r"members\[1\]\.kind: the linear stiffness model 'corotational' holds struts only"
    ):
        build_structure_spec(with_beam, timestep_s=0.01, integrator="RK4")
