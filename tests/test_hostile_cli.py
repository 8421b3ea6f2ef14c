"""Hostile inputs to the ``magsail`` CLI: never a traceback, exit statuses of the table, memory bounds.

Every verb is called in-process through :func:`magsail_mj.cli.main` with ``capsys``. The
property-based part (hypothesis) draws random strings, empty strings, non-finite, huge, negative
and zero numbers, missing files, folders, files where folders are expected and paths below a
regular file (which fail for root too), and checks: the exit status is 0, 1, 2 or 3; no exception
escapes; exit 2 comes with a line ``error: ...`` on stderr; exit 0 prints JSON with finite numbers
only where the verb prints JSON. Runs are 2 steps of a 3 × 3 lattice; a fixed ``--memory-limit``
keeps the analytic verbs from spending seconds on valid but large inputs.
"""

from __future__ import annotations

# The GL backend is chosen before mujoco is imported (MUJOCO_GL is read at import time): pytest
# imports tests/conftest.py, which calls ensure_gl_backend(), before it imports this module.
import errno
import json
import os
import signal
import time
import tracemalloc
from collections.abc import Iterable
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from magsail_mj.io import file_sha256
from magsail_mj import cli, load
from magsail_mj.export import read_timeseries
from magsail_mj.lattice.modes import lattice_modes
from magsail_mj.cli import EXIT_CODES, main
from magsail_mj.config import load_config
from magsail_mj.environment.environment import Environment
from magsail_mj.control.lloyd import LloydSelector
from magsail_mj.lattice.geometry import make_lattice
from magsail_mj.lattice.mjcf import lattice_arena_bytes
from magsail_mj.records import STORE_NAME, write_group
from magsail_mj.resources import (
    ENV_VAR,
    MemoryLimitError,
    available_memory_bytes,
    check_memory,
    environment_bytes,
    estimate_model_bytes,
    estimate_run_bytes,
    explicit_arena_mujoco_bytes,
    lattice_counts,
    lattice_model_bytes,
    memory_limit,
    memory_limit_bytes,
    mjcf_arena_bytes,
    mjcf_model_bytes,
    mujoco_bytes,
    parse_memory_limit,
)
from magsail_mj.run import run_scenario
from magsail_mj.scenario import build_scenario
from tests.conftest import start_cli

REPO = Path(__file__).resolve().parents[1]
CONFIG = str(REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.toml")
STRUCTURE_FILE = str(REPO / "magsail_mj/concepts/structure/configs/structures/sail_100m.toml")
TINY = ["--set", "lattice.units=3", "--set", "sim.duration_s=0.2", "--set", "sim.record_every=1"]
JSON_VERBS = ("build", "validate", "run", "sweep", "scaling", "torque", "modes")
FUZZ = settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


# --------------------------------------------------------------------------- helpers


@pytest.fixture(autouse=True)
def _in_scratch_folder(tmp_path, monkeypatch):
    """Relative paths drawn by the fuzz land in a scratch folder, never in the repository."""
    monkeypatch.chdir(tmp_path)


def _strict_json(text: str):
    """Parse JSON, refusing NaN/Infinity (only finite numbers are allowed)."""

    def refuse(token: str):
        raise AssertionError(f"non-finite number {token} in the output")

    return json.loads(text, parse_constant=refuse)


def call(capsys, argv: list[str]) -> tuple[int, str, str]:
    """``main(argv)`` with the checks every call must pass; returns (status, stdout, stderr)."""
    capsys.readouterr()
    rc = main(argv)
    out, err = capsys.readouterr()
    assert rc in (0, 1, 2, 3), (argv, rc, err)
    assert "Traceback" not in err, (argv, err)
    if rc == 2:
        assert any(line.startswith("error:") for line in err.splitlines()), (argv, err)
    verb = argv[2] if argv[:1] == ["--memory-limit"] and len(argv) > 2 else (argv or [""])[0]
    if rc == 0 and verb in JSON_VERBS and "--help" not in argv:
        _strict_json(out)
    return rc, out, err


@pytest.fixture(scope="module")
def arena(tmp_path_factory) -> SimpleNamespace:
    """Files and folders the fuzz draws from, and one tiny finished run folder."""
    root = tmp_path_factory.mktemp("hostile")
    plain = root / "plain.txt"
    plain.write_text("not a folder\n")
    binary = root / "binary.toml"
    binary.write_bytes(bytes(range(256)) * 4)
    folder = root / "folder"
    folder.mkdir()
    empty_toml = root / "empty.toml"
    empty_toml.write_text("")
    sweep = root / "sweep.toml"
    sweep.write_text(
        f'name = "tiny"\n[[run]]\nid = "a"\nconfig = "{CONFIG}"\n'
        'set = ["lattice.units=3", "sim.duration_s=0.2", "sim.record_every=1"]\n'
    )
    run = root / "run"
    assert main(["run", CONFIG, "--out", str(run), "--no-progress", *TINY]) == 0
    return SimpleNamespace(
        root=root,
        plain=plain,
        binary=binary,
        folder=folder,
        empty_toml=empty_toml,
        sweep=sweep,
        run=run,
        below_file=plain / "sub" / "x",
    )


def paths(arena: SimpleNamespace, *, suffix: str = "") -> st.SearchStrategy[str]:
    """Hostile path strings: empty, blank, random text, missing, a folder, a file, below a file."""
    return st.one_of(
        st.sampled_from(["", " ", ".", "..", "/", "\t"]),
        st.text(min_size=1, max_size=12).filter(lambda s: "\x00" not in s),
        st.sampled_from(
            [
                str(arena.root / f"missing{suffix}"),
                str(arena.folder),
                str(arena.plain),
                str(arena.below_file) + suffix,
                str(arena.binary),
                str(arena.empty_toml),
            ]
        ),
    )


NUMBERS = st.one_of(
    st.floats(min_value=0.5, max_value=500).map(lambda x: repr(round(x, 3))),  # mostly valid
    st.integers(min_value=1, max_value=40).map(str),
    st.sampled_from(
        [
            "",
            "nan",
            "inf",
            "-inf",
            "0",
            "-0",
            "-1",
            "1e308",
            "1e-308",
            "-1e308",
            "abc",
            "1e6",
            "0x10",
            "1_000",
            " 5",
            "1e-3",
            "3",
            "2.5",
            "19",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.integers(min_value=-(10**12), max_value=10**12).map(str),
)


def opt(name: str, value: str) -> list[str]:
    """``--name=value`` (a value starting with '-' is still a value)."""
    return [f"{name}={value}"]


def call_limited(capsys, argv: list[str], options: Iterable[tuple[str, str]] = ()) -> tuple[int, str, str]:
    """:func:`call` of ``argv`` followed by ``--name=value`` for each ``(name, value)`` of ``options``,
    under a 64 MB memory limit."""
    return call(capsys, ["--memory-limit", "64M", *argv, *(arg for name, value in options for arg in opt(name, value))])


# --------------------------------------------------------------------------- the memory mechanism


def test_memory_limit_sources_and_parsing(monkeypatch):
    assert available_memory_bytes() > 0
    assert parse_memory_limit("auto") is None
    assert parse_memory_limit("2G") == 2 << 30 and parse_memory_limit("512m") == 512 << 20
    assert parse_memory_limit("1e9") == 10**9
    for bad in ("", "-1", "0", "lots", "1e400", "nan", "2 GB GB"):
        with pytest.raises(ValueError, match="--memory-limit"):
            parse_memory_limit(bad)
    monkeypatch.setenv(ENV_VAR, "3M")
    assert memory_limit_bytes() == 3 << 20
    with memory_limit(5 << 20):
        assert memory_limit_bytes() == 5 << 20  # the CLI option beats the environment
    monkeypatch.setenv(ENV_VAR, "auto")
    assert memory_limit_bytes() > 0
    monkeypatch.setenv(ENV_VAR, "junk")
    with pytest.raises(ValueError, match=ENV_VAR):
        memory_limit_bytes()
    with pytest.raises(MemoryLimitError, match=r"thing: needs about 2 KiB .* limit of 1 KiB"):
        check_memory(2048, what="thing", limit=1024)
    assert check_memory(1000, what="thing", limit=1024) == 1000


def test_lattice_counts_match_the_lattice_builder():
    for units in (1, 2, 5):
        for diagonals in ("parity", "X"):
            lat = make_lattice(units=units, side_m=1.0, diagonals=diagonals)
            assert lattice_counts(units, diagonals=diagonals) == (lat.n_nodes, lat.n_struts)


@pytest.mark.parametrize(
    "config, overrides",
    [
        ("magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", ["lattice.units=8"]),
        ("magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", ["lattice.units=6", "lattice.diagonals=X"]),
        ("magsail_mj/concepts/current_loops/configs/slew.toml", ["lattice.units=12"]),
    ],
)
def test_lattice_mujoco_estimate_within_10_percent(config, overrides):
    """A lattice's MuJoCo part (buffers and the arena the builder sets, from the config's counts)
    against MjModel + MjData + arena of the build (the buffer fit is within 1 %), and the whole
    model estimate is above it."""
    cfg = load_config(REPO / config, overrides)
    nodes, struts = lattice_counts(cfg.lattice.units, diagonals=cfg.lattice.diagonals)
    model = build_scenario(cfg).spec.compile()
    data = mujoco.MjData(model)
    measured = model.nbuffer + data.nbuffer + data.narena
    assert data.narena == lattice_arena_bytes(3 * nodes)
    estimate = explicit_arena_mujoco_bytes(nv=3 * nodes + 6, ntendon=struts, arena_bytes=lattice_arena_bytes(3 * nodes))
    assert measured <= estimate <= 1.1 * measured, (estimate, measured)
    assert estimate_model_bytes(cfg) > estimate


def test_default_arena_estimate_within_a_factor_3_of_mujoco():
    """The rigid models keep MuJoCo's default arena: :func:`mujoco_bytes` against the build."""
    cfg = load_config(REPO / "magsail_mj/concepts/reflector/configs/detumble.toml")
    model = build_scenario(cfg).spec.compile()
    data = mujoco.MjData(model)
    measured = model.nbuffer + data.nbuffer + data.narena
    estimate = estimate_model_bytes(cfg)
    assert measured / 3 <= estimate <= 3 * measured, (estimate, measured)


@pytest.mark.parametrize("integrator", ["Euler", "RK4", "implicit", "implicitfast"])
def test_lattice_arena_is_linear_in_nv_and_8_times_what_a_step_uses(integrator):
    """The arena the lattice builder sets grows with nv (MuJoCo's default grows with nv²: 49 MB at
    nv = 486) and holds at least 8 times what a step uses with every integrator."""
    cfg = load_config(
        REPO / "magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml",
        ["lattice.units=8", f"sim.integrator={integrator}"],
    )
    model = build_scenario(cfg).spec.compile()
    data = mujoco.MjData(model)
    data.qvel[:] = 1e-3
    for _ in range(3):
        mujoco.mj_step(model, data)
    assert data.narena == lattice_arena_bytes(model.nv) < 5_000 * model.nv + (1 << 20)
    assert 8 * data.maxuse_arena <= data.narena, (data.maxuse_arena, data.narena)


def test_current_loop_modes_estimate_against_tracemalloc():
    """The current-loop lattice's Python side (build, loads, dense modal matrices) grows by about
    40 B·nv²; the estimate's growth from N = 8 to N = 14 is within a factor 3 of the traced one."""
    config = REPO / "magsail_mj/concepts/current_loops/configs/sweep/b_n19_ei1e4.toml"
    peaks, estimates = [], []
    for units in (8, 14):
        cfg = load_config(config, [f"lattice.units={units}"])
        nodes, struts = lattice_counts(units)
        tracemalloc.start()
        load(cfg).step()
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
        estimates.append(lattice_model_bytes(nv=3 * nodes + 6, ntendon=struts, dense_modes=True))
    grown, estimated = peaks[1] - peaks[0], estimates[1] - estimates[0]
    assert grown / 3 <= estimated <= 3 * grown, (estimated, grown)


def test_mjcf_estimate_reads_the_arena_the_file_sets(tmp_path):
    xml = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.xml"
    model = mujoco.MjModel.from_xml_path(str(xml))
    data = mujoco.MjData(model)
    assert mjcf_arena_bytes(xml) == data.narena
    estimate, nbody = mjcf_model_bytes(xml)
    measured = model.nbuffer + data.nbuffer + data.narena
    assert nbody == model.nbody and measured <= estimate <= 1.1 * measured, (estimate, measured)
    plain = tmp_path / "plain.xml"
    plain.write_text('<mujoco><worldbody><body><joint type="slide"/><geom size="1"/></body></worldbody></mujoco>')
    assert mjcf_arena_bytes(plain) is None
    assert mjcf_model_bytes(plain)[0] == mujoco_bytes(nv=1, nbody=2, ntendon=0)
    (tmp_path / "m.xml").write_text('<mujoco><size memory="2M"/></mujoco>')
    assert mjcf_arena_bytes(tmp_path / "m.xml") == 2 << 20


def test_environment_grid_estimate_against_tracemalloc():
    """The orbital environment grid (IGRF along the orbit) is part of the model estimate: within a
    factor 2 of the measured peak for 2 000 rows, and a 1e11 s orbit is refused before any grid."""
    cfg = load_config(REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", ["sim.duration_s=20000"])
    tracemalloc.start()
    Environment.from_config(cfg.environment_config(), duration_s=cfg.sim.duration_s)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak / 2 <= environment_bytes(cfg) <= 2 * peak, (environment_bytes(cfg), peak)
    long = load_config(
        REPO / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml",
        ["sim.duration_s=1e11", "sim.timestep_s=10", "sim.record_every=1000000000"],
    )
    with pytest.raises(MemoryLimitError, match="needs about"):
        check_memory(estimate_run_bytes(long), what="run", limit=1e12)


def test_huge_lattice_is_refused_fast_without_allocating(capsys):
    """units = 100000 (schema limit or not) is refused, and the schema's largest lattice (200:
    242 406 dofs, 5 GiB estimated) on a 2 GiB limit, in well under a second; the estimate itself
    needs no build."""
    t0 = time.perf_counter()
    fake = SimpleNamespace(
        concept="truss_magnetorquer", scenario="detumble", lattice=SimpleNamespace(units=100_000, diagonals="parity")
    )
    with pytest.raises(MemoryLimitError, match="needs about"):
        check_memory(estimate_model_bytes(fake), what="lattice.units=100000")
    for units in (100_000, 200):
        for verb in ("validate", "build"):
            rc, _, err = call(capsys, ["--memory-limit", "2G", verb, CONFIG, "--set", f"lattice.units={units}"])
            assert rc == 2 and ("lattice.units" in err or "needs about" in err), err
    argv = ["--memory-limit", "2G", "run", CONFIG, "--out", "/nonexistent-never-made", "--set", "lattice.units=200"]
    rc, _, err = call(capsys, argv)
    assert rc == 2
    assert time.perf_counter() - t0 < 1.0


def test_memory_limit_option_reaches_every_verb(capsys, arena):
    for argv in (
        ["validate", CONFIG, *TINY],
        ["build", CONFIG, "-o", str(arena.root / "m.xml"), *TINY],
        ["run", CONFIG, "--out", str(arena.root / "r"), *TINY],
        ["sweep", str(arena.sweep)],
        ["render", str(arena.run), "-o", str(arena.root / "v.mp4")],
        ["torque", "coil"],
        ["scaling", "loops", "--geometry", "B"],
        ["scaling", "magnetorquer", "--side-m", "75", "--kappa", "100"],
    ):
        rc, _, err = call(capsys, ["--memory-limit", "100", *argv])
        assert rc == 2 and "limit of 100 B" in err, (argv, err)
        assert not (arena.root / "m.xml").exists() and not (arena.root / "v.mp4").exists()


# --------------------------------------------------------------------------- fixed hostile cases


def test_help_of_every_verb_shows_the_exit_table(capsys):
    for argv in (
        [],
        ["build"],
        ["validate"],
        ["run"],
        ["render"],
        ["sweep"],
        ["scaling"],
        ["scaling", "magnetorquer"],
        ["scaling", "loops"],
        ["torque"],
        ["torque", "coil"],
    ):
        capsys.readouterr()
        assert main([*argv, "--help"]) == 0
        out = capsys.readouterr().out
        assert "130  interrupted" in out and "3    the simulation diverged" in out, argv
        assert "sweep: non-zero when any run failed" in out
    assert "--memory-limit" in EXIT_CODES


def test_bad_config_files_exit_2(capsys, arena):
    for path, match in (
        (arena.binary, "not UTF-8"),
        (arena.folder, "config"),
        ("", "config: must be a path"),
        (arena.below_file, "config"),
        (arena.root / "missing.toml", "config"),
    ):
        for verb in ("validate", "build"):
            rc, _, err = call(capsys, [verb, str(path)])
            assert rc == 2 and match in err, (path, err)


@pytest.mark.skipif(IS_ROOT, reason="root reads files whatever their mode")
def test_unreadable_config_exits_2(capsys, arena, tmp_path):
    config = tmp_path / "c.toml"
    config.write_text(Path(CONFIG).read_text())
    config.chmod(0)
    rc, _, err = call(capsys, ["validate", str(config)])
    assert rc == 2 and "not readable" in err


def test_output_paths_are_checked(capsys, arena):
    committed = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_a_central_bangbang.xml"
    before = committed.read_bytes() if committed.exists() else None
    cases = [
        (["build", CONFIG, "-o", "", *TINY], "--output: must be a path"),
        (["build", CONFIG, "-o", str(arena.folder), *TINY], "is a folder"),
        (["build", CONFIG, "-o", str(arena.below_file), *TINY], "is a file"),
        (["run", CONFIG, "--out", "", *TINY], "--out: must be a path"),
        (["run", CONFIG, "--out", str(arena.plain), *TINY], "is not a folder"),
        (["run", CONFIG, "--out", str(arena.below_file), *TINY], "is a file"),
        (["sweep", str(arena.sweep), "--out", ""], "--out: must be a path"),
        (["sweep", str(arena.sweep), "--out", str(arena.below_file)], "is a file"),
        (["run", CONFIG, "--out", str(arena.root / "never"), "--resume", *TINY], "--resume"),
    ]
    for argv, match in cases:
        rc, _, err = call(capsys, argv)
        assert rc == 2 and match in err, (argv, err)
    after = committed.read_bytes() if committed.exists() else None
    assert after == before  # build -o '' never falls back to the committed MJCF


@pytest.mark.skipif(IS_ROOT, reason="root writes into read-only folders")
def test_read_only_folders_exit_2(capsys, tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        for argv in (["build", CONFIG, "-o", str(ro / "m.xml"), *TINY], ["run", CONFIG, "--out", str(ro / "r"), *TINY]):
            rc, _, err = call(capsys, argv)
            assert rc == 2 and "not writable" in err, err
    finally:
        ro.chmod(0o700)


def test_render_errors_exit_2(capsys, arena, tmp_path):
    no_qpos = tmp_path / "no_qpos"
    no_qpos.mkdir()
    for name in ("model.xml", "manifest.json"):
        (no_qpos / name).write_bytes((arena.run / name).read_bytes())
    arrays = {k: v for k, v in read_timeseries(arena.run).items() if k != "qpos"}
    write_group(no_qpos / STORE_NAME, arrays, n_time=len(arrays["t"]))  # a record store without positions
    manifest = json.loads((no_qpos / "manifest.json").read_text())  # listing the files as they now are
    manifest["files"] = {name: file_sha256(no_qpos / name) for name in ("model.xml", STORE_NAME)}
    manifest.pop("records_digests", None)
    (no_qpos / "manifest.json").write_text(json.dumps(manifest))
    cases = [
        ([str(tmp_path / "missing"), "-o", str(tmp_path / "v.mp4")], "RUN_DIR: no such folder"),
        ([str(no_qpos), "-o", str(tmp_path / "v.mp4")], "series 'qpos' is missing"),
        ([str(arena.run), "-o", str(tmp_path / "x.avi")], "--output: only MP4"),
        ([str(arena.run), "-o", ""], "--output: must be a path"),
        ([str(arena.run), "-o", str(arena.below_file) + ".mp4"], "is a file"),
        ([str(arena.run), "-o", str(tmp_path / "v.mp4"), "--compare", str(arena.plain)], "--compare: is a file"),
        (["", "-o", str(tmp_path / "v.mp4")], "RUN_DIR: must be a path"),
    ]
    for argv, match in cases:
        rc, _, err = call(capsys, ["render", *argv])
        assert rc == 2 and match in err, (argv, err)
    assert not (tmp_path / "v.mp4").exists()


def test_truncated_checkpoint_refuses_resume(capsys, tmp_path):
    sets = ["lattice.units=3", "sim.duration_s=0.4", "sim.record_every=1"]
    out = tmp_path / "run"
    run_scenario(load_config(CONFIG, sets), out, stop_after_s=0.2, progress=False)
    checkpoints = sorted(out.glob("checkpoint*"))
    assert checkpoints
    for path in checkpoints:
        path.write_bytes(path.read_bytes()[:50])
    rc, _, err = call(
        capsys,
        ["run", CONFIG, "--out", str(out), "--resume", "--no-progress", *[x for s in sets for x in ("--set", s)]],
    )
    assert rc == 2 and "checkpoint" in err


def test_corrupt_lloyd_cache_is_recomputed_and_rewritten(tmp_path):
    sites = [np.random.default_rng(0).uniform(0, 1, (12, 2))]
    first = LloydSelector(sites, region=(0, 0, 1, 1), cache_dir=tmp_path, max_iter=200).selected(0, 5).copy()
    files = sorted(tmp_path.rglob("*.np[yz]"))
    assert {f.suffix for f in files} == {".npy", ".npz"}
    for f in files:
        f.write_bytes(f.read_bytes()[:40])  # truncated
    again = LloydSelector(sites, region=(0, 0, 1, 1), cache_dir=tmp_path, max_iter=200)
    assert np.array_equal(again.selected(0, 5), first) and again.stats["lloyd_runs"] == 1
    third = LloydSelector(sites, region=(0, 0, 1, 1), cache_dir=tmp_path, max_iter=200)
    assert np.array_equal(third.selected(0, 5), first) and third.stats["snap_disk_hits"] == 1
    np.save(files[0] if files[0].suffix == ".npy" else files[1], np.array([0, 0, 99]))  # wrong content
    fourth = LloydSelector(sites, region=(0, 0, 1, 1), cache_dir=tmp_path, max_iter=200)
    assert np.array_equal(fourth.selected(0, 5), first)


def test_non_finite_results_are_errors(capsys):
    rc, out, err = call(capsys, ["scaling", "magnetorquer", "--side-m", "1e308", "--kappa", "1e-308"])
    assert rc == 2 and out == "" and "not finite" in err and "side_m" in err and "1e+308" in err


def test_interrupt_and_unexpected_errors(capsys, monkeypatch):
    def interrupted(args):
        raise KeyboardInterrupt

    def broken(args):
        raise RuntimeError("boom")

    monkeypatch.setattr(cli, "_cmd_torque_coil", interrupted)
    rc = main(["torque", "coil"])
    err = capsys.readouterr().err
    assert rc == 130 and err == "interrupted\n"
    monkeypatch.setattr(cli, "_cmd_torque_coil", broken)
    monkeypatch.delenv(cli.DEBUG_ENV, raising=False)
    assert main(["torque", "coil"]) == 1
    err = capsys.readouterr().err
    assert err == "error: internal error: RuntimeError: boom\n"
    monkeypatch.setenv(cli.DEBUG_ENV, "1")
    assert main(["torque", "coil"]) == 1
    assert "Traceback" in capsys.readouterr().err


def test_sigterm_exits_130_without_traceback(tmp_path):
    """A long run stopped by SIGTERM: exit 130, one line 'interrupted', no traceback."""
    long_run = ["lattice.units=3", "sim.duration_s=1e5", "sim.record_every=100"]
    proc = start_cli(
        ["run", CONFIG, "--out", str(tmp_path / "r"), "--no-progress", *(a for o in long_run for a in ("--set", o))],
        cwd=REPO,
    )
    try:
        deadline = time.monotonic() + 60
        while not (tmp_path / "r" / "model.xml").exists() and time.monotonic() < deadline:
            time.sleep(0.1)
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert "Traceback" not in err and err.strip().splitlines()[-1] == "interrupted"


# --------------------------------------------------------------------------- property-based fuzz


@FUZZ
@given(data=st.data())
def test_fuzz_validate_and_build(capsys, arena, data):
    verb = data.draw(st.sampled_from(["validate", "build"]))
    config = data.draw(st.one_of(st.just(CONFIG), st.just(CONFIG), paths(arena, suffix=".toml")))
    argv = [verb, config]
    for _ in range(data.draw(st.integers(0, 2))):
        key = data.draw(
            st.sampled_from(
                [
                    "lattice.units",
                    "sim.duration_s",
                    "sim.timestep_s",
                    "mass.total_kg",
                    "stiffness.EI_Nm2",
                    "nope",
                    "",
                    "lattice",
                ]
            )
        )
        argv += ["--set", f"{key}={data.draw(NUMBERS)}"]
    if verb == "build":
        out = data.draw(st.one_of(st.just("ok.xml"), paths(arena, suffix=".xml")))
        argv += ["-o", out]
    call(capsys, ["--memory-limit", "2G", *argv, *TINY[:2]])


@FUZZ
@given(data=st.data())
def test_fuzz_modes(capsys, arena, data):
    """``magsail modes`` with hostile sources and ``--set`` values: a config takes them as ``run``
    does (the lattice kept small by a last ``--set lattice.units=3``), a structure file refuses any
    ``--set`` by name; never an exception."""
    source = data.draw(st.one_of(st.just(CONFIG), st.just(STRUCTURE_FILE), paths(arena, suffix=".toml")))
    argv = ["modes", source, "--count", data.draw(st.sampled_from(["8", "1", "0", "-2", "x"]))]
    for _ in range(data.draw(st.integers(0, 2))):
        keys = ["lattice.units", "stiffness.EI_Nm2", "mass.total_kg", "sim.timestep_s", "nope", "", "lattice"]
        argv += ["--set", f"{data.draw(st.sampled_from(keys))}={data.draw(NUMBERS)}"]
    if source == CONFIG:
        argv += TINY[:2]
    rc, out, err = call(capsys, ["--memory-limit", "2G", *argv])
    if source == STRUCTURE_FILE and "--set" in argv and argv[3] == "8":
        assert rc == 2 and err.startswith("error: --set:") and out == "", err


@settings(
    max_examples=6,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_fuzz_run(capsys, arena, data):
    out = data.draw(st.one_of(paths(arena), st.just(str(arena.root / "fuzz_run"))))
    extra = data.draw(
        st.sampled_from(
            [
                [],
                ["--overwrite"],
                ["--resume"],
                ["--set", "sim.timestep_s=nan"],
                ["--set", "sim.duration_s=-1"],
                ["--set", "sim.record_every=0"],
            ]
        )
    )
    call(capsys, ["--memory-limit", "2G", "run", CONFIG, "--out", out, "--no-progress", *TINY, *extra])


@FUZZ
@given(data=st.data())
def test_fuzz_render(capsys, arena, data):
    run_dir = data.draw(st.one_of(st.just(str(arena.run)), paths(arena)))
    out = data.draw(st.one_of(st.just("v.mp4"), paths(arena, suffix=".mp4"), st.sampled_from(["x.avi", "v.MP4x"])))
    argv = ["render", run_dir, "-o", out]
    if data.draw(st.integers(0, 3)) == 0:
        argv += ["--compare", data.draw(st.one_of(st.just(str(arena.run)), paths(arena)))]
    rc, _, _ = call(capsys, ["--memory-limit", "2G", *argv])
    assert rc != 0 or Path(out).suffix.lower() == ".mp4"


@settings(
    max_examples=10,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(data=st.data())
def test_fuzz_sweep(capsys, arena, data, tmp_path_factory):
    sweep = data.draw(st.one_of(st.just(str(arena.sweep)), paths(arena, suffix=".toml")))
    workers = data.draw(st.one_of(st.just("1"), st.sampled_from(["2", "0", "-3", "abc", "nan", "1e3", ""])))
    out = data.draw(st.one_of(paths(arena), st.just(str(tmp_path_factory.mktemp("sweep")))))
    batch = data.draw(st.sampled_from([None, "1", "3", "0", "-2", "1e3", "abc", "2.5", "", "1025", "9" * 30]))
    extra = [] if batch is None else opt("--batch-size", batch)
    argv = ["--memory-limit", "2G", "sweep", sweep, "--out", out, *opt("--workers", workers), *extra]
    rc, _, err = call(capsys, argv)
    if workers in ("1", "2") and batch is not None and not (batch.isdigit() and 1 <= int(batch) <= 1024):
        assert rc == 2 and "error: --batch-size:" in err, (batch, err)  # the parser's, before anything runs


@FUZZ
@given(
    side=st.lists(NUMBERS, min_size=1, max_size=3),
    kappa=st.lists(NUMBERS, min_size=1, max_size=3),
    extra=st.lists(st.tuples(st.sampled_from(["--altitude-km", "--total-kg", "--rod-mass-kg"]), NUMBERS), max_size=2),
)
def test_fuzz_scaling_magnetorquer(capsys, side, kappa, extra):
    call_limited(capsys, ["scaling", "magnetorquer", "--side-m", *side, "--kappa", *kappa], extra)


@FUZZ
@given(
    geometry=st.one_of(st.sampled_from(["A", "B", "C", "D", "Cx", "Dy", "", "E"]), st.text(max_size=4)),
    extra=st.lists(
        st.tuples(st.sampled_from(["--units", "--side-m", "--areal-density", "--kappa"]), NUMBERS), max_size=3
    ),
    table=st.booleans(),
)
def test_fuzz_scaling_loops(capsys, geometry, extra, table):
    call_limited(capsys, ["scaling", "loops", *opt("--geometry", geometry)] + (["--table"] if table else []), extra)


@FUZZ
@given(
    extra=st.lists(
        st.tuples(
            st.sampled_from(
                ["--side-m", "--segment-m", "--depth-m", "--current-a", "--field-t", "--pitch-cells", "--rows"]
            ),
            NUMBERS,
        ),
        max_size=3,
    )
)
def test_fuzz_torque_coil(capsys, extra):
    call_limited(capsys, ["torque", "coil"], extra)


@FUZZ
@given(
    argv=st.lists(
        st.one_of(
            st.text(max_size=10),
            st.sampled_from(
                [
                    "build",
                    "run",
                    "render",
                    "sweep",
                    "scaling",
                    "torque",
                    "coil",
                    "loops",
                    "--out",
                    "-o",
                    "--set",
                    "--memory-limit",
                    "--workers",
                    "--help-me",
                    "-",
                    "--",
                ]
            ),
        ),
        max_size=5,
    )
)
def test_fuzz_any_command_line(capsys, argv):
    """Random words: usage errors are exit 2 with 'error:', never an exception."""
    if "--help" in argv or "-h" in argv:
        return
    call_limited(capsys, argv)


def test_valid_inputs_still_succeed(capsys, arena, tmp_path):
    """The checks refuse nothing valid: every verb with a small valid input exits 0."""
    for argv in (
        ["validate", CONFIG, *TINY],
        ["build", CONFIG, "-o", str(tmp_path / "m.xml"), *TINY],
        ["sweep", str(arena.sweep), "--out", str(tmp_path / "sw")],
        ["scaling", "magnetorquer", "--side-m", "75", "100", "--kappa", "100"],
        ["scaling", "loops", "--table"],
        ["torque", "coil", "--side-m", "20"],
    ):
        rc, out, err = call(capsys, argv)
        assert rc == 0, (argv, err)
    assert _strict_json(out)["T_max_ycoil_Nm"] > 0


def test_corrupt_modes_cache_is_recomputed_and_rewritten(tmp_path):
    lat = make_lattice(units=2, side_m=1.0)
    args = (lat.nodes, lat.struts, np.ones(lat.n_struts), np.ones(lat.n_nodes))
    first = lattice_modes(*args, cache_dir=tmp_path)
    (cache,) = tmp_path.glob("*.npz")
    size = cache.stat().st_size
    for corrupt in (cache.read_bytes()[:60], b"garbage", b""):
        cache.write_bytes(corrupt)
        again = lattice_modes(*args, cache_dir=tmp_path)
        assert np.allclose(again.omega, first.omega) and cache.stat().st_size == size
    np.savez(cache, eigvals=np.ones(3), phi=np.ones((3, 3)))  # a readable file of the wrong shape
    assert np.allclose(lattice_modes(*args, cache_dir=tmp_path).omega, first.omega)


def test_os_errors_about_user_paths_exit_2_others_1(capsys, monkeypatch, tmp_path):
    target = tmp_path / "out" / "m.xml"

    def denied(args):
        raise PermissionError(errno.EACCES, "Permission denied", str(target.parent / ".m.xml.tmp"))

    def disk_full(args):
        raise OSError(errno.ENOSPC, "No space left on device", "/var/somewhere/else")

    monkeypatch.setattr(cli, "_cmd_build", denied)
    rc, _, err = call(capsys, ["build", CONFIG, "-o", str(target)])
    assert rc == 2 and err.startswith("error: ") and "Permission denied" in err
    monkeypatch.setattr(cli, "_cmd_build", disk_full)
    rc, _, err = call(capsys, ["build", CONFIG, "-o", str(target)])
    assert rc == 1 and err.startswith("error: output failed: OSError") and "No space left" in err
