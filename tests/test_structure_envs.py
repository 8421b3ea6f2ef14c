"""Environment of the structure concept (magsail_mj.concepts.structure.env): dm_env contract, the
shipped controllers as policies (the run's summary to 1e-9 relative; the rods and currents actions
give the run's records exactly), the dipole action's torque, a held loop current's torque, seeding,
the drawn start, termination when a member breaks, action bounds and refusals.

Small, short runs: the regular octahedron of the concept's tests (6 nodes of 1 kg, 12 struts with a
200 A m² rod each, isotropic inertia 4 kg m², a constant field, free space) at δt = 5 ms, control
every 50 ms, 1 s (20 environment steps), and the same with current loops on its three equators
(2 m² each, at most 50 A); the shipped 100 m sail (``structure/detumble``) for 2–3 s and the
shipped 100 m reflector slewed by its two rim loops for 3 s.
"""

from __future__ import annotations

import copy
import math
import re
from typing import Any

import magsail_mj
import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from magsail_mj import envs
from magsail_mj.concepts.structure.env import B_BOUND_T, StructureRodsTask
from magsail_mj.config import parse_config
from magsail_mj.envs.core import REQUEST_HEADROOM
from magsail_mj.quaternion import quat_from_matrix
from tests.envs_shared import RandomActions, assert_shipped_policy_gives_the_run_summary, built_environment

SAIL = "structure/detumble"
SAIL_SHORT = ("sim.duration_s=3", "sim.progress=false")  # control every 0.5 s: 6 steps
REFLECTOR = envs.core.REPO_ROOT / "magsail_mj/concepts/structure/configs/reflector_loops_slew.toml"
REFLECTOR_SHORT = ["sim.duration_s=3", "sim.progress=false"]  # control every 1 s: 3 steps
LOOP_I_MAX_A = 50.0
FIELD_T = 3e-5
INERTIA_KGM2 = 4.0  # six 1 kg nodes at unit distance: I = 2 · 2 · 1 kg m² about every axis


def octahedron(scenario: str = "detumble", **sim: Any) -> dict[str, Any]:
    """A regular octahedron (nodes ±e_i, 1 kg each), its 12 edges stiff damped struts with a rod
    each, in a constant field along z, free space; B-dot below saturation (k B² / I = 0.2 /s) or,
    for a slew, quaternion PD towards identity from 5° about z."""
    nodes = [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0], [0, 0, -1.0]]
    edges = [[a, b] for a in range(6) for b in range(a + 1, 6) if b != a + 1 or a % 2]
    tree: dict[str, Any] = {
        "concept": "structure",
        "scenario": scenario,
        "sim": {"duration_s": 1.0, "timestep_s": 5e-3, "record_every": 10, "progress": False, **sim},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 1.0},
            "member_groups": [{"kind": "strut", "name": "edges", "nodes": edges, "EA_N": 2.0e4, "damping_Ns_m": 20.0}],
        },
        "actuators": {"member_set": "edges", "dipole_max_Am2": 200.0},
        "field": {"model": "constant", "constant_T": [0.0, 0.0, FIELD_T]},
        "control": {"kind": "bdot", "k_bdot_Nms_T2": 0.2 * INERTIA_KGM2 / FIELD_T**2, "period_s": 0.05},
        "initial": {"omega0_rad_s": [0.01, 0.0, 0.0]},
    }
    if scenario == "slew":
        half = math.radians(5.0) / 2
        tree["field"]["constant_T"] = [FIELD_T, 0.0, 0.0]
        tree["control"] = {
            "kind": "quat_pd",
            "period_s": 0.05,
            "Pq_Nm": [2.0] * 3,
            "Pw_Nms": [2.8] * 3,
            "q_ref_wxyz": [1.0, 0.0, 0.0, 0.0],
        }
        tree["initial"] = {"q0_wxyz": [math.cos(half), 0.0, 0.0, math.sin(half)]}
    return tree


def looped(scenario: str = "detumble", *, rods: bool = True, field_T: Any = None) -> dict[str, Any]:
    """The octahedron with a current loop on each of its three equators (the squares of the nodes
    ±e_j, ±e_k: vector areas 2 m² along +z, +x, +y in that order, at most ``LOOP_I_MAX_A``), with or
    without its rods; ``field_T`` replaces the constant field."""
    tree = octahedron(scenario)
    edges = tree["structure"]["member_groups"][0]["nodes"]
    index = {tuple(e): i for i, e in enumerate(edges)}

    def loop(seq: list[int]) -> list[int]:
        return [index[(min(a, b), max(a, b))] for a, b in zip(seq, seq[1:] + seq[:1])]

    tree["structure"]["member_sets"] = {
        "eq_z": loop([0, 2, 1, 3]),
        "eq_x": loop([2, 4, 3, 5]),
        "eq_y": loop([4, 0, 5, 1]),
    }
    tree["loops"] = {"member_sets": ["eq_z", "eq_x", "eq_y"], "I_max_A": LOOP_I_MAX_A}
    if not rods:
        del tree["actuators"]
    if field_T is not None:
        tree["field"]["constant_T"] = list(field_T)
    return tree


def load(tree: dict[str, Any], **options: Any):
    return envs.load(parse_config(tree), **options)


def run_of(tree: dict[str, Any]) -> tuple[Any, Any]:
    """The plain run of a config (``magsail run`` without outputs): its simulation and result."""
    sim = magsail_mj.load(parse_config(tree))
    return sim, sim.run()


class StructureDetumbleTorqueEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return load(octahedron(), random=0)


class StructureSlewRodsEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return load(octahedron("slew"), random=0, action="rods")


class StructureLoopsDetumbleTorqueEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return load(looped(rods=False), random=0)


class StructureLoopsSlewCurrentsEnvTest(RandomActions, test_utils.EnvironmentTestMixin, absltest.TestCase):
    def make_object_under_test(self):
        return load(looped("slew"), random=0, action="currents")


# ----------------------------------------------------------------------------- the shipped controllers


def test_shipped_sail_controller_through_the_environment_gives_the_run_summary() -> None:
    """The shipped sail (beams from a rigid hub, a cable net, tidal gravity and the IGRF field in
    orbit) under its B-dot: every summary key of the run to 1e-9 relative."""
    ref, steps = assert_shipped_policy_gives_the_run_summary(
        SAIL, list(SAIL_SHORT), reference=envs.core.task_entry(SAIL).config
    )
    assert steps == 6 and ref["control_samples"] == 7 and len(ref) > 30


@pytest.mark.parametrize("scenario", ["detumble", "slew"])
def test_shipped_torque_through_the_environment_gives_the_run_summary(scenario: str) -> None:
    tree = octahedron(scenario)
    env = load(tree, randomize=False)
    _, steps = envs.run_episode(env, envs.shipped_policy(env))
    assert steps == 20 and env.physics.status == "completed"
    sim, result = run_of(tree)
    assert envs.summary_mismatches(sim.scenario.postprocess(result)[0], env.physics.summary(), rel=1e-9) == []


def test_shipped_activations_as_the_rods_action_give_the_runs_records() -> None:
    """The shipped activations ``u`` as the ``rods`` action drive the rods alike: the records equal
    the run's exactly. The shipped dipole as the ``dipole`` action gives back ``u = D⁺ (D u)``, the
    same activations to rounding (u lies in the row space of D): positions within 1e-12 m."""
    tree = octahedron()
    ref = run_of(tree)[1].records
    rods = load(tree, randomize=False, action="rods")
    envs.run_episode(rods, envs.shipped_policy(rods))
    got = rods.physics.result().records
    for key in ("qpos", "rod_activation", "dipole_body_Am2", "torque_alloc_body_Nm", "angmom_world_Nms"):
        np.testing.assert_array_equal(got[key], ref[key], err_msg=key)
    dipole = load(tree, randomize=False, action="dipole")
    envs.run_episode(dipole, envs.shipped_policy(dipole))
    got = dipole.physics.result().records
    np.testing.assert_allclose(got["qpos"], ref["qpos"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got["rod_activation"], ref["rod_activation"], rtol=0, atol=1e-12)


def test_shipped_reflector_loops_slew_through_the_environment_gives_the_run_summary() -> None:
    """The shipped 100 m reflector slewed by its two rim loops (no rods; quaternion PD with the
    gravity-gradient compensation, solar pressure, tidal gravity in orbit), its ``T_ref`` as the
    torque action through the shipped allocation over the loops: every summary key of the run to
    1e-9 relative, the loops saturated at every sample as in the run."""
    ref, steps = assert_shipped_policy_gives_the_run_summary(REFLECTOR, REFLECTOR_SHORT)
    assert steps == 3 and ref["control_samples"] == 4 and len(ref) > 30
    assert ref["saturation_fraction"] == 1.0 and ref["loop_current_max_A"] == pytest.approx(10.0, rel=1e-12)


@pytest.mark.parametrize("scenario", ["detumble", "slew"])
@pytest.mark.parametrize("rods", [False, True], ids=["loops", "loops_and_rods"])
def test_shipped_commands_over_loops_through_every_action_give_the_run(scenario: str, rods: bool) -> None:
    """The octahedron with its three equator loops (and its rods): the shipped ``T_ref`` as the
    torque action gives every summary key of the run to 1e-9 relative; the shipped currents (and
    activations) as the currents action give the run's motion and currents exactly (``I/I_max ·
    I_max`` is ``I`` here, measured), the recorded dipole ``D v`` to 1e-14 of its largest (``v``
    and ``I/I_max`` an ulp apart); the shipped dipole as the dipole action gives back ``v = D⁺ (D v)`` to
    rounding (v lies in D's row space): positions within 1e-12 m, currents within 1e-9 A (of
    ≤ 50 A; measured 6e-12)."""
    tree = looped(scenario, rods=rods)
    sim, result = run_of(tree)
    ref = result.records
    torque = load(tree, randomize=False)
    _, steps = envs.run_episode(torque, envs.shipped_policy(torque))
    assert steps == 20 and torque.physics.status == "completed"
    assert envs.summary_mismatches(sim.scenario.postprocess(result)[0], torque.physics.summary(), rel=1e-9) == []
    currents = load(tree, randomize=False, action="currents")
    envs.run_episode(currents, envs.shipped_policy(currents))
    got = currents.physics.result().records
    for key in ["qpos", "loop_currents_A", "angmom_world_Nms"] + (["rod_activation"] if rods else []):
        np.testing.assert_array_equal(got[key], ref[key], err_msg=key)
    for key in ("dipole_body_Am2", "torque_alloc_body_Nm"):  # D v with v = I/I_max: an ulp apart
        scale = np.max(np.abs(np.asarray(ref[key])))
        np.testing.assert_allclose(got[key], ref[key], rtol=0, atol=1e-14 * scale, err_msg=key)
    assert np.max(np.abs(np.asarray(ref["loop_currents_A"]))) > 1.0  # the loops carry the slew
    dipole = load(tree, randomize=False, action="dipole")
    envs.run_episode(dipole, envs.shipped_policy(dipole))
    got = dipole.physics.result().records
    np.testing.assert_allclose(got["qpos"], ref["qpos"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(got["loop_currents_A"], ref["loop_currents_A"], rtol=0, atol=1e-9)


# ----------------------------------------------------------------------------- physics of an action


def test_a_dipole_action_changes_the_angular_momentum_by_m_cross_b() -> None:
    """From rest, a held dipole m = 100 A m² along body x in the field B ẑ turns the octahedron with
    the torque m × B = −m B ŷ: H(t) = (m × B) t. Within 1e-6 of |T| t: the body turns about y by
    θ = |T| t² / (2 I) ≤ 3.8e-4 rad in 1 s, which turns the body-fixed dipole in the x–z plane, so
    the torque's y component falls by a factor cos θ (1 − θ²/2 ≥ 1 − 7e-8) and it gains no other
    component (m stays ⟂ y); the stiff struts stretch by ~1e-8 under the rods' couples (measured
    1.4e-8 in all)."""
    tree = octahedron()
    tree["initial"] = {"omega0_rad_s": [0.0, 0.0, 0.0]}
    env = load(tree, randomize=False, action="dipole")
    env.reset()
    m = np.array([100.0, 0.0, 0.0])
    while not env.step(m).last():
        pass
    assert env.physics.controller.command.saturated is False
    rec = env.physics.result().records
    t, H = np.asarray(rec["t"]), np.asarray(rec["angmom_world_Nms"])
    T = np.cross(m, [0.0, 0.0, FIELD_T])
    np.testing.assert_allclose(H[1:], np.outer(t[1:], T), rtol=0, atol=1e-6 * np.linalg.norm(T) * t[-1])


def test_a_held_loop_current_changes_the_angular_momentum_by_i_a_n_cross_b() -> None:
    """From rest, the equator loop of normal +z (a planar square of vector area A n̂ = 2 m² ẑ)
    held at I = 25 A (half its limit; the other loops off) in the field B x̂ turns the octahedron
    with the torque I A n̂ × B = I A B ŷ: H(t) = (I A n̂ × B) t. The body
    turns about y by θ = |T| t² / (2 I_b) ≤ 1.9e-4 rad in 1 s, which turns n̂ in the x–z plane, so
    the torque's y component falls by cos θ (≥ 1 − 2e-8) and it gains no other component; the loop
    forces strain the stiff struts by ~1e-9. Within 1e-7 of |T| t (measured 3.5e-9). The
    observation reports the held currents."""
    field = np.array([FIELD_T, 0.0, 0.0])
    tree = looped(rods=False, field_T=field)
    tree["initial"] = {"omega0_rad_s": [0.0, 0.0, 0.0]}
    env = load(tree, randomize=False, action="currents")
    obs = env.reset().observation
    np.testing.assert_array_equal(obs["loop_currents_A"], np.zeros(3))
    action = np.array([0.5, 0.0, 0.0])
    ts = env.step(action)
    np.testing.assert_array_equal(ts.observation["loop_currents_A"], [0.5 * LOOP_I_MAX_A, 0.0, 0.0])
    while not ts.last():
        ts = env.step(action)
    rec = env.physics.result().records
    t, H = np.asarray(rec["t"]), np.asarray(rec["angmom_world_Nms"])
    T = np.cross(0.5 * LOOP_I_MAX_A * 2.0 * np.array([0.0, 0.0, 1.0]), field)
    assert T[1] == pytest.approx(1.5e-3, rel=1e-12)
    np.testing.assert_allclose(H[1:], np.outer(t[1:], T), rtol=0, atol=1e-7 * np.linalg.norm(T) * t[-1])


# ----------------------------------------------------------------------------- seeds and the start


def _episode(env, n: int) -> list[dict[str, np.ndarray]]:
    rng = np.random.RandomState(1)
    spec = env.action_spec()
    out = [env.reset().observation]
    for _ in range(n):
        out.append(env.step(rng.uniform(spec.minimum, spec.maximum)).observation)
    return [{k: v.copy() for k, v in obs.items()} for obs in out]


def test_same_seed_gives_the_same_episode_and_another_seed_another_start() -> None:
    tree = octahedron()
    runs = [_episode(load(tree, random=seed), 8) for seed in (7, 7, 8)]
    for a, b in zip(runs[0], runs[1]):
        assert a.keys() == b.keys()
        for key in a:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)
    assert not np.array_equal(runs[0][0]["attitude_wxyz"], runs[2][0]["attitude_wxyz"])
    assert not np.array_equal(runs[0][0]["body_rate_rad_s"], runs[2][0]["body_rate_rad_s"])


def test_drawn_start_is_the_rigid_motion_it_reports() -> None:
    """The first observation is the drawn attitude and rate of an undeformed structure. With no
    torque the isotropic octahedron keeps its rate (free rigid rotation, I ω constant): the
    backward-difference rate after one step equals the drawn rate within 1e-5 relative (the
    log-map difference of a constant-rate turn is exact; the struts stretch by m ω² r / EA ≤ 4e-7
    under the spin, which moves the fitted rotation by about as much; measured 2.3e-7). Each
    episode's records start at its own draw."""
    env = load(octahedron(), random=4, rate_range_rad_s=0.05, attitude_range_deg=90.0)
    for _ in range(2):
        obs = env.reset().observation
        start = env.task.start
        assert np.all(np.abs(start["omega0_body_rad_s"]) <= 0.05)
        assert abs(abs(float(obs["attitude_wxyz"] @ start["q0_wxyz"])) - 1.0) < 1e-12
        np.testing.assert_array_equal(obs["body_rate_rad_s"], start["omega0_body_rad_s"])
        assert obs["shape_max_m"][0] < 1e-12 and obs["strain_max"][0] < 1e-12
        q0 = np.asarray(env.physics.cfg.initial.q0_wxyz)
        assert 2 * math.acos(min(1.0, abs(float(q0 @ start["q0_wxyz"])))) <= math.radians(90.0) + 1e-12
        w = start["omega0_body_rad_s"]
        obs1 = env.step(np.zeros(3)).observation
        assert np.linalg.norm(obs1["body_rate_rad_s"] - w) < 1e-5 * np.linalg.norm(w)
        R0 = np.asarray(env.physics.result().records["R_fit"])[0]
        assert abs(abs(float(quat_from_matrix(R0) @ start["q0_wxyz"])) - 1.0) < 1e-12


def test_slew_observes_its_target_and_rewards_the_pointing_error() -> None:
    """Slew configs add ``target_wxyz``; the reward's pointing term is (θ/π)² of the best-fit
    attitude's angle to it (5° at the config's start, at rest, nothing actuated yet)."""
    env = load(octahedron("slew"), randomize=False, reward_weights={"w_u": 0.0, "w_omega": 0.0, "w_strain": 0.0})
    obs = env.reset().observation
    np.testing.assert_array_equal(obs["target_wxyz"], [1.0, 0.0, 0.0, 0.0])
    ts = env.step(np.zeros(3))
    theta = 2 * math.acos(min(1.0, abs(float(ts.observation["attitude_wxyz"][0]))))
    assert theta == pytest.approx(math.radians(5.0), abs=1e-6)
    assert ts.reward == pytest.approx(-((theta / math.pi) ** 2), rel=1e-12)


# ----------------------------------------------------------------------------- termination


def test_a_member_past_its_limit_ends_the_episode_with_discount_zero() -> None:
    """A spin of 0.2 rad/s stretches the struts by about m ω² r / EA ~ 1e-6 (measured 8.9e-7), a
    thousand times the limit of 1e-9 given here: the first record after the start (t = 0.05 s)
    finds a member past its limit, the run stops with ``structure_failed`` and the episode ends
    there with discount 0, its last observation's strain ratio above 1."""
    tree = octahedron()
    tree["structure"]["member_groups"][0]["strain_limit"] = 1e-9
    tree["initial"] = {"omega0_rad_s": [0.0, 0.0, 0.2]}
    env = load(tree, randomize=False)
    ts, steps = env.reset(), 0
    while not ts.last():
        ts = env.step(np.zeros(3))
        steps += 1
    assert steps < 20 and ts.discount == 0.0
    assert env.physics.status == "structure_failed"
    assert re.fullmatch(
        r"member \d+ strain [0-9.e+-]+ exceeds its strain limit 1e-09 at t = [0-9.e+-]+ s", env.physics.sim.message
    ), env.physics.sim.message
    assert ts.observation["strain_ratio_max"][0] > 1.0 and math.isfinite(ts.reward)


# ----------------------------------------------------------------------------- actions and refusals


def test_action_bounds_clipping_and_refusals() -> None:
    """Torque: bounds Σ m_max · 1e-4 T, a request beyond the headroom scaled down (direction kept);
    rods: one activation per member of the set, clipped to ±1; non-finite actions refused by name."""
    env = load(octahedron(), random=0)
    env.reset()
    spec = env.action_spec()
    assert spec.name == "T_x_Nm,T_y_Nm,T_z_Nm"
    np.testing.assert_allclose(spec.maximum, 12 * 200.0 * B_BOUND_T)
    env.step(np.array([1e300, -1e300, 0.0]))
    held = env.task._last_action
    np.testing.assert_allclose(held, REQUEST_HEADROOM * spec.maximum[0] * np.array([1.0, -1.0, 0.0]), rtol=1e-12)
    assert env.physics.controller.command.saturated is True
    with pytest.raises(ValueError, match="action: every component must be finite"):
        env.step(np.array([math.nan, 0.0, 0.0]))
    rods = load(octahedron(), random=0, action="rods")
    rods.reset()
    assert rods.action_spec().shape == (12,) and rods.action_spec().name.startswith("u_member0,u_member1,")
    rods.step(np.r_[5.0, -5.0, np.zeros(10)])
    np.testing.assert_array_equal(rods.physics.controller.command.activation, np.r_[1.0, -1.0, np.zeros(10)])
    with pytest.raises(ValueError, match=r"action: expected shape \(12,\)"):
        rods.step(np.zeros(3))


@pytest.mark.parametrize("action", ["torque", "dipole", "currents"])
def test_huge_finite_actions_keep_the_loop_currents_within_their_limits(action: str) -> None:
    """Finite actions up to ±1.7e308 on every component through the loops and rods: the held
    command is finite, every ``|I_L| ≤ I_max`` and ``|u_r| ≤ 1`` (to 1e-12: the saturation divides
    by the largest ratio), and the step's observation is finite."""
    env = load(looped("slew"), random=0, action=action)
    env.reset()
    n = env.action_spec().shape[0]
    for value in (1e300, -1.7e308, 1e-300):
        ts = env.step(np.full(n, value) * np.where(np.arange(n) % 2, -1.0, 1.0))
        cmd = env.physics.controller.command
        assert np.all(np.abs(cmd.currents_A) <= LOOP_I_MAX_A * (1 + 1e-12))
        assert np.all(np.abs(cmd.activation) <= 1 + 1e-12)
        assert np.all(np.isfinite(cmd.dipole_body)) and np.all(np.isfinite(cmd.torque_ref_body))
        assert all(np.all(np.isfinite(v)) for v in ts.observation.values()) and math.isfinite(ts.reward)


def test_sail_dipole_bounds_are_zero_across_the_plane_of_its_rods() -> None:
    """The sail's rods lie along its booms, in the sail's plane z = 0: no dipole across it (bound
    0, the component dropped), the in-plane bounds Σ m_max |r̂_i| (the booms along the diagonals:
    m_total/√2 on each axis)."""
    env = built_environment(SAIL, SAIL_SHORT, action="dipole")
    spec = env.action_spec()
    total = float(env.physics.scenario.sm.rod_dipole_max_Am2.sum())
    np.testing.assert_allclose(spec.maximum, [total / math.sqrt(2), total / math.sqrt(2), 0.0], rtol=1e-9, atol=1e-6)
    env.reset()
    env.step(np.array([10.0, 0.0, 5.0]))
    assert env.task._last_action[2] == 0.0
    np.testing.assert_allclose(env.physics.controller.command.dipole_body, [10.0, 0.0, 0.0], atol=1e-9)


def test_configs_without_rods_and_bad_options_are_refused_by_name() -> None:
    free = octahedron()
    free["scenario"] = "free"
    del free["control"]
    with pytest.raises(ValueError, match="config: the given config .*'free'.* has no environment"):
        load(free)
    with pytest.raises(ValueError, match="action: must be one of 'torque', 'dipole', 'rods', 'currents', got 'volts'"):
        load(octahedron(), action="volts")
    with pytest.raises(ValueError, match="rate_range_rad_s: must be a finite number >= 0"):
        load(octahedron(), rate_range_rad_s=-1.0)
    held = copy.deepcopy(octahedron())
    held["structure"]["fixed"] = [{"nodes": [0], "dofs": "123"}]
    held["initial"] = {}
    with pytest.raises(ValueError, match=r"randomize: the structure holds components in place \(structure.fixed\)"):
        load(held)
    assert isinstance(load(held, randomize=False).task, StructureRodsTask)
    with pytest.raises(ValueError, match=r"action: 'currents' sets current loops and the config has none"):
        load(octahedron(), action="currents")


def test_loop_action_bounds_clipping_and_refusals() -> None:
    """With loops: the torque bound adds Σ I_max |a_L| · 1e-4 T, the dipole bound I_max |a_L,i|
    per axis to the rods'; the currents action is one value per loop then one per rod, clipped to
    ±1 (currents ±I_max); a wrong length is refused, and so is ``rods`` without rods (naming
    ``actuators.member_set``) or beside loops that it would leave off."""
    rods_only = load(octahedron(), action="dipole").action_spec()
    both = load(looped(), action="dipole").action_spec()
    np.testing.assert_allclose(both.maximum, rods_only.maximum + 2.0 * LOOP_I_MAX_A, rtol=1e-12)
    torque = load(looped()).action_spec()
    np.testing.assert_allclose(torque.maximum, (12 * 200.0 + 3 * 2.0 * LOOP_I_MAX_A) * B_BOUND_T, rtol=1e-12)
    env = load(looped(), random=0, action="currents")
    spec = env.action_spec()
    assert spec.shape == (15,) and spec.name.startswith("u_loop_eq_z,u_loop_eq_x,u_loop_eq_y,u_member0,")
    env.reset()
    env.step(np.r_[3.0, -0.25, -7.0, 2.0, -2.0, np.zeros(10)])
    cmd = env.physics.controller.command
    np.testing.assert_array_equal(cmd.currents_A, [LOOP_I_MAX_A, -0.25 * LOOP_I_MAX_A, -LOOP_I_MAX_A])
    np.testing.assert_array_equal(cmd.activation, np.r_[1.0, -1.0, np.zeros(10)])
    with pytest.raises(ValueError, match=r"action: expected shape \(15,\)"):
        env.step(np.zeros(3))
    loops_only = load(looped(rods=False), random=0, action="currents")
    assert loops_only.action_spec().shape == (3,)
    loops_only.reset()
    with pytest.raises(ValueError, match=r"action: expected shape \(3,\)"):
        loops_only.step(np.zeros(15))
    with pytest.raises(ValueError, match=r"action: 'rods' drives magnetorquer rods and the config has none"):
        load(looped(rods=False), action="rods")
    with pytest.raises(ValueError, match=r"action: 'rods' would leave the config's current loops \(\[loops\]\) off"):
        load(looped(), action="rods")
