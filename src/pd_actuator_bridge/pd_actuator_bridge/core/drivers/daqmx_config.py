"""Configuration of the ``daqmx`` driver: wiring and linear calibrations, read from YAML.

:class:`DaqmxChannelConfig` is one actuated DOF (its command output, its displacement and force
inputs, their calibrations and voltage ranges); :class:`DaqmxConfig` is the driver-level
configuration (the channels, sampling, terminal configuration, settle time, timeout), built from
the ``daqmx:`` section of a driver's settings file (``config/daqmx_example.yaml``), read once
and typed by :func:`pd_common.config.read_driver_config`. The calibrations are linear::

    command:       V = (x - command_offset) / command_scale          (command_scale in m/V)
    displacement:  x = displacement_scale * V + displacement_offset  (m/V, m)
    force:         f = force_scale * V + force_offset                (N/V, N)

Every value is checked by the shared schema
(:class:`pd_common.config.schema_driver.DaqmxSection`), on construction too; errors are one
line naming the file and the dotted path (``daqmx.yaml: daqmx.channels.0.command_scale: must
not be 0, got 0.0``). The driver is :class:`~.daqmx.DaqmxDriver`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path
from typing import TYPE_CHECKING, Any

from pd_common.config.bridge_file import read_driver_config
from pd_common.config.schema_base import SchemaError

from ..error_models import validated
from ..errors import BridgeConfigError

if TYPE_CHECKING:
    from pd_common.config.schema_driver import DaqmxChannelSection, DaqmxSection

TERMINAL_CONFIGURATIONS = ('default', 'rse', 'nrse', 'diff', 'pseudo_diff')
"""Accepted ``terminal_configuration`` values (analog inputs; the schema's)."""

MAX_ABS_VOLTAGE = 10.0
"""Largest |voltage| accepted in a channel range, V (servo-controller inputs are +-10 V)."""


@dataclass(frozen=True)
class DaqmxChannelConfig:
    """Wiring and calibration of one actuated DOF.

    Attributes:
        command_channel: Analog output carrying the displacement command, e.g. ``'Dev1/ao0'``.
        command_scale: Commanded displacement per volt, m/V (non-zero; negative inverts).
        displacement_channel: Analog input of the conditioned displacement, e.g. ``'Dev1/ai0'``.
        displacement_scale: Measured displacement per volt, m/V (non-zero).
        force_channel: Analog input of the conditioned load-cell signal, e.g. ``'Dev1/ai1'``.
        force_scale: Measured force per volt, N/V (non-zero).
        name: Optional DOF name used in messages.
        command_offset: Commanded displacement at 0 V, m.
        command_min_voltage: Lowest voltage the driver will ever write, V.
        command_max_voltage: Highest voltage the driver will ever write, V.
        displacement_offset: Measured displacement at 0 V, m.
        displacement_min_voltage: Lower end of the displacement input range, V.
        displacement_max_voltage: Upper end of the displacement input range, V.
        force_offset: Measured force at 0 V, N (e.g. to null a load-cell offset).
        force_min_voltage: Lower end of the force input range, V.
        force_max_voltage: Upper end of the force input range, V.

    Every voltage range must lie within +-:data:`MAX_ABS_VOLTAGE` with min < max.

    Raises:
        BridgeConfigError: On an invalid value (one line naming the field).
    """

    command_channel: str
    command_scale: float
    displacement_channel: str
    displacement_scale: float
    force_channel: str
    force_scale: float
    name: str = ''
    command_offset: float = 0.0
    command_min_voltage: float = -10.0
    command_max_voltage: float = 10.0
    displacement_offset: float = 0.0
    displacement_min_voltage: float = -10.0
    displacement_max_voltage: float = 10.0
    force_offset: float = 0.0
    force_min_voltage: float = -10.0
    force_max_voltage: float = 10.0

    def __post_init__(self) -> None:
        """Validate (the schema's ``DaqmxChannelSection``) and normalise the numbers."""
        from pd_common.config.schema_driver import (  # noqa: PLC0415 (first use)
            DaqmxChannelSection,
        )

        values = {field.name: getattr(self, field.name) for field in fields(self)}
        for name, value in validated(DaqmxChannelSection, values, 'DaqmxChannelConfig'):
            object.__setattr__(self, name, value)

    @classmethod
    def from_mapping(
        cls, mapping: Mapping[str, Any], source: str = 'DaqmxChannelConfig', path: str = ''
    ) -> DaqmxChannelConfig:
        """Build one DOF's configuration from a mapping (e.g. one item of a YAML list).

        Args:
            mapping: Keys as the attribute names; the six channel/scale keys are required.
            source: File or namespace name used in error messages.
            path: The mapping's dotted path in its file, in error messages.

        Returns:
            The validated configuration.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown or missing key, or a bad value.
        """
        from pd_common.config.schema_driver import (  # noqa: PLC0415 (first use)
            DaqmxChannelSection,
        )

        return cls.from_section(validated(DaqmxChannelSection, mapping, source, path))

    @classmethod
    def from_section(cls, section: DaqmxChannelSection) -> DaqmxChannelConfig:
        """The configuration of a typed channel (an item of ``daqmx.channels``)."""
        return cls(**dict(section))

    def label(self, dof: int) -> str:
        """``'DOF <dof> (<name>)'``, or ``'DOF <dof>'`` when unnamed."""
        return f'DOF {dof} ({self.name})' if self.name else f'DOF {dof}'


@dataclass(frozen=True)
class DaqmxConfig:
    """Configuration of the ``daqmx`` driver.

    Attributes:
        channels: One :class:`DaqmxChannelConfig` per DOF, in DOF order.
        sample_rate: Analog input sample clock, Hz (per channel).
        samples_per_read: Samples per input channel acquired and averaged per measurement.
        terminal_configuration: Analog input terminal configuration, one of
            :data:`TERMINAL_CONFIGURATIONS` (use ``'diff'`` for the conditioned outputs of a
            servo-controller unless its outputs are ground-referenced to the DAQ).
        settle_time: Wait between writing a command and starting the acquisition, s.
        timeout: DAQmx write and read timeout, s; must exceed the acquisition time
            ``samples_per_read / sample_rate``.

    Raises:
        BridgeConfigError: On an invalid value (one line naming the field).
    """

    channels: tuple[DaqmxChannelConfig, ...]
    sample_rate: float = 1000.0
    samples_per_read: int = 100
    terminal_configuration: str = 'diff'
    settle_time: float = 0.5
    timeout: float = 10.0

    def __post_init__(self) -> None:
        """Validate (the schema's ``DaqmxSection``) and normalise the values."""
        from pd_common.config.schema_driver import DaqmxSection  # noqa: PLC0415 (first use)

        values = {field.name: getattr(self, field.name) for field in fields(self)}
        channels = values['channels']
        if isinstance(channels, (list, tuple)):  # (the schema checks the channels' values)
            values['channels'] = [_channel_values(channel) for channel in channels]
        section = validated(DaqmxSection, values, 'DaqmxConfig')
        for name, value in section:
            if name != 'channels':
                object.__setattr__(self, name, value)
        object.__setattr__(self, 'channels', tuple(
            channel if isinstance(channel, DaqmxChannelConfig)
            else DaqmxChannelConfig.from_section(typed)
            for channel, typed in zip(channels, section.channels, strict=True)))

    @property
    def n_dof(self) -> int:
        """Number of DOF (one per channel configuration)."""
        return len(self.channels)

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any], source: str = 'DaqmxConfig',
                     path: str = '') -> DaqmxConfig:
        """Build the configuration from a mapping such as the ``daqmx:`` section of a YAML file.

        Args:
            mapping: Keys ``channels`` (a non-empty list of channel mappings, see
                :meth:`DaqmxChannelConfig.from_mapping`) and optionally ``sample_rate``,
                ``samples_per_read``, ``terminal_configuration``, ``settle_time``, ``timeout``.
            source: File or namespace name used in error messages.
            path: The mapping's dotted path in its file (``'daqmx'``), in error messages.

        Returns:
            The validated configuration.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown or missing key, or a bad value, e.g.
                ``daqmx.yaml: daqmx.channels.0.command_scale: must not be 0, got 0.0``.
        """
        from pd_common.config.schema_driver import DaqmxSection  # noqa: PLC0415 (first use)

        return cls.from_section(validated(DaqmxSection, mapping, source, path))

    @classmethod
    def from_section(cls, section: DaqmxSection) -> DaqmxConfig:
        """The configuration of a typed ``daqmx`` section (a driver's settings file)."""
        channels = tuple(DaqmxChannelConfig.from_section(channel) for channel in section.channels)
        values = {name: value for name, value in section if name != 'channels'}
        return cls(channels=channels, **values)

    @classmethod
    def from_yaml(cls, path: str | Path) -> DaqmxConfig:
        """Read the configuration from the ``daqmx`` section of a driver's settings file.

        Args:
            path: The YAML file (see ``config/daqmx_example.yaml``), read once and typed by
                :func:`pd_common.config.read_driver_config`.

        Returns:
            The validated configuration.

        Raises:
            BridgeConfigError: If the file cannot be read or parsed, the section is missing, or
                a value is invalid (one line naming the file and the dotted path).
        """
        path = Path(path)
        try:
            settings = read_driver_config(path)
        except SchemaError as err:
            raise BridgeConfigError(str(err)) from None
        if settings.daqmx is None:
            msg = f'{path.name}: daqmx: is required (the daqmx driver\'s section)'
            raise BridgeConfigError(msg)
        return cls.from_section(settings.daqmx)


def _channel_values(channel: Any) -> Any:
    """A channel's values for the schema (a :class:`DaqmxChannelConfig`'s fields, or as given)."""
    if isinstance(channel, DaqmxChannelConfig):
        return {field.name: getattr(channel, field.name) for field in fields(channel)}
    return channel
