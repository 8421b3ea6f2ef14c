"""The truss lattice in a batch: every world equals the single run of its config, bit for bit.

Batches of the 800-node truss's orbital detumble (B-dot) and slew (quaternion feedback) worlds
that differ in what a batch may vary per world — initial rate and attitude, gain, epoch, strut
damping and stiffness (another compiled model per world), strain bound — are run, and each world's
records (``qpos`` and every orbital probe: rod counts, commanded and delivered torques, the
best-fit rotation and rate, the field, the gravity-gradient torques) are compared with those of
``magsail_mj.load`` of that world's config with ``np.array_equal``: the batch forms each world's
loads and best fit with the single run's BLAS/LAPACK calls and element-wise order
(:mod:`magsail_mj.concepts.truss_magnetorquer.batch_loads`, ``batch_control``) and runs each
world's own controller and probe functions, and MuJoCo's batch steps each world as ``mj_step``
does, so no tolerance is needed. Status, message, end time and step count agree too, also for a
world that diverges (stiffness too high for the step: MuJoCo's bad-state warning at 0.2 s) and one
whose strain bound is passed (``structure_failed``) while the others go on. The numbers do not
depend on the thread count, a state handed out by ``get_state`` continues bit-identically, and a
stopped batch resumes from its checkpoint to the uninterrupted batch's folders.
"""

from __future__ import annotations

import numpy as np
import pytest

import magsail_mj
from magsail_mj.concepts import build_task
from magsail_mj.batch.checkpoint import BATCH_CHECKPOINT_NAME
from magsail_mj.batch.folders import run_batch_folders
from magsail_mj.batch.runner import BatchSimulation
from magsail_mj.checkpoint import read_checkpoint
from magsail_mj.concepts.truss_magnetorquer.batch import TrussWorlds
from magsail_mj.concepts.truss_magnetorquer.tasks import TrussScenario
from magsail_mj.config import ConfigError, load_config
from tests.conftest import REPO
from tests.test_batch_checkpoint import _assert_same_folder
from tests.test_batch_equals_single import assert_same_records, run_and_compare

CONFIGS = REPO / "magsail_mj/concepts/truss_magnetorquer/configs"
DETUMBLE = str(CONFIGS / "detumble.toml")
SLEW = str(CONFIGS / "slew_i.toml")

WORLDS = [
    [],
    ["initial.omega0_rad_s=[0.004, -0.01, 0.002]", "control.k_bdot_Nms_T2=3e11"],
    ['orbit.epoch="2020-03-01T00:00:00Z"', "damping.zeta_strut=0.2", "initial.q0_wxyz=[0.8, 0.2, -0.4, 0.4]"],
]


def assert_same_tree(a, b, where: str = "state") -> None:
    """Equal plain-data trees (dicts, lists, arrays, numbers, None), arrays bit for bit."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), where
        for key in a:
            assert_same_tree(a[key], b[key], f"{where}.{key}")
    elif isinstance(a, list) and a and isinstance(a[0], (dict, list)) or a is None:
        assert type(a) is type(b) and (a is None or len(a) == len(b)), where
        for i, (x, y) in enumerate(zip(a or [], b or [])):
            assert_same_tree(x, y, f"{where}[{i}]")
    else:
        assert np.array_equal(np.asarray(a), np.asarray(b)), where


def test_detumble_worlds_equal_their_single_runs_on_two_threads():
    sim, result = run_and_compare(DETUMBLE, ["sim.duration_s=10"], WORLDS, nthread=2)
    assert result.status == ["completed"] * 3
    # world 2's damping is its own in the batch's model (another compiled model, fields expanded)
    assert sim.batch.expanded("tendon_damping") is not None
    w0, w1 = result.worlds[0].records["omega_est_body_rad_s"], result.worlds[1].records["omega_est_body_rad_s"]
    assert not np.allclose(w0[-1], w1[-1], rtol=1e-3, atol=0.0)
    assert result.worlds[0].records["qpos"].shape == (11, 2400)


def test_slew_worlds_equal_their_single_runs():
    run_and_compare(
        SLEW, ["sim.duration_s=4"], [[], ["control.Pq_Nm=[20.0, 40.0, 2.0]", "initial.omega0_rad_s=[0.0, 0.001, 0.0]"]]
    )


def test_a_failing_world_stops_alone():
    worlds = [[], ["stiffness.EI_Nm2=1e9"], ["sim.max_strain=1e-7"]]
    _, result = run_and_compare(DETUMBLE, ["sim.duration_s=2"], worlds, nthread=2)
    assert result.status == ["completed", "diverged", "structure_failed"]
    assert result.worlds[1].t_end_s == pytest.approx(0.2) and result.worlds[2].t_end_s == pytest.approx(1.0)
    assert "sim.max_strain" in result.worlds[2].message


def test_thread_count_does_not_change_the_numbers():
    shared = ["sim.duration_s=1"]
    one = magsail_mj.load(DETUMBLE, shared, world_overrides=WORLDS[:2], nthread=1).run()
    two = magsail_mj.load(DETUMBLE, shared, world_overrides=WORLDS[:2], nthread=2).run()
    for k in range(2):
        assert_same_records(two.worlds[k].records, one.worlds[k].records, f"world {k}")


def test_state_round_trip_continues_bit_identically():
    sim = magsail_mj.load(DETUMBLE, ["sim.duration_s=2"], world_overrides=WORLDS[:2])
    sim.step(7)
    state = sim.get_state()
    first = sim.run()
    end = sim.get_state()
    sim.set_state(state)
    assert_same_tree(sim.get_state(), state)
    again = sim.run()
    for k in range(2):
        assert_same_records(again.worlds[k].records, first.worlds[k].records, f"world {k}")
    assert_same_tree(sim.get_state(), end)
    other = magsail_mj.load(DETUMBLE, ["sim.duration_s=2"], world_overrides=WORLDS[:2])
    other.set_state(state)
    elsewhere = other.run()
    assert np.array_equal(other.get_state()["mj_state"], end["mj_state"])
    for k in range(2):
        m = len(elsewhere.worlds[k].records["t"])
        tail = {name: np.asarray(v)[-m:] for name, v in first.worlds[k].records.items()}
        assert_same_records(elsewhere.worlds[k].records, tail, f"world {k} in another batch")


def test_world_task_has_what_its_single_run_builds():
    cfg = load_config(DETUMBLE, ["sim.duration_s=2"])
    worlds = TrussWorlds([cfg])
    mine, theirs = worlds.scenario(0), build_task(cfg)
    theirs.simulation()
    assert set(vars(mine)) == set(vars(theirs))
    assert mine.cfg == theirs.cfg and mine.environment.t_max == theirs.environment.t_max
    assert type(mine.rod_load) is type(theirs.rod_load) and type(mine.controller) is type(theirs.controller)


@pytest.mark.parametrize(
    ("config", "override", "key"),
    [
        (DETUMBLE, 'sim.load_timing="midpoint"', "sim.load_timing"),
        (DETUMBLE, "srp.enabled=true", "srp.enabled"),
        (DETUMBLE, "drag.enabled=true", "drag.enabled"),
        (DETUMBLE, "gravity.j2=true", "gravity.j2"),
        (DETUMBLE, 'actuators.force_pair="printed"', "actuators.force_pair"),
        (DETUMBLE, "control.period_s=0.2", "control.period_s"),
        (DETUMBLE, "lattice.units=18", "lattice.units"),
        (DETUMBLE, "gravity.tidal=false", "gravity.tidal"),
    ],
)
def test_refusals_name_the_key(config, override, key):
    with pytest.raises(ConfigError) as err:
        magsail_mj.load(config, ["sim.duration_s=1"], world_overrides=[[], [override]])
    assert any(line.startswith(f"world 1: {key}:") for line in err.value.problems), err.value.problems


def test_other_scenarios_are_refused_by_name():
    with pytest.raises(ConfigError, match="scenario: the batch runs the truss's orbital scenarios"):
        magsail_mj.load(str(CONFIGS / "libration.toml"), ["sim.duration_s=1"], worlds=2)


def test_a_stopped_truss_batch_resumes_to_the_uninterrupted_folders(tmp_path, monkeypatch):
    """Two lattice worlds stopped at 1.3 s (their checkpoint at 1 s and the stop's at 1.3 s) and
    resumed write the uninterrupted batch's folders: every record and series bit for bit, the same
    summary but for the process's timing, the same manifest status and end time."""
    monkeypatch.setattr(TrussScenario, "plots", lambda self, run_dir, result, series: [])
    shared = ["sim.duration_s=3", "sim.checkpoint_every_s=1.0", "sim.progress=false"]

    def batch() -> magsail_mj.batch.BatchSimulation:
        return magsail_mj.load(DETUMBLE, shared, world_overrides=WORLDS[:2])

    want = [tmp_path / "whole" / f"w{k}" for k in range(2)]
    assert [o.status for o in run_batch_folders(batch(), want)] == ["completed"] * 2
    got = [tmp_path / "resumed" / f"w{k}" for k in range(2)]
    assert [o.status for o in run_batch_folders(batch(), got, stop_after_s=1.3)] == ["stopped"] * 2
    header, _, _ = read_checkpoint(got[0] / BATCH_CHECKPOINT_NAME)
    assert header["step"] == 13 and [w["folder"] for w in header["worlds"]] == ["w0", "w1"]
    restored: list[int] = []  # the resumed batch starts from the checkpoint's state, not from t = 0
    set_state = BatchSimulation.set_state
    monkeypatch.setattr(BatchSimulation, "set_state", lambda sim, state: (restored.append(1), set_state(sim, state)))
    assert [o.status for o in run_batch_folders(batch(), got, resume=True)] == ["completed"] * 2
    assert restored == [1]
    assert not (got[0] / BATCH_CHECKPOINT_NAME).exists()
    for mine, theirs in zip(got, want):
        _assert_same_folder(mine, theirs)
