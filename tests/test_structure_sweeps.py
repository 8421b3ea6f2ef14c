"""Sweeps over structure-concept configs: ``[grid]`` and ``[monte_carlo]`` designs of a structure
config run through ``magsail sweep`` (LocalCluster), a structure file swapped by the sweep, keys of
the structure that an override cannot reach refused by name, the shipped example sweep.

Tiny runs: the regular octahedron (6 nodes, 12 stiff struts with a 200 A m² rod each) as a structure
file, B-dot below saturation in a constant field along z, free space, 1 s at δt = 5 ms.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from magsail_mj.cli import main
from magsail_mj.config import ConfigError, load_config
from magsail_mj.sweep import load_sweep
from magsail_mj.sweep.design import toml_literal
from tests.conftest import REPO

FIELD_T = 3e-5
K1_NMS_T2 = 0.2 * 4.0 / FIELD_T**2  # B-dot decay rate k B² / I = 0.2 /s for the 1 kg-node octahedron (I = 4 kg m²)
SHIPPED_SWEEP = REPO / "magsail_mj" / "concepts" / "structure" / "configs" / "sweeps" / "sail_bdot_grid.toml"


def write_toml(path: Path, tree: dict[str, Any]) -> Path:
    """``tree`` as TOML (every top-level table inline: TOML reads it back as the same tree)."""
    path.write_text("".join(f"{json.dumps(k)} = {toml_literal(v)}\n" for k, v in tree.items()))
    return path


def octahedron_structure(mass_kg: float) -> dict[str, Any]:
    """A regular octahedron (nodes ±e_i of ``mass_kg`` each: isotropic inertia 4 ``mass_kg`` m²) as
    a structure file's tables; its edges the member set ``edges``."""
    nodes = [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0], [0, 0, -1.0]]
    edges = [[a, b] for a in range(6) for b in range(a + 1, 6) if b != a + 1 or a % 2]
    return {
        "nodes": {"position_m": nodes, "mass_kg": mass_kg},
        "member_groups": [{"kind": "strut", "name": "edges", "nodes": edges, "EA_N": 2.0e4, "damping_Ns_m": 20.0}],
    }


def config_tree(structure: dict[str, Any]) -> dict[str, Any]:
    return {
        "concept": "structure",
        "scenario": "detumble",
        "sim": {"duration_s": 1.0, "timestep_s": 5e-3, "record_every": 20, "progress": False},
        "structure": structure,
        "actuators": {"member_set": "edges", "dipole_max_Am2": 200.0},
        "field": {"model": "constant", "constant_T": [0.0, 0.0, FIELD_T]},
        "control": {"kind": "bdot", "k_bdot_Nms_T2": K1_NMS_T2},
        "initial": {"omega0_rad_s": [0.01, 0.0, 0.0]},
    }


@pytest.fixture
def files(tmp_path: Path) -> Path:
    """A folder with the octahedron as structure files of 1 kg and 2 kg nodes, a config reading the
    first (``octa.toml``) and one holding the structure inline (``inline.toml``)."""
    for mass in (1, 2):
        header = {"format": "magsail-structure", "version": 1}
        write_toml(tmp_path / f"octa_{mass}kg.toml", {**header, **octahedron_structure(mass)})
    write_toml(tmp_path / "octa.toml", config_tree({"file": "octa_1kg.toml"}))
    write_toml(tmp_path / "inline.toml", config_tree(octahedron_structure(1.0)))
    return tmp_path


def sweep_file(folder: Path, config: str, body: str) -> Path:
    path = folder / "sweep.toml"
    path.write_text(f'name = "octa"\nconfig = "{config}"\n{body}')
    return path


def test_a_grid_swapping_the_structure_file_runs_through_magsail_sweep(files: Path, capsys) -> None:
    """A grid varying the structure file (1 kg or 2 kg nodes: I = 4 or 8 kg m²), the B-dot gain and
    the initial rate together (linked keys); ``magsail sweep --only`` runs the swapped file's point
    on a LocalCluster (one run: a run process costs about 10 s of imports, build and figures).
    Its folder, ``sweep_summary.json`` with both runs (the other ``not_run``) and the params; the
    run read the swapped file (its mass, its digest in the manifest) and detumbled at its own rate
    ``λ = k B² / I = 0.3 /s``: the final best-fit rate is ``|ω0| e^{−λ (T − Δ/2)}`` (the last
    record's rate is a backward difference over Δ = 0.1 s, the rate half a record earlier) within
    1e-3: the controller's rate is a backward difference over one step held for the next, a lag of
    about δt = 5 ms that speeds the decay by the factor 1 + λ δt (a final rate lower by
    λ² δt t = 4.3e-4; measured 3.9e-4); the struts stretch by ~1e-8."""
    body = (
        '[grid]\n"structure.file,control.k_bdot_Nms_T2,initial.omega0_rad_s" = [\n'
        f'  ["octa_1kg.toml", {K1_NMS_T2!r}, [0.01, 0.0, 0.0]],\n'
        f'  ["octa_2kg.toml", {3 * K1_NMS_T2!r}, [0.0, 0.008, 0.0]],\n]\n'
    )
    path = sweep_file(files, "octa.toml", body)
    out = files / "out"
    argv = ["sweep", str(path), "--out", str(out), "--only", "octa_2kg", "--workers", "1", "--no-progress"]
    assert main(argv) == 0
    capsys.readouterr()
    records = json.loads((out / "sweep_summary.json").read_text())
    assert [r["status"] for r in records] == ["not_run", "completed"]
    assert records[0]["config_hash"] != records[1]["config_hash"]
    record = records[1]
    assert record["id"] == "file=octa_2kg.toml,k_bdot_Nms_T2=2666666666.67,omega0_rad_s=0x0.008x0"
    assert record["params"] == {
        "structure.file": "octa_2kg.toml",
        "control.k_bdot_Nms_T2": 3 * K1_NMS_T2,
        "initial.omega0_rad_s": [0.0, 0.008, 0.0],
    }
    run = out / record["id"]
    assert {"summary.json", "manifest.json", "params.json", "model.xml"} <= {p.name for p in run.iterdir()}
    assert not (out / records[0]["id"]).exists()
    manifest = json.loads((run / "manifest.json").read_text())
    assert Path(manifest["config"]["structure"]["file"]) == files / "octa_2kg.toml"
    assert list(manifest["config"]["structure"]["sha256"]) == ["octa_2kg.toml"]
    summary = record["summary"]
    assert summary["total_mass_kg"] == pytest.approx(12.0, rel=1e-12) and summary["saturation_fraction"] == 0.0
    lam = 3 * K1_NMS_T2 * FIELD_T**2 / 8.0
    assert summary["omega_norm_initial_rad_s"] == pytest.approx(0.008, rel=1e-12)
    assert summary["omega_norm_final_rad_s"] == pytest.approx(0.008 * math.exp(-lam * (1.0 - 0.05)), rel=1e-3)


def test_grid_and_monte_carlo_designs_validate_every_structure_run(files: Path) -> None:
    """A 2 × 2 grid of B-dot gain × initial rate: four runs, ids and params from the values, four
    config hashes. A Monte Carlo draw of the initial rate (a uniform direction, magnitude uniform in
    [0.005, 0.02] rad/s) lands in each run's config."""
    grid = load_sweep(
        sweep_file(
            files,
            "inline.toml",
            f'[grid]\n"control.k_bdot_Nms_T2" = [{K1_NMS_T2!r}, {2 * K1_NMS_T2!r}]\n'
            '"initial.omega0_rad_s" = [[0.01, 0.0, 0.0], [0.0, 0.02, 0.0]]\n',
        )
    )
    assert len(grid.runs) == 4 and len({r.config_hash for r in grid.runs}) == 4
    assert grid.runs[1].id == "k_bdot_Nms_T2=888888888.889,omega0_rad_s=0x0.02x0"
    assert grid.runs[1].params == {"control.k_bdot_Nms_T2": K1_NMS_T2, "initial.omega0_rad_s": [0.0, 0.02, 0.0]}
    mc = load_sweep(
        sweep_file(
            files,
            "inline.toml",
            '[monte_carlo]\nsamples = 3\nseed = 5\n"initial.omega0_rad_s" = '
            '{ dist = "direction", magnitude = { dist = "uniform", low = 0.005, high = 0.02 } }\n',
        )
    )
    assert [r.id for r in mc.runs] == ["s0", "s1", "s2"]
    for run in mc.runs:
        w = np.asarray(load_config(run.config, list(run.overrides)).initial.omega0_rad_s)
        np.testing.assert_array_equal(w, run.params["initial.omega0_rad_s"])
        assert 0.005 <= np.linalg.norm(w) <= 0.02 * (1 + 1e-12)


def test_a_changed_structure_file_changes_the_run_identity(files: Path) -> None:
    """The config hash holds the structure file's digest: a sweep after an edit of the file reruns
    the run (a finished run is reused only for the hash the sweep would run now); a base config
    that pins ``structure.sha256`` refuses the edited file by that key."""
    path = sweep_file(files, "octa.toml", f'[grid]\n"control.k_bdot_Nms_T2" = [{K1_NMS_T2!r}]\n')
    before = load_sweep(path).runs[0].config_hash
    structure = files / "octa_1kg.toml"
    structure.write_text(structure.read_text().replace('"EA_N" = 20000.0', '"EA_N" = 30000.0'))
    assert load_sweep(path).runs[0].config_hash != before
    pinned = config_tree({"file": "octa_2kg.toml", "sha256": {"octa_2kg.toml": "0" * 64}})
    write_toml(files / "octa.toml", pinned)
    with pytest.raises(ConfigError, match=r"structure\.sha256: the files read have the digests"):
        load_sweep(path)


def test_structure_keys_an_override_cannot_reach_are_refused_by_name(files: Path) -> None:
    """Member properties sit in the array ``structure.member_groups``: an override cannot index into
    it (a whole group list can be given inline instead); an inline structure key on a config
    that reads a file is refused naming ``structure.file``; a missing file is named with its path.
    Each problem names the run id and the key; nothing is written."""
    cases = [
        ("inline.toml", '"structure.member_groups.0.EA_N" = [1e4]', "structure.member_groups is a value, not a table"),
        ("octa.toml", '"structure.nodes.mass_kg" = [2.0]', r"structure\.file: give the structure once.*\['nodes'\]"),
        ("octa.toml", '"structure.file" = ["nope.toml"]', r"file=nope\.toml: structure\.file: .*nope\.toml"),
    ]
    for config, grid, message in cases:
        with pytest.raises(ConfigError, match=message):
            load_sweep(sweep_file(files, config, f"[grid]\n{grid}\n"))
    groups = config_tree(octahedron_structure(1.0))["structure"]["member_groups"]
    groups[0]["EA_N"] = 1.0e4
    path = files / "whole.toml"
    path.write_text(
        f'name = "whole"\n[[run]]\nid = "soft"\nconfig = "inline.toml"\n'
        f"set = [{json.dumps('structure.member_groups=' + toml_literal(groups))}]\n"
    )
    run = load_sweep(path).runs[0]
    cfg = load_config(run.config, list(run.overrides))
    assert cfg.structure.structure.members.stiffness_N_m[0] == pytest.approx(1.0e4 / math.sqrt(2), rel=1e-12)
    assert not (files / "out").exists()


def test_the_shipped_sail_grid_designs_six_runs_of_gain_and_rate() -> None:
    sweep = load_sweep(SHIPPED_SWEEP)
    assert len(sweep.runs) == 6 and len({r.config_hash for r in sweep.runs}) == 6
    gains = sorted({r.params["control.k_bdot_Nms_T2"] for r in sweep.runs})
    assert gains == [1e10, 1e11, 1e12]
    shipped = load_config(REPO / "magsail_mj/concepts/structure/configs/sail_detumble.toml")
    rates = {tuple(r.params["initial.omega0_rad_s"]) for r in sweep.runs}
    w0 = np.asarray(shipped.initial.omega0_rad_s)
    assert rates == {tuple(w0), tuple(2 * w0)}
    assert all(r.config.name == "sail_detumble.toml" for r in sweep.runs)
