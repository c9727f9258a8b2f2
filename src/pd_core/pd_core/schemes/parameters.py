"""Scheme parameters: one declaration per parameter, with its default and its range.

A scheme lists its parameters once, as :class:`~pd_common.registry.Parameter` values (the one
parameter type of every plug-in kind; :data:`SchemeParameter` is its name here) in
``Integrator.PARAMETERS``; construction, stability limits, amplification matrices, summaries
and the analysis tool all read them from there.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from pd_common.registry import Parameter, ParameterError, check_number

from ..errors import ConfigError

__all__ = ['SchemeParameter', 'SchemeParameterError', 'check_parameter', 'resolve_parameters']

#: A scheme's parameter: the shared :class:`~pd_common.registry.Parameter` (bounded: ``low``,
#: ``high``; a switch: a ``True``/``False`` default).
SchemeParameter = Parameter


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
    try:
        return check_number(value, name, low, high, low_open=low_open)
    except ParameterError as err:
        raise SchemeParameterError(str(err)) from None


def resolve_parameters(scheme: str, declared: Sequence[Parameter],
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
    try:
        return {parameter.name: parameter.check(given[parameter.name])
                if parameter.name in given else parameter.default for parameter in declared}
    except ParameterError as err:
        raise SchemeParameterError(str(err)) from None
