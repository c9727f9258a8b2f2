"""The pre-test's outputs: one CSV row per run, the spectra CSV and the summary table."""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from pathlib import Path

from .execute import RunOutcome
from .limits import LIMIT_NAMES, BridgeLimits
from .plan import Plan
from .spectra import Spectrum

__all__ = ['csv_columns', 'limits_line', 'safe_scales', 'summary_table', 'write_runs_csv',
           'write_spectra_csv']


def csv_columns(plan: Plan) -> list[str]:
    """The columns of ``pretest.csv`` (SI units: m, m/s, N)."""
    dof = plan.dof_name
    return (['run', 'record', 'scale', *(v.name for v in plan.variations), 'status',
             'omega_dt', f'peak_stroke_{dof}', f'max_increment_{dof}', f'peak_velocity_{dof}',
             f'peak_force_{dof}', f'residual_{dof}', f'structure_velocity_{dof}', 'trips',
             'held_step', 'held_limit'])


def _number(value: float) -> str:
    return repr(value) if math.isfinite(value) else ('nan' if math.isnan(value) else
                                                     ('inf' if value > 0 else '-inf'))


def write_runs_csv(plan: Plan, outcomes: Sequence[RunOutcome], path: Path) -> None:
    """One row per run (floats written exactly, ``repr``)."""
    with path.open('w', newline='', encoding='utf-8') as handle:
        writer = csv.writer(handle)
        writer.writerow(csv_columns(plan))
        for o in outcomes:
            run = o.run
            writer.writerow([run.index, plan.records[run.record].name, _number(run.scale),
                             *(_number(v) for v in run.values), o.status, _number(o.omega_dt),
                             _number(o.peak_stroke), _number(o.max_increment),
                             _number(o.peak_velocity), _number(o.peak_force),
                             _number(o.residual), _number(o.structure_velocity),
                             ';'.join(o.trips), '' if o.hold is None else o.hold.step,
                             '' if o.hold is None else o.hold.limit])


def write_spectra_csv(plan: Plan, spectra: Sequence[Spectrum], path: Path) -> None:
    """``period`` and one ``Sa_<record>`` column (m/s²) per record."""
    with path.open('w', newline='', encoding='utf-8') as handle:
        writer = csv.writer(handle)
        writer.writerow(['period', *(f'Sa_{r.name}' for r in plan.records)])
        for i, period in enumerate(spectra[0].periods):
            writer.writerow([_number(float(period)),
                             *(_number(float(s.pseudo_acceleration[i])) for s in spectra)])


def limits_line(limits: BridgeLimits) -> str:
    """The bridge's limits on one line."""
    velocity = (f'{limits.max_velocity:g} m/s' if limits.max_velocity is not None else 'off')
    duration = (f'{limits.step_duration:g} s' if limits.step_duration is not None else
                'off (no velocity)')
    return (f'bridge limits ({limits.source}): max_displacement {limits.max_displacement:g} m, '
            f'max_increment {limits.max_increment:g} m, max_velocity {velocity}, '
            f'max_force {limits.max_force:g} N; step_duration {duration}')


def safe_scales(plan: Plan, outcomes: Sequence[RunOutcome]) -> list[str]:
    """Per record (and variation), the largest scale up to which no run trips a limit."""
    groups: dict[tuple[int, tuple[float, ...]], list[RunOutcome]] = {}
    for o in outcomes:
        groups.setdefault((o.run.record, o.run.values), []).append(o)
    lines = []
    for (record, values), items in groups.items():
        items = sorted(items, key=lambda o: o.run.scale)
        safe = None
        for o in items:
            if o.trips or o.status != 'ok':
                break
            safe = o.run.scale
        label = plan.records[record].name
        if values:
            label += ' (' + ', '.join(f'{v.name}={x:g}' for v, x in zip(plan.variations, values)
                                      ) + ')'
        first = next((o for o in items if o.trips or o.status != 'ok'), None)
        if first is None:
            lines.append(f'{label}: no limit tripped up to scale {items[-1].run.scale:g}')
        elif safe is None:
            what = ', '.join(first.trips) or first.status
            lines.append(f'{label}: trips {what} already at scale {first.run.scale:g}')
        else:
            what = ', '.join(first.trips) or first.status
            lines.append(f'{label}: safe up to scale {safe:g}; {what} at {first.run.scale:g}')
    return lines


def summary_table(plan: Plan, outcomes: Sequence[RunOutcome], limits: BridgeLimits, *,
                  max_rows: int = 40) -> str:
    """The printed summary: the limits, one row per run (up to ``max_rows``), the counts."""
    dof = plan.dof_name
    names = [v.name.split('.')[-1] for v in plan.variations]
    record_width = max(6, *(len(r.name) for r in plan.records))
    header = (f'{"run":>4}  {"record":<{record_width}}  {"scale":>6}'
              + ''.join(f'  {n:>12}' for n in names)
              + f'  {"status":<8}  {"stroke mm":>9}  {"incr mm":>8}  {"vel m/s":>8}'
              f'  {"force kN":>9}  trips')
    lines = [limits_line(limits), f'actuator {dof}:', header]
    for o in outcomes[:max_rows]:
        run = o.run
        velocity = f'{o.peak_velocity:8.3f}' if math.isfinite(o.peak_velocity) else \
            f'{"-":>8}'
        lines.append(
            f'{run.index:>4}  {plan.records[run.record].name:<{record_width}}  {run.scale:>6.3g}'
            + ''.join(f'  {v:>12.6g}' for v in run.values)
            + f'  {o.status:<8}  {1e3 * o.peak_stroke:9.2f}  {1e3 * o.max_increment:8.3f}'
            f'  {velocity}  {1e-3 * o.peak_force:9.3f}  {",".join(o.trips) or "-"}'
            + (f' (held at step {o.hold.step}: {o.hold.limit})' if o.hold is not None
               else ''))
    if len(outcomes) > max_rows:
        lines.append(f'... {len(outcomes) - max_rows} more runs in the CSV')
    total = len(outcomes)
    for name in LIMIT_NAMES:
        value = limits.value(name)
        count = sum(name in o.trips for o in outcomes)
        if value is None:
            lines.append(f'{name}: not checked (off)')
        else:
            lines.append(f'{name}: {count} of {total} runs would trip it')
    held = [(o.hold, o.run.index) for o in outcomes if o.hold is not None]
    if held:
        hold, index = min(held, key=lambda item: (item[0].step, item[1]))
        lines.append(f'{len(held)} of {total} runs would be held by the bridge; the earliest: '
                     f'run {index} at step {hold.step} ({hold.limit}): {hold.message}')
    bad = [o for o in outcomes if o.status != 'ok']
    if bad:
        lines.append(f'{len(bad)} of {total} runs would not run to the end '
                     f'({", ".join(sorted({o.status for o in bad}))})')
    scales = safe_scales(plan, outcomes)
    lines += scales[:10]
    if len(scales) > 10:
        lines.append(f'... {len(scales) - 10} more records/variations')
    return '\n'.join(lines)
