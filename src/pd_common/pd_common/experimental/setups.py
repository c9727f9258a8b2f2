"""Experimental setups: from an experimental element's DOFs to a site's actuator strokes.

As in OpenFresco's layering, an *experimental element* lives in the numerical model and has
*basic* DOFs (e.g. a story drift, or the translation and rotation of a column top); the
*setup* transforms them to the strokes of the actuators of its site and transforms what the
site measures (actuator displacements and forces) back to the element's basic DOFs:

* :meth:`ExperimentalSetup.actuator_targets` — basic trial displacement → actuator commands;
* :meth:`ExperimentalSetup.basic_displacement` — measured actuator displacements → basic;
* :meth:`ExperimentalSetup.basic_force` — measured actuator forces → basic forces
  (``f_b = Jᵀ f_a`` with ``J = ∂d_a/∂d_b``: exact by virtual work for pinned actuators).

The module is shared by the integrator (its experimental elements) and the simulated
specimen (to emulate the lab's geometry); it imports neither ROS nor a node package, and
raises :class:`~pd_common.errors.SetupError` (one line).

Setups (``setup.type`` in the test file):

``one_to_one``
    one actuator per basic DOF, ``d_a = d_b``.
``rigid_link_2``
    two parallel actuators acting on a rigid link, for a translation ``u`` and a rotation
    ``θ`` (the link's basic DOFs, in this order). Actuator *i* is attached to the link at the
    distance ``a_i`` (``offsets``) from the reference point, measured along the link
    (perpendicular to the actuators); ``θ`` is positive when it moves the point at ``+a`` in
    the actuators' positive direction. ``geometry: linear`` (default) gives
    ``d_i = u + a_i θ``. ``geometry: nonlinear`` takes the actuators' rotation into account
    (``actuator_length`` L, from the reaction pin to the attachment point at rest):
    ``d_i = sqrt((L + u + a_i sin θ)² + (a_i (1 − cos θ))²) − L``; its inverse is found by
    Newton iterations.
``planar`` (:class:`PlanarActuators`)
    a rigid body in the plane (x horizontal, y vertical up, the reference point at the origin
    at rest) with basic DOFs ``(u, v)`` or ``(u, v, θ)`` (θ counter-clockwise), and as many
    pinned actuators as basic DOFs. Actuator *i* goes from its reaction pin ``pin_i`` to the
    body point ``attach_i`` (its position at rest); with ``p_i(b) = (u, v) + R(θ)·attach_i``
    its stroke is ``d_i = |p_i − pin_i| − |attach_i − pin_i|``, and a positive force pushes
    the body along ``e_i = (p_i − pin_i)/|p_i − pin_i|``. ``J``'s row *i* is
    ``e_iᵀ ∂p_i/∂b`` (exact), the basic forces ``Jᵀ f``. ``geometry: nonlinear`` (default)
    is exact (inverse by Newton iterations); ``linear`` uses the Jacobian at rest.
``column`` (:class:`ColumnSetup`)
    a column top (basic DOFs ``u, v``) loaded by a horizontal actuator (pin at
    ``(−horizontal_length, 0)``, pushes in +x) and a vertical one (pin above the top at
    ``(0, vertical_length)``, a positive force pushes down: an axial load ``P`` is the force
    ``+P``); actuators in this order. The tilted vertical actuator adds ``≈ P·u/vertical_length``
    to the lateral basic force (exactly ``P·u/|p − pin|``).
``planar_3`` (:class:`PlanarThreeActuators`)
    a loading beam on a column top (basic DOFs ``u, v, θ``): vertical actuators at
    ``x = −offset`` and ``x = +offset`` (pins at height ``vertical_length`` above them), and a
    horizontal one at the reference point (pin at ``(−horizontal_length, 0)``), in this order.
"""

from __future__ import annotations

import abc
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import SetupError

__all__ = [
    'SETUP_TYPES',
    'ColumnSetup',
    'ExperimentalSetup',
    'OneToOneSetup',
    'PlanarActuators',
    'PlanarThreeActuators',
    'RigidLinkTwoActuators',
    'setup_from_config',
]

GEOMETRIES = ('linear', 'nonlinear')


class ExperimentalSetup(abc.ABC):
    """Maps an element's basic DOFs to actuator DOFs and back."""

    #: Number of basic DOFs of the element.
    n_basic: int
    #: Number of actuators.
    n_actuators: int

    @abc.abstractmethod
    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        """Actuator strokes [m] that impose the basic displacement ``basic``."""

    @abc.abstractmethod
    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        """``∂ d_actuator / ∂ d_basic`` at ``basic`` (``n_actuators × n_basic``)."""

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        """The basic displacement that produced the measured actuator strokes."""
        return np.linalg.solve(self.jacobian(np.zeros(self.n_basic)), actuator)

    def basic_force(
        self, actuator_force: NDArray[np.float64], basic: np.ndarray
    ) -> NDArray[np.float64]:
        """Basic forces equivalent to the actuator forces at ``basic`` (``Jᵀ f``)."""
        return self.jacobian(basic).T @ actuator_force


class OneToOneSetup(ExperimentalSetup):
    """One actuator per basic DOF: ``d_a = d_b``."""

    def __init__(self, n_basic: int) -> None:
        if n_basic < 1:
            msg = f'one_to_one setup: needs at least one DOF, got {n_basic}'
            raise SetupError(msg)
        self.n_basic = n_basic
        self.n_actuators = n_basic
        self._identity = np.eye(n_basic)

    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        """Actuator strokes [m]: the basic displacement itself."""
        return np.array(basic, dtype=float)

    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        """The identity matrix."""
        return self._identity

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        """The basic displacement: the measured strokes themselves."""
        return np.array(actuator, dtype=float)

    def basic_force(
        self, actuator_force: NDArray[np.float64], basic: np.ndarray
    ) -> NDArray[np.float64]:
        """Basic forces: the actuator forces themselves."""
        return np.array(actuator_force, dtype=float)


class RigidLinkTwoActuators(ExperimentalSetup):
    """Two parallel actuators on a rigid link: basic DOFs (u, θ) → two strokes.

    Args:
        offsets: ``(a_1, a_2)`` [m], attachment points along the link (distinct).
        geometry: ``'linear'`` (small rotations) or ``'nonlinear'`` (exact actuator geometry).
        actuator_length: L [m], pin-to-attachment length at rest (``nonlinear`` only).
    """

    NEWTON_TOLERANCE = 1e-14
    NEWTON_ITERATIONS = 50

    def __init__(self, offsets: Sequence[float], geometry: str = 'linear',
                 actuator_length: float | None = None) -> None:
        a = [float(value) for value in offsets]
        if len(a) != 2 or not all(math.isfinite(value) for value in a) or a[0] == a[1]:
            msg = ('rigid_link_2 setup: offsets must be two distinct finite numbers, '
                   f'got {offsets!r}')
            raise SetupError(msg)
        if geometry not in GEOMETRIES:
            msg = f"rigid_link_2 setup: geometry must be 'linear' or 'nonlinear', got {geometry!r}"
            raise SetupError(msg)
        if geometry == 'nonlinear' and (actuator_length is None or not math.isfinite(
                actuator_length) or actuator_length <= 0.0):
            msg = ('rigid_link_2 setup: geometry nonlinear needs a positive actuator_length, '
                   f'got {actuator_length!r}')
            raise SetupError(msg)
        self.n_basic = 2
        self.n_actuators = 2
        self.offsets = np.array(a)
        self.geometry = geometry
        self.actuator_length = actuator_length
        self._linear = np.array([[1.0, a[0]], [1.0, a[1]]])

    def _length(self) -> float:
        """L [m]: set (and positive) for the nonlinear geometry (checked on construction)."""
        if self.actuator_length is None:
            msg = 'rigid_link_2 setup: geometry nonlinear needs a positive actuator_length'
            raise SetupError(msg)
        return float(self.actuator_length)

    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        """Actuator strokes [m] that impose the basic displacement ``basic``."""
        u, theta = float(basic[0]), float(basic[1])
        if self.geometry == 'linear':
            return u + self.offsets * theta
        length = self._length()
        along = length + u + self.offsets * math.sin(theta)
        across = self.offsets * (1.0 - math.cos(theta))
        return np.hypot(along, across) - length

    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        """``∂ d_actuator / ∂ d_basic`` at ``basic`` (``n_actuators × n_basic``)."""
        if self.geometry == 'linear':
            return self._linear
        u, theta = float(basic[0]), float(basic[1])
        length = self._length()
        a = self.offsets
        along = length + u + a * math.sin(theta)
        across = a * (1.0 - math.cos(theta))
        stroke = np.hypot(along, across)
        d_u = along / stroke
        d_theta = (along * a * math.cos(theta) + across * a * math.sin(theta)) / stroke
        return np.column_stack((d_u, d_theta))

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        """The basic displacement that produced the measured actuator strokes."""
        actuator = np.asarray(actuator, dtype=float)
        basic = np.linalg.solve(self._linear, actuator)
        if self.geometry == 'linear':
            return basic
        for _ in range(self.NEWTON_ITERATIONS):
            residual = self.actuator_targets(basic) - actuator
            if float(np.max(np.abs(residual))) <= self.NEWTON_TOLERANCE * (
                    1.0 + float(np.max(np.abs(actuator)))):
                return basic
            basic = basic - np.linalg.solve(self.jacobian(basic), residual)
        msg = (f'rigid_link_2 setup: no (u, theta) found for the measured strokes '
               f'{actuator.tolist()!r}')
        raise SetupError(msg)


def _norms(vectors: NDArray[np.float64]) -> NDArray[np.float64]:
    """The lengths of the rows ``(x, y)`` of ``vectors``."""
    lengths: NDArray[np.float64] = np.hypot(vectors[:, 0], vectors[:, 1])
    return lengths


class PlanarActuators(ExperimentalSetup):
    """Pinned actuators on a rigid body in the plane: basic ``(u, v)`` or ``(u, v, θ)``.

    x is horizontal, y vertical up, θ counter-clockwise; the body's reference point is at the
    origin at rest. Actuator *i* is pinned to a reaction at ``pins[i]`` and to the body at
    ``attachments[i]`` (body coordinates = its position at rest).

    Args:
        pins: ``(x, y)`` [m] of each actuator's reaction pin.
        attachments: ``(x, y)`` [m] of each actuator's body attachment point at rest.
        n_basic: 2 (translation ``u, v``) or 3 (``u, v, θ``); must equal the actuator count.
        geometry: ``'nonlinear'`` (exact) or ``'linear'`` (the Jacobian at rest).
        name: the setup's name in error messages (``'<name> setup: …'``).

    Raises:
        SetupError: invalid points, counts or geometry, or a singular Jacobian at rest.
    """

    NEWTON_TOLERANCE = 1e-14
    NEWTON_ITERATIONS = 50
    #: Above this condition number the Jacobian at rest is taken as singular.
    SINGULAR_CONDITION = 1e12

    def __init__(self, pins: Sequence[Sequence[float]], attachments: Sequence[Sequence[float]],
                 n_basic: int, geometry: str = 'nonlinear', name: str = 'planar') -> None:
        self.name = name
        if n_basic not in (2, 3):
            msg = f'{name} setup: needs 2 (u, v) or 3 (u, v, theta) basic DOFs, got {n_basic}'
            raise SetupError(msg)
        if geometry not in GEOMETRIES:
            msg = f"{name} setup: geometry must be 'linear' or 'nonlinear', got {geometry!r}"
            raise SetupError(msg)
        pin = self._points(pins, 'pins')
        attach = self._points(attachments, 'attachments')
        if len(pin) != len(attach):
            msg = (f'{name} setup: {len(pin)} pins but {len(attach)} attachment points '
                   '(one of each per actuator)')
            raise SetupError(msg)
        if len(pin) != n_basic:
            msg = (f'{name} setup: needs as many actuators as basic DOFs ({n_basic}), '
                   f'got {len(pin)}')
            raise SetupError(msg)
        rest = _norms(attach - pin)
        if not np.all(rest > 0.0):
            index = int(np.argmin(rest))
            msg = f'{name} setup: actuator {index + 1} has its pin at its attachment point'
            raise SetupError(msg)
        self.n_basic = n_basic
        self.n_actuators = n_basic
        self.pins = pin
        self.attachments = attach
        self.rest_lengths = rest
        self.geometry = geometry
        self._at_rest = self._exact_jacobian(np.zeros(n_basic))
        condition = float(np.linalg.cond(self._at_rest))
        if not condition < self.SINGULAR_CONDITION:
            msg = (f'{name} setup: the actuators cannot impose the {n_basic} basic DOFs '
                   f'(Jacobian at rest singular, condition number {condition:.3g})')
            raise SetupError(msg)

    def _points(self, points: Sequence[Sequence[float]], what: str) -> NDArray[np.float64]:
        try:
            array = np.array(points, dtype=float)
        except (TypeError, ValueError):
            array = np.empty((0, 0))
        if array.ndim != 2 or array.shape[1] != 2 or not np.all(np.isfinite(array)):
            msg = (f'{self.name} setup: {what} must be a list of [x, y] finite points, '
                   f'got {points!r}')
            raise SetupError(msg)
        return array

    def _positions(self, basic: np.ndarray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The attachment points ``p_i(b)`` and ``∂p_i/∂θ`` (zero for the translation setup)."""
        b = np.asarray(basic, dtype=float)
        theta = float(b[2]) if self.n_basic == 3 else 0.0
        c, s = math.cos(theta), math.sin(theta)
        x, y = self.attachments[:, 0], self.attachments[:, 1]
        points = np.column_stack((b[0] + c * x - s * y, b[1] + s * x + c * y))
        d_theta = np.column_stack((-s * x - c * y, c * x - s * y))
        return points, d_theta

    def directions(self, basic: np.ndarray) -> NDArray[np.float64]:
        """Unit vectors ``e_i`` (rows) from each pin to its attachment point at ``basic``."""
        points, _ = self._positions(basic)
        chord = points - self.pins
        unit: NDArray[np.float64] = chord / _norms(chord)[:, None]
        return unit

    def _exact_jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        _, d_theta = self._positions(basic)
        e = self.directions(basic)
        if self.n_basic == 2:
            return e
        full: NDArray[np.float64] = np.column_stack((e, np.sum(e * d_theta, axis=1)))
        return full

    def actuator_targets(self, basic: np.ndarray) -> np.ndarray:
        """Actuator strokes [m] that impose the basic displacement ``basic``."""
        if self.geometry == 'linear':
            linear: NDArray[np.float64] = self._at_rest @ np.asarray(basic, dtype=float)
            return linear
        points, _ = self._positions(basic)
        strokes: NDArray[np.float64] = _norms(points - self.pins) - self.rest_lengths
        return strokes

    def jacobian(self, basic: np.ndarray) -> NDArray[np.float64]:
        """``∂ d_actuator / ∂ d_basic`` at ``basic`` (``n_actuators × n_basic``)."""
        if self.geometry == 'linear':
            return self._at_rest
        return self._exact_jacobian(basic)

    def basic_displacement(self, actuator: np.ndarray) -> np.ndarray:
        """The basic displacement that produced the measured actuator strokes."""
        actuator = np.asarray(actuator, dtype=float)
        basic = np.linalg.solve(self._at_rest, actuator)
        if self.geometry == 'linear':
            return basic
        scale = 1.0 + float(np.max(np.abs(actuator)))
        for _ in range(self.NEWTON_ITERATIONS):
            residual = self.actuator_targets(basic) - actuator
            if float(np.max(np.abs(residual))) <= self.NEWTON_TOLERANCE * scale:
                return basic
            try:
                basic = basic - np.linalg.solve(self._exact_jacobian(basic), residual)
            except np.linalg.LinAlgError:
                break
            if not np.all(np.isfinite(basic)):
                break
        msg = (f'{self.name} setup: no basic displacement found for the measured strokes '
               f'{actuator.tolist()!r}')
        raise SetupError(msg)


def _positive(value: float, key: str, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
            math.isfinite(value) and value > 0.0):
        msg = f'{name} setup: {key} must be a positive number [m], got {value!r}'
        raise SetupError(msg)
    return float(value)


class ColumnSetup(PlanarActuators):
    """A column top (basic ``u, v``) with a horizontal and a vertical actuator, in this order.

    Args:
        horizontal_length: [m] the horizontal actuator's length at rest; pin at ``(−L_h, 0)``.
        vertical_length: [m] the vertical actuator's length at rest; pin at ``(0, L_v)``, so
            a positive (pushing) force pushes the top down (an axial load ``P`` is ``+P``).
        geometry: ``'nonlinear'`` (default, exact) or ``'linear'``.
    """

    def __init__(self, horizontal_length: float, vertical_length: float,
                 geometry: str = 'nonlinear') -> None:
        horizontal = _positive(horizontal_length, 'horizontal_length', 'column')
        vertical = _positive(vertical_length, 'vertical_length', 'column')
        super().__init__([(-horizontal, 0.0), (0.0, vertical)], [(0.0, 0.0), (0.0, 0.0)],
                         2, geometry, 'column')


class PlanarThreeActuators(PlanarActuators):
    """A loading beam (basic ``u, v, θ``): two vertical actuators at ``∓offset``, one horizontal.

    Args:
        offset: [m] half the distance between the vertical actuators along the beam (> 0).
        vertical_length: [m] the vertical actuators' length at rest (pins above them).
        horizontal_length: [m] the horizontal actuator's length at rest; pin at ``(−L_h, 0)``.
        geometry: ``'nonlinear'`` (default, exact) or ``'linear'``.
    """

    def __init__(self, offset: float, vertical_length: float, horizontal_length: float,
                 geometry: str = 'nonlinear') -> None:
        a = _positive(offset, 'offset', 'planar_3')
        vertical = _positive(vertical_length, 'vertical_length', 'planar_3')
        horizontal = _positive(horizontal_length, 'horizontal_length', 'planar_3')
        super().__init__([(-a, vertical), (a, vertical), (-horizontal, 0.0)],
                         [(-a, 0.0), (a, 0.0), (0.0, 0.0)], 3, geometry, 'planar_3')


SETUP_TYPES = ('one_to_one', 'rigid_link_2', 'planar', 'column', 'planar_3')

_ALLOWED = {
    'one_to_one': {'type'},
    'rigid_link_2': {'type', 'offsets', 'geometry', 'actuator_length'},
    'planar': {'type', 'basic', 'actuators', 'geometry'},
    'column': {'type', 'horizontal_length', 'vertical_length', 'geometry'},
    'planar_3': {'type', 'offset', 'vertical_length', 'horizontal_length', 'geometry'},
}
_BASIC_NAMES = (['u', 'v'], ['u', 'v', 'theta'])


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


def _length_key(raw: Mapping[str, Any], key: str, where: str) -> float:
    value: Any = raw.get(key)
    if not _is_number(value) or not (math.isfinite(value) and value > 0.0):
        msg = f'{where}.{key}: must be a positive number [m], got {value!r}'
        raise SetupError(msg)
    return float(value)


def _geometry_key(raw: Mapping[str, Any], where: str, default: str) -> str:
    geometry = raw.get('geometry', default)
    if geometry not in GEOMETRIES:
        msg = f"{where}.geometry: must be 'linear' or 'nonlinear', got {geometry!r}"
        raise SetupError(msg)
    return str(geometry)


def _point_key(value: Any, where: str) -> tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2 or not all(
            _is_number(v) and math.isfinite(v) for v in value):
        msg = f'{where}: must be a point [x, y] of two finite numbers [m], got {value!r}'
        raise SetupError(msg)
    return float(value[0]), float(value[1])


def _dof_count(kind: str, n_basic: int, needed: int, names: str, where: str) -> None:
    if n_basic != needed:
        msg = (f'{where}: a {kind} setup needs an element with {needed} DOFs ({names}), '
               f'got {n_basic}')
        raise SetupError(msg)


def _planar_from_config(raw: Mapping[str, Any], n_basic: int, where: str) -> PlanarActuators:
    basic = raw.get('basic')
    if not isinstance(basic, list) or basic not in _BASIC_NAMES:
        msg = f'{where}.basic: must be [u, v] or [u, v, theta], got {basic!r}'
        raise SetupError(msg)
    _dof_count('planar', n_basic, len(basic), ', '.join(basic), where)
    actuators = raw.get('actuators')
    if not isinstance(actuators, list) or len(actuators) != len(basic):
        msg = (f'{where}.actuators: must be a list of {len(basic)} actuators '
               f'{{pin: [x, y], attach: [x, y]}} (one per basic DOF), got {actuators!r}')
        raise SetupError(msg)
    pins, attachments = [], []
    for index, actuator in enumerate(actuators):
        here = f'{where}.actuators[{index}]'
        if not isinstance(actuator, Mapping):
            msg = f'{here}: must be a mapping {{pin: [x, y], attach: [x, y]}}, got {actuator!r}'
            raise SetupError(msg)
        unknown = sorted(str(key) for key in set(actuator) - {'pin', 'attach'})
        if unknown:
            msg = f'{here}.{unknown[0]}: unknown key of an actuator (pin, attach)'
            raise SetupError(msg)
        pins.append(_point_key(actuator.get('pin'), f'{here}.pin'))
        attachments.append(_point_key(actuator.get('attach'), f'{here}.attach'))
    return PlanarActuators(pins, attachments, len(basic), _geometry_key(raw, where, 'nonlinear'))


def _rigid_link_from_config(raw: Mapping[str, Any]) -> RigidLinkTwoActuators:
    offsets = raw.get('offsets')
    if not isinstance(offsets, (list, tuple)) or not all(_is_number(v) for v in offsets):
        msg = f'offsets: must be a list of two numbers [m], got {offsets!r}'
        raise SetupError(msg)
    length = raw.get('actuator_length')
    if length is not None and not _is_number(length):
        msg = f'actuator_length: must be a number [m], got {length!r}'
        raise SetupError(msg)
    return RigidLinkTwoActuators(offsets, str(raw.get('geometry', 'linear')),
                                 None if length is None else float(length))


def setup_from_config(raw: Any, n_basic: int, where: str) -> ExperimentalSetup:
    """Build a setup from a test file's ``setup`` mapping (``None``: one-to-one).

    Keys by ``type``: ``rigid_link_2`` — ``offsets``, ``geometry``, ``actuator_length``;
    ``column`` — ``horizontal_length``, ``vertical_length``, ``geometry``; ``planar_3`` —
    ``offset``, ``vertical_length``, ``horizontal_length``, ``geometry``; ``planar`` —
    ``basic`` (``[u, v]`` or ``[u, v, theta]``), ``actuators`` (``[{pin: [x, y],
    attach: [x, y]}, …]``), ``geometry``. The planar types default to the nonlinear geometry.

    Raises:
        SetupError: one line naming ``where`` (e.g. ``test.yaml: structure.elements[0].setup``).
    """
    if raw is None:
        raw = {'type': 'one_to_one'}
    if isinstance(raw, str):
        raw = {'type': raw}
    if not isinstance(raw, Mapping):
        msg = f'{where}: must be a mapping with a type, got {raw!r}'
        raise SetupError(msg)
    kind = raw.get('type', 'one_to_one')
    if kind not in _ALLOWED:
        msg = f'{where}.type: must be one of {", ".join(SETUP_TYPES)}, got {kind!r}'
        raise SetupError(msg)
    unknown = sorted(str(key) for key in set(raw) - _ALLOWED[kind])
    if unknown:
        msg = f'{where}.{unknown[0]}: unknown parameter for a {kind} setup'
        raise SetupError(msg)
    try:
        if kind == 'one_to_one':
            return OneToOneSetup(n_basic)
        if kind == 'rigid_link_2':
            if n_basic != 2:
                msg = f'needs an element with 2 DOFs (translation, rotation), got {n_basic}'
                raise SetupError(msg)
            return _rigid_link_from_config(raw)
        if kind == 'planar':
            return _planar_from_config(raw, n_basic, where)
        if kind == 'column':
            _dof_count(kind, n_basic, 2, 'u, v', where)
            return ColumnSetup(_length_key(raw, 'horizontal_length', where),
                               _length_key(raw, 'vertical_length', where),
                               _geometry_key(raw, where, 'nonlinear'))
        _dof_count(kind, n_basic, 3, 'u, v, theta', where)
        return PlanarThreeActuators(_length_key(raw, 'offset', where),
                                    _length_key(raw, 'vertical_length', where),
                                    _length_key(raw, 'horizontal_length', where),
                                    _geometry_key(raw, where, 'nonlinear'))
    except SetupError as err:
        text = str(err)
        if text.startswith(f'{where}'):
            raise
        for prefix in (f'{name} setup: ' for name in SETUP_TYPES):
            text = text.removeprefix(prefix)
        msg = f'{where}: {text}'
        raise SetupError(msg) from None
