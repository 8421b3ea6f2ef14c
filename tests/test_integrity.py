"""A run folder can never make the program run code or read missing data as zeros.

Checkpoints are restored only into state slots (no attribute walking, no imports from header
strings) and carry a digest of their contents; record stores carry digests of every chunk in every
checkpoint and in the manifest, and ``--resume``, ``render``, ``export`` and ``report collect``
verify them, refusing with exit status 2 and the name of the piece.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from magsail_mj.checkpoint import CheckpointError, StateWalker, restore_state, state_digest
from magsail_mj.cli import main
from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.integrity import IntegrityError, verify_run_folder
from magsail_mj.records import STORE_NAME
from tests.conftest import REPO

CONFIG = REPO / "magsail_mj/concepts/truss_magnetorquer/configs/dist_vs_central/case_c_central_bangbang.toml"
SMALL = [
    "sim.duration_s=1",
    "lattice.units=3",
    "sim.checkpoint_every_s=0.25",
    "sim.record_every=1",
    "sim.progress=false",
]


def _run(out: Path, *extra: str) -> int:
    sets = [a for s in SMALL for a in ("--set", s)]
    return main(["run", str(CONFIG), "--out", str(out), *sets, *extra])


@pytest.fixture(scope="module")
def stopped_run(tmp_path_factory) -> Path:
    """A run stopped at 0.5 s with a checkpoint."""
    out = tmp_path_factory.mktemp("integrity") / "stopped"
    assert _run(out, "--stop-after-s", "0.5") == 0
    return out


@pytest.fixture(scope="module")
def finished_run(stopped_run, tmp_path_factory) -> Path:
    """The stopped run resumed to its end: the resume read its store back against the
    checkpoint's digests (bit-identity of resumed runs: tests/test_hostile_runs.py)."""
    out = tmp_path_factory.mktemp("integrity") / "finished"
    shutil.copytree(stopped_run, out)
    assert _run(out, "--resume") == 0
    return out


def _copy(src: Path, tmp_path: Path) -> Path:
    dst = tmp_path / src.name
    shutil.copytree(src, dst)
    return dst


def _rewrite_checkpoint(path: Path, edit) -> None:
    """Edit a checkpoint's header as an attacker would, with a matching state digest."""
    with np.load(path, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    header = json.loads(str(arrays.pop("__header__")))
    edit(header)
    header["state_digest"] = state_digest(header, arrays)
    arrays["__header__"] = np.array(json.dumps(header))
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


def _chunk_files(store: Path, name: str) -> list[Path]:
    return sorted(p for p in (store / name).rglob("*") if p.is_file() and p.name != "zarr.json")


# ---------------------------------------------------------------------------------- state slots
def test_a_dunder_path_is_never_followed():
    """The crafted node of the issue reached os.environ through __class__.__init__.__globals__."""
    walker = StateWalker({"controller": BestFitRotation(np.eye(3))})
    walker.baseline()
    tree = {
        "controller": {"kind": "object", "class": "magsail_mj.estimation.attitude:BestFitRotation"},
        'controller.__class__.__init__.__globals__{"np"}': {"kind": "scalar", "value": 1},
    }
    with pytest.raises(CheckpointError, match="not a state slot"):
        restore_state(walker, tree, {})


@pytest.mark.parametrize(
    "path", ["controller.update", "controller.no_such_attribute", "controller<x>", "other", "controller.p0.T"]
)
def test_a_path_that_is_not_a_slot_of_the_rebuilt_run_is_refused(path):
    walker = StateWalker({"controller": BestFitRotation(np.eye(3))})
    walker.baseline()
    tree = {
        "controller": {"kind": "object", "class": "magsail_mj.estimation.attitude:BestFitRotation"},
        path: {"kind": "scalar", "value": 1},
    }
    with pytest.raises(CheckpointError, match="not a state slot|malformed"):
        restore_state(walker, tree, {})


@pytest.mark.parametrize(
    "class_name",
    ["magsail_mj.checkpoint:importlib.import_module", "os:system", "magsail_mj.run:RunOutcome", "builtins:object", 3],
)
def test_a_class_name_is_looked_up_never_imported(class_name, monkeypatch):
    import importlib

    monkeypatch.setattr(importlib, "import_module", lambda *a, **k: pytest.fail("a header string reached an import"))
    walker = StateWalker({"late": None})
    walker.baseline()
    with pytest.raises(CheckpointError, match="refuses to create"):
        restore_state(walker, {"late": {"kind": "object", "class": class_name}}, {})


def test_crafted_checkpoint_cannot_reach_the_environment(tmp_path, stopped_run, capsys, monkeypatch):
    """The issue's reproducer: a node that would set IMAGEIO_FFMPEG_EXE to a script of the folder."""
    run = _copy(stopped_run, tmp_path)
    script = run / "evil.sh"
    script.write_text("#!/bin/sh\ntouch " + str(tmp_path / "pwned") + "\n")
    script.chmod(0o755)
    monkeypatch.delenv("IMAGEIO_FFMPEG_EXE", raising=False)
    node = 'controller.__class__.__init__.__globals__{"np"}._pytesttester.os.environ{"IMAGEIO_FFMPEG_EXE"}'
    _rewrite_checkpoint(
        run / "checkpoint.npz", lambda h: h["state_tree"].update({node: {"kind": "scalar", "value": str(script)}})
    )
    assert _run(run, "--resume", "--video") == 2
    err = capsys.readouterr().err
    assert "not a state slot" in err and "checkpoint" in err
    assert "IMAGEIO_FFMPEG_EXE" not in __import__("os").environ and not (tmp_path / "pwned").exists()


def test_an_edited_checkpoint_is_refused_by_its_digest(tmp_path, stopped_run, capsys):
    run = _copy(stopped_run, tmp_path)
    with np.load(run / "checkpoint.npz", allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    header = json.loads(str(arrays.pop("__header__")))
    header["wall_s"] = header["wall_s"] + 1.0  # edited without its digest
    arrays["__header__"] = np.array(json.dumps(header))
    with open(run / "checkpoint.npz", "wb") as fh:
        np.savez(fh, **arrays)
    assert _run(run, "--resume") == 2
    assert "differs from its state digest" in capsys.readouterr().err


# ---------------------------------------------------------------------------------- records
@pytest.mark.parametrize("damage", ["delete_one", "delete_all", "truncate", "edit"])
def test_a_damaged_record_chunk_refuses_the_resume(tmp_path, stopped_run, capsys, damage):
    run = _copy(stopped_run, tmp_path)
    chunks = _chunk_files(run / STORE_NAME, "qpos")
    assert chunks, "the stopped run stored qpos chunks"
    if damage == "delete_one":
        chunks[0].unlink()
    elif damage == "delete_all":
        for c in chunks:
            c.unlink()
    elif damage == "truncate":
        data = chunks[0].read_bytes()
        chunks[0].write_bytes(data[: len(data) // 2])
    else:
        data = bytearray(chunks[0].read_bytes())
        data[-3] ^= 0xFF
        chunks[0].write_bytes(bytes(data))
    assert _run(run, "--resume") == 2
    err = capsys.readouterr().err
    assert "qpos" in err and "records" in err, err


def test_a_finished_run_verifies_and_lists_its_digests(finished_run):
    manifest = verify_run_folder(finished_run)
    digests = manifest["records_digests"]
    assert {"t", "qpos"} <= set(digests) and any(k.startswith("series/") for k in digests)
    assert manifest["checkpoint"]["state_digest"]
    assert all(len(d["chunks"]) == -(-d["n"] // d["rows"]) for d in digests.values() if d["rows"])


@pytest.mark.parametrize("verb", ["render", "export"])
def test_render_and_export_refuse_a_missing_chunk_naming_it(tmp_path, finished_run, capsys, verb):
    run = _copy(finished_run, tmp_path)
    _chunk_files(run / STORE_NAME, "qpos")[0].unlink()
    with pytest.raises(IntegrityError, match="qpos records 0-"):
        verify_run_folder(run)
    args = {
        "render": ["render", str(run), "-o", str(tmp_path / "v.mp4")],
        "export": ["export", str(run), "--out", str(tmp_path / "e.npz")],
    }
    assert main(args[verb]) == 2
    assert "qpos records 0-" in capsys.readouterr().err
    assert not (tmp_path / "v.mp4").exists() and not (tmp_path / "e.npz").exists()


@pytest.mark.parametrize("piece", ["summary.json", "model.xml", "manifest.json"])
def test_an_edited_or_missing_file_is_named(tmp_path, finished_run, piece):
    run = _copy(finished_run, tmp_path)
    if piece == "manifest.json":
        (run / piece).unlink()
        with pytest.raises(IntegrityError, match="no manifest.json"):
            verify_run_folder(run)
        return
    (run / piece).write_text((run / piece).read_text() + " ")
    with pytest.raises(IntegrityError, match=piece):
        verify_run_folder(run)
