"""Compiled loads (``sim.loads = "compiled"``): the CNUSAIL cubesat's loads as a MuJoCo plugin built
from C (magsail_mj/compiled/cubesat_loads.c) equal the Python path, converge at RK4's order with
stage timing, checkpoint and resume bit for bit, coexist with other simulations in a process, are
refused by name without a compiler, and keep the runner's divergence checks."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import magsail_mj
from magsail_mj.bench import bench
from magsail_mj.compiled import SOURCE_DIR, build
from magsail_mj.concepts.cnusail.compiled import PARAM_FIELDS, STATE_FIELDS
from magsail_mj.concepts.cnusail.env import make_cubesat_environment
from magsail_mj.config import ConfigError, load_config
from magsail_mj.loads.base import StepState
from magsail_mj.quaternion import quat_conj, quat_mul
from tests.compiled_shared import assert_c_layout, assert_missing_compiler_is_refused, assert_records_close
from tests.compiled_shared import assert_resume_is_bitwise, assert_set_state_continues_bitwise, random_states
from tests.conftest import REPO

CONFIGS = REPO / "magsail_mj/concepts/cnusail/configs"
PRE, POST = CONFIGS / "detumble_pre.toml", CONFIGS / "detumble_post.toml"


def _load(config, *overrides: str):
    return magsail_mj.load(config, ["sim.progress=false", *overrides])


def test_the_c_layout_is_the_python_layout():
    """The parameter and state blocks the Python side writes have the C enums' order and lengths."""
    assert_c_layout(
        "cubesat_loads.c", [("P", PARAM_FIELDS, "EXP"), ("S", STATE_FIELDS, "FIXED")], constants={"MAX_FACETS": 8}
    )


@pytest.mark.parametrize("config", [PRE, POST], ids=["stowed", "deployed"])
def test_plugin_torques_equal_the_python_loads(config):
    """At 200 random states (attitude uniform, rates up to 10°/s, times over the run, random held
    dipoles): the plugin's five body-axes torques at the step's start equal the Python loads'
    (CubesatDisturbanceLoad.torques_body and m × Rᵀ B) to 1e-12 of the largest (the same formulas
    in C and Python: they differ by round-off only)."""
    sim = _load(config, "sim.duration_s=6000", "sim.loads='compiled'", "sim.load_timing='start'")
    m, d, plant, sc = sim.model, sim.data, sim.compiled, sim.scenario
    rng = np.random.default_rng(5)
    worst = 0.0
    for _ in random_states(rng, d, n=200, rate_max_rad_s=0.17, steps=30000, dt=m.opt.timestep, speed_max_m_s=1.0):
        dipole = rng.uniform(-0.2, 0.2, 3)
        plant.write_command(d, dipole_Am2=dipole, wheel_cmd=np.zeros(3))
        mujoco.mj_forward(m, d)
        got = plant.state(d, "SOURCES").reshape(5, 3)
        sim.kin.update(d)
        env = sc.environment.sample(d.time)
        state = StepState(d.time, sim.kin.pos, sim.kin.vel, sim.kin.xquat, sim.kin.omega, env)
        R = np.empty(9)
        mujoco.mju_quat2Mat(R, sim.kin.xquat[1])
        k = int(round(d.time / m.opt.timestep))
        on = k % sim.controller.controller._n_cycle < sim.controller.controller._n_on
        want = np.vstack(
            [sc.disturbances.torques_body(state), np.cross(dipole if on else 0 * dipole, R.reshape(3, 3).T @ env.B_eci)]
        )
        scale = np.abs(want).max()
        worst = max(worst, float(np.abs(got - want).max() / scale))
    assert worst < 1e-12, worst


@pytest.mark.parametrize("config", [PRE, POST], ids=["stowed", "deployed"])
@pytest.mark.parametrize("timing", ["start", "midpoint"])
def test_compiled_run_equals_the_python_run(config, timing):
    """300 steps (60 s) of the detumble, loads held over the step at its start or its predicted
    middle: every record of the compiled run equals the Python run's to 1e-10 of the series'
    largest value (the torques differ by round-off, ~1e-16, which 300 steps of the tumbling
    spacecraft grow by far less than 10⁶; measured 5e-15)."""
    over = ("sim.duration_s=60", f"sim.load_timing='{timing}'")
    a, b = _load(config, *over), _load(config, *over, "sim.loads='compiled'")
    ra, rb = a.run(), b.run()
    assert ra.status == rb.status == "completed"
    assert b.compiled is not None and a.compiled is None
    assert_records_close(ra.records, rb.records, rel_tol=1e-10)


@pytest.mark.parametrize(
    ("config", "extra"),
    [("nadir_post.toml", ()), ("pd_vs_eigenaxis.toml", ("control.mode='pd'",))],
    ids=["eigen_axis", "pd"],
)
def test_compiled_slews_with_wheels_equal_the_python_run(config, extra):
    """The pointing laws drive the wheels through the DC-motor driver (held current command, the
    per-step voltage clip, back-EMF and speed limiter in the plugin) and unload them with the
    magnetorquers: 1 000 steps (200 s) of the deployed eigen-axis slew and of the PD slew, mid-step
    loads, every record within 1e-9 of the series' largest value of the Python run's (the closed
    loop carries round-off on; measured 1.5e-12 and 4.6e-12)."""
    over = ("sim.duration_s=200", "sim.load_timing='midpoint'", *extra)
    a, b = _load(CONFIGS / config, *over), _load(CONFIGS / config, *over, "sim.loads='compiled'")
    ra, rb = a.run(), b.run()
    assert ra.status == rb.status == "completed"
    assert np.abs(np.asarray(ra.records["T_M_Nm"])).max() > 1e-5  # the wheels do work
    assert_records_close(ra.records, rb.records, rel_tol=1e-9)


def _final_state(dt: float, timing: str) -> tuple[np.ndarray, np.ndarray]:
    sim = _load(
        PRE,
        "sim.duration_s=60",
        f"sim.timestep_s={dt}",
        f"sim.load_timing='{timing}'",
        "sim.loads='compiled'",
        f"sim.record_every={int(round(10 / dt))}",
        "drag.enabled=false",
    )
    assert sim.run().status == "completed"
    return sim.data.qpos[3:7].copy(), sim.data.qvel[3:6].copy()


def _angle(q1: np.ndarray, q2: np.ndarray) -> float:
    dq = quat_mul(quat_conj(q1), q2)
    return 2.0 * float(np.arctan2(np.linalg.norm(dq[1:]), abs(dq[0])))


def test_stage_timing_converges_at_fourth_order():
    """The stowed detumble (B-dot, K = 3e4) for 60 s with the loads at every RK4 stage: the attitude
    error at δt = 0.2, 0.1, 0.05 s against δt = 0.0125 s shrinks 16-fold per halving (measured
    orders 4.00 and 4.00; errors 1.9e-9, 1.2e-10, 7.3e-12 rad), where loads held at the step's
    midpoint converge at order 2. Drag is off: its one-sided bus faces switch on and off as they turn
    through edge-on, a kink in the torque that caps any integrator at second order locally (with
    drag the stage-timing errors are 5.9e-9 / 1.7e-9 / 1.6e-9 rad)."""
    ref = _final_state(0.0125, "stage")
    errors = [_angle(_final_state(dt, "stage")[0], ref[0]) for dt in (0.2, 0.1, 0.05)]
    orders = [np.log2(errors[0] / errors[1]), np.log2(errors[1] / errors[2])]
    assert all(abs(o - 4.0) < 0.3 for o in orders), (errors, orders)
    mid = _angle(_final_state(0.2, "midpoint")[0], ref[0])
    assert mid > 100 * errors[0], (mid, errors)


def test_checkpoint_and_resume_are_bitwise(tmp_path):
    """A compiled run stopped at 30 s (a checkpoint every 10 s) and resumed equals the run that went
    through, record for record and bit for bit: the plugin's held command and step memory are part
    of MuJoCo's integration state, which the checkpoint carries."""
    over = ["sim.duration_s=60", "sim.loads='compiled'", "sim.checkpoint_every_s=10", "sim.progress=false"]
    assert_resume_is_bitwise(PRE, over, tmp_path, stop_after_s=30.0)


def test_get_state_and_set_state_continue_bitwise():
    over = ("sim.duration_s=60", "sim.loads='compiled'", "sim.load_timing='midpoint'")
    assert_set_state_continues_bitwise(lambda: _load(PRE, *over), steps_before=37)


def test_two_simulations_in_one_process_do_not_share_state():
    """The stowed and the deployed detumble stepped in turns, 7 steps at a time, end where each
    ends alone: each model has its own plugin instance and each MjData its own plugin state."""
    solo = []
    for config in (PRE, POST):
        sim = _load(config, "sim.duration_s=30", "sim.loads='compiled'")
        sim.run()
        solo.append(sim.data.qvel.copy())
    a, b = (_load(c, "sim.duration_s=30", "sim.loads='compiled'") for c in (PRE, POST))
    while a.status == "running" or b.status == "running":
        a.step(7)
        b.step(7)
    assert np.array_equal(a.data.qvel, solo[0]) and np.array_equal(b.data.qvel, solo[1])


def test_a_missing_compiler_is_refused_naming_the_key(monkeypatch, tmp_path):
    assert_missing_compiler_is_refused(monkeypatch, tmp_path, _load, config=PRE)


def test_the_library_is_keyed_by_source_mujoco_and_compiler(monkeypatch, tmp_path):
    monkeypatch.setenv("MAGSAIL_COMPILED_CACHE", str(tmp_path))
    path = build.library_path("cubesat_loads")
    assert path.parent.parent == tmp_path and path.name == "libcubesat_loads.so"
    monkeypatch.setattr(build.mujoco, "__version__", "0.0.0")
    assert build.library_path("cubesat_loads") != path


def test_the_library_key_covers_the_folders_headers(monkeypatch, tmp_path):
    """The sources include the folder's headers (plugin_common.h): an edited header, or a new
    one, keys another library, so the next load builds anew; the unchanged folder keys the same."""
    monkeypatch.setenv("MAGSAIL_COMPILED_CACHE", str(tmp_path / "cache"))
    src = tmp_path / "src"
    src.mkdir()
    for f in [*SOURCE_DIR.glob("*.c"), *SOURCE_DIR.glob("*.h")]:
        (src / f.name).write_bytes(f.read_bytes())
    assert (src / "plugin_common.h").is_file() and '#include "plugin_common.h"' in (src / "cubesat_loads.c").read_text()
    monkeypatch.setattr(build, "SOURCE_DIR", src)
    path = build.library_path("cubesat_loads")
    assert build.library_path("cubesat_loads") == path
    header = src / "plugin_common.h"
    header.write_text(header.read_text() + "\n/* edited */\n")
    edited = build.library_path("cubesat_loads")
    assert edited != path
    (src / "extra.h").write_text("/* another header */\n")
    assert build.library_path("cubesat_loads") not in (path, edited)


def test_refusals_name_the_key():
    with pytest.raises(ConfigError, match="sim.load_timing: 'stage'.*loads = 'compiled'"):
        load_config(PRE, ["sim.load_timing='stage'"])
    with pytest.raises(ConfigError, match="sim.loads: compiled loads exist for the CNUSAIL attitude runs and the"):
        magsail_mj.load(CONFIGS / "lifetime.toml", ["sim.loads='compiled'"])
    with pytest.raises(ConfigError, match="world 1: sim.loads: must be the same in every world of a batch"):
        magsail_mj.load(PRE, ["sim.duration_s=10"], world_overrides=[[], ["sim.loads='compiled'"]])
    with pytest.raises(ConfigError, match="sim.loads: the environment drives"):
        make_cubesat_environment(load_config(PRE, ["sim.loads='compiled'"]))
    with pytest.raises(ConfigError, match="actuators.wheels.electrical: compiled loads model the quasi-static"):
        _load(PRE, "sim.duration_s=10", "sim.loads='compiled'", "actuators.wheels.electrical='substep'")


def test_a_diverging_compiled_run_is_dated_as_the_python_run():
    """A velocity made NaN after 13 steps: the compiled run (whose steps between records run in one
    native call) stops as 'diverged' at the same step with the same message as the Python run."""
    out = {}
    for kind in ("python", "compiled"):
        sim = _load(PRE, "sim.duration_s=20", f"sim.loads='{kind}'")
        sim.step(13)
        sim.data.qvel[4] = np.nan
        result = sim.run()
        out[kind] = (result.status, result.message, sim.step_index, len(result.records["t"]))
    assert out["python"][0] == "diverged", out
    assert out["compiled"] == out["python"]


def test_a_blow_up_inside_a_native_chunk_is_dated_to_its_step():
    """A huge body rate set at step 11 overflows inside the steps the native loop runs in one call;
    the chunk is stepped again one by one and the run is dated at the step of the first bad state,
    as the Python loop dates it."""
    out = {}
    for kind in ("python", "compiled"):
        sim = _load(PRE, "sim.duration_s=20", f"sim.loads='{kind}'", "sim.record_every=50")
        sim.step(11)
        sim.data.qvel[3:6] = 3e9
        result = sim.run()
        out[kind] = (result.status, result.message, sim.step_index)
    assert out["python"][0] == "diverged", out
    assert out["compiled"] == out["python"]


def test_bench_reports_the_compiled_step_beside_the_python_one():
    """``magsail bench`` of a Python-path CNUSAIL config adds the compiled passes, their median and
    its ratio to the same bare step (no timing threshold: only the relations that hold by
    construction); a config already compiled reports its loads, and another concept has no such
    field."""
    out = bench(PRE, duration_s=4.0, repeat=3)
    assert out["loads"] == "python" and len(out["us_per_step_compiled_runs"]) == 3
    assert out["us_per_step_compiled"] == pytest.approx(sorted(out["us_per_step_compiled_runs"])[1], rel=1e-15)
    assert out["ratio_to_mj_step_compiled"] == pytest.approx(out["us_per_step_compiled"] / out["mj_step_us"], rel=1e-12)
    compiled = bench(PRE, duration_s=4.0, overrides=["sim.loads='compiled'"])
    assert compiled["loads"] == "compiled" and "us_per_step_compiled" not in compiled
    other = bench(REPO / "magsail_mj/concepts/msac/configs/slow_1hz.toml", duration_s=0.05)
    assert "us_per_step_compiled" not in other and "compiled_unavailable" not in other


def test_bench_says_why_compiled_loads_are_unavailable(monkeypatch, tmp_path):
    monkeypatch.setenv("MAGSAIL_CC", str(tmp_path / "no-such-cc"))
    out = bench(PRE, duration_s=2.0)
    assert "us_per_step_compiled" not in out
    assert "sim.loads: 'compiled' needs a C compiler" in out["compiled_unavailable"]
