"""Input checks of the exact reference solutions: numbers and sample histories.

Each check returns the value as a float (or a float array) or raises
:class:`~pd_core.errors.ConfigError` with a one-line message naming the argument.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ConfigError

__all__ = [
    'damping_ratio',
    'finite',
    'non_negative',
    'positive',
    'sample_history',
]


def positive(value: Any, name: str) -> float:
    """A positive, finite number.

    Args:
        value: The value to check.
        name: The argument's name, for the error message.

    Returns:
        The number as a float.

    Raises:
        ConfigError: If ``value`` is not a number, not finite or not positive.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = f'{name}: expected a number, got {value!r}'
        raise ConfigError(msg) from None
    if not (math.isfinite(number) and number > 0.0):
        msg = f'{name}: must be positive and finite, got {value!r}'
        raise ConfigError(msg)
    return number


def non_negative(value: Any, name: str) -> float:
    """A non-negative, finite number.

    Args:
        value: The value to check.
        name: The argument's name, for the error message.

    Returns:
        The number as a float.

    Raises:
        ConfigError: If ``value`` is not a number, not finite or negative.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = f'{name}: expected a number, got {value!r}'
        raise ConfigError(msg) from None
    if not (math.isfinite(number) and number >= 0.0):
        msg = f'{name}: must be non-negative and finite, got {value!r}'
        raise ConfigError(msg)
    return number


def finite(value: Any, name: str) -> float:
    """A finite number.

    Args:
        value: The value to check.
        name: The argument's name, for the error message.

    Returns:
        The number as a float.

    Raises:
        ConfigError: If ``value`` is not a number or not finite.
    """
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = f'{name}: expected a number, got {value!r}'
        raise ConfigError(msg) from None
    if not math.isfinite(number):
        msg = f'{name}: must be finite, got {value!r}'
        raise ConfigError(msg)
    return number


def sample_history(value: Any, name: str) -> np.ndarray:
    """A non-empty 1-D array of finite numbers (a sampled excitation or load).

    Args:
        value: The value to check.
        name: The argument's name, for the error message.

    Returns:
        A new float array.

    Raises:
        ConfigError: If ``value`` is not a non-empty 1-D array of finite numbers.
    """
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError):
        msg = f'{name}: expected a 1-D array of numbers'
        raise ConfigError(msg) from None
    if array.ndim != 1 or array.size == 0:
        msg = f'{name}: expected a non-empty 1-D array, got shape {array.shape}'
        raise ConfigError(msg)
    if not np.all(np.isfinite(array)):
        msg = f'{name}: all values must be finite'
        raise ConfigError(msg)
    return array


def damping_ratio(value: Any, name: str) -> float:
    """An underdamped damping ratio, ``0 ≤ ζ < 1``.

    Args:
        value: The value to check.
        name: The argument's name, for the error message.

    Returns:
        The ratio as a float.

    Raises:
        ConfigError: If ``value`` is not a number in ``[0, 1)``.
    """
    number = non_negative(value, name)
    if number >= 1.0:
        msg = f'{name}: must be below 1 (underdamped), got {value!r}'
        raise ConfigError(msg)
    return number
