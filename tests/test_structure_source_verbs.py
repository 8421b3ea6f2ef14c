"""``magsail validate`` and ``magsail build`` on a structure alone (a structure file or a Nastran
deck): the free structure's model at a stable step, checked against a dense eigensolve and the
step-growth probe; ``magsail run`` refuses a structure (it needs a task config) and ``--set`` is
refused for a structure, both naming the argument, with nothing written."""

from __future__ import annotations

import json
import math

import mujoco
import numpy as np
import pytest
import scipy.linalg

from magsail_mj.cli import main
from magsail_mj.structure.assembly import assemble
from magsail_mj.structure.fileformat import read_structure, write_structure
from magsail_mj.structure.model import Members, Structure
from magsail_mj.structure.stability import STABILITY_LIMITS, STEP_SAFETY, UNSTABLE_GROWTH, step_growth

SAIL = "magsail_mj/concepts/structure/configs/structures/sail_100m.toml"
DECK = "tests/data/nastran/truss_small.bdf"
OCTET = "magsail_mj/concepts/structure/configs/structures/octet_75m.toml"


def _run(capsys, argv):
    capsys.readouterr()
    code = main(argv)
    out, err = capsys.readouterr()
    return code, out, err


def _dense_omega_max(path: str) -> float:
    a = assemble(read_structure(path).structure)
    lam = scipy.linalg.eigh(a.K_r.toarray(), a.M_r.toarray(), eigvals_only=True)
    return math.sqrt(float(lam.max()))


def test_validate_a_structure_file(capsys):
    """The sail (beams, cables, panels, a hub): counts and mass of the file; the highest frequency
    equals the dense eigensolve's (Lanczos to 1e-3 relative: 2e-3 here); the proposed steps are
    STEP_SAFETY of the undamped limits; the model's step is stable on the compiled model."""
    code, out, err = _run(capsys, ["validate", SAIL])
    assert code == 0, err
    report = json.loads(out)
    s = read_structure(SAIL).structure
    total_kg, center_m, _ = s.mass_properties()
    assert report["valid"] and report["kind"] == "structure file" and report["nodes"] == s.n_nodes
    assert report["members"] == {"strut": 0, "cable": 88, "beam": 16} and report["rigid_parts"] == 1
    assert report["panels"] == len(s.panels) > 0
    assert report["mass_kg"] == pytest.approx(total_kg, rel=1e-12)
    np.testing.assert_allclose(report["center_of_mass_m"], center_m, atol=1e-9)
    omega = _dense_omega_max(SAIL)
    assert report["f_max_Hz"] == pytest.approx(omega / (2 * math.pi), rel=2e-3)
    for name, limit in STABILITY_LIMITS.items():
        assert report["proposed_timestep_s"][name] == pytest.approx(
            STEP_SAFETY * limit / (2 * math.pi * report["f_max_Hz"]), rel=1e-12
        )
    assert report["integrator"] == "RK4" and report["timestep_s"] <= report["proposed_timestep_s"]["RK4"]
    assert report["memory_estimate_bytes"] > 0


def test_build_a_structure_file_and_a_nastran_deck(tmp_path, capsys):
    """The written MJCF loads in MuJoCo with the reported sizes and step, the step is stable
    (step-growth probe); the octet plate (struts only: slide joints, so the momentum is linear in the
    velocities and RK4 keeps it to round-off) keeps its linear momentum over 400 steps from a random
    velocity to 1e-12 relative (no gravity, no external force)."""
    for source in (SAIL, DECK, OCTET):
        out_xml = tmp_path / "model.xml"
        code, out, err = _run(capsys, ["build", source, "-o", str(out_xml)])
        assert code == 0, err
        report = json.loads(out)
        model = mujoco.MjModel.from_xml_path(str(out_xml))
        assert (model.nv, model.nbody) == (report["dofs"], report["bodies"])
        assert model.opt.timestep == report["timestep_s"] and model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
        assert step_growth(model) <= UNSTABLE_GROWTH
        if source != OCTET:
            continue
        assert not np.any(model.opt.gravity)
        data = mujoco.MjData(model)
        data.qvel[:] = np.random.default_rng(1).normal(scale=1e-3, size=model.nv)
        momenta = []
        for _ in range(2):
            mujoco.mj_forward(model, data)
            mujoco.mj_subtreeVel(model, data)
            momenta.append(model.body_subtreemass[0] * data.subtree_linvel[0].copy())
            for _ in range(200):
                mujoco.mj_step(model, data)
        size = float(np.linalg.norm(momenta[0]))
        assert size > 1e-6 * float(model.body_subtreemass[0]) * 1e-3  # the draw gives it a momentum
        np.testing.assert_allclose(momenta[1], momenta[0], rtol=0, atol=1e-12 * size)


def test_a_stiff_pair_gets_a_step_inside_its_limit(tmp_path, capsys):
    """Two 1 kg masses on a 1e6 N/m strut: ω = √(2k/m) = 1414 rad/s, so RK4's proposed step is
    0.5 · 2.785/1414 s = 0.985 ms (a closed form, 1e-3 for Lanczos)."""
    positions = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    pair = Structure(
        name="pair",
        positions_m=positions,
        node_mass_kg=np.array([1.0, 1.0]),
        members=Members.build([[0, 1]], positions_m=positions, EA_N=1e6),
    )
    write_structure(pair, tmp_path / "pair.toml")
    code, out, err = _run(capsys, ["validate", str(tmp_path / "pair.toml")])
    assert code == 0, err
    report = json.loads(out)
    omega = math.sqrt(2 * 1e6 / 1.0)
    assert 2 * math.pi * report["f_max_Hz"] == pytest.approx(omega, rel=1e-3)
    assert report["proposed_timestep_s"]["RK4"] == pytest.approx(0.5 * 2.785 / omega, rel=1e-3)
    assert report["timestep_s"] == pytest.approx(0.5 * 2.785 / omega, rel=1e-3)


def test_run_refuses_a_structure_and_set_is_refused(tmp_path, capsys):
    """``run`` on a structure file exits 2 naming ``config`` and the way to a task config, with no
    run folder; ``--set`` with a structure exits 2 naming ``--set``; ``build`` of a bad structure
    exits 2 naming the element and writes no model."""
    code, _, err = _run(capsys, ["run", SAIL, "--out", str(tmp_path / "run")])
    assert code == 2 and "config:" in err and "is a structure, not a config" in err and "[structure] file" in err
    assert not (tmp_path / "run").exists()
    for verb in ("validate", "build"):
        argv = [verb, SAIL, "--set", "sim.duration_s=1"] + (["-o", str(tmp_path / "m.xml")] if verb == "build" else [])
        code, _, err = _run(capsys, argv)
        assert code == 2 and err.startswith("error: --set:"), err
    assert not (tmp_path / "m.xml").exists()
    bad = tmp_path / "bad.toml"
    text = (
        'format = "magsail-structure"\nversion = 1\nname = "bad"\n[nodes]\n'
        "position_m = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]\nmass_kg = [1.0, 1.0]\n"
        '[members]\nnodes = [[0, 7]]\nkind = "strut"\nEA_N = 1.0\n'
    )
    bad.write_text(text)
    code, _, err = _run(capsys, ["build", str(bad), "-o", str(tmp_path / "bad.xml")])
    assert code == 2 and "members" in err, err
    assert not (tmp_path / "bad.xml").exists()
