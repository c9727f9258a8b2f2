"""Build a :class:`Specimen` from the ``specimen:`` section of a test YAML file.

Schema (SI units)::

    specimen:
      topology: independent          # or shear_building; default independent
      elements:                      # one per DOF (independent) or per story (shear_building)
        - model: pushover
          backbone:                  # exactly one of bilinear, csv, opensees
            bilinear: {stiffness: 312559.0, yield_force: 12000.0, hardening_ratio: 0.01,
                       max_displacement: 1.0}   # hardening_ratio, max_displacement,
                                                # residual_force optional
            # csv: path/to/curve.csv
            # opensees: {displacement_file: DFree.txt, reaction_file: RBase.txt,
            #            skip_rows: 10, column: 1, force_sign: -1.0, force_scale: 0.02}
          unloading_stiffness: null        # optional, default: backbone initial stiffness
          beyond_last_point: extrapolate   # optional: extrapolate | plateau | error
          memory: none                     # optional: none | kinematic
        - {model: elastic, stiffness: 1.0e5}
        - {model: epp, stiffness: 1.0e5, yield_force: 2.0e3}
        - {model: bilinear, stiffness: 1.0e5, yield_force: 2.0e3, hardening_ratio: 0.02}
        - {model: bilinear, stiffness: 1.0e5, yield_force: 2.0e3, hardening_ratio: -0.05,
           residual_force: 400.0}          # softening to a strength floor (optional)
        - {model: bouc_wen, stiffness: 1.0e5, post_yield_ratio: 0.05, exponent: 1.0,
           beta: 25.0, gamma: 25.0,        # 1/m^n: z_u = (a0 / (beta + gamma))^(1/n) = 0.02 m
           a0: 1.0, delta_a: 0.0, delta_nu: 2.0e-4, delta_eta: 2.0e-4}   # per J, optional

    # or, instead of topology/elements, a cantilever column with P-Δ (basic DOFs u, v; see
    # pd_common.specimen.column), served by the specimen server (model_from_config):
    column:
      height: 3.0                    # L [m]
      axial_stiffness: 1.0e9         # k_a [N/m]
      lateral: {model: bilinear, stiffness: 1.0e6, yield_force: 3.0e4,
                hardening_ratio: -0.01}   # any element mapping above

    ``hardening_ratio`` is in (-1, 1): negative is a softening post-yield slope.
    ``residual_force`` (N, in [0, yield_force], softening only) is a strength floor, in
    ``bilinear`` and in ``backbone.bilinear``. ``memory`` of a pushover element is ``none``
    (the thesis's rule, default) or ``kinematic`` (each direction continues along its
    backbone from the furthest point it reached: cycles stay within the envelope).

Relative file paths resolve against ``base_dir``. Every error is a one-line
:class:`SpecimenConfigError` naming the YAML file and the parameter path.

An element's ``model`` is looked up in :data:`~.models.HYSTERESIS_MODELS`: the built-in models
are registered at the end of this module, a plug-in package adds its own through the
``pd.hysteresis`` entry-point group (:mod:`.models`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from ..config.schema_base import SchemaError
from ..config.test_file import TestFile, read_test_file
from ..errors import SpecimenConfigError, SpecimenError
from ..registry import Parameter
from .backbone import (
    BEYOND_MODES,
    Backbone,
    bilinear_backbone,
    load_backbone_csv,
    load_opensees_pushover,
)
from .bouc_wen import BoucWen
from .column import ColumnSpecimen
from .hysteresis import (
    MEMORY_MODES,
    BilinearKinematic,
    Elastic,
    ElasticPerfectlyPlastic,
    HysteresisModel,
    PushoverHysteresis,
)
from .models import (
    HYSTERESIS_MODELS,
    ElementReader,
    HysteresisModelSpec,
    register_hysteresis_model,
)
from .specimen import TOPOLOGIES, Specimen

_BACKBONE_KINDS = ('bilinear', 'csv', 'opensees')
#: The key of a column specimen (instead of ``elements``).
COLUMN_KEY = 'column'


class _Context:
    """Formats errors as ``<source>: <path>: <message>``."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, path: str, message: str) -> SpecimenConfigError:
        return SpecimenConfigError(f'{self.source}: {path}: {message}')

    def mapping(self, value: Any, path: str, required: set[str], optional: set[str]
                ) -> Mapping[str, Any]:
        """Check that ``value`` is a mapping with the required keys and no unknown key."""
        if not isinstance(value, Mapping):
            raise self.error(path, f'must be a mapping, got {_show(value)}')
        unknown = sorted(str(key) for key in value if key not in required | optional)
        if unknown:
            allowed = ', '.join(sorted(required | optional))
            raise self.error(path, f"unknown key '{unknown[0]}' (allowed: {allowed})")
        missing = sorted(required - set(value))
        if missing:
            raise self.error(path, f"missing key '{missing[0]}'")
        return value

    def number(self, value: Any, path: str, *, positive: bool = True) -> float:
        """Return a finite number (positive unless ``positive`` is False)."""
        what = 'a positive finite number' if positive else 'a finite number'
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = ''
            if isinstance(value, str) and _parses_as_float(value):
                hint = ' (a string: write e.g. 1.0e5, with a dot, so YAML reads a number)'
            raise self.error(path, f'must be {what}, got {_show(value)}{hint}')
        number = float(value)
        if not math.isfinite(number) or (positive and number <= 0.0):
            raise self.error(path, f'must be {what}, got {_show(value)}')
        return number

    def ratio(self, value: Any, path: str) -> float:
        """Return a hardening ratio in (-1, 1) (negative: softening)."""
        number = self.number(value, path, positive=False)
        if not -1.0 < number < 1.0:
            raise self.error(path, f'must be in (-1, 1), got {_show(value)}')
        return number

    def integer(self, value: Any, path: str) -> int:
        """Return an integer >= 0."""
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self.error(path, f'must be an integer >= 0, got {_show(value)}')
        return value

    def text(self, value: Any, path: str) -> str:
        """Return a non-empty string."""
        if not isinstance(value, str) or not value.strip():
            raise self.error(path, f'must be a non-empty string, got {_show(value)}')
        return value


def _show(value: Any) -> str:
    """Short representation of a config value for messages."""
    if isinstance(value, str):
        return repr(value)
    if value is None:
        return 'null'
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, (int, float)):
        return f'{value:g}'
    return type(value).__name__


def _parses_as_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _resolve(base_dir: Path, name: str) -> Path:
    path = Path(name)
    return path if path.is_absolute() else base_dir / path


def _backbone(ctx: _Context, value: Any, path: str, base_dir: Path) -> Backbone:
    """Build the backbone of a pushover element."""
    if not isinstance(value, Mapping):
        raise ctx.error(path, f'must be a mapping, got {_show(value)}')
    kinds = [key for key in value if key in _BACKBONE_KINDS]
    unknown = [str(key) for key in value if key not in _BACKBONE_KINDS]
    if unknown:
        allowed = ', '.join(_BACKBONE_KINDS)
        raise ctx.error(path, f"unknown key '{unknown[0]}' (allowed: {allowed})")
    if len(kinds) != 1:
        raise ctx.error(path, f"needs exactly one of {', '.join(_BACKBONE_KINDS)}, got "
                              f'{len(kinds)}')
    kind = kinds[0]
    path = f'{path}.{kind}'
    spec = value[kind]
    try:
        if kind == 'csv':
            return load_backbone_csv(_resolve(base_dir, ctx.text(spec, path)))
        if kind == 'bilinear':
            spec = ctx.mapping(spec, path, {'stiffness', 'yield_force'},
                               {'hardening_ratio', 'max_displacement', 'residual_force'})
            max_d = spec.get('max_displacement')
            residual = spec.get('residual_force')
            return bilinear_backbone(
                ctx.number(spec['stiffness'], f'{path}.stiffness'),
                ctx.number(spec['yield_force'], f'{path}.yield_force'),
                ctx.ratio(spec.get('hardening_ratio', 0.0), f'{path}.hardening_ratio'),
                None if max_d is None else ctx.number(max_d, f'{path}.max_displacement'),
                None if residual is None else ctx.number(
                    residual, f'{path}.residual_force', positive=False))
        spec = ctx.mapping(spec, path, {'displacement_file', 'reaction_file'},
                           {'skip_rows', 'column', 'force_sign', 'force_scale'})
        sign_key = f'{path}.force_sign'
        sign = ctx.number(spec.get('force_sign', -1.0), sign_key, positive=False)
        if sign == 0.0:
            raise ctx.error(sign_key, 'must be non-zero, got 0')
        return load_opensees_pushover(
            _resolve(base_dir, ctx.text(spec['displacement_file'], f'{path}.displacement_file')),
            _resolve(base_dir, ctx.text(spec['reaction_file'], f'{path}.reaction_file')),
            skip_rows=ctx.integer(spec.get('skip_rows', 10), f'{path}.skip_rows'),
            column=ctx.integer(spec.get('column', 1), f'{path}.column'),
            force_sign=sign,
            force_scale=ctx.number(spec.get('force_scale', 1.0), f'{path}.force_scale'))
    except SpecimenConfigError:
        raise
    except SpecimenError as exc:
        raise ctx.error(path, str(exc)) from None


def _element(ctx: _Context, value: Any, path: str, base_dir: Path) -> HysteresisModel:
    """Build one element: its model's registry entry checks the keys and builds it."""
    if not isinstance(value, Mapping):
        raise ctx.error(path, f'must be a mapping, got {_show(value)}')
    if 'model' not in value:
        raise ctx.error(path, "missing key 'model'")
    model = value['model']
    if not isinstance(model, str) or model not in HYSTERESIS_MODELS:
        model_key = f'{path}.model'
        broken = HYSTERESIS_MODELS.broken.get(model) if isinstance(model, str) else None
        raise ctx.error(model_key, f"must be one of {', '.join(HYSTERESIS_MODELS)}, got "
                                   f'{_show(model)}' + (f' (its plug-in did not load: {broken})'
                                                        if broken else ''))
    entry = HYSTERESIS_MODELS[model]
    spec = ctx.mapping(value, path, entry.required_keys | {'model'}, entry.optional_keys)
    return entry.make(spec, path=path, source=ctx.source, base_dir=base_dir)


def _number(reader: ElementReader, key: str, *, positive: bool = True) -> float:
    """The element's number ``key`` (positive unless ``positive`` is False)."""
    return _Context(reader.source).number(reader.spec[key], f'{reader.path}.{key}',
                                          positive=positive)


def _elastic(reader: ElementReader) -> HysteresisModel:
    """``{model: elastic, stiffness}``."""
    return Elastic(_number(reader, 'stiffness'))


def _epp(reader: ElementReader) -> HysteresisModel:
    """``{model: epp, stiffness, yield_force}``."""
    return ElasticPerfectlyPlastic(_number(reader, 'stiffness'), _number(reader, 'yield_force'))


def _bilinear(reader: ElementReader) -> HysteresisModel:
    """``{model: bilinear, stiffness, yield_force, hardening_ratio[, residual_force]}``."""
    ctx, spec, path = _Context(reader.source), reader.spec, reader.path
    residual = spec.get('residual_force')
    return BilinearKinematic(
        _number(reader, 'stiffness'), _number(reader, 'yield_force'),
        ctx.ratio(spec['hardening_ratio'], f'{path}.hardening_ratio'),
        None if residual is None else _number(reader, 'residual_force', positive=False))


def _pushover(reader: ElementReader) -> HysteresisModel:
    """``{model: pushover, backbone[, unloading_stiffness, beyond_last_point, memory]}``."""
    ctx, spec, path = _Context(reader.source), reader.spec, reader.path
    backbone = _backbone(ctx, spec['backbone'], f'{path}.backbone', reader.base_dir)
    ku = spec.get('unloading_stiffness')
    beyond = spec.get('beyond_last_point', 'extrapolate')
    if beyond not in BEYOND_MODES:
        beyond_key = f'{path}.beyond_last_point'
        raise ctx.error(beyond_key,
                        f"must be one of {', '.join(BEYOND_MODES)}, got {_show(beyond)}")
    memory = spec.get('memory', 'none')
    if memory not in MEMORY_MODES:
        memory_key = f'{path}.memory'
        raise ctx.error(memory_key,
                        f"must be one of {', '.join(MEMORY_MODES)}, got {_show(memory)}")
    return PushoverHysteresis(
        backbone, None if ku is None else _number(reader, 'unloading_stiffness'), beyond, memory)


def _bouc_wen(reader: ElementReader) -> HysteresisModel:
    """A Bouc–Wen element (numbers checked here, ranges by the model, both naming the key)."""
    ctx, spec, path = _Context(reader.source), reader.spec, reader.path
    values: dict[str, Any] = {}
    for key in ('stiffness', 'post_yield_ratio', 'exponent', 'beta', 'gamma', 'a0', 'delta_a',
                'delta_nu', 'delta_eta', 'tolerance'):
        if key in spec:
            values[key] = ctx.number(spec[key], f'{path}.{key}',
                                     positive=key in ('stiffness', 'exponent', 'a0',
                                                      'tolerance'))
    if 'max_iterations' in spec:
        values['max_iterations'] = ctx.integer(spec['max_iterations'], f'{path}.max_iterations')
    return BoucWen(**values)


def hysteresis_from_config(value: Any, *, path: str, base_dir: Path, source: str
                           ) -> HysteresisModel:
    """One hysteresis model from a mapping like an element of ``specimen.elements``.

    Used by the integrator for nonlinear *numerical* springs, so that a numerical spring and a
    simulated specimen with the same mapping are the same model.

    Raises:
        SpecimenConfigError: one line naming ``source`` and ``path``.
    """
    return _element(_Context(source), value, path, Path(base_dir))


def specimen_from_config(section: Mapping[str, Any], *, base_dir: Path, source: str,
                         dof_names: Sequence[str]) -> Specimen:
    """Build the specimen described by the ``specimen:`` section of a test YAML file.

    Args:
        section: The parsed ``specimen:`` mapping.
        base_dir: Directory against which relative file paths resolve.
        source: Name of the YAML file, used in error messages.
        dof_names: Names of the test's DOFs; one element per DOF (story).

    Returns:
        The specimen, in its virgin state.

    Raises:
        SpecimenConfigError: One line naming ``source`` and the parameter path, for unknown or
            missing keys, wrong types, out-of-range values, unreadable or invalid backbone
            files and an element count different from the DOF count.
    """
    ctx = _Context(source)
    if isinstance(section, Mapping) and COLUMN_KEY in section:
        where = 'specimen.column'
        raise ctx.error(where, 'a column specimen is simulated by the specimen server only '
                               '(pd_specimen_sim, the ROS-free runner)')
    # 'errors' (injected experimental errors) and 'commit' belong to the specimen server, which
    # validates them (server.split_errors, server_from_config); the specimen ignores them.
    root, topology_key, elements_key = 'specimen', 'specimen.topology', 'specimen.elements'
    section = ctx.mapping(section, root, {'elements'}, {'topology', 'errors', 'commit'})
    topology = section.get('topology', 'independent')
    if topology not in TOPOLOGIES:
        raise ctx.error(topology_key,
                        f"must be one of {', '.join(TOPOLOGIES)}, got {_show(topology)}")
    items = section['elements']
    if isinstance(items, (str, bytes, Mapping)) or not isinstance(items, Sequence):
        raise ctx.error(elements_key, f'must be a list, got {_show(items)}')
    names = list(dof_names)
    if len(items) != len(names):
        per = 'story' if topology == 'shear_building' else 'DOF'
        raise ctx.error(elements_key,
                        f'{len(items)} elements but {len(names)} DOFs {names} (one per {per})')
    base_dir = Path(base_dir)
    elements = [_element(ctx, item, f'specimen.elements[{i}]', base_dir)
                for i, item in enumerate(items)]
    try:
        return Specimen(elements, topology=topology, dof_names=names)
    except SpecimenConfigError:
        raise
    except SpecimenError as exc:
        raise ctx.error(root, str(exc)) from None


def model_from_config(section: Mapping[str, Any], *, base_dir: Path, source: str,
                      dof_names: Sequence[str]) -> Specimen | ColumnSpecimen:
    """The model of a ``specimen:`` section.

    A :class:`ColumnSpecimen` (``column:``) or a :class:`Specimen` (``elements:``, see
    :func:`specimen_from_config`).

    A column's basic DOFs are ``u, v`` whatever ``dof_names`` (the DOFs served are the site's
    actuators: the specimen server checks their count against its setup).

    Raises:
        SpecimenConfigError: One line naming ``source`` and the parameter path.
    """
    if not (isinstance(section, Mapping) and COLUMN_KEY in section):
        return specimen_from_config(section, base_dir=base_dir, source=source,
                                    dof_names=dof_names)
    ctx = _Context(source)
    if 'elements' in section:
        where = 'specimen'
        raise ctx.error(where, 'give either elements or column, not both')
    section = ctx.mapping(section, 'specimen', {COLUMN_KEY}, {'errors', 'commit'})
    path = 'specimen.column'
    spec = ctx.mapping(section[COLUMN_KEY], path, {'height', 'axial_stiffness', 'lateral'},
                       set())
    height = ctx.number(spec['height'], f'{path}.height')
    axial = ctx.number(spec['axial_stiffness'], f'{path}.axial_stiffness')
    lateral = _element(ctx, spec['lateral'], f'{path}.lateral', Path(base_dir))
    try:
        return ColumnSpecimen(lateral, height, axial)
    except SpecimenError as exc:
        raise ctx.error(path, str(exc).removeprefix('column: ')) from None


def read_specimen_test_file(path: str | Path) -> TestFile:
    """The test file ``path`` read once and validated by the typed schema.

    With the registered hysteresis models (:data:`~.models.HYSTERESIS_MODELS`).

    Raises:
        SpecimenConfigError: it cannot be read or is refused (one line naming the file).
    """
    try:
        return read_test_file(path, hysteresis_models=tuple(HYSTERESIS_MODELS),
                              broken_models=HYSTERESIS_MODELS.broken)
    except SchemaError as err:
        raise SpecimenConfigError(str(err)) from None


def load_specimen_section(path: str | Path | TestFile, site: str = ''
                          ) -> tuple[dict[str, Any], list[str] | None]:
    """The specimen section (of the test, or of ``site``) of a test file and its DOF names.

    Args:
        path: the test file, or the test file read already (:func:`read_specimen_test_file`).
        site: a site of a substructured test ('' for the test's ``specimen`` section).

    The DOF names are ``None`` for a site (they are the site's actuators: the caller knows).

    Raises:
        SpecimenError: the file cannot be read or has no such section.
    """
    test = path if isinstance(path, TestFile) else read_specimen_test_file(path)
    model = test.model
    # The typed file says what is there; the builders (and a simulator's state-file
    # fingerprint) take the section as it was written.
    if site:
        settings = (model.sites or {}).get(site)
        if settings is None or settings.specimen is None:
            msg = (f'{test.source}: sites.{site}.specimen: section is required for the '
                   f'simulated specimen of site {site!r}')
            raise SpecimenError(msg)
        return test.data['sites'][site]['specimen'], None
    if model.specimen is None:
        msg = f'{test.source}: specimen: section is required for the simulated specimen'
        raise SpecimenError(msg)
    structure = model.structure
    names = structure.dof_names
    if names is None:
        mass = structure.mass
        names = [f'u{i + 1}' for i in range(len(mass) if isinstance(mass, list) else 1)]
    return test.data['specimen'], list(names)


def _key(name: str, description: str, *, required: bool = True) -> Parameter:
    """One key of a built-in model (checked by its builder, which names it in messages)."""
    return Parameter(name, None, description, required=required)


_STIFFNESS = _key('stiffness', 'initial stiffness k, N/m (> 0)')
_YIELD_FORCE = _key('yield_force', 'yield force, N (> 0)')

for _spec in (
    HysteresisModelSpec('elastic', _elastic, (_STIFFNESS,), 'linear elastic spring'),
    HysteresisModelSpec('epp', _epp, (_STIFFNESS, _YIELD_FORCE), 'elastic-perfectly plastic'),
    HysteresisModelSpec('bilinear', _bilinear, (
        _STIFFNESS, _YIELD_FORCE,
        _key('hardening_ratio', 'post-yield stiffness over k, in (-1, 1) (< 0: softening)'),
        _key('residual_force', 'strength floor of a softening branch, N', required=False)),
        'bilinear with kinematic hardening (or softening to a floor)'),
    HysteresisModelSpec('pushover', _pushover, (
        _key('backbone', 'the backbone curve: one of bilinear, csv, opensees'),
        _key('unloading_stiffness', "unloading stiffness, N/m (default: the backbone's "
                                    'initial stiffness)', required=False),
        _key('beyond_last_point', 'extrapolate, plateau or error', required=False),
        _key('memory', "none (the thesis's rule) or kinematic", required=False)),
        "a pushover backbone with the thesis's unloading rule"),
    HysteresisModelSpec('bouc_wen', _bouc_wen, (
        _STIFFNESS,
        _key('post_yield_ratio', 'post-yield stiffness over k'),
        _key('exponent', 'smoothness n (> 0)'),
        _key('beta', 'shape parameter beta, 1/m^n'),
        _key('gamma', 'shape parameter gamma, 1/m^n'),
        *(_key(name, description, required=False) for name, description in (
            ('a0', 'initial a (> 0)'), ('delta_a', 'degradation of a per J'),
            ('delta_nu', 'strength degradation per J'),
            ('delta_eta', 'stiffness degradation per J'),
            ('tolerance', 'Newton tolerance (> 0)'),
            ('max_iterations', 'Newton iterations (integer >= 0)')))),
        'Bouc-Wen with degradation'),
):
    register_hysteresis_model(_spec)
