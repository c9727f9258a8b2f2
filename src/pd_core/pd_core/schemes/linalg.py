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
    'Tridiagonal',
    'cholesky_or_lu',
    'is_sparse_structure',
    'large_bands',
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
        matrix = np.asarray(matrix, dtype=float)  # (read only: the factors are new arrays)
        if matrix.shape == (1, 1):  # an SDOF: a division (fast and exact)
            value = float(matrix[0, 0])
            if value == 0.0 or not math.isfinite(value):
                msg = f'{name} is singular'
                raise ConfigError(msg)
            self._factor: tuple[str, Any] = ('scalar', value)
            return
        bands = large_bands(matrix)
        if bands is not None:  # the same symmetry test on the two off-diagonals: O(n)
            lower, _, upper = bands
            symmetric = bool(np.allclose(lower, upper, rtol=1e-12, atol=0.0)
                             and np.allclose(upper, lower, rtol=1e-12, atol=0.0))
            self._factor = cholesky_or_lu(matrix, symmetric, bands)
        else:
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


Bands = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


def large_bands(matrix: Any) -> Bands | None:
    """The bands of a large dense tridiagonal matrix, else ``None``.

    ``(lower, diagonal, upper)`` (copies) of a dense tridiagonal matrix of at least
    :data:`LARGE_MODEL_DOF` rows (a shear building, a chain; a diagonal one too), else
    ``None``. One counting pass over the matrix; everything else is then O(n).
    """
    if not isinstance(matrix, np.ndarray) or matrix.ndim != 2 or (
            matrix.shape[0] < LARGE_MODEL_DOF or matrix.shape[0] != matrix.shape[1]):
        return None
    lower, diagonal, upper = (np.diagonal(matrix, -1), np.diagonal(matrix),
                              np.diagonal(matrix, 1))
    if np.count_nonzero(matrix) != (np.count_nonzero(lower) + np.count_nonzero(diagonal)
                                    + np.count_nonzero(upper)):
        return None
    return (np.array(lower, dtype=float), np.array(diagonal, dtype=float),
            np.array(upper, dtype=float))


class Tridiagonal:
    """A large tridiagonal matrix for repeated products ``A @ x``, from its three bands.

    A row's product is summed as the CSR product sums it (lower, diagonal, upper entry, in
    that order; an addition of a zero entry's ``0·x`` changes no finite sum but the sign of a
    zero), at about half its cost per vector. A matrix of columns goes through CSR.
    """

    def __init__(self, lower: NDArray[np.float64], diagonal: NDArray[np.float64],
                 upper: NDArray[np.float64]) -> None:
        self._lower = lower
        self._diagonal = diagonal
        self._upper = upper
        self._diagonal_only = not (lower.any() or upper.any())
        self.shape = (diagonal.size, diagonal.size)

    @classmethod
    def of_csr(cls, matrix: Any) -> Tridiagonal | None:
        """The bands of a large tridiagonal scipy CSR matrix, else ``None``.

        The bands of a large square scipy CSR matrix in canonical form whose entries are
        all on the three middle diagonals, else ``None``.
        """
        if not scipy.sparse.issparse(matrix) or matrix.format != 'csr':
            return None
        n = matrix.shape[0]
        if n < LARGE_MODEL_DOF or matrix.shape != (n, n) or not matrix.has_canonical_format:
            return None
        rows = np.repeat(np.arange(n), np.diff(matrix.indptr))
        if matrix.nnz and int(np.max(np.abs(matrix.indices - rows))) > 1:
            return None
        return cls(np.asarray(matrix.diagonal(-1), dtype=float),
                   np.asarray(matrix.diagonal(), dtype=float),
                   np.asarray(matrix.diagonal(1), dtype=float))

    def __matmul__(self, other: NDArray[np.float64], /) -> NDArray[np.float64]:
        """The product of the matrix with ``other`` (a vector or the columns of a matrix)."""
        x = np.asarray(other, dtype=float)
        if x.ndim != 1:
            columns: NDArray[np.float64] = self.csr() @ x
            return columns
        product: NDArray[np.float64] = self._diagonal * x  # (+ l·x_{i-1} first: a + b = b + a)
        if not self._diagonal_only:
            product[1:] += self._lower * x[:-1]
            product[:-1] += self._upper * x[1:]
        return product

    def csr(self) -> scipy.sparse.csr_matrix:
        """The matrix in CSR form."""
        return scipy.sparse.diags([self._lower, self._diagonal, self._upper], [-1, 0, 1],
                                  format='csr')


def large_diagonal(matrix: np.ndarray) -> NDArray[np.float64] | None:
    """The diagonal of a large diagonal ``matrix`` (a copy), else ``None``.

    The diagonal of ``matrix`` if it is a diagonal matrix of at least
    :data:`LARGE_MODEL_DOF` rows (a copy), else ``None``.
    """
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
    """``matrix`` for repeated products.

    Its bands (:class:`Tridiagonal`) when it is large and tridiagonal, CSR when it is large and
    sparse, else itself.
    """
    bands = large_bands(matrix)
    if bands is not None:
        return Tridiagonal(*bands)
    if matrix.ndim == 2 and is_sparse_structure(matrix):
        # scipy has no type information; a CSR matrix multiplies arrays with ``@``.
        sparse: MatrixOperator = scipy.sparse.csr_matrix(matrix)
        return sparse
    return matrix


def cholesky_or_lu(matrix: np.ndarray, symmetric: bool, bands: Bands | None = None
                   ) -> tuple[str, Any]:
    """``('cholesky', …)`` if ``symmetric`` and positive definite, else ``('lu', …)``.

    Large sparse matrices get a sparse LU (``('sparse', splu)``), which raises ``ConfigError``
    when singular. The dense LU factors are not checked for singularity: the caller does that.
    ``bands``: the matrix's :func:`large_bands` if the caller has them (not counted again).
    A large diagonal matrix with a positive diagonal is ``('diagonal', d)``: a division, the
    floats of the tridiagonal solve with a zero off-diagonal.
    """
    if symmetric and bands is not None and not (bands[0].any() or bands[2].any()) and bool(
            np.all(bands[1] > 0.0)):
        return ('diagonal', bands[1])
    if symmetric and (tridiagonal := _tridiagonal_cholesky(matrix, bands)) is not None:
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


def _tridiagonal_cholesky(matrix: np.ndarray, bands: Bands | None = None
                          ) -> tuple[str, Any] | None:
    """``('tridiagonal', (d, e))``, the ``L D Lᵀ`` factors of LAPACK ``?pttrf``.

    For a large (:data:`LARGE_MODEL_DOF`) symmetric positive definite tridiagonal matrix (a shear
    building, a chain: ``M + γΔt C + βΔt² K``), else ``None``. A solve is then O(n) with no
    sparse-matrix overhead.
    """
    if bands is None:
        bands = large_bands(matrix)
        if bands is None:
            return None
    lower, diagonal, _ = bands
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
        c, lower = value
        if _plain(rhs, c):  # LAPACK's solve as cho_solve calls it, without its wrappers
            solution, info = _POTRS(c, rhs, lower=lower)
            if info != 0:
                msg = f'illegal value in {-info}th argument of internal potrs'
                raise ValueError(msg)
        else:
            solution = scipy.linalg.cho_solve(value, rhs, check_finite=False)
    elif kind == 'diagonal':
        rhs = np.asarray(rhs, dtype=float)
        solution = rhs / (value if rhs.ndim == 1 else value[:, None])
    elif kind == 'sparse':
        solution = value.solve(np.asarray(rhs, dtype=float))
    elif kind == 'tridiagonal':
        solution, info = scipy.linalg.lapack.dpttrs(value[0], value[1], rhs)
        if info != 0:
            msg = f'tridiagonal solve failed (LAPACK info {info})'
            raise ConfigError(msg)
    elif _plain(rhs, value[0]):  # LAPACK's solve as lu_solve calls it, without its wrappers
        solution, info = _GETRS(value[0], value[1], rhs)
        if info != 0:
            msg = f'illegal value in {-info}th argument of internal gesv|posv'
            raise ValueError(msg)
    else:
        solution = scipy.linalg.lu_solve(value, rhs, check_finite=False)
    return solution


#: The LAPACK solves scipy's ``cho_solve`` and ``lu_solve`` call for float64 operands.
_POTRS = scipy.linalg.lapack.dpotrs
_GETRS = scipy.linalg.lapack.dgetrs


def _plain(rhs: Any, factor: Any) -> bool:
    """Whether ``rhs`` and ``factor`` are what scipy would hand LAPACK's float64 solve as they are.

    A non-empty float64 vector or matrix of the factor's rows against a float64 factor: scipy's
    ``cho_solve``/``lu_solve`` would pick ``dpotrs``/``dgetrs`` and pass both unchanged (the
    same floats, a few microseconds of checks and batch handling less a solve). Anything else
    goes through scipy.
    """
    return (type(rhs) is np.ndarray and rhs.dtype == np.float64 and 0 < rhs.ndim <= 2
            and rhs.size > 0 and type(factor) is np.ndarray and factor.dtype == np.float64
            and factor.ndim == 2 and rhs.shape[0] == factor.shape[0])
