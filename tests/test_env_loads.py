"""Surface loads (SRP, drag) on rigid facets and lattice cells, and the residual-dipole torque
(Yoo et al. 2016, Eqs. 13–23).

Tolerances: closed forms are a few flops, asserted to 1e-12 relative. The lattice-vs-rigid-plate
checks sum (N−1)² cell forces of equal size: rounding ~N² eps, asserted 1e-11 of the face-on
force. The SRP force law is compared with an independent transcription of the t̂ form
(division by sin α, tangential term zeroed below sin α = 1e-9) to 2e-9 of the
face-on force: that threshold alone makes differences up to (1 − rs)·1e-9.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from magsail_mj.environment.surfaces import (
    FacetSet,
    Optics,
    drag_forces,
    lattice_top_cells,
    optics_arrays,
    srp_forces,
)
from magsail_mj.loads.base import Load, StepState
from magsail_mj.loads.dipole import ResidualDipoleLoad
from magsail_mj.loads.drag import LatticeDragLoad, RigidDragLoad
from magsail_mj.loads.srp import LatticeSRPLoad, RigidSRPLoad
from magsail_mj.loads.tidal import GravityGradientTorqueLoad, TidalGravityLoad

P = 4.563e-6


@dataclass
class FakeEnv:
    sun_eci: np.ndarray = None
    srp_pressure_N_m2: float = P
    density_kg_m3: float = 0.0
    v_rel_eci: np.ndarray = None
    B_eci: np.ndarray = None
    r_ref_eci: np.ndarray = None


def _state(xquat=None, env=None, pos=None, vel=None, nbody=2):
    if xquat is None:
        xquat = np.tile([1.0, 0, 0, 0], (nbody, 1))
    pos = np.zeros((nbody, 3)) if pos is None else pos
    vel = np.zeros((nbody, 3)) if vel is None else vel
    return StepState(t=0.0, pos=pos, vel=vel, xquat=xquat, omega=np.zeros_like(pos), env=env)


def _spec_srp(n, s, A, P, o: Optics):
    """Yoo et al. 2016, Eqs. 16–22 (standard non-ideal sail model) transcribed
    literally (t̂ form), for one facet with front normal n."""
    c = s @ n
    if c < 0:
        n = -n
        Bl, el, Bd, ed = o.B_b, o.e_b, o.B_f, o.e_f
    else:
        Bl, el, Bd, ed = o.B_f, o.e_f, o.B_b, o.e_b
    cos_a = min(1.0, abs(c))
    sin_a = np.linalg.norm(s - cos_a * n)  # = sin α for unit vectors (√(1 − cos²α) loses digits near 0)
    t = (s - cos_a * n) / sin_a if sin_a >= 1e-9 else np.zeros(3)
    r, sp = o.r, o.s
    kn = (1 + r * sp) * cos_a + Bl * r * (1 - sp) + (1 - r) * (el * Bl - ed * Bd) / (el + ed)
    return -P * A * cos_a * (kn * n + (1 - r * sp) * sin_a * t)


unit = (
    st.tuples(*[st.floats(-1, 1)] * 3)
    .filter(lambda v: sum(c * c for c in v) > 1e-2)
    .map(lambda v: np.array(v) / np.linalg.norm(v))
)


@settings(max_examples=80, deadline=None)
@given(unit, unit)
def test_srp_law_matches_spec_transcription(n, s):
    o = Optics.cnusail_sail()
    F = srp_forces(n[None], np.array([4.0]), s, P, optics_arrays([o]), True)[0]
    ref = _spec_srp(n, s, 4.0, P, o)
    # the transcription zeroes the tangential term below sin α = 1e-9 (ours keeps it): ≤ 1e-9 relative
    assert np.allclose(F, ref, rtol=0, atol=2e-9 * P * 4.0)
    assert F @ s <= 1e-20  # never pulls towards the Sun


def test_flat_plate_facing_sun_closed_forms():
    n = np.array([0.0, 0.0, 1.0])
    A = 4.0
    # absorber: F = −P A ŝ; perfect mirror: F = −2 P A n̂ (limits of the sail model)
    F = srp_forces(n[None], np.array([A]), n, P, optics_arrays([Optics.absorber()]))[0]
    assert np.allclose(F, -P * A * n, rtol=1e-14)
    F = srp_forces(n[None], np.array([A]), n, P, optics_arrays([Optics.mirror()]))[0]
    assert np.allclose(F, -2 * P * A * n, rtol=1e-14)
    # absorber at incidence α: F = −P A cos α ŝ
    a = math.radians(35)
    s = np.array([math.sin(a), 0, math.cos(a)])
    F = srp_forces(n[None], np.array([A]), s, P, optics_arrays([Optics.absorber()]))[0]
    assert np.allclose(F, -P * A * math.cos(a) * s, rtol=1e-14)
    # CNUSAIL sail at normal incidence:
    # F = −P A [1 + r s + B_f r (1 − s) + (1 − r)(e_f B_f − e_b B_b)/(e_f + e_b)] n̂
    o = Optics.cnusail_sail()
    kappa = (o.e_f * o.B_f - o.e_b * o.B_b) / (o.e_f + o.e_b)
    k = 1 + o.r * o.s + o.B_f * o.r * (1 - o.s) + (1 - o.r) * kappa
    F = srp_forces(n[None], np.array([A]), n, P, optics_arrays([o]))[0]
    assert np.allclose(F, -P * A * k * n, rtol=1e-14)


def test_plate_edge_on_gets_nothing():
    n = np.array([0.0, 0.0, 1.0])
    s = np.array([1.0, 0.0, 0.0])
    for o in (Optics.absorber(), Optics.mirror(), Optics.cnusail_sail()):
        assert np.all(srp_forces(n[None], np.array([4.0]), s, P, optics_arrays([o]))[0] == 0.0)
    assert np.all(drag_forces(n[None], np.array([4.0]), np.array([7500.0, 0, 0]), 1e-12, 2.2) == 0.0)


def test_one_sided_and_back_lit():
    n = np.array([[0.0, 0.0, 1.0]])
    s = np.array([0.0, 0.0, -1.0])  # Sun behind the facet
    c = optics_arrays([Optics.cnusail_sail()])
    assert np.all(srp_forces(n, np.array([1.0]), s, P, c, False) == 0.0)
    F = srp_forces(n, np.array([1.0]), s, P, c, True)[0]
    assert F[2] > 0 and np.allclose(F[:2], 0)  # pushed away from the Sun, along +z
    # swapping the coefficients changes the back-lit force (B_f ≠ B_b, e_f ≠ e_b)
    c2 = optics_arrays([Optics(**{**Optics.cnusail_sail().__dict__, "swap_back": False})])
    assert not np.allclose(srp_forces(n, np.array([1.0]), s, P, c2, True)[0], F)


def test_drag_plate_along_normal():
    rho, v, cd, A = 3.7e-12, 7600.0, 2.2, 4.0
    n = np.array([0.0, 1.0, 0.0])
    F = drag_forces(n[None], np.array([A]), v * n, rho, cd)[0]
    assert np.allclose(F, -0.5 * rho * v * v * cd * A * n, rtol=1e-14)
    # one-sided face in the wake gets nothing; at incidence: A cos θ projected area
    assert np.all(drag_forces(n[None], np.array([A]), -v * n, rho, cd, False) == 0)
    th = math.radians(60)
    V = v * np.array([0, math.cos(th), math.sin(th)])
    F = drag_forces(n[None], np.array([A]), V, rho, cd)[0]
    assert np.allclose(F, -0.5 * rho * cd * A * math.cos(th) * v * V, rtol=1e-14)


def test_rigid_loads_torque_and_force_flags():
    q = Rotation.from_euler("zyx", [20, -35, 50], degrees=True)
    xq = np.array([[1, 0, 0, 0], q.as_quat(scalar_first=True)])
    sun = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    facets = FacetSet.plate(area=4.0, centre=(0.01, 0.01, 0.10), optics=Optics.cnusail_sail())
    env = FakeEnv(sun_eci=sun, density_kg_m3=2e-12, v_rel_eci=np.array([7000.0, 1000.0, -500.0]))
    st_ = _state(xq, env)
    F_ref = srp_forces(q.apply([[0, 0, 1.0]]), np.array([4.0]), sun, P, facets.coeffs, True)[0]
    xfrc = np.zeros((2, 6))
    RigidSRPLoad(1, facets).add(st_, xfrc)
    assert np.allclose(xfrc[1, :3], F_ref, rtol=1e-13)
    assert np.allclose(xfrc[1, 3:], np.cross(q.apply([0.01, 0.01, 0.10]), F_ref), rtol=1e-13)
    xfrc2 = np.zeros((2, 6))
    RigidSRPLoad(1, facets, apply_force=False).add(st_, xfrc2)
    assert np.all(xfrc2[1, :3] == 0) and np.allclose(xfrc2[1, 3:], xfrc[1, 3:])
    # shadow: zero pressure → nothing
    xfrc3 = np.zeros((2, 6))
    RigidSRPLoad(1, facets).add(_state(xq, FakeEnv(sun_eci=sun, srp_pressure_N_m2=0.0)), xfrc3)
    assert np.all(xfrc3 == 0)
    # drag on sail + bus: torque = Σ c × F
    box = FacetSet.box(size=(0.1, 0.1, 0.3), centre=(0, 0, -0.05))
    both = FacetSet.concat([facets, box])
    xfrc4 = np.zeros((2, 6))
    RigidDragLoad(1, both, apply_force=False).add(st_, xfrc4)
    Fd = drag_forces(q.apply(both.normal), both.area, env.v_rel_eci, 2e-12, 2.2, both.two_sided)
    assert np.allclose(xfrc4[1, 3:], np.cross(q.apply(both.centre), Fd).sum(0), rtol=1e-12)
    assert xfrc4[1, 3:] @ xfrc4[1, 3:] > 0


def _lattice(n=8, d=10.0):
    a = d / (n - 1)
    k, j, i = np.meshgrid(np.arange(2), np.arange(n), np.arange(n), indexing="ij")
    p = np.stack([i * a - d / 2, j * a - d / 2, (k - 0.5) * a], -1).reshape(-1, 3)  # index k n² + j n + i
    return p, a


@settings(max_examples=25, deadline=None)
@given(st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(c * c for c in q) > 1e-2), unit, unit)
def test_rotated_lattice_cells_equal_rigid_plate(qv, sun, flow):
    n, d = 8, 10.0
    p, a = _lattice(n, d)
    q = Rotation.from_quat(np.array(qv), scalar_first=True)
    offset = np.array([3.0, -2.0, 1.0])
    pos = np.vstack([np.zeros(3), q.apply(p) + offset])  # body 0 = world
    cells = lattice_top_cells(n)
    assert cells.shape == ((n - 1) ** 2, 4)
    o = Optics.cnusail_sail()
    env = FakeEnv(sun_eci=sun, density_kg_m3=1e-12, v_rel_eci=7500.0 * flow)
    st_ = StepState(t=0.0, pos=pos, vel=np.zeros_like(pos), xquat=None, omega=None, env=env)
    plate = FacetSet.plate(area=d * d, centre=(0, 0, a / 2), optics=o)  # top layer sits a/2 above the COM
    xq = np.array([[1, 0, 0, 0], q.as_quat(scalar_first=True)])
    rigid_state = _state(xq, env)
    for lat_load, rig_load, face_on in (
        (LatticeSRPLoad(cells, optics=o), RigidSRPLoad(1, plate), 2 * P * d * d),
        (LatticeDragLoad(cells), RigidDragLoad(1, plate), 0.5 * 1e-12 * 2.2 * 7500.0**2 * d * d),
    ):
        xfrc = np.zeros((len(pos), 6))
        lat_load.add(st_, xfrc)
        F_lat = xfrc[:, :3].sum(0)
        tau_lat = np.cross(pos - offset, xfrc[:, :3]).sum(0)  # about the COM
        assert np.all(xfrc[1 : n * n + 1] == 0)  # bottom layer untouched
        xr = np.zeros((2, 6))
        rig_load.add(rigid_state, xr)
        scale = face_on  # the largest force either can see (edge-on cases are ~0 ± rounding)
        assert np.allclose(F_lat, xr[1, :3], rtol=0, atol=1e-11 * scale)
        assert np.allclose(tau_lat, xr[1, 3:], rtol=0, atol=1e-11 * scale * d)


def test_lattice_drag_uses_node_velocity_and_current_geometry():
    n, d = 6, 5.0
    p, a = _lattice(n, d)
    cells = lattice_top_cells(n)
    pos = np.vstack([np.zeros(3), p])
    env = FakeEnv(density_kg_m3=1e-12, v_rel_eci=np.array([0, 0, 7500.0]))
    vel = np.zeros_like(pos)
    vel[1:, 2] = 100.0  # whole lattice moving along +z adds to the flow speed
    xf = np.zeros((len(pos), 6))
    LatticeDragLoad(cells).add(StepState(0.0, pos, vel, None, None, env), xf)
    assert xf[:, 2].sum() == pytest.approx(-0.5 * 1e-12 * 2.2 * d * d * 7600.0**2, rel=1e-12)
    # stretch the top layer by 10 % in x: area grows by 10 %
    pos2 = pos.copy()
    pos2[1 + n * n :, 0] *= 1.1
    xf2 = np.zeros((len(pos), 6))
    LatticeDragLoad(cells).add(StepState(0.0, pos2, np.zeros_like(pos), None, None, env), xf2)
    assert xf2[:, 2].sum() == pytest.approx(-0.5 * 1e-12 * 2.2 * 1.1 * d * d * 7500.0**2, rel=1e-12)


def test_lattice_srp_shadowed():
    n = 5
    p, _ = _lattice(n, 4.0)
    pos = np.vstack([np.zeros(3), p])
    env = FakeEnv(sun_eci=np.array([0, 0, 1.0]), srp_pressure_N_m2=0.0)
    xf = np.zeros((len(pos), 6))
    LatticeSRPLoad(lattice_top_cells(n)).add(StepState(0.0, pos, None, None, None, env), xf)
    assert np.all(xf == 0)


@settings(max_examples=40, deadline=None)
@given(unit, unit, st.tuples(*[st.floats(-1, 1)] * 4).filter(lambda q: sum(c * c for c in q) > 1e-2))
def test_residual_dipole_torque(Ddir, Bdir, qv):
    q = Rotation.from_quat(np.array(qv), scalar_first=True)
    D = 5e-4 * Ddir
    B = 3e-5 * Bdir
    xq = np.array([[1, 0, 0, 0], q.as_quat(scalar_first=True)])
    xf = np.zeros((2, 6))
    ResidualDipoleLoad(1, D).add(_state(xq, FakeEnv(B_eci=B)), xf)
    assert np.allclose(xf[1, 3:], np.cross(q.apply(D), B), rtol=0, atol=1e-22)
    assert abs(xf[1, 3:] @ B) < 1e-24 and np.all(xf[:, :3] == 0)


def test_loads_follow_the_protocol_and_accumulate():
    cells = lattice_top_cells(3)
    loads = [
        TidalGravityLoad([1], [1.0]),
        GravityGradientTorqueLoad(1, [1, 2, 3]),
        RigidSRPLoad(1, FacetSet.plate(area=1.0)),
        RigidDragLoad(1, FacetSet.plate(area=1.0)),
        LatticeSRPLoad(cells),
        LatticeDragLoad(cells),
        ResidualDipoleLoad(1, [0, 0, 1.0]),
    ]
    for ld in loads:
        assert isinstance(ld, Load) and isinstance(ld.name, str)
    env = FakeEnv(sun_eci=np.array([0, 0, 1.0]), B_eci=np.array([1e-5, 0, 0]))
    xf = np.full((2, 6), 2.0)
    ResidualDipoleLoad(1, [0, 0, 1.0]).add(_state(env=env), xf)
    ResidualDipoleLoad(1, [0, 0, 1.0]).add(_state(env=env), xf)
    assert xf[1, 4] == pytest.approx(2.0 + 2e-5)  # (ẑ × x̂) = ŷ, twice
    with pytest.raises(ValueError, match="cells"):
        LatticeSRPLoad(np.zeros((3, 3), int))
    with pytest.raises(ValueError, match="drag_coefficient"):
        RigidDragLoad(1, FacetSet.plate(area=1.0), drag_coefficient=0.0)
    with pytest.raises(ValueError, match="dipole_body"):
        ResidualDipoleLoad(1, [1.0, 2.0])
    with pytest.raises(ValueError, match="optics"):
        FacetSet(area=[1.0, 2.0], normal=[[0, 0, 1]] * 2, centre=[[0, 0, 0]] * 2, two_sided=True, optics=[Optics()] * 3)
    with pytest.raises(ValueError, match="^r:"):
        Optics(r=1.5)


def test_cell_scatter_paths_agree():
    from magsail_mj.environment.surfaces import CellGeometry

    g = CellGeometry(lattice_top_cells(5) + 1)
    F = np.random.default_rng(5).normal(size=(3, g.ncell))
    a = np.zeros((51, 6))
    b = np.asfortranarray(np.zeros((51, 6)))  # not C-contiguous: sparse path
    g.scatter(F, a)
    g.scatter(F, b)
    assert np.allclose(a, b, rtol=0, atol=1e-15) and np.allclose(a[:, :3].sum(0), F.sum(1), atol=1e-14)
    assert np.all(a[:, 3:] == 0)
