"""Input checks of the model's building blocks: numbers and square matrices.

Each check returns the checked value (a float, or dense float matrices) or raises
:class:`~pd_core.errors.ConfigError` with a one-line message naming it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import scipy.sparse

from ..errors import ConfigError
from ..matrices import square_matrix

__all__ = [
    'dense_square',
    'mass_and_stiffness',
    'positive',
]


def positive(value: Any, name: str, what: str) -> float:
    """``value`` as a finite, strictly positive float, or ConfigError naming ``name``.

    Args:
        value: The value to check.
        name: What the value belongs to (an element name, ``'rayleigh'``), for the message.
        what: The value's own name in the message (``'stiffness k'``, ``'E'``).

    Returns:
        The number as a float.

    Raises:
        ConfigError: If ``value`` is not a number, not finite or not positive.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = f'{name}: {what} must be a number, got {value!r}'
        raise ConfigError(msg) from None
    if not math.isfinite(number) or number <= 0.0:
        msg = f'{name}: {what} must be positive and finite, got {value!r}'
        raise ConfigError(msg)
    return number


def dense_square(value: Any, name: str) -> np.ndarray:
    """A square finite float matrix from an array-like, a scalar or a scipy.sparse matrix.

    Args:
        value: The matrix (a scipy.sparse matrix is made dense).
        name: Its name in error messages.

    Returns:
        The dense float matrix (see :func:`~pd_core.matrices.square_matrix`).

    Raises:
        ConfigError: If ``value`` is not a square matrix of finite numbers.
    """
    if scipy.sparse.issparse(value):
        value = value.toarray()
    return square_matrix(value, name)


def mass_and_stiffness(mass: Any, stiffness: Any) -> tuple[np.ndarray, np.ndarray]:
    """Mass and stiffness as dense square matrices of one shape.

    Args:
        mass: Mass matrix (array-like, scalar or scipy.sparse).
        stiffness: Stiffness matrix of the same shape.

    Returns:
        ``(M, K)`` as dense float matrices.

    Raises:
        ConfigError: If either is not a square finite matrix or their shapes differ.
    """
    m = dense_square(mass, 'mass')
    k = dense_square(stiffness, 'stiffness')
    if m.shape != k.shape:
        msg = f'stiffness: shape {k.shape} does not match mass shape {m.shape}'
        raise ConfigError(msg)
    return m, k
