"""Current loops along member sets in the ``structure`` concept: Lorentz forces, dipoles, allocation.

Checks against invariants and closed forms, each with its tolerance and why:

* any closed loop (random shapes, orders and senses of its members, random current and field;
  hypothesis): the members' forces ``I (x_b − x_a) × B``, half at each end, sum to zero and their
  moment about any point is ``m × B`` with ``m = I ½ Σ x_a × x_b`` (rounding: 1e-12 of the largest
  term);
* a planar circular loop (a 64-gon of struts) in a rotated structure: the torque through the
  model's bodies is ``I A n̂ × B`` with the polygon's area ``A = ½ N R² sin(2π/N)`` (1e-12), which
  is ``π R²`` less 0.16 %;
* the allocation over loops (and rods): the allocated dipole makes the reference torque across the
  field, the currents are the least-norm ones and within their limits, saturated ones scaled
  together;
* a slew of a stiff isotropic octahedron through three loops follows the linear closed loop;
* validation names the set and the reason of a set that is not one closed loop.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import magsail_mj
from magsail_mj.concepts.structure.circuits import LoopEdges, LoopError, oriented_loop
from magsail_mj.concepts.structure.loads import LoopLorentzLoad
from magsail_mj.concepts.structure.model import NodeFrames, make_structure_model, rigid_initial_state
from magsail_mj.concepts.structure.tasks import StructureTask
from magsail_mj.config import ConfigError, parse_config
from magsail_mj.records import open_records
from magsail_mj.run import run_scenario

Q0 = (0.9, 0.3, 0.3, math.sqrt(1 - 0.99))


@pytest.fixture
def no_plots(monkeypatch):
    """Runs whose figures are not under test write none (Matplotlib costs about a second a figure)."""
    monkeypatch.setattr(StructureTask, "plots", lambda self, run_dir, result, series: [])


def _particles(n: int) -> NodeFrames:
    """Frames of ``n`` particle nodes: node ``i`` is body ``i`` at its origin."""
    return NodeFrames(np.arange(n), np.zeros((n, 3)), np.zeros((n, 3)))


# ----------------------------------------------------------------------------- any closed loop


@settings(max_examples=60, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    k=st.integers(3, 12),
    current=st.floats(-1e3, 1e3, allow_nan=False).filter(lambda v: abs(v) > 1e-3),
)
def test_closed_loop_has_no_net_force_and_the_dipole_torque(seed, k, current):
    """A random (non-planar) k-gon whose members are listed in a random order and direction: zero
    net force, and the moment about a random point is ``I a × B``, ``a = ½ Σ x_a × x_b`` along the
    sense of the first listed member; both to 1e-12 of ``|I| |B| Σ |x|²`` (the rounding of the sums)."""
    rng = np.random.default_rng(seed)
    x = rng.normal(scale=10.0, size=(k, 3)) + rng.normal(scale=30.0, size=3)
    cycle = rng.permutation(k)  # the loop visits the nodes in this order
    members = np.stack([cycle, np.roll(cycle, -1)], axis=1)
    flip = rng.random(k) < 0.5
    members[flip] = members[flip][:, ::-1]
    order = rng.permutation(k)
    member_nodes = members[order]  # the member table; the set lists them in table order
    loops = LoopEdges.from_sets(member_nodes, {"loop": np.arange(k)}, [1.0])
    # the sense: along the first listed member, a → b
    a0, b0 = member_nodes[0]
    i0 = int(np.flatnonzero(cycle == a0)[0])
    sense = 1.0 if cycle[(i0 + 1) % k] == b0 else -1.0
    ordered = x[cycle]
    area = sense * 0.5 * np.cross(ordered, np.roll(ordered, -1, axis=0)).sum(axis=0)
    np.testing.assert_allclose(loops.vector_areas(x)[0], area, rtol=1e-12, atol=1e-12 * np.sum(x * x))
    load = LoopLorentzLoad(_particles(k), loops)
    B = rng.normal(scale=3e-5, size=3)
    F = load.node_forces(x[load.used], np.array([current]), B)
    scale = abs(current) * np.linalg.norm(B) * float(np.sum(x * x))
    assert np.linalg.norm(F.sum(axis=0)) <= 1e-12 * scale
    point = rng.normal(scale=20.0, size=3)
    moment = np.cross(x[load.used] - point, F).sum(axis=0)
    np.testing.assert_allclose(moment, np.cross(current * area, B), rtol=0, atol=1e-12 * scale)


def test_loop_walk_refuses_what_is_not_one_closed_loop():
    ends = np.array([[0, 1], [2, 1], [2, 3], [0, 3], [3, 4], [4, 5], [5, 3]])
    src, dst, member = oriented_loop(ends, [1, 0, 3, 2])  # member 1 first: 2 → 1 sets the sense
    assert src.tolist() == [2, 1, 0, 3] and dst.tolist() == [1, 0, 3, 2] and member.tolist() == [1, 0, 3, 2]
    with pytest.raises(LoopError, match=r"node 3 \(4 members\)"):
        oriented_loop(ends, range(7))
    with pytest.raises(LoopError, match=r"node 0 \(1 member\), node 3 \(1 member\)"):
        oriented_loop(ends, [0, 1, 2])
    with pytest.raises(LoopError, match="member 0 is listed twice"):
        oriented_loop(ends, [0, 0, 1, 2, 3])
    two = np.array([[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 3]])
    with pytest.raises(LoopError, match=r"more than one closed loop \(the one through member 0 has 3 of the 6"):
        oriented_loop(two, range(6))


# ----------------------------------------------------------------------------- through the model


def _ring(*, n: int = 64, radius_m: float = 5.0, I_max_A=100.0, wire: float = 0.0) -> dict:
    """A ring of ``n`` struts (radius ``radius_m``, z = 0) braced to a hub node at its centre and one
    above it, the ring a member set ``rim``; a slew config in a constant field."""
    phi = 2 * np.pi * np.arange(n) / n
    nodes = np.stack([radius_m * np.cos(phi), radius_m * np.sin(phi), np.zeros(n)], axis=1).tolist()
    nodes += [[0.0, 0.0, 0.0], [0.0, 0.0, 2.0]]
    rim = [[i, (i + 1) % n] for i in range(n)]
    spokes = [[i, n + h] for i in range(n) for h in (0, 1)]
    return {
        "concept": "structure",
        "scenario": "slew",
        "sim": {"duration_s": 1.0, "timestep_s": 5e-4, "record_every": 200, "progress": False},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 0.1},
            "member_groups": [
                {"kind": "strut", "name": "rim", "nodes": rim, "EA_N": 1e5},
                {"kind": "strut", "name": "spokes", "nodes": spokes + [[n, n + 1]], "EA_N": 1e5},
            ],
        },
        "field": {"model": "constant", "constant_T": [2e-5, -1e-5, 3e-5]},
        "loops": {"member_sets": ["rim"], "I_max_A": I_max_A, "wire_linear_density_kg_m": wire},
        "control": {"kind": "quat_pd", "q_ref_wxyz": [1.0, 0.0, 0.0, 0.0]},
    }


def test_planar_circular_loop_torque_through_the_model():
    """A 64-gon of radius 5 m turned by q0, 40 A: Σ over the bodies of the applied forces is zero
    and their moment ``I A n̂ × B`` (1e-12), ``A = ½ N R² sin(2π/N)`` = π R² (1 − 1.6e-3)."""
    n, R, current = 64, 5.0, 40.0
    sm = make_structure_model(parse_config(_ring(n=n, radius_m=R)))
    data = mujoco.MjData(sm.model)
    rigid_initial_state(sm, data, q0_wxyz=Q0, omega0_body_rad_s=(0.0, 0.0, 0.0))
    mujoco.mj_forward(sm.model, data)
    B = np.array([2e-5, -1e-5, 3e-5])
    load = LoopLorentzLoad(sm.nodes, sm.loops, B_fixed_T=B)
    state = SimpleNamespace(pos=data.xpos, xquat=data.xquat, ctrl=SimpleNamespace(currents_A=np.array([current])))
    xfrc = np.zeros((sm.model.nbody, 6))
    load.add(state, xfrc)
    w, x, y, z = Q0
    n_hat = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)])  # R ẑ
    A = 0.5 * n * R**2 * math.sin(2 * math.pi / n)
    assert A == pytest.approx(math.pi * R**2, rel=1.7e-3) and A != pytest.approx(math.pi * R**2, rel=1.5e-3)
    expected = current * A * np.cross(n_hat, B)
    force = xfrc[:, :3].sum(axis=0)
    moment = xfrc[:, 3:].sum(axis=0) + np.cross(data.xipos, xfrc[:, :3]).sum(axis=0)
    scale = current * np.linalg.norm(B) * R * R
    assert np.linalg.norm(force) < 1e-12 * scale / R
    np.testing.assert_allclose(moment, expected, rtol=1e-12, atol=1e-13 * scale)
    np.testing.assert_allclose(load.torque_world(state), expected, rtol=1e-12, atol=1e-13 * scale)


def test_wire_mass_is_added_to_the_loop_members():
    """``wire_linear_density_kg_m`` adds ρ × the loop's length to the structure's mass (1e-12)."""
    n, R = 64, 5.0
    bare = make_structure_model(parse_config(_ring(n=n, radius_m=R)))
    wired = make_structure_model(parse_config(_ring(n=n, radius_m=R, wire=0.2)))
    perimeter = 2 * n * R * math.sin(math.pi / n)
    assert wired.total_mass_kg - bare.total_mass_kg == pytest.approx(0.2 * perimeter, rel=1e-12)


# ----------------------------------------------------------------------------- allocation


def _octahedron(*, I_max_A=1.0e4, rods: bool = False) -> dict:
    """The stiff isotropic octahedron (nodes ±e_i, 1 kg each: I = 4 kg m²), its three equators
    loops (vector areas 2 m² along ±x, ±y, ±z); a 5° slew about z in a field along x."""
    nodes = [[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0], [0, 0, 1.0], [0, 0, -1.0]]
    edges = [[a, b] for a in range(6) for b in range(a + 1, 6) if b != a + 1 or a % 2]
    index = {tuple(e): i for i, e in enumerate(edges)}

    def loop(seq: list[int]) -> list[int]:
        return [index[(min(a, b), max(a, b))] for a, b in zip(seq, seq[1:] + seq[:1])]

    half = math.radians(5.0) / 2
    tree = {
        "concept": "structure",
        "scenario": "slew",
        "sim": {"duration_s": 6.0, "timestep_s": 5e-3, "record_every": 20, "progress": False},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 1.0},
            "member_groups": [{"kind": "strut", "name": "edges", "nodes": edges, "EA_N": 2e4, "damping_Ns_m": 20.0}],
            "member_sets": {"eq_z": loop([0, 2, 1, 3]), "eq_x": loop([2, 4, 3, 5]), "eq_y": loop([4, 0, 5, 1])},
        },
        "field": {"model": "constant", "constant_T": [3e-5, 0.0, 0.0]},
        "loops": {"member_sets": ["eq_z", "eq_x", "eq_y"], "I_max_A": I_max_A},
        "control": {"kind": "quat_pd", "Pq_Nm": [2.0] * 3, "Pw_Nms": [2.8] * 3, "q_ref_wxyz": [1.0, 0, 0, 0]},
        "initial": {"q0_wxyz": [math.cos(half), 0.0, 0.0, math.sin(half)]},
    }
    if rods:
        tree["actuators"] = {"member_set": "edges", "dipole_max_Am2": 50.0}
    return tree


@pytest.mark.parametrize("rods", [False, True], ids=["loops", "loops_and_rods"])
def test_allocation_over_loops_makes_the_torque_across_the_field(rods):
    """In a rotated, sampled state: unsaturated, the allocated dipole ``R Σ I_L a_L (+ rods)`` makes
    ``T``'s part across ``B`` (1e-12) and the activations are the least-norm ones (``lstsq``'s
    minimum-norm solution, 1e-9); at 1e5 times the gains, ``max |I_L / I_max,L| = 1`` and the
    dipole keeps its direction (1e-9)."""
    tree = _octahedron(I_max_A=[50.0, 80.0, 20.0], rods=rods)
    tree["control"].update(Pq_Nm=[1e-4] * 3, Pw_Nms=[1e-3] * 3)
    sim = magsail_mj.load(parse_config(tree))
    ctrl, sm = sim.controller, sim.scenario.sm
    data = mujoco.MjData(sm.model)
    rigid_initial_state(sm, data, q0_wxyz=Q0, omega0_body_rad_s=(0.01, -0.02, 0.005))
    mujoco.mj_kinematics(sm.model, data)
    B = np.array([1e-5, -2e-5, 3e-5])
    state = SimpleNamespace(t=0.0, pos=data.xpos, xquat=data.xquat, env=SimpleNamespace(B_eci=B))
    cmd = ctrl.update(state)
    R = cmd.R
    loops = sim.scenario.loop_load
    a_world = loops.vector_areas(loops.node_positions(state))
    m_world = cmd.currents_A @ a_world
    if rods:
        m_world += R @ (ctrl.allocation.D @ cmd.activation)
    np.testing.assert_allclose(R @ cmd.dipole_body, m_world, rtol=1e-12, atol=1e-12 * np.linalg.norm(m_world))
    T, B_b = cmd.torque_ref_body, cmd.B_body
    T_perp = T - (T @ B_b) / (B_b @ B_b) * B_b
    assert not cmd.saturated
    np.testing.assert_allclose(np.cross(cmd.dipole_body, B_b), T_perp, rtol=1e-12, atol=1e-12 * np.linalg.norm(T))
    I_max = np.array([50.0, 80.0, 20.0])
    D = np.hstack([ctrl.allocation.D, ((a_world @ R) * I_max[:, None]).T])
    u = np.concatenate([cmd.activation, cmd.currents_A / I_max])
    m_star = np.cross(B_b, T) / (B_b @ B_b)
    np.testing.assert_allclose(u, np.linalg.lstsq(D, m_star, rcond=None)[0], rtol=1e-9, atol=1e-12)
    ctrl.Pq, ctrl.Pw = 1e5 * ctrl.Pq, 1e5 * ctrl.Pw
    cmd = ctrl.update(SimpleNamespace(t=0.01, pos=data.xpos, xquat=data.xquat, env=SimpleNamespace(B_eci=B)))
    u = np.concatenate([cmd.activation, cmd.currents_A / I_max])
    assert cmd.saturated and np.max(np.abs(u)) == pytest.approx(1.0, abs=1e-12)
    m_star = np.cross(cmd.B_body, cmd.torque_ref_body)
    np.testing.assert_allclose(
        np.cross(cmd.dipole_body, m_star), 0.0, atol=1e-9 * np.linalg.norm(cmd.dipole_body) * np.linalg.norm(m_star)
    )


def _two_rims(n: int = 16, radius_m: float = 5.0) -> dict:
    """Two parallel rings of ``n`` struts (z = 0 and z = 0.5 m) joined by verticals and diagonals,
    each ring a loop (both along +z), the PD law's small gains; a slew config in a constant field."""
    phi = 2 * np.pi * np.arange(n) / n
    ring = np.stack([radius_m * np.cos(phi), radius_m * np.sin(phi), np.zeros(n)], axis=1)
    nodes = np.vstack([ring, ring + [0.0, 0.0, 0.5], [[0.0, 0.0, 0.25]]]).tolist()
    rims = [[i, (i + 1) % n] for i in range(n)] + [[n + i, n + (i + 1) % n] for i in range(n)]
    webs = [[i, n + i] for i in range(n)] + [[i, n + (i + 1) % n] for i in range(n)]
    webs += [[i, 2 * n] for i in range(2 * n)]
    return {
        "concept": "structure",
        "scenario": "slew",
        "sim": {"duration_s": 1.0, "timestep_s": 1e-3, "record_every": 100, "progress": False},
        "structure": {
            "nodes": {"position_m": nodes, "mass_kg": 0.1},
            "member_groups": [{"kind": "strut", "nodes": rims + webs, "EA_N": 1e5}],
            "member_sets": {"rim_a": list(range(n)), "rim_b": list(range(n, 2 * n))},
        },
        "field": {"model": "constant", "constant_T": [0.0, 3e-5, 1e-5]},
        "loops": {"member_sets": ["rim_a", "rim_b"], "I_max_A": 100.0},
        "control": {"kind": "quat_pd", "Pq_Nm": [1e-4] * 3, "Pw_Nms": [1e-3] * 3, "q_ref_wxyz": [1.0, 0, 0, 0]},
        "initial": {"q0_wxyz": [math.cos(0.1), math.sin(0.1), 0.0, 0.0]},
    }


def test_parallel_loops_of_a_deformed_plane_share_the_normal_dipole():
    """Two parallel loops deformed by 1e-3 m: their vector areas differ across the normal by ~1e-4
    of their size, a direction they can hardly make. The allocation leaves it out
    (:data:`~magsail_mj.concepts.structure.control.LOOP_PINV_RCOND`): the currents are equal to 1e-3
    and unsaturated, and the torque is the normal dipole's, ``(n̂·m*) n̂ × B`` (1e-3), where the exact
    least-norm currents would be opposite, saturated and make almost no torque."""
    sim = magsail_mj.load(parse_config(_two_rims()))
    ctrl, sm = sim.controller, sim.scenario.sm
    data = mujoco.MjData(sm.model)
    rigid_initial_state(sm, data, q0_wxyz=(math.cos(0.1), math.sin(0.1), 0.0, 0.0), omega0_body_rad_s=(0, 0, 0))
    data.qpos[:] += np.random.default_rng(5).normal(scale=1e-3, size=sm.model.nq)
    mujoco.mj_kinematics(sm.model, data)
    B = np.array([0.0, 3e-5, 1e-5])
    cmd = ctrl.update(SimpleNamespace(t=0.0, pos=data.xpos, xquat=data.xquat, env=SimpleNamespace(B_eci=B)))
    I1, I2 = cmd.currents_A
    assert not cmd.saturated and I1 * I2 > 0 and abs(I1 - I2) < 1e-3 * abs(I1)
    loops = sim.scenario.loop_load
    a = loops.vector_areas(loops.node_positions(SimpleNamespace(pos=data.xpos, xquat=data.xquat))) @ cmd.R
    across = np.linalg.norm(np.cross(a[0], a[1])) / np.linalg.norm(a[0]) ** 2
    assert 1e-6 < across < 1e-3  # the deformation opened a weak direction
    n_hat = a.sum(axis=0) / np.linalg.norm(a.sum(axis=0))
    m_star = np.cross(cmd.B_body, cmd.torque_ref_body) / (cmd.B_body @ cmd.B_body)
    expected = (n_hat @ m_star) * np.cross(n_hat, cmd.B_body)
    np.testing.assert_allclose(cmd.torque_alloc_body, expected, rtol=1e-3, atol=1e-3 * np.linalg.norm(expected))
    D = (a * 100.0).T
    exact = np.linalg.lstsq(D, m_star, rcond=None)[0] * 100.0  # the untruncated least-norm currents
    assert exact[0] * exact[1] < 0 and np.max(np.abs(exact)) > 10 * abs(I1)


def test_slew_through_three_loops_follows_the_linear_closed_loop(tmp_path, no_plots):
    """The rods' slew test with loops only: below saturation the error angle obeys
    ``I θ̈ + P_ω θ̇ + (P_q / 2) θ ≈ 0`` (ω_n = 0.5 rad/s, ζ = 0.7) within 0.5 % of the initial 5°
    (sin(θ/2) ≈ θ/2 to 3e-4, the one-step lag of the rate estimate)."""
    out = run_scenario(parse_config(_octahedron()), tmp_path / "s")
    assert out.status == "completed" and out["saturation_fraction"] == 0.0
    assert out["loop_current_max_A"] < 1.0e4 and out["torque_loop_max_Nm"] > 0
    t = np.asarray(open_records(tmp_path / "s")["t"])
    err = np.asarray(open_records(tmp_path / "s", group="series")["error_angle_rad"])
    half = math.radians(5.0) / 2
    wn, zeta = 0.5, 0.7
    wd = wn * math.sqrt(1 - zeta**2)
    theta = 2 * half * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta / math.sqrt(1 - zeta**2) * np.sin(wd * t))
    np.testing.assert_allclose(err, np.abs(theta), atol=0.005 * 2 * half)


# ----------------------------------------------------------------------------- validation


@pytest.mark.parametrize(
    "change, message",
    [
        (
            lambda t: t["structure"]["member_sets"].update(eq_z=[0, 4, 1]),
            r"loops\.member_sets\[0\]: member set 'eq_z': every node of a loop must end exactly 2 of its members",
        ),
        (
            lambda t: t["structure"]["member_sets"].update(eq_z=list(range(12))),
            r"loops\.member_sets\[0\]: member set 'eq_z': every node of a loop must end exactly 2 of its members: "
            r"node 0 \(4 members\)",
        ),
        (
            lambda t: t["loops"].update(member_sets=["eq_z", "ring"]),
            r"loops\.member_sets\[1\]: the structure has no member set 'ring'",
        ),
        (lambda t: t["loops"].update(member_sets=["eq_z", "eq_z"]), r"loops\.member_sets: each set makes one loop"),
        (lambda t: t["loops"].update(I_max_A=[1.0, 2.0]), r"loops\.I_max_A: one limit for every loop or one per"),
        (lambda t: t["loops"].update(I_max_A=-1.0), r"loops\.I_max_A: must be a current > 0 A"),
        (lambda t: t.pop("loops"), r"actuators: scenario 'slew' needs an actuator: the \[actuators\] table"),
        (lambda t: t.update(field={"model": "none"}), r"field\.model: scenario 'slew' drives magnetic actuators"),
    ],
    ids=["open", "degree_4", "missing", "twice", "limits_count", "negative", "no_actuator", "no_field"],
)
def test_loops_that_are_not_closed_loops_are_refused_naming_the_set(change, message):
    tree = _octahedron()
    change(tree)
    with pytest.raises(ConfigError, match=message):
        parse_config(tree)


def test_a_loop_enclosing_no_area_is_refused():
    """Three collinear nodes joined both ways round: a closed loop of zero vector area."""
    tree = _octahedron()
    tree["structure"]["nodes"]["position_m"].append([2.0, 0.0, 0.0])  # node 6 on the line of 0 and 1
    tree["structure"]["member_groups"].append({"kind": "strut", "nodes": [[0, 6], [6, 1], [1, 0], [2, 6]], "EA_N": 2e4})
    tree["structure"]["member_sets"]["flat"] = [12, 13, 14]
    tree["loops"]["member_sets"] = ["flat"]
    with pytest.raises(ConfigError, match=r"loops\.member_sets\[0\]: loop 'flat' encloses no vector area"):
        parse_config(tree)


def test_checkpoint_resume_with_loops_equals_the_uninterrupted_run(tmp_path, no_plots):
    """The held command's loop currents and the loads' state come back from a checkpoint: the
    resumed run's records equal the uninterrupted run's, bit for bit."""
    tree = _octahedron(I_max_A=500.0)
    tree["sim"].update(duration_s=1.0, checkpoint_every_s=0.25)
    cfg = parse_config(tree)
    run_scenario(cfg, tmp_path / "full")
    run_scenario(cfg, tmp_path / "cut", stop_after_s=0.5)
    run_scenario(cfg, tmp_path / "cut", resume=True)
    a, b = open_records(tmp_path / "full"), open_records(tmp_path / "cut")
    assert sorted(a) == sorted(b) and "loop_currents_A" in a
    for key in a:
        assert np.array_equal(np.asarray(a[key]), np.asarray(b[key]), equal_nan=True), key
