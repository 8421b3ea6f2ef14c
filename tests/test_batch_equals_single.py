"""Every world of a batch equals the single run of its config, bit for bit.

A batch of CNUSAIL B-dot detumble worlds that differ in what a batch may vary per world — initial
rate and wheel speeds, epoch, B-dot gain and form, magnetorquer limits, wheel model, mass and
inertia, disturbance parameters, sail geometry — is run, and each world's records (every probe:
``qpos``, ``qvel``, the controller's telemetry and commands, the disturbance and magnetorquer
torques) are compared with the records of ``magsail_mj.load`` of that world's config with
``np.array_equal``: the batch performs each world's arithmetic in the single run's order
(:mod:`magsail_mj.batch.worldmath`), and MuJoCo's batch steps each world as ``mj_step`` does, so no
tolerance is needed. Status, end time and step count agree too. The per-world masses and inertias
are also shown to act: a world that differs from world 0 only in them ends elsewhere.
"""

from __future__ import annotations

import numpy as np

import magsail_mj
from tests.conftest import REPO

PRE = str(REPO / "magsail_mj/concepts/cnusail/configs/detumble_pre.toml")
POST = str(REPO / "magsail_mj/concepts/cnusail/configs/detumble_post.toml")


def assert_same_records(batch_records, single_records, where: str) -> None:
    assert set(batch_records) == set(single_records), where
    for name in single_records:
        a, b = np.asarray(batch_records[name]), np.asarray(single_records[name])
        assert a.shape == b.shape and a.dtype == b.dtype, f"{where}: {name} {a.shape} {a.dtype} vs {b.shape} {b.dtype}"
        assert np.array_equal(a, b), f"{where}: {name} differs by up to {np.nanmax(np.abs(a - b)):.3g}"


def run_and_compare(config: str, shared: list[str], worlds: list[list[str]], *, nthread: int = 1):
    sim = magsail_mj.load(config, shared, world_overrides=worlds, nthread=nthread)
    result = sim.run()
    for k, extra in enumerate(worlds):
        single = magsail_mj.load(config, [*shared, *extra]).run()
        mine = result.worlds[k]
        where = f"world {k} {extra}"
        assert (mine.status, mine.message) == (single.status, single.message), where
        assert mine.t_end_s == single.t_end_s and mine.steps == single.steps, where
        assert_same_records(mine.records, single.records, where)
    return sim, result


def test_stowed_worlds_equal_their_single_runs_and_use_their_masses():
    worlds = [
        [],
        ["initial.omega0_deg_s=[2.0, 9.0, -4.0]", "control.bdot_gain_Am2s_T=20000.0"],
        ['orbit.epoch="2016-06-01T12:00:00Z"', "initial.omega0_deg_s=[-3.0, 1.0, 8.0]"],
        ["spacecraft.mass_kg=4.5", "spacecraft.inertia_kgm2=[0.07, 0.06, 0.015]"],
        [
            'control.bdot_form="filtered"',
            'actuators.wheels.model="ideal"',
            "initial.wheel_speed_rpm=[7000.0, -100.0, 3000.0]",
        ],
        [
            'actuators.mtq.limits="half_watt"',
            "spacecraft.residual_dipole_Am2=[0.0, 0.0, 0.0]",
            "drag.drag_coefficient=2.5",
            "gravity.classical_torque=false",
        ],
    ]
    sim, result = run_and_compare(PRE, ["sim.duration_s=30"], worlds, nthread=2)
    assert result.status == ["completed"] * len(worlds)
    # world 3's mass and inertia are its own in the batch's model, and they change its motion
    masses = sim.batch.expanded("body_mass")
    bus = sim.model.body("bus").id
    assert masses is not None and masses[3, bus] != masses[0, bus] and masses[1, bus] == masses[0, bus]
    inertia = sim.batch.expanded("body_inertia")
    assert not np.array_equal(inertia[3, bus], inertia[0, bus])
    w0, w3 = result.worlds[0].records["qvel"], result.worlds[3].records["qvel"]
    assert np.array_equal(w0[0], w3[0]) and not np.allclose(w0[-1], w3[-1], rtol=1e-3, atol=0.0)


def test_deployed_worlds_equal_their_single_runs():
    worlds = [
        [],
        ["srp.enabled=false", "initial.omega0_deg_s=[1.0, -2.0, 6.0]"],
        ["spacecraft.r_cp_m=[0.02, 0.0, 0.12]", "spacecraft.sail_area_m2=3.0", 'orbit.epoch="2016-03-20T06:00:00Z"'],
        ["drag.enabled=false", "atmosphere.corotating=false", "actuators.wheels.torque_max_Nm=0.0019"],
    ]
    _, result = run_and_compare(POST, ["sim.duration_s=30"], worlds)
    assert result.status == ["completed"] * len(worlds)


def test_start_of_step_loads_equal_their_single_runs():
    worlds = [[], ["initial.omega0_deg_s=[-5.0, 4.0, 1.0]"]]
    run_and_compare(PRE, ["sim.duration_s=20", 'sim.load_timing="start"', 'sim.integrator="Euler"'], worlds)
