"""The ``structure.elements`` list of a test file: numerical and experimental elements.

Each element names the structure DOFs it connects (``dofs``; ``null`` = the ground)::

    structure:
      dof_names: [u1, u2, u3]
      mass: [2.0e4, 2.0e4, 1.5e4]        # diagonal; 0 = massless (condensed) DOF
      damping: {rayleigh: {modes: [1, 3], ratios: [0.05, 0.05]}}   # or {modal: [...]}, ratio
      elements:
        - {type: experimental, name: story1, site: lab_a, dofs: [u1],
           setup: {type: one_to_one}, initial_stiffness: 4.0e7}
        - {type: spring, dofs: [u1, u2], stiffness: 3.5e7}        # (alias: story)
        - {type: nonlinear_spring, dofs: [u2, u3],
           model: {model: epp, stiffness: 3.0e7, yield_force: 2.0e5}}
        - {type: beam_column, dofs: [null, null, null, u4, v4, r4],
           coordinates: [[0, 0], [0, 3.0]], E: 2.0e11, A: 1.0e-2, I: 1.0e-4}
        - {type: linear, dofs: [u1, u2], stiffness: [[2.0e7, -1.0e7], [-1.0e7, 1.0e7]]}

* ``spring`` / ``story``: linear, ``dofs: [i, j]`` (deformation ``x_j − x_i``) or ``[j]``
  (to the ground), ``stiffness`` [N/m]; optionally ``pdelta: {axial_load: P, height: L}``
  (N, m; both positive): the force becomes ``k d − P d / L`` (a leaning column's P-Δ).
* ``beam_column``: linear 2-D Euler–Bernoulli frame element, six end DOFs
  ``[ux_i, uy_i, rz_i, ux_j, uy_j, rz_j]``, ``coordinates`` of its ends [m], ``E``, ``A``, ``I``;
  optionally ``geometry: linear`` (default), ``pdelta`` (the chord's geometric stiffness, as
  OpenSees's ``geomTransf PDelta``) or ``pdelta_consistent`` (the consistent one) with
  ``axial_load: P`` [N] (compression positive, constant), see
  :func:`~.elements.beam_column_2d_geometric_stiffness`.
* ``linear``: a linear numerical substructure given by its symmetric stiffness matrix
  [N/m] on the structure DOFs ``dofs`` (any of them, no ground: e.g. a condensed model from
  another program, or the vRTHS benchmark's numerical substructure ``K − K_E``).
* ``nonlinear_spring``: like ``spring`` with a ``model`` mapping exactly as an element of a
  ``specimen`` section (elastic, epp, bilinear, pushover); ``pdelta`` as for ``spring``
  (force and tangent of the model minus ``P/L``, :class:`~.elements.PDeltaHysteresis`).
* ``experimental``: measured at ``site``; basic DOFs ``dofs`` (optionally minus
  ``relative_to``, same length, ``null`` = ground), ``setup`` (``one_to_one``,
  ``rigid_link_2``, ``column``, ``planar_3`` or ``planar``, see :mod:`.setups`),
  ``actuators`` (names of the site's actuator DOFs; default from the element),
  ``initial_stiffness`` in basic DOFs (scalar, diagonal or matrix),
  ``control`` per actuator (``{mode: displacement}``, the default, or ``{mode: force,
  force: F}`` with ``F`` in N or a table ``[[t, F], ...]``, see :mod:`.control`). A ``null``
  entry of ``dofs`` is a *free* basic DOF (not a structure DOF: measured, e.g. a column's
  axial shortening under a force-controlled axial load); an element needs exactly one
  force-controlled actuator per ``null`` entry, and its ``initial_stiffness`` is statically
  condensed onto the structure DOFs.

DOFs with zero mass are statically condensed out (only linear elements may touch them); the
session integrates the retained DOFs. With P-Δ terms the initial stiffness (modes, damping,
the ω·Δt check) includes them; if it is then not positive definite the structure is unstable
under its axial loads (one-line ConfigError).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pd_common.specimen import SpecimenError, hysteresis_from_config

from ..errors import ConfigError
from ..matrices import as_matrix
from .control import parse_control
from .elements import (
    BEAM_COLUMN_GEOMETRIES,
    PDeltaHysteresis,
    assemble,
    beam_column_2d_stiffness,
    pdelta_stiffness,
    spring_stiffness,
    static_condensation,
)
from .setups import OneToOneSetup, setup_from_config
from .substructure import ExperimentalElement, NonlinearSpring, StructuralModel

__all__ = ['ELEMENT_TYPES', 'SITE_NAME', 'ParsedModel', 'parse_elements']

ELEMENT_TYPES = ('spring', 'story', 'beam_column', 'linear', 'nonlinear_spring',
                 'experimental')
#: Site names become ROS namespaces: letters, digits and underscores, starting with a letter.
SITE_NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]{0,63}$')

#: ``(DOF indices, element matrix)`` pairs of the linear elements (``None``: the ground).
Parts = list[tuple[list[int | None], np.ndarray]]

_KEYS: dict[str, tuple[set[str], set[str]]] = {
    'spring': ({'dofs', 'stiffness'}, {'pdelta'}),
    'story': ({'dofs', 'stiffness'}, {'pdelta'}),
    'beam_column': ({'dofs', 'coordinates', 'E', 'A', 'I'}, {'geometry', 'axial_load'}),
    'linear': ({'dofs', 'stiffness'}, set()),
    'nonlinear_spring': ({'dofs', 'model'}, {'pdelta'}),
    'experimental': ({'dofs', 'site', 'initial_stiffness'},
                     {'relative_to', 'setup', 'actuators', 'control'}),
}


class ParsedModel:
    """The model on the retained DOFs plus what the test definition needs from it.

    Attributes:
        model: the :class:`StructuralModel`.
        retained: indices of the retained DOFs in ``structure.dof_names``.
        mass: the retained mass matrix.
    """

    def __init__(self, model: StructuralModel, retained: list[int], mass: np.ndarray) -> None:
        self.model = model
        self.retained = retained
        self.mass = mass


def _number(value: Any, where: str, *, positive: bool = True) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(
            float(value)) or (positive and float(value) <= 0.0):
        kind = 'a positive finite number' if positive else 'a finite number'
        msg = f'{where}: must be {kind}, got {value!r}'
        raise ConfigError(msg)
    return float(value)


def _pdelta(raw: Any, where: str) -> tuple[float, float] | None:
    """``(P, L)`` of an element's ``pdelta: {axial_load: P, height: L}`` (``None``: absent)."""
    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        msg = f'{where}: must be a mapping {{axial_load: P, height: L}} (N, m), got {raw!r}'
        raise ConfigError(msg)
    unknown = sorted(str(key) for key in set(raw) - {'axial_load', 'height'})
    if unknown:
        msg = f'{where}.{unknown[0]}: unknown parameter (pdelta has axial_load and height)'
        raise ConfigError(msg)
    for key in ('axial_load', 'height'):
        if key not in raw:
            msg = f'{where}.{key}: is required'
            raise ConfigError(msg)
    return (_number(raw['axial_load'], f'{where}.axial_load'),
            _number(raw['height'], f'{where}.height'))


def _beam_geometry(raw: Mapping[str, Any], path: str) -> tuple[str, float]:
    """A beam-column's ``geometry`` and ``axial_load`` (``linear`` and 0 by default)."""
    geometry = raw.get('geometry', 'linear')
    if geometry not in BEAM_COLUMN_GEOMETRIES:
        msg = (f'{path}.geometry: must be one of {", ".join(BEAM_COLUMN_GEOMETRIES)}, got '
               f'{geometry!r}')
        raise ConfigError(msg)
    if geometry == 'linear':
        if 'axial_load' in raw:
            msg = (f'{path}.axial_load: needs geometry pdelta or pdelta_consistent (a linear '
                   'beam-column ignores the axial load)')
            raise ConfigError(msg)
        return geometry, 0.0
    if 'axial_load' not in raw:
        msg = f'{path}.axial_load: is required with geometry {geometry} (N, compression positive)'
        raise ConfigError(msg)
    return geometry, _number(raw['axial_load'], f'{path}.axial_load', positive=False)


def _condensed(stiffness: np.ndarray, structural: list[int], free: list[int], where: str
               ) -> np.ndarray:
    """``K_ss − K_sf K_ff⁻¹ K_fs``: the stiffness on the structure DOFs when the free DOFs
    are held by constant forces (the given matrix when there are none)."""
    if not free:
        return stiffness
    k_ss = stiffness[np.ix_(structural, structural)]
    k_sf = stiffness[np.ix_(structural, free)]
    k_ff = stiffness[np.ix_(free, free)]
    if not np.all(np.isfinite(k_ff)) or np.linalg.cond(k_ff) > 1e12:
        msg = (f'{where}: its block on the free basic DOFs (null entries of dofs) must be '
               f'invertible, got {k_ff.tolist()!r}')
        raise ConfigError(msg)
    k_fs = stiffness[np.ix_(free, structural)]
    condensed: np.ndarray = k_ss - k_sf @ np.linalg.solve(k_ff, k_fs)
    return condensed


def parse_elements(raw_elements: Any, *, dof_names: Sequence[str], mass: np.ndarray,
                   source: str, base_dir: Path) -> ParsedModel:
    """Build the structural model of ``structure.elements``.

    Raises:
        ConfigError: one line naming ``source`` and the element parameter.
    """
    where = f'{source}: structure.elements'
    if not isinstance(raw_elements, list) or not raw_elements:
        msg = f'{where}: must be a non-empty list of elements'
        raise ConfigError(msg)
    names = list(dof_names)
    index = {name: i for i, name in enumerate(names)}
    n_all = len(names)
    linear: list[tuple[list[int | None], np.ndarray]] = []
    springs: list[tuple[list[int | None], Any, str, str]] = []
    spring_pdelta: list[tuple[float, float] | None] = []
    # The P-Δ parts of the linear elements (already in ``linear``), for the stability message.
    geometric_parts: list[tuple[list[int | None], np.ndarray]] = []
    experimental: list[dict[str, Any]] = []
    touched_nonlinear: set[int] = set()
    element_names: set[str] = set()
    for number, raw in enumerate(raw_elements):
        path = f'{where}[{number}]'
        if not isinstance(raw, Mapping):
            msg = f'{path}: must be a mapping with a type, got {raw!r}'
            raise ConfigError(msg)
        kind = raw.get('type')
        if kind not in _KEYS:
            msg = f'{path}.type: must be one of {", ".join(ELEMENT_TYPES)}, got {kind!r}'
            raise ConfigError(msg)
        name = raw.get('name', f'{kind}{number + 1}')
        if not isinstance(name, str) or not name or name in element_names:
            msg = f'{path}.name: must be a unique non-empty string, got {name!r}'
            raise ConfigError(msg)
        element_names.add(name)
        path = f'{where}[{number}] ({name})'
        required, optional = _KEYS[kind]
        unknown = sorted(set(raw) - required - optional - {'type', 'name'})
        if unknown:
            msg = f'{path}.{unknown[0]}: unknown parameter for a {kind} element'
            raise ConfigError(msg)
        missing = sorted(required - set(raw))
        if missing:
            msg = f'{path}.{missing[0]}: is required for a {kind} element'
            raise ConfigError(msg)

        def dof_list(key: str, size: int | tuple[int, ...], *, nulls: bool = True,
                     _raw: Mapping[str, Any] = raw, _path: str = path) -> list[int | None]:
            value = _raw.get(key)
            sizes = (size,) if isinstance(size, int) else size
            if not isinstance(value, list) or len(value) not in sizes:
                msg = (f'{_path}.{key}: must be a list of {" or ".join(map(str, sizes))} DOF '
                       f'names, got {value!r}')
                raise ConfigError(msg)
            out: list[int | None] = []
            for item in value:
                if item is None and nulls:
                    out.append(None)
                elif isinstance(item, str) and item in index:
                    out.append(index[item])
                else:
                    allowed = 'a DOF name or null' if nulls else 'a DOF name'
                    msg = (f'{_path}.{key}: {item!r} is not {allowed} (DOFs: '
                           f'{", ".join(names)})')
                    raise ConfigError(msg)
            return out

        if kind in ('spring', 'story'):
            dofs = dof_list('dofs', (1, 2))
            if len(dofs) == 1:
                dofs = [None, *dofs]
            matrix = spring_stiffness(_number(raw['stiffness'], f'{path}.stiffness'), name=name)
            pdelta = _pdelta(raw.get('pdelta'), f'{path}.pdelta')
            if pdelta is not None:
                geometric = pdelta_stiffness(*pdelta, name=name)
                matrix = matrix + geometric
                geometric_parts.append((dofs, geometric))
            linear.append((dofs, matrix))
        elif kind == 'beam_column':
            dofs = dof_list('dofs', 6)
            coords = raw['coordinates']
            if (not isinstance(coords, list) or len(coords) != 2 or not all(
                    isinstance(c, list) and len(c) == 2 for c in coords)):
                msg = f'{path}.coordinates: must be [[x_i, y_i], [x_j, y_j]] in m, got {coords!r}'
                raise ConfigError(msg)
            xi = (_number(coords[0][0], f'{path}.coordinates', positive=False),
                  _number(coords[0][1], f'{path}.coordinates', positive=False))
            xj = (_number(coords[1][0], f'{path}.coordinates', positive=False),
                  _number(coords[1][1], f'{path}.coordinates', positive=False))
            geometry, axial_load = _beam_geometry(raw, path)
            properties = (_number(raw['E'], f'{path}.E'), _number(raw['A'], f'{path}.A'),
                          _number(raw['I'], f'{path}.I'))
            try:
                matrix = beam_column_2d_stiffness(xi, xj, *properties, name=name,
                                                  geometry=geometry, axial_load=axial_load)
                if geometry != 'linear':
                    geometric_parts.append((dofs, matrix - beam_column_2d_stiffness(
                        xi, xj, *properties, name=name)))
            except ConfigError as err:
                msg = f'{path}: {err}'
                raise ConfigError(msg) from None
            linear.append((dofs, matrix))
        elif kind == 'linear':
            value = raw.get('dofs')
            dofs = dof_list('dofs', tuple(range(1, n_all + 1)), nulls=False)
            if len(set(dofs)) != len(dofs):
                msg = f'{path}.dofs: must name each DOF once, got {value!r}'
                raise ConfigError(msg)
            try:
                matrix = as_matrix(raw['stiffness'], len(dofs), 'stiffness')
            except ConfigError as err:
                msg = f'{path}.{err}'
                raise ConfigError(msg) from None
            if not np.allclose(matrix, matrix.T, rtol=1e-12, atol=0.0):
                msg = f'{path}.stiffness: must be symmetric'
                raise ConfigError(msg)
            linear.append((dofs, matrix))
        elif kind == 'nonlinear_spring':
            dofs = dof_list('dofs', (1, 2))
            if len(dofs) == 1:
                dofs = [None, *dofs]
            touched_nonlinear.update(i for i in dofs if i is not None)
            springs.append((dofs, raw['model'], name, f'{path}.model'))
            spring_pdelta.append(_pdelta(raw.get('pdelta'), f'{path}.pdelta'))
        else:
            value = raw.get('dofs')
            nulls = isinstance(value, list) and None in value
            dofs = dof_list('dofs', len(value) if isinstance(value, list) and nulls
                            else tuple(range(1, n_all + 1)), nulls=nulls)
            if all(d is None for d in dofs):
                msg = (f'{path}.dofs: needs at least one structure DOF (null entries are free '
                       f'basic DOFs held by force-controlled actuators), got {value!r}')
                raise ConfigError(msg)
            relative = (dof_list('relative_to', len(dofs)) if raw.get('relative_to') is not None
                        else [None] * len(dofs))
            for k, (d, r) in enumerate(zip(dofs, relative)):
                if d is None and r is not None:
                    msg = (f'{path}.relative_to: entry {k + 1} must be null: the basic DOF is '
                           'free (dofs entry null)')
                    raise ConfigError(msg)
            site = raw['site']
            if not isinstance(site, str) or not SITE_NAME.match(site):
                msg = (f'{path}.site: must be a name of letters, digits and _ starting with a '
                       f'letter (it becomes the namespace /pd/<site>), got {site!r}')
                raise ConfigError(msg)
            touched_nonlinear.update(i for i in dofs if i is not None)
            touched_nonlinear.update(i for i in relative if i is not None)
            experimental.append({'name': name, 'site': site, 'dofs': dofs, 'relative': relative,
                                 'raw': raw, 'path': path})

    # Massless DOFs are condensed out (the mass must be diagonal for that).
    diagonal = np.diag(mass)
    massless = [i for i in range(n_all) if diagonal[i] == 0.0]
    if massless and not np.array_equal(mass, np.diag(diagonal)):
        msg = f'{source}: structure.mass: must be diagonal when some DOFs are massless'
        raise ConfigError(msg)
    bad = sorted(set(massless) & touched_nonlinear)
    if bad:
        msg = (f'{source}: structure.mass: DOF {names[bad[0]]} is massless but connected to a '
               'nonlinear or experimental element (only linear elements may touch massless '
               'DOFs, which are condensed out)')
        raise ConfigError(msg)
    retained = [i for i in range(n_all) if i not in set(massless)]
    if not retained:
        msg = f'{source}: structure.mass: every DOF is massless'
        raise ConfigError(msg)
    try:
        linear_retained = _linear_retained(n_all, linear, massless, source)
    except ConfigError:
        if geometric_parts:  # a massless DOF that P-Δ left without stiffness
            _check_stable(n_all, linear, geometric_parts, None, retained, names, source,
                          only=massless)
        raise
    position = {full: i for i, full in enumerate(retained)}

    def remap(indices: list[int | None]) -> tuple[np.ndarray, np.ndarray]:
        return (np.array([position[i] for i in indices if i is not None], dtype=int),
                np.array([-1 if i is None else position[i] for i in indices], dtype=int))

    spring_objects = []
    for (dofs, model_raw, name, path), pdelta in zip(springs, spring_pdelta):
        i, j = dofs
        assert j is not None or i is not None
        if j is None:  # [i, null]: deformation -x_i; keep the convention x_j - x_i
            msg = f'{path.removesuffix(".model")}.dofs: the second DOF must not be null'
            raise ConfigError(msg)
        try:
            hysteresis = hysteresis_from_config(model_raw, path=path.split(': ', 1)[-1],
                                                base_dir=base_dir, source=source)
        except SpecimenError as err:
            raise ConfigError(str(err)) from None
        if pdelta is not None:
            hysteresis = PDeltaHysteresis(hysteresis, *pdelta, name=name)
        spring_objects.append(NonlinearSpring(
            dofs=np.array([position[j]]),
            relative=np.array([-1 if i is None else position[i]]), name=name,
            model=hysteresis))

    experimental_objects = []
    actuator_names_seen: dict[str, set[str]] = {}
    for item in experimental:
        raw = item['raw']
        path = item['path']
        n_basic = len(item['dofs'])
        setup = setup_from_config(raw.get('setup'), n_basic, f'{path}.setup')
        actuators = raw.get('actuators')
        if actuators is None:
            if isinstance(setup, OneToOneSetup):
                actuators = [f'{item["name"]}.a{k + 1}' if d is None
                             else names[d] if r is None else f'{names[d]}-{names[r]}'
                             for k, (d, r) in enumerate(zip(item['dofs'], item['relative']))]
            else:
                actuators = [f'{item["name"]}.a{k + 1}' for k in range(setup.n_actuators)]
        if (not isinstance(actuators, list) or len(actuators) != setup.n_actuators
                or not all(isinstance(a, str) and a for a in actuators)):
            msg = (f'{path}.actuators: must be a list of {setup.n_actuators} actuator names, '
                   f'got {actuators!r}')
            raise ConfigError(msg)
        seen = actuator_names_seen.setdefault(item['site'], set())
        clash = sorted(seen & set(actuators))
        if clash or len(set(actuators)) != len(actuators):
            msg = f'{path}.actuators: actuator names must be unique within site {item["site"]}'
            raise ConfigError(msg)
        seen.update(actuators)
        control = parse_control(raw.get('control'), actuators, f'{path}.control')
        free = [k for k, d in enumerate(item['dofs']) if d is None]
        forced = [a for a, c in zip(actuators, control) if c.force_controlled]
        if len(forced) != len(free):
            msg = (f'{path}.control: {len(forced)} force-controlled actuator'
                   f'{"" if len(forced) == 1 else "s"} for {len(free)} free basic DOF'
                   f'{"" if len(free) == 1 else "s"} (null entries of dofs): each null entry '
                   'needs one actuator {mode: force, force: F} and a force-controlled '
                   'actuator needs one')
            raise ConfigError(msg)
        try:
            stiffness = as_matrix(raw['initial_stiffness'], n_basic, 'initial_stiffness')
        except ConfigError as err:
            msg = f'{path}.{err}'
            raise ConfigError(msg) from None
        structural = [k for k, d in enumerate(item['dofs']) if d is not None]
        condensed = _condensed(stiffness, structural, free, f'{path}.initial_stiffness')
        dofs_r, _ = remap([d for d in item['dofs'] if d is not None])
        _, relative_r = remap([r for d, r in zip(item['dofs'], item['relative'])
                               if d is not None])
        experimental_objects.append(ExperimentalElement(
            dofs=dofs_r, relative=relative_r, name=item['name'], site=item['site'],
            setup=setup, actuator_names=tuple(actuators), initial_stiffness=condensed,
            basic_index=np.array(structural, dtype=np.intp) if free else None,
            control=control if forced else (),
            basic_stiffness=stiffness if free else None))

    model = StructuralModel(
        dof_names=tuple(names[i] for i in retained), linear_stiffness=linear_retained,
        springs=spring_objects, experimental=experimental_objects,
        condensed_names=tuple(names[i] for i in massless))
    mass_retained = mass[np.ix_(retained, retained)]
    if geometric_parts or any(p is not None for p in spring_pdelta):
        _check_stable(n_all, linear, geometric_parts, model, retained, names, source)
    return ParsedModel(model, retained, mass_retained)


def _linear_retained(n_all: int, linear: Parts, massless: list[int], source: str) -> Any:
    """The assembled linear stiffness with the massless DOFs condensed out."""
    linear_full = assemble(n_all, linear) if linear else np.zeros((n_all, n_all))
    if not massless:
        return linear_full
    try:
        condensation = static_condensation(
            linear_full if isinstance(linear_full, np.ndarray) else linear_full.toarray(),
            massless)
    except ConfigError as err:
        msg = f'{source}: structure.elements: {err}'
        raise ConfigError(msg) from None
    return condensation.stiffness


def _dense(matrix: Any) -> np.ndarray:
    return np.array(matrix.toarray() if hasattr(matrix, 'toarray') else matrix, dtype=float)


def _full_stiffness(n_all: int, linear: Parts, model: StructuralModel | None,
                    retained: list[int], *, elastic: bool) -> np.ndarray:
    """The initial stiffness on every DOF (massless ones not condensed): the linear elements,
    and the springs' and experimental elements' initial stiffness on the retained DOFs
    (without their P-Δ terms if ``elastic``)."""
    full = _dense(assemble(n_all, linear, sparse=False)) if linear else np.zeros((n_all,) * 2)
    if model is None:
        return full
    n = model.n_dof
    extra = np.zeros((n, n))
    for spring in model.springs:
        hysteresis = (spring.model.inner if elastic and isinstance(spring.model, PDeltaHysteresis)
                      else spring.model)
        assert hysteresis is not None
        b = spring.matrix(n)
        extra += hysteresis.initial_stiffness * (b.T @ b)
    for element in model.experimental:
        if element.initial_stiffness is not None:
            b = element.matrix(n)
            extra += b.T @ element.initial_stiffness @ b
    full[np.ix_(retained, retained)] += extra
    return full


def _positive_definite(stiffness: np.ndarray) -> bool:
    try:
        np.linalg.cholesky(0.5 * (stiffness + stiffness.T))
    except np.linalg.LinAlgError:
        return False
    return True


def _check_stable(n_all: int, linear: Parts, geometric: Parts, model: StructuralModel | None,
                  retained: list[int], names: list[str], source: str, *,
                  only: list[int] | None = None) -> None:
    """One line if the initial stiffness with the P-Δ terms (on every DOF: a massless DOF may
    buckle too; on the DOFs ``only`` if given) is not positive definite while the one without
    them is; otherwise the usual stiffness checks speak."""
    chosen = list(range(n_all)) if only is None else only
    total = _full_stiffness(n_all, linear, model, retained, elastic=False)[np.ix_(chosen, chosen)]
    if _positive_definite(total):
        return
    elastic_parts = linear + [(dofs, -matrix) for dofs, matrix in geometric]
    elastic = _full_stiffness(n_all, elastic_parts, model, retained,
                              elastic=True)[np.ix_(chosen, chosen)]
    if not _positive_definite(elastic):
        return
    values, shapes = np.linalg.eigh(0.5 * (total + total.T))
    dof = names[chosen[int(np.argmax(np.abs(shapes[:, 0])))]]
    base = float(np.linalg.eigvalsh(0.5 * (elastic + elastic.T))[0])
    msg = (f'{source}: structure.elements: the structure is unstable under its axial loads '
           f'(P-Δ): its initial stiffness with the geometric stiffness is not positive '
           f'definite (lowest eigenvalue {values[0]:.6g} N/m, mostly DOF {dof}; without P-Δ '
           f'{base:.6g} N/m); lower the axial loads or stiffen it')
    raise ConfigError(msg)
