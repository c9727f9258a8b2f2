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

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from pd_common.config.schema_test_file import (
    BeamColumnElement,
    Element,
    LinearElement,
    NonlinearSpringElement,
    SpringElement,
)
from pd_common.config.schema_test_file import ExperimentalElement as ExperimentalSpec
from pd_common.specimen import SpecimenError, hysteresis_from_config

from ..errors import ConfigError
from ..matrices import as_matrix
from .control import parse_control
from .elements import (
    PDeltaHysteresis,
    assemble,
    beam_column_2d_stiffness,
    pdelta_stiffness,
    spring_stiffness,
    static_condensation,
)
from .setups import OneToOneSetup, setup_from_config
from .substructure import ExperimentalElement, NonlinearSpring, StructuralModel

__all__ = ['ParsedModel', 'parse_elements']

#: ``(DOF indices, element matrix)`` pairs of the linear elements (``None``: the ground).
Parts = list[tuple[list[int | None], np.ndarray]]


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


@dataclass(frozen=True)
class _Spring:
    """A nonlinear spring, its DOFs resolved (``[i, j]``, ``i`` ``None``: the ground)."""

    element: NonlinearSpringElement
    name: str
    dofs: list[int | None]
    path: str


@dataclass(frozen=True)
class _Experimental:
    """An experimental element, its basic DOFs and ``relative_to`` resolved."""

    element: ExperimentalSpec
    name: str
    dofs: list[int | None]
    relative: list[int | None]
    path: str


@dataclass
class _Parts:
    """What the elements contribute, in their order."""

    names: list[str]
    linear: Parts = field(default_factory=list)
    #: The P-Δ parts of the linear elements (already in ``linear``), for the stability check.
    geometric: Parts = field(default_factory=list)
    springs: list[_Spring] = field(default_factory=list)
    experimental: list[_Experimental] = field(default_factory=list)
    #: The DOFs a nonlinear or experimental element touches (none may be massless).
    nonlinear_dofs: set[int] = field(default_factory=set)

    def dofs(self, value: Sequence[str | None], path: str, *, nulls: bool = True
             ) -> list[int | None]:
        """DOF names (``null``: the ground or a free DOF if ``nulls``) as indices."""
        out: list[int | None] = []
        for item in value:
            if item is None and nulls:
                out.append(None)
            elif item is not None and item in self.names:
                out.append(self.names.index(item))
            else:
                allowed = 'a DOF name or null' if nulls else 'a DOF name'
                msg = f'{path}: {item!r} is not {allowed} (DOFs: {", ".join(self.names)})'
                raise ConfigError(msg)
        return out


def _condensed(stiffness: np.ndarray, structural: list[int], free: list[int], where: str
               ) -> np.ndarray:
    """The stiffness condensed on the structure DOFs, ``K_ss − K_sf K_ff⁻¹ K_fs``.

    The free DOFs are held by constant forces (the given matrix when there are none).
    """
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


def _grounded(dofs: list[int | None]) -> list[int | None]:
    """A spring's ``[j]`` as ``[null, j]`` (to the ground)."""
    return [None, *dofs] if len(dofs) == 1 else dofs


def _spring(parts: _Parts, element: SpringElement, name: str, path: str) -> None:
    dofs = _grounded(parts.dofs(element.dofs, f'{path}.dofs'))
    matrix = spring_stiffness(element.stiffness, name=name)
    if element.pdelta is not None:
        geometric = pdelta_stiffness(element.pdelta.axial_load, element.pdelta.height,
                                     name=name)
        matrix = matrix + geometric
        parts.geometric.append((dofs, geometric))
    parts.linear.append((dofs, matrix))


def _beam_column(parts: _Parts, element: BeamColumnElement, name: str, path: str) -> None:
    dofs = parts.dofs(element.dofs, f'{path}.dofs')
    geometry = element.geometry
    if geometry == 'linear' and element.axial_load is not None:
        msg = (f'{path}.axial_load: needs geometry pdelta or pdelta_consistent (a linear '
               'beam-column ignores the axial load)')
        raise ConfigError(msg)
    if geometry != 'linear' and element.axial_load is None:
        msg = f'{path}.axial_load: is required with geometry {geometry} (N, compression positive)'
        raise ConfigError(msg)
    (xi, yi), (xj, yj) = element.coordinates
    properties = (element.E, element.A, element.I)
    try:
        matrix = beam_column_2d_stiffness((xi, yi), (xj, yj), *properties, name=name,
                                          geometry=geometry,
                                          axial_load=element.axial_load or 0.0)
        if geometry != 'linear':
            parts.geometric.append((dofs, matrix - beam_column_2d_stiffness(
                (xi, yi), (xj, yj), *properties, name=name)))
    except ConfigError as err:
        msg = f'{path}: {err}'
        raise ConfigError(msg) from None
    parts.linear.append((dofs, matrix))


def _linear(parts: _Parts, element: LinearElement, path: str) -> None:
    if len(element.dofs) > len(parts.names) or len(set(element.dofs)) != len(element.dofs):
        msg = f'{path}.dofs: must name each DOF once, got {element.dofs!r}'
        raise ConfigError(msg)
    dofs = parts.dofs(element.dofs, f'{path}.dofs', nulls=False)
    try:
        matrix = as_matrix(element.stiffness, len(dofs), 'stiffness')
    except ConfigError as err:
        msg = f'{path}.{err}'
        raise ConfigError(msg) from None
    if not np.allclose(matrix, matrix.T, rtol=1e-12, atol=0.0):
        msg = f'{path}.stiffness: must be symmetric'
        raise ConfigError(msg)
    parts.linear.append((dofs, matrix))


def _nonlinear_spring(parts: _Parts, element: NonlinearSpringElement, name: str, path: str
                      ) -> None:
    dofs = _grounded(parts.dofs(element.dofs, f'{path}.dofs'))
    if dofs[1] is None:  # [i, null]: deformation -x_i; keep the convention x_j - x_i
        msg = f'{path}.dofs: the second DOF must not be null'
        raise ConfigError(msg)
    parts.nonlinear_dofs.update(i for i in dofs if i is not None)
    parts.springs.append(_Spring(element, name, dofs, path))


def _experimental(parts: _Parts, element: ExperimentalSpec, name: str, path: str) -> None:
    nulls = None in element.dofs
    if not nulls and len(element.dofs) > len(parts.names):
        msg = (f'{path}.dofs: must be a list of 1 to {len(parts.names)} DOF names, got '
               f'{element.dofs!r}')
        raise ConfigError(msg)
    dofs = parts.dofs(element.dofs, f'{path}.dofs', nulls=nulls)
    if all(d is None for d in dofs):
        msg = (f'{path}.dofs: needs at least one structure DOF (null entries are free basic '
               f'DOFs held by force-controlled actuators), got {element.dofs!r}')
        raise ConfigError(msg)
    relative: list[int | None] = [None] * len(dofs)
    if element.relative_to is not None:
        if len(element.relative_to) != len(dofs):
            msg = (f'{path}.relative_to: must be a list of {len(dofs)} DOF names, got '
                   f'{element.relative_to!r}')
            raise ConfigError(msg)
        relative = parts.dofs(element.relative_to, f'{path}.relative_to')
    for k, (d, r) in enumerate(zip(dofs, relative)):
        if d is None and r is not None:
            msg = (f'{path}.relative_to: entry {k + 1} must be null: the basic DOF is free '
                   '(dofs entry null)')
            raise ConfigError(msg)
    parts.nonlinear_dofs.update(i for i in (*dofs, *relative) if i is not None)
    parts.experimental.append(_Experimental(element, name, dofs, relative, path))


def _collect(elements: Sequence[Element], names: list[str], where: str) -> _Parts:
    """Each element's DOFs resolved and its linear matrix built, in order."""
    parts = _Parts(names)
    element_names: set[str] = set()
    for number, element in enumerate(elements):
        path = f'{where}.{number}'
        name = element.name if element.name is not None else f'{element.type}{number + 1}'
        if name in element_names:
            msg = f'{path}.name: must be unique, got {name!r}'
            raise ConfigError(msg)
        element_names.add(name)
        if isinstance(element, SpringElement):
            _spring(parts, element, name, path)
        elif isinstance(element, BeamColumnElement):
            _beam_column(parts, element, name, path)
        elif isinstance(element, LinearElement):
            _linear(parts, element, path)
        elif isinstance(element, NonlinearSpringElement):
            _nonlinear_spring(parts, element, name, path)
        else:
            _experimental(parts, element, name, path)
    return parts


def _massless(mass: np.ndarray, parts: _Parts, source: str) -> tuple[list[int], list[int]]:
    """The ``(massless, retained)`` DOF indices.

    The massless ones are condensed out (the mass must be diagonal for that, and no nonlinear
    or experimental element may touch them).
    """
    names = parts.names
    diagonal = np.diag(mass)
    massless = [i for i in range(len(names)) if diagonal[i] == 0.0]
    if massless and not np.array_equal(mass, np.diag(diagonal)):
        msg = f'{source}: structure.mass: must be diagonal when some DOFs are massless'
        raise ConfigError(msg)
    bad = sorted(set(massless) & parts.nonlinear_dofs)
    if bad:
        msg = (f'{source}: structure.mass: DOF {names[bad[0]]} is massless but connected to a '
               'nonlinear or experimental element (only linear elements may touch massless '
               'DOFs, which are condensed out)')
        raise ConfigError(msg)
    retained = [i for i in range(len(names)) if i not in set(massless)]
    if not retained:
        msg = f'{source}: structure.mass: every DOF is massless'
        raise ConfigError(msg)
    return massless, retained


def _spring_object(spring: _Spring, position: dict[int, int], *, source: str,
                   base_dir: Path) -> NonlinearSpring:
    i, j = spring.dofs
    assert j is not None
    raw = spring.element.model.model_dump(exclude_unset=True)
    try:
        hysteresis = hysteresis_from_config(raw, path=f'{spring.path.split(": ", 1)[-1]}.model',
                                            base_dir=base_dir, source=source)
    except SpecimenError as err:
        raise ConfigError(str(err)) from None
    pdelta = spring.element.pdelta
    if pdelta is not None:
        hysteresis = PDeltaHysteresis(hysteresis, pdelta.axial_load, pdelta.height,
                                      name=spring.name)
    return NonlinearSpring(dofs=np.array([position[j]]),
                           relative=np.array([-1 if i is None else position[i]]),
                           name=spring.name, model=hysteresis)


def _actuator_names(item: _Experimental, n_actuators: int, one_to_one: bool, names: list[str]
                    ) -> list[str]:
    """The element's actuator names: given, or from its DOFs (one-to-one) or its name."""
    if item.element.actuators is not None:
        return list(item.element.actuators)
    if one_to_one:
        return [f'{item.name}.a{k + 1}' if d is None
                else names[d] if r is None else f'{names[d]}-{names[r]}'
                for k, (d, r) in enumerate(zip(item.dofs, item.relative))]
    return [f'{item.name}.a{k + 1}' for k in range(n_actuators)]


def _experimental_object(item: _Experimental, position: dict[int, int], names: list[str],
                         seen: dict[str, set[str]]) -> ExperimentalElement:
    element, path = item.element, item.path
    n_basic = len(item.dofs)
    setup_raw = None if element.setup is None else element.setup.model_dump(exclude_unset=True)
    setup = setup_from_config(setup_raw, n_basic, f'{path}.setup')
    actuators = _actuator_names(item, setup.n_actuators, isinstance(setup, OneToOneSetup),
                                names)
    if len(actuators) != setup.n_actuators:
        msg = (f'{path}.actuators: must be a list of {setup.n_actuators} actuator names, '
               f'got {actuators!r}')
        raise ConfigError(msg)
    at_site = seen.setdefault(element.site, set())
    if at_site & set(actuators) or len(set(actuators)) != len(actuators):
        msg = f'{path}.actuators: actuator names must be unique within site {element.site}'
        raise ConfigError(msg)
    at_site.update(actuators)
    control = parse_control(element.control, actuators, f'{path}.control')
    free = [k for k, d in enumerate(item.dofs) if d is None]
    forced = [a for a, c in zip(actuators, control) if c.force_controlled]
    if len(forced) != len(free):
        msg = (f'{path}.control: {len(forced)} force-controlled actuator'
               f'{"" if len(forced) == 1 else "s"} for {len(free)} free basic DOF'
               f'{"" if len(free) == 1 else "s"} (null entries of dofs): each null entry '
               'needs one actuator {mode: force, force: F} and a force-controlled '
               'actuator needs one')
        raise ConfigError(msg)
    try:
        stiffness = as_matrix(element.initial_stiffness, n_basic, 'initial_stiffness')
    except ConfigError as err:
        msg = f'{path}.{err}'
        raise ConfigError(msg) from None
    structural = [k for k, d in enumerate(item.dofs) if d is not None]
    condensed = _condensed(stiffness, structural, free, f'{path}.initial_stiffness')
    return ExperimentalElement(
        dofs=np.array([position[d] for d in item.dofs if d is not None], dtype=int),
        relative=np.array([-1 if r is None else position[r]
                           for d, r in zip(item.dofs, item.relative) if d is not None],
                          dtype=int),
        name=item.name, site=element.site, setup=setup, actuator_names=tuple(actuators),
        initial_stiffness=condensed,
        basic_index=np.array(structural, dtype=np.intp) if free else None,
        control=control if forced else (), basic_stiffness=stiffness if free else None)


def parse_elements(elements: Sequence[Element], *, dof_names: Sequence[str], mass: np.ndarray,
                   source: str, base_dir: Path) -> ParsedModel:
    """Build the structural model of ``structure.elements``.

    The elements are typed by the schema (``pd_common.config.validate_elements``).

    Raises:
        ConfigError: one line naming ``source`` and the element's dotted path
            (``test.yaml: structure.elements.0.dofs: 'u9' is not a DOF name or null ...``).
    """
    names = list(dof_names)
    parts = _collect(elements, names, f'{source}: structure.elements')
    massless, retained = _massless(mass, parts, source)
    n_all = len(names)
    try:
        linear_retained = _linear_retained(n_all, parts.linear, massless, source)
    except ConfigError:
        if parts.geometric:  # a massless DOF that P-Δ left without stiffness
            _check_stable(n_all, parts.linear, parts.geometric, None, retained, names, source,
                          only=massless)
        raise
    position = {full: i for i, full in enumerate(retained)}
    springs = [_spring_object(spring, position, source=source, base_dir=base_dir)
               for spring in parts.springs]
    seen: dict[str, set[str]] = {}
    experimental = [_experimental_object(item, position, names, seen)
                    for item in parts.experimental]
    model = StructuralModel(
        dof_names=tuple(names[i] for i in retained), linear_stiffness=linear_retained,
        springs=springs, experimental=experimental,
        condensed_names=tuple(names[i] for i in massless))
    mass_retained = mass[np.ix_(retained, retained)]
    if parts.geometric or any(spring.element.pdelta is not None for spring in parts.springs):
        _check_stable(n_all, parts.linear, parts.geometric, model, retained, names, source)
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
    """The initial stiffness on every DOF (massless ones not condensed).

    The linear elements, and the springs' and experimental elements' initial stiffness on the
    retained DOFs (without their P-Δ terms if ``elastic``).
    """
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
    """Refuse, in one line, a stiffness that P-Δ alone makes indefinite.

    That is: the initial stiffness with the P-Δ terms (on every DOF: a massless DOF may buckle
    too; on the DOFs ``only`` if given) is not positive definite while the one without them
    is; otherwise the usual stiffness checks speak.
    """
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
