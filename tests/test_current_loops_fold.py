"""The current-loops plate's shape classification: the fold angle between the best rigid fits of
its two halves (analytic folds of a lattice, turned as a whole at random), the collapse criteria a
run meets and the classification by shape beside the one with the strain bound."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsail_mj.concepts.current_loops.config import ClassificationConfig
from magsail_mj.concepts.current_loops.metrics import (
    classification_keys,
    fold_angle,
    plate_halves,
)
from magsail_mj.estimation.attitude import so3_exp
from magsail_mj.lattice.geometry import make_lattice

SIDE_M = 60.0


def _fold(nodes: np.ndarray, *, theta: float, line: str) -> np.ndarray:
    """The plate folded through ``theta`` [rad] about a line in its mid-plane through the centre:
    the nodes on the positive side of the line turn about it, the others stay."""
    u, v = nodes[:, 0], nodes[:, 1]
    if line == "x":  # the line x = 0, along y
        side, axis = u > 1e-9, np.array([0.0, 1.0, 0.0])
    elif line == "y":
        side, axis = v > 1e-9, np.array([1.0, 0.0, 0.0])
    else:  # the diagonal x = y
        side, axis = u - v > 1e-9, np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    out = nodes.copy()
    out[side] = nodes[side] @ so3_exp(theta * axis).T
    return out


@pytest.mark.parametrize("units", [3, 4, 7])
def test_halves_split_the_plate_by_four_lines(units):
    nodes = make_lattice(units=units, side_m=SIDE_M).nodes
    halves = plate_halves(nodes)
    assert len(halves) == 4
    for a, b in halves:
        assert len(a) == len(b) > 0  # the plate is symmetric about each line
        assert not set(a) & set(b)
    # odd units: no node on a mid-line; even: one row of each layer lies on it
    on_mid = len(nodes) - sum(map(len, halves[0]))
    assert on_mid == (0 if units % 2 else 2 * (units + 1))


@settings(max_examples=25, deadline=None)
@given(
    rotvec=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
    offset=st.tuples(*[st.floats(-1e3, 1e3)] * 3),
)
def test_a_plate_turned_as_a_whole_has_no_fold(rotvec, offset):
    nodes = make_lattice(units=5, side_m=SIDE_M).nodes
    x = nodes @ so3_exp(np.array(rotvec)).T + np.array(offset)
    assert fold_angle(nodes, x[None])[0] < 1e-6


@settings(max_examples=25, deadline=None)
@given(
    theta=st.floats(0.01, 3.0),
    line=st.sampled_from(["x", "y", "diagonal"]),
    units=st.sampled_from([4, 5]),
    rotvec=st.tuples(*[st.floats(-3.0, 3.0)] * 3),
)
def test_a_fold_reads_its_angle_whatever_the_turn(theta, line, units, rotvec):
    """Folded about a mid-line or a diagonal, the halves of that line are each rigid and turned by
    theta against each other; no other line's halves differ by more (each holds parts of both
    folded sides). Tolerance: the SVD of a 3 x 3 covariance, 1e-7 rad."""
    nodes = make_lattice(units=units, side_m=SIDE_M).nodes
    x = _fold(nodes, theta=theta, line=line) @ so3_exp(np.array(rotvec)).T
    assert fold_angle(nodes, x[None])[0] == pytest.approx(theta, abs=1e-7)


def test_fold_angle_per_record():
    nodes = make_lattice(units=4, side_m=SIDE_M).nodes
    thetas = np.array([0.0, 0.3, 1.2, 2.5])
    x = np.stack([_fold(nodes, theta=t, line="x") for t in thetas])
    np.testing.assert_allclose(fold_angle(nodes, x), thetas, atol=1e-7)


CFG = ClassificationConfig()
D, N = 250.0, 19  # w = D / N = 13.16 m: thickness bound 5 w = 65.8 m; residual bound 0.1 D = 25 m


def _keys(*, rho, strain, h, dev=0.0):
    return classification_keys(CFG, side_m=D, units=N, rho_max=rho, strain_max=strain, h_max=h, dev_max=dev)


def test_strain_alone_collapses_by_the_bound_not_by_shape():
    k = _keys(rho=17.9, strain=0.501, h=30.6)
    assert k["collapse_criteria"] == ["strain"]
    assert k["classification"] == "collapsed"
    assert k["classification_by_shape"] == "flexible"


@pytest.mark.parametrize(
    ("rho", "strain", "h", "met"),
    [
        (26.0, 0.1, 30.0, ["residual"]),
        (10.0, 0.1, 66.0, ["thickness"]),
        (26.0, 0.6, 70.0, ["residual", "strain", "thickness"]),
        (24.9, 0.499, 65.7, []),
    ],
)
def test_each_shape_criterion_collapses_both_classifications(rho, strain, h, met):
    k = _keys(rho=rho, strain=strain, h=h)
    assert k["collapse_criteria"] == met
    expected = "collapsed" if met else "flexible"
    assert k["classification"] == expected
    assert k["classification_by_shape"] == expected


def test_rigid_like_by_shape_when_a_stiff_plate_only_overstrains():
    k = _keys(rho=1.0, strain=0.6, h=13.2, dev=np.radians(1.0))
    assert (k["classification"], k["classification_by_shape"]) == ("collapsed", "rigid_like")
