"""``daqmx`` driver: analog command out and analog feedback in through NI DAQ hardware.

This is the usual way to drive a servo-hydraulic controller (MOOG, MTS, Instron...) from a PC:

* one analog output per actuator carries the **displacement command** (typically +-10 V) into
  the controller's external command / program input, with the controller's inner loop in
  displacement control and the external command enabled;
* the controller's **conditioned displacement** (LVDT) output and **conditioned load-cell**
  output (both typically +-10 V full scale) come back on two analog inputs.

The driver is synchronous: :meth:`DaqmxDriver.command` converts the target (m) to volts,
refuses a voltage outside the channel's command range, writes it, waits ``settle_time``, acquires
``samples_per_read`` samples per input channel at ``sample_rate``, averages them, converts to m
and N and reports the measurement before it returns. All calibrations are linear::

    command:       V = (x - command_offset) / command_scale          (command_scale in m/V)
    displacement:  x = displacement_scale * V + displacement_offset  (m/V, m)
    force:         f = force_scale * V + force_offset                (N/V, N)

The ``nidaqmx`` package is imported only inside :meth:`DaqmxDriver.open` and only when no task
factory is injected, so it is not a dependency of the rest of the package; tests inject a fake
task. **This driver has not been run on hardware.** Registered as the ``daqmx`` driver
(:data:`DAQMX`): the ``driver_config`` parameter names a YAML file with a ``daqmx`` section
(``config/daqmx_example.yaml``), read into :class:`~.daqmx_config.DaqmxConfig`
(:mod:`.daqmx_config`: the channels, calibrations and their validation).

nidaqmx API used (checked against NI's sources and documentation):

* ``nidaqmx.Task()``; ``task.close()`` clears the task.
* ``task.ao_channels.add_ao_voltage_chan(physical_channel, min_val=..., max_val=...)``.
* ``task.ai_channels.add_ai_voltage_chan(physical_channel, terminal_config=..., min_val=...,
  max_val=...)``; its default range is +-5 V, so the range is always passed explicitly.
* ``task.timing.cfg_samp_clk_timing(rate, sample_mode=AcquisitionType.FINITE,
  samps_per_chan=N)``: a finite acquisition that ``task.read`` starts implicitly on each call.
* ``task.write(data, auto_start=True, timeout=...)``: a scalar for one channel, a list of one
  value per channel for several (one sample each, on-demand timing).
* ``task.read(number_of_samples_per_channel=N, timeout=...)``: with N given and several channels
  it returns a list of lists, one list of N samples per channel, in channel creation order.
* ``nidaqmx.constants.TerminalConfiguration`` members ``DEFAULT``, ``RSE``, ``NRSE``, ``DIFF``,
  ``PSEUDO_DIFF`` (``DIFFERENTIAL`` and ``PSEUDODIFFERENTIAL`` before nidaqmx 0.7) and
  ``nidaqmx.constants.AcquisitionType.FINITE``.

References:
    https://nidaqmx-python.readthedocs.io/ (API reference: Task, channel collections, Timing,
    constants); https://pypi.org/project/nidaqmx/ (installation: also needs the NI-DAQmx
    driver); https://github.com/ni/nidaqmx-python (``generated/nidaqmx/task/_task.py``:
    ``Task.read`` and ``Task.write`` docstrings; ``task/collections/_ai_channel_collection.py``,
    ``_ao_channel_collection.py``, ``task/_timing.py``, ``constants.py``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from ..errors import BridgeConfigError, DriverError
from .base import ActuatorDriver, ActuatorMeasurement, StepId
from .daqmx_config import DaqmxConfig
from .registry import (
    DriverContext,
    DriverParameter,
    DriverSpec,
    read_driver_settings,
    register_driver,
)

TaskFactory = Callable[[str], Any]
"""``factory(role)``: a new task with the ``nidaqmx.Task`` interface; ``role`` is ``'command'``
(analog outputs) or ``'feedback'`` (analog inputs)."""

# nidaqmx.constants.TerminalConfiguration member names per configuration (newest first).
_TERMINAL_MEMBERS = {
    'default': ('DEFAULT',),
    'rse': ('RSE',),
    'nrse': ('NRSE',),
    'diff': ('DIFF', 'DIFFERENTIAL'),
    'pseudo_diff': ('PSEUDO_DIFF', 'PSEUDODIFFERENTIAL'),
}

# Stand-in for nidaqmx.constants when a task factory is injected without constants: the fake
# tasks then receive the member names as strings.
SYMBOLIC_CONSTANTS = SimpleNamespace(
    TerminalConfiguration=SimpleNamespace(
        DEFAULT='DEFAULT', RSE='RSE', NRSE='NRSE', DIFF='DIFF', PSEUDO_DIFF='PSEUDO_DIFF'
    ),
    AcquisitionType=SimpleNamespace(FINITE='FINITE'),
)

class DaqmxDriver(ActuatorDriver):
    """Synchronous driver commanding a servo-controller through NI-DAQmx analog I/O.

    The driver refuses (:class:`DriverError`, nothing written) any target whose command voltage
    is non-finite or outside the channel's ``command_min_voltage..command_max_voltage``. It is a
    last line of defence behind the bridge's own limits, not a replacement for them.

    Attributes:
        config: The driver configuration.
    """

    driver_name = 'daqmx'

    def force_control_problem(self) -> str | None:
        """Why this driver refuses force-controlled actuators (always: see the docs)."""
        return ('force control not supported; '
                'its analog outputs are displacement commands (wire a force-controlled '
                'channel as described in docs/force_control.md, or use another driver)')

    def __init__(
        self,
        config: DaqmxConfig,
        task_factory: TaskFactory | None = None,
        constants: Any = None,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        """Create the driver (no hardware is touched until :meth:`open`).

        Args:
            config: The driver configuration.
            task_factory: Creates the tasks (see :data:`TaskFactory`); ``None`` uses
                ``nidaqmx.Task``, importing ``nidaqmx`` in :meth:`open`.
            constants: Provides ``TerminalConfiguration`` and ``AcquisitionType`` like
                ``nidaqmx.constants``; ``None`` means ``nidaqmx.constants`` with the default
                factory and :data:`SYMBOLIC_CONSTANTS` (member names as strings) with an
                injected factory.
            sleep: Waits the settle time, s (injectable for tests).

        Raises:
            BridgeConfigError: If ``config`` is not a :class:`DaqmxConfig` or an argument is
                not callable.
        """
        super().__init__()
        if not isinstance(config, DaqmxConfig):
            msg = f'DaqmxDriver: config must be a DaqmxConfig, got {type(config).__name__}'
            raise BridgeConfigError(msg)
        if task_factory is not None and not callable(task_factory):
            msg = 'DaqmxDriver: task_factory must be callable'
            raise BridgeConfigError(msg)
        if not callable(sleep):
            msg = 'DaqmxDriver: sleep must be callable'
            raise BridgeConfigError(msg)
        self.config = config
        self._task_factory = task_factory
        self._constants = constants
        self._sleep = sleep
        self._command_task: Any = None
        self._feedback_task: Any = None
        self._last_voltage: tuple[float, ...] | None = None
        self._position: tuple[float, ...] | None = None
        self._force: tuple[float, ...] | None = None
        self._hold_count = 0

    # ------------------------------------------------------------------ properties

    @property
    def n_dof(self) -> int:
        """Number of DOF."""
        return self.config.n_dof

    @property
    def is_open(self) -> bool:
        """Whether the tasks exist (between a successful :meth:`open` and :meth:`close`)."""
        return self._command_task is not None and self._feedback_task is not None

    @property
    def last_voltage(self) -> tuple[float, ...] | None:
        """Command voltages last written since :meth:`open`, V; ``None`` before the first."""
        return self._last_voltage

    @property
    def last_force(self) -> list[float] | None:
        """Last measured force per DOF, N; ``None`` before the first measurement."""
        return None if self._force is None else list(self._force)

    @property
    def hold_count(self) -> int:
        """Number of :meth:`hold` calls."""
        return self._hold_count

    # ------------------------------------------------------------------ lifecycle

    def open(self) -> None:
        """Create the command and feedback tasks and measure the initial position and force.

        Nothing is written: the command output keeps whatever it was until the first
        :meth:`command`. Does nothing if already open. On any failure every task already
        created is closed again.

        Raises:
            DriverError: If ``nidaqmx`` is missing, a task or channel cannot be created, or the
                initial measurement fails.
        """
        if self.is_open:
            return
        factory, constants = self._backend()
        terminal = _terminal_constant(constants, self.config.terminal_configuration)
        try:
            finite = constants.AcquisitionType.FINITE
        except AttributeError as exc:
            msg = 'DaqmxDriver: the constants have no AcquisitionType.FINITE'
            raise DriverError(msg) from exc

        command_task: Any = None
        feedback_task: Any = None
        try:
            command_task = factory('command')
            for channel in self.config.channels:
                command_task.ao_channels.add_ao_voltage_chan(
                    channel.command_channel,
                    min_val=channel.command_min_voltage,
                    max_val=channel.command_max_voltage,
                )
            feedback_task = factory('feedback')
            for channel in self.config.channels:
                feedback_task.ai_channels.add_ai_voltage_chan(
                    channel.displacement_channel,
                    terminal_config=terminal,
                    min_val=channel.displacement_min_voltage,
                    max_val=channel.displacement_max_voltage,
                )
                feedback_task.ai_channels.add_ai_voltage_chan(
                    channel.force_channel,
                    terminal_config=terminal,
                    min_val=channel.force_min_voltage,
                    max_val=channel.force_max_voltage,
                )
            feedback_task.timing.cfg_samp_clk_timing(
                self.config.sample_rate,
                sample_mode=finite,
                samps_per_chan=self.config.samples_per_read,
            )
        except Exception as exc:
            message = f'DaqmxDriver: open() failed: {_describe(exc)}'
            message += _close_all((feedback_task, command_task))
            raise DriverError(message) from exc

        self._command_task = command_task
        self._feedback_task = feedback_task
        self._last_voltage = None
        try:
            self.measure()
        except DriverError as exc:
            message = f'DaqmxDriver: open(): initial measurement failed: {exc}'
            message += self._drop_tasks()
            raise DriverError(message) from exc

    def close(self) -> None:
        """Close both tasks. Idempotent; nothing is written.

        What the command output does once its task is cleared depends on the device (see the
        analog output idle behaviour in the NI-DAQmx help).

        Raises:
            DriverError: If a task failed to close (both are dropped anyway).
        """
        problems = self._drop_tasks()
        if problems:
            msg = f'DaqmxDriver: close() failed{problems}'
            raise DriverError(msg)

    # ------------------------------------------------------------------ motion

    def command(self, step: StepId, target: Sequence[float]) -> None:
        """Write the command for ``target`` (m per DOF), settle, measure and report.

        Every DOF's voltage is checked before anything is written.

        Raises:
            DriverError: If the driver is closed, the target is malformed or non-finite, a
                voltage is outside its command range (nothing written), or the write or the
                measurement fails.
        """
        if not self.is_open:
            msg = 'DaqmxDriver: command() called while closed'
            raise DriverError(msg)
        volts = self.command_voltages(target)
        self._write(volts)
        self._last_voltage = volts
        if self.config.settle_time > 0.0:
            self._sleep(self.config.settle_time)
        displacement, force = self.measure()
        self._emit(ActuatorMeasurement(step, tuple(displacement), tuple(force)))

    def command_voltages(self, target: Sequence[float]) -> tuple[float, ...]:
        """Convert a target displacement per DOF (m) to command voltages (V), checking them.

        Raises:
            DriverError: If the target is malformed or non-finite or a voltage is outside its
                channel's command range.
        """
        if isinstance(target, (str, bytes, Mapping)):
            msg = f'DaqmxDriver: target must be a sequence of numbers, got {type(target).__name__}'
            raise DriverError(msg)
        try:
            values = [float(x) for x in target]
        except (TypeError, ValueError) as exc:
            msg = f'DaqmxDriver: target is not a sequence of numbers: {exc}'
            raise DriverError(msg) from exc
        if len(values) != self.n_dof:
            msg = (
                f'DaqmxDriver: target has {len(values)} values, expected {self.n_dof}; '
                'nothing written'
            )
            raise DriverError(msg)
        volts = []
        for dof, (value, channel) in enumerate(zip(values, self.config.channels)):
            label = channel.label(dof)
            if not math.isfinite(value):
                msg = (
                    f'DaqmxDriver: {label}: non-finite target displacement {value}; '
                    'nothing written'
                )
                raise DriverError(msg)
            voltage = (value - channel.command_offset) / channel.command_scale
            low, high = channel.command_min_voltage, channel.command_max_voltage
            if not math.isfinite(voltage) or voltage < low or voltage > high:
                msg = (
                    f'DaqmxDriver: {label}: target {value:.6g} m needs {voltage:.6g} V on '
                    f'{channel.command_channel}, outside the command range [{low:g}, {high:g}] V;'
                    ' nothing written'
                )
                raise DriverError(msg)
            volts.append(voltage)
        return tuple(volts)

    def hold(self) -> None:
        """Hold position by re-writing the last command voltages.

        Before the first command since :meth:`open` nothing is written (the output was never
        changed by this driver).

        Raises:
            DriverError: If the driver is closed or the write fails.
        """
        self._hold_count += 1
        if not self.is_open:
            msg = 'DaqmxDriver: hold() called while closed; nothing written'
            raise DriverError(msg)
        if self._last_voltage is not None:
            self._write(self._last_voltage)

    def position(self) -> list[float]:
        """Return the last measured displacement per DOF, m.

        Raises:
            DriverError: Before the first measurement (the driver was never opened).
        """
        if self._position is None:
            msg = 'DaqmxDriver: position unknown: open() the driver first'
            raise DriverError(msg)
        return list(self._position)

    def measure(self) -> tuple[list[float], list[float]]:
        """Acquire, average and convert the feedback without commanding anything.

        Returns:
            ``(displacement, force)``: per DOF, m and N. Also becomes :meth:`position` and
            :attr:`last_force`.

        Raises:
            DriverError: If the driver is closed, the read fails, returns the wrong shape or a
                non-finite sample, or a sample is outside its channel's input range (clipped).
        """
        if not self.is_open:
            msg = 'DaqmxDriver: measure() called while closed'
            raise DriverError(msg)
        config = self.config
        n_signals = 2 * config.n_dof
        n_samples = config.samples_per_read
        try:
            raw = self._feedback_task.read(
                number_of_samples_per_channel=n_samples, timeout=config.timeout
            )
        except Exception as exc:
            msg = f'DaqmxDriver: reading the feedback failed: {_describe(exc)}'
            raise DriverError(msg) from exc
        try:
            samples = np.asarray(raw, dtype=float)
        except (TypeError, ValueError) as exc:
            msg = f'DaqmxDriver: feedback samples are not numbers: {exc}'
            raise DriverError(msg) from exc
        if samples.shape != (n_signals, n_samples):
            msg = (
                f'DaqmxDriver: read returned samples of shape {samples.shape}, expected '
                f'({n_signals}, {n_samples}) (input channels, samples per channel)'
            )
            raise DriverError(msg)
        for row, values in enumerate(samples):
            dof, is_force = divmod(row, 2)
            channel = config.channels[dof]
            signal = 'force' if is_force else 'displacement'
            physical = channel.force_channel if is_force else channel.displacement_channel
            if not np.all(np.isfinite(values)):
                msg = (
                    f'DaqmxDriver: {channel.label(dof)}: non-finite {signal} sample on '
                    f'{physical}'
                )
                raise DriverError(msg)
            low = getattr(channel, f'{signal}_min_voltage')
            high = getattr(channel, f'{signal}_max_voltage')
            if values.min() < low or values.max() > high:
                worst = values.min() if values.min() < low else values.max()
                msg = (
                    f'DaqmxDriver: {channel.label(dof)}: {signal} sample {worst:.6g} V on '
                    f'{physical} is outside the input range [{low:g}, {high:g}] V (clipped)'
                )
                raise DriverError(msg)
        means = samples.mean(axis=1)
        displacement = [
            channel.displacement_scale * float(means[2 * dof]) + channel.displacement_offset
            for dof, channel in enumerate(config.channels)
        ]
        force = [
            channel.force_scale * float(means[2 * dof + 1]) + channel.force_offset
            for dof, channel in enumerate(config.channels)
        ]
        self._position = tuple(displacement)
        self._force = tuple(force)
        return displacement, force

    # ------------------------------------------------------------------ internals

    def _backend(self) -> tuple[TaskFactory, Any]:
        """The task factory and the constants to use (importing nidaqmx if needed)."""
        if self._task_factory is not None:
            constants = self._constants if self._constants is not None else SYMBOLIC_CONSTANTS
            return self._task_factory, constants
        # nidaqmx is imported here, not at the top: it is an optional hardware package (NI's
        # driver must be installed too) that nothing but a real DAQ needs, so the module, its
        # tests (which inject a fake task) and every other driver work without it.
        try:
            import nidaqmx  # noqa: PLC0415 - optional hardware package, see above
            import nidaqmx.constants  # noqa: PLC0415
        except ImportError as exc:
            msg = (
                f'DaqmxDriver: cannot import nidaqmx ({exc}): install nidaqmx '
                '(python -m pip install nidaqmx) and the NI-DAQmx driver to use the daqmx driver'
            )
            raise DriverError(msg) from exc

        def factory(role: str) -> Any:
            return nidaqmx.Task()

        constants = self._constants if self._constants is not None else nidaqmx.constants
        return factory, constants

    def _write(self, volts: Sequence[float]) -> None:
        """Write one sample per command channel (a scalar for a single channel)."""
        data: float | list[float] = float(volts[0]) if len(volts) == 1 else list(volts)
        try:
            self._command_task.write(data, auto_start=True, timeout=self.config.timeout)
        except Exception as exc:
            msg = f'DaqmxDriver: writing the command failed: {_describe(exc)}'
            raise DriverError(msg) from exc

    def _drop_tasks(self) -> str:
        """Close and forget both tasks; return ``''`` or a suffix describing close failures."""
        tasks = (self._feedback_task, self._command_task)
        self._feedback_task = None
        self._command_task = None
        self._last_voltage = None
        return _close_all(tasks)


def _close_all(tasks: Sequence[Any]) -> str:
    """Close every task that is not ``None``; return ``''`` or a suffix naming failures."""
    problems = []
    for task in tasks:
        if task is None:
            continue
        try:
            task.close()
        except Exception as exc:  # noqa: BLE001 - keep closing the others
            problems.append(_describe(exc))
    if not problems:
        return ''
    return '; closing a task also failed: ' + '; '.join(problems)


def _terminal_constant(constants: Any, name: str) -> Any:
    """The ``TerminalConfiguration`` member for ``name`` (one of the accepted spellings)."""
    enum = getattr(constants, 'TerminalConfiguration', None)
    for member in _TERMINAL_MEMBERS[name]:
        if enum is not None and hasattr(enum, member):
            return getattr(enum, member)
    msg = (
        f'DaqmxDriver: terminal_configuration {name!r} is not available in this nidaqmx '
        f'(looked for TerminalConfiguration.{" or .".join(_TERMINAL_MEMBERS[name])})'
    )
    raise DriverError(msg)


def _describe(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f'{type(exc).__name__}: {text[0]}' if text else type(exc).__name__


def make_daqmx_driver(context: DriverContext) -> DaqmxDriver:
    """The ``daqmx`` driver configured by the ``daqmx`` section of the ``driver_config`` file.

    The file is read once and typed (:func:`~.registry.read_driver_settings`).

    Raises:
        BridgeConfigError: No file, or one without a ``daqmx`` section or with a bad value (one
            line naming the file and the dotted path).
    """
    path = str(context.parameters['driver_config'])
    settings = read_driver_settings(path, 'driver_config')
    if settings.daqmx is None:
        msg = f"{Path(path).name}: daqmx: is required (the daqmx driver's section)"
        raise BridgeConfigError(msg)
    return DaqmxDriver(DaqmxConfig.from_section(settings.daqmx))


DAQMX = DriverSpec(
    name='daqmx',
    factory=make_daqmx_driver,
    parameters=(DriverParameter('driver_config', '', 'YAML file with the driver settings'),),
    description='analog command out / conditioned feedback in through NI DAQ hardware '
                '(untested on hardware)',
)
register_driver(DAQMX)
