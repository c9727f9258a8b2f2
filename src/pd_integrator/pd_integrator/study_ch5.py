"""The thesis's chapter 5 study: ``ros2 run pd_integrator study_ch5`` (or ``./pd study_ch5``).

Runs the section 5.1 SDOF column (m = 2543.4 kg, k_ini = 312.559 kN/m, 5 % damping, the default
bilinear pushover specimen, dt = 0.01 s) under each record with each scheme through the
ROS-free runner (:func:`~pd_integrator.core.runner.run_offline`: the same session and specimen
models as the node graph), and compares the schemes as the thesis's Figures 5.4-5.15 do::

    study_ch5                                   # El Centro (shipped), both schemes
    study_ch5 --records elcentro northridge=/data/RSN953_NORTHR_MUL009.AT2 \\
              kobe=/data/RSN1106_KOBE_KJM000.AT2 --out runs/ch5
    study_ch5 --records /data/RSN1106_KOBE_KJM000.AT2 --schemes newmark_explicit,alpha_os

A record is a study name (``elcentro``, ``northridge``, ``kobe``: the test files of
``config/study_ch5``), ``NAME=PATH`` (that test file with your record file), or a ``PATH`` (the
test file whose ``match`` words occur in the file name, else the SDOF of the generic record under
the file's own name). PEER's records are not shipped; bring your own ``.AT2`` files.

Output folder (``--out``, default ``runs/study_ch5-<UTC time>``)::

    <record>/<scheme>/          one run folder per scheme (bag, response.csv, summary.json, ...)
    <record>/displacement.png   the schemes overlaid, with their difference below
    <record>/velocity.png, acceleration.png, force_deformation.png
    peak_differences.csv        per record and response quantity: the peak of each scheme,
    peak_differences.md         the difference and relative difference to the first scheme
                                (the reference), and ω·Δt per record
    study.json                  what was run (records, files, schemes, run folders)

Exit status: 0 when every run finished, 1 if a run stopped early, 2 on invalid input (a missing
or invalid record file, an unknown scheme or record, an output folder that already holds runs).
"""

from __future__ import annotations

import argparse
import copy
import csv
import json
import math
import re
import sys
from dataclasses import dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import yaml

from pd_common.resources import ResourceError, share_file

from .core.config import TestDefinition, from_dict
from .core.errors import ConfigError, PdIntegratorError
from .core.runner import BAG_DIRECTORY, run_offline
from .core.schemes import SCHEMES
from .core.session import TestSession

if TYPE_CHECKING:
    from collections.abc import Callable

    from .core.history import ResponseHistory

PROG = 'study_ch5'
STUDY_FILE = 'study.yaml'
TABLE_CSV = 'peak_differences.csv'
TABLE_MD = 'peak_differences.md'
STUDY_JSON = 'study.json'
#: Largest plausible peak ground acceleration of a record given in g (larger: wrong units).
MAX_PGA_G = 10.0

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

_LABEL = re.compile(r'[^A-Za-z0-9_.\-]+')


class StudyError(PdIntegratorError, ValueError):
    """Invalid study input: a missing or invalid record, scheme, folder or study file."""


# -- the study definition ------------------------------------------------------------------------
@dataclass(frozen=True)
class RecordSpec:
    """A record of the study file.

    Attributes:
        name: study name (``elcentro``, ...).
        test_file: its base test file.
        title: title for figures and tables.
        match: lower-case words that select this record from a record file's name.
        thesis: what the thesis says about it (date, magnitude, pga_g, dt, figures).
    """

    name: str
    test_file: Path
    title: str
    match: tuple[str, ...] = ()
    thesis: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Study:
    """The study file (``study.yaml``) of a study folder.

    Attributes:
        directory: the study folder.
        schemes: default schemes (the first is the reference of the table).
        scheme_parameters: parameters per scheme.
        default_records: records run without ``--records``.
        generic_record: the record whose test file runs a record file that matches no name.
        records: the records by name.
    """

    directory: Path
    schemes: tuple[str, ...]
    scheme_parameters: dict[str, dict[str, float]]
    default_records: tuple[str, ...]
    generic_record: str
    records: dict[str, RecordSpec]


@dataclass
class StudyRecord:
    """One record of a study run, validated.

    Attributes:
        label: name of its folder and table rows.
        title: title for figures and tables.
        record_file: the ground-motion file.
        spec: the study record whose test file it uses.
        definitions: the test per scheme.
    """

    label: str
    title: str
    record_file: Path
    spec: RecordSpec
    definitions: dict[str, TestDefinition]

    @property
    def figures(self) -> tuple[str, ...]:
        """The thesis's figure numbers for this record (if it is the thesis's record)."""
        if self.label != self.spec.name:
            return ()
        return tuple(str(number) for number in self.spec.thesis.get('figures', ()))


def default_study_directory() -> Path:
    """The shipped study folder (source tree, or the installed share)."""
    source = Path(__file__).resolve().parents[1] / 'config' / 'study_ch5'
    if (source / STUDY_FILE).is_file():
        return source
    try:
        return share_file('pd_integrator', 'config', 'study_ch5')
    except ResourceError:
        return source


def _read_yaml(path: Path, what: str) -> Any:
    try:
        text = path.read_text(encoding='utf-8')
    except OSError as err:
        msg = f'{what} {str(path)!r}: cannot read it ({err.strerror})'
        raise StudyError(msg) from err
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as err:
        mark = getattr(err, 'problem_mark', None)
        where = f'line {mark.line + 1}: ' if mark is not None else ''
        msg = f'{path.name}: {where}{getattr(err, "problem", None) or "invalid YAML"}'
        raise StudyError(msg) from err


def load_study(directory: str | Path) -> Study:
    """Read and check ``study.yaml`` of a study folder.

    Raises:
        StudyError: the file is missing or a value is invalid (one line naming it).
    """
    directory = Path(directory)
    path = directory / STUDY_FILE
    if not path.is_file():
        msg = f'study folder {str(directory)!r}: no {STUDY_FILE}'
        raise StudyError(msg)
    raw = _read_yaml(path, 'study file')
    if not isinstance(raw, dict):
        msg = f'{STUDY_FILE}: must be a mapping'
        raise StudyError(msg)
    records_raw = raw.get('records')
    if not isinstance(records_raw, dict) or not records_raw:
        msg = f'{STUDY_FILE}: records: must map record names to their test files'
        raise StudyError(msg)
    records: dict[str, RecordSpec] = {}
    for name, item in records_raw.items():
        if not isinstance(item, dict) or not isinstance(item.get('test_file'), str):
            msg = f'{STUDY_FILE}: records.{name}.test_file: is required (a file name)'
            raise StudyError(msg)
        match = item.get('match', [])
        if not isinstance(match, list) or not all(isinstance(word, str) for word in match):
            msg = f'{STUDY_FILE}: records.{name}.match: must be a list of words'
            raise StudyError(msg)
        thesis = item.get('thesis', {}) or {}
        records[str(name).lower()] = RecordSpec(
            name=str(name).lower(), test_file=directory / item['test_file'],
            title=str(item.get('title', name)), match=tuple(word.lower() for word in match),
            thesis=dict(thesis) if isinstance(thesis, dict) else {})
    schemes = tuple(parse_schemes(raw.get('schemes', ['newmark_explicit', 'linear_acceleration']),
                                  f'{STUDY_FILE}: schemes'))
    parameters = raw.get('scheme_parameters', {}) or {}
    if not isinstance(parameters, dict) or not all(
            isinstance(value, dict) for value in parameters.values()):
        msg = f'{STUDY_FILE}: scheme_parameters: must map scheme names to parameter mappings'
        raise StudyError(msg)
    defaults = raw.get('default_records', list(records)[:1])
    if not isinstance(defaults, list) or not all(
            str(name).lower() in records for name in defaults):
        msg = f'{STUDY_FILE}: default_records: must list names of records, got {defaults!r}'
        raise StudyError(msg)
    generic = str(raw.get('generic_record', next(iter(records)))).lower()
    if generic not in records:
        msg = f'{STUDY_FILE}: generic_record: {generic!r} is not a record'
        raise StudyError(msg)
    return Study(directory=directory, schemes=schemes,
                 scheme_parameters={str(k): dict(v) for k, v in parameters.items()},
                 default_records=tuple(str(name).lower() for name in defaults),
                 generic_record=generic, records=records)


def parse_schemes(value: str | list[str], what: str = '--schemes') -> list[str]:
    """Scheme names from ``a,b`` or a list; at least two, registered, no repeats.

    Raises:
        StudyError: an unknown, repeated or missing scheme.
    """
    names = value.split(',') if isinstance(value, str) else [str(item) for item in value]
    names = [name.strip() for name in names if name.strip()]
    for name in names:
        if name not in SCHEMES:
            msg = f'{what}: unknown scheme {name!r}; valid: {", ".join(sorted(SCHEMES))}'
            raise StudyError(msg)
    if len(set(names)) != len(names):
        msg = f'{what}: a scheme is repeated in {",".join(names)}'
        raise StudyError(msg)
    if len(names) < 2:  # noqa: PLR2004 - a comparison needs two
        msg = f'{what}: give at least two schemes to compare, got {",".join(names) or "none"}'
        raise StudyError(msg)
    return names


# -- records ------------------------------------------------------------------------------------
def _label(text: str) -> str:
    label = _LABEL.sub('_', text).strip('_.-')[:24]
    return label or 'record'


def resolve_records(study: Study, items: list[str] | None) -> list[tuple[str, RecordSpec, Path]]:
    """``(label, test file's record, record file)`` for each ``--records`` item.

    An item is a study record name, ``NAME=PATH`` or a ``PATH`` (see the module docstring).
    Relative paths are resolved against the current directory.

    Raises:
        StudyError: an unknown record name, or a record file that does not exist.
    """
    items = list(study.default_records) if not items else items
    resolved: list[tuple[str, RecordSpec, Path]] = []
    for item in items:
        name, equals, path_text = item.partition('=')
        if equals:
            if not name.strip() or not path_text.strip():
                msg = f'--records {item!r}: expected NAME=PATH'
                raise StudyError(msg)
            key = name.strip().lower()
            spec = study.records.get(key, study.records[study.generic_record])
            label = key if key in study.records else _label(name.strip())
            path = Path(path_text.strip()).expanduser()
            _check_record_file(path, item)
            resolved.append((label, spec, path.resolve()))
        elif item.lower() in study.records:
            spec = study.records[item.lower()]
            path = _placeholder_file(spec)
            resolved.append((spec.name, spec, path))
        else:
            path = Path(item).expanduser()
            if not path.exists() and '/' not in item and not path.suffix:
                msg = (f'--records {item!r}: no such record file and no study record of that '
                       f'name (study records: {", ".join(study.records)})')
                raise StudyError(msg)
            _check_record_file(path, item)
            lowered = path.name.lower()
            spec = next((spec for spec in study.records.values()
                         if any(word in lowered for word in spec.match)), None)
            if spec is None:
                resolved.append((_label(path.stem), study.records[study.generic_record],
                                 path.resolve()))
            else:
                resolved.append((spec.name, spec, path.resolve()))
    labels: dict[str, int] = {}
    unique: list[tuple[str, RecordSpec, Path]] = []
    for label, spec, path in resolved:
        labels[label] = labels.get(label, 0) + 1
        unique.append((label if labels[label] == 1 else f'{label}-{labels[label]}', spec, path))
    return unique


def _check_record_file(path: Path, item: str) -> None:
    if not path.exists():
        msg = f'record file {str(path)!r} not found (--records {item})'
        raise StudyError(msg)
    if not path.is_file():
        msg = f'record file {str(path)!r} is not a file (--records {item})'
        raise StudyError(msg)


def _placeholder_file(spec: RecordSpec) -> Path:
    """The record file a study test file names; checked to exist."""
    raw = _read_yaml(spec.test_file, 'test file')
    ground = raw.get('ground_motion') if isinstance(raw, dict) else None
    file = ground.get('file') if isinstance(ground, dict) else None
    if not isinstance(file, str):
        msg = f'{spec.test_file.name}: ground_motion.file: is required'
        raise StudyError(msg)
    path = Path(file).expanduser()
    if not path.is_absolute():
        path = spec.test_file.parent / path
    if not path.is_file():
        msg = (f"record '{spec.name}': record file {str(path)!r} not found (PEER records are not "
               f'shipped): pass your own with --records {spec.name}=/path/to/record.AT2')
        raise StudyError(msg)
    return path.resolve()


def _check_runnable(definition: TestDefinition) -> None:
    """Build the specimen and the session once: stability and specimen errors surface here."""
    from pd_common.specimen import specimen_from_config  # noqa: PLC0415

    if definition.specimen is None:
        msg = f'{definition.source}: specimen: section is required for a simulated run'
        raise ConfigError(msg)
    specimen_from_config(definition.specimen, base_dir=definition.base_dir,
                         source=definition.source, dof_names=definition.dof_names)
    TestSession(definition)


def prepare_records(study: Study, items: list[str] | None, schemes: list[str],
                    duration: float | None = None) -> list[StudyRecord]:
    """Resolve and validate every record and build its test per scheme (nothing runs yet).

    Raises:
        StudyError: a missing or invalid record file, or an invalid test file.
    """
    records: list[StudyRecord] = []
    for label, spec, path in resolve_records(study, items):
        raw = _read_yaml(spec.test_file, 'test file')
        if not isinstance(raw, dict):
            msg = f'{spec.test_file.name}: a test file must be a mapping of sections'
            raise StudyError(msg)
        definitions: dict[str, TestDefinition] = {}
        for scheme in schemes:
            scheme_raw = copy.deepcopy(raw)
            test = scheme_raw.setdefault('test', {})
            test['id'] = f'ch5-{label}-{scheme}'
            test['scheme'] = scheme
            test['scheme_parameters'] = dict(study.scheme_parameters.get(scheme, {}))
            if duration is not None:
                test['duration'] = duration
            scheme_raw.setdefault('ground_motion', {})['file'] = str(path)
            try:
                definition = from_dict(scheme_raw, source=spec.test_file.name,
                                       base_dir=spec.test_file.parent)
                _check_runnable(definition)
            except (PdIntegratorError, ValueError) as err:
                text = ' '.join(str(err).split())
                msg = f"record '{label}' ({path.name}) is not valid: {text}"
                raise StudyError(msg) from err
            definitions[scheme] = definition
        motion = next(iter(definitions.values())).ground_motion
        g = float(next(iter(definitions.values())).record_info.get('g') or 9.81)
        pga_g = motion.pga / g
        if not pga_g > 0.0:
            msg = f"record '{label}' ({path.name}) is not valid: every acceleration is zero"
            raise StudyError(msg)
        if pga_g > MAX_PGA_G:
            msg = (f"record '{label}' ({path.name}) is not valid: PGA {pga_g:.4g} g is "
                   f'implausible for a record in g (other units?)')
            raise StudyError(msg)
        title = spec.title if label == spec.name else f'{label} ({path.name})'
        records.append(StudyRecord(label=label, title=title, record_file=path, spec=spec,
                                   definitions=definitions))
    return records


# -- running ------------------------------------------------------------------------------------
@dataclass
class RecordResult:
    """The runs of one record.

    Attributes:
        record: the record.
        run_directories: run folder per scheme.
        histories: committed response per scheme.
        summaries: ``summary.json`` per scheme, as read back from the run folder.
    """

    record: StudyRecord
    run_directories: dict[str, Path]
    histories: dict[str, ResponseHistory]
    summaries: dict[str, dict[str, Any]]

    @property
    def omega_dt(self) -> float:
        """ω·Δt of the record's tests (the same structure and dt for every scheme)."""
        value = next(iter(self.summaries.values())).get('omega_max_dt')
        return math.nan if value is None else float(value)


def check_output_directory(out: Path, records: list[StudyRecord]) -> None:
    """Refuse an output folder that already holds one of the runs (nothing is overwritten).

    Raises:
        StudyError: a run folder already holds a bag.
    """
    for record in records:
        for scheme in record.definitions:
            run = out / record.label / scheme
            if (run / BAG_DIRECTORY).exists():
                msg = f'{run}: already holds a run (bag/); choose a new --out folder'
                raise StudyError(msg)


def run_record(record: StudyRecord, out: Path, *, run_figures: bool = True,
               progress: Callable[[str], None] | None = None) -> RecordResult:
    """Run one record with each scheme (ROS-free runner) and read the summaries back."""
    directories: dict[str, Path] = {}
    histories: dict[str, ResponseHistory] = {}
    summaries: dict[str, dict[str, Any]] = {}
    for scheme, definition in record.definitions.items():
        directory = out / record.label / scheme
        result = run_offline(definition, directory, figures=run_figures)
        directories[scheme] = directory
        histories[scheme] = result.session.history
        summaries[scheme] = json.loads((directory / 'summary.json').read_text(encoding='utf-8'))
        if progress is not None:
            summary = summaries[scheme]
            dof = next(iter(summary['dofs'].values()))
            progress(f'{record.label} / {scheme}: {summary["state"]}, {summary["steps"]} steps '
                     f'in {summary["wall_time"]:.2f} s; peak displacement '
                     f'{dof["peaks"]["displacement"]["abs"] * 1e3:.2f} mm')
    return RecordResult(record=record, run_directories=directories, histories=histories,
                        summaries=summaries)


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
             '| record | file | record dt [s] | PGA [g] | thesis PGA [g] | test dt [s] | steps '
             '| ω·Δt | stability limits |',
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
    lines += ['', f'ω·Δt with ω = {", ".join(omegas)} rad/s (initial stiffness). The thesis '
              'quotes 0.2217 for El Centro at its record step (0.02 s) and 0.111 for Northridge '
              'and Kobe (0.01 s); this study integrates every record at the test files\' dt '
              '(0.01 s: El Centro linearly resampled, as the thesis\'s MATLAB does).',
              '', '## Peak differences', '',
              'Peaks are absolute values (`summary.json` of each run); difference = scheme − '
              'reference; relative = difference / reference peak; max |Δ(t)| = largest '
              'difference of the two histories.', '',
              '| record | quantity | reference | ref. peak | scheme | peak | difference '
              '| relative | max \\|Δ(t)\\| | unit |',
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
    import matplotlib as mpl  # noqa: PLC0415 - heavy; only needed here

    mpl.use('Agg')
    import matplotlib.pyplot as plt  # noqa: PLC0415

    record = result.record
    schemes = list(result.histories)
    reference = schemes[0]
    numbers = record.figures
    styles = [{'linewidth': 1.1}, {'linewidth': 0.9, 'linestyle': '--'},
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
    figure_number = f' (cf. thesis Fig. {numbers[3]})' if len(numbers) > 3 else ''  # noqa: PLR2004
    axes.set_title(f'Force–deformation — {record.title}{figure_number}\n{subtitle}')
    axes.set_xlabel(f'Measured displacement [m] ({first_dof})')
    axes.set_ylabel('Restoring force [kN]')
    axes.grid(visible=True, alpha=0.4)
    axes.legend(loc='upper left', fontsize='small')
    figure.savefig(directory / 'force_deformation.png', dpi=110)
    plt.close(figure)
    written.append(directory / 'force_deformation.png')
    return written


# -- the command --------------------------------------------------------------------------------
def default_output_directory() -> Path:
    """``runs/study_ch5-<UTC timestamp>``."""
    stamp = datetime.now(tz=timezone.utc).strftime('%Y%m%d-%H%M%S')
    return Path('runs') / f'study_ch5-{stamp}'


def _manifest(study: Study, results: list[RecordResult], schemes: list[str],
              duration: float | None) -> dict[str, Any]:
    return {
        'study': str(study.directory),
        'schemes': schemes,
        'reference_scheme': schemes[0],
        'scheme_parameters': {scheme: study.scheme_parameters.get(scheme, {})
                              for scheme in schemes},
        'duration_override': duration,
        'records': [{
            'label': result.record.label,
            'title': result.record.title,
            'test_file': str(result.record.spec.test_file),
            'record_file': str(result.record.record_file),
            'thesis': result.record.spec.thesis if result.record.label
            == result.record.spec.name else None,
            'omega_dt': result.omega_dt,
            'runs': {scheme: {'directory': str(path),
                              'state': result.summaries[scheme]['state'],
                              'steps': result.summaries[scheme]['steps']}
                     for scheme, path in result.run_directories.items()},
        } for result in results],
    }


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        msg = f'expected a positive number of seconds, got {text!r}'
        raise argparse.ArgumentTypeError(msg)
    return value


def build_parser() -> argparse.ArgumentParser:
    """The command-line parser."""
    parser = argparse.ArgumentParser(
        prog=PROG, description='The thesis chapter 5 study: the section 5.1 SDOF under each '
        'record with each scheme (ROS-free), compared as in Figures 5.4-5.15.',
        epilog='Records: a study name (elcentro, northridge, kobe), NAME=PATH, or a PATH to '
        'your own record file (PEER .AT2, or a two-column file in g). PEER records are not '
        'shipped. Example: study_ch5 --records elcentro northridge=RSN953_NORTHR_MUL009.AT2 '
        'kobe=RSN1106_KOBE_KJM000.AT2')
    parser.add_argument('--records', nargs='+', metavar='RECORD',
                        help='records to run (default: the study file\'s default_records, '
                        'El Centro)')
    parser.add_argument('--schemes', help='comma-separated schemes, the first is the reference '
                        '(default: newmark_explicit,linear_acceleration)')
    parser.add_argument('--out', help='output folder (default: runs/study_ch5-<UTC time>)')
    parser.add_argument('--config', help='study folder with study.yaml and the test files '
                        '(default: the shipped config/study_ch5)')
    parser.add_argument('--duration', type=_positive, metavar='SECONDS',
                        help='simulate only this long (default: each record\'s duration)')
    parser.add_argument('--no-run-figures', action='store_true',
                        help='skip each run folder\'s own figures (the comparison figures are '
                        'always written)')
    parser.add_argument('--quiet', action='store_true', help='print only errors')
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point; 0 when every run finished, 1 if one stopped, 2 on invalid input."""
    args = build_parser().parse_args(argv)

    def say(text: str) -> None:
        if not args.quiet:
            print(text, flush=True)

    try:
        study = load_study(Path(args.config) if args.config else default_study_directory())
        schemes = parse_schemes(args.schemes) if args.schemes else list(study.schemes)
        records = prepare_records(study, args.records, schemes, args.duration)
        out = Path(args.out) if args.out else default_output_directory()
        check_output_directory(out, records)
        if not args.records:
            others = [name for name in study.records if name not in study.default_records]
            if others:
                say(f'(not shipped: {", ".join(others)}; add them with --records '
                    + ' '.join(f'{name}=/path/to/record.AT2' for name in others) + ')')
        results: list[RecordResult] = []
        for record in records:
            result = run_record(record, out, run_figures=not args.no_run_figures,
                                progress=say)
            comparison_figures(result, out / record.label)
            results.append(result)
    except (PdIntegratorError, ValueError) as err:
        print(f'{PROG}: error: {" ".join(str(err).split())}', file=sys.stderr)
        return 2
    rows = [row for result in results for row in peak_rows(result)]
    write_table_csv(rows, out / TABLE_CSV)
    markdown = markdown_table(results, rows)
    (out / TABLE_MD).write_text(markdown, encoding='utf-8')
    (out / STUDY_JSON).write_text(json.dumps(_manifest(study, results, schemes, args.duration),
                                             indent=2, default=str) + '\n', encoding='utf-8')
    say('')
    say(markdown)
    say(f'outputs in {out}')
    finished = all(summary['state'] == 'finished'
                   for result in results for summary in result.summaries.values())
    return 0 if finished else 1


if __name__ == '__main__':
    sys.exit(main())
