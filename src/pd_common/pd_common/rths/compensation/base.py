"""Tracking controllers and delay compensators: the interface and the registry.

A compensator runs at the controller rate. Each sample ``k`` it gets the newest desired
displacement ``x_d[k]`` and the newest measured displacement ``x_m[k]`` and returns the command
``u[k]`` sent to the transfer system::

    u = compensator.command(target, measured)

Adding one is one module with its class and one :class:`CompensatorSpec` registered with
:func:`register_compensator`; its parameters are named in the test file (``compensator:
{name: ..., <parameter>: value}``) and on ``./pd rths_benchmark``.
"""

from __future__ import annotations

import abc
import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ...errors import RthsError

_NAME = re.compile(r'[a-z][a-z0-9_]*')
_REGISTRY: dict[str, CompensatorSpec] = {}


class Compensator(abc.ABC):
    """One tracking controller / delay compensator, stepped at the controller rate.

    The timing is the benchmark's: ``command(x_d[k], x_m[k])`` at sample ``k`` returns
    ``u[k]``, held over ``[t_k, t_{k+1}]`` (it acts on the measurement of sample ``k + 1``),
    and a compensator's delay compensation is designed for that. A caller that knows the
    target one sample ahead (the continuous actuator does: the step's path is known) gives
    ``x_d[k+1]`` instead only to a compensator with :attr:`uses_preview` set, which is then
    exact for an ideal plant (``none``).
    """

    #: Whether :meth:`command` takes the target of the next sample, ``x_d[k+1]``.
    uses_preview: bool = False

    def __init__(self, dt: float) -> None:
        """Create it for the controller sample period ``dt``, s."""
        dt = float(dt)
        if not math.isfinite(dt) or dt <= 0.0:
            msg = f'compensator dt must be a positive finite number, got {dt!r}'
            raise RthsError(msg)
        self.dt = dt

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget the past (the start of a run)."""

    @abc.abstractmethod
    def command(self, target: float, measured: float) -> float:
        """The command ``u[k]`` (m) for desired ``x_d[k]`` and measured ``x_m[k]`` (m)."""


@dataclass(frozen=True)
class CompensatorParameter:
    """One parameter of a compensator: name, default (its type is the parameter's type),
    one-line description."""

    name: str
    default: float | int | bool | str
    description: str


CompensatorFactory = Callable[[float, Mapping[str, Any]], Compensator]
"""``factory(dt, parameters)``: the compensator, with every declared parameter resolved."""


@dataclass(frozen=True)
class CompensatorSpec:
    """The registration of one compensator: name, factory, parameters, one-line description."""

    name: str
    factory: CompensatorFactory
    parameters: tuple[CompensatorParameter, ...] = ()
    description: str = ''

    def resolve(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """The defaults updated with ``values``, each checked against its default's type.

        Raises:
            RthsError: On an unknown parameter or a value of the wrong type.
        """
        resolved: dict[str, Any] = {p.name: p.default for p in self.parameters}
        for name, value in values.items():
            if name not in resolved:
                known = ', '.join(resolved) or 'none'
                msg = (f'compensator {self.name}: unknown parameter {name!r} '
                       f'(its parameters: {known})')
                raise RthsError(msg)
            default = resolved[name]
            if isinstance(default, bool):
                ok = isinstance(value, bool)
            elif isinstance(default, int):
                ok = isinstance(value, int) and not isinstance(value, bool)
            elif isinstance(default, float):
                ok = (isinstance(value, int | float) and not isinstance(value, bool)
                      and math.isfinite(float(value)))
                value = float(value) if ok else value
            else:
                ok = isinstance(value, str)
            if not ok:
                msg = (f'compensator {self.name}: parameter {name} must be '
                       f'{type(default).__name__}, got {value!r}')
                raise RthsError(msg)
            resolved[name] = value
        return resolved


def register_compensator(spec: CompensatorSpec) -> CompensatorSpec:
    """Register ``spec`` under its name and return it.

    Raises:
        RthsError: On a bad or taken name.
    """
    if not _NAME.fullmatch(spec.name):
        msg = f'compensator {spec.name!r}: name must match {_NAME.pattern}'
        raise RthsError(msg)
    if spec.name in _REGISTRY:
        msg = f'compensator {spec.name}: a compensator of that name is already registered'
        raise RthsError(msg)
    _REGISTRY[spec.name] = spec
    return spec


def compensator_names() -> tuple[str, ...]:
    """The registered names, sorted."""
    return tuple(sorted(_REGISTRY))


def compensator_spec(name: str) -> CompensatorSpec:
    """The registration of ``name``.

    Raises:
        RthsError: If no compensator has that name.
    """
    try:
        return _REGISTRY[name]
    except KeyError:
        msg = (f'unknown compensator {name!r} (registered: '
               f'{", ".join(compensator_names())})')
        raise RthsError(msg) from None


def make_compensator(name: str, dt: float,
                     parameters: Mapping[str, Any] | None = None) -> Compensator:
    """Build the compensator ``name`` for sample period ``dt`` with ``parameters``.

    Raises:
        RthsError: Unknown name, unknown or ill-typed parameter, or a value the compensator
            refuses.
    """
    spec = compensator_spec(name)
    return spec.factory(dt, spec.resolve(parameters or {}))


class NoCompensation(Compensator):
    """``u = x_d``: the command is the desired displacement (of the next sample where the
    caller knows it: with an ideal plant the actuator is then exactly on its path)."""

    uses_preview = True

    def reset(self) -> None:
        """Nothing to forget."""

    def command(self, target: float, measured: float) -> float:
        """The target itself."""
        return target


NONE = register_compensator(CompensatorSpec(
    name='none', factory=lambda dt, _parameters: NoCompensation(dt),
    description='no compensation: u = x_d'))
