"""The YAML test file: one schema for the file, the node parameters and the bag.

A test file has the sections ``test``, ``structure``, ``ground_motion``, ``protocol``, ``probe``
and ``specimen`` (the last one is read by the specimen simulator and by the ROS-free runner, and
ignored by the integrator, so a physical specimen needs no change here), and ``sites`` for a
substructured test. See ``config/default_test.yaml`` for a documented example.

Every error is a :class:`ConfigError` whose one-line message names the file and the parameter,
e.g. ``default_test.yaml: test.dt: must be > 0, got -0.01``.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from pd_common.config import (
    SchemaError,
    TestFile,
    describe_size,
    load_yaml,
    read_test_data,
    validate_section,
    validate_test_file,
)
from pd_common.config.schema_test_file import GroundMotionSection, SiteSettings
from pd_common.resources import ResourceError, share_file
from pd_common.specimen import HYSTERESIS_MODELS, SpecimenError, specimen_from_config

from ..dynamics.ground_motion import GroundMotion
from ..dynamics.record_readers import read_ground_motion
from ..dynamics.structure import SYMMETRY_RTOL
from ..errors import ConfigError, GroundMotionError
from ..matrices import as_float_array, as_matrix, first_boolean
from ..model.parse import parse_elements
from ..schemes import SCHEMES
from ..schemes.linalg import large_diagonal
from .collapse import CollapseSettings
from .definition import (
    GroundComponent,
    ProbeSettings,
    ProtocolSettings,
    TestDefinition,
)

__all__ = ['MAX_STEPS', 'PARAMETER_PATHS', 'RUN_PARAMETERS', 'SECTIONS', 'apply_overrides',
           'default_test_file', 'from_dict', 'from_json', 'load_test_file', 'parse_overrides',
           'read_definition', 'run_parameter', 'steps_refusal']

def default_test_file() -> Path:
    """The shipped default test: the integrator's installed share, or the source tree."""
    try:
        path = share_file('pd_integrator', 'config', 'default_test.yaml')
        if path.is_file():
            return path
    except ResourceError:
        pass
    return Path(__file__).resolve().parents[3] / 'pd_integrator' / 'config' / 'default_test.yaml'


#: The sections of a test file (``rig`` is read by ``run_test`` only: the rig's ROS domain and
#: discovery; the integrator does not need it).
SECTIONS = ('test', 'structure', 'ground_motion', 'protocol', 'probe', 'specimen', 'sites',
            'collapse', 'rig')

#: Node parameter name -> path in the test definition (the integrator node's overrides).
PARAMETER_PATHS: dict[str, tuple[str, str]] = {
    'test_id': ('test', 'id'),
    'scheme': ('test', 'scheme'),
    'dt': ('test', 'dt'),
    'duration': ('test', 'duration'),
    'mass': ('structure', 'mass'),
    'damping_ratio': ('structure', 'damping'),
    'damping_coefficient': ('structure', 'damping'),
    'initial_stiffness': ('structure', 'initial_stiffness'),
    'ground_motion_file': ('ground_motion', 'file'),
    'ground_motion_format': ('ground_motion', 'format'),
    'ground_motion_units': ('ground_motion', 'units'),
    'ground_motion_dt': ('ground_motion', 'dt'),
    'scale_factor': ('ground_motion', 'scale'),
    'direction': ('ground_motion', 'direction'),
    'feedback_timeout': ('protocol', 'feedback_timeout'),
    'max_retries': ('protocol', 'max_retries'),
    'tracking_tolerance': ('protocol', 'tracking_tolerance'),
}

#: The integrator node's own parameters a run may set with ``-p`` besides the test's
#: (:data:`PARAMETER_PATHS`): name -> (the least value, whether it is allowed, what it is).
RUN_PARAMETERS: dict[str, tuple[float, bool, str]] = {
    'sync_interval': (0.0, True, 'most seconds between two fsync of the journal (0: every step)'),
    'progress_interval': (0.0, False, 'seconds between two progress lines'),
}

#: A node parameter's name as ROS reads one on the command line (``-p NAME:=VALUE``).
_PARAMETER_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_.]*')

#: The most integration steps a test may have (its history is held in memory: five arrays per
#: DOF, the loads and the ground motion, per step: 5e7 steps of one DOF take 3 GB).
MAX_STEPS = 50_000_000
#: The part of this machine's memory a test's history may take.
MEMORY_FRACTION = 0.5

#: Relative (Frobenius) difference between ``structure.initial_stiffness`` and the specimen's own
#: initial stiffness above which the definition carries a warning.
STIFFNESS_WARNING_RTOL = 0.01


class _Reader:
    """Typed access to one section of a raw mapping, with errors that name the parameter."""

    def __init__(self, raw: Mapping[str, Any], path: str, source: str) -> None:
        if not isinstance(raw, dict):
            msg = f'{source}: {path}: must be a mapping, got {type(raw).__name__}'
            raise ConfigError(msg)
        self.raw = raw
        self.path = path
        self.source = source
        self.used: set[str] = set()

    def error(self, key: str, what: str) -> ConfigError:
        """Build the one-line error for ``key``."""
        return ConfigError(f'{self.source}: {self.path}.{key}: {what}')

    def get(self, key: str, default: Any = None) -> Any:
        """Raw value of ``key`` (or ``default``)."""
        self.used.add(key)
        return self.raw.get(key, default)

    def finish(self) -> None:
        """Reject keys that were never read (typos must not pass silently)."""
        unknown = sorted(set(self.raw) - self.used)
        if unknown:
            raise self.error(unknown[0], 'unknown parameter')


def load_test_file(path: str | Path, overrides: Mapping[str, Any] | None = None
                   ) -> TestDefinition:
    """Read and validate a YAML test file.

    Args:
        path: the YAML test file.
        overrides: node parameters (names of :data:`PARAMETER_PATHS`) that replace file values.

    Raises:
        ConfigError: the file is missing, not YAML, or a parameter is invalid.
    """
    return read_definition(path, overrides)[0]


def read_definition(path: str | Path, overrides: Mapping[str, Any] | None = None
                    ) -> tuple[TestDefinition, TestFile]:
    """The test definition of a YAML test file and the file read and typed.

    For the other readers of the same process (the launcher's specimens and rig): the file is read
    once.

    Args:
        path: the YAML test file.
        overrides: node parameters (names of :data:`PARAMETER_PATHS`) that replace file values
            (in the definition and the typed file).

    Raises:
        ConfigError: the file is missing, not YAML, or a parameter is invalid.
    """
    path = Path(path)
    source = path.name
    try:
        raw = read_test_data(path)
    except SchemaError as err:  # (cannot be read, not YAML, not a mapping: one line)
        raise ConfigError(str(err)) from None
    definition = from_dict(raw, source=source, base_dir=path.resolve().parent,
                           overrides=overrides)
    # The whole file against the typed schema (pd_common.config.schema), after the sections
    # from_dict reads (typed by the same schema where no DOF count is needed; the structure's
    # matrices and the records checked by hand): it refuses what the integrator does not read,
    # e.g. a bad simulated specimen, with the line every other reader of the file gives.
    data = apply_overrides(raw, overrides, source) if overrides else raw
    try:
        model = validate_test_file(data, source, hysteresis_models=tuple(HYSTERESIS_MODELS),
                                   broken_models=HYSTERESIS_MODELS.broken)
    except SchemaError as err:
        raise ConfigError(str(err)) from None
    return definition, TestFile(path=path, model=model, data=data)


def from_json(text: str, *, source: str = 'bag') -> TestDefinition:
    """Read a resolved definition stored as JSON (e.g. in a bag)."""
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as err:
        msg = f'{source}: test definition is not valid JSON ({err.msg} at char {err.pos})'
        raise ConfigError(msg) from err
    except RecursionError:  # json's decoder recurses per level: thousands of them
        msg = f'{source}: test definition is not a test (JSON nested too deep)'
        raise ConfigError(msg) from None
    protocol = raw.get('protocol') if isinstance(raw, dict) else None
    if isinstance(protocol, dict) and 'tracking_tolerance' not in protocol:
        protocol['tracking_tolerance'] = 0.0  # recorded before the check existed: as it ran
    return from_dict(raw, source=source, base_dir=Path.cwd())


def parse_overrides(items: Sequence[str]) -> dict[str, Any]:
    """``NAME:=VALUE`` items (YAML values, as ``ros2 run --ros-args -p`` reads them).

    Raises:
        ConfigError: an item is not ``NAME:=VALUE`` (one line naming it).
    """
    overrides: dict[str, Any] = {}
    for item in items:
        name, sep, value = item.partition(':=')
        if not sep or not _PARAMETER_NAME.fullmatch(name):
            msg = f'--param {item!r}: expected NAME:=VALUE (a parameter name, e.g. dt:=0.005)'
            raise ConfigError(msg)
        if not value.strip():  # (ROS cannot parse an empty override: the node would not start)
            msg = f'--param {item!r}: no value after := (e.g. {name}:=0.5)'
            raise ConfigError(msg)
        try:
            overrides[name] = load_yaml(value)
        except yaml.YAMLError as err:
            msg = f'--param {item!r}: not a YAML value ({str(err).splitlines()[0]})'
            raise ConfigError(msg) from None
    return overrides


def run_parameter(name: str, value: Any) -> float:
    """A run parameter's value (:data:`RUN_PARAMETERS`) as seconds.

    Raises:
        ConfigError: not a finite number, or below its least value (one line naming it).
    """
    least, inclusive, what = RUN_PARAMETERS[name]
    bound = f'{least:g} or more' if inclusive else f'more than {least:g}'
    try:
        seconds = float(value)
    except (TypeError, ValueError, OverflowError):  # (an integer of 400 digits)
        seconds = math.nan
    if (isinstance(value, bool) or not math.isfinite(seconds)
            or not (seconds >= least if inclusive else seconds > least)):
        shown = repr(value) if len(repr(value)) <= 40 else f'{repr(value)[:37]}...'
        msg = f'parameter {name}: must be a number of seconds, {bound} ({what}); got {shown}'
        raise ConfigError(msg)
    return seconds


def apply_overrides(raw: dict[str, Any], overrides: Mapping[str, Any], source: str
                    ) -> dict[str, Any]:
    """Return a copy of ``raw`` with node parameter overrides applied."""
    result = {key: dict(value) if isinstance(value, dict) else value
              for key, value in raw.items()}
    for name, value in overrides.items():
        if value is None:
            continue
        if name not in PARAMETER_PATHS:
            msg = (f'{source}: parameter {name!r} is not a test parameter (one of '
                   f'{", ".join(PARAMETER_PATHS)})')
            raise ConfigError(msg)
        section, key = PARAMETER_PATHS[name]
        target = result.setdefault(section, {})
        if not isinstance(target, dict):
            msg = f'{source}: {section}: must be a mapping'
            raise ConfigError(msg)
        if name == 'damping_ratio':
            value = {'ratio': value}
        elif name == 'damping_coefficient':
            value = {'coefficient': value}
        target[key] = value
    return result


def from_dict(raw: Mapping[str, Any], *, source: str = '<memory>',
              base_dir: Path | None = None, overrides: Mapping[str, Any] | None = None
              ) -> TestDefinition:
    """Validate a raw test definition (parsed YAML or JSON).

    Raises:
        ConfigError: with a one-line message naming ``source`` and the parameter.
    """
    base_dir = Path.cwd() if base_dir is None else base_dir
    if not isinstance(raw, dict):
        msg = f'{source}: a test file must be a mapping of sections, got {type(raw).__name__}'
        raise ConfigError(msg)
    raw = dict(raw)
    raw.pop('schema_version', None)
    if overrides:
        raw = apply_overrides(raw, overrides, source)
    unknown = sorted(set(raw) - set(SECTIONS))
    if unknown:
        msg = f'{source}: {unknown[0]}: unknown section (expected {", ".join(SECTIONS)})'
        raise ConfigError(msg)

    test = _section('test', raw.get('test', {}), source)
    test_id, scheme, dt, duration = test.id, test.scheme, test.dt, test.duration
    if scheme not in SCHEMES:
        msg = (f'{source}: test.scheme: must be one of {", ".join(sorted(SCHEMES))}, got '
               f'{scheme!r}')
        raise ConfigError(msg)
    scheme_parameters = test.scheme_parameters or {}

    structure = _Reader(raw.get('structure', {}), 'structure', source)
    structure_raw = raw.get('structure', {})
    dof_names = _dof_names(structure)
    n = len(dof_names)
    elements_raw = structure.get('elements')
    mass = _matrix(structure, 'mass', n, required=True)
    assert mass is not None
    stiffness_raw = structure.get('initial_stiffness')
    stiffness: np.ndarray | None
    model = None
    retained = list(range(n))
    elements: Any = ()
    if elements_raw is not None:
        if stiffness_raw is not None:
            error = structure.error('initial_stiffness', 'must not be given with elements (it '
                                    "follows from them and the experimental elements' "
                                    'initial_stiffness)')
            raise error
        elements = _section('structure.elements', elements_raw, source)
        parsed = parse_elements(elements, dof_names=dof_names, mass=mass, source=source,
                                base_dir=base_dir)
        model = parsed.model
        retained = parsed.retained
        mass = parsed.mass
        stiffness = None
    elif stiffness_raw == 'probe':
        stiffness = None
    elif stiffness_raw is None:
        error = structure.error('initial_stiffness', "is required (a value or 'probe')")
        raise error
    else:
        stiffness = _stiffness(structure, stiffness_raw, n)
    _check_mass(structure, mass, [dof_names[i] for i in retained])
    damping, damping_ratio, damping_spec = _damping(structure, n)
    if damping is not None and model is not None and len(retained) != n:
        error = structure.error('damping', 'give a ratio, rayleigh or modal damping with '
                                'massless DOFs (a coefficient matrix would include them)')
        raise error
    influence_given = 'influence' in structure.raw
    influence_raw = structure.get('influence', [1.0] * n)
    influence_full = _vector(structure, 'influence', influence_raw, n)
    structure.finish()
    if duration is not None:
        refusal = steps_refusal(duration / dt, n)
        if refusal is not None:
            msg = f'{source}: test.duration: {duration:g} s at dt {dt:g} s is {refusal}'
            raise ConfigError(msg)

    components, record_steps = _ground_components(
        raw.get('ground_motion'), source, base_dir, dof_names=dof_names, retained=retained,
        default_influence=influence_full, influence_given=influence_given, dt=dt)
    n_steps = record_steps if duration is None else math.floor(duration / dt + 1e-9)
    if n_steps < 1:
        msg = (f'{source}: test.dt: is longer than the test '
               f'({components[0].motion.duration} s)')
        raise ConfigError(msg)
    components = tuple(_padded(component, n_steps) for component in components)
    first = components[0]
    proto = _section('protocol', raw.get('protocol', {}), source)
    protocol = ProtocolSettings(
        feedback_timeout=proto.feedback_timeout or 2.0, max_retries=proto.max_retries,
        start_timeout=proto.start_timeout or 30.0,
        tracking_tolerance=proto.tracking_tolerance)
    probe = ProbeSettings(
        amplitude=_section('probe', raw.get('probe', {}), source).amplitude or 1.0e-3)

    specimen = raw.get('specimen')
    if specimen is not None and not isinstance(specimen, dict):
        msg = f'{source}: specimen: must be a mapping'
        raise ConfigError(msg)

    sites = raw.get('sites')
    if sites is not None and not isinstance(sites, dict):
        msg = f'{source}: sites: must be a mapping of site names to their settings'
        raise ConfigError(msg)
    if sites:
        used = model.site_names if model is not None else ()
        unknown = sorted(str(name) for name in sites if name not in used)
        if unknown:
            where = (f'no experimental element is at this site (sites: {", ".join(used)})'
                     if used else 'only a test with experimental elements has sites')
            msg = f'{source}: sites.{unknown[0]}: {where}'
            raise ConfigError(msg)
    typed_sites = _section('sites', sites, source) or {}
    site_settings = {name: settings if settings is not None else SiteSettings()
                     for name, settings in typed_sites.items()}
    warnings: tuple[str, ...] = ()
    if model is not None:
        stiffness = model.initial_stiffness()
        dof_names = model.dof_names
    elif stiffness is not None and specimen is not None:
        warnings = _specimen_stiffness_warnings(stiffness, specimen, source=source,
                                                base_dir=base_dir, dof_names=dof_names)
    collapse = _collapse(raw.get('collapse'), source, dof_names)

    definition = TestDefinition(
        test_id=test_id, scheme=scheme, dt=dt, n_steps=n_steps, dof_names=dof_names, mass=mass,
        damping=damping, damping_ratio=damping_ratio, initial_stiffness=stiffness,
        influence=first.influence, ground_motion=first.motion,
        ground_acceleration=first.acceleration, specimen=specimen, protocol=protocol,
        probe=probe, source=source, base_dir=base_dir, record_info=first.info,
        scheme_parameters={key: value if isinstance(value, bool | str) else float(value)
                           for key, value in scheme_parameters.items()},
        damping_spec=damping_spec, components=components, model=model,
        structure_raw=_with_absolute_paths(structure_raw, base_dir) if model is not None
        else None, sites=sites, warnings=warnings, collapse=collapse,
        site_settings=site_settings, elements=tuple(elements))
    if stiffness is not None:
        # Validates matrices together (symmetry, definiteness) and derives the damping.
        definition = definition.with_initial_stiffness(stiffness)
    return definition


def _collapse(raw: Any, source: str, dof_names: tuple[str, ...]) -> CollapseSettings | None:
    """The ``collapse`` section (see :mod:`.collapse`), or ``None`` if absent."""
    if raw is None:
        return None
    section = _section('collapse', raw, source)
    values = section.drift if isinstance(section.drift, list) else [section.drift]
    if len(values) not in (1, len(dof_names)):
        msg = (f'{source}: collapse.drift: must be a positive number or a list of '
               f'{len(dof_names)} positive numbers (one per DOF), got {raw["drift"]!r}')
        raise ConfigError(msg)
    drift = tuple(float(v) for v in values) * (len(dof_names) if len(values) == 1 else 1)
    return CollapseSettings(drift=drift, action=section.action or 'stop', window=section.window,
                            tangent_ratio=section.tangent_ratio or 0.0)


def _section(path: str, raw: Any, source: str) -> Any:
    """A part of the test file typed by the schema (``pd_common.config.validate_section``).

    Raises:
        ConfigError: one line naming ``source`` and the dotted path.
    """
    try:
        return validate_section(path, raw, source)
    except SchemaError as err:
        raise ConfigError(str(err)) from None


#: Keys of a hysteresis mapping that name files (pushover backbones).
_FILE_KEYS = ('csv', 'displacement_file', 'reaction_file')


def _with_absolute_paths(raw: Any, base_dir: Path) -> Any:
    """A deep copy of ``raw`` whose backbone file names are absolute (for the bag's copy)."""
    if isinstance(raw, dict):
        return {key: (str((base_dir / value).resolve()) if key in _FILE_KEYS
                      and isinstance(value, str) else _with_absolute_paths(value, base_dir))
                for key, value in raw.items()}
    if isinstance(raw, list):
        return [_with_absolute_paths(item, base_dir) for item in raw]
    return raw


def _dof_names(reader: _Reader) -> tuple[str, ...]:
    names = reader.get('dof_names')
    if names is None:
        mass = reader.raw.get('mass')
        n = len(mass) if isinstance(mass, list) else 1
        return tuple(f'u{i + 1}' for i in range(n))
    if (not isinstance(names, list) or not names
            or not all(isinstance(name, str) and name for name in names)):
        error = reader.error('dof_names', f'must be a non-empty list of names, got {names!r}')
        raise error
    if len(set(names)) != len(names):
        error = reader.error('dof_names', f'names must be unique, got {names!r}')
        raise error
    return tuple(names)


def _matrix(reader: _Reader, key: str, n: int, *, required: bool = False,
            value: Any = None) -> np.ndarray | None:
    raw_value = reader.get(key) if value is None else value
    if raw_value is None:
        if required:
            raise reader.error(key, 'is required')
        return None
    try:
        matrix = as_matrix(raw_value, n, key)
    except (ConfigError, ValueError, TypeError) as err:
        raise reader.error(key, str(err).split(': ')[-1]) from err
    if not np.all(np.isfinite(matrix)):
        raise reader.error(key, 'must contain finite numbers only')
    return matrix


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _stiffness(reader: _Reader, value: Any, n: int) -> np.ndarray:
    """``structure.initial_stiffness`` given as numbers: a scalar (SDOF) or the n×n matrix.

    For an MDOF a scalar or a flat list is refused: ``[k1, k2, k3]`` may be a diagonal or the
    story stiffnesses of a shear building, whose matrices (and periods) differ.
    """
    key = 'initial_stiffness'
    if n == 1:
        matrix = _matrix(reader, key, n, required=True)
        assert matrix is not None
        if matrix[0, 0] < 0.0:
            raise reader.error(key, f'must not be negative, got {float(matrix[0, 0])!r}')
        return matrix
    give = f"give the {n}x{n} matrix (one row per DOF) or 'probe'"
    if _is_number(value):
        raise reader.error(key, f'a single value is ambiguous for {n} DOFs; {give}, '
                           f'got {value!r}')
    if isinstance(value, list) and value and all(_is_number(item) for item in value):
        if len(value) != n:
            raise reader.error(key, f'{give}, got a list of {len(value)} values')
        raise reader.error(key, f'a list of {n} values is ambiguous for {n} DOFs (a diagonal? '
                           f'the story stiffnesses of a shear building?); {give}, '
                           f'got {value!r}')
    try:
        matrix = as_float_array(value, key)
    except ConfigError as err:
        raise reader.error(key, str(err).split(': ', 1)[-1]) from err
    if matrix.shape != (n, n):
        raise reader.error(key, f'{give}, got shape {matrix.shape}')
    scale = float(np.max(np.abs(matrix)))
    if np.any(np.abs(matrix - matrix.T) > SYMMETRY_RTOL * scale):
        raise reader.error(key, 'must be a symmetric matrix')
    eigenvalues = np.linalg.eigvalsh(matrix)
    if eigenvalues[0] < -1e-10 * float(np.max(np.abs(eigenvalues))):
        raise reader.error(key, 'must be positive semi-definite, it has a negative eigenvalue '
                           f'({eigenvalues[0]:.6g})')
    return matrix


def _check_mass(reader: _Reader, mass: np.ndarray, names: list[str]) -> None:
    """``structure.mass``: symmetric positive definite (every retained DOF has a mass > 0)."""
    key = 'mass'
    for name, value in zip(names, np.diag(mass)):
        if not value > 0.0:
            where = f' for DOF {name!r}' if len(names) > 1 else ''
            raise reader.error(key, f'must be positive, got {float(value)!r}{where}')
    if large_diagonal(mass) is not None:  # a large lumped mass: symmetric and positive definite
        return
    scale = float(np.max(np.abs(mass)))
    if np.any(np.abs(mass - mass.T) > SYMMETRY_RTOL * scale):
        raise reader.error(key, 'must be a symmetric matrix')
    try:
        np.linalg.cholesky(mass)
    except np.linalg.LinAlgError:
        raise reader.error(key, 'must be positive definite') from None


def _specimen_stiffness_warnings(stiffness: np.ndarray, specimen: dict[str, Any], *,
                                 source: str, base_dir: Path, dof_names: tuple[str, ...]
                                 ) -> tuple[str, ...]:
    """A warning when ``structure.initial_stiffness`` is not the specimen's own (> 1 %).

    A specimen that cannot be built is not this check's business: the simulator reports it.
    """
    try:
        built = specimen_from_config(specimen, base_dir=base_dir, source=source,
                                     dof_names=dof_names)
        own = np.asarray(built.initial_stiffness_matrix(), dtype=float)
    except (SpecimenError, OSError, ValueError, TypeError):
        return ()
    if own.shape != stiffness.shape:
        return ()
    reference = float(np.linalg.norm(own))
    difference = float(np.linalg.norm(stiffness - own))
    if difference <= STIFFNESS_WARNING_RTOL * reference:
        return ()
    by = (f'by {100.0 * difference / reference:.3g} % (relative Frobenius norm)'
          if reference > 0.0 else '(which is zero)')
    warning = (f"{source}: structure.initial_stiffness differs from the specimen's initial "
               f'stiffness {by}: {_show_matrix(stiffness)} N/m in the structure, '
               f'{_show_matrix(own)} N/m from the specimen')
    return (warning,)


def _show_matrix(matrix: np.ndarray) -> str:
    """A matrix on one line, e.g. ``[[3.5e+08, -1.5e+08], [-1.5e+08, 1.5e+08]]``."""
    if matrix.shape == (1, 1):
        return f'{matrix[0, 0]:.6g}'
    return '[' + ', '.join('[' + ', '.join(f'{value:.6g}' for value in row) + ']'
                           for row in matrix) + ']'


def _vector(reader: _Reader, key: str, value: Any, n: int) -> np.ndarray:
    if first_boolean(value) is not None:
        raise reader.error(key, f'must be a list of {n} numbers, got {value!r}')
    try:
        vector = np.array(value, dtype=float).reshape(-1)
    except (ValueError, TypeError) as err:
        raise reader.error(key, f'must be a list of {n} numbers, got {value!r}') from err
    if vector.size != n or not np.all(np.isfinite(vector)):
        raise reader.error(key, f'must be a list of {n} finite numbers, got {value!r}')
    vector.setflags(write=False)
    return vector


def _damping(reader: _Reader, n: int
             ) -> tuple[np.ndarray | None, float | None, dict[str, Any] | None]:
    """``(coefficient matrix, ratio, rayleigh/modal spec)``: exactly one is set."""
    raw = reader.get('damping', {'ratio': 0.0})
    if _is_number(raw):
        raw = {'ratio': raw}
    section = _section('structure.damping', raw, reader.source)
    damping = _Reader(raw, f'{reader.path}.damping', reader.source)
    if section.ratio is not None:
        return None, section.ratio, None
    if section.rayleigh is not None:
        spec = _Reader(raw['rayleigh'], f'{reader.path}.damping.rayleigh', reader.source)
        ratios = _ratios(spec, 'ratios', section.rayleigh.ratios, 2)
        return None, None, {'rayleigh': {'modes': list(section.rayleigh.modes),
                                         'ratios': ratios}}
    if section.modal is not None:
        return None, None, {'modal': _ratios(damping, 'modal', section.modal, None)}
    matrix = _matrix(damping, 'coefficient', n, value=raw['coefficient'])
    return matrix, None, None


def _ratios(reader: _Reader, key: str, value: float | list[float], count: int | None
            ) -> list[float]:
    """Damping ratios (each in [0, 1) by the schema): ``count`` of them, or one for all."""
    values = [value] * (count or 1) if isinstance(value, float) else value
    if not values or (count is not None and len(values) != count):
        size = f'{count} ' if count else ''
        raise reader.error(key, f'must be a list of {size}damping ratios in [0, 1), got {value!r}')
    return [float(v) for v in values]


def steps_refusal(steps: float, n_dof: int) -> str | None:
    """Why ``steps`` integration steps of ``n_dof`` DOFs are too many for a test.

    As the end of a message (``1e+11 steps; at most 5e+07``), or ``None`` when they fit (at most
    :data:`MAX_STEPS`, and a history within :data:`MEMORY_FRACTION` of this machine's memory).
    """
    if not steps <= MAX_STEPS:  # (an infinite count too)
        return f'{steps:.4g} steps; at most {MAX_STEPS:.0e}'
    need = (steps + 1.0) * (6 * n_dof + 2) * 8.0  # history, loads and ground motion [bytes]
    memory = _physical_memory()
    if memory is not None and need > MEMORY_FRACTION * memory:
        return (f'{steps:.4g} steps of {n_dof} DOF(s): the history needs '
                f"{describe_size(int(need))}, more than {MEMORY_FRACTION:.0%} of this machine's "
                f'{describe_size(memory)}')
    return None


def _physical_memory() -> int | None:
    """This machine's memory [bytes] (``None``: unknown)."""
    try:
        return os.sysconf('SC_PHYS_PAGES') * os.sysconf('SC_PAGE_SIZE')
    except (ValueError, OSError, AttributeError):
        return None


def _ground_components(raw: Any, source: str, base_dir: Path, *, dof_names: tuple[str, ...],
                       retained: list[int], default_influence: np.ndarray,
                       influence_given: bool, dt: float
                       ) -> tuple[tuple[GroundComponent, ...], int]:
    """The ground motion components (one mapping, or a list for multi-directional tests)."""
    if raw is None:
        msg = f'{source}: ground_motion: section is required'
        raise ConfigError(msg)
    section = _section('ground_motion', raw, source)
    n = len(dof_names)
    items: list[tuple[str, list[float] | None, GroundMotionSection, str]]
    if isinstance(section, list):
        if influence_given:
            msg = (f'{source}: structure.influence: with several ground motion components give '
                   'each component its own influence')
            raise ConfigError(msg)
        items = [(f'component{k + 1}' if item.name is None else str(item.name),
                  item.influence, item, f'ground_motion.{k}')
                 for k, item in enumerate(section)]
    else:
        items = [('ground', None, section, 'ground_motion')]
    components = []
    for name, influence_raw, item, path in items:
        motion, info = _ground_motion(item, source, base_dir, path)
        if influence_raw is None:
            full = default_influence
        else:
            full = _vector(_Reader({}, path, source), 'influence', influence_raw, n)
        influence = np.array(full[retained], dtype=float)
        influence.setflags(write=False)
        refusal = steps_refusal(motion.duration / dt, n)
        if refusal is not None:  # before the record is resampled to that many steps
            msg = (f'{source}: test.dt: {dt:g} s over the {motion.duration:g} s of the record '
                   f"'{motion.source}' is {refusal}")
            raise ConfigError(msg)
        resampled = motion.resampled(dt).acceleration
        components.append(GroundComponent(
            name=name, motion=motion, acceleration=resampled, influence=influence,
            influence_raw=None if influence_raw is None else [float(v) for v in full],
            info={**info, 'name': name} if isinstance(raw, list) else info))
    record_steps = max(math.floor(c.motion.duration / dt + 1e-9) for c in components)
    return tuple(components), record_steps


def _padded(component: GroundComponent, n_steps: int) -> GroundComponent:
    """The component with its resampled record cut or zero-padded to ``n_steps + 1`` values."""
    acceleration = np.zeros(n_steps + 1)
    count = min(n_steps + 1, component.acceleration.size)
    acceleration[:count] = component.acceleration[:count]
    acceleration.setflags(write=False)
    return GroundComponent(name=component.name, motion=component.motion,
                           acceleration=acceleration, influence=component.influence,
                           influence_raw=component.influence_raw, info=component.info)


def _ground_motion(section: GroundMotionSection, source: str, base_dir: Path,
                   where: str = 'ground_motion') -> tuple[GroundMotion, dict[str, Any]]:
    """One record of ``ground_motion`` (typed by the schema), read, scaled and directed."""
    scale, direction, units, g = section.scale, section.direction, section.units, section.g
    try:
        if section.inline is not None:
            if units not in ('m/s2', 'm/s^2', 'g'):
                msg = f"{source}: {where}.units: must be 'g' or 'm/s2', got {units!r}"
                raise ConfigError(msg)
            factor = 1.0 if units in ('m/s2', 'm/s^2') else (g or 9.81)
            with np.errstate(over='ignore', invalid='ignore'):  # refused below, not warned
                acceleration = np.asarray(section.inline.acceleration, dtype=float) * factor
            motion = GroundMotion(dt=section.inline.dt, acceleration=acceleration,
                                  source='inline')
            _check_scale(f'{source}: {where}', scale, motion)
            motion = motion.scaled(scale * direction)
            info = dict(section.record) if section.record is not None else {
                'file': 'inline', 'scale': scale, 'direction': direction}
        else:
            assert section.file is not None  # (the schema: file or inline)
            path = Path(section.file)
            if not path.is_absolute():
                path = base_dir / path
            with np.errstate(over='ignore', invalid='ignore'):  # refused, not warned
                motion = read_ground_motion(path, format=section.format or 'auto',
                                            units=units or 'g', dt=section.dt, g=g or 9.81)
            info = {'file': path.name, 'format': section.format, 'units': units, 'g': g,
                    'scale': scale, 'direction': direction, 'record_dt': motion.dt,
                    'record_samples': motion.n_samples}
            _check_scale(f'{source}: {where}', scale, motion)
            motion = motion.scaled(scale * direction)
    except ConfigError:  # (a ValueError) names its key already
        raise
    except GroundMotionError as err:
        msg = f'{source}: {where}: {err}'
        raise ConfigError(msg) from err
    except (TypeError, ValueError) as err:
        msg = f'{source}: {where}: {err}'
        raise ConfigError(msg) from err
    return motion, info


def _check_scale(where: str, scale: float, motion: GroundMotion) -> None:
    """Refuse a ``scale`` that takes the record's peak beyond the largest float."""
    peak = motion.pga
    if not math.isfinite(scale * peak):
        msg = (f"{where}.scale: {scale:g} × the record's peak {peak:.4g} m/s2 is beyond the "
               'largest number')
        raise ConfigError(msg)

