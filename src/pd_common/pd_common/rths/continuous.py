"""Continuous actuator motion: integration-step targets sub-stepped at the controller rate.

The integrator commands one target displacement ``d[n+1]`` per integration step Δt_int; the
actuator's controller runs ``S = Δt_int · controller_rate`` samples per step (e.g. 4 at
Δt_int = 1/1024 s and 4096 Hz). Each sample the desired displacement is a polynomial in the
targets — the corrector (interpolation through ``d[n+1]`` and the previous targets) when the
new target is known, the predictor (extrapolation through the previous targets only) while it
is not (Nakashima & Masaoka 1999; OpenFresco's event-driven predictor–corrector) — and goes
through the compensator, the command quantiser and the transfer system; the sensors read the
plant's displacement (noise, quantiser) and the specimen's force (backward differences of the
plant's displacement, noise).

Timing of one controller sample (a *tick*), the same in both clocks. The actuator is at sample
``k`` (time ``t_k``) with the reading ``x_m[k]`` taken at the end of the previous tick::

    phase' = phase + rate          # rate 1 except when slowed; phase in samples of the step
    x_d[k+1] = P(phase' / S)       # the desired displacement of sample k + 1
    u[k]   = quantise(compensator.command(x_d[k], x_m[k]))   # the benchmark's timing; a
                                   # compensator that uses_preview gets x_d[k+1] (the plant is
                                   # strictly proper: u[k] acts on x[k + 1])
    plant.advance(u[k])            # now at sample k + 1
    x_m[k+1] = quantise(x[k+1] + displacement noise)
    F_m[k+1] = specimen.force(x[k+1], x[k], x[k-1]) + force noise     # x: the plant's output

A step ends at the tick whose phase' reaches ``S`` with its target known: the measurement of
step ``n+1`` is ``(x_m, F_m)`` of that sample, i.e. taken at ``t_{n+1}``, the instant of the
target ``d[n+1]`` itself — what an explicit Newmark step needs (target ``d[n+1]`` → restoring
force ``r[n+1]``). The same reading is the ``x_m`` the compensator gets at the first tick of the
next step (each sample is read once; one noise draw per sample and sensor).

Two clocks:

* **simulated time** — :meth:`ContinuousActuator.step` sets the target before the step's first
  tick and runs its ``S`` ticks: no prediction, deterministic (same config and seeds → the
  same floats);
* **real time** — :meth:`ContinuousActuator.tick` once per controller deadline and
  :meth:`ContinuousActuator.set_next_target` whenever the integrator's target arrives
  (:mod:`pd_common.rths.realtime` drives them against the wall clock). While the target is
  missing the actuator follows the predictor; if it is still missing when the phase nears
  ``hold_at · S`` the rate falls smoothly (constant deceleration over ``slowdown_samples``
  ticks) to a hold at ``hold_at · S``; when it arrives the corrector takes over from the current
  desired displacement (the jump between predictor and corrector is spread linearly over the
  rest of the step) and the rate recovers at the same deceleration. Slowed ticks are counted.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from ..errors import RthsError
from .base import BENCHMARK_SPECIMEN, PhysicalSpecimen, SensorNoise, TransferSystem
from .compensation import Compensator, make_compensator
from .cpu_latency import CPU_LATENCY, check_cpu_latency
from .plant import plant_from_config

#: How targets are sub-stepped: the polynomial order of predictor and corrector.
INTERPOLATIONS = ('linear', 'cubic')
#: What the returned force contains: the load cell's reading, or that minus m_e·ẍ.
INERTIA_MODES = ('measured', 'subtract')

_KEYS = ('controller_rate', 'plant', 'compensator', 'specimen', 'noise', 'quantum', 'capacity',
         'interpolation', 'inertia', 'realtime')
_REALTIME_KEYS = ('hold_at', 'slowdown_samples', 'cpu_latency')
_SPECIMEN_KEYS = ('mass', 'stiffness', 'damping_ratio')
_NOISE_KEYS = ('displacement_power', 'force_power', 'seed')
# Nodes of the Lagrange polynomials, in steps relative to the last reached target d[n].
_CORRECTOR_NODES = {'linear': (0.0, 1.0), 'cubic': (-2.0, -1.0, 0.0, 1.0)}
_PREDICTOR_NODES = {'linear': (-1.0, 0.0), 'cubic': (-3.0, -2.0, -1.0, 0.0)}
_HISTORY = 4  # previous targets kept: enough for the cubic predictor
_NOISE_BLOCK = 8192  # standard normals drawn at a time (same sequence as one at a time)


@dataclass(frozen=True)
class ContinuousConfig:
    """The ``transfer_system:`` section of a site (and of the bridge driver's config).

    Attributes:
        plant: The ``plant:`` section (``{model: benchmark | ideal, perturbed, seed}``), built by
            :func:`pd_common.rths.plant.plant_from_config`.
        controller_rate: Controller samples per second, Hz (Δt_int must be a whole multiple of
            its period).
        compensator: Name of the registered compensator.
        compensator_parameters: Its parameters (the section's other keys).
        specimen: The specimen whose force the load cell reads; ``None``: the plant's own
            (``plant.specimen``, e.g. a perturbed k_e), else the benchmark's.
        noise: Sensor noise (``None``: none).
        quantum: Quantisation step of command and measured displacement, m (0: none).
        capacity: Actuator force capacity, N (a sample whose force reaches it makes the run
            invalid; ``inf``: none).
        interpolation: ``linear`` or ``cubic`` predictor–corrector polynomials.
        inertia: ``measured`` (the load cell's force) or ``subtract`` (minus m_e·ẍ of the
            plant's displacement, an ideal accelerometer: the integrator carries m_e itself).
        hold_at: Real time: the farthest phase, as a fraction of the step, the predictor goes
            while the next target is missing (the actuator holds there).
        slowdown_samples: Real time: controller samples to brake from full rate to the hold
            (and to recover).
        cpu_latency: Real time: the CPUs' wake-up latency to ask for while ticking, s
            (:mod:`.cpu_latency`); ``None``: ask nothing.
    """

    plant: Mapping[str, Any]
    controller_rate: float = 4096.0
    compensator: str = 'none'
    compensator_parameters: Mapping[str, Any] = field(default_factory=dict)
    specimen: PhysicalSpecimen | None = None
    noise: SensorNoise | None = None
    quantum: float = 0.0
    capacity: float = math.inf
    interpolation: str = 'linear'
    inertia: str = 'measured'
    hold_at: float = 0.8
    slowdown_samples: float = 2.0
    cpu_latency: float | None = CPU_LATENCY

    def __post_init__(self) -> None:
        """Check the fields (one-line :class:`RthsError` naming the field)."""
        where = 'transfer_system'
        _check_positive(self.controller_rate, f'{where}.controller_rate', 'Hz')
        if not isinstance(self.plant, Mapping):
            msg = f'{where}.plant: must be a mapping with a model, got {self.plant!r}'
            raise RthsError(msg)
        object.__setattr__(self, 'plant', MappingProxyType(dict(self.plant)))
        object.__setattr__(self, 'compensator_parameters',
                           MappingProxyType(dict(self.compensator_parameters)))
        if not (math.isfinite(self.quantum) and self.quantum >= 0.0):
            msg = f'{where}.quantum: must be a number >= 0 [m], got {self.quantum!r}'
            raise RthsError(msg)
        if not (self.capacity > 0.0):  # inf allowed
            msg = f'{where}.capacity: must be a positive number [N], got {self.capacity!r}'
            raise RthsError(msg)
        if self.interpolation not in INTERPOLATIONS:
            msg = (f'{where}.interpolation: must be one of {", ".join(INTERPOLATIONS)}, '
                   f'got {self.interpolation!r}')
            raise RthsError(msg)
        if self.inertia not in INERTIA_MODES:
            msg = (f'{where}.inertia: must be one of {", ".join(INERTIA_MODES)}, '
                   f'got {self.inertia!r}')
            raise RthsError(msg)
        if not (math.isfinite(self.hold_at) and 0.0 < self.hold_at < 1.0):
            msg = (f'{where}.realtime.hold_at: must be a fraction of the step in (0, 1), '
                   f'got {self.hold_at!r}')
            raise RthsError(msg)
        _check_positive(self.slowdown_samples, f'{where}.realtime.slowdown_samples', 'samples')
        if self.cpu_latency is not None:  # (null: nothing is asked)
            check_cpu_latency(self.cpu_latency, f'{where}.realtime.cpu_latency')

    @property
    def controller_dt(self) -> float:
        """The controller's sample period, s."""
        return 1.0 / self.controller_rate


def _check_positive(value: object, where: str, unit: str) -> float:
    if (isinstance(value, bool) or not isinstance(value, int | float)
            or not math.isfinite(value) or value <= 0.0):
        msg = f'{where}: must be a positive finite number [{unit}], got {value!r}'
        raise RthsError(msg)
    return float(value)


def _number(raw: Mapping[str, Any], key: str, where: str, *, minimum: float = 0.0,
            strict: bool = False, unit: str = '') -> float:
    value = raw[key]
    ok = (isinstance(value, int | float) and not isinstance(value, bool)
          and math.isfinite(value) and (value > minimum if strict else value >= minimum))
    if not ok:
        bound = f'> {minimum:g}' if strict else f'>= {minimum:g}'
        unit_text = f' [{unit}]' if unit else ''
        msg = f'{where}.{key}: must be a finite number {bound}{unit_text}, got {value!r}'
        raise RthsError(msg)
    return float(value)


def _mapping(value: Any, where: str, keys: tuple[str, ...]) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        msg = f'{where}: must be a mapping ({", ".join(keys)}), got {value!r}'
        raise RthsError(msg)
    unknown = [key for key in value if key not in keys]
    if unknown:
        msg = f'{where}.{unknown[0]}: unknown key (keys: {", ".join(keys)})'
        raise RthsError(msg)
    return value


def _prefixed(error: RthsError, where: str) -> RthsError:
    text = str(error)
    return RthsError(text if text.startswith(where) else f'{where}: {text}')


def continuous_from_config(section: Mapping[str, Any], where: str) -> ContinuousConfig:
    """Parse and check a ``transfer_system:`` section.

    The plant and the compensator are built once at the controller rate to check their
    sections (unknown model, unknown or ill-typed parameter).

    Args:
        section: The mapping (see the module's docstring and :class:`ContinuousConfig`).
        where: Where it is, for the messages (e.g. ``test.yaml: sites.lab1.transfer_system``).

    Raises:
        RthsError: One line naming ``where`` and the key.
    """
    raw = _mapping(section, where, _KEYS)
    if 'plant' not in raw:
        msg = f'{where}.plant: missing (e.g. {{model: benchmark}})'
        raise RthsError(msg)
    kwargs: dict[str, Any] = {'plant': raw['plant']}
    if 'controller_rate' in raw:
        kwargs['controller_rate'] = _number(raw, 'controller_rate', where, strict=True,
                                            unit='Hz')
    rate = kwargs.get('controller_rate', 4096.0)
    if 'compensator' in raw:
        compensator = raw['compensator']
        if not isinstance(compensator, Mapping) or not isinstance(compensator.get('name'), str):
            msg = (f'{where}.compensator: must be a mapping with a name and its parameters, '
                   f'got {compensator!r}')
            raise RthsError(msg)
        kwargs['compensator'] = compensator['name']
        kwargs['compensator_parameters'] = {key: value for key, value in compensator.items()
                                            if key != 'name'}
    if raw.get('specimen') is not None:
        specimen = _mapping(raw['specimen'], f'{where}.specimen', _SPECIMEN_KEYS)
        missing = [key for key in _SPECIMEN_KEYS if key not in specimen]
        if missing:
            msg = f'{where}.specimen.{missing[0]}: missing'
            raise RthsError(msg)
        here = f'{where}.specimen'
        kwargs['specimen'] = PhysicalSpecimen(
            mass=_number(specimen, 'mass', here, unit='kg'),
            stiffness=_number(specimen, 'stiffness', here, strict=True, unit='N/m'),
            damping_ratio=_number(specimen, 'damping_ratio', here))
    if raw.get('noise') is not None:
        here = f'{where}.noise'
        noise = _mapping(raw['noise'], here, _NOISE_KEYS)
        seed = noise.get('seed', 0)
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            msg = f'{here}.seed: must be an integer >= 0, got {seed!r}'
            raise RthsError(msg)
        powers = {key: _number(noise, key, here, unit=unit) if key in noise else 0.0
                  for key, unit in (('displacement_power', 'm2 s'), ('force_power', 'N2 s'))}
        kwargs['noise'] = SensorNoise(seed=seed, **powers)
    if 'quantum' in raw:
        kwargs['quantum'] = _number(raw, 'quantum', where, unit='m')
    if raw.get('capacity') is not None:
        kwargs['capacity'] = _number(raw, 'capacity', where, strict=True, unit='N')
    for key, choices in (('interpolation', INTERPOLATIONS), ('inertia', INERTIA_MODES)):
        if key in raw:
            if raw[key] not in choices:
                msg = f'{where}.{key}: must be one of {", ".join(choices)}, got {raw[key]!r}'
                raise RthsError(msg)
            kwargs[key] = raw[key]
    if raw.get('realtime') is not None:
        here = f'{where}.realtime'
        realtime = _mapping(raw['realtime'], here, _REALTIME_KEYS)
        if 'hold_at' in realtime:
            kwargs['hold_at'] = _number(realtime, 'hold_at', here, strict=True)
        if 'slowdown_samples' in realtime:
            kwargs['slowdown_samples'] = _number(realtime, 'slowdown_samples', here,
                                                 strict=True, unit='samples')
        if 'cpu_latency' in realtime:
            kwargs['cpu_latency'] = (None if realtime['cpu_latency'] is None else
                                     _number(realtime, 'cpu_latency', here, unit='s'))
    try:
        config = ContinuousConfig(**kwargs)
    except RthsError as error:
        raise _prefixed_config(error, where) from None
    plant_from_config(config.plant, 1.0 / rate, f'{where}.plant')
    try:
        make_compensator(config.compensator, 1.0 / rate, config.compensator_parameters)
    except RthsError as error:
        raise _prefixed(error, f'{where}.compensator') from None
    return config


def _prefixed_config(error: RthsError, where: str) -> RthsError:
    text = str(error)
    if text.startswith('transfer_system'):
        text = where + text[len('transfer_system'):]
    return RthsError(text)


def _lagrange(nodes: tuple[float, ...], s: float) -> tuple[float, ...]:
    """The Lagrange weights of ``nodes`` at ``s`` (exactly 1 and 0s at a node)."""
    weights = []
    for m, node in enumerate(nodes):
        weight = 1.0
        for j, other in enumerate(nodes):
            if j != m:
                weight *= (s - other) / (node - other)
        weights.append(weight)
    return tuple(weights)


def _weighted(weights: tuple[float, ...], values: list[float]) -> float:
    total = 0.0
    for weight, value in zip(weights, values, strict=True):
        total += weight * value
    return total


@dataclass(frozen=True)
class ContinuousMeasurement:
    """What the actuator gives back at the end of one integration step.

    ``displacement`` and ``force`` are the readings of the step's last sample (time
    ``time`` = t_{n+1}); the arrays hold the step's samples in order, each at the sample the
    tick moved to (``times``: the actuator's simulated time of each, uniform unless slowed).

    Attributes:
        step: Index of the completed step (1 for the first).
        time: Simulated time of its end, s (step · Δt_int).
        target: The step's target d[n+1], m.
        displacement: Measured displacement x_m at the end of the step, m.
        force: The force returned to the integrator, N (the load cell's, or minus m_e·ẍ with
            ``inertia: subtract``).
        peak_force: Largest |actuator force| (noise-free) over the step's samples, N.
        capacity_exceeded: Whether a sample of this step reached the capacity.
        valid: False once any sample of the run reached the capacity (the run is invalid).
        times: Simulated time of each sample, s.
        desired: Desired displacement x_d of each sample, m.
        command: Command u sent at the previous sample to reach it (quantised), m.
        measured: Measured displacement x_m of each sample, m.
        measured_force: Load-cell force F_m of each sample (with noise), N.
        predicted_samples: Samples of the step computed while the target was missing.
        slowed_samples: Samples of the step at less than the full rate.
    """

    step: int
    time: float
    target: float
    displacement: float
    force: float
    peak_force: float
    capacity_exceeded: bool
    valid: bool
    times: np.ndarray
    desired: np.ndarray
    command: np.ndarray
    measured: np.ndarray
    measured_force: np.ndarray
    predicted_samples: int = 0
    slowed_samples: int = 0

    @property
    def samples(self) -> int:
        """Controller samples of the step."""
        return len(self.desired)


@dataclass
class ActuatorCounters:
    """Counts of the actuator's controller samples since the last reset.

    Attributes:
        samples: Ticks.
        steps: Completed integration steps.
        predicted_samples: Ticks while the next target was missing (predictor).
        slowed_samples: Ticks at less than the full rate.
        held_samples: Ticks at rate 0 (holding at ``hold_at``).
        slowdowns: Times the actuator began to slow down.
    """

    samples: int = 0
    steps: int = 0
    predicted_samples: int = 0
    slowed_samples: int = 0
    held_samples: int = 0
    slowdowns: int = 0

    @property
    def slowdown_fraction(self) -> float:
        """Slowed ticks over all ticks (0 before the first)."""
        return self.slowed_samples / self.samples if self.samples else 0.0


class ContinuousActuator:
    """One site's actuator in continuous motion: controller, transfer system and sensors.

    Args:
        config: The site's ``transfer_system`` configuration.
        integration_dt: Δt_int, s: a whole multiple of the controller period.
        plant: A transfer system to use instead of the one ``config.plant`` names (its ``dt``
            must be the controller period).
        compensator: A compensator to use instead of the one ``config`` names.

    Raises:
        RthsError: Δt_int not a whole multiple of the controller period, or a plant or
            compensator for another period; in real time (:meth:`tick` without the target), a
            ``slowdown_samples`` whose braking does not fit before ``hold_at``.
    """

    def __init__(self, config: ContinuousConfig, integration_dt: float, *,
                 plant: TransferSystem | None = None,
                 compensator: Compensator | None = None) -> None:
        """Build the actuator at rest."""
        self.config = config
        self.controller_dt = config.controller_dt
        integration_dt = float(integration_dt)
        ratio = integration_dt * config.controller_rate
        samples = round(ratio) if math.isfinite(ratio) else 0
        if samples < 1 or abs(ratio - samples) > 1e-9 * samples:
            msg = (f'integration dt {integration_dt!r} s must be a whole multiple of the '
                   f'controller period 1/{config.controller_rate:g} s')
            raise RthsError(msg)
        self.integration_dt = integration_dt
        self.samples_per_step = samples
        self.plant = plant if plant is not None else plant_from_config(
            config.plant, self.controller_dt, 'transfer_system.plant')
        self.compensator = compensator if compensator is not None else make_compensator(
            config.compensator, self.controller_dt, config.compensator_parameters)
        for name, piece in (('plant', self.plant), ('compensator', self.compensator)):
            if not math.isclose(piece.dt, self.controller_dt, rel_tol=1e-12):
                msg = (f'{name} dt {piece.dt!r} s is not the controller period '
                       f'{self.controller_dt!r} s')
                raise RthsError(msg)
        own = getattr(self.plant, 'specimen', None)
        self.specimen: PhysicalSpecimen = (
            config.specimen if config.specimen is not None
            else own if isinstance(own, PhysicalSpecimen) else BENCHMARK_SPECIMEN)
        hold = config.hold_at * samples
        # Real time only (a tick without the target): the braking must fit before the hold.
        self._realtime_problem = (
            f'transfer_system.realtime.slowdown_samples: {config.slowdown_samples:g} samples '
            f'of braking do not fit before hold_at ({hold:g} of the {samples} samples of a '
            f'step); at most {2.0 * hold:g}') if config.slowdown_samples / 2.0 > hold else None
        self._hold_phase = hold
        self._acceleration = 1.0 / config.slowdown_samples
        nodes_c = _CORRECTOR_NODES[config.interpolation]
        self._corrector_nodes = nodes_c
        self._predictor_nodes = _PREDICTOR_NODES[config.interpolation]
        # Corrector weights at the integer phases 1 … S (the simulated-time path).
        self._corrector_table = [_lagrange(nodes_c, j / samples) for j in range(samples + 1)]
        noise = config.noise
        self._displacement_std = noise.displacement_std(self.controller_dt) if noise else 0.0
        self._force_std = noise.force_std(self.controller_dt) if noise else 0.0
        self._noisy = self._displacement_std > 0.0 or self._force_std > 0.0
        self.counters = ActuatorCounters()
        self.reset()

    # -- state -------------------------------------------------------------------------------
    def reset(self) -> None:
        """Back to rest at sample 0 of step 1: plant, compensator, sensors, counters.

        The previous targets are 0 (the structure at rest before the start).
        """
        self.plant.reset()
        self.compensator.reset()
        noise = self.config.noise
        self._rng = noise.generator() if noise is not None and self._noisy else None
        self._normals = np.empty(0)
        self._normal_index = 0
        self._history = [0.0] * _HISTORY  # d[n-3] … d[n]
        self._next_target: float | None = None
        self._phase = 0.0
        self._rate = 1.0
        self._slowing = False
        self._offset = 0.0          # predictor − corrector at the target's arrival
        self._arrival_phase = 0.0
        self._desired = 0.0          # x_d of the current sample
        self._step = 0
        self._valid = True
        self.first_invalid_time: float | None = None
        self.counters = ActuatorCounters()
        y = self.plant.output()
        self._y1 = y                 # plant displacement at the current sample …
        self._y2 = y                 # … and the one before
        self._x_m = self._read_displacement(y)
        self._read_force_noise()     # sample 0's force draw (keeps one pair per sample)
        self._clear_step()

    def _clear_step(self) -> None:
        self._times: list[float] = []
        self._desired_log: list[float] = []
        self._command_log: list[float] = []
        self._measured_log: list[float] = []
        self._force_log: list[float] = []
        self._peak = 0.0
        self._breach = False
        self._step_predicted = 0
        self._step_slowed = 0

    @property
    def measured_displacement(self) -> float:
        """x_m of the current sample, m."""
        return self._x_m

    @property
    def target_pending(self) -> bool:
        """Whether the current step's target is known (set and not yet reached)."""
        return self._next_target is not None

    @property
    def phase(self) -> float:
        """Controller samples into the current step (fractional while slowed)."""
        return self._phase

    @property
    def completed_steps(self) -> int:
        """Integration steps completed since the reset."""
        return self._step

    @property
    def valid(self) -> bool:
        """False once a sample reached the actuator's capacity."""
        return self._valid

    # -- sensors -----------------------------------------------------------------------------
    def _normal(self) -> float:
        if self._normal_index >= len(self._normals):
            assert self._rng is not None
            self._normals = self._rng.standard_normal(_NOISE_BLOCK)
            self._normal_index = 0
        value = float(self._normals[self._normal_index])
        self._normal_index += 1
        return value

    def _read_displacement(self, y: float) -> float:
        if self._rng is not None:
            y = y + self._displacement_std * self._normal()
        quantum = self.config.quantum
        return round(y / quantum) * quantum if quantum > 0.0 else y

    def _read_force_noise(self) -> float:
        return self._force_std * self._normal() if self._rng is not None else 0.0

    # -- targets -----------------------------------------------------------------------------
    def set_next_target(self, target: float) -> None:
        """The integrator's target d[n+1] of the current step has arrived.

        Raises:
            RthsError: A non-finite target, or the step's target already set.
        """
        target = float(target)
        if not math.isfinite(target):
            msg = f'target of step {self._step + 1} must be finite, got {target!r}'
            raise RthsError(msg)
        if self._next_target is not None:
            msg = (f'target of step {self._step + 1} already set '
                   '(the next one may come once the step is measured)')
            raise RthsError(msg)
        self._next_target = target
        phase = self._phase
        self._arrival_phase = phase
        if phase > 0.0:
            corrected = self._polynomial(self._corrector_nodes, phase / self.samples_per_step,
                                         target)
            self._offset = self._desired - corrected
        else:
            self._offset = 0.0

    def _polynomial(self, nodes: tuple[float, ...], s: float, target: float | None) -> float:
        """The corrector (``target`` d[n+1] given) or the predictor (``None``) at ``s``."""
        history = self._history
        values = ([*history[len(history) - len(nodes) + 1:], target] if target is not None
                  else history[len(history) - len(nodes):])
        return _weighted(_lagrange(nodes, s), values)

    def _desired_at(self, phase: float) -> float:
        target = self._next_target
        samples = self.samples_per_step
        if target is None:
            return self._polynomial(self._predictor_nodes, phase / samples, None)
        if self._offset == 0.0 and phase == int(phase):  # simulated time: tabulated weights
            weights = self._corrector_table[int(phase)]
            history = self._history
            return _weighted(weights, [*history[len(history) - len(weights) + 1:], target])
        corrected = self._polynomial(self._corrector_nodes, phase / samples, target)
        remaining = (samples - phase) / (samples - self._arrival_phase)
        return corrected + self._offset * remaining

    # -- one controller sample ---------------------------------------------------------------
    def tick(self) -> ContinuousMeasurement | None:
        """Run one controller sample (see the module's docstring for the ordering).

        Returns:
            The step's measurement if this sample completed it (its phase reached the end of
            the step with the target known), else ``None``.
        """
        phase = self._phase
        rate = self._rate
        samples = self.samples_per_step
        known = self._next_target is not None
        if known:
            rate = min(1.0, rate + self._acceleration)
            new_phase = min(phase + rate, float(samples))
        else:
            if self._realtime_problem is not None:
                raise RthsError(self._realtime_problem)
            acceleration = self._acceleration
            distance = self._hold_phase - phase
            stopping = acceleration * (math.sqrt(0.25 + 2.0 * distance / acceleration) - 0.5)
            rate = min(1.0, rate + acceleration, max(stopping, rate - acceleration))
            new_phase = min(phase + rate, self._hold_phase)
            rate = new_phase - phase
        increment = new_phase - phase
        desired = self._desired_at(new_phase)
        compensator = self.compensator
        command = compensator.command(desired if compensator.uses_preview else self._desired,
                                      self._x_m)
        quantum = self.config.quantum
        if quantum > 0.0:
            command = round(command / quantum) * quantum
        plant = self.plant
        plant.advance(command)
        y = plant.output()
        y1, y2 = self._y1, self._y2
        x_m = self._read_displacement(y)
        dt = self.controller_dt
        actuator_force = self.specimen.force(y, y1, y2, dt)
        load_cell = actuator_force + self._read_force_noise()
        self._y2, self._y1 = y1, y
        self._x_m = x_m
        self._desired = desired
        self._phase = new_phase
        self._rate = rate
        # counters and the step's log
        counters = self.counters
        counters.samples += 1
        slowed = increment < 1.0 - 1e-12
        if not known:
            counters.predicted_samples += 1
            self._step_predicted += 1
        if slowed:
            counters.slowed_samples += 1
            self._step_slowed += 1
            if increment <= 0.0:
                counters.held_samples += 1
            if not self._slowing and not known:
                counters.slowdowns += 1
            self._slowing = True
        else:
            self._slowing = False
        self._times.append((self._step + new_phase / samples) * self.integration_dt)
        self._desired_log.append(desired)
        self._command_log.append(command)
        self._measured_log.append(x_m)
        self._force_log.append(load_cell)
        magnitude = abs(actuator_force)
        self._peak = max(self._peak, magnitude)
        if magnitude >= self.config.capacity:
            self._breach = True
            if self._valid:
                self._valid = False
                self.first_invalid_time = self._times[-1]
        if not known or new_phase < samples:
            return None
        return self._complete(load_cell, y, y1, y2)

    def _complete(self, load_cell: float, y: float, y1: float, y2: float) -> ContinuousMeasurement:
        target = self._next_target
        assert target is not None
        force = load_cell
        if self.config.inertia == 'subtract':
            dt = self.controller_dt
            force -= self.specimen.mass * (y - 2.0 * y1 + y2) / (dt * dt)
        self._step += 1
        self.counters.steps += 1
        measurement = ContinuousMeasurement(
            step=self._step, time=self._step * self.integration_dt, target=target,
            displacement=self._x_m, force=force, peak_force=self._peak,
            capacity_exceeded=self._breach, valid=self._valid,
            times=np.array(self._times), desired=np.array(self._desired_log),
            command=np.array(self._command_log), measured=np.array(self._measured_log),
            measured_force=np.array(self._force_log),
            predicted_samples=self._step_predicted, slowed_samples=self._step_slowed)
        self._history = [*self._history[1:], target]
        self._next_target = None
        self._phase = 0.0
        self._offset = 0.0
        self._arrival_phase = 0.0
        self._clear_step()
        return measurement

    # -- simulated time ----------------------------------------------------------------------
    def step(self, target: float) -> ContinuousMeasurement:
        """Execute one integration step in simulated time.

        Set ``target`` (d[n+1]) and run the step's ``S`` controller samples.

        Raises:
            RthsError: A non-finite target, or a step already under way with its target set.
        """
        if self._phase != 0.0:
            msg = (f'step {self._step + 1}: the actuator is {self._phase:g} samples into the '
                   'step (real-time ticks without a target); reset first')
            raise RthsError(msg)
        self.set_next_target(target)
        while True:
            measurement = self.tick()
            if measurement is not None:
                return measurement
