"""What a pre-test runs: every record × scale × parameter variation of one test file.

The test file is read by the project's own loader (:func:`~..run.test_file.from_dict`), once
per record (the ground motion, at scale 1) and once per structural variation (with a stand-in
record), so that every run's mass, damping, ground motion and specimen model are exactly what
``./pd offline`` would use for that test. ``--vary NAME=LO:HI:N`` sets the dotted path ``NAME``
of the YAML (``specimen.elements.0.yield_force``, ``structure.mass``; ``[0]`` works as ``.0``).

Supported (else a :class:`PretestError` of one line naming the file and what is not): an SDOF
test (one DOF, no ``structure.elements``), scheme ``newmark_explicit``, a given initial
stiffness (not ``probe``), one ground motion component, no ``collapse`` section, a ``specimen``
with one element of a model of :data:`~.models.SUPPORTED_MODELS` and no injected errors.
"""

from __future__ import annotations

import copy
import itertools
import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from pd_common.config import MAX_TEXT_BYTES, load_yaml, read_text, yaml_problem
from pd_common.specimen import HysteresisModel, Specimen, SpecimenError, server_from_config
from pd_common.specimen.server import split_errors
from pd_common.types import FloatArray
from pd_core.dynamics.ground_motion import GroundMotion
from pd_core.dynamics.stability import StabilityReport, check_stability
from pd_core.errors import PdIntegratorError
from pd_core.run.definition import TestDefinition
from pd_core.run.test_file import from_dict

from .errors import PretestError
from .models import unsupported_reason

__all__ = ['SUPPORTED_SCHEMES', 'Plan', 'Record', 'Run', 'Structural', 'Variation', 'build_plan',
           'parse_range', 'parse_scales', 'parse_variation', 'read_test_file']

#: Schemes the vectorised integrator implements.
SUPPORTED_SCHEMES = ('newmark_explicit',)

_INDEX = re.compile(r'\[(\d+)\]')
_LOAD_SECTIONS = ('test', 'ground_motion')


def _clean(value: float) -> float:
    """``value`` rounded to 12 significant digits (``0.7`` rather than ``0.7000000000000001``)."""
    return float(f'{value:.12g}')


#: Most values of one ``--scales`` or ``--vary``, and most analyses of one pre-test: a
#: pre-test is a survey of a few hundred runs; a typo in a step (``0:1000:1e-6``) would
#: otherwise allocate and run for hours.
MAX_VALUES = 10_000
MAX_RUNS = 100_000


def _too_many(what: str, count: int, text: str) -> str:
    return f'{what}: {count:,} values from {text!r}; at most {MAX_VALUES:,}'


def parse_range(text: str, what: str) -> list[float]:
    """``LO:HI:STEP`` (inclusive), a comma list, or one number.

    Raises:
        PretestError: naming ``what``.
    """
    try:
        if ':' in text:
            lo, hi, step = (float(part) for part in text.split(':'))
            if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(step)
                    and step > 0.0 and hi >= lo):
                raise ValueError
            count = math.floor((hi - lo) / step + 1e-9) + 1
            values = ([_clean(lo + i * step) for i in range(count)] if count <= MAX_VALUES
                      else [])
        else:
            values = [float(part) for part in text.split(',')]
            count = len(values)
    except ValueError:
        msg = (f'{what}: expected LO:HI:STEP (HI >= LO, STEP > 0), a comma list or a number, '
               f'got {text!r}')
        raise PretestError(msg) from None
    if count > MAX_VALUES:
        msg = _too_many(what, count, text)
        raise PretestError(msg)
    if not values or not all(math.isfinite(v) for v in values):
        msg = f'{what}: values must be finite numbers, got {text!r}'
        raise PretestError(msg)
    return values


def parse_scales(text: str) -> list[float]:
    """The ``--scales`` values (positive).

    Raises:
        PretestError: naming ``--scales``.
    """
    values = parse_range(text, '--scales')
    if not all(v > 0.0 for v in values):
        msg = f'--scales: scale factors must be positive, got {text!r}'
        raise PretestError(msg)
    return values


@dataclass(frozen=True)
class Variation:
    """One ``--vary``: a dotted path of the test file and its values."""

    name: str
    keys: tuple[str | int, ...]
    values: tuple[float, ...]

    @property
    def load(self) -> bool:
        """Whether it changes the loading (a ``test`` or ``ground_motion`` key)."""
        return str(self.keys[0]) in _LOAD_SECTIONS

    @property
    def structural(self) -> bool:
        """Whether it changes the structure or specimen (anything but ``ground_motion``)."""
        return str(self.keys[0]) != 'ground_motion'


def parse_variation(text: str) -> Variation:
    """``NAME=LO:HI:N``: ``N`` values from ``LO`` to ``HI`` (linearly spaced).

    Raises:
        PretestError: naming ``--vary`` and the text.
    """
    name, sep, spec = text.partition('=')
    name = name.strip()
    parts = spec.split(':')
    try:
        if not (sep and name and len(parts) == 3):
            raise ValueError
        lo, hi = float(parts[0]), float(parts[1])
        count = int(parts[2])
        if count < 1 or not (math.isfinite(lo) and math.isfinite(hi)):
            raise ValueError
    except ValueError:
        msg = f'--vary: expected NAME=LO:HI:N (N an integer >= 1), got {text!r}'
        raise PretestError(msg) from None
    if count > MAX_VALUES:
        msg = _too_many('--vary', count, text)
        raise PretestError(msg)
    keys: list[str | int] = []
    for token in _INDEX.sub(r'.\1', name).split('.'):
        if not token:
            msg = f'--vary {name}: empty key in the dotted path'
            raise PretestError(msg)
        keys.append(int(token) if token.isdigit() else token)
    if isinstance(keys[0], int):
        msg = f'--vary {name}: must start with a section name (e.g. specimen, structure)'
        raise PretestError(msg)
    if keys[:2] == ['ground_motion', 'scale']:
        msg = f'--vary {name}: vary the scale factor with --scales'
        raise PretestError(msg)
    values = [lo] if count == 1 else [_clean(v) for v in np.linspace(lo, hi, count)]
    return Variation(name=name, keys=tuple(keys), values=tuple(values))


def _set(raw: dict[str, Any], variation: Variation, value: float, source: str) -> None:
    """Set ``variation``'s path in ``raw`` (in place) to ``value``."""
    node: Any = raw
    path = ''
    for key in variation.keys[:-1]:
        path = f'{path}.{key}' if path else str(key)
        node = _child(node, key, path, variation, source)
    last = variation.keys[-1]
    if isinstance(node, list):
        if not isinstance(last, int) or not 0 <= last < len(node):
            msg = f'{source}: --vary {variation.name}: {path} has {len(node)} items, no [{last}]'
            raise PretestError(msg)
        node[last] = value
    elif isinstance(node, dict):
        node[str(last)] = value
    else:
        msg = f'{source}: --vary {variation.name}: {path or "the file"} is not a mapping or list'
        raise PretestError(msg)


def _child(node: Any, key: str | int, path: str, variation: Variation, source: str) -> Any:
    if isinstance(node, list) and isinstance(key, int) and 0 <= key < len(node):
        return node[key]
    if isinstance(node, dict) and str(key) in node:
        return node[str(key)]
    msg = f'{source}: --vary {variation.name}: the test file has no {path}'
    raise PretestError(msg)


def read_test_file(path: str | Path) -> tuple[dict[str, Any], str, Path]:
    """``(raw mapping, file name, folder)`` of a YAML test file.

    Raises:
        PretestError: the file cannot be read or is not a YAML mapping.
    """
    path = Path(path)
    try:
        text = read_text(path, limit=MAX_TEXT_BYTES, what='a test file')
    except OSError as err:  # (also not a regular file, too large, not UTF-8: InputFileError)
        msg = f'{path}: cannot read the test file ({err.strerror or type(err).__name__})'
        raise PretestError(msg) from None
    try:
        raw = load_yaml(text)
    except yaml.YAMLError as err:
        msg = f'{path.name}: {yaml_problem(err)}'
        raise PretestError(msg) from None
    if not isinstance(raw, dict):
        msg = f'{path.name}: a test file must be a mapping of sections'
        raise PretestError(msg)
    return raw, path.name, path.resolve().parent


@dataclass(frozen=True)
class Record:
    """A ground motion as the session reads it, at scale 1 (direction applied).

    Attributes:
        name: the file name.
        motion: the record at its own step [m/s²].
        dt: the test's time step [s].
        n_steps: the test's steps with this record.
    """

    name: str
    motion: GroundMotion
    dt: float
    n_steps: int

    def at_test_steps(self, scale: float) -> FloatArray:
        """The record × ``scale`` at the test's steps, padded: the session's ground motion.

        As :mod:`..run.test_file` does: scaled at the record's step, resampled, cut or padded
        with zeros to ``n_steps + 1`` values.
        """
        resampled = self.motion.scaled(scale).resampled(self.dt).acceleration
        out = np.zeros(self.n_steps + 1)
        count = min(self.n_steps + 1, resampled.size)
        out[:count] = resampled[:count]
        return out


@dataclass(frozen=True)
class Structural:
    """One structural variation: the SDOF's constants and its specimen model (virgin)."""

    mass: float
    damping: float
    load_factor: float
    stiffness: float
    dt: float
    stability: StabilityReport
    model: HysteresisModel
    model_name: str
    warnings: tuple[str, ...] = ()

    @property
    def period(self) -> float:
        """Initial period ``2π √(m/k)`` [s]."""
        return 2.0 * math.pi * math.sqrt(self.mass / self.stiffness)


@dataclass(frozen=True)
class Run:
    """One run: a record, a scale factor and one value per variation."""

    index: int
    record: int
    scale: float
    values: tuple[float, ...]
    load_key: tuple[int, tuple[float, ...]]
    structure_key: tuple[float, ...]


@dataclass
class Plan:
    """Every run of a pre-test and what they share."""

    test_id: str
    source: str
    dof_name: str
    scheme: str
    variations: tuple[Variation, ...]
    records: list[Record]
    loads: dict[tuple[int, tuple[float, ...]], Record]
    structures: dict[tuple[float, ...], Structural]
    runs: list[Run]
    raw: dict[str, Any]
    base: TestDefinition
    warnings: list[str] = field(default_factory=list)


def _supported(definition: TestDefinition, raw: Mapping[str, Any], source: str) -> None:
    """Refuse what the vectorised pre-test does not do, in one line."""
    problems = []
    if definition.model is not None or definition.site_names:
        problems.append('a substructured test (structure.elements / sites) is not supported '
                        'yet (SDOF specimen tests only)')
    elif definition.n_dof != 1:
        problems.append(f'an MDOF test ({definition.n_dof} DOFs) is not supported yet (SDOF '
                        'only)')
    if definition.scheme not in SUPPORTED_SCHEMES:
        problems.append(f"test.scheme '{definition.scheme}' is not supported (supported: "
                        f'{", ".join(SUPPORTED_SCHEMES)})')
    if definition.needs_probe:
        problems.append("structure.initial_stiffness 'probe' is not supported (give the value)")
    if len(definition.components) > 1:
        problems.append('several ground motion components are not supported')
    if definition.collapse is not None:
        problems.append('a collapse section is not supported (the pre-test runs every step)')
    specimen = raw.get('specimen')
    if not isinstance(specimen, dict) or 'elements' not in specimen:
        problems.append('the specimen section with elements is required (a column specimen '
                        'is not supported)')
    if problems:
        msg = f'{source}: pretest: {problems[0]}'
        raise PretestError(msg)


def _structural(raw: dict[str, Any], source: str, base_dir: Path) -> Structural:
    """The SDOF of one structural variation (``raw`` with a stand-in record)."""
    test = raw.get('test')
    dt = test.get('dt') if isinstance(test, dict) else None
    if not isinstance(dt, (int, float)) or isinstance(dt, bool) or not dt > 0.0:
        dt = 1.0  # the loader reports the real problem
    raw = dict(raw)
    raw['ground_motion'] = {'inline': {'dt': float(dt), 'acceleration': [0.0, 0.0]},
                            'units': 'm/s2'}
    definition = from_dict(raw, source=source, base_dir=base_dir)
    _supported(definition, raw, source)
    structure = definition.structure()
    mass = float(structure.mass[0, 0])
    stiffness = float(structure.initial_stiffness[0, 0])
    influence = definition.components[0].influence if definition.components else \
        definition.influence
    section = raw['specimen']
    _, errors = split_errors(section, source)
    if errors is not None and not errors.is_ideal:
        msg = (f'{source}: pretest: specimen.errors (injected experimental errors) are not '
               'supported')
        raise PretestError(msg)
    server = server_from_config(section, base_dir=base_dir, source=source,
                                dof_names=definition.dof_names)
    specimen = server.specimen
    if not isinstance(specimen, Specimen):
        msg = f'{source}: pretest: a column specimen is not supported'
        raise PretestError(msg)
    model = specimen.elements[0]
    reason = unsupported_reason(model)
    if reason is not None:
        msg = f'{source}: pretest: specimen.elements[0]: {reason}'
        raise PretestError(msg)
    stability = check_stability(definition.scheme, structure.mass, structure.initial_stiffness,
                                definition.dt)
    return Structural(mass=mass, damping=float(structure.damping[0, 0]),
                      load_factor=float((structure.mass @ influence)[0]), stiffness=stiffness,
                      dt=definition.dt, stability=stability, model=model,
                      model_name=str(section['elements'][0].get('model')),
                      warnings=definition.warnings)


def _record(raw: dict[str, Any], record: Path | None, source: str, base_dir: Path) -> Record:
    """A record as the session reads it (scale 1, the file's direction)."""
    raw = dict(raw)
    ground = raw.get('ground_motion')
    if not isinstance(ground, dict):
        msg = f'{source}: pretest: ground_motion: one mapping is required'
        raise PretestError(msg)
    ground = dict(ground)
    ground['scale'] = 1.0
    if record is not None:
        if not record.exists():  # (anything else is refused by the reader, in one line)
            msg = f'{record}: --records: no such file'
            raise PretestError(msg)
        ground.pop('inline', None)
        ground.pop('record', None)
        ground['file'] = str(record.resolve())
        ground['format'] = 'auto'
        if record.suffix.lower() == '.at2':
            ground.pop('dt', None)
    raw['ground_motion'] = ground
    try:
        definition = from_dict(raw, source=source, base_dir=base_dir)
    except PdIntegratorError as err:
        if record is None:
            raise
        msg = f'{record}: --records: {str(err).split(": ", 2)[-1]}'
        raise PretestError(msg) from None
    name = record.name if record is not None else str(definition.record_info.get('file', 'record'))
    return Record(name=name, motion=definition.ground_motion, dt=definition.dt,
                  n_steps=definition.n_steps)


def build_plan(test_file: str | Path, *, records: Sequence[str | Path] = (),
               scales: Sequence[float] | None = None,
               variations: Sequence[Variation] = ()) -> Plan:
    """Every run of the pre-test of ``test_file``.

    Args:
        test_file: the YAML test file.
        records: ground motion files (``.AT2``, CSV, ...; default: the test's own record).
        scales: scale factors of the records (default: the test file's ``ground_motion.scale``);
            each replaces ``ground_motion.scale``.
        variations: the ``--vary`` parameters (their values multiply).

    Raises:
        PretestError: (or another one-line :class:`PdIntegratorError` /
            :class:`~pd_common.specimen.SpecimenError` of the loader) naming the file and the
            parameter.
    """
    raw, source, base_dir = read_test_file(test_file)
    names = [v.name for v in variations]
    if len(set(names)) != len(names):
        msg = f'{source}: --vary: a parameter is given twice'
        raise PretestError(msg)
    base = from_dict(copy.deepcopy(raw), source=source, base_dir=base_dir)
    _supported(base, raw, source)
    if scales is None:
        scales = [float(base.record_info.get('scale', 1.0))]
    record_paths: list[Path | None] = [Path(r) for r in records] or [None]
    plan_records: dict[int, Record] = {}
    loads: dict[tuple[int, tuple[float, ...]], Record] = {}
    structures: dict[tuple[float, ...], Structural] = {}
    runs: list[Run] = []
    warnings: list[str] = []
    planned = len(record_paths) * len(scales) * math.prod(len(v.values) for v in variations)
    if planned > MAX_RUNS:
        msg = (f'{source}: {planned:,} analyses ({len(record_paths)} record(s) × '
               f'{len(scales)} scale(s) × the --vary values); at most {MAX_RUNS:,}')
        raise PretestError(msg)
    load_vars = [i for i, v in enumerate(variations) if v.load]
    struct_vars = [i for i, v in enumerate(variations) if v.structural]
    combos = list(itertools.product(*(v.values for v in variations)))
    try:
        for combo in combos:
            load_values = tuple(combo[i] for i in load_vars)
            struct_values = tuple(combo[i] for i in struct_vars)
            if struct_values not in structures:
                varied = copy.deepcopy(raw)
                for i in struct_vars:
                    _set(varied, variations[i], combo[i], source)
                try:
                    structures[struct_values] = _structural(varied, source, base_dir)
                except (PdIntegratorError, SpecimenError) as err:
                    if not struct_vars:
                        raise
                    given = ', '.join(f'{variations[i].name}={combo[i]:g}' for i in struct_vars)
                    msg = f'{err} (with --vary {given})'
                    raise PretestError(msg) from None
                warnings += [w for w in structures[struct_values].warnings if w not in warnings]
            for r, path in enumerate(record_paths):
                key = (r, load_values)
                if key not in loads:
                    varied = copy.deepcopy(raw)
                    for i in load_vars:
                        _set(varied, variations[i], combo[i], source)
                    loads[key] = _record(varied, path, source, base_dir)
                    plan_records.setdefault(r, loads[key])
                for scale in scales:
                    peak = loads[key].motion.pga
                    if not math.isfinite(scale * peak):  # refused here, not warned in numpy
                        msg = (f'--scales: {scale:g} × the peak {peak:.4g} m/s2 of '
                               f'{loads[key].name} is beyond the largest number')
                        raise PretestError(msg)
                    runs.append(Run(index=len(runs), record=r, scale=float(scale),
                                    values=tuple(float(c) for c in combo), load_key=key,
                                    structure_key=struct_values))
    except SpecimenError as err:
        raise PretestError(str(err)) from None
    return Plan(test_id=base.test_id, source=source, dof_name=base.dof_names[0],
                scheme=base.scheme, variations=tuple(variations),
                records=[plan_records[r] for r in sorted(plan_records)], loads=loads,
                structures=structures, runs=runs, raw=raw, base=base, warnings=warnings)
