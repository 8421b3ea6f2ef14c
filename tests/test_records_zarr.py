"""Records streamed to Zarr: units parser, store layout, lazy reading, flat memory, resume cut."""

from __future__ import annotations

import json
import shutil
import tracemalloc

import numpy as np
import pytest
import xarray as xr
import zarr

from magsail_mj.checkpoint import read_checkpoint
from magsail_mj.config import apply_overrides, parse_config
from magsail_mj.export import read_timeseries
from magsail_mj.records import (
    SERIES_GROUP,
    STORE_NAME,
    Recorder,
    StoreRecords,
    dims_of,
    open_records,
    store_length,
    units_of,
)
from magsail_mj.run import run_scenario


def _cfg(tree, *overrides):
    return parse_config(apply_overrides(tree, list(overrides)))


@pytest.mark.parametrize(
    "name,units,long_name",
    [
        ("omega_body_rad_s", "rad/s", "omega body"),
        ("psi_ddot_ref_rad_s2", "rad/s²", "psi ddot ref"),
        ("torque_gg_world_Nm", "N m", "torque gg world"),
        ("torque_cmd_body_Nm", "N m", "torque cmd body"),
        ("angmom_Nms", "N m s", "angmom"),
        ("dipole_cmd_Am2", "A m²", "dipole cmd"),
        ("com_world_m", "m", "com world"),
        ("strain_energy_J", "J", "strain energy"),
        ("theta_e_rad", "rad", "theta e"),
        ("v_m_s", "m/s", "v"),
        ("t", "s", "simulated time"),
        ("saturated", "1", "saturated"),
        ("p_e", "1", "p e"),
        ("s", "1", "s"),  # a lone token is a name, not a unit
    ],
)
def test_units_from_si_suffix(name, units, long_name):
    assert units_of(name) == (units, long_name)


def test_dims_named_per_probe():
    assert dims_of("qpos", (7,)) == ("qpos_index",)
    assert dims_of("omega_body_rad_s", (3,)) == ("axis",)
    assert dims_of("com_nodes_m", (5, 3)) == ("com_nodes_m_dim0", "axis")
    assert dims_of("q_e", (4,)) == ("q_e_dim0",)
    assert dims_of("mode", ()) == ()


NAMES = ["t", "mode", "w_rad_s", "grid_m"]


def _rows(n, seed=1):
    """n random records of a scalar int, a (3,) and a (2, 5) variable; 80 B for the widest."""
    rng = np.random.default_rng(seed)
    return [
        {"t": 0.5 * k, "mode": np.int8(k % 3), "w_rad_s": rng.normal(size=3), "grid_m": rng.normal(size=(2, 5))}
        for k in range(n)
    ]


def _reference(rows):
    return {k: np.array([r[k] for r in rows]) for k in NAMES}


def _equal(a, b):
    assert set(a) == set(b)
    for k in a:
        x, y = np.asarray(a[k]), np.asarray(b[k])
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k  # bitwise, NaN too


@pytest.mark.parametrize("cut", [0, 3, 5, 12, 17, 20])
def test_memory_and_store_recorders_equal_bitwise_through_truncation(tmp_path, cut):
    """Records cut at ``cut`` (inside the buffer, on a chunk boundary, inside an earlier chunk)
    and continued give the same arrays, in memory and in the store, as the list of records kept;
    the chunk length is 400 B // 80 B = 5 records."""
    rows = _rows(30)
    mem, sto = Recorder(NAMES, chunk_bytes=400, min_chunk=2), Recorder(NAMES, chunk_bytes=400, min_chunk=2)
    sto.create_store(tmp_path / "s.zarr", attrs={"config_hash": "x"})
    for rec in (mem, sto):
        for r in rows[:20]:
            rec.append(r)
        rec.truncate(cut)
        for r in rows[20:]:
            rec.append(r)
    assert mem.chunk == sto.chunk == 5 and len(mem) == len(sto) == cut + 10
    want = _reference(rows[:cut] + rows[20:])
    _equal(mem.arrays(), want)
    _equal(dict(sto.arrays()), want)
    assert store_length(tmp_path / "s.zarr") == cut + 10


def test_store_continued_from_a_count_equals_uninterrupted(tmp_path):
    """open_store(path, n) (a resume) cuts the store to n records and continues it: equal bitwise
    to a store written without the detour, rows beyond n written before included."""
    rows = _rows(23, seed=2)
    a = Recorder(NAMES, chunk_bytes=400)
    a.create_store(tmp_path / "a.zarr")
    for r in rows:
        a.append(r)
    a.flush()
    b = Recorder(NAMES, chunk_bytes=400)
    b.create_store(tmp_path / "b.zarr")
    for r in rows[:19]:
        b.append(r)
    b.flush()  # 19 records stored; the checkpoint below says 12
    c = Recorder(NAMES, chunk_bytes=400)
    c.open_store(tmp_path / "b.zarr", 12)
    assert store_length(tmp_path / "b.zarr") == 12
    for r in rows[12:]:
        c.append(r)
    _equal(dict(a.arrays()), dict(c.arrays()))
    with pytest.raises(Exception, match="fewer records"):
        Recorder(NAMES).open_store(tmp_path / "b.zarr", 24)


def test_int_probe_that_turns_float_is_widened_not_cut(tmp_path):
    """A probe whose first value is an int and a later one a float keeps the float exactly."""
    rec = Recorder(["t", "x"], chunk_bytes=8, min_chunk=2)
    rec.create_store(tmp_path / "s.zarr")
    for k, x in enumerate([0, 1, 2, 2.75, 3]):
        rec.append({"t": float(k), "x": x})
    got = rec.arrays()["x"]
    assert got.dtype == np.float64 and np.array_equal(got, [0, 1, 2, 2.75, 3])


def test_non_finite_values_are_found_in_flushed_chunks():
    rec = Recorder(["t", "x"], chunk_bytes=16, min_chunk=2)
    for k in range(9):
        rec.append({"t": 0.1 * k, "x": np.inf if k == 5 else 1.0})
    assert rec.non_finite() == ("x", 0.1 * 5)
    rec.truncate(5)
    assert rec.non_finite() is None


def test_store_layout_dims_units_attrs_read_by_xarray(tmp_path, small_truss_tree):
    """timeseries.zarr of a run opens with xarray.open_zarr: dimension ``time`` with coordinate
    ``t`` [s], per-probe dimensions, units and long names, config hash, versions and status."""
    out = run_scenario(_cfg(small_truss_tree, "sim.duration_s=2.0"), tmp_path / "run")
    store = out.run_dir / STORE_NAME
    ds = xr.open_zarr(store)
    assert ds["qpos"].dims == ("time", "qpos_index") and ds["t"].dims == ("time",)
    assert "t" in ds.coords and ds["t"].attrs["units"] == "s"
    assert ds.sizes["time"] == 2.0 / 0.1 / 5 + 1
    assert np.array_equal(ds["t"].values, np.arange(ds.sizes["time"]) * 0.5)
    for name, var in ds.data_vars.items():
        assert var.dims[0] == "time" and {"units", "long_name"} <= set(var.attrs), name
    manifest_hash = json.loads((out.run_dir / "manifest.json").read_text())["config_hash"]
    assert ds.attrs["config_hash"] == manifest_hash and ds.attrs["status"] == "completed"
    assert ds.attrs["version_numpy"] == np.__version__ and "version_mujoco" in ds.attrs
    series = xr.open_zarr(store, group=SERIES_GROUP)
    assert series.sizes["time"] == ds.sizes["time"]
    # what analysis scripts read (records, the series replacing records of their name) is the same numbers
    ts = read_timeseries(out.run_dir)
    assert np.array_equal(ts["qpos"], ds["qpos"].values) and set(ts) == set(ds.variables) | set(series.variables)
    for name in series.data_vars:
        assert np.array_equal(ts[name], series[name].values, equal_nan=True), name


def test_store_records_read_each_variable_on_first_access(tmp_path):
    """StoreRecords reads a variable when it is first asked for (a value changed on disk after
    opening is seen), then keeps it; it is read-only."""
    rec = Recorder(["t", "a", "b"])
    rec.create_store(tmp_path / "s.zarr")
    for k in range(4):
        rec.append({"t": float(k), "a": float(k), "b": -float(k)})
    rec.flush()
    lazy = StoreRecords(tmp_path / "s.zarr")
    assert list(lazy) == ["t", "a", "b"]
    zarr.open_group(str(tmp_path / "s.zarr"), mode="r+", use_consolidated=False)["b"][0] = 42.0
    assert lazy["b"][0] == 42.0 and lazy["a"][3] == 3.0
    with pytest.raises(TypeError):
        lazy["a"] = np.zeros(4)  # type: ignore[index]


def _peak_bytes(n_records, *, store):
    rec = Recorder(["t", "qpos"], chunk_bytes=1 << 16)
    if store is not None:
        rec.create_store(store)
    row = np.ones(2000)
    tracemalloc.start()
    for k in range(n_records):
        rec.append({"t": float(k), "qpos": row})
    if store is not None:
        rec.flush()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak


def test_record_memory_flat_in_run_length(tmp_path):
    """Streaming 4N records of 16 kB peaks within 1.2x of N records (the buffer of one chunk,
    64 kB // 16 kB = 4 records, plus zarr's write buffers), while the in-memory recorder grows
    about 4x (so the measurement can tell)."""
    n = 300
    flat = [_peak_bytes(k, store=tmp_path / f"s{k}.zarr") for k in (n, 4 * n)]
    grown = [_peak_bytes(k, store=None) for k in (n, 4 * n)]
    assert flat[1] <= 1.2 * flat[0], flat
    assert grown[1] >= 3.0 * grown[0], grown
    assert flat[1] < 0.2 * grown[1]


def test_resume_cuts_the_store_to_the_checkpoint_count(tmp_path, small_truss_tree):
    """A run stopped at 4 s, continued to 7 s (its store now longer than the 4 s checkpoint says)
    and resumed from the 4 s checkpoint equals the uninterrupted run bitwise (records and
    series); the checkpoint carries no records: its size is the same at 4 s and 7 s (±64 B)."""
    cfg = _cfg(small_truss_tree, "sim.duration_s=10.0")
    full = run_scenario(cfg, tmp_path / "full")
    cut = tmp_path / "cut"
    run_scenario(cfg, cut, stop_after_s=4.0)
    shutil.copy(cut / "checkpoint.npz", tmp_path / "ckpt4.npz")
    header4 = read_checkpoint(cut / "checkpoint.npz")[0]
    run_scenario(cfg, cut, resume=True, stop_after_s=7.0)
    assert store_length(cut / STORE_NAME) > header4["n_records"] == 8
    size4, size7 = (tmp_path / "ckpt4.npz").stat().st_size, (cut / "checkpoint.npz").stat().st_size
    assert abs(size7 - size4) <= 64, (size4, size7)
    shutil.copy(tmp_path / "ckpt4.npz", cut / "checkpoint.npz")
    resumed = run_scenario(cfg, cut, resume=True)
    assert resumed.status == full.status == "completed"
    for group in (None, SERIES_GROUP):
        a, b = open_records(full.run_dir, group=group), open_records(cut, group=group)
        _equal(dict(a), dict(b))


def test_column_before_the_first_chunk_reaches_the_store(tmp_path):
    """A run that diverges before its first chunk is stored searches its times in the buffer."""
    rec = Recorder(["t", "x"])
    rec.create_store(tmp_path / "s.zarr")
    for k in range(3):
        rec.append({"t": 0.1 * k, "x": float(k)})
    assert np.array_equal(rec.column("t"), [0.0, 0.1, 0.2])
    rec.truncate(int(np.searchsorted(rec.column("t"), 0.15)))
    assert np.array_equal(rec.arrays()["x"], [0.0, 1.0])
