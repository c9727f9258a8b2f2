"""Discrete-parameter (lumped-mass) model of the structure under test.

The equation of motion solved by the pseudo-dynamic loop is thesis eq. 3.1,

    M a_{i+1} + C v_{i+1} + r_{i+1} = p_{i+1},     p = -M ι a_g,

where the restoring force ``r`` is measured on the specimen. This module holds the numerical
side of that model: the mass ``M``, the viscous damping ``C``, the initial (elastic) stiffness
``K`` used for damping and stability estimates, and the influence vector ``ι`` that maps the
ground acceleration onto the degrees of freedom. All quantities are SI (kg, N·s/m, N/m, m/s²).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.sparse
from numpy.typing import NDArray

from ..errors import ConfigError
from ..matrices import as_float_array, as_vector, readonly, square_matrix
from ..schemes.linalg import LARGE_MODEL_DOF, is_sparse_structure, large_bands, large_diagonal

__all__ = [
    'Structure',
    'damping_from_ratio',
    'effective_load',
    'modal_analysis',
    'mode_frequencies',
    'omega_max',
    'rayleigh_frequencies',
]

#: Relative tolerance used for the symmetry checks of the mass and stiffness matrices.
SYMMETRY_RTOL = 1e-10


def _is_symmetric(matrix: np.ndarray) -> bool:
    bands = large_bands(matrix)
    if bands is not None:  # the same test on the two off-diagonals: O(n)
        lower, _, upper = bands
        scale = max(float(np.max(np.abs(band))) if band.size else 0.0 for band in bands)
        return bool(np.all(np.abs(lower - upper) <= SYMMETRY_RTOL * scale))
    scale = float(np.max(np.abs(matrix))) if matrix.size else 0.0
    if matrix.shape[0] >= LARGE_MODEL_DOF and is_sparse_structure(matrix):
        # The same test on the stored entries (no n×n temporaries, no transposed pass).
        sparse = scipy.sparse.csr_matrix(matrix)
        difference = abs(sparse - sparse.T)
        return bool(difference.nnz == 0 or difference.max() <= SYMMETRY_RTOL * scale)
    return bool(np.all(np.abs(matrix - matrix.T) <= SYMMETRY_RTOL * scale))


def _check_positive_definite(matrix: np.ndarray, name: str) -> None:
    lumped = large_diagonal(matrix)  # a large diagonal matrix: its diagonal says it, in O(n)
    if lumped is not None:
        if not bool(np.all(lumped > 0.0)):
            msg = f'{name}: matrix must be positive definite'
            raise ConfigError(msg)
        return
    try:
        np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        msg = f'{name}: matrix must be positive definite'
        raise ConfigError(msg) from None


def modal_analysis(
    mass: Any, stiffness: Any
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Undamped modes of ``K φ = ω² M φ``.

    Args:
        mass: Mass matrix ``M`` (symmetric positive definite), or a scalar for an SDOF.
        stiffness: Stiffness matrix ``K`` (symmetric positive semi-definite), or a scalar.

    Returns:
        ``(omegas, shapes)``: circular frequencies in rad/s in ascending order and the mode
        shapes as the columns of an ``n``×``n`` array, mass-normalised (``Φᵀ M Φ = I``) and
        signed so that the largest-magnitude component of each shape is positive.

    Raises:
        ConfigError: If the matrices are malformed, ``M`` is not positive definite or ``K``
            has a clearly negative eigenvalue.
    """
    m = square_matrix(mass, 'mass')
    k = square_matrix(stiffness, 'stiffness')
    if m.shape != k.shape:
        msg = f'stiffness: shape {k.shape} does not match mass shape {m.shape}'
        raise ConfigError(msg)
    _check_positive_definite(m, 'mass')
    tridiagonal = _large_tridiagonal(m, k)
    if tridiagonal is not None:
        return _tridiagonal_modes(*tridiagonal)
    # scipy has no type information: eigh of two real matrices gives real float arrays.
    eigenvalues: NDArray[np.float64]
    shapes: NDArray[np.float64]
    eigenvalues, shapes = scipy.linalg.eigh(k, m)
    scale = float(np.max(np.abs(eigenvalues))) if eigenvalues.size else 0.0
    if eigenvalues[0] < -1e-10 * scale:
        msg = (
            f'stiffness: matrix has a negative eigenvalue ({eigenvalues[0]:.6g}); '
            'it must be positive semi-definite'
        )
        raise ConfigError(msg)
    omegas = np.sqrt(np.clip(eigenvalues, 0.0, None))
    for j in range(shapes.shape[1]):
        column = shapes[:, j]
        if column[int(np.argmax(np.abs(column)))] < 0.0:
            shapes[:, j] = -column
    return omegas, shapes


def _large_tridiagonal(m: np.ndarray, k: np.ndarray
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                  NDArray[np.float64]] | None:
    """``(d, e, s)`` for a large lumped mass and a tridiagonal stiffness, else ``None``.

    ``M^{-1/2} K M^{-1/2}`` is then the symmetric tridiagonal matrix of diagonal ``d`` and
    off-diagonal ``e`` (from the lower triangle, as ``eigh`` reads it), ``s = diag(M)^{-1/2}``.
    """
    lumped = large_diagonal(m)
    if lumped is None or k.shape != m.shape or not bool(np.all(lumped > 0.0)):
        return None  # (a mass that is not positive: the dense path says so)
    bands = large_bands(k)
    if bands is None:
        return None
    lower, diagonal, _ = bands
    s = 1.0 / np.sqrt(lumped)
    return diagonal * s * s, lower * s[1:] * s[:-1], s


def _check_spectrum(lowest: float, highest: float) -> None:
    scale = max(abs(lowest), abs(highest))
    if lowest < -1e-10 * scale:
        msg = (
            f'stiffness: matrix has a negative eigenvalue ({lowest:.6g}); '
            'it must be positive semi-definite'
        )
        raise ConfigError(msg)


def _tridiagonal_modes(d: NDArray[np.float64], e: NDArray[np.float64], s: NDArray[np.float64]
                       ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """:func:`modal_analysis` of a large lumped-mass, tridiagonal-stiffness model."""
    eigenvalues: NDArray[np.float64]
    vectors: NDArray[np.float64]
    eigenvalues, vectors = scipy.linalg.eigh_tridiagonal(d, e)
    _check_spectrum(float(eigenvalues[0]), float(eigenvalues[-1]))
    shapes = vectors * s[:, None]  # Φ = M^{-1/2} V: Φᵀ M Φ = Vᵀ V = I
    columns = np.arange(shapes.shape[1])
    negative = shapes[np.argmax(np.abs(shapes), axis=0), columns] < 0.0
    shapes[:, negative] = -shapes[:, negative]
    return np.sqrt(np.clip(eigenvalues, 0.0, None)), shapes


def mode_frequencies(mass: Any, stiffness: Any, modes: Sequence[int]) -> NDArray[np.float64]:
    """Circular frequencies (rad/s) of the 1-based ``modes`` of ``K φ = ω² M φ``.

    The values of :func:`modal_analysis` (float for float for a model it solves densely); a
    large lumped-mass, tridiagonal-stiffness model (:data:`LARGE_MODEL_DOF`) gets only the
    asked eigenvalues and the two extreme ones (the positive semi-definiteness check) by
    bisection, O(n) each, with no mode shapes (10,000 shapes are 800 MB and half a minute).

    Raises:
        ConfigError: As :func:`modal_analysis`; a mode number out of ``1..n``.
    """
    m = square_matrix(mass, 'mass')
    k = square_matrix(stiffness, 'stiffness')
    n = m.shape[0]
    wanted = [int(mode) for mode in modes]
    if any(not 1 <= mode <= n for mode in wanted):
        msg = f'modes: expected mode numbers in 1..{n}, got {tuple(wanted)}'
        raise ConfigError(msg)
    tridiagonal = _large_tridiagonal(m, k)  # (a mass it takes is lumped and positive)
    if tridiagonal is not None:
        d, e, _ = tridiagonal
        _checked_extremes(d, e)
        values = np.array([_tridiagonal_eigenvalue(d, e, mode - 1) for mode in wanted])
        frequencies: NDArray[np.float64] = np.sqrt(np.clip(values, 0.0, None))
        return frequencies
    omegas, _ = modal_analysis(m, k)
    return np.array([omegas[mode - 1] for mode in wanted], dtype=float)


def _checked_extremes(d: NDArray[np.float64], e: NDArray[np.float64]) -> tuple[float, float]:
    """The lowest and highest eigenvalues of a symmetric tridiagonal matrix (bisection, O(n) each).

    After :func:`_check_spectrum`.
    """
    lowest, highest = (_tridiagonal_eigenvalue(d, e, i) for i in (0, d.size - 1))
    _check_spectrum(lowest, highest)
    return lowest, highest


def _tridiagonal_eigenvalue(d: NDArray[np.float64], e: NDArray[np.float64], index: int
                            ) -> float:
    """The ``index``-th (0-based, ascending) eigenvalue of a symmetric tridiagonal matrix."""
    return float(scipy.linalg.eigh_tridiagonal(
        d, e, eigvals_only=True, select='i', select_range=(index, index))[0])


def omega_max(mass: Any, stiffness: Any) -> float:
    """Highest undamped circular frequency ``ω_max`` in rad/s (sets the stability limit).

    Args:
        mass: Mass matrix (or scalar for an SDOF).
        stiffness: Stiffness matrix (or scalar for an SDOF).

    Returns:
        ``ω_max`` (``√(k/m)`` for an SDOF).
    """
    m = square_matrix(mass, 'mass')
    k = square_matrix(stiffness, 'stiffness')
    if m.shape == (1, 1) and k.shape == (1, 1):
        if m[0, 0] <= 0.0:
            msg = 'mass: must be positive'
            raise ConfigError(msg)
        if k[0, 0] < 0.0:
            msg = 'stiffness: must not be negative'
            raise ConfigError(msg)
        return math.sqrt(float(k[0, 0]) / float(m[0, 0]))
    tridiagonal = _large_tridiagonal(m, k)
    if tridiagonal is not None:  # the extreme eigenvalues only, by bisection: O(n)
        d, e, _ = tridiagonal
        return math.sqrt(max(_checked_extremes(d, e)[1], 0.0))
    omegas, _ = modal_analysis(m, k)
    return float(omegas[-1])


def rayleigh_frequencies(mass: Any, stiffness: Any, modes: Sequence[int]) -> tuple[float, float]:
    """The two circular frequencies at which Rayleigh damping matches its ratios.

    Args:
        mass: Mass matrix (square, already checked; symmetric positive definite).
        stiffness: Stiffness matrix of the same shape.
        modes: Two distinct 1-based mode numbers ``(i, j)``.

    Returns:
        ``(ω_i, ω_j)`` in rad/s.

    Raises:
        ConfigError: On anything but two distinct mode numbers in ``1..n``, or modes whose
            frequencies are zero or equal (``C = a0 M + a1 K`` is then not determined).
    """
    n = int(np.shape(mass)[0])
    if isinstance(modes, (str, bytes)) or len(modes) != 2:
        msg = f'damping_modes: expected two mode numbers, got {modes!r}'
        raise ConfigError(msg)
    mode_i, mode_j = (int(modes[0]), int(modes[1]))
    if not (1 <= mode_i <= n and 1 <= mode_j <= n) or mode_i == mode_j:
        msg = f'damping_modes: expected two distinct mode numbers in 1..{n}, got {tuple(modes)}'
        raise ConfigError(msg)
    w_i, w_j = (float(w) for w in mode_frequencies(mass, stiffness, (mode_i, mode_j)))
    if w_i <= 0.0 or w_j <= 0.0 or math.isclose(w_i, w_j, rel_tol=1e-9):
        msg = (
            f'damping_modes: modes {mode_i} and {mode_j} have frequencies {w_i:.6g} and '
            f'{w_j:.6g} rad/s; Rayleigh damping needs two distinct non-zero frequencies'
        )
        raise ConfigError(msg)
    return w_i, w_j


def damping_from_ratio(
    mass: Any, stiffness: Any, ratio: float | Sequence[float], modes: Sequence[int] = (1, 2)
) -> np.ndarray:
    """Viscous damping matrix giving a target damping ratio.

    For an SDOF this is the thesis's ``c = 2 m ω ζ`` with ``ω = √(k_ini/m)`` (Appendix A,
    lines 21–22), i.e. ``c = 2 ζ √(k m)``. For an MDOF it is Rayleigh damping
    ``C = a0 M + a1 K`` with ``a0, a1`` chosen so that the modal damping ratio
    ``ζ_j = a0/(2 ω_j) + a1 ω_j/2`` equals the target at the two given modes.

    Args:
        mass: Mass matrix (or scalar).
        stiffness: Initial stiffness matrix (or scalar).
        ratio: Damping ratio ``ζ`` (≥ 0), or a pair ``(ζ_i, ζ_j)`` for the two modes.
        modes: The two 1-based mode numbers at which the ratio is matched (MDOF only).

    Returns:
        The damping matrix ``C`` (``1``×``1`` for an SDOF).

    Raises:
        ConfigError: On a negative or non-finite ratio, invalid mode numbers or modes with
            equal or zero frequencies.
    """
    m = square_matrix(mass, 'mass')
    k = square_matrix(stiffness, 'stiffness')
    if m.shape != k.shape:
        msg = f'stiffness: shape {k.shape} does not match mass shape {m.shape}'
        raise ConfigError(msg)
    ratios = as_float_array(ratio, 'damping_ratio').reshape(-1)
    if ratios.size not in (1, 2) or np.any(ratios < 0.0):
        msg = f'damping_ratio: expected one non-negative ratio or a pair, got {ratio!r}'
        raise ConfigError(msg)
    n = m.shape[0]
    if n == 1:
        if ratios.size != 1:
            msg = 'damping_ratio: an SDOF takes a single ratio'
            raise ConfigError(msg)
        mm = float(m[0, 0])
        kk = float(k[0, 0])
        if mm <= 0.0:
            msg = 'mass: must be positive'
            raise ConfigError(msg)
        if kk < 0.0:
            msg = 'stiffness: must not be negative'
            raise ConfigError(msg)
        w = math.sqrt(kk / mm)
        return np.array([[2 * mm * w * float(ratios[0])]])
    zeta_i, zeta_j = (float(ratios[0]), float(ratios[-1]))
    w_i, w_j = rayleigh_frequencies(m, k, modes)
    # ζ = a0/(2ω) + a1 ω/2 at both modes.
    system = np.array([[1.0 / (2.0 * w_i), w_i / 2.0], [1.0 / (2.0 * w_j), w_j / 2.0]])
    coefficients = np.linalg.solve(system, np.array([zeta_i, zeta_j]))
    a0, a1 = float(coefficients[0]), float(coefficients[1])
    return a0 * m + a1 * k


def effective_load(mass: Any, influence: Any, ground_acceleration: Any) -> np.ndarray:
    """Effective earthquake load ``p = -M ι a_g`` (thesis §3.2, ``p_{i+1} = -m a_g``).

    Args:
        mass: Mass matrix (or scalar).
        influence: Influence vector ``ι`` (or scalar, broadcast to every DOF).
        ground_acceleration: Ground acceleration in m/s², a scalar or a 1-D history.

    Returns:
        Shape ``(n,)`` for a scalar acceleration, ``(n_steps, n)`` for a history.
    """
    m = square_matrix(mass, 'mass')
    n = m.shape[0]
    iota = as_vector(influence, n, 'influence')
    a_g = as_float_array(ground_acceleration, 'ground_acceleration')
    if a_g.ndim > 1:
        msg = f'ground_acceleration: expected a 1-D history, got shape {a_g.shape}'
        raise ConfigError(msg)
    m_iota = m @ iota
    if a_g.ndim == 0:
        return -(m_iota * float(a_g))
    return -(a_g[:, None] * m_iota[None, :])


@dataclass(frozen=True)
class Structure:
    """Lumped-mass numerical model of the structure (thesis §3.2).

    The arrays are copied on construction and stored read-only, so an instance is immutable
    and hashable.

    Attributes:
        dof_names: Unique, non-empty names of the ``n`` degrees of freedom.
        mass: Mass matrix ``M`` in kg, ``n``×``n``, symmetric positive definite.
        damping: Viscous damping matrix ``C`` in N·s/m, ``n``×``n``.
        initial_stiffness: Initial (elastic) stiffness ``K`` in N/m, ``n``×``n``, symmetric.
        influence: Influence vector ``ι`` (length ``n``) mapping ``a_g`` onto the DOFs.
    """

    dof_names: tuple[str, ...]
    mass: np.ndarray
    damping: np.ndarray
    initial_stiffness: np.ndarray
    influence: np.ndarray

    def __post_init__(self) -> None:
        """Check the DOF names and the matrices."""
        names = self.dof_names
        if isinstance(names, str) or not isinstance(names, Sequence):
            msg = f'dof_names: expected a sequence of names, got {names!r}'
            raise ConfigError(msg)
        names = tuple(names)
        if not names:
            msg = 'dof_names: at least one degree of freedom is required'
            raise ConfigError(msg)
        for name in names:
            if not isinstance(name, str) or not name:
                msg = f'dof_names: every name must be a non-empty string, got {name!r}'
                raise ConfigError(msg)
        if len(set(names)) != len(names):
            msg = f'dof_names: names must be unique, got {list(names)}'
            raise ConfigError(msg)
        n = len(names)
        fields: dict[str, np.ndarray] = {}
        for field in ('mass', 'damping', 'initial_stiffness'):
            array = as_float_array(getattr(self, field), field)
            if array.shape != (n, n):
                msg = f'{field}: expected shape ({n}, {n}) for {n} DOF, got {array.shape}'
                raise ConfigError(msg)
            fields[field] = array
        influence = as_float_array(self.influence, 'influence')
        if influence.shape != (n,):
            msg = f'influence: expected shape ({n},) for {n} DOF, got {influence.shape}'
            raise ConfigError(msg)
        for field in ('mass', 'initial_stiffness'):
            if not _is_symmetric(fields[field]):
                msg = f'{field}: matrix must be symmetric'
                raise ConfigError(msg)
        _check_positive_definite(fields['mass'], 'mass')
        object.__setattr__(self, 'dof_names', names)
        # (as_float_array made new arrays: they are kept, read-only, without a second copy)
        for field, array in fields.items():
            object.__setattr__(self, field, readonly(array))
        object.__setattr__(self, 'influence', readonly(influence))

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom ``n``."""
        return len(self.dof_names)

    def __eq__(self, other: object) -> bool:
        """Equal DOF names and equal matrices."""
        if not isinstance(other, Structure):
            return NotImplemented
        return self.dof_names == other.dof_names and all(
            np.array_equal(getattr(self, f), getattr(other, f))
            for f in ('mass', 'damping', 'initial_stiffness', 'influence')
        )

    def __hash__(self) -> int:
        """A hash of the DOF names and the matrices' bytes."""
        fields = ('mass', 'damping', 'initial_stiffness', 'influence')
        return hash((self.dof_names, *(getattr(self, f).tobytes() for f in fields)))
