"""Tracking controllers and delay compensators: the interface and the registry.

A compensator runs at the controller rate. Each sample ``k`` it gets the newest desired
displacement ``x_d[k]`` and the newest measured displacement ``x_m[k]`` and returns the command
``u[k]`` sent to the transfer system::

    u = compensator.command(target, measured)

Adding one is one module with its class and one :class:`CompensatorSpec` registered with
:func:`register_compensator` (or, from a separate package, named by an entry point of the
``pd.compensators`` group); its parameters (:class:`~pd_common.registry.Parameter`) are named in
the test file (``compensator: {name: ..., <parameter>: value}``) and on
``./pd rths_benchmark``.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from ...errors import RthsError
from ...registry import GROUPS, Parameter, ParameterError, Registry, resolve_parameters


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


#: One parameter of a compensator: the shared :class:`~pd_common.registry.Parameter` (name,
#: default whose type is the parameter's type, one-line description).
CompensatorParameter = Parameter


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
        declared = {parameter.name for parameter in self.parameters}
        unknown = [name for name in values if name not in declared]
        if unknown:
            known = ', '.join(parameter.name for parameter in self.parameters) or 'none'
            msg = (f'compensator {self.name}: unknown parameter {unknown[0]!r} '
                   f'(its parameters: {known})')
            raise RthsError(msg)
        try:
            return resolve_parameters(self.parameters, values)
        except ParameterError as err:
            msg = f'compensator {self.name}: parameter {err.parameter} {err.reason}'
            raise RthsError(msg) from None


def _admit(name: str, spec: Any) -> CompensatorSpec:
    """A :class:`CompensatorSpec` named ``name``.

    Raises:
        RthsError: Anything else.
    """
    if not isinstance(spec, CompensatorSpec) or spec.name != name:
        msg = f'compensator {name}: expected a CompensatorSpec named {name!r}, got {spec!r}'
        raise RthsError(msg)
    return spec


#: The compensators by name: the built-ins and the installed ``pd.compensators`` plug-ins.
COMPENSATORS: Registry[CompensatorSpec] = Registry(
    'compensator', GROUPS['compensator'], admit=_admit, error=RthsError,
    unknown='unknown compensator {name!r} (registered: {known})')


def register_compensator(spec: CompensatorSpec) -> CompensatorSpec:
    """Register ``spec`` under its name and return it.

    Raises:
        RthsError: On a bad or taken name.
    """
    return COMPENSATORS.register(spec.name, spec)


def compensator_names() -> tuple[str, ...]:
    """The registered names, sorted."""
    return COMPENSATORS.names()


def compensator_spec(name: str) -> CompensatorSpec:
    """The registration of ``name``.

    Raises:
        RthsError: If no compensator has that name.
    """
    return COMPENSATORS.lookup(name)


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
    """No compensation: the command is the desired displacement, ``u = x_d``.

    ``u = x_d``: the command is the desired displacement (of the next sample where the
    caller knows it: with an ideal plant the actuator is then exactly on its path).
    """

    uses_preview = True

    def reset(self) -> None:
        """Nothing to forget."""

    def command(self, target: float, measured: float) -> float:
        """The target itself."""
        return target


NONE = register_compensator(CompensatorSpec(
    name='none', factory=lambda dt, _parameters: NoCompensation(dt),
    description='no compensation: u = x_d'))
