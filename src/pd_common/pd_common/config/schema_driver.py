"""The typed schema of an actuator driver's settings file (the bridge's ``driver_config``).

The YAML file the bridge's ``driver_config`` parameter names: the ``daqmx`` driver's wiring and
calibrations (``daqmx``), the ``emulator`` driver's servo-hydraulic model (``emulator``), its
ramp-and-hold execution (``ramp_hold``) and the experimental errors it injects (``errors``).
Read once by :func:`~.bridge_file.read_driver_config`; the drivers build from the typed
sections. Every check of these settings is here, one line naming the file and the dotted path::

    daqmx.yaml: daqmx.channels.0.command_scale: must not be 0, got 0.0
"""

from __future__ import annotations

import math
from typing import Annotated, Literal, Self

from pydantic import Field, field_validator, model_validator

from .schema_base import ConfigModel, Finite, NonNegative, Positive, check, refuse_at
from .schema_specimen import ErrorsSection

__all__ = ['DAQMX_TERMINAL_CONFIGURATIONS', 'EMULATOR_MIN_RATE',
           'MAX_ABS_VOLTAGE', 'MAX_FRICTION_STIFFNESS_NUMBER', 'DaqmxChannelSection',
           'DaqmxSection', 'DriverConfigFile', 'EmulatorSection', 'RampHoldSection']

#: Accepted ``terminal_configuration`` values of the daqmx driver's analog inputs.
DAQMX_TERMINAL_CONFIGURATIONS = ('default', 'rse', 'nrse', 'diff', 'pseudo_diff')
#: Largest |voltage| of a daqmx channel range [V] (servo-controller inputs are +-10 V).
MAX_ABS_VOLTAGE = 10.0
#: Lowest controller rate of the emulator [Hz].
EMULATOR_MIN_RATE = 1000.0
#: Largest ``sqrt(friction_stiffness / piston_mass) * h`` of the emulator (explicit friction).
MAX_FRICTION_STIFFNESS_NUMBER = 0.5

#: A finite number other than 0.
NonZero = Annotated[float, Field(allow_inf_nan=False), check(lambda value: value != 0.0,
                                                             'must not be 0')]
#: A voltage within +-MAX_ABS_VOLTAGE.
Voltage = Annotated[float, Field(ge=-MAX_ABS_VOLTAGE, le=MAX_ABS_VOLTAGE, allow_inf_nan=False)]
#: One physical channel of a DAQ device (``Dev1/ao0``; no list or range).
PhysicalChannel = Annotated[str, Field(pattern=r'^\s*[^\s,:][^,:]*$')]

_SIGNALS = ('command', 'displacement', 'force')


class DaqmxChannelSection(ConfigModel):
    """Wiring and linear calibration of one DOF of the daqmx driver."""

    command_channel: PhysicalChannel
    """Analog output of the displacement command (``Dev1/ao0``)."""
    command_scale: NonZero
    """Commanded displacement per volt [m/V] (negative inverts)."""
    displacement_channel: PhysicalChannel
    """Analog input of the conditioned displacement (``Dev1/ai0``)."""
    displacement_scale: NonZero
    """Measured displacement per volt [m/V]."""
    force_channel: PhysicalChannel
    """Analog input of the conditioned load-cell signal (``Dev1/ai1``)."""
    force_scale: NonZero
    """Measured force per volt [N/V]."""
    name: str = ''
    """The DOF's name in messages."""
    command_offset: Finite = 0.0
    """Commanded displacement at 0 V [m]."""
    command_min_voltage: Voltage = -10.0
    """Lowest voltage the driver ever writes [V]."""
    command_max_voltage: Voltage = 10.0
    """Highest voltage the driver ever writes [V]."""
    displacement_offset: Finite = 0.0
    """Measured displacement at 0 V [m]."""
    displacement_min_voltage: Voltage = -10.0
    """Lower end of the displacement input range [V]."""
    displacement_max_voltage: Voltage = 10.0
    """Upper end of the displacement input range [V]."""
    force_offset: Finite = 0.0
    """Measured force at 0 V [N] (nulls a load-cell offset)."""
    force_min_voltage: Voltage = -10.0
    """Lower end of the force input range [V]."""
    force_max_voltage: Voltage = 10.0
    """Upper end of the force input range [V]."""

    @field_validator('command_channel', 'displacement_channel', 'force_channel')
    @classmethod
    def _strip(cls, value: str) -> str:
        return value.strip()

    @model_validator(mode='after')
    def _ranges_and_inputs(self) -> Self:
        for signal in _SIGNALS:
            low = getattr(self, f'{signal}_min_voltage')
            high = getattr(self, f'{signal}_max_voltage')
            if not low < high:
                refuse_at(f'{signal}_min_voltage',
                                f'must be below {signal}_max_voltage ({low:g} V >= {high:g} V)')
        if self.displacement_channel.lower() == self.force_channel.lower():
            refuse_at('force_channel', 'same physical channel as displacement_channel '
                            f'({self.force_channel})')
        return self


class DaqmxSection(ConfigModel):
    """The daqmx driver: its channels (one per DOF), sampling and timing."""

    channels: Annotated[list[DaqmxChannelSection], Field(min_length=1)]
    """One channel mapping per DOF, in DOF order."""
    sample_rate: Positive = 1000.0
    """Analog input sample clock per channel [Hz]."""
    samples_per_read: Annotated[int, Field(ge=1)] = 100
    """Samples per input channel acquired and averaged per measurement."""
    terminal_configuration: Literal['default', 'rse', 'nrse', 'diff', 'pseudo_diff'] = 'diff'
    """Analog input terminal configuration (``diff`` for a servo-controller's conditioned
    outputs unless they are ground-referenced to the DAQ)."""
    settle_time: NonNegative = 0.5
    """Wait between writing a command and starting the acquisition [s]."""
    timeout: Positive = 10.0
    """DAQmx write and read timeout [s]; more than ``samples_per_read / sample_rate``."""

    @model_validator(mode='after')
    def _distinct_and_timely(self) -> Self:
        names: dict[str, int] = {}
        used: dict[str, str] = {}
        for index, channel in enumerate(self.channels):
            if channel.name and channel.name in names:
                refuse_at(f'channels.{index}.name',
                                f'duplicate DOF name {channel.name!r} (channels.'
                                f'{names[channel.name]}.name)')
            names.setdefault(channel.name, index)
            for signal in _SIGNALS:
                key = f'channels.{index}.{signal}_channel'
                physical = getattr(channel, f'{signal}_channel')
                normalised = physical.lower().lstrip('/')
                if normalised in used:
                    refuse_at(key, f'physical channel {physical} is already used by '
                                    f'{used[normalised]}')
                used[normalised] = key
        acquisition = self.samples_per_read / self.sample_rate
        if self.timeout <= acquisition:
            refuse_at('timeout', f'{self.timeout:g} s does not exceed the acquisition '
                            f'time samples_per_read / sample_rate = {acquisition:g} s')
        return self


class EmulatorSection(ConfigModel):
    """The emulator driver's servo-hydraulic actuator: plant, controller, sensors, friction."""

    rate: Annotated[float, Field(ge=EMULATOR_MIN_RATE, allow_inf_nan=False)] = 1000.0
    """Controller rate [Hz] (>= 1000)."""
    substeps: Annotated[int, Field(ge=1)] = 2
    """Integration sub-steps per controller period."""
    piston_area: Positive = 0.01
    """Effective piston area A [m2]."""
    bulk_modulus: Positive = 6.9e8
    """Effective oil bulk modulus (oil, hoses, entrained air) [Pa]."""
    chamber_volume: Positive = 6.0e-3
    """Total volume of both chambers and the lines [m3]."""
    piston_mass: Positive = 50.0
    """Moving mass (piston, rod, load cell, clevis) [kg]."""
    piston_damping: NonNegative = 9500.0
    """Viscous damping of the piston seals [N s/m] (not seen by the load cell)."""
    valve_time_constant: Positive = 0.0015
    """First-order spool lag [s]."""
    valve_flow: Positive = 1.0e-3
    """Rated flow at full opening [m3/s]."""
    leakage: NonNegative = 5.0e-12
    """Flow-pressure coefficient (valve and cross-port leakage) [m3/(s Pa)]."""
    supply_pressure: Positive | None = None
    """Supply pressure for the orifice law [Pa] (null: flow linear in the spool opening)."""
    kp: NonNegative = 4000.0
    """Proportional gain [V/m]."""
    ki: NonNegative = 20000.0
    """Integral gain [V/(m s)]."""
    integral_band: Annotated[float, Field(gt=0.0, allow_inf_nan=True)] = 5.0e-5
    """The integral acts only while the error is within this [m] (``.inf``: always)."""
    kd: NonNegative = 0.0
    """Derivative gain (on the measurement) [V s/m]."""
    derivative_filter: NonNegative = 0.002
    """Time constant of the derivative filter [s] (0: none)."""
    velocity_feedforward: NonNegative = 0.0
    """Velocity feed-forward, a fraction of the ideal one."""
    valve_saturation: Positive = 10.0
    """Controller output limit, the servo-valve's rated input [V]."""
    delay_ticks: Annotated[int, Field(ge=0)] = 0
    """Transport delay of the command [controller periods]."""
    displacement_noise: NonNegative = 0.0
    """Standard deviation of the displacement sensor noise [m]."""
    force_noise: NonNegative = 0.0
    """Standard deviation of the load-cell noise [N]."""
    displacement_lsb: NonNegative = 0.0
    """Quantisation step of the displacement sensor [m] (0: none)."""
    force_lsb: NonNegative = 0.0
    """Quantisation step of the load cell [N] (0: none)."""
    force_bias: Finite = 0.0
    """Constant load-cell offset [N]."""
    friction_coulomb: NonNegative = 0.0
    """Coulomb (Dahl) friction force of the connections [N]."""
    friction_viscous: NonNegative = 0.0
    """Viscous friction of the connections [N s/m]."""
    friction_stiffness: Positive = 1.0e7
    """Dahl pre-sliding stiffness [N/m]."""
    seed: Annotated[int, Field(ge=0)] | None = None
    """Seed of the sensor-noise generator (null: a different draw every run)."""

    @model_validator(mode='after')
    def _friction_resolved(self) -> Self:
        substep = 1.0 / (self.rate * self.substeps)
        number = math.sqrt(self.friction_stiffness / self.piston_mass) * substep
        if self.friction_coulomb > 0.0 and number > MAX_FRICTION_STIFFNESS_NUMBER:
            refuse_at('friction_stiffness', (
                f'{self.friction_stiffness:g} N/m is too stiff for the sub-step {substep:g} s '
                f'(sqrt(friction_stiffness/piston_mass)*h = {number:.3g} > '
                f'{MAX_FRICTION_STIFFNESS_NUMBER}); raise substeps or rate'))
        return self


class RampHoldSection(ConfigModel):
    """How the emulator driver executes each step: ramp, hold, settle, sample."""

    ramp_time: NonNegative | None = None
    """Ramp duration [s] (0: a step command); exclusive with ``ramp_velocity`` (neither: the
    default ramp time)."""
    ramp_velocity: Positive | None = None
    """Ramp velocity of the DOF with the largest increment [m/s]."""
    hold_time: NonNegative = 0.0
    """Minimum time the target is held before sampling [s]."""
    settle_tolerance: Positive = 1.0e-5
    """Every DOF's measured displacement stays within this of the target [m] ..."""
    settle_time: NonNegative = 0.02
    """... continuously for this long [s] (0: one sample within tolerance)."""
    samples: Annotated[int, Field(ge=1)] = 10
    """Samples averaged into the answer (after settling)."""
    timeout: Positive = 2.0
    """Longest hold after the ramp (settling and sampling) before the step is a fault [s]."""

    @model_validator(mode='after')
    def _one_ramp(self) -> Self:
        if self.ramp_time is not None and self.ramp_velocity is not None:
            refuse_at('ramp_velocity', 'ramp_time and ramp_velocity are exclusive, got '
                            f'both ({self.ramp_time:g} s and {self.ramp_velocity:g} m/s)')
        return self


class DriverConfigFile(ConfigModel):
    """A driver's settings file (the bridge's ``driver_config``): the sections its driver reads.

    ``daqmx`` for the daqmx driver; ``emulator``, ``ramp_hold`` and ``errors`` for the
    emulator driver (each optional: its defaults).
    """

    daqmx: DaqmxSection | None = None
    """The daqmx driver's wiring, calibrations and timing."""
    emulator: EmulatorSection | None = None
    """The emulator driver's servo-hydraulic actuator."""
    ramp_hold: RampHoldSection | None = None
    """The emulator driver's step execution."""
    errors: ErrorsSection | None = None
    """Experimental errors the emulator driver injects into each step."""
