"""One registry pattern for every plug-in kind, and one parameter type.

Every kind of plug-in (an integration scheme, an actuator driver, a hysteresis model, a delay
compensator, a plant model) has one :class:`Registry`: a read-only mapping from the name a test
or parameter file uses to the entry that builds it. The built-in entries register themselves
in code, next to their classes (``registry.register(name, entry)``); a separate package adds
its own entries through a Python entry point of the kind's group (the entry point's value,
and the registry), without editing ours:

* ``pd.schemes``: an ``Integrator`` subclass (``pd_core.schemes.SCHEMES``);
* ``pd.drivers``: a ``DriverSpec`` (``pd_actuator_bridge.core.drivers.registry.DRIVERS``);
* ``pd.hysteresis``: a ``HysteresisModelSpec`` (``pd_common.specimen.HYSTERESIS_MODELS``);
* ``pd.compensators``: a ``CompensatorSpec`` (``pd_common.rths.compensation.COMPENSATORS``);
* ``pd.plants``: a plant factory (``pd_common.rths.plant.PLANT_MODELS``);
* ``pd.commands``: a ``CliCommand``, a subcommand of ``./pd`` (``pd_common.cli.COMMANDS``).

A plug-in package declares them in its ``pyproject.toml``; the entry point's name is the
entry's registry name::

    [project.entry-points."pd.hysteresis"]
    linear_spring = "pd_plugin_example.spring:LINEAR_SPRING"

The group is read once, lazily, the first time the registry is asked for a name. A plug-in
that does not load (an import error, a value of the wrong kind, a name already taken) is left
out with one line on the ``pd_common.registry`` logger naming its entry point, never a
traceback; asking for its name then says so.

Every kind declares its parameters with :class:`Parameter` (name, default, description, and
optionally bounds or choices); :meth:`Parameter.check` validates a value the same way for all.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from importlib import metadata
from typing import Any, Generic, TypeVar

import numpy as np

__all__ = [
    'GROUPS',
    'NAME_PATTERN',
    'Parameter',
    'ParameterError',
    'ParameterValue',
    'Registry',
    'RegistryError',
    'check_number',
    'resolve_parameters',
]

T = TypeVar('T')

#: The entry-point group of each plug-in kind.
GROUPS: Mapping[str, str] = {
    'scheme': 'pd.schemes',
    'driver': 'pd.drivers',
    'hysteresis model': 'pd.hysteresis',
    'compensator': 'pd.compensators',
    'plant model': 'pd.plants',
    './pd command': 'pd.commands',
}

ParameterValue = bool | int | float | str
"""The types a parameter's value may have."""

#: What a registry name and a parameter name look like.
NAME_PATTERN = re.compile(r'[a-z][a-z0-9_]*')
_LOG = logging.getLogger(__name__)


class RegistryError(ValueError):
    """A registry was asked for an unknown name, or given a bad or taken name."""


class ParameterError(ValueError):
    """A parameter's declaration or value is invalid.

    Attributes:
        parameter: The parameter's name.
        reason: What is wrong, e.g. ``must be in [0, 1], got 2``.
    """

    def __init__(self, parameter: str, reason: str) -> None:
        """Make the message ``<parameter>: <reason>``."""
        super().__init__(f'{parameter}: {reason}')
        self.parameter = parameter
        self.reason = reason


def check_number(value: Any, name: str, low: float = -math.inf, high: float = math.inf, *,
                 low_open: bool = False) -> float:
    """A finite number in ``[low, high]`` (``(low, high]`` if ``low_open``).

    Values within rounding of a closed bound (e.g. ``2/3 - 1`` for ``-1/3``) are taken as the
    bound.

    Raises:
        ParameterError: Not a number, not finite, or out of range.
    """
    if isinstance(value, bool):
        raise ParameterError(name, f'expected a number, got {value!r}')
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ParameterError(name, f'expected a number, got {value!r}') from None
    finite_bounds = [abs(bound) for bound in (low, high) if math.isfinite(bound)]
    slack = 1e-12 * max([1.0, *finite_bounds])
    if math.isfinite(number) and not low_open and low - slack <= number < low:
        number = low
    if math.isfinite(number) and high < number <= high + slack:
        number = high
    below = number <= low if low_open else number < low
    if not math.isfinite(number) or below or number > high:
        bracket = '(' if low_open else '['
        raise ParameterError(name, f'must be in {bracket}{low:g}, {high:g}], got {value!r}')
    return number


def _is_bool(value: Any) -> bool:
    """Whether ``value`` is a bool (also numpy's)."""
    return isinstance(value, bool | np.bool_)


@dataclass(frozen=True)
class Parameter:
    """One parameter of a plug-in (a scheme, a driver, a hysteresis model, a compensator).

    Three shapes, told apart by the fields:

    * **bounded** (``low`` or ``high`` given): a number in the range, an integral one if
      ``integer``; ``None`` is accepted when the default is ``None`` (an optional parameter);
    * **a choice** (``choices`` given): one of the strings;
    * **typed by its default** (neither): a value of the default's type, ``bool`` (``true`` or
      ``false``), ``int``, ``float`` (an int is taken as a float) or ``str``; any value if the
      default is ``None`` (the plug-in checks it).

    Attributes:
        name: Keyword of the parameter (lower case, digits, underscores), e.g. ``rho_inf``.
        default: Value when it is not given (``None``: absent, or required if ``required``).
        description: One line for users (listings, ROS descriptors, ``./pd analyze``).
        low: Lower bound of a bounded parameter.
        high: Upper bound of a bounded parameter.
        low_open: Whether ``low`` itself is excluded.
        integer: Whether a bounded parameter takes integers only (e.g. ``iterations``).
        choices: The strings a choice parameter takes.
        required: Whether the parameter must be given (a hysteresis model's ``stiffness``).

    Raises:
        ParameterError: On a bad name, an empty description, or a default that is not a bool,
            int, float, str or ``None``.
    """

    name: str
    default: ParameterValue | None
    description: str
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    integer: bool = False
    choices: tuple[str, ...] = ()
    required: bool = False

    def __post_init__(self) -> None:
        """Check the declaration."""
        label = f'parameter {self.name!r}' if not isinstance(self.name, str) else (
            f'parameter {self.name}')
        if not isinstance(self.name, str) or not NAME_PATTERN.fullmatch(self.name):
            raise ParameterError(label, f'name must match {NAME_PATTERN.pattern}')
        if self.default is not None and not isinstance(self.default, ParameterValue):
            raise ParameterError(label, 'default must be a bool, int, float, str or None, got '
                                        f'{type(self.default).__name__}')
        if not isinstance(self.description, str) or not self.description:
            raise ParameterError(label, 'description must be a non-empty string')
        if self.bounded and self.choices:
            raise ParameterError(label, 'bounds and choices exclude each other')

    @property
    def bounded(self) -> bool:
        """Whether the parameter is a number in a range."""
        return self.low is not None or self.high is not None

    @property
    def boolean(self) -> bool:
        """Whether the parameter is a switch (``true`` or ``false``)."""
        return isinstance(self.default, bool)

    def check(self, value: Any) -> ParameterValue | None:
        """The validated value (an int for an integer parameter, a bool for a switch).

        Raises:
            ParameterError: The value is not acceptable (a switch takes ``True`` or ``False``
                only, not ``0``/``1`` or a string).
        """
        if self.boolean:
            if _is_bool(value):
                return bool(value)
            raise ParameterError(self.name, f'expected true or false, got {value!r}')
        if value is None and self.default is None and not self.required:
            return None
        if self.choices:
            if isinstance(value, str) and value in self.choices:
                return value
            raise ParameterError(self.name, f'must be one of {", ".join(self.choices)}, got '
                                            f'{value!r}')
        if self.bounded:
            return self._check_bounded(value)
        return self._check_typed(value)

    def _check_bounded(self, value: Any) -> float | int:
        """A number in ``[low, high]``; an integral one for an integer parameter."""
        low = -math.inf if self.low is None else self.low
        high = math.inf if self.high is None else self.high
        if not self.integer:
            return check_number(value, self.name, low, high, low_open=self.low_open)
        if _is_bool(value) or not isinstance(value, int | float | np.integer | np.floating):
            raise ParameterError(self.name, f'expected an integer, got {value!r}')
        number = float(value)
        if not (math.isfinite(number) and number == int(number) and low <= number <= high):
            raise ParameterError(self.name, f'must be an integer in [{low:g}, {high:g}], got '
                                            f'{value!r}')
        return int(number)

    def _check_typed(self, value: Any) -> ParameterValue:
        """A value of the default's type (an int is taken for a float; any for ``None``)."""
        default = self.default
        if default is None:
            checked_any: ParameterValue = value
            return checked_any
        if isinstance(default, int):
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif isinstance(default, float):
            ok = (isinstance(value, int | float) and not isinstance(value, bool)
                  and math.isfinite(float(value)))
            value = float(value) if ok else value
        else:
            ok = isinstance(value, str)
        if not ok:
            expected = type(default).__name__
            raise ParameterError(self.name, f'must be {expected}, got {value!r}')
        checked: ParameterValue = value
        return checked


def resolve_parameters(declared: tuple[Parameter, ...], given: Mapping[str, Any],
                       *, check: bool = True) -> dict[str, Any]:
    """Every declared parameter's value: the given one (validated) or its default.

    Args:
        declared: The declarations, in order.
        given: The values given by name.
        check: Whether to validate the given values (:meth:`Parameter.check`).

    Returns:
        The values by name, in declaration order.

    Raises:
        ParameterError: A given name is not declared (``parameter`` is the first unknown name,
            ``reason`` lists the declared ones), a required one is missing, or a value is
            invalid.
    """
    names = [parameter.name for parameter in declared]
    unknown = [name for name in given if name not in names]
    if unknown:
        known = ', '.join(names) or 'none'
        raise ParameterError(str(unknown[0]), f'unknown parameter (parameters: {known})')
    resolved: dict[str, Any] = {}
    for parameter in declared:
        if parameter.name in given:
            value = given[parameter.name]
            resolved[parameter.name] = parameter.check(value) if check else value
        elif parameter.required:
            raise ParameterError(parameter.name, 'missing')
        else:
            resolved[parameter.name] = parameter.default
    return resolved


@cache
def _entry_points(group: str) -> tuple[metadata.EntryPoint, ...]:
    """The installed entry points of ``group`` (read once per process: the scan is slow)."""
    return tuple(metadata.entry_points(group=group))


class Registry(Mapping[str, T], Generic[T]):
    """The entries of one plug-in kind by name: the built-ins and the installed plug-ins.

    A read-only mapping (``name in registry``, ``registry[name]``, iteration in registration
    order; :meth:`names` sorts) plus :meth:`register` and :meth:`lookup`. The kind's
    entry-point group is loaded the first time a name is asked for (not while the built-ins
    register: :meth:`loaded` is what is registered so far).

    Args:
        kind: What an entry is, for messages (``'driver'``, ``'hysteresis model'``).
        group: The entry-point group of the kind's plug-ins (``None``: built-ins only).
        admit: Checks an entry before it is registered (its type and the kind's own rules)
            and returns it typed; raises on a bad entry. Default: any entry is admitted.
        error: The exception :meth:`lookup` and :meth:`register` raise (one-line message).
        unknown: The message of an unknown name, a :meth:`str.format` template with ``kind``,
            ``name`` and ``known`` (the registered names, sorted, comma-separated).
    """

    def __init__(self, kind: str, group: str | None = None, *,
                 admit: Callable[[str, Any], T] | None = None,
                 error: Callable[[str], Exception] = RegistryError,
                 unknown: str = 'unknown {kind} {name!r} (known: {known})') -> None:
        """Create an empty registry."""
        self.kind = kind
        self.group = group
        self._admit = admit
        self._error = error
        self._unknown = unknown
        self._entries: dict[str, T] = {}
        self._broken: dict[str, str] = {}
        self._discovered = group is None

    # ---------------------------------------------------------------- registration

    def register(self, name: str, entry: Any) -> T:
        """Register ``entry`` under ``name`` and return it.

        Raises:
            The registry's error: On a bad or taken name, or an entry ``admit`` refuses.
        """
        if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
            msg = f'{self.kind} {name!r}: name must match {NAME_PATTERN.pattern}'
            raise self._error(msg)
        if name in self._entries:
            msg = f'{self.kind} {name}: a {self.kind} of that name is already registered'
            raise self._error(msg)
        admitted: T = entry if self._admit is None else self._admit(name, entry)
        self._entries[name] = admitted
        return admitted

    def discover(self) -> None:
        """Load the kind's plug-ins from its entry-point group (once; later calls do nothing).

        A plug-in that fails to load or is refused is left out with one warning line.
        """
        if self._discovered or self.group is None:
            return
        self._discovered = True
        for point in _entry_points(self.group):
            try:
                self.register(point.name, point.load())
            except Exception as err:  # noqa: BLE001  (a broken plug-in must not stop the rest)
                reason = f'{type(err).__name__}: {err}'.splitlines()[0]
                self._broken[point.name] = reason
                _LOG.warning('%s plug-in %s = %s (group %s) not loaded: %s',
                             self.kind, point.name, point.value, self.group, reason)

    def loaded(self) -> Mapping[str, T]:
        """The entries registered so far.

        Without loading the plug-ins (for an ``admit`` that compares a new entry with the others:
        it runs while the built-ins register).
        """
        return dict(self._entries)

    @property
    def broken(self) -> Mapping[str, str]:
        """The plug-ins that did not load, by entry-point name, with the reason."""
        self.discover()
        return dict(self._broken)

    def copy(self) -> Registry[T]:
        """An independent copy (for tests that register entries of their own)."""
        twin: Registry[T] = Registry(self.kind, self.group, admit=self._admit,
                                     error=self._error, unknown=self._unknown)
        self.discover()
        twin._discovered = True
        twin._entries = dict(self._entries)
        twin._broken = dict(self._broken)
        return twin

    @contextmanager
    def added(self, name: str, entry: Any) -> Iterator[T]:
        """Register ``entry`` for the duration of a ``with`` block (for tests).

        Raises:
            The registry's error: As :meth:`register`.
        """
        admitted = self.register(name, entry)
        try:
            yield admitted
        finally:
            del self._entries[name]

    # ---------------------------------------------------------------- lookup

    def lookup(self, name: str) -> T:
        """The entry ``name``.

        Raises:
            The registry's error: ``unknown <kind> '<name>' (known: a, b, c)``, one line; it
                names a plug-in of that name that did not load, and why.
        """
        self.discover()
        try:
            return self._entries[name]
        except (KeyError, TypeError):
            msg = self.unknown_message(name)
            raise self._error(msg) from None

    def unknown_message(self, name: object) -> str:
        """The one-line message for an unknown ``name``."""
        message = self._unknown.format(kind=self.kind, name=name, known=', '.join(self.names()))
        if isinstance(name, str) and name in self._broken:
            message += f'; its plug-in did not load: {self._broken[name]}'
        return message

    def names(self) -> tuple[str, ...]:
        """The registered names, sorted."""
        self.discover()
        return tuple(sorted(self._entries))

    def __getitem__(self, name: str) -> T:
        """The entry ``name`` (``KeyError`` if unknown; :meth:`lookup` explains)."""
        self.discover()
        return self._entries[name]

    def __iter__(self) -> Iterator[str]:
        """The names in registration order (the built-ins first, then the plug-ins)."""
        self.discover()
        return iter(tuple(self._entries))

    def __len__(self) -> int:
        """How many entries are registered."""
        self.discover()
        return len(self._entries)

    def __contains__(self, name: object) -> bool:
        """Whether ``name`` is registered."""
        self.discover()
        return name in self._entries

    def __repr__(self) -> str:
        """``Registry('driver', 'pd.drivers', [names])``."""
        return f'Registry({self.kind!r}, {self.group!r}, {list(self._entries)})'
