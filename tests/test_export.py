"""``magsail export``: npz and netCDF written bitwise from the record store; hostile inputs exit 2."""

from __future__ import annotations

import argparse
import re

import numpy as np
import pytest
import xarray as xr

from magsail_mj import export
from magsail_mj.config import apply_overrides, parse_config
from magsail_mj.records import SERIES_GROUP, STORE_NAME, lazy_arrays, open_records
from magsail_mj.run import run_scenario
from tests.conftest import SMALL_TRUSS  # the 3 × 3-cube truss of the other run tests


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory):
    cfg = parse_config(apply_overrides(SMALL_TRUSS, ["sim.duration_s=2.0"]))
    return run_scenario(cfg, tmp_path_factory.mktemp("export") / "run").run_dir


def _args(*argv):
    return export.add_arguments(argparse.ArgumentParser(prog="magsail export")).parse_args(list(argv))


def _bitwise(a, b, name):
    a, b = np.asarray(a), np.asarray(b)
    assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name


def test_npz_round_trip_equals_the_store_bitwise(run_dir, tmp_path, capsys):
    """Every record and series (a series replacing a record of its name) is in the npz bit for bit."""
    out = tmp_path / "x.npz"
    assert export.main(_args(str(run_dir), "--format", "npz", "--out", str(out))) == 0
    assert capsys.readouterr().out.strip() == str(out)
    records, series = open_records(run_dir), open_records(run_dir, group=SERIES_GROUP)
    want = {**{k: records[k] for k in records}, **{k: series[k] for k in series}}
    with np.load(out, allow_pickle=False) as npz:
        assert sorted(npz.files) == sorted(want)
        for name, value in want.items():
            _bitwise(npz[name], value, name)


def test_readers_of_the_store_equal_its_groups_bitwise(run_dir):
    """What analysis code reads (read_timeseries eagerly, records.lazy_arrays lazily) is the root
    group's records and the series group's arrays (a series replacing a record of its name), bit
    for bit, as the two groups read one by one."""
    records, series = open_records(run_dir), open_records(run_dir, group=SERIES_GROUP)
    want = {**{k: records[k] for k in records}, **{k: series[k] for k in series}}
    assert set(records) - set(series) and set(series) - {"t"}  # both groups contribute
    eager, lazy = export.read_timeseries(run_dir), lazy_arrays(run_dir)
    assert sorted(eager) == sorted(lazy) == sorted(want)
    for name, value in want.items():
        _bitwise(eager[name], value, name)
        _bitwise(lazy[name][...], value, name)


def test_streamed_npz_of_many_blocks_reads_back(tmp_path):
    """An array written in several blocks (chunked along its first axis) is the same array."""
    rng = np.random.default_rng(0)
    a = rng.normal(size=(1000, 7))

    class Chunked:  # a minimal lazy array: shape, dtype, chunks, slicing
        shape, dtype, chunks, ndim = a.shape, a.dtype, (64, 7), 2

        def __getitem__(self, key):
            return a[key]

    export.write_npz_streamed(tmp_path / "c.npz", {"a": Chunked(), "s": np.float64(2.5), "i": np.arange(3)})
    with np.load(tmp_path / "c.npz") as npz:
        _bitwise(npz["a"], a, "a")
        assert npz["s"].shape == () and npz["s"] == 2.5 and np.array_equal(npz["i"], np.arange(3))


def test_netcdf_round_trip_equals_the_store_bitwise(run_dir, tmp_path):
    out = tmp_path / "x.nc"
    assert export.main(_args(str(run_dir), "--format", "netcdf", "--out", str(out))) == 0
    for group in (None, SERIES_GROUP):
        stored = open_records(run_dir, group=group)
        with xr.open_dataset(out, group=group) as ds:
            names = set(ds.data_vars) | set(ds.coords)
            assert names == set(stored)
            for name in stored:
                _bitwise(ds[name].values, stored[name], name)
            if group is None:
                assert ds["qpos"].dims == ("time", "qpos_index") and ds["qpos"].attrs["long_name"]
                assert ds.attrs["config_hash"] == stored.attrs["config_hash"]


def test_default_output_is_beside_the_store(run_dir):
    assert export.main(_args(str(run_dir), "--format", "netcdf")) == 0
    assert (run_dir / "timeseries.nc").is_file()


@pytest.mark.parametrize(
    "case,argv,match",
    [
        ("missing", ["{tmp}/nowhere"], "RUN_DIR: .*nowhere is missing"),
        ("file", ["{tmp}/afile"], "RUN_DIR: .*afile is a file, not a folder"),
        ("no store", ["{tmp}"], f"RUN_DIR: .* holds no {STORE_NAME}"),
        ("empty", [""], "RUN_DIR: must name a run folder"),
        ("format", ["{run}", "--format", "csv"], "--format: must be one of npz, netcdf, got 'csv'"),
        ("out dir", ["{run}", "--out", "{tmp}"], "--out: must name a file"),
        ("out parent", ["{run}", "--out", "{tmp}/no/such/x.npz"], "--out: folder .*no/such does not exist"),
    ],
)
def test_hostile_inputs_exit_2_naming_the_argument(run_dir, tmp_path, capsys, case, argv, match):
    (tmp_path / "afile").write_text("x")
    argv = [a.format(tmp=tmp_path, run=run_dir) for a in argv]
    assert export.main(_args(*argv)) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "Traceback" not in err
    assert re.search(match, err), err


def test_unreadable_store_exits_2(tmp_path, capsys):
    (tmp_path / STORE_NAME).mkdir()
    (tmp_path / STORE_NAME / "zarr.json").write_text("{not json")
    assert export.main(_args(str(tmp_path))) == 2
    assert "error: " in capsys.readouterr().err


def test_memory_limit_refuses_an_export_whose_chunks_exceed_it(run_dir, tmp_path, capsys):
    """Export streams a chunk's rows at a time: its estimate is the store's largest such block
    (from the metadata) times the blocks in flight plus a fixed part; a limit below it is exit 2
    naming the export and the limit, nothing written; the CLI's --memory-limit sets that limit."""
    from magsail_mj import cli
    from magsail_mj.records import chunk_block_bytes
    from magsail_mj.resources import EXPORT_BASE_BYTES, export_store_bytes

    block = chunk_block_bytes(lazy_arrays(run_dir))
    qpos = open_records(run_dir).array("qpos")
    assert block >= min(qpos.shape[0], qpos.chunks[0]) * qpos.shape[1] * 8 > 0
    need = export_store_bytes(block)
    assert need > EXPORT_BASE_BYTES
    out = tmp_path / "x.npz"
    code = cli.main(["export", str(run_dir), "--out", str(out), "--memory-limit", str(int(need) - 1)])
    err = capsys.readouterr().err
    assert code == 2 and "export" in err and "memory" in err.lower() and not out.exists(), err
    assert cli.main(["export", str(run_dir), "--out", str(out), "--memory-limit", str(int(need) + 1)]) == 0
    assert out.is_file()
