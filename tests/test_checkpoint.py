"""Data-only checkpoints: a snapshot written into a rebuilt object tree gives back the saved state."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.checkpoint import (
    CheckpointError,
    StateWalker,
    read_arrays,
    read_checkpoint,
    restore_state,
    write_arrays,
    write_checkpoint,
)
from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.export import read_timeseries

_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=False, allow_infinity=False),
    st.text(max_size=5),
)
_keys = st.one_of(st.text(alphabet='ab{}[]<>."\\ ', max_size=4), st.integers(-5, 5))
_arrays = st.builds(
    lambda shape, seed: np.random.default_rng(seed).normal(size=shape),
    st.lists(st.integers(0, 3), min_size=0, max_size=3).map(tuple),
    st.integers(0, 1000),
)
_leaves = st.one_of(_scalars, _arrays)
_trees = st.recursive(
    _leaves,
    lambda children: st.one_of(st.lists(children, max_size=4), st.dictionaries(_keys, children, max_size=4)),
    max_leaves=12,
)


def _equal(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape and np.array_equal(a, b)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b


@settings(max_examples=150, deadline=None)
@given(built=_trees, changed=_trees)
def test_restore_gives_back_any_changed_state(built, changed):
    """Build a tree, let the 'run' replace it by another one, checkpoint, rebuild and restore."""
    live = {"state": copy.deepcopy(built)}
    walker = StateWalker(live)
    walker.baseline()
    live["state"] = copy.deepcopy(changed)
    tree, arrays = walker.snapshot()
    rebuilt = StateWalker({"state": copy.deepcopy(built)})
    rebuilt.baseline()
    restore_state(rebuilt, tree, arrays)
    assert _equal(rebuilt.roots["state"], changed)


def test_arrays_are_restored_in_place_and_aliases_kept():
    shared = np.zeros(4)
    roots = {"a": {"x": shared}, "b": [shared]}
    walker = StateWalker(roots)
    walker.baseline()
    shared[:] = [1, 2, 3, 4]
    tree, arrays = walker.snapshot()
    fresh_shared = np.zeros(4)
    fresh = StateWalker({"a": {"x": fresh_shared}, "b": [fresh_shared]})
    restore_state(fresh, tree, arrays)
    assert fresh.roots["a"]["x"] is fresh_shared and fresh.roots["b"][0] is fresh_shared
    assert np.array_equal(fresh_shared, [1, 2, 3, 4])


def test_package_objects_and_rng_state_round_trip(tmp_path):
    rng = np.random.default_rng(7)
    fit = BestFitRotation(np.random.default_rng(1).normal(size=(6, 3)))
    walker = StateWalker({"fit": fit, "rng": rng, "late": None})
    walker.baseline()
    rng.normal(size=5)
    walker.roots["late"] = BestFitRotation(np.eye(3))  # an object created during the run
    tree, arrays = walker.snapshot()
    write_checkpoint(
        tmp_path / "c.npz", {"step": 3}, tree=tree, arrays=arrays, extra_arrays={"mj_state": np.arange(3.0)}
    )
    header, arrays, extra = read_checkpoint(tmp_path / "c.npz")
    fresh = StateWalker(
        {
            "fit": BestFitRotation(np.random.default_rng(1).normal(size=(6, 3))),
            "rng": np.random.default_rng(7),
            "late": None,
        }
    )
    restore_state(fresh, header["state_tree"], arrays)
    assert fresh.roots["rng"].normal() == rng.normal()
    assert isinstance(fresh.roots["late"], BestFitRotation)
    assert np.array_equal(extra["mj_state"], np.arange(3.0)) and header["step"] == 3


def test_a_different_build_is_refused():
    walker = StateWalker({"k": np.ones(3), "n": [1]})
    walker.baseline()
    walker.roots["n"][0] = 2
    tree, arrays = walker.snapshot()
    other = StateWalker({"k": np.full(3, 2.0), "n": [1]})  # a constant that differs: another build
    with pytest.raises(CheckpointError, match="differs from the rebuilt run"):
        restore_state(other, tree, arrays)


def test_files_hold_no_pickles(tmp_path):
    write_arrays(tmp_path / "a.npz", {"x": np.arange(4)}, header={"k": [1, "two"]})
    header, arrays = read_arrays(tmp_path / "a.npz")
    assert header == {"k": [1, "two"]} and np.array_equal(arrays["x"], np.arange(4))
    with pytest.raises(TypeError, match="object arrays"):
        write_arrays(tmp_path / "b.npz", {"x": np.array([object()])})
    (tmp_path / "c.npz").write_bytes(b"not a zip")
    with pytest.raises(CheckpointError, match="unreadable or truncated"):
        read_arrays(tmp_path / "c.npz")
    with pytest.raises(CheckpointError, match="does not exist"):
        read_arrays(tmp_path / "missing.npz")


def test_restoring_an_early_snapshot_into_live_objects_puts_back_build_values():
    """set_state semantics: a snapshot taken before a leaf changed restores the build value."""
    live = {"v": np.zeros(3), "s": [1, "a"], "rng": np.random.default_rng(3)}
    walker = StateWalker(live)
    walker.baseline()
    early_tree, early_arrays = walker.snapshot()
    draw = np.random.default_rng(3).normal()
    live["v"][:] = 5.0
    live["s"][0] = 9
    live["rng"].normal(size=4)
    restore_state(walker, early_tree, early_arrays)
    assert np.array_equal(live["v"], np.zeros(3)) and live["s"] == [1, "a"]
    assert walker.roots["rng"].normal() == draw


def test_cli_stop_then_resume_in_new_processes_is_bitwise(tmp_path):
    """Stop and resume from the command line, each in its own process (a checkpoint must not depend on
    the memory a build happened to get: scratch buffers made with np.empty once refused this resume)."""
    import subprocess
    import sys

    from tests.conftest import REPO

    def magsail(*args):
        config = str(REPO / "magsail_mj/concepts/cnusail/configs/nadir_pre.toml")
        return subprocess.run(
            [
                sys.executable,
                "-m",
                "magsail_mj.entry",
                "run",
                config,
                "--set",
                "sim.duration_s=40",
                "--no-progress",
                *args,
            ],
            capture_output=True,
            text=True,
            cwd=tmp_path,
            timeout=300,
        )

    assert magsail("--out", str(tmp_path / "full")).returncode == 0
    assert magsail("--out", str(tmp_path / "cut"), "--stop-after-s", "20").returncode == 0
    resumed = magsail("--out", str(tmp_path / "cut"), "--resume")
    assert resumed.returncode == 0, resumed.stderr
    a, b = read_timeseries(tmp_path / "full"), read_timeseries(tmp_path / "cut")
    assert sorted(a) == sorted(b)
    assert all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)
    # the manifest counts every step from t = 0, those before the checkpoint included, as it counts
    # their wall time: the resumed run reports the uninterrupted run's steps
    full, cut = (json.loads((tmp_path / name / "manifest.json").read_text()) for name in ("full", "cut"))
    assert cut["steps"] == full["steps"] == round(40.0 / full["config"]["sim"]["timestep_s"])
    assert cut["wall_time_s"] > 0


def test_an_alias_follows_a_leaf_put_back_as_built():
    """A leaf recorded as unchanged since the build but replaced since (another shape) is put back
    as a new array; an alias of it must reach that new array, not the replaced one."""
    shared = np.arange(3.0)
    live = {"a": {"x": shared}, "b": [shared]}
    walker = StateWalker(live)
    walker.baseline()
    early_tree, early_arrays = walker.snapshot()
    live["a"]["x"] = np.zeros(5)
    restore_state(walker, early_tree, early_arrays)
    assert np.array_equal(walker.roots["a"]["x"], np.arange(3.0))
    assert walker.roots["b"][0] is walker.roots["a"]["x"]
