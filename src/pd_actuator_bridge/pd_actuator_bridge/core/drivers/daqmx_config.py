"""Configuration of the ``daqmx`` driver: wiring and linear calibrations, read from YAML.

:class:`DaqmxChannelConfig` is one actuated DOF (its command output, its displacement and force
inputs, their calibrations and voltage ranges); :class:`DaqmxConfig` is the driver-level
configuration (the channels, sampling, terminal configuration, settle time, timeout), built from
the ``daqmx:`` section of a YAML file (``config/daqmx_example.yaml``). The calibrations are
linear::

    command:       V = (x - command_offset) / command_scale          (command_scale in m/V)
    displacement:  x = displacement_scale * V + displacement_offset  (m/V, m)
    force:         f = force_scale * V + force_offset                (N/V, N)

Every value is validated on construction; errors are one line naming the file and the key. The
driver is :class:`~.daqmx.DaqmxDriver`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import yaml

from pd_common.config import load_yaml

from ..errors import BridgeConfigError

TERMINAL_CONFIGURATIONS = ('default', 'rse', 'nrse', 'diff', 'pseudo_diff')
"""Accepted ``terminal_configuration`` values (analog inputs)."""

MAX_ABS_VOLTAGE = 10.0
"""Largest |voltage| accepted in a channel range, V (servo-controller inputs are +-10 V)."""

_CHANNEL_REQUIRED = (
    'command_channel', 'command_scale',
    'displacement_channel', 'displacement_scale',
    'force_channel', 'force_scale',
)
_CHANNEL_OPTIONAL = (
    'name',
    'command_offset', 'command_min_voltage', 'command_max_voltage',
    'displacement_offset', 'displacement_min_voltage', 'displacement_max_voltage',
    'force_offset', 'force_min_voltage', 'force_max_voltage',
)
_SIGNALS = ('command', 'displacement', 'force')

_CONFIG_REQUIRED = ('channels',)
_CONFIG_OPTIONAL = (
    'sample_rate', 'samples_per_read', 'terminal_configuration', 'settle_time', 'timeout'
)


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
        """Validate and normalise the numbers to ``float``."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        for key, value in _check_channel(values, 'DaqmxChannelConfig', '').items():
            object.__setattr__(self, key, value)

    @classmethod
    def from_mapping(
        cls, mapping: Mapping[str, Any], source: str = 'daqmx channel'
    ) -> DaqmxChannelConfig:
        """Build one DOF's configuration from a mapping (e.g. one item of a YAML list).

        Args:
            mapping: Keys as the attribute names; the six channel/scale keys are required.
            source: File or namespace name used in error messages.

        Returns:
            The validated configuration.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown or missing key, or a bad value.
        """
        return _channel_from_mapping(mapping, source, '')

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
        """Validate and normalise the values."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        for key, value in _check_config(values, 'DaqmxConfig').items():
            object.__setattr__(self, key, value)

    @property
    def n_dof(self) -> int:
        """Number of DOF (one per channel configuration)."""
        return len(self.channels)

    @classmethod
    def from_mapping(cls, mapping: Mapping[str, Any], source: str = 'daqmx') -> DaqmxConfig:
        """Build the configuration from a mapping such as the ``daqmx:`` section of a YAML file.

        Args:
            mapping: Keys ``channels`` (a non-empty list of channel mappings, see
                :meth:`DaqmxChannelConfig.from_mapping`) and optionally ``sample_rate``,
                ``samples_per_read``, ``terminal_configuration``, ``settle_time``, ``timeout``.
            source: File or namespace name used in error messages.

        Returns:
            The validated configuration.

        Raises:
            BridgeConfigError: On a non-mapping, an unknown or missing key, or a bad value, e.g.
                ``daqmx.yaml: channels[0].command_scale: must be a non-zero finite number,
                got 0.0``.
        """
        _check_keys(mapping, source, '', _CONFIG_REQUIRED, _CONFIG_OPTIONAL, 'daqmx section')
        raw_channels = mapping['channels']
        if isinstance(raw_channels, (str, bytes, Mapping)) or not isinstance(
            raw_channels, Sequence
        ):
            msg = (
                f'{source}: channels: must be a list of channel mappings, '
                f'got {type(raw_channels).__name__}'
            )
            raise BridgeConfigError(msg)
        channels = tuple(
            _channel_from_mapping(item, source, f'channels[{index}].')
            for index, item in enumerate(raw_channels)
        )
        values = {key: mapping[key] for key in _CONFIG_OPTIONAL if key in mapping}
        values['channels'] = channels
        defaults = {f.name: f.default for f in fields(cls) if f.name != 'channels'}
        checked = _check_config({**defaults, **values}, source)
        return cls(**checked)

    @classmethod
    def from_yaml(cls, path: str | Path, section: str = 'daqmx') -> DaqmxConfig:
        """Read the configuration from the ``section`` mapping of a YAML file.

        Args:
            path: The YAML file (see ``config/daqmx_example.yaml``).
            section: Top-level key holding the driver configuration.

        Returns:
            The validated configuration.

        Raises:
            BridgeConfigError: If the file cannot be read or parsed, the section is missing, or
                a value is invalid.
        """
        path = Path(path)
        source = path.name
        try:
            text = path.read_text(encoding='utf-8')
        except OSError as exc:
            msg = f'{path}: cannot read the daqmx configuration ({exc.strerror})'
            raise BridgeConfigError(msg) from exc
        try:
            raw = load_yaml(text)
        except yaml.YAMLError as exc:
            mark = getattr(exc, 'problem_mark', None)
            where = f'line {mark.line + 1}: ' if mark is not None else ''
            problem = getattr(exc, 'problem', None) or 'invalid YAML'
            msg = f'{source}: {where}{problem}'
            raise BridgeConfigError(msg) from exc
        if not isinstance(raw, Mapping) or section not in raw:
            msg = f"{source}: missing top-level section '{section}'"
            raise BridgeConfigError(msg)
        return cls.from_mapping(raw[section], source=f'{source}: {section}')


# ---------------------------------------------------------------------- validation


def _check_keys(
    mapping: Any,
    source: str,
    prefix: str,
    required: Sequence[str],
    optional: Sequence[str],
    what: str,
) -> None:
    where = prefix.rstrip('.') or what
    if not isinstance(mapping, Mapping):
        msg = f'{source}: {where}: must be a mapping, got {type(mapping).__name__}'
        raise BridgeConfigError(msg)
    allowed = tuple(required) + tuple(optional)
    for key in mapping:
        if key not in allowed:
            msg = f'{source}: {prefix}{key}: unknown key (allowed: {", ".join(sorted(allowed))})'
            raise BridgeConfigError(msg)
    for key in required:
        if key not in mapping:
            msg = f"{source}: {where}: missing required key '{key}'"
            raise BridgeConfigError(msg)


def _channel_from_mapping(mapping: Any, source: str, prefix: str) -> DaqmxChannelConfig:
    _check_keys(mapping, source, prefix, _CHANNEL_REQUIRED, _CHANNEL_OPTIONAL, 'channel')
    defaults = {f.name: f.default for f in fields(DaqmxChannelConfig) if f.name not in mapping}
    values = {**defaults, **{key: mapping[key] for key in mapping}}
    return DaqmxChannelConfig(**_check_channel(values, source, prefix))


def _number(value: Any, source: str, key: str, *, rule: str = 'finite') -> float:
    """Return ``value`` as a float satisfying ``rule``: finite, non-zero, positive, >= 0."""
    what = {
        'finite': 'a finite number',
        'nonzero': 'a non-zero finite number',
        'positive': 'a positive finite number',
        'nonnegative': 'a finite number >= 0',
    }[rule]
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        msg = f'{source}: {key}: must be {what}, got {type(value).__name__} {value!r}'
        raise BridgeConfigError(msg)
    number = float(value)
    bad = (
        not math.isfinite(number)
        or (rule == 'nonzero' and number == 0.0)
        or (rule == 'positive' and number <= 0.0)
        or (rule == 'nonnegative' and number < 0.0)
    )
    if bad:
        msg = f'{source}: {key}: must be {what}, got {value!r}'
        raise BridgeConfigError(msg)
    return number


def _physical_channel(value: Any, source: str, key: str) -> str:
    if not isinstance(value, str) or not value.strip():
        msg = f'{source}: {key}: must be a physical channel name such as Dev1/ao0, got {value!r}'
        raise BridgeConfigError(msg)
    if any(sep in value for sep in ',:'):
        msg = f'{source}: {key}: must name one physical channel (no list or range), got {value!r}'
        raise BridgeConfigError(msg)
    return value.strip()


def _check_channel(values: Mapping[str, Any], source: str, prefix: str) -> dict[str, Any]:
    """Validate one channel's values; return them normalised."""
    checked: dict[str, Any] = {}
    name = values['name']
    if not isinstance(name, str):
        msg = f'{source}: {prefix}name: must be a string, got {name!r}'
        raise BridgeConfigError(msg)
    checked['name'] = name
    for signal in _SIGNALS:
        channel_key = f'{signal}_channel'
        checked[channel_key] = _physical_channel(values[channel_key], source, prefix + channel_key)
        scale_key = f'{signal}_scale'
        checked[scale_key] = _number(values[scale_key], source, prefix + scale_key, rule='nonzero')
        offset_key = f'{signal}_offset'
        checked[offset_key] = _number(values[offset_key], source, prefix + offset_key)
        low_key, high_key = f'{signal}_min_voltage', f'{signal}_max_voltage'
        low = _number(values[low_key], source, prefix + low_key)
        high = _number(values[high_key], source, prefix + high_key)
        for key, voltage in ((low_key, low), (high_key, high)):
            if abs(voltage) > MAX_ABS_VOLTAGE:
                msg = f'{source}: {prefix}{key}: {voltage:g} V is beyond +-{MAX_ABS_VOLTAGE:g} V'
                raise BridgeConfigError(msg)
        if not low < high:
            msg = (
                f'{source}: {prefix}{low_key}: must be below {high_key} '
                f'({low:g} V >= {high:g} V)'
            )
            raise BridgeConfigError(msg)
        checked[low_key] = low
        checked[high_key] = high
    if checked['displacement_channel'].lower() == checked['force_channel'].lower():
        msg = (
            f'{source}: {prefix}force_channel: same physical channel as displacement_channel '
            f'({checked["force_channel"]})'
        )
        raise BridgeConfigError(msg)
    return checked


def _check_config(values: Mapping[str, Any], source: str) -> dict[str, Any]:
    """Validate the driver-level values; return them normalised."""
    channels = values['channels']
    if isinstance(channels, DaqmxChannelConfig) or not isinstance(channels, (list, tuple)):
        msg = (
            f'{source}: channels: must be a list of channel configurations, '
            f'got {type(channels).__name__}'
        )
        raise BridgeConfigError(msg)
    if not channels:
        msg = f'{source}: channels: must list at least one DOF'
        raise BridgeConfigError(msg)
    for index, channel in enumerate(channels):
        if not isinstance(channel, DaqmxChannelConfig):
            msg = (
                f'{source}: channels[{index}]: must be a DaqmxChannelConfig, '
                f'got {type(channel).__name__}'
            )
            raise BridgeConfigError(msg)
    names: set[str] = set()
    for index, channel in enumerate(channels):
        if channel.name in names:
            msg = f'{source}: channels[{index}].name: duplicate DOF name {channel.name!r}'
            raise BridgeConfigError(msg)
        if channel.name:
            names.add(channel.name)
    seen: dict[str, str] = {}
    for index, channel in enumerate(channels):
        for signal in _SIGNALS:
            key = f'channels[{index}].{signal}_channel'
            physical = getattr(channel, f'{signal}_channel')
            normalised = physical.lower().lstrip('/')
            if normalised in seen:
                msg = (
                    f'{source}: {key}: physical channel {physical} is already used by '
                    f'{seen[normalised]}'
                )
                raise BridgeConfigError(msg)
            seen[normalised] = key

    sample_rate = _number(values['sample_rate'], source, 'sample_rate', rule='positive')
    samples = values['samples_per_read']
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        msg = f'{source}: samples_per_read: must be a positive integer, got {samples!r}'
        raise BridgeConfigError(msg)
    terminal = values['terminal_configuration']
    if terminal not in TERMINAL_CONFIGURATIONS:
        msg = (
            f'{source}: terminal_configuration: must be one of '
            f'{", ".join(TERMINAL_CONFIGURATIONS)}, got {terminal!r}'
        )
        raise BridgeConfigError(msg)
    settle_time = _number(values['settle_time'], source, 'settle_time', rule='nonnegative')
    timeout = _number(values['timeout'], source, 'timeout', rule='positive')
    acquisition = samples / sample_rate
    if timeout <= acquisition:
        msg = (
            f'{source}: timeout: {timeout:g} s does not exceed the acquisition time '
            f'samples_per_read / sample_rate = {acquisition:g} s'
        )
        raise BridgeConfigError(msg)
    return {
        'channels': tuple(channels),
        'sample_rate': sample_rate,
        'samples_per_read': samples,
        'terminal_configuration': terminal,
        'settle_time': settle_time,
        'timeout': timeout,
    }
