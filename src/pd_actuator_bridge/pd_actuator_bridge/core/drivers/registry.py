"""The driver registry: the name of every actuator driver and how to build it.

Adding a controller family is one module plus one registration. Next to its driver class the
module declares a :class:`DriverSpec` (the name, a factory, the parameters the driver needs with
their defaults and descriptions, a one-line description) and registers it::

    GENERIC_TCP = DriverSpec(
        name='generic_tcp',
        factory=make_generic_tcp_driver,
        parameters=(DriverParameter('tcp_host', '127.0.0.1', 'controller server host'), ...),
        description='client of an OpenFresco GenericTCP controller-side server',
    )
    register_driver(GENERIC_TCP)

Importing :mod:`pd_actuator_bridge.core.drivers` registers the built-in pure drivers
(``emulator``, ``generic_tcp``, ``opensees_adapter``, ``daqmx``, ``transfer_system``); the node
shell registers ``sim_servo`` (:mod:`pd_actuator_bridge.sim_servo`, which needs ``rclpy``). A
separate package adds a driver without editing ours through the ``pd.drivers`` entry-point
group (the entry point's name is the driver's name, its value the :class:`DriverSpec`)::

    [project.entry-points."pd.drivers"]
    my_controller = "my_package.driver:MY_CONTROLLER"

The node declares every registered driver's parameters as ROS parameters and builds the
selected driver with :func:`make_driver`. A parameter several drivers declare (``tcp_host``,
``driver_config``, ...) is one ROS parameter, so every declaration of it must have the same
default. The registry is a :class:`pd_common.registry.Registry` (:data:`DRIVERS`) and a
driver's parameters are :class:`pd_common.registry.Parameter` values (``DriverParameter``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

from pd_common.auth import Key
from pd_common.config.bridge_file import read_driver_config
from pd_common.config.schema_base import SchemaError
from pd_common.registry import (
    GROUPS,
    NAME_PATTERN,
    Parameter,
    ParameterError,
    Registry,
    resolve_parameters,
)

from ..errors import BridgeConfigError
from .base import ActuatorDriver

if TYPE_CHECKING:
    from pd_common.config.schema_driver import DriverConfigFile

FaultCallback = Callable[[str], None]
"""``cb(message)``: an asynchronous driver reports a fault found outside :meth:`command`."""

TrajectoryCallback = Callable[[Any, Any], None]
"""``cb(step, execution)``: a driver reports the sub-step trajectory of a step (the emulator's
:class:`~.ramp_hold.StepExecution`)."""

#: One parameter a driver needs, declared by the node as a ROS parameter: the shared
#: :class:`~pd_common.registry.Parameter` (name, default, one-line description); its default
#: must not be ``None`` (its type is the ROS parameter's type).
DriverParameter = Parameter


@dataclass(frozen=True)
class DriverContext:
    """Everything a driver factory gets.

    Attributes:
        n_dof: Number of actuated DOF (one per name of the node's ``dof_names``).
        parameters: Values of the driver's declared parameters, by name (:func:`make_driver`
            completes the missing ones with their defaults).
        on_trajectory: Receives ``(step, execution)`` from a driver that records sub-step
            trajectories (the emulator); ``None``: not recorded.
        on_fault: Receives the message of a fault an asynchronous driver finds outside
            :meth:`~.base.ActuatorDriver.command` (``sim_servo``: a specimen fault).
        host: Whatever a shell-side driver needs from its host, e.g. the ``rclpy`` node that
            ``sim_servo`` publishes from; ``None`` for the pure drivers.
        key: The bridge's key, for a driver that talks to an authenticated peer
            (``sim_servo``); ``None``: authentication off.
    """

    n_dof: int
    parameters: Mapping[str, Any] = field(default_factory=dict)
    on_trajectory: TrajectoryCallback | None = None
    on_fault: FaultCallback | None = None
    host: Any = None
    key: Key | None = None


DriverFactory = Callable[[DriverContext], ActuatorDriver]
"""``factory(context)``: builds the driver (not opened yet)."""


@dataclass(frozen=True)
class DriverSpec:
    """The registration of one driver.

    Attributes:
        name: The value of the node's ``driver`` parameter that selects it.
        factory: Builds the driver from a :class:`DriverContext`.
        parameters: The parameters the driver needs, with defaults and descriptions.
        description: One line saying what answers (for listings and documentation).

    Raises:
        BridgeConfigError: On a bad field or a parameter declared twice.
    """

    name: str
    factory: DriverFactory
    parameters: tuple[DriverParameter, ...] = ()
    description: str = ''

    def __post_init__(self) -> None:
        """Check the fields."""
        if not isinstance(self.name, str) or not NAME_PATTERN.fullmatch(self.name):
            msg = f'driver {self.name!r}: name must match {NAME_PATTERN.pattern}'
            raise BridgeConfigError(msg)
        if not callable(self.factory):
            msg = f'driver {self.name}: factory must be callable'
            raise BridgeConfigError(msg)
        if not isinstance(self.parameters, tuple) or not all(
                isinstance(parameter, DriverParameter) for parameter in self.parameters):
            msg = f'driver {self.name}: parameters must be a tuple of DriverParameter'
            raise BridgeConfigError(msg)
        for parameter in self.parameters:
            if parameter.default is None:
                msg = (f'driver {self.name}: parameter {parameter.name} needs a default (its '
                       'type is the ROS parameter\'s type)')
                raise BridgeConfigError(msg)
        names = [parameter.name for parameter in self.parameters]
        for name in names:
            if names.count(name) > 1:
                msg = f'driver {self.name}: parameter {name} is declared twice'
                raise BridgeConfigError(msg)
        if not isinstance(self.description, str):
            msg = f'driver {self.name}: description must be a string'
            raise BridgeConfigError(msg)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the declared parameters, in declaration order."""
        return tuple(parameter.name for parameter in self.parameters)

    def parameter(self, name: str) -> DriverParameter | None:
        """The declared parameter ``name``, or ``None``."""
        for parameter in self.parameters:
            if parameter.name == name:
                return parameter
        return None

    def resolve(self, values: Mapping[str, Any]) -> dict[str, Any]:
        """The declared parameters' defaults, updated with ``values``.

        Raises:
            BridgeConfigError: If ``values`` has a key the driver does not declare.
        """
        try:
            return resolve_parameters(self.parameters, values, check=False)
        except ParameterError as err:
            expected = ', '.join(self.parameter_names) or 'none'
            msg = (f'driver {self.name}: unknown parameter {err.parameter!r} '
                   f'(its parameters: {expected})')
            raise BridgeConfigError(msg) from None


def _admit(name: str, spec: Any) -> DriverSpec:
    """A :class:`DriverSpec` named ``name`` whose shared parameters keep their defaults.

    Raises:
        BridgeConfigError: Not a :class:`DriverSpec`, another name, or a parameter that another
            driver declares with a different default (both are one ROS parameter).
    """
    if not isinstance(spec, DriverSpec):
        msg = f'register_driver: expected a DriverSpec, got {type(spec).__name__}'
        raise BridgeConfigError(msg)
    if spec.name != name:
        msg = f'driver {name}: its DriverSpec is named {spec.name!r}'
        raise BridgeConfigError(msg)
    for parameter in spec.parameters:
        for other in DRIVERS.loaded().values():
            theirs = other.parameter(parameter.name)
            if theirs is not None and (type(theirs.default), theirs.default) != (
                    type(parameter.default), parameter.default):
                msg = (f'driver {spec.name}: parameter {parameter.name}: default '
                       f'{parameter.default!r} differs from {theirs.default!r} of driver '
                       f'{other.name}')
                raise BridgeConfigError(msg)
    return spec


#: The drivers by name: the built-ins and the installed ``pd.drivers`` plug-ins.
DRIVERS: Registry[DriverSpec] = Registry(
    'driver', GROUPS['driver'], admit=_admit, error=BridgeConfigError,
    unknown='parameter driver: unknown driver {name!r} (available: {known})')


def register_driver(spec: DriverSpec) -> DriverSpec:
    """Register ``spec`` under its name and return it.

    Raises:
        BridgeConfigError: If ``spec`` is not a :class:`DriverSpec`, its name is taken, or it
            declares a parameter that another driver declares with a different default (both
            are one ROS parameter).
    """
    if not isinstance(spec, DriverSpec):
        msg = f'register_driver: expected a DriverSpec, got {type(spec).__name__}'
        raise BridgeConfigError(msg)
    return DRIVERS.register(spec.name, spec)


def driver_names() -> tuple[str, ...]:
    """Names of the registered drivers, sorted."""
    return DRIVERS.names()


def driver_spec(name: str) -> DriverSpec:
    """The registration of driver ``name``.

    Raises:
        BridgeConfigError: If no driver of that name is registered (the message lists them).
    """
    return DRIVERS.lookup(name)


def driver_parameters() -> tuple[tuple[DriverParameter, tuple[str, ...]], ...]:
    """Every distinct driver parameter, sorted by name, with the drivers that declare it.

    The parameter is the declaration of the first of those drivers (in name order); all of
    them have its default (:func:`register_driver` checks that).
    """
    users: dict[str, list[str]] = {}
    first: dict[str, DriverParameter] = {}
    for name in driver_names():
        for parameter in DRIVERS[name].parameters:
            first.setdefault(parameter.name, parameter)
            users.setdefault(parameter.name, []).append(name)
    return tuple((first[key], tuple(users[key])) for key in sorted(first))


def make_driver(name: str, context: DriverContext) -> ActuatorDriver:
    """Build driver ``name`` (not opened yet).

    The factory gets ``context`` with every declared parameter: the given values, the defaults
    for the others.

    Raises:
        BridgeConfigError: On an unknown driver, an unknown parameter, a factory that returns
            no :class:`~.base.ActuatorDriver`, or whatever the factory refuses.
    """
    spec = driver_spec(name)
    parameters = MappingProxyType(spec.resolve(context.parameters))
    driver = spec.factory(replace(context, parameters=parameters))
    if not isinstance(driver, ActuatorDriver):
        msg = f'driver {name}: the factory returned {type(driver).__name__}, not an ActuatorDriver'
        raise BridgeConfigError(msg)
    return driver


def read_driver_settings(path: str, parameter: str) -> DriverConfigFile:
    """The driver's settings file ``path`` (the value of parameter ``parameter``), typed.

    For factories whose settings are in a file named by a parameter (``driver_config``): the
    file is read once (:func:`pd_common.config.read_driver_config`) and the factory builds
    from its typed sections (``daqmx``, ``emulator``, ``ramp_hold``, ``errors``).

    Raises:
        BridgeConfigError: If ``path`` is empty, cannot be read or parsed, or is refused by the
            schema (one line naming the file and the dotted path).
    """
    if not path:
        msg = f'parameter {parameter}: a YAML file is required for this driver'
        raise BridgeConfigError(msg)
    try:
        return read_driver_config(path)
    except SchemaError as err:
        raise BridgeConfigError(str(err)) from None
