"""Solar radiation pressure and drag on a structure's panels (the ``structure`` concept).

Checks against closed forms and invariants, each with its tolerance and why:

* a flat square panel (a quad, split along its 0–2 diagonal) at a known incidence, lit on either
  face: the textbook flat-plate force of each optical case, ``−P A cos α [ρ_a ŝ + 2 ρ_s cos α n̂_l
  + ρ_d (ŝ + ⅔ n̂_l)]``, and ``−½ C_D ρ A |n̂·V| V`` for drag, and the split to the nodes in
  thirds of each triangle (1e-12 relative: rounding);
* a closed tetrahedron in uniform light and flow (no self-shadowing is modelled, so every face is
  lit on one of its sides): a pure absorber's net force is ``−2 P A⊥ ŝ`` and the drag
  ``−C_D ρ |V| A⊥ V``, with ``A⊥`` the area of the shadow the tetrahedron casts (both along the
  light or flow: free-molecular drag on a closed body is not zero); forces grow as the area;
* an edge-on panel feels nothing, nor does a panel in the Earth's shadow;
* in a run, the panel forces move the centre of mass of a free panel at ``F / M``, and the shipped
  sail runs with both loads on, its recorded force at the start equal to the closed form.
"""

from __future__ import annotations

import json
import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from magsail_mj.concepts.structure.loads import PanelSurfaceLoad
from magsail_mj.concepts.structure.model import make_structure_model, rigid_initial_state
from magsail_mj.concepts.structure.tasks import StructureTask
from magsail_mj.config import ConfigError, load_config, parse_config
from magsail_mj.environment.environment import Environment
from magsail_mj.export import read_timeseries
from magsail_mj.run import run_scenario
from tests.conftest import REPO

CONFIGS = REPO / "magsail_mj" / "concepts" / "structure" / "configs"


@pytest.fixture
def no_plots(monkeypatch):
    """Runs whose figures are not under test write none (Matplotlib costs about a second a figure)."""
    monkeypatch.setattr(StructureTask, "plots", lambda self, run_dir, result, series: [])


Q0 = (0.9, 0.3, 0.3, math.sqrt(1 - 0.99))  # a rotation about a skew axis


def _square(*, side_m: float = 2.0, reflectivity=(0.0, 0.0, 1.0), drag_coefficient: float = 2.0) -> dict:
    """A square of side ``side_m`` in the z = 0 plane (normal +z), its edges and diagonals struts, one
    quad panel; free space, the Sun fixed, no shadow."""
    s = side_m
    return {
        "concept": "structure",
        "scenario": "free",
        "sim": {"duration_s": 1.0, "timestep_s": 2e-3, "record_every": 50, "progress": False},
        "structure": {
            "nodes": {"position_m": [[0, 0, 0], [s, 0, 0], [s, s, 0], [0, s, 0]], "mass_kg": 1.0},
            "member_groups": [
                {"kind": "strut", "nodes": [[0, 1], [1, 2], [2, 3], [3, 0], [0, 2], [1, 3]], "EA_N": 1e4}
            ],
            "panels": [
                {"nodes": [[0, 1, 2, 3]], "reflectivity": list(reflectivity), "drag_coefficient": drag_coefficient}
            ],
        },
        "sun": {"model": "fixed", "direction_eci": [0.0, 0.6, 0.8], "shadow": "none"},
        "srp": {"enabled": True, "pressure_N_m2": 1.0, "distance_scaling": False},
    }


def _tetrahedron(points: np.ndarray, *, reflectivity=(0.0, 0.0, 1.0)) -> dict:
    """The four faces of the tetrahedron ``points`` (4, 3) as triangle panels, outward normals."""
    p = np.asarray(points, dtype=float)
    faces = []
    for face in ([0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]):
        other = p[[k for k in range(4) if k not in face][0]]
        a, b, c = p[face]
        if np.cross(b - a, c - a) @ (other - a) > 0:  # the normal points at the fourth vertex: reverse
            face = face[::-1]
        faces.append([*face, -1])
    tree = _square()
    tree["structure"] = {
        "nodes": {"position_m": p.tolist(), "mass_kg": 1.0},
        "member_groups": [{"kind": "strut", "nodes": [[a, b] for a in range(4) for b in range(a + 1, 4)], "EA_N": 1e4}],
        "panels": [{"nodes": faces, "reflectivity": list(reflectivity)}],
    }
    return tree


def _load_and_state(tree: dict, *, q0=Q0, sun=(0.0, 0.6, 0.8), P: float = 1.0, rho: float = 0.0, V=(0.0, 0.0, 0.0)):
    """The panel load of the config ``tree`` (both laws on) and a state of its structure rotated by
    ``q0``, with an environment sample of the given Sun, pressure, density and flow."""
    sm = make_structure_model(parse_config(tree))
    data = mujoco.MjData(sm.model)
    rigid_initial_state(sm, data, q0_wxyz=q0, omega0_body_rad_s=(0.0, 0.0, 0.0))
    mujoco.mj_kinematics(sm.model, data)
    s = np.asarray(sun, dtype=float)
    env = SimpleNamespace(
        sun_eci=s / np.linalg.norm(s), srp_pressure_N_m2=P, density_kg_m3=rho, v_rel_eci=np.asarray(V, dtype=float)
    )
    state = SimpleNamespace(pos=data.xpos.copy(), xquat=data.xquat.copy(), env=env)
    load = PanelSurfaceLoad(sm.nodes, sm.structure.panels, srp=True, drag=True)
    return sm, load, state


def _flat_plate_srp(A: float, n: np.ndarray, s: np.ndarray, P: float, rho_s: float, rho_d: float) -> np.ndarray:
    """The textbook flat plate: absorbed ``ρ_a ŝ``, specular ``2 ρ_s cos α n̂_l``, Lambertian
    diffuse ``ρ_d (ŝ + ⅔ n̂_l)``, all times ``−P A cos α``."""
    c = float(n @ s)
    n_l = n if c >= 0 else -n
    cos_a = abs(c)
    rho_a = 1.0 - rho_s - rho_d
    return -P * A * cos_a * (rho_a * s + 2.0 * rho_s * cos_a * n_l + rho_d * (s + 2.0 / 3.0 * n_l))


def _rotation(q) -> np.ndarray:
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


# ----------------------------------------------------------------------------- one panel


@pytest.mark.parametrize(
    "reflectivity",
    [(0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.6, 0.25, 0.15)],
    ids=["absorber", "mirror", "lambertian", "mixed"],
)
@pytest.mark.parametrize("face", [1.0, -1.0], ids=["front_lit", "back_lit"])
def test_square_panel_srp_is_the_flat_plate_force_split_by_triangles(reflectivity, face):
    """At 35° incidence on the rotated panel: the net force is the textbook force (1e-12); node 0
    and 2 (on both triangles) take a third of each half, nodes 1 and 3 a third of one."""
    R = _rotation(Q0)
    n = R[:, 2]
    tangent = R[:, 0]
    alpha = math.radians(35.0)
    s = face * math.cos(alpha) * n + math.sin(alpha) * tangent
    sm, load, state = _load_and_state(_square(reflectivity=reflectivity), sun=s, P=2.0)
    x, F = load.node_forces(state)
    expected = _flat_plate_srp(4.0, n, s, 2.0, reflectivity[0], reflectivity[1])
    np.testing.assert_allclose(F.sum(axis=0), expected, rtol=1e-12, atol=1e-15)
    share = np.array([1 / 3, 1 / 6, 1 / 3, 1 / 6])  # (0,1,2) and (0,2,3): half the area each
    np.testing.assert_allclose(F, share[:, None] * expected, rtol=1e-12, atol=1e-15)
    centre = x.mean(axis=0)
    np.testing.assert_allclose(np.cross(x - centre, F).sum(axis=0), 0.0, atol=1e-13)  # flat, uniform
    xfrc = np.zeros((sm.model.nbody, 6))
    load.add(state, xfrc)
    np.testing.assert_allclose(xfrc[:, :3].sum(axis=0), expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("theta_deg", [0.0, 30.0, 70.0, 150.0])
def test_square_panel_drag_is_the_free_molecular_flat_plate(theta_deg):
    """Flow at θ to the normal: ``F = −½ C_D ρ A |cos θ| |V| V`` (1e-12), the panel's own C_D."""
    R = _rotation(Q0)
    n, tangent = R[:, 2], R[:, 1]
    th = math.radians(theta_deg)
    V = 7500.0 * (math.cos(th) * n + math.sin(th) * tangent)
    tree = _square(drag_coefficient=2.4)
    sm, load, state = _load_and_state(tree, P=0.0, rho=3e-12, V=V)
    _, F = load.node_forces(state)
    expected = -0.5 * 2.4 * 3e-12 * 4.0 * abs(math.cos(th)) * 7500.0 * V
    np.testing.assert_allclose(F.sum(axis=0), expected, rtol=1e-12, atol=1e-18)


def test_edge_on_and_shadowed_panels_feel_nothing():
    """Light and flow in the panel's plane: zero (to the rounding of ``ŝ·n̂`` ~ 1e-16, times P A);
    the Earth's shadow (P = 0) and no atmosphere (ρ = 0): zero, and nothing is added."""
    R = _rotation(Q0)
    s = R[:, 0]
    sm, load, state = _load_and_state(_square(reflectivity=(0.5, 0.3, 0.2)), sun=s, P=1.0, rho=1e-11, V=7e3 * R[:, 1])
    _, F = load.node_forces(state)
    assert np.max(np.abs(F)) < 1e-14 * 4.0 * 1.0 + 1e-14 * 0.5 * 2.0 * 1e-11 * 4.0 * 7e3**2
    state.env.srp_pressure_N_m2 = 0.0
    state.env.density_kg_m3 = 0.0
    state.env.sun_eci = R[:, 2]
    xfrc = np.zeros((sm.model.nbody, 6))
    load.add(state, xfrc)
    assert not np.any(xfrc)
    assert not np.any(load.node_forces(state)[1])


# ----------------------------------------------------------------------------- closed surface


def _shadow_area(points: np.ndarray, direction: np.ndarray) -> float:
    """The area of the convex body's shadow on a plane across ``direction``."""
    d = direction / np.linalg.norm(direction)
    e1 = np.cross(d, [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    return float(ConvexHull(np.stack([points @ e1, points @ e2], axis=1)).volume)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_closed_tetrahedron_in_uniform_light_and_flow(seed):
    """A pure absorber: ``F = −2 P A⊥ ŝ`` (each face lit on one side, its projections covering the
    shadow twice); drag ``F = −C_D ρ |V| A⊥ V``, along −V and not zero; both 1e-12 relative (rounding
    of four faces); scaled by k, the forces by k² (1e-12)."""
    rng = np.random.default_rng(seed)
    points = rng.normal(size=(4, 3))
    s = rng.normal(size=3)
    s /= np.linalg.norm(s)
    V = 7.0e3 * rng.normal(size=3)
    tree = _tetrahedron(points)
    sm, load, state = _load_and_state(tree, q0=(1.0, 0.0, 0.0, 0.0), sun=s, P=1.5, rho=0.0)
    world = load.node_positions(state)  # the structure is centred on its centre of mass
    F = load.node_forces(state)[1].sum(axis=0)
    np.testing.assert_allclose(F, -2.0 * 1.5 * _shadow_area(world, s) * s, rtol=1e-12)
    state.env.srp_pressure_N_m2, state.env.density_kg_m3, state.env.v_rel_eci = 0.0, 2e-12, V
    F = load.node_forces(state)[1].sum(axis=0)
    expected = -2.2 * 2e-12 * np.linalg.norm(V) * _shadow_area(world, V) * V  # 2 × ½ C_D ρ |V| A⊥ V
    np.testing.assert_allclose(F, expected, rtol=1e-12)
    _, big, state_big = _load_and_state(_tetrahedron(3.0 * points), q0=(1.0, 0.0, 0.0, 0.0), sun=s, rho=2e-12, V=V)
    state_big.env.srp_pressure_N_m2 = 0.0
    np.testing.assert_allclose(big.node_forces(state_big)[1].sum(axis=0), 9.0 * F, rtol=1e-12)


# ----------------------------------------------------------------------------- validation


def _octahedron_free() -> dict:
    tree = _square()
    tree["structure"].pop("panels")
    return tree


@pytest.mark.parametrize(
    "change, message",
    [
        ({"structure": None}, r"srp\.enabled: solar pressure and drag act on the structure's panels, and it has none"),
        ({"sun": {"model": "none"}}, r"srp\.enabled: needs sun\.model = 'ephemeris' or 'fixed'"),
        ({"drag": {"enabled": True}}, r"drag\.enabled: drag needs orbit\.enabled = true"),
        ({"drag": {"drag_coefficient": 3.0}}, r"drag\.drag_coefficient: each panel carries its own drag_coefficient"),
    ],
    ids=["no_panels", "no_sun", "drag_in_free_space", "drag_coefficient_key"],
)
def test_surface_loads_are_refused_naming_the_key(change, message):
    tree = _square()
    for key, value in change.items():
        if value is None:
            tree = _octahedron_free()
        else:
            tree[key] = value
    with pytest.raises(ConfigError, match=message):
        parse_config(tree)


def test_drag_on_a_structure_without_panels_is_refused():
    cfg = load_config(CONFIGS / "octet_detumble.toml")
    tree = cfg.model_dump(mode="json")
    tree["drag"] = {"enabled": True}
    tree["atmosphere"] = {"model": "exponential"}
    with pytest.raises(ConfigError, match=r"drag\.enabled: solar pressure and drag act on the structure's panels"):
        parse_config(tree)


# ----------------------------------------------------------------------------- runs


def test_panel_force_moves_the_centre_of_mass(tmp_path, no_plots):
    """A free 4 kg square absorber lit at cos α = 0.8 by P = 1 N/m²: F = −3.2 ŝ N, so its centre of
    mass moves by ½ (F / M) t² in 1 s; within 1e-3 relative: the unequal thirds on the quad's two
    diagonals bend it by ~1e-4 of its size, which tilts the triangles (measured 3e-4)."""
    cfg = parse_config(_square())
    out = run_scenario(cfg, tmp_path / "r")
    assert out.status == "completed"
    ts = read_timeseries(tmp_path / "r")
    s = np.array([0.0, 0.6, 0.8])
    np.testing.assert_allclose(ts["srp_wrench_world"][0, :3], -3.2 * s, rtol=1e-12)
    sm = make_structure_model(cfg)
    x = sm.structure.positions_m + ts["qpos"][-1].reshape(-1, 3)
    moved = x.mean(axis=0) - sm.structure.positions_m.mean(axis=0)
    np.testing.assert_allclose(moved, 0.5 * (-3.2 * s / 4.0) * ts["t"][-1] ** 2, rtol=1e-3)
    assert out["srp_force_max_N"] == pytest.approx(3.2, rel=1e-3)


def test_shipped_sail_runs_with_solar_pressure_and_drag(tmp_path, no_plots):
    """One second of the sail (beams, a hub, 64 panels) with both loads on; at t = 0 the recorded net
    forces are the flat sail's closed forms at the environment's sample (the sail is flat in its
    z = 0 plane, one reflectivity; 1e-9 relative: the rigid initial state's rounding)."""
    overrides = [
        "sim.progress=false",
        "sim.duration_s=1.0",
        "sim.checkpoint_every_s=0.0",
        "srp.enabled=true",
        "drag.enabled=true",
        "sun.model=ephemeris",
        "sun.shadow=none",
        "atmosphere.model=exponential",
    ]
    cfg = load_config(CONFIGS / "sail_detumble.toml", overrides)
    out = run_scenario(cfg, tmp_path / "sail")
    assert out.status == "completed", out.get("status_message")
    ts = read_timeseries(tmp_path / "sail")
    env = Environment.from_config(cfg.environment_config(), duration_s=cfg.sim.duration_s).sample(0.0)
    panels = cfg.structure.structure.panels
    A = float(panels.areas_m2(cfg.structure.structure.positions_m).sum())
    rho_s, rho_d, _ = panels.reflectivity[0]
    n = np.array([0.0, 0.0, 1.0])
    np.testing.assert_allclose(
        ts["srp_wrench_world"][0, :3],
        _flat_plate_srp(A, n, env.sun_eci, env.srp_pressure_N_m2, rho_s, rho_d),
        rtol=1e-9,
    )
    V = env.v_rel_eci
    drag = -0.5 * panels.drag_coefficient[0] * env.density_kg_m3 * A * abs(n @ V) * V
    np.testing.assert_allclose(ts["drag_wrench_world"][0, :3], drag, rtol=1e-9)
    summary = json.loads((tmp_path / "sail" / "summary.json").read_text())
    assert summary["srp_force_max_N"] > 0 and summary["drag_force_max_N"] > 0
