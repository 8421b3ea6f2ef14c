"""The per-step 3-vector helpers equal their NumPy definitions."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from magsail_mj.vec3 import cross3, moment_sum

finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(arrays(float, 3, elements=finite), arrays(float, 3, elements=finite))
def test_cross3_is_np_cross(a, b):
    # scalar arithmetic in the same order as NumPy's: equal to rounding of the largest product
    scale = max(1.0, float(np.abs(a).max() * np.abs(b).max()))
    np.testing.assert_allclose(cross3(a, b), np.cross(a, b), rtol=0, atol=1e-15 * scale)
    np.testing.assert_allclose(cross3(list(a), tuple(b)), np.cross(a, b), rtol=0, atol=1e-15 * scale)


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 60), st.integers(0, 2**32 - 1))
def test_moment_sum_is_sum_of_cross_products(n, seed):
    rng = np.random.default_rng(seed)
    d = rng.normal(scale=50.0, size=(n, 3))
    F = rng.normal(scale=1e-3, size=(n, 3))
    ref = np.cross(d, F).sum(axis=0)
    # n terms of size |d||F|: summation order differs, error ~ n eps |d||F|
    np.testing.assert_allclose(
        moment_sum(d, F), ref, rtol=0, atol=10 * n * 1e-16 * np.abs(d).max() * np.abs(F).max() * 3
    )
