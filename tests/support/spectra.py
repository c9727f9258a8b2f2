"""Comparing eigenvalue sets without depending on the order round-off gives them."""

from __future__ import annotations

import numpy as np
import scipy.optimize


def matched(actual: np.ndarray, desired: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``actual`` and ``desired`` reordered so that paired values are nearest to each other.

    The pairing minimises the total distance (an assignment problem), so it does not depend on
    how round-off orders nearly equal real parts (``np.sort_complex`` does).
    """
    actual = np.asarray(actual, dtype=complex).reshape(-1)
    desired = np.asarray(desired, dtype=complex).reshape(-1)
    if actual.shape != desired.shape:
        msg = f'{actual.size} values against {desired.size}'
        raise AssertionError(msg)
    cost = np.abs(actual[:, None] - desired[None, :])
    rows, cols = scipy.optimize.linear_sum_assignment(cost)
    return actual[rows], desired[cols]


def assert_same_spectrum(actual: np.ndarray, desired: np.ndarray, *, atol: float) -> None:
    """Assert two eigenvalue sets are equal within ``atol``, in whatever order they come."""
    left, right = matched(actual, desired)
    np.testing.assert_allclose(left, right, rtol=0.0, atol=atol)
