"""A run's outputs: ``response.csv``, ``summary.json`` and the figures.

The same functions serve the node-graph run, the ROS-free run and the bag replay.

Tracking monitors (thesis section 3.4.3): from the committed history, the command ``x`` (the
computed displacement sent to the specimen) against the measured displacement ``xm``:
``tracking.csv`` holds per DOF the tracking error ``xm - x`` and the running tracking indicator
of Mercan and Ricles (``pd_actuator_bridge.core.error_models.tracking_indicator``: the area of
the measured-vs-command loop, m²; **positive = energy removed** from the test (measured leading
the command, like extra damping), **negative = energy added** (measured lagging, like negative
damping); times the specimen stiffness it is an energy). ``summary.json`` gets a ``tracking``
block and ``tracking.png`` shows measured vs command displacement and both histories.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_common.experimental import tracking_error, tracking_indicator

from ...plotting import pyplot

if TYPE_CHECKING:
    from .energy import EnergyHistory
    from .history import ResponseHistory

RESPONSE_CSV = 'response.csv'
ENERGY_CSV = 'energy.csv'
TRACKING_CSV = 'tracking.csv'
SUMMARY_JSON = 'summary.json'
FIGURES = ('displacement.png', 'velocity.png', 'acceleration.png', 'force_deformation.png',
           'energy.png', 'tracking.png')
TRACKING_SIGN = ('positive = energy removed from the test (measured leading the command), '
                 'negative = energy added (measured lagging the command)')


def write_columns_csv(columns: dict[str, np.ndarray], path: str | Path) -> Path:
    """Write named columns; floats with 17 significant digits (exact), ``step`` as integer."""
    path = Path(path)
    names = list(columns)
    data = np.column_stack([columns[name] for name in names])
    formats = ['%.17g'] * len(names)
    if 'step' in names:
        formats[names.index('step')] = '%d'
    np.savetxt(path, data, fmt=formats, delimiter=',', header=','.join(names), comments='')
    return path


def write_response_csv(history: ResponseHistory, path: str | Path) -> Path:
    """Write the committed history (``response.csv``)."""
    return write_columns_csv(history.columns(), path)


def write_energy_csv(history: ResponseHistory, energy: EnergyHistory, path: str | Path
                     ) -> Path:
    """Write the energy balance per step (``energy.csv``)."""
    return write_columns_csv({'time': history.time, 'step': history.steps,
                              **energy.columns()}, path)


@dataclass(frozen=True)
class TrackingHistory:
    """Tracking monitors of a committed history, one row per step (step 0 first).

    Attributes:
        dof_names: DOF names.
        command: commanded (computed) displacement x [m], shape (rows, n_dof).
        measured: measured displacement xm [m], the same shape.
        error: tracking error ``xm - x`` [m].
        indicator: running tracking indicator [m²] (positive: energy removed, negative:
            energy added).
    """

    dof_names: tuple[str, ...]
    command: np.ndarray
    measured: np.ndarray
    error: np.ndarray
    indicator: np.ndarray

    def columns(self) -> dict[str, np.ndarray]:
        """Per DOF ``error_<dof>`` [m] and ``indicator_<dof>`` [m²], for ``tracking.csv``."""
        result: dict[str, np.ndarray] = {}
        for j, name in enumerate(self.dof_names):
            result[f'error_{name}'] = self.error[:, j]
            result[f'indicator_{name}'] = self.indicator[:, j]
        return result

    def summary(self) -> dict[str, Any]:
        """The ``tracking`` block of ``summary.json``.

        Per DOF the largest |error|, the RMS error and the final tracking indicator (with its
        extremes over the run), plus the units and the sign convention.
        """
        dofs: dict[str, Any] = {}
        rows = self.error.shape[0]
        for j, name in enumerate(self.dof_names):
            error, indicator = self.error[:, j], self.indicator[:, j]
            dofs[name] = {
                'max_abs_error': float(np.max(np.abs(error))) if rows else math.nan,
                'rms_error': float(np.sqrt(np.mean(error ** 2))) if rows else math.nan,
                'final_indicator': float(indicator[-1]) if rows else math.nan,
                'min_indicator': float(np.min(indicator)) if rows else math.nan,
                'max_indicator': float(np.max(indicator)) if rows else math.nan,
            }
        return {'units': {'error': 'm', 'indicator': 'm^2'}, 'error': 'measured - command',
                'indicator_sign': TRACKING_SIGN, 'dofs': dofs}


def tracking_history(history: ResponseHistory) -> TrackingHistory:
    """Tracking error and indicator of the committed rows (command ``x``, measured ``xm``)."""
    n = history.n_committed
    command = history.displacement[:n]
    measured = history.measured_displacement[:n]
    return TrackingHistory(dof_names=tuple(history.dof_names), command=command,
                           measured=measured, error=tracking_error(command, measured),
                           indicator=tracking_indicator(command, measured))


def write_tracking_csv(history: ResponseHistory, tracking: TrackingHistory, path: str | Path
                       ) -> Path:
    """Write the tracking monitors per step (``tracking.csv``)."""
    return write_columns_csv({'time': history.time, 'step': history.steps,
                              **tracking.columns()}, path)


def read_response_csv(path: str | Path) -> dict[str, np.ndarray]:
    """Read a ``response.csv`` back into named columns."""
    path = Path(path)
    with path.open(encoding='utf-8') as stream:
        names = stream.readline().strip().split(',')
    data = np.loadtxt(path, delimiter=',', skiprows=1, ndmin=2)
    return {name: data[:, i] for i, name in enumerate(names)}


def _peak(time: np.ndarray, values: np.ndarray) -> dict[str, float]:
    if values.size == 0:
        return {'value': math.nan, 'abs': math.nan, 'time': math.nan}
    index = int(np.argmax(np.abs(values)))
    return {'value': float(values[index]), 'abs': float(abs(values[index])),
            'time': float(time[index])}


def summarize(history: ResponseHistory, **info: Any) -> dict[str, Any]:
    """Peaks (with their times), residual displacement and run information.

    Args:
        history: the committed response.
        **info: run information merged into the summary (scheme, omega_dt, dt, wall time,
            retries, ignored messages, state, ...).

    ``residual_displacement`` is the displacement at the last committed step; ``peaks`` holds,
    per DOF, the largest absolute displacement, velocity, relative and absolute acceleration and
    restoring force with their signed values and times.
    """
    time = history.time
    n = history.n_committed
    ground = history.ground_acceleration[:n]
    dofs: dict[str, Any] = {}
    for j, name in enumerate(history.dof_names):
        x = history.displacement[:n, j]
        dofs[name] = {
            'peaks': {
                'displacement': _peak(time, x),
                'velocity': _peak(time, history.velocity[:n, j]),
                'acceleration': _peak(time, history.acceleration[:n, j]),
                'absolute_acceleration': _peak(time, history.acceleration[:n, j] + ground),
                'restoring_force': _peak(time, history.restoring_force[:n, j]),
            },
            'residual_displacement': float(x[-1]) if n else math.nan,
            'max_measurement_error': (float(np.max(np.abs(
                history.measured_displacement[:n, j] - x))) if n else math.nan),
        }
    summary: dict[str, Any] = {
        'dt': history.dt,
        'steps': max(n - 1, 0),
        'duration': float(time[-1]) if n else 0.0,
        'units': {'displacement': 'm', 'velocity': 'm/s', 'acceleration': 'm/s^2',
                  'force': 'N', 'time': 's'},
        'peak_ground_acceleration': _peak(time, ground),
        'dofs': dofs,
    }
    summary.update(info)
    return summary


def write_summary(summary: dict[str, Any], path: str | Path) -> Path:
    """Write ``summary.json`` (NaN becomes null)."""
    path = Path(path)

    def clean(value: Any) -> Any:
        if isinstance(value, float) and not math.isfinite(value):
            return None
        if isinstance(value, dict):
            return {key: clean(item) for key, item in value.items()}
        if isinstance(value, (list, tuple)):
            return [clean(item) for item in value]
        return value

    path.write_text(json.dumps(clean(summary), indent=2) + '\n', encoding='utf-8')
    return path


def write_figures(history: ResponseHistory, directory: str | Path, *, title: str = ''
                  ) -> list[Path]:
    """Displacement, velocity and acceleration histories and the force-deformation loop.

    Like the thesis's Figures 5.4–5.7, one line per DOF.
    """
    plt = pyplot()
    directory = Path(directory)
    n = history.n_committed
    time = history.time
    series = (
        ('displacement.png', history.displacement, 'Displacement [m]', 'Displacement response'),
        ('velocity.png', history.velocity, 'Velocity [m/s]', 'Velocity response'),
        ('acceleration.png', history.acceleration, 'Acceleration [m/s²]',
         'Acceleration response (relative)'),
    )
    written: list[Path] = []
    for filename, values, ylabel, heading in series:
        figure, axes = plt.subplots(figsize=(9, 4), layout='constrained')
        for j, name in enumerate(history.dof_names):
            axes.plot(time, values[:n, j], linewidth=1.0, label=name)
        axes.set_xlim(0.0, float(time[-1]) if n else 1.0)
        axes.set_xlabel('Time [s]')
        axes.set_ylabel(ylabel)
        axes.set_title(f'{heading} — {title}' if title else heading)
        axes.grid(visible=True, which='both', alpha=0.4)
        if len(history.dof_names) > 1:
            axes.legend()
        figure.savefig(directory / filename, dpi=110)
        plt.close(figure)
        written.append(directory / filename)
    figure, axes = plt.subplots(figsize=(6, 5), layout='constrained')
    for j, name in enumerate(history.dof_names):
        axes.plot(history.measured_displacement[:n, j], history.restoring_force[:n, j] / 1e3,
                  linewidth=0.8, label=name)
    axes.set_xlabel('Measured displacement [m]')
    axes.set_ylabel('Restoring force [kN]')
    axes.set_title(f'Force–deformation — {title}' if title else 'Force–deformation')
    axes.grid(visible=True, alpha=0.4)
    if len(history.dof_names) > 1:
        axes.legend()
    figure.savefig(directory / 'force_deformation.png', dpi=110)
    plt.close(figure)
    written.append(directory / 'force_deformation.png')
    return written


def write_energy_figure(history: ResponseHistory, energy: EnergyHistory, directory: Path,
                        *, title: str = '') -> Path:
    """The energy terms and the energy error over time (``energy.png``)."""
    plt = pyplot()
    time = history.time
    figure, (top, bottom) = plt.subplots(2, 1, figsize=(9, 6), sharex=True,
                                         layout='constrained',
                                         gridspec_kw={'height_ratios': (3, 1)})
    top.plot(time, energy.input, label='input', linewidth=1.2)
    top.plot(time, energy.kinetic, label='kinetic', linewidth=0.8)
    top.plot(time, energy.viscous, label='viscous', linewidth=0.8)
    top.plot(time, energy.strain, label='strain + hysteretic', linewidth=0.8)
    top.set_ylabel('Energy [J]')
    top.set_title(f'Energy balance — {title}' if title else 'Energy balance')
    top.grid(visible=True, alpha=0.4)
    top.legend()
    bottom.plot(time, 100.0 * energy.error_ratio, color='k', linewidth=0.8)
    bottom.set_xlabel('Time [s]')
    bottom.set_ylabel('Error [%]')
    bottom.grid(visible=True, alpha=0.4)
    path = directory / 'energy.png'
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def write_tracking_figure(history: ResponseHistory, tracking: TrackingHistory, directory: Path,
                          *, title: str = '') -> Path:
    """Measured vs command displacement, the tracking error and indicator (``tracking.png``)."""
    plt = pyplot()
    time = history.time
    figure, axes = plt.subplot_mosaic([['loop', 'error'], ['loop', 'indicator']],
                                      figsize=(12, 5.5), layout='constrained',
                                      width_ratios=(1, 1.6))
    loop, error, indicator = axes['loop'], axes['error'], axes['indicator']
    several = len(tracking.dof_names) > 1
    for j, name in enumerate(tracking.dof_names):
        loop.plot(1e3 * tracking.command[:, j], 1e3 * tracking.measured[:, j], linewidth=0.8,
                  label=name)
        error.plot(time, 1e6 * tracking.error[:, j], linewidth=0.8, label=name)
        indicator.plot(time, 1e6 * tracking.indicator[:, j], linewidth=1.0, label=name)
    if tracking.command.size:
        low = float(min(tracking.command.min(), tracking.measured.min())) * 1e3
        high = float(max(tracking.command.max(), tracking.measured.max())) * 1e3
        loop.plot([low, high], [low, high], color='0.5', linestyle='--', linewidth=0.8,
                  label='measured = command')
    loop.set_xlabel('Command displacement x [mm]')
    loop.set_ylabel('Measured displacement xm [mm]')
    loop.set_title('Measured vs command')
    loop.set_aspect('equal', adjustable='datalim')
    loop.legend(fontsize='small')
    error.set_ylabel('xm − x [µm]')
    error.set_title(f'Tracking — {title}' if title else 'Tracking')
    indicator.set_ylabel('Indicator [mm²]')
    indicator.set_xlabel('Time [s]')
    indicator.annotate('> 0: energy removed, < 0: energy added', (0.01, 0.04),
                       xycoords='axes fraction', fontsize='small')
    for item in (loop, error, indicator):
        item.grid(visible=True, alpha=0.4)
    for item in (error, indicator):
        item.set_xlim(0.0, float(time[-1]) if time.size else 1.0)
        if several:
            item.legend(fontsize='small')
    path = directory / 'tracking.png'
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def write_run_outputs(history: ResponseHistory, summary: dict[str, Any], directory: str | Path,
                      *, figures: bool = True, title: str = '',
                      energy: EnergyHistory | None = None,
                      tracking: TrackingHistory | None = None) -> list[Path]:
    """Write the CSV files, ``summary.json`` and (optionally) the figures of a run."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    written = [write_response_csv(history, directory / RESPONSE_CSV),
               write_summary(summary, directory / SUMMARY_JSON)]
    if energy is not None:
        written.append(write_energy_csv(history, energy, directory / ENERGY_CSV))
    if tracking is not None:
        written.append(write_tracking_csv(history, tracking, directory / TRACKING_CSV))
    if figures:
        written += draw_run_figures(history, directory, title=title, energy=energy,
                                    tracking=tracking)
    return written


def draw_run_figures(history: ResponseHistory, directory: str | Path, *, title: str = '',
                     energy: EnergyHistory | None = None,
                     tracking: TrackingHistory | None = None) -> list[Path]:
    """A run's figures (``FIGURES``: those of ``energy`` and ``tracking`` when given)."""
    directory = Path(directory)
    written = write_figures(history, directory, title=title)
    if energy is not None:
        written.append(write_energy_figure(history, energy, directory, title=title))
    if tracking is not None:
        written.append(write_tracking_figure(history, tracking, directory, title=title))
    return written


def prepare_figures() -> None:
    """Import matplotlib and draw a small figure (fonts, text layout).

    As the first of a run's figures would: a process that draws later starts at once
    (``.figure_worker``).
    """
    plt = pyplot()
    figure, axes = plt.subplots(figsize=(2, 2), layout='constrained')
    axes.plot([0.0, 1.0], [0.0, 1.0], linewidth=1.0)
    axes.set_xlabel('Time [s]')
    axes.set_title('—')
    figure.canvas.draw()
    plt.close(figure)
