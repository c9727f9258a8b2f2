"""The schemes' factored solves (:func:`pd_core.schemes.linalg.solve_factored`).

A dense Cholesky or LU factor is solved with LAPACK's ``dpotrs``/``dgetrs`` called directly
(what scipy's ``cho_solve``/``lu_solve`` call, without their wrappers): the same floats as
scipy's, bit for bit; anything that is not plain float64 still goes through scipy.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from pd_core.schemes import linalg as scheme_linalg


def _matrices(seed: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    general = rng.normal(size=(n, n)) + n * np.eye(n)
    return general @ general.T + np.eye(n), general  # positive definite, unsymmetric


@pytest.mark.parametrize('n', [1, 2, 3, 7, 40])
@pytest.mark.parametrize('columns', [None, 1, 3])
def test_dense_solves_are_scipys_to_the_bit(n: int, columns: int | None) -> None:
    spd, general = _matrices(n, n)
    rng = np.random.default_rng(100 + n)
    rhs = rng.normal(size=n if columns is None else (n, columns)) * 10.0 ** rng.integers(
        -6, 6, size=n if columns is None else (n, columns))
    cholesky = scheme_linalg.cholesky_or_lu(spd, True)
    lu = scheme_linalg.cholesky_or_lu(general, False)
    assert cholesky[0] == 'cholesky' and lu[0] == 'lu'
    solved = scheme_linalg.solve_factored(cholesky, rhs)
    assert np.array_equal(solved, scipy.linalg.cho_solve(cholesky[1], rhs))
    assert solved.shape == rhs.shape
    solved = scheme_linalg.solve_factored(lu, rhs)
    assert np.array_equal(solved, scipy.linalg.lu_solve(lu[1], rhs))
    assert solved.shape == rhs.shape


def test_a_solve_leaves_its_right_hand_side_as_it_was() -> None:
    spd, general = _matrices(5, 4)
    rhs = np.arange(1.0, 5.0)
    for factor in (scheme_linalg.cholesky_or_lu(spd, True),
                   scheme_linalg.cholesky_or_lu(general, False)):
        scheme_linalg.solve_factored(factor, rhs)
        assert rhs.tolist() == [1.0, 2.0, 3.0, 4.0]


@pytest.mark.parametrize('rhs', [[1.0, 2.0, 3.0], np.array([1, 2, 3]),
                                 np.array([1.0, 2.0, 3.0], dtype=np.float32),
                                 np.array([1.0, 2.0, 3.0])[::-1]])
def test_what_is_not_a_plain_float64_array_is_solved_as_scipy_solves_it(rhs: object) -> None:
    spd, general = _matrices(3, 3)
    cholesky = scheme_linalg.cholesky_or_lu(spd, True)
    lu = scheme_linalg.cholesky_or_lu(general, False)
    assert np.array_equal(scheme_linalg.solve_factored(cholesky, rhs),
                          scipy.linalg.cho_solve(cholesky[1], rhs))
    assert np.array_equal(scheme_linalg.solve_factored(lu, rhs),
                          scipy.linalg.lu_solve(lu[1], rhs))


def test_a_right_hand_side_of_the_wrong_length_is_refused_as_scipy_refuses_it() -> None:
    spd, general = _matrices(3, 3)
    for factor in (scheme_linalg.cholesky_or_lu(spd, True),
                   scheme_linalg.cholesky_or_lu(general, False)):
        with pytest.raises(ValueError):
            scheme_linalg.solve_factored(factor, np.ones(4))
