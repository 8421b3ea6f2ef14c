"""The ``structure`` concept: any structure through validate, build and run.

Physics checks compare with an invariant or an analytic result, each with its tolerance and why:
angular momentum of a free structure (beams, a rigid part, struts), B-dot decay of a stiff
isotropic body against ``ω₀ e^{−k B² t / I}``, the centripetal strain of a spinning triangle against
``m ω² L / (3 EA)``, the strain energy against MuJoCo's own spring potential, the lever arms of
forces on a rigid part's nodes against ``Σ x × F``.
"""

from __future__ import annotations

import copy
import importlib.util
import json
import math
import re
import warnings
from pathlib import Path
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

import magsail_mj
from magsail_mj.cli import main
from magsail_mj.concepts.structure.control import DipoleAllocation
from magsail_mj.concepts.structure.metrics import StructureMonitor
from magsail_mj.concepts.structure.model import make_structure_model, rigid_initial_state
from magsail_mj.concepts.structure.tasks import StructureTask
from magsail_mj.config import ConfigError, load_config, parse_config
from magsail_mj.export import read_timeseries
from magsail_mj.records import open_records
from magsail_mj.resources import estimate_run_bytes
from magsail_mj.run import run_scenario
from magsail_mj.scenario import build_scenario
from magsail_mj.structure.fileformat import read_structure, write_structure
from tests.conftest import REPO

CONFIGS = REPO / "magsail_mj" / "concepts" / "structure" / "configs"
SHIPPED = sorted(p for p in CONFIGS.glob("*.toml"))
QUIET = ["sim.progress=false"]


@pytest.fixture
def no_plots(monkeypatch):
    """Runs whose figures are not under test write none (Matplotlib costs about a second a figure)."""
    monkeypatch.setattr(StructureTask, "plots", lambda self, run_dir, result, series: [])


def _octahedron(*, EA_N: float = 2.0e4, damping: float = 20.0, dipole: float | None = 200.0) -> dict:
    """A regular octahedron (nodes ±e_i, 1 kg each: isotropic inertia 4 kg m²), its 12 edges
    struts, rods on them; a detumble in a constant field, free space."""
    nodes = [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0], [0, 0, -1.0]]
    edges = [[a, b] for a in range(6) for b in range(a + 1, 6) if b != a + 1 or a % 2]
    tree = {
        "concept": "structure",
        "scenario": "detumble",
        "sim": {"duration_s": 5.0, "timestep_s": 5e-3, "record_every": 20, "progress": False},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 1.0},
            "member_groups": [
                {"kind": "strut", "name": "edges", "nodes": edges, "EA_N": EA_N, "damping_Ns_m": damping}
            ],
        },
        "field": {"model": "constant", "constant_T": [0.0, 0.0, 3e-5]},
        "control": {"kind": "bdot", "k_bdot_Nms_T2": 8.0e9 / 9.0},
        "initial": {"omega0_rad_s": [0.01, 0.0, 0.0]},
    }
    if dipole is not None:
        tree["actuators"] = {"member_set": "edges", "dipole_max_Am2": dipole}
    return tree


def _mixed() -> dict:
    """Beams in a tree from a rigid part (hub off its node), struts closing loops, a cable."""
    nodes = [[0.0, 0, 0], [2.0, 0, 0], [4.0, 0, 0], [0, 2.0, 0], [2.0, 2.0, 0.5]]
    return {
        "concept": "structure",
        "scenario": "free",
        "sim": {"duration_s": 2.0, "timestep_s": 2e-3, "record_every": 50, "progress": False},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 1.0},
            "member_groups": [
                {
                    "kind": "beam",
                    "name": "beams",
                    "nodes": [[0, 1], [1, 2], [0, 3]],
                    "EA_N": 2.0e4,
                    "EI_Nm2": 500.0,
                    "GJ_Nm2": 300.0,
                    "linear_density_kg_m": 0.5,
                    "damping_Ns_m": 5.0,
                },
                {"kind": "strut", "nodes": [[2, 4], [3, 4], [1, 4]], "EA_N": 5.0e3, "damping_Ns_m": 2.0},
                {"kind": "cable", "nodes": [[2, 3]], "EA_N": 1.0e3, "prestrain": 1e-3},
            ],
            "rigid_parts": [
                {
                    "name": "hub",
                    "mass_kg": 5.0,
                    "center_m": [0.0, 0.0, 0.2],
                    "inertia_kgm2": [1.0, 1.2, 1.5],
                    "nodes": [0],
                }
            ],
        },
        "initial": {"omega0_rad_s": [0.1, 0.2, 0.3], "q0_wxyz": [0.9, 0.3, 0.3, math.sqrt(1 - 0.99)]},
    }


# ----------------------------------------------------------------------------- validation


def test_shipped_configs_validate_and_count_their_models():
    """Each shipped config validates, resolves its structure file, records its digest and counts its
    model exactly as MuJoCo builds it (the memory estimate's input)."""
    assert [p.name for p in SHIPPED] == [
        "octet_detumble.toml",
        "offset_grid_detumble.toml",
        "reflector_loops_slew.toml",
        "sail_detumble.toml",
    ]
    for path in SHIPPED:
        cfg = load_config(path)
        file = Path(cfg.structure.file)
        assert file.is_absolute() and file.is_file() and file.parent.name == "structures"
        assert list(cfg.structure.sha256) == [file.name] and len(cfg.structure.sha256[file.name]) == 64
        sm = make_structure_model(cfg)
        assert cfg.model_counts() == (sm.model.nv, sm.model.nbody, sm.model.ntendon), path.name
        assert 0 < estimate_run_bytes(cfg) < 2**32
        dumped = parse_config(cfg.model_dump(mode="json"))  # a dump re-validates from anywhere
        assert dumped.structure.sha256 == cfg.structure.sha256


def test_shipped_structure_files_are_what_the_script_writes(tmp_path):
    """The committed structure files equal the generators' structures (read back: 1e-9 relative, the
    cantilever calibration's sparse solve may differ in the last bits between machines)."""
    spec = importlib.util.spec_from_file_location("make_structure_configs", REPO / "scripts/make_structure_configs.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    for name, make in script.STRUCTURES.items():
        committed = read_structure(CONFIGS / "structures" / name).structure
        fresh = read_structure(write_structure(make(), tmp_path / name)[0]).structure
        np.testing.assert_allclose(committed.positions_m, fresh.positions_m, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(committed.members.nodes, fresh.members.nodes)
        for column in ("EA_N", "EI_Nm2", "damping_Ns_m", "rest_length_m", "linear_density_kg_m"):
            np.testing.assert_allclose(getattr(committed.members, column), getattr(fresh.members, column), rtol=1e-9)
        assert committed.member_sets.keys() == fresh.member_sets.keys()


def test_inline_structure_problems_name_their_key_paths():
    tree = _octahedron()
    tree["structure"]["member_groups"][0]["EA_N"] = -1.0
    tree["structure"]["member_groups"][0]["nodes"][3] = [0, 9]
    with pytest.raises(ConfigError) as err:
        parse_config(tree)
    text = str(err.value)
    assert "structure.members[0].EA_N: must be > 0, got -1.0" in text
    assert "structure.members[3].nodes: node 9 does not exist (6 nodes)" in text
    tree = _octahedron()
    tree["actuators"]["member_set"] = "booms"
    with pytest.raises(
        ConfigError, match=r"actuators\.member_set: the structure has no member set 'booms' \(it has \['edges'\]\)"
    ):
        parse_config(tree)
    tree = _octahedron()
    tree["structure"]["file"] = "x.toml"
    with pytest.raises(ConfigError, match=r"structure\.file: give the structure once"):
        parse_config(tree)


def test_a_changed_structure_file_is_refused_by_its_recorded_digest(tmp_path):
    structure = read_structure(CONFIGS / "structures" / "sail_100m.toml").structure
    write_structure(structure, tmp_path / "s.toml")
    tree = {**_mixed(), "structure": {"file": str(tmp_path / "s.toml")}}
    cfg = parse_config(tree)
    pinned = cfg.model_dump(mode="json")
    (tmp_path / "s.toml").write_text((tmp_path / "s.toml").read_text().replace('name = "sail_100m"', 'name = "x"'))
    with pytest.raises(ConfigError, match=r"structure\.sha256: the files read have the digests"):
        parse_config(pinned)


@pytest.mark.parametrize("source", ["mesh", "deck"])
def test_a_mesh_and_a_deck_run_through_the_same_config(source, tmp_path):
    """A gmsh mesh (curve group → beams, surface group → panels) and a Nastran deck (a CBAR
    cantilever clamped by an SPC) validate, count their models and step, named by
    ``structure.file`` alone; a deck whose beam tree is held at three nodes (two welds to the world
    and a ball joint) builds and counts its model; one the model builder cannot hold (a beam held
    at both ends by the z translation alone) is refused by validation, naming the file and the
    rule, as a missing file is."""
    if source == "mesh":
        table = {
            "file": str(REPO / "tests/data/meshes/sail.msh"),
            "mesh": {
                "groups": {
                    "booms": {
                        "kind": "beam",
                        "EA_N": 2.0e5,
                        "EI_Nm2": [12.0, 15.0],
                        "GJ_Nm2": 8.0,
                        "linear_density_kg_m": 0.05,
                    },
                    "membrane": {"areal_density_kg_m2": 0.02, "reflectivity": [0.88, 0.02, 0.1]},
                }
            },
        }
    else:
        table = {"file": str(REPO / "tests/data/nastran/cantilever_cbar.bdf")}
    tree = {
        "concept": "structure",
        "scenario": "free",
        # the steel deck's and the light booms' stiffest modes need a short step (validation checks)
        "sim": {"duration_s": 1e-3, "timestep_s": 1e-5, "progress": False},
        "structure": table,
    }
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the deck reader's notes on the cards it completes
        cfg = parse_config(tree)
    sim = magsail_mj.load(cfg)
    assert cfg.model_counts() == (sim.model.nv, sim.model.nbody, sim.model.ntendon)
    assert sim.step(5) == "running" and np.all(np.isfinite(sim.data.qpos))
    if source == "mesh":
        assert len(cfg.structure.structure.panels) > 0 and np.any(cfg.structure.structure.members.kind == 2)
    broken = copy.deepcopy(tree)
    broken["structure"]["file"] = table["file"] + ".missing"
    with pytest.raises(ConfigError, match=r"structure\.file: .*missing: does not exist"):
        parse_config(broken)
    if source == "deck":
        held = copy.deepcopy(tree)  # a beam tree held at three nodes: welded, welded, pinned
        held["structure"]["file"] = str(REPO / "tests/data/nastran/truss_free.bdf")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cfg = parse_config(held)
        model = magsail_mj.load(cfg).model
        assert cfg.model_counts() == (model.nv, model.nbody, model.ntendon) and model.neq == 2
        deck = tmp_path / "cantilever_z.bdf"  # now held at both ends by z alone
        text = (
            Path(table["file"])
            .read_text()
            .replace("SPC1           1  123456       1", "SPC1           1       3       1      11")
        )
        deck.write_text(text)
        broken["structure"]["file"] = str(deck)
        with warnings.catch_warnings(), pytest.raises(ConfigError) as err:
            warnings.simplefilter("ignore")
            parse_config(broken)
        assert "structure.file: " in str(err.value) and "cantilever_z.bdf: fixed_dofs: nodes [0, 10]" in str(err.value)


def test_bad_structure_file_exits_2_naming_the_element_and_writes_nothing(tmp_path, capsys):
    (tmp_path / "bad.toml").write_text(
        'format = "magsail-structure"\nversion = 1\n[nodes]\nposition_m = [[0.0, 0, 0], [1.0, 0, 0], [0, 1.0, 0]]\n'
        'mass_kg = 1.0\n[[member_groups]]\nkind = "strut"\nnodes = [[0, 1], [1, 99]]\nEA_N = 10.0\n'
    )
    (tmp_path / "run.toml").write_text(
        'concept = "structure"\nscenario = "free"\n[sim]\nduration_s = 1.0\ntimestep_s = 0.01\n'
        '[structure]\nfile = "bad.toml"\n'
    )
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "run.toml"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "structure.file:" in err and "bad.toml: members[1].nodes: node 99 does not exist (3 nodes)" in err, err
    assert not out.exists()
    assert main(["validate", str(tmp_path / "run.toml")]) == 2


# ----------------------------------------------------------------------------- runs


def test_short_run_of_the_sail_writes_summary_records_and_manifest(tmp_path):
    """Two seconds of the shipped sail (beams, a rigid hub, cables, panels, IGRF, tidal gravity)."""
    cfg = load_config(CONFIGS / "sail_detumble.toml", [*QUIET, "sim.duration_s=2.0", "sim.checkpoint_every_s=0.0"])
    out = run_scenario(cfg, tmp_path / "run")
    assert out.status == "completed", out.get("status_message")
    run = tmp_path / "run"
    names = {p.name for p in run.iterdir()}
    assert {"model.xml", "summary.json", "manifest.json", "timeseries.zarr", "body_rates.png", "torques.png"} <= names
    manifest = json.loads((run / "manifest.json").read_text())
    assert manifest["structure"]["sha256"] == cfg.structure.sha256
    assert manifest["model_size"]["nodes"] == 41 and manifest["model_size"]["rigid_parts"] == 1
    ts = read_timeseries(run)
    assert ts["qpos"].shape == (3, make_structure_model(cfg).model.nq) and ts["rod_activation"].shape == (3, 16)
    assert np.all(np.abs(ts["rod_activation"]) <= 1.0 + 1e-12)
    summary = json.loads((run / "summary.json").read_text())
    assert summary["n_members"] == 104 and summary["member_strain_max"] < 0.01


def test_free_structure_conserves_angular_momentum(tmp_path, no_plots):
    """No loads: |H(t) − H(0)| / |H(0)| stays below 1e-9 over 2 s (RK4 at 1 ms: its local error
    is O(δt⁵ ω_max⁵) ~ 1e-11 relative for ω_max ≈ 250 rad/s (the mixed structure's highest
    mode), summed over 2 000 steps). H(0) of a particle structure equals I ω exactly (1e-12)."""
    result = run_scenario(parse_config(_mixed()), tmp_path / "m")
    assert result.status == "completed"
    H = read_timeseries(tmp_path / "m")["angmom_world_Nms"]
    assert np.max(np.linalg.norm(H - H[0], axis=1)) / np.linalg.norm(H[0]) < 1e-9
    tree = _octahedron(dipole=None)
    tree.update(scenario="free", field={"model": "none"})
    tree.pop("control")
    tree["initial"] = {"omega0_rad_s": [0.3, -0.2, 0.5], "q0_wxyz": [0.8, 0.0, 0.6, 0.0]}
    cfg = parse_config(tree)
    sim = magsail_mj.load(cfg)
    R = np.array([[0.28, 0.0, 0.96], [0.0, 1.0, 0.0], [-0.96, 0.0, 0.28]])  # of q0
    H0 = sim.scenario.monitor.angular_momentum(sim.data)
    expected = R @ (4.0 * np.eye(3)) @ np.array([0.3, -0.2, 0.5])  # I = 4 m a² about every axis
    np.testing.assert_allclose(H0, expected, rtol=1e-12)


def test_centripetal_strain_and_the_strain_limit(tmp_path, no_plots):
    """An equilateral triangle (side L, masses m) spinning at ω about its normal settles at the
    strain m ω² L / (3 EA) (within 1 %: the radius grows by the strain, 1e-3, and the damped
    oscillation has decayed by e^{−20}); with a strain limit of half of it the run stops with
    ``structure_failed`` naming the member, its strain and its limit."""
    L, m, w, EA = 1.0, 1.0, 1.0, 1000.0 / 3.0
    h = L * math.sqrt(3) / 2
    tree = {
        "concept": "structure",
        "scenario": "free",
        "sim": {"duration_s": 2.0, "timestep_s": 5e-3, "record_every": 20, "progress": False},
        "structure": {
            "nodes": {"position_m": [[0.0, 0.0, 0.0], [L, 0.0, 0.0], [L / 2, h, 0.0]], "mass_kg": m},
            "member_groups": [{"kind": "strut", "nodes": [[0, 1], [1, 2], [2, 0]], "EA_N": EA, "damping_Ns_m": 18.0}],
        },
        "initial": {"omega0_rad_s": [0.0, 0.0, w]},
    }
    static = m * w * w * L / (3.0 * EA)
    run_scenario(parse_config(tree), tmp_path / "ok")
    strain = read_timeseries(tmp_path / "ok")["member_strain_max"]
    assert strain[-1] == pytest.approx(static, rel=0.01)
    tree["structure"]["member_groups"][0]["strain_limit"] = 0.5 * static
    out = run_scenario(parse_config(tree), tmp_path / "bad")
    assert out.status == "structure_failed"
    assert re.search(
        r"member [0-2] strain [0-9.e-]+ exceeds its strain limit 0\.0005 at t = [0-9.]+ s", out["status_message"]
    )
    assert (tmp_path / "bad" / "manifest.json").is_file()


def test_bdot_decays_an_isotropic_stiff_body_exponentially(tmp_path, no_plots):
    """B-dot below saturation on a stiff isotropic body (I = 4 kg m²) with ω ⟂ B: T = −k B² ω, so
    |H(t)| = I |ω₀| e^{−λt} with λ = k B² / I = 0.2 /s; 5 s: e^{−1}. Within 0.2 %: the controller's
    rate is a backward difference over one 5 ms step held for the next (a lag of about one step:
    λ δt = 1e-3), and the struts stretch ~1e-8 under the rods' couples. The recorded best-fit rate,
    a backward difference over the 0.1 s between records, is the rate half a record earlier."""
    run_scenario(parse_config(_octahedron()), tmp_path / "d")
    ts = read_timeseries(tmp_path / "d")
    summary = json.loads((tmp_path / "d" / "summary.json").read_text())
    assert summary["saturation_fraction"] == 0.0
    t = ts["t"]
    H = np.linalg.norm(ts["angmom_world_Nms"], axis=1)
    np.testing.assert_allclose(H, 4.0 * 0.01 * np.exp(-0.2 * t), rtol=2e-3)
    w = np.linalg.norm(ts["omega_body_rad_s"], axis=1)
    np.testing.assert_allclose(w[1:], 0.01 * np.exp(-0.2 * (t[1:] - 0.05)), rtol=2e-3)
    assert summary["omega_norm_final_rad_s"] < 0.4 * summary["omega_norm_initial_rad_s"]
    # at a thousand times the gain the rods saturate: |H| falls at every record, and by no more
    # than the rods' largest torque allows, |ΔH| ≤ |B| Σ m_max t
    tree = _octahedron()
    tree["control"]["k_bdot_Nms_T2"] *= 1e3
    tree["sim"]["duration_s"] = 1.0
    out = run_scenario(parse_config(tree), tmp_path / "high")
    H = np.linalg.norm(read_timeseries(tmp_path / "high")["angmom_world_Nms"], axis=1)
    assert out["saturation_fraction"] == 1.0 and np.all(np.diff(H) < 0)
    assert H[0] - H[-1] <= 3e-5 * 12 * 200.0 * 1.0


def test_slew_follows_the_linear_closed_loop(tmp_path, no_plots):
    """Quaternion PD about z (5°) of the stiff isotropic octahedron (I = 4 kg m²) in a field along x:
    the torque about z stays across the field, so below saturation the error angle obeys
    ``I θ̈ + P_ω θ̇ + (P_q / 2) θ ≈ 0`` (q_e,vec = sin(θ/2) ẑ), ω_n = 0.5 rad/s, ζ = 0.7, from rest.
    Within 0.5 % of the initial angle: sin(θ/2) ≈ θ/2 to θ²/24 = 3e-4, the rate estimate lags a
    step (ω_n δt = 2.5e-3; measured 8e-4 in all)."""
    tree = _octahedron(dipole=2000.0)
    tree["scenario"] = "slew"
    tree["field"]["constant_T"] = [3e-5, 0.0, 0.0]
    tree["sim"]["duration_s"] = 6.0
    half = math.radians(5.0) / 2
    tree["control"] = {"kind": "quat_pd", "Pq_Nm": [2.0] * 3, "Pw_Nms": [2.8] * 3, "q_ref_wxyz": [1.0, 0, 0, 0]}
    tree["initial"] = {"q0_wxyz": [math.cos(half), 0.0, 0.0, math.sin(half)]}
    out = run_scenario(parse_config(tree), tmp_path / "s")
    assert out["saturation_fraction"] == 0.0 and out["slew_angle_deg"] == pytest.approx(5.0)
    t = read_timeseries(tmp_path / "s")["t"]
    err = np.asarray(open_records(tmp_path / "s", group="series")["error_angle_rad"])
    wn, zeta = 0.5, 0.7
    wd = wn * math.sqrt(1 - zeta**2)
    theta = 2 * half * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    np.testing.assert_allclose(err, np.abs(theta), atol=0.005 * 2 * half)


def test_checkpoint_resume_equals_the_uninterrupted_run(tmp_path, no_plots):
    cfg = parse_config(
        {**_octahedron(), "sim": {**_octahedron()["sim"], "duration_s": 1.0, "checkpoint_every_s": 0.25}}
    )
    full = run_scenario(cfg, tmp_path / "full")
    run_scenario(cfg, tmp_path / "cut", stop_after_s=0.5)
    resumed = run_scenario(cfg, tmp_path / "cut", resume=True)
    a, b = read_timeseries(tmp_path / "full"), read_timeseries(tmp_path / "cut")
    assert sorted(a) == sorted(b)
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=True), key
    for key, value in full.items():  # as JSON: NaN (no detumble within 1 s) equals NaN
        if key not in {"wall_time_s", "status_message"}:
            assert json.dumps(value) == json.dumps(resumed[key]), key


# ----------------------------------------------------------------------------- pieces


def test_strain_energy_is_mujocos_spring_potential():
    """The monitor's strain energy (struts, a taut and a slack cable, beam joints) equals MuJoCo's
    spring potential ``energy[0]`` (gravity off) at a deformed state, to 1e-9 relative (rounding)."""
    tree = _mixed()
    tree["structure"]["member_groups"].append({"kind": "cable", "nodes": [[1, 3]], "EA_N": 800.0, "prestrain": -0.05})
    cfg = parse_config(tree)
    sm = make_structure_model(cfg)
    monitor = StructureMonitor(sm, max_strain=0.5)
    model, data = sm.model, mujoco.MjData(sm.model)
    model.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    rigid_initial_state(sm, data, q0_wxyz=(1.0, 0, 0, 0), omega0_body_rad_s=(0, 0, 0))
    rng = np.random.default_rng(3)
    dq = rng.normal(scale=0.02, size=model.nv)
    mujoco.mj_integratePos(model, data.qpos, dq, 1.0)
    mujoco.mj_forward(model, data)
    state = SimpleNamespace(pos=data.xpos, xquat=data.xquat)
    strain = monitor.strains(monitor.node_positions(state))
    assert strain[-1] < 0 < strain[-2]  # the slack cable and a taut one
    assert monitor.strain_energy(strain, data.qpos) == pytest.approx(data.energy[0], rel=1e-9)


def test_node_forces_on_a_rigid_part_act_at_the_nodes():
    """Forces at nodes (one held by the hub, off its centre) give, summed over the bodies, the force
    ``Σ F`` and the moment ``Σ x × F`` about the origin (1e-12 relative), in a rotated state."""
    cfg = parse_config(_mixed())
    sm = make_structure_model(cfg)
    data = mujoco.MjData(sm.model)
    rigid_initial_state(sm, data, q0_wxyz=(0.9, 0.3, 0.3, math.sqrt(1 - 0.99)), omega0_body_rad_s=(0, 0, 0))
    mujoco.mj_forward(sm.model, data)
    F = np.random.default_rng(1).normal(size=(sm.structure.n_nodes, 3))
    xfrc = np.zeros((sm.model.nbody, 6))
    sm.nodes.apply(F, data.xquat, xfrc)
    x = sm.nodes.positions(data.xpos, data.xquat)
    np.testing.assert_allclose(x, data.site_xpos[sm.index.node_site], atol=1e-12)
    moment = xfrc[:, 3:].sum(axis=0) + np.cross(data.xipos, xfrc[:, :3]).sum(axis=0)
    np.testing.assert_allclose(xfrc[:, :3].sum(axis=0), F.sum(axis=0), rtol=1e-12)
    np.testing.assert_allclose(moment, np.cross(x, F).sum(axis=0), rtol=1e-12, atol=1e-12)


def test_dipole_allocation_makes_the_torque_across_the_field():
    """Unsaturated: the allocated dipole's torque ``(D u) × B`` is ``T``'s component across ``B``
    (1e-12); saturated: ``max |u| = 1`` and ``D u`` keeps the wanted dipole's direction; rods in one
    plane make no dipole across it."""
    rng = np.random.default_rng(7)
    axes = rng.normal(size=(9, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    alloc = DipoleAllocation(axes, np.full(9, 50.0))
    B, T = np.array([1e-5, -2e-5, 3e-5]), np.array([1e-4, 3e-4, -2e-4])
    u, saturated = alloc(T, B)
    T_perp = T - (T @ B) / (B @ B) * B
    assert not saturated and np.max(np.abs(u)) < 1
    np.testing.assert_allclose(np.cross(alloc.D @ u, B), T_perp, rtol=1e-12, atol=1e-18)
    u, saturated = alloc(1e6 * T, B)
    m = np.cross(B, T) / (B @ B)
    assert saturated and np.max(np.abs(u)) == pytest.approx(1.0)
    np.testing.assert_allclose(
        np.cross(alloc.D @ u, m), 0.0, atol=1e-9 * np.linalg.norm(alloc.D @ u) * np.linalg.norm(m)
    )
    planar = DipoleAllocation(np.array([[1.0, 0, 0], [0, 1.0, 0], [0.6, 0.8, 0]]), np.ones(3))
    u, _ = planar(np.array([0.0, 1e-6, 0.0]), np.array([1e-5, 0, 0]))  # wants m along z
    assert np.allclose(u, 0.0)


def test_a_plate_video_draws_its_top_layer():
    """The renderer gets the structure's ``top`` node set (layer-wise exaggeration and height colours;
    without it the octet plate's 3.95 m depth was stretched with its deflection and drew as a cube);
    a structure without one (the sail) or whose nodes are not bodies 1 … n gets none."""
    octet = build_scenario(load_config(CONFIGS / "octet_detumble.toml"))
    top = octet.render_info()["top_nodes"]
    assert top == sorted(octet.sm.structure.node_sets["top"].tolist()) and len(top) == 200
    assert "top_nodes" not in build_scenario(load_config(CONFIGS / "sail_detumble.toml")).render_info()
