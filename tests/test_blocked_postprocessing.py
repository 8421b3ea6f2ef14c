"""Post-processing of long runs reads the record store block by block: the blocks cover every row
once and in order, the lattice's structural series computed over blocks equal those of the whole
array, and asking whether a store holds a variable never reads it."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import zarr
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.analysis.energy import structural_failure
from magsail_mj.concepts.current_loops.metrics import structural_series
from magsail_mj.concepts.truss_magnetorquer.metrics import common_summary
from magsail_mj.config import load_config
from magsail_mj.concepts import build_task
from magsail_mj.lattice.trajectory import NodeTrajectory
from magsail_mj import records as records_module
from magsail_mj.records import Recorder, StoreRecords, lazy_record, row_blocks, write_group
from tests.conftest import REPO

TRUSS = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.toml"
SWEEP = REPO / "magsail_mj/concepts/current_loops/configs/sweep/a_n12_ei1e3.toml"


@settings(max_examples=40, deadline=None)
@given(rows=st.integers(0, 60), width=st.integers(1, 7), chunk=st.integers(1, 20), budget_rows=st.integers(1, 30))
def test_row_blocks_cover_every_row_once_in_order(tmp_path_factory, rows, width, chunk, budget_rows):
    data = np.arange(rows * width, dtype=float).reshape(rows, width)
    z = zarr.create_array(tmp_path_factory.mktemp("z") / "a.zarr", shape=data.shape, chunks=(chunk, width), dtype=float)
    z[...] = data
    budget = budget_rows * width * 8
    for array in (data, z):
        blocks = list(row_blocks(array, budget_bytes=budget))
        assert all(isinstance(b, np.ndarray) and len(b) >= 1 for b in blocks)
        assert all(b.nbytes <= max(budget, width * 8) for b in blocks)
        np.testing.assert_array_equal(np.concatenate(blocks) if blocks else data[:0], data)


def test_row_blocks_refuse_bad_arguments():
    with pytest.raises(ValueError, match="budget_bytes"):
        next(row_blocks(np.zeros((3, 2)), budget_bytes=0))
    with pytest.raises(ValueError, match="array"):
        next(row_blocks(np.float64(1.0)))


def test_asking_for_a_variable_does_not_read_it(tmp_path):
    write_group(tmp_path / "s.zarr", {"t": np.arange(5) * 0.1, "qpos": np.arange(5.0)[:, None] * np.ones(4)}, n_time=5)
    records = StoreRecords(tmp_path / "s.zarr")
    assert "qpos" in records and "nothing" not in records
    assert not records._cache  # nothing was read
    lazy = lazy_record(records, "qpos")
    assert isinstance(lazy, zarr.Array) and not records._cache
    np.testing.assert_array_equal(np.asarray(lazy[...])[:, 0], np.arange(5.0))
    plain = {"qpos": np.ones((2, 4))}
    assert lazy_record(plain, "qpos") is plain["qpos"]


def test_structural_series_over_blocks_equal_the_whole():
    """A free flexible plate (12 × 12 units) with random node displacements of 1 % of a cell: the
    series from blocks of 1, 3 and all rows agree to 1e-12 relative (every series is a function of
    one record; only the matrix product of the modal amplitudes may sum in another order)."""
    task = build_task(load_config(SWEEP, ["sim.duration_s=1"]))
    rng = np.random.default_rng(7)
    nodes = task.lm.lattice.nodes
    cell = task.cfg.lattice.side_m / task.cfg.lattice.units
    x = nodes[None] + 0.01 * cell * rng.standard_normal((9, *nodes.shape))
    qpos = (x - task.model.body_pos[1 : len(nodes) + 1]).reshape(len(x), -1)  # slide coordinates of free nodes
    np.testing.assert_allclose(task.node_positions(qpos), x, atol=1e-12)
    whole = structural_series(task.lm, x, modes=task.modes)
    assert "modal_amplitude" in whole and np.abs(whole["modal_amplitude"]).max() == pytest.approx(1.0)
    for rows in (1, 3):
        trajectory = NodeTrajectory(qpos, task.node_positions, budget_bytes=rows * qpos.shape[1] * 8)
        blocked = structural_series(task.lm, trajectory, modes=task.modes)
        assert set(blocked) == set(whole)
        for key, value in whole.items():
            np.testing.assert_allclose(blocked[key], value, rtol=1e-12, atol=1e-15 * np.abs(value).max(), err_msg=key)


def test_trajectory_map_joins_arrays_tuples_named_tuples_and_mappings():
    rng = np.random.default_rng(3)
    x = rng.standard_normal((11, 4, 3))
    trajectory = NodeTrajectory.of_positions(x, budget_bytes=2 * x[0].nbytes)  # blocks of 2 records
    assert len(list(trajectory.blocks())) == 6 and len(trajectory) == 11
    np.testing.assert_array_equal(trajectory.map(lambda b: b.sum(axis=(1, 2))), x.sum(axis=(1, 2)))
    check = trajectory.map(lambda b: structural_failure(b, np.array([[0, 1], [2, 3]]), 1.0))
    whole = structural_failure(x, np.array([[0, 1], [2, 3]]), 1.0)
    assert type(check) is type(whole)
    for a, b in zip(check, whole):
        np.testing.assert_array_equal(a, b)
    joined = trajectory.map(lambda b: {"first": b[:, 0], "norm": np.linalg.norm(b, axis=2)})
    np.testing.assert_array_equal(joined["norm"], np.linalg.norm(x, axis=2))
    pair = trajectory.map(lambda b: (b[:, 1], b[:, 2, 0]))
    np.testing.assert_array_equal(pair[1], x[:, 2, 0])
    np.testing.assert_array_equal(trajectory.at(-1), x[-1])
    np.testing.assert_array_equal(trajectory.at(4), x[4])


def test_trajectory_refuses_bad_arguments():
    with pytest.raises(ValueError, match="positions"):
        NodeTrajectory.of_positions(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="budget_bytes"):
        NodeTrajectory(np.zeros((3, 6)), np.asarray, budget_bytes=0)
    with pytest.raises(ValueError, match="records"):
        NodeTrajectory(np.float64(0.0), np.asarray)
    with pytest.raises(IndexError, match="k: record 3"):
        NodeTrajectory.of_positions(np.zeros((3, 2, 3))).at(3)
    with pytest.raises(ValueError, match="no records"):
        NodeTrajectory.of_positions(np.zeros((0, 2, 3))).map(np.asarray)


def test_truss_summary_from_blocks_equals_the_whole(tmp_path):
    """A 1 s free truss run (6 units): the summary keys and series from the run's store read in blocks
    of 3 records equal those from the whole position array: each is a function of one record, but
    NumPy's vectorised sums over the struts may group terms differently for another array shape,
    so values agree to a few ulp (1e-13 relative), not always bitwise."""
    task = build_task(load_config(TRUSS, ["lattice.units=6", "sim.duration_s=1", "sim.record_every=1"]))
    result = task.simulation().run()
    t = result.records["t"]
    qpos = np.asarray(result.records["qpos"])
    whole = common_summary(task.tm, task.node_positions(qpos), result, max_strain=0.5, zeta_strut=0.01)
    blocked_positions = NodeTrajectory(qpos, task.node_positions, budget_bytes=3 * qpos.shape[1] * 8)
    blocked = common_summary(task.tm, blocked_positions, result, max_strain=0.5, zeta_strut=0.01)
    assert len(t) > 6 and whole[0].keys() == blocked[0].keys()
    for key, value in whole[0].items():
        if isinstance(value, float):
            np.testing.assert_allclose(blocked[0][key], value, rtol=1e-13, err_msg=key)
        else:
            assert blocked[0][key] == value, key
    for key in whole[1]:
        np.testing.assert_allclose(blocked[1][key], whole[1][key], rtol=1e-13, err_msg=key)


def _structure_peak_bytes(task, n_records: int, store) -> int:
    """tracemalloc peak [bytes] of the task's structural post-processing of ``n_records`` stored records."""
    rng = np.random.default_rng(n_records)
    nodes = task.lm.lattice.nodes
    x = nodes[None] + 1e-3 * rng.standard_normal((n_records, *nodes.shape))
    qpos = (x - task.model.body_pos[1 : len(nodes) + 1]).reshape(n_records, -1)
    recorder = Recorder(["t", "qpos"], chunk_bytes=64 * 1024, min_chunk=1)  # chunks of 8 records, as a run's
    recorder.create_store(store)
    recorder.extend({"t": np.arange(n_records, dtype=float), "qpos": qpos})
    recorder.flush()
    del x, qpos, recorder
    records = StoreRecords(store)
    tracemalloc.start()
    try:
        task.structure(records)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_structural_post_processing_memory_is_flat_in_run_length(tmp_path, monkeypatch):
    """With store chunks and blocks of 64 kB (8 records of the 12-unit plate; a run's chunks are a
    fixed number of bytes too, whatever its length), post-processing 160 stored records
    peaks within 1.2x of 40 records: the per-record series (about 200 B each) are all that grows.
    Reading the whole of qpos, as before, would peak at about 4x."""
    monkeypatch.setattr(records_module, "BLOCK_BYTES", 64 * 1024)
    task = build_task(load_config(SWEEP, ["sim.duration_s=1"]))
    task.modes()  # the lattice's modes are built once, outside the measure
    short, long = (_structure_peak_bytes(task, n, tmp_path / f"s{n}.zarr") for n in (40, 160))
    assert long < 1.2 * short, (short, long)
