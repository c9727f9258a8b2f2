"""The chapter 5 study's records: the study file, the record files and their tests.

:func:`load_study` reads ``study.yaml`` of a study folder; :func:`resolve_records` and
:func:`prepare_records` turn the ``--records`` items of :mod:`.study_ch5` into validated
records with one test definition per scheme; :class:`RecordResult` holds the runs of one
record, tabulated and plotted by :mod:`.study_ch5_figures`.
"""

from __future__ import annotations

import copy
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from pd_common.config import load_yaml
from pd_common.resources import ResourceError, share_file
from pd_common.specimen import specimen_from_config
from pd_core.errors import ConfigError, PdIntegratorError
from pd_core.run.definition import TestDefinition
from pd_core.run.loop.session import TestSession
from pd_core.run.test_file import from_dict
from pd_core.schemes import SCHEMES

if TYPE_CHECKING:
    from pd_core.run.record.history import ResponseHistory

__all__ = [
    'MAX_PGA_G',
    'STUDY_FILE',
    'RecordResult',
    'RecordSpec',
    'Study',
    'StudyError',
    'StudyRecord',
    'default_study_directory',
    'load_study',
    'parse_schemes',
    'prepare_records',
    'resolve_records',
]

STUDY_FILE = 'study.yaml'
#: Largest plausible peak ground acceleration of a record given in g (larger: wrong units).
MAX_PGA_G = 10.0

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
    source = Path(__file__).resolve().parents[2] / 'pd_integrator' / 'config' / 'study_ch5'
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
        return load_yaml(text)
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
    if len(names) < 2:
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
    items = items if items else list(study.default_records)
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
            matched = next((spec for spec in study.records.values()
                            if any(word in lowered for word in spec.match)), None)
            if matched is None:
                resolved.append((_label(path.stem), study.records[study.generic_record],
                                 path.resolve()))
            else:
                resolved.append((matched.name, matched, path.resolve()))
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


# -- results ------------------------------------------------------------------------------------
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
