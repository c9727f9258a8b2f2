"""The typed schema of the actuator bridge's parameters.

Its ROS parameter file (``<node>: {ros__parameters: {...}}``) and a site's
``sites.<site>.bridge`` of a test file.

Mirrors the parameters the bridge node declares (``pd_actuator_bridge.node``: the safety
limits of :data:`pd_common.experimental.LIMIT_PARAMETERS` and their defaults) and those of its
registered drivers (each driver's ``DriverSpec``); the bridge checks the values again when it
configures (the limits together, the driver's own).
"""

from __future__ import annotations

import functools
from typing import Annotated, Any, Literal, Self

from pydantic import ConfigDict, Field, RootModel, model_validator

from ..registry import GROUPS, Registry
from .schema_base import ConfigModel, NonNegative, Positive, refuse_at

__all__ = ['BridgeNodeSection', 'BridgeParameterFile', 'BridgeParameters',
           'SiteBridgeParameters', 'plugin_driver_parameters']


@functools.cache
def plugin_driver_parameters() -> dict[str, Any]:
    """The parameters the installed driver plug-ins declare: name to default.

    The ``pd.drivers`` entry points (a lab's own driver package); the built-in drivers'
    parameters are this schema's own fields. The bridge node declares both, so a parameter
    file may set both.
    """
    drivers: Registry[Any] = Registry('driver', GROUPS['driver'])
    drivers.discover()
    declared: dict[str, Any] = {}
    for spec in drivers.loaded().values():
        for parameter in getattr(spec, 'parameters', ()):
            declared.setdefault(str(parameter.name), parameter.default)
    return declared


def _kind(value: Any) -> str:
    if isinstance(value, bool):
        return 'a boolean'
    if isinstance(value, int | float):
        return 'a number'
    if isinstance(value, str):
        return 'a string'
    return 'a list' if isinstance(value, list | tuple) else type(value).__name__


class SiteBridgeParameters(ConfigModel):
    """The bridge's parameters that a test file may set for one site.

    Each key of ``sites.<site>.bridge`` is passed to that site's bridge as a ROS parameter. A
    key that no field names is refused unless an installed driver plug-in declares it (then of
    its default's kind); the published JSON Schema lists the built-in keys only.
    """

    model_config = ConfigDict(extra='allow', json_schema_extra={'additionalProperties': False})

    driver: Annotated[str, Field(pattern=r'^[a-z][a-z0-9_]*$')] | None = None
    """The actuator driver, a registered one (``sim_servo``, ``emulator``, ``generic_tcp``,
    ``opensees_adapter``, ``daqmx``, ``transfer_system``, ...)."""
    max_displacement: Positive = 0.25
    """Absolute displacement limit of every DOF [m]."""
    max_increment: Positive = 0.02
    """Largest displacement change in one step [m]."""
    max_force: Positive = 1.0e5
    """Absolute measured force limit [N]."""
    max_velocity: NonNegative = 0.0
    """Velocity limit [m/s] (0: off; needs step_duration)."""
    step_duration: NonNegative = 0.0
    """Time the actuator takes for one step [s] (0: off)."""
    tracking_tolerance: NonNegative = 0.0
    """|measured − commanded| limit [m] (0: off)."""
    watchdog_timeout: NonNegative = 0.0
    """Hold after this long without a command while active [s] (0: off)."""
    max_force_increment: NonNegative = 0.0
    """Largest change of a force-controlled actuator's force in one sub-step [N]: a force
    change is ramped in sub-steps of at most this (0: no ramp)."""
    on_limit: Literal['hold', 'saturate'] = 'hold'
    """What a command beyond a limit does: ``hold`` the bridge, or ``saturate`` it (quasi-static
    and manual moves only)."""
    autostart: bool | None = None
    """Configure and activate at start (simulated set-ups)."""
    driver_timeout: Positive | None = None
    """sim_servo, generic_tcp, opensees_adapter: how long a move may take before the bridge
    holds [s]."""
    specimen_namespace: str | None = None
    """sim_servo: the namespace of the specimen node."""
    tcp_host: str | None = None
    """generic_tcp, opensees_adapter: the controller's (adapter element's) host."""
    tcp_port: Annotated[int, Field(ge=0, le=65535)] | None = None
    """generic_tcp, opensees_adapter: the controller's (adapter element's) port."""
    driver_config: str | None = None
    """daqmx, emulator: the YAML file with the driver's settings."""
    clock: Literal['simulated', 'realtime'] | None = None
    """transfer_system: the clock of the continuous loop."""


    @model_validator(mode='after')
    def _plugin_parameters(self) -> Self:
        """Keys beyond the fields: parameters an installed driver plug-in declares."""
        extra = self.model_extra or {}
        if extra:
            declared = plugin_driver_parameters()
            for key, value in extra.items():
                if key not in declared:
                    refuse_at(key, 'unknown key')
                default = declared[key]
                if default is not None and _kind(value) != _kind(default):
                    refuse_at(key, f'must be {_kind(default)} (a driver plug-in\'s parameter), '
                                   f'got {value!r}')
        return self


class BridgeParameters(SiteBridgeParameters):
    """Every parameter of the bridge node (``ros__parameters`` of its parameter file)."""

    dof_names: Annotated[list[Annotated[str, Field(min_length=1)]],
                        Field(min_length=1)] | None = None
    """One name per actuator DOF (run_test sets them from the test)."""
    record_file: str | None = None
    """The bridge's durable record (default:
    ``$XDG_STATE_HOME/pd/bridges/domain<id>/<node>.jsonl``)."""
    test_file: str | None = None
    """emulator, transfer_system: the test file whose specimen (transfer system) is driven."""
    site: str | None = None
    """transfer_system: the site of ``test_file`` whose transfer system is driven."""
    realtime_report: str | None = None
    """transfer_system: where the real-time report is written."""
    key_file: str | None = None
    """The rig's key file (signed controls)."""
    authentication: bool | None = None
    """Whether controls must be signed."""
    use_sim_time: bool | None = None
    """ROS: use the /clock topic."""


class BridgeNodeSection(ConfigModel):
    """A node's section of a ROS parameter file."""

    ros__parameters: BridgeParameters
    """The node's parameters."""


class BridgeParameterFile(RootModel[dict[str, BridgeNodeSection]]):
    """A ROS parameter file of the actuator bridge.

    Node name (``/**`` for any) to its ``ros__parameters``.
    """

    def parameters(self) -> dict[str, Any]:
        """The parameters the file sets (its first node section's; the others' defaults apart).

        As the bridge's rehearsals read it (:func:`pd_common.experimental.bridge_parameters`):
        a parameter the file does not set is the node's default.
        """
        for section in self.root.values():
            return section.ros__parameters.model_dump(exclude_unset=True)
        return {}
