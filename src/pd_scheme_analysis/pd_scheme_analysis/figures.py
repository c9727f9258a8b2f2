"""Outputs of the spectral analysis: the CSV table and the figures of the sweeps.

:func:`write_sweep_csv` writes sweeps of :func:`~.analysis.sweep` as one CSV table;
:func:`plot_sweeps` draws spectral radius, numerical damping ratio and period error against
``Ω = ωΔt``; :func:`plot_figure_3_2` draws the thesis's Figure 3.2 (period shrinkage of
Newmark explicit). Used by ``./pd analyze``; matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_core.dynamics.analysis import SWEEP_COLUMNS, sweep
from pd_core.plotting import pyplot
from pd_core.schemes import newmark_explicit_numerical_frequency, scheme_class

if TYPE_CHECKING:
    from matplotlib.typing import LineStyleType

__all__ = [
    'plot_figure_3_2',
    'plot_sweeps',
    'write_sweep_csv',
]


def _format(value: Any) -> str:
    if isinstance(value, (bool, np.bool_)):
        return '1' if value else '0'
    if isinstance(value, (float, np.floating)):
        return repr(float(value))
    return str(value)


def write_sweep_csv(
    sweeps: Mapping[str, np.ndarray] | Sequence[Mapping[str, np.ndarray]], path: str | Path,
    *, parameters: Sequence[Mapping[str, Any]] | None = None,
) -> Path:
    """Write one or more sweeps as one CSV table, one row per ``Ω``.

    The columns are the :data:`SWEEP_COLUMNS`, then ``algorithmic_damping``, ``stable``
    (0/1), ``xi`` and one column per scheme parameter; floats are written exactly (``repr``),
    NaN as ``nan``.

    Args:
        sweeps: A result of :func:`sweep`, or a sequence of them stacked in order.
        path: The CSV file.
        parameters: The scheme parameters of each sweep (same length as ``sweeps``).

    Returns:
        ``path``.
    """
    items = [sweeps] if isinstance(sweeps, Mapping) else list(sweeps)
    tags = [dict(p) for p in parameters] if parameters is not None else [{} for _ in items]
    if len(tags) != len(items):
        msg = f'parameters: {len(tags)} sets for {len(items)} sweeps'
        raise ValueError(msg)
    parameter_names: list[str] = []
    for tag in tags:
        parameter_names += [name for name in tag if name not in parameter_names]
    columns = [*SWEEP_COLUMNS, 'algorithmic_damping', 'stable', 'xi']
    n_columns = len(columns)
    names = [*columns, *parameter_names]
    path = Path(path)
    with path.open('w', newline='', encoding='utf-8') as stream:
        writer = csv.writer(stream)
        writer.writerow(names)
        for item, tag in zip(items, tags):
            n = len(item['omega_dt'])
            for i in range(n):
                row = [_format(item[name][i]) for name in names[:n_columns]]
                row += [_format(tag.get(name, '')) for name in parameter_names]
                writer.writerow(row)
    return path


def _add_dt_over_t_axis(axes: Any) -> None:
    top = axes.secondary_xaxis('top', functions=(lambda o: o / (2.0 * math.pi),
                                                 lambda r: r * 2.0 * math.pi))
    top.set_xlabel('Δt/T')


_LINESTYLES: tuple[LineStyleType, ...] = ('-', '--', ':', '-.')


def plot_sweeps(
    curves: Sequence[tuple[str, Mapping[str, np.ndarray]]], directory: str | Path,
    *, title: str = '',
) -> list[Path]:
    """Plot spectral radius, numerical damping ratio and period error against ``Ω``.

    Writes ``spectral_radius.png``, ``numerical_damping.png`` and ``period_error.png``: one
    colour per label (scheme and parameters), one line style per viscous damping ratio. The
    damping and period plots show the stable range only.

    Args:
        curves: ``(label, sweep)`` pairs; the same label with several ``ξ`` shares a colour.
        directory: Folder for the PNG files (must exist).
        title: Optional suffix of the figure titles.

    Returns:
        The written paths.
    """
    plt = pyplot()
    from matplotlib.lines import Line2D  # noqa: PLC0415

    directory = Path(directory)
    labels = list(dict.fromkeys(label for label, _ in curves))
    xis = sorted({float(item['xi'][0]) for _, item in curves if len(item['xi'])})
    colours = plt.get_cmap('tab10' if len(labels) <= 10 else 'tab20')
    omega_max = max((float(np.max(item['omega_dt'])) for _, item in curves), default=1.0)
    specs = (
        ('spectral_radius.png', 'spectral_radius', 1.0, 'Spectral radius ρ',
         'Spectral radius'),
        ('numerical_damping.png', 'numerical_damping', 100.0,
         'Numerical damping ratio ξ̄ [%] (viscous + algorithmic)', 'Numerical damping ratio'),
        ('period_error.png', 'period_error', 100.0, 'Relative period error (T̄ − T)/T [%]',
         'Relative period error'),
    )
    written: list[Path] = []
    for filename, key, factor, ylabel, heading in specs:
        figure, axes = plt.subplots(figsize=(9, 5.5), layout='constrained')
        for label, item in curves:
            colour = colours(labels.index(label) % colours.N)
            xi = float(item['xi'][0])
            style = _LINESTYLES[xis.index(xi) % len(_LINESTYLES)]
            values = factor * np.asarray(item[key], dtype=float)
            if key != 'spectral_radius':
                values = np.where(item['stable'], values, np.nan)
            axes.plot(item['omega_dt'], values, color=colour, linestyle=style, linewidth=1.3)
        if key == 'spectral_radius':
            axes.axhline(1.0, color='k', linewidth=0.6)
            axes.set_ylim(0.0, 1.5)
        else:
            axes.axhline(0.0, color='k', linewidth=0.6)
            _robust_ylim(axes, [factor * np.where(item['stable'], item[key], np.nan)
                                for _, item in curves])
        axes.set_xlim(0.0, omega_max)
        axes.set_xlabel('Ω = ωΔt')
        axes.set_ylabel(ylabel)
        _add_dt_over_t_axis(axes)
        suffix = '' if key == 'spectral_radius' else ' (stable range)'
        axes.set_title(f'{heading}{suffix} — {title}' if title else f'{heading}{suffix}')
        axes.grid(visible=True, alpha=0.4)
        handles = [Line2D([], [], color=colours(i % colours.N), linewidth=1.5, label=label)
                   for i, label in enumerate(labels)]
        handles += [Line2D([], [], color='0.3', linestyle=_LINESTYLES[i % len(_LINESTYLES)],
                           label=f'ξ = {xi:g}') for i, xi in enumerate(xis)]
        axes.legend(handles=handles, fontsize='small', loc='best')
        path = directory / filename
        figure.savefig(path, dpi=110)
        plt.close(figure)
        written.append(path)
    return written


def _robust_ylim(axes: Any, series: list[np.ndarray]) -> None:
    finite = np.concatenate([np.asarray(s, dtype=float).reshape(-1) for s in series])
    finite = finite[np.isfinite(finite)]
    if finite.size == 0:
        return
    low = min(0.0, float(np.min(finite)))
    high = max(0.0, float(np.max(finite)))
    margin = 0.05 * (high - low) or 1.0
    axes.set_ylim(low - margin, high + margin)


def plot_figure_3_2(path: str | Path, *, dt_over_t_max: float = 0.3, points: int = 300) -> Path:
    """Thesis Figure 3.2: period shrinkage ``(T − T̄)/T`` of Newmark explicit vs ``Δt/T``.

    The line comes from the eigenvalues of the amplification matrix (:mod:`.analysis`); the
    markers are the closed form of eq. 3.19. The abscissa ends at ``dt_over_t_max`` or at the
    stability limit ``Δt/T = 1/π``, whichever is smaller.

    Args:
        path: The PNG file.
        dt_over_t_max: Largest ``Δt/T``.
        points: Number of points of the line.

    Returns:
        ``path``.
    """
    plt = pyplot()
    limit = scheme_class('newmark_explicit').stability_limit / (2.0 * math.pi)
    upper = min(float(dt_over_t_max), limit)
    ratios = upper * np.arange(1, points + 1) / points
    shrinkage = sweep('newmark_explicit', 2.0 * math.pi * ratios)['period_shrinkage']
    marks = ratios[points // 30 - 1::points // 30]
    closed = [1.0 - 2.0 * math.pi * r / newmark_explicit_numerical_frequency(2.0 * math.pi * r)
              for r in marks]
    figure, axes = plt.subplots(figsize=(7, 5), layout='constrained')
    axes.plot(np.concatenate(([0.0], ratios)), 100.0 * np.concatenate(([0.0], shrinkage)),
              color='tab:blue', linewidth=1.5, label='eigenvalues of A (eq. 3.7)')
    axes.plot(marks, 100.0 * np.asarray(closed), 'o', color='tab:red', markersize=4,
              markerfacecolor='none', label='closed form (eq. 3.19)')
    axes.axvline(0.05, color='0.4', linestyle='--', linewidth=0.8)
    axes.annotate('Δt/T = 0.05', (0.05, 0.9), xycoords=('data', 'axes fraction'),
                  xytext=(4, 0), textcoords='offset points', fontsize='small', color='0.3')
    axes.set_xlim(0.0, upper)
    axes.set_ylim(bottom=0.0)
    axes.set_xlabel('Δt/T')
    axes.set_ylabel('Period shrinkage (T − T̄)/T [%]')
    axes.set_title('Period shrinkage by the Newmark explicit method (thesis Figure 3.2)')
    axes.grid(visible=True, alpha=0.4)
    axes.legend()
    path = Path(path)
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
