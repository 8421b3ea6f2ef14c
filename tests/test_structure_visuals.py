"""Drawn beams and rigid parts (``magsail_mj.structure.mjcf``, "Drawn beams and rigid parts"):
capsules and boxes that change no mass, inertia, dof, joint, tendon or equality array and no
trajectory, of the shipped four-boom sail and of a generated one with a closed beam loop."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco
import numpy as np
import pytest

from magsail_mj.structure.fileformat import read_structure
from magsail_mj.structure.mjcf import (
    BEAM_RADIUS_OF_WIDTH,
    PART_MIN_HALF_OF_RADIUS,
    VISUAL_GROUP,
    build_structure_spec,
    part_box,
)
from magsail_mj.structure.model import MEMBER_KINDS, Members, RigidPart, Structure
from tests.conftest import small_sail

SAIL = Path(__file__).resolve().parents[1] / "magsail_mj/concepts/structure/configs/structures/sail_100m.toml"

#: Every model array that the dynamics read and geoms could reach (bodies, dofs, joints,
#: tendons, equalities, options), compared bit for bit.
DYNAMIC_FIELDS = (
    "body_mass",
    "body_inertia",
    "body_ipos",
    "body_iquat",
    "body_pos",
    "body_quat",
    "body_parentid",
    "body_subtreemass",
    "body_simple",
    "body_dofnum",
    "dof_bodyid",
    "dof_jntid",
    "dof_parentid",
    "dof_armature",
    "dof_damping",
    "dof_invweight0",
    "dof_M0",
    "jnt_type",
    "jnt_pos",
    "jnt_axis",
    "jnt_stiffness",
    "jnt_qposadr",
    "jnt_dofadr",
    "qpos0",
    "qpos_spring",
    "tendon_stiffness",
    "tendon_damping",
    "tendon_lengthspring",
    "tendon_length0",
    "tendon_invweight0",
    "eq_type",
    "eq_data",
    "eq_solref",
    "eq_solimp",
    "site_pos",
    "site_bodyid",
)


def _sail_with_loop() -> Structure:
    """A small four-boom sail with a hub whose inertia is a box's, plus a beam from boom tip to
    boom tip (a closed beam loop: a closing body)."""
    sail = small_sail(hub_mass_kg=12.0, hub_inertia_kg_m2=np.diag([1.0, 2.0, 2.5]))
    beams = sail.members.of_kind("beam")
    tips = sorted(
        {int(i) for i in sail.members.nodes[beams].ravel()}, key=lambda i: -np.linalg.norm(sail.positions_m[i])
    )
    loop = Members.build(
        [[tips[0], tips[1]]],
        positions_m=sail.positions_m,
        kind="beam",
        EA_N=1e5,
        EI_Nm2=1000.0,
        GJ_Nm2=800.0,
        linear_density_kg_m=0.1,
    )
    return dataclasses.replace(sail, members=Members.concatenate([sail.members, loop]))


def _models(structure: Structure, **options) -> tuple[mujoco.MjModel, mujoco.MjModel]:
    options = {"timestep_s": 0.01, "integrator": "RK4", **options}
    drawn = build_structure_spec(structure, **options).compile()
    bare = build_structure_spec(structure, visual_geoms=False, **options).compile()
    return drawn, bare


def _assert_same_dynamics(drawn: mujoco.MjModel, bare: mujoco.MjModel) -> None:
    for field in ("nq", "nv", "nbody", "njnt", "ntendon", "neq", "nsite", "nu"):
        assert getattr(drawn, field) == getattr(bare, field), field
    for field in DYNAMIC_FIELDS:
        np.testing.assert_array_equal(getattr(drawn, field), getattr(bare, field), err_msg=field)


@pytest.mark.parametrize("which", ["shipped", "loop"])
def test_visual_geoms_change_no_dynamics(which: str) -> None:
    """The drawn and the bare model have equal mass, inertia, dof, joint, tendon and equality
    arrays (exactly), and 50 RK4 steps from a spinning, deformed start give bit-identical
    ``qpos``/``qvel`` (the geoms are never in a computation the dynamics read)."""
    structure = read_structure(SAIL).structure if which == "shipped" else _sail_with_loop()
    drawn, bare = _models(structure)
    _assert_same_dynamics(drawn, bare)
    beams = structure.members.of_kind("beam").size
    added = drawn.ngeom - bare.ngeom
    assert added == 2 * beams + len(structure.rigid_parts)
    extra = np.arange(bare.ngeom, drawn.ngeom)  # which geoms are new: by type, not position
    new = (drawn.geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE) | (drawn.geom_type == mujoco.mjtGeom.mjGEOM_BOX)
    assert new.sum() == extra.size
    assert np.all(drawn.geom_contype[new] == 0) and np.all(drawn.geom_conaffinity[new] == 0)
    assert np.all(drawn.geom_group[new] == VISUAL_GROUP)
    runs = []
    for model in (drawn, bare):
        data = mujoco.MjData(model)
        rng = np.random.default_rng(1)
        data.qvel[:] = 1e-3 * rng.standard_normal(model.nv)
        for _ in range(50):
            mujoco.mj_step(model, data)
        runs.append((data.qpos.copy(), data.qvel.copy()))
    np.testing.assert_array_equal(runs[0][0], runs[1][0])
    np.testing.assert_array_equal(runs[0][1], runs[1][1])


def test_beam_capsules_span_their_members() -> None:
    """Each beam's two capsules meet at its midpoint and reach its end nodes at the reference
    (world positions from ``mj_kinematics`` within 1e-12 m), radius ``BEAM_RADIUS_OF_WIDTH`` times
    the member width."""
    structure = _sail_with_loop()
    width = 0.05
    model = build_structure_spec(structure, timestep_s=0.01, integrator="RK4", member_width_m=width).compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    capsules = np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_CAPSULE)
    np.testing.assert_allclose(model.geom_size[capsules, 0], BEAM_RADIUS_OF_WIDTH * width, rtol=0, atol=0)
    axis = data.geom_xmat[capsules].reshape(-1, 3, 3)[:, :, 2]
    half = model.geom_size[capsules, 1][:, None]
    segments = np.sort(
        np.stack([data.geom_xpos[capsules] - half * axis, data.geom_xpos[capsules] + half * axis], axis=1), axis=1
    )
    p = structure.positions_m
    beams = structure.members.of_kind("beam")
    ends = structure.members.nodes[beams]
    mid = 0.5 * (p[ends[:, 0]] + p[ends[:, 1]])
    expected = np.concatenate([np.stack([p[ends[:, 0]], mid], 1), np.stack([mid, p[ends[:, 1]]], 1)])
    expected = np.sort(expected, axis=1)
    # match each expected half to a capsule (every one found once)
    found = []
    for seg in expected:
        err = np.abs(segments - seg).max(axis=(1, 2))
        k = int(np.argmin(err))
        assert err[k] < 1e-12
        found.append(k)
    assert sorted(found) == list(range(capsules.size))


def test_part_box_matches_the_inertia() -> None:
    """A uniform box of the drawn half-sides and the part's mass has the part's principal
    inertia (rtol 1e-12) when no enlargement applies; a massless part takes its nodes' extent;
    the floor ``PART_MIN_HALF_OF_RADIUS`` node radii scales the box uniformly."""
    rotation = np.linalg.qr(np.random.default_rng(3).standard_normal((3, 3)))[0]
    half = np.array([0.4, 1.2, 2.0])
    mass = 30.0
    principal = (
        mass / 3 * np.array([half[1] ** 2 + half[2] ** 2, half[0] ** 2 + half[2] ** 2, half[0] ** 2 + half[1] ** 2])
    )
    positions = np.array([[0.0, 0.0, 0.0], [3.0, 0.0, 0.0], [0.0, 1.0, 0.5]])
    members = Members.build([[0, 1], [0, 2]], positions_m=positions, kind=MEMBER_KINDS[0], EA_N=1.0)
    center = np.array([0.5, -0.2, 0.1])
    part = RigidPart("bus", mass, center, rotation @ np.diag(principal) @ rotation.T, np.array([0]))
    massless = RigidPart("frame", 0.0, center, np.zeros((3, 3)), np.array([1, 2]))
    structure = Structure(
        name="parts", positions_m=positions, node_mass_kg=np.ones(3), members=members, rigid_parts=(part, massless)
    )
    where, axes, got = part_box(structure, 0, radius_m=0.01)
    np.testing.assert_allclose(where, center, rtol=0, atol=0)
    np.testing.assert_allclose(np.sort(got), half, rtol=1e-12)
    box_inertia = axes @ np.diag(mass / 3 * (np.sum(got**2) - got**2)) @ axes.T
    np.testing.assert_allclose(box_inertia, part.inertia_kg_m2, rtol=1e-12, atol=1e-12 * principal.max())
    where, axes, got = part_box(structure, 1, radius_m=0.01)
    np.testing.assert_allclose(where, [1.5, 0.5, 0.25])
    np.testing.assert_allclose(got, [1.5, 0.5, 0.25])
    radius = 2.0  # largest half-side 2.0 < 3 radii: scaled by 3 so that the largest is 6
    _, _, got = part_box(structure, 0, radius_m=radius)
    np.testing.assert_allclose(np.sort(got), np.maximum(half, 0.5 * radius) * PART_MIN_HALF_OF_RADIUS * radius / 2.0)
