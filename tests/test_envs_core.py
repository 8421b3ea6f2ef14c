"""The dm_control environment core (magsail_mj.envs.core): registry, seeding, episode start,
termination, reward formula, action handling, state round trip.

Small, short runs: the truss at 3 × 3 cubes, 2 s; the reflector plate, 2 s.
"""

from __future__ import annotations

import math

import dm_env
import numpy as np
import pytest
from dm_control.rl import control

from magsail_mj import envs
from magsail_mj.config import load_config
from magsail_mj.concepts.current_loops.attitude import rigid_velocity_fit
from magsail_mj.envs.core import REPO_ROOT, draw_rigid_start, set_rigid_motion, summary_mismatches
from magsail_mj.estimation.attitude import BestFitRotation
from magsail_mj.quaternion import quat_from_matrix

TRUSS = ["lattice.units=3", "sim.duration_s=2", 'control.cache_dir=""']
PLATE = ["sim.duration_s=2"]
MINE = (
    "truss/detumble",
    "truss/slew_I",
    "truss/slew_II",
    "truss/slew_III",
    "truss/slew_IV",
    "current_loops/slew",
    "reflector/detumble",
    "reflector/pitch_tracking",
)
SMALL = {"truss": TRUSS, "current_loops": ["lattice.units=3", "sim.duration_s=2"], "reflector": PLATE}


def small(name: str) -> list[str]:
    return SMALL[name.split("/")[0]]


def test_list_names_every_task_of_this_module() -> None:
    names = envs.list()
    assert names == sorted(names)
    for name in MINE:
        assert name in names


def test_every_task_config_exists() -> None:
    for name in envs.list():
        assert envs.core.task_entry(name).config.is_file(), name


def test_discovery_registers_every_concept_env_module_and_names_it_by_domain() -> None:
    """Each task is registered by the ``env`` module of a concept package (found by discovery, no
    concept named in magsail_mj.envs); ``envs.<domain>`` and ``envs.<concept>`` are that module."""
    modules = envs.ENV_MODULES
    assert modules and all(m.__name__ == f"magsail_mj.concepts.{c}.env" for c, m in modules.items())
    for name in envs.list():
        module = getattr(envs, name.partition("/")[0])
        assert module.__name__ == envs.core.task_entry(name).factory.__module__, name
        assert module in modules.values()
    assert envs.truss is envs.truss_magnetorquer is modules["truss_magnetorquer"]
    with pytest.raises(AttributeError, match="'zz_nope'"):
        envs.zz_nope  # noqa: B018
    assert not hasattr(envs, "__wrapped__")


def test_load_by_name_and_by_path_give_the_same_task() -> None:
    by_name = envs.load("truss/detumble", TRUSS, randomize=False)
    by_path = envs.load(
        REPO_ROOT / "magsail_mj/concepts/truss_magnetorquer/configs/detumble.toml", TRUSS, randomize=False
    )  # noqa: E501
    assert type(by_name.task) is type(by_path.task)
    a, b = by_name.reset().observation, by_path.reset().observation
    assert a.keys() == b.keys()
    for key in a:
        np.testing.assert_array_equal(a[key], b[key])


def test_unknown_name_and_unserved_config_are_refused_by_name() -> None:
    with pytest.raises(ValueError, match="task: unknown environment 'truss/nope'"):
        envs.load("truss/nope")
    with pytest.raises(ValueError, match="config: .*cantilever.*has no environment"):
        envs.load(REPO_ROOT / "magsail_mj/concepts/truss_magnetorquer/configs/cantilever.toml", ["lattice.units=3"])


def test_bad_task_options_name_the_option() -> None:
    with pytest.raises(ValueError, match="action: must be 'torque' or 'rods'"):
        envs.load("truss/detumble", TRUSS, action="dipoles")
    with pytest.raises(ValueError, match="health_every"):
        envs.load("truss/detumble", TRUSS, health_every=0)
    with pytest.raises(TypeError, match="random: expected an int seed"):
        envs.load("reflector/detumble", PLATE, random="seven")
    with pytest.raises(ValueError, match="reward_weights.w_u"):
        envs.load("reflector/detumble", PLATE, reward_weights={"w_u": -1.0})


@pytest.mark.parametrize("name", MINE)
def test_same_seed_gives_the_same_first_observation(name: str) -> None:
    """Two environments made with the same seed start alike; another seed starts elsewhere."""
    first = [envs.load(name, small(name), random=seed).reset().observation for seed in (11, 11, 12)]
    assert first[0].keys() == first[1].keys()
    for key in first[0]:
        np.testing.assert_array_equal(first[0][key], first[1][key])
    assert not np.array_equal(first[0]["attitude_wxyz"], first[2]["attitude_wxyz"])


def test_random_state_object_is_used_as_given() -> None:
    rs_a, rs_b = np.random.RandomState(5), np.random.RandomState(5)
    a = envs.load("reflector/detumble", PLATE, random=rs_a)
    b = envs.load("reflector/detumble", PLATE, random=rs_b)
    assert a.task.random is rs_a
    np.testing.assert_array_equal(a.reset().observation["body_rate_rad_s"], b.reset().observation["body_rate_rad_s"])


def test_randomize_false_starts_from_the_config() -> None:
    env = envs.load("reflector/detumble", PLATE, randomize=False)
    obs = env.reset().observation
    cfg = env.physics.cfg
    np.testing.assert_allclose(obs["attitude_wxyz"], cfg.initial.q0_wxyz, rtol=0, atol=1e-15)
    np.testing.assert_allclose(obs["body_rate_rad_s"], cfg.initial.omega0_rad_s, rtol=0, atol=1e-15)


def test_drawn_start_is_within_its_documented_ranges() -> None:
    env = envs.load("reflector/detumble", PLATE, random=3, rate_range_rad_s=0.02, attitude_range_deg=30.0)
    for _ in range(5):
        obs = env.reset().observation
        start = env.task.start
        assert np.all(np.abs(start["omega0_body_rad_s"]) <= 0.02)
        np.testing.assert_allclose(obs["body_rate_rad_s"], start["omega0_body_rad_s"], rtol=0, atol=1e-15)
        q0 = np.asarray(env.physics.cfg.initial.q0_wxyz)
        angle = 2 * math.acos(min(1.0, abs(float(q0 @ obs["attitude_wxyz"]))))
        assert angle <= math.radians(30.0) + 1e-12


def test_rigid_motion_of_a_lattice_is_what_the_estimators_read() -> None:
    """set_rigid_motion on the current-loop lattice: the best-fit rotation of the nodes is the drawn
    attitude and the least-squares rigid-velocity fit the drawn rate (independent estimators)."""
    env = envs.load("current_loops/slew", ["lattice.units=3", "sim.duration_s=2"], randomize=False)
    env.reset()
    q, w = draw_rigid_start(
        np.random.RandomState(0), q0_wxyz=np.array([1.0, 0, 0, 0]), rate_range_rad_s=0.01, attitude_range_rad=math.pi
    )
    physics = env.physics
    set_rigid_motion(physics, q_wxyz=q, omega_body_rad_s=w)
    state = physics.step_state()
    nodes = env.task.nodes
    x, v = state.pos[nodes], state.vel[nodes]
    R, _ = BestFitRotation(env.physics.scenario.lm.lattice.nodes)(x)
    q_fit = quat_from_matrix(R)
    assert abs(abs(float(q_fit @ q)) - 1.0) < 1e-12
    np.testing.assert_allclose(R.T @ rigid_velocity_fit(x, v, env.task.masses), w, rtol=0, atol=1e-14)


def test_time_limit_is_the_duration_and_ends_with_discount_one() -> None:
    env = envs.load("reflector/detumble", PLATE, random=0)
    assert env.control_timestep() == pytest.approx(env.physics.cfg.sim.timestep_s, rel=1e-15)
    total, n = envs.run_episode(env, lambda ts: np.zeros(2))
    assert n == 20 and math.isfinite(total)
    assert env.physics.time() == pytest.approx(2.0, rel=1e-12)
    assert env.physics.status == "completed"


def test_divergence_ends_the_episode_with_discount_zero() -> None:
    env = envs.load("truss/detumble", TRUSS, random=0)
    env.reset()
    env.physics.data.qvel[0] = np.inf
    ts = env.step(np.zeros(3))
    assert ts.last() and ts.discount == 0.0
    assert env.physics.status == "diverged"
    with pytest.raises(control.PhysicsError):
        env.physics.check_divergence()
    assert env.step(np.zeros(3)).first()  # the next step starts a new episode


def test_structural_failure_ends_the_episode_with_discount_zero() -> None:
    env = envs.load("truss/detumble", [*TRUSS, "sim.max_strain=1e-9"], random=0, rate_range_rad_s=0.05)
    ts = env.reset()
    while not ts.last():
        ts = env.step(np.zeros(3))
    assert env.physics.status == "structure_failed"
    assert ts.discount == 0.0
    assert env.physics.time() < 2.0


def test_reward_is_the_documented_formula() -> None:
    """r = −(w_θ (θ/π)² + w_ω (|ω|/ω_s)² + w_u mean((a/a_max)²) + w_ε (ε_max/ε_fail)²), computed here
    from the observation with the task's weights."""
    weights = {"w_theta": 2.0, "w_omega": 0.5, "w_u": 0.25, "w_strain": 3.0}
    env = envs.load("truss/slew_I", TRUSS, random=4, reward_weights=weights)
    env.reset()
    action = np.array([0.5, -1.0, 0.25])
    ts = env.step(action)
    obs, task = ts.observation, env.task
    q_ref = np.asarray(obs["target_wxyz"])
    theta = 2 * math.acos(min(1.0, abs(float(q_ref @ obs["attitude_wxyz"]))))
    a_max = task.action_high
    expected = -(
        2.0 * (theta / math.pi) ** 2
        + 0.5 * (np.linalg.norm(obs["body_rate_rad_s"]) / 1e-3) ** 2
        + 0.25 * np.mean((action / a_max) ** 2)
        + 3.0 * (obs["strain_max"][0] / env.physics.cfg.sim.max_strain) ** 2
    )
    assert ts.reward == pytest.approx(expected, rel=1e-12)
    assert theta > 0.1  # the slew target is far: the pointing term is exercised


def test_actions_are_clipped_where_the_hardware_clips_them() -> None:
    env = envs.load("reflector/detumble", PLATE, random=0)
    env.reset()
    high = env.action_spec().maximum
    env.step(10 * high)
    np.testing.assert_array_equal(env.physics.controller.action, high)
    cmd = env.physics.controller.command
    np.testing.assert_array_equal(cmd.currents_A, high)
    with pytest.raises(ValueError, match="action: expected shape"):
        env.step(np.zeros(3))


def test_state_round_trip_continues_identically() -> None:
    env = envs.load("reflector/pitch_tracking", ["sim.duration_s=5"], random=1)
    env.reset()
    env.step(np.array([1e-4, 0.0, 0.0]))
    state = env.physics.get_state()
    after = [env.step(np.zeros(3)).observation["attitude_wxyz"] for _ in range(3)]
    env.physics.set_state(state)
    again = [env.step(np.zeros(3)).observation["attitude_wxyz"] for _ in range(3)]
    np.testing.assert_array_equal(np.array(after), np.array(again))
    assert env.physics.flat_state().dtype == np.float64


def test_summary_mismatches_reports_what_differs() -> None:
    ref = {"a_s": 1.0, "b": float("nan"), "c": "x", "wall_time_s": 3.0, "d": 2.0}
    same = {"a_s": 1.0 + 1e-12, "b": float("nan"), "c": "x", "wall_time_s": 9.0, "d": 2.0}
    assert summary_mismatches(ref, same) == []
    bad = summary_mismatches(ref, {"a_s": 1.0 + 1e-6, "b": 0.0, "c": "y"})
    assert [line.split(":")[0] for line in bad] == ["a_s", "b", "c", "d"]


def test_first_time_step_has_no_reward_and_specs_match() -> None:
    env = envs.load("current_loops/slew", ["lattice.units=3", "sim.duration_s=2"], random=0)
    ts = env.reset()
    assert ts.step_type == dm_env.StepType.FIRST and ts.reward is None
    spec = env.observation_spec()
    assert list(spec) == list(ts.observation)
    for key, value in ts.observation.items():
        assert value.dtype == np.float64 and spec[key].shape == value.shape
    assert env.action_spec().name == "I_C_x_A,I_C_y_A,I_B_A"


@pytest.mark.parametrize("name", ["truss/slew_I", "current_loops/slew", "reflector/pitch_tracking"])
def test_a_second_episode_repeats_the_first(name: str) -> None:
    """reset() restores the whole simulation (controller memory, loads, records): the shipped
    policy's second episode on the same environment has the first one's summary exactly."""
    env = envs.load(name, small(name), randomize=False)
    policy = envs.shipped_policy(env)
    first = (envs.run_episode(env, policy), env.physics.summary())
    second = (envs.run_episode(env, policy), env.physics.summary())
    assert first[0] == second[0]
    assert summary_mismatches(first[1], second[1], rel=0.0) == []


def test_a_validated_config_with_overrides_is_accepted() -> None:
    cfg = load_config(REPO_ROOT / "magsail_mj/concepts/reflector/configs/detumble.toml")
    env = envs.load(cfg, ["sim.duration_s=1"], randomize=False)
    assert type(env.task).__name__ == "ReflectorDetumbleTask"
    assert envs.run_episode(env, lambda ts: np.zeros(2))[1] == 10


def _attitude_kind(cfg) -> bool:
    """The attitude-control scenarios of the truss, current-loop and reflector concepts: a closed
    loop the environment replaces (not the structural load cases, free drift, open-loop torque
    profiles, structural sweeps or the reflector's cap search)."""
    if cfg.concept == "truss_magnetorquer":
        return cfg.scenario in ("detumble", "slew")
    if cfg.concept == "current_loops":
        return cfg.scenario in ("slew", "slew_rigid")
    return cfg.concept == "reflector" and cfg.kind in ("detumble", "pitch")


def test_every_shipped_attitude_config_of_these_concepts_has_an_environment() -> None:
    """Every config file under models/ of the three concepts: an attitude scenario is served by a
    task of its concept, any other kind is refused (no build: the registry's match only)."""
    served, refused = 0, 0
    for folder in ("truss_magnetorquer", "current_loops", "reflector"):
        for path in sorted((REPO_ROOT / "magsail_mj" / "concepts" / folder).rglob("*.toml")):
            try:
                cfg = load_config(path)
            except ValueError:
                continue  # a sweep file, not a run config
            if _attitude_kind(cfg):
                entry = envs.core.entry_for_config(cfg, str(path))
                assert entry.name.split("/")[0] == folder.replace("_magnetorquer", ""), path
                served += 1
            else:
                with pytest.raises(ValueError, match="has no environment"):
                    envs.core.entry_for_config(cfg, str(path))
                refused += 1
    assert served >= 25 and refused >= 20
