"""The fit-free edge angle of ``scripts/plate_readings.py`` against closed forms.

For the twist ``w = A u v`` the plane through a right triangle of the grid (legs ``h`` along the
axes) has the gradient of ``w`` at its right-angle vertex, ``A (v₀, u₀)``, exactly; over a square
plate of half-side ``L`` the largest boundary triangle angle therefore lies between
``atan(A √(L² + (L − h)²))`` (the corner cell split through its corner) and ``atan(A √2 L)`` (split
the other way). The angle is measured against the best-fit plane, so a rigid motion of the layer
(with the body rotation passed along) changes nothing, and a flat layer reads zero.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial.transform import Rotation

from tests.conftest import load_file_module

plate_readings = load_file_module("scripts", "plate_readings")

HALF_SIDE_M = 37.5
N_SIDE = 20


def _grid(height) -> np.ndarray:
    g = np.linspace(-HALF_SIDE_M, HALF_SIDE_M, N_SIDE)
    U, V = np.meshgrid(g, g)
    u, v = U.ravel(), V.ravel()
    return np.stack([u, v, height(u, v)], axis=1)


def test_twist_angle_lies_between_its_closed_form_bounds() -> None:
    A = math.tan(math.radians(4.0)) / (HALF_SIDE_M * math.sqrt(2.0))  # 4° at the corners
    h = 2.0 * HALF_SIDE_M / (N_SIDE - 1)
    edge_deg, all_deg = plate_readings.triangle_angles(_grid(lambda u, v: A * u * v), np.eye(3))
    low = math.degrees(math.atan(A * math.hypot(HALF_SIDE_M, HALF_SIDE_M - h)))
    assert low - 1e-9 <= edge_deg <= 4.0 + 1e-9
    assert all_deg == edge_deg  # the steepest triangles are at the corners, on the boundary


def test_flat_layer_reads_zero_and_a_rigid_motion_changes_nothing() -> None:
    flat = _grid(lambda u, v: 0.0 * u)
    assert plate_readings.triangle_angles(flat, np.eye(3)) == (0.0, 0.0)
    bent = _grid(lambda u, v: 0.02 * np.cos(u / 12.0) * np.sin(v / 9.0))
    R = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    moved = bent @ R.T + np.array([5.0, -3.0, 2.0])
    ref = plate_readings.triangle_angles(bent, np.eye(3))
    assert ref[0] > 0.05
    np.testing.assert_allclose(plate_readings.triangle_angles(moved, R), ref, rtol=1e-9)
