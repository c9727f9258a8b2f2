"""The vRTHS benchmark as one call: options → run → J-values (``./pd rths_benchmark``).

:func:`run_benchmark` runs one case under one record with one controller, in the benchmark's
own loop (:mod:`.benchmark_loop`) or in this project's (:mod:`.native_loop`), on the nominal
plant or on plant ``i`` of the seed's perturbed plants
(:func:`pd_common.rths.plant.perturbed_plants`), with the benchmark's sensors: band-limited
white noise (seeded), 2⁻¹⁸ m converters and the ±8,900 N capacity. The noise floor is
``100 σ_noise / std(x_ref,1)``: the J2 no controller can go below (x_d of a run that tracks is
x_ref,1; the reference keeps the floor the same for every controller).

The record: the benchmark runs its records (``ElCentroAccelNoScaling.mat`` etc., which carry
5 s of zeros at each end) from 0 to their last time; a record without them (the shipped El
Centro) gets them here, a record with them is run as it is (:func:`benchmark_ground_motion`).

``ideal``: the transfer system of the loop's own error, x_m = x_d at every sample (no delay,
noise or converters). In the benchmark loop that is the perfect actuator of
:func:`~.benchmark_loop.run_benchmark_loop` (``x_m[k] = u[k] = x_d[k]``, the same sample); in
the native loop the ``ideal`` plant (``x[k+1] = u[k]``) driven by the compensator ``none``,
whose command at sample ``k`` is the next sample's desired displacement. Either way the
controller is ``none``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.typing import NDArray

from pd_common.resources import ResourceError, share_file
from pd_common.rths import (
    BENCHMARK_CAPACITY,
    BENCHMARK_NOISE,
    BENCHMARK_QUANTUM,
    IdealPlant,
    SensorNoise,
    TransferSystem,
    compensator_spec,
    make_compensator,
)
from pd_common.rths.plant import BenchmarkPlant, BenchmarkPlantParameters, perturbed_plants
from pd_core.dynamics.record_readers import read_ground_motion
from pd_core.errors import ConfigError

from .benchmark_loop import run_benchmark_loop
from .criteria import J_KEYS, j_criteria, native_j_criteria, noise_floor_percent
from .native_loop import native_test_file, run_native_loop
from .problem import benchmark_case, prepare_ground_motion, reference_response

__all__ = [
    'BRIDGE_PARAMETERS',
    'CONTROLLER_RATE',
    'DEFAULT_RECORD',
    'DEFAULT_RECORD_UNITS',
    'LOOPS',
    'PADDING',
    'BenchmarkOptions',
    'BenchmarkRecord',
    'BenchmarkRun',
    'benchmark_ground_motion',
    'j_table',
    'load_record',
    'native_benchmark_file',
    'perturbed_csv',
    'perturbed_statistics',
    'run_benchmark',
    'statistics_table',
    'write_test_file',
]

#: The benchmark's controller rate, Hz, and zeros before and after the record, s (added
#: only where the record does not hold them: :func:`~.problem.padding_needed`).
CONTROLLER_RATE = 4096.0
PADDING = 5.0
LOOPS = ('benchmark', 'native')
#: The shipped record (El Centro 1940 NS, in g) and the units of a text record by default.
DEFAULT_RECORD = ('data', 'ground_motions', 'elcentro_1940_ns_chopra.csv')
DEFAULT_RECORD_UNITS = 'g'


@dataclass(frozen=True)
class BenchmarkRecord:
    """A ground motion for the benchmark: acceleration (m/s²) at ``dt`` and where it came from."""

    acceleration: NDArray[np.float64]
    dt: float
    source: str


@dataclass(frozen=True)
class BenchmarkOptions:
    """What to run.

    Attributes:
        case: Benchmark case 1–4.
        intensity: Factor on the record (the benchmark's 0.4).
        controller: Registered compensator name.
        controller_parameters: Its parameters (the others keep their defaults).
        loop: ``benchmark`` or ``native``.
        seed: Seed of the sensor noise and of the perturbed plants.
        integration_dt: Native loop: Δt_int, s (a whole multiple of 1/4096 s).
        scheme: Native loop: the integration scheme.
        interpolation: Native loop: the predictor–corrector polynomial (linear or cubic).
        ideal: An ideal transfer system, x_m = x_d at every sample (module docstring), no
            noise, no converters: the loop's own error. Only with the controller ``none``.
    """

    case: int = 1
    intensity: float = 0.4
    controller: str = 'pi_p'
    controller_parameters: Mapping[str, Any] = field(default_factory=dict)
    loop: str = 'benchmark'
    seed: int = 0
    integration_dt: float = 1.0 / 1024.0
    scheme: str = 'newmark_explicit'
    interpolation: str = 'cubic'
    ideal: bool = False

    def __post_init__(self) -> None:
        """Check the options (one-line ConfigError naming the option)."""
        if self.case not in (1, 2, 3, 4):
            msg = f'--case: must be 1, 2, 3 or 4, got {self.case!r}'
            raise ConfigError(msg)
        if not (math.isfinite(self.intensity) and self.intensity > 0.0):
            msg = f'--intensity: must be a positive number, got {self.intensity!r}'
            raise ConfigError(msg)
        if self.loop not in LOOPS:
            msg = f'--loop: must be one of {", ".join(LOOPS)}, got {self.loop!r}'
            raise ConfigError(msg)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            msg = f'--seed: must be an integer >= 0, got {self.seed!r}'
            raise ConfigError(msg)
        ratio = self.integration_dt * CONTROLLER_RATE
        if not (math.isfinite(ratio) and ratio >= 1.0 - 1e-9
                and abs(ratio - round(ratio)) < 1e-9):
            msg = ('--dt: the integration step must be a whole multiple of 1/4096 s, got '
                   f'{self.integration_dt!r}')
            raise ConfigError(msg)
        compensator_spec(self.controller).resolve(self.controller_parameters)
        if self.ideal and self.controller != 'none':
            msg = ('--ideal: the ideal transfer system follows x_d itself (x_m = x_d at every '
                   f'sample); --controller must be none, got {self.controller!r}')
            raise ConfigError(msg)


@dataclass(frozen=True, eq=False)
class BenchmarkRun:
    """One run's histories and criteria.

    ``t``, ``x_d``, ``x_m`` are at the controller rate; ``t_floors``, ``floors`` and
    ``reference`` (the full structure at the same instants) at the loop's steps (the
    controller rate in the benchmark loop, Δt_int in the native one).
    """

    case: int
    controller: str
    controller_parameters: dict[str, Any]
    loop: str
    plant: str
    j: dict[str, float]
    noise_floor_percent: float
    capacity_reached: bool
    peak_force: float
    t: NDArray[np.float64]
    x_d: NDArray[np.float64]
    x_m: NDArray[np.float64]
    t_floors: NDArray[np.float64]
    floors: NDArray[np.float64]
    reference: NDArray[np.float64]
    completed: bool = True
    state: str = 'finished'

    @property
    def samples(self) -> int:
        """Controller samples of the run."""
        return int(self.t.size)

    def write_histories(self, path: Path) -> Path:
        """``histories.csv``: t, x_d, x_m at the controller rate.

        With the floors and the reference at the same instants where the loop has them (empty cells
        otherwise).
        """
        rows = ['t,x_d,x_m,x1,x2,x3,x1_ref,x2_ref,x3_ref']
        by_time = {round(float(tf) * CONTROLLER_RATE): i for i, tf in enumerate(self.t_floors)}
        for k in range(self.t.size):
            base = f'{self.t[k]:.9g},{self.x_d[k]:.9g},{self.x_m[k]:.9g}'
            i = by_time.get(round(float(self.t[k]) * CONTROLLER_RATE))
            if i is None:
                rows.append(base + ',,,,,,')
            else:
                values = [*self.floors[i], *self.reference[i]]
                rows.append(base + ',' + ','.join(f'{v:.9g}' for v in values))
        path.write_text('\n'.join(rows) + '\n', encoding='utf-8')
        return path


def load_record(path: str | Path | None, units: str | None = None) -> BenchmarkRecord:
    """The record of ``path`` (any format the readers support; ``None``: the shipped El Centro).

    ``units`` default: m/s² for a ``.mat`` file (the benchmark's own records), g otherwise.

    Raises:
        ConfigError: A file that cannot be read (one line naming it).
    """
    if path is None:
        try:
            file = share_file('pd_integrator', *DEFAULT_RECORD)
        except ResourceError as err:
            raise ConfigError(str(err)) from None
    else:
        file = Path(path)
    if units is None:
        units = 'm/s2' if file.suffix.lower() == '.mat' else DEFAULT_RECORD_UNITS
    if not file.is_file():
        msg = (f'--record {file}: not a regular file' if file.exists()
               else f'--record {file}: no such file')
        raise ConfigError(msg)
    try:
        motion = read_ground_motion(file, units=units)
    except (ValueError, OSError) as err:
        msg = f'--record {file}: {err}'
        raise ConfigError(msg) from None
    return BenchmarkRecord(acceleration=np.asarray(motion.acceleration, dtype=np.float64),
                           dt=float(motion.dt), source=file.name)


def _plant(options: BenchmarkOptions, perturbed: int | None
           ) -> tuple[BenchmarkPlantParameters, dict[str, Any], str]:
    if options.ideal:
        if perturbed is not None:
            msg = '--perturbed: an ideal transfer system has no perturbed plants'
            raise ConfigError(msg)
        return BenchmarkPlantParameters.nominal(), {'model': 'ideal'}, 'ideal'
    if perturbed is None:
        return BenchmarkPlantParameters.nominal(), {'model': 'benchmark'}, 'nominal'
    if perturbed < 0:
        msg = f'perturbed plant index must be >= 0, got {perturbed}'
        raise ConfigError(msg)
    params = perturbed_plants(options.seed, perturbed + 1)[perturbed]
    section = {'model': 'benchmark', 'perturbed': True, 'seed': options.seed,
               'index': perturbed}
    return params, section, f'perturbed {perturbed} (seed {options.seed})'


def _noise(options: BenchmarkOptions) -> SensorNoise | None:
    if options.ideal:
        return None
    return SensorNoise(BENCHMARK_NOISE.displacement_power, BENCHMARK_NOISE.force_power,
                       seed=options.seed)


def benchmark_ground_motion(record: BenchmarkRecord, intensity: float
                            ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The loop's sample times and ground acceleration (m/s²).

    ``record`` × ``intensity`` with the benchmark's 5 s of zeros at each end that does not hold
    them yet, at 4096 Hz (:func:`~.problem.prepare_ground_motion`). A record that carries them (the
    benchmark's own) runs from 0 to its last time: ``⌊t_end · 4096⌋ + 1`` samples, as the
    benchmark's model runs to ``tend = record(1, end)``.

    Raises:
        ConfigError: A bad record or intensity.
    """
    padding_samples = round(PADDING / record.dt)
    return prepare_ground_motion(record.acceleration, record.dt, intensity, CONTROLLER_RATE,
                                 padding_samples * record.dt)


def run_benchmark(options: BenchmarkOptions, record: BenchmarkRecord,
                  perturbed: int | None = None) -> BenchmarkRun:
    """Run the benchmark: the nominal plant, or perturbed plant ``perturbed`` of the seed.

    Raises:
        ConfigError: Bad options or record (one line).
    """
    case = benchmark_case(options.case)
    params, _section, plant_label = _plant(options, perturbed)
    parameters = compensator_spec(options.controller).resolve(options.controller_parameters)
    h = 1.0 / CONTROLLER_RATE
    t, ag = benchmark_ground_motion(record, options.intensity)
    reference = reference_response(case, t, ag)
    noise = _noise(options)
    noise_std = noise.displacement_std(h) if noise is not None else 0.0
    quantum = 0.0 if options.ideal else BENCHMARK_QUANTUM
    if options.loop == 'benchmark':
        # --ideal: the perfect actuator, x_m[k] = u[k] = x_d[k] (the plant is not used).
        plant: TransferSystem = IdealPlant(h) if options.ideal else BenchmarkPlant(h, params)
        result = run_benchmark_loop(
            case, t, ag, make_compensator(options.controller, h, parameters), plant,
            params.specimen, noise, quantum, BENCHMARK_CAPACITY,
            perfect_actuator=options.ideal)
        j = j_criteria(result.x_d, result.x_m, result.floors, reference, h)
        return BenchmarkRun(
            case=options.case, controller=options.controller,
            controller_parameters=parameters, loop=options.loop, plant=plant_label, j=j,
            noise_floor_percent=noise_floor_percent(noise_std, reference[:, 0]),
            capacity_reached=result.capacity_reached, peak_force=result.peak_force,
            t=result.t, x_d=result.x_d, x_m=result.x_m, t_floors=result.t,
            floors=result.floors, reference=reference)
    native = run_native_loop(native_benchmark_file(options, record, perturbed),
                             source='--loop native')
    steps = round(options.integration_dt * CONTROLLER_RATE)
    n_samples = native.x_m.size
    at_samples = reference[1:1 + n_samples]
    floors_reference = reference[::steps][:native.floors.shape[0]]
    j = native_j_criteria(native.x_d, native.x_m, at_samples, native.floors, floors_reference,
                          h)
    return BenchmarkRun(
        case=options.case, controller=options.controller, controller_parameters=parameters,
        loop=options.loop, plant=plant_label, j=j,
        noise_floor_percent=noise_floor_percent(noise_std, reference[:, 0]),
        capacity_reached=native.capacity_reached, peak_force=native.peak_force,
        t=native.t_samples, x_d=native.x_d, x_m=native.x_m, t_floors=native.t_steps,
        floors=native.floors, reference=floors_reference, completed=native.completed,
        state=native.state)


def native_benchmark_file(options: BenchmarkOptions, record: BenchmarkRecord,
                          perturbed: int | None = None, *,
                          bridge: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The native loop of ``options`` as a test file (a mapping).

    The site ``lab1`` with its ``transfer_system`` (plant, compensator, sensors, capacity) and, for
    a run through the node graph, its ``bridge`` parameters.
    """
    case = benchmark_case(options.case)
    params, plant_section, _label = _plant(options, perturbed)
    parameters = compensator_spec(options.controller).resolve(options.controller_parameters)
    transfer_system: dict[str, Any] = {
        'plant': plant_section, 'controller_rate': CONTROLLER_RATE,
        'compensator': {'name': options.controller, **parameters},
        'quantum': 0.0 if options.ideal else BENCHMARK_QUANTUM,
        'capacity': BENCHMARK_CAPACITY, 'interpolation': options.interpolation,
        'inertia': 'subtract'}
    noise = _noise(options)
    if noise is not None:
        transfer_system['noise'] = {'displacement_power': noise.displacement_power,
                                    'force_power': noise.force_power, 'seed': noise.seed}
    return native_test_file(
        case, record.acceleration, record.dt, padding_samples=round(PADDING / record.dt),
        intensity=options.intensity, integration_dt=options.integration_dt,
        transfer_system=transfer_system, specimen=params.specimen, scheme=options.scheme,
        test_id=f'vrths-case{options.case}', bridge=bridge)


#: The bridge parameters of the written test file's site: the transfer system driver and
#: limits that hold the benchmark's motion (its stroke is a few mm) with a margin.
BRIDGE_PARAMETERS: dict[str, Any] = {'driver': 'transfer_system', 'max_displacement': 0.05,
                                     'max_increment': 0.005, 'max_force': 8900.0}


def write_test_file(options: BenchmarkOptions, record: BenchmarkRecord, path: Path) -> Path:
    """Write the native loop as a YAML test file for ``./pd run FILE --site bridge``.

    Raises:
        FileExistsError: ``path`` exists (a file is never replaced).
        OSError: The file cannot be written.
    """
    raw = native_benchmark_file(options, record, bridge=BRIDGE_PARAMETERS)
    header = (f'# The vRTHS benchmark, case {options.case}, {record.source} x'
              f'{options.intensity:g}, controller {options.controller}, through this '
              'project\'s integrator:\n# ./pd run THIS_FILE --site bridge   (the bridge runs '
              'the transfer system at 4096 Hz)\n')
    text = header + yaml.safe_dump(raw, sort_keys=False, width=100)
    with path.open('x', encoding='utf-8') as stream:
        stream.write(text)
    return path


def j_table(rows: Mapping[str, Mapping[str, float]], noise_floor: float | None = None) -> str:
    """A text table: one row per entry, columns J1 (ms) … J9 (%), and the noise floor."""
    header = f'{"":<22}' + ''.join(f'{key:>9}' for key in J_KEYS)
    lines = [header + (f'{"floor %":>9}' if noise_floor is not None else '')]
    for name, j in rows.items():
        line = f'{name:<22}' + ''.join(f'{j[key]:9.3f}' for key in J_KEYS)
        if noise_floor is not None:
            line += f'{noise_floor:9.3f}'
        lines.append(line)
    return '\n'.join(lines)


def perturbed_statistics(runs: Sequence[BenchmarkRun]) -> dict[str, dict[str, float]]:
    """Per J (and the noise floor): mean, std (n − 1) and worst (the largest) over ``runs``."""
    stats: dict[str, dict[str, float]] = {}
    for key in (*J_KEYS, 'noise_floor_percent'):
        values = np.array([run.j.get(key, run.noise_floor_percent) for run in runs])
        stats[key] = {'mean': float(values.mean()),
                      'std': float(values.std(ddof=1)) if values.size > 1 else 0.0,
                      'worst': float(values.max())}
    stats['capacity_reached'] = {'count': float(sum(run.capacity_reached for run in runs))}
    return stats


def statistics_table(stats: Mapping[str, Mapping[str, float]]) -> str:
    """The mean / std / worst rows of :func:`perturbed_statistics`."""
    rows = {name: {key: stats[key][name] for key in J_KEYS} for name in ('mean', 'std', 'worst')}
    return j_table(rows)


def perturbed_csv(runs: Sequence[BenchmarkRun]) -> str:
    """One row per perturbed plant: its label, J1–J9, the noise floor and the peak force."""
    lines = ['plant,' + ','.join(J_KEYS) + ',noise_floor_percent,peak_force,capacity_reached']
    for run in runs:
        lines.append(f'"{run.plant}",' + ','.join(f'{run.j[key]:.6g}' for key in J_KEYS)
                     + f',{run.noise_floor_percent:.6g},{run.peak_force:.6g},'
                     f'{str(run.capacity_reached).lower()}')
    return '\n'.join(lines) + '\n'
