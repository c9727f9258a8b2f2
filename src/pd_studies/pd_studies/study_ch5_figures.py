"""The chapter 5 study's outputs: the table of peak differences and the comparison figures.

:func:`peak_rows` compares each scheme's peaks with the reference scheme's,
:func:`write_table_csv` and :func:`markdown_table` write them, and :func:`comparison_figures`
draws the thesis's Figures 5.4-5.15 for one record (:class:`~.study_ch5_records.RecordResult`).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from pd_core.plotting import pyplot

if TYPE_CHECKING:
    from pd_core.run.record.history import ResponseHistory

    from .study_ch5_records import RecordResult

__all__ = [
    'QUANTITIES',
    'SCHEME_LABELS',
    'TABLE_COLUMNS',
    'comparison_figures',
    'markdown_table',
    'peak_rows',
    'write_table_csv',
]

#: Response quantities of the table: summary.json peak key, label, unit.
QUANTITIES: tuple[tuple[str, str, str], ...] = (
    ('displacement', 'displacement', 'm'),
    ('velocity', 'velocity', 'm/s'),
    ('acceleration', 'relative acceleration', 'm/s^2'),
    ('absolute_acceleration', 'absolute acceleration', 'm/s^2'),
    ('restoring_force', 'restoring force', 'N'),
)

#: Legend labels of the schemes (the registry name otherwise).
SCHEME_LABELS = {
    'newmark_explicit': 'Newmark explicit',
    'linear_acceleration': 'Linear acceleration (implicit Newmark, β = 1/6)',
    'average_acceleration': 'Average acceleration (implicit Newmark, β = 1/4)',
}


# -- the table ----------------------------------------------------------------------------------
TABLE_COLUMNS = ('record', 'dof', 'quantity', 'unit', 'reference_scheme', 'reference_peak',
                 'reference_time', 'scheme', 'peak', 'time', 'difference',
                 'relative_difference', 'max_history_difference', 'omega_dt', 'dt', 'steps')


def _history_values(history: ResponseHistory, key: str, j: int) -> np.ndarray:
    n = history.n_committed
    if key == 'displacement':
        return history.displacement[:n, j]
    if key == 'velocity':
        return history.velocity[:n, j]
    if key == 'acceleration':
        return history.acceleration[:n, j]
    if key == 'absolute_acceleration':
        return history.acceleration[:n, j] + history.ground_acceleration[:n]
    return history.restoring_force[:n, j]


def peak_rows(result: RecordResult) -> list[dict[str, Any]]:
    """Table rows of one record: each scheme against the first (reference) per quantity.

    The peaks are the ``abs`` peaks of each run's ``summary.json``; ``difference`` is
    ``peak − reference_peak``, ``relative_difference`` that divided by ``reference_peak``, and
    ``max_history_difference`` the largest ``|scheme(t) − reference(t)|`` over the common steps.
    """
    schemes = list(result.summaries)
    reference = schemes[0]
    ref_summary = result.summaries[reference]
    rows: list[dict[str, Any]] = []
    for j, dof in enumerate(ref_summary['dofs']):
        for key, _label_text, unit in QUANTITIES:
            ref_peak = ref_summary['dofs'][dof]['peaks'][key]
            ref_values = _history_values(result.histories[reference], key, j)
            for scheme in schemes[1:]:
                peak = result.summaries[scheme]['dofs'][dof]['peaks'][key]
                values = _history_values(result.histories[scheme], key, j)
                count = min(values.size, ref_values.size)
                difference = peak['abs'] - ref_peak['abs']
                rows.append({
                    'record': result.record.label, 'dof': dof, 'quantity': key, 'unit': unit,
                    'reference_scheme': reference, 'reference_peak': ref_peak['abs'],
                    'reference_time': ref_peak['time'], 'scheme': scheme,
                    'peak': peak['abs'], 'time': peak['time'], 'difference': difference,
                    'relative_difference': (difference / ref_peak['abs'] if ref_peak['abs']
                                            else math.nan),
                    'max_history_difference': float(np.max(np.abs(
                        values[:count] - ref_values[:count]))) if count else math.nan,
                    'omega_dt': result.omega_dt, 'dt': ref_summary['dt'],
                    'steps': ref_summary['steps'],
                })
    return rows


def write_table_csv(rows: list[dict[str, Any]], path: Path) -> Path:
    """The rows as CSV; floats with 17 significant digits (they equal summary.json's)."""
    with path.open('w', encoding='utf-8', newline='') as stream:
        writer = csv.writer(stream)
        writer.writerow(TABLE_COLUMNS)
        for row in rows:
            writer.writerow([repr(float(row[name])) if isinstance(row[name], float)
                             else row[name] for name in TABLE_COLUMNS])
    return path


def _number(value: float, digits: int = 4) -> str:
    if value is None or not math.isfinite(value):
        return '—'
    return f'{value:.{digits}g}'


def markdown_table(results: list[RecordResult], rows: list[dict[str, Any]]) -> str:
    """The records (ω·Δt, PGA, dt) and the peak differences as Markdown."""
    lines = ['# Thesis chapter 5: comparison of the schemes', '',
             '## Records', '',
             ('| record | file | record dt [s] | PGA [g] | thesis PGA [g] | test dt [s] | steps '
              '| ω·Δt | stability limits |'),
             '|---|---|---|---|---|---|---|---|---|']
    for result in results:
        record = result.record
        definition = next(iter(record.definitions.values()))
        g = float(definition.record_info.get('g') or 9.81)
        thesis = record.spec.thesis if record.label == record.spec.name else {}
        limits = ', '.join(
            f'{scheme} {_number(summary.get("stability_limit") or math.inf, 3)}'
            for scheme, summary in result.summaries.items())
        lines.append(
            f'| {record.title} | `{record.record_file.name}` | {definition.ground_motion.dt:g} '
            f'| {_number(definition.ground_motion.pga / g, 3)} '
            f'| {_number(thesis["pga_g"], 3) if "pga_g" in thesis else "—"} '
            f'| {definition.dt:g} | {next(iter(result.summaries.values()))["steps"]} '
            f'| {result.omega_dt:.4f} | {limits} |')
    omegas = sorted({_number(float(summary.get('omega_max') or math.nan), 6)
                     for result in results for summary in result.summaries.values()})
    lines += ['', (f'ω·Δt with ω = {", ".join(omegas)} rad/s (initial stiffness). The thesis '
                   'quotes 0.2217 for El Centro at its record step (0.02 s) and 0.111 for '
                   'Northridge and Kobe (0.01 s); this study integrates every record at the test '
                   'files\' dt (0.01 s: El Centro linearly resampled, as the thesis\'s MATLAB '
                   'does).'),
              '', '## Peak differences', '',
              ('Peaks are absolute values (`summary.json` of each run); difference = scheme − '
               'reference; relative = difference / reference peak; max |Δ(t)| = largest '
               'difference of the two histories.'), '',
              ('| record | quantity | reference | ref. peak | scheme | peak | difference '
               '| relative | max \\|Δ(t)\\| | unit |'),
              '|---|---|---|---|---|---|---|---|---|---|']
    for row in rows:
        relative = row['relative_difference']
        lines.append(
            f'| {row["record"]} | {row["quantity"].replace("_", " ")} '
            f'| {row["reference_scheme"]} | {_number(row["reference_peak"])} '
            f'| {row["scheme"]} | {_number(row["peak"])} | {_number(row["difference"], 3)} '
            f'| {_number(100.0 * relative, 3) + " %" if math.isfinite(relative) else "—"} '
            f'| {_number(row["max_history_difference"], 3)} | {row["unit"]} |')
    return '\n'.join(lines) + '\n'


# -- the figures --------------------------------------------------------------------------------
def _scheme_label(scheme: str) -> str:
    return SCHEME_LABELS.get(scheme, scheme)


def comparison_figures(result: RecordResult, directory: Path) -> list[Path]:
    """The thesis's Figures 5.4-5.7 (5.8-5.11, 5.12-5.15) for one record: the schemes overlaid.

    Displacement, velocity and relative acceleration histories (each scheme minus the reference
    in a lower panel) and the force-deformation loops (measured displacement, restoring force).
    """
    plt = pyplot()
    record = result.record
    schemes = list(result.histories)
    reference = schemes[0]
    numbers = record.figures
    # Keyword arguments of ``Axes.plot`` (matplotlib types each keyword differently).
    styles: list[dict[str, Any]] = [
        {'linewidth': 1.1}, {'linewidth': 0.9, 'linestyle': '--'},
        {'linewidth': 0.8, 'linestyle': ':'}, {'linewidth': 0.8, 'linestyle': '-.'}]
    dt = next(iter(record.definitions.values())).dt
    subtitle = f'ω·Δt = {result.omega_dt:.4f}, dt = {dt:g} s'
    series = (('displacement.png', 'displacement', 'Displacement [m]', 'Displacement response',
               'm'),
              ('velocity.png', 'velocity', 'Velocity [m/s]', 'Velocity response', 'm/s'),
              ('acceleration.png', 'acceleration', 'Acceleration [m/s²]',
               'Acceleration response (relative)', 'm/s²'))
    written: list[Path] = []
    first_dof = next(iter(result.summaries[reference]['dofs']))
    j = 0  # the study's structure is an SDOF; MDOF test files show their first DOF
    for index, (filename, key, ylabel, heading, unit) in enumerate(series):
        figure, (top, bottom) = plt.subplots(
            2, 1, figsize=(9, 5.5), sharex=True, layout='constrained',
            gridspec_kw={'height_ratios': (3, 1)})
        ref_history = result.histories[reference]
        ref_values = _history_values(ref_history, key, j)
        for number, scheme in enumerate(schemes):
            history = result.histories[scheme]
            values = _history_values(history, key, j)
            top.plot(history.time, values, label=_scheme_label(scheme), color=f'C{number}',
                     **styles[number % len(styles)])
            if scheme != reference:
                count = min(values.size, ref_values.size)
                bottom.plot(history.time[:count], values[:count] - ref_values[:count],
                            linewidth=0.8, label=f'{scheme} − {reference}', color=f'C{number}',
                            **{k: v for k, v in styles[number % len(styles)].items()
                               if k != 'linewidth'})
        figure_number = f' (cf. thesis Fig. {numbers[index]})' if numbers else ''
        top.set_title(f'{heading} — {record.title}{figure_number}\n{subtitle}')
        top.set_ylabel(ylabel)
        top.grid(visible=True, alpha=0.4)
        top.legend(loc='upper right', fontsize='small')
        bottom.set_xlabel('Time [s]')
        bottom.set_ylabel(f'Difference [{unit}]')
        bottom.grid(visible=True, alpha=0.4)
        bottom.legend(loc='upper right', fontsize='x-small')
        end = max(float(h.time[-1]) for h in result.histories.values() if h.n_committed)
        bottom.set_xlim(0.0, end)
        figure.savefig(directory / filename, dpi=110)
        plt.close(figure)
        written.append(directory / filename)
    figure, axes = plt.subplots(figsize=(6.5, 5.5), layout='constrained')
    for number, scheme in enumerate(schemes):
        history = result.histories[scheme]
        n = history.n_committed
        axes.plot(history.measured_displacement[:n, j], history.restoring_force[:n, j] / 1e3,
                  label=_scheme_label(scheme), color=f'C{number}',
                  **styles[number % len(styles)])
    figure_number = f' (cf. thesis Fig. {numbers[3]})' if len(numbers) > 3 else ''
    axes.set_title(f'Force–deformation — {record.title}{figure_number}\n{subtitle}')
    axes.set_xlabel(f'Measured displacement [m] ({first_dof})')
    axes.set_ylabel('Restoring force [kN]')
    axes.grid(visible=True, alpha=0.4)
    axes.legend(loc='upper left', fontsize='small')
    figure.savefig(directory / 'force_deformation.png', dpi=110)
    plt.close(figure)
    written.append(directory / 'force_deformation.png')
    return written
