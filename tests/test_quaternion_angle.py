"""The quaternion rotation angle against an independent reference (scipy) and at tiny angles."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from magsail_mj.quaternion import quat_angle


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_quat_angle_equals_scipy_magnitude_with_either_sign(seed):
    """Random rotations: the angle equals scipy's rotation magnitude (1e-12 rad), for q and −q."""
    r = Rotation.random(16, random_state=seed)
    q = r.as_quat(scalar_first=True)
    assert np.allclose(quat_angle(q), r.magnitude(), rtol=0, atol=1e-12)
    assert np.allclose(quat_angle(-q), r.magnitude(), rtol=0, atol=1e-12)


def test_quat_angle_keeps_relative_precision_where_arccos_does_not():
    """At 1e-6 … 1e-10 rad the angle is exact to 1e-12 relative; ``2 arccos|w|`` is off by up to
    ~1e-8 rad absolute there (it is what this function replaces), so this test fails with it."""
    angles = np.array([1e-6, 3.7e-7, 1e-8, 1e-10])
    q = np.stack([np.cos(angles / 2), np.sin(angles / 2), 0 * angles, 0 * angles], axis=1)
    assert np.allclose(quat_angle(q), angles, rtol=1e-12, atol=0)
    arccos = 2 * np.arccos(np.clip(q[:, 0], 0, 1))
    assert not np.allclose(arccos, angles, rtol=1e-6, atol=0)
