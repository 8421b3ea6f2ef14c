"""Compiled loads of the reflector's pitch tracking (``sim.loads = "compiled"``): the controller,
coil torque and gravity gradient as a MuJoCo plugin built from C
(magsail_mj/compiled/reflector_loads.c) equal the Python path, converge at RK4's order with stage
timing, checkpoint and resume bit for bit, coexist with other simulations in a process and are
refused by name where they cannot run."""

from __future__ import annotations

import numpy as np
import pytest

import magsail_mj
from magsail_mj.bench import bench
from magsail_mj.concepts.reflector.compiled import PARAM_FIELDS, PROBE_FIELDS, STATE_FIELDS
from magsail_mj.concepts.reflector.env import reflector_pitch_tracking
from magsail_mj.config import ConfigError, load_config
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import error_quaternion, quat_angle
from tests.compiled_shared import assert_c_layout, assert_missing_compiler_is_refused, assert_records_close
from tests.compiled_shared import assert_resume_is_bitwise, assert_set_state_continues_bitwise, random_states
from tests.conftest import REPO

CONFIGS = REPO / "magsail_mj/concepts/reflector/configs"
TRACK, TRACK100 = CONFIGS / "tracking_10g.toml", CONFIGS / "tracking_100g.toml"
GG, FF = CONFIGS / "pitch/b5_gg_sigma10.toml", CONFIGS / "pitch/b4_rate_error_ff_sigma10.toml"


def _load(config, *overrides: str):
    return magsail_mj.load(config, ["sim.progress=false", *overrides])


def test_the_c_layout_is_the_python_layout():
    """The parameter, state and probe blocks the Python side reads and writes have the C enums'
    order and lengths."""
    assert_c_layout(
        "reflector_loads.c", [("P", PARAM_FIELDS, "SIZE"), ("S", STATE_FIELDS, "FIXED"), ("O", PROBE_FIELDS, "SIZE")]
    )


@pytest.mark.parametrize("config", [TRACK, GG, FF], ids=["baseline", "gravity_gradient", "rate_error_ff"])
def test_plugin_command_equals_the_python_controller(config):
    """At 200 random states (attitude uniform, rates up to 0.05 rad/s, times over ten orbits): what
    the plugin's C function computes equals the Python controller's command and the gravity-gradient
    load's torque to 1e-13 of their size (the same operations; the Python side's 3-vector and 3 × 3
    products go through NumPy, which may round them otherwise)."""
    sim = _load(config, "sim.loads='compiled'")
    ref = _load(config)
    m, d, plant = sim.model, sim.data, sim.compiled
    ctl = ref.controller
    gg = [load for load in ref.loads if load.name == "gravity_gradient"]
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in random_states(rng, d, n=200, rate_max_rad_s=0.05, steps=120000, dt=m.opt.timestep):
        plant.state(d, "PRIMED")[:] = 0.0  # no unwrapping memory, as the fresh steering below
        ref.data.qpos[:], ref.data.qvel[:] = d.qpos, d.qvel
        ref.kin.update(ref.data)
        state = StepState(d.time, ref.kin.pos, ref.kin.vel, ref.kin.xquat, ref.kin.omega, None)
        ctl.steering._beta = None  # the plugin's memory is unprimed at these states too
        cmd = ctl.update(state)
        for name, want in (
            ("T_ACT", cmd.torque_body),
            ("T_REF", cmd.T_ref_body),
            ("Q_E", cmd.q_e),
            ("Q_REF", cmd.q_ref),
            ("PSI", [cmd.psi_ref, cmd.psi_dot_ref, cmd.psi_ddot_ref]),
            ("B_WORLD", cmd.B_world),
            ("GG_WORLD", gg[0].torque_world(state) if gg else np.zeros(3)),
        ):
            v, want = plant.field(d, name), np.asarray(want, dtype=float)
            scale = max(float(np.abs(want).max()), 1e-300)
            worst = max(worst, float(np.abs(v - want).max()) / scale)
        assert plant.field(d, "SATURATED")[0] == float(cmd.saturated)
    assert worst < 1e-13, worst


@pytest.mark.parametrize(
    ("config", "extra", "tol"),
    [
        (TRACK, ("sim.load_timing='start'",), 1e-13),
        (TRACK, ("sim.load_timing='midpoint'",), 1e-13),
        (TRACK100, ("control.saturation='per_path'",), 1e-13),
        (TRACK, ("control.saturation='field_scaled'",), 1e-13),
        (FF, (), 1e-13),
        (GG, ("sim.load_timing='midpoint'",), 1e-12),
    ],
    ids=["start", "midpoint", "per_path", "field_scaled", "rate_error_ff", "gravity_gradient"],
)
def test_compiled_run_equals_the_python_run(config, extra, tol):
    """1 000 steps (500 s) of pitch tracking, the controller at every step's start and the loads held
    over the step: every record of the compiled run equals the Python run's to ``tol`` of the series'
    largest value. The C source performs the controller's operations in the Python path's order, so
    the records are equal to round-off (bit for bit on the development machine without the gravity
    gradient); NumPy's 3 × 3 product R I Rᵀ of the gravity gradient rounds otherwise (measured 3e-15
    relative after 3 000 s)."""
    over = ("sim.duration_s=500", *extra)
    a, b = _load(config, *over), _load(config, *over, "sim.loads='compiled'")
    ra, rb = a.run(), b.run()
    assert ra.status == rb.status == "completed"
    assert b.compiled is not None and a.compiled is None and b.controller is None and not b.loads
    assert_records_close(ra.records, rb.records, rel_tol=tol, dtypes=True)


def _final_attitude(dt: float, timing: str) -> np.ndarray:
    sim = _load(
        TRACK,
        "sim.duration_s=120",
        f"sim.timestep_s={dt}",
        f"sim.load_timing='{timing}'",
        "sim.loads='compiled'",
        f"sim.record_every={int(round(10 / dt))}",
    )
    sim.data.qvel[3:6] += np.array([2e-3, -3e-3, 1e-3])  # off the reference: the law works (saturated)
    assert sim.run().status == "completed"
    return sim.data.qpos[3:7].copy()


def test_stage_timing_converges_at_fourth_order():
    """Pitch tracking for 120 s from 3.7 mrad/s off the reference rate (the torque at its norm cap
    throughout) with the control law and loads at every RK4 stage: the attitude error at δt = 1,
    0.5, 0.25 s against δt = 1/64 s shrinks 16-fold per halving (measured orders 4.00 and 4.02;
    errors 1.8e-11, 1.1e-12, 6.9e-14 rad), where the controller held over the step converges at
    order 1 (5.3e-5 rad at δt = 1 s)."""
    ref = _final_attitude(1 / 64, "stage")

    def err(q: np.ndarray) -> float:
        return float(quat_angle(error_quaternion(ref, q)))

    errors = [err(_final_attitude(dt, "stage")) for dt in (1.0, 0.5, 0.25)]
    orders = [np.log2(errors[0] / errors[1]), np.log2(errors[1] / errors[2])]
    assert all(abs(o - 4.0) < 0.3 for o in orders), (errors, orders)
    held = [err(_final_attitude(dt, "start")) for dt in (1.0, 0.5)]
    assert abs(np.log2(held[0] / held[1]) - 1.0) < 0.2 and held[0] > 1e5 * errors[0], (held, errors)


def test_checkpoint_and_resume_are_bitwise(tmp_path):
    """A compiled run stopped at 150 s (a checkpoint every 50 s) and resumed equals the run that
    went through, record for record and bit for bit: the steering reference's unwrapping memory and
    the held torque are plugin state, part of MuJoCo's integration state."""
    over = ["sim.duration_s=300", "sim.loads='compiled'", "sim.checkpoint_every_s=50", "sim.progress=false"]
    assert "psi_ref_rad" in assert_resume_is_bitwise(TRACK, over, tmp_path, stop_after_s=150.0)


def test_get_state_and_set_state_continue_bitwise():
    over = ("sim.duration_s=300", "sim.loads='compiled'", "sim.load_timing='midpoint'")
    assert_set_state_continues_bitwise(lambda: _load(GG, *over), steps_before=137)


def test_simulations_in_one_process_do_not_share_state():
    """Three compiled simulations (two plates and two timings, one with the gravity gradient) stepped
    in turns, 7 steps at a time, end where each ends alone, with the same records: each model has its
    own plugin instance and parameter block, each MjData its own plugin state."""
    setups = [
        (TRACK, "sim.load_timing='start'"),
        (TRACK100, "sim.load_timing='midpoint'"),
        (GG, "sim.load_timing='stage'"),
    ]
    solo = []
    for config, timing in setups:
        sim = _load(config, "sim.duration_s=200", "sim.loads='compiled'", timing)
        sim.run()
        solo.append((sim.data.qvel.copy(), dict(sim.records())))
    sims = [_load(c, "sim.duration_s=200", "sim.loads='compiled'", t) for c, t in setups]
    while any(s.status == "running" for s in sims):
        for s in sims:
            s.step(7)
    for s, (qvel, records) in zip(sims, solo):
        assert np.array_equal(s.data.qvel, qvel)
        assert all(np.array_equal(np.asarray(s.records()[k]), np.asarray(v)) for k, v in records.items())


def test_refusals_name_the_key():
    with pytest.raises(ConfigError, match="sim.loads: compiled loads exist for .*reflector's pitch tracking only"):
        magsail_mj.load(CONFIGS / "detumble.toml", ["sim.loads='compiled'"])
    with pytest.raises(ConfigError, match="sim.loads: compiled loads exist for .*reflector's pitch tracking only"):
        magsail_mj.load(CONFIGS / "pitch/b3_caps_sigma10.toml", ["sim.loads='compiled'"])
    with pytest.raises(ConfigError, match="sim.loads: the environment's actions drive the reflector's coils"):
        reflector_pitch_tracking(load_config(TRACK, ["sim.loads='compiled'"]))
    with pytest.raises(ConfigError, match="sim.load_timing: 'stage'.*loads = 'compiled'"):
        load_config(TRACK, ["sim.load_timing='stage'"])


def test_bench_reports_the_compiled_step_of_the_reflector():
    """``magsail bench`` of the Python-path tracking config adds the compiled passes against the bare
    step of the model without the plugin (only the relations that hold by construction)."""
    out = bench(TRACK, duration_s=20.0, repeat=3)
    assert out["loads"] == "python" and len(out["us_per_step_compiled_runs"]) == 3
    assert out["us_per_step_compiled"] == pytest.approx(sorted(out["us_per_step_compiled_runs"])[1], rel=1e-15)
    assert out["ratio_to_mj_step_compiled"] == pytest.approx(out["us_per_step_compiled"] / out["mj_step_us"], rel=1e-12)


def test_a_missing_compiler_is_refused_naming_the_key(monkeypatch, tmp_path):
    assert_missing_compiler_is_refused(monkeypatch, tmp_path, _load, config=TRACK)
