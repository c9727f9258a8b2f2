"""Scheme parameters: one declaration per parameter, with its default and its range.

A scheme lists its parameters once, as :class:`SchemeParameter` values in
``Integrator.PARAMETERS``; construction, stability limits, amplification matrices, summaries
and the analysis tool all read them from there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import ConfigError

__all__ = ['SchemeParameter', 'SchemeParameterError', 'check_parameter', 'resolve_parameters']


class SchemeParameterError(ConfigError):
    """A scheme parameter is unknown or out of its range (the message names it)."""


def check_parameter(
    value: Any, name: str, low: float, high: float, *, low_open: bool = False
) -> float:
    """Validate a real parameter: a finite number in ``[low, high]`` (``(low, high]``).

    Values within rounding of a closed bound (e.g. ``2/3 - 1`` for ``-1/3``) are taken as the
    bound.

    Raises:
        SchemeParameterError: not a number, not finite, or out of range.
    """
    if isinstance(value, bool):
        msg = f'{name}: expected a number, got {value!r}'
        raise SchemeParameterError(msg)
    try:
        number = float(value)
    except (TypeError, ValueError):
        msg = f'{name}: expected a number, got {value!r}'
        raise SchemeParameterError(msg) from None
    slack = 1e-12 * max(1.0, abs(low), abs(high))
    if math.isfinite(number) and not low_open and low - slack <= number < low:
        number = low
    if math.isfinite(number) and high < number <= high + slack:
        number = high
    below = number <= low if low_open else number < low
    if not math.isfinite(number) or below or number > high:
        bracket = '(' if low_open else '['
        msg = f'{name}: must be in {bracket}{low:g}, {high:g}], got {value!r}'
        raise SchemeParameterError(msg)
    return number


@dataclass(frozen=True)
class SchemeParameter:
    """One parameter of an integration scheme.

    A number in a range, an integer in a range, or a switch (``boolean``: ``true`` or
    ``false``, made with :meth:`switch`).

    Attributes:
        name: Keyword of the parameter (``rho_inf``, ``alpha``, ...).
        default: Value when it is not given (``None``: an optional parameter, absent).
        low: Lower bound of the range (unused for a switch).
        high: Upper bound of the range (unused for a switch).
        low_open: Whether ``low`` itself is excluded.
        integer: Whether the value must be an integer (e.g. ``iterations``).
        description: One line for users (shown by ``./pd analyze``).
        boolean: Whether the value is ``True`` or ``False`` (e.g. ``forward_only``).
    """

    name: str
    default: float | int | bool | None
    low: float
    high: float
    low_open: bool = False
    integer: bool = False
    description: str = ''
    boolean: bool = False

    def __post_init__(self) -> None:
        if self.boolean and (self.integer or not isinstance(self.default, bool)):
            msg = f'{self.name}: a switch has a default True or False, got {self.default!r}'
            raise TypeError(msg)

    @classmethod
    def switch(cls, name: str, default: bool, *, description: str = '') -> SchemeParameter:
        """A parameter that is ``True`` or ``False`` (YAML ``true``/``false``)."""
        return cls(name, default, 0.0, 1.0, description=description, boolean=True)

    def check(self, value: Any) -> float | int | bool | None:
        """The validated value (a float, an int for an integer parameter, a bool for a switch).

        Raises:
            SchemeParameterError: the value is not acceptable (a switch takes ``True`` or
                ``False`` only, not ``0``/``1`` or a string).
        """
        if self.boolean:
            if isinstance(value, (bool, np.bool_)):
                return bool(value)
            msg = f'{self.name}: expected true or false, got {value!r}'
            raise SchemeParameterError(msg)
        if value is None and self.default is None:
            return None
        if not self.integer:
            return check_parameter(value, self.name, self.low, self.high,
                                   low_open=self.low_open)
        if isinstance(value, bool) or not isinstance(
                value, (int, float, np.integer, np.floating)):
            msg = f'{self.name}: expected an integer, got {value!r}'
            raise SchemeParameterError(msg)
        number = float(value)
        if not (math.isfinite(number) and number == int(number)
                and self.low <= number <= self.high):
            msg = (f'{self.name}: must be an integer in [{self.low:g}, {self.high:g}], got '
                   f'{value!r}')
            raise SchemeParameterError(msg)
        return int(number)


def resolve_parameters(scheme: str, declared: Sequence[SchemeParameter],
                       given: Mapping[str, Any]) -> dict[str, Any]:
    """Every declared parameter's value: the given one (validated) or its default.

    Args:
        scheme: The scheme's registry name (for messages).
        declared: The scheme's :class:`SchemeParameter` declarations, in order.
        given: Keyword values given by the caller.

    Raises:
        SchemeParameterError: an unknown parameter, or a value out of its range.
    """
    names = [parameter.name for parameter in declared]
    unknown = sorted(set(given) - set(names))
    if unknown:
        known = ', '.join(names) if names else 'it has none'
        msg = (f'scheme {scheme!r}: unknown parameter(s) {", ".join(unknown)}; parameters: '
               f'{known}')
        raise SchemeParameterError(msg)
    return {parameter.name: parameter.check(given[parameter.name]) if parameter.name in given
            else parameter.default for parameter in declared}
