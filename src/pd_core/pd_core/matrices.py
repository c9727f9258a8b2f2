"""Matrix and vector inputs: one set of checks for every model quantity (kg, N/m, N·s/m).

Each helper turns a user value (a scalar, a list, a nested list or an array) into a finite
float array of the expected shape, or raises one :class:`~.errors.ConfigError` line that names
the parameter.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .errors import ConfigError

__all__ = [
    'as_float_array',
    'as_matrix',
    'as_vector',
    'first_boolean',
    'readonly',
    'readonly_copy',
    'square_matrix',
]


def readonly(array: np.ndarray) -> np.ndarray:
    """``array``, made read-only (returned for chaining)."""
    array.setflags(write=False)
    return array


def readonly_copy(array: Any) -> NDArray[np.float64]:
    """A read-only float copy of ``array``."""
    return readonly(np.array(array, dtype=float))


def first_boolean(value: Any) -> bool | None:
    """The first boolean in ``value`` (a scalar, nested lists or tuples, an array), or ``None``.

    YAML's ``true`` is no number, but numpy reads it as 1.0.
    """
    stack = [value]
    while stack:
        item = stack.pop()
        if isinstance(item, (bool, np.bool_)):
            return bool(item)
        if isinstance(item, (list, tuple)):
            stack.extend(reversed(item))
        elif isinstance(item, np.ndarray) and item.dtype == np.bool_ and item.size:
            return bool(item.flat[0])
    return None


def as_float_array(value: Any, name: str) -> NDArray[np.float64]:
    """``value`` as a finite float array.

    A ConfigError naming ``name`` otherwise (a boolean is not a number).
    """
    if value is None:
        msg = f'{name}: a value is required'
        raise ConfigError(msg)
    if isinstance(value, (str, bytes)):
        msg = f'{name}: expected a number or an array of numbers, got {value!r}'
        raise ConfigError(msg)
    flag = first_boolean(value)
    if flag is not None:  # numpy reads true as 1.0: a flag where a number belongs is a typo
        msg = (f'{name}: expected a number or an array of numbers, got a boolean '
               f'({"true" if flag else "false"})')
        raise ConfigError(msg)
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        msg = f'{name}: expected a number or an array of numbers ({exc})'
        raise ConfigError(msg) from None
    if array.dtype == object:
        msg = f'{name}: expected a number or an array of numbers'
        raise ConfigError(msg)
    bad = ~np.isfinite(array)
    if np.any(bad):
        index = tuple(int(i) for i in np.argwhere(bad)[0]) if array.ndim else ()
        where = f' at index {index[0] if len(index) == 1 else index}' if index else ''
        msg_0 = f'{name}: all values must be finite, got {float(array[bad].flat[0])}{where}'
        raise ConfigError(msg_0)
    return array


def as_matrix(value: Any, n: int, name: str) -> NDArray[np.float64]:
    """Build an ``n``×``n`` matrix from a scalar, a diagonal or a full matrix.

    Args:
        value: A scalar (gives ``value·I``), a 1-D sequence of length ``n`` (gives
            ``diag(value)``) or an ``n``×``n`` nested sequence / array (used as is).
        n: Number of degrees of freedom.
        name: Parameter name used in error messages.

    Returns:
        A new float array of shape ``(n, n)``.

    Raises:
        ConfigError: If the value is not numeric, not finite or has an incompatible shape.
    """
    array = as_float_array(value, name)
    if array.ndim == 0:
        return float(array) * np.eye(n)
    if array.ndim == 1 and array.shape == (n,):
        return np.diag(array)
    if array.ndim == 2 and array.shape == (n, n):
        return array
    msg = (
        f'{name}: expected a scalar, a list of {n} diagonal values or a {n}x{n} matrix, '
        f'got shape {array.shape}'
    )
    raise ConfigError(msg)


def as_vector(value: Any, n: int, name: str) -> NDArray[np.float64]:
    """Build a length-``n`` vector from a scalar (broadcast) or a sequence of length ``n``.

    Args:
        value: A scalar or a 1-D sequence of length ``n``.
        n: Number of degrees of freedom.
        name: Parameter name used in error messages.

    Returns:
        A new float array of shape ``(n,)``.

    Raises:
        ConfigError: If the value is not numeric, not finite or has an incompatible shape.
    """
    array = as_float_array(value, name)
    if array.ndim == 0:
        return np.full(n, float(array))
    if array.shape == (n,):
        return array
    msg = f'{name}: expected a scalar or a list of {n} values, got shape {array.shape}'
    raise ConfigError(msg)


def square_matrix(value: Any, name: str) -> NDArray[np.float64]:
    """A scalar or a square matrix as a finite 2-D float array (ConfigError otherwise)."""
    array = as_float_array(value, name)
    if array.ndim == 0:
        return array.reshape(1, 1)
    if array.ndim != 2 or array.shape[0] != array.shape[1] or array.shape[0] == 0:
        msg = f'{name}: expected a square matrix, got shape {array.shape}'
        raise ConfigError(msg)
    return array
