"""What keeps a large structure's path from file to first step linear in its size (small sizes; the
timings are ``scripts/bench_structure_scale.py``'s):

* the builder sets MuJoCo's arena from ``nv`` (linear), never MuJoCo's default (``nv²``);
* no step of the path (read, check, build, compile, data, step) allocates an ``nv × nv`` array on
  the Python side: the traced peak of a 2 048-node plate stays below a bound linear in the nodes;
* :func:`~magsail_mj.resources.structure_model_bytes` bounds MuJoCo's model, data and arena;
* a model assembled from scratch specs (:class:`~magsail_mj.lattice.mjcf.WorldTrees`, above
  :data:`~magsail_mj.lattice.mjcf.SPEC_DIRECT_BODIES` bodies) compiles to the model written
  element by element, array for array, and its MJCF loads back to it.
"""

from __future__ import annotations

import dataclasses
import tracemalloc
import warnings

import mujoco
import numpy as np
import pytest

from magsail_mj.lattice import mjcf as lattice_mjcf
from magsail_mj.lattice.mjcf import lattice_arena_bytes
from magsail_mj.resources import structure_model_bytes
from magsail_mj.structure.checks import check_structure
from magsail_mj.structure.fileformat import read_structure, write_structure
from magsail_mj.structure.generators import square_plate_lattice
from magsail_mj.structure.mjcf import build_structure_spec
from magsail_mj.structure.model import MEMBER_KINDS, Members, Structure
from tests.conftest import small_sail

MIB = 1 << 20
#: Python-side bytes per node the whole path may trace at its peak: 2.3 times the 3.6 kB measured
#: for the 2 048-node plate (the structure's arrays, the MjSpec's Python handles and names); a dense
#: nv × nv array of that plate would be 36 MiB as bytes, 288 MiB as doubles (nv = 6 144).
TRACED_BYTES_PER_NODE = 8 * 1024


def _plate(units: int, *, clamp_root: bool = False) -> Structure:
    plate = square_plate_lattice(units=units, side_m=10.0, EA_N=1.0e5, total_mass_kg=10.0, zeta_strut=0.01)
    if not clamp_root:
        return plate
    fixed = np.array(plate.fixed_dofs)
    fixed[plate.node_sets["root"], :3] = True  # clamped translations: those particles have no joints
    return dataclasses.replace(plate, fixed_dofs=fixed)


def _forest() -> Structure:
    """Trees of several sizes: a clamped 6-beam boom, a free 2-beam boom (free joint root), a
    3-beam boom pinned at its root (ball joint), and particles joined by struts and a cable; struts
    tie the booms' tips together and to the particles."""
    chains = [(0, 7, [0.0, 0.0, 0.0]), (7, 3, [0.0, 2.0, 0.0]), (10, 4, [0.0, 4.0, 0.0])]  # (first node, nodes, start)
    positions = np.vstack([np.column_stack([np.arange(k), np.zeros(k), np.zeros(k)]) + s for _, k, s in chains])
    particles = np.array([[0.0, 6.0, 0.0], [1.0, 6.0, 0.0], [1.0, 7.0, 0.0], [0.0, 7.0, 0.0]])
    positions = np.vstack([positions, particles])
    beam_ends = np.vstack([f + np.column_stack([np.arange(k - 1), np.arange(1, k)]) for f, k, _ in chains])
    beams = Members.build(
        beam_ends,
        positions_m=positions,
        kind="beam",
        EA_N=1.0e5,
        EI_Nm2=50.0,
        GJ_Nm2=40.0,
        linear_density_kg_m=0.2,
        orientation=np.tile([0.0, 0.0, 1.0], (len(beam_ends), 1)),
    )
    ties = Members.build(
        [[14, 15], [15, 16], [16, 17], [17, 14], [14, 16], [13, 14], [6, 9], [9, 13]],
        positions_m=positions,
        kind=np.array([MEMBER_KINDS.index("cable" if j == 4 else "strut") for j in range(8)]),
        EA_N=1.0e4,
        damping_Ns_m=np.array([0.1, 0.1, 0.1, 0.1, 0.0, 0.1, 0.1, 0.1]),
    )
    fixed = np.zeros((len(positions), 6), dtype=bool)
    fixed[0] = True
    fixed[10, :3] = True
    return Structure(
        "forest", positions, np.full(len(positions), 0.05), Members.concatenate([beams, ties]), fixed_dofs=fixed
    )


def _sail() -> Structure:
    """A rigid hub (part) with four 3-beam booms, and the membrane's nodes as particles (panels)."""
    return small_sail()


def _model_arrays(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    arrays = {k: getattr(model, k) for k in dir(model) if not k.startswith("_")}
    return {k: np.array(v) for k, v in arrays.items() if isinstance(v, np.ndarray)}


def _assert_same_model(model: mujoco.MjModel, expected: mujoco.MjModel) -> None:
    got, want = _model_arrays(model), _model_arrays(expected)
    assert len(want) > 150 and set(got) == set(want)
    assert [k for k in want if not np.array_equal(got[k], want[k])] == []
    for field in ("timestep", "integrator", "gravity", "disableflags", "tolerance"):
        assert np.array_equal(getattr(model.opt, field), getattr(expected.opt, field)), field


# --------------------------------------------------------------------------- arena and buffers


@pytest.mark.parametrize(
    "structure", [_plate(3), _plate(9, clamp_root=True), _forest(), _sail()], ids=["plate", "clamped", "forest", "sail"]
)
def test_arena_is_set_from_nv(structure: Structure) -> None:
    """``spec.memory`` is ``lattice_arena_bytes(nv)`` (1 MiB + 4 kiB per dof), the compiled model's
    arena is exactly that, and it is below MuJoCo's default arena for the same model (building the
    spec again without ``memory``: an arena that grows with ``nv²``)."""
    check_structure(structure)
    spec = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler")
    model = spec.compile()
    assert spec.memory == lattice_arena_bytes(model.nv) == MIB + 4096 * model.nv
    assert model.narena == spec.memory
    spec.memory = -1  # MuJoCo's default arena
    assert spec.compile().narena > model.narena


def test_arena_and_buffers_grow_linearly_with_the_plate() -> None:
    """Between plates of 200 and 882 nodes, the arena grows by exactly 4 kiB per added dof and the
    model's mass matrix stays sparse: ``nM = 2 nv`` (each particle's three slide dofs chained) and
    ``nD = 3 nv``, never ``nv (nv + 1) / 2``."""
    small, large = (build_structure_spec(_plate(u), timestep_s=1e-3, integrator="Euler").compile() for u in (9, 20))
    assert large.narena - small.narena == 4096 * (large.nv - small.nv)
    for model in (small, large):
        assert model.nM == 2 * model.nv and model.nD == 3 * model.nv


def test_the_path_allocates_nothing_quadratic_in_nv(tmp_path) -> None:
    """Read (``.npz`` companion), check, build, compile, data and the first step of a 2 048-node
    plate (nv = 6 144) under ``tracemalloc``: the traced peak stays below
    :data:`TRACED_BYTES_PER_NODE` per node (16 MiB), where one dense ``nv × nv`` array of bytes
    would be 36 MiB. (MuJoCo's own C buffers are not traced: ``structure_model_bytes`` bounds them,
    below.)"""
    plate = _plate(31)
    path = write_structure(plate, tmp_path / "plate.toml", arrays="npz")[0]
    tracemalloc.start()
    try:
        structure = read_structure(path).structure
        check_structure(structure)
        model = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler").compile()
        data = mujoco.MjData(model)
        mujoco.mj_step(model, data)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert model.nv == 6144 and structure.n_nodes == 2048
    assert peak < TRACED_BYTES_PER_NODE * structure.n_nodes < model.nv**2


@pytest.mark.parametrize("units", [3, 9, 20])
def test_estimate_bounds_the_plate_model(units: int) -> None:
    """``structure_model_bytes`` of the node and member counts alone is at least MuJoCo's model
    and data buffers plus the arena, for plates of 32, 200 and 882 nodes."""
    structure = _plate(units)
    model = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler").compile()
    data = mujoco.MjData(model)
    measured = model.nbuffer + data.nbuffer + model.narena
    assert structure_model_bytes(n_nodes=structure.n_nodes, n_members=structure.n_members) >= measured


@pytest.mark.parametrize(
    "structure", [_forest(), _sail(), _plate(9, clamp_root=True)], ids=["forest", "sail", "clamped"]
)
def test_estimate_bounds_models_with_chains_given_their_counts(structure: Structure) -> None:
    """With a model's own counts (``nv``, ``nbody``, ``ntendon`` and the mass matrix's ``nM``,
    which beam chains fill), the estimate bounds model, data and arena too."""
    model = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler").compile()
    data = mujoco.MjData(model)
    estimate = structure_model_bytes(
        n_nodes=structure.n_nodes,
        n_members=structure.n_members,
        nv=model.nv,
        nbody=model.nbody,
        ntendon=model.ntendon,
        mass_nnz=model.nM,
    )
    assert estimate >= model.nbuffer + data.nbuffer + model.narena


@pytest.mark.parametrize(("key", "value"), [("n_nodes", -1), ("nv", 2.5), ("mass_nnz", True)])
def test_estimate_refuses_bad_counts(key: str, value: object) -> None:
    counts = {"n_nodes": 4, "n_members": 3, key: value}
    with pytest.raises(ValueError, match=f"{key}: must be an integer >= 0, got {value!r}"):
        structure_model_bytes(**counts)


# --------------------------------------------------------------------------- assembly from scratch specs


@pytest.mark.parametrize("chunk", [1, 3])
@pytest.mark.parametrize(
    "structure", [_plate(4, clamp_root=True), _forest(), _sail()], ids=["clamped", "forest", "sail"]
)
def test_assembled_model_equals_the_directly_written_one(monkeypatch, structure: Structure, chunk: int) -> None:
    """Forced through scratch specs of ``chunk`` bodies (several attaches, trees larger than a
    chunk, fixed and pinned roots, a rigid part, a skin), the model compiles to every array, name
    and option of the one written element by element, MuJoCo warns of nothing (an empty attach
    prefix would make it warn on every compile), and the MJCF it writes (with its identity frames)
    loads back to the same model."""
    direct = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler")
    assert "<frame" not in direct.to_xml()
    monkeypatch.setattr(lattice_mjcf, "SPEC_DIRECT_BODIES", 0)
    monkeypatch.setattr(lattice_mjcf, "SPEC_CHUNK_BODIES", chunk)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        spec = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler")
        model = spec.compile()
        xml = spec.to_xml()
    assert "<frame" in xml
    _assert_same_model(model, direct.compile())
    _assert_same_model(mujoco.MjModel.from_xml_string(xml), model)


# --------------------------------------------------------------------------- flex struts


def test_flex_plate_assembled_from_scratch_specs_and_bounded(monkeypatch) -> None:
    """A plate whose struts are flex edges: assembled through scratch specs it compiles to the
    directly written model (every array), its MJCF loads back to it, and the estimate of its node
    and member counts bounds MuJoCo's model, data and arena."""
    structure = _plate(4, clamp_root=True)
    direct = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler", strut_elements="flex")
    expected = direct.compile()
    assert expected.ntendon == 0 and expected.nflexedge == structure.n_members
    monkeypatch.setattr(lattice_mjcf, "SPEC_DIRECT_BODIES", 0)
    monkeypatch.setattr(lattice_mjcf, "SPEC_CHUNK_BODIES", 3)
    spec = build_structure_spec(structure, timestep_s=1e-3, integrator="Euler", strut_elements="flex")
    model = spec.compile()
    _assert_same_model(model, expected)
    _assert_same_model(mujoco.MjModel.from_xml_string(spec.to_xml()), model)
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    measured = model.nbuffer + data.nbuffer + model.narena
    assert structure_model_bytes(n_nodes=structure.n_nodes, n_members=structure.n_members) >= measured
