"""Linear algebra of the schemes: matrices factorised once, sparse when large and sparse.

Every scheme factorises its constant effective matrices (``M``, ``M + Δt/2·C``,
``M + γΔt C + βΔt² K_I``, ...) once per test: Cholesky when symmetric positive definite, LU
otherwise, a sparse LU for large sparse models (:data:`SPARSE_MIN_DOF`,
:data:`SPARSE_MAX_DENSITY`), a division for an SDOF.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, Protocol

import numpy as np
import scipy.linalg
import scipy.linalg.lapack
import scipy.sparse
import scipy.sparse.linalg
from numpy.typing import NDArray

from ..errors import ConfigError

__all__ = [
    'LARGE_MODEL_DOF',
    'SPARSE_MAX_DENSITY',
    'SPARSE_MIN_DOF',
    'Factorization',
    'MatrixOperator',
    'cholesky_or_lu',
    'is_sparse_structure',
    'large_diagonal',
    'operator',
    'solve_factored',
]


class Factorization:
    """A matrix factorised once for repeated solves (Cholesky if SPD, else LU).

    Used by the schemes for their constant effective matrices (``M``, ``M + Δt/2·C``,
    ``M + γΔt C + βΔt² K_I``, ...), computed once per test.
    """

    def __init__(self, matrix: np.ndarray, name: str) -> None:
        """Factorise ``matrix``.

        Args:
            matrix: Square matrix.
            name: Description used in the error message.

        Raises:
            ConfigError: If the matrix is singular.
        """
        matrix = np.array(matrix, dtype=float)
        if matrix.shape == (1, 1):  # an SDOF: a division (fast and exact)
            value = float(matrix[0, 0])
            if value == 0.0 or not math.isfinite(value):
                msg = f'{name} is singular'
                raise ConfigError(msg)
            self._factor: tuple[str, Any] = ('scalar', value)
            return
        self._factor = cholesky_or_lu(
            matrix, bool(np.allclose(matrix, matrix.T, rtol=1e-12, atol=0.0))
        )
        if self._factor[0] == 'lu':
            diagonal = np.abs(np.diag(self._factor[1][0]))
            if not np.all(diagonal > 1e-13 * max(float(np.max(diagonal)), 1e-300)):
                msg = f'{name} is singular'
                raise ConfigError(msg)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """Solve ``matrix · x = rhs`` (``rhs`` a vector or a matrix of columns)."""
        return solve_factored(self._factor, rhs)


#: Matrices of at least this many DOFs that are mostly zeros (a shear building, a frame) are
#: factorised and multiplied as sparse matrices: a step then costs O(nnz) instead of O(n²).
SPARSE_MIN_DOF = 64
SPARSE_MAX_DENSITY = 0.1


def is_sparse_structure(matrix: np.ndarray) -> bool:
    """Whether ``matrix`` is large and mostly zeros (handled as a sparse matrix)."""
    n: int = matrix.shape[0]
    return n >= SPARSE_MIN_DOF and bool(np.count_nonzero(matrix) <= SPARSE_MAX_DENSITY * n * n)


#: Models of at least this many DOFs skip the dense O(n³) work that has an exact or a sparse
#: equivalent: a diagonal mass matrix (lumped masses) is positive definite when its diagonal
#: is, and is inverted by a division; a tridiagonal stiffness (a shear building, a chain) gets
#: its frequencies from a tridiagonal eigensolver. Smaller models keep the dense computations,
#: float for float.
LARGE_MODEL_DOF = 2048


def large_diagonal(matrix: np.ndarray) -> NDArray[np.float64] | None:
    """The diagonal of ``matrix`` if it is a diagonal matrix of at least
    :data:`LARGE_MODEL_DOF` rows (a copy), else ``None``."""
    if matrix.ndim != 2 or matrix.shape[0] < LARGE_MODEL_DOF or (
            matrix.shape[0] != matrix.shape[1]):
        return None
    diagonal = np.diagonal(matrix)
    if np.count_nonzero(matrix) != np.count_nonzero(diagonal):
        return None
    return np.array(diagonal, dtype=float)


class MatrixOperator(Protocol):
    """A constant matrix for repeated products ``A @ x``: a dense array or a scipy CSR matrix."""

    def __matmul__(self, other: NDArray[np.float64], /) -> NDArray[np.float64]:
        """The product with a vector (or a matrix of columns)."""
        ...


def operator(matrix: np.ndarray) -> MatrixOperator:
    """``matrix`` for repeated products: CSR when it is large and sparse, else itself."""
    if matrix.ndim == 2 and is_sparse_structure(matrix):
        # scipy has no type information; a CSR matrix multiplies arrays with ``@``.
        sparse: MatrixOperator = scipy.sparse.csr_matrix(matrix)
        return sparse
    return matrix


def cholesky_or_lu(matrix: np.ndarray, symmetric: bool) -> tuple[str, Any]:
    """``('cholesky', …)`` if ``symmetric`` and positive definite, else ``('lu', …)``.

    Large sparse matrices get a sparse LU (``('sparse', splu)``), which raises ``ConfigError``
    when singular. The dense LU factors are not checked for singularity: the caller does that.
    """
    if symmetric and (tridiagonal := _tridiagonal_cholesky(matrix)) is not None:
        return tridiagonal
    if is_sparse_structure(matrix):
        try:
            return ('sparse', scipy.sparse.linalg.splu(scipy.sparse.csc_matrix(matrix)))
        except RuntimeError as err:  # "Factor is exactly singular"
            msg = f'matrix of {matrix.shape[0]} DOFs is singular ({err})'
            raise ConfigError(msg) from None
    if symmetric:
        try:
            return ('cholesky', scipy.linalg.cho_factor(matrix, check_finite=False))
        except np.linalg.LinAlgError:
            pass  # not positive definite: fall back to LU
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', scipy.linalg.LinAlgWarning)
        return ('lu', scipy.linalg.lu_factor(matrix, check_finite=False))


def _tridiagonal_cholesky(matrix: np.ndarray) -> tuple[str, Any] | None:
    """``('tridiagonal', (d, e))``, the ``L D Lᵀ`` factors of LAPACK ``?pttrf``, for a large
    (:data:`LARGE_MODEL_DOF`) symmetric positive definite tridiagonal matrix (a shear
    building, a chain: ``M + γΔt C + βΔt² K``), else ``None``. A solve is then O(n) with no
    sparse-matrix overhead."""
    if matrix.ndim != 2 or matrix.shape[0] < LARGE_MODEL_DOF:
        return None
    diagonal, lower = np.diagonal(matrix), np.diagonal(matrix, -1)
    if np.count_nonzero(matrix) != (np.count_nonzero(diagonal) + np.count_nonzero(lower)
                                    + np.count_nonzero(np.diagonal(matrix, 1))):
        return None
    d, e, info = scipy.linalg.lapack.dpttrf(diagonal, lower)
    if info != 0:  # not positive definite: the general factorisations decide
        return None
    return ('tridiagonal', (d, e))


def solve_factored(factor: tuple[str, Any], rhs: np.ndarray) -> np.ndarray:
    """Solve with a ``(kind, factor)`` of :class:`Factorization` or :func:`cholesky_or_lu`."""
    kind, value = factor
    # ``value`` is a float, or a factor of scipy (untyped): the solution is a float array.
    solution: NDArray[np.float64]
    if kind == 'scalar':
        solution = np.asarray(rhs, dtype=float) / value
    elif kind == 'cholesky':
        solution = scipy.linalg.cho_solve(value, rhs, check_finite=False)
    elif kind == 'sparse':
        solution = value.solve(np.asarray(rhs, dtype=float))
    elif kind == 'tridiagonal':
        solution, info = scipy.linalg.lapack.dpttrs(value[0], value[1], rhs)
        if info != 0:
            msg = f'tridiagonal solve failed (LAPACK info {info})'
            raise ConfigError(msg)
    else:
        solution = scipy.linalg.lu_solve(value, rhs, check_finite=False)
    return solution
